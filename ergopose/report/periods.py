"""Sustained periods of high risk: what a worker's report asks a safety engineer to act on.

A one-frame score is noise as often as it is a posture (a joint placed wrongly for 1/12 s), so
the report does not rank single frames. Its rule (docs/reports.md, "Sustained periods"):

1. A frame is **high** when its RULA action level or its REBA risk level is one of the high
   levels (RULA AL3-AL4, REBA high or very high: :data:`HIGH_LEVELS`).
2. High frames less than :data:`MAX_GAP_S` apart join into one period: the gap is the time from
   the end of one high frame (its time plus one frame period) to the start of the next high
   frame, whatever filled it (lower scores, unscored or untracked frames).
3. A period lasts from its first high frame to the end of its last; only periods lasting at
   least :data:`MIN_DURATION_S` are kept.
4. Periods are ranked by their time at high risk (high frames x frame period), longest first;
   ties by the earlier start.
5. Each period is drawn at one frame: the middle frame of its longest run of consecutive high
   frames with unchanged RULA grand and REBA scores (the posture held longest), the first such
   run on ties.

6. Each period names its score inputs and where they came from (:func:`period_inputs`, over its
   high frames): the body angles the cameras measured; each task input of the settings in force
   (load and how it is held, coupling, the flags, with the time each value held); the wrist
   angles given by the settings where the hand was not seen (``inputs_from_settings``); and the
   task inputs not given (scored by the rule for unknown inputs).

Everything here is numpy on whole arrays (no per-frame Python loop): an 8-hour shift at 12 fps
(346k frames) is found in milliseconds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from ergopose.ergonomics.task_inputs import COLUMN as FROM_SETTINGS_COLUMN
from ergopose.ergonomics.task_inputs import SETTINGS_INPUTS, used_mask

#: Levels counted as high risk (the index page's and floor maps' "high"), per method.
HIGH_LEVELS = {"rula": (3, 4), "reba": (3, 4)}
#: A period lasts at least this long (seconds) from its first high frame to the end of its last.
MIN_DURATION_S = 5.0
#: High frames at most this far apart (seconds, end of one to start of the next) belong to one period.
MAX_GAP_S = 2.0
#: Periods reported per worker.
MAX_PERIODS = 6
#: A body part drives a period when it is in one of its two highest RULA posture bands (from band
#: 2) for at least this share of the period's high-risk time; at most MAX_DRIVERS per period, the
#: highest band score first.
DRIVER_SHARE = 0.25
MAX_DRIVERS = 3
_EPS = 1e-6


@dataclass(frozen=True)
class Period:
    """A sustained period of high risk in a frame series.

    start, stop: index of its first high frame and one past its last (into the series given).
    start_s: time of the first high frame; end_s: time of the last high frame plus one frame
    period. high_s: high frames x frame period (the gaps bridged are not counted).
    drawn: index of the frame drawn for it (rule 5).
    """

    start: int
    stop: int
    start_s: float
    end_s: float
    high_s: float
    drawn: int

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


def high_frames(rula_level: np.ndarray, reba_level: np.ndarray) -> np.ndarray:
    """Rule 1: True where either level is high (NaN = not scored, never high)."""
    r = np.asarray(rula_level, dtype=np.float64)
    b = np.asarray(reba_level, dtype=np.float64)
    return np.isin(r, HIGH_LEVELS["rula"]) | np.isin(b, HIGH_LEVELS["reba"])


def sustained_periods(
    time_s: np.ndarray,
    high: np.ndarray,
    frame_period_s: float,
    *,
    min_duration_s: float = MIN_DURATION_S,
    max_gap_s: float = MAX_GAP_S,
    held: np.ndarray | None = None,
) -> list[Period]:
    """Rules 2-5 on a series: time_s ascending (seconds), high (bool per frame), held (an integer
    code per frame whose runs are the postures held, e.g. RULA grand x 16 + REBA score; None:
    every high frame the same). Returns the periods, ranked (rule 4)."""
    t = np.asarray(time_s, dtype=np.float64)
    high = np.asarray(high, dtype=bool)
    if t.shape != high.shape:
        raise ValueError(f"time_s has {t.size} frames, high has {high.size}")
    if not frame_period_s > 0:
        raise ValueError("frame_period_s must be positive")
    idx = np.flatnonzero(high)
    if idx.size == 0:
        return []
    gap = t[idx[1:]] - (t[idx[:-1]] + frame_period_s)
    new = np.concatenate([[True], gap > max_gap_s + _EPS])
    first = idx[new]
    last = idx[np.append(np.flatnonzero(new)[1:] - 1, idx.size - 1)]
    n_high = np.diff(np.append(np.flatnonzero(new), idx.size))
    start_s = t[first]
    end_s = t[last] + frame_period_s
    keep = end_s - start_s >= min_duration_s - _EPS
    order = np.lexsort((start_s[keep], -n_high[keep]))
    first, last, n_high, start_s, end_s = (a[keep][order] for a in (first, last, n_high, start_s, end_s))
    drawn = _drawn_frames(t, high, frame_period_s, held, first, last + 1)
    return [
        Period(int(a), int(b) + 1, float(s), float(e), float(n) * frame_period_s, int(d))
        for a, b, s, e, n, d in zip(first, last, start_s, end_s, n_high, drawn)
    ]


def _drawn_frames(
    t: np.ndarray, high: np.ndarray, period: float, held: np.ndarray | None, starts: np.ndarray, stops: np.ndarray
) -> np.ndarray:
    """Rule 5 for every period at once: runs of consecutive high frames with one held code (a run
    also ends where frames are more than 1.5 frame periods apart), the longest in each period."""
    n = t.size
    code = np.zeros(n, dtype=np.int64) if held is None else np.asarray(held, dtype=np.int64)
    brk = np.ones(n, dtype=bool)
    brk[1:] = (code[1:] != code[:-1]) | (high[1:] != high[:-1]) | (np.diff(t) > 1.5 * period)
    run_id = np.cumsum(brk) - 1
    lengths = np.bincount(run_id[high], minlength=run_id[-1] + 1 if n else 0)
    out = np.empty(starts.size, dtype=np.int64)
    run_first = np.flatnonzero(brk)
    for k, (a, b) in enumerate(zip(starts.tolist(), stops.tolist())):  # one step per period, not per frame
        ids = np.arange(run_id[a], run_id[b - 1] + 1)
        best = int(ids[np.argmax(lengths[ids])])
        out[k] = run_first[best] + (lengths[best] - 1) // 2
    return out


def worker_periods(
    time_s: np.ndarray,
    rula_grand: np.ndarray,
    rula_level: np.ndarray,
    reba_score: np.ndarray,
    reba_level: np.ndarray,
    frame_period_s: float,
    limit: int = MAX_PERIODS,
) -> list[Period]:
    """The ranked sustained periods of one worker's frames (score arrays: float, NaN = not
    scored), at most ``limit`` of them."""
    high = high_frames(rula_level, reba_level)
    rg = np.nan_to_num(np.asarray(rula_grand, dtype=np.float64), nan=0.0).astype(np.int64)
    rb = np.nan_to_num(np.asarray(reba_score, dtype=np.float64), nan=0.0).astype(np.int64)
    return sustained_periods(time_s, high, frame_period_s, held=rg * 16 + rb)[:limit]


#: Task inputs of the settings as the scored frames hold them (docs/posture-table.md): load_kg
#: (NaN = not given), load_mode and coupling (text, <NA> = not given), flags 0.0 / 1.0 (NaN = not
#: given). The load and how it is held are one input (RULA force/load, REBA load/force).
TASK_INPUTS = ("load", "coupling", "shock", "arm_supported", "seated", "legs_supported", "wrist_twist_end_range")
#: The angles the cameras measure for RULA and REBA (the wrists too, unless the settings stand in).
MEASURED_INPUTS = ("upper arms", "lower arms", "wrists", "neck", "trunk", "legs")
#: Columns of the scored frames :func:`period_inputs` reads.
INPUT_COLUMNS = ("load_kg", "load_mode", *TASK_INPUTS[1:], FROM_SETTINGS_COLUMN, *SETTINGS_INPUTS)


@dataclass(frozen=True)
class InputUse:
    """A score input during a period's high frames and where it came from.

    input: "angles" (the MEASURED_INPUTS), a TASK_INPUTS name, or a SETTINGS_INPUTS wrist angle
    ("left_wrist_flexion": the settings' value scored where the hand was not seen; the measured
    angle elsewhere). source: "measured" (the cameras), "task input" (settings.toml) or "not
    given" (no value in the settings: the scoring's rule for unknown inputs). value: for a task
    input, load (kg or None, how held or None), the coupling text, the flag (bool) or the wrist
    angle (radians); None otherwise. seconds: the period's high frames with this source and value
    x frame period. measured: for "angles", the MEASURED_INPUTS.
    """

    input: str
    source: str
    value: Any
    seconds: float
    measured: tuple[str, ...] = ()


def period_inputs(rows: Any, frame_period_s: float) -> tuple[InputUse, ...]:
    """The score inputs of one period (``rows``: its high frames from the scored frames, with the
    INPUT_COLUMNS present; a column missing = results written before they were read: that input
    is left out). Order: the measured angles, the wrist angles given by the settings, the task
    inputs given, the task inputs not given; within an input the value held longest first."""
    n = len(rows)
    if not n:
        return ()
    cols = set(rows.columns)
    out: list[InputUse] = []
    wrists: list[InputUse] = []
    if FROM_SETTINGS_COLUMN in cols:
        for name in SETTINGS_INPUTS:
            used = used_mask(rows[FROM_SETTINGS_COLUMN], name)
            if not used.any() or name not in cols:
                continue
            given = np.round(rows[name].to_numpy(np.float64, na_value=np.nan)[used], 9)
            vals, counts = np.unique(given, return_counts=True)
            for k in np.argsort(-counts, kind="stable"):
                wrists.append(InputUse(name, "task input", float(vals[k]), float(counts[k]) * frame_period_s))
    out.append(InputUse("angles", "measured", None, n * frame_period_s, MEASURED_INPUTS))
    out.extend(wrists)
    given_rows: list[InputUse] = []
    missing: list[InputUse] = []
    for name in TASK_INPUTS:
        keys = ["load_kg", "load_mode"] if name == "load" else [name]
        if not all(k in cols for k in keys):
            continue
        table = rows.loc[:, keys].reset_index(drop=True)
        present = table.notna().any(axis=1).to_numpy(dtype=bool)
        if not present.all():
            missing.append(InputUse(name, "not given", None, float((~present).sum()) * frame_period_s))
        if not present.any():
            continue
        counts = table[present].astype(object).value_counts(dropna=False)
        found = [
            (tuple(_plain(v) for v in (key if isinstance(key, tuple) else (key,))), int(c)) for key, c in counts.items()
        ]
        for key, count in sorted(found, key=lambda kc: (-kc[1], repr(kc[0]))):
            value: Any = key if name == "load" else key[0] if name == "coupling" else bool(key[0])
            given_rows.append(InputUse(name, "task input", value, count * frame_period_s))
    return tuple(out + given_rows + missing)


def _plain(v: Any) -> Any:
    """A value of a task input column as a plain Python value; None where not given."""
    if v is None or v is pd.NA:
        return None
    if isinstance(v, (float, np.floating)):
        return None if not np.isfinite(v) else float(v)
    return str(v)


__all__ = [
    "HIGH_LEVELS",
    "MIN_DURATION_S",
    "MAX_GAP_S",
    "MAX_PERIODS",
    "DRIVER_SHARE",
    "MAX_DRIVERS",
    "Period",
    "high_frames",
    "sustained_periods",
    "worker_periods",
    "TASK_INPUTS",
    "MEASURED_INPUTS",
    "INPUT_COLUMNS",
    "InputUse",
    "period_inputs",
]
