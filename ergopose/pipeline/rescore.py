"""The tracked people of stored results, and scoring them again under new names without the video work.

:func:`tracked_people` lists the people of a results folder's tracks table with a few facts that
help tell them apart (stature, tracked time, first and last seen, where on the floor).
:func:`rename` stores names for them in the session (:mod:`ergopose.pipeline.names`) and runs the
stages after tracking again from the stored tracks table (:func:`ergopose.pipeline.assess.
score_and_report`): scores, CSV files, stored results and pages are replaced whole, so the task
inputs of the settings reach the people they were meant for. Nothing here reads video frames.
"""

from __future__ import annotations

import datetime as dt
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pyarrow.compute as pc
import pyarrow.parquet as pq

from ergopose.atomic import write_text
from ergopose.errors import InputError
from ergopose.pipeline import guard, headcount, names
from ergopose.pipeline.assess import score_and_publish
from ergopose.pipeline.inputs import ModelUse, scoring_settings
from ergopose.pipeline.track import stored_tracks
from ergopose.pipeline import window as part_of_day
from ergopose.pipeline.store import ResultStore
from ergopose.pose.models import BLAZEPOSE_DETECTOR, DEFAULT_LANDMARK_MODEL, MODEL_CARDS, landmark_card
from ergopose.progress import ProgressCallback, warn
from ergopose.recon.table import read_metadata
from ergopose.report.adapters import load_floor_plan
from ergopose.report.context import FloorItem
from ergopose.session import Session, load_session

DEFAULT_REPORTS_DIR = "reports"
#: Furniture within this distance (metres) of a person's median floor position names the place.
NEAR_M = 1.0


def results_folder(session_dir: str | Path, results: str | Path | None = None) -> Path:
    """The results folder of a session: ``results`` if given, else the session folder itself when
    it holds the stored tracks, else reports/<session folder name>; InputError without a tracks table."""
    session_dir = Path(session_dir)
    if results is not None:
        folder = Path(results)
    elif ResultStore(session_dir).tracks_path.is_file():
        folder = session_dir
    else:
        folder = Path(DEFAULT_REPORTS_DIR) / session_dir.resolve().name
    if not ResultStore(folder).tracks_path.is_file():
        raise InputError(
            f"no stored tracks for this session (expected {ResultStore(folder).tracks_path}); run "
            f"'ergopose assess --session {session_dir}' first, or give its output folder with --results",
            path=folder,
        )
    return folder


@dataclass(frozen=True)
class TrackedPerson:
    """One tracked id of stored results.

    tracked_id: the tracker's pseudonym. reported_id / name: the id and name it is reported under
    now (names.toml, stature match or the pseudonym). stature_m: the stature measured (NaN when
    unknown). tracked_s: time with a row in the tracks table. first_s / last_s: seconds from the
    first frame. x_m, y_m: median floor position of the mid-hip (NaN when never measured).
    place: the nearest furniture of floor.toml within NEAR_M of it, or "".
    """

    tracked_id: str
    reported_id: str
    name: str
    stature_m: float
    tracked_s: float
    first_s: float
    last_s: float
    x_m: float
    y_m: float
    place: str = ""


def tracked_people(session: Session, folder: Path) -> list[TrackedPerson]:
    """The tracked people of the results in ``folder`` (in tracker order) for ``session``."""
    path = ResultStore(folder).tracks_path
    meta = read_metadata(path)
    fps = float(meta.get("fps") or session.fps)
    table = pq.read_table(
        path, columns=["worker", "frame", "joint", "x", "y"], filters=[("joint", "in", ["left_hip", "right_hip"])]
    )
    df = table.to_pandas()
    df["worker"] = df["worker"].astype(str)
    hips = df.groupby(["worker", "frame"], sort=False)[["x", "y"]].mean()  # NaN unless both hips known
    per = hips.reset_index().groupby("worker")
    frames = per["frame"].agg(["count", "min", "max"])
    where = per[["x", "y"]].median()
    statures = {k: (v or {}).get("stature_estimate_m") for k, v in (meta.get("workers") or {}).items()}
    tracked = sorted(frames.index, key=names.tracker_number)
    naming = names.resolve_naming(session, tracked, names.load_names(session.path), statures)
    shown = naming.session(session)
    furniture = _furniture(session)
    out = []
    for t in tracked:
        x, y = float(where.loc[t, "x"]), float(where.loc[t, "y"])
        reported = naming.rename(t)
        stature = statures.get(t)
        out.append(
            TrackedPerson(
                tracked_id=t,
                reported_id=reported,
                name=shown.display_name(reported),
                stature_m=float(stature) if stature is not None else math.nan,
                tracked_s=int(frames.loc[t, "count"]) / fps,
                first_s=int(frames.loc[t, "min"]) / fps,
                last_s=int(frames.loc[t, "max"]) / fps,
                x_m=x,
                y_m=y,
                place=_nearest(furniture, x, y),
            )
        )
    return out


def _furniture(session: Session) -> tuple[FloorItem, ...]:
    if session.floor_plan_path is None:
        return ()
    return load_floor_plan(session.floor_plan_path).furniture


def _nearest(furniture: Sequence[FloorItem], x: float, y: float) -> str:
    if not (math.isfinite(x) and math.isfinite(y)) or not furniture:
        return ""
    d = [math.hypot(max(f.x0 - x, 0.0, x - f.x1), max(f.y0 - y, 0.0, y - f.y1)) for f in furniture]
    k = int(np.argmin(d))
    return f"near {furniture[k].name}" if d[k] <= NEAR_M else ""


def clock(session: Session, seconds: float) -> str:
    """A time of the shift as clock time (HH:MM:SS) of the session's start time."""
    t = session.recorded_at + dt.timedelta(seconds=float(seconds))
    return t.strftime("%H:%M:%S")


def tracked_ids(folder: Path) -> list[str]:
    """Every tracked id of the results' tracks table, in tracker order."""
    table = pq.read_table(ResultStore(folder).tracks_path, columns=["worker"])
    return sorted((str(w) for w in pc.unique(table.column("worker")).to_pylist()), key=names.tracker_number)


def _models(folder: Path | None = None) -> tuple[ModelUse, ...]:
    """The pose models the report names: the ones the stored tracks were made with (their SHA-256
    in the results' manifest), else the detector and the default landmark model; no fetch."""
    by_digest = {card.file.sha256: card for card in MODEL_CARDS.values()}
    cards = []
    if folder is not None:
        try:
            manifest = json.loads(ResultStore(folder).manifest_path.read_text())
            digests = manifest["inputs"]["models"]
            cards = [by_digest[d] for d in digests]
        except (OSError, ValueError, KeyError, TypeError):
            cards = []
    if not cards:
        cards = [MODEL_CARDS[BLAZEPOSE_DETECTOR], landmark_card(DEFAULT_LANDMARK_MODEL)]
    return tuple(ModelUse(card=card, sha256=card.file.sha256, path=Path(card.name)) for card in cards)


def rename(
    session_dir: str | Path,
    given: Mapping[str, str],
    results: str | Path | None = None,
    progress: ProgressCallback | None = None,
    *,
    bom: bool = False,
) -> Any:
    """Store names for tracked ids (``{tracked id: alias}``; an empty alias removes the name) in
    the session's names.toml and score the stored tracks again under them.

    Tracked ids that the results do not hold are refused (InputError naming them) before anything
    is written. When scoring fails, names.toml is put back as it was; the earlier outputs stay whole.
    Returns the :class:`ergopose.pipeline.publish.Outputs` written.
    """
    session = load_session(session_dir, check_videos=False)
    folder = results_folder(session_dir, results)
    known = tracked_ids(folder)
    unknown = [t for t in given if t not in known]
    if unknown:
        raise InputError(
            f"{', '.join(unknown)}: no such tracked id in these results (tracked: "
            f"{', '.join(known) or 'nobody'}); see them with 'ergopose workers --session {session_dir}'",
            field="--name",
        )
    guard.check_results_session(
        folder, session, False, progress=progress, advice="give the output folder of this session with --results"
    )
    path = names.names_path(session.path)
    before = path.read_text(encoding="utf-8") if path.is_file() else None
    mapping = names.load_names(session.path)
    for t, alias in given.items():
        if alias:
            mapping[t] = alias
        else:
            mapping.pop(t, None)
    names.write_names(session.path, mapping)
    try:
        return rescore(session, folder, progress, bom=bom)
    except BaseException:
        if before is None:
            path.unlink(missing_ok=True)
        else:
            write_text(path, before)
        raise


def rescore(session: Session, folder: Path, progress: ProgressCallback | None = None, *, bom: bool = False) -> Any:
    """Score the stored tracks of ``folder`` again with the session's settings and names (no video);
    bom: CSV files with a UTF-8 byte order mark (Excel)."""
    store = ResultStore(folder)
    with guard.output_faults(folder), store.lock():
        tracks = stored_tracks(store.tracks_path, session.reconstruction)
        return score_and_publish(session, tracks, folder, scoring_settings(session), _models(folder), progress, bom=bom)


def rescore_window(
    session: Session,
    folder: Path,
    window: part_of_day.Window,
    progress: ProgressCallback | None = None,
    *,
    bom: bool = False,
) -> Any:
    """Score the stored tracks of ``folder`` again for a part of the day (``window``: an
    :class:`ergopose.pipeline.window.Window`) into ``folder/part-HHMM-HHMM`` (CSV files, stored
    results, pages; replaced whole), leaving the whole day's outputs as they are. No video."""
    store = ResultStore(folder)
    out = Path(folder) / part_of_day.folder_name(window, session.recorded_at)
    with guard.output_faults(out), store.lock():
        tracks = stored_tracks(store.tracks_path, session.reconstruction)
        return score_and_publish(
            session,
            tracks,
            out,
            scoring_settings(session),
            _models(folder),
            progress,
            bom=bom,
            window=window,
            store_dir=Path(folder),
        )


def warn_unused(session: Session, people: Sequence[TrackedPerson], progress: ProgressCallback | None) -> list[str]:
    """Warn (through ``progress``) about settings ids whose task inputs none of ``people``
    (:class:`TrackedPerson`) is reported under."""
    unused = names.unused_task_inputs(session, sorted({p.reported_id for p in people}))
    if unused:
        warn(progress, names.unused_message(session, unused, tracked_ids=[p.tracked_id for p in people]))
    return unused


def warn_headcount(
    session: Session, folder: Path, people: Sequence[TrackedPerson], progress: ProgressCallback | None
) -> headcount.Excess | None:
    """Warn (through ``progress``) when ``people`` are reported as more workers than the settings
    say the area holds, naming the pairs most likely one worker (:mod:`ergopose.pipeline.headcount`)."""
    members: dict[str, list[str]] = {}
    for p in people:
        members.setdefault(p.reported_id, []).append(p.tracked_id)
    path = ResultStore(folder).tracks_path
    return headcount.check_headcount(
        session,
        path,
        int(session.reconstruction.expected_workers),
        members,
        {p.tracked_id: p.stature_m for p in people},
        part_of_day.Window.from_dict(read_metadata(path).get("window")),
        progress,
    )


__all__ = [
    "TrackedPerson",
    "tracked_people",
    "results_folder",
    "rename",
    "rescore",
    "rescore_window",
    "tracked_ids",
    "clock",
    "warn_unused",
    "warn_headcount",
]
