"""``ergopose settings template [--out FILE]``: a settings.toml with every key, its default and a
one-line explanation as comments (docs/settings.md lists the same keys)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ergopose.atomic import write_text
from ergopose.errors import InputError
from ergopose.settings.generate import settings_text

HELP = """\
Write a settings.toml template: the keys a session must set (format_version, recorded_at, the
cameras) with example values, and every other key commented out with its default (or an example
where it has none) and a one-line explanation. Edit it into a session folder's settings.toml
(docs/session-format.md); docs/settings.md lists every key."""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "settings", help="the settings.toml template", description="Settings files (docs/settings.md)."
    )
    actions = parser.add_subparsers(dest="settings_action", metavar="ACTION", title="actions")
    template = actions.add_parser(
        "template",
        help="write a settings.toml with every key, commented",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    template.add_argument(
        "--out",
        type=Path,
        metavar="FILE",
        default=None,
        help="write to FILE (it must not exist) instead of the standard output",
    )
    template.set_defaults(func=run_template)

    def show_help(args: argparse.Namespace) -> int:
        parser.print_help()
        return 2

    parser.set_defaults(func=show_help)
    return parser


def run_template(args: argparse.Namespace) -> int:
    text = settings_text()
    if args.out is None:
        sys.stdout.write(text)
        return 0
    if args.out.exists():
        raise InputError("already exists: give a new file name (the template never overwrites a file)", path=args.out)
    write_text(args.out, text)
    print(f"wrote {args.out}: every key of settings.toml, commented with its default (docs/settings.md)")
    return 0
