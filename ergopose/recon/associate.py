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

:func:`associate_views` does the same for any number C of cameras: a person is a *set* of
detections, at most one per camera. With three or more cameras, every candidate pair of every
two cameras (cost within the gate) seeds a hypothesis: its torso joints are triangulated from
the two views (least-squares point of the rays), and each other camera adds the detection
whose torso rays pass closest to those points, if the mean distance is within
``association_max_distance_m`` (a ray passing within d of the point where two rays meet lies
within d of each of them, so the gate keeps every pairwise ray distance of the set within the
pairwise gate). The torso is triangulated again from all the set's views; an added view whose
rays are then farther than the gate is dropped (the worst first), and the set must pass the same
plausibility checks as a pair. Sets are then taken greedily, the most cameras first and, among
equals, the lowest cost, skipping any that shares a detection with a set already taken: a ghost
pair (two people in one epipolar plane of two cameras) rarely gets a third camera's support,
while the true set does. The detections left over are paired with the gated optimal assignment
of each camera pair; where two cameras' assignments claim the same detection, the lower cost
wins and the assignments are run again without the detections taken. Last, sets (or single
detections) with no camera in common that are linked by a candidate pair are joined when all
the union's views meet its triangulated points within the gate (:func:`_merge_sets`: a seed
only grows with cameras that see enough of the joints both seed views saw, so a half-hidden
worker could otherwise be left as two pairs). With two cameras this is exactly
:func:`associate`; with one camera every detection is single. Details and measurements:
docs/reconstruction.md, section 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence, cast

import numpy as np
from scipy.optimize import linear_sum_assignment

from ergopose.arrays import BoolArray, FloatArray, IntArray
from ergopose.geometry.triangulation import triangulate_midpoint
from ergopose.keypoints import MIRROR, NUM_JOINTS
from ergopose.recon.records import HIPS, SHOULDERS, TORSO_JOINTS
from ergopose.recon.settings import ReconSettings
from ergopose.records import Detections2D

#: One camera's world rays (N, 33, 3) and view centres (N, 3), as Detections2D gives them.
CameraRays = tuple[FloatArray, FloatArray]


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


def gated_assignment(
    cost: np.ndarray, gate: float | np.ndarray, gain: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
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


def ray_closest_points(
    origin_a: np.ndarray, rays_a: np.ndarray, origin_b: np.ndarray, rays_b: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
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


def pair_costs(
    det_a: Detections2D,
    det_b: Detections2D,
    settings: ReconSettings,
    rays: tuple[CameraRays | None, CameraRays | None] | None = None,
) -> np.ndarray:
    """(Na, Nb) mean ray-to-ray distance in metres of every candidate pair; +inf if impossible.

    rays: optional ((rays_a, centres_a), (rays_b, centres_b)) already computed (world_rays(),
    centres_world()) -- associate_views computes them once per camera."""
    na, nb = det_a.count, det_b.count
    if na == 0 or nb == 0:
        return np.full((na, nb), np.inf)
    if rays is None:
        rays = ((det_a.world_rays(), det_a.centres_world()), (det_b.world_rays(), det_b.centres_world()))
    # both cameras have detections here, so both have their rays (None only for a camera without)
    (ra, oa), (rb, ob) = cast("tuple[CameraRays, CameraRays]", rays)  # (N, 33, 3), (N, 3)
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


#: Two cameras' detections of one person have their left and right crossed when pairing them with
#: one of the two mirrored (keypoints.MIRROR) costs less than this fraction of pairing them as
#: reported; as reported when the reverse holds; undecided in between (a person seen side-on).
SIDE_MARGIN = 0.6
#: ... and by at least this much (metres of mean ray distance): two small costs of noise alone
#: (a person seen side-on, whose left and right rays nearly coincide) decide nothing. A crossed
#: torso misses by about a shoulder's or a hip's width (0.1-0.4 m).
SIDE_MIN_GAIN_M = 0.05


def canonical_sides(dets: Sequence[Detections2D], settings: ReconSettings | None = None) -> list[Detections2D]:
    """The detections of one frame with every person's left and right agreeing across cameras.

    A 2D network can take a person's back for their front and hold that labelling for many
    frames (BlazePose on one camera of the real recording, docs/pose-in-fisheye.md); the camera
    then contradicts the others on every limb, its torso rays miss theirs and the association
    rejects the pair, so the person is left with one camera. Here, for every two cameras, the
    people are paired on the cheaper of the two labellings (pair_costs as reported and with the
    second camera's people mirrored, within the gate, globally optimal); each pair whose cheaper
    labelling is clearly cheaper (:data:`SIDE_MARGIN`, :data:`SIDE_MIN_GAIN_M`) says whether the two detections agree or
    are crossed. Those statements, cheapest first, join the detections into groups with a known
    relative labelling (a union-find that keeps each member's parity to its root; a statement
    within a group already joined is ignored); in each group the labelling most of its members
    report is kept (on a tie, that of the detection of the first camera) and the others are
    mirrored. Two cameras that disagree are a tie: the first camera's labelling is kept, and the
    body model's check against the worker's previous fit (:func:`ergopose.recon.bodyfit.
    correct_left_right`) turns it where the previous frames say otherwise.
    """
    settings = settings or ReconSettings()
    C = len(dets)
    if C < 2:
        return list(dets)
    gate = settings.association_max_distance_m
    offset = np.concatenate([[0], np.cumsum([d.count for d in dets])]).astype(np.int64)
    mirrored = [d.with_sides_exchanged(np.ones(d.count, bool)) for d in dets]
    rays = [(d.world_rays(), d.centres_world()) for d in dets]
    rays_m = [(r[:, MIRROR], o) for r, o in rays]
    edges = []  # (cost, node a, node b, crossed)
    for a in range(C):
        for b in range(a + 1, C):
            if dets[a].count == 0 or dets[b].count == 0:
                continue
            as_is = pair_costs(dets[a], dets[b], settings, (rays[a], rays[b]))
            crossed = pair_costs(dets[a], mirrored[b], settings, (rays[a], rays_m[b]))
            best = np.minimum(as_is, crossed)
            for i, j in zip(*gated_assignment(best, gate)):
                if crossed[i, j] < SIDE_MARGIN * as_is[i, j] and as_is[i, j] - crossed[i, j] >= SIDE_MIN_GAIN_M:
                    edges.append((float(best[i, j]), offset[a] + i, offset[b] + j, 1))
                elif as_is[i, j] < SIDE_MARGIN * crossed[i, j] and crossed[i, j] - as_is[i, j] >= SIDE_MIN_GAIN_M:
                    edges.append((float(best[i, j]), offset[a] + i, offset[b] + j, 0))
    if not any(e[3] for e in edges):
        return list(dets)
    n = int(offset[-1])
    parent = np.arange(n)
    parity = np.zeros(n, np.int64)  # labelling relative to the parent

    def root(x: int) -> tuple[int, int]:
        p = 0
        while parent[x] != x:
            p ^= int(parity[x])
            x = int(parent[x])
        return x, p

    for _, u, v, c in sorted(edges):
        (ru, pu), (rv, pv) = root(int(u)), root(int(v))
        if ru != rv:  # join: v's labelling is u's, crossed if c
            hi, lo = max(ru, rv), min(ru, rv)
            parent[hi] = lo
            parity[hi] = pu ^ pv ^ c
    roots, par = zip(*(root(x) for x in range(n)))
    roots_a, par_a = np.array(roots), np.array(par)
    flip = np.zeros(n, bool)
    for r in np.unique(roots_a):
        members = np.flatnonzero(roots_a == r)
        ones = int(par_a[members].sum())
        # The root is the group's lowest node, i.e. its detection of the first camera.
        keep = 1 if ones * 2 > len(members) else 0
        flip[members] = par_a[members] != keep
    return [d.with_sides_exchanged(flip[offset[c] : offset[c + 1]]) for c, d in enumerate(dets)]


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
    return Association(
        pairs=pairs,
        cost_m=cost[pairs[:, 0], pairs[:, 1]] if len(pairs) else np.zeros(0),
        single_a=single_a,
        single_b=single_b,
        cost_matrix_m=cost,
    )


@dataclass(frozen=True)
class ViewAssociation:
    """Result of associating the people of C cameras in one frame.

    groups: (K, C) int64, one row per person seen by two or more cameras: the index of its
        detection in each camera's Detections2D, -1 where that camera is not in the set. Rows
        with more cameras come first, then in the order of the detection indices.
    cost_m: (K,) the set's cost in metres: for two cameras the pair cost (mean ray-to-ray
        distance, :func:`pair_costs`); for three or more twice the mean distance of the set's
        torso rays to their least-squares points (the same scale: two rays meeting at d lie d/2
        from their midpoint).
    singles: (S, 2) int64 rows (camera position, detection index) of the detections in no set,
        by camera, then by detection index.
    """

    groups: np.ndarray
    cost_m: np.ndarray
    singles: np.ndarray

    @property
    def n_cameras(self) -> IntArray:
        """(K,) number of cameras in each set."""
        counts: IntArray = (self.groups >= 0).sum(axis=1)
        return counts


def associate_views(dets: Sequence[Detections2D], settings: ReconSettings | None = None) -> ViewAssociation:
    """Group the people seen by C calibrated cameras in one frame (module docstring).

    dets: one Detections2D per camera (any C >= 1). Every detection ends up in exactly one set
    or single. With C = 2 the sets are the pairs of :func:`associate`.
    """
    settings = settings or ReconSettings()
    C = len(dets)
    gate = settings.association_max_distance_m
    used = [np.zeros(d.count, bool) for d in dets]
    cam_pairs = [(a, b) for a in range(C) for b in range(a + 1, C)]
    rays = [(d.world_rays(), d.centres_world()) if d.count else None for d in dets]
    costs = {(a, b): pair_costs(dets[a], dets[b], settings, (rays[a], rays[b])) for a, b in cam_pairs}
    groups: list[IntArray] = []
    group_cost: list[float] = []
    geo = _Views(dets, rays, settings) if C >= 3 else None
    if geo is not None:
        sets, set_cost = _multi_view_sets(geo, costs, settings)
        order = np.lexsort((set_cost, -(sets >= 0).sum(axis=1)))
        for h in order:
            cams = np.flatnonzero(sets[h] >= 0)
            if any(used[c][sets[h, c]] for c in cams):
                continue
            for c in cams:
                used[c][sets[h, c]] = True
            groups.append(sets[h])
            group_cost.append(float(set_cost[h]))
    while True:  # pairs among the detections left
        proposals = []
        for a, b in cam_pairs:
            cost = costs[(a, b)]
            if cost.size == 0:
                continue
            cost = np.where(used[a][:, None] | used[b][None, :], np.inf, cost)
            rows, cols = gated_assignment(cost, gate)
            proposals += [(float(cost[i, j]), a, int(i), b, int(j)) for i, j in zip(rows, cols)]
        conflict = False
        for cst, a, i, b, j in sorted(proposals):
            if used[a][i] or used[b][j]:
                conflict = True
                continue
            used[a][i] = used[b][j] = True
            row = np.full(C, -1, np.int64)
            row[a], row[b] = i, j
            groups.append(row)
            group_cost.append(cst)
        if not conflict:
            break
    if geo is not None:
        groups, group_cost = _merge_sets(groups, group_cost, used, geo, costs, settings)
        used = [np.zeros(d.count, bool) for d in dets]
        for g in groups:
            for c in np.flatnonzero(g >= 0):
                used[c][g[c]] = True
    if groups:
        g = np.stack(groups)
        order = np.lexsort(tuple(g[:, c] for c in range(C - 1, -1, -1)) + (-(g >= 0).sum(axis=1),))
        g, set_cost = g[order], np.array(group_cost)[order]
    else:
        g, set_cost = np.zeros((0, C), np.int64), np.zeros(0)
    singles = [(c, i) for c in range(C) for i in np.flatnonzero(~used[c])]
    return ViewAssociation(groups=g, cost_m=set_cost, singles=np.array(singles, np.int64).reshape(-1, 2))


class _Views:
    """The rays of every detection of every camera, padded with one empty slot per camera so
    that index -1 means "not in the set": S (C, N+1, J) seen with min_confidence, R (C, N+1, J,
    3) unit world rays, O (C, N+1, 3) centres."""

    def __init__(
        self, dets: Sequence[Detections2D], rays: Sequence[CameraRays | None], settings: ReconSettings
    ) -> None:
        C = len(dets)
        self.counts = [d.count for d in dets]
        n = max(self.counts)
        self.S = np.zeros((C, n + 1, NUM_JOINTS), bool)
        self.R = np.full((C, n + 1, NUM_JOINTS, 3), np.nan)
        self.O = np.full((C, n + 1, 3), np.nan)
        min_conf = max(settings.min_confidence, 1e-12)
        for c, d in enumerate(dets):
            if d.count:
                self.S[c, : d.count] = d.confidence >= min_conf
                # a camera with detections has its rays (None only for a camera without)
                self.R[c, : d.count], self.O[c, : d.count] = cast(CameraRays, rays[c])
        self.cam = np.arange(C)[None, :]

    def check(self, mem: np.ndarray, settings: ReconSettings) -> tuple[np.ndarray, np.ndarray]:
        """Triangulate sets (H, C) from all their views (least-squares point of the rays).

        Returns (view_dist (H, C): each member view's mean distance to the points (the rule of
        pair_costs: torso joints, else all its triangulated joints, at least 3), +inf where it
        has too few joints or a point lies behind it, NaN for non-members; plausible (H,): the
        torso's height and trunk length pass the checks of a pair)."""
        member = mem >= 0
        tri = triangulate_midpoint(
            self.O[self.cam, mem], self.R[self.cam, mem], (member[..., None] & self.S[self.cam, mem]).astype(np.float64)
        )
        res = tri.residuals_m  # (H, C, J): +inf behind the camera, NaN where not used or no point
        view_dist, ok = _view_distance(res, ~np.isnan(res), settings)
        view_dist = np.where(member, np.where(ok, view_dist, np.inf), np.nan)
        P = tri.points
        z = P[..., TORSO_JOINTS, 2]
        with np.errstate(invalid="ignore"):
            plausible = ~np.any(np.isfinite(z) & ((z < settings.torso_min_z_m) | (z > settings.torso_max_z_m)), axis=1)
            sh = _masked_mean(P[:, SHOULDERS], np.isfinite(P[:, SHOULDERS]).all(axis=-1))
            hp = _masked_mean(P[:, HIPS], np.isfinite(P[:, HIPS]).all(axis=-1))
            trunk = np.linalg.norm(sh - hp, axis=-1)
            plausible &= ~np.isfinite(trunk) | (
                (trunk >= settings.trunk_min_length_m) & (trunk <= settings.trunk_max_length_m)
            )
        return view_dist, plausible


def _set_cost(view_dist: np.ndarray) -> FloatArray:
    """Twice the mean over the member views of their distance (the scale of a pair's cost)."""
    member = ~np.isnan(view_dist)
    cost: FloatArray = 2.0 * np.where(member, view_dist, 0.0).sum(axis=1) / np.maximum(member.sum(axis=1), 1)
    return cost


def _multi_view_sets(
    geo: _Views, costs: Mapping[tuple[int, int], FloatArray], settings: ReconSettings
) -> tuple[np.ndarray, np.ndarray]:
    """Hypotheses of three or more views, one per candidate pair (module docstring).

    Returns (sets (H, C) int64 with -1 for cameras not in the set, cost (H,)); only sets of at
    least three cameras that pass the checks.
    """
    C = len(geo.counts)
    gate = settings.association_max_distance_m
    empty = (np.zeros((0, C), np.int64), np.zeros(0))
    seeds = []
    for (a, b), cost in costs.items():
        ii, jj = np.nonzero(cost <= gate)
        if len(ii):
            m = np.full((len(ii), C), -1, np.int64)
            m[:, a], m[:, b] = ii, jj
            seeds.append(m)
    if not seeds:
        return empty
    mem = np.concatenate(seeds)
    H = len(mem)
    cam, S, R, O = geo.cam, geo.S, geo.R, geo.O
    seed_cam = mem >= 0
    X = triangulate_midpoint(O[cam, mem], R[cam, mem], (S[cam, mem] & seed_cam[..., None]).astype(np.float64)).points
    fin = np.isfinite(X).all(axis=-1)  # (H, J) joints both seed views saw
    # Each other camera adds the detection whose rays pass closest to the seed's points (over
    # the torso joints it sees, else over all joints it sees, as pair_costs does).
    for c in range(C):
        n = geo.counts[c]
        if n == 0:
            continue
        d = R[c, :n][None]  # (1, n, J, 3)
        v = X[:, None] - O[c, :n][None, :, None, :]  # (H, n, J, 3)
        with np.errstate(invalid="ignore"):
            t = np.einsum("hnjk,hnjk->hnj", v, d)
            perp = np.linalg.norm(v - t[..., None] * d, axis=-1)
        dist, ok = _view_distance(perp, fin[:, None, :] & S[c, :n][None], settings)
        with np.errstate(invalid="ignore"):
            ok &= ~np.any(fin[:, None, :] & S[c, :n][None] & ~(t > 0), axis=-1) & ~seed_cam[:, c, None]
        dist = np.where(ok, dist, np.inf)
        k = np.argmin(dist, axis=1)
        add = dist[np.arange(H), k] <= gate
        mem[add, c] = k[add]
    grown = (mem >= 0).sum(axis=1) >= 3
    if not grown.any():
        return empty
    mem, seed_cam = mem[grown], seed_cam[grown]
    # Seeds of one person (every pair of its cameras) usually grow into the same set.
    mem, first = np.unique(mem, axis=0, return_index=True)
    seed_cam = seed_cam[first]
    # Triangulate from all the views; drop the added view farthest beyond the gate, then again
    # (at most C - 2 drops, so the last round always ends the loop).
    for _ in range(C - 1):
        view_dist, plausible = geo.check(mem, settings)
        bad = ~seed_cam & (mem >= 0) & ~(view_dist <= gate)
        if not bad.any():
            break
        rows = np.flatnonzero(bad.any(axis=1))
        worst = np.argmax(np.where(bad, np.minimum(view_dist, 1e300), -1.0), axis=1)[rows]
        mem[rows, worst] = -1
    member = mem >= 0
    keep = (member.sum(axis=1) >= 3) & plausible & np.all(~member | (view_dist <= gate), axis=1)
    return mem[keep], _set_cost(view_dist)[keep]


def _merge_sets(
    groups: list[IntArray],
    group_cost: list[float],
    used: Sequence[BoolArray],
    geo: _Views,
    costs: Mapping[tuple[int, int], FloatArray],
    settings: ReconSettings,
) -> tuple[list[IntArray], list[float]]:
    """Join sets (and single detections) of disjoint cameras that are one person.

    The seeds of :func:`_multi_view_sets` only grow with a camera that sees enough of the joints
    both seed views saw; with a hidden torso a person can end up as two pairs, e.g. cameras
    (2, 3) and (1, 4). Two sets with no camera in common, linked by at least one candidate pair
    within the gate, are joined when every view of the union lies within the gate of the union's
    points and the union passes the plausibility checks; the lowest cost first, in rounds until
    nothing joins. Returns the new (groups, group_cost).
    """
    C = len(geo.counts)
    gate = settings.association_max_distance_m
    mem = [np.asarray(g) for g in groups]
    cost = list(group_cost)
    for c in range(C):
        for i in np.flatnonzero(~used[c]):
            row = np.full(C, -1, np.int64)
            row[c] = i
            mem.append(row)
            cost.append(np.nan)
    if len(mem) < 2:
        return groups, group_cost
    # Global detection numbers and the candidate-pair links between them.
    offset = np.concatenate([[0], np.cumsum(geo.counts)])
    link = np.zeros((offset[-1], offset[-1]), bool)
    for (a, b), cst in costs.items():
        if cst.size:
            link[offset[a] : offset[a + 1], offset[b] : offset[b + 1]] = cst <= gate
    link |= link.T
    while len(mem) >= 2:
        M = np.stack(mem)
        inside = np.zeros((len(M), offset[-1]), bool)
        r, col = np.nonzero(M >= 0)
        inside[r, offset[col] + M[r, col]] = True
        linked = (inside.astype(np.int64) @ link.astype(np.int64) @ inside.T.astype(np.int64)) > 0
        disjoint = ((M >= 0).astype(np.int64) @ (M >= 0).T.astype(np.int64)) == 0
        s, t = np.nonzero(np.triu(linked & disjoint, 1))
        if not len(s):
            break
        union = np.maximum(M[s], M[t])
        view_dist, plausible = geo.check(union, settings)
        ok = plausible & np.all(np.isnan(view_dist) | (view_dist <= gate), axis=1)
        if not ok.any():
            break
        ucost = _set_cost(view_dist)
        taken = np.zeros(len(M), bool)
        new_mem, new_cost = [], []
        for k in np.flatnonzero(ok)[np.argsort(ucost[ok], kind="stable")]:
            if taken[s[k]] or taken[t[k]]:
                continue
            taken[s[k]] = taken[t[k]] = True
            new_mem.append(union[k])
            new_cost.append(float(ucost[k]))
        mem = [m for m, x in zip(mem, taken) if not x] + new_mem
        cost = [q for q, x in zip(cost, taken) if not x] + new_cost
    keep = [k for k, m in enumerate(mem) if (m >= 0).sum() >= 2]
    return [mem[k] for k in keep], [cost[k] for k in keep]


def _view_distance(dist: np.ndarray, valid: np.ndarray, settings: ReconSettings) -> tuple[np.ndarray, np.ndarray]:
    """Mean over joints (last axis) of distances, the rule of pair_costs: the torso joints
    among ``valid`` when there are at least association_min_joints of them, else all valid
    joints (at least 3). Returns (mean distance, enough joints); inf propagates (behind)."""
    torso = np.zeros(NUM_JOINTS, bool)
    torso[TORSO_JOINTS] = True
    vt = valid & torso
    by_torso = vt.sum(axis=-1) >= settings.association_min_joints
    use = np.where(by_torso[..., None], vt, valid)
    n = use.sum(axis=-1)
    with np.errstate(invalid="ignore"):
        mean = np.where(use, dist, 0.0).sum(axis=-1) / np.maximum(n, 1)
    return mean, by_torso | (n >= 3)
