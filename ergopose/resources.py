"""Where packaged data lives: assessments/ (scoring methods) and templates/ (report templates).

In a checkout they sit at the top of the repository; ``pip install .`` installs them inside
the package (``ergopose/assessments``, ``ergopose/templates``). Both places work.
"""

from __future__ import annotations

from pathlib import Path

from ergopose.errors import ErgoposeError

_KNOWN = ("assessments", "templates")


def resource_dir(name: str) -> Path:
    """Return the folder holding packaged data ``name`` ("assessments" or "templates")."""
    if name not in _KNOWN:
        raise ValueError(f"unknown resource folder {name!r}; expected one of {_KNOWN}")
    package = Path(__file__).resolve().parent
    for candidate in (package / name, package.parent / name):
        if candidate.is_dir():
            return candidate
    raise ErgoposeError(f"the packaged folder '{name}' is missing; reinstall ergopose with 'pip install .'")
