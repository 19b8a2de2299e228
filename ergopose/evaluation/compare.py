"""Compare an assessed simulated session with its ground truth (docs/evaluation.md).

:func:`evaluate_results` reads what ``ergopose assess`` wrote (the tracks table and the per-worker
steps CSV files, :class:`ResultsLayout`), the session and its ``ground_truth/`` folder, and returns
an :class:`Evaluation`: identity matching and switches, detection rate, 3D joint errors (MPJPE) per
joint and lens region, limb-length errors and reconstruction frequencies, joint-angle errors, the
agreement of RULA and REBA with the scores of the ground-truth angles, and the reference-bar check.

Tracked workers ("worker_1", ...) are matched to the simulated workers ("w1", ...) frame by frame:
in each frame the tracked rows and the simulated workers are paired one-to-one by the distance of
their body centres (at most 0.5 m, the default of :mod:`ergopose.recon.diagnostics`), and every
per-frame comparison (3D error, limb lengths, angles, scores) uses that pairing, so geometry is
measured apart from identity mistakes. The identities are judged separately: the mapping of each
tracked id to its most frequent partner (:func:`ergopose.recon.diagnostics.match_workers`), the
identity switches (:func:`~ergopose.recon.diagnostics.identity_switches`), and the 3D error when
every row is compared with its id's mapped worker (``by_track_identity``), which is what a report
attributing a whole track to one person would suffer.

One lens-region definition: ``lens_region_limits_deg`` of the reconstruction settings stored in
the tracks table (the regions the reconstruction's own diagnostics use). The simulator's
``LENS_REGIONS_DEG`` and the calibration check's default rings are reported beside it when they
differ.

Units: metres and radians inside; the sections of the result give millimetres (``_mm``), degrees
(``_deg``) and percentages (``_pct``) for people to read.

The sections live in :mod:`ergopose.evaluation.loading`, :mod:`ergopose.evaluation.matching`,
:mod:`ergopose.evaluation.errors3d` and :mod:`ergopose.evaluation.scoring`; this module puts them
together (:func:`evaluate_results`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ergopose.atomic import write_text
from ergopose.evaluation.bar import bar_section
from ergopose.evaluation.errors3d import errors_section, limbs_section
from ergopose.evaluation.loading import ResultsLayout, json_ready, lens_region_info, load_inputs
from ergopose.evaluation.matching import detection_section, matching_section, row_people
from ergopose.evaluation.scoring import (
    SCORE_SCALES,
    angles_section,
    ground_truth_posture,
    ground_truth_scores,
    scores_section,
    worker_frames,
)
from ergopose.progress import ProgressCallback, report

NETWORK_SOURCE = "pose network (ergopose assess)"


@dataclass(frozen=True)
class Evaluation:
    """The outcome of :func:`evaluate_results`; every section is a JSON-ready dictionary whose keys
    docs/evaluation.md defines. ``source`` says what produced the 2D keypoints (the pose network
    or the ORACLE); ``notes`` are sentences a reader needs to interpret the figures."""

    source: str
    session: str
    results: str
    frames: int
    fps: float
    lens_regions: dict
    matching: dict
    detection: dict
    errors_3d: dict
    limbs: dict
    angles: dict
    scores: dict
    bar: dict
    oracle: dict | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict[str, Any]:
        out = {
            "format": "ergopose.evaluation",
            "version": 1,
            "source": self.source,
            "session": self.session,
            "results": self.results,
            "frames": self.frames,
            "fps": self.fps,
        }
        if self.oracle is not None:
            out["oracle"] = self.oracle
        out.update(
            {
                "lens_regions": self.lens_regions,
                "matching": self.matching,
                "detection": self.detection,
                "errors_3d": self.errors_3d,
                "limbs": self.limbs,
                "angles": self.angles,
                "scores": self.scores,
                "bar": self.bar,
                "notes": list(self.notes),
            }
        )
        return json_ready(out)


# ---------------------------------------------------------------------------------------- evaluate


def evaluate_results(
    session_dir: str | Path,
    layout: ResultsLayout,
    *,
    source: str = NETWORK_SOURCE,
    oracle: dict | None = None,
    bar_noise_px: float = 0.5,
    bar_draws: int = 100,
    seed: int = 0,
    progress: ProgressCallback | None = None,
) -> Evaluation:
    """Compare the results in ``layout`` with the session's ground truth (module docstring)."""
    steps = ("inputs", "matching", "detection", "3D errors", "limbs", "angles", "scores", "reference bar")
    done = 0

    def step(msg: str) -> None:
        nonlocal done
        report(progress, "evaluation", done, len(steps), unit="step", message=msg)
        done += 1

    step("reading the session, ground truth and results")
    inp = load_inputs(session_dir, layout)
    regions, notes = lens_region_info(inp.recon)
    step("matching tracked workers to the simulated ones")
    person = row_people(inp)
    matching, mapping = matching_section(inp, person)
    step("detection rate")
    detection = detection_section(inp)
    step("3D joint errors")
    errors = errors_section(inp, person, mapping)
    step("limbs")
    limbs = limbs_section(inp, person)
    csvs = worker_frames(inp, layout, person)
    step("joint angles")
    angles = angles_section(inp, csvs)
    step("RULA and REBA agreement")
    scores = scores_section(inp, csvs)
    step("reference bar")
    bar = bar_section(
        inp.session, inp.gt, inp.recon.lens_region_limits_deg, noise_px=bar_noise_px, draws=bar_draws, seed=seed
    )
    report(progress, "evaluation", len(steps), len(steps), unit="step")
    if scores.get("task_factor_note"):
        notes.append(scores["task_factor_note"])
    if not mapping:
        notes.append("No tracked worker could be matched to a simulated worker: the per-worker sections are empty.")
    notes.append(angles["caveat"])
    return Evaluation(
        source=source,
        session=str(inp.session.path),
        results=str(layout.root),
        frames=int(inp.gt.n_frames),
        fps=float(inp.gt.fps),
        lens_regions=regions,
        matching=matching,
        detection=detection,
        errors_3d=errors,
        limbs=limbs,
        angles=angles,
        scores=scores,
        bar=bar,
        oracle=oracle,
        notes=tuple(notes),
    )


def write_json(evaluation: Evaluation, path: str | Path) -> Path:
    """The evaluation as strict JSON (NaN as null), written atomically."""
    return write_text(path, json.dumps(evaluation.to_dict(), indent=1, allow_nan=False) + "\n")


__all__ = [
    "ResultsLayout",
    "Evaluation",
    "evaluate_results",
    "write_json",
    "ground_truth_posture",
    "ground_truth_scores",
    "load_inputs",
    "SCORE_SCALES",
]
