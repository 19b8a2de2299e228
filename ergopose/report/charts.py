"""Bar charts of the report: stacked bars (a worker's time per level, per body part), stacked
columns (time per level in each hour), box plots (limb lengths) and bar panels (detection rates).

Built on the primitives of :mod:`ergopose.report.svg` (escaping, numbers, the hatched "not
scored" fill, the ``<svg>`` element).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

from markupsafe import Markup

from ergopose.report.svg import (
    GRID,
    MUTED,
    TEXT,
    esc,
    fit_label,
    hatch_defs,
    label_fill,
    num,
    segment_fill,
    svg_element,
    text_width,
)


# ------------------------------------------------------------------------ stacked bars


@dataclass(frozen=True)
class Segment:
    """One part of a stacked bar: value (any unit), fill colour (None = not scored, hatched),
    short label drawn inside when it fits (e.g. "AL3"), long label for the tooltip."""

    value: float
    colour: str | None
    short: str
    long: str


@dataclass(frozen=True)
class StackRow:
    """A bar of segments with its label on the left."""

    label: str
    segments: tuple[Segment, ...]


def _hatch_legend(x: float, y: float, label: str, id_prefix: str) -> str:
    """A legend entry for the hatched fill: swatch and label, baseline at y."""
    return (
        f'<rect x="{num(x)}" y="{num(y - 10)}" width="12" height="12" fill="url(#{esc(id_prefix)}-hatch)" '
        f'stroke="{MUTED}" stroke-width="0.5"/><text x="{num(x + 17)}" y="{num(y)}" font-size="11">{esc(label)}</text>'
    )


def _has_hatch(groups: Iterable[Sequence[Segment]]) -> bool:
    return any(seg.colour is None and seg.value > 0 for segs in groups for seg in segs)


def stacked_bars(
    rows: Sequence[StackRow],
    *,
    title: str,
    desc: str,
    id_prefix: str,
    total: float | None = None,
    width: float = 720,
    label_width: float = 170,
    bar_height: float = 26,
    axis_label: str = "share of observed time (%)",
    hatch_label: str = "not scored",
) -> Markup:
    """Horizontal stacked bars, one per row, scaled to ``total`` (default: each row's own sum = 100 %).
    Row labels are shortened to fit (the full label is their tooltip); when a hatched segment is
    drawn, a legend under the axis names it (``hatch_label``)."""
    plot_w = width - label_width - 16
    top = 8
    hatched = _has_hatch(r.segments for r in rows)
    height = top + len(rows) * (bar_height + 8) + 34
    out = [hatch_defs(id_prefix)]
    if hatched:
        out.append(_hatch_legend(label_width, height + 14, hatch_label, id_prefix))
    x0 = label_width
    for k in range(5):
        x = x0 + plot_w * k / 4
        out.append(f'<line x1="{num(x)}" y1="{top - 2}" x2="{num(x)}" y2="{num(height - 28)}" stroke="{GRID}"/>')
        out.append(f'<text x="{num(x)}" y="{num(height - 14)}" text-anchor="middle" fill="{MUTED}">{25 * k}</text>')
    out.append(
        f'<text x="{num(x0 + plot_w / 2)}" y="{num(height - 1)}" text-anchor="middle" fill="{MUTED}">'
        f"{esc(axis_label)}</text>"
    )
    for i, row in enumerate(rows):
        y = top + i * (bar_height + 8)
        out.append(
            f'<text x="{num(label_width - 8)}" y="{num(y + bar_height / 2 + 4)}" text-anchor="end">'
            f"<title>{esc(row.label)}</title>{esc(fit_label(row.label, label_width - 12, 12))}</text>"
        )
        denom = total if total is not None else sum(max(s.value, 0.0) for s in row.segments)
        x = x0
        for seg in row.segments:
            if denom <= 0 or seg.value <= 0:
                continue
            w = plot_w * seg.value / denom
            out.append(
                f'<rect x="{num(x)}" y="{num(y)}" width="{num(max(w, 0.5))}" height="{num(bar_height)}" '
                f'fill="{segment_fill(seg.colour, id_prefix)}" stroke="#ffffff" stroke-width="0.5">'
                f"<title>{esc(seg.long)}</title></rect>"
            )
            if seg.short and text_width(seg.short, 11) + 6 <= w:
                out.append(
                    f'<text x="{num(x + w / 2)}" y="{num(y + bar_height / 2 + 4)}" text-anchor="middle" '
                    f'font-size="11" fill="{label_fill(seg.colour)}">{esc(seg.short)}</text>'
                )
            x += w
    return svg_element(width, height + (20 if hatched else 0), title, desc, id_prefix, out)


@dataclass(frozen=True)
class StackColumn:
    """A vertical stacked column (e.g. one hour) with its label under it."""

    label: str
    segments: tuple[Segment, ...]


def stacked_columns(
    columns: Sequence[StackColumn],
    *,
    title: str,
    desc: str,
    id_prefix: str,
    y_max: float,
    y_label: str,
    y_ticks: Sequence[float],
    width: float = 720,
    height: float = 260,
    hatch_label: str = "not scored",
) -> Markup:
    """Vertical stacked columns on a common axis 0..y_max (e.g. minutes of each hour); a legend
    names the hatched fill when it is drawn."""
    left, right, top, bottom = 46, 8, 10, 40
    hatched = _has_hatch(c.segments for c in columns)
    plot_w, plot_h = width - left - right, height - top - bottom
    n = max(len(columns), 1)
    slot = plot_w / n
    col_w = min(slot * 0.78, 60)
    out = [hatch_defs(id_prefix)]

    def ypix(v: float) -> float:
        return top + plot_h * (1 - v / y_max)

    for t in y_ticks:
        out.append(
            f'<line x1="{left}" y1="{num(ypix(t))}" x2="{num(width - right)}" y2="{num(ypix(t))}" stroke="{GRID}"/>'
        )
        out.append(
            f'<text x="{left - 6}" y="{num(ypix(t) + 4)}" text-anchor="end" fill="{MUTED}">{esc(_tick(t))}</text>'
        )
    out.append(
        f'<text transform="translate(12 {num(top + plot_h / 2)}) rotate(-90)" text-anchor="middle" '
        f'fill="{MUTED}">{esc(y_label)}</text>'
    )
    every = max(1, math.ceil(n / max(1, plot_w // 44)))
    for i, col in enumerate(columns):
        cx = left + slot * (i + 0.5)
        y = ypix(0)
        for seg in col.segments:
            if seg.value <= 0:
                continue
            h = plot_h * seg.value / y_max
            out.append(
                f'<rect x="{num(cx - col_w / 2)}" y="{num(y - h)}" width="{num(col_w)}" height="{num(max(h, 0.5))}" '
                f'fill="{segment_fill(seg.colour, id_prefix)}" stroke="#ffffff" stroke-width="0.5">'
                f"<title>{esc(col.label)}: {esc(seg.long)}</title></rect>"
            )
            if seg.short and h >= 14 and text_width(seg.short, 10) + 4 <= col_w:
                out.append(
                    f'<text x="{num(cx)}" y="{num(y - h / 2 + 4)}" text-anchor="middle" font-size="10" '
                    f'fill="{label_fill(seg.colour)}">{esc(seg.short)}</text>'
                )
            y -= h
        if i % every == 0:
            out.append(
                f'<text x="{num(cx)}" y="{num(height - bottom + 16)}" text-anchor="middle" fill="{MUTED}">'
                f"{esc(col.label)}</text>"
            )
    if hatched:
        out.append(_hatch_legend(left, height + 10, hatch_label, id_prefix))
    return svg_element(width, height + (18 if hatched else 0), title, desc, id_prefix, out)


def _tick(v: float) -> str:
    return f"{v:g}"


# ------------------------------------------------------------------------------- box plots


@dataclass(frozen=True)
class BoxRow:
    """One box: whiskers, quartiles and median in the axis unit; n = number of values."""

    label: str
    whisker_lo: float
    q1: float
    median: float
    q3: float
    whisker_hi: float
    n: int


def box_plots(
    rows: Sequence[BoxRow],
    *,
    title: str,
    desc: str,
    id_prefix: str,
    unit: str,
    x_min: float | None = None,
    x_max: float | None = None,
    width: float = 720,
    label_width: float = 150,
    row_height: float = 22,
) -> Markup:
    """Horizontal box plots on one axis (rows with n = 0 get a 'no data' note)."""
    finite = [v for r in rows if r.n > 0 for v in (r.whisker_lo, r.whisker_hi) if math.isfinite(v)]
    lo = x_min if x_min is not None else (min(finite) if finite else 0.0)
    hi = x_max if x_max is not None else (max(finite) if finite else 1.0)
    if hi <= lo:
        hi = lo + 1.0
    step = _nice_step((hi - lo) / 6)
    lo, hi = math.floor(lo / step) * step, math.ceil(hi / step) * step
    plot_w = width - label_width - 20
    top = 6
    height = top + len(rows) * row_height + 40

    def xpix(v: float) -> float:
        return label_width + plot_w * (v - lo) / (hi - lo)

    out = []
    t = lo
    while t <= hi + step * 1e-6:
        x = xpix(t)
        out.append(
            f'<line x1="{num(x)}" y1="{top}" x2="{num(x)}" y2="{num(height - 34)}" stroke="{GRID}" stroke-width="0.75"/>'
        )
        out.append(
            f'<text x="{num(x)}" y="{num(height - 20)}" text-anchor="middle" fill="{MUTED}" font-size="11">'
            f"{esc(f'{t:g}')}</text>"
        )
        t += step
    out.append(
        f'<text x="{num(label_width + plot_w / 2)}" y="{num(height - 4)}" text-anchor="middle" fill="{MUTED}" '
        f'font-size="11">{esc(unit)}</text>'
    )
    for i, r in enumerate(rows):
        y = top + i * row_height
        cy = y + row_height / 2
        out.append(
            f'<text x="{num(label_width - 8)}" y="{num(cy + 4)}" text-anchor="end" font-size="11">{esc(r.label)}</text>'
        )
        vals = (r.whisker_lo, r.q1, r.median, r.q3, r.whisker_hi)
        if r.n <= 0 or not all(math.isfinite(v) for v in vals):
            out.append(
                f'<text x="{num(label_width + 4)}" y="{num(cy + 4)}" fill="{MUTED}" font-size="11">no data</text>'
            )
            continue
        wl, q1, md, q3, wh = (xpix(min(max(v, lo), hi)) for v in vals)
        tip = (
            f"{r.label}: median {r.median:.3g}, quartiles {r.q1:.3g} to {r.q3:.3g}, whiskers {r.whisker_lo:.3g} "
            f"to {r.whisker_hi:.3g} {unit}, n = {r.n}"
        )
        out.append(
            f"<g><title>{esc(tip)}</title>"
            f'<line x1="{num(wl)}" y1="{num(cy)}" x2="{num(q1)}" y2="{num(cy)}" stroke="{TEXT}"/>'
            f'<line x1="{num(q3)}" y1="{num(cy)}" x2="{num(wh)}" y2="{num(cy)}" stroke="{TEXT}"/>'
            f'<line x1="{num(wl)}" y1="{num(cy - 5)}" x2="{num(wl)}" y2="{num(cy + 5)}" stroke="{TEXT}"/>'
            f'<line x1="{num(wh)}" y1="{num(cy - 5)}" x2="{num(wh)}" y2="{num(cy + 5)}" stroke="{TEXT}"/>'
            f'<rect x="{num(q1)}" y="{num(cy - 7)}" width="{num(max(q3 - q1, 1))}" height="14" fill="#9ecae1" '
            f'stroke="{TEXT}"/>'
            f'<line x1="{num(md)}" y1="{num(cy - 7)}" x2="{num(md)}" y2="{num(cy + 7)}" stroke="{TEXT}" '
            f'stroke-width="2.5"/></g>'
        )
    return svg_element(width, height, title, desc, id_prefix, out)


def _nice_step(raw: float) -> float:
    if raw <= 0 or not math.isfinite(raw):
        return 1.0
    mag: float = 10 ** math.floor(math.log10(raw))  # 10 ** n: an int for n >= 0
    for m in (1, 2, 2.5, 5, 10):
        if raw <= m * mag:
            return m * mag
    return 10 * mag


# ------------------------------------------------------------------------- bar panels


def bar_panels(
    labels: Sequence[str],
    panels: Sequence[tuple[str, Sequence[float]]],
    *,
    title: str,
    desc: str,
    id_prefix: str,
    max_value: float = 100.0,
    unit: str = "%",
    width: float = 720,
    label_width: float = 150,
    row_height: float = 20,
    colour: str = "#4a7fb0",
) -> Markup:
    """Horizontal bars, one row per label, in side-by-side panels sharing the labels.

    panels: (panel title, one value per label; NaN = no data). Each bar carries its value as text.
    """
    n_p = max(len(panels), 1)
    gap = 14
    pw = (width - label_width - gap * (n_p - 1) - 8) / n_p
    top = 24
    height = top + len(labels) * row_height + 10
    out = []
    for i, lab in enumerate(labels):
        y = top + i * row_height + row_height / 2 + 4
        out.append(f'<text x="{num(label_width - 8)}" y="{num(y)}" text-anchor="end" font-size="11">{esc(lab)}</text>')
    for p, (ptitle, values) in enumerate(panels):
        x0 = label_width + p * (pw + gap)
        out.append(
            f'<text x="{num(x0 + pw / 2)}" y="14" text-anchor="middle" font-weight="bold" font-size="11">'
            f"{esc(ptitle)}</text>"
        )
        out.append(f'<line x1="{num(x0)}" y1="{top - 2}" x2="{num(x0)}" y2="{num(height - 8)}" stroke="{MUTED}"/>')
        for i, v in enumerate(values):
            y = top + i * row_height
            if not math.isfinite(v):
                out.append(
                    f'<text x="{num(x0 + 4)}" y="{num(y + row_height / 2 + 4)}" fill="{MUTED}" font-size="10">'
                    f"no data</text>"
                )
                continue
            w = (pw - 40) * min(max(v / max_value, 0.0), 1.0)
            out.append(
                f'<rect x="{num(x0)}" y="{num(y + 3)}" width="{num(max(w, 0.5))}" height="{num(row_height - 6)}" '
                f'fill="{esc(colour)}"><title>{esc(labels[i])}, {esc(ptitle)}: {v:.1f} {esc(unit)}</title></rect>'
            )
            out.append(f'<text x="{num(x0 + w + 3)}" y="{num(y + row_height / 2 + 4)}" font-size="10">{v:.0f}</text>')
    return svg_element(width, height, title, desc, id_prefix, out)
