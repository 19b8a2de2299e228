"""Scripted workers: body sizes, a shift of tasks, and every frame's posture and 3D joints.

Each worker has a stature between 1.55 and 1.95 m (segment lengths from
:meth:`ergopose.ergonomics.body.BodyMeasurements.from_stature`) and follows a shift built from a
seed: walking between stations, lifting cartons from a pallet (stoop or squat), carrying them and
placing them on a shelf, reaching overhead, picking with a trunk twist, standing assembly at a
table, short rests. The same seed gives the same motion, bit for bit.

How the motion is made
----------------------
- Upper body: key postures (joint angles, degrees in the task tables, radians in the result) at
  key times, blended with the minimum-jerk curve 10s^3 - 15s^4 + 6s^5 (zero velocity and
  acceleration at every key posture, so the motion is smooth).
- Feet: every foot is either planted (its ankle fixed in the world, sole flat on the floor) or
  in a swing from one footprint to the next (minimum-jerk horizontally, lifted by a sine arch).
  Walking is a sequence of steps along a path planned around the furniture (A* on a 10 cm grid,
  then shortened by line of sight); the worker turns on the spot with small steps at the corners.
- Pelvis: follows the footsteps; its height is the planned height lowered where a leg could not
  reach its foot (this gives the natural dip of the pelvis during double support).
- Legs: analytic inverse kinematics from the pelvis to each ankle target (hip flexion, hip
  abduction, knee flexion), and the ankle angle that keeps the sole level.
- The 33 joints then come from :func:`ergopose.ergonomics.body.pose_skeleton` with exactly these
  angles, so the ground-truth angles are the ones the motion was built from.

The body model has no hip rotation, so a foot always points where the pelvis faces: while the
worker turns on the spot, a planted foot pivots about its ankle (the ankle itself never moves
while planted). Workers may pass through each other while walking (stations are reserved so two
workers never work at the same place at the same time, and paths avoid occupied stations).
"""

from __future__ import annotations

import dataclasses
import heapq
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.ndimage import gaussian_filter1d

from ergopose.ergonomics.body import ANGLE_FIELDS, BodyMeasurements, Posture, pose_skeleton
from ergopose.errors import ConfigError
from ergopose.keypoints import JOINT_INDEX
from ergopose.sim.scene import Scene, Station

#: Task labels (per frame per worker); the ground truth stores the index into this tuple.
TASKS: tuple[str, ...] = (
    "rest", "walk", "turn", "carry", "lift_stoop", "lift_squat", "place_shelf", "reach_overhead",
    "pick_twist", "assembly",
)
TASK_INDEX = {name: i for i, name in enumerate(TASKS)}

#: Plausible joint ranges (degrees) every simulated frame stays within (tests check it).
#: ergopose's own envelope around typical active ranges of motion, not a published table.
JOINT_LIMITS_DEG: dict[str, tuple[float, float]] = {
    "trunk_flexion": (-30, 110), "trunk_side_bend": (-40, 40), "trunk_twist": (-50, 50),
    "neck_flexion": (-60, 60), "neck_side_bend": (-40, 40), "neck_twist": (-70, 70),
    "shoulder_elevation": (-10, 30), "upper_arm_flexion": (-60, 180), "upper_arm_abduction": (-20, 180),
    "upper_arm_rotation": (-90, 90), "elbow_flexion": (0, 150), "forearm_rotation": (-90, 90),
    "wrist_flexion": (-70, 80), "wrist_deviation": (-25, 35), "hip_flexion": (-30, 130),
    "hip_abduction": (-30, 45), "knee_flexion": (0, 150), "ankle_flexion": (-50, 45),
}

LEG_FIELDS = tuple(f"{s}_{n}" for s in ("left", "right")
                   for n in ("hip_flexion", "hip_abduction", "knee_flexion", "ankle_flexion"))
UPPER_FIELDS = tuple(f for f in ANGLE_FIELDS if f not in LEG_FIELDS)
_BILATERAL = ("shoulder_elevation", "upper_arm_flexion", "upper_arm_abduction", "upper_arm_rotation",
              "elbow_flexion", "forearm_rotation", "wrist_flexion", "wrist_deviation")

#: Upper-body key postures (degrees). Bilateral names apply to both sides.
NEUTRAL_DEG = {"trunk_flexion": 2.0, "neck_flexion": 6.0, "upper_arm_flexion": 2.0, "upper_arm_abduction": 9.0,
               "upper_arm_rotation": 5.0, "elbow_flexion": 14.0}
CARRY_DEG = {"trunk_flexion": -2.0, "neck_flexion": 10.0, "upper_arm_flexion": 22.0, "upper_arm_abduction": 14.0,
             "upper_arm_rotation": 14.0, "elbow_flexion": 88.0}

#: Fraction of the leg length (hip to ankle) the pelvis may stretch a leg to.
MAX_LEG_STRETCH = 0.998
#: Lateral offset of each ankle from the pelvis centre when standing, beyond half the hip width.
STANCE_EXTRA_WIDTH = 0.0
#: Clearance kept around furniture by walking paths (metres, from the mid-hip point).
PATH_CLEARANCE = 0.3
GRID_STEP = 0.1
#: Step length as a fraction of stature, and the fraction of each step both feet are down at its
#: start and at its end (double support).
STEP_LENGTH = 0.32
#: Path corners sharper than this (degrees) are walked as stop, turn on the spot, go on.
SHARP_CORNER_DEG = 35.0
DOUBLE_SUPPORT = 0.14
#: How much lower the pelvis is while walking than while standing (metres, for 1.75 m stature).
WALK_PELVIS_DROP = 0.045


@dataclass(frozen=True)
class Appearance:
    """Colours of a mannequin (BGR, 0-255)."""

    skin: tuple[int, int, int]
    hair: tuple[int, int, int]
    shirt: tuple[int, int, int]
    trousers: tuple[int, int, int]
    shoes: tuple[int, int, int]

    def to_dict(self) -> dict[str, list[int]]:
        return {k: list(v) for k, v in dataclasses.asdict(self).items()}


@dataclass(frozen=True)
class WorkerSpec:
    """One simulated worker: id, body, clothes and walking speed (m/s)."""

    worker_id: str
    measurements: BodyMeasurements
    appearance: Appearance
    walk_speed: float

    @property
    def stature(self) -> float:
        return self.measurements.stature


@dataclass(frozen=True)
class FactorPeriod:
    """A time window (seconds from the start) with what the cameras cannot see (load and grip)."""

    start_s: float
    end_s: float
    load_kg: float
    load_mode: str
    coupling: str


@dataclass(frozen=True)
class WorkerMotion:
    """The whole shift of one worker, F frames.

    posture: a :class:`Posture` whose fields are arrays of shape (F,) (root_position (F, 3)):
        the angles the motion was built from (radians).
    joints_world: (F, 33, 3) BlazePose landmarks, metres, world frame.
    task: (F,) int8 index into :data:`TASKS`.
    planted: (F, 2) bool, left and right foot planted (ankle fixed, sole flat on the floor).
    carrying: (F,) bool, the worker holds a carton (the renderer draws it between the hands).
    periods: load periods (for the session settings: what the cameras cannot see).
    """

    spec: WorkerSpec
    posture: Posture
    joints_world: np.ndarray
    task: np.ndarray
    planted: np.ndarray
    carrying: np.ndarray
    periods: tuple[FactorPeriod, ...]

    @property
    def worker_id(self) -> str:
        return self.spec.worker_id

    def angles(self) -> dict[str, np.ndarray]:
        """Every angle field (radians, (F,)) plus heading."""
        out = {name: np.asarray(getattr(self.posture, name)) for name in ANGLE_FIELDS}
        out["heading"] = np.asarray(self.posture.heading)
        return out


@dataclass(frozen=True)
class Motion:
    """All workers over F frames at ``fps``."""

    fps: float
    n_frames: int
    workers: tuple[WorkerMotion, ...]
    seed: int

    @property
    def worker_ids(self) -> tuple[str, ...]:
        return tuple(w.worker_id for w in self.workers)

    @property
    def joints_world(self) -> np.ndarray:
        """(F, W, 33, 3) joints of every worker."""
        return np.stack([w.joints_world for w in self.workers], axis=1)

    @property
    def times_s(self) -> np.ndarray:
        return np.arange(self.n_frames) / self.fps


# --- workers -------------------------------------------------------------------------------------

_SKINS = ((120, 160, 220), (95, 140, 200), (70, 110, 160), (150, 180, 230), (50, 80, 125), (110, 150, 205))
_HAIRS = ((30, 30, 35), (40, 60, 90), (25, 25, 25), (90, 140, 190), (120, 120, 125), (20, 40, 70))
_SHIRTS = ((40, 40, 200), (200, 120, 30), (40, 160, 60), (30, 170, 230), (150, 60, 140), (200, 200, 200),
           (60, 60, 60), (180, 140, 90))
_TROUSERS = ((90, 60, 30), (50, 50, 50), (110, 100, 90), (40, 60, 90), (30, 30, 30))
_SHOES = ((20, 20, 20), (60, 60, 60), (30, 40, 70), (200, 200, 200))


def make_workers(n_workers: int, rng: np.random.Generator) -> tuple[WorkerSpec, ...]:
    """``n_workers`` (1-4) workers with distinct statures in 1.55-1.95 m and distinct clothes."""
    if not 1 <= n_workers <= 4:
        raise ConfigError(f"expected 1 to 4 workers, got {n_workers}", field="workers")
    # Spread the statures: one draw per equal slice of the range, in random order.
    edges = np.linspace(1.56, 1.94, n_workers + 1)
    statures = edges[:-1] + rng.uniform(0.0, 1.0, n_workers) * np.diff(edges)
    statures = statures[rng.permutation(n_workers)]
    shirts = rng.choice(len(_SHIRTS), n_workers, replace=False)
    out = []
    for k in range(n_workers):
        m = BodyMeasurements.from_stature(round(float(statures[k]), 4))
        look = Appearance(skin=_SKINS[rng.integers(len(_SKINS))], hair=_HAIRS[rng.integers(len(_HAIRS))],
                          shirt=_SHIRTS[shirts[k]], trousers=_TROUSERS[rng.integers(len(_TROUSERS))],
                          shoes=_SHOES[rng.integers(len(_SHOES))])
        speed = round(float(rng.uniform(0.95, 1.2)) * m.stature / 1.75, 4)
        out.append(WorkerSpec(worker_id=f"w{k + 1}", measurements=m, appearance=look, walk_speed=speed))
    return tuple(out)


# --- small helpers ---------------------------------------------------------------------------------


def min_jerk(s: np.ndarray) -> np.ndarray:
    """The minimum-jerk blend 10s^3 - 15s^4 + 6s^5 of s clipped to [0, 1]."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _rot2(h: float) -> np.ndarray:
    return np.array([[math.cos(h), -math.sin(h)], [math.sin(h), math.cos(h)]])


def _expand(pose_deg: dict[str, float]) -> dict[str, float]:
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
    base.update(_expand(pose_deg))
    return base


NEUTRAL = _full_pose(NEUTRAL_DEG)
CARRY = _full_pose(CARRY_DEG)


# --- path planning ---------------------------------------------------------------------------------


class _Grid:
    """Occupancy grid of the area for walking (furniture inflated by PATH_CLEARANCE)."""

    def __init__(self, scene: Scene):
        x0, x1, y0, y1 = scene.area
        self.x0, self.y0 = x0, y0
        self.nx = int(round((x1 - x0) / GRID_STEP))
        self.ny = int(round((y1 - y0) / GRID_STEP))
        xs = x0 + (np.arange(self.nx) + 0.5) * GRID_STEP
        ys = y0 + (np.arange(self.ny) + 0.5) * GRID_STEP
        self.cx, self.cy = np.meshgrid(xs, ys, indexing="ij")
        blocked = (self.cx < x0 + 0.25) | (self.cx > x1 - 0.25) | (self.cy < y0 + 0.25) | (self.cy > y1 - 0.25)
        for bx0, by0, bx1, by1 in scene.obstacles_xy():
            blocked |= _box_distance(self.cx, self.cy, bx0, by0, bx1, by1) < PATH_CLEARANCE
        self.static = blocked
        self.obstacles = scene.obstacles_xy()

    def free_point(self, p: np.ndarray, circles: list[tuple[float, float, float]]) -> bool:
        x, y = float(p[0]), float(p[1])
        for bx0, by0, bx1, by1 in self.obstacles:
            if _box_distance(x, y, bx0, by0, bx1, by1) < PATH_CLEARANCE - 1e-9:
                return False
        return all(math.hypot(x - cx, y - cy) >= r for cx, cy, r in circles)

    def cell(self, p: np.ndarray) -> tuple[int, int]:
        i = int(np.clip((p[0] - self.x0) / GRID_STEP, 0, self.nx - 1))
        j = int(np.clip((p[1] - self.y0) / GRID_STEP, 0, self.ny - 1))
        return i, j

    def centre(self, c: tuple[int, int]) -> np.ndarray:
        return np.array([self.x0 + (c[0] + 0.5) * GRID_STEP, self.y0 + (c[1] + 0.5) * GRID_STEP])


def _box_distance(x, y, bx0, by0, bx1, by1):
    dx = np.maximum(np.maximum(bx0 - x, x - bx1), 0.0)
    dy = np.maximum(np.maximum(by0 - y, y - by1), 0.0)
    return np.hypot(dx, dy)


def plan_path(grid: _Grid, start: np.ndarray, goal: np.ndarray,
              circles: list[tuple[float, float, float]] = ()) -> np.ndarray:
    """Waypoints (n, 2) from start to goal around the furniture (and the given circles (x, y, r)).

    A* over the 8-connected grid, then shortened: from each waypoint, jump to the farthest later
    one in line of sight. Start and goal themselves may lie in blocked cells (stations are close
    to furniture); the path leaves and enters them in a straight line.
    """
    circles = list(circles)
    blocked = grid.static.copy()
    for cx, cy, r in circles:
        blocked |= np.hypot(grid.cx - cx, grid.cy - cy) < r
    s, g = grid.cell(start), grid.cell(goal)
    blocked[s] = False
    blocked[g] = False
    steps = [(1, 0, 1.0), (-1, 0, 1.0), (0, 1, 1.0), (0, -1, 1.0),
             (1, 1, math.sqrt(2)), (1, -1, math.sqrt(2)), (-1, 1, math.sqrt(2)), (-1, -1, math.sqrt(2))]
    came: dict[tuple[int, int], tuple[int, int]] = {}
    cost = {s: 0.0}
    heap = [(0.0, 0, s)]
    counter = 0
    found = False
    while heap:
        _, _, c = heapq.heappop(heap)
        if c == g:
            found = True
            break
        for di, dj, w in steps:
            n = (c[0] + di, c[1] + dj)
            if not (0 <= n[0] < grid.nx and 0 <= n[1] < grid.ny) or blocked[n]:
                continue
            if di and dj and (blocked[c[0] + di, c[1]] or blocked[c[0], c[1] + dj]):
                continue  # no corner cutting
            nc = cost[c] + w
            if nc < cost.get(n, math.inf):
                cost[n] = nc
                came[n] = c
                counter += 1
                heapq.heappush(heap, (nc + math.hypot(g[0] - n[0], g[1] - n[1]), counter, n))
    if not found:
        if circles:
            return plan_path(grid, start, goal, ())
        return np.array([start, goal], dtype=np.float64)
    cells = [g]
    while cells[-1] != s:
        cells.append(came[cells[-1]])
    cells.reverse()
    points = [np.asarray(start, float)] + [grid.centre(c) for c in cells[1:-1]] + [np.asarray(goal, float)]

    def visible(a: np.ndarray, b: np.ndarray) -> bool:
        n = max(2, int(math.ceil(np.linalg.norm(b - a) / 0.04)) + 1)
        for t in np.linspace(0.0, 1.0, n)[1:-1]:
            p = a + (b - a) * t
            i, j = grid.cell(p)
            if blocked[i, j] and (i, j) not in (s, g):
                return False
        return True

    out = [points[0]]
    k = 0
    while k < len(points) - 1:
        nxt = k + 1
        for m in range(len(points) - 1, k, -1):
            if visible(points[k], points[m]):
                nxt = m
                break
        out.append(points[nxt])
        k = nxt
    return np.array(out)


def _rounded_curve(points: np.ndarray, radius: float = 0.6, spacing: float = 0.02) -> np.ndarray:
    """A polyline with its corners rounded (quadratic Bezier from ``radius`` before to ``radius``
    after each corner, at most half of each segment), sampled every ``spacing`` metres."""
    if len(points) == 2:
        n = max(2, int(math.ceil(np.linalg.norm(points[1] - points[0]) / spacing)) + 1)
        return points[0] + (points[1] - points[0]) * np.linspace(0.0, 1.0, n)[:, None]
    pieces = [points[0][None, :]]
    start = points[0]
    for i in range(1, len(points) - 1):
        a, c, b = points[i - 1], points[i], points[i + 1]
        ra = min(radius, 0.5 * np.linalg.norm(c - a))
        rb = min(radius, 0.5 * np.linalg.norm(b - c))
        p_in = c + (a - c) * ra / np.linalg.norm(c - a)
        p_out = c + (b - c) * rb / np.linalg.norm(b - c)
        n = max(2, int(math.ceil(np.linalg.norm(p_in - start) / spacing)) + 1)
        pieces.append(start + (p_in - start) * np.linspace(0.0, 1.0, n)[1:, None])
        t = np.linspace(0.0, 1.0, 25)[1:, None]
        pieces.append((1 - t) ** 2 * p_in + 2 * (1 - t) * t * c + t ** 2 * p_out)
        start = p_out
    end = points[-1]
    n = max(2, int(math.ceil(np.linalg.norm(end - start) / spacing)) + 1)
    pieces.append(start + (end - start) * np.linspace(0.0, 1.0, n)[1:, None])
    curve = np.concatenate(pieces)
    keep = np.concatenate([[True], np.linalg.norm(np.diff(curve, axis=0), axis=1) > 1e-9])
    return curve[keep]


# --- leg inverse kinematics -------------------------------------------------------------------------


def leg_ik(m: BodyMeasurements, root: np.ndarray, heading: np.ndarray, ankle_world: np.ndarray,
           side: str, foot_pitch: np.ndarray | float = 0.0) -> dict[str, np.ndarray]:
    """Hip flexion, hip abduction, knee flexion and ankle flexion that put the ankle at ``ankle_world``.

    root (F, 3) mid-hip point, heading (F,), ankle_world (F, 3). The ankle angle keeps the sole
    level (plus ``foot_pitch``, toes up positive). Targets beyond MAX_LEG_STRETCH of the leg are
    reached as far as the leg allows (the callers keep the pelvis low enough that this never
    happens). Conventions: those of :mod:`ergopose.ergonomics.body`.
    """
    sigma = 1.0 if side == "left" else -1.0
    lt, ls = m.thigh_length, m.shank_length
    d_world = np.asarray(ankle_world, float) - np.asarray(root, float)
    c, s = np.cos(heading), np.sin(heading)
    vx = c * d_world[:, 0] + s * d_world[:, 1]
    vy = -s * d_world[:, 0] + c * d_world[:, 1] - sigma * m.hip_width / 2.0
    vz = d_world[:, 2]
    dist = np.sqrt(vx * vx + vy * vy + vz * vz)
    dist = np.clip(dist, abs(lt - ls) + 1e-6, (lt + ls) * (1.0 - 1e-12))
    cos_k = (dist * dist - lt * lt - ls * ls) / (2.0 * lt * ls)
    knee = np.arccos(np.clip(cos_k, -1.0, 1.0))
    rho = lt + ls * np.cos(knee)
    ab_signed = np.arcsin(np.clip(vy / rho, -1.0, 1.0))  # sigma * hip_abduction
    a = -ls * np.sin(knee)
    zp = -rho * np.cos(ab_signed)
    hip_flex = np.arctan2(vz, vx) - np.arctan2(zp, a)
    hip_flex = (hip_flex + np.pi) % (2 * np.pi) - np.pi
    beta = np.arctan2(np.sin(hip_flex), np.cos(hip_flex) * np.cos(ab_signed))
    ankle = knee - beta + foot_pitch
    return {f"{side}_hip_flexion": hip_flex, f"{side}_hip_abduction": sigma * ab_signed,
            f"{side}_knee_flexion": knee, f"{side}_ankle_flexion": ankle}


# --- the timeline of one worker ------------------------------------------------------------------------


@dataclass
class _Chunk:
    f0: int
    f1: int
    root_xy: np.ndarray      # (n, 2)
    root_dz: np.ndarray      # (n,) planned height offset from the neutral height
    heading: np.ndarray      # (n,)
    upper: dict[str, np.ndarray]
    ankles: np.ndarray       # (n, 2, 3)
    planted: np.ndarray      # (n, 2)
    task: np.ndarray         # (n,)
    carrying: np.ndarray     # (n,)
    pitch: np.ndarray | None = None   # (n, 2) foot pitch in swing (toes up positive); None = level


class _Track:
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
        self.neutral_z = self.m.ankle_height + math.sqrt((MAX_LEG_STRETCH * leg) ** 2 - lateral ** 2) - 1e-4

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

    def pose_task(self, task: str, keys: list[tuple[float, dict[str, float]]], carrying=None,
                  period: tuple[float, float, float, str, str] | None = None) -> None:
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
            f0, f1, root_xy=self.root_xy[None, :] + offsets, root_dz=cols["dz"], heading=np.full(n, self.heading),
            upper={k: cols[k] for k in UPPER_FIELDS}, ankles=np.broadcast_to(self.ankles, (n, 2, 3)).copy(),
            planted=np.ones((n, 2), bool), task=np.full(n, TASK_INDEX[task], np.int8),
            carrying=np.zeros(n, bool) if carrying is None else (local >= carrying[0]) & (local < carrying[1]))
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
                steps.append({"side": side, "to": to, "h0": h0, "h1": h1, "root1": root.copy(),
                              "dur": 0.45 * t_step + 0.12, "lift": 0.04, "pitch": math.radians(8.0),
                              "task": turn_task})
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
            curve = _rounded_curve(np.array(run))
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
                steps.append({"side": side, "to": to, "h0": heading, "h1": h1, "root1": at(arc)[0],
                              "run": (run_id, curve, cum), "arc1": arc,
                              "dur": t_step, "lift": 0.07, "pitch": math.radians(25.0), "task": task})
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
            key_t = np.concatenate([[starts[k]], starts[k + 1:m + 1]])
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
        self.chunks.append(_Chunk(f0, f1, root_xy=root_xy, root_dz=-drop * ease, heading=heading, upper=upper,
                                  ankles=ankles, planted=planted, task=task, carrying=np.full(n, carrying),
                                  pitch=pitch))
        self.t += total


# --- the tasks ----------------------------------------------------------------------------------------


def _vary(rng: np.random.Generator, value: float, spread: float) -> float:
    return float(value + rng.uniform(-spread, spread))


def _do_task(track: _Track, task: str, station: Station, rng: np.random.Generator,
             carton_kg: float = 0.0) -> None:
    """Append one task at ``station`` (the worker is already standing there)."""
    m = track.m
    h = m.stature
    k = float(rng.uniform(0.85, 1.2))  # tempo of this repetition
    if task == "rest":
        d = float(rng.uniform(3.0, 7.0))
        track.pose_task("rest", [
            (1.2, {**NEUTRAL, "dy": 0.03, **_expand({"neck_flexion": 12.0, "trunk_flexion": 0.0})}),
            (d * 0.6, {"dy": -0.02, **_expand({"neck_flexion": 4.0, "neck_twist": _vary(rng, 0.0, 25.0)})}),
            (d, dict(NEUTRAL)),
        ])
    elif task == "lift_stoop":
        trunk = _vary(rng, 78.0, 8.0)
        down = {**_expand({"trunk_flexion": trunk, "neck_flexion": -12.0, "upper_arm_flexion": trunk + 12.0,
                           "upper_arm_abduction": 12.0, "elbow_flexion": 15.0, "upper_arm_rotation": 10.0}),
                "dx": -0.05 * h, "dz": -0.02}
        grasp = _expand({"elbow_flexion": 22.0, "wrist_flexion": 10.0})
        t1, t2, t3 = 1.4 * k, 2.1 * k, 3.6 * k
        track.pose_task("lift_stoop", [(t1, down), (t2, grasp), (t3, dict(CARRY))],
                        carrying=(t2, math.inf), period=(t2, t3, carton_kg, "intermittent", "fair"))
    elif task == "lift_squat":
        trunk = _vary(rng, 38.0, 6.0)
        down = {**_expand({"trunk_flexion": trunk, "neck_flexion": -15.0, "upper_arm_flexion": trunk + 22.0,
                           "upper_arm_abduction": 16.0, "elbow_flexion": 12.0, "upper_arm_rotation": 10.0}),
                "dx": -0.09 * h, "dz": 0.35 * h - track.neutral_z}
        grasp = _expand({"elbow_flexion": 20.0, "wrist_flexion": 10.0})
        t1, t2, t3 = 1.6 * k, 2.3 * k, 4.0 * k
        track.pose_task("lift_squat", [(t1, down), (t2, grasp), (t3, dict(CARRY))],
                        carrying=(t2, math.inf), period=(t2, t3, carton_kg, "intermittent", "fair"))
    elif task == "place_shelf":
        shoulder_z = 0.818 * h
        arm = m.upper_arm_length + m.forearm_length + 0.5 * m.hand_length
        flex = 90.0 + math.degrees(math.asin(float(np.clip((station.work_height - shoulder_z) / arm, -0.8, 0.95))))
        flex = float(np.clip(flex, 45.0, 150.0))
        up = {**_expand({"upper_arm_flexion": flex, "upper_arm_abduction": 12.0, "elbow_flexion": 25.0,
                         "upper_arm_rotation": 8.0, "trunk_flexion": 3.0,
                         "neck_flexion": -10.0 if station.work_height > 0.75 * h else 12.0,
                         "shoulder_elevation": 10.0 if flex > 100 else 2.0}), "dx": 0.03}
        t1, t2, t3 = 1.3 * k, 2.0 * k, 3.3 * k
        track.pose_task("place_shelf", [(t1, up), (t2, _expand({"wrist_flexion": -10.0})), (t3, dict(NEUTRAL))],
                        carrying=(0.0, t2), period=(0.0, t2, carton_kg, "intermittent", "fair"))
    elif task == "reach_overhead":
        flex = _vary(rng, 158.0, 8.0)
        up = _expand({"upper_arm_flexion": flex, "upper_arm_abduction": 12.0, "elbow_flexion": 18.0,
                      "neck_flexion": -28.0, "trunk_flexion": -6.0, "shoulder_elevation": 22.0,
                      "wrist_flexion": -10.0})
        hold = _expand({"wrist_deviation": 10.0, "elbow_flexion": 24.0})
        t1, t2, t3 = 1.4 * k, 2.6 * k, 4.0 * k
        track.pose_task("reach_overhead", [(t1, up), (t2, hold), (t3, dict(NEUTRAL))],
                        period=(0.5, t3 - 0.5, 1.0, "intermittent", "good"))
    elif task == "pick_twist":
        sigma = 1.0 if rng.uniform() < 0.5 else -1.0
        reach, other = ("left", "right") if sigma > 0 else ("right", "left")
        twist = _vary(rng, 34.0, 6.0)
        out = {**_expand({"trunk_twist": sigma * twist, "trunk_side_bend": -sigma * 8.0, "trunk_flexion": 22.0,
                          "neck_twist": sigma * 22.0, "neck_flexion": 15.0}),
               **{f"{reach}_upper_arm_flexion": math.radians(65.0), f"{reach}_upper_arm_abduction": math.radians(28.0),
                  f"{reach}_elbow_flexion": math.radians(18.0), f"{other}_upper_arm_flexion": math.radians(15.0),
                  f"{other}_elbow_flexion": math.radians(35.0)}}
        back = _expand({"trunk_twist": 0.0, "trunk_side_bend": 0.0, "trunk_flexion": 8.0, "neck_twist": 0.0,
                        "neck_flexion": 20.0, "upper_arm_flexion": 30.0, "upper_arm_abduction": 10.0,
                        "elbow_flexion": 75.0})
        t1, t2, t3, t4 = 1.2 * k, 1.8 * k, 3.0 * k, 3.8 * k
        track.pose_task("pick_twist", [(t1, out), (t2, _expand({"wrist_flexion": 12.0})), (t3, back),
                                       (t4, dict(NEUTRAL))], period=(t2, t4, 2.0, "intermittent", "good"))
    elif task == "assembly":
        d = float(rng.uniform(10.0, 26.0))
        trunk = _vary(rng, 20.0, 5.0)
        neck = _vary(rng, 28.0, 6.0)
        work = _expand({"trunk_flexion": trunk, "neck_flexion": neck, "upper_arm_flexion": 38.0,
                        "upper_arm_abduction": 14.0, "upper_arm_rotation": 20.0, "elbow_flexion": 88.0,
                        "forearm_rotation": 45.0, "wrist_flexion": 8.0})
        keys: list[tuple[float, dict[str, float]]] = [(1.2, {**work, "dx": 0.03})]
        period = float(rng.uniform(2.6, 3.6))
        t = 1.2
        reach = True
        while t + period / 2 < d - 1.2:
            t += period / 2
            if reach:
                change = {"right_upper_arm_flexion": math.radians(_vary(rng, 56.0, 6.0)),
                          "right_elbow_flexion": math.radians(55.0), "right_wrist_flexion": math.radians(-15.0),
                          "right_wrist_deviation": math.radians(8.0), "left_wrist_flexion": math.radians(20.0),
                          "trunk_flexion": math.radians(trunk + 6.0)}
            else:
                change = {"right_upper_arm_flexion": math.radians(38.0), "right_elbow_flexion": math.radians(88.0),
                          "right_wrist_flexion": math.radians(18.0), "right_wrist_deviation": math.radians(-6.0),
                          "left_wrist_flexion": math.radians(5.0), "trunk_flexion": math.radians(trunk)}
            keys.append((t, change))
            reach = not reach
        keys.append((t + 1.2, {**dict(NEUTRAL)}))
        track.pose_task("assembly", keys, period=(1.2, t, round(float(rng.uniform(0.5, 1.5)), 2), "repeated", "good"))
    else:
        raise ValueError(f"unknown task {task!r}")


# --- the shift -----------------------------------------------------------------------------------------

#: Jobs and their weights: a job is one or two tasks at stations.
JOBS = (("lift_and_place", 0.32), ("reach_overhead", 0.14), ("pick_twist", 0.16), ("assembly", 0.24),
        ("rest", 0.14))


class _Reservations:
    def __init__(self) -> None:
        self.busy: dict[str, list[tuple[float, float, str]]] = {}

    def free(self, station: str, t0: float, t1: float, worker: str) -> bool:
        return all(w == worker or t1 <= a or t0 >= b for a, b, w in self.busy.get(station, []))

    def add(self, station: str, t0: float, t1: float, worker: str) -> None:
        self.busy.setdefault(station, []).append((t0, t1, worker))

    def occupied(self, t0: float, t1: float, worker: str) -> list[str]:
        return [s for s, spans in self.busy.items() for a, b, w in spans if w != worker and not (t1 <= a or t0 >= b)]


def simulate_motion(scene: Scene, n_workers: int, duration_s: float, fps: float, seed: int) -> Motion:
    """Workers and their shifts: ``n_workers`` (1-4) for ``duration_s`` seconds at ``fps``.

    Deterministic: the same arguments give the same Motion (bit for bit).
    """
    if not (duration_s > 0 and math.isfinite(duration_s)):
        raise ConfigError(f"expected a positive duration, got {duration_s}", field="minutes")
    if not (fps > 0 and math.isfinite(fps)):
        raise ConfigError(f"expected a positive frame rate, got {fps}", field="fps")
    n_frames = int(round(duration_s * fps))
    if n_frames < 2:
        raise ConfigError(f"{duration_s} s at {fps} fps is fewer than 2 frames", field="minutes")
    root_seq = np.random.SeedSequence(seed)
    rng_workers, *rng_tracks = [np.random.default_rng(s) for s in root_seq.spawn(n_workers + 1)]
    specs = make_workers(n_workers, rng_workers)
    grid = _Grid(scene)
    stations = {s.name: s for s in scene.stations}
    # Distinct start stations (not the pallets: a shift starts empty-handed).
    starts = [s for s in scene.stations if not s.tasks[0].startswith("lift")]
    order = rng_workers.permutation(len(starts))[:n_workers]
    tracks = [_Track(spec, fps, starts[i], rng) for spec, i, rng in zip(specs, order, rng_tracks)]
    reservations = _Reservations()
    positions: dict[str, np.ndarray] = {}
    for tr in tracks:
        positions[tr.spec.worker_id] = tr.root_xy.copy()
    end_time = n_frames / fps + 0.5
    # First task where each worker starts.
    for tr in tracks:
        first = tr.station.tasks[0] if tr.station.tasks[0] != "place_shelf" else "reach_overhead"
        t0 = tr.t
        _do_task(tr, first, tr.station, tr.rng)
        reservations.add(tr.station.name, t0, tr.t, tr.spec.worker_id)
    while True:
        live = [tr for tr in tracks if tr.t < end_time]
        if not live:
            break
        tr = min(live, key=lambda x: (x.t, x.spec.worker_id))
        _next_job(tr, scene, stations, grid, reservations, tracks)
    workers = tuple(_finish(tr, n_frames) for tr in tracks)
    return Motion(fps=float(fps), n_frames=n_frames, workers=workers, seed=int(seed))


def _walk_time(path: np.ndarray, speed: float) -> float:
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()) / speed + 2.5


def _go(tr: _Track, station: Station, grid: _Grid, reservations: _Reservations, tracks: list[_Track],
        stations: dict[str, Station], carrying: bool, t_hold: float) -> None:
    """Walk to ``station`` avoiding stations other workers occupy meanwhile (and where they stand now)."""
    start = tr.root_xy.copy()
    goal = np.array(station.position, float)
    occupied = reservations.occupied(tr.t, tr.t + t_hold, tr.spec.worker_id)
    circles = [(*stations[s].position, 0.55) for s in occupied if s != station.name]
    for other in tracks:
        if other is not tr:
            circles.append((float(other.root_xy[0]), float(other.root_xy[1]), 0.55))
    circles = [c for c in circles if math.hypot(c[0] - start[0], c[1] - start[1]) > c[2] + 0.05
               and math.hypot(c[0] - goal[0], c[1] - goal[1]) > c[2] + 0.05]
    path = plan_path(grid, start, goal, circles)
    tr.walk(path, station.heading, carrying)


def _pick_station(tr: _Track, task: str, scene: Scene, reservations: _Reservations, grid: _Grid,
                  hold_s: float) -> Station | None:
    candidates = [s for s in scene.stations if task in s.tasks]
    free = []
    for s in candidates:
        eta = tr.t + _walk_time(np.array([tr.root_xy, s.position]), tr.spec.walk_speed) * 1.5
        if reservations.free(s.name, tr.t, eta + hold_s, tr.spec.worker_id):
            free.append(s)
    if not free:
        return None
    return free[int(tr.rng.integers(len(free)))]


def _next_job(tr: _Track, scene: Scene, stations: dict[str, Station], grid: _Grid,
              reservations: _Reservations, tracks: list[_Track]) -> None:
    names = [j for j, _ in JOBS]
    weights = np.array([w for _, w in JOBS])
    job = names[int(tr.rng.choice(len(names), p=weights / weights.sum()))]
    wid = tr.spec.worker_id
    if job == "lift_and_place":
        pallet = _pick_station(tr, "lift_stoop", scene, reservations, grid, 6.0)
        if pallet is None:
            _rest_here(tr, reservations)
            return
        else:
            t0 = tr.t
            reservations.add(pallet.name, t0, t0 + 30.0, wid)  # provisional, replaced below
            _go(tr, pallet, grid, reservations, tracks, stations, False, 8.0)
            tr.station = pallet
            t_arrive = tr.t
            kg = round(float(tr.rng.uniform(4.0, 18.0)), 1)
            lift = "lift_squat" if tr.rng.uniform() < 0.45 else "lift_stoop"
            _do_task(tr, lift, pallet, tr.rng, carton_kg=kg)
            reservations.busy[pallet.name] = [r for r in reservations.busy[pallet.name] if r != (t0, t0 + 30.0, wid)]
            reservations.add(pallet.name, t_arrive - 1.0, tr.t + 0.5, wid)
            shelf = _pick_station(tr, "place_shelf", scene, reservations, grid, 5.0)
            if shelf is None:  # put it back down where it came from
                _do_task(tr, "place_shelf", dataclasses.replace(pallet, work_height=0.6), tr.rng, carton_kg=kg)
                return
            t1 = tr.t
            _go(tr, shelf, grid, reservations, tracks, stations, True, 8.0)
            tr.station = shelf
            # the walk carried the carton: a load period for it
            tr.periods.append(FactorPeriod(round(t1, 6), round(tr.t, 6), kg, "intermittent", "fair"))
            t_arrive = tr.t
            _do_task(tr, "place_shelf", shelf, tr.rng, carton_kg=kg)
            reservations.add(shelf.name, t_arrive - 1.0, tr.t + 0.5, wid)
            return
    if job == "rest" and tr.rng.uniform() < 0.5:
        _rest_here(tr, reservations)
        return
    task = job
    station = _pick_station(tr, task, scene, reservations, grid, 25.0 if task == "assembly" else 6.0)
    if station is None:
        _rest_here(tr, reservations)
        return
    _go(tr, station, grid, reservations, tracks, stations, False, 8.0)
    tr.station = station
    t_arrive = tr.t
    _do_task(tr, task, station, tr.rng)
    reservations.add(station.name, t_arrive - 1.0, tr.t + 0.5, wid)


def _rest_here(tr: _Track, reservations: _Reservations) -> None:
    """A short rest where the worker stands (the place stays reserved meanwhile)."""
    t0 = tr.t
    _do_task(tr, "rest", tr.station, tr.rng)
    reservations.add(tr.station.name, t0, tr.t + 0.5, tr.spec.worker_id)


def _finish(tr: _Track, n_frames: int) -> WorkerMotion:
    """Concatenate the chunks, fix the pelvis height, solve the legs, run the skeleton."""
    chunks = tr.chunks
    f_end = chunks[-1].f1
    if f_end < n_frames:
        raise AssertionError("the shift is shorter than the session")  # end_time covers n_frames
    cat = lambda name: np.concatenate([getattr(c, name) for c in chunks])[:n_frames]  # noqa: E731
    root_xy = cat("root_xy")
    root_dz = cat("root_dz")
    heading = cat("heading")
    ankles = cat("ankles")
    planted = cat("planted")
    task = cat("task")
    carrying = cat("carrying")
    pitch = np.concatenate([c.pitch if c.pitch is not None else np.zeros((c.f1 - c.f0, 2)) for c in chunks])[:n_frames]
    upper = {k: np.concatenate([c.upper[k] for c in chunks])[:n_frames] for k in UPPER_FIELDS}
    m = tr.m
    leg = m.thigh_length + m.shank_length
    reach = MAX_LEG_STRETCH * leg
    z_plan = tr.neutral_z + root_dz
    c, s = np.cos(heading), np.sin(heading)

    def z_limit() -> np.ndarray:
        out = np.full(n_frames, np.inf)
        for k, sigma in enumerate((1.0, -1.0)):
            hip = root_xy + sigma * (m.hip_width / 2.0) * np.stack([-s, c], axis=1)
            horiz = np.linalg.norm(ankles[:, k, :2] - hip, axis=1)
            out = np.minimum(out, ankles[:, k, 2] + np.sqrt(np.maximum(reach * reach - horiz * horiz, 0.0)))
        return out

    limit = z_limit()
    z = np.minimum(z_plan, limit)
    for _ in range(4):  # smooth the dips where a leg limits the pelvis, staying below the limit
        z = np.minimum(gaussian_filter1d(z, 1.0, mode="nearest"), limit)
    root = np.concatenate([root_xy, z[:, None]], axis=1)
    legs: dict[str, np.ndarray] = {}
    for k, side in enumerate(("left", "right")):
        legs.update(leg_ik(m, root, heading, ankles[:, k], side, foot_pitch=pitch[:, k]))
    posture = Posture(root_position=root, heading=heading, **upper, **legs)
    joints = pose_skeleton(m, posture)
    # The legs must have reached their targets (the pelvis was kept low enough).
    for k, side in enumerate(("left", "right")):
        err = np.abs(joints[:, JOINT_INDEX[f"{side}_ankle"]] - ankles[:, k]).max()
        if err > 1e-6:
            raise AssertionError(f"leg IK missed the {side} ankle by {err:.3g} m")
    periods = tuple(p for p in sorted(tr.periods, key=lambda p: p.start_s) if p.start_s < n_frames / tr.fps)
    return WorkerMotion(spec=tr.spec, posture=posture, joints_world=joints, task=task, planted=planted,
                        carrying=carrying, periods=periods)
