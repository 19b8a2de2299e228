"""Video reading: chunks in any order give the frames of one pass; bad files give one clear error."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from ergopose.errors import InputError
from ergopose.video import (
    UNDECODABLE,
    WRONG_SIZE,
    image_size,
    list_images,
    open_video_writer,
    probe_video,
    read_frames,
    read_frames_checked,
    read_images_checked,
)


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
        checked = list(read_frames_checked(path, start, stop))
        assert [i for i, _, _ in checked] == list(range(start, stop))
        for i, frame, why in checked:
            assert why == "" and np.array_equal(frame, one_pass[i]), f"frame {i} differs (checked reader)"


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


def write_textured_video(path, n=36, size=(320, 240), fps=12.0):
    """A video whose frames are seeded coarse noise moving sideways, each with its number."""
    rng = np.random.default_rng(3)
    base = rng.integers(0, 256, (size[1] // 8, size[0] // 8, 3), dtype=np.uint8)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, size)
    for i in range(n):
        frame = cv2.resize(np.roll(base, i, axis=1), size, interpolation=cv2.INTER_NEAREST)
        cv2.putText(frame, str(i), (10, 80), cv2.FONT_HERSHEY_SIMPLEX, 2, (255, 255, 255), 3)
        writer.write(frame)
    writer.release()
    return path


def damage_middle(path, out, length=1000, seed=0):
    """A copy of a video with ``length`` seeded random bytes written over the middle of the file."""
    data = bytearray(path.read_bytes())
    at = len(data) // 2
    data[at : at + length] = np.random.default_rng(seed).integers(0, 256, length, dtype=np.uint8).tobytes()
    out.write_bytes(bytes(data))
    return out


def test_a_damaged_frame_is_skipped_and_later_frames_keep_their_numbers(tmp_path):
    from ergopose.video import UNDECODABLE

    clean = write_textured_video(tmp_path / "clean.mp4")
    bad = damage_middle(clean, tmp_path / "bad.mp4")
    one_pass = [f for _, f in read_frames(clean, 0, 36)]
    got = list(read_frames_checked(bad, 0, 36))
    assert [i for i, _, _ in got] == list(range(36))
    skipped = [i for i, f, why in got if f is None]
    assert skipped and all(why == UNDECODABLE for _, f, why in got if f is None)
    assert len(skipped) <= 3  # a few frames, not the rest of the file
    # the strict reader stops at the first of them, naming it
    with pytest.raises(InputError, match=f"frame {skipped[0]} cannot be read"):
        list(read_frames(bad, 0, 36))
    # frames before the damage, and from the next key frame on, are exactly those of the clean file
    for i, frame, _ in got:
        if i < skipped[0] - 1 or i >= 24:
            assert np.array_equal(frame, one_pass[i]), f"frame {i} differs"
    # a chunk that starts after the damage reads the same as one pass, although OpenCV's seek in
    # this file lands on the damaged frame 19 (frames are numbered by their timestamps)
    for start in (24, 30):
        got = list(read_frames_checked(bad, start, 36))
        assert [i for i, _, _ in got] == list(range(start, 36))
        for i, frame, why in got:
            assert why == "" and np.array_equal(frame, one_pass[i]), f"frame {i} read from {start} differs"


class _FakeCapture:
    """Frames of a capture as OpenCV would give them, some short (a truncated frame buffer)."""

    def __init__(self, frames, fps=12.0):
        self.frames, self.fps, self.pos = frames, fps, 0

    def get(self, prop):
        return {
            cv2.CAP_PROP_FRAME_HEIGHT: 120,
            cv2.CAP_PROP_FRAME_WIDTH: 160,
            cv2.CAP_PROP_FPS: self.fps,
            cv2.CAP_PROP_POS_MSEC: 1000.0 * (self.pos - 1) / self.fps,
        }[prop]

    def set(self, prop, value):
        self.pos = int(value)

    def read(self):
        if self.pos >= len(self.frames):
            return False, None
        self.pos += 1
        return True, self.frames[self.pos - 1]


def test_frames_of_the_wrong_size_are_skipped_and_named():
    from ergopose.video import WRONG_SIZE, _checked

    frames = [np.full((120, 160, 3), i, np.uint8) for i in range(10)]
    frames[3] = frames[3][:60]  # half a frame
    frames[7] = frames[7][:, :, 0]  # one channel
    got = list(_checked(_FakeCapture(frames), 2, 10))
    assert [i for i, _, _ in got] == list(range(2, 10))
    assert [(i, why) for i, f, why in got if f is None] == [(3, WRONG_SIZE), (7, WRONG_SIZE)]
    assert all(int(f[0, 0, 0]) == i for i, f, _ in got if f is not None)


def test_a_folder_of_images_is_read_in_name_order_and_its_bad_images_skipped(tmp_path):
    for k in (10, 2, 1):
        cv2.imwrite(str(tmp_path / f"f_{k}.png"), np.full((8, 12, 3), k, np.uint8))
    cv2.imwrite(str(tmp_path / "F_3.JPG"), np.full((8, 12, 3), 3, np.uint8))
    cv2.imwrite(str(tmp_path / "f_4.png"), np.full((9, 12, 3), 4, np.uint8))  # another size
    (tmp_path / "f_5.png").write_bytes(b"not a png")
    (tmp_path / "notes.txt").write_text("x")
    (tmp_path / "sub.png").mkdir()
    paths = list_images(tmp_path)
    assert [p.name for p in paths] == ["f_1.png", "f_2.png", "F_3.JPG", "f_4.png", "f_5.png", "f_10.png"]
    assert image_size(paths[0]) == (12, 8)
    got = list(read_images_checked(paths, 1, 6, (12, 8)))
    assert [(i, w) for i, _, w in got] == [(1, ""), (2, ""), (3, WRONG_SIZE), (4, UNDECODABLE), (5, "")]
    assert [int(im[0, 0, 0]) for _, im, _ in got if im is not None] == [2, 3, 10]
    with pytest.raises(InputError, match="no image"):
        list_images(tmp_path / "sub.png")
    with pytest.raises(InputError, match="folder not found"):
        list_images(tmp_path / "missing")
    with pytest.raises(InputError, match="cannot read the image"):
        image_size(paths[4])


def test_a_video_writer_that_cannot_write_is_one_error(tmp_path):
    with pytest.raises(InputError, match="cannot write"):
        open_video_writer(tmp_path / "missing" / "x.mp4", 10.0, 32, 32)
    writer = open_video_writer(tmp_path / "x.mp4", 10.0, 32, 32)
    writer.write(np.zeros((32, 32, 3), np.uint8))
    writer.release()
    assert probe_video(tmp_path / "x.mp4").frames == 1
