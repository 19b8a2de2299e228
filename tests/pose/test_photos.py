"""Issue 14's photo test: real photographs of people that ship in packages, warped into a ceiling
fisheye (ergopose/evaluation/photos.py), found by the fisheye 2D stage at 20, 50 and 80 deg off
the lens axis in 8 image directions at two pixel densities, with keypoints close to the same
network on the photo (figures in docs/pose-in-fisheye.md, "Real photographs")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ergopose.evaluation import photos as P

#: Issue 14's bar: found in every case, median keypoint error within 0.05 torso lengths.
ISSUE_MAX_ERROR = 0.05
#: What the stage measures now, per landmark model, photo and pixel density (docs/pose-in-fisheye.md,
#: "Real photographs"): cases found (of 24) and the largest median keypoint error of a found case
#: (torso lengths). full is assess's model, heavy the default of `ergopose pose`. A change that
#: loses a case or adds more than MARGIN to the worst error fails.
MEASURED = {
    ("full", "astronaut", 620.0): (24, 0.046),
    ("full", "astronaut", 250.0): (24, 0.083),
    ("full", "camera", 620.0): (21, 0.217),
    ("full", "camera", 250.0): (23, 0.386),
    ("heavy", "astronaut", 620.0): (24, 0.037),
    ("heavy", "astronaut", 250.0): (24, 0.045),
    ("heavy", "camera", 620.0): (24, 0.114),
    ("heavy", "camera", 250.0): (24, 0.134),
}
MARGIN = 0.015
#: Where issue 14's bar is not met, and why (strict xfail: the test fails once it is met, to
#: move the figures up).
SHORTFALL = {
    ("full", "astronaut", 250.0): "0.083 in one case (80 deg, straight down the 1024 x 768 image, whose bottom edge "
    "runs through the eyes); the other 23 within 0.039",
    ("full", "camera", 620.0): "not found in 3 of 24 (80 deg at 0, 90 and 270 deg: the detector's cue views, rolled "
    "to its body axis, hold the man bent over his tripod below the gate); 13 of the 21 found above 0.05, up to 0.217",
    ("full", "camera", 250.0): "not found in 1 of 24 (80 deg straight up: 11 of the 25 keypoints outside the "
    "1024 x 768 frame); 19 of the 23 found above 0.05, up to 0.386",
    ("heavy", "camera", 620.0): "found in all 24; 3 above 0.05 (20 deg at 0 deg 0.114, 20 deg at 180 deg and 80 deg "
    "at 270 deg 0.05-0.052)",
    ("heavy", "camera", 250.0): "found in all 24; 6 above 0.05, up to 0.134 (20 deg at 270 deg)",
}
MODELS = ("full", "heavy")


@pytest.fixture(scope="module")
def landmarkers(landmarker, fetched_model_dir):
    """The landmark network of each model measured (full: the shared fixture)."""
    from ergopose.pose.blazepose import BlazePoseLandmarker

    return {"full": landmarker, "heavy": BlazePoseLandmarker(model="heavy", model_dir=fetched_model_dir[0])}


def _photo(name: str) -> np.ndarray:
    photo = next(p for p in P.PHOTOS if p.name == name)
    path = P.photo_file(photo)
    if path is None:
        pytest.skip(
            f"needs the photo {photo.path} of the package {photo.package} "
            "(a test dependency: pip install -c constraints.txt '.[test]')"
        )
    return P.read_photo(path)


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


_ROWS: dict[tuple[str, str, float], list[dict]] = {}


def _measure(model: str, name: str, density: tuple[float, int, int], landmarkers, detector) -> list[dict]:
    """The 24 cases (3 angles x 8 directions) of one photo at one density, run once per session."""
    landmarker = landmarkers[model]
    assert landmarker.card.name == f"blazepose_landmark_{model}"
    key = (model, name, density[0])
    if key not in _ROWS:
        image = _photo(name)
        ref = P.photo_reference(image, detector, landmarker)
        assert ref is not None, f"the network finds nobody with both shoulders in {name}"
        same = P.reference_at_density(image, detector, landmarker, density[0] / P.focal_px(ref))
        _ROWS[key] = [
            P.run_case(case, image, ref, landmarker, detector, same_density=same)
            for case in P.cases([name], densities=[density])
        ]
    return _ROWS[key]


@pytest.mark.slow
@pytest.mark.parametrize("density", P.DENSITIES, ids=lambda d: f"{d[0]:g}px_per_rad")
@pytest.mark.parametrize("name", [p.name for p in P.PHOTOS])
@pytest.mark.parametrize("model", MODELS)
def test_stage_on_real_photos_holds_its_measured_figures(model, name, density, landmarkers, detector):
    rows = _measure(model, name, density, landmarkers, detector)
    found, worst = MEASURED[(model, name, density[0])]
    table = P.render(rows)
    assert sum(r["found"] for r in rows) >= found, f"found in fewer than {found} of {len(rows)} cases:\n{table}"
    errors = [r["error"] for r in rows if r["found"]]
    assert max(errors) <= worst + MARGIN, f"median keypoint error up to {max(errors):.3f} torso lengths:\n{table}"


def _issue_bar_cases():
    for model in MODELS:
        for name in [p.name for p in P.PHOTOS]:
            for density in P.DENSITIES:
                key = (model, name, density[0])
                found, worst = MEASURED[key]
                marks = [pytest.mark.slow]
                if found < len(P.ANGLES_DEG) * len(P.DIRECTIONS_DEG) or worst > ISSUE_MAX_ERROR:
                    marks.append(pytest.mark.xfail(strict=True, reason=SHORTFALL[key]))
                yield pytest.param(model, name, density, marks=marks, id=f"{model}-{name}-{density[0]:g}px_per_rad")


@pytest.mark.parametrize("model, name, density", list(_issue_bar_cases()))
def test_issue_14_bar_found_everywhere_within_005_torso_lengths(model, name, density, landmarkers, detector):
    rows = _measure(model, name, density, landmarkers, detector)
    table = P.render(rows)
    assert all(r["found"] for r in rows), f"not found in every case:\n{table}"
    worst = max(r["error"] for r in rows)
    assert worst <= ISSUE_MAX_ERROR, f"median keypoint error up to {worst:.3f} torso lengths:\n{table}"
