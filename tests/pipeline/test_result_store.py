"""The result store's lock and its clean-up of what killed runs left."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ergopose.errors import InputError
from ergopose.pipeline.store import ResultStore


@pytest.mark.slow
def test_a_second_run_on_the_same_folder_is_refused_while_the_first_holds_it(tmp_path):
    code = (
        "import sys, time\nfrom ergopose.pipeline.store import ResultStore\n"
        f"with ResultStore({str(tmp_path)!r}).lock():\n"
        "    print('locked', flush=True)\n    time.sleep(30)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}  # this checkout's ergopose
    holder = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(InputError, match="another 'ergopose assess' is writing"):
            with ResultStore(tmp_path).lock():
                pass
    finally:
        holder.kill()  # a killed holder releases the lock: the folder is usable at once
        holder.wait()
    with ResultStore(tmp_path).lock():
        pass


def test_taking_the_lock_removes_temporary_files_of_a_killed_run(tmp_path):
    store = ResultStore(tmp_path)
    store.chunks_dir.mkdir(parents=True)
    stale = [
        store.root / ".tracks.ab12cd.tmp.parquet",
        store.chunks_dir / ".chunk_000000120.x1.tmp.npz",
        tmp_path / "csv" / ".worker-1.q.tmp.csv",
    ]
    for p in stale:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(b"half")
    kept = store.chunks_dir / "chunk_000000000.npz"
    kept.write_bytes(b"whole")
    with store.lock():
        assert not any(p.exists() for p in stale)
        assert kept.read_bytes() == b"whole"
