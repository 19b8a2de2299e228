"""Reconstruct a whole session: 2D detections of every frame in, tracks table out.

:func:`reconstruct_session` reads the frames lazily (any iterable), processes them in chunks of
``chunk_frames`` (association and triangulation, then :class:`ShiftReconstruction`), writes the
finished rows of each chunk to the Parquet tracks table as it goes, and returns a summary.
Memory is bounded by the chunk size and the smoother's window, not by the shift's length.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Sequence, SupportsFloat

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.errors import InputError
from ergopose.geometry.camera import Camera
from ergopose.keypoints import LIMBS
from ergopose.progress import ProgressCallback, report
from ergopose.recon.pipeline import ShiftReconstruction, TrackFrames
from ergopose.recon.settings import ReconSettings
from ergopose.recon.table import TracksWriter
from ergopose.recon.triangulate import reconstruct_frames
from ergopose.records import Detections2D


@dataclass(frozen=True)
class SessionSummary:
    """What a reconstruction run produced.

    path: the tracks table (None when only kept in memory). frames: frames processed.
    workers: worker names in order of appearance. stature_m / limb_medians_m: per worker, the
    stature estimate and the median raw limb lengths (keypoints.LIMBS names -> metres).
    people_pairs / people_single_view: person rows triangulated from two or more cameras / seen by one.
    rows: worker-frame rows written. seconds: wall time.
    """

    path: Path | None
    frames: int
    workers: tuple[str, ...]
    stature_m: dict[str, float]
    limb_medians_m: dict[str, FloatArray]
    people_pairs: int
    people_single_view: int
    rows: int
    seconds: float


def _chunks(frames: Iterable[Sequence[Detections2D]], size: int) -> Iterator[list[Sequence[Detections2D]]]:
    buf: list[Sequence[Detections2D]] = []
    for f in frames:
        buf.append(f)
        if len(buf) >= size:
            yield buf
            buf = []
    if buf:
        yield buf


def worker_summary(shift: ShiftReconstruction) -> dict[str, dict[str, Any]]:
    """{worker: {"stature_estimate_m", "limb_medians_m": {limb: metres}}} for the table metadata."""
    out: dict[str, dict[str, Any]] = {}
    statures = shift.stature_estimates()
    for name, med in shift.limb_medians().items():
        out[name] = {
            "stature_estimate_m": _num(statures.get(name)),
            "limb_medians_m": {limb: _num(v) for (limb, _, _), v in zip(LIMBS, med)},
        }
    return out


def _num(v: SupportsFloat | None) -> float | None:
    return None if v is None or not math.isfinite(float(v)) else round(float(v), 6)


def reconstruct_session(
    frames: Iterable[Sequence[Detections2D]],
    out_path: str | os.PathLike[str] | None,
    *,
    fps: float,
    cameras: Sequence[Camera] | None = None,
    settings: ReconSettings | None = None,
    chunk_frames: int = 1200,
    first_frame: int = 0,
    progress: ProgressCallback | None = None,
    total_frames: int | None = None,
) -> tuple[SessionSummary, TrackFrames | None]:
    """Associate, triangulate, track, smooth and write a session.

    frames: per frame, one Detections2D per camera (one or more cameras, frame indices increasing; frames
        may be missing: they count as frames where nobody was seen).
    out_path: the Parquet tracks table; None keeps the rows in memory and returns them.
    cameras: the Camera objects (for lens angles); settings: ReconSettings.
    Returns (summary, TrackFrames if out_path is None else None).
    """
    settings = settings or ReconSettings()
    if chunk_frames < 1:
        raise InputError(f"must be at least 1, got {chunk_frames}", field="chunk_frames")
    t0 = time.perf_counter()
    shift = ShiftReconstruction(settings, fps, cameras, first_frame=first_frame)
    kept: list[TrackFrames] = []
    counts = {"pairs": 0, "single": 0, "frames": 0, "rows": 0}
    cam_names: tuple[str, ...] = tuple(c.name for c in cameras) if cameras else ()

    def run(sink: Callable[[TrackFrames], None]) -> None:
        for chunk in _chunks(frames, chunk_frames):
            people = reconstruct_frames(chunk, settings)
            counts["pairs"] += int(np.sum(people.n_cameras >= 2))
            counts["single"] += int(np.sum(people.n_cameras == 1))
            stop = chunk[-1][0].frame + 1
            done = shift.push(people, shift.next_frame, stop)
            counts["frames"] = stop - first_frame
            sink(done)
            report(progress, "reconstruction", counts["frames"], total_frames, unit="frame")
        sink(shift.finish())

    if out_path is None:

        def keep(tf: TrackFrames) -> None:
            counts["rows"] += len(tf)
            kept.append(tf)

        run(keep)
    else:
        with TracksWriter(out_path, fps=fps, cameras=cam_names, settings=settings.as_dict()) as writer:

            def write(tf: TrackFrames) -> None:
                counts["rows"] += len(tf)
                writer.write(tf)

            run(write)
            writer.set_workers(worker_summary(shift))
    summary = SessionSummary(
        path=None if out_path is None else Path(out_path),
        frames=counts["frames"],
        workers=tuple(shift.limb_medians().keys()),
        stature_m=shift.stature_estimates(),
        limb_medians_m={k: v for k, v in shift.limb_medians().items()},
        people_pairs=counts["pairs"],
        people_single_view=counts["single"],
        rows=counts["rows"],
        seconds=time.perf_counter() - t0,
    )
    return summary, (TrackFrames.concat(kept) if out_path is None else None)
