"""ORACLE run: the assessment's driver with the simulator's ORACLE 2D keypoints (evaluation only).

The ORACLE (:class:`ergopose.sim.oracle.OracleSource`) reports the simulated workers' true fisheye
pixels with seeded noise and dropouts instead of running the pose network. :class:`OracleFrames`
makes it a 2D source of the assessment's driver (:class:`ergopose.pipeline.detect.Source2D`:
per-person upright virtual views, :func:`ergopose.sim.synthetic.frames_from_oracle`), injected in
place of the pose networks; every stage after it is the assessment's own, run by the same driver
(:mod:`ergopose.pipeline.assess`): body model (association and triangulation), track and smooth,
score (joint angles, task factors, RULA/REBA), aggregate. Only the stage *publish* is the ORACLE's
(:func:`publish_oracle`): it keeps the labelled steps CSV files and writes no report pages. This
measures geometry, tracking and smoothing apart from the network.

Everything written is labelled ORACLE: the folder ``OUT/oracle/``, a ``README_ORACLE.txt`` in it,
the file names (``ORACLE_tracks.parquet``, ``ORACLE_<worker>_steps.csv``), the tracks table's
metadata (``source``) and the evaluation JSON. These numbers describe the stages after 2D pose
with a known 2D error; they are never a measurement of ergopose on video.
"""

from __future__ import annotations

import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ergopose.atomic import atomic_dir, write_text
from ergopose.ergonomics.export import STEPS_SUFFIX
from ergopose.errors import InputError
from ergopose.evaluation.loading import ResultsLayout
from ergopose.pipeline import assess
from ergopose.pipeline.guard import fingerprint_of
from ergopose.pipeline.score import CSV_DIR
from ergopose.progress import ProgressCallback, report
from ergopose.session import load_session
from ergopose.sim.ground_truth import load_ground_truth
from ergopose.sim.oracle import OracleSource
from ergopose.sim.synthetic import frames_from_oracle

ORACLE_DIR = "oracle"
PREFIX = "ORACLE_"
README = "README_ORACLE.txt"
#: Frames per chunk of the ORACLE run (the chunks of the reconstruction of ergopose.recon.session;
#: memory: 1,200 frames x 2 cameras x 4 workers of observations is 5 MB).
CHUNK_FRAMES = 1200


@dataclass(frozen=True)
class OracleOptions:
    """The ORACLE's simulated 2D errors (see :class:`ergopose.sim.oracle.OracleSource`).

    noise_px: pixel noise (standard deviation per axis, fisheye pixels) on visible joints.
    person_dropout: probability that a worker is not reported in a camera frame.
    joint_dropout: probability that a single visible joint is missing.
    occluded_noise_px: pixel noise on joints the camera cannot see (reported with low confidence).
    seed: the ORACLE's random source.
    own_body_hides: joints behind the worker's own body count as hidden (True) or are reported
        like visible ones (False: issue 13's "true joints + noise";
        :attr:`ergopose.sim.oracle.OracleSource.own_body_hides`).
    """

    noise_px: float = 2.0
    person_dropout: float = 0.02
    joint_dropout: float = 0.02
    occluded_noise_px: float = 6.0
    seed: int = 0
    own_body_hides: bool = True

    def banner(self) -> str:
        seen = "" if self.own_body_hides else "; joints behind the worker's own body reported as seen"
        return (
            f"ORACLE 2D (simulated ground truth projected with {self.noise_px:g} px noise{seen}) — not the pose network"
        )

    def as_dict(self) -> dict:
        return {
            "noise_px": self.noise_px,
            "person_dropout": self.person_dropout,
            "joint_dropout": self.joint_dropout,
            "occluded_noise_px": self.occluded_noise_px,
            "seed": self.seed,
            "own_body_hides": self.own_body_hides,
            "banner": self.banner(),
        }


def oracle_layout(out_dir: str | Path):
    """Where an ORACLE run under the results folder ``out_dir`` writes (OUT/oracle/...)."""
    root = Path(out_dir) / ORACLE_DIR
    return ResultsLayout(
        root=root, tracks=root / "pipeline" / f"{PREFIX}tracks.parquet", csv_dir=root / "csv", csv_prefix=PREFIX
    )


class OracleFrames:
    """The ORACLE as the driver's 2D source (:class:`ergopose.pipeline.detect.Source2D`): per frame,
    one Detections2D per camera (session order) made from the ORACLE's keypoints
    (:func:`ergopose.sim.synthetic.frames_from_oracle`)."""

    def __init__(self, session, gt, options: OracleOptions, progress: ProgressCallback | None = None) -> None:
        self.cameras = session.calibrated_cameras
        self.frames = gt.n_frames
        self.progress = progress
        self.source = OracleSource(
            gt,
            noise_px=options.noise_px,
            occluded_noise_px=options.occluded_noise_px,
            person_dropout=options.person_dropout,
            joint_dropout=options.joint_dropout,
            own_body_hides=options.own_body_hides,
            seed=options.seed,
        )

    def frames_2d(self, start: int, stop: int) -> tuple[list, np.ndarray]:
        frames, _ = frames_from_oracle(self.source.observe(np.arange(start, stop)), self.cameras)
        counts = np.array([[len(d.pixels_view) for d in f] for f in frames], dtype=np.int16)
        report(self.progress, "oracle 2D", stop, self.frames, unit="frame")
        return list(frames), counts.reshape(stop - start, len(self.cameras))


def publish_oracle(
    named,
    scored,
    stage: Path,
    out_dir: Path,
    scoring,
    models,
    progress: ProgressCallback | None,
    *,
    bom: bool = False,
    store_dir: Path | None = None,
) -> tuple[str, ...]:
    """The ORACLE's stage *publish* (:data:`ergopose.pipeline.assess.Publisher`): each scored
    worker's steps CSV file, written by the scoring into ``stage``, moved to
    ``out_dir/csv/ORACLE_<worker>_steps.csv``; no other CSV file and no report pages (they would
    not carry the ORACLE label). Returns the reported worker ids."""
    csv_dir = Path(out_dir) / "csv"
    csv_dir.mkdir(parents=True, exist_ok=True)
    for s in scored:
        os.replace(stage / CSV_DIR / f"{s.worker_id}{STEPS_SUFFIX}", csv_dir / f"{PREFIX}{s.worker_id}{STEPS_SUFFIX}")
    return tuple(s.worker_id for s in scored)


def run_oracle(
    session_dir: str | Path,
    out_dir: str | Path,
    options: OracleOptions = OracleOptions(),
    recon=None,
    progress: ProgressCallback | None = None,
):
    """Reconstruct and score the session from ORACLE 2D keypoints into OUT/oracle/ (module docstring),
    through the assessment's driver with :class:`OracleFrames` as its 2D source.

    Returns the :class:`ergopose.evaluation.loading.ResultsLayout` of the written folder.
    """
    session = load_session(session_dir, check_videos=False)
    if session.ground_truth_dir is None:
        raise InputError(
            "not a simulated session: the ORACLE needs the ground_truth/ folder of a session made "
            "by 'ergopose simulate'",
            path=session.path,
        )
    gt = load_ground_truth(session.ground_truth_dir)
    if tuple(gt.camera_names) != tuple(session.camera_names):
        raise InputError(
            f"the ground truth's cameras ({', '.join(gt.camera_names)}) differ from the session's "
            f"({', '.join(session.camera_names)})",
            path=gt.path,
        )
    recon = recon or session.reconstruction  # the session's [reconstruction] table over the defaults
    layout = oracle_layout(out_dir)
    label = {
        "source": "oracle",
        "oracle": options.as_dict(),
        "session_fingerprint": fingerprint_of(session),
    }  # whose results (ergopose.pipeline.guard)
    t0 = time.perf_counter()
    with atomic_dir(layout.root) as tmp:
        run = assess.prepare_source(session, tmp, recon, CHUNK_FRAMES, label)
        # No pose network, so none of its error (scoring's joint_sd_floor_m): the ORACLE's pixel
        # noise is independent between the cameras and in the fit's covariance already.
        run.scoring = run.scoring.replace(joint_sd_floor_m=0.0)
        with run.store.lock():
            ranges, _, todo = assess.open_store(run, progress)
            assess.people_in_3d(run, todo, ranges, 0, 1, progress, source=OracleFrames(session, gt, options, progress))
            tracks, workers = assess.after_people(run, ranges, progress, publisher=publish_oracle)
        # The folder keeps the labelled results only: the stored chunks served this run alone.
        tracks_path = tmp / layout.tracks.relative_to(layout.root)
        os.replace(tracks.path, tracks_path)
        shutil.rmtree(run.store.chunks_dir)
        for name in ("manifest.json", "lock"):
            (run.store.root / name).unlink(missing_ok=True)
        write_text(tmp / README, _readme(options, session, len(workers), time.perf_counter() - t0))
    return layout


def _readme(options: OracleOptions, session, workers: int, seconds: float) -> str:
    return (
        f"{options.banner()}\n\n"
        "ORACLE RESULTS -- FOR EVALUATION ONLY. The 2D keypoints of this folder were not found by the pose\n"
        "network: they are the simulator's exact joint positions projected into both cameras, with seeded\n"
        f"noise ({options.noise_px:g} px on visible joints, {options.occluded_noise_px:g} px on hidden ones), "
        f"whole detections dropped with probability {options.person_dropout:g}\n"
        f"and single joints with probability {options.joint_dropout:g} (seed {options.seed}). Association, "
        "triangulation, tracking,\nsmoothing, joint angles and scoring are ergopose's own (the scores' probabilities "
        "without the pose network's\nkeypoint error: joint_sd_floor_m = 0). The figures measure "
        "those stages, never\nergopose on video.\n\n"
        f"session: {session.path}\ntracked workers: {workers}\nrun time: {seconds:.1f} s\n\n"
        f'pipeline/{PREFIX}tracks.parquet   the tracks table (metadata source = "oracle")\n'
        f"csv/{PREFIX}<worker>_steps.csv    posture and every RULA/REBA step per frame\n"
        "evaluation.json                   the comparison with the ground truth (ergopose evaluate --oracle)\n"
    )
