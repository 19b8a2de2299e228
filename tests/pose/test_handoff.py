"""Cues from the other cameras (ergopose/pose/handoff.py): a person one camera found, placed on
the floor from that camera alone and looked for in another.

Known answers: rays cast from a ceiling camera to a standing body whose floor point is known (the
feet, then the hips only, then a crouch whose hips are lower than the rule assumes, where the error
is the geometry's: the height's error times the tangent of the ray's angle from vertical); the
direction and size of the view in the second camera against the same body projected there; and
the fisheye 2D stage with the real BlazePose network, which finds a person it has no cue of its
own for only where another camera says.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_fisheye import LENS, SIZE, fisheye_with_person

from ergopose.geometry.camera import Camera, ceiling_camera, look_at_rotation
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS
from ergopose.pose import handoff
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.pose.records import SOURCE_OTHER_CAMERA, SOURCE_REFOCUS, FrameDetections
from ergopose.pose.settings import PoseSettings

CAM_A = ceiling_camera("cam_a", LENS, SIZE, SIZE, position_world=(-1.5, 0.0, 3.0))
CAM_B = ceiling_camera("cam_b", LENS, SIZE, SIZE, position_world=(1.5, 0.5, 3.2))
FEET = ("left_ankle", "right_ankle", "left_heel", "right_heel")


def _body_world(floor_xy, hip_height=handoff.HIP_HEIGHT_M, foot_height=handoff.FOOT_HEIGHT_M) -> np.ndarray:
    """(33, 3) a body standing on floor_xy: feet at foot_height, hips at hip_height, shoulders
    0.5 m above the hips, the rest at the hips (only the feet and hips matter here)."""
    x, y = floor_xy
    points = np.tile([x, y, hip_height], (NUM_JOINTS, 1)).astype(float)
    for k, name in enumerate(FEET):
        points[JOINT_INDEX[name]] = (x + (-0.1 if k % 2 == 0 else 0.1), y, foot_height)
    for side, dx in (("left", -0.12), ("right", 0.12)):
        points[JOINT_INDEX[f"{side}_hip"]] = (x + dx, y, hip_height)
        points[JOINT_INDEX[f"{side}_shoulder"]] = (x + 1.5 * dx, y, hip_height + 0.5)
    return points


def _found(camera: Camera, bodies_world: list[np.ndarray], confidence: list[np.ndarray]) -> FrameDetections:
    """The record a camera's 2D stage would give for these bodies (rays exact)."""
    n = len(bodies_world)
    rays = np.stack([camera.points_world_to_cam(b) for b in bodies_world]) if n else np.zeros((0, NUM_JOINTS, 3))
    rays = rays / np.linalg.norm(rays, axis=-1, keepdims=True) if n else rays
    nan2 = np.full((n, NUM_JOINTS, 2), np.nan)
    return FrameDetections(
        camera_index=0,
        frame_index=0,
        pixels_view=nan2,
        pixels_fisheye=camera.lens.project(rays) if n else nan2,
        rays_cam=rays,
        confidence=np.stack(confidence) if n else np.zeros((0, NUM_JOINTS)),
        presence=np.ones(n),
        projection=np.zeros((n, 3, 4)),
        view_direction_cam=np.zeros((n, 3)),
        view_half_fov=np.zeros(n),
        source=np.zeros(n, np.int64),
    )


def _confidence(names=None, value=0.9) -> np.ndarray:
    conf = np.full(NUM_JOINTS, 0.05)
    for name in names or ():
        conf[JOINT_INDEX[name]] = value
    return conf


HIPS = ("left_hip", "right_hip")


def test_a_person_is_placed_on_the_floor_by_the_feet_then_by_the_hips():
    floors = [(1.2, -0.8), (-2.5, 1.9), (-1.4, 0.1)]  # the last under camera A
    bodies = [_body_world(f) for f in floors]
    # The feet seen: the floor point is where the body stands (exact rays: to the micrometre).
    got = handoff.floor_points_world(_found(CAM_A, bodies, [_confidence(FEET + HIPS)] * 3), CAM_A, 0.3)
    assert np.allclose(got, [(x, y, 0.0) for x, y in floors], atol=1e-6)
    # Only the hips seen: the same point from the hips' height.
    got = handoff.floor_points_world(_found(CAM_A, bodies, [_confidence(HIPS)] * 3), CAM_A, 0.3)
    assert np.allclose(got, [(x, y, 0.0) for x, y in floors], atol=1e-6)
    # One ankle is enough; an ankle below the gate is not used.
    one = _confidence(("left_ankle",))
    got = handoff.floor_points_world(_found(CAM_A, bodies[:1], [one]), CAM_A, 0.3)
    left_ankle = bodies[0][JOINT_INDEX["left_ankle"]]
    assert np.allclose(got[0], (left_ankle[0], left_ankle[1], 0.0), atol=1e-6)
    assert np.isnan(handoff.floor_points_world(_found(CAM_A, bodies[:1], [one]), CAM_A, 0.95)).all()
    # Nothing seen: no floor point; nobody found: no rows.
    assert np.isnan(handoff.floor_points_world(_found(CAM_A, bodies, [_confidence()] * 3), CAM_A, 0.3)).all()
    assert handoff.floor_points_world(_found(CAM_A, [], []), CAM_A, 0.3).shape == (0, 3)


def test_a_crouch_moves_the_point_along_the_line_of_sight_by_the_height_error():
    floor = np.array([0.8, 1.1])  # 2.3 m from camera A horizontally: 43 deg from its axis at the hips
    crouch = _body_world(floor, hip_height=0.55)
    got = handoff.floor_points_world(_found(CAM_A, [crouch], [_confidence(HIPS)]), CAM_A, 0.3)[0]
    hips_world = crouch[[JOINT_INDEX[h] for h in HIPS]].mean(axis=0)
    away = hips_world[:2] - CAM_A.position_world[:2]
    tan_theta = np.linalg.norm(away) / (CAM_A.position_world[2] - hips_world[2])
    expected_shift = (handoff.HIP_HEIGHT_M - 0.55) * tan_theta  # towards the camera
    assert np.linalg.norm(got[:2] - floor) == pytest.approx(expected_shift, rel=1e-6)
    assert np.dot(got[:2] - floor, away) < 0  # a lower body than assumed is placed nearer the camera


def test_a_floor_point_becomes_a_view_aimed_at_the_standing_body_in_the_other_camera():
    floors = np.array([[1.2, -0.8, 0.0], [-2.5, 1.9, 0.0], [1.4, 0.6, 0.0]])  # the last under camera B
    directions, radii = handoff.cues_in_camera(CAM_B, floors)
    middle = CAM_B.points_world_to_cam(floors + [0.0, 0.0, handoff.BODY_HEIGHT_M / 2])
    assert np.allclose(directions, middle / np.linalg.norm(middle, axis=1, keepdims=True), atol=1e-12)
    # The radius reaches the head, the feet and the sides of the column, and no farther.
    for floor, d, r in zip(floors, directions, radii):
        ends = CAM_B.points_world_to_cam(floor + np.array([[0, 0, 0], [0, 0, handoff.BODY_HEIGHT_M]]))
        ends /= np.linalg.norm(ends, axis=1, keepdims=True)
        angles = np.arccos(np.clip(ends @ d, -1, 1))
        assert r >= angles.max() - 1e-12
        assert r < np.radians(60)
    # Seen from straight above the column is its width: a smaller view than seen from the side.
    assert radii[2] < radii[0]


def test_a_place_the_camera_cannot_see_gives_no_view():
    # A pinhole camera on a wall looking along +x sees nothing behind it.
    rotation = look_at_rotation((1.0, 0.0, -0.3))
    wall = Camera("wall", Rectilinear(fx=500.0, fy=500.0, cx=319.5, cy=239.5), 640, 480, rotation, (-3.0, 0.0, 2.5))
    directions, radii = handoff.cues_in_camera(wall, np.array([[0.0, 0.0, 0.0], [-5.0, 0.0, 0.0], [np.nan] * 3]))
    assert np.isfinite(directions[0]).all() and np.isfinite(radii[0])
    assert np.isnan(directions[1:]).all() and np.isnan(radii[1:]).all()


class _Listener:
    wants_cues = True

    def __init__(self):
        self.cues = None

    def take_cues(self, directions_cam, radii):
        self.cues = (directions_cam, radii)


def test_each_camera_is_told_where_the_others_found_people():
    body = _body_world((0.4, -1.0))
    stages = [_Listener(), _Listener(), _Listener()]
    cam_c = ceiling_camera("cam_c", LENS, SIZE, SIZE, position_world=(0.0, 2.0, 3.0))
    cameras = [CAM_A, CAM_B, cam_c]
    found = [
        _found(CAM_A, [body], [_confidence(FEET)]),
        _found(CAM_B, [], []),
        _found(cam_c, [body], [_confidence(FEET)]),
    ]
    handoff.pass_cues(stages, found, cameras, 0.3)
    for stage, camera, expected in zip(stages, cameras, (1, 2, 1)):
        directions, radii = stage.cues
        assert len(directions) == len(radii) == expected  # one per person each other camera found
        middle = camera.points_world_to_cam((0.4, -1.0, handoff.BODY_HEIGHT_M / 2))
        assert np.allclose(directions, middle / np.linalg.norm(middle), atol=1e-6)
    # A session of one camera passes nothing.
    lone = _Listener()
    handoff.pass_cues([lone], found[:1], cameras[:1], 0.3)
    assert lone.cues is None


@pytest.mark.slow
def test_the_stage_finds_a_person_only_where_another_camera_says(landmarker):
    """The real network, no detector and the motion cues not yet warmed up: the stage has no cue
    of its own on the first frames, so it finds the drawn person only when another camera passes
    their place on (and follows them after), on the frames of its schedule, never with
    ``other_camera_every = 0``, and not from a place where nobody is."""
    camera = ceiling_camera("cam_1", LENS, SIZE, SIZE, position_world=(0.0, 0.0, 3.0))
    target = np.array([1.2, 0.8, 1.0])
    frame, _ = fisheye_with_person(camera, target)
    toward = camera.points_world_to_cam(target)
    toward /= np.linalg.norm(toward)
    radius = np.array([np.radians(16.0)])
    every = PoseSettings().other_camera_every
    assert every == 2  # the default (docs/pose-in-fisheye.md, "Cues from the other cameras")

    stage = FisheyePoseEstimator(camera, 0, landmarker, None)
    assert stage.process(frame, 0).count == 0  # nothing to look at
    stage.take_cues(toward[None], radius)
    assert stage.process(frame, 1).count == 0 and stage.landmark_runs == 0  # not a frame of the schedule
    stage.take_cues(toward[None], radius)
    found = stage.process(frame, 2)
    assert found.count == 1 and found.source[0] == SOURCE_OTHER_CAMERA and stage.landmark_runs == 1
    assert stage.process(frame, 3).source.tolist() == [SOURCE_REFOCUS]  # followed from then on
    runs = stage.landmark_runs
    stage.take_cues(toward[None], radius)  # a place a view already holds: no second view
    assert stage.process(frame, 4).count == 1 and stage.landmark_runs == runs + 1

    each = dataclasses.replace(PoseSettings(), other_camera_every=1)
    stage = FisheyePoseEstimator(camera, 0, landmarker, None, each)
    stage.take_cues(toward[None], radius)
    assert stage.process(frame, 0).source.tolist() == [SOURCE_OTHER_CAMERA]

    off = FisheyePoseEstimator(camera, 0, landmarker, None, dataclasses.replace(PoseSettings(), other_camera_every=0))
    off.take_cues(toward[None], radius)
    assert off.process(frame, 0).count == 0 and off.landmark_runs == 0

    elsewhere = camera.points_world_to_cam((-1.5, -1.5, 1.0))
    empty = FisheyePoseEstimator(camera, 0, landmarker, None)
    empty.take_cues((elsewhere / np.linalg.norm(elsewhere))[None], radius)
    assert empty.process(frame, 0).count == 0 and empty.landmark_runs == 1
