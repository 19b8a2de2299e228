"""Issue 14's photo test with the heavy landmark model (the default of ``ergopose pose``): as
test_photos.py's with the full model, in a file of its own so that the test processes run the
two side by side (the figures and the bar in photo_bars.py)."""

from __future__ import annotations

import photo_bars as B
import pytest


@pytest.fixture(scope="module")
def heavy_landmarker(fetched_model_dir):
    from ergopose.pose.blazepose import BlazePoseLandmarker

    return BlazePoseLandmarker(model="heavy", model_dir=fetched_model_dir[0])


@pytest.mark.parametrize("name, density", B.measured_cases("heavy"))
def test_stage_on_real_photos_holds_its_measured_figures(name, density, heavy_landmarker, detector):
    B.check_measured_figures("heavy", name, density, B.measure("heavy", name, density, heavy_landmarker, detector))


@pytest.mark.parametrize("name, density", B.issue_bar_cases("heavy"))
def test_issue_14_bar_found_everywhere_within_005_torso_lengths(name, density, heavy_landmarker, detector):
    B.check_issue_bar(B.measure("heavy", name, density, heavy_landmarker, detector))
