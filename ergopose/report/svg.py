"""Small inline-SVG plotting helpers for the HTML reports (no JavaScript, no external files).

Every helper returns :class:`markupsafe.Markup` holding one ``<svg>`` element that:
- carries ``role="img"``, a ``<title>`` and a ``<desc>`` (referenced by ``aria-labelledby``), so a
  screen reader announces what the figure shows;
- escapes every piece of text that goes into it (labels, titles, tooltips): a worker name with
  ``</svg><script>`` in it stays text;
- has a fixed ``viewBox`` and natural ``width``/``height``; the stylesheet scales it down to the
  page width (``max-width: 100%; height: auto``), so nothing is cut on screen or on A4;
- labels colours with numbers or words (an action level is never told by colour alone).

Coordinates inside an SVG are pixels of the viewBox; data coordinates are converted by the
helpers. Numbers are written with at most two decimals to keep pages small.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike
from markupsafe import Markup, escape

from ergopose.keypoints import JOINT_INDEX, LIMBS

FONT = "system-ui, -apple-system, 'Segoe UI', Roboto, Helvetica, Arial, sans-serif"
TEXT = "#1a1a1a"
MUTED = "#505050"
GRID = "#c8c8c8"
#: Fill of time that could not be scored (hatched in the figures).
UNSCORED_FILL = "#e4e4e4"


# ------------------------------------------------------------------------------ basics


def _e(text: object) -> str:
    """Text escaped for SVG/HTML element content and attribute values."""
    return str(escape(str(text)))


def _n(x: float) -> str:
    """A coordinate with at most two decimals, no trailing zeros."""
    if not math.isfinite(x):
        raise ValueError(f"non-finite coordinate {x}")
    s = f"{x:.2f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _ns(values: np.ndarray) -> list[str]:
    """Many coordinates as _n would write them (at most two decimals, no trailing zeros), at once."""
    v = np.round(np.asarray(values, dtype=np.float64), 2) + 0.0  # + 0.0: no "-0"
    if not np.all(np.isfinite(v)):
        raise ValueError("non-finite coordinate")
    return [f"{x:.2f}".rstrip("0").rstrip(".") for x in v.tolist()]


def relative_luminance(colour: str) -> float:
    """WCAG 2 relative luminance of a ``#rrggbb`` colour."""
    c = colour.lstrip("#")
    if len(c) != 6:
        raise ValueError(f"expected #rrggbb, got {colour!r}")
    rgb = [int(c[i : i + 2], 16) / 255.0 for i in (0, 2, 4)]
    lin = [v / 12.92 if v <= 0.03928 else ((v + 0.055) / 1.055) ** 2.4 for v in rgb]
    return 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]


def contrast_ratio(a: str, b: str) -> float:
    """WCAG 2 contrast ratio between two ``#rrggbb`` colours (1 to 21)."""
    la, lb = relative_luminance(a), relative_luminance(b)
    hi, lo = max(la, lb), min(la, lb)
    return (hi + 0.05) / (lo + 0.05)


def text_colour_on(fill: str) -> str:
    """Black or white, whichever contrasts more with ``fill``."""
    return "#000000" if contrast_ratio(fill, "#000000") >= contrast_ratio(fill, "#ffffff") else "#ffffff"


def _text_width(text: str, size: float) -> float:
    """A generous estimate of a label's width in pixels (sans-serif)."""
    return 0.6 * size * len(text)


def _svg(
    width: float, height: float, title: str, desc: str, id_prefix: str, body: Iterable[str], css_class: str = "fig"
) -> Markup:
    tid, did = f"{id_prefix}-title", f"{id_prefix}-desc"
    head = (
        f'<svg xmlns="http://www.w3.org/2000/svg" class="{_e(css_class)}" viewBox="0 0 {_n(width)} {_n(height)}" '
        f'width="{_n(width)}" height="{_n(height)}" role="img" aria-labelledby="{_e(tid)} {_e(did)}" '
        f'font-family="{_e(FONT)}" font-size="12" fill="{TEXT}">'
        f'<title id="{_e(tid)}">{_e(title)}</title><desc id="{_e(did)}">{_e(desc)}</desc>'
    )
    return Markup(head + "".join(body) + "</svg>")


def _hatch(id_prefix: str) -> str:
    return (
        f'<defs><pattern id="{_e(id_prefix)}-hatch" width="6" height="6" patternUnits="userSpaceOnUse" '
        f'patternTransform="rotate(45)"><rect width="6" height="6" fill="{UNSCORED_FILL}"/>'
        f'<line x1="0" y1="0" x2="0" y2="6" stroke="#9a9a9a" stroke-width="1.5"/></pattern></defs>'
    )


def _fill(colour: str | None, id_prefix: str) -> str:
    """A segment fill: None means 'not scored' (hatched grey)."""
    return f"url(#{_e(id_prefix)}-hatch)" if colour is None else _e(colour)


def _label_fill(colour: str | None) -> str:
    return TEXT if colour is None else text_colour_on(colour)


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
        f'<rect x="{_n(x)}" y="{_n(y - 10)}" width="12" height="12" fill="url(#{_e(id_prefix)}-hatch)" '
        f'stroke="{MUTED}" stroke-width="0.5"/><text x="{_n(x + 17)}" y="{_n(y)}" font-size="11">{_e(label)}</text>'
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
    out = [_hatch(id_prefix)]
    if hatched:
        out.append(_hatch_legend(label_width, height + 14, hatch_label, id_prefix))
    x0 = label_width
    for k in range(5):
        x = x0 + plot_w * k / 4
        out.append(f'<line x1="{_n(x)}" y1="{top - 2}" x2="{_n(x)}" y2="{_n(height - 28)}" stroke="{GRID}"/>')
        out.append(f'<text x="{_n(x)}" y="{_n(height - 14)}" text-anchor="middle" fill="{MUTED}">{25 * k}</text>')
    out.append(
        f'<text x="{_n(x0 + plot_w / 2)}" y="{_n(height - 1)}" text-anchor="middle" fill="{MUTED}">'
        f"{_e(axis_label)}</text>"
    )
    for i, row in enumerate(rows):
        y = top + i * (bar_height + 8)
        out.append(
            f'<text x="{_n(label_width - 8)}" y="{_n(y + bar_height / 2 + 4)}" text-anchor="end">'
            f"<title>{_e(row.label)}</title>{_e(fit_label(row.label, label_width - 12, 12))}</text>"
        )
        denom = total if total is not None else sum(max(s.value, 0.0) for s in row.segments)
        x = x0
        for seg in row.segments:
            if denom <= 0 or seg.value <= 0:
                continue
            w = plot_w * seg.value / denom
            out.append(
                f'<rect x="{_n(x)}" y="{_n(y)}" width="{_n(max(w, 0.5))}" height="{_n(bar_height)}" '
                f'fill="{_fill(seg.colour, id_prefix)}" stroke="#ffffff" stroke-width="0.5">'
                f"<title>{_e(seg.long)}</title></rect>"
            )
            if seg.short and _text_width(seg.short, 11) + 6 <= w:
                out.append(
                    f'<text x="{_n(x + w / 2)}" y="{_n(y + bar_height / 2 + 4)}" text-anchor="middle" '
                    f'font-size="11" fill="{_label_fill(seg.colour)}">{_e(seg.short)}</text>'
                )
            x += w
    return _svg(width, height + (20 if hatched else 0), title, desc, id_prefix, out)


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
    out = [_hatch(id_prefix)]

    def ypix(v: float) -> float:
        return top + plot_h * (1 - v / y_max)

    for t in y_ticks:
        out.append(
            f'<line x1="{left}" y1="{_n(ypix(t))}" x2="{_n(width - right)}" y2="{_n(ypix(t))}" stroke="{GRID}"/>'
        )
        out.append(f'<text x="{left - 6}" y="{_n(ypix(t) + 4)}" text-anchor="end" fill="{MUTED}">{_e(_tick(t))}</text>')
    out.append(
        f'<text transform="translate(12 {_n(top + plot_h / 2)}) rotate(-90)" text-anchor="middle" '
        f'fill="{MUTED}">{_e(y_label)}</text>'
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
                f'<rect x="{_n(cx - col_w / 2)}" y="{_n(y - h)}" width="{_n(col_w)}" height="{_n(max(h, 0.5))}" '
                f'fill="{_fill(seg.colour, id_prefix)}" stroke="#ffffff" stroke-width="0.5">'
                f"<title>{_e(col.label)}: {_e(seg.long)}</title></rect>"
            )
            if seg.short and h >= 14 and _text_width(seg.short, 10) + 4 <= col_w:
                out.append(
                    f'<text x="{_n(cx)}" y="{_n(y - h / 2 + 4)}" text-anchor="middle" font-size="10" '
                    f'fill="{_label_fill(seg.colour)}">{_e(seg.short)}</text>'
                )
            y -= h
        if i % every == 0:
            out.append(
                f'<text x="{_n(cx)}" y="{_n(height - bottom + 16)}" text-anchor="middle" fill="{MUTED}">'
                f"{_e(col.label)}</text>"
            )
    if hatched:
        out.append(_hatch_legend(left, height + 10, hatch_label, id_prefix))
    return _svg(width, height + (18 if hatched else 0), title, desc, id_prefix, out)


def _tick(v: float) -> str:
    return f"{v:g}"


# -------------------------------------------------------------------------------- timeline


@dataclass(frozen=True)
class Band:
    """A horizontal colour band behind a timeline: scores lo..hi belong to one action level."""

    lo: float
    hi: float
    colour: str
    label: str


def score_timeline(
    starts_s: np.ndarray,
    bin_s: float,
    worst: np.ndarray,
    median: np.ndarray,
    bands: Sequence[Band],
    *,
    y_min: float,
    y_max: float,
    x_ticks: Sequence[tuple[float, str]],
    title: str,
    desc: str,
    id_prefix: str,
    y_label: str,
    width: float = 960,
    height: float = 250,
) -> Markup:
    """Ordinal scores per time bin: a bar per bin up to its worst score, coloured by the action level
    band the score falls in (height and band label carry the level as well), with the median score
    of each bin as a black step line, over light bands of the action levels (named at the right).

    starts_s: bin starts (seconds since the start of the shift), ascending; every bin is bin_s long.
    worst, median: per bin, NaN where nothing was scored (a hatched mark under the axis).
    """
    left, right, top, bottom = 40, 104, 10, 46
    plot_w, plot_h = width - left - right, height - top - bottom
    starts_s = np.asarray(starts_s, dtype=np.float64)
    worst = np.asarray(worst, dtype=np.float64)
    median = np.asarray(median, dtype=np.float64)
    t0 = float(starts_s[0]) if starts_s.size else 0.0
    t1 = float(starts_s[-1] + bin_s) if starts_s.size else 1.0
    span = max(t1 - t0, 1e-9)

    def xpix(t: ArrayLike) -> np.ndarray:
        return left + plot_w * (np.asarray(t, dtype=np.float64) - t0) / span

    def ypix(v: ArrayLike) -> np.ndarray:
        return top + plot_h * (1 - (np.asarray(v, dtype=np.float64) - y_min) / (y_max - y_min))

    out = [_hatch(id_prefix)]
    for b in bands:
        ya, yb = float(ypix(b.hi)), float(ypix(b.lo))
        out.append(
            f'<rect x="{left}" y="{_n(ya)}" width="{_n(plot_w)}" height="{_n(yb - ya)}" fill="{_e(b.colour)}" '
            f'fill-opacity="0.22"/>'
        )
        out.append(f'<line x1="{left}" y1="{_n(ya)}" x2="{_n(left + plot_w + 4)}" y2="{_n(ya)}" stroke="{GRID}"/>')
        out.append(
            f'<rect x="{_n(left + plot_w + 6)}" y="{_n((ya + yb) / 2 - 5)}" width="10" height="10" '
            f'fill="{_e(b.colour)}" stroke="{MUTED}" stroke-width="0.5"/>'
        )
        out.append(
            f'<text x="{_n(left + plot_w + 20)}" y="{_n((ya + yb) / 2 + 4)}" font-size="11">{_e(b.label)}</text>'
        )
    lo_i, hi_i = int(math.ceil(y_min)), int(math.floor(y_max))
    every = 1 if hi_i - lo_i <= 8 else 2
    for v in range(lo_i, hi_i + 1):
        if (v - lo_i) % every:
            continue
        out.append(
            f'<text x="{left - 6}" y="{_n(float(ypix(v)) + 4)}" text-anchor="end" fill="{MUTED}" '
            f'font-size="11">{v}</text>'
        )
    for t, label in x_ticks:
        x = float(xpix(t))
        out.append(
            f'<line x1="{_n(x)}" y1="{_n(top + plot_h)}" x2="{_n(x)}" y2="{_n(top + plot_h + 14)}" '
            f'stroke="{MUTED}" stroke-width="0.75"/>'
        )
        out.append(
            f'<text x="{_n(x)}" y="{_n(top + plot_h + 28)}" text-anchor="middle" fill="{MUTED}" '
            f'font-size="11">{_e(label)}</text>'
        )
    out.append(
        f'<text transform="translate(11 {_n(top + plot_h / 2)}) rotate(-90)" text-anchor="middle" '
        f'fill="{MUTED}" font-size="11">{_e(y_label)}</text>'
    )
    # worst-score bars: one path per band colour (small files)
    x_a = xpix(starts_s)
    x_b = xpix(starts_s + bin_s)
    base = float(ypix(y_min))
    for b in bands:
        sel = np.flatnonzero(np.isfinite(worst) & (worst >= b.lo) & (worst < b.hi))
        if sel.size == 0:
            continue
        ys = ypix(worst[sel])
        d = "".join(
            f"M{_n(float(x_a[i]))} {_n(base)}V{_n(float(y))}H{_n(float(x_b[i]))}V{_n(base)}Z"
            for i, y in zip(sel.tolist(), ys.tolist())
        )
        out.append(
            f'<path d="{d}" fill="{_e(b.colour)}" stroke="none"><title>worst score in {_e(b.label)}</title></path>'
        )
    # not-measured bins: a hatched strip under the plot
    for a, z in _runs(np.isnan(worst)):
        xa, xb = float(xpix(starts_s[a])), float(xpix(starts_s[z - 1] + bin_s))
        out.append(
            f'<rect x="{_n(xa)}" y="{_n(top + plot_h + 2)}" width="{_n(max(xb - xa, 0.8))}" height="9" '
            f'fill="url(#{_e(id_prefix)}-hatch)" stroke="{MUTED}" stroke-width="0.3"><title>not tracked or '
            f"not scored</title></rect>"
        )
    out.append(f'<rect x="{left}" y="{top}" width="{_n(plot_w)}" height="{_n(plot_h)}" fill="none" stroke="{MUTED}"/>')
    for a, z in _runs(np.isfinite(median)):
        xs = xpix(np.concatenate([starts_s[a:z], [starts_s[z - 1] + bin_s]]))
        ys = ypix(median[a:z])
        pts = [f"M{_n(float(xs[0]))} {_n(float(ys[0]))}"]
        for k in range(z - a):
            pts.append(f"H{_n(float(xs[k + 1]))}")
            if k + 1 < z - a and ys[k + 1] != ys[k]:
                pts.append(f"V{_n(float(ys[k + 1]))}")
        d = "".join(pts)
        out.append(
            f'<path d="{d}" fill="none" stroke="#ffffff" stroke-width="3.2" stroke-opacity="0.8"/>'
            f'<path d="{d}" fill="none" stroke="{TEXT}" stroke-width="1.4"><title>median score</title></path>'
        )
    return _svg(width, height, title, desc, id_prefix, out)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs of the True runs of a boolean array."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    d = np.flatnonzero(np.diff(m.astype(np.int8)))
    return list(zip(d[0::2].tolist(), d[1::2].tolist()))


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
            f'<line x1="{_n(x)}" y1="{top}" x2="{_n(x)}" y2="{_n(height - 34)}" stroke="{GRID}" stroke-width="0.75"/>'
        )
        out.append(
            f'<text x="{_n(x)}" y="{_n(height - 20)}" text-anchor="middle" fill="{MUTED}" font-size="11">'
            f"{_e(f'{t:g}')}</text>"
        )
        t += step
    out.append(
        f'<text x="{_n(label_width + plot_w / 2)}" y="{_n(height - 4)}" text-anchor="middle" fill="{MUTED}" '
        f'font-size="11">{_e(unit)}</text>'
    )
    for i, r in enumerate(rows):
        y = top + i * row_height
        cy = y + row_height / 2
        out.append(
            f'<text x="{_n(label_width - 8)}" y="{_n(cy + 4)}" text-anchor="end" font-size="11">{_e(r.label)}</text>'
        )
        vals = (r.whisker_lo, r.q1, r.median, r.q3, r.whisker_hi)
        if r.n <= 0 or not all(math.isfinite(v) for v in vals):
            out.append(f'<text x="{_n(label_width + 4)}" y="{_n(cy + 4)}" fill="{MUTED}" font-size="11">no data</text>')
            continue
        wl, q1, md, q3, wh = (xpix(min(max(v, lo), hi)) for v in vals)
        tip = (
            f"{r.label}: median {r.median:.3g}, quartiles {r.q1:.3g} to {r.q3:.3g}, whiskers {r.whisker_lo:.3g} "
            f"to {r.whisker_hi:.3g} {unit}, n = {r.n}"
        )
        out.append(
            f"<g><title>{_e(tip)}</title>"
            f'<line x1="{_n(wl)}" y1="{_n(cy)}" x2="{_n(q1)}" y2="{_n(cy)}" stroke="{TEXT}"/>'
            f'<line x1="{_n(q3)}" y1="{_n(cy)}" x2="{_n(wh)}" y2="{_n(cy)}" stroke="{TEXT}"/>'
            f'<line x1="{_n(wl)}" y1="{_n(cy - 5)}" x2="{_n(wl)}" y2="{_n(cy + 5)}" stroke="{TEXT}"/>'
            f'<line x1="{_n(wh)}" y1="{_n(cy - 5)}" x2="{_n(wh)}" y2="{_n(cy + 5)}" stroke="{TEXT}"/>'
            f'<rect x="{_n(q1)}" y="{_n(cy - 7)}" width="{_n(max(q3 - q1, 1))}" height="14" fill="#9ecae1" '
            f'stroke="{TEXT}"/>'
            f'<line x1="{_n(md)}" y1="{_n(cy - 7)}" x2="{_n(md)}" y2="{_n(cy + 7)}" stroke="{TEXT}" '
            f'stroke-width="2.5"/></g>'
        )
    return _svg(width, height, title, desc, id_prefix, out)


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
        out.append(f'<text x="{_n(label_width - 8)}" y="{_n(y)}" text-anchor="end" font-size="11">{_e(lab)}</text>')
    for p, (ptitle, values) in enumerate(panels):
        x0 = label_width + p * (pw + gap)
        out.append(
            f'<text x="{_n(x0 + pw / 2)}" y="14" text-anchor="middle" font-weight="bold" font-size="11">'
            f"{_e(ptitle)}</text>"
        )
        out.append(f'<line x1="{_n(x0)}" y1="{top - 2}" x2="{_n(x0)}" y2="{_n(height - 8)}" stroke="{MUTED}"/>')
        for i, v in enumerate(values):
            y = top + i * row_height
            if not math.isfinite(v):
                out.append(
                    f'<text x="{_n(x0 + 4)}" y="{_n(y + row_height / 2 + 4)}" fill="{MUTED}" font-size="10">'
                    f"no data</text>"
                )
                continue
            w = (pw - 40) * min(max(v / max_value, 0.0), 1.0)
            out.append(
                f'<rect x="{_n(x0)}" y="{_n(y + 3)}" width="{_n(max(w, 0.5))}" height="{_n(row_height - 6)}" '
                f'fill="{_e(colour)}"><title>{_e(labels[i])}, {_e(ptitle)}: {v:.1f} {_e(unit)}</title></rect>'
            )
            out.append(f'<text x="{_n(x0 + w + 3)}" y="{_n(y + row_height / 2 + 4)}" font-size="10">{v:.0f}</text>')
    return _svg(width, height, title, desc, id_prefix, out)


# ------------------------------------------------------------------------------ heat map


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

    out = [f'<rect x="{pad_l}" y="{pad_t}" width="{_n(size)}" height="{_n(size)}" fill="#ffffff" stroke="{MUTED}"/>']
    cw, ch = (x1 - x0) / nx, (y1 - y0) / ny
    vmax = float(np.nanmax(grid)) if grid.size and np.any(grid > 0) else 0.0
    steps = len(HEAT_COLOURS)
    edges = [vmax * k / steps for k in range(steps + 1)]
    if presence is not None:
        pres = np.asarray(presence, dtype=np.float64)
        iy, ix = np.nonzero((pres > 0) & ~(grid > 0))
        for a, b in zip(iy.tolist(), ix.tolist()):
            out.append(
                f'<rect x="{_n(px(x0 + b * cw))}" y="{_n(py(y0 + (a + 1) * ch))}" width="{_n(cw * sx)}" '
                f'height="{_n(ch * sy)}" fill="{PRESENT_FILL}"/>'
            )
    if vmax > 0:
        iy, ix = np.nonzero(grid > 0)
        vals = grid[iy, ix]
        k = np.minimum((vals / vmax * steps).astype(int), steps - 1)
        for a, b, kk, v in zip(iy.tolist(), ix.tolist(), k.tolist(), vals.tolist()):
            out.append(
                f'<rect x="{_n(px(x0 + b * cw))}" y="{_n(py(y0 + (a + 1) * ch))}" width="{_n(cw * sx)}" '
                f'height="{_n(ch * sy)}" fill="{HEAT_COLOURS[kk]}"><title>{v:.1f} {_e(unit)}</title></rect>'
            )
    for o in outlines:
        xa, xb = sorted((px(o.x0), px(o.x1)))
        ya, yb = sorted((py(o.y0), py(o.y1)))
        out.append(
            f'<rect x="{_n(xa)}" y="{_n(ya)}" width="{_n(xb - xa)}" height="{_n(yb - ya)}" fill="none" '
            f'stroke="#2b4c7e" stroke-width="1.5"><title>{_e(o.name)}</title></rect>'
        )
        if o.label and _text_width(o.label, 9) + 4 <= xb - xa and yb - ya >= 12:
            out.append(
                f'<text x="{_n((xa + xb) / 2)}" y="{_n((ya + yb) / 2 + 3)}" text-anchor="middle" font-size="9" '
                f'fill="#2b4c7e">{_e(o.label)}</text>'
            )
    for m in markers:
        cx, cy = px(m.x), py(m.y)
        out.append(
            f'<g><title>{_e(m.name)}</title><path d="M{_n(cx - 5)} {_n(cy)}L{_n(cx)} {_n(cy - 5)}'
            f'L{_n(cx + 5)} {_n(cy)}L{_n(cx)} {_n(cy + 5)}Z" fill="#2b4c7e"/>'
            f'<text x="{_n(cx + 7)}" y="{_n(cy - 6)}" font-size="10" fill="#2b4c7e">{_e(m.name)}</text></g>'
        )
    # axes in metres
    for v in range(math.ceil(x0), math.floor(x1) + 1):
        out.append(
            f'<text x="{_n(px(v))}" y="{_n(pad_t + size + 14)}" text-anchor="middle" font-size="10" '
            f'fill="{MUTED}">{v}</text>'
        )
    for v in range(math.ceil(y0), math.floor(y1) + 1):
        out.append(
            f'<text x="{pad_l - 4}" y="{_n(py(v) + 3)}" text-anchor="end" font-size="10" fill="{MUTED}">{v}</text>'
        )
    out.append(
        f'<text x="{_n(pad_l + size / 2)}" y="{_n(height - 2)}" text-anchor="middle" font-size="10" '
        f'fill="{MUTED}">x (m)</text>'
    )
    # legend
    lx = pad_l + size + 16
    out.append(f'<text x="{_n(lx)}" y="{pad_t + 10}" font-size="11" font-weight="bold">{_e(unit)}</text>')
    if vmax > 0:
        for k in range(steps):
            y = pad_t + 18 + k * 20
            out.append(f'<rect x="{_n(lx)}" y="{y}" width="16" height="16" fill="{HEAT_COLOURS[k]}" stroke="{GRID}"/>')
            out.append(
                f'<text x="{_n(lx + 22)}" y="{y + 12}" font-size="10">{_e(_range_label(edges[k], edges[k + 1]))}</text>'
            )
        y = pad_t + 18 + steps * 20
    else:
        out.append(f'<text x="{_n(lx)}" y="{pad_t + 30}" font-size="10">none</text>')
        y = pad_t + 40
    if presence is not None:
        out.append(
            f'<rect x="{_n(lx)}" y="{y}" width="16" height="16" fill="{PRESENT_FILL}" stroke="{GRID}"/>'
            f'<text x="{_n(lx + 22)}" y="{y + 12}" font-size="10">present, 0</text>'
        )
        y += 20
    if outlines:
        out.append(
            f'<rect x="{_n(lx)}" y="{y}" width="16" height="16" fill="none" stroke="#2b4c7e" stroke-width="1.5"/>'
            f'<text x="{_n(lx + 22)}" y="{y + 12}" font-size="10">furniture</text>'
        )
    return _svg(width, height, title, desc, id_prefix, out)


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


# ------------------------------------------------------------------------------- skeleton


_HEAD = ("nose", "left_ear", "right_ear")


def body_axes(joints_world: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(origin, lateral, forward) of a skeleton in the floor plane, from the hips (else shoulders).

    lateral points from the worker's left to right side, forward = up x lateral (where the worker
    faces); origin is the mid point of the pair at floor height. None if neither pair is known.
    """
    j = np.asarray(joints_world, dtype=np.float64)
    for a, b in (("left_hip", "right_hip"), ("left_shoulder", "right_shoulder")):
        pa, pb = j[JOINT_INDEX[a]], j[JOINT_INDEX[b]]
        if np.all(np.isfinite(pa)) and np.all(np.isfinite(pb)):
            lat = (pb - pa) * np.array([1.0, 1.0, 0.0])
            norm = float(np.linalg.norm(lat))
            if norm < 1e-6:
                continue
            lat /= norm
            fwd = np.cross(np.array([0.0, 0.0, 1.0]), lat)
            origin = (pa + pb) / 2 * np.array([1.0, 1.0, 0.0])
            return origin, lat, fwd
    return None


def skeleton_views(
    joints_world: np.ndarray, *, title: str, desc: str, id_prefix: str, panel: float = 170, min_height_m: float = 1.9
) -> Markup:
    """Front and side projections of a 33-joint skeleton (metres, world frame, NaN = missing joint).

    Front view: seen from in front of the worker (the worker's right side on the viewer's left).
    Side view: seen from the worker's right (the worker faces right). Both views share one scale,
    chosen so the whole body fits (at least min_height_m tall); the floor is drawn as a line.
    Left-side limbs are solid blue, right-side limbs dashed red, and L/R mark the wrists.
    """
    j = np.asarray(joints_world, dtype=np.float64).reshape(-1, 3)
    proj = skeleton_projection(j)
    gap = 12
    panel_h = panel * 1.25
    width = 2 * panel + gap + 4
    height = panel_h + 30
    out = []
    if proj is None:
        out.append(
            f'<text x="{_n(width / 2)}" y="{_n(height / 2)}" text-anchor="middle" fill="{MUTED}">'
            f"skeleton not available</text>"
        )
        return _svg(width, height, title, desc, id_prefix, out, css_class="fig skeleton")
    front, side, zs = proj
    views = (("front view", front), ("side view (from the right)", side))
    known = np.all(np.isfinite(j), axis=1)
    top_m = max(min_height_m, float(np.nanmax(zs[known])) + 0.15) if known.any() else min_height_m
    spans = [(float(np.min(h[known])), float(np.max(h[known]))) if known.any() else (-0.5, 0.5) for _, h in views]
    widest = max(b - a for a, b in spans) + 0.3
    scale = min((panel_h - 16) / top_m, (panel - 10) / widest)
    floor_y = 4 + panel_h - 8
    for k, (name, hs) in enumerate(views):
        x_left = 2 + k * (panel + gap)
        cx = x_left + panel / 2
        mid = (spans[k][0] + spans[k][1]) / 2
        clip = f"{id_prefix}-clip{k}"

        def P(h: float, z: float) -> tuple[float, float]:
            return cx + (h - mid) * scale, floor_y - z * scale

        out.append(
            f'<clipPath id="{_e(clip)}"><rect x="{_n(x_left)}" y="4" width="{_n(panel)}" '
            f'height="{_n(panel_h)}"/></clipPath>'
        )
        out.append(
            f'<rect x="{_n(x_left)}" y="4" width="{_n(panel)}" height="{_n(panel_h)}" fill="#f7f7f7" stroke="{GRID}"/>'
        )
        out.append(f'<g clip-path="url(#{_e(clip)})">')
        out.append(
            f'<line x1="{_n(x_left)}" y1="{_n(floor_y)}" x2="{_n(x_left + panel)}" y2="{_n(floor_y)}" '
            f'stroke="{MUTED}" stroke-width="1.5"/>'
        )
        for limb, a, b in LIMBS:
            ia, ib = JOINT_INDEX[a], JOINT_INDEX[b]
            if not (known[ia] and known[ib]):
                continue
            (xa, ya), (xb, yb) = P(hs[ia], zs[ia]), P(hs[ib], zs[ib])
            if limb.startswith("right"):
                colour, style = "#b2182b", ' stroke-dasharray="5 3"'
            elif limb.startswith("left"):
                colour, style = "#2166ac", ""
            else:
                colour, style = TEXT, ""
            out.append(
                f'<line x1="{_n(xa)}" y1="{_n(ya)}" x2="{_n(xb)}" y2="{_n(yb)}" stroke="{colour}" '
                f'stroke-width="3" stroke-linecap="round"{style}/>'
            )
        ls, rs, nose = JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"], JOINT_INDEX["nose"]
        if known[ls] and known[rs] and known[nose]:
            xa, ya = P((hs[ls] + hs[rs]) / 2, (zs[ls] + zs[rs]) / 2)
            xb, yb = P(hs[nose], zs[nose])
            out.append(
                f'<line x1="{_n(xa)}" y1="{_n(ya)}" x2="{_n(xb)}" y2="{_n(yb)}" stroke="{TEXT}" '
                f'stroke-width="3" stroke-linecap="round"/>'
            )
            out.append(
                f'<circle cx="{_n(xb)}" cy="{_n(yb)}" r="{_n(0.09 * scale)}" fill="none" stroke="{TEXT}" '
                f'stroke-width="2"/>'
            )
        for wrist, letter in (("left_wrist", "L"), ("right_wrist", "R")):
            i = JOINT_INDEX[wrist]
            if known[i]:
                x, y = P(hs[i], zs[i])
                out.append(f'<text x="{_n(x + 5)}" y="{_n(y + 4)}" font-size="11" font-weight="bold">{letter}</text>')
        out.append("</g>")
        out.append(
            f'<text x="{_n(cx)}" y="{_n(height - 8)}" text-anchor="middle" font-size="11" fill="{MUTED}">'
            f"{_e(name)}</text>"
        )
    return _svg(width, height, title, desc, id_prefix, out, css_class="fig skeleton")


# --------------------------------------------------------------------------- risk strips


#: Categories of the risk strips, drawn in this order from the top of each strip: colour (None =
#: hatched "not scored"), label. Not tracked is left white (the strip's outline shows the bin).
RISK_FILLS = (("high", "#d73027"), ("medium", "#fee08b"), ("low", "#a6d96a"), ("not scored", None))


@dataclass(frozen=True)
class StripRow:
    """One strip of a risk timeline: label (drawn at the left, shortened to fit; the full text is
    the tooltip), shares (n_bins x 4: share of each bin's length that was high, medium, low and
    not scored, in RISK_FILLS order; the rest of the bin was not tracked)."""

    label: str
    shares: np.ndarray


def fit_label(text: str, width_px: float, size: float = 11) -> str:
    """``text`` shortened with an ellipsis so that its estimated width fits ``width_px``."""
    room = max(int(width_px / (0.6 * size)), 2)
    return text if len(text) <= room else text[: room - 1].rstrip() + "…"


def risk_strips(
    rows: Sequence[StripRow],
    bin_s: float,
    *,
    x_ticks: Sequence[tuple[float, str]],
    title: str,
    desc: str,
    id_prefix: str,
    legend: Sequence[str],
    marks: Sequence[tuple[float, float, str]] = (),
    width: float = 960,
    label_width: float = 150,
    strip_h: float = 16,
    gap: float = 5,
) -> Markup:
    """A timeline of the shift per row: each time bin a column split by the share of it at high,
    medium and low risk and not scored (hatched); white = not tracked. marks: (start_s, end_s,
    label) brackets above the strips (e.g. the numbered sustained periods). legend: the text of
    each category (RISK_FILLS order, then "not tracked"), drawn under the time axis."""
    n_bins = max((r.shares.shape[0] for r in rows), default=1)
    if len(rows) > 12:  # many workers: thin strips, so a summary page holds twenty
        strip_h, gap = min(strip_h, 8.0), min(gap, 2.0)
    elif len(rows) > 4:
        strip_h, gap = min(strip_h, 11.0), min(gap, 3.0)
    right = 10
    plot_w = width - label_width - right
    mark_h = 16 if marks else 0
    top = 4 + mark_h
    plot_h = len(rows) * (strip_h + gap) - gap if rows else strip_h
    axis_y = top + plot_h
    legend_y = axis_y + 34
    height = legend_y + 14
    span = n_bins * bin_s

    def xpix(t: float) -> float:
        return label_width + plot_w * t / span

    out = [_hatch(id_prefix)]
    bw = plot_w / n_bins
    bws = _n(bw)
    for c, (name, colour) in enumerate(RISK_FILLS):
        parts = []
        for i, r in enumerate(rows):
            y0 = top + i * (strip_h + gap)
            sh = np.asarray(r.shares, dtype=np.float64)
            ys = y0 + strip_h * (sh[:, :c].sum(axis=1) if c else np.zeros(sh.shape[0]))
            hs = strip_h * sh[:, c]
            k = np.flatnonzero(hs > 0)
            parts += [
                f"M{x} {y}h{bws}v{h}h-{bws}Z" for x, y, h in zip(_ns(label_width + k * bw), _ns(ys[k]), _ns(hs[k]))
            ]
        if parts:
            out.append(
                f'<path d="{"".join(parts)}" fill="{_fill(colour, id_prefix)}" stroke="none">'
                f"<title>{_e(name)}</title></path>"
            )
    for i, r in enumerate(rows):
        y0 = top + i * (strip_h + gap)
        out.append(
            f'<rect x="{_n(label_width)}" y="{_n(y0)}" width="{_n(plot_w)}" height="{_n(strip_h)}" fill="none" '
            f'stroke="{MUTED}" stroke-width="0.5"/>'
        )
        out.append(
            f'<text x="{_n(label_width - 6)}" y="{_n(y0 + strip_h / 2 + 4)}" text-anchor="end" font-size="11">'
            f"<title>{_e(r.label)}</title>{_e(fit_label(r.label, label_width - 10))}</text>"
        )
    for a, b, label in marks:
        xa, xb = xpix(a), max(xpix(b), xpix(a) + 2)
        out.append(
            f'<path d="M{_n(xa)} {_n(top - 2)}V{_n(top - 7)}H{_n(xb)}V{_n(top - 2)}" fill="none" '
            f'stroke="{TEXT}" stroke-width="1.2"/>'
        )
        out.append(
            f'<text x="{_n((xa + xb) / 2)}" y="{_n(top - 9)}" text-anchor="middle" font-size="10" '
            f'font-weight="bold">{_e(label)}</text>'
        )
    for t, label in x_ticks:
        x = xpix(t)
        out.append(f'<line x1="{_n(x)}" y1="{_n(axis_y)}" x2="{_n(x)}" y2="{_n(axis_y + 6)}" stroke="{MUTED}"/>')
        out.append(
            f'<text x="{_n(x)}" y="{_n(axis_y + 18)}" text-anchor="middle" font-size="11" fill="{MUTED}">'
            f"{_e(label)}</text>"
        )
    x = label_width
    fills = [c for _, c in RISK_FILLS] + ["#ffffff"]
    for text, colour in zip(legend, fills):
        out.append(
            f'<rect x="{_n(x)}" y="{_n(legend_y - 9)}" width="11" height="11" fill="{_fill(colour, id_prefix)}" '
            f'stroke="{MUTED}" stroke-width="0.5"/>'
        )
        out.append(f'<text x="{_n(x + 15)}" y="{_n(legend_y)}" font-size="11">{_e(text)}</text>')
        x += 15 + _text_width(text, 11) + 12
    return _svg(max(width, x), height, title, desc, id_prefix, out, css_class="fig strips")


# --------------------------------------------------------------------- skeleton projection


def skeleton_projection(joints_world: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The coordinates skeleton_views draws, per joint (metres; NaN rows = missing joints):
    front: across the body as seen from in front, = minus the distance towards the worker's right
    (the right side is drawn on the viewer's left); side: distance forward of the hips (seen from
    the worker's right, the worker faces the viewer's right); height: above the floor. Origin: the
    floor point under the middle of the hips (else of the shoulders). None when neither pair is
    known."""
    j = np.asarray(joints_world, dtype=np.float64).reshape(-1, 3)
    axes = body_axes(j)
    if axes is None:
        return None
    origin, lat, fwd = axes
    rel = j - origin
    return -(rel @ lat), rel @ fwd, rel[:, 2]
