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


# --------------------------------------------------------------------------- simulated room
# Two ceiling cameras with known Kannala-Brandt lenses (800 x 800, about 190 degrees) and poses,
# 3 m above a 6 x 6 m floor, 1.5 m apart; board images rendered through the true lenses.

SIM_SIZE = (800, 800)
INTRINSIC_BOARD = "checkerboard:9x6:0.04"
FLOOR_BOARD = "checkerboard:9x6:0.25"
#: floor board corner 0 placed so that the board is centred under the rig
FLOOR_ORIGIN = (-0.625, -1.0)


def _tilt(axis: str, degrees: float) -> np.ndarray:
    from ergopose.calibration._so3 import rotation_matrices

    vec = {"x": (1.0, 0, 0), "y": (0, 1.0, 0)}[axis]
    return rotation_matrices(np.radians(degrees) * np.array(vec))


def true_cameras():
    from ergopose.geometry.camera import Camera, ceiling_rotation
    from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt

    lens_a = KannalaBrandt(245.0, 245.5, 401.3, 398.2, 0.02, -0.005, 0.001, -0.0002)
    lens_b = KannalaBrandt(247.2, 246.8, 398.6, 402.1, 0.018, -0.004, 0.0008, -0.00015)
    cam_a = Camera("cam_a", lens_a, *SIM_SIZE, _tilt("x", 1.5) @ ceiling_rotation(0.1), (-0.75, 0.1, 3.0))
    cam_b = Camera("cam_b", lens_b, *SIM_SIZE, _tilt("y", -1.0) @ ceiling_rotation(3.0), (0.75, -0.05, 2.97))
    return cam_a, cam_b


def intrinsic_board_poses(rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    """15 poses (R_cam_from_board, t_cam) of the hand-held board: centre, middle ring and edge
    (up to about 100 degrees off-axis), facing the camera with random tilts."""
    from ergopose.calibration._so3 import rotation_matrices

    poses = []
    layout = [
        (0, 0),
        (20, 30),
        (20, 210),
        (40, 0),
        (40, 120),
        (40, 240),
        (60, 60),
        (60, 180),
        (60, 300),
        (75, 0),
        (75, 90),
        (75, 180),
        (75, 270),
        (85, 45),
        (85, 225),
    ]
    for th_deg, ph_deg in layout:
        th, ph = np.radians(th_deg), np.radians(ph_deg)
        tilt = rng.uniform(-0.4, 0.4, 2)
        spin = rng.uniform(-0.5, 0.5)
        dist = rng.uniform(0.45, 0.6) if th_deg < 50 else rng.uniform(0.6, 0.8)
        d = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
        x = np.cross([0.0, 1.0, 0.0], d) if abs(d[1]) < 0.9 else np.cross([1.0, 0.0, 0.0], d)
        x /= np.linalg.norm(x)
        R = np.stack([x, np.cross(d, x), d], 1) @ rotation_matrices(np.array([tilt[0], tilt[1], spin]))
        poses.append((R, dist * d - R @ np.array([0.16, 0.1, 0.0])))
    return poses


@dataclass(frozen=True)
class SimRoom:
    cameras: tuple
    intrinsic_dirs: dict
    floor_images: dict
    root: object
    intrinsic_board: str = INTRINSIC_BOARD
    floor_board: str = FLOOR_BOARD
    floor_origin: tuple = FLOOR_ORIGIN


@pytest.fixture(scope="session")
def sim_room(tmp_path_factory) -> SimRoom:
    """Rendered images: 15 hand-held board views per camera and one floor-board view per camera."""
    from ergopose.calibration.boards import parse_board
    from ergopose.calibration.simulate import render_board, render_floor_board

    root = tmp_path_factory.mktemp("sim_room")
    rng = np.random.default_rng(20181001)
    cams = true_cameras()
    board = parse_board(INTRINSIC_BOARD)
    floor = parse_board(FLOOR_BOARD)
    dirs, floors = {}, {}
    for cam in cams:
        folder = root / f"{cam.name}_intrinsics"
        folder.mkdir()
        for i, (R, t) in enumerate(intrinsic_board_poses(rng)):
            image = render_board(cam.lens, SIM_SIZE, board, R, t, supersample=3, noise_std=2.0, rng=rng)
            cv2.imwrite(str(folder / f"view_{i:02d}.png"), image)
        dirs[cam.name] = folder
        image = render_floor_board(cam, floor, FLOOR_ORIGIN, 0.0, supersample=3, noise_std=2.0, rng=rng)
        floors[cam.name] = root / f"{cam.name}_floor.png"
        cv2.imwrite(str(floors[cam.name]), image)
    return SimRoom(cams, dirs, floors, root)
