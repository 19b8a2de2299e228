"""Who a new track is (ergopose.recon.tracking, step 6 of its docstring): a tentative track is
given the identity of a worker lost earlier, by clothing colour where known, else by its
body-measurement signature, or a new identity (docs/reconstruction.md, 3. Identities)."""

from __future__ import annotations

import numpy as np

from ergopose.pose.appearance import appearance_distance
from ergopose.recon.track_records import Candidate, Identity, Track, TrackEnd, TrackerState
from ergopose.recon.track_signatures import (
    APPEARANCE_MARGIN,
    APPEARANCE_NEW,
    APPEARANCE_SAME,
    LimbHistogram,
    signature_distance,
)

#: A new track fitting (signature within relink_max_signature_m) exactly one identity lost at
#: most this long before it began takes that identity without the margin test: a worker
#: re-appearing after a short occlusion is the worker who just vanished there, even when an
#: older identity happens to have a similar signature.
RECENT_GAP_S = 10.0


def by_colour(cands: list[Candidate], colours: list[float]) -> tuple[Identity | None, bool]:
    """What the clothes say about a new track: (the candidate identity whose colour is within
    APPEARANCE_SAME and APPEARANCE_MARGIN closer than every other candidate's, or None;
    whether it is someone new: further than APPEARANCE_NEW from every identity, all known)."""
    known = sorted((c for c in cands if np.isfinite(c[3])), key=lambda c: (c[3], c[1].number))
    if known:
        second = known[1][3] if len(known) > 1 else np.inf
        if known[0][3] <= APPEARANCE_SAME and second - known[0][3] >= APPEARANCE_MARGIN:
            return known[0][1], False
    new = bool(colours) and all(np.isfinite(c) and c > APPEARANCE_NEW for c in colours)
    return None, new


def resolve(
    state: TrackerState, t: Track, resolved: dict[int, int | None], ended: list[TrackEnd], final: bool = False
) -> bool:
    """Give a tentative track its identity (see the tracker's docstring). Returns False (and
    leaves it tentative) while an identity it could be is waiting for a contact group's
    decision, unless ``final`` (the track ends): then those identities are left out."""
    s = state.settings
    state.flush(t)
    mine = t.hist.medians()
    mine_look = t.look.mean()
    live = {x.id: x for x in state.tracks}
    reserved = state.reserved()
    cands: list[Candidate] = []
    colours = []  # clothing-colour distance to every identity it could be or is followed now
    for ident in state.identities.values():
        if ident.number in reserved:
            if not final and ident.track is None and ident.last_frame < t.first_frame:
                return False
            continue
        colour = float(appearance_distance(mine_look, ident.look.mean()))
        colours.append(colour)
        if ident.track is not None:
            other = live.get(ident.track)
            if other is None or other.last_3d_frame >= t.first_frame:
                continue  # being followed right now (seen together with the new track)
            # Coasting, or kept by one camera's rays only, since before the new track began:
            # the new track may be the same person, seen by two cameras again.
            state.flush(other)
            last_frame, last_pos = other.last_3d_frame, other.pos
        else:
            last_frame, last_pos = ident.last_frame, ident.last_pos
        if last_frame >= t.first_frame:
            continue
        gap_s = (t.first_frame - last_frame) / state.fps
        reach = s.relink_max_speed_m_s * gap_s + s.track_gate_m
        if np.linalg.norm((t.first_pos - last_pos)[:2]) > reach:
            continue
        cands.append((signature_distance(mine, ident.hist.medians()), ident, gap_s, colour))
    choice, someone_new = by_colour(cands, colours)
    valid = sorted(
        [c for c in cands if np.isfinite(c[0]) and c[0] <= s.relink_max_signature_m], key=lambda c: (c[0], c[1].number)
    )
    recent = [c for c in valid if c[2] <= RECENT_GAP_S]
    if choice is not None or someone_new:
        pass  # the clothes decided
    elif len(cands) == 1 and not np.isfinite(cands[0][0]):
        choice = cands[0][1]  # the only identity that could be here; too little data to compare
    elif len(recent) == 1:
        choice = recent[0][1]  # the only fitting identity lost moments ago: the same person
    else:
        if valid:
            others = [c[0] for c in cands if c[1] is not valid[0][1] and np.isfinite(c[0])]
            if not others or min(others) - valid[0][0] >= s.relink_margin_m:
                choice = valid[0][1]
    if choice is None and cands and s.expected_workers and len(state.identities) >= s.expected_workers:
        # Every worker of the area has an identity: the track is one of those who could have
        # walked here, whatever the (noisy) signatures say.
        choice = min(
            cands,
            key=lambda c: (
                c[3] if np.isfinite(c[3]) else np.inf,
                c[0] if np.isfinite(c[0]) else np.inf,
                c[2],
                c[1].number,
            ),
        )[1]
    if choice is None:
        choice = Identity(state.next_identity, LimbHistogram(), t.last_frame, t.pos.copy(), None)
        state.identities[choice.number] = choice
        state.next_identity += 1
    elif choice.track is not None:
        # The identity's coasting track ends here: the new track is the same person.
        old = live[choice.track]
        state.tracks = [x for x in state.tracks if x.id != old.id]
        state.flush(old)
        ended.append(TrackEnd(old.id, old.first_frame, old.last_frame, old.identity))
    choice.hist.merge(t.hist)
    t.hist = choice.hist
    choice.look.merge(t.look)
    t.look = choice.look
    choice.track = t.id
    t.identity = choice.number
    resolved[t.id] = choice.number
    return True
