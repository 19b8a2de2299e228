"""Where an assessment keeps its intermediate results, so an interrupted run can resume.

Layout under the output folder::

    pipeline/manifest.json           what the results were computed from (the input fingerprint)
    pipeline/chunks/chunk_*.npz      one file per finished chunk of frames (2D -> 3D people)
    pipeline/tracks.parquet          the tracks table (written by the tracking stage)
    pipeline/scored/<worker>.parquet every scored frame of a tracked worker (posture in radians and
                                     every score column; written by the scoring stage, read back
                                     for the report's worst moments)
    pipeline/lock                    held (flock) by the one run writing to this folder

Every file is written under a temporary name and renamed when complete, so a killed process
leaves either a whole chunk file or none. A chunk file that cannot be read is computed again.
When the inputs change (videos, calibration, settings, models, ergopose version, chunk size),
the fingerprint changes and the earlier chunks are not reused.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import zipfile
from pathlib import Path
from typing import Any, Iterable, Iterator

import numpy as np

from ergopose import __version__
from ergopose.atomic import atomic_path, clean_up, write_text
from ergopose.errors import InputError
from ergopose.pipeline.detect import ChunkResult, people_from_arrays, people_to_arrays

FORMAT_VERSION = 2  # 2: People3D chunks carry every camera's 2D observations (the body fit)


def file_fingerprint(path: str | os.PathLike, sample_bytes: int = 1 << 20) -> str:
    """SHA-256 over a file's size and its first and last ``sample_bytes`` (cheap for large videos)."""
    path = Path(path)
    size = path.stat().st_size
    h = hashlib.sha256(str(size).encode())
    with path.open("rb") as f:
        h.update(f.read(sample_bytes))
        if size > 2 * sample_bytes:
            f.seek(size - sample_bytes)
            h.update(f.read(sample_bytes))
        elif size > sample_bytes:
            h.update(f.read())
    return h.hexdigest()


def fingerprint(parts: dict[str, Any]) -> str:
    """SHA-256 of a JSON-serialisable description of the inputs (keys sorted)."""
    text = json.dumps(parts, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


class ResultStore:
    """The results folder of one assessment."""

    def __init__(self, out_dir: str | os.PathLike):
        self.root = Path(out_dir) / "pipeline"
        self.chunks_dir = self.root / "chunks"
        self.manifest_path = self.root / "manifest.json"
        self.tracks_path = self.root / "tracks.parquet"

    @classmethod
    def at(cls, root: str | os.PathLike) -> "ResultStore":
        """The store whose root folder is ``root`` (as passed to worker processes)."""
        return cls(Path(root).parent)

    @contextlib.contextmanager
    def lock(self) -> Iterator[None]:
        """Hold the output folder for one run; a second run on the same folder fails at once.

        The lock (an advisory ``flock`` on ``pipeline/lock``) dies with its process, so a killed
        run never leaves the folder locked. While holding it, the temporary files a killed run
        left anywhere under the output folder are removed (:func:`ergopose.atomic.clean_up`).
        """
        self.root.mkdir(parents=True, exist_ok=True)
        with open(self.root / "lock", "a+b") as f:
            try:
                import fcntl
            except ImportError:  # not a POSIX system: no lock, the rest works the same
                fcntl = None
            if fcntl is not None:
                try:
                    fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
                except OSError:
                    raise InputError("another 'ergopose assess' is writing to this output folder; wait for it "
                                     "to finish or give another folder with --out", path=self.root.parent) from None
            clean_up(self.root.parent)
            try:
                yield
            finally:
                if fcntl is not None:
                    fcntl.flock(f.fileno(), fcntl.LOCK_UN)

    def open(self, inputs: dict[str, Any]) -> bool:
        """Prepare the store for inputs; True when earlier chunks of the same inputs are reused.

        A store made from other inputs is cleared of its chunk files (they cannot be reused).
        """
        manifest = {"format": FORMAT_VERSION, "ergopose": __version__, "fingerprint": fingerprint(inputs),
                    "inputs": inputs}
        old = self._read_manifest()
        reuse = old is not None and old.get("fingerprint") == manifest["fingerprint"] \
            and old.get("format") == FORMAT_VERSION
        self.chunks_dir.mkdir(parents=True, exist_ok=True)
        if not reuse:
            for p in self.chunks_dir.glob("chunk_*.npz"):
                p.unlink()
            write_text(self.manifest_path, json.dumps(manifest, indent=2, sort_keys=True, default=repr) + "\n")
        return reuse

    def _read_manifest(self) -> dict | None:
        try:
            return json.loads(self.manifest_path.read_text())
        except (OSError, ValueError):
            return None

    def chunk_path(self, start: int) -> Path:
        return self.chunks_dir / f"chunk_{start:09d}.npz"

    def save_chunk(self, result: ChunkResult) -> Path:
        final = self.chunk_path(result.start)
        arrays = people_to_arrays(result.people)
        with atomic_path(final) as tmp:
            with tmp.open("wb") as f:
                np.savez(f, start=result.start, stop=result.stop, detections=result.detections, **arrays)
        return final

    def load_chunk(self, start: int, stop: int) -> ChunkResult | None:
        """A finished chunk, or None if it is missing, unreadable or not for this range."""
        path = self.chunk_path(start)
        if not path.exists():
            return None
        try:
            with np.load(path, allow_pickle=False) as data:
                if int(data["start"]) != start or int(data["stop"]) != stop:
                    return None
                return ChunkResult(start, stop, people_from_arrays(data), np.asarray(data["detections"]))
        except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError):
            return None

    def finished(self, ranges: Iterable[tuple[int, int]]) -> set[int]:
        """Start frames of the chunks already stored for their range.

        Only each file's range is read (chunk files appear whole, by rename); the arrays are read
        once, by the tracking stage, which names a file it cannot read.
        """
        done = set()
        for start, stop in ranges:
            try:
                with np.load(self.chunk_path(start), allow_pickle=False) as data:
                    if int(data["start"]) == start and int(data["stop"]) == stop:
                        done.add(start)
            except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError):
                continue
        return done
