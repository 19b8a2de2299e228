"""A shift in chunks: tracking -> identities -> smoothing -> rows of the tracks table.

:class:`ShiftReconstruction` takes the People3D of consecutive chunks of frames
(:meth:`ShiftReconstruction.push`) and returns the finished :class:`TrackFrames` as soon as
they are final; :meth:`ShiftReconstruction.finish` returns the rest. The object is the state
carried from chunk to chunk (tracker, rows whose identity is not decided yet, the smoother's
window) and can be pickled between chunks. Memory stays bounded: rows leave as soon as their
block of frames is smoothed.

Why the result does not depend on the chunking: the tracker works frame by frame; a row is
handed on only once its identity is final (the tracker's resolved frontier); the smoother's
backward pass runs for blocks of ``BLOCK_FRAMES`` frames on a fixed grid of frame indices and
starts ``smoother_lag_s`` after each block's end; limb-length targets of the bone constraint
are the medians over everything filtered before the block is smoothed. A test processes the
same frames in one piece and in uneven chunks and gets identical tables.

Rows of the table: one per worker and frame while the worker's track is alive (from its first
to its last observation, coasting frames in between included), 33 joints each.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.errors import InputError
from ergopose.geometry.camera import Camera
from ergopose.keypoints import LIMB_INDEX, NUM_JOINTS
from ergopose.recon.bodyfit import ShiftBodies, hold_and_flag
from ergopose.recon.records import People3D
from ergopose.recon.settings import ReconSettings
from ergopose.recon.smoothing import KalmanRTS
from ergopose.recon.triangulate import triangulate_observations
from ergopose.recon.track_records import TrackingResult, identity_name
from ergopose.recon.track_signatures import LimbHistogram, limb_lengths
from ergopose.recon.tracking import Tracker

#: Frames per smoothing block (the grid is frame // BLOCK_FRAMES).
BLOCK_FRAMES = 1024
#: Gauss-Seidel sweeps of the bone-length constraint.
BONE_ITERATIONS = 10

_SER = NUM_JOINTS * 3


@dataclass(frozen=True, eq=False)
class TrackFrames:
    """Reconstructed workers, one row per worker and frame (the wide form of the tracks table).

    n rows, J = 33 joints.

    worker: (n,) int64 identity number (name: ``identity_name(worker)`` = "worker_<n>").
    frame: (n,) int64; time_s: (n,) float64 = frame / fps. Rows sorted by frame, then worker.
    points_world: (n, J, 3) final positions, metres: smoothed (``smoothed`` True) or the raw
        triangulation; NaN where nothing is known (not reconstructed and not gap-filled).
    raw_points_world: (n, J, 3) the triangulation before smoothing; NaN where not triangulated.
    confidence: (n, J) mean 2D confidence of the cameras used (0 where views = 0).
    reprojection_error_px: (n, J) RMS reprojection error of the raw point (NaN where none).
    views: (n, J) int8 cameras whose observation of the joint was used (2 = triangulated,
        1 = one camera only, no 3D point; 0 = none).
    gap_filled: (n, J) bool, position filled by the smoother inside a short gap.
    gated: (n, J) bool, the raw point was ignored by the smoother as an outlier.
    smoothed: bool, whether points_world comes from the smoother.
    lens_angle_deg: (n, J) the larger angle (degrees) between the two cameras' axes and the
        direction to the joint's final position; where that is NaN, to the worker's body centre
        (tracker estimate), so every row has a lens region. NaN without cameras.
    inferred: (n, J) bool, the position was placed by the body model (fewer than two cameras
        saw the joint with min_confidence: segment lengths, previous pose, one camera's ray).
    limited: (n, J) bool, a joint limit of the body model held the joint: the body fit or the
        smoothed position passed the limit (bodyfit.hold_and_flag, bodyfit.LIMIT_HELD_JOINTS).
    std_world: (n, J, 3) standard deviation (metres) of each coordinate of points_world (the
        smoother's, else the body fit's or the triangulation's); NaN where points_world is NaN.
    """

    worker: np.ndarray
    frame: np.ndarray
    time_s: np.ndarray
    points_world: np.ndarray
    raw_points_world: np.ndarray
    confidence: np.ndarray
    reprojection_error_px: np.ndarray
    views: np.ndarray
    gap_filled: np.ndarray
    gated: np.ndarray
    smoothed: bool
    lens_angle_deg: np.ndarray
    inferred: np.ndarray | None = None
    std_world: np.ndarray | None = None
    limited: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.frame)
        if self.inferred is None:
            object.__setattr__(self, "inferred", np.zeros((n, NUM_JOINTS), bool))
        if self.limited is None:
            object.__setattr__(self, "limited", np.zeros((n, NUM_JOINTS), bool))
        if self.std_world is None:
            object.__setattr__(self, "std_world", np.full((n, NUM_JOINTS, 3), np.nan))

    def __len__(self) -> int:
        return int(self.frame.shape[0])

    @classmethod
    def concat(cls, parts: list["TrackFrames"]) -> "TrackFrames":
        parts = [p for p in parts if p is not None]
        if not parts:
            return _empty_frames(True)
        names = (
            "worker",
            "frame",
            "time_s",
            "points_world",
            "raw_points_world",
            "confidence",
            "reprojection_error_px",
            "views",
            "gap_filled",
            "gated",
            "inferred",
            "std_world",
            "limited",
        )
        kw = {n: np.concatenate([getattr(p, n) for p in parts]) for n in names}
        kw["lens_angle_deg"] = np.concatenate([p.lens_angle_deg for p in parts])
        return cls(smoothed=parts[0].smoothed, **kw)

    def worker_rows(self, worker: int) -> "TrackFrames":
        sel = self.worker == worker
        return TrackFrames(**{n: (v[sel] if isinstance(v, np.ndarray) else v) for n, v in self.__dict__.items()})

    @property
    def workers(self) -> list[int]:
        return sorted(int(w) for w in np.unique(self.worker))


def _empty_frames(smoothed: bool) -> TrackFrames:
    J = NUM_JOINTS
    return TrackFrames(
        worker=np.zeros(0, np.int64),
        frame=np.zeros(0, np.int64),
        time_s=np.zeros(0),
        points_world=np.zeros((0, J, 3)),
        raw_points_world=np.zeros((0, J, 3)),
        confidence=np.zeros((0, J)),
        reprojection_error_px=np.zeros((0, J)),
        views=np.zeros((0, J), np.int8),
        gap_filled=np.zeros((0, J), bool),
        gated=np.zeros((0, J), bool),
        smoothed=smoothed,
        lens_angle_deg=np.zeros((0, J)),
    )


class _Rows:
    """Columnar rows (dict of arrays with a common first axis) kept sorted by frame.

    New batches are merged (and sorted, stably) once when rows are next read; reading a range
    of frames and dropping the rows before a frame are binary searches and slices, so a long
    chunk is not copied once per smoothing block.
    """

    def __init__(self) -> None:
        self.data: dict[str, np.ndarray] | None = None
        self.new: list[dict[str, np.ndarray]] = []

    def add(self, batch: dict[str, np.ndarray]) -> None:
        if len(batch["frame"]):
            self.new.append(batch)

    def all(self) -> dict[str, np.ndarray] | None:
        if self.new:
            parts = ([self.data] if self.data is not None else []) + self.new
            keys = parts[0].keys()
            cat = {k: np.concatenate([p[k] for p in parts]) for k in keys}
            frame = cat["frame"]
            if len(frame) > 1 and np.any(frame[1:] < frame[:-1]):
                order = np.argsort(frame, kind="stable")
                cat = {k: v[order] for k, v in cat.items()}
            self.data = cat
            self.new = []
        return self.data

    def split(self, keep: np.ndarray) -> dict[str, np.ndarray]:
        """Keep rows where ``keep`` (over :meth:`all`), return the others."""
        rows = self.all()
        assert rows is not None  # called on rows that were added
        out = {k: v[~keep] for k, v in rows.items()}
        kept = {k: v[keep] for k, v in rows.items()}
        self.data = kept if len(kept["frame"]) else None
        return out

    def range(self, f0: int, f1: int) -> dict[str, np.ndarray] | None:
        rows = self.all()
        if rows is None:
            return None
        i0, i1 = np.searchsorted(rows["frame"], [f0, f1])
        return {k: v[i0:i1] for k, v in rows.items()}

    def drop_before(self, f: int) -> None:
        rows = self.all()
        if rows is None:
            return
        i0 = int(np.searchsorted(rows["frame"], f))
        if i0 == len(rows["frame"]):
            self.data = None
        elif i0:
            self.data = {k: v[i0:] for k, v in rows.items()}


class ShiftReconstruction:
    """Tracking, identities and smoothing of a shift, chunk by chunk (see module docstring).

    settings: ReconSettings; fps: frame rate of the session; cameras: the two Camera objects
    (for lens angles; None leaves lens_angle_deg NaN); first_frame: the first frame index.
    """

    def __init__(
        self,
        settings: ReconSettings | None = None,
        fps: float = 12.0,
        cameras: Sequence[Camera] | None = None,
        first_frame: int = 0,
        block_frames: int = BLOCK_FRAMES,
    ) -> None:
        self.settings = settings or ReconSettings()
        self.fps = float(fps)
        self.cameras = tuple(cameras) if cameras is not None else None
        self.tracker = Tracker(self.settings, self.fps)
        self.block = int(block_frames)
        self.lag = int(np.ceil(self.settings.smoother_lag_s * self.fps))
        max_gap = int(np.floor(self.settings.max_fill_gap_s * self.fps + 1e-9))
        if self.lag <= max_gap + 1:
            raise InputError("smoother_lag_s must be longer than max_fill_gap_s", field="smoother_lag_s")
        self.next_frame = int(first_frame)
        self.track_identity: dict[int, int | None] = {}
        self.track_last: dict[int, int] = {}
        self.pending_obs = _Rows()
        self.pending_cent = _Rows()
        self.obs = _Rows()
        self.cent = _Rows()
        self.slots: dict[int, int] = {}  # identity number -> slot (series of the smoother)
        self.n_slots = 0
        self.free_slots: list[int] = []  # slots of identities gone for good (ascending)
        # The body fit is robust itself (Huber loss, segment lengths, previous pose) and its
        # variance says how far to trust each joint, so its output is not gated again: the gate's
        # restarts left joints without a position (oracle, 30 s, 4 workers: 2.5 % of the
        # joint-frames and up to 10 % of the frames of an angle lost).
        smoother_settings = self.settings.replace(outlier_gate_chi2=0.0) if self.settings.body_model else self.settings
        self.kalman = (
            KalmanRTS(0, self.fps, smoother_settings, first_frame=first_frame) if self.settings.smoothing else None
        )
        self.filtered_until = int(first_frame)  # frames before this went into the smoother
        self.block_start = int(first_frame)
        self.hists: dict[int, LimbHistogram] = {}
        self.bodies = ShiftBodies(self.settings, self.fps) if self.settings.body_model else None
        self.finished = False

    # --- public -----------------------------------------------------------------------------------

    def push(self, people: People3D, first_frame: int, stop_frame: int) -> TrackFrames:
        """Process frames first_frame <= f < stop_frame (the rows of ``people``); returns the rows
        that became final (possibly none)."""
        if self.finished:
            raise InputError("the shift was already finished", field="frames")
        if first_frame != self.next_frame:
            raise InputError(f"chunk starts at frame {first_frame}, expected {self.next_frame}", field="frames")
        res = self.tracker.update(people, first_frame, stop_frame)
        self.next_frame = stop_frame
        self._take(people, res)
        return self._advance(self.tracker.resolved_frontier(), final=False)

    def finish(self) -> TrackFrames:
        """End of the shift: end every track and return the remaining rows."""
        if self.finished:
            return _empty_frames(self.settings.smoothing)
        res = self.tracker.finish()
        self._take(None, res)
        self.finished = True
        return self._advance(self.next_frame, final=True)

    def stature_estimates(self) -> dict[str, float]:
        """Estimated stature (metres) per worker name, from its limb-length medians."""
        return self.tracker.stature_estimates()

    def limb_medians(self) -> dict[str, np.ndarray]:
        """(L,) median raw limb lengths per worker name (keypoints.LIMBS order)."""
        return self.tracker.identity_signatures()

    # --- rows in ----------------------------------------------------------------------------------

    def _take(self, people: People3D | None, res: TrackingResult) -> None:
        for e in res.ended:
            self.track_last[e.track] = e.last_frame
        self.track_identity.update(res.resolved)
        for ident in res.resolved.values():
            if ident is None:
                continue
            if ident not in self.hists:
                self.hists[ident] = LimbHistogram()
            if ident not in self.slots:
                if self.free_slots:  # a slot whose series have all expired: they restart at the next measurement
                    self.slots[ident] = self.free_slots.pop(0)
                else:
                    self.slots[ident] = self.n_slots
                    self.n_slots += 1
                    if self.kalman is not None:
                        self.kalman.add_series(_SER)
        if people is not None and len(people):
            sel = res.track >= 0
            m = int(sel.sum())
            # People3D fills the observation fields (zeros / NaN for rows made from 3D points).
            assert people.obs_projection is not None and people.obs_pixels_view is not None
            assert people.obs_confidence is not None
            self.pending_obs.add(
                {
                    "frame": people.frame[sel],
                    "track": res.track[sel],
                    "points": people.points_world[sel],
                    "conf": people.confidence[sel],
                    "err": people.reprojection_error_px[sel],
                    "views": people.views[sel],
                    "var": people.variance_world[sel],
                    "P": people.obs_projection[sel],
                    "px": people.obs_pixels_view[sel],
                    "oc": people.obs_confidence[sel],
                    "ungated": triangulate_observations(people)[sel],
                    "fit": np.full((m, NUM_JOINTS, 3), np.nan),
                    "fit_var": np.full((m, NUM_JOINTS, 3), np.nan),
                    "inferred": np.zeros((m, NUM_JOINTS), bool),
                    "limited": np.zeros((m, NUM_JOINTS), bool),
                    "fit_err": np.full((m, NUM_JOINTS), np.nan),
                }
            )
        if len(res.centres):
            c = res.centres
            self.pending_cent.add(
                {"frame": c[:, 0].astype(np.int64), "track": c[:, 1].astype(np.int64), "centre": c[:, 2:].copy()}
            )
        for pend, dest in ((self.pending_obs, self.obs), (self.pending_cent, self.cent)):
            rows = pend.all()
            if rows is None:
                continue
            idents = self._identities_of(rows["track"])
            decided = idents != -2
            moved = pend.split(~decided)
            mi = idents[decided]
            keep = mi >= 0
            if "centre" in moved:
                # Only frames up to the track's last observation belong to it.
                last = np.array(
                    [self.track_last.get(int(t), np.iinfo(np.int64).max) for t in moved["track"]], dtype=np.int64
                )
                keep &= moved["frame"] <= last
            batch = {k: v[keep] for k, v in moved.items()}
            batch["identity"] = mi[keep]
            dest.add(batch)
        # Centre records of ended tracks beyond their last observation (already moved earlier).
        rows = self.cent.all()
        if rows is not None and res.ended:
            last = np.array(
                [self.track_last.get(int(t), np.iinfo(np.int64).max) for t in rows["track"]], dtype=np.int64
            )
            bad = rows["frame"] > last
            if bad.any():
                self.cent.split(~bad)

    def _identities_of(self, tracks: np.ndarray) -> np.ndarray:
        """Identity of each track id: the number, -3 if dropped, -2 if not decided yet."""
        uniq, inv = np.unique(tracks, return_inverse=True)
        vals = []
        for t in uniq:
            if int(t) not in self.track_identity:
                vals.append(-2)
            else:
                v = self.track_identity[int(t)]
                vals.append(-3 if v is None else v)
        return np.array(vals, dtype=np.int64)[inv]

    # --- smoothing and output -----------------------------------------------------------------------

    def _advance(self, frontier: int | None, final: bool) -> TrackFrames:
        if frontier is None:
            frontier = self.next_frame
        frontier = min(frontier, self.next_frame)
        out = []
        while True:
            b0 = self.block_start
            b1 = (b0 // self.block + 1) * self.block
            need = b1 + self.lag
            target = min(frontier, need)
            if target > self.filtered_until:
                self._forward(self.filtered_until, target)
            if self.filtered_until >= need:
                out.append(self._emit(b0, b1))
            elif final and b0 < frontier:
                out.append(self._emit(b0, min(b1, frontier)))
            else:
                break
        return TrackFrames.concat(out) if out else _empty_frames(self.settings.smoothing)

    def _forward(self, f0: int, f1: int) -> None:
        rows = self.obs.range(f0, f1)
        if rows is not None and len(rows["frame"]):
            if self.bodies is not None:
                self.bodies.fit_range(rows, f0, f1)
            else:
                rows["fit"][...] = rows["points"]
                rows["fit_var"][...] = rows["var"]
                rows["inferred"][...] = rows["views"] < 2
            lengths = limb_lengths(rows["points"])
            for ident in np.unique(rows["identity"]):
                self.hists[int(ident)].add(lengths[rows["identity"] == ident])
        if self.kalman is not None:
            S = self.kalman.S
            z = np.full((f1 - f0, S // _SER, NUM_JOINTS, 3), np.nan)
            var = np.full((f1 - f0, S // _SER, NUM_JOINTS, 3), np.nan)
            if rows is not None and len(rows["frame"]):
                slot = np.array([self.slots[int(i)] for i in rows["identity"]], dtype=np.int64)
                t = rows["frame"] - f0
                z[t, slot] = rows["fit"]
                var[t, slot] = rows["fit_var"]
            with np.errstate(invalid="ignore"):
                self.kalman.forward(z.reshape(f1 - f0, S), var.reshape(f1 - f0, S))
        self.filtered_until = f1

    def _free_idle_slots(self) -> None:
        """Give back the smoother slots of identities that have no rows left and whose series have
        all expired (no accepted measurement for longer than the fill gap before the filtered
        frames): their filter state restarts at the next measurement anyway, so a later identity,
        or the same one re-linked after a long gap, can take the slot with identical results.
        Without this the smoother would carry every identity of the shift to the end: memory and
        time per frame would grow with the shift."""
        if self.kalman is None or not self.slots:
            return
        live = set()
        for rows in (self.obs.all(), self.cent.all()):
            if rows is not None:
                live.update(np.unique(rows["identity"]).tolist())
        limit = self.filtered_until - self.kalman.max_gap - 1
        last = self.kalman.last_meas.reshape(-1, _SER).max(axis=1)  # per slot
        idle = [i for i, sl in self.slots.items() if i not in live and last[sl] < limit]
        for ident in idle:
            self.free_slots.append(self.slots.pop(ident))
        self.free_slots.sort()

    def _emit(self, b0: int, b1: int) -> TrackFrames:
        out = self._emit_rows(b0, b1)
        self._free_idle_slots()
        return out

    def _emit_rows(self, b0: int, b1: int) -> TrackFrames:
        smoothing = self.kalman is not None
        cent = self.cent.range(b0, b1)
        obs = self.obs.range(b0, b1)
        sm = None
        if self.kalman is not None:
            sm = self.kalman.smooth(stop=b1)
        self.block_start = b1
        self.obs.drop_before(b1)
        self.cent.drop_before(b1)
        if cent is None or not len(cent["frame"]):
            return _empty_frames(smoothing)
        order = np.lexsort((cent["identity"], cent["frame"]))
        frame = cent["frame"][order]
        worker = cent["identity"][order]
        centre = cent["centre"][order]
        n = len(frame)
        J = NUM_JOINTS
        raw = np.full((n, J, 3), np.nan)
        conf = np.zeros((n, J))
        err = np.full((n, J), np.nan)
        views = np.zeros((n, J), np.int8)
        fit = np.full((n, J, 3), np.nan)
        fit_var = np.full((n, J, 3), np.nan)
        inferred = np.zeros((n, J), bool)
        limited = np.zeros((n, J), bool)
        if obs is not None and len(obs["frame"]):
            key_rows = frame * (1 << 20) + worker
            key_obs = obs["frame"] * (1 << 20) + obs["identity"]
            pos = np.searchsorted(key_rows, key_obs)
            ok = (pos < n) & (key_rows[np.minimum(pos, n - 1)] == key_obs)
            p = pos[ok]
            raw[p] = obs["points"][ok]
            conf[p] = obs["conf"][ok]
            err[p] = obs["err"][ok]
            views[p] = obs["views"][ok]
            fit[p] = obs["fit"][ok]
            fit_var[p] = obs["fit_var"][ok]
            inferred[p] = obs["inferred"][ok]
            limited[p] = obs["limited"][ok]
        gap = np.zeros((n, J), bool)
        gated = np.zeros((n, J), bool)
        if sm is not None:
            slot = np.array([self.slots[int(i)] for i in worker], dtype=np.int64)
            t = frame - b0
            val = sm.value.reshape(len(sm.frame), -1, J, 3)
            pts = val[t, slot]
            std = np.sqrt(sm.variance.reshape(len(sm.frame), -1, J, 3)[t, slot])
            gap = sm.gap_filled.reshape(len(sm.frame), -1, J, 3)[t, slot].all(axis=-1)
            gated = sm.gated.reshape(len(sm.frame), -1, J, 3)[t, slot].any(axis=-1)
            if self.settings.bone_length_constraint:
                varj = sm.variance.reshape(len(sm.frame), -1, J, 3)[t, slot].mean(axis=-1)
                targets = (
                    np.stack([self.hists[int(w)].medians() for w in worker]) if n else np.zeros((0, len(LIMB_INDEX)))
                )
                pts = constrain_bone_lengths(pts, varj, targets)
        else:
            pts = fit.copy()
            std = np.sqrt(fit_var)
        if self.bodies is not None:  # the smoother does not know the body model's joint limits
            pts, passed = hold_and_flag(pts, std * std, self.bodies.options)
            limited |= passed
        inferred |= gap
        angle = lens_angles_deg(self.cameras, pts, centre)
        return TrackFrames(
            worker=worker,
            frame=frame,
            time_s=frame / self.fps,
            points_world=pts,
            raw_points_world=raw,
            confidence=conf,
            reprojection_error_px=err,
            views=views,
            gap_filled=gap,
            gated=gated,
            smoothed=smoothing,
            lens_angle_deg=angle,
            inferred=inferred & np.isfinite(pts).all(axis=-1),
            std_world=std,
            limited=limited & np.isfinite(pts).all(axis=-1),
        )


def constrain_bone_lengths(
    points: np.ndarray, variance: np.ndarray, targets: np.ndarray, iterations: int = BONE_ITERATIONS
) -> np.ndarray:
    """Move joints so that each limb (keypoints.LIMBS) gets its target length.

    points: (n, 33, 3); variance: (n, 33) positional variance per joint (a joint moves in
    proportion to its variance); targets: (n, L) target lengths (NaN = leave the limb alone).
    Gauss-Seidel over the limbs, ``iterations`` sweeps; NaN joints stay NaN and are not used.
    """
    X = points.copy()
    v = np.where(np.isfinite(variance) & (variance > 0), variance, np.nan)
    for _ in range(iterations):
        for li, (a, b) in enumerate(LIMB_INDEX):
            d = X[:, b] - X[:, a]
            length = np.linalg.norm(d, axis=-1)
            L = targets[:, li]
            wa, wb = v[:, a], v[:, b]
            ok = np.isfinite(length) & (length > 1e-9) & np.isfinite(L) & np.isfinite(wa) & np.isfinite(wb)
            if not ok.any():
                continue
            with np.errstate(invalid="ignore", divide="ignore"):
                corr = np.where(ok[:, None], ((length - L) / length)[:, None] * d, 0.0)
                fa = np.where(ok, wa / (wa + wb), 0.0)[:, None]
            X[:, a] += fa * corr
            X[:, b] -= (1.0 - fa) * corr
    return X


def lens_angles_deg(cameras: Sequence[Camera] | None, points: np.ndarray, centres: np.ndarray) -> FloatArray:
    """(n, 33) the larger angle (degrees) off the cameras' axes of each joint (or, where the
    joint is NaN, of the row's centre (n, 3)); NaN without cameras."""
    n = points.shape[0]
    if not cameras:
        return np.full((n, NUM_JOINTS), np.nan)
    P = np.where(np.isfinite(points).all(axis=-1, keepdims=True), points, centres[:, None, :])
    ang = np.stack([cam.theta_of_points_world(P) for cam in cameras])
    with np.errstate(invalid="ignore"):
        angles: FloatArray = np.degrees(np.max(ang, axis=0))
        return angles


def identity_names(workers: Iterable[int]) -> list[str]:
    return [identity_name(int(w)) for w in workers]
