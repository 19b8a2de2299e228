"""The simulated rig and work area match the paper's evaluation set-up."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ergopose.sim.paths import PATH_CLEARANCE
from ergopose.sim.scene import (
    DEFAULT_SIZE,
    IMAGE_CIRCLE_THETA,
    LENS_REGIONS_DEG,
    PAPER_SIZE,
    default_scene,
    lens_region,
    rig_cameras,
)


@pytest.mark.parametrize("size", [DEFAULT_SIZE, PAPER_SIZE, (640, 480)])
def test_rig_geometry(size):
    cams = rig_cameras(*size)
    assert [c.name for c in cams] == ["cam_1", "cam_2"]
    c1, c2 = (c.position_world for c in cams)
    assert 2.9 <= c1[2] <= 3.05 and 2.9 <= c2[2] <= 3.05  # 3 m ceiling
    assert 1.4 <= np.linalg.norm((c1 - c2)[:2]) <= 1.6  # baseline about 1.5 m
    for cam in cams:
        assert cam.axis_world[2] < -0.99  # looking down, within 8 degrees
        # 95 degrees off-axis lands just inside the short side of the image: the image circle fits
        lens = cam.lens
        phi = np.linspace(0, 2 * np.pi, 72, endpoint=False)
        t = IMAGE_CIRCLE_THETA
        rim = lens.project(
            np.stack([np.sin(t) * np.cos(phi), np.sin(t) * np.sin(phi), np.full_like(phi, np.cos(t))], 1)
        )
        assert cam.in_image(rim).all()
        short = rim[:, 1] if size[1] <= size[0] else rim[:, 0]
        assert short.min() < 0.02 * min(size) and short.max() > 0.98 * min(size)
        assert cam.lens.max_theta > IMAGE_CIRCLE_THETA
    assert cams[0].lens != cams[1].lens  # two real cameras never share exact intrinsics


def test_whole_area_is_seen_by_both_cameras():
    scene = default_scene()
    x0, x1, y0, y1 = scene.area
    assert (x1 - x0, y1 - y0) == (6.0, 6.0)
    corners = np.array([[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (0.0, 1.95)])
    for cam in rig_cameras():
        pix = cam.project_world(corners)
        assert cam.in_image(pix).all()
        assert np.degrees(cam.theta_of_points_world(corners)).max() < 85


def test_reference_bars_are_1_5_m_and_in_their_lens_regions_for_both_cameras():
    scene = default_scene()
    names = [r[0] for r in LENS_REGIONS_DEG]
    assert sorted(b.intended_region for b in scene.bars) == sorted(names)
    for bar in scene.bars:
        assert bar.length == pytest.approx(1.5)
        samples = np.array(bar.end_a) + np.linspace(0, 1, 11)[:, None] * (np.array(bar.end_b) - np.array(bar.end_a))
        for cam in rig_cameras():
            regions = lens_region(cam.theta_of_points_world(samples))
            assert (regions == names.index(bar.intended_region)).all(), (bar.name, cam.name)


def test_stations_are_clear_of_furniture_and_inside_the_area():
    scene = default_scene()
    obstacles = scene.obstacles_xy()
    for st in scene.stations:
        x, y = st.position
        assert abs(x) < 2.75 and abs(y) < 2.75
        dist = [math.hypot(max(o[0] - x, 0, x - o[2]), max(o[1] - y, 0, y - o[3])) for o in obstacles]
        assert min(dist) >= PATH_CLEARANCE + 0.05, st.name


def test_lens_region_boundaries():
    theta = np.radians([0.0, 29.9, 30.0, 59.9, 60.0, 90.0, np.nan])
    assert lens_region(theta).tolist() == [0, 0, 1, 1, 2, 2, -1]
