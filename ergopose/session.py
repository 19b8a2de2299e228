"""A recording session: one folder with the camera videos, the calibration and the settings.

    session/
      settings.toml       what was recorded, and what the cameras cannot see (format below)
      calibration.toml    the cameras (docs/calibration-file.md)
      cam_1.mp4           one video per camera, file names listed in settings.toml
      cam_2.mp4
      floor.toml          optional: the monitored area and its furniture, for the report's floor map
      ground_truth/       only in simulated sessions (ergopose.sim.ground_truth)

docs/session-format.md is the user's description of the format; this module is its reference
implementation. :func:`load_session` reads and checks everything and returns a frozen
:class:`Session`; any problem raises ONE ConfigError (settings, calibration) or InputError
(videos) naming the file and the field and saying what is wrong.

settings.toml (format_version 1)::

    format_version = 1
    recorded_at = 2024-03-04T08:00:00+01:00    # when the first frame was taken (ISO 8601)
    fps = 12.0                                  # optional; default: the videos' frame rate
    description = "Assembly line 3, early shift" # optional
    calibration = "calibration.toml"            # optional; this is the default

    [[cameras]]                                 # camera order is this order (never sorted)
    name = "cam_1"                              # a camera of the calibration file
    video = "cam_1.mp4"                         # relative to the session folder, or an fsspec
                                                #   URL (s3://...; ergopose.remote makes a local copy)

    [[cameras]]
    name = "cam_2"
    video = "cam_2.mp4"

    [defaults]                                  # task factors for everyone, whole session
    load_kg = 0.0
    coupling = "good"

    [[periods]]                                 # time windows for everyone
    start = 600.0                               # seconds from the start, a clock time
    end = 10:30:00                              #   (10:30:00) or a date-time
    load_kg = 12.0

    [workers.w1]                                # one table per worker id
    name = "Worker A"                           # optional name or pseudonym for reports
    load_kg = 2.0                               # factors for this worker, whole session
    [[workers.w1.periods]]
    start = 120.0
    end = 180.0
    load_kg = 15.0
    load_mode = "static"

    [scoring]                                   # optional scoring settings (docs/scoring.md)
    [pose]                                      # optional 2D stage settings (docs/settings.md)
    [reconstruction]                            # optional 3D settings (docs/reconstruction.md)

Every key, its type, range and default: docs/settings.md, generated from the settings model
(ergopose.settings.model.SettingsFile), which validates the file.

Task factors (all optional; absent = not given, and scoring treats it as unknown):
load_kg (kg >= 0), load_mode (intermittent | static | repeated), coupling (good | fair | poor |
unacceptable), shock, arm_supported, seated, legs_supported, wrist_twist_end_range (true/false),
wrist_flexion_deg and wrist_deviation_deg (degrees, -90 to 90; flexion + toward the palm, - toward
the back of the hand; deviation + toward the thumb): the wrist posture of the task, used in place
of a wrist angle only where the cameras do not see the hand (ergopose.ergonomics.task_inputs).
Inside, the wrist angles are radians (TaskFactors.wrist_flexion / wrist_deviation).
For a worker at a time the most specific value wins: the worker's period, then a period for
everyone, then the worker's own value, then [defaults].
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import cv2
import numpy as np
import pandas as pd

from ergopose import remote, video
from ergopose.errors import ConfigError, InputError
from ergopose.geometry.calibration_file import load_calibration
from ergopose.geometry.camera import Camera
from ergopose.pose.settings import PoseSettings
from ergopose.recon.settings import ReconSettings
from ergopose.recon.settings import from_table as recon_from_table
from ergopose.settings.model import CALIBRATION_FILE as CALIBRATION_FILE  # re-exported: the folder's names
from ergopose.settings.generate import TEMPLATE_HEADER, TEMPLATE_HOWTO, settings_text
from ergopose.settings.model import FORMAT_VERSION, read_settings
from ergopose.settings.tasks import FACTOR_KEYS, PeriodTable, TaskFactorsTable

SETTINGS_FILE = "settings.toml"
GROUND_TRUTH_DIR = "ground_truth"
#: Optional plan of the monitored area (area and furniture) for the report's floor map.
FLOOR_PLAN_FILE = "floor.toml"

FLAG_FACTORS = ("shock", "arm_supported", "seated", "legs_supported", "wrist_twist_end_range")
#: Task factors that are angles: field of TaskFactors (radians) -> key in settings.toml (degrees).
ANGLE_FACTORS = {"wrist_flexion": "wrist_flexion_deg", "wrist_deviation": "wrist_deviation_deg"}
#: The fields of TaskFactors.
FACTOR_NAMES = ("load_kg", "load_mode", "coupling") + FLAG_FACTORS + tuple(ANGLE_FACTORS)
_ANGLE_KEYS = {key: name for name, key in ANGLE_FACTORS.items()}
#: Largest accepted relative difference between the settings' fps and a video's frame rate.
FPS_TOLERANCE = 0.01


@dataclass(frozen=True)
class TaskFactors:
    """What the cameras cannot see. None = not given.

    wrist_flexion / wrist_deviation: the task's wrist posture in RADIANS (settings.toml gives
    degrees: wrist_flexion_deg, wrist_deviation_deg), with the sign conventions of the joint angles
    (docs/joint-angles.md).
    """

    load_kg: float | None = None
    load_mode: str | None = None
    coupling: str | None = None
    shock: bool | None = None
    arm_supported: bool | None = None
    seated: bool | None = None
    legs_supported: bool | None = None
    wrist_twist_end_range: bool | None = None
    wrist_flexion: float | None = None
    wrist_deviation: float | None = None

    def over(self, base: "TaskFactors") -> "TaskFactors":
        """These factors where given, ``base``'s elsewhere."""
        return TaskFactors(
            **{f: (getattr(self, f) if getattr(self, f) is not None else getattr(base, f)) for f in FACTOR_NAMES}
        )

    def given(self) -> dict[str, Any]:
        """The factors that are given, by field name (angles in radians)."""
        return {f: getattr(self, f) for f in FACTOR_NAMES if getattr(self, f) is not None}

    def settings_values(self) -> dict[str, Any]:
        """The factors that are given, as settings.toml has them (keys and degrees)."""
        return {
            ANGLE_FACTORS.get(f, f): (round(math.degrees(v), 9) if f in ANGLE_FACTORS else v)
            for f, v in self.given().items()
        }


@dataclass(frozen=True)
class FactorPeriod:
    """Task factors over [start_s, end_s) seconds from the first frame."""

    start_s: float
    end_s: float
    factors: TaskFactors


@dataclass(frozen=True)
class WorkerInfo:
    """A worker named in the settings: id (as in the results), optional name, own factors and periods.

    stature_m: the worker's body height in metres, if given; ergopose then recognises the worker
    among the tracked people by the stature it measures (docs/session-format.md, "Workers").
    """

    worker_id: str
    name: str | None
    factors: TaskFactors
    periods: tuple[FactorPeriod, ...]
    stature_m: float | None = None


@dataclass(frozen=True)
class Identification:
    """How tracked people are matched to the workers of the settings that give a stature.

    by_stature: match at all (off by default: a stature measured from a noisy reconstruction can
        be several centimetres off, and a wrong match puts one worker's loads on another; switch
        it on where the report's limb-length quality is good and the workers differ in height).
    stature_tolerance_m: largest difference between a worker's given stature and the stature
        measured for a tracked person for the two to be matched.
    stature_margin_m: the best matching must beat every other matching of the same people by
        at least this much in total (otherwise two workers are too alike in height to tell apart,
        and nobody is named).
    """

    by_stature: bool = False
    stature_tolerance_m: float = 0.05
    stature_margin_m: float = 0.02


@dataclass(frozen=True)
class CalibrationCheck:
    """A reference bar measured by both cameras (ergopose calibrate check; docs/calibration.md).

    observations_path: CSV of the bar ends' pixel positions (measurement,camera,end,u,v).
    length_m: the bar's true length in metres.
    """

    observations_path: Path
    length_m: float


@dataclass(frozen=True)
class SessionCamera:
    """One camera of the session: its calibration and its video (checked readable)."""

    camera: Camera
    video_path: Path
    frame_count: int
    video_fps: float
    video_url: str | None = None  # the fsspec URL settings.toml gives; video_path is then its local copy

    @property
    def name(self) -> str:
        return self.camera.name


@dataclass(frozen=True)
class Session:
    """A checked session folder.

    cameras: in the order of settings.toml. frame_count: frames per camera (equal for all).
    fps: frames per second (settings, else the videos). recorded_at: the first frame's time.
    defaults / periods / workers: the task factors (see the module docstring).
    scoring: the [scoring] table as given (a plain dict; ergopose.ergonomics.settings reads it).
    ground_truth_dir: the ground_truth/ folder of a simulated session, else None.
    identification: how tracked people are matched to workers with a given stature.
    calibration_check: the reference-bar observations for the accuracy check, or None.
    pose, reconstruction: the settings of the 2D stage and of the 3D reconstruction ([pose] and
        [reconstruction] over the defaults; angles in radians).
    """

    path: Path
    format_version: int
    recorded_at: dt.datetime
    fps: float
    frame_count: int
    cameras: tuple[SessionCamera, ...]
    defaults: TaskFactors
    periods: tuple[FactorPeriod, ...]
    workers: tuple[WorkerInfo, ...]
    scoring: Mapping[str, Any]
    description: str | None
    ground_truth_dir: Path | None
    settings_path: Path
    calibration_path: Path
    identification: Identification = Identification()
    calibration_check: CalibrationCheck | None = None
    pose: PoseSettings = PoseSettings()
    reconstruction: ReconSettings = ReconSettings()

    @property
    def duration_s(self) -> float:
        return self.frame_count / self.fps

    @property
    def floor_plan_path(self) -> Path | None:
        """The session's floor.toml (the monitored area and its furniture, for the report's floor
        map; docs/session-format.md), or None when the folder has none."""
        p = self.path / FLOOR_PLAN_FILE
        return p if p.is_file() else None

    @property
    def camera_names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.cameras)

    @property
    def calibrated_cameras(self) -> tuple[Camera, ...]:
        return tuple(c.camera for c in self.cameras)

    @property
    def times_s(self) -> np.ndarray:
        """(frame_count,) time of every frame from the first, seconds."""
        return np.arange(self.frame_count) / self.fps

    def worker(self, worker_id: str) -> WorkerInfo | None:
        for w in self.workers:
            if w.worker_id == worker_id:
                return w
        return None

    def display_name(self, worker_id: str) -> str:
        """The worker's name from the settings, else the id."""
        w = self.worker(worker_id)
        return w.name if w is not None and w.name else worker_id

    def clock_time(self, time_s: float) -> dt.datetime:
        return self.recorded_at + dt.timedelta(seconds=float(time_s))

    def factors_at(self, worker_id: str, time_s: float) -> TaskFactors:
        """The task factors of a worker at a time (most specific first; see the module docstring)."""
        w = self.worker(worker_id)
        out = self.defaults
        if w is not None:
            out = w.factors.over(out)
        for p in self.periods:
            if p.start_s <= time_s < p.end_s:
                out = p.factors.over(out)
        if w is not None:
            for p in w.periods:
                if p.start_s <= time_s < p.end_s:
                    out = p.factors.over(out)
        return out

    def _layers(self, worker_id: str, t: np.ndarray) -> list[tuple[np.ndarray, TaskFactors]]:
        """(mask over the times, factors) from the least to the most specific."""
        n = t.size
        w = self.worker(worker_id)
        layers: list[tuple[np.ndarray, TaskFactors]] = [(np.ones(n, bool), self.defaults)]
        if w is not None:
            layers.append((np.ones(n, bool), w.factors))
        layers += [((t >= p.start_s) & (t < p.end_s), p.factors) for p in self.periods]
        if w is not None:
            layers += [((t >= p.start_s) & (t < p.end_s), p.factors) for p in w.periods]
        return layers

    def factor_table(self, worker_id: str, times_s: Sequence[float] | np.ndarray) -> pd.DataFrame:
        """A pandas DataFrame of the task factors at each time, in the posture-table conventions
        (docs/posture-table.md): load_kg float (NaN unknown), load_mode / coupling strings (<NA>
        unknown), flags 0.0 / 1.0 (NaN unknown). One row per time, index 0..n-1. The angle factors
        are not in it (they are not posture-table inputs): see :meth:`task_angles`."""
        t = np.asarray(times_s, dtype=np.float64)
        n = t.size
        load = np.full(n, np.nan)
        flags = {f: np.full(n, np.nan) for f in FLAG_FACTORS}
        cats = {"load_mode": np.full(n, None, dtype=object), "coupling": np.full(n, None, dtype=object)}
        for mask, f in self._layers(worker_id, t):
            if f.load_kg is not None:
                load[mask] = f.load_kg
            for name in FLAG_FACTORS:
                v = getattr(f, name)
                if v is not None:
                    flags[name][mask] = float(v)
            for name in cats:
                v = getattr(f, name)
                if v is not None:
                    cats[name][mask] = v
        frame = pd.DataFrame(
            {
                "load_kg": load,
                "load_mode": pd.array(cats["load_mode"], dtype="string"),
                "coupling": pd.array(cats["coupling"], dtype="string"),
                **flags,
            }
        )
        return frame

    def task_angles(self, worker_id: str, times_s: Sequence[float] | np.ndarray) -> pd.DataFrame:
        """The angle factors of a worker at each time: columns wrist_flexion and wrist_deviation in
        radians (NaN where the settings give none), one row per time, index 0..n-1."""
        t = np.asarray(times_s, dtype=np.float64)
        out = {name: np.full(t.size, np.nan) for name in ANGLE_FACTORS}
        for mask, f in self._layers(worker_id, t):
            for name in ANGLE_FACTORS:
                v = getattr(f, name)
                if v is not None:
                    out[name][mask] = v
        return pd.DataFrame(out)


# --- loading ------------------------------------------------------------------------------------------


def load_session(path: str | os.PathLike[str], *, check_videos: bool = True) -> Session:
    """Read and check a session folder (see the module docstring); raise one clear error otherwise.

    The settings are validated by the settings model (ergopose.settings.model.SettingsFile: keys,
    types, ranges); what needs the folder (calibration, videos, the recording's length) is checked
    here. check_videos: open every video with OpenCV, read its first and last frame and compare
    frame counts and sizes (the default); False only reads the container headers' frame counts.
    """
    root = Path(path)
    if not root.exists():
        raise InputError("the session folder does not exist", path=root)
    if not root.is_dir():
        raise InputError("expected a session folder (with settings.toml, calibration.toml and the videos)", path=root)
    settings_path = root / SETTINGS_FILE
    model, data = read_settings(settings_path)
    recorded_at = model.recorded_at
    calibration_path = root / model.calibration

    # calibration and videos (the duration is needed to check the periods)
    if not calibration_path.is_file():
        raise ConfigError("the calibration file does not exist", path=calibration_path)
    calibrated = {cam.name: cam for cam in load_calibration(calibration_path)}
    session_cams: list[SessionCamera] = []
    for i, entry in enumerate(model.cameras):
        name, url = entry.name, entry.video if remote.is_url(entry.video) else None
        vpath = remote.fetch(url) if url else root / entry.video  # a URL: read from this machine's copy
        if name not in calibrated:
            raise ConfigError(
                f"camera {name!r} is not in {calibration_path.name} (it has {', '.join(map(repr, calibrated))})",
                path=settings_path,
                field=f"cameras[{i}].name",
            )
        cam = calibrated[name]
        try:
            count, fps_video, size = probe_video(vpath, full=check_videos)
        except InputError as exc:
            if url is None:
                raise
            raise InputError(str(exc).removeprefix(f"{exc.path}: "), path=url) from None  # name the URL, not the copy
        if size != (cam.width, cam.height):
            raise ConfigError(
                f"camera {name!r} is calibrated for {cam.width} x {cam.height} pixels but its video "
                f"{vpath.name} is {size[0]} x {size[1]}",
                path=calibration_path,
                field=f"cameras[{list(calibrated).index(name)}].width",
            )
        session_cams.append(
            SessionCamera(camera=cam, video_path=vpath, frame_count=count, video_fps=fps_video, video_url=url)
        )
    counts = [c.frame_count for c in session_cams]
    if len(set(counts)) > 1:
        listing = ", ".join(f"{c.video_path.name}: {c.frame_count}" for c in session_cams)
        raise InputError(
            f"the videos have different numbers of frames ({listing}); the cameras must be "
            "recorded in sync, frame for frame",
            path=root,
        )
    fps = model.fps
    for c in session_cams:
        if not (c.video_fps > 0 and math.isfinite(c.video_fps)):
            if fps is None:
                raise InputError(
                    "the video does not state its frame rate; give fps in settings.toml", path=c.video_path
                )
            continue
        if fps is None:
            fps = c.video_fps
        elif abs(c.video_fps - fps) > FPS_TOLERANCE * fps:
            raise ConfigError(
                f"fps = {fps:g} but {c.video_path.name} plays at {c.video_fps:g} frames per second",
                path=settings_path,
                field="fps",
            )
    assert fps is not None
    times = _Times(settings_path, recorded_at, counts[0] / fps)
    workers = tuple(
        WorkerInfo(
            worker_id=wid,
            name=w.name,
            factors=task_factors(w),
            periods=times.periods(w.periods, f"workers.{wid}.periods"),
            stature_m=w.stature_m,
        )
        for wid, w in model.workers.items()
    )
    check = None
    if model.calibration_check is not None:
        check = CalibrationCheck(
            observations_path=root / model.calibration_check.observations, length_m=model.calibration_check.length_m
        )
        if not check.observations_path.is_file():
            raise ConfigError(
                f"the file {model.calibration_check.observations!r} does not exist in the session folder",
                path=settings_path,
                field="calibration_check.observations",
            )
    gt = root / GROUND_TRUTH_DIR
    return Session(
        path=root,
        format_version=model.format_version,
        recorded_at=recorded_at,
        fps=float(fps),
        frame_count=counts[0],
        cameras=tuple(session_cams),
        defaults=task_factors(model.defaults),
        periods=times.periods(model.periods, "periods"),
        workers=workers,
        scoring={k: getattr(model.scoring, k) for k in data.get("scoring", {})},
        description=model.description,
        ground_truth_dir=gt if gt.is_dir() else None,
        settings_path=settings_path,
        calibration_path=calibration_path,
        identification=Identification(**model.identification.model_dump()),
        calibration_check=check,
        pose=dataclasses.replace(PoseSettings(), **model.pose.record_values()),
        reconstruction=recon_from_table(model.reconstruction),
    )


def task_factors(table: TaskFactorsTable) -> TaskFactors:
    """The TaskFactors of a validated table of task factors (the wrist angles in radians)."""
    given = table.given()
    factors: dict[str, Any] = {
        _ANGLE_KEYS.get(k, k): (math.radians(v) if k in _ANGLE_KEYS else v)
        for k, v in given.items()
        if k in FACTOR_KEYS
    }
    return TaskFactors(**factors)


class _Times:
    """Period times -> seconds from the first frame, and the checks that need the recording."""

    def __init__(self, path: Path, recorded_at: dt.datetime, duration: float):
        self.path, self.recorded_at, self.duration = path, recorded_at, duration

    def seconds(self, value: float | dt.time | dt.datetime, field: str) -> float:
        """Seconds from the first frame of a number, a clock time (time of day) or a date-time."""
        at = self.recorded_at
        if isinstance(value, dt.datetime):
            if (value.tzinfo is None) != (at.tzinfo is None):
                raise ConfigError(
                    "give a time zone offset on both this time and recorded_at, or on neither",
                    path=self.path,
                    field=field,
                )
            return (value - at).total_seconds()
        if isinstance(value, dt.time):
            if value.tzinfo is not None:
                raise ConfigError(
                    "a clock time cannot carry a time zone; use a full date-time", path=self.path, field=field
                )
            return (dt.datetime.combine(at.date(), value, tzinfo=at.tzinfo) - at).total_seconds()
        return float(value)

    def periods(self, items: Sequence[PeriodTable], where: str) -> tuple[FactorPeriod, ...]:
        out: list[FactorPeriod] = []
        for i, item in enumerate(items):
            at = f"{where}[{i}]"
            start = self.seconds(item.start, f"{at}.start")
            end = self.seconds(item.end, f"{at}.end")
            if not end > start:
                raise ConfigError(f"ends ({end:g} s) before it starts ({start:g} s)", path=self.path, field=at)
            if end <= 0 or start >= self.duration:
                raise ConfigError(
                    f"lies outside the recording ({start:g} s to {end:g} s; the videos last {self.duration:g} s)",
                    path=self.path,
                    field=at,
                )
            for j, other in enumerate(out):
                if start < other.end_s and other.start_s < end:
                    raise ConfigError(
                        f"overlaps {where}[{j}] ({other.start_s:g} s to {other.end_s:g} s)", path=self.path, field=at
                    )
            out.append(FactorPeriod(start_s=start, end_s=end, factors=task_factors(item)))
        return tuple(out)


# --- videos ---------------------------------------------------------------------------------------------


def probe_video(path: Path, *, full: bool = True) -> tuple[int, float, tuple[int, int]]:
    """(frame count, frames per second, (width, height)) of a video; InputError if it cannot be read.

    full: prove the file readable with :func:`ergopose.video.probe_video` (it decodes the first and
    the last frame, so truncated and corrupt files are refused); False reads the header only.
    """
    path = Path(path)
    if full:
        info = video.probe_video(path)
        return info.frames, info.fps, (info.width, info.height)
    if not path.is_file():
        raise InputError("video file not found", path=path)
    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            raise InputError("cannot open the video (not a video file, or an unsupported codec)", path=path)
        count = int(round(cap.get(cv2.CAP_PROP_FRAME_COUNT)))
        if count <= 0:
            raise InputError("the video does not state its number of frames", path=path)
        return (
            count,
            float(cap.get(cv2.CAP_PROP_FPS)),
            (int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))),
        )
    finally:
        cap.release()


# --- writing ----------------------------------------------------------------------------------------------


def settings_to_toml(
    *,
    recorded_at: dt.datetime,
    cameras: Iterable[tuple[str, str]],
    fps: float | None = None,
    description: str | None = None,
    defaults: TaskFactors | None = None,
    periods: Sequence[FactorPeriod] = (),
    workers: Sequence[WorkerInfo] = (),
    scoring: Mapping[str, Any] | None = None,
    header: str = "",
    calibration_check: tuple[str, float] | None = None,
    reconstruction: Mapping[str, Any] | None = None,
) -> str:
    """The text of a settings.toml (format_version 1) for these values, every other key commented
    with its default and a one-line explanation (ergopose.settings.generate); load_session reads
    it back. ``header``: comment lines to start with."""
    data: dict[str, Any] = {"format_version": FORMAT_VERSION, "recorded_at": recorded_at}
    if fps is not None:
        data["fps"] = float(fps)
    if description:
        data["description"] = description
    data["cameras"] = [{"name": n, "video": v} for n, v in cameras]
    if defaults is not None and defaults.given():
        data["defaults"] = defaults.settings_values()
    if periods:
        data["periods"] = [_period_dict(p) for p in periods]
    if workers:
        table: dict[str, Any] = {}
        for w in workers:
            entry: dict[str, Any] = {}
            if w.name:
                entry["name"] = w.name
            if w.stature_m is not None:
                entry["stature_m"] = float(w.stature_m)
            entry.update(w.factors.settings_values())
            if w.periods:
                entry["periods"] = [_period_dict(p) for p in w.periods]
            table[w.worker_id] = entry
        data["workers"] = table
    if scoring:
        data["scoring"] = dict(scoring)
    if calibration_check is not None:
        data["calibration_check"] = {"observations": calibration_check[0], "length_m": float(calibration_check[1])}
    if reconstruction:
        data["reconstruction"] = dict(reconstruction)
    return settings_text(data, header=header + TEMPLATE_HOWTO if header else TEMPLATE_HEADER)


def _period_dict(p: FactorPeriod) -> dict[str, Any]:
    return {"start": float(p.start_s), "end": float(p.end_s), **p.factors.settings_values()}
