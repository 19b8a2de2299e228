"""The tracks table of a session: one row per worker, frame and joint, as Parquet.

Columns (docs/reconstruction.md has the full definitions):

=====================  =========  ==========================================================
worker                 string     pseudonymous identity: worker_1, worker_2, ...
frame                  int64      frame index in the session
time_s                 float64    frame / fps, seconds from the start of the session
joint                  string     keypoints.BLAZEPOSE33 name
x, y, z                float32    final position, metres, world frame (floor z = 0, z up);
                                  smoothed when ``smoothed``; NaN where unknown
confidence             float32    mean 2D confidence of the cameras used (0 = not seen)
reprojection_error_px  float32    RMS reprojection error of the raw triangulation (NaN = none)
views                  int8       cameras whose 2D keypoint was used (2 = triangulated,
                                  1 = one camera only, no 3D; 0 = none)
smoothed               bool       x, y, z come from the Kalman/RTS smoother (else raw)
gap_filled             bool       x, y, z filled by the smoother inside a short gap
gated                  bool       the raw point was ignored by the smoother as an outlier
raw_x, raw_y, raw_z    float32    the triangulation before smoothing (NaN = not triangulated)
lens_angle_deg         float32    largest angle off the cameras' axes of the joint's final
                                  position (or of the worker's body centre where that is NaN)
inferred               bool       the position was placed by the body model: fewer than two
                                  cameras saw the joint with min_confidence
limited                bool       a joint limit of the body model held the joint (elbow, knee,
                                  or the face's nose and eyes): the cameras put it past the limit
std_x, std_y, std_z    float32    standard deviation of x, y, z (metres; NaN where unknown)
=====================  =========  ==========================================================

Rows exist for every frame a worker's track is alive (first to last observation of each track;
coasting frames included). Rows are sorted by frame, then worker, then joint (schema order).

The file's key-value metadata ``ergopose.tracks`` holds JSON: format version, fps, camera
names, the reconstruction settings, and per worker the stature estimate and median limb
lengths (written when the file is closed). The file is written atomically
(:func:`ergopose.atomic.atomic_path`): under its final name it is always complete. Writing is
chunked (:class:`TracksWriter`: one row group per write), so a whole shift never has to be in
memory; :func:`read_tracks` can read one worker or a few columns at a time.
"""

from __future__ import annotations

import contextlib
import json
import os
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, Literal, Mapping, Sequence

import numpy as np
from numpy.typing import DTypeLike
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from ergopose.atomic import atomic_path
from ergopose.errors import InputError
from ergopose.keypoints import BLAZEPOSE33, JOINT_INDEX, NUM_JOINTS
from ergopose.recon.pipeline import TrackFrames
from ergopose.recon.track_records import identity_name

FORMAT = "ergopose.tracks"
FORMAT_VERSION = 3  # 2: inferred, std_x/y/z (the body model); 3: limited; older files read with defaults
METADATA_KEY = b"ergopose.tracks"

SCHEMA = pa.schema(
    [
        ("worker", pa.string()),
        ("frame", pa.int64()),
        ("time_s", pa.float64()),
        ("joint", pa.string()),
        ("x", pa.float32()),
        ("y", pa.float32()),
        ("z", pa.float32()),
        ("confidence", pa.float32()),
        ("reprojection_error_px", pa.float32()),
        ("views", pa.int8()),
        ("smoothed", pa.bool_()),
        ("gap_filled", pa.bool_()),
        ("gated", pa.bool_()),
        ("raw_x", pa.float32()),
        ("raw_y", pa.float32()),
        ("raw_z", pa.float32()),
        ("lens_angle_deg", pa.float32()),
        ("inferred", pa.bool_()),
        ("std_x", pa.float32()),
        ("std_y", pa.float32()),
        ("std_z", pa.float32()),
        ("limited", pa.bool_()),
    ]
)
COLUMNS = tuple(SCHEMA.names)
#: Columns a version 1 table lacks (read as not inferred, unknown deviation), and a version 2
#: table (read as not limited).
_ADDED_IN_V2 = ("inferred", "std_x", "std_y", "std_z")
_ADDED_IN_V3 = ("limited",)
_ADDED = _ADDED_IN_V2 + _ADDED_IN_V3


def frames_to_arrow(tf: TrackFrames) -> pa.Table:
    """The long form of :class:`TrackFrames`: n rows x 33 joints -> a table with SCHEMA."""
    n = len(tf)
    J = NUM_JOINTS
    names = np.array([identity_name(w) for w in range(int(tf.worker.max()) + 1)] if n else [], dtype=object)
    worker = (
        pa.DictionaryArray.from_arrays(pa.array(np.repeat(tf.worker, J).astype(np.int32)), pa.array(names, pa.string()))
        if n
        else pa.array([], pa.string())
    )
    joint = pa.DictionaryArray.from_arrays(
        pa.array(np.tile(np.arange(J, dtype=np.int32), n)), pa.array(BLAZEPOSE33, pa.string())
    )
    # TrackFrames.__post_init__ fills them
    assert tf.std_world is not None and tf.inferred is not None and tf.limited is not None
    P = tf.points_world.reshape(-1, 3).astype(np.float32)
    R = tf.raw_points_world.reshape(-1, 3).astype(np.float32)
    S = tf.std_world.reshape(-1, 3).astype(np.float32)
    cols = {
        "worker": worker.cast(pa.string()) if n else worker,
        "frame": pa.array(np.repeat(tf.frame, J)),
        "time_s": pa.array(np.repeat(tf.time_s, J)),
        "joint": joint.cast(pa.string()),
        "x": pa.array(P[:, 0]),
        "y": pa.array(P[:, 1]),
        "z": pa.array(P[:, 2]),
        "confidence": pa.array(tf.confidence.reshape(-1).astype(np.float32)),
        "reprojection_error_px": pa.array(tf.reprojection_error_px.reshape(-1).astype(np.float32)),
        "views": pa.array(tf.views.reshape(-1).astype(np.int8)),
        "smoothed": pa.array(np.repeat(np.isfinite(P).all(axis=1) & tf.smoothed, 1)),
        "gap_filled": pa.array(tf.gap_filled.reshape(-1)),
        "gated": pa.array(tf.gated.reshape(-1)),
        "raw_x": pa.array(R[:, 0]),
        "raw_y": pa.array(R[:, 1]),
        "raw_z": pa.array(R[:, 2]),
        "lens_angle_deg": pa.array(tf.lens_angle_deg.reshape(-1).astype(np.float32)),
        "inferred": pa.array(tf.inferred.reshape(-1)),
        "std_x": pa.array(S[:, 0]),
        "std_y": pa.array(S[:, 1]),
        "std_z": pa.array(S[:, 2]),
        "limited": pa.array(tf.limited.reshape(-1)),
    }
    return pa.Table.from_pydict(cols, schema=SCHEMA)


class TracksWriter:
    """Write a tracks table chunk by chunk, atomically::

        with TracksWriter(path, fps=12.0, cameras=("cam_1", "cam_2"), settings=s.as_dict()) as w:
            w.write(track_frames)        # any number of times
            w.set_workers({...})         # optional summary per worker, stored at close

    If the block raises, nothing appears under ``path`` (an older file there stays intact).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        fps: float,
        cameras: Sequence[str] = (),
        settings: Mapping[str, Any] | None = None,
        compression: str = "zstd",
    ) -> None:
        self.path = Path(path)
        self.meta = {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "fps": float(fps),
            "cameras": list(cameras),
            "settings": dict(settings or {}),
            "workers": {},
        }
        self.compression = compression
        self.rows = 0
        self._stack: contextlib.ExitStack | None = None
        self._writer: pq.ParquetWriter | None = None

    def __enter__(self) -> "TracksWriter":
        self._stack = contextlib.ExitStack()
        tmp = self._stack.enter_context(atomic_path(self.path))
        self._writer = pq.ParquetWriter(tmp, SCHEMA, compression=self.compression)
        return self

    def write(self, tf: TrackFrames) -> None:
        if self._writer is None:
            raise RuntimeError("use TracksWriter in a with block")
        if tf is None or len(tf) == 0:
            return
        table = frames_to_arrow(tf)
        self._writer.write_table(table)
        self.rows += table.num_rows

    def set_workers(self, workers: Mapping[str, Mapping[str, Any]]) -> None:
        """Per-worker summary (e.g. stature estimate, limb medians) stored in the metadata."""
        self.meta["workers"] = {k: dict(v) for k, v in workers.items()}

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> Literal[False]:
        assert self._stack is not None and self._writer is not None
        try:
            if exc_type is None:
                self._writer.add_key_value_metadata({METADATA_KEY: json.dumps(self.meta, allow_nan=True).encode()})
            self._writer.close()
        finally:
            self._stack.__exit__(exc_type, exc, tb)
        return False


def write_tracks(
    path: str | os.PathLike[str],
    tf: TrackFrames,
    *,
    fps: float,
    cameras: Sequence[str] = (),
    settings: Mapping[str, Any] | None = None,
    workers: Mapping[str, Mapping[str, Any]] | None = None,
) -> Path:
    """Write one TrackFrames as a tracks table (atomically); returns the path."""
    with TracksWriter(path, fps=fps, cameras=cameras, settings=settings) as w:
        w.write(tf)
        if workers:
            w.set_workers(workers)
    return Path(path)


@dataclass(frozen=True)
class TracksTable:
    """A tracks table read back: ``data`` (pandas, COLUMNS; worker and joint categorical) and
    ``metadata`` (the JSON dictionary described in the module docstring)."""

    data: pd.DataFrame
    metadata: dict[str, Any]

    @property
    def fps(self) -> float:
        return float(self.metadata.get("fps", float("nan")))

    @property
    def workers(self) -> list[str]:
        return sorted(self.data["worker"].unique().tolist(), key=_worker_key)


def _worker_key(name: str) -> tuple[str, int]:
    head, _, num = str(name).rpartition("_")
    return (head, int(num)) if num.isdigit() else (str(name), 0)


def read_metadata(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The table's ``ergopose.tracks`` metadata; InputError if the file is not a tracks table."""
    p = Path(path)
    try:
        file_meta = pq.read_metadata(p)
        schema = file_meta.schema.to_arrow_schema()
    except FileNotFoundError:
        raise InputError("the tracks table does not exist", path=p) from None
    except (OSError, pa.ArrowInvalid) as exc:
        raise InputError(f"not a readable Parquet file ({exc})", path=p) from None
    raw = (file_meta.metadata or {}).get(METADATA_KEY)
    if raw is None:
        raise InputError("not an ergopose tracks table (no ergopose.tracks metadata)", path=p)
    meta: dict[str, Any] = json.loads(raw)
    if meta.get("format") != FORMAT or int(meta.get("version", 0)) > FORMAT_VERSION:
        raise InputError(
            f"unsupported tracks table format {meta.get('format')!r} version {meta.get('version')!r}", path=p
        )
    missing = [c for c in COLUMNS if c not in schema.names and c not in _ADDED]
    if missing:
        raise InputError(f"columns missing: {', '.join(missing)}", path=p)
    return meta


def read_tracks(
    path: str | os.PathLike[str], *, workers: Sequence[str] | None = None, columns: Sequence[str] | None = None
) -> TracksTable:
    """Read a tracks table (optionally only some workers and/or columns)."""
    meta = read_metadata(path)
    cols = list(COLUMNS) if columns is None else list(columns)
    unknown = [c for c in cols if c not in COLUMNS]
    if unknown:
        raise InputError(f"unknown column(s) {', '.join(unknown)}; known: {', '.join(COLUMNS)}", field="columns")
    filters = [("worker", "in", list(workers))] if workers else None
    present = set(pq.read_schema(path).names)
    absent = [c for c in cols if c not in present]
    table = pq.read_table(path, columns=[c for c in cols if c in present], filters=filters)
    df = table.to_pandas()
    for c in absent:  # a version 1 or 2 table
        df[c] = False if c in ("inferred", "limited") else np.float32(np.nan)
    for c in ("worker", "joint"):
        if c in df:
            df[c] = df[c].astype("category")
    return TracksTable(data=df, metadata=meta)


def table_to_frames(table: TracksTable | pd.DataFrame) -> TrackFrames:
    """The wide TrackFrames form of a (full-column) tracks table, for downstream arrays."""
    df = table.data if isinstance(table, TracksTable) else table
    missing = [c for c in COLUMNS if c not in df.columns and c not in _ADDED]
    if missing:
        raise InputError(f"columns missing: {', '.join(missing)}", field="tracks")
    worker_num = np.array([int(str(w).rpartition("_")[2]) for w in df["worker"].astype(str)], dtype=np.int64)
    joint = np.array([JOINT_INDEX[str(j)] for j in df["joint"].astype(str)], dtype=np.int64)
    frame = df["frame"].to_numpy(np.int64)
    key = frame * (1 << 20) + worker_num
    uniq, inv = np.unique(key, return_inverse=True)
    n = len(uniq)
    J = NUM_JOINTS

    def grid(col: None, fill: Any, dtype: DTypeLike = np.float64, k: int | None = None) -> np.ndarray:
        out: np.ndarray = np.full((n, J) if k is None else (n, J, k), fill, dtype=dtype)
        return out

    pts = grid(None, np.nan, k=3)
    raw = grid(None, np.nan, k=3)
    pts[inv, joint] = df[["x", "y", "z"]].to_numpy(np.float64)
    raw[inv, joint] = df[["raw_x", "raw_y", "raw_z"]].to_numpy(np.float64)
    conf = grid(None, 0.0)
    conf[inv, joint] = df["confidence"].to_numpy(np.float64)
    err = grid(None, np.nan)
    err[inv, joint] = df["reprojection_error_px"].to_numpy(np.float64)
    views = grid(None, 0, np.int8)
    views[inv, joint] = df["views"].to_numpy(np.int8)
    gap = grid(None, False, bool)
    gap[inv, joint] = df["gap_filled"].to_numpy(bool)
    gated = grid(None, False, bool)
    gated[inv, joint] = df["gated"].to_numpy(bool)
    ang = grid(None, np.nan)
    ang[inv, joint] = df["lens_angle_deg"].to_numpy(np.float64)
    inferred = grid(None, False, bool)
    std = grid(None, np.nan, k=3)
    if "inferred" in df:
        inferred[inv, joint] = df["inferred"].to_numpy(bool)
    limited = grid(None, False, bool)
    if "limited" in df:
        limited[inv, joint] = df["limited"].to_numpy(bool)
    if "std_x" in df:
        std[inv, joint] = df[["std_x", "std_y", "std_z"]].to_numpy(np.float64)
    time_s = np.zeros(n)
    time_s[inv] = df["time_s"].to_numpy(np.float64)
    smoothed = bool(df["smoothed"].any()) if len(df) else True
    return TrackFrames(
        worker=uniq % (1 << 20),
        frame=uniq // (1 << 20),
        time_s=time_s,
        points_world=pts,
        raw_points_world=raw,
        confidence=conf,
        reprojection_error_px=err,
        views=views,
        gap_filled=gap,
        gated=gated,
        smoothed=smoothed,
        lens_angle_deg=ang,
        inferred=inferred,
        std_world=std,
        limited=limited,
    )


def display_names(workers: Sequence[str], names: Mapping[str, str] | None = None) -> dict[str, str]:
    """Names to show for pseudonymous workers: ``names`` (from the session settings, worker id ->
    name) where given, else the pseudonym itself."""
    names = dict(names or {})
    return {w: str(names.get(w, w)) for w in workers}
