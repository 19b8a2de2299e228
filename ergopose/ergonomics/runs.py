"""Runs (holds) of an integer-coded series over a shift taken in chunks: the frames and holds per
value, the longest hold, the holds longer than a static hold time and the worst episodes.

Every frame stands for one frame period, so a run lasts from its first to its last frame plus one
period; frames further apart than the largest gap (tracking lost) end a run. A run still open at
the end of a chunk is carried into the next one, so chunks give exactly the answer of the whole
series. Used by ergopose.ergonomics.aggregate (score columns) and ergopose.ergonomics.exposure
(zones of the exposure standards).
"""

from __future__ import annotations

import numpy as np


class Runs:
    """Runs (holds) of an integer-coded series across chunks; -1 codes a missing frame."""

    def __init__(self, period_s: float, max_gap_s: float, static_s: float | None = None, top: int = 0):
        self.period = period_s
        self.max_gap = max_gap_s
        self.static_s = static_s
        self.frames: dict[int, int] = {}
        self.holds: dict[int, int] = {}
        self.longest: dict[int, tuple[float, float]] = {}  # value -> (duration, -start) for max
        self.static_time: dict[int, int] = {}  # frames inside static holds
        self.static_holds: dict[int, int] = {}
        self.top = top
        # episodes: (-level, -duration, start, end, peak)
        self.best: list[tuple[int, float, float, float, int | None]] = []
        self.open: tuple[int, float, float, int, float] | None = None  # value, start, last, frames, peak

    def add(self, t: np.ndarray, codes: np.ndarray, peaks: np.ndarray | None = None) -> None:
        n = codes.size
        if n == 0:
            return
        new = np.ones(n, dtype=bool)
        new[1:] = (codes[1:] != codes[:-1]) | (np.diff(t) > self.max_gap)
        first = np.flatnonzero(new)
        last = np.append(first[1:] - 1, n - 1)
        vals = codes[first]
        starts = t[first]
        ends = t[last]
        counts = last - first + 1
        if peaks is not None:
            pk = np.maximum.reduceat(np.where(np.isnan(peaks), -np.inf, peaks), first)
        else:
            pk = np.full(first.size, -np.inf)
        # join the run left open by the previous chunk
        if self.open is not None:
            ov, ostart, olast, oframes, opeak = self.open
            if ov == vals[0] and t[0] - olast <= self.max_gap:
                starts[0] = ostart
                counts[0] += oframes
                pk[0] = max(pk[0], opeak)
            else:
                self._close(
                    np.array([ov]), np.array([ostart]), np.array([olast]), np.array([oframes]), np.array([opeak])
                )
        self._close(vals[:-1], starts[:-1], ends[:-1], counts[:-1], pk[:-1])
        self.open = (int(vals[-1]), float(starts[-1]), float(ends[-1]), int(counts[-1]), float(pk[-1]))

    def _close(
        self, vals: np.ndarray, starts: np.ndarray, ends: np.ndarray, counts: np.ndarray, peaks: np.ndarray
    ) -> None:
        if vals.size == 0:
            return
        dur = ends - starts + self.period
        for v in np.unique(vals):
            sel = vals == v
            v = int(v)
            self.frames[v] = self.frames.get(v, 0) + int(counts[sel].sum())
            self.holds[v] = self.holds.get(v, 0) + int(sel.sum())
            d, s = dur[sel], starts[sel]
            k = int(np.argmax(d))  # first of the longest: earliest start among ties
            cand = (float(d[k]), -float(s[k]))
            if v not in self.longest or cand > self.longest[v]:
                self.longest[v] = cand
            if self.static_s is not None:
                st = d > self.static_s
                self.static_time[v] = self.static_time.get(v, 0) + int(counts[sel][st].sum())  # frames
                self.static_holds[v] = self.static_holds.get(v, 0) + int(st.sum())
        if self.top:
            keep = vals >= 0
            if keep.any():
                order = np.lexsort((starts[keep], -dur[keep], -vals[keep]))[: self.top]
                for i in order:
                    idx = np.flatnonzero(keep)[i]
                    pk = peaks[idx]
                    self.best.append(
                        (
                            -int(vals[idx]),
                            -float(dur[idx]),
                            float(starts[idx]),
                            float(ends[idx] + self.period),
                            None if np.isinf(pk) else int(pk),
                        )
                    )
                self.best.sort()
                del self.best[self.top :]

    def finish(self) -> None:
        if self.open is not None:
            v, s, last, frames, pk = self.open
            self.open = None
            self._close(np.array([v]), np.array([s]), np.array([last]), np.array([frames]), np.array([pk]))


def int_codes(x: np.ndarray) -> np.ndarray:
    """Float values (NaN = missing) as int64 codes, -1 = missing."""
    out = np.full(x.shape, -1, dtype=np.int64)
    ok = ~np.isnan(x)
    out[ok] = x[ok].astype(np.int64)
    return out


__all__ = ["Runs", "int_codes"]
