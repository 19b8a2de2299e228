"""The person-size check before 3D: people are person-sized where they stand, skeletons squeezed
into the visible part of a person are not (synthetic rig and the real Pose2Sim recording)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ergopose.evaluation.keypoint_reference import read_openpose_folder
from ergopose.evaluation.markers import BODY_25B, joint_of_marker
from ergopose.geometry.calibration_file import read_any_calibration
from ergopose.geometry.camera import ceiling_camera
from ergopose.geometry.lenses.equidistant import Equidistant
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS
from ergopose.recon.person_scale import keep_person_sized, person_scale
from ergopose.recon.settings import ReconSettings
from ergopose.recon.triangulate import reconstruct_frames
from ergopose.records import Detections2D, detections_from_fisheye
from ergopose.sim.synthetic import walk_workers
from tests.recon.conftest import FPS, shift_scripts

SHOULDERS = [JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]]
TORSO_25B = [BODY_25B.index(m) for m in ("LShoulder", "RShoulder", "LHip", "RHip")]


def _detections(camera, frame: int, points_world: np.ndarray) -> Detections2D:
    px = camera.project_world(points_world)
    return detections_from_fisheye(camera, frame, frame / FPS, px, np.ones(px.shape[:2]))


def _squeezed(points_world: np.ndarray, factor: float) -> np.ndarray:
    """Every joint pulled towards the mid-shoulder point: a whole skeleton in the upper body's room."""
    centre = points_world[:, SHOULDERS].mean(axis=1, keepdims=True)
    return centre + factor * (points_world - centre)


@pytest.fixture(scope="module")
def shift():
    return walk_workers(shift_scripts(), 240, FPS)


def test_standing_and_working_people_are_person_sized(cameras, shift):
    """Four workers 1.62-1.93 m tall walking and working (trunk bent up to 45 deg, arms raised)
    under the rig's two ceiling cameras: every detection spans at least 0.75 of a standing
    1.70 m person there, none is left out."""
    scales = []
    for f in range(0, len(shift), 3):
        for cam in cameras:
            det = _detections(cam, f, shift[f])
            scales.append(person_scale(det))
            assert keep_person_sized(det, ReconSettings().min_person_scale).count == det.count
    s = np.concatenate(scales)
    assert len(s) == 80 * 2 * 4 and np.isfinite(s).all()
    assert s.min() >= 0.75 and 0.95 <= np.median(s) <= 1.2, (s.min(), np.median(s))


def test_a_crouching_person_is_kept(cameras, shift):
    """The same people at 0.6 of their height (hips at 0.55 m: a deep squat or kneeling) span less
    (half a standing person in at least 98 % of the camera-frames) and are always kept."""
    s = np.concatenate(
        [person_scale(_detections(cam, f, shift[f] * [1.0, 1.0, 0.6])) for f in range(0, 240, 3) for cam in cameras]
    )
    assert np.mean(s >= 0.5) >= 0.98 and s.min() >= 0.45 > ReconSettings().min_person_scale, (
        np.mean(s >= 0.5),
        s.min(),
    )


def test_a_squeezed_skeleton_is_left_out(cameras, shift):
    """A whole skeleton squeezed to 0.2 of its size around the shoulders (what a network returns for
    a worker whose legs a shelf hides) spans less than ``min_person_scale`` (0.4) of a person
    wherever it is seen from the side, and is left out; with the check off it stays."""
    out = kept = 0
    for f in range(0, 240, 3):
        for cam in cameras:
            det = _detections(cam, f, _squeezed(shift[f], 0.2))
            s = person_scale(det)
            # Seen from straight above even a whole person spans little: no verdict there.
            side = cam.theta_of_points_world(shift[f][:, SHOULDERS].mean(axis=1)) > np.radians(30.0)
            out += int((s[side] < ReconSettings().min_person_scale).sum())
            kept += int(side.sum())
            assert keep_person_sized(det, ReconSettings().min_person_scale).count == det.count - int((s < 0.4).sum())
            assert keep_person_sized(det, 0.0).count == det.count
    assert kept >= 300 and out >= 0.98 * kept, (out, kept)


def test_no_verdict_without_hips_or_from_below_the_hips():
    lens = Equidistant(fx=320.0, fy=320.0, cx=511.5, cy=511.5)
    cam = ceiling_camera("low", lens, 1024, 1024, (0.0, 0.0, 0.8))  # below standing hip height
    person = walk_workers(shift_scripts()[:1], 1, FPS)[0]
    person[:, :, :2] += [2.0, 0.5]
    det = _detections(cam, 0, _squeezed(person, 0.3))
    assert np.isinf(person_scale(det)).all()
    cam = ceiling_camera("high", lens, 1024, 1024, (0.0, 0.0, 3.0))
    det = _detections(cam, 0, person)
    conf = det.confidence.copy()
    conf[:, [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]] = 0.0
    no_hips = dataclasses.replace(det, confidence=conf, rays_world=None)
    assert np.isinf(person_scale(no_hips)).all() and np.isfinite(person_scale(det)).all()
    empty = Detections2D.empty("high", 0, 0.0)
    assert person_scale(empty).shape == (0,) and keep_person_sized(empty, 0.5).count == 0


def test_reconstruction_leaves_a_squeezed_detection_out(cameras, shift):
    """A squeezed skeleton next to the four workers in the first camera: left out, the rows are
    those of the four; with ``min_person_scale = 0`` it becomes a row of its own."""
    f = 120
    ghost = _squeezed(shift[f][:1], 0.2)
    ghost[..., :2] += [0.0, 1.2]
    frames = []
    for cam in cameras:
        real = _detections(cam, f, shift[f])
        extra = _detections(cam, f, ghost)
        both = Detections2D(
            cam.name,
            f,
            f / FPS,
            np.concatenate([real.pixels_view, extra.pixels_view]),
            np.concatenate([real.confidence, extra.confidence]),
            np.concatenate([real.projection, extra.projection]),
        )
        frames.append(both if cam is cameras[0] else real)
    assert person_scale(frames[0])[-1] < ReconSettings().min_person_scale
    on = reconstruct_frames([frames], ReconSettings())
    off = reconstruct_frames([frames], dataclasses.replace(ReconSettings(), min_person_scale=0.0))
    assert len(on) == 4 and (on.n_cameras == 2).all()
    assert len(off) == 5


@pytest.mark.slow
def test_the_real_person_is_person_sized(shared_data):
    """The Pose2Sim recording's person, as OpenPose placed them in each of the four cameras (100
    frames each, through the calibration, floor at z = 0): 0.7-1.2 of a standing person in every
    frame with both hips placed; the same keypoints squeezed to 0.2 around the shoulders fall below
    ``min_person_scale`` (0.4)."""
    demo = shared_data / "pose2sim-demo"
    cams, _ = read_any_calibration(demo / "Calib_qualisys.toml")
    to_ours = [(k, JOINT_INDEX[j]) for k, m in enumerate(BODY_25B) if (j := joint_of_marker(m)) in JOINT_INDEX]
    src, dst = np.array([k for k, _ in to_ours]), np.array([j for _, j in to_ours])
    for n, cam in enumerate(cams, start=1):
        _, kp = read_openpose_folder(demo / "pose-associated" / f"cam{n:02d}_json")
        found = kp[:, TORSO_25B, 2].min(axis=1) > 0  # no verdict without the hips
        px = np.full((len(kp), NUM_JOINTS, 2), np.nan)
        conf = np.zeros((len(kp), NUM_JOINTS))
        px[:, dst], conf[:, dst] = kp[:, src, :2], kp[:, src, 2]
        centre = px[:, SHOULDERS].mean(axis=1, keepdims=True)
        for f in np.flatnonzero(found):
            whole = person_scale(detections_from_fisheye(cam, int(f), f / 60.0, px[f : f + 1], conf[f : f + 1]))
            small = centre[f] + 0.2 * (px[f] - centre[f])
            squeezed = person_scale(detections_from_fisheye(cam, int(f), f / 60.0, small[None], conf[f : f + 1]))
            assert 0.7 <= whole[0] <= 1.2 and squeezed[0] < 0.4, (cam.name, int(f), whole, squeezed)
        assert found.sum() >= 95, (cam.name, int(found.sum()))
