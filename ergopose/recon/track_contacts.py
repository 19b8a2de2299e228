"""Contacts between workers (ergopose.recon.tracking, step 7 of its docstring): confirmed tracks
that come too close to each other end, continuations carry on with the same identities
provisionally, and once the people have separated again the identities are confirmed or crossed
over by clothing colour, else by body-measurement signature (docs/reconstruction.md,
3. Identities)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from ergopose.pose.appearance import appearance_distance
from ergopose.recon.track_records import Track, TrackEnd, TrackerState, continuation
from ergopose.recon.track_signatures import APPEARANCE_APART, APPEARANCE_MARGIN, LimbHistogram, Look

#: A contact group waits at most this many relink windows for comparable limb data after the
#: people separated, and at most GROUP_MAX_WAIT_S in all (people working side by side).
GROUP_MAX_WAIT = 4
GROUP_MAX_WAIT_S = 60.0
#: A continuation is compared with the group's identities over at least this many limbs
#: known in it and in every identity. The gated triangulation gives the trunk's four limbs
#: (shoulder and hip width, the trunk's sides) in about half of the frames and the others
#: rarely (ORACLE, 2592 x 1944, 4 workers, 10 min: upper arms 5 %, thighs 2 %, shanks 0 %), so
#: the relinking's MIN_COMMON_LIMBS (6) left most contacts undecided, and a single limb
#: crossed two workers wrongly (docs/reconstruction.md, 3. Identities).
GROUP_MIN_LIMBS = 3


def group_costs(members: list[np.ndarray], identities: list[np.ndarray]) -> np.ndarray:
    """(M, I) RMS difference of limb medians between contact continuations and the group's
    identities, each row over the limbs known in that member and in every identity (so a row
    compares the identities on equal terms); NaN rows with fewer than GROUP_MIN_LIMBS such
    limbs (a single limb's median of a few seconds can be as far from its owner's as from
    another worker's)."""
    known_all = np.all([np.isfinite(i) for i in identities], axis=0)
    out = np.full((len(members), len(identities)), np.nan)
    for r, m in enumerate(members):
        ok = np.isfinite(m) & known_all
        if ok.sum() >= GROUP_MIN_LIMBS:
            out[r] = [float(np.sqrt(np.mean((m[ok] - i[ok]) ** 2))) for i in identities]
    return out


def group_identities(members: list[Track]) -> list[int]:
    """The identities of a contact group's continuations (every one has one: only confirmed
    tracks are split)."""
    out = [m.identity for m in members]
    assert all(k is not None for k in out)
    return [int(k) for k in out if k is not None]


def split_contacts(state: TrackerState, f: int, ended: list[TrackEnd], resolved: dict[int, int | None]) -> None:
    """Split confirmed tracks that come within contact_distance_m of each other.

    Two people this close (passing each other, or a simulated body passing through another)
    can swap tracks without any geometric sign. Each track of a contact group ends here and a
    continuation carries on with the same identity, *provisionally*: its rows wait, and its
    limb lengths are collected apart. Once the live continuations have relink_window_s of 3D
    data and comparable limbs (or after GROUP_MAX_WAIT windows), :func:`resolve_group`
    confirms the identities or crosses them over, if the body-measurement signatures say so
    by relink_margin_m (:func:`assign_group`: a continuation that ended unseen keeps its identity
    unless another continuation's measurements claim it).

    A provisional continuation that meets someone else before its group is decided (a third
    worker walking into two who just passed each other, or the two meeting again after they
    had separated) joins a new contact: its group is decided at once on what it has seen so
    far (kept unless the evidence is already clear), and all of that group's live
    continuations are split again with the others, so that the new group decides among every
    identity that could have been exchanged.
    """
    s = state.settings
    for t in state.tracks:
        if t.no_split_with:
            near = set()
            for o in state.tracks:
                if o.identity in t.no_split_with and np.linalg.norm((o.pos - t.pos)[:2]) < 1.5 * s.contact_distance_m:
                    near.add(o.identity)
            t.no_split_with = near
    # Only tracks seen in this frame: an extrapolated coasting track proves no contact.
    live = [t for t in state.tracks if t.identity is not None and t.last_update_frame == f]
    if len(live) < 2:
        return
    pos = np.array([t.pos[:2] for t in live])
    d = np.linalg.norm(pos[:, None] - pos[None], axis=-1)
    close = d < s.contact_distance_m
    np.fill_diagonal(close, False)
    if close.any() and APPEARANCE_APART > 0:
        # People in clearly different clothes are told apart frame by frame by the colour
        # term of the matching: no provisional split.
        colours = np.array([state.colour(t) for t in live])
        apart = appearance_distance(colours[:, None], colours[None]) >= APPEARANCE_APART
        close &= ~apart
    for a in range(len(live)):
        for b in range(len(live)):
            if not close[a, b]:
                continue
            ga, gb = live[a].group, live[b].group
            if live[b].identity in live[a].no_split_with:
                close[a, b] = False
            elif ga is not None and ga == gb and state.groups[ga]["separated"] is None:
                close[a, b] = False  # still together since their contact: the same contact
    if not close.any():
        return
    label = list(range(len(live)))

    def root(i: int) -> int:
        while label[i] != i:
            label[i] = label[label[i]]
            i = label[i]
        return i

    for a, b in zip(*np.nonzero(close)):
        label[root(a)] = root(b)
    # A pending group touched by the new contact takes all its live continuations into it.
    touched = {g for i in np.flatnonzero(close.any(axis=1)) if (g := live[i].group) is not None}
    for gid in touched:
        idx = [i for i in range(len(live)) if live[i].group == gid]
        for i in idx[1:]:
            label[root(i)] = root(idx[0])
    in_contact = close.any(axis=1)
    groups: dict[int, list[Track]] = {}
    for i in range(len(live)):
        if in_contact[i] or live[i].group in touched:
            groups.setdefault(root(i), []).append(live[i])
    for gid in sorted(touched):
        resolve_group(state, gid, resolved)
    gone = set()
    new_tracks = []
    for members in groups.values():
        gid = state.next_group
        state.next_group += 1
        conts = []
        for t in members:
            state.flush(t)
            ended.append(TrackEnd(t.id, t.first_frame, t.last_frame, t.identity))
            gone.add(t.id)
            c = continuation(t, state.next_track, f, t.identity, gid)
            state.next_track += 1
            assert t.identity is not None  # only tracks with an identity are split
            state.identities[t.identity].track = c.id
            conts.append(c)
        state.groups[gid] = {"members": conts, "start": f + 1, "separated": None}
        new_tracks += conts
    state.tracks = [t for t in state.tracks if t.id not in gone] + new_tracks


def live_members(state: TrackerState, gid: int) -> list[Track]:
    g = state.groups[gid]
    alive = {t.id for t in state.tracks}
    return [m for m in g["members"] if m.id in alive]


def watch_separation(state: TrackerState, f: int) -> None:
    """Note when the live continuations of each pending group are all apart (1.5 x
    contact_distance_m): from then on their limb lengths are collected apart from what was
    measured while they were together (that may belong to either)."""
    far = 1.5 * state.settings.contact_distance_m
    for gid, g in state.groups.items():
        if g["separated"] is not None:
            continue
        live = live_members(state, gid)
        if len(live) >= 2:
            pos = np.array([m.pos[:2] for m in live])
            d = np.linalg.norm(pos[:, None] - pos[None], axis=-1)
            np.fill_diagonal(d, np.inf)
            if d.min() < far:
                continue
        g["separated"] = f
        for m in g["members"]:
            state.flush(m)
            m.hist_before = m.hist
            m.hist = LimbHistogram()
            m.look_before = m.look
            m.look = Look()
            m.frames_3d = 0


def member_medians(state: TrackerState, m: Track) -> np.ndarray:
    """Limb medians of a continuation: since the separation, or (when that has no
    comparable data yet) everything since the contact."""
    state.flush(m)
    med = m.hist.medians()
    if np.isfinite(med).any() or m.hist_before is None:
        return med
    both = LimbHistogram()
    both.merge(m.hist)
    both.merge(m.hist_before)
    return both.medians()


def member_look(m: Track) -> np.ndarray:
    """Mean colour of a continuation: since the separation, else since the contact."""
    look = m.look.mean()
    if np.isfinite(look).any() or m.look_before is None:
        return look
    both = Look()
    both.merge(m.look)
    both.merge(m.look_before)
    return both.mean()


def group_colours(state: TrackerState, members: list[Track], idents: list[int]) -> np.ndarray:
    """(M, I) clothing-colour distance between contact continuations and the group's
    identities (NaN where either colour is unknown)."""
    looks = np.array([state.identities[k].look.mean() for k in idents])
    return np.array([appearance_distance(member_look(m), looks) for m in members]).reshape(len(members), len(idents))


def group_ready(state: TrackerState, gid: int, f: int) -> bool:
    """Decide a contact group once its people have separated and every live continuation
    has relink_window_s of 3D data since, with clothing colours or signatures that can be
    compared (GROUP_MIN_LIMBS limbs known in the continuation and in every identity of the
    group); or after GROUP_MAX_WAIT windows since the separation, GROUP_MAX_WAIT_S since the
    contact, or when no continuation is alive any more."""
    g = state.groups[gid]
    live = live_members(state, gid)
    if not live or (f - g["start"]) >= GROUP_MAX_WAIT_S * state.fps:
        return True
    if g["separated"] is None:
        return False
    if any(m.frames_3d < state.window_frames for m in live):
        return False
    if any(m.frames_3d >= GROUP_MAX_WAIT * state.window_frames for m in live):
        return True
    members = g["members"]
    rows = [members.index(m) for m in live]
    idents = group_identities(members)
    if np.isfinite(group_colours(state, members, idents)[rows]).all():
        return True  # the clothes decide (resolve_group)
    cost = group_costs(
        [member_medians(state, m) for m in members], [state.identities[k].hist.medians() for k in idents]
    )
    return bool(np.isfinite(cost[rows]).all(axis=1).all())


def assign_group(cost: np.ndarray, idents: list[int], margin: float) -> list[int]:
    """The final identities of a contact group's continuations.

    cost: (M, M) distance of every continuation (rows) to every identity of the group
    (columns, the continuations' provisional identities ``idents`` in the same order); a row
    with a NaN is a continuation with nothing to compare (it ended before it was seen apart).
    The continuations that can be compared take the identities, any of the group's, that
    minimise the total distance -- if that beats keeping them by ``margin`` per changed
    identity; the others keep theirs where still free, else take those left over (a
    continuation that ended unseen does not hold on to an identity that another
    continuation's measurements claim)."""
    final = list(idents)
    rows = np.flatnonzero(np.isfinite(cost).all(axis=1))
    if len(rows) == 0:
        return final
    sub = cost[rows]
    r, c = linear_sum_assignment(sub)
    now = float(sub[np.arange(len(rows)), rows].sum())
    new = float(sub[r, c].sum())
    changed = int(np.sum(c != rows[r]))
    if not changed or new + margin * changed > now:
        return final
    for i, j in zip(r, c):
        final[rows[i]] = idents[j]
    taken = {idents[j] for j in c}
    others = sorted(set(range(len(idents))) - set(rows.tolist()))
    keep = {m for m in others if idents[m] not in taken}
    left = [k for k in idents if k not in taken and k not in {idents[m] for m in keep}]
    for m in others:
        final[m] = idents[m] if m in keep else left.pop(0)
    return final


def resolve_group(state: TrackerState, gid: int, resolved: dict[int, int | None]) -> None:
    """Confirm or cross over the identities of a contact group's continuations (live or
    ended), then make them final."""
    s = state.settings
    g = state.groups.pop(gid)
    members: list[Track] = g["members"]
    idents = group_identities(members)
    cost = group_costs(
        [member_medians(state, m) for m in members], [state.identities[k].hist.medians() for k in idents]
    )
    colour = group_colours(state, members, idents)
    margin = s.relink_margin_m
    if np.isfinite(colour).all(axis=1).sum() >= 2:
        # The clothes decide where they are known (limb lengths from a pose network scatter
        # more than workers differ: docs/reconstruction.md, 3. Identities).
        cost, margin = colour, APPEARANCE_MARGIN
    final = assign_group(cost, idents, margin)
    alive = {t.id for t in state.tracks}
    for m, ident_no in zip(members, final):
        m.identity = ident_no
        ident = state.identities[ident_no]
        if m.id in alive:
            ident.track = m.id
        elif ident.track is None or ident.track in {x.id for x in members}:
            ident.track = None
            ident.last_frame, ident.last_pos = m.last_frame, m.pos.copy()
        m.no_split_with = set(idents) - {ident_no}
        if m.hist_before is not None:
            m.hist.merge(m.hist_before)
            m.hist_before = None
        if m.look_before is not None:
            m.look.merge(m.look_before)
            m.look_before = None
        ident.hist.merge(m.hist)
        m.hist = ident.hist
        ident.look.merge(m.look)
        m.look = ident.look
        m.group = None
        resolved[m.id] = ident_no
