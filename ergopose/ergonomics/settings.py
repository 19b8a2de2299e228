"""Scoring settings: the choices RULA and REBA leave open, with documented defaults.

The worksheets settle most of the scoring (assessments/rula.toml, assessments/reba.toml); what
they leave open is collected here: boundaries the wording does not settle, tolerances for the
single-point "neutral" and "upright" postures, thresholds that turn measured angles into the
yes/no adjustments, the time windows of muscle use and activity, and worksheet variants in
circulation. docs/scoring.md explains every setting.

Values a user types are in degrees, seconds, kilograms and metres (the names say which); the
scoring converts degrees to radians where it compares them with measured angles.

A settings file is TOML: either top-level keys, or a ``[scoring]`` table inside a larger
session settings file (then only that table is read). Names, defaults, allowed values and the
one-line errors come from the typed table ergopose.settings.scoring.ScoringTable; this record
holds the same fields (a test holds the two together).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Mapping

from ergopose.errors import ConfigError
from ergopose.settings.base import validate
from ergopose.settings.model import read_toml
from ergopose.settings.scoring import ScoringTable


@dataclass(frozen=True)
class ScoringSettings:
    """Every open choice of the scoring, with the default ergopose uses.

    Boundaries not settled by the worksheets' wording (an angle exactly on the edge):
        rula_open_boundary: "higher" -- RULA's own pattern ("X or more") gives the shared end
            point to the higher-scoring band: upper arm +20/+45, neck 10, trunk 20.
        reba_open_boundary: "lower" -- REBA's own pattern ("> X") gives it to the lower band:
            trunk +20, upper arm +20/+45, knee 30.
    Tolerances of single-point postures (degrees; an angle within +-tolerance counts as the
    neutral posture, the tolerance edge itself included):
        wrist_neutral_deg: 5 -- RULA wrist "neutral" (step 3).
        trunk_upright_deg: 5 -- RULA and REBA trunk "upright".
        neck_extension_deg: 5 -- neck "in extension" counts beyond this many degrees of extension.
    Thresholds of the yes/no adjustments (a flag column in the posture table overrides them):
        shoulder_raised_deg: 10 -- shoulder_elevation above this is a raised shoulder.
        upper_arm_abducted_deg: 30 -- upper_arm_abduction above this is an abducted arm.
        trunk_twisted_deg / trunk_side_bent_deg: 10 -- |trunk_twist| / |trunk_side_bend| above
            this (EN 1005-4 treats 10 degrees of trunk twist or side bend as the first limit).
        neck_twisted_deg / neck_side_bent_deg: 10 -- the same for the neck.
        wrist_deviated_deg: 10 -- |wrist_deviation| (radial/ulnar) above this.
        across_midline_m: 0.05 -- the wrist is across the midline when it lies more than this
            far (metres) beyond the trunk's midsagittal plane, on the other arm's side.
        out_to_side_m: 0.35 -- the wrist is out to the side when it lies more than this far
            (metres) from the midsagittal plane on its own side.
    Muscle use (RULA) and activity (REBA), from the time series:
        rula_static_hold_s: 60 -- RULA "mainly static, e.g. held > 1 min" (600 = the "> 10 min"
            variant of one commercial sheet).
        reba_static_hold_s: 60 -- REBA "held > 1 min".
        static_includes_neutral: False -- a body part resting in its lowest-scoring band is not
            a static load; True counts any unchanged band.
        repetition_amplitude_deg: 15 -- an action is a rise and fall of a joint angle by at
            least this much (the prominence of the angle's peak).
        repetition_window_s: 60 -- repetitions are counted in a window this long centred on
            each frame.
        rula_repetitions_per_min: 4 -- RULA "repeated 4 or more times/min" (>=).
        reba_repetitions_per_min: 4 -- REBA "repeated more than 4 times/min" (>).
        rapid_change_deg: 30, rapid_change_window_s: 1 -- REBA "rapid large-range changes":
            an angle that spans more than rapid_change_deg within rapid_change_window_s.
        max_gap_s: 1 -- frames further apart than this break a hold (tracking lost).
    Worksheet variants:
        rula_lower_arm_adjust: "single" -- one +1 for working across the midline or out to the
            side (original); "separate" -- a +1 for each (some sheets; can exceed Table A).
        reba_twist_side_adjust: "single" -- one +1 for twisted or side-flexed neck/trunk
            (original); "separate" -- a +1 for each (some sheets; can exceed Table A).
    Unknown yes/no inputs (NaN flags, missing load):
        unknown_flags: "absent" -- an unknown flag adds nothing (the score is a lower bound and
            the rows are counted in rula_unknown_flags / reba_unknown_flags); "missing" -- the
            step score becomes missing.
    How sure each frame's scores are (ergopose.ergonomics.uncertainty):
        joint_sd_floor_m: 0.018 -- the pose network's own error at each joint (metres, per
            coordinate), added in quadrature to the reconstruction's standard deviation when the
            joints are drawn: the fit's covariance holds only what the cameras disagree on, and
            on the real Pose2Sim recording the product's joints lie a median 39 mm from that
            tool's 3D (half of that variance taken as ours: 39 / sqrt(2) / 1.54 = 18 mm per
            coordinate; docs/scoring.md). 0 draws within the fit's deviations only.
    """

    rula_open_boundary: str = "higher"
    reba_open_boundary: str = "lower"

    wrist_neutral_deg: float = 5.0
    trunk_upright_deg: float = 5.0
    neck_extension_deg: float = 5.0

    shoulder_raised_deg: float = 10.0
    upper_arm_abducted_deg: float = 30.0
    trunk_twisted_deg: float = 10.0
    trunk_side_bent_deg: float = 10.0
    neck_twisted_deg: float = 10.0
    neck_side_bent_deg: float = 10.0
    wrist_deviated_deg: float = 10.0
    across_midline_m: float = 0.05
    out_to_side_m: float = 0.35

    rula_static_hold_s: float = 60.0
    reba_static_hold_s: float = 60.0
    static_includes_neutral: bool = False
    repetition_amplitude_deg: float = 15.0
    repetition_window_s: float = 60.0
    rula_repetitions_per_min: float = 4.0
    reba_repetitions_per_min: float = 4.0
    rapid_change_deg: float = 30.0
    rapid_change_window_s: float = 1.0
    max_gap_s: float = 1.0

    rula_lower_arm_adjust: str = "single"
    reba_twist_side_adjust: str = "single"

    unknown_flags: str = "absent"

    joint_sd_floor_m: float = 0.018

    def __post_init__(self) -> None:
        validate(ScoringTable, dataclasses.asdict(self))

    def replace(self, **changes: Any) -> "ScoringSettings":
        """A copy with some settings changed (unknown names raise ConfigError)."""
        return from_mapping({**dataclasses.asdict(self), **changes})

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def setting_names() -> tuple[str, ...]:
    return tuple(f.name for f in fields(ScoringSettings))


def from_mapping(
    values: Mapping[str, Any], source: str | os.PathLike[str] | None = None, prefix: tuple[str, ...] = ()
) -> ScoringSettings:
    """Settings from a mapping of names to values; a problem raises one ConfigError naming the
    file (``source``), the key (under ``prefix``), the value and what is allowed."""
    return ScoringSettings(**validate(ScoringTable, dict(values), source, prefix).model_dump())


def load_settings(path: str | os.PathLike[str] | None) -> ScoringSettings:
    """Read a TOML settings file (top-level keys or a [scoring] table); None gives the defaults."""
    if path is None:
        return ScoringSettings()
    p = Path(path)
    data = read_toml(p, "settings file")
    if "scoring" in data:
        if not isinstance(data["scoring"], dict):
            raise ConfigError("expected a table", path=p, field="scoring")
        return from_mapping(data["scoring"], source=p, prefix=("scoring",))
    return from_mapping(data, source=p)
