"""``ergopose camera import``: the calibration TOML of Pose2Sim/anipose, checked on the real
4-camera Pose2Sim recording (../shared/data/pose2sim-demo/SOURCE.md): Pose2Sim's own 3D output
(the TRC) projected with the imported cameras lands on the 2D keypoints it was triangulated from."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ergopose import cli
from ergopose.errors import ConfigError
from ergopose.evaluation.markers import BODY_25B
from ergopose.evaluation.trc import read_trc
from ergopose.geometry.calibration_file import load_calibration, read_pose2sim_calibration, world_frame_warnings
from ergopose.geometry.camera import Camera

TRC = "pose-3d/S00_P00_T01_BalancingTrial_0-100.trc"


def reprojection_errors(demo, cameras, min_confidence=0.3):
    """{camera: pixel distances} between the projected TRC markers and the associated 2D keypoints.
    SOURCE.md: TRC axes = world[:, [1, 2, 0]], so world = TRC[:, [2, 0, 1]]; TRC row k is JSON frame k."""
    trc = read_trc(demo / TRC)
    world = trc.points_trc[:, :, [2, 0, 1]]
    index = [BODY_25B.index(m) for m in trc.markers]
    out = {}
    for c, camera in enumerate(cameras):
        errors = []
        for k in range(len(world)):
            people = json.loads((demo / f"pose-associated/cam0{c + 1}_json/cam0{c + 1}.{k:04d}.json").read_text())
            people = [p for p in people["people"] if "pose_keypoints_2d" in p]
            if not people:
                continue
            kp = np.array(people[0]["pose_keypoints_2d"]).reshape(-1, 3)[index]
            pixels = camera.project_world(world[k])
            ok = (kp[:, 2] >= min_confidence) & np.isfinite(pixels).all(axis=1)
            errors.append(np.linalg.norm(pixels[ok] - kp[ok, :2], axis=1))
        out[camera.name] = np.concatenate(errors)
    return out


@pytest.fixture(scope="module")
def demo(shared_data):
    return shared_data / "pose2sim-demo"


def test_import_cli_writes_a_calibration_in_file_order(demo, tmp_path, capsys):
    out = tmp_path / "calibration.toml"
    assert cli.main(["camera", "import", str(demo / "Calib_qualisys.toml"), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "warning" not in text and "wrote" in text
    cameras = load_calibration(out)
    assert [c.name for c in cameras] == ["cam_01", "cam_02", "cam_03", "cam_04"]
    assert all(c.lens.kind == "brown_conrady" and (c.width, c.height) == (1088, 1920) for c in cameras)
    # Writing again needs --force; the written file equals the import.
    assert cli.main(["camera", "import", str(demo / "Calib_qualisys.toml"), "--out", str(out)]) == 2
    assert "--force" in capsys.readouterr().err
    assert list(cameras) == list(read_pose2sim_calibration(demo / "Calib_qualisys.toml"))


@pytest.mark.slow
def test_pose2sim_output_reprojects_onto_its_2d_keypoints(demo):
    cameras = read_pose2sim_calibration(demo / "Calib_qualisys.toml")
    errors = reprojection_errors(demo, cameras)
    medians = {k: float(np.median(v)) for k, v in errors.items()}
    overall = float(np.median(np.concatenate(list(errors.values()))))
    # Measured: medians 11.4 / 7.9 / 17.2 / 9.1 px per camera, 10.7 px overall, on 8,065 keypoints
    # with confidence >= 0.3 (Pose2Sim's own triangulation residual; SOURCE.md finds 13 px with a DLT).
    assert sum(len(v) for v in errors.values()) > 7500
    assert overall < 13.0, overall
    assert max(medians.values()) < 21.0, medians
    # The other reading of the extrinsics (camera -> world) misses by metres in the image.
    # The file's (R, t) read as camera -> world: R_world_from_cam = R, position = t, where the
    # import has R_world_from_cam = R^T and position = -R^T t.
    flipped = [
        Camera(
            c.name,
            c.lens,
            c.width,
            c.height,
            c.rotation_world_from_cam.T,
            -(c.rotation_world_from_cam.T @ c.position_world),
            c.calibration,
        )
        for c in cameras
    ]
    wrong = np.concatenate(list(reprojection_errors(demo, flipped).values()))
    assert np.nanmedian(wrong) > 500.0


def test_world_frame_is_z_up_with_the_floor_near_zero(demo):
    cameras = read_pose2sim_calibration(demo / "Calib_qualisys.toml")
    assert world_frame_warnings(cameras) == []
    trc = read_trc(demo / TRC)
    world = trc.points_trc[:, :, [2, 0, 1]]
    heels = world[:, [trc.markers.index("LHeel"), trc.markers.index("RHeel")], 2]
    # The person stands on the floor: heels 5-15 cm above z = 0 (heel keypoints sit above the sole).
    assert 0.0 < np.nanmedian(heels) < 0.15
    assert all(1.5 < c.position_world[2] < 2.5 for c in cameras)


def _write(path, text):
    path.write_text(text)
    return path


CAM = """[cam_0]
name = "A"
size = [1280.0, 720.0]
matrix = [[900.0, 0.0, 640.0], [0.0, 900.0, 360.0], [0.0, 0.0, 1.0]]
distortions = [-0.1, 0.02, 0.0, 0.0, 0.0]
rotation = [0.0, 0.0, 0.0]
translation = [0.0, 0.0, 0.0]
fisheye = false
"""


def test_anipose_layout_fisheye_units_and_warnings(tmp_path):
    second = (
        CAM.replace("cam_0", "cam_1")
        .replace('"A"', '"B"')
        .replace("translation = [0.0, 0.0, 0.0]", "translation = [-1500.0, 0.0, 0.0]")
        .replace("distortions = [-0.1, 0.02, 0.0, 0.0, 0.0]", "distortions = [0.01, -0.002, 0.001, 0.0]")
        .replace("fisheye = false", "fisheye = true")
    )
    path = _write(tmp_path / "anipose.toml", CAM + "\n" + second + "\n[metadata]\nadjusted = true\n")
    cameras = read_pose2sim_calibration(path, units="mm")
    assert [c.name for c in cameras] == ["A", "B"]
    assert cameras[0].lens.kind == "brown_conrady" and cameras[1].lens.kind == "kannala_brandt"
    np.testing.assert_allclose(cameras[1].position_world, [1.5, 0.0, 0.0])
    warnings = world_frame_warnings(cameras)
    assert len(warnings) == 1 and "first camera" in warnings[0]
    # Read as metres, the second camera is 1.5 km away: the user is told to check the unit.
    in_metres = read_pose2sim_calibration(path)
    assert any("millimetres" in w for w in world_frame_warnings(in_metres))


@pytest.mark.parametrize(
    "edit, field",
    [
        (lambda t: t.replace("fisheye = false", "fisheye = true"), "cam_0.distortions"),
        (lambda t: t.replace("size = [1280.0, 720.0]", "size = [1280.5, 720.0]"), "cam_0.size"),
        (lambda t: t.replace("rotation = [0.0, 0.0, 0.0]\n", ""), "cam_0.rotation"),
        (lambda t: t.replace("fisheye = false", "fisheye = false\nskew = 0"), "cam_0.skew"),
        (lambda t: t.replace("[0.0, 900.0, 360.0]", "[0.0, -900.0, 360.0]"), "cam_0"),
        (
            lambda t: t.replace("distortions = [-0.1, 0.02, 0.0, 0.0, 0.0]", "distortions = [-0.1, 0.02]"),
            "cam_0.distortions",
        ),
        (lambda t: "", None),
    ],
)
def test_bad_files_give_one_clear_error(tmp_path, edit, field, capsys):
    path = _write(tmp_path / "bad.toml", edit(CAM))
    with pytest.raises(ConfigError) as info:
        read_pose2sim_calibration(path)
    if field:
        assert info.value.field == field, str(info.value)
    assert cli.main(["camera", "import", str(path), "--out", str(tmp_path / "o.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err
