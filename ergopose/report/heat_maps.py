"""Floor heat maps of the report: a value per floor cell (e.g. minutes at high risk) over the
floor plan, with the furniture outlines, the cameras and a legend of the value range per colour.

Built on the primitives of :mod:`ergopose.report.svg`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from markupsafe import Markup

from ergopose.report.svg import GRID, MUTED, esc, num, svg_element, text_width


#: Sequential palette of the floor heat maps (light to dark), 6 steps.
HEAT_COLOURS = ("#fee6ce", "#fdc38d", "#fd9a4e", "#f16913", "#c44103", "#7f2704")


#: Floor cells where the worker was, but never at the mapped level.
PRESENT_FILL = "#d4d4d4"


@dataclass(frozen=True)
class Outline:
    """A furniture outline on the floor plan (world metres): name (tooltip), corners, label drawn
    inside when it fits (e.g. the kind, "shelf")."""

    name: str
    x0: float
    y0: float
    x1: float
    y1: float
    label: str = ""


@dataclass(frozen=True)
class Marker:
    """A point on the floor plan (e.g. a camera) with its label."""

    name: str
    x: float
    y: float


def heat_map(
    grid: np.ndarray,
    extent: tuple[float, float, float, float],
    *,
    title: str,
    desc: str,
    id_prefix: str,
    unit: str,
    outlines: Sequence[Outline] = (),
    markers: Sequence[Marker] = (),
    presence: np.ndarray | None = None,
    size: float = 340,
) -> Markup:
    """A floor heat map: grid[iy, ix] is a value per cell (0 = none) over extent (x0, x1, y0, y1).

    World x runs to the right, world y upwards. Cells with presence > 0 but no value are drawn
    light grey ("present, not at risk"). A legend gives the value range of each colour step.
    """
    grid = np.asarray(grid, dtype=np.float64)
    ny, nx = grid.shape
    x0, x1, y0, y1 = extent
    pad_l, pad_t, legend_w = 30, 8, 150
    sx = size / (x1 - x0)
    sy = size / (y1 - y0)
    width = pad_l + size + 16 + legend_w
    height = pad_t + size + 30

    def px(x: float) -> float:
        return pad_l + (x - x0) * sx

    def py(y: float) -> float:
        return pad_t + (y1 - y) * sy

    out = [f'<rect x="{pad_l}" y="{pad_t}" width="{num(size)}" height="{num(size)}" fill="#ffffff" stroke="{MUTED}"/>']
    cw, ch = (x1 - x0) / nx, (y1 - y0) / ny
    vmax = float(np.nanmax(grid)) if grid.size and np.any(grid > 0) else 0.0
    steps = len(HEAT_COLOURS)
    edges = [vmax * k / steps for k in range(steps + 1)]
    if presence is not None:
        pres = np.asarray(presence, dtype=np.float64)
        iy, ix = np.nonzero((pres > 0) & ~(grid > 0))
        for a, b in zip(iy.tolist(), ix.tolist()):
            out.append(
                f'<rect x="{num(px(x0 + b * cw))}" y="{num(py(y0 + (a + 1) * ch))}" width="{num(cw * sx)}" '
                f'height="{num(ch * sy)}" fill="{PRESENT_FILL}"/>'
            )
    if vmax > 0:
        iy, ix = np.nonzero(grid > 0)
        vals = grid[iy, ix]
        k = np.minimum((vals / vmax * steps).astype(int), steps - 1)
        for a, b, kk, v in zip(iy.tolist(), ix.tolist(), k.tolist(), vals.tolist()):
            out.append(
                f'<rect x="{num(px(x0 + b * cw))}" y="{num(py(y0 + (a + 1) * ch))}" width="{num(cw * sx)}" '
                f'height="{num(ch * sy)}" fill="{HEAT_COLOURS[kk]}"><title>{v:.1f} {esc(unit)}</title></rect>'
            )
    for o in outlines:
        xa, xb = sorted((px(o.x0), px(o.x1)))
        ya, yb = sorted((py(o.y0), py(o.y1)))
        out.append(
            f'<rect x="{num(xa)}" y="{num(ya)}" width="{num(xb - xa)}" height="{num(yb - ya)}" fill="none" '
            f'stroke="#2b4c7e" stroke-width="1.5"><title>{esc(o.name)}</title></rect>'
        )
        if o.label and text_width(o.label, 9) + 4 <= xb - xa and yb - ya >= 12:
            out.append(
                f'<text x="{num((xa + xb) / 2)}" y="{num((ya + yb) / 2 + 3)}" text-anchor="middle" font-size="9" '
                f'fill="#2b4c7e">{esc(o.label)}</text>'
            )
    for m in markers:
        cx, cy = px(m.x), py(m.y)
        out.append(
            f'<g><title>{esc(m.name)}</title><path d="M{num(cx - 5)} {num(cy)}L{num(cx)} {num(cy - 5)}'
            f'L{num(cx + 5)} {num(cy)}L{num(cx)} {num(cy + 5)}Z" fill="#2b4c7e"/>'
            f'<text x="{num(cx + 7)}" y="{num(cy - 6)}" font-size="10" fill="#2b4c7e">{esc(m.name)}</text></g>'
        )
    # axes in metres
    for v in range(math.ceil(x0), math.floor(x1) + 1):
        out.append(
            f'<text x="{num(px(v))}" y="{num(pad_t + size + 14)}" text-anchor="middle" font-size="10" '
            f'fill="{MUTED}">{v}</text>'
        )
    for v in range(math.ceil(y0), math.floor(y1) + 1):
        out.append(
            f'<text x="{pad_l - 4}" y="{num(py(v) + 3)}" text-anchor="end" font-size="10" fill="{MUTED}">{v}</text>'
        )
    out.append(
        f'<text x="{num(pad_l + size / 2)}" y="{num(height - 2)}" text-anchor="middle" font-size="10" '
        f'fill="{MUTED}">x (m)</text>'
    )
    # legend
    lx = pad_l + size + 16
    out.append(f'<text x="{num(lx)}" y="{pad_t + 10}" font-size="11" font-weight="bold">{esc(unit)}</text>')
    if vmax > 0:
        for k in range(steps):
            y = pad_t + 18 + k * 20
            out.append(f'<rect x="{num(lx)}" y="{y}" width="16" height="16" fill="{HEAT_COLOURS[k]}" stroke="{GRID}"/>')
            out.append(
                f'<text x="{num(lx + 22)}" y="{y + 12}" font-size="10">{esc(_range_label(edges[k], edges[k + 1]))}</text>'
            )
        y = pad_t + 18 + steps * 20
    else:
        out.append(f'<text x="{num(lx)}" y="{pad_t + 30}" font-size="10">none</text>')
        y = pad_t + 40
    if presence is not None:
        out.append(
            f'<rect x="{num(lx)}" y="{y}" width="16" height="16" fill="{PRESENT_FILL}" stroke="{GRID}"/>'
            f'<text x="{num(lx + 22)}" y="{y + 12}" font-size="10">present, 0</text>'
        )
        y += 20
    if outlines:
        out.append(
            f'<rect x="{num(lx)}" y="{y}" width="16" height="16" fill="none" stroke="#2b4c7e" stroke-width="1.5"/>'
            f'<text x="{num(lx + 22)}" y="{y + 12}" font-size="10">furniture</text>'
        )
    return svg_element(width, height, title, desc, id_prefix, out)


def _range_label(a: float, b: float) -> str:
    """A legend step "0.25 to 0.50": enough decimals that the step's two ends differ (and at
    least as many as the upper end needs to show a non-zero value)."""
    step = abs(b - a)
    decimals = 0 if step >= 10 else max(1, min(3, math.ceil(-math.log10(step)) + 1)) if step > 0 else 1
    if step >= 1 and step < 10:
        decimals = 1

    def f(v: float) -> str:
        return f"{v:.{decimals}f}"

    return f"up to {f(b)}" if a <= 0 else f"{f(a)} to {f(b)}"
