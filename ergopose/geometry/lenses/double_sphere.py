"""Double sphere camera model (Usenko, Demmel, Cremers, "The Double Sphere Camera Model", 3DV 2018).

A point is projected onto a unit sphere, then onto a second unit sphere shifted by ``xi`` along
the axis, then through a pinhole shifted by alpha / (1 - alpha):

    d1 = |(x, y, z)|,  k = xi d1 + z,  d2 = |(x, y, k)|
    pixel = (cx + fx x / (alpha d2 + (1 - alpha) k),  cy + fy y / (alpha d2 + (1 - alpha) k))

Valid projections (the paper's set Omega): z > -w2 d1 with
w1 = alpha / (1 - alpha) if alpha <= 0.5 else (1 - alpha) / alpha and
w2 = (w1 + xi) / sqrt(2 w1 xi + xi^2 + 1); so ``max_theta`` = arccos(-w2). For the TUM-VI
calibrations that is about 125 degrees off-axis: rays well beyond 90 degrees project.

Unprojection, with m = ((u - cx) / fx, (v - cy) / fy) and r^2 = |m|^2, is closed-form:

    mz  = (1 - alpha^2 r^2) / (alpha sqrt(1 - (2 alpha - 1) r^2) + 1 - alpha)
    ray = (mz xi + sqrt(mz^2 + (1 - xi^2) r^2)) / (mz^2 + r^2) (mx, my, mz) - (0, 0, xi)

defined for r^2 <= 1 / (2 alpha - 1) when alpha > 0.5 (the paper's unprojection domain);
pixels outside it, or whose ray lies beyond max_theta, give NaN. Omega is a little smaller than
the region where the image radius increases (for the TUM-VI parameters: 125.2 vs 127 degrees),
so the image of max_theta is a closed disc slightly inside the unprojection domain; the extra
ring of pixels unprojects to NaN, and project and unproject agree on one closed domain
(theta = max_theta itself counts as inside on both sides).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ergopose.errors import ConfigError
from ergopose.geometry.lenses.base import BlockwiseLens, require_finite, require_positive


@dataclass(frozen=True)
class DoubleSphere(BlockwiseLens):
    """Double sphere model: fx, fy, cx, cy in pixels; xi, alpha dimensionless (0 <= alpha <= 1)."""

    fx: float
    fy: float
    cx: float
    cy: float
    xi: float
    alpha: float

    kind: ClassVar[str] = "double_sphere"

    _w2: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self._coerce_parameters()
        require_positive(self.kind, fx=self.fx, fy=self.fy)
        require_finite(self.kind, cx=self.cx, cy=self.cy)
        if not 0.0 <= self.alpha <= 1.0:
            raise ConfigError(f"alpha must be in [0, 1], got {self.alpha}", field="lens.alpha")
        if not -1.0 < self.xi < 1.0:
            raise ConfigError(f"xi must be in (-1, 1), got {self.xi}", field="lens.xi")
        a = self.alpha
        w1 = a / (1.0 - a) if a <= 0.5 else (1.0 - a) / a
        w2 = (w1 + self.xi) / math.sqrt(2.0 * w1 * self.xi + self.xi * self.xi + 1.0)
        object.__setattr__(self, "_w2", w2)

    @property
    def max_theta(self) -> float:
        """arccos(-w2): the edge of the paper's valid projection set."""
        return math.acos(max(-1.0, min(1.0, -self._w2)))

    def _project_block(self, points: np.ndarray, out: np.ndarray) -> None:
        x = points[:, 0]
        y = points[:, 1]
        z = points[:, 2]
        r2 = x * x
        r2 += y * y
        d1 = z * z
        d1 += r2
        np.sqrt(d1, out=d1)
        valid = z >= -self._w2 * (1.0 + 1e-12) * d1  # closed set, with room for rounding
        valid &= d1 > 0
        k = d1 * self.xi
        k += z
        d2 = k * k
        d2 += r2
        np.sqrt(d2, out=d2)
        d2 *= self.alpha
        k *= 1.0 - self.alpha
        d2 += k  # the denominator; it reaches 0 at max_theta when alpha <= 0.5 (unbounded image)
        valid &= d2 > 0
        scale = np.divide(1.0, d2, out=d2)
        scale[~valid] = np.nan
        u = out[:, 0]
        v = out[:, 1]
        np.multiply(x, scale, out=u)
        u *= self.fx
        u += self.cx
        np.multiply(y, scale, out=v)
        v *= self.fy
        v += self.cy

    def _unproject_block(self, pixels: np.ndarray, out: np.ndarray) -> None:
        a = self.alpha
        xi = self.xi
        mx = pixels[:, 0] - self.cx
        mx *= 1.0 / self.fx
        my = pixels[:, 1] - self.cy
        my *= 1.0 / self.fy
        r2 = mx * mx
        r2 += my * my
        # mz = (1 - a^2 r^2) / (a sqrt(1 - (2a - 1) r^2) + 1 - a); NaN outside the domain
        # (the square root's argument turns negative exactly where r^2 > 1 / (2a - 1)).
        root = r2 * (1.0 - 2.0 * a)
        root += 1.0
        root[root < 0] = np.nan
        np.sqrt(root, out=root)
        root *= a
        root += 1.0 - a
        mz = r2 * (-a * a)
        mz += 1.0
        mz /= root
        # factor = (mz xi + sqrt(mz^2 + (1 - xi^2) r^2)) / (mz^2 + r^2)
        mz2 = mz * mz
        num = r2 * (1.0 - xi * xi)
        num += mz2
        np.sqrt(num, out=num)
        num += mz * xi
        mz2 += r2
        num /= mz2
        np.multiply(mx, num, out=out[:, 0])
        np.multiply(my, num, out=out[:, 1])
        rz = out[:, 2]
        np.multiply(mz, num, out=rz)
        rz -= xi
        # The formula lands on the unit sphere; normalise away the last rounding errors.
        norm = out[:, 0] * out[:, 0]
        norm += out[:, 1] * out[:, 1]
        norm += rz * rz
        np.sqrt(norm, out=norm)
        np.divide(1.0, norm, out=norm)
        norm[rz < -self._w2 * (1.0 + 1e-12)] = np.nan  # beyond max_theta: not the model's ray
        out *= norm[:, None]
