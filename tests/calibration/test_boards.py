"""Board specs, board files, printable textures and detection through a fisheye lens."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from ergopose.calibration._so3 import rotation_matrices
from ergopose.calibration.boards import Board, board_texture, detect_board, load_board_file, parse_board
from ergopose.calibration.simulate import render_board, true_corner_pixels
from ergopose.errors import ConfigError
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt

LENS = KannalaBrandt(245.0, 245.5, 401.3, 398.2, 0.02, -0.005, 0.001, -0.0002)


def test_parse_specs_round_trip():
    b = parse_board("checkerboard:9x6:0.025")
    assert (b.kind, b.cols, b.rows, b.square) == ("checkerboard", 9, 6, 0.025)
    assert b.pattern_size == (9, 6) and b.n_corners == 54 and b.squares == (10, 7)
    assert parse_board(b.spec()) == b
    c = parse_board("charuco:7x5:0.04:0.03:dict_5x5_100")
    assert (c.kind, c.pattern_size, c.n_corners, c.dictionary) == ("charuco", (6, 4), 24, "DICT_5X5_100")
    assert parse_board(c.spec()) == c


def test_checkerboard_object_points():
    pts = parse_board("checkerboard:4x3:0.1").object_points()
    assert pts.shape == (12, 3) and pts.dtype == np.float64
    np.testing.assert_allclose(pts[[0, 1, 4, 11]], [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.3, 0.2, 0]])


def test_board_file(tmp_path):
    f = tmp_path / "board.toml"
    f.write_text(
        '[board]\nkind = "charuco"\ncols = 7\nrows = 5\nsquare = 0.04\nmarker = 0.03\ndictionary = "DICT_5X5_100"\n'
    )
    assert parse_board(str(f)) == Board("charuco", 7, 5, 0.04, 0.03, "DICT_5X5_100")
    f.write_text('[board]\nkind = "checkerboard"\ncols = 9\n')
    with pytest.raises(ConfigError, match="missing field 'rows'"):
        load_board_file(f)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(kind="circles", cols=4, rows=4, square=0.1), "unknown board kind"),
        (dict(kind="checkerboard", cols=1, rows=4, square=0.1), "at least 2 x 2"),
        (dict(kind="checkerboard", cols=4, rows=4, square=-1.0), "positive"),
    ],
)
def test_invalid_boards(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        Board(**kwargs)


def test_texture_corners_are_where_the_board_says():
    b = parse_board("checkerboard:9x6:0.025")
    tex = board_texture(b)
    det = detect_board(tex.image, b)
    np.testing.assert_allclose(det.pixels, tex.coordinates(b, b.object_points()), atol=0.05)
    # turned by 180 degrees the corner order follows the board (the black outside square), not the image
    turned = detect_board(cv2.rotate(tex.image, cv2.ROTATE_180), b)
    h, w = tex.image.shape
    np.testing.assert_allclose(turned.pixels, [w - 1, h - 1] - tex.coordinates(b, b.object_points()), atol=0.05)


@pytest.mark.parametrize("spec", ["checkerboard:9x6:0.04", "charuco:7x5:0.06:0.045:DICT_5X5_100"])
def test_detection_through_a_fisheye_lens_is_subpixel(spec, rng):
    """Render through a known lens; detected corners are within 0.3 px of the true projections."""
    b = parse_board(spec)
    for rvec, t in [((0.2, 0.1, 0.0), (-0.18, -0.1, 0.5)), ((0.0, 0.9, 0.0), (0.45, -0.1, 0.35))]:
        R = rotation_matrices(np.array(rvec))
        image = render_board(LENS, (800, 800), b, R, np.array(t), supersample=3, noise_std=2.0, rng=rng)
        det = detect_board(image, b, source="x")
        assert det is not None and det.image_size == (800, 800)
        truth = true_corner_pixels(LENS, b, R, np.array(t))[det.ids]
        err = np.linalg.norm(det.pixels - truth, axis=-1)
        assert err.max() < 0.3, err.max()
        if b.kind == "checkerboard":
            assert len(det.ids) == 54


def test_no_board_gives_none():
    b = parse_board("checkerboard:9x6:0.04")
    assert detect_board(np.full((300, 300), 128, np.uint8), b) is None
