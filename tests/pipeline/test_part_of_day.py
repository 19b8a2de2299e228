"""Part of a day (issue 15, item 5): ``--start/--end`` of ``ergopose assess`` and ``ergopose report``.

The times: clock time of the session's day and time zone, or seconds from its start; bad values
give one line and exit 2. ``report --start/--end`` scores the stored tracks again for the window
(the results of tests/pipeline/test_csv_tables.py's kind: a tracks table from the simulated
session's ground truth, no pose network). ``assess --start/--end`` with the real pose network is
in tests/pipeline/test_assess.py (slow).
"""

from __future__ import annotations

import datetime as dt
import shutil

import numpy as np
import pandas as pd
import pytest

from ergopose import cli
from ergopose.errors import ConfigError
from ergopose.pipeline import rescore
from ergopose.pipeline.window import Window, folder_name, parse_time, resolve
from ergopose.session import load_session
from tests.pipeline.helpers import PROGRESS_LINE, ground_truth_tracks

START = dt.datetime(2024, 3, 4, 22, 0, 0, tzinfo=dt.timezone(dt.timedelta(hours=1)))


@pytest.mark.parametrize(
    "text, seconds",
    [
        ("22:00", 0.0),
        ("22:15", 900.0),
        ("22:15:30", 930.0),
        ("22:15:30.5", 930.5),
        ("90", 90.0),
        ("90.5", 90.5),
        ("90s", 90.0),
        ("0", 0.0),
        ("01:30", 3.5 * 3600),  # past midnight: the next day, within the shift
    ],
)
def test_times_are_clock_times_of_the_sessions_day_or_seconds(text, seconds):
    assert parse_time(text, START, 8 * 3600.0, "--start") == pytest.approx(seconds)


@pytest.mark.parametrize(
    "start, end, field, words",
    [
        ("22:30", "22:10", "--end", "is not after --start 22:30"),
        ("22:30", "22:30", "--end", "is not after"),
        ("21:00", None, "--start", "outside the session"),
        (None, "07:00", "--end", "outside the session"),  # the next morning, after the 8 h shift
        ("99999", None, "--start", "outside the session"),
        ("half past ten", None, "--start", "is not a time"),
        ("25:00", None, "--start", "not a clock time"),
    ],
)
def test_bad_windows_name_the_option(start, end, field, words):
    with pytest.raises(ConfigError) as exc:
        resolve(start, end, START, 8 * 3600.0)
    assert exc.value.field == field and words in str(exc.value)


def test_a_window_holds_the_frames_from_its_start_up_to_its_end():
    w = resolve("22:00:01", "3", START, 8 * 3600.0)
    assert w == Window(1.0, 3.0)
    assert w.frame_range(12.0) == (12, 36)
    assert w.mask(np.arange(40), 12.0).sum() == 24
    assert resolve(None, None, START, 60.0) is None
    assert resolve("30", None, START, 60.0) == Window(30.0, 60.0)
    assert folder_name(w, START) == "part-220001-220003"


@pytest.fixture(scope="module")
def assessed(tiny_session, tmp_path_factory):
    """(session folder, results folder, frames) of the tiny session scored from its ground truth."""
    base = tmp_path_factory.mktemp("part")
    session = base / "day1"
    shutil.copytree(tiny_session, session)
    out = base / "out"
    frames = ground_truth_tracks(session, out)
    rescore.rescore(load_session(session, check_videos=False), out)
    return session, out, frames


def _clock(session, seconds: float) -> str:
    return (load_session(session, check_videos=False).recorded_at + dt.timedelta(seconds=seconds)).strftime("%H:%M:%S")


@pytest.mark.slow
def test_report_start_end_scores_the_window_again_beside_the_whole_day(assessed, capsys):
    session, out, frames = assessed
    whole = {p: p.read_bytes() for p in (out / "csv").iterdir()}
    code = cli.main(
        [
            "report",
            "--session",
            str(session),
            "--out",
            str(out),
            "--quiet",
            "--start",
            _clock(session, 1.0),
            "--end",
            "2.5",
        ]
    )
    printed = capsys.readouterr().out
    assert code == 0
    recorded = load_session(session, check_videos=False).recorded_at
    part = out / folder_name(Window(1.0, 2.5), recorded)
    assert f"report: {part / 'index.html'}" in printed
    assert {p: p.read_bytes() for p in (out / "csv").iterdir()} == whole  # the whole day's files stay
    table = pd.read_csv(part / "csv" / "worker_1_frames.csv", parse_dates=["time"])
    np.testing.assert_array_equal(table["frame"], np.arange(12, 30))  # 1.0 <= f / 12 < 2.5
    assert table["time"].min() == pd.Timestamp(recorded) + pd.Timedelta(seconds=1)
    summary = pd.read_csv(part / "csv" / "session_summary.csv")
    assert summary["tracked_s"].tolist() == pytest.approx([1.5, 1.5])
    assert summary["start"].iloc[0].startswith((recorded + dt.timedelta(seconds=1)).isoformat()[:19])
    html = (part / "index.html").read_text(encoding="utf-8")
    assert "part of the day" in html.lower()


@pytest.mark.slow
@pytest.mark.parametrize(
    "start, end, words",
    [
        ("2.5", "1", "--end: 1 is not after --start 2.5"),
        ("60", None, "--start: 60 is outside the session"),
        ("soon", None, "--start: 'soon' is not a time"),
    ],
)
def test_bad_report_windows_give_one_line_and_exit_2(assessed, capsys, start, end, words):
    session, out, _ = assessed
    args = ["report", "--session", str(session), "--out", str(out), "--quiet", "--start", start]
    code = cli.main(args + (["--end", end] if end else []))
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip() and not PROGRESS_LINE.match(ln)]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("ergopose: error:") and words in lines[0], err
    assert "Traceback" not in err


@pytest.mark.slow
def test_assess_refuses_a_bad_window_before_any_work(tiny_session, tmp_path, capsys):
    out = tmp_path / "report"
    code = cli.main(["assess", "--session", str(tiny_session), "--out", str(out), "--start", "2", "--end", "1"])
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip() and not PROGRESS_LINE.match(ln)]
    assert code == 2 and lines == [
        "ergopose: error: --end: 1 is not after --start 2: the session runs from 08:00 to 08:00:03 (3 s)"
    ], err
    assert not (out / "pipeline" / "chunks").exists()
