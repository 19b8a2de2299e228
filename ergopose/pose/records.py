"""The fisheye 2D stage's records: where to look for a person (:class:`Target`), the people
found in one frame of one camera (:class:`FrameDetections`), and the networks it calls
(:class:`Landmarker`, :class:`Detector`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ergopose.geometry.camera import Camera
from ergopose.keypoints import NUM_JOINTS
from ergopose.pose.blazepose import Keypoints2D, PersonDetection
from ergopose.records import Detections2D

#: Where a person's view came from (FrameDetections.source).
SOURCE_REFOCUS, SOURCE_MOTION, SOURCE_SEARCH, SOURCE_OTHER_CAMERA = 0, 1, 2, 3
SOURCE_NAMES = ("refocus", "motion", "search", "other camera")


class Landmarker(Protocol):
    """A 2D pose network on a square BGR view (BlazePoseLandmarker or an ONNX top-down model)."""

    input_size: tuple[int, int]

    def __call__(self, image_bgr: np.ndarray) -> Keypoints2D: ...


class Detector(Protocol):
    """A person detector on a square BGR view (the BlazePose detector): the people it finds."""

    input_size: tuple[int, int]

    def __call__(self, image_bgr: np.ndarray) -> list[PersonDetection]: ...


@dataclass(frozen=True)
class Target:
    """Where to look for a person: a unit direction in the camera frame and an angular radius.

    up_cam: (3,) a direction in the camera frame whose image should point up in the view (its
    component across the view's axis is used), e.g. the ray to the shoulders of a person whose
    hips the view is aimed at; None: the view is upright (world vertical up).
    """

    direction_cam: np.ndarray
    half_fov: float
    source: int
    missed: int = 0
    up_cam: np.ndarray | None = None


@dataclass(frozen=True)
class FrameDetections:
    """The people found in one frame of one camera (N people; N may be 0).

    camera_index: position of the camera in the session's camera list.
    frame_index: index of the frame in the video.
    pixels_view: (N, 33, 2) keypoints in the pixels of the view that produced them; NaN where
        the network reports no keypoint.
    pixels_fisheye: (N, 33, 2) the same keypoints in the camera's (fisheye) pixels; NaN where
        the view pixel is NaN or maps outside the lens model.
    rays_cam: (N, 33, 3) unit rays in the camera frame through the keypoints (NaN as above).
    confidence: (N, 33) keypoint confidence in [0, 1] (0 where the pixels are NaN).
    presence: (N,) the network's probability that the view holds a person.
    projection: (N, 3, 4) each view's projection matrix P = K [I|0] [R^T 0; 0 1] W^-1 (world
        points to view pixels), for triangulation in the views (the paper's DLT).
    view_direction_cam: (N, 3) and view_half_fov: (N,) the views' axes and half fields of view.
    source: (N,) int, SOURCE_REFOCUS / SOURCE_MOTION / SOURCE_SEARCH / SOURCE_OTHER_CAMERA (what
        aimed the view; :mod:`ergopose.pose.handoff` for the last).
    left_right_uncertain: (N, 33) bool, the left/right check doubts the side of this keypoint:
        every left/right keypoint of a person whose labelling the network split over the last
        frames or changed less than a window ago, and the keypoints of an arm or leg pair whose
        own left/right disagrees with the body's (``PoseSettings.left_right_check``); None: not
        checked.
    """

    camera_index: int
    frame_index: int
    pixels_view: np.ndarray
    pixels_fisheye: np.ndarray
    rays_cam: np.ndarray
    confidence: np.ndarray
    presence: np.ndarray
    projection: np.ndarray
    view_direction_cam: np.ndarray
    view_half_fov: np.ndarray
    source: np.ndarray
    left_right_uncertain: np.ndarray | None = None

    @property
    def count(self) -> int:
        return int(self.presence.shape[0])

    def to_recon(self, camera: Camera, time_s: float, appearance: np.ndarray | None = None) -> Detections2D:
        """The reconstruction stage's record (ergopose.recon.records.Detections2D) of these people;
        appearance: (N, 6) their clothing colours (ergopose.pose.appearance), None: unknown."""
        rotation = np.asarray(camera.rotation_world_from_cam, dtype=np.float64)
        return Detections2D(
            camera=camera.name,
            frame=self.frame_index,
            time_s=time_s,
            pixels_view=self.pixels_view,
            confidence=self.confidence,
            projection=self.projection,
            rays_world=self.rays_cam @ rotation.T,
            appearance=appearance,
        )

    @classmethod
    def empty(cls, camera_index: int, frame_index: int) -> "FrameDetections":
        return cls(
            camera_index,
            frame_index,
            np.zeros((0, NUM_JOINTS, 2)),
            np.zeros((0, NUM_JOINTS, 2)),
            np.zeros((0, NUM_JOINTS, 3)),
            np.zeros((0, NUM_JOINTS)),
            np.zeros(0),
            np.zeros((0, 3, 4)),
            np.zeros((0, 3)),
            np.zeros(0),
            np.zeros(0, dtype=np.int64),
        )
