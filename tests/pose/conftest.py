"""Fixtures for the pose tests: the real BlazePose networks (``fetched_model_dir``, in
tests/conftest.py, fetches them once per session; the drawn person is in mannequin.py)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def landmarker(fetched_model_dir):
    from ergopose.pose.blazepose import BlazePoseLandmarker

    return BlazePoseLandmarker(model_dir=fetched_model_dir[0], world=True)


@pytest.fixture(scope="session")
def detector(fetched_model_dir):
    from ergopose.pose.blazepose import BlazePoseDetector

    return BlazePoseDetector(model_dir=fetched_model_dir[0])
