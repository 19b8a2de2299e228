"""The posture table: what scoring consumes (docs/posture-table.md is the contract).

A posture table is a pandas DataFrame with one row per frame of one worker (or several workers,
told apart by a ``worker`` column), in time order. Inside the code angles are RADIANS; CSV files
hold DEGREES and :func:`read_posture_csv` / :func:`to_csv_units` convert at the edge.

Column kinds:
    angles     radians (degrees in CSV), flexion positive, extension negative; elbow and knee
               0 = straight. NaN = not measured (the joint was not seen).
    distances  metres. NaN = not measured.
    flags      0.0 / 1.0, NaN = unknown.
    load_kg    kilograms >= 0, NaN = unknown.
    load_mode  intermittent | static | repeated, missing = unknown (a Categorical after prepare).
    coupling   good | fair | poor | unacceptable, missing = unknown (a Categorical after prepare).
    time_s     seconds, strictly increasing per worker.
Per-side columns carry a ``left_`` or ``right_`` prefix; an unprefixed per-side column means
"both sides" (its values are used for each side; giving both forms is an error).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable, Sequence, SupportsFloat

import numpy as np
import pandas as pd

from ergopose.arrays import FloatArray
from ergopose.errors import InputError

SIDES = ("left_", "right_")

#: per-side angles (radians; degrees in CSV)
SIDE_ANGLES = (
    "upper_arm_flexion",
    "upper_arm_abduction",
    "elbow_flexion",
    "wrist_flexion",
    "knee_flexion",
    # optional: measured inputs for the yes/no adjustments and exposure reporting
    "shoulder_elevation",
    "wrist_deviation",
    "upper_arm_elevation",
)
#: whole-body angles
BODY_ANGLES = ("trunk_flexion", "trunk_side_bend", "trunk_twist", "neck_flexion", "neck_side_bend", "neck_twist")
#: per-side distances (metres): wrist position from the trunk's midsagittal plane, positive
#: towards the arm's own side
SIDE_DISTANCES = ("wrist_lateral_m",)
#: per-side yes/no inputs
SIDE_FLAGS = (
    "shoulder_raised",
    "arm_supported",
    "arm_across_midline_or_out",
    "wrist_deviated",
    "wrist_twist_end_range",
    # optional overrides of flags otherwise derived from angles / distances
    "upper_arm_abducted",
    "arm_across_midline",
    "arm_out_to_side",
)
#: whole-body yes/no inputs
BODY_FLAGS = (
    "legs_supported",
    "one_leg_stance",
    "seated",
    "walking",
    "shock",
    "static_posture",
    "repeated_action",
    "rapid_change",
    # optional overrides of flags otherwise derived from angles
    "trunk_twisted",
    "trunk_side_bent",
    "neck_twisted",
    "neck_side_bent",
)
CATEGORIES = {"load_mode": ("intermittent", "static", "repeated"), "coupling": ("good", "fair", "poor", "unacceptable")}
NUMBERS = ("load_kg", "time_s")
IDENTITY = ("worker", "frame")

#: the angles each method cannot do without (per side where listed in SIDE_ANGLES)
REQUIRED = {
    "rula": ("upper_arm_flexion", "elbow_flexion", "wrist_flexion", "neck_flexion", "trunk_flexion"),
    "reba": ("neck_flexion", "trunk_flexion", "knee_flexion", "upper_arm_flexion", "elbow_flexion", "wrist_flexion"),
}
#: activity inputs that, when all given, make time_s unnecessary
ACTIVITY_FLAGS = {
    "rula": ("static_posture", "repeated_action"),
    "reba": ("static_posture", "repeated_action", "rapid_change"),
}


def _sided(names: Iterable[str]) -> list[str]:
    return [f"{s}{n}" for n in names for s in SIDES]


ANGLE_COLUMNS = tuple(BODY_ANGLES) + tuple(_sided(SIDE_ANGLES))
DISTANCE_COLUMNS = tuple(_sided(SIDE_DISTANCES))
FLAG_COLUMNS = tuple(BODY_FLAGS) + tuple(_sided(SIDE_FLAGS))
#: every column a posture table may hold (after side expansion)
POSTURE_COLUMNS = ANGLE_COLUMNS + DISTANCE_COLUMNS + FLAG_COLUMNS + tuple(CATEGORIES) + NUMBERS + IDENTITY
_SIDE_BASES = set(SIDE_ANGLES) | set(SIDE_DISTANCES) | set(SIDE_FLAGS)


def expand_sides(frame: pd.DataFrame, source: str | None = None) -> pd.DataFrame:
    """Copy unprefixed per-side columns (e.g. ``wrist_flexion``) to ``left_``/``right_``."""
    both = [c for c in frame.columns if c in _SIDE_BASES]
    if not both:
        return frame
    clash = [c for c in both if any(f"{s}{c}" in frame.columns for s in SIDES)]
    if clash:
        raise InputError(
            f"give either the unprefixed (both sides) or the left_/right_ column, not both: {', '.join(clash)}",
            path=source,
        )
    out = frame.drop(columns=both)
    for c in both:
        for s in SIDES:
            out[f"{s}{c}"] = frame[c].to_numpy()
    return out


def check_columns(columns: Iterable[str], method: str | Sequence[str], source: str | None = None) -> None:
    """One InputError naming every missing and unknown column (after side expansion).

    method: "rula", "reba" or several of them (the union of their requirements).
    """
    methods = (method,) if isinstance(method, str) else tuple(method)
    cols = list(columns)
    known = set(POSTURE_COLUMNS)
    unknown = [c for c in cols if c not in known]
    missing: list[str] = []
    for m in methods:
        if m not in REQUIRED:
            raise InputError(f"unknown scoring method {m!r}; expected rula or reba", field="method")
        for name in REQUIRED[m]:
            need = [f"{s}{name}" for s in SIDES] if name in SIDE_ANGLES else [name]
            missing += [c for c in need if c not in cols and c not in missing]
        if "time_s" not in cols and "time_s" not in missing and not all(f in cols for f in ACTIVITY_FLAGS[m]):
            missing.append("time_s")
    problems = []
    if missing:
        problems.append(f"missing column(s) for {'+'.join(m.upper() for m in methods)}: {', '.join(missing)}")
    if unknown:
        problems.append(f"unknown column(s): {', '.join(unknown)} (docs/posture-table.md lists the columns)")
    if problems:
        raise InputError("; ".join(problems), path=source)


def _first_bad(mask: np.ndarray) -> int:
    return int(np.flatnonzero(mask)[0])


def _show(value: object) -> str:
    """A cell value as a user typed it: text in quotes, numbers plain."""
    if isinstance(value, str):
        return repr(value)
    if not isinstance(value, SupportsFloat):
        return repr(str(value))
    try:
        return f"{float(value):g}"
    except (TypeError, ValueError):
        return repr(str(value))


def validate_values(frame: pd.DataFrame, source: str | None = None, *, degrees: bool = False) -> None:
    """One InputError naming each column with an invalid value and its first bad row (1-based)."""
    problems: list[str] = []
    limit = 180.0 if degrees else np.pi
    unit = "degrees" if degrees else "radians"

    def number(col: str) -> FloatArray | None:
        s = frame[col]
        if pd.api.types.is_numeric_dtype(s) and not pd.api.types.is_bool_dtype(s):
            values: FloatArray = s.to_numpy(dtype=np.float64, na_value=np.nan)
            return values
        conv = pd.to_numeric(s, errors="coerce")
        bad = conv.isna().to_numpy() & s.notna().to_numpy() & (s.astype(str).str.strip() != "").to_numpy()
        if bad.any():
            i = _first_bad(bad)
            problems.append(f"{col}: row {i + 1}: {_show(s.iloc[i])} is not a number")
            return None
        converted: FloatArray = conv.to_numpy(dtype=np.float64, na_value=np.nan)
        return converted

    for col in frame.columns:
        if col in ANGLE_COLUMNS:
            x = number(col)
            if x is not None:
                bad = np.isinf(x) | (np.abs(np.nan_to_num(x)) > limit)
                if bad.any():
                    i = _first_bad(bad)
                    problems.append(f"{col}: row {i + 1}: {x[i]:g} is outside -{limit:g}..{limit:g} {unit}")
        elif col in DISTANCE_COLUMNS:
            x = number(col)
            if x is not None and (bad := np.isinf(x) | (np.abs(np.nan_to_num(x)) > 10.0)).any():
                i = _first_bad(bad)
                problems.append(f"{col}: row {i + 1}: {x[i]:g} m is not a plausible distance")
        elif col in FLAG_COLUMNS:
            x = number(col)
            if x is not None:
                bad = ~np.isnan(x) & (x != 0) & (x != 1)
                if bad.any():
                    i = _first_bad(bad)
                    problems.append(f"{col}: row {i + 1}: {_show(frame[col].iloc[i])} is not 0, 1 or empty")
        elif col == "load_kg":
            x = number(col)
            if x is not None and (bad := np.isinf(x) | (np.nan_to_num(x) < 0)).any():
                i = _first_bad(bad)
                problems.append(f"load_kg: row {i + 1}: {x[i]:g} is not a load in kg (>= 0)")
        elif col == "time_s":
            x = number(col)
            if x is not None and (bad := ~np.isfinite(x)).any():
                i = _first_bad(bad)
                problems.append(f"time_s: row {i + 1}: the time is missing")
        elif col in CATEGORIES:
            codes, normal = _category_codes(frame[col])
            bad_codes = [k for k, u in enumerate(normal) if u is not None and u not in CATEGORIES[col]]
            if bad_codes:
                i = _first_bad(np.isin(codes, bad_codes))
                problems.append(
                    f"{col}: row {i + 1}: {_show(frame[col].iloc[i])} is not one of {', '.join(CATEGORIES[col])}"
                )
    if problems:
        raise InputError("invalid value(s): " + "; ".join(problems), path=source)


def _category_codes(s: pd.Series) -> tuple[np.ndarray, list[str | None]]:
    """Codes per row and the distinct values, trimmed and lower-cased (None = missing/empty)."""
    codes, uniques = pd.factorize(s, use_na_sentinel=True)
    normal = [None if (pd.isna(u) or not str(u).strip()) else str(u).strip().lower() for u in uniques]
    return codes, normal


def _clean(frame: pd.DataFrame) -> pd.DataFrame:
    """Numbers as float64, categories as pandas Categoricals of their allowed values."""
    out = {}
    for col in frame.columns:
        s = frame[col]
        if col in CATEGORIES:
            codes, normal = _category_codes(s)
            allowed = list(CATEGORIES[col])
            lut = np.array([allowed.index(u) if u is not None else -1 for u in normal] + [-1], dtype=np.int64)
            out[col] = pd.Categorical.from_codes(lut[codes], categories=allowed)
        elif col == "worker":
            out[col] = s.astype("string")
        elif col == "frame":
            out[col] = s
        elif s.dtype == np.float64:
            out[col] = s
        else:
            out[col] = pd.to_numeric(s, errors="coerce").astype(np.float64)
    return pd.DataFrame(out, index=frame.index, copy=False)


def prepare(
    frame: pd.DataFrame, method: str | Sequence[str], source: str | None = None, *, degrees: bool = False
) -> pd.DataFrame:
    """Expand sides, check columns and values; return a clean posture table (radians)."""
    if not isinstance(frame, pd.DataFrame):
        raise InputError(f"expected a pandas DataFrame, got {type(frame).__name__}", path=source)
    expanded = expand_sides(frame, source)
    check_columns(expanded.columns, method, source)
    validate_values(expanded, source, degrees=degrees)
    clean = _clean(expanded)
    if degrees:
        for col in clean.columns:
            if col in ANGLE_COLUMNS:
                clean[col] = np.deg2rad(clean[col].to_numpy())
    return clean


def read_posture_csv(path: str | os.PathLike[str], method: str | Sequence[str]) -> pd.DataFrame:
    """Read a posture CSV (angles in DEGREES) and return a checked posture table (RADIANS)."""
    p = Path(path)
    try:
        frame = pd.read_csv(
            p, dtype={"worker": "string", "load_mode": "string", "coupling": "string"}, skipinitialspace=True
        )
    except FileNotFoundError:
        raise InputError("the posture file does not exist", path=p) from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, OSError) as exc:
        raise InputError(f"cannot read the CSV file ({str(exc).splitlines()[0]})", path=p) from None
    frame.columns = [str(c).strip() for c in frame.columns]
    dup = sorted({c for c in frame.columns if list(frame.columns).count(c) > 1})
    if dup:
        raise InputError(f"duplicate column(s): {', '.join(dup)}", path=p)
    return prepare(frame, method, str(p), degrees=True)


def to_csv_units(frame: pd.DataFrame) -> pd.DataFrame:
    """A copy with angle columns converted from radians to degrees (for CSV output)."""
    out = frame.copy()
    for col in out.columns:
        if col in ANGLE_COLUMNS:
            out[col] = np.rad2deg(out[col].to_numpy(dtype=np.float64))
    return out


__all__ = [
    "SIDES",
    "SIDE_ANGLES",
    "BODY_ANGLES",
    "SIDE_DISTANCES",
    "SIDE_FLAGS",
    "BODY_FLAGS",
    "CATEGORIES",
    "ANGLE_COLUMNS",
    "DISTANCE_COLUMNS",
    "FLAG_COLUMNS",
    "POSTURE_COLUMNS",
    "REQUIRED",
    "expand_sides",
    "check_columns",
    "validate_values",
    "prepare",
    "read_posture_csv",
    "to_csv_units",
]
