"""The stage *track and smooth* read back from a stored tracks table (ergopose/pipeline/track.py),
on a hand-built table: frames 0-3 hold workers 1 and 2, frames 4-5 workers 1 and 3, written in
three pieces (three row groups): the first ends inside frame 2, the second holds only frame 2's
other row, the third holds frames 3-5."""

from __future__ import annotations

import dataclasses

import numpy as np
import pyarrow.parquet as pq
import pytest

from ergopose.pipeline.track import read_track_parts, regroup, stored_tracks
from ergopose.pipeline.track import _within as within
from ergopose.pipeline.window import Window
from ergopose.recon.pipeline import TrackFrames
from ergopose.recon.settings import ReconSettings
from ergopose.recon.table import TracksWriter
from ergopose.sim.synthetic import WorkerScript, walk_workers

FPS = 12.0
#: (frame, worker) of every row, in the table's order (by frame, then worker)
ROWS = [(0, 1), (0, 2), (1, 1), (1, 2), (2, 1), (2, 2), (3, 1), (3, 2), (4, 1), (4, 3), (5, 1), (5, 3)]
#: the pieces written: rows [0, 5), [5, 6), [6, 12)
PIECES = [(0, 5), (5, 6), (6, 12)]
SUMMARY = {"worker_1": {"stature_estimate_m": 1.8}, "worker_2": {"stature_estimate_m": 1.6}}


def _rows(sel: slice) -> TrackFrames:
    frame = np.array([f for f, _ in ROWS[sel]], np.int64)
    worker = np.array([w for _, w in ROWS[sel]], np.int64)
    # three standing people 1.2 m apart; the joint positions change with the frame (rows are told apart)
    scripts = [WorkerScript(1.6 + 0.1 * k, np.array([[-1.2 + 1.2 * k, 0.0]]), pause_s=10.0) for k in range(3)]
    people = walk_workers(scripts, 6, fps=FPS)  # (6, 3, 33, 3)
    pts = people[frame, worker - 1] + 0.001 * frame[:, None, None]
    n, j = pts.shape[:2]
    return TrackFrames(
        worker=worker,
        frame=frame,
        time_s=frame / FPS,
        points_world=pts,
        raw_points_world=pts.copy(),
        confidence=np.full((n, j), 0.9),
        reprojection_error_px=np.ones((n, j)),
        views=np.full((n, j), 2, np.int8),
        gap_filled=np.zeros((n, j), bool),
        gated=np.zeros((n, j), bool),
        smoothed=True,
        lens_angle_deg=np.full((n, j), 20.0),
        inferred=np.zeros((n, j), bool),
        std_world=np.full((n, j, 3), 0.01),
    )


@pytest.fixture
def table(tmp_path):
    path = tmp_path / "tracks.parquet"
    with TracksWriter(path, fps=FPS, cameras=("cam_1", "cam_2"), settings=ReconSettings().as_dict()) as w:
        w.meta["window"] = Window(0.0, 0.5).as_dict()
        for a, b in PIECES:
            w.write(_rows(slice(a, b)))
        w.set_workers(SUMMARY)
    assert pq.ParquetFile(path).num_row_groups == len(PIECES)  # one row group per piece
    return path


def test_parts_hold_whole_frames_in_order(table):
    parts = list(read_track_parts(table))
    # piece 1 ends inside frame 2 (carried on), piece 2 holds only frame 2's other row, piece 3
    # ends with frame 5, which is complete only at the end of the file
    assert [sorted(set(p.frame.tolist())) for p in parts] == [[0, 1], [2, 3, 4], [5]]
    got = [(int(f), int(w)) for p in parts for f, w in zip(p.frame, p.worker)]
    assert got == ROWS
    every = _rows(slice(0, len(ROWS)))
    np.testing.assert_allclose(np.concatenate([p.points_world for p in parts]), every.points_world, atol=1e-6)


def test_stored_tracks_read_the_table_and_its_metadata(table):
    recon = ReconSettings(lens_region_limits_deg=(40.0, 70.0))
    t = stored_tracks(table, recon)
    assert (t.rows, t.workers, t.recon, t.groups) == (len(ROWS), (1, 2, 3), recon, {})
    assert t.worker_summary == SUMMARY
    assert t.window == Window(0.0, 0.5)
    # tracker 3 scored as one worker with tracker 2: the same rows, two workers
    merged = stored_tracks(table, recon, {3: 2})
    assert (merged.rows, merged.workers, merged.groups) == (len(ROWS), (1, 2), {3: 2})


def test_regroup_reads_again_only_for_other_groups(table):
    t = dataclasses.replace(stored_tracks(table, ReconSettings()), worker_summary={"kept": {}}, window=None)
    assert regroup(t, {}) is t
    merged = regroup(t, {3: 2})
    assert merged.workers == (1, 2) and merged.groups == {3: 2}
    # what the table does not hold stays as the tracks had it
    assert merged.worker_summary == {"kept": {}} and merged.window is None


@pytest.mark.parametrize(
    "start, end, groups, expected",
    [
        (0.0, 4 / FPS, {}, (1, 2)),  # frames 0-3: tracker 3 not yet seen
        (4 / FPS, 6 / FPS, {}, (1, 3)),  # frames 4-5: tracker 2 gone
        (4 / FPS, 6 / FPS, {3: 2}, (1, 2)),  # ... but scored with tracker 3, who is there
        (3 / FPS, 4 / FPS, {}, (1, 2)),  # frame 3 alone
    ],
)
def test_within_keeps_the_workers_tracked_in_the_window(table, start, end, groups, expected):
    t = dataclasses.replace(stored_tracks(table, ReconSettings(), groups), window=Window(start, end))
    assert within(t, FPS).workers == expected


def test_within_without_a_window_is_the_same_tracks(table):
    t = dataclasses.replace(stored_tracks(table, ReconSettings()), window=None)
    assert within(t, FPS) is t
