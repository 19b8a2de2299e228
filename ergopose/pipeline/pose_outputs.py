"""What ``ergopose pose --out DIR`` writes beside the CSV file: the keypoint table as Parquet, as
COCO-style JSON, and an overlay (the frames with the skeletons drawn) for checking by eye.

The table is :data:`ergopose.pipeline.pose_video.POSE_COLUMNS`, one row per frame, person and
keypoint, pixels in the camera's own image (docs/pose-command.md, "Output folder").
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pandas as pd

from ergopose.atomic import atomic_path
from ergopose.keypoints import BLAZEPOSE33, JOINT_INDEX, LIMB_INDEX, NUM_JOINTS
from ergopose.video import open_video_writer

#: The lines of a drawn skeleton (pairs of BLAZEPOSE33 indices): the limbs of keypoints.LIMBS,
#: the ankle to heel and toe, and the face from the nose through the eyes to the ears. The same
#: pairs, counted from 1, are the COCO category's ``skeleton``.
SKELETON: tuple[tuple[int, int], ...] = tuple((int(a), int(b)) for a, b in LIMB_INDEX) + tuple(
    (JOINT_INDEX[a], JOINT_INDEX[b])
    for a, b in (
        ("left_ankle", "left_heel"),
        ("right_ankle", "right_heel"),
        ("left_ankle", "left_foot_index"),
        ("right_ankle", "right_foot_index"),
        ("nose", "left_eye"),
        ("nose", "right_eye"),
        ("left_eye", "left_ear"),
        ("right_eye", "right_ear"),
    )
)

#: COCO's category of the keypoints (one category: a person with BlazePose's 33 points).
COCO_CATEGORY_ID = 1

# Colours (BGR): the person's left side, right side, and the points between.
_LEFT = (255, 160, 0)
_RIGHT = (0, 140, 255)
_MIDDLE = (240, 240, 240)
_DOUBTED = (160, 160, 160)


def _side(index: int) -> str:
    name = BLAZEPOSE33[index]
    return "left" if name.startswith("left_") else "right" if name.startswith("right_") else "middle"


_POINT_SIDE = tuple(_side(j) for j in range(NUM_JOINTS))


@dataclass(frozen=True)
class PosePeople:
    """The people of one frame as arrays: pixels (P, 33, 2) in the camera's image (NaN = not
    placed), confidence (P, 33) 0-1, uncertain (P, 33) bool (side in doubt)."""

    pixels: np.ndarray
    confidence: np.ndarray
    uncertain: np.ndarray

    @property
    def count(self) -> int:
        return int(self.pixels.shape[0])


def people_of_frames(table: pd.DataFrame) -> dict[int, PosePeople]:
    """The keypoint table regrouped per frame (frames without people are absent)."""
    out: dict[int, PosePeople] = {}
    if table.empty:
        return out
    t = table.sort_values(["frame", "person"], kind="stable")
    joint = t["joint"].map(JOINT_INDEX).to_numpy()
    frames = t["frame"].to_numpy()
    persons = t["person"].to_numpy()
    keys = np.stack([frames, persons], axis=1)
    uniq, row_of = np.unique(keys, axis=0, return_inverse=True)
    row_of = row_of.reshape(-1)
    P = len(uniq)
    pixels = np.full((P, NUM_JOINTS, 2), np.nan)
    conf = np.zeros((P, NUM_JOINTS))
    doubted = np.zeros((P, NUM_JOINTS), bool)
    pixels[row_of, joint, 0] = t["x_px"].to_numpy(dtype=float)
    pixels[row_of, joint, 1] = t["y_px"].to_numpy(dtype=float)
    conf[row_of, joint] = t["confidence"].to_numpy(dtype=float)
    doubted[row_of, joint] = t["left_right_uncertain"].to_numpy() == 1
    for f in np.unique(uniq[:, 0]):
        rows = np.flatnonzero(uniq[:, 0] == f)
        out[int(f)] = PosePeople(pixels[rows], conf[rows], doubted[rows])
    return out


def write_pose_parquet(path: str | os.PathLike[str], table: pd.DataFrame) -> Path:
    """The keypoint table as Parquet (the CSV's columns and types), written atomically."""
    with atomic_path(path) as tmp:
        table.to_parquet(tmp, index=False)
    return Path(path)


@dataclass(frozen=True)
class CocoImage:
    """One frame of the COCO document: its index in the video (or folder), time, file name and
    size."""

    frame: int
    time_s: float
    file_name: str
    width: int
    height: int


@dataclass(frozen=True)
class CocoSource:
    """What the COCO document says of where its keypoints come from."""

    description: str
    model: str
    min_confidence: float
    extra: dict[str, Any] = field(default_factory=dict)


def coco_document(table: pd.DataFrame, images: list[CocoImage], source: CocoSource) -> dict[str, Any]:
    """The keypoints in the layout of COCO's person-keypoint annotations.

    ``images``: every frame processed (an image id is the frame index; frames without people have
    no annotation). Each person-frame is an annotation: ``keypoints`` [x1, y1, v1, ..., x33, y33,
    v33] in BLAZEPOSE33 order, with v = 2 for a point placed with confidence >= ``min_confidence``
    (the model card's keypoint gate), 1 placed below it, 0 not placed (x = y = 0: outside the
    lens); ``num_keypoints`` the points with v = 2; ``bbox`` [x, y, w, h] and ``area`` of the
    placed points; ``score`` their mean confidence; and, beyond COCO, ``person`` (numbered within
    the frame as in the CSV), ``keypoint_scores`` (33 confidences) and ``left_right_uncertain``
    (33 flags, 1 = that point's side in doubt)."""
    by_frame = people_of_frames(table)
    annotations: list[dict[str, Any]] = []
    for frame in sorted(by_frame):
        people = by_frame[frame]
        for person in range(people.count):
            xy = people.pixels[person]
            conf = people.confidence[person]
            placed = np.isfinite(xy).all(axis=1)
            vis = np.where(placed, np.where(conf >= source.min_confidence, 2, 1), 0)
            flat = np.column_stack([np.where(placed[:, None], xy, 0.0), vis]).reshape(-1)
            if placed.any():
                lo, hi = xy[placed].min(axis=0), xy[placed].max(axis=0)
                bbox = [round(float(lo[0]), 2), round(float(lo[1]), 2)] + [round(float(v), 2) for v in hi - lo]
                score = float(conf[placed].mean())
            else:
                bbox, score = [0.0, 0.0, 0.0, 0.0], 0.0
            annotations.append(
                {
                    "id": len(annotations) + 1,
                    "image_id": int(frame),
                    "category_id": COCO_CATEGORY_ID,
                    "person": person,
                    "keypoints": [round(float(v), 2) if k % 3 < 2 else int(v) for k, v in enumerate(flat)],
                    "num_keypoints": int(np.count_nonzero(vis == 2)),
                    "keypoint_scores": [round(float(c), 4) for c in conf],
                    "left_right_uncertain": [int(u) for u in people.uncertain[person]],
                    "bbox": bbox,
                    "area": round(bbox[2] * bbox[3], 2),
                    "score": round(score, 4),
                    "iscrowd": 0,
                }
            )
    return {
        "info": {
            "description": source.description,
            "model": source.model,
            "visibility": (
                f"v = 2: placed with confidence >= {source.min_confidence:g}; 1: placed below it; 0: not placed"
            ),
            **source.extra,
        },
        "images": [
            {
                "id": im.frame,
                "file_name": im.file_name,
                "width": im.width,
                "height": im.height,
                "frame": im.frame,
                "time_s": round(im.time_s, 4),
            }
            for im in images
        ],
        "annotations": annotations,
        "categories": [
            {
                "id": COCO_CATEGORY_ID,
                "name": "person",
                "supercategory": "person",
                "keypoints": list(BLAZEPOSE33),
                "skeleton": [[a + 1, b + 1] for a, b in SKELETON],
            }
        ],
    }


def write_pose_coco(path: str | os.PathLike[str], document: dict[str, Any]) -> Path:
    """The COCO document as JSON (UTF-8), written atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(document, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    return Path(path)


def draw_people(image: np.ndarray, people: PosePeople, min_confidence: float) -> np.ndarray:
    """The image (BGR, not changed) with each person's skeleton drawn on a copy: the person's left
    side blue, the right orange, the points between white; a line or point below ``min_confidence``
    thin and grey, a point whose side is in doubt grey; the person's number at the top of its
    points."""
    out = image.copy()
    scale = max(1.0, math.hypot(*image.shape[:2]) / 1500.0)
    thick = max(1, int(round(2 * scale)))
    radius = max(2, int(round(3 * scale)))
    colours = {"left": _LEFT, "right": _RIGHT, "middle": _MIDDLE}
    for person in range(people.count):
        xy = people.pixels[person]
        conf = people.confidence[person]
        placed = np.isfinite(xy).all(axis=1)
        sure = placed & (conf >= min_confidence)
        for a, b in SKELETON:
            if not (placed[a] and placed[b]):
                continue
            both = bool(sure[a] and sure[b])
            side = _POINT_SIDE[a] if _POINT_SIDE[a] == _POINT_SIDE[b] else "middle"
            colour = colours[side] if both else _DOUBTED
            p, q = (tuple(int(round(float(v))) for v in xy[k]) for k in (a, b))
            cv2.line(out, p, q, colour, thick if both else 1, cv2.LINE_AA)
        for j in np.flatnonzero(placed):
            colour = _DOUBTED if (people.uncertain[person, j] or not sure[j]) else colours[_POINT_SIDE[j]]
            centre = tuple(int(round(float(v))) for v in xy[j])
            cv2.circle(out, centre, radius, colour, -1 if sure[j] else 1, cv2.LINE_AA)
        if placed.any():
            top = xy[placed][np.argmin(xy[placed][:, 1])]
            cv2.putText(
                out,
                str(person),
                (int(top[0]) + radius, max(int(top[1]) - 2 * radius, 10)),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.5 * scale,
                _MIDDLE,
                thick,
                cv2.LINE_AA,
            )
    return out


#: Grey level of the overlay's frame for a frame that could not be read.
UNREAD_GREY = 40


def unread_frame(index: int, width: int, height: int) -> np.ndarray:
    """A dark frame saying that frame ``index`` could not be read (BGR)."""
    out = np.full((height, width, 3), UNREAD_GREY, np.uint8)
    scale = max(0.5, min(width, height) / 800.0)
    cv2.putText(
        out,
        f"frame {index}: could not be read",
        (int(0.05 * width), height // 2),
        cv2.FONT_HERSHEY_SIMPLEX,
        scale,
        (200, 200, 200),
        max(1, int(round(2 * scale))),
        cv2.LINE_AA,
    )
    return out


class OverlayVideo:
    """The overlay of a video: every frame, with its people drawn (a frame that could not be read
    as a dark frame saying so), into one mp4v file (the caller writes it under a temporary name:
    ``ergopose pose`` builds its whole output folder aside)."""

    def __init__(self, path: str | os.PathLike[str], fps: float, width: int, height: int, min_confidence: float):
        self.path = Path(path)
        self.min_confidence = min_confidence
        self.writer = open_video_writer(self.path, fps, width, height)
        self.width, self.height = int(width), int(height)
        self.frames = 0

    def add(self, index: int, image: np.ndarray | None, people: PosePeople | None) -> None:
        """One frame with its people drawn; a frame that could not be read (``image`` None) as a
        dark frame saying so, so that the overlay keeps the video's frames and times."""
        if image is None or people is None:
            self.writer.write(unread_frame(index, self.width, self.height))
        else:
            self.writer.write(draw_people(image, people, self.min_confidence))
        self.frames += 1

    def close(self) -> None:
        self.writer.release()


class OverlayImages:
    """The overlay of a folder of images: each image read, with its people drawn, as a JPEG of the
    same name in ``folder``."""

    def __init__(self, folder: str | os.PathLike[str], names: list[str], min_confidence: float):
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.names = names
        self.min_confidence = min_confidence
        self.frames = 0

    def add(self, index: int, image: np.ndarray | None, people: PosePeople | None) -> None:
        """The image with its people drawn, as NAME.jpg; nothing for an image that could not be read."""
        if image is None or people is None:
            return
        path = self.folder / (Path(self.names[index]).stem + ".jpg")
        if not cv2.imwrite(str(path), draw_people(image, people, self.min_confidence), [cv2.IMWRITE_JPEG_QUALITY, 90]):
            raise OSError(f"cannot write {path}")
        self.frames += 1

    def close(self) -> None:
        return None
