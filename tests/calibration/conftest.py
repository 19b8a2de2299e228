"""Fixtures for the calibration tests: the real fisheye corners of opencv-fisheye-stereo-jy."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import pytest

from ergopose.calibration.boards import Board, Detection

JY_SIZE = (1280, 800)
JY_VIEWS = 34


@dataclass(frozen=True)
class JYData:
    board: Board
    left: list[Detection]
    right: list[Detection]
    object_points: list[np.ndarray]
    size: tuple[int, int] = JY_SIZE


def _read_fs(path, n_values: int) -> list[np.ndarray]:
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    try:
        out = []
        for i in range(JY_VIEWS):
            node = fs.getNode(f"image_{i}")
            out.append(np.array([node.at(j).real() for j in range(node.size())], np.float64).reshape(-1, n_values))
        return out
    finally:
        fs.release()


@pytest.fixture(scope="session")
def jy(shared_data) -> JYData:
    """The 34 stereo views of an 8x6 (inner corners), 24.4 mm checkerboard (see its SOURCE.md)."""
    root = shared_data / "opencv-fisheye-stereo-jy"
    board = Board("checkerboard", 8, 6, 0.0244)
    left = _read_fs(root / "left.xml", 2)
    right = _read_fs(root / "right.xml", 2)
    obj = _read_fs(root / "object.xml", 3)
    ids = np.arange(board.n_corners)
    return JYData(
        board,
        [Detection(p, ids, JY_SIZE, f"left image_{i}") for i, p in enumerate(left)],
        [Detection(p, ids, JY_SIZE, f"right image_{i}") for i, p in enumerate(right)],
        obj,
    )
