"""Issue 14's photo test, shared by the two files that run it (tests/pose/test_photos.py, the
full landmark model, and tests/pose/test_photos_heavy.py, the heavy one: two files, so that the
test processes run them side by side): what the stage measures on real photographs warped into a
ceiling fisheye, the bar, and the cases, each computed once per process."""

from __future__ import annotations

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


def _photo(name: str):
    photo = next(p for p in P.PHOTOS if p.name == name)
    path = P.photo_file(photo)
    if path is None:
        pytest.skip(
            f"needs the photo {photo.path} of the package {photo.package} "
            "(a test dependency: pip install -c constraints.txt '.[test]')"
        )
    return P.read_photo(path)


_ROWS: dict[tuple[str, str, float], list[dict]] = {}


def measure(model: str, name: str, density: tuple[float, int, int], landmarker, detector) -> list[dict]:
    """The 24 cases (3 angles x 8 directions) of one photo at one density, run once per process."""
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


def measured_cases(model: str) -> list:
    """(name, density) of every photo and density, for the test of the measured figures."""
    return [
        pytest.param(name, density, marks=pytest.mark.slow, id=f"{model}-{name}-{density[0]:g}px_per_rad")
        for name in [p.name for p in P.PHOTOS]
        for density in P.DENSITIES
    ]


def issue_bar_cases(model: str) -> list:
    """(name, density) of every photo and density, strictly expected to fail where the bar is not met."""
    params = []
    for name in [p.name for p in P.PHOTOS]:
        for density in P.DENSITIES:
            key = (model, name, density[0])
            found, worst = MEASURED[key]
            marks = [pytest.mark.slow]
            if found < len(P.ANGLES_DEG) * len(P.DIRECTIONS_DEG) or worst > ISSUE_MAX_ERROR:
                marks.append(pytest.mark.xfail(strict=True, reason=SHORTFALL[key]))
            params.append(pytest.param(name, density, marks=marks, id=f"{model}-{name}-{density[0]:g}px_per_rad"))
    return params


def check_measured_figures(model: str, name: str, density: tuple[float, int, int], rows: list[dict]) -> None:
    """Found in at least as many cases, and no worse by more than MARGIN, as measured."""
    found, worst = MEASURED[(model, name, density[0])]
    table = P.render(rows)
    assert sum(r["found"] for r in rows) >= found, f"found in fewer than {found} of {len(rows)} cases:\n{table}"
    errors = [r["error"] for r in rows if r["found"]]
    assert max(errors) <= worst + MARGIN, f"median keypoint error up to {max(errors):.3f} torso lengths:\n{table}"


def check_issue_bar(rows: list[dict]) -> None:
    """Issue 14's bar: found in every case, within ISSUE_MAX_ERROR torso lengths."""
    table = P.render(rows)
    assert all(r["found"] for r in rows), f"not found in every case:\n{table}"
    worst = max(r["error"] for r in rows)
    assert worst <= ISSUE_MAX_ERROR, f"median keypoint error up to {worst:.3f} torso lengths:\n{table}"
