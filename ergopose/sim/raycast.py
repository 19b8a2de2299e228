"""Ray intersections with the primitives of the simulated scene (capsule, ellipsoid, oriented box,
axis-aligned box), broadcasting over any leading shape: distance along the ray, inf for a miss.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

# --- ray intersections (broadcasting over any leading shape) -----------------------------------------


def dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Dot products of 3-vectors along the last axis (u, v broadcast)."""
    return u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1] + u[..., 2] * v[..., 2]


def ray_capsule(origin: np.ndarray, d: np.ndarray, a: np.ndarray, b: np.ndarray, r) -> np.ndarray:
    """Distance along unit rays ``d`` from ``origin`` to the first hit of capsules (a, b, r); inf = miss.

    Every argument broadcasts ((..., 3) vectors, (...) radii). The capsule is the union of a
    cylinder and two end spheres, so its first hit is the nearest of their first hits.
    """
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        ba = b - a
        oa = origin - a
        baba = dot(ba, ba)
        bard = dot(ba, d)
        baoa = dot(ba, oa)
        rdoa = dot(d, oa)
        oaoa = dot(oa, oa)
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
        rdob = dot(d, ob)
        h2 = rdob * rdob - (dot(ob, ob) - r2)
        t2 = -rdob - np.sqrt(h2)
        return np.minimum(t_cyl, np.where((h2 > 0) & (t2 > 0), t2, np.inf))


def ray_ellipsoid(
    origin: np.ndarray, d: np.ndarray, centre: np.ndarray, axes: np.ndarray, radii: np.ndarray
) -> np.ndarray:
    """First-hit distance of unit rays with ellipsoids (centre (..., 3), axes (..., 3, 3) columns,
    radii (..., 3)); inf = miss."""
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        scaled = axes / radii[..., None, :]
        o_l = np.einsum("...ji,...j->...i", scaled, origin - centre)
        d_l = np.einsum("...ji,...j->...i", scaled, d)
        qa = dot(d_l, d_l)
        qb = dot(o_l, d_l)
        qc = dot(o_l, o_l) - 1.0
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


def ray_aabb_planar(origin: np.ndarray, inv: Sequence[np.ndarray], lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """First-hit distance of rays given by their inverse direction components (planes of any
    shape; inv: the three components) with an axis-aligned box [lo, hi]; inf = miss."""
    with np.errstate(invalid="ignore", over="ignore"):
        los, his = [], []
        for k in range(3):
            t1 = (np.float32(lo[k] - origin[k])) * inv[k]
            t2 = (np.float32(hi[k] - origin[k])) * inv[k]
            los.append(np.fmin(t1, t2))
            his.append(np.fmax(t1, t2))
        near = np.fmax(np.fmax(los[0], los[1]), los[2])
        far = np.fmin(np.fmin(his[0], his[1]), his[2])
        return np.where((near <= far) & (near > 0), near, np.float32(np.inf))
