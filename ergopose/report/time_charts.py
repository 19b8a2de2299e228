"""Charts over the time of a shift: the score timeline (the worst and median score of each time
bin over bands of the action levels) and the risk strips (a row per worker or body part, each bin
split by the share of it at high, medium and low risk and not scored).

Built on the primitives of :mod:`ergopose.report.svg`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from markupsafe import Markup
from numpy.typing import ArrayLike

from ergopose.report.svg import (
    GRID,
    MUTED,
    TEXT,
    esc,
    fit_label,
    hatch_defs,
    num,
    nums,
    segment_fill,
    svg_element,
    text_width,
)


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

    out = [hatch_defs(id_prefix)]
    for b in bands:
        ya, yb = float(ypix(b.hi)), float(ypix(b.lo))
        out.append(
            f'<rect x="{left}" y="{num(ya)}" width="{num(plot_w)}" height="{num(yb - ya)}" fill="{esc(b.colour)}" '
            f'fill-opacity="0.22"/>'
        )
        out.append(f'<line x1="{left}" y1="{num(ya)}" x2="{num(left + plot_w + 4)}" y2="{num(ya)}" stroke="{GRID}"/>')
        out.append(
            f'<rect x="{num(left + plot_w + 6)}" y="{num((ya + yb) / 2 - 5)}" width="10" height="10" '
            f'fill="{esc(b.colour)}" stroke="{MUTED}" stroke-width="0.5"/>'
        )
        out.append(
            f'<text x="{num(left + plot_w + 20)}" y="{num((ya + yb) / 2 + 4)}" font-size="11">{esc(b.label)}</text>'
        )
    lo_i, hi_i = int(math.ceil(y_min)), int(math.floor(y_max))
    every = 1 if hi_i - lo_i <= 8 else 2
    for v in range(lo_i, hi_i + 1):
        if (v - lo_i) % every:
            continue
        out.append(
            f'<text x="{left - 6}" y="{num(float(ypix(v)) + 4)}" text-anchor="end" fill="{MUTED}" '
            f'font-size="11">{v}</text>'
        )
    for t, label in x_ticks:
        x = float(xpix(t))
        out.append(
            f'<line x1="{num(x)}" y1="{num(top + plot_h)}" x2="{num(x)}" y2="{num(top + plot_h + 14)}" '
            f'stroke="{MUTED}" stroke-width="0.75"/>'
        )
        out.append(
            f'<text x="{num(x)}" y="{num(top + plot_h + 28)}" text-anchor="middle" fill="{MUTED}" '
            f'font-size="11">{esc(label)}</text>'
        )
    out.append(
        f'<text transform="translate(11 {num(top + plot_h / 2)}) rotate(-90)" text-anchor="middle" '
        f'fill="{MUTED}" font-size="11">{esc(y_label)}</text>'
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
            f"M{num(float(x_a[i]))} {num(base)}V{num(float(y))}H{num(float(x_b[i]))}V{num(base)}Z"
            for i, y in zip(sel.tolist(), ys.tolist())
        )
        out.append(
            f'<path d="{d}" fill="{esc(b.colour)}" stroke="none"><title>worst score in {esc(b.label)}</title></path>'
        )
    # not-measured bins: a hatched strip under the plot
    for a, z in _runs(np.isnan(worst)):
        xa, xb = float(xpix(starts_s[a])), float(xpix(starts_s[z - 1] + bin_s))
        out.append(
            f'<rect x="{num(xa)}" y="{num(top + plot_h + 2)}" width="{num(max(xb - xa, 0.8))}" height="9" '
            f'fill="url(#{esc(id_prefix)}-hatch)" stroke="{MUTED}" stroke-width="0.3"><title>not tracked or '
            f"not scored</title></rect>"
        )
    out.append(
        f'<rect x="{left}" y="{top}" width="{num(plot_w)}" height="{num(plot_h)}" fill="none" stroke="{MUTED}"/>'
    )
    for a, z in _runs(np.isfinite(median)):
        xs = xpix(np.concatenate([starts_s[a:z], [starts_s[z - 1] + bin_s]]))
        ys = ypix(median[a:z])
        pts = [f"M{num(float(xs[0]))} {num(float(ys[0]))}"]
        for k in range(z - a):
            pts.append(f"H{num(float(xs[k + 1]))}")
            if k + 1 < z - a and ys[k + 1] != ys[k]:
                pts.append(f"V{num(float(ys[k + 1]))}")
        d = "".join(pts)
        out.append(
            f'<path d="{d}" fill="none" stroke="#ffffff" stroke-width="3.2" stroke-opacity="0.8"/>'
            f'<path d="{d}" fill="none" stroke="{TEXT}" stroke-width="1.4"><title>median score</title></path>'
        )
    return svg_element(width, height, title, desc, id_prefix, out)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs of the True runs of a boolean array."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    d = np.flatnonzero(np.diff(m.astype(np.int8)))
    return list(zip(d[0::2].tolist(), d[1::2].tolist()))


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

    out = [hatch_defs(id_prefix)]
    bw = plot_w / n_bins
    bws = num(bw)
    for c, (name, colour) in enumerate(RISK_FILLS):
        parts = []
        for i, r in enumerate(rows):
            y0 = top + i * (strip_h + gap)
            sh = np.asarray(r.shares, dtype=np.float64)
            ys = y0 + strip_h * (sh[:, :c].sum(axis=1) if c else np.zeros(sh.shape[0]))
            hs = strip_h * sh[:, c]
            k = np.flatnonzero(hs > 0)
            parts += [
                f"M{x} {y}h{bws}v{h}h-{bws}Z" for x, y, h in zip(nums(label_width + k * bw), nums(ys[k]), nums(hs[k]))
            ]
        if parts:
            out.append(
                f'<path d="{"".join(parts)}" fill="{segment_fill(colour, id_prefix)}" stroke="none">'
                f"<title>{esc(name)}</title></path>"
            )
    for i, r in enumerate(rows):
        y0 = top + i * (strip_h + gap)
        out.append(
            f'<rect x="{num(label_width)}" y="{num(y0)}" width="{num(plot_w)}" height="{num(strip_h)}" fill="none" '
            f'stroke="{MUTED}" stroke-width="0.5"/>'
        )
        out.append(
            f'<text x="{num(label_width - 6)}" y="{num(y0 + strip_h / 2 + 4)}" text-anchor="end" font-size="11">'
            f"<title>{esc(r.label)}</title>{esc(fit_label(r.label, label_width - 10))}</text>"
        )
    for a, b, label in marks:
        xa, xb = xpix(a), max(xpix(b), xpix(a) + 2)
        out.append(
            f'<path d="M{num(xa)} {num(top - 2)}V{num(top - 7)}H{num(xb)}V{num(top - 2)}" fill="none" '
            f'stroke="{TEXT}" stroke-width="1.2"/>'
        )
        out.append(
            f'<text x="{num((xa + xb) / 2)}" y="{num(top - 9)}" text-anchor="middle" font-size="10" '
            f'font-weight="bold">{esc(label)}</text>'
        )
    for t, label in x_ticks:
        x = xpix(t)
        out.append(f'<line x1="{num(x)}" y1="{num(axis_y)}" x2="{num(x)}" y2="{num(axis_y + 6)}" stroke="{MUTED}"/>')
        out.append(
            f'<text x="{num(x)}" y="{num(axis_y + 18)}" text-anchor="middle" font-size="11" fill="{MUTED}">'
            f"{esc(label)}</text>"
        )
    x = label_width
    fills = [c for _, c in RISK_FILLS] + ["#ffffff"]
    for text, colour in zip(legend, fills):
        out.append(
            f'<rect x="{num(x)}" y="{num(legend_y - 9)}" width="11" height="11" fill="{segment_fill(colour, id_prefix)}" '
            f'stroke="{MUTED}" stroke-width="0.5"/>'
        )
        out.append(f'<text x="{num(x + 15)}" y="{num(legend_y)}" font-size="11">{esc(text)}</text>')
        x += 15 + text_width(text, 11) + 12
    return svg_element(max(width, x), height, title, desc, id_prefix, out, css_class="fig strips")
