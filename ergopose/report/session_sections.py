"""The session-level sections of the report's pages, the same for every worker: the session
header, the calibration check and the methods, the glossary, the rule of the sustained periods,
the sentence on skipped video frames, and the links to the CSV files and the print version.
"""

from __future__ import annotations

import datetime as _dt
import math
from pathlib import Path

from ergopose.report import periods
from ergopose.report.context import MAX_SKIPPED_SPANS, SessionInfo
from ergopose.report.page_types import CalibrationRow, Link, MethodsSection, SessionHeader, SettingRow, Term
from ergopose.report.periods import DRIVER_SHARE
from ergopose.report.timelines import risk_legend
from ergopose.report.wording import REGION_NAMES, SETTING_MEANINGS, Clock, fmt_duration, fmt_percent, safe_href


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
        notices=s.notices,
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
        "The neck's angles are those of the line from the shoulders to the ears, against the trunk: a ceiling "
        "camera does not see the face, so a nod of the head without the neck bending is not measured.",
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
