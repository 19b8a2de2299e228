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

The pieces: :mod:`ergopose.sim.workforce` (the records), :mod:`ergopose.sim.paths`,
:mod:`ergopose.sim.legs`, :mod:`ergopose.sim.timeline` and :mod:`ergopose.sim.tasks`; this module
plans the shift (:func:`simulate_motion`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ergopose.ergonomics.body import Posture, pose_skeleton
from ergopose.errors import ConfigError
from ergopose.keypoints import JOINT_INDEX
from ergopose.sim.legs import MAX_LEG_STRETCH, leg_ik
from ergopose.sim.paths import WalkGrid, plan_path
from ergopose.sim.scene import Scene, Station
from ergopose.sim.tasks import do_task
from ergopose.sim.timeline import UPPER_FIELDS, TimelineBuilder
from ergopose.sim.workforce import FactorPeriod, Motion, WorkerMotion, make_workers

# --- the shift -----------------------------------------------------------------------------------------

#: Jobs and their weights: a job is one or two tasks at stations.
JOBS = (("lift_and_place", 0.32), ("reach_overhead", 0.14), ("pick_twist", 0.16), ("assembly", 0.24), ("rest", 0.14))


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
    grid = WalkGrid(scene)
    stations = {s.name: s for s in scene.stations}
    # Distinct start stations (not the pallets: a shift starts empty-handed).
    starts = [s for s in scene.stations if not s.tasks[0].startswith("lift")]
    order = rng_workers.permutation(len(starts))[:n_workers]
    tracks = [TimelineBuilder(spec, fps, starts[i], rng) for spec, i, rng in zip(specs, order, rng_tracks)]
    reservations = _Reservations()
    positions: dict[str, np.ndarray] = {}
    for tr in tracks:
        positions[tr.spec.worker_id] = tr.root_xy.copy()
    end_time = n_frames / fps + 0.5
    # First task where each worker starts.
    for tr in tracks:
        first = tr.station.tasks[0] if tr.station.tasks[0] != "place_shelf" else "reach_overhead"
        t0 = tr.t
        do_task(tr, first, tr.station, tr.rng)
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


def _go(
    tr: TimelineBuilder,
    station: Station,
    grid: WalkGrid,
    reservations: _Reservations,
    tracks: list[TimelineBuilder],
    stations: dict[str, Station],
    carrying: bool,
    t_hold: float,
) -> None:
    """Walk to ``station`` avoiding stations other workers occupy meanwhile (and where they stand now)."""
    start = tr.root_xy.copy()
    goal = np.array(station.position, float)
    occupied = reservations.occupied(tr.t, tr.t + t_hold, tr.spec.worker_id)
    circles = [(*stations[s].position, 0.55) for s in occupied if s != station.name]
    for other in tracks:
        if other is not tr:
            circles.append((float(other.root_xy[0]), float(other.root_xy[1]), 0.55))
    circles = [
        c
        for c in circles
        if math.hypot(c[0] - start[0], c[1] - start[1]) > c[2] + 0.05
        and math.hypot(c[0] - goal[0], c[1] - goal[1]) > c[2] + 0.05
    ]
    path = plan_path(grid, start, goal, circles)
    tr.walk(path, station.heading, carrying)


def _pick_station(
    tr: TimelineBuilder, task: str, scene: Scene, reservations: _Reservations, grid: WalkGrid, hold_s: float
) -> Station | None:
    candidates = [s for s in scene.stations if task in s.tasks]
    free = []
    for s in candidates:
        eta = tr.t + _walk_time(np.array([tr.root_xy, s.position]), tr.spec.walk_speed) * 1.5
        if reservations.free(s.name, tr.t, eta + hold_s, tr.spec.worker_id):
            free.append(s)
    if not free:
        return None
    return free[int(tr.rng.integers(len(free)))]


def _next_job(
    tr: TimelineBuilder,
    scene: Scene,
    stations: dict[str, Station],
    grid: WalkGrid,
    reservations: _Reservations,
    tracks: list[TimelineBuilder],
) -> None:
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
            do_task(tr, lift, pallet, tr.rng, carton_kg=kg)
            reservations.busy[pallet.name] = [r for r in reservations.busy[pallet.name] if r != (t0, t0 + 30.0, wid)]
            reservations.add(pallet.name, t_arrive - 1.0, tr.t + 0.5, wid)
            shelf = _pick_station(tr, "place_shelf", scene, reservations, grid, 5.0)
            if shelf is None:  # put it back down where it came from
                do_task(tr, "place_shelf", dataclasses.replace(pallet, work_height=0.6), tr.rng, carton_kg=kg)
                return
            t1 = tr.t
            _go(tr, shelf, grid, reservations, tracks, stations, True, 8.0)
            tr.station = shelf
            # the walk carried the carton: a load period for it
            tr.periods.append(FactorPeriod(round(t1, 6), round(tr.t, 6), kg, "intermittent", "fair"))
            t_arrive = tr.t
            do_task(tr, "place_shelf", shelf, tr.rng, carton_kg=kg)
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
    do_task(tr, task, station, tr.rng)
    reservations.add(station.name, t_arrive - 1.0, tr.t + 0.5, wid)


def _rest_here(tr: TimelineBuilder, reservations: _Reservations) -> None:
    """A short rest where the worker stands (the place stays reserved meanwhile)."""
    t0 = tr.t
    do_task(tr, "rest", tr.station, tr.rng)
    reservations.add(tr.station.name, t0, tr.t + 0.5, tr.spec.worker_id)


def _finish(tr: TimelineBuilder, n_frames: int) -> WorkerMotion:
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
    return WorkerMotion(
        spec=tr.spec,
        posture=posture,
        joints_world=joints,
        task=task,
        planted=planted,
        carrying=carrying,
        periods=periods,
    )
