"""What tells workers apart over a shift: the body-measurement signature (the medians of a
person's limb lengths, keypoints.LIMBS, gathered in 1 mm histograms) and the clothing colour
(the running mean of ergopose.pose.appearance), with the thresholds the tracker judges them by
(ergopose.recon.tracking; docs/reconstruction.md, 3. Identities)."""

from __future__ import annotations

import numpy as np

from ergopose.arrays import FloatArray, IntArray
from ergopose.keypoints import LIMB_INDEX, LIMBS
from ergopose.records import APPEARANCE_DIMS

#: Clothing colour (ergopose.pose.appearance; distances in its L*a*b* units, 0..255 scale). A
#: worker's own 3D rows lie a median 2.5-5.5 (90th percentile 4-14) from the worker's mean, and
#: the means of four simulated workers 21-40 from each other (seed 0, network keypoints, the first
#: 10 s). APPEARANCE_SIGMA: the spread of one row about its track's mean in the matching's
#: likelihood; APPEARANCE_GATE: a row further than this from a track's colour is not that
#: track's person; an identity within APPEARANCE_SAME of a new track, APPEARANCE_MARGIN closer
#: than any other, is its person; one further than APPEARANCE_NEW from every identity is someone
#: new. A colour enters a mean only from APPEARANCE_MIN_ROWS rows on.
APPEARANCE_SIGMA = 8.0
APPEARANCE_GATE = 30.0
APPEARANCE_SAME = 12.0
APPEARANCE_MARGIN = 8.0
APPEARANCE_NEW = 18.0
APPEARANCE_MIN_ROWS = 5
#: Two confirmed tracks whose colours are at least this far apart are not split at a contact
#: (the colour term of the matching tells their people apart frame by frame).
APPEARANCE_APART = 18.0
#: Limb-length histogram: bin width and number of bins (0 .. 1.5 m in millimetres).
HIST_BIN_M = 0.001
HIST_BINS = 1500
#: A limb's median enters a signature only with at least this many samples; a comparison needs
#: at least MIN_COMMON_LIMBS such limbs in both.
MIN_LIMB_SAMPLES = 5
MIN_COMMON_LIMBS = 6
#: Winter (2009, Fig. 4.1) fractions of stature of the body's long segments: trunk (hip to
#: shoulder, 0.818 - 0.530), thigh, shank, upper arm, forearm. The stature estimate is the sum of
#: the median lengths of the segments known (mean of the sides known) divided by the sum of their
#: fractions; the trunk must be among them (legs are often hidden from one of two ceiling cameras).
_STATURE_SEGMENTS = {"trunk_side": 0.288, "thigh": 0.245, "shank": 0.246, "upper_arm": 0.186, "forearm": 0.146}


def limb_lengths(points_world: np.ndarray) -> FloatArray:
    """(..., 33, 3) -> (..., L) length of every limb of keypoints.LIMBS, NaN where a joint is NaN."""
    X = np.asarray(points_world, dtype=np.float64)
    lengths: FloatArray = np.linalg.norm(X[..., LIMB_INDEX[:, 0], :] - X[..., LIMB_INDEX[:, 1], :], axis=-1)
    return lengths


class LimbHistogram:
    """Counts of limb lengths in 1 mm bins (bounded memory, exact robust medians to 1 mm)."""

    def __init__(self, n_limbs: int = len(LIMBS)) -> None:
        self.counts = np.zeros((n_limbs, HIST_BINS), dtype=np.int64)

    def add(self, lengths: np.ndarray) -> None:
        """lengths: (n, L) metres; NaN and lengths beyond the histogram are ignored."""
        n_limbs = self.counts.shape[0]
        lengths = np.asarray(lengths, dtype=np.float64).reshape(-1, n_limbs)
        if lengths.size == 0:
            return
        with np.errstate(invalid="ignore"):
            b = np.floor(lengths / HIST_BIN_M)
            ok = np.isfinite(b) & (b >= 0) & (b < HIST_BINS)
        limb = np.broadcast_to(np.arange(n_limbs), lengths.shape)[ok]
        flat = limb * HIST_BINS + b[ok].astype(np.int64)
        self.counts += np.bincount(flat, minlength=self.counts.size).reshape(self.counts.shape)

    def merge(self, other: "LimbHistogram") -> None:
        self.counts += other.counts

    @property
    def samples(self) -> IntArray:
        """(L,) number of samples per limb."""
        samples: IntArray = self.counts.sum(axis=1)
        return samples

    def medians(self, min_samples: int = MIN_LIMB_SAMPLES) -> np.ndarray:
        """(L,) median length per limb (metres, linear within the 1 mm bin); NaN with too few samples."""
        n = self.samples
        cum = np.cumsum(self.counts, axis=1)
        half = n / 2.0
        k = np.argmax(cum >= half[:, None], axis=1)
        below = np.where(k > 0, cum[np.arange(len(n)), k - 1], 0)
        inbin = self.counts[np.arange(len(n)), k]
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.where(inbin > 0, (half - below) / inbin, 0.5)
        med = (k + frac) * HIST_BIN_M
        return np.where(n >= max(min_samples, 1), med, np.nan)

    def stature_estimate(self) -> float:
        """Estimated stature (metres) from the median lengths of the long segments known (see
        _STATURE_SEGMENTS, Winter's fractions of stature); NaN without the trunk."""
        med = self.medians()
        names = [n for n, _, _ in LIMBS]
        total = 0.0
        frac = 0.0
        for segment, f in _STATURE_SEGMENTS.items():
            sides = [med[names.index(f"{side}_{segment}")] for side in ("left", "right")]
            sides = [v for v in sides if np.isfinite(v)]
            if not sides:
                if segment == "trunk_side":
                    return float("nan")
                continue
            total += float(np.mean(sides))
            frac += f
        return float(total / frac)


class Look:
    """The running mean clothing colour of a track or identity (ergopose.pose.appearance)."""

    def __init__(self) -> None:
        self.total = np.zeros(APPEARANCE_DIMS)
        self.count = np.zeros(APPEARANCE_DIMS, dtype=np.int64)

    def add(self, looks: np.ndarray) -> None:
        """looks: (n, APPEARANCE_DIMS); NaN entries are ignored."""
        looks = np.asarray(looks, dtype=np.float64).reshape(-1, APPEARANCE_DIMS)
        known = np.isfinite(looks)
        self.total += np.where(known, looks, 0.0).sum(axis=0)
        self.count += known.sum(axis=0)

    def merge(self, other: "Look") -> None:
        self.total += other.total
        self.count += other.count

    def mean(self) -> np.ndarray:
        """(APPEARANCE_DIMS,) mean colour; NaN where fewer than APPEARANCE_MIN_ROWS rows gave it."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.count >= APPEARANCE_MIN_ROWS, self.total / np.maximum(self.count, 1), np.nan)


def signature_distance(a: np.ndarray, b: np.ndarray) -> float:
    """RMS difference (metres) of two limb-median vectors over the limbs known in both; NaN when
    fewer than MIN_COMMON_LIMBS are."""
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < MIN_COMMON_LIMBS:
        return float("nan")
    return float(np.sqrt(np.mean((a[ok] - b[ok]) ** 2)))
