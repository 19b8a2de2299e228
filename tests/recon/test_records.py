"""The input record and the fisheye adapter, against the geometry module's own classes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ergopose.errors import InputError
from ergopose.geometry.views import VirtualView, upright_rotation
from ergopose.recon.records import People3D, body_centres
from ergopose.records import Detections2D, detections_from_fisheye, upright_rotations
from ergopose.sim.synthetic import project_all, walk_workers
from tests.recon.conftest import FPS, crossing_scripts


def test_upright_rotations_match_views_module(rng):
    d = rng.normal(size=(50, 3))
    up = np.array([0.1, -0.2, -0.97])
    R = upright_rotations(d, up)
    for k in range(50):
        assert np.allclose(R[k], upright_rotation(d[k], up), atol=1e-12)
    # Parallel to up: falls back like the views module.
    assert np.allclose(
        upright_rotations(np.array([[0, 0, 1.0]]), np.array([0, 0, 1.0]))[0],
        upright_rotation(np.array([0, 0, 1.0]), np.array([0, 0, 1.0])),
    )


def test_fisheye_adapter_equals_virtual_view(cameras, rng):
    truth = walk_workers(crossing_scripts(), 1, FPS)[0]  # (4, 33, 3)
    cam = cameras[0]
    px = cam.project_world(truth)
    conf = rng.uniform(0.5, 1.0, px.shape[:2])
    det = detections_from_fisheye(cam, 5, 5 / FPS, px, conf, view_size=(256, 256))
    assert det.count == 4
    for n in range(4):
        rays = cam.lens.unproject(px[n])
        axis = rays.mean(axis=0)
        axis /= np.linalg.norm(axis)
        half = np.degrees(np.max(np.arccos(np.clip(rays @ axis, -1, 1))))
        fov = math.radians(np.clip(2 * half + 8.0, 20.0, 150.0))
        view = VirtualView.aimed_along(cam, axis, fov, (256, 256))
        assert np.allclose(det.projection[n], view.projection_matrix, atol=1e-9)
        assert np.allclose(det.pixels_view[n], view.source_to_view_pixels(px[n]), atol=1e-6)
        # P maps the true 3D joints onto the view pixels; world_rays point at them.
        assert np.allclose(det.pixels_view[n], view.project_world(truth[n]), atol=1e-6)
        to_joint = truth[n] - cam.position_world
        to_joint /= np.linalg.norm(to_joint, axis=-1, keepdims=True)
        assert np.allclose(det.world_rays()[n], to_joint, atol=1e-9)
        assert np.allclose(det.centres_world()[n], cam.position_world, atol=1e-9)
    assert np.allclose(det.confidence, conf)


def test_detections_validation_and_nan_meaning():
    px = np.zeros((2, 33, 2))
    px[0, 3] = np.nan
    P = np.tile(np.hstack([np.eye(3), np.zeros((3, 1))]), (2, 1, 1))
    det = Detections2D("cam_1", 0, 0.0, px, np.ones((2, 33)), P)
    assert det.confidence[0, 3] == 0.0 and np.all(np.isnan(det.pixels_view[0, 3]))
    with pytest.raises(InputError, match="confidence"):
        Detections2D("cam_1", 0, 0.0, px, np.full((2, 33), 1.5), P)
    with pytest.raises(InputError, match="projection"):
        Detections2D("cam_1", 0, 0.0, px, np.ones((2, 33)), P[:1])
    with pytest.raises(InputError, match="cam_1"):
        Detections2D("cam_1", 0, 0.0, np.zeros((2, 30, 2)), np.ones((2, 33)), P)
    assert not det.pixels_view.flags.writeable
    assert Detections2D.empty("cam_2", 3, 0.25).count == 0


def test_body_centres_prefer_torso():
    X = np.full((2, 33, 3), np.nan)
    X[0, [11, 12, 23, 24]] = [[0, 0, 1], [1, 0, 1], [0, 0, 0], [1, 0, 0]]
    X[0, 0] = [10, 10, 10]  # nose far away: ignored while torso joints exist
    X[1, 0] = [1, 2, 3]
    c = body_centres(X)
    assert np.allclose(c[0], [0.5, 0, 0.5]) and np.allclose(c[1], [1, 2, 3])
    assert np.all(np.isnan(body_centres(np.full((33, 3), np.nan))))


def test_people_from_points_and_take(cameras):
    X = walk_workers(crossing_scripts(), 3, FPS).reshape(-1, 33, 3)
    X[0, 5] = np.nan
    p = People3D.from_points(np.repeat(np.arange(3), 4), np.repeat(np.arange(3), 4) / FPS, X)
    assert len(p) == 12 and p.views[0, 5] == 0 and p.views[0, 4] == 2
    assert np.isnan(p.variance_world[0, 5]).all() and np.allclose(p.variance_world[1], 0.03**2)
    q = People3D.concat([p.take(np.arange(4)), p.take(np.arange(4, 12))])
    assert np.array_equal(q.points_world, p.points_world, equal_nan=True)


def test_project_all_marks_outside_image(cameras):
    cam = cameras[0]
    th = np.radians(120.0)  # 120 degrees off-axis towards the image's short side: off the image
    inside = cam.position_world + cam.rotation_world_from_cam @ np.array([0.0, 0.2, 1.0])
    outside = cam.position_world + cam.rotation_world_from_cam @ np.array([0.0, np.sin(th), np.cos(th)])
    X = np.stack([np.broadcast_to(inside, (33, 3)), np.broadcast_to(outside, (33, 3))])[None]
    px = project_all(cameras, X)
    assert np.isfinite(px[0, 0, 0]).all() and np.isnan(px[0, 0, 1]).all()


def test_a_subset_keeps_the_chosen_people_whole(cameras, rng):
    truth = walk_workers(crossing_scripts(), 1, FPS)[0]  # (4, 33, 3)
    cam = cameras[0]
    px = cam.project_world(truth)
    det = detections_from_fisheye(cam, 5, 5 / FPS, px, rng.uniform(0.5, 1.0, px.shape[:2]))
    det = Detections2D(
        det.camera, det.frame, det.time_s, det.pixels_view, det.confidence, det.projection,
        det.world_rays(), rng.uniform(0, 100, (4, 6)),
    )  # fmt: skip
    part = det.subset(np.array([True, False, True, False]))
    assert part.count == 2 and (part.camera, part.frame, part.time_s) == (det.camera, det.frame, det.time_s)
    for name in ("pixels_view", "confidence", "projection", "rays_world", "appearance"):
        assert np.allclose(getattr(part, name), getattr(det, name)[[0, 2]], rtol=0, atol=1e-12), name
    assert det.subset(np.array([3, 1])).count == 2 and det.subset(np.zeros(4, bool)).count == 0
