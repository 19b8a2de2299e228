"""``ergopose score``: RULA or REBA step scores for a CSV of joint angles.

    ergopose score --method rula|reba --angles FILE.csv --out FILE.csv [--settings FILE.toml]

The input is a posture table in DEGREES (docs/posture-table.md); the output has one row per
input row: worker/frame/time_s when given, then every step score per side (docs/csv-columns.md).
Missing, unknown or invalid columns stop the command with one line naming them.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ergopose.cli_progress import ProgressBars
from ergopose.ergonomics.export import write_scores_csv
from ergopose.ergonomics.methods import load_method
from ergopose.ergonomics.posture import read_posture_csv
from ergopose.ergonomics.scoring import LEVEL_COLUMNS, score_posture
from ergopose.ergonomics.settings import load_settings

DESCRIPTION = """\
Score every row of a joint-angle CSV with RULA or REBA and write every step score.

The input holds one row per frame with angles in degrees (flexion positive, extension
negative; elbow and knee 0 = straight), yes/no flags as 0/1 and the task inputs (load_kg,
load_mode, coupling); docs/posture-table.md lists the columns. Unprefixed arm, wrist and
knee columns mean both sides. An empty cell is "not measured": the scores that need it stay
empty. --settings takes a TOML file of scoring settings (docs/scoring.md)."""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "score",
        help="RULA or REBA step scores for a CSV of joint angles",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--method", required=True, choices=("rula", "reba"), help="the scoring method")
    parser.add_argument(
        "--angles",
        required=True,
        type=Path,
        metavar="FILE.csv",
        help="joint angles in degrees, one row per frame (docs/posture-table.md)",
    )
    parser.add_argument(
        "--out", required=True, type=Path, metavar="FILE.csv", help="where to write the scores (written atomically)"
    )
    parser.add_argument(
        "--settings",
        type=Path,
        metavar="FILE.toml",
        help="scoring settings (top-level keys or a [scoring] table; docs/scoring.md)",
    )
    parser.set_defaults(func=run)
    return parser


def run(args: argparse.Namespace) -> int:
    settings = load_settings(args.settings)
    method = load_method(args.method)
    posture = read_posture_csv(args.angles, args.method)
    scores = score_posture(
        posture, (args.method,), settings, progress=ProgressBars(), method_data={args.method: method}
    )
    ident = [c for c in ("worker", "frame", "time_s") if c in posture.columns]
    frames = posture[ident].join(scores) if ident else scores
    write_scores_csv(args.out, frames)
    score_col, level_col = LEVEL_COLUMNS[args.method]
    levels = scores[level_col]
    counts = levels.value_counts(dropna=True).sort_index()
    parts = [f"{method.level(int(lv)).label}: {int(k)}" for lv, k in counts.items()]
    missing = int(levels.isna().sum())
    if missing:
        parts.append(f"not scored: {missing}")
    print(
        f"{args.method.upper()}: {len(scores)} rows scored ({', '.join(parts) or 'none'}); wrote {args.out}",
        file=sys.stdout,
    )
    return 0
