"""Exposure standards: the zones of the body parts' angles per frame and the findings over a shift.

Reference: rula-reba-reference.md, "Exposure over time"; docs/scoring.md.
    ISO 11226:2000 -- static postures (a zone held longer than ``static_hold_s`` = 4 s):
        trunk flexion 0-20 acceptable, 20-60 time-limited (unless supported), > 60 not recommended;
        head inclination (trunk + neck flexion) 25-85 time-limited, > 85 not recommended;
        neck flexion > 25 and neck extension not recommended;
        upper arm elevation 0-20 acceptable, 20-60 time-limited (unless supported), > 60 not
        recommended; raised shoulder not recommended.
    EN 1005-4 -- movement frequency, split at 2 per minute (entries into the zone per observed
        minute): upper arm 20-60 conditionally acceptable at >= 2/min; upper arm > 60 not
        acceptable; trunk side bend or twist >= 10 degrees conditionally acceptable below 2/min,
        not acceptable at >= 2/min.

:func:`exposure_zones` codes a chunk of frames per finding (:func:`exposure_specs`); the
aggregation (ergopose.ergonomics.aggregate) follows the codes' runs over the shift
(ergopose.ergonomics.runs) and :func:`exposure_finding` gives each finding's verdict from them.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Sequence

import numpy as np
import pandas as pd

from ergopose.arrays import FloatArray
from ergopose.ergonomics.runs import Runs
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.ergonomics.shift_records import ExposureFinding

ISO_VERDICTS = ("acceptable", "time-limited", "not recommended")
EN_VERDICTS = ("acceptable", "conditionally acceptable", "not acceptable")


def _zones(x: np.ndarray, edges: Sequence[float], upper_inclusive: Sequence[bool]) -> np.ndarray:
    """Zone index per frame for angles x (radians) and edges (degrees): NaN where x is NaN.

    upper_inclusive[k]: an angle exactly on edge k belongs to the zone above it.
    """
    z = np.zeros(x.shape, dtype=np.float64)
    for e, up in zip(edges, upper_inclusive):
        r = np.deg2rad(e)
        z += (x >= r) if up else (x > r)
    z[np.isnan(x)] = np.nan
    return z


@dataclass(frozen=True)
class ExposureSpec:
    """One finding: the standard, the body part, the names of its zones by code ("-": a code not
    used) and its kind."""

    standard: str
    body_part: str
    zone_names: tuple[str, ...]
    kind: str  # "iso" (static holds) or "en_arm" / "en_trunk" (frequency)


def exposure_specs() -> list[ExposureSpec]:
    """The findings reported, in this order: ISO 11226 per body part, then EN 1005-4."""
    specs = [
        ExposureSpec("ISO 11226", "trunk", ("0-20", "20-60", ">60"), "iso"),
        ExposureSpec("ISO 11226", "head", ("<25", "25-85", ">85"), "iso"),
        ExposureSpec("ISO 11226", "neck", ("acceptable", "-", "flexion>25 or extension"), "iso"),
    ]
    for side in ("left", "right"):
        specs.append(ExposureSpec("ISO 11226", f"{side} upper arm", ("0-20", "20-60", ">60"), "iso"))
        specs.append(ExposureSpec("ISO 11226", f"{side} shoulder", ("not raised", "-", "raised"), "iso"))
    for side in ("left", "right"):
        specs.append(ExposureSpec("EN 1005-4", f"{side} upper arm", ("0-20", "20-60", ">60"), "en_arm"))
    specs.append(ExposureSpec("EN 1005-4", "trunk side bend or twist", ("<10", ">=10"), "en_trunk"))
    return specs


def float_column(frames: pd.DataFrame, name: str) -> FloatArray | None:
    """A column of the frames as floats (NaN where missing); None when the frames lack it."""
    if name in frames.columns:
        column: FloatArray = frames[name].to_numpy(dtype=np.float64, na_value=np.nan)
        return column
    return None


def exposure_zones(frames: pd.DataFrame, s: ScoringSettings) -> dict[str, np.ndarray | None]:
    """Zone index per frame for each exposure spec (None when the inputs are absent)."""
    n = len(frames)
    out: dict[str, np.ndarray | None] = {}
    trunk = float_column(frames, "trunk_flexion")
    neck = float_column(frames, "neck_flexion")
    # ISO 11226: 0-20 acceptable (20 included), 20-60 time-limited (60 included), > 60 not recommended
    out["ISO 11226|trunk"] = None if trunk is None else _zones(trunk, (20, 60), (False, False))
    head = None if trunk is None or neck is None else trunk + neck
    out["ISO 11226|head"] = None if head is None else _zones(head, (25, 85), (False, False))
    if neck is None:
        out["ISO 11226|neck"] = None
    else:
        with np.errstate(invalid="ignore"):
            bad = (neck > np.deg2rad(25)) | (neck < -np.deg2rad(s.neck_extension_deg))
        out["ISO 11226|neck"] = np.where(np.isnan(neck), np.nan, np.where(bad, 2.0, 0.0))
    for side in ("left", "right"):
        elev = float_column(frames, f"{side}_upper_arm_elevation")
        if elev is None:
            flex = float_column(frames, f"{side}_upper_arm_flexion")
            abd = float_column(frames, f"{side}_upper_arm_abduction")
            if flex is not None and abd is not None:
                elev = np.where(np.isnan(flex) | np.isnan(abd), np.nan, np.fmax(flex, abd))
            else:
                elev = flex
        zones = None if elev is None else _zones(elev, (20, 60), (False, False))
        out[f"ISO 11226|{side} upper arm"] = zones
        out[f"EN 1005-4|{side} upper arm"] = zones
        raised = float_column(frames, f"{side}_shoulder_raised")
        elevation = float_column(frames, f"{side}_shoulder_elevation")
        derived = None
        if elevation is not None:
            with np.errstate(invalid="ignore"):
                derived = np.where(
                    np.isnan(elevation), np.nan, (elevation > np.deg2rad(s.shoulder_raised_deg)).astype(np.float64)
                )
        if raised is None:
            raised = derived
        elif derived is not None:
            raised = np.where(np.isnan(raised), derived, raised)
        out[f"ISO 11226|{side} shoulder"] = None if raised is None else raised * 2.0
    side_bend = float_column(frames, "trunk_side_bend")
    twist = float_column(frames, "trunk_twist")
    if side_bend is None and twist is None:
        out["EN 1005-4|trunk side bend or twist"] = None
    else:
        parts = [np.abs(a) for a in (side_bend, twist) if a is not None]
        worst = (
            parts[0]
            if len(parts) == 1
            else np.where(np.isnan(parts[0]) | np.isnan(parts[1]), np.nan, np.fmax(parts[0], parts[1]))
        )
        out["EN 1005-4|trunk side bend or twist"] = _zones(worst, (10,), (True,))
    assert all(v is None or v.shape == (n,) for v in out.values())
    return out


def exposure_finding(spec: ExposureSpec, runs: Runs | None, period_s: float, minutes: float) -> ExposureFinding:
    """The finding of one spec over the shift from the runs of its zone codes (None: the angles
    were not in the frames, "not measured"); period_s: the time one frame stands for; minutes:
    the observed minutes (for the entries per minute)."""
    if runs is None:
        return ExposureFinding(
            spec.standard,
            spec.body_part,
            "not measured",
            False,
            MappingProxyType({}),
            MappingProxyType({}),
            MappingProxyType({}),
            MappingProxyType({}),
            0,
            0.0,
        )
    names = spec.zone_names
    zone_time = {names[v]: runs.frames.get(v, 0) * period_s for v in range(len(names)) if names[v] != "-"}
    static_time = {names[v]: runs.static_time.get(v, 0) * period_s for v in range(len(names)) if names[v] != "-"}
    static_holds = {names[v]: runs.static_holds.get(v, 0) for v in range(len(names)) if names[v] != "-"}
    longest = {
        names[v]: (runs.longest[v][0] if v in runs.longest else 0.0) for v in range(len(names)) if names[v] != "-"
    }
    entries, per_minute = 0, 0.0
    if spec.kind == "iso":
        if static_holds.get(names[2], 0) > 0:
            verdict = ISO_VERDICTS[2]
        elif names[1] != "-" and static_holds.get(names[1], 0) > 0:
            verdict = ISO_VERDICTS[1]
        else:
            verdict = ISO_VERDICTS[0]
    elif spec.kind == "en_arm":
        entries = runs.holds.get(1, 0)
        per_minute = entries / minutes if minutes else 0.0
        if runs.frames.get(2, 0) > 0:
            verdict = EN_VERDICTS[2]
        elif per_minute >= 2.0:
            verdict = EN_VERDICTS[1]
        else:
            verdict = EN_VERDICTS[0]
    else:  # en_trunk
        entries = runs.holds.get(1, 0)
        per_minute = entries / minutes if minutes else 0.0
        if per_minute >= 2.0:
            verdict = EN_VERDICTS[2]
        elif entries > 0:
            verdict = EN_VERDICTS[1]
        else:
            verdict = EN_VERDICTS[0]
    return ExposureFinding(
        spec.standard,
        spec.body_part,
        verdict,
        True,
        MappingProxyType(zone_time),
        MappingProxyType(static_time),
        MappingProxyType(static_holds),
        MappingProxyType(longest),
        entries,
        per_minute,
    )


__all__ = [
    "ISO_VERDICTS",
    "EN_VERDICTS",
    "ExposureSpec",
    "exposure_specs",
    "float_column",
    "exposure_zones",
    "exposure_finding",
]
