"""assessments/rula.toml and reba.toml against the reference, and the loader's checks.

The independent source is the markdown reference itself (../shared/ergonomics/
rula-reba-reference.md): its tables are parsed here and compared cell by cell with the loaded
method data and with the scoring's table lookup.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from ergopose.ergonomics.methods import load_method, load_method_file
from ergopose.ergonomics.scoring import lookup
from ergopose.errors import ConfigError
from ergopose.resources import resource_dir
from tests.conftest import SHARED, need_shared

REPO = Path(__file__).resolve().parents[2]
REFERENCE = SHARED / "ergonomics" / "rula-reba-reference.md"


def _markdown_tables(text: str) -> dict[str, list[list[str]]]:
    """Every pipe table of the markdown, keyed by the nearest non-empty line above it."""
    lines = text.splitlines()
    tables: dict[str, list[list[str]]] = {}
    i = 0
    while i < len(lines):
        if lines[i].startswith("|"):
            j = i - 1
            while j >= 0 and not lines[j].strip():
                j -= 1
            title = lines[j].strip() if j >= 0 else ""
            rows = []
            while i < len(lines) and lines[i].startswith("|"):
                cells = [c.strip() for c in lines[i].strip().strip("|").split("|")]
                if not all(set(c) <= {"-", ":"} for c in cells):
                    rows.append(cells)
                i += 1
            tables[title] = rows
        else:
            i += 1
    return tables


@pytest.fixture(scope="module")
def reference() -> dict[str, list[list[str]]]:
    need_shared(REFERENCE, "the RULA/REBA reference")
    return _markdown_tables(REFERENCE.read_text(encoding="utf-8"))


def _table(reference, prefix: str, label_columns: int) -> tuple[list[str], list[list[str]], np.ndarray]:
    key = next(k for k in reference if k.startswith(prefix))
    header, *rows = reference[key]
    values = np.array([[int(c) for c in r[label_columns:]] for r in rows])
    return header, rows, values


def _header_codes(header: list[str], label_columns: int) -> list[list[int]]:
    """'W2T1' -> [2, 1]; '7' -> [7]."""
    return [[int(n) for n in re.findall(r"\d+", h)] for h in header[label_columns:]]


# ------------------------------------------------------------------ every cell of every table

CASES = [
    # method, table, reference prefix, label columns
    ("rula", "table_a", "RULA Table A", 2),
    ("rula", "table_b", "RULA Table B", 1),
    ("rula", "table_c", "RULA Table C", 1),
    ("reba", "table_a", "REBA Table A", 1),
    ("reba", "table_b", "REBA Table B", 1),
    ("reba", "table_c", "REBA Table C", 1),
]


@pytest.mark.slow
@pytest.mark.parametrize("method,name,prefix,labels", CASES)
def test_every_cell_matches_the_reference(reference, method, name, prefix, labels):
    table = load_method(method).tables[name]
    header, rows, values = _table(reference, prefix, labels)
    col_codes = _header_codes(header, labels)
    checked = 0
    for r, row in enumerate(rows):
        row_codes = [int(x) for x in row[:labels]]
        for c, codes in enumerate(col_codes):
            index = tuple(k - 1 for k in row_codes + codes)
            assert table.values[index] == values[r, c], (method, name, row_codes + codes)
            checked += 1
    assert checked == table.values.size  # every cell of the loaded table was compared


@pytest.mark.slow
@pytest.mark.parametrize("method,name,prefix,labels", CASES)
def test_lookup_returns_every_cell(reference, method, name, prefix, labels):
    """The scoring's vectorised lookup, fed every index combination at once."""
    table = load_method(method).tables[name]
    header, rows, values = _table(reference, prefix, labels)
    col_codes = _header_codes(header, labels)
    idx, expect = [], []
    for r, row in enumerate(rows):
        for c, codes in enumerate(col_codes):
            idx.append([int(x) for x in row[:labels]] + codes)
            expect.append(values[r, c])
    idx = np.array(idx, dtype=float)
    got = lookup(table, *idx.T)
    np.testing.assert_array_equal(got, np.array(expect, dtype=float))


def test_lookup_clamps_rula_8_plus_and_7_plus():
    c = load_method("rula").tables["table_c"]
    got = lookup(c, np.array([8, 9, 13, 5, np.nan]), np.array([7, 7, 11, 9, 1]))
    np.testing.assert_array_equal(got[:4], [c.values[7, 6], c.values[7, 6], c.values[7, 6], c.values[4, 6]])
    assert np.isnan(got[4])


def test_action_levels_match_the_reference():
    text = need_shared(REFERENCE, "the RULA/REBA reference").read_text(encoding="utf-8")
    rula = re.search(r"RULA action levels:(.*?)\n\n", text, re.S).group(1)
    found = re.findall(r"(\d+)(?:-(\d+))? AL(\d)", rula)
    expected = [(int(a), int(b or a), int(lv)) for a, b, lv in found]
    got = [(lv.low, lv.high, lv.level) for lv in load_method("rula").action_levels]
    assert got == expected == [(1, 2, 1), (3, 4, 2), (5, 6, 3), (7, 7, 4)]
    reba = re.search(r"REBA risk levels:(.*?)\n\n", text, re.S).group(1)
    found = re.findall(r"(\d+)(?:-(\d+))? ([a-z ]+?) \(AL(\d)\)", reba)
    expected = [(int(a), int(b or a), name.strip(), int(lv)) for a, b, name, lv in found]
    got = [(lv.low, lv.high, lv.label, lv.level) for lv in load_method("reba").action_levels]
    assert got == expected
    assert len(got) == 5


def test_level_of_scores():
    m = load_method("reba")
    np.testing.assert_array_equal(m.level_of(np.array([1, 2, 3, 4, 7, 8, 10, 11, 15])), [0, 1, 1, 2, 2, 3, 3, 4, 4])
    assert np.isnan(m.level_of(np.array([np.nan]))[0])


def test_bands_read_as_the_reference_words_them():
    rula, reba = load_method("rula"), load_method("reba")
    assert rula.bands["upper_arm"].edges_deg == (-20, 20, 45, 90)
    assert rula.bands["upper_arm"].scores == (2, 1, 2, 3, 4)
    assert rula.bands["upper_arm"].adjustment.points == {
        "shoulder_raised": 1,
        "upper_arm_abducted": 1,
        "arm_supported": -1,
    }
    assert rula.bands["upper_arm"].adjustment.adjusted_range == (1, 6)
    assert rula.bands["lower_arm"].adjustment.adjusted_range == (1, 3)
    assert rula.bands["lower_arm"].variants["separate"].adjusted_range == (1, 4)
    assert rula.bands["wrist"].adjustment.adjusted_range == (1, 4)
    assert reba.bands["neck"].adjustment.adjusted_range == (1, 3)
    assert reba.bands["trunk"].adjustment.adjusted_range == (1, 5)
    assert reba.bands["knee"].adjustment.adjusted_range == (1, 4)
    assert reba.coupling == {"good": 0, "fair": 1, "poor": 2, "unacceptable": 3}
    assert reba.load.edges_kg == (5, 10) and reba.load.shock_add == 1
    assert rula.load.edges_kg == (2, 10) and rula.load.shock_score == 3
    assert rula.points == {"muscle_use": 1}
    assert reba.points == {"static": 1, "repeated": 1, "rapid": 1}


def test_packaged_folder_holds_both_methods():
    folder = resource_dir("assessments")
    for name in ("rula", "reba"):
        m = load_method_file(folder / f"{name}.toml", name)
        assert m.name == name and m.source


def test_tables_are_read_only():
    t = load_method("rula").tables["table_a"]
    with pytest.raises(ValueError):
        t.values[0, 0, 0, 0] = 5


# --------------------------------------------------------------------------- malformed files

RULA_TEXT = (REPO / "assessments" / "rula.toml").read_text(encoding="utf-8")
REBA_TEXT = (REPO / "assessments" / "reba.toml").read_text(encoding="utf-8")


def _broken(tmp_path, text: str, old: str, new: str, name: str = "rula.toml") -> Path:
    assert old in text, old
    p = tmp_path / name
    p.write_text(text.replace(old, new, 1), encoding="utf-8")
    return p


MALFORMED = [
    # (text, old, new, expected field in the message, fragment of the message)
    (
        RULA_TEXT,
        "  [ 3,   4,   4,   4,   4,   4,   5,   5 ],   # UA2 LA3",
        "  [ 3,   4,   4,   4,   4,   4,   5 ],   # UA2 LA3",
        "table_a.values",
        "expected 8 values",
    ),
    (RULA_TEXT, "  [ 9,   9,   9,   9,   9,   9,   9,   9 ],   # UA6 LA3\n", "", "table_a.values", "expected 18 rows"),
    (
        RULA_TEXT,
        "  [ 4,   4,   4,   4,   4,   5,   5,   5 ],   # UA3 LA3",
        "  [ 2,   4,   4,   4,   4,   5,   5,   5 ],   # UA3 LA3",
        "table_a.values",
        "not monotone",
    ),
    (
        RULA_TEXT,
        "  [ 1,  2,  3,  3,  4,  5,  5 ],   # C1",
        "  [ 1,  2,  3,  3,  4,  5,  12 ],   # C1",
        "table_c.values",
        "whole numbers 1-7",
    ),
    (
        RULA_TEXT,
        "sizes = { neck = 6, trunk = 6, legs = 2 }",
        "sizes = { neck = 6, trunk = 5, legs = 2 }",
        "table_b.values",
        "expected 10 values",
    ),
    (
        RULA_TEXT,
        "edges   = [      -20,        20,        45,        90]",
        "edges   = [      -20,        45,        20,        90]",
        "upper_arm.edges",
        "ascend",
    ),
    (
        RULA_TEXT,
        "scores  = [   2,         1,         2,         3,        4]",
        "scores  = [   2,         1,         3,         2,        4]",
        "upper_arm.scores",
        "rise away",
    ),
    (
        RULA_TEXT,
        'at_edge = [  "lower",  "setting", "setting",  "higher"]',
        'at_edge = [  "lower",  "setting", "maybe",  "higher"]',
        "upper_arm.at_edge",
        "expected one of",
    ),
    (
        RULA_TEXT,
        "adjusted_range = [1, 6]",
        "adjusted_range = [1, 5]",
        "upper_arm.adjusted_range",
        "highest adjusted score is 6",
    ),
    (
        RULA_TEXT,
        "adjust = { wrist_deviated = 1 }",
        "adjust = { wrist_bent = 1 }",
        "wrist.adjust.wrist_bent",
        "unknown flag",
    ),
    (
        RULA_TEXT,
        'tolerance_setting = "wrist_neutral_deg"',
        'tolerance_setting = "wrist_tolerance"',
        "wrist.tolerance_setting",
        "not an angle setting",
    ),
    (
        RULA_TEXT,
        'scores = [5, 6]\nlabel = "AL3"',
        'scores = [5, 5]\nlabel = "AL3"',
        "action_levels[4].scores",
        "start at 6",
    ),
    (RULA_TEXT, 'method = "rula"', 'method = "owas"', "method", "expected one of"),
    (RULA_TEXT, "[muscle_use]", "[muscle_use]\nscroe = 1", "muscle_use", "unknown key"),
    (
        RULA_TEXT,
        "table = [\n#  intermittent  static or repeated\n  [ 0,            0 ],",
        "table = [\n#  intermittent  static or repeated\n  [ 0,            0, 1 ],",
        "force.table",
        "equal length",
    ),
    (RULA_TEXT, "score_range = [1, 7]", "score_range = [1, 8]", "score_range", "expected [1, 7]"),
    (
        REBA_TEXT,
        "scores = { good = 0, fair = 1, poor = 2, unacceptable = 3 }",
        "scores = { good = 0, fair = 2, poor = 1, unacceptable = 3 }",
        "coupling.scores",
        "rising",
    ),
    (
        REBA_TEXT,
        "sizes = { trunk = 5, neck = 3, legs = 4 }",
        "sizes = { trunk = 5, neck = 3, legs = 3 }",
        "table_a.values",
        "expected 9 values",
    ),
    (
        REBA_TEXT,
        "adjusted_range = [1, 4]  # legs + knee",
        "adjusted_range = [1, 3]  # legs + knee",
        "knee.adjusted_range",
        "spans [1, 4]",
    ),
    (REBA_TEXT, "shock_add = 1", "shock_add = 1\nshock_score = 3", "load", "exactly one of"),
]


@pytest.mark.parametrize("text,old,new,field,fragment", MALFORMED)
def test_malformed_file_gives_one_config_error_naming_file_and_field(tmp_path, text, old, new, field, fragment):
    name = "reba.toml" if text is REBA_TEXT else "rula.toml"
    path = _broken(tmp_path, text, old, new, name)
    with pytest.raises(ConfigError) as exc:
        load_method_file(path)
    msg = str(exc.value)
    assert msg.startswith(f"{path}: "), msg
    assert field in msg and fragment in msg, msg


def test_not_toml_and_missing_file(tmp_path):
    p = tmp_path / "rula.toml"
    p.write_text("method = [", encoding="utf-8")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_method_file(p)
    with pytest.raises(ConfigError, match="does not exist"):
        load_method_file(tmp_path / "none.toml")


def test_method_key_must_match_expected(tmp_path):
    p = tmp_path / "x.toml"
    p.write_text(RULA_TEXT, encoding="utf-8")
    with pytest.raises(ConfigError, match="expected 'reba'"):
        load_method_file(p, "reba")


def test_tolerance_that_makes_bands_overlap_is_an_error():
    b = load_method("rula").bands["wrist"]
    with pytest.raises(ConfigError, match="overlap"):
        b.resolve(tolerance_deg=20, open_boundary="higher")


def test_every_reference_band_boundary_is_in_the_files():
    """Each number the reference's step tables name as a boundary appears as an edge."""
    methods = {"rula": load_method("rula"), "reba": load_method("reba")}
    expected = {
        ("rula", "upper_arm"): {-20, 20, 45, 90},
        ("rula", "lower_arm"): {60, 100},
        ("rula", "wrist"): {-15, 0, 15},
        ("rula", "neck"): {0, 10, 20},
        ("rula", "trunk"): {0, 20, 60},
        ("reba", "neck"): {0, 20},
        ("reba", "trunk"): {-20, 0, 20, 60},
        ("reba", "knee"): {30, 60},
        ("reba", "upper_arm"): {-20, 20, 45, 90},
        ("reba", "lower_arm"): {60, 100},
        ("reba", "wrist"): {-15, 15},
    }
    for (m, part), edges in expected.items():
        assert set(methods[m].bands[part].edges_deg) == edges, (m, part)
    assert list(methods["rula"].load.edges_kg) == [2, 10] and list(methods["reba"].load.edges_kg) == [5, 10]
