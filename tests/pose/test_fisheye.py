"""The fisheye 2D stage with the real BlazePose networks on a person warped into a fisheye image.

A cartoon person is drawn upright in a virtual view aimed at a floor position, then warped into
the fisheye image through the lens model (the inverse of view generation). The stage must find
the person with its search views, put the keypoints back on the drawn joints in fisheye pixels,
and re-focus on the next frame.
"""

from __future__ import annotations

import numpy as np
import pytest
from mannequin import MANNEQUIN_JOINTS, draw_mannequin

from ergopose.geometry.camera import ceiling_camera
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.geometry.views import VirtualView, build_map
from ergopose.keypoints import JOINT_INDEX
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.pose.records import SOURCE_REFOCUS, SOURCE_SEARCH
from ergopose.pose.settings import PoseSettings
from ergopose.pose.view_cache import ViewCache
from ergopose.pose.view_geometry import view_rotation
from ergopose.records import Detections2D

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


@pytest.mark.slow
@pytest.mark.parametrize(
    "target", [(1.2, 0.8, 1.0), (-2.0, 1.5, 1.0), (0.5, -2.6, 1.0), (0.35, -0.3, 1.0)]
)  # the last 12 deg off the axis, under the camera
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
        from_p = Detections2D(
            det.camera, det.frame, det.time_s, det.pixels_view, det.confidence, det.projection
        ).world_rays()
        assert np.allclose(det.rays_world[ok], from_p[ok], atol=1e-9)


def stage_index(name):
    from ergopose.keypoints import JOINT_INDEX

    return JOINT_INDEX[name]


@pytest.mark.slow
def test_empty_frame_has_no_people(camera, landmarker, detector):
    frame = np.full((SIZE, SIZE, 3), 170, np.uint8)
    stage = FisheyePoseEstimator(camera, 0, landmarker, detector)
    assert stage.process(frame, 0).count == 0


def test_view_cache_reuses_maps_for_nearby_requests(camera):
    cache = ViewCache(camera, (64, 64), tolerance_px=0.5)
    d = np.array([0.3, 0.2, 0.9])
    v1, m1 = cache.get(d, np.radians(20))
    v2, m2 = cache.get(d + np.array([1e-5, 0, 0]), np.radians(20.001))
    assert m1 is m2 and cache.hits == 1 and cache.misses == 1
    # A request a few pixels away is a different view.
    cache.get(d + np.array([0.02, 0, 0]), np.radians(20))
    assert cache.misses == 2
    # Tolerance 0: no cache, every map is fresh.
    fresh = ViewCache(camera, (64, 64), tolerance_px=0.0)
    assert fresh.get(d, np.radians(20))[1] is not fresh.get(d, np.radians(20))[1]


def _view_pixel_shift(requested: VirtualView, served: VirtualView) -> float:
    """Largest distance (view pixels) between where a ray falls in the requested view and in the
    view served instead, over all pixels of the requested view."""
    v, u = np.mgrid[0 : requested.height, 0 : requested.width].astype(np.float64)
    pixels = np.stack([u, v], axis=-1)
    rays_cam = requested.view_pixels_to_rays_cam(pixels)
    in_served = served.lens.project(rays_cam @ served.rotation_cam_from_view)
    return float(np.nanmax(np.linalg.norm(in_served - pixels, axis=-1)))


@pytest.mark.slow
@pytest.mark.parametrize("tolerance_px", [0.25, 0.5, 1.0])
def test_view_cache_serves_views_within_its_pixel_tolerance(camera, tolerance_px):
    """Every cached view lies within the tolerance of the exact view requested (checked at every
    pixel against a freshly built view), and its map equals a freshly built map of itself
    (interpolated, as the stage builds them; within 0.01 px of the exact one)."""
    rng = np.random.default_rng(5)
    cache = ViewCache(camera, (256, 256), tolerance_px=tolerance_px)
    worst = 0.0
    for _ in range(40):
        polar = rng.uniform(0.0, np.radians(80.0))
        az = rng.uniform(-np.pi, np.pi)
        d = np.array([np.sin(polar) * np.cos(az), np.sin(polar) * np.sin(az), np.cos(polar)])
        half = rng.uniform(np.radians(8.0), np.radians(55.0))
        up = None if rng.random() < 0.3 else rng.normal(size=3)
        served, served_map = cache.get(d, half, up)
        lens = Rectilinear.from_fov(256, 256, 2.0 * half)
        exact = VirtualView(camera, lens, 256, 256, view_rotation(camera, d, up))
        worst = max(worst, _view_pixel_shift(exact, served))
        fresh = served.build_map()  # the stage's maps are exact (docs/pose-in-fisheye.md)
        assert np.array_equal(fresh.map_x, served_map.map_x) and np.array_equal(fresh.map_y, served_map.map_y)
    assert worst <= tolerance_px
    assert worst > 0.1 * tolerance_px  # the quantisation is used, not far finer than asked


def test_view_rotation_puts_the_given_direction_up(camera):
    rng = np.random.default_rng(2)
    for _ in range(50):
        d = rng.normal(size=3)
        d[2] = abs(d[2]) + 0.2
        up = rng.normal(size=3)
        r = view_rotation(camera, d, up)
        assert np.allclose(r.T @ r, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(r), 1.0)
        assert np.allclose(r[:, 2], d / np.linalg.norm(d))
        # The image of the ray d + 0.1 up lies straight above the view's centre.
        lens = Rectilinear.from_fov(256, 256, np.radians(60))
        d_unit = d / np.linalg.norm(d)
        px = lens.project((d_unit + 0.1 * up / np.linalg.norm(up)) @ r)
        centre = lens.project(d_unit @ r)
        assert px[1] < centre[1] and abs(px[0] - centre[0]) < 1e-9 * (centre[1] - px[1])
        # No up given: the paper's upright view.
        assert np.allclose(view_rotation(camera, d), VirtualView.aimed_along(camera, d, 1.0).rotation_cam_from_view)


def _rolled_view(camera, target_world, hfov_deg, roll):
    upright = VirtualView.aimed_at(camera, np.asarray(target_world, float), np.radians(hfov_deg), size=(512, 512))
    c, s = np.cos(roll), np.sin(roll)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return VirtualView(camera, upright.lens, 512, 512, upright.rotation_cam_from_view @ rz)


@pytest.mark.slow
@pytest.mark.parametrize("lean_deg", [-60.0, 50.0])
def test_refocused_view_is_rolled_to_the_body_axis(camera, landmarker, detector, lean_deg):
    """A person leaning (drawn upright in a view rolled against the upright one): the stage's
    next view is rolled from upright towards the drawn hip-to-shoulder direction by at most
    ``max_body_roll`` (here 30 degrees; world vertical stays the reference), and the pose found
    in that view leans by what is left over."""
    target = (1.4, 0.6, 1.0)
    view = _rolled_view(camera, target, 40.0, np.radians(lean_deg))
    background = (170, 170, 170)
    drawing = np.empty((512, 512, 3), np.uint8)
    drawing[:] = background
    joints_view = draw_mannequin(drawing, scale=2.0)
    to_view = build_map(camera.lens, (camera.width, camera.height), view.lens, view.rotation_cam_from_view.T)
    frame = to_view.apply(drawing, exact=True, border_value=background)
    hip_ray = _unit(view.view_pixels_to_rays_cam((joints_view["left_hip"] + joints_view["right_hip"]) / 2))
    shoulder_ray = _unit(
        view.view_pixels_to_rays_cam((joints_view["left_shoulder"] + joints_view["right_shoulder"]) / 2)
    )
    # In the upright view the person leans by the drawn angle.
    upright = VirtualView.aimed_along(camera, hip_ray, np.radians(40))
    d = upright.lens.project(shoulder_ray @ upright.rotation_cam_from_view) - upright.lens.project(
        hip_ray @ upright.rotation_cam_from_view
    )
    assert abs(np.degrees(np.arctan2(d[0], -d[1])) - lean_deg) < 3.0
    settings = PoseSettings(max_body_roll=np.radians(30.0))
    stage = FisheyePoseEstimator(camera, 0, landmarker, detector, settings)
    assert stage.process(frame, 0).count == 1
    (nxt,) = stage._targets
    assert nxt.up_cam is not None
    bound = np.degrees(settings.max_body_roll)
    left_over = lean_deg - np.clip(lean_deg, -bound, bound)
    r = view_rotation(camera, nxt.direction_cam, nxt.up_cam)
    lens = Rectilinear.from_fov(256, 256, 2 * nxt.half_fov)
    d = lens.project(shoulder_ray @ r) - lens.project(hip_ray @ r)
    assert abs(np.degrees(np.arctan2(d[0], -d[1])) - left_over) < 10.0
    found = stage.process(frame, 1)
    assert found.count == 1 and found.source[0] == SOURCE_REFOCUS
    px = found.pixels_view[0]
    axis = px[[JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]]].mean(0) - px[
        [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]
    ].mean(0)
    # (The network's shoulders and hips on the drawn figure leaning by 30 degrees in the view
    # give its axis to within about 13 degrees.)
    assert abs(np.degrees(np.arctan2(axis[0], -axis[1])) - left_over) < 15.0
    # Keypoints still come back onto the drawn joints in the fisheye image.
    drawn_fisheye = view.view_to_source_pixels(joints_view["left_shoulder"])
    torso = np.linalg.norm(view.view_to_source_pixels(joints_view["left_hip"]) - drawn_fisheye)
    assert np.linalg.norm(found.pixels_fisheye[0, JOINT_INDEX["left_shoulder"]] - drawn_fisheye) < 0.25 * torso


def _unit(v):
    return v / np.linalg.norm(v)
