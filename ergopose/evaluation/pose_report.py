"""What the 2D pose measurement (ergopose.evaluation.pose) reports: its scored rows summarised
per condition, camera and lens region (and people under one camera seen by the other), and the
whole result as markdown tables."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ergopose.evaluation.pose_records import CONDITIONS, OtherCameraSummary, PersonTrials, PoseEvaluation, RegionSummary
from ergopose.geometry.regions import describe


def summarise(
    trials: PersonTrials, conditions: Sequence[str], cameras: Sequence[str], regions: Sequence[str]
) -> tuple[RegionSummary, ...]:
    out = []
    for condition in conditions:
        c_mask = trials.condition == CONDITIONS.index(condition)
        for ci, cam in [(None, "all")] + list(enumerate(cameras)):
            cam_mask = c_mask if ci is None else c_mask & (trials.camera == ci)
            for ri, reg in list(enumerate(regions)) + [(None, "all")]:
                m = cam_mask if ri is None else cam_mask & (trials.region == ri)
                out.append(region_summary(condition, cam, reg, trials.select(m)))
    return tuple(out)


def region_summary(condition: str, camera: str, region: str, t: PersonTrials) -> RegionSummary:
    persons, found = len(t), int(t.found.sum())
    px = t.joint_error_px[np.isfinite(t.joint_error_px)]
    torso = t.joint_error_torso[np.isfinite(t.joint_error_torso)]

    def q(values: np.ndarray, p: float) -> float:
        return float(np.percentile(values, p)) if values.size else float("nan")

    return RegionSummary(
        condition,
        camera,
        region,
        persons,
        found,
        found / persons if persons else float("nan"),
        int(px.size),
        q(px, 50),
        q(px, 90),
        q(torso, 50),
        q(torso, 90),
    )


def other_camera_summaries(
    trials: PersonTrials, conditions: Sequence[str], n_cameras: int, central: int
) -> tuple[OtherCameraSummary, ...]:
    if n_cameras != 2:
        return ()
    out = []
    for condition in conditions:
        t = trials.select(trials.condition == CONDITIONS.index(condition))
        found_at = {(int(f), int(c), int(w)): bool(x) for f, c, w, x in zip(t.frame, t.camera, t.worker, t.found)}
        persons = here = other = either = 0
        for f, c, w, r, x in zip(t.frame, t.camera, t.worker, t.region, t.found):
            if r != central:
                continue
            o = found_at.get((int(f), 1 - int(c), int(w)), False)
            persons += 1
            here += bool(x)
            other += o
            either += bool(x) or o
        out.append(OtherCameraSummary(condition, persons, here, other, either))
    return tuple(out)


#: Trunk inclination bins (degrees from the vertical) of the markdown's last table.
INCLINATION_BINS_DEG: tuple[tuple[float, float], ...] = ((0.0, 15.0), (15.0, 30.0), (30.0, 60.0), (60.0, 180.0))


def _pct(found: int, persons: int) -> str:
    return "-" if persons == 0 else f"{100.0 * found / persons:.1f} % ({found}/{persons})"


def _num(x: float, digits: int) -> str:
    return "-" if not np.isfinite(x) else f"{x:.{digits}f}"


def render_markdown(result: PoseEvaluation, *, per_camera: bool = True) -> str:
    """The evaluation as markdown tables: per region pooled over cameras, then per camera,
    the stage's false positives, and the central region seen by the other camera."""
    lines = []
    start, stop, step = result.frames
    w, h = result.image_size
    lines.append(
        f"Session `{result.session.name}`: {w}x{h}, cameras {', '.join(result.cameras)}, "
        f"workers {', '.join(result.workers)}, frames {start}..{stop - 1} every {step} "
        f"({result.scored_frames} scored frames per camera). Lens regions: "
        f"{describe(result.settings.region_limits_deg)}."
    )
    lines.append("")

    def table(camera: str) -> None:
        lines.append("| condition | region | found | keypoints | median px | p90 px | median torso | p90 torso |")
        lines.append("|---|---|---|---|---|---|---|---|")
        for condition in result.conditions:
            for region in result.regions + ("all",):
                s = result.summary(condition, camera, region)
                lines.append(
                    f"| {condition} | {region} | {_pct(s.found, s.persons)} | {s.joints} | "
                    f"{_num(s.error_px_median, 1)} | {_num(s.error_px_p90, 1)} | "
                    f"{_num(s.error_torso_median, 3)} | {_num(s.error_torso_p90, 3)} |"
                )
        lines.append("")

    lines.append("Both cameras pooled:")
    lines.append("")
    table("all")
    if per_camera:
        for cam in result.cameras:
            lines.append(f"Camera {cam}:")
            lines.append("")
            table(cam)
    lines.append(
        "Detection rate by trunk inclination (true hip-to-shoulder direction from the vertical), "
        "both cameras, all regions:"
    )
    lines.append("")
    lines.append("| trunk inclination | " + " | ".join(result.conditions) + " |")
    lines.append("|---" * (len(result.conditions) + 1) + "|")
    t = result.trials
    incl = np.degrees(t.trunk_inclination)
    for lo, hi in INCLINATION_BINS_DEG:
        cells = []
        for condition in result.conditions:
            m = (t.condition == CONDITIONS.index(condition)) & (incl >= lo) & (incl < hi)
            cells.append(_pct(int(t.found[m].sum()), int(m.sum())))
        label = f"{lo:g}-{hi:g} deg" if hi < 180 else f">= {lo:g} deg"
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines.append("")
    if "stage" in result.conditions:
        fp = ", ".join(f"{c} {n}" for c, n in zip(result.cameras, result.stage_false_positives))
        lines.append(
            f"Stage detections matched to no worker (false positives) in the scored frames: {fp} "
            f"({result.stage_frames} frames processed per camera)."
        )
        lines.append("")
    if result.other_camera:
        lines.append("People in the central region of one camera (seen from above), and the other camera:")
        lines.append("")
        lines.append(
            "| condition | person-frames | found by that camera | found by the other camera | found by either |"
        )
        lines.append("|---|---|---|---|---|")
        for o in result.other_camera:
            lines.append(
                f"| {o.condition} | {o.persons} | {_pct(o.found_here, o.persons)} | "
                f"{_pct(o.found_other, o.persons)} | {_pct(o.found_either, o.persons)} |"
            )
        lines.append("")
    return "\n".join(lines)
