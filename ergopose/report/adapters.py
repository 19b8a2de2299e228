"""Thin adapters: other stages' records -> report input records (ergopose.report.context).

The pipeline calls these when it stores the results of a session (ergopose.report.results.
save_results); each one only renames and converts (radians -> nothing: reports hold seconds and
metres; text for people), it computes no new numbers.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import math
import os
import tomllib
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.ergonomics.methods import Method, load_method
from ergopose.ergonomics.scoring import BODY_PART_COLUMNS, LEVEL_COLUMNS
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.errors import ConfigError
from ergopose.keypoints import LIMBS
from ergopose.report import periods
from ergopose.report.context import (
    Driver,
    ActionLevelInfo,
    Assumption,
    BandTime,
    CalibrationInfo,
    CauseSeconds,
    ConfidenceTime,
    DataFile,
    FloorCamera,
    FloorItem,
    FloorPlan,
    Hold,
    HourLevels,
    InputQuality,
    SettingsValue,
    LevelTime,
    LimbFrequency,
    LimbStats,
    MethodInfo,
    ModelInfo,
    PeriodInput,
    RegionAccuracy,
    Repetition,
    Setting,
    StandardFlag,
    WorkerDiagnostics,
    WorkerInfo,
    WorkerSummary,
    WorstMoment,
)

#: Furniture kinds drawn on the floor plan (table legs and brackets are left out: the top is drawn).
FLOOR_KINDS = {"shelf": "shelf", "table_top": "table", "pallet": "pallet", "carton": "carton"}


def file_sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def method_info(method: Method) -> MethodInfo:
    """A scoring method (ergopose.ergonomics.methods.Method) as recorded in a report."""
    return MethodInfo(
        name=method.name,
        title=method.title,
        source=method.source,
        file=Path(method.path).name,
        sha256=file_sha256(method.path),
        score_low=int(method.score_range[0]),
        score_high=int(method.score_range[1]),
        action_levels=tuple(
            ActionLevelInfo(level=int(a.level), low=int(a.low), high=int(a.high), label=a.label, wording=a.wording)
            for a in method.action_levels
        ),
    )


def methods_info(names: Sequence[str] = ("rula", "reba")) -> tuple[MethodInfo, ...]:
    """The packaged methods (assessments/*.toml) as report records."""
    return tuple(method_info(load_method(n)) for n in names)


def model_info(card: Any, sha256: str | None = None) -> ModelInfo:
    """A pose model card (ergopose.pose.models.ModelCard) as recorded in a report.

    sha256: the digest verified before the run (defaults to the card's pinned digest).
    """
    source = getattr(card, "source", None)
    requirement = getattr(source, "requirement", None)
    src = requirement() if callable(requirement) else (requirement or str(source or ""))
    return ModelInfo(name=card.name, file=card.file.filename, sha256=sha256 or card.file.sha256, source=src)


def settings_records(settings: ScoringSettings) -> tuple[Setting, ...]:
    """Every scoring setting with its value, in the dataclass's order."""
    return tuple(Setting(name=k, value=v) for k, v in settings.as_dict().items())


def floor_plan_from_boxes(
    boxes: Iterable[Any],
    area: Sequence[float] = (-3.0, 3.0, -3.0, 3.0),
    cameras: Iterable[tuple[str, float, float]] = (),
    cell_m: float = 0.25,
) -> FloorPlan:
    """A floor plan from furniture boxes (objects with name, kind, lo, hi: ergopose.sim.scene.Box),
    the area (x_min, x_max, y_min, y_max) and camera positions (name, x, y)."""
    items = tuple(
        FloorItem(
            name=b.name,
            kind=FLOOR_KINDS[b.kind],
            x0=float(b.lo[0]),
            y0=float(b.lo[1]),
            x1=float(b.hi[0]),
            y1=float(b.hi[1]),
        )
        for b in boxes
        if b.kind in FLOOR_KINDS
    )
    return FloorPlan(
        x_min=float(area[0]),
        x_max=float(area[1]),
        y_min=float(area[2]),
        y_max=float(area[3]),
        cell_m=cell_m,
        furniture=items,
        cameras=tuple(FloorCamera(name=n, x=float(x), y=float(y)) for n, x, y in cameras),
    )


def floor_plan_from_scene(scene: Any, cameras: Iterable[Any] = (), cell_m: float = 0.25) -> FloorPlan:
    """A floor plan from a simulated scene (ergopose.sim.scene.Scene) and its cameras
    (ergopose.geometry.camera.Camera objects, or (name, x, y) tuples)."""
    cams = []
    for k, c in enumerate(cameras):
        if isinstance(c, tuple):
            cams.append(c)
        else:
            pos = c.position_world
            cams.append((getattr(c, "name", None) or f"camera {k + 1}", float(pos[0]), float(pos[1])))
    return floor_plan_from_boxes(scene.boxes, scene.area, cams, cell_m)


def load_floor_plan(
    path: str | os.PathLike[str], cameras: Iterable[tuple[str, float, float]] = (), cell_m: float = 0.25
) -> FloorPlan:
    """The floor plan of a session's floor.toml (docs/session-format.md) with the cameras (name, x, y).

    ``area_m = [x_min, x_max, y_min, y_max]`` (metres, optional, default 6 x 6 m around the
    origin) and ``[[boxes]]`` with ``name``, ``kind``, ``lo = [x, y, z]`` and ``hi = [x, y, z]``
    (other keys, e.g. the simulator's colours, are ignored). Kinds outside FLOOR_KINDS are not
    drawn. A wrong file raises one ConfigError naming the file and the key.
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"cannot read the floor plan ({exc})", path=path) from None
    area = data.get("area_m", (-3.0, 3.0, -3.0, 3.0))
    if not (
        isinstance(area, (list, tuple))
        and len(area) == 4
        and all(_is_number(v) for v in area)
        and area[1] > area[0]
        and area[3] > area[2]
    ):
        raise ConfigError(
            f"expected [x_min, x_max, y_min, y_max] in metres with x_max > x_min and y_max > y_min, got {area!r}",
            path=path,
            field="area_m",
        )
    boxes = data.get("boxes", [])
    if not isinstance(boxes, list):
        raise ConfigError("expected [[boxes]] tables", path=path, field="boxes")
    parsed = []
    for k, b in enumerate(boxes):
        where = f"boxes[{k}]"
        if not isinstance(b, dict):
            raise ConfigError("expected a table with name, kind, lo, hi", path=path, field=where)
        for key in ("name", "kind"):
            if not isinstance(b.get(key), str):
                raise ConfigError(f"expected a text {key}, got {b.get(key)!r}", path=path, field=f"{where}.{key}")
        for key in ("lo", "hi"):
            v = b.get(key)
            if not (isinstance(v, list) and len(v) in (2, 3) and all(_is_number(x) for x in v)):
                raise ConfigError(f"expected [x, y, z] in metres, got {v!r}", path=path, field=f"{where}.{key}")
        parsed.append(SimpleNamespace(name=b["name"], kind=b["kind"], lo=b["lo"], hi=b["hi"]))
    return floor_plan_from_boxes(parsed, area, cameras, cell_m)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


# ------------------------------------------------------------------- shift aggregation


def _criteria(text: str) -> dict[int, str]:
    """ "1: a; 2: b" (a method file's criterion) -> {1: "a", 2: "b"}."""
    out: dict[int, str] = {}
    for part in text.split(";"):
        head, sep, rest = part.partition(":")
        head = head.strip().lstrip("+")
        if sep and head.isdigit():
            out[int(head)] = rest.strip()
    return out


def body_part_of(column: str) -> tuple[str, str, str]:
    """A body-part column of ergopose.ergonomics.scoring -> (method, body part in words, method part).

    "left_rula_upper_arm_band" -> ("rula", "left upper arm", "upper_arm"); "reba_legs" -> ("reba", "legs", "legs").
    """
    side = ""
    rest = column
    for s in ("left_", "right_"):
        if rest.startswith(s):
            side, rest = s[:-1], rest[len(s) :]
    method, _, part = rest.partition("_")
    if part.endswith("_band"):
        part = part[: -len("_band")]
    words = part.replace("_", " ")
    return method, f"{side} {words}".strip(), part


def band_criteria(method: Method, part: str) -> dict[int, str]:
    """Band score -> the method's wording of that band, for a body part ("upper_arm", "legs")."""
    if part in method.bands:
        return _criteria(method.bands[part].criterion)
    if part in method.flag_scores:
        return _criteria(method.flag_scores[part].criterion)
    return {}


_ANGLE_WORDS = {
    "trunk": "trunk flexion",
    "head": "head inclination",
    "upper arm": "upper arm elevation",
    "trunk side bend or twist": "trunk side bend or twist",
}


def _flag_from_finding(f: Any) -> Any:
    if not f.measured:
        return StandardFlag(
            standard=f.standard,
            body_part=f.body_part,
            condition="the angles needed were not measured",
            verdict="not measured",
            seconds=0.0,
            longest_s=float("nan"),
            note="",
        )
    zones = list(f.zone_time_s)
    # the worst zone the worker reached (zones are in increasing order of concern)
    reached = [z for z in zones[1:] if f.zone_time_s.get(z, 0.0) > 0] or zones[:1]
    zone = reached[-1]
    kind = next((w for k, w in _ANGLE_WORDS.items() if f.body_part.endswith(k)), "")
    condition = f"{kind} {zone} deg".strip() if kind and zone[:1] in "<>0123456789" else zone
    if f.standard.startswith("ISO"):
        seconds = float(f.static_time_s.get(zone, 0.0))
        longest = float(f.longest_static_hold_s.get(zone, float("nan")))
        note = (
            f"held longer than 4 s {f.static_holds.get(zone, 0)} times "
            f"({seconds:.0f} s in such holds, {f.zone_time_s.get(zone, 0.0):.0f} s in the zone in all)"
        )
    else:
        seconds = float(f.zone_time_s.get(zone, 0.0))
        longest = float("nan")
        note = f"{f.entries} movements into the zone, {f.per_minute:.1f} per minute"
    verdict = f.verdict if f.verdict != "time-limited" else "time-limited"
    return StandardFlag(
        standard=f.standard,
        body_part=f.body_part,
        condition=condition,
        verdict=verdict,
        seconds=seconds,
        longest_s=longest,
        note=note,
    )


def worker_summary(
    summary: Any,
    methods: Mapping[str, Method] | None = None,
    *,
    frames: Any = None,
    timeline: Any = None,
    joints_at: Any = None,
    worst_limit: int = 6,
    holds_limit: int = 12,
) -> Any:
    """A WorkerSummary from ergopose.ergonomics.shift_records.ShiftSummary.

    timeline: every frame of the worker (time_s and the level and score columns: the report's
    frames table) to find the sustained periods of high risk (ergopose.report.periods); frames:
    scored frames holding at least those of the periods (time_s, the score and band columns), for
    what drove each period; None: the timeline is used, or, without either, no periods.
    joints_at: callable(time_s) -> (33, 3) joints in the world frame (or None) for the skeleton
    drawn for each period.
    """
    methods = dict(methods or {n: load_method(n) for n in ("rula", "reba")})
    levels, unscored = [], {}
    for m, (_, level_col) in LEVEL_COLUMNS.items():
        d = summary.distributions.get(level_col)
        for lv in methods[m].action_levels:
            levels.append(LevelTime(m, int(lv.level), float(d.at(lv.level).time_s) if d else 0.0))
        unscored[m] = float(d.missing_time_s) if d else float(summary.observed_s)
    body_parts, holds = [], []
    for m, cols in BODY_PART_COLUMNS.items():
        for col in cols:
            d = summary.distributions.get(col)
            if d is None:
                continue
            _, words, part = body_part_of(col)
            crit = band_criteria(methods[m], part)
            lowest = min((v.value for v in d.values), default=1)
            for v in d.values:
                text = crit.get(v.value, f"score {v.value}")
                body_parts.append(BandTime(m, words, int(v.value), text, float(v.time_s)))
                if v.value > lowest and np.isfinite(v.longest_hold_s) and v.longest_hold_s > 0:
                    holds.append(
                        Hold(words, m, int(v.value), text, float(v.longest_hold_start_s), float(v.longest_hold_s))
                    )
    holds.sort(key=lambda h: -h.duration_s)
    hourly = []
    for h in summary.hourly:
        hm = next((k for k, (_, lc) in LEVEL_COLUMNS.items() if lc == h.column), None)
        if hm is None:
            continue
        hourly.append(
            HourLevels(
                start_s=3600.0 * h.hour,
                method=hm,
                levels=tuple(
                    LevelTime(hm, int(lv.level), float(h.time_by_value.get(lv.level, 0.0)))
                    for lv in methods[hm].action_levels
                ),
                unscored_s=float(h.missing_s),
                observed_s=float(h.observed_s),
            )
        )
    s_limit = 4.0
    reps = tuple(
        Repetition(
            body_part=_angle_body_part(r.angle),
            angle=r.angle,
            actions=int(r.actions),
            per_minute=float(r.per_minute),
            max_in_one_minute=int(r.max_in_one_minute),
            limit_per_min=s_limit,
            minutes_over_limit=int(r.minutes_at_or_above_4),
        )
        for r in summary.repetitions
    )
    worst = worst_periods(
        timeline if timeline is not None else frames,
        frames,
        methods,
        float(summary.frame_period_s),
        joints_at,
        worst_limit,
    )
    flags = tuple(_flag_from_finding(f) for f in summary.exposure)
    confidence = tuple(
        ConfidenceTime(
            level=c.level,
            seconds=float(c.time_s),
            causes=tuple(CauseSeconds(ca.cause, float(ca.time_s)) for ca in c.causes),
        )
        for c in getattr(summary, "confidence", ())
    )
    period = float(summary.frame_period_s)
    scored_s = float(getattr(summary, "scored_frames", 0)) * period
    used = tuple(getattr(summary, "from_settings", ()))
    inputs = tuple(
        InputQuality(
            body_part=i.body_part,
            angles=tuple(i.angles),
            median_sd_rad=float(i.median_sd_rad),
            inferred_s=i.inferred_frames * period,
            known_s=i.known_frames * period,
            limited_s=i.limited_frames * period if math.isfinite(i.limited_percent) else math.nan,
            from_settings=tuple(
                SettingsValue(u.input, float(u.value_rad), float(u.time_s), scored_s)
                for u in used
                if u.input in i.angles
            ),
        )
        for i in getattr(summary, "inputs", ())
    )
    return WorkerSummary(
        worker_id=str(summary.worker),
        observed_s=float(summary.observed_s),
        levels=tuple(levels),
        unscored_s=unscored,
        body_parts=tuple(body_parts),
        holds=tuple(holds[:holds_limit]),
        repetitions=reps,
        hourly=tuple(hourly),
        worst=worst,
        flags=flags,
        confidence=confidence,
        inputs=inputs,
    )


def _angle_body_part(angle: str) -> str:
    words = angle.replace("_", " ")
    for suffix in (" flexion", " abduction", " elevation"):
        if words.endswith(suffix):
            words = words[: -len(suffix)]
    return words.replace("elbow", "lower arm (elbow)")


def _column(table: Any, name: str) -> FloatArray:
    """A column as float64 with NaN for missing values."""
    column: FloatArray = table[name].to_numpy(dtype=np.float64, na_value=np.nan)
    return column


def worst_periods(
    timeline: Any,
    frames: Any,
    methods: Mapping[str, Method],
    frame_period_s: float,
    joints_at: Any = None,
    limit: int = 6,
) -> tuple[WorstMoment, ...]:
    """The sustained periods of high risk of a worker (ergopose.report.periods) as report records,
    ranked: clock span, time at high risk, scores at the frame drawn and the period's peak, the
    body parts in their high bands (from ``frames``, the scored frames with band columns) and the
    skeleton at the frame drawn (``joints_at``)."""
    if timeline is None or not len(timeline) or not frame_period_s > 0:
        return ()
    t = timeline["time_s"].to_numpy(dtype=np.float64)
    cols = {c: _column(timeline, c) for c in ("rula_grand", "rula_action_level", "reba_score", "reba_risk_level")}
    found = periods.worker_periods(
        t,
        cols["rula_grand"],
        cols["rula_action_level"],
        cols["reba_score"],
        cols["reba_risk_level"],
        frame_period_s,
        limit,
    )
    ft = frames["time_s"].to_numpy(dtype=np.float64) if frames is not None and len(frames) else None
    out = []
    for p in found:
        sl = slice(p.start, p.stop)
        high = periods.high_frames(cols["rula_action_level"][sl], cols["reba_risk_level"][sl])
        drawn_s = float(t[p.drawn])

        def score(name: str, i: int = p.drawn) -> int | None:
            v = cols[name][i]
            return None if np.isnan(v) else int(v)

        def peak(name: str) -> int | None:
            v = cols[name][sl]
            return int(np.nanmax(v)) if np.isfinite(v).any() else None

        drivers: tuple[Driver, ...] = ()
        inputs: tuple[PeriodInput, ...] = ()
        if ft is not None:
            a, b = np.searchsorted(ft, [p.start_s, p.end_s - 0.5 * frame_period_s])
            rows = frames.iloc[int(a) : int(b) + 1] if b >= a else frames.iloc[0:0]
            rows = rows[np.isin(rows["time_s"].to_numpy(dtype=np.float64), t[sl][high])] if len(rows) else rows
            drivers = _drivers(rows, methods, frame_period_s, p.high_s)
            inputs = period_input_records(periods.period_inputs(rows, frame_period_s))
        joints = joints_at(drawn_s) if joints_at is not None else None
        reason = (
            "; ".join(
                f"{d.body_part} {d.criterion} (band {d.score} of {d.top}) for {_secs(d.seconds)}" for d in drivers
            )
            or "no single body part in a high band for most of it: the combination of postures"
        )
        out.append(
            WorstMoment(
                start_s=float(p.start_s),
                end_s=float(p.end_s),
                peak_s=drawn_s,
                rula_grand=score("rula_grand"),
                rula_level=score("rula_action_level"),
                reba_score=score("reba_score"),
                reba_level=score("reba_risk_level"),
                reason=reason,
                joints_world_m=None
                if joints is None
                else tuple((float(q[0]), float(q[1]), float(q[2])) for q in np.asarray(joints)),
                high_s=float(p.high_s),
                rula_peak=peak("rula_grand"),
                reba_peak=peak("reba_score"),
                drivers=drivers,
                inputs=inputs,
            )
        )
    return tuple(out)


#: What the measured angles feed.
MEASURED_USE = "RULA and REBA posture steps (upper arm, lower arm, wrist, neck, trunk, legs)"


def period_input_records(uses: Sequence[periods.InputUse]) -> tuple[PeriodInput, ...]:
    """The report records of a period's score inputs (ergopose.report.periods.InputUse): each in
    words, its value in words (angles in degrees) and what it feeds."""
    out = []
    for u in uses:
        if u.input == "angles":
            name, use = f"angles of the {', '.join(u.measured)}", MEASURED_USE
        elif u.input in periods.TASK_INPUTS:
            key = "load_kg" if u.input == "load" else u.input
            name, use = FACTOR_WORDS[key], FACTOR_USE[key]
        else:  # a wrist angle the settings gave where the hand was not seen
            side, angle = u.input.split("_", 1)
            name, use = f"{side} {angle.replace('_', ' ')}", FACTOR_USE[angle]
        value = ""
        if u.source == "task input":
            if u.input == "load":
                kg, held = u.value
                value = ", ".join(
                    x
                    for x in ((f"{kg:g} kg" if kg is not None else "kg not given"), (f"held {held}" if held else ""))
                    if x
                )
            elif isinstance(u.value, bool):
                value = "yes" if u.value else "no"
            elif u.input in periods.TASK_INPUTS:
                value = str(u.value)
            else:
                value = f"{_wrist_words(u.input, float(u.value))}, where the hand was not seen"
        out.append(PeriodInput(input=name, source=u.source, value=value, seconds=float(u.seconds), use=use))
    return tuple(out)


def _secs(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds >= 10 else f"{seconds:.1f} s"


def _drivers(rows: Any, methods: Mapping[str, Method], frame_period_s: float, high_s: float) -> tuple[Driver, ...]:
    """Per RULA body part, its high band held longest in ``rows`` (the period's high frames); those
    held for at least periods.DRIVER_SHARE of the period's high time, highest band score first (it
    adds most to the score), then longest."""
    found = []
    for col in BODY_PART_COLUMNS["rula"]:
        if col not in rows.columns or not len(rows):
            continue
        _, words, part = body_part_of(col)
        b = methods["rula"].bands.get(part)
        top = max(b.scores) if b is not None else 2
        v = _column(rows, col)
        v = v[np.isfinite(v)].astype(np.int64)
        floor = max(2, top - 1)
        v = v[v >= floor]
        if not v.size:
            continue
        counts = np.bincount(v - floor)
        band = int(np.argmax(counts[::-1]))  # most frequent high band; the higher on ties
        band = floor + counts.size - 1 - band
        secs = float(counts[band - floor]) * frame_period_s
        if secs >= periods.DRIVER_SHARE * high_s - 1e-9:
            crit = band_criteria(methods["rula"], part).get(band, f"score {band}")
            found.append(Driver("rula", words, band, int(top), crit, secs))
    found.sort(key=lambda d: (-d.score, -d.seconds))  # the band adding most to the score first
    return tuple(found[: periods.MAX_DRIVERS])


# ------------------------------------------------------------------ reconstruction quality


def worker_diagnostics(
    diag: Any,
    *,
    frames_reliable: int,
    reliable_rule: str,
    error_3d_m: float = float("nan"),
    region_limb: str = "hip_width",
) -> Any:
    """A WorkerDiagnostics from ergopose.recon.diagnostics.WorkerLimbDiagnostics.

    frames_reliable / reliable_rule: from :func:`ergopose.report.quality.reliable_frames`.
    region_frames are the frames per lens region of ``region_limb`` (the hips: where the body is).
    """
    stats, freq = [], []
    for limb, _, _ in LIMBS:
        for region in ("all", "central", "outer", "edge"):
            r = diag.stats.get((limb, region))
            if r is not None:
                p = r.percentiles_m
                stats.append(
                    LimbStats(
                        limb=limb,
                        n=int(r.reconstructed),
                        mean_m=r.mean_m,
                        std_m=r.std_m,
                        p5_m=p[0],
                        q1_m=p[1],
                        median_m=p[2],
                        q3_m=p[3],
                        p95_m=p[4],
                        region=region,
                    )
                )
                freq.append(
                    LimbFrequency(limb=limb, region=region, frames=int(r.frames), reconstructed=int(r.reconstructed))
                )
    region_frames = {region: int(diag.stats[(region_limb, region)].frames) for region in ("central", "outer", "edge")}
    return WorkerDiagnostics(
        worker_id=str(diag.worker),
        frames_observed=int(diag.frames),
        frames_reliable=int(frames_reliable),
        reliable_rule=reliable_rule,
        region_frames=region_frames,
        limb_lengths=tuple(stats),
        reconstruction=tuple(freq),
        error_3d_m=float(error_3d_m),
    )


# ------------------------------------------------------------------------- calibration


def calibration_info(
    path: str | Path, cameras: Sequence[str], *, reprojection_rms_px: float = float("nan"), check: Any = None
) -> Any:
    """A CalibrationInfo from the calibration file and, when run, its bar check
    (ergopose.calibration.check.CheckReport)."""
    regions: tuple[RegionAccuracy, ...] = ()
    if check is not None:
        regions = tuple(
            RegionAccuracy(
                region=r.region,
                target_m=float(r.target),
                measured_m=float(r.mean),
                spread_m=float(r.std) if int(r.n) >= 2 else float("nan"),
                n=int(r.n),
                angles=f"{r.angle_range_deg[0]:g}-{r.angle_range_deg[1]:g} deg",
            )
            for r in check.regions
        )
    return CalibrationInfo(
        file=Path(path).name,
        sha256=file_sha256(path),
        cameras=tuple(cameras),
        reprojection_rms_px=float(reprojection_rms_px),
        regions=regions,
    )


# ---------------------------------------------------------------------------- session


#: What each task factor of the session settings feeds (RULA / REBA steps).
FACTOR_USE = {
    "load_kg": "RULA force/load (steps 7 and 14), REBA load/force (step 5)",
    "load_mode": "RULA force/load (steps 7 and 14)",
    "shock": "RULA force/load, REBA load/force (shock or rapid build-up)",
    "coupling": "REBA coupling (step 11)",
    "arm_supported": "RULA upper arm (step 1a), REBA upper arm (step 7a)",
    "seated": "RULA trunk (step 10), REBA legs (step 3)",
    "legs_supported": "RULA legs (step 11)",
    "wrist_twist_end_range": "RULA wrist twist (step 4)",
    "wrist_flexion": "RULA wrist (step 3), REBA wrist (step 9), where the cameras do not see the hand",
    "wrist_deviation": "RULA wrist deviation (step 3), REBA wrist deviation (step 9), where the cameras do not see the hand",
}
FACTOR_WORDS = {
    "load_kg": "load",
    "load_mode": "load held",
    "shock": "shock or rapid build-up of force",
    "coupling": "hand coupling",
    "arm_supported": "arm supported or leaning",
    "seated": "seated",
    "legs_supported": "legs and feet supported",
    "wrist_twist_end_range": "wrist twisted near the end of its range",
    "wrist_flexion": "wrist flexion of the task",
    "wrist_deviation": "wrist deviation of the task",
}


def _factor_value(name: str, value: Any) -> str:
    if value is None and name in ("wrist_flexion", "wrist_deviation"):
        return "not given: the measured angle is scored"
    if value is None:
        return "not given: scored as unknown"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if name == "load_kg":
        return f"{value:g} kg"
    if name in ("wrist_flexion", "wrist_deviation"):
        return _wrist_words(name, float(value))
    return str(value)


def _wrist_words(name: str, value_rad: float) -> str:
    """A wrist angle of the settings in words: "20° (flexion)", "-15° (extension)"."""
    deg = math.degrees(value_rad)
    if name.endswith("wrist_flexion"):
        way = "flexion" if deg > 0 else "extension" if deg < 0 else "neutral"
    else:
        way = "radial, toward the thumb" if deg > 0 else "ulnar, toward the little finger" if deg < 0 else "neutral"
    return f"{deg:g}° ({way})"


def _clock(shift_s: float, start: Any) -> str:
    if start is not None:
        clock: str = (start + _dt.timedelta(seconds=float(shift_s))).strftime("%H:%M:%S")
        return clock
    h, rem = divmod(int(round(shift_s)), 3600)
    return f"{h}:{rem // 60:02d}:{rem % 60:02d}"


def worker_assumptions(
    session: Any, worker: Any | None, settings_name: str = "settings.toml"
) -> tuple[Assumption, ...]:
    """What was assumed for a worker (ergopose.session.WorkerInfo, or None for an unnamed worker):
    every task factor with the value in force for the whole session and where it was set, then
    every period that changes a factor."""
    start = getattr(session, "recorded_at", None)
    out = []
    own = worker.factors if worker is not None else None
    for name in FACTOR_USE:
        v_own = getattr(own, name) if own is not None else None
        v_def = getattr(session.defaults, name)
        if v_own is not None and worker is not None:  # v_own is only set with a worker
            value, src = v_own, f"{settings_name} [workers.{worker.worker_id}]"
        elif v_def is not None:
            value, src = v_def, f"{settings_name} [defaults]"
        else:
            value, src = None, "not in the settings"
        out.append(
            Assumption(
                item=FACTOR_WORDS[name], value=_factor_value(name, value), applies_to=FACTOR_USE[name], source=src
            )
        )
    periods = [(p, f"{settings_name} [[periods]]") for p in session.periods]
    if worker is not None:
        periods += [(p, f"{settings_name} [[workers.{worker.worker_id}.periods]]") for p in worker.periods]
    for p, src in periods:
        when = f"{_clock(p.start_s, start)} to {_clock(p.end_s, start)}"
        for name, value in p.factors.given().items():
            out.append(
                Assumption(
                    item=f"{FACTOR_WORDS[name]}, {when}",
                    value=_factor_value(name, value),
                    applies_to=FACTOR_USE[name],
                    source=src,
                )
            )
    return tuple(out)


def worker_infos(
    session: Any,
    worker_ids: Sequence[str],
    csv_files: Mapping[str, Sequence[tuple[str, str]]] | None = None,
    settings_name: str = "settings.toml",
) -> tuple[WorkerInfo, ...]:
    """WorkerInfo records for the workers found in a session (ids as in the results), with names
    and assumptions from the session settings (ergopose.session.Session) and their CSV files
    ({id: [(label, path relative to the report folder), ...]})."""
    named = {w.worker_id: w for w in session.workers}
    out = []
    for wid in worker_ids:
        w = named.get(wid)
        files = tuple(DataFile(label, path) for label, path in (csv_files or {}).get(wid, ()))
        out.append(
            WorkerInfo(
                worker_id=wid,
                name=w.name if w is not None else None,
                assumptions=worker_assumptions(session, w, settings_name),
                csv_files=files,
            )
        )
    return tuple(out)
