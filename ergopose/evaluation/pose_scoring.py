"""Scoring in the 2D pose measurement (ergopose.evaluation.pose): one prediction of one person
against the truth (found or not, keypoint errors), the full stage's detections matched to the
people, and the scored rows gathered into PersonTrials."""

from __future__ import annotations

import numpy as np

from ergopose.evaluation.pose_geometry import EVAL_JOINTS, PersonGeometry, hip_centre_ray, ray_angles
from ergopose.sim.visibility import VISIBLE
from ergopose.evaluation.pose_records import EvaluationSettings, PersonTrials
from ergopose.geometry.regions import region_index


def score_prediction(
    person: PersonGeometry,
    pixels_fisheye: np.ndarray,
    rays_cam: np.ndarray,
    presence: float,
    settings: EvaluationSettings,
) -> tuple[bool, float, np.ndarray, np.ndarray]:
    """Score one prediction of one person: (found, hip error in torso lengths, joint errors in
    fisheye pixels (12,), joint errors in torso lengths (12,)).

    pixels_fisheye: (33, 2) predicted fisheye pixels; rays_cam: (33, 3) their unit rays (NaN
    where there is no prediction). Joint errors are NaN unless found and the joint is visible.
    """
    hip_error = float(ray_angles(hip_centre_ray(rays_cam), person.hip_ray) / person.torso_angle)
    found = bool(presence >= settings.min_presence and hip_error <= settings.found_within_torso)
    nan = np.full(EVAL_JOINTS.size, np.nan)
    if not found:
        return False, hip_error, nan, nan.copy()
    seen = person.visibility[EVAL_JOINTS] == VISIBLE
    err_px = np.linalg.norm(pixels_fisheye[EVAL_JOINTS] - person.pixels[EVAL_JOINTS], axis=1)
    err_torso = ray_angles(rays_cam[EVAL_JOINTS], person.rays_cam[EVAL_JOINTS]) / person.torso_angle
    return True, hip_error, np.where(seen, err_px, np.nan), np.where(seen, err_torso, np.nan)


def match_stage(
    people: list[tuple[int, PersonGeometry]], others: list[PersonGeometry], found, settings: EvaluationSettings
) -> tuple[dict[int, int], int]:
    """Match the stage's detections (FrameDetections) to the counted people one to one.

    Pairs closer than ``found_within_torso`` (hip centres, torso lengths of the person) are
    taken smallest first. Returns {person position: detection index} and the number of false
    positives: detections matched neither to a counted person nor to a worker whose torso is
    hidden (``others``, such a detection is right but not scored).
    """
    n_det = found.count
    if n_det == 0:
        return {}, 0
    det_hips = hip_centre_ray(found.rays_cam)  # (D, 3)

    def distances(persons: list[PersonGeometry]) -> np.ndarray:
        if not persons:
            return np.zeros((0, n_det))
        hips = np.stack([p.hip_ray for p in persons])
        torso = np.array([p.torso_angle for p in persons])
        return ray_angles(det_hips[None], hips[:, None]) / torso[:, None]

    d = distances([p for _, p in people])
    matches: dict[int, int] = {}
    used: set[int] = set()
    if d.size:
        order = np.dstack(np.unravel_index(np.argsort(d, axis=None), d.shape))[0]
        for i, j in order:
            if not d[i, j] <= settings.found_within_torso:
                break
            if i in matches or j in used:
                continue
            matches[int(i)] = int(j)
            used.add(int(j))
    rest = [j for j in range(n_det) if j not in used]
    d_other = distances(others)
    explained = {j for j in rest if d_other.size and np.nanmin(d_other[:, j]) <= settings.found_within_torso}
    return matches, len(rest) - len(explained)


class TrialRows:
    """The scored rows of one camera (one per condition, frame and counted person), gathered into
    PersonTrials by :meth:`trials`."""

    def __init__(self, limits_deg: tuple[float, float]):
        self.limits_deg = limits_deg
        self.rows: list[tuple] = []

    def add(
        self,
        condition: int,
        frame: int,
        camera: int,
        worker: int,
        person: PersonGeometry,
        presence: float,
        scored: tuple[bool, float, np.ndarray, np.ndarray],
    ) -> None:
        region = int(region_index(np.degrees(person.theta), self.limits_deg))
        found, hip_error, err_px, err_torso = scored
        self.rows.append(
            (
                condition,
                frame,
                camera,
                worker,
                region,
                person.theta,
                person.trunk_inclination,
                presence,
                found,
                hip_error,
                err_px,
                err_torso,
            )
        )

    def trials(self) -> PersonTrials:
        n = len(self.rows)
        k = EVAL_JOINTS.size
        if n == 0:
            z = np.zeros(0)
            return PersonTrials(
                z.astype(np.int64),
                z.astype(np.int64),
                z.astype(np.int64),
                z.astype(np.int64),
                z.astype(np.int64),
                z,
                z,
                z,
                z.astype(bool),
                z,
                np.zeros((0, k)),
                np.zeros((0, k)),
            )
        cols = list(zip(*self.rows))
        ints = [np.array(c, dtype=np.int64) for c in cols[:5]]
        return PersonTrials(
            condition=ints[0],
            frame=ints[1],
            camera=ints[2],
            worker=ints[3],
            region=ints[4],
            theta=np.array(cols[5], np.float64),
            trunk_inclination=np.array(cols[6], np.float64),
            presence=np.array(cols[7], np.float64),
            found=np.array(cols[8], bool),
            hip_error_torso=np.array(cols[9], np.float64),
            joint_error_px=np.stack(cols[10]),
            joint_error_torso=np.stack(cols[11]),
        )
