"""Scoring with the settings' wrist posture where the hand is not seen (ergopose.pipeline.score.score_rows).

A posed body (ergopose.ergonomics.body) with the left wrist flexed 5 degrees toward the palm; its
hand points are placed by the body model (inferred) in the first half of the frames, and the right
hand is not measured at all in three frames. The settings give wrist_flexion_deg = 20.
RULA wrist (step 3): neutral 1, up to 15 degrees 2, more than 15 degrees 3; REBA wrist (step 9):
0-15 degrees 1, more than 15 degrees 2.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ergopose.ergonomics import body
from ergopose.ergonomics.aggregate import aggregate_shift
from ergopose.ergonomics.export import frames_table, session_summary_table, worker_summary_table
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.keypoints import JOINT_INDEX
from ergopose.pipeline.score import score_rows
from ergopose.recon.pipeline import TrackFrames
from ergopose.session import Session, TaskFactors

FPS = 12.0
N = 24
LEFT_HAND = [JOINT_INDEX[j] for j in ("left_wrist", "left_index", "left_pinky")]
RIGHT_HAND = [JOINT_INDEX[j] for j in ("right_wrist", "right_index", "right_pinky")]
HIDDEN_LEFT = np.arange(N) < 12
NAN_RIGHT = np.isin(np.arange(N), [6, 7, 8])


def _session(defaults: TaskFactors) -> Session:
    return Session(
        path=Path("day1"),
        format_version=1,
        recorded_at=None,
        fps=FPS,
        frame_count=N,
        cameras=(),
        defaults=defaults,
        periods=(),
        workers=(),
        scoring={},
        description=None,
        ground_truth_dir=None,
        settings_path=Path("day1/settings.toml"),
        calibration_path=Path("day1/calibration.toml"),
    )


def _rows(with_inferred: bool = True):
    m = body.BodyMeasurements.from_stature(1.75)
    posture = body.Posture(
        left_upper_arm_flexion=np.radians(30.0),
        right_upper_arm_flexion=np.radians(30.0),
        left_elbow_flexion=np.radians(80.0),
        right_elbow_flexion=np.radians(80.0),
        left_wrist_flexion=np.radians(5.0),
        right_wrist_flexion=np.radians(-8.0),
        heading=np.zeros(N),
    )
    pts = body.pose_skeleton(m, body.place_on_floor(m, posture))
    pts[np.ix_(NAN_RIGHT, RIGHT_HAND)] = np.nan
    J = pts.shape[1]
    inferred = np.zeros((N, J), bool)
    inferred[np.ix_(HIDDEN_LEFT, LEFT_HAND)] = True
    inferred[~HIDDEN_LEFT, JOINT_INDEX["left_index"]] = True  # one hand point inferred: the hand is still seen
    z = np.zeros((N, J))
    frame = np.arange(N, dtype=np.int64)
    fields = dict(
        worker=np.ones(N, np.int64),
        frame=frame,
        time_s=frame / FPS,
        points_world=pts,
        raw_points_world=pts,
        confidence=z + 0.9,
        reprojection_error_px=z,
        views=np.full((N, J), 2, np.int8),
        gap_filled=z.astype(bool),
        gated=z.astype(bool),
        smoothed=True,
        lens_angle_deg=z + 30,
        std_world=np.full((N, J, 3), 0.004),
    )
    if with_inferred:
        return TrackFrames(**fields, inferred=inferred)

    class Rows:  # a caller's rows without an inferred attribute
        def __len__(self):
            return N

    rows = Rows()
    for k, v in fields.items():
        setattr(rows, k, v)
    return rows


def _score(defaults: TaskFactors, with_inferred: bool = True) -> pd.DataFrame:
    # No keypoint floor: the settings' value gets no spread in the draws while a measured angle
    # gets the floor's, and REBA's activity reads across frames, so with it the probabilities of
    # the frames next to those given by the settings would differ (the scores do not).
    return score_rows(_session(defaults), _rows(with_inferred), "w1", ScoringSettings(joint_sd_floor_m=0.0))


@pytest.fixture(scope="module")
def given():
    return _score(TaskFactors(wrist_flexion=float(np.radians(20.0))))


@pytest.fixture(scope="module")
def plain():
    return _score(TaskFactors())


@pytest.mark.slow
def test_unseen_hand_is_scored_with_the_settings_wrist_flexion(given):
    left = np.degrees(given["left_wrist_flexion"].to_numpy())
    np.testing.assert_allclose(left[HIDDEN_LEFT], 20.0)
    np.testing.assert_allclose(left[~HIDDEN_LEFT], 5.0, atol=1e-6)  # seen: the measurement stays
    assert (given["left_rula_wrist_band"][HIDDEN_LEFT] == 3).all()
    assert (given["left_rula_wrist_band"][~HIDDEN_LEFT] == 2).all()
    assert (given["left_reba_wrist_band"][HIDDEN_LEFT] == 2).all()
    assert (given["left_reba_wrist_band"][~HIDDEN_LEFT] == 1).all()
    right = np.degrees(given["right_wrist_flexion"].to_numpy())
    np.testing.assert_allclose(right[NAN_RIGHT], 20.0)  # not measured at all: the settings' value
    np.testing.assert_allclose(right[~NAN_RIGHT], -8.0, atol=1e-6)
    assert np.isnan(given["right_wrist_deviation"][NAN_RIGHT]).all()  # the settings give no deviation


@pytest.mark.slow
def test_the_frames_name_the_inputs_from_the_settings(given):
    expected = np.where(HIDDEN_LEFT, "left_wrist_flexion", "").astype(object)
    expected[NAN_RIGHT] = "left_wrist_flexion;right_wrist_flexion"
    assert given["inputs_from_settings"].tolist() == expected.tolist()


@pytest.mark.slow
def test_a_settings_value_adds_no_spread(given):
    sd = np.degrees(given["left_wrist_flexion_sd"].to_numpy())
    assert (sd[HIDDEN_LEFT] == 0).all()
    assert (sd[~HIDDEN_LEFT] > 0.1).all()  # measured from joints with 4 mm deviations


@pytest.mark.slow
def test_without_a_settings_value_the_measurement_stays(plain, given):
    np.testing.assert_allclose(np.degrees(plain["left_wrist_flexion"]), 5.0, atol=1e-6)
    assert np.isnan(plain["right_wrist_flexion"][NAN_RIGHT]).all()
    assert (plain["inputs_from_settings"] == "").all()
    seen = ~HIDDEN_LEFT & ~NAN_RIGHT  # frames the settings did not touch score alike
    cols = [c for c in plain.columns if c != "inputs_from_settings"]
    pd.testing.assert_frame_equal(plain.loc[seen, cols], given.loc[seen, cols])


def test_rows_without_inferred_flags_count_the_hands_as_seen():
    out = _score(TaskFactors(wrist_flexion=float(np.radians(20.0))), with_inferred=False)
    np.testing.assert_allclose(np.degrees(out["left_wrist_flexion"]), 5.0, atol=1e-6)
    assert out["inputs_from_settings"].tolist() == np.where(NAN_RIGHT, "right_wrist_flexion", "").tolist()


@pytest.mark.slow
def test_the_shift_summary_gives_the_share_of_the_scored_time(given):
    summary = aggregate_shift(given.assign(time_s=np.arange(N) / FPS), "w1", frame_period_s=1 / FPS)
    scored = given["rula_grand"].notna() | given["reba_score"].notna()
    assert summary.scored_frames == int(scored.sum()) > 0
    assert not scored[NAN_RIGHT].any()  # no right hand point: the right arm (and the grand scores) unscored
    by = {u.input: u for u in summary.from_settings}
    assert set(by) == {"left_wrist_flexion"}  # the right wrist's settings value was used in unscored frames only
    left = by["left_wrist_flexion"]
    assert left.frames == int((HIDDEN_LEFT & scored).sum())
    assert np.degrees(left.value_rad) == pytest.approx(20.0)
    assert left.percent == pytest.approx(100.0 * left.frames / summary.scored_frames)
    assert left.time_s == pytest.approx(left.frames / FPS)
    rows = worker_summary_table(summary)
    row = rows[(rows["section"] == "inputs") & (rows["item"] == "left_wrist_flexion")]
    assert row["value"].tolist() == ["from settings: 20 deg"] and row["count"].tolist() == [left.frames]
    table = session_summary_table([summary])
    assert table["left_wrist_flexion_from_settings_pct_of_scored"][0] == pytest.approx(round(left.percent, 2))
    assert table["left_wrist_deviation_from_settings_pct_of_scored"][0] == 0.0


def test_a_limb_held_at_a_joint_limit_is_the_cause_of_low_confidence():
    """score_rows reads the rows' ``limited`` flags: with joints 8 cm uncertain no frame is scored
    with confidence (frames 6-8, without a right hand, are not scored); frames 12-17, whose right knee a joint limit held, give 'joint limit', the
    frames before them 'occluded limbs' (their left hand placed by the body model comes first),
    the others 'uncertain angles'."""
    rows = _rows()
    limited = np.zeros_like(rows.inferred)
    held = (np.arange(N) >= 12) & (np.arange(N) < 18)
    limited[held, JOINT_INDEX["right_knee"]] = True
    inferred = np.zeros_like(rows.inferred)
    inferred[np.ix_(HIDDEN_LEFT, LEFT_HAND)] = True
    fields = {
        **rows.__dict__,
        "std_world": np.full_like(rows.std_world, 0.08),
        "inferred": inferred,
        "limited": limited,
    }
    scored = score_rows(_session(TaskFactors()), TrackFrames(**fields), "w1", ScoringSettings())
    assert scored["confidence"].tolist() == np.where(NAN_RIGHT, "unscored", "low").tolist()
    expect = np.where(HIDDEN_LEFT, "occluded limbs", np.where(held, "joint limit", "uncertain angles"))
    assert scored["cause"].tolist() == expect.tolist()
    assert scored["held_at_limit"].tolist() == np.where(held, "legs", "").tolist()
    # the frames CSV's table carries it, beside the cause
    table = frames_table(scored)
    assert table["held_at_limit"].tolist() == np.where(held, "legs", "").tolist()
    columns = list(table.columns)
    assert columns.index("held_at_limit") == columns.index("cause") + 1
