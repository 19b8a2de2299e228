"""Association and triangulation of a run of frames: Detections2D per camera -> People3D.

Per frame, a camera's detections that are not the size of a person where their hips are are
left out (:mod:`ergopose.recon.person_scale`); the people of the C cameras (any C >= 1) are
grouped into sets of at most one detection per camera
(:func:`ergopose.recon.associate.associate_views`; with two cameras these are the pairs of
:func:`~ergopose.recon.associate.associate`). Every set of two or more cameras
is triangulated with the weighted DLT in its virtual views
(:func:`ergopose.geometry.triangulation.reject_outliers`, weights = 2D confidence, keypoints
below ``min_confidence`` excluded), all sets of all frames in one vectorised call. Outliers:
while a joint has three or more views the worst view above ``reprojection_threshold_px`` is
dropped (reject_outliers); with two views left nothing tells which of the two is wrong, so a
joint still above the threshold is rejected as a whole -- its point becomes NaN and its
observations are marked in ``rejected``. A joint seen by fewer than two cameras stays NaN:
nothing is invented. People in no set become single-view rows (n_cameras = 1).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.errors import InputError
from ergopose.geometry.triangulation import reject_outliers, triangulate_dlt
from ergopose.keypoints import NUM_JOINTS
from ergopose.progress import ProgressCallback, report
from ergopose.recon.associate import associate_views, canonical_sides
from ergopose.recon.person_scale import keep_person_sized
from ergopose.recon.records import TORSO_JOINTS, People3D, body_centres
from ergopose.recon.settings import ReconSettings
from ergopose.records import APPEARANCE_DIMS, Detections2D


def reconstruct_frames(
    frames: Sequence[Sequence[Detections2D]],
    settings: ReconSettings | None = None,
    progress: ProgressCallback | None = None,
) -> People3D:
    """Associate and triangulate every frame of a run.

    frames: for each frame, one Detections2D per camera (one or more cameras), in the same camera
        order every frame; frame indices must increase.
    Returns the :class:`People3D` rows of all frames (within a frame: the sets seen by two or
    more cameras, most cameras first (ViewAssociation order), then the single-view people of
    the first camera, of the second, ...).
    """
    settings = settings or ReconSettings()
    if not frames:
        raise InputError("no frames to reconstruct", field="frames")
    cameras = tuple(d.camera for d in frames[0])
    if not cameras:
        raise InputError("no cameras in the first frame", field="frames")
    twice = sorted({c for c in cameras if cameras.count(c) > 1})
    if twice:
        raise InputError(f"camera {twice[0]!r} is listed twice in a frame (cameras {list(cameras)})", field="frames")
    C = len(cameras)
    rows_frame, rows_time, rows_det, rows_ncam = [], [], [], []
    set_P, set_px, set_w, set_look = [], [], [], []
    single_rows = []  # (row index, camera position, Detections2D, person index)
    last = None
    for k, dets in enumerate(frames):
        if tuple(d.camera for d in dets) != cameras:
            raise InputError(
                f"frame {dets[0].frame if dets else k}: cameras {[d.camera for d in dets]} differ from {list(cameras)}",
                field="frames",
            )
        a = dets[0]
        if any(d.frame != a.frame for d in dets):
            raise InputError(f"the cameras disagree on the frame index ({[d.frame for d in dets]})", field="frames")
        if last is not None and a.frame <= last:
            raise InputError(f"frame indices must increase (frame {a.frame} after {last})", field="frames")
        last = a.frame
        dets = canonical_sides([keep_person_sized(d, settings.min_person_scale) for d in dets], settings)
        assoc = associate_views(dets, settings)
        g = assoc.groups
        if len(g):
            # Padded per-camera arrays: index -1 is the empty slot (camera not in the set).
            nmax = max(d.count for d in dets)
            P = np.zeros((C, nmax + 1, 3, 4))
            px = np.full((C, nmax + 1, NUM_JOINTS, 2), np.nan)
            w = np.zeros((C, nmax + 1, NUM_JOINTS))
            look = np.full((C, nmax + 1, APPEARANCE_DIMS), np.nan)
            for c, d in enumerate(dets):
                P[c, : d.count], px[c, : d.count], w[c, : d.count] = d.projection, d.pixels_view, d.confidence
                look[c, : d.count] = d.appearance
            cams = np.arange(C)[None, :]
            set_P.append(P[cams, g])
            set_px.append(px[cams, g])
            set_w.append(w[cams, g])
            set_look.append(_mean_over_cameras(look[cams, g]))
            rows_frame += [a.frame] * len(g)
            rows_time += [a.time_s] * len(g)
            rows_det += list(g)
            rows_ncam += list((g >= 0).sum(axis=1))
        for c, i in assoc.singles:
            single_rows.append((len(rows_frame), int(c), dets[c], int(i)))
            rows_frame.append(a.frame)
            rows_time.append(a.time_s)
            single = np.full(C, -1, np.int64)
            single[c] = i
            rows_det.append(single)
            rows_ncam.append(1)
        report(progress, "association", k + 1, len(frames), unit="frame")

    m = len(rows_frame)
    n_cameras = np.array(rows_ncam, dtype=np.int8)
    points = np.full((m, NUM_JOINTS, 3), np.nan)
    err = np.full((m, NUM_JOINTS), np.nan)
    views = np.zeros((m, NUM_JOINTS), np.int8)
    conf = np.zeros((m, NUM_JOINTS))
    rejected = np.zeros((m, C, NUM_JOINTS), bool)
    variance = np.full((m, NUM_JOINTS, 3), np.nan)
    origin = np.full((m, 3), np.nan)
    ray = np.full((m, 3), np.nan)
    obs_P = np.zeros((m, C, 3, 4))
    obs_px = np.full((m, C, NUM_JOINTS, 2), np.nan)
    obs_conf = np.zeros((m, C, NUM_JOINTS))
    appearance = np.full((m, APPEARANCE_DIMS), np.nan)
    is_set = n_cameras >= 2
    if set_P:
        P, px, w = np.concatenate(set_P), np.concatenate(set_px), np.concatenate(set_w)
        obs_P[is_set], obs_px[is_set], obs_conf[is_set] = P, px, w
        appearance[is_set] = np.concatenate(set_look)
        tri = triangulate_pairs(P, px, w, settings)
        points[is_set], err[is_set], views[is_set], conf[is_set], rejected[is_set], variance[is_set] = tri
    for row, cam, det, i in single_rows:
        obs_P[row, cam], obs_px[row, cam], obs_conf[row, cam] = det.projection[i], det.pixels_view[i], det.confidence[i]
        appearance[row] = det.appearance[i]
        c = det.confidence[i]
        used = c >= max(settings.min_confidence, 1e-12)
        views[row] = used
        conf[row] = np.where(used, c, 0.0)
        rays = det.world_rays()[i]
        origin[row] = det.centres_world()[i]
        ray[row] = _mean_ray(rays, used)
    return People3D(
        cameras=cameras,
        frame=np.array(rows_frame, np.int64),
        time_s=np.array(rows_time, np.float64),
        n_cameras=n_cameras,
        detection=np.array(rows_det, np.int32).reshape(m, C),
        points_world=points,
        reprojection_error_px=err,
        views=views,
        confidence=conf,
        rejected=rejected,
        variance_world=variance,
        centre_world=body_centres(points),
        ray_origin_world=origin,
        ray_world=ray,
        obs_projection=obs_P,
        obs_pixels_view=obs_px,
        obs_confidence=obs_conf,
        appearance=appearance,
    )


def _mean_over_cameras(look: np.ndarray) -> np.ndarray:
    """(G, C, D) per-camera appearance of G sets -> (G, D) mean over the cameras that measured
    each number; NaN where none did."""
    known = np.isfinite(look)
    count = known.sum(axis=1)
    total = np.where(known, look, 0.0).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _mean_ray(rays: np.ndarray, used: np.ndarray) -> FloatArray:
    """Unit mean of the torso joints' rays (else of all used rays); NaN if none."""
    torso = np.zeros_like(used)
    torso[TORSO_JOINTS] = True
    pick = used & torso if (used & torso).any() else used
    if not pick.any():
        return np.full(3, np.nan)
    r = rays[pick].sum(axis=0)
    direction: FloatArray = r / np.linalg.norm(r)
    return direction


def triangulate_pairs(
    projections: np.ndarray, pixels_view: np.ndarray, confidence: np.ndarray, settings: ReconSettings | None = None
) -> tuple[np.ndarray, ...]:
    """Triangulate associated people (two or more views each), all at once.

    projections: (M, V, 3, 4); pixels_view: (M, V, 33, 2); confidence: (M, V, 33). A view the
    person is not seen in (a camera outside its set) has an all-zero projection matrix (as in
    People3D.obs_projection) or confidence 0; it is left out.
    Returns (points (M, 33, 3), reprojection_error_px (M, 33), views (M, 33) int8,
    confidence (M, 33) mean over the used views, rejected (M, V, 33) bool,
    variance (M, 33, 3) per-coordinate variance from :func:`point_variance`).
    """
    settings = settings or ReconSettings()
    projections = np.asarray(projections, dtype=np.float64)
    absent = ~np.any(projections != 0.0, axis=(-2, -1))  # (M, V)
    w = np.where(confidence >= max(settings.min_confidence, 1e-12), confidence, 0.0)
    w = np.where(np.isfinite(pixels_view).all(axis=-1) & ~absent[..., None], w, 0.0)
    if absent.any():
        # A stand-in matrix (the person's first view, weight 0) keeps the algebra finite.
        first = np.argmax(~absent, axis=1)
        stand_in = projections[np.arange(len(projections)), first]
        projections = np.where(absent[..., None, None], stand_in[:, None], projections)
    tri, rejected = reject_outliers(projections, pixels_view, w, 2, threshold_px=settings.reprojection_threshold_px)
    points = tri.points.copy()
    err = tri.reprojection_error_px.copy()
    used = (w > 0) & ~rejected
    # Two views left and still above the threshold (or behind a view): no way to tell which
    # observation is wrong -- reject the joint.
    bad = np.isfinite(points).all(axis=-1) & ~(err <= settings.reprojection_threshold_px)
    rejected = rejected | (used & bad[:, None, :])
    used &= ~bad[:, None, :]
    points[bad] = np.nan
    err[bad] = np.nan
    n_used = used.sum(axis=1)
    ok = np.isfinite(points).all(axis=-1)
    views = np.where(ok, n_used, np.minimum(n_used, 1)).astype(np.int8)
    with np.errstate(invalid="ignore", divide="ignore"):
        conf = np.where(n_used > 0, np.where(used, w, 0.0).sum(axis=1) / n_used, 0.0)
    variance = point_variance(projections, points, np.where(used, w, 0.0), err, settings)
    return points, err, views, conf, rejected, variance


def view_focal_px(projections: np.ndarray) -> FloatArray:
    """(..., 3, 4) projection matrices -> (...) focal length in pixels, sqrt(fx fy) = sqrt(|det M|)
    of M = P[:, :3] scaled so that its last row has unit length (P = K R [I | -c], K[2] = (0, 0, 1))."""
    M = projections[..., :3]
    scale = np.linalg.norm(M[..., 2, :], axis=-1)
    focal: FloatArray = np.sqrt(np.abs(np.linalg.det(M))) / scale**1.5
    return focal


def point_variance(
    projections: np.ndarray,
    points: np.ndarray,
    weights: np.ndarray,
    reprojection_error_px: np.ndarray,
    settings: ReconSettings,
) -> np.ndarray:
    """Variance (m^2) of each coordinate of triangulated points, from the geometry of the rays.

    A keypoint seen in view v with confidence w has an angular error of about
    keypoint_sigma_px / (f_v w) radians (f_v: the view's focal length), i.e. a lateral error
    sigma_v = keypoint_sigma_px d_v / (f_v w) at the point's distance d_v from the camera. The
    information matrix of the point is sum_v (I - u_v u_v^T) / sigma_v^2 (u_v: unit direction
    from the camera to the point); its inverse is the point's covariance, whose diagonal is
    returned, multiplied by 1 + (reprojection_error / reprojection_scale_px)^2 (a poor fit means
    the 2D points were worse than assumed).

    projections: (M, V, 3, 4); points: (M, J, 3); weights: (M, V, J) (0 = view not used);
    reprojection_error_px: (M, J). Returns (M, J, 3); NaN where the point is NaN.
    """
    P = np.asarray(projections, dtype=np.float64)
    M3 = P[..., :3]
    centres = -np.linalg.solve(M3, P[..., 3:])[..., 0]  # (M, V, 3)
    f = view_focal_px(P)  # (M, V)
    v = points[:, None, :, :] - centres[:, :, None, :]  # (M, V, J, 3)
    d = np.linalg.norm(v, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = v / d[..., None]
        sigma = settings.keypoint_sigma_px * d / (f[..., None] * weights)
        inv_s2 = np.where((weights > 0) & np.isfinite(sigma), 1.0 / (sigma * sigma), 0.0)
    u = np.where(np.isfinite(u), u, 0.0)
    info = np.einsum("mvj,mvjab->mjab", inv_s2, np.eye(3) - u[..., :, None] * u[..., None, :])
    ok = np.isfinite(points).all(axis=-1) & (np.linalg.det(info) > 0)
    info[~ok] = np.eye(3)
    cov = np.linalg.inv(info)
    var = np.diagonal(cov, axis1=-2, axis2=-1).copy()
    with np.errstate(invalid="ignore"):
        var *= (1.0 + (reprojection_error_px / settings.reprojection_scale_px) ** 2)[..., None]
    var[~ok] = np.nan
    return var


#: A joint triangulated from every observation (:func:`triangulate_observations`) must reproject
#: within this (view pixels, RMS over the cameras).
UNGATED_MAX_PX = 15.0


def triangulate_observations(people: People3D) -> np.ndarray:
    """(M, 33, 3) each joint triangulated from every camera that saw it at all: weighted DLT with
    the confidences as weights and no confidence gate, kept where its RMS reprojection error is
    within UNGATED_MAX_PX; NaN where fewer than two cameras saw it. Rows without stored 2D
    observations (made from 3D points) give their points_world.

    Noisier than the gated triangulation but unbiased, and available where the gate leaves
    nothing (legs, neck and face under ceiling cameras): what body measurements are taken from.
    """
    if len(people) == 0:
        return people.points_world
    oc = people.obs_confidence
    P = people.obs_projection
    assert oc is not None and P is not None  # People3D.__post_init__ fills them
    # cameras that did not see the person: any invertible matrix (asarray: an array for numpy's stubs)
    absent = ~np.asarray((oc > 0).any(axis=-1))
    P = np.where(absent[..., None, None], np.eye(3, 4) + np.array([0.0, 0.0, 0.0, 1.0]), P)
    assert people.obs_pixels_view is not None
    px = np.where(oc[..., None] > 0, people.obs_pixels_view, np.nan)
    tri = triangulate_dlt(P, px, oc)
    X = np.where((tri.reprojection_error_px <= UNGATED_MAX_PX)[..., None], tri.points, np.nan)
    stored = oc.reshape(len(oc), -1).max(axis=1) > 0
    return np.where(stored[:, None, None], X, people.points_world)
