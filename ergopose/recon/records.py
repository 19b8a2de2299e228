"""The reconstruction stage's own record.

:class:`People3D` is the result of association and triangulation for a run of frames: one row
per person and frame, before tracking gives them identities. What the 2D pose stage hands over
(:class:`ergopose.records.Detections2D`) lives in :mod:`ergopose.records`, below every stage.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike

from ergopose.errors import InputError
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS
from ergopose.records import APPEARANCE_DIMS

#: Torso joints used for association, tracking centres and signatures: shoulders and hips.
TORSO_JOINTS = np.array([JOINT_INDEX[n] for n in ("left_shoulder", "right_shoulder", "left_hip", "right_hip")])
SHOULDERS = np.array([JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]])
HIPS = np.array([JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]])


@dataclass(frozen=True, eq=False)
class People3D:
    """People reconstructed in a run of frames, one row per person and frame (before tracking).

    M rows, C cameras (in the order of ``cameras``), J = 33 joints.

    cameras: (C,) camera names.
    frame: (M,) int64 frame index; rows are sorted by frame. time_s: (M,) float64 seconds.
    n_cameras: (M,) int8 -- the number of cameras in the person's set (>= 2: associated across
        them and triangulated), 1 for a person seen by one camera only (never triangulated:
        points all NaN).
    detection: (M, C) int32 index of the person in that camera's Detections2D of the frame,
        -1 where that camera did not see (or was not associated with) the person.
    points_world: (M, J, 3) float64 metres; NaN where the joint was not reconstructed (seen by
        fewer than two cameras, confidence below the threshold, rejected as outlier, or a
        single-view person).
    reprojection_error_px: (M, J) RMS reprojection error in view pixels; NaN where points is NaN.
    views: (M, J) int8 number of cameras whose observation of the joint was used: >= 2 for a
        triangulated joint, 1 where only one camera saw it (no 3D point), 0 where none did or
        the joint was rejected.
    confidence: (M, J) float64 mean 2D confidence of the used observations; 0 where views = 0.
    rejected: (M, C, J) bool, True where a camera's observation was dropped as an outlier.
    variance_world: (M, J, 3) variance (m^2) of each world coordinate of the point, from the
        geometry of the rays and the 2D noise model (triangulate.point_variance); NaN where
        points is NaN.
    centre_world: (M, 3) body centre used by the tracker: mean of the reconstructed torso joints
        (shoulders, hips), else of all reconstructed joints; NaN for single-view rows or when no
        joint was reconstructed.
    ray_origin_world, ray_world: (M, 3) for single-view rows the camera centre and the unit
        ray towards the torso (mean of the torso joints' rays, else of all found joints); NaN
        for pairs.
    obs_projection: (M, C, 3, 4) the projection matrix of the view in which each camera saw the
        person (zeros where it did not); obs_pixels_view: (M, C, 33, 2) that camera's keypoints
        in its view (NaN where not seen); obs_confidence: (M, C, 33) their confidences, without
        any gate (0 where not seen). The body model (recon.bodyfit) is fitted to these. None
        (rows made from 3D points only) gives zeros / NaN.
    appearance: (M, 6) the person's clothing colour (ergopose.pose.appearance), the mean over
        the cameras of the set that measured it; NaN where none did (None gives NaN).
    """

    cameras: tuple[str, ...]
    frame: np.ndarray
    time_s: np.ndarray
    n_cameras: np.ndarray
    detection: np.ndarray
    points_world: np.ndarray
    reprojection_error_px: np.ndarray
    views: np.ndarray
    confidence: np.ndarray
    rejected: np.ndarray
    variance_world: np.ndarray
    centre_world: np.ndarray
    ray_origin_world: np.ndarray
    ray_world: np.ndarray
    obs_projection: np.ndarray | None = None
    obs_pixels_view: np.ndarray | None = None
    obs_confidence: np.ndarray | None = None
    appearance: np.ndarray | None = None

    def __post_init__(self) -> None:
        m, c = len(self.frame), len(self.cameras)
        if self.appearance is None:
            object.__setattr__(self, "appearance", np.full((m, APPEARANCE_DIMS), np.nan))
        if self.obs_projection is None:
            object.__setattr__(self, "obs_projection", np.zeros((m, c, 3, 4)))
        if self.obs_pixels_view is None:
            object.__setattr__(self, "obs_pixels_view", np.full((m, c, NUM_JOINTS, 2), np.nan))
        if self.obs_confidence is None:
            object.__setattr__(self, "obs_confidence", np.zeros((m, c, NUM_JOINTS)))

    def __len__(self) -> int:
        return int(self.frame.shape[0])

    def take(self, rows: np.ndarray | Sequence[int]) -> "People3D":
        """The subset of rows (index array or boolean mask), in that order."""
        return People3D(self.cameras, *(getattr(self, f)[rows] for f in _ROW_FIELDS))

    @classmethod
    def concat(cls, parts: list["People3D"]) -> "People3D":
        if not parts:
            raise ValueError("nothing to concatenate")
        cams = parts[0].cameras
        if any(p.cameras != cams for p in parts):
            raise InputError("chunks with different cameras cannot be joined", field="cameras")
        return cls(cams, *(np.concatenate([getattr(p, f) for p in parts]) for f in _ROW_FIELDS))

    @classmethod
    def from_points(
        cls,
        frame: ArrayLike,
        time_s: ArrayLike,
        points_world: ArrayLike,
        *,
        variance_world: ArrayLike | None = None,
        confidence: ArrayLike | None = None,
        reprojection_error_px: ArrayLike | None = None,
        sigma_m: float = 0.03,
        cameras: tuple[str, ...] = ("cam_1", "cam_2"),
    ) -> "People3D":
        """Rows of already triangulated people (e.g. stored triangulations).

        points_world: (M, 33, 3); variance_world: (M, 33, 3) or None for sigma_m^2 everywhere;
        confidence: (M, 33) or None for 1; reprojection_error_px: (M, 33) or None for 0.
        """
        frame = np.asarray(frame, dtype=np.int64).reshape(-1)
        X = np.asarray(points_world, dtype=np.float64).reshape(-1, NUM_JOINTS, 3)
        m = X.shape[0]
        ok = np.asarray(np.isfinite(X).all(axis=-1))  # asarray: an array for numpy's stubs (no copy)
        conf = np.where(ok, 1.0, 0.0) if confidence is None else np.where(ok, confidence, 0.0)
        err = (
            np.where(ok, 0.0, np.nan) if reprojection_error_px is None else np.where(ok, reprojection_error_px, np.nan)
        )
        var = np.full(X.shape, sigma_m * sigma_m) if variance_world is None else np.asarray(variance_world, np.float64)
        c = len(cameras)
        return cls(
            cameras=tuple(cameras),
            frame=frame,
            time_s=np.asarray(time_s, dtype=np.float64).reshape(-1),
            n_cameras=np.full(m, 2, np.int8),
            detection=np.full((m, c), -1, np.int32),
            points_world=np.where(ok[..., None], X, np.nan),
            reprojection_error_px=err,
            views=np.where(ok, 2, 0).astype(np.int8),
            confidence=conf,
            rejected=np.zeros((m, c, NUM_JOINTS), bool),
            variance_world=np.where(ok[..., None], var, np.nan),
            centre_world=body_centres(X),
            ray_origin_world=np.full((m, 3), np.nan),
            ray_world=np.full((m, 3), np.nan),
        )


_ROW_FIELDS = (
    "frame",
    "time_s",
    "n_cameras",
    "detection",
    "points_world",
    "reprojection_error_px",
    "views",
    "confidence",
    "rejected",
    "variance_world",
    "centre_world",
    "ray_origin_world",
    "ray_world",
    "obs_projection",
    "obs_pixels_view",
    "obs_confidence",
    "appearance",
)


def body_centres(points_world: np.ndarray) -> np.ndarray:
    """(..., 33, 3) -> (..., 3): mean of the finite torso joints, else of all finite joints, else NaN."""
    X = np.asarray(points_world, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        torso = _nanmean_points(X[..., TORSO_JOINTS, :])
        allj = _nanmean_points(X)
    return np.where(np.isfinite(torso), torso, allj)


def _nanmean_points(X: np.ndarray) -> np.ndarray:
    ok = np.isfinite(X).all(axis=-1)
    n = ok.sum(axis=-1)
    s = np.where(ok[..., None], X, 0.0).sum(axis=-2)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n[..., None] > 0, s / n[..., None], np.nan)
