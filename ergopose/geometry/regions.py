"""Lens regions: the rings of a fisheye's field of view in which accuracy is reported.

The source paper splits the field of view into three concentric rings, central, outer and edge
(its Table 1), without giving their angles. ergopose uses ONE definition everywhere (simulator,
calibration check, reconstruction diagnostics, evaluation, reports): the angle between a ray and
the lens axis, cut at 30 and 60 degrees, i.e. the 90-degree half field of a 180-degree lens in
three equal rings. The limits are a setting where a stage reports by region.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

REGION_NAMES: tuple[str, ...] = ("central", "outer", "edge")
#: Angles (degrees from the lens axis) where "outer" and "edge" begin.
DEFAULT_LIMITS_DEG: tuple[float, float] = (30.0, 60.0)


def region_index(angle_deg: ArrayLike, limits_deg: tuple[float, float] = DEFAULT_LIMITS_DEG) -> np.ndarray:
    """Region of each angle (degrees, any shape): 0 central (< first limit), 1 outer, 2 edge
    (>= second limit), -1 where the angle is NaN. An angle on a limit belongs to the outer ring."""
    a = np.round(np.asarray(angle_deg, dtype=np.float64), 9)  # 30 deg via radians and back is 29.999...
    lo, hi = float(limits_deg[0]), float(limits_deg[1])
    if not 0.0 < lo < hi:
        raise ValueError(f"lens region limits must satisfy 0 < first < second, got {limits_deg}")
    out = np.full(a.shape, -1, dtype=np.int8)
    with np.errstate(invalid="ignore"):
        out[a < lo] = 0
        out[(a >= lo) & (a < hi)] = 1
        out[a >= hi] = 2
    return out


def region_table(limits_deg: tuple[float, float] = DEFAULT_LIMITS_DEG) -> tuple[tuple[str, float, float], ...]:
    """((name, from_deg, to_deg), ...) for the three rings (edge up to 180 degrees)."""
    lo, hi = float(limits_deg[0]), float(limits_deg[1])
    return (("central", 0.0, lo), ("outer", lo, hi), ("edge", hi, 180.0))


def describe(limits_deg: tuple[float, float] = DEFAULT_LIMITS_DEG) -> str:
    """The rings in words, for reports and command output."""
    lo, hi = limits_deg
    return f"central < {lo:g} deg, outer {lo:g}-{hi:g} deg, edge >= {hi:g} deg from the lens axis"
