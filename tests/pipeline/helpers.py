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


#: The warning that task inputs of the settings reach no tracked person. The simulated sessions'
#: settings give loads for w1, w2 (the simulation's ground truth) with stature matching off, so
#: every assessment of one warns (tests/pipeline/test_workers.py checks that warning).
TASK_INPUTS_WARNING = "are applied to nobody"


def user_lines(err: str) -> list[str]:
    """The lines of stderr meant for the user (progress bars and model-runtime chatter left out),
    except the simulated sessions' TASK_INPUTS_WARNING."""
    return [ln for ln in err.splitlines()
            if ln.strip() and not PROGRESS_LINE.match(ln) and not ln.startswith("INFO:")
            and TASK_INPUTS_WARNING not in ln]
