"""Quality of the reconstruction: limb lengths per worker, by lens region, and 3D errors.

A person's limbs do not change length, so the spread of their measured lengths over a shift
shows how well the reconstruction works (the paper's evaluation, Fig. "limb length statistics"
and "reconstruction frequencies"). For every worker and limb of keypoints.LIMBS:

- the distribution of measured lengths: count, mean, standard deviation, coefficient of
  variation (std / mean), percentiles 5, 25, 50, 75, 95;
- the reconstruction frequency: the share of the worker's frames (rows of the tracks table) in
  which both joints of the limb have a position;

each for all frames and split by lens region. The region of a limb in a frame comes from the
larger of its two joints' ``lens_angle_deg`` (the largest angle off the cameras' axes; for a
joint without a position, the worker's body centre): central below the first limit of
``lens_region_limits_deg``, outer up to the second, edge beyond (settings; defaults 30 and 60
degrees).

With ground truth (simulation), :func:`region_errors` gives the 3D error of the joints per
lens region, :func:`match_workers` pairs workers with ground-truth people and
:func:`identity_switches` counts how often a ground-truth person's worker id changes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator, Sequence

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import linear_sum_assignment

from ergopose.arrays import FloatArray
from ergopose.keypoints import LIMB_INDEX, LIMBS, NUM_JOINTS
from ergopose.recon.pipeline import TrackFrames
from ergopose.recon.records import body_centres
from ergopose.recon.settings import ReconSettings
from ergopose.recon.track_records import identity_name
from ergopose.recon.track_signatures import limb_lengths

REGIONS = ("central", "outer", "edge")
PERCENTILES = (5, 25, 50, 75, 95)


def lens_region(angle_deg: ArrayLike, limits_deg: tuple[float, float] = (30.0, 60.0)) -> np.ndarray:
    """Angle off-axis (degrees) -> region index 0 central, 1 outer, 2 edge; -1 for NaN."""
    a = np.asarray(angle_deg, dtype=np.float64)
    out = np.full(a.shape, -1, dtype=np.int8)
    with np.errstate(invalid="ignore"):
        out[a < limits_deg[0]] = 0
        out[(a >= limits_deg[0]) & (a < limits_deg[1])] = 1
        out[a >= limits_deg[1]] = 2
    return out


@dataclass(frozen=True)
class LengthStats:
    """Distribution of one limb's measured length (metres) over a set of frames.

    region: "all", "central", "outer" or "edge".
    frames: frames in the set (the worker's rows in that region); reconstructed: of those, the
    frames where the limb has a length; frequency = reconstructed / frames (NaN if no frames).
    mean_m, std_m (population), cv = std / mean, percentiles_m: values at PERCENTILES; NaN
    when nothing was reconstructed (std and cv need two lengths).
    """

    limb: str
    region: str
    frames: int
    reconstructed: int
    frequency: float
    mean_m: float
    std_m: float
    cv: float
    percentiles_m: tuple[float, ...]


@dataclass(frozen=True)
class WorkerLimbDiagnostics:
    """All limbs of one worker: stats[(limb, region)] for every limb of LIMBS and every region
    in ("all",) + REGIONS; ``source`` is "final" (the table's x, y, z) or "raw"."""

    worker: str
    source: str
    frames: int
    stats: dict[tuple[str, str], LengthStats]

    def get(self, limb: str, region: str = "all") -> LengthStats:
        return self.stats[(limb, region)]


#: Width (metres) and number of the histogram bins the percentiles are read from; lengths beyond
#: the last bin go to an overflow bin that spans up to the longest length seen.
LENGTH_BIN_M = 0.001
LENGTH_BINS = 2000


def histogram_percentiles(
    counts: np.ndarray, q: Sequence[float], bin_m: float = LENGTH_BIN_M, overflow_max_m: np.ndarray | float = np.nan
) -> np.ndarray:
    """Percentiles q (0-100) of values counted in bins of width ``bin_m`` from 0 (last axis of
    ``counts``; its last bin is the overflow bin, spanning up to ``overflow_max_m``).

    Each counted value is placed evenly within its bin (the i-th of m values in a bin at
    (i + 0.5) / m of its width), then numpy's "linear" rule interpolates between the items of
    rank floor and ceil of q/100 x (n - 1); every placed value is within one bin of the true one,
    so the result is within one bin of np.percentile of the values. NaN where
    nothing was counted. Returns counts.shape[:-1] + (len(q),).
    """
    counts = np.asarray(counts)
    lead = counts.shape[:-1]
    c = counts.reshape(-1, counts.shape[-1]).astype(np.float64)
    n = c.sum(axis=1)
    cum = np.cumsum(c, axis=1)
    rank = (np.asarray(q, dtype=np.float64)[None, :] / 100.0) * np.maximum(n[:, None] - 1, 0)  # (m, Q)
    out = np.full(rank.shape, np.nan)
    rows = np.flatnonzero(n > 0)
    nb = c.shape[1]
    top = np.broadcast_to(np.asarray(overflow_max_m, dtype=np.float64), lead).reshape(-1)

    def value_at(j: np.ndarray) -> FloatArray:
        """Estimated value of the sorted item of index j (per row of ``rows``): placed evenly in its bin."""
        k = np.minimum(np.argmax(cum[rows] > j[:, None], axis=1), nb - 1)  # the bin holding item j
        below = np.where(k > 0, cum[rows, np.maximum(k - 1, 0)], 0.0)
        inbin = np.maximum(c[rows, k], 1.0)
        lo = k * bin_m
        width = np.where(k == nb - 1, np.fmax(top[rows] - lo, 0.0), bin_m)
        values: FloatArray = lo + np.clip((j - below + 0.5) / inbin, 0.0, 1.0) * width
        return values

    for qi in range(rank.shape[1]):  # five percentiles: a loop over q, vectorised over limbs and regions
        r = rank[rows, qi]
        j0 = np.floor(r)
        j1 = np.minimum(j0 + 1, np.maximum(n[rows] - 1, 0))
        v0, v1 = value_at(j0), value_at(j1)
        out[rows, qi] = v0 + (r - j0) * (v1 - v0)  # numpy's "linear" rule between neighbouring items
    return out.reshape(*lead, rank.shape[1])


class LimbStatsAccumulator:
    """The limb-length statistics of :func:`limb_diagnostics`, built chunk by chunk.

    Memory does not grow with the shift: per worker, limb and region it keeps counts, sums
    (exact mean and standard deviation) and a histogram of lengths in LENGTH_BIN_M bins
    (percentiles within one bin, 1 mm, of the exact values). Feed :meth:`add` the rows of a
    tracks table in any chunks; :meth:`result` gives the same diagnostics whatever the chunking.
    """

    def __init__(self, settings: ReconSettings | None = None, source: str = "final") -> None:
        if source not in ("final", "raw"):
            raise ValueError(f"source must be 'final' or 'raw', got {source!r}")
        self.settings = settings or ReconSettings()
        self.source = source
        self._w: dict[int, dict[str, np.ndarray]] = {}

    def _state(self, worker: int) -> dict[str, np.ndarray]:
        if worker not in self._w:
            L, R = len(LIMBS), len(REGIONS) + 1  # region 0 = all, 1.. = REGIONS
            self._w[worker] = {
                "rows": np.zeros(1, np.int64),
                "frames": np.zeros((L, R), np.int64),
                "known": np.zeros((L, R), np.int64),
                "sum": np.zeros((L, R)),
                "sumsq": np.zeros((L, R)),
                "max": np.full((L, R), np.nan),
                "hist": np.zeros((L, R, LENGTH_BINS + 1), np.int32),
            }
        return self._w[worker]

    def add(self, tracks: TrackFrames) -> None:
        if len(tracks) == 0:
            return
        X = tracks.points_world if self.source == "final" else tracks.raw_points_world
        lengths = limb_lengths(X)  # (n, L)
        ang = np.fmax(tracks.lens_angle_deg[:, LIMB_INDEX[:, 0]], tracks.lens_angle_deg[:, LIMB_INDEX[:, 1]])
        region = lens_region(ang, self.settings.lens_region_limits_deg).astype(np.int64) + 1  # 0 = no region
        L, R = len(LIMBS), len(REGIONS) + 1
        for w in np.unique(tracks.worker):
            sel = tracks.worker == w
            st = self._state(int(w))
            st["rows"] += int(sel.sum())
            x = lengths[sel]
            known = np.isfinite(x)
            limb = np.broadcast_to(np.arange(L), x.shape)
            region_w = region[sel]
            for whole in (True, False):  # "all", then each frame's lens region (none where unknown)
                reg = np.zeros_like(region_w) if whole else region_w
                use = np.ones(x.shape, bool) if whole else reg > 0
                cell = limb * R + reg
                st["frames"] += np.bincount(cell[use], minlength=L * R).reshape(L, R)
                ku = known & use
                kc, v = cell[ku], x[ku]
                st["known"] += np.bincount(kc, minlength=L * R).reshape(L, R)
                st["sum"] += np.bincount(kc, weights=v - _SHIFT_M, minlength=L * R).reshape(L, R)
                st["sumsq"] += np.bincount(kc, weights=(v - _SHIFT_M) ** 2, minlength=L * R).reshape(L, R)
                b = np.minimum(np.floor(v / LENGTH_BIN_M), LENGTH_BINS).astype(np.int64)
                st["hist"] += np.bincount(kc * (LENGTH_BINS + 1) + b, minlength=L * R * (LENGTH_BINS + 1)).reshape(
                    L, R, LENGTH_BINS + 1
                )
                m = np.full(L * R, -np.inf)
                np.maximum.at(m, kc, v)
                st["max"] = np.fmax(st["max"], np.where(np.isfinite(m), m, np.nan).reshape(L, R))

    def workers(self) -> list[int]:
        return sorted(self._w)

    def medians(self, worker: int) -> np.ndarray:
        """(L,) median length per limb (all regions), NaN for a limb never reconstructed."""
        st = self._w[worker]
        return histogram_percentiles(st["hist"][:, 0], (50,), overflow_max_m=st["max"][:, 0])[:, 0]

    def result(self) -> list[WorkerLimbDiagnostics]:
        out = []
        for w in self.workers():
            st = self._w[w]
            pct = histogram_percentiles(st["hist"], PERCENTILES, overflow_max_m=st["max"])
            stats = {}
            for li, (name, _, _) in enumerate(LIMBS):
                for r, region in enumerate(("all",) + REGIONS):
                    stats[(name, region)] = _length_stats(
                        name,
                        region,
                        int(st["frames"][li, r]),
                        int(st["known"][li, r]),
                        st["sum"][li, r],
                        st["sumsq"][li, r],
                        pct[li, r],
                    )
            out.append(
                WorkerLimbDiagnostics(
                    worker=identity_name(w), source=self.source, frames=int(st["rows"][0]), stats=stats
                )
            )
        return out


#: Lengths are summed relative to this (metres), so the variance does not lose digits.
_SHIFT_M = 0.4


def _length_stats(limb: str, region: str, n: int, k: int, s: float, ss: float, pct: np.ndarray) -> LengthStats:
    if k:
        mean_off = s / k
        mean = _SHIFT_M + mean_off
        std = float(np.sqrt(max(ss / k - mean_off**2, 0.0))) if k > 1 else float("nan")
        percentiles = tuple(float(x) for x in pct)
    else:
        mean = std = float("nan")
        percentiles = tuple(float("nan") for _ in PERCENTILES)
    return LengthStats(
        limb=limb,
        region=region,
        frames=n,
        reconstructed=k,
        frequency=k / n if n else float("nan"),
        mean_m=float(mean),
        std_m=std,
        cv=std / mean if k > 1 and mean > 0 else float("nan"),
        percentiles_m=percentiles,
    )


def limb_diagnostics(
    tracks: TrackFrames, settings: ReconSettings | None = None, source: str = "final"
) -> list[WorkerLimbDiagnostics]:
    """Limb-length statistics per worker (see module docstring); source "final" or "raw".

    One piece of :class:`LimbStatsAccumulator`: percentiles within 1 mm of the exact values.
    """
    acc = LimbStatsAccumulator(settings, source)
    acc.add(tracks)
    return acc.result()


@dataclass(frozen=True)
class RegionError:
    """3D error (metres) of the joints in one lens region ("all" for every region).

    points: joints compared (position and ground truth both known); mean_m (MPJPE), median_m,
    p95_m, rmse_m: statistics of the Euclidean error; NaN when points is 0.
    """

    region: str
    points: int
    mean_m: float
    median_m: float
    p95_m: float
    rmse_m: float


def region_errors(
    tracks: TrackFrames, truth: dict[int, np.ndarray], settings: ReconSettings | None = None, source: str = "final"
) -> dict[str, RegionError]:
    """3D error per lens region against ground truth.

    truth: {worker number: (n_w, 33, 3) true joints for that worker's rows, in the order of
    ``tracks.worker_rows(worker)``} (see :func:`truth_for_workers`). The region of a joint is
    that of its ``lens_angle_deg``.
    """
    settings = settings or ReconSettings()
    errs, regs = [], []
    for w, gt in truth.items():
        r = tracks.worker_rows(w)
        X = r.points_world if source == "final" else r.raw_points_world
        e = np.linalg.norm(X - gt, axis=-1)
        errs.append(e.reshape(-1))
        regs.append(lens_region(r.lens_angle_deg, settings.lens_region_limits_deg).reshape(-1))
    e = np.concatenate(errs) if errs else np.zeros(0)
    g = np.concatenate(regs) if regs else np.zeros(0, np.int8)
    out = {"all": _error_stats("all", e)}
    for k, region in enumerate(REGIONS):
        out[region] = _error_stats(region, e[g == k])
    return out


def _error_stats(region: str, e: np.ndarray) -> RegionError:
    v = e[np.isfinite(e)]
    if not len(v):
        nan = float("nan")
        return RegionError(region, 0, nan, nan, nan, nan)
    return RegionError(
        region,
        len(v),
        float(v.mean()),
        float(np.median(v)),
        float(np.percentile(v, 95)),
        float(np.sqrt(np.mean(v * v))),
    )


def _frame_matches(
    tracks: TrackFrames, truth_points: np.ndarray, truth_frames: np.ndarray, max_distance_m: float
) -> Iterator[tuple[int, list[tuple[int, int]]]]:
    """Per frame: LSA of workers to ground-truth people by body-centre distance.

    Yields (frame, list of (worker, person)). truth_points: (F, P, 33, 3) at truth_frames (F,).
    """
    centres_w = body_centres(np.where(np.isfinite(tracks.points_world), tracks.points_world, tracks.raw_points_world))
    gt_c = body_centres(truth_points)  # (F, P, 3)
    index = {int(f): i for i, f in enumerate(truth_frames)}
    order = np.argsort(tracks.frame, kind="stable")
    frames = tracks.frame[order]
    bounds = np.flatnonzero(np.diff(frames)) + 1
    for rows in np.split(order, bounds):
        if not len(rows):
            continue
        f = int(tracks.frame[rows[0]])
        if f not in index:
            continue
        c = centres_w[rows]
        g = gt_c[index[f]]
        d = np.linalg.norm(c[:, None, :] - g[None, :, :], axis=-1)
        d = np.where(np.isfinite(d) & (d <= max_distance_m), d, np.inf)
        if not np.isfinite(d).any():
            yield f, []
            continue
        ri, ci = linear_sum_assignment(np.where(np.isfinite(d), d, 1e9))
        yield f, [(int(tracks.worker[rows[a]]), int(b)) for a, b in zip(ri, ci) if np.isfinite(d[a, b])]


def match_workers(
    tracks: TrackFrames, truth_points: np.ndarray, truth_frames: np.ndarray | None = None, max_distance_m: float = 0.5
) -> dict[int, int]:
    """{worker number: ground-truth person index} by majority of per-frame matches."""
    truth_frames = np.arange(len(truth_points)) if truth_frames is None else np.asarray(truth_frames)
    votes: dict[tuple[int, int], int] = {}
    for _, pairs in _frame_matches(tracks, truth_points, truth_frames, max_distance_m):
        for w, p in pairs:
            votes[(w, p)] = votes.get((w, p), 0) + 1
    out: dict[int, int] = {}
    for (w, p), n in sorted(votes.items(), key=lambda kv: -kv[1]):
        if w not in out:
            out[w] = p
    return out


def identity_switches(
    tracks: TrackFrames,
    truth_points: np.ndarray,
    truth_frames: np.ndarray | None = None,
    max_distance_m: float = 0.5,
    min_frames: int = 1,
) -> int:
    """How many times a ground-truth person's matched worker id changes to a different id
    (frames where the person is not matched do not count). min_frames = 1 is the CLEAR-MOT
    notion of an ID switch (every change counts, also a flicker of one frame when two people
    pass each other); with min_frames = k a change counts only when the new id then holds for
    at least k matched frames (sustained swaps)."""
    truth_frames = np.arange(len(truth_points)) if truth_frames is None else np.asarray(truth_frames)
    seq: dict[int, list[int]] = {}
    for _, pairs in _frame_matches(tracks, truth_points, truth_frames, max_distance_m):
        for w, p in pairs:
            seq.setdefault(p, []).append(w)
    switches = 0
    for ids in seq.values():
        # Runs of equal ids; a run shorter than min_frames is ignored (merged into its context).
        runs: list[list[int]] = []  # [id, frames]
        for w in ids:
            if runs and runs[-1][0] == w:
                runs[-1][1] += 1
            else:
                runs.append([w, 1])
        kept = [r[0] for r in runs if r[1] >= min_frames]
        switches += sum(1 for a, b in zip(kept[:-1], kept[1:]) if a != b)
    return switches


def truth_for_workers(
    tracks: TrackFrames, truth_points: np.ndarray, mapping: dict[int, int], truth_frames: np.ndarray | None = None
) -> dict[int, np.ndarray]:
    """{worker: (n_w, 33, 3) ground truth of its rows} for the workers in ``mapping``."""
    truth_frames = np.arange(len(truth_points)) if truth_frames is None else np.asarray(truth_frames)
    index = np.full(int(truth_frames.max()) + 1 if len(truth_frames) else 0, -1, np.int64)
    index[truth_frames] = np.arange(len(truth_frames))
    out = {}
    for w, p in mapping.items():
        r = tracks.worker_rows(w)
        k = index[r.frame]
        gt = np.full((len(r), NUM_JOINTS, 3), np.nan)
        ok = k >= 0
        gt[ok] = truth_points[k[ok], p]
        out[w] = gt
    return out
