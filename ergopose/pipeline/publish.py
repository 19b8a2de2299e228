"""Stage *publish*: the per-worker summary CSV files, the session summary, the skipped frames,
the stored report results and the HTML pages, written into a folder beside the outputs and moved
into place when complete (:func:`swap_outputs`).

In: the :class:`ergopose.pipeline.aggregate.ReportWorker` records. Out: :class:`Outputs`.
The pages are rendered from those records in memory (:func:`write_report`); nothing is read back.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as dt
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

from ergopose import __version__
from ergopose.calibration import check
from ergopose.ergonomics.export import (
    FRAMES_SUFFIX,
    SUMMARY_SUFFIX,
    steps_path,
    write_session_summary_csv,
    write_worker_summary_csv,
)
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.pipeline.aggregate import ReportWorker
from ergopose.pipeline.guard import fingerprint_of
from ergopose.pipeline.headcount import Excess, SamePerson
from ergopose.pipeline.inputs import ModelUse
from ergopose.pipeline.names import NAMES_FILE
from ergopose.pipeline.score import CSV_DIR, SCORED_DIR
from ergopose.pipeline.skipped import SKIPPED_CSV, skipped_in_store, skipped_records, write_skipped_csv
from ergopose.pipeline.store import ResultStore
from ergopose.pipeline.track import NamedTracks
from ergopose.pipeline.window import Window, describe
from ergopose.progress import ProgressCallback
from ergopose.report import adapters
from ergopose.report.adapters import floor_plan_from_boxes, load_floor_plan
from ergopose.report.context import Assumption, DataFile, FloorPlan, SessionInfo, SkippedFrames
from ergopose.report.quality import reliable_rule
from ergopose.report.render import render_report
from ergopose.report.results import save_results, session_results
from ergopose.session import Session

SESSION_CSV = "session_summary.csv"


@dataclass(frozen=True)
class WorkerOutput:
    """One worker's results: id, shown name, the shift summary (ergopose.ergonomics.shift_records.
    ShiftSummary: tracked time, time at each level, the split by confidence with causes) and the
    CSV files written."""

    worker_id: str
    name: str
    summary: Any
    csv_files: tuple[Path, ...]

    @property
    def observed_s(self) -> float:
        return float(self.summary.observed_s)


@dataclass(frozen=True)
class Outputs:
    index_html: Path
    session_csv: Path
    workers: tuple[WorkerOutput, ...]


@contextlib.contextmanager
def staging(out_dir: Path) -> Iterator[Path]:
    """A fresh folder beside the outputs of ``out_dir`` (``.outputs.*.tmp``), where the stages after
    tracking write; removed on leaving (its complete contents are moved into place by
    :func:`publish` first)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".outputs.", suffix=".tmp", dir=out_dir))
    try:
        yield stage
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def publish(
    named: NamedTracks,
    scored: Sequence[ReportWorker],
    stage: Path,
    out_dir: Path,
    scoring: ScoringSettings,
    models: Sequence[ModelUse],
    progress: ProgressCallback | None,
    *,
    bom: bool = False,
    store_dir: Path | None = None,
) -> Outputs:
    """The scored workers' summary CSV files, the session summary, the skipped frames, the stored
    results and the pages, written into ``stage`` beside the per-frame files the scoring wrote
    there, then moved into ``out_dir`` (:func:`swap_outputs`).

    store_dir: the folder whose stored chunks name the skipped video frames (default ``out_dir``).
    """
    session, out_dir = named.session, Path(out_dir)
    csv_dir = stage / CSV_DIR
    csv_dir.mkdir(parents=True, exist_ok=True)
    csv_files: dict[str, list[tuple[str, str]]] = {}
    outputs = []
    for s in scored:
        frames_csv = out_dir / CSV_DIR / f"{s.worker_id}{FRAMES_SUFFIX}"
        summary_csv = write_worker_summary_csv(csv_dir / f"{s.worker_id}{SUMMARY_SUFFIX}", s.summary, bom=bom)
        csv_files[s.worker_id] = [
            ("Angles and scores per frame, with clock time and confidence (CSV)", f"{CSV_DIR}/{frames_csv.name}"),
            ("Every RULA/REBA step per frame (CSV)", f"{CSV_DIR}/{steps_path(frames_csv).name}"),
            ("Shift summary (CSV)", f"{CSV_DIR}/{summary_csv.name}"),
        ]
        outputs.append(
            WorkerOutput(
                worker_id=s.worker_id,
                name=session.display_name(s.worker_id),
                summary=s.summary,
                csv_files=(
                    frames_csv,
                    frames_csv.with_suffix(".parquet"),
                    steps_path(frames_csv),
                    out_dir / CSV_DIR / summary_csv.name,
                ),
            )
        )
    write_session_summary_csv(
        csv_dir / SESSION_CSV,
        {s.worker_id: s.summary for s in scored},
        names={s.worker_id: session.display_name(s.worker_id) for s in scored},
        recorded_at=session.recorded_at,
        bom=bom,
    )
    skipped = _skipped_frames(
        session, Path(store_dir) if store_dir is not None else out_dir, stage, bom=bom, window=named.tracks.window
    )
    index = write_report(
        session,
        scored,
        stage,
        scoring,
        models,
        csv_files,
        named.naming,
        progress,
        skipped,
        unused=named.unused,
        window=named.tracks.window,
        excess=named.excess,
    )
    swap_outputs(stage, out_dir)
    return Outputs(index_html=out_dir / index.name, session_csv=out_dir / CSV_DIR / SESSION_CSV, workers=tuple(outputs))


#: What the stages after tracking write, relative to the output folder: folders, then pages.
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


def _skipped_frames(
    session: Session, out_dir: Path, write_to: Path | None = None, bom: bool = False, window: Window | None = None
) -> tuple[SkippedFrames, ...]:
    """csv/frames_skipped.csv (under ``write_to``, default ``out_dir``) from the stored chunks of
    ``out_dir`` (those within ``window`` when given); the report's records of them."""
    rows = skipped_in_store(ResultStore(out_dir))
    if window is not None:
        rows = rows[window.mask(rows[:, 0], session.fps)]
    write_skipped_csv((write_to or out_dir) / CSV_DIR / SKIPPED_CSV, rows, session.camera_names, session.fps, bom=bom)
    return skipped_records(rows, session.camera_names, session.fps)


def write_report(
    session: Session,
    scored: Sequence[ReportWorker],
    out_dir: Path,
    scoring: ScoringSettings,
    models: Sequence[ModelUse],
    csv_files: Mapping[str, Sequence[tuple[str, str]]],
    ident: Any,
    progress: ProgressCallback | None,
    skipped: tuple[SkippedFrames, ...] = (),
    unused: Sequence[str] = (),
    window: Window | None = None,
    excess: Excess | None = None,
) -> Path:
    """Store the report results (ergopose.report.results) and render the pages.

    window: the part of the day scored (named in the report's title).

    skipped: the video frames skipped (:func:`ergopose.pipeline.skipped.skipped_records`).
    unused: settings ids whose task inputs reach no reported worker (every worker's assumptions
    say so). excess: more workers reported than the settings say the area holds, with the pairs
    most likely one worker (every page's header carries the notice; both workers of a pair say
    so in their assumptions).
    """
    worker_records = []
    for s in scored:
        summary = adapters.worker_summary(
            s.summary,
            timeline=s.timeline,
            frames=s.period_frames if len(s.period_frames) else None,
            joints_at=s.joints_at,
        )
        diag = adapters.worker_diagnostics(
            s.diagnostics, frames_reliable=s.reliable_frames, reliable_rule=reliable_rule()
        )
        worker_records.append((summary, diag, s.timeline))
    floor = _floor_plan(session)
    info = SessionInfo(
        session_id=session.path.resolve().name,
        title=_title(session, window),
        site="",
        start=session.recorded_at.isoformat() if session.recorded_at else None,
        fps=float(session.fps),
        frames=int(session.frame_count),
        duration_s=float(session.duration_s),
        ergopose_version=__version__,
        created=dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat(),
        models=tuple(adapters.model_info(m.card, m.sha256) for m in models),
        methods=adapters.methods_info(),
        settings=adapters.settings_records(scoring),
        calibration=adapters.calibration_info(
            session.calibration_path, session.camera_names, check=calibration_check(session)
        ),
        floor=floor,
        workers=_with_identities(
            adapters.worker_infos(session, [s.worker_id for s in scored], csv_files),
            ident,
            session,
            unused,
            excess.pairs if excess is not None else (),
        ),
        csv_files=(
            DataFile("Session summary (CSV)", f"{CSV_DIR}/{SESSION_CSV}"),
            DataFile("Skipped video frames (CSV)", f"{CSV_DIR}/{SKIPPED_CSV}"),
        ),
        fingerprint=fingerprint_of(session),
        skipped_frames=tuple(skipped),
        notices=(excess.notice(),) if excess is not None else (),
    )
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


def calibration_check(session: Session) -> check.CheckReport | None:
    """The reference-bar check of the session's calibration (None when the settings give no bar)."""
    if session.calibration_check is None:
        return None

    spec = session.calibration_check
    labels, pixels = check.read_bar_observations(spec.observations_path, session.camera_names)
    return check.measure_bar(session.calibrated_cameras, pixels, spec.length_m, labels=labels)


def _with_identities(
    infos: Sequence[Any],
    ident: Any,
    session: Session,
    unused: Sequence[str] = (),
    same_person: Sequence[SamePerson] = (),
) -> tuple[Any, ...]:
    """Each worker's assumptions, plus how the tracked person was matched to the settings' worker
    (names.toml or stature; ident: ergopose.pipeline.names.Naming or identify.Identification),
    which settings ids' task inputs reach nobody, and which other worker this one most likely is
    when more were tracked than the area holds (same_person)."""
    members = getattr(ident, "members", {})
    named: frozenset[str] = getattr(ident, "named", frozenset())
    out = []
    for info in infos:
        extras = []
        m = ident.match_of(info.worker_id)
        tracked = members.get(info.worker_id, ())
        if any(t in named for t in tracked):
            extras.append(
                Assumption(
                    item="who this is",
                    value="the person tracked as "
                    + " and ".join(tracked)
                    + (" (scored as one worker)" if len(tracked) > 1 else ""),
                    applies_to="the name, task factors and periods of this worker",
                    source=f"{NAMES_FILE} (ergopose workers --name)",
                )
            )
        elif m is not None:
            extras.append(
                Assumption(
                    item="who this is",
                    value=f"the person tracked as {m.tracked_id}: measured stature "
                    f"{m.measured_m:.2f} m, given {m.given_m:.2f} m",
                    applies_to="the name, task factors and periods of this worker",
                    source=f"{session.settings_path.name} [workers.{m.worker_id}] stature_m",
                )
            )
        elif ident.notes:
            extras.append(
                Assumption(
                    item="who this is",
                    value="not matched to a worker of the settings: " + "; ".join(ident.notes),
                    applies_to="the defaults and periods for everyone apply",
                    source=f"{session.settings_path.name} stature_m",
                )
            )
        for pair in same_person:
            if info.worker_id in (pair.first, pair.second):
                other = pair.second if info.worker_id == pair.first else pair.first
                extras.append(
                    Assumption(
                        item="who this is",
                        value=f"most likely the same worker as {other}: more people were tracked than the "
                        f"area holds, and the two were followed at the same time in {pair.together} of "
                        f"the {pair.shorter} frames of the shorter one ({pair.together_pct:.0f} %); if "
                        "so, give both one name with 'ergopose workers --name'",
                        applies_to="this worker's share of the shift (the other's frames are not in it)",
                        source=f"{session.settings_path.name} [reconstruction] expected_workers",
                    )
                )
        if unused:
            extras.append(
                Assumption(
                    item="task inputs applied to nobody",
                    value=", ".join(f"[workers.{u}]" for u in unused)
                    + ": no tracked person has that id; name the tracked people with "
                    "'ergopose workers --name'",
                    applies_to="nobody (these loads, couplings and periods are not in any score)",
                    source=session.settings_path.name,
                )
            )
        if extras:
            info = dataclasses.replace(info, assumptions=tuple(extras) + tuple(info.assumptions))
        out.append(info)
    return tuple(out)


def _floor_plan(session: Session) -> FloorPlan:
    """The monitored area for the floor map: the session's floor.toml when it has one, else 6 x 6 m."""
    cams = [(c.name, float(c.position_world[0]), float(c.position_world[1])) for c in session.calibrated_cameras]
    if session.floor_plan_path is not None:
        return load_floor_plan(session.floor_plan_path, cameras=cams)
    return floor_plan_from_boxes([], cameras=cams)
