"""Report input records: what a report is made of, stored as JSON/Parquet under ``results/``.

These frozen dataclasses are the contract between the pipeline (``ergopose assess`` writes them
with :func:`ergopose.report.results.save_results`) and the report (``ergopose report`` reads them
back and renders pages). docs/reports.md lists the layout; every field is documented here.

Units: seconds, metres, fractions 0-1 for shares are never stored (the report computes shares from
seconds, so all numbers on a page add up). Times are seconds since the first frame of the session
("shift time"); ``SessionInfo.start`` turns them into clock times when known. A float field may be
NaN (JSON null) where the value is unknown; the field's doc says so.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from ergopose.ergonomics.uncertainty import CONFIDENCE_LEVELS
from ergopose.errors import InputError

#: Allowed worker ids (also folder and file names): pseudonymous, no path characters.
WORKER_ID_PATTERN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
#: Methods a report shows, in order.
METHODS = ("rula", "reba")
#: Lens regions of the quality section (ergopose.sim.scene.LENS_REGIONS_DEG), in order; "all" is
#: the whole field of view.
REGIONS = ("all", "central", "outer", "edge")
#: Verdicts of ISO 11226 / EN 1005-4 flags (ergopose.ergonomics.exposure), best to worst, then
#: "not measured" (the angles needed were not available).
FLAG_VERDICTS = (
    "acceptable",
    "conditionally acceptable",
    "time-limited",
    "not recommended",
    "not acceptable",
    "not measured",
)


# ----------------------------------------------------------------------------- session


@dataclass(frozen=True)
class ActionLevelInfo:
    """One action (risk) level of a method, as in assessments/<method>.toml.

    level: the level number (RULA 1-4, REBA 0-4). low, high: the final scores it covers
    (inclusive). label: short name ("AL3", "high"). wording: what the level asks for.
    """

    level: int
    low: int
    high: int
    label: str
    wording: str


@dataclass(frozen=True)
class MethodInfo:
    """A scoring method used for the session.

    name: "rula" or "reba". title: full name. source: the publication. file: the method file's
    name (assessments/<name>.toml). sha256: its SHA-256 (hex), so the exact tables are traceable.
    score_low, score_high: range of the final score. action_levels: ascending levels.
    """

    name: str
    title: str
    source: str
    file: str
    sha256: str
    score_low: int
    score_high: int
    action_levels: tuple[ActionLevelInfo, ...]


@dataclass(frozen=True)
class ModelInfo:
    """A network the 2D pose stage ran. name: card name. file: file name. sha256: the file's
    SHA-256 (hex) as verified before the run. source: where it came from (package and version)."""

    name: str
    file: str
    sha256: str
    source: str


@dataclass(frozen=True)
class RegionAccuracy:
    """Calibration check in one lens region: a reference bar of known length measured in 3D.

    region: "central", "outer" or "edge". target_m: the bar's true length. measured_m: mean of the
    measured lengths. spread_m: their standard deviation (NaN with one measurement). n: count.
    angles: the region's angles from the lens axis in words ("40-70 deg"; empty if unknown).
    """

    region: str
    target_m: float
    measured_m: float
    spread_m: float
    n: int
    angles: str = ""


@dataclass(frozen=True)
class CalibrationInfo:
    """The calibration the session was processed with.

    file: calibration file name. sha256: its SHA-256. cameras: camera names in file order.
    reprojection_rms_px: RMS reprojection error of the calibration (pixels; NaN if unknown).
    regions: bar-length check per lens region (empty if no check was run).
    """

    file: str
    sha256: str
    cameras: tuple[str, ...]
    reprojection_rms_px: float
    regions: tuple[RegionAccuracy, ...] = ()


@dataclass(frozen=True)
class FloorItem:
    """Furniture on the floor plan: name, kind ("shelf", "table", ...), footprint x0..x1, y0..y1
    (world metres)."""

    name: str
    kind: str
    x0: float
    y0: float
    x1: float
    y1: float


@dataclass(frozen=True)
class FloorCamera:
    """A camera's position over the floor (world metres)."""

    name: str
    x: float
    y: float


@dataclass(frozen=True)
class FloorPlan:
    """The monitored area (world metres, x right, y up on the plan) with furniture when known.

    cell_m: side of the heat-map cells.
    """

    x_min: float = -3.0
    x_max: float = 3.0
    y_min: float = -3.0
    y_max: float = 3.0
    cell_m: float = 0.25
    furniture: tuple[FloorItem, ...] = ()
    cameras: tuple[FloorCamera, ...] = ()

    def __post_init__(self) -> None:
        if not (self.x_max > self.x_min and self.y_max > self.y_min and self.cell_m > 0):
            raise ValueError("the floor area must have x_max > x_min, y_max > y_min and cell_m > 0")


@dataclass(frozen=True)
class Assumption:
    """Something scored as assumed rather than measured (from the session settings).

    item: what ("load", "coupling", "arm support", "legs supported", ...). value: the assumed value
    in words ("4 kg, intermittent", "fair"). applies_to: which score steps use it ("RULA step 7,
    REBA step 5"). source: where it was set ("session.toml [workers.W1]", "default").
    """

    item: str
    value: str
    applies_to: str
    source: str


@dataclass(frozen=True)
class DataFile:
    """A data file the report links to: label (what it holds, in words), path (relative to the
    report folder, '/'-separated; no '..', no absolute path, no URL)."""

    label: str
    path: str

    def __post_init__(self) -> None:
        p = self.path.replace("\\", "/")
        if not p or ":" in p or p.startswith("/") or ".." in p.split("/"):
            raise ValueError(f"data file path {self.path!r} must be relative to the report folder")


@dataclass(frozen=True)
class WorkerInfo:
    """A worker of the session.

    worker_id: pseudonymous id (WORKER_ID_PATTERN; used in file names). name: the name the session
    settings map to the id, or None (reports then show only the id); any text, always escaped.
    assumptions: what was assumed for this worker. csv_files: the worker's CSV files (written by
    ergopose.ergonomics.export: per-frame scores, shift summary).
    """

    worker_id: str
    name: str | None = None
    assumptions: tuple[Assumption, ...] = ()
    csv_files: tuple[DataFile, ...] = ()

    def __post_init__(self) -> None:
        if not WORKER_ID_PATTERN.match(self.worker_id):
            raise ValueError(f"worker id {self.worker_id!r} must match {WORKER_ID_PATTERN.pattern}")


@dataclass(frozen=True)
class Setting:
    """One scoring setting as used: name (ScoringSettings field), value (number, word or true/false)."""

    name: str
    value: bool | float | str


@dataclass(frozen=True)
class SkippedFrames:
    """Frames of one camera's video that could not be read and were skipped (nobody was measured
    from that camera in them). camera: camera name. frames: how many. spans_s: (first, last)
    shift time in seconds of each run of consecutive skipped frames, in time order, at most
    MAX_SKIPPED_SPANS of them (csv/frames_skipped.csv lists every frame)."""

    camera: str
    frames: int
    spans_s: tuple[tuple[float, float], ...] = ()


MAX_SKIPPED_SPANS = 20


@dataclass(frozen=True)
class SessionInfo:
    """The session as a whole (``results/session.json``).

    session_id: folder name of the session. title: a human title (may be empty). site: where
    (may be empty). start: clock time of the first frame, ISO 8601 ("2024-05-06T06:00:00"), or
    None when unknown (pages then show shift time only). fps: frame rate. frames: frames in the
    session. duration_s: session length. ergopose_version: version that produced the results.
    created: when the results were written (ISO 8601, UTC). models, methods: what scored it.
    settings: the scoring settings (ergopose.ergonomics.settings.ScoringSettings) as used.
    calibration: the calibration and its accuracy, or None. floor: the monitored area.
    workers: every worker, in report order. csv_files: session-wide CSV files (the session
    summary). fingerprint: the recording's fingerprint (ergopose.pipeline.guard; None in results
    written before it existed). skipped_frames: per camera with skipped frames, which (empty when
    every frame was read). notices: what a reader must know before the figures, one sentence
    each (e.g. more people tracked than the area holds; empty when nothing).
    """

    session_id: str
    title: str
    site: str
    start: str | None
    fps: float
    frames: int
    duration_s: float
    ergopose_version: str
    created: str
    models: tuple[ModelInfo, ...]
    methods: tuple[MethodInfo, ...]
    settings: tuple[Setting, ...]
    calibration: CalibrationInfo | None
    floor: FloorPlan
    workers: tuple[WorkerInfo, ...]
    csv_files: tuple[DataFile, ...] = ()
    fingerprint: str | None = None
    skipped_frames: tuple[SkippedFrames, ...] = ()
    notices: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        ids = [w.worker_id for w in self.workers]
        if len(set(ids)) != len(ids):
            raise ValueError("worker ids must be unique")
        names = [m.name for m in self.methods]
        if sorted(names) != sorted(METHODS):
            raise ValueError(f"methods must be {', '.join(METHODS)}; got {', '.join(names)}")
        if not self.fps > 0:
            raise ValueError("fps must be positive")

    def method(self, name: str) -> MethodInfo:
        for m in self.methods:
            if m.name == name:
                return m
        raise KeyError(name)


# ----------------------------------------------------------------------- worker summary


@dataclass(frozen=True)
class LevelTime:
    """Time at one action level: method ("rula"/"reba"), level number, seconds."""

    method: str
    level: int
    seconds: float


@dataclass(frozen=True)
class BandTime:
    """Time a body part spent in one posture band.

    method: "rula" or "reba". body_part: in words ("left upper arm", "trunk"). score: the band's
    position score (before adjustments). criterion: the band in words ("45-90 deg flexion").
    seconds: time in the band (frames where the angle was measured).
    """

    method: str
    body_part: str
    score: int
    criterion: str
    seconds: float


@dataclass(frozen=True)
class Hold:
    """A longest continuous hold of a posture band.

    body_part, method, score, criterion: as in BandTime. start_s: shift time it began.
    duration_s: how long it lasted (a gap over ScoringSettings.max_gap_s breaks it).
    """

    body_part: str
    method: str
    score: int
    criterion: str
    start_s: float
    duration_s: float


@dataclass(frozen=True)
class Repetition:
    """Repetitive movement of one joint angle (ergopose.ergonomics.shift_records.Repetitions).

    body_part: in words. angle: the posture-table angle ("left_upper_arm_flexion"). actions: rises
    and falls of the angle by at least ScoringSettings.repetition_amplitude_deg over the shift.
    per_minute: actions per observed minute. max_in_one_minute: most actions in one minute of
    the shift. limit_per_min: the threshold of the methods (4 per minute). minutes_over_limit:
    minutes of the shift with at least that many actions.
    """

    body_part: str
    angle: str
    actions: int
    per_minute: float
    max_in_one_minute: int
    limit_per_min: float
    minutes_over_limit: int


@dataclass(frozen=True)
class HourLevels:
    """Action levels within one clock hour (or hour of shift time when the start is unknown).

    start_s: shift time the hour starts; the bin is [start_s, start_s + 3600) (the first and last
    hours may be partial when the shift does not start on the hour). method: "rula"/"reba". levels: seconds at each level.
    unscored_s: observed but not scored. observed_s: time the worker was tracked in the hour.
    """

    start_s: float
    method: str
    levels: tuple[LevelTime, ...]
    unscored_s: float
    observed_s: float


@dataclass(frozen=True)
class Driver:
    """A body part that drove a sustained period of high risk.

    method: "rula" (the posture bands of the RULA worksheet). body_part: in words ("trunk").
    score: its band score. top: the highest band score of that body part. criterion: the band in
    words ("20-60 flexion"; angles in degrees). seconds: time of the period's high frames with the
    body part in that band.
    """

    method: str
    body_part: str
    score: int
    top: int
    criterion: str
    seconds: float


@dataclass(frozen=True)
class PeriodInput:
    """A score input during a sustained period's high-risk time and where it came from
    (ergopose.report.periods.period_inputs).

    input: the input in words ("load", "hand coupling", "left wrist flexion", or the measured
    angles, "angles of the upper arms, lower arms, wrists, neck, trunk, legs"). source: one of
    PERIOD_INPUT_SOURCES: "measured" (the cameras), "task input" (settings.toml) or "not given"
    (no value: the scoring's rule for unknown inputs). value: a task input's value in words ("12
    kg, held static", "poor", "yes", "17° (flexion)"; angles in degrees), "" otherwise. seconds:
    the time of the period's high frames with this source and value. use: what the input feeds
    (RULA and REBA steps).
    """

    input: str
    source: str
    value: str
    seconds: float
    use: str

    def __post_init__(self) -> None:
        if self.source not in PERIOD_INPUT_SOURCES:
            raise ValueError(f"source must be one of {PERIOD_INPUT_SOURCES}, got {self.source!r}")


#: Where a score input of a period came from.
PERIOD_INPUT_SOURCES = ("measured", "task input", "not given")


@dataclass(frozen=True)
class WorstMoment:
    """A sustained period of high risk (ergopose.report.periods; "worst moment" in results
    written before periods existed, when it was one run of a level).

    start_s, end_s: the period (shift time); peak_s: the frame drawn (the posture held longest).
    rula_grand, rula_level, reba_score, reba_level: scores at that frame (None if not scored).
    reason: what drove the score in words. joints_world_m: the 33 BlazePose joints at that frame
    (world metres, NaN = missing joint), or None when no skeleton was stored. high_s: time at high
    risk within the period (NaN in older results). rula_peak, reba_peak: highest score within the
    period (None when unknown). drivers: the body parts in their high bands for most of the
    period, longest first (empty when unknown). inputs: the score inputs of its high-risk time and
    where each came from, measured or task input (empty in results written before they were read).
    """

    start_s: float
    end_s: float
    peak_s: float
    rula_grand: int | None
    rula_level: int | None
    reba_score: int | None
    reba_level: int | None
    reason: str
    joints_world_m: tuple[tuple[float, float, float], ...] | None = None
    high_s: float = float("nan")
    rula_peak: int | None = None
    reba_peak: int | None = None
    drivers: tuple[Driver, ...] = ()
    inputs: tuple[PeriodInput, ...] = ()

    def __post_init__(self) -> None:
        if self.joints_world_m is not None and len(self.joints_world_m) != 33:
            raise ValueError(f"joints_world_m must hold 33 joints, got {len(self.joints_world_m)}")


@dataclass(frozen=True)
class StandardFlag:
    """A posture judged against ISO 11226 or EN 1005-4.

    standard: "ISO 11226" or "EN 1005-4". body_part: in words. condition: the posture and limit
    in words ("upper arm elevation > 60 deg"). verdict: one of FLAG_VERDICTS. seconds: time in the
    condition. longest_s: longest continuous hold. note: why this verdict (holding time, frequency).
    """

    standard: str
    body_part: str
    condition: str
    verdict: str
    seconds: float
    longest_s: float
    note: str

    def __post_init__(self) -> None:
        if self.verdict not in FLAG_VERDICTS:
            raise ValueError(f"verdict must be one of {', '.join(FLAG_VERDICTS)}, got {self.verdict!r}")


@dataclass(frozen=True)
class CauseSeconds:
    """Time with one cause of low confidence or of no score: cause (in words: "not seen", "one
    camera", "occluded limbs", "uncertain angles", "not recorded"), seconds."""

    cause: str
    seconds: float


@dataclass(frozen=True)
class ConfidenceTime:
    """One part of the tracked time by confidence (ergopose.ergonomics.uncertainty): level
    ("confident" = both scores scored with confidence, "low" = scored with low confidence,
    "unscored" = a score missing), seconds, causes (time per cause; empty for "confident")."""

    level: str
    seconds: float
    causes: tuple[CauseSeconds, ...] = ()

    def __post_init__(self) -> None:
        if self.level not in CONFIDENCE_LEVELS:
            raise ValueError(f"level must be one of {', '.join(CONFIDENCE_LEVELS)}, got {self.level!r}")


@dataclass(frozen=True)
class SettingsValue:
    """A task input of the settings scored in place of a hidden measurement (ergopose.ergonomics.
    task_inputs): input (the posture-table angle, "left_wrist_flexion"), value_rad (the value used,
    radians), seconds (scored time in which it was used), scored_s (the worker's scored time: a
    RULA or REBA grand score present; the base of the share)."""

    input: str
    value_rad: float
    seconds: float
    scored_s: float


@dataclass(frozen=True)
class InputQuality:
    """How well one body part's RULA/REBA inputs were measured over the shift.

    body_part: in words ("left wrist"). angles: the posture-table angles. median_sd_rad: median
    over the shift of the per-frame standard deviation of its angles (radians; NaN when unknown).
    inferred_s: time in which one of its joints was placed by the body model rather than seen by
    two cameras; known_s: time for which that was recorded (0 = unknown). from_settings: its
    angles' values taken from the settings where the cameras did not see them, with the time each
    was used (empty when none). limited_s: time in which a joint limit of the body model held its
    angles (the cameras put the joint past its anatomical range); NaN when no limit concerns the
    body part (trunk, upper arms, wrists) or when it was not recorded.
    """

    body_part: str
    angles: tuple[str, ...]
    median_sd_rad: float
    inferred_s: float
    known_s: float
    from_settings: tuple[SettingsValue, ...] = ()
    limited_s: float = math.nan


@dataclass(frozen=True)
class WorkerSummary:
    """The shift aggregation of one worker (``results/workers/<id>/summary.json``).

    worker_id: as in WorkerInfo. observed_s: time the worker was tracked. levels: seconds per
    method and level (every level of both methods, zeros included). unscored_s: per method,
    observed time without a score (missing joints). body_parts: time per body part and band.
    holds: longest holds. repetitions: repetitive movements. hourly: per hour and method.
    worst: sustained periods of high risk, ranked (ergopose.report.periods). flags: ISO 11226 /
    EN 1005-4 judgements. confidence: the tracked time split into scored with confidence, scored with low confidence and unscored, with
    causes (empty in results written before it existed). inputs: per body part, how well its
    inputs were measured (empty when unknown).
    """

    worker_id: str
    observed_s: float
    levels: tuple[LevelTime, ...]
    unscored_s: dict[str, float]
    body_parts: tuple[BandTime, ...] = ()
    holds: tuple[Hold, ...] = ()
    repetitions: tuple[Repetition, ...] = ()
    hourly: tuple[HourLevels, ...] = ()
    worst: tuple[WorstMoment, ...] = ()
    flags: tuple[StandardFlag, ...] = ()
    confidence: tuple[ConfidenceTime, ...] = ()
    inputs: tuple[InputQuality, ...] = ()


# ---------------------------------------------------------------------------- diagnostics


@dataclass(frozen=True)
class LimbStats:
    """Statistics of one limb's 3D length over the shift (metres; NaN when n = 0).

    limb: name from ergopose.keypoints.LIMBS. n: frames with the limb reconstructed. p5/p95 are
    the whiskers of the box plot, q1/q3 the box, median the line. region: one of REGIONS ("all"
    = every frame; else the frames in which the limb was in that lens region).
    """

    limb: str
    n: int
    mean_m: float
    std_m: float
    p5_m: float
    q1_m: float
    median_m: float
    q3_m: float
    p95_m: float
    region: str = "all"

    def __post_init__(self) -> None:
        if self.region not in REGIONS:
            raise ValueError(f"region must be one of {', '.join(REGIONS)}, got {self.region!r}")


@dataclass(frozen=True)
class LimbFrequency:
    """How often a limb was reconstructed: limb (LIMBS name), region (one of REGIONS),
    frames (worker observed in that region), reconstructed (frames with both joints in 3D)."""

    limb: str
    region: str
    frames: int
    reconstructed: int

    def __post_init__(self) -> None:
        if self.region not in REGIONS:
            raise ValueError(f"region must be one of {', '.join(REGIONS)}, got {self.region!r}")
        if not 0 <= self.reconstructed <= self.frames:
            raise ValueError("reconstructed must lie between 0 and frames")


@dataclass(frozen=True)
class WorkerDiagnostics:
    """Reconstruction quality of one worker (``results/workers/<id>/diagnostics.json``).

    worker_id: as in WorkerInfo. frames_observed: frames the worker was tracked. frames_reliable:
    frames whose skeleton met reliable_rule. reliable_rule: that rule in words. region_frames:
    frames per lens region ("central", "outer", "edge"; by the worker's position in the lenses).
    limb_lengths: per limb. reconstruction: per limb and region. error_3d_m: median 3D joint error
    against ground truth (simulated sessions), NaN when there is none.
    """

    worker_id: str
    frames_observed: int
    frames_reliable: int
    reliable_rule: str
    region_frames: dict[str, int]
    limb_lengths: tuple[LimbStats, ...]
    reconstruction: tuple[LimbFrequency, ...]
    error_3d_m: float = float("nan")

    def __post_init__(self) -> None:
        if not 0 <= self.frames_reliable <= self.frames_observed:
            raise ValueError("frames_reliable must lie between 0 and frames_observed")


# ------------------------------------------------------------------------------ all of it


@dataclass(frozen=True)
class WorkerResults:
    """Everything a worker's page needs; ``frames`` is the per-frame table (pandas DataFrame with
    the columns of ergopose.report.results.FRAME_COLUMNS), kept out of JSON."""

    info: WorkerInfo
    summary: WorkerSummary
    diagnostics: WorkerDiagnostics
    frames: object = field(repr=False, compare=False)


def check_worker(info: WorkerInfo, summary: WorkerSummary, diagnostics: WorkerDiagnostics, source: str) -> None:
    """The three records of a worker must name the same worker."""
    for what, wid in (("summary", summary.worker_id), ("diagnostics", diagnostics.worker_id)):
        if wid != info.worker_id:
            raise InputError(
                f"the {what} is for worker {wid!r}, expected {info.worker_id!r}", path=source, field="worker_id"
            )
