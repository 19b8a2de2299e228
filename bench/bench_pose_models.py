"""Per-crop time of each landmark model card (lite, full, heavy): one 256 x 256 crop of a drawn
person through the network, preprocessing and decoding included, on one LiteRT thread (as
``ergopose assess`` runs it: one thread per worker process) and on two.

The models come from the model cache (fetched on first use: lite and heavy from the npm
package tarball). Measured figures and the accuracy of each card: docs/models.md.

``pose_landmark_NAME_cpu_ms`` is the processor time of one crop on one thread (the best of 20):
on a machine shared with other jobs the wall time measures the queue for the cores, the
processor time still measures the network.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import cv2

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench_pose import _person  # noqa: E402
from common import best_time, emit  # noqa: E402

from ergopose.pose.blazepose import BlazePoseLandmarker  # noqa: E402
from ergopose.pose.models import LANDMARK_MODELS  # noqa: E402


def best_cpu_time(fn, repeat: int = 20) -> float:
    """Smallest processor time (seconds) of one call over ``repeat`` calls, after one warm-up."""
    fn()
    best = float("inf")
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


def main() -> None:
    cv2.setNumThreads(1)
    crop = _person(256, 1.0, (0, 0))
    for name in LANDMARK_MODELS:
        for threads in (1, 2):
            landmarker = BlazePoseLandmarker(model=name, num_threads=threads)
            kp = landmarker(crop)
            emit(
                f"pose_landmark_{name}_ms",
                best_time(lambda: landmarker(crop), repeat=20) * 1e3,
                "ms",
                model=landmarker.card.name,
                threads=threads,
                input="256x256",
                presence=round(kp.presence, 4),
            )
            if threads == 1:
                emit(
                    f"pose_landmark_{name}_cpu_ms",
                    best_cpu_time(lambda: landmarker(crop)) * 1e3,
                    "ms",
                    model=landmarker.card.name,
                    threads=1,
                    input="256x256",
                )


if __name__ == "__main__":
    main()
