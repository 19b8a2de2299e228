"""Synthetic board images through a known lens, for testing calibration against ground truth.

Rendering is inverse mapping: for every (supersampled) image pixel, the lens unprojects it to a
ray, the ray meets the board plane, and the board texture is looked up there (cv2.remap with
maps built in numpy). The supersampled image is averaged down (cv2.INTER_AREA), which
anti-aliases the square edges so OpenCV's corner detectors behave as on real photographs.

Pixel convention: the centre of pixel (u, v) is at (u, v); subpixel j of a pixel row in an
``s`` times supersampled image sits at u = (j + 0.5) / s - 0.5.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from ergopose.arrays import FloatArray
from ergopose.calibration.boards import Board, BoardTexture, board_texture
from ergopose.geometry.camera import Camera
from ergopose.geometry.lenses.base import LensModel

_ROWS_PER_BLOCK_POINTS = 1 << 20


def floor_board_transform(yaw: float = 0.0) -> FloatArray:
    """(3, 3) rotation world_from_board of a board lying face up on the floor (see
    extrinsics.floor_board_points): world x = board y, world y = board x, world z = -board z,
    then turned by ``yaw`` about z."""
    c, s = np.cos(yaw), np.sin(yaw)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    swap = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    rotation: FloatArray = Rz @ swap
    return rotation


def board_pose_in_camera(
    rotation_world_from_cam: np.ndarray,
    position_world: np.ndarray,
    rotation_world_from_board: np.ndarray,
    origin_world: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(R_cam_from_board, t_cam) for a board placed in the world and a camera pose."""
    R_wc = np.asarray(rotation_world_from_cam, np.float64)
    R = R_wc.T @ np.asarray(rotation_world_from_board, np.float64)
    t = R_wc.T @ (np.asarray(origin_world, np.float64) - np.asarray(position_world, np.float64))
    return R, t


def board_region(
    lens: LensModel,
    image_size: tuple[int, int],
    board: Board,
    rotation_cam_from_board: np.ndarray,
    translation_cam: np.ndarray,
    texture: BoardTexture,
) -> tuple[int, int, int, int]:
    """(u0, v0, u1, v1) pixel box (end exclusive) that holds the whole board texture in the image.

    Found by projecting densely sampled points of the texture's outline; the full image when the
    outline cannot be projected everywhere (board crossing the lens's domain).
    """
    width, height = image_size
    x0, y0, x1, y1 = board.extent()
    m = texture.margin_px / texture.scale
    x0, y0, x1, y1 = x0 - m, y0 - m, x1 + m, y1 + m
    n = 200
    ts = np.linspace(0.0, 1.0, n)
    outline = np.concatenate(
        [
            np.stack([x0 + (x1 - x0) * ts, np.full(n, y0)], -1),
            np.stack([x0 + (x1 - x0) * ts, np.full(n, y1)], -1),
            np.stack([np.full(n, x0), y0 + (y1 - y0) * ts], -1),
            np.stack([np.full(n, x1), y0 + (y1 - y0) * ts], -1),
        ]
    )
    pts = np.concatenate([outline, np.zeros((len(outline), 1))], -1) @ np.asarray(rotation_cam_from_board).T
    pts += np.asarray(translation_cam)
    px = lens.project(pts)
    if not np.all(np.isfinite(px)):
        return 0, 0, width, height
    u0, v0 = np.floor(px.min(axis=0)).astype(int) - 3
    u1, v1 = np.ceil(px.max(axis=0)).astype(int) + 4
    u0, v0 = max(u0, 0), max(v0, 0)
    u1, v1 = min(u1, width), min(v1, height)
    if u1 <= u0 or v1 <= v0:
        return 0, 0, 0, 0
    return int(u0), int(v0), int(u1), int(v1)


def board_maps(
    lens: LensModel,
    image_size: tuple[int, int],
    board: Board,
    rotation_cam_from_board: np.ndarray,
    translation_cam: np.ndarray,
    texture: BoardTexture,
    supersample: int = 3,
    region: tuple[int, int, int, int] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """cv2.remap maps (float32, (h*s, w*s)) from the supersampled image (or the pixel box
    ``region`` = (u0, v0, u1, v1) of it) into the board texture.

    Pixels whose ray misses the board plane (or the lens domain) map far outside the texture: background.
    """
    width, height = image_size
    u0, v0, u1, v1 = region if region is not None else (0, 0, width, height)
    s = int(supersample)
    W, H = (u1 - u0) * s, (v1 - v0) * s
    R = np.asarray(rotation_cam_from_board, np.float64)
    t = np.asarray(translation_cam, np.float64)
    centre_board = -R.T @ t  # camera centre in the board frame
    us = u0 + (np.arange(W) + 0.5) / s - 0.5
    map_x = np.empty((H, W), np.float32)
    map_y = np.empty((H, W), np.float32)
    rows = max(1, _ROWS_PER_BLOCK_POINTS // max(W, 1))
    for r0 in range(0, H, rows):
        r1 = min(H, r0 + rows)
        vs = v0 + (np.arange(r0, r1) + 0.5) / s - 0.5
        uu, vv = np.meshgrid(us, vs)
        rays_cam = lens.unproject(np.stack([uu, vv], axis=-1))
        rays_board = rays_cam @ R  # R.T @ ray, row-wise
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = -centre_board[2] / rays_board[..., 2]
            hit = centre_board[:2] + lam[..., None] * rays_board[..., :2]
        uv = texture.coordinates(board, hit)
        bad = ~(np.isfinite(lam) & (lam > 0)) | ~np.all(np.isfinite(uv), axis=-1)
        uv[bad] = -1e4
        map_x[r0:r1] = uv[..., 0]
        map_y[r0:r1] = uv[..., 1]
    return map_x, map_y


def render_board(
    lens: LensModel,
    image_size: tuple[int, int],
    board: Board,
    rotation_cam_from_board: np.ndarray,
    translation_cam: np.ndarray,
    *,
    supersample: int = 3,
    texture: BoardTexture | None = None,
    background: int = 140,
    noise_std: float = 0.0,
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """A (H, W) uint8 image of the board seen through ``lens`` (board pose in the camera frame).

    noise_std: Gaussian pixel noise (grey levels) added after anti-aliasing (needs ``rng``).
    """
    texture = texture if texture is not None else board_texture(board)
    width, height = image_size
    image = np.full((height, width), int(background), np.uint8)
    u0, v0, u1, v1 = board_region(lens, image_size, board, rotation_cam_from_board, translation_cam, texture)
    if u1 > u0 and v1 > v0:
        map_x, map_y = board_maps(
            lens,
            image_size,
            board,
            rotation_cam_from_board,
            translation_cam,
            texture,
            supersample,
            region=(u0, v0, u1, v1),
        )
        big = cv2.remap(
            texture.image,
            map_x,
            map_y,
            interpolation=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=int(background),
        )
        if supersample > 1:
            big = cv2.resize(big, (u1 - u0, v1 - v0), interpolation=cv2.INTER_AREA)
        image[v0:v1, u0:u1] = big
    if noise_std > 0:
        if rng is None:
            raise ValueError("noise_std > 0 needs a seeded rng")
        image = np.clip(image.astype(np.float64) + rng.normal(0.0, noise_std, image.shape), 0, 255).astype(np.uint8)
    return image


def render_floor_board(
    camera: Camera, board: Board, origin_xy: tuple[float, float] = (0.0, 0.0), yaw: float = 0.0, **kwargs: Any
) -> np.ndarray:
    """A ceiling camera's view of a board lying on the floor (placed as extrinsics.floor_board_points)."""
    R, t = board_pose_in_camera(
        camera.rotation_world_from_cam,
        camera.position_world,
        floor_board_transform(yaw),
        np.array([origin_xy[0], origin_xy[1], 0.0]),
    )
    return render_board(camera.lens, (camera.width, camera.height), board, R, t, **kwargs)


def true_corner_pixels(
    lens: LensModel, board: Board, rotation_cam_from_board: np.ndarray, translation_cam: np.ndarray
) -> np.ndarray:
    """(N, 2) pixels of every board corner through ``lens`` (the ground truth for a rendering)."""
    pts = board.object_points() @ np.asarray(rotation_cam_from_board).T + np.asarray(translation_cam)
    return lens.project(pts)
