"""Pinhole camera with OpenCV's standard (Brown-Conrady) distortion: k1, k2, p1, p2, k3.

For a point (X, Y, Z) in front of the camera (Z > 0), x = X / Z, y = Y / Z, r^2 = x^2 + y^2:

    radial = 1 + k1 r^2 + k2 r^4 + k3 r^6
    x_d = x radial + 2 p1 x y + p2 (r^2 + 2 x^2)
    y_d = y radial + p1 (r^2 + 2 y^2) + 2 p2 x y
    pixel = (fx x_d + cx, fy y_d + cy)

The parameters mean exactly what cv2.projectPoints' camera matrix K = [[fx, 0, cx], [0, fy, cy],
[0, 0, 1]] and distCoeffs (k1, k2, p1, p2, k3) mean (no skew, no rational or thin-prism terms).
Pose2Sim and anipose calibrations (``fisheye = false``) use this model.

Valid domain: the polynomial folds back on itself beyond the radius where the radial mapping
r_d = r (1 + k1 r^2 + k2 r^4 + k3 r^6) stops increasing (a real lens never images those rays;
the polynomial was only fitted inside the image). ``max_r`` is that radius (in units of the
focal length; infinite if the mapping increases for ever) and ``max_theta`` = atan(max_r).
Points beyond it project to NaN; pixels are unprojected by Newton's method on the 2 x 2 system
(vectorised, from the distorted point as the start), and a pixel whose solution does not
converge to within 1e-10 (normalised units) or lies beyond ``max_r`` gives a NaN ray.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ergopose.errors import ConfigError
from ergopose.geometry.lenses.base import BlockwiseLens, require_finite, require_positive

#: Newton iterations of the unprojection (quadratic convergence: real lenses need 3-5).
NEWTON_STEPS = 30
#: Largest accepted residual of the unprojection, normalised image units (1e-10 f = 1e-7 px at f = 1000).
RESIDUAL_TOL = 1e-10


@dataclass(frozen=True)
class BrownConrady(BlockwiseLens):
    """Pinhole with OpenCV distortion: focal lengths fx, fy, principal point cx, cy (pixels),
    radial k1, k2, k3 and tangential p1, p2 (OpenCV's order of distCoeffs: k1, k2, p1, p2, k3)."""

    fx: float
    fy: float
    cx: float
    cy: float
    k1: float
    k2: float
    p1: float
    p2: float
    k3: float
    _max_r: float = field(init=False, repr=False, compare=False)

    kind: ClassVar[str] = "brown_conrady"

    def __post_init__(self) -> None:
        self._coerce_parameters()
        require_positive(self.kind, fx=self.fx, fy=self.fy)
        require_finite(self.kind, cx=self.cx, cy=self.cy)
        object.__setattr__(self, "_max_r", _radial_turning_point(self.k1, self.k2, self.k3))

    # --- OpenCV interchange ----------------------------------------------------------------------

    @classmethod
    def from_opencv(cls, K: Any, dist: Any) -> "BrownConrady":
        """From cv2's camera matrix K (3x3, no skew) and distCoeffs (4 or 5 values: k1, k2, p1, p2[, k3])."""
        K = np.asarray(K, dtype=np.float64)
        d = np.asarray(dist, dtype=np.float64).ravel()
        if K.shape != (3, 3):
            raise ConfigError(f"expected a 3x3 camera matrix, got shape {K.shape}", field="K")
        if abs(K[0, 1]) > 1e-9 * max(abs(K[0, 0]), 1.0):
            raise ConfigError(f"skew is not supported (K[0][1] = {K[0, 1]!r})", field="K")
        if d.size not in (4, 5):
            raise ConfigError(
                f"expected 4 or 5 distortion coefficients (k1, k2, p1, p2[, k3]), got {d.size}", field="distortions"
            )
        k3 = float(d[4]) if d.size == 5 else 0.0
        return cls(K[0, 0], K[1, 1], K[0, 2], K[1, 2], d[0], d[1], d[2], d[3], k3)

    def to_opencv(self) -> tuple[np.ndarray, np.ndarray]:
        """(K 3x3, distCoeffs (5,) = k1, k2, p1, p2, k3) for cv2.projectPoints / cv2.undistortPoints."""
        K = np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])
        return K, np.array([self.k1, self.k2, self.p1, self.p2, self.k3])

    # --- model -----------------------------------------------------------------------------------

    @property
    def max_r(self) -> float:
        """Largest undistorted radius (normalised by the focal length) the model represents."""
        return self._max_r

    @property
    def max_theta(self) -> float:
        return math.atan(self._max_r) if math.isfinite(self._max_r) else 0.5 * math.pi

    def _distort(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r2 = x * x + y * y
        radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))
        xy = x * y
        xd = x * radial + 2.0 * self.p1 * xy + self.p2 * (r2 + 2.0 * x * x)
        yd = y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * xy
        return xd, yd

    def _project_block(self, points: np.ndarray, out: np.ndarray) -> None:
        z = points[:, 2]
        inv_z = np.full(z.shape, np.nan)
        np.divide(1.0, z, out=inv_z, where=z > 0)
        x = points[:, 0] * inv_z
        y = points[:, 1] * inv_z
        bad = ~(x * x + y * y <= self._max_r * self._max_r)  # NaN too
        xd, yd = self._distort(x, y)
        xd[bad] = np.nan
        yd[bad] = np.nan
        np.multiply(xd, self.fx, out=out[:, 0])
        out[:, 0] += self.cx
        np.multiply(yd, self.fy, out=out[:, 1])
        out[:, 1] += self.cy

    def _unproject_block(self, pixels: np.ndarray, out: np.ndarray) -> None:
        k1, k2, k3, p1, p2 = self.k1, self.k2, self.k3, self.p1, self.p2
        xd = (pixels[:, 0] - self.cx) / self.fx
        yd = (pixels[:, 1] - self.cy) / self.fy
        x = xd.copy()
        y = yd.copy()
        for _ in range(NEWTON_STEPS):
            r2 = x * x + y * y
            radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
            dradial = 2.0 * (k1 + r2 * (2.0 * k2 + 3.0 * r2 * k3))  # d radial / d(r^2) times 2
            fx_ = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - xd
            fy_ = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - yd
            # Jacobian of (x_d, y_d) with respect to (x, y).
            a = radial + x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x
            b = x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y
            c = x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y
            d = radial + y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x
            det = a * d - b * c
            step_x = (d * fx_ - b * fy_) / det
            step_y = (a * fy_ - c * fx_) / det
            x -= step_x
            y -= step_y
            if not (np.nanmax(np.abs(step_x) + np.abs(step_y), initial=0.0) > 1e-15):
                break
        rx, ry = self._distort(x, y)
        residual = np.hypot(rx - xd, ry - yd)
        bad = ~(residual <= RESIDUAL_TOL) | ~(x * x + y * y <= self._max_r * self._max_r)
        norm = 1.0 / np.sqrt(x * x + y * y + 1.0)
        norm[bad] = np.nan
        np.multiply(x, norm, out=out[:, 0])
        np.multiply(y, norm, out=out[:, 1])
        out[:, 2] = norm


def _radial_turning_point(k1: float, k2: float, k3: float) -> float:
    """Smallest r > 0 where d/dr [r (1 + k1 r^2 + k2 r^4 + k3 r^6)] = 1 + 3 k1 r^2 + 5 k2 r^4 + 7 k3 r^6
    vanishes (inf if it never does)."""
    coeffs = np.array([7.0 * k3, 5.0 * k2, 3.0 * k1, 1.0])
    nonzero = np.flatnonzero(coeffs)
    coeffs = coeffs[nonzero[0] :]
    limit = math.inf
    if coeffs.size > 1:
        for root in np.roots(coeffs):
            if abs(root.imag) <= 1e-9 * max(1.0, abs(root)) and root.real > 0:
                limit = min(limit, math.sqrt(root.real))
    return float(limit)
