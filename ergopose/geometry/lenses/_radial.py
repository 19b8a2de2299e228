"""Shared machinery for radially symmetric lenses r_d = f * g(theta) (the paper's section on
lens models): theta is the angle between a ray and the optical axis, phi its angle around the
axis, which the lens keeps.

A model supplies g (``_rd_of_theta``) and its inverse (``_theta_of_rd``) in normalised units
(r_d / f); this class turns them into pixels with fx, fy (no skew) and principal point cx, cy:

    project:   theta = atan2(sqrt(x^2 + y^2), z)        (so rays at and beyond 90 degrees work)
               pixel = (cx + fx g(theta) x / r, cy + fy g(theta) y / r)
    unproject: m = ((u - cx) / fx, (v - cy) / fy),  r_d = |m|,  theta = g^-1(r_d)
               ray = (sin(theta) m / r_d, cos(theta))

A point on the optical axis behind the camera (x = y = 0, z < 0) and the origin have no
defined pixel (phi is undefined) and give NaN. g must be increasing on [0, max_theta], so
every pixel inside the image of max_theta has exactly one ray.
"""

from __future__ import annotations

from abc import abstractmethod

import numpy as np

from ergopose.geometry.lenses.base import BlockwiseLens, require_finite, require_positive


class RadialLens(BlockwiseLens):
    """Base of the radially symmetric models; subclasses are frozen dataclasses with fx, fy, cx, cy."""

    fx: float
    fy: float
    cx: float
    cy: float

    def _check_intrinsics(self) -> None:
        require_positive(self.kind, fx=self.fx, fy=self.fy)
        require_finite(self.kind, cx=self.cx, cy=self.cy)

    @property
    @abstractmethod
    def rd_max(self) -> float:
        """g(max_theta): the normalised radius of the image of max_theta (inf if unbounded)."""

    @abstractmethod
    def _rd_of_theta(self, theta: np.ndarray) -> np.ndarray:
        """g(theta) for theta in [0, pi]; NaN where theta > max_theta. May overwrite ``theta``."""

    @abstractmethod
    def _theta_of_rd(self, rd: np.ndarray) -> np.ndarray:
        """g^-1(rd) for rd >= 0; NaN where rd > rd_max. Must not overwrite ``rd``."""

    def radius_of_theta(self, theta: np.ndarray) -> np.ndarray:
        """Normalised radius g(theta) (multiply by fx or fy for pixels); NaN beyond max_theta."""
        theta = np.array(theta, dtype=np.float64)
        with np.errstate(all="ignore"):
            out = self._rd_of_theta(theta.copy())
            out[~(theta >= 0)] = np.nan
        return out

    def theta_of_radius(self, rd: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`radius_of_theta`; NaN for rd < 0 or rd > rd_max."""
        rd = np.array(rd, dtype=np.float64)
        with np.errstate(all="ignore"):
            out = self._theta_of_rd(rd)
            out[~(rd >= 0)] = np.nan
        return out

    def _project_block(self, points: np.ndarray, out: np.ndarray) -> None:
        x = points[:, 0]
        y = points[:, 1]
        z = points[:, 2]
        r = x * x
        scale = y * y
        r += scale
        np.sqrt(r, out=r)
        scale = self._rd_of_theta(np.arctan2(r, z))
        scale /= r  # g(theta) / r; on the axis (r = 0) fixed below
        on_axis = r == 0
        if on_axis.any():
            # In front (z > 0): g(0) = 0, the principal point. Behind or at the origin: undefined.
            scale[on_axis] = np.where(z[on_axis] > 0, 0.0, np.nan)
        scale *= self.fx
        u = out[:, 0]
        v = out[:, 1]
        np.multiply(x, scale, out=u)
        u += self.cx
        if self.fy != self.fx:
            scale *= self.fy / self.fx
        np.multiply(y, scale, out=v)
        v += self.cy

    def _unproject_block(self, pixels: np.ndarray, out: np.ndarray) -> None:
        mx = pixels[:, 0] - self.cx
        mx *= 1.0 / self.fx
        my = pixels[:, 1] - self.cy
        my *= 1.0 / self.fy
        rd = mx * mx
        rd += my * my
        np.sqrt(rd, out=rd)
        # sin and cos of theta from t = tan(theta / 2) (numpy's float64 tan is several times
        # faster than sin + cos): sin = 2t / (1 + t^2), cos = (1 - t^2) / (1 + t^2).
        t = self._theta_of_rd(rd)
        t *= 0.5
        np.tan(t, out=t)
        t2 = t * t
        inv = t2 + 1.0
        np.divide(1.0, inv, out=inv)
        np.subtract(1.0, t2, out=t2)
        np.multiply(t2, inv, out=out[:, 2])
        t *= inv
        t += t  # sin(theta)
        np.divide(t, rd, out=t, where=rd > 0)  # rd = 0: sin(0) = 0 stays, ray (0, 0, 1)
        np.multiply(mx, t, out=out[:, 0])
        np.multiply(my, t, out=out[:, 1])
