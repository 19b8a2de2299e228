"""RULA and REBA over a posture table, vectorised: every step score of every frame, per side.

Input: a posture table (ergopose.ergonomics.posture; docs/posture-table.md), angles in radians.
Output: a DataFrame with the same index and one column per step score (docs/csv-columns.md):
pandas nullable integers (SCORE_DTYPE, Int16: scores never exceed 15, and ~90 Int64 columns
would take ~1 GB per 8-hour shift of 4 workers), <NA> where an input the step needs was not
measured (a missing joint is never guessed). The method data (bands, tables, levels) come from
assessments/*.toml through ergopose.ergonomics.methods; the open choices from ScoringSettings.

How a step is scored (docs/scoring.md):
    band      the position score from the angle alone (``*_band`` columns);
    adjust    the yes/no adjustments added to it (``*_adjust``; a flag column of the posture
              table wins over the flag derived from a measured angle);
    step      band + adjust, clamped to the method's range (e.g. ``left_rula_upper_arm``);
    tables    numpy lookups into Tables A, B, C (a score above a table's last row/column uses
              that last row/column: RULA's 8+ and 7+).
Muscle use (RULA) and activity (REBA) come from the posture table's flags where given and from
the time series otherwise (ergopose.ergonomics.activity).
"""

from __future__ import annotations

from typing import Callable, Iterable, Mapping, Sequence

import numpy as np
import pandas as pd

from ergopose.ergonomics import activity as act
from ergopose.ergonomics.methods import Bands, Method, ScoreTable, load_method
from ergopose.ergonomics.posture import SIDES, prepare
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.errors import InputError
from ergopose.progress import ProgressCallback, report

NAN = np.nan
#: Values of rula_worse_side / reba_worse_side (missing where a side could not be scored).
WORSE_SIDE_LABELS = ("left", "right", "both")

# ----------------------------------------------------------------- column names (documented)


def rula_columns() -> list[str]:
    """Every column score_rula writes, in order."""
    side = [
        "rula_upper_arm_band",
        "rula_upper_arm_adjust",
        "rula_upper_arm",
        "rula_lower_arm_band",
        "rula_lower_arm_adjust",
        "rula_lower_arm",
        "rula_wrist_band",
        "rula_wrist_adjust",
        "rula_wrist",
        "rula_wrist_twist",
        "rula_table_a",
        "rula_static",
        "rula_repeated",
        "rula_muscle",
        "rula_score_c",
        "rula_grand",
        "rula_action_level",
    ]
    body = [
        "rula_force",
        "rula_neck_band",
        "rula_neck_adjust",
        "rula_neck",
        "rula_trunk_band",
        "rula_trunk_adjust",
        "rula_trunk",
        "rula_legs",
        "rula_table_b",
        "rula_static_b",
        "rula_repeated_b",
        "rula_muscle_b",
        "rula_score_d",
    ]
    worse = ["rula_grand", "rula_action_level", "rula_worse_side", "rula_unknown_flags"]
    return [f"{s}{c}" for s in SIDES for c in side] + body + worse


def reba_columns() -> list[str]:
    """Every column score_reba writes, in order."""
    group_a = [
        "reba_neck_band",
        "reba_neck_adjust",
        "reba_neck",
        "reba_trunk_band",
        "reba_trunk_adjust",
        "reba_trunk",
        "reba_legs_band",
        "reba_knee",
        "reba_legs",
        "reba_table_a",
        "reba_load",
        "reba_score_a",
    ]
    side = [
        "reba_upper_arm_band",
        "reba_upper_arm_adjust",
        "reba_upper_arm",
        "reba_lower_arm",
        "reba_wrist_band",
        "reba_wrist_adjust",
        "reba_wrist",
        "reba_table_b",
    ]
    rest = [
        "reba_table_b",
        "reba_worse_side",
        "reba_coupling",
        "reba_score_b",
        "reba_table_c",
        "reba_static",
        "reba_repeated",
        "reba_rapid",
        "reba_activity",
        "reba_score",
        "reba_risk_level",
        "reba_unknown_flags",
    ]
    return group_a + [f"{s}{c}" for s in SIDES for c in side] + rest


#: Body-part posture bands (position score from the angle alone) that shift reports summarise.
BODY_PART_COLUMNS = {
    "rula": [
        "left_rula_upper_arm_band",
        "right_rula_upper_arm_band",
        "left_rula_lower_arm_band",
        "right_rula_lower_arm_band",
        "left_rula_wrist_band",
        "right_rula_wrist_band",
        "rula_neck_band",
        "rula_trunk_band",
        "rula_legs",
    ],
    "reba": [
        "reba_neck_band",
        "reba_trunk_band",
        "reba_legs",
        "left_reba_upper_arm_band",
        "right_reba_upper_arm_band",
        "left_reba_lower_arm",
        "right_reba_lower_arm",
        "left_reba_wrist_band",
        "right_reba_wrist_band",
    ],
}
#: The final score and its level per method (worse side for RULA).
LEVEL_COLUMNS = {"rula": ("rula_grand", "rula_action_level"), "reba": ("reba_score", "reba_risk_level")}

#: Angles whose actions count as repetitions (per side where prefixed).
REPETITION_ANGLES = (
    "neck_flexion",
    "trunk_flexion",
    "left_upper_arm_flexion",
    "right_upper_arm_flexion",
    "left_elbow_flexion",
    "right_elbow_flexion",
    "left_wrist_flexion",
    "right_wrist_flexion",
)
#: Angles whose rapid large-range changes count for REBA (whole-body posture changes).
RAPID_ANGLES = (
    "trunk_flexion",
    "left_upper_arm_flexion",
    "right_upper_arm_flexion",
    "left_knee_flexion",
    "right_knee_flexion",
)


# ------------------------------------------------------------------------- small helpers


#: Integer type of every score column: nullable, 2 bytes + 1 mask byte per value (Int64 would take
#: 9: ~1 GB for the ~90 columns of an 8-hour shift of 4 workers; scores never exceed 15).
SCORE_DTYPE = "Int16"
_NP_SCORE = np.int16


def _int_array(x: np.ndarray) -> pd.arrays.IntegerArray:
    """Float scores (NaN = missing) as a nullable integer array (SCORE_DTYPE)."""
    x = np.asarray(x, dtype=np.float64)
    mask = np.isnan(x)
    with np.errstate(invalid="ignore"):
        values = x.astype(_NP_SCORE)  # NaN casts to an arbitrary value, hidden by the mask
    return pd.arrays.IntegerArray(values, mask)


def band_scores(angle: np.ndarray, bands: Bands, settings: ScoringSettings, open_boundary: str) -> np.ndarray:
    """Position score per frame from an angle in radians (float; NaN where the angle is NaN)."""
    tol = getattr(settings, bands.tolerance_setting) if bands.tolerance_setting else 0.0
    edges, goes_up = bands.resolve(tolerance_deg=tol, open_boundary=open_boundary)
    x = np.asarray(angle, dtype=np.float64)
    idx = np.zeros(x.shape, dtype=np.intp)
    for e, up in zip(edges, goes_up):
        idx += (x >= e) if up else (x > e)
    out = np.asarray(bands.scores, dtype=np.float64)[idx]
    out[np.isnan(x)] = NAN
    return out


def lookup(table: ScoreTable, *scores: np.ndarray) -> np.ndarray:
    """Table value per frame from 1-based scores (float; NaN if any score is NaN).

    A score above an axis' size uses the last row/column (RULA's "8+" and "7+"); a score below 1
    uses the first (scores are never below 1 by construction).
    """
    if len(scores) != len(table.axes):
        raise ValueError(f"{table.name} takes {len(table.axes)} scores, got {len(scores)}")
    flat = np.zeros(np.shape(scores[0]), dtype=np.intp)
    valid = np.ones(np.shape(scores[0]), dtype=bool)
    stride = 1
    strides = []
    for size in reversed(table.sizes):
        strides.append(stride)
        stride *= size
    for s, size, st in zip(scores, table.sizes, reversed(strides)):
        s = np.asarray(s, dtype=np.float64)
        nan = np.isnan(s)
        valid = valid & ~nan
        with np.errstate(invalid="ignore"):
            i = np.clip(s, 1, size).astype(np.intp)  # NaN casts to garbage, masked below
        i -= 1
        np.clip(i, 0, size - 1, out=i)
        i *= st
        flat += i
    out = table.values.reshape(-1).astype(np.float64)[flat]
    out[~valid] = NAN
    return out


def _k_or(*xs: np.ndarray) -> np.ndarray:
    """Three-valued OR of 0/1/NaN arrays: 1 if any is 1, 0 if all are 0, NaN otherwise."""
    known_max = xs[0]
    strict_max = xs[0]
    for x in xs[1:]:
        known_max = np.fmax(known_max, x)  # NaN only where all are NaN
        strict_max = np.maximum(strict_max, x)  # NaN where any is NaN
    return np.where(known_max == 1, 1.0, strict_max)


def _k_and(*xs: np.ndarray) -> np.ndarray:
    """Three-valued AND of 0/1/NaN arrays: 0 if any is 0, 1 if all are 1, NaN otherwise."""
    known_min = xs[0]
    strict_min = xs[0]
    for x in xs[1:]:
        known_min = np.fmin(known_min, x)
        strict_min = np.minimum(strict_min, x)
    return np.where(known_min == 0, 0.0, strict_min)


def _k_not(x: np.ndarray) -> np.ndarray:
    return 1.0 - x


# ------------------------------------------------------------------------------ the inputs


_ACTIVITY_FLAGS = frozenset({"static_posture", "repeated_action", "rapid_change"})
_COMPOSITE = frozenset(
    {
        "arm_across_midline_or_out",
        "wrist_deviated_or_twisted",
        "neck_twisted_or_side_bent",
        "trunk_twisted_or_side_bent",
        "legs_supported_balanced",
        "unilateral_stance",
    }
)


class _Inputs:
    """Angles and yes/no inputs of one posture table, with the flag rules of docs/scoring.md.

    Leaves are the posture table's own inputs: a flag column where given (0/1), else the flag
    derived from a measured angle or distance with the settings' thresholds, else unknown (NaN).
    Composite flags combine leaves with three-valued logic. Under unknown_flags = "absent" an
    undetermined flag is evaluated with its unknown leaves as absent (0) and counted.
    """

    def __init__(self, table: pd.DataFrame, settings: ScoringSettings, shared: "_Shared"):
        self.t = table
        self.s = settings
        self.n = len(table)
        self.absent = settings.unknown_flags == "absent"
        self.unknown = np.zeros(self.n, dtype=np.int64)
        self._counted: set[tuple[str, str]] = set()
        self._leaf: dict[tuple[str, str], np.ndarray] = {}
        self.shared = shared
        self.activity: dict[tuple[str, str], np.ndarray] = {}

    # columns
    def col(self, name: str) -> np.ndarray | None:
        return self.shared.col(name)

    def angle(self, name: str, side: str = "") -> np.ndarray:
        x = self.col(side + name)
        if x is None:
            return np.full(self.n, NAN)
        return x

    def _above(self, name: str, side: str, threshold_deg: float, absolute: bool) -> np.ndarray | None:
        x = self.col(side + name)
        if x is None:
            return None
        v = np.abs(x) if absolute else x
        with np.errstate(invalid="ignore"):
            return np.where(np.isnan(x), NAN, (v > np.deg2rad(threshold_deg)).astype(np.float64))

    def _derived(self, name: str, side: str) -> np.ndarray | None:
        s = self.s
        if name == "shoulder_raised":
            return self._above("shoulder_elevation", side, s.shoulder_raised_deg, absolute=False)
        if name == "upper_arm_abducted":
            return self._above("upper_arm_abduction", side, s.upper_arm_abducted_deg, absolute=False)
        if name == "wrist_deviated":
            return self._above("wrist_deviation", side, s.wrist_deviated_deg, absolute=True)
        if name in ("neck_twisted", "neck_side_bent", "trunk_twisted", "trunk_side_bent"):
            part, what = name.split("_", 1)
            angle = {"twisted": "twist", "side_bent": "side_bend"}[what]
            return self._above(f"{part}_{angle}", "", getattr(s, f"{name}_deg"), absolute=True)
        if name in ("arm_across_midline", "arm_out_to_side"):
            x = self.col(side + "wrist_lateral_m")
            if x is None:
                return None
            with np.errstate(invalid="ignore"):
                hit = (x < -s.across_midline_m) if name == "arm_across_midline" else (x > s.out_to_side_m)
            return np.where(np.isnan(x), NAN, hit.astype(np.float64))
        if name in ("static_posture", "repeated_action", "rapid_change"):
            return self.activity.get((name, side))
        return None

    def _override(self, name: str, side: str, derived: np.ndarray | None) -> np.ndarray:
        given = self.col(side + name)
        if given is None:
            return derived if derived is not None else np.full(self.n, NAN)
        if derived is None:
            return given
        return np.where(np.isnan(given), derived, given)

    def leaf(self, name: str, side: str = "") -> np.ndarray:
        """A posture-table input (given flag, else derived), NaN where unknown."""
        key = (name, side)
        if key not in self._leaf:
            col_side = "" if name in ("static_posture", "repeated_action", "rapid_change") else side
            self._leaf[key] = self._override(name, col_side, self._derived(name, side))
        return self._leaf[key]

    def _value(self, name: str, side: str, get: Callable[[str, str], np.ndarray]) -> np.ndarray:
        if name == "arm_across_midline_or_out":
            return self._override(name, side, _k_or(get("arm_across_midline", side), get("arm_out_to_side", side)))
        if name == "wrist_deviated_or_twisted":
            return _k_or(get("wrist_deviated", side), get("wrist_twist_end_range", side))
        if name in ("neck_twisted_or_side_bent", "trunk_twisted_or_side_bent"):
            part = name.split("_", 1)[0]
            return _k_or(get(f"{part}_twisted", ""), get(f"{part}_side_bent", ""))
        if name == "legs_supported_balanced":
            return self._override("legs_supported", "", _k_not(_k_or(get("one_leg_stance", ""), get("walking", ""))))
        if name == "unilateral_stance":
            return _k_and(get("one_leg_stance", ""), _k_not(_k_or(get("walking", ""), get("seated", ""))))
        return get(name, side)

    def flag(self, name: str, side: str = "") -> np.ndarray:
        """A yes/no input as the scoring uses it (policy for unknown values applied)."""
        # flags of the posture table are the same for every method; activity flags are per method
        shared = name not in _ACTIVITY_FLAGS
        key = (name, side, self.absent)
        cached = self.shared.flags.get(key) if shared else None
        if cached is None:
            kleene = self._value(name, side, self.leaf)
            unknown = np.isnan(kleene)
            if not self.absent or not unknown.any():
                cached = (kleene, None)
            elif name in _COMPOSITE:
                cached = (self._value(name, side, self._filled_leaf), unknown)
            else:
                cached = (np.where(unknown, 0.0, kleene), unknown)
            if shared:
                self.shared.flags[key] = cached
        value, unknown = cached
        if unknown is not None and (name, side) not in self._counted:
            self._counted.add((name, side))
            self.unknown += unknown
        return value

    def _filled_leaf(self, name: str, side: str) -> np.ndarray:
        x = self.leaf(name, side)
        return np.where(np.isnan(x), 0.0, x)

    def assumed(self, name: str, unknown: np.ndarray) -> None:
        """Count an unknown non-flag input (load, mode, coupling) assumed at its lowest."""
        if (name, "") not in self._counted and unknown.any():
            self._counted.add((name, ""))
            self.unknown += unknown


# ------------------------------------------------------------------------ time-series inputs


class _Shared:
    """Per-worker timelines and repetition events, shared by RULA and REBA in one call."""

    def __init__(self, table: pd.DataFrame, settings: ScoringSettings):
        self.table = table
        self.s = settings
        self.has_time = "time_s" in table.columns
        self._groups: list[np.ndarray] | None = None
        self._timelines: list[act.Timeline] = []
        self._rates: dict[str, np.ndarray] = {}
        self._cols: dict[str, np.ndarray | None] = {}
        self.flags: dict[tuple[str, str, bool], tuple[np.ndarray, np.ndarray | None]] = {}  # (name, side, absent)

    def category(self, name: str, mapping: Mapping[str, int]) -> np.ndarray:
        """A text column mapped to numbers (float; NaN where missing or absent)."""
        key = f"category:{name}:{sorted(mapping.items())}"
        if key not in self._cols:
            out = np.full(len(self.table), NAN)
            if name in self.table.columns:
                codes, uniques = pd.factorize(self.table[name], use_na_sentinel=True)
                lut = np.array([mapping.get(str(u), NAN) for u in uniques] + [NAN], dtype=np.float64)
                out = lut[codes]  # code -1 (missing) picks the trailing NaN
            self._cols[key] = out
            return out
        category = self._cols[key]
        assert category is not None  # stored above, never None
        return category

    def col(self, name: str) -> np.ndarray | None:
        """A numeric column as float64 (NaN = missing), or None if the table lacks it."""
        if name not in self._cols:
            if name in self.table.columns:
                x = self.table[name].to_numpy(dtype=np.float64, na_value=np.nan, copy=False)
                x.setflags(write=False)
                self._cols[name] = x
            else:
                self._cols[name] = None
        return self._cols[name]

    def groups(self) -> list[np.ndarray]:
        if self._groups is None:
            n = len(self.table)
            if "worker" in self.table.columns:
                codes, _ = pd.factorize(self.table["worker"], use_na_sentinel=False)
                order = np.argsort(codes, kind="stable")
                bounds = np.flatnonzero(np.diff(codes[order])) + 1
                self._groups = np.split(order, bounds) if n else []
            else:
                self._groups = [np.arange(n)] if n else []
            t = self.col("time_s")
            if t is None:
                raise ValueError("worker timelines need the time_s column (callers check has_time)")
            for g in self._groups:
                try:
                    act.check_time(t[g])
                except InputError as exc:
                    who = ""
                    if "worker" in self.table.columns:
                        who = f" (worker {self.table['worker'].iloc[g[0]]})"
                    raise InputError(f"{exc}{who}") from None
                self._timelines.append(act.Timeline(t[g]))
        return self._groups

    def timelines(self) -> list[act.Timeline]:
        self.groups()
        return self._timelines

    def events(self, angle_col: str) -> np.ndarray:
        """True at each action (repetition) of one angle column."""
        key = "events:" + angle_col
        if key not in self._rates:
            out = np.zeros(len(self.table), dtype=bool)
            x = self.col(angle_col)
            if x is not None:
                amp = np.deg2rad(self.s.repetition_amplitude_deg)
                for g, tl in zip(self.groups(), self.timelines()):
                    out[g] = act.repetition_events(
                        tl.time_s, x[g], amp, self.s.repetition_window_s, period_s=tl.period_s
                    )
            self._rates[key] = out
        return self._rates[key]

    def rate(self, angle_col: str) -> np.ndarray:
        """Actions in the repetition window around each frame, for one angle column."""
        if angle_col not in self._rates:
            out = np.zeros(len(self.table), dtype=np.int64)
            if self.col(angle_col) is not None:
                ev = self.events(angle_col)
                for g, tl in zip(self.groups(), self.timelines()):
                    out[g] = tl.count_centred(ev[g], self.s.repetition_window_s)
            self._rates[angle_col] = out
        return self._rates[angle_col]

    def held(self, band: np.ndarray, hold_s: float, neutral: float | None) -> np.ndarray:
        out = np.zeros(len(self.table), dtype=bool)
        for g, tl in zip(self.groups(), self.timelines()):
            out[g] = act.held(
                tl.time_s, band[g], hold_s, max_gap_s=self.s.max_gap_s, neutral=neutral, period_s=tl.period_s
            )
        return out

    def rapid(self, angles: Sequence[np.ndarray]) -> np.ndarray:
        out = np.zeros(len(self.table), dtype=bool)
        change = np.deg2rad(self.s.rapid_change_deg)
        for g, tl in zip(self.groups(), self.timelines()):
            out[g] = tl.rapid_change([a[g] for a in angles], change, self.s.rapid_change_window_s)
        return out


def _needs_time_series(inp: _Inputs, names: Iterable[str]) -> bool:
    for name in names:
        given = inp.col(name)
        if given is None or np.isnan(given).any():
            return True
    return False


def _neutral(bands: Bands, settings: ScoringSettings) -> float | None:
    return None if settings.static_includes_neutral else float(min(bands.scores))


# ----------------------------------------------------------------------------- shared steps


def _step(
    inp: _Inputs,
    method: Method,
    part: str,
    side: str,
    variant: str,
    open_boundary: str,
    angle: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(band, adjust, adjusted step score) of one body part."""
    bands = method.bands[part]
    band = band_scores(inp.angle(bands.angle, side) if angle is None else angle, bands, inp.s, open_boundary)
    adjustment = bands.variants.get(variant, bands.adjustment) if variant != "single" else bands.adjustment
    adjust = np.zeros(inp.n)
    for flag, points in adjustment.points.items():
        adjust = adjust + points * inp.flag(flag, side)
    lo, hi = adjustment.adjusted_range
    step = np.clip(band + adjust, lo, hi)
    return band, adjust, step


def _load_score(inp: _Inputs, method: Method) -> np.ndarray:
    rule = method.load
    kg = inp.col("load_kg")
    kg = np.full(inp.n, NAN) if kg is None else kg
    unknown_kg = np.isnan(kg)
    if inp.absent:
        inp.assumed("load_kg", unknown_kg)
        kg = np.where(unknown_kg, 0.0, kg)
    row = np.zeros(inp.n, dtype=np.intp)
    for e, rule_at in zip(rule.edges_kg, rule.at_edge):
        row += (kg >= e) if rule_at == "higher" else (kg > e)
    mode = inp.shared.category("load_mode", rule.modes)
    unknown_mode = np.isnan(mode)
    col = np.where(unknown_mode, rule.modes["intermittent"], mode).astype(np.intp)
    score = rule.table[row, col].astype(np.float64)
    if rule.table.shape[1] > 1:
        # the mode matters only where the table's columns differ for the load band
        matters = rule.table[row, :].min(axis=1) != rule.table[row, :].max(axis=1)
        if inp.absent:
            inp.assumed("load_mode", unknown_mode & matters)
        else:
            score[unknown_mode & matters] = NAN
    shock = inp.flag("shock")
    if rule.shock_score is not None:
        score = np.where(shock == 1, np.maximum(score, rule.shock_score), np.where(np.isnan(shock), NAN, score))
    else:
        score = score + rule.shock_add * shock
    score[np.isnan(kg)] = NAN
    return score


def _finish(
    columns: dict[str, np.ndarray], order: list[str], index: pd.Index, text: Mapping[str, object]
) -> pd.DataFrame:
    data = {}
    for name in order:
        if name in text:
            data[name] = text[name]
        else:
            data[name] = _int_array(columns[name])
    return pd.DataFrame(data, index=index, copy=False)


def _worse(
    left: np.ndarray, right: np.ndarray, left_tie: np.ndarray | None = None, right_tie: np.ndarray | None = None
) -> tuple[np.ndarray, pd.Categorical]:
    """The higher of two sides (NaN if either is NaN) and which side it was."""
    both = ~(np.isnan(left) | np.isnan(right))
    worse = np.where(both, np.fmax(left, right), NAN)
    lk, rk = left.copy(), right.copy()
    if left_tie is not None and right_tie is not None:
        tie = left == right
        lk = np.where(tie, left_tie, left)
        rk = np.where(tie, right_tie, right)
    codes = np.where(lk > rk, 0, np.where(rk > lk, 1, 2)).astype(np.int8)
    codes[~both] = -1
    labels = pd.Categorical.from_codes(codes, categories=WORSE_SIDE_LABELS)
    return worse, labels


# ------------------------------------------------------------------------------------- RULA


def score_rula(
    posture: pd.DataFrame,
    settings: ScoringSettings | None = None,
    *,
    method: Method | None = None,
    progress: ProgressCallback | None = None,
    _shared: _Shared | None = None,
) -> pd.DataFrame:
    """RULA step scores for every frame of a posture table (radians); columns: :func:`rula_columns`."""
    s = settings or ScoringSettings()
    m = method or load_method("rula")
    table = posture if _shared is not None else prepare(posture, "rula")
    shared = _shared or _Shared(table, s)
    inp = _Inputs(table, s, shared)
    ob = s.rula_open_boundary
    variant = s.rula_lower_arm_adjust
    c: dict[str, np.ndarray] = {}
    report(progress, "rula", 0, 4, unit="step")

    for side in SIDES:
        for part, v in (("upper_arm", "single"), ("lower_arm", variant), ("wrist", "single")):
            band, adjust, step = _step(inp, m, part, side, v, ob)
            c[f"{side}rula_{part}_band"], c[f"{side}rula_{part}_adjust"], c[f"{side}rula_{part}"] = band, adjust, step
            # an adjustment is only meaningful where the band is known
            c[f"{side}rula_{part}_adjust"] = np.where(np.isnan(band), NAN, adjust)
        fs = m.flag_scores["wrist_twist"]
        twist = inp.flag(fs.flag, side)
        c[f"{side}rula_wrist_twist"] = np.where(np.isnan(twist), NAN, np.where(twist == 1, fs.scores[1], fs.scores[0]))
        c[f"{side}rula_table_a"] = lookup(
            m.tables["table_a"],
            c[f"{side}rula_upper_arm"],
            c[f"{side}rula_lower_arm"],
            c[f"{side}rula_wrist"],
            c[f"{side}rula_wrist_twist"],
        )
    for part in ("neck", "trunk"):
        band, adjust, step = _step(inp, m, part, "", "single", ob)
        c[f"rula_{part}_band"], c[f"rula_{part}"] = band, step
        c[f"rula_{part}_adjust"] = np.where(np.isnan(band), NAN, adjust)
    fs = m.flag_scores["legs"]
    legs = inp.flag(fs.flag)
    c["rula_legs"] = np.where(np.isnan(legs), NAN, np.where(legs == 1, fs.scores[1], fs.scores[0]))
    c["rula_table_b"] = lookup(m.tables["table_b"], c["rula_neck"], c["rula_trunk"], c["rula_legs"])
    report(progress, "rula", 1, 4, unit="step")

    # muscle use: static or repeated, per group (A per side: arm and wrist; B: neck and trunk)
    if shared.has_time and _needs_time_series(inp, ("static_posture", "repeated_action")):
        hold = s.rula_static_hold_s
        for side in SIDES:
            st = shared.held(c[f"{side}rula_upper_arm_band"], hold, _neutral(m.bands["upper_arm"], s)) | shared.held(
                c[f"{side}rula_wrist_band"], hold, _neutral(m.bands["wrist"], s)
            )
            rep = np.zeros(inp.n, dtype=bool)
            for a in ("upper_arm_flexion", "elbow_flexion", "wrist_flexion"):
                rep |= shared.rate(f"{side}{a}") >= s.rula_repetitions_per_min * s.repetition_window_s / 60.0
            inp.activity[("static_posture", side)] = st.astype(np.float64)
            inp.activity[("repeated_action", side)] = rep.astype(np.float64)
        st = shared.held(c["rula_neck_band"], hold, _neutral(m.bands["neck"], s)) | shared.held(
            c["rula_trunk_band"], hold, _neutral(m.bands["trunk"], s)
        )
        rep = np.zeros(inp.n, dtype=bool)
        for a in ("neck_flexion", "trunk_flexion"):
            rep |= shared.rate(a) >= s.rula_repetitions_per_min * s.repetition_window_s / 60.0
        inp.activity[("static_posture", "b")] = st.astype(np.float64)
        inp.activity[("repeated_action", "b")] = rep.astype(np.float64)
    report(progress, "rula", 2, 4, unit="step")

    force = _load_score(inp, m)
    c["rula_force"] = force
    muscle_pts = m.points["muscle_use"]
    for side, prefix, suffix in (("left_", "left_", ""), ("right_", "right_", ""), ("b", "", "_b")):
        static = inp.flag("static_posture", side)
        repeated = inp.flag("repeated_action", side)
        c[f"{prefix}rula_static{suffix}"] = static
        c[f"{prefix}rula_repeated{suffix}"] = repeated
        c[f"{prefix}rula_muscle{suffix}"] = muscle_pts * _k_or(static, repeated)
    for side in SIDES:
        c[f"{side}rula_score_c"] = c[f"{side}rula_table_a"] + c[f"{side}rula_muscle"] + force
    c["rula_score_d"] = c["rula_table_b"] + c["rula_muscle_b"] + force
    for side in SIDES:
        c[f"{side}rula_grand"] = lookup(m.tables["table_c"], c[f"{side}rula_score_c"], c["rula_score_d"])
        c[f"{side}rula_action_level"] = m.level_of(c[f"{side}rula_grand"])
    report(progress, "rula", 3, 4, unit="step")

    grand, side_label = _worse(
        c["left_rula_grand"], c["right_rula_grand"], c["left_rula_score_c"], c["right_rula_score_c"]
    )
    c["rula_grand"] = grand
    c["rula_action_level"] = m.level_of(grand)
    c["rula_unknown_flags"] = inp.unknown.astype(np.float64)
    out = _finish(c, rula_columns(), table.index, {"rula_worse_side": side_label})
    report(progress, "rula", 4, 4, unit="step")
    return out


# ------------------------------------------------------------------------------------- REBA


def score_reba(
    posture: pd.DataFrame,
    settings: ScoringSettings | None = None,
    *,
    method: Method | None = None,
    progress: ProgressCallback | None = None,
    _shared: _Shared | None = None,
) -> pd.DataFrame:
    """REBA step scores for every frame of a posture table (radians); columns: :func:`reba_columns`."""
    s = settings or ScoringSettings()
    m = method or load_method("reba")
    table = posture if _shared is not None else prepare(posture, "reba")
    shared = _shared or _Shared(table, s)
    inp = _Inputs(table, s, shared)
    ob = s.reba_open_boundary
    variant = s.reba_twist_side_adjust
    c: dict[str, np.ndarray] = {}
    report(progress, "reba", 0, 4, unit="step")

    for part in ("neck", "trunk"):
        band, adjust, step = _step(inp, m, part, "", variant, ob)
        c[f"reba_{part}_band"], c[f"reba_{part}"] = band, step
        c[f"reba_{part}_adjust"] = np.where(np.isnan(band), NAN, adjust)
    fs = m.flag_scores["legs"]
    unilateral = inp.flag(fs.flag)
    legs_band = np.where(np.isnan(unilateral), NAN, np.where(unilateral == 1, fs.scores[1], fs.scores[0]))
    knee_bands = m.bands["knee"]
    knee_angle = np.fmax(inp.angle("knee_flexion", "left_"), inp.angle("knee_flexion", "right_"))
    knee_angle[np.isnan(inp.angle("knee_flexion", "left_")) | np.isnan(inp.angle("knee_flexion", "right_"))] = NAN
    knee = band_scores(knee_angle, knee_bands, s, ob)
    assert knee_bands.not_when is not None  # load_method requires knee.not_when
    seated = inp.flag(knee_bands.not_when)
    knee = np.where(seated == 1, 0.0, np.where(np.isnan(seated), NAN, knee))
    c["reba_legs_band"] = legs_band
    c["reba_knee"] = knee
    lo, hi = knee_bands.adjustment.adjusted_range
    c["reba_legs"] = np.clip(legs_band + knee, lo, hi)
    c["reba_table_a"] = lookup(m.tables["table_a"], c["reba_trunk"], c["reba_neck"], c["reba_legs"])
    c["reba_load"] = _load_score(inp, m)
    c["reba_score_a"] = c["reba_table_a"] + c["reba_load"]
    report(progress, "reba", 1, 4, unit="step")

    for side in SIDES:
        for part in ("upper_arm", "wrist"):
            band, adjust, step = _step(inp, m, part, side, "single", ob)
            c[f"{side}reba_{part}_band"], c[f"{side}reba_{part}"] = band, step
            c[f"{side}reba_{part}_adjust"] = np.where(np.isnan(band), NAN, adjust)
        _, _, lower = _step(inp, m, "lower_arm", side, "single", ob)
        c[f"{side}reba_lower_arm"] = lower
        c[f"{side}reba_table_b"] = lookup(
            m.tables["table_b"], c[f"{side}reba_upper_arm"], c[f"{side}reba_lower_arm"], c[f"{side}reba_wrist"]
        )
    table_b, side_label = _worse(c["left_reba_table_b"], c["right_reba_table_b"])
    c["reba_table_b"] = table_b
    cpl = inp.shared.category("coupling", m.coupling).copy()
    unknown_cpl = np.isnan(cpl)
    if inp.absent:
        inp.assumed("coupling", unknown_cpl)
        cpl[unknown_cpl] = min(m.coupling.values())
    c["reba_coupling"] = cpl
    c["reba_score_b"] = table_b + cpl
    c["reba_table_c"] = lookup(m.tables["table_c"], c["reba_score_a"], c["reba_score_b"])
    report(progress, "reba", 2, 4, unit="step")

    if shared.has_time and _needs_time_series(inp, ("static_posture", "repeated_action", "rapid_change")):
        hold = s.reba_static_hold_s
        st = np.zeros(inp.n, dtype=bool)
        for col, part in (
            ("reba_neck_band", "neck"),
            ("reba_trunk_band", "trunk"),
            ("left_reba_upper_arm_band", "upper_arm"),
            ("right_reba_upper_arm_band", "upper_arm"),
            ("left_reba_wrist_band", "wrist"),
            ("right_reba_wrist_band", "wrist"),
        ):
            st |= shared.held(c[col], hold, _neutral(m.bands[part], s))
        rep = np.zeros(inp.n, dtype=bool)
        for a in REPETITION_ANGLES:
            rep |= shared.rate(a) > s.reba_repetitions_per_min * s.repetition_window_s / 60.0
        rapid = shared.rapid([inp.angle(a) for a in RAPID_ANGLES])
        inp.activity[("static_posture", "")] = st.astype(np.float64)
        inp.activity[("repeated_action", "")] = rep.astype(np.float64)
        inp.activity[("rapid_change", "")] = rapid.astype(np.float64)
    static = inp.flag("static_posture")
    repeated = inp.flag("repeated_action")
    walking = inp.flag("walking")
    # "repeated small-range actions (not walking)": no repetitions while walking
    repeated = np.where(walking == 1, 0.0, np.where(np.isnan(walking) & (repeated != 0), NAN, repeated))
    rapid = inp.flag("rapid_change")
    c["reba_static"], c["reba_repeated"], c["reba_rapid"] = static, repeated, rapid
    c["reba_activity"] = m.points["static"] * static + m.points["repeated"] * repeated + m.points["rapid"] * rapid
    c["reba_score"] = c["reba_table_c"] + c["reba_activity"]
    c["reba_risk_level"] = m.level_of(c["reba_score"])
    c["reba_unknown_flags"] = inp.unknown.astype(np.float64)
    report(progress, "reba", 3, 4, unit="step")
    out = _finish(c, reba_columns(), table.index, {"reba_worse_side": side_label})
    report(progress, "reba", 4, 4, unit="step")
    return out


# ------------------------------------------------------------------------------- both at once

_SCORERS = {"rula": score_rula, "reba": score_reba}


def score_posture(
    posture: pd.DataFrame,
    methods: Sequence[str] = ("rula", "reba"),
    settings: ScoringSettings | None = None,
    *,
    progress: ProgressCallback | None = None,
    method_data: Mapping[str, Method] | None = None,
    with_events: bool = False,
) -> pd.DataFrame:
    """Score a posture table with several methods (time-series work shared); columns concatenated.

    with_events: also return ``rep_<angle>`` columns (Int16 0/1: an action of that angle ends its
    rise at this frame; see ergopose.ergonomics.activity) for the shift aggregation.
    """
    s = settings or ScoringSettings()
    unknown = [m for m in methods if m not in _SCORERS]
    if unknown:
        raise InputError(f"unknown scoring method(s): {', '.join(unknown)}; expected rula or reba", field="method")
    if not methods:
        return pd.DataFrame(index=posture.index)
    table = prepare(posture, tuple(methods))  # the union of the requirements, one clear error
    shared = _Shared(table, s)
    parts = []
    for name in methods:
        m = (method_data or {}).get(name) or load_method(name)
        parts.append(_SCORERS[name](table, s, method=m, progress=progress, _shared=shared))
    if with_events:
        events = {}
        if shared.has_time:
            for a in REPETITION_ANGLES:
                if shared.col(a) is not None:
                    events[f"rep_{a}"] = _int_array(shared.events(a).astype(np.float64))
        parts.append(pd.DataFrame(events, index=table.index, copy=False))
    return pd.concat(parts, axis=1)


__all__ = [
    "score_rula",
    "score_reba",
    "score_posture",
    "rula_columns",
    "reba_columns",
    "band_scores",
    "lookup",
    "BODY_PART_COLUMNS",
    "LEVEL_COLUMNS",
    "REPETITION_ANGLES",
    "RAPID_ANGLES",
]
