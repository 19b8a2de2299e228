"""Inline SVG figures (report/svg.py, charts.py, time_charts.py, heat_maps.py, skeleton_drawing.py):
well-formed XML, text escaped, accessible, geometry against known answers."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pandas as pd
import pytest

from ergopose.ergonomics.body import BodyMeasurements, Posture, place_on_floor, pose_skeleton
from ergopose.keypoints import JOINT_INDEX
from ergopose.report import charts, heat_maps, skeleton_drawing, svg, time_charts
from ergopose.report.timelines import binned_scores
from ergopose.report.wording import BAND_COLOURS, LEVEL_COLOURS

NS = "{http://www.w3.org/2000/svg}"
EVIL = '</svg><script>alert("x")</script> & <b>'


def parse(markup) -> ET.Element:
    """The SVG as XML: a text that escaped badly would break the parse or add elements."""
    root = ET.fromstring(str(markup))
    assert root.tag == f"{NS}svg"
    assert root.get("role") == "img"
    ids = root.get("aria-labelledby").split()
    assert {e.get("id") for e in root.iter() if e.get("id")} >= set(ids)
    assert float(root.get("width")) > 0 and float(root.get("height")) > 0
    assert not any(e.tag.endswith("script") or e.tag.endswith("foreignObject") for e in root.iter())
    return root


def texts(root: ET.Element) -> list[str]:
    return ["".join(e.itertext()) for e in root.iter() if e.tag in (f"{NS}text", f"{NS}title", f"{NS}desc")]


def all_figures():
    seg = (charts.Segment(2.0, "#a6d96a", EVIL, EVIL), charts.Segment(1.0, None, "n/s", EVIL))
    starts = np.arange(10) * 60.0
    worst = np.array([1, 2, 3, np.nan, 7, 7, 5, 4, 3, 2], dtype=float)
    med = np.array([1, 1, 2, np.nan, 5, 6, 4, 3, 2, 1], dtype=float)
    joints = pose_skeleton(
        BodyMeasurements.from_stature(1.75), place_on_floor(BodyMeasurements.from_stature(1.75), Posture())
    )
    return {
        "stacked_bars": charts.stacked_bars([charts.StackRow(EVIL, seg)], title=EVIL, desc=EVIL, id_prefix="a"),
        "stacked_columns": charts.stacked_columns(
            [charts.StackColumn(EVIL, seg)],
            title=EVIL,
            desc=EVIL,
            id_prefix="b",
            y_max=60,
            y_label=EVIL,
            y_ticks=(0, 30, 60),
        ),
        "score_timeline": time_charts.score_timeline(
            starts,
            60.0,
            worst,
            med,
            [time_charts.Band(0.5, 4.5, "#a6d96a", EVIL), time_charts.Band(4.5, 7.5, "#d73027", EVIL)],
            y_min=0.5,
            y_max=7.5,
            x_ticks=[(0, EVIL)],
            title=EVIL,
            desc=EVIL,
            id_prefix="c",
            y_label=EVIL,
        ),
        "box_plots": charts.box_plots(
            [charts.BoxRow(EVIL, 1, 2, 3, 4, 5, 10), charts.BoxRow("none", *[math.nan] * 5, 0)],
            title=EVIL,
            desc=EVIL,
            id_prefix="d",
            unit=EVIL,
        ),
        "bar_panels": charts.bar_panels([EVIL, "b"], [(EVIL, [50.0, math.nan])], title=EVIL, desc=EVIL, id_prefix="e"),
        "heat_map": heat_maps.heat_map(
            np.array([[0.0, 2.0], [1.0, 0.0]]),
            (-3, 3, -3, 3),
            title=EVIL,
            desc=EVIL,
            id_prefix="f",
            unit=EVIL,
            outlines=[heat_maps.Outline(EVIL, -1, -1, 1, 1, EVIL)],
            markers=[heat_maps.Marker(EVIL, 0, 0)],
            presence=np.ones((2, 2)),
        ),
        "skeleton_views": skeleton_drawing.skeleton_views(joints, title=EVIL, desc=EVIL, id_prefix="g"),
    }


@pytest.mark.parametrize("name", list(all_figures()))
def test_text_is_escaped_and_svg_is_well_formed(name):
    markup = all_figures()[name]
    assert "<script" not in str(markup)
    root = parse(markup)
    found = texts(root)
    assert EVIL in found, f"{name}: the hostile text should survive as text"


def test_contrast_of_labels_on_level_colours():
    """Labels inside coloured segments meet WCAG AA (4.5:1) with the text colour chosen for them."""
    colours = {c for pal in LEVEL_COLOURS.values() for c in pal} | set(BAND_COLOURS) | set(heat_maps.HEAT_COLOURS)
    for c in colours:
        assert svg.contrast_ratio(c, svg.text_colour_on(c)) >= 4.5, c
    assert svg.contrast_ratio(svg.TEXT, "#ffffff") >= 4.5 and svg.contrast_ratio(svg.MUTED, "#ffffff") >= 4.5
    assert svg.contrast_ratio(svg.TEXT, svg.UNSCORED_FILL) >= 4.5


def test_contrast_ratio_known_values():
    assert svg.contrast_ratio("#000000", "#ffffff") == pytest.approx(21.0)
    assert svg.contrast_ratio("#777777", "#ffffff") == pytest.approx(4.48, abs=0.01)  # the classic AA near-miss


def test_stacked_bar_widths_are_proportional():
    root = parse(
        charts.stacked_bars(
            [charts.StackRow("r", (charts.Segment(3.0, "#a6d96a", "", "a"), charts.Segment(1.0, "#d73027", "", "b")))],
            title="t",
            desc="d",
            id_prefix="p",
            width=720,
            label_width=170,
        )
    )
    rects = [r for r in root.iter(f"{NS}rect") if r.find(f"{NS}title") is not None]
    w = [float(r.get("width")) for r in rects]
    assert w[0] / w[1] == pytest.approx(3.0, rel=1e-3)
    assert sum(w) == pytest.approx(720 - 170 - 16, abs=0.02)


def test_runs():
    assert time_charts._runs(np.array([0, 1, 1, 0, 1], bool)) == [(1, 3), (4, 5)]
    assert time_charts._runs(np.zeros(3, bool)) == []


def test_binned_scores_match_a_groupby():
    rng = np.random.default_rng(7)
    t = np.sort(rng.uniform(0, 3600, 20000))
    s = pd.Series(rng.integers(1, 8, t.size), dtype="Int16")
    s[rng.random(t.size) < 0.1] = pd.NA
    starts, worst, med = binned_scores(t, s, 3600.0, 60.0, 7)
    df = pd.DataFrame({"b": (t // 60).astype(int), "s": s.astype("float64")}).dropna()
    g = df.groupby("b")["s"]
    np.testing.assert_array_equal(worst, g.max().reindex(range(60)).to_numpy())
    # lower median of integers: the value at rank ceil(n/2)
    low_median = g.apply(lambda x: np.sort(x.to_numpy())[(len(x) + 1) // 2 - 1])
    np.testing.assert_array_equal(med, low_median.reindex(range(60)).to_numpy())
    np.testing.assert_array_equal(starts, np.arange(60) * 60.0)


def test_body_axes_of_a_worker_facing_plus_y():
    """Facing +y, the worker's right is +x: lateral (left to right) = +x, forward = +y."""
    m = BodyMeasurements.from_stature(1.8)
    joints = pose_skeleton(m, place_on_floor(m, Posture(heading=math.pi / 2, root_position=np.array([1.0, 2.0, 0]))))
    origin, lat, fwd = skeleton_drawing.body_axes(joints)
    np.testing.assert_allclose(lat, [1, 0, 0], atol=1e-9)
    np.testing.assert_allclose(fwd, [0, 1, 0], atol=1e-9)
    np.testing.assert_allclose(origin, [1, 2, 0], atol=1e-9)


def test_skeleton_front_view_puts_the_right_side_on_the_left_and_side_view_faces_right():
    m = BodyMeasurements.from_stature(1.75)
    joints = pose_skeleton(m, place_on_floor(m, Posture(heading=0.7, right_upper_arm_flexion=math.pi / 2)))
    root = parse(skeleton_drawing.skeleton_views(joints, title="t", desc="d", id_prefix="s"))
    labels = {e.text: float(e.get("x")) for e in root.iter(f"{NS}text") if e.text in ("L", "R")}
    # two views: the first L/R pair is the front view; find it by text position order
    xs = sorted((float(e.get("x")), e.text) for e in root.iter(f"{NS}text") if e.text in ("L", "R"))
    front = [t for x, t in xs if x < 180]
    assert front == ["R", "L"], xs
    side = [(x, t) for x, t in xs if x >= 180]
    # the right arm is raised forward: in the side view its wrist lies right of the left wrist
    assert dict((t, x) for x, t in side)["R"] > dict((t, x) for x, t in side)["L"]
    assert labels


def test_skeleton_with_missing_joints_and_without_any():
    m = BodyMeasurements.from_stature(1.75)
    joints = pose_skeleton(m, place_on_floor(m, Posture()))
    joints[JOINT_INDEX["left_wrist"]] = np.nan
    root = parse(skeleton_drawing.skeleton_views(joints, title="t", desc="d", id_prefix="s"))
    assert "L" not in [e.text for e in root.iter(f"{NS}text")]
    empty = parse(skeleton_drawing.skeleton_views(np.full((33, 3), np.nan), title="t", desc="d", id_prefix="s"))
    assert "skeleton not available" in texts(empty)


def test_heat_map_cells_and_legend():
    grid = np.zeros((24, 24))
    grid[3, 5] = 6.0
    grid[10, 10] = 1.0
    root = parse(heat_maps.heat_map(grid, (-3, 3, -3, 3), title="t", desc="d", id_prefix="h", unit="minutes"))
    cells = [r for r in root.iter(f"{NS}rect") if r.find(f"{NS}title") is not None]
    assert len(cells) == 2
    by_value = {r.find(f"{NS}title").text: r for r in cells}
    hot = by_value["6.0 minutes"]
    assert hot.get("fill") == heat_maps.HEAT_COLOURS[-1]
    # cell (iy=3, ix=5): x from -3 + 5 * 0.25 = -1.75 m; y top edge at -3 + 4 * 0.25 = -2.0 m
    size = 340
    assert float(hot.get("x")) == pytest.approx(30 + (5 * 0.25) * size / 6, abs=0.01)
    assert float(hot.get("y")) == pytest.approx(8 + (3 - (-2.0)) * size / 6, abs=0.01)


def test_skeleton_projection_of_known_points():
    """Hips 0.2 m apart along -x (the worker's right is -x), so the worker faces -y: a wrist at
    (1.3, 1.5, 1.2) is 0.3 m to the worker's left (drawn right of centre in the front view),
    0.5 m forward of the hips and 1.2 m high."""
    j = np.full((33, 3), np.nan)
    j[JOINT_INDEX["left_hip"]] = (1.1, 2.0, 0.9)
    j[JOINT_INDEX["right_hip"]] = (0.9, 2.0, 0.9)
    j[JOINT_INDEX["left_wrist"]] = (1.3, 1.5, 1.2)
    j[JOINT_INDEX["right_wrist"]] = (0.8, 2.2, 0.4)
    front, side, height = skeleton_drawing.skeleton_projection(j)
    lw, rw = JOINT_INDEX["left_wrist"], JOINT_INDEX["right_wrist"]
    np.testing.assert_allclose([front[lw], side[lw], height[lw]], [0.3, 0.5, 1.2], atol=1e-12)
    np.testing.assert_allclose([front[rw], side[rw], height[rw]], [-0.2, -0.2, 0.4], atol=1e-12)
    np.testing.assert_allclose(front[JOINT_INDEX["left_hip"]], 0.1, atol=1e-12)
    assert np.isnan(front[JOINT_INDEX["nose"]])
    # the drawing puts the points there: one scale for both views, heights up from the floor line
    root = parse(skeleton_drawing.skeleton_views(j, title="t", desc="d", id_prefix="k"))
    marks = [(e.text, float(e.get("x")), float(e.get("y"))) for e in root.iter(f"{NS}text") if e.text in ("L", "R")]
    assert [m[0] for m in marks] == ["L", "R", "L", "R"]  # front view, then side view
    for (_, lx, ly), (_, rx, ry), (dh, dz) in zip(
        marks[0::2], marks[1::2], ((0.3 - -0.2, 1.2 - 0.4), (0.5 - -0.2, 1.2 - 0.4))
    ):
        assert (lx - rx) / (ly - ry) == pytest.approx(-dh / dz, rel=1e-3)  # pixel y grows downwards
    assert skeleton_drawing.skeleton_projection(np.full((33, 3), np.nan)) is None


def test_risk_strips_draw_each_share():
    shares = np.array([[1.0, 0, 0, 0], [0.25, 0.25, 0.25, 0.25], [0, 0, 0, 0]])
    root = parse(
        time_charts.risk_strips(
            [time_charts.StripRow(EVIL, shares)],
            60.0,
            x_ticks=[(0, "06:00")],
            title=EVIL,
            desc=EVIL,
            id_prefix="r",
            legend=("high", "medium", "low", "not scored", "not tracked"),
            marks=[(0.0, 60.0, "1")],
            width=400,
            label_width=100,
        )
    )
    assert EVIL in texts(root)
    paths = {p.find(f"{NS}title").text: p.get("d") for p in root.iter(f"{NS}path") if p.find(f"{NS}title") is not None}
    # bin width (400 - 100 - 10) / 3; the high path: a full bin, then a quarter of the next
    # strips start 20 px down (under the period brackets)
    assert paths["high"] == "M100 20h96.67v16h-96.67ZM196.67 20h96.67v4h-96.67Z"
    assert paths["not scored"].startswith("M196.67 32h96.67v4")
    assert "medium" in paths and "low" in paths
