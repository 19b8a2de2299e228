"""The records of a worker's shift summary (ergopose.ergonomics.aggregate): time per value of a
score column, per hour, the worst episodes, repetitions, exposure findings, the confidence of the
tracked time, the certainty of the inputs and the task inputs given by the settings.

All frozen dataclasses; times in seconds, percents of the observed (tracked) time unless a field
says otherwise. Scores are ordinal: a distribution over time, a hold, a count or a rate -- never
an average of scores.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence


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
    reached in the standard's sense (ergopose.ergonomics.exposure); measured: False when the angles needed
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
    inferred_percent: inferred_frames of known_frames (NaN when unknown). limited_frames: frames in
    which a joint limit of the body model held its angles (the cameras put the elbow, the knees or
    the head past the anatomical range; INPUT_GROUP_LIMIT_JOINTS); limited_percent: of the frames
    whose limit flags were given (NaN when unknown or when no limit concerns the part: the trunk,
    the upper arms and the wrists).
    """

    body_part: str
    angles: tuple[str, ...]
    measured_frames: int
    median_sd_rad: float
    inferred_frames: int
    known_frames: int
    inferred_percent: float
    limited_frames: int = 0
    limited_percent: float = math.nan


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


__all__ = [
    "ValueTime",
    "Distribution",
    "HourStats",
    "Episode",
    "Repetitions",
    "ExposureFinding",
    "CauseTime",
    "ConfidenceShare",
    "InputCertainty",
    "SettingsInputTime",
    "ShiftSummary",
]
