"""Enhanced unified camera model (Khomutenko, Garcia, Martinet, "An Enhanced Unified Camera
Model", IEEE RA-L 2016), in the parametrisation of Usenko et al. 2018 (alpha, beta):

    rho = sqrt(beta (x^2 + y^2) + z^2)
    pixel = (cx + fx x / (alpha rho + (1 - alpha) z),  cy + fy y / (alpha rho + (1 - alpha) z))

Valid projections: z > -w rho with w = alpha / (1 - alpha) if alpha <= 0.5 else (1 - alpha) / alpha.
For a unit ray at angle theta this is cos(theta) > -w sqrt(beta sin^2 + cos^2), so
``max_theta`` = pi - atan(sqrt((1 - w^2) / (w^2 beta))) (pi/2 when w = 0).

Unprojection, with m = ((u - cx) / fx, (v - cy) / fy) and r^2 = |m|^2:

    mz  = (1 - beta alpha^2 r^2) / (alpha sqrt(1 - (2 alpha - 1) beta r^2) + 1 - alpha)
    ray = (mx, my, mz) / |(mx, my, mz)|

defined for r^2 <= 1 / (beta (2 alpha - 1)) when alpha > 0.5; pixels outside it, or whose ray
lies beyond max_theta, give NaN. For alpha > 0.5 the image is a bounded disc and the boundary
theta = max_theta counts as inside on both sides; for alpha <= 0.5 the image radius grows without
bound towards max_theta, which is then a supremum that is never reached (like a pinhole's 90 deg).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ergopose.errors import ConfigError
from ergopose.geometry.lenses.base import BlockwiseLens, require_finite, require_positive


@dataclass(frozen=True)
class EUCM(BlockwiseLens):
    """Enhanced unified camera model: fx, fy, cx, cy in pixels; 0 <= alpha <= 1, beta > 0."""

    fx: float
    fy: float
    cx: float
    cy: float
    alpha: float
    beta: float

    kind: ClassVar[str] = "eucm"

    _w: float = field(init=False, repr=False, compare=False)
    _cos_max: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self._coerce_parameters()
        require_positive(self.kind, fx=self.fx, fy=self.fy, beta=self.beta)
        require_finite(self.kind, cx=self.cx, cy=self.cy)
        if not 0.0 <= self.alpha <= 1.0:
            raise ConfigError(f"alpha must be in [0, 1], got {self.alpha}", field="lens.alpha")
        a = self.alpha
        w = a / (1.0 - a) if a <= 0.5 else (1.0 - a) / a
        object.__setattr__(self, "_w", w)
        if w <= 0.0:
            theta = 0.5 * math.pi
        elif w >= 1.0:
            theta = math.pi
        else:
            theta = math.pi - math.atan(math.sqrt((1.0 - w * w) / (w * w * self.beta)))
        object.__setattr__(self, "_cos_max", math.cos(theta))

    @property
    def max_theta(self) -> float:
        return math.acos(self._cos_max)

    def _project_block(self, points: np.ndarray, out: np.ndarray) -> None:
        x = points[:, 0]
        y = points[:, 1]
        z = points[:, 2]
        rho = x * x
        rho += y * y
        rho *= self.beta
        rho += z * z
        np.sqrt(rho, out=rho)
        valid = z >= -self._w * (1.0 + 1e-12) * rho  # closed set, with room for rounding
        valid &= rho > 0
        rho *= self.alpha
        rho += (1.0 - self.alpha) * z  # reaches 0 at max_theta when alpha <= 0.5 (unbounded image)
        valid &= rho > 0
        scale = np.divide(1.0, rho, out=rho)
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
        b = self.beta
        mx = pixels[:, 0] - self.cx
        mx *= 1.0 / self.fx
        my = pixels[:, 1] - self.cy
        my *= 1.0 / self.fy
        r2 = mx * mx
        r2 += my * my
        root = r2 * ((1.0 - 2.0 * a) * b)
        root += 1.0
        root[root < 0] = np.nan
        np.sqrt(root, out=root)
        root *= a
        root += 1.0 - a
        mz = r2 * (-b * a * a)
        mz += 1.0
        mz /= root
        norm = mz * mz
        norm += r2
        np.sqrt(norm, out=norm)
        np.divide(1.0, norm, out=norm)
        np.multiply(mx, norm, out=out[:, 0])
        np.multiply(my, norm, out=out[:, 1])
        rz = out[:, 2]
        np.multiply(mz, norm, out=rz)
        beyond = rz < self._cos_max - 1e-12
        out[beyond] = np.nan
