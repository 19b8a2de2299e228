"""settings.toml as one typed model: :class:`SettingsFile` and its tables.

docs/session-format.md describes the file and docs/settings.md lists every key (generated from
this model by ``python -m ergopose.settings``). ergopose.session.load_session validates the file
with :func:`read_settings`, then checks what needs the folder (calibration, videos, the
recording's length) and builds the frozen Session record.
"""

from __future__ import annotations

import datetime as dt
import os
import tomllib
from pathlib import Path
from typing import Annotated, Any

from pydantic import BeforeValidator, Field, field_validator

from ergopose.errors import ConfigError
from ergopose.settings.base import Table, validate
from ergopose.settings.pose import PoseTable
from ergopose.settings.reconstruction import ReconstructionTable
from ergopose.settings.scoring import ScoringTable
from ergopose.settings.tasks import PeriodTable, TaskFactorsTable, Text, WorkerTable

#: The settings format this code writes; it reads exactly the versions in SUPPORTED_VERSIONS.
FORMAT_VERSION = 1
SUPPORTED_VERSIONS = (1,)
CALIBRATION_FILE = "calibration.toml"


def _iso(value: Any) -> Any:
    if isinstance(value, str):
        try:
            return dt.datetime.fromisoformat(value)
        except ValueError:
            pass
    return value


def _version(value: int) -> int:
    if value not in SUPPORTED_VERSIONS:
        raise ValueError(
            f"unsupported format version {value!r} (this ergopose reads {', '.join(map(str, SUPPORTED_VERSIONS))})"
        )
    return value


class CameraTable(Table):
    """One camera of the session and its video."""

    name: Text = Field(description="a camera of the calibration file", examples=["cam_1"])
    video: Text = Field(
        description="its video: a file relative to the session folder, or an fsspec URL (docs/cluster.md)",
        examples=["cam_1.mp4"],
    )


class IdentificationTable(Table):
    """How tracked people are matched to the workers that give a stature (docs/session-format.md)."""

    by_stature: bool = Field(False, description="name tracked people by their measured stature")
    stature_tolerance_m: float = Field(
        0.05, gt=0, description="largest difference of given and measured stature for a match"
    )
    stature_margin_m: float = Field(
        0.02, gt=0, description="the best matching must beat every other by this much in total"
    )


class CalibrationCheckTable(Table):
    """A reference bar measured by the cameras (ergopose calibrate check; docs/calibration.md)."""

    observations: Text = Field(
        description="CSV of the bar ends' pixels, relative to the session folder", examples=["reference_bars.csv"]
    )
    length_m: float = Field(gt=0, description="the bar's true length", examples=[1.5])


class SettingsFile(Table):
    """The whole settings.toml (format_version 1)."""

    format_version: int = Field(description="version of this format; this ergopose reads 1", examples=[FORMAT_VERSION])
    recorded_at: Annotated[dt.datetime, BeforeValidator(_iso)] = Field(
        description="date and time of the first frame (a time-zone offset, or local time)",
        examples=[dt.datetime(2024, 3, 4, 8, 0, tzinfo=dt.timezone(dt.timedelta(hours=1)))],
    )
    fps: float | None = Field(
        None, gt=0, description="frames per second; default: the videos' rate (must agree within 1 %)", examples=[12.0]
    )
    description: Text | None = Field(None, description="free text for the reports", examples=["Line 3, early shift"])
    calibration: Text = Field(CALIBRATION_FILE, description="the calibration file in the session folder")
    cameras: list[CameraTable] = Field(
        min_length=1,
        description="one table per camera; the order is the order ergopose uses everywhere",
        json_schema_extra={"allowed": "at least one [[cameras]] table (name and video)"},
    )
    defaults: TaskFactorsTable = Field(
        default_factory=TaskFactorsTable, description="task factors for every worker, whole session"
    )
    periods: list[PeriodTable] = Field(default_factory=list, description="time windows with task factors for everyone")
    workers: dict[str, WorkerTable] = Field(default_factory=dict, description="one table per worker id")
    identification: IdentificationTable = Field(
        default_factory=IdentificationTable, description="matching tracked people to workers by stature"
    )
    calibration_check: CalibrationCheckTable | None = Field(None, description="a reference bar for the accuracy check")
    scoring: ScoringTable = Field(default_factory=ScoringTable, description="scoring settings (docs/scoring.md)")
    pose: PoseTable = Field(default_factory=PoseTable, description="the 2D pose stage (docs/pose-in-fisheye.md)")
    reconstruction: ReconstructionTable = Field(
        default_factory=ReconstructionTable, description="the 3D reconstruction (docs/reconstruction.md)"
    )

    @field_validator("format_version")
    @classmethod
    def _supported(cls, v: int) -> int:
        return _version(v)

    @field_validator("cameras")
    @classmethod
    def _distinct(cls, cams: list[CameraTable]) -> list[CameraTable]:
        for i, c in enumerate(cams):
            for j, other in enumerate(cams[:i]):
                if c.name == other.name:
                    raise ValueError(f"camera {c.name!r} is listed twice (cameras[{j}] and cameras[{i}])")
                if os.path.normpath(c.video) == os.path.normpath(other.video):
                    raise ValueError(f"video {c.video!r} is listed for two cameras (cameras[{j}] and cameras[{i}])")
        return cams


def read_toml(path: Path, what: str) -> dict[str, Any]:
    """A TOML file as a dict; ConfigError naming the file when it is missing, unreadable or not TOML."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"the {what} does not exist", path=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the {what} ({exc})", path=path) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML ({exc})", path=path) from None


def read_settings(path: str | os.PathLike[str]) -> tuple[SettingsFile, dict[str, Any]]:
    """settings.toml validated: (the model, the file's data as read)."""
    p = Path(path)
    data = read_toml(p, "settings file")
    return validate(SettingsFile, data, path=p), data
