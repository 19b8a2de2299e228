"""Marker names of other keypoint sets and motion-capture exports, mapped onto BlazePose-33 joints.

A reference marker counts as the counterpart of one of our joints when it names the same anatomical
point in that set's own definition. The definitions are not the same keypoints (this is measured,
not hidden: :func:`ergopose.evaluation.reference.evaluate_reference` reports each matched joint's
mean offset after alignment and the segment lengths of both sides):

- OpenPose BODY_25 / BODY_25B, COCO and HALPE hips are the hip points as their annotators placed
  them; BlazePose's hips follow its own annotation. Measured on the Pose2Sim recording (our
  assessment of each camera pair against Pose2Sim's BODY_25B triangulation, docs/evaluation.md):
  our hips lie 10-68 mm lower (11 of the 12 hip-and-pair figures; one is 19 mm higher), the hip
  width is 0.83-0.97 and the left thigh 0.88-0.93 of Pose2Sim's in all six camera pairs.
- BODY_25B / HALPE big toe maps to ``foot_index`` (BlazePose's foot index is the tip of the foot);
  the small toe has no counterpart.
- ``Neck``, ``Head``, ``MidHip``/``Hip`` have no BlazePose landmark and are not used.
- Surface markers of motion capture (Plug-in Gait style LSHO, LELB, LKNE, LANK, LHEE, LTOE and
  the wrist bar LWRA/LWRB) sit on the skin, a few centimetres from the joint centre; pelvis
  markers (LASI, RASI, LPSI, RPSI) locate no hip joint centre without a regression model and
  are not mapped.

Names are compared after removing a ``Subject:`` prefix, underscores, spaces, dots and dashes,
case-insensitively.
"""

from __future__ import annotations

import re

from ergopose.keypoints import BLAZEPOSE33

#: OpenPose BODY_25B keypoint order (Pose2Sim's skeletons; the JSON files' pose_keypoints_2d).
BODY_25B: tuple[str, ...] = (
    "Nose",
    "LEye",
    "REye",
    "LEar",
    "REar",
    "LShoulder",
    "RShoulder",
    "LElbow",
    "RElbow",
    "LWrist",
    "RWrist",
    "LHip",
    "RHip",
    "LKnee",
    "RKnee",
    "LAnkle",
    "RAnkle",
    "Neck",
    "Head",
    "LBigToe",
    "LSmallToe",
    "LHeel",
    "RBigToe",
    "RSmallToe",
    "RHeel",
)

_SIDES = {"L": "left", "R": "right"}

#: Side-free marker stems -> our joint stem (the side prefix L/R/Left/Right/left_/right_ is added).
_SIDED_STEMS: dict[str, str] = {
    # OpenPose BODY_25 / BODY_25B, HALPE, Pose2Sim, OpenSim-style names.
    "eye": "eye",
    "ear": "ear",
    "shoulder": "shoulder",
    "elbow": "elbow",
    "wrist": "wrist",
    "hip": "hip",
    "knee": "knee",
    "ankle": "ankle",
    "heel": "heel",
    "bigtoe": "foot_index",
    "eyeinner": "eye_inner",
    "eyeouter": "eye_outer",
    "pinky": "pinky",
    "index": "index",
    "thumb": "thumb",
    "footindex": "foot_index",
    "mouth": "mouth",
    # Plug-in Gait style surface markers.
    "sho": "shoulder",
    "elb": "elbow",
    "kne": "knee",
    "ank": "ankle",
    "hee": "heel",
    "toe": "foot_index",
    "wra": "wrist",
}
#: Names without a side.
_PLAIN: dict[str, str] = {"nose": "nose"}

#: Marker stems that are surface markers of motion capture (offset from the joint centre).
SURFACE_STEMS = frozenset({"sho", "elb", "kne", "ank", "hee", "toe", "wra"})


def _clean(name: str) -> str:
    name = name.split(":")[-1]
    return re.sub(r"[\s_.\-]", "", name)


def joint_of_marker(name: str) -> str | None:
    """Our BlazePose joint for a reference marker name, or None when it has no counterpart."""
    clean = _clean(name)
    low = clean.lower()
    if low in _PLAIN:
        return _PLAIN[low]
    for prefix, side in (("left", "left"), ("right", "right")):
        if low.startswith(prefix) and low[len(prefix) :] in _SIDED_STEMS:
            return _check(f"{side}_{_SIDED_STEMS[low[len(prefix) :]]}")
    if clean[:1].upper() in _SIDES and low[1:] in _SIDED_STEMS:
        return _check(f"{_SIDES[clean[0].upper()]}_{_SIDED_STEMS[low[1:]]}")
    # COCO-style "left_shoulder" after cleaning is "leftshoulder" (handled above); BlazePose's own
    # names map onto themselves.
    if name in BLAZEPOSE33:
        return name
    return None


def is_surface_marker(name: str) -> bool:
    low = _clean(name).lower()
    return low[:1] in ("l", "r") and low[1:] in SURFACE_STEMS


def _check(joint: str) -> str | None:
    return joint if joint in BLAZEPOSE33 else None


def map_markers(names) -> dict[str, str]:
    """{marker name: our joint} for the markers that have a counterpart; when two markers map onto
    the same joint (LWRA and LWRB, LHip and Left_Hip), the first in file order is kept."""
    out: dict[str, str] = {}
    taken: set[str] = set()
    for name in names:
        joint = joint_of_marker(name)
        if joint is not None and joint not in taken:
            out[name] = joint
            taken.add(joint)
    return out


__all__ = ["BODY_25B", "joint_of_marker", "map_markers", "is_surface_marker", "SURFACE_STEMS"]
