"""The CSV tables of an assessment (issue 15): the tidy frames table per worker, the summary per
worker, their documentation, the Excel option, and one truth for the headline shares.

The results are made without the pose network: the tiny simulated session (tests/conftest.py)
with a tracks table written from its ground truth (tests/pipeline/helpers.ground_truth_tracks),
then scored by the stage ``ergopose assess`` runs after tracking.
"""

from __future__ import annotations

import itertools
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ergopose.commands.assess import worker_lines
from ergopose.ergonomics.export import frame_columns, session_summary_columns
from ergopose.pipeline import rescore
from ergopose.report.results import load_results
from ergopose.report.pages import build_index_page, build_worker_page
from ergopose.session import load_session
from tests.pipeline.helpers import ground_truth_tracks

DOC = Path(__file__).resolve().parents[2] / "docs" / "csv-columns.md"
#: The first worker's first frames without head joints: tracked, not scored.
HEADLESS = 9


@pytest.fixture(scope="module")
def assessed(tiny_session, tmp_path_factory):
    """(session, results folder, frames per worker, outputs of the scoring stage)."""
    base = tmp_path_factory.mktemp("tidy")
    session = base / "day1"
    shutil.copytree(tiny_session, session)
    out = base / "out"
    frames = ground_truth_tracks(session, out, headless_frames=HEADLESS)
    outputs = rescore.rescore(load_session(session, check_videos=False), out)
    return session, out, frames, outputs


# ------------------------------------------------------------------------------ the docs


def _expand(name: str, placeholders: dict[str, tuple[str, ...]]) -> list[str]:
    """`{a,b}_x` -> a_x, b_x (nested and repeated braces), placeholders like <method> likewise."""
    for ph, values in placeholders.items():
        name = name.replace(ph, "{" + ",".join(values) + "}")
    parts = re.split(r"(\{[^{}]*\})", name)
    options = [p[1:-1].split(",") if p.startswith("{") else [p] for p in parts]
    return ["".join(c) for c in itertools.product(*options)]


def documented(section: str, placeholders: dict[str, tuple[str, ...]] | None = None) -> list[str]:
    """The columns a section of docs/csv-columns.md documents: the `names` of the first cell of
    every table row between its heading and the next ## heading, braces expanded."""
    text = DOC.read_text(encoding="utf-8")
    start = text.index(f"\n## {section}\n")
    end = text.find("\n## ", start + 1)
    names: list[str] = []
    for line in text[start : end if end > 0 else None].splitlines():
        if not line.startswith("| `"):
            continue
        first = line.split("|")[1]
        for n in re.findall(r"`([^`]+)`", first):
            names += _expand(n, placeholders or {})
    return names


def test_the_doc_parser_finds_what_a_table_lists():
    assert _expand("<method>_level{1,2}_s", {"<method>": ("rula", "reba")}) == [
        "rula_level1_s",
        "rula_level2_s",
        "reba_level1_s",
        "reba_level2_s",
    ]
    assert "rula_grand_p" in documented("Frames per worker")
    assert "not_a_column" not in documented("Frames per worker")


@pytest.mark.slow
def test_every_frames_column_is_documented_and_every_documented_one_written(assessed):
    _, out, _, _ = assessed
    written = list(pd.read_csv(out / "csv" / "worker_1_frames.csv", nrows=0).columns)
    assert written == list(frame_columns())
    doc = documented("Frames per worker")
    assert len(doc) == len(set(doc)), "a column is documented twice"
    assert sorted(set(written) - set(doc)) == [], "written but not in docs/csv-columns.md"
    assert sorted(set(doc) - set(written)) == [], "documented but not written"


@pytest.mark.slow
def test_every_summary_column_is_documented_and_every_documented_one_written(assessed):
    _, out, _, _ = assessed
    written = list(pd.read_csv(out / "csv" / "session_summary.csv", nrows=0).columns)
    assert written == session_summary_columns()
    doc = documented("Summary per worker", {"<method>": ("rula", "reba")})
    assert len(doc) == len(set(doc)), "a column is documented twice"
    assert sorted(set(written) - set(doc)) == [], "written but not in docs/csv-columns.md"
    assert sorted(set(doc) - set(written)) == [], "documented but not written"


# ------------------------------------------------------------------------- the frames table


@pytest.mark.slow
def test_the_frames_table_has_one_row_per_tracked_frame_with_a_tz_aware_clock(assessed):
    session, out, frames, _ = assessed
    loaded = load_session(session, check_videos=False)
    for worker in ("worker_1", "worker_2"):
        table = pd.read_csv(out / "csv" / f"{worker}_frames.csv", parse_dates=["time"])
        assert len(table) == frames  # the ground truth tracks every worker in every frame
        assert isinstance(table["time"].dtype, pd.DatetimeTZDtype)
        first = pd.Timestamp(loaded.recorded_at)
        assert table["time"].iloc[0] == first
        step = (table["time"] - first).dt.total_seconds().to_numpy()
        np.testing.assert_allclose(step, table["time_s"].to_numpy(), atol=5e-4)
        np.testing.assert_array_equal(table["frame"].to_numpy(), np.arange(frames))
        assert set(table["scored"]) <= {"yes", "no"}
        both = table["rula_grand"].notna() & table["reba_score"].notna()
        assert (table["scored"].eq("yes") == both).all()
        unscored = HEADLESS if worker == "worker_1" else 0
        assert (table["scored"] == "no").sum() == unscored and (table["confidence"] == "unscored").sum() == unscored
        scored = table[table["scored"] == "yes"]
        assert scored["rula_grand_p"].between(0, 1).all() and scored["reba_score_p"].between(0, 1).all()
        assert (scored["rula_grand_low"] <= scored["rula_grand_high"]).all()
        unscored_rows = table[table["scored"] == "no"]
        assert unscored_rows[["rula_grand", "rula_grand_p", "rula_grand_low"]].isna().all().all()
        assert unscored_rows["cause"].notna().all()
        assert (table.loc[table["confidence"] != "confident", "cause"].notna()).all()
        parquet = pd.read_parquet(out / "csv" / f"{worker}_frames.parquet")
        assert list(parquet.columns) == list(table.columns) and len(parquet) == frames
        assert (parquet["time"].dt.tz is not None) and (parquet["time"] == table["time"]).all()


@pytest.mark.slow
def test_the_steps_file_keeps_every_step_for_the_evaluation(assessed):
    _, out, frames, _ = assessed
    steps = pd.read_csv(out / "csv" / "worker_1_steps.csv")
    assert len(steps) == frames and {"reba_load", "left_rula_upper_arm_band", "trunk_flexion"} <= set(steps.columns)
    tidy = pd.read_csv(out / "csv" / "worker_1_frames.csv")
    np.testing.assert_allclose(tidy["trunk_flexion_deg"], steps["trunk_flexion"], atol=1e-9)
    pd.testing.assert_series_equal(tidy["rula_grand"].astype("Float64"), steps["rula_grand"].astype("Float64"))


@pytest.mark.slow
def test_csv_bom_writes_excel_readable_utf8(assessed, tmp_path):
    session, out, _, _ = assessed
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    rescore.rescore(load_session(session, check_videos=False), copy, bom=True)
    for name in ("worker_1_frames.csv", "session_summary.csv", "worker_1_summary.csv", "worker_1_steps.csv"):
        raw = (copy / "csv" / name).read_bytes()
        assert raw.startswith(b"\xef\xbb\xbf") and raw.count(b"\xef\xbb\xbf") == 1, name
        assert raw[3:] == (out / "csv" / name).read_bytes(), name  # the same bytes after the mark
    assert not (out / "csv" / "worker_1_frames.csv").read_bytes().startswith(b"\xef\xbb\xbf")


# ------------------------------------------------------------------------------- one truth


def _printed_shares(line: str) -> tuple[float, float]:
    m = re.search(r"= ([\d.]+) % of tracked time, ([\d.]+|n/a)( %)? of scored time", line)
    assert m, line
    return float(m.group(1)), float(m.group(2)) if m.group(2) != "n/a" else float("nan")


@pytest.mark.slow
def test_the_terminal_the_report_and_the_summary_csv_give_the_same_shares(assessed):
    _, out, _, outputs = assessed
    table = pd.read_csv(out / "csv" / "session_summary.csv").set_index("worker")
    results = load_results(out)
    index = build_index_page(results.workers, results.session)
    for w, res in zip(outputs.workers, results.workers):
        row = table.loc[w.worker_id]
        lines = worker_lines(w)
        page = build_worker_page(res, results.session)
        irow = next(r for r in index.workers if r.page.text == w.name)
        if w.worker_id == "worker_1":  # the shares of tracked and of scored time differ
            assert row["unscored_s"] == pytest.approx(HEADLESS / 12.0, abs=1e-3)
            assert row["rula_high_pct_of_scored"] > row["rula_high_pct_of_tracked"] > 0
        for method, label in (("rula", "RULA action level 3-4"), ("reba", "REBA high/very high")):
            line = next(ln for ln in lines if label in ln)
            of_tracked, of_scored = _printed_shares(line)
            assert abs(row[f"{method}_high_pct_of_tracked"] - of_tracked) <= 0.05 + 1e-9
            assert abs(row[f"{method}_high_pct_of_scored"] - of_scored) <= 0.05 + 1e-9
            head = next(h for h in page.headline if h.method == method.upper())
            assert f"{of_tracked:.1f} % of the tracked time" in head.key_fact
            assert f"{of_scored:.1f} % of the scored time" in head.key_fact
            assert getattr(irow, f"{method}_high") == f"{of_tracked:.1f} %"
            assert f"not scored {_seconds(row[f'{method}_unscored_s'])}" in line or row[f"{method}_unscored_s"] == 0
        tracked = next(ln for ln in lines if "tracked" in ln)
        assert w.worker_id in tracked


def _seconds(s: float) -> str:
    from ergopose.report.wording import fmt_duration

    return fmt_duration(s)
