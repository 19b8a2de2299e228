"""How well one pretrained 2D network finds people in ceiling fisheye video, measured on a
simulated session against its exact ground truth (docs/pose-in-fisheye.md has the tables).

The paper's central claim: a 2D network trained on ordinary upright photographs, applied to
upright virtual pinhole views instead of the raw fisheye image, finds people anywhere under a
ceiling fisheye without retraining. This module measures that claim with the SAME network
(the BlazePose landmark model) on the SAME people, changing only what the network is shown.

Conditions (``CONDITIONS``), each per ground-truth person whose torso the camera sees (below):

``view``
    An upright virtual pinhole view (the network's input size, 256 x 256) aimed at the true
    hip centre, its field of view fitted to the true body as the 2D stage fits it to detected
    body keypoints (when the network gives no alignment points): half field of view = the
    largest angle between the hip-centre ray and the rays of the body keypoints, times
    ``PoseSettings.body_margin``, clipped to the stage's limits. Keypoints go back to fisheye
    pixels through the view.
``crop``
    The raw fisheye image, cut as an axis-aligned square around the bounding box of the true
    body keypoints in fisheye pixels (side = margin x the box's longer side, centred on the
    box) and resized to 256 x 256: what a person detector's box on the raw image would give.
    Keypoints go back with the crop's affine map.
``rotated_crop``
    The raw fisheye image, cut as a square centred on the true hip centre and rotated so the
    image of the hip-to-shoulder direction points up (side = 2 x margin x the largest distance
    from the hip centre to a body keypoint in fisheye pixels): the region MediaPipe's own
    pipeline would hand its landmark model (its detector aligns the crop with the body axis).
``aligned_view``
    The ``view`` above rolled about its own optical axis so that the image of the true
    hip-to-shoulder direction points straight up: still a pinhole view of the same part of the
    scene, but aligned with the body the way MediaPipe's crops are (a person leaning over a
    table leans in an upright view and stands straight in an aligned one).
``stage``
    The full 2D stage, :class:`ergopose.pose.fisheye.FisheyePoseEstimator`, run end to end on
    every frame (search views with the detector, motion cues, re-focusing on the network's
    alignment points with views upright to the world (turned towards the body axis by at most
    ``PoseSettings.max_body_roll``), left/right kept consistent, coasting, searching where a person was
    lost); nothing from the ground truth is given to it. Its detections are matched one to one to the people.

The four oracle conditions (all but ``stage``) give the network the true
position and size of the person, so they measure only the effect of what the network sees;
``stage`` measures the product.

Found: presence (the network's pose flag) >= ``min_presence`` and the predicted hip centre
within ``found_within_torso`` torso lengths of the true hip centre. Distances "in torso
lengths" are angles between rays from the camera, divided by the angle the torso subtends at
the person's distance (3D shoulder-centre to hip-centre length / distance of the hip centre
from the camera): the error perpendicular to the line of sight, in units of the person's own
torso. This does not shrink when the torso is foreshortened (a person seen from above).

Keypoint error: for every found person, each of the 12 limb keypoints (shoulders, elbows,
wrists, hips, knees, ankles) that the camera sees (ground-truth visibility 0) gives one error
in fisheye pixels and one in torso lengths; the summaries pool these per region and camera.

Region: the angle of the true hip centre off the camera's lens axis, in ergopose's lens regions
(ergopose.geometry.regions: central < 30 deg, outer 30-60, edge >= 60 by default;
``EvaluationSettings.region_limits_deg``).
Counted persons: the camera sees the torso, i.e. both shoulders and both hips have ground-truth
visibility 0 (visible) or 1 (self-occluded: behind the person's own body, as the far hip and
shoulder of anyone seen from the side are), and none is hidden by furniture or another worker or
outside the image. ``EvaluationSettings.torso_codes = (0,)`` counts only people whose four
torso joints are all directly visible (people facing the camera or seen from above); that
drops almost everyone seen from the side, the view the rig's second camera has of a person
under the first.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import cv2
import numpy as np

from ergopose.atomic import write_text
from ergopose.cli_progress import ProgressBars
from ergopose.errors import ConfigError, ErgoposeError, InputError
from ergopose.geometry.regions import DEFAULT_LIMITS_DEG, REGION_NAMES, describe, region_index
from ergopose.geometry.views import VirtualView
from ergopose.keypoints import JOINT_INDEX
from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker, Roi
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.pose.settings import PoseSettings
from ergopose.progress import ProgressCallback, report
from ergopose.session import load_session
from ergopose.sim.ground_truth import load_ground_truth
from ergopose.video import read_frames

CONDITIONS: tuple[str, ...] = ("view", "crop", "rotated_crop", "aligned_view", "stage")

#: One line per condition for tables and reports.
CONDITION_TEXT: dict[str, str] = {
    "view": "upright virtual view aimed at the true hip centre, field of view fitted to the true body",
    "crop": "raw fisheye crop: axis-aligned square around the true keypoints' box, resized to 256 x 256",
    "rotated_crop": "raw fisheye crop centred on the true hips, rotated so the body axis points up",
    "aligned_view": "the upright view rolled about its axis so the true hip-to-shoulder direction points up",
    "stage": "full 2D stage (FisheyePoseEstimator: search views + detector, motion, re-focus), no ground truth",
}

#: Keypoints whose errors are measured (the ones RULA/REBA angles are built from).
EVAL_JOINT_NAMES: tuple[str, ...] = (
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
)
EVAL_JOINTS = np.array([JOINT_INDEX[n] for n in EVAL_JOINT_NAMES])

#: Keypoints that fit a view or crop to the body (the set the 2D stage fits its views to).
FIT_JOINT_NAMES: tuple[str, ...] = (
    "nose",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
    "left_heel",
    "right_heel",
    "left_foot_index",
    "right_foot_index",
)
FIT_JOINTS = np.array([JOINT_INDEX[n] for n in FIT_JOINT_NAMES])

_HIPS = np.array([JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]])
_SHOULDERS = np.array([JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]])
_TORSO = np.concatenate([_SHOULDERS, _HIPS])
_VISIBLE = 0  # ground-truth visibility code of a joint the camera sees
_OUTSIDE_IMAGE = 4


@dataclass(frozen=True)
class EvaluationSettings:
    """How the conditions are built and scored (angles in radians).

    margin, min_half_fov, max_half_fov: the view fit (defaults: the 2D stage's PoseSettings).
    min_presence: pose flag needed to count a person as found (the stage's threshold).
    found_within_torso: largest hip-centre error, in torso lengths, of a found person.
    region_limits_deg: where the outer and edge lens regions begin (degrees off the lens axis).
    torso_codes: ground-truth visibility codes the four torso joints may have for a person to
        be counted (0 visible, 1 self-occluded; see the module docstring).
    stage: the 2D stage's settings for the ``stage`` condition.
    """

    margin: float = 1.3
    min_half_fov: float = float(np.radians(8.0))
    max_half_fov: float = float(np.radians(55.0))
    min_presence: float = 0.5
    found_within_torso: float = 0.5
    torso_codes: tuple[int, ...] = (0, 1)
    region_limits_deg: tuple[float, float] = DEFAULT_LIMITS_DEG
    stage: object = None  # PoseSettings; None: the stage's defaults

    def stage_settings(self):
        return self.stage if self.stage is not None else PoseSettings()

    @classmethod
    def like_stage(cls, stage=None, **overrides) -> "EvaluationSettings":
        """Settings whose view fit equals the given (default) 2D stage settings."""
        s = stage if stage is not None else PoseSettings()
        values: dict[str, Any] = dict(
            margin=float(s.body_margin),
            min_half_fov=float(s.min_half_fov),
            max_half_fov=float(s.max_half_fov),
            min_presence=float(s.min_presence),
            stage=s,
        )
        values.update(overrides)
        return cls(**values)


@dataclass(frozen=True)
class PersonTrials:
    """One row per condition, frame, camera and counted person (N rows).

    condition: (N,) int, index into CONDITIONS. frame, camera, worker: (N,) int (frame index in
    the video, camera index in the session, worker index in the ground truth).
    region: (N,) int, index into ergopose.geometry.regions.REGION_NAMES of the true hip centre. theta: (N,) its angle
    off the lens axis, radians. trunk_inclination: (N,) angle of the true 3D hip-centre to
    shoulder-centre direction from the vertical, radians (0 upright, pi/2 bent flat).
    presence: (N,) the network's pose flag (stage: of the matched detection; NaN when no
    detection matched).
    found: (N,) bool (see the module docstring).
    hip_error_torso: (N,) predicted-to-true hip-centre distance in torso lengths (NaN when the
    network gave no usable hips, or for the stage when nothing matched).
    joint_error_px: (N, 12) fisheye-pixel error of EVAL_JOINTS; NaN where the person was not
    found, the joint is not visible in the camera, or the prediction has no fisheye pixel.
    joint_error_torso: (N, 12) the same errors in torso lengths.
    """

    condition: np.ndarray
    frame: np.ndarray
    camera: np.ndarray
    worker: np.ndarray
    region: np.ndarray
    theta: np.ndarray
    trunk_inclination: np.ndarray
    presence: np.ndarray
    found: np.ndarray
    hip_error_torso: np.ndarray
    joint_error_px: np.ndarray
    joint_error_torso: np.ndarray

    def __len__(self) -> int:
        return int(self.condition.shape[0])

    @classmethod
    def concatenate(cls, parts: Sequence["PersonTrials"]) -> "PersonTrials":
        names = cls.__dataclass_fields__.keys()
        return cls(**{n: np.concatenate([getattr(p, n) for p in parts]) for n in names})

    def select(self, mask: np.ndarray) -> "PersonTrials":
        names = type(self).__dataclass_fields__.keys()
        return type(self)(**{n: getattr(self, n)[mask] for n in names})


@dataclass(frozen=True)
class RegionSummary:
    """Detection rate and keypoint error of one condition in one lens region of one camera.

    camera, region: names, or "all" when pooled. persons: counted person-frames; found: of
    those, found. detection_rate: found / persons (NaN when persons is 0). joints: number of
    keypoint errors pooled. error_*: median and 90th percentile of those errors, in fisheye
    pixels and in torso lengths (NaN when no errors).
    """

    condition: str
    camera: str
    region: str
    persons: int
    found: int
    detection_rate: float
    joints: int
    error_px_median: float
    error_px_p90: float
    error_torso_median: float
    error_torso_p90: float


@dataclass(frozen=True)
class OtherCameraSummary:
    """People in the central region of one camera (seen from above) and what the rig makes of them.

    persons: person-frames with the torso visible in the central region of some camera.
    found_here: found by that camera; found_other: found by the other camera (the person is
    then in its outer region, seen from the side); found_either: by at least one of the two.
    """

    condition: str
    persons: int
    found_here: int
    found_other: int
    found_either: int


@dataclass(frozen=True)
class PoseEvaluation:
    """The result of :func:`evaluate_session`.

    session: the session folder. frames: the (start, stop, step) of the scored frames.
    image_size: (width, height) of the cameras. cameras, workers, regions: names, in the index
    order used by ``trials``. conditions: those evaluated. settings: how.
    trials: every scored person (PersonTrials). summaries: per condition, camera (and "all")
    and region (and "all"). stage_frames: frames the stage processed per camera;
    stage_false_positives: per camera, stage detections in scored frames matched to no worker.
    other_camera: OtherCameraSummary per condition (only for sessions with two cameras).
    seconds: wall time of the evaluation.
    """

    session: Path
    frames: tuple[int, int, int]
    image_size: tuple[int, int]
    cameras: tuple[str, ...]
    workers: tuple[str, ...]
    regions: tuple[str, ...]
    conditions: tuple[str, ...]
    settings: EvaluationSettings
    trials: PersonTrials
    summaries: tuple[RegionSummary, ...]
    stage_frames: int
    stage_false_positives: tuple[int, ...]
    other_camera: tuple[OtherCameraSummary, ...]
    seconds: float = field(default=float("nan"))

    def summary(self, condition: str, camera: str = "all", region: str = "all") -> RegionSummary:
        for s in self.summaries:
            if (s.condition, s.camera, s.region) == (condition, camera, region):
                return s
        raise KeyError(f"no summary for condition {condition!r}, camera {camera!r}, region {region!r}")

    @property
    def scored_frames(self) -> int:
        start, stop, step = self.frames
        return len(range(start, stop, step))


# --------------------------------------------------------------------------------------------
# Geometry of one person in one camera


def _unit(v: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles (radians) between unit vectors (..., 3), accurate near 0; NaN propagates."""
    return 2.0 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


def _hip_centre_ray(rays: np.ndarray) -> np.ndarray:
    """(..., 33, 3) unit rays -> (..., 3) unit ray of the hip centre (mean of the two hip rays)."""
    return _unit(rays[..., _HIPS, :].mean(axis=-2))


@dataclass(frozen=True)
class PersonGeometry:
    """Ground truth of one person in one camera and frame (camera frame, fisheye pixels).

    rays_cam: (33, 3) unit rays to the joints. pixels: (33, 2) fisheye pixels (NaN outside the
    lens). visibility: (33,) codes. hip_world: (3,) the true hip centre (3D mid-point of the
    hips). hip_ray: (3,) unit ray of the hip centre, the normalised mean of the two hip rays
    (the construction used for predictions). torso_angle: 3D torso length (shoulder centre to
    hip centre) / distance of the hip centre from the camera (radians). theta: angle of
    hip_ray off the lens axis (radians). trunk_inclination: angle of the 3D hip-centre to
    shoulder-centre direction from the vertical (radians).
    """

    rays_cam: np.ndarray
    pixels: np.ndarray
    visibility: np.ndarray
    hip_world: np.ndarray
    hip_ray: np.ndarray
    torso_angle: float
    theta: float
    trunk_inclination: float = float("nan")

    @classmethod
    def of(cls, camera, joints_world: np.ndarray, pixels: np.ndarray, visibility: np.ndarray) -> "PersonGeometry":
        points_cam = camera.points_world_to_cam(joints_world)
        rays = _unit(points_cam)
        hip_world = joints_world[_HIPS].mean(axis=0)
        trunk = joints_world[_SHOULDERS].mean(axis=0) - hip_world
        torso = float(np.linalg.norm(trunk))
        inclination = float(np.arccos(np.clip(trunk[2] / torso, -1.0, 1.0))) if torso > 0 else float("nan")
        distance = float(np.linalg.norm(camera.points_world_to_cam(hip_world)))
        # The hip centre's ray is built as for a prediction (mean of the two hip rays), so a
        # perfect prediction scores exactly zero; it differs from the ray to the 3D mid-point
        # by a small fraction of the hip width's angle.
        hip_ray = _hip_centre_ray(rays)
        theta = float(np.arctan2(np.hypot(hip_ray[0], hip_ray[1]), hip_ray[2]))
        return cls(
            rays,
            np.asarray(pixels, np.float64),
            np.asarray(visibility),
            hip_world,
            hip_ray,
            torso / distance,
            theta,
            inclination,
        )

    @property
    def torso_visible(self) -> bool:
        """All four torso joints directly visible (visibility 0)."""
        return bool(np.all(self.visibility[_TORSO] == _VISIBLE))

    def counted(self, settings: EvaluationSettings) -> bool:
        """The person counts in the evaluation: every torso joint's code is in settings.torso_codes."""
        return bool(np.all(np.isin(self.visibility[_TORSO], settings.torso_codes)))

    def view(self, camera, size: tuple[int, int], settings: EvaluationSettings):
        """The upright virtual view aimed at the true hip centre, fitted to the true body."""
        radius = float(np.max(_angle(self.rays_cam[FIT_JOINTS], self.hip_ray[None])))
        half = float(np.clip(radius * settings.margin, settings.min_half_fov, settings.max_half_fov))
        return VirtualView.aimed_along(camera, self.hip_ray, hfov=2.0 * half, size=size)

    def aligned_view(self, camera, size: tuple[int, int], settings: EvaluationSettings):
        """:meth:`view` rolled about its optical axis so hip -> shoulder points up in the image."""
        view = self.view(camera, size, settings)
        r = view.rotation_cam_from_view
        hip = view.lens.project(self.hip_ray @ r)
        shoulder = view.lens.project(_unit(self.rays_cam[_SHOULDERS].mean(axis=0)) @ r)
        d = shoulder - hip
        roll = float(np.arctan2(d[0], -d[1])) if np.all(np.isfinite(d)) and np.any(d != 0) else 0.0
        c, s = np.cos(roll), np.sin(roll)
        # A view pixel direction turned clockwise by ``roll`` from up comes out straight up.
        rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return VirtualView(
            source=view.source, lens=view.lens, width=view.width, height=view.height, rotation_cam_from_view=r @ rz
        )

    def _fit_pixels(self) -> np.ndarray:
        px = self.pixels[FIT_JOINTS]
        inside = (self.visibility[FIT_JOINTS] != _OUTSIDE_IMAGE) & np.isfinite(px).all(axis=1)
        return px[inside]

    def crop_roi(self, settings: EvaluationSettings):
        """Axis-aligned square around the true keypoints' box in fisheye pixels (``crop``)."""
        px = self._fit_pixels()
        lo, hi = px.min(axis=0), px.max(axis=0)
        side = settings.margin * float(max(hi - lo))
        return Roi(centre=(lo + hi) / 2.0, side=max(side, 4.0), rotation=0.0)

    def rotated_roi(self, settings: EvaluationSettings):
        """Square on the true hip centre, rotated so hip -> shoulder points up (``rotated_crop``)."""
        hip = self.pixels[_HIPS].mean(axis=0)
        axis = self.pixels[_SHOULDERS].mean(axis=0) - hip
        rotation = float(np.arctan2(axis[0], -axis[1]))
        radius = float(np.max(np.linalg.norm(self._fit_pixels() - hip, axis=1)))
        return Roi(centre=hip, side=max(2.0 * settings.margin * radius, 4.0), rotation=rotation)


def score_prediction(
    person: PersonGeometry,
    pixels_fisheye: np.ndarray,
    rays_cam: np.ndarray,
    presence: float,
    settings: EvaluationSettings,
) -> tuple[bool, float, np.ndarray, np.ndarray]:
    """Score one prediction of one person: (found, hip error in torso lengths, joint errors in
    fisheye pixels (12,), joint errors in torso lengths (12,)).

    pixels_fisheye: (33, 2) predicted fisheye pixels; rays_cam: (33, 3) their unit rays (NaN
    where there is no prediction). Joint errors are NaN unless found and the joint is visible.
    """
    hip_error = float(_angle(_hip_centre_ray(rays_cam), person.hip_ray) / person.torso_angle)
    found = bool(presence >= settings.min_presence and hip_error <= settings.found_within_torso)
    nan = np.full(EVAL_JOINTS.size, np.nan)
    if not found:
        return False, hip_error, nan, nan.copy()
    seen = person.visibility[EVAL_JOINTS] == _VISIBLE
    err_px = np.linalg.norm(pixels_fisheye[EVAL_JOINTS] - person.pixels[EVAL_JOINTS], axis=1)
    err_torso = _angle(rays_cam[EVAL_JOINTS], person.rays_cam[EVAL_JOINTS]) / person.torso_angle
    return True, hip_error, np.where(seen, err_px, np.nan), np.where(seen, err_torso, np.nan)


# --------------------------------------------------------------------------------------------
# One camera


class _Rows:
    def __init__(self, limits_deg: tuple[float, float]):
        self.limits_deg = limits_deg
        self.rows: list[tuple] = []

    def add(
        self,
        condition: int,
        frame: int,
        camera: int,
        worker: int,
        person: PersonGeometry,
        presence: float,
        scored: tuple[bool, float, np.ndarray, np.ndarray],
    ) -> None:
        region = int(region_index(np.degrees(person.theta), self.limits_deg))
        found, hip_error, err_px, err_torso = scored
        self.rows.append(
            (
                condition,
                frame,
                camera,
                worker,
                region,
                person.theta,
                person.trunk_inclination,
                presence,
                found,
                hip_error,
                err_px,
                err_torso,
            )
        )

    def trials(self) -> PersonTrials:
        n = len(self.rows)
        k = EVAL_JOINTS.size
        if n == 0:
            z = np.zeros(0)
            return PersonTrials(
                z.astype(np.int64),
                z.astype(np.int64),
                z.astype(np.int64),
                z.astype(np.int64),
                z.astype(np.int64),
                z,
                z,
                z,
                z.astype(bool),
                z,
                np.zeros((0, k)),
                np.zeros((0, k)),
            )
        cols = list(zip(*self.rows))
        ints = [np.array(c, dtype=np.int64) for c in cols[:5]]
        return PersonTrials(
            condition=ints[0],
            frame=ints[1],
            camera=ints[2],
            worker=ints[3],
            region=ints[4],
            theta=np.array(cols[5], np.float64),
            trunk_inclination=np.array(cols[6], np.float64),
            presence=np.array(cols[7], np.float64),
            found=np.array(cols[8], bool),
            hip_error_torso=np.array(cols[9], np.float64),
            joint_error_px=np.stack(cols[10]),
            joint_error_torso=np.stack(cols[11]),
        )


def _match_stage(
    people: list[tuple[int, PersonGeometry]], others: list[PersonGeometry], found, settings: EvaluationSettings
) -> tuple[dict[int, int], int]:
    """Match the stage's detections (FrameDetections) to the counted people one to one.

    Pairs closer than ``found_within_torso`` (hip centres, torso lengths of the person) are
    taken smallest first. Returns {person position: detection index} and the number of false
    positives: detections matched neither to a counted person nor to a worker whose torso is
    hidden (``others``, such a detection is right but not scored).
    """
    n_det = found.count
    if n_det == 0:
        return {}, 0
    det_hips = _hip_centre_ray(found.rays_cam)  # (D, 3)

    def distances(persons: list[PersonGeometry]) -> np.ndarray:
        if not persons:
            return np.zeros((0, n_det))
        hips = np.stack([p.hip_ray for p in persons])
        torso = np.array([p.torso_angle for p in persons])
        return _angle(det_hips[None], hips[:, None]) / torso[:, None]

    d = distances([p for _, p in people])
    matches: dict[int, int] = {}
    used: set[int] = set()
    if d.size:
        order = np.dstack(np.unravel_index(np.argsort(d, axis=None), d.shape))[0]
        for i, j in order:
            if not d[i, j] <= settings.found_within_torso:
                break
            if i in matches or j in used:
                continue
            matches[int(i)] = int(j)
            used.add(int(j))
    rest = [j for j in range(n_det) if j not in used]
    d_other = distances(others)
    explained = {j for j in rest if d_other.size and np.nanmin(d_other[:, j]) <= settings.found_within_torso}
    return matches, len(rest) - len(explained)


def _evaluate_camera(
    session_dir: Path,
    camera_index: int,
    frames: tuple[int, int, int],
    conditions: tuple[str, ...],
    settings: EvaluationSettings,
    landmarker,
    detector,
    progress: ProgressCallback | None,
    done_offset: int,
    total: int,
) -> tuple[PersonTrials, int, int]:
    session = load_session(session_dir)
    if session.ground_truth_dir is None:
        raise InputError(
            "not a simulated session: no ground_truth/ folder (evaluation needs the truth)", path=session_dir
        )
    gt = load_ground_truth(session.ground_truth_dir)
    cam = session.cameras[camera_index]
    camera = cam.camera
    size = (int(landmarker.input_size[0]), int(landmarker.input_size[1]))
    start, stop, step = frames
    want = {c: CONDITIONS.index(c) for c in conditions}
    stage = None
    if "stage" in want:
        stage = FisheyePoseEstimator(camera, camera_index, landmarker, detector, settings.stage_settings())
    rows = _Rows(settings.region_limits_deg)
    false_positives = 0
    stage_frames = 0
    n_workers = len(gt.worker_ids)
    for index, frame in read_frames(cam.video_path, start, stop):
        scored = (index - start) % step == 0
        found = None
        if stage is not None:
            found = stage.process(frame, index)
            stage_frames += 1
        if not scored:
            continue
        people: list[tuple[int, PersonGeometry]] = []
        hidden: list[PersonGeometry] = []
        for w in range(n_workers):
            p = PersonGeometry.of(
                camera,
                gt.joints_world[index, w],
                gt.pixels[index, camera_index, w],
                gt.visibility[index, camera_index, w],
            )
            if p.counted(settings):
                people.append((w, p))
            elif np.any(p.visibility != _OUTSIDE_IMAGE):
                hidden.append(p)
        for w, p in people:
            for name, make in (("view", p.view), ("aligned_view", p.aligned_view)):
                if name not in want:
                    continue
                view = make(camera, size, settings)
                kp = landmarker(view.build_map().apply(frame))
                rays = view.view_pixels_to_rays_cam(kp.pixels)
                rows.add(
                    want[name],
                    index,
                    camera_index,
                    w,
                    p,
                    kp.presence,
                    score_prediction(p, camera.lens.project(rays), rays, kp.presence, settings),
                )
            for name, make_roi in (("crop", p.crop_roi), ("rotated_crop", p.rotated_roi)):
                if name not in want:
                    continue
                roi = make_roi(settings)
                kp = landmarker(roi.crop(frame, size[0])).transformed(roi.crop_to_image(size[0]))
                rays = _unit(camera.lens.unproject(kp.pixels))
                rows.add(
                    want[name],
                    index,
                    camera_index,
                    w,
                    p,
                    kp.presence,
                    score_prediction(p, kp.pixels, rays, kp.presence, settings),
                )
        if found is not None:
            matches, fp = _match_stage(people, hidden, found, settings)
            false_positives += fp
            for pos, (w, p) in enumerate(people):
                j = matches.get(pos)
                if j is None:
                    nan = np.full(EVAL_JOINTS.size, np.nan)
                    rows.add(want["stage"], index, camera_index, w, p, float("nan"), (False, float("nan"), nan, nan))
                else:
                    rows.add(
                        want["stage"],
                        index,
                        camera_index,
                        w,
                        p,
                        float(found.presence[j]),
                        score_prediction(
                            p, found.pixels_fisheye[j], found.rays_cam[j], float(found.presence[j]), settings
                        ),
                    )
        report(
            progress,
            "pose evaluation",
            done_offset + (index - start) // step + 1,
            total,
            unit="frame",
            message=camera.name,
        )
    return rows.trials(), false_positives, stage_frames


def _camera_worker(args) -> tuple[PersonTrials, int, int]:
    """One camera in its own process, with its own networks (num_threads as given)."""
    session_dir, camera_index, frames, conditions, settings, model_dir, num_threads = args

    cv2.setNumThreads(1)
    landmarker = BlazePoseLandmarker(model_dir=model_dir, num_threads=num_threads)
    detector = BlazePoseDetector(model_dir=model_dir, num_threads=num_threads) if "stage" in conditions else None
    return _evaluate_camera(session_dir, camera_index, frames, conditions, settings, landmarker, detector, None, 0, 0)


# --------------------------------------------------------------------------------------------
# Summaries


def _summarise(
    trials: PersonTrials, conditions: Sequence[str], cameras: Sequence[str], regions: Sequence[str]
) -> tuple[RegionSummary, ...]:
    out = []
    for condition in conditions:
        c_mask = trials.condition == CONDITIONS.index(condition)
        for ci, cam in [(None, "all")] + list(enumerate(cameras)):
            cam_mask = c_mask if ci is None else c_mask & (trials.camera == ci)
            for ri, reg in list(enumerate(regions)) + [(None, "all")]:
                m = cam_mask if ri is None else cam_mask & (trials.region == ri)
                out.append(_summary(condition, cam, reg, trials.select(m)))
    return tuple(out)


def _summary(condition: str, camera: str, region: str, t: PersonTrials) -> RegionSummary:
    persons, found = len(t), int(t.found.sum())
    px = t.joint_error_px[np.isfinite(t.joint_error_px)]
    torso = t.joint_error_torso[np.isfinite(t.joint_error_torso)]

    def q(values: np.ndarray, p: float) -> float:
        return float(np.percentile(values, p)) if values.size else float("nan")

    return RegionSummary(
        condition,
        camera,
        region,
        persons,
        found,
        found / persons if persons else float("nan"),
        int(px.size),
        q(px, 50),
        q(px, 90),
        q(torso, 50),
        q(torso, 90),
    )


def _other_camera(
    trials: PersonTrials, conditions: Sequence[str], n_cameras: int, central: int
) -> tuple[OtherCameraSummary, ...]:
    if n_cameras != 2:
        return ()
    out = []
    for condition in conditions:
        t = trials.select(trials.condition == CONDITIONS.index(condition))
        found_at = {(int(f), int(c), int(w)): bool(x) for f, c, w, x in zip(t.frame, t.camera, t.worker, t.found)}
        persons = here = other = either = 0
        for f, c, w, r, x in zip(t.frame, t.camera, t.worker, t.region, t.found):
            if r != central:
                continue
            o = found_at.get((int(f), 1 - int(c), int(w)), False)
            persons += 1
            here += bool(x)
            other += o
            either += bool(x) or o
        out.append(OtherCameraSummary(condition, persons, here, other, either))
    return tuple(out)


# --------------------------------------------------------------------------------------------
# Entry point


def evaluate_session(
    session_dir: str | os.PathLike,
    *,
    conditions: Sequence[str] = CONDITIONS,
    start: int = 0,
    stop: int | None = None,
    step: int = 1,
    settings: EvaluationSettings | None = None,
    landmarker=None,
    detector=None,
    processes: int = 1,
    num_threads: int = 1,
    model_dir: str | os.PathLike | None = None,
    progress: ProgressCallback | None = None,
) -> PoseEvaluation:
    """Measure the conditions (module docstring) on a simulated session.

    session_dir: a folder written by ``ergopose simulate`` (it must have ground_truth/).
    conditions: any of CONDITIONS. start, stop, step: the frames scored (the stage processes
    every frame from ``start`` to ``stop`` and is scored on the same frames as the others).
    landmarker, detector: networks to use (processes=1 only); default: BlazePose from the model
    cache (``model_dir``) with ``num_threads`` LiteRT threads.
    processes: 1, or 2 to evaluate each camera in its own process with its own networks.
    """
    t0 = time.perf_counter()
    conditions = tuple(conditions)
    unknown = [c for c in conditions if c not in CONDITIONS]
    if unknown or not conditions:
        raise ConfigError(f"unknown condition(s) {unknown}; choose from {', '.join(CONDITIONS)}", field="conditions")
    settings = settings if settings is not None else EvaluationSettings.like_stage()
    session_dir = Path(session_dir)
    session = load_session(session_dir)
    if session.ground_truth_dir is None:
        raise InputError(
            "not a simulated session: no ground_truth/ folder (evaluation needs the truth)", path=session_dir
        )
    gt = load_ground_truth(session.ground_truth_dir)
    n_frames = min(session.frame_count, gt.n_frames)
    stop = n_frames if stop is None else min(int(stop), n_frames)
    if not 0 <= start < stop or step < 1:
        raise ConfigError(f"no frames to score in {start}..{stop} step {step} (session has {n_frames})", field="frames")
    frames = (int(start), int(stop), int(step))
    n_cam = len(session.cameras)
    per_camera = len(range(*frames))
    if processes not in (1, 2):
        raise ConfigError(f"processes must be 1 or 2, got {processes}", field="processes")
    if processes == 2 and n_cam > 1:
        if landmarker is not None or detector is not None:
            raise ConfigError(
                "networks cannot be passed to worker processes; leave landmarker/detector unset", field="processes"
            )
        jobs = [(session_dir, ci, frames, conditions, settings, model_dir, num_threads) for ci in range(n_cam)]
        results = []
        # Spawned workers: forking a process whose LiteRT or OpenCV thread pools are running
        # (a caller that already ran a network) can deadlock the child.
        with ProcessPoolExecutor(max_workers=2, mp_context=multiprocessing.get_context("spawn")) as pool:
            for k, r in enumerate(pool.map(_camera_worker, jobs)):
                results.append(r)
                report(progress, "pose evaluation", (k + 1) * per_camera, n_cam * per_camera, unit="frame")
    else:
        if landmarker is None:
            landmarker = BlazePoseLandmarker(model_dir=model_dir, num_threads=num_threads)
        if detector is None and "stage" in conditions:
            detector = BlazePoseDetector(model_dir=model_dir, num_threads=num_threads)
        results = [
            _evaluate_camera(
                session_dir,
                ci,
                frames,
                conditions,
                settings,
                landmarker,
                detector,
                progress,
                ci * per_camera,
                n_cam * per_camera,
            )
            for ci in range(n_cam)
        ]
    trials = PersonTrials.concatenate([r[0] for r in results])
    cameras = session.camera_names
    regions = REGION_NAMES
    summaries = _summarise(trials, conditions, cameras, regions)
    return PoseEvaluation(
        session=session_dir,
        frames=frames,
        image_size=(session.cameras[0].camera.width, session.cameras[0].camera.height),
        cameras=cameras,
        workers=tuple(gt.worker_ids),
        regions=regions,
        conditions=conditions,
        settings=settings,
        trials=trials,
        summaries=summaries,
        stage_frames=max(r[2] for r in results),
        stage_false_positives=tuple(int(r[1]) for r in results),
        other_camera=_other_camera(trials, conditions, n_cam, regions.index("central")),
        seconds=time.perf_counter() - t0,
    )


# --------------------------------------------------------------------------------------------
# Markdown

#: Trunk inclination bins (degrees from the vertical) of the markdown's last table.
INCLINATION_BINS_DEG: tuple[tuple[float, float], ...] = ((0.0, 15.0), (15.0, 30.0), (30.0, 60.0), (60.0, 180.0))


def _pct(found: int, persons: int) -> str:
    return "-" if persons == 0 else f"{100.0 * found / persons:.1f} % ({found}/{persons})"


def _num(x: float, digits: int) -> str:
    return "-" if not np.isfinite(x) else f"{x:.{digits}f}"


def render_markdown(result: PoseEvaluation, *, per_camera: bool = True) -> str:
    """The evaluation as markdown tables: per region pooled over cameras, then per camera,
    the stage's false positives, and the central region seen by the other camera."""
    lines = []
    start, stop, step = result.frames
    w, h = result.image_size
    lines.append(
        f"Session `{result.session.name}`: {w}x{h}, cameras {', '.join(result.cameras)}, "
        f"workers {', '.join(result.workers)}, frames {start}..{stop - 1} every {step} "
        f"({result.scored_frames} scored frames per camera). Lens regions: "
        f"{describe(result.settings.region_limits_deg)}."
    )
    lines.append("")

    def table(camera: str) -> None:
        lines.append("| condition | region | found | keypoints | median px | p90 px | median torso | p90 torso |")
        lines.append("|---|---|---|---|---|---|---|---|")
        for condition in result.conditions:
            for region in result.regions + ("all",):
                s = result.summary(condition, camera, region)
                lines.append(
                    f"| {condition} | {region} | {_pct(s.found, s.persons)} | {s.joints} | "
                    f"{_num(s.error_px_median, 1)} | {_num(s.error_px_p90, 1)} | "
                    f"{_num(s.error_torso_median, 3)} | {_num(s.error_torso_p90, 3)} |"
                )
        lines.append("")

    lines.append("Both cameras pooled:")
    lines.append("")
    table("all")
    if per_camera:
        for cam in result.cameras:
            lines.append(f"Camera {cam}:")
            lines.append("")
            table(cam)
    lines.append(
        "Detection rate by trunk inclination (true hip-to-shoulder direction from the vertical), "
        "both cameras, all regions:"
    )
    lines.append("")
    lines.append("| trunk inclination | " + " | ".join(result.conditions) + " |")
    lines.append("|---" * (len(result.conditions) + 1) + "|")
    t = result.trials
    incl = np.degrees(t.trunk_inclination)
    for lo, hi in INCLINATION_BINS_DEG:
        cells = []
        for condition in result.conditions:
            m = (t.condition == CONDITIONS.index(condition)) & (incl >= lo) & (incl < hi)
            cells.append(_pct(int(t.found[m].sum()), int(m.sum())))
        label = f"{lo:g}-{hi:g} deg" if hi < 180 else f">= {lo:g} deg"
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines.append("")
    if "stage" in result.conditions:
        fp = ", ".join(f"{c} {n}" for c, n in zip(result.cameras, result.stage_false_positives))
        lines.append(
            f"Stage detections matched to no worker (false positives) in the scored frames: {fp} "
            f"({result.stage_frames} frames processed per camera)."
        )
        lines.append("")
    if result.other_camera:
        lines.append("People in the central region of one camera (seen from above), and the other camera:")
        lines.append("")
        lines.append(
            "| condition | person-frames | found by that camera | found by the other camera | found by either |"
        )
        lines.append("|---|---|---|---|---|")
        for o in result.other_camera:
            lines.append(
                f"| {o.condition} | {o.persons} | {_pct(o.found_here, o.persons)} | "
                f"{_pct(o.found_other, o.persons)} | {_pct(o.found_either, o.persons)} |"
            )
        lines.append("")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# Command line: python -m ergopose.evaluation.pose SESSION [options]


def main(argv: Sequence[str] | None = None) -> int:
    """Evaluate a simulated session and write the markdown tables (stdout or --out, atomically)."""
    parser = argparse.ArgumentParser(
        prog="python -m ergopose.evaluation.pose",
        description="Detection rate and keypoint error of the BlazePose landmark model on upright views, "
        "raw fisheye crops, rotated crops and the full 2D stage, per lens region, "
        "on a session written by 'ergopose simulate' (docs/pose-in-fisheye.md).",
    )
    parser.add_argument("session", type=Path, help="simulated session folder")
    parser.add_argument(
        "--conditions", default=",".join(CONDITIONS), help="comma-separated, from " + ", ".join(CONDITIONS)
    )
    parser.add_argument("--start", type=int, default=0)
    parser.add_argument("--stop", type=int, default=None)
    parser.add_argument("--step", type=int, default=1, help="score every STEP-th frame (the stage sees all)")
    parser.add_argument("--processes", type=int, default=2, choices=(1, 2), help="2: one process per camera (default)")
    parser.add_argument("--threads", type=int, default=1, help="LiteRT threads per process (default 1)")
    parser.add_argument("--model-dir", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=None, help="write the markdown here instead of stdout")
    args = parser.parse_args(argv)

    try:
        result = evaluate_session(
            args.session,
            conditions=[c.strip() for c in args.conditions.split(",") if c.strip()],
            start=args.start,
            stop=args.stop,
            step=args.step,
            processes=args.processes,
            num_threads=args.threads,
            model_dir=args.model_dir,
            progress=ProgressBars(),
        )
    except ErgoposeError as exc:
        print(f"ergopose: error: {exc}", file=sys.stderr)
        return 2
    text = render_markdown(result) + f"\nEvaluated in {result.seconds:.0f} s.\n"
    if args.out is not None:
        write_text(args.out, text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
