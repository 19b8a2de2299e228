"""Scoring settings: defaults, files, unknown names and bad values, and their documentation."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from ergopose.ergonomics.settings import ScoringSettings, from_mapping, load_settings, setting_names
from ergopose.errors import ConfigError

REPO = Path(__file__).resolve().parents[2]


def test_defaults_follow_each_methods_pattern():
    s = ScoringSettings()
    assert s.rula_open_boundary == "higher" and s.reba_open_boundary == "lower"
    assert s.rula_static_hold_s == 60 and s.reba_static_hold_s == 60
    assert s.rula_repetitions_per_min == 4 and s.reba_repetitions_per_min == 4
    assert s.rula_lower_arm_adjust == "single" and s.reba_twist_side_adjust == "single"
    assert s.unknown_flags == "absent"
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.wrist_neutral_deg = 3  # type: ignore[misc]


def test_file_with_top_level_keys_or_a_scoring_table(tmp_path):
    a = tmp_path / "a.toml"
    a.write_text('rula_open_boundary = "lower"\nwrist_neutral_deg = 3\n')
    s = load_settings(a)
    assert s.rula_open_boundary == "lower" and s.wrist_neutral_deg == 3.0 and isinstance(s.wrist_neutral_deg, float)
    b = tmp_path / "b.toml"
    b.write_text('[cameras]\nfps = 12\n[scoring]\nunknown_flags = "missing"\n')
    assert load_settings(b).unknown_flags == "missing"
    assert load_settings(None) == ScoringSettings()


def test_unknown_names_are_one_error_naming_them(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text("wrist_neutral = 3\nrula_boundary = 'lower'\n")
    with pytest.raises(ConfigError) as exc:
        load_settings(p)
    msg = str(exc.value)
    assert msg.startswith(f"{p}: wrist_neutral: unknown key; did you mean 'wrist_neutral_deg'?")
    assert msg.endswith("(and 1 more problem: rula_boundary)")
    with pytest.raises(ConfigError, match="nope: unknown key"):
        ScoringSettings().replace(nope=1)


@pytest.mark.parametrize(
    "name,value,fragment",
    [
        ("rula_open_boundary", "upper", "expected one of higher, lower"),
        ("unknown_flags", "ignore", "expected one of absent, missing"),
        ("wrist_neutral_deg", -1, "expected a number >= 0 and below 90 (degrees), got -1"),
        ("trunk_twisted_deg", 95, "below 90 (degrees), got 95"),
        ("rula_static_hold_s", 0, "greater than 0"),
        ("static_includes_neutral", 1, "true or false"),
        ("rapid_change_deg", "30", "expected a number"),
        ("max_gap_s", float("nan"), "expected a number"),
    ],
)
def test_bad_values_name_the_setting(tmp_path, name, value, fragment):
    with pytest.raises(ConfigError) as exc:
        from_mapping({name: value}, source="day1.toml")
    msg = str(exc.value)
    assert msg.startswith(f"day1.toml: {name}: ") and fragment in msg, msg


def test_not_toml(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text("x = [")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_settings(p)
    with pytest.raises(ConfigError, match="does not exist"):
        load_settings(tmp_path / "missing.toml")


def test_every_setting_is_documented_with_its_default():
    doc = (REPO / "docs" / "scoring.md").read_text(encoding="utf-8")
    defaults = ScoringSettings()
    for name in setting_names():
        rows = [line for line in doc.splitlines() if line.startswith(f"| `{name}` |")]
        assert rows, f"docs/scoring.md has no table row for {name}"
        default = getattr(defaults, name)
        shown = rows[0].split("|")[2].strip().strip("`")
        if isinstance(default, bool):
            assert shown == str(default).lower(), name
        elif isinstance(default, str):
            assert shown == default, name
        else:
            assert float(shown) == default, name
    assert not re.search(r"TODO|TBD", doc)
