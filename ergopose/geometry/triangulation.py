"""Triangulation of 2D joints seen in several pinhole (rectilinear, virtual) views.

The paper triangulates in the upright virtual pinhole views, not in the fisheye images, because
the pinhole projection is linear in homogeneous coordinates. A view's projection matrix is

    P = K [I | 0] [[R^T, 0], [0, 1]] W^-1       (paper, section "3D Human Pose Reconstruction")

with K the view's 3x3 pinhole matrix, R = ``rotation_cam_from_view`` (columns: the view's x, y, z
axes written in its fisheye camera's frame; a direction d_view in the view is R @ d_view in the
camera) and W = ``pose_world_from_cam`` (4x4; maps camera coordinates to world coordinates, so its
last column is the camera centre in the world).

Each observed pixel (u, v) of a world point X (homogeneous X~ = [X, 1]) in a view with rows
p0, p1, p2 of P gives two linear equations (DLT):

    (u p2 - p0) . X~ = 0,      (v p2 - p1) . X~ = 0.

Every row is divided by the norm of its first three entries, so that its residual is the distance
in metres of X from the plane through the camera centre that projects onto the image line x = u
(or y = v); then both rows of an observation are multiplied by its weight (the 2D confidence).
The default solver sets the homogeneous coordinate to 1 and solves the 3x3 normal equations in
closed form (Cramer's rule over all joints at once): the weighted least-squares point for those
planes, independent of where the world origin is. ``solver="svd"`` instead takes the unit vector
X~ minimising |A X~| (the classic homogeneous DLT, via the smallest eigenvector of the 4x4 matrix
A^T A, which equals the smallest right singular vector of A); with ``normalize_rows=False`` it is
the plain likelihood-weighted DLT of Pose2Sim.

Shapes: V views, J joints, ``...`` any leading shape (frames, people); the leading dimensions of
``projections``, ``pixels`` and ``weights`` broadcast against each other. Nothing loops in Python
over joints or frames. Units: metres for world points, pixels for image points.

An observation is *used* when its pixel is finite and its weight is finite and > 0. A point seen
by fewer than ``min_views`` views, or whose views cannot fix it (all rays through one centre, or
parallel), comes back NaN: a point is never invented.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Any

import numpy as np
from numpy.typing import ArrayLike

from ergopose.arrays import FloatArray
from ergopose.errors import InputError

__all__ = [
    "Triangulation",
    "RayTriangulation",
    "projection_matrix",
    "reproject",
    "triangulate_dlt",
    "triangulate_midpoint",
    "reject_outliers",
]

#: A point is NaN when det(N) < _DEGENERATE * (trace(N) / 3) ** 3 for its 3x3 normal matrix N:
#: the views' constraints do not fix it in all three directions (the rays meet at an angle of
#: roughly 1e-4 degrees or less, or all come from one centre).
_DEGENERATE = 1e-12


@dataclass(frozen=True)
class Triangulation:
    """Points triangulated from pinhole views, with per-view reprojection residuals.

    points: (..., J, 3) float, world frame (the frame of the projection matrices), metres. NaN
        where ``views_used < min_views`` or the views cannot fix the point (degenerate geometry).
    reprojection_error_px: (..., J) float, root mean square over the used views of
        ``residuals_px``. NaN where ``points`` is NaN; +inf when the point lies behind a used view.
    views_used: (..., J) int, how many views observed the joint (finite pixel, weight > 0); it is
        reported even where the point is NaN (e.g. 1 when only one view saw the joint).
    residuals_px: (..., V, J) float, distance in pixels between the observed pixel and the
        reprojected point in each view. NaN where that view's observation was excluded (NaN pixel,
        zero weight, rejected) or where ``points`` is NaN; +inf where the point is behind that view
        (depth <= 0), i.e. the observation cannot be explained by the point.
    """

    points: np.ndarray
    reprojection_error_px: np.ndarray
    views_used: np.ndarray
    residuals_px: np.ndarray


@dataclass(frozen=True)
class RayTriangulation:
    """Points closest (weighted least squares) to rays from several centres.

    points: (..., J, 3) float, frame of the origins and rays, metres. NaN where
        ``views_used < min_views`` or the rays are (nearly) parallel.
    rms_distance_m: (..., J) float, root mean square over the used rays of ``residuals_m``. NaN
        where ``points`` is NaN; +inf when the point lies behind a used ray's origin.
    views_used: (..., J) int, how many rays were used (finite ray, weight > 0); reported even
        where the point is NaN.
    residuals_m: (..., V, J) float, distance in metres from the point to each used ray. NaN where
        the ray was excluded or ``points`` is NaN; +inf where the point is behind the ray's origin.
    """

    points: np.ndarray
    rms_distance_m: np.ndarray
    views_used: np.ndarray
    residuals_m: np.ndarray


# --------------------------------------------------------------------------------------------
# Projection matrices


def _as_float(a: ArrayLike, name: str) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"not an array of numbers ({exc})", field=name) from None
    return arr


def _check_tail(arr: np.ndarray, tail: tuple[int, ...], name: str, what: str) -> None:
    if arr.ndim < len(tail) or arr.shape[arr.ndim - len(tail) :] != tail:
        raise InputError(f"expected shape {what}, got {arr.shape}", field=name)


def projection_matrix(
    K: ArrayLike, rotation_cam_from_view: ArrayLike | None = None, pose_world_from_cam: ArrayLike | None = None
) -> FloatArray:
    """The paper's ``P = K [I|0] [[R^T, 0], [0, 1]] W^-1`` for one or many views.

    K: (..., 3, 3) pinhole matrix of the (virtual) view, pixels.
    rotation_cam_from_view: (..., 3, 3) rotation R taking view coordinates to the coordinates of
        the physical (fisheye) camera the view belongs to: ``d_cam = R @ d_view``; its columns are
        the view's x (right), y (down), z (viewing direction) axes in the camera frame. None means
        identity (the view looks along the camera's axis).
    pose_world_from_cam: (..., 4, 4) rigid pose W of that camera in the world: ``X_world = W @
        X_cam``; its last column is the camera centre in the world. None means identity.
        For a calibration given as world->camera (R_wc, t) (OpenCV's rvec/tvec), ``P`` is simply
        ``K [R_wc | t]``, which equals this function with W = inverse([R_wc | t]).

    Returns (..., 3, 4) projection matrices (leading dimensions broadcast); a world point X
    projects to pixel ``(P @ [X, 1])[:2] / (P @ [X, 1])[2]`` and its depth along the view axis
    is ``(P @ [X, 1])[2]`` when K[2] = (0, 0, 1).
    Raises InputError when a matrix has the wrong shape or W / R is not a rigid transform.
    """
    K = _as_float(K, "K")
    _check_tail(K, (3, 3), "K", "(..., 3, 3)")
    if rotation_cam_from_view is None:
        R = np.eye(3)
    else:
        R = _as_float(rotation_cam_from_view, "rotation_cam_from_view")
        _check_tail(R, (3, 3), "rotation_cam_from_view", "(..., 3, 3)")
        _check_rotation(R, "rotation_cam_from_view")
    if pose_world_from_cam is None:
        W = np.eye(4)
    else:
        W = _as_float(pose_world_from_cam, "pose_world_from_cam")
        _check_tail(W, (4, 4), "pose_world_from_cam", "(..., 4, 4)")
        if not np.allclose(W[..., 3, :], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
            raise InputError("last row must be (0, 0, 0, 1)", field="pose_world_from_cam")
        _check_rotation(W[..., :3, :3], "pose_world_from_cam (rotation block)")
    R_wc = W[..., :3, :3]
    t_wc = W[..., :3, 3:]
    # [I|0] diag(R^T, 1) W^-1 = R^T [R_wc^T | -R_wc^T t_wc]  (W^-1 of a rigid W, no general inverse).
    R_view_from_world = np.swapaxes(R, -1, -2) @ np.swapaxes(R_wc, -1, -2)
    t_view = -(R_view_from_world @ t_wc)
    R_view_from_world, t_view = _broadcast_leading(R_view_from_world, t_view)
    P: FloatArray = K @ np.concatenate([R_view_from_world, t_view], axis=-1)
    return P


def _broadcast_leading(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lead = np.broadcast_shapes(a.shape[:-2], b.shape[:-2])
    return np.broadcast_to(a, lead + a.shape[-2:]), np.broadcast_to(b, lead + b.shape[-2:])


def _check_rotation(R: np.ndarray, name: str) -> None:
    eye = np.swapaxes(R, -1, -2) @ R
    if not np.all(np.isfinite(R)) or not np.allclose(eye, np.eye(3), atol=1e-6) or not np.all(np.linalg.det(R) > 0):
        raise InputError("not a rotation matrix (orthonormal, determinant +1)", field=name)


def reproject(projections: ArrayLike, points: ArrayLike) -> np.ndarray:
    """Project world points into each view.

    projections: (..., V, 3, 4); points: (..., J, 3) (leading dimensions broadcast).
    Returns (..., V, J, 2) pixels; NaN where the point is NaN or lies behind the view (depth <= 0,
    which assumes P is oriented as :func:`projection_matrix` builds it, i.e. K[2, 2] > 0).
    """
    P = _as_float(projections, "projections")
    X = _as_float(points, "points")
    _check_tail(P, (3, 4), "projections", "(..., V, 3, 4)")
    _check_tail(X, (3,), "points", "(..., J, 3)")
    h = _project_h(P, X)
    depth = h[..., 2:3]
    with np.errstate(invalid="ignore", divide="ignore"):
        pixels = h[..., :2] / depth
    return np.where(depth > 0, pixels, np.nan)


def _project_h(P: np.ndarray, X: np.ndarray) -> FloatArray:
    """Homogeneous image points (..., V, J, 3) of points X (..., J, 3) under P (..., V, 3, 4)."""
    projected: FloatArray = X[..., None, :, :] @ np.swapaxes(P[..., :3], -1, -2) + P[..., None, :, 3]
    return projected


# --------------------------------------------------------------------------------------------
# Shared pieces


def _weights(weights: ArrayLike | None, name: str = "weights") -> np.ndarray | None:
    """Weights as float array broadcastable to ``shape`` (..., V, J), or None for all ones."""
    if weights is None:
        return None
    w = _as_float(weights, name)
    if w.ndim < 2:
        raise InputError(f"expected shape (..., V, J), got {w.shape}", field=name)
    if np.any(w < 0):
        raise InputError("confidences must be >= 0", field=name)
    return w


def _check_min_views(min_views: int) -> int:
    if int(min_views) != min_views or min_views < 2:
        raise InputError(f"must be an integer >= 2 (a point needs two views), got {min_views!r}", field="min_views")
    return int(min_views)


def _solve_sym3(M: np.ndarray, usable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve N x = c, N = M[..., :3, :3, :] (symmetric), c = -M[..., :3, 3, :], by Cramer's rule.

    M: (..., 4, 4, J), joints last so every entry is one contiguous (..., J) slice.
    usable: (..., J) bool, joints to solve at all (enough views).
    Returns x (..., 3, J), NaN where not usable or not well posed (det(N) not clearly > 0),
    and the (..., J) mask of solved joints.
    """
    a, b, c = M[..., 0, 0, :], M[..., 0, 1, :], M[..., 0, 2, :]
    d, e, f = M[..., 1, 1, :], M[..., 1, 2, :], M[..., 2, 2, :]
    c00 = d * f - e * e
    c01 = c * e - b * f
    c02 = b * e - c * d
    det = a * c00 + b * c01 + c * c02
    tr3 = (a + d + f) * (1.0 / 3.0)
    ok = (det > _DEGENERATE * tr3 * tr3 * tr3) & usable
    inv = np.where(ok, -1.0 / det, np.nan)
    r0, r1, r2 = M[..., 0, 3, :] * inv, M[..., 1, 3, :] * inv, M[..., 2, 3, :] * inv
    x = np.empty(M.shape[:-3] + (3,) + M.shape[-1:])
    x[..., 0, :] = c00 * r0 + c01 * r1 + c02 * r2
    x[..., 1, :] = c01 * r0 + (a * f - c * c) * r1 + (b * c - a * e) * r2
    x[..., 2, :] = c02 * r0 + (b * c - a * e) * r1 + (a * d - b * b) * r2
    return x, ok


def _residuals(
    diff_a: np.ndarray,
    diff_b: np.ndarray | float,
    in_front: np.ndarray,
    used: np.ndarray,
    ok: np.ndarray,
    views_used: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-view residual hypot(diff_a, diff_b) (..., V, J) and its RMS over views (..., J).

    NaN where an observation is not used or its point not solved; +inf where ``in_front`` is
    False for a used observation (the point is behind that view / ray origin).
    """
    dist = np.where(in_front, np.hypot(diff_a, diff_b), np.inf)
    used_ok = used & ok[..., None, :]
    residuals = np.where(used_ok, dist, np.nan)
    sq = np.where(used_ok, dist, 0.0)
    sq *= sq
    rms = np.sqrt(sq.sum(axis=-2) / np.where(ok, views_used, 0))  # 0/0 -> NaN where not solved
    return residuals, rms


# --------------------------------------------------------------------------------------------
# DLT


def triangulate_dlt(
    projections: ArrayLike,
    pixels: ArrayLike,
    weights: ArrayLike | None = None,
    min_views: int = 2,
    *,
    solver: Literal["normal", "svd"] = "normal",
    normalize_rows: bool = True,
) -> Triangulation:
    """Weighted linear triangulation (DLT) of many joints in many frames at once.

    projections: (..., V, 3, 4) one projection matrix per view (see :func:`projection_matrix`).
    pixels: (..., V, J, 2) observed pixels of J joints in each view; NaN = not observed.
    weights: (..., V, J) confidences >= 0, or None for all 1. Both rows of an observation are
        multiplied by its weight (so squared residuals count with weight**2); weight 0 (or NaN)
        excludes the observation.
    min_views: points used by fewer views come back NaN (>= 2).
    solver: "normal" (default): homogeneous coordinate fixed to 1, 3x3 normal equations solved in
        closed form; "svd": unit homogeneous vector minimising |A x| (smallest eigenvector of
        A^T A), the classic DLT.
    normalize_rows: divide each row by the norm of its first three entries (default), so a row's
        residual is a point-to-plane distance in metres and neither the scale of P nor pixel
        coordinates in the hundreds weigh in; False keeps the raw rows (as Pose2Sim does).

    The leading dimensions (``...``) of the three inputs broadcast. Returns a :class:`Triangulation`
    (shapes and NaN meaning documented there).
    """
    P = _as_float(projections, "projections")
    uv = _as_float(pixels, "pixels")
    _check_tail(P, (3, 4), "projections", "(..., V, 3, 4)")
    _check_tail(uv, (2,), "pixels", "(..., V, J, 2)")
    if uv.ndim < 3:
        raise InputError(f"expected shape (..., V, J, 2), got {uv.shape}", field="pixels")
    if P.ndim < 3 or P.shape[-3] != uv.shape[-3]:
        raise InputError(f"{P.shape[:-2]} projection matrices for {uv.shape[-3]} views of pixels", field="projections")
    min_views = _check_min_views(min_views)
    if solver not in ("normal", "svd"):
        raise InputError(f"unknown solver {solver!r} (use 'normal' or 'svd')", field="solver")
    w = _weights(weights)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return _dlt(P, uv, w, min_views, solver, normalize_rows)


def _dlt(
    P: np.ndarray, uv: np.ndarray, w: np.ndarray | None, min_views: int, solver: str, normalize_rows: bool
) -> Triangulation:
    # Joints last throughout: (..., V, J) per observation, (..., V, 2, 4, J) rows, (..., 4, 4, J).
    u, v = uv[..., 0], uv[..., 1]
    used = np.isfinite(u + v)  # False when either is NaN or inf
    if w is None:
        scale = used.astype(np.float64)
    else:
        used = used & (w > 0)  # NaN weights compare False: excluded
        scale = np.where(used, w, 0.0)
    uv0 = np.where(used[..., None], uv, 0.0).swapaxes(-1, -2)  # (..., V, 2, J)
    # Rows (u p2 - p0), (v p2 - p1) of A: (..., V, 2, 4, J).
    rows = uv0[..., :, None, :] * P[..., 2:3, :, None] - P[..., :2, :, None]
    if normalize_rows:
        r3 = rows[..., :3, :]
        scale = scale[..., None, :] / np.sqrt(np.einsum("...ij,...ij->...j", r3, r3))
    else:
        scale = scale[..., None, :]
    rows *= scale[..., None, :]
    # Normal matrix M = A^T A summed over views and both rows: (..., 4, 4, J).
    M = np.einsum("...vrij,...vrkj->...ikj", rows, rows)

    views_used = used.sum(axis=-2)
    X, ok = _solve_sym3(M, views_used >= min_views)
    if solver == "svd":
        _, vecs = np.linalg.eigh(np.moveaxis(M, -1, -3))  # (..., J, 4, 4), ascending eigenvalues
        h = np.moveaxis(vecs[..., :, 0], -1, -2)  # (..., 4, J)
        X = np.where(ok[..., None, :], h[..., :3, :] / h[..., 3:, :], np.nan)
        ok = ok & np.isfinite(X).all(axis=-2)

    # Reprojection: (..., V, 3, J) homogeneous pixels of every point in every view.
    h = P[..., :3] @ X[..., None, :, :] + P[..., 3:]
    depth = h[..., 2, :]
    residuals, rms = _residuals(
        h[..., 0, :] / depth - uv0[..., 0, :], h[..., 1, :] / depth - uv0[..., 1, :], depth > 0, used, ok, views_used
    )
    shape = ok.shape
    if views_used.shape != shape:
        views_used = np.broadcast_to(views_used, shape).copy()
    return Triangulation(
        points=X.swapaxes(-1, -2), reprojection_error_px=rms, views_used=views_used, residuals_px=residuals
    )


# --------------------------------------------------------------------------------------------
# Midpoint (rays)


def triangulate_midpoint(
    origins: ArrayLike, rays: ArrayLike, weights: ArrayLike | None = None, min_views: int = 2
) -> RayTriangulation:
    """Weighted least-squares point closest to rays: the midpoint method for two or more rays.

    origins: (..., V, 3) ray origins (camera centres), metres.
    rays: (..., V, J, 3) ray directions (any length > 0) from each origin towards each joint;
        NaN = not observed.
    weights: (..., V, J) confidences >= 0 or None for all 1; weight 0 (or NaN) excludes a ray.
        As in :func:`triangulate_dlt` a ray's constraints are multiplied by its weight, so the
        point minimises ``sum_v (w_v * distance(X, ray_v)) ** 2``.
    min_views: points with fewer rays come back NaN (>= 2).

    Solves ``sum_v w_v^2 (I - d_v d_v^T) X = sum_v w_v^2 (I - d_v d_v^T) o_v`` (unit d_v) in
    closed form for all joints at once. Returns a :class:`RayTriangulation`.
    """
    O = _as_float(origins, "origins")
    D = _as_float(rays, "rays")
    _check_tail(O, (3,), "origins", "(..., V, 3)")
    _check_tail(D, (3,), "rays", "(..., V, J, 3)")
    if D.ndim < 3 or O.ndim < 2 or O.shape[-2] != D.shape[-3]:
        raise InputError(f"origins {O.shape} and rays {D.shape} do not have the same views (V)", field="rays")
    min_views = _check_min_views(min_views)
    w = _weights(weights)

    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return _midpoint(O, D, w, min_views)


def _midpoint(O: np.ndarray, D: np.ndarray, w: np.ndarray | None, min_views: int) -> RayTriangulation:
    d = np.swapaxes(D, -1, -2)  # (..., V, 3, J), joints last as in the DLT
    d = d / np.sqrt(np.einsum("...ij,...ij->...j", d, d))[..., None, :]
    o = O[..., :, :, None]  # (..., V, 3, 1)
    used = np.isfinite(d.sum(axis=-2)) & np.isfinite(O.sum(axis=-1))[..., None]
    if w is None:
        w2 = used.astype(np.float64)
    else:
        used = used & (w > 0)
        w2 = np.where(used, w * w, 0.0)
    d = np.where(used[..., None, :], d, 0.0)
    o = np.where(np.isfinite(o), o, 0.0)
    # Normal equations as a 4x4 [[N, -c], [., .]] so the DLT's solver serves: (..., 4, 4, J).
    wd = w2[..., None, :] * d  # (..., V, 3, J)
    dot_od = np.einsum("...ij,...ij->...j", o, d)  # (..., V, J)
    M = np.zeros(np.broadcast_shapes(wd.shape[:-3], o.shape[:-3]) + (4, 4, wd.shape[-1]))
    M[..., :3, :3, :] = np.eye(3)[:, :, None] * w2.sum(axis=-2)[..., None, None, :] - np.einsum(
        "...vij,...vkj->...ikj", wd, d
    )
    M[..., :3, 3, :] = (wd * dot_od[..., None, :]).sum(axis=-3) - (w2[..., None, :] * o).sum(axis=-3)
    views_used = used.sum(axis=-2)
    X, ok = _solve_sym3(M, views_used >= min_views)

    q = X[..., None, :, :] - o  # (..., V, 3, J)
    t = np.einsum("...ij,...ij->...j", q, d)
    perp = q - t[..., None, :] * d
    dist = np.sqrt(np.einsum("...ij,...ij->...j", perp, perp))
    residuals, rms = _residuals(dist, 0.0, t > 0, used, ok, views_used)
    shape = ok.shape
    if views_used.shape != shape:
        views_used = np.broadcast_to(views_used, shape).copy()
    return RayTriangulation(points=X.swapaxes(-1, -2), rms_distance_m=rms, views_used=views_used, residuals_m=residuals)


# --------------------------------------------------------------------------------------------
# Outlier rejection


def reject_outliers(
    projections: ArrayLike,
    pixels: ArrayLike,
    weights: ArrayLike | None = None,
    min_views: int = 2,
    *,
    threshold_px: float = 15.0,
    **dlt_options: Any,
) -> tuple[Triangulation, np.ndarray]:
    """DLT, then drop the worst view of each badly reprojected joint and triangulate again.

    In every round, each joint whose ``reprojection_error_px`` exceeds ``threshold_px`` and which
    is still used by more than ``min_views`` views loses the one view with the largest residual;
    then all joints are triangulated again. Rounds repeat until no joint qualifies (at most
    V - min_views rounds). A joint that stays above the threshold with ``min_views`` views keeps
    its point; its error tells how far it is off. Greedy: Pose2Sim instead tries every subset of
    views of each size and keeps the best, which can drop a different view.

    Same inputs as :func:`triangulate_dlt` (``dlt_options`` passes ``solver``/``normalize_rows``).
    Returns ``(triangulation, rejected)`` where ``rejected`` is a (..., V, J) boolean array, True
    for each observation that was used at first and then dropped as an outlier.
    """
    if not np.isfinite(threshold_px) or threshold_px <= 0:
        raise InputError(f"must be a positive number of pixels, got {threshold_px!r}", field="threshold_px")
    min_views = _check_min_views(min_views)
    P = _as_float(projections, "projections")
    uv = _as_float(pixels, "pixels")
    tri = triangulate_dlt(P, uv, weights, min_views, **dlt_options)
    shape = tri.residuals_px.shape
    w = np.ones(shape) if weights is None else np.broadcast_to(_as_float(weights, "weights"), shape)
    rejected = np.zeros(shape, dtype=bool)
    V = shape[-2]
    for _ in range(max(V - min_views, 0)):
        bad = (tri.reprojection_error_px > threshold_px) & (tri.views_used > min_views)
        if not bad.any():
            break
        worst = np.argmax(np.where(np.isnan(tri.residuals_px), -1.0, tri.residuals_px), axis=-2)
        drop = (np.arange(V)[:, None] == worst[..., None, :]) & bad[..., None, :]
        rejected |= drop
        tri = triangulate_dlt(P, uv, np.where(rejected, 0.0, w), min_views, **dlt_options)
    return tri, rejected
