"""EUCM on the real TUM-VI calibration (Basalt): domain edges in both directions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from lens_examples import rays_at, tumvi

from ergopose.errors import ConfigError
from ergopose.geometry.lenses import EUCM


def test_projection_formula(shared_data):
    p = tumvi(shared_data, "eucm", 0)
    lens = EUCM(**p)
    point = np.array([0.3, -0.2, 0.5])
    rho = math.sqrt(p["beta"] * (0.3**2 + 0.2**2) + 0.5**2)
    denom = p["alpha"] * rho + (1 - p["alpha"]) * 0.5
    expected = [p["fx"] * 0.3 / denom + p["cx"], p["fy"] * -0.2 / denom + p["cy"]]
    np.testing.assert_allclose(lens.project(point), expected, rtol=1e-14)


def test_max_theta_matches_the_valid_set_and_the_unprojection_domain(shared_data):
    p = tumvi(shared_data, "eucm", 0)
    lens = EUCM(**p)
    a, b = p["alpha"], p["beta"]
    w = (1 - a) / a
    # On the boundary z = -w rho of the valid set:
    t = lens.max_theta
    assert math.cos(t) == pytest.approx(-w * math.sqrt(b * math.sin(t) ** 2 + math.cos(t) ** 2), rel=1e-12)
    assert math.degrees(t) == pytest.approx(126.7, abs=0.05)
    # Its image is the edge of the unprojection domain r^2 < 1 / (beta (2 alpha - 1)).
    edge = lens.project(rays_at(np.array([t]), np.array([0.0])))[0]
    assert (edge[0] - lens.cx) / lens.fx == pytest.approx(1 / math.sqrt(b * (2 * a - 1)), rel=1e-9)
    # The image radius grows all the way to max_theta (one ray per pixel).
    theta = np.linspace(0, t, 20_000)
    u = lens.project(rays_at(theta, np.zeros_like(theta)))[:, 0]
    assert np.all(np.diff(u) > 0)
    assert np.isnan(lens.project(rays_at(np.array([t + 1e-9]), np.array([0.0])))).all()


def test_low_alpha_image_is_unbounded():
    lens = EUCM(300.0, 300.0, 320.0, 240.0, 0.3, 1.4)  # alpha <= 0.5: w = alpha / (1 - alpha)
    w = 0.3 / 0.7
    assert lens.max_theta == pytest.approx(math.pi - math.atan(math.sqrt((1 - w * w) / (w * w * 1.4))), rel=1e-14)
    radii = lens.project(rays_at(lens.max_theta - np.array([1e-2, 1e-4, 1e-6]), np.zeros(3)))[:, 0]
    assert np.all(np.diff(radii) > 0) and radii[-1] > 1e7
    assert np.isfinite(lens.unproject(np.array([1e9, 240.0]))).all()  # every pixel has a ray


def test_parameter_checks():
    with pytest.raises(ConfigError, match="beta"):
        EUCM(100, 100, 50, 50, 0.5, 0.0)
    with pytest.raises(ConfigError, match="alpha"):
        EUCM(100, 100, 50, 50, -0.1, 1.0)
