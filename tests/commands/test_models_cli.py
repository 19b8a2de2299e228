"""``ergopose models``: one clear line and exit code 2 for every problem with the cache.

(The real download and the success paths run in tests/pose/test_models.py, which has the
session's fetched models.)"""

from __future__ import annotations

import hashlib
import zipfile

import pytest

from ergopose import cli
from ergopose.pose.models import DEFAULT_LANDMARK_MODEL, MODEL_CARDS, POSE_COMMAND_MODEL


def _run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_models_is_a_registered_command(capsys):
    with pytest.raises(SystemExit):
        cli.main(["--help"])
    assert "models" in capsys.readouterr().out
    code, out, _ = _run(capsys, "models")
    assert code == 0 and "fetch" in out and "verify" in out


def test_list_on_an_empty_cache_shows_the_cards(tmp_path, capsys):
    code, out, err = _run(capsys, "models", "list", "--model-dir", str(tmp_path))
    assert code == 0 and err == ""
    for name, card in MODEL_CARDS.items():
        assert f"{name}  [missing]" in out
        assert card.file.sha256 in out
    assert out.count("Apache-2.0") == 4 and "mediapipe==0.10.14 wheel (PyPI)" in out
    assert out.count("@mediapipe/pose@0.5.1675469404 package tarball (npm)") == 2
    # The landmark cards say which --model picks them and which is the default, and their gates.
    # (assess: full, for its real-time budget; pose: heavy, which keeps left and right best).
    assert DEFAULT_LANDMARK_MODEL == "full" and POSE_COMMAND_MODEL == "heavy"
    assert "blazepose_landmark_heavy  [missing]  (--model heavy, the default of pose)" in out
    assert "blazepose_landmark_full  [missing]  (--model full, the default of assess)" in out
    assert "blazepose_landmark_lite  [missing]  (--model lite)\n" in out
    assert out.count("  gates    person when the pose flag >= ") == 3


def test_verify_on_an_empty_cache_says_to_fetch(tmp_path, capsys):
    code, out, err = _run(capsys, "models", "verify", "--model-dir", str(tmp_path))
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("ergopose: error: ")
    assert "run 'ergopose models fetch'" in err and "3 more problem" in err


def test_verify_refuses_a_changed_file(tmp_path, capsys):
    (tmp_path / "pose_detection.tflite").write_bytes(b"edited model" * 1000)
    code, out, err = _run(capsys, "models", "verify", "blazepose_detector", "--model-dir", str(tmp_path))
    assert code == 2 and err.count("\n") == 1
    digest = hashlib.sha256(b"edited model" * 1000).hexdigest()
    assert f"SHA-256 {digest[:12]}" in err and "ergopose models fetch --force" in err
    assert str(tmp_path / "pose_detection.tflite") in err


def test_fetch_from_a_wrong_wheel_fails_in_one_line(tmp_path, capsys):
    wheel = tmp_path / "mediapipe-0.10.14-x.whl"
    with zipfile.ZipFile(wheel, "w") as z:
        for card in MODEL_CARDS.values():
            z.writestr(card.file.path_in_source, b"other bytes")
    code, out, err = _run(capsys, "models", "fetch", "--wheel", str(wheel), "--model-dir", str(tmp_path / "c"))
    # a progress line may come first; the error is one line, without a traceback
    errors = [line for line in err.splitlines() if line.startswith("ergopose: error: ")]
    assert code == 2 and len(errors) == 1 and "SHA-256" in errors[0] and "Traceback" not in err
    assert not (tmp_path / "c").exists() or not any((tmp_path / "c").iterdir())
    code, _, err = _run(capsys, "models", "fetch", "nonsense", "--model-dir", str(tmp_path / "c"))
    assert code == 2 and "unknown model 'nonsense'" in err


def test_user_onnx_cards_are_listed_and_verified(tmp_path, capsys):
    folder = tmp_path / "onnx"
    folder.mkdir()
    model = folder / "mine.onnx"
    model.write_bytes(b"pretend onnx bytes")
    digest = hashlib.sha256(model.read_bytes()).hexdigest()
    (folder / "mine.toml").write_text(
        f'name = "mine"\nfile = "mine.onnx"\nsha256 = "{digest}"\nlicence = "MIT"\nsource = "my lab"\n'
        "[input]\nwidth = 192\nheight = 256\nmean = [0, 0, 0]\nstd = [1, 1, 1]\n"
        '[output]\ntype = "simcc"\nkeypoints = "coco17"\n',
        encoding="utf-8",
    )
    code, out, _ = _run(capsys, "models", "list", "--model-dir", str(tmp_path))
    assert code == 0 and "mine  [ok]  (your ONNX model)" in out and "17 keypoints (17 in the ergopose schema)" in out
    model.write_bytes(b"changed")
    code, out, err = _run(capsys, "models", "list", "--model-dir", str(tmp_path))
    assert "mine  [corrupt]" in out
    code, out, err = _run(capsys, "models", "verify", "--model-dir", str(tmp_path))
    assert code == 2 and "(and 4 more problem(s))" in err  # four BlazePose files missing too
