"""ergopose assess --session DIR [--out DIR]: the whole job, from videos to reports."""

from __future__ import annotations

import argparse
import glob
import sys
from pathlib import Path
from typing import Sequence

from ergopose.cli_progress import ProgressBars
from ergopose.errors import ConfigError
from ergopose.pipeline.assess import AssessOptions, AssessResult, assess
from ergopose.pipeline.publish import WorkerOutput
from ergopose.pose.models import DEFAULT_LANDMARK_MODEL, LANDMARK_MODELS
from ergopose.ergonomics.shares import HIGH_WORDS, format_percent, shift_high_risk
from ergopose.report.wording import CONFIDENCE_WORDS, fmt_duration, fmt_percent


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "assess",
        help="assess a session: videos in, RULA/REBA per worker, CSV files and an HTML report out",
        description=(
            "Assess a recording session: find the workers in every camera's video, estimate their 3D\n"
            "posture over the whole shift, score RULA and REBA per frame, aggregate per worker, and\n"
            "write per-worker CSV files and an HTML report.\n\n"
            "An interrupted run (Ctrl-C, a killed process, a power cut) continues where it stopped\n"
            "when started again with the same session and output folder."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument(
        "--session",
        type=Path,
        metavar="DIR",
        help="the session folder (videos, calibration.toml, settings.toml; docs/session-format.md)",
    )
    which.add_argument(
        "--sessions",
        nargs="+",
        metavar="DIR",
        help="with --cluster: several session folders (or glob patterns) in one submission, "
        "each into <--out>/<session folder name> (default reports/<name>)",
    )
    p.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        default=None,
        help="the report folder (default: reports/<session folder name>)",
    )
    p.add_argument(
        "--cluster",
        default=None,
        metavar="ADDRESS",
        help="run the work on a Dask cluster: a scheduler address (tcp://host:8786) or local:N for N "
        "worker processes on this machine (docs/cluster.md)",
    )
    p.add_argument(
        "--processes", type=int, default=None, metavar="N", help="processes for the video work (default: one per core)"
    )
    p.add_argument(
        "--chunk-seconds",
        type=float,
        default=10.0,
        metavar="S",
        help="video is processed and stored in pieces of this length (default 10)",
    )
    p.add_argument(
        "--model-dir",
        default=None,
        metavar="DIR",
        help="pose model cache (default: $ERGOPOSE_MODEL_DIR or the user cache)",
    )
    p.add_argument(
        "--model",
        choices=tuple(LANDMARK_MODELS),
        default=DEFAULT_LANDMARK_MODEL,
        help=f"the pose model (default {DEFAULT_LANDMARK_MODEL}; 'ergopose models list', docs/models.md)",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="write into an output folder that holds the results of another recording, replacing them",
    )
    p.add_argument(
        "--max-bad-frames",
        type=float,
        default=0.2,
        metavar="SHARE",
        help="share of a piece of video (--chunk-seconds) that may be unreadable and skipped; "
        "more is an error naming the video and the time (default 0.2)",
    )
    p.add_argument(
        "--start",
        default=None,
        metavar="TIME",
        help="assess from this time on: clock time HH:MM[:SS] of the session's day (its recorded_at), "
        "or seconds from its start (default: the start)",
    )
    p.add_argument(
        "--end", default=None, metavar="TIME", help="assess up to this time (same forms as --start; default: the end)"
    )
    p.add_argument(
        "--csv-bom",
        action="store_true",
        help="write the CSV files with a UTF-8 byte order mark, so Excel reads names in any script",
    )
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    if args.chunk_seconds <= 0:
        raise ConfigError(f"expected a positive number of seconds, got {args.chunk_seconds}", field="--chunk-seconds")
    if not 0.0 <= args.max_bad_frames <= 1.0:
        raise ConfigError(f"expected a share between 0 and 1, got {args.max_bad_frames}", field="--max-bad-frames")
    options = AssessOptions(
        out_dir=args.out,
        processes=args.processes,
        chunk_seconds=args.chunk_seconds,
        model_dir=args.model_dir,
        force=args.force,
        max_bad_frame_share=args.max_bad_frames,
        model=args.model,
        start=args.start,
        end=args.end,
        csv_bom=args.csv_bom,
    )
    if args.cluster is not None:
        return run_on_cluster(args, options)
    if args.sessions is not None:
        raise ConfigError(
            "several sessions are assessed in one submission on a cluster: add --cluster (local:N for this machine)",
            field="--sessions",
        )
    result = assess(args.session, options, progress=ProgressBars())
    print_result(result)
    return 0


def run_on_cluster(args: argparse.Namespace, options: AssessOptions) -> int:
    """--cluster: the sessions on Dask (ergopose.pipeline.cluster); a summary per session. One
    session's error is raised as for a local run; of several, each failed session is named with
    its error and the exit code is 1."""
    try:  # deferred on purpose: Dask is the optional extra 'cluster', needed only here
        from ergopose.pipeline.cluster import assess_sessions
    except ImportError as exc:
        raise ConfigError(
            f"--cluster needs Dask distributed ({exc}): pip install 'ergopose[cluster]'", field="--cluster"
        ) from None

    sessions = [args.session] if args.session is not None else expand_sessions(args.sessions)
    outcomes = assess_sessions(sessions, args.cluster, options, progress=ProgressBars())
    if args.session is not None:
        if outcomes[0].error is not None:
            raise outcomes[0].error
        assert outcomes[0].result is not None  # no error: a result
        print_result(outcomes[0].result)
        return 0
    for o in outcomes:
        if o.result is not None:
            print_result(o.result)
    failed = [o for o in outcomes if o.error is not None]
    for o in failed:
        print(f"ergopose: error: {o.session}: {o.error}", file=sys.stderr)
    print(
        f"{len(outcomes) - len(failed)} of {len(outcomes)} sessions assessed"
        + (f"; {len(failed)} failed: {', '.join(str(o.session) for o in failed)}" if failed else "")
    )
    return 1 if failed else 0


def expand_sessions(patterns: Sequence[str]) -> list[Path]:
    """Session folders from --sessions: each a folder, or a glob pattern (sorted matches)."""
    out: list[Path] = []
    for pat in patterns:
        if Path(pat).is_dir() or not any(ch in pat for ch in "*?["):
            out.append(Path(pat))
            continue
        found = sorted(Path(m) for m in glob.glob(pat) if Path(m).is_dir())
        if not found:
            raise ConfigError(f"no session folder matches {pat!r}", field="--sessions")
        out.extend(found)
    return out


def print_result(result: AssessResult) -> None:
    """The summary a user sees at the end: per worker the tracked time split by confidence (with
    causes), the shares at high risk of the tracked and of the scored time, where the files are.
    The figures are the shift summary's, formatted as in the report."""
    print(
        f"assessed {result.session} ({result.frames} frames, {result.seconds:.0f} s"
        + (f", {result.chunks_reused} of {result.chunks_total} chunks reused" if result.chunks_reused else "")
        + ")"
    )
    for w in result.workers:
        for line in worker_lines(w):
            print(line)
    print(f"report: {result.index_html}")
    print(f"CSV files: {result.session_csv.parent}")


def worker_lines(w: WorkerOutput) -> list[str]:
    """One worker's lines of the terminal summary (w: ergopose.pipeline.publish.WorkerOutput)."""
    s = w.summary
    total = s.observed_s
    name = f" ({w.name})" if w.name != w.worker_id else ""
    lines = [f"  {w.worker_id}{name}: tracked {fmt_duration(total)}"]
    for c in s.confidence:
        causes = "; ".join(f"{ca.cause} {fmt_duration(ca.time_s)} ({fmt_percent(ca.time_s, total)})" for ca in c.causes)
        lines.append(
            f"    {CONFIDENCE_WORDS[c.level]}: {fmt_duration(c.time_s)} ({fmt_percent(c.time_s, total)} of "
            f"tracked time)" + (f": {causes}" if causes else "")
        )
    for method in ("rula", "reba"):  # the shares of the report's headline and session_summary.csv
        r = shift_high_risk(s, method)
        lines.append(
            f"    {HIGH_WORDS[method]}: {fmt_duration(r.high_s)} = {format_percent(r.pct_of_tracked)} of tracked "
            f"time, {format_percent(r.pct_of_scored)} of scored time ({fmt_duration(r.scored_s)} scored; "
            f"not scored {fmt_duration(r.unscored_s)} = {format_percent(r.unscored_pct_of_tracked)} of "
            f"tracked time" + (", causes above)" if r.unscored_s > 0 and s.confidence else ")")
        )
    return lines
