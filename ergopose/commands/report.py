"""``ergopose report``: re-render a session's HTML report from its stored results.

Reads ``<report folder>/results/`` (written by ``ergopose assess``) and writes ``index.html`` and
one ``worker-<id>.html`` per worker next to it, without running the pipeline again: use it after
an update of ergopose's report templates, or to restore deleted pages.

Where the report folder is: ``--out DIR`` if given; else ``--session DIR`` itself when it holds
``results/session.json`` (a report folder); else ``reports/<name of the session folder>`` in the
current folder (where ``ergopose assess`` puts it by default).

Part of the day: ``--start HH:MM --end HH:MM`` (clock time of the session's day, or seconds from
its start) scores the stored tracks again for that part only (no video work) and writes its
report, CSV files and results into ``<report folder>/part-HHMM-HHMM/``; the whole day's report
stays as it is. --session must then be the session folder (its settings and names are used).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ergopose.cli_progress import ProgressBars, warnings_only
from ergopose.errors import InputError
from ergopose.pipeline.guard import check_results_session
from ergopose.pipeline import rescore
from ergopose.pipeline import window as part_of_day
from ergopose.pipeline.names import unused_message, unused_task_inputs
from ergopose.pipeline.store import ResultStore
from ergopose.progress import warn
from ergopose.progress import ProgressCallback
from ergopose.report.render import render_report
from ergopose.report.results import RESULTS_DIR, SESSION_FILE, SessionResults, load_results
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
        raise InputError(
            f"no stored results for this session (expected {folder / RESULTS_DIR / SESSION_FILE}); "
            f"run 'ergopose assess --session {session}' first, or give the report folder with --out",
            path=session,
        )
    return folder


def check_session(session: str | Path, folder: Path, force: bool, progress: ProgressCallback | None = None) -> None:
    """When --session is a session folder (not the report folder itself), refuse stored results of
    another recording unless ``force`` (ergopose.pipeline.guard)."""
    session = Path(session)
    if folder.resolve() == session.resolve() or not (session / SETTINGS_FILE).is_file():
        return
    check_results_session(
        folder,
        load_session(session, check_videos=False),
        force,
        progress=progress,
        advice="give the report folder of this session with --out, or add --force to render them anyway",
    )


def warn_unused_inputs(session: str | Path, results: SessionResults, progress: ProgressCallback | None) -> None:
    """Before rendering: warn when task inputs of the session's settings name ids that none of the
    stored workers (of ``results``) has (the report re-renders stored scores; 'ergopose workers
    --name' scores again)."""
    session = Path(session)
    if not (session / SETTINGS_FILE).is_file():
        return
    loaded = load_session(session, check_videos=False)
    stored = [w.info.worker_id for w in results.workers]
    unused = unused_task_inputs(loaded, stored)
    if unused:
        warn(progress, unused_message(loaded, unused, tracked_ids=stored))


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "report",
        help="re-render the HTML report of a session from its stored results",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--session", required=True, metavar="DIR", help="the session folder (or its report folder)")
    parser.add_argument(
        "--out",
        metavar="DIR",
        default=None,
        help=f"the report folder holding {RESULTS_DIR}/ (default: {DEFAULT_REPORTS_DIR}/<session name>)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument(
        "--force",
        action="store_true",
        help="render results that belong to another recording than --session (refused otherwise)",
    )
    parser.add_argument(
        "--start",
        default=None,
        metavar="TIME",
        help="a part of the day from this time: clock time HH:MM[:SS] of the session's day, or "
        "seconds from its start (scored again from the stored tracks, no video)",
    )
    parser.add_argument("--end", default=None, metavar="TIME", help="... up to this time (same forms as --start)")
    parser.add_argument(
        "--csv-bom", action="store_true", help="with --start/--end: CSV files with a UTF-8 byte order mark (Excel)"
    )
    parser.set_defaults(func=run)
    return parser


def run_window(args: argparse.Namespace, folder: Path, progress: ProgressCallback | None) -> int:
    """--start/--end: the part of the day scored again from the stored tracks into its own folder."""
    session_dir = Path(args.session)
    if not (session_dir / SETTINGS_FILE).is_file():
        raise InputError(
            f"--start/--end score the stored tracks again and need the session folder (with "
            f"{SETTINGS_FILE}) as --session, and its report folder as --out",
            path=session_dir,
        )
    session = load_session(session_dir, check_videos=False)
    window = part_of_day.resolve(args.start, args.end, session.recorded_at, session.duration_s)
    assert window is not None  # --start or --end was given
    if not ResultStore(folder).tracks_path.is_file():
        raise InputError(
            f"no stored tracks in this report folder (expected {ResultStore(folder).tracks_path}); "
            "run 'ergopose assess' on the session first",
            path=folder,
        )
    check_session(session_dir, folder, args.force, progress or warnings_only)
    outputs = rescore.rescore_window(session, folder, window, progress, bom=args.csv_bom)
    print(f"part of the day {part_of_day.describe(window, session.recorded_at)}")
    print(f"report: {outputs.index_html}")
    print(f"CSV files: {outputs.session_csv.parent}")
    return 0


def run(args: argparse.Namespace) -> int:
    folder = report_folder(args.session, args.out)
    progress = None if args.quiet else ProgressBars()
    if args.start is not None or args.end is not None:
        return run_window(args, folder, progress)
    check_session(args.session, folder, args.force, progress or warnings_only)
    results = load_results(folder)  # read once: the warning and the pages use the same records
    warn_unused_inputs(args.session, results, progress or warnings_only)
    files = render_report(folder, results, progress=progress)
    for path in (files.index, *files.workers):
        size = files.sizes[path.name]
        print(f"{path} ({size / 1e6:.2f} MB)")
    return 0


__all__ = ["register", "run", "report_folder"]
