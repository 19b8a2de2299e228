"""Equidistant fisheye: r_d = f theta (the paper's eq. "equidistant").

The radius grows linearly with the angle from the axis, for every angle up to pi: a ray 120
degrees off-axis lands at r_d = f * 2.094. ``max_theta`` is pi; a ray straight behind the
camera (theta = pi exactly) has no defined direction phi and projects to NaN. Pixels with
normalised radius r_d / f > pi unproject to NaN. This is Kannala-Brandt with k1..k4 = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ergopose.geometry.lenses._radial import RadialLens


@dataclass(frozen=True)
class Equidistant(RadialLens):
    """Equidistant projection with focal lengths fx, fy and principal point cx, cy (pixels)."""

    fx: float
    fy: float
    cx: float
    cy: float

    kind: ClassVar[str] = "equidistant"

    def __post_init__(self) -> None:
        self._coerce_parameters()
        self._check_intrinsics()

    @property
    def max_theta(self) -> float:
        return math.pi

    @property
    def rd_max(self) -> float:
        return math.pi

    def _rd_of_theta(self, theta: np.ndarray) -> np.ndarray:
        return theta

    def _theta_of_rd(self, rd: np.ndarray) -> np.ndarray:
        theta = rd.copy()
        theta[rd > math.pi] = np.nan
        return theta
