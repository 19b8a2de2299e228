"""Views that stay upright and a body that keeps its left and right (issue 19).

Geometry: a view built for a person at known positions and body-axis rolls holds world vertical
within the bounded correction. Network (real BlazePose on the drawn person warped into a fisheye
frame): a view that starts upside down is re-checked and comes upright at once, where the stage
before issue 19 stays locked upside down; a left/right swap injected into a sequence is put back,
and a swap the network keeps making is followed with the limbs marked uncertain.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_fisheye import LENS, SIZE, fisheye_with_person

from ergopose.geometry.camera import Camera, ceiling_camera, look_at_rotation
from ergopose.geometry.lenses.equidistant import Equidistant
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.keypoints import JOINT_INDEX
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.pose.records import SOURCE_REFOCUS, Target
from ergopose.pose.settings import PoseSettings
from ergopose.pose.view_geometry import bounded_up, roll_from_upright, upright_defined, view_rotation

#: The stage before issue 19: views follow the body axis wherever it points, no re-check,
#: duplicates ranked by confidence only, no left/right check.
BEFORE = PoseSettings(max_body_roll=np.pi, recheck_roll=None, merge_prefers_upright=False, left_right_check=False)
L_SH, R_SH = JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]
L_WR, R_WR = JOINT_INDEX["left_wrist"], JOINT_INDEX["right_wrist"]


def _unit(v):
    return np.asarray(v, float) / np.linalg.norm(v)


def _image_roll_of_world_up(camera, rotation_cam_from_view, point_world):
    """Angle (radians, clockwise on screen) of the image of the world vertical through
    ``point_world`` from straight up, in a 256 x 256 view with the given rotation."""
    lens = Rectilinear.from_fov(256, 256, np.radians(40))
    a = camera.points_world_to_cam(np.asarray(point_world, float)) @ rotation_cam_from_view
    b = camera.points_world_to_cam(np.asarray(point_world, float) + [0, 0, 0.2]) @ rotation_cam_from_view
    d = lens.project(b) - lens.project(a)
    return float(np.arctan2(d[0], -d[1]))


CAMERAS = {
    "ceiling": ceiling_camera("cam_1", Equidistant(330.0, 330.0, 511.5, 511.5), 1024, 1024, (0.0, 0.0, 3.0)),
    # A tilted wall camera (the re-rendered Pose2Sim cameras are of this kind).
    "tilted": Camera(
        "cam_2",
        Equidistant(300.0, 300.0, 511.5, 511.5),
        1024,
        1024,
        look_at_rotation((1.0, 0.3, -0.6)),
        (-2.0, -1.0, 2.5),
    ),
}


@pytest.mark.slow
@pytest.mark.parametrize("bound_deg", [0.0, 30.0])
@pytest.mark.parametrize("name", list(CAMERAS))
def test_views_are_upright_to_the_world_within_the_bound(name, bound_deg):
    camera = CAMERAS[name]
    s = PoseSettings(max_body_roll=np.radians(bound_deg))
    rng = np.random.default_rng(19)
    checked = near_axis = 0
    for _ in range(60):
        hips = np.array([rng.uniform(-3, 3), rng.uniform(-3, 3), 1.0])
        d = _unit(camera.points_world_to_cam(hips))
        if camera.lens.project(d)[0] != camera.lens.project(d)[0]:  # outside the lens
            continue
        upright = view_rotation(camera, d)
        for body_roll_deg in (0.0, 20.0, -45.0, 90.0, 150.0, 180.0):
            r = np.radians(body_roll_deg)
            # A body axis rolled by r from world up in the upright view along d.
            body_up = upright @ np.array([np.sin(r), -np.cos(r), 0.0])
            assert np.isclose(roll_from_upright(camera, d, body_up), np.arctan2(np.sin(r), np.cos(r)), atol=1e-9)
            stage = FisheyePoseEstimator.__new__(FisheyePoseEstimator)
            stage.camera, stage.settings = camera, s
            up = stage._view_up(d, body_up)
            rot = view_rotation(camera, d, up)
            world = _image_roll_of_world_up(camera, rot, hips)
            # The image of the world vertical through the person is within the bound of up.
            if not upright_defined(camera, d, s.upright_undefined_angle):
                # Nearly straight below the camera the world has no up in the view: the body decides.
                assert abs(np.sin(world + r)) < 0.01 and np.cos(world + r) > 0, (hips, body_roll_deg)
                near_axis += 1
            elif abs(body_roll_deg) > np.degrees(s.recheck_roll):
                assert abs(world) < np.radians(0.5), (hips, body_roll_deg)  # implausible axis: upright
            else:
                expected = -np.clip(r, -s.max_body_roll, s.max_body_roll)  # the view turns, the world turns back
                assert abs(world - expected) < np.radians(0.5), (hips, body_roll_deg, np.degrees(world))
            checked += 1
    assert checked > 100


def test_bounded_up_limits_and_passes_through():
    camera = CAMERAS["ceiling"]
    d = _unit([0.5, 0.3, 0.8])
    upright = view_rotation(camera, d)
    body = upright @ np.array([np.sin(2.5), -np.cos(2.5), 0.0])  # 143 degrees
    assert np.isclose(roll_from_upright(camera, d, bounded_up(camera, d, body, np.radians(30))), np.radians(30))
    assert bounded_up(camera, d, body, 0.0) is None
    assert bounded_up(camera, d, body, np.pi) is body
    # Straight below the camera the world gives no up: the body axis is used as it is.
    below = np.array([0.0, 0.0, 1.0])
    assert bounded_up(camera, below, body, np.radians(30), np.radians(10)) is body
    assert bounded_up(camera, below, body, 0.0, np.radians(10)) is body


# --------------------------------------------------------------------------------------------
# With the real network


@pytest.fixture(scope="module")
def camera():
    return ceiling_camera("cam_1", LENS, SIZE, SIZE, position_world=(0.0, 0.0, 3.0))


def _upside_down_target(camera, frame_joints, roll_deg=180.0):
    hip = _unit(camera.lens.unproject((frame_joints["left_hip"] + frame_joints["right_hip"]) / 2))
    r = np.radians(roll_deg)
    down = view_rotation(camera, hip) @ np.array([np.sin(r), -np.cos(r), 0.0])
    return Target(hip, np.radians(20.0), SOURCE_REFOCUS, up_cam=down)


@pytest.mark.slow
@pytest.mark.parametrize("target_world", [(1.2, 0.8, 1.0), (-2.0, 1.5, 1.0)])
def test_a_view_that_starts_upside_down_comes_upright(camera, landmarker, target_world):
    frame, joints = fisheye_with_person(camera, target_world)
    torso = np.linalg.norm(joints["left_shoulder"] - joints["left_hip"])
    rolls = {}
    for name, settings in (("before", BEFORE), ("after", PoseSettings())):
        stage = FisheyePoseEstimator(camera, 0, landmarker, None, settings)
        stage._targets = [_upside_down_target(camera, joints)]
        rolls[name] = []
        for f in range(4):
            found = stage.process(frame, f)
            assert found.count == 1, (name, f)
            (nxt,) = stage._targets
            rolls[name].append(np.degrees(abs(roll_from_upright(camera, nxt.direction_cam, nxt.up_cam))))
            if name == "after":
                err = np.linalg.norm(found.pixels_fisheye[0, L_SH] - joints["left_shoulder"])
                assert err < 0.25 * torso
    # Before: the network's alignment points in an upside-down view point "up" in it, and every
    # next view stays upside down.
    assert min(rolls["before"]) > 120.0, rolls
    # After: re-checked in an upright view on the first frame, upright from then on.
    assert max(rolls["after"]) <= np.degrees(PoseSettings().max_body_roll) + 1e-6, rolls
    # The first detection came from the re-check.
    stage = FisheyePoseEstimator(camera, 0, landmarker, None, PoseSettings())
    person = stage._run_view(frame, _upside_down_target(camera, joints))
    assert person is not None and person["rechecked"] and person["view_roll"] == 0.0
    assert abs(person["body_roll"]) < np.radians(30)


class _SwappingLandmarker:
    """The real network, with left and right exchanged in the given calls (counted from 0)."""

    def __init__(self, landmarker, swap_calls):
        from ergopose.keypoints import MIRROR as _MIRROR

        self.inner, self.swap_calls, self.calls, self.mirror = landmarker, set(swap_calls), 0, _MIRROR
        self.input_size = landmarker.input_size

    def __call__(self, image):
        kp = self.inner(image)
        n, self.calls = self.calls, self.calls + 1
        if n not in self.swap_calls:
            return kp
        m = self.mirror
        return dataclasses.replace(
            kp,
            pixels=kp.pixels[m],
            confidence=kp.confidence[m],
            depth=None if kp.depth is None else kp.depth[m],
            landmark_presence=None if kp.landmark_presence is None else kp.landmark_presence[m],
            world_m=None if kp.world_m is None else kp.world_m[m],
        )


def _run(camera, landmarker, frame, joints, settings, frames, flags=None):
    """Left shoulder in the right place (True) or on the right shoulder (False) per frame, and
    the reported confidence of the left wrist; ``flags``, a list, gets each frame's
    ``left_right_uncertain`` of the left wrist."""
    stage = FisheyePoseEstimator(camera, 0, landmarker, None, settings)
    hip = _unit(camera.lens.unproject((joints["left_hip"] + joints["right_hip"]) / 2))
    stage._targets = [Target(hip, np.radians(20.0), SOURCE_REFOCUS)]
    correct, wrist_conf = [], []
    for f in range(frames):
        found = stage.process(frame, f)
        assert found.count == 1
        px = found.pixels_fisheye[0]
        to_left = np.linalg.norm(px[L_SH] - joints["left_shoulder"])
        to_right = np.linalg.norm(px[L_SH] - joints["right_shoulder"])
        correct.append(bool(to_left < to_right))
        wrist_conf.append(float(found.confidence[0, L_WR]))
        if flags is not None:
            flags.append(bool(found.left_right_uncertain[0, L_WR]))
    return correct, wrist_conf


@pytest.mark.slow
def test_a_left_right_swap_in_a_sequence_is_put_back(camera, landmarker):
    frame, joints = fisheye_with_person(camera, (1.2, 0.8, 1.0))
    # The drawn person faces the camera with left and right well apart; the network gets them right.
    assert np.linalg.norm(joints["left_shoulder"] - joints["right_shoulder"]) > 10
    swaps = {3, 6, 7}  # network calls (one view per frame here): frames 3, 6 and 7
    before, _ = _run(
        camera,
        _SwappingLandmarker(landmarker, swaps),
        frame,
        joints,
        dataclasses.replace(PoseSettings(), left_right_check=False),
        10,
    )
    assert [not c for c in before] == [f in swaps for f in range(10)]  # passed on unchecked
    lowering = PoseSettings(uncertain_confidence=0.1)
    flags: list[bool] = []
    after, conf = _run(camera, _SwappingLandmarker(landmarker, swaps), frame, joints, lowering, 10, flags)
    assert all(after), after
    # Two swaps in the recent frames: the frames after the second are flagged uncertain (and,
    # with uncertain_confidence set, lowered; by default they keep their confidence).
    assert conf[2] > 0.5 and conf[7] <= lowering.uncertain_confidence
    # The flag is passed on with the frame's detections, and marks exactly the lowered frames.
    assert flags == [c <= lowering.uncertain_confidence for c in conf], (flags, conf)
    assert not any(flags[:6]) and flags[7]
    flags_default: list[bool] = []
    _, conf_default = _run(
        camera, _SwappingLandmarker(landmarker, swaps), frame, joints, PoseSettings(), 10, flags_default
    )
    assert min(conf_default) > 0.5, conf_default
    assert flags_default == flags  # flagged all the same


@pytest.mark.slow
def test_a_swap_the_network_keeps_is_followed_and_flagged(camera, landmarker):
    """From frame 2 on the network labels the person the other way round for good: the stage
    corrects the first frames of it, then follows the network (one labelling change, not one
    per frame), and with ``uncertain_confidence`` set the frames in between carry lowered
    confidence."""
    frame, joints = fisheye_with_person(camera, (1.2, 0.8, 1.0))
    s = PoseSettings(uncertain_confidence=0.1)
    frames = 2 + 2 * s.left_right_window + 2
    swapped = _SwappingLandmarker(landmarker, range(2, frames))
    correct, conf = _run(camera, swapped, frame, joints, s, frames)
    flip = correct.index(False)
    # Corrected while the network's new labelling is the minority of the recent frames...
    assert correct[:flip] == [True] * flip and flip == 2 + s.left_right_window // 2, correct
    # ... then followed: one change of labelling, not one per frame.
    assert not any(correct[flip:]), correct
    # The frames of the change and a window after it carry lowered confidence; the network's
    # labelling is trusted again once it has held for a whole window.
    assert all(c <= s.uncertain_confidence for c in conf[flip : flip + s.left_right_window]), conf
    assert all(c > 0.5 for c in conf[flip + s.left_right_window :]), conf
    assert conf[1] > 0.5


@pytest.mark.slow
def test_on_real_frames_a_view_that_starts_upside_down_comes_upright(shared_data, landmarker, detector):
    """Real people: frames of the Pose2Sim recording's cam_02 re-rendered into a virtual
    equidistant fisheye (the person 75 degrees off the lens axis, 250 px/rad, the camera turned
    by 180 degrees), the stage started on a view upside down at the person. Before issue 19 the
    view stays upside down on every frame; now it is upright from the first frame and the
    person's hips are where BlazePose puts them on the original pinhole frames."""
    from ergopose.evaluation import refisheye as R

    root = shared_data / "pose2sim-demo"
    real = R.load_cameras(root)[1]
    frames = R.read_frames(root, 2, 5)
    pixels, _ = R.reference_pose(frames[0], detector, landmarker)
    rays = R._unit(real.lens.unproject(pixels))
    hip = R._unit(rays[R.HIPS].mean(0))
    torso = float(R._angle(R._unit(rays[R.SHOULDERS].mean(0)), hip))
    vf = R.virtual_fisheye(real, hip, np.radians(75.0), np.pi, 250.0)
    view_map = R.build_map(
        vf.camera.lens, (vf.camera.width, vf.camera.height), real.lens, vf.rotation_real_from_virtual
    )
    hip_v = hip @ vf.rotation_real_from_virtual
    assert np.isclose(np.degrees(np.arccos(hip_v[2])), 75.0)
    rolls = {}
    for name, settings in (("before", BEFORE), ("after", PoseSettings())):
        stage = FisheyePoseEstimator(vf.camera, 0, landmarker, None, settings)
        down = view_rotation(vf.camera, hip_v) @ np.array([0.0, 1.0, 0.0])
        stage._targets = [Target(hip_v, np.radians(25.0), SOURCE_REFOCUS, up_cam=down)]
        rolls[name] = []
        for f, frame in enumerate(frames):
            found = stage.process(view_map.apply(frame), f)
            assert found.count == 1, (name, f)
            (nxt,) = stage._targets
            rolls[name].append(np.degrees(abs(roll_from_upright(vf.camera, nxt.direction_cam, nxt.up_cam))))
            if name == "after" and f == 0:
                hips = R._unit(found.rays_cam[0, R.HIPS].mean(0))
                assert R._angle(hips, hip_v) < 0.5 * torso
    assert min(rolls["before"]) > 120.0, rolls
    assert max(rolls["after"]) <= np.degrees(PoseSettings().max_body_roll) + 1e-6, rolls


def _rerendered_cam_02(shared_data):
    """cam_02 of the Pose2Sim recording re-rendered into a virtual fisheye (the person 45 degrees
    off the lens axis, 250 px/rad): the virtual camera, the view map, the 100 real frames and
    their OpenPose reference."""
    from ergopose.evaluation import refisheye as R

    root = shared_data / "pose2sim-demo"
    real = R.load_cameras(root)[1]
    frames = R.read_frames(root, 2, 100)
    ref = R.openpose_reference(root, 2, len(frames), real)
    ok = (ref["conf"][:, R.HIPS] > 0).all(axis=1)
    hip = R._unit(np.nanmedian(R._unit(ref["rays"][ok][:, R.HIPS].mean(axis=1)), axis=0))
    vf = R.virtual_fisheye(real, hip, np.radians(45.0), 0.0, 250.0)
    view_map = R.build_map(
        vf.camera.lens, (vf.camera.width, vf.camera.height), real.lens, vf.rotation_real_from_virtual
    )
    return vf, view_map, frames, ref, ok


def _crossed_of_confident(stage, rerendered) -> tuple[int, int, int]:
    """Run the stage over the re-rendered frames; (confident frames with left and right crossed
    against OpenPose, confident frames, frames counted). Every counted frame must be found."""
    from ergopose.evaluation import refisheye as R

    vf, view_map, frames, ref, ok = rerendered
    scores = []
    for f, image in enumerate(frames):
        found = stage.process(view_map.apply(image), f)
        if ok[f]:
            scores.append(R.score_frame(ref["rays"][f] @ vf.rotation_real_from_virtual, ref["conf"][f], found))
    assert all(s["found"] for s in scores)
    judged = [s["swapped"] for s in scores if s["swapped"] is not None]
    return sum(judged), len(judged), len(scores)


@pytest.mark.slow
def test_on_real_frames_a_second_upright_view_puts_the_sides_right(shared_data, fetched_model_dir):
    """Real people: cam_02 of the Pose2Sim recording re-rendered into a virtual fisheye (the
    person 45 degrees off the lens axis, 250 px/rad), through the 2D stage as `ergopose pose`
    runs it, with and without its second, upright view (``left_right_upright_check``). Against
    the recording's OpenPose keypoints, the frames passed on as confident with left and right
    crossed: a fifth without the check (the network reads the sides wrongly from views turned
    to the body axis), a few with it (the frames where the upright view disagrees are doubted
    instead), and more frames confident; the check ran where views were turned."""
    from ergopose.commands.pose import stage_settings
    from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker

    model_dir = fetched_model_dir[0]
    rerendered = _rerendered_cam_02(shared_data)
    landmarker = BlazePoseLandmarker(model_dir=model_dir)
    detector = BlazePoseDetector(model_dir=model_dir)
    command = stage_settings(landmarker.card.gates, 60.0, 8)
    assert command.left_right_upright_check is not None
    crossed, confident, checks = {}, {}, {}
    for name, settings in (("without", dataclasses.replace(command, left_right_upright_check=None)), ("with", command)):
        stage = FisheyePoseEstimator(rerendered[0].camera, 0, landmarker, detector, settings)
        crossed[name], confident[name], _ = _crossed_of_confident(stage, rerendered)
        checks[name] = (stage.upright_checks, stage.upright_disputed)
    assert checks["without"] == (0, 0) and checks["with"][1] > 0, checks
    # Measured: 6 of 28 confident frames crossed without the check, 2 of 41 with it (the other
    # frames are withheld: their sides doubted, their confidence lowered); 78 views checked, 28
    # of them disputed.
    assert crossed["without"] >= 0.15 * confident["without"], (crossed, confident)
    assert crossed["with"] <= 0.1 * confident["with"], (crossed, confident)
    assert confident["with"] >= confident["without"] + 10, (crossed, confident)


@pytest.mark.slow
def test_on_real_frames_the_pose_commands_model_keeps_the_sides(shared_data, fetched_model_dir):
    """The same re-rendered frames (cam_02, 45 degrees off the lens axis, 250 px/rad) through the
    2D stage as `ergopose pose` runs it by default: the heavy landmark model
    (``POSE_COMMAND_MODEL``) with its own gates. It reads the person's sides where full crosses
    them, so nearly every frame is passed on as confident and almost none is crossed. Measured:
    0 of 98 confident frames crossed (full, in the test above: 2 of 41)."""
    from ergopose.commands.pose import stage_settings
    from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker
    from ergopose.pose.models import POSE_COMMAND_MODEL

    model_dir = fetched_model_dir[0]
    rerendered = _rerendered_cam_02(shared_data)
    landmarker = BlazePoseLandmarker(model=POSE_COMMAND_MODEL, model_dir=model_dir)
    assert landmarker.card.name == "blazepose_landmark_heavy"
    stage = FisheyePoseEstimator(
        rerendered[0].camera,
        0,
        landmarker,
        BlazePoseDetector(model_dir=model_dir),
        stage_settings(landmarker.card.gates, 60.0, 8),
    )
    crossed, confident, counted = _crossed_of_confident(stage, rerendered)
    assert confident >= 0.9 * counted, (crossed, confident, counted)
    assert crossed <= 0.02 * confident, (crossed, confident)
