"""Virtual views: homography equivalence, uprightness, full rendering beyond 90 degrees."""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.geometry.camera import ceiling_camera as make_ceiling_camera
from ergopose.geometry.lenses.equidistant import Equidistant
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.geometry.views import VirtualView, build_map, upright_rotation

# The paper's camera: 2592 x 1944, 180-degree fisheye; realistic Kannala-Brandt coefficients.
W, H = 2592, 1944
FISHEYE_KB = KannalaBrandt(fx=620.0, fy=620.0, cx=(W - 1) / 2, cy=(H - 1) / 2, k1=0.02, k2=-0.01, k3=0.003, k4=-0.0005)


def ceiling_camera(lens, size=(W, H)):
    return make_ceiling_camera("cam_1", lens, size[0], size[1], position_world=(0.0, 0.0, 3.0))


def rot_xyz(ax, ay, az):
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def test_map_between_two_pinholes_is_the_homography(rng):
    k_src = Rectilinear(fx=500.0, fy=510.0, cx=319.5, cy=239.5)
    k_dst = Rectilinear(fx=300.0, fy=300.0, cx=159.5, cy=119.5)
    r_src = rot_xyz(0.1, -0.2, 0.3)  # orientations of both cameras in a common frame
    r_dst = rot_xyz(0.15, -0.1, 0.25)
    view_map = build_map(k_dst, (320, 240), k_src, r_src.T @ r_dst)
    # The paper: i' = K' R'^T R K^-1 i, from the destination camera (K, R) to the source (K', R').
    homography = k_src.K @ r_src.T @ r_dst @ np.linalg.inv(k_dst.K)
    u, v = np.meshgrid(np.arange(320.0), np.arange(240.0))
    h = np.stack([u, v, np.ones_like(u)], axis=-1) @ homography.T
    expected = h[..., :2] / h[..., 2:]
    assert np.all(view_map.valid)
    assert np.abs(view_map.map_x - expected[..., 0]).max() < 1e-3  # float32 storage
    assert np.abs(view_map.map_y - expected[..., 1]).max() < 1e-3


@pytest.mark.parametrize("x,y", [(0.5, 0.0), (2.5, 1.0), (-2.9, -2.9), (0.0, -2.0), (2.95, -0.3)])
def test_a_standing_person_is_upright_anywhere_under_the_camera(x, y):
    camera = ceiling_camera(FISHEYE_KB)
    view = VirtualView.aimed_at(camera, np.array([x, y, 1.0]), hfov=np.radians(60), size=(256, 256))
    hip, shoulder, head = (np.array([x, y, z]) for z in (0.9, 1.4, 1.7))
    p = view.project_world(np.stack([hip, shoulder, head]))
    # A vertical line through the aim point lies in the plane of the optical axis and world up,
    # which maps to the image's vertical centre line; up in the world is up in the image.
    assert np.allclose(p[:, 0], view.lens.cx, atol=1e-6)
    assert p[1, 1] < p[0, 1] and p[2, 1] < p[1, 1]


def test_upright_rotation_is_a_rotation_even_looking_straight_up():
    for direction in ([0, 0, 1.0], [0.3, -0.2, 0.9], [0.0, 0.0, -1.0]):
        r = upright_rotation(np.array(direction), np.array([0.0, -1.0, 0.0]))
        assert np.allclose(r.T @ r, np.eye(3), atol=1e-12)
        assert np.isclose(np.linalg.det(r), 1.0)
        assert np.allclose(r[:, 2], np.array(direction) / np.linalg.norm(direction))


def _pattern(rays):
    """A smooth brightness pattern defined on directions (so any camera can render it exactly)."""
    rays = rays / np.linalg.norm(rays, axis=-1, keepdims=True)
    return 128 + 60 * np.sin(7 * rays[..., 0]) * np.cos(5 * rays[..., 1]) + 50 * rays[..., 2]


@pytest.mark.slow
def test_view_image_equals_the_scene_seen_by_the_virtual_camera():
    """Remapping a rendered fisheye image gives what a real pinhole there would see."""
    camera = ceiling_camera(FISHEYE_KB, size=(W, H))
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    rays = camera.lens.unproject(np.stack([u, v], axis=-1))
    fisheye = np.nan_to_num(_pattern(rays), nan=0.0).astype(np.float32)
    view = VirtualView.aimed_at(camera, np.array([2.0, 1.5, 1.0]), hfov=np.radians(70), size=(320, 320))
    image = view.build_map().apply(fisheye, exact=True)
    vv, uu = np.mgrid[0:320, 0:320].astype(np.float64)
    expected = _pattern(view.view_pixels_to_rays_cam(np.stack([uu, vv], axis=-1)))
    assert np.abs(image - expected).max() < 0.5  # bilinear interpolation of a smooth pattern


@pytest.mark.parametrize("off_axis_deg", [95.0, 100.0, 105.0])
def test_views_beyond_90_degrees_render_fully(off_axis_deg):
    """Lenses of about 240 degrees (equidistant, and KB with theta from atan2) both see past 90 degrees."""
    for lens in (
        Equidistant(fx=280.0, fy=280.0, cx=599.5, cy=599.5),
        KannalaBrandt(fx=280.0, fy=280.0, cx=599.5, cy=599.5, k1=0.01, k2=-0.002, k3=0.0, k4=0.0),
    ):
        camera = ceiling_camera(lens, size=(1200, 1200))
        a = np.radians(off_axis_deg)
        view = VirtualView.aimed_along(
            camera, np.array([np.sin(a), 0.0, np.cos(a)]), hfov=np.radians(20), size=(128, 128)
        )
        view_map = view.build_map()
        assert view_map.valid.all()
        inside = (view_map.map_x >= 0) & (view_map.map_x <= 1199) & (view_map.map_y >= 0) & (view_map.map_y <= 1199)
        assert inside.all()
        fisheye = np.full((1200, 1200), 200, np.uint8)
        assert (view_map.apply(fisheye) == 200).all()  # no black holes


def test_points_map_both_ways_and_match_the_projection_matrix(rng):
    camera = ceiling_camera(FISHEYE_KB)
    view = VirtualView.aimed_at(camera, np.array([1.5, -2.0, 1.0]), hfov=np.radians(60), size=(256, 256))
    pixels_view = rng.uniform(0, 255, size=(200, 2))
    pixels_src = view.view_to_source_pixels(pixels_view)
    assert np.allclose(view.source_to_view_pixels(pixels_src), pixels_view, atol=1e-6)
    # World points around the aim point: P and the source camera's projection agree.
    points_world = np.array([1.5, -2.0, 1.0]) + rng.uniform(-0.4, 0.4, size=(100, 3))
    h = np.c_[points_world, np.ones(len(points_world))] @ view.projection_matrix.T
    via_p = h[:, :2] / h[:, 2:]
    via_fisheye = view.source_to_view_pixels(camera.project_world(points_world))
    assert np.allclose(via_p, via_fisheye, atol=1e-6)
    assert np.allclose(via_p, view.project_world(points_world), atol=1e-9)


def test_maps_work_from_pinhole_to_fisheye():
    """Any pair of models: here a fisheye image made from a pinhole source."""
    pinhole = Rectilinear(fx=400.0, fy=400.0, cx=399.5, cy=399.5)
    fisheye = Equidistant(fx=200.0, fy=200.0, cx=399.5, cy=399.5)
    view_map = build_map(fisheye, (800, 800), pinhole, np.eye(3))
    # Where the fisheye ray is within the pinhole's field, the composition equals the direct formula.
    u, v = np.meshgrid(np.arange(800.0), np.arange(800.0))
    rays = fisheye.unproject(np.stack([u, v], axis=-1))
    expected = pinhole.project(rays)
    ok = np.isfinite(expected).all(axis=-1)
    assert ok.any() and (~ok).any()
    assert np.allclose(view_map.map_x[ok], expected[ok][:, 0], atol=1e-3)
    assert not view_map.valid[~ok].any()
