"""``ergopose simulate``: a simulated session with exact ground truth.

    ergopose simulate --out DIR [--workers 2] [--minutes 5] [--seed 0] [--size 1024x768] [--fps 12]

Writes a complete session folder (two fisheye videos, calibration.toml, settings.toml) plus
ground_truth/ (docs/session-format.md, docs/simulator.md). The same seed gives the same session.
"""

from __future__ import annotations

import argparse
import datetime as dt
import re
import time
from pathlib import Path

from ergopose.cli_progress import ProgressBars
from ergopose.errors import ConfigError
from ergopose.sim.render import RenderOptions
from ergopose.sim.scene import DEFAULT_FPS, DEFAULT_SIZE, PAPER_SIZE
from ergopose.sim.writer import DEFAULT_START, SimulationConfig, simulate_session

DESCRIPTION = f"""\
Write a simulated recording session with exact ground truth: two 180-degree fisheye cameras on
the ceiling (3 m high, 1.5 m apart) over a 6 x 6 m workplace with shelves and tables, and 1 to 4
workers of different body sizes doing a scripted shift (walking, lifting from the floor,
placing on shelves, reaching overhead, picking with a twist, assembly, rests).

The folder is a normal session (the videos, calibration.toml, settings.toml) plus ground_truth/
with every frame's 3D joints, joint angles, task labels, and per camera the joints' fisheye
pixels, angles off the lens axis and visibility. The same --seed gives the same session.
Default size {DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]}; the paper's cameras recorded {PAPER_SIZE[0]}x{PAPER_SIZE[1]}."""


def _size(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT (e.g. 1024x768), got {text!r}")
    return int(m.group(1)), int(m.group(2))


def _start(text: str) -> dt.datetime:
    try:
        return dt.datetime.fromisoformat(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an ISO 8601 date and time, got {text!r}") from None


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "simulate",
        help="write a simulated session with exact ground truth",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--out", required=True, type=Path, metavar="DIR", help="the session folder to write")
    parser.add_argument("--workers", type=int, default=2, help="number of workers, 1 to 4 (default 2)")
    parser.add_argument("--minutes", type=float, default=5.0, help="length of the session (default 5)")
    parser.add_argument("--seed", type=int, default=0, help="random seed: the same seed, the same session (default 0)")
    parser.add_argument(
        "--size",
        type=_size,
        default=DEFAULT_SIZE,
        metavar="WxH",
        help=f"camera image size (default {DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]})",
    )
    parser.add_argument("--fps", type=float, default=DEFAULT_FPS, help=f"frames per second (default {DEFAULT_FPS:g})")
    parser.add_argument(
        "--start",
        type=_start,
        default=DEFAULT_START,
        metavar="ISO",
        help=f"recording start time (default {DEFAULT_START.isoformat()})",
    )
    parser.add_argument("--clean", action="store_true", help="no sensor noise, blur or brightness drift")
    parser.add_argument(
        "--processes", type=int, default=None, help="render processes (default: one per camera for long sessions)"
    )
    parser.add_argument("--force", action="store_true", help="replace DIR if it exists and is not empty")
    parser.set_defaults(func=run)
    return parser


def run(args: argparse.Namespace) -> int:
    out: Path = args.out
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not args.force:
        raise ConfigError("exists and is not an empty folder; use --force to replace it", path=out)
    render = RenderOptions(noise_sigma=0.0, blur_sigma=0.0, brightness_drift=0.0) if args.clean else RenderOptions()
    if args.processes is not None and args.processes < 1:
        raise ConfigError(f"expected at least 1 process, got {args.processes}", field="processes")
    config = SimulationConfig(
        workers=args.workers,
        minutes=args.minutes,
        seed=args.seed,
        size=args.size,
        fps=args.fps,
        start=args.start,
        render=render,
        processes=args.processes,
    )
    t0 = time.perf_counter()
    simulate_session(out, config, progress=ProgressBars())
    frames = int(round(config.minutes * 60.0 * config.fps))
    print(
        f"wrote {out}: {config.workers} simulated worker(s), 2 cameras x {frames} frames "
        f"({frames / config.fps:.1f} s at {config.fps:g} fps, {config.size[0]}x{config.size[1]}), "
        f"ground truth in {out / 'ground_truth'} ({time.perf_counter() - t0:.1f} s)"
    )
    return 0
