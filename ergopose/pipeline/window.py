"""Part of a day: ``--start`` / ``--end`` of ``ergopose assess`` and ``ergopose report``.

A time is a clock time of the session's day and time zone (``HH:MM`` or ``HH:MM:SS``, as read
from the session's ``recorded_at``; a clock time before the recording's start time of day is taken
on the next day when that falls within the session, for shifts past midnight) or seconds from
the session's first frame (``90``, ``90.5``, ``90s``). Either may be left out (the session's
start, its end).

A :class:`Window` is half open, [start, end): a frame belongs to it when start <= frame / fps <
end. Bad values (not a time, end not after start, outside the session) raise ConfigError naming
the option, which the command line prints as one line (exit 2).
"""

from __future__ import annotations

import datetime as dt
import math
import re
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ergopose.errors import ConfigError

_CLOCK = re.compile(r"^(\d{1,2}):(\d{2})(?::(\d{2}(?:\.\d+)?))?$")
_SECONDS = re.compile(r"^(\d+(?:\.\d*)?|\.\d+)\s*s?$")


@dataclass(frozen=True)
class Window:
    """[start_s, end_s) in seconds from the session's first frame."""

    start_s: float
    end_s: float

    def frame_range(self, fps: float) -> tuple[int, int]:
        """(first, stop): the frames f with start_s <= f / fps < end_s."""
        first = int(math.ceil(self.start_s * fps - 1e-6))
        stop = int(math.ceil(self.end_s * fps - 1e-6))
        return first, stop

    def mask(self, frames: np.ndarray, fps: float) -> np.ndarray:
        first, stop = self.frame_range(fps)
        frames = np.asarray(frames)
        return (frames >= first) & (frames < stop)

    def as_dict(self) -> dict[str, float]:
        return {"start_s": float(self.start_s), "end_s": float(self.end_s)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any] | None) -> "Window | None":
        if not data:
            return None
        return cls(float(data["start_s"]), float(data["end_s"]))


def clock_label(recorded_at: dt.datetime, seconds: float, sep: str = ":") -> str:
    """The clock time of a time of the session: HH:MM, or HH:MM:SS when the seconds are not 0."""
    t = recorded_at + dt.timedelta(seconds=float(seconds))
    return t.strftime(f"%H{sep}%M{sep}%S" if t.second or t.microsecond else f"%H{sep}%M")


def describe(window: Window, recorded_at: dt.datetime) -> str:
    """The window in words: "08:15 to 08:30 (900 s from 00:15:00 after the start)"."""
    return f"{clock_label(recorded_at, window.start_s)} to {clock_label(recorded_at, window.end_s)}"


def folder_name(window: Window, recorded_at: dt.datetime) -> str:
    """A folder name for the window's outputs: part-0815-0830."""
    return f"part-{clock_label(recorded_at, window.start_s, '')}-{clock_label(recorded_at, window.end_s, '')}"


def parse_time(value: str, recorded_at: dt.datetime, duration_s: float, option: str) -> float:
    """Seconds from the session's first frame for a --start/--end value (see the module docstring)."""
    text = str(value).strip()
    m = _SECONDS.match(text)
    if m:
        return float(m.group(1))
    m = _CLOCK.match(text)
    if not m:
        raise ConfigError(
            f"{value!r} is not a time: give a clock time HH:MM or HH:MM:SS of the session's day "
            "(its recorded_at), or seconds from its start (e.g. 90)",
            field=option,
        )
    hours, minutes = int(m.group(1)), int(m.group(2))
    seconds = float(m.group(3) or 0.0)
    if hours > 23 or minutes > 59 or seconds >= 60:
        raise ConfigError(f"{value!r} is not a clock time (hours 0-23, minutes and seconds 0-59)", field=option)
    whole = int(seconds)
    moment = dt.datetime.combine(
        recorded_at.date(),
        dt.time(hours, minutes, whole, int(round((seconds - whole) * 1e6))),
        tzinfo=recorded_at.tzinfo,
    )
    offset = (moment - recorded_at).total_seconds()
    if offset < 0 and offset + 86400.0 <= duration_s:  # a shift past midnight
        offset += 86400.0
    return offset


def resolve(start: str | None, end: str | None, recorded_at: dt.datetime, duration_s: float) -> Window | None:
    """The Window of --start/--end (None when neither is given); ConfigError for bad values."""
    if start is None and end is None:
        return None
    first = parse_time(start, recorded_at, duration_s, "--start") if start is not None else 0.0
    last = parse_time(end, recorded_at, duration_s, "--end") if end is not None else float(duration_s)
    span = (
        f"the session runs from {clock_label(recorded_at, 0.0)} to {clock_label(recorded_at, duration_s)} "
        f"({duration_s:g} s)"
    )
    if start is not None and not (0.0 <= first < duration_s):
        raise ConfigError(f"{start} is outside the session: {span}", field="--start")
    if end is not None and not (0.0 < last <= duration_s + 1e-6):
        raise ConfigError(f"{end} is outside the session: {span}", field="--end")
    if last <= first:
        raise ConfigError(
            f"{end if end is not None else 'the end'} is not after --start "
            f"{start if start is not None else 'the start'}: {span}",
            field="--end",
        )
    return Window(first, min(last, float(duration_s)))


__all__ = ["Window", "parse_time", "resolve", "describe", "folder_name", "clock_label"]
