"""Reconstruction settings: defaults, validation, TOML files."""

from __future__ import annotations

import pytest

from ergopose.errors import ConfigError
from ergopose.recon.settings import ReconSettings, from_mapping, load_settings


def test_defaults_and_replace():
    s = ReconSettings()
    assert s.lens_region_limits_deg == (30.0, 60.0) and s.motion_model == "constant_velocity"
    t = s.replace(max_fill_gap_s=1, lens_region_limits_deg=[35, 65])
    assert t.max_fill_gap_s == 1.0 and t.lens_region_limits_deg == (35, 65)
    assert from_mapping(s.as_dict()) == s


@pytest.mark.parametrize(
    "changes, field",
    [
        ({"nope": 1}, "unknown"),
        ({"motion_model": "spline"}, "motion_model"),
        ({"smoothing": 1}, "smoothing"),
        ({"track_gate_m": 0}, "track_gate_m"),
        ({"lens_region_limits_deg": [60, 30]}, "lens_region_limits_deg"),
        ({"max_gated_run": 2.5}, "max_gated_run"),
        ({"torso_min_z_m": 3.0}, "torso_min_z_m"),
        ({"min_confidence": 1.0}, "min_confidence"),
        ({"keypoint_sigma_px": float("nan")}, "keypoint_sigma_px"),
    ],
)
def test_invalid_settings_name_the_field(changes, field):
    with pytest.raises(ConfigError, match=field):
        ReconSettings().replace(**changes)


def test_load_from_session_file(tmp_path):
    p = tmp_path / "session.toml"
    p.write_text("[scoring]\nx = 1\n[reconstruction]\nmax_fill_gap_s = 0.25\nbone_length_constraint = true\n")
    s = load_settings(p)
    assert s.max_fill_gap_s == 0.25 and s.bone_length_constraint
    assert load_settings(None) == ReconSettings()
    (tmp_path / "bad.toml").write_text("max_coast_s = -1\n")
    with pytest.raises(ConfigError, match="bad.toml: max_coast_s"):
        load_settings(tmp_path / "bad.toml")
    with pytest.raises(ConfigError, match="does not exist"):
        load_settings(tmp_path / "missing.toml")
