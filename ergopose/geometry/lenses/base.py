"""The contract every lens model keeps.

A lens model maps between directions in the camera frame (x right, y down, z forward) and
pixel coordinates (x right, y down; the centre of the top-left pixel is (0, 0), as in OpenCV).

- ``project(points_cam)``: (..., 3) points or directions -> (..., 2) pixels. A point the model
  cannot represent (behind a pinhole, beyond the model's largest angle, the origin) gives NaN
  in both coordinates, never a silent number.
- ``unproject(pixels)``: (..., 2) pixels -> (..., 3) unit rays. A pixel outside the model's
  image domain gives NaN in all three coordinates.
- ``max_theta``: the largest angle from the optical axis (radians) the model represents.

Both verbs are vectorised over any leading shape and never loop in Python over points.
``project(unproject(p)) == p`` holds over the whole valid domain (tests check it per model).
Models are frozen dataclasses: parameters never change after construction.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np


class LensModel(ABC):
    """A central, radially symmetric (or generic) projection between rays and pixels."""

    #: The name used in calibration files ("kannala_brandt", "double_sphere", ...).
    kind: ClassVar[str]

    @property
    @abstractmethod
    def max_theta(self) -> float:
        """Largest representable angle from the optical axis, radians."""

    @abstractmethod
    def project(self, points_cam: np.ndarray) -> np.ndarray:
        """(..., 3) points in the camera frame -> (..., 2) pixels; NaN where not representable."""

    @abstractmethod
    def unproject(self, pixels: np.ndarray) -> np.ndarray:
        """(..., 2) pixels -> (..., 3) unit rays in the camera frame; NaN outside the domain."""

    @abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """Parameters as plain numbers, with ``kind``; the calibration file stores this."""

    @classmethod
    @abstractmethod
    def from_dict(cls, data: dict[str, Any]) -> "LensModel":
        """Inverse of :meth:`to_dict`; raises ConfigError naming a missing or invalid field."""
