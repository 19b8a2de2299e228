"""``ergopose pose``: the 2D stage alone on one video, keypoints per frame into a CSV file.

No session, no second camera: the camera (from a calibration file or a nominal one built from
the image, :mod:`ergopose.geometry.image_circle`) gives the lens and which way is up, and the
fisheye 2D stage (:class:`ergopose.pose.fisheye.FisheyePoseEstimator`, which works for any lens
model) finds and follows the people frame by frame. The table is tidy: one row per frame,
person and keypoint, pixels in the video's own pixels (docs/pose-command.md).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable

import numpy as np
import pandas as pd

from ergopose.atomic import atomic_path
from ergopose.errors import InputError
from ergopose.geometry.camera import Camera
from ergopose.geometry.image_circle import CircleSearch, find_image_circle, max_image
from ergopose.keypoints import BLAZEPOSE33, NUM_JOINTS
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.pose.records import Detector, Landmarker
from ergopose.pose.settings import PoseSettings
from ergopose.progress import ProgressCallback, report, warn
from ergopose.pipeline.pose_outputs import PosePeople
from ergopose.video import read_frames, read_frames_checked, read_images_checked

#: What ``on_frame`` is given: the frame's index, the image (BGR) and its people; None and None
#: for a frame that could not be read.
FrameSink = Callable[[int, np.ndarray | None, PosePeople | None], None]

#: The CSV's columns, in order.
POSE_COLUMNS: tuple[str, ...] = (
    "frame",
    "time_s",
    "person",
    "joint",
    "x_px",
    "y_px",
    "confidence",
    "left_right_uncertain",
)

#: Frames sampled through the video for the image circle's maximum image.
CIRCLE_SAMPLES = 24


@dataclass(frozen=True)
class PoseVideoResult:
    """What :func:`pose_video` found.

    table: the keypoints (columns POSE_COLUMNS), frame by frame, person by person.
    people: (frames,) int, people found per frame of the range; -1 a frame that could not be read.
    start, stop: the frames processed, start .. stop-1.
    capped_frames: frames where the stage reached ``max_people``.
    upright_checks, upright_disputed: person views turned from upright that were run again
        upright (``PoseSettings.left_right_upright_check``), and of those the ones whose upright
        view labelled the sides the other way round (their sides doubted).
    """

    table: pd.DataFrame
    people: np.ndarray
    start: int
    stop: int
    capped_frames: int
    upright_checks: int = 0
    upright_disputed: int = 0

    @property
    def frames_read(self) -> int:
        return int(np.count_nonzero(self.people >= 0))

    @property
    def uncertain_person_frames(self) -> int:
        """Person-frames with a keypoint whose side the stage doubted (``left_right_uncertain``)."""
        t = self.table
        return int(t.loc[t["left_right_uncertain"] == 1, ["frame", "person"]].drop_duplicates().shape[0])

    @property
    def frames_with_people(self) -> int:
        return int(np.count_nonzero(self.people > 0))


def _circle_picks(start: int, stop: int, samples: int) -> np.ndarray:
    return np.unique(np.linspace(start, stop - 1, min(samples, stop - start)).round().astype(int))


def circle_from_video(
    path: str | os.PathLike[str], start: int, stop: int, samples: int = CIRCLE_SAMPLES
) -> CircleSearch:
    """The image circle seen in up to ``samples`` frames spread evenly over start .. stop-1."""
    frames = (frame for i in _circle_picks(start, stop, samples) for _, frame in read_frames(path, int(i), int(i) + 1))
    return find_image_circle(max_image(frames))


def circle_from_images(
    paths: list[Path], start: int, stop: int, size: tuple[int, int], samples: int = CIRCLE_SAMPLES
) -> CircleSearch:
    """The image circle seen in up to ``samples`` of the images start .. stop-1 (unreadable ones
    and ones of another size left out)."""
    picks = _circle_picks(start, stop, samples)
    frames = (
        image
        for i in picks
        for _, image, _ in read_images_checked(paths, int(i), int(i) + 1, size)
        if image is not None
    )
    try:
        brightest = max_image(frames)
    except ValueError:  # none readable
        raise InputError(
            f"none of the {len(picks)} images sampled for the image circle could be read", path=paths[0].parent
        ) from None
    return find_image_circle(brightest)


def pose_video(
    path: str | os.PathLike[str],
    camera: Camera,
    fps: float,
    start: int,
    stop: int,
    landmarker: Landmarker,
    detector: Detector | None,
    settings: PoseSettings = PoseSettings(),
    progress: ProgressCallback | None = None,
    on_frame: FrameSink | None = None,
) -> PoseVideoResult:
    """The 2D stage on frames start .. stop-1 of one video. Frames that cannot be decoded are
    skipped (counted in ``people`` as -1, and told through ``progress``); reaching
    ``settings.max_people`` is told once, naming the camera and the setting. ``on_frame`` is
    given every frame, with its people, or None and None where it could not be read (the overlay
    of ``ergopose pose``)."""
    frames = read_frames_checked(path, start, stop)
    return pose_frames(frames, path, camera, fps, start, stop, landmarker, detector, settings, progress, on_frame)


def pose_frames(
    frames: Iterable[tuple[int, np.ndarray | None, str]],
    source: str | os.PathLike[str],
    camera: Camera,
    fps: float,
    start: int,
    stop: int,
    landmarker: Landmarker,
    detector: Detector | None,
    settings: PoseSettings,
    progress: ProgressCallback | None,
    on_frame: FrameSink | None,
) -> PoseVideoResult:
    """The 2D stage on (index, image or None, why) frames start .. stop-1 of ``source``: a video's
    (:func:`ergopose.video.read_frames_checked`, as :func:`pose_video` runs it) or a folder's
    images taken as one camera's frames at ``fps`` (:func:`ergopose.video.read_images_checked`:
    an image that cannot be read or has another size is skipped as a frame that cannot be
    decoded)."""
    stage = FisheyePoseEstimator(camera, 0, landmarker, detector, settings, progress=progress)
    count = stop - start
    people = np.zeros(count, np.int64)
    found_frames, persons, pixels, confidence, uncertain = [], [], [], [], []
    for k, (index, image, problem) in enumerate(frames):
        if image is None:
            people[k] = -1  # why: problem, one of ergopose.video.SKIP_CODES
            if on_frame is not None:
                on_frame(index, None, None)
        else:
            found = stage.process(image, index)
            people[k] = found.count
            xy = found.pixels_fisheye
            conf = np.where(np.isfinite(xy).all(axis=-1), found.confidence, 0.0)  # none outside the lens
            doubted = found.left_right_uncertain
            doubted = np.zeros((found.count, NUM_JOINTS), bool) if doubted is None else doubted
            if found.count:
                found_frames.append(np.full(found.count, index, np.int64))
                persons.append(np.arange(found.count, dtype=np.int64))
                pixels.append(xy)
                confidence.append(conf)
                uncertain.append(doubted)
            if on_frame is not None:
                on_frame(index, image, PosePeople(xy, conf, doubted))
        report(progress, "pose", k + 1, count, unit="frame")
    skipped = int(np.count_nonzero(people < 0))
    if skipped == count:
        raise InputError(f"none of the {count} frames could be decoded", path=source)
    if skipped:
        warn(progress, f"{camera.name}: {skipped} of {count} frames could not be decoded and were skipped")
    table = _table(found_frames, persons, pixels, confidence, uncertain, fps)
    return PoseVideoResult(
        table, people, start, stop, stage.capped_frames, stage.upright_checks, stage.upright_disputed
    )


def _table(
    frames: list[np.ndarray],
    persons: list[np.ndarray],
    pixels: list[np.ndarray],
    confidence: list[np.ndarray],
    uncertain: list[np.ndarray],
    fps: float,
) -> pd.DataFrame:
    if not frames:
        return pd.DataFrame(
            {
                c: pd.Series(dtype=t)
                for c, t in zip(
                    POSE_COLUMNS, ("int64", "float64", "int64", "str", "float64", "float64", "float64", "int64")
                )
            }
        )
    frame = np.concatenate(frames)
    person = np.concatenate(persons)
    xy = np.concatenate(pixels)  # (P, 33, 2)
    conf = np.concatenate(confidence)  # (P, 33)
    doubted = np.concatenate(uncertain).astype(np.int64)  # (P, 33)
    rows = frame.size * NUM_JOINTS
    return pd.DataFrame(
        {
            "frame": np.repeat(frame, NUM_JOINTS),
            "time_s": np.repeat(np.round(frame / fps, 4), NUM_JOINTS),
            "person": np.repeat(person, NUM_JOINTS),
            "joint": np.tile(np.array(BLAZEPOSE33, dtype=object), frame.size),
            "x_px": np.round(xy[..., 0].reshape(rows), 2),
            "y_px": np.round(xy[..., 1].reshape(rows), 2),
            "confidence": np.round(conf.reshape(rows), 4),  # 0 where the lens cannot place the point
            "left_right_uncertain": doubted.reshape(rows),
        },
        columns=list(POSE_COLUMNS),
    )


def write_pose_csv(path: str | os.PathLike[str], table: pd.DataFrame) -> Path:
    """Write the keypoint table atomically (a keypoint the lens cannot place: empty x_px, y_px)."""
    with atomic_path(path) as tmp:
        table.to_csv(tmp, index=False, lineterminator="\n")
    return Path(path)
