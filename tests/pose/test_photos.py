"""Issue 14's photo test: real photographs of people that ship in packages, warped into a ceiling
fisheye (ergopose/evaluation/photos.py), found by the fisheye 2D stage at 20, 50 and 80 deg off
the lens axis in 8 image directions at two pixel densities, with keypoints close to the same
network on the photo (figures in docs/pose-in-fisheye.md, "Real photographs"). The warp, and the
stage with the full landmark model (assess's); the heavy model's in test_photos_heavy.py, the
figures and the bar in photo_bars.py."""

from __future__ import annotations

import math

import numpy as np
import photo_bars as B
import pytest

from ergopose.evaluation import photos as P


@pytest.mark.parametrize("off_axis_deg, direction_deg", [(20.0, 0.0), (50.0, 135.0), (80.0, 270.0)])
def test_warp_puts_the_photo_where_asked_head_away_from_the_centre(off_axis_deg, direction_deg):
    photo = np.full((200, 160, 3), 100, np.uint8)
    photo[40:60, 70:90] = 255  # a bright square 50 px above the body centre (80, 100)
    centre = np.array([80.0, 100.0])
    rho, n = 230.0, 768
    w = P.warp_photo(photo, centre, 600.0, math.radians(off_axis_deg), math.radians(direction_deg), rho, (n, n))
    c = (n - 1) / 2.0
    at = w.fisheye_pixels(centre)
    a = math.radians(direction_deg)
    expected = c + rho * math.radians(off_axis_deg) * np.array([math.cos(a), math.sin(a)])
    np.testing.assert_allclose(at, expected, atol=1e-6)
    # The round trip photo -> fisheye -> photo is exact.
    pts = np.array([[10.0, 20.0], [150.0, 190.0], [80.0, 100.0]])
    np.testing.assert_allclose(w.photo_pixels(w.camera.lens.unproject(w.fisheye_pixels(pts))), pts, atol=1e-6)
    # The square is rendered where the map says, and its photo-up lies away from the lens axis
    # (a standing person's head under a ceiling camera).
    ys, xs = np.nonzero(w.image[..., 0] > 200)
    blob = np.array([xs.mean(), ys.mean()])
    np.testing.assert_allclose(blob, w.fisheye_pixels(np.array([79.5, 49.5])), atol=1.0)
    assert np.linalg.norm(blob - c) > np.linalg.norm(at - c)
    # Every lit pixel sees the photo, and the pixels that see the photo are lit.
    lit = w.image[..., 0] > 0
    v, u = np.mgrid[0:n, 0:n]
    back = w.photo_pixels(w.camera.lens.unproject(np.stack([u, v], axis=-1).astype(np.float64)))

    def within(margin):
        return (
            (back[..., 0] > -margin)
            & (back[..., 0] < 159 + margin)
            & (back[..., 1] > -margin)
            & (back[..., 1] < 199 + margin)
        )

    assert within(0.0).sum() > 0.7 * 160 * 200 * (rho / 600.0) ** 2  # the photo's area, near enough
    assert (lit & ~within(1.0)).sum() == 0  # bilinear sampling blends the edge with the black
    assert (within(0.0) & ~lit).sum() == 0


@pytest.mark.parametrize(
    "off_axis_deg, direction_deg, focal", [(20.0, 0.0, 600.0), (50.0, 135.0, 900.0), (80.0, 270.0, 300.0)]
)
def test_warp_over_the_photos_footprint_gives_the_whole_images_warp_to_the_bit(off_axis_deg, direction_deg, focal):
    photo = np.random.default_rng(3).integers(0, 256, (300, 220, 3), dtype=np.uint8)
    args = (photo, np.array([110.0, 150.0]), focal, math.radians(off_axis_deg), math.radians(direction_deg), 230.0)
    n = (768, 640)
    box = P.warp_photo(*args, n)
    whole = P.warp_photo(*args, n, whole_image=True)
    np.testing.assert_array_equal(box.image, whole.image)
    rotation = box.rotation_photo_from_cam.T
    x0, y0, x1, y1 = P._footprint(photo.shape, box.photo_lens, rotation, box.camera)
    assert (x1 - x0) * (y1 - y0) < 0.5 * n[0] * n[1]  # the box, not the whole image, was mapped
    # The photo lights nothing up to the box's edge, except where the image's own edge cuts the box.
    lit_y, lit_x = np.nonzero(whole.image.any(axis=2))
    assert lit_x.min() > x0 or x0 == 0
    assert lit_y.min() > y0 or y0 == 0
    assert lit_x.max() < x1 - 1 or x1 == n[0]
    assert lit_y.max() < y1 - 1 or y1 == n[1]


@pytest.mark.parametrize("name, density", B.measured_cases("full"))
def test_stage_on_real_photos_holds_its_measured_figures(name, density, landmarker, detector):
    B.check_measured_figures("full", name, density, B.measure("full", name, density, landmarker, detector))


@pytest.mark.parametrize("name, density", B.issue_bar_cases("full"))
def test_issue_14_bar_found_everywhere_within_005_torso_lengths(name, density, landmarker, detector):
    B.check_issue_bar(B.measure("full", name, density, landmarker, detector))
