"""The tracked time split by confidence (scored with confidence, low confidence, unscored, with
causes) is counted once, in the shift aggregation, and the worker summary CSV, the session summary
CSV, the rendered report and the terminal summary show the same seconds and percentages.

Frames with known ``confidence`` / ``cause`` columns (as ergopose.pipeline.score.score_uncertainty
writes them): 200 frames at 10 frames per second (20 s tracked):
  confident                100 frames  10 s  50 %
  low, one camera           40 frames   4 s  20 %
  low, occluded limbs       20 frames   2 s  10 %
  unscored, not seen        30 frames   3 s  15 %
  unscored, one camera      10 frames   1 s   5 %
and the left wrist's inputs: SD 5 degrees in 150 frames and 20 degrees in 50 (median 5), its
joints inferred in 120 frames (60 %); the neck measured with SD 2 degrees, never inferred.
"""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ergopose.commands.assess import worker_lines
from ergopose.ergonomics.aggregate import aggregate_shift
from ergopose.ergonomics.export import session_summary_table, worker_summary_table
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS
from ergopose.pipeline.publish import WorkerOutput
from ergopose.report import adapters
from ergopose.report.render import render_report
from ergopose.report.results import load_results, save_results, session_results
from report_synthetic import synthetic_session

FPS = 10.0
EXPECTED = {  # level -> (seconds, percent, {cause: (seconds, percent)})
    "confident": (10.0, 50.0, {}),
    "low": (4.0 + 2.0, 30.0, {"one camera": (4.0, 20.0), "occluded limbs": (2.0, 10.0)}),
    "unscored": (3.0 + 1.0, 20.0, {"not seen": (3.0, 15.0), "one camera": (1.0, 5.0)}),
}


def _frames() -> tuple[pd.DataFrame, np.ndarray]:
    n = 200
    spec = [
        ("confident", "", 100),
        ("low", "one camera", 40),
        ("low", "occluded limbs", 20),
        ("unscored", "not seen", 30),
        ("unscored", "one camera", 10),
    ]
    conf = np.concatenate([[c] * k for c, _, k in spec])
    cause = np.concatenate([[ca] * k for _, ca, k in spec])
    order = np.random.default_rng(3).permutation(n)  # interleaved, so runs cross chunk ends
    conf, cause = conf[order], cause[order]
    scored = conf != "unscored"
    rula = np.where(scored, np.where(np.arange(n) % 4 == 0, 6, 3), np.nan)
    reba = np.where(scored, np.where(np.arange(n) % 5 == 0, 9, 4), np.nan)
    sd_wrist = np.where(np.arange(n) < 150, 5.0, 20.0)[order]
    frames = pd.DataFrame(
        {
            "worker": "W1",
            "frame": np.arange(n),
            "time_s": np.arange(n) / FPS,
            "rula_grand": pd.array(rula, dtype="Float64").astype("Int16"),
            "rula_action_level": pd.array(
                np.where(np.isnan(rula), np.nan, np.where(rula >= 5, 3, 2)), dtype="Float64"
            ).astype("Int8"),
            "reba_score": pd.array(reba, dtype="Float64").astype("Int16"),
            "reba_risk_level": pd.array(
                np.where(np.isnan(reba), np.nan, np.where(reba >= 8, 3, 2)), dtype="Float64"
            ).astype("Int8"),
            "left_wrist_flexion": np.radians(10.0),
            "left_wrist_flexion_sd": np.radians(sd_wrist),
            "neck_flexion": np.radians(15.0),
            "neck_flexion_sd": np.radians(2.0),
            "confidence": pd.array(conf, dtype="string"),
            "cause": pd.array(cause, dtype="string"),
        }
    )
    inferred = np.zeros((n, NUM_JOINTS), dtype=bool)
    inferred[order[:120], JOINT_INDEX["left_pinky"]] = True
    return frames, inferred


@pytest.fixture(scope="module")
def summary():
    frames, inferred = _frames()
    return aggregate_shift(frames, "W1", frame_period_s=1.0 / FPS, chunk_frames=37, inferred=inferred)


def test_aggregation_splits_tracked_time(summary):
    assert summary.observed_s == pytest.approx(20.0)
    assert [c.level for c in summary.confidence] == ["confident", "low", "unscored"]
    for c in summary.confidence:
        secs, pct, causes = EXPECTED[c.level]
        assert c.time_s == pytest.approx(secs) and c.percent == pytest.approx(pct)
        assert [ca.cause for ca in c.causes] == list(causes)
        for ca in c.causes:
            assert (ca.time_s, ca.percent) == pytest.approx(causes[ca.cause])
    assert sum(c.time_s for c in summary.confidence) == pytest.approx(summary.observed_s)
    # the same answer in one piece as in chunks of 37 frames
    frames, inferred = _frames()
    assert aggregate_shift(frames, "W1", frame_period_s=1.0 / FPS, inferred=inferred).confidence == summary.confidence


def test_aggregation_measures_inputs(summary):
    inputs = {i.body_part: i for i in summary.inputs}
    wrist, neck = inputs["left wrist"], inputs["neck"]
    assert math.degrees(wrist.median_sd_rad) == pytest.approx(5.0, abs=0.01)
    assert (wrist.inferred_frames, wrist.known_frames, wrist.inferred_percent) == (120, 200, pytest.approx(60.0))
    assert math.degrees(neck.median_sd_rad) == pytest.approx(2.0, abs=0.01)
    assert neck.inferred_frames == 0
    assert math.isnan(inputs["legs"].median_sd_rad) and inputs["legs"].measured_frames == 0


def test_summary_csvs_carry_the_split(summary):
    long = worker_summary_table(summary)
    conf = long[long["section"] == "confidence"]
    for level, (secs, pct, causes) in EXPECTED.items():
        allrow = conf[(conf["item"] == level) & (conf["value"] == "all")].iloc[0]
        assert (allrow["time_s"], allrow["percent"]) == pytest.approx((secs, pct))
        for cause, (cs, cp) in causes.items():
            row = conf[(conf["item"] == level) & (conf["value"] == cause)].iloc[0]
            assert (row["time_s"], row["percent"]) == pytest.approx((cs, cp))
    wrist = long[(long["section"] == "inputs") & (long["item"] == "left wrist")].set_index("value")
    assert wrist.loc["angle sd", "sd_deg"] == pytest.approx(5.0, abs=0.01)
    assert wrist.loc["inferred", "percent"] == pytest.approx(60.0)

    row = session_summary_table([summary]).iloc[0]
    assert (row["confident_s"], row["confident_pct_of_tracked"]) == pytest.approx((10.0, 50.0))
    assert (row["low_confidence_s"], row["low_confidence_pct_of_tracked"]) == pytest.approx((6.0, 30.0))
    assert (row["low_confidence_one_camera_s"], row["low_confidence_occluded_limbs_s"]) == pytest.approx((4.0, 2.0))
    assert (row["scored_s"], row["scored_pct_of_tracked"]) == pytest.approx((16.0, 80.0))
    assert row["low_confidence_not_seen_s"] == 0.0
    assert (row["unscored_s"], row["unscored_pct_of_tracked"], row["unscored_not_seen_s"]) == pytest.approx(
        (4.0, 20.0, 3.0)
    )
    assert row["left_wrist_inferred_pct_of_tracked"] == pytest.approx(60.0)
    # high risk with both bases: RULA level 3 in the frames with grand score 6
    frames, _ = _frames()
    high = float((frames["rula_action_level"] >= 3).sum()) / FPS
    assert row["rula_high_s"] == pytest.approx(high)
    assert row["rula_high_pct_of_tracked"] == pytest.approx(100 * high / 20.0, abs=0.006)
    assert row["rula_high_pct_of_scored"] == pytest.approx(100 * high / 16.0, abs=0.006)


def _text(html: str) -> str:
    return re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", html))


def test_report_and_terminal_show_the_same_figures(summary, tmp_path: Path):
    session, workers = synthetic_session(n_workers=1, duration_s=20.0, fps=FPS, gaps=False, csv=False)
    _, diag, frames = workers[0]
    record = adapters.worker_summary(summary)
    save_results(tmp_path, session, [(record, diag, frames)])
    files = render_report(tmp_path, session_results(session, [(record, diag, frames)]))
    page = (tmp_path / "worker-W1.html").read_text(encoding="utf-8")
    index = files.index.read_text(encoding="utf-8")

    shares = dict(re.findall(r'data-share="confidence-(\w+)">([^<]*)<', page))
    assert shares == {"confident": "50.0 %", "low": "30.0 %", "unscored": "20.0 %"}
    for level, share in (("confident", "50.0 %"), ("low", "30.0 %"), ("unscored", "20.0 %")):
        assert re.search(rf'data-share="{level}">{re.escape(share)}<', index), level
    row = re.search(r'<tr data-confidence="low">(.*?)</tr>', page).group(1)
    assert "6.0 s" in row and "one camera 4.0 s (20.0 %)" in row and "occluded limbs 2.0 s (10.0 %)" in row
    row = re.search(r'<tr data-confidence="unscored">(.*?)</tr>', page).group(1)
    assert "not seen 3.0 s (15.0 %)" in row and "one camera 1.0 s (5.0 %)" in row

    # the quality section names the wrist as mostly inferred and gives its median SD
    wrist = re.search(r'<tr data-input="left wrist">(.*?)</tr>', page).group(1)
    assert "5.0°" in wrist and "60.0 %" in wrist and "mostly inferred" in wrist and "wrist_twist_end_range" in wrist
    neck = re.search(r'<tr data-input="neck">(.*?)</tr>', page).group(1)
    assert "2.0°" in neck and "0.0 %" in neck and "measured" in neck
    assert "docs/session-format.md" in _text(page)

    # the headline states both bases; the terminal prints the very same figures
    rula_high = float((_frames()[0]["rula_action_level"] >= 3).sum()) / FPS
    text = _text(page)
    tracked_pct, scored_pct = f"{100 * rula_high / 20.0:.1f} %", f"{100 * rula_high / 16.0:.1f} %"
    assert f"{tracked_pct} of the tracked time" in text and f"{scored_pct} of the scored time" in text
    lines = worker_lines(WorkerOutput(worker_id="W1", name="W1", summary=summary, csv_files=()))
    terminal = "\n".join(lines)
    assert "scored with confidence: 10 s (50.0 % of tracked time)" in terminal
    assert (
        "scored with low confidence: 6.0 s (30.0 % of tracked time): one camera 4.0 s (20.0 %); "
        "occluded limbs 2.0 s (10.0 %)" in terminal
    )
    assert "not scored: 4.0 s (20.0 % of tracked time): not seen 3.0 s (15.0 %); one camera 1.0 s (5.0 %)" in terminal
    assert (
        f"RULA action level 3-4: {'%.1f s' % rula_high} = {tracked_pct} of tracked time, {scored_pct} of scored "
        "time (16 s scored; not scored 4.0 s = 20.0 % of tracked time, causes above)" in terminal
    )


def test_results_without_confidence_still_render(tmp_path: Path):
    """Results stored before the split existed (no confidence, no inputs) render with a note."""
    session, workers = synthetic_session(n_workers=1, duration_s=20.0, fps=FPS, gaps=False, csv=False)
    rec, diag, frames = workers[0]
    rec = dataclasses.replace(rec, confidence=(), inputs=())
    render_report(tmp_path, session_results(session, [(rec, diag, frames)]))
    page = (tmp_path / "worker-W1.html").read_text(encoding="utf-8")
    assert "Not recorded with these results." in page and "data-input=" not in page


def test_wrist_flexion_from_the_settings_is_counted_once_and_shown_alike(tmp_path: Path):
    """The first 80 frames take the left wrist flexion from the settings (-20 degrees); the share is
    of the scored time (160 frames), counting only the scored frames among the 80."""
    frames, inferred = _frames()
    first = np.arange(len(frames)) < 80
    frames["left_wrist_flexion"] = np.where(first, np.radians(-20.0), np.radians(10.0))
    frames["inputs_from_settings"] = pd.array(np.where(first, "left_wrist_flexion", ""), dtype="string")
    scored = (frames["confidence"] != "unscored").to_numpy()
    used = int((first & scored).sum())
    assert 0 < used < 80 and scored.sum() == 160
    summary = aggregate_shift(frames, "W1", frame_period_s=1.0 / FPS, chunk_frames=37, inferred=inferred)
    (u,) = summary.from_settings
    assert (u.input, u.frames) == ("left_wrist_flexion", used) and math.degrees(u.value_rad) == pytest.approx(-20.0)
    assert u.time_s == pytest.approx(used / FPS) and u.percent == pytest.approx(100.0 * used / 160)
    assert aggregate_shift(frames, "W1", frame_period_s=1.0 / FPS).from_settings == summary.from_settings

    long = worker_summary_table(summary)
    row = long[(long["section"] == "inputs") & (long["item"] == "left_wrist_flexion")]
    assert row["value"].tolist() == ["from settings: -20 deg"]
    assert row["percent"].tolist() == [round(100.0 * used / 160, 2)] and row["count"].tolist() == [used]
    table = session_summary_table([summary])
    assert table.loc[0, "left_wrist_flexion_from_settings_pct_of_scored"] == round(100.0 * used / 160, 2)
    assert table.loc[0, "right_wrist_flexion_from_settings_pct_of_scored"] == 0.0

    session, workers = synthetic_session(n_workers=1, duration_s=20.0, fps=FPS, gaps=False, csv=False)
    _, diag, timeline = workers[0]
    record = adapters.worker_summary(summary)
    wrist = next(i for i in record.inputs if i.body_part == "left wrist")
    assert [(v.input, v.seconds, v.scored_s) for v in wrist.from_settings] == [
        ("left_wrist_flexion", pytest.approx(used / FPS), pytest.approx(16.0))
    ]
    assert all(not i.from_settings for i in record.inputs if i.body_part != "left wrist")
    save_results(tmp_path, session, [(record, diag, timeline)])
    render_report(tmp_path, session_results(session, [(record, diag, timeline)]))
    page = (tmp_path / "worker-W1.html").read_text(encoding="utf-8")
    cells = re.search(r'<tr data-input="left wrist">(.*?)</tr>', page).group(1)
    assert f"flexion -20° in {100.0 * used / 160:.1f} % of the scored time" in cells
    assert "wrist_flexion_deg" in cells
    neck = re.search(r'<tr data-input="neck">(.*?)</tr>', page).group(1)
    assert neck.endswith("<td>none</td>")


def test_joint_limits_are_counted_once_and_shown_alike(tmp_path: Path):
    """Ten of the 40 'low, one camera' frames relabelled 'low, joint limit' (1 s, 5 %); a knee held
    at its limit in 30 of the 200 frames (legs 15 %: 'often held at a joint limit', from 10 %),
    the left elbow in 4 (left lower arm 2 %), a hip in 50 (no limit concerns the trunk: no share).
    The aggregation (in chunks of 37 and in one piece), both summary CSVs, the report and the
    terminal show the same figures."""
    frames, inferred = _frames()
    cause = frames["cause"].to_numpy(dtype=object).copy()
    low = (frames["confidence"] == "low").to_numpy()
    cause[np.flatnonzero(low & (cause == "one camera"))[:10]] = "joint limit"  # of the 40 low, one camera
    assert ((frames["confidence"] == "low").to_numpy() & (cause == "joint limit")).sum() == 10
    frames["cause"] = pd.array(cause, dtype="string")
    rng = np.random.default_rng(5)
    limited = np.zeros((len(frames), NUM_JOINTS), dtype=bool)
    limited[rng.permutation(200)[:30], JOINT_INDEX["right_knee"]] = True
    limited[rng.permutation(200)[:4], JOINT_INDEX["left_elbow"]] = True
    limited[rng.permutation(200)[:50], JOINT_INDEX["left_hip"]] = True
    summary = aggregate_shift(
        frames, "W1", frame_period_s=1.0 / FPS, chunk_frames=37, inferred=inferred, limited=limited
    )
    whole = aggregate_shift(frames, "W1", frame_period_s=1.0 / FPS, inferred=inferred, limited=limited)
    assert summary.inputs == whole.inputs and summary.confidence == whole.confidence
    inputs = {i.body_part: i for i in summary.inputs}
    assert (inputs["legs"].limited_frames, inputs["legs"].limited_percent) == (30, pytest.approx(15.0))
    assert (inputs["left lower arm"].limited_frames, inputs["left lower arm"].limited_percent) == (
        4,
        pytest.approx(2.0),
    )
    assert inputs["neck"].limited_percent == 0.0 and inputs["right lower arm"].limited_percent == 0.0
    for part in ("trunk", "left upper arm", "right upper arm", "left wrist", "right wrist"):
        assert math.isnan(inputs[part].limited_percent) and inputs[part].limited_frames == 0, part
    # without limit flags no share is claimed
    assert all(math.isnan(i.limited_percent) for i in aggregate_shift(frames, "W1", frame_period_s=0.1).inputs)

    low = {ca.cause: ca for ca in summary.confidence_of("low").causes}
    assert (low["joint limit"].time_s, low["joint limit"].percent) == pytest.approx((1.0, 5.0))
    assert (low["one camera"].time_s, low["one camera"].percent) == pytest.approx((3.0, 15.0))

    long = worker_summary_table(summary)
    rows = long[(long["section"] == "inputs") & (long["value"] == "joint limit")].set_index("item")
    assert sorted(rows.index) == sorted(["neck", "left lower arm", "right lower arm", "legs"])
    assert (rows.loc["legs", "count"], rows.loc["legs", "percent"]) == (30, pytest.approx(15.0))
    conf = long[(long["section"] == "confidence") & (long["value"] == "joint limit")].iloc[0]
    assert (conf["item"], conf["time_s"], conf["percent"]) == ("low", pytest.approx(1.0), pytest.approx(5.0))
    row = session_summary_table([summary]).iloc[0]
    assert row["legs_joint_limit_pct_of_tracked"] == pytest.approx(15.0)
    assert row["left_lower_arm_joint_limit_pct_of_tracked"] == pytest.approx(2.0)
    assert row["low_confidence_joint_limit_s"] == pytest.approx(1.0) and row["unscored_joint_limit_s"] == 0.0
    assert "trunk_joint_limit_pct_of_tracked" not in row.index

    session, workers = synthetic_session(n_workers=1, duration_s=20.0, fps=FPS, gaps=False, csv=False)
    _, diag, table = workers[0]
    record = adapters.worker_summary(summary)
    save_results(tmp_path, session, [(record, diag, table)])
    render_report(tmp_path, session_results(session, [(record, diag, table)]))
    page = (tmp_path / "worker-W1.html").read_text(encoding="utf-8")
    legs = _text(re.search(r'<tr data-input="legs">(.*?)</tr>', page).group(1))
    assert "15.0 %" in legs and "often held at a joint limit" in legs
    arm = _text(re.search(r'<tr data-input="left lower arm">(.*?)</tr>', page).group(1))
    assert " 2.0 % " in arm and "joint limit" not in arm
    trunk = _text(re.search(r'<tr data-input="trunk">(.*?)</tr>', page).group(1))
    assert " - " in trunk and "joint limit" not in trunk
    row = re.search(r'<tr data-confidence="low">(.*?)</tr>', page).group(1)
    assert "joint limit 1.0 s (5.0 %)" in row and "one camera 3.0 s (15.0 %)" in row
    terminal = "\n".join(worker_lines(WorkerOutput(worker_id="W1", name="W1", summary=summary, csv_files=())))
    assert "one camera 3.0 s (15.0 %); occluded limbs 2.0 s (10.0 %); joint limit 1.0 s (5.0 %)" in terminal
    # stored and loaded again: the same page
    loaded = {i.body_part: i for i in load_results(tmp_path).workers[0].summary.inputs}
    assert loaded["legs"].limited_s == pytest.approx(3.0) and loaded["left lower arm"].limited_s == pytest.approx(0.4)
    assert math.isnan(loaded["trunk"].limited_s)
