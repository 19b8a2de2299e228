"""Helpers of the pipeline tests that assess the tiny simulated session (its fixtures
``tiny_session`` and ``reference`` are in tests/conftest.py)."""

from __future__ import annotations

import re
from pathlib import Path

#: A progress bar line on stderr (not a message for the user).
PROGRESS_LINE = re.compile(r"^\s*[\w ]+ \[[#-]+\] ")


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
