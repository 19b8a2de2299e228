"""What an assessment's run depends on, settled before the video work: the scoring settings of the
session, the pose models in the cache (verified), and the fingerprint of the inputs the stored
chunks depend on (:class:`ergopose.pipeline.store.ResultStore`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

from ergopose import __version__
from ergopose.ergonomics.settings import ScoringSettings, from_mapping
from ergopose.pipeline.detect import DetectJob
from ergopose.pipeline.store import file_fingerprint
from ergopose.pose.models import BLAZEPOSE_DETECTOR, ensure_model, landmark_card, model_card
from ergopose.progress import ProgressCallback, report
from ergopose.session import Session


def scoring_settings(session: Session) -> ScoringSettings:
    """The scoring settings of the session's [scoring] table (defaults where not given)."""
    return from_mapping(dict(session.scoring), source=session.settings_path)


@dataclass(frozen=True)
class ModelUse:
    """A pose model used by the run: its card and the SHA-256 verified before use."""

    card: Any
    sha256: str
    path: Path


def ensure_models(
    model_dir: str | None, progress: ProgressCallback | None, model: str | None = None
) -> tuple[ModelUse, ...]:
    """The BlazePose detector and the landmark model ``model`` (lite, full, heavy; None: the
    default) in the cache (fetched with a progress bar on first use), verified."""
    out = []
    names = (BLAZEPOSE_DETECTOR, landmark_card(model).name)
    for k, name in enumerate(names):
        report(progress, "models", k, len(names), unit="model", message=name)
        path = ensure_model(name, progress, model_dir=model_dir)
        card = model_card(name)
        out.append(ModelUse(card=card, sha256=card.file.sha256, path=Path(path)))
    report(progress, "models", len(names), len(names), unit="model")
    return tuple(out)


def fingerprint_inputs(
    session: Session,
    job: DetectJob,
    chunk_frames: int,
    models: Sequence[ModelUse],
    source: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """What the stored chunks depend on: videos, calibration, 2D and 3D settings, models, version.

    Task factors, worker names and scoring settings are not part of it: changing them re-runs
    only the stages after the 2D work. source: the description of a 2D source other than the pose
    networks (:class:`ergopose.pipeline.detect.Source2D`), when there is one.
    """
    inputs = {
        "ergopose": __version__,
        "videos": [file_fingerprint(c.video_path) for c in session.cameras],
        "calibration": file_fingerprint(session.calibration_path),
        "cameras": list(session.camera_names),
        "fps": session.fps,
        "frames": session.frame_count,
        "chunk_frames": int(chunk_frames),
        "pose_settings": repr(job.pose),
        "recon_settings": repr(job.recon),
        "models": [m.sha256 for m in models],
    }
    if source is not None:
        inputs["source"] = dict(source)
    return inputs
