"""An approximate camera from the footage alone: the image circle of a fisheye video, and a
nominal lens around it (``ergopose pose`` without a calibration file; docs/pose-command.md).

A fisheye lens lights a disc on the sensor; outside it the pixels stay dark whatever the scene
does. :func:`find_image_circle` takes the per-pixel maximum over frames spread through the
video (a dark object in the scene at one moment is lit at another), keeps the largest lit
region, and fits a circle to its border where that border is not the frame's edge (a circle
cut by the frame, as in "full-frame" fisheye videos, still has its arcs). It refuses, with a
reason, footage where no such disc is seen: a black video, a frame lit to its corners (not a
fisheye image with a visible circle), a lit region whose border is not round.

:func:`nominal_fisheye_camera` puts a radially symmetric lens (equidistant r = f theta by
default; equisolid, stereographic or orthographic) in the circle with the given field of view,
looking straight down (a ceiling camera; ``ergopose camera guess`` writes it as a calibration
file); :func:`nominal_pinhole_camera`
a pinhole lens of the given horizontal field of view, looking level. Neither knows the
camera's place in the room: they serve the 2D stage, which needs the lens and which way is up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterable

import cv2
import numpy as np

from ergopose.geometry.camera import CalibrationInfo, Camera, ceiling_rotation
from ergopose.geometry.lenses._radial import RadialLens
from ergopose.geometry.lenses.equidistant import Equidistant
from ergopose.geometry.lenses.equisolid import Equisolid
from ergopose.geometry.lenses.orthographic import Orthographic
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.geometry.lenses.stereographic import Stereographic

#: A pixel whose brightest value over the sampled frames (8-bit grey) is above this is lit.
LIT_LEVEL = 24
#: Fraction of the frame that may be lit before the footage counts as "lit to the corners".
MAX_LIT_SHARE = 0.97
#: The circle's radius must be at least this fraction of the frame's shorter side.
MIN_RADIUS_SHARE = 0.2
#: Border points must lie within this fraction of the radius from the fitted circle (RMS).
MAX_FIT_RMS_SHARE = 0.02
#: Share of the fitted disc (inside the frame) that must be lit, and of the frame outside it that may be.
MIN_INSIDE_LIT = 0.9
MAX_OUTSIDE_LIT = 0.05


@dataclass(frozen=True)
class CircleSearch:
    """The outcome of :func:`find_image_circle`.

    circle: (u, v, radius) in pixels, or None when no circle was found.
    reason: why not (a phrase for the user), "" when found.
    lit_share: fraction of the frame lit in the maximum image.
    fit_rms_px: RMS distance of the border points from the circle (NaN when not fitted).
    """

    circle: tuple[float, float, float] | None
    reason: str = ""
    lit_share: float = float("nan")
    fit_rms_px: float = float("nan")


def max_image(frames: Iterable[np.ndarray]) -> np.ndarray:
    """Per-pixel maximum of the frames' grey values (uint8, H x W); ValueError if no frame."""
    out: np.ndarray | None = None
    for frame in frames:
        grey = frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        out = grey.copy() if out is None else np.maximum(out, grey, out=out)
    if out is None:
        raise ValueError("no frames")
    return out


def fit_circle(points: np.ndarray) -> tuple[float, float, float]:
    """Least-squares circle (u, v, radius) through (N, 2) points (algebraic fit, N >= 3)."""
    x, y = points[:, 0].astype(np.float64), points[:, 1].astype(np.float64)
    a = np.stack([x, y, np.ones_like(x)], axis=1)
    b = x * x + y * y
    (c0, c1, c2), *_ = np.linalg.lstsq(a, b, rcond=None)
    u, v = 0.5 * c0, 0.5 * c1
    return float(u), float(v), float(math.sqrt(max(c2 + u * u + v * v, 0.0)))


def find_image_circle(brightest: np.ndarray, lit_level: int = LIT_LEVEL) -> CircleSearch:
    """The image circle in a per-pixel maximum image (:func:`max_image`); pixel centres are
    integer coordinates, (0, 0) the top-left pixel."""
    h, w = brightest.shape[:2]
    lit = (brightest > lit_level).astype(np.uint8)
    share = float(lit.mean())
    if share == 0.0:
        return CircleSearch(None, "no lit pixels (a black video?)", share)
    if share > MAX_LIT_SHARE:
        return CircleSearch(
            None,
            f"the frame is lit to its corners ({100 * share:.0f} % of it): not a fisheye image with a visible circle",
            share,
        )
    count, labels, stats, _ = cv2.connectedComponentsWithStats(lit, connectivity=8)
    largest = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    region = (labels == largest).astype(np.uint8)
    contours, _ = cv2.findContours(region, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    border = np.concatenate([c.reshape(-1, 2) for c in contours]).astype(np.float64)
    inner = (border[:, 0] > 1) & (border[:, 0] < w - 2) & (border[:, 1] > 1) & (border[:, 1] < h - 2)
    border = border[inner]
    if border.shape[0] < 20:
        return CircleSearch(None, "the lit region has no border inside the frame", share)
    u, v, r = fit_circle(border)
    rms = float(np.sqrt(np.mean((np.hypot(border[:, 0] - u, border[:, 1] - v) - r) ** 2)))
    if not (math.isfinite(r) and r >= MIN_RADIUS_SHARE * min(w, h)):
        return CircleSearch(None, "the lit region is too small for an image circle", share, rms)
    if rms > MAX_FIT_RMS_SHARE * r:
        return CircleSearch(
            None, f"the border of the lit region is not round (off a circle by {rms:.1f} px RMS)", share, rms
        )
    yy, xx = np.mgrid[0:h, 0:w]
    inside = np.hypot(xx - u, yy - v) <= r
    inside_lit = float(lit[inside].mean()) if inside.any() else 0.0
    outside_lit = float(lit[~inside].mean()) if (~inside).any() else 0.0
    if inside_lit < MIN_INSIDE_LIT or outside_lit > MAX_OUTSIDE_LIT:
        return CircleSearch(
            None,
            f"the lit region is not a disc ({100 * inside_lit:.0f} % of the circle lit, "
            f"{100 * outside_lit:.0f} % outside it)",
            share,
            rms,
        )
    return CircleSearch((u, v, r), "", share, rms)


#: The lens models a nominal fisheye can have: radially symmetric models r = f g(theta) with no
#: other parameter, so that the image circle's radius and the field of view fix f.
NOMINAL_FISHEYE_LENSES: dict[str, Callable[[float, float, float, float], RadialLens]] = {
    cls.kind: cls for cls in (Equidistant, Equisolid, Stereographic, Orthographic)
}
#: The whole field of view (radians) a nominal fisheye may span across its image circle.
NOMINAL_FOV_RANGE = (math.radians(100.0), math.radians(280.0))


def nominal_max_fov(kind: str) -> float:
    """The widest field of view (radians, across the image circle) a nominal lens of ``kind`` has."""
    return 2.0 * NOMINAL_FISHEYE_LENSES[kind](1.0, 1.0, 0.0, 0.0).max_theta


def nominal_fisheye_lens(kind: str, circle: tuple[float, float, float], fov: float) -> RadialLens:
    """A lens of ``kind`` (a key of NOMINAL_FISHEYE_LENSES) centred on the image circle (u, v,
    radius) whose radius is the image of half the field of view ``fov`` (radians).

    ValueError when the kind is unknown or cannot reach half of ``fov`` (an orthographic lens
    ends at 90 degrees off-axis)."""
    cls = NOMINAL_FISHEYE_LENSES.get(kind)
    if cls is None:
        raise ValueError(f"unknown lens {kind!r}; choose one of {', '.join(NOMINAL_FISHEYE_LENSES)}")
    u, v, r = circle
    unit = cls(1.0, 1.0, 0.0, 0.0)
    half = 0.5 * fov
    if not half <= unit.max_theta + 1e-12:
        raise ValueError(
            f"a {kind} lens reaches at most {math.degrees(2 * unit.max_theta):g} deg across its "
            f"image circle, not {math.degrees(fov):g}"
        )
    g = float(unit.radius_of_theta(np.array(min(half, unit.max_theta))))
    f = r / g
    return cls(f, f, u, v)


def nominal_fisheye_camera(
    name: str,
    width: int,
    height: int,
    circle: tuple[float, float, float],
    fov: float,
    height_m: float = 3.0,
    lens: str = "equidistant",
) -> Camera:
    """A fisheye of the given lens model (default equidistant, r = f theta) whose image circle
    (u, v, radius) spans ``fov`` radians (the whole field of view across the circle), looking
    straight down from ``height_m`` metres above the world origin, image x along world +x."""
    model = nominal_fisheye_lens(lens, circle, fov)
    u, v, r = circle
    info = CalibrationInfo(
        method=f"nominal: {lens} lens, {math.degrees(fov):g} deg across the image circle "
        "found in the footage, looking straight down"
    )
    return Camera(
        name,
        model,
        width,
        height,
        ceiling_rotation(0.0),
        np.array([0.0, 0.0, height_m]),
        calibration=info,
        image_circle=(float(u), float(v), float(r)),
    )


#: rotation_world_from_cam of a camera looking level along world +y, image up = world up.
LEVEL_ROTATION = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def nominal_pinhole_camera(name: str, width: int, height: int, hfov: float, height_m: float = 1.5) -> Camera:
    """A pinhole camera of horizontal field of view ``hfov`` (radians), principal point at the
    image centre, looking level with the image's up = world up."""
    lens = Rectilinear.from_fov(width, height, hfov)
    info = CalibrationInfo(method=f"nominal: pinhole lens, {math.degrees(hfov):g} deg across the image, looking level")
    return Camera(name, lens, width, height, LEVEL_ROTATION, np.array([0.0, 0.0, height_m]), calibration=info)
