"""Shared fixtures: paths to ../shared data, seeded random generators.

Tests that need the real data of ../shared (beside the clone; ERGOPOSE_SHARED names another
place) ask for it with the ``shared_data`` fixture or :func:`need_shared`: without it they are
skipped with a reason naming the missing path. CI sets ERGOPOSE_REQUIRE_SHARED=1 (.ci/run), which
turns those skips into failures, so CI never passes without the data.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parent.parent
#: ../shared next to the checkout; ERGOPOSE_SHARED overrides it (a git worktree elsewhere).
SHARED = Path(os.environ.get("ERGOPOSE_SHARED") or REPO.parent / "shared")
DATA = SHARED / "data"
REQUIRE_SHARED = "ERGOPOSE_REQUIRE_SHARED"


def need_shared(path: Path, what: str = "data") -> Path:
    """``path`` under ../shared, or skip the test (fail when ERGOPOSE_REQUIRE_SHARED=1) naming it."""
    if path.exists():
        return path
    reason = (
        f"needs ../shared ({what}): {path} is missing; put the shared data beside the clone "
        f"or name it with ERGOPOSE_SHARED"
    )
    if os.environ.get(REQUIRE_SHARED, "") not in ("", "0"):
        pytest.fail(f"{reason} ({REQUIRE_SHARED} is set)", pytrace=False)
    pytest.skip(reason)


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: every random source in the tests is reproducible."""
    return np.random.default_rng(20181001)


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real data in ../shared/data (see each folder's SOURCE.md)."""
    return need_shared(DATA, "the real recordings and calibrations")


@pytest.fixture(scope="session")
def fetched_model_dir(tmp_path_factory):
    """A model cache filled by a real fetch (pip download of the mediapipe wheel and the npm
    registry's @mediapipe/pose tarball), once per session.

    Returns (model folder, progress events of the fetch).
    """
    from ergopose.pose.models import fetch_models

    model_dir = tmp_path_factory.mktemp("models")
    events = []
    fetch_models(progress=events.append, model_dir=model_dir)
    return model_dir, events


# The tiny simulated session and one uninterrupted assessment of it: shared by the pipeline tests
# (end to end, kill and resume, fault injection), made once per test session.


@pytest.fixture(scope="session")
def tiny_session(tmp_path_factory):
    """3 seconds of a simulated two-worker shift (36 frame pairs at 12 fps)."""
    from ergopose.sim.writer import SimulationConfig, simulate_session

    path = tmp_path_factory.mktemp("session") / "day1"
    simulate_session(path, SimulationConfig(workers=2, minutes=0.05, seed=4))
    return path


@pytest.fixture(scope="session")
def reference(tiny_session, fetched_model_dir, tmp_path_factory):
    """An uninterrupted run: the report folder and the bytes of every CSV file."""
    from ergopose import cli
    from tests.pipeline import helpers

    out = tmp_path_factory.mktemp("reference") / "report"
    assert cli.main(helpers.assess_args(tiny_session, out, fetched_model_dir[0])) == 0
    return out, helpers.csv_bytes(out)
