"""The scoring of ergopose.evaluation.pose on synthetic people under a ceiling camera, against
answers worked out independently (angles from dot products, boxes from the pixels, rotations
checked by where the transformed joints land)."""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.errors import ConfigError
from ergopose.geometry.camera import ceiling_camera
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS
from ergopose.evaluation.pose import evaluate_session
from ergopose.evaluation.pose_geometry import EVAL_JOINTS, FIT_JOINTS, PersonGeometry
from ergopose.evaluation.pose_records import CONDITIONS, EvaluationSettings, PersonTrials
from ergopose.evaluation.pose_report import region_summary
from ergopose.evaluation.pose_scoring import TrialRows, match_stage, score_prediction
from ergopose.pose.records import FrameDetections
from ergopose.pose.settings import PoseSettings

LENS = KannalaBrandt(fx=330.0, fy=330.0, cx=511.5, cy=511.5, k1=0.01, k2=-0.004)
CAMERA_HEIGHT = 3.0

#: A standing person facing +x at the origin: (forward, left, height) in metres per joint.
_BODY = {
    "nose": (0.10, 0.0, 1.62),
    "left_eye_inner": (0.09, 0.02, 1.66),
    "left_eye": (0.09, 0.035, 1.66),
    "left_eye_outer": (0.08, 0.05, 1.66),
    "right_eye_inner": (0.09, -0.02, 1.66),
    "right_eye": (0.09, -0.035, 1.66),
    "right_eye_outer": (0.08, -0.05, 1.66),
    "left_ear": (0.0, 0.08, 1.64),
    "right_ear": (0.0, -0.08, 1.64),
    "mouth_left": (0.09, 0.025, 1.57),
    "mouth_right": (0.09, -0.025, 1.57),
    "left_shoulder": (0.0, 0.19, 1.45),
    "right_shoulder": (0.0, -0.19, 1.45),
    "left_elbow": (0.0, 0.22, 1.15),
    "right_elbow": (0.0, -0.22, 1.15),
    "left_wrist": (0.03, 0.23, 0.88),
    "right_wrist": (0.03, -0.23, 0.88),
    "left_pinky": (0.05, 0.24, 0.80),
    "right_pinky": (0.05, -0.24, 0.80),
    "left_index": (0.06, 0.23, 0.79),
    "right_index": (0.06, -0.23, 0.79),
    "left_thumb": (0.06, 0.21, 0.82),
    "right_thumb": (0.06, -0.21, 0.82),
    "left_hip": (0.0, 0.10, 0.95),
    "right_hip": (0.0, -0.10, 0.95),
    "left_knee": (0.02, 0.10, 0.50),
    "right_knee": (0.02, -0.10, 0.50),
    "left_ankle": (0.0, 0.10, 0.08),
    "right_ankle": (0.0, -0.10, 0.08),
    "left_heel": (-0.05, 0.10, 0.04),
    "right_heel": (-0.05, -0.10, 0.04),
    "left_foot_index": (0.15, 0.10, 0.02),
    "right_foot_index": (0.15, -0.10, 0.02),
}


def standing_person(x: float, y: float, heading: float = 0.0) -> np.ndarray:
    """(33, 3) world joints of the standing person at floor position (x, y), facing ``heading``."""
    local = np.array([_BODY[name] for name in sorted(_BODY, key=JOINT_INDEX.__getitem__)])
    c, s = np.cos(heading), np.sin(heading)
    out = np.empty_like(local)
    out[:, 0] = x + c * local[:, 0] - s * local[:, 1]
    out[:, 1] = y + s * local[:, 0] + c * local[:, 1]
    out[:, 2] = local[:, 2]
    return out


@pytest.fixture(scope="module")
def camera():
    return ceiling_camera("cam", LENS, 1024, 1024, position_world=(0.0, 0.0, CAMERA_HEIGHT))


def geometry(camera, joints, visibility=None):
    vis = np.zeros(NUM_JOINTS, np.int8) if visibility is None else visibility
    return PersonGeometry.of(camera, joints, camera.project_world(joints), vis)


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    a = axis / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


SETTINGS = EvaluationSettings.like_stage()


def test_settings_follow_the_stage():
    stage = PoseSettings()
    assert SETTINGS.margin == stage.body_margin
    assert SETTINGS.min_half_fov == stage.min_half_fov and SETTINGS.max_half_fov == stage.max_half_fov
    assert SETTINGS.min_presence == stage.min_presence
    plain = EvaluationSettings()  # the plain defaults are the stage's too
    assert (plain.margin, plain.min_half_fov, plain.max_half_fov, plain.min_presence) == (
        stage.body_margin,
        stage.min_half_fov,
        stage.max_half_fov,
        stage.min_presence,
    )
    assert len(EVAL_JOINTS) == 12 and set(EVAL_JOINTS) <= set(FIT_JOINTS)


@pytest.mark.parametrize("x, y", [(0.3, 0.2), (1.5, -1.0), (-2.2, 2.0)])
def test_person_geometry_torso_angle_and_theta(camera, x, y):
    joints = standing_person(x, y, heading=0.7)
    p = geometry(camera, joints)
    hip = joints[[JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]].mean(axis=0)
    shoulder = joints[[JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]]].mean(axis=0)
    offset = hip - np.array([0.0, 0.0, CAMERA_HEIGHT])
    assert p.torso_angle == pytest.approx(0.50 / np.linalg.norm(offset), rel=1e-12)
    assert p.trunk_inclination == pytest.approx(0.0, abs=1e-12)
    leaning = geometry(camera, leaning_person(x, y, 0.7, np.radians(35.0)))
    assert np.degrees(leaning.trunk_inclination) == pytest.approx(35.0)
    assert np.allclose(p.hip_world, hip)
    assert np.linalg.norm(shoulder - hip) == pytest.approx(0.50)
    # The camera looks straight down: the angle off its axis is the angle off the vertical.
    # (theta belongs to the mean of the two hip rays, within 0.1 degree of the 3D mid-point's ray)
    assert p.theta == pytest.approx(np.arctan2(np.hypot(x, y), CAMERA_HEIGHT - hip[2]), abs=np.radians(0.1))
    left, right = (joints[JOINT_INDEX[n]] - [0, 0, CAMERA_HEIGHT] for n in ("left_hip", "right_hip"))
    mean_ray = left / np.linalg.norm(left) + right / np.linalg.norm(right)
    mean_ray *= [1, -1, -1]  # world -> camera frame of a ceiling camera with yaw 0
    assert p.theta == pytest.approx(np.arccos(mean_ray[2] / np.linalg.norm(mean_ray)), abs=1e-12)
    assert p.torso_visible and p.counted(SETTINGS)
    side = np.zeros(NUM_JOINTS, np.int8)
    side[JOINT_INDEX["right_hip"]] = 1  # behind the person's own body: still counted
    assert not geometry(camera, joints, side).torso_visible
    assert geometry(camera, joints, side).counted(SETTINGS)
    assert not geometry(camera, joints, side).counted(EvaluationSettings.like_stage(torso_codes=(0,)))
    for code in (2, 3, 4):  # hidden by another worker, by furniture, outside the image
        hidden = side.copy()
        hidden[JOINT_INDEX["left_shoulder"]] = code
        assert not geometry(camera, joints, hidden).counted(SETTINGS)


def test_perfect_prediction_is_found_with_zero_error(camera):
    vis = np.zeros(NUM_JOINTS, np.int8)
    vis[JOINT_INDEX["left_wrist"]] = 1
    p = geometry(camera, standing_person(1.2, 0.4), vis)
    found, hip_err, err_px, err_torso = score_prediction(p, p.pixels, p.rays_cam, 0.9, SETTINGS)
    assert found and hip_err == pytest.approx(0.0, abs=1e-7)
    wrist = list(EVAL_JOINTS).index(JOINT_INDEX["left_wrist"])
    assert np.isnan(err_px[wrist]) and np.isnan(err_torso[wrist])
    others = np.delete(np.arange(12), wrist)
    assert np.allclose(err_px[others], 0.0, atol=1e-9) and np.allclose(err_torso[others], 0.0, atol=1e-7)
    # The same keypoints with a low pose flag: not found, no keypoint errors.
    found, _, err_px, _ = score_prediction(p, p.pixels, p.rays_cam, 0.49, SETTINGS)
    assert not found and np.isnan(err_px).all()


@pytest.mark.parametrize("torso_lengths", [0.1, 0.3, 0.49, 0.51, 0.9])
def test_hip_error_in_torso_lengths(camera, torso_lengths):
    """All rays turned by a known angle about an axis across the hips' line of sight: the hip
    error is that angle divided by the torso's angle."""
    p = geometry(camera, standing_person(-1.0, 1.3))
    axis = np.cross(p.hip_ray, [0.0, 0.0, 1.0])
    angle = torso_lengths * p.torso_angle
    rays = p.rays_cam @ rotation_about(axis, angle).T
    found, hip_err, err_px, err_torso = score_prediction(p, camera.lens.project(rays), rays, 1.0, SETTINGS)
    assert hip_err == pytest.approx(torso_lengths, rel=1e-6)
    assert found == (torso_lengths <= 0.5)
    if found:
        # Rays off the rotation's equator turn by less: angle from the dot product.
        turned = np.arccos(np.clip(np.sum(rays[EVAL_JOINTS] * p.rays_cam[EVAL_JOINTS], axis=1), -1, 1))
        assert np.allclose(err_torso, turned / p.torso_angle, rtol=1e-5)
        assert np.all(err_torso <= torso_lengths * (1 + 1e-9)) and np.all(err_torso > 0.95 * torso_lengths)
        expected_px = np.linalg.norm(camera.lens.project(rays[EVAL_JOINTS]) - p.pixels[EVAL_JOINTS], axis=1)
        assert np.allclose(err_px, expected_px)
        assert np.all(err_px > 0)


@pytest.mark.parametrize("x, y", [(0.0, 0.05), (1.0, 0.0), (-1.4, 1.4), (0.6, -2.5), (-2.6, -0.3)])
def test_view_is_aimed_at_the_hips_and_holds_the_body(camera, x, y):
    joints = standing_person(x, y, heading=1.1)
    p = geometry(camera, joints)
    view = p.view(camera, (256, 256), SETTINGS)
    aim_world = camera.points_cam_to_world(2.0 * p.hip_ray)  # a point on the hip-centre ray
    centre = view.project_world(aim_world)
    assert np.allclose(centre, [127.5, 127.5], atol=1e-6)
    # The ray of the mean hip ray and the ray to the 3D mid-point of the hips nearly coincide.
    assert np.allclose(view.project_world(p.hip_world), centre, atol=0.5)
    # Half field of view = margin x largest angle between the hip ray and a body joint's ray.
    rays = p.rays_cam[FIT_JOINTS]
    radius = np.max(np.arccos(np.clip(rays @ p.hip_ray, -1, 1)))
    half = np.clip(SETTINGS.margin * radius, SETTINGS.min_half_fov, SETTINGS.max_half_fov)
    assert view.lens.fx == pytest.approx(128.0 / np.tan(half), rel=1e-9)
    px = view.project_world(joints[FIT_JOINTS])
    assert np.all((px > -0.5) & (px < 255.5))
    # Upright: the vertical through the hips points straight up in the view.
    above = view.project_world(aim_world + [0.0, 0.0, 0.4])
    assert above[1] < centre[1] and abs(above[0] - centre[0]) < 1e-6


def leaning_person(x: float, y: float, heading: float, lean: float) -> np.ndarray:
    """The standing person with the upper body tipped forward by ``lean`` (radians) about the hips."""
    joints = standing_person(0.0, 0.0)
    hip_height = _BODY["left_hip"][2]
    upper = joints[:, 2] > hip_height + 1e-9
    rel = joints[upper] - [0.0, 0.0, hip_height]
    c, s = np.cos(lean), np.sin(lean)
    joints[upper] = np.stack([c * rel[:, 0] + s * rel[:, 2], rel[:, 1], -s * rel[:, 0] + c * rel[:, 2]], axis=1)
    joints[upper, 2] += hip_height
    ch, sh = np.cos(heading), np.sin(heading)
    out = joints.copy()
    out[:, 0] = x + ch * joints[:, 0] - sh * joints[:, 1]
    out[:, 1] = y + sh * joints[:, 0] + ch * joints[:, 1]
    return out


@pytest.mark.parametrize("x, y, side", [(1.2, 0.0, 1), (0.0, -1.5, -1), (-1.4, 1.4, 1), (0.3, 0.2, -1)])
def test_aligned_view_is_the_upright_view_rolled_to_the_body(camera, x, y, side):
    # Leaning across the line of sight (a lean along it would not tip the torso in the image).
    heading = np.arctan2(y, x) + side * np.pi / 2
    joints = leaning_person(x, y, heading, lean=np.radians(35.0))
    p = geometry(camera, joints)
    upright = p.view(camera, (256, 256), SETTINGS)
    aligned = p.aligned_view(camera, (256, 256), SETTINGS)
    r = aligned.rotation_cam_from_view
    assert np.allclose(r.T @ r, np.eye(3), atol=1e-12) and np.linalg.det(r) == pytest.approx(1.0)
    # Same optical axis and lens: only rolled.
    assert np.allclose(r[:, 2], upright.rotation_cam_from_view[:, 2], atol=1e-12)
    assert aligned.lens == upright.lens
    shoulder_ray = p.rays_cam[[JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]]].mean(axis=0)
    hip = aligned.lens.project(p.hip_ray @ r)
    sh = aligned.lens.project(shoulder_ray / np.linalg.norm(shoulder_ray) @ r)
    assert np.allclose(hip, 127.5, atol=1e-6)
    assert sh[1] < hip[1] and abs(sh[0] - hip[0]) < 1e-6 * abs(sh[1] - hip[1])
    # In the upright view the leaning torso is tipped: the roll is not zero.
    r0 = upright.rotation_cam_from_view
    d = upright.lens.project(shoulder_ray / np.linalg.norm(shoulder_ray) @ r0) - upright.lens.project(p.hip_ray @ r0)
    assert abs(np.degrees(np.arctan2(d[0], -d[1]))) > 5.0
    body = aligned.project_world(joints[FIT_JOINTS])
    assert np.all((body > -0.5) & (body < 255.5))


@pytest.mark.parametrize("x, y", [(1.0, 0.0), (0.0, -1.5), (-1.4, 1.4), (2.2, 1.9)])
def test_crops_around_the_true_keypoints(camera, x, y):
    joints = standing_person(x, y, heading=-0.4)
    p = geometry(camera, joints)
    px = p.pixels[FIT_JOINTS]
    roi = p.crop_roi(SETTINGS)
    assert roi.rotation == 0.0
    assert np.allclose(roi.centre, (px.min(axis=0) + px.max(axis=0)) / 2)
    assert roi.side == pytest.approx(SETTINGS.margin * np.max(px.max(axis=0) - px.min(axis=0)))
    in_crop = px @ roi.image_to_crop(256)[:, :2].T + roi.image_to_crop(256)[:, 2]
    assert np.all((in_crop > 0) & (in_crop < 255))
    # Rotated crop: hips at the centre, shoulders straight above them.
    rot = p.rotated_roi(SETTINGS)
    m = rot.image_to_crop(256)
    hip = p.pixels[[JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]].mean(axis=0) @ m[:, :2].T + m[:, 2]
    sh = p.pixels[[JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]]].mean(axis=0) @ m[:, :2].T + m[:, 2]
    assert np.allclose(hip, 127.5, atol=1e-6)
    assert sh[1] < hip[1] and abs(sh[0] - hip[0]) < 1e-6
    in_rot = px @ m[:, :2].T + m[:, 2]
    assert np.all((in_rot > 0) & (in_rot < 255))


def detections(camera, rays_list, presence):
    rays = np.stack(rays_list)
    n = rays.shape[0]
    return FrameDetections(
        0,
        0,
        np.zeros((n, NUM_JOINTS, 2)),
        camera.lens.project(rays),
        rays,
        np.ones((n, NUM_JOINTS)),
        np.asarray(presence, float),
        np.zeros((n, 3, 4)),
        np.zeros((n, 3)),
        np.zeros(n),
        np.zeros(n, np.int64),
    )


def test_stage_matching_is_one_to_one_and_counts_false_positives(camera):
    a = geometry(camera, standing_person(1.0, 0.5))
    b = geometry(camera, standing_person(-1.5, 1.0))
    hidden = geometry(camera, standing_person(0.5, -2.0))
    ghost = geometry(camera, standing_person(2.0, -2.0))
    shift = rotation_about(np.cross(a.hip_ray, [0.0, 0.0, 1.0]), 0.2 * a.torso_angle)
    # Detections: b exactly, a slightly off, a second (worse) copy of a, the hidden worker, a ghost.
    found = detections(
        camera,
        [b.rays_cam, a.rays_cam @ shift.T, a.rays_cam @ (shift @ shift @ shift).T, hidden.rays_cam, ghost.rays_cam],
        [0.9, 0.8, 0.7, 0.9, 0.9],
    )
    matches, false_positives = match_stage([(0, a), (1, b)], [hidden], found, SETTINGS)
    assert matches == {0: 1, 1: 0}
    # The second copy of a and the ghost are false positives; the hidden worker's detection is not.
    assert false_positives == 2
    none, fp = match_stage([(0, a)], [], FrameDetections.empty(0, 0), SETTINGS)
    assert none == {} and fp == 0


def test_summary_counts_and_percentiles():
    n, k = 5, EVAL_JOINTS.size
    err = np.full((n, k), np.nan)
    err[0, :4] = [1.0, 2.0, 3.0, 4.0]
    err[2, :2] = [5.0, 10.0]
    trials = PersonTrials(
        condition=np.zeros(n, np.int64),
        frame=np.arange(n),
        camera=np.zeros(n, np.int64),
        worker=np.zeros(n, np.int64),
        region=np.ones(n, np.int64),
        theta=np.full(n, 0.7),
        trunk_inclination=np.full(n, 0.1),
        presence=np.array([0.9, 0.2, 0.8, np.nan, 0.1]),
        found=np.array([True, False, True, False, False]),
        hip_error_torso=np.full(n, 0.1),
        joint_error_px=err,
        joint_error_torso=err / 10.0,
    )
    s = region_summary("view", "all", "outer", trials)
    assert (s.persons, s.found, s.joints) == (5, 2, 6)
    assert s.detection_rate == pytest.approx(0.4)
    values = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 10.0])
    assert s.error_px_median == pytest.approx(3.5)
    assert s.error_px_p90 == pytest.approx(np.percentile(values, 90))
    assert s.error_torso_median == pytest.approx(0.35)
    empty = region_summary("view", "all", "edge", trials.select(np.zeros(n, bool)))
    assert empty.persons == 0 and np.isnan(empty.detection_rate) and np.isnan(empty.error_px_median)


def test_unknown_condition_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="unknown condition"):
        evaluate_session(tmp_path, conditions=("view", "fisheye_network"))
    assert CONDITIONS == ("view", "crop", "rotated_crop", "aligned_view", "stage")


def test_region_follows_the_configured_limits(camera):
    # Hips 0.95 m up under a camera at 3 m: 57 degrees off-axis at 3.16 m from the axis.
    p = geometry(camera, standing_person(3.16, 0.0))
    assert np.degrees(p.theta) == pytest.approx(57.0, abs=0.2)
    nan = np.full(EVAL_JOINTS.size, np.nan)
    regions = []
    for limits in ((30.0, 60.0), (30.0, 55.0), (60.0, 70.0)):
        rows = TrialRows(limits)
        rows.add(0, 0, 0, 0, p, 0.9, (False, 1.0, nan, nan))
        regions.append(int(rows.trials().region[0]))
    assert regions == [1, 2, 0]
    assert EvaluationSettings().region_limits_deg == (30.0, 60.0)
