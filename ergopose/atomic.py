"""Atomic file output: write to a temporary name in the same folder, then rename.

A crash never leaves half a file under the final name, and an earlier result under that
name stays intact until the new one is complete.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterator


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _ordinary_mode(path: Path, directory: bool) -> None:
    """Give a temporary file or folder the permissions a normally created one would have.

    mkstemp/mkdtemp make them private (0600/0700); reports and CSV files are meant to be opened
    by others (a shared drive), so the user's umask decides, as for any new file.
    """
    os.chmod(path, (0o777 if directory else 0o666) & ~_umask())


def readable(path: str | os.PathLike[str]) -> None:
    """Give a written file (or folder) the permissions the user's umask allows for new files.

    Atomic writing goes through temporary files that are private (0600, folders 0700); reports
    are meant to be opened by others from a shared drive.
    """
    p = Path(path)
    _ordinary_mode(p, p.is_dir())


@contextlib.contextmanager
def atomic_path(final: str | os.PathLike[str], suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``final``; rename it to ``final`` if the block succeeds.

    The temporary name keeps the final suffix (some writers choose the format from it).
    """
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    suffix = final.suffix if suffix is None else suffix
    fd, tmp = tempfile.mkstemp(prefix=f".{final.stem}.", suffix=f".tmp{suffix}", dir=final.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    _ordinary_mode(tmp_path, directory=False)
    try:
        yield tmp_path
        os.replace(tmp_path, final)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        raise


def write_text(final: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> Path:
    """Write text atomically and return the final path."""
    with atomic_path(final) as tmp:
        tmp.write_text(text, encoding=encoding)
    return Path(final)


def write_bytes(final: str | os.PathLike[str], data: bytes) -> Path:
    """Write bytes atomically and return the final path."""
    with atomic_path(final) as tmp:
        tmp.write_bytes(data)
    return Path(final)


@contextlib.contextmanager
def atomic_dir(final: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary folder beside ``final``; swap it into place if the block succeeds.

    An existing folder under ``final`` is replaced only after the new one is complete.
    """
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".tmp", dir=final.parent))
    _ordinary_mode(tmp, directory=True)
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    old = None
    if final.exists():
        old = final.with_name(f".{final.name}.old")
        shutil.rmtree(old, ignore_errors=True)
        os.replace(final, old)
    os.replace(tmp, final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def _remove(path: Path) -> None:
    """Remove a file, link or folder (and what it holds); gone already is fine."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


def _made_here(name: str) -> bool:
    """Whether a file or folder name is one this module makes (".<name>.<random>.tmp<suffix>")."""
    return name.startswith(".") and ".tmp" in name


def clean_up(folder: str | os.PathLike[str]) -> list[Path]:
    """Tidy what a killed process left in ``folder`` and below; return what was removed.

    A process killed while writing (SIGKILL, a power cut) cannot remove its temporary files and
    folders. This removes them, and puts back a folder that :func:`atomic_dir` had moved aside
    (``.<name>.old``) but not yet replaced. Call it only while no other process writes there.
    """
    folder = Path(folder)
    if not folder.is_dir():
        return []
    removed = []
    for path in sorted(folder.rglob(".*"), key=lambda p: len(p.parts)):
        if not os.path.lexists(path):
            continue  # inside a folder removed a moment ago
        name = path.name
        if name.endswith(".old") and path.is_dir():
            final = path.with_name(name[1 : -len(".old")])
            if not final.exists():
                os.replace(path, final)
                continue
        elif not _made_here(name):
            continue
        _remove(path)
        removed.append(path)
    return removed


def clean_up_beside(final: str | os.PathLike[str]) -> list[Path]:
    """Tidy what a killed writer of ``final`` left beside it; return what was removed.

    Only the names :func:`atomic_path` and :func:`atomic_dir` make for ``final`` are touched
    (``.<stem>.<random>.tmp<suffix>``, ``.<name>.<random>.tmp``, and ``.<name>.old``, which is put
    back when ``final`` is missing): the rest of the folder, someone else's, is left alone. Call it
    only while no other process writes ``final``.
    """
    final = Path(final)
    parent = final.parent
    if not parent.is_dir():
        return []
    removed = []
    for path in sorted(parent.iterdir()):
        name = path.name
        if name == f".{final.name}.old" and path.is_dir() and not final.exists():
            os.replace(path, final)
            continue
        ours = (
            name == f".{final.name}.old"
            or (name.startswith(f".{final.name}.") and name.endswith(".tmp"))
            or (name.startswith(f".{final.stem}.") and name.endswith(f".tmp{final.suffix}"))
        )
        if not ours:
            continue
        _remove(path)
        removed.append(path)
    return removed
