"""Template contexts: one frozen dataclass per page template, built from the stored results.

``IndexPage`` feeds templates/index.html.j2 and ``WorkerPage`` feeds templates/worker.html.j2; the
nested records below are theirs. Every field is documented in its class docstring, and
tests/report/test_templates.py holds each template to it: rendered from a fully populated example
with jinja2.StrictUndefined, every field is used and no other name is.

Text fields are plain text (the templates escape them); fields typed ``Markup`` hold inline SVG
built by ergopose.report.svg, where every piece of text was escaped when the SVG was made. All
numbers are already formatted for reading (units included), so templates do no arithmetic.
"""

from __future__ import annotations

import datetime as _dt
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence
from urllib.parse import quote

import numpy as np
import pandas as pd
from markupsafe import Markup

from ergopose.ergonomics.shares import HIGH_LEVELS as SHARE_HIGH_LEVELS
from ergopose.ergonomics.shares import format_percent, high_risk, percent
from ergopose.keypoints import LIMBS
from ergopose.report import periods, svg
from ergopose.report.periods import DRIVER_SHARE, MAX_PERIODS
from ergopose.report.context import (
    FLAG_VERDICTS,
    MAX_SKIPPED_SPANS,
    Assumption,
    MethodInfo,
    ModelInfo,
    SessionInfo,
    WorkerInfo,
    WorkerResults,
    WorkerSummary,
)
from ergopose.report.quality import SCORED_LIMBS, Finding, Verdict, quality_verdict

# ------------------------------------------------------------------------- shared records


@dataclass(frozen=True)
class Link:
    """A link to another file of the report folder.

    href: relative URL (percent-encoded). text: what the reader sees. note: empty, or why there is
    no link (e.g. the file is missing); with a note the template shows the text without a link.
    """

    href: str
    text: str
    note: str


@dataclass(frozen=True)
class Figure:
    """A figure: id (unique on the page, used as anchor), svg (inline SVG, text escaped),
    caption (plain text under the figure, says what it shows and how to read it)."""

    id: str
    svg: Markup
    caption: str


@dataclass(frozen=True)
class SessionHeader:
    """Who/when/where of the session, formatted.

    title: session title (or its id). session_id: folder name. site: where (may be empty).
    when: date and clock times, or a sentence that they are unknown. duration: length in words.
    generated: which ergopose version wrote the results, and when.
    """

    title: str
    session_id: str
    site: str
    when: str
    duration: str
    generated: str


@dataclass(frozen=True)
class SettingRow:
    """A scoring setting: name (as in the settings file), value (formatted), meaning (in words)."""

    name: str
    value: str
    meaning: str


@dataclass(frozen=True)
class MethodsSection:
    """What was measured and how it was scored.

    measured: sentences on what the cameras measured. methods: the scoring methods (tables,
    action levels, file hashes). settings: every open choice of the scoring and its value.
    models: the pose networks with their SHA-256. version: ergopose version. calibration: the
    calibration file in a sentence.
    """

    measured: tuple[str, ...]
    methods: tuple[MethodInfo, ...]
    settings: tuple[SettingRow, ...]
    models: tuple[ModelInfo, ...]
    version: str
    calibration: str


@dataclass(frozen=True)
class CalibrationRow:
    """Reference-bar check in one lens region: region, target, measured (mean +- spread), error."""

    region: str
    target: str
    measured: str
    error: str


# ----------------------------------------------------------------------------- worker page


@dataclass(frozen=True)
class LevelRow:
    """One action level in the headline table.

    key: stable id "<method>-<level>" (data attribute for tests and tools). level: number.
    label: short name. wording: what the level asks for. scores: covered final scores ("5-6").
    time: time at the level. percent: share of the tracked time. colour: the level's colour.
    """

    key: str
    level: int
    label: str
    wording: str
    scores: str
    time: str
    percent: str
    colour: str


@dataclass(frozen=True)
class MethodHeadline:
    """Headline of one method: method ("RULA"), title (full name), levels (ascending),
    unscored_time / unscored_percent (tracked but not scored), key_fact (one sentence with the
    share at the two highest levels)."""

    method: str
    title: str
    levels: tuple[LevelRow, ...]
    unscored_time: str
    unscored_percent: str
    key_fact: str


@dataclass(frozen=True)
class ConfidenceRow:
    """One part of the tracked time by confidence: key ("confident", "low", "unscored"; data
    attribute for tests and tools), level (in words), time, percent (of the tracked time), causes
    (time per cause in words, "cause 1 min 02 s (12.3 %)" joined by semicolons; "-" when none)."""

    key: str
    level: str
    time: str
    percent: str
    causes: str


@dataclass(frozen=True)
class BandRow:
    """Time of a body part in one band: method, body_part, score (band score), criterion (band in
    words), time, percent (of the tracked time)."""

    method: str
    body_part: str
    score: int
    criterion: str
    time: str
    percent: str


@dataclass(frozen=True)
class HoldRow:
    """A longest hold: body_part, method, score (band score), criterion, start (clock time),
    duration."""

    body_part: str
    method: str
    score: int
    criterion: str
    start: str
    duration: str


@dataclass(frozen=True)
class RepetitionRow:
    """Repetitive movement: body_part, actions (over the shift), per_minute (actions per tracked
    minute), max (most actions in one minute), limit (per minute), over_limit (minutes of the
    shift with at least the limit)."""

    body_part: str
    actions: str
    per_minute: str
    max: str
    limit: str
    over_limit: str


@dataclass(frozen=True)
class DriverRow:
    """A body part that drove a sustained period: body_part, band (band score of the highest,
    "3 of 4"), criterion (the band in words, angles in degrees), time (in that band during the
    period's high-risk time), percent (share of the period's high-risk time)."""

    body_part: str
    band: str
    criterion: str
    time: str
    percent: str


@dataclass(frozen=True)
class PeriodInputRow:
    """A score input of a sustained period: input (in words), source ("measured", "task input" or
    "not given"), value (a task input's value, angles in degrees; "" otherwise), time (of the
    period's high-risk time with it, and its share: "9.0 s (75 %)"), use (the RULA / REBA steps it
    feeds)."""

    input: str
    source: str
    value: str
    time: str
    use: str


@dataclass(frozen=True)
class MomentCard:
    """A sustained period of high risk (ergopose.report.periods): rank (1 = most time at high
    risk), start / end (clock times), duration (start to end), high_time (time at high risk within
    it, with its share of the duration), when (clock time of the frame drawn: the posture held
    longest), rula / reba (score at that frame with its level's name, "6 (AL3), up to 7" when the
    period's highest score differs),
    drivers (the body parts in their high bands for most of it; empty when unknown), reason (the
    same in a sentence, or why there is none), task_inputs (the task inputs of the settings in
    force during its high-risk time and those not given, in one line), inputs (every score input,
    measured or task input; empty in results written before they were read), figure (front and
    side view of the skeleton at the frame drawn)."""

    rank: int
    start: str
    end: str
    duration: str
    high_time: str
    when: str
    rula: str
    reba: str
    drivers: tuple[DriverRow, ...]
    reason: str
    task_inputs: str
    inputs: tuple[PeriodInputRow, ...]
    figure: Figure


@dataclass(frozen=True)
class Term:
    """An abbreviation or coded word of the page and what it means: term, meaning."""

    term: str
    meaning: str


@dataclass(frozen=True)
class HourRow:
    """One hour of an hourly table: hour (clock range), tracked (time tracked), cells (time at
    each level, in the order of HourTable.columns, then not scored; "-" for none)."""

    hour: str
    tracked: str
    cells: tuple[str, ...]


@dataclass(frozen=True)
class HourTable:
    """Hourly breakdown of one method: method ("RULA"), columns (level headers then "not
    scored"), rows (one per hour)."""

    method: str
    columns: tuple[str, ...]
    rows: tuple[HourRow, ...]


@dataclass(frozen=True)
class FlagRow:
    """An ISO 11226 / EN 1005-4 judgement: standard, body_part, condition, verdict (words),
    severity ("ok", "caution", "bad" or "unknown"; for styling only, the verdict words carry the
    meaning), time, longest (hold), note."""

    standard: str
    body_part: str
    condition: str
    verdict: str
    severity: str
    time: str
    longest: str
    note: str


@dataclass(frozen=True)
class LimbRow:
    """Limb-length statistics in centimetres: limb, n (frames), median, iqr (q1-q3),
    whiskers (p5-p95), mean_sd (mean +- standard deviation)."""

    limb: str
    n: str
    median: str
    iqr: str
    whiskers: str
    mean_sd: str


@dataclass(frozen=True)
class RegionSpreadRow:
    """A limb's length spread per lens region: limb, cells (interquartile range and count in the
    central, outer and edge regions, in that order)."""

    limb: str
    cells: tuple[str, ...]


@dataclass(frozen=True)
class RegionRow:
    """Time in one lens region: region, time (tracked there), percent (of the tracked time),
    reconstruction (median reconstruction frequency of the scored limbs there)."""

    region: str
    time: str
    percent: str
    reconstruction: str


@dataclass(frozen=True)
class InputRow:
    """How well one body part's RULA/REBA inputs were measured: body_part, median_sd (median over
    the shift of the angles' standard deviation, degrees), inferred (share of the tracked time in
    which its joints were placed by the body model), verdict ("measured", "uncertain", "mostly
    inferred", "mostly inferred, uncertain"), concern (true when the verdict is not "measured"; for
    styling), task_input (the settings key that can give the input instead, or why none can),
    from_settings (the values the settings gave in place of unseen angles and the share of the
    scored time each was used, e.g. "flexion 20° in 35.0 % of the scored time"; "none" when the
    measurement was always used)."""

    body_part: str
    median_sd: str
    inferred: str
    verdict: str
    concern: bool
    task_input: str
    from_settings: str = "none"


@dataclass(frozen=True)
class QualitySection:
    """The quality section (as in the paper's evaluation).

    verdict: overall rating, plain-language headline and findings. verdict_label: the rating in
    words ("High confidence"). reliable: sentence on the share of the shift with a reliable
    skeleton. limb_figure / limb_rows: limb-length box plots and their table. region_spread: the
    spread of each limb's length per lens region (the paper: errors grow towards the lens edge).
    frequency_figure: reconstruction frequency per limb overall and per lens region.
    regions: time per lens region. calibration_rows / calibration_note: the calibration's accuracy.
    error_3d: median 3D error against ground truth in a sentence (empty when there is none).
    video: which video frames could not be read and were skipped, in a sentence.
    inputs: per body part, how well its RULA/REBA inputs were measured (empty when unknown);
    inputs_note: how to read that table and which inputs can be given as task inputs instead.
    """

    verdict: Verdict
    verdict_label: str
    reliable: str
    limb_figure: Figure
    limb_rows: tuple[LimbRow, ...]
    region_spread: tuple[RegionSpreadRow, ...]
    frequency_figure: Figure
    regions: tuple[RegionRow, ...]
    calibration_rows: tuple[CalibrationRow, ...]
    calibration_note: str
    error_3d: str
    video: str = ""
    inputs: tuple[InputRow, ...] = ()
    inputs_note: str = ""


@dataclass(frozen=True)
class WorkerPage:
    """Context of templates/worker.html.j2: one worker's shift.

    page_title: the HTML title. session: session header. worker_id: pseudonymous id.
    display_name: the name (with the id) or the id alone. nav: links to the index and the other
    workers. tracked: sentence on how much of the session the worker was tracked.
    confidence_rows: the tracked time split into scored with confidence, scored with low
    confidence and not scored, with causes (empty when not recorded); confidence_note: how the
    split was made, or that it was not recorded.
    headline: per method, share of the shift at each action level; headline_figure: the same
    as stacked bars. timeline_figures: worst and median score per time bin, per method;
    timeline_note: how the timeline was downsampled. body_part_figures / body_part_rows: time per
    body part and band. holds: longest holds. repetitions: repetitive movements. worst: the
    sustained periods of high risk (what to act on), ranked, with skeleton drawings; worst_note:
    the rule that finds them. act_summary: in a sentence, how much of the high-risk time the
    periods hold and the body parts that drove most of them. risk_figure: the shift by time of
    day at high, medium and low risk and not scored, with the periods marked. hourly_figures / hourly_tables: hourly breakdown.
    flags: ISO 11226 / EN 1005-4 judgements. floor_figures / floor_note: where on the floor the
    risky postures happened. quality: the quality section. assumptions: what was assumed for this
    worker. methods: the methods section. downloads: the worker's CSV and the session summary.
    print_link: the print version. glossary: every abbreviation of the page with its meaning.
    """

    page_title: str
    session: SessionHeader
    worker_id: str
    display_name: str
    nav: tuple[Link, ...]
    tracked: str
    confidence_rows: tuple[ConfidenceRow, ...]
    confidence_note: str
    headline: tuple[MethodHeadline, ...]
    headline_figure: Figure
    timeline_figures: tuple[Figure, ...]
    timeline_note: str
    body_part_figures: tuple[Figure, ...]
    body_part_rows: tuple[BandRow, ...]
    holds: tuple[HoldRow, ...]
    repetitions: tuple[RepetitionRow, ...]
    worst: tuple[MomentCard, ...]
    worst_note: str
    act_summary: str
    risk_figure: Figure
    hourly_figures: tuple[Figure, ...]
    hourly_tables: tuple[HourTable, ...]
    flags: tuple[FlagRow, ...]
    floor_figures: tuple[Figure, ...]
    floor_note: str
    quality: QualitySection
    assumptions: tuple[Assumption, ...]
    methods: MethodsSection
    downloads: tuple[Link, ...]
    print_link: Link
    glossary: tuple[Term, ...]


# ------------------------------------------------------------------------------ index page


@dataclass(frozen=True)
class WorkerRow:
    """A worker on the index page: display_name, page (link to the worker page), tracked (time),
    confident / low_confidence / unscored (share of the tracked time scored with confidence, scored
    with low confidence, not scored; "n/a" when not recorded), rula_high (share of the tracked time
    at RULA action level 3-4), reba_high (share of the tracked time at REBA high or very high),
    reliable (share with a reliable skeleton), verdict_label (confidence in words), verdict_rating
    ("good"/"fair"/"poor", for styling), csv (links to the worker's CSV files), periods (the
    sustained periods of high risk shown: how many, with their time at high risk in brackets;
    "none")."""

    display_name: str
    page: Link
    tracked: str
    confident: str
    low_confidence: str
    unscored: str
    rula_high: str
    reba_high: str
    reliable: str
    verdict_label: str
    verdict_rating: str
    csv: tuple[Link, ...]
    periods: str


@dataclass(frozen=True)
class IndexPage:
    """Context of templates/index.html.j2: the session overview.

    page_title: the HTML title. session: session header. workers: one row per worker.
    risk_figure: the shift by time of day, one strip per worker (high, medium, low, not scored).
    overview_figures: per method, share of the shift at each level for every worker.
    calibration_rows / calibration_note: the calibration's accuracy. methods: the methods
    section. downloads: the session summary CSV. print_link: the print version. glossary: every
    abbreviation of the page with its meaning.
    """

    page_title: str
    session: SessionHeader
    workers: tuple[WorkerRow, ...]
    risk_figure: Figure
    overview_figures: tuple[Figure, ...]
    calibration_rows: tuple[CalibrationRow, ...]
    calibration_note: str
    methods: MethodsSection
    downloads: tuple[Link, ...]
    print_link: Link
    glossary: tuple[Term, ...]


# ------------------------------------------------------------------------------ print page


@dataclass(frozen=True)
class PrintRow:
    """A worker in the print version's summary table: worker_id, name (from the settings, or empty),
    tracked (time), confident /
    low_confidence / unscored (shares of the tracked time as on the index), rula_high, reba_high
    (share of the tracked time at the high levels), periods (sustained periods of high risk: how
    many and their time at high risk), verdict_label / verdict_rating (reconstruction quality in
    words, and "good"/"fair"/"poor" for styling)."""

    worker_id: str
    name: str
    tracked: str
    confident: str
    low_confidence: str
    unscored: str
    rula_high: str
    reba_high: str
    periods: str
    verdict_label: str
    verdict_rating: str


@dataclass(frozen=True)
class PrintWorker:
    """One worker in the print version (at most two A4 pages): worker_id, display_name, tracked
    (sentence), headline (per method, share at each level, with its key fact), act_summary (the
    periods' share of the high-risk time and what drove them, a sentence), confidence_rows (tracked time by confidence), risk_figure (the shift by time of day), worst
    (the sustained periods, at most PRINT_PERIODS), more (sentence naming the periods left out,
    or empty)."""

    worker_id: str
    display_name: str
    tracked: str
    headline: tuple[MethodHeadline, ...]
    act_summary: str
    confidence_rows: tuple[ConfidenceRow, ...]
    risk_figure: Figure
    worst: tuple[MomentCard, ...]
    more: str


@dataclass(frozen=True)
class PrintPage:
    """Context of templates/print.html.j2: the print version (one summary page, then at most two
    pages per worker). page_title: the HTML title. session: session header. workers_table: one
    row per worker (the index's figures). risk_figure: the shift by time of day, one strip per worker.
    worst_note: the rule that finds the sustained periods. workers: each worker's pages.
    glossary: every abbreviation with its meaning."""

    page_title: str
    session: SessionHeader
    workers_table: tuple[PrintRow, ...]
    risk_figure: Figure
    worst_note: str
    workers: tuple[PrintWorker, ...]
    glossary: tuple[Term, ...]


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
CONFIDENCE_WORDS = {"confident": "scored with confidence", "low": "scored with low confidence", "unscored": "not scored"}
#: An input is "uncertain" when the median standard deviation of its angles over the shift is at
#: least this (degrees): RULA/REBA posture bands are 10-25 degrees wide (neck 10-20, wrist 15,
#: trunk and upper arm 20 or more), so such an angle often falls in a neighbouring band.
UNCERTAIN_SD_DEG = 10.0
#: An input is "mostly inferred" when its joints were placed by the body model in at least this
#: share (percent) of the tracked time.
MOSTLY_INFERRED_PCT = 50.0
#: Settings keys (docs/session-format.md, task factors) that give a body part's input instead of
#: the cameras; body parts not listed can only be measured.
TASK_INPUTS = {
    "left upper arm": "arm_supported", "right upper arm": "arm_supported",
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


def _level_colours(method: MethodInfo) -> dict[int, str]:
    pal = LEVEL_COLOURS[len(method.action_levels)] if len(method.action_levels) in LEVEL_COLOURS else None
    if pal is None:
        pal = tuple(svg.HEAT_COLOURS[min(i, 5)] for i in range(len(method.action_levels)))
    return {lv.level: pal[i] for i, lv in enumerate(method.action_levels)}


def _band_colour(score: int) -> str:
    return BAND_COLOURS[min(max(score, 1), len(BAND_COLOURS)) - 1]


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]+", "-", text).strip("-").lower() or "x"


def worker_page_name(worker_id: str) -> str:
    """File name of a worker's page in the report folder."""
    return f"worker-{worker_id}.html"


def display_name(worker_id: str, name: str | None) -> str:
    return f"{name} ({worker_id})" if name else worker_id


# ------------------------------------------------------------------------- shared builders


def session_header(s: SessionInfo) -> SessionHeader:
    clock = Clock(s.start)
    if clock.known:
        assert clock.start is not None
        end = clock.start + _dt.timedelta(seconds=s.duration_s)
        when = f"{clock.start.strftime('%A %d %B %Y')}, {clock.start.strftime('%H:%M')} to {end.strftime('%H:%M')}"
    else:
        when = "Clock time not recorded: times are given from the start of the recording (h:mm:ss)."
    return SessionHeader(
        title=s.title or s.session_id, session_id=s.session_id, site=s.site, when=when,
        duration=f"{fmt_duration(s.duration_s)} ({s.frames:,} frames at {s.fps:g} frames per second)",
        generated=f"Results written {s.created} by ergopose {s.ergopose_version}.")


def calibration_rows(s: SessionInfo) -> tuple[tuple[CalibrationRow, ...], str]:
    cal = s.calibration
    if cal is None:
        return (), "No calibration information was stored with these results."
    rows = []
    for r in cal.regions:
        spread = f" ± {100 * r.spread_m:.1f} cm" if r.n >= 2 and math.isfinite(r.spread_m) else ""
        err = (f"{100 * (r.measured_m - r.target_m) / r.target_m:+.1f} %"
               if math.isfinite(r.measured_m) and r.target_m > 0 else "n/a")
        region = REGION_NAMES.get(r.region, r.region) + (f" ({r.angles})" if r.angles else "")
        rows.append(CalibrationRow(region=region, target=f"{r.target_m:.3f} m",
                                   measured=f"{r.measured_m:.3f} m{spread} ({_count(r.n, 'measurement')})",
                                   error=err))
    rms = (f" The calibration's reprojection error is {cal.reprojection_rms_px:.2f} pixels (RMS)."
           if math.isfinite(cal.reprojection_rms_px) else "")
    if rows:
        note = ("A reference bar of known length was measured in 3D in each lens region (the paper's check); "
                "the error is measured minus true length." + rms)
    else:
        note = "The calibration was not checked with a reference bar of known length." + rms
    return tuple(rows), note


def methods_section(s: SessionInfo) -> MethodsSection:
    n_cams = len(s.calibration.cameras) if s.calibration is not None else 0
    filmed = (f"{n_cams} calibrated camera{'s' if n_cams != 1 else ''} filmed" if n_cams
              else "Calibrated cameras filmed")
    measured = (
        f"{filmed} the work area; each worker's 33 body landmarks were found in upright virtual views of "
        "every camera and reconstructed in 3D (metres), then tracked and smoothed.",
        "Joint angles (trunk, neck, upper and lower arms, wrists, knees) were computed from the 3D skeleton in "
        f"every frame ({s.fps:g} per second) and scored with RULA and REBA frame by frame.",
        "Shares of the shift are shares of the time the worker was tracked; scores are ordinal, so the report "
        "shows time per level, never averages of scores.",
        "Loads, hand coupling and supports cannot be seen by the cameras: they are the assumptions listed for "
        "each worker.",
    )
    settings = tuple(SettingRow(name=st.name, value=_fmt_setting(st.value),
                                meaning=SETTING_MEANINGS.get(st.name, "see docs/scoring.md"))
                     for st in s.settings)
    cal = s.calibration
    if cal is None:
        cal_text = "No calibration information was stored."
    else:
        cal_text = (f"Calibration file {cal.file} (SHA-256 {cal.sha256}) with cameras "
                    f"{', '.join(cal.cameras)}.")
    return MethodsSection(measured=measured, methods=s.methods, settings=settings, models=s.models,
                          version=s.ergopose_version, calibration=cal_text)


def _count(n: int, what: str) -> str:
    """ "1 measurement", "12 measurements"."""
    return f"{n:,} {what}{'' if n == 1 else 's'}"


def _fmt_setting(v: bool | float | str) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def _csv_label(label: str) -> str:
    return label if "csv" in label.lower() else f"{label} (CSV)"


def _csv_link(report_dir: Path | None, path: str, text: str) -> Link:
    href = safe_href(path)
    if href is None:
        return Link(href="", text=text, note="unsafe path ignored")
    if report_dir is not None and not (report_dir / path).is_file():
        return Link(href=href, text=text, note=f"missing: expected {path} next to this report")
    return Link(href=href, text=text, note="")


# -------------------------------------------------------------------------- worker builder


def level_seconds(summary: WorkerSummary, method: str) -> dict[int, float]:
    return {lt.level: lt.seconds for lt in summary.levels if lt.method == method}


def headline(summary: WorkerSummary, method: MethodInfo) -> MethodHeadline:
    secs = level_seconds(summary, method.name)
    colours = _level_colours(method)
    total = summary.observed_s
    rows = []
    for lv in method.action_levels:
        t = secs.get(lv.level, 0.0)
        rows.append(LevelRow(key=f"{method.name}-{lv.level}", level=lv.level, label=lv.label, wording=lv.wording,
                             scores=f"{lv.low}" if lv.low == lv.high else f"{lv.low}-{lv.high}",
                             time=fmt_duration(t), percent=fmt_percent(t, total), colour=colours[lv.level]))
    unscored = summary.unscored_s.get(method.name, 0.0)
    high = [lv for lv in method.action_levels if lv.level in HIGH_LEVELS[method.name]]
    risk = high_risk(method.name, total, secs, unscored)  # the terminal's and session_summary.csv's figures
    names = " or ".join(lv.label for lv in high)
    key = (f"{format_percent(risk.pct_of_tracked)} of the tracked time ({fmt_duration(risk.high_s)}) at "
           f"{METHOD_TITLES[method.name]} level {names}, {format_percent(risk.pct_of_scored)} of the scored time "
           f"({fmt_duration(risk.scored_s)} scored, {fmt_duration(risk.unscored_s)} not scored): {high[0].wording}."
           if high else "")
    return MethodHeadline(method=METHOD_TITLES[method.name], title=method.title, levels=tuple(rows),
                          unscored_time=fmt_duration(unscored), unscored_percent=fmt_percent(unscored, total),
                          key_fact=key)


def confidence_rows(summary: WorkerSummary) -> tuple[tuple[ConfidenceRow, ...], str]:
    """The tracked time by confidence, with causes, and a note on the split (shares of the tracked time)."""
    total = summary.observed_s
    rows = []
    for c in summary.confidence:
        causes = "; ".join(f"{ca.cause} {fmt_duration(ca.seconds)} ({fmt_percent(ca.seconds, total)})"
                           for ca in c.causes)
        rows.append(ConfidenceRow(key=c.level, level=CONFIDENCE_WORDS.get(c.level, c.level),
                                  time=fmt_duration(c.seconds), percent=fmt_percent(c.seconds, total),
                                  causes=causes or "-"))
    if not rows:
        return (), ("How sure each frame's scores are was not recorded with these results (written before "
                    "ergopose measured it): shares below are of the tracked time, scored or not.")
    note = ("Shares are of the tracked time. A frame is scored with confidence when both its RULA and its REBA "
            "score keep their value in most draws of the joints within their measured uncertainty; causes: not "
            "seen = no camera saw the worker, one camera = only one camera did, occluded limbs = joints the "
            "scores need were placed by the body model, uncertain angles = seen, but the angles are too "
            "uncertain for the score.")
    return tuple(rows), note


def input_rows(summary: WorkerSummary) -> tuple[tuple[InputRow, ...], str]:
    """Per body part, how well its RULA/REBA inputs were measured, and how to read the table."""
    rows = []
    for i in summary.inputs:
        sd = math.degrees(i.median_sd_rad)
        share = 100.0 * i.inferred_s / i.known_s if i.known_s > 0 else float("nan")
        uncertain = math.isfinite(sd) and sd >= UNCERTAIN_SD_DEG
        inferred = math.isfinite(share) and share >= MOSTLY_INFERRED_PCT
        verdict = ", ".join(w for w, on in (("mostly inferred", inferred), ("uncertain", uncertain)) if on) or "measured"
        rows.append(InputRow(body_part=i.body_part, median_sd=f"{sd:.1f}°" if math.isfinite(sd) else "n/a",
                             inferred=fmt_percent(i.inferred_s, i.known_s), verdict=verdict,
                             concern=verdict != "measured",
                             task_input=TASK_INPUTS.get(i.body_part, "none: measured only"),
                             from_settings=_settings_words(i.from_settings)))
    if not rows:
        return (), ""
    weak = [r.body_part for r in rows if r.concern]
    lead = (f"The scores of {', '.join(weak)} rest on inputs that were mostly inferred or uncertain: read those "
            "body parts' bands and the scores they feed with care. " if weak else
            "Every body part's inputs were mostly seen and measured with a small spread. ")
    note = (lead + f"Median SD: the median over the shift of the standard deviation of the body part's angles "
            f"(the largest of them in each frame); 'uncertain' from {UNCERTAIN_SD_DEG:g}° (posture bands are "
            f"10-25° wide). Inferred: share of the tracked time in which its joints were placed by the body model, "
            f"not seen by two cameras; 'mostly inferred' from {MOSTLY_INFERRED_PCT:g} %. Where the cameras cannot "
            "settle an input, the session's settings.toml can give it as a task input (the keys in the column "
            "'Task input in settings'; [defaults], [workers.ID] or [[periods]], docs/session-format.md). The wrist "
            "angles given there (wrist_flexion_deg, wrist_deviation_deg) replace the measurement only in frames "
            "where the angle could not be measured or the hand points were all placed by the body model; the last "
            "column gives each value used and its share of the scored time, and the frames CSV names them per "
            "frame (inputs_from_settings). The neck, trunk, arm and knee angles can only be measured.")
    return tuple(rows), note


def _settings_words(values: Sequence) -> str:
    """The settings' values used in place of a body part's unseen angles, with the share of the
    scored time each was used; "none" when there were none."""
    parts = []
    for v in values:
        angle = "flexion" if v.input.endswith("wrist_flexion") else "deviation"
        parts.append(f"{angle} {math.degrees(v.value_rad):g}° in {fmt_percent(v.seconds, v.scored_s)} of the scored time")
    return "; ".join(parts) or "none"


def _level_segments(secs: dict[int, float], unscored: float, method: MethodInfo, unit: str = "time") -> tuple:
    colours = _level_colours(method)
    segs = []
    for lv in method.action_levels:
        t = secs.get(lv.level, 0.0)
        short = lv.label if method.name == "rula" else str(lv.level)
        segs.append(svg.Segment(t, colours[lv.level], short,
                                f"{METHOD_TITLES[method.name]} level {lv.level} ({lv.label}): {fmt_duration(t)}"))
    segs.append(svg.Segment(unscored, None, "", f"not scored: {fmt_duration(unscored)}"))
    return tuple(segs)


def headline_figure(summary: WorkerSummary, session: SessionInfo, who: str) -> Figure:
    rows = []
    for m in session.methods:
        rows.append(svg.StackRow(METHOD_TITLES[m.name], _level_segments(level_seconds(summary, m.name),
                                                                        summary.unscored_s.get(m.name, 0.0), m)))
    fig = svg.stacked_bars(rows, title=f"Share of the tracked time at each action level, {who}",
                           desc="Stacked bars, one per method; each segment is an action level, labelled with its "
                                "name or number; hatched grey is time not scored. The table beside gives the numbers.",
                           id_prefix="fig-headline", total=summary.observed_s, label_width=70,
                           axis_label="share of the tracked time (%)")
    return Figure(id="fig-headline", svg=fig,
                  caption="Share of the tracked time at each action level (RULA AL1-AL4, REBA 0-4; hatched = not "
                          "scored). Exact numbers are in the tables.")


def choose_bin(duration_s: float) -> float:
    for b in BIN_CHOICES_S:
        if duration_s / b <= MAX_BINS:
            return float(b)
    return float(BIN_CHOICES_S[-1])


def binned_scores(time_s: np.ndarray, scores: pd.Series, duration_s: float, bin_s: float,
                  max_score: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per time bin: starts (s), worst score and (lower) median score (NaN where no score).

    Vectorised with one bincount over (bin, score): memory is bins x scores, not frames.
    """
    n_bins = max(1, int(math.ceil(duration_s / bin_s)))
    vals = scores.to_numpy(dtype=np.float64, na_value=np.nan)
    ok = np.isfinite(vals)
    idx = np.clip((time_s[ok] // bin_s).astype(np.int64), 0, n_bins - 1)
    sc = np.clip(vals[ok].astype(np.int64), 0, max_score)
    counts = np.bincount(idx * (max_score + 1) + sc, minlength=n_bins * (max_score + 1)).reshape(n_bins, max_score + 1)
    n = counts.sum(axis=1)
    has = n > 0
    worst = np.where(has, max_score - np.argmax(counts[:, ::-1] > 0, axis=1), np.nan).astype(np.float64)
    cum = counts.cumsum(axis=1)
    median = np.where(has, np.argmax(cum >= ((n + 1) // 2)[:, None], axis=1), np.nan).astype(np.float64)
    return np.arange(n_bins) * bin_s, worst, median


def _time_ticks(duration_s: float, clock: Clock) -> list[tuple[float, str]]:
    for step in (5, 10, 15, 30, 60, 120, 300, 600, 900, 1800, 3600, 7200):
        if duration_s / step <= 10:
            break
    if clock.known:
        assert clock.start is not None
        first = clock.start.replace(minute=0, second=0, microsecond=0)
        offset = (first - clock.start).total_seconds()
        k0 = math.ceil(-offset / step)
        ticks = [offset + k * step for k in range(k0, int((duration_s - offset) // step) + 1)]
    else:
        ticks = [k * step for k in range(int(duration_s // step) + 1)]
    return [(t, clock(t, seconds=step < 60)) for t in ticks if 0 <= t <= duration_s]


def timeline_figures(frames: pd.DataFrame, session: SessionInfo, who: str, clock: Clock) -> tuple[tuple[Figure, ...], str]:
    bin_s = choose_bin(session.duration_s)
    t = frames["time_s"].to_numpy(dtype=np.float64)
    figs = []
    for m, col in (("rula", "rula_grand"), ("reba", "reba_score")):
        meth = session.method(m)
        starts, worst, med = binned_scores(t, frames[col], session.duration_s, bin_s, meth.score_high)
        colours = _level_colours(meth)
        bands = [svg.Band(lv.low - 0.5, lv.high + 0.5, colours[lv.level],
                          f"{lv.label}" if m == "rula" else f"{lv.level} {lv.label}") for lv in meth.action_levels]
        fig = svg.score_timeline(
            starts, bin_s, worst, med, bands, y_min=meth.score_low - 0.5, y_max=meth.score_high + 0.5,
            x_ticks=_time_ticks(session.duration_s, clock),
            title=f"{METHOD_TITLES[m]} score over the shift, {who}",
            desc=f"For each {fmt_duration(bin_s)} of the shift, a bar up to the worst {METHOD_TITLES[m]} score in it, "
                 "coloured by its action level, and a black step line at the median score; the action levels are "
                 "named at the right. Hatched marks under the axis: not tracked or not scored.",
            id_prefix=f"fig-timeline-{m}", y_label=f"{METHOD_TITLES[m]} score")
        figs.append(Figure(id=f"fig-timeline-{m}", svg=fig,
                           caption=f"{METHOD_TITLES[m]} over the shift: bars = worst score in each {fmt_duration(bin_s)} "
                                   "(colour and height = action level), black line = median score."))
    note = (f"Each point of the timelines summarises {fmt_duration(bin_s)} of the shift ({len(starts)} periods); "
            "all other numbers on this page come from every frame.")
    return tuple(figs), note


def body_part_section(summary: WorkerSummary, who: str) -> tuple[tuple[Figure, ...], tuple[BandRow, ...]]:
    total = summary.observed_s
    rows = tuple(BandRow(method=METHOD_TITLES.get(b.method, b.method), body_part=b.body_part, score=b.score,
                         criterion=b.criterion, time=fmt_duration(b.seconds), percent=fmt_percent(b.seconds, total))
                 for b in summary.body_parts)
    figs = []
    for m in ("rula", "reba"):
        parts: dict[str, list] = {}
        for b in summary.body_parts:
            if b.method == m:
                parts.setdefault(b.body_part, []).append(b)
        if not parts:
            continue
        stack = []
        for part, bands in parts.items():
            bands = sorted(bands, key=lambda b: b.score)
            segs = [svg.Segment(b.seconds, _band_colour(b.score), str(b.score),
                                f"{part}, score {b.score} ({b.criterion}): {fmt_duration(b.seconds)}") for b in bands]
            rest = max(total - sum(b.seconds for b in bands), 0.0)
            segs.append(svg.Segment(rest, None, "", f"{part} not measured: {fmt_duration(rest)}"))
            stack.append(svg.StackRow(part, tuple(segs)))
        fig = svg.stacked_bars(stack, title=f"Time per posture band of each body part ({METHOD_TITLES[m]}), {who}",
                               desc="One bar per body part; each segment is a posture band, labelled with its band "
                                    "score (1 = best). Hatched grey: the angle was not measured. Numbers in the table.",
                               id_prefix=f"fig-parts-{m}", total=total if total > 0 else None,
                               axis_label="share of the tracked time (%)", hatch_label="angle not measured")
        figs.append(Figure(id=f"fig-parts-{m}", svg=fig,
                           caption=f"{METHOD_TITLES[m]} posture bands per body part (number = band score, higher is "
                                   "worse), as a share of the tracked time."))
    return tuple(figs), rows


def worst_moments(summary: WorkerSummary, session: SessionInfo, who: str, clock: Clock,
                  limit: int = MAX_PERIODS, prefix: str = "") -> tuple[MomentCard, ...]:
    """The sustained periods of high risk of a worker as cards (ranked as stored); prefix: of the
    figures' ids (unique when several workers share a page)."""
    cards = []
    rula, reba = session.method("rula"), session.method("reba")

    def words(score: int | None, level: int | None, peak: int | None, meth: MethodInfo) -> str:
        if score is None:
            text = "not scored"
        else:
            lv = next((x for x in meth.action_levels if x.level == level), None)
            text = f"{score} ({lv.label})" if lv else f"{score}"
        if peak is not None and peak != score:
            text += f", up to {peak}"
        return text

    for k, w in enumerate(summary.worst[:limit], start=1):
        if w.joints_world_m is None:
            joints = np.full((33, 3), np.nan)
        else:
            joints = np.asarray(w.joints_world_m, dtype=np.float64)
        fig = svg.skeleton_views(joints, title=f"Posture of {who} at {clock(w.peak_s)}",
                                 desc=f"Front and side view of the 3D skeleton at {clock(w.peak_s)}: {w.reason}. "
                                      "Left limbs solid blue, right limbs dashed red; L and R mark the wrists.",
                                 id_prefix=f"{prefix}fig-moment-{k}")
        length = w.end_s - w.start_s
        high = (f"{fmt_duration(w.high_s)} ({fmt_percent(w.high_s, length)})" if math.isfinite(w.high_s)
                else "not recorded")
        drivers = tuple(DriverRow(body_part=d.body_part, band=f"{d.score} of {d.top}", criterion=d.criterion,
                                  time=fmt_duration(d.seconds), percent=fmt_percent(d.seconds, w.high_s))
                        for d in w.drivers)
        base = w.high_s if math.isfinite(w.high_s) else length
        inputs = tuple(PeriodInputRow(input=i.input, source=i.source, value=i.value,
                                      time=f"{fmt_duration(i.seconds)} ({fmt_percent(i.seconds, base)})", use=i.use)
                       for i in w.inputs)
        cards.append(MomentCard(
            rank=k, start=clock(w.start_s), end=clock(w.end_s), duration=fmt_duration(length), high_time=high,
            when=clock(w.peak_s), rula=words(w.rula_grand, w.rula_level, w.rula_peak, rula),
            reba=words(w.reba_score, w.reba_level, w.reba_peak, reba), drivers=drivers, reason=w.reason,
            task_inputs=task_inputs_line(w.inputs, base), inputs=inputs,
            figure=Figure(id=f"{prefix}fig-moment-{k}", svg=fig,
                          caption=f"Period {k} at {clock(w.peak_s)}: front view (worker's right on the left) and side "
                                  "view (seen from the worker's right). No video images are kept.")))
    return tuple(cards)


def task_inputs_line(inputs, high_s: float) -> str:
    """The task inputs of a period in one line: each given value (with its time when it held for
    only part of the high-risk time), then those not given; "not recorded" for older results."""
    if not inputs:
        return "not recorded"
    given, missing = [], []
    for i in inputs:
        if i.source == "task input":
            part = "" if i.seconds >= high_s - 1e-6 else f" ({fmt_duration(i.seconds)})"
            given.append(f"{i.input}: {i.value}{part}")
        elif i.source == "not given" and i.input not in missing:
            missing.append(i.input)
    text = "; ".join(given) if given else "none given"
    return text + (f"; not given: {', '.join(missing)}" if missing else "")


def act_summary(res: WorkerResults, session: SessionInfo, limit: int = MAX_PERIODS) -> str:
    """How much of the worker's high-risk time the periods shown hold, and the body parts that
    drove most of them (summed over the periods), in a sentence."""
    frames: pd.DataFrame = res.frames  # type: ignore[assignment]
    shown = res.summary.worst[:limit]
    high = periods.high_frames(frames["rula_action_level"].to_numpy(dtype=np.float64, na_value=np.nan),
                               frames["reba_risk_level"].to_numpy(dtype=np.float64, na_value=np.nan))
    high_s = float(high.sum()) / session.fps
    if not shown:
        return (f"No sustained period of high risk: {fmt_duration(high_s)} at high risk in all, in stretches "
                f"shorter than {periods.MIN_DURATION_S:g} s.")
    if not all(math.isfinite(w.high_s) for w in shown):
        return f"{len(shown)} periods of high risk (results written before sustained periods were found)."
    in_periods = sum(w.high_s for w in shown)
    parts: dict[tuple, list[float]] = {}
    for w in shown:
        for d in w.drivers:
            parts.setdefault((d.body_part, d.criterion, d.score, d.top), []).append(d.seconds)
    ranked = sorted(parts.items(), key=lambda kv: (-sum(kv[1]), kv[0]))[:3]
    drivers = "; ".join(f"{bp} {crit} (band {sc} of {top}) for {fmt_duration(sum(v))} in {len(v)} of them"
                        for (bp, crit, sc, top), v in ranked)
    n = len(shown)
    return (f"The {n} sustained period{'s' if n != 1 else ''} shown hold {fmt_duration(in_periods)} of the worker's "
            f"{fmt_duration(high_s)} at high risk ({fmt_percent(in_periods, high_s)})."
            + (f" Body parts in a high band in them: {drivers}." if drivers else ""))


def worst_note(session: SessionInfo) -> str:
    """The rule of the sustained periods, in words."""
    rula, reba = session.method("rula"), session.method("reba")
    hi = {m.name: " or ".join(lv.label for lv in m.action_levels if lv.level in periods.HIGH_LEVELS[m.name])
          for m in (rula, reba)}
    return (f"A sustained period of high risk is a stretch of frames at RULA {hi['rula']} or REBA {hi['reba']}, "
            f"joined across gaps of at most {periods.MAX_GAP_S:g} s (lower scores, not scored or not tracked), "
            f"lasting at least {periods.MIN_DURATION_S:g} s from its first to its last high-risk frame: one-frame "
            f"spikes are left out. Periods are ranked by their time at high risk; at most {periods.MAX_PERIODS} are "
            "shown. Each is drawn at the middle of the posture (the RULA and REBA scores) held longest in it. Body "
            f"parts: those in one of their two highest RULA posture bands for at least "
            f"{100 * DRIVER_SHARE:.0f} % of the period's high-risk time (band 3 of 4 = the third of four bands).")


#: Risk categories of the timelines (high, medium, low), per method: the levels in each.
RISK_LEVELS = {"rula": {"high": (3, 4), "medium": (2,), "low": (1,)},
               "reba": {"high": (3, 4), "medium": (2,), "low": (0, 1)}}
RISK_ORDER = ("high", "medium", "low")
NOT_SCORED = len(RISK_ORDER)


def risk_codes(frames: pd.DataFrame, method: str | None) -> np.ndarray:
    """Per frame: 0 high, 1 medium, 2 low, 3 not scored, by one method's level, or (method None)
    the worse of the two methods' scored categories (not scored when neither is scored)."""
    if method is None:
        return np.minimum(risk_codes(frames, "rula"), risk_codes(frames, "reba"))
    col = {"rula": "rula_action_level", "reba": "reba_risk_level"}[method]
    lv = frames[col].to_numpy(dtype=np.float64, na_value=np.nan)
    code = np.full(lv.shape, NOT_SCORED, dtype=np.int64)
    for k, cat in enumerate(RISK_ORDER):
        code[np.isin(lv, RISK_LEVELS[method][cat])] = k
    return code


def risk_shares(time_s: np.ndarray, codes: np.ndarray, duration_s: float, bin_s: float, fps: float) -> np.ndarray:
    """(bins, 4): share of each time bin at high, medium, low risk and not scored (one bincount);
    the rest of a bin was not tracked. The last bin may be partial: its share is of its own length."""
    n_bins = max(1, int(math.ceil(duration_s / bin_s)))
    idx = np.clip((np.asarray(time_s) // bin_s).astype(np.int64), 0, n_bins - 1)
    counts = np.bincount(idx * 4 + codes, minlength=n_bins * 4).reshape(n_bins, 4).astype(np.float64)
    length = np.minimum(bin_s, duration_s - np.arange(n_bins) * bin_s) * fps
    total = np.maximum(np.maximum(length, counts.sum(axis=1)), 1.0)
    return counts / total[:, None]


def risk_legend(session: SessionInfo) -> tuple[str, ...]:
    """The words of each category of the risk timelines (RISK_FILLS order, then not tracked)."""
    out = []
    for cat in RISK_ORDER:
        parts = []
        for m in (session.method("rula"), session.method("reba")):
            labels = [lv.label for lv in m.action_levels if lv.level in RISK_LEVELS[m.name][cat]]
            parts.append(f"{METHOD_TITLES[m.name]} {'/'.join(labels)}")
        out.append(f"{cat} ({', '.join(parts)})")
    return (*out, "not scored", "not tracked")


def risk_figure(rows: Sequence[tuple[str, pd.DataFrame, str | None]], session: SessionInfo, clock: Clock, *,
                fig_id: str, title: str, marks: Sequence[tuple[float, float, str]] = (),
                label_width: float = 60) -> Figure:
    """The shift by time of day: a strip per (label, frames, method or None for either)."""
    bin_s = choose_bin(session.duration_s)
    strips = [svg.StripRow(label, risk_shares(f["time_s"].to_numpy(dtype=np.float64), risk_codes(f, m),
                                              session.duration_s, bin_s, session.fps))
              for label, f, m in rows]
    legend = risk_legend(session)
    fig = svg.risk_strips(strips, bin_s, x_ticks=_time_ticks(session.duration_s, clock), title=title,
                          desc=f"Time runs left to right ({'clock time' if clock.known else 'time from the start'}); "
                               f"each {fmt_duration(bin_s)} column is split by the share of it at "
                               + "; ".join(legend) + ". Numbered brackets mark the sustained periods of high risk.",
                          id_prefix=fig_id, legend=legend, marks=marks, label_width=label_width)
    return Figure(id=fig_id, svg=fig,
                  caption=f"The shift by time of day, in {fmt_duration(bin_s)} columns: red = high, yellow = medium, "
                          "green = low risk, hatched = tracked but not scored, white = not tracked"
                          + ("; numbered brackets = the sustained periods of high risk." if marks else "."))


def glossary(session: SessionInfo) -> tuple[Term, ...]:
    """Every abbreviation and coded word the pages use, with its meaning."""
    rula, reba = session.method("rula"), session.method("reba")
    terms = [Term("RULA", f"{rula.title}: final (grand) score {rula.score_low}-{rula.score_high}"),
             Term("REBA", f"{reba.title}: final score {reba.score_low}-{reba.score_high}")]
    terms += [Term(f"RULA {lv.label}", f"action level {lv.level}, scores {lv.low}-{lv.high}: {lv.wording}")
              for lv in rula.action_levels]
    terms += [Term(f"REBA {lv.level} {lv.label}", f"risk level {lv.level}, scores {lv.low}-{lv.high}: {lv.wording}")
              for lv in reba.action_levels]
    terms += [
        Term("high, medium, low", "; ".join(risk_legend(session)[:3])),
        Term("not scored", "the worker was tracked but a score could not be given (joints the score needs were "
                           "missing or too uncertain)"),
        Term("not tracked", "the worker was not found in the frames (out of view, or away)"),
        Term("band", "the posture band of a body part on the RULA/REBA worksheet (1 = best); '3 of 4' = the "
                     "third of its four bands"),
        Term("n/a", "not applicable: nothing to take a share of (no time of that kind)"),
        Term("SD", "standard deviation"),
        Term("ISO 11226, EN 1005-4", "standards for static working postures and for postures and movements at "
                                     "machinery"),
        Term("°, deg", "degrees of angle"),
    ]
    return tuple(terms)


PRINT_FILE = "print.html"
#: Sustained periods in a worker's print pages (the second page holds their drawings).
PRINT_PERIODS = 6


def print_link() -> Link:
    return Link(href=PRINT_FILE, text="Print version (one summary page, then at most two pages per worker)",
                note="")


def hourly_section(summary: WorkerSummary, session: SessionInfo, who: str, clock: Clock) -> tuple[tuple[Figure, ...], tuple[HourTable, ...]]:
    figs, tables = [], []
    for m in ("rula", "reba"):
        meth = session.method(m)
        hours = sorted((h for h in summary.hourly if h.method == m), key=lambda h: h.start_s)
        if not hours:
            continue
        cols, rows = [], []
        for h in hours:
            secs = {lt.level: lt.seconds for lt in h.levels}
            label = f"{clock(max(h.start_s, 0.0), seconds=False)}"
            segs = tuple(svg.Segment(s.value / 60.0, s.colour, s.short, s.long)
                         for s in _level_segments(secs, h.unscored_s, meth))
            cols.append(svg.StackColumn(label, segs))
            end = min(h.start_s + 3600.0, session.duration_s)
            rows.append(HourRow(hour=f"{clock(max(h.start_s, 0.0), seconds=False)}-{clock(end, seconds=False)}",
                                tracked=fmt_duration(h.observed_s),
                                cells=tuple(_hour_cell(secs.get(lv.level, 0.0)) for lv in meth.action_levels)
                                + (_hour_cell(h.unscored_s),)))
        fig = svg.stacked_columns(cols, title=f"{METHOD_TITLES[m]} action levels per hour, {who}",
                                  desc="One column per hour; segments are minutes at each action level (labelled), "
                                       "hatched grey is time not scored. The table below gives the minutes.",
                                  id_prefix=f"fig-hourly-{m}", y_max=60, y_label="minutes", y_ticks=(0, 15, 30, 45, 60))
        figs.append(Figure(id=f"fig-hourly-{m}", svg=fig,
                           caption=f"Minutes per hour at each {METHOD_TITLES[m]} action level (hatched = not scored)."))
        columns = tuple(f"{lv.label}" if m == "rula" else f"{lv.level} {lv.label}" for lv in meth.action_levels)
        tables.append(HourTable(method=METHOD_TITLES[m], columns=columns + ("not scored",), rows=tuple(rows)))
    return tuple(figs), tuple(tables)


def _hour_cell(seconds: float) -> str:
    """Time in an hour-table cell: "-" for none, else a duration ("4 min 10 s", "0.4 s")."""
    return "-" if not seconds > 0 else fmt_duration(seconds)


def floor_section(frames: pd.DataFrame, session: SessionInfo, who: str) -> tuple[tuple[Figure, ...], str]:
    fp = session.floor
    nx = max(1, int(round((fp.x_max - fp.x_min) / fp.cell_m)))
    ny = max(1, int(round((fp.y_max - fp.y_min) / fp.cell_m)))
    x = frames["floor_x_m"].to_numpy(dtype=np.float64)
    y = frames["floor_y_m"].to_numpy(dtype=np.float64)
    ok = np.isfinite(x) & np.isfinite(y)
    dt = 1.0 / session.fps
    edges = (np.linspace(fp.y_min, fp.y_max, ny + 1), np.linspace(fp.x_min, fp.x_max, nx + 1))
    presence, _, _ = np.histogram2d(y[ok], x[ok], bins=edges)
    outlines = [svg.Outline(f.name, f.x0, f.y0, f.x1, f.y1, f.kind) for f in fp.furniture]
    markers = [svg.Marker(c.name, c.x, c.y) for c in fp.cameras]
    figs = []
    for m, col in (("rula", "rula_action_level"), ("reba", "reba_risk_level")):
        meth = session.method(m)
        lv = frames[col].to_numpy(dtype=np.float64, na_value=np.nan)
        risky = ok & np.isin(lv, HIGH_LEVELS[m])
        grid, _, _ = np.histogram2d(y[risky], x[risky], bins=edges)
        names = " or ".join(x.label for x in meth.action_levels if x.level in HIGH_LEVELS[m])
        secs = grid * dt
        unit, scale = ("minutes", 60.0) if secs.size and float(secs.max()) >= 120.0 else ("seconds", 1.0)
        fig = svg.heat_map(secs / scale, (fp.x_min, fp.x_max, fp.y_min, fp.y_max),
                           title=f"Where {who} worked at {METHOD_TITLES[m]} level {names}",
                           desc=f"Floor plan of the {fp.x_max - fp.x_min:g} x {fp.y_max - fp.y_min:g} m area seen from "
                                f"above, in {fp.cell_m:g} m squares; darker squares = more {unit} at {METHOD_TITLES[m]} "
                                f"level {names} (legend at the right); light grey = present but not at that level; "
                                "blue outlines = furniture, diamonds = cameras.",
                           id_prefix=f"fig-floor-{m}", unit=unit, outlines=outlines, markers=markers,
                           presence=presence)
        figs.append(Figure(id=f"fig-floor-{m}", svg=fig,
                           caption=f"{unit.capitalize()} at {METHOD_TITLES[m]} level {names} per {fp.cell_m:g} m square of floor "
                                   "(seen from above; position = middle of the hips)."))
    located = float(ok.sum()) * dt
    note = (f"The worker's floor position was known for {fmt_duration(located)} of the tracked time. "
            + ("Furniture outlines come from the session's floor plan." if fp.furniture else
               "No furniture layout was given for this session."))
    return tuple(figs), note


def quality_section(res: WorkerResults, session: SessionInfo, who: str) -> QualitySection:
    d = res.diagnostics
    verdict = quality_verdict(d, session.calibration)
    reliable = (f"The skeleton was reliable for {fmt_percent(d.frames_reliable, d.frames_observed)} of the tracked "
                f"time ({fmt_duration(d.frames_reliable / session.fps)} of {fmt_duration(d.frames_observed / session.fps)}"
                f"), that is {fmt_percent(d.frames_reliable, session.frames)} of the whole session. Rule: "
                f"{d.reliable_rule}.")
    order = [name for name, _, _ in LIMBS]
    stats = sorted((s for s in d.limb_lengths if s.region == "all"),
                   key=lambda s: order.index(s.limb) if s.limb in order else len(order))
    by_region = {(s.limb, s.region): s for s in d.limb_lengths}
    region_spread = tuple(
        RegionSpreadRow(limb=s.limb.replace("_", " "),
                        cells=tuple(_spread(by_region.get((s.limb, reg))) for reg in ("central", "outer", "edge")))
        for s in stats)
    boxes = [svg.BoxRow(s.limb.replace("_", " "), 100 * s.p5_m, 100 * s.q1_m, 100 * s.median_m, 100 * s.q3_m,
                        100 * s.p95_m, s.n) for s in stats]
    limb_fig = svg.box_plots(boxes, title=f"3D limb lengths over the shift, {who}",
                             desc="Box plots per limb: box = middle half of the measured lengths, thick line = median, "
                                  "whiskers = 5th to 95th percentile, in centimetres. A real limb does not change "
                                  "length, so a wide box means noisy measurement. Numbers in the table below.",
                             id_prefix="fig-limbs", unit="length (cm)")
    rows = tuple(LimbRow(limb=s.limb.replace("_", " "), n=f"{s.n:,}", median=_cm(s.median_m),
                         iqr=f"{_cm(s.q1_m)} to {_cm(s.q3_m)}", whiskers=f"{_cm(s.p5_m)} to {_cm(s.p95_m)}",
                         mean_sd=f"{_cm(s.mean_m)} ± {_cm(s.std_m)}" if s.n >= 2 else _cm(s.mean_m)) for s in stats)
    # reconstruction frequency: one panel per region
    freq = {(r.limb, r.region): r for r in d.reconstruction}
    limbs = [n for n in order if any((n, reg) in freq for reg in ("all", "central", "outer", "edge"))]
    panels = []
    for reg in ("all", "central", "outer", "edge"):
        vals = []
        for limb in limbs:
            r = freq.get((limb, reg))
            vals.append(100.0 * r.reconstructed / r.frames if r is not None and r.frames > 0 else float("nan"))
        panels.append((REGION_NAMES[reg], vals))
    freq_fig = svg.bar_panels([n.replace("_", " ") for n in limbs], panels,
                              title=f"Reconstruction frequency per limb and lens region, {who}",
                              desc="Per limb, the percentage of tracked frames in which the limb was reconstructed in "
                                   "3D: whole field of view, then the central, outer and edge regions of the lenses. "
                                   "Each bar is labelled with its percentage; 'no data' = never in that region.",
                              id_prefix="fig-frequency")
    total_frames = sum(d.region_frames.values())
    regions = []
    for reg in ("central", "outer", "edge"):
        nfr = d.region_frames.get(reg, 0)
        fr = [freq[(limb, reg)] for limb in SCORED_LIMBS if (limb, reg) in freq and freq[(limb, reg)].frames > 0]
        rec = (f"{100 * float(np.median([r.reconstructed / r.frames for r in fr])):.1f} %" if fr else "n/a")
        regions.append(RegionRow(region=REGION_NAMES[reg], time=fmt_duration(nfr / session.fps),
                                 percent=fmt_percent(nfr, total_frames), reconstruction=rec))
    cal_rows, cal_note = calibration_rows(session)
    inputs, inputs_note = input_rows(res.summary)
    err = (f"Against ground truth, the median 3D joint error was {100 * d.error_3d_m:.1f} cm."
           if math.isfinite(d.error_3d_m) else "")
    return QualitySection(
        verdict=verdict, verdict_label=RATING_LABELS[verdict.rating], reliable=reliable,
        limb_figure=Figure(id="fig-limbs", svg=limb_fig,
                           caption="Limb lengths (cm): box = middle half, line = median, whiskers = 5th-95th percentile."),
        limb_rows=rows,
        frequency_figure=Figure(id="fig-frequency", svg=freq_fig,
                                caption="Share of tracked frames (%) in which each limb was reconstructed, overall and "
                                        "per lens region (central, outer, edge)."),
        region_spread=region_spread, regions=tuple(regions), calibration_rows=cal_rows, calibration_note=cal_note,
        error_3d=err, video=skipped_sentence(session), inputs=inputs, inputs_note=inputs_note)


def skipped_sentence(session: SessionInfo) -> str:
    """The quality section's sentence on the video frames that could not be read and were skipped."""
    if not session.skipped_frames:
        return "Every frame of every camera's video was read."
    parts = []
    for r in session.skipped_frames:
        spans = ", ".join(_clock_s(a) if b - a < 0.5 / session.fps else f"{_clock_s(a)} to {_clock_s(b)}"
                          for a, b in r.spans_s)
        more = " and later" if len(r.spans_s) >= MAX_SKIPPED_SPANS else ""
        parts.append(f"{r.camera}: {r.frames:,} frame{'s' if r.frames != 1 else ''} "
                     f"({fmt_percent(r.frames, session.frames)} of the session) at {spans}{more}")
    return ("Some video frames could not be read and were skipped; in them nobody was measured from that "
            "camera (the skipped-frames CSV file lists every one). " + "; ".join(parts) + ".")


def _clock_s(seconds: float) -> str:
    """Shift time as h:mm:ss.s."""
    h, rem = divmod(float(seconds), 3600.0)
    m, sec = divmod(rem, 60.0)
    return f"{int(h)}:{int(m):02d}:{sec:04.1f}"


def _spread(s) -> str:
    """A limb's length spread in one region: "1.2 cm (n = 3,456)", or "no data"."""
    if s is None or s.n == 0 or not (math.isfinite(s.q1_m) and math.isfinite(s.q3_m)):
        return "no data"
    if s.n == 1:
        return "one frame: no spread"
    return f"{100 * (s.q3_m - s.q1_m):.1f} cm (n = {s.n:,})"


def _cm(m: float) -> str:
    return f"{100 * m:.1f} cm" if math.isfinite(m) else "n/a"


FLAG_ORDER = FLAG_VERDICTS[-1:] + FLAG_VERDICTS[:-1]  # sort key: not measured last, worst first
FLAG_SEVERITY = {"acceptable": "ok", "conditionally acceptable": "caution", "time-limited": "caution",
                 "not recommended": "bad", "not acceptable": "bad", "not measured": "unknown"}


def build_worker_page(res: WorkerResults, session: SessionInfo, report_dir: Path | None = None) -> WorkerPage:
    """The context of one worker's page."""
    info, summ = res.info, res.summary
    frames: pd.DataFrame = res.frames  # type: ignore[assignment]
    who = display_name(info.worker_id, info.name)
    clock = Clock(session.start)
    header = session_header(session)
    nav = [Link(href="index.html", text="Session overview", note="")]
    nav += [Link(href=quote(worker_page_name(w.worker_id)), text=display_name(w.worker_id, w.name), note="")
            for w in session.workers if w.worker_id != info.worker_id]
    tracked = (f"{who} was tracked for {fmt_duration(summ.observed_s)} of the {fmt_duration(session.duration_s)} "
               f"recorded ({fmt_percent(summ.observed_s, session.duration_s)}). Shares below are shares of the "
               "tracked time unless they say otherwise.")
    conf_rows, conf_note = confidence_rows(summ)
    timeline, tl_note = timeline_figures(frames, session, who, clock)
    part_figs, part_rows = body_part_section(summ, who)
    holds = tuple(HoldRow(body_part=h.body_part, method=METHOD_TITLES.get(h.method, h.method), score=h.score,
                          criterion=h.criterion, start=clock(h.start_s), duration=fmt_duration(h.duration_s))
                  for h in summ.holds)
    reps = tuple(RepetitionRow(body_part=r.body_part, actions=f"{r.actions:,}", per_minute=f"{r.per_minute:.1f}",
                               max=f"{r.max_in_one_minute}", limit=f"{r.limit_per_min:g}",
                               over_limit=f"{r.minutes_over_limit} min")
                 for r in summ.repetitions)
    hourly_figs, hourly_tables = hourly_section(summ, session, who, clock)
    flags = tuple(FlagRow(standard=f.standard, body_part=f.body_part, condition=f.condition, verdict=f.verdict,
                          severity=FLAG_SEVERITY[f.verdict], time=fmt_duration(f.seconds),
                          longest=fmt_duration(f.longest_s), note=f.note)
                  for f in sorted(summ.flags, key=lambda f: -FLAG_ORDER.index(f.verdict)))
    floor_figs, floor_note = floor_section(frames, session, who)
    downloads = tuple(_csv_link(report_dir, f.path, _csv_label(f.label)) for f in info.csv_files + session.csv_files)
    worst = worst_moments(summ, session, who, clock)
    return WorkerPage(
        page_title=f"{who}: ergonomic report, {header.title}", session=header, worker_id=info.worker_id,
        display_name=who, nav=tuple(nav), tracked=tracked, confidence_rows=conf_rows, confidence_note=conf_note,
        headline=tuple(headline(summ, m) for m in session.methods),
        headline_figure=headline_figure(summ, session, who), timeline_figures=timeline, timeline_note=tl_note,
        body_part_figures=part_figs, body_part_rows=part_rows, holds=holds, repetitions=reps,
        worst=worst, worst_note=worst_note(session), act_summary=act_summary(res, session), risk_figure=worker_risk_figure(res, session, clock),
        hourly_figures=hourly_figs, hourly_tables=hourly_tables,
        flags=flags, floor_figures=floor_figs, floor_note=floor_note, quality=quality_section(res, session, who),
        assumptions=info.assumptions, methods=methods_section(session), downloads=downloads, print_link=print_link(),
        glossary=glossary(session))


def worker_risk_figure(res: WorkerResults, session: SessionInfo, clock: Clock, prefix: str = "") -> Figure:
    """A worker's shift by time of day (a RULA and a REBA strip) with the sustained periods marked."""
    frames: pd.DataFrame = res.frames  # type: ignore[assignment]
    marks = [(w.start_s, w.end_s, str(k)) for k, w in enumerate(res.summary.worst[:MAX_PERIODS], start=1)]
    who = display_name(res.info.worker_id, res.info.name)
    return risk_figure([("RULA", frames, "rula"), ("REBA", frames, "reba")], session, clock, fig_id=f"{prefix}fig-risk",
                       title=f"The shift of {who} by time of day: high, medium and low risk", marks=marks)


# --------------------------------------------------------------------------- index builder


def worker_row(res: WorkerResults, session: SessionInfo, report_dir: Path | None = None) -> WorkerRow:
    """A worker's row in the index's and the print version's table."""
    info, summ, d = res.info, res.summary, res.diagnostics
    who = display_name(info.worker_id, info.name)
    verdict = quality_verdict(d, session.calibration)
    highs = {m: format_percent(high_risk(m, summ.observed_s, level_seconds(summ, m),
                                         summ.unscored_s.get(m, 0.0)).pct_of_tracked) for m in ("rula", "reba")}
    conf = {c.level: fmt_percent(c.seconds, summ.observed_s) for c in summ.confidence}
    shown = summ.worst[:MAX_PERIODS]
    if shown and all(math.isfinite(w.high_s) for w in shown):
        periods_text = f"{len(shown)} ({fmt_duration(sum(w.high_s for w in shown))})"
    else:
        periods_text = f"{len(shown)}" if shown else "none"
    return WorkerRow(
        display_name=who, page=Link(href=quote(worker_page_name(info.worker_id)), text=who, note=""),
        tracked=fmt_duration(summ.observed_s), confident=conf.get("confident", "n/a"),
        low_confidence=conf.get("low", "n/a"), unscored=conf.get("unscored", "n/a"),
        rula_high=highs["rula"], reba_high=highs["reba"],
        reliable=fmt_percent(d.frames_reliable, d.frames_observed), verdict_label=RATING_LABELS[verdict.rating],
        verdict_rating=verdict.rating, csv=tuple(_csv_link(report_dir, f.path, f.label) for f in info.csv_files),
        periods=periods_text)


def session_risk_figure(workers: Sequence[WorkerResults], session: SessionInfo) -> Figure:
    """Every worker's shift by time of day, one strip each (the worse of RULA and REBA)."""
    rows = [(f"{r.info.worker_id} {r.info.name}" if r.info.name else r.info.worker_id, r.frames, None) for r in workers]
    return risk_figure(rows, session, Clock(session.start), fig_id="fig-risk-all", label_width=170,  # type: ignore[misc]
                       title="Each worker's shift by time of day: high, medium and low risk (the worse of RULA "
                             "and REBA)")


def build_index_page(workers: Sequence[WorkerResults], session: SessionInfo, report_dir: Path | None = None) -> IndexPage:
    """The context of the session overview page."""
    header = session_header(session)
    figs = []
    for m in session.methods:
        stack = []
        for res in workers:
            who = display_name(res.info.worker_id, res.info.name)
            stack.append(svg.StackRow(who, _level_segments(level_seconds(res.summary, m.name),
                                                           res.summary.unscored_s.get(m.name, 0.0), m)))
        fig = svg.stacked_bars(stack, title=f"{METHOD_TITLES[m.name]}: share of the tracked time at each level, per worker",
                               desc="One bar per worker; segments are action levels, labelled; hatched grey is time "
                                    "not scored. Numbers are in the table and on each worker's page.",
                               id_prefix=f"fig-overview-{m.name}", axis_label="share of the tracked time (%)")
        figs.append(Figure(id=f"fig-overview-{m.name}", svg=fig,
                           caption=f"{METHOD_TITLES[m.name]} action levels per worker (share of tracked time; hatched = "
                                   "not scored)."))
    rows = tuple(worker_row(res, session, report_dir) for res in workers)
    cal_rows, cal_note = calibration_rows(session)
    return IndexPage(page_title=f"Ergonomic report: {header.title}", session=header, workers=rows,
                     risk_figure=session_risk_figure(workers, session),
                     overview_figures=tuple(figs), calibration_rows=cal_rows, calibration_note=cal_note,
                     methods=methods_section(session),
                     downloads=tuple(_csv_link(report_dir, f.path, _csv_label(f.label)) for f in session.csv_files),
                     print_link=print_link(), glossary=glossary(session))


def _print_row(r: WorkerRow, info: WorkerInfo) -> PrintRow:
    return PrintRow(worker_id=info.worker_id, name=info.name or "", tracked=r.tracked, confident=r.confident,
                    low_confidence=r.low_confidence, unscored=r.unscored, rula_high=r.rula_high, reba_high=r.reba_high,
                    periods=r.periods, verdict_label=r.verdict_label, verdict_rating=r.verdict_rating)


def build_print_page(workers: Sequence[WorkerResults], session: SessionInfo,
                     report_dir: Path | None = None) -> PrintPage:
    """The context of the print version: the summary page, then each worker's (at most two) pages."""
    header = session_header(session)
    clock = Clock(session.start)
    out = []
    for n, res in enumerate(workers, start=1):
        summ = res.summary
        who = display_name(res.info.worker_id, res.info.name)
        cards = worst_moments(summ, session, who, clock, limit=PRINT_PERIODS, prefix=f"w{n}-")
        left = len(summ.worst) - len(cards)
        out.append(PrintWorker(
            worker_id=res.info.worker_id, display_name=who,
            tracked=(f"Tracked for {fmt_duration(summ.observed_s)} of the {fmt_duration(session.duration_s)} recorded "
                     f"({fmt_percent(summ.observed_s, session.duration_s)}); shares are of the tracked time."),
            headline=tuple(headline(summ, m) for m in session.methods), act_summary=act_summary(res, session),
            confidence_rows=confidence_rows(summ)[0], risk_figure=worker_risk_figure(res, session, clock, f"w{n}-"),
            worst=cards, more=(f"{left} more period{'s' if left != 1 else ''} on the worker's page." if left > 0
                               else "")))
    return PrintPage(page_title=f"Ergonomic report (print): {header.title}", session=header,
                     workers_table=tuple(_print_row(worker_row(res, session, report_dir), res.info) for res in workers),
                     risk_figure=session_risk_figure(workers, session), worst_note=worst_note(session),
                     workers=tuple(out), glossary=glossary(session))


__all__ = [
    "Link", "Figure", "SessionHeader", "SettingRow", "MethodsSection", "CalibrationRow", "LevelRow", "MethodHeadline",
    "ConfidenceRow", "InputRow", "confidence_rows", "input_rows", "CONFIDENCE_WORDS",
    "BandRow", "HoldRow", "RepetitionRow", "MomentCard", "HourRow", "HourTable", "FlagRow", "LimbRow", "RegionRow",
    "QualitySection", "WorkerPage", "WorkerRow", "IndexPage", "build_worker_page", "build_index_page",
    "DriverRow", "PeriodInputRow", "task_inputs_line", "Term", "PrintRow", "PrintWorker", "PrintPage", "build_print_page", "PRINT_FILE", "glossary",
    "worker_page_name", "Finding", "Verdict",
]
