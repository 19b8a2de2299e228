"""Scoring a shift in blocks gives the frames of scoring it in one piece (simulated 25-minute shift)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ergopose.ergonomics.angles import joint_angles, shoulder_heights
from ergopose.pipeline.scoring import ShiftReferences, WorkerScorer, block_sizes, context_seconds
from ergopose.recon.pipeline import TrackFrames

# End to end (simulated sessions, whole runs): left out by make test-fast.
pytestmark = pytest.mark.slow

FPS = 12.0


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    from ergopose.session import load_session
    from ergopose.sim.writer import SimulationConfig, simulate_session

    path = tmp_path_factory.mktemp("scoring") / "day1"
    simulate_session(path, SimulationConfig(workers=1, minutes=0.01, seed=4))
    return load_session(path)


def _shift_rows(seconds: float, seed: int, long_gap: bool) -> TrackFrames:
    """A simulated worker's joints with measurement noise, lost frames (tracking gaps of a few
    seconds) and joints missing for stretches, as the tracks table has them."""
    from ergopose.sim.motion import simulate_motion
    from ergopose.sim.scene import default_scene

    rng = np.random.default_rng(seed)
    m = simulate_motion(default_scene(), 1, seconds, FPS, seed)
    pts = m.joints_world[:, 0].copy()
    # a stooped posture held for 3 minutes across a block boundary (frames 2500-4660; blocks of 2880)
    flexion = joint_angles(pts).trunk_flexion
    stoop = int(np.flatnonzero((flexion > np.radians(35)) & (flexion < np.radians(50)))[0])
    pts[2500 : 2500 + int(180 * FPS)] = pts[stoop]
    pts += rng.normal(0, 0.003, pts.shape)
    n = len(pts)
    keep = np.ones(n, bool)
    for start in rng.integers(min(4700, n // 2), n - 100, 12):  # the track lost for 1-8 s
        keep[start : start + rng.integers(12, 96)] = False
    for start in rng.integers(0, n - 400, 20):  # an arm unseen for up to 30 s
        pts[start : start + rng.integers(10, 360), 13:16] = np.nan
    if long_gap:  # the right elbow unseen for 3 minutes: longer than the blocks' context
        pts[6000 : 6000 + int(180 * FPS), 14] = np.nan
    frame = np.flatnonzero(keep).astype(np.int64)
    J = pts.shape[1]
    z = np.zeros((len(frame), J))
    return TrackFrames(
        worker=np.ones(len(frame), np.int64),
        frame=frame,
        time_s=frame / FPS,
        points_world=pts[keep],
        raw_points_world=pts[keep],
        confidence=z + 0.9,
        reprojection_error_px=z,
        views=np.full((len(frame), J), 2, np.int8),
        gap_filled=z.astype(bool),
        gated=z.astype(bool),
        smoothed=True,
        lens_angle_deg=z + 30,
    )


class _Collect:
    def __init__(self):
        self.frames, self.rows = [], []

    def write(self, frames, rows):
        assert len(frames) == len(rows) and np.array_equal(frames["frame"].to_numpy(), rows.frame)
        self.frames.append(frames)
        self.rows.append(rows)


def _reference(rows) -> float:
    refs = ShiftReferences()
    refs.add(rows)
    return refs.shoulder_reference_m(1)


def _blockwise(session, rows, scoring, pieces, block_frames, context_frames):
    from ergopose.pipeline.score import score_rows

    sink = _Collect()
    ref = _reference(rows)
    scorer = WorkerScorer(
        lambda r: score_rows(session, r, "worker_1", scoring, ref), sink, block_frames, context_frames
    )
    for a, b in zip(pieces[:-1], pieces[1:]):  # rows arrive in uneven pieces, as row groups of the table do
        sel = (rows.frame >= a) & (rows.frame < b)
        scorer.add(TrackFrames(**{k: (v[sel] if isinstance(v, np.ndarray) else v) for k, v in rows.__dict__.items()}))
        scorer.advance(b)
    scorer.finish()
    return pd.concat(sink.frames, ignore_index=True), scorer


def test_blocks_score_every_frame_as_the_whole_shift_does(session):
    from ergopose.pipeline.inputs import scoring_settings
    from ergopose.pipeline.score import score_rows

    scoring = scoring_settings(session)
    rows = _shift_rows(25 * 60, seed=3, long_gap=False)
    ref = _reference(rows)
    heights = shoulder_heights(rows.points_world)
    assert abs(ref - np.median(heights[np.isfinite(heights)])) < 1e-3  # the whole shift's median, to 1 mm
    whole = score_rows(session, rows, "worker_1", scoring, ref)
    block, context = block_sizes(scoring, FPS, block_seconds=240.0)
    assert context == int(np.ceil(context_seconds(scoring) * FPS)) and context_seconds(scoring) >= 90
    pieces = [0, 500, 1024, 5000, 5001, 9000, 17000, 18000]
    blocks, scorer = _blockwise(session, rows, scoring, pieces, block, context)
    assert scorer.blocks == 7 and scorer.frames == len(rows)
    static = whole["reba_static"].fillna(0).to_numpy() > 0
    assert static[2500 + 60 * 12 : 4660].all() and static.sum() < 3000, "the held stoop is static, and only it"
    rep = [c for c in whole.columns if c.startswith("rep_")]
    assert sum(int(whole[c].fillna(0).sum()) for c in rep) > 20, "the shift has repetitions to compare"
    pd.testing.assert_frame_equal(blocks, whole)


def test_an_angle_missing_longer_than_the_context_changes_at_most_a_few_frames(session):
    """The documented exception: the last angle before a 3-minute gap is not in the block."""
    from ergopose.pipeline.inputs import scoring_settings
    from ergopose.pipeline.score import score_rows

    scoring = scoring_settings(session)
    rows = _shift_rows(25 * 60, seed=3, long_gap=True)
    whole = score_rows(session, rows, "worker_1", scoring, _reference(rows))
    block, context = block_sizes(scoring, FPS, block_seconds=240.0)
    blocks, _ = _blockwise(session, rows, scoring, [0, 18000], block, context)
    differ = ~((blocks == whole) | (blocks.isna() & whole.isna())).all(axis=1)
    assert differ.sum() <= 0.01 * len(whole)


def test_the_frames_csv_written_block_by_block_has_the_bytes_of_one_write(session, tmp_path):
    from ergopose.ergonomics.export import FramesCsvWriter, write_worker_frames_csv
    from ergopose.pipeline.inputs import scoring_settings
    from ergopose.pipeline.score import score_rows

    scoring = scoring_settings(session)
    rows = _shift_rows(8 * 60, seed=5, long_gap=False)
    whole = score_rows(session, rows, "worker_1", scoring, _reference(rows))
    block, context = block_sizes(scoring, FPS, block_seconds=120.0)
    blocks, scorer = _blockwise(session, rows, scoring, [0, 3000, len(rows) + 10_000], block, context)
    assert scorer.blocks >= 4
    write_worker_frames_csv(tmp_path / "one.csv", whole)
    with FramesCsvWriter(tmp_path / "blocks.csv") as w:
        for k in range(0, len(blocks), 1000):
            w.write(blocks.iloc[k : k + 1000])
    assert (tmp_path / "blocks.csv").read_bytes() == (tmp_path / "one.csv").read_bytes()


def test_worst_periods_from_the_period_frames_equal_those_from_every_frame(session, tmp_path):
    """The report reads back only the frames of the sustained periods of high risk; the periods
    (time, scores, levels, what drove them) are those found from every scored frame of the shift."""
    import contextlib

    from ergopose.pipeline import aggregate, inputs, score
    from ergopose.report import adapters

    scoring = inputs.scoring_settings(session)
    rows = _shift_rows(25 * 60, seed=3, long_gap=False)
    ref = _reference(rows)
    block, context = block_sizes(scoring, FPS, block_seconds=240.0)
    with contextlib.ExitStack() as stack:
        sink = score.WorkerSink(
            stack, "worker_1", tmp_path / "w_frames.csv", tmp_path / "w.parquet", scoring, FPS, np.full(16, np.nan)
        )
        scorer = WorkerScorer(lambda r: score.score_rows(session, r, "worker_1", scoring, ref), sink, block, context)
        scorer.add(rows)
        scorer.finish()
    summary = sink.acc.result()
    period_rows, drawn = aggregate._period_frames(sink, summary)
    whole = score.score_rows(session, rows, "worker_1", scoring, ref)
    assert 0 < len(period_rows) < len(whole) and len(drawn) >= 1
    a = adapters.worker_summary(summary, frames=whole).worst
    b = adapters.worker_summary(summary, timeline=aggregate._timeline(sink), frames=period_rows).worst
    assert len(a) >= 1 and a == b
    assert all(w.end_s - w.start_s >= 5.0 and w.drivers for w in a)


def test_the_periods_name_the_task_inputs_of_the_settings(session):
    """A 6-minute shift scored with a load and a coupling for everyone from the settings: every
    sustained period names them for its whole high-risk time, the angles measured, the shock not
    given."""
    import dataclasses

    from ergopose.pipeline.inputs import scoring_settings
    from ergopose.pipeline.score import score_worker
    from ergopose.report import adapters
    from ergopose.session import TaskFactors

    given = dataclasses.replace(
        session, defaults=TaskFactors(load_kg=12.0, load_mode="static", coupling="poor"), periods=(), workers=()
    )
    scoring = scoring_settings(given)
    scored = score_worker(given, _shift_rows(6 * 60, seed=3, long_gap=False), "worker_1", scoring, None)
    worst = adapters.worker_summary(scored.summary, frames=scored.frames).worst
    assert len(worst) >= 1
    for w in worst:
        found = {(i.input, i.source): i for i in w.inputs}
        assert found[("load", "task input")].value == "12 kg, held static"
        assert found[("hand coupling", "task input")].value == "poor"
        for key in (
            ("load", "task input"),
            ("hand coupling", "task input"),
            ("shock or rapid build-up of force", "not given"),
        ):
            assert found[key].seconds == pytest.approx(w.high_s)
        assert w.inputs[0].source == "measured" and w.inputs[0].input.startswith("angles of the upper arms")
