"""The quality section of a worker's page: how reliable the skeleton was, the spread of its 3D limb
lengths, how often each limb was reconstructed per lens region, and the measurement's inputs.
"""

from __future__ import annotations

import math

import numpy as np

from ergopose.keypoints import LIMBS
from ergopose.report import charts
from ergopose.report.context import LimbStats, SessionInfo, WorkerResults
from ergopose.report.page_types import Figure, LimbRow, QualitySection, RegionRow, RegionSpreadRow
from ergopose.report.quality import SCORED_LIMBS, quality_verdict
from ergopose.report.session_sections import calibration_rows, skipped_sentence
from ergopose.report.wording import RATING_LABELS, REGION_NAMES, fmt_duration, fmt_percent
from ergopose.report.worker_sections import input_rows


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
        charts.BoxRow(
            s.limb.replace("_", " "), 100 * s.p5_m, 100 * s.q1_m, 100 * s.median_m, 100 * s.q3_m, 100 * s.p95_m, s.n
        )
        for s in stats
    ]
    limb_fig = charts.box_plots(
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
    freq_fig = charts.bar_panels(
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


def _spread(s: LimbStats | None) -> str:
    """A limb's length spread in one region: "1.2 cm (n = 3,456)", or "no data"."""
    if s is None or s.n == 0 or not (math.isfinite(s.q1_m) and math.isfinite(s.q3_m)):
        return "no data"
    if s.n == 1:
        return "one frame: no spread"
    return f"{100 * (s.q3_m - s.q1_m):.1f} cm (n = {s.n:,})"


def _cm(m: float) -> str:
    return f"{100 * m:.1f} cm" if math.isfinite(m) else "n/a"
