"""The one keypoint schema of ergopose: BlazePose's 33 landmarks.

Every stage (2D pose, triangulation, tracking, joint angles, simulation) indexes joints with
these names and this order. Hand points (pinky, index, thumb) and foot points (heel, foot
index) are kept because the wrist and leg scores need them. ``COCO17`` maps the COCO subset
that other networks (e.g. the RTMPose family) report onto this schema.
"""

from __future__ import annotations

import numpy as np

BLAZEPOSE33: tuple[str, ...] = (
    "nose",
    "left_eye_inner",
    "left_eye",
    "left_eye_outer",
    "right_eye_inner",
    "right_eye",
    "right_eye_outer",
    "left_ear",
    "right_ear",
    "mouth_left",
    "mouth_right",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_pinky",
    "right_pinky",
    "left_index",
    "right_index",
    "left_thumb",
    "right_thumb",
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
NUM_JOINTS = len(BLAZEPOSE33)
JOINT_INDEX: dict[str, int] = {name: i for i, name in enumerate(BLAZEPOSE33)}
#: Each keypoint's mirror partner (left <-> right, mouth_left <-> mouth_right); the nose is its
#: own. ``keypoints[..., MIRROR, :]`` is the same skeleton with its left and right exchanged.
MIRROR = np.array(
    [JOINT_INDEX[n.replace("left", "#").replace("right", "left").replace("#", "right")] for n in BLAZEPOSE33],
    dtype=np.int64,
)

#: COCO's 17 keypoints in COCO order; each is also a BlazePose landmark of the same name.
COCO17: tuple[str, ...] = (
    "nose",
    "left_eye",
    "right_eye",
    "left_ear",
    "right_ear",
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
#: For each COCO keypoint (in COCO order), its index in BLAZEPOSE33.
COCO17_TO_BLAZEPOSE33 = np.array([JOINT_INDEX[n] for n in COCO17], dtype=np.int64)

#: Limbs (bones) used for limb-length diagnostics and skeleton drawings: (name, joint a, joint b).
LIMBS: tuple[tuple[str, str, str], ...] = (
    ("shoulder_width", "left_shoulder", "right_shoulder"),
    ("hip_width", "left_hip", "right_hip"),
    ("left_upper_arm", "left_shoulder", "left_elbow"),
    ("right_upper_arm", "right_shoulder", "right_elbow"),
    ("left_forearm", "left_elbow", "left_wrist"),
    ("right_forearm", "right_elbow", "right_wrist"),
    ("left_trunk_side", "left_shoulder", "left_hip"),
    ("right_trunk_side", "right_shoulder", "right_hip"),
    ("left_thigh", "left_hip", "left_knee"),
    ("right_thigh", "right_hip", "right_knee"),
    ("left_shank", "left_knee", "left_ankle"),
    ("right_shank", "right_knee", "right_ankle"),
    ("left_foot", "left_heel", "left_foot_index"),
    ("right_foot", "right_heel", "right_foot_index"),
    ("left_hand", "left_wrist", "left_index"),
    ("right_hand", "right_wrist", "right_index"),
)
LIMB_INDEX = np.array([(JOINT_INDEX[a], JOINT_INDEX[b]) for _, a, b in LIMBS], dtype=np.int64)


def joint_index(name: str) -> int:
    """Index of a joint by name; raises KeyError naming the unknown joint."""
    try:
        return JOINT_INDEX[name]
    except KeyError:
        raise KeyError(f"unknown joint {name!r}; known joints: {', '.join(BLAZEPOSE33)}") from None
