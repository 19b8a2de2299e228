"""A reference made from another 2D keypoint source: every camera's keypoints triangulated together.

A 3D reference such as Pose2Sim's TRC is itself a triangulation of a 2D network's keypoints, and
how it was triangulated is part of what it says. Pose2Sim, for one, leaves a camera out of a
keypoint when the keypoint reprojects more than 15 px away from it (its
``reproj_error_threshold_triangulation``), so a keypoint the networks place differently from
different sides (the hips, seen from the front and from the side) moves with the cameras that
were kept. To tell the assessment's own error from the reference's choice, this module builds a
second reference from the same 2D keypoints with a fixed, simple rule: every camera whose keypoint
has a likelihood of at least ``min_likelihood`` counts, weighted by its likelihood, in a linear
triangulation (DLT on the lens-corrected rays); nothing is left out after the fact. The result is
a :class:`ergopose.evaluation.trc.TrcData` in a TRC's axes (Y up; world y, z, x), compared exactly like a
TRC file (``ergopose evaluate --reference-keypoints DIR``).

Keypoint files: OpenPose JSON, one folder per camera (``cam01_json/cam01.0000.json``, ... as
OpenPose and Pose2Sim write them; the first person of each file, ``pose_keypoints_2d`` in the
BODY_25B order, :data:`ergopose.evaluation.markers.BODY_25B`). A folder belongs to the calibration's
camera whose name carries the same number (``cam01_json`` -> ``cam_01``); frame numbers are read
from the file names. This is evaluation code: nothing in the product imports it.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Sequence

import numpy as np

from ergopose.errors import InputError
from ergopose.evaluation.markers import BODY_25B
from ergopose.evaluation.trc import TrcData
from ergopose.geometry.camera import Camera
from ergopose.geometry.triangulation import triangulate_dlt

#: Pose2Sim's own likelihood threshold for triangulation (Config.toml,
#: likelihood_threshold_triangulation), the default here so both references use the same keypoints.
MIN_LIKELIHOOD = 0.3

_NUMBER = re.compile(r"(\d+)")
_FRAME = re.compile(r"(\d+)(?:_keypoints)?\.json$")


def _number(name: str) -> int | None:
    found = _NUMBER.findall(name)
    return int(found[-1]) if found else None


def camera_folders(root: Path, cameras: Sequence[Camera]) -> list[tuple[Camera, Path]]:
    """(camera, folder) for every sub-folder of ``root`` that holds JSON files, matched by the
    number in their names; InputError naming what does not match."""
    root = Path(root)
    if not root.is_dir():
        raise InputError("not a folder of per-camera keypoint folders", path=root)
    folders = sorted((p for p in root.iterdir() if p.is_dir() and any(p.glob("*.json"))), key=lambda p: p.name)
    if not folders:
        raise InputError(
            "no sub-folder with JSON keypoint files (expected one folder per camera, e.g. cam01_json/cam01.0000.json)",
            path=root,
        )
    by_number: dict[int, Camera] = {}
    for cam in cameras:
        n = _number(cam.name)
        if n is not None:
            if n in by_number:
                raise InputError(
                    f"cameras {by_number[n].name} and {cam.name} carry the same number: cannot tell "
                    "their keypoint folders apart",
                    path=root,
                )
            by_number[n] = cam
    pairs = []
    for folder in folders:
        n = _number(folder.name)
        if n is None or n not in by_number:
            raise InputError(
                f"keypoint folder {folder.name} matches no camera of the calibration "
                f"({', '.join(c.name for c in cameras)}): its number must be a camera's number",
                path=folder,
            )
        pairs.append((by_number[n], folder))
    if len(pairs) < 2:
        raise InputError("keypoints of at least two cameras are needed to triangulate a reference", path=root)
    return pairs


def read_openpose_folder(folder: Path, markers: int = len(BODY_25B)) -> tuple[np.ndarray, np.ndarray]:
    """(frame numbers (F,), keypoints (F, markers, 3) pixels x, y and likelihood) of a folder of
    OpenPose JSON files; a file without a person gives zero likelihoods."""
    files = []
    for p in folder.glob("*.json"):
        m = _FRAME.search(p.name)
        if m is None:
            raise InputError("cannot read a frame number from the file name", path=p)
        files.append((int(m.group(1)), p))
    files.sort()
    frames = np.array([f for f, _ in files], dtype=np.int64)
    out = np.zeros((len(files), markers, 3))
    for k, (_, p) in enumerate(files):
        try:
            people = json.loads(p.read_text(encoding="utf-8")).get("people", [])
        except (OSError, ValueError, AttributeError) as exc:
            raise InputError(f"not a readable OpenPose JSON file ({exc})", path=p) from None
        people = [q for q in people if isinstance(q, dict) and q.get("pose_keypoints_2d")]
        if not people:
            continue
        values = np.asarray(people[0]["pose_keypoints_2d"], dtype=np.float64)
        if values.size != markers * 3:
            raise InputError(
                f"pose_keypoints_2d has {values.size} numbers, expected {markers * 3} "
                f"(BODY_25B: {markers} keypoints x (x, y, likelihood))",
                path=p,
            )
        out[k] = values.reshape(markers, 3)
    return frames, out


def triangulate_weighted(cameras: Sequence[Camera], pixels: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Weighted DLT of every point at once, on the lens-corrected rays (normalised image
    coordinates, projection [R | t]), rows kept as they are (as Pose2Sim does).

    cameras: C cameras; pixels: (C, F, M, 2) image pixels; weights: (C, F, M), 0 = not used.
    Returns (F, M, 3) world points, NaN where fewer than two cameras have a weight.
    """
    normalised = np.empty(pixels.shape, dtype=np.float64)
    projections = []
    for c, cam in enumerate(cameras):
        rays = cam.lens.unproject(np.asarray(pixels[c], dtype=np.float64).reshape(-1, 2))
        with np.errstate(invalid="ignore", divide="ignore"):
            xy = rays[:, :2] / np.where(rays[:, 2:] > 0, rays[:, 2:], np.nan)
        normalised[c] = xy.reshape(pixels.shape[1:])
        R_cam = np.asarray(cam.rotation_world_from_cam).T  # world -> camera
        projections.append(np.hstack([R_cam, (-R_cam @ np.asarray(cam.position_world))[:, None]]))
    # (F, C, M, 2) observations of C views with one projection each.
    tri = triangulate_dlt(
        np.stack(projections),
        np.moveaxis(normalised, 0, 1),
        np.moveaxis(weights, 0, 1),
        solver="svd",
        normalize_rows=False,
    )
    return tri.points


def openpose_reference(
    root: str | Path, cameras: Sequence[Camera], fps: float, min_likelihood: float = MIN_LIKELIHOOD
) -> TrcData:
    """The reference of the module docstring, from the per-camera OpenPose folders under ``root``
    and the calibrated ``cameras``, sampled at ``fps`` (frame n at n / fps seconds)."""
    if not math.isfinite(fps) or fps <= 0:
        raise InputError(f"the frame rate must be positive, got {fps}", field="fps")
    if not 0.0 <= min_likelihood < 1.0:
        raise InputError(
            f"the likelihood threshold must be in [0, 1), got {min_likelihood}", field="--reference-min-likelihood"
        )
    pairs = camera_folders(Path(root), cameras)
    read = [read_openpose_folder(folder) for _, folder in pairs]
    frames = np.unique(np.concatenate([f for f, _ in read]))
    px = np.full((len(pairs), len(frames), len(BODY_25B), 2), np.nan)
    w = np.zeros((len(pairs), len(frames), len(BODY_25B)))
    for c, (f, k) in enumerate(read):
        at = np.searchsorted(frames, f)
        px[c, at] = k[..., :2]
        w[c, at] = np.where(k[..., 2] >= min_likelihood, k[..., 2], 0.0)
    points = triangulate_weighted([cam for cam, _ in pairs], px, w)
    # In a TRC's axes (Y up: world y, z, x), as every reference reaches the comparison.
    return TrcData(
        path=Path(root),
        markers=tuple(BODY_25B),
        points_trc=points[..., [1, 2, 0]],
        frame_numbers=frames + 1,
        times_s=frames / float(fps),
        rate_hz=float(fps),
        units="m",
    )


__all__ = ["MIN_LIKELIHOOD", "camera_folders", "openpose_reference", "read_openpose_folder", "triangulate_weighted"]
