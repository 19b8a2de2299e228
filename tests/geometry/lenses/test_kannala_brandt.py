"""Kannala-Brandt against OpenCV's cv2.fisheye (an independent implementation) on real
calibrations, and its behaviour beyond 90 degrees where cv2.fisheye stops."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from lens_examples import JY_LEFT_D, JY_LEFT_K, JY_RIGHT_D, JY_RIGHT_K, angle_between, rays_at, tumvi
from scipy.optimize import least_squares

from ergopose.errors import ConfigError
from ergopose.geometry.lenses import DoubleSphere, Equidistant, KannalaBrandt

REAL = [(JY_LEFT_K, JY_LEFT_D), (JY_RIGHT_K, JY_RIGHT_D)]


@pytest.mark.parametrize("K, D", REAL)
def test_project_matches_cv2_fisheye_below_90_degrees(K, D, rng):
    lens = KannalaBrandt.from_opencv(K, D)
    n = 20_000
    theta = rng.uniform(0.0, math.radians(89.0), n)
    points = rays_at(theta, rng.uniform(-math.pi, math.pi, n)) * rng.uniform(0.2, 5.0, (n, 1))
    expected, _ = cv2.fisheye.projectPoints(points.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)
    np.testing.assert_allclose(lens.project(points), expected[:, 0, :], rtol=0, atol=1e-6)


@pytest.mark.parametrize("K, D", REAL)
def test_unproject_matches_cv2_fisheye_undistort_points(K, D, rng):
    lens = KannalaBrandt.from_opencv(K, D)
    # Pixels of rays up to 85 degrees (cv2 returns tan(theta), which explodes towards 90), and
    # only where theta_d < pi/2: cv2.fisheye.undistortPoints clamps theta_d to pi/2.
    n = 20_000
    theta = rng.uniform(0.0, math.radians(85.0), n)
    pixels = lens.project(rays_at(theta, rng.uniform(-math.pi, math.pi, n)))
    theta_d = np.hypot((pixels[:, 0] - K[0, 2]) / K[0, 0], (pixels[:, 1] - K[1, 2]) / K[1, 1])
    pixels = pixels[theta_d < 0.5 * math.pi - 1e-9]
    assert len(pixels) > 0.9 * n
    criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-15)
    normalised = cv2.fisheye.undistortPoints(pixels.reshape(-1, 1, 2), K, D, criteria=criteria)[:, 0, :]
    rays = lens.unproject(pixels)
    ours = rays[:, :2] / rays[:, 2:3]
    # Compared in pixels of a pinhole with the same focal length.
    assert np.abs((ours - normalised) * K[0, 0]).max() < 1e-6


def test_cv2_interchange_and_parameters():
    lens = KannalaBrandt.from_opencv(JY_LEFT_K, JY_LEFT_D)
    K, D = lens.to_opencv()
    np.testing.assert_array_equal(K, JY_LEFT_K)
    np.testing.assert_array_equal(D.ravel(), JY_LEFT_D)
    assert D.shape == (4, 1)
    assert lens.coefficients == tuple(JY_LEFT_D)
    skewed = JY_LEFT_K.copy()
    skewed[0, 1] = 0.5
    with pytest.raises(ConfigError, match="skew"):
        KannalaBrandt.from_opencv(skewed, JY_LEFT_D)
    with pytest.raises(ConfigError, match="D"):
        KannalaBrandt.from_opencv(JY_LEFT_K, JY_LEFT_D[:3])
    with pytest.raises(ConfigError, match="K"):
        KannalaBrandt.from_opencv(JY_LEFT_K[:2], JY_LEFT_D)


def test_equidistant_is_kannala_brandt_without_distortion(rng):
    kb = KannalaBrandt(300.0, 310.0, 320.5, 319.2, 0.0, 0.0, 0.0, 0.0)
    eq = Equidistant(300.0, 310.0, 320.5, 319.2)
    assert kb.max_theta == eq.max_theta == math.pi
    theta = rng.uniform(0.0, math.pi - 1e-6, 10_000)
    rays = rays_at(theta, rng.uniform(-math.pi, math.pi, 10_000))
    np.testing.assert_allclose(kb.project(rays), eq.project(rays), rtol=0, atol=1e-9)
    pixels = rng.uniform(-400, 1000, (10_000, 2))
    np.testing.assert_allclose(kb.unproject(pixels), eq.unproject(pixels), rtol=0, atol=1e-12, equal_nan=True)
    assert np.isnan(eq.unproject(pixels)).any()  # the sample reaches beyond theta = pi


def test_max_theta_is_where_the_polynomial_turns():
    lens = KannalaBrandt.from_opencv(JY_LEFT_K, JY_LEFT_D)
    k1, k2, k3, k4 = JY_LEFT_D

    def theta_d(t):
        return t * (1 + k1 * t**2 + k2 * t**4 + k3 * t**6 + k4 * t**8)

    t = lens.max_theta
    assert 1.0 < t < math.pi  # this real lens turns at about 93 degrees
    assert math.degrees(t) == pytest.approx(93.28, abs=0.01)
    h = 1e-5
    assert theta_d(t - h) < theta_d(t) and theta_d(t + h) < theta_d(t)  # a maximum
    grid = np.linspace(0, t, 10_000)
    assert np.all(np.diff(theta_d(grid)) > 0)  # increasing up to it: one angle per radius
    assert lens.rd_max == pytest.approx(theta_d(t), rel=1e-14)
    # No turning point inside [0, pi]: the domain is capped at pi.
    assert KannalaBrandt(200, 200, 0, 0, 0.05, 0.01, -0.002, 0.0003).max_theta == math.pi
    assert KannalaBrandt(200, 200, 0, 0, -1.0, 0, 0, 0).max_theta == pytest.approx(math.sqrt(1 / 3), rel=1e-12)


def test_beyond_90_degrees(rng):
    """cv2.fisheye cannot project a ray at or beyond 90 degrees; this model does (theta = atan2(r, z))."""
    lens = KannalaBrandt(200.0, 201.0, 320.5, 319.2, 0.05, 0.01, -0.002, 0.0003)
    theta = np.radians([90.0, 100.0, 120.0, 150.0])
    pixels = lens.project(rays_at(theta, np.zeros(4)))
    radius = (pixels[:, 0] - lens.cx) / lens.fx
    expected = theta * (1 + 0.05 * theta**2 + 0.01 * theta**4 - 0.002 * theta**6 + 0.0003 * theta**8)
    np.testing.assert_allclose(radius, expected, rtol=1e-14)
    np.testing.assert_allclose(pixels[:, 1], lens.cy, atol=1e-9)
    back = lens.unproject(pixels)
    assert angle_between(back, rays_at(theta, np.zeros(4))).max() < 1e-12


def test_fits_the_real_double_sphere_lens_beyond_90_degrees(shared_data):
    """A Kannala-Brandt fitted to TUM-VI cam0's double sphere calibration (up to 110 degrees)
    reproduces it to a small fraction of a pixel, including the rays beyond 90 degrees."""
    ds = DoubleSphere(**tumvi(shared_data, "ds", 0))
    theta = np.radians(np.linspace(0.0, 110.0, 400))
    target = ds.project(rays_at(theta, np.zeros_like(theta)))[:, 0]

    def residual(p):
        kb = KannalaBrandt(p[0], p[0], ds.cx, ds.cy, *p[1:])
        return kb.project(rays_at(theta, np.zeros_like(theta)))[:, 0] - target

    fit = least_squares(residual, x0=[ds.fx, 0, 0, 0, 0], x_scale=[100, 0.01, 0.01, 0.001, 0.001])
    kb = KannalaBrandt(fit.x[0], fit.x[0], ds.cx, ds.cy, *fit.x[1:])
    assert kb.max_theta > math.radians(110)
    assert np.abs(fit.fun).max() < 0.1
    pixels = ds.project(rays_at(np.radians([95.0, 105.0]), np.array([0.7, -2.0])))
    rays_kb = kb.unproject(pixels)
    rays_ds = ds.unproject(pixels)
    assert np.degrees(angle_between(rays_kb, rays_ds)).max() < 0.05


def test_unprojection_converges_near_max_theta(rng):
    """The inverse has a square-root cusp at max_theta; the table over sqrt(1 - r/r_max) and
    Newton still give the right ray right up to the edge of the image circle."""
    lens = KannalaBrandt.from_opencv(JY_LEFT_K, JY_LEFT_D)
    t = lens.max_theta - np.geomspace(1e-2, 1e-7, 200)
    pixels = lens.project(rays_at(t, rng.uniform(-math.pi, math.pi, 200)))
    rays = lens.unproject(pixels)
    assert np.isfinite(rays).all()
    np.testing.assert_allclose(lens.project(rays), pixels, rtol=0, atol=1e-7)
