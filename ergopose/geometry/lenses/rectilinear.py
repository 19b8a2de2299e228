"""Rectilinear (pinhole) projection: r_d = f tan(theta) (the paper's eq. "rectilinear").

Pixel = (fx x/z + cx, fy y/z + cy), no distortion, no skew. Only points in front of the camera
(z > 0) project; points at z <= 0 (at or behind the image plane through the centre of
projection) give NaN. Every finite pixel unprojects to a ray with z > 0, so ``max_theta`` is
pi/2, approached but never reached.

The virtual upright views that the 2D pose model sees are of this kind.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ergopose.errors import ConfigError
from ergopose.geometry.lenses.base import BlockwiseLens, require_finite, require_positive


@dataclass(frozen=True)
class Rectilinear(BlockwiseLens):
    """Pinhole camera: focal lengths fx, fy and principal point cx, cy, in pixels."""

    fx: float
    fy: float
    cx: float
    cy: float

    kind: ClassVar[str] = "rectilinear"

    def __post_init__(self) -> None:
        self._coerce_parameters()
        require_positive(self.kind, fx=self.fx, fy=self.fy)
        require_finite(self.kind, cx=self.cx, cy=self.cy)

    @classmethod
    def from_fov(cls, width: int, height: int, hfov_rad: float) -> "Rectilinear":
        """Square pixels, principal point at the image centre ((w-1)/2, (h-1)/2).

        ``hfov_rad`` is the full horizontal field of view, edge to edge of the outer pixels
        (the image spans ``width`` pixels, from -0.5 to width-0.5), so fx = (width/2)/tan(hfov/2).
        """
        if not (isinstance(width, (int, np.integer)) and width > 0):
            raise ConfigError(f"expected a positive integer width, got {width!r}", field="width")
        if not (isinstance(height, (int, np.integer)) and height > 0):
            raise ConfigError(f"expected a positive integer height, got {height!r}", field="height")
        if not (0.0 < float(hfov_rad) < math.pi):
            raise ConfigError(f"a pinhole needs 0 < hfov < pi rad, got {hfov_rad!r}", field="hfov_rad")
        f = 0.5 * width / math.tan(0.5 * float(hfov_rad))
        return cls(f, f, 0.5 * (width - 1), 0.5 * (height - 1))

    @property
    def K(self) -> np.ndarray:
        """The 3x3 intrinsic matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (a new array)."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def max_theta(self) -> float:
        """pi/2: the supremum of representable angles (rays at exactly 90 degrees give NaN)."""
        return 0.5 * math.pi

    def _project_block(self, points: np.ndarray, out: np.ndarray) -> None:
        x = points[:, 0]
        y = points[:, 1]
        z = points[:, 2]
        inv_z = np.full(z.shape, np.nan)
        np.divide(1.0, z, out=inv_z, where=z > 0)
        # NaN in x or y must blank both coordinates, as the contract says.
        inv_z += x * 0.0
        inv_z += y * 0.0
        u = out[:, 0]
        v = out[:, 1]
        np.multiply(x, inv_z, out=u)
        u *= self.fx
        u += self.cx
        np.multiply(y, inv_z, out=v)
        v *= self.fy
        v += self.cy

    def _unproject_block(self, pixels: np.ndarray, out: np.ndarray) -> None:
        x = pixels[:, 0] - self.cx
        x *= 1.0 / self.fx
        y = pixels[:, 1] - self.cy
        y *= 1.0 / self.fy
        z = x * x
        z += y * y
        z += 1.0
        np.sqrt(z, out=z)
        np.divide(1.0, z, out=z)
        z += x * 0.0  # a NaN in either coordinate blanks the whole ray
        z += y * 0.0
        np.multiply(x, z, out=out[:, 0])
        np.multiply(y, z, out=out[:, 1])
        out[:, 2] = z
