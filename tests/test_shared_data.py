"""Tests that need ../shared say so: skipped with a reason naming it, failures in CI."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.conftest import REPO, REQUIRE_SHARED, need_shared


def test_missing_shared_data_skips_naming_what_is_missing(tmp_path, monkeypatch):
    monkeypatch.delenv(REQUIRE_SHARED, raising=False)
    with pytest.raises(pytest.skip.Exception, match=r"needs \.\./shared \(the reference\): .*nothing-here"):
        need_shared(tmp_path / "nothing-here", "the reference")
    assert need_shared(tmp_path) == tmp_path  # present: given back


def test_ci_turns_the_skip_into_a_failure(tmp_path, monkeypatch):
    monkeypatch.setenv(REQUIRE_SHARED, "1")
    with pytest.raises(pytest.fail.Exception, match=f"nothing-here.*{REQUIRE_SHARED} is set"):
        need_shared(tmp_path / "nothing-here")
    assert f"export {REQUIRE_SHARED}=1" in (REPO / ".ci" / "run").read_text()


@pytest.mark.slow
def test_a_clone_without_shared_skips_and_ci_fails(tmp_path):
    """pytest in a subprocess with ../shared pointing at an empty folder: the tests that need it
    are skipped (exit 0) naming it; with the CI variable they fail (exit 1)."""
    files = ["tests/geometry/lenses/test_eucm.py", "tests/ergonomics/test_scoring_methods.py"]
    env = {**os.environ, "ERGOPOSE_SHARED": str(tmp_path / "shared"), "PYTHONPATH": str(REPO)}
    env.pop(REQUIRE_SHARED, None)
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider", *files],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout[-3000:]
    assert "skipped" in done.stdout and "needs ../shared" in done.stdout and str(tmp_path / "shared") in done.stdout
    env[REQUIRE_SHARED] = "1"
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *files],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 1 and "needs ../shared" in done.stdout, done.stdout[-3000:]
