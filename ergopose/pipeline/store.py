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
leaves either a whole chunk file or none. Each chunk file also carries the fingerprint of the
inputs it was computed from and a SHA-256 checksum of its arrays: a chunk that cannot be read or
fails its checksum (a disk fault, a file cut short by copying) is named, removed and computed
again, and only that chunk. When the inputs change (videos, calibration, settings, models,
ergopose version, chunk size), the fingerprint changes and the earlier chunks are not reused.
The manifest only records the inputs for people to read: a damaged manifest costs no chunk.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import zipfile
from pathlib import Path
from types import ModuleType
from typing import Any, Iterable, Iterator

import numpy as np

from ergopose import __version__
from ergopose.atomic import atomic_path, clean_up, write_text
from ergopose.errors import InputError
from ergopose.pipeline.detect import ChunkResult, people_from_arrays, people_to_arrays
from ergopose.progress import ProgressCallback, warn

#: 2: chunk files carry the inputs' fingerprint and a checksum (version 1 chunks are computed again);
#: 3: People3D chunks carry every camera's 2D observations (the body fit);
#: 4: and every person's clothing colour (the tracker's appearance signature).
FORMAT_VERSION = 4

#: Members of a chunk file besides the People3D arrays.
_CHECKSUM = "sha256"
_INPUTS = "inputs"


def file_fingerprint(path: str | os.PathLike[str], sample_bytes: int = 1 << 20) -> str:
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


def arrays_checksum(arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 over named arrays (sorted by name): each name, dtype, shape and bytes."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    return h.hexdigest()


class DamagedPiece(Exception):
    """A stored piece that cannot be read or fails its checksum (message: what is wrong)."""


class ResultStore:
    """The results folder of one assessment."""

    def __init__(self, out_dir: str | os.PathLike[str]):
        self.root = Path(out_dir) / "pipeline"
        self.chunks_dir = self.root / "chunks"
        self.manifest_path = self.root / "manifest.json"
        self.tracks_path = self.root / "tracks.parquet"
        self.inputs_fingerprint: str | None = None
        #: (file, what was wrong) of every damaged chunk found and removed by this store object
        self.damaged: list[tuple[Path, str]] = []

    @classmethod
    def at(cls, root: str | os.PathLike[str]) -> "ResultStore":
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
            fcntl: ModuleType | None
            try:
                import fcntl
            except ImportError:  # not a POSIX system: no lock, the rest works the same
                fcntl = None
            if fcntl is not None:
                try:
                    fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
                except OSError:
                    raise InputError(
                        "another 'ergopose assess' is writing to this output folder; wait for it "
                        "to finish or give another folder with --out",
                        path=self.root.parent,
                    ) from None
            clean_up(self.root.parent)
            try:
                yield
            finally:
                if fcntl is not None:
                    fcntl.flock(f.fileno(), fcntl.LOCK_UN)

    def open(self, inputs: dict[str, Any]) -> bool:
        """Prepare the store for inputs; True when the manifest says earlier chunks are of the same inputs.

        Chunk files of other inputs are removed when :meth:`finished` meets them (each carries the
        fingerprint of its inputs), so a damaged or missing manifest costs nothing.
        """
        self.inputs_fingerprint = fingerprint(inputs)
        manifest = {
            "format": FORMAT_VERSION,
            "ergopose": __version__,
            "fingerprint": self.inputs_fingerprint,
            "inputs": inputs,
        }
        old = self._read_manifest()
        reuse = (
            old is not None
            and old.get("fingerprint") == manifest["fingerprint"]
            and old.get("format") == FORMAT_VERSION
        )
        self.chunks_dir.mkdir(parents=True, exist_ok=True)
        if old != json.loads(json.dumps(manifest, sort_keys=True, default=repr)):
            write_text(self.manifest_path, json.dumps(manifest, indent=2, sort_keys=True, default=repr) + "\n")
        return reuse

    def _read_manifest(self) -> dict[str, Any] | None:
        try:
            manifest: dict[str, Any] = json.loads(self.manifest_path.read_text())
            return manifest
        except (OSError, ValueError):
            return None

    def chunk_path(self, start: int) -> Path:
        return self.chunks_dir / f"chunk_{start:09d}.npz"

    def _fingerprint(self) -> str:
        """The inputs' fingerprint: set by :meth:`open`, or read from the manifest (worker processes)."""
        if self.inputs_fingerprint is None:
            manifest = self._read_manifest()
            if manifest is None or not isinstance(manifest.get("fingerprint"), str):
                raise RuntimeError(f"{self.manifest_path}: the store was not opened for these inputs")
            self.inputs_fingerprint = manifest["fingerprint"]
        return self.inputs_fingerprint

    def save_chunk(self, result: ChunkResult) -> Path:
        final = self.chunk_path(result.start)
        arrays = people_to_arrays(result.people)
        arrays.update(
            start=np.array(result.start, dtype=np.int64),
            stop=np.array(result.stop, dtype=np.int64),
            detections=np.asarray(result.detections),
            **{_INPUTS: np.array(self._fingerprint())},
        )
        arrays[_CHECKSUM] = np.array(arrays_checksum(arrays))
        with atomic_path(final) as tmp:
            with tmp.open("wb") as f:
                # numpy's stubs: a **dict might name savez's allow_pickle (these names never do)
                np.savez(f, **arrays)  # type: ignore[arg-type]
        return final

    def read_chunk(self, start: int, stop: int) -> ChunkResult | None:
        """The stored chunk of frames start .. stop-1 of these inputs; None if there is none (no file,
        or one of other inputs or another range). DamagedPiece if the file cannot be read or fails
        its checksum."""
        path = self.chunk_path(start)
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {name: data[name] for name in data.files}
        except FileNotFoundError:
            return None
        except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as exc:
            raise DamagedPiece(f"cannot be read ({type(exc).__name__}: {exc})") from None
        stored = arrays.pop(_CHECKSUM, None)
        if stored is None:
            return None  # an earlier format: computed again, as for changed inputs
        if str(stored) != arrays_checksum(arrays):
            raise DamagedPiece("fails its checksum (the file was changed or damaged after it was written)")
        if str(arrays.get(_INPUTS)) != self._fingerprint():
            return None
        try:
            if int(arrays["start"]) != start or int(arrays["stop"]) != stop:
                return None
            return ChunkResult(start, stop, people_from_arrays(arrays), np.asarray(arrays["detections"]))
        except (KeyError, ValueError, TypeError) as exc:
            raise DamagedPiece(f"does not hold a chunk of people ({type(exc).__name__}: {exc})") from None

    def _drop_damaged(self, start: int, problem: str) -> None:
        path = self.chunk_path(start)
        with contextlib.suppress(FileNotFoundError):
            path.unlink()
        self.damaged.append((path, problem))

    def load_chunk(self, start: int, stop: int) -> ChunkResult | None:
        """A finished chunk, or None if it is missing, of other inputs, or damaged (a damaged file is
        removed, so the next run computes it again, and listed in :attr:`damaged`)."""
        try:
            return self.read_chunk(start, stop)
        except DamagedPiece as exc:
            self._drop_damaged(start, str(exc))
            return None

    def finished(self, ranges: Iterable[tuple[int, int]], progress: ProgressCallback | None = None) -> set[int]:
        """Start frames of the chunks already stored, whole and of these inputs, for their range.

        Every stored chunk is read and its checksum checked. A damaged one is named (a warning
        through ``progress``), removed and left out, so it is computed again in this run; a chunk
        of other inputs or of another range is removed.
        """
        ranges = list(ranges)
        done = set()
        for start, stop in ranges:
            path = self.chunk_path(start)
            try:
                chunk = self.read_chunk(start, stop)
            except DamagedPiece as exc:
                self._drop_damaged(start, str(exc))
                warn(progress, f"{path}: the stored piece {exc}; it is computed again")
                continue
            if chunk is not None:
                done.add(start)
            else:
                with contextlib.suppress(FileNotFoundError):
                    path.unlink()
        wanted = {self.chunk_path(start).name for start, _ in ranges}
        for p in self.chunks_dir.glob("chunk_*.npz"):
            if p.name not in wanted:  # another chunk length or session length
                p.unlink()
        return done
