"""Small skeletons squeezed onto part of a bigger one: one person detected twice, once whole.

The landmark network, run on a view that holds only part of a person (a search view cut at the
waist, the head and shoulders of someone close to the lens), often fits a whole small skeleton to
that part. Its hips then lie on the person's chest or thighs, 0.5-1 body radius from the real
hips, too far for the hip-centre rule of :meth:`FisheyePoseEstimator._merge` to call it the same
person; such a skeleton also wins that rule's ranking when its view is more upright, and then the
whole person is dropped as its duplicate.

A detection is a *fragment* of another when it is much smaller (its body's angular radius at most
``fragment_ratio`` of the other's) and its confident body keypoints lie along the other's skeleton
(their median angular distance to the nearest bone of the other is at most ``fragment_distance``
of the other's body radius). Measured on the four videos of the Pose2Sim recording
(docs/pose-command.md): fragments had 0.14-0.61 of the person's radius and a median distance of
0.02-0.13 radii; skeletons on other things in the scene lay 0.8-1.2 radii from every bone. A
second person standing beside or behind someone has keypoints on their own body, away from the
first person's bones, and is kept.
"""

from __future__ import annotations

import numpy as np

from ergopose.arrays import BoolArray, FloatArray
from ergopose.keypoints import JOINT_INDEX, LIMB_INDEX

#: The bones a fragment's keypoints are measured against: the skeleton's limbs and trunk, and the
#: neck as nose to each shoulder (a fragment on the head and shoulders lies there).
BONES = np.concatenate(
    [
        LIMB_INDEX,
        np.array(
            [(JOINT_INDEX["nose"], JOINT_INDEX["left_shoulder"]), (JOINT_INDEX["nose"], JOINT_INDEX["right_shoulder"])],
            dtype=np.int64,
        ),
    ]
)


def distance_to_bones(points_ray: FloatArray, rays_cam: FloatArray, good: BoolArray) -> FloatArray:
    """Angle (radians) from each of ``points_ray`` (N, 3), unit rays, to the nearest bone of a
    skeleton whose keypoint rays are ``rays_cam`` (33, 3) and whose usable keypoints are ``good``
    (33,) bool; a bone counts when both its ends are usable. The bone is the chord between its
    ends' rays (at these angles of a few degrees the chord and the arc differ by far less than a
    keypoint's error). inf when no bone is usable."""
    bones = BONES[good[BONES[:, 0]] & good[BONES[:, 1]]]
    if bones.size == 0:
        return np.full(points_ray.shape[0], np.inf)
    a = rays_cam[bones[:, 0]]  # (B, 3)
    ab = rays_cam[bones[:, 1]] - a
    ap = points_ray[:, None, :] - a[None]  # (N, B, 3)
    t = np.clip((ap * ab[None]).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-18)[None], 0.0, 1.0)
    nearest = a[None] + t[..., None] * ab[None]  # (N, B, 3)
    cos = (nearest * points_ray[:, None, :]).sum(-1) / np.linalg.norm(nearest, axis=-1)
    gaps: FloatArray = np.arccos(np.clip(cos, -1.0, 1.0)).min(axis=1)
    return gaps


def is_fragment(
    rays_small: np.ndarray,
    good_small: np.ndarray,
    radius_small: float,
    rays_big: np.ndarray,
    good_big: np.ndarray,
    radius_big: float,
    ratio: float,
    distance: float,
) -> bool:
    """Whether the small detection (keypoint rays (33, 3), usable keypoints (33,), body radius in
    radians) is a fragment of the big one: radius at most ``ratio`` of the big one's and its
    usable keypoints a median at most ``distance`` big radii from the big skeleton's bones."""
    if not radius_small <= ratio * radius_big or not good_small.any():
        return False
    gaps = distance_to_bones(rays_small[good_small], rays_big, good_big)
    return bool(np.median(gaps) <= distance * radius_big)
