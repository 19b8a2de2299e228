"""Ground truth of a simulated session: the ``ground_truth/`` folder (docs/session-format.md).

    ground_truth/
      scene.toml         how the session was made (seed, sizes), the furniture, the reference
                         bars (end points and their angles off each lens axis), the stations,
                         the workers (stature, segment lengths, colours), the task and
                         visibility code lists, the lens regions
      joints.npz         per frame: 3D joints of every worker; per frame and camera: their
                         fisheye pixels, angle off the lens axis and visibility; task labels
      postures.parquet   one row per frame and worker: the joint angles the motion was built
                         from (radians), heading, pelvis position, task

joints.npz arrays (F frames, C cameras in session order, W workers in ``worker_ids`` order):
    joints_world  (F, W, 33, 3) float64  metres, world frame (BlazePose 33 order)
    pixels        (F, C, W, 33, 2) float32 fisheye pixels (NaN: the lens cannot image the joint)
    theta         (F, C, W, 33) float32  angle from the lens axis, radians
    visibility    (F, C, W, 33) int8     0 visible, 1 self_occluded, 2 occluded_by_worker,
                                         3 occluded_by_scene, 4 outside_image
    task          (F, W) int8            index into task_names
    planted       (F, W, 2) bool         left / right foot planted
    carrying      (F, W) bool            holding a carton
    times_s       (F,) float64; worker_ids, camera_names, joint_names, task_names: strings
"""

from __future__ import annotations

import math
import os
import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import pandas as pd
import tomli_w

from ergopose.errors import InputError
from ergopose.keypoints import BLAZEPOSE33, JOINT_INDEX, NUM_JOINTS
from ergopose.sim.workforce import TASKS
from ergopose.sim.scene import LENS_REGIONS_DEG, lens_region

SCENE_FILE = "scene.toml"
JOINTS_FILE = "joints.npz"
POSTURES_FILE = "postures.parquet"
#: Version of the ground-truth folder layout.
GROUND_TRUTH_VERSION = 1


@dataclass(frozen=True)
class GroundTruth:
    """The ground truth of a simulated session (arrays as documented in the module docstring)."""

    path: Path | None  # None: made in memory (ergopose.sim.synthetic), not read from a folder
    fps: float
    worker_ids: tuple[str, ...]
    camera_names: tuple[str, ...]
    joints_world: np.ndarray
    pixels: np.ndarray
    theta: np.ndarray
    visibility: np.ndarray
    task: np.ndarray
    task_names: tuple[str, ...]
    planted: np.ndarray
    carrying: np.ndarray
    times_s: np.ndarray
    postures: Any  # pandas.DataFrame
    scene: dict[str, Any]

    @property
    def n_frames(self) -> int:
        return int(self.joints_world.shape[0])

    @property
    def visible(self) -> np.ndarray:
        """(F, C, W, 33) bool: the camera sees the joint."""
        return self.visibility == 0

    def lens_region(self) -> np.ndarray:
        """(F, C, W, 33) int8 lens region of every joint (index into scene["lens_regions"]; -1 = none)."""
        return lens_region(self.theta)

    def worker_index(self, worker_id: str) -> int:
        try:
            return self.worker_ids.index(worker_id)
        except ValueError:
            raise KeyError(f"no worker {worker_id!r} (the session has {', '.join(self.worker_ids)})") from None

    def angles(self, worker_id: str):
        """The posture rows of one worker (DataFrame, one row per frame, angles in radians)."""
        rows = self.postures[self.postures["worker"] == worker_id]
        return rows.reset_index(drop=True)

    def person_table(self):
        """One row per frame, camera and worker (pandas DataFrame) for detection statistics:
        frame, time_s, camera, worker, task, theta_deg (mid-hip angle from the lens axis), region
        (central / outer / edge, see scene["lens_regions"]), n_visible and n_in_image (of the 33
        joints), and the box u_min, v_min, u_max, v_max (fisheye pixels) of the joints in the image."""
        f, c, w = self.visibility.shape[:3]
        hips = [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]
        theta = self.theta[..., hips].astype(np.float64).mean(axis=-1)  # (F, C, W)
        region = lens_region(theta)
        names = np.array([r[0] for r in LENS_REGIONS_DEG] + [""], dtype=object)
        inside = self.visibility != 4
        px = np.where(inside[..., None], self.pixels, np.nan)
        with np.errstate(all="ignore"):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                lo = np.nanmin(px, axis=3)
                hi = np.nanmax(px, axis=3)
        ff, cc, ww = np.meshgrid(np.arange(f), np.arange(c), np.arange(w), indexing="ij")
        return pd.DataFrame(
            {
                "frame": ff.ravel(),
                "time_s": self.times_s[ff.ravel()],
                "camera": pd.array(np.array(self.camera_names, dtype=object)[cc.ravel()], dtype="string"),
                "worker": pd.array(np.array(self.worker_ids, dtype=object)[ww.ravel()], dtype="string"),
                "task": pd.array(
                    np.array(self.task_names, dtype=object)[self.task[ff.ravel(), ww.ravel()]], dtype="string"
                ),
                "theta_deg": np.degrees(theta).ravel(),
                "region": pd.array(names[region.ravel()], dtype="string"),
                "n_visible": (self.visibility == 0).sum(axis=-1).ravel(),
                "n_in_image": inside.sum(axis=-1).ravel(),
                "u_min": lo[..., 0].ravel(),
                "v_min": lo[..., 1].ravel(),
                "u_max": hi[..., 0].ravel(),
                "v_max": hi[..., 1].ravel(),
            }
        )

    def reference_bars(self) -> list[dict[str, Any]]:
        """The reference bars: name, end_a, end_b (world, metres), length_m, per-camera angles."""
        return list(self.scene.get("reference_bars", []))


def write_ground_truth(
    folder: Path,
    *,
    scene_info: dict[str, Any],
    motion,
    camera_names: Sequence[str],
    pixels: np.ndarray,
    theta: np.ndarray,
    visibility: np.ndarray,
) -> None:
    """Write scene.toml, joints.npz and postures.parquet into ``folder`` (which must exist)."""
    folder = Path(folder)
    header = (
        "# Ground truth of a SIMULATED ergopose session (ergopose simulate); "
        "docs/session-format.md describes every field.\n"
    )
    (folder / SCENE_FILE).write_text(header + tomli_w.dumps(_plain(scene_info)), encoding="utf-8")
    arrays = {
        "joints_world": motion.joints_world.astype(np.float64),
        "pixels": pixels.astype(np.float32),
        "theta": theta.astype(np.float32),
        "visibility": visibility.astype(np.int8),
        "task": np.stack([w.task for w in motion.workers], axis=1).astype(np.int8),
        "planted": np.stack([w.planted for w in motion.workers], axis=1),
        "carrying": np.stack([w.carrying for w in motion.workers], axis=1),
        "times_s": motion.times_s,
        "worker_ids": np.array(motion.worker_ids),
        "camera_names": np.array(list(camera_names)),
        "joint_names": np.array(BLAZEPOSE33),
        "task_names": np.array(TASKS),
    }
    with open(folder / JOINTS_FILE, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    rows = []
    for w in motion.workers:
        a = w.angles()
        root = np.asarray(w.posture.root_position)
        table = {
            "frame": np.arange(motion.n_frames, dtype=np.int64),
            "time_s": motion.times_s,
            "worker": np.full(motion.n_frames, w.worker_id, dtype=object),
            "task": np.array(TASKS, dtype=object)[w.task],
            "root_x": root[:, 0],
            "root_y": root[:, 1],
            "root_z": root[:, 2],
        }
        table.update({k: np.asarray(v, np.float64) for k, v in a.items()})
        rows.append(pd.DataFrame(table))
    frame = pd.concat(rows, ignore_index=True)
    frame["worker"] = frame["worker"].astype("string")
    frame["task"] = frame["task"].astype("string")
    frame.to_parquet(folder / POSTURES_FILE, index=False)


def _plain(value: Any) -> Any:
    """numpy scalars and tuples -> TOML-writable Python values."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return float(value)
    if isinstance(value, (np.integer,)):
        return int(value)
    return value


def load_ground_truth(path: str | os.PathLike) -> GroundTruth:
    """Read the ground truth of a simulated session (the session folder or its ground_truth/ folder)."""
    p = Path(path)
    folder = p / "ground_truth" if (p / "ground_truth").is_dir() else p
    for name in (SCENE_FILE, JOINTS_FILE, POSTURES_FILE):
        if not (folder / name).is_file():
            raise InputError(f"no ground truth here: {name} is missing (only simulated sessions have one)", path=folder)
    try:
        scene = tomllib.loads((folder / SCENE_FILE).read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"cannot read the scene description ({exc})", path=folder / SCENE_FILE) from None
    try:
        with np.load(folder / JOINTS_FILE, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read the joints ({exc})", path=folder / JOINTS_FILE) from None
    try:
        postures = pd.read_parquet(folder / POSTURES_FILE)
    except Exception as exc:  # pyarrow raises its own types for damaged files
        raise InputError(f"cannot read the postures ({exc})", path=folder / POSTURES_FILE) from None
    needed = (
        "joints_world",
        "pixels",
        "theta",
        "visibility",
        "task",
        "planted",
        "carrying",
        "times_s",
        "worker_ids",
        "camera_names",
        "task_names",
    )
    missing = [k for k in needed if k not in data]
    if missing:
        raise InputError(f"missing arrays {', '.join(missing)}", path=folder / JOINTS_FILE)
    j = data["joints_world"]
    if j.ndim != 4 or j.shape[2:] != (NUM_JOINTS, 3):
        raise InputError(
            f"joints_world has shape {j.shape}, expected (F, W, {NUM_JOINTS}, 3)", path=folder / JOINTS_FILE
        )
    times = data["times_s"]
    fps = float(scene.get("session", {}).get("fps", 0.0)) or (
        1.0 / float(np.diff(times[:2])[0]) if len(times) > 1 else math.nan
    )
    return GroundTruth(
        path=folder,
        fps=fps,
        worker_ids=tuple(str(x) for x in data["worker_ids"]),
        camera_names=tuple(str(x) for x in data["camera_names"]),
        joints_world=j,
        pixels=data["pixels"],
        theta=data["theta"],
        visibility=data["visibility"],
        task=data["task"],
        task_names=tuple(str(x) for x in data["task_names"]),
        planted=data["planted"],
        carrying=data["carrying"],
        times_s=times,
        postures=postures,
        scene=scene,
    )
