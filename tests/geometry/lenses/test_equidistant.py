"""Equidistant: r_d = f theta (paper eq. equidistant), up to 180 degrees."""

from __future__ import annotations

import math

import numpy as np
from lens_examples import rays_at

from ergopose.geometry.lenses import Equidistant


def test_radius_is_focal_length_times_angle():
    lens = Equidistant(300.0, 280.0, 320.0, 240.0)
    theta = np.radians([0.0, 30.0, 90.0, 135.0, 179.0])
    u = lens.project(rays_at(theta, np.zeros(5)))[:, 0]
    v = lens.project(rays_at(theta, np.full(5, math.pi / 2)))[:, 1]
    np.testing.assert_allclose(u - 320.0, 300.0 * theta, rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(v - 240.0, 280.0 * theta, rtol=1e-14, atol=1e-12)


def test_domain_ends_at_the_circle_of_180_degrees():
    lens = Equidistant(300.0, 300.0, 320.0, 240.0)
    assert lens.max_theta == math.pi
    inside = lens.unproject(np.array([[320.0 + 300.0 * math.pi * (1 - 1e-9), 240.0]]))
    assert inside[0, 2] < -0.999999
    assert np.isnan(lens.unproject(np.array([[320.0 + 300.0 * math.pi * (1 + 1e-9), 240.0]]))).all()
