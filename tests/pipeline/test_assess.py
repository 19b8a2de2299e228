"""ergopose assess end to end on a tiny simulated session with the real pose network:
outputs, resuming after kills with identical CSV files, and one clear message for bad input."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from ergopose import cli
from tests.pipeline.helpers import PROGRESS_LINE
from tests.pipeline.helpers import assess_args as _assess_args
from tests.pipeline.helpers import csv_bytes as _csv_bytes

# End to end (simulated sessions, whole runs): left out by make test-fast.
pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]


def test_assess_writes_the_report_and_csv_files(reference, capsys):
    out, csvs = reference
    assert (out / "index.html").exists()
    assert "session_summary.csv" in csvs
    frames = [name for name in csvs if name.endswith("_frames.csv")]
    assert frames, "no worker was tracked"
    header = csvs[frames[0]].split(b"\n", 1)[0].decode()
    for column in (
        "time",
        "time_s",
        "name",
        "trunk_flexion_deg",
        "trunk_flexion_sd_deg",
        "rula_grand",
        "rula_grand_p",
        "rula_action_level",
        "reba_score",
        "reba_risk_level",
        "scored",
        "cause",
    ):
        assert column in header.split(",")
    steps = csvs[frames[0].replace("_frames.csv", "_steps.csv")].split(b"\n", 1)[0].decode().split(",")
    assert "trunk_flexion" in steps and "left_rula_upper_arm_band" in steps
    html = (out / "index.html").read_text()
    assert "worker_1" in html and "<script" not in html
    assert (out / "pipeline" / "tracks.parquet").exists()


def test_killed_runs_resume_to_identical_csv_files(reference, tiny_session, fetched_model_dir, tmp_path):
    """Kill the assessment at five random moments, then let it finish: the CSVs equal an uninterrupted run's."""
    _, expected = reference
    out = tmp_path / "report"
    args = [sys.executable, "-m", "ergopose", *_assess_args(tiny_session, out, fetched_model_dir[0])]
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    rng = np.random.default_rng(5)
    for _ in range(5):
        proc = subprocess.Popen(
            args, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
        )
        time.sleep(float(rng.uniform(1.0, 6.0)))
        os.killpg(proc.pid, signal.SIGKILL)  # the process and its worker processes: a power cut
        proc.wait()
    done = subprocess.run(args, cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert _csv_bytes(out) == expected
    leftovers = [p for p in out.rglob("*") if ".tmp" in p.name]
    assert not leftovers, f"temporary files left behind: {leftovers}"


def _kill_when(args, env, out: Path, appeared, timeout_s: float = 120.0) -> bool:
    """Start the assessment, kill its whole process group the moment ``appeared(out)`` is true;
    False when the run ended first."""
    proc = subprocess.Popen(
        args, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
    )
    t_end = time.monotonic() + timeout_s
    try:
        while proc.poll() is None and time.monotonic() < t_end:
            if _seen(appeared, out):
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
                return True
            time.sleep(0.002)
        return False
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def _seen(appeared, out: Path) -> bool:
    """``appeared(out)``, False when a folder it lists is moved away while it looks inside (the run
    published that stage between the listing and the look: the moment passed)."""
    try:
        return bool(appeared(out))
    except FileNotFoundError:
        return False


def _temp_in(folder: str):
    return lambda out: any(".tmp" in p.name for p in (out / folder).glob(".*")) if (out / folder).is_dir() else False


def _staged(pattern: str):
    """A file or folder matching ``pattern`` inside the folder the scoring stage writes its outputs
    to before they are moved into place (ergopose.pipeline.assess.score_and_publish)."""
    return lambda out: any(True for stage in out.glob(".outputs.*.tmp") for _ in stage.glob(pattern))


@pytest.mark.slow
def test_runs_killed_in_every_stage_resume_to_identical_csv_files(reference, tiny_session, fetched_model_dir, tmp_path):
    """Kill at a seeded chunk of the 2D stage, then while the tracks table, a scored-frames file,
    a CSV file and the stored results are being written (the moment a temporary file of each
    appears): each following run resumes, and the last one writes the CSVs of an uninterrupted run."""
    _, expected = reference
    out = tmp_path / "report"
    args = [sys.executable, "-m", "ergopose", *_assess_args(tiny_session, out, fetched_model_dir[0])]
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    k = int(np.random.default_rng(16).integers(1, 5))  # of the 6 chunks
    moments = {
        f"{k} chunks stored": lambda o: len(list((o / "pipeline" / "chunks").glob("chunk_*.npz"))) >= k,
        "tracks table": _temp_in("pipeline"),
        "scored frames": _staged("pipeline/scored/.*.tmp*"),
        "CSV files": _staged("csv/.*.tmp*"),
        "stored results": _staged(".results.*"),
    }
    killed = [name for name, appeared in moments.items() if _kill_when(args, env, out, appeared)]
    assert len(killed) >= 3, f"killed only at {killed}"  # the late moments are short: most must be hit
    done = subprocess.run(args, cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert _csv_bytes(out) == expected
    assert not [p for p in out.rglob("*") if ".tmp" in p.name]


def _copy_session(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


def _corrupt(session: Path) -> str:
    (session / "cam_2.mp4").write_bytes(b"\x00not a video" * 1000)
    return "cam_2.mp4"


def _truncate(session: Path) -> str:
    data = (session / "cam_1.mp4").read_bytes()
    (session / "cam_1.mp4").write_bytes(data[: len(data) // 3])
    return "cam_1.mp4"


def _fewer_frames(session: Path) -> str:
    src = session / "cam_2.mp4"
    cap = cv2.VideoCapture(str(src))
    frames = []
    while True:
        ok, f = cap.read()
        if not ok:
            break
        frames.append(f)
    cap.release()
    h, w = frames[0].shape[:2]
    tmp = session / "short.mp4"
    writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter_fourcc(*"mp4v"), 12.0, (w, h))
    for f in frames[:-5]:
        writer.write(f)
    writer.release()
    os.replace(tmp, src)
    return "frames"


def _wrong_size(session: Path) -> str:
    text = (session / "calibration.toml").read_text()
    (session / "calibration.toml").write_text(text.replace("width = 1024", "width = 2048", 1))
    return "calibration"


def _unknown_key(session: Path) -> str:
    text = (session / "settings.toml").read_text()
    (session / "settings.toml").write_text(text.replace("fps = ", "colour = 3\nfps = ", 1))
    return "colour"


@pytest.mark.parametrize("damage", [_corrupt, _truncate, _fewer_frames, _wrong_size, _unknown_key])
def test_bad_input_gives_one_clear_message_and_keeps_earlier_outputs(
    damage, reference, tiny_session, fetched_model_dir, tmp_path, capsys
):
    ref_out, expected = reference
    out = tmp_path / "report"
    shutil.copytree(ref_out, out)
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    session = _copy_session(tiny_session, tmp_path / "day1")
    expected_word = damage(session)
    capsys.readouterr()
    code = cli.main(_assess_args(session, out, fetched_model_dir[0]))
    err = capsys.readouterr().err
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip() and not PROGRESS_LINE.match(ln)]
    assert len(lines) == 1 and lines[0].startswith("ergopose: error:"), err
    assert expected_word in lines[0]
    assert "Traceback" not in err
    after = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before


@pytest.mark.browser
def test_assessed_report_in_chromium(reference, tmp_path):
    """The report of a real assessment in headless Chromium (offline): no console message, no
    resource loaded, every figure laid out, the headline shares equal to the stored frames."""
    import pandas as pd

    from tests.report.test_browser import probe

    out, _ = reference
    pages = [out / "index.html", *sorted(out.glob("worker-*.html"))]
    assert len(pages) >= 2
    for page in pages:
        result = probe(page, tmp_path)
        assert result["resources"] == 0
        assert result["svgs"], page.name
        for s in result["svgs"]:
            assert s["width"] > 50 and s["height"] > 30, (page.name, s)
    worker_page = pages[1]
    worker_id = worker_page.stem[len("worker-") :]
    frames = pd.read_parquet(out / "results" / "workers" / worker_id / "frames.parquet")
    result = probe(worker_page, tmp_path)
    for method, col, levels in (("rula", "rula_action_level", range(1, 5)), ("reba", "reba_risk_level", range(0, 5))):
        lv = frames[col].to_numpy(dtype=np.float64, na_value=np.nan)
        for k in levels:
            cell = result["shares"][f"{method}-{k}"]
            assert cell["text"] == f"{100.0 * np.sum(lv == k) / len(lv):.1f} %"
            assert cell["shown"]


def test_assess_a_part_of_the_day(reference, tiny_session, fetched_model_dir, tmp_path):
    """--start/--end: only the chunks around the window go through the video work (stored as a
    whole-day run stores them), and only the window's frames are scored."""
    import pandas as pd

    out = tmp_path / "report"
    assert cli.main(_assess_args(tiny_session, out, fetched_model_dir[0], "--start", "1", "--end", "2")) == 0
    chunks = sorted(p.name for p in (out / "pipeline" / "chunks").glob("chunk_*.npz"))
    assert chunks == ["chunk_000000012.npz", "chunk_000000018.npz"]  # chunks of 6 frames; frames 12-23
    frames = sorted((out / "csv").glob("*_frames.csv"))
    assert frames
    for path in frames:
        table = pd.read_csv(path, parse_dates=["time"])
        assert table["frame"].between(12, 23).all() and table["time_s"].between(1.0, 2.0 - 1e-9).all()
    summary = pd.read_csv(out / "csv" / "session_summary.csv")
    assert (summary["tracked_s"] <= 1.0 + 1e-9).all()


@pytest.mark.browser
def test_assessed_print_version_in_chromium(reference, tmp_path):
    """The print version of a real assessment: one summary page, then at most two A4 pages per
    worker (counted from Chromium's PDF), laid out inside the A4 width with its print rules."""
    from tests.report.test_browser_print import A4_PRINTABLE_PX, layout, pdf_pages

    out, _ = reference
    workers = sorted(p.stem[len("worker-") :] for p in out.glob("worker-*.html"))
    total, per_worker = pdf_pages(out / "print.html", tmp_path)
    assert sorted(per_worker) == workers
    assert total == 1 + sum(per_worker.values()) and all(1 <= n <= 2 for n in per_worker.values()), per_worker
    found = layout(out / "print.html", tmp_path, f"{A4_PRINTABLE_PX},1000", print_rules=True)
    assert found["outside"] == [] and found["overflowing"] == [] and found["scroll_width"] <= found["viewport"] + 1
