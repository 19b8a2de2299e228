"""The headline figures of a worker, computed in one place: time at high risk and its shares.

The terminal summary of ``ergopose assess``, the report's headline (worker page and index) and
the session summary CSV all take their shares from :func:`high_risk` (or
:func:`shift_high_risk`, the same from a shift summary), and format them with
:func:`format_percent`. Every share names its base:

- of the tracked time: the time the worker was tracked (frames x frame period);
- of the scored time: the tracked time with a score of the method (tracked less unscored);
- the unscored time of the method, beside them, whose causes the confidence split gives
  (:class:`ergopose.ergonomics.shift_records.ConfidenceShare`).

A share is NaN (printed "n/a") when its base is zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

from ergopose.ergonomics.shift_records import ShiftSummary

#: The level column of each method and the levels counted as high risk: RULA action level 3-4
#: (investigate and change soon / immediately), REBA risk level 3-4 (high, very high).
LEVEL_COLUMNS = {"rula": "rula_action_level", "reba": "reba_risk_level"}
HIGH_LEVELS = {"rula": (3, 4), "reba": (3, 4)}
#: The high levels in words, as the terminal summary and the report's headline say them.
HIGH_WORDS = {"rula": "RULA action level 3-4", "reba": "REBA high/very high"}


def percent(part_s: float, base_s: float) -> float:
    """100 x part / base; NaN when the base is not positive or the part not finite."""
    if not (base_s > 0) or not math.isfinite(part_s):
        return math.nan
    return 100.0 * part_s / base_s


def format_percent(value: float) -> str:
    """A share as "12.3 %" (one decimal), "n/a" when NaN."""
    return "n/a" if not math.isfinite(value) else f"{value:.1f} %"


@dataclass(frozen=True)
class HighRisk:
    """One method's time at high risk for one worker.

    method: "rula" or "reba". tracked_s: time tracked. high_s: time at the high levels
    (HIGH_LEVELS). unscored_s: tracked time without a score of the method.
    """

    method: str
    tracked_s: float
    high_s: float
    unscored_s: float

    @property
    def scored_s(self) -> float:
        """Tracked time with a score of the method."""
        return max(self.tracked_s - self.unscored_s, 0.0)

    @property
    def pct_of_tracked(self) -> float:
        return percent(self.high_s, self.tracked_s)

    @property
    def pct_of_scored(self) -> float:
        return percent(self.high_s, self.scored_s)

    @property
    def unscored_pct_of_tracked(self) -> float:
        return percent(self.unscored_s, self.tracked_s)


def high_risk(method: str, tracked_s: float, seconds_by_level: Mapping[int, float], unscored_s: float) -> HighRisk:
    """The HighRisk of a method from the time per level and the unscored time."""
    high = float(sum(seconds_by_level.get(lv, 0.0) for lv in HIGH_LEVELS[method]))
    return HighRisk(method=method, tracked_s=float(tracked_s), high_s=high, unscored_s=float(unscored_s))


def shift_high_risk(summary: ShiftSummary, method: str) -> HighRisk:
    """The HighRisk of a method from a shift summary;
    without the method's level column nothing counts as scored."""
    d = summary.distributions.get(LEVEL_COLUMNS[method])
    if d is None:
        return HighRisk(
            method=method, tracked_s=float(summary.observed_s), high_s=0.0, unscored_s=float(summary.observed_s)
        )
    return high_risk(method, summary.observed_s, {v.value: v.time_s for v in d.values}, d.missing_time_s)


__all__ = [
    "LEVEL_COLUMNS",
    "HIGH_LEVELS",
    "HIGH_WORDS",
    "percent",
    "format_percent",
    "HighRisk",
    "high_risk",
    "shift_high_risk",
]
