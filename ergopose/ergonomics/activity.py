"""Muscle use (RULA) and activity (REBA) from the time series of one worker.

Neither can be judged from one frame: "held > 1 min", "repeated 4 or more times a minute" and
"rapid large-range changes" are statements about time. This module turns the per-frame posture
into those yes/no inputs, with definitions a safety engineer can check by hand
(docs/scoring.md, section "Muscle use and activity"):

held (static)
    A body part is held while its posture band (the position score from its angle alone) stays
    the same over consecutive frames; a band change, a missing angle (NaN) or a gap between frames
    longer than ``max_gap_s`` ends the hold. The hold lasts from its first to its last frame plus
    one frame period (each frame stands for one period). Every frame of a hold that lasts longer
    than ``hold_s`` is static. Holds in the lowest-scoring (neutral) band can be left out.
repeated
    One action is one rise and fall of a joint angle by at least ``amplitude``: a local maximum
    of the angle whose topographic prominence is at least ``amplitude`` (it stands that far
    above the lowest angle on each side before the angle climbs higher again), looking at most
    ``window_s / 2`` to each side. Actions are counted in the window of ``window_s`` seconds
    centred on each frame (clipped at the ends of the recording). A gap of missing angles is
    bridged with the last measured angle, so no action is invented inside it.
rapid change
    A frame lies in a rapid change when, within some stretch of at most ``window_s`` seconds
    containing it, the angle spans more than ``change`` (the largest minus the smallest angle
    measured in the stretch).

All functions are vectorised (cumulative sums, searchsorted, a sparse table of window maxima,
scipy.signal.find_peaks) and take the frames of ONE worker in time order: ``time_s`` strictly
increasing. Angles are in radians.
"""

from __future__ import annotations

from typing import Literal, NamedTuple

import numpy as np
from scipy.ndimage import maximum_filter1d, minimum_filter1d
from scipy.signal import find_peaks

from ergopose.arrays import BoolArray, FloatArray, IntArray
from ergopose.errors import InputError


def check_time(time_s: np.ndarray, field: str = "time_s") -> np.ndarray:
    """Return time as float64 after checking it is finite and strictly increasing."""
    t = np.asarray(time_s, dtype=np.float64)
    if t.ndim != 1:
        raise InputError("expected one time per frame", field=field)
    bad = ~np.isfinite(t)
    if bad.any():
        raise InputError(f"row {int(np.flatnonzero(bad)[0]) + 1}: the time is missing or not finite", field=field)
    if t.size > 1:
        d = np.diff(t)
        if np.any(d <= 0):
            i = int(np.flatnonzero(d <= 0)[0])
            raise InputError(
                f"row {i + 2}: time {t[i + 1]:g} s does not come after {t[i]:g} s "
                "(frames of one worker must be in time order, without repeats)",
                field=field,
            )
    return t


def frame_period(time_s: np.ndarray) -> float:
    """The typical time between frames (median of the differences); 0 for fewer than 2 frames."""
    t = np.asarray(time_s, dtype=np.float64)
    if t.size < 2:
        return 0.0
    return float(np.median(np.diff(t)))


def runs(time_s: np.ndarray, codes: np.ndarray, max_gap_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split frames into runs of an unchanged value.

    codes: float array (NaN = unknown; every unknown frame is a run of its own).
    Returns (run_id per frame, first frame index per run, last frame index per run).
    A run ends where the value changes, at an unknown frame, or at a gap > max_gap_s.
    """
    t = np.asarray(time_s, dtype=np.float64)
    c = np.asarray(codes, dtype=np.float64)
    n = c.size
    if n == 0:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty, empty
    new = np.ones(n, dtype=bool)
    if n > 1:
        same = c[1:] == c[:-1]  # False where either is NaN
        new[1:] = ~same | (np.diff(t) > max_gap_s)
    run_id = np.cumsum(new) - 1
    first = np.flatnonzero(new)
    last = np.empty_like(first)
    last[:-1] = first[1:] - 1
    last[-1] = n - 1
    return run_id, first, last


def run_durations(time_s: np.ndarray, first: np.ndarray, last: np.ndarray, period_s: float) -> FloatArray:
    """Duration of each run: last minus first timestamp plus one frame period."""
    t = np.asarray(time_s, dtype=np.float64)
    durations: FloatArray = t[last] - t[first] + period_s
    return durations


def held(
    time_s: np.ndarray,
    band: np.ndarray,
    hold_s: float,
    *,
    max_gap_s: float,
    neutral: float | None = None,
    period_s: float | None = None,
) -> BoolArray:
    """True for every frame of a hold (unchanged band) lasting longer than ``hold_s``.

    neutral: a band value whose holds do not count (the lowest-scoring band), or None.
    """
    t = np.asarray(time_s, dtype=np.float64)
    b = np.asarray(band, dtype=np.float64)
    if b.size == 0:
        return np.zeros(0, dtype=bool)
    period = frame_period(t) if period_s is None else period_s
    run_id, first, last = runs(t, b, max_gap_s)
    long_run = run_durations(t, first, last, period) > hold_s
    long_run &= ~np.isnan(b[first])
    if neutral is not None:
        long_run &= b[first] != neutral
    in_hold: BoolArray = long_run[run_id]
    return in_hold


def repetition_events(
    time_s: np.ndarray, angle: np.ndarray, amplitude: float, window_s: float, period_s: float | None = None
) -> np.ndarray:
    """True at the frame of each action (a peak of the angle with prominence >= amplitude)."""
    t = np.asarray(time_s, dtype=np.float64)
    x = np.asarray(angle, dtype=np.float64)
    events = np.zeros(x.size, dtype=bool)
    valid = ~np.isnan(x)
    if valid.sum() < 3:
        return events
    # bridge gaps with the last measured angle (and the first one before it): flat, so no new peaks
    idx = np.where(valid, np.arange(x.size), 0)
    np.maximum.accumulate(idx, out=idx)
    first_valid = int(np.argmax(valid))
    idx[:first_valid] = first_valid
    filled = x[idx]
    period = frame_period(t) if period_s is None else period_s
    half = int(np.ceil(0.5 * window_s / period)) if period > 0 else x.size
    wlen = 2 * half + 1
    peaks, _ = find_peaks(filled, prominence=amplitude, wlen=wlen if wlen >= 3 else None)
    # a flat bridge over a gap may sit at a peak: find_peaks reports its middle; move it to a measured frame
    peaks = idx[peaks]
    events[peaks] = True
    return events


class _Windows(NamedTuple):
    """Trailing windows of one length: first frame, reach (see rapid_change), the sparse table."""

    start: np.ndarray
    reach: np.ndarray
    regular: bool
    width: int
    # (start of the second half-window, frames grouped by table level, top level); None if regular
    sparse: tuple[np.ndarray, list[tuple[np.intp, np.ndarray]], int] | None


class Timeline:
    """Window bounds of one worker's frames, computed once and shared by every body part.

    time_s: strictly increasing (see :func:`check_time`).
    """

    def __init__(self, time_s: np.ndarray):
        self.time_s = np.asarray(time_s, dtype=np.float64)
        self.n = self.time_s.size
        self.period_s = frame_period(self.time_s)
        self._cache: dict[tuple[float, str], np.ndarray] = {}
        self._windows: dict[float, _Windows] = {}

    def searchsorted(self, offset_s: float, side: Literal["left", "right"]) -> np.ndarray:
        key = (offset_s, side)
        if key not in self._cache:
            self._cache[key] = np.searchsorted(self.time_s, self.time_s + offset_s, side=side)
        return self._cache[key]

    def count_centred(self, events: np.ndarray, window_s: float) -> IntArray:
        """Number of events within [t - window_s/2, t + window_s/2) around each frame."""
        lo = self.searchsorted(-0.5 * window_s, "left")
        hi = self.searchsorted(0.5 * window_s, "left")
        c = np.concatenate(([0], np.cumsum(np.asarray(events, dtype=np.int64))))
        counts: IntArray = c[hi] - c[lo]
        return counts

    def _sparse(self, window_s: float) -> _Windows:
        """Trailing windows [start[i], i] of frames at most window_s (+1 ns for rounding) before i."""
        key = window_s
        if key not in self._windows:
            n = self.n
            idx = np.arange(n)
            start = np.searchsorted(self.time_s, self.time_s - (window_s + 1e-9), side="left")
            length = idx - start + 1
            width = int(length.max()) if n else 1
            # regular frames (every window holds the same number of frames, fewer only at the start):
            # running max/min filters give the same windows in O(n)
            regular = bool(np.array_equal(length, np.minimum(idx + 1, width)))
            if regular:
                reach = np.minimum(idx + width, n)
                sparse: tuple[np.ndarray, list[tuple[np.intp, np.ndarray]], int] | None = None
            else:
                lut = np.zeros(width + 1, dtype=np.intp)
                lut[1:] = np.floor(np.log2(np.arange(1, width + 1))).astype(np.intp)
                level = lut[length]
                hi_start = idx - (np.intp(1) << level) + 1
                groups = [(lv, np.flatnonzero(level == lv)) for lv in np.flatnonzero(np.bincount(level))]
                reach = np.searchsorted(start, idx, side="right")
                sparse = (hi_start, groups, int(lut[width]))
            self._windows[key] = _Windows(start, reach, regular, width, sparse)
        return self._windows[key]

    def window_span(self, x: np.ndarray, window_s: float) -> FloatArray:
        """max - min of x over the frames within window_s before each frame (NaN ignored)."""
        start, _, regular, width, sparse = self._sparse(window_s)
        x = np.asarray(x, dtype=np.float64)
        if regular:
            # trailing window [i - width + 1, i]; 'nearest' repeats frame 0, which is inside the window
            nan = np.isnan(x)
            origin = (width - 1) // 2
            wmax = maximum_filter1d(np.where(nan, -np.inf, x), width, mode="nearest", origin=origin)
            wmin = minimum_filter1d(np.where(nan, np.inf, x), width, mode="nearest", origin=origin)
            with np.errstate(invalid="ignore"):
                span: FloatArray = wmax - wmin
            span[np.isinf(wmax)] = np.nan  # no measured angle in the window
            return span
        assert sparse is not None  # built whenever the frames are not regular
        hi_start, groups, top = sparse
        lmax, lmin = [x], [x]
        for k in range(1, top + 1):
            step = 1 << (k - 1)
            pmax, pmin = lmax[-1], lmin[-1]
            nmax, nmin = pmax.copy(), pmin.copy()
            nmax[:-step] = np.fmax(pmax[:-step], pmax[step:])
            nmin[:-step] = np.fmin(pmin[:-step], pmin[step:])
            lmax.append(nmax)
            lmin.append(nmin)
        span = np.empty(self.n)
        for lv, sel in groups:
            if sel.size == self.n:
                a, b = start, hi_start
                span = np.fmax(lmax[lv][a], lmax[lv][b]) - np.fmin(lmin[lv][a], lmin[lv][b])
            else:
                a, b = start[sel], hi_start[sel]
                span[sel] = np.fmax(lmax[lv][a], lmax[lv][b]) - np.fmin(lmin[lv][a], lmin[lv][b])
        return span

    def rapid_change(self, angles: list[np.ndarray], change: float, window_s: float) -> BoolArray:
        """True for every frame inside a stretch of <= window_s over which any angle spans > change."""
        if self.n == 0:
            return np.zeros(0, dtype=bool)
        ends = np.zeros(self.n, dtype=bool)
        with np.errstate(invalid="ignore"):
            for x in angles:
                ends |= self.window_span(x, window_s) > change  # the stretch [start[j], j] qualifies
        # frame i lies in a qualifying stretch ending at some j with start[j] <= i <= j; start is
        # non-decreasing, so: a qualifying j in [i, reach[i]) where reach[i] = first j with start[j] > i
        reach = self._sparse(window_s)[1]
        cq = np.concatenate(([0], np.cumsum(ends)))
        rapid: BoolArray = (cq[reach] - cq[:-1]) > 0
        return rapid


def count_in_window(time_s: np.ndarray, events: np.ndarray, window_s: float) -> np.ndarray:
    """Number of events within [t - window_s/2, t + window_s/2) around each frame."""
    return Timeline(time_s).count_centred(events, window_s)


def rapid_change(time_s: np.ndarray, angle: np.ndarray, change: float, window_s: float) -> np.ndarray:
    """True for every frame inside a stretch of <= window_s seconds over which the angle spans > change."""
    return Timeline(time_s).rapid_change([angle], change, window_s)


__all__ = [
    "check_time",
    "frame_period",
    "runs",
    "run_durations",
    "held",
    "repetition_events",
    "count_in_window",
    "rapid_change",
    "Timeline",
]
