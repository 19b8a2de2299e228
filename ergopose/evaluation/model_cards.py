"""The landmark model cards (lite, full, heavy) on the same crops (evaluation only).

Two sources of crops:

``real``: every frame of the Pose2Sim recording's four videos (/work/shared/data/pose2sim-demo)
gives one crop of the person, placed as the stage places a view that follows a person: from Pose2Sim's
3D result (``pose-3d`` TRC) projected into the camera, the crop is centred on the hip centre,
its "up" along the hip-to-shoulder direction, its side 2.5 times the largest distance of a
projected joint from the hip centre (the landmark network's 1.25 margin around the body
circle). The same frame also gives crops of the same size beside the person, wholly inside the
image and clear of the body circle: crops that hold nobody.

``rendered``: a short simulated session (``ergopose simulate``: two workers, two ceiling fisheye
cameras); per frame, camera and worker whose torso the camera sees, the upright virtual view
aimed at the true hip centre and fitted to the true body (the ``view`` condition of
:mod:`ergopose.evaluation.pose`). Reference: the true joints projected into the view; only the
joints the camera sees are scored; torso length: the torso's angle at the person's distance
times the view's focal length.

Each model runs on the same crops (one thread). Per model and source:

* time per crop: the network's invoke and decoding (not the crop), median over the crops;
* keypoint error: distance between the model's 12 limb keypoints (shoulders, elbows, wrists,
  hips, knees, ankles) and the projected reference, over the reference torso (shoulder centre
  to hip centre) in pixels; median and p90;
* confidences: the pose flag on person crops and on empty crops, and the limb keypoints'
  visibility split into right keypoints (error below ``RIGHT_TORSO`` torso lengths) and wrong
  ones.

Gates (:func:`gate_table`, both sources pooled): the keypoint gate of a model keeps the same
share of its right keypoints as the ``full`` model keeps of its own with its gate (quantile
matching, :func:`matched_gate`); the pose-flag gate is reported as the share of person crops
that a gate keeps and the largest pose flag of an empty crop (a gate must stay above it).

Run: ``python -m ergopose.evaluation.model_cards [--frames N] [--rendered-seconds S] [--json FILE]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ergopose.evaluation.pose_csv import trc_reference
from ergopose.evaluation.pose_geometry import PersonGeometry
from ergopose.evaluation.pose_records import EvaluationSettings
from ergopose.evaluation.refisheye import DEFAULT_ROOT, LIMBS, read_frames
from ergopose.geometry.calibration_file import camera_for_video, read_pose2sim_calibration
from ergopose.keypoints import JOINT_INDEX
from ergopose.pose.blazepose import BlazePoseLandmarker, Roi
from ergopose.pose.models import LANDMARK_MODELS, landmark_card
from ergopose.session import load_session
from ergopose.sim.ground_truth import load_ground_truth
from ergopose.sim.writer import SimulationConfig, simulate_session
from ergopose.video import read_frames as read_video

RIGHT_TORSO = 0.2
HIPS = [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]
SHOULDERS = [JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]]


def crops_of_recording(root: Path = DEFAULT_ROOT, frames: int = 100, step: int = 1) -> dict:
    """Person crops, their reference pixels and torso lengths, and empty crops (see the module text)."""
    cameras = read_pose2sim_calibration(root / "Calib_qualisys.toml")
    person, reference, torso, empty = [], [], [], []
    for number, camera in enumerate(cameras, start=1):
        images = read_frames(root, number, frames)
        h, w = images[0].shape[:2]
        camera = camera_for_video(camera, w, h) or camera
        ref = trc_reference(root, frames, camera)
        for f in range(0, len(images), step):
            conf = ref["conf"][f]
            if not (conf[HIPS + SHOULDERS] > 0).all():
                continue
            px = camera.lens.project(ref["rays"][f])
            hip, shoulder = px[HIPS].mean(axis=0), px[SHOULDERS].mean(axis=0)
            v = shoulder - hip
            radius = float(np.nanmax(np.linalg.norm(px[conf > 0] - hip, axis=1)))
            side = 2.5 * radius
            roi = Roi(hip, side, float(np.arctan2(v[0], -v[1])))
            person.append(roi.crop(images[f], 256))
            reference.append(px @ roi.image_to_crop(256)[:, :2].T + roi.image_to_crop(256)[:, 2])
            torso.append(float(np.linalg.norm(v)) * 256.0 / side)
            for dx, dy in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                centre = hip + np.array([dx, dy]) * (radius + side / 2 + 1)
                if side / 2 <= centre[0] <= w - side / 2 and side / 2 <= centre[1] <= h - side / 2:
                    empty.append(Roi(centre, side, 0.0).crop(images[f], 256))
    return {
        "person": np.stack(person),
        "reference": np.stack(reference),
        "torso": np.array(torso),
        "empty": np.stack(empty) if empty else np.zeros((0, 256, 256, 3), np.uint8),
    }


def crops_of_simulation(folder: Path, seconds: float = 3.0, seed: int = 4, step: int = 1) -> dict:
    """Views of the workers of a simulated session (made in ``folder`` unless it is there)."""

    if not (folder / "settings.toml").is_file():
        simulate_session(folder, SimulationConfig(workers=2, minutes=seconds / 60.0, seed=seed))
    session = load_session(folder)
    if session.ground_truth_dir is None:
        raise ValueError(f"{folder} is not a simulated session (no ground truth)")
    gt = load_ground_truth(session.ground_truth_dir)
    settings = EvaluationSettings()
    person, reference, torso = [], [], []
    for c, cam in enumerate(session.cameras):
        camera = cam.camera
        for index, frame in read_video(cam.video_path, 0, session.frame_count):
            if index % step:
                continue
            for w in range(len(gt.worker_ids)):
                p = PersonGeometry.of(
                    camera, gt.joints_world[index, w], gt.pixels[index, c, w], gt.visibility[index, c, w]
                )
                if not p.counted(settings):
                    continue
                view = p.view(camera, (256, 256), settings)
                px = view.lens.project(p.rays_cam @ view.rotation_cam_from_view)
                px[p.visibility != 0] = np.nan  # only what the camera sees is scored
                person.append(view.build_map().apply(frame))
                reference.append(px)
                torso.append(p.torso_angle * float(view.lens.fx))
    return {
        "person": np.stack(person),
        "reference": np.stack(reference),
        "torso": np.array(torso),
        "empty": np.zeros((0, 256, 256, 3), np.uint8),
    }


def run_model(model: str, crops: dict, model_dir=None) -> dict:
    """One model on every crop: times, errors, pose flags and limb visibilities."""
    landmarker = BlazePoseLandmarker(model=model, model_dir=model_dir, num_threads=1)
    landmarker(crops["person"][0])  # warm-up
    times, errors, visibility, flags = [], [], [], []
    for image, ref, torso in zip(crops["person"], crops["reference"], crops["torso"]):
        t0 = time.perf_counter()
        kp = landmarker(image)
        times.append(time.perf_counter() - t0)
        errors.append(np.linalg.norm(kp.pixels[LIMBS] - ref[LIMBS], axis=1) / torso)  # NaN: not scored
        visibility.append(kp.confidence[LIMBS])
        flags.append(kp.presence)
    empty_flags = [landmarker(image).presence for image in crops["empty"]]
    return {
        "model": model,
        "time_s": np.array(times),
        "errors": np.array(errors),
        "visibility": np.array(visibility),
        "presence": np.array(flags),
        "empty_presence": np.array(empty_flags),
    }


def matched_gate(values: np.ndarray, reference_values: np.ndarray, reference_gate: float) -> float:
    """The gate on ``values`` that keeps the share of them that ``reference_gate`` keeps of
    ``reference_values`` (quantile matching: the smallest value kept, so that the share below
    it is the reference's)."""
    share_below = float(np.mean(np.asarray(reference_values) < reference_gate))
    values = np.sort(np.asarray(values, dtype=np.float64))
    k = min(int(np.ceil(share_below * values.size)), values.size - 1)
    return float(values[k])


def gate_table(results_by_source: dict[str, dict[str, dict]], base: str = "full") -> list[dict]:
    """Per model, over all sources pooled: the matched keypoint gate, and for presence gates of
    0.5 and the card's own: the share of person crops kept and the largest empty-crop flag."""
    models = list(next(iter(results_by_source.values())))

    def pooled(model: str, key: str) -> np.ndarray:
        return np.concatenate([np.ravel(r[model][key]) for r in results_by_source.values()])

    def right_visibility(model: str) -> np.ndarray:
        return np.concatenate(
            [r[model]["visibility"][r[model]["errors"] < RIGHT_TORSO] for r in results_by_source.values()]
        )

    base_gates = landmark_card(base).gates
    assert base_gates is not None
    ref_right = right_visibility(base)
    rows = []
    for model in models:
        gates = landmark_card(model).gates
        assert gates is not None
        right = right_visibility(model)
        presence, empty = pooled(model, "presence"), pooled(model, "empty_presence")
        rows.append(
            {
                "model": model,
                "right_keypoints": int(right.size),
                "right_below_0.3": float(np.mean(right < 0.3)),
                "matched_min_keypoint_confidence": matched_gate(right, ref_right, base_gates.min_keypoint_confidence),
                "card_min_keypoint_confidence": gates.min_keypoint_confidence,
                "right_kept_by_card_gate": float(np.mean(right >= gates.min_keypoint_confidence)),
                "persons_kept_at_0.5": float(np.mean(presence >= 0.5)),
                "card_min_presence": gates.min_presence,
                "persons_kept_by_card_gate": float(np.mean(presence >= gates.min_presence)),
                "empty_presence_max": float(empty.max()) if empty.size else float("nan"),
                "empty_kept_by_card_gate": int(np.sum(empty >= gates.min_presence)),
            }
        )
    return rows


def _markdown(rows: list[dict]) -> str:
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for row in rows:
        lines.append("| " + " | ".join(f"{v:.3f}" if isinstance(v, float) else str(v) for v in row.values()) + " |")
    return "\n".join(lines)


def summarise(results: dict[str, dict], base: str = "full", source: str = "") -> list[dict]:
    """One row per model: timing, errors, confidences and the matched gates."""
    ref = results[base]
    gates = landmark_card(base).gates
    assert gates is not None
    ref_right = ref["errors"] < RIGHT_TORSO
    rows = []
    for model, r in results.items():
        scored = np.isfinite(r["errors"])
        right = r["errors"] < RIGHT_TORSO
        wrong = scored & ~right
        errors = r["errors"][scored]
        rows.append(
            {
                "source": source,
                "model": model,
                "crops": int(r["errors"].shape[0]),
                "keypoints": int(errors.size),
                "time_ms_median": 1e3 * float(np.median(r["time_s"])),
                "time_ms_p90": 1e3 * float(np.percentile(r["time_s"], 90)),
                "error_median": float(np.median(errors)),
                "error_p90": float(np.percentile(errors, 90)),
                "right_share": float(right.sum() / scored.sum()),
                "presence_median": float(np.median(r["presence"])),
                "presence_p05": float(np.percentile(r["presence"], 5)),
                "empty_presence_max": float(r["empty_presence"].max()) if r["empty_presence"].size else float("nan"),
                "empty_crops": int(r["empty_presence"].size),
                "visibility_right_median": float(np.median(r["visibility"][right])),
                "visibility_right_p10": float(np.percentile(r["visibility"][right], 10)),
                "visibility_wrong_median": float(np.median(r["visibility"][wrong])) if wrong.any() else float("nan"),
                "matched_min_presence": matched_gate(r["presence"], ref["presence"], gates.min_presence),
                "matched_min_keypoint_confidence": matched_gate(
                    r["visibility"][right], ref["visibility"][ref_right], gates.min_keypoint_confidence
                ),
            }
        )
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", type=Path, default=DEFAULT_ROOT)
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--step", type=int, default=1, help="use every STEP-th frame")
    parser.add_argument(
        "--rendered-seconds", type=float, default=3.0, help="length of the simulated session (0: no rendered crops)"
    )
    parser.add_argument(
        "--rendered-dir",
        type=Path,
        default=None,
        help="the simulated session's folder (made there when missing; default: a temporary folder)",
    )
    parser.add_argument("--models", nargs="*", default=list(LANDMARK_MODELS))
    parser.add_argument("--model-dir", default=None)
    parser.add_argument("--json", type=Path, default=None, help="write the rows here too")
    parser.add_argument("--raw", type=Path, default=None, help="write every measured value here (.npz)")
    args = parser.parse_args(argv)
    sources = {"real": crops_of_recording(args.root, args.frames, args.step)}
    if args.rendered_seconds > 0:
        with tempfile.TemporaryDirectory(prefix="ergopose-cards-") as tmp:
            folder = args.rendered_dir or Path(tmp) / "session"
            sources["rendered"] = crops_of_simulation(folder, args.rendered_seconds, step=args.step)
    rows = []
    results_by_source = {}
    for name, crops in sources.items():
        results = {m: run_model(m, crops, args.model_dir) for m in args.models}
        results_by_source[name] = results
        rows += summarise(results, source=name)
    gates = gate_table(results_by_source)
    print(_markdown(rows))
    print()
    print(_markdown(gates))
    if args.json is not None:
        args.json.write_text(json.dumps({"rows": rows, "gates": gates}, indent=1))
    if args.raw is not None:
        arrays: dict[str, Any] = {
            f"{source}.{model}.{key}": value
            for source, results in results_by_source.items()
            for model, r in results.items()
            for key, value in r.items()
            if isinstance(value, np.ndarray)
        }
        np.savez_compressed(args.raw, **arrays)
    return 0


if __name__ == "__main__":
    sys.exit(main())
