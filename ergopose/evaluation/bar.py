"""The reference-bar check of a simulated session, without rendering (docs/evaluation.md).

The simulated room holds 1.5 m reference bars placed so that both cameras see each one in the same
lens region (ground_truth/scene.toml ``reference_bars``). Like the paper's Table 1 (a bar of known
length measured in the central, outer and edge regions of the lens), each bar is measured many
times:

1. its two end points (world) are projected through the TRUE cameras of the simulated rig
   (:func:`ergopose.sim.scene.rig_cameras` at the session's image size) to fisheye pixels;
2. seeded Gaussian pixel noise (``noise_px`` per axis, default 0.5 px: a careful click on the end
   cap) is added, ``draws`` times per bar;
3. the ends are triangulated through the session's CALIBRATION cameras and the length measured by
   the calibration check (:func:`ergopose.calibration.check.measure_bar`, regions from the
   reconstruction settings' lens-region limits), and tabulated with its ``format_table``.

This measures calibration and two-camera geometry, NOT the pose network. In a simulated session the
calibration file holds the true cameras, so the spread comes from the pixel noise alone (the
``calibration_vs_truth_px`` figure shows how far the calibration projects the bar ends from the
true cameras: 0 in a simulated session).
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ergopose.calibration.check import format_table, measure_bar
from ergopose.errors import InputError
from ergopose.sim.scene import rig_cameras

DEFAULT_NOISE_PX = 0.5
DEFAULT_DRAWS = 100


def true_cameras(gt) -> tuple:
    """The simulated rig's cameras at the session's image size, in the ground truth's camera order."""
    size = gt.scene.get("session", {})
    try:
        width, height = int(size["width"]), int(size["height"])
    except (KeyError, TypeError, ValueError):
        raise InputError("scene.toml has no [session] width and height", path=gt.path) from None
    cams = {c.name: c for c in rig_cameras(width, height)}
    missing = [n for n in gt.camera_names if n not in cams]
    if missing:
        raise InputError(f"the simulated rig has no camera {', '.join(missing)}", path=gt.path)
    return tuple(cams[n] for n in gt.camera_names)


def bar_pixels(
    cameras: Sequence, bars: Sequence[dict], noise_px: float, draws: int, seed: int
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Noisy observations of the bars: (draws * B, V, 2, 2) pixels [measurement, camera, end, uv],
    the exact pixels (B, V, 2, 2) and one label per measurement ("<bar>#<draw>")."""
    ends = np.array([[b["end_a"], b["end_b"]] for b in bars], dtype=np.float64)  # (B, 2, 3)
    exact = np.stack([cam.project_world(ends) for cam in cameras], axis=1)  # (B, V, 2, 2)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 1500]))
    noise = rng.standard_normal((int(draws),) + exact.shape) * float(noise_px)
    pixels = (exact[None] + noise).reshape((-1,) + exact.shape[1:])
    labels = [f"{b['name']}#{d}" for d in range(int(draws)) for b in bars]
    return pixels, exact, labels


def bar_section(
    session,
    gt,
    limits_deg: tuple[float, float],
    *,
    noise_px: float = DEFAULT_NOISE_PX,
    draws: int = DEFAULT_DRAWS,
    seed: int = 0,
) -> dict[str, Any]:
    """The reference-bar table (module docstring) as a JSON-ready dictionary; ``table`` holds the
    text of :func:`ergopose.calibration.check.format_table` for each bar length."""
    if not (np.isfinite(noise_px) and noise_px >= 0):
        raise InputError(f"expected a pixel noise >= 0, got {noise_px}", field="--bar-noise-px")
    if draws < 1:
        raise InputError(f"expected at least 1 draw per bar, got {draws}", field="--bar-draws")
    bars = gt.reference_bars()
    out: dict[str, Any] = {
        "definition": (
            "bar ends projected through the TRUE simulated cameras, seeded Gaussian pixel noise added, "
            "triangulated through the session's CALIBRATION cameras and measured with "
            "ergopose.calibration.check.measure_bar; measures calibration + geometry, not the pose "
            "network. In a simulated session the calibration equals the truth, so the errors come "
            "from the pixel noise"
        ),
        "noise_px": float(noise_px),
        "draws_per_bar": int(draws),
        "seed": int(seed),
        "ring_bounds_deg": [float(x) for x in limits_deg],
        "bars": [],
        "regions": [],
        "table": "",
    }
    if not bars:
        out["table"] = "the scene has no reference bars"
        return out
    truth = true_cameras(gt)
    calib = session.calibrated_cameras
    pixels, exact, labels = bar_pixels(truth, bars, noise_px, draws, seed)
    ends = np.array([[b["end_a"], b["end_b"]] for b in bars], dtype=np.float64)
    calib_px = np.stack([cam.project_world(ends) for cam in calib], axis=1)
    out["calibration_vs_truth_px"] = round(float(np.nanmax(np.linalg.norm(calib_px - exact, axis=-1))), 6)
    lengths = np.array([float(b.get("length_m", np.linalg.norm(np.subtract(b["end_b"], b["end_a"])))) for b in bars])
    bar_of = np.tile(np.arange(len(bars)), int(draws))
    tables = []
    for target in np.unique(lengths):
        sel = lengths[bar_of] == target
        rep = measure_bar(
            calib,
            pixels[sel],
            float(target),
            ring_bounds_deg=limits_deg,
            labels=[lab for lab, s in zip(labels, sel) if s],
        )
        noiseless = measure_bar(calib, exact[lengths == target], float(target), ring_bounds_deg=limits_deg)
        tables.append(
            f"Reference bar {target:g} m ({int(sel.sum())} measurements, {noise_px:g} px noise):\n" + format_table(rep)
        )
        for r in rep.regions:
            out["regions"].append(
                {
                    "region": r.region,
                    "angle_range_deg": list(r.angle_range_deg),
                    "n": r.n,
                    "target_m": r.target,
                    "mean_m": _r(r.mean, 5),
                    "std_m": _r(r.std, 5),
                    "min_m": _r(r.minimum, 5),
                    "max_m": _r(r.maximum, 5),
                    "error_pct": _r(r.error_percent, 3),
                    "spread_m": _r(r.spread, 5),
                }
            )
        idx = np.flatnonzero(lengths == target)
        m = rep.measurements
        for j, k in enumerate(idx):
            mine = bar_of[sel] == k
            L = m.lengths[mine]
            out["bars"].append(
                {
                    "name": bars[k]["name"],
                    "length_m": float(target),
                    "region": m.regions[int(np.flatnonzero(mine)[0])],
                    "max_angle_deg": _r(np.degrees(np.nanmax(m.max_angle[mine])), 3),
                    "noiseless_length_m": _r(noiseless.measurements.lengths[j], 6),
                    "mean_m": _r(np.nanmean(L), 5),
                    "std_m": _r(np.nanstd(L, ddof=1) if len(L) > 1 else 0.0, 5),
                    "error_pct": _r(100.0 * (np.nanmean(L) - target) / target, 3),
                }
            )
    out["table"] = "\n\n".join(tables)
    return out


def _r(x: float, nd: int) -> float:
    x = float(x)
    return round(x, nd) if np.isfinite(x) else float("nan")
