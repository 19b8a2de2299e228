"""Rotation vectors <-> matrices, vectorised (Rodrigues), for the least-squares solvers."""

from __future__ import annotations

import cv2
import numpy as np

from ergopose.arrays import FloatArray


def rotation_matrices(rvecs: np.ndarray) -> np.ndarray:
    """(..., 3) rotation vectors (axis * angle, radians) -> (..., 3, 3) rotation matrices."""
    r = np.asarray(rvecs, dtype=np.float64)
    theta = np.linalg.norm(r, axis=-1)[..., None, None]
    small = theta < 1e-12
    safe = np.where(small, 1.0, theta)
    k = r / safe[..., 0]  # unit axes, (..., 3)
    kx, ky, kz = k[..., 0], k[..., 1], k[..., 2]
    zero = np.zeros_like(kx)
    K = np.stack([np.stack([zero, -kz, ky], -1), np.stack([kz, zero, -kx], -1), np.stack([-ky, kx, zero], -1)], -2)
    eye = np.broadcast_to(np.eye(3), K.shape)
    sin, cos = np.sin(safe), np.cos(safe)
    R = eye + sin * K + (1.0 - cos) * (K @ K)
    # first-order form near zero: I + [r]x
    rx, ry, rz = r[..., 0], r[..., 1], r[..., 2]
    Rs = eye + np.stack(
        [np.stack([zero, -rz, ry], -1), np.stack([rz, zero, -rx], -1), np.stack([-ry, rx, zero], -1)], -2
    )
    return np.where(small, Rs, R)


def rotation_vectors(matrices: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices -> (..., 3) rotation vectors (via OpenCV's Rodrigues)."""
    m = np.asarray(matrices, dtype=np.float64)
    flat = m.reshape(-1, 3, 3)
    out = np.array([cv2.Rodrigues(x)[0].ravel() for x in flat]).reshape(m.shape[:-2] + (3,))
    return out


def angle_between(R_a: np.ndarray, R_b: np.ndarray) -> FloatArray:
    """Angle (radians) of the rotation taking R_a to R_b."""
    rel = np.swapaxes(np.asarray(R_a), -1, -2) @ np.asarray(R_b)
    c = (np.trace(rel, axis1=-2, axis2=-1) - 1.0) / 2.0
    angle: FloatArray = np.arccos(np.clip(c, -1.0, 1.0))
    return angle
