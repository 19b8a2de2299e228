"""Compare an assessment with a reference 3D marker recording (TRC), as a validation study against
motion capture would (docs/evaluation.md, "Against a reference recording").

Steps:

1. The TRC is read (:mod:`ergopose.evaluation.trc`, metres, Y up by convention) and its markers
   are mapped onto our BlazePose joints (:mod:`ergopose.evaluation.markers`); a file with no
   marker we know is refused.
2. Time: the reference's first sample is put at ``offset_s`` seconds of the assessment (default 0:
   the first sample is the videos' first frame, as for Pose2Sim, whose TRC frame 1 is video frame 0)
   and the reference is interpolated linearly at each assessment frame's time; assessment frames
   outside the reference's time span are left out and counted.
3. Space: either the user gives the axis order (``axes``, e.g. ``("z", "x", "y")``: world x, y, z
   are the reference's Z, X, Y; a leading ``-`` flips one) and the reference is only permuted, or
   a rigid transform without scale (Kabsch) is fitted over every pair of matched joints in the
   compared frames. Either way the residual is reported, in total and per joint (its mean offset
   vector shows where a keypoint definition differs, e.g. BlazePose's hips against OpenPose's).
4. Person: in each frame, the tracked row nearest the aligned reference (mean distance over the
   joints both have) is compared when it is within ``match_distance_m``; the first fit uses the
   tracked worker with the most frames, then selection and fit alternate until the selection is
   stable, so identity switches of the tracker do not lose frames.
5. Angles and scores: the reference joints (aligned) go through the product's own
   :func:`ergopose.ergonomics.angles.joint_angles` and
   :func:`ergopose.ergonomics.scoring.score_posture`, with the task inputs the assessment applied
   (read from its steps CSV) and the session's scoring settings when ``session_dir`` is given
   (defaults otherwise, said in the notes). The assessment's side is its steps CSV, as written.

The result is a JSON-ready dictionary in the layout of the simulated evaluation
(``angles.by_angle.NAME.mae_deg``, ``scores.rula_grand.kappa_linear``, ...) with, in addition,
``reference``, ``alignment``, ``frame_selection`` (compared and left out, by reason; ``frames`` is
the number compared) and ``definitions``: the segment lengths of both sides, and every angle and
body part compared again against the reference moved by each joint's median offset in the
person's heading frame (``definitions.without_constant_offsets``), which shows how much of a
difference a constant keypoint definition difference (BlazePose's hip against OpenPose's) explains.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from ergopose.ergonomics.angles import joint_angles, pelvis_frames
from ergopose.ergonomics.export import STEPS_SUFFIX
from ergopose.ergonomics.posture import ANGLE_COLUMNS
from ergopose.ergonomics.scoring import score_posture
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.errors import ConfigError, InputError
from ergopose.evaluation.agreement import confusion_matrix, exact_agreement, kappa_from_matrix, within_one
from ergopose.evaluation.loading import ResultsLayout, json_ready, reported_ids, round_or_nan
from ergopose.evaluation.scoring import (
    EXPECTED_SHIFTS,
    SCORE_SCALES,
    angle_stats,
    moved_posture,
    read_frames_csv,
    reported_sd,
)
from ergopose.evaluation.markers import is_surface_marker, map_markers
from ergopose.evaluation.trc import TrcData, read_trc
from ergopose.geometry.rigid import kabsch
from ergopose.keypoints import BLAZEPOSE33, JOINT_INDEX, LIMBS, NUM_JOINTS
from ergopose.pipeline.scoring import take_rows
from ergopose.pipeline.inputs import scoring_settings
from ergopose.progress import ProgressCallback, report
from ergopose.recon.table import read_tracks, table_to_frames
from ergopose.recon.track_records import identity_name
from ergopose.session import load_session

#: A tracked row and the aligned reference are the same person within this mean joint distance (m).
MATCH_DISTANCE_M = 0.5
#: Fewest joints both sides must have in a frame for it to be compared / used in the fit.
MIN_COMMON_JOINTS = 3
#: Select-and-fit rounds at most (it stops when the selection no longer changes).
MAX_ROUNDS = 5
#: Distances below this (m) never make a pair an outlier of the rigid fit (see robust_kabsch).
OUTLIER_FLOOR_M = 0.020

#: Per-body-part score columns compared besides the totals, with their scales (docs/csv-columns.md;
#: widened when the data hold values outside, e.g. the "separate" variants).
PART_SCALES: dict[str, tuple[int, int]] = {
    "left_rula_upper_arm": (1, 6),
    "right_rula_upper_arm": (1, 6),
    "left_rula_lower_arm": (1, 3),
    "right_rula_lower_arm": (1, 3),
    "left_rula_wrist": (1, 4),
    "right_rula_wrist": (1, 4),
    "rula_neck": (1, 6),
    "rula_trunk": (1, 6),
    "rula_legs": (1, 2),
    "reba_neck": (1, 3),
    "reba_trunk": (1, 5),
    "reba_legs": (1, 4),
    "left_reba_upper_arm": (1, 6),
    "right_reba_upper_arm": (1, 6),
    "left_reba_lower_arm": (1, 2),
    "right_reba_lower_arm": (1, 2),
    "left_reba_wrist": (1, 3),
    "right_reba_wrist": (1, 3),
}
#: Task inputs (not posture) the product takes from the settings; copied from the assessment's CSV.
FACTOR_COLUMNS = (
    "load_kg",
    "load_mode",
    "coupling",
    "shock",
    "arm_supported",
    "seated",
    "legs_supported",
    "wrist_twist_end_range",
)


# ------------------------------------------------------------------------------------------ geometry


def parse_axes(text: str) -> tuple[np.ndarray, str]:
    """'z,x,y' or '-x,z,y' -> (3x3 matrix M with world = M @ reference, canonical text)."""
    parts = [p.strip().lower() for p in str(text).split(",")]
    names = {"x": 0, "y": 1, "z": 2}
    m = np.zeros((3, 3))
    used = set()
    ok = len(parts) == 3
    for row, p in enumerate(parts if ok else []):
        sign = -1.0 if p.startswith("-") else 1.0
        axis = p.lstrip("+-")
        if axis not in names or axis in used:
            ok = False
            break
        used.add(axis)
        m[row, names[axis]] = sign
    if not ok:
        raise ConfigError(
            f"expected three of x, y, z, each once and optionally signed, e.g. z,x,y (world x, y, z "
            f"= reference Z, X, Y), got {text!r}",
            field="--reference-axes",
        )
    if np.linalg.det(m) < 0:
        raise ConfigError(f"{text!r} is a mirror (left-handed); flip one axis's sign", field="--reference-axes")
    return m, ",".join(parts)


def robust_kabsch(ref: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`kabsch` refitted without the outlying pairs: a pair is an outlier when its distance
    after the fit exceeds median + 3 x 1.4826 x MAD of the distances (the normal-consistent robust
    3-sigma) and 20 mm; refitted until the inliers no longer change (at most MAX_ROUNDS times).
    Keypoint definitions differ by a few centimetres everywhere, so only grossly wrong points (a
    joint on the wrong limb, a failed triangulation) are left out. Returns (R, t, inlier mask)."""
    inliers = np.ones(len(ref), bool)
    r, t = kabsch(ref, target)
    for _ in range(MAX_ROUNDS):
        d = np.linalg.norm(ref @ r.T + t - target, axis=-1)
        med = float(np.median(d[inliers]))
        limit = max(med + 3.0 * 1.4826 * float(np.median(np.abs(d[inliers] - med))), OUTLIER_FLOOR_M)
        new = d <= limit
        if new.sum() < MIN_COMMON_JOINTS or np.array_equal(new, inliers):
            break
        inliers = new
        r, t = kabsch(ref[inliers], target[inliers])
    return r, t, inliers


def _interpolate(
    times_ref: np.ndarray, points: np.ndarray, t: np.ndarray, period: float
) -> tuple[np.ndarray, np.ndarray]:
    """Reference points (F, J, 3) at times ``t``: linear between the two neighbouring samples (NaN if
    either is missing), the nearest sample within half a period outside the span. Returns (points (n,
    J, 3), inside (n,) bool)."""
    n = len(t)
    lo_edge, hi_edge = times_ref[0] - 0.5 * period, times_ref[-1] + 0.5 * period
    inside = (t >= lo_edge - 1e-9) & (t <= hi_edge + 1e-9)
    out = np.full((n,) + points.shape[1:], np.nan)
    if len(times_ref) == 1:
        out[inside] = points[0]
        return out, inside
    tc = np.clip(t, times_ref[0], times_ref[-1])
    k = np.clip(np.searchsorted(times_ref, tc, side="right") - 1, 0, len(times_ref) - 2)
    w = ((tc - times_ref[k]) / (times_ref[k + 1] - times_ref[k]))[:, None, None]
    # Exactly on a sample: that sample alone (its neighbour may be missing).
    on_lo = np.isclose(tc, times_ref[k], rtol=0, atol=1e-9)[:, None, None]
    on_hi = np.isclose(tc, times_ref[k + 1], rtol=0, atol=1e-9)[:, None, None]
    a, b = points[k], points[k + 1]
    value = np.where(on_lo, a, np.where(on_hi, b, (1 - w) * a + w * b))
    out[inside] = value[inside]
    return out, inside


# ------------------------------------------------------------------------------------------ inputs


def _reference_joints(trc: TrcData) -> tuple[np.ndarray, dict[str, str]]:
    mapping = map_markers(trc.markers)
    if not mapping:
        raise InputError(
            "no marker of this file has a counterpart among our joints (known: OpenPose BODY_25/"
            "BODY_25B, COCO, HALPE, BlazePose and Plug-in Gait style names such as LShoulder, "
            f"left_knee, LKNE); its markers: {', '.join(trc.markers[:12])}"
            f"{' ...' if len(trc.markers) > 12 else ''}",
            path=trc.path,
        )
    joints = np.full((len(trc.times_s), NUM_JOINTS, 3), np.nan)
    for marker, joint in mapping.items():
        joints[:, JOINT_INDEX[joint]] = trc.points_trc[:, trc.markers.index(marker)]
    return joints, mapping


def _frames_csvs(layout: ResultsLayout, tracks, names: Mapping[int, str] | None) -> dict[int, pd.DataFrame]:
    """{tracked worker number: its steps CSV}: by the tracked name (worker_N), by the session's
    naming (``names``), else by the unique CSV whose frames are exactly the worker's."""
    files = sorted(layout.csv_dir.glob(f"{layout.csv_prefix}*{STEPS_SUFFIX}"))
    by_frames: dict[tuple, list[str]] = {}
    cache: dict[str, pd.DataFrame] = {}
    out: dict[int, pd.DataFrame] = {}
    for w in np.unique(tracks.worker):
        w = int(w)
        name = (names or {}).get(w, identity_name(w))
        if layout.frames_csv(name).is_file():
            out[w] = cache.setdefault(name, read_frames_csv(layout, name))
            continue
        if not by_frames:
            for f in files:
                wid = f.name[len(layout.csv_prefix) : -len(STEPS_SUFFIX)]
                csv = cache.setdefault(wid, read_frames_csv(layout, wid))
                by_frames.setdefault(tuple(csv["frame"].to_numpy(np.int64)), []).append(wid)
        key = tuple(np.asarray(tracks.frame[tracks.worker == w], np.int64))
        found = by_frames.get(key, [])
        if len(found) != 1:
            raise InputError(
                f"cannot tell which steps CSV belongs to tracked {identity_name(w)} "
                f"({'none' if not found else 'several'} with its frames): give --session DIR so "
                "the names the assessment gave can be re-made",
                path=layout.csv_dir,
            )
        out[w] = cache[found[0]]
    return out


# ------------------------------------------------------------------------------------------ selection


def _mean_distance(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, J, 3) x2 -> (mean distance over joints both have, count of such joints)."""
    d = np.linalg.norm(a - b, axis=-1)
    ok = np.isfinite(d)
    count = ok.sum(axis=-1)
    with np.errstate(invalid="ignore"):
        mean = np.where(count > 0, np.where(ok, d, 0.0).sum(axis=-1) / np.maximum(count, 1), np.inf)
    return mean, count


def _select_rows(
    points: np.ndarray, frames: np.ndarray, ref_world: np.ndarray, distance_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """For each frame, the row nearest the reference (mean joint distance) if within ``distance_m``
    with >= MIN_COMMON_JOINTS joints. ref_world: (n, J, 3) the reference at each row's frame.
    Returns (selected row indices, per-row distance)."""
    dist, count = _mean_distance(points, ref_world)
    dist = np.where(count >= MIN_COMMON_JOINTS, dist, np.inf)
    order = np.lexsort((dist, frames))
    first = np.ones(len(order), bool)
    first[1:] = frames[order][1:] != frames[order][:-1]
    best = order[first]
    return best[dist[best] <= distance_m], dist


def _select_and_fit(pts, tracks, ref_at_rows, inside, rotation, translation, distance_m: float, fit: bool):
    """Alternate row selection and (when ``fit``) the Kabsch fit on the selected rows until the
    selection is stable (at most MAX_ROUNDS); returns (rotation, translation, selected rows)."""
    selected = np.zeros(0, np.int64)
    candidates = np.flatnonzero(inside)
    for _ in range(MAX_ROUNDS if fit else 1):
        ref_world = ref_at_rows[candidates] @ rotation.T + translation
        chosen, _ = _select_rows(pts[candidates], tracks.frame[candidates], ref_world, distance_m)
        chosen = np.sort(candidates[chosen])
        if np.array_equal(chosen, selected):
            break
        selected = chosen
        if fit and len(selected):
            rotation, translation, _ = robust_kabsch(*_pairs(pts[selected], ref_at_rows[selected]))
    return rotation, translation, selected


def _pairs(points: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ok = np.isfinite(points).all(-1) & np.isfinite(ref).all(-1)
    return ref[ok], points[ok]


# ------------------------------------------------------------------------------------------ evaluate


def definition_offsets(points_world: np.ndarray, ref_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How a constant difference of keypoint definitions would place the reference.

    points_world, ref_world: (n, J, 3) the compared rows of the assessment and the aligned
    reference. Returns each joint's median offset (assessment - reference) in the reference
    person's heading frame (:func:`ergopose.ergonomics.angles.pelvis_frames`; (J, 3) forward, left, up in metres, NaN where
    the joint has no pair), and the reference with those offsets added in every frame ((n, J, 3);
    a joint without an offset, or a frame without a heading, is left as it was). A difference
    that is only a constant offset of some joints in the heading frame disappears against the
    moved reference; a difference that varies from frame to frame (error) does not."""
    frames = pelvis_frames(ref_world)
    local = np.einsum("nij,nJi->nJj", frames, points_world - ref_world)
    pairs = np.isfinite(local).all(-1).any(0)
    offsets = np.full(local.shape[1:], np.nan)
    if pairs.any():
        offsets[pairs] = np.nanmedian(local[:, pairs], axis=0)
    added = np.einsum("nij,Jj->nJi", frames, np.nan_to_num(offsets))
    moved = np.where(np.isfinite(added), ref_world + added, ref_world)
    return offsets, moved


def _csv_numbers(table: pd.DataFrame, column: str) -> np.ndarray:
    """A column of the steps CSV as floats (NaN where empty; all NaN when the column is absent)."""
    if column not in table.columns:
        return np.full(len(table), np.nan)
    return pd.to_numeric(table[column], errors="coerce").to_numpy(np.float64)


def _angle_differences(ours: pd.DataFrame, posture: pd.DataFrame) -> dict[str, np.ndarray]:
    """Per angle of ``posture`` (radians): the steps CSV ``ours`` (degrees) minus it, in degrees,
    wrapped to [-180, 180)."""
    return {
        c: (_csv_numbers(ours, c) - np.degrees(posture[c].to_numpy(np.float64)) + 180.0) % 360.0 - 180.0
        for c in ANGLE_COLUMNS
        if c in posture.columns
    }


def _reference_scores(
    ref_world: np.ndarray, times: np.ndarray, factors: pd.DataFrame, scoring: ScoringSettings
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The posture (radians) and the RULA/REBA steps of the reference's joints ``ref_world``."""
    posture = joint_angles(ref_world, times if np.all(np.diff(times) > 0) else None).to_frame()
    posture = posture.reset_index(drop=True)
    inputs = factors.drop(columns=[c for c in factors.columns if c in posture.columns])
    return posture, score_posture(pd.concat([posture, inputs], axis=1), settings=scoring)


def _score_pair(assessed: pd.DataFrame, ref_scores: pd.DataFrame, c: str) -> dict:
    """Agreement of score column ``c`` between the assessment's CSV rows and the reference's steps."""
    a = _csv_numbers(assessed, c)
    b = pd.to_numeric(ref_scores[c], errors="coerce").to_numpy(np.float64)
    if c in SCORE_SCALES:
        scale = SCORE_SCALES[c]
    else:
        lo, hi = PART_SCALES[c]
        seen = np.concatenate([a[np.isfinite(a)], b[np.isfinite(b)]])
        if len(seen):
            lo, hi = min(lo, int(seen.min())), max(hi, int(seen.max()))
        scale = tuple(range(lo, hi + 1))
    return _agreement(a, b, scale)


def _without_offsets(
    points: np.ndarray,
    ref_world: np.ndarray,
    times: np.ndarray,
    factors: pd.DataFrame,
    scoring: ScoringSettings,
    assessed: pd.DataFrame,
    parts: Sequence[str],
) -> dict[str, Any]:
    """The angles' and parts' agreement against the reference moved by the constant definition
    offsets (:func:`definition_offsets`): what of each difference a constant offset explains."""
    offsets, moved = definition_offsets(points, ref_world)
    posture, scores = _reference_scores(moved, times, factors, scoring)
    angles = {}
    for c, d in _angle_differences(assessed, posture).items():
        stats = angle_stats(d)
        angles[c] = {k: stats[k] for k in ("n", "mae_deg", "bias_deg", "rmse_deg")}
    return {
        "definition": (
            "the same comparison against the reference with each joint moved by its median offset "
            "(assessment - reference) in the reference person's heading frame (forward, left, up; "
            "offsets_heading_mm): a keypoint definition difference that is a constant offset there "
            "disappears, an error that varies does not; a constant bias of the reconstruction looks the "
            "same, and a limb that moves against the heading carries its offset only roughly"
        ),
        "offsets_heading_mm": {
            BLAZEPOSE33[j]: [round_or_nan(1000 * v, 1) for v in offsets[j]]
            for j in range(len(offsets))
            if np.isfinite(offsets[j]).all()
        },
        "angles": angles,
        "parts_exact_agreement_pct": {c: _score_pair(assessed, scores, c)["exact_agreement_pct"] for c in parts},
    }


def evaluate_reference(
    results_dir: str | Path,
    reference: str | Path | TrcData,
    *,
    session_dir: str | Path | None = None,
    axes: str | None = None,
    offset_s: float = 0.0,
    worker: str | None = None,
    match_distance_m: float = MATCH_DISTANCE_M,
    layout: ResultsLayout | None = None,
    progress: ProgressCallback | None = None,
    source: str | None = None,
) -> dict[str, Any]:
    """Compare the assessment in ``results_dir`` with the reference TRC (module docstring).

    reference: a TRC file, or a reference already read or built (:class:`TrcData`, e.g. from
    :func:`ergopose.evaluation.keypoint_reference.openpose_reference`); source: what the
    reference is, written into the result (default: a TRC marker recording).
    """
    if not math.isfinite(offset_s):
        raise ConfigError(f"expected a number of seconds, got {offset_s}", field="--reference-offset")
    steps = 5
    report(progress, "evaluation", 0, steps, unit="step", message="reading the reference and the results")
    trc = reference if isinstance(reference, TrcData) else read_trc(reference)
    ref_joints, mapping = _reference_joints(trc)
    layout = layout or ResultsLayout.of_assess(results_dir)
    table = read_tracks(layout.tracks)
    tracks = table_to_frames(table)
    notes: list[str] = []
    session = None
    names = None
    scoring = ScoringSettings()
    if session_dir is not None:
        session = load_session(session_dir, check_videos=False)
        scoring = scoring_settings(session)
        reported, _ = reported_ids(session, tracks, table.metadata)
        names = {int(w): reported[identity_name(int(w))] for w in np.unique(tracks.worker)}
    else:
        notes.append(
            "No --session: the reference is scored with the default scoring settings; give the "
            "session when its settings.toml changes [scoring]."
        )
    if len(tracks) == 0:
        raise InputError("the assessment tracked nobody: nothing to compare", path=layout.tracks)
    if worker is not None:
        wanted = [w for w in np.unique(tracks.worker) if worker in (identity_name(int(w)), (names or {}).get(int(w)))]
        if not wanted:
            raise InputError(f"no tracked worker {worker!r} in the results", field="--worker", path=layout.tracks)
        keep = np.isin(tracks.worker, wanted)
        tracks = take_rows(tracks, keep)

    # --- time -------------------------------------------------------------------------------------
    period = 1.0 / trc.rate_hz
    times_ref = trc.times_s - trc.times_s[0] + offset_s
    ref_at_rows, inside = _interpolate(times_ref, ref_joints, tracks.time_s, period)
    fps = float(table.metadata.get("fps", float("nan")))
    frames_all = np.unique(tracks.frame)
    if not inside.any():
        raise InputError(
            f"the reference ({times_ref[0]:.3f}-{times_ref[-1]:.3f} s after --reference-offset {offset_s:g} s) "
            f"does not overlap the assessment's tracked frames ({tracks.time_s.min():.3f}-{tracks.time_s.max():.3f} s)",
            path=trc.path,
        )

    # --- space ------------------------------------------------------------------------------------
    report(progress, "evaluation", 1, steps, unit="step", message="aligning the reference")
    pts = tracks.points_world
    if axes is not None:
        m, canonical = parse_axes(axes)
        method = f"axis order given (--reference-axes {canonical}): world = M @ reference, no fit"
        rotation, translation, selected = _select_and_fit(
            pts, tracks, ref_at_rows, inside, m, np.zeros(3), match_distance_m, fit=False
        )
    else:
        canonical = None
        method = (
            "rigid transform without scale (Kabsch) fitted over the matched joints of the compared frames, "
            "gross outliers left out (median + 3 robust sigma, at least 20 mm)"
        )
        common = np.isfinite(ref_at_rows).all(-1) & np.isfinite(pts).all(-1)
        usable = (common.sum(-1) >= MIN_COMMON_JOINTS) & inside
        if not usable.any():
            raise InputError(
                "no tracked frame shares at least 3 joints with the reference: nothing to align", path=trc.path
            )
        # Each tracked worker in turn starts the fit (another person may be tracked longer); the start
        # that ends with the most compared frames, then the smallest residual, wins.
        best = None
        for w in np.unique(tracks.worker[usable]):
            start = usable & (tracks.worker == w)
            r0, t0, _ = robust_kabsch(*_pairs(pts[start], ref_at_rows[start]))
            r, t, sel = _select_and_fit(pts, tracks, ref_at_rows, inside, r0, t0, match_distance_m, fit=True)
            if len(sel):
                d = np.linalg.norm(pts[sel] - (ref_at_rows[sel] @ r.T + t), axis=-1)
                key = (-len(sel), float(np.sqrt(np.nanmean(d * d))))
                if best is None or key < best[0]:
                    best = (key, r, t, sel)
        if best is None:
            rotation, translation, selected = np.eye(3), np.zeros(3), np.zeros(0, np.int64)
        else:
            _, rotation, translation, selected = best
    ref_world = ref_at_rows @ rotation.T + translation
    if not len(selected):
        raise InputError(
            f"no tracked row comes within {match_distance_m:g} m of the aligned reference in any "
            "overlapping frame (wrong --reference-axes or --reference-offset?)",
            path=trc.path,
        )
    selected = selected[np.argsort(tracks.frame[selected])]

    # --- alignment residual and keypoint definitions ----------------------------------------------
    report(progress, "evaluation", 2, steps, unit="step", message="residuals and keypoint definitions")
    diff = pts[selected] - ref_world[selected]  # (n, J, 3) assessment minus reference
    dist = np.linalg.norm(diff, axis=-1)
    fin = np.isfinite(dist)
    per_joint = {}
    for j, name in enumerate(BLAZEPOSE33):
        v = fin[:, j]
        if not v.any():
            continue
        marker = next(m for m, jj in mapping.items() if jj == name)
        per_joint[name] = {
            "reference_marker": marker,
            "pairs": int(v.sum()),
            "rms_mm": round_or_nan(1000 * np.sqrt(np.mean(dist[v, j] ** 2)), 1),
            "median_mm": round_or_nan(1000 * np.median(dist[v, j]), 1),
            "mean_offset_world_mm": [round_or_nan(1000 * x, 1) for x in diff[v, j].mean(axis=0)],
            "surface_marker": is_surface_marker(marker),
        }
    if axes is None:
        _, _, inl = robust_kabsch(*_pairs(pts[selected], ref_at_rows[selected]))
        fit_pairs = int(inl.sum())
    else:
        fit_pairs = 0
    alignment = {
        "method": method,
        "fit_pairs_used": fit_pairs,
        "rotation_world_from_reference": rotation.tolist(),
        "translation_m": translation.tolist(),
        "reference_up_in_world": (rotation @ np.array([0.0, 1.0, 0.0])).tolist(),
        "pairs": int(fin.sum()),
        "residual_rms_mm": round_or_nan(1000 * np.sqrt(np.mean(dist[fin] ** 2)), 2),
        "residual_median_mm": round_or_nan(1000 * np.median(dist[fin]), 2),
        "residual_p95_mm": round_or_nan(1000 * np.percentile(dist[fin], 95), 2),
        "residual_within_50mm_pct": round_or_nan(100.0 * float(np.mean(dist[fin] <= 0.05)), 2),
        "by_joint": per_joint,
    }
    up = alignment["reference_up_in_world"]
    if up[2] < math.cos(math.radians(20)):
        notes.append(
            f"The reference's Y axis (up in a TRC) lands {math.degrees(math.acos(max(-1, min(1, up[2])))):.0f} "
            "deg from world up after alignment: check the reference's axes."
        )
    segments = {}
    for limb, joint_a, joint_b in LIMBS:
        ia, ib = JOINT_INDEX[joint_a], JOINT_INDEX[joint_b]
        la = np.linalg.norm(pts[selected, ia] - pts[selected, ib], axis=-1)
        lr = np.linalg.norm(ref_world[selected, ia] - ref_world[selected, ib], axis=-1)
        ok = np.isfinite(la) & np.isfinite(lr)
        if ok.any():
            ma, mr = float(np.median(la[ok])), float(np.median(lr[ok]))
            segments[limb] = {
                "frames": int(ok.sum()),
                "assessment_median_mm": round_or_nan(1000 * ma, 1),
                "reference_median_mm": round_or_nan(1000 * mr, 1),
                "ratio": round_or_nan(ma / mr, 3) if mr > 0 else None,
            }
    definitions = {
        "note": (
            "the assessment's keypoints (BlazePose) and the reference's markers are different definitions of "
            "the same joints; a joint's mean offset after alignment and the ratio of segment lengths measure "
            "the difference (a constant offset is definition, a scatter is error)"
        ),
        "segments": segments,
    }

    # --- angles -----------------------------------------------------------------------------------
    report(progress, "evaluation", 3, steps, unit="step", message="reference angles and scores")
    csvs = _frames_csvs(layout, tracks, names)
    rows_worker = tracks.worker[selected]
    rows_frame = tracks.frame[selected]
    assessed = []
    for w in np.unique(rows_worker):
        csv = csvs[int(w)]
        sel = rows_worker == w
        f = rows_frame[sel]
        index = pd.Index(csv["frame"].to_numpy(np.int64))
        pos = index.get_indexer(f)
        if (pos < 0).any():
            raise InputError(
                f"the steps CSV of {identity_name(int(w))} lacks frames of its track (first: {int(f[pos < 0][0])})",
                path=layout.csv_dir,
            )
        part = csv.iloc[pos].copy()
        part["_row"] = np.flatnonzero(sel)
        assessed.append(part)
    assessed_df = pd.concat(assessed).sort_values("_row").reset_index(drop=True)

    times = tracks.time_s[selected]
    factors = pd.DataFrame(index=pd.RangeIndex(len(selected)))
    for c in FACTOR_COLUMNS:
        if c in assessed_df.columns:
            if c in ("load_mode", "coupling"):
                factors[c] = assessed_df[c].astype("string").to_numpy()
            else:
                factors[c] = pd.to_numeric(assessed_df[c], errors="coerce").to_numpy(np.float64)
    posture, ref_scores = _reference_scores(ref_world[selected], times, factors, scoring)
    factors = factors.drop(columns=[c for c in factors.columns if c in posture.columns])

    by_angle = {}
    pooled = []
    differences = _angle_differences(assessed_df, posture)
    for c, d in differences.items():
        ref_deg = posture[c].to_numpy(np.float64)
        row = angle_stats(d, reported_sd(assessed_df, c))
        row["missing_assessment"] = int((~np.isfinite(_csv_numbers(assessed_df, c))).sum())
        row["missing_reference"] = int((~np.isfinite(ref_deg)).sum())
        if row["missing_reference"] == len(ref_deg):
            row["why_missing"] = "the reference's markers do not define this angle (no counterpart of a joint it needs)"
        by_angle[c] = row
        pooled.append(d[np.isfinite(d)])
    allv = np.concatenate(pooled) if pooled else np.zeros(0)
    angles = {
        "definition": (
            "steps CSV angle (degrees) minus the same angle computed by ergopose.ergonomics.angles from "
            "the aligned reference markers at the same frame; wrapped to [-180, 180); frames where either "
            "is not measured are counted as missing (missing_assessment, missing_reference)"
        ),
        "rows_compared": int(len(selected)),
        "rmse_all_deg": round_or_nan(np.sqrt(np.mean(allv * allv)), 3) if len(allv) else float("nan"),
        "by_angle": by_angle,
    }

    # --- scores -----------------------------------------------------------------------------------
    report(progress, "evaluation", 4, steps, unit="step", message="agreement")
    scores: dict[str, Any] = {
        "definition": (
            "scores of the steps CSV against the scores of the reference's angles by "
            "ergopose.ergonomics.scoring.score_posture with the task inputs the assessment applied (its "
            "CSV) and the scoring settings named in settings_source; per-part columns are the RULA/REBA "
            "step scores of docs/csv-columns.md"
        ),
        "settings_source": str(session.settings_path) if session is not None else "defaults (no --session)",
    }
    compared_scores = [c for c in list(SCORE_SCALES) + list(PART_SCALES) if c in ref_scores.columns]
    expected = expected_reference_agreement(posture, factors, differences, ref_scores, compared_scores, scoring)
    for c in compared_scores:
        scores[c] = _score_pair(assessed_df, ref_scores, c)
        scores[c]["expected_exact_agreement_pct"] = expected[c]
    scores["expected_definition"] = (
        "expected_exact_agreement_pct: exact agreement of the reference's scores with those of the "
        "reference's angles plus this run's own angle differences shifted in time by k/"
        f"{EXPECTED_SHIFTS + 1} of the compared frames, k = 1..{EXPECTED_SHIFTS} (a missing "
        "difference counts as 0): how much agreement differences of this size leave wherever they fall"
    )
    parts = {c: scores[c]["exact_agreement_pct"] for c in PART_SCALES if c in scores}
    definitions["without_constant_offsets"] = _without_offsets(
        pts[selected], ref_world[selected], times, factors, scoring, assessed_df, list(parts)
    )
    scores["parts_exact_agreement_pct"] = parts

    # --- frames -----------------------------------------------------------------------------------
    tracked_frames = set(frames_all.tolist())
    compared = set(rows_frame.tolist())
    outside = set(tracks.frame[~inside].tolist()) - set(tracks.frame[inside].tolist())
    in_frames = set(tracks.frame[inside].tolist())
    ref_frame_times = times_ref
    video_frames = np.round(ref_frame_times * fps).astype(np.int64) if math.isfinite(fps) else np.zeros(0, np.int64)
    untracked = sorted(set(video_frames.tolist()) - tracked_frames) if len(video_frames) else []
    frames = {
        "reference_samples": int(len(trc.times_s)),
        "reference_span_s": [round_or_nan(times_ref[0], 4), round_or_nan(times_ref[-1], 4)],
        "offset_s": offset_s,
        "assessment_frames_tracked": int(len(tracked_frames)),
        "compared": int(len(compared)),
        "left_out": {
            "assessment_outside_reference_time": int(len(outside)),
            "no_tracked_row_near_reference": int(len(in_frames - compared)),
            "reference_frames_nobody_tracked": int(len(untracked)),
        },
        "left_out_definition": {
            "assessment_outside_reference_time": "tracked frames before the reference's first or after its last sample",
            "no_tracked_row_near_reference": (
                f"frames inside the reference's span where no tracked row shares "
                f">= {MIN_COMMON_JOINTS} joints with the aligned reference within "
                f"{match_distance_m:g} m (mean joint distance)"
            ),
            "reference_frames_nobody_tracked": "reference samples at a video frame where the assessment tracked nobody",
        },
        "tracked_ids_used": sorted(
            {identity_name(int(w)) for w in rows_worker}, key=lambda s: int(s.rpartition("_")[2])
        ),
    }
    unmapped = [m for m in trc.markers if m not in mapping]
    ref_info = {
        "path": str(trc.path),
        "rate_hz": trc.rate_hz,
        "units": trc.units,
        "samples": int(len(trc.times_s)),
        "markers": list(trc.markers),
        "mapped": mapping,
        "unmapped": unmapped,
        "axes": canonical or "fitted",
    }
    if any(is_surface_marker(m) for m in mapping):
        notes.append(
            "Surface markers of motion capture sit a few centimetres from the joint centres our keypoints "
            "aim at; part of the residual is that offset."
        )
    for c in ("rula_grand", "reba_score"):
        if c in scores and scores[c]["pairs"] == 0:
            miss = [a for a, r in by_angle.items() if r.get("why_missing")]
            notes.append(
                f"{c}: the reference cannot be scored (it lacks markers for {', '.join(miss)}); "
                "the per-part agreement covers what it defines."
            )
    report(progress, "evaluation", steps, steps, unit="step")
    out = {
        "format": "ergopose.evaluation",
        "version": 1,
        "source": source or "reference marker recording (TRC)",
        "results": str(layout.root),
        "reference": ref_info,
        "fps": fps,
        "frames": frames["compared"],
        "frame_selection": frames,
        "alignment": alignment,
        "definitions": definitions,
        "angles": angles,
        "scores": scores,
        "notes": notes,
    }
    return json_ready(out)


def expected_reference_agreement(
    posture: pd.DataFrame,
    factors: pd.DataFrame,
    differences_deg: Mapping[str, np.ndarray],
    ref_scores: pd.DataFrame,
    columns: Sequence[str],
    scoring: ScoringSettings | None,
) -> dict[str, float]:
    """Exact agreement (%) per score of ``columns`` between the reference's scores and the scores of
    the reference's angles (``posture``, radians) plus the run's own differences to them
    (``differences_deg``, per angle, degrees, NaN: not measured, taken as 0) shifted in time by
    k/(EXPECTED_SHIFTS + 1) of the frames, k = 1..EXPECTED_SHIFTS, with the same task inputs
    (``factors``): how much exact agreement differences of this size and persistence leave, however
    close the reference's angles lie to the scoring's band edges."""
    n = len(posture)
    errors = np.full((n, len(ANGLE_COLUMNS)), np.nan)
    for j, c in enumerate(ANGLE_COLUMNS):
        if c in differences_deg:
            errors[:, j] = np.radians(np.asarray(differences_deg[c], dtype=np.float64))
    hits: dict[str, list[np.ndarray]] = {c: [] for c in columns}
    for k in range(1, EXPECTED_SHIFTS + 1):
        moved = moved_posture(posture, errors, (k * n) // (EXPECTED_SHIFTS + 1))
        moved_scores = score_posture(pd.concat([moved, factors], axis=1), settings=scoring)
        for c in columns:
            t = pd.to_numeric(ref_scores[c], errors="coerce").to_numpy(np.float64)
            m = pd.to_numeric(moved_scores[c], errors="coerce").to_numpy(np.float64)
            ok = np.isfinite(t) & np.isfinite(m)
            hits[c].append(t[ok] == m[ok])
    return {
        c: round_or_nan(100.0 * float(np.mean(np.concatenate(v))), 2) if sum(map(len, v)) else float("nan")
        for c, v in hits.items()
    }


def _agreement(a: np.ndarray, b: np.ndarray, scale: Sequence[int]) -> dict:
    both = np.isfinite(a) & np.isfinite(b)
    cm = confusion_matrix(a, b, scale)
    return {
        "scale": list(scale),
        "pairs": int(cm.sum()),
        "missing_assessment": int((~np.isfinite(a) & np.isfinite(b)).sum()),
        "missing_reference": int((np.isfinite(a) & ~np.isfinite(b)).sum()),
        "missing_both": int((~np.isfinite(a) & ~np.isfinite(b)).sum()),
        "exact_agreement_pct": round_or_nan(100.0 * exact_agreement(cm), 2),
        "within_one_pct": round_or_nan(100.0 * within_one(cm), 2),
        "kappa": round_or_nan(kappa_from_matrix(cm, "none"), 4),
        "kappa_linear": round_or_nan(kappa_from_matrix(cm, "linear"), 4),
        "kappa_quadratic": round_or_nan(kappa_from_matrix(cm, "quadratic"), 4),
        "mean_difference": round_or_nan(float(np.mean(a[both] - b[both])), 3) if both.any() else float("nan"),
        "confusion_matrix": {"rows": "assessment", "columns": "reference", "counts": cm.tolist()},
    }


def _sd_cover(row: Mapping[str, Any]) -> str:
    """How well the assessment's reported SDs cover the differences (empty without them)."""
    if not row.get("sd_rows"):
        return ""
    return (
        f"  within 1 / 2 of its SDs {row['within_one_sd_pct']:.0f} / {row['within_two_sd_pct']:.0f} % "
        f"(median SD {row['median_sd_deg']:.1f})"
    )


def format_reference(ev: Mapping[str, Any]) -> str:
    """A short text summary for the terminal."""
    fr, al, an, sc = ev["frame_selection"], ev["alignment"], ev["angles"], ev["scores"]
    lines = [
        f"Reference: {ev['reference']['path']} ({ev['reference']['samples']} samples at "
        f"{ev['reference']['rate_hz']:g} Hz; {len(ev['reference']['mapped'])} of "
        f"{len(ev['reference']['markers'])} markers mapped)",
        f"Frames compared: {fr['compared']}; left out: "
        + ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in fr["left_out"].items()),
        f"Alignment: {al['method']}; residual RMS {al['residual_rms_mm']} mm, median {al['residual_median_mm']} mm, "
        f"{al['residual_within_50mm_pct']} % within 50 mm, over {al['pairs']} joint pairs"
        + (f" ({al['fit_pairs_used']} used in the fit)" if al.get("fit_pairs_used") else ""),
        "Joint offsets after alignment (assessment - reference; mean x, y, z and RMS, mm):",
    ]
    for j, r in al["by_joint"].items():
        x, y, z = (v + 0.0 if v is not None else float("nan") for v in r["mean_offset_world_mm"])
        label = f"{j} ({r['reference_marker']})"
        lines.append(f"  {label:<30} {x:+7.1f} {y:+7.1f} {z:+7.1f}   rms {r['rms_mm']}")
    defs = ev.get("definitions", {})
    without = defs.get("without_constant_offsets", {})
    if defs.get("segments"):
        lines.append("Segment lengths (median over the compared frames; assessment / reference mm, ratio):")
        for limb, r in defs["segments"].items():
            lines.append(
                f"  {limb:<18} {r['assessment_median_mm']:7.1f} / {r['reference_median_mm']:7.1f}   {r['ratio']:.3f}"
            )
    if without.get("offsets_heading_mm"):
        lines.append("Joint offsets in the person's heading frame (median; forward, left, up, mm):")
        for j, (fwd, left, up) in without["offsets_heading_mm"].items():
            lines.append(f"  {j:<30} {fwd:+7.1f} {left:+7.1f} {up:+7.1f}")
    lines.append(
        "Angles (assessment - reference, degrees): mean absolute difference, bias, frames; "
        "then against the reference moved by those offsets (what a constant definition difference leaves)"
    )
    for c, r in an["by_angle"].items():
        if r["n"]:
            w = without.get("angles", {}).get(c)
            rest = f"  | offsets removed: MAD {w['mae_deg']:6.2f}  bias {w['bias_deg']:+6.2f}" if w and w["n"] else ""
            lines.append(
                f"  {c:<28} MAD {r['mae_deg']:6.2f}  bias {r['bias_deg']:+6.2f}  n {r['n']}" + _sd_cover(r) + rest
            )
    skipped = [c for c, r in an["by_angle"].items() if not r["n"]]
    if skipped:
        lines.append(f"  not compared (not measured on one side): {', '.join(skipped)}")
    lines.append(
        "Scores: exact agreement %, within one %, kappa (linear), pairs; expected: the exact agreement "
        "that this run's angle differences leave (moved in time); offsets removed: the exact agreement "
        "against the reference moved by the joints' constant offsets"
    )
    for c in list(SCORE_SCALES) + list(PART_SCALES):
        if c in sc and isinstance(sc[c], dict):
            r = sc[c]
            if r["pairs"]:
                lines.append(
                    f"  {c:<22} {r['exact_agreement_pct']:6.1f} {r['within_one_pct']:6.1f} "
                    f"{(r['kappa_linear'] if r['kappa_linear'] is not None else float('nan')):7.3f}  {r['pairs']}"
                    + (
                        f"  expected {r['expected_exact_agreement_pct']:.1f}"
                        if "expected_exact_agreement_pct" in r
                        else ""
                    )
                    + (
                        f"  offsets removed {without['parts_exact_agreement_pct'][c]:.1f}"
                        if c in without.get("parts_exact_agreement_pct", {})
                        else ""
                    )
                )
            else:
                lines.append(
                    f"  {c:<22} not compared (missing: assessment {r['missing_assessment']}, "
                    f"reference {r['missing_reference']}, both {r['missing_both']})"
                )
    for n in ev.get("notes", []):
        lines.append(f"Note: {n}")
    return "\n".join(lines)


__all__ = ["evaluate_reference", "format_reference", "kabsch", "robust_kabsch", "parse_axes", "MATCH_DISTANCE_M"]
