"""The stage *track and smooth* fed chunk by chunk while the 2D stage still runs
(ergopose/pipeline/track.py, ``SessionTracking``; ergopose/pipeline/assess.py): the chunks are
tracked in frame order as far as they are stored, whatever order they are stored in, and the
table is the one tracking after the 2D stage writes; a run left before the end leaves no table.
On the stored chunks of the tiny session's uninterrupted assessment (6 chunks of 6 frames)."""

from __future__ import annotations

import shutil

import pyarrow.parquet as pq
import pytest

from ergopose.pipeline import detect
from ergopose.pipeline.store import ResultStore
from ergopose.pipeline.track import SessionTracking, track_session
from ergopose.recon.settings import ReconSettings
from ergopose.session import load_session

pytestmark = pytest.mark.slow

#: the order the six chunks are stored in (as two processes may finish them), by chunk index
STORED_ORDER = [1, 0, 3, 2, 5, 4]


def _copy_of_run(reference, tmp_path, name):
    out, _ = reference
    copy = tmp_path / name
    shutil.copytree(out / "pipeline", copy / "pipeline")
    (copy / "pipeline" / "tracks.parquet").unlink()
    return ResultStore(copy)


def test_chunks_tracked_as_they_are_stored_give_the_table_of_tracking_afterwards(reference, tiny_session, tmp_path):
    session = load_session(tiny_session)
    ranges = detect.chunk_ranges(session.frame_count, 6)
    assert len(ranges) == 6
    recon = ReconSettings()
    after = _copy_of_run(reference, tmp_path, "after")
    during = _copy_of_run(reference, tmp_path, "during")
    expected = track_session(session, after, ranges, recon, None)

    stored: set[int] = set()
    tracked = []  # chunks tracked after each one is stored
    with SessionTracking(session, during, ranges, recon, None) as tracking:
        for k in STORED_ORDER:
            stored.add(ranges[k][0])
            tracking.push_stored(stored)
            tracked.append(tracking._next)
            assert not during.tracks_path.exists()  # nothing final before the end
        tracks = tracking.finish()
        assert tracking.finish() is tracks
    # Chunk 1 waits for chunk 0; then both go, and so on.
    assert tracked == [0, 2, 2, 4, 4, 6]
    assert tracking.seconds > 0
    assert tracks.rows == expected.rows > 0
    assert tracks.workers == expected.workers
    assert tracks.worker_summary == expected.worker_summary
    assert during.tracks_path.read_bytes() == after.tracks_path.read_bytes()
    assert pq.read_metadata(during.tracks_path).num_rows == expected.rows


def test_tracking_left_before_its_end_leaves_no_table_and_keeps_an_earlier_one(reference, tiny_session, tmp_path):
    session = load_session(tiny_session)
    ranges = detect.chunk_ranges(session.frame_count, 6)
    store = _copy_of_run(reference, tmp_path, "left")
    # Left without finish(): no table from part of the chunks.
    with SessionTracking(session, store, ranges, ReconSettings(), None) as tracking:
        tracking.push_stored({start for start, _ in ranges[:3]})
    assert not store.tracks_path.exists()
    assert not list(store.root.glob(".tracks.*"))  # nor a temporary file
    # An error on the way (the 2D stage failed) keeps the table of an earlier run as it was.
    store.tracks_path.write_bytes(b"an earlier run's table")
    with pytest.raises(KeyboardInterrupt):
        with SessionTracking(session, store, ranges, ReconSettings(), None) as tracking:
            tracking.push_stored({ranges[0][0]})
            raise KeyboardInterrupt
    assert store.tracks_path.read_bytes() == b"an earlier run's table"
    assert not list(store.root.glob(".tracks.*"))
    with pytest.raises(RuntimeError, match="outside its with-block"):
        SessionTracking(session, store, ranges, ReconSettings(), None).finish()


def test_assess_tracks_the_chunks_while_the_2d_stage_runs(reference, tiny_session, fetched_model_dir, tmp_path):
    from ergopose.pipeline import assess
    from tests.pipeline import helpers

    out = tmp_path / "report"
    options = assess.AssessOptions(out_dir=out, model_dir=fetched_model_dir[0], chunk_seconds=0.5, processes=2)
    result = assess.assess(tiny_session, options)
    seconds = result.stage_seconds
    # Every chunk was tracked as it was stored; only the end of the shift is left after the 2D stage.
    assert 0 < seconds["tracking_during_pose"] <= seconds["tracking"]
    assert seconds["tracking_during_pose"] < seconds["pose"]
    assert "tracking_after_pose" in seconds
    assert helpers.csv_bytes(out) == reference[1]
