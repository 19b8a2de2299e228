"""How sure each frame's angles and scores are: resampling the 3D joints within their uncertainty.

The reconstruction gives every joint of every frame a standard deviation per world coordinate
(the body fit's covariance, smoothed; the tracks table's ``std_x/y/z``). That covariance holds
only what the cameras disagree on; the scoring setting ``joint_sd_floor_m`` adds the pose
network's own error (the same in every camera, an offset of each joint that lasts: see
:func:`iter_samples`). Here the joints are drawn ``SAMPLES`` times from independent normal
distributions with those deviations; the joint
angles and the RULA and REBA scores are computed for every draw exactly as for the estimate
(the same angle and scoring code, task inputs and time windows). From the draws:

- ``<angle>_sd``: the standard deviation of each angle over the draws (radians inside; degrees
  in the CSV), measured from the estimate's angle;
- ``rula_grand_p`` / ``reba_score_p``: the share of draws that give the reported score -- the
  probability that the reported score is the one the true posture would give, under the joints'
  uncertainty;
- ``rula_grand_low`` / ``rula_grand_high``, ``reba_score_low`` / ``reba_score_high``: the lowest
  and highest score of the middle 80 % of the draws (10th and 90th percentile);
- ``confidence``: ``confident`` when both reported scores have a probability of at least
  ``CONFIDENT_P`` and no joint limit held a joint the scores need, ``low`` when scored otherwise,
  ``unscored`` when a score is missing. A held joint is never confident: the cameras showed a
  posture the body cannot take, so their keypoints of that joint are wrong by more than the
  fit's uncertainty says (measured on the simulated demo with the network: the elbow flexion where
  a limit held the elbow was 101-111 deg off the truth (RMSE), 1 of 101 rows within 2 reported
  SDs; docs/reconstruction.md, "Which joints a limit held");
- ``cause``: why a frame is not confident (``joint limit`` for a frame whose scores are sure
  but for a held joint; otherwise the first that applies of): ``not seen`` (no camera saw the worker in this
  frame), ``one camera`` (only one camera saw the worker), ``occluded limbs`` (joints the scores
  need were placed by the body model, not seen by two cameras), ``joint limit`` (the cameras put
  an elbow, a knee or the head past its anatomical range and the body model held it at the
  limit), ``uncertain angles`` (seen, but the angles are too uncertain for the score), empty when
  confident;
- ``held_at_limit``: the body parts whose angles a joint limit held in the frame (``neck``,
  ``left lower arm``, ``right lower arm``, ``legs``), joined by ";"; empty when none
  (:func:`held_parts`).

The draws come from fixed, seeded standard normal numbers, one set per draw and the same in every
frame (the estimate's errors last; :func:`iter_samples`), so a frame gets the same draws however
the shift is cut into blocks: results do not depend on chunking, and the same input gives the same
bytes.
"""

from __future__ import annotations

import warnings
from typing import Iterator

import numpy as np
import pandas as pd

from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS

#: Draws per frame.
SAMPLES = 16
#: A score is "confident" when at least this share of the draws gives the reported score.
CONFIDENT_P = 0.6
_SEED = 20181001
_TABLE: np.ndarray | None = None
_OFFSETS: np.ndarray | None = None

#: Angles that get a standard deviation column (the posture's angles, radians).
SD_ANGLES = (
    "trunk_flexion",
    "trunk_side_bend",
    "trunk_twist",
    "neck_flexion",
    "neck_side_bend",
    "neck_twist",
    "left_upper_arm_flexion",
    "right_upper_arm_flexion",
    "left_upper_arm_abduction",
    "right_upper_arm_abduction",
    "left_elbow_flexion",
    "right_elbow_flexion",
    "left_wrist_flexion",
    "right_wrist_flexion",
    "left_wrist_deviation",
    "right_wrist_deviation",
    "left_knee_flexion",
    "right_knee_flexion",
)
SD_COLUMNS = tuple(f"{a}_sd" for a in SD_ANGLES)
SCORE_COLUMNS = (
    "rula_grand_p",
    "rula_grand_low",
    "rula_grand_high",
    "reba_score_p",
    "reba_score_low",
    "reba_score_high",
    "confidence",
    "cause",
    "held_at_limit",
)
CONFIDENCE_LEVELS = ("confident", "low", "unscored")
#: Causes of a frame that is not confident, in the order reports list them.
CAUSES = ("not seen", "one camera", "occluded limbs", "joint limit", "uncertain angles")

#: Joints the scores need (both methods): a frame whose needed joints were placed by the body
#: model rather than seen by two cameras is "occluded limbs" when not confident.
SCORED_JOINTS = np.array(
    [
        JOINT_INDEX[n]
        for n in (
            "left_ear",
            "right_ear",
            "left_shoulder",
            "right_shoulder",
            "left_elbow",
            "right_elbow",
            "left_wrist",
            "right_wrist",
            "left_index",
            "right_index",
            "left_pinky",
            "right_pinky",
            "left_hip",
            "right_hip",
            "left_knee",
            "right_knee",
            "left_ankle",
            "right_ankle",
        )
    ]
)


#: The RULA/REBA inputs whose certainty the shift summary reports, per body part: (body part in
#: words, its SD_ANGLES angles, the joints those angles are measured from).
INPUT_GROUPS = (
    (
        "neck",
        ("neck_flexion", "neck_side_bend", "neck_twist"),
        ("left_ear", "right_ear", "left_shoulder", "right_shoulder"),
    ),
    (
        "trunk",
        ("trunk_flexion", "trunk_side_bend", "trunk_twist"),
        ("left_shoulder", "right_shoulder", "left_hip", "right_hip"),
    ),
    ("left upper arm", ("left_upper_arm_flexion", "left_upper_arm_abduction"), ("left_shoulder", "left_elbow")),
    ("right upper arm", ("right_upper_arm_flexion", "right_upper_arm_abduction"), ("right_shoulder", "right_elbow")),
    ("left lower arm", ("left_elbow_flexion",), ("left_elbow", "left_wrist")),
    ("right lower arm", ("right_elbow_flexion",), ("right_elbow", "right_wrist")),
    ("left wrist", ("left_wrist_flexion", "left_wrist_deviation"), ("left_wrist", "left_index", "left_pinky")),
    ("right wrist", ("right_wrist_flexion", "right_wrist_deviation"), ("right_wrist", "right_index", "right_pinky")),
    (
        "legs",
        ("left_knee_flexion", "right_knee_flexion"),
        ("left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle"),
    ),
)
#: The joints of each INPUT_GROUPS entry as indices into the 33 joints.
INPUT_GROUP_JOINTS = tuple(np.array([JOINT_INDEX[j] for j in joints]) for _, _, joints in INPUT_GROUPS)
#: The joints whose ``limited`` flag (the tracks table's: a joint limit of the body model held the
#: joint, ergopose.recon.bodyfit.LIMIT_HELD_JOINTS) tells that an INPUT_GROUPS entry's angles were
#: held at an anatomical limit: the face's points for the neck, the elbow for a lower arm, the
#: knees for the legs; none for the others (no limit holds them).
_LIMIT_JOINTS_BY_GROUP = {
    "neck": ("nose", "left_eye", "right_eye"),
    "left lower arm": ("left_elbow",),
    "right lower arm": ("right_elbow",),
    "legs": ("left_knee", "right_knee"),
}
INPUT_GROUP_LIMIT_JOINTS = tuple(
    np.array([JOINT_INDEX[j] for j in _LIMIT_JOINTS_BY_GROUP.get(part, ())], dtype=np.int64)
    for part, _, _ in INPUT_GROUPS
)
#: Every joint whose ``limited`` flag concerns a score (the union of INPUT_GROUP_LIMIT_JOINTS).
LIMITED_SCORED_JOINTS = np.unique(np.concatenate(INPUT_GROUP_LIMIT_JOINTS))


def held_parts(limited: np.ndarray | None, n: int) -> np.ndarray:
    """(n,) object array: per frame the INPUT_GROUPS body parts whose angles a joint limit held
    (limited: (n, 33) the tracks table's flags; None = none), joined by ";" in INPUT_GROUPS order;
    "" where none."""
    text = np.full(n, "", dtype=object)
    if limited is None:
        return text
    flags = np.asarray(limited, dtype=bool)
    for (part, _, _), joints in zip(INPUT_GROUPS, INPUT_GROUP_LIMIT_JOINTS):
        if len(joints):
            mask = flags[:, joints].any(axis=1)
            text = np.where(mask, np.where(text == "", part, text + ";" + part), text)
    return text


def _normals() -> np.ndarray:
    """(SAMPLES, 33, 3) standard normal numbers, one set per draw and the same in every frame
    (seeded), moment-matched over the draws: each joint coordinate's SAMPLES numbers have mean 0 and
    standard deviation 1, so the draws spread each coordinate by exactly its deviation however few
    they are (drawn once for a whole shift, a set's own sampling error would otherwise scale every
    frame's deviations alike)."""
    global _TABLE
    if _TABLE is None:
        z = np.random.default_rng(_SEED).standard_normal((SAMPLES, NUM_JOINTS, 3))
        _TABLE = (z - z.mean(axis=0)) / z.std(axis=0)
        _TABLE.setflags(write=False)
    return _TABLE


def _offsets() -> np.ndarray:
    """(SAMPLES, 33, 3) standard normal offsets of the joints, one set per draw (seeded)."""
    global _OFFSETS
    if _OFFSETS is None:
        rng = np.random.default_rng(_SEED + 1)
        _OFFSETS = rng.standard_normal((SAMPLES, NUM_JOINTS, 3))
        _OFFSETS.setflags(write=False)
    return _OFFSETS


def iter_samples(points_world: np.ndarray, std_world: np.ndarray, floor_m: float = 0.0) -> Iterator[np.ndarray]:
    """(n, 33, 3) estimate and deviations -> the SAMPLES draws, one (n, 33, 3) array at a time (a
    NaN deviation counts as 0): only one draw's points are in memory at once (all at once would be
    SAMPLES x 792 bytes per frame).

    Each draw moves every joint by its deviation in that frame times a standard normal number of
    its own that is the same in every frame (:func:`_normals`). The estimate's errors last: the
    smoother's output errs alike over neighbouring frames, and a network's errors are shared by the
    cameras. Drawn afresh in every frame, they would be a jitter the estimate does not have, which
    the scoring counts as repeated actions, rapid changes and one-sided adjustments: the draws then
    scored systematically higher than the estimate (ORACLE, 1 minute: the reported RULA grand score
    below the draws' 10th percentile in 13 % of frames, 2 % with lasting draws; docs/scoring.md).
    A frame's draws do not depend on the frames around it, so a shift cut into blocks gets the same
    draws.

    ``floor_m``: the keypoints' own error (metres per coordinate), added the same way with an
    independent set of offsets (:func:`_offsets`), so a frame's variance is the deviation's plus the
    floor's."""
    sd = np.where(np.isfinite(std_world), std_world, 0.0)
    table = _normals()
    offsets = _offsets()
    for k in range(SAMPLES):
        draw = points_world + sd * table[k]
        if floor_m > 0:
            draw = draw + floor_m * offsets[k]
        yield draw


def angle_sd(estimate: pd.DataFrame, draws: list[pd.DataFrame]) -> pd.DataFrame:
    """Standard deviation (radians) of each SD_ANGLES angle over the draws, about the estimate
    (wrapped to [-pi, pi)); NaN where the estimate is NaN."""
    out = {}
    for a in SD_ANGLES:
        if a not in estimate:
            continue
        est = estimate[a].to_numpy(np.float64)
        d = np.stack([dr[a].to_numpy(np.float64) for dr in draws]) - est
        d = (d + np.pi) % (2 * np.pi) - np.pi
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a frame whose every draw is NaN: NaN
            out[f"{a}_sd"] = np.sqrt(np.nanmean(d * d, axis=0)) if len(draws) else np.full(len(est), np.nan)
        out[f"{a}_sd"] = np.where(np.isfinite(est), out[f"{a}_sd"], np.nan)
    return pd.DataFrame(out, index=estimate.index)


def score_spread(reported: pd.Series, draws: list[pd.Series]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(probability of the reported score, 10th, 90th percentile) over the draws; NaN where not scored."""
    rep = pd.to_numeric(reported, errors="coerce").to_numpy(np.float64)
    D = np.stack([pd.to_numeric(d, errors="coerce").to_numpy(np.float64) for d in draws])
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # frames without any scored draw: NaN
        p = np.where(np.isfinite(rep), (D == rep).mean(axis=0), np.nan)
        ok = np.isfinite(D)
        low = np.where(ok.any(axis=0), np.nanpercentile(np.where(ok, D, np.nan), 10, axis=0, method="lower"), np.nan)
        high = np.where(ok.any(axis=0), np.nanpercentile(np.where(ok, D, np.nan), 90, axis=0, method="higher"), np.nan)
    bad = ~np.isfinite(rep)
    return p, np.where(bad, np.nan, low), np.where(bad, np.nan, high)


def frame_confidence(
    rula_p: np.ndarray,
    reba_p: np.ndarray,
    views: np.ndarray | None,
    inferred: np.ndarray | None,
    seen_cameras: np.ndarray | None,
    limited: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(confidence, cause) per frame (object arrays of strings; see the module docstring).

    views: (n, 33) cameras that saw each joint with the reconstruction's min_confidence;
    inferred: (n, 33) joints placed by the body model; seen_cameras: (n,) the most cameras that saw
    any joint of the worker in the frame (0 = not seen); limited: (n, 33) joints a joint limit held
    (None = none). seen_cameras None = unknown (no cause given)."""
    n = len(rula_p)
    scored = np.isfinite(rula_p) & np.isfinite(reba_p)
    held = np.asarray(limited)[:, LIMITED_SCORED_JOINTS].any(axis=1) if limited is not None else np.zeros(n, bool)
    with np.errstate(invalid="ignore"):
        sure = scored & (rula_p >= CONFIDENT_P) & (reba_p >= CONFIDENT_P)
    confident = sure & ~held
    conf = np.where(confident, "confident", np.where(scored, "low", "unscored")).astype(object)
    cause = np.full(n, "", dtype=object)
    if seen_cameras is not None:
        occluded = inferred[:, SCORED_JOINTS].any(axis=1) if inferred is not None else np.zeros(n, bool)
        cause = np.select(
            [seen_cameras == 0, seen_cameras == 1, occluded, held],
            ["not seen", "one camera", "occluded limbs", "joint limit"],
            "uncertain angles",
        ).astype(object)
        cause[sure & held] = "joint limit"  # sure of the scores but for the limit: the limit is why
        cause[confident] = ""
    return conf, cause
