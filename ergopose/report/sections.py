"""The sections of the report's pages, built from the stored results: the session header,
methods, calibration, each worker's headline, confidence and task inputs, timelines, body parts,
worst moments, risk shares over time, glossary, hourly table, floor map and quality section.
"""

from __future__ import annotations

import datetime as _dt
import math
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from ergopose.arrays import FloatArray, IntArray
from ergopose.ergonomics.shares import format_percent, high_risk
from ergopose.keypoints import LIMBS
from ergopose.report import periods, svg
from ergopose.report.context import (
    MAX_SKIPPED_SPANS,
    BandTime,
    LimbStats,
    MethodInfo,
    PeriodInput,
    SessionInfo,
    SettingsValue,
    WorkerResults,
    WorkerSummary,
)
from ergopose.report.page_types import (
    BandRow,
    CalibrationRow,
    ConfidenceRow,
    DriverRow,
    Figure,
    HourRow,
    HourTable,
    InputRow,
    LevelRow,
    LimbRow,
    Link,
    MethodHeadline,
    MethodsSection,
    MomentCard,
    PeriodInputRow,
    QualitySection,
    RegionRow,
    RegionSpreadRow,
    SessionHeader,
    SettingRow,
    Term,
)
from ergopose.report.periods import DRIVER_SHARE, MAX_PERIODS
from ergopose.report.quality import SCORED_LIMBS, quality_verdict
from ergopose.report.wording import (
    BIN_CHOICES_S,
    CONFIDENCE_WORDS,
    HIGH_LEVELS,
    MAX_BINS,
    METHOD_TITLES,
    MOSTLY_INFERRED_PCT,
    RATING_LABELS,
    REGION_NAMES,
    SETTING_MEANINGS,
    TASK_INPUTS,
    UNCERTAIN_SD_DEG,
    Clock,
    band_colour,
    fmt_duration,
    fmt_percent,
    level_colours,
    safe_href,
)

# ------------------------------------------------------------------------- shared builders


def session_header(s: SessionInfo) -> SessionHeader:
    clock = Clock(s.start)
    if clock.known:
        assert clock.start is not None
        end = clock.start + _dt.timedelta(seconds=s.duration_s)
        when = f"{clock.start.strftime('%A %d %B %Y')}, {clock.start.strftime('%H:%M')} to {end.strftime('%H:%M')}"
    else:
        when = "Clock time not recorded: times are given from the start of the recording (h:mm:ss)."
    return SessionHeader(
        title=s.title or s.session_id,
        session_id=s.session_id,
        site=s.site,
        when=when,
        duration=f"{fmt_duration(s.duration_s)} ({s.frames:,} frames at {s.fps:g} frames per second)",
        generated=f"Results written {s.created} by ergopose {s.ergopose_version}.",
    )


def calibration_rows(s: SessionInfo) -> tuple[tuple[CalibrationRow, ...], str]:
    cal = s.calibration
    if cal is None:
        return (), "No calibration information was stored with these results."
    rows = []
    for r in cal.regions:
        spread = f" ± {100 * r.spread_m:.1f} cm" if r.n >= 2 and math.isfinite(r.spread_m) else ""
        err = (
            f"{100 * (r.measured_m - r.target_m) / r.target_m:+.1f} %"
            if math.isfinite(r.measured_m) and r.target_m > 0
            else "n/a"
        )
        region = REGION_NAMES.get(r.region, r.region) + (f" ({r.angles})" if r.angles else "")
        rows.append(
            CalibrationRow(
                region=region,
                target=f"{r.target_m:.3f} m",
                measured=f"{r.measured_m:.3f} m{spread} ({_count(r.n, 'measurement')})",
                error=err,
            )
        )
    rms = (
        f" The calibration's reprojection error is {cal.reprojection_rms_px:.2f} pixels (RMS)."
        if math.isfinite(cal.reprojection_rms_px)
        else ""
    )
    if rows:
        note = (
            "A reference bar of known length was measured in 3D in each lens region (the paper's check); "
            "the error is measured minus true length." + rms
        )
    else:
        note = "The calibration was not checked with a reference bar of known length." + rms
    return tuple(rows), note


def methods_section(s: SessionInfo) -> MethodsSection:
    n_cams = len(s.calibration.cameras) if s.calibration is not None else 0
    filmed = f"{n_cams} calibrated camera{'s' if n_cams != 1 else ''} filmed" if n_cams else "Calibrated cameras filmed"
    measured = (
        f"{filmed} the work area; each worker's 33 body landmarks were found in upright virtual views of "
        "every camera and reconstructed in 3D (metres), then tracked and smoothed.",
        "Joint angles (trunk, neck, upper and lower arms, wrists, knees) were computed from the 3D skeleton in "
        f"every frame ({s.fps:g} per second) and scored with RULA and REBA frame by frame.",
        "Shares of the shift are shares of the time the worker was tracked; scores are ordinal, so the report "
        "shows time per level, never averages of scores.",
        "Loads, hand coupling and supports cannot be seen by the cameras: they are the assumptions listed for "
        "each worker.",
    )
    settings = tuple(
        SettingRow(
            name=st.name, value=_fmt_setting(st.value), meaning=SETTING_MEANINGS.get(st.name, "see docs/scoring.md")
        )
        for st in s.settings
    )
    cal = s.calibration
    if cal is None:
        cal_text = "No calibration information was stored."
    else:
        cal_text = f"Calibration file {cal.file} (SHA-256 {cal.sha256}) with cameras {', '.join(cal.cameras)}."
    return MethodsSection(
        measured=measured,
        methods=s.methods,
        settings=settings,
        models=s.models,
        version=s.ergopose_version,
        calibration=cal_text,
    )


def _count(n: int, what: str) -> str:
    """ "1 measurement", "12 measurements"."""
    return f"{n:,} {what}{'' if n == 1 else 's'}"


def _fmt_setting(v: bool | float | str) -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def csv_label(label: str) -> str:
    """A link label that says it leads to a CSV file."""
    return label if "csv" in label.lower() else f"{label} (CSV)"


def csv_link(report_dir: Path | None, path: str, text: str) -> Link:
    """A link to a CSV file of the results at ``path`` (relative to the report); a note instead of
    the link when the path is unsafe, or when the file is missing next to the report."""
    href = safe_href(path)
    if href is None:
        return Link(href="", text=text, note="unsafe path ignored")
    if report_dir is not None and not (report_dir / path).is_file():
        return Link(href=href, text=text, note=f"missing: expected {path} next to this report")
    return Link(href=href, text=text, note="")


# -------------------------------------------------------------------------- worker builder


def level_seconds(summary: WorkerSummary, method: str) -> dict[int, float]:
    return {lt.level: lt.seconds for lt in summary.levels if lt.method == method}


def headline(summary: WorkerSummary, method: MethodInfo) -> MethodHeadline:
    secs = level_seconds(summary, method.name)
    colours = level_colours(method)
    total = summary.observed_s
    rows = []
    for lv in method.action_levels:
        t = secs.get(lv.level, 0.0)
        rows.append(
            LevelRow(
                key=f"{method.name}-{lv.level}",
                level=lv.level,
                label=lv.label,
                wording=lv.wording,
                scores=f"{lv.low}" if lv.low == lv.high else f"{lv.low}-{lv.high}",
                time=fmt_duration(t),
                percent=fmt_percent(t, total),
                colour=colours[lv.level],
            )
        )
    unscored = summary.unscored_s.get(method.name, 0.0)
    high = [lv for lv in method.action_levels if lv.level in HIGH_LEVELS[method.name]]
    risk = high_risk(method.name, total, secs, unscored)  # the terminal's and session_summary.csv's figures
    names = " or ".join(lv.label for lv in high)
    key = (
        f"{format_percent(risk.pct_of_tracked)} of the tracked time ({fmt_duration(risk.high_s)}) at "
        f"{METHOD_TITLES[method.name]} level {names}, {format_percent(risk.pct_of_scored)} of the scored time "
        f"({fmt_duration(risk.scored_s)} scored, {fmt_duration(risk.unscored_s)} not scored): {high[0].wording}."
        if high
        else ""
    )
    return MethodHeadline(
        method=METHOD_TITLES[method.name],
        title=method.title,
        levels=tuple(rows),
        unscored_time=fmt_duration(unscored),
        unscored_percent=fmt_percent(unscored, total),
        key_fact=key,
    )


def confidence_rows(summary: WorkerSummary) -> tuple[tuple[ConfidenceRow, ...], str]:
    """The tracked time by confidence, with causes, and a note on the split (shares of the tracked time)."""
    total = summary.observed_s
    rows = []
    for c in summary.confidence:
        causes = "; ".join(
            f"{ca.cause} {fmt_duration(ca.seconds)} ({fmt_percent(ca.seconds, total)})" for ca in c.causes
        )
        rows.append(
            ConfidenceRow(
                key=c.level,
                level=CONFIDENCE_WORDS.get(c.level, c.level),
                time=fmt_duration(c.seconds),
                percent=fmt_percent(c.seconds, total),
                causes=causes or "-",
            )
        )
    if not rows:
        return (), (
            "How sure each frame's scores are was not recorded with these results (written before "
            "ergopose measured it): shares below are of the tracked time, scored or not."
        )
    note = (
        "Shares are of the tracked time. A frame is scored with confidence when both its RULA and its REBA "
        "score keep their value in most draws of the joints within their measured uncertainty; causes: not "
        "seen = no camera saw the worker, one camera = only one camera did, occluded limbs = joints the "
        "scores need were placed by the body model, uncertain angles = seen, but the angles are too "
        "uncertain for the score."
    )
    return tuple(rows), note


def input_rows(summary: WorkerSummary) -> tuple[tuple[InputRow, ...], str]:
    """Per body part, how well its RULA/REBA inputs were measured, and how to read the table."""
    rows = []
    for i in summary.inputs:
        sd = math.degrees(i.median_sd_rad)
        share = 100.0 * i.inferred_s / i.known_s if i.known_s > 0 else float("nan")
        uncertain = math.isfinite(sd) and sd >= UNCERTAIN_SD_DEG
        inferred = math.isfinite(share) and share >= MOSTLY_INFERRED_PCT
        verdict = (
            ", ".join(w for w, on in (("mostly inferred", inferred), ("uncertain", uncertain)) if on) or "measured"
        )
        rows.append(
            InputRow(
                body_part=i.body_part,
                median_sd=f"{sd:.1f}°" if math.isfinite(sd) else "n/a",
                inferred=fmt_percent(i.inferred_s, i.known_s),
                verdict=verdict,
                concern=verdict != "measured",
                task_input=TASK_INPUTS.get(i.body_part, "none: measured only"),
                from_settings=_settings_words(i.from_settings),
            )
        )
    if not rows:
        return (), ""
    weak = [r.body_part for r in rows if r.concern]
    lead = (
        f"The scores of {', '.join(weak)} rest on inputs that were mostly inferred or uncertain: read those "
        "body parts' bands and the scores they feed with care. "
        if weak
        else "Every body part's inputs were mostly seen and measured with a small spread. "
    )
    note = (
        lead + f"Median SD: the median over the shift of the standard deviation of the body part's angles "
        f"(the largest of them in each frame); 'uncertain' from {UNCERTAIN_SD_DEG:g}° (posture bands are "
        f"10-25° wide). Inferred: share of the tracked time in which its joints were placed by the body model, "
        f"not seen by two cameras; 'mostly inferred' from {MOSTLY_INFERRED_PCT:g} %. Where the cameras cannot "
        "settle an input, the session's settings.toml can give it as a task input (the keys in the column "
        "'Task input in settings'; [defaults], [workers.ID] or [[periods]], docs/session-format.md). The wrist "
        "angles given there (wrist_flexion_deg, wrist_deviation_deg) replace the measurement only in frames "
        "where the angle could not be measured or the hand points were all placed by the body model; the last "
        "column gives each value used and its share of the scored time, and the frames CSV names them per "
        "frame (inputs_from_settings). The neck, trunk, arm and knee angles can only be measured."
    )
    return tuple(rows), note


def _settings_words(values: Sequence[SettingsValue]) -> str:
    """The settings' values used in place of a body part's unseen angles, with the share of the
    scored time each was used; "none" when there were none."""
    parts = []
    for v in values:
        angle = "flexion" if v.input.endswith("wrist_flexion") else "deviation"
        parts.append(
            f"{angle} {math.degrees(v.value_rad):g}° in {fmt_percent(v.seconds, v.scored_s)} of the scored time"
        )
    return "; ".join(parts) or "none"


def level_segments(
    secs: dict[int, float], unscored: float, method: MethodInfo, unit: str = "time"
) -> tuple[svg.Segment, ...]:
    """One stacked-bar segment per action level of ``method`` (seconds at that level, coloured by
    ``level_colours``), then the unscored time."""
    colours = level_colours(method)
    segs = []
    for lv in method.action_levels:
        t = secs.get(lv.level, 0.0)
        short = lv.label if method.name == "rula" else str(lv.level)
        segs.append(
            svg.Segment(
                t,
                colours[lv.level],
                short,
                f"{METHOD_TITLES[method.name]} level {lv.level} ({lv.label}): {fmt_duration(t)}",
            )
        )
    segs.append(svg.Segment(unscored, None, "", f"not scored: {fmt_duration(unscored)}"))
    return tuple(segs)


def headline_figure(summary: WorkerSummary, session: SessionInfo, who: str) -> Figure:
    rows = []
    for m in session.methods:
        rows.append(
            svg.StackRow(
                METHOD_TITLES[m.name],
                level_segments(level_seconds(summary, m.name), summary.unscored_s.get(m.name, 0.0), m),
            )
        )
    fig = svg.stacked_bars(
        rows,
        title=f"Share of the tracked time at each action level, {who}",
        desc="Stacked bars, one per method; each segment is an action level, labelled with its "
        "name or number; hatched grey is time not scored. The table beside gives the numbers.",
        id_prefix="fig-headline",
        total=summary.observed_s,
        label_width=70,
        axis_label="share of the tracked time (%)",
    )
    return Figure(
        id="fig-headline",
        svg=fig,
        caption="Share of the tracked time at each action level (RULA AL1-AL4, REBA 0-4; hatched = not "
        "scored). Exact numbers are in the tables.",
    )


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
            svg.Band(
                lv.low - 0.5,
                lv.high + 0.5,
                colours[lv.level],
                f"{lv.label}" if m == "rula" else f"{lv.level} {lv.label}",
            )
            for lv in meth.action_levels
        ]
        fig = svg.score_timeline(
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


def body_part_section(summary: WorkerSummary, who: str) -> tuple[tuple[Figure, ...], tuple[BandRow, ...]]:
    total = summary.observed_s
    rows = tuple(
        BandRow(
            method=METHOD_TITLES.get(b.method, b.method),
            body_part=b.body_part,
            score=b.score,
            criterion=b.criterion,
            time=fmt_duration(b.seconds),
            percent=fmt_percent(b.seconds, total),
        )
        for b in summary.body_parts
    )
    figs = []
    for m in ("rula", "reba"):
        parts: dict[str, list[BandTime]] = {}
        for b in summary.body_parts:
            if b.method == m:
                parts.setdefault(b.body_part, []).append(b)
        if not parts:
            continue
        stack = []
        for part, bands in parts.items():
            bands = sorted(bands, key=lambda b: b.score)
            segs = [
                svg.Segment(
                    b.seconds,
                    band_colour(b.score),
                    str(b.score),
                    f"{part}, score {b.score} ({b.criterion}): {fmt_duration(b.seconds)}",
                )
                for b in bands
            ]
            rest = max(total - sum(b.seconds for b in bands), 0.0)
            segs.append(svg.Segment(rest, None, "", f"{part} not measured: {fmt_duration(rest)}"))
            stack.append(svg.StackRow(part, tuple(segs)))
        fig = svg.stacked_bars(
            stack,
            title=f"Time per posture band of each body part ({METHOD_TITLES[m]}), {who}",
            desc="One bar per body part; each segment is a posture band, labelled with its band "
            "score (1 = best). Hatched grey: the angle was not measured. Numbers in the table.",
            id_prefix=f"fig-parts-{m}",
            total=total if total > 0 else None,
            axis_label="share of the tracked time (%)",
            hatch_label="angle not measured",
        )
        figs.append(
            Figure(
                id=f"fig-parts-{m}",
                svg=fig,
                caption=f"{METHOD_TITLES[m]} posture bands per body part (number = band score, higher is "
                "worse), as a share of the tracked time.",
            )
        )
    return tuple(figs), rows


def worst_moments(
    summary: WorkerSummary, session: SessionInfo, who: str, clock: Clock, limit: int = MAX_PERIODS, prefix: str = ""
) -> tuple[MomentCard, ...]:
    """The sustained periods of high risk of a worker as cards (ranked as stored); prefix: of the
    figures' ids (unique when several workers share a page)."""
    cards = []
    rula, reba = session.method("rula"), session.method("reba")

    def words(score: int | None, level: int | None, peak: int | None, meth: MethodInfo) -> str:
        if score is None:
            text = "not scored"
        else:
            lv = next((x for x in meth.action_levels if x.level == level), None)
            text = f"{score} ({lv.label})" if lv else f"{score}"
        if peak is not None and peak != score:
            text += f", up to {peak}"
        return text

    for k, w in enumerate(summary.worst[:limit], start=1):
        if w.joints_world_m is None:
            joints = np.full((33, 3), np.nan)
        else:
            joints = np.asarray(w.joints_world_m, dtype=np.float64)
        fig = svg.skeleton_views(
            joints,
            title=f"Posture of {who} at {clock(w.peak_s)}",
            desc=f"Front and side view of the 3D skeleton at {clock(w.peak_s)}: {w.reason}. "
            "Left limbs solid blue, right limbs dashed red; L and R mark the wrists.",
            id_prefix=f"{prefix}fig-moment-{k}",
        )
        length = w.end_s - w.start_s
        high = (
            f"{fmt_duration(w.high_s)} ({fmt_percent(w.high_s, length)})" if math.isfinite(w.high_s) else "not recorded"
        )
        drivers = tuple(
            DriverRow(
                body_part=d.body_part,
                band=f"{d.score} of {d.top}",
                criterion=d.criterion,
                time=fmt_duration(d.seconds),
                percent=fmt_percent(d.seconds, w.high_s),
            )
            for d in w.drivers
        )
        base = w.high_s if math.isfinite(w.high_s) else length
        inputs = tuple(
            PeriodInputRow(
                input=i.input,
                source=i.source,
                value=i.value,
                time=f"{fmt_duration(i.seconds)} ({fmt_percent(i.seconds, base)})",
                use=i.use,
            )
            for i in w.inputs
        )
        cards.append(
            MomentCard(
                rank=k,
                start=clock(w.start_s),
                end=clock(w.end_s),
                duration=fmt_duration(length),
                high_time=high,
                when=clock(w.peak_s),
                rula=words(w.rula_grand, w.rula_level, w.rula_peak, rula),
                reba=words(w.reba_score, w.reba_level, w.reba_peak, reba),
                drivers=drivers,
                reason=w.reason,
                task_inputs=task_inputs_line(w.inputs, base),
                inputs=inputs,
                figure=Figure(
                    id=f"{prefix}fig-moment-{k}",
                    svg=fig,
                    caption=f"Period {k} at {clock(w.peak_s)}: front view (worker's right on the left) and side "
                    "view (seen from the worker's right). No video images are kept.",
                ),
            )
        )
    return tuple(cards)


def task_inputs_line(inputs: Sequence[PeriodInput], high_s: float) -> str:
    """The task inputs of a period in one line: each given value (with its time when it held for
    only part of the high-risk time), then those not given; "not recorded" for older results."""
    if not inputs:
        return "not recorded"
    given, missing = [], []
    for i in inputs:
        if i.source == "task input":
            part = "" if i.seconds >= high_s - 1e-6 else f" ({fmt_duration(i.seconds)})"
            given.append(f"{i.input}: {i.value}{part}")
        elif i.source == "not given" and i.input not in missing:
            missing.append(i.input)
    text = "; ".join(given) if given else "none given"
    return text + (f"; not given: {', '.join(missing)}" if missing else "")


def act_summary(res: WorkerResults, session: SessionInfo, limit: int = MAX_PERIODS) -> str:
    """How much of the worker's high-risk time the periods shown hold, and the body parts that
    drove most of them (summed over the periods), in a sentence."""
    frames: pd.DataFrame = res.frames
    shown = res.summary.worst[:limit]
    high = periods.high_frames(
        frames["rula_action_level"].to_numpy(dtype=np.float64, na_value=np.nan),
        frames["reba_risk_level"].to_numpy(dtype=np.float64, na_value=np.nan),
    )
    high_s = float(high.sum()) / session.fps
    if not shown:
        return (
            f"No sustained period of high risk: {fmt_duration(high_s)} at high risk in all, in stretches "
            f"shorter than {periods.MIN_DURATION_S:g} s."
        )
    if not all(math.isfinite(w.high_s) for w in shown):
        return f"{len(shown)} periods of high risk (results written before sustained periods were found)."
    in_periods = sum(w.high_s for w in shown)
    parts: dict[tuple[str, str, int, int], list[float]] = {}
    for w in shown:
        for d in w.drivers:
            parts.setdefault((d.body_part, d.criterion, d.score, d.top), []).append(d.seconds)
    ranked = sorted(parts.items(), key=lambda kv: (-sum(kv[1]), kv[0]))[:3]
    drivers = "; ".join(
        f"{bp} {crit} (band {sc} of {top}) for {fmt_duration(sum(v))} in {len(v)} of them"
        for (bp, crit, sc, top), v in ranked
    )
    n = len(shown)
    return (
        f"The {n} sustained period{'s' if n != 1 else ''} shown hold {fmt_duration(in_periods)} of the worker's "
        f"{fmt_duration(high_s)} at high risk ({fmt_percent(in_periods, high_s)})."
        + (f" Body parts in a high band in them: {drivers}." if drivers else "")
    )


def worst_note(session: SessionInfo) -> str:
    """The rule of the sustained periods, in words."""
    rula, reba = session.method("rula"), session.method("reba")
    hi = {
        m.name: " or ".join(lv.label for lv in m.action_levels if lv.level in periods.HIGH_LEVELS[m.name])
        for m in (rula, reba)
    }
    return (
        f"A sustained period of high risk is a stretch of frames at RULA {hi['rula']} or REBA {hi['reba']}, "
        f"joined across gaps of at most {periods.MAX_GAP_S:g} s (lower scores, not scored or not tracked), "
        f"lasting at least {periods.MIN_DURATION_S:g} s from its first to its last high-risk frame: one-frame "
        f"spikes are left out. Periods are ranked by their time at high risk; at most {periods.MAX_PERIODS} are "
        "shown. Each is drawn at the middle of the posture (the RULA and REBA scores) held longest in it. Body "
        f"parts: those in one of their two highest RULA posture bands for at least "
        f"{100 * DRIVER_SHARE:.0f} % of the period's high-risk time (band 3 of 4 = the third of four bands)."
    )


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
        svg.StripRow(
            label,
            risk_shares(
                f["time_s"].to_numpy(dtype=np.float64), risk_codes(f, m), session.duration_s, bin_s, session.fps
            ),
        )
        for label, f, m in rows
    ]
    legend = risk_legend(session)
    fig = svg.risk_strips(
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


def glossary(session: SessionInfo) -> tuple[Term, ...]:
    """Every abbreviation and coded word the pages use, with its meaning."""
    rula, reba = session.method("rula"), session.method("reba")
    terms = [
        Term("RULA", f"{rula.title}: final (grand) score {rula.score_low}-{rula.score_high}"),
        Term("REBA", f"{reba.title}: final score {reba.score_low}-{reba.score_high}"),
    ]
    terms += [
        Term(f"RULA {lv.label}", f"action level {lv.level}, scores {lv.low}-{lv.high}: {lv.wording}")
        for lv in rula.action_levels
    ]
    terms += [
        Term(f"REBA {lv.level} {lv.label}", f"risk level {lv.level}, scores {lv.low}-{lv.high}: {lv.wording}")
        for lv in reba.action_levels
    ]
    terms += [
        Term("high, medium, low", "; ".join(risk_legend(session)[:3])),
        Term(
            "not scored",
            "the worker was tracked but a score could not be given (joints the score needs were "
            "missing or too uncertain)",
        ),
        Term("not tracked", "the worker was not found in the frames (out of view, or away)"),
        Term(
            "band",
            "the posture band of a body part on the RULA/REBA worksheet (1 = best); '3 of 4' = the "
            "third of its four bands",
        ),
        Term("n/a", "not applicable: nothing to take a share of (no time of that kind)"),
        Term("SD", "standard deviation"),
        Term(
            "ISO 11226, EN 1005-4", "standards for static working postures and for postures and movements at machinery"
        ),
        Term("°, deg", "degrees of angle"),
    ]
    return tuple(terms)


PRINT_FILE = "print.html"
#: Sustained periods in a worker's print pages (the second page holds their drawings).
PRINT_PERIODS = 6


def print_link() -> Link:
    return Link(href=PRINT_FILE, text="Print version (one summary page, then at most two pages per worker)", note="")


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
                svg.Segment(s.value / 60.0, s.colour, s.short, s.long) for s in level_segments(secs, h.unscored_s, meth)
            )
            cols.append(svg.StackColumn(label, segs))
            end = min(h.start_s + 3600.0, session.duration_s)
            rows.append(
                HourRow(
                    hour=f"{clock(max(h.start_s, 0.0), seconds=False)}-{clock(end, seconds=False)}",
                    tracked=fmt_duration(h.observed_s),
                    cells=tuple(_hour_cell(secs.get(lv.level, 0.0)) for lv in meth.action_levels)
                    + (_hour_cell(h.unscored_s),),
                )
            )
        fig = svg.stacked_columns(
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
    outlines = [svg.Outline(f.name, f.x0, f.y0, f.x1, f.y1, f.kind) for f in fp.furniture]
    markers = [svg.Marker(c.name, c.x, c.y) for c in fp.cameras]
    figs = []
    for m, col in (("rula", "rula_action_level"), ("reba", "reba_risk_level")):
        meth = session.method(m)
        lv = frames[col].to_numpy(dtype=np.float64, na_value=np.nan)
        risky = ok & np.isin(lv, HIGH_LEVELS[m])
        grid, _, _ = np.histogram2d(y[risky], x[risky], bins=edges)
        names = " or ".join(x.label for x in meth.action_levels if x.level in HIGH_LEVELS[m])
        secs = grid * dt
        unit, scale = ("minutes", 60.0) if secs.size and float(secs.max()) >= 120.0 else ("seconds", 1.0)
        fig = svg.heat_map(
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


def quality_section(res: WorkerResults, session: SessionInfo, who: str) -> QualitySection:
    d = res.diagnostics
    verdict = quality_verdict(d, session.calibration)
    reliable = (
        f"The skeleton was reliable for {fmt_percent(d.frames_reliable, d.frames_observed)} of the tracked "
        f"time ({fmt_duration(d.frames_reliable / session.fps)} of {fmt_duration(d.frames_observed / session.fps)}"
        f"), that is {fmt_percent(d.frames_reliable, session.frames)} of the whole session. Rule: "
        f"{d.reliable_rule}."
    )
    order = [name for name, _, _ in LIMBS]
    stats = sorted(
        (s for s in d.limb_lengths if s.region == "all"),
        key=lambda s: order.index(s.limb) if s.limb in order else len(order),
    )
    by_region = {(s.limb, s.region): s for s in d.limb_lengths}
    region_spread = tuple(
        RegionSpreadRow(
            limb=s.limb.replace("_", " "),
            cells=tuple(_spread(by_region.get((s.limb, reg))) for reg in ("central", "outer", "edge")),
        )
        for s in stats
    )
    boxes = [
        svg.BoxRow(
            s.limb.replace("_", " "), 100 * s.p5_m, 100 * s.q1_m, 100 * s.median_m, 100 * s.q3_m, 100 * s.p95_m, s.n
        )
        for s in stats
    ]
    limb_fig = svg.box_plots(
        boxes,
        title=f"3D limb lengths over the shift, {who}",
        desc="Box plots per limb: box = middle half of the measured lengths, thick line = median, "
        "whiskers = 5th to 95th percentile, in centimetres. A real limb does not change "
        "length, so a wide box means noisy measurement. Numbers in the table below.",
        id_prefix="fig-limbs",
        unit="length (cm)",
    )
    rows = tuple(
        LimbRow(
            limb=s.limb.replace("_", " "),
            n=f"{s.n:,}",
            median=_cm(s.median_m),
            iqr=f"{_cm(s.q1_m)} to {_cm(s.q3_m)}",
            whiskers=f"{_cm(s.p5_m)} to {_cm(s.p95_m)}",
            mean_sd=f"{_cm(s.mean_m)} ± {_cm(s.std_m)}" if s.n >= 2 else _cm(s.mean_m),
        )
        for s in stats
    )
    # reconstruction frequency: one panel per region
    freq = {(r.limb, r.region): r for r in d.reconstruction}
    limbs = [n for n in order if any((n, reg) in freq for reg in ("all", "central", "outer", "edge"))]
    panels = []
    for reg in ("all", "central", "outer", "edge"):
        vals = []
        for limb in limbs:
            r = freq.get((limb, reg))
            vals.append(100.0 * r.reconstructed / r.frames if r is not None and r.frames > 0 else float("nan"))
        panels.append((REGION_NAMES[reg], vals))
    freq_fig = svg.bar_panels(
        [n.replace("_", " ") for n in limbs],
        panels,
        title=f"Reconstruction frequency per limb and lens region, {who}",
        desc="Per limb, the percentage of tracked frames in which the limb was reconstructed in "
        "3D: whole field of view, then the central, outer and edge regions of the lenses. "
        "Each bar is labelled with its percentage; 'no data' = never in that region.",
        id_prefix="fig-frequency",
    )
    total_frames = sum(d.region_frames.values())
    regions = []
    for reg in ("central", "outer", "edge"):
        nfr = d.region_frames.get(reg, 0)
        fr = [freq[(limb, reg)] for limb in SCORED_LIMBS if (limb, reg) in freq and freq[(limb, reg)].frames > 0]
        rec = f"{100 * float(np.median([r.reconstructed / r.frames for r in fr])):.1f} %" if fr else "n/a"
        regions.append(
            RegionRow(
                region=REGION_NAMES[reg],
                time=fmt_duration(nfr / session.fps),
                percent=fmt_percent(nfr, total_frames),
                reconstruction=rec,
            )
        )
    cal_rows, cal_note = calibration_rows(session)
    inputs, inputs_note = input_rows(res.summary)
    err = (
        f"Against ground truth, the median 3D joint error was {100 * d.error_3d_m:.1f} cm."
        if math.isfinite(d.error_3d_m)
        else ""
    )
    return QualitySection(
        verdict=verdict,
        verdict_label=RATING_LABELS[verdict.rating],
        reliable=reliable,
        limb_figure=Figure(
            id="fig-limbs",
            svg=limb_fig,
            caption="Limb lengths (cm): box = middle half, line = median, whiskers = 5th-95th percentile.",
        ),
        limb_rows=rows,
        frequency_figure=Figure(
            id="fig-frequency",
            svg=freq_fig,
            caption="Share of tracked frames (%) in which each limb was reconstructed, overall and "
            "per lens region (central, outer, edge).",
        ),
        region_spread=region_spread,
        regions=tuple(regions),
        calibration_rows=cal_rows,
        calibration_note=cal_note,
        error_3d=err,
        video=skipped_sentence(session),
        inputs=inputs,
        inputs_note=inputs_note,
    )


def skipped_sentence(session: SessionInfo) -> str:
    """The quality section's sentence on the video frames that could not be read and were skipped."""
    if not session.skipped_frames:
        return "Every frame of every camera's video was read."
    parts = []
    for r in session.skipped_frames:
        spans = ", ".join(
            _clock_s(a) if b - a < 0.5 / session.fps else f"{_clock_s(a)} to {_clock_s(b)}" for a, b in r.spans_s
        )
        more = " and later" if len(r.spans_s) >= MAX_SKIPPED_SPANS else ""
        parts.append(
            f"{r.camera}: {r.frames:,} frame{'s' if r.frames != 1 else ''} "
            f"({fmt_percent(r.frames, session.frames)} of the session) at {spans}{more}"
        )
    return (
        "Some video frames could not be read and were skipped; in them nobody was measured from that "
        "camera (the skipped-frames CSV file lists every one). " + "; ".join(parts) + "."
    )


def _clock_s(seconds: float) -> str:
    """Shift time as h:mm:ss.s."""
    h, rem = divmod(float(seconds), 3600.0)
    m, sec = divmod(rem, 60.0)
    return f"{int(h)}:{int(m):02d}:{sec:04.1f}"


def _spread(s: LimbStats | None) -> str:
    """A limb's length spread in one region: "1.2 cm (n = 3,456)", or "no data"."""
    if s is None or s.n == 0 or not (math.isfinite(s.q1_m) and math.isfinite(s.q3_m)):
        return "no data"
    if s.n == 1:
        return "one frame: no spread"
    return f"{100 * (s.q3_m - s.q1_m):.1f} cm (n = {s.n:,})"


def _cm(m: float) -> str:
    return f"{100 * m:.1f} cm" if math.isfinite(m) else "n/a"
