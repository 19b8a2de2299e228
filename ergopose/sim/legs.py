"""Analytic inverse kinematics of a simulated leg: from the pelvis to an ankle target, the hip
flexion, hip abduction and knee flexion, and the ankle angle that keeps the sole level
(:func:`leg_ik`).
"""

from __future__ import annotations

import numpy as np

from ergopose.ergonomics.body import BodyMeasurements

#: Fraction of the leg length (hip to ankle) the pelvis may stretch a leg to.
MAX_LEG_STRETCH = 0.998


# --- leg inverse kinematics -------------------------------------------------------------------------


def leg_ik(
    m: BodyMeasurements,
    root: np.ndarray,
    heading: np.ndarray,
    ankle_world: np.ndarray,
    side: str,
    foot_pitch: np.ndarray | float = 0.0,
) -> dict[str, np.ndarray]:
    """Hip flexion, hip abduction, knee flexion and ankle flexion that put the ankle at ``ankle_world``.

    root (F, 3) mid-hip point, heading (F,), ankle_world (F, 3). The ankle angle keeps the sole
    level (plus ``foot_pitch``, toes up positive). Targets beyond MAX_LEG_STRETCH of the leg are
    reached as far as the leg allows (the callers keep the pelvis low enough that this never
    happens). Conventions: those of :mod:`ergopose.ergonomics.body`.
    """
    sigma = 1.0 if side == "left" else -1.0
    lt, ls = m.thigh_length, m.shank_length
    d_world = np.asarray(ankle_world, float) - np.asarray(root, float)
    c, s = np.cos(heading), np.sin(heading)
    vx = c * d_world[:, 0] + s * d_world[:, 1]
    vy = -s * d_world[:, 0] + c * d_world[:, 1] - sigma * m.hip_width / 2.0
    vz = d_world[:, 2]
    dist = np.sqrt(vx * vx + vy * vy + vz * vz)
    dist = np.clip(dist, abs(lt - ls) + 1e-6, (lt + ls) * (1.0 - 1e-12))
    cos_k = (dist * dist - lt * lt - ls * ls) / (2.0 * lt * ls)
    knee = np.arccos(np.clip(cos_k, -1.0, 1.0))
    rho = lt + ls * np.cos(knee)
    ab_signed = np.arcsin(np.clip(vy / rho, -1.0, 1.0))  # sigma * hip_abduction
    a = -ls * np.sin(knee)
    zp = -rho * np.cos(ab_signed)
    hip_flex = np.arctan2(vz, vx) - np.arctan2(zp, a)
    hip_flex = (hip_flex + np.pi) % (2 * np.pi) - np.pi
    beta = np.arctan2(np.sin(hip_flex), np.cos(hip_flex) * np.cos(ab_signed))
    ankle = knee - beta + foot_pitch
    return {
        f"{side}_hip_flexion": hip_flex,
        f"{side}_hip_abduction": sigma * ab_signed,
        f"{side}_knee_flexion": knee,
        f"{side}_ankle_flexion": ankle,
    }
