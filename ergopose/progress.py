"""Progress reporting: the core never prints.

Long-running functions take ``progress: ProgressCallback | None`` and call it with a
:class:`ProgressEvent`. The command line turns events into progress bars on stderr; tests
collect them in a list.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol


@dataclass(frozen=True)
class ProgressEvent:
    """One step of a stage.

    stage: short name of the stage ("views", "pose", "tracking", ...).
    done: units finished so far in this stage (frames, views, files ...).
    total: units in the stage, or None when unknown.
    unit: what is counted ("frame", "file", "byte").
    message: optional detail for a human.
    """

    stage: str
    done: int
    total: int | None = None
    unit: str = "item"
    message: str = ""


class ProgressCallback(Protocol):
    def __call__(self, event: ProgressEvent) -> None: ...


def no_progress(event: ProgressEvent) -> None:
    """The default callback: ignore every event."""


def report(
    progress: ProgressCallback | None,
    stage: str,
    done: int,
    total: int | None = None,
    unit: str = "item",
    message: str = "",
) -> None:
    """Send one event if a callback was given."""
    if progress is not None:
        progress(ProgressEvent(stage=stage, done=done, total=total, unit=unit, message=message))


def warn(progress: ProgressCallback | None, message: str) -> None:
    """Tell the user something they should know that does not stop the work (a damaged stored
    piece computed again, frames skipped): an event of stage "warning", unit "note"."""
    report(progress, "warning", 0, None, unit="note", message=message)


ProgressFn = Callable[[ProgressEvent], None]
