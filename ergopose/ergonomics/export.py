"""CSV export: per-frame scores, per-worker frame files, worker summaries, the session summary.

Every file is written atomically (ergopose.atomic) and its columns and units are documented in
docs/csv-columns.md. Angles are DEGREES in every CSV file; times are seconds; loads kilograms;
distances metres; percentages are of the worker's observed time. Scores are whole numbers and an
empty cell means "not scored" (a joint the score needs was not measured).
"""

from __future__ import annotations

import abc
import contextlib

import datetime as dt
import math
import os
from pathlib import Path
from types import TracebackType
from typing import Any, Iterable, Literal, Mapping, Self, Sequence, TextIO

import numpy as np
from numpy.typing import ArrayLike
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from ergopose.arrays import AnyArray, FloatArray
from ergopose.atomic import atomic_path
from ergopose.ergonomics.aggregate import REPETITION_PREFIX, aggregate_shift
from ergopose.ergonomics.posture import (
    ANGLE_COLUMNS,
    DISTANCE_COLUMNS,
    FLAG_COLUMNS,
    IDENTITY,
    POSTURE_COLUMNS,
    expand_sides,
    to_csv_units,
)
from ergopose.ergonomics.scoring import reba_columns, rula_columns
from ergopose.ergonomics.task_inputs import COLUMN as TASK_INPUTS_COLUMN
from ergopose.ergonomics.task_inputs import SETTINGS_INPUTS
from ergopose.ergonomics.shares import HIGH_LEVELS as SHARE_HIGH_LEVELS
from ergopose.ergonomics.shares import LEVEL_COLUMNS, percent, shift_high_risk
from ergopose.ergonomics.shift_records import ShiftSummary
from ergopose.ergonomics.uncertainty import (
    CAUSES,
    CONFIDENCE_LEVELS,
    INPUT_GROUP_LIMIT_JOINTS,
    INPUT_GROUPS,
    SD_ANGLES,
    SD_COLUMNS,
)
from ergopose.ergonomics.uncertainty import SCORE_COLUMNS as UNCERTAINTY_SCORE_COLUMNS

#: digits after the decimal point per kind of column
_DECIMALS = {"angle": 2, "distance": 3, "time": 3, "load": 2, "percent": 2, "rate": 3}

#: A worker's files in csv/: the frames table (and its Parquet twin), the steps, the summary.
FRAMES_SUFFIX, STEPS_SUFFIX, SUMMARY_SUFFIX = "_frames.csv", "_steps.csv", "_summary.csv"


def steps_path(frames_csv: str | os.PathLike[str]) -> Path:
    """The steps CSV beside a worker's frames CSV (<worker>_steps.csv)."""
    name = Path(frames_csv).name
    stem = name[: -len(FRAMES_SUFFIX)] if name.endswith(FRAMES_SUFFIX) else Path(name).stem
    return Path(frames_csv).with_name(stem + STEPS_SUFFIX)


#: The levels counted as high risk (RULA action level 3-4, REBA risk level 3-4 = high, very high).
HIGH_LEVELS = SHARE_HIGH_LEVELS["rula"]

#: the session summary's level columns: (method, level column, levels)
_SESSION_LEVELS = (("rula", LEVEL_COLUMNS["rula"], (1, 2, 3, 4)), ("reba", LEVEL_COLUMNS["reba"], (0, 1, 2, 3, 4)))


def _score_columns(columns: Iterable[str]) -> list[str]:
    cols = set(columns)
    ordered = [c for c in rula_columns() + reba_columns() if c in cols]
    ordered += sorted(c for c in cols if c.startswith(REPETITION_PREFIX))
    return ordered


def _write(path: str | os.PathLike[str], frame: pd.DataFrame, bom: bool = False) -> Path:
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False, na_rep="", lineterminator="\n", encoding=_encoding(bom))
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
    spread = [
        c
        for c in (*SD_COLUMNS, *UNCERTAINTY_SCORE_COLUMNS, TASK_INPUTS_COLUMN)
        if include_posture and c in frames.columns
    ]
    table = frames[ident + posture + scores + spread]
    out = _rounded(to_csv_units(table))
    for c in spread:
        if c in SD_COLUMNS:
            out[c] = np.rad2deg(out[c].to_numpy(np.float64)).round(_DECIMALS["angle"])
    return out


def write_scores_csv(path: str | os.PathLike[str], frames: pd.DataFrame, *, include_posture: bool = False) -> Path:
    """Per-frame scores (what ``ergopose score`` writes): identity, time_s, every step score."""
    return _write(path, scores_table(frames, include_posture=include_posture))


def write_worker_steps_csv(path: str | os.PathLike[str], frames: pd.DataFrame, *, bom: bool = False) -> Path:
    """One worker's frames step by step: identity, time_s, the posture (degrees), every step score
    of both methods and the frame's uncertainty (docs/csv-columns.md, "Steps per frame")."""
    with StepsCsvWriter(path, bom=bom) as w:
        w.write(frames)
    return Path(path)


def _encoding(bom: bool) -> str:
    """UTF-8, with a byte order mark when asked (Excel then reads the file as UTF-8)."""
    return "utf-8-sig" if bom else "utf-8"


class _PieceWriter(abc.ABC):
    """A CSV file written piece by piece, atomically: the file appears under ``path`` complete
    when the block ends, or not at all; the pieces give the bytes of one write of all the rows
    (the first piece fixes the columns). Subclasses give ``table(frames)`` and ``empty()``."""

    def __init__(self, path: str | os.PathLike[str], *, bom: bool = False) -> None:
        self.path = Path(path)
        self.bom = bool(bom)
        self.columns: list[str] | None = None
        self.rows = 0
        self._ctx: contextlib.AbstractContextManager[Path] | None = None
        self._file: TextIO | None = None

    @abc.abstractmethod
    def table(self, frames: pd.DataFrame) -> pd.DataFrame:
        """The rows of these frames."""

    @abc.abstractmethod
    def empty(self) -> pd.DataFrame:
        """The table of no frames (its columns)."""

    def __enter__(self) -> Self:
        self._ctx = atomic_path(self.path)
        tmp = self._ctx.__enter__()
        self._file = open(tmp, "w", encoding=_encoding(self.bom), newline="")
        return self

    def write(self, frames: pd.DataFrame) -> pd.DataFrame:
        table = self.table(frames)
        if self.columns is None:
            self.columns = list(table.columns)
            header = True
        else:
            missing = [c for c in self.columns if c not in table.columns]
            if missing or len(table.columns) != len(self.columns):
                raise ValueError(f"every piece needs the columns of the first; this one differs in {missing}")
            table = table[self.columns]
            header = False
        if self._file is None:
            raise RuntimeError("write() is called inside the with block")
        table.to_csv(self._file, index=False, header=header, na_rep="", lineterminator="\n")
        self.rows += len(table)
        return table

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> Literal[False]:
        assert self._ctx is not None and self._file is not None  # set by __enter__
        self._file.close()
        if exc_type is None and self.columns is None:  # no frames: the header of an empty table
            with open(self._file.name, "w", encoding=_encoding(self.bom), newline="") as f:
                self.empty().to_csv(f, index=False, na_rep="", lineterminator="\n")
        self._ctx.__exit__(exc_type, exc, tb)
        return False


class StepsCsvWriter(_PieceWriter):
    """:func:`write_worker_steps_csv` piece by piece, for a whole shift in bounded memory::

    with StepsCsvWriter(path) as w:
        w.write(frames_of_block)    # consecutive pieces of one worker's frames
    """

    def table(self, frames: pd.DataFrame) -> pd.DataFrame:
        return scores_table(frames, include_posture=True)

    def empty(self) -> pd.DataFrame:
        return scores_table(pd.DataFrame({"time_s": []}), include_posture=True)


# ------------------------------------------------------------------------- frames (tidy)

#: The angles of the frames table, each with its standard deviation (docs/csv-columns.md).
FRAME_ANGLES = SD_ANGLES
#: The final scores of the frames table, each with its probability and 80 % range, and the level
#: column that follows from it.
FRAME_SCORES = (("rula_grand", "rula_action_level"), ("reba_score", "reba_risk_level"))
YES, NO = "yes", "no"


def frame_columns() -> tuple[str, ...]:
    """The columns of a worker's frames table, in file order."""
    cols = ["time", "time_s", "frame", "worker", "name"]
    for a in FRAME_ANGLES:
        cols += [f"{a}_deg", f"{a}_sd_deg"]
    for score, level in FRAME_SCORES:
        cols += [score, f"{score}_p", f"{score}_low", f"{score}_high", level]
    cols += ["scored", "confidence", "cause", "held_at_limit", "inputs_from_settings"]
    return tuple(cols)


def clock_times(recorded_at: dt.datetime | None, time_s: ArrayLike) -> pd.DatetimeIndex | None:
    """The clock time of each time_s (seconds from the session's first frame), to the millisecond:
    tz-aware when recorded_at has an offset; None without recorded_at."""
    if recorded_at is None:
        return None
    ms = np.round(np.asarray(time_s, dtype=np.float64) * 1000.0).astype(np.int64)
    return pd.DatetimeIndex(pd.Timestamp(recorded_at) + pd.to_timedelta(ms, unit="ms"))


def iso_strings(times: pd.DatetimeIndex | None, n: int) -> AnyArray:
    """ISO 8601 with milliseconds and the UTC offset (2024-03-04T08:00:00.083+01:00; no offset for
    times without a zone); empty strings without times. Vectorised (numpy's datetime strings)."""
    if times is None:
        return np.full(n, "", dtype=object)
    wall = times.tz_localize(None) if times.tz is not None else times  # the local clock
    text: AnyArray = np.datetime_as_string(wall.to_numpy().astype("datetime64[ms]"), unit="ms")
    if times.tz is None:
        return text.astype(object)
    utc = times.tz_convert("UTC").tz_localize(None)
    offsets = np.round((wall - utc).total_seconds().to_numpy() / 60.0).astype(np.int64)  # minutes
    suffix = np.empty(len(offsets), dtype="U6")
    for m in np.unique(offsets):  # one offset, or two across a change of daylight saving time
        h, mm = divmod(abs(int(m)), 60)
        suffix[offsets == m] = f"{'-' if m < 0 else '+'}{h:02d}:{mm:02d}"
    return np.char.add(text, suffix).astype(object)


def _int_column(frames: pd.DataFrame, col: str) -> pd.Series:
    if col not in frames.columns:
        return pd.Series(pd.arrays.IntegerArray(np.zeros(len(frames), np.int16), np.ones(len(frames), bool)))
    x = pd.to_numeric(frames[col], errors="coerce").to_numpy(np.float64, na_value=np.nan)
    ok = np.isfinite(x)
    return pd.Series(pd.arrays.IntegerArray(np.where(ok, np.round(x), 0).astype(np.int16), ~ok))


def _float_column(frames: pd.DataFrame, col: str) -> FloatArray:
    if col not in frames.columns:
        return np.full(len(frames), np.nan)
    column: FloatArray = pd.to_numeric(frames[col], errors="coerce").to_numpy(np.float64, na_value=np.nan)
    return column


def _text_column(frames: pd.DataFrame, col: str) -> AnyArray:
    if col not in frames.columns:
        return np.full(len(frames), "", dtype=object)
    column: AnyArray = frames[col].astype("string").fillna("").to_numpy(dtype=object)
    return column


def frames_table(
    frames: pd.DataFrame, *, recorded_at: dt.datetime | None = None, name: str | None = None
) -> pd.DataFrame:
    """A worker's scored frames (score_rows columns, radians) as the tidy frames table
    (frame_columns(), degrees; docs/csv-columns.md, "Frames per worker").

    recorded_at: the session's first frame (the ``time`` column; empty without it). name: the
    worker's display name (default: the id)."""
    frames = expand_sides(frames).reset_index(drop=True)
    n = len(frames)
    t = _float_column(frames, "time_s")
    worker = _text_column(frames, "worker")
    out: dict[str, object] = {
        "time": iso_strings(clock_times(recorded_at, t), n),
        "time_s": np.round(t, _DECIMALS["time"]),
        "frame": _int_column(frames, "frame").astype("Int64"),
        "worker": worker,
        "name": np.full(n, name, dtype=object) if name is not None else worker,
    }
    for a in FRAME_ANGLES:
        out[f"{a}_deg"] = np.round(np.rad2deg(_float_column(frames, a)), _DECIMALS["angle"]) + 0.0  # no -0.0
        out[f"{a}_sd_deg"] = np.round(np.rad2deg(_float_column(frames, f"{a}_sd")), _DECIMALS["angle"])
    present = np.ones(n, dtype=bool)
    for score, level in FRAME_SCORES:
        scores = out[score] = _int_column(frames, score)
        out[f"{score}_p"] = np.round(_float_column(frames, f"{score}_p"), 4)
        out[f"{score}_low"] = _int_column(frames, f"{score}_low")
        out[f"{score}_high"] = _int_column(frames, f"{score}_high")
        out[level] = _int_column(frames, level)
        present &= scores.notna().to_numpy()
    confidence = _text_column(frames, "confidence")
    if "confidence" not in frames.columns:  # frames without the uncertainty: scored or not
        confidence = np.where(present, "", "unscored").astype(object)
    out["scored"] = np.where(present, YES, NO).astype(object)
    out["confidence"] = confidence
    out["cause"] = _text_column(frames, "cause")
    out["held_at_limit"] = _text_column(frames, "held_at_limit")
    out["inputs_from_settings"] = _text_column(frames, TASK_INPUTS_COLUMN)
    table = pd.DataFrame(out)
    return table[list(frame_columns())]


def frames_arrow(table: pd.DataFrame, recorded_at: dt.datetime | None) -> pa.Table:
    """The frames table for Parquet: ``time`` as a timestamp (milliseconds, with the session's
    time zone; null without recorded_at), the rest as in the CSV file."""
    times = clock_times(recorded_at, table["time_s"].to_numpy(np.float64))
    t = table.drop(columns=["time"])
    arrow = pa.Table.from_pandas(t, preserve_index=False)
    if times is None:
        col = pa.nulls(len(table), type=pa.timestamp("ms"))
    else:
        col = pa.array(times.as_unit("ms") if hasattr(times, "as_unit") else times)
        col = col.cast(pa.timestamp("ms", tz=col.type.tz))
    return arrow.add_column(0, "time", col).replace_schema_metadata(None)


class FramesCsvWriter(_PieceWriter):
    """A worker's frames table (:func:`frames_table`) piece by piece, in bounded memory::

        with FramesCsvWriter(path, recorded_at=..., name=..., parquet=path.with_suffix(".parquet")) as w:
            w.write(frames_of_block)    # consecutive pieces of one worker's scored frames

    The CSV file (and the Parquet file when ``parquet`` names one) appear complete when the block
    ends, or not at all; the pieces give the bytes of one write of all the frames.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        recorded_at: dt.datetime | None = None,
        name: str | None = None,
        bom: bool = False,
        parquet: str | os.PathLike[str] | None = None,
    ) -> None:
        super().__init__(path, bom=bom)
        self.recorded_at = recorded_at
        self.name = name
        self.parquet = Path(parquet) if parquet is not None else None
        self._pq_ctx: contextlib.AbstractContextManager[Path] | None = None
        self._pq_writer: pq.ParquetWriter | None = None
        self._pq_tmp: Path | None = None

    def table(self, frames: pd.DataFrame) -> pd.DataFrame:
        return frames_table(frames, recorded_at=self.recorded_at, name=self.name)

    def empty(self) -> pd.DataFrame:
        return frames_table(pd.DataFrame({"time_s": []}), recorded_at=self.recorded_at, name=self.name)

    def __enter__(self) -> Self:
        super().__enter__()
        if self.parquet is not None:
            self._pq_ctx = atomic_path(self.parquet)
            self._pq_tmp = self._pq_ctx.__enter__()
        return self

    def write(self, frames: pd.DataFrame) -> pd.DataFrame:
        table = super().write(frames)
        self._parquet_write(table)
        return table

    def _parquet_write(self, table: pd.DataFrame) -> None:
        if self._pq_tmp is None:
            return
        arrow = frames_arrow(table, self.recorded_at)
        if self._pq_writer is None:
            self._pq_writer = pq.ParquetWriter(self._pq_tmp, arrow.schema, compression="zstd")
        self._pq_writer.write_table(arrow.cast(self._pq_writer.schema))

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> Literal[False]:
        try:
            if self._pq_ctx is not None:
                if exc_type is None and self._pq_writer is None:
                    self._parquet_write(self.empty())
                if self._pq_writer is not None:
                    self._pq_writer.close()
                self._pq_ctx.__exit__(exc_type, exc, tb)
        finally:
            super().__exit__(exc_type, exc, tb)
        return False


def write_worker_frames_csv(
    path: str | os.PathLike[str],
    frames: pd.DataFrame,
    *,
    recorded_at: dt.datetime | None = None,
    name: str | None = None,
    bom: bool = False,
    parquet: str | os.PathLike[str] | None = None,
) -> Path:
    """One worker's frames table (:func:`frames_table`), and the same as Parquet when ``parquet``
    names a file."""
    with FramesCsvWriter(path, recorded_at=recorded_at, name=name, bom=bom, parquet=parquet) as w:
        w.write(frames)
    return Path(path)


# ------------------------------------------------------------------------- worker summary

WORKER_SUMMARY_COLUMNS = (
    "worker",
    "section",
    "item",
    "hour",
    "value",
    "time_s",
    "percent",
    "holds",
    "longest_hold_s",
    "longest_hold_start_s",
    "start_s",
    "end_s",
    "peak_score",
    "count",
    "per_minute",
    "verdict",
    "sd_deg",
)
#: The session summary's names of the confidence levels (columns <name>_s, <name>_pct, <name>_<cause>_s ...).
CONFIDENCE_NAMES = {"confident": "confident", "low": "low_confidence", "unscored": "unscored"}


def worker_summary_table(summary: ShiftSummary) -> pd.DataFrame:
    """A worker's shift summary as a long table (columns WORKER_SUMMARY_COLUMNS)."""
    rows: list[dict[str, Any]] = []

    def row(**kw: Any) -> None:
        rows.append({"worker": summary.worker, **kw})

    for col, dist in summary.distributions.items():
        for v in dist.values:
            row(
                section="distribution",
                item=col,
                value=str(v.value),
                time_s=v.time_s,
                percent=v.percent,
                holds=v.holds,
                longest_hold_s=v.longest_hold_s,
                longest_hold_start_s=v.longest_hold_start_s,
            )
        row(section="distribution", item=col, value="missing", time_s=dist.missing_time_s, percent=dist.missing_percent)
    for h in summary.hourly:
        for value, secs in h.time_by_value.items():
            row(section="hourly", item=h.column, hour=h.hour, value=str(value), time_s=secs, percent=h.percent(value))
        row(
            section="hourly",
            item=h.column,
            hour=h.hour,
            value="missing",
            time_s=h.missing_s,
            percent=100.0 * h.missing_s / h.observed_s if h.observed_s else 0.0,
        )
    for col, episodes in summary.episodes.items():
        for e in episodes:
            row(
                section="episode",
                item=col,
                value=str(e.level),
                time_s=e.duration_s,
                start_s=e.start_s,
                end_s=e.end_s,
                peak_score=e.peak_score,
            )
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
            row(
                section="exposure",
                item=item,
                value=zone,
                time_s=secs,
                percent=100.0 * secs / summary.observed_s if summary.observed_s else 0.0,
                holds=f.static_holds.get(zone),
                longest_hold_s=f.longest_static_hold_s.get(zone),
                count=f.entries if f.standard.startswith("EN") else None,
                per_minute=f.per_minute if f.standard.startswith("EN") else None,
                verdict=f.verdict,
            )
    for c in summary.confidence:
        row(section="confidence", item=c.level, value="all", time_s=c.time_s, percent=c.percent)
        for ca in c.causes:
            row(section="confidence", item=c.level, value=ca.cause, time_s=ca.time_s, percent=ca.percent)
    for i in summary.inputs:
        if math.isfinite(i.median_sd_rad):
            row(
                section="inputs",
                item=i.body_part,
                value="angle sd",
                count=i.measured_frames,
                sd_deg=math.degrees(i.median_sd_rad),
            )
        shares = (
            ("inferred", i.inferred_frames, i.inferred_percent, i.known_frames > 0),
            ("joint limit", i.limited_frames, i.limited_percent, math.isfinite(i.limited_percent)),
        )
        for kind, count, share, known in shares:
            if known:
                row(section="inputs", item=i.body_part, value=kind, count=count, percent=share)
    for u in summary.from_settings:
        row(
            section="inputs",
            item=u.input,
            value=f"from settings: {math.degrees(u.value_rad):g} deg",
            count=u.frames,
            time_s=u.time_s,
            percent=u.percent,
        )
    table = pd.DataFrame(rows, columns=list(WORKER_SUMMARY_COLUMNS))
    table["sd_deg"] = table["sd_deg"].astype(np.float64).round(_DECIMALS["angle"])
    for name in ("hour", "holds", "peak_score", "count"):
        table[name] = table[name].astype("Int64")
    for name in ("time_s", "longest_hold_s", "longest_hold_start_s", "start_s", "end_s"):
        table[name] = table[name].astype(np.float64).round(_DECIMALS["time"])
    table["percent"] = table["percent"].astype(np.float64).round(_DECIMALS["percent"])
    table["per_minute"] = table["per_minute"].astype(np.float64).round(_DECIMALS["rate"])
    return table


def write_worker_summary_csv(path: str | os.PathLike[str], summary: ShiftSummary, *, bom: bool = False) -> Path:
    """A worker's shift summary, one row per reported figure (docs/csv-columns.md)."""
    return _write(path, worker_summary_table(summary), bom=bom)


# ------------------------------------------------------------------------ session summary


def _slug(text: str) -> str:
    out = "".join(ch.lower() if ch.isalnum() else "_" for ch in text)
    while "__" in out:
        out = out.replace("__", "_")
    return out.strip("_")


#: The exposure columns of the session summary per finding (standard, body part): the zones
#: reported, each (zone index of ergopose.ergonomics.exposure, the zone in the standard's terms,
#: whether its static holds are reported too, whether its entries per minute are reported too).
_ISO_LIMITED = ((1, "time_limited", True, False), (2, "not_recommended", True, False))
_ISO_NOT_RECOMMENDED = ((2, "not_recommended", True, False),)
EXPOSURE_COLUMNS: dict[tuple[str, str], tuple[tuple[int, str, bool, bool], ...]] = {
    ("ISO 11226", "trunk"): _ISO_LIMITED,
    ("ISO 11226", "head"): _ISO_LIMITED,
    ("ISO 11226", "neck"): _ISO_NOT_RECOMMENDED,
    ("ISO 11226", "left upper arm"): _ISO_LIMITED,
    ("ISO 11226", "left shoulder"): _ISO_NOT_RECOMMENDED,
    ("ISO 11226", "right upper arm"): _ISO_LIMITED,
    ("ISO 11226", "right shoulder"): _ISO_NOT_RECOMMENDED,
    ("EN 1005-4", "left upper arm"): ((1, "20_60", False, True), (2, "over_60", False, False)),
    ("EN 1005-4", "right upper arm"): ((1, "20_60", False, True), (2, "over_60", False, False)),
    ("EN 1005-4", "trunk side bend or twist"): ((1, "10_or_more", False, True),),
}
#: the names of the zones of each finding, by index (ergopose.ergonomics.exposure.exposure_specs)
_ZONE_NAMES = {
    "trunk": ("0-20", "20-60", ">60"),
    "head": ("<25", "25-85", ">85"),
    "neck": ("acceptable", "-", "flexion>25 or extension"),
    "upper arm": ("0-20", "20-60", ">60"),
    "shoulder": ("not raised", "-", "raised"),
    "trunk side bend or twist": ("<10", ">=10"),
}


def _zone_name(body_part: str, index: int) -> str:
    for key in (body_part, body_part.replace("left ", "").replace("right ", "")):
        if key in _ZONE_NAMES:
            return _ZONE_NAMES[key][index]
    raise KeyError(body_part)


def _exposure_columns(s: ShiftSummary) -> dict[str, object]:
    """Per body part in the standards' terms: the verdict, the time in each zone that is not
    acceptable (ISO 11226: also the part of it held still longer than 4 s; EN 1005-4: also the
    movements into the zone per minute)."""
    found = {(f.standard, f.body_part): f for f in s.exposure}
    r: dict[str, object] = {}
    for (standard, part), zones in EXPOSURE_COLUMNS.items():
        key = f"{_slug(standard)}_{_slug(part)}"
        f = found.get((standard, part))
        r[key] = f.verdict if f is not None else "not measured"
        m = f if f is not None and f.measured else None
        for index, term, held, rate in zones:
            zone = _zone_name(part, index)
            r[f"{key}_{term}_s"] = m.zone_time_s.get(zone, 0.0) if m is not None else math.nan
            if held:
                r[f"{key}_{term}_held_s"] = m.static_time_s.get(zone, 0.0) if m is not None else math.nan
                r[f"{key}_{term}_longest_hold_s"] = (
                    m.longest_static_hold_s.get(zone, 0.0) if m is not None else math.nan
                )
            if rate:
                r[f"{key}_{term}_per_min"] = m.per_minute if m is not None else math.nan
    return r


def _confidence_columns(s: ShiftSummary) -> dict[str, float]:
    """The tracked time split into scored and unscored (with causes), and the scored time by
    confidence (NaN when the frames carried no confidence column)."""
    r: dict[str, float] = {}
    tracked = s.observed_s
    if s.confidence:
        scored = sum(c.time_s for c in s.confidence if c.level != "unscored")
        r["scored_s"], r["scored_pct_of_tracked"] = scored, percent(scored, tracked)
    else:
        r["scored_s"] = r["scored_pct_of_tracked"] = math.nan
    for lv in reversed(CONFIDENCE_LEVELS):  # unscored (with causes), low, confident
        c = s.confidence_of(lv)
        name = CONFIDENCE_NAMES[lv]
        r[f"{name}_s"] = c.time_s if c is not None else math.nan
        r[f"{name}_pct_of_tracked"] = percent(c.time_s, tracked) if c is not None else math.nan
        if lv == "confident":
            continue
        by = {ca.cause: ca for ca in c.causes} if c is not None else {}
        for cause in CAUSES:
            ca = by.get(cause)
            r[f"{name}_{_slug(cause)}_s"] = (ca.time_s if ca else 0.0) if c is not None else math.nan
    return r


def _input_columns(s: ShiftSummary) -> dict[str, float]:
    """How well each input was measured (NaN without deviation columns or scored frames)."""
    r: dict[str, float] = {}
    inputs = {i.body_part: i for i in s.inputs}
    for part, _, _ in INPUT_GROUPS:
        i = inputs.get(part)
        r[f"{_slug(part)}_median_sd_deg"] = math.degrees(i.median_sd_rad) if i is not None else math.nan
        r[f"{_slug(part)}_inferred_pct_of_tracked"] = i.inferred_percent if i is not None else math.nan
    for (part, _, _), held in zip(INPUT_GROUPS, INPUT_GROUP_LIMIT_JOINTS):
        if len(held):
            i = inputs.get(part)
            r[f"{_slug(part)}_joint_limit_pct_of_tracked"] = i.limited_percent if i is not None else math.nan
    for name in SETTINGS_INPUTS:
        used = sum(u.frames for u in s.from_settings if u.input == name)
        r[f"{name}_from_settings_pct_of_scored"] = 100.0 * used / s.scored_frames if s.scored_frames else math.nan
    return r


def _clock(recorded_at: dt.datetime | None, seconds: float) -> str:
    if recorded_at is None or not math.isfinite(seconds):
        return ""
    return str(iso_strings(clock_times(recorded_at, [seconds]), 1)[0])


def session_summary_table(
    summaries: Sequence[ShiftSummary] | Mapping[str, ShiftSummary],
    *,
    names: Mapping[str, str] | None = None,
    recorded_at: dt.datetime | None = None,
) -> pd.DataFrame:
    """One row per worker (docs/csv-columns.md, "Summary per worker"): tracked, scored and unscored
    time with causes, time per level with the shares of the tracked and of the scored time, the
    worst episodes, repetitions and exposure per body part in the standards' terms.

    names: display name per worker id (default: the id). recorded_at: the session's first frame
    (the clock-time columns; empty without it)."""
    items = list(summaries.values()) if isinstance(summaries, Mapping) else list(summaries)
    names = names or {}
    rows = []
    for s in items:
        tracked = s.observed_s
        r: dict[str, object] = {
            "worker": s.worker,
            "name": names.get(s.worker, s.worker),
            "start": _clock(recorded_at, s.start_s),
            "end": _clock(recorded_at, s.end_s),
            "start_s": s.start_s,
            "end_s": s.end_s,
            "frames": s.frames,
            "frame_period_s": s.frame_period_s,
            "tracked_s": tracked,
        }
        r.update(_confidence_columns(s))
        for method, col, levels in _SESSION_LEVELS:
            dist = s.distributions.get(col)
            risk = shift_high_risk(s, method)
            known = dist is not None
            r[f"{method}_scored_s"] = risk.scored_s if known else math.nan
            r[f"{method}_unscored_s"] = risk.unscored_s if known else math.nan
            r[f"{method}_unscored_pct_of_tracked"] = risk.unscored_pct_of_tracked if known else math.nan
            for lv in levels:
                v = dist.at(lv) if dist is not None else None
                r[f"{method}_level{lv}_s"] = v.time_s if v else math.nan
                r[f"{method}_level{lv}_pct_of_tracked"] = percent(v.time_s, tracked) if v else math.nan
                r[f"{method}_level{lv}_pct_of_scored"] = percent(v.time_s, risk.scored_s) if v else math.nan
                r[f"{method}_level{lv}_longest_hold_s"] = v.longest_hold_s if v else math.nan
            r[f"{method}_high_s"] = risk.high_s if known else math.nan
            r[f"{method}_high_pct_of_tracked"] = risk.pct_of_tracked if known else math.nan
            r[f"{method}_high_pct_of_scored"] = risk.pct_of_scored if known else math.nan
            eps = s.episodes.get(col, ())
            worst = eps[0] if eps else None
            r[f"{method}_worst_level"] = worst.level if worst else None
            r[f"{method}_worst_episode_start"] = _clock(recorded_at, worst.start_s) if worst else ""
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
        r.update(_exposure_columns(s))
        r.update(_input_columns(s))
        rows.append(r)
    table = pd.DataFrame(rows, columns=session_summary_columns()) if not rows else pd.DataFrame(rows)
    for c in table.columns:
        if c == "frame_period_s":
            table[c] = table[c].astype(np.float64).round(6)
        elif c.endswith("_s"):
            table[c] = table[c].astype(np.float64).round(_DECIMALS["time"])
        elif "_pct" in c:
            table[c] = table[c].astype(np.float64).round(_DECIMALS["percent"])
        elif c.endswith("_sd_deg"):
            table[c] = table[c].astype(np.float64).round(_DECIMALS["angle"])
        elif c.endswith("_per_min"):
            table[c] = table[c].astype(np.float64).round(_DECIMALS["rate"])
        elif c.endswith(("_worst_level", "_worst_episode_peak", "in_one_minute")) or c == "frames":
            table[c] = table[c].astype("Int64")
    return table


def session_summary_columns() -> list[str]:
    """The columns of the session summary, in file order (those of a worker with every figure)."""
    empty = aggregate_shift(pd.DataFrame({"time_s": [0.0], "rula_action_level": [1], "reba_risk_level": [1]}), "")
    return list(session_summary_table([empty]).columns)


def write_session_summary_csv(
    path: str | os.PathLike[str],
    summaries: Sequence[ShiftSummary] | Mapping[str, ShiftSummary],
    *,
    names: Mapping[str, str] | None = None,
    recorded_at: dt.datetime | None = None,
    bom: bool = False,
) -> Path:
    """The session summary, one row per worker (docs/csv-columns.md)."""
    return _write(path, session_summary_table(summaries, names=names, recorded_at=recorded_at), bom=bom)


__all__ = [
    "scores_table",
    "write_scores_csv",
    "write_worker_steps_csv",
    "StepsCsvWriter",
    "frame_columns",
    "frames_table",
    "frames_arrow",
    "FramesCsvWriter",
    "write_worker_frames_csv",
    "worker_summary_table",
    "write_worker_summary_csv",
    "session_summary_table",
    "session_summary_columns",
    "write_session_summary_csv",
    "WORKER_SUMMARY_COLUMNS",
    "clock_times",
    "iso_strings",
    "FRAMES_SUFFIX",
    "STEPS_SUFFIX",
    "SUMMARY_SUFFIX",
    "steps_path",
]
