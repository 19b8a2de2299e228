"""When and where a worker's risk fell: the score timelines over the shift, the shares of high,
medium and low risk over time of day, the hourly table and the floor map of high-risk time.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import pandas as pd

from ergopose.arrays import FloatArray, IntArray
from ergopose.report import charts, heat_maps, time_charts
from ergopose.report.context import SessionInfo, WorkerSummary
from ergopose.report.page_types import Figure, HourRow, HourTable
from ergopose.report.wording import (
    BIN_CHOICES_S,
    HIGH_LEVELS,
    MAX_BINS,
    METHOD_TITLES,
    Clock,
    fmt_duration,
    level_colours,
)
from ergopose.report.worker_sections import level_segments


def choose_bin(duration_s: float) -> float:
    for b in BIN_CHOICES_S:
        if duration_s / b <= MAX_BINS:
            return float(b)
    return float(BIN_CHOICES_S[-1])


def binned_scores(
    time_s: np.ndarray, scores: pd.Series, duration_s: float, bin_s: float, max_score: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per time bin: starts (s), worst score and (lower) median score (NaN where no score).

    Vectorised with one bincount over (bin, score): memory is bins x scores, not frames.
    """
    n_bins = max(1, int(math.ceil(duration_s / bin_s)))
    vals = scores.to_numpy(dtype=np.float64, na_value=np.nan)
    ok = np.isfinite(vals)
    idx = np.clip((time_s[ok] // bin_s).astype(np.int64), 0, n_bins - 1)
    sc = np.clip(vals[ok].astype(np.int64), 0, max_score)
    counts = np.bincount(idx * (max_score + 1) + sc, minlength=n_bins * (max_score + 1)).reshape(n_bins, max_score + 1)
    n = counts.sum(axis=1)
    has = n > 0
    worst = np.where(has, max_score - np.argmax(counts[:, ::-1] > 0, axis=1), np.nan).astype(np.float64)
    cum = counts.cumsum(axis=1)
    median = np.where(has, np.argmax(cum >= ((n + 1) // 2)[:, None], axis=1), np.nan).astype(np.float64)
    return np.arange(n_bins) * bin_s, worst, median


def _time_ticks(duration_s: float, clock: Clock) -> list[tuple[float, str]]:
    for step in (5, 10, 15, 30, 60, 120, 300, 600, 900, 1800, 3600, 7200):
        if duration_s / step <= 10:
            break
    if clock.known:
        assert clock.start is not None
        first = clock.start.replace(minute=0, second=0, microsecond=0)
        offset = (first - clock.start).total_seconds()
        k0 = math.ceil(-offset / step)
        ticks = [offset + k * step for k in range(k0, int((duration_s - offset) // step) + 1)]
    else:
        ticks = [k * step for k in range(int(duration_s // step) + 1)]
    return [(t, clock(t, seconds=step < 60)) for t in ticks if 0 <= t <= duration_s]


def timeline_figures(
    frames: pd.DataFrame, session: SessionInfo, who: str, clock: Clock
) -> tuple[tuple[Figure, ...], str]:
    bin_s = choose_bin(session.duration_s)
    t = frames["time_s"].to_numpy(dtype=np.float64)
    figs = []
    for m, col in (("rula", "rula_grand"), ("reba", "reba_score")):
        meth = session.method(m)
        starts, worst, med = binned_scores(t, frames[col], session.duration_s, bin_s, meth.score_high)
        colours = level_colours(meth)
        bands = [
            time_charts.Band(
                lv.low - 0.5,
                lv.high + 0.5,
                colours[lv.level],
                f"{lv.label}" if m == "rula" else f"{lv.level} {lv.label}",
            )
            for lv in meth.action_levels
        ]
        fig = time_charts.score_timeline(
            starts,
            bin_s,
            worst,
            med,
            bands,
            y_min=meth.score_low - 0.5,
            y_max=meth.score_high + 0.5,
            x_ticks=_time_ticks(session.duration_s, clock),
            title=f"{METHOD_TITLES[m]} score over the shift, {who}",
            desc=f"For each {fmt_duration(bin_s)} of the shift, a bar up to the worst {METHOD_TITLES[m]} score in it, "
            "coloured by its action level, and a black step line at the median score; the action levels are "
            "named at the right. Hatched marks under the axis: not tracked or not scored.",
            id_prefix=f"fig-timeline-{m}",
            y_label=f"{METHOD_TITLES[m]} score",
        )
        figs.append(
            Figure(
                id=f"fig-timeline-{m}",
                svg=fig,
                caption=f"{METHOD_TITLES[m]} over the shift: bars = worst score in each {fmt_duration(bin_s)} "
                "(colour and height = action level), black line = median score.",
            )
        )
    note = (
        f"Each point of the timelines summarises {fmt_duration(bin_s)} of the shift ({len(starts)} periods); "
        "all other numbers on this page come from every frame."
    )
    return tuple(figs), note


#: Risk categories of the timelines (high, medium, low), per method: the levels in each.
RISK_LEVELS = {
    "rula": {"high": (3, 4), "medium": (2,), "low": (1,)},
    "reba": {"high": (3, 4), "medium": (2,), "low": (0, 1)},
}
RISK_ORDER = ("high", "medium", "low")
NOT_SCORED = len(RISK_ORDER)


def risk_codes(frames: pd.DataFrame, method: str | None) -> IntArray:
    """Per frame: 0 high, 1 medium, 2 low, 3 not scored, by one method's level, or (method None)
    the worse of the two methods' scored categories (not scored when neither is scored)."""
    if method is None:
        worse: IntArray = np.minimum(risk_codes(frames, "rula"), risk_codes(frames, "reba"))
        return worse
    col = {"rula": "rula_action_level", "reba": "reba_risk_level"}[method]
    lv = frames[col].to_numpy(dtype=np.float64, na_value=np.nan)
    code = np.full(lv.shape, NOT_SCORED, dtype=np.int64)
    for k, cat in enumerate(RISK_ORDER):
        code[np.isin(lv, RISK_LEVELS[method][cat])] = k
    return code


def risk_shares(time_s: np.ndarray, codes: np.ndarray, duration_s: float, bin_s: float, fps: float) -> FloatArray:
    """(bins, 4): share of each time bin at high, medium, low risk and not scored (one bincount);
    the rest of a bin was not tracked. The last bin may be partial: its share is of its own length."""
    n_bins = max(1, int(math.ceil(duration_s / bin_s)))
    idx = np.clip((np.asarray(time_s) // bin_s).astype(np.int64), 0, n_bins - 1)
    counts = np.bincount(idx * 4 + codes, minlength=n_bins * 4).reshape(n_bins, 4).astype(np.float64)
    length = np.minimum(bin_s, duration_s - np.arange(n_bins) * bin_s) * fps
    total = np.maximum(np.maximum(length, counts.sum(axis=1)), 1.0)
    shares: FloatArray = counts / total[:, None]
    return shares


def risk_legend(session: SessionInfo) -> tuple[str, ...]:
    """The words of each category of the risk timelines (RISK_FILLS order, then not tracked)."""
    out = []
    for cat in RISK_ORDER:
        parts = []
        for m in (session.method("rula"), session.method("reba")):
            labels = [lv.label for lv in m.action_levels if lv.level in RISK_LEVELS[m.name][cat]]
            parts.append(f"{METHOD_TITLES[m.name]} {'/'.join(labels)}")
        out.append(f"{cat} ({', '.join(parts)})")
    return (*out, "not scored", "not tracked")


def risk_figure(
    rows: Sequence[tuple[str, pd.DataFrame, str | None]],
    session: SessionInfo,
    clock: Clock,
    *,
    fig_id: str,
    title: str,
    marks: Sequence[tuple[float, float, str]] = (),
    label_width: float = 60,
) -> Figure:
    """The shift by time of day: a strip per (label, frames, method or None for either)."""
    bin_s = choose_bin(session.duration_s)
    strips = [
        time_charts.StripRow(
            label,
            risk_shares(
                f["time_s"].to_numpy(dtype=np.float64), risk_codes(f, m), session.duration_s, bin_s, session.fps
            ),
        )
        for label, f, m in rows
    ]
    legend = risk_legend(session)
    fig = time_charts.risk_strips(
        strips,
        bin_s,
        x_ticks=_time_ticks(session.duration_s, clock),
        title=title,
        desc=f"Time runs left to right ({'clock time' if clock.known else 'time from the start'}); "
        f"each {fmt_duration(bin_s)} column is split by the share of it at "
        + "; ".join(legend)
        + ". Numbered brackets mark the sustained periods of high risk.",
        id_prefix=fig_id,
        legend=legend,
        marks=marks,
        label_width=label_width,
    )
    return Figure(
        id=fig_id,
        svg=fig,
        caption=f"The shift by time of day, in {fmt_duration(bin_s)} columns: red = high, yellow = medium, "
        "green = low risk, hatched = tracked but not scored, white = not tracked"
        + ("; numbered brackets = the sustained periods of high risk." if marks else "."),
    )


def hourly_section(
    summary: WorkerSummary, session: SessionInfo, who: str, clock: Clock
) -> tuple[tuple[Figure, ...], tuple[HourTable, ...]]:
    figs, tables = [], []
    for m in ("rula", "reba"):
        meth = session.method(m)
        hours = sorted((h for h in summary.hourly if h.method == m), key=lambda h: h.start_s)
        if not hours:
            continue
        cols, rows = [], []
        for h in hours:
            secs = {lt.level: lt.seconds for lt in h.levels}
            label = f"{clock(max(h.start_s, 0.0), seconds=False)}"
            segs = tuple(
                charts.Segment(s.value / 60.0, s.colour, s.short, s.long)
                for s in level_segments(secs, h.unscored_s, meth)
            )
            cols.append(charts.StackColumn(label, segs))
            end = min(h.start_s + 3600.0, session.duration_s)
            rows.append(
                HourRow(
                    hour=f"{clock(max(h.start_s, 0.0), seconds=False)}-{clock(end, seconds=False)}",
                    tracked=fmt_duration(h.observed_s),
                    cells=tuple(_hour_cell(secs.get(lv.level, 0.0)) for lv in meth.action_levels)
                    + (_hour_cell(h.unscored_s),),
                )
            )
        fig = charts.stacked_columns(
            cols,
            title=f"{METHOD_TITLES[m]} action levels per hour, {who}",
            desc="One column per hour; segments are minutes at each action level (labelled), "
            "hatched grey is time not scored. The table below gives the minutes.",
            id_prefix=f"fig-hourly-{m}",
            y_max=60,
            y_label="minutes",
            y_ticks=(0, 15, 30, 45, 60),
        )
        figs.append(
            Figure(
                id=f"fig-hourly-{m}",
                svg=fig,
                caption=f"Minutes per hour at each {METHOD_TITLES[m]} action level (hatched = not scored).",
            )
        )
        columns = tuple(f"{lv.label}" if m == "rula" else f"{lv.level} {lv.label}" for lv in meth.action_levels)
        tables.append(HourTable(method=METHOD_TITLES[m], columns=columns + ("not scored",), rows=tuple(rows)))
    return tuple(figs), tuple(tables)


def _hour_cell(seconds: float) -> str:
    """Time in an hour-table cell: "-" for none, else a duration ("4 min 10 s", "0.4 s")."""
    return "-" if not seconds > 0 else fmt_duration(seconds)


def floor_section(frames: pd.DataFrame, session: SessionInfo, who: str) -> tuple[tuple[Figure, ...], str]:
    fp = session.floor
    nx = max(1, int(round((fp.x_max - fp.x_min) / fp.cell_m)))
    ny = max(1, int(round((fp.y_max - fp.y_min) / fp.cell_m)))
    x = frames["floor_x_m"].to_numpy(dtype=np.float64)
    y = frames["floor_y_m"].to_numpy(dtype=np.float64)
    ok = np.isfinite(x) & np.isfinite(y)
    dt = 1.0 / session.fps
    edges = (np.linspace(fp.y_min, fp.y_max, ny + 1), np.linspace(fp.x_min, fp.x_max, nx + 1))
    presence, _, _ = np.histogram2d(y[ok], x[ok], bins=edges)
    outlines = [heat_maps.Outline(f.name, f.x0, f.y0, f.x1, f.y1, f.kind) for f in fp.furniture]
    markers = [heat_maps.Marker(c.name, c.x, c.y) for c in fp.cameras]
    figs = []
    for m, col in (("rula", "rula_action_level"), ("reba", "reba_risk_level")):
        meth = session.method(m)
        lv = frames[col].to_numpy(dtype=np.float64, na_value=np.nan)
        risky = ok & np.isin(lv, HIGH_LEVELS[m])
        grid, _, _ = np.histogram2d(y[risky], x[risky], bins=edges)
        names = " or ".join(x.label for x in meth.action_levels if x.level in HIGH_LEVELS[m])
        secs = grid * dt
        unit, scale = ("minutes", 60.0) if secs.size and float(secs.max()) >= 120.0 else ("seconds", 1.0)
        fig = heat_maps.heat_map(
            secs / scale,
            (fp.x_min, fp.x_max, fp.y_min, fp.y_max),
            title=f"Where {who} worked at {METHOD_TITLES[m]} level {names}",
            desc=f"Floor plan of the {fp.x_max - fp.x_min:g} x {fp.y_max - fp.y_min:g} m area seen from "
            f"above, in {fp.cell_m:g} m squares; darker squares = more {unit} at {METHOD_TITLES[m]} "
            f"level {names} (legend at the right); light grey = present but not at that level; "
            "blue outlines = furniture, diamonds = cameras.",
            id_prefix=f"fig-floor-{m}",
            unit=unit,
            outlines=outlines,
            markers=markers,
            presence=presence,
        )
        figs.append(
            Figure(
                id=f"fig-floor-{m}",
                svg=fig,
                caption=f"{unit.capitalize()} at {METHOD_TITLES[m]} level {names} per {fp.cell_m:g} m square of floor "
                "(seen from above; position = middle of the hips).",
            )
        )
    located = float(ok.sum()) * dt
    note = f"The worker's floor position was known for {fmt_duration(located)} of the tracked time. " + (
        "Furniture outlines come from the session's floor plan."
        if fp.furniture
        else "No furniture layout was given for this session."
    )
    return tuple(figs), note
