"""The ORACLE run: reconstruction from the simulator's ORACLE 2D keypoints, labelled ORACLE in every
output, exact without noise, worse with it; and through the command line."""

from __future__ import annotations

import json

import pytest

from ergopose.cli import main
from ergopose.evaluation.compare import evaluate_results
from ergopose.evaluation.oracle import OracleOptions, run_oracle
from ergopose.recon.table import read_metadata

# Left out of make test-fast (still in make test): every test here runs the oracle evaluation on a simulated session.
pytestmark = pytest.mark.slow

EXACT = OracleOptions(noise_px=0.0, occluded_noise_px=0.0, person_dropout=0.0, joint_dropout=0.0)


@pytest.fixture(scope="module")
def exact_run(small_session, tmp_path_factory):
    # naming tracked people by stature is off by default; with exact 2D it must name them right
    import shutil

    small_session = shutil.copytree(small_session, tmp_path_factory.mktemp("by_stature") / "session")
    settings = small_session / "settings.toml"
    settings.write_text(settings.read_text() + "\n[identification]\nby_stature = true\n")
    out = tmp_path_factory.mktemp("oracle") / "out"
    layout = run_oracle(small_session, out, EXACT)
    ev = evaluate_results(small_session, layout, source=EXACT.banner(), oracle=EXACT.as_dict(), bar_draws=5)
    return out, layout, ev.to_dict()


def test_oracle_outputs_are_labelled(exact_run):
    out, layout, ev = exact_run
    assert layout.root == out / "oracle"
    readme = (layout.root / "README_ORACLE.txt").read_text()
    assert readme.startswith("ORACLE 2D (simulated ground truth projected with 0 px noise) — not the pose network")
    assert layout.tracks.name == "ORACLE_tracks.parquet" and layout.tracks.is_file()
    meta = read_metadata(layout.tracks)
    assert meta["source"] == "oracle" and meta["oracle"]["noise_px"] == 0.0
    csvs = sorted(p.name for p in (layout.root / "csv").iterdir())
    # named after the settings' workers by stature, as assess does (the simulator gives the statures)
    assert csvs == ["ORACLE_w1_steps.csv", "ORACLE_w2_steps.csv"]
    # the assessment's driver ran it (its stored chunks served this run alone and are gone):
    # the folder holds the labelled results only, no unlabelled CSV file, report page or chunk
    files = sorted(str(p.relative_to(layout.root)) for p in layout.root.rglob("*") if p.is_file())
    assert files == [
        "README_ORACLE.txt",
        "csv/ORACLE_w1_steps.csv",
        "csv/ORACLE_w2_steps.csv",
        "pipeline/ORACLE_tracks.parquet",
    ]
    assert ev["source"].startswith("ORACLE 2D") and ev["oracle"]["banner"] == ev["source"]


def test_exact_oracle_reconstructs_the_ground_truth(exact_run):
    _, _, ev = exact_run
    assert ev["matching"]["identity_switches"] == 0
    named = ev["matching"]["named_by_stature"]
    assert sorted(named["ids"].values()) == ["w1", "w2"] and named["correct_pct"] == 100.0
    assert sorted(ev["matching"]["mapping"].values()) == ["w1", "w2"]
    # Triangulation of exact rays is exact. The final positions are the body model's for every
    # joint (not only those two cameras saw), smoothed: its priors (segment play, previous pose)
    # and the smoother's lag behind fast hands and feet cost a little; measured 18.3 mm.
    assert ev["errors_3d"]["raw"]["mpjpe_mm"] < 0.5
    assert ev["errors_3d"]["final"]["mpjpe_mm"] < 22.0
    assert ev["detection"]["detection_rate_pct"] >= 98.0
    assert ev["limbs"]["error"]["rmse_mm"] < 15.0
    # Every compared frame carries its score's probability. The RULA grand scores the pipeline
    # calls confident are the true score (exact keypoints); REBA's probability does not tell right
    # from wrong (docs/scoring.md, "Each draw lasts"), so only its count is checked.
    for c in ("rula_grand", "reba_score"):
        rel = ev["scores"][c]["reported_probability"]
        assert sum(rel["frames"]) == ev["scores"][c]["pairs"], c
    rel = ev["scores"]["rula_grand"]["reported_probability"]
    assert rel["confident"]["frames"] > 0 and rel["confident"]["exact_agreement_pct"] >= 90.0, rel
    assert rel["others"]["exact_agreement_pct"] < rel["confident"]["exact_agreement_pct"] - 20.0, rel  # 36 / 97 %


def test_pixel_noise_costs_accuracy(small_session, exact_run, tmp_path):
    _, _, exact = exact_run
    noisy = OracleOptions(noise_px=1.0, occluded_noise_px=3.0, person_dropout=0.0, joint_dropout=0.0, seed=3)
    layout = run_oracle(small_session, tmp_path / "out", noisy)
    ev = evaluate_results(small_session, layout, source=noisy.banner(), bar_draws=5).to_dict()
    assert ev["errors_3d"]["raw"]["mpjpe_mm"] > exact["errors_3d"]["raw"]["mpjpe_mm"] + 5.0
    assert ev["errors_3d"]["final"]["mpjpe_mm"] < ev["errors_3d"]["raw"]["mpjpe_mm"]  # smoothing helps


@pytest.mark.slow
def test_oracle_through_the_command_line(small_session, tmp_path, capsys):
    out = tmp_path / "out"
    code = main(
        [
            "evaluate",
            "--session",
            str(small_session),
            "--results",
            str(out),
            "--oracle",
            "--noise-px",
            "0.5",
            "--dropout",
            "0.01",
            "--own-body-seen",
            "--bar-draws",
            "5",
        ]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert text.splitlines()[0] == (
        "ORACLE 2D (simulated ground truth projected with 0.5 px noise; joints behind the worker's own body "
        "reported as seen) — not the pose network"
    )
    data = json.loads((out / "oracle" / "evaluation.json").read_text())
    assert data["oracle"]["noise_px"] == 0.5 and data["oracle"]["person_dropout"] == 0.01
    assert data["oracle"]["own_body_hides"] is False
    assert data["source"].startswith("ORACLE 2D")
    assert not (out / "evaluation.json").exists()  # nothing outside OUT/oracle/


def test_bad_oracle_options_are_one_line_errors(small_session, tmp_path, capsys):
    code = main(
        ["evaluate", "--session", str(small_session), "--results", str(tmp_path), "--oracle", "--dropout", "1.5"]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("ergopose: error:") and err.count("\n") == 1 and "--dropout" in err
