"""Fixtures for the evaluation tests: a small simulated session."""

from __future__ import annotations

from pathlib import Path

import pytest

from ergopose.cli import main


def simulate(out: Path, *, workers: int = 2, minutes: float = 0.25, seed: int = 0, size: str = "320x240") -> Path:
    code = main(["simulate", "--out", str(out), "--workers", str(workers), "--minutes", str(minutes),
                 "--seed", str(seed), "--size", size])
    assert code == 0
    return out


@pytest.fixture(scope="session")
def small_session(tmp_path_factory) -> Path:
    """2 workers, 15 s (180 frames), seed 0, small images (the evaluation does not look at video)."""
    return simulate(tmp_path_factory.mktemp("eval_sim") / "session")
