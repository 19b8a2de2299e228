"""Thin adapters: other stages' records -> report input records (ergopose.report.context).

The pipeline calls these when it stores the results of a session (ergopose.report.results.
save_results); each one only renames and converts (radians -> nothing: reports hold seconds and
metres; text for people), it computes no new numbers.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from ergopose.ergonomics.methods import Method, load_method
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.report.context import (ActionLevelInfo, FloorCamera, FloorItem, FloorPlan, MethodInfo, ModelInfo,
                                     Setting)

#: Furniture kinds drawn on the floor plan (table legs and brackets are left out: the top is drawn).
FLOOR_KINDS = {"shelf": "shelf", "table_top": "table", "pallet": "pallet", "carton": "carton"}


def file_sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def method_info(method: Method) -> MethodInfo:
    """A scoring method (ergopose.ergonomics.methods.Method) as recorded in a report."""
    return MethodInfo(
        name=method.name, title=method.title, source=method.source, file=Path(method.path).name,
        sha256=file_sha256(method.path), score_low=int(method.score_range[0]), score_high=int(method.score_range[1]),
        action_levels=tuple(ActionLevelInfo(level=int(a.level), low=int(a.low), high=int(a.high), label=a.label,
                                            wording=a.wording) for a in method.action_levels))


def methods_info(names: Sequence[str] = ("rula", "reba")) -> tuple[MethodInfo, ...]:
    """The packaged methods (assessments/*.toml) as report records."""
    return tuple(method_info(load_method(n)) for n in names)


def model_info(card: Any, sha256: str | None = None) -> ModelInfo:
    """A pose model card (ergopose.pose.models.ModelCard) as recorded in a report.

    sha256: the digest verified before the run (defaults to the card's pinned digest).
    """
    source = getattr(card, "source", None)
    src = source.requirement() if hasattr(source, "requirement") else str(source or "")
    return ModelInfo(name=card.name, file=card.file.filename, sha256=sha256 or card.file.sha256, source=src)


def settings_records(settings: ScoringSettings) -> tuple[Setting, ...]:
    """Every scoring setting with its value, in the dataclass's order."""
    return tuple(Setting(name=k, value=v) for k, v in settings.as_dict().items())


def floor_plan_from_boxes(boxes: Iterable[Any], area: Sequence[float] = (-3.0, 3.0, -3.0, 3.0),
                          cameras: Iterable[tuple[str, float, float]] = (), cell_m: float = 0.25) -> FloorPlan:
    """A floor plan from furniture boxes (objects with name, kind, lo, hi: ergopose.sim.scene.Box),
    the area (x_min, x_max, y_min, y_max) and camera positions (name, x, y)."""
    items = tuple(FloorItem(name=b.name, kind=FLOOR_KINDS[b.kind], x0=float(b.lo[0]), y0=float(b.lo[1]),
                            x1=float(b.hi[0]), y1=float(b.hi[1])) for b in boxes if b.kind in FLOOR_KINDS)
    return FloorPlan(x_min=float(area[0]), x_max=float(area[1]), y_min=float(area[2]), y_max=float(area[3]),
                     cell_m=cell_m, furniture=items,
                     cameras=tuple(FloorCamera(name=n, x=float(x), y=float(y)) for n, x, y in cameras))


def floor_plan_from_scene(scene: Any, cameras: Iterable[Any] = (), cell_m: float = 0.25) -> FloorPlan:
    """A floor plan from a simulated scene (ergopose.sim.scene.Scene) and its cameras
    (ergopose.geometry.camera.Camera objects, or (name, x, y) tuples)."""
    cams = []
    for k, c in enumerate(cameras):
        if isinstance(c, tuple):
            cams.append(c)
        else:
            pos = c.position_world
            cams.append((getattr(c, "name", None) or f"camera {k + 1}", float(pos[0]), float(pos[1])))
    return floor_plan_from_boxes(scene.boxes, scene.area, cams, cell_m)


def floor_plan_from_mapping(data: Mapping[str, Any], cell_m: float = 0.25) -> FloorPlan:
    """A floor plan from a scene's ``to_dict()`` (area_m, boxes with name/kind/lo/hi)."""
    class _B:
        def __init__(self, d: Mapping[str, Any]):
            self.name, self.kind, self.lo, self.hi = d["name"], d["kind"], d["lo"], d["hi"]
    return floor_plan_from_boxes([_B(b) for b in data.get("boxes", ())], data.get("area_m", (-3, 3, -3, 3)),
                                 cell_m=cell_m)
