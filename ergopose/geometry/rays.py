"""Rays in the world: where a ray from a camera reaches a given height (the floor at z = 0, z up).

Used where one camera's ray has to stand for a point: the tracker matching a person seen by one
camera to a track at the track's height (:mod:`ergopose.recon.track_matching`), and the 2D stage
placing a person one camera found on the floor for the other cameras (:mod:`ergopose.pose.handoff`).
"""

from __future__ import annotations

import numpy as np

#: A ray whose world z component is smaller than this in size does not fix a point at a height.
MIN_VERTICAL = 0.05


def ray_at_height(
    origin: np.ndarray, ray: np.ndarray, z: np.ndarray, min_vertical: float = MIN_VERTICAL
) -> tuple[np.ndarray, np.ndarray]:
    """Points of rays o + t d (R rays: ``origin`` and ``ray`` (R, 3)) at heights z (T,): (T, R, 3)
    and t (T, R).

    A nearly horizontal ray (|d_z| < ``min_vertical``) does not fix a point at a height: t is NaN
    there (and the point)."""
    dz = ray[:, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (z[:, None] - origin[None, :, 2]) / np.where(np.abs(dz) >= min_vertical, dz, np.nan)[None, :]
    return origin[None] + t[..., None] * ray[None], t
