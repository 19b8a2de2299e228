"""Association and triangulation with 1 to 4 cameras (the rig's two plus two more ceiling
fisheyes looking down from the other sides), against the synthetic truth, the simulator's
ORACLE and the real 4-camera Pose2Sim recording."""

from __future__ import annotations

import json
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS
from ergopose.recon.associate import associate, associate_views
from ergopose.records import Detections2D, detections_from_fisheye
from ergopose.recon.settings import ReconSettings
from ergopose.sim.synthetic import extra_ceiling_cameras, observe, walk_workers
from ergopose.recon.triangulate import reconstruct_frames
from tests.recon.conftest import FPS, crossing_scripts


@pytest.fixture(scope="module")
def four_cameras(cameras):
    return tuple(cameras) + extra_ceiling_cameras()


@pytest.fixture(scope="module")
def crossing4(four_cameras, crossing):
    frames, order = observe(four_cameras, crossing.truth, noise_px=2.0, dropout=0.02, seed=11, fps=FPS)
    return frames, order


def _workers(people, order):
    """(M, C) ground-truth person of each row's detection in each camera (-1: not in the row)."""
    f0 = people.frame - people.frame.min()
    w = np.full(people.detection.shape, -1)
    for r in range(len(people)):
        for c in np.flatnonzero(people.detection[r] >= 0):
            w[r, c] = order[f0[r]][c][people.detection[r, c]]
    return w


def _select(frames, order, cams):
    return [tuple(f[c] for c in cams) for f in frames], [[o[c] for c in cams] for o in order]


def test_two_cameras_give_the_pairs_of_associate(crossing):
    for a, b in crossing.frames:
        res, old = associate_views((a, b)), associate(a, b)
        np.testing.assert_array_equal(res.groups, old.pairs)
        np.testing.assert_array_equal(res.cost_m, old.cost_m)
        expect = [(0, i) for i in old.single_a] + [(1, j) for j in old.single_b]
        np.testing.assert_array_equal(res.singles, np.array(expect, np.int64).reshape(-1, 2))


@pytest.mark.slow
@pytest.mark.parametrize("cams", [(0, 1, 2), (1, 2, 3), (0, 1, 2, 3)])
def test_crossing_paths_every_set_right(crossing4, crossing, cams):
    frames, order = _select(*crossing4, cams)
    people = reconstruct_frames(frames)
    w = _workers(people, order)
    multi = people.n_cameras >= 2
    assert np.all(people.n_cameras == (w >= 0).sum(axis=1))
    # Every set is one person, and every person seen by every camera is one set of all of them.
    for r in np.flatnonzero(multi):
        assert len(set(w[r][w[r] >= 0])) == 1
    n_full = 0
    for f in range(len(frames)):
        rows = np.flatnonzero(people.frame == f)
        for p in range(len(crossing.statures)):
            seen_by = [c for c in range(len(cams)) if p in order[f][c]]
            mine = [r for r in rows if p in w[r]]
            assert len(mine) == 1  # never split
            assert (w[mine[0]] >= 0).sum() == len(seen_by)
            n_full += len(seen_by) == len(cams)
    assert n_full == len(frames) * 4  # everyone is in view of every camera here


def test_person_seen_by_one_camera_is_a_single_row(four_cameras, crossing):
    truth = crossing.truth[:24]
    vis = np.ones((24, 4, 4), bool)
    vis[:, [0, 2, 3], 1] = False  # person 1 seen by camera 2 only
    vis[:, 3, 2] = False  # person 2 by cameras 1-3
    frames, order = observe(four_cameras, truth, noise_px=1.0, dropout=0.0, visible=vis, seed=3, fps=FPS)
    people = reconstruct_frames(frames)
    w = _workers(people, order)
    single = people.n_cameras == 1
    assert single.sum() == 24 and np.all(w[single, 1] == 1) and np.all(people.detection[single][:, [0, 2, 3]] == -1)
    assert np.all(np.isnan(people.points_world[single]))
    assert np.allclose(people.ray_origin_world[single], four_cameras[1].position_world, atol=1e-9)
    three = people.n_cameras == 3
    assert three.sum() == 24 and np.all(w[three][:, :3] == 2) and np.all(w[three, 3] == -1)
    four = people.n_cameras == 4
    assert four.sum() == 48 and np.all(np.isin(w[four], [0, 3]))
    # Every camera of a set has its observation stored for the body fit; the others none.
    for r in range(len(people)):
        for c in range(4):
            d = people.detection[r, c]
            if d >= 0:
                det = frames[people.frame[r]][c]
                np.testing.assert_array_equal(people.obs_projection[r, c], det.projection[d])
                np.testing.assert_array_equal(people.obs_confidence[r, c], det.confidence[d])
            else:
                assert not people.obs_projection[r, c].any() and not people.obs_confidence[r, c].any()
    assert people.rejected.shape == (len(people), 4, NUM_JOINTS)


def test_one_camera_every_detection_is_single(crossing4):
    frames, order = _select(*crossing4, (2,))
    people = reconstruct_frames(frames)
    assert len(people) == sum(len(o[0]) for o in order)
    assert np.all(people.n_cameras == 1) and people.detection.shape == (len(people), 1)
    assert np.all(np.isnan(people.points_world)) and np.isfinite(people.ray_world).all()


@pytest.mark.slow
def test_more_cameras_smaller_3d_error(crossing4, crossing):
    """The same people and joints, triangulated from 2, 3 and 4 cameras."""
    errors = {}
    for cams in ((0, 1), (0, 1, 2), (0, 1, 2, 3)):
        frames, order = _select(*crossing4, cams)
        people = reconstruct_frames(frames)
        w = _workers(people, order)
        e = np.full((len(frames), 4, NUM_JOINTS), np.nan)
        for r in np.flatnonzero(people.n_cameras >= 2):
            p = w[r][w[r] >= 0][0]
            e[people.frame[r], p] = np.linalg.norm(people.points_world[r] - crossing.truth[people.frame[r], p], axis=-1)
        errors[len(cams)] = e
    both = np.isfinite(errors[2]) & np.isfinite(errors[4])
    assert both.sum() > 0.9 * np.isfinite(errors[2]).sum()
    mean = {k: np.mean(e[both]) for k, e in errors.items()}
    # Measured: 28.2, 18.3, 13.3 mm on 9,132 joints (2 px noise, 2 % dropouts).
    assert mean[4] < mean[3] < mean[2]
    assert mean[4] < 0.75 * mean[2]
    assert np.isfinite(errors[4]).sum() >= np.isfinite(errors[2]).sum()


@pytest.mark.slow
def test_tracking_and_body_fit_with_four_cameras(crossing4, crossing, four_cameras):
    """The rest of the reconstruction takes sets of any size: same identities, smaller error."""
    from ergopose.recon import diagnostics as D
    from ergopose.recon.pipeline import ShiftReconstruction, TrackFrames

    errors = {}
    for cams in ((0, 1), (0, 1, 2, 3)):
        frames, _ = _select(*crossing4, cams)
        people = reconstruct_frames(frames)
        sr = ShiftReconstruction(ReconSettings(), FPS, [four_cameras[c] for c in cams])
        tf = TrackFrames.concat([sr.push(people, 0, len(frames)), sr.finish()])
        assert len(tf.workers) == 4 and D.identity_switches(tf, crossing.truth) == 0
        mapping = D.match_workers(tf, crossing.truth)
        errors[len(cams)] = D.region_errors(tf, D.truth_for_workers(tf, crossing.truth, mapping))["all"].mean_m
    assert errors[4] < 0.7 * errors[2]  # measured 19.0 -> 10.1 mm


def test_gross_error_in_one_of_three_views_drops_that_view(four_cameras):
    cams = four_cameras[:3]
    truth = walk_workers(crossing_scripts(), 1, FPS)[0]
    dets = []
    for cam in cams:
        px = cam.project_world(truth)
        dets.append(detections_from_fisheye(cam, 0, 0.0, px, np.ones(px.shape[:2])))
    b = dets[1]
    px = b.pixels_view.copy()
    px[:, JOINT_INDEX["left_elbow"]] += 40.0  # every left elbow in camera 2 is 57 px off
    dets[1] = Detections2D(b.camera, b.frame, b.time_s, px, b.confidence, b.projection)
    people = reconstruct_frames([tuple(dets)], ReconSettings(reprojection_threshold_px=5.0))
    assert len(people) == 4 and np.all(people.n_cameras == 3)
    j = JOINT_INDEX["left_elbow"]
    # One observation of the joint dropped per person, the joint kept from the other two.
    assert people.rejected.sum() == 4 and people.rejected[:, :, j].sum() == 4 and np.all(people.views[:, j] == 2)
    assert np.all(people.reprojection_error_px[:, j] <= 5.0) and np.all(people.views[:, :j] == 3)
    # Mostly the wrong one: then the point from the two good views is exact. reject_outliers
    # drops the view with the largest residual, which for one of the four people (its worst
    # residual, 28 px, is a good view's) is not the bad one -- greedy, as documented there.
    right = people.rejected[:, 1, j]
    assert right.sum() == 3
    for r in np.flatnonzero(right):
        assert np.min(np.linalg.norm(truth[:, j] - people.points_world[r, j], axis=-1)) < 1e-6


@pytest.mark.slow
def test_oracle_four_cameras():
    """ORACLE 2D (2 px noise, dropouts, furniture and body occlusion by ray casts), 4 workers,
    20 s, with the simulator's two-camera rig plus two more ceiling cameras."""
    from ergopose.sim.synthetic import PAPER_SIZE, frames_from_oracle, simulated_ground_truth
    from ergopose.sim.oracle import OracleSource
    from ergopose.sim.scene import rig_cameras

    cams = tuple(rig_cameras(*PAPER_SIZE)) + extra_ceiling_cameras()
    gt, cams = simulated_ground_truth(4, 20.0, seed=3, cameras=cams)
    obs = OracleSource(gt, noise_px=2.0, seed=1).observe()
    frames, order = frames_from_oracle(obs, cams)
    errors, timing = {}, {}
    for sel in ((0, 1), (0, 1, 2, 3)):
        fr, od = _select(frames, order, sel)
        t0 = time.process_time()
        people = reconstruct_frames(fr)
        timing[len(sel)] = (time.process_time() - t0) / len(fr)
        w = _workers(people, od)
        sets = np.flatnonzero(people.n_cameras >= 2)
        assert all(len(set(w[r][w[r] >= 0])) == 1 for r in sets)  # no set mixes workers
        keys = [(people.frame[r], w[r][w[r] >= 0][0]) for r in sets]
        assert len(set(keys)) == len(keys)  # no worker split over two sets
        # Detections of workers seen by two or more cameras that were left out of the worker's
        # set (measured: 2 of 1,860 with the rig's 2 cameras -- torsos hidden, too few joints
        # to pair -- and 0 of 3,775 with 4).
        seen = np.zeros((len(fr), 4), np.int64)
        for f, o in enumerate(od):
            for c in range(len(sel)):
                seen[f, o[c]] += 1
        n_det = seen[seen >= 2].sum()
        left_out = n_det - (w[sets] >= 0).sum()
        assert left_out <= 2
        e = np.full((len(fr), 4, NUM_JOINTS), np.nan)
        for r in sets:
            p = w[r][w[r] >= 0][0]
            e[people.frame[r], p] = np.linalg.norm(
                people.points_world[r] - gt.joints_world[people.frame[r], p], axis=-1
            )
        errors[len(sel)] = e
    both = np.isfinite(errors[2]) & np.isfinite(errors[4])
    m2, m4 = np.mean(errors[2][both]), np.mean(errors[4][both])
    # Measured: 27.9 -> 15.8 mm on the same 9,594 joints; 9,594 -> 15,654 joints triangulated.
    assert m4 < 0.8 * m2
    assert np.isfinite(errors[4]).sum() > 1.4 * np.isfinite(errors[2]).sum()
    assert timing[4] < 0.025  # CPU seconds per frame (measured 4.6-4.8 ms)


# ---------------------------------------------------------------------------------------------
# Real people: the Pose2Sim demo (4 pinhole cameras, OpenPose BODY_25B, up to 2 people a camera)

#: BODY_25B index of each BlazePose joint it has (COCO order for 0-16, feet 19-24).
BODY25B = {
    "nose": 0,
    "left_eye": 1,
    "right_eye": 2,
    "left_ear": 3,
    "right_ear": 4,
    "left_shoulder": 5,
    "right_shoulder": 6,
    "left_elbow": 7,
    "right_elbow": 8,
    "left_wrist": 9,
    "right_wrist": 10,
    "left_hip": 11,
    "right_hip": 12,
    "left_knee": 13,
    "right_knee": 14,
    "left_ankle": 15,
    "right_ankle": 16,
    "left_foot_index": 19,
    "left_heel": 21,
    "right_foot_index": 22,
    "right_heel": 24,
}


def _pose2sim_people(path):
    people = json.loads(path.read_text())["people"]
    return [np.array(p["pose_keypoints_2d"]).reshape(25, 3) for p in people if p.get("pose_keypoints_2d")]


@pytest.fixture(scope="module")
def pose2sim_frames(shared_data):
    """Minimal loader for this test only (a Pose2Sim calibration importer is separate work):
    [cam_xx] matrix K, distortions (k1, k2, p1, p2), rotation (Rodrigues, world -> camera),
    translation (m). Keypoints are undistorted to ideal pinhole pixels of K, so that the view's
    projection is K [R | t]."""
    cv2 = pytest.importorskip("cv2")
    root = shared_data / "pose2sim-demo"
    calib = tomllib.loads((root / "Calib_qualisys.toml").read_text())
    names = [k for k in calib if k.startswith("cam_")]
    src = np.array(list(BODY25B.values()))
    dst = np.array([JOINT_INDEX[n] for n in BODY25B])
    frames, raw, chosen = [], [], []
    for f in range(100):
        dets, raws, picks = [], [], []
        for v, name in enumerate(names):
            c = calib[name]
            K, dist = np.array(c["matrix"]), np.array(c["distortions"])
            R, _ = cv2.Rodrigues(np.array(c["rotation"]))
            P = K @ np.hstack([R, np.array(c["translation"])[:, None]])
            kp = _pose2sim_people(root / "pose" / f"cam0{v + 1}_json" / f"cam0{v + 1}.{f:04d}.json")
            px = np.full((len(kp), NUM_JOINTS, 2), np.nan)
            conf = np.zeros((len(kp), NUM_JOINTS))
            for i, k in enumerate(kp):
                u = cv2.undistortPoints(k[src, :2].reshape(-1, 1, 2), K, dist, P=K).reshape(-1, 2)
                ok = k[src, 2] > 0
                px[i, dst] = np.where(ok[:, None], u, np.nan)
                conf[i, dst] = np.where(ok, k[src, 2], 0.0)
            dets.append(Detections2D(name, f, f / 60.0, px, conf, np.broadcast_to(P, (len(kp), 3, 4))))
            raws.append(kp)
            # The person Pose2Sim's own association kept in this camera (-1: none).
            kept = _pose2sim_people(root / "pose-associated" / f"cam0{v + 1}_json" / f"cam0{v + 1}.{f:04d}.json")
            picks.append(next((i for i, k in enumerate(kp) if kept and np.array_equal(k, kept[0])), -1))
        frames.append(tuple(dets))
        raw.append(raws)
        chosen.append(picks)
    return Pose2SimDemo(root, frames, raw, np.array(chosen))


@dataclass
class Pose2SimDemo:
    root: Path
    frames: list  # per frame, one Detections2D per camera
    raw: list  # per frame and camera, the BODY_25B keypoints (25, 3) of each person
    chosen: np.ndarray  # (100, 4) the person Pose2Sim's association kept (-1: none)


@pytest.mark.slow
def test_pose2sim_demo_association(pose2sim_frames):
    """100 frames, 4 cameras; cameras 1 and 2 also report a second, static detection that no
    other camera supports. Pose2Sim's association kept one person per camera."""
    demo = pose2sim_frames
    frames, raw, chosen = demo.frames, demo.raw, demo.chosen
    assert sum(d.count for fr in frames for d in fr) == 601
    people = reconstruct_frames(frames)
    sets = people.n_cameras >= 2
    assert sets.sum() == 100 and np.all(people.n_cameras[sets] == 4)
    assert np.array_equal(people.frame[sets], np.arange(100))
    det = people.detection[sets]
    kept = chosen >= 0
    assert kept.sum() == 399 and np.array_equal(det[kept], chosen[kept])
    # The one observation Pose2Sim left out (frame 52, camera 3) is the same person: its torso
    # keypoints are within a few pixels of frames 51 and 53.
    assert not kept[52, 2] and det[52, 2] == 0
    torso = [5, 6, 11, 12]
    for g in (51, 53):
        assert np.abs(raw[52][2][0][torso, :2] - raw[g][2][0][torso, :2]).max() < 16
    # The second detections (confidence 0.3-0.5) stay single-view at min_confidence 0.5.
    assert np.all(people.n_cameras[~sets] == 1) and (~sets).sum() == 201
    # 3D against Pose2Sim's own triangulation of the same keypoints (not ground truth; it
    # leaves out views over 15 px by trying every subset, we drop the worst view greedily).
    trc = _pose2sim_trc(demo.root)
    names = list(TRC_MARKERS.values())
    ours = people.points_world[sets][:, [JOINT_INDEX[n] for n in names]]
    diff_mm = 1000 * np.linalg.norm(ours - trc[:, [list(TRC_MARKERS).index(m) for m in TRC_MARKERS]], axis=-1)
    # Measured: 94.7 % of the 1,700 joint-frames, median 1.5 mm, p90 76 mm.
    assert np.isfinite(diff_mm).mean() > 0.93 and np.nanmedian(diff_mm) < 3.0

    # At Pose2Sim's own confidence threshold (0.3) the second detections of cameras 1 and 2 meet:
    # a bystander standing at the left edge of both images (seen on the videos), 3.3 m behind the
    # subject, a 2-camera set.
    low = reconstruct_frames(frames, ReconSettings(min_confidence=0.3))
    main = np.array([np.flatnonzero(low.frame == f)[np.argmax(low.n_cameras[low.frame == f])] for f in range(100)])
    assert np.all(low.n_cameras[main] == 4) and np.array_equal(low.detection[main][kept], chosen[kept])
    two = low.n_cameras == 2
    assert two.sum() >= 90 and np.all(low.detection[two][:, 2:] == -1)
    assert np.all(low.detection[two][:, :2] != low.detection[main][low.frame[two], :2])
    nose = np.nanmedian(low.points_world[two][:, 0], axis=0)
    ankles = np.nanmedian(
        low.points_world[two][:, [JOINT_INDEX["left_ankle"], JOINT_INDEX["right_ankle"]]], axis=(0, 1)
    )
    assert np.linalg.norm(nose[:2] - np.nanmedian(low.points_world[main, 0, :2], axis=0)) > 2.5
    # Nose 1.4 m above the ankles (standing), but the whole body about 0.2 m low (ankles at
    # -0.17 m): at the edge of both images, outside the calibrated volume.
    assert 1.2 < nose[2] - ankles[2] < 1.8 and -0.4 < ankles[2] < 0.1
    assert np.nanmedian(low.reprojection_error_px[two]) < 10
    diff_mm = 1000 * np.linalg.norm(low.points_world[main][:, [JOINT_INDEX[n] for n in names]] - trc, axis=-1)
    # Measured: 99.6 % of the joint-frames, median 0.7 mm.
    assert np.isfinite(diff_mm).mean() > 0.99 and np.nanmedian(diff_mm) < 2.0


#: Pose2Sim TRC marker -> BlazePose joint (the markers both skeletons have).
TRC_MARKERS = {
    "RHip": "right_hip",
    "RKnee": "right_knee",
    "RAnkle": "right_ankle",
    "RBigToe": "right_foot_index",
    "RHeel": "right_heel",
    "LHip": "left_hip",
    "LKnee": "left_knee",
    "LAnkle": "left_ankle",
    "LBigToe": "left_foot_index",
    "LHeel": "left_heel",
    "Nose": "nose",
    "RShoulder": "right_shoulder",
    "RElbow": "right_elbow",
    "RWrist": "right_wrist",
    "LShoulder": "left_shoulder",
    "LElbow": "left_elbow",
    "LWrist": "left_wrist",
}


def _pose2sim_trc(root):
    """(100, len(TRC_MARKERS), 3) Pose2Sim's triangulation in the calibration's world (the TRC's
    axes are world[:, [1, 2, 0]], Y up; SOURCE.md)."""
    lines = (root / "pose-3d" / "S00_P00_T01_BalancingTrial_0-100.trc").read_text().splitlines()
    names = [n for n in lines[3].split("\t")[2:] if n]
    values = np.array(
        [[float(x) for x in line.split("\t")[2 : 2 + 3 * len(names)]] for line in lines[5:] if line.strip()]
    )
    trc = values.reshape(len(values), len(names), 3)[..., [2, 0, 1]]
    return trc[:, [names.index(m) for m in TRC_MARKERS]]


def test_sides_agree_across_four_cameras(crossing4, crossing):
    """Nobody crossed: canonical_sides changes no detection (four people crossing, 2 px noise).
    One camera of four crossed some people: the three others outvote it, and exactly those
    detections are turned back."""
    from ergopose.recon.associate import canonical_sides

    frames, _ = crossing4
    rng = np.random.default_rng(3)
    turned = 0
    for dets in frames:
        out = canonical_sides(list(dets))
        for d0, d1 in zip(dets, out):
            np.testing.assert_array_equal(d0.pixels_view, d1.pixels_view)
        if rng.random() < 0.3:
            c = int(rng.integers(4))
            flip = rng.random(dets[c].count) < 0.5
            wrong = list(dets)
            wrong[c] = dets[c].with_sides_exchanged(flip)
            back = canonical_sides(wrong)
            for d0, d1 in zip(dets, back):
                np.testing.assert_array_equal(d0.pixels_view, d1.pixels_view)
            turned += int(flip.sum())
    assert turned >= 10
