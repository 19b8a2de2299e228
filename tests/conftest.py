"""Shared fixtures: paths to ../shared data, seeded random generators."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parent.parent
#: ../shared next to the checkout; ERGOPOSE_SHARED overrides it (a git worktree elsewhere).
SHARED = Path(os.environ.get("ERGOPOSE_SHARED") or REPO.parent / "shared")
DATA = SHARED / "data"


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: every random source in the tests is reproducible."""
    return np.random.default_rng(20181001)


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real data in ../shared/data (see each folder's SOURCE.md)."""
    if not DATA.is_dir():
        pytest.fail(f"../shared/data is missing (expected at {DATA}); it comes with every clone's workspace")
    return DATA


@pytest.fixture(scope="session")
def fetched_model_dir(tmp_path_factory):
    """A model cache filled by a real fetch (pip download of the mediapipe wheel), once per session.

    Returns (model folder, progress events of the fetch).
    """
    from ergopose.pose.models import fetch_models

    model_dir = tmp_path_factory.mktemp("models")
    events = []
    fetch_models(progress=events.append, model_dir=model_dir)
    return model_dir, events
