"""Stored results: round trip, atomic writing, one clear error per problem."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from ergopose.errors import InputError
from ergopose.report import results as R
from ergopose.report.context import LevelTime, SessionInfo, StandardFlag, WorkerDiagnostics, WorkerInfo, WorkerSummary
from ergopose.report._codec import from_jsonable, to_jsonable
from ergopose.report.render import render_pages

from report_synthetic import synthetic_session


@pytest.fixture(scope="module")
def small():
    return synthetic_session(n_workers=2, duration_s=900.0, seed=3)


def test_round_trip(tmp_path, small):
    session, workers = small
    R.save_results(tmp_path, session, workers)
    loaded = R.load_results(tmp_path)
    assert loaded.session == session
    for (summary, diag, frames), res in zip(workers, loaded.workers):
        assert res.summary == summary or _same_with_nan(res.summary, summary)
        assert _same_with_nan(res.diagnostics, diag)
        pd.testing.assert_frame_equal(res.frames, frames[list(R.FRAME_COLUMNS)], check_dtype=True)
    # the folder itself may be given as well as its parent
    assert R.load_results(tmp_path / "results").session == session


def _same_with_nan(a, b) -> bool:
    """Dataclass trees equal, NaN equal to NaN."""
    ja, jb = to_jsonable(a), to_jsonable(b)
    return json.dumps(ja, sort_keys=True) == json.dumps(jb, sort_keys=True)


def test_nan_round_trips_as_null():
    d = WorkerDiagnostics("W1", 10, 5, "rule", {"edge": 10}, (), ())
    data = to_jsonable(d)
    assert data["error_3d_m"] is None
    back = from_jsonable(WorkerDiagnostics, data, source="x")
    assert math.isnan(back.error_3d_m)


def test_saving_again_replaces_only_when_complete(tmp_path, small, monkeypatch):
    session, workers = small
    R.save_results(tmp_path, session, workers)
    before = (tmp_path / "results" / "session.json").read_text()

    def broken(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(pd.DataFrame, "to_parquet", broken)
    other = SessionInfo(**{**session.__dict__, "title": "changed"})
    with pytest.raises(OSError):
        R.save_results(tmp_path, other, workers)
    assert (tmp_path / "results" / "session.json").read_text() == before
    assert [p.name for p in tmp_path.iterdir()] == ["results"]  # no temporary folder left


def test_missing_results_name_the_folder(tmp_path):
    with pytest.raises(InputError, match="no stored results.*ergopose assess"):
        R.load_results(tmp_path)


def test_missing_worker_file_names_it(tmp_path, small):
    session, workers = small
    R.save_results(tmp_path, session, workers)
    (tmp_path / "results" / "workers" / "W2" / "diagnostics.json").unlink()
    with pytest.raises(InputError, match=r"W2[/\\]diagnostics.json: missing"):
        R.load_results(tmp_path)


def test_bad_field_names_file_and_field(tmp_path, small):
    session, workers = small
    R.save_results(tmp_path, session, workers)
    path = tmp_path / "results" / "workers" / "W1" / "summary.json"
    raw = json.loads(path.read_text())
    raw["data"]["levels"][2]["seconds"] = "a lot"
    path.write_text(json.dumps(raw))
    with pytest.raises(InputError, match=r"summary.json: levels\[2\].seconds: expected a number"):
        R.load_results(tmp_path)


def test_wrong_format_and_unknown_fields(tmp_path, small):
    session, workers = small
    R.save_results(tmp_path, session, workers)
    path = tmp_path / "results" / "session.json"
    raw = json.loads(path.read_text())
    raw["data"]["surprise"] = 1
    path.write_text(json.dumps(raw))
    with pytest.raises(InputError, match="unknown field.*surprise"):
        R.load_results(tmp_path)
    raw["format"] = "something-else/9"
    path.write_text(json.dumps(raw))
    with pytest.raises(InputError, match="format"):
        R.load_results(tmp_path)
    path.write_text("{ not json")
    with pytest.raises(InputError, match="session.json: cannot read"):
        R.load_results(tmp_path)


def test_corrupt_parquet_is_one_error(tmp_path, small):
    session, workers = small
    R.save_results(tmp_path, session, workers)
    (tmp_path / "results" / "workers" / "W1" / "frames.parquet").write_bytes(b"PAR1 truncated")
    with pytest.raises(InputError, match="frames.parquet: cannot read the per-frame table"):
        R.load_results(tmp_path)


def test_records_refuse_bad_values():
    with pytest.raises(ValueError, match="worker id"):
        WorkerInfo(worker_id="../etc")
    with pytest.raises(ValueError, match="verdict"):
        StandardFlag("ISO 11226", "trunk", "c", "bad", 1.0, 1.0, "")
    with pytest.raises(ValueError):
        R.frames_table(
            np.array([0.0, 0.0]),
            rula_grand=[1, 2],
            rula_action_level=[1, 1],
            reba_score=[1, 2],
            reba_risk_level=[0, 1],
            floor_x_m=[0, 0],
            floor_y_m=[0, 0],
            reliable=[True, True],
        )


def test_frames_table_keeps_missing_scores():
    f = R.frames_table(
        np.array([0.0, 0.1]),
        rula_grand=np.array([3.0, np.nan]),
        rula_action_level=np.array([2.0, np.nan]),
        reba_score=np.array([5.0, 6.0]),
        reba_risk_level=np.array([2.0, 2.0]),
        floor_x_m=np.zeros(2),
        floor_y_m=np.zeros(2),
        reliable=np.array([True, False]),
    )
    assert str(f["rula_grand"].dtype) == "Int16"
    assert f["rula_grand"].isna().tolist() == [False, True]


def test_summary_for_another_worker_is_refused(tmp_path, small):
    session, workers = small
    wrong = [(WorkerSummary("W9", 1.0, (LevelTime("rula", 1, 1.0),), {}), d, f) for _, d, f in workers]
    with pytest.raises(InputError, match="worker 'W9'"):
        R.save_results(tmp_path, session, wrong)


@pytest.mark.slow
def test_results_in_memory_are_the_stored_results(tmp_path, small):
    """ergopose assess renders from session_results(...) instead of reading the folder back: the
    records, tables and every page must be what load_results gives."""
    session, workers = small
    R.save_results(tmp_path, session, workers)
    stored = R.load_results(tmp_path)
    memory = R.session_results(session, workers)
    assert memory.session == stored.session
    for a, b in zip(memory.workers, stored.workers):
        assert (
            a.info == b.info and _same_with_nan(a.summary, b.summary) and _same_with_nan(a.diagnostics, b.diagnostics)
        )
        pd.testing.assert_frame_equal(a.frames, b.frames, check_dtype=True)
    assert render_pages(memory, tmp_path) == render_pages(stored, tmp_path)
    with pytest.raises(ValueError, match="1 worker results for 2 workers"):
        R.session_results(session, workers[:1])
