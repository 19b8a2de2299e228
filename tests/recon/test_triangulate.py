"""Triangulation of associated people: exactness, no invented joints, outliers, variance model."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ergopose.errors import InputError
from ergopose.recon.settings import ReconSettings
from ergopose.recon.triangulate import point_variance, reconstruct_frames, triangulate_pairs, view_focal_px
from ergopose.records import Detections2D, detections_from_fisheye
from ergopose.sim.synthetic import walk_workers
from tests.recon.conftest import FPS, crossing_scripts


def _exact_frames(cameras, truth):
    frames = []
    for f in range(len(truth)):
        dets = []
        for cam in cameras:
            px = cam.project_world(truth[f])
            dets.append(detections_from_fisheye(cam, f, f / FPS, px, np.ones(px.shape[:2])))
        frames.append(tuple(dets))
    return frames


def test_exact_observations_give_exact_points(cameras):
    truth = walk_workers(crossing_scripts(), 6, FPS)
    people = reconstruct_frames(_exact_frames(cameras, truth))
    assert len(people) == 24 and np.all(people.n_cameras == 2)
    err = [
        np.linalg.norm(people.points_world[r] - truth[people.frame[r]], axis=-1).max(axis=-1)
        for r in range(len(people))
    ]
    # Each pair is one true person (rows are not labelled: take the closest).
    for r in range(len(people)):
        d = np.linalg.norm(people.points_world[r][None] - truth[people.frame[r]], axis=-1).max(axis=-1)
        assert d.min() < 1e-6
    assert np.nanmax(people.reprojection_error_px) < 1e-4
    assert np.all(people.views == 2) and not people.rejected.any()
    assert len(err) == 24


def test_a_joint_seen_once_stays_nan(cameras):
    truth = walk_workers(crossing_scripts(), 1, FPS)
    a, b = _exact_frames(cameras, truth)[0]
    conf_b = b.confidence.copy()
    conf_b[:, 15] = 0.0  # camera 2 misses every left wrist
    conf_b[:, 16] = 0.1  # and sees right wrists below min_confidence
    b2 = Detections2D(b.camera, b.frame, b.time_s, b.pixels_view, conf_b, b.projection)
    people = reconstruct_frames([(a, b2)])
    assert np.all(np.isnan(people.points_world[:, 15])) and np.all(people.views[:, 15] == 1)
    assert np.all(np.isnan(people.points_world[:, 16])) and np.all(people.views[:, 16] == 1)
    assert np.all(people.confidence[:, 15] == 1.0)  # the one camera that saw it
    assert np.isfinite(people.points_world[:, 14]).all()


def test_gross_2d_error_is_rejected_and_marked(cameras):
    truth = walk_workers(crossing_scripts(), 1, FPS)
    a, b = _exact_frames(cameras, truth)[0]
    px = b.pixels_view.copy()
    # Every left elbow in camera 2 is 40 view pixels off, across the epipolar line (an error
    # along it only slides the point along camera 1's ray and cannot be seen).
    from ergopose.geometry.triangulation import reproject

    for n in range(b.count):
        centre = cameras[0].position_world
        ray = truth[0, :, 13][np.argmin(np.linalg.norm(truth[0, :, 13] - _point_of(a, b, n, 13), axis=-1))] - centre
        q = reproject(b.projection[n][None], np.stack([centre + 0.9 * ray, centre + 1.1 * ray]))[0]
        e = (q[1] - q[0]) / np.linalg.norm(q[1] - q[0])
        px[n, 13] += 40.0 * np.array([-e[1], e[0]])
    b2 = Detections2D(b.camera, b.frame, b.time_s, px, b.confidence, b.projection)
    people = reconstruct_frames([(a, b2)], ReconSettings(reprojection_threshold_px=5.0))
    assert np.all(np.isnan(people.points_world[:, 13])) and np.all(people.views[:, 13] == 0)
    assert people.rejected[:, :, 13].all()  # both observations marked
    assert not people.rejected[:, :, :13].any() and np.isfinite(people.points_world[:, 12]).all()
    # Under a lenient threshold the joint is kept with its (large) error.
    lenient = reconstruct_frames([(a, b2)], ReconSettings(reprojection_threshold_px=100.0))
    assert np.isfinite(lenient.points_world[:, 13]).all() and np.all(lenient.reprojection_error_px[:, 13] > 5)


def test_view_focal_from_projection():
    K = np.array([[300.0, 0, 127.5], [0, 300.0, 127.5], [0, 0, 1]])
    th = 0.3
    R = np.array([[1, 0, 0], [0, np.cos(th), -np.sin(th)], [0, np.sin(th), np.cos(th)]])
    P = K @ np.hstack([R, -(R @ np.array([[1.0], [2.0], [3.0]]))])
    assert np.isclose(view_focal_px(P), 300.0) and np.isclose(view_focal_px(7.5 * P), 300.0)


def test_variance_model_matches_the_observed_scatter(cameras, rng):
    """Gaussian noise of keypoint_sigma_px in the view pixels: the predicted per-coordinate
    variance agrees with the scatter of the triangulated points (Monte Carlo, 400 draws)."""
    truth = walk_workers(crossing_scripts(), 1, FPS)[0]
    a, b = _exact_frames(cameras, truth[None])[0]
    settings = ReconSettings(keypoint_sigma_px=1.5, reprojection_threshold_px=1e6)
    P = np.stack([a.projection, b.projection], axis=1)  # rows are people in the same order
    px0 = np.stack([a.pixels_view, b.pixels_view], axis=1)
    conf = np.ones(px0.shape[:-1])
    draws = 400
    noisy = px0[None] + rng.normal(0.0, 1.5, (draws,) + px0.shape)
    pts = triangulate_pairs(
        np.broadcast_to(P, (draws,) + P.shape).reshape(-1, 2, 3, 4),
        noisy.reshape((-1,) + px0.shape[1:]),
        np.broadcast_to(conf, (draws,) + conf.shape).reshape((-1,) + conf.shape[1:]),
        settings,
    )[0].reshape(draws, 4, 33, 3)
    emp = pts.var(axis=0)  # (4, 33, 3)
    exact = triangulate_pairs(P, px0, conf, settings)
    pred = point_variance(P, exact[0], conf, np.zeros((4, 33)), settings)
    ratio = emp / pred
    assert 0.8 < np.median(ratio) < 1.2
    assert np.percentile(ratio, 5) > 0.6 and np.percentile(ratio, 95) < 1.5
    # Lower confidence means proportionally larger variance (sigma ~ 1 / confidence).
    half = point_variance(P, exact[0], conf * 0.5, np.zeros((4, 33)), settings)
    assert np.allclose(half / pred, 4.0)
    worse = point_variance(P, exact[0], conf, np.full((4, 33), settings.reprojection_scale_px), settings)
    assert np.allclose(worse / pred, 2.0)


def _point_of(a, b, n, joint):
    """The exact 3D point of detection n of camera b at a joint (triangulated with its partner)."""
    people = reconstruct_frames([(a, b)])
    r = np.flatnonzero(people.detection[:, 1] == n)[0]
    return people.points_world[r, joint]


def test_a_person_carries_the_mean_clothing_colour_of_its_cameras(cameras):
    """Each camera gives the person's colour (person p: 10 p + camera); a 3D person carries the
    mean over the cameras that measured it, one camera's where the other did not."""
    truth = walk_workers(crossing_scripts(), 2, FPS)
    frames = []
    for f in range(len(truth)):
        dets = []
        for c, cam in enumerate(cameras):
            px = cam.project_world(truth[f])
            det = detections_from_fisheye(cam, f, f / FPS, px, np.ones(px.shape[:2]))
            look = np.repeat(10.0 * np.arange(len(px))[:, None] + c, 6, axis=1)
            if c == 1:
                look[0, 3:] = np.nan  # camera 1 did not see person 0's thighs
            dets.append(dataclasses.replace(det, appearance=look))
        frames.append(tuple(dets))
    people = reconstruct_frames(frames)
    assert np.all(people.n_cameras == 2)
    for r in range(len(people)):
        cam0, cam1 = people.detection[r]
        assert cam0 == cam1  # the simulated people are in the same order in both cameras
        expected = np.full(6, 10.0 * cam0 + 0.5)
        if cam0 == 0:
            expected[3:] = 0.0
        np.testing.assert_allclose(people.appearance[r], expected)


def test_detections_refuse_a_misshapen_appearance(cameras):
    truth = walk_workers(crossing_scripts(), 1, FPS)
    px = cameras[0].project_world(truth[0])
    det = detections_from_fisheye(cameras[0], 0, 0.0, px, np.ones(px.shape[:2]))
    assert np.isnan(det.appearance).all() and det.appearance.shape == (len(px), 6)
    with pytest.raises(InputError, match="appearance must have shape"):
        dataclasses.replace(det, appearance=np.zeros((len(px), 5)))
