"""CSV export: columns, units (degrees at the edge), atomic writes, documented columns."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ergopose.ergonomics.aggregate import aggregate_shift
from ergopose.ergonomics.export import (
    WORKER_SUMMARY_COLUMNS,
    session_summary_table,
    write_scores_csv,
    write_session_summary_csv,
    write_worker_frames_csv,
    write_worker_steps_csv,
    write_worker_summary_csv,
)
from ergopose.ergonomics.scoring import reba_columns, rula_columns, score_posture

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "csv-columns.md"


def _frames(seconds: float = 130.0) -> pd.DataFrame:
    t = np.arange(int(seconds * 12)) / 12.0
    deg = {
        "trunk_flexion": 25 + 10 * np.sin(t / 5),
        "neck_flexion": 15.0 + 0 * t,
        "upper_arm_flexion": 50 + 30 * np.sin(t),
        "elbow_flexion": 90.0 + 0 * t,
        "wrist_flexion": 10.0 + 0 * t,
        "knee_flexion": 5.0 + 0 * t,
        "trunk_twist": 12.0 + 0 * t,
    }
    frame = pd.DataFrame({k: np.deg2rad(v) for k, v in deg.items()})
    frame["time_s"] = t
    frame["load_kg"] = 3.0
    frame["coupling"] = "fair"
    frame.loc[5, "trunk_flexion"] = np.nan
    scores = score_posture(frame, with_events=True)
    return pd.concat([frame, scores], axis=1).assign(worker="w7")


def test_worker_steps_csv_in_degrees_with_every_score(tmp_path):
    frames = _frames()
    path = write_worker_steps_csv(tmp_path / "w7.csv", frames)
    back = pd.read_csv(path)
    assert list(back.columns[:2]) == ["worker", "time_s"]
    assert "left_upper_arm_flexion" in back.columns and "right_upper_arm_flexion" in back.columns
    np.testing.assert_allclose(back["trunk_flexion"].dropna(), np.rad2deg(frames["trunk_flexion"].dropna()), atol=0.005)
    for c in rula_columns() + reba_columns():
        assert c in back.columns, c
    assert pd.isna(back.loc[5, "rula_grand"]) and pd.isna(back.loc[5, "trunk_flexion"])
    assert back["rula_grand"].dropna().eq(back["rula_grand"].dropna().round()).all()
    assert any(c.startswith("rep_") for c in back.columns)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w7.csv"]  # no temporary file left


def test_scores_csv_has_only_identity_time_and_scores(tmp_path):
    frames = _frames(20)
    back = pd.read_csv(write_scores_csv(tmp_path / "s.csv", frames))
    assert "trunk_flexion" not in back.columns and back.columns[0] == "worker"


def test_a_failed_write_keeps_the_previous_file(tmp_path, monkeypatch):
    path = tmp_path / "w7.csv"
    path.write_text("previous\n")

    def boom(self, target, *a, **k):
        target.write("half") if hasattr(target, "write") else Path(target).write_text("half")
        raise OSError("disk full")

    monkeypatch.setattr(pd.DataFrame, "to_csv", boom)
    with pytest.raises(OSError):
        write_worker_frames_csv(path, _frames(5))
    assert path.read_text() == "previous\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w7.csv"]


def test_worker_and_session_summaries(tmp_path):
    frames = _frames()
    summary = aggregate_shift(frames, "w7")
    long = pd.read_csv(write_worker_summary_csv(tmp_path / "w7_summary.csv", summary))
    assert list(long.columns) == list(WORKER_SUMMARY_COLUMNS)
    assert set(long["section"]) == {"distribution", "hourly", "episode", "repetitions", "exposure"}
    dist = long[(long.section == "distribution") & (long.item == "rula_action_level")]
    assert dist["percent"].sum() == pytest.approx(100.0, abs=0.05)
    session = pd.read_csv(write_session_summary_csv(tmp_path / "session.csv", {"w7": summary, "w8": summary}))
    assert session["worker"].tolist() == ["w7", "w7"]
    level_pct = [c for c in session.columns if c.startswith("rula_level") and c.endswith("_pct_of_tracked")]
    assert session.loc[0, level_pct].sum() + session.loc[0, "rula_unscored_pct_of_tracked"] == pytest.approx(
        100.0, abs=0.05
    )
    of_scored = [c for c in session.columns if c.startswith("rula_level") and c.endswith("_pct_of_scored")]
    assert session.loc[0, of_scored].sum() == pytest.approx(100.0, abs=0.05)
    assert session.loc[0, "tracked_s"] == pytest.approx(130.0)
    assert session.loc[0, "rula_scored_s"] + session.loc[0, "rula_unscored_s"] == pytest.approx(130.0, abs=0.002)
    assert session.loc[0, "en_1005_4_trunk_side_bend_or_twist"] in ("conditionally acceptable", "not acceptable")


def _documented_names() -> list[re.Pattern]:
    text = DOC.read_text(encoding="utf-8")
    names = re.findall(r"`([a-z0-9_<>{}]+)`", text)
    pats = []
    for n in names:
        rx = re.escape(n)
        for ph in ("<side>", "<N>", "<angle>", "<standard>", "<part>", "<method>"):
            rx = rx.replace(re.escape(ph), r"[a-z0-9_]+")
        pats.append(re.compile(rf"^{rx}$"))
    return pats


def test_every_exported_column_is_documented():
    pats = _documented_names()
    frames = _frames()
    summary = aggregate_shift(frames, "w7")
    columns = list(frames.columns) + list(WORKER_SUMMARY_COLUMNS) + list(session_summary_table([summary]).columns)
    undocumented = sorted({c for c in columns if not any(p.match(c) for p in pats)})
    assert not undocumented, f"add to docs/csv-columns.md: {undocumented}"
