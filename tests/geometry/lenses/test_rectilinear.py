"""The pinhole model against OpenCV's projectPoints and its own inverse."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from ergopose.errors import ConfigError
from ergopose.geometry.lenses.rectilinear import Rectilinear


def test_from_fov_centres_the_principal_point_and_spans_the_fov():
    lens = Rectilinear.from_fov(640, 480, math.radians(90))
    assert lens.cx == 319.5 and lens.cy == 239.5
    assert lens.fx == pytest.approx(320.0) and lens.fy == lens.fx
    # The outer pixel edges (-0.5 and 639.5) are the rays at +-45 degrees.
    rays = lens.unproject(np.array([[-0.5, 239.5], [639.5, 239.5]]))
    angles = np.degrees(np.arctan2(rays[:, 0], rays[:, 2]))
    np.testing.assert_allclose(angles, [-45.0, 45.0], atol=1e-12)
    np.testing.assert_array_equal(lens.K, [[lens.fx, 0, 319.5], [0, lens.fy, 239.5], [0, 0, 1]])


def test_matches_opencv_project_points(rng):
    lens = Rectilinear(410.5, 398.25, 300.2, 211.7)
    points = rng.uniform([-2, -2, 0.1], [2, 2, 5], size=(500, 3))
    expected, _ = cv2.projectPoints(points, np.zeros(3), np.zeros(3), lens.K, None)
    np.testing.assert_allclose(lens.project(points), expected[:, 0, :], atol=1e-9)


def test_round_trips_over_any_leading_shape(rng):
    lens = Rectilinear(410.5, 398.25, 300.2, 211.7)
    pixels = rng.uniform(-2000, 2000, size=(7, 11, 2))
    rays = lens.unproject(pixels)
    assert rays.shape == (7, 11, 3)
    np.testing.assert_allclose(np.linalg.norm(rays, axis=-1), 1.0, atol=1e-12)
    np.testing.assert_allclose(lens.project(rays), pixels, atol=1e-9)
    # And from rays: any direction in front of the camera, up to 89.9 degrees off-axis.
    theta = rng.uniform(0, math.radians(89.9), 2000)
    phi = rng.uniform(-math.pi, math.pi, 2000)
    rays = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=-1)
    np.testing.assert_allclose(lens.unproject(lens.project(rays * 3.7)), rays, atol=1e-9)
    assert lens.project(np.array([0.0, 0.0, 2.0])).shape == (2,)


def test_nan_where_the_pinhole_cannot_see():
    lens = Rectilinear(400, 400, 320, 240)
    points = np.array([[0, 0, -1.0], [1, 0, 0], [0, 0, 0], [np.nan, 0, 1], [0, np.nan, 1], [-1, 2, -0.1]])
    assert np.isnan(lens.project(points)).all()
    pixels = np.array([[np.nan, 3.0], [3.0, np.nan]])
    assert np.isnan(lens.unproject(pixels)).all()
    assert lens.max_theta == pytest.approx(math.pi / 2)


def test_out_argument_is_filled_and_returned(rng):
    lens = Rectilinear(400, 400, 320, 240)
    pixels = rng.uniform(0, 640, size=(40000, 2))  # more than one block
    out = np.empty((40000, 3))
    assert lens.unproject(pixels, out=out) is out
    np.testing.assert_array_equal(out, lens.unproject(pixels))
    with pytest.raises(ValueError):
        lens.unproject(pixels, out=np.empty((40000, 2)))


def test_dict_round_trip_and_errors():
    lens = Rectilinear(400, 401, 320, 240)
    assert Rectilinear.from_dict(lens.to_dict()) == lens
    assert lens.to_dict()["kind"] == "rectilinear"
    with pytest.raises(ConfigError, match="fy"):
        Rectilinear.from_dict({"fx": 1, "cx": 0, "cy": 0})
    with pytest.raises(ConfigError, match="fxx"):
        Rectilinear.from_dict({"fx": 1, "fy": 1, "cx": 0, "cy": 0, "fxx": 2})
    with pytest.raises(ConfigError, match="fx"):
        Rectilinear(-1, 1, 0, 0)
    with pytest.raises(ConfigError, match="cx"):
        Rectilinear.from_dict({"fx": 1, "fy": 1, "cx": "0", "cy": 0})
    with pytest.raises(ConfigError, match="hfov"):
        Rectilinear.from_fov(640, 480, math.pi)
