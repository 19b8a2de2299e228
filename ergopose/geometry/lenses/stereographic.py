"""Stereographic fisheye: r_d = 2 f tan(theta / 2) (the paper's eq. "stereographic").

Conformal (keeps small shapes' angles). Defined for every angle below pi: the image radius
grows without bound as theta approaches pi, so ``max_theta`` is pi (not reached) and every
finite pixel unprojects to a ray (theta = 2 atan(r_d / 2f)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ergopose.geometry.lenses._radial import RadialLens


@dataclass(frozen=True)
class Stereographic(RadialLens):
    """Stereographic projection with focal lengths fx, fy and principal point cx, cy (pixels)."""

    fx: float
    fy: float
    cx: float
    cy: float

    kind: ClassVar[str] = "stereographic"

    def __post_init__(self) -> None:
        self._coerce_parameters()
        self._check_intrinsics()

    @property
    def max_theta(self) -> float:
        """pi, the supremum: theta = pi itself maps to infinity."""
        return math.pi

    @property
    def rd_max(self) -> float:
        return math.inf

    def _rd_of_theta(self, theta: np.ndarray) -> np.ndarray:
        theta *= 0.5
        np.tan(theta, out=theta)
        theta *= 2.0
        return theta

    def _theta_of_rd(self, rd: np.ndarray) -> np.ndarray:
        theta = rd * 0.5
        np.arctan(theta, out=theta)
        theta *= 2.0
        return theta
