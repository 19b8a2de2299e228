"""Triangulation: exact answers on simulated cameras, NaN rules, weights, outliers, and the
real Pose2Sim demo recording (4 cameras, OpenPose BODY_25B, Pose2Sim's own 3D output)."""

from __future__ import annotations

import json
import tomllib

import cv2
import numpy as np
import pytest

from ergopose.errors import InputError
from ergopose.geometry.triangulation import (
    RayTriangulation,
    Triangulation,
    projection_matrix,
    reject_outliers,
    reproject,
    triangulate_dlt,
    triangulate_midpoint,
)

K_PIX = np.array([[800.0, 0.0, 640.0], [0.0, 810.0, 360.0], [0.0, 0.0, 1.0]])


# ------------------------------------------------------------------------------------------
# Simulated cameras


def look_at(centre, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Pose world_from_cam (4x4) of a camera at ``centre`` looking at ``target`` (x right, y down)."""
    z = np.asarray(target, float) - np.asarray(centre, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    W = np.eye(4)
    W[:3, :3] = np.stack([x, y, z], axis=1)
    W[:3, 3] = centre
    return W


def ring_cameras(n: int, radius: float = 3.0, height: float = 2.5) -> tuple[np.ndarray, np.ndarray]:
    """n cameras on a circle around the work area; returns (P (n,3,4), poses (n,4,4))."""
    angles = np.linspace(0.0, 2 * np.pi, n, endpoint=False) + 0.3
    poses = np.stack([look_at([radius * np.cos(a), radius * np.sin(a), height], [0.1, -0.2, 1.0]) for a in angles])
    return projection_matrix(K_PIX, None, poses), poses


def body_points(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Points at human heights inside a 1.6 x 1.6 m box around the target."""
    low, high = np.array([-0.7, -1.0, 0.1]), np.array([0.9, 0.6, 1.9])
    return rng.uniform(low, high, size=shape + (3,))


# ------------------------------------------------------------------------------------------
# Projection matrix and reprojection


def test_projection_matrix_is_the_papers_product(rng):
    W = look_at([0.5, -0.3, 3.0], [0.4, -0.2, 0.0], up=(0.0, 1.0, 0.0))  # fisheye looking down
    # The view is the camera turned 40 degrees about its y axis then 10 about x.
    R, _ = cv2.Rodrigues(np.array([0.0, np.radians(40.0), 0.0]))
    R2, _ = cv2.Rodrigues(np.array([np.radians(10.0), 0.0, 0.0]))
    R = R @ R2
    paper = (
        K_PIX
        @ np.hstack([np.eye(3), np.zeros((3, 1))])
        @ np.block([[R.T, np.zeros((3, 1))], [np.zeros((1, 3)), np.ones((1, 1))]])
        @ np.linalg.inv(W)
    )
    P = projection_matrix(K_PIX, R, W)
    np.testing.assert_allclose(P, paper, rtol=1e-12, atol=1e-9)
    # Rotation direction: the view's optical axis is R @ e_z in the camera frame, so a point
    # along it lands on the principal point.
    on_axis_world = W[:3, :3] @ (R @ np.array([0.0, 0.0, 2.0])) + W[:3, 3]
    np.testing.assert_allclose(reproject(P[None], on_axis_world[None])[0, 0], K_PIX[:2, 2], atol=1e-9)
    # The transposed rotation would not.
    P_wrong = projection_matrix(K_PIX, R.T, W)
    assert np.linalg.norm(reproject(P_wrong[None], on_axis_world[None])[0, 0] - K_PIX[:2, 2]) > 100


def test_projection_matrix_matches_opencv_projectpoints(rng):
    rvec = np.array([0.3, -1.1, 0.4])
    tvec = np.array([0.2, 0.1, 3.5])
    R_cw, _ = cv2.Rodrigues(rvec)
    W = np.eye(4)
    W[:3, :3] = R_cw.T
    W[:3, 3] = -R_cw.T @ tvec
    P = projection_matrix(K_PIX, None, W)
    X = rng.uniform(-0.5, 0.5, size=(50, 3))
    expected, _ = cv2.projectPoints(X, rvec, tvec, K_PIX, None)
    np.testing.assert_allclose(reproject(P[None], X)[0], expected[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(P, K_PIX @ np.hstack([R_cw, tvec[:, None]]), atol=1e-9)


def test_projection_matrix_broadcasts_and_rejects_non_rigid_pose():
    _, poses = ring_cameras(3)
    P = projection_matrix(K_PIX, np.eye(3), poses)
    assert P.shape == (3, 3, 4)
    np.testing.assert_allclose(P[1], projection_matrix(K_PIX, None, poses[1]))
    scaled = poses[0].copy()
    scaled[:3, :3] *= 1.1
    with pytest.raises(InputError, match="pose_world_from_cam"):
        projection_matrix(K_PIX, None, scaled)
    with pytest.raises(InputError, match="rotation_cam_from_view"):
        projection_matrix(K_PIX, np.diag([1.0, 1.0, -1.0]), poses[0])


def test_reproject_gives_nan_behind_the_view():
    P, _ = ring_cameras(2)
    centre_0 = np.array([3.0 * np.cos(0.3), 3.0 * np.sin(0.3), 2.5])
    behind = centre_0 + (centre_0 - np.array([0.1, -0.2, 1.0]))  # opposite the viewing direction
    pix = reproject(P, np.array([behind, [np.nan, 0.0, 0.0]]))
    assert pix.shape == (2, 2, 2)
    assert np.all(np.isnan(pix[0, 0])) and np.all(np.isfinite(pix[1, 0]))
    assert np.all(np.isnan(pix[:, 1]))


# ------------------------------------------------------------------------------------------
# DLT: exact on noise-free data


@pytest.mark.parametrize("n_views", [2, 3, 4])
@pytest.mark.parametrize("solver", ["normal", "svd"])
def test_dlt_exact_on_noise_free_data_batched(rng, n_views, solver):
    P, _ = ring_cameras(n_views)
    X = body_points(rng, (6, 2, 17))  # frames x people x joints
    pixels = reproject(P, X)  # (6, 2, V, 17, 2)
    assert pixels.shape == (6, 2, n_views, 17, 2)
    assert 100 < np.nanmean(np.abs(pixels)) < 1500  # pixel coordinates in the hundreds
    tri = triangulate_dlt(P, pixels, solver=solver)
    assert isinstance(tri, Triangulation)
    assert tri.points.shape == (6, 2, 17, 3)
    assert tri.reprojection_error_px.shape == (6, 2, 17)
    assert tri.views_used.shape == (6, 2, 17)
    assert tri.residuals_px.shape == (6, 2, n_views, 17)
    np.testing.assert_allclose(tri.points, X, rtol=1e-9, atol=0)
    np.testing.assert_array_equal(tri.views_used, n_views)
    assert np.all(tri.residuals_px < 1e-6)
    assert np.all(tri.reprojection_error_px < 1e-6)


def test_dlt_per_frame_projections_broadcast(rng):
    # Virtual views move with the person: one set of projection matrices per frame.
    frames = 5
    centres = np.array([[0.0, 0.0, 3.0], [1.5, 0.0, 3.0]])
    X = body_points(rng, (frames, 12))
    P = np.empty((frames, 2, 3, 4))
    for f in range(frames):
        for v in range(2):
            P[f, v] = projection_matrix(K_PIX, None, look_at(centres[v], X[f].mean(axis=0), up=(0, 1, 0)))
    pixels = reproject(P, X)
    tri = triangulate_dlt(P, pixels)
    np.testing.assert_allclose(tri.points, X, rtol=1e-9)
    # Shared matrices with per-frame pixels broadcast the other way.
    P0 = P[0]
    tri0 = triangulate_dlt(P0, reproject(P0, X))
    np.testing.assert_allclose(tri0.points, X, rtol=1e-9)


def test_dlt_world_far_from_origin_stays_exact(rng):
    # Conditioning: pixels in the hundreds and a world origin 500 m away.
    offset = np.array([500.0, -300.0, 0.0])
    _, poses = ring_cameras(3)
    poses[:, :3, 3] += offset
    P = projection_matrix(K_PIX, None, poses)
    X = body_points(rng, (40,)) + offset
    tri = triangulate_dlt(P, reproject(P, X))
    np.testing.assert_allclose(tri.points, X, rtol=0, atol=1e-8)


def test_fisheye_cameras_through_virtual_views(rng):
    # The pipeline: ceiling fisheye cameras (Kannala-Brandt), upright virtual views aimed at the
    # person, pixels mapped fisheye -> view, DLT with the paper's P of each view.
    from ergopose.geometry.camera import ceiling_camera
    from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt
    from ergopose.geometry.views import VirtualView

    lens = KannalaBrandt(fx=620.0, fy=620.0, cx=1295.5, cy=971.5, k1=-7.4e-05, k2=-0.00703, k3=0.00738, k4=-0.00342)
    cams = [
        ceiling_camera(f"cam_{i}", lens, 2592, 1944, c) for i, c in enumerate([(-0.75, 0.0, 3.0), (0.75, 0.0, 3.0)])
    ]
    X = body_points(rng, (33,)) + np.array([2.0, -2.5, 0.0])  # near a corner of the floor
    views = [VirtualView.aimed_at(cam, X.mean(axis=0), hfov=np.radians(60.0), size=(320, 320)) for cam in cams]
    P = np.stack([projection_matrix(v.K, v.rotation_cam_from_view, v.source.pose_world_from_cam) for v in views])
    np.testing.assert_allclose(P, np.stack([v.projection_matrix for v in views]), rtol=1e-12, atol=1e-9)
    pixels_view = np.stack([v.source_to_view_pixels(cam.project_world(X)) for v, cam in zip(views, cams)])
    np.testing.assert_allclose(pixels_view, reproject(P, X), atol=1e-6)
    tri = triangulate_dlt(P, pixels_view)
    np.testing.assert_allclose(tri.points, X, rtol=0, atol=1e-7)


# ------------------------------------------------------------------------------------------
# DLT: missing observations


def test_nan_pixels_and_zero_weights_are_excluded(rng):
    P, _ = ring_cameras(3)
    X = body_points(rng, (4, 10))
    pixels = reproject(P, X)  # (4, 3, 10, 2)
    weights = np.ones(pixels.shape[:-1])
    pixels[0, 1, 2] = np.nan  # frame 0 joint 2: view 1 missing
    pixels[1, 0, 3] = [5000.0, -70.0]  # frame 1 joint 3: garbage in view 0 ...
    weights[1, 0, 3] = 0.0  # ... with weight 0
    pixels[2, 0, 4, 0] = np.nan  # one coordinate NaN is enough
    pixels[3, 2, 5] = [-900.0, 80.0]  # frame 3 joint 5: garbage in view 2 ...
    weights[3, 2, 5] = np.nan  # ... with an unknown weight
    tri = triangulate_dlt(P, pixels, weights)
    np.testing.assert_allclose(tri.points, X, rtol=1e-9)
    assert tri.views_used[0, 2] == 2 and tri.views_used[1, 3] == 2 and tri.views_used[2, 4] == 2
    assert tri.views_used[3, 5] == 2
    assert tri.views_used.sum() == 4 * 10 * 3 - 4
    assert np.isnan(tri.residuals_px[0, 1, 2]) and np.isnan(tri.residuals_px[1, 0, 3])
    assert np.isfinite(tri.residuals_px[0, 0, 2]) and np.isfinite(tri.reprojection_error_px[0, 2])


def test_fewer_than_min_views_gives_nan_never_a_point(rng):
    P, _ = ring_cameras(3)
    X = body_points(rng, (8,))
    pixels = reproject(P, X)
    pixels[1:, 0] = np.nan  # joint 0 only in view 0
    pixels[:, 1] = np.nan  # joint 1 nowhere
    pixels[2, 2] = np.nan  # joint 2 in views 0 and 1 only
    tri = triangulate_dlt(P, pixels)
    np.testing.assert_array_equal(tri.views_used[:3], [1, 0, 2])
    assert np.all(np.isnan(tri.points[:2])) and np.all(np.isnan(tri.reprojection_error_px[:2]))
    assert np.all(np.isnan(tri.residuals_px[:, :2]))
    np.testing.assert_allclose(tri.points[2:], X[2:], rtol=1e-9)
    strict = triangulate_dlt(P, pixels, min_views=3)
    assert np.all(np.isnan(strict.points[:3])) and np.all(np.isfinite(strict.points[3:]))
    assert strict.views_used[2] == 2


def test_views_from_one_centre_cannot_fix_a_point():
    # Two virtual views of the same fisheye camera: the rays coincide, depth is unknown.
    W = look_at([0.0, 0.0, 3.0], [0.5, 0.5, 0.0], up=(0, 1, 0))
    R, _ = cv2.Rodrigues(np.array([0.0, 0.2, 0.0]))
    P = projection_matrix(K_PIX, np.stack([np.eye(3), R]), W)
    X = np.array([[0.4, 0.6, 1.0], [0.5, 0.3, 1.5]])
    tri = triangulate_dlt(P, reproject(P, X))
    assert np.all(np.isnan(tri.points)) and np.all(tri.views_used == 2)
    tri_svd = triangulate_dlt(P, reproject(P, X), solver="svd")
    assert np.all(np.isnan(tri_svd.points))


def test_point_behind_a_view_has_infinite_residual():
    # Camera A at the origin looks along +z; camera B looks along -x at (0, 0, -2). Both see
    # their principal point: the rays meet at (0, 0, -2), behind A.
    W_a = look_at([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], up=(0.0, 1.0, 0.0))
    W_b = look_at([1.0, 0.0, -2.0], [0.0, 0.0, -2.0])
    P = projection_matrix(K_PIX, None, np.stack([W_a, W_b]))
    pixels = np.broadcast_to(K_PIX[:2, 2], (2, 1, 2))
    tri = triangulate_dlt(P, pixels)
    np.testing.assert_allclose(tri.points[0], [0.0, 0.0, -2.0], atol=1e-12)
    assert np.isinf(tri.residuals_px[0, 0]) and tri.residuals_px[1, 0] < 1e-9
    assert np.isinf(tri.reprojection_error_px[0])
    assert np.all(np.isnan(reproject(P[:1], tri.points)))


# ------------------------------------------------------------------------------------------
# DLT: noise, weights, residuals


def test_residuals_match_an_independent_reprojection(rng):
    P, poses = ring_cameras(3)
    X = body_points(rng, (30,))
    pixels = reproject(P, X) + rng.normal(0.0, 2.0, size=(3, 30, 2))
    tri = triangulate_dlt(P, pixels)
    for v in range(3):
        R_cw = poses[v, :3, :3].T
        t = -R_cw @ poses[v, :3, 3]
        proj, _ = cv2.projectPoints(tri.points, cv2.Rodrigues(R_cw)[0], t, K_PIX, None)
        np.testing.assert_allclose(
            tri.residuals_px[v], np.linalg.norm(proj[:, 0] - pixels[v], axis=-1), rtol=1e-9, atol=1e-9
        )
    np.testing.assert_allclose(tri.reprojection_error_px, np.sqrt(np.mean(tri.residuals_px**2, axis=0)))
    # With noise the error is of the order of the noise, and the 3D error of millimetres.
    assert 0.5 < np.median(tri.reprojection_error_px) < 3.0
    assert np.median(np.linalg.norm(tri.points - X, axis=-1)) < 0.01


def test_weights_pull_the_answer_toward_the_trusted_view(rng):
    P, _ = ring_cameras(3)
    X = body_points(rng, (200,))
    pixels = reproject(P, X)
    pixels[0] += rng.normal(0.0, 8.0, size=(200, 2))  # view 0 is poor
    pixels[1:] += rng.normal(0.0, 0.5, size=(2, 200, 2))
    equal = triangulate_dlt(P, pixels)
    weights = np.ones((3, 200))
    weights[0] = 0.1
    trusted = triangulate_dlt(P, pixels, weights)
    err_equal = np.linalg.norm(equal.points - X, axis=-1)
    err_trusted = np.linalg.norm(trusted.points - X, axis=-1)
    assert np.mean(err_trusted) < 0.5 * np.mean(err_equal)
    # The residual in the poor view grows, in the trusted views it shrinks.
    assert np.nanmean(trusted.residuals_px[0]) > np.nanmean(equal.residuals_px[0])
    assert np.nanmean(trusted.residuals_px[1:]) < np.nanmean(equal.residuals_px[1:])
    # Scaling all weights together changes nothing.
    np.testing.assert_allclose(triangulate_dlt(P, pixels, 7.0 * weights).points, trusted.points, rtol=1e-9)
    # A vanishing weight tends to leaving the view out.
    weights[0] = 1e-4
    np.testing.assert_allclose(
        triangulate_dlt(P, pixels, weights).points, triangulate_dlt(P[1:], pixels[1:]).points, atol=1e-6
    )


def test_normalized_rows_ignore_the_scale_of_p(rng):
    # P and 1000 P project identically. Normalised rows give the same point; raw rows (Pose2Sim)
    # weight the rescaled view 1000 times more and move the point by millimetres.
    P, _ = ring_cameras(3)
    X = body_points(rng, (300,))
    pixels = reproject(P, X) + rng.normal(0.0, 1.0, size=(3, 300, 2))
    P_scaled = P.copy()
    P_scaled[0] *= 1000.0
    for solver in ("normal", "svd"):
        a = triangulate_dlt(P, pixels, solver=solver).points
        b = triangulate_dlt(P_scaled, pixels, solver=solver).points
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
        raw_a = triangulate_dlt(P, pixels, solver=solver, normalize_rows=False).points
        raw_b = triangulate_dlt(P_scaled, pixels, solver=solver, normalize_rows=False).points
        assert np.max(np.abs(raw_a - raw_b)) > 1e-3
        assert np.mean(np.linalg.norm(a - X, axis=-1)) < 0.01


def test_normal_solver_does_not_depend_on_the_world_origin(rng):
    P, poses = ring_cameras(3)
    X = body_points(rng, (300,))
    pixels = reproject(P, X) + rng.normal(0.0, 1.0, size=(3, 300, 2))
    offset = np.array([500.0, -300.0, 0.0])
    poses[:, :3, 3] += offset
    P_far = projection_matrix(K_PIX, None, poses)
    near = triangulate_dlt(P, pixels).points
    far = triangulate_dlt(P_far, pixels).points - offset
    np.testing.assert_allclose(near, far, rtol=0, atol=1e-9)
    # The homogeneous (unit-norm) solution is not invariant: it moves by tens of micrometres.
    svd_near = triangulate_dlt(P, pixels, solver="svd").points
    svd_far = triangulate_dlt(P_far, pixels, solver="svd").points - offset
    assert np.max(np.abs(svd_near - svd_far)) > 1e-5


def test_bad_inputs_raise_input_error():
    P, _ = ring_cameras(2)
    pixels = np.zeros((2, 5, 2))
    with pytest.raises(InputError, match="projections"):
        triangulate_dlt(P[:1], pixels)
    with pytest.raises(InputError, match="pixels"):
        triangulate_dlt(P, np.zeros((2, 5, 3)))
    with pytest.raises(InputError, match="weights"):
        triangulate_dlt(P, pixels, -np.ones((2, 5)))
    with pytest.raises(InputError, match="min_views"):
        triangulate_dlt(P, pixels, min_views=1)
    with pytest.raises(InputError, match="solver"):
        triangulate_dlt(P, pixels, solver="magic")


# ------------------------------------------------------------------------------------------
# Midpoint


def _rays(poses: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    origins = poses[:, :3, 3]
    rays = X[..., None, :, :] - origins[:, None, :]
    return origins, rays * np.linspace(0.5, 2.0, rays.shape[-2])[:, None]  # any length


def test_midpoint_agrees_with_dlt_on_noise_free_data(rng):
    P, poses = ring_cameras(3)
    X = body_points(rng, (4, 2, 9))
    origins, rays = _rays(poses, X)
    mid = triangulate_midpoint(origins, rays)
    assert isinstance(mid, RayTriangulation)
    assert mid.points.shape == (4, 2, 9, 3) and mid.residuals_m.shape == (4, 2, 3, 9)
    dlt = triangulate_dlt(P, reproject(P, X))
    np.testing.assert_allclose(mid.points, X, rtol=1e-9)
    np.testing.assert_allclose(mid.points, dlt.points, rtol=1e-9)
    assert np.all(mid.rms_distance_m < 1e-9)


def test_midpoint_two_skew_rays_gives_the_midpoint_of_the_common_perpendicular():
    origins = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    rays = np.array([[[0.0, 1.0, 0.0]], [[0.0, 0.0, 1.0]]])  # y axis, and x=1 parallel to z
    mid = triangulate_midpoint(origins, rays, np.ones((2, 1)) * 3.0)
    np.testing.assert_allclose(mid.points[0], [0.5, 0.0, 0.0], atol=1e-12)
    # Both rays pass 0.5 m from it ... but the point is at the origin of both rays (t = 0),
    # so move the origins back to have the point in front.
    origins = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, -1.0]])
    mid = triangulate_midpoint(origins, rays)
    np.testing.assert_allclose(mid.points[0], [0.5, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(mid.residuals_m[:, 0], [0.5, 0.5], atol=1e-12)
    np.testing.assert_allclose(mid.rms_distance_m[0], 0.5, atol=1e-12)
    # Weights: the trusted ray (weight 3) gets 1/(1+9) of the gap, the other 9/10.
    mid = triangulate_midpoint(origins, rays, np.array([[3.0], [1.0]]))
    np.testing.assert_allclose(mid.points[0], [0.1, 0.0, 0.0], atol=1e-12)


def test_midpoint_nan_rules(rng):
    _, poses = ring_cameras(3)
    X = body_points(rng, (5,))
    origins, rays = _rays(poses, X)
    rays[0, 0] = np.nan
    rays[1, 0] = np.nan  # joint 0: one ray
    weights = np.ones((3, 5))
    weights[:2, 1] = 0.0  # joint 1: one ray
    rays[2, 2] = [1e3, 0, 0]
    weights[2, 2] = 0.0  # joint 2: two good rays, garbage with weight 0
    mid = triangulate_midpoint(origins, rays, weights)
    np.testing.assert_array_equal(mid.views_used, [1, 1, 2, 3, 3])
    assert np.all(np.isnan(mid.points[:2])) and np.all(np.isnan(mid.residuals_m[:, :2]))
    np.testing.assert_allclose(mid.points[2:], X[2:], rtol=1e-9)
    parallel = triangulate_midpoint(origins[:2], np.broadcast_to([[[0.0, 0.0, 1.0]]], (2, 1, 3)))
    assert np.all(np.isnan(parallel.points))


# ------------------------------------------------------------------------------------------
# Outlier rejection


def test_reject_outliers_drops_the_wrong_view(rng):
    P, _ = ring_cameras(5)
    X = body_points(rng, (3, 20))
    pixels = reproject(P, X) + rng.normal(0.0, 0.3, size=(3, 5, 20, 2))
    truth_bad = np.zeros((3, 5, 20), dtype=bool)
    truth_bad[0, 2, 5] = truth_bad[1, 0, 7] = truth_bad[2, 3, 0] = True
    truth_bad[2, 1, 9] = truth_bad[2, 3, 9] = True  # two wrong views of one joint
    pixels[truth_bad] += np.array([60.0, -45.0])
    plain = triangulate_dlt(P, pixels)
    assert np.all(plain.reprojection_error_px[truth_bad.any(axis=1)] > 15)
    tri, rejected = reject_outliers(P, pixels, threshold_px=5.0)
    np.testing.assert_array_equal(rejected, truth_bad)
    assert np.all(tri.reprojection_error_px < 2.0)
    assert np.all(np.isnan(tri.residuals_px[rejected]))
    np.testing.assert_array_equal(tri.views_used, 5 - rejected.sum(axis=-2))
    assert np.max(np.linalg.norm(tri.points - X, axis=-1)) < 0.01


def test_reject_outliers_keeps_min_views_and_clean_data(rng):
    P, _ = ring_cameras(2)
    X = body_points(rng, (10,))
    pixels = reproject(P, X)
    pixels[0, 3] += 40.0
    tri, rejected = reject_outliers(P, pixels, threshold_px=5.0)
    assert not rejected.any()  # only two views: nothing may go
    assert tri.reprojection_error_px[3] > 5.0 and np.isfinite(tri.points[3]).all()
    P3, _ = ring_cameras(3)
    tri3, rejected3 = reject_outliers(P3, reproject(P3, X), threshold_px=1.0)
    assert not rejected3.any()
    np.testing.assert_allclose(tri3.points, X, rtol=1e-9)


# ------------------------------------------------------------------------------------------
# Real data: the Pose2Sim demo session

#: BODY_25B keypoint index of each TRC marker, in the TRC's column order; from the skeleton tree
#: printed in Config_BalancingTrial.toml ([pose.CUSTOM]: "id = 12, name = RHip", ...).
TRC_TO_BODY25B = {
    "RHip": 12,
    "RKnee": 14,
    "RAnkle": 16,
    "RBigToe": 22,
    "RSmallToe": 23,
    "RHeel": 24,
    "LHip": 11,
    "LKnee": 13,
    "LAnkle": 15,
    "LBigToe": 19,
    "LSmallToe": 20,
    "LHeel": 21,
    "Neck": 17,
    "Head": 18,
    "Nose": 0,
    "RShoulder": 6,
    "RElbow": 8,
    "RWrist": 10,
    "LShoulder": 5,
    "LElbow": 7,
    "LWrist": 9,
}


@pytest.fixture(scope="module")
def pose2sim(shared_data):
    root = shared_data / "pose2sim-demo"
    calib = tomllib.loads((root / "Calib_qualisys.toml").read_text())
    cams = sorted(k for k in calib if k.startswith("cam_"))
    assert cams == ["cam_01", "cam_02", "cam_03", "cam_04"]
    P = []
    for cam in cams:
        K = np.array(calib[cam]["matrix"])
        R_cw, _ = cv2.Rodrigues(np.array(calib[cam]["rotation"]))  # world -> camera
        t = np.array(calib[cam]["translation"])  # metres
        W = np.eye(4)
        W[:3, :3], W[:3, 3] = R_cw.T, -R_cw.T @ t
        P.append(projection_matrix(K, None, W))  # == K [R|t]; undistort_points = false
    P = np.array(P)

    # TRC: header line 3 says units, line 4 the marker names.
    lines = (root / "pose-3d" / "S00_P00_T01_BalancingTrial_0-100.trc").read_text().splitlines()
    header = dict(zip(lines[1].split("\t"), lines[2].split("\t")))
    assert header["Units"] == "m" and header["NumMarkers"] == "21" and header["NumFrames"] == "100"
    names = [n for n in lines[3].split("\t")[2:] if n]
    assert len(names) == 21
    values = np.array([[float(x) for x in line.split("\t")[2 : 2 + 63]] for line in lines[5:] if line.strip()])
    trc = values.reshape(-1, 21, 3)
    assert trc.shape[0] == 100
    points_world = trc[..., [2, 0, 1]]  # TRC axes = world[:, [1, 2, 0]]
    idx = np.array([TRC_TO_BODY25B[n] for n in names])

    frames = np.full((100, 4, 25, 3), np.nan)
    for v in range(4):
        for f in range(100):
            path = root / "pose-associated" / f"cam0{v + 1}_json" / f"cam0{v + 1}.{f:04d}.json"
            people = json.loads(path.read_text())["people"]
            if people and "pose_keypoints_2d" in people[0]:  # {} = no person associated
                frames[f, v] = np.array(people[0]["pose_keypoints_2d"]).reshape(25, 3)
    pixels = frames[:, :, idx, :2]
    confidence = np.nan_to_num(frames[:, :, idx, 2])
    weights = np.where(confidence >= 0.3, confidence, 0.0)  # likelihood_threshold_triangulation
    return P, pixels, weights, points_world


def test_pose2sim_demo_reproduced_by_weighted_dlt(pose2sim):
    P, pixels, weights, reference = pose2sim
    # Pose2Sim's own method: raw rows times likelihood, homogeneous SVD solution.
    tri = triangulate_dlt(P, pixels, weights, solver="svd", normalize_rows=False)
    assert tri.points.shape == (100, 21, 3)
    diff_mm = 1000 * np.linalg.norm(tri.points - reference, axis=-1)
    n_views = tri.views_used
    assert n_views.min() >= 2
    close = diff_mm < 0.1
    assert 0.60 <= close.mean() <= 0.63  # SOURCE.md: 61.5 % of the 2,100 points
    assert close[n_views == 2].mean() >= 0.90  # 93.5 % of the 2-camera points
    assert 0.55 <= close[n_views == 4].mean() <= 0.61  # 57.9 % of the 4-camera points
    # The rest is where Pose2Sim left a camera out (reprojection error over 15 px).
    assert np.median(tri.reprojection_error_px[~close]) > np.median(tri.reprojection_error_px[close])
    assert 20 < np.mean(diff_mm) < 28  # SOURCE.md: mean difference 24 mm (all points)
    assert 50 < np.percentile(diff_mm, 90) < 62  # SOURCE.md: p90 56 mm
    # Median reprojection error (mean over cameras, as Pose2Sim reports it): about 13-14 px.
    assert 12 < np.median(np.nanmean(tri.residuals_px, axis=1)) < 15

    # Our default (rows normalised to metres, w = 1) differs from Pose2Sim's algebraic
    # solution by about a millimetre, on the same 2D data.
    ours = triangulate_dlt(P, pixels, weights)
    to_p2s = 1000 * np.linalg.norm(ours.points - tri.points, axis=-1)
    assert np.median(to_p2s) < 2.0
    assert abs(np.median(ours.reprojection_error_px) - np.median(tri.reprojection_error_px)) < 0.5


def test_pose2sim_demo_outlier_rejection_moves_toward_pose2sim(pose2sim):
    P, pixels, weights, reference = pose2sim
    plain = triangulate_dlt(P, pixels, weights, solver="svd", normalize_rows=False)
    tri, rejected = reject_outliers(P, pixels, weights, threshold_px=15.0, solver="svd", normalize_rows=False)
    before = np.mean(1000 * np.linalg.norm(plain.points - reference, axis=-1) < 0.1)
    after = np.mean(1000 * np.linalg.norm(tri.points - reference, axis=-1) < 0.1)
    assert after > before + 0.1  # 61.5 % -> about 74 %
    assert rejected.any() and not (rejected & (weights == 0)).any()
    assert np.all(tri.views_used >= 2)
