"""Checks that keep an assessment's work and earlier results safe.

* :func:`check_output_folder` before any video is read: the output folder is a folder (or can be
  made), can be written, and (:func:`check_room`) its disk has room for the estimated output.
* :func:`output_faults` while the run writes: a full disk or a read-only folder met mid-run ends
  the run with one line (every piece finished before stays, ergopose.atomic).
* The session fingerprint (:func:`session_fingerprint`): which recording results belong to. It is
  the SHA-256 of the calibration file's and each camera video's content fingerprint
  (:func:`ergopose.pipeline.store.file_fingerprint`: size, first and last MiB), in the session's
  camera order. File names, folder names, modification times and settings are not part of it:
  a copied or renamed session is the same recording, and changed task factors or worker names
  are a new assessment of the same recording. :func:`results_owner` reads it back from a report
  folder (``results/session.json`` or ``pipeline/manifest.json``); :func:`check_results_session`
  refuses results of another recording unless forced.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, Sequence

from ergopose.errors import OutputError, output_error, output_reason
from ergopose.pipeline.store import file_fingerprint
from ergopose.progress import ProgressCallback, warn
from ergopose.recon.table import read_metadata
from ergopose.report.results import RESULTS_DIR, SESSION_FILE
from ergopose.session import Session

#: Bytes an assessment stores per tracked person and frame, measured (docs/assess.md, "Room on
#: disk"): the chunk store (real 2D work: 3.7 kB), and tracks, scored frames, CSV files and
#: stored results together (2.0 kB; a simulated 10-minute two-worker shift).
CHUNK_BYTES_PER_PERSON_FRAME = 3700
AFTER_BYTES_PER_PERSON_FRAME = 2000
#: Pages, summaries and the other files of fixed size, and a margin for the file system.
FIXED_BYTES = 20_000_000


# ------------------------------------------------------------------------------ output folder


def _existing_ancestor(path: Path) -> Path:
    p = path.absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def check_output_folder(out_dir: str | os.PathLike[str]) -> None:
    """OutputError unless ``out_dir`` is a folder that can be written (or can be made where it is)."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise OutputError(
            "--out names a file, not a folder; give a folder for the report (it is made if missing)", path=out
        )
    base = _existing_ancestor(out)
    if not base.is_dir():
        raise OutputError(f"cannot make the output folder here: {base} is a file, not a folder", path=out)
    try:  # a real write: permissions, read-only mounts and ACLs all show here (os.access can be wrong)
        fd, probe = tempfile.mkstemp(prefix=".write-check.", suffix=".tmp", dir=base)
        try:
            os.write(fd, b"ergopose")
        finally:
            os.close(fd)
            os.unlink(probe)
    except OSError as exc:
        what = output_reason(exc)
        if what is None:
            raise
        where = "cannot be written" if base == out.absolute() else f"cannot be made in {base}"
        raise OutputError(
            f"the output folder {where} ({what}); give a folder you can write to with --out", path=out
        ) from None


def estimate_output_bytes(frames: int, people: int, chunk_bytes_stored: int = 0) -> int:
    """Bytes an assessment of ``frames`` frames with ``people`` tracked persons still needs on disk.

    chunk_bytes_stored: bytes of chunk files already stored (a resumed run). The tracks table,
    scored frames and results are counted twice: a new one is complete before the old one goes.
    """
    chunks = max(0, frames * people * CHUNK_BYTES_PER_PERSON_FRAME - chunk_bytes_stored)
    return int(chunks + 2 * frames * people * AFTER_BYTES_PER_PERSON_FRAME + FIXED_BYTES)


def check_room(out_dir: str | os.PathLike[str], need_bytes: int) -> None:
    """OutputError if the disk of ``out_dir`` has less free space than ``need_bytes``."""
    base = _existing_ancestor(Path(out_dir))
    free = shutil.disk_usage(base).free
    if free < need_bytes:
        raise OutputError(
            f"not enough room on the disk: this assessment needs about {_size(need_bytes)} and "
            f"{_size(free)} is free; make room or give a folder on another disk with --out",
            path=out_dir,
        )


def _size(n: float) -> str:
    for unit, scale in (("GB", 1e9), ("MB", 1e6)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{n / 1e3:.0f} kB"


def stored_chunk_bytes(out_dir: str | os.PathLike[str]) -> int:
    """Bytes of the chunk files already in an output folder (a run to be resumed)."""
    chunks = Path(out_dir) / "pipeline" / "chunks"
    if not chunks.is_dir():
        return 0
    return sum(p.stat().st_size for p in chunks.glob("chunk_*.npz"))


@contextlib.contextmanager
def output_faults(out_dir: str | os.PathLike[str]) -> Iterator[None]:
    """Turn a full disk, a read-only file system or a refused write met while writing the
    output into one OutputError (naming the file when known, else the output folder)."""
    try:
        yield
    except OSError as exc:
        err = output_error(exc)
        if err is None:
            raise
        if exc.filename is None:
            raise type(err)(err.args[0], path=out_dir) from None
        raise err from None


def check_before_work(out_dir: Path, session: Session, force: bool, progress: ProgressCallback | None = None) -> None:
    """Everything checked about the output folder before the work starts: a writable folder, room
    for the estimated output, and no results of another recording in it (unless ``force``)."""
    check_output_folder(out_dir)
    people = max(2, len(session.workers))
    check_room(out_dir, estimate_output_bytes(int(session.frame_count), people, stored_chunk_bytes(out_dir)))
    check_results_session(
        out_dir,
        session,
        force,
        progress=progress,
        advice="give another folder with --out, or add --force to replace them",
    )


# ------------------------------------------------------------------------- session fingerprint


def session_fingerprint(calibration_fingerprint: str, video_fingerprints: Sequence[str]) -> str:
    """The fingerprint of a recording from its files' content fingerprints (module docstring)."""
    text = json.dumps({"calibration": calibration_fingerprint, "videos": list(video_fingerprints)})
    return hashlib.sha256(text.encode()).hexdigest()


def fingerprint_of(session: Session) -> str:
    """The fingerprint of a loaded session (:class:`ergopose.session.Session`)."""
    return session_fingerprint(
        file_fingerprint(session.calibration_path), [file_fingerprint(c.video_path) for c in session.cameras]
    )


@dataclass(frozen=True)
class ResultsOwner:
    """Whose results a report folder holds: the session fingerprint (None for results written
    before fingerprints), the session id (folder name) and the frame count when known."""

    fingerprint: str | None
    session_id: str | None
    frames: int | None
    source: Path

    def describe(self) -> str:
        parts = [f"session {self.session_id!r}" if self.session_id else "an unnamed session"]
        if self.frames is not None:
            parts.append(f"{self.frames} frames")
        if self.fingerprint:
            parts.append(f"fingerprint {self.fingerprint[:12]}")
        return ", ".join(parts)


def results_owner(out_dir: str | os.PathLike[str]) -> ResultsOwner | None:
    """Whose results ``out_dir`` holds, or None when it holds none (no readable record of them).

    Read from the stored results (results/session.json), else the pose stage's manifest
    (pipeline/manifest.json: the content fingerprints of the calibration and videos), else a
    tracks table's metadata (an ORACLE run's folder)."""
    out = Path(out_dir)
    path = out / RESULTS_DIR / SESSION_FILE
    with contextlib.suppress(OSError, ValueError, AttributeError, TypeError):
        data = json.loads(path.read_text(encoding="utf-8"))["data"]
        frames = data.get("frames")
        return ResultsOwner(
            data.get("fingerprint"), data.get("session_id"), int(frames) if frames is not None else None, path
        )
    path = out / "pipeline" / "manifest.json"
    with contextlib.suppress(OSError, ValueError, AttributeError, TypeError, KeyError):
        manifest = json.loads(path.read_text(encoding="utf-8"))
        inputs = manifest["inputs"]
        if "calibration" in inputs and "videos" in inputs:  # the inputs hold the files' content fingerprints
            fp = manifest.get("session") or session_fingerprint(inputs["calibration"], inputs["videos"])
            return ResultsOwner(fp, None, int(inputs["frames"]) if "frames" in inputs else None, path)
    for path in sorted((out / "pipeline").glob("*tracks.parquet")):  # an ORACLE run's folder
        with contextlib.suppress(Exception):  # an unreadable table tells nothing about its owner
            fp = read_metadata(path).get("session_fingerprint")
            if isinstance(fp, str):
                return ResultsOwner(fp, None, None, path)
    return None


def foreign_results(out_dir: str | os.PathLike[str], session: Session, fingerprint: str) -> ResultsOwner | None:
    """The owner of the results in ``out_dir`` if they are of another recording than ``session``
    (with fingerprint ``fingerprint``); None if there are none or they are of this one.

    Results written before fingerprints existed are judged by session name and frame count.
    """
    owner = results_owner(out_dir)
    if owner is None:
        return None
    if owner.fingerprint is not None:
        return None if owner.fingerprint == fingerprint else owner
    same_name = owner.session_id in (None, Path(session.path).resolve().name)
    same_length = owner.frames in (None, int(session.frame_count))
    return None if same_name and same_length else owner


def check_results_session(
    out_dir: str | os.PathLike[str],
    session: Session,
    force: bool,
    *,
    advice: str,
    progress: ProgressCallback | None = None,
) -> None:
    """OutputError if ``out_dir`` holds results of another recording than ``session``, unless
    ``force``; then a warning says so. ``advice``: what the user can do instead (the message
    adds "or add --force to ...")."""
    fingerprint = fingerprint_of(session)
    owner = foreign_results(out_dir, session, fingerprint)
    if owner is None:
        return
    if not force:
        raise OutputError(
            f"holds the results of another recording ({owner.describe()}), not of {session.path} "
            f"(fingerprint {fingerprint[:12]}); {advice}",
            path=out_dir,
        )
    warn(
        progress, f"{out_dir} holds the results of another recording ({owner.describe()}); going on because of --force"
    )


__all__ = [
    "check_before_work",
    "check_output_folder",
    "check_room",
    "estimate_output_bytes",
    "stored_chunk_bytes",
    "output_faults",
    "session_fingerprint",
    "fingerprint_of",
    "ResultsOwner",
    "results_owner",
    "foreign_results",
    "check_results_session",
]
