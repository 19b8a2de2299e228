"""What an evaluation reads (ergopose/evaluation/loading.py): the results layout, the strict-JSON
helpers, the lens-region definitions, the ids the results report and the refusal of a session
without ground truth; on hand-made values and a session folder of three grey frames."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from evaluation_helpers import video_session

from ergopose.errors import InputError
from ergopose.evaluation.loading import (
    ResultsLayout,
    json_ready,
    lens_region_info,
    load_inputs,
    reported_ids,
    round_or_nan,
)
from ergopose.recon.settings import ReconSettings
from ergopose.session import load_session


def test_layout_of_an_assessment():
    layout = ResultsLayout.of_assess(Path("out"))
    assert layout.root == Path("out")
    assert layout.tracks == Path("out/pipeline/tracks.parquet")
    assert layout.frames_csv("w1") == Path("out/csv/w1_steps.csv")
    prefixed = ResultsLayout(root=Path("o"), tracks=Path("o/t.parquet"), csv_dir=Path("o/csv"), csv_prefix="X_")
    assert prefixed.frames_csv("worker_2") == Path("o/csv/X_worker_2_steps.csv")


def test_json_ready_gives_strict_json():
    value = {
        1: (np.int64(3), np.float32(0.5), np.bool_(True)),
        "a": [math.nan, -math.inf, 2.5],
        "arr": np.array([[1.0, np.nan], [np.inf, 4.0]]),
        "s": "text",
        "n": None,
    }
    out = json_ready(value)
    assert out == {
        "1": [3, 0.5, True],
        "a": [None, None, 2.5],
        "arr": [[1.0, None], [None, 4.0]],
        "s": "text",
        "n": None,
    }
    assert [type(x) for x in out["1"]] == [int, float, bool]  # numpy scalars become Python ones
    json.dumps(out, allow_nan=False)  # would raise on a NaN left in


@pytest.mark.parametrize(
    "x, nd, expected", [(1.23456, 3, 1.235), (np.float32(2.5), 0, 2.0), (np.float64(-0.00049), 3, -0.0), (7, 1, 7.0)]
)
def test_round_or_nan_rounds(x, nd, expected):
    assert round_or_nan(x, nd) == expected


@pytest.mark.parametrize("x", [None, math.nan, math.inf, np.float64(-np.inf)])
def test_round_or_nan_is_nan_for_missing_or_infinite(x):
    assert math.isnan(round_or_nan(x))


def test_lens_regions_agree_by_default():
    info, notes = lens_region_info(ReconSettings())
    assert info["used_limits_deg"] == info["simulator_limits_deg"] == [30.0, 60.0]
    assert info["calibration_check_default_limits_deg"] == [30.0, 60.0]
    assert info["agree"] is True and notes == []


def test_other_lens_regions_are_noted():
    info, notes = lens_region_info(ReconSettings(lens_region_limits_deg=(40.0, 70.0)))
    assert info["used_limits_deg"] == [40.0, 70.0] and info["agree"] is False
    assert len(notes) == 1
    assert "reconstruction settings 40/70 deg" in notes[0] and "LENS_REGIONS_DEG 30/60 deg" in notes[0]


STATURES = {"workers": {"worker_1": {"stature_estimate_m": 1.601}, "worker_2": {"stature_estimate_m": 1.799}}}


def test_reported_ids_follow_the_stature_match(tmp_path):
    session = load_session(video_session(tmp_path / "s"), check_videos=False)
    ids, notes = reported_ids(session, SimpleNamespace(workers=(1, 2, 3)), STATURES)
    # 1.601 m is w2 (1.60), 1.799 m is w1 (1.80); tracker 3 has no stature and keeps its pseudonym
    assert ids == {"worker_1": "w2", "worker_2": "w1", "worker_3": "worker_3"}
    assert notes == ()


def test_reported_ids_follow_names_toml_first(tmp_path):
    folder = video_session(tmp_path / "s")
    (folder / "names.toml").write_text('format_version = 1\n[names]\nworker_3 = "w1"\n', encoding="utf-8")
    session = load_session(folder, check_videos=False)
    ids, _ = reported_ids(session, SimpleNamespace(workers=(1, 2, 3)), STATURES)
    # w1 is taken by the names file: worker_2 (1.799 m) matches nobody else and keeps its pseudonym
    assert ids == {"worker_1": "w2", "worker_2": "worker_2", "worker_3": "w1"}


def test_load_inputs_refuses_a_session_without_ground_truth(tmp_path):
    folder = video_session(tmp_path / "s")
    with pytest.raises(InputError, match="not a simulated session") as err:
        load_inputs(folder, ResultsLayout.of_assess(tmp_path / "out"))
    assert str(folder) in str(err.value)
