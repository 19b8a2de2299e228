"""Score the keypoint CSV of ``ergopose pose`` against the Pose2Sim recording's reference
keypoints (evaluation only; docs/pose-command.md).

The recording (/work/shared/data/pose2sim-demo) has four pinhole videos and, per camera and
frame, the OpenPose keypoints after Pose2Sim's person association (``pose-associated``: one
person). Scores are those of :mod:`ergopose.evaluation.refisheye`, on the camera's own pixels:
pixels become rays through the calibrated lens;

* found: a row's person whose hip centre lies within 0.5 torso lengths of the reference's (the
  closest is scored); counted over the frames where the reference has the person;
* keypoint error: angle between the rays of the 12 limb keypoints the reference gives (score
  >= 0.3), over the angle of the reference torso (shoulder centre to hip centre).

A second reference, ``trc``: Pose2Sim's own 3D result of the recording
(``pose-3d/S00_P00_T01_BalancingTrial_0-100.trc``, triangulated from the OpenPose keypoints of
all four cameras, TRC axes = world[:, [1, 2, 0]]) projected into each camera: the keypoints as
the four cameras agree on them, not as one camera's OpenPose run placed them.

Run: ``python -m ergopose.evaluation.pose_csv --csv-dir DIR`` with DIR holding cam01.csv ..
cam04.csv written by ``ergopose pose`` (see ``main``).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from ergopose.evaluation.refisheye import DEFAULT_ROOT, openpose_reference, score_frame
from ergopose.evaluation.trc import read_trc
from ergopose.geometry.calibration_file import read_pose2sim_calibration
from ergopose.geometry.camera import Camera
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS


@dataclass(frozen=True)
class _Frame:
    """The part of a FrameDetections that the scores read."""

    rays_cam: np.ndarray
    confidence: np.ndarray

    @property
    def count(self) -> int:
        return int(self.rays_cam.shape[0])


def frames_from_csv(table: pd.DataFrame, camera: Camera, frames: int) -> list[_Frame]:
    """Per frame 0 .. frames-1, the people of a pose CSV as rays in the camera frame."""
    table = table[table["frame"] < frames]
    joint = table["joint"].map(JOINT_INDEX).to_numpy()
    key = table["frame"].to_numpy() * 10_000 + table["person"].to_numpy()
    people, row = np.unique(key, return_inverse=True)
    pixels = np.full((people.size, NUM_JOINTS, 2), np.nan)
    conf = np.zeros((people.size, NUM_JOINTS))
    pixels[row, joint] = table[["x_px", "y_px"]].to_numpy(dtype=np.float64)
    conf[row, joint] = table["confidence"].to_numpy(dtype=np.float64)
    rays = camera.lens.unproject(pixels.reshape(-1, 2)).reshape(people.size, NUM_JOINTS, 3)
    frame_of = people // 10_000
    return [_Frame(rays[frame_of == f], conf[frame_of == f]) for f in range(frames)]


TRC_FILE = "pose-3d/S00_P00_T01_BalancingTrial_0-100.trc"
#: The TRC's markers scored, by joint.
_TRC_MARKERS = {
    "RShoulder": "right_shoulder",
    "LShoulder": "left_shoulder",
    "RElbow": "right_elbow",
    "LElbow": "left_elbow",
    "RWrist": "right_wrist",
    "LWrist": "left_wrist",
    "RHip": "right_hip",
    "LHip": "left_hip",
    "RKnee": "right_knee",
    "LKnee": "left_knee",
    "RAnkle": "right_ankle",
    "LAnkle": "left_ankle",
}


def trc_reference(root: Path, frames: int, camera: Camera) -> dict:
    """Pose2Sim's 3D markers projected into the camera: rays (frames, 33, 3) and conf (1 where given)."""
    trc = read_trc(root / TRC_FILE)
    rays = np.full((frames, NUM_JOINTS, 3), np.nan)
    conf = np.zeros((frames, NUM_JOINTS))
    n = min(frames, trc.points_trc.shape[0])
    for marker, joint in _TRC_MARKERS.items():
        world = trc.points_trc[:n, trc.markers.index(marker)][:, [2, 0, 1]]  # TRC axes = world[:, [1, 2, 0]]
        cam = camera.points_world_to_cam(world)
        j = JOINT_INDEX[joint]
        rays[:n, j] = cam / np.linalg.norm(cam, axis=-1, keepdims=True)
        conf[:n, j] = np.isfinite(cam).all(axis=-1)
    return {"rays": rays, "conf": conf}


def score_csv(
    csv: str | Path,
    camera: Camera,
    number: int,
    root: Path = DEFAULT_ROOT,
    frames: int = 100,
    reference: str = "openpose",
) -> dict:
    """found (share of the reference's frames), counted, median and p90 keypoint error (torso
    lengths); reference "openpose" (the camera's own OpenPose keypoints) or "trc" (Pose2Sim's 3D
    result projected)."""
    ref = (
        openpose_reference(root, number, frames, camera)
        if reference == "openpose"
        else trc_reference(root, frames, camera)
    )
    found = counted = 0
    errors = []
    for f, people in enumerate(frames_from_csv(pd.read_csv(csv), camera, frames)):
        rays, conf = ref["rays"][f], ref["conf"][f]
        hips = [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]
        shoulders = [JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]]
        if not (conf[hips + shoulders] > 0).all():
            continue  # the reference does not have the person's torso in this frame
        counted += 1
        score = score_frame(rays, conf, people)
        if score["found"]:
            found += 1
            errors.append(score["errors"])
    err = np.concatenate(errors) if errors else np.zeros(0)
    return {
        "camera": camera.name,
        "counted": counted,
        "found": found,
        "found_share": found / counted if counted else float("nan"),
        "median": float(np.median(err)) if err.size else float("nan"),
        "p90": float(np.percentile(err, 90)) if err.size else float("nan"),
        "keypoints": int(err.size),
        "errors": err,
    }


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--csv-dir", type=Path, required=True, help="folder with cam01.csv .. cam04.csv")
    parser.add_argument("--root", type=Path, default=DEFAULT_ROOT)
    parser.add_argument("--frames", type=int, default=100)
    args = parser.parse_args(argv)
    cameras = read_pose2sim_calibration(args.root / "Calib_qualisys.toml")
    print("| camera | reference | found | keypoints | median torso | p90 torso |")
    print("|---|---|---|---|---|---|")
    pooled: dict[str, list] = {"openpose": [], "trc": []}
    for number, camera in enumerate(cameras, start=1):
        for reference in ("openpose", "trc"):
            s = score_csv(args.csv_dir / f"cam{number:02d}.csv", camera, number, args.root, args.frames, reference)
            pooled[reference].append(s)
            print(
                f"| {s['camera']} | {reference} | {100 * s['found_share']:.0f} % ({s['found']}/{s['counted']}) | "
                f"{s['keypoints']} | {s['median']:.3f} | {s['p90']:.3f} |"
            )
    for reference, rows in pooled.items():
        err = np.concatenate([r["errors"] for r in rows])
        found, counted = sum(r["found"] for r in rows), sum(r["counted"] for r in rows)
        print(
            f"| all four | {reference} | {100 * found / max(counted, 1):.1f} % ({found}/{counted}) | {err.size} | "
            f"{np.median(err):.3f} | {np.percentile(err, 90):.3f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
