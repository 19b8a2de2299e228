"""``ergopose workers``: the tracked people of an assessed session, and their names.

Without --name: a table of the tracked ids of the stored results (docs/workers.md): the id and
the name it is reported under, the measured stature, the tracked time, first and last seen
(clock time of the session's start) and where on the floor (median position; the nearest
furniture of floor.toml).

With --name worker_1=ALIAS (as often as needed): the names are stored in the session's
names.toml and the stored tracks are scored again (no video work): CSV files, stored results
and report are replaced whole. ALIAS is a [workers.<id>] key of settings.toml or that table's
name (the person then gets that worker's task inputs), or any other name. Tracked ids given the
same ALIAS are scored as one worker. An empty ALIAS (worker_1=) removes the name.

--rescore scores the stored tracks again with the current settings.toml (changed task inputs)
without changing names.
"""

from __future__ import annotations

import argparse
import math
from typing import Sequence

from ergopose.cli_progress import ProgressBars, warnings_only
from ergopose.pipeline import names, rescore
from ergopose.session import load_session
from ergopose.session import Session


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "workers",
        help="list the tracked people of an assessed session and give them names (re-scored, no video)",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--session", required=True, metavar="DIR", help="the session folder (settings.toml, videos)")
    p.add_argument(
        "--results",
        metavar="DIR",
        default=None,
        help="the output folder of 'ergopose assess' (default: reports/<session folder name>)",
    )
    p.add_argument(
        "--name",
        action="append",
        default=[],
        metavar="TRACKED_ID=ALIAS",
        help="name a tracked id (repeatable): a [workers.<id>] key of settings.toml, its name, or any name",
    )
    p.add_argument(
        "--rescore", action="store_true", help="score the stored tracks again with the current settings (no video work)"
    )
    p.add_argument(
        "--csv-bom", action="store_true", help="with --name/--rescore: CSV files with a UTF-8 byte order mark (Excel)"
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    progress = warnings_only if args.quiet else ProgressBars()
    if args.name or args.rescore:
        given = names.parse_name_args(args.name)
        if given:
            outputs = rescore.rename(args.session, given, args.results, progress, bom=args.csv_bom)
        else:
            session = load_session(args.session, check_videos=False)
            outputs = rescore.rescore(
                session, rescore.results_folder(args.session, args.results), progress, bom=args.csv_bom
            )
        for w in outputs.workers:
            shown = f" ({w.name})" if w.name != w.worker_id else ""
            print(f"  {w.worker_id}{shown}")
        print(f"report: {outputs.index_html}")
        print(f"CSV files: {outputs.session_csv.parent}")
        return 0
    session = load_session(args.session, check_videos=False)
    folder = rescore.results_folder(args.session, args.results)
    people = rescore.tracked_people(session, folder)
    for line in table_lines(session, people):
        print(line)
    rescore.warn_unused(session, people, progress)
    rescore.warn_headcount(session, folder, people, progress)
    return 0


def table_lines(session: Session, people: Sequence[rescore.TrackedPerson]) -> list[str]:
    """The listing: one line per tracked id under a header."""
    rows = [("tracked id", "reported as", "stature", "tracked", "first seen", "last seen", "floor x, y (m)")]
    for p in people:
        shown = p.reported_id if p.name == p.reported_id else f"{p.reported_id} ({p.name})"
        where = (f"{p.x_m:+.1f}, {p.y_m:+.1f}" if math.isfinite(p.x_m) else "-") + (f" {p.place}" if p.place else "")
        rows.append(
            (
                p.tracked_id,
                shown,
                f"{p.stature_m:.2f} m" if math.isfinite(p.stature_m) else "-",
                _duration(p.tracked_s),
                rescore.clock(session, p.first_s),
                rescore.clock(session, p.last_s),
                where,
            )
        )
    widths = [max(len(r[k]) for r in rows) for k in range(len(rows[0]))]
    return ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]


def _duration(s: float) -> str:
    m, sec = divmod(int(round(s)), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"
