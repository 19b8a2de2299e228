"""What an evaluation of simulated results reads: the results folder's layout
(:class:`ResultsLayout`), the session, its ground truth and the tracks table (:func:`load_inputs`),
the reported ids, the one lens-region definition, and the strict-JSON helpers of the result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, SupportsFloat

import numpy as np

from ergopose.calibration.check import DEFAULT_RING_BOUNDS_DEG
from ergopose.ergonomics.export import STEPS_SUFFIX
from ergopose.errors import InputError
from ergopose.pipeline.inputs import scoring_settings
from ergopose.pipeline.names import load_names, resolve_naming
from ergopose.recon.settings import ReconSettings, from_mapping
from ergopose.recon.table import read_tracks, table_to_frames
from ergopose.recon.track_records import identity_name
from ergopose.session import load_session
from ergopose.sim.ground_truth import load_ground_truth
from ergopose.sim.scene import LENS_REGIONS_DEG


@dataclass(frozen=True)
class ResultsLayout:
    """Where an assessment's outputs are.

    root: the results folder; tracks: the tracks table (Parquet); csv_dir: the per-worker steps
    CSV files (every angle and RULA/REBA step per frame; docs/csv-columns.md), named
    ``<csv_prefix><worker>_steps.csv``.
    """

    root: Path
    tracks: Path
    csv_dir: Path
    csv_prefix: str = ""

    @classmethod
    def of_assess(cls, out_dir: str | Path) -> "ResultsLayout":
        """The layout ``ergopose assess --out OUT`` writes: OUT/pipeline/tracks.parquet, OUT/csv/."""
        root = Path(out_dir)
        return cls(root=root, tracks=root / "pipeline" / "tracks.parquet", csv_dir=root / "csv")

    def frames_csv(self, worker: str) -> Path:
        return self.csv_dir / f"{self.csv_prefix}{worker}{STEPS_SUFFIX}"


def json_ready(value: Any) -> Any:
    """NaN/inf -> None, numpy scalars -> Python, tuples -> lists (strict JSON)."""
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return [json_ready(v) for v in value.tolist()]
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        f = float(value)
        return f if math.isfinite(f) else None
    if isinstance(value, (np.bool_,)):
        return bool(value)
    return value


def round_or_nan(x: SupportsFloat | None, nd: int = 3) -> float:
    """``x`` rounded to ``nd`` decimals for the JSON summaries; NaN when it is None or not finite."""
    return round(float(x), nd) if x is not None and math.isfinite(float(x)) else float("nan")


# ------------------------------------------------------------------------------------------ inputs


@dataclass(frozen=True)
class EvaluationInputs:
    """What an evaluation compares: the session (headers only), its ground truth, the tracks table,
    the settings the assessment used, its metadata and the ids the results report (``load_inputs``)."""

    session: Any
    gt: Any
    tracks: Any  # TrackFrames
    recon: Any  # ReconSettings
    scoring: Any  # ScoringSettings
    metadata: dict
    reported: dict  # tracked id ("worker_3") -> id the results use ("w1" when named by stature)
    identification_notes: tuple


def load_inputs(session_dir: str | Path, layout: ResultsLayout) -> EvaluationInputs:
    """The session (headers only), its ground truth, the tracks table and the settings used."""
    session = load_session(session_dir, check_videos=False)
    if session.ground_truth_dir is None:
        raise InputError(
            "not a simulated session: there is no ground_truth/ folder, and evaluate compares "
            "results with the simulator's ground truth (make one with 'ergopose simulate')",
            path=session.path,
        )
    gt = load_ground_truth(session.ground_truth_dir)
    if tuple(gt.camera_names) != tuple(session.camera_names):
        raise InputError(
            f"the ground truth's cameras ({', '.join(gt.camera_names)}) differ from the session's "
            f"({', '.join(session.camera_names)})",
            path=gt.path,
        )
    if gt.n_frames != session.frame_count:
        raise InputError(
            f"the ground truth has {gt.n_frames} frames but the videos have {session.frame_count}", path=gt.path
        )
    table = read_tracks(layout.tracks)
    settings = table.metadata.get("settings") or {}
    recon = from_mapping(settings, source=layout.tracks) if settings else ReconSettings()
    tracks = table_to_frames(table)
    reported, notes = reported_ids(session, tracks, table.metadata)
    return EvaluationInputs(
        session=session,
        gt=gt,
        tracks=tracks,
        recon=recon,
        scoring=scoring_settings(session),
        metadata=table.metadata,
        reported=reported,
        identification_notes=notes,
    )


def reported_ids(session, tracks, metadata: Mapping) -> tuple[dict[str, str], tuple[str, ...]]:
    """{tracked id: the id the results use}: ``ergopose assess`` names a tracked person after the
    settings' worker whose given stature matches its measured one
    (:func:`ergopose.pipeline.identify.identify_by_stature`, on the stature estimates stored in the
    tracks table) and keeps the pseudonym otherwise, after the names of the session's names.toml
    (:mod:`ergopose.pipeline.names`); the same decision is re-made here."""
    names = [identity_name(w) for w in tracks.workers]
    workers = metadata.get("workers") or {}
    measured = {n: (workers.get(n) or {}).get("stature_estimate_m") for n in names}
    naming = resolve_naming(session, names, load_names(session.path), measured)
    return {n: naming.rename(n) for n in names}, tuple(naming.notes)


# ------------------------------------------------------------------------------------ lens regions


def lens_region_info(recon) -> tuple[dict, list[str]]:
    """The lens-region definition used (the reconstruction settings') and the others in the project."""
    used = [float(x) for x in recon.lens_region_limits_deg]
    sim = [float(LENS_REGIONS_DEG[0][2]), float(LENS_REGIONS_DEG[1][2])]
    cal = [float(x) for x in DEFAULT_RING_BOUNDS_DEG]
    info = {
        "used_limits_deg": used,
        "used_from": "lens_region_limits_deg of the reconstruction settings stored in the tracks table "
        "(ergopose.recon.diagnostics.lens_region)",
        "rule": "central below the first limit, outer up to the second, edge beyond; a 3D point's angle is the "
        "larger of its angles off the two cameras' axes",
        "simulator_limits_deg": sim,
        "calibration_check_default_limits_deg": cal,
        "agree": used == sim == cal,
    }
    notes = []
    if used != sim or used != cal:
        notes.append(
            f"Lens regions: the project has more than one definition -- reconstruction settings "
            f"{used[0]:g}/{used[1]:g} deg (used here for every region figure), simulator "
            f"LENS_REGIONS_DEG {sim[0]:g}/{sim[1]:g} deg, calibration check default "
            f"{cal[0]:g}/{cal[1]:g} deg."
        )
    return info, notes
