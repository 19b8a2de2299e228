from ergopose import keypoints as kp


def test_schema_is_blazepose_order():
    assert kp.NUM_JOINTS == 33
    # Landmark indices published with BlazePose (pose_landmark topology).
    assert kp.JOINT_INDEX["left_shoulder"] == 11
    assert kp.JOINT_INDEX["right_hip"] == 24
    assert kp.JOINT_INDEX["right_foot_index"] == 32


def test_coco_mapping_against_the_published_orders():
    # Written out by hand from the two published orders (COCO keypoint annotations: nose, eyes,
    # ears, shoulders, elbows, wrists, hips, knees, ankles, left before right; BlazePose's
    # pose_landmark topology 0-32), not derived from the module's own tables.
    assert kp.COCO17[0] == "nose" and kp.COCO17[5] == "left_shoulder" and kp.COCO17[16] == "right_ankle"
    assert kp.COCO17_TO_BLAZEPOSE33.tolist() == [0, 2, 5, 7, 8, 11, 12, 13, 14, 15, 16, 23, 24, 25, 26, 27, 28]
