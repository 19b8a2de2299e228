"""Joint angles and stance flags from 3D joints.

Known answers: (1) skeletons posed by the body model with known angles (its chain is checked against
scipy's rotations in test_body.py) across each angle's range, headings, positions and statures;
(2) hand-built stick figures whose angles follow from plain trigonometry, for every sign convention;
(3) constructed stance sequences; (4) the real Pose2Sim recording in ../shared/data.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from ergopose.errors import ConfigError, InputError
from ergopose.ergonomics import angles as angles_mod
from ergopose.ergonomics.angles import (
    DIAGNOSTIC_COLUMNS,
    FLAG_COLUMNS,
    MEASURED_COLUMNS,
    POSTURE_TABLE_COLUMNS,
    AngleSettings,
    joint_angles,
)
from ergopose.ergonomics.posture import check_columns, validate_values
from ergopose.ergonomics.body import BodyMeasurements, Posture, flat_foot_ankle, place_on_floor, pose_skeleton
from ergopose.keypoints import JOINT_INDEX

D = math.radians
SIDES = ("left", "right")

#: Where every definition is well posed (docs/joint-angles.md, "Ambiguities"): recovery is tested
#: over these ranges, all angles varied at once. Upper-arm abduction stops short of 90 deg, where the
#: flexion plane is undefined; upper-arm rotation is only defined with a bent elbow.
RANGES_DEG = {
    "trunk_flexion": (-30, 110),
    "trunk_side_bend": (-30, 30),
    "trunk_twist": (-45, 45),
    "neck_flexion": (-45, 60),
    "neck_side_bend": (-35, 35),
    "neck_twist": (-70, 70),
    "upper_arm_flexion": (-60, 180),
    "upper_arm_abduction": (-30, 80),
    "upper_arm_rotation": (-80, 80),
    "elbow_flexion": (0, 150),
    "forearm_rotation": (-90, 90),
    "wrist_flexion": (-70, 70),
    "wrist_deviation": (-25, 35),
    "shoulder_elevation": (-10, 30),
    "hip_flexion": (-20, 120),
    "hip_abduction": (-20, 45),
    "knee_flexion": (0, 150),
    "ankle_flexion": (-30, 30),
}
PER_SIDE = (
    "upper_arm_flexion",
    "upper_arm_abduction",
    "upper_arm_rotation",
    "elbow_flexion",
    "forearm_rotation",
    "wrist_flexion",
    "wrist_deviation",
    "shoulder_elevation",
    "hip_flexion",
    "hip_abduction",
    "knee_flexion",
    "ankle_flexion",
)
NOT_MEASURED = ("forearm_rotation", "ankle_flexion")  # posable, but not part of the posture table


def random_postures(rng: np.random.Generator, n: int) -> Posture:
    kw = {}
    for name, (lo, hi) in RANGES_DEG.items():
        names = [f"{s}_{name}" for s in SIDES] if name in PER_SIDE else [name]
        for full in names:
            kw[full] = np.radians(rng.uniform(lo, hi, n))
    kw["heading"] = rng.uniform(-np.pi, np.pi, n)
    kw["root_position"] = np.c_[rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), np.zeros(n)]
    return Posture(**kw)


def angle_error_deg(measured, true):
    """Smallest angular difference in degrees (wraps at 360)."""
    return np.degrees(np.abs(np.angle(np.exp(1j * (np.asarray(measured) - np.asarray(true))))))


# ---------------------------------------------------------------- recovery from posed skeletons


@pytest.mark.parametrize("stature", [1.55, 1.75, 1.95])
def test_recovers_every_posed_angle(rng, stature):
    n = 4000
    m = BodyMeasurements.from_stature(stature)
    posture = place_on_floor(m, random_postures(rng, n))
    pts = pose_skeleton(m, posture)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = joint_angles(pts, np.arange(n) / 12.0, AngleSettings(trunk_length_m=m.trunk_length))
    checked = 0
    for name in RANGES_DEG:
        if name in NOT_MEASURED:
            continue
        for full in [f"{s}_{name}" for s in SIDES] if name in PER_SIDE else [name]:
            true = getattr(posture, full)
            got = getattr(result, full)
            if name == "upper_arm_rotation":
                bent = getattr(posture, full.replace("upper_arm_rotation", "elbow_flexion")) >= D(20)
                assert np.all(np.isnan(got[~bent]))
                got, true = got[bent], true[bent]
            assert np.all(np.isfinite(got)), full
            err = angle_error_deg(got, true)
            assert err.max() < 0.5, f"{full}: max error {err.max():.3g} deg"
            checked += 1
    assert checked == 3 + 3 + 2 * 10
    # Upper-arm flexion is reported in [-90, 180] deg: overhead stays flexion, never "-179".
    for s in SIDES:
        np.testing.assert_allclose(
            getattr(result, f"{s}_upper_arm_flexion"), getattr(posture, f"{s}_upper_arm_flexion"), atol=D(0.5)
        )


def test_shoulder_reference_defaults_to_the_sequence_median(rng):
    """Relaxed shoulders most of the time: the median of the shoulder heights is the reference."""
    n = 600
    m = BodyMeasurements.from_stature(1.70)
    elev = np.where(rng.uniform(size=n) < 0.3, D(20), 0.0)
    elev_r = np.where(rng.uniform(size=n) < 0.2, D(-8), 0.0)
    posture = random_postures(rng, n).replace(left_shoulder_elevation=elev, right_shoulder_elevation=elev_r)
    result = joint_angles(pose_skeleton(m, place_on_floor(m, posture)))
    assert angle_error_deg(result.left_shoulder_elevation, elev).max() < 0.5
    assert angle_error_deg(result.right_shoulder_elevation, elev_r).max() < 0.5


def test_neck_neutral_offset_shifts_neck_flexion():
    m = BodyMeasurements.from_stature(1.80)
    pts = pose_skeleton(m, Posture(neck_flexion=np.radians([-20.0, 0.0, 35.0])))
    plain = joint_angles(pts)
    shifted = joint_angles(pts, settings=AngleSettings(neck_neutral_offset=D(8)))
    np.testing.assert_allclose(plain.neck_flexion, np.radians([-20.0, 0.0, 35.0]), atol=1e-12)
    np.testing.assert_allclose(shifted.neck_flexion, plain.neck_flexion - D(8), atol=1e-12)


# ---------------------------------------------------------------- sign conventions on stick figures


def stick_figure() -> np.ndarray:
    """An upright figure facing +x (left = +y) with explicit coordinates, arms hanging, thumbs forward."""
    pts = np.full((33, 3), np.nan)

    def put(name, xyz):
        pts[JOINT_INDEX[name]] = xyz

    for s, y in (("left", 1.0), ("right", -1.0)):
        put(f"{s}_hip", (0, 0.10 * y, 0.90))
        put(f"{s}_shoulder", (0, 0.20 * y, 1.40))
        put(f"{s}_ear", (0, 0.07 * y, 1.60))
        put(f"{s}_eye", (0.09, 0.03 * y, 1.60))
        put(f"{s}_elbow", (0, 0.20 * y, 1.10))
        put(f"{s}_wrist", (0, 0.20 * y, 0.85))
        put(f"{s}_index", (0.03, 0.20 * y, 0.75))
        put(f"{s}_pinky", (-0.03, 0.20 * y, 0.75))
        put(f"{s}_thumb", (0.05, 0.19 * y, 0.78))
        put(f"{s}_knee", (0, 0.10 * y, 0.50))
        put(f"{s}_ankle", (0, 0.10 * y, 0.08))
        put(f"{s}_heel", (-0.05, 0.10 * y, 0.0))
        put(f"{s}_foot_index", (0.18, 0.10 * y, 0.0))
    put("nose", (0.09, 0.0, 1.60))
    return pts


def measure(pts: np.ndarray, **settings) -> dict[str, float]:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        frame = joint_angles(pts[None], settings=AngleSettings(**settings)).to_frame(diagnostics=True)
    return frame.iloc[0].to_dict()


def deg(row: dict, name: str) -> float:
    return math.degrees(row[name])


def set_point(pts, name, xyz):
    pts[JOINT_INDEX[name]] = xyz


def get_point(pts, name):
    return pts[JOINT_INDEX[name]].copy()


def test_upright_stick_figure_reads_neutral():
    row = measure(stick_figure())
    for name in (
        "trunk_flexion",
        "trunk_side_bend",
        "trunk_twist",
        "neck_flexion",
        "neck_side_bend",
        "neck_twist",
        "left_upper_arm_flexion",
        "right_upper_arm_abduction",
        "left_elbow_flexion",
        "right_wrist_flexion",
        "left_wrist_deviation",
        "left_knee_flexion",
        "right_hip_flexion",
    ):
        assert deg(row, name) == pytest.approx(0.0, abs=1e-9), name
    assert row["legs_supported"] == 1.0 and row["one_leg_stance"] == 0.0 and row["seated"] == 0.0
    assert np.isnan(row["walking"]) and "time_s" not in row


def _move_upper_body(pts, mid_shoulder, lateral):
    """Shoulders at mid_shoulder +- 0.2 lateral (unit); the head moves with the mid-shoulder point."""
    shift = np.asarray(mid_shoulder) - np.array([0, 0, 1.40])
    for name in ("nose", "left_eye", "right_eye", "left_ear", "right_ear"):
        set_point(pts, name, get_point(pts, name) + shift)
    set_point(pts, "left_shoulder", np.asarray(mid_shoulder) + 0.2 * np.asarray(lateral))
    set_point(pts, "right_shoulder", np.asarray(mid_shoulder) - 0.2 * np.asarray(lateral))


@pytest.mark.parametrize("angle", [30.0, -15.0, 95.0])
def test_trunk_flexion_is_positive_forward(angle):
    a = D(angle)
    pts = stick_figure()
    _move_upper_body(pts, (0.5 * math.sin(a), 0, 0.9 + 0.5 * math.cos(a)), (0, 1, 0))
    row = measure(pts)
    assert deg(row, "trunk_flexion") == pytest.approx(angle, abs=1e-9)
    assert deg(row, "trunk_side_bend") == pytest.approx(0.0, abs=1e-9)


def test_trunk_side_bend_is_positive_to_the_right_and_twist_to_the_left():
    a = D(20)
    pts = stick_figure()
    _move_upper_body(pts, (0, -0.5 * math.sin(a), 0.9 + 0.5 * math.cos(a)), (0, math.cos(a), math.sin(a)))
    row = measure(pts)
    assert deg(row, "trunk_side_bend") == pytest.approx(20.0, abs=1e-9)
    assert deg(row, "trunk_flexion") == pytest.approx(0.0, abs=1e-9)
    assert deg(row, "trunk_twist") == pytest.approx(0.0, abs=1e-9)

    t = D(25)
    pts = stick_figure()
    _move_upper_body(pts, (0, 0, 1.40), (-math.sin(t), math.cos(t), 0))  # left shoulder goes back
    row = measure(pts)
    assert deg(row, "trunk_twist") == pytest.approx(25.0, abs=1e-9)
    assert deg(row, "trunk_flexion") == pytest.approx(0.0, abs=1e-9)


def _set_head(pts, forward, lateral, distance=0.09, half_ears=0.07):
    """The head turned about the mid-shoulder point (0, 0, 1.40) to its forward and lateral axes
    (unit, perpendicular): mid-ear 0.2 m along its up axis (forward x lateral), ears at mid-ear +-
    half_ears * lateral; nose and eyes centred at mid-ear + distance * forward."""
    forward, lateral = np.asarray(forward, float), np.asarray(lateral, float)
    mid_ear = np.array([0, 0, 1.40]) + 0.2 * np.cross(forward, lateral)
    set_point(pts, "left_ear", mid_ear + half_ears * lateral)
    set_point(pts, "right_ear", mid_ear - half_ears * lateral)
    face = mid_ear + distance * forward
    set_point(pts, "nose", face)
    set_point(pts, "left_eye", face + 0.03 * lateral)
    set_point(pts, "right_eye", face - 0.03 * lateral)


def test_neck_signs():
    a = D(20)
    pts = stick_figure()
    _set_head(pts, (math.cos(a), 0, -math.sin(a)), (0, 1, 0))  # looking down
    assert deg(measure(pts), "neck_flexion") == pytest.approx(20.0, abs=1e-9)
    pts = stick_figure()
    _set_head(pts, (math.cos(a), 0, math.sin(a)), (0, 1, 0))  # looking up
    assert deg(measure(pts), "neck_flexion") == pytest.approx(-20.0, abs=1e-9)
    b = D(15)
    pts = stick_figure()
    _set_head(pts, (1, 0, 0), (0, math.cos(b), math.sin(b)))  # left ear up: head tilted to the right
    row = measure(pts)
    assert deg(row, "neck_side_bend") == pytest.approx(15.0, abs=1e-9)
    assert deg(row, "neck_flexion") == pytest.approx(0.0, abs=1e-9)
    c = D(30)
    pts = stick_figure()
    _set_head(pts, (math.cos(c), math.sin(c), 0), (-math.sin(c), math.cos(c), 0))  # looking to the left
    row = measure(pts)
    assert deg(row, "neck_twist") == pytest.approx(30.0, abs=1e-9)
    assert deg(row, "neck_side_bend") == pytest.approx(0.0, abs=1e-9)


def test_the_neck_needs_no_face_and_ignores_a_shrug(rng):
    """Nose and eyes anywhere near the head (a network's guesses on a head seen from above) move no
    neck angle; both shoulders raised 4 cm along the trunk move none either (the neck base stays at
    the relaxed shoulder height)."""
    m = BodyMeasurements.from_stature(1.75)
    posture = place_on_floor(m, random_postures(rng, 30))
    pts = pose_skeleton(m, posture)
    settings = AngleSettings(trunk_length_m=m.trunk_length)
    plain = joint_angles(pts, settings=settings)
    guessed = pts.copy()
    for name in ("nose", "left_eye", "right_eye"):
        guessed[:, JOINT_INDEX[name]] += rng.normal(0.0, 0.05, (30, 3))
    moved = joint_angles(guessed, settings=settings)
    lift = m.shoulder_width / 2 * math.tan(D(15))
    shrug = pose_skeleton(
        m, posture.replace(left_shoulder_elevation=np.full(30, D(15)), right_shoulder_elevation=np.full(30, D(15)))
    )
    shrugged = joint_angles(shrug, settings=settings)
    for name in ("neck_flexion", "neck_side_bend", "neck_twist"):
        np.testing.assert_allclose(getattr(moved, name), getattr(plain, name), atol=1e-12)
        np.testing.assert_allclose(getattr(shrugged, name), getattr(plain, name), atol=1e-9)
        np.testing.assert_allclose(getattr(plain, name), getattr(posture, name), atol=1e-9)
    assert lift > 0.03  # the shrug moved the shoulders by more than the face's guesses


def test_neck_is_measured_relative_to_the_trunk():
    """Bending the trunk forward 40 deg with the head carried along reads trunk 40, neck 0."""
    a = D(40)
    pts = stick_figure()
    mid_sh = np.array([0.5 * math.sin(a), 0, 0.9 + 0.5 * math.cos(a)])
    _move_upper_body(pts, mid_sh, (0, 1, 0))
    mid_ear = mid_sh + 0.2 * np.array([math.sin(a), 0, math.cos(a)])
    fwd = np.array([math.cos(a), 0, -math.sin(a)])
    for s, y in (("left", 1), ("right", -1)):
        set_point(pts, f"{s}_ear", mid_ear + (0, 0.07 * y, 0))
        set_point(pts, f"{s}_eye", mid_ear + 0.09 * fwd + (0, 0.03 * y, 0))
    set_point(pts, "nose", mid_ear + 0.09 * fwd)
    row = measure(pts)
    assert deg(row, "trunk_flexion") == pytest.approx(40.0, abs=1e-9)
    assert deg(row, "neck_flexion") == pytest.approx(0.0, abs=1e-9)


def test_upper_arm_signs():
    pts = stick_figure()
    ls, rs = get_point(pts, "left_shoulder"), get_point(pts, "right_shoulder")
    set_point(pts, "left_elbow", ls + (0.3, 0, 0))  # reaching forward at shoulder height
    a = D(40)
    set_point(pts, "right_elbow", rs + 0.3 * np.array([-math.sin(a), 0, -math.cos(a)]))  # arm back
    row = measure(pts)
    assert deg(row, "left_upper_arm_flexion") == pytest.approx(90.0, abs=1e-9)
    assert deg(row, "right_upper_arm_flexion") == pytest.approx(-40.0, abs=1e-9)
    assert deg(row, "left_upper_arm_abduction") == pytest.approx(0.0, abs=1e-9)

    b = D(45)
    pts = stick_figure()
    set_point(pts, "left_elbow", ls + 0.3 * np.array([0, math.sin(b), -math.cos(b)]))
    set_point(pts, "right_elbow", rs + 0.3 * np.array([0, -math.sin(b), -math.cos(b)]))
    row = measure(pts)
    assert deg(row, "left_upper_arm_abduction") == pytest.approx(45.0, abs=1e-9)
    assert deg(row, "right_upper_arm_abduction") == pytest.approx(45.0, abs=1e-9)
    assert deg(row, "left_upper_arm_flexion") == pytest.approx(0.0, abs=1e-9)
    assert deg(row, "left_upper_arm_elevation") == pytest.approx(45.0, abs=1e-9)

    c = D(20)
    pts = stick_figure()
    set_point(pts, "left_elbow", ls + 0.3 * np.array([0, -math.sin(c), -math.cos(c)]))  # across the body
    assert deg(measure(pts), "left_upper_arm_abduction") == pytest.approx(-20.0, abs=1e-9)

    pts = stick_figure()  # overhead and a little behind the head: saturates at 180, never "-170"
    set_point(pts, "right_elbow", rs + 0.3 * np.array([-math.sin(D(10)), 0, math.cos(D(10))]))
    assert deg(measure(pts), "right_upper_arm_flexion") == pytest.approx(180.0, abs=1e-9)
    set_point(pts, "right_elbow", rs + 0.3 * np.array([math.sin(D(10)), 0, math.cos(D(10))]))
    assert deg(measure(pts), "right_upper_arm_flexion") == pytest.approx(170.0, abs=1e-9)


def test_elbow_knee_and_hip_signs():
    pts = stick_figure()
    set_point(pts, "left_wrist", get_point(pts, "left_elbow") + (0.25, 0, 0))
    k = get_point(pts, "right_knee")
    a = D(60)
    set_point(pts, "right_ankle", k + 0.42 * np.array([-math.sin(a), 0, -math.cos(a)]))
    h = get_point(pts, "left_hip")
    set_point(pts, "left_knee", h + 0.4 * np.array([math.sin(D(30)), 0, -math.cos(D(30))]))
    row = measure(pts)
    assert deg(row, "left_elbow_flexion") == pytest.approx(90.0, abs=1e-9)
    assert deg(row, "right_elbow_flexion") == pytest.approx(0.0, abs=1e-9)
    assert deg(row, "right_knee_flexion") == pytest.approx(60.0, abs=1e-9)
    assert deg(row, "left_hip_flexion") == pytest.approx(30.0, abs=1e-9)


@pytest.mark.parametrize("side,y", [("left", 1.0), ("right", -1.0)])
def test_wrist_signs(side, y):
    """Arm hanging, thumb forward: the palm faces the thigh, so flexion moves the fingers medially."""
    w = np.array([0, 0.20 * y, 0.85])
    a = D(30)
    pts = stick_figure()
    long_axis = np.array([0, -y * math.sin(a), -math.cos(a)])  # bent toward the palm
    set_point(pts, f"{side}_index", w + 0.1 * long_axis + (0.03, 0, 0))
    set_point(pts, f"{side}_pinky", w + 0.1 * long_axis - (0.03, 0, 0))
    row = measure(pts)
    assert deg(row, f"{side}_wrist_flexion") == pytest.approx(30.0, abs=1e-9)
    assert deg(row, f"{side}_wrist_deviation") == pytest.approx(0.0, abs=1e-9)

    d = D(20)
    pts = stick_figure()
    long_axis = np.array([math.sin(d), 0, -math.cos(d)])  # toward the thumb: radial deviation
    radial = np.array([math.cos(d), 0, math.sin(d)])
    set_point(pts, f"{side}_index", w + 0.1 * long_axis + 0.03 * radial)
    set_point(pts, f"{side}_pinky", w + 0.1 * long_axis - 0.03 * radial)
    row = measure(pts)
    assert deg(row, f"{side}_wrist_deviation") == pytest.approx(20.0, abs=1e-9)
    assert deg(row, f"{side}_wrist_flexion") == pytest.approx(0.0, abs=1e-9)

    pts = stick_figure()  # extension: fingers toward the back of the hand
    long_axis = np.array([0, y * math.sin(a), -math.cos(a)])
    set_point(pts, f"{side}_index", w + 0.1 * long_axis + (0.03, 0, 0))
    set_point(pts, f"{side}_pinky", w + 0.1 * long_axis - (0.03, 0, 0))
    assert deg(measure(pts), f"{side}_wrist_flexion") == pytest.approx(-30.0, abs=1e-9)


def test_shoulder_elevation():
    pts = stick_figure()
    set_point(pts, "left_shoulder", get_point(pts, "left_shoulder") + (0, 0, 0.04))
    row = measure(pts, trunk_length_m=0.50)
    # The mid-shoulder point stays on the vertical through the mid-hip; the left shoulder is 0.04 m
    # above the 0.50 m reference, 0.2 m from the trunk axis.
    assert deg(row, "left_shoulder_elevation") == pytest.approx(math.degrees(math.atan2(0.04, 0.2)), abs=1e-9)
    assert deg(row, "right_shoulder_elevation") == pytest.approx(0.0, abs=1e-9)
    assert deg(row, "trunk_side_bend") == pytest.approx(0.0, abs=1e-9)


def test_wrist_lateral_position():
    pts = stick_figure()
    set_point(pts, "left_wrist", (0.3, -0.05, 1.1))  # left hand 5 cm past the midline
    set_point(pts, "right_wrist", (0.1, -0.40, 1.0))  # right hand 0.4 m out on its own side
    row = measure(pts)
    assert row["left_wrist_lateral_m"] == pytest.approx(-0.05)
    assert row["right_wrist_lateral_m"] == pytest.approx(0.40)
    # Measured in the trunk frame: a twisted trunk carries the midline with it.
    t = D(30)
    pts = stick_figure()
    _move_upper_body(pts, (0, 0, 1.40), (-math.sin(t), math.cos(t), 0))
    set_point(pts, "left_wrist", (0.3 * math.cos(t), 0.3 * math.sin(t), 1.1))  # straight ahead of the chest
    assert measure(pts)["left_wrist_lateral_m"] == pytest.approx(0.0, abs=1e-12)


# ---------------------------------------------------------------- ambiguities (documented)


def test_lateral_raise_above_shoulder_reads_as_flexion_180():
    """Above 90 deg in the frontal plane the arm's sagittal projection points up: flexion 180,
    abduction = 180 - raise; the elevation (angle from hanging) is the raise itself."""
    pts = stick_figure()
    a = D(120)
    set_point(pts, "left_elbow", get_point(pts, "left_shoulder") + 0.3 * np.array([0, math.sin(a), -math.cos(a)]))
    row = measure(pts)
    assert deg(row, "left_upper_arm_flexion") == pytest.approx(180.0, abs=1e-9)
    assert deg(row, "left_upper_arm_abduction") == pytest.approx(60.0, abs=1e-9)
    assert deg(row, "left_upper_arm_elevation") == pytest.approx(120.0, abs=1e-9)


def test_flexion_is_ill_posed_for_an_arm_pointing_sideways():
    """Near 90 deg abduction a 2 mm elbow shift swings the flexion by tens of degrees, while the
    elevation barely moves: why recovery is tested for abduction up to 80 deg only."""
    pts = stick_figure()
    ls = get_point(pts, "left_shoulder")
    b = D(89.5)
    set_point(pts, "left_elbow", ls + 0.3 * np.array([0, math.sin(b), -math.cos(b)]))
    before = measure(pts)
    set_point(pts, "left_elbow", get_point(pts, "left_elbow") + (0.002, 0, 0))
    after = measure(pts)
    assert abs(deg(after, "left_upper_arm_flexion") - deg(before, "left_upper_arm_flexion")) > 30
    assert abs(deg(after, "left_upper_arm_elevation") - deg(before, "left_upper_arm_elevation")) < 0.5


def test_upper_arm_rotation_needs_a_bent_elbow():
    m = BodyMeasurements.from_stature(1.75)
    pts = pose_skeleton(m, Posture(left_upper_arm_rotation=D(30), left_elbow_flexion=np.radians([0.0, 10.0, 25.0])))
    rot = joint_angles(pts).left_upper_arm_rotation
    assert np.isnan(rot[0]) and np.isnan(rot[1])
    assert math.degrees(rot[2]) == pytest.approx(30.0, abs=1e-9)


# ---------------------------------------------------------------- missing joints, degenerate geometry

ARM_TRUNK_FRAME = [
    "upper_arm_flexion",
    "upper_arm_abduction",
    "upper_arm_elevation",
    "upper_arm_rotation",
    "wrist_lateral_m",
]
STANCE = ["legs_supported", "one_leg_stance", "seated"]
TRUNK_NECK = ["trunk_flexion", "trunk_side_bend", "trunk_twist", "neck_flexion", "neck_side_bend", "neck_twist"]
BOTH = lambda names: [f"{s}_{n}" for s in SIDES for n in names]  # noqa: E731

NAN_CASES = {
    "left_elbow": [
        "left_upper_arm_flexion",
        "left_upper_arm_abduction",
        "left_upper_arm_elevation",
        "left_upper_arm_rotation",
        "left_elbow_flexion",
        "left_wrist_flexion",
        "left_wrist_deviation",
    ],
    "right_wrist": [
        "right_elbow_flexion",
        "right_upper_arm_rotation",
        "right_wrist_flexion",
        "right_wrist_deviation",
        "right_wrist_lateral_m",
    ],
    "left_index": ["left_wrist_flexion", "left_wrist_deviation"],
    "nose": [],
    "right_ear": ["neck_flexion", "neck_side_bend", "neck_twist"],
    "left_shoulder": TRUNK_NECK + BOTH(ARM_TRUNK_FRAME) + BOTH(["shoulder_elevation"]) + ["left_elbow_flexion"],
    "right_hip": TRUNK_NECK
    + BOTH(ARM_TRUNK_FRAME)
    + BOTH(["shoulder_elevation"])
    + BOTH(["hip_flexion", "hip_abduction"])
    + ["right_knee_flexion"]
    + STANCE,
    "left_knee": ["left_hip_flexion", "left_hip_abduction", "left_knee_flexion"],
}


@pytest.mark.parametrize("joint", sorted(NAN_CASES))
def test_a_missing_joint_makes_exactly_its_dependants_nan(rng, joint):
    n = 40
    m = BodyMeasurements.from_stature(1.75)
    pts = pose_skeleton(m, place_on_floor(m, random_postures(rng, n)))
    settings = AngleSettings(trunk_length_m=m.trunk_length)
    full = joint_angles(pts, settings=settings).to_frame(diagnostics=True)
    pts[10, JOINT_INDEX[joint]] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        holed = joint_angles(pts, settings=settings).to_frame(diagnostics=True)
    became_nan = {c for c in holed.columns if np.isnan(holed[c][10]) and not np.isnan(full[c][10])}
    assert became_nan == set(NAN_CASES[joint])
    others = holed.drop(index=10)
    np.testing.assert_array_equal(others.to_numpy(), full.drop(index=10).to_numpy())
    rest = [c for c in holed.columns if c not in became_nan]
    np.testing.assert_array_equal(holed[rest].iloc[10].to_numpy(), full[rest].iloc[10].to_numpy())


def test_missing_foot_points_fall_back_to_the_ankle_then_nan():
    m = BodyMeasurements.from_stature(1.75)
    pts = pose_skeleton(m, place_on_floor(m, Posture(root_position=np.zeros((3, 3)))))
    pts[1, [JOINT_INDEX["left_heel"], JOINT_INDEX["left_foot_index"]]] = np.nan
    pts[2, [JOINT_INDEX["left_heel"], JOINT_INDEX["left_foot_index"], JOINT_INDEX["left_ankle"]]] = np.nan
    r = joint_angles(pts)
    assert r.left_foot_height_m[1] == pytest.approx(m.ankle_height - 0.07)
    assert r.feet_on_floor[1] == 2 and r.legs_supported[1] == 1
    assert np.isnan(r.left_foot_height_m[2]) and np.isnan(r.feet_on_floor[2])
    assert np.isnan(r.legs_supported[2]) and np.isnan(r.one_leg_stance[2])
    assert r.seated[2] == 0.0  # hips and knees are still there


def test_degenerate_geometry_gives_nan_without_warnings():
    pts = np.stack([stick_figure()] * 4)
    pts[0, JOINT_INDEX["right_shoulder"]] = pts[0, JOINT_INDEX["left_shoulder"]]  # no shoulder line
    pts[1, JOINT_INDEX["right_hip"]] = pts[1, JOINT_INDEX["left_hip"]]  # no hip line
    pts[2] = 1.0  # every point at one place
    pts[3] = np.nan  # nothing seen
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = joint_angles(pts, np.arange(4) / 12.0)
    assert np.isfinite(r.trunk_flexion[0]) and np.isfinite(r.trunk_side_bend[0]) and np.isnan(r.trunk_twist[0])
    assert np.isnan(r.left_upper_arm_flexion[0])
    assert np.isnan(r.trunk_flexion[1]) and np.isnan(r.left_hip_flexion[1]) and np.isfinite(r.left_knee_flexion[1])
    frame = r.to_frame(diagnostics=True)
    # Feet 1 m above the floor are still feet off the floor: no foot down, so no one-leg stance.
    feet = ["left_foot_height_m", "right_foot_height_m", "feet_on_floor", "one_leg_stance"]
    assert frame.drop(columns=["time_s"] + feet).iloc[2].isna().all()
    assert frame[feet].iloc[2].tolist() == [1.0, 1.0, 0.0, 0.0]
    assert frame.drop(columns=["time_s"]).iloc[3].isna().all()


# ---------------------------------------------------------------- stance: constructed sequences

FPS = 12.0


def sequence(posture: Posture, stature=1.75, **settings):
    m = BodyMeasurements.from_stature(stature)
    pts = pose_skeleton(m, place_on_floor(m, posture))
    n = pts.shape[0]
    return joint_angles(pts, np.arange(n) / FPS, AngleSettings(**settings))


def constant(n, **angles_deg):
    return {k: np.full(n, D(v)) for k, v in angles_deg.items()}


def test_standing_still():
    n = 36
    r = sequence(
        Posture(
            root_position=np.tile([1.0, 2.0, 0.0], (n, 1)),
            heading=np.full(n, 2.0),
            **constant(n, trunk_flexion=25, left_upper_arm_flexion=60),
        )
    )
    for flag, value in [
        ("walking", 0),
        ("seated", 0),
        ("one_leg_stance", 0),
        ("legs_supported", 1),
        ("feet_on_floor", 2),
    ]:
        np.testing.assert_array_equal(getattr(r, flag), value, err_msg=flag)


def walking_posture(n, speed, heading=D(30)):
    t = np.arange(n) / FPS
    phase = 2 * np.pi * 0.9 * t
    hip_l = D(25) * np.sin(phase)
    knee_l = D(45) * np.clip(np.sin(phase + 1.2), 0, None)
    knee_r = D(45) * np.clip(np.sin(phase + 1.2 + np.pi), 0, None)
    root = np.c_[speed * t * math.cos(heading), speed * t * math.sin(heading), np.zeros(n)]
    return Posture(
        root_position=root,
        heading=np.full(n, heading),
        left_hip_flexion=hip_l,
        right_hip_flexion=-hip_l,
        left_knee_flexion=knee_l,
        right_knee_flexion=knee_r,
    )


def test_walking_and_shuffling():
    n = 60
    r = sequence(walking_posture(n, 1.1))
    np.testing.assert_array_equal(r.walking, 1.0)
    np.testing.assert_allclose(r.walking_speed_mps[12:-12], 1.1, rtol=0.15)
    np.testing.assert_array_equal(r.one_leg_stance, 0.0)  # swing phases are walking, not one-leg stance
    np.testing.assert_array_equal(r.seated, 0.0)
    slow = sequence(walking_posture(n, 0.1))
    np.testing.assert_array_equal(slow.walking, 0.0)


def test_walking_with_a_tracking_gap_and_without_times():
    n = 60
    m = BodyMeasurements.from_stature(1.75)
    pts = pose_skeleton(m, place_on_floor(m, walking_posture(n, 1.0)))
    pts[20:26] = np.nan
    r = joint_angles(pts, np.arange(n) / FPS)
    assert np.isnan(r.walking[20:26]).all()
    np.testing.assert_array_equal(np.delete(r.walking, np.arange(20, 26)), 1.0)
    r = joint_angles(pts)
    assert np.isnan(r.walking).all() and np.isnan(r.walking_speed_mps).all() and np.isnan(r.time_s).all()


def test_one_leg_stance():
    n = 24
    r = sequence(Posture(**constant(n, right_hip_flexion=40, right_knee_flexion=90)))
    np.testing.assert_array_equal(r.feet_on_floor, 1.0)
    np.testing.assert_array_equal(r.one_leg_stance, 1.0)
    np.testing.assert_array_equal(r.legs_supported, 0.0)
    np.testing.assert_array_equal(r.walking, 0.0)
    # Without times walking is unknown, so is a one-leg stance.
    m = BodyMeasurements.from_stature(1.75)
    pts = pose_skeleton(m, place_on_floor(m, Posture(**constant(n, right_hip_flexion=40, right_knee_flexion=90))))
    assert np.isnan(joint_angles(pts).one_leg_stance).all()


def test_a_small_lift_counts_as_off_the_floor():
    """A foot 9 cm higher than the other is lifted even though it is under the 12 cm contact height."""
    n = 12
    m = BodyMeasurements.from_stature(1.75)
    hip, knee = np.full(n, D(28)), np.full(n, D(56))
    posture = place_on_floor(
        m, Posture(right_hip_flexion=hip, right_knee_flexion=knee, right_ankle_flexion=flat_foot_ankle(hip, knee))
    )
    pts = pose_skeleton(m, posture)
    lift = np.fmin(pts[:, JOINT_INDEX["right_heel"], 2], pts[:, JOINT_INDEX["right_foot_index"], 2])
    assert np.all((lift > 0.08) & (lift < 0.11))
    r = joint_angles(pts, np.arange(n) / FPS)
    np.testing.assert_array_equal(r.feet_on_floor, 1.0)
    np.testing.assert_array_equal(r.one_leg_stance, 1.0)
    # The same posture with every keypoint 5 cm above its true place (keypoints above the sole, or a
    # floor calibrated 5 cm low) reads the same.
    r = joint_angles(pts + (0, 0, 0.05), np.arange(n) / FPS)
    np.testing.assert_array_equal(r.feet_on_floor, 1.0)


def test_sitting_on_a_chair_and_on_a_high_stool():
    n = 24
    legs = constant(n, left_hip_flexion=90, right_hip_flexion=90, left_knee_flexion=90, right_knee_flexion=90)
    r = sequence(Posture(**legs))
    for flag, value in [
        ("seated", 1),
        ("legs_supported", 1),
        ("one_leg_stance", 0),
        ("walking", 0),
        ("feet_on_floor", 2),
    ]:
        np.testing.assert_array_equal(getattr(r, flag), value, err_msg=flag)
    m = BodyMeasurements.from_stature(1.75)
    chair = place_on_floor(m, Posture(**legs))
    stool = chair.replace(root_position=chair.root_position + (0, 0, 0.25))  # feet dangle 25 cm up
    r = joint_angles(pose_skeleton(m, stool), np.arange(n) / FPS)
    for flag, value in [("seated", 1), ("legs_supported", 0), ("one_leg_stance", 0), ("feet_on_floor", 0)]:
        np.testing.assert_array_equal(getattr(r, flag), value, err_msg=flag)
    # Seated on a rolling chair that moves: still seated (and the moving feet read as walking).
    rolling = chair.replace(root_position=chair.root_position + np.c_[np.arange(n) / FPS * 0.8, np.zeros((n, 2))])
    r = joint_angles(pose_skeleton(m, rolling), np.arange(n) / FPS)
    np.testing.assert_array_equal(r.walking, 1.0)
    np.testing.assert_array_equal(r.seated, 1.0)


def test_deep_squat_is_not_seated():
    n = 12
    hip, knee = np.full(n, D(120)), np.full(n, D(140))
    r = sequence(
        Posture(
            trunk_flexion=np.full(n, D(40)),
            left_hip_flexion=hip,
            right_hip_flexion=hip,
            left_knee_flexion=knee,
            right_knee_flexion=knee,
            left_ankle_flexion=flat_foot_ankle(hip, knee),
            right_ankle_flexion=flat_foot_ankle(hip, knee),
        )
    )
    np.testing.assert_array_equal(r.seated, 0.0)
    np.testing.assert_array_equal(r.feet_on_floor, 2.0)


@pytest.mark.parametrize("lean_deg,supported", [(2.0, 1.0), (10.0, 0.0)])
def test_weight_on_one_leg_is_not_evenly_balanced(lean_deg, supported):
    """Both legs tilted sideways by the same angle shift the hips over one foot."""
    n = 12
    r = sequence(Posture(**constant(n, left_hip_abduction=lean_deg, right_hip_abduction=-lean_deg)))
    np.testing.assert_array_equal(r.feet_on_floor, 2.0)
    np.testing.assert_array_equal(r.legs_supported, supported)


# ---------------------------------------------------------------- real data


def load_pose2sim_trial(shared_data):
    """Pose2Sim's 3D output of a real 4-camera recording, mapped to BlazePose names and z up."""
    path = shared_data / "pose2sim-demo" / "pose-3d" / "S00_P00_T01_BalancingTrial_0-100_filt_butterworth.trc"
    lines = path.read_text().splitlines()
    names = [n for n in lines[3].split("\t")[2:] if n]
    data = np.loadtxt(path, skiprows=5)
    xyz = data[:, 2:].reshape(len(data), -1, 3)[:, :, [2, 0, 1]]  # TRC axes = world[:, [1, 2, 0]] (SOURCE.md)
    mapping = {
        "Hip": "hip",
        "Knee": "knee",
        "Ankle": "ankle",
        "BigToe": "foot_index",
        "Heel": "heel",
        "Shoulder": "shoulder",
        "Elbow": "elbow",
        "Wrist": "wrist",
    }
    pts = np.full((len(data), 33, 3), np.nan)
    for prefix, side in (("L", "left"), ("R", "right")):
        for trc, ours in mapping.items():
            pts[:, JOINT_INDEX[f"{side}_{ours}"]] = xyz[:, names.index(prefix + trc)]
    pts[:, JOINT_INDEX["nose"]] = xyz[:, names.index("Nose")]
    return data[:, 1], pts, xyz, names


def test_real_recording_feet_and_leg_swing(shared_data):
    """In this trial the subject stands, then swings the right leg out to the right and forward
    (its ankle rises to 0.45 m), and sets it down; the left foot stays down until frame ~85."""
    t, pts, xyz, names = load_pose2sim_trial(shared_data)
    r = joint_angles(pts, t)
    right_low = np.fmin(xyz[:, names.index("RHeel"), 2], xyz[:, names.index("RBigToe"), 2])
    left_low = np.fmin(xyz[:, names.index("LHeel"), 2], xyz[:, names.index("LBigToe"), 2])
    lifted = (right_low > 0.25) & (left_low < 0.10)
    assert lifted.sum() >= 15
    np.testing.assert_array_equal(r.feet_on_floor[lifted], 1.0)
    np.testing.assert_array_equal(r.feet_on_floor[:5], 2.0)
    # The swung leg points out to the subject's right: right hip abduction positive and large where the
    # right ankle is far to the right of the right hip (the subject faces world +x here).
    hip, ankle = xyz[:, names.index("RHip")], xyz[:, names.index("RAnkle")]
    out_right = (hip[:, 1] - ankle[:, 1]) > 0.45
    assert out_right.sum() >= 10
    rough = np.degrees(np.arctan2(hip[out_right, 1] - ankle[out_right, 1], hip[out_right, 2] - ankle[out_right, 2]))
    measured = np.degrees(r.right_hip_abduction[out_right])
    assert np.all(measured > 30)
    np.testing.assert_allclose(measured, rough, atol=12)
    # Standing at the start: trunk near upright, knees nearly straight.
    assert np.all(np.abs(np.degrees(r.trunk_flexion[:3])) < 10)
    assert np.all(np.degrees(r.right_knee_flexion[:3]) < 25)
    # No face points in this data: neck unknown; no hand points: wrist unknown.
    assert np.isnan(r.neck_flexion).all() and np.isnan(r.left_wrist_flexion).all()


# ---------------------------------------------------------------- table, inputs, settings


def test_posture_table_columns_pass_the_scoring_contract(rng):
    n = 200
    m = BodyMeasurements.from_stature(1.75)
    posture = random_postures(rng, n).replace(left_upper_arm_flexion=np.radians(rng.uniform(-80, 200, n)))
    pts = pose_skeleton(m, place_on_floor(m, posture))
    pts[5, JOINT_INDEX["nose"]] = np.nan
    t = np.arange(n) / FPS
    result = joint_angles(pts, t)
    frame = result.to_frame()
    assert list(frame.columns) == list(POSTURE_TABLE_COLUMNS + MEASURED_COLUMNS)
    assert len(frame) == n and all(frame.dtypes == np.float64)
    np.testing.assert_array_equal(frame["time_s"], t)
    for c in FLAG_COLUMNS:
        assert set(np.unique(frame[c].dropna())) <= {0.0, 1.0}, c
    # docs/posture-table.md (ergopose.ergonomics.posture): every column known, every value valid.
    check_columns(frame.columns, ["rula", "reba"])
    validate_values(frame)
    assert np.nanmax(np.abs(frame.drop(columns="time_s").to_numpy())) <= np.pi
    with_diagnostics = result.to_frame(diagnostics=True)
    assert list(with_diagnostics.columns) == list(POSTURE_TABLE_COLUMNS + MEASURED_COLUMNS + DIAGNOSTIC_COLUMNS)
    # Without frame times there is no time_s column (scoring then asks for one or for activity flags).
    assert "time_s" not in joint_angles(pts).to_frame().columns


def test_blocks_give_the_same_result_as_one_pass(rng, monkeypatch):
    m = BodyMeasurements.from_stature(1.75)
    n = 100
    pts = pose_skeleton(m, place_on_floor(m, random_postures(rng, n)))
    one = joint_angles(pts, np.arange(n) / FPS).to_frame(diagnostics=True)
    monkeypatch.setattr(angles_mod, "CHUNK_FRAMES", 7)
    blocks = joint_angles(pts, np.arange(n) / FPS).to_frame(diagnostics=True)
    np.testing.assert_array_equal(one.to_numpy(), blocks.to_numpy())
    assert joint_angles(np.zeros((0, 33, 3))).n_frames == 0


def test_bad_inputs_and_settings_are_named():
    pts = np.zeros((4, 33, 3))
    with pytest.raises(InputError, match="points_world"):
        joint_angles(np.zeros((4, 17, 3)))
    with pytest.raises(InputError, match="time_s"):
        joint_angles(pts, np.arange(3.0))
    with pytest.raises(InputError, match="increasing"):
        joint_angles(pts, np.array([0.0, 0.1, 0.1, 0.2]))
    with pytest.raises(InputError, match="finite"):
        joint_angles(pts, np.array([0.0, np.nan, 0.2, 0.3]))
    with pytest.raises(ConfigError, match="walking_window_s"):
        AngleSettings(walking_window_s=0.0)
    with pytest.raises(ConfigError, match="trunk_length_m"):
        AngleSettings(trunk_length_m=-0.5)
    with pytest.raises(ConfigError, match="settings"):
        joint_angles(pts, settings={"walking_window_s": 1.0})
