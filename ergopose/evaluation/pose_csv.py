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


def score_csv(csv: str | Path, camera: Camera, number: int, root: Path = DEFAULT_ROOT, frames: int = 100) -> dict:
    """found (share of the reference's frames), counted, median and p90 keypoint error (torso lengths)."""
    ref = openpose_reference(root, number, frames, camera)
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
    return {"camera": camera.name, "counted": counted, "found": found,
            "found_share": found / counted if counted else float("nan"),
            "median": float(np.median(err)) if err.size else float("nan"),
            "p90": float(np.percentile(err, 90)) if err.size else float("nan"), "keypoints": int(err.size)}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--csv-dir", type=Path, required=True, help="folder with cam01.csv .. cam04.csv")
    parser.add_argument("--root", type=Path, default=DEFAULT_ROOT)
    parser.add_argument("--frames", type=int, default=100)
    args = parser.parse_args(argv)
    cameras = read_pose2sim_calibration(args.root / "Calib_qualisys.toml")
    print("| camera | found | keypoints | median torso | p90 torso |")
    print("|---|---|---|---|---|")
    for number, camera in enumerate(cameras, start=1):
        s = score_csv(args.csv_dir / f"cam{number:02d}.csv", camera, number, args.root, args.frames)
        print(f"| {s['camera']} | {100 * s['found_share']:.0f} % ({s['found']}/{s['counted']}) | {s['keypoints']} | "
              f"{s['median']:.3f} | {s['p90']:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
