"""Orientation of a person view in one camera: aim, roll, and the world's "up" in it.

A view is upright when the image of the world's vertical points up in it (the paper's
construction); a view may be rolled about its axis, e.g. towards a person's body axis, by a
bounded angle (``bounded_up``). Directions are unit vectors in the camera frame; rolls are
radians, clockwise on screen.
"""

from __future__ import annotations

import math

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.geometry.camera import Camera, cross3
from ergopose.geometry.views import upright_rotation

#: The world's vertical (z up).
WORLD_UP = np.array([0.0, 0.0, 1.0])


def unit(v: np.ndarray) -> FloatArray:
    """``v`` scaled to unit length along its last axis."""
    unit_v: FloatArray = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return unit_v


def angle_between(a: np.ndarray, b: np.ndarray) -> FloatArray:
    """Angles (radians) between unit vectors a (..., 3) and b (..., 3), accurate near 0."""
    angle: FloatArray = 2.0 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))
    return angle


def world_up_cam(camera: Camera) -> FloatArray:
    """The world's vertical in the camera frame."""
    up_cam: FloatArray = np.asarray(camera.rotation_world_from_cam, dtype=np.float64).T @ WORLD_UP
    return up_cam


def upright_view_rotation(camera: Camera, direction_cam: np.ndarray) -> np.ndarray:
    """rotation_cam_from_view (3, 3) of the upright view along ``direction_cam``."""
    return upright_rotation(direction_cam, world_up_cam(camera))


def roll_towards(camera: Camera, direction_cam: np.ndarray, up_cam: np.ndarray | None) -> float:
    """Roll (radians, clockwise on screen) that turns the up of the upright view along the unit
    ``direction_cam`` onto the image of ``up_cam`` (0 when ``up_cam`` is None or along the axis)."""
    if up_cam is None:
        return 0.0
    u = upright_view_rotation(camera, direction_cam).T @ np.asarray(up_cam, dtype=np.float64)
    if not (np.all(np.isfinite(u)) and np.hypot(u[0], u[1]) > 1e-12 * max(float(np.linalg.norm(u)), 1e-300)):
        return 0.0
    # Rolling by r turns the view's up (0, -1) into (sin r, -cos r) in the upright view.
    return float(np.arctan2(u[0], -u[1]))


def rolled_view_rotation(camera: Camera, direction_cam: np.ndarray, roll: float) -> FloatArray:
    """rotation_cam_from_view (3, 3) of the view along the unit ``direction_cam`` turned by
    ``roll`` (radians, clockwise on screen) from upright."""
    c, s = np.cos(roll), np.sin(roll)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    rotation: FloatArray = upright_view_rotation(camera, direction_cam) @ rz
    return rotation


def view_rotation(camera: Camera, direction_cam: np.ndarray, up_cam: np.ndarray | None = None) -> np.ndarray:
    """rotation_cam_from_view (3, 3) of a view looking along ``direction_cam``.

    up_cam None: upright (the image of the world's vertical points up, as
    ``VirtualView.aimed_along``). Otherwise the view is rolled about its axis so that the image
    of ``up_cam`` (its component across the axis) points straight up; when that component
    vanishes (up along the axis) the view stays upright.
    """
    return rolled_view_rotation(camera, direction_cam, roll_towards(camera, direction_cam, up_cam))


def upright_defined(camera: Camera, direction_cam: np.ndarray, undefined_angle: float) -> bool:
    """True when a view along ``direction_cam`` is further than ``undefined_angle`` from the
    world's vertical (up or down), so that "upright" is well defined in it."""
    d = unit(np.asarray(direction_cam, dtype=np.float64))
    c = cross3(d, world_up_cam(camera))
    return bool(math.sqrt(float(c.dot(c))) > np.sin(undefined_angle))  # np.linalg.norm's arithmetic


def roll_from_upright(camera: Camera, direction_cam: np.ndarray, up_cam: np.ndarray | None) -> float:
    """Roll (radians, clockwise on screen, in (-pi, pi]) of the image of ``up_cam`` from the
    image of world up, in a view along ``direction_cam`` (0 when ``up_cam`` is None or along
    the axis)."""
    return roll_towards(camera, unit(np.asarray(direction_cam, dtype=np.float64)), up_cam)


def bounded_up(
    camera: Camera, direction_cam: np.ndarray, up_cam: np.ndarray | None, max_roll: float, undefined_angle: float = 0.0
) -> FloatArray | None:
    """The up direction of a view along ``direction_cam`` that follows ``up_cam`` (e.g. the body
    axis) but is rolled at most ``max_roll`` from world upright. None when ``up_cam`` is None;
    ``up_cam`` unchanged when the view is within ``undefined_angle`` of the world's vertical (no
    world up to hold to) or ``max_roll`` >= pi; None (upright) when ``max_roll`` is 0."""
    if up_cam is None:
        return None
    d = unit(np.asarray(direction_cam, dtype=np.float64))
    if max_roll >= np.pi or not upright_defined(camera, d, undefined_angle):
        return up_cam
    if max_roll <= 0:
        return None
    roll = float(np.clip(roll_towards(camera, d, up_cam), -max_roll, max_roll))
    # roll_towards of this vector is ``roll``: its image in the upright view is (sin r, -cos r).
    up_view: FloatArray = upright_view_rotation(camera, d) @ np.array([np.sin(roll), -np.cos(roll), 0.0])
    return up_view
