"""A body model per worker, fitted to every camera's keypoints at once.

Each worker-frame is fitted as a whole body, not as a cloud of independent points: the 33
keypoints' world positions X (33, 3) minimise

    sum over cameras c, joints j   rho(|pi(P_c, X_j) - u_cj| / sigma_cj)        reprojection
  + sum over segments s            ((|D_s X| - L_s) / sigma_s)^2                  segment lengths
  + sum over joints j              |X_j - X_prev_j|^2 / sigma_t^2                 previous pose
  + sum over prior links e         |B_e X - T_e(X)|^2 / sigma_p^2                 pose prior
  + sum over foot points           (min(z, 0) / 0.02 m)^2                          floor
  + sum over limits l              (min(0, a_l . C_l X - b_l) / sigma_lim)^2       joint limits

- pi(P, X): the view's pinhole projection (the projection matrix each person's view comes
  with); sigma_cj = keypoint_sigma_px / max(confidence, 0.05) view pixels; rho is Huber's
  loss with its corner at ``fit_huber_k`` sigmas (iteratively reweighted). Every keypoint of
  every camera counts, weighted by its confidence: there is no hard confidence gate.
- Segments (:data:`SEGMENTS`): the limbs, the hands and feet, the face and a neck (mid-ears to
  mid-shoulders). L_s is the worker's own length: the median of its best-seen raw
  triangulations (keypoints above ``min_confidence`` in two cameras, reprojection-checked),
  refreshed once a second as the shift goes; sigma_s is the segment's natural play
  (:data:`SEGMENT_PLAY`). Before a segment has been seen, its length is a population
  proportion (:data:`PRIOR_LENGTH_VECTOR`) scaled to the worker's known segments, with 15 % play.
- The previous pose: the worker's fit of the previous frame it was seen in, with
  sigma_t = ``fit_temporal_sigma_m`` + ``fit_speed_m_s`` x the time between them.
  It carries joints that no camera sees and, with the segment lengths, lets one camera fix a
  body's depth.
- The pose prior T(X), articulated: each link B_e X of :data:`_PRIOR_LINKS` (mid-hip to the
  shoulders, upper arm, forearm, thigh, shank, ankle to heel and toe, mid-shoulder to each face
  point) points as in the neutral pose (:data:`TEMPLATE_BODY`) turned to the way the hips face
  -- or, for the head's links, turned with the current trunk -- with a wide sigma_p
  (``fit_pose_prior_sigma_m``). It only decides what nothing else decides (a new track's
  hidden legs; the head of a worker bent forward whose face no camera sees).
- The joint limits (:data:`LIMITS`): elbows and knees bend at most 150 and 155 deg, knees
  backwards at most 10 deg, the face turns at most 90 deg from the trunk's forward direction;
  one-sided, so a pose within them is not touched, with sigma_lim = ``fit_limit_sigma_m``.

Solved by a Levenberg-Marquardt iteration on the 99 unknowns of every row at once (the rows of a
frame are independent problems; numpy's batched solve). Why not scipy.optimize.least_squares:
each problem is small and dense (99 unknowns, a few hundred residuals) and there are hundreds of
thousands of them in a shift, one after the other (each frame starts from the previous one);
scipy's per-call overhead (~1 ms, Python-level residual callbacks) would dominate, while one
batched normal-equation solve per iteration handles all workers of a frame in ~50 microseconds.

The covariance of each joint is the 3 x 3 diagonal block of the inverse of the Gauss-Newton
normal matrix at the solution (residuals are in units of their sigmas), so a joint seen sharply
by two cameras has a few millimetres and a joint carried by the previous pose has decimetres.
A joint is *inferred* when fewer than two cameras saw it with ``min_confidence``: its position
comes from the model (segment lengths, previous pose, one camera's ray) rather than from
triangulation.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.geometry.rigid import kabsch
from ergopose.keypoints import JOINT_INDEX, LIMBS, MIRROR, NUM_JOINTS
from ergopose.recon.person_scale import HIPS_M
from ergopose.recon.settings import ReconSettings
from ergopose.recon.track_signatures import LimbHistogram

J = NUM_JOINTS

# --- the body model ------------------------------------------------------------------------------


def _pt(*names: str) -> dict[int, float]:
    """A point of the model: one keypoint, or the mean of several."""
    return {JOINT_INDEX[n]: 1.0 / len(names) for n in names}


#: Segments of the body model: (name, point a, point b, kind). Kinds set the play of the length
#: (SEGMENT_PLAY). The limbs of keypoints.LIMBS come first, under the same names; then the neck
#: (mid-ears to mid-shoulders); then every pair of points within a rigid part -- the head's 11
#: face points, each hand's wrist, pinky, index and thumb, each foot's ankle, heel and toe -- so
#: that each rigid part keeps its shape (all its distances) and only moves as a whole.
_LIMB_KIND = {
    "left_trunk_side": "flexible",
    "right_trunk_side": "flexible",
    "left_foot": "rigid",
    "right_foot": "rigid",
    "left_hand": "hand",
    "right_hand": "hand",
}
_RIGID_PARTS: tuple[tuple[str, tuple[str, ...]], ...] = (
    (
        "face",
        (
            "nose",
            "left_eye_inner",
            "left_eye",
            "left_eye_outer",
            "right_eye_inner",
            "right_eye",
            "right_eye_outer",
            "left_ear",
            "right_ear",
            "mouth_left",
            "mouth_right",
        ),
    ),
    ("hand", ("left_wrist", "left_pinky", "left_index", "left_thumb")),
    ("hand", ("right_wrist", "right_pinky", "right_index", "right_thumb")),
    ("rigid", ("left_ankle", "left_heel", "left_foot_index")),
    ("rigid", ("right_ankle", "right_heel", "right_foot_index")),
)


def _segment_defs() -> tuple[tuple[str, dict[int, float], dict[int, float], str], ...]:
    defs = [(name, _pt(a), _pt(b), _LIMB_KIND.get(name, "limb")) for name, a, b in LIMBS]
    defs.append(("neck", _pt("left_ear", "right_ear"), _pt("left_shoulder", "right_shoulder"), "flexible"))
    pairs = {frozenset((a, b)) for _, a, b in LIMBS}
    for kind, names in _RIGID_PARTS:
        for i, a in enumerate(names):
            for b in names[i + 1 :]:
                if frozenset((a, b)) not in pairs:
                    defs.append((f"{a}-{b}", _pt(a), _pt(b), kind))
    return tuple(defs)


_SEGMENT_DEFS = _segment_defs()
SEGMENTS: tuple[str, ...] = tuple(s[0] for s in _SEGMENT_DEFS)
NUM_SEGMENTS = len(SEGMENTS)


def _difference_matrix(defs: tuple[tuple[str, dict[int, float], dict[int, float], str], ...]) -> np.ndarray:
    """(len(defs), 33) read-only: row k is point b minus point a of defs[k] = (name, a, b, kind),
    so that the vectors are this matrix @ X."""
    out = np.zeros((len(defs), J))
    for k, (_, a, b, _) in enumerate(defs):
        for j, w in a.items():
            out[k, j] -= w
        for j, w in b.items():
            out[k, j] += w
    out.setflags(write=False)
    return out


#: (S, 33) point b minus point a: segment vectors are SEGMENT_MATRIX @ X.
SEGMENT_MATRIX = _difference_matrix(_SEGMENT_DEFS)
#: The segment terms of the normal matrix couple only the joint pairs (j, k) that share a segment:
#: _PAIR_J, _PAIR_K list those pairs (j, k) and _PAIR_W (pairs, S) holds sum_s D[s, j] D[s, k] per
#: segment, so the pairs' 3 x 3 blocks are _PAIR_W @ (the segments' 3 x 3 blocks) -- a few hundred
#: pairs instead of all 33 x 33.
_DD_FULL = SEGMENT_MATRIX[:, :, None] * SEGMENT_MATRIX[:, None, :]  # (S, 33, 33)
_PAIR_J, _PAIR_K = np.nonzero((_DD_FULL != 0).any(axis=0))
_PAIR_W = np.ascontiguousarray(_DD_FULL[:, _PAIR_J, _PAIR_K].T)  # (pairs, S)
del _DD_FULL
SEGMENT_KIND = tuple(s[3] for s in _SEGMENT_DEFS)

#: Play of a segment's length around the worker's median (metres + fraction of the length):
#: limbs carry keypoints that slide over the joint as it turns (BlazePose's shoulder and hip
#: points are not joint centres), the trunk sides and the neck bend; the face is rigid.
SEGMENT_PLAY = {
    "limb": (0.01, 0.04),
    "flexible": (0.015, 0.08),
    "rigid": (0.005, 0.05),
    "hand": (0.005, 0.10),
    "face": (0.003, 0.05),
}
#: Long segments: limbs and the bending trunk sides and neck (not the hands, feet and face).
_LONG = np.array([k in ("limb", "flexible") for k in SEGMENT_KIND])
_PLAY_ABS = np.array([SEGMENT_PLAY[k][0] for k in SEGMENT_KIND])
_PLAY_REL = np.array([SEGMENT_PLAY[k][1] for k in SEGMENT_KIND])

#: Play (fraction of the length) of a population length.
PRIOR_PLAY = 0.15

#: Neutral standing pose of a 1.75 m adult, body frame: origin mid-hip, x towards the left hip,
#: y forward, z up (metres). Only a weak prior for joints nothing else determines.
TEMPLATE_BODY = np.zeros((J, 3))
_TEMPLATE = {
    "nose": (0.0, 0.10, 0.66),
    "left_eye_inner": (0.015, 0.085, 0.69),
    "left_eye": (0.03, 0.08, 0.69),
    "left_eye_outer": (0.045, 0.075, 0.69),
    "right_eye_inner": (-0.015, 0.085, 0.69),
    "right_eye": (-0.03, 0.08, 0.69),
    "right_eye_outer": (-0.045, 0.075, 0.69),
    "left_ear": (0.075, 0.0, 0.67),
    "right_ear": (-0.075, 0.0, 0.67),
    "mouth_left": (0.025, 0.09, 0.62),
    "mouth_right": (-0.025, 0.09, 0.62),
    "left_shoulder": (0.18, 0.0, 0.50),
    "right_shoulder": (-0.18, 0.0, 0.50),
    "left_elbow": (0.20, 0.0, 0.18),
    "right_elbow": (-0.20, 0.0, 0.18),
    "left_wrist": (0.21, 0.03, -0.07),
    "right_wrist": (-0.21, 0.03, -0.07),
    "left_pinky": (0.225, 0.02, -0.17),
    "right_pinky": (-0.225, 0.02, -0.17),
    "left_index": (0.21, 0.06, -0.18),
    "right_index": (-0.21, 0.06, -0.18),
    "left_thumb": (0.20, 0.08, -0.12),
    "right_thumb": (-0.20, 0.08, -0.12),
    "left_hip": (0.11, 0.0, 0.0),
    "right_hip": (-0.11, 0.0, 0.0),
    "left_knee": (0.11, 0.02, -0.43),
    "right_knee": (-0.11, 0.02, -0.43),
    "left_ankle": (0.11, 0.0, -0.86),
    "right_ankle": (-0.11, 0.0, -0.86),
    "left_heel": (0.11, -0.06, -0.93),
    "right_heel": (-0.11, -0.06, -0.93),
    "left_foot_index": (0.12, 0.20, -0.93),
    "right_foot_index": (-0.12, 0.20, -0.93),
}
for _name, _p in _TEMPLATE.items():
    TEMPLATE_BODY[JOINT_INDEX[_name]] = _p
TEMPLATE_BODY.setflags(write=False)

#: Population segment lengths (metres): those of TEMPLATE_BODY, whose long segments follow Winter
#: (2009, Biomechanics and Motor Control of Human Movement, Fig. 4.1) fractions of a 1.75 m
#: stature (upper arm 0.186, forearm 0.146, thigh 0.245, shank 0.246, hip to shoulder 0.288); the
#: foot (heel to toe 0.152) too; the face and hand layout are rounded estimates. Used only until the worker's own segment has
#: been measured, scaled to the worker by its measured segments, with PRIOR_PLAY.
PRIOR_LENGTH_VECTOR = np.linalg.norm(SEGMENT_MATRIX @ TEMPLATE_BODY, axis=-1)
PRIOR_LENGTH_VECTOR.setflags(write=False)
_TRUNK_SIDE = SEGMENTS.index("left_trunk_side")

_LHIP, _RHIP = JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]
_FOOT = np.array(
    [
        JOINT_INDEX[n]
        for n in ("left_ankle", "right_ankle", "left_heel", "right_heel", "left_foot_index", "right_foot_index")
    ]
)
_FLOOR_SIGMA_M = 0.02
#: The sole points (heels and toes) and how high above the floor the lowest of them may lie
#: before the floor-contact prior pulls (metres; a standing foot's heel keypoint lies about 0.1 m
#: up in the real Pose2Sim recording).
_SOLE = np.array([JOINT_INDEX[n] for n in ("left_heel", "right_heel", "left_foot_index", "right_foot_index")])
FLOOR_CONTACT_BAND_M = 0.15

#: The hand's long axis continues the forearm: per side, mid(index, pinky) - wrist - k (wrist -
#: elbow) = 0 with k = hand / forearm length of the neutral pose (a linear term in X), standard
#: deviation ``fit_hand_prior_sigma_m``, applied only to a hand two cameras do not see. Without
#: it, a hand seen by one camera or none could settle bent back past any wrist's range (ORACLE,
#: 2 workers, 30 s, 2592 x 1944: wrist flexion RMSE 30.8 deg, 20 % of one hand's frames off by
#: more than 45 deg, fitted angles of -111 to +148 deg where the truth was near 0).


def _hand_prior_matrix() -> np.ndarray:
    rows = np.zeros((2, J))
    for r, side in enumerate(("left", "right")):
        w, e = JOINT_INDEX[f"{side}_wrist"], JOINT_INDEX[f"{side}_elbow"]
        i, p = JOINT_INDEX[f"{side}_index"], JOINT_INDEX[f"{side}_pinky"]
        hand = np.linalg.norm(0.5 * (TEMPLATE_BODY[i] + TEMPLATE_BODY[p]) - TEMPLATE_BODY[w])
        k = hand / np.linalg.norm(TEMPLATE_BODY[w] - TEMPLATE_BODY[e])
        rows[r, i] += 0.5
        rows[r, p] += 0.5
        rows[r, w] -= 1.0 + k
        rows[r, e] += k
    return rows


HAND_PRIOR = _hand_prior_matrix()
HAND_PRIOR.setflags(write=False)
_HAND_POINTS = np.array(
    [[JOINT_INDEX[f"{side}_{j}"] for j in ("wrist", "index", "pinky")] for side in ("left", "right")]
)
#: The pose prior, articulated: each of these links (name, from, to, frame) points from its
#: first point to its second as in TEMPLATE_BODY, turned into the world by the worker's current
#: frame of reference -- "facing" the hips' heading about the vertical (the trunk upright, arms
#: and legs hanging), "trunk" the current trunk (mid-hip to mid-shoulder, and the shoulder line):
#: the head continues the trunk however far the worker bends. A prior on whole positions about a
#: standing template placed at the pelvis (the earlier form) pulled a stooping worker's head and
#: arms towards where they would be standing: ORACLE, 2 workers, 1 min, 2592 x 1944, the head
#: turned 160 deg backwards during a stooped lift and neck flexion RMSE was 16.9 deg.
#: The hands are left out: the hand prior (HAND_PRIOR) continues the forearm where no two
#: cameras see the hand.
_PRIOR_LINKS: tuple[tuple[str, dict[int, float], dict[int, float], str], ...] = (
    ("trunk_left", _pt("left_hip", "right_hip"), _pt("left_shoulder"), "facing"),
    ("trunk_right", _pt("left_hip", "right_hip"), _pt("right_shoulder"), "facing"),
    *(
        (f"{side}_{a}-{b}", _pt(f"{side}_{a}"), _pt(f"{side}_{b}"), "facing")
        for side in ("left", "right")
        for a, b in (
            ("shoulder", "elbow"),
            ("elbow", "wrist"),
            ("hip", "knee"),
            ("knee", "ankle"),
            ("ankle", "heel"),
            ("ankle", "foot_index"),
        )
    ),
    *((f"head_{name}", _pt("left_shoulder", "right_shoulder"), _pt(name), "trunk") for name in _RIGID_PARTS[0][1]),
)
#: (E, 33): link vectors are PRIOR_LINK_MATRIX @ X.
PRIOR_LINK_MATRIX = _difference_matrix(_PRIOR_LINKS)
_LINK_TEMPLATE = PRIOR_LINK_MATRIX @ TEMPLATE_BODY  # (E, 3) body frame
_LINK_IN_TRUNK = np.array([f == "trunk" for *_, f in _PRIOR_LINKS])
_LINK_H = PRIOR_LINK_MATRIX.T @ PRIOR_LINK_MATRIX  # (33, 33)
_LSH, _RSH = JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]


def _trunk_frames(X: np.ndarray) -> FloatArray:
    """(R, 33, 3) -> (R, 3, 3) world-from-body map of the current trunk (columns: towards the left
    shoulder, forward, along the trunk from mid-hip to mid-shoulder; a reflection, like
    :func:`_yaw_frames`); where the trunk is degenerate, the facing frame."""
    z = 0.5 * (X[:, _LSH] + X[:, _RSH] - X[:, _LHIP] - X[:, _RHIP])
    nz = np.linalg.norm(z, axis=-1, keepdims=True)
    z = z / np.maximum(nz, 1e-12)
    x = X[:, _LSH] - X[:, _RSH]
    x = x - (x * z).sum(axis=-1, keepdims=True) * z
    nx = np.linalg.norm(x, axis=-1, keepdims=True)
    x = x / np.maximum(nx, 1e-12)
    out = np.stack([x, np.cross(x, z), z], axis=-1)
    ok = (nz[:, 0] > 1e-6) & (nx[:, 0] > 1e-6)
    frames: FloatArray = np.where(ok[:, None, None], out, _yaw_frames(X))
    return frames


def prior_links(X: np.ndarray, scale: np.ndarray) -> FloatArray:
    """(R, 33, 3), (R,) -> (R, E, 3) the pose prior's link vectors in the world: the template's,
    scaled to the worker, in the facing or the trunk frame of X (:data:`_PRIOR_LINKS`)."""
    tmpl = scale[:, None, None] * _LINK_TEMPLATE[None]  # (R, E, 3)
    facing = np.matmul(tmpl, np.swapaxes(_yaw_frames(X), -1, -2))
    trunk = np.matmul(tmpl, np.swapaxes(_trunk_frames(X), -1, -2))
    out: FloatArray = np.array(facing, dtype=np.float64)
    out[:, _LINK_IN_TRUNK] = trunk[:, _LINK_IN_TRUNK]
    return out


#: The anatomical limits of the model (issue 13, item 1), each a one-sided term
#: min(0, a . (C X) - b)^2 / sigma_lim^2 on a combination C X of the keypoints, with the direction
#: a and the bound b taken from the current pose at each iteration (like the pose prior's template,
#: they are not differentiated):
#: - an elbow or a knee bends at most so far (``fit_elbow_max_flexion_rad``,
#:   ``fit_knee_max_flexion_rad``): the shoulder-to-wrist (hip-to-ankle) distance stays at least
#:   what the current upper arm and forearm (thigh and shank) make at that flexion; a = the
#:   distance's own direction;
#: - a knee bends forwards (``fit_knee_max_hyperextension_rad``): the knee lies no further behind
#:   the hip-to-ankle line than that hyperextension puts it, "behind" against the way the hips
#:   face (the pelvis's forward direction made perpendicular to the line; the hip turns the knee
#:   by at most 45 degrees either way, so a bent knee is always ahead of it); where the line runs
#:   within 10 degrees of that direction the term is off;
#: - the face looks forwards of the trunk (``fit_head_max_turn_rad``): the angle between the line
#:   from the mid-ears to the mean of nose and eyes (the face's direction) and the
#:   trunk's forward direction stays within the limit, a head turned further than the neck turns.
#: A network's keypoints of a body seen from above put knees behind the leg and faces on the back
#: of the head (docs/reconstruction.md, "Joint limits").
_LIMITS: tuple[tuple[str, dict[int, float], dict[int, float], str], ...] = (
    *((f"{s}_elbow_max_flexion", _pt(f"{s}_shoulder"), _pt(f"{s}_wrist"), "reach") for s in ("left", "right")),
    *((f"{s}_knee_max_flexion", _pt(f"{s}_hip"), _pt(f"{s}_ankle"), "reach") for s in ("left", "right")),
    *((f"{s}_knee_hyperextension", _pt(f"{s}_hip", f"{s}_ankle"), _pt(f"{s}_knee"), "knee") for s in ("left", "right")),
    ("head_turn", _pt("left_ear", "right_ear"), _pt("nose", "left_eye", "right_eye"), "face"),
)
LIMITS: tuple[str, ...] = tuple(lim[0] for lim in _LIMITS)
#: The knee limit is off where the hip-to-ankle line runs within 10 degrees of the hips' forward
#: direction (sine of the angle between them).
_KNEE_MIN_SIN = float(np.sin(np.radians(10.0)))
#: (limits, 33): the limited vectors are LIMIT_MATRIX @ X.
LIMIT_MATRIX = _difference_matrix(_LIMITS)
_LIMIT_KIND = np.array([lim[3] for lim in _LIMITS])
#: The six limb limits' (elbows, knees, knees again) upper, middle and lower points.
_LIMB_POINTS = np.array(
    [
        [JOINT_INDEX[f"{side}_{p}"] for p in (("shoulder", "elbow", "wrist") if k < 2 else ("hip", "knee", "ankle"))]
        for k, side in enumerate(("left", "right", "left", "right", "left", "right"))
    ]
)
_REACH = np.flatnonzero(_LIMIT_KIND == "reach")
_KNEE = np.flatnonzero(_LIMIT_KIND == "knee")
_FACE = int(np.flatnonzero(_LIMIT_KIND == "face")[0])
#: The joints the limits involve, and each limit's C_l C_l^T on those joints only, as a
#: (joints^2, limits) matrix: the normal matrix's blocks are its product with the a a^T terms.
_LIMIT_JOINTS = np.flatnonzero((LIMIT_MATRIX != 0).any(axis=0))
_LIMIT_HSUB2 = np.ascontiguousarray(
    np.einsum("lj,lk->jkl", LIMIT_MATRIX[:, _LIMIT_JOINTS], LIMIT_MATRIX[:, _LIMIT_JOINTS]).reshape(-1, len(_LIMITS))
)


_XYZ = np.arange(3)

#: (limits, 33) bool: the joints each limit holds, as the tracks table's ``limited`` flags them:
#: the middle point of a limb limit (the elbow for an elbow's flexion, the knee for a knee's
#: flexion and hyperextension), the face's points (nose and eyes) for the head's turn.
LIMIT_HELD_JOINTS = np.zeros((len(_LIMITS), J), bool)
LIMIT_HELD_JOINTS[np.arange(len(_LIMB_POINTS)), _LIMB_POINTS[:, 1]] = True
LIMIT_HELD_JOINTS[_FACE, list(_LIMITS[_FACE][2])] = True
#: A limit counts as holding a pose passed by more than this (metres): with the limits' sigma of
#: 2 mm the fit leaves a pose the cameras pull past a limit a little beyond it.
LIMIT_HELD_TOLERANCE_M = 1e-4


def _limit_normal_terms(a: np.ndarray, w: np.ndarray, value: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The limit terms' part of the normal equations for h rows: a (h, limits, 3) directions,
    w (h, limits) weights (0 where a limit is not passed), value (h, limits) -> the blocks of
    the normal matrix on _LIMIT_JOINTS (h, m, 3, m, 3) and the gradient (h, 33, 3)."""
    h, m = len(a), len(_LIMIT_JOINTS)
    aa = (w[..., None, None] * a[..., :, None] * a[..., None, :]).reshape(h, len(LIMITS), 9)
    blocks = np.matmul(_LIMIT_HSUB2, aa).reshape(h, m, m, 3, 3).transpose(0, 1, 3, 2, 4)
    grad = np.matmul(LIMIT_MATRIX.T, (w * value)[..., None] * a)
    return blocks, grad


def _unit_rows(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = np.sqrt((v * v).sum(axis=-1))
    return v / np.maximum(n, 1e-12)[..., None], n


def limits_held(
    points_world: np.ndarray, options: "FitOptions", tolerance_m: float = LIMIT_HELD_TOLERANCE_M
) -> np.ndarray:
    """(n, 33, 3) -> (n, 33) bool: the joints of the limits (:data:`LIMIT_HELD_JOINTS`) that the
    pose passes by more than ``tolerance_m``; False for rows with a NaN and when the limits are
    off (``limit_sigma_m`` 0)."""
    X = np.asarray(points_world, dtype=np.float64)
    held = np.zeros(X.shape[:2], bool)
    if options.limit_sigma_m <= 0 or not len(X):
        return held
    ok = np.flatnonzero(np.isfinite(X).all(axis=(1, 2)))
    if len(ok):
        held[ok] = _held_joints(limit_terms(X[ok], options)[2], tolerance_m)
    return held


def _held_joints(values: np.ndarray, tolerance_m: float = LIMIT_HELD_TOLERANCE_M) -> np.ndarray:
    """(h, limits) values of the limit terms (:func:`limit_terms`; negative = passed) -> (h, 33)
    bool, the joints of the limits passed by more than ``tolerance_m``."""
    passed = (values < -tolerance_m).astype(np.int64)
    return np.asarray(np.matmul(passed, LIMIT_HELD_JOINTS.astype(np.int64)) > 0)


def limit_terms(X: np.ndarray, opt: "FitOptions") -> tuple[FloatArray, FloatArray, FloatArray]:
    """(R, 33, 3) -> the limits' current directions a (R, limits, 3), bounds b (R, limits) and
    values a . (C X) - b (R, limits), negative where a limit is passed (:data:`_LIMITS`); where a
    limit does not apply (a degenerate limb, a leg along the hips' forward direction) a = 0 and
    b = 0, so its value is 0."""
    R = X.shape[0]
    v = np.matmul(LIMIT_MATRIX, X)  # (R, limits, 3)
    a = np.zeros((R, len(LIMITS), 3))
    b = np.zeros((R, len(LIMITS)))
    limb = X[:, _LIMB_POINTS]  # (R, 6, 3 points, 3)
    # The limb's current segments (not the worker's lengths: measured with those, the fit reached
    # the limit more slowly -- an elbow shown at 170 deg stayed at 159-175 after 10 iterations).
    l1 = np.sqrt(((limb[:, :, 1] - limb[:, :, 0]) ** 2).sum(axis=-1))  # (R, 6)
    l2 = np.sqrt(((limb[:, :, 2] - limb[:, :, 1]) ** 2).sum(axis=-1))
    # The reach limits: |C X| >= what the limb's two segments make at the largest flexion.
    max_flex = np.array([opt.elbow_max_flexion_rad] * 2 + [opt.knee_max_flexion_rad] * 2)
    u, vn = _unit_rows(v[:, _REACH])
    dmin = np.sqrt(np.maximum(l1[:, :4] ** 2 + l2[:, :4] ** 2 + 2.0 * l1[:, :4] * l2[:, :4] * np.cos(max_flex), 0.0))
    ok = vn > 1e-9
    a[:, _REACH] = np.where(ok[..., None], u, 0.0)
    b[:, _REACH] = np.where(ok, dmin, 0.0)
    # The knees: ahead of the hip-to-ankle line, against the hips' forward direction.
    hip_line = X[:, _LHIP] - X[:, _RHIP]
    fwd = np.stack([hip_line[:, 1], -hip_line[:, 0], np.zeros(R)], axis=-1)
    fwd, fwd_n = _unit_rows(fwd)
    line, ln = _unit_rows(limb[:, 4:, 2] - limb[:, 4:, 0])  # (R, 2, 3)
    f = fwd[:, None, :] - (fwd[:, None, :] * line).sum(axis=-1, keepdims=True) * line
    f, f_n = _unit_rows(f)
    usable = (f_n > _KNEE_MIN_SIN) & (ln > 1e-6) & (fwd_n[:, None] > 1e-6)
    a[:, _KNEE] = np.where(usable[..., None], f, 0.0)
    behind = l1[:, 4:] * l2[:, 4:] * np.sin(opt.knee_max_hyperextension_rad) / np.maximum(ln, 1e-6)
    b[:, _KNEE] = np.where(usable, -behind, 0.0)
    # The face: within the largest turn of the trunk's forward direction (shoulder line x trunk).
    mid_sh = 0.5 * (X[:, _LSH] + X[:, _RSH])
    p, q = X[:, _LSH] - X[:, _RSH], mid_sh - 0.5 * (X[:, _LHIP] + X[:, _RHIP])
    trunk = np.stack(
        [
            p[:, 1] * q[:, 2] - p[:, 2] * q[:, 1],
            p[:, 2] * q[:, 0] - p[:, 0] * q[:, 2],
            p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0],
        ],
        axis=-1,
    )  # the shoulder line x the trunk: forward
    trunk_fwd, t_n = _unit_rows(trunk)
    trunk_fwd = np.where((t_n > 1e-9)[:, None], trunk_fwd, fwd)
    face_n = np.sqrt((v[:, _FACE] ** 2).sum(axis=-1))
    a[:, _FACE] = np.where((face_n > 1e-9)[:, None], trunk_fwd, 0.0)
    b[:, _FACE] = np.where(face_n > 1e-9, np.cos(opt.head_max_turn_rad) * face_n, 0.0)
    value = (a * v).sum(axis=-1) - b
    return a, b, value


#: A segment takes the median of its best-seen samples once it has this many (else of all).
BEST_SAMPLES = 30
#: Weight of each frame in a worker's running keypoint-noise estimate (about 5 frames' memory).
NOISE_RATE = 0.2
#: The measured keypoint noise never falls below this share of keypoint_sigma_px. Measured with
#: 0.25 (ORACLE, 30 s, 4 workers, 2592 x 1944): MPJPE 24.0 -> 20.6 mm, but RULA grand exact
#: agreement 82.5 -> 63.9 %: the noise of the keypoints a camera cannot see (the network's
#: guesses) is larger than that of the seen ones the scale is measured on, and the face's
#: hidden points then outweighed its shape, tipping the neck angle.
MIN_NOISE_SCALE = 1.0


@dataclass(frozen=True)
class FitOptions:
    """The body fit's weights (all in ReconSettings; see docs/reconstruction.md)."""

    keypoint_sigma_px: float = 1.5
    min_confidence: float = 0.5
    huber_k: float = 3.0
    temporal_sigma_m: float = 0.03
    speed_m_s: float = 1.5
    pose_prior_sigma_m: float = 0.35
    hand_prior_sigma_m: float = 0.05
    floor_contact_sigma_m: float = 0.05
    turn_rate_rad_s: float = 4.0
    iterations: int = 10
    max_prior_gap_s: float = 2.0
    limit_sigma_m: float = 0.002
    elbow_max_flexion_rad: float = float(np.radians(150.0))
    knee_max_flexion_rad: float = float(np.radians(155.0))
    knee_max_hyperextension_rad: float = float(np.radians(10.0))
    head_max_turn_rad: float = float(np.radians(90.0))

    @classmethod
    def from_settings(cls, settings: ReconSettings) -> "FitOptions":
        return cls(
            keypoint_sigma_px=settings.keypoint_sigma_px,
            min_confidence=settings.min_confidence,
            huber_k=settings.fit_huber_k,
            temporal_sigma_m=settings.fit_temporal_sigma_m,
            speed_m_s=settings.fit_speed_m_s,
            pose_prior_sigma_m=settings.fit_pose_prior_sigma_m,
            hand_prior_sigma_m=settings.fit_hand_prior_sigma_m,
            floor_contact_sigma_m=settings.fit_floor_contact_sigma_m,
            turn_rate_rad_s=settings.fit_turn_rate_rad_s,
            iterations=settings.fit_iterations,
            max_prior_gap_s=settings.max_coast_s,
            limit_sigma_m=settings.fit_limit_sigma_m,
            elbow_max_flexion_rad=settings.fit_elbow_max_flexion_rad,
            knee_max_flexion_rad=settings.fit_knee_max_flexion_rad,
            knee_max_hyperextension_rad=settings.fit_knee_max_hyperextension_rad,
            head_max_turn_rad=settings.fit_head_max_turn_rad,
        )


@dataclass(frozen=True, eq=False)
class BodyFit:
    """Result of fitting R worker-frames.

    points_world: (R, 33, 3) fitted positions (metres).
    variance_world: (R, 33, 3) variance of each coordinate (m^2), from the fit's covariance.
    inferred: (R, 33) bool, fewer than two cameras saw the joint with min_confidence: the model
        (segment lengths, previous pose, one camera's ray, pose prior) placed it.
    reprojection_error_px: (R, 33) RMS reprojection error over the cameras that saw the joint
        (view pixels); NaN where none saw it.
    cost: (R,) final cost (sum of squared normalised residuals, robust).
    noise_scale: (R,) the keypoints' error measured by this fit, in units of the keypoint sigma
        used: the mean squared normalised reprojection residual of the joints two or more cameras
        saw, times n / (n - 3 m) for n residual coordinates of m joints (the triangulation's own
        degrees of freedom), square-rooted; NaN where no joint had two cameras.
    limited: (R, 33) bool, a joint limit held the joint: the cameras pulled the pose past the
        limit (:func:`limits_held` on the fitted pose; :data:`LIMIT_HELD_JOINTS`).
    """

    points_world: np.ndarray
    variance_world: np.ndarray
    inferred: np.ndarray
    reprojection_error_px: np.ndarray
    cost: np.ndarray
    noise_scale: np.ndarray
    limited: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.limited is None:
            object.__setattr__(self, "limited", np.zeros(self.inferred.shape, bool))


def segment_lengths(points_world: np.ndarray) -> np.ndarray:
    """(..., 33, 3) -> (..., S) length of every segment of the body model (NaN where a point is NaN)."""
    X = np.asarray(points_world, dtype=np.float64)
    d = np.einsum("sj,...jk->...sk", SEGMENT_MATRIX, np.where(np.isfinite(X), X, 0.0))
    bad = np.einsum("sj,...j->...s", SEGMENT_MATRIX != 0, ~np.isfinite(X).all(axis=-1)) > 0
    return np.where(bad, np.nan, np.linalg.norm(d, axis=-1))


def worker_lengths(measured: np.ndarray, samples: np.ndarray, min_samples: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Segment lengths and their play (both (S,), metres) for a worker.

    measured: (S,) medians of the worker's best-seen raw segment lengths (NaN = none);
    samples: (S,) how many raw lengths each median has. A segment with at least ``min_samples``
    takes its median and SEGMENT_PLAY; the others take the population length scaled by the median
    ratio of the measured long segments (limbs, trunk sides, neck) to the population (1 when none)
    with PRIOR_PLAY.
    """
    measured = np.asarray(measured, dtype=np.float64)
    known = np.isfinite(measured) & (np.asarray(samples) >= min_samples)
    ref = known & _LONG
    scale = float(np.median(measured[ref] / PRIOR_LENGTH_VECTOR[ref])) if ref.any() else 1.0
    scale = float(np.clip(scale, 0.75, 1.25))
    prior = PRIOR_LENGTH_VECTOR * scale
    length = np.where(known, measured, prior)
    play = np.where(known, _PLAY_ABS + _PLAY_REL * length, PRIOR_PLAY * prior)
    return length, play


def _yaw_frames(X: np.ndarray) -> np.ndarray:
    """(R, 33, 3) -> (R, 3, 3) world-from-body map (columns: towards the left hip, forward, up; a
    reflection, as the body frame of TEMPLATE_BODY is left-handed)."""
    x = X[:, _LHIP] - X[:, _RHIP]
    x[:, 2] = 0.0
    n = np.linalg.norm(x, axis=-1, keepdims=True)
    x = np.where(n > 1e-6, x / np.maximum(n, 1e-12), np.array([1.0, 0.0, 0.0]))
    out = np.zeros(x.shape[:-1] + (3, 3))
    out[..., :, 0] = x
    # forward = left x up (as ergonomics.angles' pelvis frame): (x1, -x0, 0) for up = (0, 0, 1)
    out[..., 0, 1] = x[..., 1]
    out[..., 1, 1] = -x[..., 0]
    out[..., 2, 2] = 1.0
    return out


def template_pose(pelvis_world: np.ndarray, rotation: np.ndarray, scale: np.ndarray | float = 1.0) -> FloatArray:
    """(R, 3), (R, 3, 3) -> (R, 33, 3) the neutral pose placed at the pelvis, rotated and scaled."""
    scale = np.broadcast_to(np.asarray(scale, dtype=np.float64), (len(pelvis_world),))
    pose: FloatArray = pelvis_world[:, None, :] + scale[:, None, None] * np.matmul(
        TEMPLATE_BODY, np.swapaxes(rotation, -1, -2)
    )
    return pose


def fit_bodies(
    projections: np.ndarray,
    pixels_view: np.ndarray,
    confidence: np.ndarray,
    initial_world: np.ndarray,
    lengths: np.ndarray,
    play: np.ndarray,
    previous_world: np.ndarray | None = None,
    previous_sigma_m: np.ndarray | None = None,
    previous_dt_s: np.ndarray | None = None,
    options: FitOptions | None = None,
    sigma_scale: np.ndarray | None = None,
) -> BodyFit:
    """Fit the body model to R worker-frames at once.

    projections: (R, C, 3, 4) each camera's view projection (world -> view pixels; any finite
        matrix where the camera did not see the person: its confidences are 0).
    pixels_view: (R, C, 33, 2) keypoints (NaN = not found); confidence: (R, C, 33) in [0, 1].
    initial_world: (R, 33, 3) starting positions (finite).
    lengths, play: (R, S) segment lengths and their standard deviation (metres).
    previous_world: (R, 33, 3) the previous pose (NaN rows = none); previous_sigma_m: (R,) the
        sigma of each joint's position about it; previous_dt_s: (R,) the time since it (each
        segment's direction may turn by ``turn_rate_rad_s`` x that, one sigma).
    sigma_scale: (R,) multiplies keypoint_sigma_px per row (the keypoint noise measured for the
        worker so far, :attr:`BodyFit.noise_scale`); None = 1.
    """
    opt = options or FitOptions()
    P = np.asarray(projections, dtype=np.float64)
    u_obs = np.asarray(pixels_view, dtype=np.float64)
    conf = np.nan_to_num(np.asarray(confidence, dtype=np.float64))
    seen = np.isfinite(u_obs).all(axis=-1) & (conf > 0)
    conf = np.where(seen, conf, 0.0)
    u_obs = np.where(seen[..., None], u_obs, 0.0)
    R = P.shape[0]
    scale_px = opt.keypoint_sigma_px * (np.ones(len(P)) if sigma_scale is None else np.asarray(sigma_scale, float))
    sigma_px = scale_px[:, None, None] / np.maximum(conf, 0.05)
    w_obs = np.where(seen, 1.0 / (sigma_px * sigma_px), 0.0)  # (R, C, J)
    L = np.asarray(lengths, dtype=np.float64)
    w_seg = 1.0 / np.asarray(play, dtype=np.float64) ** 2  # (R, S)
    if previous_world is None:
        prev = np.full((R, J, 3), np.nan)
        w_prev = np.zeros(R)
    else:
        prev = np.asarray(previous_world, dtype=np.float64)
        ps = np.asarray(previous_sigma_m, dtype=np.float64)
        w_prev = np.where(np.isfinite(prev).all(axis=(1, 2)) & np.isfinite(ps), 1.0 / ps**2, 0.0)
    prev0 = np.where(np.isfinite(prev), prev, 0.0)
    # Segment turning: the segment vectors D X stay near those of the previous pose.
    if previous_dt_s is None:
        w_turn = np.zeros((R, NUM_SEGMENTS))
    else:
        sig_turn = opt.temporal_sigma_m + opt.turn_rate_rad_s * L * np.asarray(previous_dt_s, dtype=np.float64)[:, None]
        w_turn = np.where((w_prev > 0)[:, None] & np.isfinite(sig_turn), 1.0 / sig_turn**2, 0.0)
    D = SEGMENT_MATRIX
    d_prev = np.matmul(D, prev0)  # (R, S, 3)
    turn_H = np.matmul(np.swapaxes(w_turn[:, :, None] * D, 1, 2), D)  # (R, J, J)
    w_pose = 1.0 / opt.pose_prior_sigma_m**2
    scale = L[:, _TRUNK_SIDE] / PRIOR_LENGTH_VECTOR[_TRUNK_SIDE]
    n = 3 * J
    idx = np.arange(J)
    diag_n = np.arange(n)
    # The normal matrix's terms that do not depend on X, made once: segment turning (linear in X)
    # and the previous-pose and pose-prior terms (diagonal; the template's dependence on X is not
    # differentiated).
    H_const = np.zeros((R, J, 3, J, 3))
    for a in range(3):
        H_const[:, :, a, :, a] = turn_H
    H_const[:, idx, :, idx, :] += w_prev[None, :, None, None] * np.eye(3)
    for a in range(3):
        H_const[:, :, a, :, a] += w_pose * _LINK_H
    # The hand prior only where a hand is not seen: its wrist, index and pinky each above
    # min_confidence in fewer than two cameras (a hand two cameras see is left to them).
    strong = (conf >= max(opt.min_confidence, 1e-12)).sum(axis=1)  # (R, J) cameras seeing each joint
    hand_seen = (strong[:, _HAND_POINTS] >= 2).all(axis=-1)  # (R, 2)
    w_hand = np.where(hand_seen | (opt.hand_prior_sigma_m <= 0), 0.0, 1.0 / max(opt.hand_prior_sigma_m, 1e-9) ** 2)
    hand_H = np.einsum("rs,sj,sk->rjk", w_hand, HAND_PRIOR, HAND_PRIOR)  # (R, J, J)
    for a in range(3):
        H_const[:, :, a, :, a] += hand_H
    # Floor contact, for a worker one camera sees: the lowest heel or toe within
    # FLOOR_CONTACT_BAND_M of the floor (one camera's rays leave the distance to the body to its
    # size, which the keypoints tell poorly).
    one_camera = (conf > 0).any(axis=2).sum(axis=1) < 2  # (R,)
    w_contact = np.where(
        one_camera & (opt.floor_contact_sigma_m > 0), 1.0 / max(opt.floor_contact_sigma_m, 1e-9) ** 2, 0.0
    )
    rows = np.arange(R)
    P_uv = P[:, :, None, :2, :3]  # (R, C, 1, 2, 3)
    P_w = P[:, :, None, 2:3, :3]  # (R, C, 1, 1, 3)
    P_t = np.swapaxes(P, -1, -2)  # (R, C, 4, 3)
    ones = np.ones((R, J, 1))

    w_lim = 1.0 / opt.limit_sigma_m**2 if opt.limit_sigma_m > 0 else 0.0

    X = np.array(initial_world, dtype=np.float64)
    lam = np.full(R, 1e-3)
    k = opt.huber_k

    def residuals(X: np.ndarray) -> dict[str, np.ndarray]:
        """Parts of the cost and what the normal equations need."""
        Xh = np.concatenate([X, ones], axis=-1)
        xp = np.matmul(Xh[:, None], P_t)  # (R, C, J, 3)
        depth = xp[..., 2]
        front = depth > 1e-6
        dsafe = np.where(front, depth, 1.0)
        u = xp[..., :2] / dsafe[..., None]
        e = u - u_obs  # (R, C, J, 2)
        e2 = (e * e).sum(axis=-1)
        s = np.sqrt(e2 * w_obs)  # normalised error
        use = seen & front
        inner = s <= k
        hub = np.where(inner, 1.0, k / np.maximum(s, 1e-12))
        wr = np.where(use, w_obs * hub, 0.0)
        rho = np.where(use, np.where(inner, s * s, 2 * k * s - k * k), 0.0)
        d = np.matmul(D, X)  # (R, S, 3)
        ln = np.sqrt((d * d).sum(axis=-1))
        rs = ln - L
        cost_seg = w_seg * rs * rs
        dp = np.matmul(PRIOR_LINK_MATRIX, X) - prior_links(X, scale)  # (R, E, 3)
        dt = X - prev0
        zf = np.minimum(X[:, _FOOT, 2], 0.0)
        low = np.argmin(X[:, _SOLE, 2], axis=1)  # (R,)
        zc = np.maximum(X[rows, _SOLE[low], 2] - FLOOR_CONTACT_BAND_M, 0.0)
        dturn = d - d_prev
        dh = np.matmul(HAND_PRIOR, X)  # (R, 2, 3)
        if w_lim > 0:
            lim_a, _, lim_v = limit_terms(X, opt)
            lim_v = np.minimum(lim_v, 0.0)
        else:
            lim_a, lim_v = np.zeros((R, len(LIMITS), 3)), np.zeros((R, len(LIMITS)))
        cost = (
            rho.sum(axis=(1, 2))
            + cost_seg.sum(axis=1)
            + w_pose * (dp * dp).sum(axis=(1, 2))
            + (w_hand * (dh * dh).sum(axis=-1)).sum(axis=1)
            + (w_turn * (dturn * dturn).sum(axis=-1)).sum(axis=1)
            + w_prev * (dt * dt).sum(axis=(1, 2))
            + (zf * zf).sum(axis=1) / _FLOOR_SIGMA_M**2
            + w_contact * zc * zc
            + w_lim * (lim_v * lim_v).sum(axis=1)
        )
        return dict(
            dsafe=dsafe,
            u=u,
            e=e,
            e2=e2,
            wr=wr,
            d=d,
            ln=ln,
            rs=rs,
            dp=dp,
            dt=dt,
            zf=zf,
            low=low,
            zc=zc,
            dturn=dturn,
            dh=dh,
            lim_a=lim_a,
            lim_v=lim_v,
            cost=cost,
            use=use,
        )

    def normal_equations(X: np.ndarray, r: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        H = H_const.copy()
        # reprojection: du/dX = (P[:2, :3] - u P[2, :3]) / depth
        Jp = (P_uv - r["u"][..., :, None] * P_w) / r["dsafe"][..., None, None]  # (R, C, J, 2, 3)
        Jw = Jp * r["wr"][..., None, None]
        Hjj = np.einsum("rcjai,rcjak->jrik", Jw, Jp)
        g = np.einsum("rcjai,rcja->rji", Jw, r["e"])
        H[:, idx, :, idx, :] += Hjj
        # segments: d(|d|)/dX_j = D[s, j] n^T; only joint pairs sharing a segment (_PAIR_*)
        nvec = r["d"] / np.maximum(r["ln"], 1e-9)[..., None]
        M = (w_seg[..., None, None] * nvec[..., :, None] * nvec[..., None, :]).reshape(R, NUM_SEGMENTS, 9)
        blocks = np.matmul(_PAIR_W, M).reshape(R, len(_PAIR_J), 3, 3)
        H[:, _PAIR_J, :, _PAIR_K, :] += np.swapaxes(blocks, 0, 1)
        # segment lengths and turning (the turning's matrix is in H_const)
        g += np.matmul(D.T, (w_seg * r["rs"])[..., None] * nvec + w_turn[..., None] * r["dturn"])
        # priors
        g += (
            w_pose * np.matmul(PRIOR_LINK_MATRIX.T, r["dp"])
            + w_prev[:, None, None] * r["dt"]
            + np.matmul(HAND_PRIOR.T, w_hand[..., None] * r["dh"])
        )
        # floor
        fl = np.where(X[:, _FOOT, 2] < 0.0, 1.0 / _FLOOR_SIGMA_M**2, 0.0)
        H[:, _FOOT, 2, _FOOT, 2] += fl
        g[:, _FOOT, 2] += fl * r["zf"]
        sole = _SOLE[r["low"]]
        H[rows, sole, 2, sole, 2] += np.where(r["zc"] > 0, w_contact, 0.0)
        g[rows, sole, 2] += w_contact * r["zc"]
        # anatomical limits, where passed (value < 0): linear in X with a held
        act = r["lim_v"] < 0.0  # (R, limits)
        hit = act.any(axis=1)
        if hit.any():
            rows_hit = np.flatnonzero(hit)
            blocks, grad = _limit_normal_terms(r["lim_a"][rows_hit], w_lim * act[rows_hit], r["lim_v"][rows_hit])
            H[np.ix_(rows_hit, _LIMIT_JOINTS, _XYZ, _LIMIT_JOINTS, _XYZ)] += blocks
            g[rows_hit] += grad
        return H.reshape(R, n, n), g.reshape(R, n)

    r = residuals(X)
    for _ in range(opt.iterations):
        A, g = normal_equations(X, r)
        A[:, diag_n, diag_n] += lam[:, None] * np.maximum(A[:, diag_n, diag_n], 1e-9)
        step = -np.linalg.solve(A, g[..., None])[..., 0]
        Xn = X + step.reshape(R, J, 3)
        rn = residuals(Xn)
        better = rn["cost"] <= r["cost"]
        if better.all():
            X, r = Xn, rn
        elif better.any():
            X = np.where(better[:, None, None], Xn, X)
            r = {key: (np.where(better.reshape((R,) + (1,) * (val.ndim - 1)), rn[key], val)) for key, val in r.items()}
        lam = np.where(better, np.maximum(lam / 3.0, 1e-7), lam * 4.0)

    H, _ = normal_equations(X, r)
    cov = np.linalg.inv(H + 1e-9 * np.eye(3 * J))
    var = np.diagonal(cov, axis1=-2, axis2=-1).reshape(R, J, 3).copy()
    used = r["use"]
    # The keypoint noise this frame shows, from the joints two or more cameras saw.
    multi = used.sum(axis=1) >= 2  # (R, J)
    e2 = r["e2"]  # squared reprojection error (view pixels^2)
    z2 = np.minimum(e2 * w_obs, 16.0)  # clipped at 4 sigma
    chi = np.where(used & multi[:, None, :], z2, 0.0).sum(axis=(1, 2))
    n_res = 2.0 * np.where(multi[:, None, :], used, False).sum(axis=(1, 2))
    dof = n_res - 3.0 * multi.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        noise = np.where(dof > 0, np.sqrt(chi / np.maximum(dof, 1e-9)), np.nan)
    n_used = used.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        rms = np.where(n_used > 0, np.sqrt(np.where(used, e2, 0.0).sum(axis=1) / n_used), np.nan)
    return BodyFit(
        points_world=X,
        variance_world=var,
        inferred=strong < 2,
        reprojection_error_px=rms,
        cost=r["cost"],
        noise_scale=noise,
        # the limit terms' values at the solution (clipped at 0: only the passed ones are kept)
        limited=_held_joints(r["lim_v"]),
    )


def hold_within_limits(
    points_world: np.ndarray, variance_world: np.ndarray, options: FitOptions, iterations: int = 5
) -> FloatArray:
    """The smoothed positions brought back within the joint limits (:data:`LIMITS`).

    The smoother runs on the fit's output joint by joint and does not know the limits, so it can
    pass them where the fit did not. Each row (n, 33, 3) that passes one moves the least, in units
    of its joints' variance (n, 33, 3; each coordinate weighted by 1 / variance), for the limit
    terms of the fit (same sigma): Gauss-Newton, ``iterations`` at most. Rows within every limit,
    rows with a NaN and limits turned off (``limit_sigma_m`` 0) are returned unchanged.
    """
    return hold_and_flag(points_world, variance_world, options, iterations)[0]


def hold_and_flag(
    points_world: np.ndarray, variance_world: np.ndarray, options: FitOptions, iterations: int = 5
) -> tuple[FloatArray, np.ndarray]:
    """(:func:`hold_within_limits`, :func:`limits_held`) of the same positions, their limit terms
    evaluated once: the positions held within the limits, and (n, 33) the joints the positions
    given passed a limit with."""
    X = np.array(points_world, dtype=np.float64)
    held = np.zeros(X.shape[:2], bool)
    if options.limit_sigma_m <= 0 or not len(X):
        return X, held
    finite = np.flatnonzero(np.isfinite(X).all(axis=(1, 2)))
    if not len(finite):
        return X, held
    values = limit_terms(X[finite], options)[2]
    held[finite] = _held_joints(values)
    var = np.asarray(variance_world, dtype=np.float64)
    usable = np.isfinite(var[finite]).all(axis=(1, 2)) & (var[finite] > 0).all(axis=(1, 2))
    rows = finite[usable & (values < 0).any(axis=1)]
    if not len(rows):
        return X, held
    S = X[rows].copy()
    w = 1.0 / var[rows]  # (h, 33, 3)
    w_lim = 1.0 / options.limit_sigma_m**2
    n = 3 * J
    Y = S.copy()
    for _ in range(iterations):
        a, _, value = limit_terms(Y, options)
        act = value < 0.0
        if not act.any():
            break
        H = np.zeros((len(rows), J, 3, J, 3))
        H[:, np.arange(J), :, np.arange(J), :] = np.swapaxes(w, 0, 1)[..., None] * np.eye(3)
        blocks, grad = _limit_normal_terms(a, w_lim * act, np.minimum(value, 0.0))
        H[np.ix_(np.arange(len(rows)), _LIMIT_JOINTS, _XYZ, _LIMIT_JOINTS, _XYZ)] += blocks
        g = w * (Y - S) + grad
        step = np.linalg.solve(H.reshape(len(rows), n, n), g.reshape(len(rows), n, 1))[..., 0]
        Y = Y - step.reshape(len(rows), J, 3)
    X[rows] = Y
    return X, held


_LATERAL = MIRROR != np.arange(J)
#: Largest distance (view pixels) one keypoint counts with when choosing left/right.
SWAP_CAP_PX = 60.0


def _side_group(*parts: str) -> np.ndarray:
    """The left and right keypoints of some body parts: a (J,) mask of the joints whose labels an
    exchange of these parts moves."""
    mask = np.zeros(J, bool)
    for part in parts:
        mask[[JOINT_INDEX["left_" + part], JOINT_INDEX["right_" + part]]] = True
    return mask


#: Limbs a 2D network can label the wrong way round on their own, the rest of the body right (legs
#: crossing as a person turns, arms seen side-on): checked one by one after the whole body.
LIMB_SIDE_GROUPS = (
    _side_group("elbow", "wrist", "pinky", "index", "thumb"),
    _side_group("knee", "ankle", "heel", "foot_index"),
)


def correct_left_right(
    projections: np.ndarray,
    pixels_view: np.ndarray,
    confidence: np.ndarray,
    reference_world: np.ndarray,
    margin: float = 0.5,
    trust_cameras: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Undo a 2D network's left/right swap, camera by camera, against a reference pose.

    The reference (R, 33, 3) -- the worker's previous fitted pose -- is projected into each
    camera's view; a camera's keypoints are exchanged left for right when the exchanged set lies
    closer to the projection, by the cost sum_j confidence_j min(|u_j - pi_j|, SWAP_CAP_PX)^2 over
    the sided keypoints, than ``margin`` x the cost as reported. Then the same for the arms and
    for the legs on their own (:data:`LIMB_SIDE_GROUPS`): a network that takes a turning person's
    legs the wrong way round while the rest is right. A network that swaps sides in one camera
    makes the two cameras contradict each other on every limb; a triangulation can only reject
    those joints, the body model would be pulled between two bodies.
    The reference can itself be the one the wrong way round (a fit that once took a mirrored
    labelling keeps every camera mirrored to it from then on). So for each side group the
    function also tells whether the cameras were unanimous against the reference: two or more
    cameras could tell and every one of them would be exchanged. For rows and groups where
    ``trust_cameras`` (R, G) is set, such a unanimous exchange is not made: the cameras win (and
    when they win for the whole body, the limbs are not checked against that reference either).
    Returns (pixels, confidence, swapped (R, C) bool: the whole body or a limb exchanged,
    unanimous (R, G) bool for the G = 1 + len(LIMB_SIDE_GROUPS) side groups: whole body, arms,
    legs). Rows whose reference is NaN are left as they are.
    """
    P = np.asarray(projections, dtype=np.float64)
    Xh = np.concatenate([reference_world, np.ones(reference_world.shape[:-1] + (1,))], axis=-1)
    x = np.einsum("rcab,rjb->rcja", P, Xh)
    with np.errstate(invalid="ignore", divide="ignore"):
        proj = x[..., :2] / x[..., 2:3]
        ok_ref = (x[..., 2] > 0) & np.isfinite(proj).all(axis=-1)

        def cost(px: np.ndarray, conf: np.ndarray, group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            d = np.minimum(np.linalg.norm(px - proj, axis=-1), SWAP_CAP_PX)
            use = ok_ref & group & (conf > 0) & np.isfinite(d)
            return np.where(use, conf * d * d, 0.0).sum(axis=-1), use.sum(axis=-1)

        px, conf = pixels_view, confidence
        swapped = np.zeros(P.shape[:2], bool)
        groups = ((_LATERAL, 4), *((g, 2) for g in LIMB_SIDE_GROUPS))
        unanimous = np.zeros((P.shape[0], len(groups)), bool)
        trust = np.zeros_like(unanimous) if trust_cameras is None else np.asarray(trust_cameras, bool)
        for g, (group, least) in enumerate(groups):
            c_as, n_as = cost(px, conf, group)
            mirror = np.where(group, MIRROR, np.arange(J))
            px_sw, conf_sw = px[:, :, mirror], conf[:, :, mirror]
            c_sw, _ = cost(px_sw, conf_sw, group)
            can_tell = n_as >= least
            swap = can_tell & (c_sw < margin * c_as)
            unanimous[:, g] = (can_tell.sum(axis=1) >= 2) & (swap == can_tell).all(axis=1)
            # A reference the cameras overrule as a whole is mirrored everywhere: its limbs say nothing.
            overruled = (unanimous[:, g] & trust[:, g]) | (unanimous[:, 0] & trust[:, 0])
            swap &= ~overruled[:, None]
            px = np.where(swap[..., None, None], px_sw, px)
            conf = np.where(swap[..., None], conf_sw, conf)
            swapped |= swap
    return px, conf, swapped, unanimous


def raw_noise_scale(reprojection_error_px: np.ndarray, confidence: np.ndarray, views: np.ndarray) -> np.ndarray:
    """(R, 33) RMS reprojection errors of the plain two-or-more-camera triangulation (view pixels),
    the mean confidence of the views used and their number -> (R,) the keypoint sigma at
    confidence 1 those residuals show (view pixels; NaN without a triangulated joint).

    V views of a point give 2V residual coordinates for 3 unknowns: the expected sum of squared
    residuals is sigma^2 (2V - 3) (sigma at the observation's confidence = sigma_1 / confidence),
    and reprojection_error_px^2 = that sum / V. The median over the joints keeps a wrong keypoint
    out."""
    V = np.asarray(views, dtype=np.float64)
    e = np.asarray(reprojection_error_px, dtype=np.float64)
    c = np.asarray(confidence, dtype=np.float64)
    ok = (V >= 2) & np.isfinite(e) & (c > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        s2 = np.where(ok, V * e * e * c * c / np.maximum(2 * V - 3, 1), np.nan)
        out = np.sqrt(np.nanmedian(np.where(ok.any(axis=1, keepdims=True), s2, 0.0), axis=1))
    return np.where(ok.any(axis=1), out, np.nan)


def _pelvis_guess(
    points_world: np.ndarray,
    projections: np.ndarray,
    pixels_view: np.ndarray,
    confidence: np.ndarray,
    height_m: float = HIPS_M,
) -> np.ndarray:
    """(R, 3) where to put a body nothing is known about yet: the mid-hip of the triangulation,
    else 0.3 m below its other torso joints, else on the mean ray of the first camera that saw
    the person, at ``height_m`` above the floor. NaN when none of these exists."""
    X = points_world
    out: FloatArray = 0.5 * (X[:, _LHIP] + X[:, _RHIP])
    torso = np.array([JOINT_INDEX[n] for n in ("left_shoulder", "right_shoulder", "left_hip", "right_hip")])
    ok = np.isfinite(X[:, torso]).all(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(ok[..., None], X[:, torso], 0.0).sum(axis=1) / ok.sum(axis=1)[:, None]
    out = np.where(np.isfinite(out).all(axis=-1, keepdims=True), out, mean - np.array([0.0, 0.0, 0.3]))
    need = ~np.isfinite(out).all(axis=-1)
    for r in np.flatnonzero(need):
        for c in range(projections.shape[1]):
            seen = (confidence[r, c] > 0) & np.isfinite(pixels_view[r, c]).all(axis=-1)
            if not seen.any():
                continue
            M = projections[r, c, :, :3]
            centre = -np.linalg.solve(M, projections[r, c, :, 3])
            uv = np.concatenate([pixels_view[r, c, seen], np.ones((int(seen.sum()), 1))], axis=-1)
            d = np.linalg.solve(M, uv.T).T
            d = (d / np.linalg.norm(d, axis=-1, keepdims=True)).mean(axis=0)
            if d[2] < -1e-6:
                out[r] = centre + d * (height_m - centre[2]) / d[2]
                break
    return out


#: The neutral pose as a right-handed body (x towards the right hip): a rotation places it.
_TEMPLATE_RIGHT_HANDED = TEMPLATE_BODY * np.array([-1.0, 1.0, 1.0])


def _aligned_template(points_world: np.ndarray, fallback: np.ndarray, min_points: int = 4) -> np.ndarray:
    """(33, 3) the neutral pose turned and moved onto a new track's triangulated points (NaN = not
    triangulated; least squares, a proper rotation, so the pose is never its mirror image), where
    at least ``min_points`` of them span a plane; else ``fallback``. The joints no camera pair saw
    start from it: a face or a side started from a template placed from a missing hip turned
    into its mirror image, which keeps every distance of the rigid part and held on for 50
    frames (ORACLE, 4 workers, 2592 x 1944: neck flexion off by 120 deg)."""
    ok = np.isfinite(points_world).all(axis=-1)
    if ok.sum() < min_points:
        return fallback
    b = points_world[ok]
    sv = np.linalg.svd(b - b.mean(axis=0), compute_uv=False)
    if sv[1] < 1e-3 * max(sv[0], 1e-12):  # the points lie on a line: the turn about it is unknown
        return fallback
    rot, shift = kabsch(_TEMPLATE_RIGHT_HANDED[ok], b)
    out: np.ndarray = _TEMPLATE_RIGHT_HANDED @ rot.T + shift
    return out


class ShiftBodies:
    """The body model of every worker over a shift, fitted frame after frame (see module docstring).

    Per worker: a histogram of its best-seen raw segment lengths (1 mm bins), the segment lengths
    in use (refreshed on a fixed grid of frames, once a second, from everything before the grid
    point -- so the result does not depend on how the shift is cut into chunks), and its last
    fitted pose. Picklable with the rest of the reconstruction's state.
    """

    def __init__(self, settings: ReconSettings, fps: float) -> None:
        self.settings = settings
        self.options = FitOptions.from_settings(settings)
        self.fps = float(fps)
        self.refresh = max(1, int(round(self.fps)))
        self.max_gap = int(np.ceil(self.options.max_prior_gap_s * self.fps))
        self.hists: dict[int, LimbHistogram] = {}
        self.hists_all: dict[int, LimbHistogram] = {}
        self.lengths: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.last: dict[int, tuple[int, np.ndarray]] = {}
        self.swaps = 0  # camera-frames whose left and right were exchanged (correct_left_right)
        # Consecutive fitted frames in which every camera disagreed with the worker's previous fit
        # on its sides, per side group (whole body, arms, legs); from side_lock_break_frames on,
        # the cameras win.
        self.side_lock: dict[int, np.ndarray] = {}
        self.side_lock_break_frames = (
            int(round(settings.side_lock_break_s * self.fps)) if settings.side_lock_break_s > 0 else None
        )
        self.lock_breaks = 0  # worker-frames and groups where the cameras' unanimous sides beat the previous fit
        self.fitted_rows = 0  # worker-frames fitted, and the seconds spent (for the benchmark)
        self.fit_seconds = 0.0
        self.noise: dict[int, float] = {}  # keypoint noise measured per worker, x keypoint_sigma_px

    def _refresh(self) -> None:
        """Segment lengths of every worker: the median of the best-seen samples (the gated
        triangulation: both points above min_confidence in two cameras, reprojection-checked)
        where a segment has BEST_SAMPLES of them; else, for the long segments (limbs, trunk sides,
        neck), the median of every sample (every joint triangulated from all the cameras that saw
        it, :func:`ergopose.recon.triangulate.triangulate_observations`: with ceiling cameras legs,
        the neck and the face are rarely above the gate in two cameras -- oracle, 30 s, 4
        workers: thigh, shank and neck had 0-8 best samples per worker, and a population length
        scaled from the hands missed the shank by up to 20 %); else the population length
        scaled to the worker's long segments. Short segments (hands, feet, face) never take the
        ungated samples: their noise is large against their length, and a noisy length is too
        long by about var / 2L (oracle, 30 s: hands +5 cm, ankle-heel +3 cm; MPJPE 34.4 mm
        against 30.2 mm with the scaled population lengths)."""
        for ident, h_all in self.hists_all.items():
            h = self.hists[ident]
            best = h.samples >= BEST_SAMPLES
            med = np.where(best, h.medians(min_samples=1), np.where(_LONG, h_all.medians(min_samples=1), np.nan))
            self.lengths[ident] = worker_lengths(med, np.where(best, h.samples, np.where(_LONG, h_all.samples, 0)))

    def _lengths_of(self, ident: int) -> tuple[np.ndarray, np.ndarray]:
        if ident not in self.lengths:
            return worker_lengths(np.full(NUM_SEGMENTS, np.nan), np.zeros(NUM_SEGMENTS))
        return self.lengths[ident]

    def fit_range(self, rows: dict[str, np.ndarray], f0: int, f1: int) -> None:
        """Fit the rows of frames f0 <= f < f1, in frame order (rows sorted by frame).

        rows: "frame", "identity", "points" (gated raw triangulation), "ungated"
        (triangulate_observations), "var", "views", "P", "px", "oc"; writes "fit", "fit_var", "inferred",
        "limited", "fit_err" in place.
        """
        t0 = time.perf_counter()
        frames = rows["frame"]
        b = int(f0)
        while b < f1:
            if b % self.refresh == 0:
                self._refresh()
            e = min(int(f1), (b // self.refresh + 1) * self.refresh)
            i0, i1 = (int(i) for i in np.searchsorted(frames, [b, e]))
            if i1 > i0:
                starts = np.flatnonzero(np.r_[True, frames[i0 + 1 : i1] != frames[i0 : i1 - 1]]) + i0
                for s, t in zip(starts, np.r_[starts[1:], i1]):
                    self._fit_frame(rows, np.arange(s, t))
                best = segment_lengths(rows["points"][i0:i1])
                every = segment_lengths(rows["ungated"][i0:i1])
                ids = rows["identity"][i0:i1]
                for ident in np.unique(ids):
                    h = self.hists.setdefault(int(ident), LimbHistogram(NUM_SEGMENTS))
                    h.add(best[ids == ident])
                    h_all = self.hists_all.setdefault(int(ident), LimbHistogram(NUM_SEGMENTS))
                    h_all.add(every[ids == ident])
            b = e
        self.fit_seconds += time.perf_counter() - t0

    def _fit_frame(self, rows: dict[str, np.ndarray], idx: np.ndarray) -> None:
        f = int(rows["frame"][idx[0]])
        ids = rows["identity"][idx]
        oc = rows["oc"][idx]
        has = oc.reshape(len(idx), -1).max(axis=1) > 0
        # Rows without 2D observations (made from 3D points): the triangulation passes through.
        for passing in np.flatnonzero(~has):
            r = idx[passing]
            rows["fit"][r] = rows["points"][r]
            rows["fit_var"][r] = rows["var"][r]
            rows["inferred"][r] = rows["views"][r] < 2
            rows["limited"][r] = False
        if not has.any():
            return
        idx, ids = idx[has], ids[has]
        n = len(idx)
        Ls, plays = zip(*(self._lengths_of(int(i)) for i in ids))
        prev = np.full((n, J, 3), np.nan)
        prev_sigma = np.full(n, np.nan)
        prev_dt = np.full(n, np.nan)
        for k, ident in enumerate(ids):
            last = self.last.get(int(ident))
            if last is not None and 0 < f - last[0] <= self.max_gap:
                prev[k] = last[1]
                prev_dt[k] = (f - last[0]) / self.fps
                prev_sigma[k] = self.options.temporal_sigma_m + self.options.speed_m_s * prev_dt[k]
        tri = rows["points"][idx]
        P, px = rows["P"][idx], rows["px"][idx]
        oc = rows["oc"][idx]
        have_prev = np.isfinite(prev_sigma)
        if have_prev.any():
            groups = 1 + len(LIMB_SIDE_GROUPS)
            runs = np.stack([self.side_lock.get(int(i), np.zeros(groups, int)) for i in ids])
            limit = self.side_lock_break_frames
            trust = runs >= limit if limit is not None else np.zeros_like(runs, bool)
            px, oc, swapped, unanimous = correct_left_right(
                P, px, oc, np.where(have_prev[:, None, None], prev, np.nan), trust_cameras=trust
            )
            self.swaps += int(swapped.sum())
            self.lock_breaks += int((unanimous & trust).sum())
            runs = np.where(unanimous & ~trust & have_prev[:, None], runs + 1, 0)
            for k, ident in enumerate(ids):
                self.side_lock[int(ident)] = runs[k]
            # The plain triangulation paired the cameras' keypoints as reported: not a start there.
            tri = np.where(np.asarray(swapped.any(axis=1))[:, None, None] & _LATERAL[None, :, None], np.nan, tri)
        pelvis = _pelvis_guess(tri, P, px, oc)
        pelvis = np.where(np.isfinite(pelvis), pelvis, np.array([0.0, 0.0, 0.95]))
        facing = _yaw_frames(np.where(np.isfinite(tri), tri, 0.0))
        first = template_pose(pelvis, facing)
        for row in np.flatnonzero(~have_prev):
            first[row] = _aligned_template(tri[row], first[row])
        start = np.where(have_prev[:, None, None], prev, first)
        start = np.where(np.isfinite(tri), tri, start)
        used_scale = np.array([self.noise.get(int(i), 1.0) for i in ids])
        self.fitted_rows += n
        fit = fit_bodies(
            P,
            px,
            oc,
            start,
            np.stack(Ls),
            np.stack(plays),
            prev,
            prev_sigma,
            prev_dt,
            self.options,
            sigma_scale=used_scale,
        )
        # The worker's keypoint noise: a running mean (log domain, NOISE_RATE per frame) of what the
        # cameras' disagreement shows (raw_noise_scale: from the plain triangulation, so the
        # estimate cannot feed on the fit's own priors -- measured from the fit's residuals it ran
        # away on a real recording, 38 x in 70 frames, and the body drifted 30 cm), never below
        # keypoint_sigma_px; this frame's variance grows with it at once.
        measured = (
            raw_noise_scale(rows["err"][idx], rows["conf"][idx], rows["views"][idx]) / self.options.keypoint_sigma_px
        )
        new_scale = np.where(
            np.isfinite(measured),
            np.exp(np.log(used_scale) + NOISE_RATE * (np.log(np.maximum(measured, 1e-6)) - np.log(used_scale))),
            used_scale,
        )
        new_scale = np.maximum(new_scale, MIN_NOISE_SCALE)
        for k, ident in enumerate(ids):
            self.noise[int(ident)] = float(new_scale[k])
        var = fit.variance_world * np.maximum(new_scale / used_scale, 1.0)[:, None, None] ** 2
        points, inferred, err = fit.points_world, fit.inferred, fit.reprojection_error_px
        rows["fit"][idx] = points
        rows["fit_var"][idx] = var
        rows["inferred"][idx] = inferred
        rows["limited"][idx] = fit.limited
        rows["fit_err"][idx] = err
        for k, ident in enumerate(ids):
            self.last[int(ident)] = (f, points[k].copy())
