"""The reliability of the reported score probability (ergopose.evaluation.scoring.probability_reliability):
binned and counted by hand here, on made-up frames whose agreement is decided by the test."""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.ergonomics.uncertainty import CONFIDENT_P
from ergopose.evaluation.scoring import PROBABILITY_BINS, probability_reliability


def _frames(p: float, n: int, agreeing: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n frames reported with probability p, of which the first ``agreeing`` have the true score."""
    measured = np.full(n, 3.0)
    truth = np.where(np.arange(n) < agreeing, 3.0, 4.0)
    return np.full(n, p), measured, truth


def _join(*parts):
    return tuple(np.concatenate(x) for x in zip(*parts))


def test_a_calibrated_probability_has_no_gap():
    # p 0.1: 1 in 10 right; p 0.5: 5 in 10; p 0.9: 9 in 10.
    p, a, b = _join(_frames(0.1, 10, 1), _frames(0.5, 10, 5), _frames(0.9, 10, 9))
    r = probability_reliability(p, a, b)
    assert r["bins"] == [[PROBABILITY_BINS[k], PROBABILITY_BINS[k + 1]] for k in range(len(PROBABILITY_BINS) - 1)]
    assert r["frames"] == [10, 0, 10, 0, 10]
    assert r["exact_agreement_pct"][0] == pytest.approx(10.0) and r["exact_agreement_pct"][4] == pytest.approx(90.0)
    assert np.isnan(r["exact_agreement_pct"][1]) and np.isnan(r["mean_probability"][3])
    assert r["calibration_gap_pp"] == pytest.approx(0.0)
    assert r["confident"] == {"frames": 10, "exact_agreement_pct": pytest.approx(90.0)}
    assert r["others"]["frames"] == 20 and r["others"]["exact_agreement_pct"] == pytest.approx(30.0)


def test_an_overconfident_and_an_underconfident_probability_show_their_gap():
    # Reported 0.9 but right half the time: 40 points too sure; reported 0.1 and right 7 in 10:
    # 60 points too shy. Frame-weighted: (20 * 40 + 10 * 60) / 30.
    p, a, b = _join(_frames(0.9, 20, 10), _frames(0.1, 10, 7))
    r = probability_reliability(p, a, b)
    assert r["calibration_gap_pp"] == pytest.approx((20 * 40 + 10 * 60) / 30, abs=0.005)  # rounded to 0.01
    # The confident frames agree less than the others: what the gap alone does not say.
    assert r["confident"]["exact_agreement_pct"] < r["others"]["exact_agreement_pct"]


def test_edges_missing_values_and_the_confident_threshold():
    p = np.array([0.0, 0.2, CONFIDENT_P, 1.0, np.nan, 0.5, 0.5])
    a = np.array([1.0, 1.0, 1.0, 1.0, 1.0, np.nan, 1.0])
    b = np.array([1.0, 2.0, 1.0, 1.0, 1.0, 1.0, np.nan])
    r = probability_reliability(p, a, b)
    # The NaN probability, the NaN measured and the NaN truth are left out; 0.2 opens the second
    # bin; 1.0 is in the last bin; CONFIDENT_P counts as confident.
    assert sum(r["frames"]) == 4 and r["frames"][0] == 1 and r["frames"][1] == 1 and r["frames"][-1] == 1
    assert r["confident"]["frames"] == 2 and r["others"]["frames"] == 2
    assert r["others"]["exact_agreement_pct"] == pytest.approx(50.0)
