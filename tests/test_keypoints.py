from ergopose import keypoints as kp


def test_schema_is_blazepose_order():
    assert kp.NUM_JOINTS == 33
    # Landmark indices published with BlazePose (pose_landmark topology).
    assert kp.JOINT_INDEX["left_shoulder"] == 11
    assert kp.JOINT_INDEX["right_hip"] == 24
    assert kp.JOINT_INDEX["right_foot_index"] == 32


def test_coco_mapping_names_match():
    for coco_i, bp_i in enumerate(kp.COCO17_TO_BLAZEPOSE33):
        assert kp.COCO17[coco_i] == kp.BLAZEPOSE33[bp_i]
