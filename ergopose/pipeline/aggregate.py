"""Stage *aggregate*: each scored worker's shift summary (time at each level, the split by
confidence), the timeline, the sustained periods of high risk and the joints drawn for them ->
one :class:`ReportWorker` per worker, what the publishing stage needs.

:func:`score_tracks` runs *score* then *aggregate* for every tracked worker (each worker a call
of its own when the scoring is spread, e.g. over a Dask cluster).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from ergopose.arrays import FloatArray
from ergopose.ergonomics.shift_records import ShiftSummary
from ergopose.ergonomics.scoring import BODY_PART_COLUMNS
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.pipeline.names import Naming, merge_rows, tracker_number
from ergopose.pipeline.score import RunEach, WorkerSink, score_workers
from ergopose.pipeline.track import Tracks
from ergopose.progress import ProgressCallback, report
from ergopose.recon.diagnostics import WorkerLimbDiagnostics
from ergopose.recon.table import table_to_frames
from ergopose.recon.track_records import identity_name
from ergopose.report import periods
from ergopose.report.results import frames_table
from ergopose.session import Session


@dataclass(frozen=True)
class ReportWorker:
    """What the report needs of one scored worker: id, shift summary, limb diagnostics, the
    timeline (report.results.frames_table), the scored frames of its sustained periods of high risk
    (ergopose.report.periods) and the joints of the frames drawn for them (seconds -> (33, 3)
    metres), and the count of reliable frames."""

    worker_id: str
    summary: Any
    diagnostics: Any
    timeline: pd.DataFrame
    period_frames: pd.DataFrame
    joints_at: Any
    reliable_frames: int


def score_tracks(
    session: Session,
    tracks: Tracks,
    out_dir: Path,
    scoring: ScoringSettings,
    ident: Naming,
    progress: ProgressCallback | None,
    run_each: RunEach | None = None,
    *,
    bom: bool = False,
) -> list[ReportWorker]:
    """Every tracked worker scored (:func:`ergopose.pipeline.score.score_workers`: the per-frame
    CSV files are written as it goes) and aggregated (:func:`worker_result`): what the report needs.

    run_each: runs a list of calls, each returning a list, and returns their results in order
    (e.g. as tasks on a Dask cluster, ergopose.pipeline.cluster); given, each worker is scored by a
    call of its own (its own pass over the table; the same bytes, as no worker's scores depend
    on another's)."""
    if run_each is not None and len(tracks.workers) > 1:
        calls: list[Callable[[], list[Any]]] = [
            functools.partial(
                score_tracks, session, dataclasses.replace(tracks, workers=(w,)), out_dir, scoring, ident, None
            )
            for w in tracks.workers
        ]
        report(progress, "scoring", 0, len(calls), unit="worker")
        out = [r for part in run_each(calls) for r in part]
        report(progress, "scoring", len(calls), len(calls), unit="worker")
        return out
    sinks = score_workers(session, tracks, out_dir, scoring, ident, progress, bom=bom)
    diagnostics = {d.worker: d for d in tracks.references.limbs.result()}
    return [worker_result(sink, w, tracks, diagnostics) for w, sink in sinks.items()]


def worker_result(
    sink: WorkerSink, worker: int, tracks: Tracks, diagnostics: Mapping[str, WorkerLimbDiagnostics]
) -> ReportWorker:
    """One scored worker (its sink, tracker number ``worker``) aggregated for the report:
    the shift summary, the timeline, the sustained periods and the joints drawn for them, the limb
    diagnostics under the reported id."""
    tracked = identity_name(worker)
    summary = sink.acc.result()
    rows, drawn = _period_frames(sink, summary)
    # the diagnostics under the reported id (a stature match or names.toml renames the tracked id)
    diag = dataclasses.replace(diagnostics[tracked], worker=sink.worker_id)
    return ReportWorker(
        worker_id=sink.worker_id,
        summary=summary,
        diagnostics=diag,
        timeline=_timeline(sink),
        period_frames=rows,
        joints_at=_joints_at(tracks.path, _members(tracks, worker), drawn),
        reliable_frames=int(sink.column("reliable").sum()),
    )


def _timeline(sink: WorkerSink) -> pd.DataFrame:
    c = sink.column
    return frames_table(
        c("time_s"),
        rula_grand=c("rula_grand"),
        rula_action_level=c("rula_action_level"),
        reba_score=c("reba_score"),
        reba_risk_level=c("reba_risk_level"),
        floor_x_m=c("floor_x_m").astype(np.float64),
        floor_y_m=c("floor_y_m").astype(np.float64),
        reliable=c("reliable").astype(bool),
    )


#: Columns of the scored frames the report reads for the sustained periods.
_PERIOD_COLUMNS = (
    "time_s",
    "frame",
    "rula_grand",
    "rula_action_level",
    "reba_score",
    "reba_risk_level",
    *BODY_PART_COLUMNS["rula"],
    *periods.INPUT_COLUMNS,
)


def _period_frames(sink: WorkerSink, summary: ShiftSummary) -> tuple[pd.DataFrame, np.ndarray]:
    """The scored frames of the worker's sustained periods of high risk (ergopose.report.periods,
    found on every frame of the timeline; read back from the scored-frames file, only the columns
    the report reads) and the frame numbers drawn for them: the periods are then described as from
    every frame."""
    c = sink.column
    found = periods.worker_periods(
        c("time_s"),
        c("rula_grand"),
        c("rula_action_level"),
        c("reba_score"),
        c("reba_risk_level"),
        float(summary.frame_period_s),
    )
    if not found or not sink.scored_path.exists():
        return pd.DataFrame(), np.zeros(0, dtype=np.int64)
    frame = c("frame").astype(np.int64)
    wanted = np.unique(np.concatenate([frame[p.start : p.stop] for p in found]))
    table = _rows_of_frames(pq.ParquetFile(sink.scored_path), wanted).to_pandas()
    table = table.loc[:, [k for k in _PERIOD_COLUMNS if k in table.columns]]
    table = table.sort_values("time_s", kind="stable").reset_index(drop=True)
    return table, np.sort(frame[[p.drawn for p in found]])


def _rows_of_frames(f: pq.ParquetFile, frames: np.ndarray, where: tuple[str, Sequence[str]] | None = None) -> pa.Table:
    """The rows of a Parquet file (ordered by frame) whose frame is in ``frames`` (and whose column
    where[0] is one of where[1]), reading only the row groups whose frame range holds one of them."""
    col = f.schema_arrow.get_field_index("frame")
    found = [f.schema_arrow.empty_table()]
    for g in range(f.num_row_groups):  # one row group in memory at a time
        st = f.metadata.row_group(g).column(col).statistics
        if st is not None and st.has_min_max:
            k = np.searchsorted(frames, st.min)
            if k >= len(frames) or frames[k] > st.max:
                continue
        table = f.read_row_group(g)
        mask = pc.is_in(table.column("frame"), value_set=pa.array(frames))
        if where is not None:
            mask = pc.and_(mask, pc.is_in(table.column(where[0]), value_set=pa.array(list(where[1]))))
        found.append(table.filter(mask))
    return pa.concat_tables(found)


def _members(tracks: Tracks, worker: int) -> tuple[str, ...]:
    """The tracked ids scored as ``worker`` (itself, or every member of its group)."""
    return tuple(identity_name(m) for m, g in tracks.groups.items() if g == worker) or (identity_name(worker),)


def _joints_at(
    tracks_path: Path, tracked: tuple[str, ...], frames: np.ndarray
) -> Callable[[float], np.ndarray | None] | None:
    """callable(seconds) -> (33, 3) joints (metres) at the nearest of ``frames`` (ascending frame
    numbers), from the tracks table (the rows of the tracked ids ``tracked``, merged as for scoring)."""
    if not len(frames):
        return None
    tf = table_to_frames(
        _rows_of_frames(
            pq.ParquetFile(tracks_path), np.asarray(frames, dtype=np.int64), ("worker", tracked)
        ).to_pandas()
    )
    tf = merge_rows(
        tf, {tracker_number(t): tracker_number(tracked[0]) for t in tracked[1:]} if len(tracked) > 1 else {}
    )
    times, points = tf.time_s, tf.points_world

    def joints_at(t: float) -> FloatArray | None:
        if not len(times):
            return None
        i = int(np.argmin(np.abs(times - t)))
        joints: FloatArray = points[i]
        return joints

    return joints_at
