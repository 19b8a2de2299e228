"""Fault injection on a real assessment of the tiny simulated session: a bad output folder, a
full disk, damaged stored pieces, results of another recording, unreadable video frames.

Each case checks the one line the user sees, the exit code, and that what was there before is
byte-identical afterwards (or, where the run repairs it, that the CSV files equal those of an
uninterrupted run). Killing the run at random moments is in test_assess.py.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from ergopose import cli
from tests.pipeline.helpers import assess_args, csv_bytes, user_lines


def _files(folder: Path) -> dict[Path, bytes]:
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _copy(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


def _run(capsys, *args) -> tuple[int, str, list[str]]:
    """ergopose in this process: exit code, stdout, the user's lines of stderr."""
    capsys.readouterr()
    code = cli.main([str(a) for a in args])
    captured = capsys.readouterr()
    return code, captured.out, user_lines(captured.err)


def _one_error(lines: list[str], *words: str) -> str:
    assert len(lines) == 1 and lines[0].startswith("ergopose: error:"), lines
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert "Traceback" not in lines[0]
    return lines[0]


@pytest.fixture
def model_dir(fetched_model_dir):
    return fetched_model_dir[0]


# ------------------------------------------------------------------------------ output folder


@pytest.mark.slow
def test_out_naming_a_file_or_a_folder_below_a_file(tiny_session, model_dir, tmp_path, capsys):
    a_file = tmp_path / "notes.txt"
    a_file.write_text("keep me\n")
    code, _, lines = _run(capsys, *assess_args(tiny_session, a_file, model_dir))
    assert code == 2
    _one_error(lines, str(a_file), "names a file, not a folder")
    code, _, lines = _run(capsys, *assess_args(tiny_session, a_file / "report", model_dir))
    assert code == 2
    _one_error(lines, "notes.txt is a file")
    assert a_file.read_text() == "keep me\n" and sorted(tmp_path.iterdir()) == [a_file]


@pytest.mark.skipif(
    hasattr(os, "geteuid") and os.geteuid() == 0,
    reason="root writes into read-only folders; the injected read-only file system below covers it",
)
def test_read_only_output_folder(reference, tiny_session, model_dir, tmp_path, capsys):
    out = _copy(reference[0], tmp_path / "report")
    before = _files(out)
    out.chmod(0o555)
    try:
        code, _, lines = _run(capsys, *assess_args(tiny_session, out, model_dir))
    finally:
        out.chmod(0o755)
    assert code == 2
    _one_error(lines, str(out), "cannot be written", "--out")
    assert _files(out) == before


@pytest.mark.slow
def test_read_only_file_system(reference, tiny_session, model_dir, tmp_path, capsys, monkeypatch):
    """A folder on a read-only mount (EROFS on every new file there, injected): one line, and the
    earlier results are untouched."""
    import tempfile

    out = _copy(reference[0], tmp_path / "report")
    before = _files(out)
    real_mkstemp = tempfile.mkstemp

    def mkstemp(*args, dir=None, **kwargs):
        if dir is not None and Path(dir).resolve().is_relative_to(out.resolve()):
            raise OSError(errno.EROFS, "Read-only file system", str(dir))
        return real_mkstemp(*args, dir=dir, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
    code, _, lines = _run(capsys, *assess_args(tiny_session, out, model_dir))
    assert code == 2
    _one_error(lines, str(out), "read-only", "--out")
    assert _files(out) == before


@pytest.mark.slow
def test_no_room_is_found_before_any_work(tiny_session, model_dir, tmp_path, capsys, monkeypatch):
    import collections

    from ergopose.pipeline import detect, guard

    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(guard.shutil, "disk_usage", lambda path: usage(10**9, 10**9 - 5 * 10**6, 5 * 10**6))
    monkeypatch.setattr(detect, "detect_chunk", lambda *a, **k: pytest.fail("video work started"))
    out = tmp_path / "report"
    code, _, lines = _run(capsys, *assess_args(tiny_session, out, model_dir, "--processes", 1))
    assert code == 2
    _one_error(lines, "not enough room", "5.0 MB is free", "--out")
    assert not out.exists() or not list(out.rglob("*.npz"))


# ----------------------------------------------------------------------------------- full disk


def _enospc_on_chunk(monkeypatch, after: int) -> list[int]:
    """Writing the chunk file after ``after`` whole ones fails half-way with ENOSPC (as np.savez
    meets a full disk); returns the list of chunks written."""
    from ergopose.pipeline import store

    real = store.np.savez
    written = []

    def savez(f, **arrays):
        if len(written) >= after:
            f.write(b"PK\x03\x04 half a chunk")
            raise OSError(errno.ENOSPC, "No space left on device")
        real(f, **arrays)
        written.append(int(arrays["start"]))

    monkeypatch.setattr(store.np, "savez", savez)
    return written


def _chunks(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "pipeline" / "chunks").glob("*"))}


@pytest.mark.slow
def test_full_disk_while_storing_chunks_keeps_the_finished_ones(
    reference, tiny_session, model_dir, tmp_path, capsys, monkeypatch
):
    ref_out, expected = reference
    out = tmp_path / "report"
    written = _enospc_on_chunk(monkeypatch, after=2)
    code, _, lines = _run(capsys, *assess_args(tiny_session, out, model_dir, "--processes", 1))
    assert code == 2
    _one_error(lines, str(out), "the disk is full", "run the same command again")
    kept = _chunks(out)
    assert sorted(kept) == [f"chunk_{s:09d}.npz" for s in written] and len(kept) == 2  # no half file, no temp file
    ref_chunks = _chunks(ref_out)
    assert all(kept[name] == ref_chunks[name] for name in kept)  # whole, the bytes of an uninterrupted run
    monkeypatch.undo()
    code, stdout, lines = _run(capsys, *assess_args(tiny_session, out, model_dir, "--processes", 1))
    assert code == 0, lines
    assert "2 of 6 chunks reused" in stdout
    assert csv_bytes(out) == expected


@pytest.mark.slow
def test_full_disk_while_writing_csv_files_keeps_the_earlier_results(
    reference, tiny_session, model_dir, tmp_path, capsys, monkeypatch
):
    """ENOSPC in the middle of the per-frame CSV files of a second run over finished results: every
    earlier file keeps its bytes (new ones replace them only when complete)."""
    from ergopose.ergonomics import export

    out = _copy(reference[0], tmp_path / "report")
    before = _files(out)
    real = export.FramesCsvWriter.write
    calls = []

    def write(self, frames):
        calls.append(1)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, frames)

    monkeypatch.setattr(export.FramesCsvWriter, "write", write)
    code, _, lines = _run(capsys, *assess_args(tiny_session, out, model_dir, "--processes", 1))
    assert code == 2
    _one_error(lines, "the disk is full")
    assert _files(out) == before


def _mount_tmpfs(path: Path, size: str) -> None:
    path.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)], capture_output=True, text=True
    )
    if done.returncode != 0:
        pytest.skip(
            f"a small tmpfs cannot be mounted here ({done.stderr.strip() or 'mount failed'}); "
            "the injected ENOSPC tests cover a full disk"
        )


@pytest.mark.slow
@pytest.mark.skipif(
    not (hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("mount")),
    reason="mounting a small tmpfs needs root; the injected ENOSPC tests cover a full disk",
)
def test_a_really_full_disk_then_more_room(reference, tiny_session, model_dir, tmp_path, capsys, monkeypatch):
    """A 400 kB tmpfs (the room check told to let it through): the chunks fit, the later files do
    not; one line, the chunks kept, and after the disk grows the run resumes to the same CSVs."""
    from ergopose.pipeline import guard

    _, expected = reference
    mnt = tmp_path / "small"
    _mount_tmpfs(mnt, "400k")
    try:
        monkeypatch.setattr(guard, "check_room", lambda out_dir, need: None)
        out = mnt / "report"
        code, _, lines = _run(capsys, *assess_args(tiny_session, out, model_dir, "--processes", 1))
        assert code == 2
        _one_error(lines, "the disk is full")
        chunks = _chunks(out)
        assert chunks and not [p for p in out.rglob("*") if ".tmp" in p.name]
        subprocess.run(["mount", "-o", "remount,size=8m", str(mnt)], check=True)
        code, stdout, lines = _run(capsys, *assess_args(tiny_session, out, model_dir, "--processes", 1))
        assert code == 0, lines
        assert f"{len(chunks)} of 6 chunks reused" in stdout
        assert csv_bytes(out) == expected
    finally:
        subprocess.run(["umount", str(mnt)], check=False)


# ------------------------------------------------------------------------------- damaged pieces


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _flip_a_byte(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))


def _change_an_array(path: Path) -> None:
    """A whole, readable chunk file whose points were changed after it was written."""
    with np.load(path, allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    name = next(n for n in arrays if arrays[n].dtype.kind == "f" and arrays[n].size)
    arrays[name] = arrays[name] + 0.01
    with path.open("wb") as f:
        np.savez(f, **arrays)


CHUNK = "pipeline/chunks/chunk_000000012.npz"


@pytest.mark.slow
@pytest.mark.parametrize(
    "where, damage, message",
    [
        (CHUNK, _truncate, "cannot be read"),
        (CHUNK, _flip_a_byte, "cannot be read"),
        (CHUNK, _change_an_array, "fails its checksum"),
        ("pipeline/manifest.json", _truncate, None),
        ("pipeline/tracks.parquet", _truncate, None),
        ("pipeline/scored/worker_1.parquet", _truncate, None),
        ("results/session.json", _truncate, None),
        ("results/workers/worker_1/frames.parquet", _truncate, None),
        ("csv/worker_1_frames.csv", _truncate, None),
        ("index.html", _truncate, None),
    ],
    ids=[
        "chunk-cut",
        "chunk-byte",
        "chunk-checksum",
        "manifest",
        "tracks",
        "scored",
        "results-json",
        "results-frames",
        "csv",
        "html",
    ],
)
def test_a_damaged_stored_piece_is_named_and_recomputed_alone(
    where, damage, message, reference, tiny_session, model_dir, tmp_path, capsys
):
    ref_out, expected = reference
    out = _copy(ref_out, tmp_path / "report")
    damage(out / where)
    others = {k: v for k, v in _chunks(out).items() if k != Path(where).name}
    code, stdout, lines = _run(capsys, *assess_args(tiny_session, out, model_dir, "--processes", 1))
    assert code == 0, lines
    if message is not None:  # a chunk: named, computed again, the others untouched
        assert len(lines) == 1 and lines[0].startswith("ergopose: warning:"), lines
        assert str(out / where) in lines[0] and message in lines[0] and "computed again" in lines[0]
        assert "5 of 6 chunks reused" in stdout
    else:
        assert lines == []
        assert "6 of 6 chunks reused" in stdout
    assert {k: v for k, v in _chunks(out).items() if k in others} == others
    assert _chunks(out) == _chunks(ref_out)
    assert csv_bytes(out) == expected
    assert (out / where).stat().st_size == (ref_out / where).stat().st_size  # whole again


@pytest.mark.slow
def test_report_names_a_damaged_results_file(reference, tmp_path, capsys):
    out = _copy(reference[0], tmp_path / "report")
    _truncate(out / "results" / "workers" / "worker_1" / "summary.json")
    html = (out / "index.html").read_bytes()
    code, _, lines = _run(capsys, "report", "--session", out, "--quiet")
    assert code == 2
    _one_error(lines, "summary.json", "cannot read the stored results")
    assert (out / "index.html").read_bytes() == html


# ------------------------------------------------------------------------ another recording


@pytest.fixture(scope="module")
def other_session(tmp_path_factory):
    """Another recording of the same length (another seed)."""
    from ergopose.sim.writer import SimulationConfig, simulate_session

    path = tmp_path_factory.mktemp("other") / "day2"
    simulate_session(path, SimulationConfig(workers=2, minutes=0.05, seed=5))
    return path


@pytest.mark.slow
def test_results_carry_the_recordings_fingerprint(reference, tiny_session):
    from ergopose.pipeline.guard import fingerprint_of
    from ergopose.session import load_session

    data = json.loads((reference[0] / "results" / "session.json").read_text())["data"]
    assert data["fingerprint"] == fingerprint_of(load_session(tiny_session)) and len(data["fingerprint"]) == 64


@pytest.mark.slow
def test_assess_refuses_a_folder_with_another_recordings_results(reference, other_session, model_dir, tmp_path, capsys):
    out = _copy(reference[0], tmp_path / "report")
    before = _files(out)
    code, _, lines = _run(capsys, *assess_args(other_session, out, model_dir))
    assert code == 2
    _one_error(lines, str(out), "another recording", "session 'day1'", "--force")
    assert _files(out) == before
    code, _, lines = _run(capsys, *assess_args(other_session, out, model_dir, "--force"))
    assert code == 0
    assert len(lines) == 1 and lines[0].startswith("ergopose: warning:") and "--force" in lines[0]
    assert json.loads((out / "results" / "session.json").read_text())["data"]["session_id"] == "day2"


@pytest.mark.slow
def test_report_and_evaluate_refuse_another_recordings_results(
    reference, tiny_session, other_session, tmp_path, capsys
):
    out = _copy(reference[0], tmp_path / "report")
    before = _files(out)
    code, _, lines = _run(capsys, "report", "--session", other_session, "--out", out, "--quiet")
    assert code == 2
    _one_error(lines, "another recording", "--force")
    code, _, lines = _run(capsys, "evaluate", "--session", other_session, "--results", out)
    assert code == 2
    _one_error(lines, "another recording", "--force")
    assert _files(out) == before  # no evaluation.json, no page written
    code, stdout, lines = _run(capsys, "report", "--session", tiny_session, "--out", out, "--quiet")
    assert code == 0 and lines == []  # its own session: rendered
    code, stdout, lines = _run(capsys, "report", "--session", other_session, "--out", out, "--quiet", "--force")
    assert code == 0 and len(lines) == 1 and "--force" in lines[0]


# ---------------------------------------------------------------------------------- bad frames


@pytest.fixture(scope="module")
def damaged_session(tiny_session, tmp_path_factory):
    """The tiny session with 3000 seeded random bytes over the middle of cam_2.mp4: one frame cannot be
    decoded (the others decode, some with artefacts until the next key frame)."""
    from tests.test_video import damage_middle

    path = _copy(tiny_session, tmp_path_factory.mktemp("damaged") / "day1")
    damage_middle(tiny_session / "cam_2.mp4", path / "cam_2.mp4", length=3000)
    return path


def _skipped(out: Path) -> list[str]:
    return (out / "csv" / "frames_skipped.csv").read_text().splitlines()


@pytest.mark.slow
def test_unreadable_frames_are_skipped_counted_and_reported(damaged_session, model_dir, tmp_path, capsys):
    import pandas as pd

    out = tmp_path / "report"
    code, _, lines = _run(capsys, *assess_args(damaged_session, out, model_dir, "--processes", 1))
    assert code == 0, lines
    table = pd.read_csv(out / "csv" / "frames_skipped.csv")
    assert list(table.columns) == ["camera", "frame", "time_s", "reason"]
    assert len(table) >= 1 and set(table["camera"]) == {"cam_2"}
    assert set(table["reason"]) == {"cannot be decoded"}
    np.testing.assert_allclose(table["time_s"], table["frame"] / 12.0, atol=0.0005)  # ms, as every CSV
    page = (out / "worker-worker_1.html").read_text()
    assert "could not be read and were skipped" in page and "cam_2:" in page
    session = json.loads((out / "results" / "session.json").read_text())["data"]
    assert session["skipped_frames"][0]["camera"] == "cam_2"
    assert session["skipped_frames"][0]["frames"] == len(table)
    # the chunk files mark the frame, so a resumed run reports the same
    frame = int(table["frame"][0])
    with np.load(out / "pipeline" / "chunks" / f"chunk_{frame - frame % 6:09d}.npz") as data:
        assert data["detections"][frame % 6, 1] == -1


@pytest.mark.slow
def test_too_many_bad_frames_in_a_piece_name_the_video_and_time(damaged_session, model_dir, tmp_path, capsys):
    out = tmp_path / "report"
    # 1 of the 6 frames of a 0.5 s piece is 17 %: refused with at most 10 % allowed
    code, _, lines = _run(
        capsys, *assess_args(damaged_session, out, model_dir, "--processes", 1, "--max-bad-frames", 0.1)
    )
    assert code == 2
    line = _one_error(lines, "cam_2.mp4", "cannot be read", "10 %", "--max-bad-frames")
    assert "0:00:01.0 and 0:00:01.5" in line  # frames 12-17 of 12 fps: the piece holding frame 13
    kept = _chunks(out)
    assert sorted(kept) == ["chunk_000000000.npz", "chunk_000000006.npz"]  # the pieces before stay
    code, stdout, lines = _run(capsys, *assess_args(damaged_session, out, model_dir, "--processes", 1))
    assert code == 0 and "2 of 6 chunks reused" in stdout
    assert {k: v for k, v in _chunks(out).items() if k in kept} == kept
