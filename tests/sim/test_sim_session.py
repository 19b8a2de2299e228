"""`ergopose simulate` end to end: a valid, reproducible session whose ground truth fits its videos."""

from __future__ import annotations

import hashlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from ergopose.cli import main
from ergopose.keypoints import JOINT_INDEX as J
from ergopose.report.adapters import FLOOR_KINDS, load_floor_plan
from ergopose.session import load_session
from ergopose.sim.ground_truth import load_ground_truth
from ergopose.sim.oracle import OracleSource
from ergopose.sim.bodies import all_body_primitives
from ergopose.sim.render import CameraRenderer, RenderOptions
from ergopose.sim.scene import default_scene
from ergopose.sim.writer import add_floor_plan

# End to end (simulated sessions, whole runs): left out by make test-fast.
pytestmark = pytest.mark.slow

GT_FILES = ("scene.toml", "joints.npz", "postures.parquet")


def _simulate(out: Path, *extra: str) -> Path:
    code = main(["simulate", "--out", str(out), "--workers", "2", "--minutes", "0.1", *extra])
    assert code == 0
    return out


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    root = tmp_path_factory.mktemp("sim")
    a = _simulate(root / "a", "--seed", "7")
    b = _simulate(root / "b", "--seed", "7")
    c = _simulate(root / "c", "--seed", "8")
    return a, b, c


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _frames(path: Path) -> list[np.ndarray]:
    cap = cv2.VideoCapture(str(path))
    out = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        out.append(frame)
    cap.release()
    return out


def test_simulated_session_is_valid(sessions):
    s = load_session(sessions[0])
    assert s.camera_names == ("cam_1", "cam_2")
    assert s.frame_count == 72 and s.fps == 12.0
    assert s.ground_truth_dir is not None
    assert [w.worker_id for w in s.workers] == ["w1", "w2"]
    assert s.cameras[0].camera.width == 1024 and s.cameras[0].camera.height == 768
    gt = load_ground_truth(sessions[0])
    assert gt.joints_world.shape == (72, 2, 33, 3)
    assert gt.pixels.shape == (72, 2, 2, 33, 2) and gt.visibility.shape == (72, 2, 2, 33)
    assert gt.camera_names == s.camera_names and gt.worker_ids == ("w1", "w2")
    assert len(gt.postures) == 144 and set(gt.postures["worker"]) == {"w1", "w2"}
    assert gt.scene["simulated"] is True and gt.scene["generator"]["seed"] == 7
    assert {b["name"] for b in gt.reference_bars()} == {"bar_central", "bar_outer", "bar_edge"}


def test_simulated_session_has_the_scene_as_its_floor_plan(sessions):
    """The report's floor map comes from the session's floor.toml, which simulate writes from its
    scene: the same area and the same furniture as the ground truth's scene.toml."""
    s = load_session(sessions[0])
    assert s.floor_plan_path == sessions[0] / "floor.toml"
    scene = default_scene()
    plan = load_floor_plan(s.floor_plan_path, cameras=[("cam_1", -0.75, 0.0)])
    assert (plan.x_min, plan.x_max, plan.y_min, plan.y_max) == scene.area
    drawn = [b for b in scene.boxes if b.kind in FLOOR_KINDS]
    assert [f.name for f in plan.furniture] == [b.name for b in drawn] and len(drawn) > 5
    assert all((f.x0, f.y0, f.x1, f.y1) == (b.lo[0], b.lo[1], b.hi[0], b.hi[1]) for f, b in zip(plan.furniture, drawn))
    assert [c.name for c in plan.cameras] == ["cam_1"]
    gt_boxes = load_ground_truth(sessions[0]).scene["boxes"]
    assert [b["name"] for b in gt_boxes] == [b.name for b in scene.boxes]


def test_a_session_simulated_without_floor_plan_gets_the_same_one(sessions, tmp_path):
    """Sessions simulated before floor.toml existed get it from their ground truth's scene
    (ergopose demo does this for its reused demo session): byte for byte what simulate writes."""
    old = tmp_path / "old"
    old.mkdir()
    for p in sessions[0].iterdir():
        if p.name != "floor.toml":
            (old / p.name).symlink_to(p)
    assert add_floor_plan(old) is True
    assert (old / "floor.toml").read_bytes() == (sessions[0] / "floor.toml").read_bytes()
    assert add_floor_plan(old) is False and add_floor_plan(tmp_path) is False


def test_same_seed_same_session_other_seed_differs(sessions):
    a, b, c = sessions
    for name in GT_FILES:
        assert _digest(a / "ground_truth" / name) == _digest(b / "ground_truth" / name), name
    assert _digest(a / "settings.toml") == _digest(b / "settings.toml")
    assert _digest(a / "calibration.toml") == _digest(b / "calibration.toml")
    for cam in ("cam_1.mp4", "cam_2.mp4"):
        fa, fb = _frames(a / cam), _frames(b / cam)
        assert len(fa) == len(fb) == 72
        assert all(np.array_equal(x, y) for x, y in zip(fa, fb))
    assert _digest(a / "ground_truth" / "joints.npz") != _digest(c / "ground_truth" / "joints.npz")
    assert not np.array_equal(_frames(a / "cam_1.mp4")[40], _frames(c / "cam_1.mp4")[40])


def test_ground_truth_joints_lie_on_the_rendered_workers(sessions):
    """At visible hips, shoulders and noses the decoded video shows the worker, not the empty scene;
    pixels far from every worker match the empty scene (up to noise and compression)."""
    from ergopose.sim.motion import simulate_motion

    root = sessions[0]
    s = load_session(root)
    gt = load_ground_truth(root)
    scene = default_scene()
    bodies = all_body_primitives(simulate_motion(scene, 2, 6.0, 12.0, seed=7))
    sturdy = [J[n] for n in ("left_hip", "right_hip", "left_shoulder", "right_shoulder", "nose")]
    clean = RenderOptions(noise_sigma=0.0, brightness_drift=0.0)
    for c, sc in enumerate(s.cameras):
        empty = CameraRenderer(sc.camera, scene, [], clean).render(0).astype(int)
        full = CameraRenderer(sc.camera, scene, bodies, clean)
        frames = _frames(sc.video_path)
        closer, counted = 0, 0
        for f in range(0, 72, 6):
            video = frames[f].astype(int)
            with_workers = full.render(f).astype(int)
            for w in range(2):
                for j in sturdy:
                    if gt.visibility[f, c, w, j] != 0:
                        continue
                    u, v = np.rint(gt.pixels[f, c, w, j]).astype(int)
                    if np.abs(with_workers[v, u] - empty[v, u]).sum() < 30:
                        continue  # clothes the colour of the floor: this pixel cannot tell
                    counted += 1
                    closer += np.abs(video[v, u] - with_workers[v, u]).sum() < np.abs(video[v, u] - empty[v, u]).sum()
            proj = gt.pixels[f, c].reshape(-1, 2)
            vv, uu = np.mgrid[20 : sc.camera.height - 20 : 9, 20 : sc.camera.width - 20 : 9]
            far = np.min(np.hypot(uu[..., None] - proj[:, 0], vv[..., None] - proj[:, 1]), axis=-1) > 80
            assert np.median(np.abs(video[vv[far], uu[far]] - empty[vv[far], uu[far]]).sum(axis=-1)) <= 12
        assert counted > 40 and closer / counted > 0.95, (sc.name, closer, counted)


def test_ground_truth_matches_a_fresh_render_of_the_motion(sessions):
    """The stored joints are the motion the videos show: re-render frame 30 from the stored ground truth's
    statures and seed and compare it with the decoded video frame."""
    from ergopose.sim.motion import simulate_motion

    root = sessions[0]
    gt = load_ground_truth(root)
    motion = simulate_motion(default_scene(), 2, 6.0, 12.0, seed=7)
    assert np.array_equal(motion.joints_world, gt.joints_world)
    s = load_session(root)
    r = CameraRenderer(
        s.cameras[0].camera, default_scene(), all_body_primitives(motion), RenderOptions(noise_sigma=0.0)
    )
    video = _frames(s.cameras[0].video_path)[30].astype(int)
    assert np.abs(video - r.render(30).astype(int)).mean() < 4.0


def test_person_table_for_detection_statistics(sessions):
    gt = load_ground_truth(sessions[0])
    table = gt.person_table()
    assert len(table) == 72 * 2 * 2
    assert set(table["region"].dropna()) <= {"central", "outer", "edge"}
    row = table.iloc[0]
    assert row["u_min"] <= row["u_max"] and 0 <= row["n_visible"] <= row["n_in_image"] <= 33


def test_oracle_observations(sessions):
    gt = load_ground_truth(sessions[0])
    exact = OracleSource(gt, noise_px=0.0, occluded_noise_px=0.0, person_dropout=0.0, joint_dropout=0.0).observe()
    assert exact.source == "oracle"
    assert exact.pixels_fisheye.shape == (72, 2, 2, 33, 2)
    vis = exact.visibility
    assert np.array_equal(exact.pixels_fisheye[vis], gt.pixels[vis].astype(np.float64))
    assert (exact.confidence[vis] >= 0.75).all() and (exact.confidence[~vis] <= 0.4).all()
    noisy = OracleSource(gt, noise_px=2.0, person_dropout=0.1, joint_dropout=0.05, seed=3)
    obs = noisy.observe()
    err = obs.pixels_fisheye[vis] - gt.pixels[vis]
    err = err[np.isfinite(err).all(axis=1)]
    assert 1.7 < err.std() < 2.3
    assert 0.05 < 1.0 - obs.detected[vis.any(axis=-1)].mean() < 0.16
    # seeded, and a frame's errors do not depend on which frames are asked for
    again = noisy.observe(frames=[5, 40])
    assert np.array_equal(again.pixels_fisheye, obs.pixels_fisheye[[5, 40]], equal_nan=True)
    other = OracleSource(gt, noise_px=2.0, seed=4).observe(frames=[5])
    assert not np.array_equal(other.pixels_fisheye, obs.pixels_fisheye[[5]], equal_nan=True)
    frame = obs.to_frame()
    assert (frame["source"] == "oracle").all() and len(frame) == 72 * 2 * 2 * 33


def test_oracle_can_report_the_joints_behind_the_own_body_as_seen(sessions):
    from ergopose.sim.visibility import OCCLUDED_BY_SCENE, OUTSIDE_IMAGE, SELF_OCCLUDED, VISIBLE

    gt = load_ground_truth(sessions[0])
    codes = gt.visibility
    behind = codes == SELF_OCCLUDED
    assert behind.sum() > 500  # a ceiling camera sees most limbs through their own flesh
    options = dict(noise_px=2.0, occluded_noise_px=6.0, person_dropout=0.0, joint_dropout=0.0, seed=5)
    hides = OracleSource(gt, **options).observe()
    seen = OracleSource(gt, own_body_hides=False, **options).observe()
    # Joints behind the own body: hidden by default (low confidence, 6 px), seen with the option.
    assert (hides.confidence[behind] <= 0.4).all() and (seen.confidence[behind] >= 0.75).all()
    assert not hides.visibility[behind].any() and seen.visibility[behind].all()
    err = (seen.pixels_fisheye - gt.pixels)[behind]
    assert 1.7 < err[np.isfinite(err).all(axis=1)].std() < 2.3
    err = (hides.pixels_fisheye - gt.pixels)[behind]
    assert 5.2 < err[np.isfinite(err).all(axis=1)].std() < 6.8
    # Everything else is the same draw: visible joints alike, and whatever else hides still hides.
    visible = codes == VISIBLE
    assert np.array_equal(seen.pixels_fisheye[visible], hides.pixels_fisheye[visible], equal_nan=True)
    assert np.array_equal(seen.confidence[visible], hides.confidence[visible])
    other = (codes != VISIBLE) & (codes != SELF_OCCLUDED) & (codes != OUTSIDE_IMAGE)
    assert np.array_equal(seen.pixels_fisheye[other], hides.pixels_fisheye[other], equal_nan=True)
    assert (seen.confidence[other] <= 0.4).all()
    assert (codes[other] == OCCLUDED_BY_SCENE).any()  # the furniture hides some: the checks above are not empty


def test_oracle_into_a_virtual_view(sessions):
    from ergopose.geometry.views import VirtualView

    s = load_session(sessions[0])
    gt = load_ground_truth(sessions[0])
    obs = OracleSource(gt, noise_px=0.0, occluded_noise_px=0.0, person_dropout=0.0, joint_dropout=0.0).observe()
    cam = s.cameras[0].camera
    target = gt.joints_world[10, 0, [J["left_hip"], J["right_hip"]]].mean(axis=0)
    view = VirtualView.aimed_at(cam, target, hfov=np.radians(60), size=(256, 256))
    px = obs.view_pixels(view, "cam_1")[10, 0]
    direct = view.project_world(gt.joints_world[10, 0])
    ok = np.isfinite(px).all(axis=1)
    assert ok.sum() > 10
    assert np.abs(px[ok] - direct[ok]).max() < 1e-2


def test_simulate_refuses_to_overwrite_and_bad_arguments(tmp_path, capsys):
    out = tmp_path / "s"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    assert main(["simulate", "--out", str(out), "--minutes", "0.05"]) == 2
    assert "use --force" in capsys.readouterr().err
    assert (out / "keep.txt").exists()
    assert main(["simulate", "--out", str(tmp_path / "t"), "--workers", "6"]) == 2
    assert "1 to 4 workers" in capsys.readouterr().err
    assert main(["simulate", "--out", str(tmp_path / "u"), "--size", "321x240"]) == 2
    assert "even" in capsys.readouterr().err
