"""RULA and REBA scoring: full worksheets worked by hand from the reference tables, every
boundary the reference settles, the open boundaries and tolerances as settings, flags, missing
joints and worksheet variants.

Each worksheet lists, in comments, the reference row/criterion that gives every step's expected
value (rula-reba-reference.md); the expected numbers were read off the reference by hand.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ergopose.ergonomics.scoring import reba_columns, rula_columns, score_posture, score_reba, score_rula
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.errors import InputError
from ergopose.ergonomics.posture import ANGLE_COLUMNS

NEUTRAL_DEG = {  # a neutral posture (every band at its lowest score)
    "upper_arm_flexion": 0.0,
    "elbow_flexion": 80.0,
    "wrist_flexion": 0.0,
    "neck_flexion": 5.0,
    "trunk_flexion": 0.0,
    "knee_flexion": 0.0,
}
NO_ACTIVITY = {"static_posture": 0.0, "repeated_action": 0.0, "rapid_change": 0.0}


def posture(rows: list[dict] | dict, **common) -> pd.DataFrame:
    """A posture table from rows given in DEGREES (angles) / 0-1 flags; missing angles neutral."""
    if isinstance(rows, dict):
        rows = [rows]
    out = []
    for r in rows:
        row = {**NEUTRAL_DEG, **NO_ACTIVITY, **common, **r}
        out.append(row)
    frame = pd.DataFrame(out)
    for c in frame.columns:
        bare = c.removeprefix("left_").removeprefix("right_")
        if (
            c in ANGLE_COLUMNS
            or bare in NEUTRAL_DEG
            or bare in ("upper_arm_abduction", "shoulder_elevation", "wrist_deviation", "upper_arm_elevation")
        ):
            frame[c] = np.deg2rad(frame[c].astype(float))
    return frame


def one(frame: pd.DataFrame, column: str, row: int = 0):
    v = frame[column].iloc[row]
    return None if pd.isna(v) else (v if isinstance(v, str) else int(v))


# ----------------------------------------------------------------------- RULA worksheets


def test_rula_worksheet_high_risk_both_sides():
    p = posture(
        {
            "upper_arm_flexion": 50,
            "shoulder_raised": 1,  # step 1: 45-90 -> 3; 1a: +1 raised -> 4
            "elbow_flexion": 110,
            "arm_across_midline_or_out": 1,  # step 2: > 100 -> 2; 2a: +1 -> 3
            "wrist_flexion": 10,
            "wrist_deviated": 1,  # step 3: 0-15 -> 2; 3a: +1 -> 3
            "wrist_twist_end_range": 1,  # step 4: end of range -> 2
            "static_posture": 1,  # step 6: held -> +1
            "load_kg": 5,
            "load_mode": "intermittent",  # step 7: 2-10 kg intermittent -> 1
            "neck_flexion": 15,
            "neck_twisted": 1,  # step 9: 10-20 -> 2; 9a: +1 -> 3
            "trunk_flexion": 30,
            "trunk_side_bent": 1,  # step 10: 20-60 -> 3; 10a: +1 -> 4
            "legs_supported": 1,  # step 11: -> 1
        }
    )
    s = score_rula(p)
    for side in ("left_", "right_"):
        assert one(s, f"{side}rula_upper_arm_band") == 3
        assert one(s, f"{side}rula_upper_arm_adjust") == 1
        assert one(s, f"{side}rula_upper_arm") == 4
        assert one(s, f"{side}rula_lower_arm") == 3
        assert one(s, f"{side}rula_wrist") == 3
        assert one(s, f"{side}rula_wrist_twist") == 2
        assert one(s, f"{side}rula_table_a") == 5  # Table A row UA4 LA3, column W3T2
        assert one(s, f"{side}rula_muscle") == 1
        assert one(s, f"{side}rula_score_c") == 7  # 5 + 1 + 1
        assert one(s, f"{side}rula_grand") == 7
    assert one(s, "rula_force") == 1
    assert one(s, "rula_neck") == 3
    assert one(s, "rula_trunk") == 4
    assert one(s, "rula_legs") == 1
    assert one(s, "rula_table_b") == 5  # Table B row N3, column T4L1
    assert one(s, "rula_muscle_b") == 1
    assert one(s, "rula_score_d") == 7  # 5 + 1 + 1
    assert one(s, "rula_grand") == 7  # Table C row 7, column 7
    assert one(s, "rula_action_level") == 4
    assert one(s, "rula_worse_side") == "both"


def test_rula_worksheet_acceptable():
    p = posture(
        {
            "upper_arm_flexion": 10,  # 20 ext to 20 flex -> 1
            "elbow_flexion": 80,  # 60-100 -> 1
            "wrist_flexion": 3,  # within the 5-degree neutral tolerance -> 1
            "wrist_twist_end_range": 0,  # mid-range -> 1
            "load_kg": 1,  # < 2 kg -> 0
            "neck_flexion": 5,  # 0-10 -> 1
            "trunk_flexion": 2,  # upright (tolerance) -> 1
            "legs_supported": 1,
        }
    )
    s = score_rula(p)
    assert one(s, "left_rula_table_a") == 1 and one(s, "right_rula_table_a") == 1
    assert one(s, "left_rula_score_c") == 1
    assert one(s, "rula_table_b") == 1 and one(s, "rula_score_d") == 1
    assert one(s, "rula_grand") == 1 and one(s, "rula_action_level") == 1


def test_rula_worksheet_sides_differ():
    p = posture(
        {
            # left: extension > 20 -> 2, arm supported -1 -> 1; elbow < 60 -> 2; 15 or more extension -> 3
            "left_upper_arm_flexion": -30,
            "left_arm_supported": 1,
            "left_elbow_flexion": 50,
            "left_wrist_flexion": -20,
            # right: 90 or more -> 4, abducted +1 -> 5; elbow exactly 100 -> 1; wrist exactly 15 -> 3
            "right_upper_arm_flexion": 100,
            "right_upper_arm_abducted": 1,
            "right_elbow_flexion": 100,
            "right_wrist_flexion": 15,
            "repeated_action": 1,  # muscle use +1
            "load_kg": 12,
            "load_mode": "static",  # > 10 kg static -> 3
            "neck_flexion": -10,  # in extension -> 4
            "trunk_flexion": -10,  # extension: scored 2 (common choice)
            "one_leg_stance": 1,  # weight not evenly balanced -> 2
        },
        upper_arm_flexion=None,
    )
    p = p.drop(columns=["upper_arm_flexion", "elbow_flexion", "wrist_flexion"])
    s = score_rula(p)
    assert one(s, "left_rula_upper_arm") == 1
    assert one(s, "left_rula_upper_arm_adjust") == -1
    assert one(s, "left_rula_lower_arm") == 2
    assert one(s, "left_rula_wrist") == 3
    assert one(s, "left_rula_table_a") == 3  # UA1 LA2 W3T1
    assert one(s, "right_rula_upper_arm") == 5
    assert one(s, "right_rula_lower_arm") == 1
    assert one(s, "right_rula_wrist") == 3
    assert one(s, "right_rula_table_a") == 5  # UA5 LA1 W3T1
    assert one(s, "rula_force") == 3
    assert one(s, "left_rula_score_c") == 7  # 3 + 1 + 3
    assert one(s, "right_rula_score_c") == 9  # 5 + 1 + 3 (row 8+)
    assert one(s, "rula_neck") == 4 and one(s, "rula_trunk") == 2 and one(s, "rula_legs") == 2
    assert one(s, "rula_table_b") == 6  # N4 T2L2
    assert one(s, "rula_score_d") == 10  # 6 + 1 + 3 (column 7+)
    assert one(s, "left_rula_grand") == 7 and one(s, "right_rula_grand") == 7
    assert one(s, "rula_grand") == 7
    assert one(s, "rula_worse_side") == "right"  # tie on the grand score: the higher score C


def test_rula_worse_side_is_the_higher_grand_score():
    p = posture({"left_upper_arm_flexion": 100, "right_upper_arm_flexion": 0}).drop(columns="upper_arm_flexion")
    s = score_rula(p)
    assert one(s, "left_rula_grand") > one(s, "right_rula_grand")
    assert one(s, "rula_grand") == one(s, "left_rula_grand")
    assert one(s, "rula_worse_side") == "left"


def test_rula_force_rules():
    rows = [
        {"load_kg": 0},
        {"load_kg": 1.99},
        {"load_kg": 2},  # 0, 0, 1
        {"load_kg": 10},
        {"load_kg": 10.01},  # 1, 2
        {"load_kg": 5, "load_mode": "static"},
        {"load_kg": 5, "load_mode": "repeated"},  # 2, 2
        {"load_kg": 11, "load_mode": "repeated"},
        {"load_kg": 1, "shock": 1},  # 3, 3
        {"load_kg": 1, "load_mode": "static"},  # 0 (< 2 kg)
    ]
    s = score_rula(posture(rows))
    assert s["rula_force"].tolist() == [0, 0, 1, 1, 2, 2, 2, 3, 3, 0]


# ----------------------------------------------------------------------- REBA worksheets


def test_reba_worksheet_very_high():
    p = posture(
        {
            "neck_flexion": 25,
            "neck_twisted": 1,  # step 1: > 20 -> 2; 1a: +1 -> 3
            "trunk_flexion": 30,
            "trunk_side_bent": 1,  # step 2: 20-60 -> 3; 2a: +1 -> 4
            "knee_flexion": 45,  # step 3: bilateral -> 1; 3a: 30-60 +1 -> 2
            "load_kg": 7,
            "shock": 1,  # step 5: 5-10 kg -> 1, shock +1 -> 2
            "upper_arm_flexion": 60,
            "upper_arm_abducted": 1,
            "shoulder_raised": 1,  # 3 +1 +1 -> 5
            "elbow_flexion": 40,  # step 8: < 60 -> 2
            "wrist_flexion": 20,
            "wrist_deviated": 1,  # step 9: > 15 -> 2; 9a: +1 -> 3
            "coupling": "poor",  # step 11: 2
            "static_posture": 1,
            "repeated_action": 1,  # step 13: +1 +1
        }
    )
    s = score_reba(p)
    assert one(s, "reba_neck") == 3 and one(s, "reba_trunk") == 4
    assert one(s, "reba_legs_band") == 1 and one(s, "reba_knee") == 1 and one(s, "reba_legs") == 2
    assert one(s, "reba_table_a") == 7  # Table A row T4, column N3L2
    assert one(s, "reba_load") == 2
    assert one(s, "reba_score_a") == 9
    for side in ("left_", "right_"):
        assert one(s, f"{side}reba_upper_arm") == 5
        assert one(s, f"{side}reba_lower_arm") == 2
        assert one(s, f"{side}reba_wrist") == 3
        assert one(s, f"{side}reba_table_b") == 8  # Table B row UA5, column LA2W3
    assert one(s, "reba_table_b") == 8
    assert one(s, "reba_coupling") == 2
    assert one(s, "reba_score_b") == 10
    assert one(s, "reba_table_c") == 12  # Table C row A9, column B10
    assert one(s, "reba_activity") == 2
    assert one(s, "reba_score") == 14
    assert one(s, "reba_risk_level") == 4


def test_reba_worksheet_negligible():
    p = posture(
        {
            "neck_flexion": 10,
            "trunk_flexion": 3,
            "knee_flexion": 10,
            "load_kg": 2,
            "upper_arm_flexion": 15,
            "elbow_flexion": 80,
            "wrist_flexion": 5,
            "coupling": "good",
        }
    )
    s = score_reba(p)
    assert [one(s, c) for c in ("reba_neck", "reba_trunk", "reba_legs", "reba_table_a", "reba_load")] == [1, 1, 1, 1, 0]
    assert one(s, "reba_table_b") == 1 and one(s, "reba_score_b") == 1
    assert one(s, "reba_table_c") == 1 and one(s, "reba_score") == 1 and one(s, "reba_risk_level") == 0


def test_reba_worksheet_seated_sides_differ_on_boundaries():
    p = posture(
        {
            "seated": 1,
            "knee_flexion": 90,  # sitting: legs 1, no knee adjustment
            "neck_flexion": -10,  # in extension -> 2
            "trunk_flexion": -25,  # > 20 extension -> 3
            "load_kg": 10,  # exactly 10 kg: "5-10 kg" -> 1
            "left_upper_arm_flexion": 20,
            "left_elbow_flexion": 60,
            "left_wrist_flexion": 15,  # 1, 1, 1
            "right_upper_arm_flexion": 90,
            "right_elbow_flexion": 100,
            "right_wrist_flexion": -16,  # 3, 1, 2
            "coupling": "fair",
            "rapid_change": 1,
        }
    ).drop(columns=["upper_arm_flexion", "elbow_flexion", "wrist_flexion"])
    s = score_reba(p)
    assert one(s, "reba_knee") == 0 and one(s, "reba_legs") == 1
    assert one(s, "reba_neck") == 2 and one(s, "reba_trunk") == 3
    assert one(s, "reba_table_a") == 4  # T3 N2L1
    assert one(s, "reba_load") == 1 and one(s, "reba_score_a") == 5
    assert one(s, "left_reba_table_b") == 1  # UA1 LA1 W1
    assert one(s, "right_reba_upper_arm") == 3 and one(s, "right_reba_wrist") == 2
    assert one(s, "right_reba_table_b") == 4  # UA3 LA1 W2
    assert one(s, "reba_table_b") == 4 and one(s, "reba_worse_side") == "right"
    assert one(s, "reba_score_b") == 5
    assert one(s, "reba_table_c") == 6  # A5 B5
    assert one(s, "reba_activity") == 1 and one(s, "reba_score") == 7 and one(s, "reba_risk_level") == 2


def test_reba_legs_stance():
    rows = [
        {"one_leg_stance": 1},  # unilateral -> 2
        {"one_leg_stance": 1, "walking": 1},  # walking -> 1
        {"one_leg_stance": 1, "seated": 1},  # sitting -> 1
        {"one_leg_stance": 0, "knee_flexion": 70},  # bilateral, knee > 60: +2 -> 3
        {"one_leg_stance": 1, "knee_flexion": 70},  # 2 + 2 = 4
    ]
    s = score_reba(posture(rows))
    assert s["reba_legs"].tolist() == [2, 1, 1, 3, 4]


# -------------------------------------------------------------------- settled boundaries

RULA_BANDS = [
    # column of the score, angle column, angle (deg), expected band
    ("rula_upper_arm_band", "upper_arm_flexion", -20, 1),
    ("rula_upper_arm_band", "upper_arm_flexion", -20.01, 2),
    ("rula_upper_arm_band", "upper_arm_flexion", 90, 4),
    ("rula_upper_arm_band", "upper_arm_flexion", 89.99, 3),
    ("rula_lower_arm_band", "elbow_flexion", 60, 1),
    ("rula_lower_arm_band", "elbow_flexion", 59.99, 2),
    ("rula_lower_arm_band", "elbow_flexion", 100, 1),
    ("rula_lower_arm_band", "elbow_flexion", 100.01, 2),
    ("rula_wrist_band", "wrist_flexion", 15, 3),
    ("rula_wrist_band", "wrist_flexion", 14.99, 2),
    ("rula_wrist_band", "wrist_flexion", -15, 3),
    ("rula_wrist_band", "wrist_flexion", -14.99, 2),
    ("rula_neck_band", "neck_flexion", 20, 3),
    ("rula_neck_band", "neck_flexion", 19.99, 2),
    ("rula_trunk_band", "trunk_flexion", 60, 4),
    ("rula_trunk_band", "trunk_flexion", 59.99, 3),
]
REBA_BANDS = [
    ("reba_neck_band", "neck_flexion", 20, 1),
    ("reba_neck_band", "neck_flexion", 20.01, 2),
    ("reba_trunk_band", "trunk_flexion", 60, 3),
    ("reba_trunk_band", "trunk_flexion", 60.01, 4),
    ("reba_trunk_band", "trunk_flexion", -20, 2),
    ("reba_trunk_band", "trunk_flexion", -20.01, 3),
    ("reba_upper_arm_band", "upper_arm_flexion", 90, 3),
    ("reba_upper_arm_band", "upper_arm_flexion", 90.01, 4),
    ("reba_upper_arm_band", "upper_arm_flexion", -20, 1),
    ("reba_upper_arm_band", "upper_arm_flexion", -20.01, 2),
    ("reba_wrist_band", "wrist_flexion", 15, 1),
    ("reba_wrist_band", "wrist_flexion", 15.01, 2),
    ("reba_wrist_band", "wrist_flexion", -15, 1),
    ("reba_wrist_band", "wrist_flexion", -15.01, 2),
    ("reba_lower_arm", "elbow_flexion", 60, 1),
    ("reba_lower_arm", "elbow_flexion", 59.99, 2),
    ("reba_lower_arm", "elbow_flexion", 100, 1),
    ("reba_lower_arm", "elbow_flexion", 100.01, 2),
    ("reba_knee", "knee_flexion", 60, 1),
    ("reba_knee", "knee_flexion", 60.01, 2),
]


def _band_value(scores: pd.DataFrame, column: str) -> int:
    if column in scores.columns:
        return one(scores, column)
    left, right = one(scores, "left_" + column), one(scores, "right_" + column)
    assert left == right
    return left


@pytest.mark.parametrize("column,angle,deg,expected", RULA_BANDS)
def test_rula_settled_boundaries(column, angle, deg, expected):
    assert _band_value(score_rula(posture({angle: deg})), column) == expected


@pytest.mark.parametrize("column,angle,deg,expected", REBA_BANDS)
def test_reba_settled_boundaries(column, angle, deg, expected):
    assert _band_value(score_reba(posture({angle: deg})), column) == expected


def test_reba_load_boundaries():
    s = score_reba(posture([{"load_kg": kg} for kg in (4.99, 5, 10, 10.01)]))
    assert s["reba_load"].tolist() == [0, 1, 1, 2]


OPEN = [
    # method, column, angle, deg, default, other setting
    ("rula", "rula_upper_arm_band", "upper_arm_flexion", 20, 2, 1),
    ("rula", "rula_upper_arm_band", "upper_arm_flexion", 45, 3, 2),
    ("rula", "rula_neck_band", "neck_flexion", 10, 2, 1),
    ("rula", "rula_trunk_band", "trunk_flexion", 20, 3, 2),
    ("reba", "reba_trunk_band", "trunk_flexion", 20, 2, 3),
    ("reba", "reba_upper_arm_band", "upper_arm_flexion", 20, 1, 2),
    ("reba", "reba_upper_arm_band", "upper_arm_flexion", 45, 2, 3),
    ("reba", "reba_knee", "knee_flexion", 30, 0, 1),
]


@pytest.mark.parametrize("method,column,angle,deg,default,other", OPEN)
def test_open_boundaries_follow_the_setting(method, column, angle, deg, default, other):
    scorer = score_rula if method == "rula" else score_reba
    p = posture({angle: deg})
    assert _band_value(scorer(p), column) == default
    flip = {"rula": {"rula_open_boundary": "lower"}, "reba": {"reba_open_boundary": "higher"}}[method]
    assert _band_value(scorer(p, ScoringSettings(**flip)), column) == other
    # away from the edge the setting changes nothing
    q = posture({angle: deg + 0.5})
    assert _band_value(scorer(q), column) == _band_value(scorer(q, ScoringSettings(**flip)), column)


TOLERANCES = [
    ("rula", "rula_wrist_band", "wrist_flexion", [5, 5.01, -5, -5.01], [1, 2, 1, 2], "wrist_neutral_deg"),
    ("rula", "rula_trunk_band", "trunk_flexion", [5, 5.01, -5, -5.01], [1, 2, 1, 2], "trunk_upright_deg"),
    ("rula", "rula_neck_band", "neck_flexion", [-5, -5.01], [1, 4], "neck_extension_deg"),
    ("reba", "reba_trunk_band", "trunk_flexion", [5, 5.01, -5, -5.01], [1, 2, 1, 2], "trunk_upright_deg"),
    ("reba", "reba_neck_band", "neck_flexion", [-5, -5.01], [1, 2], "neck_extension_deg"),
]


@pytest.mark.parametrize("method,column,angle,degs,expected,setting", TOLERANCES)
def test_neutral_tolerances(method, column, angle, degs, expected, setting):
    scorer = score_rula if method == "rula" else score_reba
    s = scorer(posture([{angle: d} for d in degs]))
    got = s[column] if column in s.columns else s["left_" + column]
    assert got.tolist() == expected
    # with no tolerance, anything off the single point leaves the neutral band
    s0 = scorer(posture([{angle: d} for d in degs]), ScoringSettings(**{setting: 0.0}))
    got0 = s0[column] if column in s0.columns else s0["left_" + column]
    assert all(g > 1 for g, d in zip(got0.tolist(), degs))


# ------------------------------------------------------------------------- flags


def test_flag_columns_override_flags_derived_from_angles():
    rows = [
        {"shoulder_elevation": 15},  # derived: raised (> 10) -> +1
        {"shoulder_elevation": 15, "shoulder_raised": 0},  # given 0 wins
        {"shoulder_elevation": 5, "shoulder_raised": 1},  # given 1 wins
        {"shoulder_elevation": 5},  # not raised
        {"shoulder_elevation": 10},  # exactly the threshold: not above it
    ]
    frame = posture(rows)
    frame.loc[[0, 3, 4], "shoulder_raised"] = np.nan
    s = score_rula(frame)
    assert s["left_rula_upper_arm_adjust"].tolist() == [1, 0, 1, 0, 0]


def test_twist_side_bend_and_abduction_derived_from_angles():
    rows = [
        {
            "trunk_twist": 12,
            "trunk_side_bend": -12,
            "neck_twist": -3,
            "neck_side_bend": 11,
            "upper_arm_abduction": 35,
            "wrist_deviation": -12,
        }
    ]
    s = score_rula(posture(rows))
    assert one(s, "rula_trunk_adjust") == 2  # twisted + side-bent (RULA: they add)
    assert one(s, "rula_neck_adjust") == 1  # side-bent only
    assert one(s, "left_rula_upper_arm_adjust") == 1  # abducted (> 30)
    assert one(s, "left_rula_wrist_adjust") == 1  # deviated (|-12| > 10)
    r = score_reba(posture(rows))
    assert one(r, "reba_trunk_adjust") == 1  # REBA: a single +1
    assert one(r, "left_reba_wrist_adjust") == 1


def test_across_midline_or_out_to_the_side_from_wrist_position():
    rows = [
        {"wrist_lateral_m": -0.10},
        {"wrist_lateral_m": 0.50},
        {"wrist_lateral_m": 0.10},
        {"wrist_lateral_m": -0.10, "arm_across_midline_or_out": 0},
    ]
    frame = posture(rows)
    frame.loc[[0, 1, 2], "arm_across_midline_or_out"] = np.nan
    s = score_rula(frame)
    assert s["left_rula_lower_arm_adjust"].tolist() == [1, 1, 0, 0]


def test_worksheet_variants_as_settings():
    p = posture(
        {
            "arm_across_midline": 1,
            "arm_out_to_side": 1,
            "elbow_flexion": 40,
            "neck_flexion": 25,
            "neck_twisted": 1,
            "neck_side_bent": 1,
            "trunk_flexion": 70,
            "trunk_twisted": 1,
            "trunk_side_bent": 1,
        }
    )
    single = score_rula(p)
    separate = score_rula(p, ScoringSettings(rula_lower_arm_adjust="separate"))
    assert one(single, "left_rula_lower_arm") == 3  # 2 + one +1
    assert one(separate, "left_rula_lower_arm") == 4  # 2 + 1 + 1: beyond Table A's rows
    assert one(separate, "left_rula_table_a") == one(single, "left_rula_table_a")  # row 3 is the last
    r1 = score_reba(p)
    r2 = score_reba(p, ScoringSettings(reba_twist_side_adjust="separate"))
    assert one(r1, "reba_neck") == 3 and one(r2, "reba_neck") == 4
    assert one(r1, "reba_trunk") == 5 and one(r2, "reba_trunk") == 6
    assert one(r2, "reba_table_a") == one(r1, "reba_table_a")  # last row and column


def test_muscle_use_hold_variant_changes_only_derived_flags():
    # the 10-minute variant needs longer holds; given flags are unaffected
    p = posture({"static_posture": 1})
    assert one(score_rula(p, ScoringSettings(rula_static_hold_s=600)), "left_rula_muscle") == 1


# ---------------------------------------------------------------- missing joints, unknowns


def test_missing_joint_leaves_its_steps_missing_not_guessed():
    p = posture([{"left_upper_arm_flexion": 30, "right_upper_arm_flexion": 30}] * 2).drop(columns="upper_arm_flexion")
    p.loc[1, "left_upper_arm_flexion"] = np.nan
    s = score_rula(p)
    assert pd.isna(s.loc[1, "left_rula_upper_arm_band"]) and pd.isna(s.loc[1, "left_rula_upper_arm"])
    assert pd.isna(s.loc[1, "left_rula_upper_arm_adjust"])
    assert pd.isna(s.loc[1, "left_rula_table_a"]) and pd.isna(s.loc[1, "left_rula_grand"])
    assert pd.isna(s.loc[1, "rula_grand"]) and pd.isna(s.loc[1, "rula_worse_side"])
    assert one(s, "right_rula_grand", 1) == one(s, "right_rula_grand", 0)  # the other side still scores
    assert one(s, "rula_table_b", 1) == one(s, "rula_table_b", 0)
    assert s["left_rula_grand"].dtype == s["rula_grand"].dtype
    assert str(s["rula_grand"].dtype).startswith("Int")


def test_missing_trunk_leaves_group_b_and_all_grands_missing():
    p = posture([{"trunk_flexion": 10}, {"trunk_flexion": np.nan}])
    s = score_rula(p)
    assert pd.isna(s.loc[1, "rula_trunk"]) and pd.isna(s.loc[1, "rula_table_b"]) and pd.isna(s.loc[1, "rula_score_d"])
    assert pd.isna(s.loc[1, "left_rula_grand"]) and not pd.isna(s.loc[1, "left_rula_table_a"])
    r = score_reba(p)
    assert pd.isna(r.loc[1, "reba_table_a"]) and pd.isna(r.loc[1, "reba_score"])
    assert not pd.isna(r.loc[1, "reba_table_b"])


def test_one_missing_knee_leaves_reba_legs_missing_unless_seated():
    p = posture(
        [
            {"left_knee_flexion": 20, "right_knee_flexion": np.nan},
            {"left_knee_flexion": 20, "right_knee_flexion": np.nan, "seated": 1},
        ]
    ).drop(columns="knee_flexion")
    s = score_reba(p)
    assert pd.isna(s.loc[0, "reba_legs"])
    assert one(s, "reba_legs", 1) == 1


def test_unknown_flags_absent_or_missing():
    p = posture({"upper_arm_flexion": 30})
    p["shoulder_raised"] = np.nan
    absent = score_rula(p)
    assert one(absent, "left_rula_upper_arm") == 2
    assert one(absent, "rula_unknown_flags") > 0
    missing = score_rula(p, ScoringSettings(unknown_flags="missing"))
    assert pd.isna(missing.loc[0, "left_rula_upper_arm"]) and pd.isna(missing.loc[0, "rula_grand"])
    # every flag given: nothing assumed
    full = posture(
        {
            "upper_arm_flexion": 30,
            "shoulder_raised": 0,
            "upper_arm_abducted": 0,
            "arm_supported": 0,
            "arm_across_midline_or_out": 0,
            "wrist_deviated": 0,
            "wrist_twist_end_range": 0,
            "neck_twisted": 0,
            "neck_side_bent": 0,
            "trunk_twisted": 0,
            "trunk_side_bent": 0,
            "legs_supported": 1,
            "load_kg": 0,
            "load_mode": "intermittent",
            "shock": 0,
        }
    )
    assert one(score_rula(full), "rula_unknown_flags") == 0
    assert one(score_rula(full, ScoringSettings(unknown_flags="missing")), "rula_grand") == 2


def test_unknown_load_under_missing_policy():
    p = posture([{"load_kg": np.nan}, {"load_kg": 3}])
    s = score_reba(p, ScoringSettings(unknown_flags="missing"))
    assert pd.isna(s.loc[0, "reba_load"]) and pd.isna(s.loc[0, "reba_score"])


def test_columns_and_dtypes():
    s = score_posture(posture([{}, {}]))
    assert list(s.columns) == rula_columns() + reba_columns()
    for c in s.columns:
        if not c.endswith("worse_side"):
            assert str(s[c].dtype).startswith("Int"), c


@pytest.mark.slow
def test_rows_score_independently_of_their_neighbours(rng):
    """Scoring a table equals scoring each row alone (no leakage between rows without a time series)."""
    rows = []
    for _ in range(12):
        rows.append(
            {
                "upper_arm_flexion": rng.uniform(-40, 120),
                "elbow_flexion": rng.uniform(0, 150),
                "wrist_flexion": rng.uniform(-40, 40),
                "neck_flexion": rng.uniform(-20, 40),
                "trunk_flexion": rng.uniform(-30, 90),
                "knee_flexion": rng.uniform(0, 100),
                "load_kg": rng.uniform(0, 15),
                "shoulder_raised": float(rng.integers(2)),
            }
        )
    frame = posture(rows)
    whole = score_posture(frame)
    for i in range(len(rows)):
        alone = score_posture(frame.iloc[[i]])
        pd.testing.assert_frame_equal(whole.iloc[[i]], alone)


def test_input_errors_name_the_columns():
    with pytest.raises(InputError, match="missing column.*left_knee_flexion, right_knee_flexion"):
        score_reba(posture({}).drop(columns="knee_flexion"))
    with pytest.raises(InputError, match="unknown column.*elbow_angle"):
        score_rula(posture({}).assign(elbow_angle=1.0))
    with pytest.raises(InputError, match="either the unprefixed"):
        score_rula(posture({}).assign(left_wrist_flexion=0.0))
    with pytest.raises(InputError, match=r"coupling: row 1: 'great'"):
        score_reba(posture({"coupling": "great"}))
    with pytest.raises(InputError, match=r"trunk_flexion: row 1: .* outside"):
        score_reba(posture({}).assign(trunk_flexion=4.0))


def test_time_series_order_is_checked():
    p = posture([{}, {}, {}]).drop(columns=list(NO_ACTIVITY))
    p["time_s"] = [0.0, 2.0, 1.0]
    with pytest.raises(InputError, match="time_s.*row 3"):
        score_rula(p)
