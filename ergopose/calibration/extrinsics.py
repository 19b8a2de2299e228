"""Extrinsic calibration: where each ceiling camera is and where it looks.

World frame: the floor, z = 0, z up (metres). A camera's pose is solved from 3D-2D
correspondences through its FULL lens model (Levenberg-Marquardt, scipy.optimize.least_squares
method "lm", over the rotation vector and translation), after a start from cv2.solvePnP on the
rays turned into normalised coordinates of a virtual pinhole aimed at the points (rays within 80
degrees of its axis).

Correspondences come from
(a) a board lying on the floor (:func:`floor_board_points` gives its corners in the world), or
(b) measured floor points (x, y, z in metres) and their pixel positions.

Residuals are reported per point in pixels and in millimetres: for a point on the floor
(|z| < 1 mm) the distance on the floor between the point and where the ray through the observed
pixel meets the floor; for a point above the floor the distance between the point and that ray
(the sideways miss at the point's depth).

Also here: :func:`calibrate_stereo` (cv2.fisheye.stereoCalibrate with the same pitfalls handled as
the intrinsic fit) for the relative pose of two cameras that saw the same boards.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import cv2
import numpy as np
from scipy.optimize import least_squares

from ergopose.arrays import FloatArray
from ergopose.calibration._so3 import rotation_matrices, rotation_vectors
from ergopose.calibration.boards import Board, Detection
from ergopose.calibration.opencv_fisheye import (
    FISHEYE_CRITERIA,
    FISHEYE_FLAGS,
    ILL_CONDITIONED,
    DroppedImage,
    too_few_message,
)
from ergopose.errors import InputError
from ergopose.geometry.lenses.base import LensModel

#: Rays further than this from the optical axis are not used for the pinhole start.
INIT_MAX_THETA = np.radians(80.0)
MIN_POINTS = 4
_BIG = 1e4


@dataclass(frozen=True)
class PoseResult:
    """A solved camera pose and how well it fits.

    rotation_world_from_cam: (3, 3); columns are the camera axes (x right, y down, z forward) in the world.
    position_world: (3,) camera centre in the world, metres.
    points_world: (N, 3) the 3D points used, metres.
    pixels: (N, 2) their observed pixel positions.
    residuals_px: (N,) distance between observed and projected pixel, pixels.
    residuals_mm: (N,) miss in millimetres (see module doc).
    rms_px: RMS of residuals_px.
    names: (N,) point names (CSV ids or corner numbers).
    """

    rotation_world_from_cam: np.ndarray
    position_world: np.ndarray
    points_world: np.ndarray
    pixels: np.ndarray
    residuals_px: np.ndarray
    residuals_mm: np.ndarray
    rms_px: float
    names: tuple[str, ...]

    @property
    def rotation_cam_from_world(self) -> np.ndarray:
        return self.rotation_world_from_cam.T

    @property
    def translation_cam(self) -> FloatArray:
        """t in x_cam = R_cam_from_world @ x_world + t."""
        t: FloatArray = -self.rotation_world_from_cam.T @ self.position_world
        return t


def _check_points(points_world: np.ndarray, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    points_world = np.asarray(points_world, dtype=np.float64).reshape(-1, 3)
    pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    if len(points_world) != len(pixels):
        raise InputError(f"{len(points_world)} 3D points but {len(pixels)} pixel positions")
    if not (np.all(np.isfinite(points_world)) and np.all(np.isfinite(pixels))):
        raise InputError("a point or pixel position is not a finite number")
    if len(points_world) < MIN_POINTS:
        raise InputError(
            f"only {len(points_world)} point(s); a camera pose needs at least {MIN_POINTS} "
            f"(better 8 or more, spread over the view)"
        )
    centred = points_world - points_world.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    if sv[1] < 1e-3 * max(sv[0], 1e-12):
        raise InputError("the points lie on one line; a camera pose needs points spread over an area")
    return points_world, pixels


def _virtual_pinhole(rays: np.ndarray) -> np.ndarray:
    """Rotation (3, 3) taking camera-frame rays into a virtual pinhole aimed at their mean direction."""
    axis = np.nanmean(rays, axis=0)
    axis /= np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, axis)
    x /= np.linalg.norm(x)
    y = np.cross(axis, x)
    return np.stack([x, y, axis])  # rows: the virtual camera's axes in the camera frame


def initial_pose(lens: LensModel, points_world: np.ndarray, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rvec, tvec) of x_cam = R x_world + t: cv2.solvePnP on the rays (unprojected through the lens)
    as normalised coordinates of a virtual pinhole aimed at their mean direction (rays within
    80 degrees of that direction)."""
    rays = lens.unproject(pixels)
    finite = np.all(np.isfinite(rays), axis=-1)
    if finite.sum() < MIN_POINTS:
        raise InputError(
            f"only {int(finite.sum())} pixel position(s) lie inside the lens model's image; at least "
            f"{MIN_POINTS} are needed (check the pixel positions and the camera's intrinsics)"
        )
    R_vc = _virtual_pinhole(rays[finite])
    rays_v = rays @ R_vc.T
    ok = finite & (rays_v[:, 2] > np.cos(INIT_MAX_THETA))
    if ok.sum() < MIN_POINTS:
        raise InputError(
            f"the points are spread over more than {2 * np.degrees(INIT_MAX_THETA):.0f} degrees of the "
            f"view; cannot find a starting pose"
        )
    normalised = rays_v[ok, :2] / rays_v[ok, 2:3]
    obj = points_world[ok].reshape(-1, 1, 3)
    img = normalised.reshape(-1, 1, 2)
    best = None
    for flag in (cv2.SOLVEPNP_SQPNP, cv2.SOLVEPNP_ITERATIVE, cv2.SOLVEPNP_EPNP):
        try:
            found, rvec, tvec = cv2.solvePnP(obj, img, np.eye(3), None, flags=flag)
        except cv2.error:
            continue
        if not found:
            continue
        R = rotation_matrices(rvec.ravel())
        pc = points_world[ok] @ R.T + tvec.ravel()
        proj = pc[:, :2] / pc[:, 2:3]
        err = float(np.mean(np.linalg.norm(proj - normalised, axis=-1))) if np.all(pc[:, 2] > 0) else np.inf
        if best is None or err < best[0]:
            best = (err, R, tvec.ravel())
    if best is None or not np.isfinite(best[0]):
        raise InputError(
            "could not find a starting pose from these points (cv2.solvePnP failed); "
            "check that the 3D points and pixel positions are listed in matching order"
        )
    R_c = R_vc.T @ best[1]
    t_c = R_vc.T @ best[2]
    return rotation_vectors(R_c), t_c


def _project(lens: LensModel, params: np.ndarray, points_world: np.ndarray) -> np.ndarray:
    R = rotation_matrices(params[:3])
    return lens.project(points_world @ R.T + params[3:])


def solve_pose(
    lens: LensModel,
    points_world: np.ndarray,
    pixels: np.ndarray,
    *,
    names: Sequence[str] | None = None,
    initial: tuple[np.ndarray, np.ndarray] | None = None,
) -> PoseResult:
    """Camera pose from 3D-2D correspondences through the full lens model.

    lens: a lens model (project / unproject).
    points_world: (N, 3) metres; pixels: (N, 2) observed pixels of those points.
    initial: optional (rotation_world_from_cam, position_world) start; otherwise cv2.solvePnP.
    """
    points_world, pixels = _check_points(points_world, pixels)
    if initial is None:
        rvec, tvec = initial_pose(lens, points_world, pixels)
    else:
        R_wc, p_w = (np.asarray(a, np.float64) for a in initial)
        rvec = rotation_vectors(R_wc.T)
        tvec = -R_wc.T @ p_w

    def resid(params: np.ndarray) -> np.ndarray:
        r = (_project(lens, params, points_world) - pixels).ravel()
        return np.where(np.isfinite(r), r, _BIG)

    res = least_squares(
        resid, np.concatenate([rvec, tvec]), method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000
    )
    R_cw = rotation_matrices(res.x[:3])
    t = res.x[3:]
    R_wc = R_cw.T
    position = -R_wc @ t
    proj = _project(lens, res.x, points_world)
    res_px = np.linalg.norm(proj - pixels, axis=-1)
    if not np.all(np.isfinite(res_px)):
        raise InputError("after the fit some points fall outside the lens model; check the point list")
    res_mm = residuals_mm(lens, R_wc, position, points_world, pixels)
    if names is None:
        names = [str(i) for i in range(len(points_world))]
    return PoseResult(
        R_wc,
        position,
        points_world,
        pixels,
        res_px,
        res_mm,
        float(np.sqrt(np.mean(res_px**2))),
        tuple(str(n) for n in names),
    )


def residuals_mm(
    lens: LensModel,
    rotation_world_from_cam: np.ndarray,
    position_world: np.ndarray,
    points_world: np.ndarray,
    pixels: np.ndarray,
    floor_tolerance: float = 1e-3,
) -> FloatArray:
    """Per point, millimetres between the point and the ray through its observed pixel.

    Floor points (|z| < floor_tolerance): distance on the floor to where the ray meets z = 0.
    Other points: perpendicular distance from the point to the ray.
    """
    rays_world = lens.unproject(pixels) @ np.asarray(rotation_world_from_cam).T
    c = np.asarray(position_world, np.float64)
    rel = points_world - c
    along = np.sum(rel * rays_world, axis=-1, keepdims=True)
    perpendicular = np.linalg.norm(rel - along * rays_world, axis=-1)
    on_floor = np.abs(points_world[:, 2]) < floor_tolerance
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = (points_world[:, 2] - c[2]) / rays_world[:, 2]
        hit = c + lam[:, None] * rays_world
        planar = np.linalg.norm(hit[:, :2] - points_world[:, :2], axis=-1)
    usable = on_floor & (lam > 0) & np.isfinite(planar)
    distance_mm: FloatArray = 1000.0 * np.where(usable, planar, perpendicular)
    return distance_mm


# ------------------------------------------------------------------ floor board
def floor_board_points(
    board: Board, ids: np.ndarray | None = None, origin_xy: tuple[float, float] = (0.0, 0.0), yaw: float = 0.0
) -> np.ndarray:
    """World positions (N, 3) of board corners for a board lying face up on the floor.

    With origin (0, 0) and yaw 0, corner 0 is at the world origin, world x runs along the board's
    y axis (down its columns of corners) and world y along its x axis (along its rows), so the
    board lies in x >= 0, y >= 0 and z = 0, z up. ``origin_xy`` moves corner 0 and ``yaw``
    (radians, counter-clockwise seen from above) turns the board about it.
    """
    obj = board.object_points()
    if ids is not None:
        obj = obj[np.asarray(ids)]
    local = np.stack([obj[:, 1], obj[:, 0]], axis=-1)
    c, s = np.cos(yaw), np.sin(yaw)
    xy = local @ np.array([[c, s], [-s, c]]) + np.asarray(origin_xy, np.float64)
    return np.concatenate([xy, np.zeros((len(xy), 1))], axis=-1)


def solve_pose_from_board(
    lens: LensModel, detection: Detection, board: Board, origin_xy: tuple[float, float] = (0.0, 0.0), yaw: float = 0.0
) -> PoseResult:
    """Pose of a ceiling camera from one image of a board lying on the floor."""
    sx, sy = board.squares
    if board.kind == "checkerboard" and (sx + sy) % 2 == 0:
        raise InputError(
            f"a checkerboard with {sx}x{sy} squares looks the same turned by 180 degrees, so its "
            f"position on the floor is ambiguous; use a board with an odd number of squares one "
            f"way and an even number the other way (e.g. 9x6 inner corners), or a ChArUco board"
        )
    points = floor_board_points(board, detection.ids, origin_xy, yaw)
    return solve_pose(lens, points, detection.pixels, names=[f"corner {i}" for i in detection.ids])


# ------------------------------------------------------------------------ stereo
@dataclass(frozen=True)
class StereoResult:
    """cv2.fisheye.stereoCalibrate result: x_b = R x_a + T (camera b from camera a).

    rms: pixels; K_a, D_a, K_b, D_b: OpenCV fisheye intrinsics; rotation_b_from_a: (3, 3);
    translation_b: (3,) metres (board units); used: pair indices kept; dropped: left out and why.
    """

    rms: float
    K_a: np.ndarray
    D_a: np.ndarray
    K_b: np.ndarray
    D_b: np.ndarray
    rotation_b_from_a: np.ndarray
    translation_b: np.ndarray
    used: tuple[str, ...]
    dropped: tuple[DroppedImage, ...]


def calibrate_stereo(
    detections_a: Sequence[Detection | None],
    detections_b: Sequence[Detection | None],
    board: Board,
    image_size: tuple[int, int],
    *,
    min_images: int = 8,
    criteria: tuple[int, int, float] = FISHEYE_CRITERIA,
) -> StereoResult:
    """Relative pose (and intrinsics) of two fisheye cameras that saw the same boards.

    detections_a[i] and detections_b[i] are the same moment (None where the board was not found).
    Only pairs with all board corners in both views are used (cv2.fisheye.stereoCalibrate needs them).
    """
    pairs = []
    dropped: list[DroppedImage] = []
    for i, (a, b) in enumerate(zip(detections_a, detections_b)):
        label = (a.source if a is not None and a.source else None) or (b.source if b is not None else None) or str(i)
        if a is None or b is None:
            dropped.append(DroppedImage(label, "board not found in both views", "not_in_both"))
        elif len(a.ids) != board.n_corners or len(b.ids) != board.n_corners:
            dropped.append(DroppedImage(label, "board only partly visible", "partial"))
        else:
            pairs.append((label, a, b))
    obj_all = board.object_points()
    while True:
        if len(pairs) < min_images:
            raise InputError(too_few_message(len(pairs), min_images, dropped))
        obj = [obj_all[a.ids].reshape(-1, 1, 3) for _, a, _ in pairs]
        ia = [a.pixels.reshape(-1, 1, 2) for _, a, _ in pairs]
        ib = [b.pixels.reshape(-1, 1, 2) for _, _, b in pairs]
        try:
            # cv2's stubs lack None for K1, D1, K2, D2 (estimated from scratch under FISHEYE_FLAGS)
            out = cv2.fisheye.stereoCalibrate(
                obj,
                ia,
                ib,
                None,
                None,
                None,
                None,  # type: ignore[call-overload]
                tuple(image_size),
                flags=FISHEYE_FLAGS,
                criteria=criteria,
            )
        except cv2.error as exc:
            text = str(exc)
            match = ILL_CONDITIONED.search(text)
            if "CALIB_CHECK_COND" in text and match and int(match.group(1)) < len(pairs):
                label = pairs.pop(int(match.group(1)))[0]
                dropped.append(DroppedImage(label, "ill-conditioned for OpenCV", "ill_conditioned"))
                continue
            raise InputError(f"cv2.fisheye.stereoCalibrate failed: {text.strip().splitlines()[-1]}") from None
        rms, K1, D1, K2, D2, R, T = out[:7]
        return StereoResult(
            float(rms),
            K1,
            np.ravel(D1),
            K2,
            np.ravel(D2),
            np.asarray(R, np.float64),
            np.ravel(T).astype(np.float64),
            tuple(p[0] for p in pairs),
            tuple(dropped),
        )
