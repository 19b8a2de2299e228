"""The rigid transform (rotation and translation, no scale) that best maps paired points onto each
other: the Kabsch solution, used to place a body template onto triangulated joints
(ergopose.recon.bodyfit) and to align a reference recording with an assessment
(ergopose.evaluation.reference)."""

from __future__ import annotations

import numpy as np


def kabsch(ref: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R and translation t minimising sum |R ref_i + t - target_i|^2 (no scale; det R = +1).
    ref, target: (N, 3) paired points, N >= 3 not all on a line."""
    mr, mt = ref.mean(axis=0), target.mean(axis=0)
    h = (ref - mr).T @ (target - mt)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return r, mt - r @ mr


__all__ = ["kabsch"]
