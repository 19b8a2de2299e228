"""The fisheye 2D stage with the real BlazePose networks on a person warped into a fisheye image.

A cartoon person is drawn upright in a virtual view aimed at a floor position, then warped into
the fisheye image through the lens model (the inverse of view generation). The stage must find
the person with its search views, put the keypoints back on the drawn joints in fisheye pixels,
and re-focus on the next frame.
"""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.geometry.camera import ceiling_camera
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt
from ergopose.geometry.views import VirtualView, build_map
from ergopose.recon.records import Detections2D
from ergopose.pose.fisheye import SOURCE_REFOCUS, SOURCE_SEARCH, FisheyePoseEstimator, ViewCache

from mannequin import MANNEQUIN_JOINTS, draw_mannequin

SIZE = 1024
LENS = KannalaBrandt(fx=330.0, fy=330.0, cx=511.5, cy=511.5, k1=0.01, k2=-0.004, k3=0.0, k4=0.0)


def fisheye_with_person(camera, target_world, hfov_deg=40.0, background=(170, 170, 170)):
    """A fisheye frame with the cartoon person drawn upright in a view aimed at target_world."""
    view = VirtualView.aimed_at(camera, np.asarray(target_world, float), np.radians(hfov_deg), size=(512, 512))
    drawing = np.empty((512, 512, 3), np.uint8)
    drawing[:] = background
    joints_view = draw_mannequin(drawing, scale=2.0)
    # Fisheye pixels -> view pixels: build_map with the fisheye as destination, the view as source.
    to_view = build_map(camera.lens, (camera.width, camera.height), view.lens, view.rotation_cam_from_view.T)
    frame = to_view.apply(drawing, exact=True, border_value=background)
    names = list(MANNEQUIN_JOINTS)
    joints_fisheye = view.view_to_source_pixels(np.stack([joints_view[n] for n in names]))
    return frame, dict(zip(names, joints_fisheye))


@pytest.fixture(scope="module")
def camera():
    return ceiling_camera("cam_1", LENS, SIZE, SIZE, position_world=(0.0, 0.0, 3.0))


@pytest.mark.parametrize("target", [(1.2, 0.8, 1.0), (-2.0, 1.5, 1.0), (0.5, -2.6, 1.0)])
def test_stage_finds_and_refocuses_on_a_person(camera, landmarker, detector, target):
    frame, joints = fisheye_with_person(camera, target)
    stage = FisheyePoseEstimator(camera, 0, landmarker, detector)
    torso = np.linalg.norm(joints["left_shoulder"] - joints["left_hip"])
    for frame_index, expected_source in ((0, SOURCE_SEARCH), (1, SOURCE_REFOCUS)):
        found = stage.process(frame, frame_index)
        assert found.count == 1, f"frame {frame_index}: {found.count} people"
        assert found.source[0] == expected_source
        for name, drawn in joints.items():
            j = stage_index(name)
            err = np.linalg.norm(found.pixels_fisheye[0, j] - drawn)
            assert err < 0.25 * torso, f"{name}: {err:.1f} px off (torso {torso:.1f} px)"
        # Rays, fisheye pixels and view pixels describe the same points.
        assert np.allclose(camera.lens.project(found.rays_cam[0]), found.pixels_fisheye[0], atol=1e-6, equal_nan=True)
        assert found.projection.shape == (1, 3, 4)
        # The record handed to reconstruction: its rays follow from the view's projection matrix.
        det = found.to_recon(camera, time_s=frame_index / 12.0)
        assert det.count == 1 and det.camera == "cam_1"
        ok = np.isfinite(det.rays_world).all(axis=-1)
        from_p = Detections2D(det.camera, det.frame, det.time_s, det.pixels_view, det.confidence,
                              det.projection).world_rays()
        assert np.allclose(det.rays_world[ok], from_p[ok], atol=1e-9)


def stage_index(name):
    from ergopose.keypoints import JOINT_INDEX

    return JOINT_INDEX[name]


def test_empty_frame_has_no_people(camera, landmarker, detector):
    frame = np.full((SIZE, SIZE, 3), 170, np.uint8)
    stage = FisheyePoseEstimator(camera, 0, landmarker, detector)
    assert stage.process(frame, 0).count == 0


def test_view_cache_reuses_maps_for_nearby_bearings(camera):
    cache = ViewCache(camera, (64, 64), step=np.radians(0.5))
    d = np.array([0.3, 0.2, 0.9])
    v1, m1 = cache.get(d, np.radians(20))
    v2, m2 = cache.get(d + np.array([1e-4, 0, 0]), np.radians(20.01))
    assert m1 is m2 and cache.hits == 1 and cache.misses == 1
    # The cached view is an exact view aimed within half a step of the request.
    angle = np.arccos(np.clip(v1.rotation_cam_from_view[:, 2] @ (d / np.linalg.norm(d)), -1, 1))
    assert angle < np.radians(0.5)
