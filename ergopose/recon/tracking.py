"""Identities over a shift: follow every worker in 3D with one stable identity.

Per frame (in frame order; the state carries over from one chunk of frames to the next):

1. Prediction. Each live track predicts its body centre (mean of the torso joints) with
   constant horizontal velocity from its last update (the height is held).
2. Matching people seen by two or more cameras. Cost = horizontal (x, y) distance between predicted
   and triangulated centre (the height of the centre jumps when the torso is hidden and the
   centre falls back to other joints; the floor position hardly does); a pair is possible
   within ``track_gate_m`` plus ``track_gate_growth_m_per_s`` per second the track has gone
   unseen; globally optimal assignment among the candidates within the gates, maximising a
   log-likelihood gain in which a track's uncertainty grows with its gate (track_matching.match_gain;
   associate.gated_assignment, scipy.optimize.linear_sum_assignment), less the clothing colour's
   (track_matching.colour_cost: the person's colour against the track's mean, ergopose.pose.appearance;
   a colour further than APPEARANCE_GATE is no match). A matched track updates its centre and
   velocity with an alpha-beta filter (gains ALPHA, BETA).
3. Matching people seen by one camera only. Tracks still unmatched are compared with the torso
   rays of single-view people: cost = horizontal distance between the predicted centre and the
   point where the ray reaches the track's height (in front of the camera), gated by
   ``single_view_gate_m``. A match keeps the track alive (its identity goes on through an
   occlusion from one camera) and moves the centre to that point in x and y.
4. Births. A person seen by two or more cameras and matched to no track starts a new, *tentative*
   track.
5. Ends. A track unseen for more than ``max_coast_s`` ends (a newly born tentative one after
   TENTATIVE_MAX_COAST_S).
6. Identities. A tentative track is resolved once it has ``relink_window_s`` of 3D data, or
   when it ends (dropped as noise if it has less than ``min_track_s``). It is then compared
   with the identities that are not being followed right now (lost, or coasting -- or kept only
   by one camera's rays -- since before the track began): a candidate must have been able to walk from where it was last seen to
   where the new track began (``relink_max_speed_m_s``). Where the clothing colours are known
   they decide first (track_identities.by_colour): the candidate within APPEARANCE_SAME and
   APPEARANCE_MARGIN closer than any other is the person; a track further than APPEARANCE_NEW
   from every identity is someone new. Otherwise its body-measurement signature --
   the medians of its limb lengths (keypoints.LIMBS) over everything seen so far -- must
   differ from the new track's by at most ``relink_max_signature_m`` (RMS over limbs), and by
   ``relink_margin_m`` less than the second best candidate -- unless it is the only fitting
   identity lost within RECENT_GAP_S before the track began (a worker re-appearing after a
   short occlusion) -- or, once as many identities exist as the area holds workers
   (``expected_workers``), the candidate with the closest colour (else signature) whatever its
   distance. The
   chosen candidate gives the track its identity (a coasting track of
   that identity ends); otherwise the track gets a new identity. While an identity the track
   could be is waiting for a contact decision (7.), the decision waits. Identities are numbered in order of appearance: worker_1, worker_2, ...
7. Contacts. Confirmed tracks whose centres come closer than ``contact_distance_m`` (people
   passing each other, standing together) can swap people without any geometric sign. Their
   tracks end and continuations carry on with the same identities, provisionally (their rows
   wait); once the people have separated again and each live continuation has
   ``relink_window_s`` of 3D data since, with colours or GROUP_MIN_LIMBS limbs to compare (at
   most GROUP_MAX_WAIT windows after the separation, GROUP_MAX_WAIT_S after the contact), the
   identities are confirmed or crossed over by optimal assignment on the clothing colours where
   known (crossed only if that beats keeping them by APPEARANCE_MARGIN per changed identity),
   else on the signatures (by ``relink_margin_m``) (track_contacts.resolve_group). The continuations seen
   apart may take any identity of the group; one that ended unseen keeps its own only if no
   other claims it. A continuation that meets someone else before its group is decided joins
   a new contact with all its group's live continuations: the old group is decided at once on
   what it has, and the new one among every identity involved (track_contacts.split_contacts).
8. Clothes that say otherwise. A confirmed track whose clothing colour over the last
   ``relink_window_s`` (from RECENT_MIN_S worth of rows with a colour on) lies within
   APPEARANCE_SAME of an identity that no track has seen for a relink window, and
   APPEARANCE_MARGIN closer to it than to its own identity's, ends; a track with that identity
   carries the person on from the next frame (track_colour_relink; setting ``colour_relink``).
   Its rows so far keep the identity they had.

Single-view people never start tracks and are never triangulated. Frame times are frame / fps.

The parts, one module each: ``track_signatures`` (limb-length histograms, clothing colours and
the thresholds they are judged by), ``track_records`` (tracks, identities, the state carried
between chunks), ``track_matching`` (steps 1-3), ``track_identities`` (6.), ``track_contacts``
(7.); this module runs them frame by frame (4., 5.).
"""

from __future__ import annotations

import numpy as np

from ergopose.errors import InputError
from ergopose.recon.records import People3D
from ergopose.recon.track_colour_relink import better_identity, hand_on, note_look
from ergopose.recon.track_contacts import group_ready, resolve_group, split_contacts, watch_separation
from ergopose.recon.track_identities import resolve
from ergopose.recon.track_matching import match_3d, match_single_view, predict, update_track
from ergopose.recon.track_records import Track, TrackEnd, TrackerState, TrackingResult, identity_name
from ergopose.recon.track_signatures import limb_lengths


class Tracker(TrackerState):
    """Online tracker; feed it chunks of People3D in frame order with :meth:`update`.

    The object is the state carried from one chunk to the next (it can be pickled).
    """

    # --- queries ----------------------------------------------------------------------------------

    def resolved_frontier(self) -> int | None:
        """Every row before this frame has its final identity and its track's alive span is known:
        the smallest first frame of an unresolved track and last observed frame + 1 of a live
        track, and the next frame to process."""
        cands = [t.first_frame for t in self.tracks if t.identity is None]
        cands += [m.first_frame for g in self.groups.values() for m in g["members"]]  # provisional
        cands += [t.last_frame + 1 for t in self.tracks]
        if self.next_frame is not None:
            cands.append(self.next_frame)
        return min(cands) if cands else None

    def identity_signatures(self) -> dict[str, np.ndarray]:
        """{worker name: (L,) limb-length medians} of every identity so far."""
        return {identity_name(k): v.hist.medians() for k, v in self.identities.items()}

    def stature_estimates(self) -> dict[str, float]:
        return {identity_name(k): v.hist.stature_estimate() for k, v in self.identities.items()}

    # --- the loop ---------------------------------------------------------------------------------

    def update(self, people: People3D, first_frame: int, stop_frame: int) -> TrackingResult:
        """Track frames first_frame <= f < stop_frame (rows of ``people`` must lie in that range,
        sorted by frame; frames without rows are frames where nobody was seen)."""
        if self.next_frame is not None and first_frame != self.next_frame:
            raise InputError(f"chunk starts at frame {first_frame}, expected {self.next_frame}", field="frames")
        frames = people.frame
        if len(frames) and (frames[0] < first_frame or frames[-1] >= stop_frame or np.any(np.diff(frames) < 0)):
            raise InputError("rows must be sorted by frame and lie within the chunk", field="frames")
        s = self.settings
        m = len(people)
        track_of = np.full(m, -1, dtype=np.int64)
        # Signatures from the gated triangulation. (Taking the long limbs from every observation,
        # triangulate_observations, as the body model's lengths do, gave more samples but noisier
        # medians: the ORACLE 2-worker 2-minute 1024 x 768 session went from 0 to 4 identity
        # switches at contacts.)
        self.lengths = limb_lengths(people.points_world)
        looks = people.appearance
        assert looks is not None  # People3D fills it
        resolved: dict[int, int | None] = {}
        ended: list[TrackEnd] = []
        cent_f, cent_t, cent_p = [], [], []
        bounds = np.searchsorted(frames, np.arange(first_frame, stop_frame + 1))
        is3d = (people.n_cameras >= 2) & np.isfinite(people.centre_world).all(axis=1)
        is1 = (people.n_cameras == 1) & np.isfinite(people.ray_world).all(axis=1)
        centre = people.centre_world
        origin, ray = people.ray_origin_world, people.ray_world
        dt1 = 1.0 / self.fps
        gate0, growth = s.track_gate_m, s.track_gate_growth_m_per_s
        for k, f in enumerate(range(first_frame, stop_frame)):
            r0, r1 = bounds[k], bounds[k + 1]
            tracks = self.tracks
            if r0 == r1 and not tracks:
                continue
            rows = np.arange(r0, r1)
            rows3 = rows[is3d[r0:r1]]
            rows1 = rows[is1[r0:r1]]
            matched_tracks: set[int] = set()
            if tracks:
                pred, gap, gate = predict(tracks, f, dt1, gate0, growth)
            unmatched3 = rows3
            if tracks and len(rows3):
                track_colours = np.array([self.colour(t) for t in tracks])
                ti, ri = match_3d(pred, gate, gate0, centre[rows3], track_colours, looks[rows3])
                if len(ti):
                    used = np.zeros(len(rows3), bool)
                    for a, b in zip(ti, ri):
                        t = tracks[a]
                        row = rows3[b]
                        update_track(t, pred[a], centre[row], gap[a], f, self.fps)
                        t.frames_3d += 1
                        t.last_3d_frame = f
                        t.pending_rows.append(row)
                        t.look.add(looks[row])
                        note_look(t, f, looks[row], self.window_frames)
                        track_of[row] = t.id
                        matched_tracks.add(a)
                        used[b] = True
                    unmatched3 = rows3[~used]
            if tracks and len(rows1) and len(matched_tracks) < len(tracks):
                free = np.array([a for a in range(len(tracks)) if a not in matched_tracks])
                ti, ri, hit = match_single_view(
                    pred[free], gate[free], gate0, s.single_view_gate_m, origin[rows1], ray[rows1]
                )
                if len(ti):
                    for a, b in zip(ti, ri):
                        t = tracks[free[a]]
                        row = rows1[b]
                        meas = pred[free[a]].copy()
                        meas[:2] = hit[a, b, :2]
                        update_track(t, pred[free[a]], meas, gap[free[a]], f, self.fps)
                        track_of[row] = t.id
                        matched_tracks.add(int(free[a]))
            for row in unmatched3:
                t = Track(
                    id=self.next_track,
                    first_frame=f,
                    first_pos=centre[row].copy(),
                    pos=centre[row].copy(),
                    vel=np.zeros(3),
                    last_frame=f,
                    last_update_frame=f,
                    last_3d_frame=f,
                    frames_3d=1,
                )
                t.pending_rows.append(row)
                t.look.add(looks[row])
                self.next_track += 1
                track_of[row] = t.id
                self.tracks.append(t)
            if s.contact_distance_m > 0:
                split_contacts(self, f, ended, resolved)
            # Ends, then resolutions (in order of birth).
            stale = [
                t
                for t in self.tracks
                if f - t.last_frame > (self.coast_frames if t.identity is not None else self.tentative_coast_frames)
            ]
            for t in stale:
                if not any(e.track == t.id for e in ended):
                    self._end(t, resolved, ended)
            if stale:
                gone = {e.track for e in ended}
                self.tracks = [t for t in self.tracks if t.id not in gone]
            for t in list(self.tracks):
                if t.identity is None and t.group is None and t.frames_3d >= self.window_frames:
                    resolve(self, t, resolved, ended)
            if self.groups:
                watch_separation(self, f)
            for gid in list(self.groups):
                if group_ready(self, gid, f):
                    resolve_group(self, gid, resolved)
            for t in self.tracks:
                cent_f.append(f)
                cent_t.append(t.id)
                cent_p.append(t.pos if t.last_update_frame == f else t.pos + t.vel * (f - t.last_update_frame) * dt1)
            if s.colour_relink:
                for t in [x for x in self.tracks if x.recent_frames and x.recent_frames[-1] == f]:
                    number = better_identity(self, t, f)
                    if number is not None:
                        hand_on(self, t, number, f, resolved, ended)
        self.next_frame = stop_frame
        # Rows of tracks dropped during this call lose their track id.
        dropped = {tid for tid, ident in resolved.items() if ident is None}
        if dropped:
            track_of[np.isin(track_of, list(dropped))] = -1
        self.flush_all()
        centres = np.zeros((len(cent_f), 5))
        if cent_f:
            centres[:, 0] = cent_f
            centres[:, 1] = cent_t
            centres[:, 2:] = np.array(cent_p)
        return TrackingResult(track=track_of, centres=centres, resolved=resolved, ended=tuple(ended))

    def finish(self) -> TrackingResult:
        """End every live track (end of the session) and resolve the tentative ones."""
        resolved: dict[int, int | None] = {}
        ended: list[TrackEnd] = []
        members = [t for t in self.tracks if t.group is not None]
        others = [t for t in self.tracks if t.group is None]
        for t in members:
            self._end(t, resolved, ended)
        self.tracks = others
        for gid in list(self.groups):
            resolve_group(self, gid, resolved)
        for t in others:
            self._end(t, resolved, ended)
        self.tracks = []
        return TrackingResult(
            track=np.zeros(0, np.int64), centres=np.zeros((0, 5)), resolved=resolved, ended=tuple(ended)
        )

    def _end(self, t: Track, resolved: dict[int, int | None], ended: list[TrackEnd]) -> None:
        if t.group is not None:
            # A provisional continuation ends before its contact group is decided: it stays in
            # the decision; its identity is lost but reserved for the group meanwhile.
            self.flush(t)
            self.release(t)
            ended.append(TrackEnd(t.id, t.first_frame, t.last_frame, t.identity))
            return
        if t.identity is None:
            if t.frames_3d >= max(self.min_frames, 1):
                resolve(self, t, resolved, ended, final=True)
            else:
                resolved[t.id] = None
        self.flush(t)
        if t.identity is not None:
            self.release(t)
        ended.append(TrackEnd(t.id, t.first_frame, t.last_frame, t.identity))
