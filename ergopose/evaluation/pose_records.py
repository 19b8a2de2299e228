"""The records of the 2D pose measurement (ergopose.evaluation.pose, whose docstring describes
the measurement): the conditions, how they are built and scored, a row per scored person, the
summaries per lens region and camera, and the result of a whole session."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ergopose.geometry.regions import DEFAULT_LIMITS_DEG
from ergopose.pose.settings import PoseSettings

CONDITIONS: tuple[str, ...] = ("view", "crop", "rotated_crop", "aligned_view", "stage")

#: One line per condition for tables and reports.
CONDITION_TEXT: dict[str, str] = {
    "view": "upright virtual view aimed at the true hip centre, field of view fitted to the true body",
    "crop": "raw fisheye crop: axis-aligned square around the true keypoints' box, resized to 256 x 256",
    "rotated_crop": "raw fisheye crop centred on the true hips, rotated so the body axis points up",
    "aligned_view": "the upright view rolled about its axis so the true hip-to-shoulder direction points up",
    "stage": "full 2D stage (FisheyePoseEstimator: search views + detector, motion, re-focus), no ground truth",
}


@dataclass(frozen=True)
class EvaluationSettings:
    """How the conditions are built and scored (angles in radians).

    margin, min_half_fov, max_half_fov: the view fit (defaults: the 2D stage's PoseSettings).
    min_presence: pose flag needed to count a person as found (the stage's threshold).
    found_within_torso: largest hip-centre error, in torso lengths, of a found person.
    region_limits_deg: where the outer and edge lens regions begin (degrees off the lens axis).
    torso_codes: ground-truth visibility codes the four torso joints may have for a person to
        be counted (0 visible, 1 self-occluded; see ergopose.evaluation.pose).
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
    found: (N,) bool (see ergopose.evaluation.pose).
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
    """The result of :func:`ergopose.evaluation.pose.evaluate_session`.

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
