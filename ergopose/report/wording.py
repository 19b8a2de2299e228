"""Words, numbers and colours of the report as a reader sees them: durations, percentages, clock
times, level colours, the meanings of settings and task inputs, safe links and page names.
"""

from __future__ import annotations

import datetime as _dt
import math
import re
from urllib.parse import quote

from ergopose.ergonomics.shares import HIGH_LEVELS as SHARE_HIGH_LEVELS
from ergopose.ergonomics.shares import format_percent, percent
from ergopose.report import heat_maps
from ergopose.report.context import MethodInfo

# ------------------------------------------------------------------------------- formatting

#: Colours of action levels (lowest to highest) by number of levels; each is labelled in the figures.
LEVEL_COLOURS = {
    4: ("#a6d96a", "#fee08b", "#fdae61", "#d73027"),
    5: ("#d9f0d3", "#a6d96a", "#fee08b", "#fdae61", "#d73027"),
}
#: Colours of posture band scores 1, 2, 3, 4, 5+ (band score, lower is better).
BAND_COLOURS = ("#a6d96a", "#fee08b", "#fdae61", "#f46d43", "#d73027")
METHOD_TITLES = {"rula": "RULA", "reba": "REBA"}
#: The levels counted as "high" on the index page and in the floor maps, per method (ergopose.ergonomics.shares).
HIGH_LEVELS = SHARE_HIGH_LEVELS
#: Timeline bin widths (seconds) the report chooses from: the smallest giving at most MAX_BINS bins.
BIN_CHOICES_S = (1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 900, 1800, 3600)
MAX_BINS = 480
RATING_LABELS = {"good": "High confidence", "fair": "Moderate confidence", "poor": "Low confidence"}
#: The confidence levels of the tracked time in words (terminal summary and report).
CONFIDENCE_WORDS = {
    "confident": "scored with confidence",
    "low": "scored with low confidence",
    "unscored": "not scored",
}
#: An input is "uncertain" when the median standard deviation of its angles over the shift is at
#: least this (degrees): RULA/REBA posture bands are 10-25 degrees wide (neck 10-20, wrist 15,
#: trunk and upper arm 20 or more), so such an angle often falls in a neighbouring band.
UNCERTAIN_SD_DEG = 10.0
#: An input is "mostly inferred" when its joints were placed by the body model in at least this
#: share (percent) of the tracked time.
MOSTLY_INFERRED_PCT = 50.0
#: An input is "often held at a joint limit" when a joint limit of the body model held its angles
#: in at least this share (percent) of the tracked time: the cameras showed the joint past its
#: anatomical range that often, so its keypoints are suspect (ergopose's own choice).
OFTEN_LIMITED_PCT = 10.0
#: Settings keys (docs/session-format.md, task factors) that give a body part's input instead of
#: the cameras; body parts not listed can only be measured.
TASK_INPUTS = {
    "left upper arm": "arm_supported",
    "right upper arm": "arm_supported",
    "left wrist": "wrist_flexion_deg, wrist_deviation_deg (where the hand is not seen); wrist_twist_end_range",
    "right wrist": "wrist_flexion_deg, wrist_deviation_deg (where the hand is not seen); wrist_twist_end_range",
    "legs": "seated, legs_supported",
}
REGION_NAMES = {"all": "whole field of view", "central": "central", "outer": "outer", "edge": "lens edge"}

#: Plain-language meaning of each scoring setting (ergopose.ergonomics.settings.ScoringSettings).
SETTING_MEANINGS = {
    "rula_open_boundary": "RULA: which band gets an angle exactly on an edge the worksheet leaves open",
    "reba_open_boundary": "REBA: which band gets an angle exactly on an edge the worksheet leaves open",
    "wrist_neutral_deg": "wrist counts as neutral within this many degrees",
    "trunk_upright_deg": "trunk counts as upright within this many degrees",
    "neck_extension_deg": "neck counts as extended beyond this many degrees of extension",
    "shoulder_raised_deg": "shoulder counts as raised above this elevation (degrees)",
    "upper_arm_abducted_deg": "upper arm counts as abducted above this angle (degrees)",
    "trunk_twisted_deg": "trunk counts as twisted above this angle (degrees)",
    "trunk_side_bent_deg": "trunk counts as side-bent above this angle (degrees)",
    "neck_twisted_deg": "neck counts as twisted above this angle (degrees)",
    "neck_side_bent_deg": "neck counts as side-bent above this angle (degrees)",
    "wrist_deviated_deg": "wrist counts as bent sideways above this angle (degrees)",
    "across_midline_m": "hand counts as across the body's midline beyond this distance (metres)",
    "out_to_side_m": "hand counts as out to the side beyond this distance (metres)",
    "rula_static_hold_s": "RULA: a posture held this long (seconds) is static",
    "reba_static_hold_s": "REBA: a posture held this long (seconds) is static",
    "static_includes_neutral": "whether holding a neutral posture also counts as static",
    "repetition_amplitude_deg": "a movement counts as an action when the angle rises and falls this much (degrees)",
    "repetition_window_s": "actions are counted in a window this long (seconds)",
    "rula_repetitions_per_min": "RULA: repeated when at least this many actions per minute",
    "reba_repetitions_per_min": "REBA: repeated when more than this many actions per minute",
    "rapid_change_deg": "REBA: a rapid large change spans more than this many degrees ...",
    "rapid_change_window_s": "... within this many seconds",
    "max_gap_s": "a tracking gap longer than this (seconds) breaks a hold",
    "rula_lower_arm_adjust": "RULA lower-arm adjustment: one +1 (single) or one per condition (separate)",
    "reba_twist_side_adjust": "REBA neck/trunk twist and side-bend: one +1 (single) or one each (separate)",
    "unknown_flags": "an unmeasured yes/no input adds nothing (absent) or leaves the score missing (missing)",
}


def fmt_duration(seconds: float) -> str:
    """Seconds as "2 h 05 min", "4 min 10 s", "12 s" (whole seconds) or "0.4 s" (below 10 s)."""
    if not math.isfinite(seconds):
        return "unknown"
    if 0 < seconds < 9.95:
        return f"{seconds:.1f} s"
    s = int(round(max(seconds, 0.0)))
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    if h:
        return f"{h} h {m:02d} min"
    if m:
        return f"{m} min {sec:02d} s"
    return f"{sec} s"


def fmt_percent(part: float, whole: float) -> str:
    """A share as "12.3 %" (one decimal; "0.0 %" for nothing, "n/a" when whole is 0)."""
    return format_percent(percent(part, whole))


def _parse_start(start: str | None) -> _dt.datetime | None:
    if not start:
        return None
    try:
        return _dt.datetime.fromisoformat(start)
    except ValueError:
        return None


class Clock:
    """Turns shift time (seconds) into clock time when the session's start is known."""

    def __init__(self, start: str | None):
        self.start = _parse_start(start)

    def __call__(self, shift_s: float, seconds: bool = True) -> str:
        if self.start is not None:
            t = self.start + _dt.timedelta(seconds=float(shift_s))
            return t.strftime("%H:%M:%S" if seconds else "%H:%M")
        s = int(round(shift_s))
        h, rem = divmod(s, 3600)
        m, sec = divmod(rem, 60)
        return f"{h}:{m:02d}:{sec:02d}" if seconds else f"{h}:{m:02d}"

    @property
    def known(self) -> bool:
        return self.start is not None


def safe_href(path: str | None) -> str | None:
    """A relative path as a safe URL (no scheme, not absolute, no '..'), or None if it is not one."""
    if not path:
        return None
    p = path.replace("\\", "/")
    if ":" in p or p.startswith("/") or any(part == ".." for part in p.split("/")):
        return None
    return quote(p, safe="/")


def level_colours(method: MethodInfo) -> dict[int, str]:
    """{action level: colour} of a method (its palette by number of levels, else heat colours)."""
    pal = LEVEL_COLOURS[len(method.action_levels)] if len(method.action_levels) in LEVEL_COLOURS else None
    if pal is None:
        pal = tuple(heat_maps.HEAT_COLOURS[min(i, 5)] for i in range(len(method.action_levels)))
    return {lv.level: pal[i] for i, lv in enumerate(method.action_levels)}


def band_colour(score: int) -> str:
    """The colour of a score band (scores below 1 or above the palette take its ends)."""
    return BAND_COLOURS[min(max(score, 1), len(BAND_COLOURS)) - 1]


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]+", "-", text).strip("-").lower() or "x"


def worker_page_name(worker_id: str) -> str:
    """File name of a worker's page in the report folder."""
    return f"worker-{worker_id}.html"


def display_name(worker_id: str, name: str | None) -> str:
    return f"{name} ({worker_id})" if name else worker_id
