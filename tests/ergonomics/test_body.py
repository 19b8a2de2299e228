"""The posable body model: anthropometry, forward kinematics, placement on the floor.

Known answers: Winter's (2009, Fig. 4.1) landmark heights for the neutral standing body; bone lengths
that must not change with posture; segment orientations recomposed with scipy's Rotation (an
independent rotation implementation); the physical direction each positive angle moves a point.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ergopose.errors import ConfigError
from ergopose.ergonomics import body
from ergopose.ergonomics.body import (
    ANGLE_FIELDS,
    FACE_POINTS_IN_HEAD,
    BodyMeasurements,
    Posture,
    flat_foot_ankle,
    place_on_floor,
    pose_skeleton,
)
from ergopose.keypoints import JOINT_INDEX

D = math.radians
STATURES = (1.55, 1.75, 1.95)


def P(points: np.ndarray, name: str) -> np.ndarray:
    return points[..., JOINT_INDEX[name], :]


def random_posture(rng: np.random.Generator, n: int) -> Posture:
    """Any angles in wide ranges (the model itself has no well-posedness limits)."""
    kw = {name: rng.uniform(-1.5, 1.5, n) for name in ANGLE_FIELDS}
    kw["heading"] = rng.uniform(-np.pi, np.pi, n)
    kw["root_position"] = np.c_[rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), rng.uniform(0, 1, n)]
    return Posture(**kw)


# ---------------------------------------------------------------- anthropometry


@pytest.mark.parametrize("stature", STATURES)
def test_lengths_are_winter_fractions_of_stature(stature):
    m = BodyMeasurements.from_stature(stature)
    assert m.upper_arm_length == pytest.approx(0.186 * stature)
    assert m.forearm_length == pytest.approx(0.146 * stature)
    assert m.hand_length == pytest.approx(0.108 * stature)
    assert m.thigh_length == pytest.approx(0.245 * stature)
    assert m.shank_length == pytest.approx(0.246 * stature)
    assert m.foot_length == pytest.approx(0.152 * stature)
    assert m.shoulder_width == pytest.approx(0.259 * stature)
    assert m.hip_width == pytest.approx(0.191 * stature)
    assert m.trunk_length == pytest.approx((0.818 - 0.530) * stature)


def test_overrides_and_validation():
    m = BodyMeasurements.from_stature(1.80, shoulder_width=0.40)
    assert m.shoulder_width == 0.40 and m.stature == 1.80
    with pytest.raises(ConfigError, match="stature"):
        BodyMeasurements.from_stature(1.30)
    with pytest.raises(ConfigError, match="stature"):
        BodyMeasurements.from_stature(2.10)
    with pytest.raises(ConfigError, match="forearm"):
        BodyMeasurements.from_stature(1.70, forearm=0.3)
    with pytest.raises(ConfigError, match="thigh_length"):
        BodyMeasurements.from_stature(1.70, thigh_length=-0.1)
    with pytest.raises(ConfigError, match="heel_offset"):
        BodyMeasurements.from_stature(1.70, heel_offset=0.5)


@pytest.mark.parametrize("stature", STATURES)
def test_neutral_standing_landmark_heights_match_winter(stature):
    """Winter Fig. 4.1: shoulder 0.818H, elbow 0.630H, wrist 0.485H, hip 0.530H, knee 0.285H, ankle 0.039H, eye 0.936H."""
    m = BodyMeasurements.from_stature(stature)
    pts = pose_skeleton(m, place_on_floor(m, Posture()))
    expected = {"shoulder": 0.818, "elbow": 0.630, "wrist": 0.485, "hip": 0.530, "knee": 0.285, "ankle": 0.039}
    for joint, frac in expected.items():
        for side in ("left", "right"):
            # elbow and wrist follow from the segment lengths (0.818 - 0.186 = 0.632, - 0.146 = 0.486)
            assert P(pts, f"{side}_{joint}")[2] == pytest.approx(frac * stature, abs=0.003 * stature), joint
    assert P(pts, "left_eye")[2] == pytest.approx(0.936 * stature, abs=0.002 * stature)
    for side in ("left", "right"):
        assert P(pts, f"{side}_heel")[2] == pytest.approx(0.0, abs=1e-12)
        assert P(pts, f"{side}_foot_index")[2] == pytest.approx(0.0, abs=1e-12)
    # Left is +y when facing +x (heading 0); hands hang beside the hips, thumbs forward.
    assert P(pts, "left_shoulder")[1] > 0 > P(pts, "right_shoulder")[1]
    assert P(pts, "nose")[0] > P(pts, "left_ear")[0]
    for side in ("left", "right"):
        assert P(pts, f"{side}_thumb")[0] > P(pts, f"{side}_wrist")[0]
        assert P(pts, f"{side}_index")[0] > P(pts, f"{side}_pinky")[0]
    m_hip = 0.5 * (P(pts, "left_hip") + P(pts, "right_hip"))
    assert m_hip[2] == pytest.approx(m.standing_hip_height)


# ---------------------------------------------------------------- forward kinematics


def test_bone_lengths_and_rigid_parts_do_not_depend_on_posture(rng):
    m = BodyMeasurements.from_stature(1.72)
    pts = pose_skeleton(m, random_posture(rng, 500))
    neutral = pose_skeleton(m, Posture())

    def dist(points, a, b):
        return np.linalg.norm(P(points, a) - P(points, b), axis=-1)

    for side in ("left", "right"):
        for a, b, length in [
            ("shoulder", "elbow", m.upper_arm_length),
            ("elbow", "wrist", m.forearm_length),
            ("hip", "knee", m.thigh_length),
            ("knee", "ankle", m.shank_length),
        ]:
            np.testing.assert_allclose(dist(pts, f"{side}_{a}", f"{side}_{b}"), length, rtol=1e-12)
        for a, b in [
            ("wrist", "index"),
            ("wrist", "pinky"),
            ("index", "thumb"),
            ("ankle", "heel"),
            ("heel", "foot_index"),
        ]:
            np.testing.assert_allclose(
                dist(pts, f"{side}_{a}", f"{side}_{b}"), dist(neutral, f"{side}_{a}", f"{side}_{b}"), rtol=1e-12
            )
    face = list(FACE_POINTS_IN_HEAD)
    for i, a in enumerate(face):
        for b in face[i + 1 :]:
            np.testing.assert_allclose(dist(pts, a, b), dist(neutral, a, b), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(dist(pts, "left_hip", "right_hip"), m.hip_width, rtol=1e-12)


def _scipy(seq: str, angles) -> Rotation:
    return Rotation.from_euler(seq, np.stack([np.asarray(a, dtype=float) for a in angles], axis=-1))


def test_segment_orientations_match_scipy_composition(rng):
    """Recompose every segment with scipy (intrinsic 'YXZ' = Ry Rx Rz) and compare the points."""
    n = 300
    m = BodyMeasurements.from_stature(1.84)
    posture = random_posture(rng, n)
    g = posture.__getattribute__
    pts = pose_skeleton(m, posture)
    world = Rotation.from_euler("z", g("heading")[:, None])
    root = g("root_position")
    mid_hip = 0.5 * (P(pts, "left_hip") + P(pts, "right_hip"))
    np.testing.assert_allclose(mid_hip, root, atol=1e-12)
    trunk = world * _scipy("YXZ", [g("trunk_flexion"), g("trunk_side_bend"), g("trunk_twist")])
    neck_base = root + trunk.apply([0, 0, m.trunk_length])
    head = trunk * _scipy("YXZ", [g("neck_flexion"), g("neck_side_bend"), g("neck_twist")])
    for name in ("nose", "left_ear", "right_eye_outer", "mouth_left"):
        np.testing.assert_allclose(
            P(pts, name), neck_base + head.apply(np.array(FACE_POINTS_IN_HEAD[name]) * m.head_height), atol=1e-12
        )
    w = m.shoulder_width / 2
    for side, s in (("left", 1.0), ("right", -1.0)):
        elev = g(f"{side}_shoulder_elevation")
        shoulder = neck_base + trunk.apply(np.stack([np.zeros(n), np.full(n, s * w), w * np.tan(elev)], -1))
        np.testing.assert_allclose(P(pts, f"{side}_shoulder"), shoulder, atol=1e-12)
        arm = trunk * _scipy(
            "YXZ",
            [
                -g(f"{side}_upper_arm_flexion"),
                s * g(f"{side}_upper_arm_abduction"),
                -s * g(f"{side}_upper_arm_rotation"),
            ],
        )
        elbow = shoulder + arm.apply([0, 0, -m.upper_arm_length])
        np.testing.assert_allclose(P(pts, f"{side}_elbow"), elbow, atol=1e-12)
        forearm = arm * _scipy("YZ", [-g(f"{side}_elbow_flexion"), -s * g(f"{side}_forearm_rotation")])
        wrist = elbow + forearm.apply([0, 0, -m.forearm_length])
        np.testing.assert_allclose(P(pts, f"{side}_wrist"), wrist, atol=1e-12)
        hand = forearm * _scipy("YX", [-g(f"{side}_wrist_deviation"), -s * g(f"{side}_wrist_flexion")])
        x, y, z = body.HAND_POINTS_IN_HAND["index"]
        np.testing.assert_allclose(
            P(pts, f"{side}_index"), wrist + hand.apply(np.array([x, s * y, z]) * m.hand_length), atol=1e-12
        )
        hip = root + world.apply([0, s * m.hip_width / 2, 0])
        thigh = world * _scipy("YX", [-g(f"{side}_hip_flexion"), s * g(f"{side}_hip_abduction")])
        knee = hip + thigh.apply([0, 0, -m.thigh_length])
        np.testing.assert_allclose(P(pts, f"{side}_knee"), knee, atol=1e-12)
        shank = thigh * Rotation.from_euler("Y", g(f"{side}_knee_flexion")[:, None])
        ankle = knee + shank.apply([0, 0, -m.shank_length])
        np.testing.assert_allclose(P(pts, f"{side}_ankle"), ankle, atol=1e-12)
        foot = shank * Rotation.from_euler("Y", -g(f"{side}_ankle_flexion")[:, None])
        toe = ankle + foot.apply([m.foot_length - m.heel_offset, 0, -m.ankle_height])
        np.testing.assert_allclose(P(pts, f"{side}_foot_index"), toe, atol=1e-12)


def _moved(field: str, value_deg: float, point: str, stature: float = 1.75, **base) -> np.ndarray:
    """How a point moves (world, heading 0: x forward, y left, z up) when one angle goes from 0 to value."""
    m = BodyMeasurements.from_stature(stature)
    before = pose_skeleton(m, Posture(**base))
    after = pose_skeleton(m, Posture(**{**base, field: D(value_deg)}))
    return P(after, point) - P(before, point)


def test_positive_angles_move_points_the_documented_way():
    # Trunk: flexion forward, side bend to the right (-y), twist turns the left shoulder backward.
    assert _moved("trunk_flexion", 30, "nose")[0] > 0.2
    assert _moved("trunk_flexion", -20, "nose")[0] < -0.1
    assert _moved("trunk_side_bend", 20, "nose")[1] < -0.1
    assert _moved("trunk_twist", 30, "left_shoulder")[0] < -0.05
    assert _moved("trunk_twist", 30, "right_shoulder")[0] > 0.05
    # Neck: flexion brings the nose down, side bend tilts the head to the right, twist looks left.
    d = _moved("neck_flexion", 30, "nose")
    assert d[2] < -0.02
    assert _moved("neck_side_bend", 20, "left_ear")[1] < -0.01
    assert _moved("neck_twist", 40, "nose")[1] > 0.05
    # Shoulder elevation raises the shoulder only.
    d = _moved("left_shoulder_elevation", 20, "left_shoulder")
    assert d[2] > 0.03 and abs(d[0]) < 1e-12 and abs(d[1]) < 1e-12
    assert np.allclose(_moved("left_shoulder_elevation", 20, "right_shoulder"), 0)
    # Upper arm: flexion forward, abduction to the arm's own side, internal rotation turns the bent
    # forearm toward the belly.
    assert _moved("left_upper_arm_flexion", 90, "left_elbow")[0] > 0.3
    assert _moved("right_upper_arm_flexion", -40, "right_elbow")[0] < -0.1
    assert _moved("left_upper_arm_abduction", 60, "left_elbow")[1] > 0.2
    assert _moved("right_upper_arm_abduction", 60, "right_elbow")[1] < -0.2
    assert _moved("left_upper_arm_rotation", 60, "left_wrist", left_elbow_flexion=D(90))[1] < -0.1
    assert _moved("right_upper_arm_rotation", 60, "right_wrist", right_elbow_flexion=D(90))[1] > 0.1
    # Elbow flexion brings the wrist forward and up.
    d = _moved("left_elbow_flexion", 90, "left_wrist")
    assert d[0] > 0.2 and d[2] > 0.2
    # Forearm pronation turns the thumb (forward in the neutral mid position) toward the body.
    assert _moved("left_forearm_rotation", 80, "left_thumb")[1] < -0.02
    assert _moved("right_forearm_rotation", 80, "right_thumb")[1] > 0.02
    # Wrist: the palm faces the thigh with the arm hanging, so flexion moves the fingers medially;
    # radial deviation moves them toward the thumb (forward).
    assert _moved("left_wrist_flexion", 40, "left_index")[1] < -0.03
    assert _moved("right_wrist_flexion", 40, "right_index")[1] > 0.03
    assert _moved("left_wrist_deviation", 20, "left_index")[0] > 0.02
    assert _moved("right_wrist_deviation", 20, "right_pinky")[0] > 0.02
    # Legs: hip flexion swings the knee forward, abduction to its own side, knee flexion folds the
    # shank backward, dorsiflexion lifts the toes.
    assert _moved("left_hip_flexion", 90, "left_knee")[0] > 0.3
    assert _moved("right_hip_abduction", 30, "right_ankle")[1] < -0.2
    assert _moved("left_knee_flexion", 90, "left_ankle")[0] < -0.3
    assert _moved("left_ankle_flexion", 20, "left_foot_index")[2] > 0.03


def test_heading_turns_the_body_about_the_vertical():
    m = BodyMeasurements.from_stature(1.70)
    east = pose_skeleton(m, Posture(heading=0.0, root_position=np.array([1.0, 2.0, 0.9])))
    north = pose_skeleton(m, Posture(heading=D(90), root_position=np.array([1.0, 2.0, 0.9])))
    assert P(north, "nose")[1] - 2.0 == pytest.approx(P(east, "nose")[0] - 1.0)
    assert P(north, "left_shoulder")[0] - 1.0 == pytest.approx(-(P(east, "left_shoulder")[1] - 2.0))
    np.testing.assert_allclose(north[:, 2], east[:, 2])


def test_broadcasting_and_blocks_agree_with_single_frames(rng):
    m = BodyMeasurements.from_stature(1.66)
    n = body.CHUNK_FRAMES + 7  # crosses a block boundary
    posture = random_posture(rng, n)
    pts = pose_skeleton(m, posture)
    assert pts.shape == (n, 33, 3)
    for i in (0, body.CHUNK_FRAMES - 1, body.CHUNK_FRAMES, n - 1):
        single = Posture(**{f: np.asarray(getattr(posture, f))[i] for f in posture.__dataclass_fields__})
        one = pose_skeleton(m, single)
        assert one.shape == (33, 3)
        np.testing.assert_allclose(one, pts[i], atol=1e-12)
    grid = pose_skeleton(m, Posture(trunk_flexion=np.zeros((2, 1)), left_elbow_flexion=np.zeros((1, 3))))
    assert grid.shape == (2, 3, 33, 3)


def test_place_on_floor_puts_the_lowest_foot_point_at_zero(rng):
    m = BodyMeasurements.from_stature(1.90)
    posture = place_on_floor(m, random_posture(rng, 400))
    pts = pose_skeleton(m, posture)
    feet = [JOINT_INDEX[f"{s}_{p}"] for s in ("left", "right") for p in ("ankle", "heel", "foot_index")]
    np.testing.assert_allclose(pts[:, feet, 2].min(axis=1), 0.0, atol=1e-12)
    standing = place_on_floor(m, Posture(root_position=np.array([0.5, -1.0, 3.0])))
    np.testing.assert_allclose(standing.root_position, [0.5, -1.0, m.standing_hip_height])


def test_flat_foot_ankle_keeps_the_sole_level(rng):
    m = BodyMeasurements.from_stature(1.75)
    hip, knee = rng.uniform(-0.3, 2.0, 50), rng.uniform(0, 2.4, 50)
    pts = pose_skeleton(
        m, Posture(left_hip_flexion=hip, left_knee_flexion=knee, left_ankle_flexion=flat_foot_ankle(hip, knee))
    )
    np.testing.assert_allclose(P(pts, "left_heel")[:, 2], P(pts, "left_foot_index")[:, 2], atol=1e-12)
