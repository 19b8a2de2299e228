"""Stage *track and smooth*: the stored chunks of people in 3D, in frame order, through identity
tracking, the body fit and smoothing (:class:`ergopose.recon.pipeline.ShiftReconstruction`) into
the tracks table (Parquet); and the same :class:`Tracks` record of a stored table, without video.

In: the chunks of :class:`ergopose.pipeline.detect.ChunkResult` (``People3D``). Out: :class:`Tracks`.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, Iterable, Iterator, Mapping, Sequence

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from ergopose.errors import InputError
from ergopose.pipeline.headcount import Excess, check_headcount
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
    with SessionTracking(session, store, ranges, recon, progress, window, meta) as tracking:
        return tracking.finish()


class SessionTracking:
    """:func:`track_session` in steps, so that the chunks already stored are tracked while later
    ones are still being computed (``ergopose assess`` runs it in its main process while the
    worker processes run the 2D stage). The same chunks in the same order: the same table.

    Use as a context manager: :meth:`push_stored` as chunks are stored, then :meth:`finish`
    (the rest of the chunks, the table written). Leaving the block without :meth:`finish` (an
    error) leaves no table behind. ``seconds``: the time spent tracking so far.
    """

    def __init__(
        self,
        session: Session,
        store: ResultStore,
        ranges: Sequence[tuple[int, int]],
        recon: ReconSettings,
        progress: ProgressCallback | None,
        window: Window | None = None,
        meta: Mapping[str, Any] | None = None,
    ):
        self.session = session
        self.store = store
        self.ranges = list(ranges)
        self.recon = recon
        self.progress = progress
        self.window = window
        self.seconds = 0.0
        self._meta = dict(meta or {})
        self._next = 0
        self._stored: set[int] = set()
        self._shift = ShiftReconstruction(
            recon, fps=session.fps, cameras=session.calibrated_cameras, first_frame=ranges[0][0] if ranges else 0
        )
        self._refs = ShiftReferences(recon)
        self._writer: TracksWriter | None = None
        self._tracks: Tracks | None = None

    def __enter__(self) -> "SessionTracking":
        writer = TracksWriter(
            self.store.tracks_path,
            fps=self.session.fps,
            cameras=self.session.camera_names,
            settings=self.recon.as_dict(),
        )
        self._writer = writer.__enter__()
        if self.window is not None:
            writer.meta["window"] = self.window.as_dict()
        writer.meta.update(self._meta)
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        writer, self._writer = self._writer, None
        if writer is None:
            return
        if exc_type is None:  # left without finish(): no table from part of the chunks
            exc = RuntimeError("the tracking was left before finish()")
            exc_type, tb = RuntimeError, None
        writer.__exit__(exc_type, exc, tb)

    def push_stored(self, starts: Iterable[int]) -> None:
        """The chunks starting at ``starts`` are stored: track the next chunks in frame order
        among all stored so far, up to the first that is not. No progress is reported here: the
        stage that stores the chunks reports its own; :meth:`finish` reports the tracking from
        where it is."""
        self._stored.update(starts)
        while self._next < len(self.ranges) and self.ranges[self._next][0] in self._stored:
            self._push_next(report_progress=False)

    def push_stored_one(self, start: int) -> None:
        """:meth:`push_stored` for one chunk (a callback of the stage that stores them)."""
        self.push_stored((start,))

    def _push_next(self, report_progress: bool = True) -> None:
        if self._writer is None:
            raise RuntimeError("SessionTracking is used outside its with-block or after finish()")
        t0 = time.perf_counter()
        start, stop = self.ranges[self._next]
        chunk = self.store.load_chunk(start, stop)
        if chunk is None:
            raise InputError(
                f"the stored chunk of frames {start}-{stop - 1} is missing or unreadable; run the assessment again",
                path=self.store.chunk_path(start),
            )
        part = self._shift.push(chunk.people, start, stop)
        self._writer.write(part)
        self._refs.add(part)
        self._next += 1
        self.seconds += time.perf_counter() - t0
        if report_progress:
            report(self.progress, "tracking", self._next, len(self.ranges) + 1, unit="chunk")

    def finish(self) -> Tracks:
        """The chunks not tracked yet (all stored by now), the end of the shift, and the table
        written: the :class:`Tracks`."""
        if self._tracks is not None:
            return self._tracks
        if self._writer is None:
            raise RuntimeError("SessionTracking.finish() is called outside its with-block")
        report(self.progress, "tracking", self._next, len(self.ranges) + 1, unit="chunk")
        while self._next < len(self.ranges):
            self._push_next()
        writer = self._writer
        t0 = time.perf_counter()
        part = self._shift.finish()
        writer.write(part)
        self._refs.add(part)
        summary = worker_summary(self._shift)
        writer.set_workers(summary)
        rows = writer.rows
        self._writer = None
        writer.__exit__(None, None, None)
        self.seconds += time.perf_counter() - t0
        report(self.progress, "tracking", len(self.ranges) + 1, len(self.ranges) + 1, unit="chunk")
        self._tracks = Tracks(
            path=self.store.tracks_path,
            worker_summary=summary,
            references=self._refs,
            workers=tuple(self._refs.limbs.workers()),
            rows=rows,
            recon=self.recon,
            window=self.window,
        )
        return self._tracks


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
    #: more people reported than the settings say the area holds, with the pairs most likely one
    #: worker (:mod:`ergopose.pipeline.headcount`); None when not
    excess: Excess | None = None


def name_workers(
    session: Session, tracks: Tracks, progress: ProgressCallback | None, window: Window | None = None
) -> NamedTracks:
    """Who is who: the session's names.toml, then the stature match, then the tracker's pseudonym
    (:mod:`ergopose.pipeline.names`); names of names.toml that are not a tracked id, settings ids
    whose task inputs reach nobody, and more reported people than the settings say the area holds
    (with the pairs most likely one worker, :mod:`ergopose.pipeline.headcount`) are named in
    warnings.

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
    statures = {t: v.get("stature_estimate_m") for t, v in tracks.worker_summary.items()}
    excess = check_headcount(
        session, tracks.path, int(tracks.recon.expected_workers), naming.members, statures, tracks.window, progress
    )
    return NamedTracks(session=session, tracks=tracks, naming=naming, unused=tuple(unused), excess=excess)
