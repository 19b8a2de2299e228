"""Errors a user can act on.

Raise :class:`ErgoposeError` for bad input (missing or corrupt files, invalid calibration,
unknown settings, unreadable models). The message names the file or field and says what is
wrong; the command line prints it on one line and exits non-zero, without a traceback.
"""

from __future__ import annotations

import errno
from os import PathLike


class ErgoposeError(Exception):
    """A problem with the user's input or environment, explained in one sentence."""

    def __init__(self, message: str, *, path: str | PathLike[str] | None = None, field: str | None = None):
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


class OutputError(ErgoposeError):
    """The output folder cannot take the results: not a folder, not writable, or the disk is full."""


#: errno values that mean "this place cannot take more output", and what to tell the user.
_OUTPUT_ERRNOS = {
    errno.ENOSPC: "the disk is full",
    errno.EDQUOT: "the disk quota is used up",
    errno.EROFS: "the file system is read-only",
    errno.EACCES: "no permission to write here",
    errno.EPERM: "no permission to write here",
}


def output_reason(exc: BaseException) -> str | None:
    """What an OSError of writing means for the user ("the disk is full", ...), or None."""
    code = getattr(exc, "errno", None)
    return _OUTPUT_ERRNOS.get(code) if isinstance(code, int) else None


def output_error(exc: OSError) -> OutputError | None:
    """The one-line OutputError for an OSError of writing output (disk full, read-only, no
    permission), or None for any other OSError. Files already complete are never touched by a
    failed write (ergopose.atomic), so the message says the run can be resumed."""
    what = output_reason(exc)
    if what is None:
        return None
    where = exc.filename
    if exc.errno in (errno.ENOSPC, errno.EDQUOT):
        advice = (
            "make room (or give another folder with --out) and run the same command again: "
            "the finished pieces are kept and the run continues where it stopped"
        )
    else:
        advice = "give a folder you can write to with --out"
    return OutputError(f"cannot write ({what}); {advice}", path=where)
