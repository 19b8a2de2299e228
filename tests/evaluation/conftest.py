"""Fixtures for the evaluation tests: a small simulated session."""

from __future__ import annotations

from pathlib import Path

import pytest

from evaluation_helpers import simulate


@pytest.fixture(scope="session")
def small_session(tmp_path_factory) -> Path:
    """2 workers, 15 s (180 frames), seed 0, small images (the evaluation does not look at video)."""
    return simulate(tmp_path_factory.mktemp("eval_sim") / "session")
