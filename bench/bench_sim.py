"""The simulator: how fast a session renders, and whether BlazePose finds the rendered people.

Goal (docs/simulator.md): a 5-minute, 2-worker session at 12 fps (3600 frame pairs) renders in
under 3 minutes on 2 cores, i.e. at least 20 frame pairs per second, both cameras at the default
size, video encoding and ground-truth visibility included.

Benches:
  simulate_render_fps   frame pairs per second through the same path as `ergopose simulate`
                        (one process per camera: render, mp4v encoding, joint visibility)
  sim_render_frame_ms   one camera frame (2 workers) rendered in one process, no encoding
  sim_motion_ms         scripting 4 workers for 5 minutes
  sim_blazepose_found   share of visible people the BlazePose landmark network finds in 256 x 256
                        upright views aimed at them (only when the model is in the cache)
"""

from __future__ import annotations

import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from common import best_time, emit  # noqa: E402

from ergopose.sim.motion import simulate_motion  # noqa: E402
from ergopose.sim.bodies import all_body_primitives  # noqa: E402
from ergopose.sim.render import CameraRenderer, RenderOptions  # noqa: E402
from ergopose.sim.visibility import joint_visibility  # noqa: E402
from ergopose.sim.scene import DEFAULT_SIZE, default_scene, rig_cameras  # noqa: E402
from ergopose.sim.writer import SimulationConfig, render_cameras  # noqa: E402

SECONDS = 60.0
WORKERS = 2


def bench_render_fps() -> None:
    scene = default_scene()
    cams = rig_cameras(*DEFAULT_SIZE)
    motion = simulate_motion(scene, WORKERS, SECONDS, 12.0, seed=1)
    bodies = all_body_primitives(motion)
    config = SimulationConfig(workers=WORKERS, minutes=SECONDS / 60.0, seed=1, processes=2)
    with tempfile.TemporaryDirectory() as tmp:
        cpu0 = _cpu_seconds()
        t0 = time.perf_counter()
        render_cameras(Path(tmp), scene, cams, motion, bodies, ["cam_1.mp4", "cam_2.mp4"], config)
        elapsed = time.perf_counter() - t0
        cpu = _cpu_seconds() - cpu0
        size_mb = sum(p.stat().st_size for p in Path(tmp).glob("*.mp4")) / 1e6
    fps = motion.n_frames / elapsed
    cpu_ms = cpu * 1e3 / motion.n_frames
    # Other jobs on the machine slow the wall clock; the CPU time per frame pair does not depend on them.
    emit(
        "simulate_render_fps",
        fps,
        "frame_pairs/s",
        goal=20.0,
        size=f"{DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]}",
        workers=WORKERS,
        frames=motion.n_frames,
        processes="one per camera",
        includes="render + mp4v encoding + joint visibility, both cameras (process start included)",
        five_minute_session_s=round(3600 / fps, 1),
        video_mb_per_minute=round(size_mb * 60.0 / SECONDS, 1),
        cpu_ms_per_frame_pair=round(cpu_ms, 2),
        idle_two_core_estimate_fps=round(2000.0 / cpu_ms, 1),
        load_average_1min=round(os.getloadavg()[0], 2),
    )
    r = CameraRenderer(cams[0], scene, bodies, RenderOptions())
    frames = iter(range(10_000_000))
    t = best_time(lambda: r.render(next(frames) % motion.n_frames), repeat=5, number=40)
    emit(
        "sim_render_frame_ms",
        t * 1e3,
        "ms",
        size=f"{DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]}",
        workers=WORKERS,
        camera=cams[0].name,
    )


def _cpu_seconds() -> float:
    """User + system CPU time of this process and its finished children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def bench_motion() -> None:
    scene = default_scene()
    t = best_time(lambda: simulate_motion(scene, 4, 300.0, 12.0, seed=2), repeat=3)
    emit("sim_motion_ms", t * 1e3, "ms", workers=4, minutes=5, fps=12)


def bench_blazepose_found() -> None:
    from ergopose.pose.models import BLAZEPOSE_LANDMARK_FULL, model_status

    if model_status(BLAZEPOSE_LANDMARK_FULL).state != "ok":
        print("bench_sim: BlazePose landmark model not in the cache; skipping sim_blazepose_found", file=sys.stderr)
        return
    import cv2

    from ergopose.geometry.views import VirtualView
    from ergopose.keypoints import JOINT_INDEX as J
    from ergopose.pose.blazepose import BlazePoseLandmarker
    from ergopose.sim.scene import LENS_REGIONS_DEG, lens_region

    lm = BlazePoseLandmarker(num_threads=1)
    scene = default_scene()
    motion = simulate_motion(scene, 3, 40.0, 12.0, seed=5)
    bodies = all_body_primitives(motion)
    hips, shoulders = [J["left_hip"], J["right_hip"]], [J["left_shoulder"], J["right_shoulder"]]
    for size in (DEFAULT_SIZE, (640, 480)):
        counts: dict[str, list[int]] = {name: [0, 0] for name, _, _ in LENS_REGIONS_DEG}
        extents = []
        for cam in rig_cameras(*size):
            r = CameraRenderer(cam, scene, bodies, RenderOptions())
            px, th, codes = joint_visibility(cam, scene, motion, bodies)
            for f in range(0, motion.n_frames, 8):
                ok, enc = cv2.imencode(".jpg", r.render(f), [cv2.IMWRITE_JPEG_QUALITY, 85])
                img = cv2.imdecode(enc, cv2.IMREAD_COLOR)
                for w in range(len(bodies)):
                    if not (codes[f, w, hips + shoulders] == 0).all():
                        continue  # count people whose torso the camera sees
                    joints = motion.joints_world[f, w]
                    hip = joints[hips].mean(axis=0)
                    rays = joints - cam.position_world
                    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
                    axis = (hip - cam.position_world) / np.linalg.norm(hip - cam.position_world)
                    half = np.clip(np.arccos(np.clip(rays @ axis, -1, 1)).max() * 1.25, np.radians(15), np.radians(70))
                    view = VirtualView.aimed_at(cam, hip, hfov=2 * half, size=(256, 256))
                    kp = lm(view.build_map().apply(img))
                    truth = view.project_world(joints)
                    torso = np.linalg.norm(truth[shoulders].mean(0) - truth[hips].mean(0))
                    err = np.linalg.norm(kp.pixels[hips].mean(0) - truth[hips].mean(0)) / max(torso, 1e-6)
                    region = LENS_REGIONS_DEG[int(lens_region(np.array(th[f, w, hips].mean())))][0]
                    counts[region][0] += int(kp.presence >= 0.5 and err < 0.5)
                    counts[region][1] += 1
                    seen = px[f, w][codes[f, w] != 4]
                    extents.append(float(np.max(seen.max(axis=0) - seen.min(axis=0))))
        found = sum(c[0] for c in counts.values())
        total = sum(c[1] for c in counts.values())
        emit(
            "sim_blazepose_found",
            found / max(total, 1),
            "fraction",
            size=f"{size[0]}x{size[1]}",
            people=total,
            per_region={k: f"{v[0]}/{v[1]}" for k, v in counts.items()},
            median_person_extent_px=round(float(np.median(extents)), 1),
            rule="presence >= 0.5 and hip centre within 0.5 torso lengths; view aimed at the true hips",
        )


def main() -> None:
    import cv2

    cv2.setNumThreads(1)
    bench_render_fps()
    bench_motion()
    bench_blazepose_found()


if __name__ == "__main__":
    main()
