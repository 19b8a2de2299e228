"""Clothing colour of a person from a frame and keypoints (ergopose.pose.appearance)."""

from __future__ import annotations

import cv2
import numpy as np

from ergopose.keypoints import JOINT_INDEX
from ergopose.pose.appearance import APPEARANCE_DIMS, appearance_distance, appearance_fisheye

J = JOINT_INDEX


def _person(x0: float, y0: float) -> np.ndarray:
    """(33, 2) keypoints of an upright person whose shoulders are at y0, 100 px wide from x0."""
    px = np.full((33, 2), np.nan)
    px[J["left_shoulder"]] = (x0 + 100, y0)
    px[J["right_shoulder"]] = (x0, y0)
    px[J["left_hip"]] = (x0 + 90, y0 + 150)
    px[J["right_hip"]] = (x0 + 10, y0 + 150)
    px[J["left_knee"]] = (x0 + 90, y0 + 300)
    px[J["right_knee"]] = (x0 + 10, y0 + 300)
    return px


def _scene(rng) -> tuple[np.ndarray, np.ndarray]:
    """A noisy grey frame with two people: pure red shirt over black trousers, and pure blue over
    white; keypoints and confidences."""
    img = np.clip(rng.normal(128, 20, (500, 500, 3)), 0, 255).astype(np.uint8)
    a, b = _person(50, 50), _person(300, 100)
    for px, shirt, trousers in ((a, (0, 0, 255), (0, 0, 0)), (b, (255, 0, 0), (255, 255, 255))):
        torso = px[[J["right_shoulder"], J["left_shoulder"], J["left_hip"], J["right_hip"]]].astype(np.int32)
        cv2.fillPoly(img, [torso], shirt)
        for hip, knee in (("left_hip", "left_knee"), ("right_hip", "right_knee")):
            cv2.line(img, tuple(px[J[hip]].astype(int)), tuple(px[J[knee]].astype(int)), trousers, 30)
    conf = np.where(np.isfinite(np.stack([a, b])).all(axis=-1), 0.9, 0.0)
    return img, np.stack([a, b]), conf


def test_colours_of_the_shirt_and_trousers_against_published_lab_values(rng):
    """sRGB red is CIE L*a*b* (53.24, 80.09, 67.20) and blue (32.30, 79.19, -107.86) (D65); in
    OpenCV's 8-bit scale L* x 255/100 and a*, b* + 128. Black is (0, 128, 128), white (255, 128,
    128). The grey background at the edge of the quadrilateral does not enter."""
    img, px, conf = _scene(rng)
    look = appearance_fisheye(img, px, conf)
    assert look.shape == (2, APPEARANCE_DIMS)
    red = (53.24 * 2.55, 80.09 + 128, 67.20 + 128)
    blue = (32.30 * 2.55, 79.19 + 128, -107.86 + 128)
    np.testing.assert_allclose(look[0], red + (0.0, 128.0, 128.0), atol=1.5)
    np.testing.assert_allclose(look[1], blue + (255.0, 128.0, 128.0), atol=1.5)


def test_parts_without_their_keypoints_are_unknown(rng):
    img, px, conf = _scene(rng)
    conf[0, J["left_knee"]] = 0.2  # below the gate: no thighs for person 0
    px[1, J["left_hip"]] = np.nan  # no hip: neither part for person 1
    look = appearance_fisheye(img, px, conf)
    assert np.isfinite(look[0, :3]).all() and np.isnan(look[0, 3:]).all()
    assert np.isnan(look[1]).all()
    assert appearance_fisheye(img, np.zeros((0, 33, 2)), np.zeros((0, 33))).shape == (0, APPEARANCE_DIMS)


def test_people_partly_outside_the_frame_use_the_pixels_inside(rng):
    img, px, conf = _scene(rng)
    # The frame's top 100 rows cut off: person 0's shoulders lie above its edge, the lower part of
    # the shirt remains.
    look = appearance_fisheye(img[100:], px - (0, 100), conf)
    np.testing.assert_allclose(look[0, :3], (53.24 * 2.55, 80.09 + 128, 67.20 + 128), atol=1.5)


def test_distance_weighs_lightness_half_and_skips_unknown_parts():
    a = np.array([100.0, 128.0, 128.0, 50.0, 128.0, 128.0])
    b = a + np.array([20.0, 0.0, 0.0, 0.0, 6.0, 8.0])
    # Upper body: sqrt((0.5 * 20)^2 / 2.25); thighs: sqrt((6^2 + 8^2) / 2.25); RMS of the two.
    expected = np.sqrt(0.5 * (100.0 / 2.25 + 100.0 / 2.25))
    assert np.isclose(appearance_distance(a, b), expected)
    c = b.copy()
    c[3:] = np.nan
    assert np.isclose(appearance_distance(a, c), np.sqrt(100.0 / 2.25))
    assert np.isnan(appearance_distance(a, np.full(6, np.nan)))
    pair = appearance_distance(np.stack([a, b])[:, None], np.stack([a, b])[None])
    assert pair.shape == (2, 2) and np.allclose(np.diag(pair), 0.0) and np.isclose(pair[0, 1], expected)
