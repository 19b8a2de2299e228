"""Interpolated lookup maps (geometry/views.py, build_map_interpolated): the exact map on nodes
every few pixels, cubic interpolation between them, checked; exact where that cannot hold."""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.geometry.camera import ceiling_camera, cross3
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt
from ergopose.geometry.lenses.orthographic import Orthographic
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.geometry.views import VirtualView, build_map, build_map_interpolated, upright_rotation

W, H = 2592, 1944
FISHEYE_KB = KannalaBrandt(fx=620.0, fy=620.0, cx=(W - 1) / 2, cy=(H - 1) / 2, k1=0.02, k2=-0.01, k3=0.003, k4=-0.0005)
CAMERA = ceiling_camera("cam_1", FISHEYE_KB, W, H, position_world=(0.0, 0.0, 3.0))


def _direction(polar_deg: float, azimuth_deg: float) -> np.ndarray:
    p, a = np.radians(polar_deg), np.radians(azimuth_deg)
    return np.array([np.sin(p) * np.cos(a), np.sin(p) * np.sin(a), np.cos(p)])


@pytest.mark.parametrize(
    "polar,azimuth,half_fov", [(0, 0, 30), (35, 120, 8), (60, -40, 25), (65, 200, 40), (90, 10, 20)]
)
def test_interpolated_map_matches_the_exact_map(polar, azimuth, half_fov):
    # Person views of the paper's 2592 x 1944 fisheye (its lens ends at 126 deg), from straight
    # down to the horizon.
    view = VirtualView.aimed_along(CAMERA, _direction(polar, azimuth), hfov=2 * np.radians(half_fov), size=(256, 256))
    exact = view.build_map()
    fast = build_map_interpolated(view.lens, (256, 256), CAMERA.lens, view.rotation_cam_from_view)
    assert fast is not None
    assert fast.valid.all() and exact.valid.all()
    # Far below the fixed-point map's 1/32 px step at every pixel.
    assert np.abs(fast.map_x - exact.map_x).max() < 0.003
    assert np.abs(fast.map_y - exact.map_y).max() < 0.003
    same = (fast.fixed1 == exact.fixed1).all(axis=-1) & (fast.fixed2 == exact.fixed2)
    assert same.mean() > 0.99
    assert fast.map_x.dtype == np.float32 and fast.map_x.flags.c_contiguous and fast.size == (256, 256)


def test_interpolated_map_of_a_rotated_pinhole_is_its_homography():
    # Pinhole to pinhole: the map is a homography, known in closed form.
    src = Rectilinear(fx=500.0, fy=510.0, cx=319.5, cy=239.5)
    dst = Rectilinear(fx=300.0, fy=300.0, cx=159.5, cy=119.5)
    rot = upright_rotation(np.array([0.1, -0.05, 1.0]), np.array([0.0, -1.0, 0.1]))
    fast = build_map_interpolated(dst, (320, 240), src, rot)
    assert fast is not None
    homography = src.K @ rot @ np.linalg.inv(dst.K)
    u, v = np.meshgrid(np.arange(320.0), np.arange(240.0))
    h = np.stack([u, v, np.ones_like(u)], axis=-1) @ homography.T
    assert np.abs(fast.map_x - h[..., 0] / h[..., 2]).max() < 1e-3
    assert np.abs(fast.map_y - h[..., 1] / h[..., 2]).max() < 1e-3


def test_a_view_reaching_beyond_the_lens_is_built_exactly():
    # A pinhole source sees less than 90 deg from its axis: a view aimed 80 deg off it reaches
    # beyond, so the interpolation declines and build_map(interpolated=True) gives the exact map
    # with its invalid pixels.
    src_lens = Rectilinear(fx=400.0, fy=400.0, cx=399.5, cy=299.5)
    camera = ceiling_camera("pin", src_lens, 800, 600, position_world=(0.0, 0.0, 3.0))
    view = VirtualView.aimed_along(camera, _direction(80, 30), hfov=np.radians(60), size=(128, 128))
    assert build_map_interpolated(view.lens, (128, 128), src_lens, view.rotation_cam_from_view) is None
    served = view.build_map(interpolated=True)
    exact = view.build_map()
    assert not exact.valid.all()
    np.testing.assert_array_equal(served.valid, exact.valid)
    np.testing.assert_array_equal(served.map_x, exact.map_x)
    np.testing.assert_array_equal(served.fixed1, exact.fixed1)


def test_the_check_refuses_a_map_beyond_its_tolerance():
    view = VirtualView.aimed_along(CAMERA, _direction(70, 45), hfov=np.radians(100), size=(256, 256))
    args = (view.lens, (256, 256), CAMERA.lens, view.rotation_cam_from_view)
    assert build_map_interpolated(*args) is not None
    # Nodes 32 px apart cannot follow this view's map within a thousandth of a pixel.
    assert build_map_interpolated(*args, step=32, tolerance_px=1e-3) is None


def test_near_the_edge_of_a_bounded_lens_the_map_is_exact():
    # An orthographic fisheye ends at 90 deg: a view whose corners pass that edge is built exactly.
    lens = Orthographic(fx=380.0, fy=380.0, cx=511.5, cy=383.5)
    camera = ceiling_camera("ortho", lens, 1024, 768, position_world=(0.0, 0.0, 3.0))
    view = VirtualView.aimed_along(camera, _direction(85, 0), hfov=np.radians(50), size=(64, 64))
    assert build_map_interpolated(view.lens, (64, 64), lens, view.rotation_cam_from_view) is None
    inside = VirtualView.aimed_along(camera, _direction(40, 0), hfov=np.radians(50), size=(64, 64))
    assert build_map_interpolated(inside.lens, (64, 64), lens, inside.rotation_cam_from_view) is not None


def test_cross3_is_np_cross(rng):
    for _ in range(200):
        a, b = rng.normal(size=3) * 10.0 ** rng.integers(-3, 4), rng.normal(size=3)
        np.testing.assert_array_equal(cross3(a, b), np.cross(a, b))


def test_build_map_exact_is_unchanged_by_default():
    view = VirtualView.aimed_along(CAMERA, _direction(50, 10), hfov=np.radians(50), size=(64, 64))
    direct = build_map(view.lens, (64, 64), CAMERA.lens, view.rotation_cam_from_view)
    np.testing.assert_array_equal(view.build_map().map_x, direct.map_x)
