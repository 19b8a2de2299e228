"""Intrinsic calibration of a fisheye camera from board images.

The Kannala-Brandt fit goes through ``cv2.fisheye.calibrate`` with
CALIB_RECOMPUTE_EXTRINSIC | CALIB_CHECK_COND | CALIB_FIX_SKEW and object points shaped
(N, 1, 3) float64. With CALIB_CHECK_COND OpenCV stops on a board view that makes the problem
ill-conditioned and names its index ("... Ill-conditioned matrix for input array 7"): that view
is dropped (and reported) and the fit runs again.

For lenses wider than 180 degrees a Double Sphere model can be fitted afterwards: a least-squares
fit (scipy.optimize.least_squares) over the same corners and the per-view board poses,
initialised from the Kannala-Brandt result.

The core never prints; long work reports through ``progress``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Sequence

import cv2
import numpy as np
from scipy.optimize import least_squares

from ergopose.calibration._so3 import rotation_matrices, rotation_vectors
from ergopose.calibration.boards import Board, Detection, detect_board
from ergopose.calibration.extrinsics import solve_pose
from ergopose.calibration.opencv_fisheye import (
    FISHEYE_CRITERIA,
    FISHEYE_FLAGS,
    ILL_CONDITIONED,
    DroppedImage,
    too_few_message,
)
from ergopose.errors import ConfigError, InputError
from ergopose.geometry.lenses.base import LensModel
from ergopose.geometry.lenses.double_sphere import DoubleSphere
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt
from ergopose.progress import ProgressCallback, report

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".pgm", ".ppm")

DEFAULT_MIN_IMAGES = 8
#: Views OpenCV must accept for the first fit when dropped views may be recovered afterwards.
MIN_OPENCV_VIEWS = 4
#: Share of the 4 x 4 grid of image cells that must hold at least one detected corner.
DEFAULT_MIN_COVERAGE = 0.5
COVERAGE_GRID = 4

MODELS = ("kannala_brandt", "double_sphere")


@dataclass(frozen=True)
class IntrinsicsResult:
    """The outcome of an intrinsic calibration.

    model: "kannala_brandt" or "double_sphere".
    lens: the fitted lens model (ergopose.geometry.lenses).
    image_size: (width, height), pixels.
    rms: RMS reprojection error over all used corners, pixels (sqrt of the mean squared
        distance between detected and reprojected corners).
    camera_matrix, distortion: the Kannala-Brandt fit in OpenCV's form ((3, 3) and (4,)), also
        kept when ``model`` is double_sphere (it is the starting point).
    kb_rms: RMS of the Kannala-Brandt fit, pixels.
    used: sources of the images in the fit, in order.
    dropped: images left out and why (no board found, ill-conditioned, ...).
    rotations_cam_from_board: (M, 3, 3) board pose per used image.
    translations_cam: (M, 3) board origin in the camera frame per used image, metres.
    per_view_rms: (M,) RMS reprojection error per used image, pixels.
    coverage: share of image cells (4 x 4 grid) holding at least one used corner.
    max_theta_observed: largest angle from the optical axis among the used corners, radians.
    recovered: views OpenCV could not use that the full-model refinement took back (also in ``used``).
    details: diagnostics (opencv_rms, model_rms, kept_detections, ...).
    """

    model: str
    lens: LensModel
    image_size: tuple[int, int]
    rms: float
    camera_matrix: np.ndarray
    distortion: np.ndarray
    kb_rms: float
    used: tuple[str, ...]
    dropped: tuple[DroppedImage, ...]
    rotations_cam_from_board: np.ndarray
    translations_cam: np.ndarray
    per_view_rms: np.ndarray
    coverage: float
    max_theta_observed: float
    recovered: tuple[str, ...] = ()
    details: dict[str, Any] = field(default_factory=dict)


# ------------------------------------------------------------------------ images
def list_images(folder: str | Path) -> list[Path]:
    """Image files in ``folder`` (not recursive), sorted by name; InputError if there are none."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError("image folder not found", path=folder)
    paths = sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
    if not paths:
        raise InputError(f"no images ({', '.join(IMAGE_SUFFIXES)}) in this folder", path=folder)
    return paths


def read_gray(path: str | Path) -> np.ndarray:
    """A grayscale uint8 image; InputError naming the file if it cannot be read."""
    path = Path(path)
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise InputError(
            "cannot read this image (missing, corrupt or not an image); replace it or remove it from the folder",
            path=path,
        )
    return image


def detect_in_images(
    paths: Sequence[str | Path], board: Board, progress: ProgressCallback | None = None
) -> tuple[list[Detection], list[DroppedImage]]:
    """Detect the board in every image; images without a board are returned as dropped.

    All images must have the same size (InputError naming the first that differs).
    """
    detections: list[Detection] = []
    dropped: list[DroppedImage] = []
    size: tuple[int, int] | None = None
    first = None
    for i, path in enumerate(paths):
        image = read_gray(path)
        this = (image.shape[1], image.shape[0])
        if size is None:
            size, first = this, Path(path).name
        elif this != size:
            raise InputError(
                f"image is {this[0]}x{this[1]} but {first} is {size[0]}x{size[1]}; "
                f"all images of one camera must have the same size",
                path=path,
            )
        det = detect_board(image, board, source=Path(path).name)
        if det is None:
            dropped.append(DroppedImage(Path(path).name, "no board found", "no_board"))
        else:
            detections.append(det)
        report(progress, "detect", i + 1, len(paths), unit="image")
    return detections, dropped


def image_size_of(detections: Sequence[Detection]) -> tuple[int, int]:
    sizes = {d.image_size for d in detections}
    if len(sizes) != 1:
        raise InputError(f"detections come from images of different sizes: {sorted(sizes)}")
    return sizes.pop()


# ---------------------------------------------------------------------- coverage
def image_coverage(detections: Sequence[Detection], image_size: tuple[int, int], grid: int = COVERAGE_GRID) -> float:
    """Share of the ``grid`` x ``grid`` image cells that hold at least one detected corner."""
    if not detections:
        return 0.0
    pixels = np.concatenate([d.pixels for d in detections])
    w, h = image_size
    cx = np.clip((pixels[:, 0] / w * grid).astype(int), 0, grid - 1)
    cy = np.clip((pixels[:, 1] / h * grid).astype(int), 0, grid - 1)
    return len(set(zip(cx.tolist(), cy.tolist()))) / float(grid * grid)


# ------------------------------------------------------------------- Kannala-Brandt
def _kb_lens(K: np.ndarray, D: np.ndarray) -> KannalaBrandt:
    return KannalaBrandt.from_opencv(K, D)


def _opencv_points(detections: Sequence[Detection], board: Board) -> tuple[list[np.ndarray], list[np.ndarray]]:
    obj_all = board.object_points()
    objs = [obj_all[d.ids].reshape(-1, 1, 3).astype(np.float64) for d in detections]
    imgs = [d.pixels.reshape(-1, 1, 2).astype(np.float64) for d in detections]
    return objs, imgs


def degenerate_reason(detection: Detection) -> str | None:
    """Why a view's corners cannot define a board pose (OpenCV's initialisation fails on them), or None.

    Corners on top of each other (closest pair < 0.5 px) or on one line (spread across the
    line < 2 px).
    """
    p = detection.pixels
    if len(p) < 4:
        return "fewer than 4 corners"
    d = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=-1)
    d[np.diag_indices(len(p))] = np.inf
    if d.min() < 0.5:
        return "corners on top of each other"
    sv = np.linalg.svd(p - p.mean(axis=0), compute_uv=False)
    if sv[-1] / np.sqrt(len(p)) < 2.0:
        return "corners on one line (board seen edge-on)"
    return None


#: Views whose corners all lie within this share of the half image size from the centre count as
#: central (for a 180-degree lens filling the image, about 60 degrees off-axis).
CENTRAL_RADIUS = 0.65


def central_views(
    detections: Sequence[Detection], image_size: tuple[int, int]
) -> tuple[list[Detection], list[Detection]]:
    """Split views into (central, outer) by their corner farthest from the image centre."""
    w, h = image_size
    centre = np.array([(w - 1) / 2.0, (h - 1) / 2.0])
    limit = CENTRAL_RADIUS * min(w, h) / 2.0
    central: list[Detection] = []
    outer: list[Detection] = []
    for d in detections:
        (central if np.linalg.norm(d.pixels - centre, axis=-1).max() <= limit else outer).append(d)
    return central, outer


def _calibrate_once(
    kept: Sequence[Detection], board: Board, image_size: Sequence[int], flags: int, criteria: tuple[int, int, float]
) -> tuple[Any, ...]:
    """cv2.fisheye.calibrate over the kept views: (rms, K, D, rvecs, tvecs)."""
    objs, imgs = _opencv_points(kept, board)
    # cv2's stubs lack None for K and D (estimated from scratch under these flags)
    result: tuple[Any, ...] = cv2.fisheye.calibrate(
        objs,
        imgs,
        tuple(int(v) for v in image_size),
        None,
        None,  # type: ignore[call-overload]
        flags=flags,
        criteria=criteria,
    )
    return result


def fisheye_calibrate(
    detections: Sequence[Detection],
    board: Board,
    image_size: tuple[int, int],
    *,
    min_images: int = DEFAULT_MIN_IMAGES,
    criteria: tuple[int, int, float] = FISHEYE_CRITERIA,
    flags: int = FISHEYE_FLAGS,
    progress: ProgressCallback | None = None,
) -> tuple[float, np.ndarray, np.ndarray, Any, Any, list[Detection], list[DroppedImage]]:
    """cv2.fisheye.calibrate with bad views dropped and the fit retried.

    1. Views whose corners are degenerate (:func:`degenerate_reason`) are dropped up front.
    2. CALIB_CHECK_COND errors name the ill-conditioned view ("... input array 7"): it is dropped
       and the fit runs again.
    3. Any other OpenCV error (e.g. the InitExtrinsics assertion) names no view: the views are
       left out one at a time (least spread first) until the fit succeeds; that view is dropped.

    Returns (rms, K, D, rvecs (M, 3), tvecs (M, 3), kept detections, dropped images).
    Raises InputError when fewer than ``min_images`` views remain or no single view explains a failure.
    """
    kept: list[Detection] = []
    dropped: list[DroppedImage] = []
    for det in detections:
        reason = degenerate_reason(det)
        if reason is None:
            kept.append(det)
        else:
            dropped.append(DroppedImage(det.source, reason, "degenerate"))
    attempt = 0
    while True:
        if len(kept) < min_images:
            raise InputError(too_few_message(len(kept), min_images, dropped))
        attempt += 1
        report(progress, "calibrate", attempt, None, unit="attempt", message=f"{len(kept)} boards")
        try:
            rms, K, D, rvecs, tvecs = _calibrate_once(kept, board, image_size, flags, criteria)
        except cv2.error as exc:
            text = str(exc)
            match = ILL_CONDITIONED.search(text)
            if "CALIB_CHECK_COND" in text and match and int(match.group(1)) < len(kept):
                bad = kept.pop(int(match.group(1)))
                dropped.append(
                    DroppedImage(
                        bad.source,
                        "ill-conditioned for OpenCV (board too small, too far, "
                        "too oblique or too far off-axis in this view)",
                        "ill_conditioned",
                    )
                )
                continue
            culprit = _find_failing_view(kept, board, image_size, flags, criteria)
            last_line = text.strip().splitlines()[-1]
            if culprit is None:
                raise InputError(
                    f"cv2.fisheye.calibrate failed on {len(kept)} boards ({last_line}); take more "
                    f"images with the whole board sharp and at different distances and angles"
                ) from None
            bad = kept.pop(culprit)
            dropped.append(DroppedImage(bad.source, f"OpenCV failed on this view ({last_line})", "opencv_failed"))
            continue
        if not (np.isfinite(rms) and np.all(np.isfinite(K)) and np.all(np.isfinite(D))):
            raise InputError(
                "the fisheye fit did not converge (non-finite result); take more images "
                "with the board at different distances and angles"
            )
        rv = np.asarray(rvecs, np.float64).reshape(-1, 3)
        tv = np.asarray(tvecs, np.float64).reshape(-1, 3)
        return float(rms), np.asarray(K, np.float64), np.asarray(D, np.float64).ravel(), rv, tv, kept, dropped


def _find_failing_view(
    kept: list[Detection], board: Board, image_size: Sequence[int], flags: int, criteria: tuple[int, int, float]
) -> int | None:
    """Index of a view whose removal lets the fit succeed (views with the least spread tried first)."""
    spread = [np.linalg.svd(d.pixels - d.pixels.mean(axis=0), compute_uv=False)[-1] for d in kept]
    for i in np.argsort(spread):
        trial = kept[:i] + kept[i + 1 :]
        try:
            _calibrate_once(trial, board, image_size, flags, criteria)
        except cv2.error:
            continue
        return int(i)
    return None


def reprojection_errors(
    lens: LensModel,
    detections: Sequence[Detection],
    board: Board,
    rotations_cam_from_board: np.ndarray,
    translations_cam: np.ndarray,
) -> list[np.ndarray]:
    """Per view, (N,) distances (pixels) between detected corners and corners projected by ``lens``."""
    obj_all = board.object_points()
    out = []
    for det, R, t in zip(detections, rotations_cam_from_board, translations_cam):
        points_cam = obj_all[det.ids] @ R.T + t
        proj = lens.project(points_cam)
        out.append(np.linalg.norm(proj - det.pixels, axis=-1))
    return out


def _rms(errors: Sequence[np.ndarray]) -> float:
    e = np.concatenate(errors)
    return float(np.sqrt(np.mean(e**2)))


def _max_theta(detections: Sequence[Detection], board: Board, R: np.ndarray, t: np.ndarray) -> float:
    obj_all = board.object_points()
    thetas = []
    for det, Ri, ti in zip(detections, R, t):
        p = obj_all[det.ids] @ Ri.T + ti
        thetas.append(np.arctan2(np.linalg.norm(p[:, :2], axis=-1), p[:, 2]))
    return float(np.max(np.concatenate(thetas)))


def calibrate_kannala_brandt(
    detections: Sequence[Detection],
    board: Board,
    image_size: tuple[int, int] | None = None,
    *,
    min_images: int = DEFAULT_MIN_IMAGES,
    min_coverage: float = DEFAULT_MIN_COVERAGE,
    dropped: Sequence[DroppedImage] = (),
    criteria: tuple[int, int, float] = FISHEYE_CRITERIA,
    recover: bool = True,
    progress: ProgressCallback | None = None,
) -> IntrinsicsResult:
    """Fit a Kannala-Brandt lens (cv2.fisheye.calibrate) to board detections.

    recover: give views OpenCV dropped (ill-conditioned or failing, typically boards far off-axis)
    a second chance through our full model, followed by a joint refinement (see _recover_views).
    When OpenCV used every view the result is OpenCV's.

    ``dropped``: images already left out (e.g. no board found), carried into the result.
    Raises InputError for too few boards or poor coverage of the image.
    """
    dropped = list(dropped)
    if not detections:
        raise InputError(
            "the board was not found in any image; check the board spec (inner corners for a "
            "checkerboard, squares for ChArUco) and that the whole board is visible"
        )
    if len(detections) < min_images:
        raise InputError(too_few_message(len(detections), min_images, dropped))
    size = image_size if image_size is not None else image_size_of(detections)
    coverage = image_coverage(detections, size)
    if coverage < min_coverage:
        raise InputError(
            f"poor coverage: the detected corners fill {coverage:.0%} of the image (4x4 cells), at least "
            f"{min_coverage:.0%} is needed; take more images with the board near the image edges and corners, "
            f"not only in one place"
        )
    first_min = min(min_images, MIN_OPENCV_VIEWS) if recover else min_images
    try:
        rms, K, D, rv, tv, kept, ill = fisheye_calibrate(
            detections, board, size, min_images=first_min, criteria=criteria, progress=progress
        )
    except InputError:
        # OpenCV's per-view start (x / z) breaks on boards far off-axis, and with a poor start it
        # refuses good views too. Second try: OpenCV on the central views only; the others are
        # then taken back through the full model.
        central, outer = central_views(detections, size)
        if not recover or len(central) < first_min or not outer:
            raise
        rms, K, D, rv, tv, kept, ill = fisheye_calibrate(
            central, board, size, min_images=first_min, criteria=criteria, progress=progress
        )
        ill = ill + [
            DroppedImage(d.source, "far off-axis: left out of OpenCV's first fit", "ill_conditioned") for d in outer
        ]
    dropped.extend(ill)
    R = rotation_matrices(rv)
    lens = _kb_lens(K, D)
    opencv_rms = float(rms)
    recovered: list[str] = []
    if recover and ill:
        lens, K, D, kept, R, tv, recovered, ill_left = _recover_views(
            lens, kept, R, tv, ill, detections, board, progress
        )
        dropped = [d for d in dropped if d not in ill] + ill_left
    if len(kept) < min_images:
        raise InputError(too_few_message(len(kept), min_images, dropped))
    errors = reprojection_errors(lens, kept, board, R, tv)
    model_rms = _rms(errors)
    return IntrinsicsResult(
        model="kannala_brandt",
        lens=lens,
        image_size=(size[0], size[1]),
        rms=model_rms if recovered else opencv_rms,
        camera_matrix=K,
        distortion=D,
        kb_rms=model_rms if recovered else opencv_rms,
        used=tuple(d.source for d in kept),
        dropped=tuple(dropped),
        rotations_cam_from_board=R,
        translations_cam=tv,
        per_view_rms=np.array([np.sqrt(np.mean(e**2)) for e in errors]),
        coverage=image_coverage(kept, size),
        max_theta_observed=_max_theta(kept, board, R, tv),
        recovered=tuple(recovered),
        details={"opencv_rms": opencv_rms, "model_rms": model_rms, "kept_detections": tuple(kept)},
    )


# ------------------------------------------------------------- bundle refinement
_BIG = 1e3  # residual (pixels) for a corner the trial model cannot project
#: A view OpenCV could not use is taken back if its pose fits the first lens this well (pixels).
RECOVER_MAX_RMS = 5.0
#: After the joint fit, a view whose RMS exceeds max(1 px, this times the overall RMS) is dropped.
OUTLIER_FACTOR = 4.0


def kb_project(params: np.ndarray, points_cam: np.ndarray) -> np.ndarray:
    """Kannala-Brandt projection for the optimiser: params (fx, fy, cx, cy, k1..k4).

    The formula of ergopose.geometry.lenses.kannala_brandt (theta = atan2(r, z)), without building
    a lens object per call; rays past the first turning point of theta_d are not masked here (the
    final model check with the real lens class is).
    """
    fx, fy, cx, cy, k1, k2, k3, k4 = params
    x, y, z = points_cam[:, 0], points_cam[:, 1], points_cam[:, 2]
    r = np.hypot(x, y)
    theta = np.arctan2(r, z)
    t2 = theta * theta
    theta_d = theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(r > 0, theta_d / r, 0.0)
    return np.stack([cx + fx * scale * x, cy + fy * scale * y], axis=-1)


def ds_project(params: np.ndarray, points_cam: np.ndarray) -> np.ndarray:
    """Double Sphere projection for the optimiser: params (fx, fy, cx, cy, xi, alpha); NaN outside
    the model's valid set (as ergopose.geometry.lenses.double_sphere)."""
    fx, fy, cx, cy, xi, alpha = params
    x, y, z = points_cam[:, 0], points_cam[:, 1], points_cam[:, 2]
    d1 = np.sqrt(x * x + y * y + z * z)
    k = xi * d1 + z
    d2 = np.sqrt(x * x + y * y + k * k)
    den = alpha * d2 + (1.0 - alpha) * k
    w1 = alpha / (1.0 - alpha) if alpha <= 0.5 else (1.0 - alpha) / alpha
    w2 = (w1 + xi) / np.sqrt(2.0 * w1 * xi + xi * xi + 1.0)
    valid = (z > -w2 * d1) & (den > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(valid, cx + fx * x / den, np.nan)
        v = np.where(valid, cy + fy * y / den, np.nan)
    return np.stack([u, v], axis=-1)


def refine_bundle(
    project: Callable[[np.ndarray, np.ndarray], np.ndarray],
    intr0: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    detections: Sequence[Detection],
    board: Board,
    rotations: np.ndarray,
    translations: np.ndarray,
    max_iterations: int = 100,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint least squares over lens parameters and per-view board poses (bundle adjustment).

    project(params, points_cam (N, 3)) -> (N, 2) pixels (NaN where invalid). Returns
    (params, rotations (M, 3, 3), translations (M, 3)).

    Levenberg-Marquardt on the sparse structure: the Jacobian comes from central differences (the
    six pose components are perturbed in all views at once, since a pose only moves its own
    corners), the normal equations are reduced to the lens parameters by the Schur complement of
    the 6x6 pose blocks. A step leaving [lower, upper] or the model's valid set is refused (larger
    damping). Stops when the cost improves by less than 1e-12 relative or the step is below 1e-12.
    """
    n_intr = len(intr0)
    obj_all = board.object_points()
    views = np.concatenate([np.full(len(d.ids), i) for i, d in enumerate(detections)])
    obj = np.concatenate([obj_all[d.ids] for d in detections])
    pix = np.concatenate([d.pixels for d in detections])
    M = len(detections)
    row_view = np.repeat(views, 2)  # residual row -> view
    lower = np.asarray(lower, np.float64)
    upper = np.asarray(upper, np.float64)

    def resid(intr: np.ndarray, poses: np.ndarray) -> np.ndarray | None:
        if np.any(intr < lower) or np.any(intr > upper):
            return None
        R = rotation_matrices(poses[:, :3])
        pts = np.einsum("nij,nj->ni", R[views], obj) + poses[views, 3:]
        with np.errstate(all="ignore"):
            r = (project(intr, pts) - pix).ravel()
        return r if np.all(np.isfinite(r)) else None

    def jacobian(intr: np.ndarray, poses: np.ndarray) -> Any:
        J_i = np.empty((pix.size, n_intr))
        for j in range(n_intr):
            h = 1e-6 * max(1.0, abs(intr[j]))
            ip, im = intr.copy(), intr.copy()
            ip[j] += h
            im[j] -= h
            rp, rm = resid(ip, poses), resid(im, poses)
            if rp is None or rm is None:  # at a bound: one-sided
                r0 = resid(intr, poses)
                rp, rm, h = (rp, r0, h / 2) if rp is not None else (r0, rm, h / 2)
            # None (a bound or a point that does not project) on both sides fails here, as it did before
            assert rp is not None and rm is not None
            J_i[:, j] = (rp - rm) / (2 * h)
        J_p = np.empty((pix.size, 6))  # row r: derivative w.r.t. its own view's pose component
        for k in range(6):
            h = 1e-7 * np.maximum(1.0, np.abs(poses[:, k]))
            pp, pm = poses.copy(), poses.copy()
            pp[:, k] += h
            pm[:, k] -= h
            rp, rm = resid(intr, pp), resid(intr, pm)
            assert rp is not None and rm is not None  # as above (the poses themselves have no bounds)
            J_p[:, k] = (rp - rm) / (2 * h[row_view])
        return J_i, J_p

    intr = np.asarray(intr0, np.float64).copy()
    poses = np.concatenate([rotation_vectors(rotations), translations], axis=1)
    r = resid(intr, poses)
    if r is None:
        raise InputError("the starting lens does not project every board corner; cannot refine")
    cost = float(r @ r)
    lam = 1e-3
    for _ in range(max_iterations):
        J_i, J_p = jacobian(intr, poses)
        U = J_i.T @ J_i
        g_i = J_i.T @ r
        # per-view blocks
        V = np.zeros((M, 6, 6))
        W = np.zeros((M, n_intr, 6))
        g_p = np.zeros((M, 6))
        np.add.at(V, row_view, J_p[:, :, None] * J_p[:, None, :])
        np.add.at(W, row_view, J_i[:, :, None] * J_p[:, None, :])
        np.add.at(g_p, row_view, J_p * r[:, None])
        improved = False
        while lam < 1e12:
            Ud = U + lam * np.diag(np.diag(U) + 1e-12)
            Vd = V + lam * (np.eye(6) * (np.diagonal(V, axis1=1, axis2=2)[:, None, :] + 1e-12))
            Vinv = np.linalg.inv(Vd)
            WVi = W @ Vinv  # (M, n_intr, 6)
            S = Ud - np.einsum("mij,mkj->ik", WVi, W)
            rhs = g_i - np.einsum("mij,mj->i", WVi, g_p)
            d_i = -np.linalg.solve(S, rhs)
            d_p = -np.einsum("mij,mj->mi", Vinv, g_p + np.einsum("mji,j->mi", W, d_i))
            new_r = resid(intr + d_i, poses + d_p)
            if new_r is not None and float(new_r @ new_r) < cost:
                step = np.sqrt(d_i @ d_i + np.sum(d_p * d_p))
                new_cost = float(new_r @ new_r)
                done = (cost - new_cost) <= 1e-12 * cost or step < 1e-12
                intr, poses, r, cost = intr + d_i, poses + d_p, new_r, new_cost
                lam = max(lam / 10.0, 1e-12)
                improved = True
                break
            lam *= 10.0
        if not improved or done:
            break
    return intr, rotation_matrices(poses[:, :3]), poses[:, 3:].copy()


def _kb_from_params(p: np.ndarray) -> KannalaBrandt:
    return KannalaBrandt(*(float(v) for v in p))


def _recover_views(
    lens: KannalaBrandt,
    kept: list[Detection],
    R: np.ndarray,
    t: np.ndarray,
    ill: Sequence[DroppedImage],
    detections: Sequence[Detection],
    board: Board,
    progress: ProgressCallback | None,
) -> tuple[
    KannalaBrandt, np.ndarray, np.ndarray, list[Detection], np.ndarray, np.ndarray, list[str], list[DroppedImage]
]:
    """Take back views OpenCV dropped (ill-conditioned, failed) when our full KB model explains them.

    cv2.fisheye works with x/z, so boards near or beyond 90 degrees off-axis break its per-view
    initialisation; our model (theta = atan2(r, z)) has no such limit. Each dropped view gets a pose
    by Levenberg-Marquardt through the first lens; views fitting within RECOVER_MAX_RMS px join a
    joint refinement of KB parameters and all poses; views that then fit worse than
    max(1 px, OUTLIER_FACTOR x overall RMS) are dropped again and the joint fit repeated once.
    """
    by_source = {d.source: d for d in detections}
    obj_all = board.object_points()
    candidates, poses_R, poses_t, still = [], [], [], []
    for item in ill:
        det = by_source.get(item.source)
        if det is None or item.code not in ("ill_conditioned", "opencv_failed"):
            still.append(item)
            continue
        try:
            pose = solve_pose(lens, obj_all[det.ids], det.pixels)
        except InputError:
            still.append(item)
            continue
        if pose.rms_px <= RECOVER_MAX_RMS:
            candidates.append(det)
            poses_R.append(pose.rotation_cam_from_world)
            poses_t.append(pose.translation_cam)
        else:
            still.append(item)
    if not candidates:
        K, D = lens.to_opencv()
        return lens, K, np.ravel(D), kept, R, t, [], list(ill)
    report(progress, "calibrate", 1, 2, unit="step", message=f"refining with {len(candidates)} recovered boards")
    dets = list(kept) + candidates
    Rs = np.concatenate([R, np.array(poses_R)])
    ts = np.concatenate([t, np.array(poses_t)])
    lower = np.array([1.0, 1.0, -np.inf, -np.inf, -np.inf, -np.inf, -np.inf, -np.inf])
    upper = np.full(8, np.inf)
    intr0 = np.array([lens.fx, lens.fy, lens.cx, lens.cy, *lens.coefficients])
    for _ in range(2):
        intr, Rs, ts = refine_bundle(kb_project, intr0, lower, upper, dets, board, Rs, ts)
        lens = _kb_from_params(intr)
        errors = reprojection_errors(lens, dets, board, Rs, ts)
        per_view = np.array([np.sqrt(np.mean(e**2)) for e in errors])
        limit = max(1.0, OUTLIER_FACTOR * _rms(errors))
        bad = per_view > limit
        if not bad.any():
            break
        for i in np.flatnonzero(bad):
            still.append(
                DroppedImage(dets[i].source, f"does not fit the lens model (RMS {per_view[i]:.2f} px)", "outlier")
            )
        keep = ~bad
        dets = [d for d, k in zip(dets, keep) if k]
        Rs, ts, intr0 = Rs[keep], ts[keep], intr
    report(progress, "calibrate", 2, 2, unit="step")
    in_fit = {id(d) for d in dets}
    recovered = [d.source for d in candidates if id(d) in in_fit]
    K, D = lens.to_opencv()
    return lens, K, np.ravel(D), dets, Rs, ts, recovered, still


# --------------------------------------------------------------------- Double Sphere
def _ds_lens(params: np.ndarray) -> DoubleSphere:
    fx, fy, cx, cy, xi, alpha = (float(v) for v in params)
    return DoubleSphere(fx, fy, cx, cy, xi, alpha)


def fit_double_sphere(
    kb: IntrinsicsResult, board: Board, *, progress: ProgressCallback | None = None
) -> IntrinsicsResult:
    """Refine a Double Sphere lens and the board poses over the corners of a Kannala-Brandt fit.

    Step 1: fit (fx, fy, cx, cy, xi, alpha) to the KB projection of rays up to the largest observed
    angle (plus 5 degrees). Step 2: joint least squares over all corners and per-view poses
    (scipy.optimize.least_squares, trf, sparse finite-difference Jacobian).
    """
    kept: tuple[Detection, ...] = kb.details["kept_detections"]
    K = kb.camera_matrix
    # step 1: match the KB projection over the observed field of view
    theta_max = min(kb.max_theta_observed + np.radians(5.0), kb.lens.max_theta)
    th, ph = np.meshgrid(np.linspace(0.0, theta_max, 40), np.linspace(0.0, 2 * np.pi, 24, endpoint=False))
    rays = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1).reshape(-1, 3)
    target = kb.lens.project(rays)
    ok = np.all(np.isfinite(target), axis=-1)
    rays, target = rays[ok], target[ok]

    lower = np.array([1.0, 1.0, -np.inf, -np.inf, -0.999, 0.0])
    upper = np.array([np.inf, np.inf, np.inf, np.inf, 0.999, 1.0])

    def resid_fit(p: np.ndarray) -> np.ndarray:
        try:
            proj = _ds_lens(p).project(rays)
        except ConfigError:  # parameters outside the model's valid range
            return np.full(rays.size // 3 * 2, _BIG)
        r = (proj - target).ravel()
        return np.where(np.isfinite(r), r, _BIG)

    # near the axis a Double Sphere with xi = 0 has the focal length of the KB fit: start from it
    fits = [
        least_squares(
            resid_fit,
            np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2], xi0, a0]),
            bounds=(lower, upper),
            x_scale="jac",
            max_nfev=400,
        )
        for xi0, a0 in ((0.0, 0.55), (-0.2, 0.6), (0.2, 0.5))
    ]
    best = min(fits, key=lambda res: res.cost)  # the first of equal costs, as before
    intr0 = best.x
    report(progress, "double_sphere", 1, 2, unit="step")

    # step 2: joint refinement over corners and poses
    intr, R, t = refine_bundle(
        ds_project, intr0, lower, upper, kept, board, kb.rotations_cam_from_board, kb.translations_cam
    )
    report(progress, "double_sphere", 2, 2, unit="step")
    lens = _ds_lens(intr)
    errors = reprojection_errors(lens, kept, board, R, t)
    return replace(
        kb,
        model="double_sphere",
        lens=lens,
        rms=_rms(errors),
        rotations_cam_from_board=R,
        translations_cam=t,
        per_view_rms=np.array([np.sqrt(np.mean(e**2)) for e in errors]),
        details={**kb.details, "model_rms": _rms(errors), "ds_init_rms": float(np.sqrt(np.mean(best.fun**2)))},
    )


def calibrate_intrinsics(
    detections: Sequence[Detection],
    board: Board,
    image_size: tuple[int, int] | None = None,
    *,
    model: str = "kannala_brandt",
    min_images: int = DEFAULT_MIN_IMAGES,
    min_coverage: float = DEFAULT_MIN_COVERAGE,
    dropped: Sequence[DroppedImage] = (),
    recover: bool = True,
    progress: ProgressCallback | None = None,
) -> IntrinsicsResult:
    """Kannala-Brandt fit, then (model="double_sphere") a Double Sphere refinement.

    This is what ``ergopose calibrate intrinsics`` runs after detecting the board.
    """
    if model not in MODELS:
        raise InputError(f"unknown lens model {model!r}; expected one of {', '.join(MODELS)}")
    kb = calibrate_kannala_brandt(
        detections,
        board,
        image_size,
        min_images=min_images,
        min_coverage=min_coverage,
        dropped=dropped,
        recover=recover,
        progress=progress,
    )
    if model == "kannala_brandt":
        return kb
    return fit_double_sphere(kb, board, progress=progress)


def calibrate_images(
    paths: Sequence[str | Path],
    board: Board,
    *,
    model: str = "kannala_brandt",
    min_images: int = DEFAULT_MIN_IMAGES,
    min_coverage: float = DEFAULT_MIN_COVERAGE,
    progress: ProgressCallback | None = None,
) -> IntrinsicsResult:
    """Detect the board in every image and calibrate (what ``ergopose calibrate intrinsics`` runs)."""
    detections, dropped = detect_in_images(paths, board, progress=progress)
    if not detections:
        names = ", ".join(Path(p).name for p in list(paths)[:3]) + (" ..." if len(paths) > 3 else "")
        raise InputError(
            f"the board ({board.spec()}) was not found in any of {len(paths)} image(s) ({names}); "
            f"check the board spec (checkerboard: INNER corners; charuco: squares) and that the "
            f"whole board is visible and sharp"
        )
    return calibrate_intrinsics(
        detections,
        board,
        image_size_of(detections),
        model=model,
        min_images=min_images,
        min_coverage=min_coverage,
        dropped=dropped,
        progress=progress,
    )
