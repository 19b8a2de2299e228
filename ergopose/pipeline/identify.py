"""Which tracked person is which worker of the settings: matching by body height.

The tracker numbers the people it follows in order of appearance (worker_1, worker_2, ...). The
settings can give a worker's stature (``[workers.<id>] stature_m``); the tracker measures every
tracked person's stature from the medians of their limb lengths. A tracked person is given the
settings' id (and with it the worker's name, loads and periods) when

- the two statures differ by at most ``stature_tolerance_m``, and
- the matching is unambiguous: for every matched pair, the best matching that does not contain
  that pair costs at least ``stature_margin_m`` more in total (two workers of nearly the same
  height are not told apart by height; then nobody is named and the report says why).

The best matching minimises the sum of absolute stature differences (an optimal assignment).
Tracked people without a match keep their pseudonymous ids. Matching runs only when the settings
switch it on (``[identification] by_stature = true``): a wrong match would put one worker's
loads on another, and a stature measured from a noisy reconstruction can be several centimetres
off (docs/evaluation.md has the figures).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from ergopose.session import Session

_BIG = 1e6


@dataclass(frozen=True)
class Identity:
    """One tracked person matched to a worker of the settings.

    tracked_id: the tracker's id; worker_id: the settings' id; measured_m / given_m: statures.
    """

    tracked_id: str
    worker_id: str
    measured_m: float
    given_m: float


@dataclass(frozen=True)
class Identification:
    """The matching: matched people, and a sentence per decision that could not be made."""

    matches: tuple[Identity, ...]
    notes: tuple[str, ...]
    clashes: tuple[str, ...] = ()

    def rename(self, tracked_id: str) -> str:
        """The id a tracked person is reported under."""
        for m in self.matches:
            if m.tracked_id == tracked_id:
                return m.worker_id
        if tracked_id in self.clashes:
            return f"{tracked_id}_unmatched"
        return tracked_id

    def match_of(self, worker_id: str) -> Identity | None:
        for m in self.matches:
            if m.worker_id == worker_id:
                return m
        return None


def _best(cost: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    rows, cols = linear_sum_assignment(cost)
    return rows, cols, float(cost[rows, cols].sum())


def identify_by_stature(measured: dict[str, float], session: Session) -> Identification:
    """Match tracked people (``{tracked id: measured stature}``) to the workers with a given stature."""
    rules = session.identification
    workers = [w for w in session.workers if w.stature_m is not None]
    statures = [float(w.stature_m) for w in workers if w.stature_m is not None]
    tracked = [t for t, v in measured.items() if v is not None and math.isfinite(v)]
    if not workers:
        return Identification((), ())
    if not rules.by_stature:
        return Identification(
            (),
            (
                "the settings give statures, but matching tracked people by stature is off "
                "([identification] by_stature = false)",
            ),
        )
    if not tracked:
        return Identification((), ("no tracked person's stature could be measured, so nobody was identified",))
    diff = np.abs(np.array([[measured[t] - stature for stature in statures] for t in tracked]))
    cost = np.where(diff <= rules.stature_tolerance_m, diff, _BIG)
    rows, cols, total = _best(cost)
    matches, notes = [], []
    for r, c in zip(rows, cols):
        if cost[r, c] >= _BIG:
            continue
        alt = cost.copy()
        alt[r, c] = _BIG
        _, _, alt_total = _best(alt)
        t, w = tracked[r], workers[c]
        if alt_total - total < rules.stature_margin_m:
            notes.append(
                f"{t} (measured {measured[t]:.2f} m) could be {w.worker_id} (given {w.stature_m:.2f} m) "
                f"but another matching fits within {rules.stature_margin_m:.2f} m: not identified"
            )
            continue
        matches.append(Identity(t, w.worker_id, float(measured[t]), float(w.stature_m)))
    named = {m.worker_id for m in matches}
    for w in workers:
        if w.worker_id not in named and not any(w.worker_id in n for n in notes):
            notes.append(
                f"{w.worker_id} (given {w.stature_m:.2f} m): no tracked person within "
                f"{rules.stature_tolerance_m:.2f} m of that height"
            )
    taken = {m.tracked_id for m in matches}
    clash = [t for t in tracked if t in named and t not in taken]
    if clash:
        notes.append(
            f"settings ids {', '.join(clash)} are also pseudonyms of unmatched tracked people; "
            "those keep the pseudonym with the suffix '_unmatched'"
        )
    return Identification(tuple(matches), tuple(notes), tuple(clash))
