"""ergopose demo: the main job on the built-in demo session (a simulated shift made on first use)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ergopose.cli_progress import ProgressBars
from ergopose.commands.assess import print_result
from ergopose.errors import ErgoposeError
from ergopose.pipeline.assess import AssessOptions, assess
from ergopose.session import FLOOR_PLAN_FILE, load_session
from ergopose.sim.writer import SimulationConfig, add_floor_plan, simulate_session

DEMO_SESSION = Path(".demo") / "day1"
DEMO_REPORT = Path("reports") / "day1"


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "demo",
        help="run the whole job on the built-in demo session (simulated on first use)",
        description=(
            "Run 'ergopose assess' on the demo session: a SIMULATED two-worker shift with two ceiling\n"
            "fisheye cameras (made with 'ergopose simulate' on first use, seed 0, and reused later).\n"
            "The report lands in reports/day1/; 'ergopose evaluate' compares it with the simulation's\n"
            "ground truth."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--session",
        type=Path,
        default=DEMO_SESSION,
        metavar="DIR",
        help=f"where the demo session is (default {DEMO_SESSION})",
    )
    p.add_argument(
        "--out", type=Path, default=DEMO_REPORT, metavar="DIR", help=f"report folder (default {DEMO_REPORT})"
    )
    p.add_argument("--minutes", type=float, default=2.0, help="length of the simulated shift (default 2)")
    p.add_argument("--workers", type=int, default=2, help="simulated workers (default 2)")
    p.add_argument("--seed", type=int, default=0, help="simulation seed (default 0)")
    p.add_argument("--processes", type=int, default=None, metavar="N", help="processes (default: one per core)")
    p.set_defaults(func=run)
    return p


def _is_session(path: Path) -> bool:
    if not (path / "settings.toml").exists():
        return False
    try:
        load_session(path)
    except ErgoposeError:
        return False
    return True


def run(args: argparse.Namespace) -> int:
    bars = ProgressBars()
    fresh = not _is_session(args.session)
    if not fresh:
        print(f"demo session: {args.session} (already simulated)")
        if add_floor_plan(args.session):  # a demo session simulated before sessions had a floor.toml
            print(f"added {args.session / FLOOR_PLAN_FILE} (the floor map) from the simulated scene")
    else:
        print(
            f"simulating the demo session in {args.session} ({args.workers} workers, {args.minutes:g} min, "
            f"seed {args.seed})"
        )
        simulate_session(
            args.session, SimulationConfig(workers=args.workers, minutes=args.minutes, seed=args.seed), progress=bars
        )
    # A demo session simulated just now replaces the default demo report of an earlier one (with a
    # warning); any other folder holding another recording's results is refused as by assess.
    force = fresh and Path(args.out) == Path(DEMO_REPORT)
    result = assess(args.session, AssessOptions(out_dir=args.out, processes=args.processes, force=force), progress=bars)
    print_result(result)
    print(
        f"compare with the simulation's ground truth: ergopose evaluate --session {args.session} --results {args.out}"
    )
    return 0
