"""View generation: building a lookup map and applying it (the paper's Table 2, "view generation").

The paper's camera: 2592 x 1944 fisheye. The paper generated a 320 x 320 view in 0.02 s and a
640 x 640 view in 0.10 s (map and image together). Goals here: build under 3 ms / 10 ms,
apply under 0.3 ms / 1 ms.
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from common import best_time, emit  # noqa: E402

from ergopose.geometry.camera import ceiling_camera  # noqa: E402
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt  # noqa: E402
from ergopose.geometry.views import VirtualView  # noqa: E402

W, H = 2592, 1944


def main() -> None:
    cv2.setNumThreads(2)
    lens = KannalaBrandt(fx=620.0, fy=620.0, cx=(W - 1) / 2, cy=(H - 1) / 2, k1=0.02, k2=-0.01, k3=0.003, k4=-0.0005)
    camera = ceiling_camera("cam_1", lens, W, H, position_world=(0.0, 0.0, 3.0))
    rng = np.random.default_rng(7)
    fisheye = rng.integers(0, 255, size=(H, W, 3), dtype=np.uint8)
    target = np.array([2.0, 1.0, 1.0])
    for size in (640, 320):
        view = VirtualView.aimed_at(camera, target, hfov=np.radians(60), size=(size, size))
        t_build = best_time(view.build_map, repeat=15)
        view_map = view.build_map()
        out = np.empty((size, size, 3), np.uint8)
        t_apply = best_time(lambda: view_map.apply(fisheye, out=out), repeat=50, number=5)
        context = {"source": f"{W}x{H} Kannala-Brandt", "view": f"{size}x{size}", "threads": cv2.getNumThreads()}
        emit(
            f"view_map_build_{size}",
            t_build * 1e3,
            "ms",
            goal_ms=10.0 if size == 640 else 3.0,
            paper_view_generation_ms=100.0 if size == 640 else 20.0,
            **context,
        )
        emit(f"view_remap_{size}", t_apply * 1e3, "ms", goal_ms=1.0 if size == 640 else 0.3, **context)


if __name__ == "__main__":
    main()
