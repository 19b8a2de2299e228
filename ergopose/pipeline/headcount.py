"""More people tracked than the area holds: which of them are most likely one worker.

The settings may say how many workers the area holds (``[reconstruction] expected_workers``).
When an assessment reports more people than that, some of them are most likely one worker whom
the tracker followed under two ids (a track lost and begun again where the tracker could not
tell that it was the same person), or a visitor. The tracker does not merge them on its own (a
visitor must not be merged into a worker, docs/reconstruction.md, "Identities"); this names the
likeliest pairs so that the safety engineer can check them and give both one name
(``ergopose workers --name``, docs/workers.md).

The likeliest pair: two ids of one worker are seldom followed at the same time, so the pair
followed together in the smallest share of the shorter one's frames is taken first (ties: the
closer statures, then tracker order); the two then count as one, and so on until as many are
left as the area holds. A pair followed together in more than :data:`MAX_TOGETHER` of the
shorter one's frames is never suggested: those are two people.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import pyarrow.compute as pc
import pyarrow.parquet as pq

from ergopose.pipeline.names import tracker_number
from ergopose.pipeline.window import Window
from ergopose.progress import ProgressCallback, warn
from ergopose.session import Session

#: Largest share of the shorter id's frames in which two ids may both be followed and still be
#: suggested as one worker.
MAX_TOGETHER = 0.5


@dataclass(frozen=True)
class SamePerson:
    """Two reported ids that are most likely one worker.

    first, second: the reported ids (first: the one of the two the tracker numbered first).
    together: frames in which both were followed. shorter: frames of the one followed less.
    """

    first: str
    second: str
    together: int
    shorter: int

    @property
    def together_pct(self) -> float:
        return 100.0 * self.together / self.shorter if self.shorter else 0.0

    def describe(self) -> str:
        return (
            f"{self.second} with {self.first} (followed at the same time in {self.together} of the "
            f"{self.shorter} frames of the shorter one, {self.together_pct:.0f} %)"
        )


@dataclass(frozen=True)
class Excess:
    """More people reported than the area holds: expected (the settings' ``expected_workers``),
    reported (the reported ids followed, in tracker order) and the pairs most likely one worker."""

    expected: int
    reported: tuple[str, ...]
    pairs: tuple[SamePerson, ...]

    def notice(self) -> str:
        """The report's notice (one sentence or two)."""
        return report_notice(self.expected, self.reported, self.pairs)


def frames_by_id(tracks_path: Path, members: Mapping[str, Sequence[str]]) -> dict[str, np.ndarray]:
    """{reported id: the sorted frames in which any of its tracked ids has a row} from the tracks
    table, read in batches (one joint's rows; every tracked frame has a row for every joint), so a
    whole shift's table is never in memory at once."""
    reported_of = {t: r for r, ids in members.items() for t in ids}
    seen: dict[str, np.ndarray] = {r: np.zeros(0, bool) for r in members}
    for batch in pq.ParquetFile(tracks_path).iter_batches(batch_size=1 << 20, columns=["worker", "frame", "joint"]):
        rows = batch.filter(pc.equal(batch.column("joint"), "left_hip"))
        if rows.num_rows == 0:
            continue
        worker = np.asarray(rows.column("worker").to_pylist(), dtype=str)
        frame = rows.column("frame").to_numpy().astype(np.int64)
        for tracked in np.unique(worker):
            reported = reported_of.get(str(tracked))
            if reported is None:
                continue
            f = frame[worker == tracked]
            mask = seen[reported]
            if len(mask) <= f.max():
                mask = np.concatenate([mask, np.zeros(int(f.max()) + 1 - len(mask), bool)])
            mask[f] = True
            seen[reported] = mask
    return {r: np.flatnonzero(m).astype(np.int64) for r, m in seen.items()}


def likely_same(
    frames: Mapping[str, np.ndarray], expected: int, statures: Mapping[str, float] | None = None
) -> tuple[SamePerson, ...]:
    """The pairs of reported ids most likely one worker (module docstring), in the order chosen.

    frames: {reported id: sorted frames in which it was followed}, in tracker order. expected:
    how many workers the area holds (0: unknown, nothing is suggested). statures: measured
    statures (m) per reported id, for ties."""
    statures = statures or {}
    groups: dict[str, np.ndarray] = {k: np.asarray(v, np.int64) for k, v in frames.items() if len(v)}
    order = {k: i for i, k in enumerate(frames)}
    pairs: list[SamePerson] = []
    while expected > 0 and len(groups) > expected:
        best: tuple[tuple[float, float, int, int], SamePerson] | None = None
        ids = sorted(groups, key=order.__getitem__)
        for i, a in enumerate(ids):
            for b in ids[i + 1 :]:
                together = int(np.intersect1d(groups[a], groups[b], assume_unique=True).size)
                shorter = min(len(groups[a]), len(groups[b]))
                if together > MAX_TOGETHER * shorter:
                    continue
                sa, sb = statures.get(a, math.nan), statures.get(b, math.nan)
                gap = abs(sa - sb) if math.isfinite(sa) and math.isfinite(sb) else math.inf
                key = (together / shorter, gap, order[a], order[b])
                if best is None or key < best[0]:
                    best = (key, SamePerson(first=a, second=b, together=together, shorter=shorter))
        if best is None:
            break
        pair = best[1]
        pairs.append(pair)
        groups[pair.first] = np.union1d(groups[pair.first], groups.pop(pair.second))
    return tuple(pairs)


def excess_message(
    session_path: Path, settings_name: str, expected: int, reported: Sequence[str], pairs: Sequence[SamePerson]
) -> str:
    """The warning for more reported people than the area holds."""
    text = (
        f"{settings_name}: [reconstruction] expected_workers = {expected}, but {len(reported)} people were "
        f"tracked ({', '.join(reported)}): some are most likely one worker followed under two ids, or a visitor"
    )
    if pairs:
        first = pairs[0]
        text += (
            "; the likeliest: "
            + "; ".join(p.describe() for p in pairs)
            + f"; if a pair is one worker, give both one name: 'ergopose workers --session {session_path} "
            + f"--name {first.first}=NAME --name {first.second}=NAME'"
        )
    else:
        text += "; no two of them were followed apart often enough to be one worker"
    return text


def report_notice(expected: int, reported: Sequence[str], pairs: Sequence[SamePerson]) -> str:
    """The report's notice for more reported workers than the area holds (one sentence or two)."""
    text = (
        f"the settings say the area holds {expected} worker{'s' if expected != 1 else ''}, but "
        f"{len(reported)} people are reported here ({', '.join(reported)}): some are most likely one worker "
        "followed under two ids, or a visitor."
    )
    if pairs:
        text += (
            " Most likely one worker: "
            + "; ".join(
                f"{p.first} and {p.second} (followed at the same time in {p.together_pct:.0f} % of the "
                "shorter one's frames)"
                for p in pairs
            )
            + ". If so, give both one name with 'ergopose workers --name' (docs/workers.md); until then "
            "each is reported as a worker of their own, with part of the shift."
        )
    return text


def check_headcount(
    session: Session,
    tracks_path: Path,
    expected: int,
    members: Mapping[str, Sequence[str]],
    statures: Mapping[str, float | None],
    window: Window | None,
    progress: ProgressCallback | None,
) -> Excess | None:
    """When more people are reported than ``expected`` (the settings' ``expected_workers``) says
    the area holds: a warning through ``progress`` naming the pairs most likely one worker, and
    the :class:`Excess` (None otherwise).

    members: {reported id: its tracked ids}. statures: {tracked id: measured stature (m) or None}.
    window: only the frames of this part of the day count (None: all)."""
    if not expected or len(members) <= expected:
        return None
    members = dict(sorted(members.items(), key=lambda kv: min(tracker_number(t) for t in kv[1])))
    frames = frames_by_id(tracks_path, members)
    if window is not None:
        frames = {r: f[window.mask(f, session.fps)] for r, f in frames.items()}
    frames = {r: f for r, f in frames.items() if len(f)}
    if len(frames) <= expected:
        return None
    reported_statures = {}
    for r, ids in members.items():
        known = [float(v) for t in ids if (v := statures.get(t)) is not None and math.isfinite(float(v))]
        if known:
            reported_statures[r] = float(np.mean(known))
    pairs = likely_same(frames, expected, reported_statures)
    warn(progress, excess_message(session.path, session.settings_path.name, expected, list(frames), pairs))
    return Excess(expected=expected, reported=tuple(frames), pairs=pairs)


__all__ = [
    "Excess",
    "check_headcount",
    "MAX_TOGETHER",
    "SamePerson",
    "excess_message",
    "frames_by_id",
    "likely_same",
    "report_notice",
]
