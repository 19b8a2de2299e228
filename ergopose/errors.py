"""Errors a user can act on.

Raise :class:`ErgoposeError` for bad input (missing or corrupt files, invalid calibration,
unknown settings, unreadable models). The message names the file or field and says what is
wrong; the command line prints it on one line and exits non-zero, without a traceback.
"""

from __future__ import annotations

from os import PathLike


class ErgoposeError(Exception):
    """A problem with the user's input or environment, explained in one sentence."""

    def __init__(self, message: str, *, path: str | PathLike | None = None, field: str | None = None):
        self.path = None if path is None else str(path)
        self.field = field
        where = ""
        if self.path and self.field:
            where = f"{self.path}: {self.field}: "
        elif self.path:
            where = f"{self.path}: "
        elif self.field:
            where = f"{self.field}: "
        super().__init__(f"{where}{message}")


class ConfigError(ErgoposeError):
    """A settings, session or calibration file is invalid."""


class InputError(ErgoposeError):
    """A video, image or data file is missing, unreadable or inconsistent."""


class ModelError(ErgoposeError):
    """A pose model is missing, corrupt or cannot be run."""
