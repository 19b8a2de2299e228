"""Z-buffered mannequins through the real fisheye lens: the simulated camera images.

Every image pixel is a ray from the camera centre (``camera.rays_world`` of the pixel centre,
computed once per camera and kept as a (H, W, 3) float32 array). The static part of the scene
(floor, walls, furniture, reference bars) is ray-cast once per camera into a background image
and a depth map (distance along the ray, metres). For each frame, each body part of each worker
(:class:`BodyPrimitives`: capsules for limbs, neck, shoulders, hands and feet; ellipsoids for
chest, abdomen, pelvis, head and nose; an oriented box for a carried carton) is intersected
analytically with the rays of the pixels inside its projected bounding box only; a pixel takes
the nearest surface (shelves hide people, limbs hide each other). Visible body pixels are then
shaded once (Lambert from a ceiling light plus ambient; a face with eyes, nose and mouth, and
hair, on the head).

The camera effects: a slight blur (the optics; it also smooths the mannequins' edges), sensor
noise (a few precomputed noise frames, picked per frame from the seed) and a slow change of
the overall brightness.

Ray-casting the same primitives for single rays gives each joint's visibility per camera
(:func:`joint_visibility`): the ground truth of which joints a camera can see.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import cv2
import numpy as np

from ergopose.atomic import atomic_path
from ergopose.ergonomics.body import FACE_POINTS_IN_HEAD
from ergopose.errors import InputError
from ergopose.geometry.camera import Camera
from ergopose.keypoints import BLAZEPOSE33, JOINT_INDEX, NUM_JOINTS
from ergopose.sim.motion import Motion, WorkerMotion
from ergopose.sim.scene import Box, Scene

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
    ("chest", "shirt"), ("abdomen", "shirt"), ("pelvis", "trousers"), ("head", "skin"), ("nose", "skin"),
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

LIGHT_WORLD = np.array([0.25, 0.35, 1.0]) / np.linalg.norm([0.25, 0.35, 1.0])
AMBIENT = 0.42
DIFFUSE = 0.58

#: Visibility codes of a joint in a camera (ground truth).
VISIBLE, SELF_OCCLUDED, OCCLUDED_BY_WORKER, OCCLUDED_BY_SCENE, OUTSIDE_IMAGE = 0, 1, 2, 3, 4
VISIBILITY_CODES = ("visible", "self_occluded", "occluded_by_worker", "occluded_by_scene", "outside_image")


@dataclass(frozen=True)
class RenderOptions:
    """Camera effects. noise_sigma: sensor noise (grey levels); blur_sigma: optical blur (pixels,
    0 = none); brightness_drift: relative amplitude of the slow brightness change; seed: for the
    noise."""

    noise_sigma: float = 2.5
    blur_sigma: float = 0.7
    brightness_drift: float = 0.04
    seed: int = 0


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


def _unit(v: np.ndarray) -> np.ndarray:
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
    y = _unit(joints[..., J["left_ear"], :] - joints[..., J["right_ear"], :])
    f = eye_mid - ear_mid
    f = _unit(f - np.sum(f * y, axis=-1, keepdims=True) * y)
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
        along = _unit(toe - heel)
        ankle = p[:, J[f"{side}_ankle"]]
        # the sole plane's up: perpendicular to the foot, towards the ankle
        up = ankle - heel
        up = _unit(up - np.sum(up * along, axis=-1, keepdims=True) * along)
        return heel + along * r + up * r, toe - along * 0.6 * r + up * r

    ends = {
        "neck": (mid_sh, chin),
        "shoulders": (ls, rs),
        "left_upper_arm": (ls, p[:, J["left_elbow"]]), "right_upper_arm": (rs, p[:, J["right_elbow"]]),
        "left_forearm": (p[:, J["left_elbow"]], p[:, J["left_wrist"]]),
        "right_forearm": (p[:, J["right_elbow"]], p[:, J["right_wrist"]]),
        "left_hand": (p[:, J["left_wrist"]], hand_tip("left")), "right_hand": (p[:, J["right_wrist"]], hand_tip("right")),
        "left_thigh": (lh, p[:, J["left_knee"]]), "right_thigh": (rh, p[:, J["right_knee"]]),
        "left_shank": (p[:, J["left_knee"]], p[:, J["left_ankle"]]),
        "right_shank": (p[:, J["right_knee"]], p[:, J["right_ankle"]]),
    }
    radius = np.array([frac * h for _, _, frac, _ in CAPSULE_PARTS], dtype=np.float32)
    ends["left_foot"] = foot("left", float(radius[CAPSULE_NAMES.index("left_foot")]))
    ends["right_foot"] = foot("right", float(radius[CAPSULE_NAMES.index("right_foot")]))
    cap_a = np.stack([ends[n][0] for n in CAPSULE_NAMES], axis=1)
    cap_b = np.stack([ends[n][1] for n in CAPSULE_NAMES], axis=1)

    # Trunk frame: up along mid-hip -> mid-shoulder, left along the shoulder line.
    up = _unit(mid_sh - mid_hip)
    left = ls - rs
    left = _unit(left - np.sum(left * up, axis=-1, keepdims=True) * up)
    trunk = np.stack([np.cross(left, up), left, up], axis=-1)
    heading = np.asarray(worker.posture.heading, dtype=np.float64)
    c, s = np.cos(heading), np.sin(heading)
    pelvis = np.zeros((nf, 3, 3))
    pelvis[:, 0, 0], pelvis[:, 1, 0] = c, s
    pelvis[:, 0, 1], pelvis[:, 1, 1] = -s, c
    pelvis[:, 2, 2] = 1.0
    centres = np.stack([
        mid_sh - up * (0.105 * h),
        mid_hip + up * (0.1 * h),
        mid_hip + np.array([0.0, 0.0, 0.01 * h]),
        neck_base + np.einsum("fij,j->fi", head, np.array(HEAD_CENTRE) * hh),
        p[:, J["nose"]] - head[:, :, 0] * (0.6 * NOSE_RADIUS * hh),
    ], axis=1)
    axes = np.stack([trunk, trunk, pelvis, head, head], axis=1)
    radii = np.array([
        (0.062 * h, 0.098 * h, 0.12 * h),
        (0.058 * h, 0.086 * h, 0.1 * h),
        (0.06 * h, 0.1 * h, 0.066 * h),
        tuple(r * hh for r in HEAD_RADII),
        (NOSE_RADIUS * hh,) * 3,
    ], dtype=np.float32)

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
        capsule_a=cap_a.astype(f32), capsule_b=cap_b.astype(f32), capsule_radius=radius,
        ellipsoid_centre=centres.astype(f32), ellipsoid_axes=axes.astype(f32), ellipsoid_radii=radii,
        carton_centre=carton_centre.astype(f32), carton_axes=carton_axes.astype(f32),
        carton_half=carton_half.astype(f32), carrying=np.asarray(worker.carrying, bool),
        colours=np.array(colours, dtype=f32), hair=np.array(look.hair, dtype=f32),
        eye_dirs=np.stack([face_dir(["left_eye"]), face_dir(["right_eye"])]).astype(f32),
        mouth_dir=face_dir(["mouth_left", "mouth_right"]).astype(f32),
    )


# --- ray intersections (broadcasting over any leading shape) -----------------------------------------


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1] + u[..., 2] * v[..., 2]


def ray_capsule(origin: np.ndarray, d: np.ndarray, a: np.ndarray, b: np.ndarray, r) -> np.ndarray:
    """Distance along unit rays ``d`` from ``origin`` to the first hit of capsules (a, b, r); inf = miss.

    Every argument broadcasts ((..., 3) vectors, (...) radii). The capsule is the union of a
    cylinder and two end spheres, so its first hit is the nearest of their first hits.
    """
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        ba = b - a
        oa = origin - a
        baba = _dot(ba, ba)
        bard = _dot(ba, d)
        baoa = _dot(ba, oa)
        rdoa = _dot(d, oa)
        oaoa = _dot(oa, oa)
        r2 = r * r
        qa = baba - bard * bard
        qb = baba * rdoa - baoa * bard
        qc = baba * oaoa - baoa * baoa - r2 * baba
        disc = qb * qb - qa * qc
        t_cyl = (-qb - np.sqrt(disc)) / qa
        y = baoa + t_cyl * bard
        t_cyl = np.where((disc > 0) & (y > 0) & (y < baba) & (t_cyl > 0), t_cyl, np.inf)
        h1 = rdoa * rdoa - (oaoa - r2)
        t1 = -rdoa - np.sqrt(h1)
        t_cyl = np.minimum(t_cyl, np.where((h1 > 0) & (t1 > 0), t1, np.inf))
        ob = origin - b
        rdob = _dot(d, ob)
        h2 = rdob * rdob - (_dot(ob, ob) - r2)
        t2 = -rdob - np.sqrt(h2)
        return np.minimum(t_cyl, np.where((h2 > 0) & (t2 > 0), t2, np.inf))


def ray_ellipsoid(origin: np.ndarray, d: np.ndarray, centre: np.ndarray, axes: np.ndarray,
                  radii: np.ndarray) -> np.ndarray:
    """First-hit distance of unit rays with ellipsoids (centre (..., 3), axes (..., 3, 3) columns,
    radii (..., 3)); inf = miss."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        scaled = axes / radii[..., None, :]
        o_l = np.einsum("...ji,...j->...i", scaled, origin - centre)
        d_l = np.einsum("...ji,...j->...i", scaled, d)
        qa = _dot(d_l, d_l)
        qb = _dot(o_l, d_l)
        qc = _dot(o_l, o_l) - 1.0
        disc = qb * qb - qa * qc
        t = (-qb - np.sqrt(disc)) / qa
        return np.where((disc > 0) & (t > 0), t, np.inf)


def ray_box(origin: np.ndarray, d: np.ndarray, centre: np.ndarray, axes: np.ndarray, half: np.ndarray) -> np.ndarray:
    """First-hit distance of unit rays with oriented boxes (centre, axes columns, half sizes); inf = miss."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        o_l = np.einsum("...ji,...j->...i", axes, origin - centre)
        d_l = np.einsum("...ji,...j->...i", axes, d)
        t1 = (-half - o_l) / d_l
        t2 = (half - o_l) / d_l
        lo = np.fmin(t1, t2)
        hi = np.fmax(t1, t2)
        t_near = np.fmax(np.fmax(lo[..., 0], lo[..., 1]), lo[..., 2])
        t_far = np.fmin(np.fmin(hi[..., 0], hi[..., 1]), hi[..., 2])
        return np.where((t_near <= t_far) & (t_near > 0), t_near, np.inf)


def ray_aabb_planar(origin: np.ndarray, inv: tuple[np.ndarray, np.ndarray, np.ndarray],
                    lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """First-hit distance of rays given by their inverse direction components (planes of any
    shape) with an axis-aligned box [lo, hi]; inf = miss."""
    near = far = None
    with np.errstate(invalid="ignore", over="ignore"):
        for k in range(3):
            t1 = (np.float32(lo[k] - origin[k])) * inv[k]
            t2 = (np.float32(hi[k] - origin[k])) * inv[k]
            a, b = np.fmin(t1, t2), np.fmax(t1, t2)
            near = a if near is None else np.fmax(near, a)
            far = b if far is None else np.fmin(far, b)
        return np.where((near <= far) & (near > 0), near, np.float32(np.inf))


# --- the static scene ---------------------------------------------------------------------------------

#: Walls of the hall around the work area (so the lens's outer ring sees walls, not void).
HALL_HALF = 4.2
HALL_HEIGHT = 3.6


def _hall_boxes() -> list[Box]:
    wall = (188, 196, 200)
    t = 0.2
    h = HALL_HALF
    return [Box("wall_n", "wall", (-h - t, h, 0.0), (h + t, h + t, HALL_HEIGHT), wall),
            Box("wall_s", "wall", (-h - t, -h - t, 0.0), (h + t, -h, HALL_HEIGHT), wall),
            Box("wall_e", "wall", (h, -h, 0.0), (h + t, h, HALL_HEIGHT), wall),
            Box("wall_w", "wall", (-h - t, -h, 0.0), (-h, h, HALL_HEIGHT), wall)]


def _bilinear_wrap(tex: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear lookup of a periodic texture (rows v, columns u, in texels)."""
    h, w = tex.shape
    u0 = np.floor(u)
    v0 = np.floor(v)
    fu = (u - u0)
    fv = (v - v0)
    i0 = u0.astype(np.int64) % w
    j0 = v0.astype(np.int64) % h
    i1 = (i0 + 1) % w
    j1 = (j0 + 1) % h
    top = tex[j0, i0] * (1 - fu) + tex[j0, i1] * fu
    bottom = tex[j1, i0] * (1 - fu) + tex[j1, i1] * fu
    return top * (1 - fv) + bottom * fv


def _floor_colour(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Concrete floor: mottled grey, 1 m expansion joints, a yellow border around the 6 x 6 m area."""
    rng = np.random.default_rng(12345)  # fixed texture: the floor is the same in every session
    coarse = rng.normal(0.0, 1.0, (64, 64)).astype(np.float32)
    coarse = cv2.GaussianBlur(coarse, (0, 0), 1.5)
    fine = rng.normal(0.0, 1.0, (512, 512)).astype(np.float32)
    # bilinear lookup in the periodic textures (10 m and 5 m periods)
    mot = _bilinear_wrap(coarse, (x / 10.0) * 64.0, (y / 10.0) * 64.0)
    grain = _bilinear_wrap(fine, (x / 5.0) * 512.0, (y / 5.0) * 512.0)
    grey = 150.0 + 14.0 * mot + 6.0 * grain
    out = np.stack([grey + 4.0, grey + 2.0, grey - 2.0], axis=-1)
    joint = (np.abs(x - np.round(x)) < 0.006) | (np.abs(y - np.round(y)) < 0.006)
    out[joint] *= 0.7
    border = ((np.abs(np.abs(x) - 3.0) < 0.05) & (np.abs(y) < 3.05)) | ((np.abs(np.abs(y) - 3.0) < 0.05) & (np.abs(x) < 3.05))
    stripe = (np.floor((x + y) / 0.2) % 2 == 0)
    out[border & stripe] = (20.0, 190.0, 230.0)
    out[border & ~stripe] = (30.0, 30.0, 30.0)
    return out


def _box_surface_colour(kind: str, base: np.ndarray, p: np.ndarray, normal_axis: np.ndarray) -> np.ndarray:
    """Surface pattern of a furniture box at hit points p (n, 3)."""
    col = np.broadcast_to(base, (p.shape[0], 3)).astype(np.float32).copy()
    if kind == "shelf":
        # side faces: orange boards every 0.45 m with goods (boxes, bins) between them
        z = p[:, 2]
        side = normal_axis != 2
        board = side & ((z % 0.45) < 0.035)
        col[board] = (40, 110, 220)
        goods = side & ~board
        cell = np.floor(z / 0.45) * 7 + np.floor((p[:, 0] + p[:, 1]) / 0.3)
        pick = (np.abs(np.sin(cell * 12.9898)) * 43758.5453) % 1.0
        palette = np.array([[70, 120, 170], [90, 140, 190], [150, 110, 60], [60, 160, 200], [120, 120, 120]],
                           np.float32)
        shade = 0.75 + 0.35 * ((pick * 7.0) % 1.0)
        col[goods] = palette[(pick[goods] * len(palette)).astype(int) % len(palette)] * shade[goods, None]
    elif kind == "carton":
        tape = np.abs(p[:, 0] - np.round(p[:, 0] * 5) / 5) < 0.012
        col[tape] *= 0.75
    elif kind == "pallet":
        slat = (p[:, 0] % 0.2) < 0.1
        col[slat] *= 0.8
    return col


@dataclass(frozen=True)
class StaticScene:
    """The furniture boxes (axis-aligned) and bars, ready for ray casting."""

    boxes: tuple[Box, ...]
    box_lo: np.ndarray
    box_hi: np.ndarray
    bar_a: np.ndarray
    bar_b: np.ndarray
    bar_radius: np.ndarray

    @classmethod
    def from_scene(cls, scene: Scene) -> "StaticScene":
        boxes = tuple(scene.boxes) + tuple(_hall_boxes())
        return cls(boxes=boxes, box_lo=np.array([b.lo for b in boxes], np.float32),
                   box_hi=np.array([b.hi for b in boxes], np.float32),
                   bar_a=np.array([b.end_a for b in scene.bars], np.float32).reshape(-1, 3),
                   bar_b=np.array([b.end_b for b in scene.bars], np.float32).reshape(-1, 3),
                   bar_radius=np.array([b.radius for b in scene.bars], np.float32))

    def hit(self, origin: np.ndarray, d: np.ndarray, camera: Camera | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(t, what) for unit rays d (..., 3): distance of the first hit and what was hit:
        -1 nothing, 0 floor, 1 + k box k, 1 + n_boxes + k bar k.

        With ``camera`` given, d must be the camera's (H, W, 3) pixel rays; each box is then only
        tested on the pixels of its projected bounding region.
        """
        o = np.asarray(origin, np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            t_floor = np.where(d[..., 2] < 0, np.float32(-o[2]) / d[..., 2], np.inf).astype(np.float32)
            inv = tuple((np.float32(1.0) / d[..., k]).astype(np.float32) for k in range(3))
        best = t_floor
        what = np.where(np.isfinite(t_floor), 0, -1).astype(np.int16)
        for k in range(len(self.boxes)):
            region = _box_region(camera, self.box_lo[k], self.box_hi[k]) if camera is not None else None
            sl = (Ellipsis,) if region is None else (slice(region[1], region[3]), slice(region[0], region[2]))
            t = ray_aabb_planar(o, tuple(c[sl] for c in inv), self.box_lo[k], self.box_hi[k])
            sub = best[sl]
            closer = t < sub
            sub[closer] = t[closer]
            what[sl][closer] = 1 + k
        for k in range(len(self.bar_a)):
            t = ray_capsule(o.astype(np.float32), d, self.bar_a[k], self.bar_b[k], self.bar_radius[k])
            closer = t < best
            best = np.where(closer, t, best)
            what[closer] = 1 + len(self.boxes) + k
        return best, what


def _box_region(camera: Camera, lo: np.ndarray, hi: np.ndarray) -> tuple[int, int, int, int] | None:
    """Pixel region (u0, v0, u1, v1) holding the image of an axis-aligned box, or None for the
    whole image (when part of the box lies beyond the lens). Edges are sampled densely because
    the fisheye bends straight lines."""
    s = np.linspace(0.0, 1.0, 17)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])], np.float64)
    pts = []
    for i in range(8):
        for j in range(i + 1, 8):
            if np.count_nonzero(corners[i] != corners[j]) == 1:  # an edge
                pts.append(corners[i] + (corners[j] - corners[i]) * s[:, None])
    pix = camera.project_world(np.concatenate(pts))
    if not np.isfinite(pix).all():
        return None
    u0 = int(np.clip(np.floor(pix[:, 0].min()) - 3, 0, camera.width))
    v0 = int(np.clip(np.floor(pix[:, 1].min()) - 3, 0, camera.height))
    u1 = int(np.clip(np.ceil(pix[:, 0].max()) + 4, 0, camera.width))
    v1 = int(np.clip(np.ceil(pix[:, 1].max()) + 4, 0, camera.height))
    return u0, v0, max(u0, u1), max(v0, v1)


def _shade(normal: np.ndarray) -> np.ndarray:
    return AMBIENT + DIFFUSE * np.clip(_dot(normal, LIGHT_WORLD.astype(np.float32)), 0.0, 1.0)


def render_background(camera: Camera, static: StaticScene, rays: np.ndarray,
                      valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(image uint8 (H, W, 3), depth float32 (H, W)) of the empty scene; depth inf outside the lens."""
    o = camera.position_world.astype(np.float32)
    t, what = static.hit(o, rays, camera)
    t[~valid] = np.inf
    what[~valid] = -1
    p = o + rays * np.where(np.isfinite(t), t, 0.0)[..., None]
    colour = np.zeros(rays.shape, np.float32)
    normal = np.zeros(rays.shape, np.float32)
    floor = what == 0
    colour[floor] = _floor_colour(p[floor, 0], p[floor, 1])
    normal[floor] = (0.0, 0.0, 1.0)
    n_boxes = len(static.boxes)
    for k, box in enumerate(static.boxes):
        sel = what == 1 + k
        if not sel.any():
            continue
        q = p[sel]
        centre = 0.5 * (static.box_lo[k] + static.box_hi[k])
        half = 0.5 * (static.box_hi[k] - static.box_lo[k])
        rel = (q - centre) / half
        axis = np.argmax(np.abs(rel), axis=1)
        nrm = np.zeros_like(q)
        nrm[np.arange(len(q)), axis] = np.sign(rel[np.arange(len(q)), axis])
        normal[sel] = nrm
        colour[sel] = _box_surface_colour(box.kind, np.array(box.colour, np.float32), q, axis)
    for k in range(len(static.bar_a)):
        sel = what == 1 + n_boxes + k
        if not sel.any():
            continue
        a, b = static.bar_a[k], static.bar_b[k]
        q = p[sel]
        ab = b - a
        s = np.clip(((q - a) @ ab) / float(ab @ ab), 0.0, 1.0)
        nrm = q - (a + s[:, None] * ab)
        normal[sel] = _unit(nrm)
        length = float(np.linalg.norm(ab))
        along = s * length
        stripes = np.where(np.floor(along / 0.1) % 2 == 0, 0, 1)
        col = np.where(stripes[:, None] == 0, np.float32([20, 200, 235]), np.float32([25, 25, 25]))
        caps = (along < 0.05) | (along > length - 0.05)
        col[caps] = (30, 30, 220)
        colour[sel] = col
    shade = _shade(normal)
    shade[what < 0] = 0.0
    # Lens falloff (vignetting) towards the rim of the image circle.
    rays_cam = rays @ camera.rotation_world_from_cam.astype(np.float32)
    cos_theta = np.clip(rays_cam[..., 2], -1.0, 1.0)
    vignette = 0.78 + 0.22 * np.clip(cos_theta, 0.0, 1.0)
    img = np.clip(colour * (shade * vignette)[..., None], 0, 255)
    img[~valid] = 0
    return img.astype(np.uint8), t.astype(np.float32)


def pixel_rays(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Unit world rays (H, W, 3) float32 of every pixel centre and the (H, W) mask of valid ones."""
    u = np.arange(camera.width, dtype=np.float64)
    v = np.arange(camera.height, dtype=np.float64)
    grid = np.stack(np.meshgrid(u, v), axis=-1)
    rays = camera.rays_world(grid)
    valid = np.isfinite(rays).all(axis=-1)
    rays[~valid] = (0.0, 0.0, 1.0)
    return rays.astype(np.float32), valid


# --- per-frame rendering ------------------------------------------------------------------------------


def _quiet(fn):
    """Run a ray kernel with NaN/inf arithmetic silent (NaN marks a miss, by design)."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return fn(*args, **kwargs)

    return wrapper


def _sphere_samples() -> np.ndarray:
    pts = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    pts += [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    return _unit(np.array(pts, np.float64))


#: Points on a sphere, inflated: the fisheye image of a sphere is not exactly bounded by the
#: images of 14 of its points; 25 % more radius and 2 pixels of margin cover the difference.
_SAMPLES = _sphere_samples() * 1.25
_NAN = np.float32(np.nan)


class CameraRenderer:
    """Renders frames of one camera: background once, then the workers per frame.

    The rays are kept as planes (three (H, W) float32 arrays) plus their six pairwise products,
    so every primitive costs a few dozen array operations on the pixels of its own bounding box.
    """

    def __init__(self, camera: Camera, scene: Scene, bodies: list[BodyPrimitives], options: RenderOptions):
        self.camera = camera
        self.bodies = bodies
        self.options = options
        self.origin = camera.position_world.astype(np.float64)
        rays, self.valid = pixel_rays(camera)
        self.rays = rays
        self.rx, self.ry, self.rz = (np.ascontiguousarray(rays[..., k]) for k in range(3))
        self.xx, self.yy, self.zz = self.rx * self.rx, self.ry * self.ry, self.rz * self.rz
        self.xy, self.xz, self.yz = self.rx * self.ry, self.rx * self.rz, self.ry * self.rz
        self.rays_flat = rays.reshape(-1, 3)
        for name in ("rx", "ry", "rz", "xx", "yy", "zz", "xy", "xz", "yz"):
            setattr(self, f"{name}_flat", getattr(self, name).reshape(-1))
        self.static = StaticScene.from_scene(scene)
        self.sharp_background, self.bg_depth = render_background(camera, self.static, rays, self.valid)
        self.bg_depth_flat = self.bg_depth.reshape(-1)
        self.background = self._blur(self.sharp_background)
        h, w = camera.height, camera.width
        self._noise: list[tuple[np.ndarray, np.ndarray]] = []
        if options.noise_sigma > 0:
            rng = np.random.default_rng(np.random.SeedSequence([options.seed, 7]))
            for _ in range(4):
                n = np.rint(rng.standard_normal((h, w, 3), dtype=np.float32) * np.float32(options.noise_sigma))
                n = n.astype(np.int16)
                n[~self.valid] = 0
                self._noise.append((np.clip(n, 0, 255).astype(np.uint8), np.clip(-n, 0, 255).astype(np.uint8)))
        self._noise_pick = np.random.default_rng(np.random.SeedSequence([options.seed, 11]))

    def _blur(self, img: np.ndarray) -> np.ndarray:
        if self.options.blur_sigma <= 0:
            return img.copy()
        return cv2.GaussianBlur(img, (0, 0), self.options.blur_sigma)

    # bounding boxes -------------------------------------------------------------------------
    def _boxes(self, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """(P, 4) int pixel boxes (u0, v0, u1, v1), end exclusive, of spheres (P, 3), (P,)."""
        pts = centres[:, None, :].astype(np.float64) + radii[:, None, None] * _SAMPLES[None, :, :]
        pix = self.camera.project_world(pts)
        with np.errstate(invalid="ignore"):
            lo = np.floor(np.nanmin(pix, axis=1)) - 2
            hi = np.ceil(np.nanmax(pix, axis=1)) + 3
        bad = ~np.isfinite(pix).all(axis=(1, 2))  # part of the sphere beyond the lens: whole image
        w, h = self.camera.width, self.camera.height
        box = np.empty((len(centres), 4), np.int64)
        box[:, 0] = np.clip(np.nan_to_num(lo[:, 0], nan=0), 0, w)
        box[:, 1] = np.clip(np.nan_to_num(lo[:, 1], nan=0), 0, h)
        box[:, 2] = np.clip(np.nan_to_num(hi[:, 0], nan=w), 0, w)
        box[:, 3] = np.clip(np.nan_to_num(hi[:, 1], nan=h), 0, h)
        box[bad] = (0, 0, w, h)
        return box

    def _frame_boxes(self, frame: int) -> list[np.ndarray]:
        """Per worker (N_PRIMITIVES, 4) pixel boxes, from one projection call for the frame."""
        centres, radii = [], []
        for body in self.bodies:
            r = body.capsule_radius
            centres += [body.capsule_a[frame], body.capsule_b[frame], body.ellipsoid_centre[frame],
                        body.carton_centre[frame][None, :]]
            radii += [r, r, body.ellipsoid_radii.max(axis=1),
                      np.array([np.linalg.norm(body.carton_half[frame])], np.float32)]
        box = self._boxes(np.concatenate(centres), np.concatenate(radii))
        per = 2 * N_CAPSULES + N_ELLIPSOIDS + 1
        out = []
        for w in range(len(self.bodies)):
            b = box[w * per:(w + 1) * per]
            ba, bb = b[:N_CAPSULES], b[N_CAPSULES:2 * N_CAPSULES]
            caps = np.concatenate([np.minimum(ba[:, :2], bb[:, :2]), np.maximum(ba[:, 2:], bb[:, 2:])], axis=1)
            out.append(np.concatenate([caps, b[2 * N_CAPSULES:]]))
        return out

    # batched intersections: every pixel of every primitive's box in one array -------------
    def _pixels_of_boxes(self, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(flat pixel index (N,), primitive row (N,)) of all pixels inside the boxes (P, 4)."""
        w_img = self.camera.width
        bw = np.maximum(boxes[:, 2] - boxes[:, 0], 0)
        bh = np.maximum(boxes[:, 3] - boxes[:, 1], 0)
        n = bw * bh
        total = int(n.sum())
        prim = np.repeat(np.arange(len(boxes)), n)
        start = np.cumsum(n) - n
        local = np.arange(total) - np.repeat(start, n)
        bwp = bw[prim]
        row = boxes[prim, 1] + local // bwp
        col = boxes[prim, 0] + local % bwp
        return row * w_img + col, prim

    @_quiet
    def _capsules(self, flat: np.ndarray, prim: np.ndarray, a: np.ndarray, b: np.ndarray,
                  r: np.ndarray) -> np.ndarray:
        """Hit distances (N,) of pixel rays with capsules a, b (P, 3), r (P,) by primitive row; NaN = miss."""
        o = self.origin
        ba = (b - a).astype(np.float64)
        oa = o - a
        ob = oa - ba
        baba = np.einsum("ij,ij->i", ba, ba)
        baoa = np.einsum("ij,ij->i", ba, oa)
        oaoa = np.einsum("ij,ij->i", oa, oa)
        r2 = r.astype(np.float64) ** 2
        consts = np.stack([baba, baoa, baba * oaoa - baoa * baoa - r2 * baba, oaoa - r2,
                           np.einsum("ij,ij->i", ob, ob) - r2], axis=1).astype(np.float32)[prim]
        vec = np.concatenate([ba, oa], axis=1).astype(np.float32)[prim]
        rx, ry, rz = self.rx_flat[flat], self.ry_flat[flat], self.rz_flat[flat]
        bard = rx * vec[:, 0] + ry * vec[:, 1] + rz * vec[:, 2]
        rdoa = rx * vec[:, 3] + ry * vec[:, 4] + rz * vec[:, 5]
        baba_p, baoa_p = consts[:, 0], consts[:, 1]
        qa = baba_p - bard * bard
        qb = baba_p * rdoa - baoa_p * bard
        t = (-qb - np.sqrt(qb * qb - qa * consts[:, 2])) / qa
        y = baoa_p + t * bard
        t[(y <= 0) | (y >= baba_p)] = _NAN
        t1 = -rdoa - np.sqrt(rdoa * rdoa - consts[:, 3])
        rdob = rdoa - bard
        t2 = -rdob - np.sqrt(rdob * rdob - consts[:, 4])
        return np.fmin(np.fmin(t, t1), t2)

    @_quiet
    def _ellipsoids(self, flat: np.ndarray, prim: np.ndarray, centre: np.ndarray, axes: np.ndarray,
                    radii: np.ndarray) -> np.ndarray:
        """Hit distances (N,) of pixel rays with ellipsoids (P, ...) by primitive row; NaN = miss."""
        m = axes.astype(np.float64) / radii.astype(np.float64)[:, None, :]      # columns axis_i / r_i
        q = np.einsum("pik,pjk->pij", m, m)                                        # d'.d' = d^T q d
        o_l = np.einsum("pji,pj->pi", m, self.origin - centre)
        wv = np.einsum("pij,pj->pi", m, o_l)                                       # o'.d' = d . wv
        c = np.einsum("pi,pi->p", o_l, o_l) - 1.0
        coef = np.stack([q[:, 0, 0], q[:, 1, 1], q[:, 2, 2], 2 * q[:, 0, 1], 2 * q[:, 0, 2], 2 * q[:, 1, 2],
                         wv[:, 0], wv[:, 1], wv[:, 2], c], axis=1).astype(np.float32)[prim]
        qa = (self.xx_flat[flat] * coef[:, 0] + self.yy_flat[flat] * coef[:, 1] + self.zz_flat[flat] * coef[:, 2]
              + self.xy_flat[flat] * coef[:, 3] + self.xz_flat[flat] * coef[:, 4] + self.yz_flat[flat] * coef[:, 5])
        qb = self.rx_flat[flat] * coef[:, 6] + self.ry_flat[flat] * coef[:, 7] + self.rz_flat[flat] * coef[:, 8]
        return (-qb - np.sqrt(qb * qb - qa * coef[:, 9])) / qa

    @_quiet
    def _obb(self, flat: np.ndarray, centre: np.ndarray, axes: np.ndarray, half: np.ndarray) -> np.ndarray:
        o_l = axes.T.astype(np.float64) @ (self.origin - centre)
        rx, ry, rz = self.rx_flat[flat], self.ry_flat[flat], self.rz_flat[flat]
        near = far = None
        for i in range(3):
            d_l = rx * np.float32(axes[0, i]) + ry * np.float32(axes[1, i]) + rz * np.float32(axes[2, i])
            t1 = (np.float32(-half[i] - o_l[i])) / d_l
            t2 = (np.float32(half[i] - o_l[i])) / d_l
            lo, hi = np.fmin(t1, t2), np.fmax(t1, t2)
            near = lo if near is None else np.fmax(near, lo)
            far = hi if far is None else np.fmin(far, hi)
        near[(near > far) | (near <= 0)] = _NAN
        return near

    def render(self, frame: int) -> np.ndarray:
        """The camera image (H, W, 3) uint8 BGR of one frame."""
        self._set_gain(frame)
        img = self.background_gained.copy()
        if not self.bodies:
            return self._noise_add(img)
        boxes = self._frame_boxes(frame)
        pix, t, gid = self._depth_pass(frame, boxes)
        if pix.size:
            colours = np.empty((len(pix), 3), np.uint8)
            worker = gid // N_PRIMITIVES
            for w in range(len(self.bodies)):
                sel = worker == w
                if sel.any():
                    colours[sel] = self._shade_body(frame, w, gid[sel] - w * N_PRIMITIVES, t[sel],
                                                    self.rays_flat[pix[sel]])
            self._composite(img, pix, colours, boxes)
        return self._noise_add(img)

    def surface_ids(self, frame: int) -> tuple[np.ndarray, np.ndarray]:
        """(ids, depth) of one frame, (H, W) each: what each pixel's ray meets first.

        ids: worker index * N_PRIMITIVES + primitive index (PRIMITIVE_NAMES), or -1 for the static
        scene (floor, furniture, bars) and outside the lens. depth: distance along the ray, metres.
        """
        ids = np.full(self.camera.height * self.camera.width, -1, np.int16)
        depth = self.bg_depth_flat.copy()
        if self.bodies:
            pix, t, gid = self._depth_pass(frame, self._frame_boxes(frame))
            ids[pix] = gid
            depth[pix] = t
        shape = (self.camera.height, self.camera.width)
        return ids.reshape(shape), depth.reshape(shape)

    def _depth_pass(self, frame: int, boxes: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Body pixels nearer than the static scene: (flat pixel index, distance, global id), one per pixel."""
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            # capsules of all workers in one batch, then ellipsoids, then carried cartons
            cap_boxes = np.concatenate([b[:N_CAPSULES] for b in boxes])
            flat_c, prim_c = self._pixels_of_boxes(cap_boxes)
            t_c = self._capsules(flat_c, prim_c,
                                 np.concatenate([body.capsule_a[frame] for body in self.bodies]),
                                 np.concatenate([body.capsule_b[frame] for body in self.bodies]),
                                 np.concatenate([body.capsule_radius for body in self.bodies]))
            gid_c = (prim_c // N_CAPSULES) * N_PRIMITIVES + prim_c % N_CAPSULES
            ell_boxes = np.concatenate([b[N_CAPSULES:CARTON] for b in boxes])
            flat_e, prim_e = self._pixels_of_boxes(ell_boxes)
            t_e = self._ellipsoids(flat_e, prim_e,
                                   np.concatenate([body.ellipsoid_centre[frame] for body in self.bodies]),
                                   np.concatenate([body.ellipsoid_axes[frame] for body in self.bodies]),
                                   np.concatenate([body.ellipsoid_radii for body in self.bodies]))
            gid_e = (prim_e // N_ELLIPSOIDS) * N_PRIMITIVES + N_CAPSULES + prim_e % N_ELLIPSOIDS
            flats, ts, gids = [flat_c, flat_e], [t_c, t_e], [gid_c, gid_e]
            for w, body in enumerate(self.bodies):
                if body.carrying[frame]:
                    f_b, _ = self._pixels_of_boxes(boxes[w][CARTON:CARTON + 1])
                    flats.append(f_b)
                    ts.append(self._obb(f_b, body.carton_centre[frame], body.carton_axes[frame],
                                        body.carton_half[frame]))
                    gids.append(np.full(len(f_b), w * N_PRIMITIVES + CARTON))
            flat = np.concatenate(flats)
            t = np.concatenate(ts)
            gid = np.concatenate(gids).astype(np.int16)
            hit = t < self.bg_depth_flat[flat]           # NaN (miss) compares False
            flat, t, gid = flat[hit], t[hit], gid[hit]
        # z-buffer: the nearest surface per pixel (sort by pixel, then distance; keep the first)
        order = np.lexsort((t, flat))
        flat, t, gid = flat[order], t[order], gid[order]
        first = np.ones(len(flat), bool)
        first[1:] = flat[1:] != flat[:-1]
        return flat[first], t[first], gid[first]

    def _composite(self, img: np.ndarray, pix: np.ndarray, colours: np.ndarray, boxes: list[np.ndarray]) -> None:
        """Paint the body pixels into the sharp background, blur around them, paste into ``img``."""
        h, w = self.camera.height, self.camera.width
        sharp = self.sharp_gained.copy()
        sharp.reshape(-1, 3)[pix] = colours
        if self.options.blur_sigma <= 0:
            img.reshape(-1, 3)[pix] = colours
            return
        margin = 2 + int(math.ceil(3 * self.options.blur_sigma))
        rows, cols = pix // w, pix % w
        regions = []
        for b in boxes:  # one region per worker: the pixels it covers, plus the blur margin
            regions.append([int(b[:, 0].min()), int(b[:, 1].min()), int(b[:, 2].max()), int(b[:, 3].max())])
        merged = _merge_regions(regions)
        for u0, v0, u1, v1 in merged:
            inside = (rows >= v0) & (rows < v1) & (cols >= u0) & (cols < u1)
            if not inside.any():
                continue
            r0, r1 = int(rows[inside].min()), int(rows[inside].max()) + 1
            c0, c1 = int(cols[inside].min()), int(cols[inside].max()) + 1
            # blur a region larger by 2 margins; paste the inner part (one margin) whose blur saw full kernels
            a0, a1 = max(0, r0 - 2 * margin), min(h, r1 + 2 * margin)
            b0, b1 = max(0, c0 - 2 * margin), min(w, c1 + 2 * margin)
            blurred = self._blur(sharp[a0:a1, b0:b1])
            i0, i1 = max(0, r0 - margin), min(h, r1 + margin)
            j0, j1 = max(0, c0 - margin), min(w, c1 + margin)
            img[i0:i1, j0:j1] = blurred[i0 - a0:i1 - a0, j0 - b0:j1 - b0]

    def _set_gain(self, frame: int) -> None:
        """Slow brightness drift; the background is rescaled only when the quantised gain changes."""
        gain = 1.0 + self.options.brightness_drift * math.sin(2 * math.pi * frame / (12.0 * 47.0))
        level = round(gain * 400.0) / 400.0
        if level != getattr(self, "_gain", None):
            self._gain = level
            lut = np.clip(np.arange(256, dtype=np.float64) * level + 0.5, 0, 255).astype(np.uint8)
            self.background_gained = cv2.LUT(self.background, lut)
            self.sharp_gained = cv2.LUT(self.sharp_background, lut)

    def _noise_add(self, img: np.ndarray) -> np.ndarray:
        if self._noise:
            pos, neg = self._noise[int(self._noise_pick.integers(len(self._noise)))]
            cv2.add(img, pos, dst=img)
            cv2.subtract(img, neg, dst=img)
        return img

    def _shade_body(self, frame: int, w: int, local: np.ndarray, t: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Colours (n, 3) uint8 of body pixels: primitive index, hit distance, ray."""
        body = self.bodies[w]
        p = (self.origin + d * t[:, None]).astype(np.float32)
        normal = np.empty_like(p)
        cap = local < N_CAPSULES
        if cap.any():
            k = local[cap]
            a = body.capsule_a[frame][k]
            ab = body.capsule_b[frame][k] - a
            s = np.clip(_dot(p[cap] - a, ab) / np.maximum(_dot(ab, ab), 1e-12), 0.0, 1.0)
            normal[cap] = p[cap] - (a + s[:, None] * ab)
        ell = (local >= N_CAPSULES) & (local < CARTON)
        colour = body.colours[local].copy()
        if ell.any():
            e = local[ell] - N_CAPSULES
            axes = body.ellipsoid_axes[frame][e]
            radii = body.ellipsoid_radii[e]
            q = np.einsum("nji,nj->ni", axes, p[ell] - body.ellipsoid_centre[frame][e]) / radii
            normal[ell] = np.einsum("nij,nj->ni", axes, q / radii)
            head = e == HEAD - N_CAPSULES
            if head.any():
                colour[np.flatnonzero(ell)[head]] = self._face(body, _unit(q[head]), colour[ell][head])
        box = local == CARTON
        if box.any():
            axes = body.carton_axes[frame]
            q = (p[box] - body.carton_centre[frame]) @ axes / body.carton_half[frame]
            ax = np.argmax(np.abs(q), axis=1)
            sign = np.sign(q[np.arange(len(q)), ax])
            normal[box] = axes.T[ax] * sign[:, None]
        normal = _unit(normal)
        shade = _shade(normal)
        return np.clip(colour * (shade * self._gain)[:, None], 0, 255).astype(np.uint8)

    @staticmethod
    def _face(body: BodyPrimitives, q: np.ndarray, skin: np.ndarray) -> np.ndarray:
        """Head colours from the unit direction q (n, 3) in the head ellipsoid's scaled frame."""
        col = skin.copy()
        hair = (q[:, 2] > 0.42) | ((q[:, 0] < -0.15) & (q[:, 2] > -0.3))
        col[hair] = body.hair
        for e in body.eye_dirs:
            col[_dot(q, e) > math.cos(0.16)] = (35, 30, 30)
        m = body.mouth_dir
        mouth = (_dot(q, m) > math.cos(0.3)) & (np.abs(q[:, 2] - m[2]) < 0.05)
        col[mouth] = (60, 50, 150)
        return col


def _merge_regions(regions: list[list[int]]) -> list[list[int]]:
    """Merge overlapping boxes (u0, v0, u1, v1) until none overlap."""
    merged = [list(r) for r in regions]
    changed = True
    while changed:
        changed = False
        for i in range(len(merged)):
            for j in range(i + 1, len(merged)):
                a, b = merged[i], merged[j]
                if a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]:
                    merged[i] = [min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3])]
                    del merged[j]
                    changed = True
                    break
            if changed:
                break
    return merged


# --- videos ------------------------------------------------------------------------------------------------


def open_writer(path: Path, fps: float, width: int, height: int) -> cv2.VideoWriter:
    """An mp4v VideoWriter; InputError if OpenCV cannot write the file."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), float(fps), (int(width), int(height)))
    if not writer.isOpened():
        raise InputError("OpenCV cannot write an mp4v video here", path=path)
    return writer


def render_video(camera: Camera, scene: Scene, bodies: list[BodyPrimitives], path: str | Path, fps: float,
                 options: RenderOptions = RenderOptions(),
                 on_frame: Callable[[int], None] | None = None) -> Path:
    """Render every frame of one camera into an mp4v video at ``path`` (written atomically)."""
    n_frames = bodies[0].n_frames if bodies else 0
    renderer = CameraRenderer(camera, scene, bodies, options)
    path = Path(path)
    with atomic_path(path) as tmp:
        writer = open_writer(tmp, fps, camera.width, camera.height)
        try:
            for f in range(n_frames):
                writer.write(renderer.render(f))
                if on_frame is not None:
                    on_frame(f + 1)
        finally:
            writer.release()
    return path


# --- visibility -------------------------------------------------------------------------------------------

#: Per joint: the body primitives it lies in or on, and how far in front of the joint their
#: surface may be for the joint to count as seen (metres).
_HOSTS: dict[str, tuple[tuple[str, ...], float]] = {}
for _name in BLAZEPOSE33:
    if _name in FACE_POINTS_IN_HEAD:
        _HOSTS[_name] = (("head", "nose"), 0.03)
for _side in ("left", "right"):
    _HOSTS[f"{_side}_shoulder"] = (("shoulders", f"{_side}_upper_arm", "chest", "neck"), 0.08)
    _HOSTS[f"{_side}_elbow"] = ((f"{_side}_upper_arm", f"{_side}_forearm"), 0.055)
    _HOSTS[f"{_side}_wrist"] = ((f"{_side}_forearm", f"{_side}_hand"), 0.045)
    for _pt in ("pinky", "index", "thumb"):
        _HOSTS[f"{_side}_{_pt}"] = ((f"{_side}_hand", f"{_side}_forearm"), 0.045)
    _HOSTS[f"{_side}_hip"] = (("pelvis", "abdomen", f"{_side}_thigh"), 0.14)
    _HOSTS[f"{_side}_knee"] = ((f"{_side}_thigh", f"{_side}_shank"), 0.085)
    _HOSTS[f"{_side}_ankle"] = ((f"{_side}_shank", f"{_side}_foot"), 0.07)
    for _pt in ("heel", "foot_index"):
        _HOSTS[f"{_side}_{_pt}"] = ((f"{_side}_foot", f"{_side}_shank"), 0.06)
assert len(_HOSTS) == NUM_JOINTS

#: (33, N_PRIMITIVES) tolerance (metres) of each primitive in front of each joint of the same worker.
HOST_TOLERANCE = np.full((NUM_JOINTS, N_PRIMITIVES), 0.01, np.float32)
for _name, (_hosts, _tol) in _HOSTS.items():
    for _h in _hosts:
        HOST_TOLERANCE[J[_name], PRIMITIVE_NAMES.index(_h)] = _tol
#: Tolerance for primitives of other workers and for furniture.
OTHER_TOLERANCE = 0.01


def _primitive_distances(o: np.ndarray, d: np.ndarray, body: BodyPrimitives, frames: slice) -> np.ndarray:
    """Hit distances (f, R, N_PRIMITIVES) of rays d (f, R, 3) with one worker's primitives."""
    a = body.capsule_a[frames][:, None]          # (f, 1, C, 3)
    b = body.capsule_b[frames][:, None]
    dd = d[:, :, None, :]
    t_cap = ray_capsule(o, dd, a, b, body.capsule_radius)
    t_ell = ray_ellipsoid(o, dd, body.ellipsoid_centre[frames][:, None], body.ellipsoid_axes[frames][:, None],
                          body.ellipsoid_radii)
    t_box = ray_box(o, d, body.carton_centre[frames][:, None], body.carton_axes[frames][:, None],
                    body.carton_half[frames][:, None])
    t_box = np.where(body.carrying[frames][:, None], t_box, np.inf)
    return np.concatenate([t_cap, t_ell, t_box[..., None]], axis=-1)


def joint_visibility(camera: Camera, scene: Scene, motion: Motion, bodies: list[BodyPrimitives],
                     chunk: int = 64) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ground truth per frame and worker of one camera: (pixels (F, W, 33, 2) float32 fisheye
    pixels (NaN where the lens cannot image the joint), theta (F, W, 33) float32 radians from the
    lens axis, visibility (F, W, 33) int8 codes of :data:`VISIBILITY_CODES`).

    A joint is visible when the ray from the camera to it meets nothing nearer than the joint
    itself, except the body parts it belongs to, which may lie up to a few centimetres in front
    of it (their surface covers the joint; see _HOSTS). Otherwise it is occluded by its own body,
    another worker or the scene (furniture, walls, bars); joints whose pixel is outside the
    image (or beyond the lens) are "outside_image".
    """
    joints = motion.joints_world  # (F, W, 33, 3)
    nf, nw = joints.shape[:2]
    o = camera.position_world
    pixels = camera.project_world(joints)
    theta = camera.theta_of_points_world(joints)
    inside = camera.in_image(pixels) & np.isfinite(pixels).all(axis=-1)
    static = StaticScene.from_scene(scene)
    codes = np.full((nf, nw, NUM_JOINTS), VISIBLE, np.int8)
    for f0 in range(0, nf, chunk):
        f1 = min(nf, f0 + chunk)
        sl = slice(f0, f1)
        rel = joints[sl] - o                                  # (f, W, 33, 3)
        dist = np.linalg.norm(rel, axis=-1)
        d = (rel / dist[..., None]).reshape(f1 - f0, nw * NUM_JOINTS, 3).astype(np.float32)
        dist = dist.reshape(f1 - f0, nw * NUM_JOINTS).astype(np.float32)
        t_scene, _ = static.hit(o.astype(np.float32), d)
        blocked_scene = t_scene < dist - OTHER_TOLERANCE
        blocked_self = np.zeros_like(blocked_scene)
        blocked_other = np.zeros_like(blocked_scene)
        owner = np.repeat(np.arange(nw), NUM_JOINTS)
        joint_of_ray = np.tile(np.arange(NUM_JOINTS), nw)
        for w, body in enumerate(bodies):
            t = _primitive_distances(o.astype(np.float32), d, body, sl)   # (f, R, P)
            own = owner == w
            tol = np.where(own[:, None], HOST_TOLERANCE[joint_of_ray], OTHER_TOLERANCE)  # (R, P)
            hit = t < (dist[..., None] - tol[None])
            any_hit = hit.any(axis=-1)
            blocked_self |= any_hit & own[None, :]
            blocked_other |= any_hit & ~own[None, :]
        c = codes[sl].reshape(f1 - f0, nw * NUM_JOINTS)
        c[blocked_self] = SELF_OCCLUDED
        c[blocked_other] = OCCLUDED_BY_WORKER
        c[blocked_scene] = OCCLUDED_BY_SCENE
        codes[sl] = c.reshape(f1 - f0, nw, NUM_JOINTS)
    codes[~inside] = OUTSIDE_IMAGE
    return pixels.astype(np.float32), theta.astype(np.float32), codes


def all_body_primitives(motion: Motion) -> list[BodyPrimitives]:
    return [body_primitives(w) for w in motion.workers]


__all__ = [
    "RenderOptions", "BodyPrimitives", "body_primitives", "all_body_primitives", "CameraRenderer",
    "render_video", "render_background", "pixel_rays", "joint_visibility", "StaticScene", "VISIBILITY_CODES",
    "VISIBLE", "SELF_OCCLUDED", "OCCLUDED_BY_WORKER", "OCCLUDED_BY_SCENE", "OUTSIDE_IMAGE", "PRIMITIVE_NAMES",
    "ray_capsule", "ray_ellipsoid", "ray_box", "head_axes",
]
