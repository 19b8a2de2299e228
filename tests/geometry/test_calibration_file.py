"""The calibration file: round trip, file order, one clear error per defect, OpenCV import."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import cv2
import numpy as np
import pytest
import tomli_w

from ergopose.errors import ConfigError
from ergopose.geometry.calibration_file import (
    FORMAT_VERSION,
    calibration_to_toml,
    camera_from_opencv_fisheye,
    load_calibration,
    read_opencv_fisheye_file,
    rotation_from_rodrigues,
    save_calibration,
)
from ergopose.geometry.camera import CalibrationInfo, Camera, ceiling_camera, look_at_rotation
from ergopose.geometry.lenses import DoubleSphere, Equidistant, KannalaBrandt, Rectilinear

_REPO = Path(__file__).resolve().parents[2]

#: The JY left calibration (../shared/data/opencv-fisheye-stereo-jy/SOURCE.md), 1280 x 800.
JY_K = np.array([[558.478087865323, 0, 620.458515360843], [0, 560.506767351568, 381.939424848348], [0, 0, 1]])
JY_D = np.array([-0.0014613319981768, -0.00329861110580401, 0.00605760088590183, -0.00374209380722371])


def two_cameras() -> list[Camera]:
    cam_2 = ceiling_camera("cam_2", KannalaBrandt.from_opencv(JY_K, JY_D), 1280, 800, [0.1, -0.2, 3.0], yaw=0.3)
    cam_10 = Camera(
        "cam_10",
        DoubleSphere(158.286, 158.274, 254.961, 256.889, -0.1721, 0.5931),
        512,
        512,
        look_at_rotation([0.2, 0.1, -1.0]),
        [1.5, 0.0, 2.9],
        CalibrationInfo(
            rms_error_px=0.2637,
            date="2024-05-01",
            method="cv2.fisheye.calibrate",
            notes='lens "B", re-focused\nafter cleaning',
        ),
    )
    return [cam_2, cam_10]


def write(tmp_path, data: dict) -> str:
    path = tmp_path / "calibration.toml"
    path.write_text(tomli_w.dumps(data))
    return str(path)


def base_dict() -> dict:
    return tomllib.loads(calibration_to_toml(two_cameras()))


def test_round_trip_keeps_every_number_and_the_file_order(tmp_path):
    cameras = two_cameras()
    path = save_calibration(tmp_path / "calibration.toml", cameras, description="line A, day 1")
    loaded = load_calibration(path)
    assert [c.name for c in loaded] == ["cam_2", "cam_10"]  # file order, not sorted by name
    assert loaded == tuple(cameras)
    # Reversed order stays reversed.
    save_calibration(path, cameras[::-1])
    assert [c.name for c in load_calibration(path)] == ["cam_10", "cam_2"]
    text = path.read_text()
    assert text.startswith("# ergopose camera calibration")
    assert f"format_version = {FORMAT_VERSION}" in text
    assert "[[cameras]]" in text and 'kind = "double_sphere"' in text


def test_every_lens_kind_round_trips(tmp_path):
    lenses = [
        Rectilinear(500, 501, 320, 240),
        Equidistant(300, 300, 599.5, 599.5),
        KannalaBrandt(620, 621, 1295.5, 971.5, 0.02, -0.01, 0.003, -0.0005),
    ]
    cameras = [ceiling_camera(f"c{i}", lens, 1280, 960, [i, 0, 3]) for i, lens in enumerate(lenses)]
    path = save_calibration(tmp_path / "c.toml", cameras)
    assert load_calibration(path) == tuple(cameras)


def test_rodrigues_pose_is_accepted(tmp_path):
    data = base_dict()
    rotation = np.array(data["cameras"][1]["pose"].pop("rotation_world_from_cam"))
    rvec, _ = cv2.Rodrigues(rotation)
    data["cameras"][1]["pose"]["rodrigues_world_from_cam"] = rvec.ravel().tolist()
    loaded = load_calibration(write(tmp_path, data))
    np.testing.assert_allclose(loaded[1].rotation_world_from_cam, rotation, atol=1e-12)
    np.testing.assert_allclose(
        rotation_from_rodrigues([0, 0, math.pi / 2]), [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15
    )
    np.testing.assert_array_equal(rotation_from_rodrigues([0, 0, 0]), np.eye(3))


def test_toml_dates_become_iso_text(tmp_path):
    text = calibration_to_toml(two_cameras()).replace('date = "2024-05-01"', "date = 2024-05-01")
    path = tmp_path / "c.toml"
    path.write_text(text)
    assert load_calibration(path)[1].calibration.date == "2024-05-01"


def _set(data, keys, value):
    node = data
    for key in keys[:-1]:
        node = node[key]
    if value is _DELETE:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value


_DELETE = object()

ERRORS = [
    # (where, new value, field named in the error, words in the message)
    (("format_version",), _DELETE, "format_version", "missing"),
    (("format_version",), 2, "format_version", "not supported"),
    (("format_version",), "1", "format_version", "whole number"),
    (("cameras",), _DELETE, "cameras", "missing"),
    (("cameras",), [], "cameras", "no cameras"),
    (("colour",), "red", "colour", "unknown key"),
    (("cameras", 1, "name"), _DELETE, "cameras[1].name", "missing"),
    (("cameras", 1, "name"), "cam_2", "cameras[1].name", "duplicate"),
    (("cameras", 1, "name"), 7, "cameras[1].name", "expected"),
    (("cameras", 1, "width"), _DELETE, "cameras[1].width", "missing"),
    (("cameras", 1, "width"), 0, "cameras[1].width", "positive"),
    (("cameras", 1, "height"), -480, "cameras[1].height", "positive"),
    (("cameras", 1, "width"), 512.0, "cameras[1].width", "whole number"),
    (("cameras", 1, "width"), "512", "cameras[1].width", "whole number"),
    (("cameras", 1, "widht"), 512, "cameras[1].widht", "unknown key"),
    (("cameras", 1, "lens"), _DELETE, "cameras[1].lens", "missing"),
    (("cameras", 1, "lens", "kind"), "fisheye", "cameras[1].lens.kind", "unknown lens kind"),
    (("cameras", 1, "lens", "kind"), _DELETE, "cameras[1].lens.kind", "missing"),
    (("cameras", 1, "lens", "xi"), _DELETE, "cameras[1].lens.xi", "missing"),
    (("cameras", 1, "lens", "fx"), "158", "cameras[1].lens.fx", "expected a number"),
    (("cameras", 1, "lens", "fx"), -158.0, "cameras[1].lens.fx", "fx > 0"),
    (("cameras", 1, "lens", "alpha"), 1.5, "cameras[1].lens.alpha", "alpha"),
    (("cameras", 1, "lens", "k1"), 0.1, "cameras[1].lens.k1", "unknown key"),
    (("cameras", 1, "pose"), _DELETE, "cameras[1].pose", "missing"),
    (("cameras", 1, "pose", "position_world"), _DELETE, "cameras[1].pose.position_world", "missing"),
    (("cameras", 1, "pose", "position_world"), [1.0, 2.0], "cameras[1].pose.position_world", "3 numbers"),
    (("cameras", 1, "pose", "position_world"), [1.0, "2", 3.0], "cameras[1].pose.position_world", "3 numbers"),
    (("cameras", 1, "pose", "positon_world"), [1.0, 2.0, 3.0], "cameras[1].pose.positon_world", "unknown key"),
    (
        ("cameras", 1, "pose", "rotation_world_from_cam"),
        _DELETE,
        "cameras[1].pose.rotation_world_from_cam",
        "exactly one",
    ),
    (
        ("cameras", 1, "pose", "rotation_world_from_cam"),
        [[2.0, 0, 0], [0, 2.0, 0], [0, 0, 2.0]],
        "cameras[1].pose.rotation_world_from_cam",
        "orthonormal",
    ),
    (
        ("cameras", 1, "pose", "rotation_world_from_cam"),
        [[1.0, 0, 0], [0, 1.0, 0], [0, 0, -1.0]],
        "cameras[1].pose.rotation_world_from_cam",
        "determinant",
    ),
    (
        ("cameras", 1, "pose", "rotation_world_from_cam"),
        [[1.0, 0, 0], [0, 1.0, 0]],
        "cameras[1].pose.rotation_world_from_cam",
        "3 rows of 3 numbers",
    ),
    (
        ("cameras", 1, "pose", "rodrigues_world_from_cam"),
        [0.0, 0.0, 0.1],
        "cameras[1].pose.rotation_world_from_cam",
        "exactly one",
    ),
    (("cameras", 1, "calibration", "rms"), 0.3, "cameras[1].calibration.rms", "unknown key"),
    (("cameras", 1, "calibration", "rms_error_px"), -0.3, "cameras[1].calibration.rms_error_px", ">= 0"),
    (("cameras", 1, "calibration", "notes"), 12, "cameras[1].calibration.notes", "text"),
]


@pytest.mark.parametrize("keys, value, field, words", ERRORS, ids=[f"{e[2]}-{e[3]}" for e in ERRORS])
def test_each_defect_gives_one_clear_error(tmp_path, keys, value, field, words):
    data = base_dict()
    _set(data, keys, value)
    path = write(tmp_path, data)
    with pytest.raises(ConfigError) as exc:
        load_calibration(path)
    assert exc.value.field == field
    assert exc.value.path == path
    message = str(exc.value)
    assert message.startswith(f"{path}: {field}: ") and words in message
    assert "\n" not in message
    if len(keys) > 2 and keys[2] != "name":
        assert "'cam_10'" in message  # the camera is named too


def test_unreadable_files(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load_calibration(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("format_version = 1\n[[cameras]\nname = 'x'\n")
    with pytest.raises(ConfigError, match="not valid TOML") as exc:
        load_calibration(bad)
    assert exc.value.path == str(bad)


def test_save_refuses_what_it_could_not_load(tmp_path):
    cameras = two_cameras()
    with pytest.raises(ConfigError, match="unique"):
        save_calibration(tmp_path / "c.toml", [cameras[0], cameras[0]])
    with pytest.raises(ConfigError):
        save_calibration(tmp_path / "c.toml", [])
    assert not (tmp_path / "c.toml").exists()


def test_opencv_import_matches_cv2_fisheye_projection(rng):
    rvec = np.array([0.3, -2.9, 0.2])  # world -> camera, as cv2.fisheye.calibrate / solvePnP give it
    tvec = np.array([0.1, 0.4, 2.8])
    camera = camera_from_opencv_fisheye(
        "cam_1", JY_K, JY_D, 1280, 800, R=rvec, t=tvec, calibration=CalibrationInfo(rms_error_px=0.263782587133)
    )
    rotation_cw, _ = cv2.Rodrigues(rvec)
    points_cam = rng.uniform([-2, -2, 0.3], [2, 2, 4], size=(300, 3))
    points_world = (points_cam - tvec) @ rotation_cw  # R^T (p_cam - t)
    expected, _ = cv2.fisheye.projectPoints(points_world.reshape(-1, 1, 3), rvec, tvec, JY_K, JY_D)
    np.testing.assert_allclose(camera.project_world(points_world), expected[:, 0], atol=1e-6)
    # The same with R as a matrix; and without extrinsics the pose is the identity.
    same = camera_from_opencv_fisheye("cam_1", JY_K, JY_D, 1280, 800, R=rotation_cw, t=tvec)
    np.testing.assert_allclose(same.rotation_world_from_cam, camera.rotation_world_from_cam, atol=1e-15)
    plain = camera_from_opencv_fisheye("cam_1", JY_K, JY_D, 1280, 800)
    np.testing.assert_array_equal(plain.pose_world_from_cam, np.eye(4))
    with pytest.raises(ConfigError, match="both"):
        camera_from_opencv_fisheye("cam_1", JY_K, JY_D, 1280, 800, R=rvec)


@pytest.mark.parametrize("suffix", [".yml", ".xml"])
def test_reads_opencv_filestorage_files(tmp_path, suffix, rng):
    path = tmp_path / f"left{suffix}"
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    storage.write("K", JY_K)
    storage.write("D", JY_D.reshape(4, 1))
    storage.write("image_width", 1280)
    storage.write("image_height", 800)
    storage.write("rms", 0.263782587133546)
    storage.release()
    K, D, extras = read_opencv_fisheye_file(path)
    np.testing.assert_array_equal(K, JY_K)
    np.testing.assert_array_equal(D, JY_D)
    assert extras == {"image_width": 1280, "image_height": 800, "rms_error_px": 0.263782587133546}
    camera = camera_from_opencv_fisheye("left", K, D, 1280, 800)
    points = rng.uniform([-2, -2, 0.3], [2, 2, 4], size=(100, 3))
    expected, _ = cv2.fisheye.projectPoints(points.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), JY_K, JY_D)
    np.testing.assert_allclose(camera.project_world(points), expected[:, 0], atol=1e-6)


def test_opencv_file_errors(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        read_opencv_fisheye_file(tmp_path / "none.yml")
    path = tmp_path / "pinhole.yml"
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    storage.write("camera_matrix", JY_K)
    storage.write("distortion_coefficients", np.zeros((1, 5)))
    storage.release()
    with pytest.raises(ConfigError, match="4 fisheye coefficients") as exc:
        read_opencv_fisheye_file(path)
    assert exc.value.field == "distortion_coefficients"
    path = tmp_path / "only_k.yml"
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    storage.write("K", JY_K)
    storage.release()
    with pytest.raises(ConfigError, match="no distortion"):
        read_opencv_fisheye_file(path)
    garbage = tmp_path / "garbage.yml"
    garbage.write_text("this is: [not, { valid")
    with pytest.raises(ConfigError, match="OpenCV"):
        read_opencv_fisheye_file(garbage)


def test_the_documented_example_loads_and_shows_as_documented(tmp_path):
    import re

    from ergopose.commands.camera import describe

    doc = (_REPO / "docs" / "calibration-file.md").read_text()
    example = re.search(r"```toml\n(.*?)```", doc, re.S).group(1)
    path = tmp_path / "calibration.toml"
    path.write_text(example)
    cameras = load_calibration(path)
    assert [c.name for c in cameras] == ["cam_1", "cam_2"]
    for camera in cameras:
        assert f"    {describe(camera)}\n" in doc
    # The Rodrigues vector of the example is the matrix it describes.
    np.testing.assert_allclose(cameras[1].rotation_world_from_cam, [[0, 1, 0], [1, 0, 0], [0, 0, -1]], atol=1e-15)
