"""Stored results of a session: what ``ergopose assess`` writes so reports can be re-rendered.

Layout (docs/reports.md), inside a report folder such as ``reports/<session>/``::

    results/
      session.json                      SessionInfo (ergopose.report.context)
      workers/<worker_id>/frames.parquet   per-frame table, FRAME_COLUMNS
      workers/<worker_id>/summary.json     WorkerSummary
      workers/<worker_id>/diagnostics.json WorkerDiagnostics

Every JSON file is ``{"format": RESULTS_FORMAT, "kind": ..., "data": {...}}``. The per-frame
table carries the final scores of every frame the worker was tracked in, the worker's floor
position and whether the skeleton was reliable; the report downsamples it for display (timeline,
floor map) while the headline numbers come from the summary.

:func:`save_results` writes the folder atomically (a crash leaves the previous results intact);
:func:`load_results` reads it back and raises one InputError naming the file and field at the
first problem.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from ergopose.atomic import atomic_dir, readable
from ergopose.errors import InputError
from ergopose.report._codec import from_jsonable, to_jsonable
from ergopose.report.context import SessionInfo, WorkerDiagnostics, WorkerResults, WorkerSummary, check_worker

RESULTS_FORMAT = "ergopose-results/1"
RESULTS_DIR = "results"
SESSION_FILE = "session.json"
WORKERS_DIR = "workers"
FRAMES_FILE = "frames.parquet"
SUMMARY_FILE = "summary.json"
DIAGNOSTICS_FILE = "diagnostics.json"

#: Columns of frames.parquet: name -> (dtype, meaning). One row per frame the worker was tracked
#: in, ascending time. Scores are nullable integers: <NA> where the frame could not be scored.
FRAME_COLUMNS: dict[str, tuple[str, str]] = {
    "time_s": ("float64", "shift time of the frame (seconds since the session's first frame)"),
    "rula_grand": ("Int16", "RULA grand score, worse side (1-7)"),
    "rula_action_level": ("Int16", "RULA action level (1-4)"),
    "reba_score": ("Int16", "REBA score (1-15)"),
    "reba_risk_level": ("Int16", "REBA risk level (0-4)"),
    "floor_x_m": ("float64", "worker position on the floor, world x (metres; mid-hip; NaN if unknown)"),
    "floor_y_m": ("float64", "worker position on the floor, world y (metres; NaN if unknown)"),
    "reliable": ("bool", "the skeleton met the reliability rule of the diagnostics"),
}
_SCORE_COLUMNS = ("rula_grand", "rula_action_level", "reba_score", "reba_risk_level")


@dataclass(frozen=True)
class SessionResults:
    """A session's stored results: the session record and each worker's results in report order."""

    session: SessionInfo
    workers: tuple[WorkerResults, ...]


def results_dir(report_dir: str | os.PathLike[str]) -> Path:
    """The results folder of a report folder."""
    return Path(report_dir) / RESULTS_DIR


# --------------------------------------------------------------------------------- writing


def _dump(kind: str, record: Any) -> str:
    return (
        json.dumps(
            {"format": RESULTS_FORMAT, "kind": kind, "data": to_jsonable(record)},
            indent=1,
            ensure_ascii=False,
            allow_nan=False,
        )
        + "\n"
    )


def frames_table(
    time_s: np.ndarray,
    *,
    rula_grand: np.ndarray,
    rula_action_level: np.ndarray,
    reba_score: np.ndarray,
    reba_risk_level: np.ndarray,
    floor_x_m: np.ndarray,
    floor_y_m: np.ndarray,
    reliable: np.ndarray,
) -> pd.DataFrame:
    """A per-frame table with FRAME_COLUMNS from arrays (scores as floats with NaN = missing, or
    nullable integers); checks lengths and that time ascends."""
    cols = dict(
        time_s=time_s,
        rula_grand=rula_grand,
        rula_action_level=rula_action_level,
        reba_score=reba_score,
        reba_risk_level=reba_risk_level,
        floor_x_m=floor_x_m,
        floor_y_m=floor_y_m,
        reliable=reliable,
    )
    n = len(time_s)
    data = {}
    for name, values in cols.items():
        if len(values) != n:
            raise ValueError(f"{name} has {len(values)} rows, time_s has {n}")
        dtype = FRAME_COLUMNS[name][0]
        if dtype == "Int16":
            s = pd.Series(values)
            data[name] = s.astype("Float64").round().astype("Int16") if s.dtype.kind == "f" else s.astype("Int16")
        else:
            data[name] = np.asarray(values, dtype=dtype)
    frame = pd.DataFrame(data)
    if n and np.any(np.diff(frame["time_s"].to_numpy()) <= 0):
        raise ValueError("time_s must be strictly ascending")
    return frame


def save_results(
    report_dir: str | os.PathLike[str],
    session: SessionInfo,
    workers: Sequence[tuple[WorkerSummary, WorkerDiagnostics, pd.DataFrame]],
) -> Path:
    """Write ``<report_dir>/results`` (replacing an earlier one only when complete); return it.

    workers: per worker of ``session.workers`` (same order): summary, diagnostics and per-frame
    table (FRAME_COLUMNS; build it with :func:`frames_table`).
    """
    if len(workers) != len(session.workers):
        raise ValueError(f"{len(workers)} worker results for {len(session.workers)} workers")
    final = results_dir(report_dir)
    with atomic_dir(final) as tmp:
        (tmp / SESSION_FILE).write_text(_dump("session", session), encoding="utf-8")
        for info, (summary, diagnostics, frames) in zip(session.workers, workers):
            check_worker(info, summary, diagnostics, source=str(final))
            _check_frames(frames, source=f"frames of worker {info.worker_id}")
            wdir = tmp / WORKERS_DIR / info.worker_id
            wdir.mkdir(parents=True)
            (wdir / SUMMARY_FILE).write_text(_dump("summary", summary), encoding="utf-8")
            (wdir / DIAGNOSTICS_FILE).write_text(_dump("diagnostics", diagnostics), encoding="utf-8")
            frames.loc[:, list(FRAME_COLUMNS)].to_parquet(wdir / FRAMES_FILE, index=False)
        for p in (tmp, *tmp.rglob("*")):
            readable(p)
    return final


def session_results(
    session: SessionInfo, workers: Sequence[tuple[WorkerSummary, WorkerDiagnostics, pd.DataFrame]]
) -> SessionResults:
    """The results :func:`save_results` stores, as :func:`load_results` would read them back, built
    in memory: the records pass through the same JSON conversion (numpy scalars become Python
    numbers, tuples stay tuples), the per-frame tables keep FRAME_COLUMNS with nullable-integer
    scores; checked as when saving. The assessment renders its report from these."""
    if len(workers) != len(session.workers):
        raise ValueError(f"{len(workers)} worker results for {len(session.workers)} workers")
    info = from_jsonable(SessionInfo, to_jsonable(session), source="session")
    out = []
    for winfo, (summary, diagnostics, frames) in zip(info.workers, workers):
        where = f"worker {winfo.worker_id}"
        summary = from_jsonable(WorkerSummary, to_jsonable(summary), source=where)
        diagnostics = from_jsonable(WorkerDiagnostics, to_jsonable(diagnostics), source=where)
        check_worker(winfo, summary, diagnostics, source=where)
        _check_frames(frames, source=f"frames of {where}")
        table = frames.loc[:, list(FRAME_COLUMNS)].reset_index(drop=True)
        for c in _SCORE_COLUMNS:
            if table[c].dtype != "Int16":
                table[c] = table[c].astype("Int16")
        out.append(WorkerResults(info=winfo, summary=summary, diagnostics=diagnostics, frames=table))
    return SessionResults(session=info, workers=tuple(out))


# --------------------------------------------------------------------------------- reading


def _load_json(path: Path, kind: str, tp: type) -> Any:
    try:
        raw = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(
            "missing from the stored results; run 'ergopose assess' on the session again", path=path
        ) from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"cannot read the stored results ({exc})", path=path) from None
    if not isinstance(raw, dict) or raw.get("format") != RESULTS_FORMAT:
        got = raw.get("format") if isinstance(raw, dict) else None
        raise InputError(f"not ergopose results of format {RESULTS_FORMAT} (found {got!r})", path=path, field="format")
    if raw.get("kind") != kind:
        raise InputError(f"expected kind {kind!r}, found {raw.get('kind')!r}", path=path, field="kind")
    return from_jsonable(tp, raw.get("data"), source=str(path))


def _check_frames(frames: pd.DataFrame, source: str) -> None:
    missing = [c for c in FRAME_COLUMNS if c not in frames.columns]
    if missing:
        raise InputError(f"missing column(s) {', '.join(missing)}", path=source)
    t = frames["time_s"].to_numpy(dtype=np.float64)
    if t.size and (not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0)):
        raise InputError("time_s must be finite and strictly ascending", path=source, field="time_s")


def load_frames(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read a frames.parquet (only FRAME_COLUMNS), checked."""
    path = Path(path)
    if not path.is_file():
        raise InputError("missing from the stored results; run 'ergopose assess' on the session again", path=path)
    try:
        frames = pd.read_parquet(path, columns=list(FRAME_COLUMNS))
    except Exception as exc:  # pyarrow raises several kinds for unreadable or incomplete files
        raise InputError(f"cannot read the per-frame table ({type(exc).__name__}: {exc})", path=path) from None
    _check_frames(frames, source=str(path))
    for c in _SCORE_COLUMNS:
        if frames[c].dtype != "Int16":
            frames[c] = frames[c].astype("Int16")
    return frames


def load_results(report_dir: str | os.PathLike[str]) -> SessionResults:
    """Read ``<report_dir>/results`` (or ``report_dir`` itself if it is a results folder)."""
    base = Path(report_dir)
    rdir = base if (base / SESSION_FILE).is_file() else results_dir(base)
    if not (rdir / SESSION_FILE).is_file():
        raise InputError(
            f"no stored results here (expected {RESULTS_DIR}/{SESSION_FILE}); "
            "run 'ergopose assess' on the session first",
            path=base,
        )
    session = _load_json(rdir / SESSION_FILE, "session", SessionInfo)
    workers = []
    for info in session.workers:
        wdir = rdir / WORKERS_DIR / info.worker_id
        summary = _load_json(wdir / SUMMARY_FILE, "summary", WorkerSummary)
        diagnostics = _load_json(wdir / DIAGNOSTICS_FILE, "diagnostics", WorkerDiagnostics)
        check_worker(info, summary, diagnostics, source=str(wdir))
        frames = load_frames(wdir / FRAMES_FILE)
        workers.append(WorkerResults(info=info, summary=summary, diagnostics=diagnostics, frames=frames))
    return SessionResults(session=session, workers=tuple(workers))


def session_from_mapping(data: Mapping[str, Any], source: str = "session") -> SessionInfo:
    """A SessionInfo from plain JSON-like data (as in session.json's "data")."""
    info: SessionInfo = from_jsonable(SessionInfo, dict(data), source=source)
    return info


__all__ = [
    "RESULTS_FORMAT",
    "FRAME_COLUMNS",
    "SessionResults",
    "save_results",
    "session_results",
    "load_results",
    "load_frames",
    "frames_table",
    "results_dir",
    "session_from_mapping",
]
