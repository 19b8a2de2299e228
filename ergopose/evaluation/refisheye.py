"""Real people in virtual fisheye cameras: the Pose2Sim recording re-rendered (evaluation only).

The 2D stage (:mod:`ergopose.pose.fisheye`) is measured on real people by re-rendering the
4-camera Pose2Sim recording (/work/shared/data/pose2sim-demo: pinhole videos, 1080 x 1920,
60 fps, and their calibration) into virtual **equidistant fisheye** cameras that share each real
camera's centre:

* the person's hip centre (median over the frames, from the reference poses below) lies
  ``off_axis`` radians from the virtual lens axis: the axis is the hip ray tilted by that angle
  towards the real camera's image up;
* the virtual camera is then rotated about its own axis by ``roll`` (the direction of the
  person in the fisheye image turns with it; at pi the person stands on their head in the
  raw image, as people in half of a ceiling fisheye image do);
* ``px_per_rad`` sets the pixel density (r = f theta); the image is square, centred on the
  lens axis, large enough to hold the person (``off_axis`` + 25 degrees).

The virtual camera's pose in the world is the real camera's turned by the same rotation, so the
stage knows the world's vertical exactly as it would for a calibrated fisheye. Pixels of the
virtual image that the real camera did not see are black.

Reference: BlazePose on the ORIGINAL pinhole frames, placed the way MediaPipe places its crop
(the detector on the whole frame, padded to a square; the landmark network on the detector's
rotated crop; again on the crop its own alignment points give), mapped to rays in the real
camera and turned into the virtual camera. The errors below are therefore what the fisheye
re-rendering and the fisheye stage add to the same network on the same people.

Scores per virtual camera and frame (the person is counted when the reference found them):

* found: the stage reports a person whose hip centre (mean of the two hip rays) lies within
  0.5 torso lengths of the reference's; the closest detection is scored.
* keypoint error: angle between the stage's and the reference's rays of the 12 limb keypoints
  (shoulders, elbows, wrists, hips, knees, ankles) that the reference gives with confidence >=
  0.5, divided by the angle of the reference torso (shoulder centre to hip centre).
* left/right swap: of the six left/right pairs above where both the stage's keypoints have
  confidence >= 0.5 (a confident pose), a pair is swapped when the crossed assignment is closer
  to the reference than the straight one by more than 0.1 torso lengths; a frame is swapped
  when more than half of its confident pairs are, with at least two confident pairs. Limbs the
  stage marked uncertain (confidence lowered) are not confident and do not count.

Run: ``python -m ergopose.evaluation.refisheye --out table.md`` (see ``main`` for options).
This module imports the product; the product never imports it.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import sys
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import cv2
import numpy as np

from ergopose import atomic
from ergopose.errors import InputError
from ergopose.geometry.camera import Camera
from ergopose.geometry.lenses.equidistant import Equidistant
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.geometry.views import build_map
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS
from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker, Roi
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.pose.settings import PoseSettings
from ergopose.session import load_session
from ergopose.sim.ground_truth import load_ground_truth
from ergopose.video import read_frames as read_video

DEFAULT_ROOT = Path("/work/shared/data/pose2sim-demo")
LIMB_NAMES = ("shoulder", "elbow", "wrist", "hip", "knee", "ankle")
PAIRS = np.array([(JOINT_INDEX["left_" + n], JOINT_INDEX["right_" + n]) for n in LIMB_NAMES])
LIMBS = PAIRS.ravel()
HIPS = PAIRS[3]
SHOULDERS = PAIRS[0]


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return 2.0 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


# --------------------------------------------------------------------------------------------
# The recording


def load_cameras(root: Path = DEFAULT_ROOT) -> list[Camera]:
    """The four real cameras as ergopose cameras (pinhole lens; the calibration's distortion,
    |k1| < 1e-3, moves no pixel by more than about 0.3 px and is left out)."""
    calib = tomllib.loads((root / "Calib_qualisys.toml").read_text())
    names = sorted((k for k in calib if k.startswith("cam_")), key=lambda k: int(k.split("_")[1]))
    cameras = []
    for name in names:
        c = calib[name]
        K = np.array(c["matrix"], dtype=np.float64)
        r_cam_from_world, _ = cv2.Rodrigues(np.array(c["rotation"], dtype=np.float64))
        t = np.array(c["translation"], dtype=np.float64)
        lens = Rectilinear(K[0, 0], K[1, 1], K[0, 2], K[1, 2])
        cameras.append(Camera(name, lens, 1080, 1920, r_cam_from_world.T, -r_cam_from_world.T @ t))
    return cameras


def read_frames(root: Path, camera_number: int, count: int) -> list[np.ndarray]:
    cap = cv2.VideoCapture(str(root / "videos" / f"cam{camera_number:02d}.mp4"))
    frames: list[np.ndarray] = []
    while len(frames) < count:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
    cap.release()
    return frames


def _world_up_roll(camera: Camera, pixel: np.ndarray) -> float:
    """Angle (radians, clockwise from image up) of the image of the world's vertical at a pixel."""
    ray = _unit(camera.lens.unproject(np.asarray(pixel, dtype=np.float64)))
    point = camera.points_cam_to_world(3.0 * ray)
    v = camera.project_world(point + [0.0, 0.0, 0.1]) - camera.project_world(point)
    return float(np.arctan2(v[0], -v[1]))


def reference_pose(
    frame: np.ndarray, detector, landmarker, upright_camera: Camera | None = None
) -> tuple[np.ndarray, np.ndarray] | None:
    """BlazePose on a whole pinhole frame, MediaPipe's way: (33, 2) pixels and (33,) confidence,
    or None when the detector finds nobody. upright_camera: the crops are turned to the image of
    the world's vertical at the hips instead of the body axis (an upright reference)."""

    h, w = frame.shape[:2]
    side = max(h, w)
    pad = np.zeros((side, side, 3), np.uint8)
    y0, x0 = (side - h) // 2, (side - w) // 2
    pad[y0 : y0 + h, x0 : x0 + w] = frame
    size = detector.input_size[0]
    people = detector(cv2.resize(pad, (size, size), interpolation=cv2.INTER_AREA))
    if not people:
        return None
    det = people[0]
    scale = side / size
    kps = (det.keypoints + 0.5) * scale - 0.5 - np.array([x0, y0])
    v = kps[1] - kps[0]

    def turn(centre, v):
        return float(np.arctan2(v[0], -v[1])) if upright_camera is None else _world_up_roll(upright_camera, centre)

    roi = Roi(kps[0], 2.0 * 1.25 * float(np.linalg.norm(v)), turn(kps[0], v))
    n = landmarker.input_size[0]
    kp = None
    for _ in range(2):  # the detector's crop, then the crop of the network's own alignment points
        kp = landmarker(roi.crop(frame, n)).transformed(roi.crop_to_image(n))
        a = kp.alignment
        v = a[1] - a[0]
        roi = Roi(a[0], 2.0 * 1.25 * float(np.linalg.norm(v)), turn(a[0], v))
    if kp is None or kp.presence < 0.5:  # kp is set: the loop runs twice
        return None
    return kp.pixels, kp.confidence


# --------------------------------------------------------------------------------------------
# Virtual fisheye cameras


@dataclass(frozen=True)
class VirtualFisheye:
    camera: Camera  # the virtual camera (equidistant lens, pose in the world)
    rotation_real_from_virtual: np.ndarray
    off_axis: float
    roll: float
    px_per_rad: float


def virtual_fisheye(
    real: Camera, hip_ray_real: np.ndarray, off_axis: float, roll: float, px_per_rad: float
) -> VirtualFisheye:
    d = _unit(np.asarray(hip_ray_real, dtype=np.float64))
    up = np.array([0.0, -1.0, 0.0])  # the real camera's image up
    perp = _unit(up - d * (up @ d))
    axis = np.cos(off_axis) * d + np.sin(off_axis) * perp
    # Virtual frame: z = axis, y (down) = the real image's down across the axis, x = y cross z.
    y = _unit(-up - axis * (-up @ axis))
    x = np.cross(y, axis)
    base = np.stack([x, y, axis], axis=1)  # real_from_virtual before the roll
    c, s = np.cos(roll), np.sin(roll)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    r = base @ rz
    radius = int(np.ceil(px_per_rad * (off_axis + np.radians(25.0))))
    size = 2 * radius
    lens = Equidistant(px_per_rad, px_per_rad, radius - 0.5, radius - 0.5)
    cam = Camera(f"{real.name}_fe", lens, size, size, real.rotation_world_from_cam @ r, real.position_world)
    return VirtualFisheye(cam, r, float(off_axis), float(roll), float(px_per_rad))


# --------------------------------------------------------------------------------------------
# Scoring


def score_frame(rays_ref: np.ndarray, conf_ref: np.ndarray, detections, others: dict | None = None) -> dict:
    """One frame: rays_ref (33, 3) and conf_ref (33,) the reference in the virtual camera's
    frame; detections: the stage's FrameDetections. Returns found, errors (torso lengths of the
    reference-visible limb keypoints), swapped (bool or None: no confident pairs); and the same
    errors and swaps against each of ``others`` (name -> (rays, conf)) under "by" (the torso
    length and the detection scored are the main reference's)."""
    out = _score_one(rays_ref, conf_ref, detections, None)
    out["by"] = {}
    for name, (rays_o, conf_o) in (others or {}).items():
        o = _score_one(rays_o, conf_o, detections, out)
        out["by"][name] = {"errors": o["errors"], "swapped": o["swapped"]}
    return out


def _score_one(rays_ref: np.ndarray, conf_ref: np.ndarray, detections, main: dict | None) -> dict:
    if main is None:
        torso = float(_angle(_unit(rays_ref[SHOULDERS].mean(0)), _unit(rays_ref[HIPS].mean(0))))
        hip_ref = _unit(rays_ref[HIPS].mean(0))
    else:
        torso = main["torso"]
    out = {"found": False, "errors": np.zeros(0), "swapped": None, "torso": torso, "index": None}
    if main is not None:
        if main["index"] is None:
            return out
        return _score_detection(rays_ref, conf_ref, detections, main["index"], torso, out)
    if detections.count == 0:
        return out
    hips = _unit(detections.rays_cam[:, HIPS].mean(axis=1))
    dist = _angle(hips, hip_ref[None]) / torso
    dist = np.where(np.isfinite(dist), dist, np.inf)
    i = int(np.argmin(dist))
    if not dist[i] <= 0.5:
        return out
    return _score_detection(rays_ref, conf_ref, detections, i, torso, out)


def _score_detection(rays_ref, conf_ref, detections, i, torso, out) -> dict:
    out["index"] = i
    rays, conf = detections.rays_cam[i], detections.confidence[i]
    seen = LIMBS[conf_ref[LIMBS] >= 0.5]
    err = _angle(rays[seen], rays_ref[seen]) / torso
    out["found"] = True
    out["errors"] = np.where(np.isfinite(err), err, np.inf)
    l, r = PAIRS[:, 0], PAIRS[:, 1]
    confident = (conf[l] >= 0.5) & (conf[r] >= 0.5) & (conf_ref[l] >= 0.5) & (conf_ref[r] >= 0.5)
    if confident.sum() >= 2:
        l, r = l[confident], r[confident]
        straight = _angle(rays[l], rays_ref[l]) + _angle(rays[r], rays_ref[r])
        crossed = _angle(rays[l], rays_ref[r]) + _angle(rays[r], rays_ref[l])
        swapped_pairs = crossed < straight - 0.1 * torso
        out["swapped"] = bool(swapped_pairs.sum() * 2 > swapped_pairs.size)
    return out


# --------------------------------------------------------------------------------------------
# Runs

#: Stage settings compared (PoseSettings overrides). "before": the stage as it was before issue
#: 19 (views follow the body axis wherever it points, no re-check, merge by confidence, no
#: left/right check).
MODES: dict[str, dict] = {
    "before": dict(max_body_roll=np.pi, recheck_roll=None, merge_prefers_upright=False, left_right_check=False),
    "aligned+checks": dict(max_body_roll=np.pi),
    "upright": dict(max_body_roll=0.0),
    "bounded15": dict(max_body_roll=np.radians(15.0)),
    "bounded30": dict(max_body_roll=np.radians(30.0)),
    "bounded60": dict(max_body_roll=np.radians(60.0)),
    "upright-no-lr": dict(max_body_roll=0.0, left_right_check=False),
    "default": dict(),
    "memory24": dict(left_right_memory=24.0),
    "memory120": dict(left_right_memory=120.0),
    "upright-memory120": dict(max_body_roll=0.0, left_right_memory=120.0),
    "feet": dict(left_right_feet=True),
    "memory120-feet": dict(left_right_memory=120.0, left_right_feet=True),
    # As `ergopose pose` runs the stage with the default (full) model at the recording's 60 fps
    # (ergopose.commands.pose.stage_settings): doubted sides lowered to the card's keypoint gate.
    "memory120-lowered": dict(left_right_memory=120.0, uncertain_confidence=0.3),
    # The same at the simulator's 12 fps (2 s = 24 frames), for --sim.
    "memory24-lowered": dict(left_right_memory=24.0, uncertain_confidence=0.3),
    # With a second, upright view for every view turned more than 10 degrees (left_right_upright_check):
    # `ergopose pose` since 2026-11-28 (at 60 and at 12 fps), and the stage as assess runs it.
    "memory120-upright-check-lowered": dict(
        left_right_memory=120.0, left_right_upright_check=np.radians(10.0), uncertain_confidence=0.3
    ),
    "memory24-upright-check-lowered": dict(
        left_right_memory=24.0, left_right_upright_check=np.radians(10.0), uncertain_confidence=0.3
    ),
    "upright-check": dict(left_right_upright_check=np.radians(10.0)),
}


def _settings(mode: str):

    return PoseSettings(**MODES[mode])


#: OpenPose BODY_25B's first 17 keypoints are in COCO order (nose, eyes, ears, shoulders, elbows,
#: wrists, hips, knees, ankles); these are the ones scored.
_OPENPOSE_TO_BLAZEPOSE = {
    5: "left_shoulder",
    6: "right_shoulder",
    7: "left_elbow",
    8: "right_elbow",
    9: "left_wrist",
    10: "right_wrist",
    11: "left_hip",
    12: "right_hip",
    13: "left_knee",
    14: "right_knee",
    15: "left_ankle",
    16: "right_ankle",
}

#: The references: BlazePose on the pinhole frames with crops turned to the body axis
#: (MediaPipe's way; also decides who is counted and found), the same with upright crops, and
#: the recording's own OpenPose keypoints (another network: its joints sit a little elsewhere,
#: but it has no crop and no orientation of ours).
REFERENCES = ("aligned", "upright", "openpose")


def openpose_reference(root: Path, number: int, frames: int, camera: Camera) -> dict:
    rays = np.full((frames, NUM_JOINTS, 3), np.nan)
    conf = np.zeros((frames, NUM_JOINTS))
    for f in range(frames):
        path = root / "pose-associated" / f"cam{number:02d}_json" / f"cam{number:02d}.{f:04d}.json"
        people = json.loads(path.read_text())["people"] if path.exists() else []
        if not people or "pose_keypoints_2d" not in people[0]:
            continue
        k = np.array(people[0]["pose_keypoints_2d"], dtype=np.float64).reshape(-1, 3)
        for i, name in _OPENPOSE_TO_BLAZEPOSE.items():
            j = JOINT_INDEX[name]
            if k[i, 2] > 0:
                rays[f, j] = camera.lens.unproject(k[i, :2])
                # OpenPose's scores run lower than BlazePose's visibilities: >= 0.3 (Pose2Sim's
                # own triangulation threshold) counts as seen.
                conf[f, j] = 1.0 if k[i, 2] >= 0.3 else 0.0
    return {"rays": rays, "conf": conf}


def reference_for_camera(root: Path, number: int, frames: int, model_dir=None) -> dict:

    cv2.setNumThreads(1)
    det = BlazePoseDetector(model_dir=model_dir, num_threads=1)
    lm = BlazePoseLandmarker(model_dir=model_dir, num_threads=1)
    real = load_cameras(root)[number - 1]
    images = read_frames(root, number, frames)
    out = {}
    for name, upright in (("aligned", None), ("upright", real)):
        rays = np.full((len(images), NUM_JOINTS, 3), np.nan)
        conf = np.zeros((len(images), NUM_JOINTS))
        for f, image in enumerate(images):
            ref = reference_pose(image, det, lm, upright)
            if ref is not None:
                rays[f] = real.lens.unproject(ref[0])
                conf[f] = ref[1]
        out[name] = {"rays": rays, "conf": conf}
    out["openpose"] = openpose_reference(root, number, len(images), real)
    return out


def run_config(args) -> list[dict]:
    """All modes on one virtual camera (frames rendered once, every mode's stage fed in turn)."""
    root, number, frames, off_axis_deg, roll_deg, px_per_rad, modes, ref, model_dir = args

    real = load_cameras(root)[number - 1]
    refs, ref = ref, ref["aligned"]
    cv2.setNumThreads(1)
    ok = np.isfinite(ref["rays"][:, HIPS]).all(axis=(1, 2)) & (ref["conf"][:, HIPS] >= 0.5).all(axis=1)
    hip = _unit(np.nanmedian(_unit(ref["rays"][ok][:, HIPS].mean(axis=1)), axis=0))
    vf = virtual_fisheye(real, hip, np.radians(off_axis_deg), np.radians(roll_deg), px_per_rad)
    view_map = build_map(vf.camera.lens, (vf.camera.width, vf.camera.height), real.lens, vf.rotation_real_from_virtual)
    det = BlazePoseDetector(model_dir=model_dir, num_threads=1)
    lm = BlazePoseLandmarker(model_dir=model_dir, num_threads=1)
    stages = {m: FisheyePoseEstimator(vf.camera, 0, lm, det, _settings(m)) for m in modes}
    rays_ref_v = ref["rays"] @ vf.rotation_real_from_virtual  # real -> virtual frame
    others = {k: (refs[k]["rays"] @ vf.rotation_real_from_virtual, refs[k]["conf"]) for k in REFERENCES}
    scores: dict[str, list[dict]] = {m: [] for m in modes}
    seconds = {m: 0.0 for m in modes}
    for f, image in enumerate(read_frames(root, number, frames)):
        fisheye = view_map.apply(image)
        for m in modes:
            t0 = time.perf_counter()
            found = stages[m].process(fisheye, f)
            seconds[m] += time.perf_counter() - t0
            if ok[f]:
                scores[m].append(
                    score_frame(rays_ref_v[f], ref["conf"][f], found, {k: (r[f], c[f]) for k, (r, c) in others.items()})
                )
    rows = []
    for m in modes:
        s = scores[m]
        errors = np.concatenate([x["errors"] for x in s]) if s else np.zeros(0)
        judged = [x["swapped"] for x in s if x["found"] and x["swapped"] is not None]
        by = {}
        for k in REFERENCES:
            e = np.concatenate([x["by"][k]["errors"] for x in s]) if s else np.zeros(0)
            j = [x["by"][k]["swapped"] for x in s if x["found"] and x["by"][k]["swapped"] is not None]
            by[k] = {
                "median": float(np.median(e)) if e.size else float("nan"),
                "p90": float(np.percentile(e, 90)) if e.size else float("nan"),
                "swapped": int(sum(j)),
                "judged": len(j),
            }
        rows.append(
            {
                "by": by,
                **{
                    "camera": real.name,
                    "off_axis_deg": off_axis_deg,
                    "roll_deg": roll_deg,
                    "px_per_rad": px_per_rad,
                    "mode": m,
                    "counted": len(s),
                    "found": int(sum(x["found"] for x in s)),
                    "median": float(np.median(errors)) if errors.size else float("nan"),
                    "p90": float(np.percentile(errors, 90)) if errors.size else float("nan"),
                    "keypoints": int(errors.size),
                    "swapped": int(sum(judged)),
                    "judged": len(judged),
                    "seconds": seconds[m],
                },
            }
        )
    return rows


def simulated_camera(args) -> list[dict]:
    """The same scores on one camera of a simulated session against its ground truth: every
    worker whose four torso joints the camera sees (visible, or behind the worker's own body)
    is counted; the reference rays are the true joints, seen where visibility is 0."""
    session_dir, camera_index, stop, modes = args

    cv2.setNumThreads(1)
    session = load_session(session_dir)
    if session.ground_truth_dir is None:
        raise InputError("not a simulated session: no ground_truth/ folder", path=session_dir)
    gt = load_ground_truth(session.ground_truth_dir)
    cam = session.cameras[camera_index]
    det = BlazePoseDetector(num_threads=1)
    lm = BlazePoseLandmarker(num_threads=1)
    stages = {m: FisheyePoseEstimator(cam.camera, camera_index, lm, det, _settings(m)) for m in modes}
    scores: dict[str, list[dict]] = {m: [] for m in modes}
    for index, frame in read_video(cam.video_path, 0, stop if stop is not None else gt.n_frames):
        found = {m: stages[m].process(frame, index) for m in modes}
        for w in range(len(gt.worker_ids)):
            vis = gt.visibility[index, camera_index, w]
            if not np.all(np.isin(vis[np.r_[SHOULDERS, HIPS]], (0, 1))):
                continue
            rays = _unit(cam.camera.points_world_to_cam(gt.joints_world[index, w]))
            conf = (vis == 0).astype(np.float64)
            for m in modes:
                scores[m].append(score_frame(rays, conf, found[m]))
    rows = []
    for m in modes:
        sc = scores[m]
        errors = np.concatenate([x["errors"] for x in sc]) if sc else np.zeros(0)
        judged = [x["swapped"] for x in sc if x["found"] and x["swapped"] is not None]
        rows.append(
            {
                "camera": cam.camera.name,
                "mode": m,
                "counted": len(sc),
                "found": int(sum(x["found"] for x in sc)),
                "median": float(np.median(errors)) if errors.size else float("nan"),
                "p90": float(np.percentile(errors, 90)) if errors.size else float("nan"),
                "swapped": int(sum(judged)),
                "judged": len(judged),
            }
        )
    return rows


def summarise(rows: list[dict], group: Sequence[str]) -> list[dict]:
    """Pool rows by the given keys: found rate, median of the per-run medians, worst p90, swaps."""
    out: dict[tuple, dict] = {}
    for r in rows:
        key = tuple(r[g] for g in group)
        o = out.setdefault(
            key,
            {
                **{g: r[g] for g in group},
                "counted": 0,
                "found": 0,
                "swapped": 0,
                "judged": 0,
                "medians": [],
                "p90s": [],
                "runs": 0,
                "worst_found": 1.0,
            },
        )
        o["counted"] += r["counted"]
        o["found"] += r["found"]
        o["swapped"] += r["swapped"]
        o["judged"] += r["judged"]
        o["medians"].append(r["median"])
        o["p90s"].append(r["p90"])
        o["runs"] += 1
        o["worst_found"] = min(o["worst_found"], r["found"] / max(r["counted"], 1))
    return list(out.values())


def render(rows: list[dict], modes: Sequence[str]) -> str:
    lines = [
        "| mode | found | worst run found | median of run medians (torso) | median p90 | worst p90 | "
        "L/R swapped (confident frames) |",
        "|---|---|---|---|---|---|---|",
    ]
    for o in summarise(rows, ["mode"]):
        p90 = np.array(o["p90s"], dtype=float)
        lines.append(
            f"| {o['mode']} | {100 * o['found'] / max(o['counted'], 1):.1f} % ({o['found']}/{o['counted']}) | "
            f"{100 * o['worst_found']:.0f} % | {np.nanmedian(o['medians']):.3f} | {np.nanmedian(p90):.3f} | "
            f"{np.nanmax(p90) if np.isfinite(p90).any() else float('nan'):.2f} | "
            f"{100 * o['swapped'] / max(o['judged'], 1):.1f} % ({o['swapped']}/{o['judged']}) |"
        )
    lines += [
        "",
        "Keypoint error and left/right swaps against each reference (median of the runs' medians, "
        "median and worst of their p90, in torso lengths; swapped frames of the confident ones):",
        "",
        "| mode | " + " | ".join(f"{k}: median / p90 / worst p90 / swapped" for k in REFERENCES) + " |",
        "|---|" + "---|" * len(REFERENCES),
    ]
    for m in modes:
        cells = []
        for k in REFERENCES:
            rs = [r["by"][k] for r in rows if r["mode"] == m]
            med = np.array([r["median"] for r in rs], dtype=float)
            p90 = np.array([r["p90"] for r in rs], dtype=float)
            sw, jd = sum(r["swapped"] for r in rs), sum(r["judged"] for r in rs)
            cells.append(
                f"{np.nanmedian(med):.3f} / {np.nanmedian(p90):.3f} / {np.nanmax(p90):.2f} / "
                f"{100 * sw / max(jd, 1):.1f} % ({sw}/{jd})"
            )
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "Per camera, angle off the lens axis and density (found / worst p90 torso / swapped, "
        "against the aligned reference):",
        "",
    ]
    keys = ["camera", "off_axis_deg", "px_per_rad"]
    head = "| camera | off axis | px/rad | " + " | ".join(modes) + " |"
    lines += [head, "|" + "---|" * (3 + len(modes))]
    groups = summarise(rows, keys + ["mode"])
    for key in sorted({tuple(g[k] for k in keys) for g in groups}):
        cells = []
        for m in modes:
            g = next(x for x in groups if tuple(x[k] for k in keys) == key and x["mode"] == m)
            cells.append(
                f"{100 * g['found'] / max(g['counted'], 1):.0f} % / {np.nanmax(g['p90s']):.2f} / "
                f"{100 * g['swapped'] / max(g['judged'], 1):.0f} %"
            )
        lines.append(f"| {key[0]} | {key[1]:g} deg | {key[2]:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m ergopose.evaluation.refisheye", description=__doc__.split("\n")[0])
    p.add_argument("--root", type=Path, default=DEFAULT_ROOT)
    p.add_argument("--cameras", default="1,2", help="real camera numbers, e.g. 1,2")
    p.add_argument("--frames", type=int, default=100)
    p.add_argument("--angles", default="15,45,75", help="degrees off the lens axis")
    p.add_argument("--rolls", default="0,90,180,270", help="degrees the virtual camera turns about its axis")
    p.add_argument("--densities", default="620,250", help="pixels per radian")
    p.add_argument("--modes", default="before,upright,bounded30,aligned+checks")
    p.add_argument("--processes", type=int, default=2)
    p.add_argument("--out", type=Path, required=True, help="markdown table; the rows go to OUT.json")
    p.add_argument(
        "--sim",
        type=Path,
        default=None,
        help="instead: a simulated session (ergopose simulate), every camera, scored against its truth",
    )
    p.add_argument("--sim-stop", type=int, default=None, help="with --sim: frames from 0 to this")
    a = p.parse_args(argv)
    cams = [int(x) for x in a.cameras.split(",")]
    modes = a.modes.split(",")
    unknown = [m for m in modes if m not in MODES]
    if unknown:
        print(f"unknown mode(s) {', '.join(unknown)}; known: {', '.join(MODES)}", file=sys.stderr)
        return 2
    ctx = multiprocessing.get_context("spawn")
    t0 = time.time()
    if a.sim is not None:
        n = len(load_session(a.sim).cameras)
        with ProcessPoolExecutor(a.processes, mp_context=ctx) as pool:
            rows = [
                r
                for part in pool.map(simulated_camera, [(a.sim, c, a.sim_stop, modes) for c in range(n)])
                for r in part
            ]
        lines = [
            f"Simulated session {a.sim.name}, frames 0..{a.sim_stop}, {n} cameras, {time.time() - t0:.0f} s.",
            "",
            "| mode | camera | found | median torso | p90 torso | L/R swapped (confident frames) |",
            "|---|---|---|---|---|---|",
        ]
        for r in rows:
            lines.append(
                f"| {r['mode']} | {r['camera']} | {100 * r['found'] / max(r['counted'], 1):.1f} % "
                f"({r['found']}/{r['counted']}) | {r['median']:.3f} | {r['p90']:.3f} | "
                f"{100 * r['swapped'] / max(r['judged'], 1):.1f} % ({r['swapped']}/{r['judged']}) |"
            )
        text = "\n".join(lines) + "\n"
        tmp = a.out.with_name(a.out.name + ".tmp")
        tmp.write_text(text)
        os.replace(tmp, a.out)
        print(text)
        return 0
    with ProcessPoolExecutor(a.processes, mp_context=ctx) as pool:
        refs = dict(zip(cams, pool.map(reference_for_camera, [a.root] * len(cams), cams, [a.frames] * len(cams))))
        jobs = [
            (a.root, c, a.frames, float(ang), float(roll), float(d), modes, refs[c], None)
            for c in cams
            for ang in a.angles.split(",")
            for d in a.densities.split(",")
            for roll in a.rolls.split(",")
        ]
        rows = []
        for i, batch in enumerate(pool.map(run_config, jobs)):
            rows += batch
            print(
                f"[{time.time() - t0:.0f} s] {i + 1}/{len(jobs)} {batch[0]['camera']} "
                f"{batch[0]['off_axis_deg']:g} deg roll {batch[0]['roll_deg']:g} {batch[0]['px_per_rad']:g} px/rad: "
                + ", ".join(
                    f"{x['mode']} {x['found']}/{x['counted']} p90 {x['p90']:.2f} swap {x['swapped']}/{x['judged']}"
                    for x in batch
                ),
                file=sys.stderr,
                flush=True,
            )
    refs_found = {c: int(np.isfinite(refs[c]["aligned"]["rays"][:, HIPS]).all(axis=(1, 2)).sum()) for c in cams}
    base = [
        "",
        "The references against each other on the pinhole frames (torso lengths of the aligned "
        "reference; median / p90 over the limb keypoints both give; frames with left and right crossed):",
        "",
    ]
    for c in cams:
        for a_name, b_name in (("aligned", "upright"), ("aligned", "openpose"), ("upright", "openpose")):
            a_ref, b_ref = refs[c][a_name], refs[c][b_name]
            errs, swaps, judged = [], 0, 0
            for f in range(a_ref["rays"].shape[0]):
                if not np.isfinite(a_ref["rays"][f][HIPS]).all():
                    continue
                torso = float(_angle(_unit(a_ref["rays"][f][SHOULDERS].mean(0)), _unit(a_ref["rays"][f][HIPS].mean(0))))
                both = LIMBS[(a_ref["conf"][f][LIMBS] >= 0.5) & (b_ref["conf"][f][LIMBS] >= 0.5)]
                errs.append(_angle(a_ref["rays"][f][both], b_ref["rays"][f][both]) / torso)
                lj, rj = PAIRS[:, 0], PAIRS[:, 1]
                okp = (
                    (a_ref["conf"][f][lj] >= 0.5)
                    & (a_ref["conf"][f][rj] >= 0.5)
                    & (b_ref["conf"][f][lj] >= 0.5)
                    & (b_ref["conf"][f][rj] >= 0.5)
                )
                if okp.sum() >= 2:
                    ra, rb = a_ref["rays"][f], b_ref["rays"][f]
                    st = _angle(ra[lj[okp]], rb[lj[okp]]) + _angle(ra[rj[okp]], rb[rj[okp]])
                    cr = _angle(ra[lj[okp]], rb[rj[okp]]) + _angle(ra[rj[okp]], rb[lj[okp]])
                    judged += 1
                    swaps += int((cr < st - 0.1 * torso).sum() * 2 > okp.sum())
            e = np.concatenate(errs) if errs else np.zeros(0)
            base.append(
                f"- cam_{c:02d}, {a_name} vs {b_name}: {np.median(e):.3f} / {np.percentile(e, 90):.3f}; "
                f"crossed {swaps}/{judged}"
            )
    text = (
        f"Pose2Sim recording re-rendered: cameras {a.cameras}, {a.frames} frames, angles {a.angles} deg, "
        f"rolls {a.rolls} deg, {a.densities} px/rad; reference found in "
        + ", ".join(f"cam_{c:02d} {n}/{a.frames}" for c, n in refs_found.items())
        + f" frames; {time.time() - t0:.0f} s, {a.processes} processes.\n\n"
        + render(rows, modes)
        + "\n".join(base)
        + "\n"
    )
    atomic.write_text(a.out, text)
    atomic.write_text(a.out.with_suffix(".json"), json.dumps(rows, indent=1))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
