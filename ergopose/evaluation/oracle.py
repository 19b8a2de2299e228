"""ORACLE run: the stages after 2D pose on the simulator's ORACLE 2D keypoints (evaluation only).

The ORACLE (:class:`ergopose.sim.oracle.OracleSource`) reports the simulated workers' true fisheye
pixels with seeded noise and dropouts instead of running the pose network. Feeding it to the same
reconstruction the assessment uses (per-person upright virtual views,
:func:`ergopose.sim.synthetic.frames_from_oracle`; association, triangulation, tracking and
smoothing with :func:`ergopose.recon.session.reconstruct_session`, then joint angles, task factors
and RULA/REBA with :func:`ergopose.pipeline.score.score_worker`) measures geometry, tracking and
smoothing apart from the network.

Everything written is labelled ORACLE: the folder ``OUT/oracle/``, a ``README_ORACLE.txt`` in it,
the file names (``ORACLE_tracks.parquet``, ``ORACLE_<worker>_steps.csv``), the tracks table's
metadata (``source``) and the evaluation JSON. These numbers describe the stages after 2D pose
with a known 2D error; they are never a measurement of ergopose on video.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from ergopose.atomic import atomic_dir, write_text
from ergopose.ergonomics.export import write_worker_steps_csv
from ergopose.errors import InputError
from ergopose.evaluation.loading import ResultsLayout
from ergopose.pipeline.guard import fingerprint_of
from ergopose.pipeline.identify import identify_by_stature
from ergopose.pipeline.inputs import scoring_settings
from ergopose.pipeline.score import score_worker
from ergopose.progress import ProgressCallback, report
from ergopose.recon.diagnostics import limb_diagnostics
from ergopose.recon.session import reconstruct_session
from ergopose.recon.table import TracksWriter
from ergopose.recon.tracking import identity_name
from ergopose.session import load_session
from ergopose.sim.ground_truth import load_ground_truth
from ergopose.sim.oracle import OracleSource
from ergopose.sim.synthetic import frames_from_oracle

ORACLE_DIR = "oracle"
PREFIX = "ORACLE_"
README = "README_ORACLE.txt"
#: Frames per piece of ORACLE observations (memory: 600 frames x 2 cameras x 4 workers is 2.5 MB).
CHUNK_FRAMES = 600


@dataclass(frozen=True)
class OracleOptions:
    """The ORACLE's simulated 2D errors (see :class:`ergopose.sim.oracle.OracleSource`).

    noise_px: pixel noise (standard deviation per axis, fisheye pixels) on visible joints.
    person_dropout: probability that a worker is not reported in a camera frame.
    joint_dropout: probability that a single visible joint is missing.
    occluded_noise_px: pixel noise on joints the camera cannot see (reported with low confidence).
    seed: the ORACLE's random source.
    """

    noise_px: float = 2.0
    person_dropout: float = 0.02
    joint_dropout: float = 0.02
    occluded_noise_px: float = 6.0
    seed: int = 0

    def banner(self) -> str:
        return (f"ORACLE 2D (simulated ground truth projected with {self.noise_px:g} px noise) "
                "— not the pose network")

    def as_dict(self) -> dict:
        return {"noise_px": self.noise_px, "person_dropout": self.person_dropout,
                "joint_dropout": self.joint_dropout, "occluded_noise_px": self.occluded_noise_px,
                "seed": self.seed, "banner": self.banner()}


def oracle_layout(out_dir: str | Path):
    """Where an ORACLE run under the results folder ``out_dir`` writes (OUT/oracle/...)."""
    root = Path(out_dir) / ORACLE_DIR
    return ResultsLayout(root=root, tracks=root / "pipeline" / f"{PREFIX}tracks.parquet", csv_dir=root / "csv",
                         csv_prefix=PREFIX)


def oracle_frames(session, gt, options: OracleOptions, progress: ProgressCallback | None = None) -> Iterator[tuple]:
    """Per frame, one Detections2D per camera (session order) made from the ORACLE's keypoints
    (:func:`ergopose.sim.synthetic.frames_from_oracle`, in pieces of CHUNK_FRAMES frames)."""
    source = OracleSource(gt, noise_px=options.noise_px, occluded_noise_px=options.occluded_noise_px,
                          person_dropout=options.person_dropout, joint_dropout=options.joint_dropout,
                          seed=options.seed)
    F = gt.n_frames
    for start in range(0, F, CHUNK_FRAMES):
        stop = min(F, start + CHUNK_FRAMES)
        frames, _ = frames_from_oracle(source.observe(np.arange(start, stop)), session.calibrated_cameras)
        yield from frames
        report(progress, "oracle 2D", stop, F, unit="frame")


def run_oracle(session_dir: str | Path, out_dir: str | Path, options: OracleOptions = OracleOptions(),
               recon=None, progress: ProgressCallback | None = None):
    """Reconstruct and score the session from ORACLE 2D keypoints into OUT/oracle/ (module docstring).

    Returns the :class:`ergopose.evaluation.compare.ResultsLayout` of the written folder.
    """
    session = load_session(session_dir, check_videos=False)
    if session.ground_truth_dir is None:
        raise InputError("not a simulated session: the ORACLE needs the ground_truth/ folder of a session made "
                         "by 'ergopose simulate'", path=session.path)
    gt = load_ground_truth(session.ground_truth_dir)
    if tuple(gt.camera_names) != tuple(session.camera_names):
        raise InputError(f"the ground truth's cameras ({', '.join(gt.camera_names)}) differ from the session's "
                         f"({', '.join(session.camera_names)})", path=gt.path)
    recon = recon or session.reconstruction  # the session's [reconstruction] table over the defaults
    scoring = scoring_settings(session)
    layout = oracle_layout(out_dir)
    summary, tracks = reconstruct_session(oracle_frames(session, gt, options, progress), None, fps=session.fps,
                                          cameras=session.calibrated_cameras, settings=recon,
                                          progress=progress, total_frames=gt.n_frames)
    with atomic_dir(layout.root) as tmp:
        tracks_path = tmp / layout.tracks.relative_to(layout.root)
        tracks_path.parent.mkdir(parents=True, exist_ok=True)
        statures = {name: {"stature_estimate_m": _num(summary.stature_m.get(name))} for name in summary.workers}
        with TracksWriter(tracks_path, fps=session.fps, cameras=session.camera_names,
                          settings=recon.as_dict()) as writer:
            writer.meta["source"] = "oracle"
            writer.meta["oracle"] = options.as_dict()
            writer.meta["session_fingerprint"] = fingerprint_of(session)  # whose results (ergopose.pipeline.guard)
            writer.write(tracks)
            writer.set_workers(statures)
        # Named after the settings' workers by stature, as ergopose assess does.
        ident = identify_by_stature({k: v["stature_estimate_m"] for k, v in statures.items()}, session)
        diagnostics = {d.worker: d for d in limb_diagnostics(tracks, recon)} if len(tracks) else {}
        workers = tracks.workers
        for k, w in enumerate(workers):
            tracked = identity_name(w)
            wid = ident.rename(tracked)
            report(progress, "oracle scoring", k, len(workers), unit="worker", message=wid)
            scored = score_worker(session, tracks.worker_rows(w), wid, scoring, diagnostics[tracked])
            write_worker_steps_csv(tmp / "csv" / f"{PREFIX}{wid}_steps.csv", scored.frames)
        report(progress, "oracle scoring", len(workers), len(workers), unit="worker")
        write_text(tmp / README, _readme(options, session, len(workers), summary.seconds))
    return layout


def _num(v):
    return None if v is None or not np.isfinite(float(v)) else round(float(v), 6)


def _readme(options: OracleOptions, session, workers: int, seconds: float) -> str:
    return (
        f"{options.banner()}\n\n"
        "ORACLE RESULTS -- FOR EVALUATION ONLY. The 2D keypoints of this folder were not found by the pose\n"
        "network: they are the simulator's exact joint positions projected into both cameras, with seeded\n"
        f"noise ({options.noise_px:g} px on visible joints, {options.occluded_noise_px:g} px on hidden ones), "
        f"whole detections dropped with probability {options.person_dropout:g}\n"
        f"and single joints with probability {options.joint_dropout:g} (seed {options.seed}). Association, "
        "triangulation, tracking,\nsmoothing, joint angles and scoring are ergopose's own. The figures measure "
        "those stages, never\nergopose on video.\n\n"
        f"session: {session.path}\ntracked workers: {workers}\nreconstruction time: {seconds:.1f} s\n\n"
        f"pipeline/{PREFIX}tracks.parquet   the tracks table (metadata source = \"oracle\")\n"
        f"csv/{PREFIX}<worker>_steps.csv    posture and every RULA/REBA step per frame\n"
        "evaluation.json                   the comparison with the ground truth (ergopose evaluate --oracle)\n")
