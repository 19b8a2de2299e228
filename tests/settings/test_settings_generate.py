"""What the settings model writes: the settings template (it loads; every key set, it round-trips
to the same Session), the settings files of 'session new', and docs/settings.md (held to the model)."""

from __future__ import annotations

import datetime as dt
import re
import tomllib
from pathlib import Path

import pytest

from ergopose import cli
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.geometry.calibration_file import save_calibration
from ergopose.pose.settings import PoseSettings
from ergopose.recon.settings import ReconSettings
from ergopose.session import Identification, TaskFactors, load_session
from ergopose.settings.generate import settings_markdown, settings_text
from ergopose.settings.model import SettingsFile, read_settings
from ergopose.settings.tasks import FACTOR_KEYS
from ergopose.sim.scene import rig_cameras
from tests.test_session_format import H, W, write_video

REPO = Path(__file__).resolve().parents[2]
#: A commented key or table line of the generated text (explanations are indented: '#   ...').
KEY_LINE = re.compile(r"^# (\[\[?[\w.<>-]+\]\]?|[A-Za-z_]\w* = .*)$")


def set_every_key(text: str) -> str:
    """The text with every commented key and table line set."""
    return "\n".join(line[2:] if KEY_LINE.match(line) else line for line in text.splitlines()) + "\n"


def session_with(root: Path, text: str) -> Path:
    root.mkdir(parents=True)
    save_calibration(root / "calibration.toml", rig_cameras(W, H))
    write_video(root / "cam_1.mp4", 12)
    write_video(root / "cam_2.mp4", 12)
    (root / "reference_bars.csv").write_text("measurement,camera,end,u,v\n", encoding="utf-8")
    (root / "settings.toml").write_text(text, encoding="utf-8")
    return root


def test_docs_settings_md_is_what_the_model_generates():
    doc = (REPO / "docs" / "settings.md").read_text(encoding="utf-8")
    assert doc == settings_markdown(), "docs/settings.md is out of date: run python -m ergopose.settings"


def test_every_key_is_in_the_docs_and_the_template():
    """Every key of every table has a row in docs/settings.md and a line in the template (the task
    factors in [defaults]; periods and workers refer to them)."""
    doc, data = settings_markdown(), tomllib.loads(set_every_key(settings_text()))

    def walk(model, table, path):
        for name, info in model.model_fields.items():
            factor_elsewhere = name in FACTOR_KEYS and path != "defaults."
            assert factor_elsewhere or f"| `{name}` |" in doc, f"{path}{name} is not in docs/settings.md"
            assert factor_elsewhere or name in table, f"{path}{name} is not in the template"
            inner = table.get(name)
            if isinstance(inner, list):
                inner = inner[0]
            if isinstance(inner, dict) and name == "workers":
                inner = next(iter(inner.values()))
            sub = [
                a for a in (info.annotation, *getattr(info.annotation, "__args__", ())) if hasattr(a, "model_fields")
            ]
            if sub and isinstance(inner, dict):
                walk(sub[0], inner, f"{path}{name}.")

    walk(SettingsFile, data, "")
    assert set(data["defaults"]) == set(FACTOR_KEYS)


def test_the_template_loads_and_gives_the_defaults(tmp_path):
    s = load_session(session_with(tmp_path / "s", settings_text()))
    assert s.camera_names == ("cam_1", "cam_2")
    assert s.recorded_at == dt.datetime(2024, 3, 4, 8, 0, tzinfo=dt.timezone(dt.timedelta(hours=1)))
    assert s.defaults == TaskFactors() and s.periods == () and s.workers == () and s.scoring == {}
    assert s.pose == PoseSettings() and s.reconstruction == ReconSettings() and s.identification == Identification()


def test_the_template_with_every_key_set_round_trips_to_the_same_session(tmp_path):
    full = set_every_key(settings_text())
    a = load_session(session_with(tmp_path / "a", full))
    # every default written out is the default
    assert a.pose == PoseSettings() and a.reconstruction == ReconSettings() and a.identification == Identification()
    assert ScoringSettings(**a.scoring) == ScoringSettings() and len(a.scoring) == len(ScoringSettings().as_dict())
    assert a.defaults.given().keys() == TaskFactors.__dataclass_fields__.keys()
    assert a.workers[0].stature_m == 1.75 and a.periods[0].factors == TaskFactors(load_kg=12.0)
    assert a.calibration_check is not None and a.fps == 12.0 and a.description == "Line 3, early shift"
    # the model's values written again by the generator read back as the same session
    model, _ = read_settings(tmp_path / "a" / "settings.toml")
    again = settings_text(model.model_dump(exclude_unset=True))
    b = load_session(session_with(tmp_path / "b", again))
    for field in (
        "recorded_at",
        "fps",
        "description",
        "camera_names",
        "defaults",
        "periods",
        "workers",
        "scoring",
        "identification",
        "pose",
        "reconstruction",
        "format_version",
    ):
        assert getattr(a, field) == getattr(b, field), field
    assert read_settings(tmp_path / "b" / "settings.toml")[0] == model


def test_settings_template_command(tmp_path, capsys):
    out = tmp_path / "settings.toml"
    assert cli.main(["settings", "template", "--out", str(out)]) == 0
    assert out.read_text(encoding="utf-8") == settings_text()
    assert cli.main(["settings", "template", "--out", str(out)]) == 2  # never overwrites
    assert "already exists" in capsys.readouterr().err
    assert cli.main(["settings", "template"]) == 0
    assert capsys.readouterr().out == settings_text()


def test_settings_module_checks_the_docs(tmp_path):
    from ergopose.settings.__main__ import main

    target = tmp_path / "settings.md"
    assert main([str(target), "--check"]) == 1
    assert main([str(target)]) == 0 and main([str(target), "--check"]) == 0
    assert target.read_text(encoding="utf-8") == settings_markdown()


@pytest.mark.parametrize("key", ["fit_turn_rate_deg_s", "max_body_roll_deg", "wrist_flexion_deg"])
def test_degrees_at_the_edge(key):
    assert f"`{key}`" in settings_markdown() and "(degrees" in settings_markdown()
