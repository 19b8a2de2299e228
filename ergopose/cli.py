"""The ``ergopose`` command line.

Each subcommand lives in ``ergopose/commands/<name>.py`` and exposes
``register(subparsers) -> argparse.ArgumentParser``; the parser's ``func`` default is called
with the parsed arguments and returns an exit code. Errors meant for the user
(:class:`ergopose.errors.ErgoposeError`) print one line and exit 2, without a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from typing import Sequence

from ergopose import __version__
from ergopose.errors import ErgoposeError, output_error

#: Subcommand modules, in the order ``--help`` lists them.
COMMAND_MODULES: tuple[str, ...] = (
    "ergopose.commands.assess",
    "ergopose.commands.pose",
    "ergopose.commands.demo",
    "ergopose.commands.models",
    "ergopose.commands.session",
    "ergopose.commands.settings",
    "ergopose.commands.camera",
    "ergopose.commands.calibrate",
    "ergopose.commands.score",
    "ergopose.commands.simulate",
    "ergopose.commands.report",
    "ergopose.commands.workers",
    "ergopose.commands.evaluate",
)

DESCRIPTION = """\
Markerless ergonomic risk assessment (RULA, REBA) from calibrated cameras (the rig: two
ceiling-mounted fisheye cameras).

Make a session folder with 'ergopose session new DIR --calibration FILE VIDEO...' (one video
per camera, a calibration and a settings file), then run 'ergopose assess --session DIR'; each
subcommand has its own --help."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ergopose", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--version", action="version", version=f"ergopose {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    func = getattr(args, "func", None)
    if func is None:  # no command: the help, and the usage-error code (argparse's convention)
        parser.print_help(sys.stderr)
        return 2
    try:
        code = func(args)
    except ErgoposeError as exc:
        print(f"ergopose: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("ergopose: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except OSError as exc:  # a full disk or a read-only folder met while writing: one line, not a traceback
        err = output_error(exc)
        if err is None:
            raise
        print(f"ergopose: error: {err}", file=sys.stderr)
        return 2
    return 0 if code is None else int(code)
