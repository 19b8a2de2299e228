"""The [scoring] table: the choices RULA and REBA leave open (docs/scoring.md explains each).

ergopose.ergonomics.settings.ScoringSettings is the record the scoring uses; its fields and
defaults are these (a test holds the two together).
"""

from __future__ import annotations

from typing import Literal, Any

from pydantic import Field

from ergopose.settings.base import Table

Boundary = Literal["higher", "lower"]
Variant = Literal["single", "separate"]


def _deg(default: float, description: str) -> Any:  # a tolerance or threshold angle below 90 degrees
    return Field(default, ge=0, lt=90, description=description)


class ScoringTable(Table):
    """Every open choice of the scoring, with the default ergopose uses."""

    rula_open_boundary: Boundary = Field(
        "higher", description="RULA: which band an angle exactly on a band edge falls in"
    )
    reba_open_boundary: Boundary = Field(
        "lower", description="REBA: which band an angle exactly on a band edge falls in"
    )

    wrist_neutral_deg: float = _deg(5.0, "RULA wrist within +- this is neutral")
    trunk_upright_deg: float = _deg(5.0, "trunk within +- this is upright (RULA and REBA)")
    neck_extension_deg: float = _deg(5.0, "neck extension beyond this counts as 'in extension'")

    shoulder_raised_deg: float = _deg(10.0, "shoulder elevation above this is a raised shoulder")
    upper_arm_abducted_deg: float = _deg(30.0, "upper arm abduction above this is an abducted arm")
    trunk_twisted_deg: float = _deg(10.0, "trunk twist above this is a twisted trunk")
    trunk_side_bent_deg: float = _deg(10.0, "trunk side bend above this is a side-bent trunk")
    neck_twisted_deg: float = _deg(10.0, "neck twist above this is a twisted neck")
    neck_side_bent_deg: float = _deg(10.0, "neck side bend above this is a side-bent neck")
    wrist_deviated_deg: float = _deg(10.0, "wrist radial/ulnar deviation above this is a deviated wrist")
    across_midline_m: float = Field(0.05, ge=0, description="wrist this far beyond the body's midline works across it")
    out_to_side_m: float = Field(0.35, ge=0, description="wrist this far out on its own side works out to the side")

    rula_static_hold_s: float = Field(
        60.0, gt=0, description="RULA: a posture held longer is static (600 = the '> 10 min' variant)"
    )
    reba_static_hold_s: float = Field(60.0, gt=0, description="REBA: a posture held longer is static")
    static_includes_neutral: bool = Field(False, description="a hold in the lowest-scoring band counts as static too")
    repetition_amplitude_deg: float = Field(
        15.0, gt=0, description="smallest rise and fall of an angle that counts as an action"
    )
    repetition_window_s: float = Field(
        60.0, gt=0, description="actions are counted in a window this long around each frame"
    )
    rula_repetitions_per_min: float = Field(
        4.0, gt=0, description="RULA: repeated at this many actions per minute or more"
    )
    reba_repetitions_per_min: float = Field(4.0, gt=0, description="REBA: repeated above this many actions per minute")
    rapid_change_deg: float = Field(30.0, gt=0, description="REBA rapid change: an angle spans more than this ...")
    rapid_change_window_s: float = Field(1.0, gt=0, description="... within this many seconds")
    max_gap_s: float = Field(1.0, gt=0, description="frames further apart break a hold (tracking lost)")

    rula_lower_arm_adjust: Variant = Field(
        "single", description="RULA lower arm: one +1 for across the midline or out to the side, or one for each"
    )
    reba_twist_side_adjust: Variant = Field(
        "single", description="REBA neck/trunk: one +1 for twisted or side-bent, or one for each"
    )

    unknown_flags: Literal["absent", "missing"] = Field(
        "absent", description="an unknown yes/no input adds nothing (a lower bound) or makes the step score missing"
    )

    joint_sd_floor_m: float = Field(
        0.018,
        ge=0,
        le=0.2,
        description="the pose network's own error at each joint (metres, per coordinate): every draw of the "
        "scores' probabilities moves each joint by a lasting offset of this size, on top of the measured "
        "standard deviation; 0: what the cameras disagree on only",
    )
