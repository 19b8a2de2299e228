"""The page builders of the report: the context of each page template (ergopose.report.page_types)
from the stored results, with its sections (ergopose.report.session_sections, worker_sections,
timelines and quality_section).

``build_worker_page``, ``build_index_page`` and ``build_print_page`` feed templates/worker.html.j2,
templates/index.html.j2 and templates/print.html.j2; the names of ``__all__`` are the report
pages' public face (the page records and builders re-exported from the modules they live in).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence
from urllib.parse import quote

import pandas as pd

from ergopose.ergonomics.shares import format_percent, high_risk
from ergopose.report import charts
from ergopose.report.context import FLAG_VERDICTS, SessionInfo, WorkerInfo, WorkerResults
from ergopose.report.page_types import (
    BandRow,
    CalibrationRow,
    ConfidenceRow,
    DriverRow,
    Figure,
    FlagRow,
    HoldRow,
    HourRow,
    HourTable,
    IndexPage,
    InputRow,
    LevelRow,
    LimbRow,
    Link,
    MethodHeadline,
    MethodsSection,
    MomentCard,
    PeriodInputRow,
    PrintPage,
    PrintRow,
    PrintWorker,
    QualitySection,
    RegionRow,
    RepetitionRow,
    SessionHeader,
    SettingRow,
    Term,
    WorkerPage,
    WorkerRow,
)
from ergopose.report.periods import MAX_PERIODS
from ergopose.report.quality import Finding, Verdict, quality_verdict
from ergopose.report.quality_section import quality_section
from ergopose.report.session_sections import (
    PRINT_FILE,
    PRINT_PERIODS,
    calibration_rows,
    csv_label,
    csv_link,
    glossary,
    methods_section,
    print_link,
    session_header,
    worst_note,
)
from ergopose.report.timelines import floor_section, hourly_section, risk_figure, timeline_figures
from ergopose.report.wording import (
    CONFIDENCE_WORDS,
    METHOD_TITLES,
    RATING_LABELS,
    Clock,
    display_name,
    fmt_duration,
    fmt_percent,
    worker_page_name,
)
from ergopose.report.worker_sections import (
    act_summary,
    body_part_section,
    confidence_rows,
    headline,
    headline_figure,
    input_rows,
    level_seconds,
    level_segments,
    task_inputs_line,
    worst_moments,
)

FLAG_ORDER = FLAG_VERDICTS[-1:] + FLAG_VERDICTS[:-1]  # sort key: not measured last, worst first
FLAG_SEVERITY = {
    "acceptable": "ok",
    "conditionally acceptable": "caution",
    "time-limited": "caution",
    "not recommended": "bad",
    "not acceptable": "bad",
    "not measured": "unknown",
}


def build_worker_page(res: WorkerResults, session: SessionInfo, report_dir: Path | None = None) -> WorkerPage:
    """The context of one worker's page."""
    info, summ = res.info, res.summary
    frames: pd.DataFrame = res.frames
    who = display_name(info.worker_id, info.name)
    clock = Clock(session.start)
    header = session_header(session)
    nav = [Link(href="index.html", text="Session overview", note="")]
    nav += [
        Link(href=quote(worker_page_name(w.worker_id)), text=display_name(w.worker_id, w.name), note="")
        for w in session.workers
        if w.worker_id != info.worker_id
    ]
    tracked = (
        f"{who} was tracked for {fmt_duration(summ.observed_s)} of the {fmt_duration(session.duration_s)} "
        f"recorded ({fmt_percent(summ.observed_s, session.duration_s)}). Shares below are shares of the "
        "tracked time unless they say otherwise."
    )
    conf_rows, conf_note = confidence_rows(summ)
    timeline, tl_note = timeline_figures(frames, session, who, clock)
    part_figs, part_rows = body_part_section(summ, who)
    holds = tuple(
        HoldRow(
            body_part=h.body_part,
            method=METHOD_TITLES.get(h.method, h.method),
            score=h.score,
            criterion=h.criterion,
            start=clock(h.start_s),
            duration=fmt_duration(h.duration_s),
        )
        for h in summ.holds
    )
    reps = tuple(
        RepetitionRow(
            body_part=r.body_part,
            actions=f"{r.actions:,}",
            per_minute=f"{r.per_minute:.1f}",
            max=f"{r.max_in_one_minute}",
            limit=f"{r.limit_per_min:g}",
            over_limit=f"{r.minutes_over_limit} min",
        )
        for r in summ.repetitions
    )
    hourly_figs, hourly_tables = hourly_section(summ, session, who, clock)
    flags = tuple(
        FlagRow(
            standard=f.standard,
            body_part=f.body_part,
            condition=f.condition,
            verdict=f.verdict,
            severity=FLAG_SEVERITY[f.verdict],
            time=fmt_duration(f.seconds),
            longest=fmt_duration(f.longest_s),
            note=f.note,
        )
        for f in sorted(summ.flags, key=lambda f: -FLAG_ORDER.index(f.verdict))
    )
    floor_figs, floor_note = floor_section(frames, session, who)
    downloads = tuple(csv_link(report_dir, f.path, csv_label(f.label)) for f in info.csv_files + session.csv_files)
    worst = worst_moments(summ, session, who, clock)
    return WorkerPage(
        page_title=f"{who}: ergonomic report, {header.title}",
        session=header,
        worker_id=info.worker_id,
        display_name=who,
        nav=tuple(nav),
        tracked=tracked,
        confidence_rows=conf_rows,
        confidence_note=conf_note,
        headline=tuple(headline(summ, m) for m in session.methods),
        headline_figure=headline_figure(summ, session, who),
        timeline_figures=timeline,
        timeline_note=tl_note,
        body_part_figures=part_figs,
        body_part_rows=part_rows,
        holds=holds,
        repetitions=reps,
        worst=worst,
        worst_note=worst_note(session),
        act_summary=act_summary(res, session),
        risk_figure=worker_risk_figure(res, session, clock),
        hourly_figures=hourly_figs,
        hourly_tables=hourly_tables,
        flags=flags,
        floor_figures=floor_figs,
        floor_note=floor_note,
        quality=quality_section(res, session, who),
        assumptions=info.assumptions,
        methods=methods_section(session),
        downloads=downloads,
        print_link=print_link(),
        glossary=glossary(session),
    )


def worker_risk_figure(res: WorkerResults, session: SessionInfo, clock: Clock, prefix: str = "") -> Figure:
    """A worker's shift by time of day (a RULA and a REBA strip) with the sustained periods marked."""
    frames: pd.DataFrame = res.frames
    marks = [(w.start_s, w.end_s, str(k)) for k, w in enumerate(res.summary.worst[:MAX_PERIODS], start=1)]
    who = display_name(res.info.worker_id, res.info.name)
    return risk_figure(
        [("RULA", frames, "rula"), ("REBA", frames, "reba")],
        session,
        clock,
        fig_id=f"{prefix}fig-risk",
        title=f"The shift of {who} by time of day: high, medium and low risk",
        marks=marks,
    )


# --------------------------------------------------------------------------- index builder


def worker_row(res: WorkerResults, session: SessionInfo, report_dir: Path | None = None) -> WorkerRow:
    """A worker's row in the index's and the print version's table."""
    info, summ, d = res.info, res.summary, res.diagnostics
    who = display_name(info.worker_id, info.name)
    verdict = quality_verdict(d, session.calibration)
    highs = {
        m: format_percent(
            high_risk(m, summ.observed_s, level_seconds(summ, m), summ.unscored_s.get(m, 0.0)).pct_of_tracked
        )
        for m in ("rula", "reba")
    }
    conf = {c.level: fmt_percent(c.seconds, summ.observed_s) for c in summ.confidence}
    shown = summ.worst[:MAX_PERIODS]
    if shown and all(math.isfinite(w.high_s) for w in shown):
        periods_text = f"{len(shown)} ({fmt_duration(sum(w.high_s for w in shown))})"
    else:
        periods_text = f"{len(shown)}" if shown else "none"
    return WorkerRow(
        display_name=who,
        page=Link(href=quote(worker_page_name(info.worker_id)), text=who, note=""),
        tracked=fmt_duration(summ.observed_s),
        confident=conf.get("confident", "n/a"),
        low_confidence=conf.get("low", "n/a"),
        unscored=conf.get("unscored", "n/a"),
        rula_high=highs["rula"],
        reba_high=highs["reba"],
        reliable=fmt_percent(d.frames_reliable, d.frames_observed),
        verdict_label=RATING_LABELS[verdict.rating],
        verdict_rating=verdict.rating,
        csv=tuple(csv_link(report_dir, f.path, f.label) for f in info.csv_files),
        periods=periods_text,
    )


def session_risk_figure(workers: Sequence[WorkerResults], session: SessionInfo) -> Figure:
    """Every worker's shift by time of day, one strip each (the worse of RULA and REBA)."""
    rows = [(f"{r.info.worker_id} {r.info.name}" if r.info.name else r.info.worker_id, r.frames, None) for r in workers]
    return risk_figure(
        rows,
        session,
        Clock(session.start),
        fig_id="fig-risk-all",
        label_width=170,
        title="Each worker's shift by time of day: high, medium and low risk (the worse of RULA and REBA)",
    )


def build_index_page(
    workers: Sequence[WorkerResults], session: SessionInfo, report_dir: Path | None = None
) -> IndexPage:
    """The context of the session overview page."""
    header = session_header(session)
    figs = []
    for m in session.methods:
        stack = []
        for res in workers:
            who = display_name(res.info.worker_id, res.info.name)
            stack.append(
                charts.StackRow(
                    who, level_segments(level_seconds(res.summary, m.name), res.summary.unscored_s.get(m.name, 0.0), m)
                )
            )
        fig = charts.stacked_bars(
            stack,
            title=f"{METHOD_TITLES[m.name]}: share of the tracked time at each level, per worker",
            desc="One bar per worker; segments are action levels, labelled; hatched grey is time "
            "not scored. Numbers are in the table and on each worker's page.",
            id_prefix=f"fig-overview-{m.name}",
            axis_label="share of the tracked time (%)",
        )
        figs.append(
            Figure(
                id=f"fig-overview-{m.name}",
                svg=fig,
                caption=f"{METHOD_TITLES[m.name]} action levels per worker (share of tracked time; hatched = "
                "not scored).",
            )
        )
    rows = tuple(worker_row(res, session, report_dir) for res in workers)
    cal_rows, cal_note = calibration_rows(session)
    return IndexPage(
        page_title=f"Ergonomic report: {header.title}",
        session=header,
        workers=rows,
        risk_figure=session_risk_figure(workers, session),
        overview_figures=tuple(figs),
        calibration_rows=cal_rows,
        calibration_note=cal_note,
        methods=methods_section(session),
        downloads=tuple(csv_link(report_dir, f.path, csv_label(f.label)) for f in session.csv_files),
        print_link=print_link(),
        glossary=glossary(session),
    )


def _print_row(r: WorkerRow, info: WorkerInfo) -> PrintRow:
    return PrintRow(
        worker_id=info.worker_id,
        name=info.name or "",
        tracked=r.tracked,
        confident=r.confident,
        low_confidence=r.low_confidence,
        unscored=r.unscored,
        rula_high=r.rula_high,
        reba_high=r.reba_high,
        periods=r.periods,
        verdict_label=r.verdict_label,
        verdict_rating=r.verdict_rating,
    )


def build_print_page(
    workers: Sequence[WorkerResults], session: SessionInfo, report_dir: Path | None = None
) -> PrintPage:
    """The context of the print version: the summary page, then each worker's (at most two) pages."""
    header = session_header(session)
    clock = Clock(session.start)
    out = []
    for n, res in enumerate(workers, start=1):
        summ = res.summary
        who = display_name(res.info.worker_id, res.info.name)
        cards = worst_moments(summ, session, who, clock, limit=PRINT_PERIODS, prefix=f"w{n}-")
        left = len(summ.worst) - len(cards)
        out.append(
            PrintWorker(
                worker_id=res.info.worker_id,
                display_name=who,
                tracked=(
                    f"Tracked for {fmt_duration(summ.observed_s)} of the {fmt_duration(session.duration_s)} recorded "
                    f"({fmt_percent(summ.observed_s, session.duration_s)}); shares are of the tracked time."
                ),
                headline=tuple(headline(summ, m) for m in session.methods),
                act_summary=act_summary(res, session),
                confidence_rows=confidence_rows(summ)[0],
                risk_figure=worker_risk_figure(res, session, clock, f"w{n}-"),
                worst=cards,
                more=(f"{left} more period{'s' if left != 1 else ''} on the worker's page." if left > 0 else ""),
            )
        )
    return PrintPage(
        page_title=f"Ergonomic report (print): {header.title}",
        session=header,
        workers_table=tuple(_print_row(worker_row(res, session, report_dir), res.info) for res in workers),
        risk_figure=session_risk_figure(workers, session),
        worst_note=worst_note(session),
        workers=tuple(out),
        glossary=glossary(session),
    )


__all__ = [
    "Link",
    "Figure",
    "SessionHeader",
    "SettingRow",
    "MethodsSection",
    "CalibrationRow",
    "LevelRow",
    "MethodHeadline",
    "ConfidenceRow",
    "InputRow",
    "confidence_rows",
    "input_rows",
    "CONFIDENCE_WORDS",
    "BandRow",
    "HoldRow",
    "RepetitionRow",
    "MomentCard",
    "HourRow",
    "HourTable",
    "FlagRow",
    "LimbRow",
    "RegionRow",
    "QualitySection",
    "WorkerPage",
    "WorkerRow",
    "IndexPage",
    "build_worker_page",
    "build_index_page",
    "DriverRow",
    "PeriodInputRow",
    "task_inputs_line",
    "Term",
    "PrintRow",
    "PrintWorker",
    "PrintPage",
    "build_print_page",
    "PRINT_FILE",
    "glossary",
    "worker_page_name",
    "Finding",
    "Verdict",
]
