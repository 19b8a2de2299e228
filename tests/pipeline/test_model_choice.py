"""``ergopose assess --model NAME``: the landmark card reaches the worker processes with its own
confidence gates, is part of the results' fingerprint, and is named again when stored results
are re-scored (issue 14, item 3)."""

from __future__ import annotations

import dataclasses
import json

import pytest

from ergopose import cli
from ergopose.pipeline import assess as assess_module
from ergopose.pipeline import rescore
from ergopose.pipeline.assess import AssessOptions
from ergopose.pipeline.store import ResultStore
from ergopose.pose.settings import PoseSettings
from ergopose.pose.models import DEFAULT_LANDMARK_MODEL, landmark_card
from ergopose.recon.settings import ReconSettings


def test_assess_takes_a_model_name(capsys):
    parser = cli.build_parser()
    assert parser.parse_args(["assess", "--session", "s"]).model == DEFAULT_LANDMARK_MODEL
    assert parser.parse_args(["assess", "--session", "s", "--model", "heavy"]).model == "heavy"
    with pytest.raises(SystemExit):
        parser.parse_args(["assess", "--session", "s", "--model", "giant"])
    assert "invalid choice: 'giant'" in capsys.readouterr().err


@pytest.mark.slow
def test_the_chosen_card_and_its_gates_reach_the_job(tiny_session, fetched_model_dir, tmp_path):
    run = assess_module.prepare(
        tiny_session, AssessOptions(out_dir=tmp_path / "out", model="heavy", model_dir=str(fetched_model_dir[0]))
    )
    heavy = landmark_card("heavy")
    job, models = run.job, run.models
    assert job.model == "heavy" and [m.card.name for m in models] == ["blazepose_detector", heavy.name]
    assert job.pose == PoseSettings().with_gates(heavy.gates)
    assert job.recon.min_confidence == heavy.gates.min_triangulation_confidence < ReconSettings().min_confidence
    assert job.recon == dataclasses.replace(
        run.session.reconstruction, min_confidence=heavy.gates.min_triangulation_confidence
    )
    assert run.session.reconstruction.expected_workers == 2  # ergopose simulate writes the number of workers
    assert models[-1].sha256 == heavy.file.sha256


def test_rescoring_names_the_model_the_tracks_were_made_with(tmp_path):
    heavy, detector = landmark_card("heavy"), "9ba9dd3d42efaaba86b4ff0122b06f29c4122e756b329d89dca1e297fd8f866c"
    store = ResultStore(tmp_path)
    store.open({"models": [detector, heavy.file.sha256]})
    assert json.loads(store.manifest_path.read_text())["inputs"]["models"][1] == heavy.file.sha256
    assert [m.card.name for m in rescore._models(tmp_path)] == ["blazepose_detector", heavy.name]
    # No manifest (or one that names unknown files): the detector and the default card.
    assert [m.card.name for m in rescore._models(tmp_path / "nothing")] == [
        "blazepose_detector",
        landmark_card(None).name,
    ]
