"""One frame of the tracker (ergopose.recon.tracking): every live track predicts its body centre,
the people seen by two or more cameras and then those seen by one are matched to the tracks, and
a matched track follows its person with an alpha-beta filter (steps 1-3 of the tracker's
docstring; docs/reconstruction.md, 3. Identities)."""

from __future__ import annotations

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.geometry.rays import ray_at_height
from ergopose.pose.appearance import appearance_distance
from ergopose.recon.associate import gated_assignment
from ergopose.recon.track_records import Track
from ergopose.recon.track_signatures import APPEARANCE_GATE, APPEARANCE_SIGMA

#: Alpha-beta gains of the centre filter (position, velocity). The triangulated centre jumps by
#: up to ~0.2 m when the set of visible torso joints changes (a bent-over worker's shoulders lie
#: ahead of the hips), so the filter follows it only partly, and a single jump moves the velocity
#: by at most BETA * VELOCITY_RESIDUAL_CAP / dt.
ALPHA = 0.5
BETA = 0.1
VELOCITY_RESIDUAL_CAP_M = 0.15
#: Largest speed (m/s) the centre filter keeps (a walking or hurrying person).
MAX_SPEED_M_S = 3.0


def match_gain(cost: np.ndarray, gate: np.ndarray, fresh_gate: float) -> FloatArray:
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


def colour_cost(colour: np.ndarray) -> np.ndarray:
    """Negative log-likelihood of clothing-colour distances (APPEARANCE_SIGMA); 0 where unknown."""
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(colour), 0.5 * (colour / APPEARANCE_SIGMA) ** 2, 0.0)


def predict(
    tracks: list[Track], f: int, dt1: float, gate0: float, growth: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step 1 for T tracks in frame f: (T, 3) predicted centres (constant velocity since the
    last update), (T,) seconds since the last update, (T,) gates in metres (``gate0`` plus
    ``growth`` per second unseen beyond one frame)."""
    pos = np.array([t.pos for t in tracks])
    vel = np.array([t.vel for t in tracks])
    gap = np.array([f - t.last_update_frame for t in tracks], dtype=np.float64) * dt1
    unseen = np.array([f - t.last_frame for t in tracks], dtype=np.float64) * dt1
    pred = pos + vel * gap[:, None]
    gate = gate0 + growth * np.maximum(unseen - dt1, 0.0)
    return pred, gap, gate


def match_3d(
    pred: np.ndarray,
    gate: np.ndarray,
    gate0: float,
    centres_world: np.ndarray,
    track_colours: np.ndarray,
    looks: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Step 2: (track, person) pairs of T tracks and R people seen by two or more cameras.

    pred, gate: (T, 3), (T,) from :func:`predict`; centres_world: (R, 3) the people's centres;
    track_colours: (T, APPEARANCE_DIMS) the colour each track's person should have; looks:
    (R, APPEARANCE_DIMS) the people's colours. Returns (track indices, person indices)."""
    cost = np.linalg.norm(pred[:, None, :2] - centres_world[None, :, :2], axis=-1)
    colour = appearance_distance(track_colours[:, None], looks[None])
    # The colour gate only where the geometry is ambiguous (a person within the gates
    # of two tracks, or a track with two people within its gate): a worker alone keeps
    # the track while a carried carton or the light changes the colour seen.
    within = cost <= gate[:, None]
    ambiguous = (within.sum(axis=0) >= 2)[None, :] | (within.sum(axis=1) >= 2)[:, None]
    cost = np.where(ambiguous & (colour > APPEARANCE_GATE), np.inf, cost)
    gain = match_gain(cost, gate, gate0) - colour_cost(colour)
    return gated_assignment(cost, gate[:, None], np.maximum(gain, 1e-3))


def match_single_view(
    pred: np.ndarray,
    gate: np.ndarray,
    gate0: float,
    single_view_gate: float,
    origin_world: np.ndarray,
    ray_world: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step 3: (track, person) pairs of T tracks left unmatched and R people seen by one camera.

    pred, gate: (T, 3), (T,) of those tracks; origin_world, ray_world: (R, 3) the people's torso
    rays. Returns (track indices, person indices, (T, R, 3) the points where each ray reaches
    each track's predicted height)."""
    hit, along = ray_at_height(origin_world, ray_world, pred[:, 2])  # (T, R, 3) ray point at the track's height
    diff = hit - pred[:, None, :]
    cost = np.linalg.norm(diff[..., :2], axis=-1)
    cost = np.where(along > 0, cost, np.inf)
    sv_gate = single_view_gate + gate - gate0
    ti, ri = gated_assignment(cost, sv_gate[:, None], match_gain(cost, sv_gate, single_view_gate))
    return ti, ri, hit


def update_track(t: Track, pred: np.ndarray, meas: np.ndarray, gap_s: float, f: int, fps: float) -> None:
    """Alpha-beta update of a track's centre; after a gap of several frames the prediction
    is worth little, so the position follows the measurement (gain 1 - (1 - ALPHA)^frames)
    and the velocity moves half way to the mean velocity over the gap."""
    frames = max(1, int(round(gap_s * fps)))
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
