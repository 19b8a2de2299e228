"""The timeline of one simulated worker (:class:`TimelineBuilder`): key postures of the upper body blended
with the minimum-jerk curve, planted and swinging feet, footsteps along a path, the pelvis over
them, and the frames of the shift filled in from these.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.interpolate import PchipInterpolator

from ergopose.ergonomics.body import ANGLE_FIELDS
from ergopose.sim.legs import MAX_LEG_STRETCH
from ergopose.sim.paths import rounded_curve
from ergopose.sim.scene import Station
from ergopose.sim.workforce import TASK_INDEX, FactorPeriod, WorkerSpec

LEG_FIELDS = tuple(
    f"{s}_{n}" for s in ("left", "right") for n in ("hip_flexion", "hip_abduction", "knee_flexion", "ankle_flexion")
)
UPPER_FIELDS = tuple(f for f in ANGLE_FIELDS if f not in LEG_FIELDS)
_BILATERAL = (
    "shoulder_elevation",
    "upper_arm_flexion",
    "upper_arm_abduction",
    "upper_arm_rotation",
    "elbow_flexion",
    "forearm_rotation",
    "wrist_flexion",
    "wrist_deviation",
)

#: Upper-body key postures (degrees). Bilateral names apply to both sides.
NEUTRAL_DEG = {
    "trunk_flexion": 2.0,
    "neck_flexion": 6.0,
    "upper_arm_flexion": 2.0,
    "upper_arm_abduction": 9.0,
    "upper_arm_rotation": 5.0,
    "elbow_flexion": 14.0,
}
CARRY_DEG = {
    "trunk_flexion": -2.0,
    "neck_flexion": 10.0,
    "upper_arm_flexion": 22.0,
    "upper_arm_abduction": 14.0,
    "upper_arm_rotation": 14.0,
    "elbow_flexion": 88.0,
}


#: Lateral offset of each ankle from the pelvis centre when standing, beyond half the hip width.
STANCE_EXTRA_WIDTH = 0.0


#: Step length as a fraction of stature, and the fraction of each step both feet are down at its
#: start and at its end (double support).
STEP_LENGTH = 0.32
#: Path corners sharper than this (degrees) are walked as stop, turn on the spot, go on.
SHARP_CORNER_DEG = 35.0
DOUBLE_SUPPORT = 0.14
#: How much lower the pelvis is while walking than while standing (metres, for 1.75 m stature).
WALK_PELVIS_DROP = 0.045


# --- small helpers ---------------------------------------------------------------------------------


def min_jerk(s: np.ndarray) -> np.ndarray:
    """The minimum-jerk blend 10s^3 - 15s^4 + 6s^5 of s clipped to [0, 1]."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _rot2(h: float) -> np.ndarray:
    return np.array([[math.cos(h), -math.sin(h)], [math.sin(h), math.cos(h)]])


def expand_pose(pose_deg: dict[str, float]) -> dict[str, float]:
    """Degrees with bilateral names -> radians per field."""
    out: dict[str, float] = {}
    for name, value in pose_deg.items():
        if name in _BILATERAL:
            out[f"left_{name}"] = math.radians(value)
            out[f"right_{name}"] = math.radians(value)
        elif name in ("dx", "dy", "dz"):
            out[name] = float(value)
        else:
            if name not in UPPER_FIELDS:
                raise KeyError(f"unknown posture field {name!r}")
            out[name] = math.radians(value)
    return out


def _full_pose(pose_deg: dict[str, float]) -> dict[str, float]:
    base = {f: 0.0 for f in UPPER_FIELDS}
    base.update({"dx": 0.0, "dy": 0.0, "dz": 0.0})
    base.update(expand_pose(pose_deg))
    return base


NEUTRAL = _full_pose(NEUTRAL_DEG)
CARRY = _full_pose(CARRY_DEG)


# --- the timeline of one worker ------------------------------------------------------------------------


@dataclass
class _Chunk:
    f0: int
    f1: int
    root_xy: np.ndarray  # (n, 2)
    root_dz: np.ndarray  # (n,) planned height offset from the neutral height
    heading: np.ndarray  # (n,)
    upper: dict[str, np.ndarray]
    ankles: np.ndarray  # (n, 2, 3)
    planted: np.ndarray  # (n, 2)
    task: np.ndarray  # (n,)
    carrying: np.ndarray  # (n,)
    pitch: np.ndarray | None = None  # (n, 2) foot pitch in swing (toes up positive); None = level


class TimelineBuilder:
    """Builds one worker's timeline segment by segment (continuous time, sampled at frames)."""

    def __init__(self, spec: WorkerSpec, fps: float, station: Station, rng: np.random.Generator):
        self.spec = spec
        self.m = spec.measurements
        self.fps = fps
        self.rng = rng
        self.t = 0.0
        self.chunks: list[_Chunk] = []
        self.periods: list[FactorPeriod] = []
        self.station = station
        self.heading = station.heading
        self.root_xy = np.array(station.position, float)
        self.half_stance = self.m.hip_width / 2.0 + STANCE_EXTRA_WIDTH
        self.ankles = self._neutral_ankles(self.root_xy, self.heading)
        self.upper = dict(NEUTRAL)
        lateral = STANCE_EXTRA_WIDTH
        leg = self.m.thigh_length + self.m.shank_length
        self.neutral_z = self.m.ankle_height + math.sqrt((MAX_LEG_STRETCH * leg) ** 2 - lateral**2) - 1e-4

    def _neutral_ankles(self, root_xy: np.ndarray, heading: float) -> np.ndarray:
        r = _rot2(heading)
        out = np.empty((2, 3))
        for k, sigma in enumerate((1.0, -1.0)):
            out[k, :2] = root_xy + r @ np.array([0.0, sigma * self.half_stance])
            out[k, 2] = self.m.ankle_height
        return out

    def _frames(self, duration: float) -> tuple[int, int, np.ndarray]:
        f0 = int(math.ceil(self.t * self.fps - 1e-9))
        f1 = int(math.ceil((self.t + duration) * self.fps - 1e-9))
        local = np.arange(f0, f1) / self.fps - self.t
        return f0, f1, local

    # --- stationary tasks ---

    def pose_task(
        self,
        task: str,
        keys: list[tuple[float, dict[str, float]]],
        carrying=None,
        period: tuple[float, float, float, str, str] | None = None,
    ) -> None:
        """Key postures [(time_s, changes)] from the current posture; feet stay planted.

        carrying: None (no carton) or (t_on, t_off) local times holding a carton.
        period: (t0, t1, load_kg, load_mode, coupling) in local times, for the settings.
        """
        duration = keys[-1][0]
        f0, f1, local = self._frames(duration)
        times = [0.0]
        poses = [dict(self.upper)]
        for t, change in keys:
            pose = dict(poses[-1])
            pose.update(change)
            times.append(t)
            poses.append(pose)
        names = list(poses[0])
        values = np.array([[p[n] for n in names] for p in poses])  # (K, fields)
        times_a = np.array(times)
        idx = np.clip(np.searchsorted(times_a, local, side="right") - 1, 0, len(times) - 2)
        span = np.maximum(times_a[idx + 1] - times_a[idx], 1e-9)
        w = min_jerk((local - times_a[idx]) / span)[:, None]
        sampled = values[idx] + (values[idx + 1] - values[idx]) * w
        cols = {n: sampled[:, k] for k, n in enumerate(names)}
        n = f1 - f0
        r = _rot2(self.heading)
        offsets = np.stack([cols["dx"], cols["dy"]], axis=1) @ r.T
        chunk = _Chunk(
            f0,
            f1,
            root_xy=self.root_xy[None, :] + offsets,
            root_dz=cols["dz"],
            heading=np.full(n, self.heading),
            upper={k: cols[k] for k in UPPER_FIELDS},
            ankles=np.broadcast_to(self.ankles, (n, 2, 3)).copy(),
            planted=np.ones((n, 2), bool),
            task=np.full(n, TASK_INDEX[task], np.int8),
            carrying=np.zeros(n, bool) if carrying is None else (local >= carrying[0]) & (local < carrying[1]),
        )
        self.chunks.append(chunk)
        if period is not None:
            t0, t1, kg, mode, coupling = period
            self.periods.append(FactorPeriod(round(self.t + t0, 6), round(self.t + t1, 6), kg, mode, coupling))
        self.upper = dict(poses[-1])
        self.upper.update({"dx": 0.0, "dy": 0.0, "dz": 0.0})
        self.t += duration

    # --- locomotion ---

    def walk(self, path: np.ndarray, final_heading: float, carrying: bool) -> None:
        """Walk along the waypoints (the first is the current position) and turn to final_heading.

        The path is split at sharp corners (more than SHARP_CORNER_DEG), where the worker stops
        and turns on the spot; along each run the steps follow the path continuously (at gentle
        corners the heading turns during one step).
        """
        steps: list[dict[str, Any]] = []
        feet = self.ankles[:, :2].copy()
        heading = self.heading
        root = self.root_xy.copy()
        last_side = 1  # index of the foot moved last (0 left, 1 right)
        step_len = STEP_LENGTH * self.m.stature
        t_step = step_len / self.spec.walk_speed
        task = "carry" if carrying else "walk"
        turn_task = "carry" if carrying else "turn"

        def turn_to(target: float) -> None:
            nonlocal heading, last_side
            delta = _wrap(target - heading)
            if abs(delta) < math.radians(0.5):
                return
            k = int(math.ceil(abs(delta) / math.radians(65.0)))
            side = 0 if delta > 0 else 1
            for j in range(1, k + 2):
                h0 = heading + delta * min(j - 1, k) / k
                h1 = heading + delta * min(j, k) / k
                sigma = 1.0 if side == 0 else -1.0
                to = root + _rot2(h1) @ np.array([0.0, sigma * self.half_stance])
                steps.append(
                    {
                        "side": side,
                        "to": to,
                        "h0": h0,
                        "h1": h1,
                        "root1": root.copy(),
                        "dur": 0.45 * t_step + 0.12,
                        "lift": 0.04,
                        "pitch": math.radians(8.0),
                        "task": turn_task,
                    }
                )
                feet[side] = to
                last_side = side
                side = 1 - side
            heading = heading + delta

        # split into runs at sharp corners
        pts = [p for i, p in enumerate(path) if i == 0 or np.linalg.norm(p - path[i - 1]) > 0.02]
        runs: list[list[np.ndarray]] = [[pts[0]]]
        for i in range(1, len(pts)):
            runs[-1].append(pts[i])
            if i < len(pts) - 1:
                a, b = pts[i] - pts[i - 1], pts[i + 1] - pts[i]
                bend = abs(_wrap(math.atan2(b[1], b[0]) - math.atan2(a[1], a[0])))
                if bend > math.radians(SHARP_CORNER_DEG):
                    runs.append([pts[i]])
        for run in runs:
            if len(run) < 2:
                continue
            curve = rounded_curve(np.array(run))
            seg = np.diff(curve, axis=0)
            seg_len = np.linalg.norm(seg, axis=1)
            cum = np.concatenate([[0.0], np.cumsum(seg_len)])
            dist = float(cum[-1])

            def at(a: float, curve=curve, seg=seg, seg_len=seg_len, cum=cum) -> tuple[np.ndarray, np.ndarray]:
                i = int(np.clip(np.searchsorted(cum, a, side="right") - 1, 0, len(seg) - 1))
                u = seg[i] / seg_len[i]
                return curve[i] + u * (a - cum[i]), u

            first_u = seg[0] / seg_len[0]
            turn_to(math.atan2(first_u[1], first_u[0]))
            n_steps = max(1, int(math.ceil(dist / step_len)))
            sl = dist / n_steps
            side = 1 - last_side
            along = {0: 0.0, 1: 0.0}
            run_id = len(steps)
            for k in range(1, n_steps + 2):
                a = min(k * sl, dist)
                point, u = at(a)
                sigma = 1.0 if side == 0 else -1.0
                to = point + np.array([-u[1], u[0]]) * sigma * self.half_stance
                along[side] = a
                h1 = heading + _wrap(math.atan2(u[1], u[0]) - heading)
                arc = min(0.5 * (along[0] + along[1]), dist) if k <= n_steps else dist
                steps.append(
                    {
                        "side": side,
                        "to": to,
                        "h0": heading,
                        "h1": h1,
                        "root1": at(arc)[0],
                        "run": (run_id, curve, cum),
                        "arc1": arc,
                        "dur": t_step,
                        "lift": 0.07,
                        "pitch": math.radians(25.0),
                        "task": task,
                    }
                )
                heading = h1
                feet[side] = to
                last_side = side
                side = 1 - side
            root = curve[-1].copy()
        turn_to(final_heading)
        if not steps:
            return
        self._emit_steps(steps, carrying)
        self.heading = heading
        self.root_xy = root
        self.ankles = np.concatenate([feet, np.full((2, 1), self.m.ankle_height)], axis=1)

    def _emit_steps(self, steps: list[dict[str, Any]], carrying: bool) -> None:
        starts = np.cumsum([0.0] + [s["dur"] for s in steps])
        total = float(starts[-1])
        f0, f1, local = self._frames(total)
        n = f1 - f0
        # Root: turn steps hold it; along a run it follows the run's curve, its arclength
        # interpolated (monotone) through the keypoints at the step boundaries.
        root_xy = np.empty((n, 2))
        which_step = np.clip(np.searchsorted(starts, local, side="right") - 1, 0, len(steps) - 1)
        k = 0
        while k < len(steps):
            run = steps[k].get("run")
            if run is None:
                root_xy[which_step == k] = steps[k]["root1"]
                k += 1
                continue
            m = k
            while m < len(steps) and steps[m].get("run") is not None and steps[m]["run"][0] == run[0]:
                m += 1
            key_t = np.concatenate([[starts[k]], starts[k + 1 : m + 1]])
            key_a = np.array([0.0] + [steps[i]["arc1"] for i in range(k, m)])
            sel = (which_step >= k) & (which_step < m)
            arc = PchipInterpolator(key_t, key_a)(local[sel])
            _, curve, cum = run
            root_xy[sel, 0] = np.interp(arc, cum, curve[:, 0])
            root_xy[sel, 1] = np.interp(arc, cum, curve[:, 1])
            k = m
        heading = np.empty(n)
        pitch = np.zeros((n, 2))
        ankles = np.empty((n, 2, 3))
        planted = np.ones((n, 2), bool)
        task = np.empty(n, np.int8)
        pos = self.ankles[:, :2].copy()
        which = np.clip(np.searchsorted(starts, local, side="right") - 1, 0, len(steps) - 1)
        for k, s in enumerate(steps):  # per step (tens per walk), vectorised over its frames
            sel = which == k
            tl = (local[sel] - starts[k]) / s["dur"]
            heading[sel] = s["h0"] + (s["h1"] - s["h0"]) * min_jerk(tl)
            side = s["side"]
            swing = np.clip((tl - DOUBLE_SUPPORT) / (1.0 - 2.0 * DOUBLE_SUPPORT), 0.0, 1.0)
            in_air = (tl > DOUBLE_SUPPORT) & (tl < 1.0 - DOUBLE_SUPPORT)
            start_xy = pos[side].copy()
            w = min_jerk(swing)[:, None]
            ankles[sel, side, :2] = start_xy + (np.asarray(s["to"]) - start_xy) * w
            # in swing the toes point down a little (the ankle does not stay flexed as far as a
            # level foot would need); the ankle rises enough for the toes to clear the floor
            p = -s["pitch"] * np.sin(np.pi * swing)
            pitch[sel, side] = p
            pitch[sel, 1 - side] = 0.0
            ah = self.m.ankle_height
            toe_reach = self.m.foot_length - self.m.heel_offset
            clear = 0.01 * np.sin(np.pi * swing) + ah * np.cos(p) - toe_reach * np.sin(p)
            ankles[sel, side, 2] = np.maximum(ah + s["lift"] * np.sin(np.pi * swing), clear)
            ankles[sel, 1 - side, :2] = pos[1 - side]
            ankles[sel, 1 - side, 2] = self.m.ankle_height
            planted[sel, side] = ~in_air
            task[sel] = TASK_INDEX[s["task"]]
            pos[side] = s["to"]
        # Upper body: the arm mode held; arms swing against the legs when free.
        base = CARRY if carrying else self.upper
        upper = {k: np.full(n, base[k]) for k in UPPER_FIELDS}
        if not carrying:
            c, sn = np.cos(heading), np.sin(heading)
            amp = math.radians(18.0)
            for k, side in enumerate(("left", "right")):
                rel = (ankles[:, k, 0] - root_xy[:, 0]) * c + (ankles[:, k, 1] - root_xy[:, 1]) * sn
                swing = -amp * np.clip(rel / (0.18 * self.m.stature), -1.0, 1.0)
                upper[f"{side}_upper_arm_flexion"] = upper[f"{side}_upper_arm_flexion"] + swing
                upper[f"{side}_elbow_flexion"] = upper[f"{side}_elbow_flexion"] + 0.5 * np.maximum(swing, 0.0)
        # walking lowers the pelvis a little (the knees stay bent); eased in and out of standing
        drop = WALK_PELVIS_DROP * self.m.stature / 1.75
        ease = min_jerk(local / 0.6) * min_jerk((total - local) / 0.6)
        self.chunks.append(
            _Chunk(
                f0,
                f1,
                root_xy=root_xy,
                root_dz=-drop * ease,
                heading=heading,
                upper=upper,
                ankles=ankles,
                planted=planted,
                task=task,
                carrying=np.full(n, carrying),
                pitch=pitch,
            )
        )
        self.t += total
