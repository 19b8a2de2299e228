"""The Parquet tracks table: round trip, atomic writing, metadata, partial reads."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from ergopose.errors import InputError
from ergopose.keypoints import BLAZEPOSE33
from ergopose.recon.pipeline import TrackFrames
from ergopose.recon.table import (
    COLUMNS,
    TracksWriter,
    display_names,
    read_metadata,
    read_tracks,
    table_to_frames,
    write_tracks,
)


def _frames(rng, n=5, workers=(1, 3)) -> TrackFrames:
    w = np.tile(np.array(workers), n)
    f = np.repeat(np.arange(n), len(workers))
    m = len(w)
    X = rng.normal(size=(m, 33, 3))
    X[0, 4] = np.nan
    raw = X + 0.01
    raw[1, :] = np.nan
    return TrackFrames(
        worker=w,
        frame=f,
        time_s=f / 12.0,
        points_world=X,
        raw_points_world=raw,
        confidence=rng.uniform(0, 1, (m, 33)),
        reprojection_error_px=rng.uniform(0, 5, (m, 33)),
        views=rng.integers(0, 3, (m, 33)).astype(np.int8),
        gap_filled=rng.random((m, 33)) < 0.1,
        gated=rng.random((m, 33)) < 0.05,
        smoothed=True,
        lens_angle_deg=rng.uniform(0, 80, (m, 33)),
    )


def test_round_trip(tmp_path, rng):
    tf = _frames(rng)
    path = write_tracks(
        tmp_path / "tracks.parquet",
        tf,
        fps=12.0,
        cameras=("cam_1", "cam_2"),
        settings={"smoothing": True},
        workers={"worker_1": {"stature_estimate_m": 1.7}},
    )
    table = read_tracks(path)
    df = table.data
    assert tuple(df.columns) == COLUMNS and len(df) == len(tf) * 33
    assert table.workers == ["worker_1", "worker_3"] and table.fps == 12.0
    assert table.metadata["cameras"] == ["cam_1", "cam_2"]
    assert table.metadata["workers"]["worker_1"]["stature_estimate_m"] == 1.7
    row = df.iloc[33 + 7]  # second worker-frame row, joint 7
    assert row["worker"] == "worker_3" and row["joint"] == BLAZEPOSE33[7] and row["frame"] == 0
    assert np.isclose(row["x"], tf.points_world[1, 7, 0], atol=1e-6)
    back = table_to_frames(table)
    for name in ("worker", "frame", "views", "gap_filled", "gated"):
        assert np.array_equal(getattr(back, name), getattr(tf, name)), name
    for name in ("time_s", "points_world", "raw_points_world", "confidence", "reprojection_error_px", "lens_angle_deg"):
        assert np.allclose(getattr(back, name), getattr(tf, name), atol=1e-5, equal_nan=True), name
    # smoothed is per row: false where there is no position.
    assert not df["smoothed"].iloc[4] and df["smoothed"].iloc[5]


def test_partial_reads(tmp_path, rng):
    path = write_tracks(tmp_path / "t.parquet", _frames(rng), fps=12.0)
    one = read_tracks(path, workers=["worker_3"], columns=["worker", "frame", "joint", "x"])
    assert list(one.data.columns) == ["worker", "frame", "joint", "x"]
    assert set(one.data["worker"]) == {"worker_3"} and len(one.data) == 5 * 33
    with pytest.raises(InputError, match="unknown column"):
        read_tracks(path, columns=["nope"])


def test_writing_is_atomic_and_chunked(tmp_path, rng):
    path = tmp_path / "t.parquet"
    write_tracks(path, _frames(rng, n=2), fps=12.0)
    before = path.read_bytes()
    with pytest.raises(RuntimeError):
        with TracksWriter(path, fps=12.0) as w:
            w.write(_frames(rng, n=3))
            raise RuntimeError("crash in the middle")
    assert path.read_bytes() == before  # the old table is intact
    assert [p.name for p in tmp_path.iterdir()] == ["t.parquet"]  # no temporary left
    with TracksWriter(path, fps=12.0) as w:
        w.write(_frames(rng, n=3))
        w.write(_frames(rng, n=4))
    assert pq.ParquetFile(path).num_row_groups == 2 and len(read_tracks(path).data) == 7 * 2 * 33


def test_not_a_tracks_table(tmp_path):
    other = tmp_path / "other.parquet"
    pq.write_table(pa.table({"a": [1, 2]}), other)
    with pytest.raises(InputError, match="not an ergopose tracks table"):
        read_metadata(other)
    with pytest.raises(InputError, match="does not exist"):
        read_tracks(tmp_path / "missing.parquet")
    (tmp_path / "junk.parquet").write_text("junk")
    with pytest.raises(InputError, match="not a readable Parquet"):
        read_tracks(tmp_path / "junk.parquet")


def test_display_names():
    assert display_names(["worker_1", "worker_2"], {"worker_2": "Ana"}) == {"worker_1": "worker_1", "worker_2": "Ana"}
    assert isinstance(pd.DataFrame(), pd.DataFrame)


def test_the_body_model_s_flags_round_trip_and_older_tables_read_without_them(tmp_path, rng):
    """inferred, limited and std_x/y/z come back as written; a version 2 table (written before
    the ``limited`` column) reads as nothing held at a limit, the rest unchanged."""
    base = _frames(rng)
    m = len(base)
    tf = TrackFrames(
        **{
            **base.__dict__,
            "inferred": rng.random((m, 33)) < 0.2,
            "limited": rng.random((m, 33)) < 0.1,
            "std_world": rng.uniform(0.001, 0.05, (m, 33, 3)),
        }
    )
    path = write_tracks(tmp_path / "tracks.parquet", tf, fps=12.0, cameras=("cam_1", "cam_2"))
    assert read_metadata(path)["version"] == 3
    back = table_to_frames(read_tracks(path))
    assert tf.limited.any() and np.array_equal(back.limited, tf.limited)
    assert np.array_equal(back.inferred, tf.inferred)
    assert np.allclose(back.std_world, tf.std_world, atol=1e-7)
    # the same file as version 2 wrote it: no limited column, version 2 in the metadata
    info = read_metadata(path)
    info["version"] = 2
    old = pq.read_table(path).drop_columns(["limited"])
    with pq.ParquetWriter(tmp_path / "v2.parquet", old.schema) as writer:
        writer.write_table(old)
        writer.add_key_value_metadata({b"ergopose.tracks": json.dumps(info).encode()})
    assert read_metadata(tmp_path / "v2.parquet")["version"] == 2
    table = read_tracks(tmp_path / "v2.parquet")
    assert tuple(table.data.columns) == COLUMNS and not table.data["limited"].any()
    v2 = table_to_frames(table)
    assert not v2.limited.any() and np.array_equal(v2.inferred, tf.inferred)
    assert np.allclose(v2.points_world, tf.points_world, atol=1e-6, equal_nan=True)
