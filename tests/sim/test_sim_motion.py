"""Scripted workers: reproducible, anthropometric, feet on the floor without sliding, joints in range."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ergopose.ergonomics.angles import joint_angles
from ergopose.ergonomics.body import BodyMeasurements, Posture, pose_skeleton
from ergopose.keypoints import JOINT_INDEX as J
from ergopose.sim.legs import leg_ik
from ergopose.sim.motion import simulate_motion
from ergopose.sim.paths import PATH_CLEARANCE, WalkGrid, plan_path
from ergopose.sim.workforce import JOINT_LIMITS_DEG, TASKS
from ergopose.sim.scene import default_scene

FPS = 12.0


@pytest.fixture(scope="module")
def scene():
    return default_scene()


@pytest.fixture(scope="module")
def shift(scene):
    """Four workers, five minutes: every task occurs."""
    return simulate_motion(scene, 4, 300.0, FPS, seed=11)


def test_same_seed_same_motion_other_seed_differs(scene):
    a = simulate_motion(scene, 2, 40.0, FPS, seed=3)
    b = simulate_motion(scene, 2, 40.0, FPS, seed=3)
    c = simulate_motion(scene, 2, 40.0, FPS, seed=4)
    assert a.n_frames == 480
    assert np.array_equal(a.joints_world, b.joints_world)
    for wa, wb in zip(a.workers, b.workers):
        assert np.array_equal(wa.task, wb.task)
        assert all(np.array_equal(v, wb.angles()[k]) for k, v in wa.angles().items())
    assert not np.array_equal(a.joints_world, c.joints_world)


@pytest.mark.slow
def test_statures_differ_and_lie_in_range(shift):
    statures = [w.spec.stature for w in shift.workers]
    assert all(1.55 <= s <= 1.95 for s in statures)
    assert min(np.diff(sorted(statures))) > 0.02
    for w in shift.workers:
        assert w.spec.measurements == BodyMeasurements.from_stature(w.spec.stature)


@pytest.mark.slow
def test_every_task_occurs(shift):
    seen = set()
    for w in shift.workers:
        seen |= {TASKS[k] for k in np.unique(w.task)}
    assert seen == set(TASKS)


@pytest.mark.slow
def test_joints_are_the_skeleton_of_the_stored_angles(shift):
    w = shift.workers[0]
    again = pose_skeleton(w.spec.measurements, w.posture)
    assert np.array_equal(again, w.joints_world)
    assert w.joints_world.shape == (shift.n_frames, 33, 3)


@pytest.mark.slow
def test_joint_angles_measured_from_the_joints_are_the_built_angles(shift):
    """The ground-truth angles are those joint_angles measures (the body model's contract)."""
    w = shift.workers[1]
    measured = joint_angles(w.joints_world, shift.times_s)
    built = w.angles()
    for name in (
        "trunk_flexion",
        "trunk_side_bend",
        "trunk_twist",
        "neck_flexion",
        "left_knee_flexion",
        "right_knee_flexion",
        "left_elbow_flexion",
        "right_upper_arm_flexion",
        "left_upper_arm_abduction",
    ):
        got = np.asarray(getattr(measured, name))
        ok = np.isfinite(got)
        assert ok.mean() > 0.99, name
        assert np.abs(got[ok] - built[name][ok]).max() < 1e-6, name


@pytest.mark.slow
def test_feet_on_the_floor_while_planted_and_never_below(shift):
    for w in shift.workers:
        j = w.joints_world
        feet = j[:, [J[f"{s}_{p}"] for s in ("left", "right") for p in ("heel", "foot_index")], 2]
        assert feet.min() > -1e-9
        for k, side in enumerate(("left", "right")):
            planted = w.planted[:, k]
            sole = j[planted][:, [J[f"{side}_heel"], J[f"{side}_foot_index"]], 2]
            assert np.abs(sole).max() < 2e-3  # flat on the floor (hip abduction tilts it < 2 mm)
            swing = ~planted
            assert swing.any() and j[swing, J[f"{side}_ankle"], 2].max() > w.spec.measurements.ankle_height + 0.03


@pytest.mark.slow
def test_planted_feet_do_not_slide(shift):
    for w in shift.workers:
        j = w.joints_world
        heading = np.asarray(w.posture.heading)
        turning = np.abs(np.diff(heading)) > 1e-12
        for k, side in enumerate(("left", "right")):
            both = w.planted[1:, k] & w.planted[:-1, k]
            ankle = np.linalg.norm(np.diff(j[:, J[f"{side}_ankle"]], axis=0), axis=1)
            assert ankle[both].max() < 1e-9
            # heel and toe: fixed over whole stance phases, except while the worker turns on the
            # spot; the model has no hip rotation, so hip abduction yaws the foot slightly about the
            # fixed ankle (millimetres per frame, under 2 cm over a stance)
            steady = both & ~turning
            for point in ("heel", "foot_index"):
                p = j[:, J[f"{side}_{point}"]]
                step = np.linalg.norm(np.diff(p, axis=0), axis=1)
                assert step[steady].max() < 8e-3
                assert np.median(step[steady]) < 1e-9
            starts = np.flatnonzero(np.diff(np.concatenate([[0], steady.astype(int)])) == 1)
            ends = np.flatnonzero(np.diff(np.concatenate([steady.astype(int), [0]])) == -1)
            toe = j[:, J[f"{side}_foot_index"]]
            drift = [np.linalg.norm(toe[e + 1] - toe[s]) for s, e in zip(starts, ends)]
            assert max(drift) < 0.02


@pytest.mark.slow
def test_joint_angles_stay_within_limits(shift):
    for w in shift.workers:
        for name, values in w.angles().items():
            if name == "heading":
                continue
            base = name.removeprefix("left_").removeprefix("right_")
            lo, hi = JOINT_LIMITS_DEG[base]
            deg = np.degrees(values)
            assert lo <= deg.min() and deg.max() <= hi, (w.worker_id, name, deg.min(), deg.max())


@pytest.mark.slow
def test_motion_is_smooth(shift):
    dt = 1.0 / FPS
    for w in shift.workers:
        v = np.linalg.norm(np.diff(w.joints_world, axis=0), axis=-1) / dt
        assert v.max() < 7.0  # m/s: swinging feet and reaching hands, no jumps
        root = np.asarray(w.posture.root_position)
        speed = np.linalg.norm(np.diff(root[:, :2], axis=0), axis=1) / dt
        assert speed.max() < 1.8  # walking, not running
        acc = np.linalg.norm(np.diff(root, n=2, axis=0), axis=1) / dt**2
        assert acc.max() < 8.0


@pytest.mark.slow
def test_workers_keep_apart_while_working(shift):
    roots = np.stack([np.asarray(w.posture.root_position)[:, :2] for w in shift.workers], axis=1)
    moving = np.stack([np.isin(w.task, [TASKS.index(t) for t in ("walk", "turn", "carry")]) for w in shift.workers], 1)
    for a in range(len(shift.workers)):
        for b in range(a + 1, len(shift.workers)):
            both_working = ~moving[:, a] & ~moving[:, b]
            d = np.linalg.norm(roots[:, a] - roots[:, b], axis=1)
            assert d[both_working].min() > 0.6


@pytest.mark.slow
def test_carton_only_between_lift_and_place_and_with_a_load(shift):
    for w in shift.workers:
        carrying = w.carrying
        tasks = {TASKS[k] for k in np.unique(w.task[carrying])}
        assert tasks <= {"lift_stoop", "lift_squat", "carry", "place_shelf"}
        t = np.arange(len(carrying)) / FPS
        covered = np.zeros(len(carrying), bool)
        for p in w.periods:
            if p.load_kg >= 4.0:
                covered |= (t >= p.start_s - 1e-6) & (t < p.end_s + 1e-6)
        assert covered[carrying].all()


def test_leg_ik_reaches_random_targets(rng):
    m = BodyMeasurements.from_stature(1.8)
    n = 500
    root = np.column_stack([rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(0.5, 0.9, n)])
    heading = rng.uniform(-math.pi, math.pi, n)
    # reachable ankle targets: within 0.95 of the leg length from the hip, below it
    leg = m.thigh_length + m.shank_length
    direction = np.column_stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.3, 0.3, n), -np.ones(n)])
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    hip = root + m.hip_width / 2 * np.column_stack([-np.sin(heading), np.cos(heading), np.zeros(n)])
    target = hip + direction * rng.uniform(0.6, 0.95, n)[:, None] * leg
    angles = leg_ik(m, root, heading, target, "left")
    joints = pose_skeleton(m, Posture(root_position=root, heading=heading, **angles))
    assert np.abs(joints[:, J["left_ankle"]] - target).max() < 1e-9
    # the sole is level along the foot
    foot = joints[:, J["left_foot_index"]] - joints[:, J["left_heel"]]
    assert np.abs(foot[:, 2] / np.linalg.norm(foot, axis=1)).max() < 0.02


def test_paths_keep_clear_of_furniture(scene, rng):
    grid = WalkGrid(scene)
    obstacles = scene.obstacles_xy()
    stations = [np.array(s.position) for s in scene.stations]
    for _ in range(20):
        a, b = rng.choice(len(stations), 2, replace=False)
        path = plan_path(grid, stations[a], stations[b])
        assert np.allclose(path[0], stations[a]) and np.allclose(path[-1], stations[b])
        pts = np.concatenate([p + (q - p) * np.linspace(0, 1, 50)[:, None] for p, q in zip(path[:-1], path[1:])])
        for x0, y0, x1, y1 in obstacles:
            dx = np.maximum(np.maximum(x0 - pts[:, 0], pts[:, 0] - x1), 0)
            dy = np.maximum(np.maximum(y0 - pts[:, 1], pts[:, 1] - y1), 0)
            assert np.hypot(dx, dy).min() > PATH_CLEARANCE - GRID_SLACK


GRID_SLACK = 0.08  # the grid's cell size limits how exactly a path keeps the clearance


def test_bad_arguments(scene):
    from ergopose.errors import ConfigError

    with pytest.raises(ConfigError, match="1 to 4 workers"):
        simulate_motion(scene, 5, 10.0, FPS, 0)
    with pytest.raises(ConfigError, match="fewer than 2 frames"):
        simulate_motion(scene, 1, 0.05, FPS, 0)
