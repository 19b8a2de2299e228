"""``ergopose pose``: the 2D stage alone on one video, to a keypoint CSV (issue 14).

A short fisheye video of a drawn person (mannequin.py) walking slowly, warped into the fisheye
image through a known lens with a black surround outside the image circle: the command must
find the person in most frames and put the keypoints near the drawn joints, with the camera from
a calibration file and with an approximate camera made from the image circle. Bad input gives
one line and a non-zero exit. The image circle search is checked on its own, and the command on
two frames of the real Pose2Sim recording.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
from test_fisheye import LENS, SIZE, fisheye_with_person

from ergopose import cli
from ergopose.geometry.calibration_file import save_calibration
from ergopose.geometry.camera import ceiling_camera
from ergopose.geometry.image_circle import find_image_circle, max_image
from ergopose.keypoints import JOINT_INDEX
from ergopose.pipeline.pose_video import POSE_COLUMNS
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.pose.models import POSE_COMMAND_MODEL
from ergopose.pose.settings import PoseSettings
from ergopose.progress import ProgressEvent
from ergopose.video import read_frames

FPS = 12.0
FRAMES = 10
#: Lit radius of the test lens's image circle (pixels) and its centre.
CIRCLE = (511.5, 511.5, 480.0)
PROGRESS_LINE = re.compile(r"^\s*\S+ (\[[#-]*\] )?\d+(/\d+)? \w+s ")


def user_lines(err: str) -> list[str]:
    return [ln for ln in err.splitlines() if ln.strip() and not PROGRESS_LINE.match(ln) and not ln.startswith("INFO:")]


def _masked(frame: np.ndarray) -> np.ndarray:
    u, v, r = CIRCLE
    yy, xx = np.mgrid[0 : frame.shape[0], 0 : frame.shape[1]]
    out = frame.copy()
    out[np.hypot(xx - u, yy - v) > r] = 0
    return out


@pytest.fixture(scope="module")
def camera():
    return ceiling_camera("cam_1", LENS, SIZE, SIZE, position_world=(0.0, 0.0, 3.0))


@pytest.fixture(scope="module")
def walking_video(camera, tmp_path_factory):
    """A 10-frame fisheye video of the drawn person moving 3 cm a frame; the drawn joints per frame."""
    path = tmp_path_factory.mktemp("pose_video") / "cam_1.mp4"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), FPS, (SIZE, SIZE))
    truth = []
    for k in range(FRAMES):
        frame, joints = fisheye_with_person(camera, (1.2 + 0.03 * k, 0.8, 1.0))
        writer.write(_masked(frame))
        truth.append(joints)
    writer.release()
    return path, truth


def _run(capsys, *args) -> tuple[int, str, list[str]]:
    capsys.readouterr()
    code = cli.main([str(a) for a in args])
    captured = capsys.readouterr()
    return code, captured.out, user_lines(captured.err)


def _check_keypoints(table: pd.DataFrame, truth: list[dict]) -> None:
    assert tuple(table.columns) == POSE_COLUMNS
    assert set(table["left_right_uncertain"]) <= {0, 1}
    found = sorted(set(table["frame"]))
    assert len(found) >= 0.8 * FRAMES, f"person found in {len(found)} of {FRAMES} frames"
    assert np.allclose(table["time_s"], table["frame"] / FPS, atol=1e-4)
    assert set(table["joint"]) == set(JOINT_INDEX)
    errors = []
    for f in found:
        rows = table[(table["frame"] == f) & (table["person"] == 0)].set_index("joint")
        joints = truth[f]
        torso = np.linalg.norm(joints["left_shoulder"] - joints["left_hip"])
        for name, drawn in joints.items():
            errors.append(np.linalg.norm(rows.loc[name, ["x_px", "y_px"]].to_numpy(float) - drawn) / torso)
    assert np.median(errors) < 0.15 and np.percentile(errors, 90) < 0.3, (np.median(errors), np.percentile(errors, 90))


@pytest.mark.slow
def test_pose_with_a_calibration_file(camera, walking_video, fetched_model_dir, tmp_path, capsys):
    video, truth = walking_video
    calibration = save_calibration(tmp_path / "calibration.toml", [camera])
    out = tmp_path / "keypoints.csv"
    code, stdout, lines = _run(
        capsys, "pose", video, "--camera", calibration, "--out", out, "--model-dir", fetched_model_dir[0]
    )
    assert code == 0, lines
    assert lines == []  # no warnings
    assert "people found in" in stdout and str(out) in stdout
    _check_keypoints(pd.read_csv(out), truth)


@pytest.mark.slow
def test_pose_without_calibration_finds_the_image_circle(walking_video, fetched_model_dir, tmp_path, capsys):
    video, truth = walking_video
    # The field of view across the lit circle of the test lens.
    theta = float(np.arccos(LENS.unproject(np.array([CIRCLE[0] + CIRCLE[2], CIRCLE[1]]))[2]))
    out = tmp_path / "keypoints.csv"
    code, stdout, lines = _run(
        capsys,
        "pose",
        video,
        "--fov-deg",
        f"{2 * math.degrees(theta):.1f}",
        "--out",
        out,
        "--model-dir",
        fetched_model_dir[0],
        "--start",
        "0.1",
    )
    assert code == 0, lines
    circle = re.search(r"equidistant lens, .* image circle at \(([\d.]+), ([\d.]+)\) r = ([\d.]+) px", stdout)
    assert circle is not None, stdout
    assert np.allclose([float(x) for x in circle.groups()], CIRCLE, atol=1.0), stdout
    table = pd.read_csv(out)
    assert table["frame"].min() >= 1  # --start 0.1 s = frame 1
    _check_keypoints(table, truth)


def _score_against_ground_truth(table: pd.DataFrame, gt, camera_index: int) -> tuple[int, int, np.ndarray]:
    """(worker-frames whose torso the camera sees, of them found, limb keypoint errors in torso
    lengths): found = a person of the table whose hip centre is within 0.5 torso lengths (the
    ground truth's, in fisheye pixels) of the worker's; the closest is scored."""
    hips = [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]
    shoulders = [JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]]
    limbs = [
        JOINT_INDEX[s + n] for n in ("shoulder", "elbow", "wrist", "hip", "knee", "ankle") for s in ("left_", "right_")
    ]
    people = {
        key: g.set_index("joint").reindex(list(JOINT_INDEX))[["x_px", "y_px"]].to_numpy(float)
        for key, g in table.groupby(["frame", "person"])
    }
    counted, found, errors = 0, 0, []
    for f in range(gt.n_frames):
        here = [xy for (frame, _), xy in people.items() if frame == f]
        for w in range(len(gt.worker_ids)):
            visible = gt.visible[f, camera_index, w]
            if not visible[hips + shoulders].all():
                continue
            counted += 1
            px = gt.pixels[f, camera_index, w]
            hip = px[hips].mean(axis=0)
            torso = np.linalg.norm(px[shoulders].mean(axis=0) - hip)
            dist = [np.linalg.norm(xy[hips].mean(axis=0) - hip) for xy in here]
            if dist and min(dist) <= 0.5 * torso:
                found += 1
                xy = here[int(np.argmin(dist))]
                seen = [j for j in limbs if visible[j]]
                errors.extend(np.linalg.norm(xy[seen] - px[seen], axis=1) / torso)
    return counted, found, np.asarray(errors)


#: Share of the frames in which `ergopose pose` finds the simulated worker, per model: full finds
#: it in 36 of 36 frames (35 of 36 from the image circle); heavy, the command's default, places
#: the rendered mannequin's hips too far off to count in 21 and 18 of them (found 15 and 18 of 36;
#: docs/models.md, "The model of `ergopose pose`"): a shortfall on the simulator's figures, not a
#: target.
SIMULATED_FOUND = {"full": 0.9, "heavy": 0.35}


@pytest.mark.slow
@pytest.mark.parametrize("model", ["full", None])
@pytest.mark.parametrize("calibrated", [True, False])
def test_pose_on_a_simulated_session_video(tiny_session, fetched_model_dir, tmp_path, capsys, calibrated, model):
    """The simulator's rendered workshop (3 s, 2 workers, 1024 x 768 fisheye): against the ground
    truth's projected joints, with full and with the command's default (heavy). Measured: full
    finds the worker in 36 of 36 frames (35 of 36 from the image circle), limb keypoints a
    median 0.15 torso lengths off, p90 0.65 (0.55); heavy in 15 (18) of 36, median 0.17."""
    from ergopose.sim.ground_truth import load_ground_truth

    out = tmp_path / "cam_1.csv"
    camera = ["--camera", tiny_session / "calibration.toml"] if calibrated else ["--fov-deg", "190"]
    chosen = [] if model is None else ["--model", model]
    code, stdout, lines = _run(
        capsys, "pose", tiny_session / "cam_1.mp4", *camera, "--out", out, "--model-dir", fetched_model_dir[0], *chosen
    )
    assert code == 0, lines
    counted, found, errors = _score_against_ground_truth(
        pd.read_csv(out), load_ground_truth(tiny_session / "ground_truth"), 0
    )
    assert counted >= 30
    assert found >= SIMULATED_FOUND[model or POSE_COMMAND_MODEL] * counted, (found, counted)
    assert np.median(errors) < 0.25, np.median(errors)


def test_image_circle_search(camera):
    frame, _ = fisheye_with_person(camera, (1.2, 0.8, 1.0))
    found = find_image_circle(max_image([_masked(frame)]))
    assert found.circle is not None, found.reason
    assert np.allclose(found.circle, CIRCLE, atol=1.0)
    # A circle cut by the frame's top and bottom edges: its arcs are enough.
    u, v, r = CIRCLE
    tall = np.zeros((800, 1024, 3), np.uint8)
    yy, xx = np.mgrid[0:800, 0:1024]
    tall[np.hypot(xx - u, yy - 400) <= r] = 200
    cut = find_image_circle(max_image([tall]))
    assert cut.circle is not None and np.allclose(cut.circle, (u, 400, r), atol=1.0)
    assert "black" in find_image_circle(np.zeros((600, 800), np.uint8)).reason
    assert "corners" in find_image_circle(np.full((600, 800), 120, np.uint8)).reason
    square = np.zeros((600, 800), np.uint8)
    square[100:500, 200:600] = 200
    assert find_image_circle(square).circle is None


def _write(path, frames, fps=FPS):
    h, w = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
    for f in frames:
        writer.write(f)
    writer.release()
    return path


@pytest.mark.parametrize(
    "case", ["missing", "not a video", "fov 90", "fov 300", "black", "not fisheye", "fov with camera", "max people 0"]
)
def test_bad_input_is_one_line_and_a_non_zero_exit(case, tmp_path, capsys):
    out = tmp_path / "k.csv"
    args: list = []
    words: tuple = ()
    if case == "missing":
        args, words = [tmp_path / "nothing.mp4"], ("nothing.mp4", "not found")
    elif case == "not a video":
        text = tmp_path / "notes.mp4"
        text.write_text("not a video\n")
        args, words = [text], ("notes.mp4", "cannot open the video")
    elif case in ("fov 90", "fov 300"):
        args, words = [tmp_path / "any.mp4", "--fov-deg", case.split()[1]], ("--fov-deg", "between 100 and 280")
    elif case == "black":
        video = _write(tmp_path / "black.mp4", [np.zeros((240, 320, 3), np.uint8)] * 4)
        args, words = [video], ("no image circle found in", "black.mp4", "black video", "--calibration FILE")
    elif case == "not fisheye":
        rng = np.random.default_rng(14)
        video = _write(tmp_path / "wall.mp4", [rng.integers(40, 255, (240, 320, 3), dtype=np.uint8)] * 4)
        args, words = [video], ("no image circle found in", "lit to its corners", "--calibration FILE")
    elif case == "fov with camera":
        args, words = [tmp_path / "any.mp4", "--camera", tmp_path / "c.toml", "--fov-deg", "180"], ("--fov-deg",)
    elif case == "max people 0":
        args, words = [tmp_path / "any.mp4", "--max-people", "0"], ("--max-people",)
    code, stdout, lines = _run(capsys, "pose", *args, "--out", out)
    assert code != 0
    assert len(lines) == 1 and lines[0].startswith("ergopose: error:"), lines
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not out.exists()


@pytest.mark.slow
def test_reaching_max_people_is_told_once_naming_the_camera_and_the_setting(camera, landmarker, detector):
    frame, _ = fisheye_with_person(camera, (1.2, 0.8, 1.0))
    events: list[ProgressEvent] = []
    stage = FisheyePoseEstimator(camera, 0, landmarker, detector, PoseSettings(max_people=1), progress=events.append)
    for k in range(3):
        assert stage.process(frame, k).count == 1
    warnings = [e for e in events if e.unit == "note"]
    assert stage.capped_frames == 3 and len(warnings) == 1
    assert "cam_1" in warnings[0].message and "max_people = 1" in warnings[0].message
    # Below the cap: nothing to tell.
    quiet: list[ProgressEvent] = []
    stage = FisheyePoseEstimator(camera, 0, landmarker, detector, PoseSettings(max_people=2), progress=quiet.append)
    stage.process(frame, 0)
    assert stage.capped_frames == 0 and quiet == []


@pytest.mark.slow
def test_pose_on_real_pose2sim_frames(shared_data, fetched_model_dir, tmp_path, capsys):
    root = shared_data / "pose2sim-demo"
    out = tmp_path / "cam01.csv"
    # Frames 0-1 of cam01 (60 fps); the calibration's cam_01 is chosen by the video's name.
    code, stdout, lines = _run(
        capsys,
        "pose",
        root / "videos" / "cam01.mp4",
        "--camera",
        root / "Calib_qualisys.toml",
        "--out",
        out,
        "--end",
        "0.034",
        "--model-dir",
        fetched_model_dir[0],
    )
    assert code == 0, lines
    assert len(lines) == 1 and "1088x1920" in lines[0] and "1080x1920" in lines[0]  # the padding warning
    table = pd.read_csv(out)
    assert sorted(set(table["frame"])) == [0, 1]
    # The recording's own OpenPose keypoints (pose-associated) of frame 0: hips and shoulders agree.
    ref = json.loads((root / "pose-associated" / "cam01_json" / "cam01.0000.json").read_text())["people"][0]
    k = np.array(ref["pose_keypoints_2d"]).reshape(-1, 3)
    rows = table[(table["frame"] == 0)]
    torso = np.linalg.norm(k[5, :2] - k[11, :2])
    best = min(
        np.median(
            [
                np.linalg.norm(
                    rows[(rows["person"] == p) & (rows["joint"] == name)][["x_px", "y_px"]].to_numpy(float)[0]
                    - k[i, :2]
                )
                for i, name in ((5, "left_shoulder"), (6, "right_shoulder"), (11, "left_hip"), (12, "right_hip"))
            ]
        )
        for p in sorted(set(rows["person"]))
    )
    assert best < 0.15 * torso, (best, torso)


@pytest.mark.slow
@pytest.mark.parametrize("model", ["lite", "full"])
def test_pose_with_another_model_card(model, camera, walking_video, fetched_model_dir, tmp_path, capsys):
    """--model picks the landmark card; the person is found and placed as with the default."""
    video, truth = walking_video
    calibration = save_calibration(tmp_path / "calibration.toml", [camera])
    out = tmp_path / "keypoints.csv"
    code, stdout, lines = _run(
        capsys,
        "pose",
        video,
        "--camera",
        calibration,
        "--out",
        out,
        "--model-dir",
        fetched_model_dir[0],
        "--model",
        model,
    )
    assert code == 0 and lines == [], lines
    _check_keypoints(pd.read_csv(out), truth)


@pytest.mark.slow
def test_pose_refuses_an_unknown_model(walking_video, tmp_path, capsys):
    video, _ = walking_video
    with pytest.raises(SystemExit) as exc:
        cli.main(["pose", str(video), "--out", str(tmp_path / "k.csv"), "--model", "giant"])
    assert exc.value.code == 2
    assert "invalid choice: 'giant'" in capsys.readouterr().err


@pytest.mark.slow
def test_the_command_passes_doubted_sides_on_lowered_and_flagged(camera, walking_video, landmarker, detector):
    """The network labels the person the other way round from its 8th run on, for good: the
    left/right check doubts the frames of the change (docs/pose-command.md, "Doubted sides").
    As the command runs the stage, those keypoints carry ``left_right_uncertain`` = 1 and a
    confidence of at most the card's keypoint gate, below its triangulation gate; only left/right
    keypoints are doubted, and the others keep the network's confidences."""
    from test_upright_views import _SwappingLandmarker

    from ergopose.commands.pose import stage_settings
    from ergopose.keypoints import MIRROR
    from ergopose.pipeline.pose_video import pose_video

    video, _ = walking_video
    gates = landmarker.card.gates
    settings = stage_settings(gates, FPS, 8)
    assert settings.uncertain_confidence == gates.min_keypoint_confidence < gates.min_triangulation_confidence
    swapping = _SwappingLandmarker(landmarker, range(8, 10_000))
    result = pose_video(video, camera, FPS, 0, FRAMES, swapping, detector, settings)
    table = result.table
    assert tuple(table.columns) == POSE_COLUMNS
    paired = {name for i, name in enumerate(JOINT_INDEX) if MIRROR[i] != i}
    flagged = table[table["left_right_uncertain"] == 1]
    assert len(flagged), "no keypoint doubted"
    assert set(flagged["joint"]) <= paired  # the nose, say, has no side to doubt
    assert flagged["confidence"].max() <= gates.min_keypoint_confidence + 1e-9
    # Whole people doubted (every left/right keypoint), and counted in the command's summary.
    whole = [
        k for k, g in table.groupby(["frame", "person"]) if g[g["joint"].isin(paired)]["left_right_uncertain"].all()
    ]
    assert whole and result.uncertain_person_frames >= len(whole)
    trusted = table[(table["left_right_uncertain"] == 0) & table["joint"].isin(paired)]
    assert trusted["confidence"].max() > 0.5


@pytest.mark.slow
def test_the_upright_check_is_counted_and_costs_a_network_run_per_check(camera, walking_video, landmarker, detector):
    """As the command runs the stage, every person view turned more than the check's angle from
    upright is run a second time upright: with the check at 0 degrees every turned view is
    checked, each check is one more run of the network, and the result counts the checks and the
    disputes; without it nothing is checked."""
    from ergopose.commands.pose import stage_settings
    from ergopose.pipeline.pose_video import pose_video

    video, _ = walking_video

    class Counting:
        def __init__(self, inner):
            self.inner, self.runs = inner, 0
            self.input_size, self.card = inner.input_size, inner.card

        def __call__(self, image):
            self.runs += 1
            return self.inner(image)

    command = stage_settings(landmarker.card.gates, FPS, 8)
    runs, results = {}, {}
    for name, check in (("without", None), ("every turned view", 0.0)):
        counting = Counting(landmarker)
        settings = dataclasses.replace(command, left_right_upright_check=check)
        results[name] = pose_video(video, camera, FPS, 0, FRAMES, counting, detector, settings)
        runs[name] = counting.runs
    assert results["without"].upright_checks == results["without"].upright_disputed == 0
    checked = results["every turned view"]
    assert checked.upright_checks > 0 and 0 <= checked.upright_disputed <= checked.upright_checks
    assert runs["every turned view"] == runs["without"] + checked.upright_checks, runs


# --- the output folder: CSV, Parquet, COCO JSON and the overlay; a folder of images ----------------


def _check_folder(out, truth, images: bool) -> pd.DataFrame:
    """The folder's three tables agree with each other and with the drawn person."""
    table = pd.read_csv(out / "keypoints.csv")
    _check_keypoints(table, truth)
    parquet = pd.read_parquet(out / "keypoints.parquet")
    assert tuple(parquet.columns) == POSE_COLUMNS and len(parquet) == len(table)
    assert np.allclose(
        parquet[["x_px", "y_px", "confidence"]].to_numpy(float), table[["x_px", "y_px", "confidence"]], equal_nan=True
    )
    assert (parquet["joint"].to_numpy() == table["joint"].to_numpy()).all()
    coco = json.loads((out / "keypoints.coco.json").read_text())
    names = coco["categories"][0]["keypoints"]
    assert len(names) == 33 and all(1 <= i <= 33 for pair in coco["categories"][0]["skeleton"] for i in pair)
    assert [im["id"] for im in coco["images"]] == list(range(FRAMES))
    gate = float(re.search(r">= ([0-9.]+)", coco["info"]["visibility"]).group(1))
    people = table.groupby(["frame", "person"])
    assert len(coco["annotations"]) == people.ngroups
    for ann in coco["annotations"]:
        rows = people.get_group((ann["image_id"], ann["person"])).set_index("joint").loc[names]
        k = np.array(ann["keypoints"], float).reshape(33, 3)
        placed = rows["x_px"].notna().to_numpy()
        assert np.allclose(k[placed, :2], rows[["x_px", "y_px"]].to_numpy(float)[placed], atol=0.011)
        want_v = np.where(placed, np.where(rows["confidence"].to_numpy() >= gate, 2, 1), 0)
        assert (k[:, 2] == want_v).all() and ann["num_keypoints"] == int((want_v == 2).sum())
        x0, y0, w, h = ann["bbox"]
        assert x0 == pytest.approx(rows["x_px"].min(), abs=0.011) and x0 + w == pytest.approx(
            rows["x_px"].max(), abs=0.02
        )
        assert ann["area"] == pytest.approx(w * h, abs=0.05)
    frame_names = {im["id"]: im["file_name"] for im in coco["images"]}
    if images:
        assert frame_names[2] == "frame_2.png" and frame_names[9] == "frame_10.png"
    return table


def _drawn_near_keypoints(
    source: np.ndarray, overlay: np.ndarray, table: pd.DataFrame, frame: int
) -> tuple[float, float]:
    """Mean absolute change of the overlay against the source at the frame's confident
    keypoints and far from the person (more than 150 px from every keypoint)."""
    rows = table[(table["frame"] == frame) & (table["confidence"] >= 0.5)]
    xy = rows[["x_px", "y_px"]].to_numpy(float)
    diff = np.abs(overlay.astype(float) - source.astype(float)).sum(axis=2)
    near = np.mean([diff[int(round(y)), int(round(x))] for x, y in xy])
    yy, xx = np.mgrid[0 : diff.shape[0], 0 : diff.shape[1]]
    dist = np.min(np.hypot(xx[..., None] - xy[:, 0], yy[..., None] - xy[:, 1]), axis=-1)
    far = float(diff[(dist > 150) & (np.hypot(xx - CIRCLE[0], yy - CIRCLE[1]) < CIRCLE[2] - 5)].mean())
    return float(near), far


@pytest.mark.slow
def test_pose_writes_a_folder_with_csv_parquet_coco_and_an_overlay_video(
    camera, walking_video, fetched_model_dir, tmp_path, capsys
):
    video, truth = walking_video
    calibration = save_calibration(tmp_path / "calibration.toml", [camera])
    out = tmp_path / "out"
    args = ("pose", video, "--calibration", calibration, "--camera", "cam_1", "--out", out, "--overlay")
    code, stdout, lines = _run(capsys, *args, "--model-dir", fetched_model_dir[0], "--model", "full")
    assert code == 0, lines
    assert sorted(p.name for p in out.iterdir()) == [
        "keypoints.coco.json",
        "keypoints.csv",
        "keypoints.parquet",
        "overlay.mp4",
    ]
    for name in ("keypoints.csv", "keypoints.parquet", "keypoints.coco.json", "overlay.mp4"):
        assert str(out / name) in stdout
    table = _check_folder(out, truth, images=False)
    source = cv2.VideoCapture(str(video))
    drawn = cv2.VideoCapture(str(out / "overlay.mp4"))
    assert int(drawn.get(cv2.CAP_PROP_FRAME_COUNT)) == FRAMES
    for f in range(FRAMES):
        ok_s, a = source.read()
        ok_d, b = drawn.read()
        assert ok_s and ok_d and a.shape == b.shape
        if f in set(table["frame"]):
            near, far = _drawn_near_keypoints(a, b, table, f)
            # Drawn at the keypoints; elsewhere only the codec's noise of a second encoding.
            assert near > 60 and near > 10 * far, (f, near, far)
    # Again without --force: refused, the folder as it was; with --force: replaced.
    before = (out / "keypoints.csv").read_bytes()
    code, _, lines = _run(capsys, *args, "--model-dir", fetched_model_dir[0], "--model", "full")
    assert code != 0 and len(lines) == 1 and "--force" in lines[0] and str(out) in lines[0]
    (tmp_path / ".out.stale0.tmp").mkdir()  # what a killed run left beside --out: tidied by the next
    code, _, lines = _run(capsys, *args, "--model-dir", fetched_model_dir[0], "--model", "full", "--force")
    assert code == 0, lines
    assert (out / "keypoints.csv").read_bytes() == before  # the same frames, the same keypoints
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no staging folder left, none stale


@pytest.mark.slow
def test_pose_on_a_folder_of_images_in_name_order(camera, walking_video, fetched_model_dir, tmp_path, capsys):
    """The video's frames as frame_0.png .. frame_9.png (frame_10 for the last: the names' numbers
    order them, not their letters), a text file beside them; the calibration's only camera."""
    video, truth = walking_video
    folder = tmp_path / "cam_1"
    folder.mkdir()
    names = [f"frame_{k}.png" for k in range(FRAMES - 1)] + ["frame_10.png"]
    for name, (_, image) in zip(names, read_frames(video, 0, FRAMES)):
        cv2.imwrite(str(folder / name), image)
    (folder / "notes.txt").write_text("not an image\n")
    calibration = save_calibration(tmp_path / "calibration.toml", [camera])
    out = tmp_path / "out"
    code, stdout, lines = _run(
        capsys,
        "pose",
        folder,
        "--calibration",
        calibration,
        "--out",
        out,
        "--overlay",
        "--fps",
        FPS,
        "--model-dir",
        fetched_model_dir[0],
        "--model",
        "full",
    )
    assert code == 0, lines
    table = _check_folder(out, truth, images=True)
    drawn = sorted(p.name for p in (out / "overlay").iterdir())
    assert drawn == sorted(Path(n).stem + ".jpg" for n in names)
    f = int(table["frame"].iloc[0])
    near, far = _drawn_near_keypoints(
        cv2.imread(str(folder / names[f])), cv2.imread(str(out / "overlay" / (Path(names[f]).stem + ".jpg"))), table, f
    )
    assert near > 60 and near > 10 * far, (near, far)


@pytest.mark.parametrize(
    "case",
    [
        "overlay into a csv",
        "fps of a video",
        "no images",
        "out is a file",
        "out holds other files",
        "camera named twice",
        "fps 0",
        "no readable image for the circle",
    ],
)
def test_bad_output_and_source_arguments_are_one_line_and_a_non_zero_exit(case, tmp_path, capsys):
    video = _write(tmp_path / "cam_1.mp4", [np.zeros((64, 64, 3), np.uint8)] * 2)
    out = tmp_path / "out"
    args: list = [video, "--out", out]
    words: tuple = ()
    if case == "overlay into a csv":
        out = tmp_path / "k.csv"
        args, words = [video, "--out", out, "--overlay"], ("--overlay", "--out DIR")
    elif case == "fps of a video":
        args, words = [video, "--out", out, "--fps", "5"], ("--fps", "folder of images")
    elif case == "no images":
        (tmp_path / "empty").mkdir()
        (tmp_path / "empty" / "notes.txt").write_text("x")
        args, words = [tmp_path / "empty", "--out", out], ("empty", "no image")
    elif case == "out is a file":
        out.write_text("mine\n")
        words = ("out", "is a file")
    elif case == "out holds other files":
        out.mkdir()
        (out / "thesis.docx").write_text("mine\n")
        args, words = [video, "--out", out, "--force"], ("thesis.docx", "choose a new --out")
    elif case == "camera named twice":
        args += ["--calibration", tmp_path / "c.toml", "--camera", "a", "--camera-name", "b"]
        words = ("--camera-name", "second time")
    elif case == "fps 0":
        args, words = [tmp_path, "--out", out, "--fps", "0"], ("--fps", "> 0")
    elif case == "no readable image for the circle":
        folder = tmp_path / "frames"
        folder.mkdir()
        cv2.imwrite(str(folder / "f_0.png"), np.zeros((64, 64, 3), np.uint8))
        (folder / "f_1.png").write_bytes(b"damaged")
        args, words = [folder, "--out", out, "--start", "1"], ("frames", "none of the 1 images sampled")
    before = sorted(p.name for p in tmp_path.rglob("*"))
    code, stdout, lines = _run(capsys, "pose", *args)
    assert code != 0
    assert len(lines) == 1 and lines[0].startswith("ergopose: error:"), lines
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # nothing written, nothing removed
