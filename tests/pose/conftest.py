"""Fixtures for the pose tests: the real BlazePose models, fetched once per session through pip
into a temporary cache (the drawn person for the tests is in mannequin.py)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def fetched_model_dir(tmp_path_factory):
    """A model cache filled by a real fetch (pip download of the mediapipe wheel), once per session."""
    from ergopose.pose.models import fetch_models

    model_dir = tmp_path_factory.mktemp("models")
    events = []
    fetch_models(progress=events.append, model_dir=model_dir)
    return model_dir, events


@pytest.fixture(scope="session")
def landmarker(fetched_model_dir):
    from ergopose.pose.blazepose import BlazePoseLandmarker

    return BlazePoseLandmarker(model_dir=fetched_model_dir[0], world=True)


@pytest.fixture(scope="session")
def detector(fetched_model_dir):
    from ergopose.pose.blazepose import BlazePoseDetector

    return BlazePoseDetector(model_dir=fetched_model_dir[0])
