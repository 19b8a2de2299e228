"""Pinhole with OpenCV (Brown-Conrady) distortion against OpenCV's own cv2.projectPoints and
cv2.undistortPointsIter (an independent implementation), on the real Pose2Sim/Qualisys
calibration and on a strongly distorted wide-angle lens whose polynomial folds back."""

from __future__ import annotations

import math
import tomllib

import cv2
import numpy as np
import pytest
from lens_examples import angle_between, rays_at

from ergopose.errors import ConfigError
from ergopose.geometry.lenses import LENS_KINDS, BrownConrady, lens_from_dict


def pose2sim_lenses(shared_data):
    with open(shared_data / "pose2sim-demo" / "Calib_qualisys.toml", "rb") as f:
        data = tomllib.load(f)
    return [
        BrownConrady.from_opencv(np.array(c["matrix"]), c["distortions"])
        for k, c in data.items()
        if k.startswith("cam_")
    ]


#: A wide-angle lens with strong barrel distortion: the radial mapping turns at r ~ 1.80 (61 deg).
WIDE = BrownConrady(600.0, 602.0, 640.3, 360.7, -0.32, 0.09, 0.0012, -0.0007, -0.011)


def lenses(shared_data):
    return pose2sim_lenses(shared_data) + [WIDE]


def sample_rays(lens, rng, n, fraction=0.97):
    limit = math.atan(min(lens.max_r, 1.5) * fraction)
    return rays_at(rng.uniform(0.0, limit, n), rng.uniform(-math.pi, math.pi, n))


def test_real_calibration_loads_and_is_valid_over_the_whole_image(shared_data):
    found = pose2sim_lenses(shared_data)
    assert len(found) == 4
    for lens in found:
        # Pose2Sim's cameras: k1 ~ -7e-4, k2 ~ 2e-3: the radial mapping never turns.
        assert math.isinf(lens.max_r) and lens.max_theta == pytest.approx(math.pi / 2)
        corners = np.array([[-0.5, -0.5], [1087.5, -0.5], [-0.5, 1919.5], [1087.5, 1919.5], [lens.cx, lens.cy]])
        rays = lens.unproject(corners)
        assert np.isfinite(rays).all()
        np.testing.assert_allclose(lens.project(rays), corners, atol=1e-7)


def test_project_matches_cv2_project_points(shared_data, rng):
    for lens in lenses(shared_data):
        n = 20_000
        points = sample_rays(lens, rng, n) * rng.uniform(0.2, 8.0, (n, 1))
        K, dist = lens.to_opencv()
        expected, _ = cv2.projectPoints(points.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, dist)
        np.testing.assert_allclose(lens.project(points), expected[:, 0, :], rtol=0, atol=1e-7)


def test_unproject_matches_cv2_undistort_points_iter(shared_data, rng):
    criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-15)
    for lens in lenses(shared_data):
        n = 20_000
        pixels = lens.project(sample_rays(lens, rng, n, fraction=0.8))
        K, dist = lens.to_opencv()
        normalised = cv2.undistortPointsIter(pixels.reshape(-1, 1, 2), K, dist, None, None, criteria)[:, 0, :]
        rays = lens.unproject(pixels)
        ours = rays[:, :2] / rays[:, 2:3]
        # In pixels of the focal length.
        assert np.abs((ours - normalised) * lens.fx).max() < 1e-6


def test_round_trips(shared_data, rng):
    for lens in lenses(shared_data):
        n = 50_000
        rays = sample_rays(lens, rng, n)
        pixels = lens.project(rays * rng.uniform(0.01, 100.0, (n, 1)))
        assert np.isfinite(pixels).all()
        back = lens.unproject(pixels)
        np.testing.assert_allclose(np.linalg.norm(back, axis=-1), 1.0, atol=1e-12)
        assert angle_between(back, rays).max() < 1e-9


def test_nan_outside_the_domain(rng):
    lens = WIDE
    assert 1.5 < lens.max_r < 2.0  # where 1 + 3 k1 r^2 + 5 k2 r^4 + 7 k3 r^6 = 0 (checked next)
    slope = 1 + 3 * lens.k1 * lens.max_r**2 + 5 * lens.k2 * lens.max_r**4 + 7 * lens.k3 * lens.max_r**6
    assert abs(slope) < 1e-9
    beyond = rays_at(rng.uniform(lens.max_theta + 1e-6, math.pi, 1000), rng.uniform(-math.pi, math.pi, 1000))
    assert np.isnan(lens.project(beyond)).all()
    assert np.isnan(lens.project(np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 0.0], [np.nan, 0.0, 1.0]]))).all()
    # Pixels beyond the image of the turning radius have no ray (the polynomial never reaches them).
    r_d_max = lens.max_r * (1 + lens.k1 * lens.max_r**2 + lens.k2 * lens.max_r**4 + lens.k3 * lens.max_r**6)
    far = np.array([[lens.cx + lens.fx * r_d_max * 1.2, lens.cy], [lens.cx, lens.cy - lens.fy * r_d_max * 1.5]])
    assert np.isnan(lens.unproject(far)).all()
    assert np.isnan(lens.unproject(np.array([[np.nan, 1.0]]))).all()


def test_dictionary_and_opencv_interchange():
    data = WIDE.to_dict()
    assert data["kind"] == "brown_conrady" and LENS_KINDS["brown_conrady"] is BrownConrady
    assert set(data) == {"kind", "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"}
    assert lens_from_dict(dict(data)) == WIDE
    with pytest.raises(ConfigError, match="k3"):
        lens_from_dict({k: v for k, v in data.items() if k != "k3"})
    K, dist = WIDE.to_opencv()
    assert BrownConrady.from_opencv(K, dist) == WIDE
    four = BrownConrady.from_opencv(K, dist[:4])
    assert four.k3 == 0.0
    with pytest.raises(ConfigError, match="distortion"):
        BrownConrady.from_opencv(K, dist[:3])
    skewed = K.copy()
    skewed[0, 1] = 1.0
    with pytest.raises(ConfigError, match="skew"):
        BrownConrady.from_opencv(skewed, dist)
    with pytest.raises(ConfigError, match="fx"):
        BrownConrady(-1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
