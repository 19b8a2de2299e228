"""From the other stages' real records to a rendered report.

Scripted workers (ergopose.sim.synthetic.walk_workers) -> joint angles -> RULA/REBA ->
shift aggregation -> adapters; noisy 3D joints in a tracks table -> limb diagnostics -> adapter;
then stored, re-loaded and rendered. The report's numbers must equal the aggregation's own.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd
import pytest

from ergopose.ergonomics.aggregate import aggregate_shift
from ergopose.ergonomics.angles import joint_angles
from ergopose.ergonomics.scoring import score_posture
from ergopose.keypoints import LIMBS, NUM_JOINTS
from ergopose.recon.diagnostics import limb_diagnostics
from ergopose.recon.pipeline import TrackFrames
from ergopose.sim.synthetic import WorkerScript, walk_workers
from ergopose.report import adapters
from ergopose.report.context import SessionInfo, WorkerInfo
from ergopose.report.quality import reliable_frames, reliable_rule
from ergopose.report.render import render_report
from ergopose.report.results import frames_table, load_results, save_results
from ergopose.session import FactorPeriod, Session, TaskFactors
from ergopose.session import WorkerInfo as SessionWorker

FPS = 12.0


@pytest.fixture(scope="module")
def pipeline_records():
    rng = np.random.default_rng(99)
    n = int(150 * FPS)
    scripts = [
        WorkerScript(1.72, np.array([[-1.5, 1.0], [1.0, 1.2], [1.5, -1.5]]), pause_s=20.0, work_phase=0.0),
        WorkerScript(1.65, np.array([[0.5, -2.0], [-1.8, -0.5]]), pause_s=30.0, work_phase=1.0),
    ]
    truth = walk_workers(scripts, n, FPS)  # (F, P, 33, 3)
    t = np.arange(n) / FPS
    out = []
    rows = []
    for p in range(truth.shape[1]):
        pts = truth[:, p] + rng.normal(0, 0.01, truth[:, p].shape)
        drop = rng.random((n, NUM_JOINTS)) < 0.02
        pts[drop] = np.nan
        posture = joint_angles(pts, t).to_frame()
        posture["time_s"] = t
        scores = score_posture(posture, with_events=True)
        frames = pd.concat([posture, scores], axis=1)
        summary = aggregate_shift(frames, f"worker_{p + 1}")
        out.append((frames, summary, pts))
        rows.append(pts)
    # a tracks table of both workers (rows sorted by frame then worker), lens angles from the centre
    pts_all = np.stack(rows, axis=1).reshape(-1, NUM_JOINTS, 3)
    worker = np.tile(np.arange(1, truth.shape[1] + 1), n)
    frame = np.repeat(np.arange(n), truth.shape[1])
    radius = np.hypot(pts_all[..., 0], pts_all[..., 1])
    lens = np.degrees(np.arctan2(np.nan_to_num(radius, nan=1.0), 3.0 - np.nan_to_num(pts_all[..., 2], nan=1.0)))
    tracks = TrackFrames(
        worker=worker,
        frame=frame,
        time_s=frame / FPS,
        points_world=pts_all,
        raw_points_world=pts_all,
        confidence=np.ones(pts_all.shape[:2]),
        reprojection_error_px=np.ones(pts_all.shape[:2]),
        views=np.full(pts_all.shape[:2], 2, np.int8),
        gap_filled=np.zeros(pts_all.shape[:2], bool),
        gated=np.zeros(pts_all.shape[:2], bool),
        smoothed=False,
        lens_angle_deg=lens,
    )
    return out, limb_diagnostics(tracks)


def test_worker_summary_matches_the_aggregation(pipeline_records):
    records, _ = pipeline_records
    frames, summary, pts = records[0]
    ws = adapters.worker_summary(summary, frames=frames, joints_at=lambda t: pts[int(round(t * FPS))])
    assert ws.observed_s == pytest.approx(summary.observed_s)
    d = summary.distributions["rula_action_level"]
    for lt in ws.levels:
        if lt.method == "rula":
            assert lt.seconds == pytest.approx(d.at(lt.level).time_s)
    assert ws.unscored_s["rula"] == pytest.approx(d.missing_time_s)
    # every distribution's band times add up to its scored time
    for col in ("rula_trunk_band", "left_rula_upper_arm_band"):
        _, words, _ = adapters.body_part_of(col)
        total = sum(b.seconds for b in ws.body_parts if b.method == "rula" and b.body_part == words)
        dist = summary.distributions[col]
        assert total == pytest.approx(dist.time_s - dist.missing_time_s)
    assert {b.criterion for b in ws.body_parts if b.body_part == "trunk" and b.method == "rula"} <= {
        "upright",
        "0-20 flexion",
        "20-60 flexion",
        "60 or more flexion",
    }
    # worst moments: inside their episodes, with a skeleton and a reason naming body parts
    assert ws.worst
    for w in ws.worst:
        assert w.start_s <= w.peak_s <= w.end_s
        assert w.joints_world_m is not None and len(w.joints_world_m) == 33
        assert w.reason
    top = ws.worst[0]
    i = int(np.argmin(np.abs(frames["time_s"].to_numpy() - top.peak_s)))
    assert top.rula_grand == int(frames["rula_grand"].iat[i])
    # exposure findings come through with the aggregation's verdicts
    assert [f.verdict for f in ws.flags] == [e.verdict for e in summary.exposure]
    assert [r.actions for r in ws.repetitions] == [r.actions for r in summary.repetitions]
    assert ws.hourly and all(h.observed_s == pytest.approx(summary.observed_s) for h in ws.hourly)


def test_body_part_of_columns():
    assert adapters.body_part_of("left_rula_upper_arm_band") == ("rula", "left upper arm", "upper_arm")
    assert adapters.body_part_of("reba_legs") == ("reba", "legs", "legs")
    assert adapters.body_part_of("right_reba_lower_arm") == ("reba", "right lower arm", "lower_arm")


def test_reliable_frames_rule():
    from ergopose.ergonomics.body import BodyMeasurements, Posture, place_on_floor, pose_skeleton

    m = BodyMeasurements.from_stature(1.8)
    pts = np.repeat(pose_skeleton(m, place_on_floor(m, Posture()))[None], 10, axis=0)
    pts[3, 15] = np.nan  # a wrist missing: forearm not reconstructed
    pts[5, 26] += np.array([0, 0, -0.2])  # a knee 20 cm off: thigh and shank lengths wrong
    pts[7, 0] = np.nan  # the nose: no scored limb needs it
    ok = reliable_frames(pts)
    assert ok.tolist() == [True, True, True, False, True, False, True, True, True, True]
    assert "15 %" in reliable_rule()


def test_diagnostics_adapter(pipeline_records):
    records, diags = pipeline_records
    frames, summary, pts = records[0]
    d = adapters.worker_diagnostics(
        diags[0], frames_reliable=int(reliable_frames(pts).sum()), reliable_rule=reliable_rule()
    )
    assert d.frames_observed == len(frames)
    assert sum(d.region_frames.values()) == len(frames)
    stats = {s.limb: s for s in d.limb_lengths if s.region == "all"}
    assert {s.region for s in d.limb_lengths} == {"all", "central", "outer", "edge"}
    assert set(stats) == {n for n, _, _ in LIMBS}
    src = diags[0].get("left_thigh")
    assert stats["left_thigh"].median_m == pytest.approx(src.percentiles_m[2])
    allf = {(r.limb, r.region): r for r in d.reconstruction}
    assert allf[("left_thigh", "all")].reconstructed == src.reconstructed
    assert 0.9 < allf[("left_thigh", "all")].reconstructed / allf[("left_thigh", "all")].frames < 1.0


def test_assumptions_from_session_settings(tmp_path):
    import datetime as dt

    session = Session(
        path=tmp_path,
        format_version=1,
        recorded_at=dt.datetime(2024, 3, 4, 8, 0, 0),
        fps=12.0,
        frame_count=100,
        cameras=(),
        defaults=TaskFactors(load_kg=0.0, coupling="good"),
        periods=(
            FactorPeriod(600.0, 900.0, TaskFactors(load_kg=12.0)),
            FactorPeriod(900.0, 960.0, TaskFactors(wrist_deviation=math.radians(-10.0))),
        ),
        workers=(
            SessionWorker(
                "w1",
                "Worker A",
                TaskFactors(load_kg=2.0, wrist_flexion=math.radians(-20.0)),
                (FactorPeriod(120.0, 180.0, TaskFactors(load_kg=15.0, load_mode="static")),),
            ),
        ),
        scoring={},
        description="Line 3",
        ground_truth_dir=None,
        settings_path=tmp_path / "settings.toml",
        calibration_path=tmp_path / "calibration.toml",
    )
    infos = adapters.worker_infos(session, ["w1", "w2"], {"w1": [("Per-frame scores", "csv/w1.csv")]})
    w1, w2 = infos
    assert w1.name == "Worker A" and w2.name is None
    by_item = {a.item: a for a in w1.assumptions}
    assert by_item["load"].value == "2 kg" and by_item["load"].source == "settings.toml [workers.w1]"
    assert by_item["hand coupling"].value == "good" and by_item["hand coupling"].source == "settings.toml [defaults]"
    assert by_item["seated"].value == "not given: scored as unknown"
    assert by_item["load, 08:02:00 to 08:03:00"].value == "15 kg"
    assert by_item["load held, 08:02:00 to 08:03:00"].value == "static"
    assert by_item["load, 08:10:00 to 08:15:00"].source == "settings.toml [[periods]]"
    assert by_item["wrist flexion of the task"].value == "-20° (extension)"
    assert by_item["wrist flexion of the task"].source == "settings.toml [workers.w1]"
    assert "where the cameras do not see the hand" in by_item["wrist flexion of the task"].applies_to
    assert by_item["wrist deviation of the task"].value == "not given: the measured angle is scored"
    assert (
        by_item["wrist deviation of the task, 08:15:00 to 08:16:00"].value == "-10° (ulnar, toward the little finger)"
    )
    assert {a.item for a in w2.assumptions} >= {"load", "load, 08:10:00 to 08:15:00"}
    assert w1.csv_files[0].path == "csv/w1.csv"


def test_from_pipeline_records_to_pages(pipeline_records, tmp_path):
    """The whole chain renders, and the page shows the aggregation's own percentages."""
    records, diags = pipeline_records
    from report_synthetic import synthetic_session

    base, _ = synthetic_session(n_workers=1, duration_s=60.0)
    workers, infos = [], []
    for (frames, summary, pts), diag in zip(records, diags):
        ws = adapters.worker_summary(summary, frames=frames, joints_at=lambda t, pts=pts: pts[int(round(t * FPS))])
        wd = adapters.worker_diagnostics(
            diag, frames_reliable=int(reliable_frames(pts).sum()), reliable_rule=reliable_rule()
        )
        mid = (pts[:, 23, :2] + pts[:, 24, :2]) / 2  # NaN where a hip is missing
        table = frames_table(
            frames["time_s"].to_numpy(),
            rula_grand=frames["rula_grand"],
            rula_action_level=frames["rula_action_level"],
            reba_score=frames["reba_score"],
            reba_risk_level=frames["reba_risk_level"],
            floor_x_m=mid[:, 0],
            floor_y_m=mid[:, 1],
            reliable=reliable_frames(pts),
        )
        workers.append((ws, wd, table))
        infos.append(WorkerInfo(worker_id=summary.worker))
    n = len(records[0][0])
    session = SessionInfo(
        **{**base.__dict__, "workers": tuple(infos), "frames": n, "duration_s": n / FPS, "csv_files": ()}
    )
    save_results(tmp_path, session, workers)
    render_report(tmp_path)
    text = (tmp_path / "worker-worker_1.html").read_text(encoding="utf-8")
    d = records[0][1].distributions["rula_action_level"]
    for v in d.values:
        cell = re.search(rf'data-share="rula-{v.value}">([^<]*)<', text).group(1)
        assert cell == f"{v.percent:.1f} %"
    assert load_results(tmp_path).workers[1].info.worker_id == "worker_2"
    assert not math.isnan(records[0][1].observed_s)
