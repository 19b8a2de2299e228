"""The reference triangulated from another network's 2D keypoints (ergopose.evaluation.keypoint_reference):
the weighted DLT against known points, folder matching, errors, and Pose2Sim's own triangulation
reproduced wherever Pose2Sim kept every camera."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ergopose.cli import main
from ergopose.errors import InputError
from ergopose.evaluation.keypoint_reference import camera_folders, openpose_reference, triangulate_weighted
from ergopose.evaluation.markers import BODY_25B
from ergopose.evaluation.trc import read_trc
from ergopose.geometry.calibration_file import read_any_calibration
from ergopose.geometry.camera import Camera
from ergopose.geometry.lenses.rectilinear import Rectilinear

TRC = "pose-3d/S00_P00_T01_BalancingTrial_0-100.trc"


def _look_at(position: np.ndarray, target: np.ndarray) -> np.ndarray:
    """rotation_world_from_cam of a camera at ``position`` looking at ``target`` (camera y down, world z up)."""
    z = target - position
    z = z / np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x = x / np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


def _cameras(names=("cam_01", "cam_02", "cam_03")) -> list[Camera]:
    positions = [np.array([3.0, 0.0, 1.5]), np.array([0.0, 3.0, 1.8]), np.array([-2.5, -2.0, 2.2])]
    lens = Rectilinear.from_fov(800, 600, np.radians(70))
    return [
        Camera(
            name=n,
            lens=lens,
            width=800,
            height=600,
            rotation_world_from_cam=_look_at(p, np.array([0, 0, 1.0])),
            position_world=p,
        )
        for n, p in zip(names, positions)
    ]


def test_weighted_dlt_recovers_the_points_the_cameras_saw():
    rng = np.random.default_rng(3)
    cams = _cameras()
    points = rng.uniform([-0.5, -0.5, 0.2], [0.5, 0.5, 1.8], size=(4, 5, 3))
    pixels = np.stack([c.project_world(points.reshape(-1, 3)).reshape(4, 5, 2) for c in cams])
    weights = rng.uniform(0.3, 1.0, size=(3, 4, 5))
    weights[2, 0, :] = 0.0  # frame 0: only two cameras
    weights[1:, 1, 0] = 0.0  # frame 1, point 0: one camera only
    out = triangulate_weighted(cams, pixels, weights)
    seen = np.ones((4, 5), bool)
    seen[1, 0] = False
    np.testing.assert_allclose(out[seen], points[seen], atol=1e-9)
    assert np.isnan(out[1, 0]).all()


def test_a_wrong_camera_moves_the_point_less_when_its_weight_is_lower():
    cams = _cameras()
    point = np.array([[[0.1, -0.2, 1.1]]])
    pixels = np.stack([c.project_world(point.reshape(-1, 3)).reshape(1, 1, 2) for c in cams])
    pixels[2, 0, 0] += 25.0  # one camera's keypoint 25 px off
    heavy = triangulate_weighted(cams, pixels, np.array([1.0, 1.0, 1.0])[:, None, None] * np.ones((3, 1, 1)))
    light = triangulate_weighted(cams, pixels, np.array([1.0, 1.0, 0.2])[:, None, None] * np.ones((3, 1, 1)))
    assert np.linalg.norm(light - point) < 0.5 * np.linalg.norm(heavy - point)


def _write_folder(folder, frames: int, keypoints: np.ndarray | None = None):
    folder.mkdir(parents=True)
    for f in range(frames):
        people = [] if keypoints is None else [{"pose_keypoints_2d": keypoints.ravel().tolist()}]
        (folder / f"{folder.name.split('_')[0]}.{f:04d}.json").write_text(json.dumps({"people": people}))


def test_folders_are_matched_by_number_not_by_order(tmp_path):
    cams = _cameras(("cam_10", "cam_2", "cam_3"))
    for name in ("cam02_json", "cam10_json"):
        _write_folder(tmp_path / name, 1)
    pairs = camera_folders(tmp_path, cams)
    assert [(c.name, p.name) for c, p in pairs] == [("cam_2", "cam02_json"), ("cam_10", "cam10_json")]


def test_bad_keypoint_folders_are_named(tmp_path):
    cams = _cameras()
    with pytest.raises(InputError, match="not a folder"):
        camera_folders(tmp_path / "none", cams)
    _write_folder(tmp_path / "cam07_json", 1)
    _write_folder(tmp_path / "cam01_json", 1)
    with pytest.raises(InputError, match="cam07_json matches no camera"):
        camera_folders(tmp_path, cams)
    short = tmp_path / "short"
    _write_folder(short / "cam01_json", 1, np.zeros((3, 3)))
    _write_folder(short / "cam02_json", 1, np.zeros((3, 3)))
    with pytest.raises(InputError, match="has 9 numbers, expected 75"):
        openpose_reference(short, cams, 30.0)


def test_it_reproduces_pose2sim_wherever_pose2sim_kept_every_camera(shared_data):
    """Pose2Sim triangulated these keypoints with the same likelihood threshold (0.3) but left a camera
    out where a keypoint reprojected more than 15 px away from it: where it did not, both give the
    same point (61.5 % of the 2,100 points within 1 mm, as ../shared's SOURCE.md found); the hips,
    which the networks place differently from each side, are where they part."""
    demo = shared_data / "pose2sim-demo"
    cams, _ = read_any_calibration(demo / "Calib_qualisys.toml")
    ref = openpose_reference(demo / "pose-associated", cams, 60.0)
    trc = read_trc(demo / TRC)
    assert ref.markers == BODY_25B and ref.points_trc.shape == (100, 25, 3)
    common = [m for m in trc.markers if m in ref.markers]
    a = np.stack([ref.points_trc[:, ref.markers.index(m)] for m in common], axis=1)
    b = np.stack([trc.points_trc[:, trc.markers.index(m)] for m in common], axis=1)
    d = np.linalg.norm(a - b, axis=-1)
    assert len(common) == 21 and np.isfinite(d).all()
    assert 0.60 <= np.mean(d < 1e-3) <= 0.63
    by = {m: float(np.median(d[:, k])) for k, m in enumerate(common)}
    assert by["LAnkle"] < 1e-3 and by["RAnkle"] < 1e-3 and by["Nose"] < 1e-3
    assert by["LHip"] > 0.03 and by["RHip"] > 0.03


def test_evaluate_refuses_two_references_and_needs_a_session(shared_data, tmp_path, capsys):
    demo = shared_data / "pose2sim-demo"
    args = ["evaluate", "--results", str(tmp_path), "--reference-keypoints", str(demo / "pose-associated")]
    assert main(args + ["--reference", str(demo / TRC)]) == 2
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "not both" in err[0] and "--reference-keypoints needs --session" in err[1]
    assert all(line.startswith("ergopose: error:") for line in err)
