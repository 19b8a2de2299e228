"""The product on real people: ``session new`` -> the REAL ``assess`` (BlazePose, body model) ->
``evaluate --reference`` on the Pose2Sim recording (../shared/data/pose2sim-demo), cameras 01 and
04 (two cameras, as the rig). Pose2Sim's own 3D (triangulated OpenPose keypoints of all four
cameras) is the reference, not ground truth.

Measured 2026-11-26 (docs/evaluation.md, "The product with the body model", after left and right
were settled by the reconstruction): 100 of 100 frames compared, median residual 40 mm, trunk
flexion MAD 12.9 deg (bias about -10: keypoint definitions), knee flexion 15.4 / 6.8, elbow
flexion 7.5 / 7.5, upper-arm elevation 4.1 / 2.8. The bounds below sit above these with room for
the machine's floating point, not at the issue's targets (not all met).
"""

from __future__ import annotations

import json

import pytest

from ergopose.cli import main

pytestmark = pytest.mark.slow

TRC = "pose-3d/S00_P00_T01_BalancingTrial_0-100.trc"


def test_a_real_camera_pair_is_scored_in_every_frame(shared_data, fetched_model_dir, tmp_path, capsys):
    demo = shared_data / "pose2sim-demo"
    session, out = tmp_path / "pair", tmp_path / "out"
    assert (
        main(
            [
                "session",
                "new",
                str(session),
                "--calibration",
                str(demo / "Calib_qualisys.toml"),
                "--cameras",
                "cam_01,cam_04",
                "--link",
                str(demo / "videos" / "cam01.mp4"),
                str(demo / "videos" / "cam04.mp4"),
            ]
        )
        == 0
    )
    assert (
        main(
            [
                "assess",
                "--session",
                str(session),
                "--out",
                str(out),
                "--processes",
                "1",
                "--model-dir",
                str(fetched_model_dir[0]),
            ]
        )
        == 0
    )
    assert (
        main(
            [
                "evaluate",
                "--results",
                str(out),
                "--reference",
                str(demo / TRC),
                "--session",
                str(session),
                "--json",
                str(tmp_path / "ref.json"),
            ]
        )
        == 0
    )
    capsys.readouterr()
    ev = json.loads((tmp_path / "ref.json").read_text())
    assert ev["frame_selection"]["compared"] == 100  # every frame tracked and scored
    assert ev["alignment"]["residual_median_mm"] < 50.0
    angles = ev["angles"]["by_angle"]
    for name, bound in (
        ("trunk_flexion", 16.0),
        ("left_knee_flexion", 19.0),
        ("right_knee_flexion", 10.0),
        ("left_elbow_flexion", 10.0),
        ("right_elbow_flexion", 10.0),
        ("left_upper_arm_elevation", 7.0),
        ("right_upper_arm_elevation", 6.0),
    ):
        assert angles[name]["mae_deg"] < bound, (name, angles[name]["mae_deg"])
    # Per-part agreement the reference allows (no neck or wrist markers): legs and lower arms.
    assert ev["scores"]["rula_legs"]["exact_agreement_pct"] >= 75.0
    assert ev["scores"]["left_rula_lower_arm"]["exact_agreement_pct"] >= 85.0
    # The same assessment against the reference triangulated from the same OpenPose keypoints with
    # every camera (evaluate --reference-keypoints): what is left when Pose2Sim's choice of cameras
    # per keypoint is taken out (docs/evaluation.md, "Two references from the same keypoints").
    assert (
        main(
            [
                "evaluate",
                "--results",
                str(out),
                "--session",
                str(session),
                "--reference-keypoints",
                str(demo / "pose-associated"),
                "--reference-calibration",
                str(demo / "Calib_qualisys.toml"),
                "--json",
                str(tmp_path / "kp.json"),
            ]
        )
        == 0
    )
    capsys.readouterr()
    kp = json.loads((tmp_path / "kp.json").read_text())
    assert kp["frame_selection"]["compared"] == 100 and kp["source"].startswith("reference triangulated")
    angles = kp["angles"]["by_angle"]
    for name, bound in (
        ("trunk_flexion", 4.0),
        ("trunk_side_bend", 4.0),
        ("left_knee_flexion", 11.0),
        ("right_knee_flexion", 7.0),
        ("left_elbow_flexion", 7.0),
        ("right_elbow_flexion", 9.0),
        ("left_upper_arm_elevation", 5.0),
        ("right_upper_arm_elevation", 4.0),
    ):
        assert angles[name]["mae_deg"] < bound, (name, angles[name]["mae_deg"])
    assert abs(angles["trunk_flexion"]["bias_deg"]) < 2.0  # the -10 deg against the TRC is the reference's
