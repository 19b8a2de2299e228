"""A person's clothing colour in one camera frame: the appearance half of a worker's signature.

Limb lengths alone do not tell workers apart when the keypoints come from a pose network: on a
simulated 4-worker session the limb-length medians of tracks differed by 30-250 mm RMS whether
they followed the same worker or two (docs/reconstruction.md, 3. Identities). The colour of the
clothes does: it is measured here from the fisheye frame the network ran on, at the keypoints it
found, and carried to the tracker (ergopose.recon.tracking) with the person.

Descriptor (:data:`APPEARANCE_DIMS` = 6 numbers per person): the median CIE L*a*b* colour
(OpenCV's 8-bit scale: L*, a* and b* each mapped to 0..255, a* and b* offset by 128) of pixels
sampled on the upper body (inside the quadrilateral of the shoulders and hips, shrunk towards its
middle so that the background and the arms at its edges are left out) and on the thighs (along
hip -> knee, the middle of each segment). A part whose keypoints are not all found with at
least :data:`MIN_CONFIDENCE` is NaN. Only colours leave this module: no pixels, no faces.
"""

from __future__ import annotations

import cv2
import numpy as np

from ergopose.arrays import FloatArray
from ergopose.keypoints import JOINT_INDEX
from ergopose.records import APPEARANCE_DIMS  # (L*, a*, b*) of the upper body, then of the thighs

#: Smallest keypoint confidence of the joints a part is sampled between.
MIN_CONFIDENCE = 0.5
#: Sample grid of the upper body (fractions across the shoulders-hips quadrilateral, both ways)
#: and of each thigh (fractions along hip -> knee).
_TORSO_STEPS = np.linspace(0.25, 0.75, 5)
_THIGH_STEPS = np.linspace(0.2, 0.7, 6)

_LS, _RS = JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]
_LH, _RH = JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]
_LK, _RK = JOINT_INDEX["left_knee"], JOINT_INDEX["right_knee"]


def _torso_points(px: np.ndarray) -> FloatArray:
    """(N, 33, 2) -> (N, S, 2) sample points inside the shoulders-hips quadrilateral."""
    u, v = np.meshgrid(_TORSO_STEPS, _TORSO_STEPS, indexing="ij")
    u, v = u.ravel()[None, :, None], v.ravel()[None, :, None]
    top = px[:, None, _LS] + u * (px[:, None, _RS] - px[:, None, _LS])
    bottom = px[:, None, _LH] + u * (px[:, None, _RH] - px[:, None, _LH])
    points: FloatArray = top + v * (bottom - top)
    return points


def _thigh_points(px: np.ndarray) -> np.ndarray:
    """(N, 33, 2) -> (N, 2 * S, 2) sample points along both thighs."""
    t = _THIGH_STEPS[None, :, None]
    left = px[:, None, _LH] + t * (px[:, None, _LK] - px[:, None, _LH])
    right = px[:, None, _RH] + t * (px[:, None, _RK] - px[:, None, _RH])
    return np.concatenate([left, right], axis=1)


def appearance_fisheye(image_bgr: np.ndarray, pixels_fisheye: np.ndarray, confidence: np.ndarray) -> np.ndarray:
    """(N, APPEARANCE_DIMS) clothing colours of N people in one fisheye frame.

    image_bgr: (H, W, 3) uint8, the frame the keypoints were found in; pixels_fisheye: (N, 33, 2)
    keypoints in its pixels (NaN: not found); confidence: (N, 33) in [0, 1].
    """
    px = np.asarray(pixels_fisheye, dtype=np.float64).reshape(-1, 33, 2)
    conf = np.asarray(confidence, dtype=np.float64).reshape(-1, 33)
    n = px.shape[0]
    if n == 0:
        return np.zeros((0, APPEARANCE_DIMS))
    seen = np.isfinite(px).all(axis=-1) & (conf >= MIN_CONFIDENCE)
    torso_ok = np.asarray(seen[:, [_LS, _RS, _LH, _RH]].all(axis=1))
    thigh_ok = np.asarray(seen[:, [_LH, _RH, _LK, _RK]].all(axis=1))
    if not (torso_ok.any() or thigh_ok.any()):
        return np.full((n, APPEARANCE_DIMS), np.nan)
    # Lab of the sampled pixels only (the whole frame's conversion would cost more than the rest).
    torso = _torso_points(px)
    thighs = _thigh_points(px)
    image = np.asarray(image_bgr)
    return np.concatenate([_median_lab_of(image, torso, torso_ok), _median_lab_of(image, thighs, thigh_ok)], axis=1)


def _median_lab_of(image_bgr: np.ndarray, points: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """Median Lab of BGR pixels at ``points`` (N, S, 2); NaN where not ``ok`` or outside."""
    h, w = image_bgr.shape[:2]
    pts = np.nan_to_num(points, nan=-1.0)
    col = np.round(pts[..., 0]).astype(np.int64)
    row = np.round(pts[..., 1]).astype(np.int64)
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h) & ok[:, None]
    bgr = image_bgr[np.clip(row, 0, h - 1), np.clip(col, 0, w - 1)].astype(np.uint8)  # (N, S, 3)
    lab = cv2.cvtColor(bgr.reshape(1, -1, 3), cv2.COLOR_BGR2Lab).reshape(bgr.shape).astype(np.float64)
    lab[~inside] = np.nan
    # Median over the points inside (np.sort puts NaN last; numpy's nanmedian loops in Python).
    ordered = np.sort(lab, axis=1)
    count = inside.sum(axis=1)  # (N,)
    lo = np.maximum(count - 1, 0) // 2
    hi = np.maximum(count // 2, lo)
    pick = np.stack([lo, hi], axis=1)[:, :, None]  # (N, 2, 1)
    both = np.take_along_axis(ordered, np.broadcast_to(pick, (len(count), 2, 3)), axis=1)
    return np.where((count > 0)[:, None], both.mean(axis=1), np.nan)


def appearance_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance between appearance descriptors (..., APPEARANCE_DIMS), broadcasting: the RMS over
    the parts known in both of the Lab differences, lightness counted at half weight (the two
    cameras and the room's light change it more than the hue); NaN where no part is known in both.
    """
    d = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    d = d.reshape(d.shape[:-1] + (2, 3)) * np.array([0.5, 1.0, 1.0])
    per_part = np.sum(d * d, axis=-1) / 2.25  # (..., 2) mean square per weighted channel (0.25 + 1 + 1)
    known = np.isfinite(per_part)
    count = known.sum(axis=-1)
    total = np.where(known, per_part, 0.0).sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, np.sqrt(total / count), np.nan)
