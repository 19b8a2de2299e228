"""Names for numpy array types in annotations (mypy's strict mode wants a dtype on every array).

The dtype is the one the code means, not a promise checked at run time: numpy's annotations
cannot carry shapes, so a docstring or the record's field list still says the shape and the
frame (``points_world``: (N, 3) metres, ...).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

#: Floating arrays (float64 inside the product; float32 where a network or OpenCV map needs it).
FloatArray = NDArray[np.floating[Any]]
#: Integer arrays (indices, counts, frame numbers, pixel values of 8-bit images).
IntArray = NDArray[np.integer[Any]]
#: Boolean masks.
BoolArray = NDArray[np.bool_]
#: An array whose dtype varies with the input (images of any depth, table columns).
AnyArray = NDArray[Any]

__all__ = ["AnyArray", "BoolArray", "FloatArray", "IntArray"]
