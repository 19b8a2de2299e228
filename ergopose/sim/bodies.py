"""The simulated workers' bodies as primitives for ray casting: capsules for limbs, neck,
shoulders, hands and feet; ellipsoids for chest, abdomen, pelvis, head and nose; an oriented box
for a carried carton (:class:`BodyPrimitives`, from a worker's motion by :func:`body_primitives`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ergopose.ergonomics.body import FACE_POINTS_IN_HEAD
from ergopose.keypoints import JOINT_INDEX
from ergopose.sim.workforce import Motion, WorkerMotion

J = JOINT_INDEX

#: Capsule parts: name, joint (or point) a, joint b, radius as a fraction of stature, colour slot.
CAPSULE_PARTS: tuple[tuple[str, str, float, str], ...] = (
    ("neck", "neck", 0.026, "skin"),
    ("shoulders", "shoulders", 0.03, "shirt"),
    ("left_upper_arm", "left_upper_arm", 0.026, "shirt"),
    ("right_upper_arm", "right_upper_arm", 0.026, "shirt"),
    ("left_forearm", "left_forearm", 0.02, "sleeve"),
    ("right_forearm", "right_forearm", 0.02, "sleeve"),
    ("left_hand", "left_hand", 0.015, "skin"),
    ("right_hand", "right_hand", 0.015, "skin"),
    ("left_thigh", "left_thigh", 0.039, "trousers"),
    ("right_thigh", "right_thigh", 0.039, "trousers"),
    ("left_shank", "left_shank", 0.028, "trousers"),
    ("right_shank", "right_shank", 0.028, "trousers"),
    ("left_foot", "left_foot", 0.021, "shoes"),
    ("right_foot", "right_foot", 0.021, "shoes"),
)
CAPSULE_NAMES = tuple(p[0] for p in CAPSULE_PARTS)
#: Ellipsoid parts: name, colour slot (geometry in :func:`body_primitives`).
ELLIPSOID_PARTS: tuple[tuple[str, str], ...] = (
    ("chest", "shirt"),
    ("abdomen", "shirt"),
    ("pelvis", "trousers"),
    ("head", "skin"),
    ("nose", "skin"),
)
ELLIPSOID_NAMES = tuple(p[0] for p in ELLIPSOID_PARTS)
N_CAPSULES = len(CAPSULE_PARTS)
N_ELLIPSOIDS = len(ELLIPSOID_PARTS)
#: Primitive index layout per worker: capsules, then ellipsoids, then the carton.
PRIMITIVE_NAMES = CAPSULE_NAMES + ELLIPSOID_NAMES + ("carton",)
N_PRIMITIVES = len(PRIMITIVE_NAMES)
HEAD = N_CAPSULES + ELLIPSOID_NAMES.index("head")
CARTON = N_PRIMITIVES - 1
CARTON_COLOUR = (70, 125, 175)

#: Head ellipsoid in the head frame of body.py, in units of head_height: centre and radii.
HEAD_CENTRE = (0.03, 0.0, 0.66)
HEAD_RADII = (0.31, 0.24, 0.36)
NOSE_RADIUS = 0.035


# --- primitives -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class BodyPrimitives:
    """The mannequin of one worker in every frame (world frame, metres, float32).

    capsule_a, capsule_b: (F, 14, 3) segment ends; capsule_radius: (14,).
    ellipsoid_centre: (F, 5, 3); ellipsoid_axes: (F, 5, 3, 3), columns = the ellipsoid's local
    x, y, z axes (for the head: forward, left, up); ellipsoid_radii: (5, 3).
    carton_centre (F, 3), carton_axes (F, 3, 3), carton_half (F, 3), carrying (F,) bool.
    colours: (N_PRIMITIVES, 3) BGR float32; hair: (3,) BGR; face: the unit directions of the
    eyes (2, 3) and the mouth (3,) in the head ellipsoid's scaled frame.
    """

    capsule_a: np.ndarray
    capsule_b: np.ndarray
    capsule_radius: np.ndarray
    ellipsoid_centre: np.ndarray
    ellipsoid_axes: np.ndarray
    ellipsoid_radii: np.ndarray
    carton_centre: np.ndarray
    carton_axes: np.ndarray
    carton_half: np.ndarray
    carrying: np.ndarray
    colours: np.ndarray
    hair: np.ndarray
    eye_dirs: np.ndarray
    mouth_dir: np.ndarray

    @property
    def n_frames(self) -> int:
        return self.capsule_a.shape[0]


def unit_vectors(v: np.ndarray) -> np.ndarray:
    """``v`` scaled to unit length along its last axis."""
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _head_frame_angle() -> float:
    """Angle between the head's forward axis and the ear-to-eyes direction (body.py's face layout)."""
    eye = np.array(FACE_POINTS_IN_HEAD["left_eye"]) + np.array(FACE_POINTS_IN_HEAD["right_eye"])
    ear = np.array(FACE_POINTS_IN_HEAD["left_ear"]) + np.array(FACE_POINTS_IN_HEAD["right_ear"])
    f = (eye - ear) / 2.0
    return math.atan2(f[2], f[0])


def head_axes(joints: np.ndarray) -> np.ndarray:
    """(..., 33, 3) joints -> (..., 3, 3) head frame (columns forward, left, up) from ears and eyes."""
    ear_mid = 0.5 * (joints[..., J["left_ear"], :] + joints[..., J["right_ear"], :])
    eye_mid = 0.5 * (joints[..., J["left_eye"], :] + joints[..., J["right_eye"], :])
    y = unit_vectors(joints[..., J["left_ear"], :] - joints[..., J["right_ear"], :])
    f = eye_mid - ear_mid
    f = unit_vectors(f - np.sum(f * y, axis=-1, keepdims=True) * y)
    e3 = np.cross(f, y)
    a = _head_frame_angle()
    x = math.cos(a) * f - math.sin(a) * e3
    z = math.sin(a) * f + math.cos(a) * e3
    return np.stack([x, y, z], axis=-1)


def body_primitives(worker: WorkerMotion) -> BodyPrimitives:
    """Capsules, ellipsoids and carton of one worker for every frame (vectorised over frames)."""
    m = worker.spec.measurements
    h = m.stature
    hh = m.head_height
    p = worker.joints_world
    nf = p.shape[0]
    ls, rs = p[:, J["left_shoulder"]], p[:, J["right_shoulder"]]
    lh, rh = p[:, J["left_hip"]], p[:, J["right_hip"]]
    mid_sh, mid_hip = 0.5 * (ls + rs), 0.5 * (lh + rh)
    head = head_axes(p)
    ear_mid = 0.5 * (p[:, J["left_ear"]] + p[:, J["right_ear"]])
    ear_local = 0.5 * (np.array(FACE_POINTS_IN_HEAD["left_ear"]) + np.array(FACE_POINTS_IN_HEAD["right_ear"]))
    neck_base = ear_mid - np.einsum("fij,j->fi", head, ear_local * hh)
    chin = neck_base + np.einsum("fij,j->fi", head, np.array([0.06, 0.0, 0.36]) * hh)

    def hand_tip(side: str) -> np.ndarray:
        w = p[:, J[f"{side}_wrist"]]
        k = 0.5 * (p[:, J[f"{side}_index"]] + p[:, J[f"{side}_pinky"]])
        return w + 0.85 * (k - w)

    def foot(side: str, r: float) -> tuple[np.ndarray, np.ndarray]:
        heel, toe = p[:, J[f"{side}_heel"]], p[:, J[f"{side}_foot_index"]]
        along = unit_vectors(toe - heel)
        ankle = p[:, J[f"{side}_ankle"]]
        # the sole plane's up: perpendicular to the foot, towards the ankle
        up = ankle - heel
        up = unit_vectors(up - np.sum(up * along, axis=-1, keepdims=True) * along)
        return heel + along * r + up * r, toe - along * 0.6 * r + up * r

    ends = {
        "neck": (mid_sh, chin),
        "shoulders": (ls, rs),
        "left_upper_arm": (ls, p[:, J["left_elbow"]]),
        "right_upper_arm": (rs, p[:, J["right_elbow"]]),
        "left_forearm": (p[:, J["left_elbow"]], p[:, J["left_wrist"]]),
        "right_forearm": (p[:, J["right_elbow"]], p[:, J["right_wrist"]]),
        "left_hand": (p[:, J["left_wrist"]], hand_tip("left")),
        "right_hand": (p[:, J["right_wrist"]], hand_tip("right")),
        "left_thigh": (lh, p[:, J["left_knee"]]),
        "right_thigh": (rh, p[:, J["right_knee"]]),
        "left_shank": (p[:, J["left_knee"]], p[:, J["left_ankle"]]),
        "right_shank": (p[:, J["right_knee"]], p[:, J["right_ankle"]]),
    }
    radius = np.array([frac * h for _, _, frac, _ in CAPSULE_PARTS], dtype=np.float32)
    ends["left_foot"] = foot("left", float(radius[CAPSULE_NAMES.index("left_foot")]))
    ends["right_foot"] = foot("right", float(radius[CAPSULE_NAMES.index("right_foot")]))
    cap_a = np.stack([ends[n][0] for n in CAPSULE_NAMES], axis=1)
    cap_b = np.stack([ends[n][1] for n in CAPSULE_NAMES], axis=1)

    # Trunk frame: up along mid-hip -> mid-shoulder, left along the shoulder line.
    up = unit_vectors(mid_sh - mid_hip)
    left = ls - rs
    left = unit_vectors(left - np.sum(left * up, axis=-1, keepdims=True) * up)
    trunk = np.stack([np.cross(left, up), left, up], axis=-1)
    heading = np.asarray(worker.posture.heading, dtype=np.float64)
    c, s = np.cos(heading), np.sin(heading)
    pelvis = np.zeros((nf, 3, 3))
    pelvis[:, 0, 0], pelvis[:, 1, 0] = c, s
    pelvis[:, 0, 1], pelvis[:, 1, 1] = -s, c
    pelvis[:, 2, 2] = 1.0
    centres = np.stack(
        [
            mid_sh - up * (0.105 * h),
            mid_hip + up * (0.1 * h),
            mid_hip + np.array([0.0, 0.0, 0.01 * h]),
            neck_base + np.einsum("fij,j->fi", head, np.array(HEAD_CENTRE) * hh),
            p[:, J["nose"]] - head[:, :, 0] * (0.6 * NOSE_RADIUS * hh),
        ],
        axis=1,
    )
    axes = np.stack([trunk, trunk, pelvis, head, head], axis=1)
    radii = np.array(
        [
            (0.062 * h, 0.098 * h, 0.12 * h),
            (0.058 * h, 0.086 * h, 0.1 * h),
            (0.06 * h, 0.1 * h, 0.066 * h),
            tuple(r * hh for r in HEAD_RADII),
            (NOSE_RADIUS * hh,) * 3,
        ],
        dtype=np.float32,
    )

    # Carton between the hands, level, facing where the pelvis faces.
    lw, rw = p[:, J["left_wrist"]], p[:, J["right_wrist"]]
    across = lw - rw
    across[:, 2] = 0.0
    norm = np.linalg.norm(across, axis=1, keepdims=True)
    across = np.where(norm > 1e-6, across / np.maximum(norm, 1e-9), pelvis[:, :, 1])
    fwd = np.cross(across, np.array([0.0, 0.0, 1.0]))
    carton_axes = np.stack([fwd, across, np.broadcast_to([0.0, 0.0, 1.0], fwd.shape)], axis=-1)
    width = np.clip(np.linalg.norm(lw - rw, axis=1) - 0.05, 0.2, 0.5)
    carton_half = np.stack([np.full(nf, 0.16), width / 2.0, np.full(nf, 0.13)], axis=1)
    carton_centre = 0.5 * (lw + rw) + fwd * 0.04 + np.array([0.0, 0.0, -0.02])

    look = worker.spec.appearance
    # Long sleeves for some workers: the forearm takes the shirt colour.
    sleeve = look.shirt if (int(worker.spec.worker_id.lstrip("w") or 0) % 2 == 0) else look.skin
    slots = {"skin": look.skin, "shirt": look.shirt, "sleeve": sleeve, "trousers": look.trousers, "shoes": look.shoes}
    colours = [slots[slot] for *_, slot in CAPSULE_PARTS] + [slots[slot] for _, slot in ELLIPSOID_PARTS]
    colours.append(CARTON_COLOUR)

    def face_dir(names: list[str]) -> np.ndarray:
        q = np.mean([FACE_POINTS_IN_HEAD[n] for n in names], axis=0)
        v = (q - np.array(HEAD_CENTRE)) / np.array(HEAD_RADII)
        return v / np.linalg.norm(v)

    f32 = np.float32
    return BodyPrimitives(
        capsule_a=cap_a.astype(f32),
        capsule_b=cap_b.astype(f32),
        capsule_radius=radius,
        ellipsoid_centre=centres.astype(f32),
        ellipsoid_axes=axes.astype(f32),
        ellipsoid_radii=radii,
        carton_centre=carton_centre.astype(f32),
        carton_axes=carton_axes.astype(f32),
        carton_half=carton_half.astype(f32),
        carrying=np.asarray(worker.carrying, bool),
        colours=np.array(colours, dtype=f32),
        hair=np.array(look.hair, dtype=f32),
        eye_dirs=np.stack([face_dir(["left_eye"]), face_dir(["right_eye"])]).astype(f32),
        mouth_dir=face_dir(["mouth_left", "mouth_right"]).astype(f32),
    )


def all_body_primitives(motion: Motion) -> list[BodyPrimitives]:
    return [body_primitives(w) for w in motion.workers]
