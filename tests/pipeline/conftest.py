"""A tiny simulated session and one uninterrupted assessment of it, shared by the pipeline tests
(the end-to-end test, the kill-and-resume tests and the fault-injection suite)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ergopose import cli

#: A progress bar line on stderr (not a message for the user).
PROGRESS_LINE = re.compile(r"^\s*[\w ]+ \[[#-]+\] ")


@pytest.fixture(scope="session")
def tiny_session(tmp_path_factory):
    """3 seconds of a simulated two-worker shift (36 frame pairs at 12 fps)."""
    from ergopose.sim.writer import SimulationConfig, simulate_session

    path = tmp_path_factory.mktemp("session") / "day1"
    simulate_session(path, SimulationConfig(workers=2, minutes=0.05, seed=4))
    return path


def assess_args(session, out, model_dir, *extra):
    """``ergopose assess`` arguments for the tiny session: chunks of 0.5 s (6 frames, 6 chunks)."""
    return ["assess", "--session", str(session), "--out", str(out), "--model-dir", str(model_dir),
            "--chunk-seconds", "0.5", *extra]


def csv_bytes(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "csv").glob("*.csv"))}


def user_lines(err: str) -> list[str]:
    """The lines of stderr meant for the user (progress bars and model-runtime chatter left out)."""
    return [ln for ln in err.splitlines()
            if ln.strip() and not PROGRESS_LINE.match(ln) and not ln.startswith("INFO:")]


@pytest.fixture(scope="session")
def reference(tiny_session, fetched_model_dir, tmp_path_factory):
    """An uninterrupted run: the report folder and the bytes of every CSV file."""
    out = tmp_path_factory.mktemp("reference") / "report"
    assert cli.main(assess_args(tiny_session, out, fetched_model_dir[0])) == 0
    return out, csv_bytes(out)
