from __future__ import annotations

import pytest

from ergopose.atomic import atomic_dir, atomic_path, write_text


def test_failed_write_keeps_the_earlier_file(tmp_path):
    target = tmp_path / "scores.csv"
    write_text(target, "old\n")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("crash")
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scores.csv"]


def test_failed_dir_keeps_the_earlier_dir(tmp_path):
    target = tmp_path / "report"
    with atomic_dir(target) as d:
        (d / "index.html").write_text("v1")
    with pytest.raises(RuntimeError):
        with atomic_dir(target) as d:
            (d / "index.html").write_text("half")
            raise RuntimeError("crash")
    assert (target / "index.html").read_text() == "v1"
    with atomic_dir(target) as d:
        (d / "index.html").write_text("v2")
    assert (target / "index.html").read_text() == "v2"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]


def test_outputs_get_ordinary_permissions(tmp_path):
    """Temporary names are private while written; the final file follows the umask like any file."""
    import os

    old = os.umask(0o022)
    try:
        path = write_text(tmp_path / "report.html", "x")
        with atomic_dir(tmp_path / "folder") as d:
            (d / "a.txt").write_text("a")
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == 0o644
    assert (tmp_path / "folder").stat().st_mode & 0o777 == 0o755


def _run_and_die(code: str) -> None:
    """Run ``code`` in a fresh interpreter that dies (os._exit, no clean-up) where the code says."""
    import subprocess
    import sys

    import os
    from pathlib import Path

    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}  # this checkout's ergopose
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env)
    assert done.returncode == 9, done.stderr


def test_clean_up_removes_what_a_killed_writer_left(tmp_path):
    from ergopose.atomic import clean_up

    write_text(tmp_path / "keep.csv", "old\n")
    (tmp_path / ".hidden_user_file").write_text("not ours")
    _run_and_die(
        "import os\nfrom ergopose.atomic import atomic_path, atomic_dir\n"
        f"with atomic_dir({str(tmp_path / 'results')!r}) as d:\n"
        "    (d / 'a.txt').write_text('half')\n"
        f"    with atomic_path({str(tmp_path / 'keep.csv')!r}) as t:\n"
        "        t.write_text('half')\n"
        "        os._exit(9)\n"
    )
    left = sorted(p.name for p in tmp_path.iterdir())
    assert any(n.startswith(".keep.") for n in left) and any(n.startswith(".results.") for n in left)
    removed = clean_up(tmp_path)
    assert len(removed) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == [".hidden_user_file", "keep.csv"]
    assert (tmp_path / "keep.csv").read_text() == "old\n"


def test_clean_up_puts_back_a_folder_moved_aside_by_a_killed_swap(tmp_path):
    from ergopose.atomic import clean_up

    with atomic_dir(tmp_path / "results") as d:
        (d / "a.txt").write_text("v1")
    # die between moving the old folder aside and moving the new one in
    _run_and_die(
        "import os\nimport ergopose.atomic as atomic\n"
        "real = os.replace\ncalls = []\n"
        "def replace(a, b):\n"
        "    calls.append(a)\n"
        "    real(a, b)\n"
        "    if len(calls) == 1:\n"
        "        os._exit(9)\n"
        "atomic.os.replace = replace\n"
        f"with atomic.atomic_dir({str(tmp_path / 'results')!r}) as d:\n"
        "    (d / 'a.txt').write_text('v2')\n"
    )
    assert not (tmp_path / "results").exists()
    clean_up(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]
    assert (tmp_path / "results" / "a.txt").read_text() == "v1"


def test_clean_up_beside_removes_only_what_a_killed_writer_of_that_name_left(tmp_path):
    from ergopose.atomic import clean_up_beside

    with atomic_dir(tmp_path / "pose") as d:
        (d / "keypoints.csv").write_text("v1")
    write_text(tmp_path / "k.csv", "old\n")
    (tmp_path / ".bashrc").write_text("the user's")
    (tmp_path / ".other.abc.tmp").mkdir()  # another output's leftover: not this one's to tidy
    (tmp_path / ".k.abc.tmp.json").write_text("another file's")
    _run_and_die(
        "import os\nfrom ergopose.atomic import atomic_path, atomic_dir\n"
        f"with atomic_dir({str(tmp_path / 'pose')!r}) as d:\n"
        "    (d / 'keypoints.csv').write_text('half')\n"
        f"    with atomic_path({str(tmp_path / 'k.csv')!r}) as t:\n"
        "        t.write_text('half')\n"
        "        os._exit(9)\n"
    )
    before = sorted(p.name for p in tmp_path.iterdir())
    assert any(n.startswith(".pose.") for n in before) and any(
        n.startswith(".k.") and n.endswith(".tmp.csv") for n in before
    )
    assert len(clean_up_beside(tmp_path / "pose")) == 1
    assert len(clean_up_beside(tmp_path / "k.csv")) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        ".bashrc",
        ".k.abc.tmp.json",
        ".other.abc.tmp",
        "k.csv",
        "pose",
    ]
    assert (tmp_path / "pose" / "keypoints.csv").read_text() == "v1" and (tmp_path / "k.csv").read_text() == "old\n"
    # A folder moved aside by a swap that died comes back when the output is missing.
    (tmp_path / "pose").rename(tmp_path / ".pose.old")
    assert clean_up_beside(tmp_path / "pose") == [] and (tmp_path / "pose" / "keypoints.csv").read_text() == "v1"
