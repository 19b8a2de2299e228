"""A calibrated camera in the world: lens model, image size and pose.

Frames (see the package brief): world z up with the floor at z = 0, metres; camera x right,
y down, z forward (the lens axis). Pixels: x right, y down, (0, 0) the centre of the top-left
pixel, so the image covers [-0.5, width - 0.5] x [-0.5, height - 0.5].

The pose is ``rotation_world_from_cam`` R (columns: the camera's x, y, z axes in world
coordinates) and ``position_world`` c (the centre of projection): a point p_cam in the camera
frame is p_world = R p_cam + c. ``pose_world_from_cam`` is the paper's 4 x 4 W = [[R, c], [0, 1]].

NaN means "no answer": a point the lens cannot represent has NaN pixels, a pixel outside the
lens's domain has a NaN ray. Being inside the lens's domain and inside the image are separate
questions: use :meth:`Camera.in_image` for the latter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.errors import ConfigError
from ergopose.geometry.lenses.base import LensModel

#: Largest accepted deviation of a rotation from orthonormality, max |R^T R - I| (and
#: |det R - 1|). Calibration files store 17 significant digits, so real rotations are at
#: 1e-15; 1e-6 still accepts matrices rounded to 7 decimals and rejects anything that is not
#: a rotation (a scaled, sheared or mirrored matrix misses by far more).
ROTATION_TOLERANCE = 1e-6


@dataclass(frozen=True)
class CalibrationInfo:
    """Where a camera's numbers came from (all optional; shown in reports, never used in maths).

    rms_error_px: RMS reprojection error of the intrinsic calibration, pixels.
    date: when it was calibrated, ISO 8601 text ("2024-05-01" or with a time).
    method: how, in words (e.g. "cv2.fisheye.calibrate, 34 views of an 8x6 checkerboard").
    notes: anything else a safety engineer may want to know.
    """

    rms_error_px: float | None = None
    date: str | None = None
    method: str | None = None
    notes: str | None = None

    def __post_init__(self) -> None:
        if self.rms_error_px is not None:
            value = self.rms_error_px
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float, np.integer, np.floating))
                or not (math.isfinite(value) and value >= 0)
            ):
                raise ConfigError(f"expected a number >= 0, got {value!r}", field="calibration.rms_error_px")
            object.__setattr__(self, "rms_error_px", float(value))
        for field in ("date", "method", "notes"):
            value = getattr(self, field)
            if value is not None and not isinstance(value, str):
                raise ConfigError(f"expected text, got {value!r}", field=f"calibration.{field}")

    def is_empty(self) -> bool:
        return all(getattr(self, f) is None for f in ("rms_error_px", "date", "method", "notes"))


@dataclass(frozen=True, eq=False)
class Camera:
    """One physical camera.

    name: unique label (used in files, reports and logs).
    lens: the intrinsic model (pixels <-> rays in the camera frame).
    width, height: image size in pixels (positive ints).
    rotation_world_from_cam: (3, 3) rotation R, det +1 (stored read-only, float64).
    position_world: (3,) centre of projection in metres (stored read-only, float64).
    calibration: provenance of the numbers (optional, see :class:`CalibrationInfo`).
    image_circle: optional (u, v, radius) in pixels: the circle where light falls on a fisheye
        sensor. Pixels outside it see nothing whatever the lens model says (a Kannala-Brandt
        polynomial fitted inside the circle keeps going far beyond it); None when unknown or when
        the whole image is lit (pinhole cameras).
    """

    name: str
    lens: LensModel
    width: int
    height: int
    rotation_world_from_cam: np.ndarray
    position_world: np.ndarray
    calibration: CalibrationInfo = CalibrationInfo()
    image_circle: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise ConfigError(f"expected a non-empty camera name, got {self.name!r}", field="name")
        if not isinstance(self.lens, LensModel):
            raise ConfigError(f"expected a lens model, got {type(self.lens).__name__}", field="lens")
        for field in ("width", "height"):
            value = getattr(self, field)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
                raise ConfigError(f"expected a positive whole number of pixels, got {value!r}", field=field)
            object.__setattr__(self, field, int(value))
        object.__setattr__(self, "rotation_world_from_cam", check_rotation(self.rotation_world_from_cam))
        position = _finite_array(self.position_world, (3,), "position_world")
        object.__setattr__(self, "position_world", position)
        if not isinstance(self.calibration, CalibrationInfo):
            raise ConfigError(f"expected CalibrationInfo, got {type(self.calibration).__name__}", field="calibration")
        if self.image_circle is not None:
            circle = _finite_array(self.image_circle, (3,), "image_circle")
            if not circle[2] > 0:
                raise ConfigError(f"the radius must be positive, got {circle[2]!r}", field="image_circle")
            object.__setattr__(self, "image_circle", tuple(float(x) for x in circle))

    # --- identity ------------------------------------------------------------------------------

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Camera):
            return NotImplemented
        return (
            self.name == other.name
            and self.lens == other.lens
            and self.width == other.width
            and self.height == other.height
            and np.array_equal(self.rotation_world_from_cam, other.rotation_world_from_cam)
            and np.array_equal(self.position_world, other.position_world)
            and self.calibration == other.calibration
            and self.image_circle == other.image_circle
        )

    def __hash__(self) -> int:
        return hash(
            (
                self.name,
                self.lens,
                self.width,
                self.height,
                self.rotation_world_from_cam.tobytes(),
                self.position_world.tobytes(),
                self.calibration,
                self.image_circle,
            )
        )

    def __reduce__(self) -> tuple[type[Camera], tuple[Any, ...]]:
        # Rebuild through __init__ (checks, read-only arrays) when unpickled in a worker process.
        return (
            Camera,
            (
                self.name,
                self.lens,
                self.width,
                self.height,
                self.rotation_world_from_cam,
                self.position_world,
                self.calibration,
                self.image_circle,
            ),
        )

    # --- pose ----------------------------------------------------------------------------------

    @property
    def pose_world_from_cam(self) -> np.ndarray:
        """The 4 x 4 rigid transform W = [[R, c], [0, 1]] (camera frame -> world frame)."""
        pose = np.eye(4)
        pose[:3, :3] = self.rotation_world_from_cam
        pose[:3, 3] = self.position_world
        return pose

    @property
    def axis_world(self) -> np.ndarray:
        """The lens axis (camera +z) as a unit world direction."""
        return self.rotation_world_from_cam[:, 2].copy()

    def points_world_to_cam(self, points_world: np.ndarray) -> FloatArray:
        """(..., 3) world points -> (..., 3) points in the camera frame: R^T (p - c)."""
        p = np.asarray(points_world, dtype=np.float64)
        p_cam: FloatArray = (p - self.position_world) @ self.rotation_world_from_cam
        return p_cam

    def points_cam_to_world(self, points_cam: np.ndarray) -> FloatArray:
        """(..., 3) camera-frame points -> (..., 3) world points: R p + c."""
        p = np.asarray(points_cam, dtype=np.float64)
        p_world: FloatArray = p @ self.rotation_world_from_cam.T + self.position_world
        return p_world

    # --- projection ----------------------------------------------------------------------------

    def project_world(self, points_world: np.ndarray) -> np.ndarray:
        """(..., 3) world points -> (..., 2) pixels; NaN where the lens cannot represent the
        point (beyond its largest angle, or the centre of projection). Pixels may lie outside
        the image: check with :meth:`in_image`."""
        return self.lens.project(self.points_world_to_cam(points_world))

    def rays_world(self, pixels: np.ndarray) -> np.ndarray:
        """(..., 2) pixels -> (..., 3) unit world directions from ``position_world``; NaN
        outside the lens's domain (outside its image circle)."""
        rays: FloatArray = self.lens.unproject(pixels) @ self.rotation_world_from_cam.T
        return rays

    def in_image(self, pixels: np.ndarray) -> np.ndarray:
        """(..., 2) pixels -> (...) bool: finite and within [-0.5, size - 0.5] on both axes."""
        q = np.asarray(pixels, dtype=np.float64)
        u = q[..., 0]
        v = q[..., 1]
        with np.errstate(invalid="ignore"):
            return (u >= -0.5) & (u <= self.width - 0.5) & (v >= -0.5) & (v <= self.height - 0.5)

    def theta_of_pixels(self, pixels: np.ndarray) -> FloatArray:
        """(..., 2) pixels -> (...) angle from the lens axis (radians); NaN outside the lens's domain."""
        rays = self.lens.unproject(pixels)
        theta: FloatArray = np.arctan2(np.hypot(rays[..., 0], rays[..., 1]), rays[..., 2])
        return theta

    def theta_of_points_world(self, points_world: np.ndarray) -> np.ndarray:
        """(..., 3) world points -> (...) angle from the lens axis (radians), in [0, pi].

        Pure geometry, whatever the lens can image: a point beyond the lens's largest angle
        still has its angle. NaN only for the centre of projection itself.
        """
        p = self.points_world_to_cam(points_world)
        r = np.hypot(p[..., 0], p[..., 1])
        theta = np.arctan2(r, p[..., 2])
        return np.where((r == 0) & (p[..., 2] == 0), np.nan, theta)

    def lit(self, pixels: np.ndarray) -> np.ndarray:
        """(..., 2) pixels -> (...) bool: inside the image and inside ``image_circle`` (when given)."""
        inside = self.in_image(pixels)
        if self.image_circle is not None:
            q = np.asarray(pixels, dtype=np.float64)
            u, v, r = self.image_circle
            with np.errstate(invalid="ignore"):
                inside &= np.hypot(q[..., 0] - u, q[..., 1] - v) <= r
        return inside

    def field_of_view(self) -> tuple[float, float]:
        """(horizontal, vertical) field of view in radians through the principal point: the
        angles from the lens axis to the outermost lit pixels on both sides, added, along the row
        and the column of the principal point. Lit: inside the image and inside ``image_circle``
        when it is given; where the lens model's own domain ends first (NaN rays), its
        ``max_theta`` is the edge.

        Lenses without a principal point (none yet) are sampled through the image centre.
        """
        cx = float(getattr(self.lens, "cx", (self.width - 1) / 2))
        cy = float(getattr(self.lens, "cy", (self.height - 1) / 2))
        edge = self.lens.max_theta
        spans = []
        for horizontal in (True, False):
            lo, hi = -0.5, (self.width if horizontal else self.height) - 0.5
            centre = cx if horizontal else cy
            if self.image_circle is not None:
                u, v, r = self.image_circle
                off = (cy - v) if horizontal else (cx - u)
                half = math.sqrt(max(r * r - off * off, 0.0))
                mid = u if horizontal else v
                lo, hi = max(lo, mid - half), min(hi, mid + half)
            t = np.linspace(lo, hi, 4001)
            if horizontal:
                line = np.stack([t, np.full_like(t, cy)], axis=-1)
            else:
                line = np.stack([np.full_like(t, cx), t], axis=-1)
            spans.append(_span(self.theta_of_pixels(line), t < centre, edge))
        return spans[0], spans[1]

    def max_theta_in_image(self) -> float:
        """The largest angle from the lens axis seen anywhere in the lit image (radians).

        If part of the lit image lies outside the lens model's domain, the domain's edge is in the
        image and the answer is the lens's ``max_theta``; otherwise the largest angle on a
        256 x 256 grid over the image (border included) and, with ``image_circle``, 1440 points
        on the circle, over the lit points.
        """
        u = np.linspace(-0.5, self.width - 0.5, 256)
        v = np.linspace(-0.5, self.height - 0.5, 256)
        grid = np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)
        if self.image_circle is not None:
            cu, cv, r = self.image_circle
            a = np.linspace(0.0, 2.0 * math.pi, 1440, endpoint=False)
            ring = np.stack([cu + r * (1 - 1e-12) * np.cos(a), cv + r * (1 - 1e-12) * np.sin(a)], axis=-1)
            grid = np.concatenate([grid, ring])
            grid = grid[self.lit(grid)]
        theta = self.theta_of_pixels(grid)
        if not np.isfinite(theta).any():
            return math.nan
        return float(self.lens.max_theta) if np.isnan(theta).any() else float(np.nanmax(theta))

    def __repr__(self) -> str:
        return (
            f"Camera(name={self.name!r}, lens={self.lens!r}, width={self.width}, height={self.height}, "
            f"rotation_world_from_cam={self.rotation_world_from_cam.tolist()!r}, "
            f"position_world={self.position_world.tolist()!r}, calibration={self.calibration!r}"
            + (f", image_circle={self.image_circle!r})" if self.image_circle is not None else ")")
        )


def _span(theta: np.ndarray, left: np.ndarray, edge: float) -> float:
    """theta on a line through the axis -> the angle between its two outermost visible points.
    A side that leaves the lens's image circle (NaN) reaches the circle's edge, ``edge``."""
    total = 0.0
    for side in (theta[left], theta[~left]):
        if not np.isfinite(side).any():
            return math.nan
        total += edge if np.isnan(side).any() else float(np.nanmax(side))
    return total


def _finite_array(value: Any, shape: tuple[int, ...], field: str) -> np.ndarray:
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"expected numbers of shape {shape}, got {value!r}", field=field) from None
    if arr.shape != shape:
        raise ConfigError(f"expected shape {shape}, got {arr.shape}", field=field)
    if not np.isfinite(arr).all():
        raise ConfigError(f"expected finite numbers, got {arr.tolist()}", field=field)
    arr.setflags(write=False)
    return arr


def check_rotation(value: Any, field: str = "rotation_world_from_cam") -> np.ndarray:
    """A read-only float64 copy of ``value`` if it is a 3 x 3 rotation within
    :data:`ROTATION_TOLERANCE`; otherwise ConfigError naming ``field`` and the defect."""
    rot = _finite_array(value, (3, 3), field)
    deviation = float(np.abs(rot.T @ rot - np.eye(3)).max())
    if deviation > ROTATION_TOLERANCE:
        raise ConfigError(
            f"not a rotation: rows/columns are not orthonormal (max |R^T R - I| = {deviation:.3g}, "
            f"tolerance {ROTATION_TOLERANCE:g})",
            field=field,
        )
    det = float(np.linalg.det(rot))
    if abs(det - 1.0) > ROTATION_TOLERANCE:
        raise ConfigError(f"not a rotation: determinant {det:.6g} (a mirror if -1), expected +1", field=field)
    return rot


def look_at_rotation(forward_world: Any, up_world: Any = (0.0, 0.0, 1.0)) -> np.ndarray:
    """rotation_world_from_cam of a camera looking along ``forward_world`` with ``up_world``
    towards the top of the image (camera -y as close to ``up_world`` as possible).

    ValueError if forward is zero or parallel to up (use :func:`ceiling_rotation` for a
    camera looking straight down).
    """
    # Scalar arithmetic for the two 3-vector cross products, in np.cross's order of operations,
    # and norms as np.linalg.norm takes them (sqrt of the dot product): the same numbers as the
    # numpy calls, without their overhead (this runs several times per person view).
    z = np.asarray(forward_world, dtype=np.float64).reshape(3)
    up = np.asarray(up_world, dtype=np.float64).reshape(3)
    nz = math.sqrt(float(z.dot(z)))
    if not nz > 0:
        raise ValueError("forward_world must be a non-zero direction")
    z = z / nz
    x = cross3(z, up)
    nx = math.sqrt(float(x.dot(x)))
    if not nx > 1e-9 * max(math.sqrt(float(up.dot(up))), 1e-300):
        raise ValueError("forward_world is parallel to up_world: the image rotation is undefined")
    x = x / nx
    y = cross3(z, x)
    return np.array([[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]])


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The cross product of two (3,) float64 vectors: np.cross's formula and result, without its
    overhead for single vectors."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def ceiling_rotation(yaw: float = 0.0) -> np.ndarray:
    """rotation_world_from_cam of a camera looking straight down (z_cam = -z_world) whose image
    x axis points along world (cos yaw, sin yaw, 0). yaw = 0: image right is world +x and image
    down is world -y."""
    c, s = math.cos(yaw), math.sin(yaw)
    x = np.array([c, s, 0.0])
    z = np.array([0.0, 0.0, -1.0])
    return np.stack([x, np.cross(z, x), z], axis=1)


def ceiling_camera(
    name: str, lens: LensModel, width: int, height: int, position_world: Any, yaw: float = 0.0
) -> Camera:
    """A camera at ``position_world`` looking straight down (see :func:`ceiling_rotation`)."""
    return Camera(
        name=name,
        lens=lens,
        width=width,
        height=height,
        rotation_world_from_cam=ceiling_rotation(yaw),
        position_world=position_world,
    )
