"""Which person seen by camera A is which person seen by camera B, in one frame.

The cost of pairing detection i of camera A with detection j of camera B is the mean distance
in metres between their rays through the same torso joints (shoulders and hips, each seen by
both cameras with at least ``min_confidence``): two rays through the same body point meet (up
to the 2D error), rays through different people generally do not. With fewer than
``association_min_joints`` such torso joints, every joint seen by both counts (at least 3).

A pair is only possible when, for every joint used, the closest approach of the two rays lies
in front of both cameras, the torso joints' midpoints lie between ``torso_min_z_m`` and
``torso_max_z_m``, and the trunk (mid-hip to mid-shoulder) of those midpoints is between
``trunk_min_length_m`` and ``trunk_max_length_m`` long. These checks remove most "ghost" pairs:
two different people standing in the same epipolar plane (on a line parallel to the baseline)
have rays that meet exactly, but at a point between or above them, which makes a body far too
short or too high.

The pairs are chosen by a globally optimal assignment among the candidates whose cost is at
most ``association_max_distance_m`` (:func:`gated_assignment`: the total margin below the gate
is maximised with ``scipy.optimize.linear_sum_assignment``; leaving a person unpaired is allowed,
so one good pair is not traded for two poor ones). People left without a partner are single-view
observations: they are kept (the tracker uses them to follow an identity) but never
triangulated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from ergopose.recon.records import HIPS, SHOULDERS, TORSO_JOINTS
from ergopose.recon.settings import ReconSettings
from ergopose.records import Detections2D



@dataclass(frozen=True)
class Association:
    """Result of associating the people of two cameras in one frame.

    pairs: (K, 2) int, rows (i, j): detection i of camera A is detection j of camera B.
    cost_m: (K,) mean ray-to-ray distance of each pair, metres.
    single_a, single_b: indices of the detections left without a partner in each camera.
    cost_matrix_m: (Na, Nb) the cost of every candidate pair; +inf for impossible pairs.
    """

    pairs: np.ndarray
    cost_m: np.ndarray
    single_a: np.ndarray
    single_b: np.ndarray
    cost_matrix_m: np.ndarray


def gated_assignment(cost: np.ndarray, gate, gain: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Optimal pairs among candidates with cost <= gate (gate: scalar, or per row (R, 1)).

    Maximises the total relative margin sum(1 - cost / gate) over the chosen pairs, where
    leaving a row or a column unpaired costs nothing: linear_sum_assignment on
    min(cost / gate - 1, 0) (impossible and gated-out candidates weigh 0, like no pair).
    A plain assignment on the costs must pair as many as it can and would trade one good pair
    for two poor ones (two wrong pairs when one person's partner is missing); dividing by the
    gate keeps rows with wide gates (tracks unseen for a while) from outbidding close ones.
    ``gain`` (same shape as cost, > 0) replaces the relative margin as what is maximised over
    the candidates within the gates (the tracker passes a log-likelihood gain).
    Returns (rows, cols) of the chosen pairs.
    """
    cost = np.asarray(cost, dtype=np.float64)
    if cost.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(cost) & (cost <= gate)
    if not ok.any():
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(ok, cost / gate - 1.0 if gain is None else -np.asarray(gain, dtype=np.float64), 0.0)
    rows, cols = linear_sum_assignment(w)
    keep = ok[rows, cols]
    return rows[keep].astype(np.int64), cols[keep].astype(np.int64)


def ray_closest_points(origin_a, rays_a, origin_b, rays_b):
    """Closest approach of lines o_a + s d_a and o_b + t d_b (unit d), broadcasting (..., 3).

    Returns (distance, midpoint (..., 3), s, t); s and t are the distances along each ray (> 0
    in front of the camera). Parallel rays give NaN.
    """
    w0 = origin_a - origin_b
    b = np.sum(rays_a * rays_b, axis=-1)
    d = np.sum(rays_a * w0, axis=-1)
    e = np.sum(rays_b * w0, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        denom = 1.0 - b * b
        denom = np.where(denom > 1e-12, denom, np.nan)
        s = (b * e - d) / denom
        t = (e - b * d) / denom
    pa = origin_a + s[..., None] * rays_a
    pb = origin_b + t[..., None] * rays_b
    dist = np.linalg.norm(pa - pb, axis=-1)
    return dist, 0.5 * (pa + pb), s, t


def pair_costs(det_a: Detections2D, det_b: Detections2D, settings: ReconSettings) -> np.ndarray:
    """(Na, Nb) mean ray-to-ray distance in metres of every candidate pair; +inf if impossible."""
    na, nb = det_a.count, det_b.count
    if na == 0 or nb == 0:
        return np.full((na, nb), np.inf)
    ra, rb = det_a.world_rays(), det_b.world_rays()  # (N, 33, 3)
    oa, ob = det_a.centres_world(), det_b.centres_world()
    seen_a = det_a.confidence >= max(settings.min_confidence, 1e-12)
    seen_b = det_b.confidence >= max(settings.min_confidence, 1e-12)
    both = seen_a[:, None, :] & seen_b[None, :, :]  # (Na, Nb, 33)
    dist, mid, s, t = ray_closest_points(oa[:, None, None, :], ra[:, None], ob[None, :, None, :], rb[None, :])
    with np.errstate(invalid="ignore"):
        front = (s > 0) & (t > 0)
    torso = np.zeros(both.shape[-1], bool)
    torso[TORSO_JOINTS] = True
    n_torso = (both & torso).sum(axis=-1)
    use = np.where((n_torso >= settings.association_min_joints)[..., None], both & torso, both)
    n_use = use.sum(axis=-1)
    enough = np.where(n_torso >= settings.association_min_joints, True, n_use >= 3)
    with np.errstate(invalid="ignore"):
        cost = np.where(use, dist, 0.0).sum(axis=-1) / np.maximum(n_use, 1)
        ok = enough & ~np.any(use & ~(front & np.isfinite(dist)), axis=-1)
        # Plausibility of the torso built from the ray midpoints.
        z = mid[..., 2]
        tz = use[..., TORSO_JOINTS]
        zt = z[..., TORSO_JOINTS]
        bad_z = tz & ((zt < settings.torso_min_z_m) | (zt > settings.torso_max_z_m))
        ok &= ~bad_z.any(axis=-1)
        sh = _masked_mean(mid[..., SHOULDERS, :], use[..., SHOULDERS])
        hp = _masked_mean(mid[..., HIPS, :], use[..., HIPS])
        trunk = np.linalg.norm(sh - hp, axis=-1)
        has_trunk = np.isfinite(trunk)
        ok &= ~has_trunk | ((trunk >= settings.trunk_min_length_m) & (trunk <= settings.trunk_max_length_m))
    return np.where(ok, cost, np.inf)


def _masked_mean(points: np.ndarray, mask: np.ndarray) -> np.ndarray:
    n = mask.sum(axis=-1)
    s = np.where(mask[..., None], points, 0.0).sum(axis=-2)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n[..., None] > 0, s / n[..., None], np.nan)


def associate(det_a: Detections2D, det_b: Detections2D, settings: ReconSettings | None = None) -> Association:
    """Pair the people of camera A with those of camera B in one frame (globally optimal).

    Returns an :class:`Association`; every detection is either in exactly one pair or single.
    """
    settings = settings or ReconSettings()
    cost = pair_costs(det_a, det_b, settings)
    na, nb = cost.shape
    rows, cols = gated_assignment(cost, settings.association_max_distance_m)
    pairs = np.stack([rows, cols], axis=1).astype(np.int64)
    single_a = np.setdiff1d(np.arange(na), pairs[:, 0])
    single_b = np.setdiff1d(np.arange(nb), pairs[:, 1])
    return Association(pairs=pairs, cost_m=cost[pairs[:, 0], pairs[:, 1]] if len(pairs) else np.zeros(0),
                       single_a=single_a, single_b=single_b, cost_matrix_m=cost)
