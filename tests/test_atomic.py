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
