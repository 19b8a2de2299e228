"""Helpers for the evaluation tests: results folders made from the ground truth itself."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ergopose.cli import main


def simulate(out: Path, *, workers: int = 2, minutes: float = 0.25, seed: int = 0, size: str = "320x240") -> Path:
    code = main(
        [
            "simulate",
            "--out",
            str(out),
            "--workers",
            str(workers),
            "--minutes",
            str(minutes),
            "--seed",
            str(seed),
            "--size",
            size,
        ]
    )
    assert code == 0
    return out


def ground_truth_tracks(gt, worker_order=None):
    """TrackFrames whose every row is the ground truth: worker number k+1 is simulated worker
    ``worker_order[k]`` (default: the ground truth's order), every frame, raw = final = true joints."""
    from ergopose.keypoints import NUM_JOINTS
    from ergopose.recon.pipeline import TrackFrames

    order = list(range(len(gt.worker_ids))) if worker_order is None else list(worker_order)
    F, P = gt.n_frames, len(order)
    frame = np.repeat(np.arange(F), P)
    person = np.tile(np.asarray(order), F)
    worker = np.tile(np.arange(1, P + 1), F)
    points = gt.joints_world[frame, person]
    angle = np.degrees(np.nanmax(gt.theta.astype(np.float64), axis=1))[frame, person]  # (n, 33)
    n = len(frame)
    return TrackFrames(
        worker=worker.astype(np.int64),
        frame=frame.astype(np.int64),
        time_s=gt.times_s[frame],
        points_world=points.copy(),
        raw_points_world=points.copy(),
        confidence=np.ones((n, NUM_JOINTS)),
        reprojection_error_px=np.zeros((n, NUM_JOINTS)),
        views=np.full((n, NUM_JOINTS), 2, np.int8),
        gap_filled=np.zeros((n, NUM_JOINTS), bool),
        gated=np.zeros((n, NUM_JOINTS), bool),
        smoothed=False,
        lens_angle_deg=angle,
    )


def write_results(session_dir: Path, out: Path, tracks, statures: dict | None = None) -> Path:
    """An 'ergopose assess'-shaped results folder from TrackFrames: the tracks table written with
    the project's TracksWriter, and per worker the frames CSV from the pipeline's own scoring
    (joint angles -> task factors -> RULA/REBA) and CSV writer. With ``statures`` ({tracked id:
    metres}, stored as the table's stature estimates) the workers are named after the settings'
    workers by stature, as assess does."""
    from ergopose.pipeline.identify import identify_by_stature
    from ergopose.ergonomics.export import write_worker_steps_csv
    from ergopose.pipeline.inputs import scoring_settings
    from ergopose.pipeline.score import score_worker
    from ergopose.recon.settings import ReconSettings
    from ergopose.recon.table import TracksWriter
    from ergopose.recon.track_records import identity_name
    from ergopose.session import load_session

    session = load_session(session_dir, check_videos=False)
    with TracksWriter(
        out / "pipeline" / "tracks.parquet",
        fps=session.fps,
        cameras=session.camera_names,
        settings=ReconSettings().as_dict(),
    ) as writer:
        writer.write(tracks)
        if statures:
            writer.set_workers({k: {"stature_estimate_m": v} for k, v in statures.items()})
    ident = identify_by_stature(dict(statures or {}), session)
    scoring = scoring_settings(session)
    for w in tracks.workers:
        wid = ident.rename(identity_name(w))
        scored = score_worker(session, tracks.worker_rows(w), wid, scoring, None)
        write_worker_steps_csv(out / "csv" / f"{wid}_steps.csv", scored.frames)
    return out


SETTINGS_TWO_WORKERS = """\
format_version = 1
recorded_at = 2024-03-04T08:00:00+01:00
fps = 12.0

[[cameras]]
name = "cam_1"
video = "a.mp4"

[[cameras]]
name = "cam_2"
video = "b.mp4"

[identification]
by_stature = true

[workers.w1]
stature_m = 1.80

[workers.w2]
stature_m = 1.60
"""


def video_session(root: Path, frames: int = 3) -> Path:
    """A session folder without ground truth, in a fraction of a second: the simulator's two-camera
    rig at 160 x 120, two videos of ``frames`` grey frames, settings naming w1 (1.80 m) and w2
    (1.60 m) with matching by stature on."""
    import cv2

    from ergopose.geometry.calibration_file import save_calibration
    from ergopose.sim.scene import rig_cameras

    root.mkdir(parents=True)
    save_calibration(root / "calibration.toml", rig_cameras(160, 120))
    for name in ("a.mp4", "b.mp4"):
        writer = cv2.VideoWriter(str(root / name), cv2.VideoWriter.fourcc(*"mp4v"), 12.0, (160, 120))
        for k in range(frames):
            writer.write(np.full((120, 160, 3), 40 * k, np.uint8))
        writer.release()
    (root / "settings.toml").write_text(SETTINGS_TWO_WORKERS, encoding="utf-8")
    return root
