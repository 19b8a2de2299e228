"""The stages of an assessment after the 2D work: tracking, scoring, CSV files and the report.

Each function takes what the previous one produced and the session; :mod:`ergopose.pipeline.
assess` calls them in order. Nothing here looks at video.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as dt
import functools
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from ergopose import __version__
from ergopose.atomic import atomic_path
from ergopose.calibration import check
from ergopose.ergonomics import task_inputs as T
from ergopose.ergonomics import uncertainty as U
from ergopose.ergonomics.aggregate import ShiftAccumulator, aggregate_shift
from ergopose.ergonomics.angles import AngleSettings, joint_angles
from ergopose.ergonomics.export import (FRAMES_SUFFIX, SUMMARY_SUFFIX, FramesCsvWriter, StepsCsvWriter, steps_path,
                                        write_session_summary_csv, write_worker_summary_csv)
from ergopose.ergonomics.scoring import BODY_PART_COLUMNS, score_posture
from ergopose.ergonomics.settings import from_mapping
from ergopose.errors import ConfigError, InputError
from ergopose.keypoints import JOINT_INDEX
from ergopose.pipeline.names import (NAMES_FILE, load_names, merge_rows, resolve_naming, tracker_number,
                                     unused_message, unused_task_inputs)
from ergopose.pipeline.scoring import ShiftReferences, WorkerScorer, _take, block_sizes
from ergopose.pipeline.guard import fingerprint_of
from ergopose.pipeline.skipped import SKIPPED_CSV, skipped_in_store, skipped_records, write_skipped_csv
from ergopose.pipeline.store import ResultStore, file_fingerprint
from ergopose.pipeline.window import Window, describe
from ergopose.pose.models import BLAZEPOSE_DETECTOR, ensure_model, landmark_card, model_card
from ergopose.progress import ProgressCallback, report, warn
from ergopose.recon.pipeline import ShiftReconstruction
from ergopose.recon.session import worker_summary
from ergopose.recon.settings import ReconSettings
from ergopose.recon.settings import from_mapping as recon_from_mapping
from ergopose.recon.table import TracksWriter, read_metadata, table_to_frames
from ergopose.recon.tracking import identity_name
from ergopose.report import adapters, periods
from ergopose.report.adapters import floor_plan_from_boxes, load_floor_plan
from ergopose.report.context import Assumption, DataFile, SessionInfo
from ergopose.report.quality import reliable_frames, reliable_rule
from ergopose.report.render import render_report
from ergopose.report.results import frames_table, save_results, session_results
from ergopose.session import Session

#: Runs calls (each returning a list) somewhere, e.g. on a cluster, and returns their results in order.
RunEach = Callable[[list], list]

_HIPS = [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]
CSV_DIR = "csv"
SESSION_CSV = "session_summary.csv"


@dataclass(frozen=True)
class WorkerOutput:
    """One worker's results: id, shown name, the shift summary (ergopose.ergonomics.aggregate.
    ShiftSummary: tracked time, time at each level, the split by confidence with causes) and the
    CSV files written."""

    worker_id: str
    name: str
    summary: Any
    csv_files: tuple[Path, ...]

    @property
    def observed_s(self) -> float:
        return float(self.summary.observed_s)


# ----------------------------------------------------------------------------------- inputs


def scoring_settings(session: Session):
    """The scoring settings of the session's [scoring] table (defaults where not given)."""
    return from_mapping(dict(session.scoring), source=session.settings_path)


@dataclass(frozen=True)
class ModelUse:
    """A pose model used by the run: its card and the SHA-256 verified before use."""

    card: Any
    sha256: str
    path: Path


def ensure_models(model_dir: str | None, progress: ProgressCallback | None,
                  model: str | None = None) -> tuple[ModelUse, ...]:
    """The BlazePose detector and the landmark model ``model`` (lite, full, heavy; None: the
    default) in the cache (fetched with a progress bar on first use), verified."""
    out = []
    names = (BLAZEPOSE_DETECTOR, landmark_card(model).name)
    for k, name in enumerate(names):
        report(progress, "models", k, len(names), unit="model", message=name)
        path = ensure_model(name, progress, model_dir=model_dir)
        card = model_card(name)
        out.append(ModelUse(card=card, sha256=card.file.sha256, path=Path(path)))
    report(progress, "models", len(names), len(names), unit="model")
    return tuple(out)


def fingerprint_inputs(session: Session, job, chunk_frames: int, models: Sequence[ModelUse]) -> dict[str, Any]:
    """What the stored chunks depend on: videos, calibration, 2D and 3D settings, models, version.

    Task factors, worker names and scoring settings are not part of it: changing them re-runs
    only the stages after the 2D work.
    """
    return {
        "ergopose": __version__,
        "videos": [file_fingerprint(c.video_path) for c in session.cameras],
        "calibration": file_fingerprint(session.calibration_path),
        "cameras": list(session.camera_names),
        "fps": session.fps,
        "frames": session.frame_count,
        "chunk_frames": int(chunk_frames),
        "pose_settings": repr(job.pose),
        "recon_settings": repr(job.recon),
        "models": [m.sha256 for m in models],
    }


# --------------------------------------------------------------------------------- tracking


@dataclass(frozen=True)
class Tracks:
    """The reconstructed workers of a session: the tracks table (Parquet, read back in pieces),
    the per-worker summary stored in it, and the whole-shift references scoring needs
    (:class:`ergopose.pipeline.scoring.ShiftReferences`). Nothing per frame stays in memory."""

    path: Path
    worker_summary: dict
    references: Any  # ShiftReferences
    workers: tuple[int, ...]
    rows: int
    #: tracker numbers scored as one worker: {member: the group's first member}
    #: (ergopose.pipeline.names.Naming.groups); ``workers`` then holds the groups' first members
    groups: dict = dataclasses.field(default_factory=dict)
    #: the part of the day assessed (``ergopose assess --start/--end``; stored in the table's
    #: metadata): scoring keeps the frames within it; None = every frame of the table
    window: Window | None = None


def track_session(session: Session, store, ranges: Sequence[tuple[int, int]], recon,
                  progress: ProgressCallback | None, window: Window | None = None) -> Tracks:
    """Stored chunks, in frame order -> identities, smoothing, the tracks table (Parquet).

    ranges: consecutive chunks (all of the session, or those around ``window``: the part of the
    day assessed, stored in the table's metadata for the scoring)."""
    shift = ShiftReconstruction(recon, fps=session.fps, cameras=session.calibrated_cameras,
                                first_frame=ranges[0][0] if ranges else 0)
    refs = ShiftReferences(recon)
    with TracksWriter(store.tracks_path, fps=session.fps, cameras=session.camera_names,
                      settings=recon.as_dict()) as writer:
        if window is not None:
            writer.meta["window"] = window.as_dict()
        for k, (start, stop) in enumerate(ranges):
            chunk = store.load_chunk(start, stop)
            if chunk is None:
                raise InputError(f"the stored chunk of frames {start}-{stop - 1} is missing or unreadable; "
                                 "run the assessment again", path=store.chunk_path(start))
            part = shift.push(chunk.people, start, stop)
            writer.write(part)
            refs.add(part)
            report(progress, "tracking", k + 1, len(ranges) + 1, unit="chunk")
        part = shift.finish()
        writer.write(part)
        refs.add(part)
        summary = worker_summary(shift)
        writer.set_workers(summary)
        rows = writer.rows
    report(progress, "tracking", len(ranges) + 1, len(ranges) + 1, unit="chunk")
    return Tracks(path=store.tracks_path, worker_summary=summary, references=refs,
                  workers=tuple(refs.limbs.workers()), rows=rows, window=window)


def stored_tracks(path: Path, groups: dict | None = None, progress: ProgressCallback | None = None) -> Tracks:
    """The Tracks of a stored tracks table (the tracking stage's output) without the video work: the
    whole-shift references are gathered again in one pass over the table, with the tracker numbers
    of ``groups`` merged (:func:`ergopose.pipeline.names.merge_rows`)."""
    meta = read_metadata(path)
    try:
        recon = recon_from_mapping(meta.get("settings") or {}, source=path)
    except (ConfigError, TypeError, ValueError):
        recon = ReconSettings()
    groups = dict(groups or {})
    refs = ShiftReferences(recon)
    rows = 0
    for part in read_track_parts(path):
        refs.add(merge_rows(part, groups))
        rows += len(part)
    return Tracks(path=Path(path), worker_summary=dict(meta.get("workers") or {}), references=refs,
                  workers=tuple(refs.limbs.workers()), rows=rows, groups=groups,
                  window=Window.from_dict(meta.get("window")))


def regroup(tracks: Tracks, groups: dict) -> Tracks:
    """``tracks`` with the tracker numbers of ``groups`` scored as one worker (the same object when
    there is nothing to merge)."""
    if groups == tracks.groups:
        return tracks
    return dataclasses.replace(stored_tracks(tracks.path, groups), worker_summary=tracks.worker_summary,
                               window=tracks.window)


def read_track_parts(path: Path):
    """The tracks table again, piece by piece in frame order: TrackFrames of whole frames (all
    joints of every worker in a frame), one row group at a time."""
    f = pq.ParquetFile(path)
    carry = None
    for g in range(f.num_row_groups):
        table = f.read_row_group(g)
        if carry is not None:
            table = pa.concat_tables([carry, table])
        frames = table.column("frame").to_numpy()
        if not len(frames):
            continue
        last = frames[-1]
        cut = int(np.searchsorted(frames, last, side="left"))  # the last frame may go on in the next group
        carry = table.slice(cut)
        if cut:
            yield table_to_frames(table.slice(0, cut).to_pandas())
    if carry is not None and carry.num_rows:
        yield table_to_frames(carry.to_pandas())


# ---------------------------------------------------------------------------------- scoring


@dataclass(frozen=True)
class ScoredWorker:
    """One worker after scoring: id, per-frame table (posture in radians + every score column),
    the shift summary, the limb-length diagnostics, and per-frame reliability."""

    worker_id: str
    frames: pd.DataFrame
    summary: Any  # ShiftSummary
    diagnostics: Any  # WorkerLimbDiagnostics
    reliable: np.ndarray
    points_world: np.ndarray  # (n, 33, 3)


def score_rows(session: Session, rows, worker_id: str, scoring,
               shoulder_reference_m: float | None = None) -> pd.DataFrame:
    """One worker's consecutive rows -> joint angles, the task factors of the settings, RULA and
    REBA: one row per row of ``rows`` (worker, frame, posture in radians, every score column, and
    ``inputs_from_settings``).

    Where a wrist angle cannot be seen (NaN, or the hand points all placed by the body model:
    ``rows.inferred``; rows without it count as seen) and the settings give the task's wrist
    posture for the worker and time, the settings' value is scored instead
    (:mod:`ergopose.ergonomics.task_inputs`).

    shoulder_reference_m: the reference of shoulder elevation (the median shoulder height along
    the trunk over the worker's whole shift, :class:`ergopose.pipeline.scoring.ShiftReferences`);
    None takes the median over ``rows``.
    """
    ref = shoulder_reference_m
    settings = AngleSettings(trunk_length_m=float(ref)) if ref is not None and np.isfinite(ref) and ref > 0 else None
    angles = joint_angles(rows.points_world, rows.time_s, settings)
    posture = angles.to_frame().reset_index(drop=True)
    task = session.task_angles(worker_id, rows.time_s)
    use = T.settings_use(T.hidden_inputs(posture, getattr(rows, "inferred", None)), task)
    posture = T.apply_settings(posture, use, task)
    factors = session.factor_table(worker_id, rows.time_s)
    posture = pd.concat([posture, factors.drop(columns=[c for c in factors.columns if c in posture.columns])],
                        axis=1)
    scores = score_posture(posture, settings=scoring, with_events=True)
    ident = pd.DataFrame({"worker": worker_id, "frame": np.asarray(rows.frame, dtype=np.int64)})
    spread = score_uncertainty(rows, posture, scores, factors, settings, scoring, task_use=(use, task))
    return pd.concat([ident, posture, scores, spread, T.inputs_column(use, len(posture)).to_frame()], axis=1)


def score_uncertainty(rows, posture: pd.DataFrame, scores: pd.DataFrame, factors: pd.DataFrame,
                      angle_settings, scoring, task_use: tuple[dict, pd.DataFrame] | None = None) -> pd.DataFrame:
    """Angle deviations, score probabilities and ranges, confidence and its cause per frame
    (:mod:`ergopose.ergonomics.uncertainty`): the joints resampled within the reconstruction's
    deviations and scored again with the same task inputs.

    task_use: (inputs used from the settings, Session.task_angles) as in :func:`score_rows`: every
    draw gets the settings' value in those inputs, so they add no spread."""
    n = len(rows)
    draws_world = U.sample_points(rows.points_world, rows.std_world, rows.frame)
    extra = factors.drop(columns=[c for c in factors.columns if c in posture.columns])
    angle_draws, rula, reba = [], [], []
    for pts in draws_world:
        a = joint_angles(pts, rows.time_s, angle_settings).to_frame().reset_index(drop=True)
        if task_use is not None:
            a = T.apply_settings(a, *task_use)
        angle_draws.append(a)
        s = score_posture(pd.concat([a, extra], axis=1), settings=scoring)
        rula.append(s["rula_grand"])
        reba.append(s["reba_score"])
    out = U.angle_sd(posture, angle_draws)
    for name, reported, draws in (("rula_grand", scores["rula_grand"], rula), ("reba_score", scores["reba_score"], reba)):
        p, low, high = U.score_spread(reported, draws)
        out[f"{name}_p"] = np.round(p, 4)
        out[f"{name}_low"] = pd.array(np.where(np.isfinite(low), low, np.nan), dtype="Float64").round().astype("Int16")
        out[f"{name}_high"] = pd.array(np.where(np.isfinite(high), high, np.nan), dtype="Float64").round().astype("Int16")
    seen = rows.views.max(axis=1) if n else np.zeros(0, np.int8)
    conf, cause = U.frame_confidence(out["rula_grand_p"].to_numpy(np.float64), out["reba_score_p"].to_numpy(np.float64),
                                     rows.views, getattr(rows, "inferred", None), seen)
    out["confidence"] = pd.array(conf, dtype="string")
    out["cause"] = pd.array(cause, dtype="string")
    return out


def score_worker(session: Session, rows, worker_id: str, scoring, diagnostics) -> ScoredWorker:
    """A worker's rows scored in one piece (:func:`score_rows`) and the shift summary; for
    evaluations of short sessions. ``ergopose assess`` scores in blocks (:func:`score_tracks`)."""
    frames = score_rows(session, rows, worker_id, scoring)
    summary = aggregate_shift(frames, worker_id, settings=scoring, frame_period_s=1.0 / session.fps,
                              inferred=getattr(rows, "inferred", None))
    return ScoredWorker(worker_id=worker_id, frames=frames, summary=summary, diagnostics=diagnostics,
                        reliable=reliable_frames(rows.points_world), points_world=rows.points_world)


# ----------------------------------------------------------------------------------- output

SCORED_DIR = "scored"


@dataclass(frozen=True)
class Outputs:
    index_html: Path
    session_csv: Path
    workers: tuple


class _WorkerSink:
    """Where one worker's scored blocks go: the frames CSV, the scored-frames Parquet file (read
    back for the report's worst moments), the shift aggregation and the report's timeline
    (eight numbers per frame, the only per-frame data kept in memory)."""

    def __init__(self, stack, worker_id: str, csv_path: Path, scored_path: Path, scoring, fps: float,
                 limb_medians_m: np.ndarray, *, recorded_at: dt.datetime | None = None, name: str | None = None,
                 bom: bool = False) -> None:
        self.worker_id = worker_id
        csv_path = Path(csv_path)
        self.csv = stack.enter_context(FramesCsvWriter(csv_path, recorded_at=recorded_at, name=name, bom=bom,
                                                       parquet=csv_path.with_suffix(".parquet")))
        self.steps = stack.enter_context(StepsCsvWriter(steps_path(csv_path), bom=bom))
        self.scored_path = scored_path
        self._scored_tmp = stack.enter_context(atomic_path(scored_path))
        self._stack = stack
        self._parquet = None
        self._schema = None
        self.acc = ShiftAccumulator(worker_id, settings=scoring, frame_period_s=1.0 / fps)
        self.medians = limb_medians_m
        self.timeline: dict[str, list[np.ndarray]] = {k: [] for k in (
            "time_s", "frame", "rula_grand", "rula_action_level", "reba_score", "reba_risk_level", "floor_x_m",
            "floor_y_m", "reliable")}

    def write(self, frames: pd.DataFrame, rows) -> None:
        self.csv.write(frames)
        self.steps.write(frames)
        self.acc.add(frames, getattr(rows, "inferred", None))
        if self._schema is None:
            self._schema = pa.Schema.from_pandas(frames, preserve_index=False)
            self._parquet = self._stack.enter_context(pq.ParquetWriter(self._scored_tmp, self._schema,
                                                                       compression="zstd"))
        self._parquet.write_table(pa.Table.from_pandas(frames, schema=self._schema, preserve_index=False))
        mid_hip = rows.points_world[:, _HIPS, :].mean(axis=1)  # NaN unless both hips are known
        tl = self.timeline
        # copies: a view of a column would keep the block's whole table of scores alive
        tl["time_s"].append(frames["time_s"].to_numpy(np.float64, copy=True))
        tl["frame"].append(frames["frame"].to_numpy(np.int64, copy=True))
        for c in ("rula_grand", "rula_action_level", "reba_score", "reba_risk_level"):
            tl[c].append(frames[c].to_numpy(np.float32, na_value=np.nan))
        tl["floor_x_m"].append(mid_hip[:, 0].astype(np.float32))
        tl["floor_y_m"].append(mid_hip[:, 1].astype(np.float32))
        tl["reliable"].append(reliable_frames(rows.points_world, limb_medians_m=self.medians))

    def column(self, name: str) -> np.ndarray:
        parts = self.timeline[name]
        return np.concatenate(parts) if parts else np.zeros(0)


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


def _within(tracks: Tracks, fps: float) -> Tracks:
    """``tracks`` with only the workers that have a row within its window."""
    first, stop = tracks.window.frame_range(fps)
    table = pq.read_table(tracks.path, columns=["worker"], filters=[("frame", ">=", first), ("frame", "<", stop)])
    present = {tracker_number(str(w)) for w in pc.unique(table.column("worker")).to_pylist()}
    keep = tuple(w for w in tracks.workers if w in present or any(g == w for m, g in tracks.groups.items()
                                                                   if m in present))
    return dataclasses.replace(tracks, workers=keep)


def score_tracks(session: Session, tracks: Tracks, out_dir: Path, scoring, ident,
                 progress: ProgressCallback | None, run_each: RunEach | None = None, *,
                 bom: bool = False) -> list[ReportWorker]:
    """Every tracked worker scored in blocks (:class:`ergopose.pipeline.scoring.WorkerScorer`)
    from one pass over the tracks table: the per-frame CSV files are written as it goes; returns
    what the report needs.

    run_each: runs a list of calls, each returning a list, and returns their results in order
    (e.g. as tasks on a Dask cluster, ergopose.pipeline.cluster); given, each worker is scored by a
    call of its own (its own pass over the table; the same bytes, as no worker's scores depend
    on another's)."""
    if run_each is not None and len(tracks.workers) > 1:
        calls = [functools.partial(score_tracks, session, dataclasses.replace(tracks, workers=(w,)), out_dir,
                                   scoring, ident, None) for w in tracks.workers]
        report(progress, "scoring", 0, len(calls), unit="worker")
        out = [r for part in run_each(calls) for r in part]
        report(progress, "scoring", len(calls), len(calls), unit="worker")
        return out
    block, context = block_sizes(scoring, session.fps)
    diagnostics = {d.worker: d for d in tracks.references.limbs.result()}
    csv_dir = out_dir / CSV_DIR
    scored_dir = out_dir / "pipeline" / SCORED_DIR
    total = max(int(session.frame_count), 1)
    sinks: dict[int, _WorkerSink] = {}
    with contextlib.ExitStack() as stack:
        scorers = {}
        for w in tracks.workers:
            tracked = identity_name(w)
            wid = ident.rename(tracked)
            ref = tracks.references.shoulder_reference_m(w)
            sink = _WorkerSink(stack, wid, csv_dir / f"{wid}{FRAMES_SUFFIX}", scored_dir / f"{tracked}.parquet",
                               scoring, session.fps, tracks.references.limb_medians_m(w),
                               recorded_at=session.recorded_at, name=session.display_name(wid), bom=bom)
            sinks[w] = sink

            def score(rows, wid=wid, ref=ref):
                return score_rows(session, rows, wid, scoring, ref)

            scorers[w] = WorkerScorer(score, sink, block, context)
        report(progress, "scoring", 0, total, unit="frame")
        if tracks.workers:
            for part in read_track_parts(tracks.path):
                part = merge_rows(part, tracks.groups)
                if tracks.window is not None:
                    part = _take(part, tracks.window.mask(part.frame, session.fps))
                    if not len(part):
                        continue
                for w in np.unique(part.worker):
                    if int(w) in scorers:  # all of them, unless scoring one worker (run_each)
                        scorers[int(w)].add(part.worker_rows(int(w)))
                frontier = int(part.frame[-1])  # frames before the last one of a part are complete
                for sc in scorers.values():
                    sc.advance(frontier)
                report(progress, "scoring", min(frontier, total), total, unit="frame")
        for sc in scorers.values():
            sc.finish()
    report(progress, "scoring", total, total, unit="frame")

    out = []
    for w, sink in sinks.items():
        tracked = identity_name(w)
        summary = sink.acc.result()
        rows, drawn = _period_frames(sink, summary)
        # the diagnostics under the reported id (a stature match or names.toml renames the tracked id)
        diag = dataclasses.replace(diagnostics[tracked], worker=sink.worker_id)
        out.append(ReportWorker(worker_id=sink.worker_id, summary=summary, diagnostics=diag,
                                timeline=_timeline(sink), period_frames=rows,
                                joints_at=_joints_at(tracks.path, _members(tracks, w), drawn),
                                reliable_frames=int(sink.column("reliable").sum())))
    return out


def _timeline(sink: _WorkerSink) -> pd.DataFrame:
    c = sink.column
    return frames_table(c("time_s"), rula_grand=c("rula_grand"), rula_action_level=c("rula_action_level"),
                        reba_score=c("reba_score"), reba_risk_level=c("reba_risk_level"),
                        floor_x_m=c("floor_x_m").astype(np.float64), floor_y_m=c("floor_y_m").astype(np.float64),
                        reliable=c("reliable").astype(bool))


#: Columns of the scored frames the report reads for the sustained periods.
_PERIOD_COLUMNS = ("time_s", "frame", "rula_grand", "rula_action_level", "reba_score", "reba_risk_level",
                   *BODY_PART_COLUMNS["rula"], *periods.INPUT_COLUMNS)


def _period_frames(sink: _WorkerSink, summary) -> tuple[pd.DataFrame, np.ndarray]:
    """The scored frames of the worker's sustained periods of high risk (ergopose.report.periods,
    found on every frame of the timeline; read back from the scored-frames file, only the columns
    the report reads) and the frame numbers drawn for them: the periods are then described as from
    every frame."""
    c = sink.column
    found = periods.worker_periods(c("time_s"), c("rula_grand"), c("rula_action_level"), c("reba_score"),
                                   c("reba_risk_level"), float(summary.frame_period_s))
    if not found or not sink.scored_path.exists():
        return pd.DataFrame(), np.zeros(0, dtype=np.int64)
    frame = c("frame").astype(np.int64)
    wanted = np.unique(np.concatenate([frame[p.start:p.stop] for p in found]))
    table = _rows_of_frames(pq.ParquetFile(sink.scored_path), wanted).to_pandas()
    table = table.loc[:, [k for k in _PERIOD_COLUMNS if k in table.columns]]
    table = table.sort_values("time_s", kind="stable").reset_index(drop=True)
    return table, np.sort(frame[[p.drawn for p in found]])


def _rows_of_frames(f, frames: np.ndarray, where: tuple[str, Sequence[str]] | None = None):
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


def _joints_at(tracks_path: Path, tracked: tuple[str, ...], frames: np.ndarray):
    """callable(seconds) -> (33, 3) joints (metres) at the nearest of ``frames`` (ascending frame
    numbers), from the tracks table (the rows of the tracked ids ``tracked``, merged as for scoring)."""
    if not len(frames):
        return None
    tf = table_to_frames(_rows_of_frames(pq.ParquetFile(tracks_path), np.asarray(frames, dtype=np.int64),
                                         ("worker", tracked)).to_pandas())
    tf = merge_rows(tf, {tracker_number(t): tracker_number(tracked[0]) for t in tracked[1:]} if len(tracked) > 1
                    else {})
    times, points = tf.time_s, tf.points_world

    def joints_at(t: float):
        if not len(times):
            return None
        i = int(np.argmin(np.abs(times - t)))
        return points[i]

    return joints_at


def score_and_report(session: Session, tracks: Tracks, out_dir: Path, scoring, models: Sequence[ModelUse], recon,
                     progress: ProgressCallback | None, run_each: RunEach | None = None, *, bom: bool = False,
                     window: Window | None = None, store_dir: Path | None = None) -> Outputs:
    """Score every tracked worker, write the CSV files, the stored results and the HTML report.

    Who is who: the session's names.toml, then the stature match, then the tracker's pseudonym
    (:mod:`ergopose.pipeline.names`); settings ids whose task inputs reach nobody are named in a
    warning and in the report. Everything is written to a folder beside the outputs and swapped
    into place when complete (:func:`swap_outputs`): a failure leaves the earlier outputs whole.

    bom: CSV files with a UTF-8 byte order mark (Excel). window: score only the frames of this part
    of the day (default: the tracks' own window, ``ergopose assess --start/--end``; else all);
    only the workers tracked within it are reported. store_dir: the folder whose stored chunks name
    the skipped video frames (default ``out_dir``).
    """
    if window is not None:
        tracks = dataclasses.replace(tracks, window=window)
    measured = {name: info.get("stature_estimate_m") for name, info in tracks.worker_summary.items()}
    tracked = [identity_name(w) for w in sorted(set(tracks.workers) | set(tracks.groups))]
    given = load_names(session.path)
    stale = [t for t in given if t not in tracked]
    if stale:
        warn(progress, f"{NAMES_FILE}: {', '.join(stale)} {'is' if len(stale) == 1 else 'are'} not a tracked id of "
                       f"these results (tracked: {', '.join(tracked) or 'nobody'}); the name is not used; check "
                       f"with 'ergopose workers --session {session.path}'")
    naming = resolve_naming(session, tracked, given, measured)
    tracks = regroup(tracks, naming.groups())
    if tracks.window is not None:
        tracks = _within(tracks, session.fps)
    session = naming.session(session)
    unused = unused_task_inputs(session, sorted(naming.members))
    if unused:
        warn(progress, unused_message(session, unused, tracked_ids=tracked))
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".outputs.", suffix=".tmp", dir=out_dir))
    try:
        scored = score_tracks(session, tracks, stage, scoring, naming, progress, run_each, bom=bom)
        csv_dir = stage / CSV_DIR
        csv_dir.mkdir(parents=True, exist_ok=True)
        csv_files: dict[str, list[tuple[str, str]]] = {}
        outputs = []
        for s in scored:
            frames_csv = out_dir / CSV_DIR / f"{s.worker_id}{FRAMES_SUFFIX}"
            summary_csv = write_worker_summary_csv(csv_dir / f"{s.worker_id}{SUMMARY_SUFFIX}", s.summary, bom=bom)
            csv_files[s.worker_id] = [("Angles and scores per frame, with clock time and confidence (CSV)",
                                       f"{CSV_DIR}/{frames_csv.name}"),
                                      ("Every RULA/REBA step per frame (CSV)", f"{CSV_DIR}/{steps_path(frames_csv).name}"),
                                      ("Shift summary (CSV)", f"{CSV_DIR}/{summary_csv.name}")]
            outputs.append(WorkerOutput(worker_id=s.worker_id, name=session.display_name(s.worker_id),
                                        summary=s.summary,
                                        csv_files=(frames_csv, frames_csv.with_suffix(".parquet"), steps_path(frames_csv),
                                                   out_dir / CSV_DIR / summary_csv.name)))
        write_session_summary_csv(csv_dir / SESSION_CSV, {s.worker_id: s.summary for s in scored},
                                  names={s.worker_id: session.display_name(s.worker_id) for s in scored},
                                  recorded_at=session.recorded_at, bom=bom)
        skipped = _skipped_frames(session, Path(store_dir) if store_dir is not None else out_dir, stage, bom=bom,
                                  window=tracks.window)
        index = write_report(session, scored, stage, scoring, models, csv_files, naming, progress, skipped,
                             unused=unused, window=tracks.window)
        swap_outputs(stage, out_dir)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return Outputs(index_html=out_dir / index.name, session_csv=out_dir / CSV_DIR / SESSION_CSV,
                   workers=tuple(outputs))


#: What score_and_report writes, relative to the output folder: folders, then pages.
OUTPUT_DIRS = (CSV_DIR, f"pipeline/{SCORED_DIR}", "results")


def swap_outputs(stage: Path, out_dir: Path) -> None:
    """Move the complete outputs of ``stage`` (the layout of the output folder) into ``out_dir``:
    each folder of OUTPUT_DIRS replaces the earlier one whole (the earlier one is moved aside as
    ``.<name>.old`` first, so ergopose.atomic.clean_up puts it back after a crash between the two
    renames), then the pages; pages of workers no longer reported are removed."""
    for rel in OUTPUT_DIRS:
        new, final = stage / rel, out_dir / rel
        if not new.is_dir():
            new.mkdir(parents=True)
        final.parent.mkdir(parents=True, exist_ok=True)
        old = final.with_name(f".{final.name}.old")
        shutil.rmtree(old, ignore_errors=True)
        if final.exists():
            os.replace(final, old)
        os.replace(new, final)
        shutil.rmtree(old, ignore_errors=True)
    pages = {p.name for p in stage.glob("*.html")}
    for p in out_dir.glob("worker-*.html"):
        if p.name not in pages:
            p.unlink()
    for name in sorted(pages, key=lambda n: n == "index.html"):  # the index last
        os.replace(stage / name, out_dir / name)


def _skipped_frames(session: Session, out_dir: Path, write_to: Path | None = None, bom: bool = False,
                    window: Window | None = None) -> tuple:
    """csv/frames_skipped.csv (under ``write_to``, default ``out_dir``) from the stored chunks of
    ``out_dir`` (those within ``window`` when given); the report's records of them."""
    rows = skipped_in_store(ResultStore(out_dir))
    if window is not None:
        rows = rows[window.mask(rows[:, 0], session.fps)]
    write_skipped_csv((write_to or out_dir) / CSV_DIR / SKIPPED_CSV, rows, session.camera_names, session.fps, bom=bom)
    return skipped_records(rows, session.camera_names, session.fps)


def write_report(session: Session, scored: Sequence[ReportWorker], out_dir: Path, scoring,
                 models: Sequence[ModelUse], csv_files: dict, ident, progress: ProgressCallback | None,
                 skipped: tuple = (), unused: Sequence[str] = (), window: Window | None = None) -> Path:
    """Store the report results (ergopose.report.results) and render the pages.

    window: the part of the day scored (named in the report's title).

    skipped: the video frames skipped (:func:`ergopose.pipeline.skipped.skipped_records`).
    unused: settings ids whose task inputs reach no reported worker (every worker's assumptions
    say so).
    """
    worker_records = []
    for s in scored:
        summary = adapters.worker_summary(s.summary, timeline=s.timeline,
                                          frames=s.period_frames if len(s.period_frames) else None,
                                          joints_at=s.joints_at)
        diag = adapters.worker_diagnostics(s.diagnostics, frames_reliable=s.reliable_frames,
                                           reliable_rule=reliable_rule())
        worker_records.append((summary, diag, s.timeline))
    floor = _floor_plan(session)
    info = SessionInfo(
        session_id=session.path.resolve().name, title=_title(session, window), site="",
        start=session.recorded_at.isoformat() if session.recorded_at else None, fps=float(session.fps),
        frames=int(session.frame_count), duration_s=float(session.duration_s), ergopose_version=__version__,
        created=dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat(),
        models=tuple(adapters.model_info(m.card, m.sha256) for m in models), methods=adapters.methods_info(),
        settings=adapters.settings_records(scoring),
        calibration=adapters.calibration_info(session.calibration_path, session.camera_names,
                                              check=calibration_check(session)),
        floor=floor, workers=_with_identities(adapters.worker_infos(session, [s.worker_id for s in scored], csv_files),
                                              ident, session, unused),
        csv_files=(DataFile("Session summary (CSV)", f"{CSV_DIR}/{SESSION_CSV}"),
                   DataFile("Skipped video frames (CSV)", f"{CSV_DIR}/{SKIPPED_CSV}")),
        fingerprint=fingerprint_of(session), skipped_frames=tuple(skipped))
    save_results(out_dir, info, worker_records)
    files = render_report(out_dir, session_results(info, worker_records), progress=progress)
    return files.index


def _title(session: Session, window: Window | None) -> str:
    """The report's title: the session's description, and the part of the day when not all of it."""
    title = session.description or ""
    if window is None:
        return title
    part = f"part of the day: {describe(window, session.recorded_at)}"
    return f"{title} ({part})" if title else part[0].upper() + part[1:]


def calibration_check(session: Session):
    """The reference-bar check of the session's calibration (None when the settings give no bar)."""
    if session.calibration_check is None:
        return None

    spec = session.calibration_check
    labels, pixels = check.read_bar_observations(spec.observations_path, session.camera_names)
    return check.measure_bar(session.calibrated_cameras, pixels, spec.length_m, labels=labels)


def _with_identities(infos, ident, session: Session, unused: Sequence[str] = ()):
    """Each worker's assumptions, plus how the tracked person was matched to the settings' worker
    (names.toml or stature; ident: ergopose.pipeline.names.Naming or identify.Identification) and
    which settings ids' task inputs reach nobody."""
    members = getattr(ident, "members", {})
    named = getattr(ident, "named", frozenset())
    out = []
    for info in infos:
        extras = []
        m = ident.match_of(info.worker_id)
        tracked = members.get(info.worker_id, ())
        if any(t in named for t in tracked):
            extras.append(Assumption(item="who this is",
                                     value="the person tracked as " + " and ".join(tracked)
                                     + (" (scored as one worker)" if len(tracked) > 1 else ""),
                                     applies_to="the name, task factors and periods of this worker",
                                     source=f"{NAMES_FILE} (ergopose workers --name)"))
        elif m is not None:
            extras.append(Assumption(item="who this is",
                                     value=f"the person tracked as {m.tracked_id}: measured stature "
                                           f"{m.measured_m:.2f} m, given {m.given_m:.2f} m",
                                     applies_to="the name, task factors and periods of this worker",
                                     source=f"{session.settings_path.name} [workers.{m.worker_id}] stature_m"))
        elif ident.notes:
            extras.append(Assumption(item="who this is", value="not matched to a worker of the settings: "
                                     + "; ".join(ident.notes), applies_to="the defaults and periods for everyone apply",
                                     source=f"{session.settings_path.name} stature_m"))
        if unused:
            extras.append(Assumption(item="task inputs applied to nobody",
                                     value=", ".join(f"[workers.{u}]" for u in unused)
                                     + ": no tracked person has that id; name the tracked people with "
                                       "'ergopose workers --name'",
                                     applies_to="nobody (these loads, couplings and periods are not in any score)",
                                     source=session.settings_path.name))
        if extras:
            info = dataclasses.replace(info, assumptions=tuple(extras) + tuple(info.assumptions))
        out.append(info)
    return tuple(out)


def _floor_plan(session: Session):
    """The monitored area for the floor map: the session's floor.toml when it has one, else 6 x 6 m."""
    cams = [(c.name, float(c.position_world[0]), float(c.position_world[1])) for c in session.calibrated_cameras]
    if session.floor_plan_path is not None:
        return load_floor_plan(session.floor_plan_path, cameras=cams)
    return floor_plan_from_boxes([], cameras=cams)
