"""Lens models: one per file, each with project and unproject (see base.py).

``LENS_KINDS`` maps the ``kind`` name used in calibration files to the model class;
``lens_from_dict`` builds a model from such a table.
"""

from __future__ import annotations

from typing import Any

from ergopose.errors import ConfigError
from ergopose.geometry.lenses.base import LensModel
from ergopose.geometry.lenses.brown_conrady import BrownConrady
from ergopose.geometry.lenses.double_sphere import DoubleSphere
from ergopose.geometry.lenses.equidistant import Equidistant
from ergopose.geometry.lenses.equisolid import Equisolid
from ergopose.geometry.lenses.eucm import EUCM
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt
from ergopose.geometry.lenses.orthographic import Orthographic
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.geometry.lenses.stereographic import Stereographic

#: Every lens model by its ``kind`` (the name in calibration files).
LENS_KINDS: dict[str, type[LensModel]] = {
    cls.kind: cls
    for cls in (
        Rectilinear,
        Equidistant,
        Stereographic,
        Equisolid,
        Orthographic,
        KannalaBrandt,
        DoubleSphere,
        EUCM,
        BrownConrady,
    )
}


def lens_from_dict(data: Any) -> LensModel:
    """Build a lens from ``{"kind": ..., <parameters>}``.

    Raises ConfigError (field ``lens.kind`` or ``lens.<name>``) for a missing or unknown kind,
    a missing, unknown or non-numeric parameter, or parameters the model rejects.
    """
    if not isinstance(data, dict):
        raise ConfigError(
            f"expected a table with 'kind' and the lens parameters, got {type(data).__name__}", field="lens"
        )
    if "kind" not in data:
        raise ConfigError(f"missing 'kind' (one of: {', '.join(LENS_KINDS)})", field="lens.kind")
    kind = data["kind"]
    cls = LENS_KINDS.get(kind) if isinstance(kind, str) else None
    if cls is None:
        raise ConfigError(f"unknown lens kind {kind!r} (known: {', '.join(LENS_KINDS)})", field="lens.kind")
    return cls.from_dict(data)


__all__ = [
    "LENS_KINDS",
    "LensModel",
    "lens_from_dict",
    "Rectilinear",
    "Equidistant",
    "Stereographic",
    "Equisolid",
    "Orthographic",
    "KannalaBrandt",
    "DoubleSphere",
    "EUCM",
    "BrownConrady",
]
