"""Inline-SVG primitives of the report figures: colours, escaping, numbers, contrast, the ``<svg>``
element itself and the hatched "not scored" fill (no JavaScript, no external files).

The figures are drawn by :mod:`ergopose.report.charts` (stacked bars and columns, box plots, bar
panels), :mod:`ergopose.report.time_charts` (score timelines, risk strips),
:mod:`ergopose.report.heat_maps` (floor heat maps) and :mod:`ergopose.report.skeleton_drawing`
(front and side views of a skeleton), all with these helpers. Every figure is returned as
:class:`markupsafe.Markup` holding one ``<svg>`` element (:func:`svg_element`) that:
- carries ``role="img"``, a ``<title>`` and a ``<desc>`` (referenced by ``aria-labelledby``), so a
  screen reader announces what the figure shows;
- escapes every piece of text that goes into it (labels, titles, tooltips: :func:`esc`): a worker
  name with ``</svg><script>`` in it stays text;
- has a fixed ``viewBox`` and natural ``width``/``height``; the stylesheet scales it down to the
  page width (``max-width: 100%; height: auto``), so nothing is cut on screen or on A4;
- labels colours with numbers or words (an action level is never told by colour alone).

Coordinates inside an SVG are pixels of the viewBox; data coordinates are converted by the
figures. Numbers are written with at most two decimals to keep pages small (:func:`num`).
"""

from __future__ import annotations

import math
from typing import Iterable

import numpy as np
from markupsafe import Markup, escape

FONT = "system-ui, -apple-system, 'Segoe UI', Roboto, Helvetica, Arial, sans-serif"
TEXT = "#1a1a1a"
MUTED = "#505050"
GRID = "#c8c8c8"
#: Fill of time that could not be scored (hatched in the figures).
UNSCORED_FILL = "#e4e4e4"


def esc(text: object) -> str:
    """Text escaped for SVG/HTML element content and attribute values."""
    return str(escape(str(text)))


def num(x: float) -> str:
    """A coordinate with at most two decimals, no trailing zeros."""
    if not math.isfinite(x):
        raise ValueError(f"non-finite coordinate {x}")
    s = f"{x:.2f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def nums(values: np.ndarray) -> list[str]:
    """Many coordinates as num would write them (at most two decimals, no trailing zeros), at once."""
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


def text_width(text: str, size: float) -> float:
    """A generous estimate of a label's width in pixels (sans-serif)."""
    return 0.6 * size * len(text)


def svg_element(
    width: float, height: float, title: str, desc: str, id_prefix: str, body: Iterable[str], css_class: str = "fig"
) -> Markup:
    """The ``<svg>`` element of a figure: viewBox and size, role="img", title and description
    (ids ``<id_prefix>-title`` / ``-desc``), font, then the body's elements."""
    tid, did = f"{id_prefix}-title", f"{id_prefix}-desc"
    head = (
        f'<svg xmlns="http://www.w3.org/2000/svg" class="{esc(css_class)}" viewBox="0 0 {num(width)} {num(height)}" '
        f'width="{num(width)}" height="{num(height)}" role="img" aria-labelledby="{esc(tid)} {esc(did)}" '
        f'font-family="{esc(FONT)}" font-size="12" fill="{TEXT}">'
        f'<title id="{esc(tid)}">{esc(title)}</title><desc id="{esc(did)}">{esc(desc)}</desc>'
    )
    return Markup(head + "".join(body) + "</svg>")


def hatch_defs(id_prefix: str) -> str:
    """The hatched "not scored" pattern, id ``<id_prefix>-hatch`` (used by :func:`segment_fill`)."""
    return (
        f'<defs><pattern id="{esc(id_prefix)}-hatch" width="6" height="6" patternUnits="userSpaceOnUse" '
        f'patternTransform="rotate(45)"><rect width="6" height="6" fill="{UNSCORED_FILL}"/>'
        f'<line x1="0" y1="0" x2="0" y2="6" stroke="#9a9a9a" stroke-width="1.5"/></pattern></defs>'
    )


def segment_fill(colour: str | None, id_prefix: str) -> str:
    """A segment fill: None means 'not scored' (hatched grey)."""
    return f"url(#{esc(id_prefix)}-hatch)" if colour is None else esc(colour)


def label_fill(colour: str | None) -> str:
    """The colour of a label drawn on a segment of this fill (None: on the hatched fill)."""
    return TEXT if colour is None else text_colour_on(colour)


def fit_label(text: str, width_px: float, size: float = 11) -> str:
    """``text`` shortened with an ellipsis so that its estimated width fits ``width_px``."""
    room = max(int(width_px / (0.6 * size)), 2)
    return text if len(text) <= room else text[: room - 1].rstrip() + "…"
