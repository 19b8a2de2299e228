"""Tracked rows against simulated workers: the per-frame pairing by body centres, the identity
section (mapping, switches, naming) and the detection rate per lens region and camera.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from ergopose.evaluation.loading import EvaluationInputs, round_or_nan
from ergopose.keypoints import JOINT_INDEX
from ergopose.recon.diagnostics import REGIONS, identity_switches, lens_region, match_workers
from ergopose.recon.records import TORSO_JOINTS, body_centres
from ergopose.recon.track_records import identity_name

#: Body-centre distance (metres) within which a tracked row and a simulated worker are the same
#: person in a frame (the default of ergopose.recon.diagnostics.match_workers).
MATCH_DISTANCE_M = 0.5
#: A worker counts as visible in a camera when at least this many of the four torso joints
#: (shoulders, hips) are visible there (the association's association_min_joints default).
MIN_VISIBLE_TORSO = 2
#: A tracked row near nobody (beyond MATCH_DISTANCE_M of every worker) whose body centre lies
#: within this of a worker no other row of the frame is matched to is that worker's own row,
#: placed badly; beyond it from every worker, or on a worker another row already follows, the
#: row is a false person.
MISPLACED_DISTANCE_M = 1.0


#: An identity switch is "sustained" when the new id then holds for this long (seconds of matched
#: frames); shorter flickers happen when two simulated workers pass through each other.
SUSTAINED_SWITCH_S = 1.0


# --------------------------------------------------------------------------------- matching helpers


def _per_frame_matches(
    tracks, truth_points: np.ndarray, points: np.ndarray, max_distance_m: float = MATCH_DISTANCE_M
) -> np.ndarray:
    """(n,) ground-truth person matched to each tracked row in its frame (-1: none).

    Per frame, rows and people are paired by the optimal assignment of body-centre distances
    (only pairs within ``max_distance_m``); ``points`` (n, 33, 3) gives the rows' positions.
    """
    n = len(tracks)
    out = np.full(n, -1, np.int64)
    if n == 0:
        return out
    centres = body_centres(points)  # (n, 3)
    gt_c = body_centres(truth_points)  # (F, P, 3)
    frames = tracks.frame
    ok = np.isfinite(centres).all(axis=1) & (frames >= 0) & (frames < len(gt_c))
    rows = np.flatnonzero(ok)
    if not len(rows):
        return out
    d_all = np.linalg.norm(centres[rows, None, :] - gt_c[frames[rows]], axis=-1)  # (m, P)
    d_all = np.where(np.isfinite(d_all) & (d_all <= max_distance_m), d_all, np.inf)
    order = np.argsort(frames[rows], kind="stable")
    bounds = np.flatnonzero(np.diff(frames[rows][order])) + 1
    for group in np.split(order, bounds):
        d = d_all[group]
        if not np.isfinite(d).any():
            continue
        if d.shape[0] == 1:
            j = int(np.argmin(d[0]))
            if np.isfinite(d[0, j]):
                out[rows[group[0]]] = j
            continue
        ri, ci = linear_sum_assignment(np.where(np.isfinite(d), d, 1e9))
        for a, b in zip(ri, ci):
            if np.isfinite(d[a, b]):
                out[rows[group[a]]] = int(b)
    return out


def row_people(inp: EvaluationInputs) -> np.ndarray:
    """(n,) the simulated worker each tracked row is in its frame (-1: nobody within
    MATCH_DISTANCE_M): per frame the optimal one-to-one assignment of body centres, from the final
    positions where known, else the raw triangulation (as ergopose.recon.diagnostics matches)."""
    tf = inp.tracks
    points = np.where(np.isfinite(tf.points_world), tf.points_world, tf.raw_points_world)
    return _per_frame_matches(tf, inp.gt.joints_world, points)


def matching_section(inp: EvaluationInputs, person: np.ndarray) -> tuple[dict, dict[int, int]]:
    tf, gt = inp.tracks, inp.gt
    mapping = match_workers(tf, gt.joints_world, max_distance_m=MATCH_DISTANCE_M) if len(tf) else {}
    switches = identity_switches(tf, gt.joints_world, max_distance_m=MATCH_DISTANCE_M) if len(tf) else 0
    hold = max(1, int(round(SUSTAINED_SWITCH_S * gt.fps)))
    sustained = (
        identity_switches(tf, gt.joints_world, max_distance_m=MATCH_DISTANCE_M, min_frames=hold) if len(tf) else 0
    )
    per_gt = {
        gid: sorted((identity_name(w) for w, p in mapping.items() if p == k), key=_worker_number)
        for k, gid in enumerate(gt.worker_ids)
    }
    majority = np.array([mapping.get(int(w), -1) for w in tf.worker], dtype=np.int64) if len(tf) else np.zeros(0, int)
    matched = person >= 0
    split = _rows_by_id(tf.worker, person, gt.worker_ids)
    section = {
        "definition": (
            "per frame, tracked rows and simulated workers are paired one-to-one by body-centre distance "
            f"(at most {MATCH_DISTANCE_M} m); mapping = each tracked id's most frequent partner "
            "(ergopose.recon.diagnostics.match_workers); identity_switches = how often a simulated "
            "worker's partner id changes (diagnostics.identity_switches; a duplicate track of the same "
            "person alternating with the original counts at every alternation, and so does a flicker "
            "of one frame while two simulated workers pass through each other); "
            "identity_switches_sustained counts only changes to an id that then holds for "
            f"{SUSTAINED_SWITCH_S:g} s of matched frames"
        ),
        "tracked_workers": [identity_name(w) for w in tf.workers],
        "ground_truth_workers": list(gt.worker_ids),
        "mapping": {identity_name(w): gt.worker_ids[p] for w, p in sorted(mapping.items())},
        "unmatched_tracked_workers": [identity_name(w) for w in tf.workers if w not in mapping],
        "tracked_ids_per_ground_truth_worker": per_gt,
        "identity_switches": int(switches),
        "identity_switches_sustained": int(sustained),
        "sustained_min_frames": hold,
        "reported_as": dict(inp.reported),
        "reported_workers": sorted({inp.reported[identity_name(w)] for w in tf.workers}),
        "named_by_stature": _naming(inp, person),
        "rows": int(len(tf)),
        "rows_matched": int(matched.sum()),
        "rows_matched_to_another_worker_than_the_mapping": int((matched & (person != majority)).sum()),
        "rows_by_id_per_ground_truth_worker": split,
        "rows_on_the_workers_main_id_pct": _main_id_pct(split),
        "match_distance_m": MATCH_DISTANCE_M,
    }
    return section, mapping


def _rows_by_id(worker: np.ndarray, person: np.ndarray, worker_ids: list[str]) -> dict[str, dict[str, int]]:
    """{simulated worker: {tracked id: rows of that id paired with the worker}}, most rows first: how
    a worker's time is split over ids (a worker split over two ids keeps every row in a report of
    their own; a row on an id mapped to another worker is in someone else's)."""
    out: dict[str, dict[str, int]] = {}
    for k, gid in enumerate(worker_ids):
        ids, counts = np.unique(worker[person == k], return_counts=True)
        order = np.lexsort((ids, -counts))
        out[gid] = {identity_name(int(ids[i])): int(counts[i]) for i in order}
    return out


def _main_id_pct(split: dict[str, dict[str, int]]) -> float:
    """Share (%) of the matched rows that lie on their simulated worker's main id (the id holding
    most of that worker's rows); NaN with no matched row."""
    total = sum(sum(v.values()) for v in split.values())
    main = sum(max(v.values()) for v in split.values() if v)
    return 100.0 * main / total if total else float("nan")


def _naming(inp: EvaluationInputs, person: np.ndarray) -> dict:
    """How often a tracked person named after a settings worker (by stature) really is that worker:
    rows of the named ids matched, frame by frame, to the simulated worker of the same id."""
    tf, gt = inp.tracks, inp.gt
    named = {
        w: inp.reported[identity_name(w)] for w in tf.workers if inp.reported[identity_name(w)] != identity_name(w)
    }
    rows = correct = 0
    for w, wid in named.items():
        sel = (tf.worker == w) & (person >= 0)
        rows += int(sel.sum())
        if wid in gt.worker_ids:
            correct += int((person[sel] == gt.worker_ids.index(wid)).sum())
    return {
        "ids": {identity_name(w): wid for w, wid in named.items()},
        "rows": rows,
        "rows_correct": correct,
        "correct_pct": round_or_nan(100.0 * correct / rows, 2) if rows else float("nan"),
        "notes": list(inp.identification_notes),
    }


def _worker_number(name: str) -> int:
    tail = name.rpartition("_")[2]
    return int(tail) if tail.isdigit() else 0


# ------------------------------------------------------------------------------------------ detection


def _regions_of_people(gt, limits_deg, per_camera: bool = False) -> np.ndarray:
    """(F, P) lens region of each simulated worker's mid-hip point (larger angle of the cameras);
    per_camera: (F, C, P), the region in each camera."""
    hips = [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]
    theta = np.degrees(gt.theta[..., hips].astype(np.float64).mean(axis=-1))  # (F, C, P)
    return lens_region(theta if per_camera else np.nanmax(theta, axis=1), limits_deg)


def detection_section(inp: EvaluationInputs) -> dict:
    """Detection rate and false rows (definitions in docs/evaluation.md)."""
    gt, tf = inp.gt, inp.tracks
    F, P = gt.n_frames, len(gt.worker_ids)
    torso_visible = (gt.visibility[..., TORSO_JOINTS] == 0).sum(axis=-1) >= MIN_VISIBLE_TORSO  # (F, C, P)
    both = torso_visible.all(axis=1)
    one = torso_visible.any(axis=1) & ~both
    match = _per_frame_matches(tf, gt.joints_world, tf.raw_points_world)
    reconstructed = np.zeros((F, P), bool)
    hit = match >= 0
    reconstructed[tf.frame[hit], match[hit]] = True
    # Followed: the final positions (the body model's and the smoother's, whatever the cameras saw).
    final_match = _per_frame_matches(tf, gt.joints_world, tf.points_world)
    followed = np.zeros((F, P), bool)
    followed[tf.frame[final_match >= 0], final_match[final_match >= 0]] = True
    has_raw = np.isfinite(tf.raw_points_world).all(axis=-1).any(axis=-1) if len(tf) else np.zeros(0, bool)
    has_final = np.isfinite(tf.points_world).all(axis=-1).any(axis=-1) if len(tf) else np.zeros(0, bool)
    regions = _regions_of_people(gt, inp.recon.lens_region_limits_deg)
    per_camera = _regions_of_people(gt, inp.recon.lens_region_limits_deg, per_camera=True)
    near_nobody = rows_near_nobody(tf.frame, tf.points_world, gt.joints_world, has_final & (final_match < 0), followed)

    def rate(mask: np.ndarray, found: np.ndarray = reconstructed) -> dict:
        n = int(mask.sum())
        k = int((mask & found).sum())
        return {
            "worker_frames": n,
            "reconstructed": k,
            "rate_pct": round_or_nan(100.0 * k / n, 2) if n else float("nan"),
        }

    out = {
        "definition": (
            f"a worker is visible in a camera when at least {MIN_VISIBLE_TORSO} of its 4 torso joints "
            "are visible there (ground-truth visibility code 0); a worker-frame is reconstructed when a "
            "tracked row of that frame has a triangulated (raw) body centre within "
            f"{MATCH_DISTANCE_M} m of the worker's true body centre (one-to-one per frame); followed_*: the "
            "same with the row's final body centre (body model and smoother: also the frames carried by one "
            "camera, the previous pose or a short gap), the worker-frames the assessment has a posture for"
        ),
        "visible_in_both_cameras": rate(both),
        "detection_rate_pct": rate(both)["rate_pct"],
        "visible_in_one_camera": rate(one),
        "all_worker_frames": rate(np.ones((F, P), bool)),
        "by_region": {name: rate(both & (regions == k)) for k, name in enumerate(REGIONS)},
        "followed_in_both_cameras": rate(both, followed),
        "followed_by_region": {name: rate(both & (regions == k), followed) for k, name in enumerate(REGIONS)},
        "followed_all_worker_frames": rate(np.ones((F, P), bool), followed),
        "by_camera_region": {
            camera: {name: rate(both & (per_camera[:, c] == k)) for k, name in enumerate(REGIONS)}
            for c, camera in enumerate(inp.session.camera_names)
        },
        "tracked_rows": int(len(tf)),
        "tracked_rows_triangulated": int(has_raw.sum()),
        "tracked_rows_triangulated_unmatched": int((has_raw & ~hit).sum()),
        "tracked_rows_with_a_position": int(has_final.sum()),
        "tracked_rows_with_a_position_unmatched": int((has_final & (final_match < 0)).sum()),
        "rows_near_nobody": near_nobody,
        "false_people_pct": round_or_nan(100.0 * near_nobody["false_people"] / has_final.sum(), 2)
        if has_final.any()
        else float("nan"),
    }
    return out


def rows_near_nobody(
    frames: np.ndarray, points_world: np.ndarray, truth_world: np.ndarray, near_nobody: np.ndarray, followed: np.ndarray
) -> dict:
    """What the tracked rows near nobody are (definitions in docs/evaluation.md, "Detection").

    frames: (n,) each row's frame; points_world: (n, 33, 3) the rows' final positions;
    truth_world: (F, P, 33, 3) the simulated workers' joints; near_nobody: (n,) the rows with a
    position matched to no worker; followed: (F, P) worker-frames a row is matched to.
    Each row near nobody is *far* (no worker's body centre within MISPLACED_DISTANCE_M), a
    *second row* (its nearest worker is followed by another row of the frame) or *misplaced* (the
    only row near that worker, 0.5-1 m from them). False people: far and second rows.
    """
    idx = np.flatnonzero(near_nobody)
    centres = body_centres(points_world[idx])  # (k, 3)
    truth = body_centres(truth_world[frames[idx]])  # (k, P, 3)
    with np.errstate(invalid="ignore"):
        dist = np.linalg.norm(truth - centres[:, None, :], axis=-1)  # (k, P)
    dist = np.where(np.isfinite(dist), dist, np.inf)
    nearest = np.argmin(dist, axis=1) if dist.shape[1] else np.zeros(len(idx), np.int64)
    nearest_m = dist[np.arange(len(idx)), nearest] if dist.shape[1] else np.full(len(idx), np.inf)
    far = ~(nearest_m <= MISPLACED_DISTANCE_M)
    second = ~far & followed[frames[idx], nearest]
    misplaced = ~far & ~second
    return {
        "rows": int(len(idx)),
        "far_from_every_worker": int(far.sum()),
        "second_row_on_a_followed_worker": int(second.sum()),
        "misplaced_rows_of_a_worker": int(misplaced.sum()),
        "false_people": int(far.sum() + second.sum()),
        "misplaced_distance_m": MISPLACED_DISTANCE_M,
    }
