"""ergopose evaluate --session DIR --results OUT [--json FILE] [--oracle ...]: an assessed
simulated session against its ground truth; ergopose evaluate --results OUT --reference FILE.trc:
an assessment against a reference 3D marker recording (docs/evaluation.md)."""

from __future__ import annotations

import argparse
import json
from typing import Any
from pathlib import Path

from ergopose.atomic import write_text
from ergopose.cli_progress import ProgressBars
from ergopose.errors import ConfigError
from ergopose.geometry.calibration_file import read_any_calibration
from ergopose.evaluation.compare import evaluate_results, write_json
from ergopose.evaluation.keypoint_reference import MIN_LIKELIHOOD, openpose_reference
from ergopose.evaluation.loading import ResultsLayout
from ergopose.evaluation.oracle import ORACLE_DIR, OracleOptions, run_oracle
from ergopose.evaluation.reference import evaluate_reference, format_reference
from ergopose.pipeline.guard import check_results_session
from ergopose.progress import ProgressCallback
from ergopose.session import load_session
from ergopose.evaluation.text import format_evaluation


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "evaluate",
        help="compare an assessment with a simulation's ground truth or with a reference marker recording (TRC)",
        description=(
            "Compare what 'ergopose assess' wrote for a simulated session (made by 'ergopose simulate')\n"
            "with the simulation's ground truth: 3D joint error per lens region, limb lengths, detection\n"
            "rate, identity switches, joint-angle error, agreement of RULA and REBA with the scores of the\n"
            "true angles (Cohen's kappa), and the reference-bar table. Prints a summary and writes JSON.\n\n"
            "--oracle runs the reconstruction on the simulator's ORACLE 2D keypoints (true joints with\n"
            "pixel noise) instead of the pose network's, writes it to OUT/oracle/ and evaluates that:\n"
            "geometry, tracking and smoothing measured apart from the network.\n\n"
            "--reference FILE.trc compares any assessment with a reference 3D marker recording (Pose2Sim,\n"
            "OpenSim or motion-capture TRC; Y up): the reference is aligned to the assessment's world by a rigid\n"
            "transform fitted over the matched markers (or by --reference-axes), its angles and RULA/REBA come\n"
            "from the same code as the product's, and the differences per angle, body part and score are\n"
            "printed and written as JSON (default OUT/evaluation_reference.json)."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--session",
        type=Path,
        metavar="DIR",
        default=None,
        help="the session folder (simulated, with ground_truth/; with --reference optional: its "
        "scoring settings and worker names are used)",
    )
    p.add_argument(
        "--results",
        required=True,
        type=Path,
        metavar="OUT",
        help="the folder 'ergopose assess --out OUT' wrote (with --oracle: where OUT/oracle/ goes)",
    )
    p.add_argument(
        "--json",
        type=Path,
        metavar="FILE",
        default=None,
        help="where to write the evaluation as JSON (default OUT/evaluation.json, "
        "with --oracle OUT/oracle/evaluation.json)",
    )
    r = p.add_argument_group("against a reference marker recording")
    r.add_argument(
        "--reference",
        type=Path,
        metavar="FILE.trc",
        default=None,
        help="reference 3D markers (TRC); replaces the simulation's ground truth",
    )
    r.add_argument(
        "--reference-keypoints",
        type=Path,
        metavar="DIR",
        default=None,
        help="instead of --reference: a reference triangulated here from another network's 2D keypoints "
        "(DIR holds one folder of OpenPose JSON files per camera, e.g. cam01_json/, matched to the "
        "calibration's cameras by number): every camera whose keypoint has at least "
        "--reference-min-likelihood counts, weighted by it, nothing left out after the fact "
        "(docs/evaluation.md)",
    )
    r.add_argument(
        "--reference-calibration",
        type=Path,
        metavar="FILE",
        default=None,
        help="with --reference-keypoints: the calibration of all the cameras that filmed the keypoints "
        "(ergopose, Pose2Sim or anipose TOML; default: the session's calibration)",
    )
    r.add_argument(
        "--reference-min-likelihood",
        type=float,
        default=MIN_LIKELIHOOD,
        metavar="P",
        help=f"with --reference-keypoints: the lowest keypoint likelihood used (default {MIN_LIKELIHOOD:g}, "
        "Pose2Sim's own)",
    )
    r.add_argument(
        "--reference-axes",
        metavar="X,Y,Z",
        default=None,
        help="world x, y, z as the reference's axes instead of a fitted rigid transform, e.g. z,x,y "
        "(a leading - flips one)",
    )
    r.add_argument(
        "--reference-offset",
        type=float,
        default=0.0,
        metavar="S",
        help="time of the reference's first sample in the assessment, seconds (default 0: the first video frame)",
    )
    r.add_argument(
        "--worker",
        default=None,
        metavar="ID",
        help="compare only this tracked worker (default: in each frame the tracked row nearest the reference)",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="evaluate results that belong to another recording than --session (refused otherwise)",
    )
    o = p.add_argument_group("ORACLE run (evaluation only)")
    o.add_argument(
        "--oracle",
        action="store_true",
        help="reconstruct from the simulator's ORACLE 2D keypoints instead of evaluating assess's output",
    )
    o.add_argument(
        "--noise-px",
        type=float,
        default=2.0,
        metavar="PX",
        help="ORACLE pixel noise on visible joints, standard deviation per axis (default 2)",
    )
    o.add_argument(
        "--dropout",
        type=float,
        default=0.02,
        metavar="P",
        help="ORACLE probability that a worker is missed in a camera frame (default 0.02)",
    )
    o.add_argument(
        "--joint-dropout",
        type=float,
        default=0.02,
        metavar="P",
        help="ORACLE probability that a single visible joint is missing (default 0.02)",
    )
    o.add_argument(
        "--occluded-noise-px",
        type=float,
        default=6.0,
        metavar="PX",
        help="ORACLE pixel noise on joints a camera cannot see (default 6)",
    )
    o.add_argument(
        "--own-body-seen",
        action="store_true",
        help="ORACLE: report the joints behind the worker's own body like visible ones (--noise-px, a visible "
        "joint's confidence) instead of as hidden: the true joints plus noise; furniture and other workers still hide",
    )
    o.add_argument("--oracle-seed", type=int, default=0, metavar="N", help="ORACLE random seed (default 0)")
    b = p.add_argument_group("reference bar")
    b.add_argument(
        "--bar-noise-px", type=float, default=0.5, metavar="PX", help="pixel noise added to the bar ends (default 0.5)"
    )
    b.add_argument("--bar-draws", type=int, default=100, metavar="N", help="noisy measurements per bar (default 100)")
    b.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the bar's pixel noise (default 0)")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    progress = ProgressBars()
    if args.reference is not None or args.reference_keypoints is not None:
        return run_reference(args, progress)
    if args.session is None:
        raise ConfigError("give --session DIR (a simulated session) or --reference FILE.trc", field="--session")
    _check_results(args, progress)
    oracle = None
    if args.oracle:
        for name in ("noise_px", "occluded_noise_px"):
            v = getattr(args, name)
            if not (v == v and 0 <= v < float("inf")):
                raise ConfigError(f"expected a number of pixels >= 0, got {v}", field="--" + name.replace("_", "-"))
        for name in ("dropout", "joint_dropout"):
            v = getattr(args, name)
            if not (0.0 <= v <= 1.0):
                raise ConfigError(
                    f"expected a probability between 0 and 1, got {v}", field="--" + name.replace("_", "-")
                )
        options = OracleOptions(
            noise_px=args.noise_px,
            person_dropout=args.dropout,
            joint_dropout=args.joint_dropout,
            occluded_noise_px=args.occluded_noise_px,
            seed=args.oracle_seed,
            own_body_hides=not args.own_body_seen,
        )
        print(options.banner(), flush=True)
        layout = run_oracle(args.session, args.results, options, progress=progress)
        oracle = options.as_dict()
        source = options.banner()
        default_json = layout.root / "evaluation.json"
    else:
        layout = ResultsLayout.of_assess(args.results)
        source = "pose network (ergopose assess)"
        default_json = layout.root / "evaluation.json"
    evaluation = evaluate_results(
        args.session,
        layout,
        source=source,
        oracle=oracle,
        bar_noise_px=args.bar_noise_px,
        bar_draws=args.bar_draws,
        seed=args.seed,
        progress=progress,
    )
    path = write_json(evaluation, args.json or default_json)
    print(format_evaluation(evaluation.to_dict()))
    print(f"\nJSON: {path}")
    return 0


def run_reference(args: argparse.Namespace, progress: ProgressCallback | None) -> int:
    if args.oracle:
        raise ConfigError("--oracle needs a simulated session, not --reference", field="--oracle")
    reference, source = args.reference, None
    if args.reference_keypoints is not None:
        if args.reference is not None:
            raise ConfigError(
                "give --reference FILE.trc or --reference-keypoints DIR, not both", field="--reference-keypoints"
            )
        reference, source = _keypoint_reference(args)
    ev = evaluate_reference(
        args.results,
        reference,
        session_dir=args.session,
        axes=args.reference_axes,
        offset_s=args.reference_offset,
        worker=args.worker,
        progress=progress,
        source=source,
    )
    path = write_text(
        args.json or Path(args.results) / "evaluation_reference.json", json.dumps(ev, indent=1, allow_nan=False) + "\n"
    )
    print(format_reference(ev))
    print(f"\nJSON: {path}")
    return 0


def _check_results(args: argparse.Namespace, progress: ProgressCallback | None) -> None:
    """Refuse results (and an ORACLE run's folder) of another recording than --session, unless --force."""
    session = load_session(args.session, check_videos=False)
    folders = [args.results] + ([args.results / ORACLE_DIR] if args.oracle else [])
    for folder in folders:
        check_results_session(
            folder,
            session,
            args.force,
            progress=progress,
            advice="give the results of this session with --results, or add --force to evaluate them anyway",
        )


def _keypoint_reference(args: argparse.Namespace) -> tuple[Any, str]:
    """The reference of --reference-keypoints (ergopose.evaluation.keypoint_reference) and its description."""
    if args.session is None:
        raise ConfigError(
            "--reference-keypoints needs --session DIR (its frame rate, and its calibration unless "
            "--reference-calibration is given)",
            field="--session",
        )
    session = load_session(args.session, check_videos=False)
    if args.reference_calibration is not None:
        cameras, _ = read_any_calibration(args.reference_calibration)
    else:
        cameras = session.calibrated_cameras
    reference = openpose_reference(
        args.reference_keypoints, cameras, session.fps, min_likelihood=args.reference_min_likelihood
    )
    source = (
        f"reference triangulated from the 2D keypoints in {args.reference_keypoints} (every camera with "
        f"likelihood >= {args.reference_min_likelihood:g}, weighted DLT, nothing left out)"
    )
    return reference, source
