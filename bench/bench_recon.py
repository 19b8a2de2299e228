"""Reconstruction over a shift: speed of tracking + smoothing, accuracy from 2D, aniposelib.

- track_smooth_8h: tracking and smoothing an 8-hour shift of 4 workers at 12 fps from stored
  triangulations (345,600 frames x 4 workers x 33 joints), processed in one-hour chunks with
  ShiftReconstruction (goal: under 10 minutes on 2 cores). Also the time to write the Parquet
  tracks table, identity switches and the MPJPE of the smoothed tracks.
- recon_synthetic_10min: 4 synthetic workers (ergonomics.body) for 10 simulated minutes under
  two 2592 x 1944 Kannala-Brandt ceiling cameras; 2D = projection + 2 px Gaussian noise + 2 %
  dropouts + occlusions (hidden from one camera, from both, leaving the area); the whole
  pipeline from Detections2D: MPJPE raw / smoothed / smoothed + bone-length constraint,
  identity switches, limb-length CV, errors by lens region.
- recon_vs_aniposelib: the same kind of 2D input (fisheye pixels, one minute of 4 workers):
  ours (association, DLT in virtual views, tracking, Kalman/RTS) against aniposelib's
  CameraGroup.triangulate and triangulate_optim (given the true correspondences), 3D error and
  time.
- recon_oracle_10min: the simulator's workers, room and visibility with its ORACLE 2D source
  (2 px noise), at 2592 x 1944 and at the simulator's default 1024 x 768.

Usage: python bench/bench_recon.py [--hours H] [names...]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from common import emit  # noqa: E402

from ergopose.keypoints import LIMB_INDEX, LIMBS  # noqa: E402
from ergopose.recon import diagnostics as D  # noqa: E402
from ergopose.recon.pipeline import ShiftReconstruction, TrackFrames  # noqa: E402
from ergopose.recon.records import People3D  # noqa: E402
from ergopose.recon.settings import ReconSettings  # noqa: E402
from ergopose.sim.synthetic import WorkerScript, observe, rig, walk_workers  # noqa: E402
from ergopose.recon.track_signatures import limb_lengths  # noqa: E402

FPS = 12.0
MAJOR = [i for i, (n, _, _) in enumerate(LIMBS) if not n.endswith(("_foot", "_hand"))]
STATURES = (1.62, 1.71, 1.80, 1.89)


def quadrant_scripts(rng: np.random.Generator, hours: float) -> list[WorkerScript]:
    """Four workers, each mostly in its own quadrant, with trips through the middle."""
    out = []
    n_way = int(hours * 3600 / 8) + 10
    for k, (sx, sy) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1))):
        wp = np.c_[sx * rng.uniform(0.3, 2.6, n_way), sy * rng.uniform(0.3, 2.6, n_way)]
        trips = rng.random(n_way) < 0.15  # now and then to the middle (paths cross there)
        wp[trips] = rng.uniform(-0.6, 0.6, (trips.sum(), 2)) + 0.5 * np.array([sx, sy])
        out.append(
            WorkerScript(
                STATURES[k],
                wp,
                pause_s=tuple(rng.uniform(2.0, 12.0, n_way)),
                speed_m_s=1.1 + 0.1 * k,
                work_phase=1.3 * k,
            )
        )
    return out


def stored_triangulations(truth: np.ndarray, start: int, rng: np.random.Generator) -> tuple[People3D, np.ndarray]:
    """Rows of "stored triangulations" for a chunk: true joints + noise (20 mm in x, y; 30 mm in
    z), 3 % joint dropouts, 0.1 % gross outliers (+0.3 m), each worker out of view for 3 minutes
    every 40 minutes (staggered) and hidden for 1-3 s now and then; rows shuffled within frames."""
    F, P = truth.shape[:2]
    frames = start + np.arange(F)
    vis = np.ones((F, P), bool)
    for p in range(P):
        t = (frames / FPS + 600 * p) % 2400
        vis[:, p] &= ~((t >= 1200) & (t < 1380))
        period = (frames + 997 * p) % int(90 * FPS)
        vis[:, p] &= ~(period < int((1 + p % 3) * FPS))
    f, p = np.nonzero(vis)
    sigma = np.array([0.02, 0.02, 0.03])
    X = truth[f, p] + rng.normal(size=(len(f), 33, 3)) * sigma
    X[rng.random(X.shape[:2]) < 0.03] = np.nan
    out = rng.random(X.shape[:2]) < 0.001
    X[out] += 0.3
    order = np.lexsort((rng.random(len(f)), f))
    var = np.broadcast_to(sigma**2, X.shape)
    people = People3D.from_points(frames[f[order]], frames[f[order]] / FPS, X[order], variance_world=var)
    return people, vis


class StreamingEval:
    """Identity switches and MPJPE over emitted rows, across chunks."""

    def __init__(self) -> None:
        self.last: dict[int, int] = {}
        self.switches = 0
        self.err_sum = 0.0
        self.err_n = 0
        self.raw_sum = 0.0
        self.raw_n = 0

    def add(self, tf: TrackFrames, truth: np.ndarray, truth_start: int) -> None:
        if len(tf) == 0:
            return
        frames = np.arange(truth_start, truth_start + len(truth))
        sel = (tf.frame >= frames[0]) & (tf.frame <= frames[-1])
        if not sel.all():
            raise RuntimeError("emitted rows outside the kept truth")
        for _, pairs in D._frame_matches(tf, truth, frames, 0.5):
            for w, p in pairs:
                if p in self.last and self.last[p] != w:
                    self.switches += 1
                self.last[p] = w
        wp = {w: p for p, w in self.last.items()}
        for w in tf.workers:
            if w not in wp:
                continue
            r = tf.worker_rows(w)
            gt = truth[r.frame - truth_start, wp[w]]
            e = np.linalg.norm(r.points_world - gt, axis=-1)
            self.err_sum += float(np.nansum(e))
            self.err_n += int(np.isfinite(e).sum())
            e = np.linalg.norm(r.raw_points_world - gt, axis=-1)
            self.raw_sum += float(np.nansum(e))
            self.raw_n += int(np.isfinite(e).sum())


def track_smooth_8h(hours: float = 8.0, write: bool = True) -> None:
    rng = np.random.default_rng(8)
    scripts = quadrant_scripts(rng, hours)
    cameras = rig()
    chunk = int(3600 * FPS)
    total = int(round(hours * 3600 * FPS))
    settings = ReconSettings()
    shift = ShiftReconstruction(settings, FPS, cameras)
    ev = StreamingEval()
    t_track = 0.0
    cpu_track = 0.0
    t_write = 0.0
    t_gen = 0.0
    rows = 0
    prev = None  # (truth, start) of the previous chunk: emitted rows lag behind
    writer = None
    if write:
        import tempfile

        from ergopose.recon.table import TracksWriter

        tmpdir = tempfile.TemporaryDirectory()
        writer = TracksWriter(
            Path(tmpdir.name) / "tracks.parquet",
            fps=FPS,
            cameras=[c.name for c in cameras],
            settings=settings.as_dict(),
        )
        writer.__enter__()
    peak_people = 0
    for start in range(0, total, chunk):
        n = min(chunk, total - start)
        t0 = time.perf_counter()
        truth = walk_workers(scripts, n, FPS, start_frame=start)
        people, _ = stored_triangulations(truth, start, rng)
        peak_people = max(peak_people, len(people))
        t_gen += time.perf_counter() - t0
        t0, c0 = time.perf_counter(), time.process_time()
        tf = shift.push(people, start, start + n)
        t_track += time.perf_counter() - t0
        cpu_track += time.process_time() - c0
        both = truth if prev is None else np.concatenate([prev[0], truth])
        both_start = start if prev is None else prev[1]
        ev.add(tf, both, both_start)
        if writer is not None:
            t0 = time.perf_counter()
            writer.write(tf)
            t_write += time.perf_counter() - t0
        rows += len(tf)
        prev = (truth, start)
        del people
    t0, c0 = time.perf_counter(), time.process_time()
    tf = shift.finish()
    t_track += time.perf_counter() - t0
    cpu_track += time.process_time() - c0
    ev.add(tf, prev[0], prev[1])
    rows += len(tf)
    if writer is not None:
        t0 = time.perf_counter()
        writer.write(tf)
        writer.__exit__(None, None, None)
        t_write += time.perf_counter() - t0
    context = dict(
        hours=hours,
        frames=total,
        workers=4,
        joints=33,
        chunk_s=3600,
        worker_frame_rows=rows,
        identities=len(shift.tracker.identities),
        identity_switches=ev.switches,
        mpjpe_smoothed_mm=round(1000 * ev.err_sum / max(ev.err_n, 1), 2),
        mpjpe_raw_mm=round(1000 * ev.raw_sum / max(ev.raw_n, 1), 2),
        data_generation_s=round(t_gen, 1),
        goal_s=600 * hours / 8.0,
        cpu_s=round(cpu_track, 1),
        peak_rss_mb=_peak_rss_mb(),
    )
    emit("track_smooth_8h" if hours == 8.0 else f"track_smooth_{hours:g}h", t_track, "s", **context)
    if writer is not None:
        emit(
            "track_smooth_8h_parquet_write" if hours == 8.0 else f"track_smooth_{hours:g}h_parquet_write",
            t_write,
            "s",
            rows=rows * 33,
        )


def synthetic_scenario(minutes: float, seed: int = 10):
    """Four workers for ``minutes`` with occlusion events; returns (cameras, truth, frames, order)."""
    rng = np.random.default_rng(seed)
    scripts = quadrant_scripts(rng, minutes / 60.0)
    cameras = rig()
    n = int(minutes * 60 * FPS)
    truth = walk_workers(scripts, n, FPS)
    vis = np.ones((n, 2, 4), bool)
    s = lambda a, b: slice(int(a * FPS), int(b * FPS))  # noqa: E731
    for k in range(int(minutes)):
        base = 60 * k
        vis[s(base + 5, base + 10), 0, k % 4] = False  # behind a shelf for camera 1 (5 s)
        vis[s(base + 20, base + 21), :, (k + 1) % 4] = False  # hidden from both for 1 s
        vis[s(base + 30, base + 34), :, (k + 2) % 4] = False  # hidden from both for 4 s
        if k % 3 == 1:
            vis[s(base + 40, base + 60), :, (k + 3) % 4] = False  # leaves the area for 20 s
    frames, order = observe(cameras, truth, noise_px=2.0, dropout=0.02, visible=vis, seed=seed, fps=FPS)
    return cameras, truth, frames, order


def _cv(tf: TrackFrames, source: str) -> float:
    """Mean coefficient of variation of the major limbs' lengths over workers and the limbs that
    have at least 20 lengths (legs may never be seen by both cameras)."""
    cvs = []
    for w in tf.workers:
        r = tf.worker_rows(w)
        L = limb_lengths(r.points_world if source == "final" else r.raw_points_world)[:, MAJOR]
        for col in L.T:
            v = col[np.isfinite(col)]
            if len(v) >= 20:
                cvs.append(v.std() / v.mean())
    return float(np.mean(cvs)) if cvs else float("nan")


def recon_synthetic(minutes: float = 10.0) -> None:
    from ergopose.recon.triangulate import reconstruct_frames

    t0 = time.perf_counter()
    cameras, truth, frames, _ = synthetic_scenario(minutes)
    t_gen = time.perf_counter() - t0
    t0 = time.perf_counter()
    people = reconstruct_frames(frames)
    t_tri = time.perf_counter() - t0
    n = len(frames)
    results = {}
    variants = {
        "raw": ReconSettings(smoothing=False),
        "smoothed": ReconSettings(),
        "smoothed_no_gate": ReconSettings(outlier_gate_chi2=0.0),
        "smoothed_constant_acceleration": ReconSettings(motion_model="constant_acceleration"),
        "smoothed_bone_constraint": ReconSettings(bone_length_constraint=True),
    }
    # The variance model without the ray geometry: (30 mm / confidence)^2 (1 + (e / 5 px)^2), the
    # same in x, y and z -- to measure what the geometric model brings.
    iso = (0.03 / np.maximum(people.confidence, 0.05)) ** 2 * (1 + (people.reprojection_error_px / 5.0) ** 2)
    people_iso = People3D(**{**people.__dict__, "variance_world": np.repeat(iso[..., None], 3, axis=-1)})
    variants["smoothed_isotropic_variance"] = ReconSettings()
    for name, settings in variants.items():
        t0 = time.perf_counter()
        sr = ShiftReconstruction(settings, FPS, cameras)
        src = people_iso if name == "smoothed_isotropic_variance" else people
        tf = TrackFrames.concat([sr.push(src, 0, n), sr.finish()])
        dt = time.perf_counter() - t0
        mapping = D.match_workers(tf, truth)
        gt = D.truth_for_workers(tf, truth, mapping)
        reg = D.region_errors(tf, gt, settings)
        results[name] = tf
        err_filled = err_measured = float("nan")
        if tf.smoothed:
            e = np.concatenate(
                [np.linalg.norm(tf.worker_rows(w).points_world - gt[w], axis=-1).reshape(-1) for w in gt]
            )
            filled = np.concatenate([tf.worker_rows(w).gap_filled.reshape(-1) for w in gt])
            measured = np.concatenate(
                [np.isfinite(tf.worker_rows(w).raw_points_world).all(axis=-1).reshape(-1) for w in gt]
            )
            err_filled = round(1000 * float(np.nanmean(e[filled])), 2)
            err_measured = round(1000 * float(np.nanmean(e[measured])), 2)
        emit(
            f"recon_synthetic_{minutes:g}min_{name}",
            1000 * reg["all"].mean_m,
            "mm",
            identity_switches_sustained_1s=D.identity_switches(tf, truth, min_frames=int(FPS)),
            mpjpe_gap_filled_mm=err_filled,
            mpjpe_where_triangulated_mm=err_measured,
            gap_filled_share=round(float(tf.gap_filled.mean()), 4),
            identity_switches=D.identity_switches(tf, truth),
            workers=len(tf.workers),
            limb_cv_major_pct=round(100 * _cv(tf, "final"), 2),
            mpjpe_by_region_mm={k: round(1000 * v.mean_m, 1) for k, v in reg.items()},
            points_by_region={k: v.points for k, v in reg.items()},
            coverage=round(float(np.isfinite(tf.points_world).all(axis=-1).mean()), 4),
            track_smooth_s=round(dt, 2),
        )
    emit(
        f"recon_synthetic_{minutes:g}min_association_triangulation",
        t_tri,
        "s",
        frames=n,
        scenario_generation_s=round(t_gen, 1),
    )
    # Limb-length statistics by lens region (smoothed): the paper's figure, per worker.
    diag = D.limb_diagnostics(results["smoothed"], ReconSettings())
    raw_diag = D.limb_diagnostics(results["smoothed"], ReconSettings(), source="raw")
    for d, r in zip(diag, raw_diag):
        for limb in ("left_upper_arm", "left_forearm", "left_thigh", "left_shank", "shoulder_width"):
            emit(
                f"recon_synthetic_limb_{d.worker}_{limb}",
                100 * d.get(limb).cv,
                "% cv",
                raw_cv_pct=round(100 * r.get(limb).cv, 2),
                frequency=round(r.get(limb).frequency, 3),
                by_region={
                    g: dict(
                        cv_pct=round(100 * d.get(limb, g).cv, 2),
                        raw_cv_pct=round(100 * r.get(limb, g).cv, 2),
                        frequency=round(r.get(limb, g).frequency, 3),
                        frames=r.get(limb, g).frames,
                    )
                    for g in D.REGIONS
                },
            )


def recon_oracle(
    minutes: float = 10.0, size: tuple[int, int] = (2592, 1944), noise_px: float = 2.0, seed: int = 3
) -> None:
    """The simulator's scripted workers, room and visibility (no video), ORACLE 2D with
    ``noise_px`` (hidden joints reported with 6 px noise and confidence 0.1-0.4, 2 % person and
    joint dropouts): the whole reconstruction against the simulation's truth."""
    from ergopose.sim.synthetic import frames_from_oracle, simulated_ground_truth
    from ergopose.recon.triangulate import reconstruct_frames
    from ergopose.sim.oracle import OracleSource

    t0 = time.perf_counter()
    gt, cameras = simulated_ground_truth(4, minutes * 60.0, seed=seed, size=size)
    obs = OracleSource(gt, noise_px=noise_px, seed=seed).observe()
    frames, _ = frames_from_oracle(obs, cameras)
    t_gen = time.perf_counter() - t0
    truth = gt.joints_world
    n = len(frames)
    statures = {w["id"]: w["stature_m"] for w in gt.scene["workers"]}
    tag = f"recon_oracle_{minutes:g}min_{size[0]}x{size[1]}"
    variants = {
        "raw": ReconSettings(smoothing=False),
        "smoothed": ReconSettings(),
        "smoothed_fill_0.25s": ReconSettings(max_fill_gap_s=0.25),
        "smoothed_no_gate": ReconSettings(outlier_gate_chi2=0.0),
        "smoothed_constant_acceleration": ReconSettings(motion_model="constant_acceleration"),
        "smoothed_bone_constraint": ReconSettings(bone_length_constraint=True),
        "min_confidence_0.3": ReconSettings(min_confidence=0.3),
    }
    cache = {}
    for name, settings in variants.items():
        t0 = time.perf_counter()
        key = settings.min_confidence
        if key not in cache:
            cache[key] = reconstruct_frames(frames, settings)
        people = cache[key]
        t_tri = time.perf_counter() - t0
        t0 = time.perf_counter()
        sr = ShiftReconstruction(settings, gt.fps, cameras)
        tf = TrackFrames.concat([sr.push(people, 0, n), sr.finish()])
        dt = time.perf_counter() - t0
        mapping = D.match_workers(tf, truth)
        gtw = D.truth_for_workers(tf, truth, mapping)
        reg = D.region_errors(tf, gtw, settings)
        raw = D.region_errors(tf, gtw, settings, source="raw")
        est = sr.stature_estimates()
        emit(
            f"{tag}_{name}",
            1000 * reg["all"].mean_m,
            "mm",
            identity_switches=D.identity_switches(tf, truth),
            identity_switches_sustained_1s=D.identity_switches(tf, truth, min_frames=int(gt.fps)),
            workers=len(tf.workers),
            raw_mpjpe_mm=round(1000 * raw["all"].mean_m, 2),
            mpjpe_by_region_mm={k: round(1000 * v.mean_m, 1) for k, v in reg.items()},
            points_by_region={k: v.points for k, v in reg.items()},
            coverage=round(float(np.isfinite(tf.points_world).all(axis=-1).mean()), 4),
            raw_coverage=round(float(np.isfinite(tf.raw_points_world).all(axis=-1).mean()), 4),
            limb_cv_major_pct=round(100 * _cv(tf, "final"), 2),
            raw_limb_cv_major_pct=round(100 * _cv(tf, "raw"), 2),
            stature_error_cm={
                f"worker_{w}": round(100 * (est[f"worker_{w}"] - statures[gt.worker_ids[p]]), 1)
                for w, p in mapping.items()
            },
            triangulation_s=round(t_tri, 2),
            track_smooth_s=round(dt, 2),
            noise_px=noise_px,
        )
    emit(f"{tag}_generation", t_gen, "s", frames=n, note="motion, visibility ray casts, oracle, Detections2D")


def recon_cameras(minutes: float = 1.0, size: tuple[int, int] = (2592, 1944), seed: int = 3) -> None:
    from ergopose.sim.synthetic import extra_ceiling_cameras, frames_from_oracle, simulated_ground_truth
    from ergopose.recon.triangulate import reconstruct_frames
    from ergopose.sim.oracle import OracleSource
    from ergopose.sim.scene import rig_cameras

    cams = tuple(rig_cameras(*size)) + extra_ceiling_cameras(size)
    gt, cams = simulated_ground_truth(4, minutes * 60.0, seed=seed, size=size, cameras=cams)
    obs = OracleSource(gt, noise_px=2.0, seed=seed).observe()
    frames, order = frames_from_oracle(obs, cams)
    truth = gt.joints_world
    errors = {}
    for sel in ((0, 1), (0, 1, 2), (0, 1, 2, 3)):
        fr = [tuple(f[c] for c in sel) for f in frames]
        od = [[o[c] for c in sel] for o in order]
        t0 = time.process_time()
        people = reconstruct_frames(fr)
        cpu = (time.process_time() - t0) / len(fr)
        f0 = people.frame - people.frame.min()
        w = np.full(people.detection.shape, -1)
        for r, c in zip(*np.nonzero(people.detection >= 0)):
            w[r, c] = od[f0[r]][c][people.detection[r, c]]
        sets = np.flatnonzero(people.n_cameras >= 2)
        mixed = sum(len(set(w[r][w[r] >= 0])) > 1 for r in sets)
        keys = [(f0[r], w[r][w[r] >= 0].min()) for r in sets]
        seen = np.zeros((len(fr), truth.shape[1]), np.int64)
        for f, o in enumerate(od):
            for c in range(len(sel)):
                seen[f, o[c]] += 1
        e = np.full((len(fr),) + truth.shape[1:3], np.nan)
        for r in sets:
            p = w[r][w[r] >= 0].min()
            e[f0[r], p] = np.linalg.norm(people.points_world[r] - truth[f0[r], p], axis=-1)
        errors[len(sel)] = e
        common = np.isfinite(e) & np.isfinite(errors[2])
        emit(
            f"recon_cameras_{len(sel)}",
            1000 * cpu,
            "ms/frame",
            note="CPU time of association + triangulation",
            sets=len(sets),
            sets_mixing_workers=int(mixed),
            workers_split=len(keys) - len(set(keys)),
            detections_of_people_seen_by_2plus=int(seen[seen >= 2].sum()),
            left_out_of_their_set=int(seen[seen >= 2].sum() - (w[sets] >= 0).sum()),
            single_view_rows=int((people.n_cameras == 1).sum()),
            joints=int(np.isfinite(e).sum()),
            raw_mpjpe_mm=round(1000 * float(np.nanmean(e)), 2),
            raw_mpjpe_on_2camera_joints_mm=round(1000 * float(np.mean(e[common])), 2),
            frames=len(fr),
        )


def recon_vs_aniposelib(seconds: float = 60.0) -> None:
    import cv2
    from aniposelib.cameras import CameraGroup, FisheyeCamera

    from ergopose.recon.triangulate import reconstruct_frames

    rng = np.random.default_rng(21)
    scripts = quadrant_scripts(rng, seconds / 3600)
    cameras = rig()
    n = int(seconds * FPS)
    truth = walk_workers(scripts, n, FPS)
    frames, order = observe(cameras, truth, noise_px=2.0, dropout=0.02, seed=22, fps=FPS)
    # The very same noisy fisheye pixels, per ground-truth person (true correspondences).
    px = np.full((2, n, 4, 33, 2), np.nan)
    for f, dets in enumerate(frames):
        for c, det in enumerate(dets):
            view_px = det.pixels_view
            for k, person in enumerate(order[f][c]):
                rays = det.world_rays()[k] @ cameras[c].rotation_world_from_cam  # world -> cam
                px[c, f, person] = np.where(
                    np.isfinite(view_px[k]).all(axis=-1)[:, None], cameras[c].lens.project(rays), np.nan
                )

    lens = cameras[0].lens
    K = np.array([[lens.fx, 0.0, lens.cx], [0.0, lens.fy, lens.cy], [0.0, 0.0, 1.0]])
    group = CameraGroup(
        [
            FisheyeCamera(
                matrix=K,
                dist=np.array([lens.k1, lens.k2, lens.k3, lens.k4]),
                size=(cam.width, cam.height),
                rvec=cv2.Rodrigues(cam.rotation_world_from_cam.T)[0].ravel(),
                tvec=-cam.rotation_world_from_cam.T @ cam.position_world,
                name=cam.name,
            )
            for cam in cameras
        ]
    )

    def err_mm(X):
        e = np.linalg.norm(X - truth, axis=-1)
        return 1000 * float(np.nanmean(e)), float(np.isfinite(e).mean())

    # aniposelib triangulate (linear, all frames and people in one call).
    t0 = time.perf_counter()
    tri = group.triangulate(px.reshape(2, -1, 2), undistort=True).reshape(n, 4, 33, 3)
    t_tri = time.perf_counter() - t0
    # aniposelib triangulate_optim per person (temporal smoothness + limb-length constraints).
    t0 = time.perf_counter()
    opt = np.stack(
        [group.triangulate_optim(px[:, :, p], constraints=LIMB_INDEX.tolist(), verbose=False) for p in range(4)], axis=1
    )
    t_opt = time.perf_counter() - t0
    # ours: association + triangulation + tracking + smoothing, from the Detections2D records.
    t0 = time.perf_counter()
    people = reconstruct_frames(frames)
    sr = ShiftReconstruction(ReconSettings(), FPS, cameras)
    tf = TrackFrames.concat([sr.push(people, 0, n), sr.finish()])
    t_ours = time.perf_counter() - t0
    mapping = D.match_workers(tf, truth)
    ours = np.full_like(truth, np.nan)
    ours_raw = np.full_like(truth, np.nan)
    for w, p in mapping.items():
        r = tf.worker_rows(w)
        ours[r.frame, p] = r.points_world
        ours_raw[r.frame, p] = r.raw_points_world
    both = np.isfinite(ours).all(axis=-1) & np.isfinite(opt).all(axis=-1) & np.isfinite(tri).all(axis=-1)
    common = {}
    for name, X in (
        ("ours", ours),
        ("ours_raw", ours_raw),
        ("aniposelib_triangulate", tri),
        ("aniposelib_triangulate_optim", opt),
    ):
        common[name] = 1000 * float(np.nanmean(np.where(both, np.linalg.norm(X - truth, axis=-1), np.nan)))
    for name, X, t in (
        ("ours", ours, t_ours),
        ("ours_raw", ours_raw, None),
        ("aniposelib_triangulate", tri, t_tri),
        ("aniposelib_triangulate_optim", opt, t_opt),
    ):
        e, cov = err_mm(X)
        emit(
            f"recon_vs_aniposelib_{name}",
            e,
            "mm",
            seconds_of_video=seconds,
            people=4,
            coverage=round(cov, 4),
            mpjpe_on_common_points_mm=round(common[name], 2),
            time_s=None if t is None else round(t, 3),
            limb_cv_major_pct=round(100 * _cv_points(X), 2),
        )
    emit(
        "recon_vs_aniposelib_speedup_vs_optim",
        t_opt / t_ours,
        "x",
        ours_s=round(t_ours, 3),
        optim_s=round(t_opt, 3),
        goal=10.0,
    )
    # The body model fit alone, per worker-frame, beside triangulate_optim per worker-frame (same keypoints).
    fit_ms = 1000 * sr.bodies.fit_seconds / max(sr.bodies.fitted_rows, 1)
    optim_ms = 1000 * t_opt / (n * 4)
    emit(
        "skeleton_fit_worker_frame_ms",
        fit_ms,
        "ms",
        worker_frames=sr.bodies.fitted_rows,
        aniposelib_triangulate_optim_ms=round(optim_ms, 3),
        ratio_optim_to_ours=round(optim_ms / fit_ms, 2),
    )


def _peak_rss_mb() -> float:
    import resource

    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)


def _cv_points(X: np.ndarray) -> float:
    L = limb_lengths(X)[..., MAJOR]  # (F, P, limbs)
    return float(np.nanmean(np.nanstd(L, axis=0) / np.nanmean(L, axis=0)))


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--hours", type=float, default=8.0)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("names", nargs="*")
    args = ap.parse_args(argv)
    names = args.names or ["track_smooth", "synthetic", "oracle", "aniposelib", "cameras"]
    if "track_smooth" in names:
        track_smooth_8h(args.hours, write=not args.no_write)
    if "synthetic" in names:
        recon_synthetic(args.minutes)
    if "oracle" in names:
        recon_oracle(args.minutes)
        recon_oracle(args.minutes, size=(1024, 768))
    if "aniposelib" in names:
        recon_vs_aniposelib()
    if "cameras" in names:
        recon_cameras()
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
