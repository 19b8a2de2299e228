"""Reconstruction settings: every threshold of association, triangulation, tracking, smoothing
and the diagnostics, with documented defaults (docs/reconstruction.md explains each one).

Values a user types are in metres, seconds, pixels and degrees (the names say which); the code
converts degrees to radians where it compares them with measured angles. A settings file is
TOML: top-level keys, or a ``[reconstruction]`` table inside a larger session settings file.
Names, defaults, allowed values and the one-line errors come from the typed table
ergopose.settings.reconstruction.ReconstructionTable (a test holds the two together); its keys in
other units are ``fit_turn_rate_deg_s`` (degrees per second; here ``fit_turn_rate_rad_s``) and the
body model's limits in degrees (``fit_elbow_max_flexion_deg`` ...; here ``..._rad``).
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Mapping

from ergopose.settings.base import validate
from ergopose.settings.model import read_toml
from ergopose.settings.reconstruction import RECORD_NAMES, ReconstructionTable

#: ReconSettings field -> (key of the [reconstruction] table, factor from the field to the key).
_TABLE_NAMES = {name: (key, 1.0 / factor) for key, (name, factor) in RECORD_NAMES.items()}


@dataclass(frozen=True)
class ReconSettings:
    """Settings of the 3D reconstruction over a shift.

    2D input and triangulation
        min_confidence: 0.5 -- 2D keypoints with a lower confidence are not used at all (a
            network's guess at a hidden joint; with the simulator's oracle, keeping hidden
            joints reported at confidence 0.3-0.4 raised the raw 3D error from 28 to 41 mm,
            docs/reconstruction.md).
        keypoint_sigma_px: 1.5 -- standard deviation (view pixels) of a 2D keypoint with
            confidence 1; it sets the variance of each triangulated point from the geometry of
            its rays (triangulate.point_variance), which weighs the measurements in smoothing.
        reprojection_threshold_px: 15 -- a joint whose RMS reprojection error (view pixels)
            exceeds this loses its worst view (3+ cameras) or, with two cameras, is rejected:
            its point becomes NaN and both observations are marked rejected.
    Association of the people seen by the two cameras (per frame)
        association_max_distance_m: 0.25 -- largest mean ray-to-ray distance (torso joints) of
            a pair of detections that may be the same person.
        association_min_joints: 2 -- torso joints (shoulders, hips) both cameras must see with
            min_confidence; with fewer, all joints seen by both count (at least 3).
        torso_min_z_m, torso_max_z_m: -0.2, 2.3 -- the torso joints of a pair, triangulated
            from the two rays, must lie between these heights (a ghost pair made of two
            different people usually does not).
        trunk_min_length_m, trunk_max_length_m: 0.25, 1.0 -- mid-hip to mid-shoulder distance
            of a pair must lie within these bounds (where both are seen). The upper bound was 0.8
            until 2026-11-28: the network's keypoints of one worker seen by two cameras make a
            trunk of 0.83-1.28 m (median 0.95) in a few per cent of worker-frames, and those
            pairs were refused (docs/reconstruction.md, "Two cameras").
        min_person_scale: 0.4 -- a camera's detection whose keypoints span less than this
            fraction of the angle a standing person with hips on its hip rays would span is not
            used (a skeleton squeezed into the visible part of a partly hidden person;
            :mod:`ergopose.recon.person_scale`); 0: every detection is used.
    Tracking of identities
        track_gate_m: 0.6 -- largest distance between a track's predicted body centre and a
            person's triangulated centre for a match, at one frame of coasting.
        track_gate_growth_m_per_s: 1.5 -- the gate grows by this much per second without a
            match (the person may have changed pace while unseen).
        single_view_gate_m: 0.35 -- largest distance of a track's predicted centre from the
            torso ray of a person seen by one camera only, for that person to keep the track.
        contact_distance_m: 0.5 -- two tracks whose centres come closer than this (people
            passing each other) are split; after relink_window_s their continuations get the
            two identities back, crossed over only if the body-measurement signatures say so
            (by relink_margin_m). 0 disables the check.
        max_coast_s: 2.0 -- a track without any observation for longer than this ends; its
            identity waits in the pool of lost identities for re-linking.
        min_track_s: 1.0 -- a new track that ends before it has this many seconds of 3D
            observations is dropped as noise (its frames do not enter the tracks table).
        relink_window_s: 3.0 -- a new track is compared with the lost identities once it has
            this much 3D data (or when it ends, if earlier); the decision is then final.
        relink_max_speed_m_s: 2.5 -- a lost identity can only be re-linked to a new track whose
            first position it could have reached at this speed (plus track_gate_m).
        relink_max_signature_m: 0.03 -- largest RMS difference of the limb-length medians
            (body-measurement signature) for a re-link.
        relink_margin_m: 0.005 -- the best candidate must beat the second best by this much;
            otherwise the new track gets a new identity (no guess).
        expected_workers: 0 -- how many workers the area holds, as the safety engineer knows it
            (0: unknown). Once that many identities exist, a new track whose signature settles
            nothing takes the identity of a lost worker who could have walked to where it began
            (the closest signature, then the most recently lost) instead of a new one; with no
            such worker (everyone is being followed) it still gets a new one.
        colour_relink: true -- a followed worker whose clothing colour over the last
            relink_window_s matches a worker nobody follows (and clearly not the worker of its
            identity) takes that worker's identity from the next frame on
            (ergopose.recon.track_colour_relink); false: an identity, once given, holds.
    Body model (ergopose.recon.bodyfit: every worker-frame fitted to every camera at once)
        body_model: true -- fit the worker's body model (constant segment lengths, previous
            pose, pose prior) to all cameras' keypoints of every tracked worker-frame, with no
            confidence gate; false keeps the joint-by-joint triangulation (joints seen by two
            cameras above min_confidence only).
        fit_huber_k: 3.0 -- Huber loss corner of the reprojection error, in keypoint sigmas
            (keypoint_sigma_px / confidence): larger errors count linearly (a network's
            occasional wrong keypoint does not drag the body).
        fit_temporal_sigma_m: 0.03, fit_speed_m_s: 1.5 -- a joint may move
            fit_temporal_sigma_m + fit_speed_m_s x (time since the worker's previous fit)
            (one standard deviation) from its previous fitted position.
        fit_pose_prior_sigma_m: 0.35 -- standard deviation of each link of the neutral pose
            prior (metres; trunk upright, arms and legs hanging under the hips' heading, the
            head in line with the current trunk; decides only what nothing else decides).
        fit_hand_prior_sigma_m: 0.05 -- standard deviation of the prior that a hand two cameras
            do not see continues its forearm (hand points against the forearm's line, metres);
            0 turns it off.
        fit_floor_contact_sigma_m: 0.05 -- for a worker only one camera sees, the lowest heel or
            toe is pulled to within bodyfit.FLOOR_CONTACT_BAND_M (0.15 m) of the floor with this
            standard deviation (metres; one camera's rays leave the distance to the body to its
            size, which the keypoints tell poorly); 0 turns it off (work areas with platforms or
            stairs seen by one camera).
        fit_turn_rate_rad_s: 4.0 -- each segment's vector may change by fit_temporal_sigma_m +
            this x its length x the time since the previous fit (one standard deviation): a
            small rigid part (a hand, the head) keeps its orientation from frame to frame instead
            of flipping to its mirror image when one camera sees it poorly.
        fit_limit_sigma_m: 0.002 -- the body model's anatomical limits (bodyfit.LIMITS), each a
            one-sided term with this standard deviation (metres): an elbow bends at most
            fit_elbow_max_flexion_rad (150 deg), a knee at most fit_knee_max_flexion_rad (155 deg)
            and backwards at most fit_knee_max_hyperextension_rad (10 deg), the face turns at most
            fit_head_max_turn_rad (90 deg) from the trunk's forward direction (in settings.toml the
            four are in degrees: fit_elbow_max_flexion_deg, ...). 0 turns the limits off.
        fit_iterations: 10 -- Levenberg-Marquardt iterations per worker-frame.
        side_lock_break_s: 0.5 -- the previous fit decides a camera's left and right
            (correct_left_right); when every camera that can tell (two or more) has disagreed with
            it for this long, the cameras win: the previous fit was the one mirrored. 0: never.

    Smoothing (Kalman filter + Rauch-Tung-Striebel smoother per joint and coordinate)
        smoothing: true -- false writes the raw triangulations.
        motion_model: "constant_velocity" or "constant_acceleration".
        process_noise_m_s2: 2.0 -- standard deviation of the white-noise acceleration
            (constant velocity) in m/s^2; for constant_acceleration the jerk in m/s^3 is this
            times process_noise_jerk_factor.
        process_noise_jerk_factor: 10.0 -- see above (1/s).
        adaptive_noise: true -- (constant velocity) each joint of each worker gets the process
            noise and the factor on its measurement variance that make its own track most likely:
            a bank of filters, one per pair of adaptive_process_noise_m_s2 (1, 2, 4, 8, 16) and
            adaptive_variance_scales (1, 2, 4, 8, 16: the fit's variance is never made smaller,
            so the reported SDs stay at least the fit's), runs beside the smoother and sums each
            joint's innovation log-likelihood over its three coordinates, weighing the evidence
            of the last adaptive_memory_s (60 s, e-folding); the smoother uses the most likely
            pair from the next frame on, and process_noise_m_s2 with the variance as given until
            the joint has adaptive_min_s (5 s) of measurements. A gait's knees and a reach's
            hands move faster than the trunk, and how much a joint's measurements scatter
            depends on the cameras and the 2D source, which the fit's variance does not fully
            carry (docs/reconstruction.md, section 4).
        reprojection_scale_px: 5.0 -- the variance of a triangulated point grows by the factor
            1 + (reprojection_error / reprojection_scale_px)^2.
        outlier_gate_chi2: 16.27 -- (raw triangulations only, body_model = false; the body
            fit's output is not gated) a joint's measurement whose Mahalanobis distance squared
            (3 coordinates) from the prediction exceeds this is ignored (chi-square, 3 degrees
            of freedom, p = 0.999); 0 disables the gate.
        max_gated_run: 3 -- after this many ignored measurements in a row the filter restarts
            from the next measurement (the motion was real, not an outlier).
        max_fill_gap_s: 0.5 -- gaps of a joint up to this long are filled by the smoother
            (flagged gap_filled); longer gaps stay NaN and split the joint's track.
        bone_length_constraint: false -- after smoothing, move the joints so that each limb
            of keypoints.LIMBS has the worker's median length (weighted by the joints' variance).
        smoother_lag_s: 8.0 -- the backward pass of the smoother for a block of frames starts
            this far after the block's end (or at the end of the joint's track): a fixed-lag
            RTS smoother, so that a shift processed in chunks gives exactly the same result.
    Diagnostics
        lens_region_limits_deg: (30, 60) -- a point is "central" below the first angle from a
            camera's axis, "outer" up to the second, "edge" beyond; the larger angle of the
            two cameras counts. The default splits the 90 degree half field of view of a
            180 degree fisheye into three equal rings (the paper names three concentric rings
            but gives no limits).
    """

    min_confidence: float = 0.5
    keypoint_sigma_px: float = 1.5
    reprojection_threshold_px: float = 15.0

    association_max_distance_m: float = 0.25
    association_min_joints: int = 2
    torso_min_z_m: float = -0.2
    torso_max_z_m: float = 2.3
    trunk_min_length_m: float = 0.25
    trunk_max_length_m: float = 1.0
    min_person_scale: float = 0.4

    track_gate_m: float = 0.6
    track_gate_growth_m_per_s: float = 1.5
    single_view_gate_m: float = 0.35
    contact_distance_m: float = 0.5
    max_coast_s: float = 2.0
    min_track_s: float = 1.0
    relink_window_s: float = 3.0
    relink_max_speed_m_s: float = 2.5
    relink_max_signature_m: float = 0.03
    relink_margin_m: float = 0.005
    expected_workers: int = 0
    colour_relink: bool = True

    body_model: bool = True
    fit_huber_k: float = 3.0
    fit_temporal_sigma_m: float = 0.03
    fit_speed_m_s: float = 1.5
    fit_pose_prior_sigma_m: float = 0.35
    fit_hand_prior_sigma_m: float = 0.05
    fit_floor_contact_sigma_m: float = 0.05
    fit_turn_rate_rad_s: float = 4.0
    fit_limit_sigma_m: float = 0.002
    fit_elbow_max_flexion_rad: float = math.radians(150.0)
    fit_knee_max_flexion_rad: float = math.radians(155.0)
    fit_knee_max_hyperextension_rad: float = math.radians(10.0)
    fit_head_max_turn_rad: float = math.radians(90.0)
    fit_iterations: int = 10
    side_lock_break_s: float = 0.5

    smoothing: bool = True
    motion_model: str = "constant_velocity"
    process_noise_m_s2: float = 2.0
    process_noise_jerk_factor: float = 10.0
    adaptive_noise: bool = True
    adaptive_process_noise_m_s2: tuple[float, ...] = (1.0, 2.0, 4.0, 8.0, 16.0)
    adaptive_variance_scales: tuple[float, ...] = (1.0, 2.0, 4.0, 8.0, 16.0)
    adaptive_memory_s: float = 60.0
    adaptive_min_s: float = 5.0
    reprojection_scale_px: float = 5.0
    outlier_gate_chi2: float = 16.27
    max_gated_run: int = 3
    max_fill_gap_s: float = 0.5
    bone_length_constraint: bool = False
    smoother_lag_s: float = 8.0

    lens_region_limits_deg: tuple[float, float] = (30.0, 60.0)

    def __post_init__(self) -> None:
        validate(ReconstructionTable, to_table(self.as_dict()))

    def replace(self, **changes: Any) -> "ReconSettings":
        """A copy with some settings changed (unknown names raise ConfigError)."""
        return from_mapping({**self.as_dict(), **changes})

    def as_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["lens_region_limits_deg"] = list(self.lens_region_limits_deg)
        d["adaptive_process_noise_m_s2"] = list(self.adaptive_process_noise_m_s2)
        d["adaptive_variance_scales"] = list(self.adaptive_variance_scales)
        return d


def setting_names() -> tuple[str, ...]:
    return tuple(f.name for f in fields(ReconSettings))


def to_table(values: Mapping[str, Any]) -> dict[str, Any]:
    """Field values -> the keys and units of the [reconstruction] table."""
    out = {}
    for name, value in values.items():
        key, factor = _TABLE_NAMES.get(name, (name, 1.0))
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        out[key] = value * factor if factor != 1.0 and ok else value
    return out


def from_table(table: ReconstructionTable) -> ReconSettings:
    """The record of a validated [reconstruction] table (the defaults where it gives nothing)."""
    return dataclasses.replace(ReconSettings(), **table.record_values())


def from_mapping(
    values: Mapping[str, Any], source: str | os.PathLike[str] | None = None, prefix: tuple[str, ...] = ()
) -> ReconSettings:
    """Settings from a mapping of field names to values (as_dict's names; the tracks table stores
    them so); a problem raises one ConfigError naming the key, the value and what is allowed."""
    table = validate(ReconstructionTable, to_table(values), source, prefix)
    record = table.record_values()
    for name in _TABLE_NAMES:  # the exact value given, not its round trip through other units
        if name in values:
            record[name] = float(values[name])
    return dataclasses.replace(ReconSettings(), **record)


def load_settings(path: str | os.PathLike[str] | None) -> ReconSettings:
    """Read a TOML settings file (top-level keys or a [reconstruction] table, in the table's keys
    and units); None gives the defaults."""
    if path is None:
        return ReconSettings()
    p = Path(path)
    data = read_toml(p, "settings file")
    prefix: tuple[str, ...] = ()
    if "reconstruction" in data:
        data, prefix = data["reconstruction"], ("reconstruction",)
    return from_table(validate(ReconstructionTable, data, p, prefix))
