"""Stage *score*: each tracked worker's rows of the tracks table -> joint angles, the task factors
of the settings, RULA and REBA per frame, with their uncertainty.

In: :class:`ergopose.pipeline.track.Tracks` (read back piece by piece). Out: per frame, the
``score_rows`` table, written as it goes to the worker's frames and steps CSV files and its
scored-frames Parquet file (:class:`WorkerSink`, which also gathers the shift aggregation and the
report's timeline). Scoring in blocks: :mod:`ergopose.pipeline.scoring`.
"""

from __future__ import annotations

import contextlib
import datetime as dt
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from ergopose.arrays import AnyArray
from ergopose.atomic import atomic_path
from ergopose.ergonomics import task_inputs as T
from ergopose.ergonomics import uncertainty as U
from ergopose.ergonomics.aggregate import ShiftAccumulator, aggregate_shift
from ergopose.ergonomics.angles import AngleSettings, joint_angles
from ergopose.ergonomics.export import FRAMES_SUFFIX, FramesCsvWriter, StepsCsvWriter, steps_path
from ergopose.ergonomics.scoring import score_posture
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.keypoints import JOINT_INDEX
from ergopose.pipeline.names import Naming, merge_rows
from ergopose.pipeline.scoring import WorkerScorer, block_sizes, scoring_rows, take_rows
from ergopose.pipeline.track import Tracks, read_track_parts
from ergopose.progress import ProgressCallback, report
from ergopose.recon.pipeline import TrackFrames
from ergopose.recon.track_records import identity_name
from ergopose.report.quality import reliable_frames
from ergopose.session import Session

CSV_DIR = "csv"

#: Runs calls (each returning a list) somewhere, e.g. on a cluster, and returns their results in order.
RunEach = Callable[[list[Callable[[], list[Any]]]], list[list[Any]]]

_HIPS = [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]


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


def score_rows(
    session: Session,
    rows: TrackFrames,
    worker_id: str,
    scoring: ScoringSettings,
    shoulder_reference_m: float | None = None,
) -> pd.DataFrame:
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
    posture = pd.concat([posture, factors.drop(columns=[c for c in factors.columns if c in posture.columns])], axis=1)
    scores = score_posture(posture, settings=scoring, with_events=True)
    ident = pd.DataFrame({"worker": worker_id, "frame": np.asarray(rows.frame, dtype=np.int64)})
    spread = score_uncertainty(rows, posture, scores, factors, settings, scoring, task_use=(use, task))
    return pd.concat([ident, posture, scores, spread, T.inputs_column(use, len(posture)).to_frame()], axis=1)


def score_uncertainty(
    rows: TrackFrames,
    posture: pd.DataFrame,
    scores: pd.DataFrame,
    factors: pd.DataFrame,
    angle_settings: AngleSettings | None,
    scoring: ScoringSettings,
    task_use: tuple[dict[str, AnyArray], pd.DataFrame] | None = None,
) -> pd.DataFrame:
    """Angle deviations, score probabilities and ranges, confidence and its cause per frame
    (:mod:`ergopose.ergonomics.uncertainty`): the joints resampled within the reconstruction's
    deviations and scored again with the same task inputs.

    task_use: (inputs used from the settings, Session.task_angles) as in :func:`score_rows`: every
    draw gets the settings' value in those inputs, so they add no spread."""
    n = len(rows)
    extra = factors.drop(columns=[c for c in factors.columns if c in posture.columns])
    keep = [c for c in U.SD_ANGLES if c in posture.columns]  # what U.angle_sd reads of a draw
    angle_draws, rula, reba = [], [], []
    # one draw at a time, and of each only what is read after it (memory: a block of a shift is
    # scored at once, and all draws' points together were 25 kB per frame)
    assert rows.std_world is not None  # TrackFrames.__post_init__ fills it
    for pts in U.iter_samples(rows.points_world, rows.std_world, scoring.joint_sd_floor_m):
        a = joint_angles(pts, rows.time_s, angle_settings).to_frame().reset_index(drop=True)
        del pts
        if task_use is not None:
            a = T.apply_settings(a, *task_use)
        s = score_posture(pd.concat([a, extra], axis=1), settings=scoring)
        angle_draws.append(a[keep].copy())
        rula.append(s["rula_grand"].copy())
        reba.append(s["reba_score"].copy())
        del a, s
    out = U.angle_sd(posture, angle_draws)
    for name, reported, draws in (
        ("rula_grand", scores["rula_grand"], rula),
        ("reba_score", scores["reba_score"], reba),
    ):
        p, low, high = U.score_spread(reported, draws)
        out[f"{name}_p"] = np.round(p, 4)
        out[f"{name}_low"] = pd.array(np.where(np.isfinite(low), low, np.nan), dtype="Float64").round().astype("Int16")
        out[f"{name}_high"] = (
            pd.array(np.where(np.isfinite(high), high, np.nan), dtype="Float64").round().astype("Int16")
        )
    seen = rows.views.max(axis=1) if n else np.zeros(0, np.int8)
    conf, cause = U.frame_confidence(
        out["rula_grand_p"].to_numpy(np.float64),
        out["reba_score_p"].to_numpy(np.float64),
        rows.views,
        getattr(rows, "inferred", None),
        seen,
        getattr(rows, "limited", None),
    )
    out["confidence"] = pd.array(conf, dtype="string")
    out["cause"] = pd.array(cause, dtype="string")
    out["held_at_limit"] = pd.array(U.held_parts(getattr(rows, "limited", None), n), dtype="string")
    return out


def score_worker(
    session: Session, rows: TrackFrames, worker_id: str, scoring: ScoringSettings, diagnostics: Any
) -> ScoredWorker:
    """A worker's rows scored in one piece (:func:`score_rows`) and the shift summary; for
    evaluations of short sessions. ``ergopose assess`` scores in blocks (:func:`score_tracks`)."""
    frames = score_rows(session, rows, worker_id, scoring)
    summary = aggregate_shift(
        frames,
        worker_id,
        settings=scoring,
        frame_period_s=1.0 / session.fps,
        inferred=getattr(rows, "inferred", None),
        limited=getattr(rows, "limited", None),
    )
    return ScoredWorker(
        worker_id=worker_id,
        frames=frames,
        summary=summary,
        diagnostics=diagnostics,
        reliable=reliable_frames(rows.points_world),
        points_world=rows.points_world,
    )


SCORED_DIR = "scored"


class WorkerSink:
    """Where one worker's scored blocks go: the frames CSV, the scored-frames Parquet file (read
    back for the report's worst moments), the shift aggregation and the report's timeline
    (eight numbers per frame, the only per-frame data kept in memory)."""

    def __init__(
        self,
        stack: contextlib.ExitStack,
        worker_id: str,
        csv_path: Path,
        scored_path: Path,
        scoring: ScoringSettings,
        fps: float,
        limb_medians_m: np.ndarray,
        *,
        recorded_at: dt.datetime | None = None,
        name: str | None = None,
        bom: bool = False,
    ) -> None:
        self.worker_id = worker_id
        csv_path = Path(csv_path)
        self.csv = stack.enter_context(
            FramesCsvWriter(
                csv_path, recorded_at=recorded_at, name=name, bom=bom, parquet=csv_path.with_suffix(".parquet")
            )
        )
        self.steps = stack.enter_context(StepsCsvWriter(steps_path(csv_path), bom=bom))
        self.scored_path = scored_path
        self._scored_tmp = stack.enter_context(atomic_path(scored_path))
        self._stack = stack
        self._parquet: pq.ParquetWriter | None = None
        self._schema: pa.Schema | None = None
        self.acc = ShiftAccumulator(worker_id, settings=scoring, frame_period_s=1.0 / fps)
        self.medians = limb_medians_m
        self.timeline: dict[str, list[np.ndarray]] = {
            k: []
            for k in (
                "time_s",
                "frame",
                "rula_grand",
                "rula_action_level",
                "reba_score",
                "reba_risk_level",
                "floor_x_m",
                "floor_y_m",
                "reliable",
            )
        }

    def write(self, frames: pd.DataFrame, rows: TrackFrames) -> None:
        self.csv.write(frames)
        self.steps.write(frames)
        self.acc.add(frames, getattr(rows, "inferred", None), getattr(rows, "limited", None))
        if self._parquet is None:
            self._schema = pa.Schema.from_pandas(frames, preserve_index=False)
            self._parquet = self._stack.enter_context(
                pq.ParquetWriter(self._scored_tmp, self._schema, compression="zstd")
            )
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


def score_workers(
    session: Session,
    tracks: Tracks,
    out_dir: Path,
    scoring: ScoringSettings,
    ident: Naming,
    progress: ProgressCallback | None,
    *,
    bom: bool = False,
) -> dict[int, WorkerSink]:
    """Every worker of ``tracks`` scored in blocks (:class:`ergopose.pipeline.scoring.WorkerScorer`)
    from one pass over the tracks table, into ``out_dir``: the frames and steps CSV files under
    csv/, the scored frames under pipeline/scored/ (ident: the reported id of a tracked id,
    :class:`ergopose.pipeline.names.Naming`). Returns each worker's sink, by tracker number."""
    block, context = block_sizes(scoring, session.fps)
    csv_dir = out_dir / CSV_DIR
    scored_dir = out_dir / "pipeline" / SCORED_DIR
    total = max(int(session.frame_count), 1)
    sinks: dict[int, WorkerSink] = {}
    with contextlib.ExitStack() as stack:
        scorers = {}
        for w in tracks.workers:
            tracked = identity_name(w)
            wid = ident.rename(tracked)
            ref = tracks.references.shoulder_reference_m(w)
            sink = WorkerSink(
                stack,
                wid,
                csv_dir / f"{wid}{FRAMES_SUFFIX}",
                scored_dir / f"{tracked}.parquet",
                scoring,
                session.fps,
                tracks.references.limb_medians_m(w),
                recorded_at=session.recorded_at,
                name=session.display_name(wid),
                bom=bom,
            )
            sinks[w] = sink

            def score(rows: TrackFrames, wid: str = wid, ref: float | None = ref) -> pd.DataFrame:
                return score_rows(session, rows, wid, scoring, ref)

            scorers[w] = WorkerScorer(score, sink, block, context)
        report(progress, "scoring", 0, total, unit="frame")
        if tracks.workers:
            for part in read_track_parts(tracks.path):
                part = scoring_rows(merge_rows(part, tracks.groups))  # only what scoring reads is kept
                if tracks.window is not None:
                    part = take_rows(part, tracks.window.mask(part.frame, session.fps))
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

    return sinks
