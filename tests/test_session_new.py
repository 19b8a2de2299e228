"""``ergopose session new DIR --calibration FILE VIDEO...`` on the real Pose2Sim recording
(../shared/data/pose2sim-demo: 4 videos, Calib_qualisys.toml) and on small synthetic videos for
each kind of bad input."""

from __future__ import annotations

import tomllib
from pathlib import Path

import cv2
import numpy as np
import pytest

from ergopose import cli
from ergopose.geometry.calibration_file import load_calibration, save_calibration
from ergopose.session import load_session
from ergopose.sim.scene import rig_cameras

W, H = 160, 120


@pytest.fixture(scope="module")
def demo(shared_data):
    return shared_data / "pose2sim-demo"


def videos(demo, *numbers):
    return [str(demo / "videos" / f"cam0{n}.mp4") for n in numbers]


@pytest.mark.slow
def test_four_cameras_from_a_pose2sim_calibration(demo, tmp_path, capsys):
    root = tmp_path / "s"
    code = cli.main(
        [
            "session",
            "new",
            str(root),
            "--calibration",
            str(demo / "Calib_qualisys.toml"),
            *videos(demo, 1, 2, 3, 4),
            "--recorded-at",
            "2024-02-28T10:00:00+01:00",
        ]
    )
    out = capsys.readouterr().out
    assert code == 0, out
    session = load_session(root)
    assert session.camera_names == ("cam_01", "cam_02", "cam_03", "cam_04")
    assert session.frame_count == 100 and session.fps == pytest.approx(60.0)
    # cam01/cam02 are 1080 wide, calibrated as 1088 (encoder padding to 16): cropped, intrinsics kept.
    cams = load_calibration(root / "calibration.toml")
    assert [(c.width, c.height) for c in cams] == [(1080, 1920), (1080, 1920), (1088, 1920), (1088, 1920)]
    assert cams[0].lens.cx == pytest.approx(532.97369384375)
    assert out.count("encoder padding") == 2
    text = (root / "settings.toml").read_text()
    assert text.startswith("# ergopose session settings") and "# [defaults]" in text
    settings = tomllib.loads(text)
    assert [c["video"] for c in settings["cameras"]] == ["cam_01.mp4", "cam_02.mp4", "cam_03.mp4", "cam_04.mp4"]
    # Videos in the order given: cam_03's video really is cam03.mp4.
    assert (root / "cam_03.mp4").read_bytes() == (demo / "videos" / "cam03.mp4").read_bytes()


@pytest.mark.slow
def test_a_camera_pair_with_cameras_and_links(demo, tmp_path):
    root = tmp_path / "pair"
    assert (
        cli.main(
            [
                "session",
                "new",
                str(root),
                "--calibration",
                str(demo / "Calib_qualisys.toml"),
                "--cameras",
                "cam_04,cam_02",
                *videos(demo, 4, 2),
                "--link",
            ]
        )
        == 0
    )
    session = load_session(root)
    assert session.camera_names == ("cam_04", "cam_02")
    assert (root / "cam_04.mp4").is_symlink()
    assert "modification time" in (root / "settings.toml").read_text()


def test_count_mismatch_and_bad_cameras(demo, tmp_path, capsys):
    calibration = str(demo / "Calib_qualisys.toml")
    assert cli.main(["session", "new", str(tmp_path / "a"), "--calibration", calibration, *videos(demo, 1, 2, 3)]) == 2
    err = capsys.readouterr().err
    assert err.count("ergopose: error") == 1 and "4 camera(s)" in err and "3 video(s)" in err
    assert not (tmp_path / "a").exists()
    assert (
        cli.main(
            [
                "session",
                "new",
                str(tmp_path / "b"),
                "--calibration",
                calibration,
                "--cameras",
                "cam_9",
                *videos(demo, 1),
            ]
        )
        == 2
    )
    assert "--cameras" in capsys.readouterr().err


def write_video(path: Path, frames: int, fps: float = 12.0, size=(W, H)) -> str:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, size)
    assert writer.isOpened()
    for k in range(frames):
        writer.write(np.full((size[1], size[0], 3), 20 + 7 * k % 200, np.uint8))
    writer.release()
    return str(path)


@pytest.mark.parametrize(
    "case, message",
    [
        ("rates", "different frame rates"),
        ("lengths", "different numbers of frames"),
        ("unreadable", "cannot open"),
        ("size", "calibrated for 160 x 120"),
    ],
)
def test_bad_videos_give_one_clear_line(tmp_path, capsys, case, message):
    calibration = save_calibration(tmp_path / "cal.toml", rig_cameras(W, H))
    a = write_video(tmp_path / "a.mp4", 12)
    if case == "rates":
        b = write_video(tmp_path / "b.mp4", 12, fps=25.0)
    elif case == "lengths":
        b = write_video(tmp_path / "b.mp4", 14)
    elif case == "unreadable":
        b = tmp_path / "b.mp4"
        b.write_text("not a video")
    else:
        b = write_video(tmp_path / "b.mp4", 12, size=(W // 2, H // 2))
    root = tmp_path / "s"
    assert cli.main(["session", "new", str(root), "--calibration", str(calibration), a, str(b)]) == 2
    err = capsys.readouterr().err
    assert err.count("ergopose: error") == 1 and message in err and "Traceback" not in err
    assert not root.exists()


def test_existing_folder_is_refused(tmp_path, capsys):
    calibration = save_calibration(tmp_path / "cal.toml", rig_cameras(W, H))
    a, b = write_video(tmp_path / "a.mp4", 12), write_video(tmp_path / "b.mp4", 12)
    root = tmp_path / "s"
    assert cli.main(["session", "new", str(root), "--calibration", str(calibration), a, b]) == 0
    assert load_session(root).camera_names == tuple(c.name for c in rig_cameras(W, H))
    assert cli.main(["session", "new", str(root), "--calibration", str(calibration), a, b]) == 2
    assert "already exists" in capsys.readouterr().err


def test_the_same_video_for_two_cameras(tmp_path, capsys):
    calibration = save_calibration(tmp_path / "cal.toml", rig_cameras(W, H))
    a = write_video(tmp_path / "a.mp4", 12)
    assert cli.main(["session", "new", str(tmp_path / "s"), "--calibration", str(calibration), a, a]) == 2
    err = capsys.readouterr().err
    assert err.count("ergopose: error") == 1 and "same video" in err


def test_the_commented_task_factors_are_valid_settings(tmp_path):
    """Uncommented, the [defaults] block of a new settings.toml (written by the settings model's
    generator) reads as task factors, the wrist posture in degrees included."""
    from ergopose.session import FACTOR_KEYS, TaskFactors, task_factors
    from ergopose.settings.base import validate
    from ergopose.settings.generate import settings_text
    from ergopose.settings.tasks import TaskFactorsTable

    text = settings_text()
    block = text.split("# [defaults]\n", 1)[1].split("\n\n", 1)[0]
    table = tomllib.loads("\n".join(line[2:] for line in block.splitlines() if not line.startswith("#   ")))
    assert set(table) == set(FACTOR_KEYS) and {"wrist_flexion_deg", "wrist_deviation_deg"} <= set(table)
    factors = task_factors(validate(TaskFactorsTable, table, path=Path("settings.toml"), prefix=("defaults",)))
    assert factors.wrist_flexion == pytest.approx(np.radians(table["wrist_flexion_deg"]))
    assert isinstance(factors, TaskFactors) and factors.load_kg == table["load_kg"]
