"""``ergopose assess``: a session folder in, per-worker scores, CSV files and an HTML report out.

The driver, in the data's order (each stage a module with typed records in and out):

=====================  ====================================  ==========================================
stage                  module                                record out
=====================  ====================================  ==========================================
(inputs)               :mod:`ergopose.pipeline.inputs`       :class:`PreparedRun` (session, models, job)
find people, 2D        :mod:`ergopose.pipeline.detect`       per frame and camera ``Detections2D``
                       (a :class:`~ergopose.pipeline.detect.
                       Source2D`: the pose networks on video)
body model (3D)        :mod:`ergopose.pipeline.detect`       ``ChunkResult`` (``People3D``), stored
track and smooth       :mod:`ergopose.pipeline.track`        ``Tracks`` (the tracks table), ``NamedTracks``
score                  :mod:`ergopose.pipeline.score`        per-frame scores (CSV files as it goes)
aggregate              :mod:`ergopose.pipeline.aggregate`    ``ReportWorker`` per worker
publish                :mod:`ergopose.pipeline.publish`      ``Outputs`` (CSV files, results, pages)
=====================  ====================================  ==========================================

:func:`assess` runs them for one session on this machine: :func:`prepare` (the session, the
output folder, the pose models), :func:`open_store` (which chunks are stored already),
:func:`people_in_3d` (the chunks of video through the first stages, in as many processes as
there are cores, each chunk stored at once: an interrupted run continues with the chunks it had
not finished; meanwhile this process tracks the stored chunks in frame order,
:func:`start_tracking`), then :func:`finish` (the end of the tracking and the stages after it,
from the stored chunks). A Dask cluster runs the same functions, tracking after its 2D work
(:mod:`ergopose.pipeline.cluster`).

The stages after the chunks are recomputed from the stored chunks on every run; they are
deterministic, so a resumed run writes the same bytes as an uninterrupted one.
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import multiprocessing
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

from ergopose.ergonomics.settings import ScoringSettings
from ergopose.errors import ConfigError
from ergopose.pipeline import aggregate, detect, guard, names, publish, track
from ergopose.pipeline import window as part_of_day
from ergopose.pipeline.detect import detect_chunk
from ergopose.pipeline.inputs import ModelUse, ensure_models, fingerprint_inputs, scoring_settings
from ergopose.pipeline.publish import WorkerOutput
from ergopose.pipeline.score import RunEach
from ergopose.pipeline.store import ResultStore
from ergopose.pose.models import ConfidenceGates
from ergopose.pose.settings import PoseSettings
from ergopose.recon.settings import ReconSettings
from ergopose.progress import ProgressCallback, report, warn
from ergopose.session import Session, load_session

#: Frames per chunk = CHUNK_SECONDS x fps.
CHUNK_SECONDS = 10.0


@dataclass(frozen=True)
class AssessOptions:
    """How to run an assessment.

    out_dir: the report folder (default: reports/<session folder name> under the current folder).
    processes: worker processes for the 2D stage (default: one per core).
    chunk_seconds: length of a chunk of video processed and stored as one piece.
    model_dir: the pose model cache (default: ERGOPOSE_MODEL_DIR or the user cache).
    force: write into an output folder holding the results of another recording (replacing them).
    max_bad_frame_share: the share of a chunk's frames of one video that may be unreadable and
        skipped; more is an error naming the video and the time.
    model: the landmark model (lite, full, heavy; None: the default), run with its card's
        confidence gates.
    start, end: the part of the day to assess (clock time HH:MM[:SS] of the session's day, or
        seconds from its start; :mod:`ergopose.pipeline.window`): only the chunks around it go
        through the video work and only its frames are scored. None = the session's start / end.
    csv_bom: write the CSV files with a UTF-8 byte order mark (Excel).
    """

    out_dir: Path | None = None
    processes: int | None = None
    chunk_seconds: float = CHUNK_SECONDS
    model_dir: str | None = None
    force: bool = False
    max_bad_frame_share: float = 0.2
    model: str | None = None
    start: str | None = None
    end: str | None = None
    csv_bom: bool = False


@dataclass(frozen=True)
class AssessResult:
    """What an assessment wrote and how the work went."""

    session: Path
    report_dir: Path
    index_html: Path
    session_csv: Path
    tracks: Path
    workers: tuple[WorkerOutput, ...]
    frames: int
    chunks_total: int
    chunks_reused: int
    seconds: float
    stage_seconds: dict[str, float] = field(default_factory=dict)


def _pose_for(pose: PoseSettings, gates: ConfidenceGates | None) -> PoseSettings:
    """The 2D stage's settings ([pose] of settings.toml) with the landmark card's confidence
    gates, except where settings.toml gives a gate a value other than its default."""
    if gates is None:
        return pose
    default = PoseSettings()
    return dataclasses.replace(
        pose,
        min_presence=float(gates.min_presence) if pose.min_presence == default.min_presence else pose.min_presence,
        min_keypoint_confidence=float(gates.min_keypoint_confidence)
        if pose.min_keypoint_confidence == default.min_keypoint_confidence
        else pose.min_keypoint_confidence,
    )


def _recon_for(recon: ReconSettings, gates: ConfidenceGates | None) -> ReconSettings:
    """The reconstruction's settings ([reconstruction] of settings.toml) with the landmark card's
    triangulation gate, except where settings.toml gives min_confidence another value."""
    if gates is None or recon.min_confidence != ReconSettings().min_confidence:
        return recon
    return dataclasses.replace(recon, min_confidence=gates.min_triangulation_confidence)


def default_out_dir(session: Session) -> Path:
    return Path("reports") / session.path.resolve().name


def assess(
    session_dir: str | Path, options: AssessOptions = AssessOptions(), progress: ProgressCallback | None = None
) -> AssessResult:
    """Run the whole assessment of a session (see the module docstring)."""
    run = prepare(session_dir, options, progress)
    processes = options.processes or detect.default_workers()
    if processes < 1:
        raise ConfigError(f"expected at least 1 process, got {processes}", field="processes")
    with guard.output_faults(run.out_dir), run.store.lock():
        ranges, done, todo = open_store(run, progress)
        with start_tracking(run, ranges, progress) as tracking:
            people_in_3d(run, todo, ranges, len(done), processes, progress, tracking=tracking)
            return finish(run, ranges, len(done), progress, tracking=tracking)


@dataclass
class PreparedRun:
    """One session's run after its inputs were checked: what the chunk tasks and the stages after
    them need. ``job`` and the store's root are all a chunk task needs (picklable)."""

    session: Session
    out_dir: Path
    store: ResultStore
    job: detect.DetectJob
    chunk_frames: int
    models: tuple[ModelUse, ...]
    scoring: ScoringSettings
    t_start: float
    timings: dict[str, float] = field(default_factory=dict)
    window: part_of_day.Window | None = None
    bom: bool = False
    #: how the 2D records are made when not by the pose networks on the videos (a source an
    #: evaluation brings, :class:`ergopose.pipeline.detect.Source2D`): part of the fingerprint of
    #: the stored chunks and of the tracks table's metadata; None for the pose networks
    source: dict[str, Any] | None = None

    @property
    def frames(self) -> int:
        """Frames assessed: the session's, or those of the part of the day."""
        if self.window is None:
            return self.session.frame_count
        first, stop = self.window.frame_range(self.session.fps)
        return min(stop, self.session.frame_count) - first


def prepare(
    session_dir: str | Path, options: AssessOptions = AssessOptions(), progress: ProgressCallback | None = None
) -> PreparedRun:
    """The session and the output folder checked, the pose models in the cache."""
    t_start = time.perf_counter()
    timings: dict[str, float] = {}
    if options.out_dir is not None:
        guard.check_output_folder(options.out_dir)  # before any video is read
    report(progress, "session", 0, 1, unit="step", message="checking videos, calibration and settings")
    session = load_session(session_dir)
    window = part_of_day.resolve(options.start, options.end, session.recorded_at, session.duration_s)
    report(progress, "session", 1, 1, unit="step")
    out_dir = Path(options.out_dir) if options.out_dir is not None else default_out_dir(session)
    guard.check_before_work(out_dir, session, options.force, progress)
    unreachable = names.unreachable_task_inputs(session, names.load_names(session.path))
    if unreachable:  # before the long work, so the user can stop and name the workers
        warn(progress, names.unused_message(session, unreachable))
    scoring = scoring_settings(session)

    t0 = time.perf_counter()
    models = ensure_models(options.model_dir, progress, options.model)
    timings["models"] = time.perf_counter() - t0

    chunk_frames = max(1, int(round(options.chunk_seconds * session.fps)))
    job = detect.DetectJob(
        cameras=session.calibrated_cameras,
        videos=tuple(str(c.video_path) for c in session.cameras),
        fps=session.fps,
        model_dir=options.model_dir,
        max_bad_share=options.max_bad_frame_share,
        model=options.model,
        pose=_pose_for(session.pose, models[-1].card.gates),
        recon=_recon_for(session.reconstruction, models[-1].card.gates),
        num_threads=1,
    )  # one thread per process: the same numbers whatever the process count
    return PreparedRun(
        session=session,
        out_dir=out_dir,
        store=ResultStore(out_dir),
        job=job,
        chunk_frames=chunk_frames,
        models=models,
        scoring=scoring,
        t_start=t_start,
        timings=timings,
        window=window,
        bom=options.csv_bom,
    )


def open_store(
    run: PreparedRun, progress: ProgressCallback | None
) -> tuple[list[tuple[int, int]], set[int], list[tuple[int, int]]]:
    """With the output folder locked: the chunk ranges (with a part of the day, the chunks that
    hold a frame of it, stored as in a whole-day run), the start frames of the chunks already
    stored (checked), and the ranges still to compute."""
    run.store.open(fingerprint_inputs(run.session, run.job, run.chunk_frames, run.models, run.source))
    ranges = detect.chunk_ranges(run.session.frame_count, run.chunk_frames)
    if run.window is not None:
        first, stop = run.window.frame_range(run.session.fps)
        ranges = [r for r in ranges if r[1] > first and r[0] < stop]
    done = run.store.finished(ranges, progress)
    todo = [r for r in ranges if r[0] not in done]
    return ranges, done, todo


def prepare_source(
    session: Session, out_dir: Path, recon: ReconSettings, chunk_frames: int, source: dict[str, Any]
) -> PreparedRun:
    """A run whose 2D records come from a source an evaluation brings
    (:class:`ergopose.pipeline.detect.Source2D`, given to :func:`people_in_3d`) instead of the pose
    networks on the videos: no models, ``recon`` for the body model and the tracking, ``source``
    (a description of the source) in the fingerprint of the stored chunks and in the tracks
    table's metadata. The output folder is not checked: the caller owns it."""
    job = detect.DetectJob(cameras=session.calibrated_cameras, videos=(), fps=session.fps, recon=recon)
    return PreparedRun(
        session=session,
        out_dir=Path(out_dir),
        store=ResultStore(out_dir),
        job=job,
        chunk_frames=max(1, int(chunk_frames)),
        models=(),
        scoring=scoring_settings(session),
        t_start=time.perf_counter(),
        source=dict(source),
    )


def start_tracking(
    run: PreparedRun, ranges: Sequence[tuple[int, int]], progress: ProgressCallback | None
) -> track.SessionTracking:
    """The stage *track and smooth* of this run, to be fed the chunks as they are stored (a
    context manager: :class:`ergopose.pipeline.track.SessionTracking`)."""
    return track.SessionTracking(
        run.session, run.store, ranges, run.job.recon, progress, window=run.window, meta=run.source
    )


def people_in_3d(
    run: PreparedRun,
    todo: Sequence[tuple[int, int]],
    ranges: Sequence[tuple[int, int]],
    already: int,
    processes: int,
    progress: ProgressCallback | None,
    source: detect.Source2D | None = None,
    tracking: track.SessionTracking | None = None,
) -> None:
    """Stages *find people*, *2D* and *body model* for every chunk still to do, each chunk stored
    as it finishes (:func:`ergopose.pipeline.detect.detect_chunk`). source: where the 2D records
    come from (None: the pose networks on the session's videos, in ``processes`` processes; else
    in this process). tracking: the run's tracking (:func:`start_tracking`), given the stored
    chunks in frame order while the worker processes compute the others: the main process
    would otherwise wait for them, and track every chunk afterwards with the other cores idle."""
    t0 = time.perf_counter()
    if source is None:
        on_stored = None
        if tracking is not None:
            waiting = {start for start, _ in todo}
            tracking.push_stored(start for start, _ in ranges if start not in waiting)  # an earlier run's
            on_stored = tracking.push_stored_one
        _run_chunks(run.job, run.store, todo, ranges, already, processes, progress, on_stored)
        if tracking is not None:
            run.timings["tracking_during_pose"] = tracking.seconds
    else:
        total = sum(stop - start for start, stop in ranges)
        done = total - sum(stop - start for start, stop in todo)
        report(progress, "pose", done, total, unit="frame")
        for start, stop in todo:
            run.store.save_chunk(detect_chunk(run.job, start, stop, source=source))
            done += stop - start
            report(progress, "pose", done, total, unit="frame")
    run.timings["pose"] = time.perf_counter() - t0


def finish(
    run: PreparedRun,
    ranges: Sequence[tuple[int, int]],
    reused: int,
    progress: ProgressCallback | None,
    run_each: RunEach | None = None,
    tracking: track.SessionTracking | None = None,
) -> AssessResult:
    """The stages after the chunks, from the stored chunks (:func:`after_people`), and what the
    run wrote (run_each: see :func:`ergopose.pipeline.aggregate.score_tracks`; tracking: the
    run's tracking begun during the 2D stage, :func:`people_in_3d`)."""
    tracks, outputs = after_people(run, ranges, progress, run_each, tracking=tracking)
    return AssessResult(
        session=run.session.path,
        report_dir=run.out_dir,
        index_html=outputs.index_html,
        session_csv=outputs.session_csv,
        tracks=tracks.path,
        workers=outputs.workers,
        frames=run.frames,
        chunks_total=len(ranges),
        chunks_reused=reused,
        seconds=time.perf_counter() - run.t_start,
        stage_seconds=run.timings,
    )


#: The stage *publish*: called as publisher(named, scored, stage, out_dir, scoring, models, progress,
#: bom=..., store_dir=...) with the :class:`ergopose.pipeline.track.NamedTracks`, the
#: :class:`ergopose.pipeline.aggregate.ReportWorker` records and the staging folder the scoring wrote
#: into; returns what it wrote. The product's is :func:`ergopose.pipeline.publish.publish`.
Publisher = Callable[..., Any]


def after_people(
    run: PreparedRun,
    ranges: Sequence[tuple[int, int]],
    progress: ProgressCallback | None,
    run_each: RunEach | None = None,
    publisher: Publisher = publish.publish,
    tracking: track.SessionTracking | None = None,
) -> tuple[track.Tracks, Any]:
    """The stages after the chunks, from the stored chunks: track and smooth (the rest of it when
    ``tracking`` began during the 2D stage), then score, aggregate and publish
    (:func:`score_and_publish`). Returns the tracks and what ``publisher`` wrote.

    Timings: ``tracking`` the whole stage's time, ``tracking_after_pose`` the part after the 2D
    stage (all of it without ``tracking``)."""
    t0 = time.perf_counter()
    if tracking is None:
        with start_tracking(run, ranges, progress) as tracking:
            tracks = tracking.finish()
    else:
        tracks = tracking.finish()
    run.timings["tracking_after_pose"] = time.perf_counter() - t0
    run.timings["tracking"] = tracking.seconds

    t0 = time.perf_counter()
    outputs = score_and_publish(
        run.session, tracks, run.out_dir, run.scoring, run.models, progress, run_each, bom=run.bom, publisher=publisher
    )
    run.timings["scoring_and_report"] = time.perf_counter() - t0
    return tracks, outputs


def score_and_publish(
    session: Session,
    tracks: track.Tracks,
    out_dir: Path,
    scoring: Any,
    models: Sequence[ModelUse],
    progress: ProgressCallback | None,
    run_each: RunEach | None = None,
    *,
    bom: bool = False,
    window: part_of_day.Window | None = None,
    store_dir: Path | None = None,
    publisher: Publisher = publish.publish,
) -> Any:
    """The stages after tracking: who is who, score, aggregate, publish. Everything is written to
    a folder beside the outputs and moved into place when complete: a failure leaves the earlier
    outputs whole. Also run on stored tracks without video (:mod:`ergopose.pipeline.rescore`).

    bom: CSV files with a UTF-8 byte order mark (Excel). window: score only the frames of this part
    of the day (default: the tracks' own window; else all). store_dir: the folder whose stored
    chunks name the skipped video frames (default ``out_dir``). publisher: the stage *publish*
    (:data:`Publisher`; returns what it wrote, :class:`ergopose.pipeline.publish.Outputs` for the
    product's)."""
    named = track.name_workers(session, tracks, progress, window)
    with publish.staging(out_dir) as stage:
        scored = aggregate.score_tracks(
            named.session, named.tracks, stage, scoring, named.naming, progress, run_each, bom=bom
        )
        return publisher(named, scored, stage, out_dir, scoring, models, progress, bom=bom, store_dir=store_dir)


def chunk_task(job: detect.DetectJob, store_root: str, start: int, stop: int) -> tuple[int, int]:
    """Worker-process entry point: one chunk, stored before returning."""
    result = detect_chunk(job, start, stop)
    ResultStore.at(store_root).save_chunk(result)
    return start, stop


def _run_chunks(
    job: detect.DetectJob,
    store: ResultStore,
    todo: Sequence[tuple[int, int]],
    ranges: Sequence[tuple[int, int]],
    already: int,
    processes: int,
    progress: ProgressCallback | None,
    on_stored: Callable[[int], None] | None = None,
) -> None:
    """The chunks ``todo`` through the 2D stage in ``processes`` processes, each stored by its
    process; ``on_stored(start)`` in this process after each one is stored."""
    total_frames = sum(stop - start for start, stop in ranges)  # the chunks of this run (a window: some)
    done_frames = sum(stop - start for start, stop in ranges) - sum(stop - start for start, stop in todo)
    msg = f"{already} of {len(ranges)} chunks already done" if already else ""
    report(progress, "pose", done_frames, total_frames, unit="frame", message=msg)
    if not todo:
        return
    if processes == 1 or len(todo) == 1:
        for start, stop in todo:
            chunk_task(job, str(store.root), start, stop)
            done_frames += stop - start
            report(progress, "pose", done_frames, total_frames, unit="frame")
            if on_stored is not None:
                on_stored(start)
        return
    # 'spawn': every worker starts clean (no forked LiteRT or OpenCV thread state).
    ctx = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(max_workers=min(processes, len(todo)), mp_context=ctx) as pool:
        futures = {pool.submit(chunk_task, job, str(store.root), s, e): (s, e) for s, e in todo}
        try:
            for fut in cf.as_completed(futures):
                start, stop = fut.result()
                done_frames += stop - start
                report(progress, "pose", done_frames, total_frames, unit="frame")
                if on_stored is not None:
                    on_stored(start)
        except BaseException:
            for f in futures:
                f.cancel()
            raise
