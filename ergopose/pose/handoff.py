"""Cues from the other cameras: where a person one camera found should appear in another.

A camera that loses a person (seen from above, half hidden, lost for a few frames) often has a
neighbour that still sees them. The rig's cameras share one world (floor at z = 0, z up), so the
person found by camera A can be placed on the floor from A alone and looked for in camera B:

1. *A floor point per person in A* (:func:`floor_points_world`): the rays of the confident ankles
   and heels meet the plane ``FOOT_HEIGHT_M`` above the floor; without them, the rays of the
   confident hips meet the plane ``HIP_HEIGHT_M`` above it. The point is where the person stands.
   A wrong height (a crouch, a foot on a step) moves it along A's line of sight by the height's
   error times the tangent of A's angle off its axis: about 0.3 m for 0.3 m at 45 degrees,
   which the view's margin holds.
2. *A view in B* (:func:`cues_in_camera`): a standing body (a column ``BODY_HEIGHT_M`` tall and
   ``BODY_RADIUS_M`` wide above the floor point) seen from B: the view is aimed at the column's
   middle and its angular radius is the largest angle from there to the column's top, bottom and
   sides, as the view of any cue is sized (``FisheyePoseEstimator``).

Nothing is triangulated here: the cue only says where to look. Whether a person is there is the
landmark network's answer in B, with the gate of a new person (``min_presence``), as for the
search and motion cues. The 2D stage of each camera stays its own; the cameras only pass each
other places to look, frame by frame, inside one chunk (:func:`ergopose.pipeline.detect.video_2d`).
"""

from __future__ import annotations

from typing import Protocol, Sequence

import numpy as np

from ergopose.geometry.camera import Camera
from ergopose.geometry.rays import ray_at_height
from ergopose.keypoints import JOINT_INDEX
from ergopose.pose.records import FrameDetections
from ergopose.pose.view_geometry import angle_between

#: Height above the floor of the ankle and heel keypoints of a person standing (metres).
FOOT_HEIGHT_M = 0.08
#: Height above the floor of the hip keypoints of a person standing (metres): about 0.53 of a
#: stature of 1.7 m.
HIP_HEIGHT_M = 0.9
#: The column a person is taken to fill above their floor point: height and horizontal radius
#: (metres), enough for a standing worker with the arms out.
BODY_HEIGHT_M = 1.8
BODY_RADIUS_M = 0.4
#: A ray's world z component must be at least this in size to meet the floor in front of the
#: camera; a ray near the horizon places the person anywhere along it.
MIN_DOWN = 0.1
#: Farthest a floor point may lie from the camera, horizontally (metres).
MAX_RANGE_M = 30.0

_FEET = [JOINT_INDEX[j] for j in ("left_ankle", "right_ankle", "left_heel", "right_heel")]
_HIPS = [JOINT_INDEX[j] for j in ("left_hip", "right_hip")]


def _meet_plane(origin_world: np.ndarray, rays_world: np.ndarray, height_m: float) -> np.ndarray:
    """(..., 3) points where rays from ``origin_world`` meet the plane z = height_m
    (:func:`ergopose.geometry.rays.ray_at_height`); NaN where a ray is within ``MIN_DOWN`` of
    horizontal, meets the plane behind the camera or beyond ``MAX_RANGE_M``."""
    flat = rays_world.reshape(-1, 3)
    points, t = ray_at_height(np.broadcast_to(origin_world, flat.shape), flat, np.array([height_m]), MIN_DOWN)
    points, t = points[0], t[0]
    with np.errstate(invalid="ignore"):
        ok = (t > 0) & (np.linalg.norm(points[:, :2] - origin_world[:2], axis=-1) <= MAX_RANGE_M)
    return np.where(ok[:, None], points, np.nan).reshape(rays_world.shape)


def floor_points_world(found: FrameDetections, camera: Camera, min_confidence: float) -> np.ndarray:
    """(N, 3) the floor point (z = 0) under each person ``camera`` found; NaN rows where neither
    the feet nor the hips were seen with ``min_confidence`` (module docstring, step 1)."""
    n = found.count
    if n == 0:
        return np.zeros((0, 3))
    rays_world = found.rays_cam @ camera.rotation_world_from_cam.T  # (N, 33, 3)
    sure = (found.confidence >= min_confidence) & np.isfinite(rays_world).all(axis=-1)
    origin = camera.position_world

    def mean_point(joints: list[int], height_m: float) -> np.ndarray:
        points = _meet_plane(origin, rays_world[:, joints], height_m)  # (N, J, 3)
        points = np.where(sure[:, joints, None], points, np.nan)
        counted = np.isfinite(points).all(axis=-1)
        total = np.where(counted[..., None], points, 0.0).sum(axis=1)
        k = counted.sum(axis=1)
        return np.where((k > 0)[:, None], total / np.maximum(k, 1)[:, None], np.nan)

    feet = mean_point(_FEET, FOOT_HEIGHT_M)
    hips = mean_point(_HIPS, HIP_HEIGHT_M)
    out = np.where(np.isfinite(feet).all(axis=1, keepdims=True), feet, hips)
    out[:, 2] = np.where(np.isfinite(out[:, 0]), 0.0, np.nan)
    return out


def cues_in_camera(camera: Camera, floor_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where to look in ``camera`` for people standing on ``floor_world`` (M, 3): (M, 3) unit
    directions in its camera frame, aimed at the middle of each person's column, and (M,) the
    column's angular radius seen from there (radians). Rows whose column is not in front of the
    lens (or whose floor point is NaN) come back NaN (module docstring, step 2)."""
    floor_world = np.asarray(floor_world, dtype=np.float64).reshape(-1, 3)
    m = len(floor_world)
    r, h = BODY_RADIUS_M, BODY_HEIGHT_M
    offsets = np.array(
        [[0, 0, 0], [0, 0, h], [r, 0, h / 2], [-r, 0, h / 2], [0, r, h / 2], [0, -r, h / 2]], dtype=np.float64
    )
    centre_world = floor_world + np.array([0.0, 0.0, h / 2])
    centre_cam = camera.points_world_to_cam(centre_world)  # (M, 3)
    edge_cam = camera.points_world_to_cam(floor_world[:, None, :] + offsets[None])  # (M, 6, 3)
    direction = centre_cam / np.linalg.norm(centre_cam, axis=-1, keepdims=True)
    edges = edge_cam / np.linalg.norm(edge_cam, axis=-1, keepdims=True)
    radius = angle_between(direction[:, None, :], edges).max(axis=1) if m else np.zeros(0)
    # The column's middle must be where the camera sees: in front of it and on its lit image.
    ok = np.isfinite(direction).all(axis=1) & np.isfinite(radius)
    ok &= camera.lit(camera.lens.project(np.where(ok[:, None], direction, np.array([0.0, 0.0, 1.0]))))
    return np.where(ok[:, None], direction, np.nan), np.where(ok, radius, np.nan)


class TakesCues(Protocol):
    """A camera's 2D stage that can be told where to look (``FisheyePoseEstimator.take_cues``)."""

    @property
    def wants_cues(self) -> bool: ...

    def take_cues(self, directions_cam: np.ndarray, radii: np.ndarray) -> None: ...


def pass_cues(
    stages: Sequence[TakesCues], found: Sequence[FrameDetections], cameras: Sequence[Camera], min_confidence: float
) -> None:
    """Tell each camera's stage where the other cameras found people in this frame (for its next
    frame): every person of every other camera placed on the floor (:func:`floor_points_world`)
    and seen from this camera (:func:`cues_in_camera`). The stage itself skips the places one of
    its views already holds; a stage whose next frame takes no cues (``wants_cues``) is told
    nothing, and when none takes them nothing is computed."""
    if len(stages) < 2 or not any(stage.wants_cues for stage in stages):
        return
    floors = [floor_points_world(f, cam, min_confidence) for f, cam in zip(found, cameras)]
    for b, (stage, camera) in enumerate(zip(stages, cameras)):
        if not stage.wants_cues:
            continue
        points = [floors[a] for a in range(len(floors)) if a != b]
        floor_world = np.concatenate(points) if points else np.zeros((0, 3))
        floor_world = floor_world[np.isfinite(floor_world).all(axis=1)]
        directions, radii = cues_in_camera(camera, floor_world)
        stage.take_cues(directions, radii)
