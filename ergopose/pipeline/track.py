"""Stage *track and smooth*: the stored chunks of people in 3D, in frame order, through identity
tracking, the body fit and smoothing (:class:`ergopose.recon.pipeline.ShiftReconstruction`) into
the tracks table (Parquet); and the same :class:`Tracks` record of a stored table, without video.

In: the chunks of :class:`ergopose.pipeline.detect.ChunkResult` (``People3D``). Out: :class:`Tracks`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from ergopose.errors import InputError
from ergopose.pipeline.names import (
    NAMES_FILE,
    load_names,
    merge_rows,
    resolve_naming,
    tracker_number,
    unused_message,
    unused_task_inputs,
)
from ergopose.pipeline.scoring import ShiftReferences
from ergopose.pipeline.window import Window
from ergopose.progress import ProgressCallback, report, warn
from ergopose.pipeline.store import ResultStore
from ergopose.recon.pipeline import ShiftReconstruction, TrackFrames
from ergopose.recon.session import worker_summary
from ergopose.recon.settings import ReconSettings
from ergopose.recon.table import TracksWriter, read_metadata, table_to_frames
from ergopose.recon.track_records import identity_name
from ergopose.session import Session


@dataclass(frozen=True)
class Tracks:
    """The reconstructed workers of a session: the tracks table (Parquet, read back in pieces),
    the per-worker summary stored in it, and the whole-shift references scoring needs
    (:class:`ergopose.pipeline.scoring.ShiftReferences`). Nothing per frame stays in memory."""

    path: Path
    worker_summary: dict[str, dict[str, Any]]
    references: Any  # ShiftReferences
    workers: tuple[int, ...]
    rows: int
    #: the reconstruction settings the tracks were made (or are read back) with
    recon: ReconSettings
    #: tracker numbers scored as one worker: {member: the group's first member}
    #: (ergopose.pipeline.names.Naming.groups); ``workers`` then holds the groups' first members
    groups: dict[int, int] = dataclasses.field(default_factory=dict)
    #: the part of the day assessed (``ergopose assess --start/--end``; stored in the table's
    #: metadata): scoring keeps the frames within it; None = every frame of the table
    window: Window | None = None


def track_session(
    session: Session,
    store: ResultStore,
    ranges: Sequence[tuple[int, int]],
    recon: ReconSettings,
    progress: ProgressCallback | None,
    window: Window | None = None,
    meta: Mapping[str, Any] | None = None,
) -> Tracks:
    """Stored chunks, in frame order -> identities, smoothing, the tracks table (Parquet).

    ranges: consecutive chunks (all of the session, or those around ``window``: the part of the
    day assessed, stored in the table's metadata for the scoring). meta: more entries of the table's
    metadata (how the 2D records were made, when not by the pose networks)."""
    shift = ShiftReconstruction(
        recon, fps=session.fps, cameras=session.calibrated_cameras, first_frame=ranges[0][0] if ranges else 0
    )
    refs = ShiftReferences(recon)
    with TracksWriter(
        store.tracks_path, fps=session.fps, cameras=session.camera_names, settings=recon.as_dict()
    ) as writer:
        if window is not None:
            writer.meta["window"] = window.as_dict()
        writer.meta.update(meta or {})
        for k, (start, stop) in enumerate(ranges):
            chunk = store.load_chunk(start, stop)
            if chunk is None:
                raise InputError(
                    f"the stored chunk of frames {start}-{stop - 1} is missing or unreadable; run the assessment again",
                    path=store.chunk_path(start),
                )
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
    return Tracks(
        path=store.tracks_path,
        worker_summary=summary,
        references=refs,
        workers=tuple(refs.limbs.workers()),
        rows=rows,
        recon=recon,
        window=window,
    )


def stored_tracks(path: Path, recon: ReconSettings, groups: Mapping[int, int] | None = None) -> Tracks:
    """The Tracks of a stored tracks table (the tracking stage's output) without the video work: the
    whole-shift references are gathered again in one pass over the table, with the tracker numbers
    of ``groups`` merged (:func:`ergopose.pipeline.names.merge_rows`).

    recon: the session's reconstruction settings (``Session.reconstruction``; the limb diagnostics'
    lens regions come from them)."""
    meta = read_metadata(path)
    groups = dict(groups or {})
    refs = ShiftReferences(recon)
    rows = 0
    for part in read_track_parts(path):
        refs.add(merge_rows(part, groups))
        rows += len(part)
    return Tracks(
        path=Path(path),
        worker_summary=dict(meta.get("workers") or {}),
        references=refs,
        workers=tuple(refs.limbs.workers()),
        rows=rows,
        recon=recon,
        groups=groups,
        window=Window.from_dict(meta.get("window")),
    )


def regroup(tracks: Tracks, groups: dict[int, int]) -> Tracks:
    """``tracks`` with the tracker numbers of ``groups`` scored as one worker (the same object when
    there is nothing to merge)."""
    if groups == tracks.groups:
        return tracks
    return dataclasses.replace(
        stored_tracks(tracks.path, tracks.recon, groups), worker_summary=tracks.worker_summary, window=tracks.window
    )


def read_track_parts(path: Path) -> Iterator[TrackFrames]:
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


def _within(tracks: Tracks, fps: float) -> Tracks:
    """``tracks`` with only the workers that have a row within its window (``tracks`` itself
    without a window)."""
    if tracks.window is None:
        return tracks
    first, stop = tracks.window.frame_range(fps)
    table = pq.read_table(tracks.path, columns=["worker"], filters=[("frame", ">=", first), ("frame", "<", stop)])
    present = {tracker_number(str(w)) for w in pc.unique(table.column("worker")).to_pylist()}
    keep = tuple(
        w for w in tracks.workers if w in present or any(g == w for m, g in tracks.groups.items() if m in present)
    )
    return dataclasses.replace(tracks, workers=keep)


@dataclass(frozen=True)
class NamedTracks:
    """The tracks under the names they are reported with: the session with the settings' workers
    renamed (:meth:`ergopose.pipeline.names.Naming.session`), the tracks with the tracker numbers
    scored as one worker merged and, with a part of the day, only the workers tracked within it,
    who is who (:class:`ergopose.pipeline.names.Naming`), and the settings ids whose task inputs
    reach nobody."""

    session: Session
    tracks: Tracks
    naming: Any
    unused: tuple[str, ...]


def name_workers(
    session: Session, tracks: Tracks, progress: ProgressCallback | None, window: Window | None = None
) -> NamedTracks:
    """Who is who: the session's names.toml, then the stature match, then the tracker's pseudonym
    (:mod:`ergopose.pipeline.names`); names of names.toml that are not a tracked id and settings
    ids whose task inputs reach nobody are named in warnings.

    window: score only the frames of this part of the day (default: the tracks' own window,
    ``ergopose assess --start/--end``; else all); only the workers tracked within it are kept."""
    if window is not None:
        tracks = dataclasses.replace(tracks, window=window)
    measured = {name: info.get("stature_estimate_m") for name, info in tracks.worker_summary.items()}
    tracked = [identity_name(w) for w in sorted(set(tracks.workers) | set(tracks.groups))]
    given = load_names(session.path)
    stale = [t for t in given if t not in tracked]
    if stale:
        warn(
            progress,
            f"{NAMES_FILE}: {', '.join(stale)} {'is' if len(stale) == 1 else 'are'} not a tracked id of "
            f"these results (tracked: {', '.join(tracked) or 'nobody'}); the name is not used; check "
            f"with 'ergopose workers --session {session.path}'",
        )
    naming = resolve_naming(session, tracked, given, measured)
    tracks = regroup(tracks, naming.groups())
    if tracks.window is not None:
        tracks = _within(tracks, session.fps)
    session = naming.session(session)
    unused = unused_task_inputs(session, sorted(naming.members))
    if unused:
        warn(progress, unused_message(session, unused, tracked_ids=tracked))
    return NamedTracks(session=session, tracks=tracks, naming=naming, unused=tuple(unused))
