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
   that place. In a session of several cameras, the places where the other cameras found
   people in the previous frame that no view of this camera holds are cues too
   (:meth:`FisheyePoseEstimator.take_cues`, :mod:`ergopose.pose.handoff`). Each cue
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
   the one whose view is closest to upright, then the more confident one. Before that, a new
   cue's small skeleton squeezed onto part of a bigger detection is dropped
   (:mod:`ergopose.pose.fragments`).
4. *Left and right.* Each person's skeleton is compared with their previous frame's: a
   skeleton whose left and right limbs match it the other way round is swapped back; when the
   network keeps the other labelling for most of the last ``left_right_window`` frames it is
   followed. Frames around such a change, and limbs whose own left/right disagrees with the
   body's, are flagged per keypoint (``FrameDetections.left_right_uncertain``); with
   ``uncertain_confidence`` set their confidence is lowered too (``ergopose pose`` does). By
   default it is not: one camera's history cannot tell which
   labelling is right, while the reconstruction can (the other cameras, the worker's previous
   fitted body limb by limb: docs/reconstruction.md, "Left and right"), and a lowered
   torso takes the person out of the association altogether (measured on the real recording,
   docs/evaluation.md).

The target is a direction and an angular radius, both in the camera frame, so nothing here
depends on the world or on the other cameras: what they pass on arrives as directions in this
camera's frame.

This module holds the estimator, which runs these steps per frame; the parts live beside it:
the settings (``pose/settings.py``), the records (``pose/records.py``: targets, a frame's
detections, the networks' protocols), a view's orientation (``pose/view_geometry.py``), the
cache of view maps (``pose/view_cache.py``), the search views and motion cues
(``pose/search.py``, placed by ``pose/search_layout.py``) and the left/right check
(``pose/left_right.py``).
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ergopose.geometry.camera import Camera
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS
from ergopose.pose.fragments import is_fragment
from ergopose.pose.left_right import LeftRightCheck
from ergopose.pose.records import (
    SOURCE_MOTION,
    SOURCE_OTHER_CAMERA,
    SOURCE_REFOCUS,
    SOURCE_SEARCH,
    Detector,
    FrameDetections,
    Landmarker,
    Target,
)
from ergopose.pose.search import MotionCues, SearchViews
from ergopose.pose.search_layout import SearchLayout
from ergopose.pose.settings import PoseSettings
from ergopose.pose.view_cache import ViewCache
from ergopose.pose.view_geometry import (
    angle_between,
    bounded_up,
    roll_from_upright,
    unit,
    upright_defined,
    world_up_cam,
)
from ergopose.progress import ProgressCallback, warn

_LEFT_HIP, _RIGHT_HIP = JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]
_LEFT_SHOULDER, _RIGHT_SHOULDER = JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]
BODY_JOINTS = np.array(
    [
        JOINT_INDEX[n]
        for n in (
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
    ]
)

_BODY_MASK = np.isin(np.arange(NUM_JOINTS), BODY_JOINTS)


class FisheyePoseEstimator:
    """Finds and follows people in one fisheye camera's frames (see the module docstring).

    camera: the calibrated camera (lens, size, pose).
    landmarker: the 2D pose network run on each person view.
    detector: the person detector run on the search views (None: search by motion only).
    """

    def __init__(
        self,
        camera: Camera,
        camera_index: int,
        landmarker: Landmarker,
        detector: Detector | None = None,
        settings: PoseSettings = PoseSettings(),
        progress: ProgressCallback | None = None,
    ):
        self.camera = camera
        self.progress = progress
        #: Frames where the stage reached ``settings.max_people`` (people found or views to run).
        self.capped_frames = 0
        self.camera_index = int(camera_index)
        self.landmarker = landmarker
        self.detector = detector
        self.settings = settings
        self.views = ViewCache(
            camera, (int(landmarker.input_size[0]), int(landmarker.input_size[1])), settings.view_cache_px
        )
        #: Detector and landmark network runs so far (the stage's cost, for benches and reports).
        self.detector_runs = 0
        self.landmark_runs = 0
        #: Views turned from upright run again upright (``left_right_upright_check``), and of
        #: those the ones whose upright skeleton had the sides the other way round (doubted).
        self.upright_checks = 0
        self.upright_disputed = 0
        self.search = SearchViews(camera, None if detector is None else detector.input_size, settings)
        #: The search layout (None without a detector).
        self.search_layout: SearchLayout | None = self.search.layout
        self._motion = MotionCues(camera, settings)
        self._frames_seen = 0
        self._targets: list[Target] = []
        self._lost: list[Target] = []
        self._handed: list[Target] = []
        self._left_right = LeftRightCheck(settings)
        self._up_cam = world_up_cam(camera)

    # -- search and motion cues -------------------------------------------------------------
    def search_period(self, following: bool) -> int:
        """Frames one pass over the search views takes (``PoseSettings.search_every``)."""
        return self.search.period(following)

    def _search_cues(self, frame_bgr: np.ndarray, which: Sequence[int]) -> list[Target]:
        """Detector cues from the search views ``which``."""
        assert self.detector is not None
        self.detector_runs += len(which)
        # The detector's second point lies along the body axis from the hips (beyond the head).
        return [
            Target(
                rays[0],
                self._half_fov(float(angle_between(rays[0], rays[1]))),
                SOURCE_SEARCH,
                up_cam=self._view_up(rays[0], rays[1]),
            )
            for rays in self.search.detections(frame_bgr, self.detector, which)
        ]

    def _motion_cues(self, frame_bgr: np.ndarray) -> list[Target]:
        """Motion cues (the background model learns on every frame)."""
        return [
            Target(ray, self._half_fov(radius), SOURCE_MOTION)
            for ray, radius in self._motion(frame_bgr, self._frames_seen)
        ]

    def take_cues(self, directions_cam: np.ndarray, radii: np.ndarray) -> None:
        """Places where another camera saw people (:mod:`ergopose.pose.handoff`), for the next
        frame: (M, 3) unit directions in this camera's frame and (M,) angular radii of the bodies
        (NaN rows are ignored). The next :meth:`process` looks there with upright views, when
        it :attr:`wants_cues` and no view already holds the place."""
        directions_cam = np.asarray(directions_cam, dtype=np.float64).reshape(-1, 3)
        radii = np.asarray(radii, dtype=np.float64).reshape(-1)
        ok = np.isfinite(directions_cam).all(axis=1) & np.isfinite(radii)
        self._handed = [
            Target(d, self._half_fov(float(r)), SOURCE_OTHER_CAMERA) for d, r in zip(directions_cam[ok], radii[ok])
        ]

    @property
    def wants_cues(self) -> bool:
        """Whether the next :meth:`process` looks at the places other cameras pass on (one frame in
        ``other_camera_every``; never when it is 0)."""
        every = self.settings.other_camera_every
        return every > 0 and self._frames_seen % every == 0

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
        handed, self._handed = (self._handed if self.wants_cues else []), []
        period = self.search_period(bool(targets))
        # Motion cues at the search interval, however long a pass over the search views takes.
        motion_now = seen % (s.search_every if targets else s.idle_search_every) == 0
        motion = self._motion_cues(frame_bgr)  # the background model learns on every frame
        self._frames_seen += 1
        lost, self._lost = self._lost, []
        which = self.search.scheduled(period, seen)
        if lost and s.search_where_lost and self.detector is not None:
            # A view lost its person: the detector looks again around there at once.
            near = self.search.near([t.direction_cam for t in lost])
            which = which + [i for i in near if i not in which]
        cues = (motion if motion_now else []) + (self._search_cues(frame_bgr, which) if which else [])
        targets += [c for c in cues if not self._covered(c, targets)]
        for c in handed:  # one view per place, however many cameras passed it on; the other
            # camera's floor point is rougher than this camera's own cues: a place inside any
            # planned view counts as held
            if not self._covered(c, targets, fraction=1.0):
                targets.append(c)
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
        coasting = [
            Target(t.direction_cam, t.half_fov, t.source, t.missed + 1, t.up_cam)
            for t, r in zip(targets, results)
            if r is None and t.source == SOURCE_REFOCUS and t.missed < s.coast_frames
        ]
        self._targets = found + [t for t in coasting if not self._covered(t, found)]
        self._lost = [
            t
            for t, r in zip(targets, results)
            if r is None and t.source == SOURCE_REFOCUS and t.missed >= s.coast_frames and not self._covered(t, found)
        ]
        return self._record(people, frame_index)

    def _capped(self, frame_index: int, found: int, views: int) -> None:
        """Count a frame at the ``max_people`` cap (people found, or views to run beyond 4 per
        person); tell it the first time."""
        self.capped_frames += 1
        if self.capped_frames == 1:
            cap = self.settings.max_people
            warn(
                self.progress,
                f"camera {self.camera.name} reached max_people = {cap} in frame {frame_index} "
                f"({found} people found, {views} places to look for {4 * cap} allowed): the 2D "
                f"stage follows at most {cap} people per camera, more are not followed",
            )

    def _view_up(self, direction_cam: np.ndarray, body_up_cam: np.ndarray | None) -> np.ndarray | None:
        """The up direction of a view along ``direction_cam`` for a body whose axis points
        along ``body_up_cam``: world upright, rolled towards the body axis by at most
        ``max_body_roll``; upright when the body axis disagrees with world up by more than
        ``recheck_roll`` (an axis pointing down is the network's mistake, not the body's)."""
        s = self.settings
        if not s.align_views or body_up_cam is None:
            return None
        if (
            s.recheck_roll is not None
            and upright_defined(self.camera, direction_cam, s.upright_undefined_angle)
            and abs(roll_from_upright(self.camera, direction_cam, body_up_cam)) > s.recheck_roll
        ):
            return None
        return bounded_up(self.camera, direction_cam, body_up_cam, s.max_body_roll, s.upright_undefined_angle)

    def _covered(self, cue: Target, targets: Sequence[Target], fraction: float | None = None) -> bool:
        """A target's view already looks at the cue's place: the cue lies within ``fraction``
        (default ``same_person_angle``) of a target's half field of view from its axis."""
        f = self.settings.same_person_angle if fraction is None else fraction
        return any(angle_between(cue.direction_cam, t.direction_cam) < f * t.half_fov for t in targets)

    def _run_view(self, frame_bgr: np.ndarray, target: Target) -> dict[str, Any] | None:
        """The network on the target's view; a detection whose body axis points away from world
        up (by more than ``recheck_roll``) in a rolled view is checked again in an upright view."""
        s = self.settings
        person = self._landmarks(frame_bgr, target, target.up_cam)
        if (
            person is None
            or s.recheck_roll is None
            or target.up_cam is None
            or abs(person["body_roll"]) <= s.recheck_roll
            or abs(person["view_roll"]) < 1e-6
        ):
            return person
        again: dict[str, Any] | None
        if "upright_view_person" in person:  # the upright check already ran the upright view
            again = person["upright_view_person"]
        else:
            again = self._landmarks(frame_bgr, target, None)
        if again is None or abs(again["body_roll"]) > s.recheck_roll:
            return None
        again["rechecked"] = True
        return again

    def _landmarks(self, frame_bgr: np.ndarray, target: Target, up_cam: np.ndarray | None) -> dict[str, Any] | None:
        view, view_map = self.views.get(target.direction_cam, target.half_fov, up_cam)
        image = view_map.apply(frame_bgr)
        kp = self.landmarker(image)
        self.landmark_runs += 1
        s = self.settings
        if not kp.presence >= (s.follow_presence if target.source == SOURCE_REFOCUS else s.min_presence):
            return None
        rays_cam = view.view_pixels_to_rays_cam(kp.pixels)
        alignment = getattr(kp, "alignment", None)
        if alignment is not None:
            alignment = view.view_pixels_to_rays_cam(alignment)
        view_roll = roll_from_upright(self.camera, target.direction_cam, up_cam)
        person: dict[str, Any] = {
            "kp": kp,
            "view": view,
            # The world's up in the view, for the feet check (only when it runs).
            "up_view": view.rotation_cam_from_view.T @ self._up_cam if self.settings.left_right_feet else None,
            "rays_cam": rays_cam,
            "source": target.source,
            "half_fov": target.half_fov,
            "alignment_rays": alignment,
            "rechecked": False,
            "view_roll": view_roll,
        }
        person["body_roll"] = self._body_roll(person)
        if (
            s.left_right_upright_check is not None
            and s.left_right_check
            and up_cam is not None
            and abs(view_roll) > s.left_right_upright_check
        ):
            return self._upright_check(frame_bgr, target, person)
        return person

    def _upright_check(self, frame_bgr: np.ndarray, target: Target, person: dict[str, Any]) -> dict[str, Any]:
        """``person`` (found in a view turned from upright), its sides doubted when the network on the
        upright view gives the person's left and right the other way round
        (``PoseSettings.left_right_upright_check``)."""
        self.upright_checks += 1
        upright = self._landmarks(frame_bgr, target, None)
        # Kept for the body-axis re-check (_run_view), which would run the same upright view.
        person["upright_view_person"] = upright
        if upright is None:
            return person
        if self._left_right.labelled_the_other_way(
            person["rays_cam"], person["kp"].confidence, upright["rays_cam"], upright["kp"].confidence
        ):
            # The two views label the person's sides the other way round: which one is right
            # cannot be told from here, so this frame's sides are doubted.
            self.upright_disputed += 1
            person["views_disagree"] = True
        return person

    def _body_roll(self, person: dict[str, Any]) -> float:
        """Roll of a detection's body axis from world up (radians; 0 when unknown or when the
        world's up is undefined there): the alignment points' hip centre to body circle, else
        the confident hips to the confident shoulders."""
        s = self.settings
        aux = person["alignment_rays"]
        if aux is not None and np.isfinite(aux).all():
            centre, up = unit(aux[0]), unit(aux[1])
        else:
            rays, conf = person["rays_cam"], person["kp"].confidence
            good = (conf >= s.min_keypoint_confidence) & np.isfinite(rays).all(axis=1)
            hips, shoulders = [_LEFT_HIP, _RIGHT_HIP], [_LEFT_SHOULDER, _RIGHT_SHOULDER]
            if not (good[hips].any() and good[shoulders].any()):
                return 0.0
            centre = unit(rays[[j for j in hips if good[j]]].mean(axis=0))
            up = unit(rays[[j for j in shoulders if good[j]]].mean(axis=0))
        if not upright_defined(self.camera, centre, s.upright_undefined_angle):
            return 0.0
        return roll_from_upright(self.camera, centre, up)

    def _body_bearing(self, person: dict[str, Any]) -> tuple[np.ndarray, float, np.ndarray | None] | None:
        """Hip-centre ray, angular radius of the confident body keypoints, and the shoulder-centre
        ray when both the hips and the shoulders are confident (else None)."""
        rays, conf = person["rays_cam"], person["kp"].confidence
        good = (conf >= self.settings.min_keypoint_confidence) & np.isfinite(rays).all(axis=1)
        hips = [j for j in (_LEFT_HIP, _RIGHT_HIP) if good[j]]
        if not hips:
            hips = [j for j in (_LEFT_SHOULDER, _RIGHT_SHOULDER) if good[j]]
        body = BODY_JOINTS[good[BODY_JOINTS]]
        if not hips or body.size < 3:
            return None
        centre = unit(rays[hips].mean(axis=0))
        radius = float(angle_between(rays[body], centre[None]).max())
        shoulders = [j for j in (_LEFT_SHOULDER, _RIGHT_SHOULDER) if good[j]]
        axis = None
        if len(hips) == 2 and shoulders:
            axis = unit(rays[shoulders].mean(axis=0))
        return centre, radius, axis

    def _merge(self, people: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """One detection per person: drop a detection whose body centre lies inside a better one
        (better: with ``merge_prefers_upright``, a body axis within ``recheck_roll`` of world up,
        then a view closer to upright; then a higher pose flag times mean body-keypoint confidence)."""
        bearings = [self._body_bearing(p) for p in people]
        # The better detection of one person: the pose flag times the mean confidence of the body
        # keypoints (two views of one person often both have a flag near 1).
        score = [float(p["kp"].presence) * float(np.mean(p["kp"].confidence[BODY_JOINTS])) for p in people]
        s = self.settings
        if s.merge_prefers_upright:
            # A plausible body axis first, then the view closest to upright, then confidence.
            def rank(i: int) -> tuple[bool, int, float]:
                implausible = s.recheck_roll is not None and abs(people[i]["body_roll"]) > s.recheck_roll
                return implausible, round(abs(people[i]["view_roll"]) / s.merge_roll_step), -score[i]

            order = sorted(range(len(people)), key=rank)
        else:
            order = sorted(range(len(people)), key=lambda i: -score[i])
        fragment = self._fragments(people, bearings)
        kept: list[int] = []
        found: dict[int, tuple[np.ndarray, float]] = {}
        for i in order:
            bearing = bearings[i]
            if bearing is None or fragment[i]:
                continue
            ci, ri = bearing[:2]
            duplicate = any(
                angle_between(ci, found[j][0]) < self.settings.same_person_angle * max(ri, found[j][1]) for j in kept
            )
            if not duplicate:
                kept.append(i)
                found[i] = (ci, ri)
        for i in kept:
            people[i]["bearing"] = bearings[i]
        return [people[i] for i in kept]

    def _fragments(
        self, people: list[dict[str, Any]], bearings: list[tuple[np.ndarray, float, np.ndarray | None] | None]
    ) -> list[bool]:
        """Which detections are small skeletons squeezed onto part of a bigger detection with a
        plausible body axis (:mod:`ergopose.pose.fragments`). Only detections from new cues (search
        views, motion) are tested: a person already followed is never dropped as a fragment. On a
        simulated four-worker session, followed people of normal size were otherwise dropped as
        "fragments" of an oversized skeleton spanning two workers (docs/pose-command.md)."""
        s = self.settings
        out = [False] * len(people)
        if len(people) < 2 or s.fragment_ratio <= 0:
            return out
        good = [
            (p["kp"].confidence >= s.min_keypoint_confidence) & np.isfinite(p["rays_cam"]).all(axis=1) for p in people
        ]
        for j, small in enumerate(bearings):
            if people[j]["source"] == SOURCE_REFOCUS:
                continue  # a followed person is never dropped as a fragment (only new cues are)
            for i, big in enumerate(bearings):
                if i == j or small is None or big is None:
                    continue
                if s.recheck_roll is not None and abs(people[i]["body_roll"]) > s.recheck_roll:
                    continue  # an upside-down skeleton is no reference for another
                if is_fragment(
                    people[j]["rays_cam"],
                    good[j] & _BODY_MASK,
                    small[1],
                    people[i]["rays_cam"],
                    good[i],
                    big[1],
                    s.fragment_ratio,
                    s.fragment_distance,
                ):
                    out[j] = True
                    break
        return out

    def _refocus(self, person: dict[str, Any]) -> Target:
        """The next frame's view of a person: aimed at the hips, fitted to the body, rolled
        from upright towards the body axis by at most ``max_body_roll`` (:meth:`_view_up`)."""
        s = self.settings
        centre, radius, shoulder = person["bearing"]
        aux = person["alignment_rays"]
        if s.refocus_on_alignment and aux is not None and np.isfinite(aux).all():
            centre, extent = unit(aux[0]), unit(aux[1])
            radius = float(angle_between(centre, extent))
            if radius > 0:
                return Target(centre, self._half_fov(radius), SOURCE_REFOCUS, up_cam=self._view_up(centre, extent))
        up = None
        if shoulder is not None and angle_between(shoulder, centre) >= s.min_axis_fraction * radius:
            up = self._view_up(centre, shoulder)
        return Target(centre, self._half_fov(radius), SOURCE_REFOCUS, up_cam=up)

    def _record(self, people: list[dict[str, Any]], frame_index: int) -> FrameDetections:
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
            left_right_uncertain=(
                np.stack([p["left_right_uncertain"] for p in people]) if self.settings.left_right_check else None
            ),
        )

    def __call__(self, frame_bgr: np.ndarray, frame_index: int) -> FrameDetections:
        """Same as :meth:`process`."""
        return self.process(frame_bgr, frame_index)
