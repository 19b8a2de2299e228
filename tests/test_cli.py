"""The command line: help, version, and one clear line for user errors."""

from __future__ import annotations

import subprocess
import sys

import pytest

from ergopose import __version__, cli
from ergopose.errors import ConfigError


def test_help_lists_commands(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "ergopose" in out and "commands" in out


@pytest.mark.slow
def test_version():
    out = subprocess.run([sys.executable, "-m", "ergopose", "--version"], capture_output=True, text=True)
    assert out.returncode == 0
    assert out.stdout.strip() == f"ergopose {__version__}"


def test_user_error_is_one_line_without_traceback(monkeypatch, capsys):
    def boom(args):
        raise ConfigError("expected a number, got 'abc'", path="day1/settings.toml", field="fps")

    parser = cli.build_parser()
    monkeypatch.setattr(cli, "build_parser", lambda: parser)
    sub = next(a for a in parser._actions if a.dest == "command")
    p = sub.add_parser("boom")
    p.set_defaults(func=boom)
    assert cli.main(["boom"]) == 2
    err = capsys.readouterr().err
    assert err == "ergopose: error: day1/settings.toml: fps: expected a number, got 'abc'\n"


@pytest.mark.slow
def test_no_command_prints_the_help_and_exits_2(capsys):
    assert cli.main([]) == 2
    captured = capsys.readouterr()
    assert "usage: ergopose" in captured.err and "commands" in captured.err
    done = subprocess.run([sys.executable, "-m", "ergopose"], capture_output=True, text=True)
    assert done.returncode == 2 and "usage: ergopose" in done.stderr
