"""Helpers of the pipeline tests that assess the tiny simulated session (its fixtures
``tiny_session`` and ``reference`` are in tests/conftest.py)."""

from __future__ import annotations

import re
from pathlib import Path

#: A progress bar line on stderr (not a message for the user).
PROGRESS_LINE = re.compile(r"^\s*[\w ]+ \[[#-]+\] ")


def assess_args(session, out, model_dir, *extra):
    """``ergopose assess`` arguments for the tiny session: chunks of 0.5 s (6 frames, 6 chunks)."""
    return [
        "assess",
        "--session",
        str(session),
        "--out",
        str(out),
        "--model-dir",
        str(model_dir),
        "--chunk-seconds",
        "0.5",
        *extra,
    ]


def csv_bytes(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "csv").glob("*.csv"))}


#: The warning that task inputs of the settings reach no tracked person. The simulated sessions'
#: settings give loads for w1, w2 (the simulation's ground truth) with stature matching off, so
#: every assessment of one warns (tests/pipeline/test_workers.py checks that warning).
TASK_INPUTS_WARNING = "are applied to nobody"


def user_lines(err: str) -> list[str]:
    """The lines of stderr meant for the user (progress bars and model-runtime chatter left out),
    except the simulated sessions' TASK_INPUTS_WARNING."""
    return [
        ln
        for ln in err.splitlines()
        if ln.strip() and not PROGRESS_LINE.match(ln) and not ln.startswith("INFO:") and TASK_INPUTS_WARNING not in ln
    ]


def ground_truth_tracks(session: Path, out: Path, headless_frames: int = 0) -> int:
    """A tracks table written from the simulated session's ground truth (every worker seen by two
    cameras in every frame, joints known to 1 cm) into ``out``, as ``ergopose assess`` would have
    tracked it: the stages after tracking then run without the pose network. The first worker's
    head joints are unknown in its first ``headless_frames`` frames (neck angles missing: those
    frames are not scored). Returns the frames."""
    import numpy as np

    from ergopose.keypoints import JOINT_INDEX

    from ergopose.pipeline.store import ResultStore
    from ergopose.recon.pipeline import TrackFrames
    from ergopose.recon.table import write_tracks
    from ergopose.sim.ground_truth import load_ground_truth

    gt = load_ground_truth(Path(session) / "ground_truth")
    n_frames, n_workers = gt.joints_world.shape[:2]
    frame = np.repeat(np.arange(n_frames), n_workers)
    index = np.tile(np.arange(n_workers), n_frames)
    pts = gt.joints_world[frame, index].copy()
    head = [
        JOINT_INDEX[k]
        for k in (
            "nose",
            "left_eye",
            "right_eye",
            "left_ear",
            "right_ear",
            "mouth_left",
            "mouth_right",
            "left_eye_inner",
            "left_eye_outer",
            "right_eye_inner",
            "right_eye_outer",
        )
    ]
    pts[np.ix_((index == 0) & (frame < headless_frames), head)] = np.nan
    n, j = pts.shape[:2]
    tf = TrackFrames(
        worker=(index + 1).astype(np.int64),
        frame=frame.astype(np.int64),
        time_s=frame / gt.fps,
        points_world=pts,
        raw_points_world=pts.copy(),
        confidence=np.full((n, j), 0.9),
        reprojection_error_px=np.ones((n, j)),
        views=np.full((n, j), 2, np.int8),
        gap_filled=np.zeros((n, j), bool),
        gated=np.zeros((n, j), bool),
        smoothed=True,
        lens_angle_deg=np.full((n, j), 30.0),
        inferred=np.zeros((n, j), bool),
        std_world=np.full((n, j, 3), 0.01),
    )
    write_tracks(
        ResultStore(out).tracks_path,
        tf,
        fps=gt.fps,
        cameras=gt.camera_names,
        workers={f"worker_{k + 1}": {"stature_estimate_m": 1.75} for k in range(n_workers)},
    )
    return int(n_frames)
