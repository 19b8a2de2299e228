"""Properties of the scoring (hypothesis, derandomized): a worse posture never scores lower, and
every score stays within its documented range.

"Worse": an angle moved further from its neutral band (same direction), an adverse yes/no flag
switched on, a protective one (arm supported, legs supported) switched off, a heavier load, a
static/repeated load mode instead of intermittent, a worse coupling.
Each example scores a batch of random postures and their worsened copies in one call.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ergopose.ergonomics.scoring import score_posture
from ergopose.ergonomics.settings import ScoringSettings

# angle column -> (neutral point, low, high) in degrees; "away from neutral" = |x - n| grows, same sign
ANGLES = {
    "trunk_flexion": (0.0, -40.0, 100.0),
    "neck_flexion": (5.0, -40.0, 60.0),
    "left_upper_arm_flexion": (0.0, -60.0, 170.0),
    "right_upper_arm_flexion": (0.0, -60.0, 170.0),
    "left_elbow_flexion": (80.0, 0.0, 160.0),
    "right_elbow_flexion": (80.0, 0.0, 160.0),
    "left_wrist_flexion": (0.0, -70.0, 70.0),
    "right_wrist_flexion": (0.0, -70.0, 70.0),
    "left_knee_flexion": (0.0, 0.0, 140.0),
    "right_knee_flexion": (0.0, 0.0, 140.0),
    # measured inputs of yes/no flags: more is worse
    "trunk_twist": (0.0, -40.0, 40.0),
    "trunk_side_bend": (0.0, -40.0, 40.0),
    "neck_twist": (0.0, -40.0, 40.0),
    "neck_side_bend": (0.0, -40.0, 40.0),
    "left_upper_arm_abduction": (0.0, 0.0, 120.0),
    "right_upper_arm_abduction": (0.0, 0.0, 120.0),
    "left_shoulder_elevation": (0.0, 0.0, 30.0),
    "left_wrist_deviation": (0.0, -30.0, 30.0),
}
ADVERSE_FLAGS = [
    "left_shoulder_raised",
    "right_upper_arm_abducted",
    "left_arm_across_midline_or_out",
    "right_wrist_deviated",
    "left_wrist_twist_end_range",
    "one_leg_stance",
    "shock",
    "static_posture",
    "repeated_action",
    "rapid_change",
    "trunk_twisted",
    "neck_side_bent",
]
PROTECTIVE_FLAGS = ["left_arm_supported", "right_arm_supported", "legs_supported"]
COUPLINGS = ["good", "fair", "poor", "unacceptable"]

RANGES = {  # column suffix -> (lowest, highest) possible value
    "rula_upper_arm_band": (1, 4),
    "rula_upper_arm_adjust": (-1, 2),
    "rula_upper_arm": (1, 6),
    "rula_lower_arm_band": (1, 2),
    "rula_lower_arm_adjust": (0, 1),
    "rula_lower_arm": (1, 3),
    "rula_wrist_band": (1, 3),
    "rula_wrist_adjust": (0, 1),
    "rula_wrist": (1, 4),
    "rula_wrist_twist": (1, 2),
    "rula_table_a": (1, 9),
    "rula_static": (0, 1),
    "rula_repeated": (0, 1),
    "rula_muscle": (0, 1),
    "rula_score_c": (1, 13),
    "rula_grand": (1, 7),
    "rula_action_level": (1, 4),
    "rula_force": (0, 3),
    "rula_neck_band": (1, 4),
    "rula_neck_adjust": (0, 2),
    "rula_neck": (1, 6),
    "rula_trunk_band": (1, 4),
    "rula_trunk_adjust": (0, 2),
    "rula_trunk": (1, 6),
    "rula_legs": (1, 2),
    "rula_table_b": (1, 9),
    "rula_static_b": (0, 1),
    "rula_repeated_b": (0, 1),
    "rula_muscle_b": (0, 1),
    "rula_score_d": (1, 13),
    "reba_neck_band": (1, 2),
    "reba_neck_adjust": (0, 1),
    "reba_neck": (1, 3),
    "reba_trunk_band": (1, 4),
    "reba_trunk_adjust": (0, 1),
    "reba_trunk": (1, 5),
    "reba_legs_band": (1, 2),
    "reba_knee": (0, 2),
    "reba_legs": (1, 4),
    "reba_table_a": (1, 9),
    "reba_load": (0, 3),
    "reba_score_a": (1, 12),
    "reba_upper_arm_band": (1, 4),
    "reba_upper_arm_adjust": (-1, 2),
    "reba_upper_arm": (1, 6),
    "reba_lower_arm": (1, 2),
    "reba_wrist_band": (1, 2),
    "reba_wrist_adjust": (0, 1),
    "reba_wrist": (1, 3),
    "reba_table_b": (1, 9),
    "reba_coupling": (0, 3),
    "reba_score_b": (1, 12),
    "reba_table_c": (1, 12),
    "reba_static": (0, 1),
    "reba_repeated": (0, 1),
    "reba_rapid": (0, 1),
    "reba_activity": (0, 3),
    "reba_score": (1, 15),
    "reba_risk_level": (0, 4),
}
FINAL = ["rula_grand", "rula_action_level", "left_rula_grand", "right_rula_grand", "reba_score", "reba_risk_level"]


@st.composite
def postures(draw, n_max: int = 8):
    n = draw(st.integers(1, n_max))
    rows = []
    for _ in range(n):
        row = {c: draw(st.floats(lo, hi, allow_nan=False)) for c, (_, lo, hi) in ANGLES.items()}
        for f in ADVERSE_FLAGS + PROTECTIVE_FLAGS + ["walking", "seated"]:
            row[f] = float(draw(st.integers(0, 1)))
        row["load_kg"] = draw(st.floats(0, 25, allow_nan=False))
        row["load_mode"] = draw(st.sampled_from(["intermittent", "static", "repeated"]))
        row["coupling"] = draw(st.sampled_from(COUPLINGS))
        rows.append(row)
    return rows


def _frame(rows: list[dict]) -> pd.DataFrame:
    frame = pd.DataFrame(rows)
    for c in ANGLES:
        frame[c] = np.deg2rad(frame[c])
    return frame


def _worsen(rows: list[dict], kind: str, which: str, amount: float) -> list[dict]:
    out = []
    for r in rows:
        r = dict(r)
        if kind == "angle":
            n, lo, hi = ANGLES[which]
            x = r[which]
            away = (x - n) * (1.0 + amount) if x != n else amount * (hi - n)
            r[which] = float(np.clip(n + away, lo, hi))
        elif kind == "adverse":
            r[which] = 1.0
        elif kind == "protective":
            r[which] = 0.0
        elif kind == "load":
            r["load_kg"] = r["load_kg"] + 10 * amount
        elif kind == "mode":
            r["load_mode"] = "static" if r["load_mode"] == "intermittent" else r["load_mode"]
        elif kind == "coupling":
            r["coupling"] = COUPLINGS[min(3, COUPLINGS.index(r["coupling"]) + 1)]
        out.append(r)
    return out


CHANGES = (
    [("angle", a) for a in ANGLES]
    + [("adverse", f) for f in ADVERSE_FLAGS]
    + [("protective", f) for f in PROTECTIVE_FLAGS]
    + [("load", ""), ("mode", ""), ("coupling", "")]
)


@pytest.mark.slow
@settings(derandomize=True, max_examples=60, deadline=None)
@given(rows=postures(), amount=st.floats(0.0, 2.0), boundary=st.sampled_from(["higher", "lower"]))
def test_a_worse_posture_never_scores_lower(rows, amount, boundary):
    """Every change of CHANGES applied to every drawn posture, all scored in one call."""
    s = ScoringSettings(rula_open_boundary=boundary, reba_open_boundary=boundary)
    base = score_posture(_frame(rows * len(CHANGES)), settings=s)
    worse_rows = [r for kind, which in CHANGES for r in _worsen(rows, kind, which, amount)]
    worse = score_posture(_frame(worse_rows), settings=s)
    change_of_row = np.repeat(np.arange(len(CHANGES)), len(rows))
    for col in FINAL + [
        c
        for c in base.columns
        if c.endswith(("_table_a", "_table_b", "_table_c", "_score_c", "_score_d", "_score_a", "_score_b"))
    ]:
        b = base[col].to_numpy(dtype=float)
        w = worse[col].to_numpy(dtype=float)
        bad = ~(w >= b)
        assert not bad.any(), (col, [CHANGES[k] for k in np.unique(change_of_row[bad])], b[bad], w[bad])


@settings(derandomize=True, max_examples=40, deadline=None)
@given(rows=postures(), variant=st.sampled_from(["single", "separate"]), unknown=st.sampled_from(["absent", "missing"]))
@pytest.mark.slow
def test_every_score_stays_in_its_range(rows, variant, unknown):
    s = ScoringSettings(rula_lower_arm_adjust=variant, reba_twist_side_adjust=variant, unknown_flags=unknown)
    frame = _frame(rows)
    # some unknown inputs
    frame.loc[frame.index[::2], "left_shoulder_raised"] = np.nan
    scores = score_posture(frame, settings=s)
    for col in scores.columns:
        if col.endswith(("worse_side", "unknown_flags")):
            continue
        suffix = col.removeprefix("left_").removeprefix("right_")
        lo, hi = RANGES[suffix]
        if variant == "separate":
            hi += {
                "rula_lower_arm": 1,
                "rula_lower_arm_adjust": 1,
                "reba_neck": 1,
                "reba_neck_adjust": 1,
                "reba_trunk": 1,
                "reba_trunk_adjust": 1,
            }.get(suffix, 0)
        x = scores[col].dropna().to_numpy(dtype=float)
        assert np.all((x >= lo) & (x <= hi)), (col, x.min(), x.max())
    if unknown == "absent":
        assert not scores[FINAL].isna().any().any()


@pytest.mark.slow
@settings(derandomize=True, max_examples=30, deadline=None)
@given(rows=postures(n_max=4), column=st.sampled_from(list(ANGLES)))
def test_missing_angle_never_invents_a_score(rows, column):
    frame = _frame(rows)
    frame[column] = np.nan
    scores = score_posture(frame)
    needs = {  # which final scores depend on the angle (measured-flag inputs only feed adjustments)
        "trunk_flexion": FINAL,
        "neck_flexion": FINAL,
        "left_upper_arm_flexion": ["left_rula_grand", "rula_grand", "reba_score"],
        "right_upper_arm_flexion": ["right_rula_grand", "rula_grand", "reba_score"],
        "left_elbow_flexion": ["left_rula_grand", "reba_score"],
        "right_elbow_flexion": ["right_rula_grand", "reba_score"],
        "left_wrist_flexion": ["left_rula_grand", "reba_score"],
        "right_wrist_flexion": ["right_rula_grand", "reba_score"],
    }.get(column, [])
    seated = frame["seated"].to_numpy() == 1
    for col in needs:
        if column.endswith("knee_flexion"):
            continue
        assert scores[col].isna().all(), (column, col)
    if column.endswith("knee_flexion"):
        assert (scores["reba_score"].isna().to_numpy() == ~seated).all()


def test_range_table_covers_every_column():
    row = {c: ANGLES[c][0] for c in ANGLES}
    row.update(static_posture=0.0, repeated_action=0.0, rapid_change=0.0)
    cols = score_posture(_frame([row])).columns
    missing = (
        {c.removeprefix("left_").removeprefix("right_") for c in cols}
        - set(RANGES)
        - {"rula_worse_side", "reba_worse_side", "rula_unknown_flags", "reba_unknown_flags"}
    )
    assert not missing


@pytest.mark.parametrize("flag", ["walking"])
def test_walking_moves_the_methods_in_opposite_documented_directions(flag):
    row = {c: ANGLES[c][0] for c in ANGLES}
    row.update(
        {
            "one_leg_stance": 1.0,
            "legs_supported": np.nan,
            "repeated_action": 1.0,
            "static_posture": 0.0,
            "rapid_change": 0.0,
        }
    )
    still = score_posture(_frame([{**row, "walking": 0.0}]))
    walk = score_posture(_frame([{**row, "walking": 1.0}]))
    assert int(walk["reba_legs"].iloc[0]) == 1 < int(still["reba_legs"].iloc[0])  # REBA: walking = 1
    assert int(walk["reba_repeated"].iloc[0]) == 0 < int(still["reba_repeated"].iloc[0])  # "not walking"
    assert int(walk["rula_legs"].iloc[0]) == 2  # RULA: not balanced
