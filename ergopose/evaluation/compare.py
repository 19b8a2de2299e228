"""Compare an assessed simulated session with its ground truth (docs/evaluation.md).

:func:`evaluate_results` reads what ``ergopose assess`` wrote (the tracks table and the per-worker
steps CSV files, :class:`ResultsLayout`), the session and its ``ground_truth/`` folder, and returns
an :class:`Evaluation`: identity matching and switches, detection rate, 3D joint errors (MPJPE) per
joint and lens region, limb-length errors and reconstruction frequencies, joint-angle errors, the
agreement of RULA and REBA with the scores of the ground-truth angles, and the reference-bar check.

Tracked workers ("worker_1", ...) are matched to the simulated workers ("w1", ...) frame by frame:
in each frame the tracked rows and the simulated workers are paired one-to-one by the distance of
their body centres (at most 0.5 m, the default of :mod:`ergopose.recon.diagnostics`), and every
per-frame comparison (3D error, limb lengths, angles, scores) uses that pairing, so geometry is
measured apart from identity mistakes. The identities are judged separately: the mapping of each
tracked id to its most frequent partner (:func:`ergopose.recon.diagnostics.match_workers`), the
identity switches (:func:`~ergopose.recon.diagnostics.identity_switches`), and the 3D error when
every row is compared with its id's mapped worker (``by_track_identity``), which is what a report
attributing a whole track to one person would suffer.

One lens-region definition: ``lens_region_limits_deg`` of the reconstruction settings stored in
the tracks table (the regions the reconstruction's own diagnostics use). The simulator's
``LENS_REGIONS_DEG`` and the calibration check's default rings are reported beside it when they
differ.

Units: metres and radians inside; the sections of the result give millimetres (``_mm``), degrees
(``_deg``) and percentages (``_pct``) for people to read.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd
from scipy.optimize import linear_sum_assignment

from ergopose.atomic import write_text
from ergopose.calibration.check import DEFAULT_RING_BOUNDS_DEG
from ergopose.ergonomics.angles import joint_angles
from ergopose.ergonomics.export import STEPS_SUFFIX
from ergopose.ergonomics.posture import ANGLE_COLUMNS
from ergopose.ergonomics.scoring import score_posture
from ergopose.errors import InputError
from ergopose.evaluation.agreement import confusion_matrix, exact_agreement, kappa_from_matrix, within_one
from ergopose.evaluation.bar import bar_section
from ergopose.keypoints import BLAZEPOSE33, JOINT_INDEX, LIMB_INDEX, LIMBS, NUM_JOINTS
from ergopose.pipeline.names import load_names, resolve_naming
from ergopose.pipeline.stages import scoring_settings
from ergopose.progress import ProgressCallback, report
from ergopose.recon.diagnostics import (
    REGIONS,
    identity_switches,
    lens_region,
    limb_diagnostics,
    match_workers,
    region_errors,
    truth_for_workers,
)
from ergopose.recon.records import TORSO_JOINTS, body_centres
from ergopose.recon.settings import ReconSettings, from_mapping
from ergopose.recon.table import read_tracks, table_to_frames
from ergopose.recon.tracking import identity_name, limb_lengths
from ergopose.session import load_session
from ergopose.sim.ground_truth import load_ground_truth
from ergopose.sim.scene import LENS_REGIONS_DEG

#: The score columns compared and their scales (docs/csv-columns.md).
SCORE_SCALES: dict[str, tuple[int, ...]] = {
    "rula_grand": tuple(range(1, 8)),
    "rula_action_level": tuple(range(1, 5)),
    "reba_score": tuple(range(1, 16)),
    "reba_risk_level": tuple(range(0, 5)),
}
#: Body-centre distance (metres) within which a tracked row and a simulated worker are the same
#: person in a frame (the default of ergopose.recon.diagnostics.match_workers).
MATCH_DISTANCE_M = 0.5
#: A worker counts as visible in a camera when at least this many of the four torso joints
#: (shoulders, hips) are visible there (the association's association_min_joints default).
MIN_VISIBLE_TORSO = 2
#: A true score is "on a band edge" when moving every true angle by this much (radians, either
#: way) changes it: the simulator builds some postures exactly on scoring limits (a walking arm
#: swing of exactly 20 degrees), where a reconstruction off by 1e-7 rad already flips the band.
EDGE_NUDGE_RAD = 1e-6
#: An identity switch is "sustained" when the new id then holds for this long (seconds of matched
#: frames); shorter flickers happen when two simulated workers pass through each other.
SUSTAINED_SWITCH_S = 1.0
#: Limbs whose true length varies less than this (coefficient of variation) count as rigid.
RIGID_CV = 1e-3

NETWORK_SOURCE = "pose network (ergopose assess)"


@dataclass(frozen=True)
class ResultsLayout:
    """Where an assessment's outputs are.

    root: the results folder; tracks: the tracks table (Parquet); csv_dir: the per-worker steps
    CSV files (every angle and RULA/REBA step per frame; docs/csv-columns.md), named
    ``<csv_prefix><worker>_steps.csv``.
    """

    root: Path
    tracks: Path
    csv_dir: Path
    csv_prefix: str = ""

    @classmethod
    def of_assess(cls, out_dir: str | Path) -> "ResultsLayout":
        """The layout ``ergopose assess --out OUT`` writes: OUT/pipeline/tracks.parquet, OUT/csv/."""
        root = Path(out_dir)
        return cls(root=root, tracks=root / "pipeline" / "tracks.parquet", csv_dir=root / "csv")

    def frames_csv(self, worker: str) -> Path:
        return self.csv_dir / f"{self.csv_prefix}{worker}{STEPS_SUFFIX}"


@dataclass(frozen=True)
class Evaluation:
    """The outcome of :func:`evaluate_results`; every section is a JSON-ready dictionary whose keys
    docs/evaluation.md defines. ``source`` says what produced the 2D keypoints (the pose network
    or the ORACLE); ``notes`` are sentences a reader needs to interpret the figures."""

    source: str
    session: str
    results: str
    frames: int
    fps: float
    lens_regions: dict
    matching: dict
    detection: dict
    errors_3d: dict
    limbs: dict
    angles: dict
    scores: dict
    bar: dict
    oracle: dict | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict[str, Any]:
        out = {
            "format": "ergopose.evaluation", "version": 1, "source": self.source,
            "session": self.session, "results": self.results, "frames": self.frames, "fps": self.fps,
        }
        if self.oracle is not None:
            out["oracle"] = self.oracle
        out.update({"lens_regions": self.lens_regions, "matching": self.matching, "detection": self.detection,
                    "errors_3d": self.errors_3d, "limbs": self.limbs, "angles": self.angles,
                    "scores": self.scores, "bar": self.bar, "notes": list(self.notes)})
        return _json_ready(out)


def _json_ready(value: Any) -> Any:
    """NaN/inf -> None, numpy scalars -> Python, tuples -> lists (strict JSON)."""
    if isinstance(value, dict):
        return {str(k): _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return [_json_ready(v) for v in value.tolist()]
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        f = float(value)
        return f if math.isfinite(f) else None
    if isinstance(value, (np.bool_,)):
        return bool(value)
    return value


def _r(x: float, nd: int = 3) -> float:
    return round(float(x), nd) if x is not None and math.isfinite(float(x)) else float("nan")


# ------------------------------------------------------------------------------------------ inputs


@dataclass(frozen=True)
class _Inputs:
    session: Any
    gt: Any
    tracks: Any  # TrackFrames
    recon: Any  # ReconSettings
    scoring: Any  # ScoringSettings
    metadata: dict
    reported: dict  # tracked id ("worker_3") -> id the results use ("w1" when named by stature)
    identification_notes: tuple


def load_inputs(session_dir: str | Path, layout: ResultsLayout) -> _Inputs:
    """The session (headers only), its ground truth, the tracks table and the settings used."""
    session = load_session(session_dir, check_videos=False)
    if session.ground_truth_dir is None:
        raise InputError("not a simulated session: there is no ground_truth/ folder, and evaluate compares "
                         "results with the simulator's ground truth (make one with 'ergopose simulate')",
                         path=session.path)
    gt = load_ground_truth(session.ground_truth_dir)
    if tuple(gt.camera_names) != tuple(session.camera_names):
        raise InputError(f"the ground truth's cameras ({', '.join(gt.camera_names)}) differ from the session's "
                         f"({', '.join(session.camera_names)})", path=gt.path)
    if gt.n_frames != session.frame_count:
        raise InputError(f"the ground truth has {gt.n_frames} frames but the videos have {session.frame_count}",
                         path=gt.path)
    table = read_tracks(layout.tracks)
    settings = table.metadata.get("settings") or {}
    recon = from_mapping(settings, source=layout.tracks) if settings else ReconSettings()
    tracks = table_to_frames(table)
    reported, notes = reported_ids(session, tracks, table.metadata)
    return _Inputs(session=session, gt=gt, tracks=tracks, recon=recon, scoring=scoring_settings(session),
                   metadata=table.metadata, reported=reported, identification_notes=notes)


def reported_ids(session, tracks, metadata: Mapping) -> tuple[dict[str, str], tuple[str, ...]]:
    """{tracked id: the id the results use}: ``ergopose assess`` names a tracked person after the
    settings' worker whose given stature matches its measured one
    (:func:`ergopose.pipeline.identify.identify_by_stature`, on the stature estimates stored in the
    tracks table) and keeps the pseudonym otherwise, after the names of the session's names.toml
    (:mod:`ergopose.pipeline.names`); the same decision is re-made here."""
    names = [identity_name(w) for w in tracks.workers]
    workers = metadata.get("workers") or {}
    measured = {n: (workers.get(n) or {}).get("stature_estimate_m") for n in names}
    naming = resolve_naming(session, names, load_names(session.path), measured)
    return {n: naming.rename(n) for n in names}, tuple(naming.notes)


# ------------------------------------------------------------------------------------ lens regions


def lens_region_info(recon) -> tuple[dict, list[str]]:
    """The lens-region definition used (the reconstruction settings') and the others in the project."""
    used = [float(x) for x in recon.lens_region_limits_deg]
    sim = [float(LENS_REGIONS_DEG[0][2]), float(LENS_REGIONS_DEG[1][2])]
    cal = [float(x) for x in DEFAULT_RING_BOUNDS_DEG]
    info = {
        "used_limits_deg": used,
        "used_from": "lens_region_limits_deg of the reconstruction settings stored in the tracks table "
                     "(ergopose.recon.diagnostics.lens_region)",
        "rule": "central below the first limit, outer up to the second, edge beyond; a 3D point's angle is the "
                "larger of its angles off the two cameras' axes",
        "simulator_limits_deg": sim,
        "calibration_check_default_limits_deg": cal,
        "agree": used == sim == cal,
    }
    notes = []
    if used != sim or used != cal:
        notes.append(f"Lens regions: the project has more than one definition -- reconstruction settings "
                     f"{used[0]:g}/{used[1]:g} deg (used here for every region figure), simulator "
                     f"LENS_REGIONS_DEG {sim[0]:g}/{sim[1]:g} deg, calibration check default "
                     f"{cal[0]:g}/{cal[1]:g} deg.")
    return info, notes


# --------------------------------------------------------------------------------- matching helpers


def _per_frame_matches(tracks, truth_points: np.ndarray, points: np.ndarray,
                       max_distance_m: float = MATCH_DISTANCE_M) -> np.ndarray:
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


def row_people(inp: _Inputs) -> np.ndarray:
    """(n,) the simulated worker each tracked row is in its frame (-1: nobody within
    MATCH_DISTANCE_M): per frame the optimal one-to-one assignment of body centres, from the final
    positions where known, else the raw triangulation (as ergopose.recon.diagnostics matches)."""
    tf = inp.tracks
    points = np.where(np.isfinite(tf.points_world), tf.points_world, tf.raw_points_world)
    return _per_frame_matches(tf, inp.gt.joints_world, points)


def matching_section(inp: _Inputs, person: np.ndarray) -> tuple[dict, dict[int, int]]:
    tf, gt = inp.tracks, inp.gt
    mapping = match_workers(tf, gt.joints_world, max_distance_m=MATCH_DISTANCE_M) if len(tf) else {}
    switches = identity_switches(tf, gt.joints_world, max_distance_m=MATCH_DISTANCE_M) if len(tf) else 0
    hold = max(1, int(round(SUSTAINED_SWITCH_S * gt.fps)))
    sustained = (identity_switches(tf, gt.joints_world, max_distance_m=MATCH_DISTANCE_M, min_frames=hold)
                 if len(tf) else 0)
    per_gt = {gid: sorted((identity_name(w) for w, p in mapping.items() if p == k), key=_worker_number)
              for k, gid in enumerate(gt.worker_ids)}
    majority = np.array([mapping.get(int(w), -1) for w in tf.worker], dtype=np.int64) if len(tf) else np.zeros(0, int)
    matched = person >= 0
    section = {
        "definition": ("per frame, tracked rows and simulated workers are paired one-to-one by body-centre distance "
                       f"(at most {MATCH_DISTANCE_M} m); mapping = each tracked id's most frequent partner "
                       "(ergopose.recon.diagnostics.match_workers); identity_switches = how often a simulated "
                       "worker's partner id changes (diagnostics.identity_switches; a duplicate track of the same "
                       "person alternating with the original counts at every alternation, and so does a flicker "
                       "of one frame while two simulated workers pass through each other); "
                       "identity_switches_sustained counts only changes to an id that then holds for "
                       f"{SUSTAINED_SWITCH_S:g} s of matched frames"),
        "tracked_workers": [identity_name(w) for w in tf.workers],
        "ground_truth_workers": list(gt.worker_ids),
        "mapping": {identity_name(w): gt.worker_ids[p] for w, p in sorted(mapping.items())},
        "unmatched_tracked_workers": [identity_name(w) for w in tf.workers if w not in mapping],
        "tracked_ids_per_ground_truth_worker": per_gt,
        "identity_switches": int(switches),
        "identity_switches_sustained": int(sustained),
        "sustained_min_frames": hold,
        "reported_as": dict(inp.reported),
        "named_by_stature": _naming(inp, person),
        "rows": int(len(tf)),
        "rows_matched": int(matched.sum()),
        "rows_matched_to_another_worker_than_the_mapping": int((matched & (person != majority)).sum()),
        "match_distance_m": MATCH_DISTANCE_M,
    }
    return section, mapping


def _naming(inp: _Inputs, person: np.ndarray) -> dict:
    """How often a tracked person named after a settings worker (by stature) really is that worker:
    rows of the named ids matched, frame by frame, to the simulated worker of the same id."""
    tf, gt = inp.tracks, inp.gt
    named = {w: inp.reported[identity_name(w)] for w in tf.workers
             if inp.reported[identity_name(w)] != identity_name(w)}
    rows = correct = 0
    for w, wid in named.items():
        sel = (tf.worker == w) & (person >= 0)
        rows += int(sel.sum())
        if wid in gt.worker_ids:
            correct += int((person[sel] == gt.worker_ids.index(wid)).sum())
    return {"ids": {identity_name(w): wid for w, wid in named.items()}, "rows": rows, "rows_correct": correct,
            "correct_pct": _r(100.0 * correct / rows, 2) if rows else float("nan"),
            "notes": list(inp.identification_notes)}


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


def detection_section(inp: _Inputs) -> dict:
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
    has_raw = np.isfinite(tf.raw_points_world).all(axis=-1).any(axis=-1) if len(tf) else np.zeros(0, bool)
    regions = _regions_of_people(gt, inp.recon.lens_region_limits_deg)
    per_camera = _regions_of_people(gt, inp.recon.lens_region_limits_deg, per_camera=True)

    def rate(mask: np.ndarray) -> dict:
        n = int(mask.sum())
        k = int((mask & reconstructed).sum())
        return {"worker_frames": n, "reconstructed": k, "rate_pct": _r(100.0 * k / n, 2) if n else float("nan")}

    out = {
        "definition": (f"a worker is visible in a camera when at least {MIN_VISIBLE_TORSO} of its 4 torso joints "
                       "are visible there (ground-truth visibility code 0); a worker-frame is reconstructed when a "
                       "tracked row of that frame has a triangulated (raw) body centre within "
                       f"{MATCH_DISTANCE_M} m of the worker's true body centre (one-to-one per frame)"),
        "visible_in_both_cameras": rate(both),
        "detection_rate_pct": rate(both)["rate_pct"],
        "visible_in_one_camera": rate(one),
        "all_worker_frames": rate(np.ones((F, P), bool)),
        "by_region": {name: rate(both & (regions == k)) for k, name in enumerate(REGIONS)},
        "by_camera_region": {
            camera: {name: rate(both & (per_camera[:, c] == k)) for k, name in enumerate(REGIONS)}
            for c, camera in enumerate(inp.session.camera_names)},
        "tracked_rows": int(len(tf)),
        "tracked_rows_triangulated": int(has_raw.sum()),
        "tracked_rows_triangulated_unmatched": int((has_raw & ~hit).sum()),
    }
    return out


# ----------------------------------------------------------------------------------------- 3D errors


def truth_rows(inp: _Inputs, person: np.ndarray) -> np.ndarray:
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
    return {"points": int(len(v)), "mean_mm": _r(v.mean(), 2), "median_mm": _r(np.median(v), 2),
            "p95_mm": _r(np.percentile(v, 95), 2), "rmse_mm": _r(np.sqrt(np.mean(v * v)), 2)}


def errors_section(inp: _Inputs, person: np.ndarray, mapping: dict[int, int]) -> dict:
    tf = inp.tracks
    truth = truth_rows(inp, person)
    regions = lens_region(tf.lens_angle_deg, inp.recon.lens_region_limits_deg)
    out: dict[str, Any] = {
        "definition": ("Euclidean distance between a tracked joint and the same joint of the simulated worker the "
                       "row is matched to in that frame (MPJPE = the mean over joints with a position); 'final' are "
                       "the tracks table's positions (smoothed, gaps filled), 'raw' the triangulation; a joint's "
                       "region is that of its lens_angle_deg. by_track_identity compares every row with the "
                       "tracked id's mapped worker instead (ergopose.recon.diagnostics.region_errors), so rows "
                       "after an identity mix-up count against the wrong person, as a report would"),
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
            row["by_region_mean_mm"] = {r: _stats_mm(e[regions[:, j] == k, j])["mean_mm"]
                                        for k, r in enumerate(REGIONS)}
            section["by_joint"][name] = row
        by_id = region_errors(tf, majority, inp.recon, source=source)
        section["by_track_identity"] = {k: {"points": v.points, "mean_mm": _r(v.mean_m * 1000, 2)}
                                        for k, v in by_id.items()}
        out[source] = section
    out["mpjpe_mm"] = out["final"]["mpjpe_mm"]
    return out


# ---------------------------------------------------------------------------------------------- limbs


def limbs_section(inp: _Inputs, person: np.ndarray) -> dict:
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
            "true_mean_m": _r(np.nanmean(Lt[ok, li]), 4) if ok.any() else float("nan"),
            "measured_mean_m": _r(np.nanmean(Lm[ok, li]), 4) if ok.any() else float("nan"),
            "frequency_pct": {rg: _pct(*freq[name][rg]) for rg in ("all",) + REGIONS},
            "cv_pct": {rg: _r(100.0 * np.mean(cvs[name][rg]), 3) if cvs[name][rg] else float("nan")
                       for rg in ("all",) + REGIONS},
            "true_cv_pct": _r(100.0 * np.mean(true_cvs[name]), 3) if true_cvs[name] else float("nan"),
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
        region_summary[rg] = {"frequency_pct": _pct(sum(a for a, _ in f), sum(b for _, b in f)),
                              "cv_mean_pct": _r(100.0 * np.mean(cv), 3) if cv else float("nan"),
                              "error": _length_error(e)}
    f_all = [freq[name]["all"] for name in freq]
    rigid = [name for name in true_cvs if true_cvs[name] and max(true_cvs[name]) < RIGID_CV]
    rigid_cv = [c for name in rigid for c in cvs[name]["all"]]
    return {
        "definition": ("per tracked worker (matched in at least one frame) and limb of keypoints.LIMBS: measured "
                       "length (final positions) minus the true length of the limb of the simulated worker the row "
                       "is matched to in that frame; CV = std / mean of the worker's measured lengths "
                       "(ergopose.recon.diagnostics.limb_diagnostics), averaged over workers and limbs "
                       "(cv_mean_raw_pct: the same from the raw triangulation); true_cv_pct is the same for each "
                       "simulated worker's true lengths over the whole shift, averaged over them (the body model's "
                       "own variation: the trunk sides change with shoulder elevation); rigid limbs are those whose "
                       f"true CV is below {100 * RIGID_CV:g} %; "
                       "frequency = share of the worker's rows where both joints have a position"),
        "cv_mean_pct": _r(100.0 * np.mean(all_cv), 3) if all_cv else float("nan"),
        "cv_max_pct": _r(100.0 * np.max(all_cv), 3) if all_cv else float("nan"),
        "cv_mean_raw_pct": _r(100.0 * np.mean(raw_cvs), 3) if raw_cvs else float("nan"),
        "rigid_limbs": rigid,
        "cv_mean_rigid_pct": _r(100.0 * np.mean(rigid_cv), 3) if rigid_cv else float("nan"),
        "cv_max_rigid_pct": _r(100.0 * np.max(rigid_cv), 3) if rigid_cv else float("nan"),
        "frequency_pct": _pct(sum(a for a, _ in f_all), sum(b for _, b in f_all)),
        "error": _length_error(err[np.isfinite(err)]),
        "by_region": region_summary,
        "by_limb": per_limb,
    }


def _pct(k: int, n: int) -> float:
    return _r(100.0 * k / n, 2) if n else float("nan")


def _length_error(e: np.ndarray) -> dict:
    v = np.asarray(e, np.float64)
    v = v[np.isfinite(v)] * 1000.0
    if not len(v):
        nan = float("nan")
        return {"n": 0, "bias_mm": nan, "mae_mm": nan, "rmse_mm": nan, "p95_abs_mm": nan}
    return {"n": int(len(v)), "bias_mm": _r(v.mean(), 2), "mae_mm": _r(np.abs(v).mean(), 2),
            "rmse_mm": _r(np.sqrt(np.mean(v * v)), 2), "p95_abs_mm": _r(np.percentile(np.abs(v), 95), 2)}


# --------------------------------------------------------------------------------- steps CSV files


def _read_frames_csv(layout: ResultsLayout, worker: str) -> pd.DataFrame:
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


def _worker_frames(inp: _Inputs, layout: ResultsLayout,
                   person: np.ndarray) -> dict[int, tuple[pd.DataFrame, np.ndarray]]:
    """{worker: (steps CSV, (rows,) simulated worker each CSV row is matched to, -1 for none)} for
    every tracked worker matched to a simulated worker in at least one frame."""
    tf = inp.tracks
    out = {}
    for w in np.unique(tf.worker[person >= 0]):
        w = int(w)
        csv = _read_frames_csv(layout, inp.reported[identity_name(w)])
        sel = tf.worker == w
        frames, people = tf.frame[sel], person[sel]
        f = csv["frame"].to_numpy(np.int64)
        pos = np.clip(np.searchsorted(frames, f), 0, len(frames) - 1)
        out[w] = (csv, np.where(frames[pos] == f, people[pos], -1))
    return out


def _region_of_rows(inp: _Inputs, w: int, frames: np.ndarray) -> np.ndarray:
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
            ang[ok] = np.where(np.isfinite(a).any(axis=1), np.nanmax(np.where(np.isfinite(a), a, -np.inf), axis=1),
                               np.nan)
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


def angles_section(inp: _Inputs, csvs: Mapping[int, tuple[pd.DataFrame, np.ndarray]]) -> dict:
    """Tracked posture angles (steps CSV, degrees) against the angles the motion was built from."""
    gt = inp.gt
    columns = [c for c in ANGLE_COLUMNS if c in gt.postures.columns]
    built = _built_angles(gt, columns)
    diffs: dict[str, list[np.ndarray]] = {c: [] for c in columns}
    regions: list[np.ndarray] = []
    rows = unmatched = 0
    for w, (csv, people) in csvs.items():
        ok = people >= 0
        unmatched += int((~ok).sum())
        frames, people = csv["frame"].to_numpy(np.int64)[ok], people[ok]
        rows += len(frames)
        regions.append(_region_of_rows(inp, w, frames))
        for c in columns:
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
        row = _angle_stats(d)
        row["rmse_by_region_deg"] = {rg: _angle_stats(d[reg == k])["rmse_deg"] for k, rg in enumerate(REGIONS)}
        per_angle[c] = row
        pooled.append(d[np.isfinite(d)])
    allv = np.concatenate(pooled) if pooled else np.zeros(0)
    return {
        "definition": ("steps CSV angle (degrees, 2 decimals) minus the angle the simulated motion was built from "
                       "(ground_truth/postures.parquet) of the simulated worker the row is matched to in that "
                       "frame; differences wrapped to [-180, 180); angles NaN in the CSV (not measured) are counted "
                       "as missing; rows matched to nobody are left out (rows_unmatched)"),
        "rows_compared": int(rows),
        "rows_unmatched": int(unmatched),
        "rmse_all_deg": _r(np.sqrt(np.mean(allv * allv)), 3) if len(allv) else float("nan"),
        "by_angle": per_angle,
        "caveat": ("shoulder_elevation is measured against the worker's median shoulder height over the tracked "
                   "frames (ergopose.ergonomics.angles), the simulator's is absolute: a constant offset between "
                   "them is a definition difference, not a reconstruction error"),
    }


def _angle_stats(d: np.ndarray) -> dict:
    n_all = len(d)
    v = d[np.isfinite(d)]
    if not len(v):
        nan = float("nan")
        return {"n": 0, "missing": int(n_all), "rmse_deg": nan, "mae_deg": nan, "bias_deg": nan, "p95_abs_deg": nan}
    return {"n": int(len(v)), "missing": int(n_all - len(v)), "rmse_deg": _r(np.sqrt(np.mean(v * v)), 3),
            "mae_deg": _r(np.abs(v).mean(), 3), "bias_deg": _r(v.mean(), 3),
            "p95_abs_deg": _r(np.percentile(np.abs(v), 95), 3)}


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
        raise InputError(f"postures.parquet does not have one row per frame for worker {gid}",
                         path=gt.path)
    for c in base.columns:
        if c in built.columns and c != "time_s":
            base[c] = built[c].to_numpy(np.float64)
    return base


def ground_truth_scores(session, gt, worker_index: int, factor_worker: str, scoring,
                        posture: pd.DataFrame | None = None) -> pd.DataFrame:
    """RULA and REBA of a simulated worker's true posture, one row per frame (all frames), with the
    task factors ``session.factor_table(factor_worker, times)`` and the session's scoring settings."""
    posture = ground_truth_posture(gt, worker_index) if posture is None else posture
    factors = session.factor_table(factor_worker, gt.times_s)
    table = pd.concat([posture, factors.drop(columns=[c for c in factors.columns if c in posture.columns])], axis=1)
    return score_posture(table, settings=scoring)


def scores_section(inp: _Inputs, csvs: Mapping[int, tuple[pd.DataFrame, np.ndarray]]) -> dict:
    gt, session = inp.gt, inp.session
    postures: dict[int, pd.DataFrame] = {}
    scored: dict[tuple[int, int], tuple[pd.DataFrame, list[pd.DataFrame]]] = {}
    pairs: dict[str, tuple[list, list, list]] = {c: ([], [], []) for c in SCORE_SCALES}
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

    for w, (csv, people_all) in csvs.items():
        for p in np.unique(people_all[people_all >= 0]):
            p = int(p)
            sel = people_all == p
            truth, nudged = truth_of(p, inp.reported[identity_name(w)])
            frames = csv["frame"].to_numpy(np.int64)[sel]
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
    reg = np.concatenate(regions) if regions else np.zeros(0, np.int8)
    out: dict[str, Any] = {
        "definition": ("scores of the steps CSV (the pipeline's) against the scores of the ground-truth posture of "
                       "the matched worker (built angles; stance flags and the other unrecorded inputs from the true "
                       "joints) of the simulated worker the row is matched to in that frame, scored by "
                       "ergopose.ergonomics.scoring.score_posture (over that worker's whole simulated shift) with the "
                       "session's scoring settings and the task factors the pipeline applied (session.factor_table "
                       "of the id the results use for the tracked "
                       "worker id); frames where either score is missing are left out and counted; off_edge "
                       f"repeats the agreement without the frames whose true score changes when every true angle "
                       f"moves by {EDGE_NUDGE_RAD:g} rad (truth_on_band_edge)"),
    }
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
            "exact_agreement_pct": _r(100.0 * exact_agreement(cm), 2),
            "within_one_pct": _r(100.0 * within_one(cm), 2),
            "kappa": _r(kappa_from_matrix(cm, "none"), 4),
            "kappa_linear": _r(kappa_from_matrix(cm, "linear"), 4),
            "kappa_quadratic": _r(kappa_from_matrix(cm, "quadratic"), 4),
            "mean_difference": _r(float(np.mean(a[both] - b[both])), 3) if both.any() else float("nan"),
            "confusion_matrix": {"rows": "tracked", "columns": "ground truth", "counts": cm.tolist()},
            "truth_on_band_edge": int((edge & both).sum()),
            "off_edge": {"pairs": int(cm_off.sum()), "exact_agreement_pct": _r(100.0 * exact_agreement(cm_off), 2),
                         "kappa": _r(kappa_from_matrix(cm_off, "none"), 4),
                         "kappa_linear": _r(kappa_from_matrix(cm_off, "linear"), 4)},
            "exact_agreement_by_region_pct": {
                rg: _r(100.0 * exact_agreement(confusion_matrix(a[reg == k], b[reg == k], scale)), 2)
                for k, rg in enumerate(REGIONS)},
        }
        out[c] = entry
    named = {w.worker_id for w in session.workers if w.periods or w.factors.given()}
    tracked = set(inp.reported.values())
    foreign = sorted(named - tracked)
    out["task_factor_note"] = (
        f"settings.toml gives task factors for worker ids {', '.join(foreign)} that no tracked person was named "
        "after; the pipeline did not apply them to anyone, and neither do these ground-truth scores"
        if foreign else "")
    return out


# ---------------------------------------------------------------------------------------- evaluate


def evaluate_results(session_dir: str | Path, layout: ResultsLayout, *, source: str = NETWORK_SOURCE,
                     oracle: dict | None = None, bar_noise_px: float = 0.5, bar_draws: int = 100,
                     seed: int = 0, progress: ProgressCallback | None = None) -> Evaluation:
    """Compare the results in ``layout`` with the session's ground truth (module docstring)."""
    steps = ("inputs", "matching", "detection", "3D errors", "limbs", "angles", "scores", "reference bar")
    done = 0

    def step(msg: str) -> None:
        nonlocal done
        report(progress, "evaluation", done, len(steps), unit="step", message=msg)
        done += 1

    step("reading the session, ground truth and results")
    inp = load_inputs(session_dir, layout)
    regions, notes = lens_region_info(inp.recon)
    step("matching tracked workers to the simulated ones")
    person = row_people(inp)
    matching, mapping = matching_section(inp, person)
    step("detection rate")
    detection = detection_section(inp)
    step("3D joint errors")
    errors = errors_section(inp, person, mapping)
    step("limbs")
    limbs = limbs_section(inp, person)
    csvs = _worker_frames(inp, layout, person)
    step("joint angles")
    angles = angles_section(inp, csvs)
    step("RULA and REBA agreement")
    scores = scores_section(inp, csvs)
    step("reference bar")
    bar = bar_section(inp.session, inp.gt, inp.recon.lens_region_limits_deg, noise_px=bar_noise_px,
                      draws=bar_draws, seed=seed)
    report(progress, "evaluation", len(steps), len(steps), unit="step")
    if scores.get("task_factor_note"):
        notes.append(scores["task_factor_note"])
    if not mapping:
        notes.append("No tracked worker could be matched to a simulated worker: the per-worker sections are empty.")
    notes.append(angles["caveat"])
    return Evaluation(source=source, session=str(inp.session.path), results=str(layout.root),
                      frames=int(inp.gt.n_frames), fps=float(inp.gt.fps), lens_regions=regions, matching=matching,
                      detection=detection, errors_3d=errors, limbs=limbs, angles=angles, scores=scores, bar=bar,
                      oracle=oracle, notes=tuple(notes))


def write_json(evaluation: Evaluation, path: str | Path) -> Path:
    """The evaluation as strict JSON (NaN as null), written atomically."""
    return write_text(path, json.dumps(evaluation.to_dict(), indent=1, allow_nan=False) + "\n")


__all__ = ["ResultsLayout", "Evaluation", "evaluate_results", "write_json", "ground_truth_posture",
           "ground_truth_scores", "load_inputs", "SCORE_SCALES"]
