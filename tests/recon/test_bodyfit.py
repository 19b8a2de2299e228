"""The body model fit against simulated ground truth: bodies posed with the anthropometric model of
ergopose.ergonomics.body (an independent forward kinematics), seen by pinhole views with known
noise."""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.ergonomics.angles import joint_angles
from ergopose.ergonomics.body import BodyMeasurements, Posture, place_on_floor, pose_skeleton
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS
from ergopose.recon import bodyfit as B


def _look_at(centre_world, target_world, f_px=300.0, size=256):
    """A pinhole view's projection matrix (world -> view pixels), looking from centre at target."""
    z = target_world - centre_world
    z = z / np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    if np.linalg.norm(x) < 1e-6:
        x = np.array([1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    K = np.array([[f_px, 0.0, size / 2], [0.0, f_px, size / 2], [0.0, 0.0, 1.0]])
    return K @ np.concatenate([R, -(R @ centre_world)[:, None]], axis=1)


def _project(P, X):
    Xh = np.concatenate([X, np.ones(X.shape[:-1] + (1,))], axis=-1)
    x = np.einsum("rcab,rjb->rcja", P, Xh)
    return x[..., :2] / x[..., 2:]


CAMERAS = (np.array([0.0, 0.0, 3.0]), np.array([1.5, 0.0, 3.0]))


def _bodies(n, rng, stature=1.75):
    """n postures (reaching, bending, twisting) on the floor and their 33 points."""
    m = BodyMeasurements.from_stature(stature)
    posture = Posture(
        trunk_flexion=rng.uniform(0.0, 0.8, n),
        trunk_twist=rng.uniform(-0.3, 0.3, n),
        neck_flexion=rng.uniform(-0.2, 0.5, n),
        left_upper_arm_flexion=rng.uniform(0.0, 1.8, n),
        right_upper_arm_flexion=rng.uniform(0.0, 1.8, n),
        left_elbow_flexion=rng.uniform(0.2, 1.8, n),
        right_elbow_flexion=rng.uniform(0.2, 1.8, n),
        left_knee_flexion=rng.uniform(0.0, 0.6, n),
        right_knee_flexion=rng.uniform(0.0, 0.6, n),
        left_hip_flexion=rng.uniform(0.0, 0.5, n),
        right_hip_flexion=rng.uniform(0.0, 0.5, n),
        heading=rng.uniform(-np.pi, np.pi, n),
        root_position=np.stack([rng.uniform(0.3, 1.2, n), rng.uniform(-0.8, 0.8, n), np.zeros(n)], axis=-1),
    )
    posture = place_on_floor(m, posture)
    return pose_skeleton(m, posture)


def _views(truth, rng, noise_px=1.5, confidence=0.9):
    n = len(truth)
    P = np.stack([np.stack([_look_at(c, truth[r].mean(axis=0)) for c in CAMERAS]) for r in range(n)])
    px = _project(P, truth) + rng.normal(0.0, noise_px, (n, 2, NUM_JOINTS, 2))
    conf = np.full((n, 2, NUM_JOINTS), confidence)
    return P, px, conf


def _fit(P, px, conf, truth, start, **kw):
    L = B.segment_lengths(truth)
    play = B._PLAY_ABS + B._PLAY_REL * L
    return B.fit_bodies(P, px, conf, start, L, play, **kw)


def test_two_cameras_recover_the_body_and_its_uncertainty(rng):
    truth = _bodies(40, rng)
    P, px, conf = _views(truth, rng)
    start = truth + rng.normal(0.0, 0.08, truth.shape)
    fit = _fit(P, px, conf, truth, start)
    err = np.linalg.norm(fit.points_world - truth, axis=-1)
    # 1.5 px at f = 300 px and about 2.5 m is about 12 mm across each view's rays; two views 1.5 m
    # apart see about 2.5 m away at about 35 degrees to each other: about 22 mm in depth.
    assert np.median(err) < 0.015
    assert np.percentile(err, 95) < 0.06
    assert not fit.inferred.any()
    # The fit's deviations describe its errors: error / predicted deviation per coordinate.
    z = (fit.points_world - truth) / np.sqrt(fit.variance_world)
    assert 0.6 < np.sqrt(np.mean(z**2)) < 1.6


def test_without_the_body_model_terms_two_views_are_independent_triangulations(rng):
    """Zero-weight segments and priors: the fit is the (robust) two-view triangulation of each joint."""
    from ergopose.geometry.triangulation import triangulate_dlt

    truth = _bodies(5, rng)
    P, px, conf = _views(truth, rng, noise_px=0.5)
    L = B.segment_lengths(truth)
    fit = B.fit_bodies(
        P,
        px,
        conf,
        truth + 0.03,
        L,
        np.full_like(L, 1e6),
        options=B.FitOptions(pose_prior_sigma_m=1e6, huber_k=1e6, iterations=15),
    )
    dlt = triangulate_dlt(P, px, conf)
    # The floor term stays: a foot point the noise put below the floor is lifted to it.
    above = dlt.points[..., 2] > 0.02
    assert np.max(np.abs(fit.points_world - dlt.points)[above]) < 2e-3
    assert np.all(fit.points_world[..., 2] > -0.005)


def test_one_camera_is_enough_with_the_segment_lengths_and_the_previous_pose(rng):
    truth = _bodies(30, rng)
    moved = truth + np.array([0.03, -0.02, 0.0])  # this frame: the body moved 3.6 cm
    P, px, conf = _views(moved, rng)
    conf[:, 1] = 0.0  # the second camera does not see the worker
    fit = _fit(
        P,
        px,
        conf,
        moved,
        truth,
        previous_world=truth,
        previous_sigma_m=np.full(30, 0.155),
        previous_dt_s=np.full(30, 1 / 12),
    )
    err = np.linalg.norm(fit.points_world - moved, axis=-1)
    assert fit.inferred.all()
    assert np.median(err) < 0.03
    # Depth along the camera's rays is what one camera cannot see: larger deviations than with two.
    both = _fit(*_views(moved, rng), moved, truth)
    assert np.median(fit.variance_world) > 2 * np.median(both.variance_world)


def test_a_limb_nobody_sees_is_carried_and_marked_inferred(rng):
    truth = _bodies(20, rng)
    P, px, conf = _views(truth, rng)
    arm = [JOINT_INDEX[n] for n in ("left_wrist", "left_pinky", "left_index", "left_thumb")]
    conf[:, :, arm] = 0.0
    px[:, :, arm] = np.nan
    fit = _fit(
        P,
        px,
        conf,
        truth,
        truth + 0.02,
        previous_world=truth,
        previous_sigma_m=np.full(20, 0.155),
        previous_dt_s=np.full(20, 1 / 12),
    )
    assert fit.inferred[:, arm].all() and not fit.inferred[:, JOINT_INDEX["left_elbow"]].any()
    err = np.linalg.norm(fit.points_world - truth, axis=-1)
    assert np.median(err[:, arm]) < 0.05
    assert np.median(fit.variance_world[:, arm]) > 10 * np.median(fit.variance_world[:, JOINT_INDEX["left_elbow"]])
    assert np.isnan(fit.reprojection_error_px[:, arm]).all()


def test_a_wrong_keypoint_does_not_drag_the_body(rng):
    """Huber loss: one camera puts a confident elbow 60 px off (a network's mistake)."""
    truth = _bodies(20, rng)
    P, px, conf = _views(truth, rng)
    e = JOINT_INDEX["right_elbow"]
    px[:, 0, e] += 60.0
    robust = _fit(P, px, conf, truth, truth + 0.02)
    plain = B.fit_bodies(
        P,
        px,
        conf,
        truth + 0.02,
        B.segment_lengths(truth),
        B._PLAY_ABS + B._PLAY_REL * B.segment_lengths(truth),
        options=B.FitOptions(huber_k=1e6),
    )  # squared loss
    err_r = np.linalg.norm(robust.points_world[:, e] - truth[:, e], axis=-1)
    err_p = np.linalg.norm(plain.points_world[:, e] - truth[:, e], axis=-1)
    assert np.median(err_r) < 0.5 * np.median(err_p)
    others = [j for j in range(NUM_JOINTS) if j != e]
    assert np.median(np.linalg.norm(robust.points_world[:, others] - truth[:, others], axis=-1)) < 0.015


def test_angles_from_the_fit_follow_the_posture(rng):
    truth = _bodies(60, rng)
    P, px, conf = _views(truth, rng)
    fit = _fit(P, px, conf, truth, truth + rng.normal(0.0, 0.05, truth.shape))
    t = np.arange(60) / 12.0
    a, b = joint_angles(fit.points_world, t).to_frame(), joint_angles(truth, t).to_frame()
    for name in ("trunk_flexion", "left_upper_arm_flexion", "right_elbow_flexion", "left_knee_flexion", "neck_flexion"):
        d = np.degrees(np.abs(a[name] - b[name]))
        assert np.median(d) < 4.0, name


def test_worker_lengths_measured_or_scaled_population():
    L = B.PRIOR_LENGTH_VECTOR * 1.1
    measured = np.full(B.NUM_SEGMENTS, np.nan)
    samples = np.zeros(B.NUM_SEGMENTS)
    measured[:4], samples[:4] = L[:4], 100
    length, play = B.worker_lengths(measured, samples)
    assert np.allclose(length, L)  # measured ones as measured, the rest scaled by 1.1
    assert np.all(play[4:] == pytest.approx(B.PRIOR_PLAY * L[4:]))
    assert np.all(play[:4] < play[4:8])
    length, _ = B.worker_lengths(np.full(B.NUM_SEGMENTS, np.nan), np.zeros(B.NUM_SEGMENTS))
    assert np.allclose(length, B.PRIOR_LENGTH_VECTOR)


def test_segments_cover_every_joint_and_the_limbs_come_first():
    from ergopose.keypoints import LIMBS

    assert B.SEGMENTS[: len(LIMBS)] == tuple(name for name, _, _ in LIMBS)
    touched = (B.SEGMENT_MATRIX != 0).any(axis=0)
    assert touched.all()
    assert np.allclose(B.SEGMENT_MATRIX.sum(axis=1), 0.0)  # differences of points


def test_a_camera_that_crossed_the_legs_or_the_whole_body_is_turned_back(rng):
    """Against the previous pose, a camera whose network labelled the whole body the wrong way
    round is exchanged whole; one that crossed only the legs (or only the arms) gets those limbs
    exchanged and nothing else; a camera that got it right is left alone."""
    from ergopose.keypoints import MIRROR

    truth = _bodies(30, rng)
    P, px, conf = _views(truth, rng, noise_px=1.0)
    previous = truth + rng.normal(0.0, 0.01, truth.shape)  # last frame's fit: close to now
    legs, arms = B.LIMB_SIDE_GROUPS[1], B.LIMB_SIDE_GROUPS[0]
    wrong = px.copy()
    wrong[:10, 1] = px[:10, 1][:, MIRROR]  # whole body, camera 2
    wrong[10:20, 1] = np.where(legs[:, None], px[10:20, 1][:, MIRROR], px[10:20, 1])  # legs only
    wrong[20:, 0] = np.where(arms[:, None], px[20:, 0][:, MIRROR], px[20:, 0])  # arms only, camera 1
    fixed, _, swapped, unanimous = B.correct_left_right(P, wrong, conf, previous)
    np.testing.assert_allclose(fixed, px)
    assert swapped[:20, 1].all() and not swapped[:20, 0].any()
    assert swapped[20:, 0].all() and not swapped[20:, 1].any()
    assert not unanimous.any()  # one camera of two against the previous pose: it is turned back
    # Trusting the cameras changes nothing when they are not unanimous.
    again, _, _, _ = B.correct_left_right(P, wrong, conf, previous, trust_cameras=np.ones((30, 3), bool))
    np.testing.assert_allclose(again, px)
    # As reported, the right views are untouched.
    _, _, none, _ = B.correct_left_right(P, px, conf, previous)
    assert not none.any()


def test_a_mirrored_previous_pose_against_unanimous_cameras(rng):
    """When the previous fit is the one the wrong way round, every camera disagrees with it: the
    function says so (unanimous), turns them all to it unless told to trust the cameras, and with
    trust_cameras leaves them as reported."""
    from ergopose.keypoints import MIRROR

    truth = _bodies(20, rng)
    P, px, conf = _views(truth, rng, noise_px=1.0)
    mirrored = truth[:, MIRROR] + rng.normal(0.0, 0.01, truth.shape)
    locked, _, swapped, unanimous = B.correct_left_right(P, px, conf, mirrored)
    assert swapped.all() and unanimous[:, 0].all()
    np.testing.assert_allclose(locked, px[:, :, MIRROR])
    trust = np.zeros((20, 3), bool)
    trust[:, 0] = True
    kept, _, swapped, unanimous = B.correct_left_right(P, px, conf, mirrored, trust_cameras=trust)
    assert unanimous[:, 0].all() and not swapped.any()
    np.testing.assert_allclose(kept, px)


def _shift_rows(truth, P, px, conf):
    """The rows ShiftBodies.fit_range takes, for one worker (identity 0) over len(truth) frames."""
    n = len(truth)
    return {
        "frame": np.arange(n),
        "identity": np.zeros(n, np.int64),
        "points": truth.copy(),
        "ungated": truth.copy(),
        "var": np.full(truth.shape, 1e-4),
        "views": np.full((n, NUM_JOINTS), 2),
        "err": np.full((n, NUM_JOINTS), 1.0),
        "conf": np.full((n, NUM_JOINTS), 0.9),
        "P": P,
        "px": px,
        "oc": conf,
        "fit": np.full(truth.shape, np.nan),
        "fit_var": np.full(truth.shape, np.nan),
        "inferred": np.zeros((n, NUM_JOINTS), bool),
        "limited": np.zeros((n, NUM_JOINTS), bool),
        "fit_err": np.full((n, NUM_JOINTS), np.nan),
    }


@pytest.mark.parametrize("lock_break_s, recovers", [(0.5, True), (0.0, False)])
def test_a_worker_fitted_mirrored_comes_back_when_the_cameras_agree(rng, lock_break_s, recovers):
    """A worker whose last fit is mirrored (left for right), then seen by two cameras that agree
    with each other for 2 s: with side_lock_break_s = 0.5 the fit follows the cameras from about
    half a second on; with 0 (the previous fit always wins) it stays mirrored the whole time."""
    from ergopose.keypoints import MIRROR
    from ergopose.recon.settings import ReconSettings

    one = _bodies(1, rng)
    truth = np.repeat(one, 24, axis=0) + rng.normal(0.0, 0.002, (24, NUM_JOINTS, 3))
    P, px, conf = _views(truth, rng, noise_px=1.0)
    rows = _shift_rows(truth, P, px, conf)
    bodies = B.ShiftBodies(ReconSettings(side_lock_break_s=lock_break_s), fps=12.0)
    bodies.last[0] = (-1, one[0][MIRROR])
    bodies.fit_range(rows, 0, 24)
    err = np.linalg.norm(rows["fit"] - truth, axis=-1).mean(axis=1)
    err_mirrored = np.linalg.norm(rows["fit"] - truth[:, MIRROR], axis=-1).mean(axis=1)
    assert err_mirrored[0] < 0.05  # the first frame follows the mirrored previous fit either way
    if recovers:
        assert (err[12:] < 0.03).all(), err
        assert bodies.lock_breaks >= 1
    else:
        assert (err_mirrored[12:] < 0.05).all(), err_mirrored
        assert bodies.lock_breaks == 0


def _flexed_bodies(n, rng, wrist_flexion):
    m = BodyMeasurements.from_stature(1.75)
    posture = Posture(
        left_upper_arm_flexion=rng.uniform(0.2, 1.4, n),
        left_elbow_flexion=rng.uniform(0.4, 1.4, n),
        left_wrist_flexion=wrist_flexion,
        heading=rng.uniform(-np.pi, np.pi, n),
        root_position=np.stack([rng.uniform(0.3, 1.2, n), rng.uniform(-0.8, 0.8, n), np.zeros(n)], -1),
    )
    return pose_skeleton(m, place_on_floor(m, posture))


@pytest.mark.slow
def test_a_hand_two_cameras_do_not_see_continues_its_forearm_and_a_seen_hand_keeps_its_bend(rng):
    """The hand prior (fit_hand_prior_sigma_m): a hand no camera sees, whose previous fit was bent
    back 100 deg (a fit gone wrong), comes back towards its forearm with the prior and stays bent
    back without it; a hand two cameras see keeps its 45 deg of flexion."""
    n = 40
    truth = _flexed_bodies(n, rng, np.zeros(n))
    wrong = _flexed_bodies(n, np.random.default_rng(0), np.full(n, -np.radians(100.0)))
    hand = [JOINT_INDEX[f"left_{j}"] for j in ("wrist", "index", "pinky", "thumb")]
    start = truth.copy()
    start[:, hand] = truth[:, hand] + (wrong[:, hand] - wrong[:, [JOINT_INDEX["left_wrist"]]])
    start[:, hand] -= start[:, [JOINT_INDEX["left_wrist"]]] - truth[:, [JOINT_INDEX["left_wrist"]]]
    P, px, conf = _views(truth, rng)
    conf[:, :, hand] = 0.0  # no camera sees the hand
    flex = {}
    for sigma in (0.05, 0.0):
        fit = _fit(
            P,
            px,
            conf,
            truth,
            start,
            previous_world=start,
            previous_sigma_m=np.full(n, 0.155),
            previous_dt_s=np.full(n, 1 / 12),
            options=B.FitOptions(hand_prior_sigma_m=sigma),
        )
        flex[sigma] = np.degrees(joint_angles(fit.points_world).to_frame()["left_wrist_flexion"].to_numpy())
    assert np.median(np.abs(flex[0.05])) < 30.0  # 22.5 measured (46.4 without the prior)
    assert np.median(np.abs(flex[0.0])) > np.median(np.abs(flex[0.05])) + 15.0
    # Seen by both cameras, bent 45 deg: the prior does not touch it.
    bent = _flexed_bodies(n, rng, np.full(n, np.radians(45.0)))
    P, px, conf = _views(bent, rng)
    fit = _fit(P, px, conf, bent, bent + rng.normal(0.0, 0.02, bent.shape))
    got = np.degrees(joint_angles(fit.points_world).to_frame()["left_wrist_flexion"].to_numpy())
    assert abs(np.median(got) - 45.0) < 4.0


def _stooped_bodies(n, rng, trunk_flexion=1.2):
    """n workers bent forward by ``trunk_flexion`` (radians), the head in line with the trunk
    (neck flexion 0), arms hanging, at random headings."""
    m = BodyMeasurements.from_stature(1.75)
    posture = Posture(
        trunk_flexion=np.full(n, trunk_flexion),
        heading=rng.uniform(-np.pi, np.pi, n),
        root_position=np.stack([rng.uniform(0.3, 1.2, n), rng.uniform(-0.8, 0.8, n), np.zeros(n)], axis=-1),
    )
    return pose_skeleton(m, place_on_floor(m, posture))


def test_the_pose_prior_is_articulated_the_head_follows_the_trunk_and_the_template_is_its_own_fixed_point(rng):
    """The prior's links turn with the hips' heading (trunk, arms, legs) or with the current trunk
    (the head): TEMPLATE_BODY placed anywhere costs nothing, and a bent worker's head continues
    the trunk (independent forward kinematics, ergopose.ergonomics.body)."""
    n = 6
    heading = rng.uniform(-np.pi, np.pi, n)
    # The template's frame (x to the left hip, y forward, z up) is left-handed: world columns
    # left, left x up (forward), up.
    left = np.stack([np.cos(heading), np.sin(heading), np.zeros(n)], axis=-1)
    body_to_world = np.stack([left, np.cross(left, [0.0, 0.0, 1.0]), np.broadcast_to([0.0, 0.0, 1.0], (n, 3))], -1)
    placed = B.TEMPLATE_BODY @ np.swapaxes(body_to_world, 1, 2) + np.array([0.5, -0.3, 0.95])
    assert np.allclose(B.PRIOR_LINK_MATRIX @ placed, B.prior_links(placed, np.ones(n)), atol=1e-12)
    # Bent forward, the head's links are the trunk's turn of the template's; the legs still hang.
    bent = _stooped_bodies(n, rng)
    links = B.prior_links(bent, np.ones(n))
    head = np.array([name.startswith("head_") for name, *_ in B._PRIOR_LINKS])
    legs = np.array(["knee" in name or "ankle" in name for name, *_ in B._PRIOR_LINKS])
    trunk_axis = 0.5 * (bent[:, 11] + bent[:, 12] - bent[:, 23] - bent[:, 24])
    trunk_axis /= np.linalg.norm(trunk_axis, axis=-1, keepdims=True)
    up_along = (links[:, head] * trunk_axis[:, None]).sum(axis=-1)  # each head link along the trunk
    assert np.allclose(up_along, B._LINK_TEMPLATE[head, 2], atol=1e-9)
    assert np.all(links[:, legs, 2] <= 1e-9)  # thighs and shanks point down, the feet level
    assert np.allclose(links[:, legs & np.array(["knee" in name for name, *_ in B._PRIOR_LINKS]), :2], 0.0, atol=0.03)


def test_a_bent_worker_whose_face_no_camera_sees_keeps_the_head_in_line_with_the_trunk(rng):
    """Seen from above, a worker bent forward 70 deg hides the face. With no camera seeing the face
    points and no previous pose, only the prior turns the head: it continues the trunk (neck
    flexion near the true 0), not the standing pose's upright head."""
    n = 8
    truth = _stooped_bodies(n, rng)
    P, px, conf = _views(truth, rng)
    face = [JOINT_INDEX[name] for name in B._RIGID_PARTS[0][1]]
    conf[:, :, face] = 0.0
    px[:, :, face] = np.nan
    start = truth + rng.normal(0.0, 0.03, truth.shape)
    fit = _fit(P, px, conf, truth, start)
    t = np.arange(n) / 12.0
    neck = np.degrees(joint_angles(fit.points_world, t).to_frame()["neck_flexion"].to_numpy())
    assert np.all(np.abs(neck) < 10.0), neck
    err = np.linalg.norm(fit.points_world[:, face] - truth[:, face], axis=-1)
    assert np.median(err) < 0.04


def test_a_new_track_missing_a_hip_starts_from_the_template_turned_onto_what_was_triangulated(rng):
    """A worker's first frame: the cameras did not both see the left hip, shoulder and the left
    side of the face (NaN in the triangulation). Those joints start from the neutral pose turned
    and moved onto the triangulated ones by a proper rotation (never its mirror image): near a
    neutral standing worker's, the left ear on the left. The earlier start, a template faced by
    the hip line with the missing hip put at the origin, put the left ear decimetres off (in the
    simulator the face then settled as its mirror image for 50 frames)."""
    m = BodyMeasurements.from_stature(1.75)
    n = 8
    heading = rng.uniform(-np.pi, np.pi, n)
    root = np.stack([rng.uniform(0.3, 1.2, n), rng.uniform(-0.8, 0.8, n), np.zeros(n)], axis=-1)
    truth = pose_skeleton(m, place_on_floor(m, Posture(heading=heading, root_position=root)))
    hidden = [
        JOINT_INDEX[name]
        for name in ("left_hip", "left_shoulder", "left_ear", "left_eye", "left_eye_outer", "left_eye_inner")
    ]
    ear = JOINT_INDEX["left_ear"]
    nothing = np.full((NUM_JOINTS, 3), np.nan)
    old_ear = []
    for r in range(n):
        tri = truth[r].copy()
        tri[hidden] = np.nan
        placed = B._aligned_template(tri, nothing)
        assert np.median(np.linalg.norm(placed - truth[r], axis=-1)) < 0.05
        assert np.linalg.norm(placed[ear] - truth[r, ear]) < 0.06
        pelvis = B._pelvis_guess(
            tri[None], np.zeros((1, 1, 3, 4)), np.full((1, 1, NUM_JOINTS, 2), np.nan), np.zeros((1, 1, NUM_JOINTS))
        )
        before = B.template_pose(pelvis, B._yaw_frames(np.where(np.isfinite(tri), tri, 0.0)[None]))[0]
        old_ear.append(np.linalg.norm(before[ear] - truth[r, ear]))
    assert np.median(old_ear) > 0.15
    # Fewer than four points, or points on a line: the fallback.
    assert np.isnan(B._aligned_template(nothing, nothing)).all()
    line = np.full((NUM_JOINTS, 3), np.nan)
    line[:5] = np.linspace(0.0, 1.0, 5)[:, None] * np.array([1.0, 0.0, 0.0])
    assert np.isnan(B._aligned_template(line, nothing)).all()


def test_one_camera_keeps_a_foot_near_the_floor_and_two_cameras_are_left_alone(rng):
    """One camera, population segment lengths (a worker not yet measured), started 30 % too close
    along the camera's rays: without the floor-contact prior bodies float (the lowest heel or toe
    up to 0.3 m up); with it every body has a foot within 6 cm of the contact band (0.15 m; the
    farthest measured 5.1 cm), and
    the hips come nearer the truth. Seen by two cameras the prior is off: the same fit to the bit."""
    truth = _bodies(30, rng)
    P, px, conf = _views(truth, rng)
    one = conf.copy()
    one[:, 1] = 0.0
    L, play = B.worker_lengths(np.full(B.NUM_SEGMENTS, np.nan), np.zeros(B.NUM_SEGMENTS))
    L, play = np.tile(L, (30, 1)), np.tile(play, (30, 1))
    start = CAMERAS[0] + 0.7 * (truth - CAMERAS[0])
    hips = [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]
    runs = {}
    for sigma in (0.0, 0.05):
        fit = B.fit_bodies(P, px, one, start, L, play, options=B.FitOptions(floor_contact_sigma_m=sigma))
        lowest = fit.points_world[:, B._SOLE, 2].min(axis=1)
        hip_err = np.linalg.norm(fit.points_world[:, hips].mean(axis=1) - truth[:, hips].mean(axis=1), axis=-1)
        runs[sigma] = (lowest, hip_err)
    assert runs[0.0][0].max() > 0.25 and runs[0.05][0].max() < B.FLOOR_CONTACT_BAND_M + 0.06, runs
    assert np.percentile(runs[0.05][1], 90) < np.percentile(runs[0.0][1], 90)
    both = [
        B.fit_bodies(P, px, conf, start, L, play, options=B.FitOptions(floor_contact_sigma_m=s)).points_world
        for s in (0.0, 0.05)
    ]
    assert np.array_equal(both[0], both[1])
