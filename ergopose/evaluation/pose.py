"""How well one pretrained 2D network finds people in ceiling fisheye video, measured on a
simulated session against its exact ground truth (docs/pose-in-fisheye.md has the tables).

The paper's central claim: a 2D network trained on ordinary upright photographs, applied to
upright virtual pinhole views instead of the raw fisheye image, finds people anywhere under a
ceiling fisheye without retraining. This module measures that claim with the SAME network
(the BlazePose landmark model) on the SAME people, changing only what the network is shown.

Conditions (``CONDITIONS``), each per ground-truth person whose torso the camera sees (below):

``view``
    An upright virtual pinhole view (the network's input size, 256 x 256) aimed at the true
    hip centre, its field of view fitted to the true body as the 2D stage fits it to detected
    body keypoints (when the network gives no alignment points): half field of view = the
    largest angle between the hip-centre ray and the rays of the body keypoints, times
    ``PoseSettings.body_margin``, clipped to the stage's limits. Keypoints go back to fisheye
    pixels through the view.
``crop``
    The raw fisheye image, cut as an axis-aligned square around the bounding box of the true
    body keypoints in fisheye pixels (side = margin x the box's longer side, centred on the
    box) and resized to 256 x 256: what a person detector's box on the raw image would give.
    Keypoints go back with the crop's affine map.
``rotated_crop``
    The raw fisheye image, cut as a square centred on the true hip centre and rotated so the
    image of the hip-to-shoulder direction points up (side = 2 x margin x the largest distance
    from the hip centre to a body keypoint in fisheye pixels): the region MediaPipe's own
    pipeline would hand its landmark model (its detector aligns the crop with the body axis).
``aligned_view``
    The ``view`` above rolled about its own optical axis so that the image of the true
    hip-to-shoulder direction points straight up: still a pinhole view of the same part of the
    scene, but aligned with the body the way MediaPipe's crops are (a person leaning over a
    table leans in an upright view and stands straight in an aligned one).
``stage``
    The full 2D stage, :class:`ergopose.pose.fisheye.FisheyePoseEstimator`, run end to end on
    every frame (search views with the detector, motion cues, re-focusing on the network's
    alignment points with views upright to the world (turned towards the body axis by at most
    ``PoseSettings.max_body_roll``), left/right kept consistent, coasting, searching where a person was
    lost); nothing from the ground truth is given to it. Its detections are matched one to one to the people.

The four oracle conditions (all but ``stage``) give the network the true
position and size of the person, so they measure only the effect of what the network sees;
``stage`` measures the product.

Found: presence (the network's pose flag) >= ``min_presence`` (for ``stage``: a detection the
stage reported, which follows a person it has found down to ``PoseSettings.min_follow_presence``)
and the predicted hip centre within ``found_within_torso`` torso lengths of the true hip centre.
Distances "in torso lengths" are angles between rays from the camera, divided by the angle the
torso subtends at the person's distance (3D shoulder-centre to hip-centre length / distance of
the hip centre from the camera): the error perpendicular to the line of sight, in units of the
person's own torso. This does not shrink when the torso is foreshortened (a person seen from above).

Keypoint error: for every found person, each of the 12 limb keypoints (shoulders, elbows,
wrists, hips, knees, ankles) that the camera sees (ground-truth visibility 0) gives one error
in fisheye pixels and one in torso lengths; the summaries pool these per region and camera.

Region: the angle of the true hip centre off the camera's lens axis, in ergopose's lens regions
(ergopose.geometry.regions: central < 30 deg, outer 30-60, edge >= 60 by default;
``EvaluationSettings.region_limits_deg``).
Counted persons: the camera sees the torso, i.e. both shoulders and both hips have ground-truth
visibility 0 (visible) or 1 (self-occluded: behind the person's own body, as the far hip and
shoulder of anyone seen from the side are), and none is hidden by furniture or another worker or
outside the image. ``EvaluationSettings.torso_codes = (0,)`` counts only people whose four
torso joints are all directly visible (people facing the camera or seen from above); that
drops almost everyone seen from the side, the view the rig's second camera has of a person
under the first.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Sequence

from ergopose.atomic import write_text
from ergopose.cli_progress import ProgressBars
from ergopose.errors import ConfigError, ErgoposeError, InputError
from ergopose.evaluation.pose_camera import camera_worker, evaluate_camera
from ergopose.evaluation.pose_records import CONDITIONS, EvaluationSettings, PersonTrials, PoseEvaluation
from ergopose.evaluation.pose_report import other_camera_summaries, render_markdown, summarise
from ergopose.geometry.regions import REGION_NAMES
from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker
from ergopose.progress import ProgressCallback, report
from ergopose.session import load_session
from ergopose.sim.ground_truth import load_ground_truth


def evaluate_session(
    session_dir: str | os.PathLike,
    *,
    conditions: Sequence[str] = CONDITIONS,
    start: int = 0,
    stop: int | None = None,
    step: int = 1,
    settings: EvaluationSettings | None = None,
    landmarker=None,
    detector=None,
    processes: int = 1,
    num_threads: int = 1,
    model_dir: str | os.PathLike | None = None,
    progress: ProgressCallback | None = None,
) -> PoseEvaluation:
    """Measure the conditions (module docstring) on a simulated session.

    session_dir: a folder written by ``ergopose simulate`` (it must have ground_truth/).
    conditions: any of CONDITIONS. start, stop, step: the frames scored (the stage processes
    every frame from ``start`` to ``stop`` and is scored on the same frames as the others).
    landmarker, detector: networks to use (processes=1 only); default: BlazePose from the model
    cache (``model_dir``) with ``num_threads`` LiteRT threads.
    processes: 1, or 2 to evaluate each camera in its own process with its own networks.
    """
    t0 = time.perf_counter()
    conditions = tuple(conditions)
    unknown = [c for c in conditions if c not in CONDITIONS]
    if unknown or not conditions:
        raise ConfigError(f"unknown condition(s) {unknown}; choose from {', '.join(CONDITIONS)}", field="conditions")
    settings = settings if settings is not None else EvaluationSettings.like_stage()
    session_dir = Path(session_dir)
    session = load_session(session_dir)
    if session.ground_truth_dir is None:
        raise InputError(
            "not a simulated session: no ground_truth/ folder (evaluation needs the truth)", path=session_dir
        )
    gt = load_ground_truth(session.ground_truth_dir)
    n_frames = min(session.frame_count, gt.n_frames)
    stop = n_frames if stop is None else min(int(stop), n_frames)
    if not 0 <= start < stop or step < 1:
        raise ConfigError(f"no frames to score in {start}..{stop} step {step} (session has {n_frames})", field="frames")
    frames = (int(start), int(stop), int(step))
    n_cam = len(session.cameras)
    per_camera = len(range(*frames))
    if processes not in (1, 2):
        raise ConfigError(f"processes must be 1 or 2, got {processes}", field="processes")
    if processes == 2 and n_cam > 1:
        if landmarker is not None or detector is not None:
            raise ConfigError(
                "networks cannot be passed to worker processes; leave landmarker/detector unset", field="processes"
            )
        jobs = [(session_dir, ci, frames, conditions, settings, model_dir, num_threads) for ci in range(n_cam)]
        results = []
        # Spawned workers: forking a process whose LiteRT or OpenCV thread pools are running
        # (a caller that already ran a network) can deadlock the child.
        with ProcessPoolExecutor(max_workers=2, mp_context=multiprocessing.get_context("spawn")) as pool:
            for k, r in enumerate(pool.map(camera_worker, jobs)):
                results.append(r)
                report(progress, "pose evaluation", (k + 1) * per_camera, n_cam * per_camera, unit="frame")
    else:
        if landmarker is None:
            landmarker = BlazePoseLandmarker(model_dir=model_dir, num_threads=num_threads)
        if detector is None and "stage" in conditions:
            detector = BlazePoseDetector(model_dir=model_dir, num_threads=num_threads)
        results = [
            evaluate_camera(
                session_dir,
                ci,
                frames,
                conditions,
                settings,
                landmarker,
                detector,
                progress,
                ci * per_camera,
                n_cam * per_camera,
            )
            for ci in range(n_cam)
        ]
    trials = PersonTrials.concatenate([r[0] for r in results])
    cameras = session.camera_names
    regions = REGION_NAMES
    summaries = summarise(trials, conditions, cameras, regions)
    return PoseEvaluation(
        session=session_dir,
        frames=frames,
        image_size=(session.cameras[0].camera.width, session.cameras[0].camera.height),
        cameras=cameras,
        workers=tuple(gt.worker_ids),
        regions=regions,
        conditions=conditions,
        settings=settings,
        trials=trials,
        summaries=summaries,
        stage_frames=max(r[2] for r in results),
        stage_false_positives=tuple(int(r[1]) for r in results),
        other_camera=other_camera_summaries(trials, conditions, n_cam, regions.index("central")),
        seconds=time.perf_counter() - t0,
    )


# --------------------------------------------------------------------------------------------
# Command line: python -m ergopose.evaluation.pose SESSION [options]


def main(argv: Sequence[str] | None = None) -> int:
    """Evaluate a simulated session and write the markdown tables (stdout or --out, atomically)."""
    parser = argparse.ArgumentParser(
        prog="python -m ergopose.evaluation.pose",
        description="Detection rate and keypoint error of the BlazePose landmark model on upright views, "
        "raw fisheye crops, rotated crops and the full 2D stage, per lens region, "
        "on a session written by 'ergopose simulate' (docs/pose-in-fisheye.md).",
    )
    parser.add_argument("session", type=Path, help="simulated session folder")
    parser.add_argument(
        "--conditions", default=",".join(CONDITIONS), help="comma-separated, from " + ", ".join(CONDITIONS)
    )
    parser.add_argument("--start", type=int, default=0)
    parser.add_argument("--stop", type=int, default=None)
    parser.add_argument("--step", type=int, default=1, help="score every STEP-th frame (the stage sees all)")
    parser.add_argument("--processes", type=int, default=2, choices=(1, 2), help="2: one process per camera (default)")
    parser.add_argument("--threads", type=int, default=1, help="LiteRT threads per process (default 1)")
    parser.add_argument("--model-dir", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=None, help="write the markdown here instead of stdout")
    args = parser.parse_args(argv)

    try:
        result = evaluate_session(
            args.session,
            conditions=[c.strip() for c in args.conditions.split(",") if c.strip()],
            start=args.start,
            stop=args.stop,
            step=args.step,
            processes=args.processes,
            num_threads=args.threads,
            model_dir=args.model_dir,
            progress=ProgressBars(),
        )
    except ErgoposeError as exc:
        print(f"ergopose: error: {exc}", file=sys.stderr)
        return 2
    text = render_markdown(result) + f"\nEvaluated in {result.seconds:.0f} s.\n"
    if args.out is not None:
        write_text(args.out, text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
