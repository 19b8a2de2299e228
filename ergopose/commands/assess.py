"""ergopose assess --session DIR [--out DIR]: the whole job, from videos to reports."""

from __future__ import annotations

import argparse
from pathlib import Path

from ergopose.cli_progress import ProgressBars
from ergopose.errors import ConfigError
from ergopose.pipeline.assess import AssessOptions, assess


def register(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "assess",
        help="assess a session: videos in, RULA/REBA per worker, CSV files and an HTML report out",
        description=(
            "Assess a recording session: find the workers in every camera's video, estimate their 3D\n"
            "posture over the whole shift, score RULA and REBA per frame, aggregate per worker, and\n"
            "write per-worker CSV files and an HTML report.\n\n"
            "An interrupted run (Ctrl-C, a killed process, a power cut) continues where it stopped\n"
            "when started again with the same session and output folder."),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--session", required=True, type=Path, metavar="DIR",
                   help="the session folder (videos, calibration.toml, settings.toml; docs/session-format.md)")
    p.add_argument("--out", type=Path, metavar="DIR", default=None,
                   help="the report folder (default: reports/<session folder name>)")
    p.add_argument("--processes", type=int, default=None, metavar="N",
                   help="processes for the video work (default: one per core)")
    p.add_argument("--chunk-seconds", type=float, default=10.0, metavar="S",
                   help="video is processed and stored in pieces of this length (default 10)")
    p.add_argument("--model-dir", default=None, metavar="DIR",
                   help="pose model cache (default: $ERGOPOSE_MODEL_DIR or the user cache)")
    p.add_argument("--force", action="store_true",
                   help="write into an output folder that holds the results of another recording, replacing them")
    p.add_argument("--max-bad-frames", type=float, default=0.2, metavar="SHARE",
                   help="share of a piece of video (--chunk-seconds) that may be unreadable and skipped; "
                        "more is an error naming the video and the time (default 0.2)")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    if args.chunk_seconds <= 0:
        raise ConfigError(f"expected a positive number of seconds, got {args.chunk_seconds}", field="--chunk-seconds")
    if not 0.0 <= args.max_bad_frames <= 1.0:
        raise ConfigError(f"expected a share between 0 and 1, got {args.max_bad_frames}", field="--max-bad-frames")
    options = AssessOptions(out_dir=args.out, processes=args.processes, chunk_seconds=args.chunk_seconds,
                            model_dir=args.model_dir, force=args.force, max_bad_frame_share=args.max_bad_frames)
    result = assess(args.session, options, progress=ProgressBars())
    print_result(result)
    return 0


def print_result(result) -> None:
    """The summary a user sees at the end: workers, shares at high risk, where the files are."""
    print(f"assessed {result.session} ({result.frames} frames, {result.seconds:.0f} s"
          + (f", {result.chunks_reused} of {result.chunks_total} chunks reused" if result.chunks_reused else "") + ")")
    for w in result.workers:
        name = f" ({w.name})" if w.name != w.worker_id else ""
        print(f"  {w.worker_id}{name}: tracked {w.observed_s / 60:.1f} min; "
              f"RULA action level 3-4 {_pct(w.rula_high_share)}, REBA high/very high {_pct(w.reba_high_share)}")
    print(f"report: {result.index_html}")
    print(f"CSV files: {result.session_csv.parent}")


def _pct(x: float) -> str:
    return "n/a" if x != x else f"{100 * x:.0f} % of tracked time"
