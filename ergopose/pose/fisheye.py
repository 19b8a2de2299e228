"""2D pose in fisheye video: find people, aim virtual views at them, run the network, re-focus.

The paper's steps 1-3 for one camera. Per frame:

1. *Targets.* Every person seen in the previous frame becomes a target for this frame: the view
   is re-focused on the pose just detected. With BlazePose (``refocus_on_alignment``) it is
   placed by the landmark network's own two alignment points, the way MediaPipe places its next
   crop: aimed at their hip centre, half field of view = the angular radius of their body
   circle times ``body_margin``, rolled towards their body axis. Without them: aimed at the
   confident hip keypoints, fitted to the body keypoints, rolled towards the hip-to-shoulder
   direction. Every ``search_every`` frames moving blobs from background subtraction on a
   downscaled frame are added as cues; the BlazePose detector runs on upright search views
   that together cover the image circle to the horizon, placed and sized from the lens, the
   image and the detector's input (ergopose/pose/search_layout.py: a person at the farthest
   working distance spans enough detector pixels), a few views per frame so that a whole pass
   costs at most ``search_views_per_frame`` detector runs per frame on average; and on the
   frame after a followed person's view gave up, the detector runs on the search views around
   that place. Each cue
   is a bearing (a ray in the camera frame), an angular size and, from the detector, the body
   axis.
2. *Views.* Each target gets a virtual pinhole view (256 x 256 by default) aimed along its
   bearing. World vertical is the reference for its roll: the view is upright (the paper's
   construction: the image of the world's vertical points up), turned towards the body axis
   when one is known by at most ``max_body_roll``. BlazePose's landmark model was trained on
   crops aligned with the body axis, so a little turn helps a leaning person; a body axis
   trusted without bound lets a view that once went upside down stay upside down (the
   network's alignment points in an upside-down view point "up" in it), and views turned far
   from upright swap people's left and right more often (docs/pose-in-fisheye.md).
3. *Pose.* The landmark network runs on each view; keypoints come back in view pixels, are mapped
   to fisheye pixels and to rays in the camera frame. A detection whose body axis points more
   than ``recheck_roll`` away from world up in a turned view is run again in an upright view
   (kept only if that finds the person the right way up). Overlapping detections of one person
   (two targets that converged) are merged, keeping the one with a plausible body axis, then
   the one whose view is closest to upright, then the more confident one.
4. *Left and right.* Each person's skeleton is compared with their previous frame's: a
   skeleton whose left and right limbs match it the other way round is swapped back; when the
   network keeps the other labelling for most of the last ``left_right_window`` frames it is
   followed. Frames around such a change, and limbs whose own left/right disagrees with the
   body's, are flagged (``left_right_uncertain``); with ``uncertain_confidence`` set their
   confidence is lowered too. By default it is not: one camera's history cannot tell which
   labelling is right, while the reconstruction can (the other cameras, the worker's previous
   fitted body limb by limb: docs/reconstruction.md, "Left and right"), and a lowered
   torso takes the person out of the association altogether (measured on the real recording,
   docs/evaluation.md).

The target is a direction and an angular radius, both in the camera frame, so nothing here
depends on the world or on the other camera.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, replace
from typing import Protocol, Sequence

import cv2
import numpy as np

from ergopose.errors import ConfigError
from ergopose.geometry.camera import Camera
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.geometry.views import ViewMap, VirtualView, upright_rotation
from ergopose.keypoints import JOINT_INDEX, MIRROR, NUM_JOINTS
from ergopose.pose.blazepose import Keypoints2D, PersonDetection
from ergopose.pose.search_layout import SearchLayout, SearchSizing, derive_layout, fixed_layout
from ergopose.progress import ProgressCallback, warn
from ergopose.records import Detections2D

_WORLD_UP = np.array([0.0, 0.0, 1.0])
_LEFT_HIP, _RIGHT_HIP = JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]
_LEFT_SHOULDER, _RIGHT_SHOULDER = JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]
_BODY_JOINTS = np.array([JOINT_INDEX[n] for n in (
    "nose", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
    "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle",
    "left_heel", "right_heel", "left_foot_index", "right_foot_index")])


#: Every left/right pair of the 33 keypoints (swapping a skeleton exchanges all of them).
_LR_PAIRS = np.array([(JOINT_INDEX[n], JOINT_INDEX[n.replace("left", "right")])
                      for n in JOINT_INDEX if "left" in n], dtype=np.int64)
#: The pairs that decide a skeleton's left and right, and the two limb groups checked on their own.
_LR_DECIDE = np.array([(JOINT_INDEX["left_" + n], JOINT_INDEX["right_" + n])
                       for n in ("shoulder", "hip", "elbow", "wrist", "knee", "ankle")], dtype=np.int64)
_LR_LIMBS = {
    "arms": (("elbow", "wrist"), ("elbow", "wrist", "pinky", "index", "thumb")),
    "legs": (("knee", "ankle"), ("knee", "ankle", "heel", "foot_index")),
}
_LR_LIMB_PAIRS = {k: (np.array([(JOINT_INDEX["left_" + n], JOINT_INDEX["right_" + n]) for n in check]),
                      np.array([JOINT_INDEX[side + n] for n in joints for side in ("left_", "right_")]))
                  for k, (check, joints) in _LR_LIMBS.items()}

#: Where a person's view came from (FrameDetections.source).
SOURCE_REFOCUS, SOURCE_MOTION, SOURCE_SEARCH = 0, 1, 2
SOURCE_NAMES = ("refocus", "motion", "search")


class Landmarker(Protocol):
    """A 2D pose network on a square BGR view (BlazePoseLandmarker or an ONNX top-down model)."""

    input_size: tuple[int, int]

    def __call__(self, image_bgr: np.ndarray) -> Keypoints2D: ...


class Detector(Protocol):
    input_size: tuple[int, int]

    def __call__(self, image_bgr: np.ndarray) -> list[PersonDetection]: ...


@dataclass(frozen=True)
class PoseSettings:
    """Settings of the fisheye 2D stage (angles in radians).

    search_every: frames a whole pass over the search views takes at least while someone is
        being followed; at most ``search_views_per_frame`` detector runs per frame on average, so
        a layout of V views takes max(search_every, ceil(V / search_views_per_frame)) frames per
        pass. With ``search_spread`` the pass is spread over those frames, else it runs in one
        frame at the start of each period. The first frame an estimator sees always gets the
        whole pass (a chunk of an assessment starts with a search). Motion cues are taken every
        ``search_every`` frames (``idle_search_every`` while nobody is followed).
    idle_search_every, idle_search_views_per_frame: the same while nobody is being followed.
    search_spread: spread each pass over its frames (True) or run it at once (False).
    search_centre_rolls: the search view along the lens axis (where the world gives no "up")
        is run this many times, turned about its axis in equal steps.
    search_where_lost: when a followed person's view finds nobody for the last time (after
        coasting), run the detector on the next frame on the search views around that place.
    coast_frames: a person not found in their view is looked for in the same view for this
        many more frames (a brief occlusion) before the view is dropped.
    min_presence: a view whose pose flag is below this holds no person.
    min_keypoint_confidence: keypoints below this confidence do not steer the next view.
    body_margin: the view's half field of view is the body's angular radius times this.
    min_half_fov, max_half_fov: limits of a person view's half field of view.
    search_layout: "lens" (default): the search views are placed and sized from the lens, the
        image circle and the detector's input size (ergopose/pose/search_layout.py): a person
        ``search_person_height`` tall at ``search_max_distance`` (horizontally) spans at least
        ``search_person_px`` detector pixels in a view that holds them, no view finer than
        ``search_max_upsampling`` times the image's own pixel density, half fields of view within
        ``search_min_half_fov`` .. ``search_max_half_fov``, every direction of the image circle up
        to ``search_max_polar`` covered. "fixed": the explicit rings below.
    search_half_fov: half field of view of the fixed layout's search views.
    search_rings: angles from the lens axis of the fixed layout's rings of search views
        (radians); the first ring at 0 is a single view straight along the axis.
    search_views_per_ring: number of search views on each fixed ring after the first.
    min_detector_score: detector score to accept a search cue.
    motion_scale: downscaling of the frame for background subtraction.
    motion_min_area: smallest moving blob, as a fraction of the downscaled frame's area.
    motion_warmup: frames the background model learns before its blobs count.
    same_person_angle: two detections whose hip-centre rays are closer than this fraction of
        their angular radius are one person.
    align_views: roll each person view about its axis towards the body axis (the previous
        pose's alignment points or hip-to-shoulder direction when re-focusing, the detector's
        body axis for a search cue), by at most ``max_body_roll`` from upright; False: every
        view upright (the paper's construction: the image of the world's vertical points up).
        Search views and motion cues are always upright.
    refocus_on_alignment: re-focus on the network's own alignment points when it gives them
        (BlazePose: the hip centre and a point on the circle around the whole body, along the body
        axis; MediaPipe places its next crop with them): the view is aimed at that hip centre, its
        half field of view is the circle's angular radius times ``body_margin``, and (with
        ``align_views``) it is rolled so the body axis points up. False, or a network without
        them: aimed at the mean of the confident hip keypoints, fitted to the confident body
        keypoints, rolled to the hip-to-shoulder direction.
    min_axis_fraction: the hip-to-shoulder angle must be at least this fraction of the body's
        angular radius for its direction to roll the next view (a torso seen end-on from
        above has no reliable direction); otherwise the view is upright.
    max_body_roll: world vertical is the reference for every view's roll: the body axis (from
        the detector or the previous pose) rolls a view at most this far from upright (the
        image of the world's vertical pointing up). 0: every view upright; pi: views follow
        the body axis wherever it points (the stage before issue 19). Chosen by measurement
        (docs/pose-in-fisheye.md, "Upright views and left/right").
    upright_undefined_angle: a view whose axis is closer than this to the world's vertical
        (a person straight below or above the camera) has no defined "up" from the world: the
        body axis rolls it unbounded and its detections are not re-checked.
    recheck_roll: a detection whose body axis (the network's alignment points, or hips to
        shoulders) is rolled further than this from world up in a view that is not upright
        (a view that locked upside down) is run again in an upright view; the upright result
        is kept when it finds the person with a plausible axis, the detection is dropped
        otherwise. A search cue whose detector axis disagrees as much gets an upright view.
        None: never re-checked.
    merge_prefers_upright: of two detections of one person, keep the one whose body axis is
        plausible (within ``recheck_roll`` of world up), then the one whose view is closest to
        upright (in steps of ``merge_roll_step``), then the more confident one. False: the
        more confident one only.
    left_right_check: keep each followed person's left and right consistent from frame to
        frame: a skeleton whose left/right limbs match the previous frame's the other way
        round is swapped back, unless the network has said so in most of the last
        ``left_right_window`` frames (then its labelling is followed); limbs whose own match
        disagrees with the whole body's, and frames where the recent labelling is split, get
        their confidence lowered to at most ``uncertain_confidence``.
    left_right_ratio: the cost of one labelling (sum of the angles between this frame's and
        the previous frame's keypoints of the same label) must be below this fraction of the
        other's for a decision; in between the frame does not vote.
    view_cache_px: 0 (default): every person view's map is built for exactly the view
        requested (about 1 ms). Above 0: maps are cached and a view that differs from the one
        requested by at most this many view pixels anywhere is reused (direction, roll and
        field of view quantised; :class:`ViewCache`). People move, so few requests repeat:
        measured on a simulated session, 5 % of views reused at 0.5 px and 6 % at 2 px, with
        no measurable gain in speed, against about 1 MB of maps per cached view.
    max_people: most people tracked per camera. A frame where the stage reaches it is counted
        (``FisheyePoseEstimator.capped_frames``) and told once per estimator through its progress
        callback, naming the camera and the setting: more people than this are not followed.
    """

    search_every: int = 12
    idle_search_every: int = 4
    search_views_per_frame: float = 1.0
    idle_search_views_per_frame: float = 4.5
    coast_frames: int = 2
    min_presence: float = 0.5
    min_keypoint_confidence: float = 0.3
    body_margin: float = 1.3
    min_half_fov: float = np.radians(8.0)
    max_half_fov: float = np.radians(55.0)
    search_layout: str = "lens"
    # The search-layout rule's defaults are SearchSizing's (one place for them).
    search_person_px: float = SearchSizing.person_px
    search_person_height: float = SearchSizing.person_height
    search_max_distance: float = SearchSizing.max_distance
    search_max_upsampling: float = SearchSizing.max_upsampling
    search_min_half_fov: float = SearchSizing.min_half_fov
    search_max_half_fov: float = SearchSizing.max_half_fov
    search_max_polar: float = SearchSizing.max_polar
    search_spread: bool = True
    search_centre_rolls: int = 1
    search_half_fov: float = np.radians(42.0)
    search_rings: tuple[float, ...] = (0.0, np.radians(45.0), np.radians(75.0))
    search_views_per_ring: int = 8
    min_detector_score: float = 0.5
    motion_scale: int = 4
    motion_min_area: float = 0.0004
    motion_warmup: int = 10
    same_person_angle: float = 0.5
    search_where_lost: bool = True
    align_views: bool = True
    refocus_on_alignment: bool = True
    min_axis_fraction: float = 0.15
    max_body_roll: float = np.radians(45.0)
    upright_undefined_angle: float = np.radians(10.0)
    recheck_roll: float | None = np.radians(110.0)
    merge_prefers_upright: bool = True
    merge_roll_step: float = np.radians(20.0)
    left_right_check: bool = True
    left_right_ratio: float = 0.5
    left_right_window: int = 9
    uncertain_confidence: float | None = None
    view_cache_px: float = 0.0
    max_people: int = 8

    def with_gates(self, gates) -> "PoseSettings":
        """These settings with a landmark model card's confidence gates
        (:class:`ergopose.pose.models.ConfidenceGates`; None: unchanged)."""
        if gates is None:
            return self
        return replace(self, min_presence=float(gates.min_presence),
                       min_keypoint_confidence=float(gates.min_keypoint_confidence))


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
    source: (N,) int, SOURCE_REFOCUS / SOURCE_MOTION / SOURCE_SEARCH (what aimed the view).
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

    @property
    def count(self) -> int:
        return int(self.presence.shape[0])

    def to_recon(self, camera: Camera, time_s: float):
        """The reconstruction stage's record (ergopose.recon.records.Detections2D) of these people."""
        rotation = np.asarray(camera.rotation_world_from_cam, dtype=np.float64)
        return Detections2D(camera=camera.name, frame=self.frame_index, time_s=time_s,
                            pixels_view=self.pixels_view, confidence=self.confidence,
                            projection=self.projection, rays_world=self.rays_cam @ rotation.T)

    @classmethod
    def empty(cls, camera_index: int, frame_index: int) -> "FrameDetections":
        return cls(camera_index, frame_index, np.zeros((0, NUM_JOINTS, 2)), np.zeros((0, NUM_JOINTS, 2)),
                   np.zeros((0, NUM_JOINTS, 3)), np.zeros((0, NUM_JOINTS)), np.zeros(0), np.zeros((0, 3, 4)),
                   np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.int64))


def _lowered(confidence: np.ndarray, joints: np.ndarray, ceiling: float) -> np.ndarray:
    """``confidence`` with the given joints' values lowered to at most ``ceiling`` (a copy)."""
    out = np.array(confidence, dtype=np.float64, copy=True)
    out[joints] = np.minimum(out[joints], ceiling)
    return out


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles (radians) between unit vectors a (..., 3) and b (..., 3), accurate near 0."""
    return 2.0 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


def view_rotation(camera: Camera, direction_cam: np.ndarray, up_cam: np.ndarray | None = None) -> np.ndarray:
    """rotation_cam_from_view (3, 3) of a view looking along ``direction_cam``.

    up_cam None: upright (the image of the world's vertical points up, as
    ``VirtualView.aimed_along``). Otherwise the view is rolled about its axis so that the image
    of ``up_cam`` (its component across the axis) points straight up; when that component
    vanishes (up along the axis) the view stays upright.
    """
    return _rolled(camera, direction_cam, _roll_of(camera, direction_cam, up_cam))


def _upright(camera: Camera, direction_cam: np.ndarray) -> np.ndarray:
    up_world_cam = np.asarray(camera.rotation_world_from_cam, dtype=np.float64).T @ _WORLD_UP
    return upright_rotation(direction_cam, up_world_cam)


def _roll_of(camera: Camera, direction_cam: np.ndarray, up_cam: np.ndarray | None) -> float:
    """Roll (radians, clockwise on screen) that turns the upright view's up onto ``up_cam``."""
    if up_cam is None:
        return 0.0
    u = _upright(camera, direction_cam).T @ np.asarray(up_cam, dtype=np.float64)
    if not (np.all(np.isfinite(u)) and np.hypot(u[0], u[1]) > 1e-12 * max(np.linalg.norm(u), 1e-300)):
        return 0.0
    # Rolling by r turns the view's up (0, -1) into (sin r, -cos r) in the upright view.
    return float(np.arctan2(u[0], -u[1]))


def _world_up_cam(camera: Camera) -> np.ndarray:
    return np.asarray(camera.rotation_world_from_cam, dtype=np.float64).T @ _WORLD_UP


def upright_defined(camera: Camera, direction_cam: np.ndarray, undefined_angle: float) -> bool:
    """True when a view along ``direction_cam`` is further than ``undefined_angle`` from the
    world's vertical (up or down), so that "upright" is well defined in it."""
    d = _unit(np.asarray(direction_cam, dtype=np.float64))
    return bool(np.linalg.norm(np.cross(d, _world_up_cam(camera))) > np.sin(undefined_angle))


def roll_from_upright(camera: Camera, direction_cam: np.ndarray, up_cam: np.ndarray | None) -> float:
    """Roll (radians, clockwise on screen, in (-pi, pi]) of the image of ``up_cam`` from the
    image of world up, in a view along ``direction_cam`` (0 when ``up_cam`` is None or along
    the axis)."""
    return _roll_of(camera, _unit(np.asarray(direction_cam, dtype=np.float64)), up_cam)


def bounded_up(camera: Camera, direction_cam: np.ndarray, up_cam: np.ndarray | None, max_roll: float,
               undefined_angle: float = 0.0) -> np.ndarray | None:
    """The up direction of a view along ``direction_cam`` that follows ``up_cam`` (e.g. the body
    axis) but is rolled at most ``max_roll`` from world upright. None when ``up_cam`` is None;
    ``up_cam`` unchanged when the view is within ``undefined_angle`` of the world's vertical (no
    world up to hold to) or ``max_roll`` >= pi; None (upright) when ``max_roll`` is 0."""
    if up_cam is None:
        return None
    d = _unit(np.asarray(direction_cam, dtype=np.float64))
    if max_roll >= np.pi or not upright_defined(camera, d, undefined_angle):
        return up_cam
    if max_roll <= 0:
        return None
    roll = float(np.clip(_roll_of(camera, d, up_cam), -max_roll, max_roll))
    # _roll_of of this vector is ``roll``: its image in the upright view is (sin r, -cos r).
    return _upright(camera, d) @ np.array([np.sin(roll), -np.cos(roll), 0.0])


def _rolled(camera: Camera, direction_cam: np.ndarray, roll: float) -> np.ndarray:
    c, s = np.cos(roll), np.sin(roll)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return _upright(camera, direction_cam) @ rz


class ViewCache:
    """Lookup maps of one camera's person views (LRU), keyed by quantised field of view,
    direction and roll.

    The steps are chosen so that the view handed out differs from the one requested by at most
    about ``tolerance_px`` view pixels anywhere in the view: each of the three quantisations
    (field of view: scale at the view's border; direction: shift at the view's corner; roll:
    turn at the corner) moves no pixel by more than a third of it. The view handed out is an
    exact view (its map, projection and back-mapping agree); only its aim differs from the
    request. ``tolerance_px`` 0 disables the cache (every call builds a fresh map).
    """

    def __init__(self, camera: Camera, view_size: tuple[int, int], tolerance_px: float = 0.5,
                 capacity: int = 96):
        self.camera = camera
        self.view_size = (int(view_size[0]), int(view_size[1]))
        self.tolerance_px = float(tolerance_px)
        self.capacity = int(capacity)
        self._maps: OrderedDict[tuple[int, int, int, int], tuple[VirtualView, ViewMap]] = OrderedDict()
        self.hits = 0
        self.misses = 0

    def _build(self, direction_cam: np.ndarray, half_fov: float, roll: float) -> tuple[VirtualView, ViewMap]:
        lens = Rectilinear.from_fov(self.view_size[0], self.view_size[1], 2.0 * half_fov)
        view = VirtualView(source=self.camera, lens=lens, width=self.view_size[0], height=self.view_size[1],
                           rotation_cam_from_view=_rolled(self.camera, direction_cam, roll))
        return view, view.build_map()

    def get(self, direction_cam: np.ndarray, half_fov: float,
            up_cam: np.ndarray | None = None) -> tuple[VirtualView, ViewMap]:
        """The view (and its map) looking along ``direction_cam`` with half field of view
        ``half_fov`` (horizontal), rolled so ``up_cam`` points up (None: upright)."""
        d = _unit(np.asarray(direction_cam, dtype=np.float64))
        if self.tolerance_px <= 0:
            self.misses += 1
            return self._build(d, float(half_fov), _roll_of(self.camera, d, up_cam))
        # The requested view's up, kept when the direction is quantised (the upright frame turns
        # fast with the direction near the lens axis, so a roll relative to it would not).
        up_req = -view_rotation(self.camera, d, up_cam)[:, 1]
        third = self.tolerance_px / 3.0
        half_w = 0.5 * self.view_size[0]
        corner_px = np.hypot(half_w, 0.5 * self.view_size[1])
        # Field of view: a relative change e of tan(half_fov) moves a pixel r from the centre by r e.
        log_step = 2.0 * third / corner_px
        i_fov = int(round(np.log(np.tan(half_fov)) / log_step))
        tan_q = float(np.exp(i_fov * log_step))
        # Direction: a turn by a moves a pixel at angle t off the axis by f a / cos^2 t, most at the corner.
        focal = half_w / tan_q
        tan_corner = corner_px / focal
        dir_step = 2.0 * third / (focal * (1.0 + tan_corner ** 2)) / np.sqrt(2.0)  # two axes
        polar = float(np.arccos(np.clip(d[2], -1.0, 1.0)))
        azimuth = float(np.arctan2(d[1], d[0]))
        i_polar = int(round(polar / dir_step))
        polar_q = i_polar * dir_step
        # Azimuth steps grow as 1/sin(polar) so the grid is roughly uniform on the sphere.
        az_step = dir_step / max(np.sin(polar_q), dir_step)
        i_az = int(round(azimuth / az_step))
        az_q = i_az * az_step
        direction_q = np.array([np.sin(polar_q) * np.cos(az_q), np.sin(polar_q) * np.sin(az_q), np.cos(polar_q)])
        roll = _roll_of(self.camera, direction_q, up_req)
        # Roll: a turn by r moves the corner pixels by corner_px * r.
        roll_step = 2.0 * third / corner_px
        i_roll = int(round(roll / roll_step))
        key = (i_fov, i_polar, i_az, i_roll)
        hit = self._maps.get(key)
        if hit is not None:
            self._maps.move_to_end(key)
            self.hits += 1
            return hit
        self.misses += 1
        entry = self._build(direction_q, float(np.arctan(tan_q)), i_roll * roll_step)
        self._maps[key] = entry
        if len(self._maps) > self.capacity:
            self._maps.popitem(last=False)
        return entry


class FisheyePoseEstimator:
    """Finds and follows people in one fisheye camera's frames (see the module docstring).

    camera: the calibrated camera (lens, size, pose).
    landmarker: the 2D pose network run on each person view.
    detector: the person detector run on the search views (None: search by motion only).
    """

    def __init__(self, camera: Camera, camera_index: int, landmarker: Landmarker,
                 detector: Detector | None = None, settings: PoseSettings = PoseSettings(),
                 progress: ProgressCallback | None = None):
        self.camera = camera
        self.progress = progress
        #: Frames where the stage reached ``settings.max_people`` (people found or views to run).
        self.capped_frames = 0
        self.camera_index = int(camera_index)
        self.landmarker = landmarker
        self.detector = detector
        self.settings = settings
        size = tuple(int(s) for s in landmarker.input_size)
        self.views = ViewCache(camera, size, settings.view_cache_px)
        #: Detector and landmark network runs so far (the stage's cost, for benches and reports).
        self.detector_runs = 0
        self.landmark_runs = 0
        self.search_layout: SearchLayout | None = None
        self._search_views: list[tuple[VirtualView, ViewMap]] = []
        self._search_half = np.zeros(0)
        if detector is not None:
            self._make_search_views()
        self._search_next = 0
        self._search_credit = 0.0
        self._background = cv2.createBackgroundSubtractorMOG2(history=300, varThreshold=25, detectShadows=False)
        self._frames_seen = 0
        self._targets: list[Target] = []
        self._lost: list[Target] = []
        self._lr_tracks: list[dict] = []

    # -- search views ------------------------------------------------------------------------
    def _make_search_views(self) -> None:
        """The search views of ``settings.search_layout`` (built once; their maps are reused)."""
        s = self.settings
        size = tuple(int(v) for v in self.detector.input_size)
        if s.search_layout == "lens":
            layout = derive_layout(self.camera, size[0], self.search_sizing(s))
        elif s.search_layout == "fixed":
            layout = fixed_layout(tuple(s.search_rings), s.search_views_per_ring, s.search_half_fov,
                                  self.camera.max_theta_in_image())
        else:
            raise ConfigError(f"must be 'lens' or 'fixed', got {s.search_layout!r}", field="search_layout")
        self.search_layout = layout
        axes, halves = layout.views()
        rolls = [None] * len(axes)
        if s.search_centre_rolls > 1 and layout.rings and layout.rings[0].polar == 0:
            # The view along the lens axis has no world up (people lie in every direction in it):
            # copies turned about the axis, so each person is near upright in one of them.
            k = int(s.search_centre_rolls)
            az = 2 * np.pi * np.arange(k) / k
            axes = np.concatenate([np.repeat(axes[:1], k, axis=0), axes[1:]])
            halves = np.concatenate([np.repeat(halves[:1], k), halves[1:]])
            rolls = [np.array([np.cos(a), np.sin(a), 0.0]) for a in az] + rolls[1:]
        for d, half, up in zip(axes, halves, rolls):
            if up is None:
                view = VirtualView.aimed_along(self.camera, d, hfov=2 * float(half), size=size)
            else:
                lens = Rectilinear.from_fov(size[0], size[1], 2 * float(half))
                view = VirtualView(source=self.camera, lens=lens, width=size[0], height=size[1],
                                   rotation_cam_from_view=view_rotation(self.camera, d, up))
            self._search_views.append((view, view.build_map()))
        self._search_half = halves

    @staticmethod
    def search_sizing(s: PoseSettings) -> SearchSizing:
        """The search-layout rule's inputs from the settings."""
        return SearchSizing(person_height=s.search_person_height, max_distance=s.search_max_distance,
                            person_px=s.search_person_px, max_upsampling=s.search_max_upsampling,
                            min_half_fov=s.search_min_half_fov, max_half_fov=s.search_max_half_fov,
                            max_polar=s.search_max_polar)

    def search_period(self, following: bool) -> int:
        """Frames one pass over the search views takes (``PoseSettings.search_every``)."""
        s = self.settings
        every, budget = (s.search_every, s.search_views_per_frame) if following else \
            (s.idle_search_every, s.idle_search_views_per_frame)
        return max(int(every), int(np.ceil(len(self._search_views) / budget - 1e-9)))

    def _scheduled_search(self, period: int, first: bool) -> list[int]:
        """Indices of the search views to run on this frame: all of them on the first frame;
        with ``search_spread`` the next ones round the layout, about views / period per frame;
        otherwise all of them every ``period`` frames."""
        n = len(self._search_views)
        if n == 0:
            return []
        if first:
            self._search_next, self._search_credit = 0, 0.0
            return list(range(n))
        if not self.settings.search_spread:
            return list(range(n)) if (self._frames_seen - 1) % period == 0 else []
        self._search_credit += n / period
        k = min(int(self._search_credit + 1e-9), n)
        self._search_credit -= k
        picked = [(self._search_next + i) % n for i in range(k)]
        self._search_next = (self._search_next + k) % n
        return picked

    def _views_near(self, directions: Sequence[np.ndarray]) -> list[int]:
        """Indices of the search views whose field holds one of these directions."""
        axes = np.stack([v.rotation_cam_from_view[:, 2] for v, _ in self._search_views])
        dirs = np.stack([_unit(np.asarray(d, dtype=np.float64)) for d in directions])
        inside = _angle_between(axes[:, None], dirs[None]) < self._search_half[:, None]
        return [int(i) for i in np.nonzero(inside.any(axis=1))[0]]

    def _search_cues(self, frame_bgr: np.ndarray, which: Sequence[int] | None = None) -> list[Target]:
        """Detector cues from the search views (which: only these views; None: all)."""
        cues = []
        views = self._search_views if which is None else [self._search_views[i] for i in which]
        for view, view_map in views:
            image = view_map.apply(frame_bgr)
            self.detector_runs += 1
            for det in self.detector(image):
                if det.score < self.settings.min_detector_score:
                    continue
                centre = det.hip_centre[None]
                edge = det.keypoints[1][None]
                rays = view.view_pixels_to_rays_cam(np.vstack([centre, edge]))
                if not np.isfinite(rays).all():
                    continue
                radius = float(_angle_between(rays[0], rays[1]))
                # The detector's second point lies along the body axis from the hips (beyond the head).
                cues.append(Target(rays[0], self._half_fov(radius), SOURCE_SEARCH,
                                   up_cam=self._view_up(rays[0], rays[1])))
        return cues

    def _motion_cues(self, frame_bgr: np.ndarray) -> list[Target]:
        s = self.settings
        small = cv2.resize(frame_bgr, None, fx=1.0 / s.motion_scale, fy=1.0 / s.motion_scale,
                           interpolation=cv2.INTER_AREA)
        mask = self._background.apply(small)
        if self._frames_seen < s.motion_warmup:
            return []
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
        mask = cv2.dilate(mask, np.ones((5, 5), np.uint8))
        count, _, stats, centroids = cv2.connectedComponentsWithStats((mask > 127).astype(np.uint8))
        min_area = s.motion_min_area * mask.shape[0] * mask.shape[1]
        keep = np.nonzero(stats[1:, cv2.CC_STAT_AREA] >= min_area)[0] + 1
        if keep.size == 0:
            return []
        scale = float(s.motion_scale)
        centre_px = (centroids[keep] + 0.5) * scale - 0.5
        x0, y0 = stats[keep, cv2.CC_STAT_LEFT], stats[keep, cv2.CC_STAT_TOP]
        w, h = stats[keep, cv2.CC_STAT_WIDTH], stats[keep, cv2.CC_STAT_HEIGHT]
        corners = np.stack([np.stack([x0, y0], -1), np.stack([x0 + w, y0], -1),
                            np.stack([x0, y0 + h], -1), np.stack([x0 + w, y0 + h], -1)], axis=1) * scale
        centre_rays = self.camera.lens.unproject(centre_px)
        corner_rays = self.camera.lens.unproject(corners)
        radius = np.nanmax(_angle_between(corner_rays, centre_rays[:, None, :]), axis=1)
        ok = np.isfinite(centre_rays).all(axis=1) & np.isfinite(radius)
        return [Target(centre_rays[i], self._half_fov(float(radius[i])), SOURCE_MOTION) for i in np.nonzero(ok)[0]]

    # -- per frame ---------------------------------------------------------------------------
    def _half_fov(self, body_radius: float) -> float:
        s = self.settings
        return float(np.clip(body_radius * s.body_margin, s.min_half_fov, s.max_half_fov))

    def process(self, frame_bgr: np.ndarray, frame_index: int) -> FrameDetections:
        """Find the people in one frame; keeps what it needs to re-focus on the next frame.

        Searches are scheduled by the count of frames this estimator has seen (not by the frame
        index), so a chunk of frames gives the same result wherever it starts.
        """
        s = self.settings
        targets = list(self._targets)
        seen = self._frames_seen
        period = self.search_period(bool(targets))
        # Motion cues at the search interval, however long a pass over the search views takes.
        motion_now = seen % (s.search_every if targets else s.idle_search_every) == 0
        motion = self._motion_cues(frame_bgr)  # the background model learns on every frame
        self._frames_seen += 1
        lost, self._lost = self._lost, []
        which = self._scheduled_search(period, seen == 0)
        if lost and s.search_where_lost and self.detector is not None:
            # A view lost its person: the detector looks again around there at once.
            near = self._views_near([t.direction_cam for t in lost])
            which = which + [i for i in near if i not in which]
        cues = (motion if motion_now else []) + (self._search_cues(frame_bgr, which) if which else [])
        targets += [c for c in cues if not self._covered(c, targets)]
        views = len(targets)
        targets = targets[: 4 * s.max_people]
        results = [self._run_view(frame_bgr, t) for t in targets]
        people = self._merge([r for r in results if r is not None])
        if views > 4 * s.max_people or len(people) >= s.max_people:
            self._capped(frame_index, len(people), views)
        people = people[: s.max_people]
        if s.left_right_check:
            people = self._left_right(people)
        found = [self._refocus(p) for p in people]
        # Views that found nobody this time keep looking for a few frames (brief occlusions),
        # unless a person found elsewhere now covers them.
        coasting = [Target(t.direction_cam, t.half_fov, t.source, t.missed + 1, t.up_cam)
                    for t, r in zip(targets, results)
                    if r is None and t.source == SOURCE_REFOCUS and t.missed < s.coast_frames]
        self._targets = found + [t for t in coasting if not self._covered(t, found)]
        self._lost = [t for t, r in zip(targets, results)
                      if r is None and t.source == SOURCE_REFOCUS and t.missed >= s.coast_frames
                      and not self._covered(t, found)]
        return self._record(people, frame_index)

    def _capped(self, frame_index: int, found: int, views: int) -> None:
        """Count a frame at the ``max_people`` cap (people found, or views to run beyond 4 per
        person); tell it the first time."""
        self.capped_frames += 1
        if self.capped_frames == 1:
            cap = self.settings.max_people
            warn(self.progress, f"camera {self.camera.name} reached max_people = {cap} in frame {frame_index} "
                                f"({found} people found, {views} places to look for {4 * cap} allowed): the 2D "
                                f"stage follows at most {cap} people per camera, more are not followed")

    def _view_up(self, direction_cam: np.ndarray, body_up_cam: np.ndarray | None) -> np.ndarray | None:
        """The up direction of a view along ``direction_cam`` for a body whose axis points
        along ``body_up_cam``: world upright, rolled towards the body axis by at most
        ``max_body_roll``; upright when the body axis disagrees with world up by more than
        ``recheck_roll`` (an axis pointing down is the network's mistake, not the body's)."""
        s = self.settings
        if not s.align_views or body_up_cam is None:
            return None
        if s.recheck_roll is not None and \
                upright_defined(self.camera, direction_cam, s.upright_undefined_angle) and \
                abs(roll_from_upright(self.camera, direction_cam, body_up_cam)) > s.recheck_roll:
            return None
        return bounded_up(self.camera, direction_cam, body_up_cam, s.max_body_roll, s.upright_undefined_angle)

    def _covered(self, cue: Target, targets: Sequence[Target]) -> bool:
        for t in targets:
            if _angle_between(cue.direction_cam, t.direction_cam) < self.settings.same_person_angle * t.half_fov:
                return True
        return False

    def _run_view(self, frame_bgr: np.ndarray, target: Target) -> dict | None:
        """The network on the target's view; a detection whose body axis points away from world
        up (by more than ``recheck_roll``) in a rolled view is checked again in an upright view."""
        s = self.settings
        person = self._landmarks(frame_bgr, target, target.up_cam)
        if person is None or s.recheck_roll is None or target.up_cam is None or \
                abs(person["body_roll"]) <= s.recheck_roll or abs(person["view_roll"]) < 1e-6:
            return person
        again = self._landmarks(frame_bgr, target, None)
        if again is None or abs(again["body_roll"]) > s.recheck_roll:
            return None
        again["rechecked"] = True
        return again

    def _landmarks(self, frame_bgr: np.ndarray, target: Target, up_cam: np.ndarray | None) -> dict | None:
        view, view_map = self.views.get(target.direction_cam, target.half_fov, up_cam)
        image = view_map.apply(frame_bgr)
        kp = self.landmarker(image)
        self.landmark_runs += 1
        if not kp.presence >= self.settings.min_presence:
            return None
        rays_cam = view.view_pixels_to_rays_cam(kp.pixels)
        alignment = getattr(kp, "alignment", None)
        if alignment is not None:
            alignment = view.view_pixels_to_rays_cam(alignment)
        person = {"kp": kp, "view": view, "rays_cam": rays_cam, "source": target.source,
                  "half_fov": target.half_fov, "alignment_rays": alignment, "rechecked": False,
                  "view_roll": roll_from_upright(self.camera, target.direction_cam, up_cam)}
        person["body_roll"] = self._body_roll(person)
        return person

    def _body_roll(self, person: dict) -> float:
        """Roll of a detection's body axis from world up (radians; 0 when unknown or when the
        world's up is undefined there): the alignment points' hip centre to body circle, else
        the confident hips to the confident shoulders."""
        s = self.settings
        aux = person["alignment_rays"]
        if aux is not None and np.isfinite(aux).all():
            centre, up = _unit(aux[0]), _unit(aux[1])
        else:
            rays, conf = person["rays_cam"], person["kp"].confidence
            good = (conf >= s.min_keypoint_confidence) & np.isfinite(rays).all(axis=1)
            hips, shoulders = [_LEFT_HIP, _RIGHT_HIP], [_LEFT_SHOULDER, _RIGHT_SHOULDER]
            if not (good[hips].any() and good[shoulders].any()):
                return 0.0
            centre = _unit(rays[[j for j in hips if good[j]]].mean(axis=0))
            up = _unit(rays[[j for j in shoulders if good[j]]].mean(axis=0))
        if not upright_defined(self.camera, centre, s.upright_undefined_angle):
            return 0.0
        return roll_from_upright(self.camera, centre, up)

    def _body_bearing(self, person: dict) -> tuple[np.ndarray, float, np.ndarray | None] | None:
        """Hip-centre ray, angular radius of the confident body keypoints, and the shoulder-centre
        ray when both the hips and the shoulders are confident (else None)."""
        rays, conf = person["rays_cam"], person["kp"].confidence
        good = (conf >= self.settings.min_keypoint_confidence) & np.isfinite(rays).all(axis=1)
        hips = [j for j in (_LEFT_HIP, _RIGHT_HIP) if good[j]]
        if not hips:
            hips = [j for j in (_LEFT_SHOULDER, _RIGHT_SHOULDER) if good[j]]
        body = _BODY_JOINTS[good[_BODY_JOINTS]]
        if not hips or body.size < 3:
            return None
        centre = _unit(rays[hips].mean(axis=0))
        radius = float(_angle_between(rays[body], centre[None]).max())
        shoulders = [j for j in (_LEFT_SHOULDER, _RIGHT_SHOULDER) if good[j]]
        axis = None
        if len(hips) == 2 and shoulders:
            axis = _unit(rays[shoulders].mean(axis=0))
        return centre, radius, axis

    def _merge(self, people: list[dict]) -> list[dict]:
        """One detection per person: drop a detection whose body centre lies inside a better one
        (better: with ``merge_prefers_upright``, a body axis within ``recheck_roll`` of world up,
        then a view closer to upright; then a higher pose flag times mean body-keypoint confidence)."""
        bearings = [self._body_bearing(p) for p in people]
        # The better detection of one person: the pose flag times the mean confidence of the body
        # keypoints (two views of one person often both have a flag near 1).
        score = [float(p["kp"].presence) * float(np.mean(p["kp"].confidence[_BODY_JOINTS])) for p in people]
        s = self.settings
        if s.merge_prefers_upright:
            # A plausible body axis first, then the view closest to upright, then confidence.
            def rank(i):
                implausible = s.recheck_roll is not None and abs(people[i]["body_roll"]) > s.recheck_roll
                return implausible, round(abs(people[i]["view_roll"]) / s.merge_roll_step), -score[i]
            order = sorted(range(len(people)), key=rank)
        else:
            order = sorted(range(len(people)), key=lambda i: -score[i])
        kept: list[int] = []
        for i in order:
            if bearings[i] is None:
                continue
            ci, ri = bearings[i][:2]
            duplicate = any(
                _angle_between(ci, bearings[j][0]) < self.settings.same_person_angle * max(ri, bearings[j][1])
                for j in kept
            )
            if not duplicate:
                kept.append(i)
        for i in kept:
            people[i]["bearing"] = bearings[i]
        return [people[i] for i in kept]

    def _refocus(self, person: dict) -> Target:
        """The next frame's view of a person: aimed at the hips, fitted to the body, rolled
        from upright towards the body axis by at most ``max_body_roll`` (:meth:`_view_up`)."""
        s = self.settings
        centre, radius, shoulder = person["bearing"]
        aux = person["alignment_rays"]
        if s.refocus_on_alignment and aux is not None and np.isfinite(aux).all():
            centre, extent = _unit(aux[0]), _unit(aux[1])
            radius = float(_angle_between(centre, extent))
            if radius > 0:
                return Target(centre, self._half_fov(radius), SOURCE_REFOCUS,
                              up_cam=self._view_up(centre, extent))
        up = None
        if shoulder is not None and _angle_between(shoulder, centre) >= s.min_axis_fraction * radius:
            up = self._view_up(centre, shoulder)
        return Target(centre, self._half_fov(radius), SOURCE_REFOCUS, up_cam=up)

    # -- left and right ----------------------------------------------------------------------
    def _lr_verdict(self, before: dict, rays: np.ndarray, conf: np.ndarray, pairs: np.ndarray) -> int | None:
        """0: ``rays`` keep the left and right of ``before`` (the previous frame's skeleton of the
        same person), 1: they match it the other way round, None: cannot tell (fewer than two
        confident pairs, or neither labelling clearly closer, e.g. a side view with left and
        right on top of each other)."""
        s = self.settings
        left, right = pairs[:, 0], pairs[:, 1]
        prev_rays, prev_conf = before["rays"], before["conf"]
        good = ((conf >= s.min_keypoint_confidence) & (prev_conf >= s.min_keypoint_confidence)
                & np.isfinite(rays).all(axis=1) & np.isfinite(prev_rays).all(axis=1))
        ok = good[left] & good[right]
        if ok.sum() < 2:
            return None
        l, r = left[ok], right[ok]
        same = float(np.sum(_angle_between(prev_rays[l], rays[l]) + _angle_between(prev_rays[r], rays[r])))
        swap = float(np.sum(_angle_between(prev_rays[l], rays[r]) + _angle_between(prev_rays[r], rays[l])))
        if swap < s.left_right_ratio * same:
            return 1
        if same < s.left_right_ratio * swap:
            return 0
        return None

    def _left_right(self, people: list[dict]) -> list[dict]:
        """Keep each person's left and right consistent with their previous frames (see
        ``PoseSettings.left_right_check``); updates the per-person history."""
        s = self.settings
        tracks, used, kept = self._lr_tracks, set(), []
        window = max(1, int(s.left_right_window))
        for p in people:
            centre, radius, _ = p["bearing"]
            best = None
            for k, t in enumerate(tracks):
                a = float(_angle_between(centre, t["centre"]))
                if k not in used and a < s.same_person_angle * max(radius, t["radius"]) and \
                        (best is None or a < best[0]):
                    best = (a, k)
            votes: list[int | None] = []
            uncertain = False
            since_flip = window
            if best is not None:
                used.add(best[1])
                track = tracks[best[1]]
                since_flip = track["since_flip"] + 1
                verdict = self._lr_verdict(track, p["rays_cam"], p["kp"].confidence, _LR_DECIDE)
                votes = (track["votes"] + [verdict])[-window:]
                against = sum(1 for v in votes if v == 1)
                if against > window // 2:
                    # The network has labelled this person the other way round in most recent
                    # frames: follow it (the votes flip with the track's labelling).
                    votes = [None if v is None else 1 - v for v in votes]
                    since_flip = 0
                elif verdict == 1:
                    self._swap(p)
                # Split recent labelling, or a labelling change less than a window ago: the
                # left and right of this frame are not to be trusted.
                uncertain = against >= 2 or since_flip < window
            conf = p["kp"].confidence.copy()
            rays = p["rays_cam"]
            if best is not None:
                # Limbs whose own left and right disagree with the body's are not trusted.
                for check, joints in _LR_LIMB_PAIRS.values():
                    if self._lr_verdict(tracks[best[1]], rays, conf, check) == 1 and s.uncertain_confidence is not None:
                        p["kp"] = replace(p["kp"], confidence=_lowered(p["kp"].confidence, joints,
                                                                      s.uncertain_confidence))
            if uncertain and s.uncertain_confidence is not None:
                paired = _LR_PAIRS.ravel()
                p["kp"] = replace(p["kp"], confidence=_lowered(p["kp"].confidence, paired, s.uncertain_confidence))
            p["left_right_uncertain"] = uncertain
            kept.append({"centre": centre, "radius": radius, "rays": rays, "conf": conf, "votes": votes,
                         "since_flip": since_flip, "missed": 0})
        for k, t in enumerate(tracks):
            if k not in used and t["missed"] < s.coast_frames:
                kept.append({**t, "missed": t["missed"] + 1})
        self._lr_tracks = kept
        return people

    @staticmethod
    def _swap(person: dict) -> None:
        """Exchange the left and right keypoints of a detection (in place)."""
        kp = person["kp"]
        person["kp"] = replace(
            kp, pixels=kp.pixels[MIRROR], confidence=kp.confidence[MIRROR],
            depth=None if kp.depth is None else kp.depth[MIRROR],
            landmark_presence=None if kp.landmark_presence is None else kp.landmark_presence[MIRROR],
            world_m=None if kp.world_m is None else kp.world_m[MIRROR])
        person["rays_cam"] = person["rays_cam"][MIRROR]
        person["left_right_swapped"] = True

    def _record(self, people: list[dict], frame_index: int) -> FrameDetections:
        if not people:
            return FrameDetections.empty(self.camera_index, frame_index)
        kps = [p["kp"] for p in people]
        pixels_view = np.stack([k.pixels for k in kps])
        rays_cam = np.stack([p["rays_cam"] for p in people])
        confidence = np.stack([np.where(np.isfinite(k.pixels).all(axis=1), k.confidence, 0.0) for k in kps])
        views = [p["view"] for p in people]
        return FrameDetections(
            camera_index=self.camera_index,
            frame_index=int(frame_index),
            pixels_view=pixels_view,
            pixels_fisheye=self.camera.lens.project(rays_cam),
            rays_cam=rays_cam,
            confidence=confidence,
            presence=np.array([k.presence for k in kps], dtype=np.float64),
            projection=np.stack([v.projection_matrix for v in views]),
            view_direction_cam=np.stack([v.rotation_cam_from_view[:, 2] for v in views]),
            view_half_fov=np.array([p["half_fov"] for p in people]),
            source=np.array([p["source"] for p in people], dtype=np.int64),
        )

    def __call__(self, frame_bgr: np.ndarray, frame_index: int) -> FrameDetections:
        """Same as :meth:`process`."""
        return self.process(frame_bgr, frame_index)
