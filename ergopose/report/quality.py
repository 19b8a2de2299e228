"""How far the scores can be trusted: a plain-language verdict from the reconstruction diagnostics.

The verdict rates four things, each "good", "fair" or "poor" (thresholds in QUALITY_RULES,
explained in docs/reports.md), and takes the worst as the overall verdict:

- reliable skeleton: share of the tracked frames whose skeleton met the diagnostics' rule;
- stable body dimensions: the spread (interquartile range / median) of the 3D length of each limb
  the scores rest on; a real limb does not change length, so spread is measurement noise
  (the paper's evaluation, section "Evaluation and results");
- reconstruction frequency: the lowest share of frames in which those limbs were reconstructed;
- calibration: the largest relative error of the reference-bar check over the lens regions.

Each rating comes with a sentence naming the number behind it, so a safety engineer can explain
the verdict.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ergopose.arrays import BoolArray
from ergopose.keypoints import LIMB_INDEX, LIMBS
from ergopose.report.context import CalibrationInfo, WorkerDiagnostics

RATINGS = ("good", "fair", "poor")

#: (good at or above/below, fair at or above/below) per criterion; see docs/reports.md.
QUALITY_RULES = {
    "reliable_share": (0.90, 0.70),  # higher is better
    "limb_relative_iqr": (0.05, 0.10),  # lower is better
    "reconstruction_share": (0.90, 0.70),  # higher is better
    "calibration_relative_error": (0.02, 0.05),  # lower is better
}

#: Limbs whose lengths and reconstruction the verdict checks: those RULA and REBA angles rest on.
SCORED_LIMBS = (
    "left_upper_arm",
    "right_upper_arm",
    "left_forearm",
    "right_forearm",
    "left_trunk_side",
    "right_trunk_side",
    "left_thigh",
    "right_thigh",
    "left_shank",
    "right_shank",
)

HEADLINES = {
    "good": "The skeleton was reliable for most of the shift and the body dimensions "
    "stayed stable, so the scores can be used as measured.",
    "fair": "Use the scores for the overall picture, and check the points below "
    "before acting on single numbers or short periods.",
    "poor": "The scores should not be relied on without a check on site (observation of "
    "the task) for the reasons below.",
}


@dataclass(frozen=True)
class Finding:
    """One rated criterion: what (short name), rating ("good"/"fair"/"poor"), sentence with the number."""

    what: str
    rating: str
    sentence: str


@dataclass(frozen=True)
class Verdict:
    """The overall rating (worst finding), its plain-language headline, and the findings."""

    rating: str
    headline: str
    findings: tuple[Finding, ...]


def _rate_high(x: float, rule: tuple[float, float]) -> str:
    return "good" if x >= rule[0] else "fair" if x >= rule[1] else "poor"


def _rate_low(x: float, rule: tuple[float, float]) -> str:
    return "good" if x <= rule[0] else "fair" if x <= rule[1] else "poor"


def _limb_words(name: str) -> str:
    return name.replace("_", " ")


def quality_verdict(diag: WorkerDiagnostics, calibration: CalibrationInfo | None) -> Verdict:
    """Rate the diagnostics of one worker (and the session's calibration check)."""
    findings: list[Finding] = []
    # reliable skeleton
    if diag.frames_observed > 0:
        share = diag.frames_reliable / diag.frames_observed
        findings.append(
            Finding(
                "reliable skeleton",
                _rate_high(share, QUALITY_RULES["reliable_share"]),
                f"The skeleton was reliable in {100 * share:.1f} % of the tracked time (rule: {diag.reliable_rule}).",
            )
        )
    else:
        findings.append(Finding("reliable skeleton", "poor", "The worker was never tracked."))
    # limb-length stability
    stats = {s.limb: s for s in diag.limb_lengths if s.region == "all"}
    spreads = []
    never = []
    for limb in SCORED_LIMBS:
        s = stats.get(limb)
        if s is None or s.n == 0 or not (math.isfinite(s.median_m) and s.median_m > 0):
            never.append(limb)
            continue
        spreads.append(((s.q3_m - s.q1_m) / s.median_m, limb))
    if never:
        findings.append(
            Finding(
                "stable body dimensions",
                "poor",
                f"No length could be measured for: {', '.join(map(_limb_words, never))}.",
            )
        )
    if spreads:
        worst, limb = max(spreads)
        findings.append(
            Finding(
                "stable body dimensions",
                _rate_low(worst, QUALITY_RULES["limb_relative_iqr"]),
                f"Limb lengths varied by at most {100 * worst:.1f} % of their median "
                f"(interquartile range; largest: {_limb_words(limb)}).",
            )
        )
    # reconstruction frequency
    freq = [
        (r.reconstructed / r.frames, r.limb)
        for r in diag.reconstruction
        if r.region == "all" and r.limb in SCORED_LIMBS and r.frames > 0
    ]
    if freq:
        low, limb = min(freq)
        findings.append(
            Finding(
                "reconstruction frequency",
                _rate_high(low, QUALITY_RULES["reconstruction_share"]),
                f"Every scored limb was reconstructed in at least {100 * low:.1f} % of the tracked "
                f"frames (lowest: {_limb_words(limb)}).",
            )
        )
    # calibration
    regions = (
        []
        if calibration is None
        else [r for r in calibration.regions if r.n > 0 and math.isfinite(r.measured_m) and r.target_m > 0]
    )
    if regions:
        err, region = max((abs(r.measured_m - r.target_m) / r.target_m, r.region) for r in regions)
        findings.append(
            Finding(
                "calibration",
                _rate_low(err, QUALITY_RULES["calibration_relative_error"]),
                f"A reference bar measured within {100 * err:.1f} % of its true length in every "
                f"lens region (largest error: {region} region).",
            )
        )
    else:
        findings.append(
            Finding("calibration", "fair", "The calibration was not checked with a reference bar of known length.")
        )
    # lens edge (informative; rated fair when most of the time was spent at the edge)
    total = sum(diag.region_frames.values())
    if total > 0:
        edge = diag.region_frames.get("edge", 0) / total
        findings.append(
            Finding(
                "lens edge",
                "fair" if edge > 0.5 else "good",
                f"The worker was in the lens edge region (least accurate) {100 * edge:.1f} % of the tracked time.",
            )
        )
    rating = max((f.rating for f in findings), key=RATINGS.index)
    return Verdict(rating=rating, headline=HEADLINES[rating], findings=tuple(findings))


#: Relative deviation from the worker's median limb length still counted as reliable.
RELIABLE_LENGTH_TOLERANCE = 0.15


def reliable_rule(tolerance: float = RELIABLE_LENGTH_TOLERANCE) -> str:
    """The reliability rule of :func:`reliable_frames` in words (shown in the reports)."""
    return (
        f"every limb the scores rest on ({len(SCORED_LIMBS)} limbs: upper arms, forearms, trunk sides, thighs, "
        f"shanks) reconstructed in 3D and within {100 * tolerance:.0f} % of the worker's median length"
    )


def reliable_frames(
    points_world: ArrayLike, tolerance: float = RELIABLE_LENGTH_TOLERANCE, limb_medians_m: ArrayLike | None = None
) -> BoolArray:
    """Per frame of one worker, whether the skeleton is reliable (the rule of :func:`reliable_rule`).

    points_world: (F, 33, 3) joints in metres, NaN = missing. Returns a bool array (F,).
    limb_medians_m: (len(keypoints.LIMBS),) the worker's median limb lengths over the whole shift
    (e.g. :meth:`ergopose.recon.diagnostics.LimbStatsAccumulator.medians`), so a shift can be
    judged piece by piece; None takes the medians over the frames given.
    """
    pts = np.asarray(points_world, dtype=np.float64)
    names = [n for n, _, _ in LIMBS]
    cols = [names.index(n) for n in SCORED_LIMBS]
    idx = LIMB_INDEX[cols]
    lengths = np.linalg.norm(pts[:, idx[:, 0]] - pts[:, idx[:, 1]], axis=-1)  # (F, limbs)
    if lengths.shape[0] == 0:
        return np.zeros(0, dtype=bool)
    known = np.isfinite(lengths)
    if limb_medians_m is not None:
        median = np.asarray(limb_medians_m, dtype=np.float64)[cols]
    else:
        counts = known.sum(axis=0)
        median = np.full(lengths.shape[1], np.nan)
        for k in np.flatnonzero(counts):  # one column per limb (10): a limb never seen has no median
            median[k] = np.median(lengths[known[:, k], k])
    with np.errstate(invalid="ignore"):
        ok = known & (np.abs(lengths - median) <= tolerance * median)
    reliable: BoolArray = np.all(ok, axis=1)
    return reliable
