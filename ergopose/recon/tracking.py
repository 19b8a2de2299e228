"""Identities over a shift: follow every worker in 3D with one stable identity.

Per frame (in frame order; the state carries over from one chunk of frames to the next):

1. Prediction. Each live track predicts its body centre (mean of the torso joints) with
   constant horizontal velocity from its last update (the height is held).
2. Matching people seen by two or more cameras. Cost = horizontal (x, y) distance between predicted
   and triangulated centre (the height of the centre jumps when the torso is hidden and the
   centre falls back to other joints; the floor position hardly does); a pair is possible
   within ``track_gate_m`` plus ``track_gate_growth_m_per_s`` per second the track has gone
   unseen; globally optimal assignment among the candidates within the gates, maximising a
   log-likelihood gain in which a track's uncertainty grows with its gate (:func:`_match_gain`;
   associate.gated_assignment, scipy.optimize.linear_sum_assignment), less the clothing colour's
   (:func:`_colour_cost`: the person's colour against the track's mean, ergopose.pose.appearance;
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
   they decide first (:meth:`Tracker._by_colour`): the candidate within APPEARANCE_SAME and
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
   ``relink_window_s`` of 3D data since, with a comparable limb (at most GROUP_MAX_WAIT
   windows after the separation, GROUP_MAX_WAIT_S after the contact), the identities are
   confirmed or crossed over by optimal assignment on the clothing colours where known (crossed
   only if that beats keeping them by APPEARANCE_MARGIN per changed identity), else on the
   signatures (by ``relink_margin_m``)
   (:meth:`Tracker._resolve_group`). A continuation that ends first keeps its identity.

Single-view people never start tracks and are never triangulated. Frame times are frame / fps.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from ergopose.arrays import FloatArray, IntArray
from ergopose.errors import InputError
from ergopose.keypoints import LIMB_INDEX, LIMBS
from ergopose.pose.appearance import appearance_distance
from ergopose.recon.associate import gated_assignment
from ergopose.recon.records import People3D
from ergopose.recon.settings import ReconSettings
from ergopose.records import APPEARANCE_DIMS

#: Alpha-beta gains of the centre filter (position, velocity). The triangulated centre jumps by
#: up to ~0.2 m when the set of visible torso joints changes (a bent-over worker's shoulders lie
#: ahead of the hips), so the filter follows it only partly, and a single jump moves the velocity
#: by at most BETA * VELOCITY_RESIDUAL_CAP / dt.
ALPHA = 0.5
BETA = 0.1
VELOCITY_RESIDUAL_CAP_M = 0.15
#: Largest speed (m/s) the centre filter keeps (a walking or hurrying person).
MAX_SPEED_M_S = 3.0
#: A tentative track (identity not decided yet) unseen for longer than this ends: a spurious
#: birth (the centre of a person jumped out of its track's gate for a frame) must not linger and
#: later take over the person from its real track.
TENTATIVE_MAX_COAST_S = 0.25
#: A new track fitting (signature within relink_max_signature_m) exactly one identity lost at
#: most this long before it began takes that identity without the margin test: a worker
#: re-appearing after a short occlusion is the worker who just vanished there, even when an
#: older identity happens to have a similar signature.
RECENT_GAP_S = 10.0
#: A contact group waits at most this many relink windows for comparable limb data after the
#: people separated, and at most GROUP_MAX_WAIT_S in all (people working side by side).
GROUP_MAX_WAIT = 4
GROUP_MAX_WAIT_S = 60.0
#: Clothing colour (ergopose.pose.appearance; distances in its L*a*b* units, 0..255 scale). A
#: worker's own 3D rows lie a median 2.5-5.5 (90th percentile 4-14) from the worker's mean, and
#: the means of four simulated workers 21-40 from each other (seed 0, network keypoints, the first
#: 10 s). APPEARANCE_SIGMA: the spread of one row about its track's mean in the matching's
#: likelihood; APPEARANCE_GATE: a row further than this from a track's colour is not that
#: track's person; an identity within APPEARANCE_SAME of a new track, APPEARANCE_MARGIN closer
#: than any other, is its person; one further than APPEARANCE_NEW from every identity is someone
#: new. A colour enters a mean only from APPEARANCE_MIN_ROWS rows on.
APPEARANCE_SIGMA = 8.0
APPEARANCE_GATE = 30.0
APPEARANCE_SAME = 12.0
APPEARANCE_MARGIN = 8.0
APPEARANCE_NEW = 18.0
APPEARANCE_MIN_ROWS = 5
#: Two confirmed tracks whose colours are at least this far apart are not split at a contact
#: (the colour term of the matching tells their people apart frame by frame).
APPEARANCE_APART = 18.0
#: Limb-length histogram: bin width and number of bins (0 .. 1.5 m in millimetres).
HIST_BIN_M = 0.001
HIST_BINS = 1500
#: A limb's median enters a signature only with at least this many samples; a comparison needs
#: at least MIN_COMMON_LIMBS such limbs in both.
MIN_LIMB_SAMPLES = 5
MIN_COMMON_LIMBS = 6
#: Winter (2009, Fig. 4.1) fractions of stature of the body's long segments: trunk (hip to
#: shoulder, 0.818 - 0.530), thigh, shank, upper arm, forearm. The stature estimate is the sum of
#: the median lengths of the segments known (mean of the sides known) divided by the sum of their
#: fractions; the trunk must be among them (legs are often hidden from one of two ceiling cameras).
_STATURE_SEGMENTS = {"trunk_side": 0.288, "thigh": 0.245, "shank": 0.246, "upper_arm": 0.186, "forearm": 0.146}


def identity_name(number: int) -> str:
    """The pseudonymous name of identity ``number`` (1-based): worker_1, worker_2, ..."""
    return f"worker_{number}"


def limb_lengths(points_world: np.ndarray) -> FloatArray:
    """(..., 33, 3) -> (..., L) length of every limb of keypoints.LIMBS, NaN where a joint is NaN."""
    X = np.asarray(points_world, dtype=np.float64)
    lengths: FloatArray = np.linalg.norm(X[..., LIMB_INDEX[:, 0], :] - X[..., LIMB_INDEX[:, 1], :], axis=-1)
    return lengths


def _match_gain(cost: np.ndarray, gate: np.ndarray, fresh_gate: float) -> FloatArray:
    """Log-likelihood gain of matching track t (rows) with person o (columns).

    Each track's predicted centre is taken as a 2D Gaussian with sigma = gate / 3 (its gate is 3
    sigma; the gate, and so sigma, grow while the track goes unseen). The gain is the negative
    log-likelihood at the edge of a fresh track's gate minus that of the match,
    (4.5 + 2 ln(fresh_gate / 3)) - (0.5 (d / sigma)^2 + 2 ln sigma), at least 1e-3 inside the
    gate. A track unseen for a while, with a wide gate, pays for its uncertainty: it does not
    take a person from a track that has just seen him close by (dividing the distance by the
    gate alone let a track unseen for 2 s win a person 0.5 m away over his own track 0.12 m
    away).
    """
    sigma = np.asarray(gate, dtype=np.float64)[:, None] / 3.0
    ref = 4.5 + 2.0 * np.log(fresh_gate / 3.0)
    with np.errstate(invalid="ignore"):
        nll = 0.5 * (cost / sigma) ** 2 + 2.0 * np.log(sigma)
    gain: FloatArray = np.maximum(ref - nll, 1e-3)
    return gain


def _colour_cost(colour: np.ndarray) -> np.ndarray:
    """Negative log-likelihood of clothing-colour distances (APPEARANCE_SIGMA); 0 where unknown."""
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(colour), 0.5 * (colour / APPEARANCE_SIGMA) ** 2, 0.0)


def _ray_at_height(origin: np.ndarray, ray: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points of rays o + t d (R rays) at heights z (T tracks): (T, R, 3) and t (T, R).

    A nearly horizontal ray (|d_z| < 0.05) does not fix a point at a height: t is NaN there."""
    dz = ray[:, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (z[:, None] - origin[None, :, 2]) / np.where(np.abs(dz) >= 0.05, dz, np.nan)[None, :]
    return origin[None] + t[..., None] * ray[None], t


class LimbHistogram:
    """Counts of limb lengths in 1 mm bins (bounded memory, exact robust medians to 1 mm)."""

    def __init__(self, n_limbs: int = len(LIMBS)) -> None:
        self.counts = np.zeros((n_limbs, HIST_BINS), dtype=np.int64)

    def add(self, lengths: np.ndarray) -> None:
        """lengths: (n, L) metres; NaN and lengths beyond the histogram are ignored."""
        n_limbs = self.counts.shape[0]
        lengths = np.asarray(lengths, dtype=np.float64).reshape(-1, n_limbs)
        if lengths.size == 0:
            return
        with np.errstate(invalid="ignore"):
            b = np.floor(lengths / HIST_BIN_M)
            ok = np.isfinite(b) & (b >= 0) & (b < HIST_BINS)
        limb = np.broadcast_to(np.arange(n_limbs), lengths.shape)[ok]
        flat = limb * HIST_BINS + b[ok].astype(np.int64)
        self.counts += np.bincount(flat, minlength=self.counts.size).reshape(self.counts.shape)

    def merge(self, other: "LimbHistogram") -> None:
        self.counts += other.counts

    @property
    def samples(self) -> IntArray:
        """(L,) number of samples per limb."""
        samples: IntArray = self.counts.sum(axis=1)
        return samples

    def medians(self, min_samples: int = MIN_LIMB_SAMPLES) -> np.ndarray:
        """(L,) median length per limb (metres, linear within the 1 mm bin); NaN with too few samples."""
        n = self.samples
        cum = np.cumsum(self.counts, axis=1)
        half = n / 2.0
        k = np.argmax(cum >= half[:, None], axis=1)
        below = np.where(k > 0, cum[np.arange(len(n)), k - 1], 0)
        inbin = self.counts[np.arange(len(n)), k]
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.where(inbin > 0, (half - below) / inbin, 0.5)
        med = (k + frac) * HIST_BIN_M
        return np.where(n >= max(min_samples, 1), med, np.nan)

    def stature_estimate(self) -> float:
        """Estimated stature (metres) from the median lengths of the long segments known (see
        _STATURE_SEGMENTS, Winter's fractions of stature); NaN without the trunk."""
        med = self.medians()
        names = [n for n, _, _ in LIMBS]
        total = 0.0
        frac = 0.0
        for segment, f in _STATURE_SEGMENTS.items():
            sides = [med[names.index(f"{side}_{segment}")] for side in ("left", "right")]
            sides = [v for v in sides if np.isfinite(v)]
            if not sides:
                if segment == "trunk_side":
                    return float("nan")
                continue
            total += float(np.mean(sides))
            frac += f
        return float(total / frac)


class Look:
    """The running mean clothing colour of a track or identity (ergopose.pose.appearance)."""

    def __init__(self) -> None:
        self.total = np.zeros(APPEARANCE_DIMS)
        self.count = np.zeros(APPEARANCE_DIMS, dtype=np.int64)

    def add(self, looks: np.ndarray) -> None:
        """looks: (n, APPEARANCE_DIMS); NaN entries are ignored."""
        looks = np.asarray(looks, dtype=np.float64).reshape(-1, APPEARANCE_DIMS)
        known = np.isfinite(looks)
        self.total += np.where(known, looks, 0.0).sum(axis=0)
        self.count += known.sum(axis=0)

    def merge(self, other: "Look") -> None:
        self.total += other.total
        self.count += other.count

    def mean(self) -> np.ndarray:
        """(APPEARANCE_DIMS,) mean colour; NaN where fewer than APPEARANCE_MIN_ROWS rows gave it."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.count >= APPEARANCE_MIN_ROWS, self.total / np.maximum(self.count, 1), np.nan)


def _group_costs(members: list[np.ndarray], identities: list[np.ndarray]) -> np.ndarray:
    """(M, I) RMS difference of limb medians between contact continuations and the group's
    identities, each row over the limbs known in that member and in every identity (so a row
    compares the identities on equal terms); NaN rows when no such limb exists."""
    known_all = np.all([np.isfinite(i) for i in identities], axis=0)
    out = np.full((len(members), len(identities)), np.nan)
    for r, m in enumerate(members):
        ok = np.isfinite(m) & known_all
        if ok.any():
            out[r] = [float(np.sqrt(np.mean((m[ok] - i[ok]) ** 2))) for i in identities]
    return out


def _group_identities(members: list[_Track]) -> list[int]:
    """The identities of a contact group's continuations (every one has one: only confirmed
    tracks are split)."""
    out = [m.identity for m in members]
    assert all(k is not None for k in out)
    return [int(k) for k in out if k is not None]


def signature_distance(a: np.ndarray, b: np.ndarray) -> float:
    """RMS difference (metres) of two limb-median vectors over the limbs known in both; NaN when
    fewer than MIN_COMMON_LIMBS are."""
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < MIN_COMMON_LIMBS:
        return float("nan")
    return float(np.sqrt(np.mean((a[ok] - b[ok]) ** 2)))


@dataclass
class _Track:
    id: int
    first_frame: int
    first_pos: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    last_frame: int  # frame of the last observation (3D or single view)
    last_update_frame: int  # frame of the last state update
    last_3d_frame: int = -1  # frame of the last observation by two or more cameras
    frames_3d: int = 0
    identity: int | None = None
    hist: LimbHistogram = field(default_factory=LimbHistogram)
    look: Look = field(default_factory=Look)
    pending_rows: list[int] = field(default_factory=list)  # chunk rows not yet in hist
    group: int | None = None  # contact group whose decision is pending (provisional identity)
    hist_before: LimbHistogram | None = None  # a continuation's limb lengths before the separation
    look_before: Look | None = None  # and its colours
    no_split_with: set[int] = field(default_factory=set)  # identities it was resolved with, still close


@dataclass
class _Identity:
    number: int
    hist: LimbHistogram
    last_frame: int
    last_pos: np.ndarray
    track: int | None  # id of the live track following it, if any
    look: Look = field(default_factory=Look)


#: An identity a new track could be: (signature distance m, the identity, gap s, colour distance).
_Candidate = tuple[float, _Identity, float, float]


@dataclass(frozen=True)
class TrackEnd:
    """A track that ended: its id, first and last observed frame, and identity (None = dropped)."""

    track: int
    first_frame: int
    last_frame: int
    identity: int | None


@dataclass(frozen=True)
class TrackingResult:
    """What one call of :meth:`Tracker.update` found.

    track: (M,) int64 track id of every row of the People3D chunk, -1 = no track (a single-view
        person matched to no track, or a 3D person whose tentative track was dropped later --
        see ``dropped``).
    centres: (K, 5) float64 rows (frame, track, x, y, z): the track's body centre after each
        frame it is alive (observed or coasting), metres.
    resolved: {track id: identity number or None (dropped)} decided during this call.
    ended: tracks that ended during this call.
    """

    track: np.ndarray
    centres: np.ndarray
    resolved: dict[int, int | None]
    ended: tuple[TrackEnd, ...]


class Tracker:
    """Online tracker; feed it chunks of People3D in frame order with :meth:`update`.

    The object is the state carried from one chunk to the next (it can be pickled).
    """

    def __init__(self, settings: ReconSettings | None = None, fps: float = 12.0) -> None:
        if not (np.isfinite(fps) and fps > 0):
            raise InputError(f"frames per second must be positive, got {fps!r}", field="fps")
        self.settings = settings or ReconSettings()
        self.fps = float(fps)
        self.tracks: list[_Track] = []
        self.identities: dict[int, _Identity] = {}
        self.next_track = 0
        self.next_identity = 1
        self.next_frame: int | None = None
        s = self.settings
        self._coast_frames = s.max_coast_s * self.fps
        self._tentative_coast_frames = min(s.max_coast_s, TENTATIVE_MAX_COAST_S) * self.fps
        self._window_frames = max(1, int(round(s.relink_window_s * self.fps)))
        self.groups: dict[int, dict[str, Any]] = {}  # contact group id -> {"identities", "members", "ended"}
        self.next_group = 0
        self._min_frames = int(round(s.min_track_s * self.fps))

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
        self._lengths = limb_lengths(people.points_world)
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
                pos = np.array([t.pos for t in tracks])
                vel = np.array([t.vel for t in tracks])
                gap = np.array([f - t.last_update_frame for t in tracks], dtype=np.float64) * dt1
                unseen = np.array([f - t.last_frame for t in tracks], dtype=np.float64) * dt1
                pred = pos + vel * gap[:, None]
                gate = gate0 + growth * np.maximum(unseen - dt1, 0.0)
            unmatched3 = rows3
            if tracks and len(rows3):
                cost = np.linalg.norm(pred[:, None, :2] - centre[rows3][None, :, :2], axis=-1)
                colour = appearance_distance(np.array([self._colour(t) for t in tracks])[:, None], looks[rows3][None])
                # The colour gate only where the geometry is ambiguous (a person within the gates
                # of two tracks, or a track with two people within its gate): a worker alone keeps
                # the track while a carried carton or the light changes the colour seen.
                within = cost <= gate[:, None]
                ambiguous = (within.sum(axis=0) >= 2)[None, :] | (within.sum(axis=1) >= 2)[:, None]
                cost = np.where(ambiguous & (colour > APPEARANCE_GATE), np.inf, cost)
                gain = _match_gain(cost, gate, gate0) - _colour_cost(colour)
                ti, ri = gated_assignment(cost, gate[:, None], np.maximum(gain, 1e-3))
                if len(ti):
                    used = np.zeros(len(rows3), bool)
                    for a, b in zip(ti, ri):
                        t = tracks[a]
                        row = rows3[b]
                        self._update_track(t, pred[a], centre[row], gap[a], f)
                        t.frames_3d += 1
                        t.last_3d_frame = f
                        t.pending_rows.append(row)
                        t.look.add(looks[row])
                        track_of[row] = t.id
                        matched_tracks.add(a)
                        used[b] = True
                    unmatched3 = rows3[~used]
            if tracks and len(rows1) and len(matched_tracks) < len(tracks):
                free = np.array([a for a in range(len(tracks)) if a not in matched_tracks])
                o, d = origin[rows1], ray[rows1]
                hit, along = _ray_at_height(o, d, pred[free][:, 2])  # (T, R, 3) ray point at the track's height
                diff = hit - pred[free][:, None, :]
                cost = np.linalg.norm(diff[..., :2], axis=-1)
                cost = np.where(along > 0, cost, np.inf)
                sv_gate = s.single_view_gate_m + gate[free] - gate0
                ti, ri = gated_assignment(cost, sv_gate[:, None], _match_gain(cost, sv_gate, s.single_view_gate_m))
                if len(ti):
                    for a, b in zip(ti, ri):
                        t = tracks[free[a]]
                        row = rows1[b]
                        meas = pred[free[a]].copy()
                        meas[:2] = hit[a, b, :2]
                        self._update_track(t, pred[free[a]], meas, gap[free[a]], f)
                        track_of[row] = t.id
                        matched_tracks.add(int(free[a]))
            for row in unmatched3:
                t = _Track(
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
                self._contacts(f, dt1, ended)
            # Ends, then resolutions (in order of birth).
            stale = [
                t
                for t in self.tracks
                if f - t.last_frame > (self._coast_frames if t.identity is not None else self._tentative_coast_frames)
            ]
            for t in stale:
                if not any(e.track == t.id for e in ended):
                    self._end(t, resolved, ended)
            if stale:
                gone = {e.track for e in ended}
                self.tracks = [t for t in self.tracks if t.id not in gone]
            for t in list(self.tracks):
                if t.identity is None and t.group is None and t.frames_3d >= self._window_frames:
                    self._resolve(t, resolved, ended)
            if self.groups:
                self._watch_separation(f)
            for gid in list(self.groups):
                if self._group_ready(gid, f):
                    self._resolve_group(gid, resolved)
            for t in self.tracks:
                cent_f.append(f)
                cent_t.append(t.id)
                cent_p.append(t.pos if t.last_update_frame == f else t.pos + t.vel * (f - t.last_update_frame) * dt1)
        self.next_frame = stop_frame
        # Rows of tracks dropped during this call lose their track id.
        dropped = {tid for tid, ident in resolved.items() if ident is None}
        if dropped:
            track_of[np.isin(track_of, list(dropped))] = -1
        self._flush_all()
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
            self._resolve_group(gid, resolved)
        for t in others:
            self._end(t, resolved, ended)
        self.tracks = []
        return TrackingResult(
            track=np.zeros(0, np.int64), centres=np.zeros((0, 5)), resolved=resolved, ended=tuple(ended)
        )

    # --- pieces -----------------------------------------------------------------------------------

    def _update_track(self, t: _Track, pred: np.ndarray, meas: np.ndarray, gap_s: float, f: int) -> None:
        """Alpha-beta update of a track's centre; after a gap of several frames the prediction
        is worth little, so the position follows the measurement (gain 1 - (1 - ALPHA)^frames)
        and the velocity moves half way to the mean velocity over the gap."""
        frames = max(1, int(round(gap_s * self.fps)))
        r = meas - pred
        if frames == 1:
            t.pos = pred + ALPHA * r
            size = float(np.linalg.norm(r))
            rv = r if size <= VELOCITY_RESIDUAL_CAP_M else r * (VELOCITY_RESIDUAL_CAP_M / size)
            v = t.vel + BETA * rv / gap_s
        else:
            gain = 1.0 - (1.0 - ALPHA) ** frames
            v = 0.5 * t.vel + 0.5 * (meas - t.pos) / gap_s
            t.pos = pred + gain * r
        # Horizontal velocity only: the centre's height jumps with the set of torso joints seen
        # (and a fitted body's centre dips as the worker bends), which is no motion of the
        # worker; a vertical velocity carried that jump into every coasting prediction, and the
        # single-view rays are cut at the predicted height, so it moved their matches sideways.
        v[2] = 0.0
        speed = float(np.linalg.norm(v))
        t.vel = v if speed <= MAX_SPEED_M_S else v * (MAX_SPEED_M_S / speed)
        t.last_update_frame = f
        t.last_frame = f

    def _flush(self, t: _Track) -> None:
        if t.pending_rows:
            t.hist.add(self._lengths[np.array(t.pending_rows)])
            t.pending_rows = []

    def _flush_all(self) -> None:
        for t in self.tracks:
            self._flush(t)

    def _end(self, t: _Track, resolved: dict[int, int | None], ended: list[TrackEnd]) -> None:
        if t.group is not None:
            # A provisional continuation ends before its contact group is decided: it stays in
            # the decision; its identity is lost but reserved for the group meanwhile.
            self._flush(t)
            self._release(t)
            ended.append(TrackEnd(t.id, t.first_frame, t.last_frame, t.identity))
            return
        if t.identity is None:
            if t.frames_3d >= max(self._min_frames, 1):
                self._resolve(t, resolved, ended, final=True)
            else:
                resolved[t.id] = None
        self._flush(t)
        if t.identity is not None:
            self._release(t)
        ended.append(TrackEnd(t.id, t.first_frame, t.last_frame, t.identity))

    def _release(self, t: _Track) -> None:
        """An ending track lets go of its identity (if it still holds it): lost since its last frame."""
        assert t.identity is not None
        ident = self.identities[t.identity]
        if ident.track == t.id:
            ident.track = None
            ident.last_frame = t.last_frame
            ident.last_pos = t.pos.copy()

    def _reserved(self) -> set[int]:
        """Identities of pending contact groups."""
        return {m.identity for g in self.groups.values() for m in g["members"]}

    def _colour(self, t: _Track) -> np.ndarray:
        """The clothing colour a track's person should have: its identity's while a contact
        decision is pending (the continuation's own rows may be either person's), else its own
        (shared with its identity once resolved)."""
        if t.group is not None and t.identity is not None:
            return self.identities[t.identity].look.mean()
        return t.look.mean()

    @staticmethod
    def _by_colour(cands: list[_Candidate], colours: list[float]) -> tuple["_Identity | None", bool]:
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

    def _resolve(self, t: _Track, resolved: dict[int, int | None], ended: list[TrackEnd], final: bool = False) -> bool:
        """Give a tentative track its identity (see the module docstring). Returns False (and
        leaves it tentative) while an identity it could be is waiting for a contact group's
        decision, unless ``final`` (the track ends): then those identities are left out."""
        s = self.settings
        self._flush(t)
        mine = t.hist.medians()
        mine_look = t.look.mean()
        live = {x.id: x for x in self.tracks}
        reserved = self._reserved()
        cands: list[_Candidate] = []
        colours = []  # clothing-colour distance to every identity it could be or is followed now
        for ident in self.identities.values():
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
                self._flush(other)
                last_frame, last_pos = other.last_3d_frame, other.pos
            else:
                last_frame, last_pos = ident.last_frame, ident.last_pos
            if last_frame >= t.first_frame:
                continue
            gap_s = (t.first_frame - last_frame) / self.fps
            reach = s.relink_max_speed_m_s * gap_s + s.track_gate_m
            if np.linalg.norm((t.first_pos - last_pos)[:2]) > reach:
                continue
            cands.append((signature_distance(mine, ident.hist.medians()), ident, gap_s, colour))
        choice, someone_new = self._by_colour(cands, colours)
        valid = sorted(
            [c for c in cands if np.isfinite(c[0]) and c[0] <= s.relink_max_signature_m],
            key=lambda c: (c[0], c[1].number),
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
        if choice is None and cands and s.expected_workers and len(self.identities) >= s.expected_workers:
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
            choice = _Identity(self.next_identity, LimbHistogram(), t.last_frame, t.pos.copy(), None)
            self.identities[choice.number] = choice
            self.next_identity += 1
        elif choice.track is not None:
            # The identity's coasting track ends here: the new track is the same person.
            old = live[choice.track]
            self.tracks = [x for x in self.tracks if x.id != old.id]
            self._flush(old)
            ended.append(TrackEnd(old.id, old.first_frame, old.last_frame, old.identity))
        choice.hist.merge(t.hist)
        t.hist = choice.hist
        choice.look.merge(t.look)
        t.look = choice.look
        choice.track = t.id
        t.identity = choice.number
        resolved[t.id] = choice.number
        return True

    # --- contacts -----------------------------------------------------------------------------------

    def _contacts(self, f: int, dt1: float, ended: list[TrackEnd]) -> None:
        """Split confirmed tracks that come within contact_distance_m of each other.

        Two people this close (passing each other, or a simulated body passing through another)
        can swap tracks without any geometric sign. Each track of a contact group ends here and a
        continuation carries on with the same identity, *provisionally*: its rows wait, and its
        limb lengths are collected apart. Once the live continuations have relink_window_s of 3D
        data and a comparable limb (or after GROUP_MAX_WAIT windows), :meth:`_resolve_group`
        confirms the identities or crosses them over, if the body-measurement signatures say so
        by relink_margin_m. A continuation that ends first keeps its identity.
        """
        s = self.settings
        for t in self.tracks:
            if t.no_split_with:
                near = set()
                for o in self.tracks:
                    if (
                        o.identity in t.no_split_with
                        and np.linalg.norm((o.pos - t.pos)[:2]) < 1.5 * s.contact_distance_m
                    ):
                        near.add(o.identity)
                t.no_split_with = near
        # Only tracks seen in this frame: an extrapolated coasting track proves no contact.
        live = [t for t in self.tracks if t.identity is not None and t.group is None and t.last_update_frame == f]
        if len(live) < 2:
            return
        pos = np.array([t.pos[:2] for t in live])
        d = np.linalg.norm(pos[:, None] - pos[None], axis=-1)
        close = d < s.contact_distance_m
        np.fill_diagonal(close, False)
        if close.any() and APPEARANCE_APART > 0:
            # People in clearly different clothes are told apart frame by frame by the colour
            # term of the matching: no provisional split.
            colours = np.array([self._colour(t) for t in live])
            apart = appearance_distance(colours[:, None], colours[None]) >= APPEARANCE_APART
            close &= ~apart
        for a in range(len(live)):
            for b in range(len(live)):
                if close[a, b] and live[b].identity in live[a].no_split_with:
                    close[a, b] = False
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
        groups: dict[int, list[_Track]] = {}
        for i in range(len(live)):
            if close[i].any():
                groups.setdefault(root(i), []).append(live[i])
        gone = set()
        new_tracks = []
        for members in groups.values():
            gid = self.next_group
            self.next_group += 1
            conts = []
            for t in members:
                self._flush(t)
                ended.append(TrackEnd(t.id, t.first_frame, t.last_frame, t.identity))
                gone.add(t.id)
                c = _Track(
                    id=self.next_track,
                    first_frame=f + 1,
                    first_pos=t.pos.copy(),
                    pos=t.pos.copy(),
                    vel=t.vel.copy(),
                    last_frame=t.last_frame,
                    last_update_frame=t.last_update_frame,
                    last_3d_frame=t.last_3d_frame,
                    identity=t.identity,
                    group=gid,
                )
                self.next_track += 1
                assert t.identity is not None  # only confirmed tracks are split
                self.identities[t.identity].track = c.id
                conts.append(c)
            self.groups[gid] = {"members": conts, "start": f + 1, "separated": None}
            new_tracks += conts
        self.tracks = [t for t in self.tracks if t.id not in gone] + new_tracks

    def _live_members(self, gid: int) -> list[_Track]:
        g = self.groups[gid]
        alive = {t.id for t in self.tracks}
        return [m for m in g["members"] if m.id in alive]

    def _watch_separation(self, f: int) -> None:
        """Note when the live continuations of each pending group are all apart (1.5 x
        contact_distance_m): from then on their limb lengths are collected apart from what was
        measured while they were together (that may belong to either)."""
        far = 1.5 * self.settings.contact_distance_m
        for gid, g in self.groups.items():
            if g["separated"] is not None:
                continue
            live = self._live_members(gid)
            if len(live) >= 2:
                pos = np.array([m.pos[:2] for m in live])
                d = np.linalg.norm(pos[:, None] - pos[None], axis=-1)
                np.fill_diagonal(d, np.inf)
                if d.min() < far:
                    continue
            g["separated"] = f
            for m in g["members"]:
                self._flush(m)
                m.hist_before = m.hist
                m.hist = LimbHistogram()
                m.look_before = m.look
                m.look = Look()
                m.frames_3d = 0

    def _member_medians(self, m: _Track) -> np.ndarray:
        """Limb medians of a continuation: since the separation, or (when that has no
        comparable data yet) everything since the contact."""
        self._flush(m)
        med = m.hist.medians()
        if np.isfinite(med).any() or m.hist_before is None:
            return med
        both = LimbHistogram()
        both.merge(m.hist)
        both.merge(m.hist_before)
        return both.medians()

    @staticmethod
    def _member_look(m: _Track) -> np.ndarray:
        """Mean colour of a continuation: since the separation, else since the contact."""
        look = m.look.mean()
        if np.isfinite(look).any() or m.look_before is None:
            return look
        both = Look()
        both.merge(m.look)
        both.merge(m.look_before)
        return both.mean()

    def _group_ready(self, gid: int, f: int) -> bool:
        """Decide a contact group once its people have separated and every live continuation
        has relink_window_s of 3D data since, with signatures that can be compared (a limb known
        in the continuation and in every identity of the group); or after GROUP_MAX_WAIT windows
        since the separation, GROUP_MAX_WAIT_S since the contact, or when no continuation is
        alive any more."""
        g = self.groups[gid]
        live = self._live_members(gid)
        if not live or (f - g["start"]) >= GROUP_MAX_WAIT_S * self.fps:
            return True
        if g["separated"] is None:
            return False
        if any(m.frames_3d < self._window_frames for m in live):
            return False
        if any(m.frames_3d >= GROUP_MAX_WAIT * self._window_frames for m in live):
            return True
        members = g["members"]
        cost = _group_costs(
            [self._member_medians(m) for m in members],
            [self.identities[k].hist.medians() for k in _group_identities(members)],
        )
        return bool(np.isfinite(cost[[members.index(m) for m in live]]).all(axis=1).all())

    def _resolve_group(self, gid: int, resolved: dict[int, int | None]) -> None:
        """Confirm or cross over the identities of a contact group's continuations (live or
        ended), then make them final."""
        s = self.settings
        g = self.groups.pop(gid)
        members: list[_Track] = g["members"]
        idents = _group_identities(members)
        cost = _group_costs(
            [self._member_medians(m) for m in members], [self.identities[k].hist.medians() for k in idents]
        )
        colour = np.array(
            [
                [float(appearance_distance(self._member_look(m), self.identities[k].look.mean())) for k in idents]
                for m in members
            ]
        )
        margin = s.relink_margin_m
        if np.isfinite(colour).all(axis=1).sum() >= 2:
            # The clothes decide where they are known (limb lengths from a pose network scatter
            # more than workers differ: docs/reconstruction.md, 3. Identities).
            cost, margin = colour, APPEARANCE_MARGIN
        comparable = np.flatnonzero(np.isfinite(cost).all(axis=1))
        final = list(idents)
        if len(comparable) >= 2:
            sub = cost[np.ix_(comparable, comparable)]
            r, c = linear_sum_assignment(sub)
            now = float(np.trace(sub))
            new = float(sub[r, c].sum())
            changed = int(np.sum(r != c))
            if changed and new + margin * changed <= now:
                for i, j in zip(r, c):
                    final[comparable[i]] = idents[comparable[j]]
        alive = {t.id for t in self.tracks}
        for m, ident_no in zip(members, final):
            m.identity = ident_no
            ident = self.identities[ident_no]
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
