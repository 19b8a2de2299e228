"""Video reading: chunks in any order give the frames of one pass; bad files give one clear error."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from ergopose.errors import InputError
from ergopose.video import probe_video, read_frames


def write_numbered_video(path, n=60, size=(160, 120), fps=12.0):
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, size)
    for i in range(n):
        frame = np.zeros((size[1], size[0], 3), np.uint8)
        cv2.putText(frame, str(i), (10, 80), cv2.FONT_HERSHEY_SIMPLEX, 2, (255, 255, 255), 3)
        frame[..., 1] = (i * 9) % 256
        writer.write(frame)
    writer.release()
    return path


def test_probe_and_chunks_match_one_pass(tmp_path):
    path = write_numbered_video(tmp_path / "cam_1.mp4")
    info = probe_video(path)
    assert (info.frames, info.width, info.height) == (60, 160, 120)
    assert info.fps == pytest.approx(12.0)
    one_pass = [f for _, f in read_frames(path, 0, 60)]
    for start, stop in ((0, 13), (13, 37), (37, 60), (59, 60), (25, 26)):
        chunk = list(read_frames(path, start, stop))
        assert [i for i, _ in chunk] == list(range(start, stop))
        for i, frame in chunk:
            assert np.array_equal(frame, one_pass[i]), f"frame {i} differs when read from {start}"


def test_missing_corrupt_and_truncated_files(tmp_path):
    with pytest.raises(InputError, match="not found"):
        probe_video(tmp_path / "nope.mp4")
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"this is not a video" * 100)
    with pytest.raises(InputError, match="junk.mp4"):
        probe_video(junk)
    good = write_numbered_video(tmp_path / "good.mp4", n=48)
    data = good.read_bytes()
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match="cut.mp4"):
        probe_video(cut)
    with pytest.raises(InputError, match="frame 48 cannot be read"):
        list(read_frames(good, 40, 61))  # the file has 48 frames
