"""Example lenses (real calibrations where there are some) and helpers shared by the lens tests.

(A plain module, not conftest.py: several conftest modules exist, so ``from conftest import``
would be ambiguous.)"""

from __future__ import annotations

import json
import math

import numpy as np

from ergopose.geometry.lenses import (
    EUCM,
    DoubleSphere,
    Equidistant,
    Equisolid,
    KannalaBrandt,
    Orthographic,
    Rectilinear,
    Stereographic,
)

#: cv2.fisheye.calibrate on opencv-fisheye-stereo-jy/left.xml, as asserted by OpenCV's own test
#: (../shared/data/opencv-fisheye-stereo-jy/SOURCE.md). Image 1280 x 800.
JY_LEFT_K = np.array([[558.478087865323, 0, 620.458515360843], [0, 560.506767351568, 381.939424848348], [0, 0, 1]])
JY_LEFT_D = np.array([-0.0014613319981768, -0.00329861110580401, 0.00605760088590183, -0.00374209380722371])
#: Stereo calibration of the right camera, same source.
JY_RIGHT_K = np.array([[560.395452535348, 0, 678.971652040359], [0, 561.90171021422, 380.401340535339], [0, 0, 1]])
JY_RIGHT_D = np.array([-0.0130785435677431, 0.0284434505383497, -0.0360333869900506, 0.0144724062347222])


def tumvi(shared_data, model: str, cam: int) -> dict:
    """The TUM-VI 512 px intrinsics from Basalt (../shared/data/basalt-tumvi-calib/SOURCE.md)."""
    path = shared_data / "basalt-tumvi-calib" / "tumvi_512_cam0_cam1_ds_eucm_intrinsics.json"
    return dict(json.loads(path.read_text())[model][cam])


def make_lens(name: str, shared_data) -> object:
    if name == "rectilinear":
        return Rectilinear(400.0, 380.0, 320.5, 240.2)
    if name == "equidistant":
        return Equidistant(300.0, 310.0, 320.5, 319.2)
    if name == "stereographic":
        return Stereographic(150.0, 152.0, 320.5, 319.2)
    if name == "equisolid":
        return Equisolid(220.0, 221.0, 320.5, 319.2)
    if name == "orthographic":
        return Orthographic(320.0, 318.0, 320.5, 319.2)
    if name == "kannala_brandt_jy_left":
        return KannalaBrandt.from_opencv(JY_LEFT_K, JY_LEFT_D)
    if name == "kannala_brandt_jy_right":
        return KannalaBrandt.from_opencv(JY_RIGHT_K, JY_RIGHT_D)
    if name == "kannala_brandt_wide":  # increasing up to pi: the domain is capped at pi
        return KannalaBrandt(200.0, 201.0, 320.5, 319.2, 0.05, 0.01, -0.002, 0.0003)
    if name == "kannala_brandt_strong":  # turns early (about 33 degrees)
        return KannalaBrandt(200.0, 201.0, 320.5, 319.2, -1.0, 0.0, 0.0, 0.0)
    if name == "double_sphere_tumvi0":
        return DoubleSphere(**tumvi(shared_data, "ds", 0))
    if name == "double_sphere_tumvi1":
        return DoubleSphere(**tumvi(shared_data, "ds", 1))
    if name == "double_sphere_low_alpha":
        return DoubleSphere(300.0, 300.0, 320.5, 319.2, 0.3, 0.4)
    if name == "eucm_tumvi0":
        return EUCM(**tumvi(shared_data, "eucm", 0))
    if name == "eucm_tumvi1":
        return EUCM(**tumvi(shared_data, "eucm", 1))
    if name == "eucm_low_alpha":
        return EUCM(300.0, 300.0, 320.5, 319.2, 0.3, 1.4)
    raise KeyError(name)


EXAMPLES = (
    "rectilinear",
    "equidistant",
    "stereographic",
    "equisolid",
    "orthographic",
    "kannala_brandt_jy_left",
    "kannala_brandt_jy_right",
    "kannala_brandt_wide",
    "kannala_brandt_strong",
    "double_sphere_tumvi0",
    "double_sphere_tumvi1",
    "double_sphere_low_alpha",
    "eucm_tumvi0",
    "eucm_tumvi1",
    "eucm_low_alpha",
)


def rays_at(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Unit rays at angle ``theta`` from the optical axis and ``phi`` around it."""
    s = np.sin(theta)
    return np.stack([s * np.cos(phi), s * np.sin(phi), np.cos(theta)], axis=-1)


def angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle between unit vectors, accurate for tiny angles."""
    return 2.0 * np.arcsin(np.clip(0.5 * np.linalg.norm(a - b, axis=-1), 0.0, 1.0))


def ray_limit(lens) -> float:
    """The largest angle the ray round-trip samples: max_theta, minus a margin where the
    model's image radius stops growing (there the inverse is ill-conditioned) or is unbounded."""
    if lens.kind == "rectilinear":
        return math.radians(89.0)
    return min(lens.max_theta, math.pi) - 1e-3
