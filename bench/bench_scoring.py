"""RULA/REBA scoring and shift aggregation.

score_1M_frames: RULA and REBA (every step score, both sides, muscle use and activity from the
time series) for one million frames of joint angles at 12 fps; goal under 2 s.
aggregate_8h_shift: the shift summaries (distributions, holds, hourly, episodes, repetitions,
ISO 11226 / EN 1005-4) of four workers, 8 hours each at 12 fps (1,382,400 scored frames);
goal under 5 s.
The angles are random but seeded: smooth motion (a few slow oscillations plus a low-passed random
walk per joint), like the Kalman-smoothed output of the pipeline.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.signal import lfilter

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from common import best_time, emit  # noqa: E402

from ergopose.ergonomics.aggregate import aggregate_session  # noqa: E402
from ergopose.ergonomics.scoring import score_posture  # noqa: E402

FPS = 12.0
# angle column -> (centre, swing) in degrees
JOINTS = {
    "trunk_flexion": (20, 25),
    "trunk_side_bend": (0, 10),
    "trunk_twist": (0, 12),
    "neck_flexion": (12, 15),
    "neck_side_bend": (0, 8),
    "neck_twist": (0, 15),
    "left_upper_arm_flexion": (40, 45),
    "right_upper_arm_flexion": (35, 45),
    "left_upper_arm_abduction": (20, 15),
    "right_upper_arm_abduction": (20, 15),
    "left_elbow_flexion": (80, 40),
    "right_elbow_flexion": (80, 40),
    "left_wrist_flexion": (0, 25),
    "right_wrist_flexion": (0, 25),
    "left_knee_flexion": (15, 20),
    "right_knee_flexion": (15, 20),
    "left_shoulder_elevation": (5, 8),
    "right_shoulder_elevation": (5, 8),
    "left_wrist_deviation": (0, 12),
    "right_wrist_deviation": (0, 12),
}


def posture_table(n: int, rng: np.random.Generator, start_s: float = 0.0) -> pd.DataFrame:
    t = start_s + np.arange(n) / FPS
    cols: dict[str, np.ndarray] = {"time_s": t}
    for name, (centre, swing) in JOINTS.items():
        f1, f2 = rng.uniform(0.02, 0.3, 2)
        # a stationary random drift (first-order autoregressive, ~10 s memory), smoothed twice
        drift = lfilter([1.0], [1.0, -(1.0 - 1.0 / (10 * FPS))], rng.normal(0.0, 1.0, n))
        drift = lfilter([0.1], [1.0, -0.9], lfilter([0.1], [1.0, -0.9], drift))
        drift *= 0.5 * swing / (np.std(drift) + 1e-9)
        deg = centre + 0.5 * swing * np.sin(2 * np.pi * f1 * t) + 0.3 * swing * np.sin(2 * np.pi * f2 * t + 1) + drift
        deg = np.clip(deg, -170.0, 170.0)
        deg[rng.random(n) < 0.01] = np.nan  # 1 % of joints not measured
        cols[name] = np.deg2rad(deg)
    frame = pd.DataFrame(cols)
    frame["load_kg"] = np.where(rng.random(n) < 0.2, 8.0, 1.0)
    frame["load_mode"] = pd.array(np.where(rng.random(n) < 0.5, "intermittent", "repeated"), dtype="string")
    frame["coupling"] = pd.array(np.full(n, "fair"), dtype="string")
    frame["walking"] = (rng.random(n) < 0.05).astype(float)
    return frame


def best_cpu_time(fn, repeat: int = 3) -> float:
    """Smallest CPU time of this process over ``repeat`` calls (after one warm-up call): on a
    shared machine the wall time also counts the other processes' turns."""
    fn()
    best = float("inf")
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


def main() -> None:
    rng = np.random.default_rng(20240521)
    n = 1_000_000
    table = posture_table(n, rng)
    load = os.getloadavg()[0]
    t_score = best_time(lambda: score_posture(table, ("rula", "reba")), repeat=3)
    cpu_score = best_cpu_time(lambda: score_posture(table, ("rula", "reba")))
    emit(
        "score_1M_frames",
        t_score,
        "s",
        goal_s=2.0,
        frames=n,
        methods="rula+reba",
        per_frame_us=t_score / n * 1e6,
        cpu_s=cpu_score,
        load_average=load,
    )

    per_worker = int(8 * 3600 * FPS)
    parts = []
    for w in range(4):
        p = posture_table(per_worker, rng)
        scored = score_posture(p, ("rula", "reba"), with_events=True)
        frame = pd.concat([p, scored], axis=1)
        frame["worker"] = f"w{w + 1}"
        parts.append(frame)
    shift = pd.concat(parts, ignore_index=True)
    load = os.getloadavg()[0]
    t_agg = best_time(lambda: aggregate_session(shift), repeat=3)
    cpu_agg = best_cpu_time(lambda: aggregate_session(shift))
    emit(
        "aggregate_8h_shift",
        t_agg,
        "s",
        goal_s=5.0,
        workers=4,
        hours=8,
        fps=FPS,
        frames=len(shift),
        cpu_s=cpu_agg,
        load_average=load,
    )


if __name__ == "__main__":
    main()
