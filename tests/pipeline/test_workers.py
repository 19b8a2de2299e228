"""Naming tracked people after a run: ``ergopose workers``, names.toml, task inputs that reach nobody.

The results are made without the pose network: the tiny simulated session (tests/conftest.py)
with a tracks table written from its ground truth, in which the second simulated worker is split
in two tracked ids (worker_2 for the first half, worker_3 for the second), then scored by the
same stage ``ergopose assess`` runs after tracking.
"""

from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomli_w

from ergopose import cli
from ergopose.pipeline import names, publish, rescore
from ergopose.pipeline.store import ResultStore
from ergopose.recon.pipeline import TrackFrames
from ergopose.recon.table import write_tracks
from ergopose.session import load_session
from ergopose.sim.ground_truth import load_ground_truth

#: REBA's load/force score (step 8) without shock: < 5 kg -> 0, 5 to 10 kg -> 1, > 10 kg -> 2.
W1_LOAD_KG, W1_REBA_LOAD = 12.0, 2
W2_LOAD_KG, W2_REBA_LOAD = 7.0, 1
STATURES = {"worker_1": 1.70, "worker_2": 1.80, "worker_3": 1.80}


def _settings(session: Path, **extra) -> None:
    path = session / "settings.toml"
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    data["defaults"] = {"load_kg": 0.0}
    data["workers"] = {"w1": {"name": "Anna", "load_kg": W1_LOAD_KG}, "w2": {"load_kg": W2_LOAD_KG}}
    data.update(extra)
    path.write_text(tomli_w.dumps(data), encoding="utf-8")


def _tracks(session: Path, out: Path) -> int:
    """A tracks table of the ground truth, the second worker split at half time; returns frames."""
    gt = load_ground_truth(session / "ground_truth")
    n_frames, n_workers = gt.joints_world.shape[:2]
    frame = np.repeat(np.arange(n_frames), n_workers)
    index = np.tile(np.arange(n_workers), n_frames)
    number = np.where(index == 0, 1, np.where(frame < n_frames // 2, 2, 3))
    pts = gt.joints_world[frame, index]
    n, j = pts.shape[:2]
    tf = TrackFrames(
        worker=number.astype(np.int64),
        frame=frame.astype(np.int64),
        time_s=frame / gt.fps,
        points_world=pts,
        raw_points_world=pts.copy(),
        confidence=np.full((n, j), 0.9),
        reprojection_error_px=np.ones((n, j)),
        views=np.full((n, j), 2, np.int8),
        gap_filled=np.zeros((n, j), bool),
        gated=np.zeros((n, j), bool),
        smoothed=True,
        lens_angle_deg=np.full((n, j), 30.0),
        inferred=np.zeros((n, j), bool),
        std_world=np.full((n, j, 3), 0.01),
    )
    write_tracks(
        ResultStore(out).tracks_path,
        tf,
        fps=gt.fps,
        cameras=gt.camera_names,
        workers={k: {"stature_estimate_m": v} for k, v in STATURES.items()},
    )
    return int(n_frames)


@pytest.fixture(scope="module")
def assessed(tiny_session, tmp_path_factory):
    """(session, results folder, frames, warnings of the scoring stage) of the first run."""
    base = tmp_path_factory.mktemp("workers")
    session = base / "day1"
    shutil.copytree(tiny_session, session)
    _settings(session)
    out = base / "out"
    frames = _tracks(session, out)
    events = []
    rescore.rescore(load_session(session, check_videos=False), out, progress=events.append)
    return session, out, frames, [e.message for e in events if e.unit == "note"]


@pytest.fixture
def copy(assessed, tmp_path):
    session, out, frames, _ = assessed
    shutil.copytree(session, tmp_path / "day1")
    shutil.copytree(out, tmp_path / "out")
    return tmp_path / "day1", tmp_path / "out", frames


def _frames(out: Path, worker: str) -> pd.DataFrame:
    return pd.read_csv(out / "csv" / f"{worker}_steps.csv", comment="#")


def _csv_bytes(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "csv").iterdir())}


@pytest.mark.slow
def test_task_inputs_for_ids_nobody_has_are_named_in_a_warning_and_the_report(assessed):
    session, out, _, notes = assessed
    warnings = [n for n in notes if "applied to nobody" in n]
    assert len(warnings) == 1
    assert "[workers.w1], [workers.w2]" in warnings[0] and "ergopose workers" in warnings[0]
    assert "worker_1, worker_2, worker_3" in warnings[0]
    assert sorted(p.name for p in (out / "csv").glob("*_frames.csv")) == [
        "worker_1_frames.csv",
        "worker_2_frames.csv",
        "worker_3_frames.csv",
    ]
    scored = _frames(out, "worker_1")["reba_load"].dropna()
    assert len(scored) and (scored == 0).all()  # the defaults' 0 kg: w1's 12 kg reached nobody
    text = (out / "results" / "session.json").read_text(encoding="utf-8")
    assert "task inputs applied to nobody" in text and "[workers.w1], [workers.w2]" in text


@pytest.mark.slow
def test_assess_warns_at_the_start_before_the_video_work(copy, monkeypatch):
    from ergopose.pipeline import assess as assess_module

    session, out, _ = copy

    class Stop(Exception):
        pass

    def no_models(*args, **kwargs):
        raise Stop

    monkeypatch.setattr(assess_module, "ensure_models", no_models)
    events = []
    with pytest.raises(Stop):
        assess_module.assess(session, assess_module.AssessOptions(out_dir=out, force=True), progress=events.append)
    notes = [e.message for e in events if e.unit == "note"]
    assert len(notes) == 1 and "[workers.w1], [workers.w2]" in notes[0]
    # named in names.toml: nothing to warn about
    names.write_names(session, {"worker_1": "w1", "worker_2": "w2"})
    events.clear()
    with pytest.raises(Stop):
        assess_module.assess(session, assess_module.AssessOptions(out_dir=out, force=True), progress=events.append)
    assert not [e for e in events if e.unit == "note"]


@pytest.mark.slow
def test_naming_applies_the_task_inputs_and_the_scores_change(copy, capsys):
    session, out, frames = copy
    before = _frames(out, "worker_1")
    assert (
        cli.main(
            [
                "workers",
                "--session",
                str(session),
                "--results",
                str(out),
                "--quiet",
                "--name",
                "worker_1=Anna",
                "--name",
                "worker_2=w2",
                "--name",
                "worker_3=w2",
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "applied to nobody" not in err and "expected_workers" not in err
    assert names.load_names(session) == {"worker_1": "Anna", "worker_2": "w2", "worker_3": "w2"}
    assert sorted(p.name for p in (out / "csv").glob("*_frames.csv")) == ["w1_frames.csv", "w2_frames.csv"]
    assert sorted(p.name for p in out.glob("worker-*.html")) == ["worker-w1.html", "worker-w2.html"]
    w1 = _frames(out, "w1")
    assert (w1["frame"].to_numpy() == before["frame"].to_numpy()).all()
    scored = w1["reba_load"].notna()
    assert scored.sum() > 0 and (w1.loc[scored, "reba_load"] == W1_REBA_LOAD).all()
    assert (w1.loc[scored, "reba_score_a"] == before.loc[scored, "reba_score_a"] + W1_REBA_LOAD).all()
    assert w1.loc[scored, "reba_score"].mean() > before.loc[scored, "reba_score"].mean()
    # the two tracked ids of the second worker are one worker: every frame once
    w2 = _frames(out, "w2")
    assert w2["frame"].tolist() == list(range(frames))
    assert (w2["reba_load"].dropna() == W2_REBA_LOAD).all()
    session_json = (out / "results" / "session.json").read_text(encoding="utf-8")
    assert "worker_2 and worker_3 (scored as one worker)" in session_json and '"Anna"' in session_json


@pytest.mark.slow
def test_more_people_than_the_area_holds_names_the_likeliest_pair(assessed, copy, capsys):
    """The area holds 2 workers (simulate writes expected_workers = 2); the second worker is tracked
    as worker_2, then worker_3 (never at the same time), worker_1 throughout: the warning, the
    report and the listing name worker_3 with worker_2; once both have one name, nothing is said."""
    _, out, frames, notes = assessed
    excess = [n for n in notes if "expected_workers" in n]
    assert len(excess) == 1
    assert "expected_workers = 2, but 3 people were tracked (worker_1, worker_2, worker_3)" in excess[0]
    half = frames // 2
    assert f"worker_3 with worker_2 (followed at the same time in 0 of the {half} frames" in excess[0]
    assert "--name worker_2=NAME --name worker_3=NAME" in excess[0]
    session_json = (out / "results" / "session.json").read_text(encoding="utf-8")
    assert session_json.count("most likely the same worker as") == 2
    assert "most likely the same worker as worker_3" in session_json
    assert "most likely the same worker as worker_2" in session_json
    index = (out / "index.html").read_text(encoding="utf-8")
    assert "Before reading the figures:</strong> the settings say the area holds 2 workers, but 3 people" in index
    assert "worker_2 and worker_3 (followed at the same time in 0 %" in index

    session, out, _ = copy
    assert cli.main(["workers", "--session", str(session), "--results", str(out)]) == 0
    err = capsys.readouterr().err
    assert err.count("expected_workers = 2, but 3 people") == 1 and "worker_3 with worker_2" in err
    names.write_names(session, {"worker_2": "Ana", "worker_3": "Ana"})
    assert cli.main(["workers", "--session", str(session), "--results", str(out)]) == 0
    assert "expected_workers" not in capsys.readouterr().err
    rescore.rescore(load_session(session, check_videos=False), out)
    assert "Before reading the figures" not in (out / "index.html").read_text(encoding="utf-8")


@pytest.mark.slow
def test_a_plain_name_is_only_a_name(copy):
    session, out, _ = copy
    rescore.rename(session, {"worker_2": "Ana López"}, out)
    assert (out / "csv" / "worker_2_frames.csv").is_file()
    assert "Ana López" in (out / "worker-worker_2.html").read_text(encoding="utf-8")
    assert (_frames(out, "worker_2")["reba_load"].dropna() == 0).all()
    rescore.rename(session, {"worker_2": ""}, out)  # removed again
    assert not names.names_path(session).exists()


@pytest.mark.slow
def test_an_unknown_tracked_id_is_one_clear_line_and_changes_nothing(copy, capsys):
    session, out, _ = copy
    before = _csv_bytes(out)
    assert cli.main(["workers", "--session", str(session), "--results", str(out), "--name", "worker_9=w1"]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and "worker_9" in err[0] and "worker_1, worker_2, worker_3" in err[0]
    assert not names.names_path(session).exists()
    assert _csv_bytes(out) == before
    assert cli.main(["workers", "--session", str(session), "--results", str(out), "--name", "w1"]) == 2


@pytest.mark.slow
def test_the_listing_shows_every_tracked_id(copy, capsys):
    session, out, frames = copy
    names.write_names(session, {"worker_1": "w1"})
    assert cli.main(["workers", "--session", str(session), "--results", str(out), "--quiet"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:2] == ["tracked", "id"]
    rows = {ln.split()[0]: ln for ln in lines[1:]}
    assert sorted(rows) == ["worker_1", "worker_2", "worker_3"]
    assert "w1 (Anna)" in rows["worker_1"] and "1.70 m" in rows["worker_1"]
    start = load_session(session, check_videos=False).recorded_at.strftime("%H:%M:%S")
    assert rows["worker_1"].split()[6] == start  # first seen, clock time


@pytest.mark.slow
def test_a_failure_while_scoring_leaves_outputs_and_names_as_they_were(copy, monkeypatch):
    session, out, _ = copy
    before = _csv_bytes(out)
    pages = sorted(p.name for p in out.glob("*.html"))

    def broken(*args, **kwargs):
        raise RuntimeError("the disk went away")

    monkeypatch.setattr(publish, "write_report", broken)
    with pytest.raises(RuntimeError):
        rescore.rename(session, {"worker_1": "w1"}, out)
    assert _csv_bytes(out) == before
    assert sorted(p.name for p in out.glob("*.html")) == pages
    assert not names.names_path(session).exists()
    assert not [p for p in out.iterdir() if p.name.startswith(".")]


@pytest.mark.slow
def test_by_stature_names_the_matching_person_end_to_end(copy):
    session, out, _ = copy
    path = session / "settings.toml"
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    data["workers"]["w1"]["stature_m"] = STATURES["worker_1"]
    data["identification"] = {"by_stature": True}
    path.write_text(tomli_w.dumps(data), encoding="utf-8")
    assert cli.main(["workers", "--session", str(session), "--results", str(out), "--rescore", "--quiet"]) == 0
    assert sorted(p.name for p in (out / "csv").glob("*_frames.csv")) == [
        "w1_frames.csv",
        "worker_2_frames.csv",
        "worker_3_frames.csv",
    ]
    assert (_frames(out, "w1")["reba_load"].dropna() == W1_REBA_LOAD).all()


def test_rows_of_one_person_in_two_ids_keep_the_better_seen_row_per_frame():
    n, j = 4, 33
    rows = TrackFrames(
        worker=np.array([1, 3, 1, 3]),
        frame=np.array([0, 0, 1, 2]),
        time_s=np.zeros(n),
        points_world=np.arange(n, dtype=float)[:, None, None] * np.ones((n, j, 3)),
        raw_points_world=np.zeros((n, j, 3)),
        confidence=np.zeros((n, j)),
        reprojection_error_px=np.zeros((n, j)),
        views=np.array([1, 2, 2, 2], np.int8)[:, None] * np.ones((n, j), np.int8),
        gap_filled=np.zeros((n, j), bool),
        gated=np.zeros((n, j), bool),
        smoothed=True,
        lens_angle_deg=np.zeros((n, j)),
        inferred=np.zeros((n, j), bool),
        std_world=np.zeros((n, j, 3)),
    )
    merged = names.merge_rows(rows, {1: 1, 3: 1})
    assert merged.worker.tolist() == [1, 1, 1] and merged.frame.tolist() == [0, 1, 2]
    assert merged.points_world[:, 0, 0].tolist() == [1.0, 2.0, 3.0]  # frame 0: worker_3's row, seen by 2 cameras


@pytest.mark.slow
def test_names_of_ids_these_results_do_not_have_are_named_in_a_warning(copy):
    session, out, _ = copy
    names.write_names(session, {"worker_1": "w1", "worker_7": "w2"})
    events = []
    rescore.rescore(load_session(session, check_videos=False), out, progress=events.append)
    notes = [e.message for e in events if e.unit == "note"]
    assert any("worker_7 is not a tracked id" in n for n in notes)
    assert any("[workers.w2]" in n and "applied to nobody" in n for n in notes)
    assert (_frames(out, "w1")["reba_load"].dropna() == W1_REBA_LOAD).all()
