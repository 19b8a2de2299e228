"""Where the fisheye 2D stage looks for people it does not follow yet: the detector's search
views (placed from the lens, ergopose/pose/search_layout.py, and run on a schedule) and moving
blobs from background subtraction (motion cues).

Both give bearings (rays in the camera frame) and angular sizes; the estimator
(ergopose/pose/fisheye.py) turns them into targets.
"""

from __future__ import annotations

import dataclasses
import threading
from collections import OrderedDict
from typing import Any, Sequence

import cv2
import numpy as np

from ergopose.errors import ConfigError
from ergopose.geometry.camera import Camera
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.geometry.views import ViewMap, VirtualView
from ergopose.pose.records import Detector
from ergopose.pose.search_layout import SearchLayout, SearchSizing, derive_layout, fixed_layout
from ergopose.pose.settings import PoseSettings
from ergopose.pose.view_geometry import angle_between, unit, view_rotation


def search_sizing(s: PoseSettings) -> SearchSizing:
    """The search-layout rule's inputs from the settings."""
    return SearchSizing(
        person_height=s.search_person_height,
        max_distance=s.search_max_distance,
        person_px=s.search_person_px,
        max_upsampling=s.search_max_upsampling,
        min_half_fov=s.search_min_half_fov,
        max_half_fov=s.search_max_half_fov,
        max_polar=s.search_max_polar,
    )


_Built = tuple[SearchLayout, tuple[tuple[VirtualView, ViewMap], ...], np.ndarray]

#: The search views this process has built, by camera, detector input size and search settings.
#: A video is assessed in chunks and each chunk makes its cameras' stages again (and the photo
#: evaluation makes one per case): with this they reuse the maps instead of building them anew
#: (0.16-0.18 s per camera at 1024 x 768, 48-49 views, measured 2026-11-29). A view's maps take
#: 0.75 MB at 224 x 224, a 1024 x 768 camera's 36 MB; beyond ``_BUILT_MAX_BYTES`` the least
#: recently used camera goes (the newest always stays).
_BUILT: OrderedDict[tuple[Any, ...], _Built] = OrderedDict()
_BUILT_MAX_BYTES = 256_000_000
_BUILT_LOCK = threading.Lock()


def _map_bytes(built: _Built) -> int:
    return sum(a.nbytes for _, m in built[1] for a in (m.map_x, m.map_y, m.valid, m.fixed1, m.fixed2))


def _built_key(camera: Camera, size: tuple[int, int], settings: PoseSettings) -> tuple[Any, ...]:
    """What the search views depend on: the camera (lens, image size and circle, pose: compared
    by value), the detector's input size and every ``search_*`` setting."""
    searched = tuple(
        (f.name, getattr(settings, f.name)) for f in dataclasses.fields(settings) if f.name.startswith("search_")
    )
    return (camera, size, searched)


class SearchViews:
    """The detector's search views of one camera and the schedule that runs them.

    size: the detector's input size (None: no detector, no search views).
    layout: the search layout of ``settings.search_layout`` (None without a detector).
    views: (view, map) of each search view (built once per process for a camera, size and
        search settings, :data:`_BUILT`; the maps are only read).
    half_fov: (V,) each view's half field of view.
    """

    def __init__(self, camera: Camera, size: tuple[int, int] | None, settings: PoseSettings):
        self.camera = camera
        self.settings = settings
        self.layout: SearchLayout | None = None
        self.views: list[tuple[VirtualView, ViewMap]] = []
        self.half_fov = np.zeros(0)
        self._next = 0
        self._credit = 0.0
        if size is not None:
            self._take_views((int(size[0]), int(size[1])))

    def _take_views(self, size: tuple[int, int]) -> None:
        """The search views of ``settings.search_layout``: built by this process before, or now."""
        key = _built_key(self.camera, size, self.settings)
        with _BUILT_LOCK:
            built = _BUILT.get(key)
            if built is not None:
                _BUILT.move_to_end(key)
        if built is None:
            built = self._make_views(size)
            with _BUILT_LOCK:
                _BUILT[key] = built
                while len(_BUILT) > 1 and sum(_map_bytes(b) for b in _BUILT.values()) > _BUILT_MAX_BYTES:
                    _BUILT.popitem(last=False)
        self.layout, views, self.half_fov = built
        self.views = list(views)

    def _make_views(self, size: tuple[int, int]) -> _Built:
        """The layout of ``settings.search_layout``, its views with their maps, and each view's
        half field of view."""
        s = self.settings
        if s.search_layout == "lens":
            layout = derive_layout(self.camera, size[0], search_sizing(s))
        elif s.search_layout == "fixed":
            layout = fixed_layout(
                tuple(s.search_rings), s.search_views_per_ring, s.search_half_fov, self.camera.max_theta_in_image()
            )
        else:
            raise ConfigError(f"must be 'lens' or 'fixed', got {s.search_layout!r}", field="search_layout")
        axes, halves = layout.views()
        rolls: list[np.ndarray | None] = [None] * len(axes)
        if s.search_centre_rolls > 1 and layout.rings and layout.rings[0].polar == 0:
            # The view along the lens axis has no world up (people lie in every direction in it):
            # copies turned about the axis, so each person is near upright in one of them.
            k = int(s.search_centre_rolls)
            az = 2 * np.pi * np.arange(k) / k
            axes = np.concatenate([np.repeat(axes[:1], k, axis=0), axes[1:]])
            halves = np.concatenate([np.repeat(halves[:1], k), halves[1:]])
            turned: list[np.ndarray | None] = [np.array([np.cos(a), np.sin(a), 0.0]) for a in az]
            rolls = turned + rolls[1:]
        views = []
        for d, half, up in zip(axes, halves, rolls):
            if up is None:
                view = VirtualView.aimed_along(self.camera, d, hfov=2 * float(half), size=size)
            else:
                lens = Rectilinear.from_fov(size[0], size[1], 2 * float(half))
                view = VirtualView(
                    source=self.camera,
                    lens=lens,
                    width=size[0],
                    height=size[1],
                    rotation_cam_from_view=view_rotation(self.camera, d, up),
                )
            view_map = view.build_map()
            for array in (view_map.map_x, view_map.map_y, view_map.valid, view_map.fixed1, view_map.fixed2):
                array.flags.writeable = False  # shared by every stage of this camera in the process
            views.append((view, view_map))
        return layout, tuple(views), halves

    def period(self, following: bool) -> int:
        """Frames one pass over the search views takes (``PoseSettings.search_every``)."""
        s = self.settings
        every, budget = (
            (s.search_every, s.search_views_per_frame)
            if following
            else (s.idle_search_every, s.idle_search_views_per_frame)
        )
        return max(int(every), int(np.ceil(len(self.views) / budget - 1e-9)))

    def scheduled(self, period: int, seen: int) -> list[int]:
        """Indices of the search views to run on a frame, ``seen`` frames after the estimator's
        first: all of them on the first frame; with ``search_spread`` the next ones round the
        layout, about views / period per frame; otherwise all of them every ``period`` frames."""
        n = len(self.views)
        if n == 0:
            return []
        if seen == 0:
            self._next, self._credit = 0, 0.0
            return list(range(n))
        if not self.settings.search_spread:
            return list(range(n)) if seen % period == 0 else []
        self._credit += n / period
        k = min(int(self._credit + 1e-9), n)
        self._credit -= k
        picked = [(self._next + i) % n for i in range(k)]
        self._next = (self._next + k) % n
        return picked

    def near(self, directions: Sequence[np.ndarray]) -> list[int]:
        """Indices of the search views whose field holds one of these directions."""
        axes = np.stack([v.rotation_cam_from_view[:, 2] for v, _ in self.views])
        dirs = np.stack([unit(np.asarray(d, dtype=np.float64)) for d in directions])
        inside = angle_between(axes[:, None], dirs[None]) < self.half_fov[:, None]
        return [int(i) for i in np.nonzero(inside.any(axis=1))[0]]

    def detections(self, frame_bgr: np.ndarray, detector: Detector, which: Sequence[int]) -> list[np.ndarray]:
        """The detector on the search views ``which``: for each person it finds with at least
        ``min_detector_score``, the rays (2, 3) in the camera frame to their hip centre and to
        the detector's second point (along the body axis from the hips, beyond the head)."""
        found = []
        for view, view_map in [self.views[i] for i in which]:
            image = view_map.apply(frame_bgr)
            for det in detector(image):
                if det.score < self.settings.min_detector_score:
                    continue
                centre = det.hip_centre[None]
                edge = det.keypoints[1][None]
                rays = view.view_pixels_to_rays_cam(np.vstack([centre, edge]))
                if np.isfinite(rays).all():
                    found.append(rays)
        return found


class MotionCues:
    """Moving blobs in one camera's frames (background subtraction on a downscaled frame)."""

    def __init__(self, camera: Camera, settings: PoseSettings):
        self.camera = camera
        self.settings = settings
        self._background = cv2.createBackgroundSubtractorMOG2(history=300, varThreshold=25, detectShadows=False)

    def __call__(self, frame_bgr: np.ndarray, seen: int) -> list[tuple[np.ndarray, float]]:
        """The background model learns from this frame; the moving blobs in it (none for the
        first ``motion_warmup`` frames, ``seen`` being the frames seen before this one), each
        as the ray to its centre and its angular radius (to its bounding box's corners)."""
        s = self.settings
        small = cv2.resize(
            frame_bgr, None, fx=1.0 / s.motion_scale, fy=1.0 / s.motion_scale, interpolation=cv2.INTER_AREA
        )
        mask = self._background.apply(small)
        if seen < s.motion_warmup:
            return []
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
        mask = cv2.dilate(mask, np.ones((5, 5), np.uint8))
        count, _, stats, centroids = cv2.connectedComponentsWithStats((mask > 127).astype(np.uint8))
        min_area = s.motion_min_area * mask.shape[0] * mask.shape[1]
        keep = np.nonzero(stats[1:, cv2.CC_STAT_AREA] >= min_area)[0] + 1
        if keep.size == 0:
            return []
        scale = float(s.motion_scale)
        centre_px = (centroids[keep] + 0.5) * scale - 0.5
        x0, y0 = stats[keep, cv2.CC_STAT_LEFT], stats[keep, cv2.CC_STAT_TOP]
        w, h = stats[keep, cv2.CC_STAT_WIDTH], stats[keep, cv2.CC_STAT_HEIGHT]
        corners = (
            np.stack(
                [
                    np.stack([x0, y0], -1),
                    np.stack([x0 + w, y0], -1),
                    np.stack([x0, y0 + h], -1),
                    np.stack([x0 + w, y0 + h], -1),
                ],
                axis=1,
            )
            * scale
        )
        centre_rays = self.camera.lens.unproject(centre_px)
        corner_rays = self.camera.lens.unproject(corners)
        radius = np.nanmax(angle_between(corner_rays, centre_rays[:, None, :]), axis=1)
        ok = np.isfinite(centre_rays).all(axis=1) & np.isfinite(radius)
        return [(centre_rays[i], float(radius[i])) for i in np.nonzero(ok)[0]]
