"""The Tracks of a stored tracks table (ergopose.pipeline.track.stored_tracks) use the reconstruction
settings they are given (the session's), not defaults: the limb diagnostics' lens regions follow
them."""

from __future__ import annotations

import pytest
from helpers import ground_truth_tracks

from ergopose.pipeline.store import ResultStore
from ergopose.pipeline.track import regroup, stored_tracks
from ergopose.recon.settings import ReconSettings

# Left out of make test-fast (still in make test): simulates the tiny session (tiny_session, 3 s of two workers).
pytestmark = pytest.mark.slow


def _frames_by_region(tracks) -> dict[str, int]:
    diag = {d.worker: d for d in tracks.references.limbs.result()}["worker_1"]
    return {r: diag.get("left_upper_arm", r).frames for r in ("central", "outer", "edge")}


def test_stored_tracks_use_the_sessions_reconstruction_settings(tiny_session, tmp_path):
    n = ground_truth_tracks(tiny_session, tmp_path)  # every joint 30 degrees off the lens axis
    path = ResultStore(tmp_path).tracks_path
    default = stored_tracks(path, ReconSettings())
    assert _frames_by_region(default) == {"central": 0, "outer": n, "edge": 0}  # 30 <= 30 < 60
    wide = ReconSettings(lens_region_limits_deg=(40.0, 70.0))
    tracks = stored_tracks(path, wide)
    assert tracks.recon == wide
    assert _frames_by_region(tracks) == {"central": n, "outer": 0, "edge": 0}
    # merging tracker numbers reads the table again with the same settings
    merged = _frames_by_region(regroup(tracks, {2: 1}))
    assert merged["central"] >= n and merged["outer"] == merged["edge"] == 0
