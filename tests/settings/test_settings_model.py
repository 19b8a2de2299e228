"""The settings model (ergopose/settings/): one line per problem naming the file, the key path, the
value and what is allowed; the stages' records agree with their tables; [pose] and [reconstruction]
reach the Session."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from ergopose import cli
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.errors import ConfigError
from ergopose.pose.settings import PoseSettings
from ergopose.recon.settings import ReconSettings, from_table
from ergopose.session import load_session
from ergopose.settings.model import read_settings
from ergopose.settings.pose import PoseTable
from ergopose.settings.reconstruction import RECORD_NAMES, ReconstructionTable
from ergopose.settings.scoring import ScoringTable
from tests.test_session_format import SETTINGS, make_session

MINIMAL = """\
format_version = 1
recorded_at = 2024-03-04T08:00:00+01:00

[[cameras]]
name = "cam_1"
video = "a.mp4"
"""


def _message(tmp_path: Path, text: str) -> str:
    path = tmp_path / "settings.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        read_settings(path)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{path}: ")
    return msg.removeprefix(f"{path}: ")


@pytest.mark.parametrize(
    "extra, expected",
    [
        # unknown key, with a suggestion; without one, the allowed keys
        ("[workers.w1]\nseatd = true\n", "workers.w1.seatd: unknown key; did you mean 'seated'?"),
        (
            "[identification]\ncolour = 1\n",
            "identification.colour: unknown key (allowed: by_stature, stature_tolerance_m, stature_margin_m)",
        ),
        (
            "[reconstruction]\nfit_turn_rate_rad_s = 4.0\n",
            "reconstruction.fit_turn_rate_rad_s: unknown key; did you mean 'fit_turn_rate_deg_s'?",
        ),
        # wrong type
        ('[defaults]\nload_kg = "heavy"\n', "defaults.load_kg: expected a number >= 0 (kilograms), got 'heavy'"),
        ("[pose]\nmax_people = 2.5\n", "pose.max_people: expected a whole number greater than 0, got 2.5"),
        ("[scoring]\nstatic_includes_neutral = 1\n", "scoring.static_includes_neutral: expected true or false, got 1"),
        (
            '[[periods]]\nstart = "10:00"\nend = 3.0\nload_kg = 1.0\n',
            "periods[0].start: expected seconds from the start (a number), a clock time (10:15:00) or a date-time "
            "(2024-03-04T10:15:00+01:00), got '10:00'",
        ),
        # out of range
        (
            "[[workers.w1.periods]]\nstart = 0.0\nend = 1.0\nload_kg = -2.0\n",
            "workers.w1.periods[0].load_kg: expected a number >= 0 (kilograms), got -2.0",
        ),
        (
            "[defaults]\nwrist_flexion_deg = 95.0\n",
            "defaults.wrist_flexion_deg: expected a number from -90 to 90 (degrees), got 95.0",
        ),
        (
            "[reconstruction]\nmin_confidence = 1.0\n",
            "reconstruction.min_confidence: expected a number >= 0 and below 1, got 1.0",
        ),
        ("[pose]\nmax_half_fov_deg = 5.0\n", "pose: min_half_fov_deg (8) must be below max_half_fov_deg (5)"),
        # missing required
        (
            '[calibration_check]\nobservations = "bars.csv"\n',
            "calibration_check.length_m: missing; expected a number greater than 0 (metres)",
        ),
        ("[[periods]]\nstart = 0.0\nload_kg = 1.0\n", "periods[0].end: missing; expected seconds from the start"),
    ],
)
def test_each_problem_is_one_line_with_the_key_path_value_and_what_is_allowed(tmp_path, extra, expected):
    assert _message(tmp_path, MINIMAL + "\n" + extra).startswith(expected)


def test_missing_top_level_key_and_several_problems(tmp_path):
    msg = _message(tmp_path, MINIMAL.replace("recorded_at = 2024-03-04T08:00:00+01:00\n", ""))
    assert msg.startswith("recorded_at: missing; expected an ISO 8601 date and time")
    msg = _message(tmp_path, MINIMAL + "\n[scoring]\nmax_gap = 1\nrula_static_hold_s = 0\n")
    assert msg == (
        "scoring.max_gap: unknown key; did you mean 'max_gap_s'? (and 1 more problem: scoring.rula_static_hold_s)"
    )


def test_the_command_line_shows_one_line_and_exits_non_zero(tmp_path, capsys):
    root = make_session(tmp_path / "s", settings=SETTINGS + "\n[reconstruction]\ntrack_gate_m = 0\n")
    assert cli.main(["calibrate", "check", "--session", str(root)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(
        f"ergopose: error: {root / 'settings.toml'}: reconstruction.track_gate_m: expected a "
        "number greater than 0 (metres), got 0"
    )


def test_pose_and_reconstruction_tables_reach_the_session(tmp_path):
    plain = load_session(make_session(tmp_path / "plain"))
    assert plain.pose == PoseSettings() and plain.reconstruction == ReconSettings()
    assert repr(plain.pose) == repr(PoseSettings())  # unchanged fingerprint of the stored 2D work
    text = SETTINGS + (
        "\n[pose]\nmax_body_roll_deg = 30.0\nsearch_rings_deg = [0, 40]\nmax_people = 3\n"
        "\n[reconstruction]\nfit_turn_rate_deg_s = 180.0\nmax_fill_gap_s = 1\n"
        "lens_region_limits_deg = [25, 50]\n"
    )
    s = load_session(make_session(tmp_path / "set", settings=text))
    assert s.pose == dataclasses.replace(
        PoseSettings(), max_body_roll=math.radians(30.0), search_rings=(0.0, math.radians(40.0)), max_people=3
    )
    assert s.reconstruction.fit_turn_rate_rad_s == pytest.approx(math.pi)
    assert s.reconstruction.max_fill_gap_s == 1.0 and isinstance(s.reconstruction.max_fill_gap_s, float)
    assert s.reconstruction.lens_region_limits_deg == (25.0, 50.0)
    assert s.reconstruction == dataclasses.replace(
        ReconSettings(),
        fit_turn_rate_rad_s=s.reconstruction.fit_turn_rate_rad_s,
        max_fill_gap_s=1.0,
        lens_region_limits_deg=(25.0, 50.0),
    )


def test_records_hold_the_tables_fields_and_defaults():
    assert ScoringSettings().as_dict() == ScoringTable().model_dump()
    table = {RECORD_NAMES.get(k, (k,))[0] for k in ReconstructionTable.model_fields}
    assert table == {f.name for f in dataclasses.fields(ReconSettings)}
    assert from_table(ReconstructionTable.model_validate(ReconstructionTable().model_dump())) == ReconSettings()
    pose = PoseSettings()
    for key, value in PoseTable().model_dump().items():
        field = key.removesuffix("_deg").removesuffix("_m")
        if isinstance(value, str):
            assert getattr(pose, field) == value, key
            continue
        np.testing.assert_allclose(
            getattr(pose, field), np.radians(value) if key.endswith("_deg") else value, rtol=0, atol=1e-12, err_msg=key
        )


def test_records_check_values_made_in_code():
    with pytest.raises(ConfigError, match="track_gate_m: expected a number greater than 0"):
        ReconSettings(track_gate_m=0.0)
    with pytest.raises(ConfigError, match="unknown_flags: expected one of absent, missing"):
        ScoringSettings(unknown_flags="skip")
    # the stored field names (tracks table metadata) read back exactly, the turn rate in radians
    s = ReconSettings(fit_turn_rate_rad_s=0.1)
    assert ReconSettings().replace(**s.as_dict()) == s
