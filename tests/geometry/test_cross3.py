"""The scalar 3-vector cross product of the view aiming (geometry/camera.py, cross3)."""

from __future__ import annotations

import numpy as np

from ergopose.geometry.camera import cross3


def test_cross3_is_np_cross(rng):
    for _ in range(200):
        a, b = rng.normal(size=3) * 10.0 ** rng.integers(-3, 4), rng.normal(size=3)
        np.testing.assert_array_equal(cross3(a, b), np.cross(a, b))
