"""The [reconstruction] table: association, triangulation, tracking, body model, smoothing and the
diagnostics of the 3D reconstruction (docs/reconstruction.md explains each).

ergopose.recon.settings.ReconSettings is the record the reconstruction uses: the same names and
defaults, except the keys in degrees here (``fit_turn_rate_deg_s``, ``fit_elbow_max_flexion_deg``,
...), in radians there (``fit_turn_rate_rad_s``, ``fit_elbow_max_flexion_rad``, ...; degrees at
the edge, radians inside; :data:`RECORD_NAMES`).
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, field_validator, model_validator

from ergopose.settings.base import Table

#: Keys of the table whose record field has another name (and unit): key -> (field, factor).
RECORD_NAMES = {
    "fit_turn_rate_deg_s": ("fit_turn_rate_rad_s", math.pi / 180.0),
    "fit_elbow_max_flexion_deg": ("fit_elbow_max_flexion_rad", math.pi / 180.0),
    "fit_knee_max_flexion_deg": ("fit_knee_max_flexion_rad", math.pi / 180.0),
    "fit_knee_max_hyperextension_deg": ("fit_knee_max_hyperextension_rad", math.pi / 180.0),
    "fit_head_max_turn_deg": ("fit_head_max_turn_rad", math.pi / 180.0),
}


def _as_tuple(value: Any) -> Any:
    return tuple(value) if isinstance(value, list) else value


class ReconstructionTable(Table):
    """Every threshold of the 3D reconstruction, with the default ergopose uses."""

    min_confidence: float = Field(
        0.5, ge=0, lt=1, description="2D keypoints below this confidence are not triangulated"
    )
    keypoint_sigma_px: float = Field(
        1.5, gt=0, description="standard deviation of a keypoint of confidence 1 (view pixels)"
    )
    reprojection_threshold_px: float = Field(
        15.0, gt=0, description="a joint reprojecting worse loses its worst view or is rejected"
    )

    association_max_distance_m: float = Field(
        0.25, gt=0, description="largest mean ray-to-ray distance of two detections of one person"
    )
    association_min_joints: int = Field(
        2, gt=0, description="torso joints both cameras must see to associate by the torso"
    )
    torso_min_z_m: float = Field(-0.2, description="lowest plausible height of an associated person's torso joints")
    torso_max_z_m: float = Field(2.3, description="highest plausible height of an associated person's torso joints")
    trunk_min_length_m: float = Field(0.25, gt=0, description="shortest plausible mid-hip to mid-shoulder distance")
    trunk_max_length_m: float = Field(1.0, gt=0, description="longest plausible mid-hip to mid-shoulder distance")
    min_person_scale: float = Field(
        0.4,
        ge=0,
        description="a detection spanning less than this fraction of a standing person there is not used; 0: off",
    )

    track_gate_m: float = Field(
        0.6, gt=0, description="largest distance of a person from a track's prediction for a match"
    )
    track_gate_growth_m_per_s: float = Field(
        1.5, gt=0, description="the gate grows by this much per second without a match"
    )
    single_view_gate_m: float = Field(
        0.35, gt=0, description="largest distance of a track from the torso ray of a one-camera person"
    )
    contact_distance_m: float = Field(
        0.5, ge=0, description="tracks closer than this (people passing) are split and re-linked; 0: off"
    )
    max_coast_s: float = Field(
        2.0, gt=0, description="a track unseen for longer ends (its identity waits for re-linking)"
    )
    min_track_s: float = Field(1.0, ge=0, description="a new track shorter than this is dropped as noise")
    relink_window_s: float = Field(
        3.0, gt=0, description="a new track is compared with lost identities after this much data"
    )
    relink_max_speed_m_s: float = Field(
        2.5, gt=0, description="a lost identity is re-linked only where it could walk at this speed"
    )
    relink_max_signature_m: float = Field(
        0.03, gt=0, description="largest RMS difference of limb-length medians for a re-link"
    )
    relink_margin_m: float = Field(
        0.005, ge=0, description="the best re-link candidate must beat the second by this much"
    )
    expected_workers: int = Field(
        0,
        ge=0,
        description="how many workers the area holds (0: unknown): once that many "
        "identities exist, a new track takes a lost worker's identity if that worker could "
        "have walked there, however its limb lengths compare",
    )
    colour_relink: bool = Field(
        True,
        description="a followed worker whose clothing colour over the last relink_window_s "
        "matches a worker nobody follows, and clearly not its own identity's, takes that "
        "worker's identity from the next frame on",
    )

    body_model: bool = Field(
        True, description="fit the worker's body model to all cameras (false: joint-by-joint triangulation)"
    )
    fit_huber_k: float = Field(
        3.0, gt=0, description="Huber corner of the body fit's reprojection error, in keypoint sigmas"
    )
    fit_temporal_sigma_m: float = Field(
        0.03, gt=0, description="a joint may move this much from its previous fit, plus ..."
    )
    fit_speed_m_s: float = Field(1.5, gt=0, description="... this speed times the time since the previous fit")
    fit_pose_prior_sigma_m: float = Field(
        0.35,
        gt=0,
        description="standard deviation of each link of the neutral pose prior (trunk, arms and legs as standing, the head in line with the trunk)",
    )
    fit_hand_prior_sigma_m: float = Field(
        0.05,
        ge=0,
        description="standard deviation of the prior that a hand two "
        "cameras do not see continues its forearm (metres; 0: off)",
    )
    fit_floor_contact_sigma_m: float = Field(
        0.05,
        ge=0,
        description="a worker one camera sees keeps a heel or toe within 0.15 m of the floor, "
        "with this standard deviation (metres; 0: off)",
    )
    fit_turn_rate_deg_s: float = Field(
        math.degrees(4.0), gt=0, description="how fast a segment may turn between fits (one standard deviation)"
    )
    fit_limit_sigma_m: float = Field(
        0.002,
        ge=0,
        description="how far the body model may pass one of its anatomical limits (elbow and knee "
        "flexion, knee hyperextension, head turn), one standard deviation (metres; 0: no limits)",
    )
    fit_elbow_max_flexion_deg: float = Field(150.0, gt=0, le=180, description="an elbow bends at most this far")
    fit_knee_max_flexion_deg: float = Field(155.0, gt=0, le=180, description="a knee bends at most this far")
    fit_knee_max_hyperextension_deg: float = Field(
        10.0, ge=0, lt=90, description="a knee bends backwards at most this far"
    )
    fit_head_max_turn_deg: float = Field(
        90.0,
        gt=0,
        le=180,
        description="the face (mid-ears to nose and eyes) turns at most this far from the trunk's forward direction",
    )
    fit_iterations: int = Field(10, gt=0, description="Levenberg-Marquardt iterations per worker-frame")
    side_lock_break_s: float = Field(
        0.5,
        ge=0,
        description="when every camera (two or more) has labelled a worker's "
        "left and right against the previous fit for this long, the cameras win (seconds; "
        "0: the previous fit always wins)",
    )

    smoothing: bool = Field(True, description="Kalman filter and RTS smoother (false: the raw positions)")
    motion_model: Literal["constant_velocity", "constant_acceleration"] = Field(
        "constant_velocity", description="the smoother's motion model"
    )
    process_noise_m_s2: float = Field(2.0, gt=0, description="white-noise acceleration of the motion model")
    process_noise_jerk_factor: float = Field(
        10.0, gt=0, description="jerk = this x process_noise_m_s2 (constant acceleration)"
    )
    adaptive_noise: bool = Field(
        True,
        description="choose each joint's process noise and measurement-variance scale per worker from the "
        "likelihood of its own track (constant velocity only; false: process_noise_m_s2 and the variance as given)",
    )
    adaptive_process_noise_m_s2: Annotated[tuple[float, ...], BeforeValidator(_as_tuple)] = Field(
        (1.0, 2.0, 4.0, 8.0, 16.0),
        description="the process noises the adaptive smoother chooses from",
        json_schema_extra={"allowed": "one or more positive numbers (m/s^2)"},
    )
    adaptive_variance_scales: Annotated[tuple[float, ...], BeforeValidator(_as_tuple)] = Field(
        (1.0, 2.0, 4.0, 8.0, 16.0),
        description="the factors on the measurement variance the adaptive smoother chooses from",
        json_schema_extra={"allowed": "one or more positive numbers"},
    )
    adaptive_memory_s: float = Field(
        60.0, gt=0, description="the adaptive smoother weighs the evidence of the last this many seconds (e-folding)"
    )
    adaptive_min_s: float = Field(
        5.0,
        ge=0,
        description="a joint keeps process_noise_m_s2 and the variance as given until it has this much evidence",
    )
    reprojection_scale_px: float = Field(
        5.0, gt=0, description="a point's variance grows with (reprojection error / this)^2"
    )
    outlier_gate_chi2: float = Field(
        16.27, ge=0, description="raw positions further from the prediction are ignored (chi-square, 3 dof); 0: off"
    )
    max_gated_run: int = Field(3, gt=0, description="after this many ignored measurements in a row the filter restarts")
    max_fill_gap_s: float = Field(0.5, gt=0, description="gaps of a joint up to this long are filled by the smoother")
    bone_length_constraint: bool = Field(
        False, description="move the smoothed joints to the worker's median limb lengths"
    )
    smoother_lag_s: float = Field(8.0, gt=0, description="the fixed lag of the smoother's backward pass")

    lens_region_limits_deg: Annotated[tuple[float, float], BeforeValidator(_as_tuple)] = Field(
        (30.0, 60.0),
        description="angles off the lens axis splitting central / outer / edge (diagnostics)",
        json_schema_extra={"allowed": "two increasing angles between 0 and 180 (degrees)"},
    )

    @model_validator(mode="after")
    def _ordered(self) -> "ReconstructionTable":
        for lo, hi in (("torso_min_z_m", "torso_max_z_m"), ("trunk_min_length_m", "trunk_max_length_m")):
            if not getattr(self, lo) < getattr(self, hi):
                raise ValueError(f"{lo} ({getattr(self, lo):g}) must be below {hi} ({getattr(self, hi):g})")
        return self

    @field_validator("adaptive_process_noise_m_s2", "adaptive_variance_scales")
    @classmethod
    def _choices(cls, v: tuple[float, ...]) -> tuple[float, ...]:
        if not v or not all(math.isfinite(x) and x > 0 for x in v):
            raise ValueError(f"expected one or more positive numbers, got {list(v)!r}")
        return v

    @field_validator("lens_region_limits_deg")
    @classmethod
    def _limits(cls, v: tuple[float, float]) -> tuple[float, float]:
        if not 0 < v[0] < v[1] < 180:
            raise ValueError(f"expected two increasing angles between 0 and 180 degrees, got {list(v)!r}")
        return v

    def record_values(self) -> dict[str, Any]:
        """The given keys as ReconSettings fields (radians inside)."""
        out = {}
        for key, value in self.given().items():
            name, factor = RECORD_NAMES.get(key, (key, 1.0))
            out[name] = value * factor if factor != 1.0 else value
        return out
