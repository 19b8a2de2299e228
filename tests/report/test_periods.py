"""The sustained-period finder (ergopose.report.periods) against hand-made score series."""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.report.periods import high_frames, sustained_periods, worker_periods


def series(pattern: str, fps: float = 1.0):
    """'H' = high frame, '.' = low frame, ' ' = not tracked (no frame): times at 1/fps steps."""
    t = np.array([k / fps for k, c in enumerate(pattern) if c != " "])
    high = np.array([c == "H" for c in pattern if c != " "])
    return t, high


def spans(periods):
    return [(p.start_s, p.end_s, p.high_s) for p in periods]


def test_one_frame_spikes_are_not_periods():
    t, high = series("..H...H....H..")
    assert sustained_periods(t, high, 1.0) == []


def test_a_run_of_ten_seconds():
    t, high = series("...HHHHHHHHHH...")
    assert spans(sustained_periods(t, high, 1.0)) == [(3.0, 13.0, 10.0)]


def test_short_gaps_join_and_long_gaps_split():
    # 3 s high, 2 s low, 3 s high: the 2 s gap joins them (8 s, 6 s high)
    t, high = series("HHH..HHH")
    assert spans(sustained_periods(t, high, 1.0)) == [(0.0, 8.0, 6.0)]
    # a 3 s gap splits them, and each 3 s piece is too short
    t, high = series("HHH...HHH")
    assert sustained_periods(t, high, 1.0) == []
    # untracked time counts as a gap like low frames do
    t, high = series("HHH  HHH")
    assert spans(sustained_periods(t, high, 1.0)) == [(0.0, 8.0, 6.0)]
    t, high = series("HHH   HHH")
    assert sustained_periods(t, high, 1.0) == []


def test_minimum_duration_is_inclusive_and_settable():
    t, high = series("HHHHH")
    assert spans(sustained_periods(t, high, 1.0)) == [(0.0, 5.0, 5.0)]
    t, high = series("HHHH")
    assert sustained_periods(t, high, 1.0) == []
    assert spans(sustained_periods(t, high, 1.0, min_duration_s=4.0)) == [(0.0, 4.0, 4.0)]


def test_ranked_by_time_at_high_risk_then_start():
    #        0         1         2         3         4
    #        0123456789012345678901234567890123456789012345
    t, high = series("HHHHHH.......HHHHHHHHH......HHHHHH.....HH.HHHH")
    got = spans(sustained_periods(t, high, 1.0))
    assert got == [(13.0, 22.0, 9.0), (0.0, 6.0, 6.0), (28.0, 34.0, 6.0), (39.0, 46.0, 6.0)]


def test_frame_period_scales_the_rule():
    # 12 fps: 59 high frames = 4.92 s (too short), 60 = 5 s (kept); a 24-frame gap (2 s) joins
    t, high = series("H" * 59, fps=12.0)
    assert sustained_periods(t, high, 1 / 12) == []
    t, high = series("H" * 30 + "." * 24 + "H" * 30, fps=12.0)
    (p,) = sustained_periods(t, high, 1 / 12)
    assert (p.start, p.stop) == (0, 84)
    assert p.duration_s == pytest.approx(7.0) and p.high_s == pytest.approx(5.0)
    t, high = series("H" * 30 + "." * 25 + "H" * 30, fps=12.0)
    assert sustained_periods(t, high, 1 / 12) == []


def test_drawn_frame_is_the_middle_of_the_longest_held_posture():
    t, high = series("HHHHHHHHHHHH")
    held = np.array([5, 5, 6, 6, 6, 6, 6, 6, 7, 7, 7, 7])
    (p,) = sustained_periods(t, high, 1.0, held=held)
    assert p.drawn == 4  # run 2..7 (6 frames): middle = 2 + (6 - 1) // 2
    held = np.array([5, 5, 5, 6, 6, 6, 7, 7, 7, 8, 8, 8])
    (p,) = sustained_periods(t, high, 1.0, held=held)
    assert p.drawn == 1  # ties: the first run


def test_high_frames_and_worker_periods_from_scores():
    nan = np.nan
    rula_level = np.array([1, 3, 3, 3, nan, 2, 2, 2, 2, 2, 2, 2])
    reba_level = np.array([1, 2, 2, 2, nan, 3, 4, 1, 1, 1, 1, 1])
    assert high_frames(rula_level, reba_level).tolist() == [False, True, True, True, False, True, True] + [False] * 5
    t = np.arange(12.0)
    grand = np.array([2, 5, 5, 6, nan, 4, 4, 3, 3, 3, 3, 3])
    reba = np.array([2, 6, 6, 7, nan, 8, 11, 3, 3, 3, 3, 3])
    (p,) = worker_periods(t, grand, rula_level, reba, reba_level, 1.0)
    assert (p.start_s, p.end_s, p.high_s, p.drawn) == (1.0, 7.0, 5.0, 1)


def test_a_long_shift_keeps_every_high_second():
    rng = np.random.default_rng(3)
    n = 12 * 3600 * 8
    high = np.zeros(n, dtype=bool)
    starts = rng.choice(n - 200, 300, replace=False)
    for s in starts:  # building the series, not the code under test
        high[s : s + 120] = True
    t = np.arange(n) / 12.0
    got = sustained_periods(t, high, 1 / 12)
    assert sum(p.high_s for p in got) == pytest.approx(high.sum() / 12)


def _period_rows():
    """Ten high frames (0.5 s each) of a period: 12 kg held static for the first six, nothing given
    for the last four; the arm supported throughout; seated given as no for five frames; the left
    wrist flexion given by the settings (20 deg) in the three frames where the hand was not seen."""
    import pandas as pd

    nan = np.nan
    return pd.DataFrame(
        {
            "load_kg": [12.0] * 6 + [nan] * 4,
            "load_mode": pd.array(["static"] * 6 + [None] * 4, dtype="string"),
            "coupling": pd.array([None] * 10, dtype="string"),
            "shock": [nan] * 10,
            "arm_supported": [1.0] * 10,
            "seated": [0.0] * 5 + [nan] * 5,
            "legs_supported": [nan] * 10,
            "wrist_twist_end_range": [nan] * 10,
            "inputs_from_settings": pd.array(["left_wrist_flexion"] * 3 + [""] * 7, dtype="string"),
            "left_wrist_flexion": [np.radians(20.0)] * 3 + [0.3] * 7,
            "right_wrist_flexion": [0.1] * 10,
            "left_wrist_deviation": [0.0] * 10,
            "right_wrist_deviation": [0.0] * 10,
        }
    )


def test_a_period_names_its_task_inputs_and_what_was_measured():
    from ergopose.report.periods import MEASURED_INPUTS, InputUse, period_inputs

    got = period_inputs(_period_rows(), 0.5)
    assert got == (
        InputUse("angles", "measured", None, 5.0, MEASURED_INPUTS),
        InputUse("left_wrist_flexion", "task input", pytest.approx(np.radians(20.0)), 1.5),
        InputUse("load", "task input", (12.0, "static"), 3.0),
        InputUse("arm_supported", "task input", True, 5.0),
        InputUse("seated", "task input", False, 2.5),
        InputUse("load", "not given", None, 2.0),
        InputUse("coupling", "not given", None, 5.0),
        InputUse("shock", "not given", None, 5.0),
        InputUse("seated", "not given", None, 2.5),
        InputUse("legs_supported", "not given", None, 5.0),
        InputUse("wrist_twist_end_range", "not given", None, 5.0),
    )
    # results written before the inputs were read: only what the frames hold
    assert period_inputs(_period_rows()[["load_kg"]], 0.5) == (
        InputUse("angles", "measured", None, 5.0, MEASURED_INPUTS),
    )
    assert period_inputs(_period_rows().iloc[0:0], 0.5) == ()


def test_the_report_words_of_a_period_s_inputs():
    from ergopose.report.adapters import period_input_records
    from ergopose.report.pages import task_inputs_line
    from ergopose.report.periods import period_inputs

    records = period_input_records(period_inputs(_period_rows(), 0.5))
    words = [(r.input, r.source, r.value, r.seconds) for r in records]
    assert words[0] == ("angles of the upper arms, lower arms, wrists, neck, trunk, legs", "measured", "", 5.0)
    assert words[1] == ("left wrist flexion", "task input", "20° (flexion), where the hand was not seen", 1.5)
    assert words[2] == ("load", "task input", "12 kg, held static", 3.0)
    assert words[3] == ("arm supported or leaning", "task input", "yes", 5.0)
    assert ("hand coupling", "not given", "", 5.0) in words
    assert all(r.use for r in records)
    assert task_inputs_line(records, 5.0) == (
        "left wrist flexion: 20° (flexion), where the hand was not seen (1.5 s); load: 12 kg, held static (3.0 s); "
        "arm supported or leaning: yes; seated: no (2.5 s); not given: load, hand coupling, shock or rapid build-up "
        "of force, seated, legs and feet supported, wrist twisted near the end of its range"
    )
    assert task_inputs_line((), 5.0) == "not recorded"
