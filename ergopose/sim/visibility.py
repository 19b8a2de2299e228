"""Which joints a camera sees (ground truth): each joint's ray from the camera against the body
primitives of every worker and the scene, coded visible, self-occluded, occluded by another
worker or by the scene, or outside the image (:func:`joint_visibility`).
"""

from __future__ import annotations

import numpy as np

from ergopose.ergonomics.body import FACE_POINTS_IN_HEAD
from ergopose.geometry.camera import Camera
from ergopose.keypoints import BLAZEPOSE33, NUM_JOINTS
from ergopose.sim.backdrop import StaticScene
from ergopose.sim.bodies import N_PRIMITIVES, PRIMITIVE_NAMES, BodyPrimitives, J
from ergopose.sim.raycast import ray_box, ray_capsule, ray_ellipsoid
from ergopose.sim.scene import Scene
from ergopose.sim.workforce import Motion

#: Visibility codes of a joint in a camera (ground truth).
VISIBLE, SELF_OCCLUDED, OCCLUDED_BY_WORKER, OCCLUDED_BY_SCENE, OUTSIDE_IMAGE = 0, 1, 2, 3, 4
VISIBILITY_CODES = ("visible", "self_occluded", "occluded_by_worker", "occluded_by_scene", "outside_image")


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
    a = body.capsule_a[frames][:, None]  # (f, 1, C, 3)
    b = body.capsule_b[frames][:, None]
    dd = d[:, :, None, :]
    t_cap = ray_capsule(o, dd, a, b, body.capsule_radius)
    t_ell = ray_ellipsoid(
        o, dd, body.ellipsoid_centre[frames][:, None], body.ellipsoid_axes[frames][:, None], body.ellipsoid_radii
    )
    t_box = ray_box(
        o, d, body.carton_centre[frames][:, None], body.carton_axes[frames][:, None], body.carton_half[frames][:, None]
    )
    t_box = np.where(body.carrying[frames][:, None], t_box, np.inf)
    return np.concatenate([t_cap, t_ell, t_box[..., None]], axis=-1)


def joint_visibility(
    camera: Camera, scene: Scene, motion: Motion, bodies: list[BodyPrimitives], chunk: int = 64
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
        rel = joints[sl] - o  # (f, W, 33, 3)
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
            t = _primitive_distances(o.astype(np.float32), d, body, sl)  # (f, R, P)
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
