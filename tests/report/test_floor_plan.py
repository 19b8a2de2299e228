"""A session's floor.toml (docs/session-format.md) read into the report's floor plan."""

from __future__ import annotations

import pytest

from ergopose.errors import ConfigError
from ergopose.report.adapters import load_floor_plan

GOOD = """area_m = [-4.0, 5.0, -2.0, 3.5]

[[boxes]]
name = "shelf_north"
kind = "shelf"
lo = [-2.6, 2.55, 0.0]
hi = [2.6, 2.95, 2.0]
colour_bgr = [150, 96, 40]

[[boxes]]
name = "table_leg1"
kind = "table_leg"
lo = [0.0, 0.0, 0.0]
hi = [0.05, 0.05, 0.86]

[[boxes]]
name = "bench_top"
kind = "table_top"
lo = [1.0, -1.5, 0.86]
hi = [2.2, -0.7, 0.9]
"""


def test_area_furniture_and_cameras(tmp_path):
    path = tmp_path / "floor.toml"
    path.write_text(GOOD)
    plan = load_floor_plan(path, cameras=[("cam_1", -0.75, 0.0), ("cam_2", 0.75, 0.0)])
    assert (plan.x_min, plan.x_max, plan.y_min, plan.y_max) == (-4.0, 5.0, -2.0, 3.5)
    # table legs are not drawn; the table top is drawn as a table
    assert [(f.name, f.kind, f.x0, f.y0, f.x1, f.y1) for f in plan.furniture] == [
        ("shelf_north", "shelf", -2.6, 2.55, 2.6, 2.95),
        ("bench_top", "table", 1.0, -1.5, 2.2, -0.7),
    ]
    assert [(c.name, c.x, c.y) for c in plan.cameras] == [("cam_1", -0.75, 0.0), ("cam_2", 0.75, 0.0)]


def test_no_area_is_six_by_six_metres(tmp_path):
    path = tmp_path / "floor.toml"
    path.write_text("")
    plan = load_floor_plan(path)
    assert (plan.x_min, plan.x_max, plan.y_min, plan.y_max, plan.furniture) == (-3.0, 3.0, -3.0, 3.0, ())


@pytest.mark.parametrize(
    "text, message",
    [
        ("area_m = [3.0, -3.0, -3.0, 3.0]", "area_m: expected [x_min, x_max, y_min, y_max]"),
        ("area_m = [0, 1, 2]", "area_m: expected"),
        ("boxes = 3", "boxes: expected [[boxes]] tables"),
        ('[[boxes]]\nname = "a"\nlo = [0, 0, 0]\nhi = [1, 1, 1]', "boxes[0].kind: expected a text kind, got None"),
        ('[[boxes]]\nname = "a"\nkind = "shelf"\nlo = [0, 0, "x"]\nhi = [1, 1, 1]', "boxes[0].lo: expected [x, y, z]"),
        ("area_m = [", "cannot read the floor plan"),
    ],
)
def test_a_wrong_file_is_one_message_naming_file_and_key(tmp_path, text, message):
    path = tmp_path / "floor.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_floor_plan(path)
    assert str(err.value).startswith(str(path)) and message in str(err.value)
