"""A realistic, seeded synthetic result set for report tests and the report benchmark.

Not a pipeline: scores follow a piecewise-constant task process (a worker moves between the
stations of the simulated scene, each with its own score distribution), with tracking gaps, a
break, unscored stretches and less reliable skeletons near the lens edge. The summary records are
derived from the generated frames where the report could check them (time per level, per hour,
unscored time, worst moments), so tests can compute the expected headline numbers independently
from ``frames``. Skeletons of the worst moments come from the body model (ergopose.ergonomics.body).

Used by tests/report/*.py and bench/bench_report.py (which loads it by path).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pandas as pd

from ergopose import __version__
from ergopose.ergonomics.body import BodyMeasurements, Posture, place_on_floor, pose_skeleton
from ergopose.ergonomics.methods import load_method
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.keypoints import LIMB_INDEX, LIMBS
from ergopose.report import periods
from ergopose.report.adapters import (
    floor_plan_from_scene,
    methods_info,
    period_input_records,
    settings_records,
    worst_periods,
)
from ergopose.report.context import (
    Assumption,
    BandTime,
    CauseSeconds,
    ConfidenceTime,
    InputQuality,
    DataFile,
    SettingsValue,
    CalibrationInfo,
    Hold,
    HourLevels,
    LevelTime,
    LimbFrequency,
    LimbStats,
    ModelInfo,
    RegionAccuracy,
    Repetition,
    SessionInfo,
    StandardFlag,
    WorkerDiagnostics,
    WorkerInfo,
    WorkerSummary,
    Driver,
)
from ergopose.report.results import frames_table
from ergopose.sim.scene import RIG_POSITIONS, default_scene, lens_region

START = "2024-05-06T06:00:00"

#: Body parts and bands per method: (body part, [(score, criterion), ...]).
RULA_PARTS = [
    (
        "left upper arm",
        [
            (1, "20 deg extension to 20 deg flexion"),
            (2, "20-45 deg flexion or extension > 20 deg"),
            (3, "45-90 deg flexion"),
            (4, "90 deg flexion or more"),
        ],
    ),
    (
        "right upper arm",
        [
            (1, "20 deg extension to 20 deg flexion"),
            (2, "20-45 deg flexion or extension > 20 deg"),
            (3, "45-90 deg flexion"),
            (4, "90 deg flexion or more"),
        ],
    ),
    ("left lower arm", [(1, "60-100 deg flexion"), (2, "below 60 or above 100 deg flexion")]),
    ("right lower arm", [(1, "60-100 deg flexion"), (2, "below 60 or above 100 deg flexion")]),
    ("neck", [(1, "0-10 deg flexion"), (2, "10-20 deg flexion"), (3, "20 deg flexion or more"), (4, "in extension")]),
    ("trunk", [(1, "upright"), (2, "0-20 deg flexion"), (3, "20-60 deg flexion"), (4, "60 deg flexion or more")]),
]
REBA_PARTS = [
    ("neck", [(1, "0-20 deg flexion"), (2, "over 20 deg flexion or in extension")]),
    (
        "trunk",
        [(1, "upright"), (2, "0-20 deg flexion or extension"), (3, "20-60 deg flexion"), (4, "over 60 deg flexion")],
    ),
    ("legs", [(1, "bilateral weight bearing"), (2, "unilateral or unstable")]),
]

#: Score distribution of each station kind (RULA grand 1..7 probabilities).
TASK_RULA = {
    "shelf": [0.02, 0.10, 0.25, 0.23, 0.20, 0.12, 0.08],
    "assembly": [0.05, 0.20, 0.38, 0.22, 0.10, 0.04, 0.01],
    "lift": [0.01, 0.04, 0.10, 0.15, 0.25, 0.25, 0.20],
    "rest": [0.35, 0.40, 0.20, 0.05, 0.0, 0.0, 0.0],
}


#: The synthetic session's notice (shown under every page's header).
SYNTHETIC_NOTICE = (
    "the settings say the area holds 2 workers, but more people are reported here: W2 and W3 are most "
    "likely one worker followed under two ids (followed at the same time in 4 % of the shorter one's frames)."
)


def _kind(station_name: str) -> str:
    for k in ("shelf", "table", "pallet", "rest"):
        if station_name.startswith(k):
            return {"table": "assembly", "pallet": "lift"}.get(k, k)
    return "assembly"


def _stations(scene):
    return [(s.name, _kind(s.name), np.array(s.position, dtype=np.float64)) for s in scene.stations]


def _worker_frames(
    rng: np.random.Generator, duration_s: float, fps: float, stations, gaps: bool = True
) -> pd.DataFrame:
    n_all = int(round(duration_s * fps))
    t = np.arange(n_all) / fps
    # task segments: mean 25 s, a station per run of segments (a few minutes at each)
    n_seg = int(duration_s / 8) + 10
    seg_len = rng.exponential(25.0, n_seg) + 2.0
    seg_end = np.cumsum(seg_len)
    seg_of = np.searchsorted(seg_end, t, side="right")
    visit_len = rng.integers(3, 12, n_seg)
    visit_of_seg = np.repeat(np.arange(n_seg), visit_len)[:n_seg]
    st_of_visit = rng.integers(0, len(stations), n_seg)
    st = st_of_visit[visit_of_seg][seg_of]
    kinds = np.array([k for _, k, _ in stations])
    kind_of_frame = kinds[st]
    rula = np.empty(n_all)
    seg_u = rng.random(n_seg)
    for kind, probs in TASK_RULA.items():
        cdf = np.cumsum(probs)
        cdf /= cdf[-1]
        seg_score = np.searchsorted(cdf, seg_u) + 1
        sel = kind_of_frame == kind
        rula[sel] = seg_score[seg_of[sel]]
    # short excursions (one or two points up) inside segments
    bump = rng.random(n_all // 6 + 1) < 0.15
    rula = np.clip(rula + np.repeat(bump, 6)[:n_all], 1, 7)
    reba_noise = rng.normal(0.0, 1.0, n_seg)[seg_of]
    reba = np.clip(np.round(1.7 * rula - 1.0 + reba_noise), 1, 15)
    pos = np.stack([s[2] for s in stations])[st] + rng.normal(0.0, 0.12, (n_all, 2))
    # not tracked: a 30-minute break mid-shift (if long enough) and short occlusions
    tracked = np.ones(n_all, dtype=bool)
    if gaps and duration_s > 3 * 3600:
        b0 = duration_s * 0.5
        tracked &= ~((t >= b0) & (t < b0 + 1800))
    occl = rng.random(n_seg) < 0.04
    if gaps:
        tracked &= ~occl[seg_of]
    # unscored stretches (joints missing) and reliability worse near the edge
    unscored = (rng.random(n_seg) < 0.03)[seg_of]
    radius = np.hypot(pos[:, 0], pos[:, 1])
    p_bad = 0.02 + 0.12 * (radius / 4.0) ** 2
    reliable = rng.random(n_seg)[seg_of] > p_bad
    rula[unscored] = np.nan
    reba[unscored] = np.nan
    rm, bm = load_method("rula"), load_method("reba")
    frame = frames_table(
        t[tracked],
        rula_grand=rula[tracked],
        rula_action_level=rm.level_of(rula)[tracked],
        reba_score=reba[tracked],
        reba_risk_level=bm.level_of(reba)[tracked],
        floor_x_m=pos[tracked, 0],
        floor_y_m=pos[tracked, 1],
        reliable=reliable[tracked],
    )
    return frame


def _posture_for(rula: int, rng: np.random.Generator, x: float, y: float) -> Posture:
    sev = (rula - 1) / 6.0
    return Posture(
        root_position=np.array([x, y, 0.0]),
        heading=float(rng.uniform(-math.pi, math.pi)),
        trunk_flexion=math.radians(70 * sev + rng.uniform(0, 10)),
        trunk_twist=math.radians(rng.uniform(-15, 15)),
        neck_flexion=math.radians(10 + 20 * sev),
        left_upper_arm_flexion=math.radians(30 + 90 * sev),
        right_upper_arm_flexion=math.radians(20 + 60 * sev * rng.uniform(0.5, 1)),
        left_elbow_flexion=math.radians(40),
        right_elbow_flexion=math.radians(80),
        left_knee_flexion=math.radians(10 + 30 * sev),
        right_knee_flexion=math.radians(10 + 20 * sev),
        left_hip_flexion=math.radians(10 + 20 * sev),
        right_hip_flexion=math.radians(10 + 15 * sev),
    )


def _summary(
    worker_id: str,
    frames: pd.DataFrame,
    fps: float,
    duration_s: float,
    rng: np.random.Generator,
    body: BodyMeasurements,
) -> WorkerSummary:
    dt = 1.0 / fps
    t = frames["time_s"].to_numpy()
    levels = []
    unscored = {}
    hourly = []
    methods = {
        "rula": ("rula_grand", "rula_action_level", range(1, 5)),
        "reba": ("reba_score", "reba_risk_level", range(0, 5)),
    }
    for m, (_, lcol, lv_range) in methods.items():
        lv = frames[lcol].to_numpy(dtype=np.float64, na_value=np.nan)
        for k in lv_range:
            levels.append(LevelTime(m, k, float(np.sum(lv == k)) * dt))
        unscored[m] = float(np.sum(np.isnan(lv))) * dt
        hour = (t // 3600).astype(int)
        for h in range(int(math.ceil(duration_s / 3600))):
            sel = hour == h
            hl = lv[sel]
            hourly.append(
                HourLevels(
                    start_s=3600.0 * h,
                    method=m,
                    levels=tuple(LevelTime(m, k, float(np.sum(hl == k)) * dt) for k in lv_range),
                    unscored_s=float(np.sum(np.isnan(hl))) * dt,
                    observed_s=float(sel.sum()) * dt,
                )
            )
    observed = len(frames) * dt
    scored = observed - unscored["rula"]
    body_parts = []
    for m, parts in (("rula", RULA_PARTS), ("reba", REBA_PARTS)):
        for part, bands in parts:
            share = rng.dirichlet(np.linspace(3.0, 0.6, len(bands)))
            for (score, crit), s in zip(bands, share):
                body_parts.append(BandTime(m, part, score, crit, float(s * scored * rng.uniform(0.93, 0.99))))
    holds = tuple(
        Hold(
            part,
            "rula",
            bands[-1][0],
            bands[-1][1],
            float(rng.uniform(0, max(duration_s - 300, 1.0))),
            float(rng.uniform(20, 240)),
        )
        for part, bands in RULA_PARTS[:4]
    )
    minutes = int(observed // 60)
    reps = tuple(
        Repetition(
            part,
            angle,
            int(rng.integers(minutes, 4 * minutes + 1)),
            float(rng.uniform(1, 4)),
            int(rng.integers(5, 15)),
            4.0,
            int(rng.integers(0, max(minutes // 4, 1))),
        )
        for part, angle in (
            ("left upper arm", "left_upper_arm_flexion"),
            ("right upper arm", "right_upper_arm_flexion"),
            ("trunk", "trunk_flexion"),
            ("right wrist", "right_wrist_flexion"),
        )
    )
    # sustained periods of high risk, found as the pipeline finds them; skeletons from the body
    # model at each drawn frame's score; what drove them made up (the frames hold no bands)
    rm, bm = load_method("rula"), load_method("reba")

    def joints_at(time_s: float) -> np.ndarray:
        i = int(np.argmin(np.abs(t - time_s)))
        r = int(frames["rula_grand"].iat[i]) if not pd.isna(frames["rula_grand"].iat[i]) else 4
        x, y = float(frames["floor_x_m"].iat[i]), float(frames["floor_y_m"].iat[i])
        return pose_skeleton(body, place_on_floor(body, _posture_for(r, rng, x, y)))

    worst = []
    for k, w in enumerate(worst_periods(frames, None, {"rula": rm, "reba": bm}, dt, joints_at)):
        drivers = (
            Driver("rula", "left upper arm", 4, 4, "90 or more flexion", round(0.4 * w.high_s, 3)),
            Driver("rula", "trunk", 3, 4, "20-60 flexion", round(0.8 * w.high_s, 3)),
            Driver("rula", "right wrist", 3, 3, "15 or more flexion or extension", round(0.3 * w.high_s, 3)),
        )[: 1 + k % 3]
        joints = w.joints_world_m
        if k == 4 and joints is not None:  # one period with a missing forearm, as happens behind shelves
            joints = tuple((math.nan,) * 3 if j in (15, 17, 19, 21) else p for j, p in enumerate(joints))
        h = w.high_s
        uses = (
            periods.InputUse("angles", "measured", None, h, periods.MEASURED_INPUTS),
            periods.InputUse("left_wrist_flexion", "task input", math.radians(20.0), round(0.3 * h, 3)),
            periods.InputUse("load", "task input", (12.0, "static"), round(0.75 * h, 3)),
            periods.InputUse("arm_supported", "task input", False, h),
            periods.InputUse("load", "not given", None, round(0.25 * h, 3)),
            periods.InputUse("coupling", "not given", None, h),
        )
        inputs = period_input_records(uses[: 2 + k % 5]) if k != 2 else ()  # period 3: results before inputs
        worst.append(
            dataclasses.replace(
                w,
                drivers=drivers,
                joints_world_m=joints,
                inputs=inputs,
                reason="; ".join(f"{d.body_part} {d.criterion} (band {d.score} of {d.top})" for d in drivers),
            )
        )
    flags = (
        StandardFlag(
            "ISO 11226",
            "trunk",
            "trunk inclination over 60 deg",
            "not recommended",
            float(rng.uniform(300, 900)),
            float(rng.uniform(5, 40)),
            "held longer than 4 s",
        ),
        StandardFlag(
            "ISO 11226",
            "left upper arm",
            "upper arm elevation 20-60 deg",
            "time-limited",
            float(rng.uniform(1000, 3000)),
            float(rng.uniform(30, 120)),
            "holding time within the limit",
        ),
        StandardFlag(
            "EN 1005-4",
            "upper arm",
            "upper arm elevation over 60 deg",
            "not acceptable",
            float(rng.uniform(200, 600)),
            float(rng.uniform(5, 30)),
            "at 2 or more per minute",
        ),
        StandardFlag(
            "EN 1005-4",
            "trunk",
            "trunk twist or side bend under 10 deg",
            "acceptable",
            float(rng.uniform(5000, 9000)),
            float(rng.uniform(100, 600)),
            "within the first limit",
        ),
        StandardFlag(
            "ISO 11226", "left shoulder", "the angles needed were not measured", "not measured", 0.0, float("nan"), ""
        ),
    )
    # confidence (no draws from rng, so the other workers' frames stay as they were): unscored where
    # either score is missing ("not seen"); of the scored frames, every third block of 60 frames is
    # low confidence, split between one camera and occluded limbs
    missing = np.isnan(frames["rula_grand"].to_numpy(dtype=np.float64, na_value=np.nan)) | np.isnan(
        frames["reba_score"].to_numpy(dtype=np.float64, na_value=np.nan)
    )
    block = np.arange(len(frames)) // 60
    low = ~missing & (block % 3 == 0)
    one_camera = low & (block % 2 == 0)
    confidence = (
        ConfidenceTime("confident", float((~missing & ~low).sum()) * dt),
        ConfidenceTime(
            "low",
            float(low.sum()) * dt,
            (
                CauseSeconds("one camera", float(one_camera.sum()) * dt),
                CauseSeconds("occluded limbs", float((low & ~one_camera).sum()) * dt),
            ),
        ),
        ConfidenceTime("unscored", float(missing.sum()) * dt, (CauseSeconds("not seen", float(missing.sum()) * dt),)),
    )
    inputs = (
        InputQuality(
            "neck", ("neck_flexion", "neck_side_bend", "neck_twist"), math.radians(6.4), 0.2 * observed, observed
        ),
        InputQuality(
            "left wrist",
            ("left_wrist_flexion", "left_wrist_deviation"),
            math.radians(14.5),
            0.7 * observed,
            observed,
            (
                SettingsValue("left_wrist_flexion", math.radians(-20.0), 0.35 * observed, 0.9 * observed),
                SettingsValue("left_wrist_deviation", 0.0, 0.3 * observed, 0.9 * observed),
            ),
        ),
        InputQuality("trunk", ("trunk_flexion",), math.radians(2.1), 0.0, observed),
    )
    return WorkerSummary(
        worker_id=worker_id,
        observed_s=observed,
        levels=tuple(levels),
        unscored_s=unscored,
        body_parts=tuple(body_parts),
        holds=holds,
        repetitions=reps,
        hourly=tuple(hourly),
        worst=tuple(worst),
        flags=flags,
        confidence=confidence,
        inputs=inputs,
    )


def _diagnostics(
    worker_id: str, frames: pd.DataFrame, rng: np.random.Generator, body: BodyMeasurements
) -> WorkerDiagnostics:
    x = frames["floor_x_m"].to_numpy()
    y = frames["floor_y_m"].to_numpy()
    # angle from the nearer camera's axis to the worker's chest (1.3 m above the floor)
    thetas = [np.arctan2(np.hypot(x - cx, y - cy), cz - 1.3) for cx, cy, cz in RIG_POSITIONS]
    region = lens_region(np.minimum(*thetas))
    names = ("central", "outer", "edge")
    region_frames = {n: int(np.sum(region == k)) for k, n in enumerate(names)}
    skeleton = pose_skeleton(body, place_on_floor(body, Posture()))
    true_len = np.linalg.norm(skeleton[LIMB_INDEX[:, 0]] - skeleton[LIMB_INDEX[:, 1]], axis=-1)
    noise = {"central": 0.01, "outer": 0.018, "edge": 0.035}  # the paper's Table 1 spreads (metres)
    stats = []
    recon = []
    p_face = {"central": 0.97, "outer": 0.93, "edge": 0.82}
    for li, (limb, _, _) in enumerate(LIMBS):
        samples = []
        base = 0.9 if limb.endswith("hand") or limb.endswith("foot") else 0.97
        total_n = total_r = 0
        for k, reg in enumerate(names):
            nf = region_frames[reg]
            p = base * p_face[reg] / 0.97
            nr = int(rng.binomial(nf, min(p, 1.0))) if nf else 0
            recon.append(LimbFrequency(limb, reg, nf, nr))
            total_n += nf
            total_r += nr
            m = min(nr, 4000)
            reg_samples = true_len[li] + rng.normal(0, noise[reg] * (0.5 + true_len[li]), m)
            samples.append(reg_samples)
            if m:
                rq = np.percentile(reg_samples, [5, 25, 50, 75, 95])
                stats.append(
                    LimbStats(
                        limb, nr, float(reg_samples.mean()), float(reg_samples.std()), *map(float, rq), region=reg
                    )
                )
        recon.append(LimbFrequency(limb, "all", total_n, total_r))
        s = np.concatenate(samples)
        q = np.percentile(s, [5, 25, 50, 75, 95]) if s.size else [np.nan] * 5
        stats.append(LimbStats(limb, total_r, float(s.mean()), float(s.std()), *map(float, q)))
    reliable = int(frames["reliable"].sum())
    return WorkerDiagnostics(
        worker_id=worker_id,
        frames_observed=len(frames),
        frames_reliable=reliable,
        reliable_rule="all scored joints triangulated from both cameras with a reprojection "
        "error under 8 px and limb lengths within 15 % of the worker's median",
        region_frames=region_frames,
        limb_lengths=tuple(stats),
        reconstruction=tuple(recon),
        error_3d_m=0.027,
    )


def synthetic_session(
    n_workers: int = 3,
    duration_s: float = 2 * 3600.0,
    fps: float = 12.0,
    seed: int = 20240506,
    names: dict[str, str] | None = None,
    start: str | None = START,
    csv: bool = True,
    gaps: bool = True,
) -> tuple[SessionInfo, list[tuple[WorkerSummary, WorkerDiagnostics, pd.DataFrame]]]:
    """A session record and per-worker (summary, diagnostics, frames), seeded.

    gaps: False tracks every worker in every frame (no break, no occlusions).
    """
    rng = np.random.default_rng(seed)
    scene = default_scene()
    stations = _stations(scene)
    names = names or {}
    infos, results = [], []
    for k in range(n_workers):
        wid = f"W{k + 1}"
        body = BodyMeasurements.from_stature(1.62 + 0.08 * (k % 4))
        frames = _worker_frames(rng, duration_s, fps, stations, gaps)
        summary = _summary(wid, frames, fps, duration_s, rng, body)
        diag = _diagnostics(wid, frames, rng, body)
        infos.append(
            WorkerInfo(
                worker_id=wid,
                name=names.get(wid),
                assumptions=(
                    Assumption(
                        "load",
                        "2-10 kg, intermittent" if k % 2 == 0 else "under 2 kg",
                        "RULA steps 7 and 14, REBA step 5",
                        f"session.toml [workers.{wid}]",
                    ),
                    Assumption("coupling", "fair", "REBA step 11", "default"),
                    Assumption("arm support", "none", "RULA step 1a, REBA step 7a", "default"),
                ),
                csv_files=(
                    DataFile("Per-frame scores", f"csv/{wid}.csv"),
                    DataFile("Shift summary", f"csv/{wid}-summary.csv"),
                )
                if csv
                else (),
            )
        )
        results.append((summary, diag, frames))
    cams = [(f"cam_{i + 1}", p[0], p[1]) for i, p in enumerate(RIG_POSITIONS)]
    session = SessionInfo(
        session_id="synthetic-shift",
        title="Assembly hall, synthetic shift",
        site="Hall 3, station block B",
        start=start,
        fps=fps,
        frames=int(round(duration_s * fps)),
        duration_s=duration_s,
        ergopose_version=__version__,
        created="2024-05-06T15:02:11Z",
        models=(
            ModelInfo(
                "blazepose_detector",
                "pose_detection.tflite",
                "9ba9dd3d42efaaba86b4ff0122b06f29c4122e756b329d89dca1e297fd8f866c",
                "mediapipe==0.10.14",
            ),
            ModelInfo(
                "blazepose_landmark_full",
                "pose_landmark_full.tflite",
                "e9a5c5cb17f736fafd4c2ec1da3b3d331d6edbe8a0d32395855aeb2cdfd64b9f",
                "mediapipe==0.10.14",
            ),
        ),
        methods=methods_info(),
        settings=settings_records(ScoringSettings()),
        calibration=CalibrationInfo(
            file="calibration.toml",
            sha256="0" * 64,
            cameras=("cam_1", "cam_2"),
            reprojection_rms_px=0.41,
            regions=(
                RegionAccuracy("central", 1.5, 1.49, 0.01, 12),
                RegionAccuracy("outer", 1.5, 1.52, 0.018, 12),
                RegionAccuracy("edge", 1.5, 1.56, 0.035, 12),
            ),
        ),
        floor=floor_plan_from_scene(scene, cams),
        workers=tuple(infos),
        csv_files=(DataFile("Session summary", "csv/session-summary.csv"),) if csv else (),
        notices=(SYNTHETIC_NOTICE,),
    )
    return session, results


def write_csv_targets(report_dir: Path, session: SessionInfo, only_workers: bool = False) -> None:
    """Tiny CSV files where the session says they are, so the report links resolve (ergopose.ergonomics.export writes the real ones)."""
    paths = [f.path for w in session.workers for f in w.csv_files]
    if not only_workers:
        paths += [f.path for f in session.csv_files]
    for p in paths:
        f = report_dir / p
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text("time_s,rula_grand\n0.0,3\n", encoding="utf-8")
