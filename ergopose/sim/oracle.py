"""ORACLE 2D source: ground-truth joints projected into the cameras, with simulated errors.

FOR EVALUATION ONLY. The oracle knows where every joint is (the simulation's ground truth) and
only pretends to be a 2D pose network: it adds seeded pixel noise, drops whole detections and
single joints, and lowers the confidence of joints the camera cannot see. Use it to test the
stages after 2D pose (triangulation, tracking, angles, scoring) against exact answers, and to
separate their errors from the network's. Its results must never be reported as measurements:
every record it makes carries ``source = "oracle"``.

Coordinates: fisheye pixels of the session's cameras (x right, y down, (0, 0) the centre of the
top-left pixel). :meth:`OracleObservations.view_pixels` maps them into a virtual view.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pandas as pd

from ergopose.keypoints import BLAZEPOSE33, NUM_JOINTS
from ergopose.sim.ground_truth import GroundTruth
from ergopose.sim.visibility import OUTSIDE_IMAGE, SELF_OCCLUDED, VISIBLE

ORACLE_SOURCE = "oracle"


@dataclass(frozen=True)
class OracleObservations:
    """ORACLE 2D observations (ground truth plus simulated errors), evaluation only.

    pixels_fisheye: (F, C, W, 33, 2) float64 fisheye pixels; NaN where the oracle reports
        nothing (joint outside the image, detection or joint dropped).
    confidence: (F, C, W, 33) float32 in [0, 1]; 0 where pixels are NaN.
    visibility: (F, C, W, 33) bool, the joints the oracle reports as seen: those the ground truth
        codes visible, and with ``own_body_hides`` False also those behind the worker's own body.
    detected: (F, C, W) bool, the oracle reports this worker in this camera frame.
    frames: (F,) frame indices into the session; times_s: (F,) their times.
    worker_ids, camera_names: the W workers and C cameras, in ground-truth order.
    source: always "oracle".
    """

    pixels_fisheye: np.ndarray
    confidence: np.ndarray
    visibility: np.ndarray
    detected: np.ndarray
    frames: np.ndarray
    times_s: np.ndarray
    worker_ids: tuple[str, ...]
    camera_names: tuple[str, ...]
    source: str = ORACLE_SOURCE

    def view_pixels(self, view, camera: int | str) -> np.ndarray:
        """(F, W, 33, 2) pixels of one camera's observations in a virtual view
        (:class:`ergopose.geometry.views.VirtualView` of that camera); NaN behind the view."""
        c = camera if isinstance(camera, int) else self.camera_names.index(camera)
        return view.source_to_view_pixels(self.pixels_fisheye[:, c])

    def to_frame(self):
        """A long pandas DataFrame: source, frame, time_s, camera, worker, joint, x, y, confidence, visible."""
        f, c, w, j = np.meshgrid(
            np.arange(len(self.frames)),
            np.arange(len(self.camera_names)),
            np.arange(len(self.worker_ids)),
            np.arange(NUM_JOINTS),
            indexing="ij",
        )
        return pd.DataFrame(
            {
                "source": pd.array([self.source] * f.size, dtype="string"),
                "frame": self.frames[f.ravel()],
                "time_s": self.times_s[f.ravel()],
                "camera": pd.array(np.array(self.camera_names, dtype=object)[c.ravel()], dtype="string"),
                "worker": pd.array(np.array(self.worker_ids, dtype=object)[w.ravel()], dtype="string"),
                "joint": pd.array(np.array(BLAZEPOSE33, dtype=object)[j.ravel()], dtype="string"),
                "x": self.pixels_fisheye[..., 0].ravel(),
                "y": self.pixels_fisheye[..., 1].ravel(),
                "confidence": self.confidence.ravel(),
                "visible": self.visibility.ravel(),
            }
        )


@dataclass(frozen=True)
class OracleSource:
    """An ORACLE 2D pose source built on a simulated session's ground truth (evaluation only).

    noise_px: standard deviation of the pixel noise on visible joints (per axis, fisheye pixels).
    occluded_noise_px: the same for joints the camera cannot see (a network still guesses them).
    person_dropout: probability that a worker goes undetected in a camera frame.
    joint_dropout: probability that a single visible joint is missing.
    report_occluded: report hidden joints (with low confidence) rather than leaving them out.
    own_body_hides: a joint the ground truth codes hidden by the worker's own body (the ray from
        the camera crosses more of the worker's own limb than the allowance of
        :mod:`ergopose.sim.visibility`) counts as hidden (True) or as seen (False: ``noise_px`` and
        a visible joint's confidence -- issue 13's "true joints + noise"; furniture, walls, bars
        and other workers still hide). The random draws are the same either way.
    seed: the random source; the same seed gives the same observations.
    """

    ground_truth: GroundTruth
    noise_px: float = 1.5
    occluded_noise_px: float = 6.0
    person_dropout: float = 0.02
    joint_dropout: float = 0.02
    report_occluded: bool = True
    own_body_hides: bool = True
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("noise_px", "occluded_noise_px"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {v!r}")
        for name in ("person_dropout", "joint_dropout"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise ValueError(f"{name} must be a probability in [0, 1], got {v!r}")

    def observe(self, frames: Sequence[int] | np.ndarray | slice | None = None) -> OracleObservations:
        """ORACLE observations for the given frames (default: all). The random errors of a frame
        do not depend on which other frames are asked for."""
        gt = self.ground_truth
        index = np.arange(gt.n_frames)
        if frames is not None:
            index = index[frames] if isinstance(frames, slice) else np.asarray(frames, dtype=np.int64)
        truth = gt.pixels[index].astype(np.float64)  # (F, C, W, 33, 2)
        codes = gt.visibility[index]
        f, c, w = truth.shape[:3]
        noise = np.empty_like(truth)
        u_person = np.empty((f, c, w))
        u_joint = np.empty((f, c, w, NUM_JOINTS))
        u_conf = np.empty((f, c, w, NUM_JOINTS))
        for k, frame in enumerate(index):  # one small generator per frame: errors independent of the selection
            rng = np.random.default_rng(np.random.SeedSequence([self.seed, int(frame)]))
            noise[k] = rng.standard_normal((c, w, NUM_JOINTS, 2))
            u_person[k] = rng.random((c, w))
            u_joint[k] = rng.random((c, w, NUM_JOINTS))
            u_conf[k] = rng.random((c, w, NUM_JOINTS))
        visible = codes == VISIBLE
        if not self.own_body_hides:
            visible = visible | (codes == SELF_OCCLUDED)
        hidden = ~visible & (codes != OUTSIDE_IMAGE)
        sigma = np.where(visible, self.noise_px, self.occluded_noise_px)[..., None]
        pixels = truth + noise * sigma
        confidence = np.where(visible, 0.75 + 0.25 * u_conf, 0.1 + 0.3 * u_conf).astype(np.float32)
        detected = (u_person >= self.person_dropout) & (visible.any(axis=-1))
        keep = detected[..., None] & (codes != OUTSIDE_IMAGE) & np.isfinite(truth).all(axis=-1)
        keep &= ~(visible & (u_joint < self.joint_dropout))
        if not self.report_occluded:
            keep &= ~hidden
        pixels[~keep] = np.nan
        confidence[~keep] = 0.0
        return OracleObservations(
            pixels_fisheye=pixels,
            confidence=confidence,
            visibility=visible,
            detected=detected,
            frames=index,
            times_s=gt.times_s[index],
            worker_ids=gt.worker_ids,
            camera_names=gt.camera_names,
        )
