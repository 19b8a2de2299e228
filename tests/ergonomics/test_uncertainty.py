"""The confidence of a frame and the cause given when it is not confident (ergopose.ergonomics.
uncertainty.frame_confidence): one frame per case, worked out by hand from the module's rules --
confident when both scores' probabilities reach CONFIDENT_P and no joint the scores need was held
at a joint limit; the cause of a frame held back only by the limit is joint limit, of the others
the first of not seen, one camera, occluded limbs, joint limit that applies, else uncertain
angles; nothing for a confident frame."""

from __future__ import annotations

import numpy as np

from ergopose.ergonomics.uncertainty import CAUSES, CONFIDENT_P, LIMITED_SCORED_JOINTS, frame_confidence, held_parts
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS

LOW = CONFIDENT_P - 0.1
HIGH = CONFIDENT_P + 0.1


def test_each_cause_in_its_order():
    # (rula p, reba p, most cameras, inferred joint, limited joint) -> (confidence, cause)
    cases = [
        ((HIGH, HIGH, 2, None, None), ("confident", "")),
        ((HIGH, HIGH, 2, None, "left_hip"), ("confident", "")),  # no limit holds a hip
        ((HIGH, HIGH, 2, None, "left_knee"), ("low", "joint limit")),  # a held joint is never confident
        ((HIGH, HIGH, 2, "left_wrist", "left_knee"), ("low", "joint limit")),  # the limit is why
        ((HIGH, HIGH, 1, None, "nose"), ("low", "joint limit")),
        ((HIGH, LOW, 2, "left_wrist", "left_knee"), ("low", "occluded limbs")),  # unsure anyway: first cause
        ((np.nan, HIGH, 0, "left_knee", "left_knee"), ("unscored", "not seen")),
        ((LOW, HIGH, 1, "left_knee", "left_knee"), ("low", "one camera")),
        ((HIGH, LOW, 2, "left_wrist", "right_elbow"), ("low", "occluded limbs")),
        ((LOW, LOW, 2, None, "right_knee"), ("low", "joint limit")),
        ((LOW, HIGH, 2, None, "nose"), ("low", "joint limit")),
        ((LOW, HIGH, 2, None, "left_elbow"), ("low", "joint limit")),
        ((LOW, HIGH, 2, None, "left_hip"), ("low", "uncertain angles")),  # no limit holds a hip
        ((LOW, HIGH, 2, "left_foot_index", None), ("low", "uncertain angles")),  # a joint no score needs
        ((LOW, HIGH, 2, None, None), ("low", "uncertain angles")),
    ]
    n = len(cases)
    rula, reba, seen = (np.array([c[0][k] for c in cases], float) for k in range(3))
    inferred = np.zeros((n, NUM_JOINTS), bool)
    limited = np.zeros((n, NUM_JOINTS), bool)
    for i, ((_, _, _, inf, lim), _) in enumerate(cases):
        if inf:
            inferred[i, JOINT_INDEX[inf]] = True
        if lim:
            limited[i, JOINT_INDEX[lim]] = True
    conf, cause = frame_confidence(rula, reba, None, inferred, seen.astype(int), limited)
    assert list(zip(conf, cause)) == [c[1] for c in cases]
    # without limit flags (results of a tracks table before them) those frames are uncertain angles
    conf, cause = frame_confidence(rula, reba, None, inferred, seen.astype(int))
    assert "joint limit" not in set(cause) and list(cause[9:12]) == ["uncertain angles"] * 3
    assert conf[2] == "confident" and cause[2] == ""
    assert CAUSES.index("occluded limbs") < CAUSES.index("joint limit") < CAUSES.index("uncertain angles")
    names = {n for n, j in JOINT_INDEX.items() if j in set(LIMITED_SCORED_JOINTS.tolist())}
    assert names == {"nose", "left_eye", "right_eye", "left_elbow", "right_elbow", "left_knee", "right_knee"}


def test_the_parts_held_at_a_limit_are_named_per_frame():
    """held_parts: the body parts of the held joints, in the summaries' order, joined by ";"; a
    joint no limit holds (a hip) names nothing."""
    held = [(), ("right_knee",), ("left_eye", "left_knee", "right_elbow"), ("left_hip",), ("nose", "left_elbow")]
    limited = np.zeros((len(held), NUM_JOINTS), bool)
    for i, joints in enumerate(held):
        limited[i, [JOINT_INDEX[j] for j in joints]] = True
    assert held_parts(limited, len(held)).tolist() == [
        "",
        "legs",
        "neck;right lower arm;legs",
        "",
        "neck;left lower arm",
    ]
    assert held_parts(None, 2).tolist() == ["", ""]


def test_each_body_parts_joints_are_those_its_angles_are_measured_from():
    """Every joint an INPUT_GROUPS entry names (the inputs table's "inferred" share, the scored
    joints of "occluded limbs") is one its angles use: without it, at least one of them is NaN; and
    the face points, which no angle uses since the neck is measured from the ears, are named by
    no part and are not scored joints."""
    from ergopose.ergonomics.angles import joint_angles
    from ergopose.ergonomics.body import BodyMeasurements, Posture, place_on_floor, pose_skeleton
    from ergopose.ergonomics.uncertainty import INPUT_GROUPS, SCORED_JOINTS

    m = BodyMeasurements.from_stature(1.75)
    n = 3
    posture = Posture(
        neck_flexion=np.radians(np.full(n, 15.0)),
        left_elbow_flexion=np.radians(np.full(n, 60.0)),
        right_elbow_flexion=np.radians(np.full(n, 60.0)),
    )
    pts = pose_skeleton(m, place_on_floor(m, posture))
    for part, angles, joints in INPUT_GROUPS:
        for joint in joints:
            holed = pts.copy()
            holed[:, JOINT_INDEX[joint]] = np.nan
            got = joint_angles(holed).to_frame()
            assert any(np.isnan(got[a]).all() for a in angles), (part, joint)
    face = {"nose", "left_eye", "right_eye", "mouth_left", "mouth_right"}
    assert not face & {j for _, _, joints in INPUT_GROUPS for j in joints}
    assert not {JOINT_INDEX[j] for j in face} & set(SCORED_JOINTS.tolist())
