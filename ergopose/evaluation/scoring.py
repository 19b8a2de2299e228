"""Joint angles and scores against the ground truth: the per-worker steps CSV files read back,
the angle errors, and the agreement of RULA and REBA with the scores of the true angles (Cohen's
kappa, exact and within-one agreement, band edges).
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from ergopose.ergonomics.angles import joint_angles
from ergopose.ergonomics.uncertainty import CONFIDENT_P
from ergopose.ergonomics.posture import ANGLE_COLUMNS
from ergopose.ergonomics.scoring import score_posture
from ergopose.errors import InputError
from ergopose.evaluation.agreement import confusion_matrix, exact_agreement, kappa_from_matrix, within_one
from ergopose.evaluation.loading import EvaluationInputs, ResultsLayout, round_or_nan
from ergopose.recon.diagnostics import REGIONS, lens_region
from ergopose.recon.records import TORSO_JOINTS
from ergopose.recon.track_records import identity_name

#: The score columns compared and their scales (docs/csv-columns.md).
SCORE_SCALES: dict[str, tuple[int, ...]] = {
    "rula_grand": tuple(range(1, 8)),
    "rula_action_level": tuple(range(1, 5)),
    "reba_score": tuple(range(1, 16)),
    "reba_risk_level": tuple(range(0, 5)),
}


#: A true score is "on a band edge" when moving every true angle by this much (radians, either
#: way) changes it: the simulator builds some postures exactly on scoring limits (a walking arm
#: swing of exactly 20 degrees), where a reconstruction off by 1e-7 rad already flips the band.
EDGE_NUDGE_RAD = 1e-6

#: The angles of each body part (ANGLE_COLUMNS), for the agreement expected with one part exact.
BODY_PART_ANGLES: dict[str, tuple[str, ...]] = {
    "trunk": ("trunk_flexion", "trunk_side_bend", "trunk_twist"),
    "neck": ("neck_flexion", "neck_side_bend", "neck_twist"),
    "upper_arms": tuple(
        f"{side}_{a}"
        for side in ("left", "right")
        for a in ("upper_arm_flexion", "upper_arm_abduction", "upper_arm_elevation", "shoulder_elevation")
    ),
    "elbows": ("left_elbow_flexion", "right_elbow_flexion"),
    "wrists": tuple(f"{side}_wrist_{a}" for side in ("left", "right") for a in ("flexion", "deviation")),
    "knees": ("left_knee_flexion", "right_knee_flexion"),
}

#: How many time shifts of the run's own angle errors give the expected exact agreement (the
#: errors moved by 1/4, 2/4 and 3/4 of the shift with 3).
EXPECTED_SHIFTS = 3

#: Bin edges of a frame's reported score probability (the steps CSV's ``rula_grand_p`` and
#: ``reba_score_p``) for the reliability table; the last bin includes 1.
PROBABILITY_BINS: tuple[float, ...] = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)


def probability_reliability(probability: np.ndarray, measured: np.ndarray, truth: np.ndarray) -> dict[str, Any]:
    """How well a score's reported probability predicts that it is the true score.

    probability: (n,) the reported probability of each frame's score (the share of the uncertainty
    draws that give it, ergopose.ergonomics.uncertainty); measured, truth: (n,) the reported and the
    true score. Frames where any of the three is missing are left out. Per bin of PROBABILITY_BINS:
    frames, their mean reported probability and their exact agreement (%). ``calibration_gap_pp``: the
    frame-weighted mean over the bins of |exact agreement - mean probability| in percentage points (0:
    a frame reported at p agrees with the truth a share p of the time). ``confident`` / ``others``: the
    exact agreement of the frames at or above CONFIDENT_P (the steps CSV's ``confident``, as far as
    this score goes) and below it.
    """
    p = np.asarray(probability, dtype=np.float64)
    a = np.asarray(measured, dtype=np.float64)
    b = np.asarray(truth, dtype=np.float64)
    ok = np.isfinite(p) & np.isfinite(a) & np.isfinite(b)
    p, agree = p[ok], (a[ok] == b[ok]).astype(np.float64)
    edges = np.asarray(PROBABILITY_BINS)
    which = np.clip(np.searchsorted(edges, p, side="right") - 1, 0, len(edges) - 2)
    frames, mean_p, exact = [], [], []
    gap = 0.0
    for k in range(len(edges) - 1):
        sel = which == k
        n = int(sel.sum())
        frames.append(n)
        mean_p.append(round_or_nan(float(p[sel].mean()), 3) if n else float("nan"))
        exact.append(round_or_nan(100.0 * float(agree[sel].mean()), 2) if n else float("nan"))
        if n:
            gap += n * abs(float(agree[sel].mean()) - float(p[sel].mean()))
    high = p >= CONFIDENT_P

    def share(sel: np.ndarray) -> dict[str, Any]:
        n = int(sel.sum())
        return {
            "frames": n,
            "exact_agreement_pct": round_or_nan(100.0 * float(agree[sel].mean()), 2) if n else float("nan"),
        }

    return {
        "bins": [[float(lo), float(hi)] for lo, hi in zip(edges[:-1], edges[1:])],
        "frames": frames,
        "mean_probability": mean_p,
        "exact_agreement_pct": exact,
        "calibration_gap_pp": round_or_nan(100.0 * gap / len(p), 2) if len(p) else float("nan"),
        "confident": share(high),
        "others": share(~high),
    }


# --------------------------------------------------------------------------------- steps CSV files


def read_frames_csv(layout: ResultsLayout, worker: str) -> pd.DataFrame:
    """The steps CSV of ``worker`` in the results (InputError naming the file when it is missing or
    unreadable)."""
    path = layout.frames_csv(worker)
    if not path.is_file():
        raise InputError(f"the steps CSV of {worker} is missing (the tracks table has this worker)", path=path)
    try:
        frame = pd.read_csv(path, low_memory=False)
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read the steps CSV ({exc})", path=path) from None
    for col in ("frame",) + tuple(SCORE_SCALES):
        if col not in frame.columns:
            raise InputError(f"column {col!r} is missing (docs/csv-columns.md)", path=path)
    return frame


def worker_frames(
    inp: EvaluationInputs, layout: ResultsLayout, person: np.ndarray
) -> dict[int, tuple[pd.DataFrame, np.ndarray]]:
    """{worker: (steps CSV, (rows,) simulated worker each CSV row is matched to, -1 for none)} for
    every tracked worker matched to a simulated worker in at least one frame."""
    tf = inp.tracks
    out = {}
    for w in np.unique(tf.worker[person >= 0]):
        w = int(w)
        csv = read_frames_csv(layout, inp.reported[identity_name(w)])
        sel = tf.worker == w
        frames, people = tf.frame[sel], person[sel]
        f = csv["frame"].to_numpy(np.int64)
        pos = np.clip(np.searchsorted(frames, f), 0, len(frames) - 1)
        out[w] = (csv, np.where(frames[pos] == f, people[pos], -1))
    return out


def _region_of_rows(inp: EvaluationInputs, w: int, frames: np.ndarray) -> np.ndarray:
    """Lens region of a tracked worker's rows at the given frames: the torso joints' largest angle."""
    r = inp.tracks.worker_rows(w)
    frames = np.asarray(frames, np.int64)
    if not len(r):
        return np.full(len(frames), -1, np.int8)
    pos = np.clip(np.searchsorted(r.frame, frames), 0, len(r) - 1)
    k = np.where(r.frame[pos] == frames, pos, -1)
    ang = np.full(len(frames), np.nan)
    ok = k >= 0
    if ok.any():
        a = r.lens_angle_deg[k[ok]][:, TORSO_JOINTS]
        with np.errstate(all="ignore"):
            ang[ok] = np.where(
                np.isfinite(a).any(axis=1), np.nanmax(np.where(np.isfinite(a), a, -np.inf), axis=1), np.nan
            )
    return lens_region(ang, inp.recon.lens_region_limits_deg)


# ------------------------------------------------------------------------------------------ angles


def _built_angles(gt, columns: Sequence[str]) -> dict[str, np.ndarray]:
    """{angle: (F, P) radians} from ground_truth/postures.parquet (NaN where a row is missing)."""
    post = gt.postures
    F, P = gt.n_frames, len(gt.worker_ids)
    index = {wid: k for k, wid in enumerate(gt.worker_ids)}
    p = np.array([index.get(str(w), -1) for w in post["worker"].astype(str)], dtype=np.int64)
    f = post["frame"].to_numpy(np.int64)
    ok = (p >= 0) & (f >= 0) & (f < F)
    out = {}
    for c in columns:
        a = np.full((F, P), np.nan)
        a[f[ok], p[ok]] = post[c].to_numpy(np.float64)[ok]
        out[c] = a
    return out


def angles_section(inp: EvaluationInputs, csvs: Mapping[int, tuple[pd.DataFrame, np.ndarray]]) -> dict:
    """Tracked posture angles (steps CSV, degrees) against the angles the motion was built from."""
    gt = inp.gt
    columns = [c for c in ANGLE_COLUMNS if c in gt.postures.columns]
    built = _built_angles(gt, columns)
    diffs: dict[str, list[np.ndarray]] = {c: [] for c in columns}
    sds: dict[str, list[np.ndarray]] = {c: [] for c in columns}
    regions: list[np.ndarray] = []
    rows = unmatched = 0
    for w, (csv, people) in csvs.items():
        ok = people >= 0
        unmatched += int((~ok).sum())
        frames, people = csv["frame"].to_numpy(np.int64)[ok], people[ok]
        rows += len(frames)
        regions.append(_region_of_rows(inp, w, frames))
        for c in columns:
            sds[c].append(reported_sd(csv, c)[ok])
            if c not in csv.columns:
                diffs[c].append(np.full(len(frames), np.nan))
                continue
            measured = pd.to_numeric(csv[c], errors="coerce").to_numpy(np.float64)[ok]
            true = np.degrees(built[c][frames, people])
            diffs[c].append((measured - true + 180.0) % 360.0 - 180.0)
    reg = np.concatenate(regions) if regions else np.zeros(0, np.int8)
    per_angle = {}
    pooled = []
    for c in columns:
        d = np.concatenate(diffs[c]) if diffs[c] else np.zeros(0)
        row = angle_stats(d, np.concatenate(sds[c]) if sds[c] else np.zeros(0))
        row["rmse_by_region_deg"] = {rg: angle_stats(d[reg == k])["rmse_deg"] for k, rg in enumerate(REGIONS)}
        per_angle[c] = row
        pooled.append(d[np.isfinite(d)])
    allv = np.concatenate(pooled) if pooled else np.zeros(0)
    return {
        "definition": (
            "steps CSV angle (degrees, 2 decimals) minus the angle the simulated motion was built from "
            "(ground_truth/postures.parquet) of the simulated worker the row is matched to in that "
            "frame; differences wrapped to [-180, 180); angles NaN in the CSV (not measured) are counted "
            "as missing; rows matched to nobody are left out (rows_unmatched)"
        ),
        "rows_compared": int(rows),
        "rows_unmatched": int(unmatched),
        "rmse_all_deg": round_or_nan(np.sqrt(np.mean(allv * allv)), 3) if len(allv) else float("nan"),
        "by_angle": per_angle,
        "caveat": (
            "shoulder_elevation is measured against the worker's median shoulder height over the tracked "
            "frames (ergopose.ergonomics.angles), the simulator's is absolute: a constant offset between "
            "them is a definition difference, not a reconstruction error"
        ),
    }


def angle_stats(d: np.ndarray, sd: np.ndarray | None = None) -> dict:
    """Error statistics of one angle's differences ``d`` (degrees; NaN = missing): count, missing,
    RMSE, mean absolute, bias and 95th percentile of the absolute error, rounded to 3 decimals.

    sd: the standard deviations the assessment reported for the same rows (degrees, its steps
    CSV's ``<angle>_sd``), or None. Then also how well they cover the errors, over the rows with
    a difference and a positive deviation (0 is a value taken from the settings):
    ``sd_rows``, ``median_sd_deg``, ``within_one_sd_pct`` and ``within_two_sd_pct`` (68 and 95 %
    for normal errors with those deviations)."""
    n_all = len(d)
    v = d[np.isfinite(d)]
    if not len(v):
        nan = float("nan")
        out = {"n": 0, "missing": int(n_all), "rmse_deg": nan, "mae_deg": nan, "bias_deg": nan, "p95_abs_deg": nan}
    else:
        out = {
            "n": int(len(v)),
            "missing": int(n_all - len(v)),
            "rmse_deg": round_or_nan(np.sqrt(np.mean(v * v)), 3),
            "mae_deg": round_or_nan(np.abs(v).mean(), 3),
            "bias_deg": round_or_nan(v.mean(), 3),
            "p95_abs_deg": round_or_nan(np.percentile(np.abs(v), 95), 3),
        }
    if sd is not None:
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(d) & np.isfinite(sd) & (sd > 0)
        out["sd_rows"] = int(ok.sum())
        out.update(dict.fromkeys(("median_sd_deg", "within_one_sd_pct", "within_two_sd_pct"), float("nan")))
        if ok.any():
            z = np.abs(d[ok]) / sd[ok]
            out["median_sd_deg"] = round_or_nan(np.median(sd[ok]), 3)
            out["within_one_sd_pct"] = round_or_nan(100.0 * np.mean(z <= 1.0), 2)
            out["within_two_sd_pct"] = round_or_nan(100.0 * np.mean(z <= 2.0), 2)
    return out


def reported_sd(csv: pd.DataFrame, angle: str) -> np.ndarray:
    """(rows,) the standard deviation the steps CSV reports for ``angle`` (degrees, its
    ``<angle>_sd`` column; NaN where it has none)."""
    column = f"{angle}_sd"
    if column not in csv.columns:
        return np.full(len(csv), np.nan)
    values: np.ndarray = pd.to_numeric(csv[column], errors="coerce").to_numpy(np.float64)
    return values


# ------------------------------------------------------------------------------------------ scores


def ground_truth_posture(gt, worker_index: int) -> pd.DataFrame:
    """The posture table of a simulated worker from the ground truth, all frames, radians.

    Every angle column the motion was built from (ground_truth/postures.parquet) is taken as
    built; the columns the simulator does not record (stance flags, upper-arm elevation, wrist
    position from the midline) come from the true joints through
    :func:`ergopose.ergonomics.angles.joint_angles`, the same code the pipeline uses.
    """
    base = joint_angles(gt.joints_world[:, worker_index], gt.times_s).to_frame().reset_index(drop=True)
    gid = gt.worker_ids[worker_index]
    built = gt.postures[gt.postures["worker"] == gid].sort_values("frame").reset_index(drop=True)
    if len(built) != len(base) or not np.array_equal(built["frame"].to_numpy(), np.arange(len(base))):
        raise InputError(f"postures.parquet does not have one row per frame for worker {gid}", path=gt.path)
    for c in base.columns:
        if c in built.columns and c != "time_s":
            base[c] = built[c].to_numpy(np.float64)
    return base


def ground_truth_scores(
    session, gt, worker_index: int, factor_worker: str, scoring, posture: pd.DataFrame | None = None
) -> pd.DataFrame:
    """RULA and REBA of a simulated worker's true posture, one row per frame (all frames), with the
    task factors ``session.factor_table(factor_worker, times)`` and the session's scoring settings."""
    posture = ground_truth_posture(gt, worker_index) if posture is None else posture
    factors = session.factor_table(factor_worker, gt.times_s)
    table = pd.concat([posture, factors.drop(columns=[c for c in factors.columns if c in posture.columns])], axis=1)
    return score_posture(table, settings=scoring)


def _wrap_rad(angle: np.ndarray) -> np.ndarray:
    """Angles (radians) wrapped to [-pi, pi)."""
    wrapped: np.ndarray = (angle + np.pi) % (2 * np.pi) - np.pi
    return wrapped


def moved_posture(posture: pd.DataFrame, errors: np.ndarray, shift: int) -> pd.DataFrame:
    """``posture`` (radians) with each angle of ANGLE_COLUMNS plus its column of ``errors`` (F,
    len(ANGLE_COLUMNS), radians; NaN: none) rolled by ``shift`` frames, wrapped to [-pi, pi)."""
    moved = posture.copy()
    e = np.nan_to_num(np.roll(errors, shift, axis=0), nan=0.0)
    for j, c in enumerate(ANGLE_COLUMNS):
        if c in moved.columns:
            moved[c] = _wrap_rad(moved[c].to_numpy(np.float64) + e[:, j])
    return moved


def _store_errors(
    out: np.ndarray, csv: pd.DataFrame, sel: np.ndarray, frames: np.ndarray, posture: pd.DataFrame
) -> None:
    """Write the rows' angle errors (steps CSV minus the true posture, radians, wrapped to [-pi, pi))
    into ``out`` (F, len(ANGLE_COLUMNS)) at ``frames``; angles the CSV or the truth lacks stay NaN."""
    for k, c in enumerate(ANGLE_COLUMNS):
        if c not in csv.columns or c not in posture.columns:
            continue
        measured = np.radians(pd.to_numeric(csv[c], errors="coerce").to_numpy(np.float64)[sel])
        true = posture[c].to_numpy(np.float64)[frames]
        out[frames, k] = _wrap_rad(measured - true)


def _expected_agreement(
    inp: EvaluationInputs,
    postures: Mapping[int, pd.DataFrame],
    errors: Mapping[int, np.ndarray],
    compared: Sequence[tuple[int, str, np.ndarray, pd.DataFrame]],
    exact_part: str | None = None,
) -> dict[str, float]:
    """Exact agreement (%) per score of the true scores with those of the true angles plus the run's
    own angle errors shifted in time by k/(EXPECTED_SHIFTS + 1) of the shift, k = 1..EXPECTED_SHIFTS,
    over the compared frames: how much agreement angle errors of this size and persistence leave,
    wherever in the work they fall. Errors of frames without a matched row are taken as 0, and
    those of the angles of ``exact_part`` (a key of BODY_PART_ANGLES) too."""
    if exact_part is not None:
        zeroed = [j for j, c in enumerate(ANGLE_COLUMNS) if c in BODY_PART_ANGLES[exact_part]]
        errors = {p: e.copy() for p, e in errors.items()}
        for e in errors.values():
            e[:, zeroed] = 0.0
    hits: dict[str, list[np.ndarray]] = {c: [] for c in SCORE_SCALES}
    gt, session = inp.gt, inp.session
    F = gt.n_frames
    for k in range(1, EXPECTED_SHIFTS + 1):
        shift = (k * F) // (EXPECTED_SHIFTS + 1)
        moved_scores: dict[tuple[int, str], pd.DataFrame] = {}
        for p, worker, frames, truth in compared:
            if (p, worker) not in moved_scores:
                moved = moved_posture(postures[p], errors[p], shift)
                moved_scores[(p, worker)] = ground_truth_scores(session, gt, p, worker, inp.scoring, moved)
            for c in SCORE_SCALES:
                t = truth[c].to_numpy(dtype=np.float64, na_value=np.nan)[frames]
                m = moved_scores[(p, worker)][c].to_numpy(dtype=np.float64, na_value=np.nan)[frames]
                ok = np.isfinite(t) & np.isfinite(m)
                hits[c].append(t[ok] == m[ok])
    return {
        c: round_or_nan(100.0 * float(np.mean(np.concatenate(v))), 2) if v and sum(map(len, v)) else float("nan")
        for c, v in hits.items()
    }


#: The scores whose shares of a worker's time are compared (the levels a report shows).
SHARE_SCORES = ("rula_action_level", "reba_risk_level")


def _time_shares(
    by_worker: Mapping[int, Mapping[str, tuple[list[np.ndarray], list[np.ndarray]]]], worker_ids: Sequence[str]
) -> dict[str, Any]:
    """Per simulated worker and score of SHARE_SCORES: the share of its compared frames (both
    scores known) at each level, measured and true, in %, and the largest difference over the
    levels in percentage points; ``largest_difference_pp`` over every worker."""
    out: dict[str, Any] = {}
    for c in SHARE_SCORES:
        scale = SCORE_SCALES[c]
        workers: dict[str, Any] = {}
        largest = float("nan")
        for p in sorted(by_worker):
            if c not in by_worker[p]:
                continue
            a = np.concatenate(by_worker[p][c][0])
            b = np.concatenate(by_worker[p][c][1])
            ok = np.isfinite(a) & np.isfinite(b)
            n = int(ok.sum())
            if n == 0:
                continue
            measured = [100.0 * float(np.mean(a[ok] == v)) for v in scale]
            true = [100.0 * float(np.mean(b[ok] == v)) for v in scale]
            diff = max(abs(x - y) for x, y in zip(measured, true))
            workers[worker_ids[p]] = {
                "frames": n,
                "measured_pct": [round(x, 2) for x in measured],
                "true_pct": [round(x, 2) for x in true],
                "largest_difference_pp": round(diff, 2),
            }
            largest = diff if not np.isfinite(largest) else max(largest, diff)
        out[c] = {"levels": list(scale), "by_worker": workers, "largest_difference_pp": round_or_nan(largest, 2)}
    return out


def scores_section(inp: EvaluationInputs, csvs: Mapping[int, tuple[pd.DataFrame, np.ndarray]]) -> dict:
    gt, session = inp.gt, inp.session
    postures: dict[int, pd.DataFrame] = {}
    scored: dict[tuple[int, int], tuple[pd.DataFrame, list[pd.DataFrame]]] = {}
    pairs: dict[str, tuple[list, list, list]] = {c: ([], [], []) for c in SCORE_SCALES}
    probabilities: dict[str, list[np.ndarray]] = {c: [] for c in SCORE_SCALES}
    regions = []

    def truth_of(p: int, worker: str):
        # The same person with the same task factors (usually every tracked id: only the defaults and
        # periods for everyone apply to worker_N) is scored once.
        factors = session.factor_table(worker, gt.times_s)
        key = (p, int(pd.util.hash_pandas_object(factors, index=False).sum()))
        if key not in scored:
            if p not in postures:
                postures[p] = ground_truth_posture(gt, p)
            truth = ground_truth_scores(session, gt, p, worker, inp.scoring, postures[p])
            # The truth's score is "on a band edge" where moving every angle by +-EDGE_NUDGE_RAD changes it.
            nudged = []
            for sign in (1.0, -1.0):
                moved = postures[p].copy()
                cols = [c for c in ANGLE_COLUMNS if c in moved.columns]
                moved[cols] = moved[cols] + sign * EDGE_NUDGE_RAD
                nudged.append(ground_truth_scores(session, gt, p, worker, inp.scoring, moved))
            scored[key] = (truth, nudged)
        return scored[key]

    errors: dict[int, np.ndarray] = {}  # simulated worker -> (F, A) angle errors of its matched rows, radians
    # (simulated worker, the id whose task factors apply, frames, true scores)
    compared: list[tuple[int, str, np.ndarray, pd.DataFrame]] = []
    # simulated worker -> score -> (measured, true) over its matched rows, for the time shares
    by_worker: dict[int, dict[str, tuple[list[np.ndarray], list[np.ndarray]]]] = {}
    for w, (csv, people_all) in csvs.items():
        for p in np.unique(people_all[people_all >= 0]):
            p = int(p)
            sel = people_all == p
            truth, nudged = truth_of(p, inp.reported[identity_name(w)])
            frames = csv["frame"].to_numpy(np.int64)[sel]
            errors.setdefault(p, np.full((gt.n_frames, len(ANGLE_COLUMNS)), np.nan))
            _store_errors(errors[p], csv, sel, frames, postures[p])
            compared.append((p, inp.reported[identity_name(w)], frames, truth))
            regions.append(_region_of_rows(inp, w, frames))
            for c in SCORE_SCALES:
                t = truth[c].to_numpy(dtype=np.float64, na_value=np.nan)
                edge = np.zeros(len(t), bool)
                for other in nudged:
                    o = other[c].to_numpy(dtype=np.float64, na_value=np.nan)
                    edge |= (o != t) & np.isfinite(o) & np.isfinite(t)
                pairs[c][0].append(pd.to_numeric(csv[c], errors="coerce").to_numpy(np.float64)[sel])
                pairs[c][1].append(t[frames])
                pairs[c][2].append(edge[frames])
                pcol = f"{c}_p"
                probabilities[c].append(
                    pd.to_numeric(csv[pcol], errors="coerce").to_numpy(np.float64)[sel]
                    if pcol in csv.columns
                    else np.full(int(sel.sum()), np.nan)
                )
                mine = by_worker.setdefault(p, {}).setdefault(c, ([], []))
                mine[0].append(pairs[c][0][-1])
                mine[1].append(t[frames])
    reg = np.concatenate(regions) if regions else np.zeros(0, np.int8)
    out: dict[str, Any] = {
        "definition": (
            "scores of the steps CSV (the pipeline's) against the scores of the ground-truth posture of "
            "the matched worker (built angles; stance flags and the other unrecorded inputs from the true "
            "joints) of the simulated worker the row is matched to in that frame, scored by "
            "ergopose.ergonomics.scoring.score_posture (over that worker's whole simulated shift) with the "
            "session's scoring settings and the task factors the pipeline applied (session.factor_table "
            "of the id the results use for the tracked "
            "worker id); frames where either score is missing are left out and counted; off_edge "
            f"repeats the agreement without the frames whose true score changes when every true angle "
            f"moves by {EDGE_NUDGE_RAD:g} rad (truth_on_band_edge); expected_exact_agreement_pct is the "
            "exact agreement of the true scores with the scores of the true angles plus this run's own "
            f"angle errors moved in time ({EXPECTED_SHIFTS} shifts spread over the shift, "
            "errors of unmatched frames 0; the other inputs true): the agreement errors of this size and "
            "persistence give wherever they fall; expected_exact_agreement_with_exact_part_pct repeats it "
            "with one body part's angle errors left out (BODY_PART_ANGLES): what that part's errors cost; "
            "time_shares: per simulated worker, the share of its compared frames at each RULA action level "
            "and REBA risk level, measured and true (what a worker's report sums up)"
        )
    }
    expected = _expected_agreement(inp, postures, errors, compared)
    with_exact = {part: _expected_agreement(inp, postures, errors, compared, part) for part in BODY_PART_ANGLES}
    for c, scale in SCORE_SCALES.items():
        a = np.concatenate(pairs[c][0]) if pairs[c][0] else np.zeros(0)
        b = np.concatenate(pairs[c][1]) if pairs[c][1] else np.zeros(0)
        edge = np.concatenate(pairs[c][2]) if pairs[c][2] else np.zeros(0, bool)
        both = np.isfinite(a) & np.isfinite(b)
        cm = confusion_matrix(a, b, scale)
        cm_off = confusion_matrix(a[~edge], b[~edge], scale)
        entry = {
            "scale": list(scale),
            "pairs": int(cm.sum()),
            "missing_tracked": int((~np.isfinite(a) & np.isfinite(b)).sum()),
            "missing_truth": int(np.isfinite(a).sum() - both.sum()),
            "exact_agreement_pct": round_or_nan(100.0 * exact_agreement(cm), 2),
            "within_one_pct": round_or_nan(100.0 * within_one(cm), 2),
            "kappa": round_or_nan(kappa_from_matrix(cm, "none"), 4),
            "kappa_linear": round_or_nan(kappa_from_matrix(cm, "linear"), 4),
            "kappa_quadratic": round_or_nan(kappa_from_matrix(cm, "quadratic"), 4),
            "mean_difference": round_or_nan(float(np.mean(a[both] - b[both])), 3) if both.any() else float("nan"),
            "confusion_matrix": {"rows": "tracked", "columns": "ground truth", "counts": cm.tolist()},
            "truth_on_band_edge": int((edge & both).sum()),
            "off_edge": {
                "pairs": int(cm_off.sum()),
                "exact_agreement_pct": round_or_nan(100.0 * exact_agreement(cm_off), 2),
                "kappa": round_or_nan(kappa_from_matrix(cm_off, "none"), 4),
                "kappa_linear": round_or_nan(kappa_from_matrix(cm_off, "linear"), 4),
            },
            "expected_exact_agreement_pct": expected[c],
            "expected_exact_agreement_with_exact_part_pct": {part: e[c] for part, e in with_exact.items()},
            "exact_agreement_by_region_pct": {
                rg: round_or_nan(100.0 * exact_agreement(confusion_matrix(a[reg == k], b[reg == k], scale)), 2)
                for k, rg in enumerate(REGIONS)
            },
        }
        probs = np.concatenate(probabilities[c]) if probabilities[c] else np.zeros(0)
        if np.isfinite(probs).any():
            entry["reported_probability"] = probability_reliability(probs, a, b)
        out[c] = entry
    out["time_shares"] = _time_shares(by_worker, [str(w) for w in gt.worker_ids])
    named = {w.worker_id for w in session.workers if w.periods or w.factors.given()}
    tracked = set(inp.reported.values())
    foreign = sorted(named - tracked)
    out["task_factor_note"] = (
        f"settings.toml gives task factors for worker ids {', '.join(foreign)} that no tracked person was named "
        "after; the pipeline did not apply them to anyone, and neither do these ground-truth scores"
        if foreign
        else ""
    )
    return out
