"""End to end with simulated ground truth: a known posture -> 3D BlazePose joints (forward
kinematics of ergopose.ergonomics.body) -> joint angles (ergopose.ergonomics.angles) -> RULA and
REBA, compared with the worksheet worked by hand from the reference tables."""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.ergonomics.aggregate import aggregate_shift
from ergopose.ergonomics.angles import joint_angles
from ergopose.ergonomics.body import BodyMeasurements, Posture, place_on_floor, pose_skeleton
from ergopose.ergonomics.scoring import score_posture

FPS = 12.0


def _table(n: int, **deg):
    m = BodyMeasurements.from_stature(1.75)
    fields = {k: np.deg2rad(v(np.arange(n) / FPS) if callable(v) else np.full(n, float(v))) for k, v in deg.items()}
    points = pose_skeleton(m, place_on_floor(m, Posture(**fields)))
    return joint_angles(points, np.arange(n) / FPS).to_frame()


POSE = dict(
    trunk_flexion=35,
    neck_flexion=25,
    left_upper_arm_flexion=100,
    right_upper_arm_flexion=10,
    left_elbow_flexion=30,
    right_elbow_flexion=80,
    left_wrist_flexion=25,
    right_wrist_flexion=0,
    left_knee_flexion=45,
    right_knee_flexion=45,
)


def test_known_posture_scores_as_worked_by_hand():
    frame = _table(6, **POSE).assign(
        static_posture=0.0, repeated_action=0.0, rapid_change=0.0, legs_supported=1.0, load_kg=0.0, coupling="good"
    )
    s = score_posture(frame).iloc[0]
    # RULA left: UA 100 -> 4, LA 30 -> 2, wrist 25 -> 3, twist 1: Table A (UA4 LA2, W3T1) = 4
    assert (s.left_rula_upper_arm, s.left_rula_lower_arm, s.left_rula_wrist, s.left_rula_table_a) == (4, 2, 3, 4)
    # RULA right: UA 10 -> 1, LA 80 -> 1, wrist 0 -> 1: Table A = 1
    assert s.right_rula_table_a == 1
    # neck 25 -> 3, trunk 35 -> 3, legs supported -> 1: Table B (N3, T3L1) = 4
    assert (s.rula_neck, s.rula_trunk, s.rula_legs, s.rula_table_b) == (3, 3, 1, 4)
    # Table C: left (C4, D4) = 4, right (C1, D4) = 3; the worse side is the left
    assert (s.left_rula_grand, s.right_rula_grand, s.rula_grand, s.rula_worse_side) == (4, 3, 4, "left")
    # REBA: neck 2, trunk 3, legs 1 + knee 45 (+1) = 2: Table A (T3, N2L2) = 5
    assert (s.reba_neck, s.reba_trunk, s.reba_legs, s.reba_table_a) == (2, 3, 2, 5)
    # left arm: UA 4, LA 2, wrist 2: Table B = 6; Table C (A5, B6) = 7, medium risk
    assert (s.left_reba_table_b, s.reba_table_b, s.reba_table_c, s.reba_score, s.reba_risk_level) == (6, 6, 7, 7, 2)


def test_held_trunk_through_the_whole_chain():
    n = int(100 * FPS)
    trunk = lambda t: np.where(t < 70, 35.0, 0.0)  # noqa: E731  70 s bent, then upright
    frame = _table(n, **{**POSE, "trunk_flexion": trunk})
    scores = score_posture(frame, with_events=True)
    t = frame["time_s"].to_numpy()
    assert (scores["rula_static_b"][t < 70] == 1).all()
    assert (scores["reba_static"][t < 70] == 1).all()
    summary = aggregate_shift(frame.join(scores), "sim")
    trunk_bands = summary.distributions["rula_trunk_band"]
    assert trunk_bands.at(3).time_s == pytest.approx(70.0) and trunk_bands.at(3).longest_hold_s == pytest.approx(70.0)
    iso = {f.body_part: f.verdict for f in summary.exposure if f.standard == "ISO 11226"}
    assert iso["trunk"] == "time-limited"  # 35 degrees held > 4 s
    assert iso["left upper arm"] == "not recommended"  # 100 degrees elevation held
