"""Session settings for identification by stature and the reference-bar check."""

from __future__ import annotations

import shutil

import pytest

from ergopose import cli
from ergopose.errors import ConfigError
from ergopose.session import load_session

# Left out of make test-fast (still in make test): every test here reads a simulated session (simulated, 1.2 s of two workers).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    from ergopose.sim.writer import SimulationConfig, simulate_session

    path = tmp_path_factory.mktemp("sim") / "day1"
    simulate_session(path, SimulationConfig(workers=2, minutes=0.02, seed=2))
    return path


def _edit(src, dst, old, new):
    shutil.copytree(src, dst)
    text = (dst / "settings.toml").read_text()
    assert old in text
    (dst / "settings.toml").write_text(text.replace(old, new, 1))
    return dst


def test_simulated_settings_give_statures_and_a_bar(simulated):
    s = load_session(simulated)
    assert all(1.55 <= w.stature_m <= 1.95 for w in s.workers)
    assert s.calibration_check is not None and s.calibration_check.length_m == 1.5
    assert s.identification.stature_tolerance_m == 0.05


def test_check_command_reads_the_session(simulated, capsys):
    assert cli.main(["calibrate", "check", "--session", str(simulated)]) == 0
    out = capsys.readouterr().out
    assert "target 1.500 m" in out and "central" in out


@pytest.mark.parametrize(
    "old,new,field",
    [
        ("stature_m = ", "stature_m = 17", "stature_m"),
        ('observations = "reference_bars.csv"', 'observations = "nope.csv"', "calibration_check.observations"),
        (
            "[calibration_check]",
            "[identification]\nstature_tolerance = 0.1\n\n[calibration_check]",
            "stature_tolerance",
        ),
    ],
)
def test_bad_values_name_the_field(simulated, tmp_path, old, new, field):
    session = _edit(simulated, tmp_path / "day1", old, new)
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        load_session(session)
