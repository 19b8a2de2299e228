"""2D pose with LiteRT on 2 threads: one BlazePose landmark crop (256 x 256) and one detector
image (224 x 224), each including preprocessing and decoding, on a drawn person.

The models come from the model cache (fetched on first use). Measured here before: about 9 ms
per landmark crop and 6 ms per detector image on 2 cores (docs/models.md).
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from common import best_time, emit  # noqa: E402

from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker  # noqa: E402


def _person(size: int, scale: float, offset: tuple[int, int]) -> np.ndarray:
    """A simple stick person (head, torso, limbs) so the networks see a plausible input."""
    img = np.full((size, size, 3), 200, np.uint8)
    p = lambda x, y: (int(x * scale + offset[0]), int(y * scale + offset[1]))  # noqa: E731
    t = lambda v: max(1, int(v * scale))  # noqa: E731
    cv2.fillConvexPoly(img, np.array([p(106, 58), p(150, 58), p(146, 130), p(110, 130)], np.int32), (180, 80, 40))
    for a, b, th, col in [
        ((150, 66), (170, 102), 14, (180, 80, 40)),
        ((106, 66), (86, 102), 14, (180, 80, 40)),
        ((170, 102), (180, 136), 11, (140, 180, 230)),
        ((86, 102), (76, 136), 11, (140, 180, 230)),
        ((141, 130), (145, 180), 17, (60, 60, 60)),
        ((115, 130), (111, 180), 17, (60, 60, 60)),
        ((145, 180), (147, 226), 14, (60, 60, 60)),
        ((111, 180), (109, 226), 14, (60, 60, 60)),
    ]:
        cv2.line(img, p(*a), p(*b), col, t(th))
    cv2.circle(img, p(128, 36), t(17), (140, 180, 230), -1)
    return img


def main() -> None:
    cv2.setNumThreads(2)
    landmarker = BlazePoseLandmarker(num_threads=2)
    detector = BlazePoseDetector(num_threads=2)
    crop = _person(256, 1.0, (0, 0))
    view = _person(224, 0.6, (40, 30))
    kp = landmarker(crop)
    dets = detector(view)
    emit(
        "pose_landmark_ms",
        best_time(lambda: landmarker(crop), repeat=30) * 1e3,
        "ms",
        threads=2,
        input="256x256",
        presence=round(kp.presence, 4),
    )
    emit(
        "pose_detector_ms",
        best_time(lambda: detector(view), repeat=30) * 1e3,
        "ms",
        threads=2,
        input="224x224",
        people=len(dets),
    )


if __name__ == "__main__":
    main()
