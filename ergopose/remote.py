"""Session videos given as fsspec URLs (``s3://bucket/day1/cam_1.mp4``, ``file:///mnt/...``, any
protocol fsspec opens): a local copy for OpenCV, which reads only files.

A video is copied whole, once per machine and URL (an MP4's index may sit at its end, so a
piece of the file is not a video OpenCV can open): into a temporary name beside its place in the
cache, its size checked against the remote file's, then renamed into place; a copy of the right
size already there is reused. Copies are removed by :func:`forget` (a cluster run does so on
every worker when a session is done) and, for the copies this process made, when it exits.

The cache folder is ``$ERGOPOSE_VIDEO_CACHE``, else ``<temp dir>/ergopose-videos``; a copy's
place is ``<cache>/<digest of URL and size>/<file name>``, so a changed remote file (another
size) gets another place. Every problem (no fsspec, unknown protocol, unreachable or missing
file, a copy cut short) is one :class:`~ergopose.errors.InputError` naming the URL.
"""

from __future__ import annotations

import atexit
import hashlib
import os
import re
import shutil
import tempfile
import uuid
from pathlib import Path
from typing import Iterable, Any

from ergopose.errors import InputError

#: A URL: a scheme (letters, digits, + . -) and "://".
_URL = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*://")
#: Environment variable naming the cache folder of video copies.
CACHE_ENV = "ERGOPOSE_VIDEO_CACHE"
_BLOCK = 8 << 20
_MADE: set[Path] = set()


def is_url(text: str) -> bool:
    """True for an fsspec URL (``scheme://...``); False for a file path."""
    return bool(_URL.match(str(text)))


def cache_dir() -> Path:
    """The folder of the video copies."""
    given = os.environ.get(CACHE_ENV)
    return Path(given) if given else Path(tempfile.gettempdir()) / "ergopose-videos"


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 200 else text[:197] + "..."


def _filesystem(url: str) -> tuple[Any, str]:
    try:
        import fsspec  # deferred: the optional extra "cluster", needed only for videos given as URLs
    except ImportError:
        raise InputError(
            "reading videos from URLs needs fsspec: install ergopose with the extra 'cluster'", path=url
        ) from None
    try:
        found: tuple[Any, str] = fsspec.core.url_to_fs(url)  # (filesystem, path inside it)
        return found
    except (ImportError, ValueError) as exc:  # unknown protocol, or its package missing (s3fs for s3://)
        raise InputError(f"cannot open this URL ({_one_line(exc)})", path=url) from None


def remote_size(url: str) -> int:
    """The size in bytes of the file at ``url``; InputError if it cannot be reached or is no file."""
    fs, path = _filesystem(url)
    try:
        info = fs.info(path)
    except FileNotFoundError:
        raise InputError("video file not found", path=url) from None
    except Exception as exc:  # network, permission, credentials: what the filesystem says, on one line
        raise InputError(f"cannot reach the video ({_one_line(exc)})", path=url) from None
    size = info.get("size")
    if info.get("type") == "directory" or size is None:
        raise InputError("not a video file (a folder, or of unknown size)", path=url)
    return int(size)


def cached_path(url: str, size: int) -> Path:
    """Where the copy of ``url`` (of ``size`` bytes) is kept on this machine."""
    digest = hashlib.sha256(f"{url}\n{int(size)}".encode()).hexdigest()[:16]
    name = url.rstrip("/").rsplit("/", 1)[-1] or "video"
    return cache_dir() / digest / name


def fetch(url: str, dest: str | os.PathLike[str] | None = None, *, size: int | None = None) -> Path:
    """A local copy of the video at ``url``: ``dest`` (default :func:`cached_path`), copied whole
    unless a file of the remote size is there already. ``size``: the size the caller saw before
    (a worker is given the client's): another size now is an InputError (the video changed)."""
    actual = remote_size(url)
    if size is not None and actual != int(size):
        raise InputError(
            f"the video changed during the run (now {actual} bytes, {int(size)} when the run started)", path=url
        )
    target = Path(dest) if dest is not None else cached_path(url, actual)
    if target.is_file() and target.stat().st_size == actual:
        return target
    fs, path = _filesystem(url)
    part = target.with_name(f".{target.name}.{uuid.uuid4().hex}.part")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        with fs.open(path, "rb") as src, open(part, "wb") as out:
            shutil.copyfileobj(src, out, _BLOCK)
        got = part.stat().st_size
        if got != actual:
            raise InputError(f"the copy stopped at {got} of {actual} bytes", path=url)
        os.replace(part, target)
    except InputError:
        raise
    except Exception as exc:
        raise InputError(f"cannot copy the video to {target.parent} ({_one_line(exc)})", path=url) from None
    finally:
        part.unlink(missing_ok=True)
    _MADE.add(target.resolve())
    return target


def forget(paths: Iterable[str | os.PathLike[str]]) -> int:
    """Remove these copies (and their folders once empty); the number removed. Paths outside the
    cache folder are left alone."""
    root = cache_dir().resolve()
    removed = 0
    for p in map(Path, paths):
        try:
            p = p.resolve()
            if root not in p.parents:
                continue
            p.unlink()
            removed += 1
            p.parent.rmdir()
        except OSError:
            pass
        _MADE.discard(p)
    return removed


@atexit.register
def _forget_made() -> None:
    forget(list(_MADE))


__all__ = ["CACHE_ENV", "is_url", "cache_dir", "remote_size", "cached_path", "fetch", "forget"]
