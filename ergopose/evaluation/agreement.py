"""Agreement of two raters on an ordinal scale: confusion matrix, exact agreement, Cohen's kappa.

Cohen's kappa compares the observed agreement with the agreement expected by chance from the two
raters' own marginal distributions (Cohen 1960); the weighted form (Cohen 1968) gives partial
credit to near misses, which suits ordinal scores such as the RULA grand score:

    kappa_w = 1 - sum(w * O) / sum(w * E)

O: observed confusion matrix (counts), E: the counts expected from the marginals
(row_sum x column_sum / n), w: disagreement weights -- 0 on the diagonal and 1 off it
(unweighted), |i - j| / (k - 1) (linear) or ((i - j) / (k - 1))^2 (quadratic) for categories i, j
of an ordered scale of k categories. Unweighted kappa is the classic (p_o - p_e) / (1 - p_e).

The weights depend on the categories of the WHOLE scale (a RULA grand score of 1 and one of 7 are
six steps apart even when no frame scored 2-6), so the scale is passed explicitly.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd

WEIGHTS = ("none", "linear", "quadratic")


def confusion_matrix(a, b, categories: Sequence[float]) -> np.ndarray:
    """(k, k) int64 counts: rows = categories of ``a``, columns = categories of ``b``.

    a, b: equal-length numeric ratings (numpy, pandas nullable integers, lists); pairs where
    either is missing (NaN, pandas NA) or not one of the numeric ``categories`` are left out.
    """
    fa, fb = _numbers(a), _numbers(b)
    if fa.shape != fb.shape:
        raise ValueError(f"the two ratings have different lengths ({fa.shape} and {fb.shape})")
    cats = np.asarray(categories, dtype=np.float64)
    k = len(cats)
    order = np.argsort(cats)

    def index(x: np.ndarray) -> np.ndarray:
        pos = np.clip(np.searchsorted(cats[order], x), 0, k - 1)
        hit = cats[order][pos] == x  # NaN never equals
        return np.where(hit, order[pos], -1)

    ia, ib = index(fa), index(fb)
    ok = (ia >= 0) & (ib >= 0)
    return np.bincount(ia[ok] * k + ib[ok], minlength=k * k).reshape(k, k).astype(np.int64)


def _numbers(x) -> np.ndarray:
    """Ratings as a float array, NaN where missing (pandas NA included)."""
    return pd.to_numeric(
        pd.Series(np.asarray(x, dtype=object) if not hasattr(x, "dtype") else x), errors="coerce"
    ).to_numpy(dtype=np.float64, na_value=np.nan)


def kappa_from_matrix(counts: np.ndarray, weights: str = "none") -> float:
    """Cohen's kappa of a (k, k) confusion matrix; ``weights`` "none", "linear" or "quadratic".

    NaN when it is undefined: no pairs, or chance disagreement zero (both raters used one and the
    same single category throughout).
    """
    O = np.asarray(counts, dtype=np.float64)
    if O.ndim != 2 or O.shape[0] != O.shape[1]:
        raise ValueError(f"expected a square confusion matrix, got shape {O.shape}")
    if weights not in WEIGHTS:
        raise ValueError(f"weights must be one of {', '.join(WEIGHTS)}, got {weights!r}")
    n = O.sum()
    k = O.shape[0]
    if n <= 0:
        return float("nan")
    i, j = np.indices((k, k))
    if weights == "none":
        w = (i != j).astype(np.float64)
    else:
        d = np.abs(i - j) / max(k - 1, 1)
        w = d if weights == "linear" else d * d
    E = np.outer(O.sum(axis=1), O.sum(axis=0)) / n
    expected = float((w * E).sum())
    if expected <= 0:
        return float("nan")
    return 1.0 - float((w * O).sum()) / expected


def cohen_kappa(a, b, categories: Sequence, weights: str = "none") -> float:
    """Cohen's kappa of two ratings of the same items on the scale ``categories`` (see module)."""
    return kappa_from_matrix(confusion_matrix(a, b, categories), weights)


def exact_agreement(counts: np.ndarray) -> float:
    """Share of pairs on the diagonal (NaN without pairs)."""
    O = np.asarray(counts, dtype=np.float64)
    n = O.sum()
    return float(np.trace(O) / n) if n else float("nan")


def within_one(counts: np.ndarray) -> float:
    """Share of pairs at most one category apart (NaN without pairs)."""
    O = np.asarray(counts, dtype=np.float64)
    n = O.sum()
    i, j = np.indices(O.shape)
    return float(O[np.abs(i - j) <= 1].sum() / n) if n else float("nan")
