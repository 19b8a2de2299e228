"""The simulated workers and their motion as records: the task labels, the plausible joint ranges,
each worker's body size and appearance (:class:`WorkerSpec`, drawn from the seed by
:func:`make_workers`), the periods of task factors, and the motion of a shift (:class:`WorkerMotion`,
:class:`Motion`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ergopose.ergonomics.body import ANGLE_FIELDS, BodyMeasurements, Posture
from ergopose.errors import ConfigError

#: Task labels (per frame per worker); the ground truth stores the index into this tuple.
TASKS: tuple[str, ...] = (
    "rest",
    "walk",
    "turn",
    "carry",
    "lift_stoop",
    "lift_squat",
    "place_shelf",
    "reach_overhead",
    "pick_twist",
    "assembly",
)
TASK_INDEX = {name: i for i, name in enumerate(TASKS)}

#: Plausible joint ranges (degrees) every simulated frame stays within (tests check it).
#: ergopose's own envelope around typical active ranges of motion, not a published table.
JOINT_LIMITS_DEG: dict[str, tuple[float, float]] = {
    "trunk_flexion": (-30, 110),
    "trunk_side_bend": (-40, 40),
    "trunk_twist": (-50, 50),
    "neck_flexion": (-60, 60),
    "neck_side_bend": (-40, 40),
    "neck_twist": (-70, 70),
    "shoulder_elevation": (-10, 30),
    "upper_arm_flexion": (-60, 180),
    "upper_arm_abduction": (-20, 180),
    "upper_arm_rotation": (-90, 90),
    "elbow_flexion": (0, 150),
    "forearm_rotation": (-90, 90),
    "wrist_flexion": (-70, 80),
    "wrist_deviation": (-25, 35),
    "hip_flexion": (-30, 130),
    "hip_abduction": (-30, 45),
    "knee_flexion": (0, 150),
    "ankle_flexion": (-50, 45),
}


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
_SHIRTS = (
    (40, 40, 200),
    (200, 120, 30),
    (40, 160, 60),
    (30, 170, 230),
    (150, 60, 140),
    (200, 200, 200),
    (60, 60, 60),
    (180, 140, 90),
)
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
        look = Appearance(
            skin=_SKINS[rng.integers(len(_SKINS))],
            hair=_HAIRS[rng.integers(len(_HAIRS))],
            shirt=_SHIRTS[shirts[k]],
            trousers=_TROUSERS[rng.integers(len(_TROUSERS))],
            shoes=_SHOES[rng.integers(len(_SHOES))],
        )
        speed = round(float(rng.uniform(0.95, 1.2)) * m.stature / 1.75, 4)
        out.append(WorkerSpec(worker_id=f"w{k + 1}", measurements=m, appearance=look, walk_speed=speed))
    return tuple(out)
