"""The ground truth of one person in one camera and frame, as the 2D pose measurement
(ergopose.evaluation.pose) uses it: the joints it scores and fits views to, the rays and fisheye
pixels of the true joints, the hip centre's angle off the lens axis and the torso's size, and the
views and crops each condition shows the network."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ergopose.evaluation.pose_records import EvaluationSettings
from ergopose.geometry.views import VirtualView
from ergopose.keypoints import JOINT_INDEX
from ergopose.pose.blazepose import Roi
from ergopose.pose.fisheye import BODY_JOINTS
from ergopose.recon.records import HIPS, SHOULDERS, TORSO_JOINTS
from ergopose.sim.visibility import OUTSIDE_IMAGE, VISIBLE

#: Keypoints whose errors are measured (the ones RULA/REBA angles are built from).
EVAL_JOINT_NAMES: tuple[str, ...] = (
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
)
EVAL_JOINTS = np.array([JOINT_INDEX[n] for n in EVAL_JOINT_NAMES])

#: Keypoints that fit a view or crop to the body: the set the 2D stage fits its views to.
FIT_JOINTS = BODY_JOINTS


def unit_vectors(v: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)


def ray_angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles (radians) between unit vectors (..., 3), accurate near 0; NaN propagates."""
    return 2.0 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


def hip_centre_ray(rays: np.ndarray) -> np.ndarray:
    """(..., 33, 3) unit rays -> (..., 3) unit ray of the hip centre (mean of the two hip rays)."""
    return unit_vectors(rays[..., HIPS, :].mean(axis=-2))


@dataclass(frozen=True)
class PersonGeometry:
    """Ground truth of one person in one camera and frame (camera frame, fisheye pixels).

    rays_cam: (33, 3) unit rays to the joints. pixels: (33, 2) fisheye pixels (NaN outside the
    lens). visibility: (33,) codes. hip_world: (3,) the true hip centre (3D mid-point of the
    hips). hip_ray: (3,) unit ray of the hip centre, the normalised mean of the two hip rays
    (the construction used for predictions). torso_angle: 3D torso length (shoulder centre to
    hip centre) / distance of the hip centre from the camera (radians). theta: angle of
    hip_ray off the lens axis (radians). trunk_inclination: angle of the 3D hip-centre to
    shoulder-centre direction from the vertical (radians).
    """

    rays_cam: np.ndarray
    pixels: np.ndarray
    visibility: np.ndarray
    hip_world: np.ndarray
    hip_ray: np.ndarray
    torso_angle: float
    theta: float
    trunk_inclination: float = float("nan")

    @classmethod
    def of(cls, camera, joints_world: np.ndarray, pixels: np.ndarray, visibility: np.ndarray) -> "PersonGeometry":
        points_cam = camera.points_world_to_cam(joints_world)
        rays = unit_vectors(points_cam)
        hip_world = joints_world[HIPS].mean(axis=0)
        trunk = joints_world[SHOULDERS].mean(axis=0) - hip_world
        torso = float(np.linalg.norm(trunk))
        inclination = float(np.arccos(np.clip(trunk[2] / torso, -1.0, 1.0))) if torso > 0 else float("nan")
        distance = float(np.linalg.norm(camera.points_world_to_cam(hip_world)))
        # The hip centre's ray is built as for a prediction (mean of the two hip rays), so a
        # perfect prediction scores exactly zero; it differs from the ray to the 3D mid-point
        # by a small fraction of the hip width's angle.
        hip_ray = hip_centre_ray(rays)
        theta = float(np.arctan2(np.hypot(hip_ray[0], hip_ray[1]), hip_ray[2]))
        return cls(
            rays,
            np.asarray(pixels, np.float64),
            np.asarray(visibility),
            hip_world,
            hip_ray,
            torso / distance,
            theta,
            inclination,
        )

    @property
    def torso_visible(self) -> bool:
        """All four torso joints directly visible (visibility 0)."""
        return bool(np.all(self.visibility[TORSO_JOINTS] == VISIBLE))

    def counted(self, settings: EvaluationSettings) -> bool:
        """The person counts in the evaluation: every torso joint's code is in settings.torso_codes."""
        return bool(np.all(np.isin(self.visibility[TORSO_JOINTS], settings.torso_codes)))

    def view(self, camera, size: tuple[int, int], settings: EvaluationSettings):
        """The upright virtual view aimed at the true hip centre, fitted to the true body."""
        radius = float(np.max(ray_angles(self.rays_cam[FIT_JOINTS], self.hip_ray[None])))
        half = float(np.clip(radius * settings.margin, settings.min_half_fov, settings.max_half_fov))
        return VirtualView.aimed_along(camera, self.hip_ray, hfov=2.0 * half, size=size)

    def aligned_view(self, camera, size: tuple[int, int], settings: EvaluationSettings):
        """:meth:`view` rolled about its optical axis so hip -> shoulder points up in the image."""
        view = self.view(camera, size, settings)
        r = view.rotation_cam_from_view
        hip = view.lens.project(self.hip_ray @ r)
        shoulder = view.lens.project(unit_vectors(self.rays_cam[SHOULDERS].mean(axis=0)) @ r)
        d = shoulder - hip
        roll = float(np.arctan2(d[0], -d[1])) if np.all(np.isfinite(d)) and np.any(d != 0) else 0.0
        c, s = np.cos(roll), np.sin(roll)
        # A view pixel direction turned clockwise by ``roll`` from up comes out straight up.
        rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return VirtualView(
            source=view.source, lens=view.lens, width=view.width, height=view.height, rotation_cam_from_view=r @ rz
        )

    def _fit_pixels(self) -> np.ndarray:
        px = self.pixels[FIT_JOINTS]
        inside = (self.visibility[FIT_JOINTS] != OUTSIDE_IMAGE) & np.isfinite(px).all(axis=1)
        return px[inside]

    def crop_roi(self, settings: EvaluationSettings):
        """Axis-aligned square around the true keypoints' box in fisheye pixels (``crop``)."""
        px = self._fit_pixels()
        lo, hi = px.min(axis=0), px.max(axis=0)
        side = settings.margin * float(max(hi - lo))
        return Roi(centre=(lo + hi) / 2.0, side=max(side, 4.0), rotation=0.0)

    def rotated_roi(self, settings: EvaluationSettings):
        """Square on the true hip centre, rotated so hip -> shoulder points up (``rotated_crop``)."""
        hip = self.pixels[HIPS].mean(axis=0)
        axis = self.pixels[SHOULDERS].mean(axis=0) - hip
        rotation = float(np.arctan2(axis[0], -axis[1]))
        radius = float(np.max(np.linalg.norm(self._fit_pixels() - hip, axis=1)))
        return Roi(centre=hip, side=max(2.0 * settings.margin * radius, 4.0), rotation=rotation)
