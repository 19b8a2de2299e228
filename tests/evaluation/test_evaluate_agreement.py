"""Cohen's kappa against worked examples with known answers."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ergopose.evaluation.agreement import confusion_matrix, cohen_kappa, exact_agreement, kappa_from_matrix, within_one


def test_unweighted_kappa_of_the_textbook_two_by_two_example():
    # Two readers, 50 applications: both "yes" 20, both "no" 15, reader A yes / B no 5, A no / B yes 10.
    # p_o = 35/50 = 0.7; p_yes = 0.5 * 0.6 = 0.3, p_no = 0.5 * 0.4 = 0.2, p_e = 0.5; kappa = 0.2/0.5 = 0.4
    # (the worked example of Cohen's kappa in Wikipedia's article).
    counts = np.array([[20, 5], [10, 15]])
    assert kappa_from_matrix(counts) == pytest.approx(0.4, abs=1e-12)
    assert exact_agreement(counts) == pytest.approx(0.7)


def test_three_category_kappas_computed_by_hand():
    # O = [[10, 3, 0], [2, 8, 1], [0, 2, 4]], n = 30; rows 13, 11, 6; columns 12, 13, 5.
    # Unweighted: p_o = 22/30, p_e = (13*12 + 11*13 + 6*5)/900 = 329/900, kappa = 331/571.
    # Linear: observed disagreement = (3+2+1+2) * 1/2 = 4 (per 30); expected counts one step apart
    # (13*13 + 11*12 + 11*5 + 6*13)/30 * 1/2 = 217/30, two apart (13*5 + 6*12)/30 * 1 = 137/30,
    # so kappa = 1 - 4 / (354/30) = 1 - 120/354 = 117/177.
    # Quadratic: observed 8 * 1/4 = 2, expected (434/4 + 137)/30 = 245.5/30, kappa = 1 - 60/245.5.
    O = np.array([[10, 3, 0], [2, 8, 1], [0, 2, 4]])
    assert kappa_from_matrix(O) == pytest.approx(331 / 571, abs=1e-12)
    assert kappa_from_matrix(O, "linear") == pytest.approx(117 / 177, abs=1e-12)
    assert kappa_from_matrix(O, "quadratic") == pytest.approx(1 - 60 / 245.5, abs=1e-12)
    assert within_one(O) == pytest.approx(1.0)


def test_ratings_give_the_same_matrix_and_kappa():
    # The 3 x 3 example above written as 30 pairs of ratings on the scale 1..3.
    O = np.array([[10, 3, 0], [2, 8, 1], [0, 2, 4]])
    a, b = [], []
    for i in range(3):
        for j in range(3):
            a += [i + 1] * O[i, j]
            b += [j + 1] * O[i, j]
    assert np.array_equal(confusion_matrix(a, b, [1, 2, 3]), O)
    assert cohen_kappa(a, b, [1, 2, 3], "linear") == pytest.approx(117 / 177)
    # swapping the raters transposes the matrix; kappa is symmetric
    assert cohen_kappa(b, a, [1, 2, 3], "linear") == pytest.approx(117 / 177)


def test_missing_and_off_scale_ratings_are_left_out():
    a = pd.array([1, 2, None, 3, 9], dtype="Int16")
    b = np.array([1, 2, 2, np.nan, 1])
    assert np.array_equal(confusion_matrix(a, b, [1, 2, 3]), [[1, 0, 0], [0, 1, 0], [0, 0, 0]])


def test_unused_categories_still_count_for_the_weights():
    # The scale 1..7 with only 1 and 7 used: a 1-vs-7 disagreement weighs 1 (six of six steps),
    # so the linear kappa equals the unweighted one here; on the scale 1, 7 alone the same holds.
    a = [1, 1, 7, 7, 1]
    b = [1, 7, 7, 7, 1]
    full = cohen_kappa(a, b, range(1, 8), "linear")
    assert full == pytest.approx(cohen_kappa(a, b, [1, 7], "none"))
    # ... while near misses (1 vs 2) among ratings that also use 7 weigh 1/6 against the far chance
    # pairs: the linear kappa rises above the unweighted one.
    c = [1, 2, 7, 7, 1, 2]
    d = [2, 2, 7, 7, 1, 1]
    assert cohen_kappa(c, d, range(1, 8), "linear") > cohen_kappa(c, d, range(1, 8), "none") + 0.1


def test_perfect_agreement_is_one_and_undefined_cases_are_nan():
    assert cohen_kappa([1, 2, 3, 3], [1, 2, 3, 3], [1, 2, 3]) == 1.0
    assert cohen_kappa([1, 2, 3, 3], [1, 2, 3, 3], [1, 2, 3], "linear") == 1.0
    assert np.isnan(cohen_kappa([2, 2], [2, 2], [1, 2, 3]))  # one category only: chance agreement is 1
    assert np.isnan(cohen_kappa([], [], [1, 2, 3]))
    # agreement exactly at chance level
    assert kappa_from_matrix(np.array([[1, 1], [1, 1]])) == pytest.approx(0.0)


def test_bad_input_is_refused():
    with pytest.raises(ValueError):
        kappa_from_matrix(np.ones((2, 3)))
    with pytest.raises(ValueError):
        kappa_from_matrix(np.ones((2, 2)), "cubic")
    with pytest.raises(ValueError):
        confusion_matrix([1, 2], [1], [1, 2])
