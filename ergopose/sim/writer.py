"""A complete simulated session folder: videos, calibration, settings and ground truth.

:func:`simulate_session` is what ``ergopose simulate`` runs. The folder is built under a
temporary name beside the target and swapped into place when complete (ergopose.atomic), so a
crash never leaves a half-written session. The two cameras render in parallel, one process per
camera (each writes its own video and works out its own ground-truth visibility); short
sessions render in the calling process.

Determinism: the same configuration gives the same ground truth byte for byte, and the same
video frames with the same OpenCV build (mp4v encoding itself is deterministic).
"""

from __future__ import annotations

import datetime as dt
import math
import multiprocessing
import os
import queue
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import tomli_w

from ergopose import __version__
from ergopose.atomic import atomic_dir, write_text
from ergopose.calibration.check import write_bar_observations
from ergopose.errors import ConfigError
from ergopose.geometry.calibration_file import save_calibration
from ergopose.progress import ProgressCallback, report
from ergopose.session import FLOOR_PLAN_FILE, TaskFactors, WorkerInfo, settings_to_toml
from ergopose.session import FactorPeriod as SessionPeriod
from ergopose.sim.ground_truth import GROUND_TRUTH_VERSION, load_ground_truth, write_ground_truth
from ergopose.sim.motion import simulate_motion
from ergopose.sim.workforce import Motion, TASKS
from ergopose.sim.bodies import BodyPrimitives, all_body_primitives
from ergopose.sim.render import RenderOptions, render_video
from ergopose.sim.visibility import VISIBILITY_CODES, joint_visibility
from ergopose.sim.scene import (
    DEFAULT_FPS,
    DEFAULT_SIZE,
    LENS_REGIONS_DEG,
    Scene,
    default_scene,
    lens_region,
    rig_cameras,
)

#: The recording start written into simulated sessions (fixed, so the same seed gives the same files).
DEFAULT_START = dt.datetime(2024, 3, 4, 8, 0, 0, tzinfo=dt.timezone(dt.timedelta(hours=1)))
#: Below this many frames the cameras render in the calling process (starting processes costs more).
PARALLEL_MIN_FRAMES = 240


@dataclass(frozen=True)
class SimulationConfig:
    """What ``ergopose simulate`` makes.

    workers: 1-4. minutes: session length. seed: every random choice. size: (width, height).
    fps: frame rate. start: recording start. render: camera effects (noise, blur, brightness).
    processes: render processes (None: one per camera, up to the CPUs, for long sessions).
    """

    workers: int = 2
    minutes: float = 5.0
    seed: int = 0
    size: tuple[int, int] = DEFAULT_SIZE
    fps: float = DEFAULT_FPS
    start: dt.datetime = DEFAULT_START
    render: RenderOptions = field(default_factory=RenderOptions)
    processes: int | None = None

    def check(self) -> None:
        if isinstance(self.workers, bool) or not isinstance(self.workers, int) or not 1 <= self.workers <= 4:
            raise ConfigError(f"expected 1 to 4 workers, got {self.workers!r}", field="workers")
        if not (isinstance(self.minutes, (int, float)) and math.isfinite(self.minutes) and self.minutes > 0):
            raise ConfigError(f"expected a positive number of minutes, got {self.minutes!r}", field="minutes")
        w, h = self.size
        if not (isinstance(w, int) and isinstance(h, int) and 64 <= w <= 8192 and 64 <= h <= 8192):
            raise ConfigError(f"expected a size between 64 x 64 and 8192 x 8192 pixels, got {w} x {h}", field="size")
        if w % 2 or h % 2:
            raise ConfigError(f"video sizes must be even (mp4v), got {w} x {h}", field="size")
        if not (math.isfinite(self.fps) and 1.0 <= self.fps <= 120.0):
            raise ConfigError(f"expected a frame rate between 1 and 120, got {self.fps!r}", field="fps")
        if int(round(self.minutes * 60.0 * self.fps)) < 2:
            raise ConfigError(f"{self.minutes} minutes at {self.fps:g} fps is fewer than 2 frames", field="minutes")


def simulate_session(
    out: str | os.PathLike, config: SimulationConfig = SimulationConfig(), progress: ProgressCallback | None = None
) -> Path:
    """Write a simulated session with ground truth to ``out`` (replaced if it exists); return its path."""
    config.check()
    out = Path(out)
    scene = default_scene()
    cameras = rig_cameras(*config.size)
    report(progress, "motion", 0, 1, unit="step", message="scripting the workers")
    motion = simulate_motion(scene, config.workers, config.minutes * 60.0, config.fps, config.seed)
    bodies = all_body_primitives(motion)
    report(progress, "motion", 1, 1, unit="step")
    with atomic_dir(out) as tmp:
        save_calibration(
            tmp / "calibration.toml",
            cameras,
            description=f"SIMULATED rig of ergopose simulate (seed {config.seed}): exact values",
        )
        videos = [f"{c.name}.mp4" for c in cameras]
        bars = write_bar_observations_for(tmp / BARS_FILE, scene, cameras, config.seed)
        (tmp / "settings.toml").write_text(_settings_text(config, motion, cameras, videos, bars), encoding="utf-8")
        (tmp / FLOOR_PLAN_FILE).write_text(floor_plan_text(scene), encoding="utf-8")
        per_camera = render_cameras(tmp, scene, cameras, motion, bodies, videos, config, progress)
        gt = tmp / "ground_truth"
        gt.mkdir()
        report(progress, "ground truth", 0, 1, unit="file")
        pixels = np.stack([p[0] for p in per_camera], axis=1)
        theta = np.stack([p[1] for p in per_camera], axis=1)
        vis = np.stack([p[2] for p in per_camera], axis=1)
        write_ground_truth(
            gt,
            scene_info=_scene_info(config, scene, cameras, motion),
            motion=motion,
            camera_names=[c.name for c in cameras],
            pixels=pixels,
            theta=theta,
            visibility=vis,
        )
        report(progress, "ground truth", 1, 1, unit="file")
    return out


#: The reference-bar observations of a simulated session (for the calibration check).
BARS_FILE = "reference_bars.csv"
#: Pixel noise (standard deviation, px) of the simulated bar-end observations: what a careful
#: person marking the bar ends in the two videos would achieve.
BAR_MARK_NOISE_PX = 0.5


def write_bar_observations_for(path: Path, scene, cameras, seed: int) -> float | None:
    """Write where the scene's reference bars' ends appear in every camera (with marking noise).

    Returns the bars' length (all have the same), or None when the scene has no bar.
    """
    bars = list(scene.bars)
    if not bars:
        return None
    ends = np.array([[b.end_a, b.end_b] for b in bars], dtype=np.float64)  # (M, 2, 3)
    rng = np.random.default_rng([int(seed), 7])
    pixels = np.stack([cam.project_world(ends) for cam in cameras], axis=1)  # (M, V, 2, 2)
    pixels = pixels + rng.normal(0.0, BAR_MARK_NOISE_PX, size=pixels.shape)
    write_bar_observations(path, [c.name for c in cameras], pixels, labels=[b.name for b in bars])
    return float(bars[0].length)


def _settings_text(
    config: SimulationConfig, motion: Motion, cameras, videos: list[str], bar_length: float | None = None
) -> str:
    workers = []
    for w in motion.workers:
        periods = tuple(
            SessionPeriod(
                start_s=p.start_s,
                end_s=p.end_s,
                factors=TaskFactors(load_kg=p.load_kg, load_mode=p.load_mode, coupling=p.coupling),
            )
            for p in _merge_periods(w.periods)
        )
        # The stature as a safety engineer would note it (to the centimetre): it lets ergopose tell
        # which tracked person is which worker.
        workers.append(
            WorkerInfo(
                worker_id=w.worker_id,
                name=f"Simulated worker {w.worker_id[1:]}",
                factors=TaskFactors(),
                periods=periods,
                stature_m=round(float(w.spec.stature), 2),
            )
        )
    header = (
        "# A SIMULATED session written by 'ergopose simulate' (docs/simulator.md); the format is in\n"
        "# docs/session-format.md. The workers' load periods are the simulation's ground truth; the number\n"
        "# of workers in the area ([reconstruction] expected_workers) is what a safety engineer would know.\n"
    )
    return settings_to_toml(
        recorded_at=config.start,
        fps=config.fps,
        cameras=[(c.name, v) for c, v in zip(cameras, videos)],
        description=(
            f"Simulated workplace: {config.workers} worker(s), {config.minutes:g} min, seed {config.seed}, "
            f"{config.size[0]} x {config.size[1]} px at {config.fps:g} fps"
        ),
        defaults=TaskFactors(
            load_kg=0.0, load_mode="intermittent", coupling="good", shock=False, arm_supported=False, seated=False
        ),
        workers=workers,
        header=header,
        calibration_check=(BARS_FILE, bar_length) if bar_length is not None else None,
        reconstruction={"expected_workers": int(config.workers)},
    )


def _merge_periods(periods) -> list:
    """Join periods that touch or overlap with the same factors (a lift, its carry and its placing)."""
    out: list = []
    for p in sorted(periods, key=lambda p: p.start_s):
        if out and p.start_s <= out[-1].end_s + 1e-6:
            last = out[-1]
            if (p.load_kg, p.load_mode, p.coupling) == (last.load_kg, last.load_mode, last.coupling):
                out[-1] = type(p)(last.start_s, max(last.end_s, p.end_s), p.load_kg, p.load_mode, p.coupling)
                continue
            if p.start_s < last.end_s:  # overlap with different factors: the later one starts later
                p = type(p)(last.end_s, p.end_s, p.load_kg, p.load_mode, p.coupling)
                if p.end_s <= p.start_s:
                    continue
        out.append(p)
    return out


def floor_plan_text(scene: Scene) -> str:
    """The session's floor.toml (docs/session-format.md): the scene's area and furniture boxes."""
    return _floor_plan_toml(list(scene.area), [b.to_dict() for b in scene.boxes])


def _floor_plan_toml(area: list, boxes: list[dict[str, Any]]) -> str:
    plan = {
        "area_m": [float(v) for v in area],
        "boxes": [
            {"name": b["name"], "kind": b["kind"], "lo": [float(v) for v in b["lo"]], "hi": [float(v) for v in b["hi"]]}
            for b in boxes
        ],
    }
    return (
        "# The monitored area and its furniture (world metres), for the report's floor map.\n"
        "# Written by ergopose simulate from its scene.\n" + tomli_w.dumps(plan)
    )


def add_floor_plan(session_dir: str | os.PathLike) -> bool:
    """Give a session simulated before sessions had a floor.toml the one simulate writes now,
    from the scene of its ground truth (area and furniture boxes). Nothing is done when the
    session has a floor.toml or no ground truth. Returns True when it wrote one."""
    folder = Path(session_dir)
    target = folder / FLOOR_PLAN_FILE
    if target.exists() or not (folder / "ground_truth").is_dir():
        return False
    scene = load_ground_truth(folder / "ground_truth").scene
    write_text(target, _floor_plan_toml(scene["area_m"], scene.get("boxes", [])))
    return True


def _scene_info(config: SimulationConfig, scene: Scene, cameras, motion: Motion) -> dict[str, Any]:
    bars = []
    for b in scene.bars:
        entry = b.to_dict()
        ends = np.array([b.end_a, b.end_b])
        for cam in cameras:
            th = cam.theta_of_points_world(ends)
            entry[f"{cam.name}_theta_deg"] = [round(float(np.degrees(t)), 6) for t in th]
            regions = {LENS_REGIONS_DEG[int(k)][0] for k in lens_region(th)}
            entry[f"{cam.name}_region"] = regions.pop() if len(regions) == 1 else "mixed"
        bars.append(entry)
    workers = []
    for w in motion.workers:
        m = w.spec.measurements
        workers.append(
            {
                "id": w.worker_id,
                "stature_m": m.stature,
                "walk_speed_m_s": w.spec.walk_speed,
                "measurements_m": {k: float(v) for k, v in vars(m).items()},
                "colours_bgr": w.spec.appearance.to_dict(),
            }
        )
    info = scene.to_dict()
    info["reference_bars"] = bars
    return {
        "ground_truth_version": GROUND_TRUTH_VERSION,
        "simulated": True,
        "generator": {"program": "ergopose simulate", "ergopose_version": __version__, "seed": config.seed},
        "session": {
            "workers": config.workers,
            "minutes": config.minutes,
            "fps": config.fps,
            "frames": motion.n_frames,
            "width": config.size[0],
            "height": config.size[1],
        },
        "render": {
            "noise_sigma": config.render.noise_sigma,
            "blur_sigma": config.render.blur_sigma,
            "brightness_drift": config.render.brightness_drift,
        },
        "task_names": list(TASKS),
        "visibility_codes": list(VISIBILITY_CODES),
        "lens_regions": [{"name": n, "theta_min_deg": lo, "theta_max_deg": hi} for n, lo, hi in LENS_REGIONS_DEG],
        "workers": workers,
        **info,
    }


# --- rendering the cameras (in parallel) ----------------------------------------------------------------


def _camera_options(config: SimulationConfig, index: int) -> RenderOptions:
    seed = int(np.random.SeedSequence([config.seed, index]).generate_state(1)[0])
    r = config.render
    return RenderOptions(
        noise_sigma=r.noise_sigma, blur_sigma=r.blur_sigma, brightness_drift=r.brightness_drift, seed=seed
    )


def _render_one(camera, scene, motion, bodies, path, fps, options, on_frame):
    cv2.setNumThreads(1)
    render_video(camera, scene, bodies, path, fps, options, on_frame=on_frame)
    return joint_visibility(camera, scene, motion, bodies)


def _child(index, camera, scene, motion, bodies, path, fps, options, messages) -> None:
    try:

        def on_frame(done: int) -> None:
            if done % 12 == 0 or done == motion.n_frames:
                messages.put(("progress", index, done))

        result = _render_one(camera, scene, motion, bodies, path, fps, options, on_frame)
        messages.put(("done", index, result))
    except BaseException:  # report everything to the parent, which raises
        messages.put(("error", index, traceback.format_exc()))


def render_cameras(
    folder: Path,
    scene: Scene,
    cameras,
    motion: Motion,
    bodies: list[BodyPrimitives],
    videos: list[str],
    config: SimulationConfig,
    progress: ProgressCallback | None = None,
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Render every camera's video into ``folder``; per camera (pixels, theta, visibility)."""
    n = motion.n_frames
    total = n * len(cameras)
    processes = config.processes
    if processes is None:
        processes = min(len(cameras), os.cpu_count() or 1) if n >= PARALLEL_MIN_FRAMES else 1
    report(progress, "render", 0, total, unit="frame")
    if processes <= 1:
        out = []
        for i, cam in enumerate(cameras):
            base = i * n

            def on_frame(done: int, base: int = base) -> None:
                if done % 12 == 0 or done == n:
                    report(progress, "render", base + done, total, unit="frame")

            out.append(
                _render_one(
                    cam, scene, motion, bodies, folder / videos[i], config.fps, _camera_options(config, i), on_frame
                )
            )
        return out
    ctx = multiprocessing.get_context("spawn")
    messages = ctx.Queue()
    results: dict[int, Any] = {}
    done = {i: 0 for i in range(len(cameras))}
    pending = list(range(len(cameras)))
    running: dict[int, Any] = {}
    try:
        while pending or running:
            while pending and len(running) < processes:
                i = pending.pop(0)
                proc = ctx.Process(
                    target=_child,
                    args=(
                        i,
                        cameras[i],
                        scene,
                        motion,
                        bodies,
                        folder / videos[i],
                        config.fps,
                        _camera_options(config, i),
                        messages,
                    ),
                    daemon=True,
                )
                proc.start()
                running[i] = proc
            try:
                kind, i, payload = messages.get(timeout=1.0)
            except queue.Empty:
                for i, proc in list(running.items()):
                    if not proc.is_alive() and i not in results:
                        raise RuntimeError(
                            f"the render process of {cameras[i].name} died (exit code {proc.exitcode})"
                        ) from None
                continue
            if kind == "progress":
                done[i] = payload
                report(progress, "render", sum(done.values()), total, unit="frame")
            elif kind == "done":
                results[i] = payload
                done[i] = n
                running.pop(i).join()
                report(progress, "render", sum(done.values()), total, unit="frame")
            else:
                raise RuntimeError(f"rendering {cameras[i].name} failed:\n{payload}")
    finally:
        for proc in running.values():
            proc.terminate()
            proc.join()
    return [results[i] for i in range(len(cameras))]
