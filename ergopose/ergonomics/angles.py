"""Joint angles and stance flags from 3D BlazePose joints: the posture table.

``joint_angles(points_world, time_s)`` turns a track of 3D joints (F frames x 33 BlazePose points,
world frame: metres, floor z = 0, z up) into one value per frame and named angle, and
``JointAngles.to_frame()`` gives the posture table that RULA/REBA scoring reads (one row per frame).
Every definition (which joints, which plane, which sign) is in docs/joint-angles.md; the short form:

- Sign rule: flexion positive, extension negative; elbow and knee flexion 0 = straight. Side bend is
  positive toward the body's right, twist positive when the upper segment turns to the body's left
  (counter-clockwise seen from above). Upper-arm and hip abduction are positive away from the body
  (to that limb's own side); wrist deviation is positive toward the thumb (radial).
- Trunk, neck, upper arm and hip use one scheme: the angle IN the parent's sagittal plane (flexion),
  then the angle OUT of that plane (side bend / abduction), then the turn about the segment's own
  axis (twist). For a full frame this is the intrinsic y-x-z Euler sequence of the segment relative
  to its parent (x forward, y left, z up).
- Parents: trunk -> the pelvis frame (hip line, level, world vertical); neck (the line from the
  neck base, the trunk axis at the relaxed shoulder height, to the mid-ear point, turned by the
  ear line) -> the trunk frame;
  upper arm -> the trunk frame; hip -> the pelvis frame; wrist -> measured in the hand frame,
  because the forearm's roll is not observable.
- Angles are radians; degrees only at the CSV/report edges. NaN wherever a needed joint is NaN or
  the geometry is degenerate (coincident points); no warnings.
- Yes/no flags that are thresholds on a measured angle or distance (shoulder raised, wrist
  deviated, arm across the midline or out to the side, trunk/neck twisted or side-bent) are left to
  scoring, which derives them from the measured columns with its own settings; the stance flags
  (legs supported, one-leg stance, seated, walking) are decided here.

The body model in :mod:`ergopose.ergonomics.body` is posed with these same definitions, which is how
the tests check that every angle is recovered.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ergopose.arrays import FloatArray
from ergopose.errors import ConfigError, InputError
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS

SIDES = ("left", "right")
_SIGMA = {"left": 1.0, "right": -1.0}
_EPS = 1e-9  # metres: vectors shorter than this are degenerate


@dataclass(frozen=True)
class AngleSettings:
    """Settings of the angle definitions and the stance/flag thresholds (radians, metres, seconds).

    neck_neutral_offset: how far forward of the trunk axis the neck line (neck base -> mid-ear)
        leans in the neutral posture; neck flexion is reduced by it. 0 = ear, shoulder and hip in
        one line (the plumb line of ideal standing posture; see docs/joint-angles.md).
    trunk_length_m: mid-hip to mid-shoulder distance with relaxed shoulders, the reference of
        shoulder elevation; None = the median over the sequence of both shoulders' heights along the
        trunk axis (assumes the shoulders are relaxed most of the time).
    rotation_min_elbow_flexion: upper-arm rotation is NaN when the elbow is straighter than this.
    foot_contact_height_m: a foot whose lowest point (heel or foot_index) is higher above the floor
        than this is off the floor.
    foot_lift_height_m: a foot higher than the other foot by more than this is lifted (needs no
        floor calibration; catches keypoints that sit a few cm above the sole).
    ankle_height_m: used only when both heel and foot_index are missing: foot height = ankle height
        above the floor minus this.
    walking_window_s / walking_min_speed_mps: walking when the mid-ankle point's net horizontal
        displacement over a centred window of this length, divided by the window's duration, is at
        least this speed.
    balance_max_offset_m: standing weight counts as evenly balanced when the mid-hip point is within
        this horizontal distance of the mid-ankle point.
    seated_max_thigh_incline / seated_min_hip_height_m: seated when the thighs (mean of both sides)
        point less steeply downward than this angle from the horizontal and the mid-hip point is at
        least this high above the floor (a deep squat has the hips lower).
    """

    neck_neutral_offset: float = 0.0
    trunk_length_m: float | None = None
    rotation_min_elbow_flexion: float = math.radians(20.0)
    foot_contact_height_m: float = 0.12
    foot_lift_height_m: float = 0.07
    ankle_height_m: float = 0.07
    walking_window_s: float = 1.0
    walking_min_speed_mps: float = 0.25
    balance_max_offset_m: float = 0.10
    seated_max_thigh_incline: float = math.radians(45.0)
    seated_min_hip_height_m: float = 0.30

    def __post_init__(self) -> None:
        positive = (
            "foot_contact_height_m",
            "foot_lift_height_m",
            "walking_window_s",
            "walking_min_speed_mps",
            "balance_max_offset_m",
            "seated_max_thigh_incline",
            "seated_min_hip_height_m",
        )
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name == "trunk_length_m" and v is None:
                continue
            if not isinstance(v, (int, float, np.floating)) or not math.isfinite(v):
                raise ConfigError(f"must be a finite number, got {v!r}", field=f.name)
            if (f.name in positive or f.name == "trunk_length_m") and v <= 0:
                raise ConfigError(f"must be positive, got {v!r}", field=f.name)
            if f.name in ("rotation_min_elbow_flexion", "ankle_height_m") and v < 0:
                raise ConfigError(f"must not be negative, got {v!r}", field=f.name)


#: The posture-table columns of the shared contract (docs/posture-table.md) that joint_angles
#: fills. The contract's angle-derived yes/no flags (shoulder_raised, wrist_deviated,
#: arm_across_midline_or_out) are NOT filled here: scoring derives them from the measured columns
#: below with its own thresholds (ScoringSettings), so each threshold lives in one place. (A flag
#: column in the table would override those settings.)
POSTURE_TABLE_COLUMNS: tuple[str, ...] = (
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
    "left_knee_flexion",
    "right_knee_flexion",
    "legs_supported",
    "one_leg_stance",
    "seated",
    "walking",
    "time_s",
)

#: Measured columns the posture table accepts and scoring derives flags from.
MEASURED_COLUMNS: tuple[str, ...] = (
    "left_shoulder_elevation",
    "right_shoulder_elevation",
    "left_upper_arm_elevation",
    "right_upper_arm_elevation",
    "left_wrist_deviation",
    "right_wrist_deviation",
    "left_wrist_lateral_m",
    "right_wrist_lateral_m",
)

#: Further measurements, outside the posture-table contract (``to_frame(diagnostics=True)``).
DIAGNOSTIC_COLUMNS: tuple[str, ...] = (
    "left_upper_arm_rotation",
    "right_upper_arm_rotation",
    "left_hip_flexion",
    "right_hip_flexion",
    "left_hip_abduction",
    "right_hip_abduction",
    "left_foot_height_m",
    "right_foot_height_m",
    "feet_on_floor",
    "walking_speed_mps",
)

#: Columns that are 0/1 flags (NaN = unknown).
FLAG_COLUMNS: tuple[str, ...] = ("legs_supported", "one_leg_stance", "seated", "walking")

ALL_COLUMNS = POSTURE_TABLE_COLUMNS + MEASURED_COLUMNS + DIAGNOSTIC_COLUMNS


@dataclass(frozen=True)
class JointAngles:
    """Per-frame joint angles and stance flags; every field is a float array of shape (F,).

    Angles in radians (definitions: docs/joint-angles.md), lengths in metres, speeds in m/s, flags
    0.0/1.0. NaN means unknown: a needed joint was missing (NaN) in that frame or the geometry was
    degenerate; ``time_s`` is NaN throughout when no times were given (``walking`` is then NaN too).
    """

    trunk_flexion: np.ndarray
    trunk_side_bend: np.ndarray
    trunk_twist: np.ndarray
    neck_flexion: np.ndarray
    neck_side_bend: np.ndarray
    neck_twist: np.ndarray
    left_upper_arm_flexion: np.ndarray
    right_upper_arm_flexion: np.ndarray
    left_upper_arm_abduction: np.ndarray
    right_upper_arm_abduction: np.ndarray
    left_elbow_flexion: np.ndarray
    right_elbow_flexion: np.ndarray
    left_wrist_flexion: np.ndarray
    right_wrist_flexion: np.ndarray
    left_knee_flexion: np.ndarray
    right_knee_flexion: np.ndarray
    legs_supported: np.ndarray
    one_leg_stance: np.ndarray
    seated: np.ndarray
    walking: np.ndarray
    time_s: np.ndarray
    left_shoulder_elevation: np.ndarray
    right_shoulder_elevation: np.ndarray
    left_upper_arm_elevation: np.ndarray
    right_upper_arm_elevation: np.ndarray
    left_wrist_deviation: np.ndarray
    right_wrist_deviation: np.ndarray
    left_wrist_lateral_m: np.ndarray
    right_wrist_lateral_m: np.ndarray
    left_upper_arm_rotation: np.ndarray
    right_upper_arm_rotation: np.ndarray
    left_hip_flexion: np.ndarray
    right_hip_flexion: np.ndarray
    left_hip_abduction: np.ndarray
    right_hip_abduction: np.ndarray
    left_foot_height_m: np.ndarray
    right_foot_height_m: np.ndarray
    feet_on_floor: np.ndarray
    walking_speed_mps: np.ndarray

    @property
    def n_frames(self) -> int:
        return int(self.trunk_flexion.shape[0])

    def to_frame(self, diagnostics: bool = False) -> pd.DataFrame:
        """The posture table, one row per frame: POSTURE_TABLE_COLUMNS then MEASURED_COLUMNS (and
        DIAGNOSTIC_COLUMNS if asked). ``time_s`` is left out when no frame times were given."""
        names = POSTURE_TABLE_COLUMNS + MEASURED_COLUMNS + (DIAGNOSTIC_COLUMNS if diagnostics else ())
        if self.n_frames and np.isnan(self.time_s).all():
            names = tuple(n for n in names if n != "time_s")
        return pd.DataFrame({name: getattr(self, name) for name in names})


assert [f.name for f in dataclasses.fields(JointAngles)] == list(ALL_COLUMNS)

# ----------------------------------------------------------------------------------------------
# Vector helpers on (F, 3) arrays; NaN in -> NaN out, degenerate -> NaN, no warnings.


def _dot(a: np.ndarray, b: np.ndarray) -> FloatArray:
    dot: FloatArray = np.einsum("...i,...i->...", a, b)
    return dot


def _norm(v: np.ndarray) -> FloatArray:
    return np.sqrt(_dot(v, v))


def _unit(v: np.ndarray) -> np.ndarray:
    n = _norm(v)
    ok = n > _EPS
    with np.errstate(invalid="ignore", divide="ignore"):
        out = v / np.where(ok, n, np.nan)[..., None]
    return out


def _perp_unit(v: np.ndarray, axis_unit: np.ndarray) -> np.ndarray:
    """v without its component along axis_unit, normalised."""
    return _unit(v - _dot(v, axis_unit)[..., None] * axis_unit)


def _angle_between(a: np.ndarray, b: np.ndarray) -> FloatArray:
    """Unsigned angle between vectors, [0, pi]; precise near 0 and pi."""
    ua, ub = _unit(a), _unit(b)
    angle: FloatArray = np.arctan2(_norm(np.cross(ua, ub)), _dot(ua, ub))
    return angle


def _asin(x: np.ndarray) -> FloatArray:
    angle: FloatArray = np.arcsin(np.clip(x, -1.0, 1.0))
    return angle


def _frame(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> FloatArray:
    """(F, 3, 3) rotation with columns x, y, z."""
    rotation: FloatArray = np.stack([x, y, z], axis=-1)
    return rotation


def _in_frame(frame: np.ndarray, v: np.ndarray) -> FloatArray:
    """Coordinates of world vectors v (F, 3) in frames (F, 3, 3): frame^T v."""
    coords: FloatArray = frame[:, 0, :] * v[:, 0:1] + frame[:, 1, :] * v[:, 1:2] + frame[:, 2, :] * v[:, 2:3]
    return coords


def _yxz(rel: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Intrinsic y-x-z angles (flexion, side bend, twist) of rel = Ry(a) Rx(b) Rz(c), (F, 3, 3)."""
    a = np.arctan2(rel[:, 0, 2], rel[:, 2, 2])
    b = _asin(-rel[:, 1, 2])
    c = np.arctan2(rel[:, 1, 0], rel[:, 1, 1])
    return a, b, c


def _wrap_from(angle: np.ndarray, lower: float) -> np.ndarray:
    """Angles mapped into [lower, lower + 2 pi)."""
    return lower + np.mod(angle - lower, 2.0 * np.pi)


def _flag(condition: np.ndarray, known: np.ndarray) -> np.ndarray:
    return np.where(known, condition.astype(float), np.nan)


def _p(points: np.ndarray, name: str) -> np.ndarray:
    """One joint's (C, 3) coordinates from frame-major points (C, 33, 3)."""
    return points[:, JOINT_INDEX[name], :]


def pelvis_frames(points_world: np.ndarray) -> FloatArray:
    """(F, 3, 3) the pelvis frame of each frame of ``points_world`` (F, 33, 3): columns forward,
    left and up (world up; left = the hip line made level, forward = left x up). It turns with the
    person's heading only; NaN where a hip is missing."""
    up = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (points_world.shape[0], 3))
    left = _perp_unit(_p(points_world, "left_hip") - _p(points_world, "right_hip"), up)
    return _frame(np.cross(left, up), left, up)


#: Frames processed at a time: the (C, 3) intermediates then stay in the CPU cache.
CHUNK_FRAMES = 8192

# ----------------------------------------------------------------------------------------------


def joint_angles(
    points_world: np.ndarray, time_s: np.ndarray | None = None, settings: AngleSettings | None = None
) -> JointAngles:
    """Joint angles and stance flags for every frame of one person's 3D joint track.

    points_world: (F, 33, 3) BlazePose points, world frame (metres, floor z = 0, z up); NaN = missing.
    time_s: (F,) strictly increasing frame times in seconds, or None (then walking is unknown).
    settings: definitions' settings and flag thresholds (defaults: :class:`AngleSettings`).
    Returns :class:`JointAngles` with (F,) arrays. Vectorised over frames (processed in blocks of
    CHUNK_FRAMES frames; the shoulder reference and walking use the whole sequence).
    """
    s = settings if settings is not None else AngleSettings()
    if not isinstance(s, AngleSettings):
        raise ConfigError(f"expected AngleSettings, got {type(s).__name__}", field="settings")
    pts = np.asarray(points_world, dtype=float)
    if pts.ndim != 3 or pts.shape[1:] != (NUM_JOINTS, 3):
        raise InputError(f"expected shape (frames, {NUM_JOINTS}, 3), got {pts.shape}", field="points_world")
    n = pts.shape[0]
    if time_s is None:
        t = np.full(n, np.nan)
    else:
        t = np.asarray(time_s, dtype=float)
        if t.shape != (n,):
            raise InputError(f"expected shape ({n},) to match points_world, got {t.shape}", field="time_s")
        if not np.all(np.isfinite(t)):
            raise InputError("frame times must be finite", field="time_s")
        if n > 1 and not np.all(np.diff(t) > 0):
            raise InputError("frame times must be strictly increasing", field="time_s")

    out: dict[str, np.ndarray] = {}
    for start in range(0, n, CHUNK_FRAMES):
        part = _frame_local(pts[start : start + CHUNK_FRAMES], s)
        if not out:
            out = {k: np.empty((n,) + v.shape[1:]) for k, v in part.items()}
        for k, v in part.items():
            out[k][start : start + v.shape[0]] = v
    if n == 0:
        out = _frame_local(pts, s)

    # Shoulder elevation: each shoulder's height along the trunk axis above the reference.
    heights = {side: out.pop(f"_{side}_shoulder_height") for side in SIDES}
    half_width = out.pop("_half_shoulder_width")
    if s.trunk_length_m is not None:
        reference = float(s.trunk_length_m)
    else:
        pooled = np.concatenate([heights["left"], heights["right"]])
        pooled = pooled[np.isfinite(pooled)]
        reference = float(np.median(pooled)) if pooled.size else np.nan
    with np.errstate(invalid="ignore"):
        for side in SIDES:
            elevation = np.arctan2(heights[side] - reference, half_width)
            out[f"{side}_shoulder_elevation"] = elevation

    mid_ear, ear_line = out.pop("_mid_ear_trunk"), out.pop("_ear_line_trunk")
    out["neck_flexion"], out["neck_side_bend"], out["neck_twist"] = _neck(mid_ear, ear_line, reference, s)

    out["time_s"] = t
    out.update(_stance(pts, t, time_s is not None, out, s))
    return JointAngles(**out)


def _neck(
    mid_ear_trunk: np.ndarray, ear_line_trunk: np.ndarray, neck_base_height: float, s: AngleSettings
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Neck flexion, side bend and twist (radians, (F,) each) of the neck frame in the trunk frame.

    The neck frame: z = neck base -> mid-ear point (the neck line), y = right ear -> left ear made
    perpendicular to z, x = y cross z; turned back about y by ``neck_neutral_offset``. The neck
    base is the point of the trunk axis at the relaxed shoulder height above mid-hip
    (``neck_base_height``, the reference of shoulder elevation), so shrugging the shoulders moves
    no neck angle. Inputs are in the trunk frame: (F, 3) mid-ear point relative to mid-hip, (F, 3)
    ear line. The face points are not used: a ceiling camera sees the top of the head, where a
    network's nose and eyes are guesses (docs/joint-angles.md, "The neck").
    """
    neck_z = _unit(mid_ear_trunk - np.array([0.0, 0.0, neck_base_height]))
    neck_y = _perp_unit(ear_line_trunk, neck_z)
    neck = _frame(np.cross(neck_y, neck_z), neck_y, neck_z)
    if s.neck_neutral_offset != 0.0:
        co, so = math.cos(-s.neck_neutral_offset), math.sin(-s.neck_neutral_offset)
        neck = neck @ np.array([[co, 0.0, so], [0.0, 1.0, 0.0], [-so, 0.0, co]])
    return _yxz(neck)


def _shoulder_heights(pts: np.ndarray, mid_hip: np.ndarray, trunk_z: np.ndarray) -> list[np.ndarray]:
    """Each shoulder's height (metres) above mid-hip along the trunk axis, in SIDES order."""
    return [_dot(_p(pts, f"{side}_shoulder") - mid_hip, trunk_z) for side in SIDES]


def shoulder_heights(points_world: np.ndarray) -> np.ndarray:
    """(F, 2) both shoulders' heights along the trunk axis (SIDES order; NaN where unknown): the
    values whose median is the reference of shoulder elevation when ``trunk_length_m`` is None.
    A whole shift scored in pieces passes that median, taken over the whole shift, as
    ``trunk_length_m`` so every piece uses the same reference."""
    pts = np.asarray(points_world, dtype=float)
    l_hip, r_hip = _p(pts, "left_hip"), _p(pts, "right_hip")
    mid_hip = 0.5 * (l_hip + r_hip)
    trunk_z = _unit(0.5 * (_p(pts, "left_shoulder") + _p(pts, "right_shoulder")) - mid_hip)
    return np.stack(_shoulder_heights(pts, mid_hip, trunk_z), axis=1)


def _frame_local(pts: np.ndarray, s: AngleSettings) -> dict[str, np.ndarray]:
    """Everything that depends on one frame only, for a block of frames (C, 33, 3)."""
    out: dict[str, np.ndarray] = {}

    # Pelvis frame: left = hip line made level, forward = left x up.
    l_hip, r_hip = _p(pts, "left_hip"), _p(pts, "right_hip")
    mid_hip = 0.5 * (l_hip + r_hip)
    pelvis = pelvis_frames(pts)

    # Trunk frame: z = mid-hip -> mid-shoulder, y = shoulder line made perpendicular to z.
    l_sh, r_sh = _p(pts, "left_shoulder"), _p(pts, "right_shoulder")
    mid_sh = 0.5 * (l_sh + r_sh)
    trunk_z = _unit(mid_sh - mid_hip)
    shoulder_line = l_sh - r_sh
    trunk_y = _perp_unit(shoulder_line, trunk_z)
    trunk_x = np.cross(trunk_y, trunk_z)
    trunk = _frame(trunk_x, trunk_y, trunk_z)
    f, b, c = _yxz(np.matmul(np.swapaxes(pelvis, 1, 2), trunk))
    out["trunk_flexion"], out["trunk_side_bend"], out["trunk_twist"] = f, b, c

    # For the neck (finished over the whole sequence, from the neck base at the relaxed shoulder
    # height): the mid-ear point above mid-hip and the ear line, both in the trunk frame.
    l_ear, r_ear = _p(pts, "left_ear"), _p(pts, "right_ear")
    out["_mid_ear_trunk"] = _in_frame(trunk, 0.5 * (l_ear + r_ear) - mid_hip)
    out["_ear_line_trunk"] = _in_frame(trunk, l_ear - r_ear)

    # For shoulder elevation (finished over the whole sequence): heights along the trunk axis and
    # the shoulders' distance from the trunk axis.
    half_width = 0.5 * _norm(shoulder_line - _dot(shoulder_line, trunk_z)[:, None] * trunk_z)
    half_width = np.where(half_width > _EPS, half_width, np.nan)
    out["_half_shoulder_width"] = half_width
    for side, height in zip(SIDES, _shoulder_heights(pts, mid_hip, trunk_z)):
        out[f"_{side}_shoulder_height"] = height

    with np.errstate(invalid="ignore"):
        for side in SIDES:
            sg = _SIGMA[side]
            shoulder, elbow, wrist = (_p(pts, f"{side}_{j}") for j in ("shoulder", "elbow", "wrist"))

            # Upper arm in the trunk frame.
            arm = _unit(_in_frame(trunk, elbow - shoulder))
            flexion = _wrap_from(np.arctan2(arm[:, 0], -arm[:, 2]), -0.5 * np.pi)  # overhead stays flexion
            abduction = _asin(sg * arm[:, 1])
            out[f"{side}_upper_arm_flexion"] = np.minimum(flexion, np.pi)  # past overhead saturates at 180 deg
            out[f"{side}_upper_arm_abduction"] = abduction
            out[f"{side}_upper_arm_elevation"] = np.arccos(np.clip(-arm[:, 2], -1.0, 1.0))

            forearm_world = wrist - elbow
            elbow_flexion = _angle_between(elbow - shoulder, forearm_world)
            out[f"{side}_elbow_flexion"] = elbow_flexion

            # Upper-arm rotation: the forearm's direction about the arm's long axis, in the arm frame
            # Ry(-flexion) Rx(sigma abduction) of the trunk frame.
            v = _in_frame(trunk, forearm_world)
            cf, sf = np.cos(flexion), np.sin(flexion)
            vx = cf * v[:, 0] + sf * v[:, 2]
            vz = -sf * v[:, 0] + cf * v[:, 2]
            cb, sb = np.cos(abduction), np.sin(abduction)
            vy = cb * v[:, 1] + sg * sb * vz
            rotation = np.arctan2(-sg * vy, vx)
            out[f"{side}_upper_arm_rotation"] = np.where(
                elbow_flexion >= s.rotation_min_elbow_flexion, rotation, np.nan
            )

            # Wrist lateral position in the trunk frame, + toward the arm's own side.
            lateral = sg * _dot(wrist - mid_sh, trunk_y)
            out[f"{side}_wrist_lateral_m"] = lateral

            # Wrist: the forearm axis seen in the hand frame.
            index, pinky = _p(pts, f"{side}_index"), _p(pts, f"{side}_pinky")
            hand_long = _unit(0.5 * (index + pinky) - wrist)
            hand_radial = _perp_unit(index - pinky, hand_long)
            hand_dorsal = sg * np.cross(hand_radial, hand_long)
            u = _unit(forearm_world)
            out[f"{side}_wrist_flexion"] = np.arctan2(_dot(u, hand_dorsal), _dot(u, hand_long))
            out[f"{side}_wrist_deviation"] = _asin(-_dot(u, hand_radial))

            # Hip (thigh in the pelvis frame) and knee.
            hip, knee, ankle = (_p(pts, f"{side}_{j}") for j in ("hip", "knee", "ankle"))
            thigh = _unit(_in_frame(pelvis, knee - hip))
            out[f"{side}_hip_flexion"] = np.arctan2(thigh[:, 0], -thigh[:, 2])
            out[f"{side}_hip_abduction"] = _asin(sg * thigh[:, 1])
            out[f"{side}_knee_flexion"] = _angle_between(knee - hip, ankle - knee)

            foot = np.fmin(_p(pts, f"{side}_heel")[:, 2], _p(pts, f"{side}_foot_index")[:, 2])
            out[f"{side}_foot_height_m"] = np.where(np.isnan(foot), ankle[:, 2] - s.ankle_height_m, foot)
    return out


def _walking_speed(mid_ankle_xy: np.ndarray, t: np.ndarray, window_s: float) -> np.ndarray:
    """Net horizontal displacement over a centred window / its duration, per frame (NaN if unknown)."""
    n = t.shape[0]
    speed = np.full(n, np.nan)
    valid = np.flatnonzero(np.all(np.isfinite(mid_ankle_xy), axis=1))
    if valid.size < 2:
        return speed
    tv, pv = t[valid], mid_ankle_xy[valid]
    half = 0.5 * window_s + 1e-9  # frame times on the window's edges belong to it despite rounding
    j0 = np.searchsorted(tv, tv - half, side="left")
    j1 = np.searchsorted(tv, tv + half, side="right") - 1
    duration = tv[j1] - tv[j0]
    ok = duration >= 0.5 * window_s - 1e-9
    with np.errstate(invalid="ignore", divide="ignore"):
        v = _norm(pv[j1] - pv[j0]) / duration
    speed[valid] = np.where(ok, v, np.nan)
    return speed


def _stance(
    pts: np.ndarray, t: np.ndarray, have_time: bool, angles: dict[str, np.ndarray], s: AngleSettings
) -> dict[str, np.ndarray]:
    """walking, seated, one_leg_stance, legs_supported and the walking speed, over the whole sequence."""
    n = pts.shape[0]
    l_ank, r_ank = _p(pts, "left_ankle"), _p(pts, "right_ankle")
    mid_ankle = 0.5 * (l_ank + r_ank)
    if have_time:
        speed = _walking_speed(mid_ankle[:, :2], t, s.walking_window_s)
    else:
        speed = np.full(n, np.nan)
    with np.errstate(invalid="ignore"):
        walking = _flag(speed >= s.walking_min_speed_mps, np.isfinite(speed))

        # Feet on the floor: low enough above the floor and not clearly above the other foot.
        h_left, h_right = angles["left_foot_height_m"], angles["right_foot_height_m"]
        lowest = np.fmin(h_left, h_right)
        down = {
            side: (h <= s.foot_contact_height_m) & (h - lowest <= s.foot_lift_height_m)
            for side, h in (("left", h_left), ("right", h_right))
        }
        feet_known = np.isfinite(h_left) & np.isfinite(h_right)
        both_down = down["left"] & down["right"]
        one_down = down["left"] ^ down["right"]

        # Seated: thighs near horizontal (mean of the sides) and hips well off the floor.
        mid_hip = 0.5 * (_p(pts, "left_hip") + _p(pts, "right_hip"))
        inclines = []
        for side in SIDES:
            thigh = _p(pts, f"{side}_hip") - _p(pts, f"{side}_knee")
            horizontal = np.hypot(thigh[:, 0], thigh[:, 1])
            incl = np.arctan2(thigh[:, 2], horizontal)
            inclines.append(np.where(_norm(thigh) > _EPS, incl, np.nan))
        incline = np.where(
            np.isnan(inclines[0]),
            inclines[1],
            np.where(np.isnan(inclines[1]), inclines[0], 0.5 * (inclines[0] + inclines[1])),
        )
        seated_geom = (incline < s.seated_max_thigh_incline) & (mid_hip[:, 2] >= s.seated_min_hip_height_m)
        seated_known = np.isfinite(incline) & np.isfinite(mid_hip[:, 2])
        seated = _flag(seated_geom, seated_known)

        # One-leg stance: exactly one foot down, neither walking nor seated.
        one_leg = np.where(feet_known, one_down.astype(float), np.nan)
        undecided = (one_leg == 1.0) & (np.isnan(walking) | np.isnan(seated))
        one_leg = np.where(undecided, np.nan, one_leg)
        one_leg = np.where((walking == 1.0) | (seated == 1.0), 0.0, one_leg)

        # Legs supported: both feet down and, standing, the weight evenly balanced.
        offset = np.hypot(mid_hip[:, 0] - mid_ankle[:, 0], mid_hip[:, 1] - mid_ankle[:, 1])
        balanced = offset <= s.balance_max_offset_m
        standing_ok = _flag(both_down & balanced, feet_known & np.isfinite(offset))
        seated_ok = _flag(both_down, feet_known)
        legs_supported = np.where(seated == 1.0, seated_ok, np.where(seated == 0.0, standing_ok, np.nan))
        feet_on_floor = np.where(feet_known, down["left"].astype(float) + down["right"].astype(float), np.nan)
    return {
        "walking": walking,
        "walking_speed_mps": speed,
        "seated": seated,
        "feet_on_floor": feet_on_floor,
        "one_leg_stance": one_leg,
        "legs_supported": legs_supported,
    }
