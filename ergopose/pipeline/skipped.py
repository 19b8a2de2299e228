"""Video frames an assessment skipped because they could not be read.

The 2D stage marks a frame of a camera it could not decode (or whose size was wrong) in the
chunk's ``detections`` (negative codes, :data:`ergopose.video.SKIP_CODES`) and goes on without
it. After the run they are gathered from the stored chunks into ``csv/frames_skipped.csv`` (one
row per camera and frame: camera, frame, time_s, reason; only the header when none was skipped)
and into the report's quality section (:class:`ergopose.report.context.SkippedFrames`).
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from ergopose.atomic import atomic_path
from ergopose.pipeline.store import ResultStore
from ergopose.report.context import MAX_SKIPPED_SPANS, SkippedFrames
from ergopose.video import SKIP_CODES

SKIPPED_CSV = "frames_skipped.csv"
_REASONS = {code: reason for reason, code in SKIP_CODES.items()}


def skipped_in_store(store: ResultStore) -> np.ndarray:
    """(k, 3) int64 rows (frame, camera index, code) of every skipped frame in the stored chunks
    (:class:`ergopose.pipeline.store.ResultStore`), in frame order, then camera order."""
    rows = [np.zeros((0, 3), np.int64)]
    for path in sorted(store.chunks_dir.glob("chunk_*.npz")):  # zero-padded names: frame order
        try:
            with np.load(path, allow_pickle=False) as data:
                start = int(data["start"])
                det = np.asarray(data["detections"])
        except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError):
            continue  # the tracking stage, which reads every chunk, has named it already
        frame, cam = np.nonzero(det < 0)
        rows.append(np.column_stack([frame + start, cam, det[frame, cam]]).astype(np.int64))
    return np.concatenate(rows)


def write_skipped_csv(
    path: str | Path, skipped: np.ndarray, camera_names: Sequence[str], fps: float, *, bom: bool = False
) -> Path:
    """csv/frames_skipped.csv from :func:`skipped_in_store` rows (written atomically; bom: with a UTF-8
    byte order mark)."""
    table = pd.DataFrame(
        {
            "camera": [camera_names[int(c)] for c in skipped[:, 1]],
            "frame": skipped[:, 0],
            "time_s": np.round(skipped[:, 0] / fps, 3),
            "reason": [_REASONS.get(int(k), "cannot be read") for k in skipped[:, 2]],
        }
    )
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False, lineterminator="\n", encoding="utf-8-sig" if bom else "utf-8")
    return Path(path)


def skipped_records(skipped: np.ndarray, camera_names: Sequence[str], fps: float) -> tuple[SkippedFrames, ...]:
    """Per camera with skipped frames, a :class:`ergopose.report.context.SkippedFrames`."""
    out: list[SkippedFrames] = []
    for c, name in enumerate(camera_names):
        frames = skipped[skipped[:, 1] == c, 0]
        if not frames.size:
            continue
        breaks = np.flatnonzero(np.diff(frames) > 1)
        firsts = np.concatenate([frames[:1], frames[breaks + 1]])
        lasts = np.concatenate([frames[breaks], frames[-1:]])
        spans = tuple(
            (float(a / fps), float(b / fps)) for a, b in zip(firsts[:MAX_SKIPPED_SPANS], lasts[:MAX_SKIPPED_SPANS])
        )
        out.append(SkippedFrames(camera=name, frames=int(frames.size), spans_s=spans))
    return tuple(out)


__all__ = ["SKIPPED_CSV", "skipped_in_store", "write_skipped_csv", "skipped_records"]
