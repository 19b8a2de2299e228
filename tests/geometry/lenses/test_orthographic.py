"""Orthographic: r_d = f sin(theta) (paper eq. orthographic); only up to 90 degrees."""

from __future__ import annotations

import math

import numpy as np
from lens_examples import rays_at

from ergopose.geometry.lenses import Orthographic


def test_radius_formula_up_to_90_degrees():
    lens = Orthographic(320.0, 320.0, 320.0, 240.0)
    theta = np.radians([0.0, 30.0, 60.0, 90.0])
    u = lens.project(rays_at(theta, np.zeros(4)))[:, 0]
    np.testing.assert_allclose(u - 320.0, 320.0 * np.sin(theta), rtol=1e-14, atol=1e-12)
    assert lens.max_theta == math.pi / 2


def test_beyond_90_degrees_and_outside_the_circle_is_nan():
    lens = Orthographic(320.0, 320.0, 320.0, 240.0)
    # sin(100 deg) = sin(80 deg): without the domain check this ray would land on a valid pixel.
    assert np.isnan(lens.project(rays_at(np.radians([100.0]), np.zeros(1)))).all()
    assert np.isnan(lens.unproject(np.array([[640.0 + 1e-6, 240.0]]))).all()
    assert np.isfinite(lens.unproject(np.array([[640.0, 240.0]]))).all()
