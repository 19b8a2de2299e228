"""The tracker's records (ergopose.recon.tracking): a track, an identity, a track's end, what one
call of the tracker found, and the state the tracker carries from one chunk of frames to the
next, with the small operations every part of the tracker shares."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.errors import InputError
from ergopose.keypoints import LIMBS
from ergopose.recon.settings import ReconSettings
from ergopose.recon.track_signatures import LimbHistogram, Look

#: A tentative track (identity not decided yet) unseen for longer than this ends: a spurious
#: birth (the centre of a person jumped out of its track's gate for a frame) must not linger and
#: later take over the person from its real track.
TENTATIVE_MAX_COAST_S = 0.25


def identity_name(number: int) -> str:
    """The pseudonymous name of identity ``number`` (1-based): worker_1, worker_2, ..."""
    return f"worker_{number}"


@dataclass
class Track:
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
    recent_frames: list[int] = field(default_factory=list)  # frames of its colours of the last relink window
    recent_looks: list[np.ndarray] = field(default_factory=list)  # and those colours (track_colour_relink)


def continuation(t: Track, track_id: int, f: int, identity: int | None, group: int | None = None) -> Track:
    """A new track ``track_id`` that carries on the person of track ``t`` from frame f + 1: the
    same position, velocity and last observations, with ``identity`` (and contact ``group``)."""
    return Track(
        id=track_id,
        first_frame=f + 1,
        first_pos=t.pos.copy(),
        pos=t.pos.copy(),
        vel=t.vel.copy(),
        last_frame=t.last_frame,
        last_update_frame=t.last_update_frame,
        last_3d_frame=t.last_3d_frame,
        identity=identity,
        group=group,
    )


@dataclass
class Identity:
    number: int
    hist: LimbHistogram
    last_frame: int
    last_pos: np.ndarray
    track: int | None  # id of the live track following it, if any
    look: Look = field(default_factory=Look)


#: An identity a new track could be: (signature distance m, the identity, gap s, colour distance).
Candidate = tuple[float, Identity, float, float]


@dataclass(frozen=True)
class TrackEnd:
    """A track that ended: its id, first and last observed frame, and identity (None = dropped)."""

    track: int
    first_frame: int
    last_frame: int
    identity: int | None


@dataclass(frozen=True)
class TrackingResult:
    """What one call of :meth:`ergopose.recon.tracking.Tracker.update` found.

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


class TrackerState:
    """What the tracker carries from one chunk of frames to the next (it can be pickled): the
    live tracks, the identities, the pending contact groups and the counters; frame counts of
    the settings' durations at ``fps``; ``lengths``: the limb lengths of the current chunk's rows
    (a track's rows enter its histogram from there, :meth:`flush`)."""

    def __init__(self, settings: ReconSettings | None = None, fps: float = 12.0) -> None:
        if not (np.isfinite(fps) and fps > 0):
            raise InputError(f"frames per second must be positive, got {fps!r}", field="fps")
        self.settings = settings or ReconSettings()
        self.fps = float(fps)
        self.tracks: list[Track] = []
        self.identities: dict[int, Identity] = {}
        self.next_track = 0
        self.next_identity = 1
        self.next_frame: int | None = None
        s = self.settings
        self.coast_frames = s.max_coast_s * self.fps
        self.tentative_coast_frames = min(s.max_coast_s, TENTATIVE_MAX_COAST_S) * self.fps
        self.window_frames = max(1, int(round(s.relink_window_s * self.fps)))
        self.groups: dict[int, dict[str, Any]] = {}  # contact group id -> {"members", "start", "separated"}
        self.next_group = 0
        self.min_frames = int(round(s.min_track_s * self.fps))
        self.lengths: FloatArray = np.zeros((0, len(LIMBS)))

    def flush(self, t: Track) -> None:
        """Add a track's pending rows to its limb-length histogram."""
        if t.pending_rows:
            t.hist.add(self.lengths[np.array(t.pending_rows)])
            t.pending_rows = []

    def flush_all(self) -> None:
        for t in self.tracks:
            self.flush(t)

    def release(self, t: Track) -> None:
        """An ending track lets go of its identity (if it still holds it): lost since its last frame."""
        assert t.identity is not None
        ident = self.identities[t.identity]
        if ident.track == t.id:
            ident.track = None
            ident.last_frame = t.last_frame
            ident.last_pos = t.pos.copy()

    def reserved(self) -> set[int]:
        """Identities of pending contact groups."""
        return {m.identity for g in self.groups.values() for m in g["members"]}

    def colour(self, t: Track) -> np.ndarray:
        """The clothing colour a track's person should have: its identity's while a contact
        decision is pending (the continuation's own rows may be either person's), else its own
        (shared with its identity once resolved)."""
        if t.group is not None and t.identity is not None:
            return self.identities[t.identity].look.mean()
        return t.look.mean()
