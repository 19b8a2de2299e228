"""A posable, anthropometric 3D body model that produces the 33 BlazePose points.

The model serves two purposes: the joint-angle tests pose it with known angles and check that
:func:`ergopose.ergonomics.angles.joint_angles` recovers them, and the simulator moves it to make
synthetic workers. Both use the SAME angle definitions (docs/joint-angles.md), so every angle in a
:class:`Posture` is exactly what ``joint_angles`` measures from the points this model produces.

Frames and units
----------------
World frame: metres, floor z = 0, z up. The body is built in its own pelvis frame (origin at the
mid-hip point, x forward, y to the body's left, z up), then turned by ``heading`` about the world
vertical and moved to ``root_position``. Angles are radians.

Kinematic chain (every rotation is a right-handed rotation about an axis of the parent segment's
frame; Rx, Ry, Rz are rotations about its x (forward), y (left) and z (up) axes; sigma = +1 for the
left side and -1 for the right side):

- pelvis: level, hip keypoints at (0, +-hip_width/2, 0).
- trunk: R_trunk = Ry(trunk_flexion) Rx(trunk_side_bend) Rz(trunk_twist), about the mid-hip point;
  the neck base is at R_trunk (0, 0, trunk_length). Flexion tips the trunk forward, side bend to the
  body's right, twist turns the shoulders to the left.
- shoulders: neck base + R_trunk (0, sigma w, w tan(shoulder_elevation)) with w = shoulder_width / 2;
  elevation lifts the shoulder along the trunk axis, so the mid-shoulder point stays on the trunk axis
  and the shoulder line stays perpendicular to it in the trunk's transverse plane.
- head: R_head = R_trunk Ry(neck_flexion) Rx(neck_side_bend) Rz(neck_twist) about the neck base;
  face points are fixed in the head frame (:data:`FACE_POINTS_IN_HEAD`).
- upper arm: R_upper_arm = R_trunk Ry(-flexion) Rx(sigma abduction) Rz(-sigma rotation); the elbow
  is at shoulder + R_upper_arm (0, 0, -upper_arm_length). With all angles 0 the arm hangs along the
  trunk axis; flexion swings it forward, abduction out to its own side, rotation (internal positive)
  turns the bent forearm toward the belly.
- forearm: R_forearm = R_upper_arm Ry(-elbow_flexion) Rz(-sigma forearm_rotation); the wrist is at
  elbow + R_forearm (0, 0, -forearm_length). Forearm rotation 0 is the mid position (thumb forward
  when the arm hangs), pronation positive.
- hand: R_hand = R_forearm Ry(-wrist_deviation) Rx(-sigma wrist_flexion). In the hand frame the long
  axis points along -z, the radial (thumb) side along +x and the back of the hand along +sigma y.
  Flexion bends the hand toward the palm, radial deviation toward the thumb.
- thigh: R_thigh = Ry(-hip_flexion) Rx(sigma hip_abduction) in the pelvis frame; knee = hip +
  R_thigh (0, 0, -thigh_length).
- shank: R_shank = R_thigh Ry(knee_flexion) (the shank folds backward); ankle = knee + R_shank
  (0, 0, -shank_length).
- foot: R_foot = R_shank Ry(-ankle_flexion) (dorsiflexion positive: toes up). Heel at
  (-heel_offset, 0, -ankle_height) and foot_index at (foot_length - heel_offset, 0, -ankle_height)
  in the foot frame: with shank vertical and ankle 0 both touch the sole plane.

Anthropometry
-------------
Segment lengths are fractions of stature H from the segment-length figure of D. A. Winter,
*Biomechanics and Motor Control of Human Movement* (4th ed., Wiley 2009, Fig. 4.1), which
reproduces Drillis & Contini (1966, Report 1166-03, New York University): shoulder (acromion)
height 0.818H, hip (greater trochanter) 0.530H, knee 0.285H, ankle 0.039H, upper arm 0.186H,
forearm 0.146H, hand 0.108H, thigh 0.245H, shank 0.246H, foot length 0.152H, shoulder width
0.259H, hip width 0.191H. Derived: trunk (hip to shoulder) 0.818H - 0.530H = 0.288H, head and neck
(shoulder to vertex) 1 - 0.818 = 0.182H. The face-point layout, the heel's position behind the
ankle and the hand-point layout are ergopose's own approximations (not from a published table);
they only need to be plausible, because the angle definitions do not depend on them.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ergopose.arrays import FloatArray
from ergopose.errors import ConfigError
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS

#: Winter (2009) Fig. 4.1 after Drillis & Contini (1966): lengths as fractions of stature.
WINTER_FRACTIONS: dict[str, float] = {
    "trunk_length": 0.818 - 0.530,
    "shoulder_width": 0.259,
    "hip_width": 0.191,
    "upper_arm_length": 0.186,
    "forearm_length": 0.146,
    "hand_length": 0.108,
    "thigh_length": 0.245,
    "shank_length": 0.246,
    "ankle_height": 0.039,
    "foot_length": 0.152,
    "head_height": 1.0 - 0.818,
}

#: Face points in the head frame (x forward, y left, z up; origin at the neck base), in units of
#: head_height (neck base to vertex). ergopose's approximation of an adult head with the Frankfurt
#: plane horizontal: tragion (ear) 0.60 straight above the neck base (the ear over the shoulder, as
#: the plumb line of ideal standing posture runs); eye centres 0.65 up and 0.33 forward, 0.20
#: apart; nose tip 0.41 forward, placed so that the mean of the nose and the two eye centres is
#: level with the ears. The neck frame of angles.py (neck base -> mid-ear, turned by the ear line;
#: its neck base is the trunk axis at the relaxed shoulder height, here the trunk length) is then
#: this head frame, and reads the posture's neck angles exactly.
FACE_POINTS_IN_HEAD: dict[str, tuple[float, float, float]] = {
    "nose": (0.41, 0.0, 3 * 0.604 - 2 * 0.648),
    "left_eye_inner": (0.32, 0.055, 0.648),
    "left_eye": (0.33, 0.099, 0.648),
    "left_eye_outer": (0.31, 0.154, 0.648),
    "right_eye_inner": (0.32, -0.055, 0.648),
    "right_eye": (0.33, -0.099, 0.648),
    "right_eye_outer": (0.31, -0.154, 0.648),
    "left_ear": (0.0, 0.236, 0.604),
    "right_ear": (0.0, -0.236, 0.604),
    "mouth_left": (0.357, 0.082, 0.44),
    "mouth_right": (0.357, -0.082, 0.44),
}

#: Hand points in the hand frame (x radial/thumb side, z along the forearm, toward the elbow;
#: the fingers point along -z), in units of hand_length, for the LEFT hand; the back of the left
#: hand faces +y. The right hand mirrors y. index and pinky sit symmetrically about the hand's
#: long axis at the knuckles (so wrist -> mid(index, pinky) IS the long axis); the thumb lies on the
#: radial and palmar side.
HAND_POINTS_IN_HAND: dict[str, tuple[float, float, float]] = {
    "index": (0.18, 0.0, -0.55),
    "pinky": (-0.18, 0.0, -0.55),
    "thumb": (0.30, -0.10, -0.40),
}

#: Heel position behind the ankle, as a fraction of foot length (ergopose's approximation).
HEEL_OFFSET_FRACTION = 0.25

STATURE_RANGE_M = (1.55, 1.95)

SIDES = ("left", "right")
_SIGMA = {"left": 1.0, "right": -1.0}


@dataclass(frozen=True)
class BodyMeasurements:
    """Segment lengths of one worker, metres.

    trunk_length: mid-hip to mid-shoulder with the shoulders relaxed.
    shoulder_width / hip_width: distance between the two shoulder / hip keypoints.
    head_height: neck base (mid-shoulder level) to the top of the head; the face is scaled by it.
    ankle_height: ankle keypoint above the sole with the foot flat.
    heel_offset: heel keypoint behind the ankle (along the foot).
    """

    stature: float
    trunk_length: float
    shoulder_width: float
    hip_width: float
    upper_arm_length: float
    forearm_length: float
    hand_length: float
    thigh_length: float
    shank_length: float
    ankle_height: float
    foot_length: float
    heel_offset: float
    head_height: float

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v > 0):
                raise ConfigError(f"must be a positive finite length in metres, got {v!r}", field=f.name)
        lo, hi = STATURE_RANGE_M
        if not lo <= self.stature <= hi:
            raise ConfigError(
                f"stature {self.stature:.3f} m is outside the modelled range {lo}-{hi} m", field="stature"
            )
        if self.heel_offset >= self.foot_length:
            raise ConfigError("the heel must lie within the foot (heel_offset < foot_length)", field="heel_offset")

    @classmethod
    def from_stature(cls, stature: float, **overrides: float) -> "BodyMeasurements":
        """Measurements scaled from stature with Winter's fractions; keyword overrides replace any length."""
        stature = float(stature)
        values = {name: frac * stature for name, frac in WINTER_FRACTIONS.items()}
        values["heel_offset"] = HEEL_OFFSET_FRACTION * values["foot_length"]
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(overrides) - names
        if unknown:
            raise ConfigError(f"unknown measurement(s) {sorted(unknown)}; known: {sorted(names)}", field="overrides")
        values.update({k: float(v) for k, v in overrides.items()})
        values["stature"] = stature
        return cls(**values)

    @property
    def standing_hip_height(self) -> float:
        """Mid-hip height above the floor when standing straight with flat feet."""
        return self.ankle_height + self.shank_length + self.thigh_length


def _zero() -> float:
    return 0.0


def _angle_field() -> float:
    return field(default_factory=_zero)


@dataclass(frozen=True)
class Posture:
    """Joint angles (radians) and placement of the body; every field broadcasts over frames.

    Each angle field is a scalar or an array of shape (...); ``root_position`` is (..., 3) (the
    mid-hip point in the world frame) and ``heading`` (...) is the direction the pelvis faces,
    counter-clockwise from world +x about +z. All fields broadcast to one frame shape S and
    :func:`pose_skeleton` returns (S..., 33, 3). The angle definitions are those of
    docs/joint-angles.md (and of the module docstring above); all zeros is standing upright with
    the arms hanging, thumbs forward, feet flat.
    """

    root_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    heading: np.ndarray | float = _angle_field()
    trunk_flexion: np.ndarray | float = _angle_field()
    trunk_side_bend: np.ndarray | float = _angle_field()
    trunk_twist: np.ndarray | float = _angle_field()
    neck_flexion: np.ndarray | float = _angle_field()
    neck_side_bend: np.ndarray | float = _angle_field()
    neck_twist: np.ndarray | float = _angle_field()
    left_shoulder_elevation: np.ndarray | float = _angle_field()
    right_shoulder_elevation: np.ndarray | float = _angle_field()
    left_upper_arm_flexion: np.ndarray | float = _angle_field()
    right_upper_arm_flexion: np.ndarray | float = _angle_field()
    left_upper_arm_abduction: np.ndarray | float = _angle_field()
    right_upper_arm_abduction: np.ndarray | float = _angle_field()
    left_upper_arm_rotation: np.ndarray | float = _angle_field()
    right_upper_arm_rotation: np.ndarray | float = _angle_field()
    left_elbow_flexion: np.ndarray | float = _angle_field()
    right_elbow_flexion: np.ndarray | float = _angle_field()
    left_forearm_rotation: np.ndarray | float = _angle_field()
    right_forearm_rotation: np.ndarray | float = _angle_field()
    left_wrist_flexion: np.ndarray | float = _angle_field()
    right_wrist_flexion: np.ndarray | float = _angle_field()
    left_wrist_deviation: np.ndarray | float = _angle_field()
    right_wrist_deviation: np.ndarray | float = _angle_field()
    left_hip_flexion: np.ndarray | float = _angle_field()
    right_hip_flexion: np.ndarray | float = _angle_field()
    left_hip_abduction: np.ndarray | float = _angle_field()
    right_hip_abduction: np.ndarray | float = _angle_field()
    left_knee_flexion: np.ndarray | float = _angle_field()
    right_knee_flexion: np.ndarray | float = _angle_field()
    left_ankle_flexion: np.ndarray | float = _angle_field()
    right_ankle_flexion: np.ndarray | float = _angle_field()

    def replace(self, **changes: Any) -> "Posture":
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    @property
    def shape(self) -> tuple[int, ...]:
        """The broadcast frame shape S of all fields."""
        shapes = [np.shape(self.root_position)[:-1]]
        shapes += [np.shape(getattr(self, f.name)) for f in dataclasses.fields(self) if f.name != "root_position"]
        return np.broadcast_shapes(*shapes)


ANGLE_FIELDS: tuple[str, ...] = tuple(
    f.name for f in dataclasses.fields(Posture) if f.name not in ("root_position", "heading")
)


def rot_x(a: np.ndarray) -> np.ndarray:
    """Right-handed rotation(s) about x; a (...) -> (..., 3, 3)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(a: np.ndarray) -> np.ndarray:
    """Right-handed rotation(s) about y; a (...) -> (..., 3, 3)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def rot_z(a: np.ndarray) -> FloatArray:
    """Right-handed rotation(s) about z; a (...) -> (..., 3, 3)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    rotation: FloatArray = np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)
    return rotation


def _apply(rot: np.ndarray, vec: ArrayLike) -> FloatArray:
    """rot (..., 3, 3) times a vector (3,) or (..., 3) -> (..., 3)."""
    vec = np.asarray(vec, dtype=float)
    rotated: FloatArray = rot[..., 0] * vec[..., 0:1] + rot[..., 1] * vec[..., 1:2] + rot[..., 2] * vec[..., 2:3]
    return rotated


#: Frames computed at a time (the (C, 3, 3) intermediates then stay in the CPU cache).
CHUNK_FRAMES = 8192


def _fields_flat(posture: Posture) -> tuple[tuple[int, ...], dict[str, np.ndarray]]:
    """The frame shape S and every field broadcast to S and flattened to (N,) or (N, 3)."""
    shape = posture.shape
    flat: dict[str, np.ndarray] = {}
    for f in dataclasses.fields(posture):
        v = np.asarray(getattr(posture, f.name), dtype=float)
        if f.name == "root_position":
            flat[f.name] = np.broadcast_to(v, shape + (3,)).reshape(-1, 3)
        else:
            flat[f.name] = np.broadcast_to(v, shape).reshape(-1)
    return shape, flat


def _legs_local(m: BodyMeasurements, get: Callable[[str], np.ndarray], side: str) -> dict[str, np.ndarray]:
    """Hip, knee, ankle, heel and foot_index of one side in the pelvis frame, (C, 3) each."""
    s = _SIGMA[side]
    n = get("heading").shape[0]
    hip = np.zeros((n, 3))
    hip[:, 1] = s * m.hip_width / 2.0
    r_thigh = rot_y(-get(f"{side}_hip_flexion")) @ rot_x(s * get(f"{side}_hip_abduction"))
    knee = hip + _apply(r_thigh, (0.0, 0.0, -m.thigh_length))
    r_shank = r_thigh @ rot_y(get(f"{side}_knee_flexion"))
    ankle = knee + _apply(r_shank, (0.0, 0.0, -m.shank_length))
    r_foot = r_shank @ rot_y(-get(f"{side}_ankle_flexion"))
    heel = ankle + _apply(r_foot, (-m.heel_offset, 0.0, -m.ankle_height))
    toe = ankle + _apply(r_foot, (m.foot_length - m.heel_offset, 0.0, -m.ankle_height))
    return {"hip": hip, "knee": knee, "ankle": ankle, "heel": heel, "foot_index": toe}


def _skeleton_local(m: BodyMeasurements, get: Callable[[str], np.ndarray]) -> np.ndarray:
    """All 33 points in the pelvis frame for a block of frames, (C, 33, 3)."""
    n = get("heading").shape[0]
    out = np.empty((n, NUM_JOINTS, 3))
    r_trunk = rot_y(get("trunk_flexion")) @ rot_x(get("trunk_side_bend")) @ rot_z(get("trunk_twist"))
    neck_base = _apply(r_trunk, (0.0, 0.0, m.trunk_length))
    r_head = r_trunk @ rot_y(get("neck_flexion")) @ rot_x(get("neck_side_bend")) @ rot_z(get("neck_twist"))
    face_names = list(FACE_POINTS_IN_HEAD)
    face_local = np.array([FACE_POINTS_IN_HEAD[k] for k in face_names]) * m.head_height  # (11, 3)
    face = neck_base[:, None, :] + np.matmul(face_local, np.swapaxes(r_head, -1, -2))
    out[:, [JOINT_INDEX[k] for k in face_names], :] = face

    half_shoulder = m.shoulder_width / 2.0
    for side in SIDES:
        s = _SIGMA[side]
        shoulder_local = np.zeros((n, 3))
        shoulder_local[:, 1] = s * half_shoulder
        shoulder_local[:, 2] = half_shoulder * np.tan(get(f"{side}_shoulder_elevation"))
        shoulder = neck_base + _apply(r_trunk, shoulder_local)
        r_ua = (
            r_trunk
            @ rot_y(-get(f"{side}_upper_arm_flexion"))
            @ rot_x(s * get(f"{side}_upper_arm_abduction"))
            @ rot_z(-s * get(f"{side}_upper_arm_rotation"))
        )
        elbow = shoulder + _apply(r_ua, (0.0, 0.0, -m.upper_arm_length))
        r_fa = r_ua @ rot_y(-get(f"{side}_elbow_flexion")) @ rot_z(-s * get(f"{side}_forearm_rotation"))
        wrist = elbow + _apply(r_fa, (0.0, 0.0, -m.forearm_length))
        r_hand = r_fa @ rot_y(-get(f"{side}_wrist_deviation")) @ rot_x(-s * get(f"{side}_wrist_flexion"))
        out[:, JOINT_INDEX[f"{side}_shoulder"], :] = shoulder
        out[:, JOINT_INDEX[f"{side}_elbow"], :] = elbow
        out[:, JOINT_INDEX[f"{side}_wrist"], :] = wrist
        for name, (x, y, z) in HAND_POINTS_IN_HAND.items():
            local = np.array([x, s * y, z]) * m.hand_length
            out[:, JOINT_INDEX[f"{side}_{name}"], :] = wrist + _apply(r_hand, local)
        for name, point in _legs_local(m, get, side).items():
            out[:, JOINT_INDEX[f"{side}_{name}"], :] = point
    return out


def pose_skeleton(measurements: BodyMeasurements, posture: Posture) -> np.ndarray:
    """Forward kinematics: the 33 BlazePose points in the world frame, shape (S..., 33, 3).

    S is the broadcast shape of the posture's fields (``posture.shape``). Vectorised over frames
    (computed in blocks of CHUNK_FRAMES frames).
    """
    shape, flat = _fields_flat(posture)
    n = flat["heading"].shape[0]
    out = np.empty((n, NUM_JOINTS, 3))
    for start in range(0, n, CHUNK_FRAMES):
        stop = min(n, start + CHUNK_FRAMES)

        def get(name: str) -> np.ndarray:
            return flat[name][start:stop]

        local = _skeleton_local(measurements, get)
        r_world = rot_z(get("heading"))
        out[start:stop] = np.matmul(local, np.swapaxes(r_world, -1, -2)) + get("root_position")[:, None, :]
    return out.reshape(shape + (NUM_JOINTS, 3))


def place_on_floor(measurements: BodyMeasurements, posture: Posture) -> Posture:
    """The posture with root height set so that the lowest foot point (ankle, heel, foot_index) is at z = 0.

    Works per frame; the root's x and y are kept. (Heading turns about the vertical, so only the
    legs in the pelvis frame are needed.)
    """
    shape, flat = _fields_flat(posture)

    def get(name: str) -> np.ndarray:
        return flat[name]

    lowest = np.full(flat["heading"].shape[0], np.inf)
    for side in SIDES:
        legs = _legs_local(measurements, get, side)
        for name in ("ankle", "heel", "foot_index"):
            lowest = np.minimum(lowest, legs[name][:, 2])
    root = np.array(flat["root_position"])
    root[:, 2] = -lowest
    return posture.replace(root_position=root.reshape(shape + (3,)))


def flat_foot_ankle(hip_flexion: ArrayLike, knee_flexion: ArrayLike) -> FloatArray:
    """Ankle flexion that keeps the foot level in the sagittal plane: knee_flexion - hip_flexion.

    Exact when the hip is not abducted (the hip, knee and ankle rotations then share one axis).
    """
    ankle: FloatArray = np.asarray(knee_flexion, dtype=float) - np.asarray(hip_flexion, dtype=float)
    return ankle
