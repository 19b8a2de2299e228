"""Settings of the fisheye 2D stage (:class:`PoseSettings`; the user's ``[pose]`` table is
ergopose/settings/pose.py, which builds this record)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ergopose.pose.models import ConfidenceGates
from ergopose.pose.search_layout import SearchSizing


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
    min_follow_presence: the same for a view re-focused on a person followed from the previous
        frame (or coasting after them): a person once found is kept while the flag stays at or
        above this lower gate; a new person (search view, motion cue) needs ``min_presence``.
        None (default): ``min_presence`` for every view. Measured and not made the default
        (docs/pose-in-fisheye.md, "A lower gate for people already followed"): at 0.2 the
        simulated demo's two workers were found by both cameras in 88.3 % of frames instead of
        82.3 %, but on 10-minute four-worker sessions 37-62 % of the detections it adds lie
        away from every worker, fewer worker-frames are followed and the rows placed near
        nobody rise by 13-46 %.
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
    fragment_ratio, fragment_distance: a detection whose body radius is at most
        ``fragment_ratio`` of another's, with its confident body keypoints a median at most
        ``fragment_distance`` of that one's body radius from its bones, is a small skeleton
        squeezed onto part of that person and is dropped (:mod:`ergopose.pose.fragments`); 0:
        never.
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
        their confidence lowered to at most ``uncertain_confidence``. "The previous frame" is
        the last one whose labelling could be told, when the frame just before could not
        (:data:`ergopose.pose.left_right.UNCLEAR_HOLD_FRAMES`).
    left_right_memory: how long (frames; the weight of a frame halves every this many) the check
        remembers which labelling the network gave a followed person: the network's other
        labelling is followed only when it has more remembered support than the one in use (and
        most of the last ``left_right_window`` frames), so a long run of mislabelled frames after
        a longer run of right ones is corrected instead of followed. None: the window alone
        decides (the stage before 2026-11-27). 120 frames is 2 s at the Pose2Sim recording's 60
        fps and 10 s at the rig's 12 fps; measured in docs/pose-in-fisheye.md ("Left and right
        with a memory").
    left_right_feet: before the frame-to-frame check, check each skeleton's left and right
        against its feet (:func:`ergopose.pose.left_right.feet_verdict`): in a view that looks
        down at a standing person, the image of their left-to-right axis turns clockwise towards
        their toes whichever way they face; a skeleton that turns the other way is mirrored and is
        swapped. Needs confident hips, shoulders, heels and toes. Off by default (measured in
        docs/pose-in-fisheye.md, "Left and right from the feet": on the real recording's
        re-rendered cameras it cuts the crossed frames three times over but makes one clean camera
        cross 4.9 % of its frames, and on the simulator's toeless mannequin feet it swaps most).
    left_right_upright_check: a person view turned more than this (radians) from upright is run
        again upright, and when the two views give the person's left and right the other way
        round, the frame's left/right keypoints are doubted (``left_right_uncertain``, lowered
        with ``uncertain_confidence``) and the frame is no vote in the left/right check: the
        network reads sides from the crop's roll and framing more than from the person (issue
        19). The keypoints stay the turned view's. Costs a second network run per such view.
        None (the default, as ``assess`` runs the stage): never; ``ergopose pose`` uses 10
        degrees (:func:`ergopose.commands.pose.stage_settings`). Measured in
        docs/pose-in-fisheye.md, "A second, upright view".
    left_right_feet_pitch: the view must look down (or up) by at least this (radians) for the
        feet to vote.
    left_right_feet_sin: both feet must turn clearly: |sin| of the angle between the images of
        the body's left-to-right axis and of each heel-to-toe direction at least this.
    left_right_ratio: the cost of one labelling (sum of the angles between this frame's and
        the previous frame's keypoints of the same label) must be below this fraction of the
        other's for a decision; in between the frame does not vote.
    uncertain_confidence: None (the default, as ``assess`` runs the stage): a skeleton whose
        sides the check doubts is flagged (``FrameDetections.left_right_uncertain``) and keeps its
        confidences, since the reconstruction settles sides across cameras and a lowered torso
        falls under its association gate. A number: the confidence of the doubted keypoints is
        lowered to at most this; ``ergopose pose`` (one camera, nothing downstream) uses the model
        card's ``min_keypoint_confidence`` (:func:`ergopose.commands.pose.stage_settings`).
    view_cache_px: 0 (default): every person view's map is built for exactly the view
        requested (about 1 ms). Above 0: maps are cached and a view that differs from the one
        requested by at most this many view pixels anywhere is reused (direction, roll and
        field of view quantised; :class:`~ergopose.pose.view_cache.ViewCache`). People move, so few requests repeat:
        measured on a simulated session, 5 % of views reused at 0.5 px and 6 % at 2 px, with
        no measurable gain in speed, against about 1 MB of maps per cached view.
    other_camera_every: a person another camera of the session found and no view of this
        camera holds is looked for where they should appear (:mod:`ergopose.pose.handoff`), in
        one of every this many frames; 0: never (each camera searches alone).
    max_people: most people tracked per camera. A frame where the stage reaches it is counted
        (``FisheyePoseEstimator.capped_frames``) and told once per estimator through its progress
        callback, naming the camera and the setting: more people than this are not followed.
    """

    search_every: int = 12
    idle_search_every: int = 4
    search_views_per_frame: float = 0.5
    idle_search_views_per_frame: float = 4.5
    coast_frames: int = 2
    min_presence: float = 0.5
    min_follow_presence: float | None = None
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
    fragment_ratio: float = 0.7
    fragment_distance: float = 0.2
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
    left_right_memory: float | None = None
    left_right_feet: bool = False
    left_right_upright_check: float | None = None
    left_right_feet_pitch: float = np.radians(10.0)
    left_right_feet_sin: float = 0.5
    uncertain_confidence: float | None = None
    view_cache_px: float = 0.0
    max_people: int = 8
    other_camera_every: int = 2

    def with_gates(self, gates: ConfidenceGates | None) -> "PoseSettings":
        """These settings with a landmark model card's confidence gates
        (:class:`ergopose.pose.models.ConfidenceGates`; None: unchanged)."""
        if gates is None:
            return self
        return replace(
            self, min_presence=float(gates.min_presence), min_keypoint_confidence=float(gates.min_keypoint_confidence)
        )

    @property
    def follow_presence(self) -> float:
        """The pose-flag gate of a view that follows a person (``min_follow_presence``, at most
        ``min_presence``; ``min_presence`` when None)."""
        if self.min_follow_presence is None:
            return self.min_presence
        return min(self.min_follow_presence, self.min_presence)
