"""A followed worker who turns out to wear another worker's clothes (ergopose.recon.tracking,
step 8 of its docstring): a confirmed track whose clothing colour over the last
``relink_window_s`` matches a worker who is not being followed, and clearly not the worker
its identity says, hands its person on to that identity.

Why: a track's person is decided once, when the track begins (track_identities.resolve) or when a
contact is resolved (track_contacts.resolve_group), and a decision was never revisited. With the
pose network's keypoints the triangulated centres are noisy (about 0.2 m) and a worker can be
missed for a frame; a track then takes a person passing within its gate, or a new track is given
the wrong lost identity because its own was still held by another track. Every later decision
built on the wrong one (the lost identities were the wrong ones), so one error spread over
minutes: on two simulated 10-minute sessions with four workers, 18 and 29 % of the two-camera
rows followed another worker than the one their identity followed most. The colour of the
clothes tells the workers apart over a few seconds far better than in one frame (a 3 s mean lies
within 12 of its worker's mean in 95 % of the windows, the workers' means 18-38 apart,
ergopose.pose.appearance units): so the colour seen lately is compared with the identities'
colours, and a track that clearly wears a lost identity's colours takes that identity from the
next frame on. The rows before stay with the identity they had (they are final once handed on).

The test mirrors the relinking's colour rule (track_identities.by_colour): the recent colour
within APPEARANCE_SAME of the lost identity's, and APPEARANCE_MARGIN closer to it than to the
track's own identity's.
"""

from __future__ import annotations

import numpy as np

from ergopose.pose.appearance import appearance_distance
from ergopose.recon.track_records import Track, TrackEnd, TrackerState, continuation
from ergopose.records import APPEARANCE_DIMS
from ergopose.recon.track_signatures import APPEARANCE_MARGIN, APPEARANCE_SAME

#: A track's recent colour is known once rows worth this many seconds of frames (12 rows at
#: 12 fps, 60 at 60 fps) in the window gave a colour for each part that is compared: the mean's
#: noise then does not depend on the frame rate.
RECENT_MIN_S = 1.0


def recent_min_rows(fps: float) -> int:
    """Rows with a colour a recent mean needs at ``fps`` (RECENT_MIN_S worth of frames)."""
    return max(1, int(round(RECENT_MIN_S * fps)))


def note_look(t: Track, f: int, look: np.ndarray, window_frames: int) -> None:
    """Keep a track's colours of the last ``window_frames`` frames (rows with no colour are
    skipped)."""
    if np.isfinite(look).any():
        t.recent_frames.append(f)
        t.recent_looks.append(np.asarray(look, dtype=np.float64))
    first = f - window_frames
    drop = 0
    while drop < len(t.recent_frames) and t.recent_frames[drop] <= first:
        drop += 1
    if drop:
        del t.recent_frames[:drop]
        del t.recent_looks[:drop]


def recent_look(t: Track, min_rows: int) -> np.ndarray:
    """(APPEARANCE_DIMS,) mean colour of the track's recent rows; NaN where fewer than
    ``min_rows`` gave it."""
    if len(t.recent_looks) < min_rows:
        return np.full(APPEARANCE_DIMS, np.nan)
    a = np.array(t.recent_looks)
    known = np.isfinite(a)
    count = known.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(known, a, 0.0).sum(axis=0) / np.maximum(count, 1)
    out: np.ndarray = np.where(count >= min_rows, mean, np.nan)
    return out


def better_identity(state: TrackerState, t: Track, f: int) -> int | None:
    """The identity a confirmed track's recent colour says its person is, if it is not the
    track's own and no track has seen that identity's person since relink_window_s ago (a lost
    or coasting worker); None when the colours do not say so clearly."""
    if t.identity is None or t.group is not None:
        return None
    look = recent_look(t, recent_min_rows(state.fps))
    if not np.isfinite(look).any():
        return None
    own = float(appearance_distance(look, state.identities[t.identity].look.mean()))
    if not np.isfinite(own) or own <= APPEARANCE_MARGIN:
        return None
    reserved = state.reserved()
    live = {x.id: x for x in state.tracks}
    best, best_d = None, np.inf
    for ident in state.identities.values():
        if ident.number == t.identity or ident.number in reserved:
            continue
        d = float(appearance_distance(look, ident.look.mean()))
        if not np.isfinite(d) or d > APPEARANCE_SAME or own - d < APPEARANCE_MARGIN or d >= best_d:
            continue
        if ident.track is not None:
            other = live.get(ident.track)
            if other is not None and other.last_3d_frame >= f - state.window_frames:
                continue  # followed now: this track's colours alone do not take its person
        best, best_d = ident.number, d
    return best


def hand_on(
    state: TrackerState, t: Track, number: int, f: int, resolved: dict[int, int | None], ended: list[TrackEnd]
) -> Track:
    """End track ``t`` at frame f and carry its person on from frame f + 1 in a new track with
    identity ``number`` (a coasting track of that identity ends). Returns the new track."""
    ident = state.identities[number]
    live = {x.id: x for x in state.tracks}
    gone = [t]
    if ident.track is not None and ident.track in live:
        gone.append(live[ident.track])
    for old in gone:
        state.flush(old)
        state.release(old)
        ended.append(TrackEnd(old.id, old.first_frame, old.last_frame, old.identity))
    new = continuation(t, state.next_track, f, number)
    new.hist, new.look = ident.hist, ident.look
    state.next_track += 1
    ident.track = new.id
    resolved[new.id] = number
    ids = {x.id for x in gone}
    state.tracks = [x for x in state.tracks if x.id not in ids] + [new]
    return new
