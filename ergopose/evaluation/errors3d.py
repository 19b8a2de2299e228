"""3D geometry against the ground truth: joint errors (MPJPE) per joint and lens region, by frame
pairing and by track identity, and limb-length errors and reconstruction frequencies.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ergopose.evaluation.loading import EvaluationInputs, round_or_nan
from ergopose.keypoints import BLAZEPOSE33, LIMB_INDEX, LIMBS, NUM_JOINTS
from ergopose.recon.diagnostics import REGIONS, lens_region, limb_diagnostics, region_errors, truth_for_workers
from ergopose.recon.track_records import identity_name
from ergopose.recon.track_signatures import limb_lengths

#: Limbs whose true length varies less than this (coefficient of variation) count as rigid.
RIGID_CV = 1e-3


# ----------------------------------------------------------------------------------------- 3D errors


def truth_rows(inp: EvaluationInputs, person: np.ndarray) -> np.ndarray:
    """(n, 33, 3) true joints of the simulated worker matched to each tracked row (NaN: none)."""
    tf = inp.tracks
    out = np.full((len(tf), NUM_JOINTS, 3), np.nan)
    ok = person >= 0
    out[ok] = inp.gt.joints_world[tf.frame[ok], person[ok]]
    return out


def _stats_mm(e: np.ndarray) -> dict:
    v = e[np.isfinite(e)] * 1000.0
    if not len(v):
        nan = float("nan")
        return {"points": 0, "mean_mm": nan, "median_mm": nan, "p95_mm": nan, "rmse_mm": nan}
    return {
        "points": int(len(v)),
        "mean_mm": round_or_nan(v.mean(), 2),
        "median_mm": round_or_nan(np.median(v), 2),
        "p95_mm": round_or_nan(np.percentile(v, 95), 2),
        "rmse_mm": round_or_nan(np.sqrt(np.mean(v * v)), 2),
    }


def errors_section(inp: EvaluationInputs, person: np.ndarray, mapping: dict[int, int]) -> dict:
    tf = inp.tracks
    truth = truth_rows(inp, person)
    regions = lens_region(tf.lens_angle_deg, inp.recon.lens_region_limits_deg)
    out: dict[str, Any] = {
        "definition": (
            "Euclidean distance between a tracked joint and the same joint of the simulated worker the "
            "row is matched to in that frame (MPJPE = the mean over joints with a position); 'final' are "
            "the tracks table's positions (smoothed, gaps filled), 'raw' the triangulation; a joint's "
            "region is that of its lens_angle_deg. by_track_identity compares every row with the "
            "tracked id's mapped worker instead (ergopose.recon.diagnostics.region_errors), so rows "
            "after an identity mix-up count against the wrong person, as a report would"
        )
    }
    majority = truth_for_workers(tf, inp.gt.joints_world, mapping) if mapping else {}
    for source in ("final", "raw"):
        X = tf.points_world if source == "final" else tf.raw_points_world
        e = np.linalg.norm(X - truth, axis=-1) if len(tf) else np.zeros((0, NUM_JOINTS))
        section = {
            "by_region": {"all": _stats_mm(e)} | {r: _stats_mm(e[regions == k]) for k, r in enumerate(REGIONS)},
            "by_joint": {},
        }
        section["mpjpe_mm"] = section["by_region"]["all"]["mean_mm"]
        for j, name in enumerate(BLAZEPOSE33):
            row = _stats_mm(e[:, j])
            row["by_region_mean_mm"] = {
                r: _stats_mm(e[regions[:, j] == k, j])["mean_mm"] for k, r in enumerate(REGIONS)
            }
            section["by_joint"][name] = row
        by_id = region_errors(tf, majority, inp.recon, source=source)
        section["by_track_identity"] = {
            k: {"points": v.points, "mean_mm": round_or_nan(v.mean_m * 1000, 2)} for k, v in by_id.items()
        }
        out[source] = section
    out["mpjpe_mm"] = out["final"]["mpjpe_mm"]
    return out


# ---------------------------------------------------------------------------------------------- limbs


def limbs_section(inp: EvaluationInputs, person: np.ndarray) -> dict:
    """Limb lengths of the tracked workers (those matched to a simulated worker in at least one
    frame) against the true lengths of the matched worker in the same frames."""
    tf = inp.tracks
    T = truth_rows(inp, person)
    truth = {int(w): T[tf.worker == w] for w in np.unique(tf.worker[person >= 0])}
    diags = {d.worker: d for d in limb_diagnostics(tf, inp.recon)} if len(tf) else {}
    raw_diags = {d.worker: d for d in limb_diagnostics(tf, inp.recon, source="raw")} if len(tf) else {}
    raw_cvs: list[float] = []
    meas_all, true_all, reg_all = [], [], []
    cvs: dict[str, dict[str, list[float]]] = {name: {r: [] for r in ("all",) + REGIONS} for name, _, _ in LIMBS}
    true_cvs: dict[str, list[float]] = {name: [] for name, _, _ in LIMBS}
    freq: dict[str, dict[str, list[int]]] = {name: {r: [0, 0] for r in ("all",) + REGIONS} for name, _, _ in LIMBS}
    for w, g in truth.items():
        r = tf.worker_rows(w)
        Lm = limb_lengths(r.points_world)
        Lt = limb_lengths(g)
        ang = np.fmax(r.lens_angle_deg[:, LIMB_INDEX[:, 0]], r.lens_angle_deg[:, LIMB_INDEX[:, 1]])
        reg = lens_region(ang, inp.recon.lens_region_limits_deg)
        meas_all.append(Lm)
        true_all.append(Lt)
        reg_all.append(reg)
        d = diags[identity_name(w)]
        raw_cvs += [c for c in (raw_diags[identity_name(w)].get(name).cv for name, _, _ in LIMBS) if math.isfinite(c)]
        for li, (name, _, _) in enumerate(LIMBS):
            for region in ("all",) + REGIONS:
                s = d.get(name, region)
                if math.isfinite(s.cv):
                    cvs[name][region].append(s.cv)
                freq[name][region][0] += s.reconstructed
                freq[name][region][1] += s.frames
    # The body model's own variation: each simulated worker's true limb lengths over the whole shift.
    L_gt = limb_lengths(inp.gt.joints_world)  # (F, P, L)
    with np.errstate(invalid="ignore", divide="ignore"):
        cv_gt = np.nanstd(L_gt, axis=0) / np.nanmean(L_gt, axis=0)  # (P, L)
    for li, (name, _, _) in enumerate(LIMBS):
        true_cvs[name] = [float(v) for v in cv_gt[:, li] if np.isfinite(v)]
    L = len(LIMBS)
    Lm = np.concatenate(meas_all) if meas_all else np.zeros((0, L))
    Lt = np.concatenate(true_all) if true_all else np.zeros((0, L))
    reg = np.concatenate(reg_all) if reg_all else np.zeros((0, L), np.int8)
    err = Lm - Lt
    per_limb = {}
    for li, (name, _, _) in enumerate(LIMBS):
        e = err[:, li]
        ok = np.isfinite(e)
        row = {
            "true_mean_m": round_or_nan(np.nanmean(Lt[ok, li]), 4) if ok.any() else float("nan"),
            "measured_mean_m": round_or_nan(np.nanmean(Lm[ok, li]), 4) if ok.any() else float("nan"),
            "frequency_pct": {rg: _pct(*freq[name][rg]) for rg in ("all",) + REGIONS},
            "cv_pct": {
                rg: round_or_nan(100.0 * np.mean(cvs[name][rg]), 3) if cvs[name][rg] else float("nan")
                for rg in ("all",) + REGIONS
            },
            "true_cv_pct": round_or_nan(100.0 * np.mean(true_cvs[name]), 3) if true_cvs[name] else float("nan"),
            "error": _length_error(e),
            "error_by_region": {rg: _length_error(e[reg[:, li] == k]) for k, rg in enumerate(REGIONS)},
        }
        per_limb[name] = row
    all_cv = [c for name in cvs for c in cvs[name]["all"]]
    region_summary = {}
    for k, rg in enumerate(REGIONS):
        e = err[reg == k]
        f = [freq[name][rg] for name in freq]
        cv = [c for name in cvs for c in cvs[name][rg]]
        region_summary[rg] = {
            "frequency_pct": _pct(sum(a for a, _ in f), sum(b for _, b in f)),
            "cv_mean_pct": round_or_nan(100.0 * np.mean(cv), 3) if cv else float("nan"),
            "error": _length_error(e),
        }
    f_all = [freq[name]["all"] for name in freq]
    rigid = [name for name in true_cvs if true_cvs[name] and max(true_cvs[name]) < RIGID_CV]
    rigid_cv = [c for name in rigid for c in cvs[name]["all"]]
    return {
        "definition": (
            "per tracked worker (matched in at least one frame) and limb of keypoints.LIMBS: measured "
            "length (final positions) minus the true length of the limb of the simulated worker the row "
            "is matched to in that frame; CV = std / mean of the worker's measured lengths "
            "(ergopose.recon.diagnostics.limb_diagnostics), averaged over workers and limbs "
            "(cv_mean_raw_pct: the same from the raw triangulation); true_cv_pct is the same for each "
            "simulated worker's true lengths over the whole shift, averaged over them (the body model's "
            "own variation: the trunk sides change with shoulder elevation); rigid limbs are those whose "
            f"true CV is below {100 * RIGID_CV:g} %; "
            "frequency = share of the worker's rows where both joints have a position"
        ),
        "cv_mean_pct": round_or_nan(100.0 * np.mean(all_cv), 3) if all_cv else float("nan"),
        "cv_max_pct": round_or_nan(100.0 * np.max(all_cv), 3) if all_cv else float("nan"),
        "cv_mean_raw_pct": round_or_nan(100.0 * np.mean(raw_cvs), 3) if raw_cvs else float("nan"),
        "rigid_limbs": rigid,
        "cv_mean_rigid_pct": round_or_nan(100.0 * np.mean(rigid_cv), 3) if rigid_cv else float("nan"),
        "cv_max_rigid_pct": round_or_nan(100.0 * np.max(rigid_cv), 3) if rigid_cv else float("nan"),
        "frequency_pct": _pct(sum(a for a, _ in f_all), sum(b for _, b in f_all)),
        "error": _length_error(err[np.isfinite(err)]),
        "by_region": region_summary,
        "by_limb": per_limb,
    }


def _pct(k: int, n: int) -> float:
    return round_or_nan(100.0 * k / n, 2) if n else float("nan")


def _length_error(e: np.ndarray) -> dict:
    v = np.asarray(e, np.float64)
    v = v[np.isfinite(v)] * 1000.0
    if not len(v):
        nan = float("nan")
        return {"n": 0, "bias_mm": nan, "mae_mm": nan, "rmse_mm": nan, "p95_abs_mm": nan}
    return {
        "n": int(len(v)),
        "bias_mm": round_or_nan(v.mean(), 2),
        "mae_mm": round_or_nan(np.abs(v).mean(), 2),
        "rmse_mm": round_or_nan(np.sqrt(np.mean(v * v)), 2),
        "p95_abs_mm": round_or_nan(np.percentile(np.abs(v), 95), 2),
    }
