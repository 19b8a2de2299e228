"""The body model's anatomical limits (ergopose.recon.bodyfit.LIMITS).

Known answers from the simulator's own skeleton (ergopose.ergonomics.body, built from angles, not
from the fit): each limit's term reads zero exactly at the angle it limits, positive inside and
negative beyond. Then the fit: a knee, an elbow or a head that both cameras show past its limit
is fitted within it (and, with the limits off, where the cameras put it), while a posture within
every limit is fitted exactly as without them.
"""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.ergonomics.body import BodyMeasurements, Posture, place_on_floor, pose_skeleton
from ergopose.keypoints import JOINT_INDEX
from ergopose.recon import bodyfit as B
from ergopose.recon.settings import ReconSettings
from tests.recon.test_bodyfit import _bodies, _fit, _views


def _posture_bodies(n: int, rng: np.random.Generator, **angles: float) -> np.ndarray:
    """n bodies (random heading and place) with the given angles (radians), (n, 33, 3)."""
    m = BodyMeasurements.from_stature(1.75)
    values = {k: np.full(n, v) for k, v in angles.items()}
    posture = Posture(
        heading=rng.uniform(-np.pi, np.pi, n),
        root_position=np.stack([rng.uniform(0.3, 1.2, n), rng.uniform(-0.8, 0.8, n), np.zeros(n)], axis=-1),
        **values,
    )
    return pose_skeleton(m, place_on_floor(m, posture))


CASES = (
    ("left_elbow_max_flexion", "left_elbow_flexion", 150.0, 1.0),
    ("right_elbow_max_flexion", "right_elbow_flexion", 150.0, 1.0),
    ("left_knee_max_flexion", "left_knee_flexion", 155.0, 1.0),
    ("right_knee_max_flexion", "right_knee_flexion", 155.0, 1.0),
    ("left_knee_hyperextension", "left_knee_flexion", 10.0, -1.0),
    ("right_knee_hyperextension", "right_knee_flexion", 10.0, -1.0),
    ("head_turn", "neck_twist", 90.0, 1.0),
)


def test_the_limits_are_the_model_s_and_the_settings_defaults():
    assert B.LIMITS == tuple(case[0] for case in CASES)
    opt = B.FitOptions.from_settings(ReconSettings())
    assert opt == B.FitOptions(max_prior_gap_s=ReconSettings().max_coast_s)
    assert np.degrees([opt.elbow_max_flexion_rad, opt.knee_max_flexion_rad]) == pytest.approx([150.0, 155.0])
    assert np.degrees([opt.knee_max_hyperextension_rad, opt.head_max_turn_rad]) == pytest.approx([10.0, 90.0])
    assert opt.limit_sigma_m == 0.002


@pytest.mark.parametrize("limit, angle, limit_deg, sign", CASES)
def test_each_limit_reads_zero_at_the_angle_it_limits(rng, limit, angle, limit_deg, sign):
    """Bodies bent to the limit, 3 degrees short of it and 3 degrees past it (signed: a knee's
    hyperextension is negative flexion), at random headings and places."""
    k = B.LIMITS.index(limit)
    opt = B.FitOptions()
    values = {}
    for delta in (-3.0, 0.0, 3.0):
        bodies = _posture_bodies(8, rng, **{angle: sign * np.radians(limit_deg + delta)})
        values[delta] = B.limit_terms(bodies, opt)[2][:, k]
    assert (values[-3.0] > 1e-3).all(), values[-3.0]
    assert np.abs(values[0.0]).max() < 1e-9
    assert (values[3.0] < -1e-3).all(), values[3.0]
    # The other limits are not passed by these bodies (elbows at 0 read inside their limit).
    others = B.limit_terms(_posture_bodies(8, rng, **{angle: sign * np.radians(limit_deg + 3.0)}), opt)[2]
    assert (np.delete(others, k, axis=1) > 0).all()


def _signed_knee_deg(points: np.ndarray, side: str) -> np.ndarray:
    """Knee flexion (degrees) from the three points, negative where the knee lies behind the
    hip-to-ankle line with respect to the way the hips face (hyperextended)."""
    hip, knee, ankle = (points[:, JOINT_INDEX[f"{side}_{j}"]] for j in ("hip", "knee", "ankle"))
    thigh, shank = knee - hip, ankle - knee
    cos = (thigh * shank).sum(-1) / np.linalg.norm(thigh, axis=-1) / np.linalg.norm(shank, axis=-1)
    left = points[:, JOINT_INDEX["left_hip"]] - points[:, JOINT_INDEX["right_hip"]]
    forward = np.cross(left, [0.0, 0.0, 1.0])
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))) * np.sign(((knee - 0.5 * (hip + ankle)) * forward).sum(-1))


def _head_turn_deg(points: np.ndarray) -> np.ndarray:
    """Angle (degrees) between the face (mid-ears to the mean of nose and eyes) and the trunk's
    forward direction (the shoulder line crossed with mid-hip to mid-shoulder)."""
    p = {n: points[:, JOINT_INDEX[n]] for n in JOINT_INDEX}
    face = (p["nose"] + p["left_eye"] + p["right_eye"]) / 3.0 - 0.5 * (p["left_ear"] + p["right_ear"])
    trunk = 0.5 * (p["left_shoulder"] + p["right_shoulder"] - p["left_hip"] - p["right_hip"])
    forward = np.cross(p["left_shoulder"] - p["right_shoulder"], trunk)
    cos = (face * forward).sum(-1) / np.linalg.norm(face, axis=-1) / np.linalg.norm(forward, axis=-1)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _elbow_deg(points: np.ndarray, side: str) -> np.ndarray:
    s, e, w = (points[:, JOINT_INDEX[f"{side}_{j}"]] for j in ("shoulder", "elbow", "wrist"))
    u, v = e - s, w - e
    cos = (u * v).sum(-1) / np.linalg.norm(u, axis=-1) / np.linalg.norm(v, axis=-1)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


@pytest.mark.slow
def test_a_knee_elbow_or_head_the_cameras_show_past_its_limit_is_fitted_within_it(rng):
    """Two cameras see (1.5 px of noise) a knee bent 30 deg backwards, an elbow bent 170 deg and
    a head turned 150 deg from the trunk. With the limits the fit holds each near its limit (10,
    150 and 90 deg; a few degrees past it where every keypoint pulls the other way); with
    fit_limit_sigma_m = 0 it follows the cameras."""
    n = 20
    truth = _posture_bodies(
        n, rng, left_knee_flexion=-np.radians(30.0), right_elbow_flexion=np.radians(170.0), neck_twist=np.radians(150.0)
    )
    assert np.allclose(_signed_knee_deg(truth, "left"), -30.0, atol=0.01)
    assert np.allclose(_head_turn_deg(truth), 150.0, atol=0.01)
    assert np.allclose(_elbow_deg(truth, "right"), 170.0, atol=0.01)
    P, px, conf = _views(truth, rng)
    start = truth + rng.normal(0.0, 0.01, truth.shape)
    got, fits = {}, {}
    for sigma in (0.002, 0.0):
        fit = fits[sigma] = _fit(P, px, conf, truth, start, options=B.FitOptions(limit_sigma_m=sigma))
        got[sigma] = (
            _signed_knee_deg(fit.points_world, "left"),
            _elbow_deg(fit.points_world, "right"),
            _head_turn_deg(fit.points_world),
        )
    knee, elbow, head = got[0.0]
    assert np.median(knee) < -25.0 and np.median(elbow) > 165.0 and np.median(head) > 140.0
    knee, elbow, head = got[0.002]
    # Measured: knees -10.4 to -13.6 deg (median -11.0); elbows 150.4-170.3 (median 152.9; two of
    # 20, at 166 and 170 after the 10 iterations, reach 156 and 153 with 30); heads 92.3-103.2
    # (median 96.6): each limit holds to within the play its 2 mm leave against keypoints that
    # all pull the other way (the face's 11 in each camera).
    assert np.median(knee) > -11.5 and knee.min() > -14.5, knee
    assert np.median(elbow) < 154.0 and np.mean(elbow < 156.0) >= 0.8, elbow
    assert np.median(head) < 99.0 and head.max() < 106.0, head
    # and the fit says which joints a limit held: the left knee, the right elbow and the face in
    # every frame (the cameras pull each past its limit), no other joint in any
    flags = fits[0.002].limited
    expect = np.zeros(flags.shape[1], bool)
    expect[[JOINT_INDEX[j] for j in ("left_knee", "right_elbow", "nose", "left_eye", "right_eye")]] = True
    assert (flags == expect).all(), np.argwhere(flags != expect)
    assert not fits[0.0].limited.any()


@pytest.mark.slow
def test_a_posture_within_every_limit_is_fitted_exactly_as_without_them(rng):
    """The limits are one-sided: reaching, bending and twisting workers (elbows up to 103 deg,
    knees up to 34 deg, the head within 30 deg of the trunk) give the same fit to the last bit
    with the limits and without them."""
    truth = _bodies(40, rng)
    P, px, conf = _views(truth, rng)
    start = truth + rng.normal(0.0, 0.005, truth.shape)
    assert (B.limit_terms(truth, B.FitOptions())[2] > 0).all()
    on = _fit(P, px, conf, truth, start)
    off = _fit(P, px, conf, truth, start, options=B.FitOptions(limit_sigma_m=0.0))
    assert np.array_equal(on.points_world, off.points_world)
    assert np.array_equal(on.variance_world, off.variance_world)
    assert not on.limited.any()


def test_the_joints_each_limit_holds_are_flagged_only_past_it(rng):
    """limits_held: a knee 3 deg past its backward limit flags that knee, an elbow 3 deg past 150
    that elbow, a head turned 3 deg past 90 the nose and eyes; exactly at each limit or 3 deg
    inside it flags nothing;
    rows with a NaN and limits turned off flag nothing."""
    opt = B.FitOptions()
    cases = (
        ("left_knee_flexion", -10.0, ("left_knee",)),
        ("right_knee_flexion", 155.0, ("right_knee",)),
        ("left_elbow_flexion", 150.0, ("left_elbow",)),
        ("neck_twist", 90.0, ("nose", "left_eye", "right_eye")),
    )
    for angle, limit_deg, joints in cases:
        sign = np.sign(limit_deg)
        past = B.limits_held(_posture_bodies(6, rng, **{angle: np.radians(limit_deg + sign * 3.0)}), opt)
        inside = B.limits_held(_posture_bodies(6, rng, **{angle: np.radians(limit_deg - sign * 3.0)}), opt)
        assert not B.limits_held(_posture_bodies(6, rng, **{angle: np.radians(limit_deg)}), opt).any(), angle
        expect = np.isin(np.arange(past.shape[1]), [JOINT_INDEX[j] for j in joints])
        assert (past == expect).all(), (angle, np.argwhere(past != expect))
        assert not inside.any(), angle
    X = _posture_bodies(2, rng, left_knee_flexion=-np.radians(30.0))
    X[1, JOINT_INDEX["right_ankle"]] = np.nan
    assert B.limits_held(X, opt).sum(axis=1).tolist() == [1, 0]
    assert not B.limits_held(X, B.FitOptions(limit_sigma_m=0.0)).any()
    # every limit holds at least one joint
    assert B.LIMIT_HELD_JOINTS.shape == (len(B.LIMITS), X.shape[1]) and B.LIMIT_HELD_JOINTS.any(axis=1).all()


def test_smoothed_positions_past_a_limit_move_the_least_to_within_it(rng):
    """hold_within_limits (the smoother does not know the limits): bodies with a knee 30 deg
    backwards, an elbow at 170 deg and the head turned 150 deg come back to within a degree or
    two of each limit; the joints with the larger variance move (the knee, the wrist, the face)
    while the ones pinned by a small variance stay; rows within the limits, rows with a NaN and
    limits turned off leave the positions as they were."""
    past = _posture_bodies(
        6, rng, left_knee_flexion=-np.radians(30.0), right_elbow_flexion=np.radians(170.0), neck_twist=np.radians(150.0)
    )
    inside = _posture_bodies(3, rng, left_knee_flexion=np.radians(20.0), right_elbow_flexion=np.radians(90.0))
    X = np.concatenate([past, inside, inside[:1]])
    X[-1, JOINT_INDEX["nose"]] = np.nan
    var = np.full(X.shape, 1e-8)  # pinned ...
    moving = [JOINT_INDEX[n] for n in ("left_knee", "right_wrist", "nose", "left_eye", "right_eye")]
    var[:, moving] = 0.03**2  # ... except the knee, the wrist and the face
    Y = B.hold_within_limits(X, var, B.FitOptions())
    assert -11.0 < _signed_knee_deg(Y[:6], "left").min() < -9.0
    assert 149.0 < _elbow_deg(Y[:6], "right").max() < 152.0
    assert 89.0 < _head_turn_deg(Y[:6]).max() < 93.0
    pinned = np.setdiff1d(np.arange(X.shape[1]), moving)
    assert np.abs(Y[:6, pinned] - X[:6, pinned]).max() < 1e-4
    assert np.abs(Y[:6, moving] - X[:6, moving]).max() > 0.05
    assert np.array_equal(Y[6:], X[6:], equal_nan=True)
    assert np.array_equal(B.hold_within_limits(X, var, B.FitOptions(limit_sigma_m=0.0)), X, equal_nan=True)


def test_the_tracks_are_held_within_the_limits_after_smoothing(monkeypatch, crossing):
    """The reconstruction hands the smoothed positions and their variance to hold_and_flag (the
    hold of hold_within_limits and the flags of limits_held) and writes what it returns (the
    smoother runs joint by joint and can pass a limit the fit kept)."""
    from ergopose.recon import pipeline
    from ergopose.recon.triangulate import reconstruct_frames
    from tests.recon.conftest import FPS

    calls = []

    flagged = []

    def spy(points, variance, options):
        calls.append((points.copy(), variance.copy(), options))
        held = np.zeros(points.shape[:2], bool)
        held[::7, JOINT_INDEX["left_knee"]] = True
        flagged.append(held)
        return points + 0.5, held

    real_fit = B.fit_bodies

    def fit_holding_an_elbow(*args, **kwargs):
        fit = real_fit(*args, **kwargs)
        fit.limited[:, JOINT_INDEX["left_elbow"]] = True
        return fit

    monkeypatch.setattr(pipeline, "hold_and_flag", spy)
    monkeypatch.setattr(B, "fit_bodies", fit_holding_an_elbow)
    sr = pipeline.ShiftReconstruction(ReconSettings(), FPS, crossing.cameras)
    n = len(crossing.frames)
    people = reconstruct_frames(crossing.frames)
    tf = pipeline.TrackFrames.concat([sr.push(people, 0, n), sr.finish()])
    assert len(tf) > 100 and calls
    smoothed = np.concatenate([c[0] for c in calls])
    assert np.array_equal(tf.points_world, smoothed + 0.5, equal_nan=True)
    assert np.array_equal(tf.std_world**2, np.concatenate([c[1] for c in calls]), equal_nan=True)
    assert all(c[2] == B.FitOptions.from_settings(ReconSettings()) for c in calls)
    # the rows the hold found past a limit are flagged, and the joints the fit flagged (the left
    # elbow in every fitted row, rows without 2D keypoints are not fitted)
    finite = np.isfinite(tf.points_world).all(axis=-1)
    held = np.concatenate(flagged) & finite
    elbow = JOINT_INDEX["left_elbow"]
    others = np.arange(held.shape[1]) != elbow
    assert held.any() and np.array_equal(tf.limited[:, others], held[:, others])
    assert tf.limited[:, elbow].mean() > 0.8 and not (tf.limited[:, elbow] & ~finite[:, elbow]).any()


def test_scoring_reads_the_joints_the_limits_hold():
    """The scores' causes and the inputs' shares (ergonomics.uncertainty) look at exactly the joints
    the fit flags (the ergonomics layer cannot import the reconstruction's table)."""
    from ergopose.ergonomics.uncertainty import INPUT_GROUP_LIMIT_JOINTS, INPUT_GROUPS, LIMITED_SCORED_JOINTS

    assert np.array_equal(np.flatnonzero(B.LIMIT_HELD_JOINTS.any(axis=0)), LIMITED_SCORED_JOINTS)
    # each limit's joints belong to the input group whose angle it limits
    groups = {part: set(j.tolist()) for (part, _, _), j in zip(INPUT_GROUPS, INPUT_GROUP_LIMIT_JOINTS)}
    for name, held in zip(B.LIMITS, B.LIMIT_HELD_JOINTS):
        side = name.split("_")[0]
        part = "neck" if name == "head_turn" else "legs" if "knee" in name else f"{side} lower arm"
        assert set(np.flatnonzero(held).tolist()) <= groups[part], name


def test_hold_and_flag_is_the_hold_and_the_flags(rng):
    """hold_and_flag flags exactly limits_held's joints, and moves the rows past a limit whose
    deviations are known, leaving a row with a NaN point or a NaN deviation as it was."""
    X = _posture_bodies(6, rng, left_knee_flexion=np.radians(-30.0), right_elbow_flexion=np.radians(170.0))
    X[2, 5] = np.nan
    var = np.full(X.shape, 0.01**2)
    var[4] = np.nan
    opt = B.FitOptions()
    held_points, flags = B.hold_and_flag(X, var, opt)
    assert np.array_equal(flags, B.limits_held(X, opt)) and flags.any()
    moved = ~np.isclose(held_points, X, rtol=0.0, atol=1e-9, equal_nan=True).all(axis=(1, 2))
    assert moved.tolist() == [True, True, False, True, False, True]
    assert flags[4].any() and not flags[2].any()
