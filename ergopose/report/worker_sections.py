"""The sections on one worker's scores: the headline (time per action level) and its figure, the
confidence and input-quality tables, the body parts' posture bands, and the sustained periods of
high risk (their cards, task inputs and summary sentence).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import pandas as pd

from ergopose.ergonomics.shares import format_percent, high_risk
from ergopose.report import charts, periods, skeleton_drawing
from ergopose.report.context import (
    BandTime,
    MethodInfo,
    PeriodInput,
    SessionInfo,
    SettingsValue,
    WorkerResults,
    WorkerSummary,
)
from ergopose.report.page_types import (
    BandRow,
    ConfidenceRow,
    DriverRow,
    Figure,
    InputRow,
    LevelRow,
    MethodHeadline,
    MomentCard,
    PeriodInputRow,
)
from ergopose.report.periods import MAX_PERIODS
from ergopose.report.wording import (
    CONFIDENCE_WORDS,
    HIGH_LEVELS,
    METHOD_TITLES,
    MOSTLY_INFERRED_PCT,
    OFTEN_LIMITED_PCT,
    TASK_INPUTS,
    UNCERTAIN_SD_DEG,
    Clock,
    band_colour,
    fmt_duration,
    fmt_percent,
    level_colours,
)


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
        "score keep their value in most draws of the joints within their measured uncertainty and no joint "
        "they need was held at a joint limit; causes: not "
        "seen = no camera saw the worker, one camera = only one camera did, occluded limbs = joints the "
        "scores need were placed by the body model, joint limit = the cameras put the head, an elbow or a knee "
        "past its anatomical range and the body model held it at the limit, uncertain angles = seen, but the "
        "angles are too "
        "uncertain for the score. The uncertainty is what the cameras disagree on plus the pose network's own "
        "error at every joint (the scoring setting joint_sd_floor_m, measured on a real recording). Errors "
        "that are the same in every frame, such as where the network puts the hips, are larger than that "
        "for the trunk and the knees, so 'with confidence' is the best case (docs/scoring.md)."
    )
    return tuple(rows), note


def input_rows(summary: WorkerSummary) -> tuple[tuple[InputRow, ...], str]:
    """Per body part, how well its RULA/REBA inputs were measured, and how to read the table."""
    rows = []
    for i in summary.inputs:
        sd = math.degrees(i.median_sd_rad)
        share = 100.0 * i.inferred_s / i.known_s if i.known_s > 0 else float("nan")
        held = 100.0 * i.limited_s / i.known_s if i.known_s > 0 and math.isfinite(i.limited_s) else float("nan")
        uncertain = math.isfinite(sd) and sd >= UNCERTAIN_SD_DEG
        inferred = math.isfinite(share) and share >= MOSTLY_INFERRED_PCT
        often_held = math.isfinite(held) and held >= OFTEN_LIMITED_PCT
        words = (("mostly inferred", inferred), ("often held at a joint limit", often_held), ("uncertain", uncertain))
        verdict = ", ".join(w for w, on in words if on) or "measured"
        rows.append(
            InputRow(
                body_part=i.body_part,
                median_sd=f"{sd:.1f}°" if math.isfinite(sd) else "n/a",
                inferred=fmt_percent(i.inferred_s, i.known_s),
                verdict=verdict,
                concern=verdict != "measured",
                task_input=TASK_INPUTS.get(i.body_part, "none: measured only"),
                from_settings=_settings_words(i.from_settings),
                limited=fmt_percent(i.limited_s, i.known_s) if math.isfinite(held) else "-",
            )
        )
    if not rows:
        return (), ""
    weak = [r.body_part for r in rows if r.concern]
    lead = (
        f"The scores of {', '.join(weak)} rest on inputs that were mostly inferred, often held at a joint limit "
        "or uncertain: read those "
        "body parts' bands and the scores they feed with care. "
        if weak
        else "Every body part's inputs were mostly seen and measured with a small spread. "
    )
    note = (
        lead + f"Median SD: the median over the shift of the standard deviation of the body part's angles "
        f"(the largest of them in each frame); 'uncertain' from {UNCERTAIN_SD_DEG:g}° (posture bands are "
        f"10-25° wide). Inferred: share of the tracked time in which its joints were placed by the body model, "
        f"not seen by two cameras; 'mostly inferred' from {MOSTLY_INFERRED_PCT:g} %. Held at a joint limit: share "
        "of the tracked time in which the cameras put the head turned more than 90° from the trunk, an elbow or "
        "a knee bent further than it can, or a knee bent backwards, and the body model held the joint at its "
        "anatomical limit; the angle is then the limit's, not the cameras' (the other body parts have no "
        f"limit: '-'); 'often held at a joint limit' from {OFTEN_LIMITED_PCT:g} %. Where the cameras cannot "
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
) -> tuple[charts.Segment, ...]:
    """One stacked-bar segment per action level of ``method`` (seconds at that level, coloured by
    ``level_colours``), then the unscored time."""
    colours = level_colours(method)
    segs = []
    for lv in method.action_levels:
        t = secs.get(lv.level, 0.0)
        short = lv.label if method.name == "rula" else str(lv.level)
        segs.append(
            charts.Segment(
                t,
                colours[lv.level],
                short,
                f"{METHOD_TITLES[method.name]} level {lv.level} ({lv.label}): {fmt_duration(t)}",
            )
        )
    segs.append(charts.Segment(unscored, None, "", f"not scored: {fmt_duration(unscored)}"))
    return tuple(segs)


def headline_figure(summary: WorkerSummary, session: SessionInfo, who: str) -> Figure:
    rows = []
    for m in session.methods:
        rows.append(
            charts.StackRow(
                METHOD_TITLES[m.name],
                level_segments(level_seconds(summary, m.name), summary.unscored_s.get(m.name, 0.0), m),
            )
        )
    fig = charts.stacked_bars(
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
                charts.Segment(
                    b.seconds,
                    band_colour(b.score),
                    str(b.score),
                    f"{part}, score {b.score} ({b.criterion}): {fmt_duration(b.seconds)}",
                )
                for b in bands
            ]
            rest = max(total - sum(b.seconds for b in bands), 0.0)
            segs.append(charts.Segment(rest, None, "", f"{part} not measured: {fmt_duration(rest)}"))
            stack.append(charts.StackRow(part, tuple(segs)))
        fig = charts.stacked_bars(
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
        fig = skeleton_drawing.skeleton_views(
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
