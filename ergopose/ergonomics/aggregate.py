"""Shift aggregation per worker: distributions over time, holds, repetitions, episodes, exposure.

Input: the frames of ONE worker in time order, with the score columns of
ergopose.ergonomics.scoring (and, for the exposure standards and repetitions, the posture
table's angle columns and the ``rep_*`` action columns of ``score_posture(..., with_events=True)``).
Scores are ordinal: every result is a distribution over time (seconds and percent of the observed
time per level or band), a hold, a count or a rate -- never an average of scores.

Time: every frame stands for one frame period (``frame_period_s``; by default the median time
between the first chunk's frames), so the observed time is frames x period and a hold lasts from
its first to its last frame plus one period. Frames further apart than ``max_gap_s`` (tracking
lost) end a hold. Missing scores (<NA>) are counted as their own "missing" share.

Confidence (the frames' ``confidence`` and ``cause`` columns, ergopose.ergonomics.uncertainty):
the tracked time split into scored with confidence, scored with low confidence and unscored, each
with the time per cause -- seconds and percent of the tracked time, counted once here and shown as
such by the CSV files, the report and the terminal summary. Inputs: per body part (INPUT_GROUPS),
the median over the shift of the per-frame standard deviation of its angles (the largest of its
angles in a frame; from a histogram of 0.01 degree bins up to 90 degrees, so exact to 0.005
degree whatever the chunking) and the share of the tracked frames in which one of its joints was placed by the body
model (inferred) rather than seen by two cameras.

Task inputs (the frames' ``inputs_from_settings`` column, ergopose.ergonomics.task_inputs): per
input given by the settings in place of a hidden wrist angle, and per value used, the frames and
seconds of the scored time (a RULA or REBA grand score present) in which it was used, and their
percent of the scored time.

Chunks: :class:`ShiftAccumulator` takes the shift in pieces (``add`` each chunk, in order) and
gives exactly the answer of the whole series, because holds still open at the end of a chunk are
carried into the next one. :func:`aggregate_shift` is the one-call form.

Exposure (reference: rula-reba-reference.md, "Exposure over time"; docs/scoring.md):
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
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from ergopose.arrays import FloatArray
from ergopose.ergonomics.activity import check_time, frame_period
from ergopose.ergonomics.posture import expand_sides
from ergopose.ergonomics.scoring import BODY_PART_COLUMNS, REPETITION_ANGLES
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.ergonomics.task_inputs import COLUMN as TASK_INPUTS_COLUMN
from ergopose.ergonomics.task_inputs import SETTINGS_INPUTS, used_mask
from ergopose.ergonomics.uncertainty import CAUSES, CONFIDENCE_LEVELS, INPUT_GROUP_JOINTS, INPUT_GROUPS
from ergopose.errors import InputError
from ergopose.progress import ProgressCallback, report

#: Columns whose distribution over the shift is reported, when present.
DISTRIBUTION_COLUMNS = (
    "rula_action_level",
    "left_rula_action_level",
    "right_rula_action_level",
    "rula_grand",
    "reba_risk_level",
    "reba_score",
    *BODY_PART_COLUMNS["rula"],
    *BODY_PART_COLUMNS["reba"],
)
#: Level columns whose worst episodes are reported, with the score column giving the peak.
EPISODE_COLUMNS = {"rula_action_level": "rula_grand", "reba_risk_level": "reba_score"}
#: Prefix of the per-frame action (repetition) columns: rep_<angle column> = 1 at each action.
REPETITION_PREFIX = "rep_"

ISO_VERDICTS = ("acceptable", "time-limited", "not recommended")
EN_VERDICTS = ("acceptable", "conditionally acceptable", "not acceptable")


# ------------------------------------------------------------------------------ the results


@dataclass(frozen=True)
class ValueTime:
    """Time spent at one value (action level, band, score) over the shift.

    percent: of the worker's observed time (all frames, including frames without a score).
    holds: number of continuous holds; longest_hold_s and its start (NaN when never held).
    """

    value: int
    frames: int
    time_s: float
    percent: float
    holds: int
    longest_hold_s: float
    longest_hold_start_s: float


@dataclass(frozen=True)
class Distribution:
    """The distribution over time of one score column (ordinal: no averages)."""

    column: str
    frames: int
    time_s: float
    missing_frames: int
    missing_time_s: float
    missing_percent: float
    values: tuple[ValueTime, ...]

    def at(self, value: int) -> ValueTime:
        for v in self.values:
            if v.value == value:
                return v
        return ValueTime(value, 0, 0.0, 0.0, 0, 0.0, math.nan)


@dataclass(frozen=True)
class HourStats:
    """Time per value of one level column within one hour of the shift (hour 0 = first hour)."""

    column: str
    hour: int
    observed_s: float
    missing_s: float
    time_by_value: Mapping[int, float]

    def percent(self, value: int) -> float:
        return 100.0 * self.time_by_value.get(value, 0.0) / self.observed_s if self.observed_s else 0.0


@dataclass(frozen=True)
class Episode:
    """A continuous stretch at one level: the worst of the shift come first."""

    column: str
    level: int
    start_s: float
    end_s: float
    duration_s: float
    peak_score: int | None


@dataclass(frozen=True)
class Repetitions:
    """Actions of one angle (rises and falls by at least the repetition amplitude)."""

    angle: str
    actions: int
    per_minute: float
    max_in_one_minute: int
    minutes_at_or_above_4: int


@dataclass(frozen=True)
class ExposureFinding:
    """One body part against ISO 11226 (static holds) or EN 1005-4 (movement frequency).

    zone_time_s: observed time per zone name; static_*: holds longer than the static hold time
    (ISO); entries/per_minute: movements into the flagged zone (EN). verdict: the worst zone
    reached in the standard's sense (see the module doc); measured: False when the angles needed
    were not in the frames (verdict "not measured").
    """

    standard: str
    body_part: str
    verdict: str
    measured: bool
    zone_time_s: Mapping[str, float]
    static_time_s: Mapping[str, float]
    static_holds: Mapping[str, int]
    longest_static_hold_s: Mapping[str, float]
    entries: int
    per_minute: float


@dataclass(frozen=True)
class CauseTime:
    """Time with one cause of low confidence or of no score: cause (ergopose.ergonomics.uncertainty.
    CAUSES, or "not recorded"), frames, seconds, percent of the tracked time."""

    cause: str
    frames: int
    time_s: float
    percent: float


@dataclass(frozen=True)
class ConfidenceShare:
    """One part of the tracked time: level "confident" (both scores scored with confidence), "low"
    (scored with low confidence) or "unscored" (a score missing); frames, seconds, percent of the
    tracked time, and the time per cause (empty for "confident"; causes with no time left out)."""

    level: str
    frames: int
    time_s: float
    percent: float
    causes: tuple[CauseTime, ...]


@dataclass(frozen=True)
class InputCertainty:
    """How well one body part's RULA/REBA inputs were measured over the shift.

    body_part: in words (INPUT_GROUPS). angles: the angle columns. measured_frames: frames with
    one of the angles measured. median_sd_rad: the median over those frames of the largest
    standard deviation of its angles in the frame (radians; NaN when never measured or when the
    frames carry no deviations). inferred_frames: frames in which one of its joints was placed by
    the body model; known_frames: frames whose inferred flags were given (0 = unknown);
    inferred_percent: inferred_frames of known_frames (NaN when unknown).
    """

    body_part: str
    angles: tuple[str, ...]
    measured_frames: int
    median_sd_rad: float
    inferred_frames: int
    known_frames: int
    inferred_percent: float


@dataclass(frozen=True)
class SettingsInputTime:
    """A task input given by the settings and scored in place of a hidden measurement.

    input: the posture column (ergopose.ergonomics.task_inputs.SETTINGS_INPUTS, e.g.
    "left_wrist_flexion"); value_rad: the value used (radians); frames / time_s: the scored frames
    and seconds in which it was used; percent: of the scored time (frames with a RULA or REBA grand
    score).
    """

    input: str
    value_rad: float
    frames: int
    time_s: float
    percent: float


@dataclass(frozen=True)
class ShiftSummary:
    """Everything reported for one worker over a shift (or any stretch of frames)."""

    worker: str
    frames: int
    frame_period_s: float
    observed_s: float
    start_s: float
    end_s: float
    distributions: Mapping[str, Distribution]
    hourly: tuple[HourStats, ...]
    episodes: Mapping[str, tuple[Episode, ...]]
    repetitions: tuple[Repetitions, ...]
    exposure: tuple[ExposureFinding, ...]
    confidence: tuple[ConfidenceShare, ...] = ()
    inputs: tuple[InputCertainty, ...] = ()
    from_settings: tuple[SettingsInputTime, ...] = ()
    scored_frames: int = 0

    def confidence_of(self, level: str) -> ConfidenceShare | None:
        """The ConfidenceShare of a level ("confident", "low", "unscored"); None when the frames
        carried no confidence column."""
        for c in self.confidence:
            if c.level == level:
                return c
        return None

    def high_time_s(self, column: str, levels: Sequence[int] = (3, 4)) -> float:
        """Seconds at the given levels of a level column (0 when the column is absent)."""
        d = self.distributions.get(column)
        return float(sum(d.at(v).time_s for v in levels)) if d is not None else 0.0

    def scored_time_s(self, column: str) -> float:
        """Seconds with a value in a level column (tracked time less its missing time)."""
        d = self.distributions.get(column)
        return float(self.observed_s - d.missing_time_s) if d is not None else 0.0


#: Standard deviations of the inputs are counted in bins this wide (radians), _SD_BINS of them.
_SD_BIN_RAD = float(np.deg2rad(0.01))
_SD_BINS = 9000  # 0-90 degrees; larger deviations fall in the last bin
NOT_RECORDED = "not recorded"


def nominal_frame_period(time_s: np.ndarray) -> float:
    """1 / (frame rate rounded to 0.001 fps), the rate estimated from the median frame spacing.

    Rounding makes the estimate the same for any stretch of a recording (12 fps gives exactly
    1/12 s, 29.97 fps gives 1/29.97 s); 0 for fewer than two frames.
    """
    dt = frame_period(time_s)
    if dt <= 0:
        return 0.0
    fps = round(1.0 / dt, 3)
    return 1.0 / fps if fps > 0 else dt


# ---------------------------------------------------------------------- run accumulators


class _Runs:
    """Runs (holds) of an integer-coded series across chunks; -1 codes a missing frame."""

    def __init__(self, period_s: float, max_gap_s: float, static_s: float | None = None, top: int = 0):
        self.period = period_s
        self.max_gap = max_gap_s
        self.static_s = static_s
        self.frames: dict[int, int] = {}
        self.holds: dict[int, int] = {}
        self.longest: dict[int, tuple[float, float]] = {}  # value -> (duration, -start) for max
        self.static_time: dict[int, int] = {}  # frames inside static holds
        self.static_holds: dict[int, int] = {}
        self.top = top
        # episodes: (-level, -duration, start, end, peak)
        self.best: list[tuple[int, float, float, float, int | None]] = []
        self.open: tuple[int, float, float, int, float] | None = None  # value, start, last, frames, peak

    def add(self, t: np.ndarray, codes: np.ndarray, peaks: np.ndarray | None = None) -> None:
        n = codes.size
        if n == 0:
            return
        new = np.ones(n, dtype=bool)
        new[1:] = (codes[1:] != codes[:-1]) | (np.diff(t) > self.max_gap)
        first = np.flatnonzero(new)
        last = np.append(first[1:] - 1, n - 1)
        vals = codes[first]
        starts = t[first]
        ends = t[last]
        counts = last - first + 1
        if peaks is not None:
            pk = np.maximum.reduceat(np.where(np.isnan(peaks), -np.inf, peaks), first)
        else:
            pk = np.full(first.size, -np.inf)
        # join the run left open by the previous chunk
        if self.open is not None:
            ov, ostart, olast, oframes, opeak = self.open
            if ov == vals[0] and t[0] - olast <= self.max_gap:
                starts[0] = ostart
                counts[0] += oframes
                pk[0] = max(pk[0], opeak)
            else:
                self._close(
                    np.array([ov]), np.array([ostart]), np.array([olast]), np.array([oframes]), np.array([opeak])
                )
        self._close(vals[:-1], starts[:-1], ends[:-1], counts[:-1], pk[:-1])
        self.open = (int(vals[-1]), float(starts[-1]), float(ends[-1]), int(counts[-1]), float(pk[-1]))

    def _close(
        self, vals: np.ndarray, starts: np.ndarray, ends: np.ndarray, counts: np.ndarray, peaks: np.ndarray
    ) -> None:
        if vals.size == 0:
            return
        dur = ends - starts + self.period
        for v in np.unique(vals):
            sel = vals == v
            v = int(v)
            self.frames[v] = self.frames.get(v, 0) + int(counts[sel].sum())
            self.holds[v] = self.holds.get(v, 0) + int(sel.sum())
            d, s = dur[sel], starts[sel]
            k = int(np.argmax(d))  # first of the longest: earliest start among ties
            cand = (float(d[k]), -float(s[k]))
            if v not in self.longest or cand > self.longest[v]:
                self.longest[v] = cand
            if self.static_s is not None:
                st = d > self.static_s
                self.static_time[v] = self.static_time.get(v, 0) + int(counts[sel][st].sum())  # frames
                self.static_holds[v] = self.static_holds.get(v, 0) + int(st.sum())
        if self.top:
            keep = vals >= 0
            if keep.any():
                order = np.lexsort((starts[keep], -dur[keep], -vals[keep]))[: self.top]
                for i in order:
                    idx = np.flatnonzero(keep)[i]
                    pk = peaks[idx]
                    self.best.append(
                        (
                            -int(vals[idx]),
                            -float(dur[idx]),
                            float(starts[idx]),
                            float(ends[idx] + self.period),
                            None if np.isinf(pk) else int(pk),
                        )
                    )
                self.best.sort()
                del self.best[self.top :]

    def finish(self) -> None:
        if self.open is not None:
            v, s, last, frames, pk = self.open
            self.open = None
            self._close(np.array([v]), np.array([s]), np.array([last]), np.array([frames]), np.array([pk]))


def _codes(x: np.ndarray) -> np.ndarray:
    """Float values (NaN = missing) as int64 codes, -1 = missing."""
    out = np.full(x.shape, -1, dtype=np.int64)
    ok = ~np.isnan(x)
    out[ok] = x[ok].astype(np.int64)
    return out


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


# ----------------------------------------------------------------------------- exposure specs


@dataclass(frozen=True)
class _Exposure:
    standard: str
    body_part: str
    zone_names: tuple[str, ...]
    kind: str  # "iso" (static holds) or "en_arm" / "en_trunk" (frequency)


def _exposure_specs() -> list[_Exposure]:
    specs = [
        _Exposure("ISO 11226", "trunk", ("0-20", "20-60", ">60"), "iso"),
        _Exposure("ISO 11226", "head", ("<25", "25-85", ">85"), "iso"),
        _Exposure("ISO 11226", "neck", ("acceptable", "-", "flexion>25 or extension"), "iso"),
    ]
    for side in ("left", "right"):
        specs.append(_Exposure("ISO 11226", f"{side} upper arm", ("0-20", "20-60", ">60"), "iso"))
        specs.append(_Exposure("ISO 11226", f"{side} shoulder", ("not raised", "-", "raised"), "iso"))
    for side in ("left", "right"):
        specs.append(_Exposure("EN 1005-4", f"{side} upper arm", ("0-20", "20-60", ">60"), "en_arm"))
    specs.append(_Exposure("EN 1005-4", "trunk side bend or twist", ("<10", ">=10"), "en_trunk"))
    return specs


def _col(frames: pd.DataFrame, name: str) -> FloatArray | None:
    if name in frames.columns:
        column: FloatArray = frames[name].to_numpy(dtype=np.float64, na_value=np.nan)
        return column
    return None


def _exposure_zones(frames: pd.DataFrame, s: ScoringSettings) -> dict[str, np.ndarray | None]:
    """Zone index per frame for each exposure spec (None when the inputs are absent)."""
    n = len(frames)
    out: dict[str, np.ndarray | None] = {}
    trunk = _col(frames, "trunk_flexion")
    neck = _col(frames, "neck_flexion")
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
        elev = _col(frames, f"{side}_upper_arm_elevation")
        if elev is None:
            flex = _col(frames, f"{side}_upper_arm_flexion")
            abd = _col(frames, f"{side}_upper_arm_abduction")
            if flex is not None and abd is not None:
                elev = np.where(np.isnan(flex) | np.isnan(abd), np.nan, np.fmax(flex, abd))
            else:
                elev = flex
        zones = None if elev is None else _zones(elev, (20, 60), (False, False))
        out[f"ISO 11226|{side} upper arm"] = zones
        out[f"EN 1005-4|{side} upper arm"] = zones
        raised = _col(frames, f"{side}_shoulder_raised")
        elevation = _col(frames, f"{side}_shoulder_elevation")
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
    side_bend = _col(frames, "trunk_side_bend")
    twist = _col(frames, "trunk_twist")
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


# --------------------------------------------------------------------------- the accumulator


class ShiftAccumulator:
    """Aggregate one worker's frames chunk by chunk (each chunk continues the previous one).

    frame_period_s: time one frame stands for; None = :func:`nominal_frame_period` of the first chunk.
    settings: ScoringSettings (max_gap_s ends holds; thresholds for the exposure flags).
    static_hold_s: ISO 11226's static posture (held longer than 4 s).
    episodes: how many worst episodes to keep per level column.
    """

    def __init__(
        self,
        worker: str = "",
        *,
        frame_period_s: float | None = None,
        settings: ScoringSettings | None = None,
        static_hold_s: float = 4.0,
        episodes: int = 10,
        shift_start_s: float = 0.0,
    ):
        self.worker = worker
        self.s = settings or ScoringSettings()
        self.period = frame_period_s
        self.static_hold_s = static_hold_s
        self.n_episodes = episodes
        self.shift_start_s = shift_start_s
        self.frames = 0
        self.start_s = math.nan
        self.end_s = math.nan
        self.last_t: float | None = None
        self.runs: dict[str, _Runs] = {}
        self.exposure_runs: dict[str, _Runs] = {}
        self.hourly: dict[str, dict[tuple[int, int], int]] = {}
        self.hour_frames: dict[int, int] = {}
        self.rep_total: dict[str, int] = {}
        self.rep_minutes: dict[str, dict[int, int]] = {}
        self.columns: tuple[str, ...] | None = None
        self.exposure_present: dict[str, bool] = {}
        self.confidence_frames: dict[tuple[str, str], int] = {}  # (level, cause) -> frames
        self.input_sd_hist = np.zeros((len(INPUT_GROUPS), _SD_BINS), dtype=np.int64)
        self.input_measured = np.zeros(len(INPUT_GROUPS), dtype=np.int64)
        self.input_inferred = np.zeros(len(INPUT_GROUPS), dtype=np.int64)
        self.input_known = 0
        self.settings_frames: dict[tuple[str, float], int] = {}  # (input, value used) -> scored frames
        self.scored_frames = 0

    def add(self, frames: pd.DataFrame, inferred: np.ndarray | None = None) -> None:
        """Take the next chunk of frames (time order, after the previous chunk).

        inferred: (n, 33) joints placed by the body model, one row per frame (the tracks table's
        ``inferred``), for the inputs' inferred shares; None = not known for this chunk."""
        if len(frames) == 0:
            return
        if inferred is not None and np.shape(inferred)[0] != len(frames):
            raise ValueError(f"inferred has {np.shape(inferred)[0]} rows for {len(frames)} frames")
        frames = expand_sides(frames)
        if "time_s" not in frames.columns:
            raise InputError("the frames need a time_s column to be aggregated", field="time_s")
        t = check_time(frames["time_s"].to_numpy(dtype=np.float64, na_value=np.nan))
        if self.last_t is not None and t[0] <= self.last_t:
            raise InputError(
                f"this chunk starts at {t[0]:g} s, not after the previous chunk's end ({self.last_t:g} s)",
                field="time_s",
            )
        if self.period is None:
            self.period = nominal_frame_period(t)
        cols = tuple(c for c in DISTRIBUTION_COLUMNS if c in frames.columns)
        if self.columns is None:
            self.columns = cols
            for c in cols:
                top = self.n_episodes if c in EPISODE_COLUMNS else 0
                self.runs[c] = _Runs(self.period, self.s.max_gap_s, top=top)
        elif cols != self.columns:
            raise InputError("every chunk must carry the same score columns")
        self.frames += t.size
        if math.isnan(self.start_s):
            self.start_s = float(t[0])
        self.end_s = float(t[-1] + self.period)
        self.last_t = float(t[-1])

        hours = np.floor((t - self.shift_start_s) / 3600.0).astype(np.int64)
        uh, hc = np.unique(hours, return_counts=True)
        for h, k in zip(uh.tolist(), hc.tolist()):
            self.hour_frames[h] = self.hour_frames.get(h, 0) + k
        for c in self.columns:
            x = frames[c].to_numpy(dtype=np.float64, na_value=np.nan)
            codes = _codes(x)
            peak = None
            if c in EPISODE_COLUMNS and EPISODE_COLUMNS[c] in frames.columns:
                peak = frames[EPISODE_COLUMNS[c]].to_numpy(dtype=np.float64, na_value=np.nan)
            self.runs[c].add(t, codes, peak)
            if c in EPISODE_COLUMNS:
                key = hours * 64 + (codes + 1)
                uk, kc = np.unique(key, return_counts=True)
                table = self.hourly.setdefault(c, {})
                for k, cnt in zip(uk.tolist(), kc.tolist()):
                    hk = (k // 64, k % 64 - 1)
                    table[hk] = table.get(hk, 0) + cnt

        zones = _exposure_zones(frames, self.s)
        for key, z in zones.items():
            present = z is not None
            if key in self.exposure_present and self.exposure_present[key] != present:
                raise InputError(f"every chunk must carry the same angle columns ({key.split('|')[1]})")
            self.exposure_present[key] = present
            if z is None:
                continue
            if key not in self.exposure_runs:
                self.exposure_runs[key] = _Runs(self.period, self.s.max_gap_s, static_s=self.static_hold_s)
            self.exposure_runs[key].add(t, _codes(z))

        self._add_certainty(frames, inferred)
        self._add_task_inputs(frames)

        minutes = np.floor((t - self.shift_start_s) / 60.0).astype(np.int64)
        for angle in REPETITION_ANGLES:
            col = REPETITION_PREFIX + angle
            if col not in frames.columns:
                continue
            ev = frames[col].to_numpy(dtype=np.float64, na_value=0.0) > 0
            self.rep_total[angle] = self.rep_total.get(angle, 0) + int(ev.sum())
            per_min = self.rep_minutes.setdefault(angle, {})
            um, mc = np.unique(minutes[ev], return_counts=True)
            for m, k in zip(um.tolist(), mc.tolist()):
                per_min[m] = per_min.get(m, 0) + k

    def _add_certainty(self, frames: pd.DataFrame, inferred: np.ndarray | None) -> None:
        """Count the chunk's frames per confidence level and cause, and its inputs' deviations."""
        if "confidence" in frames.columns:
            level = frames["confidence"].astype("string").fillna("unscored").to_numpy(dtype=object)
            cause = (
                frames["cause"].astype("string").fillna("").to_numpy(dtype=object)
                if "cause" in frames.columns
                else np.full(len(frames), "", dtype=object)
            )
            cause = np.where(level == "confident", "", np.where(cause == "", NOT_RECORDED, cause))
            keys, counts = np.unique(np.stack([level.astype(str), cause.astype(str)]), axis=1, return_counts=True)
            for (lv, ca), k in zip(keys.T.tolist(), counts.tolist()):
                self.confidence_frames[(lv, ca)] = self.confidence_frames.get((lv, ca), 0) + int(k)
        for g, (_, angles, _) in enumerate(INPUT_GROUPS):
            measured = np.zeros(len(frames), dtype=bool)
            for a in angles:
                x = _col(frames, a)
                if x is not None:
                    measured |= np.isfinite(x)
            self.input_measured[g] += int(measured.sum())
            sds = [x for x in (_col(frames, f"{a}_sd") for a in angles) if x is not None]
            if sds:
                sd = np.fmax.reduce(np.stack(sds), axis=0)
                sd = sd[measured & np.isfinite(sd)]
                idx = np.clip((sd / _SD_BIN_RAD).astype(np.int64), 0, _SD_BINS - 1)
                self.input_sd_hist[g] += np.bincount(idx, minlength=_SD_BINS)
            if inferred is not None:
                self.input_inferred[g] += int(np.asarray(inferred)[:, INPUT_GROUP_JOINTS[g]].any(axis=1).sum())
        if inferred is not None:
            self.input_known += len(frames)

    def _add_task_inputs(self, frames: pd.DataFrame) -> None:
        """Count the scored frames, and per task input and value those that used the settings."""
        grand = [x for x in (_col(frames, "rula_grand"), _col(frames, "reba_score")) if x is not None]
        if not grand:
            return
        scored = np.fmax.reduce(np.stack(grand), axis=0)
        scored = np.isfinite(scored)
        self.scored_frames += int(scored.sum())
        if TASK_INPUTS_COLUMN not in frames.columns:
            return
        column = frames[TASK_INPUTS_COLUMN]
        for name in SETTINGS_INPUTS:
            x = _col(frames, name)
            if x is None:
                continue
            sel = used_mask(column, name) & scored
            if not sel.any():
                continue
            values, counts = np.unique(x[sel], return_counts=True)
            for v, k in zip(values.tolist(), counts.tolist()):
                key = (name, float(v))
                self.settings_frames[key] = self.settings_frames.get(key, 0) + int(k)

    def _settings_result(self, period: float) -> tuple[SettingsInputTime, ...]:
        order = {name: i for i, name in enumerate(SETTINGS_INPUTS)}
        out = []
        for (name, value), k in sorted(self.settings_frames.items(), key=lambda kv: (order[kv[0][0]], kv[0][1])):
            out.append(
                SettingsInputTime(
                    name, value, k, k * period, 100.0 * k / self.scored_frames if self.scored_frames else math.nan
                )
            )
        return tuple(out)

    def _confidence_result(self, period: float, pct: Callable[[float], float]) -> tuple[ConfidenceShare, ...]:
        if not self.confidence_frames:
            return ()
        out = []
        for lv in CONFIDENCE_LEVELS:
            n = sum(k for (level, _), k in self.confidence_frames.items() if level == lv)
            causes = tuple(
                CauseTime(ca, k, k * period, pct(k * period))
                for ca in (*CAUSES, NOT_RECORDED)
                if (k := self.confidence_frames.get((lv, ca), 0)) > 0 and lv != "confident"
            )
            out.append(ConfidenceShare(lv, n, n * period, pct(n * period), causes))
        return tuple(out)

    def _inputs_result(self) -> tuple[InputCertainty, ...]:
        out = []
        for g, (part, angles, _) in enumerate(INPUT_GROUPS):
            hist = self.input_sd_hist[g]
            total = int(hist.sum())
            if total:
                k = int(np.searchsorted(np.cumsum(hist), (total + 1) // 2))  # the lower median's bin
                median = (k + 0.5) * _SD_BIN_RAD
            else:
                median = math.nan
            known = self.input_known
            out.append(
                InputCertainty(
                    part,
                    angles,
                    int(self.input_measured[g]),
                    median,
                    int(self.input_inferred[g]),
                    known,
                    float(100.0 * self.input_inferred[g] / known) if known else math.nan,
                )
            )
        return tuple(out)

    # ------------------------------------------------------------------------------ result

    def result(self) -> ShiftSummary:
        """The summary so far (the accumulator can keep taking chunks afterwards)."""
        runs = {c: copy.deepcopy(r) for c, r in self.runs.items()}
        exposure_runs = {k: copy.deepcopy(r) for k, r in self.exposure_runs.items()}
        for r in (*runs.values(), *exposure_runs.values()):
            r.finish()
        period = self.period or 0.0
        observed = self.frames * period

        def pct(x: float) -> float:
            return 100.0 * x / observed if observed > 0 else 0.0

        distributions = {}
        for c, r in runs.items():
            values = []
            for v in sorted(k for k in r.frames if k >= 0):
                d, neg_start = r.longest[v]
                values.append(
                    ValueTime(
                        v, r.frames[v], r.frames[v] * period, pct(r.frames[v] * period), r.holds[v], d, -neg_start
                    )
                )
            miss = r.frames.get(-1, 0)
            distributions[c] = Distribution(
                c, self.frames, observed, miss, miss * period, pct(miss * period), tuple(values)
            )

        hourly = []
        for c, table in self.hourly.items():
            for h in sorted(self.hour_frames):
                by = {v: k * period for (hh, v), k in table.items() if hh == h and v >= 0}
                hourly.append(
                    HourStats(
                        c,
                        h,
                        self.hour_frames[h] * period,
                        table.get((h, -1), 0) * period,
                        MappingProxyType(dict(sorted(by.items()))),
                    )
                )

        episodes = {}
        for c, r in runs.items():
            if c in EPISODE_COLUMNS:
                episodes[c] = tuple(Episode(c, -lv, start, end, -neg_d, peak) for lv, neg_d, start, end, peak in r.best)

        minutes = observed / 60.0
        reps = []
        for angle in REPETITION_ANGLES:
            if angle not in self.rep_total:
                continue
            per_min = self.rep_minutes.get(angle, {})
            reps.append(
                Repetitions(
                    angle,
                    self.rep_total[angle],
                    self.rep_total[angle] / minutes if minutes else 0.0,
                    max(per_min.values(), default=0),
                    sum(1 for k in per_min.values() if k >= 4),
                )
            )

        exposure = []
        for spec in _exposure_specs():
            key = f"{spec.standard}|{spec.body_part}"
            found = exposure_runs.get(key)
            if found is None:
                exposure.append(
                    ExposureFinding(
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
                )
                continue
            r = found
            names = spec.zone_names
            zone_time = {names[v]: r.frames.get(v, 0) * period for v in range(len(names)) if names[v] != "-"}
            static_time = {names[v]: r.static_time.get(v, 0) * period for v in range(len(names)) if names[v] != "-"}
            static_holds = {names[v]: r.static_holds.get(v, 0) for v in range(len(names)) if names[v] != "-"}
            longest = {
                names[v]: (r.longest[v][0] if v in r.longest else 0.0) for v in range(len(names)) if names[v] != "-"
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
                entries = r.holds.get(1, 0)
                per_minute = entries / minutes if minutes else 0.0
                if r.frames.get(2, 0) > 0:
                    verdict = EN_VERDICTS[2]
                elif per_minute >= 2.0:
                    verdict = EN_VERDICTS[1]
                else:
                    verdict = EN_VERDICTS[0]
            else:  # en_trunk
                entries = r.holds.get(1, 0)
                per_minute = entries / minutes if minutes else 0.0
                if per_minute >= 2.0:
                    verdict = EN_VERDICTS[2]
                elif entries > 0:
                    verdict = EN_VERDICTS[1]
                else:
                    verdict = EN_VERDICTS[0]
            exposure.append(
                ExposureFinding(
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
            )

        return ShiftSummary(
            worker=self.worker,
            frames=self.frames,
            frame_period_s=period,
            observed_s=observed,
            start_s=self.start_s,
            end_s=self.end_s,
            distributions=MappingProxyType(distributions),
            hourly=tuple(hourly),
            episodes=MappingProxyType(episodes),
            repetitions=tuple(reps),
            exposure=tuple(exposure),
            confidence=self._confidence_result(period, pct),
            inputs=self._inputs_result(),
            from_settings=self._settings_result(period),
            scored_frames=self.scored_frames,
        )


def aggregate_shift(
    frames: pd.DataFrame,
    worker: str = "",
    *,
    chunk_frames: int | None = None,
    progress: ProgressCallback | None = None,
    inferred: np.ndarray | None = None,
    **options: Any,
) -> ShiftSummary:
    """Aggregate one worker's scored frames (in time order); inferred: (n, 33) joints placed by the
    body model (see :meth:`ShiftAccumulator.add`); options as :class:`ShiftAccumulator`."""
    acc = ShiftAccumulator(worker, **options)
    n = len(frames)
    step = n if not chunk_frames else max(1, int(chunk_frames))
    for i in range(0, n, step or 1):
        acc.add(frames.iloc[i : i + step], None if inferred is None else np.asarray(inferred)[i : i + step])
        report(progress, "aggregate", min(i + step, n), n, unit="frame")
    return acc.result()


def aggregate_session(
    frames: pd.DataFrame, *, by: str = "worker", progress: ProgressCallback | None = None, **options: Any
) -> dict[str, ShiftSummary]:
    """One ShiftSummary per worker (rows grouped by the ``by`` column, each in time order)."""
    if by not in frames.columns:
        return {"": aggregate_shift(frames, "", **options)}
    out = {}
    groups = list(frames.groupby(by, sort=True, dropna=False))
    for k, (name, g) in enumerate(groups):
        out[str(name)] = aggregate_shift(g, str(name), **options)
        report(progress, "aggregate", k + 1, len(groups), unit="worker")
    return out


__all__ = [
    "ValueTime",
    "Distribution",
    "HourStats",
    "Episode",
    "Repetitions",
    "ExposureFinding",
    "ShiftSummary",
    "CauseTime",
    "ConfidenceShare",
    "InputCertainty",
    "SettingsInputTime",
    "NOT_RECORDED",
    "ShiftAccumulator",
    "aggregate_shift",
    "aggregate_session",
    "DISTRIBUTION_COLUMNS",
    "EPISODE_COLUMNS",
    "REPETITION_PREFIX",
    "ISO_VERDICTS",
    "EN_VERDICTS",
]
