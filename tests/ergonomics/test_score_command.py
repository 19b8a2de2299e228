"""``ergopose score`` through ergopose.cli.main: a good file, missing columns, invalid values."""

from __future__ import annotations

import pandas as pd
import pytest

from ergopose import cli
from ergopose.ergonomics.scoring import reba_columns, rula_columns

GOOD = """\
worker,time_s,upper_arm_flexion,elbow_flexion,wrist_flexion,neck_flexion,trunk_flexion,knee_flexion,\
shoulder_raised,arm_across_midline_or_out,wrist_deviated,wrist_twist_end_range,neck_twisted,trunk_side_bent,\
legs_supported,static_posture,repeated_action,rapid_change,load_kg,load_mode,coupling
a,0.0,50,110,10,15,30,0,1,1,1,1,1,1,1,1,0,0,5,intermittent,good
a,0.5,10,80,3,5,2,0,0,0,0,0,0,0,1,0,0,0,1,intermittent,fair
a,1.0,20,80,0,5,0,0,0,0,0,0,0,0,1,0,0,0,0,intermittent,good
a,1.5,,80,0,5,0,0,0,0,0,0,0,0,1,0,0,0,0,,
"""


def _run(tmp_path, text: str, *args: str):
    src = tmp_path / "angles.csv"
    src.write_text(text)
    out = tmp_path / "scores.csv"
    code = cli.main(["score", "--angles", str(src), "--out", str(out), *args])
    return code, out


def test_good_file_rula(tmp_path, capsys):
    code, out = _run(tmp_path, GOOD, "--method", "rula")
    assert code == 0
    table = pd.read_csv(out)
    assert list(table.columns) == ["worker", "time_s", *rula_columns()]
    assert len(table) == 4
    # row 1 is the hand-worked high-risk worksheet of tests/ergonomics/test_scoring.py
    assert table.loc[0, "left_rula_table_a"] == 5 and table.loc[0, "rula_table_b"] == 5
    assert table.loc[0, "left_rula_score_c"] == 7
    assert table.loc[0, "rula_grand"] == 7 and table.loc[0, "rula_action_level"] == 4
    assert table.loc[1, "rula_grand"] == 1
    assert table.loc[2, "left_rula_upper_arm_band"] == 2  # exactly 20 degrees: RULA's upper band
    assert pd.isna(table.loc[3, "left_rula_upper_arm"]) and pd.isna(table.loc[3, "rula_grand"])
    assert "4 rows scored" in capsys.readouterr().out


def test_good_file_reba_and_settings(tmp_path):
    code, out = _run(tmp_path, GOOD, "--method", "reba")
    assert code == 0
    table = pd.read_csv(out)
    assert list(table.columns) == ["worker", "time_s", *reba_columns()]
    assert table.loc[1, "reba_coupling"] == 1
    settings = tmp_path / "settings.toml"
    settings.write_text('[scoring]\nrula_open_boundary = "lower"\n[other]\nx = 1\n')
    code, out = _run(tmp_path, GOOD, "--method", "rula", "--settings", str(settings))
    assert code == 0
    assert pd.read_csv(out).loc[2, "left_rula_upper_arm_band"] == 1  # 20 degrees now in the lower band


def test_missing_columns(tmp_path, capsys):
    text = GOOD.replace("neck_flexion,", "neck_angle,")
    code, out = _run(tmp_path, text, "--method", "reba")
    assert code == 2 and not out.exists()
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "missing column(s) for REBA: neck_flexion" in err and "unknown column(s): neck_angle" in err


def test_invalid_value_names_column_and_row(tmp_path, capsys):
    text = GOOD.replace("intermittent,fair", "intermittent,great")
    code, out = _run(tmp_path, text, "--method", "reba")
    assert code == 2 and not out.exists()
    err = capsys.readouterr().err
    assert err.startswith("ergopose: error: ") and err.count("\n") == 1
    assert "coupling: row 2: 'great' is not one of good, fair, poor, unacceptable" in err


def test_angle_out_of_range_and_flag_not_binary(tmp_path, capsys):
    text = GOOD.replace("a,0.5,10,80,3", "a,0.5,10,380,3").replace("a,1.0,20,80,0,5,0,0,0", "a,1.0,20,80,0,5,0,0,2")
    code, _ = _run(tmp_path, text, "--method", "rula")
    assert code == 2
    err = capsys.readouterr().err
    assert "left_elbow_flexion: row 2: 380 is outside -180..180 degrees" in err
    assert "left_shoulder_raised: row 3: 2 is not 0, 1 or empty" in err


def test_unknown_setting(tmp_path, capsys):
    settings = tmp_path / "s.toml"
    settings.write_text("rula_open_boundry = 'lower'\n")
    code, _ = _run(tmp_path, GOOD, "--method", "rula", "--settings", str(settings))
    assert code == 2
    assert "rula_open_boundry: unknown key; did you mean 'rula_open_boundary'?" in capsys.readouterr().err


@pytest.mark.parametrize("missing", ["angles.csv"])
def test_missing_input_file(tmp_path, capsys, missing):
    code = cli.main(
        ["score", "--method", "rula", "--angles", str(tmp_path / missing), "--out", str(tmp_path / "o.csv")]
    )
    assert code == 2 and "does not exist" in capsys.readouterr().err
