"""Bad inputs end with one clear line (exit 2) naming the file or field and what to do."""

from __future__ import annotations

import shutil

import cv2
import numpy as np
import pytest

from ergopose import cli
from ergopose.calibration._so3 import rotation_matrices
from ergopose.calibration.boards import parse_board
from ergopose.calibration.simulate import render_board
from ergopose.geometry.calibration_file import save_calibration
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt

LENS = KannalaBrandt(245.0, 245.5, 401.3, 398.2, 0.02, -0.005, 0.001, -0.0002)
BOARD = "checkerboard:9x6:0.04"


def _error(capsys, argv) -> str:
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("ergopose: error: ")]
    assert len(errors) == 1 and err.endswith(errors[0] + "\n"), err  # progress bars may come before it
    return errors[0]


def _board_images(folder, n: int, theta_deg: float, phi_deg: float, rng) -> None:
    folder.mkdir(exist_ok=True)
    board = parse_board(BOARD)
    th, ph = np.radians(theta_deg), np.radians(phi_deg)
    for i in range(n):
        d = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
        x = np.cross([0.0, 1.0, 0.0], d)
        x /= np.linalg.norm(x)
        R = np.stack([x, np.cross(d, x), d], 1) @ rotation_matrices(rng.uniform(-0.3, 0.3, 3))
        t = rng.uniform(0.5, 0.6) * d - R @ np.array([0.16, 0.1, 0.0])
        image = render_board(LENS, (800, 800), board, R, t, supersample=2, noise_std=2.0, rng=rng)
        cv2.imwrite(str(folder / f"img_{i:02d}.png"), image)


def test_no_board_in_any_image(tmp_path, capsys):
    folder = tmp_path / "blank"
    folder.mkdir()
    for i in range(3):
        cv2.imwrite(str(folder / f"b{i}.png"), np.full((400, 400), 128, np.uint8))
    err = _error(
        capsys,
        ["calibrate", "intrinsics", "--images", str(folder), "--board", BOARD, "--out", str(tmp_path / "c.toml")],
    )
    assert "was not found in any of 3 image(s)" in err and "b0.png" in err and "INNER corners" in err
    assert not (tmp_path / "c.toml").exists()


def test_too_few_images(tmp_path, capsys, rng):
    _board_images(tmp_path / "few", 3, 30, 0, rng)
    err = _error(
        capsys,
        [
            "calibrate",
            "intrinsics",
            "--images",
            str(tmp_path / "few"),
            "--board",
            BOARD,
            "--out",
            str(tmp_path / "c.toml"),
        ],
    )
    assert "only 3 usable board image(s), at least 8 are needed" in err
    assert "take more images" in err


@pytest.mark.slow
def test_boards_all_in_one_corner_fail_the_coverage_check(tmp_path, capsys, rng):
    _board_images(tmp_path / "corner", 9, 55, 225, rng)
    err = _error(
        capsys,
        [
            "calibrate",
            "intrinsics",
            "--images",
            str(tmp_path / "corner"),
            "--board",
            BOARD,
            "--out",
            str(tmp_path / "c.toml"),
        ],
    )
    assert "poor coverage" in err and "near the image edges and corners" in err


def test_unreadable_image_is_named(tmp_path, capsys, rng):
    _board_images(tmp_path / "imgs", 2, 30, 0, rng)
    (tmp_path / "imgs" / "broken.png").write_bytes(b"this is not a png")
    err = _error(
        capsys,
        [
            "calibrate",
            "intrinsics",
            "--images",
            str(tmp_path / "imgs"),
            "--board",
            BOARD,
            "--out",
            str(tmp_path / "c.toml"),
        ],
    )
    assert "broken.png" in err and "cannot read this image" in err


def test_image_folder_missing_or_empty(tmp_path, capsys):
    err = _error(
        capsys,
        [
            "calibrate",
            "intrinsics",
            "--images",
            str(tmp_path / "nope"),
            "--board",
            BOARD,
            "--out",
            str(tmp_path / "c.toml"),
        ],
    )
    assert "nope" in err and "image folder not found" in err
    (tmp_path / "empty").mkdir()
    err = _error(
        capsys,
        [
            "calibrate",
            "intrinsics",
            "--images",
            str(tmp_path / "empty"),
            "--board",
            BOARD,
            "--out",
            str(tmp_path / "c.toml"),
        ],
    )
    assert "no images" in err


@pytest.mark.parametrize(
    "spec, expected",
    [
        ("checkerboard:9x6", "checkerboard:COLSxROWS:SQUARE"),
        ("checkerboard:9by6:0.02", "COLSxROWS"),
        ("checkerboard:9x6:big", "square size"),
        ("charuco:7x5:0.04:0.05:DICT_5X5_100", "marker size"),
        ("charuco:7x5:0.04:0.03:DICT_NOPE", "unknown ArUco dictionary"),
        ("board.toml", "board file not found"),
    ],
)
def test_bad_board_spec(tmp_path, capsys, spec, expected):
    (tmp_path / "imgs").mkdir()
    err = _error(
        capsys,
        [
            "calibrate",
            "intrinsics",
            "--images",
            str(tmp_path / "imgs"),
            "--board",
            spec,
            "--out",
            str(tmp_path / "c.toml"),
        ],
    )
    assert expected in err


@pytest.mark.slow
def test_extrinsics_errors(tmp_path, capsys, sim_room):
    calib = tmp_path / "c.toml"
    save_calibration(calib, sim_room.cameras)
    err = _error(capsys, ["calibrate", "extrinsics", "--calibration", str(calib)])
    assert "give either --board-image" in err
    err = _error(
        capsys,
        [
            "calibrate",
            "extrinsics",
            "--calibration",
            str(calib),
            "--board",
            sim_room.floor_board,
            "--board-image",
            f"cam_x={sim_room.floor_images['cam_a']}",
        ],
    )
    assert "unknown camera 'cam_x'" in err
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((800, 800), 128, np.uint8))
    err = _error(
        capsys,
        [
            "calibrate",
            "extrinsics",
            "--calibration",
            str(calib),
            "--board",
            sim_room.floor_board,
            "--board-image",
            f"cam_a={blank}",
        ],
    )
    assert "blank.png" in err and "was not found" in err
    world = tmp_path / "world.csv"
    world.write_text("point,x,y,z\np1,0,0,0\np2,1,0,0\np3,0,1,0\n")
    pixels = tmp_path / "pixels.csv"
    pixels.write_text("camera,point,u,v\ncam_a,p1,400,400\ncam_a,p2,500,400\ncam_a,p3,400,500\n")
    err = _error(
        capsys,
        [
            "calibrate",
            "extrinsics",
            "--calibration",
            str(calib),
            "--points-world",
            str(world),
            "--points-pixels",
            str(pixels),
        ],
    )
    assert "only 3 point(s)" in err and "pixels.csv" in err
    pixels.write_text("camera,point,u,v\ncam_a,p9,400,400\n")
    err = _error(
        capsys,
        [
            "calibrate",
            "extrinsics",
            "--calibration",
            str(calib),
            "--points-world",
            str(world),
            "--points-pixels",
            str(pixels),
        ],
    )
    assert "line 2: point 'p9' is not in world.csv" in err


@pytest.mark.slow
def test_check_errors(tmp_path, capsys, sim_room):
    calib = tmp_path / "c.toml"
    save_calibration(calib, sim_room.cameras)
    obs = tmp_path / "bar.csv"
    obs.write_text("measurement,camera,end,u,v\n1,cam_a,a,400,400\n1,cam_q,b,410,400\n")
    err = _error(
        capsys, ["calibrate", "check", "--calibration", str(calib), "--observations", str(obs), "--length", "1.5"]
    )
    assert "line 3: unknown camera 'cam_q'" in err
    obs.write_text("measurement,camera,end,u,v\n1,cam_a,a,400,400\n1,cam_a,b,410,400\n1,cam_b,a,400,400\n")
    err = _error(
        capsys, ["calibrate", "check", "--calibration", str(calib), "--observations", str(obs), "--length", "1.5"]
    )
    assert "each bar end needs pixels from at least two cameras" in err
    obs.write_text("measurement,camera,u,v\n")
    err = _error(
        capsys, ["calibrate", "check", "--calibration", str(calib), "--observations", str(obs), "--length", "1.5"]
    )
    assert "missing column(s) end" in err
    err = _error(
        capsys,
        [
            "calibrate",
            "check",
            "--calibration",
            str(calib),
            "--observations",
            str(obs),
            "--length",
            "1.5",
            "--rings",
            "70",
        ],
    )
    assert "--rings" in err
    shutil.rmtree(tmp_path)
