"""Stereographic: r_d = 2 f tan(theta / 2) (paper eq. stereographic)."""

from __future__ import annotations

import math

import numpy as np
from lens_examples import rays_at

from ergopose.geometry.lenses import Stereographic


def test_radius_formula_and_known_values():
    lens = Stereographic(150.0, 150.0, 320.0, 240.0)
    theta = np.radians([0.0, 45.0, 90.0, 150.0])
    u = lens.project(rays_at(theta, np.zeros(4)))[:, 0]
    np.testing.assert_allclose(u - 320.0, 2 * 150.0 * np.tan(theta / 2), rtol=1e-14, atol=1e-12)
    assert abs(u[2] - 620.0) < 1e-12  # 90 deg: r = 2f


def test_every_pixel_has_a_ray_and_the_domain_is_open_at_180():
    lens = Stereographic(150.0, 150.0, 320.0, 240.0)
    far = lens.unproject(np.array([[1e9, 240.0]]))
    assert np.isfinite(far).all() and far[0, 2] < -0.99999
    assert lens.max_theta == math.pi
