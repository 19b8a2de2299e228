"""The search views placed and sized from the lens (ergopose/pose/search_layout.py) and the search
schedule of the 2D stage: every direction of the image circle lies in a view that holds the
whole person there at the detector's size rule, for lenses of different resolutions; a finer
image gets finer views; each pass runs every view once at the given cost per frame."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ergopose.geometry.camera import Camera, ceiling_rotation, look_at_rotation
from ergopose.geometry.lenses.equidistant import Equidistant
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.pose.settings import PoseSettings
from ergopose.pose.search_layout import (
    SearchSizing,
    derive_layout,
    person_radius,
    person_size,
    pixel_density,
    required_half_fov,
)
from ergopose.sim.scene import rig_cameras

DETECTOR_PX = 224


def equidistant_camera(size: int, fov_deg: float = 180.0, height: float = 3.0, tilt_deg: float = 0.0) -> Camera:
    """A square image whose circle (fov_deg across) fills the short side, looking down from ``height``."""
    f = (size / 2) / math.radians(fov_deg / 2)
    lens = Equidistant(fx=f, fy=f, cx=(size - 1) / 2, cy=(size - 1) / 2)
    c, s = math.cos(math.radians(tilt_deg)), math.sin(math.radians(tilt_deg))
    tilt = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return Camera(
        name=f"eq{size}",
        lens=lens,
        width=size,
        height=size,
        rotation_world_from_cam=ceiling_rotation() @ tilt,
        position_world=np.array([0.0, 0.0, height]),
        image_circle=((size - 1) / 2, (size - 1) / 2, size / 2),
    )


def wall_camera() -> Camera:
    """A 1920 x 1080 pinhole camera (70 deg across) 1.9 m high, looking level and 15 deg down."""
    forward = np.array([math.cos(math.radians(15)), 0.0, -math.sin(math.radians(15))])
    return Camera(
        name="wall",
        lens=Rectilinear.from_fov(1920, 1080, math.radians(70.0)),
        width=1920,
        height=1080,
        rotation_world_from_cam=look_at_rotation(forward),
        position_world=np.array([0.0, 0.0, 1.9]),
    )


CAMERAS = {
    "rig 1024x768": lambda: rig_cameras(1024, 768)[0],
    "rig 2592x1944": lambda: rig_cameras(2592, 1944)[1],
    "equidistant 2048x2048": lambda: equidistant_camera(2048),
    "equidistant 1024x1024 tilted 10 deg, 4 m": lambda: equidistant_camera(1024, 190.0, 4.0, 10.0),
    "pinhole 1920x1080 on a wall": wall_camera,
}


def cap_directions(top: float, n: int = 4000) -> np.ndarray:
    """n directions spread evenly over the cap of angles 0..top off the lens axis (camera frame)."""
    k = np.arange(n) + 0.5
    z = 1.0 - (1.0 - math.cos(top)) * k / n
    az = math.pi * (1.0 + 5**0.5) * k
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(az), r * np.sin(az), z], axis=-1)


@pytest.mark.parametrize("name", list(CAMERAS))
def test_every_direction_lies_in_a_view_that_holds_the_person_at_the_size_rule(name):
    camera = CAMERAS[name]()
    sizing = SearchSizing()
    layout = derive_layout(camera, DETECTOR_PX, sizing)
    top = min(camera.max_theta_in_image(), sizing.max_polar)
    assert layout.covered >= top - 1e-9
    axes, halves = layout.views()
    assert np.all(halves >= sizing.min_half_fov - 1e-12) and np.all(halves <= sizing.max_half_fov + 1e-12)
    dirs = cap_directions(top)
    dirs = dirs[camera.lit(camera.lens.project(dirs))]  # the image's directions
    assert len(dirs) > 500
    allowed = required_half_fov(camera, dirs, DETECTOR_PX, sizing)  # the largest view the rule allows there
    radius = person_radius(camera, dirs, sizing)
    angle = np.arccos(np.clip(dirs @ axes.T, -1.0, 1.0))  # (n, V)
    holds = angle <= halves[None] - np.minimum(radius[:, None], 0.5 * halves[None]) + 1e-9
    fine_enough = np.tan(halves[None]) <= 1.01 * np.tan(allowed[:, None])  # the rule, to 1 %
    ok = (holds & fine_enough).any(axis=1)
    worst = dirs[~ok]
    assert ok.all(), (
        f"{(~ok).sum()} of {len(dirs)} directions not held, e.g. "
        f"{np.degrees(np.arccos(worst[:3, 2])).round(1).tolist()} deg off the axis"
    )


def test_views_that_hold_nothing_of_a_rectangular_image_are_left_out():
    camera = wall_camera()
    layout = derive_layout(camera, DETECTOR_PX, SearchSizing())
    assert len(layout.dropped) > 0 and layout.count == len(layout.views()[1])
    # every view kept holds some direction of the image; coverage is checked above
    axes, halves = layout.views()
    for axis, half in zip(axes, halves):
        d = cap_directions(math.pi, 20000)
        inside = d[np.arccos(np.clip(d @ axis, -1, 1)) <= half]
        assert camera.lit(camera.lens.project(inside)).any()


def test_a_finer_image_of_the_same_lens_gets_finer_views():
    sizing = SearchSizing()
    coarse_camera = rig_cameras(1024, 768)[0]
    coarse = derive_layout(coarse_camera, DETECTOR_PX, sizing)
    fine = derive_layout(rig_cameras(2592, 1944)[0], DETECTOR_PX, sizing)
    _, h_coarse = coarse.views()
    _, h_fine = fine.views()
    # The 1024 x 768 image has about 231 px/rad on the axis: a 224-px view as fine as that has a
    # half field of view of atan(112 / 231) = 26 deg, and no view of this image is finer (within
    # the 1 % of the rule); the person rule asks for finer views near the axis, which the
    # 2592 x 1944 image resolves.
    density = pixel_density(coarse_camera, np.array([0.0, 0.0, 1.0]))
    finest_coarse = math.atan(112 / density)
    assert math.degrees(finest_coarse) == pytest.approx(25.9, abs=0.3)
    assert np.all(np.tan(h_coarse) >= np.tan(finest_coarse) / 1.01)
    assert h_fine.min() < finest_coarse - math.radians(2.0)
    # With a farther working distance the person rule asks for finer views everywhere; only the
    # finer image gets them.
    far = SearchSizing(max_distance=9.0)
    assert (
        derive_layout(rig_cameras(2592, 1944)[0], DETECTOR_PX, far).count
        > derive_layout(coarse_camera, DETECTOR_PX, far).count + 10
    )


@pytest.mark.parametrize("name", ["rig 1024x768", "equidistant 2048x2048"])
def test_no_view_is_finer_than_the_image(name):
    camera = CAMERAS[name]()
    sizing = SearchSizing()
    axes, halves = derive_layout(camera, DETECTOR_PX, sizing).views()
    view_focal = (DETECTOR_PX / 2) / np.tan(halves)
    # Over each view's own field (its inscribed cone), the image's density somewhere reaches the view's.
    for axis, half, focal in zip(axes, halves, view_focal):
        d = cap_directions(math.pi, 20000)
        inside = d[np.arccos(np.clip(d @ axis, -1, 1)) <= half]
        density = pixel_density(camera, inside)
        assert np.nanmax(density) * sizing.max_upsampling >= focal / 1.01


def test_person_size_is_the_standing_body_or_its_width_from_above():
    camera = equidistant_camera(1024, height=3.0)
    sizing = SearchSizing(person_height=1.7, person_width=0.5, max_distance=6.0)
    down = camera.rotation_world_from_cam.T  # world -> camera rotation
    # Centre 0.85 m high, 4 m away horizontally: the body spans atan(3/4) - atan(1.3/4).
    d = down @ np.array([4.0, 0.0, 0.85 - 3.0])
    assert person_size(camera, d, sizing) == pytest.approx(math.atan(3 / 4) - math.atan(1.3 / 4), abs=1e-9)
    # Straight down: the width, 0.5 m at 2.15 m.
    d = down @ np.array([0.0, 0.0, -1.0])
    assert person_size(camera, d, sizing) == pytest.approx(2 * math.atan(0.25 / 2.15), abs=1e-9)
    # Towards the horizon and beyond the working distance: the person at 6 m.
    for far in (np.array([1.0, 0.0, -0.05]), np.array([1.0, 0.0, 0.2])):
        assert person_size(camera, down @ far, sizing) == pytest.approx(math.atan(3 / 6) - math.atan(1.3 / 6), abs=1e-9)


def test_pixel_density_of_an_equidistant_lens():
    camera = equidistant_camera(1024)
    f = 512 / (math.pi / 2)
    # Radially f px/rad everywhere; across, f theta / sin(theta) (larger): the smaller is f.
    for theta in (0.0, 0.5, 1.2):
        d = np.array([math.sin(theta), 0.0, math.cos(theta)])
        assert pixel_density(camera, d) == pytest.approx(f, rel=1e-3)


class _CountingDetector:
    input_size = (224, 224)

    def __init__(self):
        self.images = []

    def __call__(self, image):
        self.images.append(image)
        return []


class _NoLandmarker:
    input_size = (256, 256)

    def __call__(self, image):  # pragma: no cover - never called: nothing is found
        raise AssertionError("no view should be run")


@pytest.mark.parametrize("spread", [True, False])
def test_each_pass_runs_every_search_view_once_at_the_cost_per_frame(spread):
    camera = rig_cameras(1024, 768)[0]
    settings = PoseSettings(search_spread=spread, idle_search_views_per_frame=4.5, idle_search_every=4)
    stage = FisheyePoseEstimator(camera, 0, _NoLandmarker(), _CountingDetector(), settings)
    views = len(stage.search.views)
    period = stage.search_period(False)
    assert period == max(4, math.ceil(views / 4.5))
    frame = np.full((768, 1024, 3), 90, np.uint8)
    stage.process(frame, 0)
    assert stage.detector_runs == views  # the first frame searches everywhere
    counts = []
    for i in range(1, 1 + 3 * period):
        before = stage.detector_runs
        stage.process(frame, i)
        counts.append(stage.detector_runs - before)
    assert sum(counts) == 3 * views
    if spread:
        assert max(counts) <= math.ceil(views / period)
    else:
        assert counts[period - 1 :: period] == [views] * 3 and sum(counts[: period - 1]) == 0


def test_an_unknown_layout_is_a_config_error():
    from ergopose.errors import ConfigError

    with pytest.raises(ConfigError, match="search_layout: must be 'lens' or 'fixed'"):
        FisheyePoseEstimator(
            rig_cameras(1024, 768)[0], 0, _NoLandmarker(), _CountingDetector(), PoseSettings(search_layout="rings")
        )


def test_fixed_layout_stays_available():
    camera = rig_cameras(1024, 768)[0]
    stage = FisheyePoseEstimator(camera, 0, _NoLandmarker(), _CountingDetector(), PoseSettings(search_layout="fixed"))
    assert len(stage.search.views) == 17
    assert stage.search_period(True) == 34  # at most half a detector run per frame on average
    old = PoseSettings(search_layout="fixed", search_views_per_frame=1.5, search_spread=False)
    assert FisheyePoseEstimator(camera, 0, _NoLandmarker(), _CountingDetector(), old).search_period(True) == 12
