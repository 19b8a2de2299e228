"""Scoring a pose CSV against the Pose2Sim recording (ergopose/evaluation/pose_csv.py): the
reference's own keypoints written as a CSV score as found with no error; frames left out are
missed; a shift of the keypoints shows up as the error it is."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ergopose.evaluation.pose_csv import score_csv
from ergopose.evaluation.refisheye import openpose_reference
from ergopose.geometry.calibration_file import read_pose2sim_calibration
from ergopose.keypoints import BLAZEPOSE33, JOINT_INDEX

SHOULDERS = [JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]]
HIPS = [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]


def _csv_of_reference(path, camera, ref, frames, shift_px=0.0):
    rows = []
    for f in frames:
        px = camera.lens.project(ref["rays"][f])
        for j, name in enumerate(BLAZEPOSE33):
            if ref["conf"][f, j] > 0:
                rows.append((f, f / 60.0, 0, name, px[j, 0] + shift_px, px[j, 1], 1.0))
    pd.DataFrame(rows, columns=["frame", "time_s", "person", "joint", "x_px", "y_px", "confidence"]).to_csv(
        path, index=False
    )
    return path


def test_reference_scores_as_found_without_error_and_a_shift_as_its_size(shared_data, tmp_path):
    root = shared_data / "pose2sim-demo"
    camera = read_pose2sim_calibration(root / "Calib_qualisys.toml")[0]
    ref = openpose_reference(root, 1, 20, camera)
    exact = score_csv(_csv_of_reference(tmp_path / "a.csv", camera, ref, range(20)), camera, 1, root, 20)
    assert exact["counted"] >= 18 and exact["found"] == exact["counted"]
    assert exact["median"] < 1e-6 and exact["p90"] < 1e-6
    # Frames 0-9 left out: missed.
    half = score_csv(_csv_of_reference(tmp_path / "b.csv", camera, ref, range(10, 20)), camera, 1, root, 20)
    missing = sum(1 for f in range(10) if (ref["conf"][f][SHOULDERS + HIPS] > 0).all())
    assert half["found"] == exact["found"] - missing
    # Every keypoint 8 px to the right: about 8 px over the torso's length in pixels.
    shifted = score_csv(_csv_of_reference(tmp_path / "c.csv", camera, ref, range(20), 8.0), camera, 1, root, 20)
    px = camera.lens.project(ref["rays"][:20])
    torso = np.linalg.norm(px[:, SHOULDERS].mean(1) - px[:, HIPS].mean(1), axis=-1)
    assert abs(shifted["median"] - np.median(8.0 / torso[np.isfinite(torso)])) < 0.01, shifted
