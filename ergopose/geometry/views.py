"""Upright virtual pinhole views of a fisheye camera (the paper's "rectilinear view generation").

A :class:`VirtualView` is a pinhole camera that shares its source camera's centre and is only
rotated against it. Generating the view image takes three steps per view pixel: un-project with
the view's lens, rotate into the source camera frame, project with the source lens. Done for
every pixel once, this gives a lookup map (:class:`ViewMap`) that ``cv2.remap`` applies with
sub-pixel interpolation to every frame. Building a map is separate from applying it: build once
per view, reuse for every frame the view stays put.

Rotation convention: ``rotation_cam_from_view`` (the paper's R) maps directions from the view
frame to the source camera frame: ``rays_cam = rotation_cam_from_view @ rays_view``. All frames
are camera frames (x right, y down, z forward).

Upright: the view's image "up" (-y of the view frame) is the projection of world up (+z) onto
the view's image plane, so a person standing anywhere under a ceiling camera appears upright.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import cv2
import numpy as np

from ergopose.arrays import FloatArray
from ergopose.geometry.camera import Camera, look_at_rotation
from ergopose.geometry.lenses.base import BlockwiseLens, LensModel
from ergopose.geometry.lenses.rectilinear import Rectilinear

_WORLD_UP = np.array([0.0, 0.0, 1.0])


def upright_rotation(direction_cam: np.ndarray, up_cam: np.ndarray) -> np.ndarray:
    """Rotation (3, 3) of a view looking along ``direction_cam`` whose image up is ``up_cam``.

    direction_cam: (3,) viewing direction in the source camera frame (any length).
    up_cam: (3,) the world's up direction expressed in the source camera frame.
    Returns rotation_cam_from_view: columns are the view's x (right), y (down) and z (forward)
    axes in the camera frame. When the direction is parallel to up (a person exactly below a
    ceiling camera), "upright" is undefined; the camera's own -y (then x) axis serves as up, so the
    result is still a rotation.
    """
    direction = np.asarray(direction_cam, dtype=np.float64)
    if not (np.all(np.isfinite(direction)) and np.linalg.norm(direction) > 0):
        raise ValueError("view direction must be a finite, non-zero vector")
    for up in (up_cam, (0.0, -1.0, 0.0), (1.0, 0.0, 0.0)):
        try:
            return look_at_rotation(direction, up)
        except ValueError:
            continue
    raise AssertionError("unreachable: a direction cannot be parallel to two orthogonal axes")


@dataclass(frozen=True)
class ViewMap:
    """A lookup map from destination pixels to source pixels, ready for cv2.remap.

    map_x, map_y: (H, W) float32 source pixel coordinates of each destination pixel; NaN never
    appears: pixels the source cannot see hold -1 (outside any image, so remap fills them with
    the border value). valid: (H, W) bool, True where the source lens represents the ray.
    fixed1, fixed2: the same map converted once by cv2.convertMaps to OpenCV's fixed-point
    format (1/32 px), which remaps several times faster than float maps.
    """

    map_x: np.ndarray
    map_y: np.ndarray
    valid: np.ndarray
    fixed1: np.ndarray
    fixed2: np.ndarray

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of the destination image."""
        return int(self.map_x.shape[1]), int(self.map_x.shape[0])

    def apply(
        self,
        image: np.ndarray,
        *,
        exact: bool = False,
        border_value: int | tuple[float, ...] = 0,
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """Sample ``image`` (the source) at the map with bilinear interpolation.

        exact=False uses the fixed-point map (1/32 px interpolation steps, the fast path);
        exact=True uses the float map. Destination pixels the source cannot see get border_value.
        """
        if exact:
            return cv2.remap(
                image,
                self.map_x,
                self.map_y,
                cv2.INTER_LINEAR,
                dst=out,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=border_value,
            )
        return cv2.remap(
            image,
            self.fixed1,
            self.fixed2,
            cv2.INTER_LINEAR,
            dst=out,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=border_value,
        )


#: Destination pixels per block while building a map: the rays and pixels of one block stay in
#: cache, and the scratch buffers are reused across blocks and calls (no fresh pages per map).
_MAP_BLOCK_PIXELS = 16384
_scratch = threading.local()  # per thread, so maps can be built in several threads at once


def _buffer(name: str, shape: tuple[int, ...], dtype: type = np.float64) -> np.ndarray:
    n = int(np.prod(shape))
    buffers = _scratch.__dict__
    buf = buffers.get(name)
    if buf is None or buf.size < n:
        buf = np.empty(max(n, _MAP_BLOCK_PIXELS * 3), dtype=dtype)
        buffers[name] = buf
    return buf[:n].reshape(shape)


def _bool_buffer(n: int) -> np.ndarray:
    return _buffer("bool", (n,), dtype=bool)


def build_map(
    dst_lens: LensModel, dst_size: tuple[int, int], src_lens: LensModel, rotation_src_from_dst: np.ndarray
) -> ViewMap:
    """Build the lookup map of a destination camera that is a pure rotation of a source camera.

    dst_lens, dst_size=(width, height): the camera whose image is being made.
    src_lens: the camera whose image is sampled.
    rotation_src_from_dst: (3, 3), rays_src = rotation_src_from_dst @ rays_dst.
    Works for any pair of lens models (fisheye to pinhole, pinhole to fisheye, ...). The work runs
    over blocks of rows (a loop over blocks, never over pixels).
    """
    width, height = int(dst_size[0]), int(dst_size[1])
    if width <= 0 or height <= 0:
        raise ValueError(f"view size must be positive, got {width} x {height}")
    rot = np.asarray(rotation_src_from_dst, dtype=np.float64)
    map_x = np.empty((height, width), dtype=np.float32)
    map_y = np.empty((height, width), dtype=np.float32)
    valid = np.empty((height, width), dtype=bool)
    rows_per_block = max(1, _MAP_BLOCK_PIXELS // width)
    pinhole = isinstance(dst_lens, Rectilinear)
    if isinstance(dst_lens, Rectilinear):
        xn = (np.arange(width, dtype=np.float64) - dst_lens.cx) / dst_lens.fx
        yn_all = (np.arange(height, dtype=np.float64) - dst_lens.cy) / dst_lens.fy
        col_terms = [xn * rot[k, 0] for k in range(3)]
    u = np.arange(width, dtype=np.float64)
    for r0 in range(0, height, rows_per_block):
        r1 = min(height, r0 + rows_per_block)
        n = (r1 - r0) * width
        rays = _buffer("rays", (r1 - r0, width, 3))
        if pinhole:
            # A pinhole ray is ((u - cx)/fx, (v - cy)/fy, 1): after the rotation each component is a
            # column term plus a row term, so the block costs three broadcast additions.
            yn = yn_all[r0:r1]
            for k in range(3):
                np.add((yn * rot[k, 1] + rot[k, 2])[:, None], col_terms[k][None, :], out=rays[..., k])
        else:
            grid = _buffer("grid", (r1 - r0, width, 2))
            grid[..., 0] = u[None, :]
            grid[..., 1] = np.arange(r0, r1, dtype=np.float64)[:, None]
            np.matmul(dst_lens.unproject(grid), rot.T, out=rays)
        pixels = _buffer("pixels", (n, 2))
        _project_into(src_lens, rays.reshape(n, 3), pixels)
        mx = map_x[r0:r1].reshape(n)
        my = map_y[r0:r1].reshape(n)
        mx[:] = pixels[:, 0]
        my[:] = pixels[:, 1]
        ok = valid[r0:r1].reshape(n)
        np.isfinite(mx, out=ok)  # the lens contract: NaN in both coordinates or in neither
        bad = _bool_buffer(n)
        np.logical_not(ok, out=bad)
        np.copyto(mx, -1.0, where=bad)  # outside every image: remap fills with the border value
        np.copyto(my, -1.0, where=bad)
    fixed1, fixed2 = cv2.convertMaps(map_x, map_y, cv2.CV_16SC2)
    return ViewMap(map_x=map_x, map_y=map_y, valid=valid, fixed1=fixed1, fixed2=fixed2)


def _project_into(lens: LensModel, rays: np.ndarray, out: np.ndarray) -> None:
    """lens.project(rays) written into ``out``, without a new array where the lens accepts out=."""
    if isinstance(lens, BlockwiseLens):
        lens.project(rays, out=out)
    else:
        out[...] = lens.project(rays)


@dataclass(frozen=True)
class VirtualView:
    """A virtual pinhole camera rotated against a source camera and sharing its centre.

    source: the physical (fisheye) camera.
    lens: the view's pinhole intrinsics; width, height: the view's image size in pixels.
    rotation_cam_from_view: (3, 3), the paper's R (rays_cam = R @ rays_view).
    """

    source: "Camera"
    lens: Rectilinear
    width: int
    height: int
    rotation_cam_from_view: np.ndarray

    @classmethod
    def aimed_along(
        cls, source: "Camera", direction_cam: np.ndarray, hfov: float, size: tuple[int, int] = (256, 256)
    ) -> "VirtualView":
        """An upright view looking along ``direction_cam`` with horizontal field of view ``hfov`` (rad)."""
        if not 0 < hfov < np.pi:
            raise ValueError(f"field of view must be between 0 and pi radians, got {hfov}")
        up_cam = np.asarray(source.rotation_world_from_cam, dtype=np.float64).T @ _WORLD_UP
        rot = upright_rotation(direction_cam, up_cam)
        lens = Rectilinear.from_fov(int(size[0]), int(size[1]), hfov)
        return cls(source=source, lens=lens, width=int(size[0]), height=int(size[1]), rotation_cam_from_view=rot)

    @classmethod
    def aimed_at(
        cls, source: "Camera", target_world: np.ndarray, hfov: float, size: tuple[int, int] = (256, 256)
    ) -> "VirtualView":
        """An upright view whose optical axis passes through the world point ``target_world``."""
        direction_cam = source.points_world_to_cam(np.asarray(target_world, dtype=np.float64))
        return cls.aimed_along(source, direction_cam, hfov, size)

    @property
    def K(self) -> np.ndarray:
        return self.lens.K

    @property
    def rotation_world_from_view(self) -> FloatArray:
        rotation: FloatArray = (
            np.asarray(self.source.rotation_world_from_cam, dtype=np.float64) @ self.rotation_cam_from_view
        )
        return rotation

    @property
    def projection_matrix(self) -> np.ndarray:
        """P (3, 4) = K [I|0] [R^T 0; 0 1] W^-1: homogeneous world points to view pixels (the paper's eq.)."""
        w_inv = np.linalg.inv(np.asarray(self.source.pose_world_from_cam, dtype=np.float64))
        view_from_cam = np.eye(4)
        view_from_cam[:3, :3] = self.rotation_cam_from_view.T
        return self.lens.K @ (view_from_cam @ w_inv)[:3]

    def build_map(self) -> ViewMap:
        """The lookup map from view pixels to source pixels (build once, apply to every frame)."""
        return build_map(self.lens, (self.width, self.height), self.source.lens, self.rotation_cam_from_view)

    def view_to_source_pixels(self, pixels_view: np.ndarray) -> np.ndarray:
        """(..., 2) view pixels -> (..., 2) source pixels (NaN where the source lens cannot see)."""
        rays_view = self.lens.unproject(np.asarray(pixels_view, dtype=np.float64))
        return self.source.lens.project(rays_view @ self.rotation_cam_from_view.T)

    def source_to_view_pixels(self, pixels_src: np.ndarray) -> np.ndarray:
        """(..., 2) source pixels -> (..., 2) view pixels (NaN for rays behind the view)."""
        rays_cam = self.source.lens.unproject(np.asarray(pixels_src, dtype=np.float64))
        return self.lens.project(rays_cam @ self.rotation_cam_from_view)

    def view_pixels_to_rays_cam(self, pixels_view: np.ndarray) -> FloatArray:
        """(..., 2) view pixels -> (..., 3) unit rays in the source camera frame."""
        rays_cam: FloatArray = (
            self.lens.unproject(np.asarray(pixels_view, dtype=np.float64)) @ self.rotation_cam_from_view.T
        )
        return rays_cam

    def project_world(self, points_world: np.ndarray) -> np.ndarray:
        """(..., 3) world points -> (..., 2) view pixels (NaN behind the view)."""
        points_cam = self.source.points_world_to_cam(np.asarray(points_world, dtype=np.float64))
        return self.lens.project(points_cam @ self.rotation_cam_from_view)
