"""Lens models: project and unproject on 409,600 points (a 640 x 640 lookup map).

The map builder unprojects a view's pixels with the pinhole and projects the rays with the
fisheye model; the goal is the whole map under 10 ms, so each call should take a few ms.
Points: rays up to the lens's max_theta (project) and pixels over its whole image circle,
edge included (unproject).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from common import best_time, emit  # noqa: E402

from ergopose.geometry.lenses import DoubleSphere, Equidistant, KannalaBrandt, Rectilinear  # noqa: E402

N = 640 * 640
DATA = Path(__file__).resolve().parent.parent.parent / "shared" / "data"


def lenses() -> dict[str, object]:
    out = {
        # cv2.fisheye.calibrate on opencv-fisheye-stereo-jy/left.xml (SOURCE.md), turns at 93 deg.
        "kannala_brandt_jy_left": KannalaBrandt(
            558.478087865323,
            560.506767351568,
            620.458515360843,
            381.939424848348,
            -0.0014613319981768,
            -0.00329861110580401,
            0.00605760088590183,
            -0.00374209380722371,
        ),
        "kannala_brandt_paper_camera": KannalaBrandt(620.0, 620.0, 1295.5, 971.5, 0.02, -0.01, 0.003, -0.0005),
        "equidistant": Equidistant(620.0, 620.0, 1295.5, 971.5),
        "rectilinear": Rectilinear.from_fov(640, 640, math.radians(60)),
    }
    calib = DATA / "basalt-tumvi-calib" / "tumvi_512_cam0_cam1_ds_eucm_intrinsics.json"
    if calib.is_file():
        out["double_sphere_tumvi0"] = DoubleSphere(**json.loads(calib.read_text())["ds"][0])
    return out


def main() -> None:
    rng = np.random.default_rng(11)
    for name, lens in lenses().items():
        limit = math.radians(80) if lens.kind == "rectilinear" else min(lens.max_theta, math.pi) - 1e-3
        theta = np.arccos(rng.uniform(math.cos(limit), 1.0, N))
        phi = rng.uniform(-math.pi, math.pi, N)
        rays = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=-1)
        pixels = lens.project(rays)
        rd_max = getattr(lens, "rd_max", math.inf)
        if math.isfinite(rd_max):
            # Unproject: pixels uniform over the whole image circle, its very edge included.
            radius = rd_max * np.sqrt(rng.uniform(0.0, 1.0, N))
            pixels = np.stack([lens.cx + lens.fx * radius * np.cos(phi), lens.cy + lens.fy * radius * np.sin(phi)], -1)
        out2 = np.empty((N, 2))
        out3 = np.empty((N, 3))
        for verb, fn in [
            ("project", lambda: lens.project(rays)),
            ("project_out", lambda: lens.project(rays, out=out2)),
            ("unproject", lambda: lens.unproject(pixels)),
            ("unproject_out", lambda: lens.unproject(pixels, out=out3)),
        ]:
            emit(f"lens_{verb}_{name}", best_time(fn, repeat=15) * 1e3, "ms", points=N)


if __name__ == "__main__":
    main()
