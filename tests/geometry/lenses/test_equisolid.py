"""Equisolid angle: r_d = 2 f sin(theta / 2) (paper eq. equisolid); image circle radius 2f."""

from __future__ import annotations

import math

import numpy as np
from lens_examples import rays_at

from ergopose.geometry.lenses import Equisolid


def test_radius_formula_and_known_values():
    lens = Equisolid(220.0, 220.0, 320.0, 240.0)
    theta = np.radians([0.0, 60.0, 90.0, 170.0])
    u = lens.project(rays_at(theta, np.zeros(4)))[:, 0]
    np.testing.assert_allclose(u - 320.0, 2 * 220.0 * np.sin(theta / 2), rtol=1e-14, atol=1e-12)
    assert abs(u[2] - 320.0 - 220.0 * math.sqrt(2)) < 1e-12  # 90 deg: r = f sqrt(2)


def test_pixels_beyond_the_image_circle_are_nan():
    lens = Equisolid(220.0, 220.0, 320.0, 240.0)
    rays = lens.unproject(np.array([[320.0 + 440.0 * (1 - 1e-12), 240.0], [320.0 + 440.0 * (1 + 1e-9), 240.0]]))
    assert rays[0, 2] < -0.9999 and np.isnan(rays[1]).all()
