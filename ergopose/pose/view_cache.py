"""Lookup maps of one camera's person views, cached (``PoseSettings.view_cache_px``)."""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from ergopose.geometry.camera import Camera
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.geometry.views import ViewMap, VirtualView
from ergopose.pose.view_geometry import rolled_view_rotation, roll_towards, unit, view_rotation


class ViewCache:
    """Lookup maps of one camera's person views (LRU), keyed by quantised field of view,
    direction and roll.

    The steps are chosen so that the view handed out differs from the one requested by at most
    about ``tolerance_px`` view pixels anywhere in the view: each of the three quantisations
    (field of view: scale at the view's border; direction: shift at the view's corner; roll:
    turn at the corner) moves no pixel by more than a third of it. The view handed out is an
    exact view (its map, projection and back-mapping agree); only its aim differs from the
    request. ``tolerance_px`` 0 disables the cache (every call builds a fresh map).
    """

    def __init__(self, camera: Camera, view_size: tuple[int, int], tolerance_px: float = 0.5, capacity: int = 96):
        self.camera = camera
        self.view_size = (int(view_size[0]), int(view_size[1]))
        self.tolerance_px = float(tolerance_px)
        self.capacity = int(capacity)
        self._maps: OrderedDict[tuple[int, int, int, int], tuple[VirtualView, ViewMap]] = OrderedDict()
        self.hits = 0
        self.misses = 0

    def _build(self, direction_cam: np.ndarray, half_fov: float, roll: float) -> tuple[VirtualView, ViewMap]:
        lens = Rectilinear.from_fov(self.view_size[0], self.view_size[1], 2.0 * half_fov)
        view = VirtualView(
            source=self.camera,
            lens=lens,
            width=self.view_size[0],
            height=self.view_size[1],
            rotation_cam_from_view=rolled_view_rotation(self.camera, direction_cam, roll),
        )
        return view, view.build_map()

    def get(
        self, direction_cam: np.ndarray, half_fov: float, up_cam: np.ndarray | None = None
    ) -> tuple[VirtualView, ViewMap]:
        """The view (and its map) looking along ``direction_cam`` with half field of view
        ``half_fov`` (horizontal), rolled so ``up_cam`` points up (None: upright)."""
        d = unit(np.asarray(direction_cam, dtype=np.float64))
        if self.tolerance_px <= 0:
            self.misses += 1
            return self._build(d, float(half_fov), roll_towards(self.camera, d, up_cam))
        # The requested view's up, kept when the direction is quantised (the upright frame turns
        # fast with the direction near the lens axis, so a roll relative to it would not).
        up_req = -view_rotation(self.camera, d, up_cam)[:, 1]
        third = self.tolerance_px / 3.0
        half_w = 0.5 * self.view_size[0]
        corner_px = np.hypot(half_w, 0.5 * self.view_size[1])
        # Field of view: a relative change e of tan(half_fov) moves a pixel r from the centre by r e.
        log_step = 2.0 * third / corner_px
        i_fov = int(round(np.log(np.tan(half_fov)) / log_step))
        tan_q = float(np.exp(i_fov * log_step))
        # Direction: a turn by a moves a pixel at angle t off the axis by f a / cos^2 t, most at the corner.
        focal = half_w / tan_q
        tan_corner = corner_px / focal
        dir_step = 2.0 * third / (focal * (1.0 + tan_corner**2)) / np.sqrt(2.0)  # two axes
        polar = float(np.arccos(np.clip(d[2], -1.0, 1.0)))
        azimuth = float(np.arctan2(d[1], d[0]))
        i_polar = int(round(polar / dir_step))
        polar_q = i_polar * dir_step
        # Azimuth steps grow as 1/sin(polar) so the grid is roughly uniform on the sphere.
        az_step = dir_step / max(np.sin(polar_q), dir_step)
        i_az = int(round(azimuth / az_step))
        az_q = i_az * az_step
        direction_q = np.array([np.sin(polar_q) * np.cos(az_q), np.sin(polar_q) * np.sin(az_q), np.cos(polar_q)])
        roll = roll_towards(self.camera, direction_q, up_req)
        # Roll: a turn by r moves the corner pixels by corner_px * r.
        roll_step = 2.0 * third / corner_px
        i_roll = int(round(roll / roll_step))
        key = (i_fov, i_polar, i_az, i_roll)
        hit = self._maps.get(key)
        if hit is not None:
            self._maps.move_to_end(key)
            self.hits += 1
            return hit
        self.misses += 1
        entry = self._build(direction_q, float(np.arctan(tan_q)), i_roll * roll_step)
        self._maps[key] = entry
        if len(self._maps) > self.capacity:
            self._maps.popitem(last=False)
        return entry
