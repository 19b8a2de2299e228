"""Records that cross stages, below every stage so that each can import them.

:class:`Detections2D` is what the 2D pose stage (:mod:`ergopose.pose`) hands over to the
reconstruction (:mod:`ergopose.recon`) for one camera and one frame: the people it found, each
with 33 keypoints in the pixels of the upright virtual view that was aimed at that person, and
that view's projection matrix (world -> view pixels). From the projection matrix alone the
reconstruction gets the camera centre and each keypoint's ray in the world, so nothing else about
the view is needed. :func:`detections_from_fisheye` builds the same record from keypoints given
in fisheye pixels (the simulator's oracle, or any source working on the fisheye image): it aims
one virtual view per person at the person's keypoints, as the 2D pose stage does, and maps the
keypoints into it.

This module imports only the base modules (errors, keypoints) and numpy; the layer test
(tests/test_layers.py) keeps it so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ergopose.arrays import FloatArray
from ergopose.errors import InputError
from ergopose.geometry.camera import Camera
from ergopose.keypoints import MIRROR, NUM_JOINTS


#: Numbers per person of Detections2D.appearance (ergopose.pose.appearance.APPEARANCE_DIMS).
APPEARANCE_DIMS = 6


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Detections2D:
    """People found by the 2D pose stage in one camera's frame.

    camera: name of the physical camera (as in the calibration).
    frame: frame index in the session (0-based, the same index in every camera).
    time_s: time of the frame in seconds from the start of the session.
    pixels_view: (N, 33, 2) float64 keypoints of N people in the pixels of the virtual view that
        produced each person (keypoints.BLAZEPOSE33 order); NaN = keypoint not found.
    confidence: (N, 33) float64 in [0, 1]; 0 = not found (NaN is read as 0). A keypoint with a
        NaN pixel has confidence 0 whatever was given.
    projection: (N, 3, 4) float64 projection matrix of each person's view, world points to view
        pixels (``VirtualView.projection_matrix``, the paper's P = K [I|0] [R^T 0; 0 1] W^-1),
        oriented so that points in front of the view have positive depth (K[2, 2] > 0).
    rays_world: optional (N, 33, 3) unit world directions from the camera centre towards each
        keypoint (NaN = not found). Computed from ``projection`` when not given (see
        :meth:`world_rays`).
    appearance: optional (N, 6) float64 clothing colour of each person in this camera
        (ergopose.pose.appearance: median L*a*b* of the upper body, then of the thighs; NaN where
        unknown). None (no image, e.g. the simulator's oracle keypoints) is all NaN.

    The arrays are converted to float64 and made read-only. InputError names a wrong shape.
    """

    camera: str
    frame: int
    time_s: float
    pixels_view: np.ndarray
    confidence: np.ndarray
    projection: np.ndarray
    rays_world: np.ndarray | None = None
    appearance: np.ndarray | None = None

    def __post_init__(self) -> None:
        where = f"detections[{self.camera!r}, frame {self.frame}]"
        try:
            px = np.array(self.pixels_view, dtype=np.float64).reshape(-1, NUM_JOINTS, 2)
            conf = np.array(self.confidence, dtype=np.float64).reshape(-1, NUM_JOINTS)
            P = np.array(self.projection, dtype=np.float64).reshape(-1, 3, 4)
        except (TypeError, ValueError) as exc:
            raise InputError(
                f"expected pixels_view (N, 33, 2), confidence (N, 33), projection (N, 3, 4): {exc}", field=where
            ) from None
        n = px.shape[0]
        if conf.shape[0] != n or P.shape[0] != n:
            raise InputError(
                f"{n} people in pixels_view but {conf.shape[0]} in confidence and {P.shape[0]} projection matrices",
                field=where,
            )
        if not np.all(np.isfinite(P)):
            raise InputError("projection matrices must be finite", field=where)
        conf = np.where(np.isfinite(conf), conf, 0.0)
        if np.any((conf < 0) | (conf > 1)):
            raise InputError("confidence must lie in [0, 1]", field=where)
        seen = np.asarray(np.isfinite(px).all(axis=-1))
        conf = np.where(seen, conf, 0.0)
        px = np.where(seen[..., None], px, np.nan)
        object.__setattr__(self, "frame", int(self.frame))
        object.__setattr__(self, "time_s", float(self.time_s))
        object.__setattr__(self, "pixels_view", _readonly(px))
        object.__setattr__(self, "confidence", _readonly(conf))
        object.__setattr__(self, "projection", _readonly(P))
        if self.rays_world is not None:
            rays = np.array(self.rays_world, dtype=np.float64)
            if rays.shape != (n, NUM_JOINTS, 3):
                raise InputError(f"rays_world must have shape ({n}, 33, 3), got {rays.shape}", field=where)
            rays = rays / np.linalg.norm(rays, axis=-1, keepdims=True)
            rays[~seen] = np.nan
            object.__setattr__(self, "rays_world", _readonly(rays))
        look = (
            np.full((n, APPEARANCE_DIMS), np.nan)
            if self.appearance is None
            else np.array(self.appearance, dtype=np.float64)
        )
        if look.shape != (n, APPEARANCE_DIMS):
            raise InputError(f"appearance must have shape ({n}, {APPEARANCE_DIMS}), got {look.shape}", field=where)
        object.__setattr__(self, "appearance", _readonly(look))

    @property
    def count(self) -> int:
        """Number of people N."""
        return int(self.pixels_view.shape[0])

    def centres_world(self) -> np.ndarray:
        """(N, 3) camera centre of each person's view (all the same for one camera): -M^-1 p4
        for P = [M | p4]."""
        if self.count == 0:
            return np.zeros((0, 3))
        M = self.projection[:, :, :3]
        return -np.linalg.solve(M, self.projection[:, :, 3:])[..., 0]

    def world_rays(self) -> FloatArray:
        """(N, 33, 3) unit world rays towards each keypoint; NaN where not found.

        ``rays_world`` when given; otherwise d = M^-1 (u, v, 1), which points in front of the
        view because the depth of centre + d is (M d)_3 = 1 > 0.
        """
        if self.rays_world is not None:
            return self.rays_world
        if self.count == 0:
            return np.zeros((0, NUM_JOINTS, 3))
        M = self.projection[:, :, :3]
        h = np.concatenate([self.pixels_view, np.ones(self.pixels_view.shape[:-1] + (1,))], axis=-1)
        d = np.linalg.solve(M[:, None], h[..., None])[..., 0]
        rays: FloatArray = d / np.linalg.norm(d, axis=-1, keepdims=True)
        return rays

    def with_sides_exchanged(self, people: np.ndarray) -> "Detections2D":
        """The same detections with the left and right keypoints of ``people`` ((N,) bool)
        exchanged (keypoints.MIRROR): the labelling a 2D network that took a person's back for
        their front (or the reverse) should have given."""
        people = np.asarray(people, dtype=bool)
        if not people.any():
            return self
        flip = people[:, None]
        px = np.where(flip[..., None], self.pixels_view[:, MIRROR], self.pixels_view)
        conf = np.where(flip, self.confidence[:, MIRROR], self.confidence)
        rays = (
            None if self.rays_world is None else np.where(flip[..., None], self.rays_world[:, MIRROR], self.rays_world)
        )
        return Detections2D(self.camera, self.frame, self.time_s, px, conf, self.projection, rays, self.appearance)

    def subset(self, people: np.ndarray) -> "Detections2D":
        """The detections of ``people`` ((N,) bool or indices) only, in their order."""
        keep = np.asarray(people)
        rays = None if self.rays_world is None else self.rays_world[keep]
        look = None if self.appearance is None else self.appearance[keep]
        return Detections2D(
            self.camera,
            self.frame,
            self.time_s,
            self.pixels_view[keep],
            self.confidence[keep],
            self.projection[keep],
            rays,
            look,
        )

    @classmethod
    def empty(cls, camera: str, frame: int, time_s: float) -> "Detections2D":
        """No people in this camera's frame."""
        return cls(camera, frame, time_s, np.zeros((0, NUM_JOINTS, 2)), np.zeros((0, NUM_JOINTS)), np.zeros((0, 3, 4)))


def detections_from_fisheye(
    camera: Camera,
    frame: int,
    time_s: float,
    pixels_fisheye: ArrayLike,
    confidence: ArrayLike,
    *,
    view_size: tuple[int, int] = (256, 256),
    margin_deg: float = 8.0,
    min_fov_deg: float = 20.0,
    max_fov_deg: float = 150.0,
) -> Detections2D:
    """Detections2D from keypoints in fisheye pixels (e.g. the simulator's oracle).

    camera: the :class:`ergopose.geometry.camera.Camera` that took the frame.
    pixels_fisheye: (N, 33, 2) keypoints in the camera's pixels, NaN = not found;
    confidence: (N, 33) in [0, 1].
    For each person, an upright virtual view (the view
    :meth:`ergopose.geometry.views.VirtualView.aimed_along` builds) is aimed along the mean ray
    of its found keypoints, with a square field of view wide enough for all of them (twice the
    largest angle from the view axis plus ``margin_deg``, clamped to [min_fov_deg,
    max_fov_deg]); the keypoints are mapped into it and its projection matrix is recorded -- the
    same record the 2D pose stage produces. A person without any found keypoint is dropped.
    Vectorised over people (tests check it against VirtualView).
    """
    px = np.asarray(pixels_fisheye, dtype=np.float64).reshape(-1, NUM_JOINTS, 2)
    conf = np.nan_to_num(np.asarray(confidence, dtype=np.float64).reshape(-1, NUM_JOINTS))
    if conf.shape[0] != px.shape[0]:
        raise InputError(
            f"{px.shape[0]} people in pixels but {conf.shape[0]} in confidence",
            field=f"detections[{camera.name!r}, frame {frame}]",
        )
    rays_cam = camera.lens.unproject(px)  # (N, 33, 3) unit rays, NaN where not representable
    seen = np.isfinite(rays_cam).all(axis=-1) & (conf > 0)
    keep = seen.any(axis=1)
    if not keep.any():
        return Detections2D.empty(camera.name, frame, time_s)
    rays_cam, seen, conf = rays_cam[keep], seen[keep], conf[keep]
    axis = np.where(seen[..., None], rays_cam, 0.0).sum(axis=1)
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    cosang = np.clip(np.einsum("njk,nk->nj", np.where(seen[..., None], rays_cam, 0.0), axis), -1.0, 1.0)
    half = np.degrees(np.arccos(np.where(seen, cosang, 1.0)).max(axis=1))
    fov = np.radians(np.clip(2.0 * half + margin_deg, min_fov_deg, max_fov_deg))
    up_cam = np.asarray(camera.rotation_world_from_cam, dtype=np.float64).T @ np.array([0.0, 0.0, 1.0])
    R = upright_rotations(axis, up_cam)  # (N, 3, 3) rotation_cam_from_view
    w, h = int(view_size[0]), int(view_size[1])
    f = 0.5 * w / np.tan(0.5 * fov)
    K = np.zeros((len(f), 3, 3))
    K[:, 0, 0] = f
    K[:, 1, 1] = f
    K[:, 0, 2] = 0.5 * (w - 1)
    K[:, 1, 2] = 0.5 * (h - 1)
    K[:, 2, 2] = 1.0
    rays_view = np.einsum("nkj,nik->nij", R, rays_cam)  # R^T d
    with np.errstate(invalid="ignore", divide="ignore"):
        z = rays_view[..., 2]
        ok = seen & (z > 0)
        pv = np.stack(
            [
                f[:, None] * rays_view[..., 0] / z + K[:, None, 0, 2],
                f[:, None] * rays_view[..., 1] / z + K[:, None, 1, 2],
            ],
            axis=-1,
        )
    pv = np.where(ok[..., None], pv, np.nan)
    R_wc = np.asarray(camera.rotation_world_from_cam, dtype=np.float64)
    c = np.asarray(camera.position_world, dtype=np.float64)
    R_view_from_world = np.swapaxes(R, -1, -2) @ R_wc.T
    P = K @ np.concatenate([R_view_from_world, -(R_view_from_world @ c)[..., None]], axis=-1)
    return Detections2D(camera.name, frame, time_s, pv, np.where(ok, conf, 0.0), P)


def upright_rotations(direction_cam: np.ndarray, up_cam: np.ndarray) -> np.ndarray:
    """(N, 3) viewing directions -> (N, 3, 3) rotation_cam_from_view of upright views.

    The same construction as :func:`ergopose.geometry.views.upright_rotation` (columns x, y, z of
    the view in the camera frame; z = direction, x = z x up, y = z x x), vectorised; where the
    direction is parallel to up, the camera's -y (then x) axis serves as up.
    """
    z = direction_cam / np.linalg.norm(direction_cam, axis=-1, keepdims=True)
    x = np.zeros_like(z)
    done = np.zeros(len(z), bool)
    for up in (np.asarray(up_cam, dtype=np.float64), np.array([0.0, -1.0, 0.0]), np.array([1.0, 0.0, 0.0])):
        cand = np.cross(z, up)
        n = np.linalg.norm(cand, axis=-1)
        good = ~done & (n > 1e-9 * np.linalg.norm(up))
        x[good] = cand[good] / n[good, None]
        done |= good
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=-1)
