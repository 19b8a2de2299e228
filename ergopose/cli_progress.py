"""Progress bars on stderr for the command line (the core only emits ProgressEvents)."""

from __future__ import annotations

import sys
import time
from typing import TextIO

from ergopose.progress import ProgressEvent


def _fmt_seconds(s: float) -> str:
    s = int(round(s))
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"


class ProgressBars:
    """A ProgressCallback that draws one bar per stage, with the time left.

    On a terminal the bar redraws in place; otherwise (logs, CI) a line is written at most
    every ``interval`` seconds per stage and when a stage completes.
    """

    def __init__(self, stream: TextIO | None = None, width: int = 30, interval: float = 5.0):
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.interval = interval
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._start: dict[str, float] = {}
        self._last: dict[str, float] = {}
        self._current: str | None = None

    def __call__(self, event: ProgressEvent) -> None:
        if event.unit == "note":  # ergopose.progress.warn: a line of its own, never throttled
            if self.tty and self._current is not None:
                self.stream.write("\n")
                self._current = None
            self.stream.write(f"ergopose: {event.stage}: {event.message}\n")
            self.stream.flush()
            return
        now = time.monotonic()
        start = self._start.setdefault(event.stage, now)
        finished = event.total is not None and event.done >= event.total
        if not self.tty and not finished and now - self._last.get(event.stage, -1e9) < self.interval:
            return
        self._last[event.stage] = now
        line = self._line(event, now - start)
        if self.tty:
            if self._current not in (None, event.stage):
                self.stream.write("\n")
            self.stream.write("\r" + line.ljust(100)[:120])
            if finished:
                self.stream.write("\n")
                self._current = None
            else:
                self._current = event.stage
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def _line(self, event: ProgressEvent, elapsed: float) -> str:
        if event.total:
            frac = min(max(event.done / event.total, 0.0), 1.0)
            filled = int(round(frac * self.width))
            bar = "#" * filled + "-" * (self.width - filled)
            left = elapsed / frac - elapsed if frac > 0 else float("nan")
            eta = f" {_fmt_seconds(left)} left" if frac > 0 and frac < 1 else f" {_fmt_seconds(elapsed)}"
            text = f"{event.stage:>12} [{bar}] {event.done}/{event.total} {event.unit}s{eta}"
        else:
            text = f"{event.stage:>12} {event.done} {event.unit}s {_fmt_seconds(elapsed)}"
        if event.message:
            text += f"  {event.message}"
        return text


def warnings_only(event: ProgressEvent) -> None:
    """A ProgressCallback for --quiet: no bars, but warnings (ergopose.progress.warn) still shown."""
    if event.unit == "note":
        print(f"ergopose: {event.stage}: {event.message}", file=sys.stderr, flush=True)
