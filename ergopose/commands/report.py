"""``ergopose report``: re-render a session's HTML report from its stored results.

Reads ``<report folder>/results/`` (written by ``ergopose assess``) and writes ``index.html`` and
one ``worker-<id>.html`` per worker next to it, without running the pipeline again: use it after
an update of ergopose's report templates, or to restore deleted pages.

Where the report folder is: ``--out DIR`` if given; else ``--session DIR`` itself when it holds
``results/session.json`` (a report folder); else ``reports/<name of the session folder>`` in the
current folder (where ``ergopose assess`` puts it by default).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ergopose.cli_progress import ProgressBars, warnings_only
from ergopose.errors import InputError
from ergopose.pipeline.guard import check_results_session
from ergopose.pipeline.names import unused_message, unused_task_inputs
from ergopose.progress import warn
from ergopose.report.render import render_report
from ergopose.report.results import RESULTS_DIR, SESSION_FILE, load_results
from ergopose.session import SETTINGS_FILE, load_session

DEFAULT_REPORTS_DIR = "reports"


def report_folder(session: str | Path, out: str | Path | None = None) -> Path:
    """The report folder of a session (see the module docstring); raises InputError when it has
    no stored results."""
    session = Path(session)
    if out is not None:
        folder = Path(out)
    elif (session / RESULTS_DIR / SESSION_FILE).is_file():
        folder = session
    else:
        folder = Path(DEFAULT_REPORTS_DIR) / session.resolve().name
    if not (folder / RESULTS_DIR / SESSION_FILE).is_file():
        raise InputError(f"no stored results for this session (expected {folder / RESULTS_DIR / SESSION_FILE}); "
                         f"run 'ergopose assess --session {session}' first, or give the report folder with --out",
                         path=session)
    return folder


def check_session(session: str | Path, folder: Path, force: bool, progress=None) -> None:
    """When --session is a session folder (not the report folder itself), refuse stored results of
    another recording unless ``force`` (ergopose.pipeline.guard)."""
    session = Path(session)
    if folder.resolve() == session.resolve() or not (session / SETTINGS_FILE).is_file():
        return
    check_results_session(folder, load_session(session, check_videos=False), force, progress=progress,
                          advice="give the report folder of this session with --out, or add --force to render "
                                 "them anyway")


def warn_unused_inputs(session: str | Path, folder: Path, progress) -> None:
    """Before rendering: warn when task inputs of the session's settings name ids that none of the
    stored workers has (the report re-renders stored scores; 'ergopose workers --name' scores again)."""
    session = Path(session)
    if not (session / SETTINGS_FILE).is_file():
        return
    loaded = load_session(session, check_videos=False)
    stored = [w.info.worker_id for w in load_results(folder).workers]
    unused = unused_task_inputs(loaded, stored)
    if unused:
        warn(progress, unused_message(loaded, unused, tracked_ids=stored))


def register(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "report", help="re-render the HTML report of a session from its stored results",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--session", required=True, metavar="DIR",
                        help="the session folder (or its report folder)")
    parser.add_argument("--out", metavar="DIR", default=None,
                        help=f"the report folder holding {RESULTS_DIR}/ (default: {DEFAULT_REPORTS_DIR}/<session name>)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--force", action="store_true",
                        help="render results that belong to another recording than --session (refused otherwise)")
    parser.set_defaults(func=run)
    return parser


def run(args: argparse.Namespace) -> int:
    folder = report_folder(args.session, args.out)
    progress = None if args.quiet else ProgressBars()
    check_session(args.session, folder, args.force, progress or warnings_only)
    warn_unused_inputs(args.session, folder, progress or warnings_only)
    files = render_report(folder, progress=progress)
    for path in (files.index, *files.workers):
        size = files.sizes[path.name]
        print(f"{path} ({size / 1e6:.2f} MB)")
    return 0


__all__ = ["register", "run", "report_folder"]
