"""Synthetic workers and 2D observations with ground truth, for tests, benchmarks and the
measurements in docs/reconstruction.md (the full simulator is :mod:`ergopose.sim`).

- :func:`rig`: two ceiling cameras 3 m above the floor, 1.5 m apart, Kannala-Brandt lenses.
- :func:`walk_workers`: people built with :mod:`ergopose.ergonomics.body` walking along
  waypoints at a given speed, pausing at each waypoint to work (bending, reaching, lifting the
  arms), with a gait while walking. Returns ground-truth joints (F, P, 33, 3).
- :func:`observe`: the fisheye pixels of those joints in each camera plus seeded Gaussian pixel
  noise, random keypoint dropouts and scripted hiding (a person hidden from a camera, e.g. by a
  shelf, or from both, or outside the area), turned into :class:`Detections2D` records the way
  the 2D pose stage hands them over (one upright virtual view per person).

Everything is seeded; nothing here is used by the reconstruction itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ergopose.ergonomics.body import BodyMeasurements, Posture, place_on_floor, pose_skeleton
from ergopose.geometry.camera import Camera, ceiling_camera
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt
from ergopose.keypoints import NUM_JOINTS
from ergopose.records import detections_from_fisheye
from ergopose.sim.ground_truth import GroundTruth
from ergopose.sim.motion import simulate_motion
from ergopose.sim.workforce import TASKS
from ergopose.sim.bodies import all_body_primitives
from ergopose.sim.visibility import joint_visibility
from ergopose.sim.scene import default_scene, rig_cameras, rig_lens

#: Distortion of a real 195-degree fisheye (TUM VI cam0, Kannala-Brandt k1..k4; Schubert et al. 2018).
LENS_COEFFICIENTS = (0.0034823894, 0.0007150348, -0.0020532361, 0.0002029367)
#: The paper's camera resolution (Axis M3007-PV).
PAPER_SIZE = (2592, 1944)


def rig(
    width: int = PAPER_SIZE[0], height: int = PAPER_SIZE[1], baseline_m: float = 1.5, height_m: float = 3.0
) -> tuple[Camera, Camera]:
    """Two ceiling cameras looking straight down at (+-baseline/2, 0, height), the second turned
    by 180 degrees; 95 degrees off-axis lands on the short side of the image."""
    k1, k2, k3, k4 = LENS_COEFFICIENTS
    t = math.radians(95.0)
    rd = t * (1 + k1 * t**2 + k2 * t**4 + k3 * t**6 + k4 * t**8)
    f = (min(width, height) / 2.0 - 2.0) / rd
    lens = KannalaBrandt(fx=f, fy=f, cx=(width - 1) / 2.0, cy=(height - 1) / 2.0, k1=k1, k2=k2, k3=k3, k4=k4)
    half = baseline_m / 2.0
    return (
        ceiling_camera("cam_1", lens, width, height, (-half, 0.0, height_m), yaw=0.0),
        ceiling_camera("cam_2", lens, width, height, (half, 0.0, height_m), yaw=math.pi),
    )


@dataclass(frozen=True)
class WorkerScript:
    """One synthetic worker.

    stature: metres (body proportions from BodyMeasurements.from_stature).
    waypoints: (K, 2) floor positions (metres) visited in order, starting at the first.
    pause_s: seconds of work at each waypoint (scalar or one per waypoint).
    speed_m_s: walking speed. start_s: the worker stands at the first waypoint until then.
    work_phase: phase offset of the work motion (radians), so workers do not move in step.
    """

    stature: float
    waypoints: np.ndarray
    pause_s: float | tuple[float, ...] = 2.0
    speed_m_s: float = 1.2
    start_s: float = 0.0
    work_phase: float = 0.0
    name: str = field(default="")


def _timeline(script: WorkerScript, t: np.ndarray):
    """Position (F, 2), heading (F,), walking flag (F,), gait phase (F,) at times t."""
    wp = np.asarray(script.waypoints, dtype=np.float64).reshape(-1, 2)
    k = len(wp)
    pauses = np.broadcast_to(np.asarray(script.pause_s, dtype=np.float64), (k,))
    # Segments: [start wait], pause at wp0, walk wp0->wp1, pause at wp1, ...
    start_list: list[float] = []
    kind_list: list[int] = []
    index_list: list[int] = []
    dur_list: list[float] = []
    clock = 0.0
    for i in range(k):
        dur = float(pauses[i] + (script.start_s if i == 0 else 0.0))
        start_list.append(clock)
        kind_list.append(0)
        index_list.append(i)
        dur_list.append(dur)
        clock += dur
        if i + 1 < k:
            dist = float(np.linalg.norm(wp[i + 1] - wp[i]))
            dur = dist / script.speed_m_s
            start_list.append(clock)
            kind_list.append(1)
            index_list.append(i)
            dur_list.append(dur)
            clock += dur
    starts = np.array(start_list)
    seg_dur = np.maximum(np.array(dur_list), 1e-9)
    kinds = np.array(kind_list)
    a_idx = np.array(index_list)
    seg = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(starts) - 1)
    u = np.clip((t - starts[seg]) / seg_dur[seg], 0.0, 1.0)
    walking = kinds[seg] == 1
    a = wp[a_idx[seg]]
    b = wp[np.minimum(a_idx[seg] + 1, k - 1)]
    pos = np.where(walking[:, None], a + u[:, None] * (b - a), a)
    d = b - a
    walk_heading = np.arctan2(d[:, 1], d[:, 0])
    # While pausing face the direction of the last walk (the first pause: towards the next waypoint).
    heading = np.where(walking, walk_heading, np.nan)
    first = ~np.isfinite(heading)
    if k > 1:
        h0 = math.atan2(*(wp[1] - wp[0])[::-1])
    else:
        h0 = 0.0
    heading = _ffill(heading, h0)
    heading[first & (np.cumsum(walking) == 0)] = h0
    walked = np.where(walking, u * seg_dur[seg] * script.speed_m_s, 0.0)
    gait_phase = 2 * math.pi * walked / (1.4 * 1.0)  # one stride (two steps) per 1.4 m
    return pos, heading, walking, gait_phase


def _ffill(a: np.ndarray, first: float) -> np.ndarray:
    ok = np.isfinite(a)
    idx = np.where(ok, np.arange(len(a)), 0)
    np.maximum.accumulate(idx, out=idx)
    out = a[idx]
    out[~np.isfinite(out)] = first
    return out


def _smooth(x: np.ndarray, width: int) -> np.ndarray:
    """Moving average along axis 0 with edge padding (width odd, in frames)."""
    if width <= 1:
        return x
    pad = width // 2
    xp = np.concatenate([np.repeat(x[:1], pad, axis=0), x, np.repeat(x[-1:], pad, axis=0)])
    c = np.cumsum(np.concatenate([np.zeros((1,) + x.shape[1:]), xp]), axis=0)
    return (c[width:] - c[:-width]) / width


def walk_workers(scripts: list[WorkerScript], n_frames: int, fps: float = 12.0, start_frame: int = 0) -> np.ndarray:
    """Ground-truth joints (F, P, 33, 3) of the scripted workers at frames start_frame ... + n_frames.

    Walking: hips and knees swing with the gait (stride 1.4 m), arms swing opposite.
    Working (pauses): trunk flexion up to ~45 deg, arms raised up to ~100 deg, elbows bent,
    neck bent, on cycles of a few seconds (work_phase shifts them). Position and heading are
    smoothed over 0.5 s so that people speed up and turn smoothly.
    """
    t = (start_frame + np.arange(n_frames)) / fps
    out = np.empty((n_frames, len(scripts), NUM_JOINTS, 3))
    w = max(1, int(round(0.5 * fps)) | 1)
    for p, s in enumerate(scripts):
        m = BodyMeasurements.from_stature(s.stature)
        # Smooth with a little history before and after so chunks agree at their edges.
        pad = w
        tt = (start_frame + np.arange(-pad, n_frames + pad)) / fps
        pos, heading, walking, gait = _timeline(s, tt)
        pos = _smooth(pos, w)[pad:-pad]
        heading = _smooth(np.unwrap(heading), w)[pad:-pad]
        walk = _smooth(walking.astype(float), w)[pad:-pad]
        gait = gait[pad:-pad]
        work = 1.0 - walk
        ph = s.work_phase
        cyc = 0.5 - 0.5 * np.cos(2 * math.pi * t / 4.0 + ph)  # 4 s work cycle
        cyc2 = 0.5 - 0.5 * np.cos(2 * math.pi * t / 2.5 + 1.3 * ph)  # 2.5 s
        sw = np.sin(gait)
        hip_l = walk * 0.35 * sw
        hip_r = -walk * 0.35 * sw
        knee_l = walk * (0.25 + 0.35 * np.maximum(0, -np.sin(gait - 0.6))) + work * 0.1 * cyc
        knee_r = walk * (0.25 + 0.35 * np.maximum(0, np.sin(gait - 0.6))) + work * 0.1 * cyc
        posture = Posture(
            root_position=np.concatenate([pos, np.zeros((n_frames, 1))], axis=1),
            heading=heading,
            trunk_flexion=work * 0.8 * cyc + walk * 0.05,
            trunk_twist=work * 0.3 * np.sin(2 * math.pi * t / 6.0 + ph),
            neck_flexion=work * 0.5 * cyc2 + 0.1,
            left_upper_arm_flexion=walk * (-0.35 * sw) + work * (0.2 + 1.5 * cyc2),
            right_upper_arm_flexion=walk * (0.35 * sw) + work * (0.3 + 1.2 * cyc),
            left_upper_arm_abduction=0.1 + work * 0.3 * cyc,
            right_upper_arm_abduction=0.1 + work * 0.2 * cyc2,
            left_elbow_flexion=0.3 + work * 0.9 * cyc,
            right_elbow_flexion=0.3 + work * 0.8 * cyc2,
            left_hip_flexion=hip_l + work * 0.15 * cyc,
            right_hip_flexion=hip_r + work * 0.15 * cyc,
            left_knee_flexion=knee_l,
            right_knee_flexion=knee_r,
            left_ankle_flexion=knee_l - hip_l,
            right_ankle_flexion=knee_r - hip_r,
        )
        posture = place_on_floor(m, posture)
        out[:, p] = pose_skeleton(m, posture)
    return out


def project_all(cameras, points_world: np.ndarray) -> np.ndarray:
    """(F, P, 33, 3) -> (F, C, P, 33, 2) exact fisheye pixels (NaN outside the image)."""
    px = []
    for cam in cameras:
        q = cam.project_world(points_world)
        q = np.where(cam.in_image(q)[..., None], q, np.nan)
        px.append(q)
    return np.stack(px, axis=1)


def observe(
    cameras,
    points_world: np.ndarray,
    *,
    noise_px: float = 2.0,
    dropout: float = 0.02,
    visible: np.ndarray | None = None,
    seed: int = 0,
    fps: float = 12.0,
    start_frame: int = 0,
    confidence: float = 0.9,
    shuffle: bool = True,
    view_size: tuple[int, int] = (256, 256),
):
    """2D observations of ground-truth people as the 2D pose stage would hand them over.

    points_world: (F, P, 33, 3). visible: (F, C, P) bool, False where person P is hidden from
    camera C (behind a shelf, or gone); default all visible. Each keypoint gets Gaussian noise of
    ``noise_px`` per coordinate in fisheye pixels and is dropped with probability ``dropout``;
    confidence is ``confidence`` (found) or 0. The order of the people in each camera's list is
    shuffled (shuffle=True), as a detector's order carries no identity.

    Returns (frames, order): frames[f] = (Detections2D of camera 1, of camera 2); order[f][c]
    is the ground-truth person index of each listed detection.
    """
    rng = np.random.default_rng(seed)
    F, P = points_world.shape[:2]
    px = project_all(cameras, points_world)  # (F, C, P, 33, 2)
    px = px + rng.normal(0.0, noise_px, px.shape)
    found = np.isfinite(px).all(axis=-1) & (rng.random(px.shape[:-1]) >= dropout)
    if visible is not None:
        found &= np.asarray(visible, bool)[..., None]
    frames, order = [], []
    for f in range(F):
        dets, orders = [], []
        for c, cam in enumerate(cameras):
            people = np.flatnonzero(found[f, c].any(axis=-1))
            if shuffle:
                people = rng.permutation(people)
            q = np.where(found[f, c, people][..., None], px[f, c, people], np.nan)
            conf = np.where(found[f, c, people], confidence, 0.0)
            frame = start_frame + f
            det = detections_from_fisheye(cam, frame, frame / fps, q, conf, view_size=view_size)
            dets.append(det)
            orders.append(people)
        frames.append(tuple(dets))
        order.append(orders)
    return frames, order


def frames_from_oracle(observations, cameras, *, view_size: tuple[int, int] = (256, 256)):
    """Detections2D per frame from the simulator's ORACLE observations (evaluation only).

    observations: :class:`ergopose.sim.oracle.OracleObservations` (fisheye pixels (F, C, W, 33, 2),
    confidence, detected); cameras: the session's cameras in its camera order. Each detected
    worker becomes one person of the camera's record (in worker order: the reconstruction does
    not use the order). Returns (frames, order) as :func:`observe` does.
    """
    names = tuple(c.name for c in cameras)
    if tuple(observations.camera_names) != names:
        raise ValueError(f"cameras {names} do not match the observations' {observations.camera_names}")
    frames, order = [], []
    for k, frame in enumerate(observations.frames):
        dets, orders = [], []
        for c, cam in enumerate(cameras):
            px = observations.pixels_fisheye[k, c]
            conf = observations.confidence[k, c].astype(np.float64)
            people = np.flatnonzero(observations.detected[k, c] & (conf > 0).any(axis=-1))
            det = detections_from_fisheye(
                cam, int(frame), float(observations.times_s[k]), px[people], conf[people], view_size=view_size
            )
            dets.append(det)
            orders.append(people)
        frames.append(tuple(dets))
        order.append(orders)
    return frames, order


def simulated_ground_truth(
    n_workers: int,
    seconds: float,
    *,
    fps: float = 12.0,
    seed: int = 0,
    size: tuple[int, int] = PAPER_SIZE,
    cameras=None,
):
    """A simulated session's ground truth built in memory, without rendering video.

    The simulator's room, rig (at ``size``), scripted workers and per-joint visibility (ray casts
    through bodies and furniture) -- everything :class:`ergopose.sim.oracle.OracleSource` needs.
    cameras: Camera objects to use instead of the simulator's two-camera rig (any number, e.g.
    the rig plus :func:`extra_ceiling_cameras`). Returns (ground_truth, cameras).
    """
    scene = default_scene()
    cameras = tuple(cameras) if cameras is not None else rig_cameras(*size)
    motion = simulate_motion(scene, n_workers, seconds, fps, seed)
    bodies = all_body_primitives(motion)
    per_camera = [joint_visibility(cam, scene, motion, bodies) for cam in cameras]
    joints = motion.joints_world
    nf, nw = joints.shape[:2]
    gt = GroundTruth(
        path=None,
        fps=fps,
        worker_ids=motion.worker_ids,
        camera_names=tuple(c.name for c in cameras),
        joints_world=joints,
        pixels=np.stack([p[0] for p in per_camera], axis=1),
        theta=np.stack([p[1] for p in per_camera], axis=1),
        visibility=np.stack([p[2] for p in per_camera], axis=1),
        task=np.zeros((nf, nw), np.int8),
        task_names=tuple(TASKS),
        planted=np.zeros((nf, nw, 2), bool),
        carrying=np.zeros((nf, nw), bool),
        times_s=motion.times_s,
        postures=None,
        scene={"workers": [{"id": w.worker_id, "stature_m": w.spec.measurements.stature} for w in motion.workers]},
    )
    return gt, cameras


def extra_ceiling_cameras(
    size: tuple[int, int] = PAPER_SIZE, positions=((0.0, 1.6, 2.95), (0.0, -1.6, 3.02)), names=("cam_3", "cam_4")
) -> tuple[Camera, ...]:
    """More ceiling fisheye cameras for multi-camera tests: the simulator rig's lens model
    (camera 1's intrinsics) looking straight down from ``positions``, turned by 90 and 270 degrees
    so that their baselines with the rig's cameras run in other directions."""
    return tuple(
        ceiling_camera(name, rig_lens(*size, 0), size[0], size[1], pos, yaw=math.pi / 2 + k * math.pi)
        for k, (name, pos) in enumerate(zip(names, positions))
    )
