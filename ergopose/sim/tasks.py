"""The scripted tasks of a simulated worker at a station (lift and place, reach overhead, pick
with a twist, assembly, rest): each adds its key postures, steps and task labels to the worker's
timeline (:func:`do_task`).
"""

from __future__ import annotations

import math

import numpy as np

from ergopose.sim.scene import Station
from ergopose.sim.timeline import CARRY, NEUTRAL, TimelineBuilder, expand_pose

# --- the tasks ----------------------------------------------------------------------------------------


def _vary(rng: np.random.Generator, value: float, spread: float) -> float:
    return float(value + rng.uniform(-spread, spread))


def do_task(
    track: TimelineBuilder, task: str, station: Station, rng: np.random.Generator, carton_kg: float = 0.0
) -> None:
    """Append one task at ``station`` (the worker is already standing there)."""
    m = track.m
    h = m.stature
    k = float(rng.uniform(0.85, 1.2))  # tempo of this repetition
    if task == "rest":
        d = float(rng.uniform(3.0, 7.0))
        track.pose_task(
            "rest",
            [
                (1.2, {**NEUTRAL, "dy": 0.03, **expand_pose({"neck_flexion": 12.0, "trunk_flexion": 0.0})}),
                (d * 0.6, {"dy": -0.02, **expand_pose({"neck_flexion": 4.0, "neck_twist": _vary(rng, 0.0, 25.0)})}),
                (d, dict(NEUTRAL)),
            ],
        )
    elif task == "lift_stoop":
        trunk = _vary(rng, 78.0, 8.0)
        down = {
            **expand_pose(
                {
                    "trunk_flexion": trunk,
                    "neck_flexion": -12.0,
                    "upper_arm_flexion": trunk + 12.0,
                    "upper_arm_abduction": 12.0,
                    "elbow_flexion": 15.0,
                    "upper_arm_rotation": 10.0,
                }
            ),
            "dx": -0.05 * h,
            "dz": -0.02,
        }
        grasp = expand_pose({"elbow_flexion": 22.0, "wrist_flexion": 10.0})
        t1, t2, t3 = 1.4 * k, 2.1 * k, 3.6 * k
        track.pose_task(
            "lift_stoop",
            [(t1, down), (t2, grasp), (t3, dict(CARRY))],
            carrying=(t2, math.inf),
            period=(t2, t3, carton_kg, "intermittent", "fair"),
        )
    elif task == "lift_squat":
        trunk = _vary(rng, 38.0, 6.0)
        down = {
            **expand_pose(
                {
                    "trunk_flexion": trunk,
                    "neck_flexion": -15.0,
                    "upper_arm_flexion": trunk + 22.0,
                    "upper_arm_abduction": 16.0,
                    "elbow_flexion": 12.0,
                    "upper_arm_rotation": 10.0,
                }
            ),
            "dx": -0.09 * h,
            "dz": 0.35 * h - track.neutral_z,
        }
        grasp = expand_pose({"elbow_flexion": 20.0, "wrist_flexion": 10.0})
        t1, t2, t3 = 1.6 * k, 2.3 * k, 4.0 * k
        track.pose_task(
            "lift_squat",
            [(t1, down), (t2, grasp), (t3, dict(CARRY))],
            carrying=(t2, math.inf),
            period=(t2, t3, carton_kg, "intermittent", "fair"),
        )
    elif task == "place_shelf":
        shoulder_z = 0.818 * h
        arm = m.upper_arm_length + m.forearm_length + 0.5 * m.hand_length
        flex = 90.0 + math.degrees(math.asin(float(np.clip((station.work_height - shoulder_z) / arm, -0.8, 0.95))))
        flex = float(np.clip(flex, 45.0, 150.0))
        up = {
            **expand_pose(
                {
                    "upper_arm_flexion": flex,
                    "upper_arm_abduction": 12.0,
                    "elbow_flexion": 25.0,
                    "upper_arm_rotation": 8.0,
                    "trunk_flexion": 3.0,
                    "neck_flexion": -10.0 if station.work_height > 0.75 * h else 12.0,
                    "shoulder_elevation": 10.0 if flex > 100 else 2.0,
                }
            ),
            "dx": 0.03,
        }
        t1, t2, t3 = 1.3 * k, 2.0 * k, 3.3 * k
        track.pose_task(
            "place_shelf",
            [(t1, up), (t2, expand_pose({"wrist_flexion": -10.0})), (t3, dict(NEUTRAL))],
            carrying=(0.0, t2),
            period=(0.0, t2, carton_kg, "intermittent", "fair"),
        )
    elif task == "reach_overhead":
        flex = _vary(rng, 158.0, 8.0)
        up = expand_pose(
            {
                "upper_arm_flexion": flex,
                "upper_arm_abduction": 12.0,
                "elbow_flexion": 18.0,
                "neck_flexion": -28.0,
                "trunk_flexion": -6.0,
                "shoulder_elevation": 22.0,
                "wrist_flexion": -10.0,
            }
        )
        hold = expand_pose({"wrist_deviation": 10.0, "elbow_flexion": 24.0})
        t1, t2, t3 = 1.4 * k, 2.6 * k, 4.0 * k
        track.pose_task(
            "reach_overhead",
            [(t1, up), (t2, hold), (t3, dict(NEUTRAL))],
            period=(0.5, t3 - 0.5, 1.0, "intermittent", "good"),
        )
    elif task == "pick_twist":
        sigma = 1.0 if rng.uniform() < 0.5 else -1.0
        reach, other = ("left", "right") if sigma > 0 else ("right", "left")
        twist = _vary(rng, 34.0, 6.0)
        out = {
            **expand_pose(
                {
                    "trunk_twist": sigma * twist,
                    "trunk_side_bend": -sigma * 8.0,
                    "trunk_flexion": 22.0,
                    "neck_twist": sigma * 22.0,
                    "neck_flexion": 15.0,
                }
            ),
            **{
                f"{reach}_upper_arm_flexion": math.radians(65.0),
                f"{reach}_upper_arm_abduction": math.radians(28.0),
                f"{reach}_elbow_flexion": math.radians(18.0),
                f"{other}_upper_arm_flexion": math.radians(15.0),
                f"{other}_elbow_flexion": math.radians(35.0),
            },
        }
        back = expand_pose(
            {
                "trunk_twist": 0.0,
                "trunk_side_bend": 0.0,
                "trunk_flexion": 8.0,
                "neck_twist": 0.0,
                "neck_flexion": 20.0,
                "upper_arm_flexion": 30.0,
                "upper_arm_abduction": 10.0,
                "elbow_flexion": 75.0,
            }
        )
        t1, t2, t3, t4 = 1.2 * k, 1.8 * k, 3.0 * k, 3.8 * k
        track.pose_task(
            "pick_twist",
            [(t1, out), (t2, expand_pose({"wrist_flexion": 12.0})), (t3, back), (t4, dict(NEUTRAL))],
            period=(t2, t4, 2.0, "intermittent", "good"),
        )
    elif task == "assembly":
        d = float(rng.uniform(10.0, 26.0))
        trunk = _vary(rng, 20.0, 5.0)
        neck = _vary(rng, 28.0, 6.0)
        work = expand_pose(
            {
                "trunk_flexion": trunk,
                "neck_flexion": neck,
                "upper_arm_flexion": 38.0,
                "upper_arm_abduction": 14.0,
                "upper_arm_rotation": 20.0,
                "elbow_flexion": 88.0,
                "forearm_rotation": 45.0,
                "wrist_flexion": 8.0,
            }
        )
        keys: list[tuple[float, dict[str, float]]] = [(1.2, {**work, "dx": 0.03})]
        period = float(rng.uniform(2.6, 3.6))
        t = 1.2
        reaching = True
        while t + period / 2 < d - 1.2:
            t += period / 2
            if reaching:
                change = {
                    "right_upper_arm_flexion": math.radians(_vary(rng, 56.0, 6.0)),
                    "right_elbow_flexion": math.radians(55.0),
                    "right_wrist_flexion": math.radians(-15.0),
                    "right_wrist_deviation": math.radians(8.0),
                    "left_wrist_flexion": math.radians(20.0),
                    "trunk_flexion": math.radians(trunk + 6.0),
                }
            else:
                change = {
                    "right_upper_arm_flexion": math.radians(38.0),
                    "right_elbow_flexion": math.radians(88.0),
                    "right_wrist_flexion": math.radians(18.0),
                    "right_wrist_deviation": math.radians(-6.0),
                    "left_wrist_flexion": math.radians(5.0),
                    "trunk_flexion": math.radians(trunk),
                }
            keys.append((t, change))
            reaching = not reaching
        keys.append((t + 1.2, {**dict(NEUTRAL)}))
        track.pose_task("assembly", keys, period=(1.2, t, round(float(rng.uniform(0.5, 1.5)), 2), "repeated", "good"))
    else:
        raise ValueError(f"unknown task {task!r}")
