"""Session folders: load_session reads a valid one and refuses each kind of defect with one clear error."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import cv2
import numpy as np
import pytest

from ergopose.errors import ConfigError, InputError
from ergopose.geometry.calibration_file import save_calibration
from ergopose.session import TaskFactors, load_session, settings_to_toml
from ergopose.sim.scene import rig_cameras

W, H = 160, 120
START = dt.datetime(2024, 3, 4, 8, 0, 0, tzinfo=dt.timezone(dt.timedelta(hours=1)))


def write_video(path: Path, frames: int, size=(W, H), fps: float = 12.0) -> None:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, size)
    assert writer.isOpened()
    rng = np.random.default_rng(frames)
    for k in range(frames):
        img = np.full((size[1], size[0], 3), 40 + 10 * k % 200, np.uint8)
        img[rng.integers(0, size[1], 50), rng.integers(0, size[0], 50)] = 255
        writer.write(img)
    writer.release()


SETTINGS = """\
format_version = 1
recorded_at = 2024-03-04T08:00:00+01:00
fps = 12.0
description = "test"

[[cameras]]
name = "cam_2"
video = "b.mp4"

[[cameras]]
name = "cam_1"
video = "a.mp4"

[defaults]
load_kg = 1.0
coupling = "good"

[[periods]]
start = 0.5
end = 08:00:01
load_kg = 3.0

[workers.w1]
name = "Anna"
seated = true

[[workers.w1.periods]]
start = 2024-03-04T08:00:00.25+01:00
end = 0.75
load_kg = 9.0
load_mode = "static"
"""


def make_session(root: Path, frames=(12, 12), sizes=((W, H), (W, H)), settings: str = SETTINGS) -> Path:
    root.mkdir(parents=True, exist_ok=True)
    save_calibration(root / "calibration.toml", rig_cameras(W, H))
    write_video(root / "a.mp4", frames[0], sizes[0])
    write_video(root / "b.mp4", frames[1], sizes[1])
    (root / "settings.toml").write_text(settings, encoding="utf-8")
    return root


def test_valid_session_keeps_camera_order_and_reads_everything(tmp_path):
    s = load_session(make_session(tmp_path / "s"))
    assert s.camera_names == ("cam_2", "cam_1")  # as listed, never sorted
    assert [c.video_path.name for c in s.cameras] == ["b.mp4", "a.mp4"]
    assert s.cameras[0].camera.name == "cam_2" and s.cameras[0].camera.width == W
    assert s.frame_count == 12 and s.fps == 12.0 and s.duration_s == pytest.approx(1.0)
    assert s.recorded_at == START
    assert s.ground_truth_dir is None
    assert s.display_name("w1") == "Anna" and s.display_name("w7") == "w7"
    assert s.clock_time(30.0) == START + dt.timedelta(seconds=30)


def test_task_factors_most_specific_wins(tmp_path):
    s = load_session(make_session(tmp_path / "s"))
    assert s.factors_at("w1", 0.1) == TaskFactors(load_kg=1.0, coupling="good", seated=True)
    # worker period (0.25 .. 0.75 s) beats the period for everyone (0.5 .. 1.0 s)
    assert s.factors_at("w1", 0.6) == TaskFactors(load_kg=9.0, load_mode="static", coupling="good", seated=True)
    assert s.factors_at("w1", 0.8).load_kg == 3.0
    assert s.factors_at("w2", 0.6) == TaskFactors(load_kg=3.0, coupling="good")
    table = s.factor_table("w1", s.times_s)
    assert list(table["load_kg"]) == [1.0] * 3 + [9.0] * 6 + [3.0] * 3
    assert table["load_mode"].isna().sum() == 6 and (table["load_mode"].dropna() == "static").all()
    assert (table["seated"] == 1.0).all() and table["shock"].isna().all()
    assert (table["coupling"] == "good").all()


def test_written_settings_read_back(tmp_path):
    from ergopose.session import FactorPeriod, WorkerInfo

    text = settings_to_toml(
        recorded_at=START,
        fps=12.0,
        cameras=[("cam_1", "a.mp4"), ("cam_2", "b.mp4")],
        defaults=TaskFactors(load_kg=0.0, shock=False),
        workers=[
            WorkerInfo("w1", "Bo", TaskFactors(coupling="fair"), (FactorPeriod(0.1, 0.4, TaskFactors(load_kg=12.5)),))
        ],
    )
    s = load_session(make_session(tmp_path / "s", settings=text))
    assert s.camera_names == ("cam_1", "cam_2")
    assert s.factors_at("w1", 0.2) == TaskFactors(load_kg=12.5, coupling="fair", shock=False)
    assert s.worker("w1").name == "Bo"


def _error(tmp_path, exc_type, **kwargs) -> str:
    root = make_session(tmp_path / "s", **kwargs)
    with pytest.raises(exc_type) as info:
        load_session(root)
    message = str(info.value)
    assert "\n" not in message
    return message


def test_unknown_key_is_named_with_a_suggestion(tmp_path):
    msg = _error(tmp_path, ConfigError, settings=SETTINGS.replace("seated = true", "seatd = true"))
    assert "settings.toml" in msg and "workers.w1.seatd" in msg and "did you mean 'seated'" in msg


def test_unknown_top_level_key(tmp_path):
    msg = _error(tmp_path, ConfigError, settings=SETTINGS.replace("fps = 12.0", "fps = 12.0\nframe_rate = 12"))
    assert "frame_rate" in msg and "unknown key" in msg


def test_wrong_types_are_named(tmp_path):
    msg = _error(tmp_path, ConfigError, settings=SETTINGS.replace("load_kg = 1.0", 'load_kg = "heavy"'))
    assert "defaults.load_kg" in msg and "expected a number" in msg
    msg = _error(tmp_path, ConfigError, settings=SETTINGS.replace('coupling = "good"', 'coupling = "ok"'))
    assert "defaults.coupling" in msg and "good, fair, poor, unacceptable" in msg
    msg = _error(tmp_path, ConfigError, settings=SETTINGS.replace("seated = true", "seated = 1"))
    assert "workers.w1.seated" in msg and "true or false" in msg


def test_missing_files(tmp_path):
    root = make_session(tmp_path / "s")
    (root / "a.mp4").unlink()
    with pytest.raises(InputError, match=r"a\.mp4: video file not found"):
        load_session(root)
    (root / "settings.toml").unlink()
    with pytest.raises(ConfigError, match=r"settings\.toml: the settings file does not exist"):
        load_session(root)
    with pytest.raises(InputError, match="does not exist"):
        load_session(tmp_path / "nowhere")


def test_missing_calibration(tmp_path):
    root = make_session(tmp_path / "s")
    (root / "calibration.toml").unlink()
    with pytest.raises(ConfigError, match=r"calibration\.toml: the calibration file does not exist"):
        load_session(root)


def test_corrupt_video(tmp_path):
    root = make_session(tmp_path / "s")
    (root / "b.mp4").write_bytes(b"this is not a video" * 100)
    with pytest.raises(InputError, match=r"b\.mp4: cannot open the video"):
        load_session(root)


def test_truncated_video(tmp_path):
    root = make_session(tmp_path / "s")
    data = (root / "a.mp4").read_bytes()
    (root / "a.mp4").write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match=r"a\.mp4"):
        load_session(root)


def test_mismatched_frame_counts(tmp_path):
    msg = _error(tmp_path, InputError, frames=(12, 10))
    assert "different numbers of frames" in msg and "b.mp4: 10" in msg and "a.mp4: 12" in msg


def test_calibration_size_differs_from_video(tmp_path):
    msg = _error(tmp_path, ConfigError, sizes=((W, H), (2 * W, 2 * H)))
    assert "calibration.toml" in msg and "cam_2" in msg and f"{W} x {H}" in msg and f"{2 * W} x {2 * H}" in msg


def test_camera_missing_from_calibration(tmp_path):
    msg = _error(tmp_path, ConfigError, settings=SETTINGS.replace('name = "cam_1"', 'name = "cam_9"'))
    assert "cameras[1].name" in msg and "cam_9" in msg and "calibration.toml" in msg


def test_fps_disagreeing_with_the_videos(tmp_path):
    msg = _error(tmp_path, ConfigError, settings=SETTINGS.replace("fps = 12.0", "fps = 25.0"))
    assert "settings.toml: fps" in msg and "12" in msg


def test_period_problems(tmp_path):
    bad_order = SETTINGS.replace("start = 0.5\nend = 08:00:01", "start = 0.9\nend = 0.2")
    assert "periods[0]" in _error(tmp_path / "a", ConfigError, settings=bad_order)
    outside = SETTINGS.replace("start = 0.5\nend = 08:00:01", "start = 30.0\nend = 40.0")
    assert "outside the recording" in _error(tmp_path / "b", ConfigError, settings=outside)
    overlap = SETTINGS + "\n[[workers.w1.periods]]\nstart = 0.5\nend = 0.9\nload_kg = 1.0\n"
    assert "overlaps workers.w1.periods[0]" in _error(tmp_path / "c", ConfigError, settings=overlap)
    text_time = SETTINGS.replace("end = 08:00:01", 'end = "08:00:01"')
    assert "clock time" in _error(tmp_path / "d", ConfigError, settings=text_time)


def test_version_and_structure(tmp_path):
    msg = _error(tmp_path / "a", ConfigError, settings=SETTINGS.replace("format_version = 1", "format_version = 2"))
    assert "format_version" in msg and "unsupported" in msg
    no_camera = (
        SETTINGS.replace('[[cameras]]\nname = "cam_1"\nvideo = "a.mp4"\n', "")
        .replace('[[cameras]]\nname = "cam_2"\nvideo = "b.mp4"\n', "")
        .replace('description = "test"', 'description = "test"\ncameras = []')
    )
    assert "at least one [[cameras]]" in _error(tmp_path / "b", ConfigError, settings=no_camera)
    assert "not valid TOML" in _error(tmp_path / "c", ConfigError, settings=SETTINGS + "\n[[oops\n")


def test_one_camera_is_a_session(tmp_path):
    """1 to N calibrated cameras: a session with one of the two calibrated cameras loads."""
    one_camera = SETTINGS.replace('[[cameras]]\nname = "cam_1"\nvideo = "a.mp4"\n', "")
    session = load_session(make_session(tmp_path / "one", settings=one_camera))
    assert session.camera_names == ("cam_2",)


def test_scoring_table_is_checked(tmp_path):
    ok = load_session(make_session(tmp_path / "a", settings=SETTINGS + "\n[scoring]\nrula_static_hold_s = 600.0\n"))
    assert ok.scoring == {"rula_static_hold_s": 600.0}
    msg = _error(tmp_path / "b", ConfigError, settings=SETTINGS + "\n[scoring]\nrula_static_hold = 600.0\n")
    assert "settings.toml" in msg and "rula_static_hold" in msg


WRIST_SETTINGS = SETTINGS.replace('coupling = "good"\n', 'coupling = "good"\nwrist_flexion_deg = -20.0\n').replace(
    'load_mode = "static"\n', 'load_mode = "static"\nwrist_flexion_deg = 35\nwrist_deviation_deg = 10.0\n'
)


def test_wrist_posture_is_read_in_degrees_and_held_in_radians(tmp_path):
    s = load_session(make_session(tmp_path / "s", settings=WRIST_SETTINGS))
    assert s.defaults.wrist_flexion == pytest.approx(np.radians(-20.0)) and s.defaults.wrist_deviation is None
    at = s.factors_at("w1", 0.6)  # the worker's period (0.25 .. 0.75 s) gives both angles
    assert at.wrist_flexion == pytest.approx(np.radians(35.0)) and at.wrist_deviation == pytest.approx(np.radians(10.0))
    table = s.task_angles("w1", s.times_s)  # frames at 0, 1/12, ... 11/12 s
    assert list(table.columns) == ["wrist_flexion", "wrist_deviation"]
    np.testing.assert_allclose(np.degrees(table["wrist_flexion"]), [-20.0] * 3 + [35.0] * 6 + [-20.0] * 3)
    dev = np.degrees(table["wrist_deviation"].to_numpy())
    assert np.isnan(dev[:3]).all() and np.isnan(dev[9:]).all() and np.allclose(dev[3:9], 10.0)
    assert "wrist_flexion" not in s.factor_table("w1", s.times_s).columns  # not a posture-table input
    assert np.isnan(load_session(make_session(tmp_path / "plain")).task_angles("w1", [0.0]).to_numpy()).all()


def test_written_wrist_posture_reads_back_in_degrees(tmp_path):
    from ergopose.session import FactorPeriod, WorkerInfo

    defaults = TaskFactors(wrist_flexion=float(np.radians(-20.0)))
    text = settings_to_toml(
        recorded_at=START,
        fps=12.0,
        cameras=[("cam_1", "a.mp4"), ("cam_2", "b.mp4")],
        defaults=defaults,
        workers=[
            WorkerInfo(
                "w1",
                None,
                TaskFactors(wrist_deviation=float(np.radians(-5.0))),
                (FactorPeriod(0.1, 0.4, TaskFactors(wrist_flexion=0.0)),),
            )
        ],
    )
    assert "wrist_flexion_deg = -20.0" in text and "wrist_deviation_deg = -5.0" in text
    s = load_session(make_session(tmp_path / "s", settings=text))
    assert s.factors_at("w1", 0.5) == TaskFactors(
        wrist_flexion=pytest.approx(np.radians(-20.0)), wrist_deviation=pytest.approx(np.radians(-5.0))
    )
    assert s.factors_at("w1", 0.2).wrist_flexion == 0.0


@pytest.mark.parametrize(
    "line, field, words",
    [
        ("wrist_flexion_deg = 95.0", "defaults.wrist_flexion_deg", "from -90 to 90"),
        ("wrist_deviation_deg = -90.5", "defaults.wrist_deviation_deg", "from -90 to 90"),
        ('wrist_flexion_deg = "20"', "defaults.wrist_flexion_deg", "expected a number"),
        ("wrist_flexion_deg = true", "defaults.wrist_flexion_deg", "expected a number"),
        ("wrist_flexion = 20.0", "defaults.wrist_flexion", "did you mean 'wrist_flexion_deg'"),
    ],
)
def test_bad_wrist_posture_is_named(tmp_path, line, field, words):
    msg = _error(
        tmp_path, ConfigError, settings=SETTINGS.replace('coupling = "good"\n', f'coupling = "good"\n{line}\n')
    )
    assert "settings.toml" in msg and field in msg and words in msg


def test_wrist_posture_in_a_period_is_checked_and_may_be_the_only_factor(tmp_path):
    msg = _error(tmp_path, ConfigError, settings=SETTINGS.replace("load_kg = 3.0", "wrist_deviation_deg = 120"))
    assert "periods[0].wrist_deviation_deg" in msg and "from -90 to 90" in msg
    s = load_session(
        make_session(tmp_path / "ok", settings=SETTINGS.replace("load_kg = 3.0", "wrist_flexion_deg = 15"))
    )
    assert s.periods[0].factors == TaskFactors(wrist_flexion=pytest.approx(np.radians(15.0)))
