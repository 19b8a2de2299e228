"""Shift aggregation on constructed time series with known answers; chunks give the same answer."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from ergopose.ergonomics.aggregate import ShiftAccumulator, aggregate_session, aggregate_shift, nominal_frame_period
from ergopose.errors import InputError

FPS = 12
P = 1.0 / FPS


def _segment(start: float, seconds: float, **cols) -> pd.DataFrame:
    n = int(round(seconds * FPS))
    frame = {"time_s": start + np.arange(n) / FPS}
    for k, v in cols.items():
        frame[k] = np.full(n, v, dtype=float)
    return pd.DataFrame(frame)


def _shift() -> pd.DataFrame:
    """A known RULA action-level series (seconds): see the expected values in the tests."""
    parts = [
        _segment(0, 30, rula_action_level=1, rula_grand=2),
        _segment(30, 90, rula_action_level=3, rula_grand=5),
        _segment(120, 6, rula_action_level=np.nan, rula_grand=np.nan),  # not scored
        _segment(126, 24, rula_action_level=3, rula_grand=5),
        # no frames from 150 to 160 s (tracking lost)
        _segment(160, 60, rula_action_level=4, rula_grand=7),
        _segment(220, 3480, rula_action_level=2, rula_grand=3),  # across the first hour
    ]
    frame = pd.concat(parts, ignore_index=True)
    frame.loc[frame.index[400], "rula_grand"] = 6  # one frame of 6 inside the 90 s hold
    frame["rep_left_wrist_flexion"] = 0.0
    events = 0.5 + 10.0 * np.arange(60)  # an action every 10 s for 10 minutes
    frame.loc[np.searchsorted(frame["time_s"].to_numpy(), events), "rep_left_wrist_flexion"] = 1.0
    for c in frame.columns:
        if c.startswith("rula_"):
            frame[c] = frame[c].astype("Int16")
    return frame


OBSERVED = (360 + 1080 + 72 + 288 + 720 + 41760) / FPS  # 3690 s


def test_time_per_level_and_percent():
    s = aggregate_shift(_shift(), "w1")
    assert s.frames == 44280 and s.frame_period_s == P
    assert s.observed_s == pytest.approx(OBSERVED)
    d = s.distributions["rula_action_level"]
    assert [v.value for v in d.values] == [1, 2, 3, 4]
    assert d.at(1).time_s == pytest.approx(30.0)
    assert d.at(3).time_s == pytest.approx(114.0)
    assert d.at(4).time_s == pytest.approx(60.0)
    assert d.at(2).time_s == pytest.approx(3480.0)
    assert d.missing_time_s == pytest.approx(6.0) and d.missing_frames == 72
    assert d.at(3).percent == pytest.approx(100 * 114 / OBSERVED)
    assert sum(v.percent for v in d.values) + d.missing_percent == pytest.approx(100.0)
    assert d.at(5).time_s == 0.0 and math.isnan(d.at(5).longest_hold_start_s)


def test_longest_holds():
    d = aggregate_shift(_shift()).distributions["rula_action_level"]
    assert d.at(3).holds == 2  # broken by the unscored frames
    assert d.at(3).longest_hold_s == pytest.approx(90.0) and d.at(3).longest_hold_start_s == pytest.approx(30.0)
    assert d.at(4).longest_hold_s == pytest.approx(60.0) and d.at(4).longest_hold_start_s == pytest.approx(160.0)
    assert d.at(2).longest_hold_s == pytest.approx(3480.0)
    g = aggregate_shift(_shift()).distributions["rula_grand"]
    assert g.at(5).holds == 3  # the single 6 splits the first hold


def test_a_gap_in_the_frames_ends_a_hold():
    frame = pd.concat([_segment(0, 30, rula_action_level=3), _segment(32, 30, rula_action_level=3)], ignore_index=True)
    d = aggregate_shift(frame).distributions["rula_action_level"]
    assert d.at(3).holds == 2 and d.at(3).longest_hold_s == pytest.approx(30.0)
    from ergopose.ergonomics.settings import ScoringSettings

    d = aggregate_shift(frame, settings=ScoringSettings(max_gap_s=3.0)).distributions["rula_action_level"]
    assert d.at(3).holds == 1 and d.at(3).longest_hold_s == pytest.approx(62.0)


def test_hourly_breakdown():
    s = aggregate_shift(_shift())
    hours = [h for h in s.hourly if h.column == "rula_action_level"]
    assert [h.hour for h in hours] == [0, 1]
    h0, h1 = hours
    assert h0.observed_s == pytest.approx(3590.0) and h1.observed_s == pytest.approx(100.0)
    assert h0.time_by_value[2] == pytest.approx(3380.0) and h1.time_by_value == {2: pytest.approx(100.0)}
    assert h0.time_by_value[4] == pytest.approx(60.0) and h0.missing_s == pytest.approx(6.0)
    assert h1.percent(2) == pytest.approx(100.0)


def test_worst_episodes_with_timestamps():
    eps = aggregate_shift(_shift()).episodes["rula_action_level"]
    got = [(e.level, round(e.start_s, 6), round(e.end_s, 6), round(e.duration_s, 6), e.peak_score) for e in eps]
    assert got == [
        (4, 160.0, 220.0, 60.0, 7),
        (3, 30.0, 120.0, 90.0, 6),
        (3, 126.0, 150.0, 24.0, 5),
        (2, 220.0, 3700.0, 3480.0, 3),
        (1, 0.0, 30.0, 30.0, 2),
    ]


def test_repetitions_per_minute():
    reps = aggregate_shift(_shift()).repetitions
    assert len(reps) == 1
    r = reps[0]
    assert r.angle == "left_wrist_flexion" and r.actions == 60
    assert r.per_minute == pytest.approx(60 / (OBSERVED / 60))
    assert r.max_in_one_minute == 6 and r.minutes_at_or_above_4 == 10


@pytest.mark.parametrize("chunk", [1000, 977, 1440, 5000])
def test_chunks_give_the_same_answer(chunk):
    whole = aggregate_shift(_shift(), "w1")
    assert aggregate_shift(_shift(), "w1", chunk_frames=chunk) == whole


@pytest.mark.slow
def test_single_frame_chunks_on_a_short_series():
    frame = _shift().iloc[:2000]
    assert aggregate_shift(frame, chunk_frames=1, frame_period_s=P) == aggregate_shift(frame, frame_period_s=P)


def test_chunks_out_of_order_are_refused():
    acc = ShiftAccumulator()
    frame = _shift()
    acc.add(frame.iloc[100:200])
    with pytest.raises(InputError, match="not after the previous chunk"):
        acc.add(frame.iloc[:100])


def test_nominal_frame_period():
    assert nominal_frame_period(np.arange(100) / 12.0) == 1 / 12
    assert nominal_frame_period(np.arange(100) / 29.97) == 1 / 29.97
    assert nominal_frame_period(np.array([3.0])) == 0.0


# ----------------------------------------------------------------------------- exposure


def _angles(seconds: float, **deg) -> pd.DataFrame:
    base = {
        "trunk_flexion": 10.0,
        "neck_flexion": 10.0,
        "trunk_twist": 0.0,
        "trunk_side_bend": 0.0,
        "left_upper_arm_elevation": 10.0,
        "right_upper_arm_elevation": 10.0,
        "left_shoulder_raised": 0.0,
        "right_shoulder_raised": 0.0,
    }
    t = np.arange(int(seconds * FPS)) / FPS
    frame = {"time_s": t}
    for k, v in {**base, **deg}.items():
        x = v(t) if callable(v) else np.full(t.size, float(v))
        frame[k] = x if k.endswith("raised") else np.deg2rad(x)
    return pd.DataFrame(frame)


def _verdicts(frame: pd.DataFrame) -> dict[str, str]:
    return {f"{f.standard}|{f.body_part}": f.verdict for f in aggregate_shift(frame).exposure}


def test_iso_11226_static_holds():
    bump = lambda lo, hi, v, rest: lambda t: np.where((t >= lo) & (t < hi), v, rest)  # noqa: E731
    v = _verdicts(_angles(600))
    assert v["ISO 11226|trunk"] == "acceptable" and v["ISO 11226|neck"] == "acceptable"
    assert v["ISO 11226|left upper arm"] == "acceptable" and v["ISO 11226|left shoulder"] == "acceptable"
    assert _verdicts(_angles(600, trunk_flexion=bump(100, 105, 70, 10)))["ISO 11226|trunk"] == "not recommended"
    assert _verdicts(_angles(600, trunk_flexion=bump(100, 103, 70, 10)))["ISO 11226|trunk"] == "acceptable"  # 3 s
    assert _verdicts(_angles(600, trunk_flexion=bump(100, 110, 30, 10)))["ISO 11226|trunk"] == "time-limited"
    head = _verdicts(_angles(600, trunk_flexion=bump(100, 105, 30, 10), neck_flexion=bump(100, 105, 60, 10)))
    assert head["ISO 11226|head"] == "not recommended"  # 30 + 60 = 90 > 85
    assert head["ISO 11226|neck"] == "not recommended"  # neck flexion 60 > 25
    assert _verdicts(_angles(600, neck_flexion=bump(100, 105, -10, 10)))["ISO 11226|neck"] == "not recommended"
    arm = _verdicts(_angles(600, left_upper_arm_elevation=bump(100, 105, 70, 10)))
    assert arm["ISO 11226|left upper arm"] == "not recommended" and arm["ISO 11226|right upper arm"] == "acceptable"
    raised = _angles(600)
    raised.loc[(raised["time_s"] >= 100) & (raised["time_s"] < 105), "right_shoulder_raised"] = 1.0
    assert _verdicts(raised)["ISO 11226|right shoulder"] == "not recommended"


def test_en_1005_4_movement_frequency():
    def excursions(per_minute: float, value: float, rest: float = 10.0, length_s: float = 2.0):
        return lambda t: np.where((t % (60.0 / per_minute)) < length_s, value, rest)

    v = _verdicts(_angles(600, left_upper_arm_elevation=excursions(3, 30)))
    assert v["EN 1005-4|left upper arm"] == "conditionally acceptable"  # 3 movements/min into 20-60
    assert v["ISO 11226|left upper arm"] == "acceptable"  # 2 s: never static
    f = next(
        x
        for x in aggregate_shift(_angles(600, left_upper_arm_elevation=excursions(3, 30))).exposure
        if x.standard == "EN 1005-4" and x.body_part == "left upper arm"
    )
    assert f.entries == 30 and f.per_minute == pytest.approx(3.0)
    assert (
        _verdicts(_angles(600, left_upper_arm_elevation=excursions(1, 30)))["EN 1005-4|left upper arm"] == "acceptable"
    )
    assert (
        _verdicts(_angles(600, left_upper_arm_elevation=excursions(1, 70)))["EN 1005-4|left upper arm"]
        == "not acceptable"
    )
    t1 = _verdicts(_angles(600, trunk_twist=excursions(1, 15, rest=0)))["EN 1005-4|trunk side bend or twist"]
    t3 = _verdicts(_angles(600, trunk_side_bend=excursions(3, -15, rest=0)))["EN 1005-4|trunk side bend or twist"]
    assert (t1, t3) == ("conditionally acceptable", "not acceptable")
    assert _verdicts(_angles(600))["EN 1005-4|trunk side bend or twist"] == "acceptable"


def test_exposure_not_measured_without_angles():
    s = aggregate_shift(_shift())
    assert all(not f.measured and f.verdict == "not measured" for f in s.exposure)


def test_upper_arm_elevation_falls_back_to_flexion_and_abduction():
    frame = _angles(600).drop(columns=["left_upper_arm_elevation", "right_upper_arm_elevation"])
    frame["upper_arm_flexion"] = np.deg2rad(10.0)  # unprefixed: both sides
    frame["upper_arm_abduction"] = np.deg2rad(np.where((frame["time_s"] >= 100) & (frame["time_s"] < 106), 70, 5))
    v = _verdicts(frame)
    assert v["ISO 11226|left upper arm"] == v["ISO 11226|right upper arm"] == "not recommended"


def test_session_groups_by_worker():
    a = _shift().assign(worker="a")
    b = _shift().iloc[:1000].assign(worker="b")
    out = aggregate_session(pd.concat([a, b], ignore_index=True))
    assert sorted(out) == ["a", "b"]
    assert out["a"].frames == len(a) and out["b"].frames == 1000
    assert out["b"].worker == "b"


def test_results_are_frozen():
    s = aggregate_shift(_shift())
    with pytest.raises(AttributeError):
        s.frames = 0  # type: ignore[misc]
    with pytest.raises(TypeError):
        s.distributions["x"] = None  # type: ignore[index]
