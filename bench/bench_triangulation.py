"""Triangulation speed and accuracy (the paper's Table 2, "3D reconstruction": 0.01 s).

- triangulate_18x2: one call for 18 joints (the paper's COCO skeleton) seen in two virtual
  pinhole views of two ceiling cameras; goal under 0.1 ms. The same for the homogeneous
  (eigenvector) solver and for a plain per-joint np.linalg.svd of A, with the mean 3D error of
  each under 1 px Gaussian noise, to show which closed form is both fast and accurate.
- triangulate_batch_per_point_us: 10,000 frames x 33 joints x 2 views in one call.
- triangulate_vs_aniposelib: fisheye pixels -> 3D against aniposelib's CameraGroup.triangulate
  (see triangulate_vs_aniposelib() for the set-up).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from common import best_time, emit  # noqa: E402

from ergopose.geometry.triangulation import projection_matrix, reproject, triangulate_dlt  # noqa: E402

#: Two ceiling cameras 3 m high, 1.5 m apart (the paper's set-up).
CENTRES = np.array([[-0.75, 0.0, 3.0], [0.75, 0.0, 3.0]])
#: Pinhole matrix of a 320 x 320 virtual view with a 60 degree field of view.
VIEW_SIZE = 320
VIEW_F = (VIEW_SIZE / 2) / np.tan(np.radians(30.0))
K_VIEW = np.array([[VIEW_F, 0.0, (VIEW_SIZE - 1) / 2], [0.0, VIEW_F, (VIEW_SIZE - 1) / 2], [0.0, 0.0, 1.0]])
#: Fisheye cameras look straight down: camera x = world x, camera y = world -y, z = world -z.
R_WORLD_FROM_CAM = np.diag([1.0, -1.0, -1.0])


def pose_world_from_cam(centre: np.ndarray) -> np.ndarray:
    W = np.eye(4)
    W[:3, :3] = R_WORLD_FROM_CAM
    W[:3, 3] = centre
    return W


def rotation_cam_from_view(direction_cam: np.ndarray) -> np.ndarray:
    """An upright view (its y axis along the camera's 'down the image' as far as possible)
    whose optical axis is ``direction_cam`` (camera frame)."""
    z = direction_cam / np.linalg.norm(direction_cam)
    helper = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


def views_aimed_at(target_world: np.ndarray) -> np.ndarray:
    """(2, 3, 4) projection matrices of the two cameras' virtual views aimed at a target."""
    P = []
    for centre in CENTRES:
        W = pose_world_from_cam(centre)
        direction_cam = R_WORLD_FROM_CAM.T @ (target_world - centre)
        P.append(projection_matrix(K_VIEW, rotation_cam_from_view(direction_cam), W))
    return np.array(P)


def person(rng: np.random.Generator, n_joints: int, frames: int = 1) -> np.ndarray:
    """(frames, n_joints, 3) joints of a person standing somewhere on the 6 x 6 m floor."""
    feet = rng.uniform([-3.0, -3.0], [3.0, 3.0], size=(frames, 1, 2))
    offsets = rng.uniform([-0.3, -0.3, 0.1], [0.3, 0.3, 1.9], size=(frames, n_joints, 3))
    joints = offsets.copy()
    joints[..., :2] += feet
    return joints


def svd_per_joint(P: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """Textbook DLT: A (J, 4, 4) from raw rows, np.linalg.svd, last right singular vector."""
    u = pixels[..., 0][..., None]  # (V, J, 1)
    v = pixels[..., 1][..., None]
    rows = np.concatenate([u * P[:, None, 2] - P[:, None, 0], v * P[:, None, 2] - P[:, None, 1]], axis=0)
    A = np.swapaxes(rows, 0, 1)  # (J, 2V, 4)
    _, _, vt = np.linalg.svd(A)
    h = vt[:, -1]
    return h[:, :3] / h[:, 3:]


def triangulate_18x2() -> None:
    rng = np.random.default_rng(18)
    # Timing: one person, 18 joints, exact pixels.
    X = person(rng, 18)[0]
    P = views_aimed_at(X.mean(axis=0))
    pixels = reproject(P, X)
    times = {
        "normal": best_time(lambda: triangulate_dlt(P, pixels), repeat=50, number=200),
        "svd": best_time(lambda: triangulate_dlt(P, pixels, solver="svd"), repeat=50, number=200),
        "linalg_svd": best_time(lambda: svd_per_joint(P, pixels), repeat=50, number=200),
    }
    # Accuracy: 2,000 people at random places, 1 px noise in both views.
    n = 2000
    people = person(rng, 18, n)
    Ps = np.stack([views_aimed_at(p.mean(axis=0)) for p in people])  # (n, 2, 3, 4)
    noisy = reproject(Ps, people) + rng.normal(0.0, 1.0, size=(n, 2, 18, 2))
    errors = {
        "normal": triangulate_dlt(Ps, noisy).points,
        "svd": triangulate_dlt(Ps, noisy, solver="svd").points,
        "linalg_svd": np.stack([svd_per_joint(Ps[i], noisy[i]) for i in range(n)]),
    }
    errors = {k: 1000 * float(np.mean(np.linalg.norm(v - people, axis=-1))) for k, v in errors.items()}
    context = {"joints": 18, "views": 2, "view": f"{VIEW_SIZE}x{VIEW_SIZE} 60deg", "noise_px": 1.0}
    emit(
        "triangulate_18x2",
        times["normal"] * 1e3,
        "ms",
        goal_ms=0.1,
        paper_ms=10.0,
        solver="normal (closed-form 3x3, rows normalised)",
        mean_error_mm=errors["normal"],
        **context,
    )
    emit(
        "triangulate_18x2_svd",
        times["svd"] * 1e3,
        "ms",
        solver="svd (eigh of 4x4 A^T A)",
        mean_error_mm=errors["svd"],
        **context,
    )
    emit(
        "triangulate_18x2_linalg_svd",
        times["linalg_svd"] * 1e3,
        "ms",
        solver="np.linalg.svd of raw A, no residuals/NaN handling",
        mean_error_mm=errors["linalg_svd"],
        **context,
    )


def triangulate_batch() -> None:
    rng = np.random.default_rng(33)
    frames, joints = 10_000, 33
    X = person(rng, joints, frames)
    P = views_aimed_at(np.array([0.5, 0.5, 1.0]))
    pixels = reproject(P, X)  # (frames, 2, 33, 2)
    t = best_time(lambda: triangulate_dlt(P, pixels), repeat=3)
    emit(
        "triangulate_batch_per_point_us",
        t / (frames * joints) * 1e6,
        "us",
        frames=frames,
        joints=joints,
        views=2,
        total_s=t,
    )


#: Kannala-Brandt coefficients of a real fisheye: D1 of OpenCV's JY stereo calibration test
#: (opencv calib3d test_fisheye.cpp; ../shared/data/opencv-fisheye-stereo-jy/SOURCE.md).
JY_D1 = (-7.44253716539556e-05, -0.00702662033932424, 0.00737569823650885, -0.00342230256441771)
FISHEYE_W, FISHEYE_H = 2592, 1944  # the paper's Axis M3007-PV
MAX_THETA_DEG = 85.0  # cv2.fisheye (and so aniposelib) is unreliable beyond


def upright_rotations(direction_cam: np.ndarray, up_cam: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation_cam_from_view of views looking along ``direction_cam`` (..., 3),
    image y pointing down the world (against ``up_cam``); vectorised over the leading shape."""
    z = direction_cam / np.linalg.norm(direction_cam, axis=-1, keepdims=True)
    down = -np.asarray(up_cam, dtype=np.float64)
    y = down - np.sum(down * z, axis=-1, keepdims=True) * z
    norm = np.linalg.norm(y, axis=-1, keepdims=True)
    # Looking straight along the vertical: any upright is as good; use the camera's y axis.
    fallback = np.array([0.0, 1.0, 0.0]) - z[..., 1:2] * z
    y = np.where(norm > 1e-6, y, fallback)
    y /= np.linalg.norm(y, axis=-1, keepdims=True)
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=-1)


def triangulate_vs_aniposelib() -> None:
    """Fisheye pixels -> 3D joints: ours (fisheye rays -> virtual pinhole views aimed at each
    person -> DLT) against aniposelib (cv2.fisheye.undistortPoints -> DLT per point in jax).

    Two ceiling cameras 3 m high, 1.5 m apart, looking down, 2592 x 1944 Kannala-Brandt lenses
    (f = 620 px, JY_D1). 300 people anywhere on the 6 x 6 m floor, 33 joints each at 0.1-1.9 m;
    joints beyond 85 degrees from either lens axis are left out (NaN for us, not passed to
    aniposelib). 1 px Gaussian noise on the fisheye pixels (seeded).
    """
    from aniposelib.cameras import CameraGroup, FisheyeCamera

    from ergopose.geometry.camera import ceiling_camera
    from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt

    lens = KannalaBrandt(
        fx=620.0,
        fy=620.0,
        cx=(FISHEYE_W - 1) / 2,
        cy=(FISHEYE_H - 1) / 2,
        k1=JY_D1[0],
        k2=JY_D1[1],
        k3=JY_D1[2],
        k4=JY_D1[3],
    )
    cameras = [ceiling_camera(f"cam_{i + 1}", lens, FISHEYE_W, FISHEYE_H, c) for i, c in enumerate(CENTRES)]
    rng = np.random.default_rng(85)
    people, joints = 300, 33
    truth = person(rng, joints, people)  # (F, J, 3)
    theta = np.stack([cam.theta_of_points_world(truth) for cam in cameras])  # (2, F, J)
    keep = np.all(theta < np.radians(MAX_THETA_DEG), axis=0)  # (F, J)
    pixels = np.stack([cam.project_world(truth) for cam in cameras])  # (2, F, J, 2)
    pixels = pixels + rng.normal(0.0, 1.0, size=pixels.shape)
    pixels[:, ~keep] = np.nan
    assert np.all(np.stack([cam.in_image(pixels[i][keep]) for i, cam in enumerate(cameras)]))

    # aniposelib: world -> camera rvec/tvec, K and D as in cv2.fisheye.
    import cv2

    K_fish = np.array([[lens.fx, 0.0, lens.cx], [0.0, lens.fy, lens.cy], [0.0, 0.0, 1.0]])
    group = CameraGroup(
        [
            FisheyeCamera(
                matrix=K_fish,
                dist=np.array(JY_D1),
                size=(FISHEYE_W, FISHEYE_H),
                rvec=cv2.Rodrigues(cam.rotation_world_from_cam.T)[0].ravel(),
                tvec=-cam.rotation_world_from_cam.T @ cam.position_world,
                name=cam.name,
            )
            for cam in cameras
        ]
    )
    points_2d = np.ascontiguousarray(pixels[:, keep])  # (2, N, 2)

    def anipose() -> np.ndarray:
        return group.triangulate(points_2d, undistort=True)

    up_cam = np.stack([cam.rotation_world_from_cam.T @ np.array([0.0, 0.0, 1.0]) for cam in cameras])
    poses = np.stack([cam.pose_world_from_cam for cam in cameras])  # (2, 4, 4)

    def ours() -> np.ndarray:
        rays_cam = lens.unproject(pixels)  # (2, F, J, 3)
        # Each camera's view of a person looks at the mean of the person's rays (the detector's job).
        aim = np.nanmean(rays_cam, axis=-2)  # (2, F, 3)
        R = upright_rotations(aim, up_cam[:, None, :])  # (2, F, 3, 3) cam_from_view
        rays_view = rays_cam @ R  # R^T ray, row vectors
        pixels_view = rays_view[..., :2] / rays_view[..., 2:]  # K = identity
        P = projection_matrix(np.eye(3), R, poses[:, None])  # (2, F, 3, 4)
        tri = triangulate_dlt(np.swapaxes(P, 0, 1), np.swapaxes(pixels_view, 0, 1))
        return tri.points  # (F, J, 3)

    t_anipose = best_time(anipose, repeat=5)
    t_ours = best_time(ours, repeat=5)
    err_anipose = 1000 * np.linalg.norm(anipose() - truth[keep], axis=-1)
    err_ours = 1000 * np.linalg.norm(ours()[keep] - truth[keep], axis=-1)
    n = int(keep.sum())
    emit(
        "triangulate_vs_aniposelib",
        t_anipose / t_ours,
        "x",
        goal_x=5.0,
        points=n,
        points_left_out=int(keep.size - n),
        noise_px=1.0,
        max_theta_deg=MAX_THETA_DEG,
        ours_ms=t_ours * 1e3,
        aniposelib_ms=t_anipose * 1e3,
        ours_us_per_point=t_ours / n * 1e6,
        aniposelib_us_per_point=t_anipose / n * 1e6,
        ours_mean_error_mm=float(np.mean(err_ours)),
        aniposelib_mean_error_mm=float(np.mean(err_anipose)),
        ours_median_error_mm=float(np.median(err_ours)),
        aniposelib_median_error_mm=float(np.median(err_anipose)),
        ours_nan=int(np.isnan(err_ours).sum()),
        aniposelib_nan=int(np.isnan(err_anipose).sum()),
        aniposelib_version=_version("aniposelib"),
    )


def _version(package: str) -> str:
    from importlib.metadata import version

    return version(package)


def main() -> None:
    triangulate_18x2()
    triangulate_batch()
    triangulate_vs_aniposelib()


if __name__ == "__main__":
    main()
