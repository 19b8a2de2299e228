"""ergopose runs numpy's BLAS on one thread per process unless the user set it (ergopose/__init__.py)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
CODE = "import ergopose, numpy, os; print(os.environ.get('OPENBLAS_NUM_THREADS'))"


def _run(env_value: str | None) -> str:
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    env["PYTHONPATH"] = str(REPO)
    if env_value is not None:
        env["OPENBLAS_NUM_THREADS"] = env_value
    out = subprocess.run([sys.executable, "-c", CODE], env=env, capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_one_blas_thread_by_default():
    assert _run(None) == "1"


def test_the_users_choice_is_kept():
    assert _run("3") == "3"
