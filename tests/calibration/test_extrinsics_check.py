"""Pose solver and bar check on exact synthetic data (known answers)."""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.calibration._so3 import rotation_matrices
from ergopose.calibration.boards import parse_board
from ergopose.calibration.check import (
    angles_from_axis,
    measure_bar,
    read_bar_observations,
    region_of,
    write_bar_observations,
)
from ergopose.calibration.extrinsics import floor_board_points, residuals_mm, solve_pose
from ergopose.calibration.simulate import board_pose_in_camera, floor_board_transform
from ergopose.errors import InputError
from ergopose.geometry.camera import Camera, ceiling_rotation
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt

LENS = KannalaBrandt(245.0, 245.5, 401.3, 398.2, 0.02, -0.005, 0.001, -0.0002)


def _camera(name="cam", position=(0.3, -0.2, 3.0), yaw=0.4, tilt=(0.02, -0.03, 0.0)):
    R = rotation_matrices(np.array(tilt)) @ ceiling_rotation(yaw)
    return Camera(name, LENS, 800, 800, R, position)


def test_solve_pose_recovers_an_exact_pose_from_floor_points(rng):
    cam = _camera()
    pts = np.concatenate([rng.uniform(-3, 3, (30, 2)), np.zeros((30, 1))], axis=1)
    pts[:5, 2] = rng.uniform(0.5, 2.0, 5)  # a few points above the floor
    res = solve_pose(LENS, pts, cam.project_world(pts))
    np.testing.assert_allclose(res.position_world, cam.position_world, atol=1e-8)
    np.testing.assert_allclose(res.rotation_world_from_cam, cam.rotation_world_from_cam, atol=1e-9)
    assert res.rms_px < 1e-6 and res.residuals_mm.max() < 1e-5


def test_solve_pose_with_noise_and_residual_units(rng):
    cam = _camera()
    pts = np.concatenate([rng.uniform(-3, 3, (40, 2)), np.zeros((40, 1))], axis=1)
    px = cam.project_world(pts) + rng.normal(0, 0.3, (40, 2))
    res = solve_pose(LENS, pts, px)
    assert np.linalg.norm(res.position_world - cam.position_world) < 0.01
    assert 0.15 < res.rms_px < 0.45
    # mm on the floor: a pixel 1 px off near the image centre misses by about 3 m / f = 12 mm
    shifted = cam.project_world(np.array([[0.3, -0.2, 0.0]])) + [[1.0, 0.0]]
    mm = residuals_mm(LENS, cam.rotation_world_from_cam, cam.position_world, np.array([[0.3, -0.2, 0.0]]), shifted)
    assert mm[0] == pytest.approx(3000.0 / 245.0, rel=0.02)


def test_solve_pose_rejects_too_few_or_collinear_points():
    cam = _camera()
    line = np.stack([np.linspace(-2, 2, 8), np.zeros(8), np.zeros(8)], -1)
    with pytest.raises(InputError, match="on one line"):
        solve_pose(LENS, line, cam.project_world(line))
    with pytest.raises(InputError, match="at least 4"):
        solve_pose(LENS, line[:3], cam.project_world(line[:3]))


def test_floor_board_frame_is_right_handed_and_matches_the_renderer():
    b = parse_board("checkerboard:9x6:0.25")
    pts = floor_board_points(b, origin_xy=(1.0, 2.0), yaw=np.radians(30))
    R_wb = floor_board_transform(np.radians(30))
    assert np.linalg.det(R_wb) == pytest.approx(1.0)
    np.testing.assert_allclose(pts, b.object_points() @ R_wb.T + [1.0, 2.0, 0.0], atol=1e-12)
    assert np.all(pts[:, 2] == 0)
    # seen from the ceiling the board's z axis (into the board) points down
    cam = _camera()
    R, t = board_pose_in_camera(cam.rotation_world_from_cam, cam.position_world, R_wb, [1.0, 2.0, 0.0])
    assert (R @ [0, 0, 1])[2] > 0.9


def test_bar_measured_exactly_through_exact_cameras(rng):
    cams = (_camera("a", (-0.75, 0, 3.0), 0.1), _camera("b", (0.75, 0, 3.0), 3.0, (0.0, 0.01, 0.0)))
    centre = np.stack([rng.uniform(-2.5, 2.5, 50), rng.uniform(-2.5, 2.5, 50), rng.uniform(0.3, 2.3, 50)], -1)
    az = rng.uniform(0, np.pi, 50)
    d = np.stack([np.cos(az), np.sin(az), np.zeros(50)], -1)
    ends = np.stack([centre - 0.75 * d, centre + 0.75 * d], 1)
    px = np.stack([c.project_world(ends) for c in cams], axis=1)
    rep = measure_bar(cams, px, 1.5)
    np.testing.assert_allclose(rep.measurements.lengths, 1.5, atol=1e-7)
    np.testing.assert_allclose(rep.measurements.endpoints_world, ends, atol=1e-7)
    # the region is the one of the largest angle from a lens axis
    angles = np.stack([np.stack([c.theta_of_points_world(ends[:, e]) for e in range(2)], -1) for c in cams], 1)
    expected = region_of(angles.max(axis=(1, 2)), (np.radians(30), np.radians(60)))
    assert [("central", "outer", "edge")[i] for i in expected] == list(rep.measurements.regions)
    assert sum(r.n for r in rep.regions) == 50
    np.testing.assert_allclose(angles_from_axis(cams[0], px[:, 0, 0]), angles[:, 0, 0], atol=1e-9)


def test_region_bounds():
    np.testing.assert_array_equal(
        region_of(np.radians([0, 39.9, 40.0, 69.9, 70, 95]), np.radians([40, 70])), [0, 0, 1, 1, 2, 2]
    )


def test_observation_csv_round_trip(tmp_path, rng):
    px = rng.uniform(100, 700, (4, 2, 2, 2))
    px[1, 0, 1] = np.nan  # camera 0 did not see end b of measurement 2 ...
    px_three = np.concatenate([px, rng.uniform(100, 700, (4, 1, 2, 2))], axis=1)  # ... a third camera did
    path = write_bar_observations(tmp_path / "obs.csv", ["a", "b", "c"], px_three, labels=["m1", "m2", "m3", "m4"])
    labels, back = read_bar_observations(path, ["a", "b", "c"])
    assert labels == ["m1", "m2", "m3", "m4"]
    np.testing.assert_allclose(back, px_three, atol=1e-4)
