"""Memory of scoring a block of frames: the uncertainty draws are made one at a time.

A block of a shift (10 minutes and its context, docs/assess.md) is scored at once, so what
score_rows holds per frame sets the memory of a whole-shift assessment. The draws of all
SAMPLES at once made the peak 26 kB per frame on this test's rows (33 kB on a simulated session's
tracks); one at a time, 5.8 kB (6.3 kB). The peak is read with tracemalloc (allocation sizes, not timing) as the slope between
two block lengths, so fixed costs (imports, the table of normal numbers) do not count.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pandas as pd
import pytest

from ergopose.ergonomics import uncertainty as U
from ergopose.recon.pipeline import TrackFrames

FPS = 12.0


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    from ergopose.session import load_session
    from ergopose.sim.writer import SimulationConfig, simulate_session

    path = tmp_path_factory.mktemp("scoring_memory") / "day1"
    simulate_session(path, SimulationConfig(workers=1, minutes=0.01, seed=3))
    return load_session(path)


def _rows(n: int, seed: int = 0) -> TrackFrames:
    """n frames of a simulated worker with 1 cm deviations (some NaN), as the tracks table has them."""
    from ergopose.sim.motion import simulate_motion
    from ergopose.sim.scene import default_scene

    rng = np.random.default_rng(seed)
    m = simulate_motion(default_scene(), 1, n / FPS, FPS, seed)
    pts = m.joints_world[:n, 0] + rng.normal(0, 0.003, m.joints_world[:n, 0].shape)
    std = np.full(pts.shape, 0.01)
    std[rng.random(pts.shape[:2]) < 0.05] = np.nan
    frame = np.arange(n, dtype=np.int64)
    J = pts.shape[1]
    z = np.zeros((n, J))
    return TrackFrames(
        worker=np.ones(n, np.int64),
        frame=frame,
        time_s=frame / FPS,
        points_world=pts,
        raw_points_world=pts,
        confidence=z + 0.9,
        reprojection_error_px=z,
        views=np.full((n, J), 2, np.int8),
        gap_filled=z.astype(bool),
        gated=z.astype(bool),
        smoothed=True,
        lens_angle_deg=z + 30,
        std_world=std,
    )


def test_draws_one_at_a_time_are_the_draws_of_all_at_once():
    rows = _rows(50)
    # all draws at once: each joint coordinate moved by its deviation times a number of its own per
    # draw, the same in every frame
    sd = np.where(np.isfinite(rows.std_world), rows.std_world, 0.0)
    every = rows.points_world[None] + sd[None] * U._normals()[:, None]
    one = U.iter_samples(rows.points_world, rows.std_world)
    assert not isinstance(one, (list, tuple, np.ndarray))  # made on demand
    got = list(one)
    assert len(got) == U.SAMPLES == len(every)
    for k, draw in enumerate(got):
        assert draw.shape == rows.points_world.shape
        assert np.array_equal(draw, every[k], equal_nan=True)
    # the numbers are moment-matched: over the draws, every joint coordinate's have mean 0 and SD 1,
    # so a coordinate's draws spread by exactly its deviation
    z = U._normals()
    assert z.shape == (U.SAMPLES, 33, 3)
    assert np.allclose(z.mean(axis=0), 0.0, atol=1e-12) and np.allclose(z.std(axis=0), 1.0)
    spread = np.stack(got).std(axis=0)
    ok = np.isfinite(rows.std_world)
    assert np.allclose(spread[ok], rows.std_world[ok])
    # lasting, not a jitter: the deviations here are the same 1 cm in every frame, so each draw
    # moves a joint coordinate by the same amount in every frame where it has one
    offset = np.stack(got) - rows.points_world[None]
    ok_all = np.broadcast_to(ok, offset.shape)
    assert np.allclose(offset[ok_all].reshape(-1), (0.01 * np.broadcast_to(z[:, None], offset.shape))[ok_all])
    # a NaN deviation counts as 0: that coordinate is the estimate in every draw
    nan = ~np.isfinite(rows.std_world)
    assert np.array_equal(got[3][nan], rows.points_world[nan])
    # the same frame gets the same draws wherever it sits in a block
    part = list(U.iter_samples(rows.points_world[10:20], rows.std_world[10:20]))
    assert np.array_equal(part[5], got[5][10:20], equal_nan=True)
    # the keypoints' own error: an offset of each joint per draw, the same in every frame (no
    # jitter), proportional to the floor, on top of the draw without it (also where the
    # deviation is NaN), and independent of the deviation's numbers
    floored = list(U.iter_samples(rows.points_world, rows.std_world, floor_m=0.003))
    double = list(U.iter_samples(rows.points_world, rows.std_world, floor_m=0.006))
    for a, b, base in zip(floored, double, got):
        shift = a - base
        assert np.allclose(shift, shift[:1]) and np.abs(shift).max() > 0
        assert np.allclose(b - base, 2 * shift)
    offsets = np.stack([a[0] - base[0] for a, base in zip(floored, got)]) / 0.003
    assert 0.7 < offsets.std() < 1.3  # standard normal offsets (16 x 33 x 3 of them)
    assert abs(np.corrcoef(offsets.ravel(), z.ravel())[0, 1]) < 0.2
    assert not np.allclose(floored[3][nan], rows.points_world[nan])


def _peak_bytes(session, rows, scoring) -> int:
    from ergopose.pipeline.score import score_rows

    tracemalloc.start()
    try:
        score_rows(session, rows, "worker_1", scoring)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_scoring_memory_per_frame_stays_small(session):
    from ergopose.pipeline.inputs import scoring_settings

    scoring = scoring_settings(session)
    small, large = _rows(100), _rows(400)
    _peak_bytes(session, small, scoring)  # first use: caches, the table of normal numbers
    per_frame = (_peak_bytes(session, large, scoring) - _peak_bytes(session, small, scoring)) / (400 - 100)
    # measured 5.8 kB per frame; all draws at once: 26 kB
    assert 0 < per_frame < 15_000, per_frame


def test_rows_kept_for_scoring_score_as_the_whole_rows(session):
    from ergopose.pipeline.inputs import scoring_settings
    from ergopose.pipeline.score import score_rows
    from ergopose.pipeline.scoring import SCORED_FIELDS, scoring_rows

    rows = _rows(150, seed=2)
    rows.inferred[::7, 15:22] = True  # hands placed by the body model now and then
    lean = scoring_rows(rows)
    for name, v in rows.__dict__.items():
        if isinstance(v, np.ndarray):
            assert getattr(lean, name).shape == (v.shape if name in SCORED_FIELDS else (len(rows), 0)), name
    size = {r: sum(a.nbytes for a in r.__dict__.values() if isinstance(a, np.ndarray)) for r in (rows, lean)}
    assert size[lean] * 1.9 < size[rows]
    scoring = scoring_settings(session)
    whole = score_rows(session, rows, "worker_1", scoring, 0.5)
    assert whole["rula_grand_p"].notna().all() and (whole["rula_grand_p"] < 1).any()  # the draws differ
    pd.testing.assert_frame_equal(score_rows(session, lean, "worker_1", scoring, 0.5), whole, check_exact=True)
