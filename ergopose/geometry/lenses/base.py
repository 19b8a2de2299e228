"""The contract every lens model keeps.

A lens model maps between directions in the camera frame (x right, y down, z forward) and
pixel coordinates (x right, y down; the centre of the top-left pixel is (0, 0), as in OpenCV).

- ``project(points_cam)``: (..., 3) points or directions -> (..., 2) pixels. A point the model
  cannot represent (behind a pinhole, beyond the model's largest angle, the origin) gives NaN
  in both coordinates, never a silent number.
- ``unproject(pixels)``: (..., 2) pixels -> (..., 3) unit rays. A pixel outside the model's
  image domain gives NaN in all three coordinates.
- ``max_theta``: the largest angle from the optical axis (radians) the model represents.

Both verbs are vectorised over any leading shape and never loop in Python over points. Models
built on :class:`BlockwiseLens` also accept ``out=`` (a C-contiguous float64 array of the result's
shape) so a caller that maps the same grid again and again (lookup maps) reuses its memory.
``project(unproject(p)) == p`` holds over the whole valid domain (tests check it per model).
Models are frozen dataclasses: parameters never change after construction.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from typing import Any, Callable, ClassVar

import numpy as np

from ergopose.errors import ConfigError


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


#: Points per block in :class:`BlockwiseLens`. The arithmetic runs on blocks of this many points so
#: that the temporaries (128 KiB each) stay in cache and are reused by the allocator; whole-array
#: temporaries of 400k points cost more in fresh memory pages than in arithmetic.
BLOCK_POINTS = 16384


class BlockwiseLens(LensModel):
    """A lens model whose project/unproject run a kernel over blocks of points.

    Subclasses implement ``_project_block(points (n, 3), out (n, 2))`` and
    ``_unproject_block(pixels (n, 2), out (n, 3))``; both read float64 arrays (columns may be
    strided) and write every element of ``out``, NaN where the model is undefined. The Python
    loop here runs over blocks of :data:`BLOCK_POINTS` points, never over single points.
    """

    def project(self, points_cam: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(..., 3) points in the camera frame -> (..., 2) pixels; NaN where not representable."""
        return _blockwise(self._project_block, points_cam, 3, 2, out, "points_cam")

    def unproject(self, pixels: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(..., 2) pixels -> (..., 3) unit rays in the camera frame; NaN outside the domain."""
        return _blockwise(self._unproject_block, pixels, 2, 3, out, "pixels")

    def to_dict(self) -> dict[str, Any]:
        """``kind`` and every constructor parameter, as plain floats."""
        return {"kind": self.kind, **{f.name: getattr(self, f.name) for f in _init_fields(self)}}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "BlockwiseLens":
        """Build from a :meth:`to_dict` table; ConfigError names a missing, unknown or bad field."""
        return cls(**parameters_from_dict(data, cls.kind, tuple(f.name for f in _init_fields(cls))))

    def _coerce_parameters(self) -> None:
        """In ``__post_init__`` of a frozen dataclass: every parameter becomes a finite float."""
        for f in _init_fields(self):
            object.__setattr__(self, f.name, finite_number(getattr(self, f.name), f"lens.{f.name}"))

    @abstractmethod
    def _project_block(self, points: np.ndarray, out: np.ndarray) -> None: ...

    @abstractmethod
    def _unproject_block(self, pixels: np.ndarray, out: np.ndarray) -> None: ...


def _blockwise(
    kernel: Callable[..., Any], data: Any, width_in: int, width_out: int, out: np.ndarray | None, what: str
) -> np.ndarray:
    arr = as_points(data, width_in, what)
    shape = arr.shape[:-1] + (width_out,)
    if out is None:
        out = np.empty(shape)
    elif out.shape != shape or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise ValueError(f"out must be a C-contiguous float64 array of shape {shape}, got {out.dtype} {out.shape}")
    flat_in = arr.reshape(-1, width_in)
    flat_out = out.reshape(-1, width_out)
    n = flat_in.shape[0]
    with np.errstate(all="ignore"):  # NaN marks the points outside the domain, by design
        for start in range(0, n, BLOCK_POINTS):
            stop = min(start + BLOCK_POINTS, n)
            kernel(flat_in[start:stop], flat_out[start:stop])
    return out


def _init_fields(obj_or_cls: Any) -> tuple[dataclasses.Field[Any], ...]:
    return tuple(f for f in dataclasses.fields(obj_or_cls) if f.init)


# --- helpers shared by the models (parameter parsing and array shapes) ---------------------------


def parameters_from_dict(
    data: Any, kind: str, required: tuple[str, ...], optional: dict[str, float] | None = None
) -> dict[str, float]:
    """Check a lens-parameter table and return its numbers by name.

    ``data`` must be a mapping with the given ``required`` names (and optionally ``kind``, which
    must equal ``kind``, and the ``optional`` names, with their defaults). Every value must be a
    real, finite number (bool is not a number here). Unknown keys are rejected: a typo in a
    calibration file must not silently fall back to a default. Raises ConfigError naming the field.
    """
    optional = optional or {}
    if not isinstance(data, dict):
        raise ConfigError(f"expected a table of {kind} lens parameters, got {type(data).__name__}", field="lens")
    if "kind" in data and data["kind"] != kind:
        raise ConfigError(f"expected kind '{kind}', got {data['kind']!r}", field="lens.kind")
    allowed = set(required) | set(optional) | {"kind"}
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise ConfigError(
            f"unknown key(s) {', '.join(map(repr, unknown))} for a {kind} lens (allowed: {', '.join(sorted(allowed))})",
            field=f"lens.{unknown[0]}",
        )
    out: dict[str, float] = {}
    for name in required:
        if name not in data:
            raise ConfigError(f"missing parameter '{name}' of the {kind} lens", field=f"lens.{name}")
    for name in (*required, *optional):
        value = data.get(name, optional.get(name))
        out[name] = finite_number(value, f"lens.{name}")
    return out


def finite_number(value: Any, field: str) -> float:
    """``value`` as a float; ConfigError naming ``field`` unless it is a real finite number."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ConfigError(f"expected a number, got {value!r}", field=field)
    number = float(value)
    if not np.isfinite(number):
        raise ConfigError(f"expected a finite number, got {number!r}", field=field)
    return number


def require_positive(kind: str, **values: float) -> None:
    """ConfigError naming the first of ``values`` that is not a finite number > 0."""
    for name, value in values.items():
        if not (np.isfinite(value) and value > 0):
            raise ConfigError(f"the {kind} lens needs {name} > 0, got {value!r}", field=f"lens.{name}")


def require_finite(kind: str, **values: float) -> None:
    """ConfigError naming the first of ``values`` that is not finite."""
    for name, value in values.items():
        if not np.isfinite(value):
            raise ConfigError(f"the {kind} lens needs a finite {name}, got {value!r}", field=f"lens.{name}")


def as_points(points: Any, width: int, what: str) -> np.ndarray:
    """``points`` as a float64 array whose last axis has ``width`` entries (no copy if possible)."""
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != width:
        raise ValueError(f"{what} must have shape (..., {width}), got {arr.shape}")
    return arr
