"""The search views of a camera are built once per process (ergopose/pose/search.py, ``_BUILT``):
a stage made again for the same camera (every chunk of a video makes its stages anew) reuses the
maps, which are the maps a fresh build gives and cannot be written; a camera, detector size or
search setting that differs gets its own."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ergopose.geometry.camera import Camera
from ergopose.pose import search as S
from ergopose.pose.settings import PoseSettings
from ergopose.sim.scene import rig_cameras

SIZE = (224, 224)


@pytest.fixture(autouse=True)
def empty_cache(monkeypatch):
    monkeypatch.setattr(S, "_BUILT", type(S._BUILT)())


def _maps(views: S.SearchViews) -> list[S.ViewMap]:
    return [m for _, m in views.views]


def test_a_camera_equal_in_value_reuses_the_maps_a_fresh_build_gives():
    first = S.SearchViews(rig_cameras(1024, 768)[0], SIZE, PoseSettings())
    again = S.SearchViews(rig_cameras(1024, 768)[0], SIZE, PoseSettings())  # another object, same values
    assert again.camera is not first.camera and again.camera == first.camera
    assert len(first.views) > 20
    assert all(a is b for a, b in zip(_maps(again), _maps(first), strict=True))
    assert again.layout is first.layout
    np.testing.assert_array_equal(again.half_fov, first.half_fov)
    # The shared maps cannot be changed by one stage under another.
    with pytest.raises(ValueError, match="read-only"):
        _maps(again)[0].map_x[0, 0] = 1.0
    # They are the maps a build from nothing gives.
    S._BUILT.clear()
    fresh = S.SearchViews(rig_cameras(1024, 768)[0], SIZE, PoseSettings())
    assert all(a is not b for a, b in zip(_maps(fresh), _maps(first), strict=True))
    for (view_a, map_a), (view_b, map_b) in zip(fresh.views, first.views, strict=True):
        np.testing.assert_array_equal(view_a.rotation_cam_from_view, view_b.rotation_cam_from_view)
        np.testing.assert_array_equal(map_a.map_x, map_b.map_x)
        np.testing.assert_array_equal(map_a.fixed1, map_b.fixed1)
    # Each stage keeps its own schedule.
    first.scheduled(4, 0)
    assert first.scheduled(4, 1) != [] and again.scheduled(4, 0) == list(range(len(again.views)))


def test_a_different_camera_size_or_search_setting_gets_its_own_maps():
    base = rig_cameras(1024, 768)[0]
    built = S.SearchViews(base, SIZE, PoseSettings())
    lower = dataclasses.replace(base, position_world=base.position_world - np.array([0.0, 0.0, 0.5]))
    other_lens = rig_cameras(1024, 768)[1]
    assert isinstance(lower, Camera) and lower != base and other_lens != base
    for variant in (
        S.SearchViews(lower, SIZE, PoseSettings()),
        S.SearchViews(other_lens, SIZE, PoseSettings()),
        S.SearchViews(base, (192, 192), PoseSettings()),
        S.SearchViews(base, SIZE, PoseSettings(search_max_distance=PoseSettings().search_max_distance + 1.0)),
        S.SearchViews(base, SIZE, PoseSettings(search_layout="fixed")),
    ):
        assert not any(m is n for m in _maps(variant) for n in _maps(built))
    assert len(S._BUILT) == 6
    # A setting that does not shape the views (not search_*) shares them.
    shared = S.SearchViews(base, SIZE, PoseSettings(coast_frames=PoseSettings().coast_frames + 3))
    assert all(a is b for a, b in zip(_maps(shared), _maps(built), strict=True))


def test_the_least_recently_used_camera_goes_beyond_the_memory_budget(monkeypatch):
    cams = rig_cameras(1024, 768)
    one = S.SearchViews(cams[0], SIZE, PoseSettings())
    per_camera = S._map_bytes((one.layout, tuple(one.views), one.half_fov))
    assert 30e6 < per_camera < 45e6  # 48 views of 224 x 224: the figure in the module's comment
    monkeypatch.setattr(S, "_BUILT_MAX_BYTES", int(1.5 * per_camera))
    S.SearchViews(cams[1], SIZE, PoseSettings())
    assert [key[0] for key in S._BUILT] == [cams[1]]
    # Over the budget with one camera alone, the newest stays.
    monkeypatch.setattr(S, "_BUILT_MAX_BYTES", 1)
    S.SearchViews(cams[0], SIZE, PoseSettings())
    assert [key[0] for key in S._BUILT] == [cams[0]]
