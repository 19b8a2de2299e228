"""CSV export: per-frame scores, per-worker frame files, worker summaries, the session summary.

Every file is written atomically (ergopose.atomic) and its columns and units are documented in
docs/csv-columns.md. Angles are DEGREES in every CSV file; times are seconds; loads kilograms;
distances metres; percentages are of the worker's observed time. Scores are whole numbers and an
empty cell means "not scored" (a joint the score needs was not measured).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np
import pandas as pd

from ergopose.atomic import atomic_path
from ergopose.ergonomics.aggregate import REPETITION_PREFIX, ShiftSummary
from ergopose.ergonomics.posture import (ANGLE_COLUMNS, DISTANCE_COLUMNS, FLAG_COLUMNS, IDENTITY, POSTURE_COLUMNS,
                                         expand_sides, to_csv_units)
from ergopose.ergonomics.scoring import reba_columns, rula_columns
from ergopose.ergonomics.task_inputs import COLUMN as TASK_INPUTS_COLUMN
from ergopose.ergonomics.task_inputs import SETTINGS_INPUTS
from ergopose.ergonomics.uncertainty import CAUSES, CONFIDENCE_LEVELS, INPUT_GROUPS, SD_COLUMNS
from ergopose.ergonomics.uncertainty import SCORE_COLUMNS as UNCERTAINTY_SCORE_COLUMNS

#: digits after the decimal point per kind of column
_DECIMALS = {"angle": 2, "distance": 3, "time": 3, "load": 2, "percent": 2, "rate": 3}

#: The levels counted as high risk (RULA action level 3-4, REBA risk level 3-4 = high, very high).
HIGH_LEVELS = (3, 4)

#: the session summary's level columns: (method, level column, levels)
_SESSION_LEVELS = (("rula", "rula_action_level", (1, 2, 3, 4)), ("reba", "reba_risk_level", (0, 1, 2, 3, 4)))


def _score_columns(columns: Iterable[str]) -> list[str]:
    cols = set(columns)
    ordered = [c for c in rula_columns() + reba_columns() if c in cols]
    ordered += sorted(c for c in cols if c.startswith(REPETITION_PREFIX))
    return ordered


def _write(path: str | os.PathLike, frame: pd.DataFrame) -> Path:
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False, na_rep="", lineterminator="\n")
    return Path(path)


def _rounded(frame: pd.DataFrame) -> pd.DataFrame:
    out = {}
    for c in frame.columns:
        s = frame[c]
        if c in ANGLE_COLUMNS:
            out[c] = s.round(_DECIMALS["angle"])
        elif c in DISTANCE_COLUMNS:
            out[c] = s.round(_DECIMALS["distance"])
        elif c == "time_s":
            out[c] = s.round(_DECIMALS["time"])
        elif c == "load_kg":
            out[c] = s.round(_DECIMALS["load"])
        elif c in FLAG_COLUMNS:
            out[c] = s.astype("Int8")
        else:
            out[c] = s
    return pd.DataFrame(out, index=frame.index)


def scores_table(frames: pd.DataFrame, *, include_posture: bool = False) -> pd.DataFrame:
    """The columns of a scores CSV, in CSV units: identity, time_s, [posture], scores."""
    frames = expand_sides(frames)
    ident = [c for c in (*IDENTITY, "time_s") if c in frames.columns]
    posture = [c for c in POSTURE_COLUMNS if include_posture and c in frames.columns and c not in ident]
    scores = _score_columns(frames.columns)
    spread = [c for c in (*SD_COLUMNS, *UNCERTAINTY_SCORE_COLUMNS, TASK_INPUTS_COLUMN)
              if include_posture and c in frames.columns]
    table = frames[ident + posture + scores + spread]
    out = _rounded(to_csv_units(table))
    for c in spread:
        if c in SD_COLUMNS:
            out[c] = np.rad2deg(out[c].to_numpy(np.float64)).round(_DECIMALS["angle"])
    return out


def write_scores_csv(path: str | os.PathLike, frames: pd.DataFrame, *, include_posture: bool = False) -> Path:
    """Per-frame scores (what ``ergopose score`` writes): identity, time_s, every step score."""
    return _write(path, scores_table(frames, include_posture=include_posture))


def write_worker_frames_csv(path: str | os.PathLike, frames: pd.DataFrame) -> Path:
    """One worker's frames: identity, time_s, the posture (degrees) and every score."""
    with FramesCsvWriter(path) as w:
        w.write(frames)
    return Path(path)


class FramesCsvWriter:
    """:func:`write_worker_frames_csv` piece by piece, for a whole shift in bounded memory::

        with FramesCsvWriter(path) as w:
            w.write(frames_of_block)    # consecutive pieces of one worker's frames

    The file appears under ``path`` complete when the block ends, or not at all; the pieces give
    the bytes of one write of all the frames (the first piece fixes the columns).
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self.columns: list[str] | None = None
        self.rows = 0
        self._ctx = None
        self._file = None

    def __enter__(self) -> "FramesCsvWriter":
        self._ctx = atomic_path(self.path)
        tmp = self._ctx.__enter__()
        self._file = open(tmp, "w", encoding="utf-8", newline="")
        return self

    def write(self, frames: pd.DataFrame) -> None:
        table = scores_table(frames, include_posture=True)
        if self.columns is None:
            self.columns = list(table.columns)
            header = True
        else:
            missing = [c for c in self.columns if c not in table.columns]
            if missing or len(table.columns) != len(self.columns):
                raise ValueError(f"every piece needs the columns of the first; this one differs in {missing}")
            table = table[self.columns]
            header = False
        table.to_csv(self._file, index=False, header=header, na_rep="", lineterminator="\n")
        self.rows += len(table)

    def __exit__(self, exc_type, exc, tb) -> bool:
        self._file.close()
        if exc_type is None and self.columns is None:  # no frames: the header of an empty table
            with open(self._file.name, "w", encoding="utf-8", newline="") as f:
                scores_table(pd.DataFrame({"time_s": []}), include_posture=True).to_csv(
                    f, index=False, na_rep="", lineterminator="\n")
        self._ctx.__exit__(exc_type, exc, tb)
        return False


# ------------------------------------------------------------------------- worker summary

WORKER_SUMMARY_COLUMNS = (
    "worker", "section", "item", "hour", "value", "time_s", "percent", "holds", "longest_hold_s",
    "longest_hold_start_s", "start_s", "end_s", "peak_score", "count", "per_minute", "verdict", "sd_deg",
)
#: The session summary's names of the confidence levels (columns <name>_s, <name>_pct, <name>_<cause>_s ...).
CONFIDENCE_NAMES = {"confident": "confident", "low": "low_confidence", "unscored": "unscored"}


def worker_summary_table(summary: ShiftSummary) -> pd.DataFrame:
    """A worker's shift summary as a long table (columns WORKER_SUMMARY_COLUMNS)."""
    rows: list[dict] = []

    def row(**kw) -> None:
        rows.append({"worker": summary.worker, **kw})

    for col, dist in summary.distributions.items():
        for v in dist.values:
            row(section="distribution", item=col, value=str(v.value), time_s=v.time_s, percent=v.percent,
                holds=v.holds, longest_hold_s=v.longest_hold_s, longest_hold_start_s=v.longest_hold_start_s)
        row(section="distribution", item=col, value="missing", time_s=dist.missing_time_s,
            percent=dist.missing_percent)
    for h in summary.hourly:
        for v, secs in h.time_by_value.items():
            row(section="hourly", item=h.column, hour=h.hour, value=str(v), time_s=secs, percent=h.percent(v))
        row(section="hourly", item=h.column, hour=h.hour, value="missing", time_s=h.missing_s,
            percent=100.0 * h.missing_s / h.observed_s if h.observed_s else 0.0)
    for col, episodes in summary.episodes.items():
        for e in episodes:
            row(section="episode", item=col, value=str(e.level), time_s=e.duration_s, start_s=e.start_s,
                end_s=e.end_s, peak_score=e.peak_score)
    for r in summary.repetitions:
        row(section="repetitions", item=r.angle, value="shift", count=r.actions, per_minute=r.per_minute)
        row(section="repetitions", item=r.angle, value="max in one minute", count=r.max_in_one_minute)
        row(section="repetitions", item=r.angle, value="minutes with 4 or more", count=r.minutes_at_or_above_4)
    for f in summary.exposure:
        item = f"{f.standard}: {f.body_part}"
        if not f.measured:
            row(section="exposure", item=item, verdict=f.verdict)
            continue
        for zone, secs in f.zone_time_s.items():
            row(section="exposure", item=item, value=zone, time_s=secs,
                percent=100.0 * secs / summary.observed_s if summary.observed_s else 0.0,
                holds=f.static_holds.get(zone), longest_hold_s=f.longest_static_hold_s.get(zone),
                count=f.entries if f.standard.startswith("EN") else None,
                per_minute=f.per_minute if f.standard.startswith("EN") else None, verdict=f.verdict)
    for c in summary.confidence:
        row(section="confidence", item=c.level, value="all", time_s=c.time_s, percent=c.percent)
        for ca in c.causes:
            row(section="confidence", item=c.level, value=ca.cause, time_s=ca.time_s, percent=ca.percent)
    for i in summary.inputs:
        if math.isfinite(i.median_sd_rad):
            row(section="inputs", item=i.body_part, value="angle sd", count=i.measured_frames,
                sd_deg=math.degrees(i.median_sd_rad))
        if i.known_frames:
            row(section="inputs", item=i.body_part, value="inferred", count=i.inferred_frames,
                percent=i.inferred_percent)
    for u in summary.from_settings:
        row(section="inputs", item=u.input, value=f"from settings: {math.degrees(u.value_rad):g} deg",
            count=u.frames, time_s=u.time_s, percent=u.percent)
    table = pd.DataFrame(rows, columns=list(WORKER_SUMMARY_COLUMNS))
    table["sd_deg"] = table["sd_deg"].astype(np.float64).round(_DECIMALS["angle"])
    for c in ("hour", "holds", "peak_score", "count"):
        table[c] = table[c].astype("Int64")
    for c in ("time_s", "longest_hold_s", "longest_hold_start_s", "start_s", "end_s"):
        table[c] = table[c].astype(np.float64).round(_DECIMALS["time"])
    table["percent"] = table["percent"].astype(np.float64).round(_DECIMALS["percent"])
    table["per_minute"] = table["per_minute"].astype(np.float64).round(_DECIMALS["rate"])
    return table


def write_worker_summary_csv(path: str | os.PathLike, summary: ShiftSummary) -> Path:
    """A worker's shift summary, one row per reported figure (docs/csv-columns.md)."""
    return _write(path, worker_summary_table(summary))


# ------------------------------------------------------------------------ session summary


def _slug(text: str) -> str:
    out = "".join(ch.lower() if ch.isalnum() else "_" for ch in text)
    while "__" in out:
        out = out.replace("__", "_")
    return out.strip("_")


def _confidence_columns(s: ShiftSummary) -> dict[str, float]:
    """The tracked time split by confidence, with causes, and each input's certainty (NaN when the
    frames carried no confidence or deviation columns)."""
    r: dict[str, float] = {}
    for lv in CONFIDENCE_LEVELS:
        c = s.confidence_of(lv)
        name = CONFIDENCE_NAMES[lv]
        r[f"{name}_s"] = c.time_s if c is not None else math.nan
        r[f"{name}_pct"] = c.percent if c is not None else math.nan
        if lv == "confident":
            continue
        by = {ca.cause: ca for ca in c.causes} if c is not None else {}
        for cause in CAUSES:
            ca = by.get(cause)
            r[f"{name}_{_slug(cause)}_s"] = (ca.time_s if ca else 0.0) if c is not None else math.nan
            r[f"{name}_{_slug(cause)}_pct"] = (ca.percent if ca else 0.0) if c is not None else math.nan
    inputs = {i.body_part: i for i in s.inputs}
    for part, _, _ in INPUT_GROUPS:
        i = inputs.get(part)
        r[f"{_slug(part)}_median_sd_deg"] = math.degrees(i.median_sd_rad) if i is not None else math.nan
        r[f"{_slug(part)}_inferred_pct"] = i.inferred_percent if i is not None else math.nan
    for name in SETTINGS_INPUTS:
        used = sum(u.frames for u in s.from_settings if u.input == name)
        r[f"{name}_from_settings_pct"] = 100.0 * used / s.scored_frames if s.scored_frames else math.nan
    return r


def session_summary_table(summaries: Sequence[ShiftSummary] | Mapping[str, ShiftSummary]) -> pd.DataFrame:
    """One row per worker: time per level, worst episode, repetitions, exposure verdicts."""
    items = list(summaries.values()) if isinstance(summaries, Mapping) else list(summaries)
    rows = []
    for s in items:
        r: dict[str, object] = {"worker": s.worker, "start_s": s.start_s, "end_s": s.end_s, "frames": s.frames,
                                "frame_period_s": s.frame_period_s, "observed_s": s.observed_s}
        for method, col, levels in _SESSION_LEVELS:
            dist = s.distributions.get(col)
            for lv in levels:
                v = dist.at(lv) if dist is not None else None
                r[f"{method}_level{lv}_s"] = v.time_s if v else math.nan
                r[f"{method}_level{lv}_pct"] = v.percent if v else math.nan
                r[f"{method}_level{lv}_longest_hold_s"] = v.longest_hold_s if v else math.nan
            r[f"{method}_missing_pct"] = dist.missing_percent if dist is not None else math.nan
            high, scored = s.high_time_s(col, HIGH_LEVELS), s.scored_time_s(col)
            r[f"{method}_scored_s"] = scored if dist is not None else math.nan
            r[f"{method}_high_s"] = high if dist is not None else math.nan
            r[f"{method}_high_pct"] = 100.0 * high / s.observed_s if dist is not None and s.observed_s > 0 else math.nan
            r[f"{method}_high_pct_of_scored"] = 100.0 * high / scored if dist is not None and scored > 0 else math.nan
            eps = s.episodes.get(col, ())
            worst = eps[0] if eps else None
            r[f"{method}_worst_level"] = worst.level if worst else None
            r[f"{method}_worst_episode_start_s"] = worst.start_s if worst else math.nan
            r[f"{method}_worst_episode_s"] = worst.duration_s if worst else math.nan
            r[f"{method}_worst_episode_peak"] = worst.peak_score if worst else None
        if s.repetitions:
            top = max(s.repetitions, key=lambda x: (x.per_minute, x.max_in_one_minute))
            r["max_repetitions_per_min"] = top.per_minute
            r["max_repetitions_angle"] = top.angle
            r["max_repetitions_in_one_minute"] = max(x.max_in_one_minute for x in s.repetitions)
        else:
            r["max_repetitions_per_min"] = math.nan
            r["max_repetitions_angle"] = None
            r["max_repetitions_in_one_minute"] = None
        for f in s.exposure:
            r[f"{_slug(f.standard)}_{_slug(f.body_part)}"] = f.verdict
        r.update(_confidence_columns(s))
        rows.append(r)
    table = pd.DataFrame(rows)
    for c in table.columns:
        if c.endswith(("_s",)) or c == "frame_period_s":
            table[c] = table[c].astype(np.float64).round(6 if c == "frame_period_s" else _DECIMALS["time"])
        elif c.endswith(("_pct", "_pct_of_scored")):
            table[c] = table[c].astype(np.float64).round(_DECIMALS["percent"])
        elif c.endswith("_sd_deg"):
            table[c] = table[c].astype(np.float64).round(_DECIMALS["angle"])
        elif c == "max_repetitions_per_min":
            table[c] = table[c].astype(np.float64).round(_DECIMALS["rate"])
        elif c.endswith(("_worst_level", "_worst_episode_peak", "in_one_minute")):
            table[c] = table[c].astype("Int64")
    return table


def write_session_summary_csv(path: str | os.PathLike, summaries: Sequence[ShiftSummary] | Mapping[str, ShiftSummary]) -> Path:
    """The session summary, one row per worker (docs/csv-columns.md)."""
    return _write(path, session_summary_table(summaries))


__all__ = [
    "scores_table", "write_scores_csv", "write_worker_frames_csv", "worker_summary_table",
    "write_worker_summary_csv", "session_summary_table", "write_session_summary_csv", "WORKER_SUMMARY_COLUMNS",
]
