"""simulate -> the REAL ergopose assess (BlazePose) -> ergopose evaluate, all through cli.main."""

from __future__ import annotations

import json
import math

import pytest

from evaluation_helpers import simulate

from ergopose.cli import main
from ergopose.recon.diagnostics import REGIONS

# End to end (simulated sessions, whole runs): left out by make test-fast.
pytestmark = pytest.mark.slow


def _num(x) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)


def test_simulate_assess_evaluate(fetched_model_dir, tmp_path, capsys):
    session = simulate(tmp_path / "session", workers=2, minutes=0.1, seed=0, size="1024x768")
    out = tmp_path / "report"
    assert main(["assess", "--session", str(session), "--out", str(out), "--model-dir", str(fetched_model_dir[0])]) == 0
    assert main(["evaluate", "--session", str(session), "--results", str(out), "--bar-draws", "20"]) == 0
    text = capsys.readouterr().out
    assert "ORACLE" not in text.split("Evaluation of")[0]
    ev = json.loads((out / "evaluation.json").read_text())
    for key in ("source", "lens_regions", "matching", "detection", "errors_3d", "limbs", "angles", "scores", "bar"):
        assert key in ev, key
    assert ev["source"] == "pose network (ergopose assess)" and ev["frames"] == 72

    m = ev["matching"]
    assert m["tracked_workers"], "the network found nobody in 6 s of two workers"
    assert m["mapping"], "no tracked worker matches a simulated one"
    assert set(m["mapping"].values()) <= {"w1", "w2"} and m["identity_switches"] >= 0

    d = ev["detection"]
    assert 0 < d["detection_rate_pct"] <= 100
    assert d["visible_in_both_cameras"]["worker_frames"] > 0

    e = ev["errors_3d"]
    # BlazePose on ~100 px people: errors of centimetres to decimetres, not metres
    assert _num(e["mpjpe_mm"]) and 0 < e["mpjpe_mm"] < 500
    assert e["final"]["by_region"]["all"]["points"] > 0
    assert set(e["final"]["by_region"]) == {"all", *REGIONS}

    limbs = ev["limbs"]
    assert 0 < limbs["frequency_pct"] <= 100 and _num(limbs["error"]["rmse_mm"])
    a = ev["angles"]
    assert a["rows_compared"] > 0 and _num(a["rmse_all_deg"]) and a["rmse_all_deg"] < 90
    for c in ("rula_grand", "rula_action_level", "reba_score", "reba_risk_level"):
        s = ev["scores"][c]
        assert s["pairs"] + s["missing_tracked"] + s["missing_truth"] <= a["rows_compared"]
        for k in ("kappa", "kappa_linear"):
            assert s[k] is None or -1.0 <= s[k] <= 1.0
    bar = {r["region"]: r for r in ev["bar"]["regions"]}
    assert abs(bar["central"]["error_pct"]) < 1.0 and bar["central"]["n"] == 20
