"""Orthographic fisheye: r_d = f sin(theta) (the paper's eq. "orthographic").

Increasing only up to theta = pi/2, where the radius reaches f: ``max_theta`` is pi/2 (rays
at exactly 90 degrees still project, onto the circle r_d = f); rays beyond project to NaN and
pixels with r_d / f > 1 unproject to NaN. Inside, theta = asin(r_d / f).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.geometry.lenses._radial import RadialLens


@dataclass(frozen=True)
class Orthographic(RadialLens):
    """Orthographic projection with focal lengths fx, fy and principal point cx, cy (pixels)."""

    fx: float
    fy: float
    cx: float
    cy: float

    kind: ClassVar[str] = "orthographic"

    def __post_init__(self) -> None:
        self._coerce_parameters()
        self._check_intrinsics()

    @property
    def max_theta(self) -> float:
        return 0.5 * math.pi

    @property
    def rd_max(self) -> float:
        return 1.0

    def _rd_of_theta(self, theta: np.ndarray) -> np.ndarray:
        beyond = theta > 0.5 * math.pi
        np.sin(theta, out=theta)
        theta[beyond] = np.nan
        return theta

    def _theta_of_rd(self, rd: np.ndarray) -> FloatArray:
        theta: FloatArray = np.arcsin(rd)  # NaN for rd > 1 (outside the image circle)
        return theta
