"""Camera: pose conventions, projection of world points, rays, angles, validation."""

from __future__ import annotations

import math
import pickle

import cv2
import numpy as np
import pytest

from ergopose.errors import ConfigError
from ergopose.geometry.camera import (
    ROTATION_TOLERANCE,
    Camera,
    ceiling_camera,
    ceiling_rotation,
    check_rotation,
    look_at_rotation,
)
from ergopose.geometry.lenses import Equidistant, KannalaBrandt, Rectilinear

#: The JY left calibration (../shared/data/opencv-fisheye-stereo-jy/SOURCE.md), 1280 x 800.
JY_K = np.array([[558.478087865323, 0, 620.458515360843], [0, 560.506767351568, 381.939424848348], [0, 0, 1]])
JY_D = np.array([-0.0014613319981768, -0.00329861110580401, 0.00605760088590183, -0.00374209380722371])


def random_rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def test_project_world_matches_cv2_fisheye_with_pose(rng):
    rotation = random_rotation(rng)
    position = np.array([0.4, -1.2, 2.9])
    camera = Camera("cam_1", KannalaBrandt.from_opencv(JY_K, JY_D), 1280, 800, rotation, position)
    points_cam = rng.uniform([-2, -2, 0.5], [2, 2, 4], size=(500, 3))
    points_world = points_cam @ rotation.T + position
    # OpenCV's extrinsics are world -> camera: R_cw = R^T, t = -R^T c.
    rvec, _ = cv2.Rodrigues(rotation.T)
    tvec = -rotation.T @ position
    expected, _ = cv2.fisheye.projectPoints(points_world.reshape(-1, 1, 3), rvec, tvec, JY_K, JY_D)
    np.testing.assert_allclose(camera.project_world(points_world), expected[:, 0], atol=1e-6)
    np.testing.assert_allclose(camera.points_world_to_cam(points_world), points_cam, atol=1e-12)
    np.testing.assert_allclose(camera.points_cam_to_world(points_cam), points_world, atol=1e-12)
    w = camera.pose_world_from_cam
    np.testing.assert_allclose((np.c_[points_cam, np.ones(500)] @ w.T)[:, :3], points_world, atol=1e-12)
    np.testing.assert_array_equal(w[3], [0, 0, 0, 1])


def test_rays_world_point_at_the_world_points(rng):
    camera = ceiling_camera("cam_1", Equidistant(300.0, 300.0, 599.5, 599.5), 1200, 1200, [1.0, 2.0, 3.0], yaw=0.4)
    # Points on the floor and up to 1 m above it, including far to the side (beyond 60 degrees).
    points = np.c_[rng.uniform(-6, 8, 1000), rng.uniform(-5, 9, 1000), rng.uniform(0, 1, 1000)]
    pixels = camera.project_world(points)
    rays = camera.rays_world(pixels)
    expected = (points - camera.position_world) / np.linalg.norm(points - camera.position_world, axis=1, keepdims=True)
    np.testing.assert_allclose(rays, expected, atol=1e-12)
    np.testing.assert_allclose(camera.theta_of_pixels(pixels), camera.theta_of_points_world(points), atol=1e-12)


def test_ceiling_camera_looks_down_and_keeps_world_x_to_the_right():
    camera = ceiling_camera("cam_1", Equidistant(300.0, 300.0, 599.5, 599.5), 1200, 1200, [0.0, 0.0, 3.0])
    np.testing.assert_array_equal(camera.axis_world, [0, 0, -1])
    below = camera.project_world(np.array([0.0, 0.0, 0.0]))
    np.testing.assert_allclose(below, [599.5, 599.5], atol=1e-12)
    right = camera.project_world(np.array([1.0, 0.0, 0.0]))
    ahead = camera.project_world(np.array([0.0, 1.0, 0.0]))
    assert right[0] > 599.5 and abs(right[1] - 599.5) < 1e-9  # world +x: image right
    assert ahead[1] < 599.5 and abs(ahead[0] - 599.5) < 1e-9  # world +y: image up
    # A point at the camera's height, 1 m to the side, is 90 degrees off-axis.
    assert camera.theta_of_points_world(np.array([1.0, 0.0, 3.0])) == pytest.approx(math.pi / 2)
    rotated = ceiling_rotation(math.pi / 2)
    np.testing.assert_allclose(rotated[:, 0], [0, 1, 0], atol=1e-15)  # image right is world +y


def test_look_at_rotation():
    rotation = look_at_rotation([1.0, 0.0, 0.0])
    np.testing.assert_allclose(rotation[:, 2], [1, 0, 0])
    np.testing.assert_allclose(rotation[:, 0], [0, -1, 0], atol=1e-15)  # looking along +x, right is -y
    np.testing.assert_allclose(rotation[:, 1], [0, 0, -1], atol=1e-15)  # image down is world down
    check_rotation(look_at_rotation([0.3, -0.5, -0.8]))
    with pytest.raises(ValueError):
        look_at_rotation([0.0, 0.0, -2.0])


def test_in_image_uses_pixel_edges():
    camera = ceiling_camera("c", Rectilinear(100.0, 100.0, 49.5, 29.5), 100, 60, [0, 0, 3])
    pixels = np.array([[-0.5, -0.5], [99.5, 59.5], [-0.51, 10], [10, 59.51], [np.nan, 3], [50, 30]])
    np.testing.assert_array_equal(camera.in_image(pixels), [True, True, False, False, False, True])


def test_nan_where_the_lens_cannot_see():
    camera = ceiling_camera("c", Rectilinear.from_fov(640, 480, math.radians(90)), 640, 480, [0, 0, 3])
    above = camera.project_world(np.array([[0.0, 0.0, 4.0], [0.0, 0.0, 3.0], [1.0, 0.0, 3.0]]))
    assert np.isnan(above).all()  # behind a pinhole, the centre, and exactly 90 degrees
    assert np.isnan(camera.theta_of_points_world(np.array([0.0, 0.0, 3.0])))
    assert camera.theta_of_points_world(np.array([0.0, 0.0, 4.0])) == pytest.approx(math.pi)
    fisheye = ceiling_camera("f", KannalaBrandt.from_opencv(JY_K, JY_D), 1280, 800, [0, 0, 3])
    assert np.isnan(fisheye.rays_world(np.array([620.0 + 560.0 * 1.6, 381.0]))).all()  # outside the circle


def test_field_of_view():
    pinhole = ceiling_camera("c", Rectilinear.from_fov(640, 480, math.radians(90)), 640, 480, [0, 0, 3])
    hfov, vfov = pinhole.field_of_view()
    assert math.degrees(hfov) == pytest.approx(90.0, abs=1e-9)
    assert math.degrees(vfov) == pytest.approx(2 * math.degrees(math.atan(240 / 320)), abs=1e-9)
    # An equidistant lens whose 180-degree circle fits in the image: the circle limits the view.
    fisheye = ceiling_camera("f", Equidistant(300.0, 300.0, 599.5, 599.5), 1200, 1200, [0, 0, 3])
    assert math.degrees(fisheye.field_of_view()[0]) == pytest.approx(2 * 600 / 300 * 180 / math.pi, abs=1e-6)
    assert fisheye.max_theta_in_image() == pytest.approx(math.hypot(600, 600) / 300, rel=1e-3)


def test_validation_names_the_field():
    lens = Equidistant(300.0, 300.0, 599.5, 599.5)
    good = dict(
        name="cam_1", lens=lens, width=1200, height=1200, rotation_world_from_cam=np.eye(3), position_world=[0, 0, 3]
    )
    Camera(**good)
    cases = [
        ({"name": ""}, "name"),
        ({"lens": "equidistant"}, "lens"),
        ({"width": 0}, "width"),
        ({"height": 12.5}, "height"),
        ({"width": True}, "width"),
        ({"rotation_world_from_cam": 2 * np.eye(3)}, "rotation_world_from_cam"),
        ({"rotation_world_from_cam": np.diag([1.0, 1.0, -1.0])}, "rotation_world_from_cam"),  # mirror
        ({"rotation_world_from_cam": np.eye(2)}, "rotation_world_from_cam"),
        ({"rotation_world_from_cam": [[1, 0, 0], [0, 1, 0], [0, 0, "x"]]}, "rotation_world_from_cam"),
        ({"position_world": [0, 0]}, "position_world"),
        ({"position_world": [0, np.nan, 3]}, "position_world"),
    ]
    for change, field in cases:
        with pytest.raises(ConfigError) as exc:
            Camera(**{**good, **change})
        assert exc.value.field == field, change
    # Rounded to 7 decimals is still a rotation; 1e-4 off is not.
    rotation = look_at_rotation([0.3, -0.5, -0.8])
    check_rotation(np.round(rotation, 7))
    assert ROTATION_TOLERANCE < 1e-4
    with pytest.raises(ConfigError, match="orthonormal"):
        check_rotation(rotation + 1e-4)


def test_frozen_equal_and_read_only():
    camera = ceiling_camera("cam_1", Equidistant(300.0, 300.0, 599.5, 599.5), 1200, 1200, [0, 0, 3])
    twin = ceiling_camera("cam_1", Equidistant(300.0, 300.0, 599.5, 599.5), 1200, 1200, [0, 0, 3])
    assert camera == twin and hash(camera) == hash(twin)
    assert camera != ceiling_camera("cam_1", Equidistant(300.0, 300.0, 599.5, 599.5), 1200, 1200, [0, 0, 3.1])
    with pytest.raises(AttributeError):
        camera.width = 3
    with pytest.raises(ValueError):
        camera.position_world[0] = 5.0
    # Worker processes get an equal, still read-only copy.
    copy = pickle.loads(pickle.dumps(camera))
    assert copy == camera and not copy.rotation_world_from_cam.flags.writeable


def test_field_of_view_follows_the_image_circle():
    """Issue 14: the simulated 190-degree rig was shown as 297.8 x 192.2 deg (the Kannala-Brandt
    polynomial reaches 171 deg in the image corners). With its image circle (95 deg) it is 190 x 190."""
    import math

    from ergopose.errors import ConfigError
    from ergopose.sim.scene import IMAGE_CIRCLE_THETA, rig_cameras

    for camera in rig_cameras(1024, 768):
        hfov, vfov = camera.field_of_view()
        # The principal point is a pixel or two off the circle's centre: both spans ~ 2 x 95 deg.
        assert abs(math.degrees(hfov) - 190.0) < 0.5 and abs(math.degrees(vfov) - 190.0) < 0.5
        assert camera.max_theta_in_image() == pytest.approx(IMAGE_CIRCLE_THETA, abs=2e-3)
        bare = Camera(
            camera.name, camera.lens, camera.width, camera.height, camera.rotation_world_from_cam, camera.position_world
        )
        assert math.degrees(bare.field_of_view()[0]) > 290.0  # the old figure, from the model alone
        assert camera != bare
        u, v, r = camera.image_circle
        assert camera.lit(np.array([[u, v], [u + r * 0.99, v]])).all()
        assert not camera.lit(np.array([[u + r * 1.01, v], [0.0, 0.0]])).any()
    with pytest.raises(ConfigError, match="radius"):
        Camera("c", camera.lens, 100, 100, np.eye(3), np.zeros(3), image_circle=(50.0, 50.0, 0.0))


def test_field_of_view_of_a_pinhole_with_distortion():
    import math

    from ergopose.geometry.lenses import BrownConrady

    lens = BrownConrady(1000.0, 1000.0, 639.5, 359.5, 0.0, 0.0, 0.0, 0.0, 0.0)
    camera = Camera("p", lens, 1280, 720, np.eye(3), np.zeros(3))
    hfov, vfov = camera.field_of_view()
    assert hfov == pytest.approx(2 * math.atan(640 / 1000), abs=1e-6)
    assert vfov == pytest.approx(2 * math.atan(360 / 1000), abs=1e-6)
