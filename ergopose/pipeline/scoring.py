"""Scoring a whole shift piece by piece, in memory that does not grow with the shift.

Joint angles, RULA and REBA need time windows: walking (1 s), rapid changes (1 s), holds
(> 60 s) and repetitions (60 s). :class:`WorkerScorer` takes one worker's rows of the tracks
table in frame order and scores them in blocks of ``block_frames`` frames on a fixed grid
(frame // block_frames). Each block is scored together with ``context_frames`` frames on both
sides, and only the block's own frames are kept. The context is longer than every window of
the settings (:func:`context_seconds`), so every kept frame is scored exactly as if the whole
shift had been scored at once:

- walking, rapid changes, repetition peaks and repetition counts look at most one window
  (plus the peak search's half window) away from the frame;
- a hold that reaches past the context has lasted at least the context inside it, which is
  longer than the hold limit, so the frame is held either way.

One case can differ: an angle missing for longer than the context is bridged with the last
measured angle, and inside a block that value is the first one measured after the gap. A
repetition peak right after such a gap can then move or vanish (tests/pipeline/
test_shift_scoring.py measures both on a simulated shift).

The grid is fixed by frame numbers, so the result does not depend on how the rows arrive:
a resumed assessment writes the same bytes as an uninterrupted one.

Each scored block goes to a :class:`BlockSink` (CSV files, the shift aggregation, the report's
timeline; see :mod:`ergopose.pipeline.score`).
"""

from __future__ import annotations

import math
from typing import Any, Callable, Protocol

import numpy as np
import pandas as pd

from ergopose.ergonomics.angles import shoulder_heights
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.recon.diagnostics import LimbStatsAccumulator, histogram_percentiles
from ergopose.recon.pipeline import TrackFrames
from ergopose.recon.settings import ReconSettings

#: Frames per block = BLOCK_SECONDS x fps.
BLOCK_SECONDS = 600.0


def context_seconds(scoring: ScoringSettings, walking_window_s: float = 1.0) -> float:
    """Seconds of context each block is scored with: the longest time window of the settings
    (hold limits, repetition window, rapid-change window, walking window) plus half of it (the
    repetition peak search looks half a window further) plus the gap that breaks a hold."""
    longest = max(
        scoring.rula_static_hold_s,
        scoring.reba_static_hold_s,
        scoring.repetition_window_s,
        scoring.rapid_change_window_s,
        walking_window_s,
    )
    return 1.5 * longest + scoring.max_gap_s + 1.0


class BlockSink(Protocol):
    def write(self, frames: pd.DataFrame, rows: TrackFrames) -> None:
        """frames: the scored frames of one block (score_rows columns); rows: the same frames'
        TrackFrames (points_world etc.), in the same order."""


class WorkerScorer:
    """One worker's rows of the tracks table in, scored blocks out (see the module docstring).

    score: callable(rows: TrackFrames) -> pd.DataFrame, one row per row of ``rows`` (e.g.
    :func:`ergopose.pipeline.score.score_rows` with the session and worker bound).
    """

    def __init__(
        self, score: Callable[[TrackFrames], pd.DataFrame], sink: BlockSink, block_frames: int, context_frames: int
    ) -> None:
        if block_frames < 1 or context_frames < 0:
            raise ValueError("block_frames must be >= 1 and context_frames >= 0")
        self.score = score
        self.sink = sink
        self.block = int(block_frames)
        self.context = int(context_frames)
        self._parts: list[TrackFrames] = []
        self.done_until = -(1 << 62)  # frames before this were written
        self.blocks = 0
        self.frames = 0

    def add(self, rows: TrackFrames) -> None:
        """The worker's next rows (frame order, after every row given before)."""
        if len(rows):
            self._parts.append(rows)

    def advance(self, frontier: int) -> None:
        """Every frame before ``frontier`` has been given: score the blocks that are complete."""
        self._run(frontier)

    def finish(self) -> None:
        """End of the shift: score what is left."""
        self._run(None)
        self._parts = []

    def _rows(self) -> TrackFrames | None:
        if len(self._parts) > 1:
            self._parts = [TrackFrames.concat(self._parts)]
        return self._parts[0] if self._parts else None

    def _run(self, frontier: int | None) -> None:
        while True:
            rows = self._rows()
            if rows is None:
                return
            later = np.flatnonzero(rows.frame >= self.done_until)
            if later.size == 0:
                return
            k = int(rows.frame[later[0]]) // self.block
            lo, hi = k * self.block, (k + 1) * self.block
            if frontier is not None and frontier < hi + self.context:
                return
            window = (rows.frame >= lo - self.context) & (rows.frame < hi + self.context)
            win = take_rows(rows, window)
            scored = self.score(win)
            core = (win.frame >= lo) & (win.frame < hi)
            self.sink.write(scored.loc[core].reset_index(drop=True), take_rows(win, core))
            self.blocks += 1
            self.frames += int(core.sum())
            self.done_until = hi
            self._parts = [take_rows(rows, rows.frame >= hi - self.context)]


#: The per-row arrays of a TrackFrames that scoring reads (score_rows and the block sinks).
SCORED_FIELDS = ("worker", "frame", "time_s", "points_world", "std_world", "views", "inferred", "limited")


def scoring_rows(rows: TrackFrames) -> TrackFrames:
    """``rows`` with only the arrays scoring reads (:data:`SCORED_FIELDS`); the others (raw points,
    2D confidence, reprojection errors, lens angles, gap and gate flags) become empty (n, 0)
    arrays. A :class:`WorkerScorer` holds a block and its context of each worker's rows: this
    halves them (3.3 -> 1.7 kB per row)."""
    n = len(rows)
    kept: dict[str, Any] = {
        k: (v if k in SCORED_FIELDS or not isinstance(v, np.ndarray) else np.empty((n, 0), v.dtype))
        for k, v in rows.__dict__.items()
    }
    return TrackFrames(**kept)


def take_rows(rows: TrackFrames, mask: np.ndarray) -> TrackFrames:
    """The rows of a TrackFrames where ``mask`` holds (its array fields indexed, the rest kept)."""
    fields: dict[str, Any] = {n: (v[mask] if isinstance(v, np.ndarray) else v) for n, v in rows.__dict__.items()}
    return TrackFrames(**fields)


class ShiftReferences:
    """What scoring needs from a worker's whole shift before the first block is scored, gathered
    while the tracks table is written (memory does not grow with the shift):

    - limb lengths (:class:`ergopose.recon.diagnostics.LimbStatsAccumulator`): the quality
      diagnostics and the medians of the reliability rule;
    - both shoulders' heights along the trunk axis (1 mm histogram): their median is the
      reference of shoulder elevation (:func:`ergopose.ergonomics.angles.shoulder_heights`).
    """

    BIN_M = 0.001
    BINS = 1500

    def __init__(self, recon_settings: ReconSettings | None = None) -> None:
        self.limbs = LimbStatsAccumulator(recon_settings, "final")
        self._shoulders: dict[int, np.ndarray] = {}

    def add(self, tracks: TrackFrames) -> None:
        """Rows of the tracks table (TrackFrames, any workers, any chunk)."""
        if len(tracks) == 0:
            return
        self.limbs.add(tracks)
        h = shoulder_heights(tracks.points_world)  # (n, 2)
        with np.errstate(invalid="ignore"):
            b = np.floor(h / self.BIN_M)
            ok = np.isfinite(b) & (b >= 0) & (b < self.BINS)
        for w in np.unique(tracks.worker):
            sel = (tracks.worker == w)[:, None] & ok
            counts = np.bincount(b[sel].astype(np.int64), minlength=self.BINS)
            if int(w) in self._shoulders:
                self._shoulders[int(w)] += counts
            else:
                self._shoulders[int(w)] = counts

    def shoulder_reference_m(self, worker: int) -> float:
        """Median shoulder height along the trunk over the shift (within 1 mm); NaN if never seen."""
        counts = self._shoulders.get(int(worker))
        if counts is None or counts.sum() == 0:
            return math.nan
        return float(histogram_percentiles(np.r_[counts, 0], (50,), bin_m=self.BIN_M)[0])

    def limb_medians_m(self, worker: int) -> np.ndarray:
        return self.limbs.medians(int(worker))


def block_sizes(scoring: ScoringSettings, fps: float, block_seconds: float = BLOCK_SECONDS) -> tuple[int, int]:
    """(block_frames, context_frames) for a frame rate and the scoring settings."""
    context = int(math.ceil(context_seconds(scoring) * fps))
    block = max(int(round(block_seconds * fps)), 1)
    return block, context
