"""The chunk's 2D stage passes each frame's people between the cameras (ergopose/pipeline/detect.py,
``_video_2d``; the cues themselves: tests/pose/test_handoff.py).

On the tiny simulated session with the real networks: after every frame each camera is told where
the other found people, from exactly the records that frame gave (so the cues are a function of the
chunk alone, and a resumed run repeats them); ``other_camera_every = 0`` passes nothing.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ergopose.pipeline import detect
from ergopose.pose import handoff
from ergopose.session import load_session


@pytest.mark.slow
@pytest.mark.parametrize("every", [1, 0])
def test_every_frame_passes_its_people_to_the_other_camera(tiny_session, fetched_model_dir, monkeypatch, every):
    session = load_session(tiny_session)
    job = detect.DetectJob(
        cameras=session.calibrated_cameras,
        videos=tuple(str(c.video_path) for c in session.cameras),
        fps=session.fps,
        model_dir=str(fetched_model_dir[0]),
    )
    job = dataclasses.replace(job, pose=dataclasses.replace(job.pose, other_camera_every=every))
    passed = []
    taken = []

    def recording_pass(stages, found, cameras, min_confidence):
        passed.append([f.rays_cam.copy() for f in found])
        for stage in stages:
            if "take_cues" not in vars(stage):  # wrap each stage's method once
                stage.take_cues = lambda d, r, _orig=stage.take_cues: (taken.append(len(d)), _orig(d, r))[1]
        handoff.pass_cues(stages, found, cameras, min_confidence)

    monkeypatch.setattr(detect, "pass_cues", recording_pass)
    frames_2d, counts = detect.video_2d(job, 0, 12)
    if every == 0:
        assert passed == [] and taken == []
        return
    assert len(passed) == 12  # once per frame, with every camera's records of that frame
    for k, per_camera in enumerate(passed):
        assert [len(r) for r in per_camera] == counts[k].tolist()
        for c, rays in enumerate(per_camera):
            world = frames_2d[k][c].rays_world
            expected = rays @ job.cameras[c].rotation_world_from_cam.T
            assert np.allclose(world, expected, equal_nan=True, atol=1e-9)
    assert sum(taken) > 0  # the simulated workers are seen, so places were passed on
