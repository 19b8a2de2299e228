"""A whole session from 2D detections to the Parquet tracks table."""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.errors import InputError
from ergopose.recon import diagnostics as D
from ergopose.recon.session import reconstruct_session
from ergopose.recon.table import read_tracks, table_to_frames
from tests.recon.conftest import FPS


@pytest.mark.slow
def test_session_to_parquet(crossing, tmp_path):
    events = []
    path = tmp_path / "out" / "tracks.parquet"
    summary, none = reconstruct_session(
        crossing.frames,
        path,
        fps=FPS,
        cameras=crossing.cameras,
        chunk_frames=25,
        progress=events.append,
        total_frames=len(crossing.frames),
    )
    assert none is None and summary.path == path and path.exists()
    assert summary.frames == len(crossing.frames) and summary.people_pairs == 4 * len(crossing.frames)
    assert summary.people_single_view == 0 and summary.workers == ("worker_1", "worker_2", "worker_3", "worker_4")
    assert [e.done for e in events] == [25, 50, 72] and events[-1].total == 72
    table = read_tracks(path)
    assert table.metadata["settings"]["max_fill_gap_s"] == 0.5
    meta_w = table.metadata["workers"]
    for w, p in D.match_workers(table_to_frames(table), crossing.truth).items():
        assert abs(meta_w[f"worker_{w}"]["stature_estimate_m"] - crossing.statures[p]) < 0.03
        assert set(meta_w[f"worker_{w}"]["limb_medians_m"]) >= {"left_thigh", "shoulder_width"}
    assert len(table.data) == summary.rows * 33
    tf = table_to_frames(table)
    assert D.identity_switches(tf, crossing.truth) == 0
    # Everything reconstructed has a lens angle; frames with nobody missing: 4 rows per frame.
    assert np.isfinite(table.data["lens_angle_deg"]).all()
    assert np.all(np.bincount(tf.frame) == 4)


def test_session_rejects_a_camera_listed_twice(crossing):
    # Any number of cameras is fine (tests/recon/test_multiview.py), but not one camera twice.
    a, b = crossing.frames[0]
    with pytest.raises(InputError, match="'cam_1' is listed twice"):
        reconstruct_session([(a, b, a)], None, fps=FPS)
