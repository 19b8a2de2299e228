"""The ORACLE's parts (ergopose/evaluation/oracle.py) without running the assessment: its options
and folder layout, its 2D source on a hand-built ground truth (two standing people under the
simulator's rig, one of them hidden in some frames), the stage *publish* and the refusal of a
session without ground truth. The whole ORACLE run has slow tests in test_evaluate_oracle.py."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from evaluation_helpers import video_session

from ergopose.errors import InputError
from ergopose.evaluation.oracle import OracleFrames, OracleOptions, _readme, oracle_layout, publish_oracle, run_oracle
from ergopose.sim.ground_truth import GroundTruth
from ergopose.sim.scene import rig_cameras
from ergopose.sim.synthetic import WorkerScript, project_all, walk_workers
from ergopose.sim.visibility import OUTSIDE_IMAGE, VISIBLE

EXACT = OracleOptions(noise_px=0.0, person_dropout=0.0, joint_dropout=0.0, occluded_noise_px=0.0)


def test_options_and_layout():
    o = OracleOptions(noise_px=1.5, seed=4)
    assert o.banner().startswith("ORACLE 2D (simulated ground truth projected with 1.5 px noise)")
    assert o.as_dict() == {
        "noise_px": 1.5,
        "person_dropout": 0.02,
        "joint_dropout": 0.02,
        "occluded_noise_px": 6.0,
        "seed": 4,
        "own_body_hides": True,
        "banner": o.banner(),
    }
    seen = OracleOptions(noise_px=1.5, own_body_hides=False)
    assert seen.banner() == (
        "ORACLE 2D (simulated ground truth projected with 1.5 px noise; joints behind the worker's own body "
        "reported as seen) — not the pose network"
    )
    assert seen.as_dict()["own_body_hides"] is False
    layout = oracle_layout(Path("out"))
    assert layout.root == Path("out/oracle")
    assert layout.tracks == Path("out/oracle/pipeline/ORACLE_tracks.parquet")
    assert layout.frames_csv("w1") == Path("out/oracle/csv/ORACLE_w1_steps.csv")


def test_readme_is_labelled():
    text = _readme(OracleOptions(noise_px=3.0, seed=7), SimpleNamespace(path=Path("sess")), 2, 12.34)
    assert text.startswith(OracleOptions(noise_px=3.0).banner())
    assert "FOR EVALUATION ONLY" in text and "(seed 7)" in text
    assert "tracked workers: 2\nrun time: 12.3 s" in text


@pytest.fixture
def truth():
    """Three frames of two people standing under the rig; person 2 is outside camera 2's image in
    every frame and outside both images in frame 1."""
    cams = rig_cameras(320, 320)
    scripts = [
        WorkerScript(1.75, np.array([[-0.5, 0.0]]), pause_s=10.0),
        WorkerScript(1.6, np.array([[0.6, 0.3]]), pause_s=10.0),
    ]
    joints = walk_workers(scripts, 3)  # (3, 2, 33, 3)
    pixels = project_all(cams, joints)  # (3, 2 cameras, 2 people, 33, 2)
    vis = np.where(np.isfinite(pixels).all(axis=-1), VISIBLE, OUTSIDE_IMAGE).astype(np.int8)
    assert (vis == VISIBLE).all()  # both people are in both images: the hiding below is the test's
    vis[:, 1, 1] = OUTSIDE_IMAGE
    vis[1, :, 1] = OUTSIDE_IMAGE
    f, c, w = vis.shape[:3]
    gt = GroundTruth(
        path=None,
        fps=12.0,
        worker_ids=("w1", "w2"),
        camera_names=tuple(cam.name for cam in cams),
        joints_world=joints,
        pixels=pixels,
        theta=np.zeros((f, c, w, 33)),
        visibility=vis,
        task=np.zeros((f, w), np.int8),
        task_names=("none",),
        planted=np.zeros((f, w, 2), bool),
        carrying=np.zeros((f, w), bool),
        times_s=np.arange(f) / 12.0,
        postures=None,
        scene={},
    )
    return SimpleNamespace(calibrated_cameras=cams), gt


def test_frames_2d_reports_who_each_camera_sees(truth):
    session, gt = truth
    frames, counts = OracleFrames(session, gt, EXACT).frames_2d(0, 3)
    assert counts.tolist() == [[2, 1], [1, 1], [2, 1]]
    assert counts.dtype == np.int16
    assert [[d.frame for d in f] for f in frames] == [[0, 0], [1, 1], [2, 2]]
    assert [[d.camera for d in f] for f in frames][0] == ["cam_1", "cam_2"]


def test_frames_2d_of_a_later_range_are_those_frames(truth):
    session, gt = truth
    frames, counts = OracleFrames(session, gt, EXACT).frames_2d(1, 3)
    assert counts.tolist() == [[1, 1], [2, 1]]
    assert [f[0].frame for f in frames] == [1, 2]


def test_exact_oracle_keypoints_are_the_true_joints(truth):
    """Without noise, each detection's view keypoints are the true joints through its view's projection."""
    session, gt = truth
    frames, _ = OracleFrames(session, gt, EXACT).frames_2d(0, 3)
    for f, per_camera in enumerate(frames):
        for d in per_camera:
            for i in range(len(d.pixels_view)):
                errors = []
                for w in range(2):  # the order of the people in a camera's list carries no identity
                    h = np.c_[gt.joints_world[f, w], np.ones(33)] @ d.projection[i].T
                    errors.append(np.abs(h[:, :2] / h[:, 2:] - d.pixels_view[i]).max())
                assert min(errors) < 1e-6
                assert d.confidence[i].min() >= 0.75  # every joint visible: confidence 0.75 .. 1


def test_publish_moves_the_steps_files_under_the_oracle_label(tmp_path):
    stage, out = tmp_path / "stage", tmp_path / "out"
    (stage / "csv").mkdir(parents=True)
    for w in ("w1", "worker_3"):
        (stage / "csv" / f"{w}_steps.csv").write_text(f"rows of {w}\n", encoding="utf-8")
    (stage / "csv" / "session_summary.csv").write_text("summary\n", encoding="utf-8")
    scored = [SimpleNamespace(worker_id="w1"), SimpleNamespace(worker_id="worker_3")]
    ids = publish_oracle(None, scored, stage, out, None, None, None)
    assert ids == ("w1", "worker_3")
    assert sorted(p.name for p in (out / "csv").iterdir()) == ["ORACLE_w1_steps.csv", "ORACLE_worker_3_steps.csv"]
    assert (out / "csv" / "ORACLE_worker_3_steps.csv").read_text(encoding="utf-8") == "rows of worker_3\n"
    assert [p.name for p in (stage / "csv").iterdir()] == ["session_summary.csv"]  # not published


def test_run_oracle_refuses_a_session_without_ground_truth(tmp_path):
    with pytest.raises(InputError, match="ORACLE needs the ground_truth/ folder"):
        run_oracle(video_session(tmp_path / "s"), tmp_path / "out")
    assert not (tmp_path / "out").exists()
