"""``ergopose camera guess``: a calibration from uncalibrated fisheye footage; ``camera show``'s
field of view from the image circle (issue 14, item 5)."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from ergopose import cli
from ergopose.geometry.calibration_file import load_calibration, save_calibration
from ergopose.geometry.camera import Camera, ceiling_camera
from ergopose.geometry.lenses import DoubleSphere, Equidistant, Equisolid, KannalaBrandt
from ergopose.sim.render import CameraRenderer, RenderOptions
from ergopose.sim.scene import default_scene

WIDTH, HEIGHT = 480, 400
#: The rendered lens's image circle: 180 deg across a circle of radius 180 px, 7 px off centre.
TRUE_CIRCLE = (246.5, 196.0, 180.0)


def _render(lens, circle=TRUE_CIRCLE, position=(0.4, -0.3, 3.0)) -> np.ndarray:
    """The simulator's hall seen by a ceiling camera with ``lens``; dark outside the image circle,
    as a real fisheye's sensor is."""
    camera = ceiling_camera("cam", lens, WIDTH, HEIGHT, list(position))
    image = CameraRenderer(camera, default_scene(), [], RenderOptions(seed=3)).render(0)
    u, v, r = circle
    yy, xx = np.mgrid[0:HEIGHT, 0:WIDTH]
    image[np.hypot(xx - u, yy - v) > r] = 0
    return image


@pytest.fixture(scope="module")
def equidistant_180(tmp_path_factory):
    u, v, r = TRUE_CIRCLE
    f = r / (math.pi / 2)
    path = tmp_path_factory.mktemp("guess") / "ceiling.png"
    cv2.imwrite(str(path), _render(Equidistant(f, f, u, v)))
    return path, f


def test_guess_finds_the_focal_length_of_a_rendered_180_degree_lens(equidistant_180, tmp_path, capsys):
    path, f_true = equidistant_180
    out = tmp_path / "guessed.toml"
    assert cli.main(["camera", "guess", str(path), "--fov", "180", "--height", "2.8", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "wrote" in text and "field of view 180.0 x 180.0 deg" in text
    (camera,) = load_calibration(out)
    assert camera.name == "ceiling" and (camera.width, camera.height) == (WIDTH, HEIGHT)
    assert camera.lens.kind == "equidistant"
    assert camera.lens.fx == pytest.approx(f_true, rel=0.02)
    assert (camera.lens.cx, camera.lens.cy) == pytest.approx(TRUE_CIRCLE[:2], abs=1.5)
    assert camera.image_circle[2] == pytest.approx(TRUE_CIRCLE[2], rel=0.02)
    np.testing.assert_allclose(camera.position_world, [0.0, 0.0, 2.8])
    np.testing.assert_allclose(camera.axis_world, [0.0, 0.0, -1.0], atol=1e-12)
    # The file's lens maps the rendered image's rays back within a few pixels.
    truth = Equidistant(f_true, f_true, *TRUE_CIRCLE[:2])
    theta = np.radians([10.0, 45.0, 80.0])
    rays = np.stack([np.sin(theta), np.zeros(3), np.cos(theta)], axis=1)
    assert np.abs(camera.lens.project(rays) - truth.project(rays)).max() < 3.0


def test_guess_with_another_lens_model_and_from_a_video(tmp_path, capsys):
    u, v, r = TRUE_CIRCLE
    half = math.radians(95.0)  # a 190-degree equisolid lens
    f = r / (2.0 * math.sin(half / 2.0))
    image = _render(Equisolid(f, f, u, v))
    video = tmp_path / "cam_7.mp4"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (WIDTH, HEIGHT))
    for _ in range(3):
        writer.write(image)
    writer.release()
    out = tmp_path / "guessed.toml"
    assert cli.main(["camera", "guess", str(video), "--fov", "190", "--lens", "equisolid", "--out", str(out)]) == 0
    (camera,) = load_calibration(out)
    assert camera.name == "cam_7" and camera.lens.kind == "equisolid"
    assert camera.lens.fx == pytest.approx(f, rel=0.03)
    assert camera.position_world[2] == 3.0
    assert math.degrees(camera.field_of_view()[0]) == pytest.approx(190.0, abs=0.5)


@pytest.mark.parametrize(
    "fov, message",
    [
        ("99", "between 100 and 280 degrees, got 99"),
        ("281", "between 100 and 280 degrees, got 281"),
        ("nan", "between 100 and 280 degrees"),
    ],
)
def test_guess_refuses_a_field_of_view_out_of_range(equidistant_180, tmp_path, capsys, fov, message):
    path, _ = equidistant_180
    out = tmp_path / "x.toml"
    assert cli.main(["camera", "guess", str(path), "--fov", fov, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--fov" in err and message in err and not out.exists()


def test_guess_refuses_what_an_orthographic_lens_cannot_span(equidistant_180, tmp_path, capsys):
    path, _ = equidistant_180
    assert (
        cli.main(
            ["camera", "guess", str(path), "--fov", "200", "--lens", "orthographic", "--out", str(tmp_path / "x.toml")]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "orthographic lens spans at most 180 degrees" in err


def test_guess_refuses_footage_that_is_not_fisheye(tmp_path, capsys):
    """A pinhole video lit to its corners: no image circle, one line, non-zero exit, no file."""
    rng = np.random.default_rng(5)
    video = tmp_path / "pinhole.mp4"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 10.0, (320, 240))
    for _ in range(3):
        writer.write(rng.integers(60, 200, (240, 320, 3), dtype=np.uint8))
    writer.release()
    out = tmp_path / "x.toml"
    assert cli.main(["camera", "guess", str(video), "--fov", "180", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no fisheye image circle found" in err and "lit to its corners" in err
    assert not out.exists()
    (tmp_path / "black.png").write_bytes(cv2.imencode(".png", np.zeros((240, 320, 3), np.uint8))[1].tobytes())
    assert cli.main(["camera", "guess", str(tmp_path / "black.png"), "--fov", "180", "--out", str(out)]) == 2
    assert "no lit pixels" in capsys.readouterr().err
    assert cli.main(["camera", "guess", str(tmp_path / "missing.mp4"), "--fov", "180", "--out", str(out)]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_guess_keeps_an_existing_file_unless_forced(equidistant_180, tmp_path, capsys):
    path, _ = equidistant_180
    out = tmp_path / "guessed.toml"
    out.write_text("keep me")
    assert cli.main(["camera", "guess", str(path), "--fov", "180", "--out", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err and out.read_text() == "keep me"
    assert cli.main(["camera", "guess", str(path), "--fov", "180", "--out", str(out), "--force"]) == 0
    assert load_calibration(out)[0].lens.kind == "equidistant"


# ------------------------------------------------------------------ camera show's field of view


def _show_fov(tmp_path, capsys, camera: Camera) -> tuple[float, float]:
    path = save_calibration(tmp_path / f"{camera.name}.toml", [camera])
    assert cli.main(["camera", "show", str(path)]) == 0
    line = capsys.readouterr().out.strip()
    h, v = line.split("field of view ")[1].split(" deg")[0].split(" x ")
    return float(h), float(v)


def test_show_gives_180_degrees_for_a_simulated_180_degree_lens(tmp_path, capsys):
    """A 180-degree Kannala-Brandt lens (the simulator's model) in a 4:3 frame with its circle
    inside the short side: ~180 x 180 from the circle, where the polynomial alone runs on into
    the corners."""
    k = (0.02, -0.004, 0.0005, 0.0)
    t = math.pi / 2
    rd = t * (1 + k[0] * t**2 + k[1] * t**4 + k[2] * t**6 + k[3] * t**8)
    f = 190.0 / rd
    lens = KannalaBrandt(f, f, 239.5, 199.5, *k)
    camera = ceiling_camera("sim180", lens, 480, 400, [0.0, 0.0, 3.0])
    circled = Camera(
        "sim180c",
        lens,
        480,
        400,
        camera.rotation_world_from_cam,
        camera.position_world,
        image_circle=(239.5, 199.5, rd * f),
    )
    h, v = _show_fov(tmp_path, capsys, circled)
    assert h == pytest.approx(180.0, abs=0.5) and v == pytest.approx(180.0, abs=0.5)
    assert _show_fov(tmp_path, capsys, camera)[0] > 200.0  # without the circle: the model to the frame's edge


def test_show_gives_the_image_circle_of_a_guessed_camera(equidistant_180, tmp_path, capsys):
    path, _ = equidistant_180
    out = tmp_path / "guessed.toml"
    assert cli.main(["camera", "guess", str(path), "--fov", "180", "--out", str(out)]) == 0
    capsys.readouterr()
    h, v = _show_fov(tmp_path, capsys, load_calibration(out)[0])
    assert h == pytest.approx(180.0, abs=0.5) and v == pytest.approx(180.0, abs=0.5)


def test_show_of_the_real_calibrations(tmp_path, capsys, shared_data):
    """The real calibrations in shared/data hold no image circle; their figures are those of the
    lens model across the frame through the principal point. JY left (OpenCV's fisheye test,
    1280 x 800): 2 theta(x edge) = 132.0 x 81.9 deg; TUM-VI cam0 (Basalt, 512 x 512, a
    195-degree lens whose circle the square frame cuts): 153.4 x 153.4 deg, within the lens's."""
    import json

    jy = KannalaBrandt.from_opencv(
        np.array([[558.478087865323, 0, 620.458515360843], [0, 560.506767351568, 381.939424848348], [0, 0, 1]]),
        np.array([-0.0014613319981768, -0.00329861110580401, 0.00605760088590183, -0.00374209380722371]),
    )
    h, v = _show_fov(tmp_path, capsys, ceiling_camera("jy_left", jy, 1280, 800, [0.0, 0.0, 3.0]))
    rays = jy.unproject(np.array([[-0.5, jy.cy], [1279.5, jy.cy]]))
    expected = math.degrees(sum(math.atan2(math.hypot(r[0], r[1]), r[2]) for r in rays))
    assert h == pytest.approx(expected, abs=0.1) and h == pytest.approx(132.0, abs=0.5)
    assert v == pytest.approx(81.9, abs=0.5)
    data = json.loads((shared_data / "basalt-tumvi-calib" / "tumvi_512_cam0_cam1_ds_eucm_intrinsics.json").read_text())
    tumvi = DoubleSphere(**data["ds"][0])
    h, v = _show_fov(tmp_path, capsys, ceiling_camera("tumvi0", tumvi, 512, 512, [0.0, 0.0, 3.0]))
    assert h == pytest.approx(153.4, abs=0.5) and v == pytest.approx(153.4, abs=0.5) and h < 195.0
