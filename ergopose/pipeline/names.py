"""Which tracked person is which worker: the names given after a run, and task inputs nobody gets.

The tracker numbers the people it follows (worker_1, worker_2, ...). The settings' task inputs
(``[workers.<id>]`` loads, coupling, periods) reach a tracked person only when that person is
reported under the settings' id. Three things give a tracked person an id or a name, the first
that applies winning:

1. the session's ``names.toml`` (written by ``ergopose workers --name worker_1=ALIAS``): ALIAS is
   a ``[workers.<id>]`` key of the settings, or the ``name`` of such a table (then the person is
   reported under that id, with its name and task inputs), or any other text (then it is only
   the name shown for the tracked id; no task inputs come with it). Several tracked ids given the
   same ALIAS are one person the tracker followed as two: their rows are scored as one worker;
2. the stature match of ``[identification] by_stature`` (:mod:`ergopose.pipeline.identify`), for
   the tracked people names.toml does not name;
3. otherwise the tracker's pseudonym.

names.toml (kept apart from settings.toml: writing the settings again would lose the comments
and layout people gave it; this file is written by ergopose, atomically)::

    # written by 'ergopose workers --name'
    format_version = 1
    [names]
    worker_1 = "w1"
    worker_3 = "w1"
    worker_2 = "Anna"

:func:`unreachable_task_inputs` (before any work) and :func:`unused_task_inputs` (after tracking)
name the settings' workers whose task inputs reach nobody, so the user is told instead of the
inputs being silently left out.
"""

from __future__ import annotations

import dataclasses
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import tomli_w

from ergopose.atomic import write_text
from ergopose.errors import ConfigError, InputError
from ergopose.pipeline.identify import Identification, Identity, identify_by_stature
from ergopose.recon.pipeline import TrackFrames
from ergopose.session import Session, TaskFactors, WorkerInfo

NAMES_FILE = "names.toml"
NAMES_FORMAT_VERSION = 1
#: The tracker's pseudonyms (ergopose.recon.track_records.identity_name).
PSEUDONYM = re.compile(r"^worker_(\d+)$")
_HEADER = (
    "# Names of the tracked people of this session, written by 'ergopose workers --name'\n"
    "# (docs/workers.md). tracked id = a [workers.<id>] key of settings.toml, its name, or any name.\n"
)


def names_path(session_dir: str | Path) -> Path:
    return Path(session_dir) / NAMES_FILE


def load_names(session_dir: str | Path) -> dict[str, str]:
    """{tracked id: alias} of the session's names.toml ({} when there is none)."""
    path = names_path(session_dir)
    if not path.is_file():
        return {}
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(
            f"cannot read the names file ({exc}); fix it or remove it and name the workers again "
            "with 'ergopose workers --name'",
            path=path,
        ) from None
    if data.get("format_version") != NAMES_FORMAT_VERSION:
        raise ConfigError(
            f"unsupported format version {data.get('format_version')!r} (expected {NAMES_FORMAT_VERSION})",
            path=path,
            field="format_version",
        )
    table = data.get("names", {})
    if not isinstance(table, dict):
        raise ConfigError("expected a [names] table (tracked id = name)", path=path, field="names")
    out = {}
    for tracked, alias in table.items():
        if not PSEUDONYM.match(tracked):
            raise ConfigError(
                f"{tracked!r} is not a tracked id (worker_1, worker_2, ...)", path=path, field=f"names.{tracked}"
            )
        if not isinstance(alias, str) or not alias.strip():
            raise ConfigError(f"expected a non-empty name, got {alias!r}", path=path, field=f"names.{tracked}")
        out[tracked] = alias.strip()
    return out


def write_names(session_dir: str | Path, names: Mapping[str, str]) -> Path:
    """Write names.toml (atomically; sorted by tracker number); remove it when ``names`` is empty."""
    path = names_path(session_dir)
    if not names:
        path.unlink(missing_ok=True)
        return path
    body = tomli_w.dumps(
        {"format_version": NAMES_FORMAT_VERSION, "names": {t: names[t] for t in sorted(names, key=tracker_number)}}
    )
    return write_text(path, _HEADER + body)


def tracker_number(tracked: str) -> int:
    m = PSEUDONYM.match(tracked)
    return int(m.group(1)) if m else 1 << 30


def parse_name_args(items: Sequence[str]) -> dict[str, str]:
    """``worker_1=ALIAS`` arguments -> {tracked id: alias}; an empty ALIAS removes the name."""
    out: dict[str, str] = {}
    for item in items:
        tracked, sep, alias = item.partition("=")
        tracked = tracked.strip()
        if not sep or not PSEUDONYM.match(tracked):
            raise InputError(
                f"expected TRACKED_ID=NAME with a tracked id such as worker_1, got {item!r}", field="--name"
            )
        out[tracked] = alias.strip()
    return out


def settings_id(session: Session, alias: str) -> str | None:
    """The [workers.<id>] key an alias names (the key itself or that table's name), else None."""
    for w in session.workers:
        if w.worker_id == alias:
            return w.worker_id
    for w in session.workers:
        if w.name is not None and w.name == alias:
            return w.worker_id
    return None


def has_task_inputs(worker: WorkerInfo) -> bool:
    return bool(worker.factors.given()) or bool(worker.periods)


# ---------------------------------------------------------------------------------- naming


@dataclass(frozen=True)
class Naming:
    """How the tracked people are reported (the module docstring's rules).

    reported: {tracked id: reported id}. members: {reported id: tracked ids, in tracker order}.
    display: {reported id: name shown} for names given as plain text in names.toml.
    stature: the stature matching of the people names.toml does not name.
    named: the tracked ids names.toml names.
    """

    reported: dict[str, str]
    members: dict[str, tuple[str, ...]]
    display: dict[str, str]
    stature: Identification
    named: frozenset[str] = frozenset()

    # the interface of ergopose.pipeline.identify.Identification, which the publishing stage uses
    def rename(self, tracked_id: str) -> str:
        return self.reported.get(tracked_id, tracked_id)

    def match_of(self, worker_id: str) -> Identity | None:
        return self.stature.match_of(worker_id)

    @property
    def notes(self) -> tuple[str, ...]:
        return self.stature.notes

    def groups(self) -> dict[int, int]:
        """{tracker number: number of the group's first member} for tracked ids scored together
        (empty when every tracked id is scored on its own)."""
        out = {}
        for ids in self.members.values():
            if len(ids) > 1:
                first = tracker_number(ids[0])
                out.update({tracker_number(t): first for t in ids})
        return out

    def session(self, session: Session) -> Session:
        """The session with the plain-text names as the reported workers' names (their task
        inputs stay those of the settings' table of the same id, if any)."""
        if not self.display:
            return session
        workers = list(session.workers)
        for wid, name in self.display.items():
            for k, w in enumerate(workers):
                if w.worker_id == wid:
                    workers[k] = dataclasses.replace(w, name=name)
                    break
            else:
                workers.append(WorkerInfo(worker_id=wid, name=name, factors=TaskFactors(), periods=()))
        return dataclasses.replace(session, workers=tuple(workers))


def resolve_naming(
    session: Session,
    tracked: Sequence[str],
    names: Mapping[str, str],
    measured: Mapping[str, float | None] | None = None,
) -> Naming:
    """The reported id of every tracked id (in ``tracked``; names of other ids are ignored)."""
    tracked = sorted(tracked, key=tracker_number)
    measured = dict(measured or {})
    reported: dict[str, str] = {}
    display: dict[str, str] = {}
    plain_first: dict[str, str] = {}
    for t in tracked:
        alias = names.get(t)
        if alias is None:
            continue
        key = settings_id(session, alias)
        if key is not None:
            reported[t] = key
        else:
            first = plain_first.setdefault(alias, t)
            reported[t] = first
            display[first] = alias
    named_ids = set(reported.values())
    rest = [t for t in tracked if t not in reported]
    stature_session = dataclasses.replace(
        session, workers=tuple(w for w in session.workers if w.worker_id not in named_ids)
    )
    known = {t: float(v) for t in rest if (v := measured.get(t)) is not None}
    ident = identify_by_stature(known, stature_session)
    taken = set(named_ids)
    for t in rest:
        r = ident.rename(t)
        if r in taken:  # a name given to another tracked person
            r = f"{t}_unmatched"
        reported[t] = r
        taken.add(r)
    members: dict[str, list[str]] = {}
    for t in tracked:
        members.setdefault(reported[t], []).append(t)
    return Naming(
        reported=reported,
        members={k: tuple(v) for k, v in members.items()},
        display=display,
        stature=ident,
        named=frozenset(t for t in tracked if t in names),
    )


# ------------------------------------------------------------------ task inputs that reach nobody


def unreachable_task_inputs(session: Session, names: Mapping[str, str]) -> list[str]:
    """Before any work: the settings' workers with task inputs that no tracked person can be
    reported under (not a tracker pseudonym, not given by names.toml, not matched by stature)."""
    given = {settings_id(session, a) for a in names.values()}
    out = []
    for w in session.workers:
        if not has_task_inputs(w) or w.worker_id in given or PSEUDONYM.match(w.worker_id):
            continue
        if session.identification.by_stature and w.stature_m is not None:
            continue
        out.append(w.worker_id)
    return out


def unused_task_inputs(session: Session, reported_ids: Sequence[str]) -> list[str]:
    """After tracking: the settings' workers with task inputs that no reported worker has."""
    have = set(reported_ids)
    return [w.worker_id for w in session.workers if has_task_inputs(w) and w.worker_id not in have]


def unused_message(session: Session, ids: Sequence[str], *, tracked_ids: Sequence[str] = ()) -> str:
    """The warning naming settings ids whose task inputs are applied to nobody."""
    listing = ", ".join(f"[workers.{i}]" for i in ids)
    where = (
        f"; the tracked people are {', '.join(tracked_ids)}"
        if tracked_ids
        else " (the tracker calls the people it follows worker_1, worker_2, ...)"
    )
    example = tracked_ids[0] if tracked_ids else "worker_1"
    return (
        f"{session.settings_path.name}: the task inputs of {listing} are applied to nobody: no tracked person "
        f"has {'that id' if len(ids) == 1 else 'those ids'}{where}; list the tracked people with 'ergopose "
        f"workers --session {session.path}' and name them with 'ergopose workers --session {session.path} "
        f"--name {example}={ids[0]}'"
    )


# ------------------------------------------------------------------ tracked ids scored together


def merge_rows(rows: TrackFrames, groups: Mapping[int, int]) -> TrackFrames:
    """TrackFrames with the tracker numbers of ``groups`` replaced by their group's number; where
    two members of a group have a row in the same frame, the row whose joints more cameras saw is
    kept (ties: the earlier tracker number). Rows stay sorted by frame, then worker."""
    if not groups or len(rows) == 0:
        return rows
    old = np.asarray(rows.worker, dtype=np.int64)
    new = old.copy()
    for member, first in groups.items():
        new[old == member] = first
    seen = np.asarray(rows.views, dtype=np.int64).sum(axis=1)
    order = np.lexsort((old, -seen, new, np.asarray(rows.frame)))  # frame, group, most views, number
    f, g = np.asarray(rows.frame)[order], new[order]
    keep = np.ones(order.size, bool)
    keep[1:] = (f[1:] != f[:-1]) | (g[1:] != g[:-1])
    take = order[keep]
    fields: dict[str, Any] = {n: (v[take] if isinstance(v, np.ndarray) else v) for n, v in rows.__dict__.items()}
    fields["worker"] = new[take]
    return type(rows)(**fields)


__all__ = [
    "NAMES_FILE",
    "Naming",
    "load_names",
    "write_names",
    "parse_name_args",
    "resolve_naming",
    "settings_id",
    "unreachable_task_inputs",
    "unused_task_inputs",
    "unused_message",
    "merge_rows",
    "tracker_number",
    "names_path",
]
