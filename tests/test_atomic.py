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
