"""Equisolid-angle fisheye: r_d = 2 f sin(theta / 2) (the paper's eq. "equisolid").

Equal solid angles cover equal image areas. Increasing for every angle up to pi, where the
radius reaches its largest value 2f: ``max_theta`` is pi, pixels with r_d / f > 2 unproject to
NaN, and theta = 2 asin(r_d / 2f) inside. A ray straight behind (theta = pi exactly) has no
defined direction phi and projects to NaN.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ergopose.geometry.lenses._radial import RadialLens


@dataclass(frozen=True)
class Equisolid(RadialLens):
    """Equisolid-angle projection with focal lengths fx, fy and principal point cx, cy (pixels)."""

    fx: float
    fy: float
    cx: float
    cy: float

    kind: ClassVar[str] = "equisolid"

    def __post_init__(self) -> None:
        self._coerce_parameters()
        self._check_intrinsics()

    @property
    def max_theta(self) -> float:
        return math.pi

    @property
    def rd_max(self) -> float:
        return 2.0

    def _rd_of_theta(self, theta: np.ndarray) -> np.ndarray:
        theta *= 0.5
        np.sin(theta, out=theta)
        theta *= 2.0
        return theta

    def _theta_of_rd(self, rd: np.ndarray) -> np.ndarray:
        theta = rd * 0.5
        np.arcsin(theta, out=theta)  # NaN for rd > 2 (outside the image circle)
        theta *= 2.0
        return theta
