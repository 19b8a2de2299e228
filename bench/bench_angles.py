"""Joint angles over a whole shift, the body model, and how point noise reaches the angles.

angles_8h: joint_angles on 8 h at 12 fps (345,600 frames of 33 points) with frame times.
Goal: well under a few seconds (2 s). pose_skeleton_8h: the body model's forward kinematics for the
same number of frames (the simulator's cost). angle_noise_*: RMS angle error (degrees) when every
point of randomly posed skeletons gets isotropic Gaussian noise of the given size (per axis): how
much a triangulation error of that size moves each angle.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from common import best_time, emit  # noqa: E402

from ergopose.ergonomics.angles import AngleSettings, joint_angles  # noqa: E402
from ergopose.ergonomics.body import BodyMeasurements, Posture, place_on_floor, pose_skeleton  # noqa: E402

FPS = 12.0
FRAMES_8H = int(8 * 3600 * FPS)


def random_postures(rng: np.random.Generator, n: int) -> Posture:
    """Working postures across the ranges the tests use (degrees -> radians)."""

    def u(lo, hi):
        return np.radians(rng.uniform(lo, hi, n))

    kw = dict(
        heading=rng.uniform(-np.pi, np.pi, n),
        root_position=np.c_[rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), np.zeros(n)],
        trunk_flexion=u(-20, 90),
        trunk_side_bend=u(-20, 20),
        trunk_twist=u(-30, 30),
        neck_flexion=u(-30, 45),
        neck_side_bend=u(-20, 20),
        neck_twist=u(-45, 45),
    )
    for s in ("left", "right"):
        kw.update(
            {
                f"{s}_upper_arm_flexion": u(-40, 150),
                f"{s}_upper_arm_abduction": u(-20, 60),
                f"{s}_upper_arm_rotation": u(-45, 45),
                f"{s}_elbow_flexion": u(10, 140),
                f"{s}_forearm_rotation": u(-60, 60),
                f"{s}_wrist_flexion": u(-40, 40),
                f"{s}_wrist_deviation": u(-15, 20),
                f"{s}_shoulder_elevation": u(0, 15),
                f"{s}_hip_flexion": u(-10, 60),
                f"{s}_knee_flexion": u(0, 60),
            }
        )
    return Posture(**kw)


def main() -> None:
    rng = np.random.default_rng(11)
    m = BodyMeasurements.from_stature(1.75)
    posture = place_on_floor(m, random_postures(rng, FRAMES_8H))
    t_fk = best_time(lambda: pose_skeleton(m, posture), repeat=2)
    points = pose_skeleton(m, posture)
    time_s = np.arange(FRAMES_8H) / FPS
    t_angles = best_time(lambda: joint_angles(points, time_s), repeat=5)
    context = {"frames": FRAMES_8H, "fps": FPS}
    emit("angles_8h", t_angles, "s", goal_s=2.0, **context)
    emit("pose_skeleton_8h", t_fk, "s", **context)

    n = 20000
    m = BodyMeasurements.from_stature(1.75)
    posture = place_on_floor(m, random_postures(rng, n))
    clean = pose_skeleton(m, posture)
    settings = AngleSettings(trunk_length_m=m.trunk_length)
    truth = joint_angles(clean, settings=settings)
    names = (
        "trunk_flexion",
        "trunk_side_bend",
        "trunk_twist",
        "neck_flexion",
        "neck_side_bend",
        "neck_twist",
        "left_upper_arm_flexion",
        "left_upper_arm_abduction",
        "left_shoulder_elevation",
        "left_elbow_flexion",
        "left_wrist_flexion",
        "left_wrist_deviation",
        "left_knee_flexion",
    )
    for sigma_mm in (5.0, 10.0, 20.0):
        noisy = clean + rng.normal(0.0, sigma_mm / 1000.0, clean.shape)
        measured = joint_angles(noisy, settings=settings)
        for name in names:
            diff = np.angle(np.exp(1j * (getattr(measured, name) - getattr(truth, name))))
            rms = float(np.degrees(np.sqrt(np.nanmean(diff**2))))
            emit(f"angle_noise_{name}", rms, "deg_rms", noise_mm=sigma_mm, postures=n)


if __name__ == "__main__":
    main()
