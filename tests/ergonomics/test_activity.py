"""Muscle use / activity from time series with known answers (holds, repetitions, rapid changes)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ergopose.ergonomics.activity import (
    Timeline,
    check_time,
    count_in_window,
    held,
    rapid_change,
    repetition_events,
    runs,
)
from ergopose.ergonomics.scoring import score_reba, score_rula
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.errors import InputError

FPS = 12.0


def _t(seconds: float, start: float = 0.0) -> np.ndarray:
    return start + np.arange(int(round(seconds * FPS))) / FPS


def test_holds_longer_than_the_hold_time():
    pieces = [(2.0, 61), (3.0, 59), (1.0, 70), (2.0, 30), (np.nan, 1 / FPS), (2.0, 40)]
    band = np.concatenate([np.full(int(round(d * FPS)), v) for v, d in pieces])
    t = np.arange(band.size) / FPS
    got = held(t, band, 60.0, max_gap_s=1.0, neutral=1.0)
    ends = np.cumsum([int(round(d * FPS)) for _, d in pieces])
    assert got[: ends[0]].all()  # 61 s in band 2: static
    assert not got[ends[0] : ends[1]].any()  # 59 s: not
    assert not got[ends[1] : ends[2]].any()  # 70 s in the neutral band: not counted
    assert not got[ends[2] :].any()  # 30 s + a missing frame + 40 s: the gap ends the hold
    with_neutral = held(t, band, 60.0, max_gap_s=1.0, neutral=None)
    assert with_neutral[ends[1] : ends[2]].all()


def test_a_time_gap_ends_a_hold():
    t = np.concatenate([_t(40), _t(40, start=42.0)])  # 2 s without frames in between
    band = np.full(t.size, 3.0)
    assert not held(t, band, 60.0, max_gap_s=1.0).any()
    assert held(t, band, 60.0, max_gap_s=3.0).all()


def test_runs_split_on_change_nan_and_gap():
    t = np.array([0, 1, 2, 3, 10, 11, 12.0])
    c = np.array([1, 1, 2, np.nan, 2, 2, 2.0])
    run_id, first, last = runs(t, c, max_gap_s=1.5)
    assert run_id.tolist() == [0, 0, 1, 2, 3, 3, 3]
    assert first.tolist() == [0, 2, 3, 4] and last.tolist() == [1, 2, 3, 6]


def test_repetitions_of_a_known_oscillation(rng):
    t = _t(120)
    x = np.deg2rad(20) * np.sin(2 * np.pi * t / 10.0)  # 40 degrees peak to peak, every 10 s
    ev = repetition_events(t, x, np.deg2rad(15), 60.0)
    assert ev.sum() == 12
    peaks = t[ev]
    np.testing.assert_allclose(peaks, 2.5 + 10 * np.arange(12), atol=1 / FPS)
    small = np.deg2rad(5) * np.sin(2 * np.pi * t / 10.0)  # 10 degrees peak to peak: below the amplitude
    assert repetition_events(t, small, np.deg2rad(15), 60.0).sum() == 0
    noisy = x + np.deg2rad(1.0) * rng.standard_normal(t.size)  # 1-degree noise adds no actions
    assert repetition_events(t, noisy, np.deg2rad(15), 60.0).sum() == 12


def test_a_gap_invents_no_action():
    t = _t(120)
    x = np.deg2rad(20) * np.sin(2 * np.pi * t / 10.0)
    x[(t > 30) & (t < 31)] = np.nan  # a short dropout inside a falling half-cycle
    assert repetition_events(t, x, np.deg2rad(15), 60.0).sum() == 12
    y = np.full(t.size, 0.3)
    y[::7] = np.nan
    assert repetition_events(t, y, np.deg2rad(15), 60.0).sum() == 0


def test_count_in_centred_window():
    t = np.arange(0, 100.0, 0.5)
    ev = np.isin(t, [10.0, 20.0, 30.0, 40.0, 50.0])
    c = count_in_window(t, ev, 60.0)
    assert c[t.tolist().index(30.0)] == 5  # [0, 60): all five
    assert c[t.tolist().index(70.0)] == 2  # [40, 100)
    assert c[t.tolist().index(79.5)] == 1  # [49.5, 109.5): 50
    assert c[t.tolist().index(80.0)] == 1  # [50, 110): the window's start is included
    assert c[t.tolist().index(80.5)] == 0  # [50.5, 110.5)
    # the window is half-open at its end: an event exactly 30 s ahead is not counted
    assert c[t.tolist().index(20.0)] == 4  # [-10, 50): 10, 20, 30, 40


def test_rapid_change_of_a_quick_step():
    t = _t(10)
    quick = np.where(t < 5, 0.0, np.deg2rad(40))  # a 40-degree step at 5 s
    got = rapid_change(t, quick, np.deg2rad(30), 1.0)
    inside = (t >= 4.0 - 1e-9) & (t <= 6.0)
    assert got[(t > 4.0 + 1e-6) & (t < 5.99)].all()  # every frame within 1 s of the step
    assert not got[~inside].any()
    slow = np.deg2rad(40) * np.clip((t - 2) / 3.0, 0, 1)  # 40 degrees over 3 s: 13.3 per second
    assert not rapid_change(t, slow, np.deg2rad(30), 1.0).any()
    small = np.where(t < 5, 0.0, np.deg2rad(20))
    assert not rapid_change(t, small, np.deg2rad(30), 1.0).any()


def test_rapid_change_irregular_frames_match_brute_force(rng):
    t = np.cumsum(rng.uniform(0.03, 0.2, 1500))
    x = np.deg2rad(rng.normal(0, 15, t.size))
    x[rng.random(t.size) < 0.1] = np.nan
    got = Timeline(t).rapid_change([x], np.deg2rad(30), 1.0)
    start = np.searchsorted(t, t - 1.0 - 1e-9)
    want = np.zeros(t.size, dtype=bool)
    for j, s in enumerate(start):
        w = x[s : j + 1]
        if np.any(~np.isnan(w)) and np.nanmax(w) - np.nanmin(w) > np.deg2rad(30):
            want[s : j + 1] = True
    np.testing.assert_array_equal(got, want)


def test_time_must_increase():
    with pytest.raises(InputError, match="row 3"):
        check_time(np.array([0.0, 1.0, 1.0]))
    with pytest.raises(InputError, match="row 2"):
        check_time(np.array([0.0, np.nan]))


# ---------------------------------------------------------------- through the scoring


def _series(seconds: float, **angles_deg) -> pd.DataFrame:
    t = _t(seconds)
    base = {
        "upper_arm_flexion": 0.0,
        "elbow_flexion": 80.0,
        "wrist_flexion": 0.0,
        "neck_flexion": 5.0,
        "trunk_flexion": 0.0,
        "knee_flexion": 0.0,
    }
    frame = {"time_s": t}
    for k, v in {**base, **angles_deg}.items():
        v = v(t) if callable(v) else np.full(t.size, v)
        frame[k] = np.deg2rad(v)
    return pd.DataFrame(frame)


def test_rula_muscle_use_from_a_held_trunk():
    p = _series(180, trunk_flexion=lambda t: np.where(t < 70, 30.0, np.where(t < 120, 0.0, 30.0)))
    s = score_rula(p)
    t = p["time_s"].to_numpy()
    assert (s["rula_static_b"][t < 70] == 1).all()  # 70 s at 20-60: static
    assert (s["rula_static_b"][(t >= 70) & (t < 120)] == 0).all()  # upright: neutral, not counted
    assert (s["rula_static_b"][t >= 120] == 0).all()  # only 60 s (to the end): not longer than 60
    assert (s["rula_muscle_b"][t < 70] == 1).all()
    assert (s["rula_score_d"][t < 70] == s["rula_table_b"][t < 70] + 1).all()
    assert (s["left_rula_static"] == 0).all()  # the arms did not hold a non-neutral band
    ten_minutes = score_rula(p, ScoringSettings(rula_static_hold_s=600))
    assert (ten_minutes["rula_static_b"] == 0).all()


def test_repetition_rate_4_per_minute_is_rula_but_not_reba():
    # wrist 0 <-> 30 degrees every 15 s: exactly 4 actions in every 60 s window
    p = _series(240, wrist_flexion=lambda t: 15 - 15 * np.cos(2 * np.pi * t / 15.0))
    t = p["time_s"].to_numpy()
    interior = (t > 45) & (t < 195)
    rula = score_rula(p)
    reba = score_reba(p)
    assert (rula["left_rula_repeated"][interior] == 1).all()  # "4 or more"
    assert (rula["rula_repeated_b"] == 0).all()  # neck and trunk did not move
    assert (reba["reba_repeated"][interior] == 0).all()  # "more than 4"
    faster = _series(240, wrist_flexion=lambda t: 15 - 15 * np.cos(2 * np.pi * t / 12.0))  # 5 per minute
    assert (score_reba(faster)["reba_repeated"][interior] == 1).all()


def test_walking_suppresses_reba_repetitions():
    p = _series(240, wrist_flexion=lambda t: 15 - 15 * np.cos(2 * np.pi * t / 10.0))
    p["walking"] = 1.0
    assert (score_reba(p)["reba_repeated"] == 0).all()
    assert score_rula(p)["left_rula_repeated"].max() == 1


def test_reba_rapid_change_from_a_quick_bend():
    p = _series(20, trunk_flexion=lambda t: np.where((t > 10) & (t < 14), 50.0, 0.0))
    s = score_reba(p)
    t = p["time_s"].to_numpy()
    assert (s["reba_rapid"][(t > 9.5) & (t < 10.5)] == 1).all()  # bending down within 1 s
    assert (s["reba_rapid"][(t > 13.5) & (t < 14.5)] == 1).all()  # and coming back up
    assert (s["reba_rapid"][t < 8.9] == 0).all() and (s["reba_rapid"][(t > 11.1) & (t < 12.9)] == 0).all()
    assert (s["reba_activity"] == s["reba_static"] + s["reba_repeated"] + s["reba_rapid"]).all()


def test_given_activity_flags_win_over_the_time_series():
    p = _series(180, trunk_flexion=30.0)
    p["static_posture"] = 0.0
    p.loc[:10, "static_posture"] = np.nan  # unknown there: derived
    s = score_rula(p)
    assert (s["rula_static_b"].iloc[:11] == 1).all()
    assert (s["rula_static_b"].iloc[11:] == 0).all()


def test_workers_are_separate_time_series():
    a = _series(70, trunk_flexion=30.0)
    b = _series(70, trunk_flexion=30.0)
    a["worker"] = "a"
    b["worker"] = "b"
    both = pd.concat([a, b.iloc[: int(50 * FPS)]], ignore_index=True)  # b holds only 50 s
    s = score_rula(both)
    assert (s["rula_static_b"][both["worker"] == "a"] == 1).all()
    assert (s["rula_static_b"][both["worker"] == "b"] == 0).all()
