"""What the intrinsic and the stereo calibration share about OpenCV's fisheye calibration: its
flags and termination, how its "ill-conditioned view" error names the view, and the record of an
image left out of a fit. Below :mod:`intrinsics` and :mod:`extrinsics`, which both use it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Sequence

import cv2

#: cv2.fisheye.calibrate flags (the pitfalls: recompute extrinsics every iteration, refuse
#: ill-conditioned views, no skew).
FISHEYE_FLAGS = cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_CHECK_COND | cv2.fisheye.CALIB_FIX_SKEW
#: Termination: 100 iterations or a parameter change below 1e-10.
FISHEYE_CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-10)

#: Where cv2.fisheye names the ill-conditioned input array (view) in its error text.
ILL_CONDITIONED = re.compile(r"input array (\d+)")


@dataclass(frozen=True)
class DroppedImage:
    """An image left out of the fit.

    source: file name (or label) of the image.
    reason: for a human.
    code: for code: "no_board", "degenerate", "ill_conditioned", "opencv_failed", "outlier",
        "not_in_both" or "partial" (stereo).
    """

    source: str
    reason: str
    code: str = ""


def too_few_message(n: int, need: int, dropped: Sequence[DroppedImage]) -> str:
    msg = f"only {n} usable board image(s), at least {need} are needed"
    if dropped:
        reasons: dict[str, int] = {}
        for d in dropped:
            reasons[d.reason] = reasons.get(d.reason, 0) + 1
        msg += " (left out: " + ", ".join(f"{k}: {v}" for k, v in reasons.items()) + ")"
    return msg + "; take more images with the whole board visible and sharp"
