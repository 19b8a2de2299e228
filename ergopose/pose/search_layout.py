"""Where the 2D stage's person detector looks for new people: search views placed and sized from
the lens, the image circle and the detector's input size (docs/pose-in-fisheye.md, "The search
views").

The rule. A person of ``person_height`` standing on the floor, at most ``max_distance``
(horizontally) from the camera, must span at least ``person_px`` pixels of the detector's input
in some search view that holds the whole person, and every direction of the image circle up to
the horizon must lie in such a view. The person's apparent size at each direction comes from the
camera's pose (its height above the floor, z = 0, and its tilt): the larger of the angle the
standing body subtends vertically and the angle its width subtends (a person right under the
camera is seen from above). A view of half field of view h on a detector input N pixels wide
has a focal length of N / (2 tan h) pixels, so a person of angular size a spans about
a N / (2 tan h) pixels at its centre (more off-centre, a rectilinear view stretches outwards):
tan h <= a N / (2 person_px).

A view finer than the fisheye image itself only interpolates: no view is made finer than
``max_upsampling`` times the image's own pixel density at that direction (the smaller of its
two densities across the ray, pixels per radian). The finer of the two limits wins only where
the image can resolve it, so a 2048 x 2048 image gets finer views (and more of them) than a
1024 x 768 image of the same lens, and a person at the horizon is searched for as finely as the
image allows.

The layout is a single view along the lens axis and rings of equal views around it, built from
the axis outwards: each ring's half field of view is the largest the rule allows over the band of
angles it covers, its count the fewest views whose cones, each shrunk by the person's angular
radius (so the whole person fits), leave no gap between them or with the ring inside it; its
angle off the axis is the one that covers the most of the circle per view. Everything here is in
the camera frame, in radians.
"""

from __future__ import annotations

import math
from typing import Callable
from dataclasses import dataclass

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.errors import InputError
from ergopose.geometry.camera import Camera

_WORLD_UP = np.array([0.0, 0.0, 1.0])
#: Azimuths sampled around the lens axis when a ring's figures are taken (worst case over them).
_AZIMUTHS = 72
#: Angles off the axis sampled from the axis to the horizon.
_POLARS = 181


@dataclass(frozen=True)
class SearchSizing:
    """The inputs of the rule (module docstring; lengths in metres, angles in radians).

    person_height: height of the smallest person to find; person_width: their width seen from
    above (shoulders). max_distance: farthest working distance, horizontally from the camera;
    people farther away are searched for at the size they would have there. person_px: the
    person's length in detector pixels at that distance. max_upsampling: no view finer than this
    many times the image's own pixel density. min_half_fov, max_half_fov: limits of a search
    view's half field of view. max_polar: the layout covers the image circle up to this angle off
    the lens axis (pi/2: the horizon of a camera looking straight down).
    """

    person_height: float = 1.7
    person_width: float = 0.5
    max_distance: float = 6.0
    person_px: float = 60.0
    max_upsampling: float = 1.0
    min_half_fov: float = math.radians(12.0)
    max_half_fov: float = math.radians(45.0)
    max_polar: float = math.radians(90.0)


@dataclass(frozen=True)
class SearchRing:
    """``count`` views with half field of view ``half_fov`` whose axes lie ``polar`` off the lens
    axis, the first at azimuth ``azimuth0`` (one view when polar is 0)."""

    polar: float
    count: int
    half_fov: float
    azimuth0: float = 0.0


@dataclass(frozen=True)
class SearchLayout:
    """The search views: rings from the lens axis outwards; ``covered``: every direction of the
    image up to this angle off the lens axis lies in a view that holds the whole person there.
    ``dropped``: indices (in the order of :meth:`all_views`) of the ring views that hold no
    direction of the image (a rectangular image cut from the circle) and are not run."""

    rings: tuple[SearchRing, ...]
    covered: float
    dropped: tuple[int, ...] = ()

    @property
    def count(self) -> int:
        return sum(r.count for r in self.rings) - len(self.dropped)

    def all_views(self) -> tuple[np.ndarray, np.ndarray]:
        """(V, 3) unit axes in the camera frame and (V,) half fields of view of every ring view."""
        axes, halves = [], []
        for r in self.rings:
            az = r.azimuth0 + 2.0 * np.pi * np.arange(r.count) / r.count
            axes.append(
                np.stack(
                    [np.sin(r.polar) * np.cos(az), np.sin(r.polar) * np.sin(az), np.full(r.count, np.cos(r.polar))],
                    axis=-1,
                )
            )
            halves.append(np.full(r.count, r.half_fov))
        return np.concatenate(axes), np.concatenate(halves)

    def views(self) -> tuple[np.ndarray, np.ndarray]:
        """(V, 3) unit axes and (V,) half fields of view of the views that are run."""
        axes, halves = self.all_views()
        keep = np.ones(len(halves), bool)
        keep[list(self.dropped)] = False
        return axes[keep], halves[keep]


def fixed_layout(polars: tuple[float, ...], per_ring: int, half_fov: float, max_theta: float) -> SearchLayout:
    """The layout of explicit rings (``PoseSettings.search_layout = "fixed"``): one view at polar
    0, ``per_ring`` on every other ring, every second ring turned by half a step; rings beyond
    ``max_theta`` (outside the image) are left out."""
    rings = []
    for k, polar in enumerate(polars):
        if polar > max_theta:
            continue
        count = 1 if polar == 0 else int(per_ring)
        rings.append(SearchRing(float(polar), count, float(half_fov), np.pi / count if k % 2 == 0 else 0.0))
    return SearchLayout(tuple(rings), float("nan"))


def _directions(polar: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    return np.stack(
        [np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar) * np.ones_like(azimuth)],
        axis=-1,
    )


def person_size(camera: Camera, directions_cam: np.ndarray, sizing: SearchSizing) -> FloatArray:
    """(...) angular size (radians) of a person whose body centre lies along each direction:
    standing on the floor (z = 0) where the ray meets the height of their centre, at most
    ``max_distance`` away horizontally (also where the ray does not come down to that height, or
    the camera is not above it)."""
    d = np.asarray(directions_cam, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    w = d @ np.asarray(camera.rotation_world_from_cam, dtype=np.float64).T
    height = float(camera.position_world[2])
    centre = 0.5 * sizing.person_height
    drop = height - centre
    horizontal = np.hypot(w[..., 0], w[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        reach = np.where(w[..., 2] < 0, drop * horizontal / -w[..., 2], np.inf)
    if drop <= 0:
        reach = np.full_like(horizontal, np.inf)
    reach = np.minimum(reach, sizing.max_distance)
    vertical = np.arctan2(sizing.person_height - height, reach) - np.arctan2(-height, reach)
    across = 2.0 * np.arctan(0.5 * sizing.person_width / np.hypot(reach, drop))
    extent: FloatArray = np.maximum(np.abs(vertical), across)
    return extent


def pixel_density(camera: Camera, directions_cam: np.ndarray, step: float = 1e-4) -> np.ndarray:
    """(...) the image's pixel density at each direction (pixels per radian): the smaller of its
    two principal densities across the ray (NaN outside the lens model)."""
    d = np.asarray(directions_cam, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    helper = np.where(np.abs(d[..., 2:3]) < 0.9, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(d, e1)
    p0 = camera.lens.project(d)
    j1 = (camera.lens.project(d + step * e1) - p0) / step
    j2 = (camera.lens.project(d + step * e2) - p0) / step
    jac = np.stack([j1, j2], axis=-1)  # (..., 2, 2)
    return np.linalg.svd(jac, compute_uv=False)[..., -1]


def required_half_fov(camera: Camera, directions_cam: np.ndarray, detector_px: int, sizing: SearchSizing) -> FloatArray:
    """(...) the largest half field of view a search view holding a person at each direction may
    have (the module's rule): the person-size limit, not finer than the image, within the limits."""
    half_px = 0.5 * float(detector_px)
    size = person_size(camera, directions_cam, sizing)
    by_size = np.arctan(half_px * size / sizing.person_px)
    density = pixel_density(camera, directions_cam)
    with np.errstate(divide="ignore", invalid="ignore"):
        by_image = np.where(
            np.isfinite(density) & (density > 0), np.arctan(half_px / (sizing.max_upsampling * density)), 0.0
        )
    half_fov: FloatArray = np.clip(np.maximum(by_size, by_image), sizing.min_half_fov, sizing.max_half_fov)
    return half_fov


def person_radius(camera: Camera, directions_cam: np.ndarray, sizing: SearchSizing) -> np.ndarray:
    """(...) the angular radius a view must keep free around a person's centre to hold them."""
    return 0.5 * person_size(camera, directions_cam, sizing)


def derive_layout(camera: Camera, detector_px: int, sizing: SearchSizing = SearchSizing()) -> SearchLayout:
    """The search layout for this camera and a detector whose input is ``detector_px`` wide
    (module docstring). InputError when the camera sees no part of its image circle."""
    top = min(float(camera.max_theta_in_image()), float(sizing.max_polar))
    if not np.isfinite(top) or top <= 0:
        raise InputError(
            f"camera {camera.name}: no lit image to search for people (largest angle off the lens "
            f"axis in the image: {top})"
        )
    polars = np.linspace(0.0, top, _POLARS)
    az = 2.0 * np.pi * np.arange(_AZIMUTHS) / _AZIMUTHS
    grid = _directions(polars[:, None], az[None, :])  # (P, A, 3)
    need = required_half_fov(camera, grid, detector_px, sizing).min(axis=1)  # worst azimuth
    radius = person_radius(camera, grid, sizing).max(axis=1)
    step = float(polars[1] - polars[0])

    def band(lo: float, hi: float) -> tuple[float, float]:
        """Largest half field of view allowed and person radius over polar angles lo..hi."""
        # One grid step beyond each end: the figures change little between samples.
        inside = (polars >= lo - step) & (polars <= hi + step)
        return float(need[inside].min()), float(radius[inside].max())

    # The view along the axis: as large as the band it covers allows.
    half, r = band(0.0, 0.0)
    for _ in range(8):
        cover = half - min(r, 0.5 * half)
        half, r = band(0.0, cover)
    covered = half - min(r, 0.5 * half)
    rings = [SearchRing(0.0, 1, half)]
    while covered < top - 1e-9 and len(rings) < 16:
        ring, reach = _next_ring(covered, top, band)
        if ring is None or reach <= covered + 1e-6:
            break
        rings.append(replace_azimuth(ring, len(rings)))
        covered = reach
    layout = SearchLayout(tuple(rings), min(covered, top))
    return SearchLayout(layout.rings, layout.covered, _outside_image(camera, layout, sizing))


def _cone(axis: np.ndarray, radius: float, n: int = 400) -> FloatArray:
    """n directions spread evenly over the cone of ``radius`` around the unit ``axis``."""
    k = np.arange(n) + 0.5
    z = 1.0 - (1.0 - np.cos(radius)) * k / n
    az = np.pi * (1.0 + 5**0.5) * k
    r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    local = np.stack([r * np.cos(az), r * np.sin(az), z], axis=-1)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[2]) > 0.9 else np.array([0.0, 0.0, 1.0])
    e1 = np.cross(helper, axis)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    points: FloatArray = local @ np.stack([e1, e2, axis])
    return points


def _outside_image(camera: Camera, layout: SearchLayout, sizing: SearchSizing) -> tuple[int, ...]:
    """Ring views whose holding cone (half field of view less the person's radius) has no
    direction that lands on a lit pixel of the image."""
    axes, halves = layout.all_views()
    out = []
    for i, (axis, half) in enumerate(zip(axes, halves)):
        dirs = _cone(axis, float(half))
        hold = half - np.minimum(person_radius(camera, dirs, sizing), 0.5 * half)
        dirs = dirs[np.arccos(np.clip(dirs @ axis, -1.0, 1.0)) <= hold]
        with np.errstate(invalid="ignore"):
            lit = camera.lit(camera.lens.project(dirs)) if len(dirs) else np.zeros(0, bool)
        if not lit.any():
            out.append(i)
    return tuple(out)


def replace_azimuth(ring: SearchRing, index: int) -> SearchRing:
    """Every second ring turned by half a step, so its views fall between the previous ring's."""
    return SearchRing(ring.polar, ring.count, ring.half_fov, np.pi / ring.count if index % 2 == 0 else 0.0)


def _ring_reach(inner: float, polar: float, cover: float) -> tuple[int, float] | None:
    """Fewest views on a ring at ``polar`` whose cones of radius ``cover`` leave no gap down to
    ``inner``, and the angle off the axis up to which they cover every azimuth (None: the ring
    is too far out to reach ``inner``)."""
    if polar - cover > inner:
        return None
    q = (np.cos(cover) - np.cos(polar) * np.cos(inner)) / max(np.sin(polar) * np.sin(inner), 1e-12)
    if q >= 1.0:
        return None
    half_step = float(np.arccos(max(q, -1.0)))  # the largest azimuth half-step
    count = max(3, int(np.ceil(np.pi / half_step - 1e-9)))
    c = np.cos(np.pi / count)
    a, b = np.cos(polar), np.sin(polar) * c
    norm = np.hypot(a, b)
    if np.cos(cover) > norm:
        return None
    return count, float(np.arctan2(b, a) + np.arccos(np.cos(cover) / norm))


def _next_ring(
    inner: float, top: float, band: Callable[[float, float], tuple[float, float]]
) -> tuple[SearchRing | None, float]:
    """The ring that continues the coverage from ``inner`` with the most new area per view; its
    half field of view is the smallest the rule asks for over the band it covers (found by
    shrinking until the band and the view agree)."""
    half, r = band(inner, inner)
    best: tuple[float, float, SearchRing] | None = None
    for _ in range(12):
        cover = half - min(r, 0.5 * half)
        best = None
        for polar in np.linspace(inner, min(inner + cover, top), 33)[1:]:
            got = _ring_reach(inner, float(polar), cover)
            if got is None:
                continue
            count, reach = got
            gain = (np.cos(inner) - np.cos(min(reach, top))) / count
            if best is None or gain > best[0] + 1e-12:
                best = (gain, reach, SearchRing(float(polar), count, half))
        if best is None:
            return None, inner
        new_half, new_r = band(inner, min(best[1], top))
        if new_half >= half - 1e-9 and new_r <= r + 1e-9:
            return best[2], best[1]
        half, r = min(half, new_half), max(r, new_r)
    return (best[2], best[1]) if best is not None else (None, inner)
