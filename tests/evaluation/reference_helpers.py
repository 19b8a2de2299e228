"""An assessment's results folder (tracks table + frames CSV files) made from known 3D joints, with
the product's own angle and scoring code, for testing ``evaluate --reference``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ergopose.ergonomics.angles import joint_angles
from ergopose.ergonomics.export import write_worker_steps_csv
from ergopose.ergonomics.scoring import score_posture
from ergopose.evaluation.markers import map_markers
from ergopose.evaluation.trc import read_trc
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS
from ergopose.recon.pipeline import TrackFrames
from ergopose.recon.table import write_tracks
from ergopose.recon.track_records import identity_name


def trc_joints(path) -> tuple[np.ndarray, np.ndarray]:
    """(F, 33, 3) BlazePose joints of a TRC in its own axes (NaN where no marker), (F,) times."""
    trc = read_trc(path)
    joints = np.full((len(trc.times_s), NUM_JOINTS, 3), np.nan)
    for marker, joint in map_markers(trc.markers).items():
        joints[:, JOINT_INDEX[joint]] = trc.points_trc[:, trc.markers.index(marker)]
    return joints, trc.times_s


def make_results(
    out: Path, people: list[tuple[int, np.ndarray, np.ndarray]], fps: float, names: dict[int, str] | None = None
) -> Path:
    """people: (worker number, frames (n,), points_world (n, 33, 3)); writes OUT/pipeline/tracks.parquet
    and OUT/csv/<name>_steps.csv (name: names[worker] or worker_<n>)."""
    rows = []
    for w, frames, pts in people:
        order = np.argsort(frames)
        rows.append((np.full(len(frames), w, np.int64), np.asarray(frames, np.int64)[order], pts[order]))
    worker = np.concatenate([r[0] for r in rows])
    frame = np.concatenate([r[1] for r in rows])
    pts = np.concatenate([r[2] for r in rows])
    order = np.lexsort((worker, frame))
    worker, frame, pts = worker[order], frame[order], pts[order]
    n = len(frame)
    ok = np.isfinite(pts).all(-1)
    tf = TrackFrames(
        worker=worker,
        frame=frame,
        time_s=frame / fps,
        points_world=pts,
        raw_points_world=pts.copy(),
        confidence=np.where(ok, 0.9, 0.0),
        reprojection_error_px=np.where(ok, 1.0, np.nan),
        views=np.where(ok, 2, 0).astype(np.int8),
        gap_filled=np.zeros((n, NUM_JOINTS), bool),
        gated=np.zeros((n, NUM_JOINTS), bool),
        smoothed=True,
        lens_angle_deg=np.full((n, NUM_JOINTS), 30.0),
    )
    (out / "pipeline").mkdir(parents=True, exist_ok=True)
    write_tracks(out / "pipeline" / "tracks.parquet", tf, fps=fps, cameras=("cam_01", "cam_02"))
    for w, frames, points in people:
        order = np.argsort(frames)
        f, p = np.asarray(frames, np.int64)[order], points[order]
        posture = joint_angles(p, f / fps).to_frame().reset_index(drop=True)
        scores = score_posture(posture, with_events=True)
        name = (names or {}).get(w, identity_name(w))
        ident = pd.DataFrame({"worker": name, "frame": f})
        write_worker_steps_csv(out / "csv" / f"{name}_steps.csv", pd.concat([ident, posture, scores], axis=1))
    return out
