"""The outputs of ``ergopose pose --out DIR`` beside the CSV file: the COCO-style document, the
table regrouped per frame, and the skeletons drawn (ergopose/pipeline/pose_outputs.py), checked
against tables written by hand."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from ergopose.keypoints import BLAZEPOSE33, JOINT_INDEX, NUM_JOINTS
from ergopose.pipeline.pose_outputs import (
    SKELETON,
    UNREAD_GREY,
    OverlayImages,
    OverlayVideo,
    CocoImage,
    CocoSource,
    PosePeople,
    coco_document,
    draw_people,
    people_of_frames,
    write_pose_coco,
    write_pose_parquet,
)
from ergopose.pipeline.pose_video import POSE_COLUMNS, pose_frames
from ergopose.pose.settings import PoseSettings
from ergopose.sim.scene import rig_cameras
from ergopose.video import UNDECODABLE, read_frames


def _table(people: dict[tuple[int, int], np.ndarray], conf: float = 0.9) -> pd.DataFrame:
    """Rows as the command writes them for {(frame, person): (33, 2) pixels}; NaN = not placed."""
    rows = []
    for (frame, person), xy in people.items():
        for j, name in enumerate(BLAZEPOSE33):
            placed = bool(np.isfinite(xy[j]).all())
            c = (0.3 if name.startswith("right_") else conf) if placed else 0.0
            rows.append((frame, frame / 10.0, person, name, xy[j, 0], xy[j, 1], c, int(name == "left_wrist")))
    return pd.DataFrame(rows, columns=list(POSE_COLUMNS))


def _person(x0: float, y0: float) -> np.ndarray:
    rng = np.random.default_rng(5)
    return np.array([x0, y0]) + rng.uniform(0.0, 100.0, (NUM_JOINTS, 2))


def test_the_coco_document_holds_every_person_frame_as_coco_lays_it_out():
    a, b, c = _person(10.0, 20.0), _person(300.0, 40.0), _person(50.0, 60.0)
    c[JOINT_INDEX["nose"]] = np.nan  # outside the lens
    table = _table({(0, 0): a, (0, 1): b, (2, 0): c})
    images = [CocoImage(f, f / 10.0, f"cam#{f}", 640, 480) for f in (0, 1, 2)]
    doc = coco_document(table, images, CocoSource("test", "BlazePose full", 0.5))
    assert [im["id"] for im in doc["images"]] == [0, 1, 2] and doc["images"][2]["file_name"] == "cam#2"
    assert [(x["image_id"], x["person"]) for x in doc["annotations"]] == [(0, 0), (0, 1), (2, 0)]
    assert [x["id"] for x in doc["annotations"]] == [1, 2, 3]
    cat = doc["categories"][0]
    assert cat["keypoints"] == list(BLAZEPOSE33) and len(cat["skeleton"]) == len(SKELETON)
    assert all(1 <= i <= NUM_JOINTS for pair in cat["skeleton"] for i in pair)
    for ann, xy in zip(doc["annotations"], (a, b, c)):
        k = np.array(ann["keypoints"], float).reshape(NUM_JOINTS, 3)
        placed = np.isfinite(xy).all(axis=1)
        right = np.array([n.startswith("right_") for n in BLAZEPOSE33])
        # v: 2 at or above the gate, 1 placed below it (the right side's 0.3 here), 0 not placed.
        assert (k[:, 2] == np.where(placed, np.where(right, 1, 2), 0)).all()
        assert np.allclose(k[placed, :2], xy[placed], atol=0.005) and (k[~placed, :2] == 0).all()
        assert ann["num_keypoints"] == int((placed & ~right).sum())
        lo, hi = xy[placed].min(axis=0), xy[placed].max(axis=0)
        assert ann["bbox"] == pytest.approx([lo[0], lo[1], hi[0] - lo[0], hi[1] - lo[1]], abs=0.01)
        assert ann["area"] == pytest.approx((hi - lo).prod(), rel=1e-3)
        assert ann["score"] == pytest.approx(np.where(right, 0.3, 0.9)[placed].mean(), abs=1e-4)
        assert ann["left_right_uncertain"] == [int(n == "left_wrist") for n in BLAZEPOSE33]
        assert ann["category_id"] == cat["id"] and ann["iscrowd"] == 0


def test_the_document_is_json_and_the_parquet_file_the_table(tmp_path):
    table = _table({(3, 0): _person(0.0, 0.0)})
    doc = coco_document(table, [CocoImage(3, 0.3, "x.png", 100, 100)], CocoSource("t", "m", 0.5))
    path = write_pose_coco(tmp_path / "k.coco.json", doc)
    assert json.loads(path.read_text()) == json.loads(json.dumps(doc))
    back = pd.read_parquet(write_pose_parquet(tmp_path / "k.parquet", table))
    pd.testing.assert_frame_equal(back, table)
    empty = coco_document(table.iloc[:0], [], CocoSource("t", "m", 0.5))
    assert empty["annotations"] == [] and empty["images"] == []


def test_people_of_frames_puts_each_row_back_in_its_place():
    a, b = _person(10.0, 20.0), _person(300.0, 40.0)
    table = _table({(4, 1): b, (4, 0): a}).sample(frac=1.0, random_state=3)  # any row order
    people = people_of_frames(table)
    assert list(people) == [4] and people[4].count == 2
    assert np.allclose(people[4].pixels[0], a) and np.allclose(people[4].pixels[1], b)
    assert people[4].uncertain[0, JOINT_INDEX["left_wrist"]] and people[4].uncertain.sum() == 2


def test_a_drawn_skeleton_lies_on_its_keypoints_sides_coloured():
    image = np.zeros((200, 200, 3), np.uint8)
    xy = np.full((NUM_JOINTS, 2), np.nan)
    points = {
        "left_shoulder": (60, 50),
        "right_shoulder": (140, 50),
        "left_elbow": (60, 150),
        "right_elbow": (140, 150),
    }
    for name, p in points.items():
        xy[JOINT_INDEX[name]] = p
    conf = np.where(np.isfinite(xy).all(axis=1), 0.9, 0.0)
    conf[JOINT_INDEX["right_elbow"]] = 0.2  # below the gate: a thin grey line, a hollow point
    drawn = draw_people(image, PosePeople(xy[None], conf[None], np.zeros((1, NUM_JOINTS), bool)), 0.5)
    assert image.max() == 0  # the image itself is left alone
    b, g, r = (int(v) for v in drawn[100, 60])  # the left upper arm: blue
    assert b > 200 and r < 50
    b, g, r = (int(v) for v in drawn[100, 140])  # the right upper arm, to a doubtful elbow: grey
    assert abs(b - r) < 30 and 100 < b < 200
    assert drawn[50, 100].min() > 200  # the shoulder line: white
    assert drawn[100, 100].max() == 0 and drawn[190, 10].max() == 0  # nothing between the arms or far off
    nothing = draw_people(
        image, PosePeople(np.zeros((0, NUM_JOINTS, 2)), np.zeros((0, NUM_JOINTS)), np.zeros((0, NUM_JOINTS), bool)), 0.5
    )
    assert (nothing == image).all()


class _NobodyDetector:
    input_size = (224, 224)

    def __call__(self, image):
        return []


class _NoLandmarker:
    input_size = (256, 256)

    def __call__(self, image):  # pragma: no cover - nothing is found, so no view is run
        raise AssertionError("no view should be run")


def test_the_overlay_video_keeps_every_frame_a_frame_that_could_not_be_read_shown_as_such(tmp_path):
    camera = rig_cameras(320, 240)[0]
    frames = [np.full((240, 320, 3), 90 + 40 * k, np.uint8) for k in range(3)]
    source = [(0, frames[0], ""), (1, None, UNDECODABLE), (2, frames[2], "")]
    overlay = OverlayVideo(tmp_path / "overlay.mp4", 5.0, 320, 240, 0.5)
    result = pose_frames(
        source, "v.mp4", camera, 5.0, 0, 3, _NoLandmarker(), _NobodyDetector(), PoseSettings(), None, overlay.add
    )
    overlay.close()
    assert list(result.people) == [0, -1, 0] and overlay.frames == 3
    back = [f for _, f in read_frames(tmp_path / "overlay.mp4", 0, 3)]
    assert len(back) == 3
    # The read frames as they were (nobody to draw), the unread one dark with its line of text.
    assert abs(float(back[0].mean()) - 90) < 6 and abs(float(back[2].mean()) - 170) < 6  # the codec: a few levels
    assert np.median(back[1]) == pytest.approx(UNREAD_GREY, abs=3) and back[1].max() > 150
    images = OverlayImages(tmp_path / "overlay", ["a.png", "b.png"], 0.5)
    images.add(1, None, None)  # an image that could not be read gives no overlay image
    assert list((tmp_path / "overlay").iterdir()) == []
