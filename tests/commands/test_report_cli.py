"""``ergopose report --session DIR`` re-renders pages from stored results through ergopose.cli.main."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

from ergopose.cli import main
from ergopose.report.results import save_results

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "report"))
from report_synthetic import synthetic_session  # noqa: E402


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cli") / "shift-01"
    session, workers = synthetic_session(n_workers=2, duration_s=600.0, seed=5)
    save_results(folder, session, workers)
    return folder


@pytest.mark.slow
def test_report_from_a_report_folder(stored, tmp_path, capsys):
    folder = tmp_path / "shift-01"
    shutil.copytree(stored, folder)
    assert main(["report", "--session", str(folder), "--quiet"]) == 0
    out = capsys.readouterr().out
    for name in ("index.html", "worker-W1.html", "worker-W2.html"):
        assert (folder / name).is_file()
        assert name in out and "MB)" in out
    # rendering again replaces the pages (the results are untouched)
    (folder / "worker-W1.html").write_text("stale")
    assert main(["report", "--session", str(folder), "--quiet"]) == 0
    assert (folder / "worker-W1.html").read_text().startswith("<!DOCTYPE html>")


@pytest.mark.slow
def test_report_finds_reports_folder_of_a_session(stored, tmp_path, monkeypatch, capsys):
    """Given the session folder, the report goes to reports/<session name> (assess's default)."""
    session_dir = tmp_path / "sessions" / "shift-01"
    session_dir.mkdir(parents=True)
    shutil.copytree(stored, tmp_path / "reports" / "shift-01")
    monkeypatch.chdir(tmp_path)
    assert main(["report", "--session", str(session_dir), "--quiet"]) == 0
    assert (tmp_path / "reports" / "shift-01" / "index.html").is_file()
    # and --out names the report folder explicitly
    out = tmp_path / "elsewhere"
    shutil.copytree(stored, out)
    assert main(["report", "--session", str(session_dir), "--out", str(out), "--quiet"]) == 0
    assert (out / "worker-W2.html").is_file()


def test_missing_results_is_one_clear_message(tmp_path, monkeypatch, capsys):
    session_dir = tmp_path / "shift-02"
    session_dir.mkdir()
    monkeypatch.chdir(tmp_path)
    assert main(["report", "--session", str(session_dir)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert err.startswith("ergopose: error:") and "no stored results" in err and "ergopose assess" in err
    assert "Traceback" not in err


def test_corrupt_results_name_the_file(stored, tmp_path, capsys):
    folder = tmp_path / "shift-01"
    shutil.copytree(stored, folder)
    (folder / "results" / "workers" / "W2" / "summary.json").write_text("{")
    assert main(["report", "--session", str(folder), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "summary.json" in err and "cannot read" in err
    assert not (folder / "index.html").exists()  # nothing half-written


def test_progress_goes_to_stderr(stored, tmp_path, capsys):
    folder = tmp_path / "shift-01"
    shutil.copytree(stored, folder)
    assert main(["report", "--session", str(folder)]) == 0
    captured = capsys.readouterr()
    assert "report" in captured.err and "index.html" in captured.out
