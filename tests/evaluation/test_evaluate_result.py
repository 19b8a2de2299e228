"""The evaluation's result (ergopose/evaluation/compare.py) without a simulated session: the strict
JSON of an Evaluation, and how evaluate_results puts the sections together (each section stood in
for by a stub that returns a known value; the sections have their own slow tests in
test_evaluate_compare.py)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import pytest

from ergopose.evaluation import compare
from ergopose.evaluation.compare import Evaluation, evaluate_results, write_json
from ergopose.evaluation.loading import ResultsLayout
from ergopose.recon.settings import ReconSettings


def _evaluation(**changes) -> Evaluation:
    fields = dict(
        source="test",
        session="s",
        results="r",
        frames=10,
        fps=12.0,
        lens_regions={"agree": True},
        matching={"switches": 0},
        detection={"rate_pct": math.nan},
        errors_3d={"mpjpe_mm": (1.5, 2)},
        limbs={},
        angles={},
        scores={},
        bar={},
        notes=("a note",),
    )
    fields.update(changes)
    return Evaluation(**fields)


def test_to_dict_orders_the_sections_and_is_strict_json():
    d = _evaluation().to_dict()
    assert list(d) == [
        "format",
        "version",
        "source",
        "session",
        "results",
        "frames",
        "fps",
        "lens_regions",
        "matching",
        "detection",
        "errors_3d",
        "limbs",
        "angles",
        "scores",
        "bar",
        "notes",
    ]
    assert (d["format"], d["version"]) == ("ergopose.evaluation", 1)
    assert d["detection"] == {"rate_pct": None}  # NaN -> null
    assert d["errors_3d"] == {"mpjpe_mm": [1.5, 2]} and d["notes"] == ["a note"]
    json.dumps(d, allow_nan=False)


def test_to_dict_names_the_oracle_after_the_header():
    d = _evaluation(oracle={"noise_px": 2.0, "seed": 1}).to_dict()
    assert list(d)[7:9] == ["oracle", "lens_regions"]
    assert d["oracle"] == {"noise_px": 2.0, "seed": 1}


def test_write_json_writes_strict_json(tmp_path):
    path = write_json(_evaluation(), tmp_path / "evaluation.json")
    text = path.read_text(encoding="utf-8")
    assert text.endswith("}\n") and "NaN" not in text
    assert json.loads(text)["detection"] == {"rate_pct": None}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["evaluation.json"]  # no temporary file left


@pytest.fixture
def stubbed(monkeypatch):
    """evaluate_results over stub sections; returns the list of calls (name, arguments)."""
    calls: list[tuple[str, tuple]] = []
    inp = SimpleNamespace(
        recon=ReconSettings(lens_region_limits_deg=(40.0, 70.0)),
        session=SimpleNamespace(path=Path("session")),
        gt=SimpleNamespace(n_frames=24, fps=12.0),
    )

    def stub(name, value):
        def f(*args, **kwargs):
            calls.append((name, args + tuple(sorted(kwargs.items()))))
            return value

        monkeypatch.setattr(compare, name, f)

    stub("load_inputs", inp)
    stub("row_people", "people")
    stub("matching_section", ({"matching": 1}, {}))  # no tracked worker matched
    stub("detection_section", {"detection": 1})
    stub("errors_section", {"errors": 1})
    stub("limbs_section", {"limbs": 1})
    stub("worker_frames", "csvs")
    stub("angles_section", {"caveat": "angles caveat"})
    stub("scores_section", {"task_factor_note": "task factor note"})
    stub("bar_section", {"bar": 1})
    return calls


def test_evaluate_results_puts_the_sections_together(stubbed):
    events = []
    layout = ResultsLayout.of_assess(Path("out"))
    ev = evaluate_results(
        "session", layout, source="src", oracle={"o": 1}, bar_noise_px=0.25, bar_draws=7, seed=3, progress=events.append
    )
    assert [name for name, _ in stubbed] == [
        "load_inputs",
        "row_people",
        "matching_section",
        "detection_section",
        "errors_section",
        "limbs_section",
        "worker_frames",
        "angles_section",
        "scores_section",
        "bar_section",
    ]
    bar_args = dict(stubbed[-1][1][3:])
    assert stubbed[-1][1][2] == (40.0, 70.0) and bar_args == {"draws": 7, "noise_px": 0.25, "seed": 3}
    assert (ev.source, ev.session, ev.results, ev.frames, ev.fps) == ("src", "session", "out", 24, 12.0)
    assert (ev.matching, ev.detection, ev.errors_3d, ev.limbs, ev.bar, ev.oracle) == (
        {"matching": 1},
        {"detection": 1},
        {"errors": 1},
        {"limbs": 1},
        {"bar": 1},
        {"o": 1},
    )
    assert ev.lens_regions["used_limits_deg"] == [40.0, 70.0]
    # notes: the lens regions differ, the scores' note, nobody matched, the angles' caveat
    assert len(ev.notes) == 4 and ev.notes[0].startswith("Lens regions")
    assert ev.notes[1:] == (
        "task factor note",
        "No tracked worker could be matched to a simulated worker: the per-worker sections are empty.",
        "angles caveat",
    )
    # one event per step before it runs, then the end
    assert [(e.stage, e.done, e.total) for e in events] == [("evaluation", k, 8) for k in range(9)]


def test_evaluate_results_notes_only_what_applies(stubbed, monkeypatch):
    monkeypatch.setattr(compare, "matching_section", lambda inp, person: ({}, {"worker_1": "w1"}))
    monkeypatch.setattr(compare, "scores_section", lambda inp, csvs: {})
    ev = evaluate_results("session", ResultsLayout.of_assess(Path("out")))
    assert ev.notes[1:] == ("angles caveat",) and ev.source == compare.NETWORK_SOURCE and ev.oracle is None
