"""The page contexts of the report: one frozen dataclass per page template and the records nested
in them, the contract between the page builders and the templates.

``IndexPage`` feeds templates/index.html.j2, ``WorkerPage`` templates/worker.html.j2 and
``PrintPage`` templates/print.html.j2. Every field is documented in its class docstring, and
tests/report/test_templates.py holds each template to it: rendered from a fully populated example
with jinja2.StrictUndefined, every field is used and no other name is.

Text fields are plain text (the templates escape them); fields typed ``Markup`` hold inline SVG
built on ergopose.report.svg (by charts, time_charts, heat_maps and skeleton_drawing), where every
piece of text was escaped when the SVG was made. All numbers are already formatted for reading
(units included), so templates do no arithmetic.
"""

from __future__ import annotations

from dataclasses import dataclass

from markupsafe import Markup

from ergopose.report.context import Assumption, MethodInfo, ModelInfo
from ergopose.report.quality import Verdict

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
    generated: which ergopose version wrote the results, and when. notices: what a reader must
    know before the figures (SessionInfo.notices), shown on every page under the header.
    """

    title: str
    session_id: str
    site: str
    when: str
    duration: str
    generated: str
    notices: tuple[str, ...] = ()


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
    measurement was always used), limited (share of the tracked time in which a joint limit of the
    body model held its angles; "-" where no limit concerns the body part; a verdict word "often
    held at a joint limit" from OFTEN_LIMITED_PCT)."""

    body_part: str
    median_sd: str
    inferred: str
    verdict: str
    concern: bool
    task_input: str
    from_settings: str = "none"
    limited: str = "-"


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
