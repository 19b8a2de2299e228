"""One camera of the 2D pose measurement (ergopose.evaluation.pose): every scored frame of its
video, every counted person shown to the network under each condition, and the full stage run
on every frame; in the calling process or in a worker process of its own."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import cv2
import numpy as np

from ergopose.errors import InputError
from ergopose.evaluation.pose_geometry import EVAL_JOINTS, PersonGeometry, unit_vectors
from ergopose.sim.visibility import OUTSIDE_IMAGE
from ergopose.evaluation.pose_records import CONDITIONS, EvaluationSettings, PersonTrials
from ergopose.evaluation.pose_scoring import TrialRows, match_stage, score_prediction
from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.progress import ProgressCallback, report
from ergopose.session import load_session
from ergopose.sim.ground_truth import load_ground_truth
from ergopose.video import read_frames


def evaluate_camera(
    session_dir: Path,
    camera_index: int,
    frames: tuple[int, int, int],
    conditions: tuple[str, ...],
    settings: EvaluationSettings,
    landmarker,
    detector,
    progress: ProgressCallback | None,
    done_offset: int,
    total: int,
) -> tuple[PersonTrials, int, int]:
    session = load_session(session_dir)
    if session.ground_truth_dir is None:
        raise InputError(
            "not a simulated session: no ground_truth/ folder (evaluation needs the truth)", path=session_dir
        )
    gt = load_ground_truth(session.ground_truth_dir)
    cam = session.cameras[camera_index]
    camera = cam.camera
    size = (int(landmarker.input_size[0]), int(landmarker.input_size[1]))
    start, stop, step = frames
    want = {c: CONDITIONS.index(c) for c in conditions}
    stage = None
    if "stage" in want:
        stage = FisheyePoseEstimator(camera, camera_index, landmarker, detector, settings.stage_settings())
    # The stage reports a person it follows down to its lower gate (new people need
    # min_presence): what it reports has passed its own gate.
    stage_scoring = dataclasses.replace(
        settings, min_presence=min(settings.min_presence, settings.stage_settings().follow_presence)
    )
    rows = TrialRows(settings.region_limits_deg)
    false_positives = 0
    stage_frames = 0
    n_workers = len(gt.worker_ids)
    for index, frame in read_frames(cam.video_path, start, stop):
        scored = (index - start) % step == 0
        found = None
        if stage is not None:
            found = stage.process(frame, index)
            stage_frames += 1
        if not scored:
            continue
        people: list[tuple[int, PersonGeometry]] = []
        hidden: list[PersonGeometry] = []
        for w in range(n_workers):
            p = PersonGeometry.of(
                camera,
                gt.joints_world[index, w],
                gt.pixels[index, camera_index, w],
                gt.visibility[index, camera_index, w],
            )
            if p.counted(settings):
                people.append((w, p))
            elif np.any(p.visibility != OUTSIDE_IMAGE):
                hidden.append(p)
        for w, p in people:
            for name, make in (("view", p.view), ("aligned_view", p.aligned_view)):
                if name not in want:
                    continue
                view = make(camera, size, settings)
                kp = landmarker(view.build_map().apply(frame))
                rays = view.view_pixels_to_rays_cam(kp.pixels)
                rows.add(
                    want[name],
                    index,
                    camera_index,
                    w,
                    p,
                    kp.presence,
                    score_prediction(p, camera.lens.project(rays), rays, kp.presence, settings),
                )
            for name, make_roi in (("crop", p.crop_roi), ("rotated_crop", p.rotated_roi)):
                if name not in want:
                    continue
                roi = make_roi(settings)
                kp = landmarker(roi.crop(frame, size[0])).transformed(roi.crop_to_image(size[0]))
                rays = unit_vectors(camera.lens.unproject(kp.pixels))
                rows.add(
                    want[name],
                    index,
                    camera_index,
                    w,
                    p,
                    kp.presence,
                    score_prediction(p, kp.pixels, rays, kp.presence, settings),
                )
        if found is not None:
            matches, fp = match_stage(people, hidden, found, settings)
            false_positives += fp
            for pos, (w, p) in enumerate(people):
                j = matches.get(pos)
                if j is None:
                    nan = np.full(EVAL_JOINTS.size, np.nan)
                    rows.add(want["stage"], index, camera_index, w, p, float("nan"), (False, float("nan"), nan, nan))
                else:
                    rows.add(
                        want["stage"],
                        index,
                        camera_index,
                        w,
                        p,
                        float(found.presence[j]),
                        score_prediction(
                            p, found.pixels_fisheye[j], found.rays_cam[j], float(found.presence[j]), stage_scoring
                        ),
                    )
        report(
            progress,
            "pose evaluation",
            done_offset + (index - start) // step + 1,
            total,
            unit="frame",
            message=camera.name,
        )
    return rows.trials(), false_positives, stage_frames


def camera_worker(args) -> tuple[PersonTrials, int, int]:
    """One camera in its own process, with its own networks (num_threads as given)."""
    session_dir, camera_index, frames, conditions, settings, model_dir, num_threads = args

    cv2.setNumThreads(1)
    landmarker = BlazePoseLandmarker(model_dir=model_dir, num_threads=num_threads)
    detector = BlazePoseDetector(model_dir=model_dir, num_threads=num_threads) if "stage" in conditions else None
    return evaluate_camera(session_dir, camera_index, frames, conditions, settings, landmarker, detector, None, 0, 0)
