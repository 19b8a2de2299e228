"""``ergopose camera show | import-opencv`` through ergopose.cli.main."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from ergopose import cli
from ergopose.geometry.calibration_file import load_calibration, save_calibration
from ergopose.geometry.camera import Camera, ceiling_camera, look_at_rotation
from ergopose.geometry.lenses import Equidistant, KannalaBrandt, Rectilinear

#: The JY left calibration (../shared/data/opencv-fisheye-stereo-jy/SOURCE.md), 1280 x 800.
JY_K = np.array([[558.478087865323, 0, 620.458515360843], [0, 560.506767351568, 381.939424848348], [0, 0, 1]])
JY_D = np.array([-0.0014613319981768, -0.00329861110580401, 0.00605760088590183, -0.00374209380722371])


def test_show_prints_one_line_per_camera_in_file_order(tmp_path, capsys):
    cameras = [
        ceiling_camera("cam_2", Equidistant(300.0, 300.0, 599.5, 599.5), 1200, 1200, [0.0, 0.0, 3.0]),
        Camera(
            "cam_10",
            Rectilinear.from_fov(640, 480, np.radians(90)),
            640,
            480,
            look_at_rotation([1.0, 0.0, -1.0]),
            [-1.5, 2.0, 2.5],
        ),
    ]
    path = save_calibration(tmp_path / "calibration.toml", cameras)
    assert cli.main(["camera", "show", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2
    assert lines[0].startswith("cam_2: equidistant, 1200x1200 px, field of view 229.2 x 229.2 deg")
    assert "at (0.000, 0.000, 3.000) m" in lines[0] and "0.0 deg from straight down" in lines[0]
    assert lines[1].startswith("cam_10: rectilinear, 640x480 px, field of view 90.0 x 73.7 deg")
    assert "at (-1.500, 2.000, 2.500) m, looking (+0.707, +0.000, -0.707), 45.0 deg from straight down" in lines[1]


def test_show_reports_a_bad_file_in_one_line(tmp_path, capsys):
    path = tmp_path / "calibration.toml"
    path.write_text("format_version = 1\n[[cameras]]\nname = 'cam_1'\nwidht = 3\n")
    assert cli.main(["camera", "show", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cameras[0].widht: unknown key" in err


def _kd_file(tmp_path, with_size=True):
    path = tmp_path / "left.yml"
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    storage.write("K", JY_K)
    storage.write("D", JY_D.reshape(4, 1))
    if with_size:
        storage.write("image_width", 1280)
        storage.write("image_height", 800)
    storage.release()
    return path


def test_import_opencv_builds_a_file_that_projects_like_cv2(tmp_path, capsys, rng):
    kd = _kd_file(tmp_path)
    out = tmp_path / "calibration.toml"
    assert cli.main(["camera", "import-opencv", "--K-D", str(kd), "--name", "cam_1", "--out", str(out)]) == 0
    assert "identity pose" in capsys.readouterr().out
    (camera,) = load_calibration(out)
    assert (camera.width, camera.height) == (1280, 800)
    points = rng.uniform([-2, -2, 0.3], [2, 2, 4], size=(200, 3))
    expected, _ = cv2.fisheye.projectPoints(points.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), JY_K, JY_D)
    np.testing.assert_allclose(camera.project_world(points), expected[:, 0], atol=1e-6)
    # A second camera is appended (order kept), on the ceiling, with the size given explicitly.
    assert (
        cli.main(
            [
                "camera",
                "import-opencv",
                "--K-D",
                str(kd),
                "--name",
                "cam_0",
                "--size",
                "1280x800",
                "--position=-1.5,0.5,3",
                "--yaw",
                "90",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    cameras = load_calibration(out)
    assert [c.name for c in cameras] == ["cam_1", "cam_0"]
    np.testing.assert_array_equal(cameras[1].position_world, [-1.5, 0.5, 3.0])
    np.testing.assert_allclose(cameras[1].axis_world, [0, 0, -1])
    np.testing.assert_allclose(cameras[1].rotation_world_from_cam[:, 0], [0, 1, 0], atol=1e-15)
    assert isinstance(cameras[1].lens, KannalaBrandt)


def test_import_opencv_errors(tmp_path, capsys):
    kd = _kd_file(tmp_path, with_size=False)
    out = tmp_path / "calibration.toml"
    args = ["camera", "import-opencv", "--K-D", str(kd), "--name", "cam_1", "--out", str(out)]
    assert cli.main(args) == 2
    assert "--size" in capsys.readouterr().err
    assert cli.main(args + ["--size", "1280x800"]) == 0
    assert cli.main(args + ["--size", "1280x800"]) == 2  # the name exists already
    assert "--replace" in capsys.readouterr().err
    assert cli.main(args + ["--size", "1280x800", "--replace"]) == 0
    assert len(load_calibration(out)) == 1
    with pytest.raises(SystemExit) as exc:
        cli.main(args + ["--size", "1280*800"])
    assert exc.value.code == 2
