"""ergopose evaluate through cli.main: text, strict JSON at the default and a chosen place, errors."""

from __future__ import annotations

import json

import pytest

from evaluation_helpers import ground_truth_tracks, write_results

from ergopose.cli import main
from ergopose.sim.ground_truth import load_ground_truth

# Left out of make test-fast (still in make test): every test here evaluates a simulated 15 s session (small_session).
pytestmark = pytest.mark.slow

SECTIONS = ("source", "lens_regions", "matching", "detection", "errors_3d", "limbs", "angles", "scores", "bar", "notes")


def _strict(text: str):
    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


@pytest.mark.slow
def test_evaluate_prints_and_writes_json(small_session, tmp_path, capsys):
    out = write_results(small_session, tmp_path / "out", ground_truth_tracks(load_ground_truth(small_session)))
    assert main(["evaluate", "--session", str(small_session), "--results", str(out), "--bar-draws", "10"]) == 0
    text = capsys.readouterr().out
    for heading in (
        "Identities",
        "Detection",
        "3D joint error (MPJPE)",
        "Limb lengths",
        "Joint angles",
        "RULA / REBA agreement",
        "Reference bar",
    ):
        assert heading in text
    data = _strict((out / "evaluation.json").read_text())
    for key in SECTIONS:
        assert key in data, key
    assert data["source"] == "pose network (ergopose assess)" and "oracle" not in data
    assert data["errors_3d"]["mpjpe_mm"] == 0.0
    chosen = tmp_path / "elsewhere" / "ev.json"
    assert (
        main(
            [
                "evaluate",
                "--session",
                str(small_session),
                "--results",
                str(out),
                "--json",
                str(chosen),
                "--bar-draws",
                "10",
            ]
        )
        == 0
    )
    assert _strict(chosen.read_text())["matching"] == data["matching"]
    assert not list(chosen.parent.glob(".*tmp*"))  # written atomically, nothing left behind


def test_missing_results_are_one_line_errors(small_session, tmp_path, capsys):
    assert main(["evaluate", "--session", str(small_session), "--results", str(tmp_path / "none")]) == 2
    err = capsys.readouterr().err  # progress lines on stderr, then one error line
    last = err.strip().splitlines()[-1]
    assert last.startswith("ergopose: error:") and "tracks table does not exist" in last
    assert err.count("ergopose: error") == 1 and "Traceback" not in err
    assert main(["evaluate", "--session", str(tmp_path / "no_session"), "--results", str(tmp_path)]) == 2
    assert "session folder does not exist" in capsys.readouterr().err
