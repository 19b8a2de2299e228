"""Left and right of each followed person, kept consistent from frame to frame in one camera.

Each person's skeleton is compared with their previous frame's: a skeleton whose left and right
limbs match it the other way round is swapped back; when the network keeps the other labelling
for most of the last ``left_right_window`` frames it is followed (with ``left_right_memory``, only
when the network has also given it in more of the remembered frames than the labelling in use).
The keypoints of frames around such a change, and of limbs whose own left/right disagrees with
the body's, are flagged (``left_right_uncertain``, per keypoint); with ``uncertain_confidence``
set their confidence is lowered too (``PoseSettings.left_right_check``).
With ``left_right_feet``, each skeleton is first checked against its own feet (:func:`feet_verdict`):
one camera frame can tell a mirrored labelling where the person's history cannot.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ergopose.keypoints import JOINT_INDEX, MIRROR
from ergopose.pose.settings import PoseSettings
from ergopose.pose.view_geometry import angle_between

#: Every left/right pair of the 33 keypoints (swapping a skeleton exchanges all of them).
_LR_PAIRS = np.array(
    [(JOINT_INDEX[n], JOINT_INDEX[n.replace("left", "right")]) for n in JOINT_INDEX if "left" in n], dtype=np.int64
)
#: The pairs that decide a skeleton's left and right, and the two limb groups checked on their own.
_LR_DECIDE = np.array(
    [
        (JOINT_INDEX["left_" + n], JOINT_INDEX["right_" + n])
        for n in ("shoulder", "hip", "elbow", "wrist", "knee", "ankle")
    ],
    dtype=np.int64,
)
_LR_LIMBS = {
    "arms": (("elbow", "wrist"), ("elbow", "wrist", "pinky", "index", "thumb")),
    "legs": (("knee", "ankle"), ("knee", "ankle", "heel", "foot_index")),
}
_LR_LIMB_PAIRS = {
    k: (
        np.array([(JOINT_INDEX["left_" + n], JOINT_INDEX["right_" + n]) for n in check]),
        np.array([JOINT_INDEX[side + n] for n in joints for side in ("left_", "right_")]),
    )
    for k, (check, joints) in _LR_LIMBS.items()
}


#: The points of the feet cue: the body's left-to-right axis (hips and shoulders) and each foot's
#: heel-to-toe direction.
_FEET_BODY = np.array([JOINT_INDEX[n] for n in ("left_hip", "left_shoulder", "right_hip", "right_shoulder")])
_FEET_FEET = np.array([JOINT_INDEX[n] for n in ("left_heel", "left_foot_index", "right_heel", "right_foot_index")])


def feet_verdict(
    pixels_view: np.ndarray, confidence: np.ndarray, up_view: np.ndarray | None, settings: PoseSettings
) -> int | None:
    """What a skeleton's feet say of its left and right in a view that looks down (or up) at the
    person: 0 the labelling agrees with them, 1 it is mirrored, None cannot tell.

    A standing person's left-to-right axis L and their toes' direction F (heel to toe) are both
    horizontal, and L x F points down, whichever way the person faces. Seen from above, the image
    of L therefore turns towards the image of F clockwise on screen (image y down: the 2D cross
    product L_x F_y - L_y F_x is positive); seen from below, counter-clockwise. A skeleton whose left
    and right are exchanged flips L and not F. The cue is used only when the view looks down or
    up by at least ``left_right_feet_pitch`` (a level view sees L x F edge-on), every point it
    needs is confident, and the turn is clear and the same in both feet (|sin| of the angle
    between the images of L and of each foot at least ``left_right_feet_sin``: a foot seen end-on
    gives none; a lifted foot pointing down turns the way the person faces, and counts only when
    the other foot agrees).

    pixels_view: (33, 2) keypoints in the view's pixels; confidence: (33,); up_view: (3,) the
    world's up direction in the view's frame (x right, y down, z forward), None: unknown.
    """
    s = settings
    if up_view is None or not s.left_right_feet:
        return None
    look = float(up_view[2])  # > 0: the view looks up at the person, < 0: down
    if abs(look) < np.sin(s.left_right_feet_pitch):
        return None
    needed = np.concatenate([_FEET_BODY, _FEET_FEET])
    px = np.asarray(pixels_view, dtype=np.float64)
    if not (np.isfinite(px[needed]).all() and np.all(np.asarray(confidence)[needed] >= s.min_keypoint_confidence)):
        return None
    b = px[_FEET_BODY]
    axis = (b[0] + b[1]) - (b[2] + b[3])  # right to left
    f = px[_FEET_FEET]
    feet = np.stack([f[1] - f[0], f[3] - f[2]])  # heel to toe, left and right foot
    cross = axis[0] * feet[:, 1] - axis[1] * feet[:, 0]
    norms = np.linalg.norm(axis) * np.linalg.norm(feet, axis=1)
    if not np.all(norms > 0):
        return None
    sin = cross / norms
    if not (np.all(np.abs(sin) >= s.left_right_feet_sin) and np.sign(sin[0]) == np.sign(sin[1])):
        return None
    expected = 1.0 if look < 0 else -1.0
    return 0 if np.sign(sin[0]) == expected else 1


def _lowered(confidence: np.ndarray, joints: np.ndarray, ceiling: float) -> np.ndarray:
    """``confidence`` with the given joints' values lowered to at most ``ceiling`` (a copy)."""
    out = np.array(confidence, dtype=np.float64, copy=True)
    out[joints] = np.minimum(out[joints], ceiling)
    return out


def swap_left_right(person: dict[str, Any]) -> None:
    """Exchange the left and right keypoints of a detection (in place; the estimator's per-view
    detection dict with "kp" and "rays_cam")."""
    kp = person["kp"]
    person["kp"] = replace(
        kp,
        pixels=kp.pixels[MIRROR],
        confidence=kp.confidence[MIRROR],
        depth=None if kp.depth is None else kp.depth[MIRROR],
        landmark_presence=None if kp.landmark_presence is None else kp.landmark_presence[MIRROR],
        world_m=None if kp.world_m is None else kp.world_m[MIRROR],
    )
    person["rays_cam"] = person["rays_cam"][MIRROR]
    person["left_right_swapped"] = True


def _support(before: tuple[float, float], verdict: int | None, memory: float | None) -> tuple[float, float]:
    """Frames in which the network gave a person's current labelling and the other one, each
    frame's weight halving every ``memory`` frames (None: not kept)."""
    if memory is None:
        return before
    fade = 0.5 ** (1.0 / memory) if memory > 0 else 0.0
    keep, other = before[0] * fade, before[1] * fade
    if verdict == 0:
        keep += 1.0
    elif verdict == 1:
        other += 1.0
    return keep, other


#: A frame whose left and right cannot be told from the skeleton before it (``verdict`` None)
#: does not become the skeleton the next frame is compared with, for this many frames in a row:
#: the network could flip its labelling inside such a frame unseen. Measured (docs/pose-in-fisheye.md,
#: "A frame that cannot be told"): 1, 3 and 9 frames all put the real recording's case right;
#: 1 crossed the fewest of the simulator's frames.
UNCLEAR_HOLD_FRAMES = 1


class LeftRightCheck:
    """The left/right check of one camera's followed people; keeps their recent history.

    ``tracks``: one entry per person seen recently (hip-centre ray, angular radius, last rays
    and confidences, recent votes, frames since the labelling was last followed, frames missed).
    """

    def __init__(self, settings: PoseSettings):
        self.settings = settings
        self.tracks: list[dict[str, Any]] = []

    def verdict(self, before: dict[str, Any], rays: np.ndarray, conf: np.ndarray, pairs: np.ndarray) -> int | None:
        """0: ``rays`` keep the left and right of ``before`` (the previous frame's skeleton of the
        same person), 1: they match it the other way round, None: cannot tell (fewer than two
        confident pairs, or neither labelling clearly closer, e.g. a side view with left and
        right on top of each other)."""
        s = self.settings
        left, right = pairs[:, 0], pairs[:, 1]
        prev_rays, prev_conf = before["rays"], before["conf"]
        good = (
            (conf >= s.min_keypoint_confidence)
            & (prev_conf >= s.min_keypoint_confidence)
            & np.isfinite(rays).all(axis=1)
            & np.isfinite(prev_rays).all(axis=1)
        )
        ok = good[left] & good[right]
        if ok.sum() < 2:
            return None
        l, r = left[ok], right[ok]
        same = float(np.sum(angle_between(prev_rays[l], rays[l]) + angle_between(prev_rays[r], rays[r])))
        swap = float(np.sum(angle_between(prev_rays[l], rays[r]) + angle_between(prev_rays[r], rays[l])))
        if swap < s.left_right_ratio * same:
            return 1
        if same < s.left_right_ratio * swap:
            return 0
        return None

    def labelled_the_other_way(
        self, rays_a: np.ndarray, conf_a: np.ndarray, rays_b: np.ndarray, conf_b: np.ndarray
    ) -> bool:
        """Whether two skeletons of one person in one frame (two views of it; rays (33, 3) in one
        camera frame, confidences (33,)) label the person's left and right the other way round,
        by the comparison :meth:`verdict` makes between frames."""
        return self.verdict({"rays": rays_a, "conf": conf_a}, rays_b, conf_b, _LR_DECIDE) == 1

    def __call__(self, people: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """Keep each person's left and right consistent with their previous frames (see
        ``PoseSettings.left_right_check``); updates the per-person history. ``people``: the
        estimator's merged detections of one frame, each with its "bearing"."""
        s = self.settings
        tracks, used, kept = self.tracks, set(), []
        window = max(1, int(s.left_right_window))
        for p in people:
            feet = feet_verdict(p["kp"].pixels, p["kp"].confidence, p.get("up_view"), s)
            # A turned and an upright view of this frame labelled the sides the other way round
            # (left_right_upright_check): the network's labelling here is no vote.
            disputed = bool(p.get("views_disagree", False))
            if feet == 1:
                # The feet say the network's left and right are mirrored: put them right.
                swap_left_right(p)
            centre, radius, _ = p["bearing"]
            best = None
            for k, t in enumerate(tracks):
                a = float(angle_between(centre, t["centre"]))
                if (
                    k not in used
                    and a < s.same_person_angle * max(radius, t["radius"])
                    and (best is None or a < best[0])
                ):
                    best = (a, k)
            votes: list[int | None] = []
            verdict: int | None = None
            uncertain = False
            since_flip = window
            support = (0.0, 0.0)
            track = None if best is None else tracks[best[1]]
            if best is not None:
                used.add(best[1])
            if track is not None and feet is not None:
                # The feet decided this frame's left and right: the person's history (which may
                # have followed the network's mirrored labelling) starts again from here, and a
                # memory's support is counted for the labelling the feet chose.
                support = track["support"]
                if self.verdict(track, p["rays_cam"], p["kp"].confidence, _LR_DECIDE) == 1:
                    support = (support[1], support[0])
                support = _support(support, 0, s.left_right_memory)
            elif track is not None:
                since_flip = track["since_flip"] + 1
                verdict = self.verdict(track, p["rays_cam"], p["kp"].confidence, _LR_DECIDE)
                vote = None if disputed else verdict
                votes = (track["votes"] + [vote])[-window:]
                against = sum(1 for v in votes if v == 1)
                support = _support(track["support"], vote, s.left_right_memory)
                if against > window // 2 and (s.left_right_memory is None or support[1] > support[0]):
                    # The network has labelled this person the other way round in most recent
                    # frames (and, with a memory, in more of the remembered frames than the way
                    # the person is labelled now): follow it (the votes flip with the labelling).
                    votes = [None if v is None else 1 - v for v in votes]
                    support = (support[1], support[0])
                    since_flip = 0
                elif verdict == 1:
                    swap_left_right(p)
                # Split recent labelling, or a labelling change less than a window ago: the
                # left and right of this frame are not to be trusted.
                uncertain = against >= 2 or since_flip < window
            conf = p["kp"].confidence.copy()
            rays = p["rays_cam"]
            doubted = np.zeros(len(conf), dtype=bool)
            if track is not None and feet is None:
                # Limbs whose own left and right disagree with the body's are not trusted.
                for check, joints in _LR_LIMB_PAIRS.values():
                    if self.verdict(track, rays, conf, check) == 1:
                        doubted[joints] = True
            if uncertain or (disputed and feet is None):
                doubted[_LR_PAIRS.ravel()] = True
            if s.uncertain_confidence is not None and doubted.any():
                p["kp"] = replace(
                    p["kp"], confidence=_lowered(p["kp"].confidence, np.flatnonzero(doubted), s.uncertain_confidence)
                )
            p["left_right_uncertain"] = doubted
            # The skeleton the next frame is compared with. A frame whose labelling could not be
            # told from its predecessor's (verdict None: a side view, left and right close
            # together) does not replace it (UNCLEAR_HOLD_FRAMES): otherwise the network could flip
            # its labelling inside such a frame unseen, and the check would then hold the flipped
            # labelling against every clear frame that follows (issue 19: the real recording
            # re-rendered, 43 frames crossed after one).
            unverified = 0
            if track is not None and feet is None and verdict is None and track["unverified"] < UNCLEAR_HOLD_FRAMES:
                rays, conf, unverified = track["rays"], track["conf"], track["unverified"] + 1
            kept.append(
                {
                    "centre": centre,
                    "radius": radius,
                    "rays": rays,
                    "conf": conf,
                    "votes": votes,
                    "since_flip": since_flip,
                    "support": support,
                    "unverified": unverified,
                    "missed": 0,
                }
            )
        for k, t in enumerate(tracks):
            if k not in used and t["missed"] < s.coast_frames:
                kept.append({**t, "missed": t["missed"] + 1})
        self.tracks = kept
        return people
