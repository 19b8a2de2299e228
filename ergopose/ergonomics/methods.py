"""RULA and REBA as declarative data: load and validate assessments/rula.toml and reba.toml.

The files hold the bands (edges in degrees and which band an edge value belongs to), the
adjustments, Tables A, B and C, the load rules and the action levels, with comments citing the
source. :func:`load_method` reads one, checks it (shapes of tables, scores in range, tables
monotone, bands monotone away from the neutral band, the tables' sizes matching the scores
that index them, action levels covering the score range) and returns a frozen :class:`Method`.
A malformed file raises one ConfigError naming the file and the field.

Scoring (ergopose.ergonomics.scoring) reads everything it needs from a Method; nothing of the
standards' numbers is repeated in the code.
"""

from __future__ import annotations

import functools
import math
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from ergopose.ergonomics.settings import setting_names
from ergopose.errors import ConfigError
from ergopose.resources import resource_dir

AT_EDGE_CHOICES = ("higher", "lower", "setting", "tolerance")
LOAD_MODES = ("intermittent", "static", "repeated")
COUPLINGS = ("good", "fair", "poor", "unacceptable")

#: yes/no inputs an adjustment may name (ergopose.ergonomics.scoring defines each one).
SIDE_FLAGS = frozenset(
    {
        "shoulder_raised",
        "upper_arm_abducted",
        "arm_supported",
        "arm_across_midline_or_out",
        "arm_across_midline",
        "arm_out_to_side",
        "wrist_deviated",
        "wrist_twist_end_range",
        "wrist_deviated_or_twisted",
    }
)
BODY_FLAGS = frozenset(
    {
        "neck_twisted",
        "neck_side_bent",
        "neck_twisted_or_side_bent",
        "trunk_twisted",
        "trunk_side_bent",
        "trunk_twisted_or_side_bent",
        "legs_supported_balanced",
        "unilateral_stance",
        "seated",
    }
)
KNOWN_FLAGS = SIDE_FLAGS | BODY_FLAGS


@dataclass(frozen=True)
class Adjustment:
    """Yes/no adjustments added to a posture score: flag name -> points; the adjusted range."""

    points: Mapping[str, int]
    adjusted_range: tuple[int, int]


@dataclass(frozen=True)
class Bands:
    """A body part scored from one angle.

    edges_deg: where the score changes (degrees, ascending); scores: one per band (len(edges)+1).
    at_edge: per edge, "higher" / "lower" (band with the higher/lower score takes an angle exactly
    on the edge), "setting" (the open-boundary setting decides), "tolerance" (edge of a single-
    point posture, moved away from the neutral band by the setting ``tolerance_setting``).
    adjustment: the standard's adjustments; variants: worksheet variants by name ("separate").
    not_when: a flag that cancels the score (REBA knee while seated) or None.
    """

    name: str
    angle: str
    criterion: str
    edges_deg: tuple[float, ...]
    scores: tuple[int, ...]
    at_edge: tuple[str, ...]
    tolerance_setting: str | None
    adjustment: Adjustment
    variants: Mapping[str, Adjustment]
    not_when: str | None = None

    def resolve(self, *, tolerance_deg: float, open_boundary: str) -> tuple[np.ndarray, np.ndarray]:
        """Edges in RADIANS and, per edge, whether an angle exactly on it goes to the band above.

        A band index is then sum over edges of (angle >= edge if goes_up else angle > edge).
        """
        if open_boundary not in ("higher", "lower"):
            raise ConfigError(f"expected higher or lower, got {open_boundary!r}", field="open_boundary")
        edges = np.array(self.edges_deg, dtype=np.float64)
        goes_up = np.zeros(len(edges), dtype=bool)
        for k, rule in enumerate(self.at_edge):
            below, above = self.scores[k], self.scores[k + 1]
            if rule == "setting":
                rule = open_boundary
            if rule == "higher":
                goes_up[k] = above > below
            elif rule == "lower":
                goes_up[k] = above < below
            else:  # tolerance: the neutral (lower-scoring) band keeps the moved edge
                goes_up[k] = above < below
                edges[k] += tolerance_deg if above > below else -tolerance_deg
        if np.any(np.diff(edges) < 0):
            raise ConfigError(
                f"the tolerance {tolerance_deg} degrees makes the {self.name} bands overlap (edges {edges.tolist()})",
                field=self.tolerance_setting or self.name,
            )
        return np.deg2rad(edges), goes_up


@dataclass(frozen=True)
class FlagScore:
    """A step scored from one yes/no input: scores[0] when absent, scores[1] when present."""

    name: str
    criterion: str
    flag: str
    scores: tuple[int, int]


@dataclass(frozen=True)
class ScoreTable:
    """A lookup table: axes (row axes then column axes), sizes, values indexed by 1-based scores.

    values has shape ``sizes`` (read-only int64). A score above an axis' size uses the last row
    or column (RULA's "8+" and "7+", and worksheet variants that exceed a table).
    """

    name: str
    axes: tuple[str, ...]
    sizes: tuple[int, ...]
    value_range: tuple[int, int]
    values: np.ndarray


@dataclass(frozen=True)
class LoadRule:
    """Load/force score: load bands (kg) x load mode -> score; shock sets or adds points."""

    criterion: str
    edges_kg: tuple[float, ...]
    at_edge: tuple[str, ...]
    modes: Mapping[str, int]
    table: np.ndarray
    shock_score: int | None
    shock_add: int

    @property
    def max_score(self) -> int:
        top = int(self.table.max()) + self.shock_add
        return max(top, self.shock_score or 0)


@dataclass(frozen=True)
class ActionLevel:
    """An action (RULA) or risk (REBA) level: the score range it covers and its wording."""

    level: int
    low: int
    high: int
    label: str
    wording: str


@dataclass(frozen=True, eq=False)
class Method:
    """One scoring method as read from its TOML file (see assessments/rula.toml).

    Compared and hashed by identity (load_method caches one per file version)."""

    name: str
    title: str
    source: str
    path: Path
    sides: str
    score_range: tuple[int, int]
    bands: Mapping[str, Bands]
    flag_scores: Mapping[str, FlagScore]
    tables: Mapping[str, ScoreTable]
    load: LoadRule
    points: Mapping[str, int]
    coupling: Mapping[str, int]
    action_levels: tuple[ActionLevel, ...]

    def level_of(self, scores: np.ndarray) -> np.ndarray:
        """Action level per score (float array, NaN where the score is NaN)."""
        scores = np.asarray(scores, dtype=np.float64)
        lut = np.full(self.score_range[1] + 1, np.nan)
        for lv in self.action_levels:
            lut[lv.low : lv.high + 1] = lv.level
        idx = np.where(np.isnan(scores), 0, np.clip(np.nan_to_num(scores), 0, self.score_range[1])).astype(np.intp)
        return np.where(np.isnan(scores), np.nan, lut[idx])

    def level(self, level: int) -> ActionLevel:
        for lv in self.action_levels:
            if lv.level == level:
                return lv
        raise KeyError(level)


# --------------------------------------------------------------------------- the schemas

_SCHEMA: dict[str, dict[str, Any]] = {
    "rula": {
        "bands": ("upper_arm", "lower_arm", "wrist", "neck", "trunk"),
        "flag_scores": ("wrist_twist", "legs"),
        "tables": ("table_a", "table_b", "table_c"),
        "load": "force",
        "points": {"muscle_use": ("score",)},
        "sums": {"score_c": ["table_a", "muscle_use", "force"], "score_d": ["table_b", "muscle_use", "force"]},
        "coupling": False,
        # table axis -> the score that indexes it ("=" the size must equal its maximum,
        # "<=" the score may exceed the size: the last row/column is used)
        "axes": {
            "table_a": {
                "upper_arm": ("upper_arm", "="),
                "lower_arm": ("lower_arm", "="),
                "wrist": ("wrist", "="),
                "wrist_twist": ("wrist_twist", "="),
            },
            "table_b": {"neck": ("neck", "="), "trunk": ("trunk", "="), "legs": ("legs", "=")},
            "table_c": {"score_c": ("score_c", "<="), "score_d": ("score_d", "<=")},
        },
    },
    "reba": {
        "bands": ("neck", "trunk", "knee", "upper_arm", "lower_arm", "wrist"),
        "flag_scores": ("legs",),
        "tables": ("table_a", "table_b", "table_c"),
        "load": "load",
        "points": {"activity": ("static", "repeated", "rapid")},
        "sums": {"score_a": ["table_a", "load"], "score_b": ["table_b", "coupling"]},
        "coupling": True,
        "axes": {
            "table_a": {"trunk": ("trunk", "="), "neck": ("neck", "="), "legs": ("legs+knee", "=")},
            "table_b": {"upper_arm": ("upper_arm", "="), "lower_arm": ("lower_arm", "="), "wrist": ("wrist", "=")},
            "table_c": {"score_a": ("score_a", "="), "score_b": ("score_b", "=")},
        },
    },
}

_TOP_KEYS = {"method", "title", "source", "sides", "score_range", "action_levels"}


class _Reader:
    """Typed access to the TOML data that raises ConfigError(path, field)."""

    def __init__(self, path: Path):
        self.path = path

    def fail(self, field: str, message: str) -> ConfigError:
        return ConfigError(message, path=self.path, field=field)

    def table(self, data: Mapping[str, Any], key: str, field: str) -> Mapping[str, Any]:
        if key not in data:
            raise self.fail(field, "missing")
        value = data[key]
        if not isinstance(value, dict):
            raise self.fail(field, f"expected a table, got {type(value).__name__}")
        return value

    def optional_string(self, data: Mapping[str, Any], key: str, field: str) -> str | None:
        return self.string(data, key, field) if key in data else None

    def string(self, data: Mapping[str, Any], key: str, field: str) -> str:
        if key not in data:
            raise self.fail(field, "missing")
        value = data[key]
        if not isinstance(value, str) or not value.strip():
            raise self.fail(field, f"expected a non-empty text, got {value!r}")
        return value

    def integer(self, data: Mapping[str, Any], key: str, field: str) -> int:
        if key not in data:
            raise self.fail(field, "missing")
        value = data[key]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(field, f"expected a whole number, got {value!r}")
        return value

    def int_list(self, data: Mapping[str, Any], key: str, field: str, length: int | None = None) -> list[int]:
        value = self.any_list(data, key, field)
        for v in value:
            if isinstance(v, bool) or not isinstance(v, int):
                raise self.fail(field, f"expected whole numbers, got {v!r}")
        if length is not None and len(value) != length:
            raise self.fail(field, f"expected {length} entries, got {len(value)}")
        return list(value)

    def number_list(self, data: Mapping[str, Any], key: str, field: str) -> list[float]:
        value = self.any_list(data, key, field)
        out = []
        for v in value:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise self.fail(field, f"expected finite numbers, got {v!r}")
            out.append(float(v))
        return out

    def any_list(self, data: Mapping[str, Any], key: str, field: str) -> list[Any]:
        if key not in data:
            raise self.fail(field, "missing")
        value = data[key]
        if not isinstance(value, list):
            raise self.fail(field, f"expected a list, got {type(value).__name__}")
        return value

    def no_unknown(self, data: Mapping[str, Any], allowed: set[str], field: str) -> None:
        unknown = sorted(set(data) - allowed)
        if unknown:
            where = f"{field}." if field else ""
            raise ConfigError(
                f"unknown key(s): {', '.join(where + u for u in unknown)}", path=self.path, field=field or None
            )

    def range_pair(self, data: Mapping[str, Any], key: str, field: str) -> tuple[int, int]:
        lo, hi = self.int_list(data, key, field, length=2)
        if lo > hi:
            raise self.fail(field, f"the range [{lo}, {hi}] is reversed")
        return lo, hi


def _check_valley(r: _Reader, scores: list[int], field: str) -> None:
    """Scores fall to one minimum band and rise after it (worse the further from neutral)."""
    m = int(np.argmin(scores))
    left, right = scores[: m + 1], scores[m:]
    if any(b > a for a, b in zip(left, left[1:])) or any(b < a for a, b in zip(right, right[1:])):
        raise r.fail(field, f"scores {scores} must fall to the neutral band and rise away from it")
    if any(a == b for a, b in zip(scores, scores[1:])):
        raise r.fail(field, f"neighbouring bands have the same score in {scores}: merge them")


def _adjustment(
    r: _Reader, data: Mapping[str, Any], field: str, scores: list[int], extra_max: int = 0, require_adjust: bool = True
) -> Adjustment:
    points: dict[str, int] = {}
    if "adjust" in data:
        adjust = r.table(data, "adjust", f"{field}.adjust")
        for flag, value in adjust.items():
            f = f"{field}.adjust.{flag}"
            if flag not in KNOWN_FLAGS:
                raise r.fail(f, f"unknown flag; known flags: {', '.join(sorted(KNOWN_FLAGS))}")
            if isinstance(value, bool) or not isinstance(value, int) or value == 0 or abs(value) > 3:
                raise r.fail(f, f"expected a whole number of points between -3 and 3 (not 0), got {value!r}")
            points[flag] = value
    lo, hi = r.range_pair(data, "adjusted_range", f"{field}.adjusted_range")
    top = max(scores) + sum(v for v in points.values() if v > 0) + extra_max
    if hi != top:
        raise r.fail(
            f"{field}.adjusted_range",
            f"the highest adjusted score is {top} (highest band score plus the positive adjustments), not {hi}",
        )
    if lo < 1 or lo > min(scores):
        raise r.fail(
            f"{field}.adjusted_range", f"the lowest adjusted score must be between 1 and {min(scores)}, got {lo}"
        )
    return Adjustment(MappingProxyType(points), (lo, hi))


def _bands(r: _Reader, data: Mapping[str, Any], name: str, is_adjunct: bool = False) -> Bands:
    field = name
    r.no_unknown(
        data,
        {
            "angle",
            "criterion",
            "edges",
            "scores",
            "at_edge",
            "tolerance_setting",
            "adjust",
            "adjusted_range",
            "variant_separate",
            "not_when",
        },
        field,
    )
    angle = r.string(data, "angle", f"{field}.angle")
    criterion = r.string(data, "criterion", f"{field}.criterion")
    edges = r.number_list(data, "edges", f"{field}.edges")
    if not edges:
        raise r.fail(f"{field}.edges", "expected at least one edge")
    if any(abs(e) > 180 for e in edges):
        raise r.fail(f"{field}.edges", f"angles must lie within -180..180 degrees, got {edges}")
    scores = r.int_list(data, "scores", f"{field}.scores", length=len(edges) + 1)
    if min(scores) < 0:
        raise r.fail(f"{field}.scores", f"scores must not be negative, got {scores}")
    at_edge = r.any_list(data, "at_edge", f"{field}.at_edge")
    if len(at_edge) != len(edges):
        raise r.fail(f"{field}.at_edge", f"expected one entry per edge ({len(edges)}), got {len(at_edge)}")
    for v in at_edge:
        if v not in AT_EDGE_CHOICES:
            raise r.fail(f"{field}.at_edge", f"expected one of {', '.join(AT_EDGE_CHOICES)}, got {v!r}")
    for k in range(len(edges) - 1):
        if edges[k + 1] < edges[k]:
            raise r.fail(f"{field}.edges", f"edges must ascend, got {edges}")
        if edges[k + 1] == edges[k] and not (at_edge[k] == at_edge[k + 1] == "tolerance"):
            raise r.fail(
                f"{field}.edges", f"two edges at {edges[k]} only make sense around a single-point (tolerance) posture"
            )
    _check_valley(r, scores, f"{field}.scores")
    tol = r.optional_string(data, "tolerance_setting", f"{field}.tolerance_setting")
    if "tolerance" in at_edge and tol is None:
        raise r.fail(f"{field}.tolerance_setting", "required when an edge is a 'tolerance' edge")
    if tol is not None:
        if tol not in setting_names() or not tol.endswith("_deg"):
            raise r.fail(f"{field}.tolerance_setting", f"{tol!r} is not an angle setting of the scoring settings")
    not_when = r.optional_string(data, "not_when", f"{field}.not_when")
    if not_when is not None and not_when not in KNOWN_FLAGS:
        raise r.fail(f"{field}.not_when", f"unknown flag {not_when!r}")
    if is_adjunct:  # points added to another step's score; adjusted_range is that step's range
        if "adjust" in data:
            raise r.fail(f"{field}.adjust", "points added to another score take no adjustments")
        adjustment = Adjustment(MappingProxyType({}), r.range_pair(data, "adjusted_range", f"{field}.adjusted_range"))
    else:
        adjustment = _adjustment(r, data, field, scores)
    variants: dict[str, Adjustment] = {}
    if "variant_separate" in data:
        v = r.table(data, "variant_separate", f"{field}.variant_separate")
        r.no_unknown(v, {"adjust", "adjusted_range"}, f"{field}.variant_separate")
        variants["separate"] = _adjustment(r, v, f"{field}.variant_separate", scores)
    return Bands(
        name=name,
        angle=angle,
        criterion=criterion,
        edges_deg=tuple(edges),
        scores=tuple(scores),
        at_edge=tuple(at_edge),
        tolerance_setting=tol,
        adjustment=adjustment,
        variants=MappingProxyType(variants),
        not_when=not_when,
    )


def _flag_score(r: _Reader, data: Mapping[str, Any], name: str) -> FlagScore:
    r.no_unknown(data, {"criterion", "flag", "scores"}, name)
    flag = r.string(data, "flag", f"{name}.flag")
    if flag not in KNOWN_FLAGS:
        raise r.fail(f"{name}.flag", f"unknown flag {flag!r}")
    scores = r.int_list(data, "scores", f"{name}.scores", length=2)
    if min(scores) < 1:
        raise r.fail(f"{name}.scores", f"scores start at 1, got {scores}")
    return FlagScore(
        name=name, criterion=r.string(data, "criterion", f"{name}.criterion"), flag=flag, scores=(scores[0], scores[1])
    )


def _score_table(r: _Reader, data: Mapping[str, Any], name: str) -> ScoreTable:
    r.no_unknown(data, {"row_axes", "column_axes", "sizes", "range", "values"}, name)
    rows = r.any_list(data, "row_axes", f"{name}.row_axes")
    cols = r.any_list(data, "column_axes", f"{name}.column_axes")
    axes = [*rows, *cols]
    if not rows or not cols or not all(isinstance(a, str) for a in axes) or len(set(axes)) != len(axes):
        raise r.fail(f"{name}.row_axes", "expected distinct axis names for rows and columns")
    sizes_t = r.table(data, "sizes", f"{name}.sizes")
    r.no_unknown(sizes_t, set(axes), f"{name}.sizes")
    sizes = []
    for a in axes:
        s = r.integer(sizes_t, a, f"{name}.sizes.{a}")
        if s < 1:
            raise r.fail(f"{name}.sizes.{a}", f"expected a positive size, got {s}")
        sizes.append(s)
    lo, hi = r.range_pair(data, "range", f"{name}.range")
    if lo < 1:
        raise r.fail(f"{name}.range", f"table scores start at 1 or more, got {lo}")
    values = r.any_list(data, "values", f"{name}.values")
    n_rows = int(np.prod(sizes[: len(rows)]))
    n_cols = int(np.prod(sizes[len(rows) :]))
    if len(values) != n_rows:
        raise r.fail(
            f"{name}.values", f"expected {n_rows} rows ({' x '.join(map(str, sizes[: len(rows)]))}), got {len(values)}"
        )
    for i, row in enumerate(values):
        if not isinstance(row, list) or len(row) != n_cols:
            got = len(row) if isinstance(row, list) else type(row).__name__
            raise r.fail(f"{name}.values", f"row {i + 1}: expected {n_cols} values, got {got}")
        for v in row:
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise r.fail(f"{name}.values", f"row {i + 1}: expected whole numbers {lo}-{hi}, got {v!r}")
    arr = np.array(values, dtype=np.int64).reshape(sizes)
    for ax, a in enumerate(axes):
        d = np.diff(arr, axis=ax)
        if np.any(d < 0):
            where = np.argwhere(d < 0)[0]
            cell = ", ".join(f"{axes[k]} {where[k] + 1 + (1 if k == ax else 0)}" for k in range(len(axes)))
            raise r.fail(f"{name}.values", f"not monotone along {a}: the cell at {cell} is lower than the one before")
    arr.setflags(write=False)
    return ScoreTable(name=name, axes=tuple(axes), sizes=tuple(sizes), value_range=(lo, hi), values=arr)


def _load_rule(r: _Reader, data: Mapping[str, Any], name: str) -> LoadRule:
    r.no_unknown(data, {"criterion", "edges_kg", "at_edge", "modes", "table", "shock_score", "shock_add"}, name)
    edges = r.number_list(data, "edges_kg", f"{name}.edges_kg")
    if not edges or any(e <= 0 for e in edges) or any(b <= a for a, b in zip(edges, edges[1:])):
        raise r.fail(f"{name}.edges_kg", f"expected positive loads in ascending order, got {edges}")
    at_edge = r.any_list(data, "at_edge", f"{name}.at_edge")
    if len(at_edge) != len(edges) or any(v not in ("higher", "lower") for v in at_edge):
        raise r.fail(f"{name}.at_edge", "expected 'higher' or 'lower' for each load edge")
    modes_t = r.table(data, "modes", f"{name}.modes")
    if set(modes_t) != set(LOAD_MODES):
        raise r.fail(f"{name}.modes", f"expected exactly the load modes {', '.join(LOAD_MODES)}")
    table = r.any_list(data, "table", f"{name}.table")
    if len(table) != len(edges) + 1:
        raise r.fail(f"{name}.table", f"expected {len(edges) + 1} rows (one per load band), got {len(table)}")
    widths = {len(row) if isinstance(row, list) else -1 for row in table}
    if len(widths) != 1 or widths == {-1} or widths == {0}:
        raise r.fail(f"{name}.table", "expected rows of equal length")
    for row in table:
        for v in row:
            if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 3:
                raise r.fail(f"{name}.table", f"expected whole numbers 0-3, got {v!r}")
    arr = np.array(table, dtype=np.int64)
    if np.any(np.diff(arr, axis=0) < 0) or np.any(np.diff(arr, axis=1) < 0):
        raise r.fail(f"{name}.table", "a heavier load or a static/repeated mode must not score lower")
    modes = {}
    for m in LOAD_MODES:
        v = r.integer(modes_t, m, f"{name}.modes.{m}")
        if not 0 <= v < arr.shape[1]:
            raise r.fail(f"{name}.modes.{m}", f"expected a column of the table (0-{arr.shape[1] - 1}), got {v}")
        modes[m] = v
    shock_score = r.integer(data, "shock_score", f"{name}.shock_score") if "shock_score" in data else None
    shock_add = r.integer(data, "shock_add", f"{name}.shock_add") if "shock_add" in data else 0
    if (shock_score is None) == ("shock_add" not in data):
        raise r.fail(f"{name}", "give exactly one of shock_score (shock sets the score) or shock_add")
    if shock_score is not None and shock_score < int(arr.max()):
        raise r.fail(f"{name}.shock_score", f"a shock must not score lower than the table ({shock_score})")
    if not 0 <= shock_add <= 3:
        raise r.fail(f"{name}.shock_add", f"expected 0-3, got {shock_add}")
    arr.setflags(write=False)
    return LoadRule(
        criterion=r.string(data, "criterion", f"{name}.criterion"),
        edges_kg=tuple(edges),
        at_edge=tuple(at_edge),
        modes=MappingProxyType(modes),
        table=arr,
        shock_score=shock_score,
        shock_add=shock_add,
    )


def _action_levels(r: _Reader, data: Mapping[str, Any], score_range: tuple[int, int]) -> tuple[ActionLevel, ...]:
    items = r.any_list(data, "action_levels", "action_levels")
    levels: list[ActionLevel] = []
    expect_low = score_range[0]
    for i, item in enumerate(items):
        f = f"action_levels[{i + 1}]"
        if not isinstance(item, dict):
            raise r.fail(f, "expected a table")
        r.no_unknown(item, {"level", "scores", "label", "wording"}, f)
        level = r.integer(item, "level", f"{f}.level")
        low, high = r.range_pair(item, "scores", f"{f}.scores")
        if low != expect_low:
            raise r.fail(
                f"{f}.scores",
                f"expected the range to start at {expect_low} (levels must cover the "
                f"scores {score_range[0]}-{score_range[1]} without gaps), got {low}",
            )
        if levels and level <= levels[-1].level:
            raise r.fail(f"{f}.level", "levels must increase")
        levels.append(
            ActionLevel(
                level=level,
                low=low,
                high=high,
                label=r.string(item, "label", f"{f}.label"),
                wording=r.string(item, "wording", f"{f}.wording"),
            )
        )
        expect_low = high + 1
    if not levels or levels[-1].high != score_range[1]:
        raise r.fail("action_levels", f"the levels must cover the scores up to {score_range[1]}")
    return tuple(levels)


def _parse(path: Path, data: Mapping[str, Any], expected: str | None) -> Method:
    r = _Reader(path)
    name = r.string(data, "method", "method")
    if name not in _SCHEMA:
        raise r.fail("method", f"expected one of {', '.join(_SCHEMA)}, got {name!r}")
    if expected is not None and name != expected:
        raise r.fail("method", f"expected {expected!r}, got {name!r}")
    schema = _SCHEMA[name]
    allowed = (
        _TOP_KEYS
        | set(schema["bands"])
        | set(schema["flag_scores"])
        | set(schema["tables"])
        | {schema["load"]}
        | set(schema["points"])
        | set(schema["sums"])
        | ({"coupling"} if schema["coupling"] else set())
    )
    r.no_unknown(data, allowed, "")
    title = r.string(data, "title", "title")
    source = r.string(data, "source", "source")
    sides = r.string(data, "sides", "sides")
    if sides not in ("each", "worse"):
        raise r.fail("sides", f"expected each or worse, got {sides!r}")
    score_range = r.range_pair(data, "score_range", "score_range")

    bands = {b: _bands(r, r.table(data, b, b), b, is_adjunct=(b == "knee")) for b in schema["bands"]}
    flag_scores = {f: _flag_score(r, r.table(data, f, f), f) for f in schema["flag_scores"]}
    tables = {t: _score_table(r, r.table(data, t, t), t) for t in schema["tables"]}
    load = _load_rule(r, r.table(data, schema["load"], schema["load"]), schema["load"])
    points: dict[str, int] = {}
    for section, keys in schema["points"].items():
        t = r.table(data, section, section)
        r.no_unknown(t, {"criterion", *keys}, section)
        r.string(t, "criterion", f"{section}.criterion")
        for k in keys:
            v = r.integer(t, k, f"{section}.{k}")
            if not 0 <= v <= 3:
                raise r.fail(f"{section}.{k}", f"expected 0-3 points, got {v}")
            points[k if section != "muscle_use" else "muscle_use"] = v
    for section, parts in schema["sums"].items():
        t = r.table(data, section, section)
        r.no_unknown(t, {"parts"}, section)
        if r.any_list(t, "parts", f"{section}.parts") != parts:
            raise r.fail(f"{section}.parts", f"expected {parts}")
    coupling: dict[str, int] = {}
    if schema["coupling"]:
        t = r.table(data, "coupling", "coupling")
        r.no_unknown(t, {"criterion", "scores"}, "coupling")
        r.string(t, "criterion", "coupling.criterion")
        s = r.table(t, "scores", "coupling.scores")
        if set(s) != set(COUPLINGS):
            raise r.fail("coupling.scores", f"expected exactly {', '.join(COUPLINGS)}")
        for k in COUPLINGS:
            coupling[k] = r.integer(s, k, f"coupling.scores.{k}")
        vals = [coupling[k] for k in COUPLINGS]
        if vals != sorted(vals) or vals[0] < 0 or vals[-1] > 3:
            raise r.fail("coupling.scores", f"expected scores 0-3 rising from good to unacceptable, got {vals}")

    # the highest value each score can take, to check the tables' sizes against
    top: dict[str, int] = {b: bands[b].adjustment.adjusted_range[1] for b in bands}
    top.update({f: max(flag_scores[f].scores) for f in flag_scores})
    if "knee" in bands:
        top["legs+knee"] = max(flag_scores["legs"].scores) + max(bands["knee"].scores)
        expect = (min(flag_scores["legs"].scores), top["legs+knee"])
        if bands["knee"].adjustment.adjusted_range != expect:
            raise r.fail("knee.adjusted_range", f"the legs score plus the knee points spans {list(expect)}")
    contributions = {
        **{t: tables[t].value_range[1] for t in tables},
        schema["load"]: load.max_score,
        "coupling": max(coupling.values()) if coupling else 0,
    }
    contributions.update(points)
    for section, parts in schema["sums"].items():
        top[section] = sum(contributions[p] for p in parts)
    for tname, axes in schema["axes"].items():
        table = tables[tname]
        if set(table.axes) != set(axes):
            raise r.fail(f"{tname}.row_axes", f"expected the axes {', '.join(axes)}, got {', '.join(table.axes)}")
        for axis, (score, rule) in axes.items():
            size = table.sizes[table.axes.index(axis)]
            if (rule == "=" and size != top[score]) or (rule == "<=" and size > top[score]):
                raise r.fail(
                    f"{tname}.sizes.{axis}",
                    f"the {score.replace('+', ' + ')} score reaches {top[score]}, the table has {size}",
                )
    final_top = tables["table_c"].value_range[1] + sum(points.get(k, 0) for k in ("static", "repeated", "rapid"))
    if score_range != (1, final_top):
        raise r.fail("score_range", f"expected [1, {final_top}] (Table C plus the points added after it)")
    levels = _action_levels(r, data, score_range)
    if "knee" in bands and bands["knee"].not_when is None:
        raise r.fail("knee.not_when", "missing")
    return Method(
        name=name,
        title=title,
        source=source,
        path=path,
        sides=sides,
        score_range=score_range,
        bands=MappingProxyType(bands),
        flag_scores=MappingProxyType(flag_scores),
        tables=MappingProxyType(tables),
        load=load,
        points=MappingProxyType(points),
        coupling=MappingProxyType(coupling),
        action_levels=levels,
    )


def load_method_file(path: str | os.PathLike[str], expected: str | None = None) -> Method:
    """Read and validate one method file; ``expected`` ("rula"/"reba") checks its method key."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError("the scoring method file does not exist", path=p) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the scoring method file ({exc})", path=p) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML ({exc})", path=p) from None
    return _parse(p, data, expected)


@functools.lru_cache(maxsize=8)
def _cached(path: str, mtime_ns: int, expected: str) -> Method:
    return load_method_file(path, expected)


def load_method(name: str) -> Method:
    """The packaged method "rula" or "reba" (assessments/<name>.toml), validated and cached."""
    if name not in _SCHEMA:
        raise ConfigError(f"unknown scoring method {name!r}; expected one of {', '.join(_SCHEMA)}", field="method")
    path = resource_dir("assessments") / f"{name}.toml"
    try:
        mtime = path.stat().st_mtime_ns
    except FileNotFoundError:
        raise ConfigError("the scoring method file is missing; reinstall ergopose", path=path) from None
    return _cached(str(path), mtime, name)


__all__ = [
    "Adjustment",
    "Bands",
    "FlagScore",
    "ScoreTable",
    "LoadRule",
    "ActionLevel",
    "Method",
    "load_method",
    "load_method_file",
    "KNOWN_FLAGS",
    "SIDE_FLAGS",
    "BODY_FLAGS",
]
