"""Reading the cameras' videos: what a file holds, and frames by index.

A video is read in chunks of frames (``read_frames(path, start, stop)``), each chunk opening
its own reader and seeking to its first frame, so chunks can be processed in any order, in
any process, and give the same frames as one pass from the start (tests check it). A file
that ends early or cannot be decoded gives one InputError naming the file and the frame.

:func:`read_frames_checked` is the reader of an assessment: a frame that cannot be decoded or has
the wrong size is given as None with the reason, and reading goes on with the next frame (the
reader seeks to it, so later frames keep their numbers); the caller decides how many it accepts.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import cv2
import numpy as np

from ergopose.errors import InputError


@dataclass(frozen=True)
class VideoInfo:
    """What a video file holds: frames (count), fps (frames per second), width and height (pixels)."""

    path: str
    frames: int
    fps: float
    width: int
    height: int

    @property
    def duration_s(self) -> float:
        return self.frames / self.fps if self.fps > 0 else float("nan")


def _open(path: Path) -> cv2.VideoCapture:
    if not path.exists():
        raise InputError("video file not found", path=path)
    if not path.is_file():
        raise InputError("expected a video file, found a folder", path=path)
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        cap.release()
        raise InputError("cannot open the video (not a video file, or an unsupported codec)", path=path)
    return cap


def probe_video(path: str | os.PathLike[str]) -> VideoInfo:
    """Frame count, frame rate and size of a video; InputError if it cannot be read.

    The frame count in a container's header can be wrong for a truncated file, so the last frame
    is decoded to prove the count: a file whose last frames are missing or corrupt is refused.
    """
    path = Path(path)
    cap = _open(path)
    try:
        frames = int(round(cap.get(cv2.CAP_PROP_FRAME_COUNT)))
        fps = float(cap.get(cv2.CAP_PROP_FPS))
        width = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH))
        height = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        ok, first = cap.read()
        if not ok or first is None:
            raise InputError("the video holds no readable frame (corrupt or empty file)", path=path)
        if frames <= 0:
            raise InputError("the video does not state its number of frames", path=path)
        if frames > 1:
            cap.set(cv2.CAP_PROP_POS_FRAMES, frames - 1)
            ok, last = cap.read()
            if not ok or last is None:
                raise InputError(
                    f"the video says it has {frames} frames but frame {frames - 1} cannot be "
                    "read (truncated or corrupt file)",
                    path=path,
                )
        if not (np.isfinite(fps) and fps > 0):
            raise InputError(f"the video states no valid frame rate ({fps!r})", path=path)
        return VideoInfo(str(path), frames, fps, width, height)
    finally:
        cap.release()


def read_frames(path: str | os.PathLike[str], start: int, stop: int) -> Iterator[tuple[int, np.ndarray]]:
    """Yield (frame index, BGR frame) for frames start .. stop-1 of a video.

    InputError names the file and the first frame that could not be decoded.
    """
    path = Path(path)
    if start < 0 or stop < start:
        raise ValueError(f"invalid frame range {start}..{stop}")
    cap = _open(path)
    try:
        if start > 0:
            cap.set(cv2.CAP_PROP_POS_FRAMES, start)
        for index in range(start, stop):
            ok, frame = cap.read()
            if not ok or frame is None:
                raise InputError(f"frame {index} cannot be read (truncated or corrupt file)", path=path)
            yield index, frame
    finally:
        cap.release()


#: Why a frame was skipped (read_frames_checked); detect stores the code per frame and camera.
UNDECODABLE = "cannot be decoded"
WRONG_SIZE = "has the wrong size (short or damaged frame)"
SKIP_CODES = {UNDECODABLE: -1, WRONG_SIZE: -2}


def read_frames_checked(
    path: str | os.PathLike[str], start: int, stop: int
) -> Iterator[tuple[int, np.ndarray | None, str]]:
    """Yield (frame index, BGR frame or None, "" or why it was skipped) for frames start .. stop-1.

    A frame that cannot be decoded (UNDECODABLE) or whose size differs from the video's
    (WRONG_SIZE) comes as None. Each decoded frame is numbered by its timestamp, not by counting:
    in a damaged file OpenCV's seek can land frames early and the decoder can drop a frame, and
    counting would then give later frames wrong numbers (measured on a damaged MPEG-4 file: a
    seek to frame 30 landed on frame 19). Frames before ``start`` are read past; frames the decoder
    dropped come as UNDECODABLE.
    """
    path = Path(path)
    if start < 0 or stop < start:
        raise ValueError(f"invalid frame range {start}..{stop}")
    cap = _open(path)
    try:
        yield from _checked(cap, start, stop)
    finally:
        cap.release()


def _checked(cap: cv2.VideoCapture, start: int, stop: int) -> Iterator[tuple[int, np.ndarray | None, str]]:
    shape = (int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)), int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)))
    fps = float(cap.get(cv2.CAP_PROP_FPS))
    timed = np.isfinite(fps) and fps > 0

    def number(counted: int) -> int:
        """The decoded frame's number from its timestamp (the count where the file gives none)."""
        ms = cap.get(cv2.CAP_PROP_POS_MSEC)
        return int(round(ms * fps / 1000.0)) if timed and np.isfinite(ms) and ms >= 0 else counted

    if start > 0:
        cap.set(cv2.CAP_PROP_POS_FRAMES, start)
    index = start
    last = -1
    while index < stop:
        ok, frame = cap.read()
        if not ok or frame is None:
            yield index, None, UNDECODABLE
            index += 1
            if index < stop:
                cap.set(cv2.CAP_PROP_POS_FRAMES, index)
                last = -1
            continue
        n = number(index)
        if n <= last:  # no progress by timestamp: trust the count from here on
            timed = False
            n = index
        last = n
        if n < index:  # the seek landed early: read on to the wanted frame
            continue
        while index < min(n, stop):  # frames the decoder dropped
            yield index, None, UNDECODABLE
            index += 1
        if index >= stop:
            break
        if frame.ndim != 3 or frame.shape[:2] != shape:
            yield index, None, WRONG_SIZE
        else:
            yield index, frame, ""
        index += 1


def open_video_writer(path: str | os.PathLike[str], fps: float, width: int, height: int) -> cv2.VideoWriter:
    """An mp4v VideoWriter of BGR frames; InputError if OpenCV cannot write the file."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"mp4v"), float(fps), (int(width), int(height)))
    if not writer.isOpened():
        raise InputError("OpenCV cannot write an mp4v video here", path=path)
    return writer


# --- a folder of images, read as the frames of one camera ---------------------------------------

#: The image files a folder of frames may hold (by suffix, any case).
IMAGE_SUFFIXES: tuple[str, ...] = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")


def _natural_key(path: Path) -> tuple[object, ...]:
    """frame_2.png before frame_10.png: the digits of a name compared as numbers."""
    return tuple(int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", path.name))


def list_images(folder: str | os.PathLike[str]) -> list[Path]:
    """The image files of a folder (IMAGE_SUFFIXES), in natural name order; InputError if there
    are none or the folder does not exist."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError("folder not found", path=folder)
    images = sorted(
        (p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES), key=_natural_key
    )
    if not images:
        raise InputError(f"the folder holds no image ({', '.join(IMAGE_SUFFIXES)})", path=folder)
    return images


def image_size(path: str | os.PathLike[str]) -> tuple[int, int]:
    """(width, height) of an image; InputError if it cannot be read."""
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise InputError("cannot read the image (not an image, or a damaged file)", path=path)
    return int(image.shape[1]), int(image.shape[0])


def read_images_checked(
    paths: list[Path], start: int, stop: int, size: tuple[int, int]
) -> Iterator[tuple[int, np.ndarray | None, str]]:
    """Images start .. stop-1 of ``paths`` as the frames of a video, like
    :func:`read_frames_checked`: (index, BGR image or None, "" or why it was skipped); an image
    that cannot be read is UNDECODABLE, one whose (width, height) is not ``size`` WRONG_SIZE."""
    for index in range(start, stop):
        image = cv2.imread(str(paths[index]), cv2.IMREAD_COLOR)
        if image is None:
            yield index, None, UNDECODABLE
        elif (image.shape[1], image.shape[0]) != tuple(size):
            yield index, None, WRONG_SIZE
        else:
            yield index, image, ""
