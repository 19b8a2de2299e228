"""Accuracy check: measure a bar of known length with the calibrated cameras, per lens region.

Like the source paper's Table 1, the fisheye field of view is split into three rings by the
angle between a ray and the lens axis (ring bounds default to the project's lens regions,
ergopose.geometry.regions: 30 and 60 degrees):

- central: every observation of the measurement within 30 degrees of its camera's axis,
- outer:   the largest angle between 30 and 60 degrees,
- edge:    the largest angle above 60 degrees.

A measurement's region is decided by its LARGEST angle over both bar ends and all cameras that
saw them: a length is only as good as its worst ray.

Each bar end is triangulated from the rays through its observed pixels (each camera's full lens
model, unproject -> rotate into the world) as the point closest to those rays
(ergopose.geometry.triangulation.triangulate_midpoint); the length is the distance between the
two triangulated ends.

Observation CSV (``ergopose calibrate check --observations``): one row per camera and bar end,
columns ``measurement,camera,end,u,v``; ``measurement`` any label shared by the rows of one
placement of the bar, ``camera`` a camera name of the calibration file, ``end`` ``a`` or ``b``,
``u, v`` pixel (centre of the top-left pixel is 0, 0). A bar end needs at least two cameras.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.atomic import write_text
from ergopose.errors import InputError
from ergopose.geometry.camera import Camera
from ergopose.geometry.regions import DEFAULT_LIMITS_DEG
from ergopose.geometry.triangulation import triangulate_midpoint

REGIONS = ("central", "outer", "edge")
#: The project's one definition of the lens regions (ergopose.geometry.regions).
DEFAULT_RING_BOUNDS_DEG = DEFAULT_LIMITS_DEG


@dataclass(frozen=True)
class BarMeasurements:
    """Lengths measured with the calibrated cameras.

    labels: (M,) measurement labels.
    lengths: (M,) measured length, metres; NaN where an end could not be triangulated.
    endpoints_world: (M, 2, 3) triangulated bar ends, metres (NaN where not triangulated).
    max_angle: (M,) largest angle from a lens axis over the measurement's rays, radians.
    regions: (M,) "central" / "outer" / "edge".
    ray_miss_m: (M, 2) RMS distance between each triangulated end and its rays, metres.
    """

    labels: tuple[str, ...]
    lengths: np.ndarray
    endpoints_world: np.ndarray
    max_angle: np.ndarray
    regions: tuple[str, ...]
    ray_miss_m: np.ndarray


@dataclass(frozen=True)
class RegionSummary:
    """One row of the table: ``n`` measurements in ``region``; lengths in metres."""

    region: str
    angle_range_deg: tuple[float, float]
    n: int
    target: float
    mean: float
    std: float
    minimum: float
    maximum: float

    @property
    def error_percent(self) -> float:
        """(mean - target) / target, percent (NaN without measurements)."""
        return 100.0 * (self.mean - self.target) / self.target if self.n else float("nan")

    @property
    def spread(self) -> float:
        """Largest deviation of a single measurement from the target, metres (the paper's +- limits)."""
        return max(abs(self.maximum - self.target), abs(self.minimum - self.target)) if self.n else float("nan")


@dataclass(frozen=True)
class CheckReport:
    """The outcome of a bar check: per-measurement values and the per-region table."""

    target_length: float
    ring_bounds_deg: tuple[float, float]
    measurements: BarMeasurements
    regions: tuple[RegionSummary, ...]


def angles_from_axis(camera: Camera, pixels: np.ndarray) -> FloatArray:
    """(...) angle in radians between the lens axis and the ray through each (..., 2) pixel."""
    rays = camera.lens.unproject(np.asarray(pixels, np.float64))
    angle: FloatArray = np.arccos(np.clip(rays[..., 2], -1.0, 1.0))
    return angle


def _rays_world(camera: Camera, pixels: np.ndarray) -> np.ndarray:
    rays_cam = camera.lens.unproject(np.asarray(pixels, np.float64))
    return rays_cam @ np.asarray(camera.rotation_world_from_cam, np.float64).T


def region_of(angle: np.ndarray, ring_bounds: tuple[float, float]) -> np.ndarray:
    """Region index (0 central, 1 outer, 2 edge) of each angle (radians); bounds in radians."""
    return np.searchsorted(np.asarray(ring_bounds, np.float64), np.asarray(angle), side="right")


def measure_bar(
    cameras: Sequence[Camera],
    pixels: np.ndarray,
    target_length: float,
    *,
    ring_bounds_deg: tuple[float, float] = DEFAULT_RING_BOUNDS_DEG,
    labels: Sequence[str] | None = None,
) -> CheckReport:
    """Measure a bar of ``target_length`` metres seen by ``cameras``.

    cameras: V objects with ``lens`` (project/unproject), ``rotation_world_from_cam`` (3, 3) and
        ``position_world`` (3,) (ergopose.geometry.camera.Camera).
    pixels: (M, V, 2, 2) observed pixels [measurement, camera, end a/b, (u, v)]; NaN where a
        camera did not see an end.
    """
    px = np.asarray(pixels, np.float64)
    V = len(cameras)
    if px.ndim != 4 or px.shape[1:] != (V, 2, 2):
        raise InputError(f"bar observations must be shaped (measurements, {V} cameras, 2 ends, 2), got {px.shape}")
    if not (target_length > 0):
        raise InputError(f"the target length must be positive, got {target_length}", field="length")
    lo, hi = ring_bounds_deg
    if not (0 < lo < hi < 180):
        raise InputError(f"ring bounds must satisfy 0 < inner < outer < 180 degrees, got {lo}, {hi}", field="rings")
    M = px.shape[0]
    rays = np.stack([_rays_world(cam, px[:, v]) for v, cam in enumerate(cameras)], axis=1)  # (M, V, 2, 3)
    origins = np.stack([np.asarray(cam.position_world, np.float64) for cam in cameras])  # (V, 3)
    tri = triangulate_midpoint(np.broadcast_to(origins, (M, V, 3)), rays)
    ends = tri.points  # (M, 2, 3)
    lengths = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=-1)
    angles = np.stack([angles_from_axis(cam, px[:, v]) for v, cam in enumerate(cameras)], axis=1)  # (M, V, 2)
    seen = np.all(np.isfinite(px), axis=-1)
    max_angle = np.max(np.where(seen, angles, -np.inf), axis=(1, 2))
    max_angle = np.where(np.isfinite(max_angle), max_angle, np.nan)
    bounds = (np.radians(lo), np.radians(hi))
    region_idx = region_of(np.nan_to_num(max_angle, nan=np.pi), bounds)
    regions = tuple(REGIONS[i] for i in region_idx)
    if labels is None:
        labels = [str(i + 1) for i in range(M)]
    meas = BarMeasurements(
        tuple(str(x) for x in labels), lengths, ends, max_angle, regions, np.asarray(tri.rms_distance_m)
    )
    ranges = ((0.0, lo), (lo, hi), (hi, 180.0))
    rows = []
    for i, name in enumerate(REGIONS):
        sel = (region_idx == i) & np.isfinite(lengths)
        L = lengths[sel]
        if L.size:
            rows.append(
                RegionSummary(
                    name,
                    ranges[i],
                    int(L.size),
                    float(target_length),
                    float(L.mean()),
                    float(L.std(ddof=1)) if L.size > 1 else 0.0,
                    float(L.min()),
                    float(L.max()),
                )
            )
        else:
            rows.append(RegionSummary(name, ranges[i], 0, float(target_length), *(float("nan"),) * 4))
    return CheckReport(float(target_length), (float(lo), float(hi)), meas, tuple(rows))


def format_table(report: CheckReport) -> str:
    """The per-region table as text (like the paper's Table 1)."""
    lines = [
        f"{'Region':<9} {'Angle from axis':<16} {'N':>4}  {'Target (m)':>10}  {'Measured (m)':>18}  "
        f"{'Error':>7}  {'Min..max (m)':>15}"
    ]
    for r in report.regions:
        lo, hi = r.angle_range_deg
        angle = f"< {hi:g} deg" if lo == 0 else (f"> {lo:g} deg" if hi >= 180 else f"{lo:g}-{hi:g} deg")
        if r.n:
            measured = f"{r.mean:.3f} +- {r.std:.3f}"
            err = f"{r.error_percent:+.2f}%"
            rng = f"{r.minimum:.3f}..{r.maximum:.3f}"
        else:
            measured, err, rng = "no measurements", "", ""
        lines.append(f"{r.region:<9} {angle:<16} {r.n:>4}  {r.target:>10.3f}  {measured:>18}  {err:>7}  {rng:>15}")
    lines.append(
        "(+- is the standard deviation over the measurements; a measurement's region is that of its "
        "ray furthest from a lens axis)"
    )
    return "\n".join(lines)


# ------------------------------------------------------------------------------- CSV
OBSERVATION_COLUMNS = ("measurement", "camera", "end", "u", "v")


def read_bar_observations(path: str | Path, camera_names: Sequence[str]) -> tuple[list[str], np.ndarray]:
    """Read the observation CSV (module doc) -> (labels, pixels (M, V, 2, 2) with NaN where unseen).

    Raises InputError naming the file, line and problem.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError("observation file not found", path=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read observation file: {exc}", path=path) from None
    reader = csv.DictReader(text.splitlines())
    header = [h.strip() for h in (reader.fieldnames or [])]
    missing = [c for c in OBSERVATION_COLUMNS if c not in header]
    if missing:
        raise InputError(
            f"missing column(s) {', '.join(missing)}; expected a header {','.join(OBSERVATION_COLUMNS)}", path=path
        )
    index = {name: i for i, name in enumerate(camera_names)}
    labels: list[str] = []
    where: dict[str, int] = {}
    values: dict[tuple[int, int, int], tuple[float, float]] = {}
    for line, row in enumerate(reader, start=2):
        row = {(k or "").strip(): (v or "").strip() for k, v in row.items()}
        if not any(row.values()):
            continue
        cam = row["camera"]
        if cam not in index:
            raise InputError(
                f"line {line}: unknown camera {cam!r}; the calibration has {', '.join(camera_names)}", path=path
            )
        end = row["end"].lower()
        if end not in ("a", "b"):
            raise InputError(f"line {line}: end must be 'a' or 'b', got {row['end']!r}", path=path)
        try:
            u, v = float(row["u"]), float(row["v"])
        except ValueError:
            raise InputError(
                f"line {line}: u and v must be numbers (pixels), got {row['u']!r}, {row['v']!r}", path=path
            ) from None
        if not (np.isfinite(u) and np.isfinite(v)):
            raise InputError(f"line {line}: u and v must be finite numbers", path=path)
        label = row["measurement"]
        if label not in where:
            where[label] = len(labels)
            labels.append(label)
        key = (where[label], index[cam], 0 if end == "a" else 1)
        if key in values:
            raise InputError(
                f"line {line}: measurement {label!r}, camera {cam!r}, end {end!r} appears twice", path=path
            )
        values[key] = (u, v)
    if not labels:
        raise InputError("no observations in this file", path=path)
    pixels = np.full((len(labels), len(camera_names), 2, 2), np.nan)
    for (m, c, e), uv in values.items():
        pixels[m, c, e] = uv
    seen = np.all(np.isfinite(pixels), axis=-1).sum(axis=1)  # (M, 2) cameras per end
    bad = np.flatnonzero(np.any(seen < 2, axis=1))
    if bad.size:
        raise InputError(
            f"measurement {labels[bad[0]]!r}: each bar end needs pixels from at least two cameras", path=path
        )
    return labels, pixels


def write_bar_observations(
    path: str | Path, camera_names: Sequence[str], pixels: np.ndarray, labels: Sequence[str] | None = None
) -> Path:
    """Write (M, V, 2, 2) pixels as an observation CSV (atomically); NaN entries are skipped."""
    px = np.asarray(pixels, np.float64)
    labels = labels if labels is not None else [str(i + 1) for i in range(px.shape[0])]
    out = [",".join(OBSERVATION_COLUMNS)]
    for m, label in enumerate(labels):
        for c, cam in enumerate(camera_names):
            for e, end in enumerate("ab"):
                u, v = px[m, c, e]
                if np.isfinite(u) and np.isfinite(v):
                    out.append(f"{label},{cam},{end},{u:.4f},{v:.4f}")
    return write_text(path, "\n".join(out) + "\n")
