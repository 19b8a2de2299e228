"""The evaluation as text for the terminal (``ergopose evaluate``)."""

from __future__ import annotations

import math
from typing import Any

from ergopose.recon.diagnostics import REGIONS


def _f(x: Any, fmt: str = ".1f", unit: str = "") -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    return f"{x:{fmt}}{unit}"


def format_evaluation(ev: dict) -> str:
    """The evaluation dictionary (:meth:`Evaluation.to_dict`) as a readable report."""
    lines: list[str] = []
    oracle = ev.get("oracle")
    if oracle:
        lines += [oracle["banner"], ""]
    lines.append(f"Evaluation of {ev['results']}")
    lines.append(f"  against the ground truth of {ev['session']} ({ev['frames']} frames at {_f(ev['fps'], 'g')} fps)")
    lines.append(f"  2D source: {ev['source']}")
    lr = ev["lens_regions"]
    lo, hi = lr["used_limits_deg"]
    lines.append(
        f"  lens regions: central < {lo:g} deg, outer {lo:g}-{hi:g} deg, edge > {hi:g} deg (reconstruction settings)"
    )
    if not lr["agree"]:
        s, c = lr["simulator_limits_deg"], lr["calibration_check_default_limits_deg"]
        lines.append(
            f"  NOTE: other definitions in the project: simulator {s[0]:g}/{s[1]:g} deg, calibration check "
            f"default {c[0]:g}/{c[1]:g} deg; this evaluation uses {lo:g}/{hi:g} deg throughout"
        )
    m = ev["matching"]
    lines += ["", "Identities"]
    reported = m.get("reported_workers", m["tracked_workers"])
    as_reported = f" (reported as {len(reported)} after naming)" if len(reported) != len(m["tracked_workers"]) else ""
    lines.append(
        f"  tracked {len(m['tracked_workers'])} worker id(s){as_reported} for {len(m['ground_truth_workers'])} simulated "
        f"worker(s); identity switches: {m['identity_switches']} ({m['identity_switches_sustained']} "
        f"holding at least {m['sustained_min_frames']} frames); rows matched to another worker than "
        f"their id's: {m['rows_matched_to_another_worker_than_the_mapping']} of {m['rows_matched']}"
    )
    nb = m["named_by_stature"]
    if nb["ids"]:
        lines.append(
            "  named (names.toml or stature): "
            + ", ".join(f"{t} -> {w}" for t, w in nb["ids"].items())
            + f"; right person in {_f(nb['correct_pct'], '.1f', ' %')} of their rows"
        )
    for note in nb["notes"]:
        lines.append(f"  naming: {note}")
    for gid, ids in m["tracked_ids_per_ground_truth_worker"].items():
        lines.append(f"    {gid}: {', '.join(ids) if ids else '(not tracked)'}")
    split = m["rows_by_id_per_ground_truth_worker"]
    lines.append(
        f"  rows on each worker's main id: {_f(m['rows_on_the_workers_main_id_pct'], '.1f', ' %')}; a worker's "
        "rows by id: "
        + "; ".join(f"{gid} " + ", ".join(f"{i} {n}" for i, n in ids.items()) for gid, ids in split.items() if ids)
    )
    if m["unmatched_tracked_workers"]:
        lines.append(f"    matched to nobody: {', '.join(m['unmatched_tracked_workers'])}")
    d = ev["detection"]
    lines += ["", "Detection"]
    v = d["visible_in_both_cameras"]
    lines.append(
        f"  detection rate {_f(d['detection_rate_pct'], '.1f', ' %')} ({v['reconstructed']} of {v['worker_frames']} "
        "worker-frames visible in both cameras)"
    )
    lines.append(
        "  by region: "
        + ", ".join(
            f"{r} {_f(d['by_region'][r]['rate_pct'], '.1f', ' %')} (n={d['by_region'][r]['worker_frames']})"
            for r in REGIONS
        )
    )
    fb, fr = d["followed_in_both_cameras"], d["followed_by_region"]
    lines.append(
        f"  followed (final position, any number of cameras) {_f(fb['rate_pct'], '.1f', ' %')}; by region: "
        + ", ".join(f"{r} {_f(fr[r]['rate_pct'], '.1f', ' %')}" for r in REGIONS)
        + f"; rows near nobody {d['tracked_rows_with_a_position_unmatched']} of {d['tracked_rows_with_a_position']}"
    )
    nn = d.get("rows_near_nobody")
    if nn is not None and nn["rows"]:
        lines.append(
            f"  rows near nobody: false people {nn['false_people']} ({_f(d['false_people_pct'], '.2f', ' %')} of the rows "
            f"with a position: {nn['far_from_every_worker']} more than {nn['misplaced_distance_m']:g} m from every "
            f"worker, {nn['second_row_on_a_followed_worker']} a second row on a worker already followed); "
            f"{nn['misplaced_rows_of_a_worker']} a worker's only row placed 0.5-{nn['misplaced_distance_m']:g} m off"
        )
    lines.append(
        f"  triangulated rows matched to nobody: {d['tracked_rows_triangulated_unmatched']} of "
        f"{d['tracked_rows_triangulated']}"
    )
    e = ev["errors_3d"]
    lines += ["", "3D joint error (MPJPE)"]
    for src, label in (("final", "smoothed"), ("raw", "raw triangulation")):
        br = e[src]["by_region"]
        lines.append(
            f"  {label:<18} all {_f(br['all']['mean_mm'], '.1f', ' mm')}"
            + "".join(f", {r} {_f(br[r]['mean_mm'], '.1f', ' mm')} (n={br[r]['points']})" for r in REGIONS)
        )
    bi = e["final"]["by_track_identity"]["all"]
    lines.append(
        f"  every row against its id's mapped worker (identity mistakes included): "
        f"{_f(bi['mean_mm'], '.1f', ' mm')} (smoothed)"
    )
    worst = sorted(
        ((k, j["mean_mm"]) for k, j in e["final"]["by_joint"].items() if j["mean_mm"] is not None),
        key=lambda kv: -kv[1],
    )[:5]
    if worst:
        lines.append("  largest per joint: " + ", ".join(f"{k} {v:.1f} mm" for k, v in worst))
    lb = ev["limbs"]
    lines += ["", "Limb lengths"]
    lines.append(
        f"  CV mean {_f(lb['cv_mean_pct'], '.2f', ' %')}, max {_f(lb['cv_max_pct'], '.2f', ' %')} "
        f"(rigid limbs: mean {_f(lb['cv_mean_rigid_pct'], '.2f', ' %')}, "
        f"max {_f(lb['cv_max_rigid_pct'], '.2f', ' %')}; raw triangulation: mean "
        f"{_f(lb['cv_mean_raw_pct'], '.2f', ' %')}); "
        f"reconstructed {_f(lb['frequency_pct'], '.1f', ' %')} of limb-frames; error "
        f"bias {_f(lb['error']['bias_mm'], '.1f', ' mm')}, RMSE {_f(lb['error']['rmse_mm'], '.1f', ' mm')}"
    )
    lines.append(
        f"  {'limb':<17} {'true m':>7} {'CV %':>6} {'true CV %':>9} {'RMSE mm':>8} {'freq %':>7}  "
        + "  ".join(f"{r[:4]} %" for r in REGIONS)
    )
    for name, row in lb["by_limb"].items():
        lines.append(
            f"  {name:<17} {_f(row['true_mean_m'], '.3f'):>7} {_f(row['cv_pct']['all'], '.2f'):>6} "
            f"{_f(row['true_cv_pct'], '.2f'):>9} {_f(row['error']['rmse_mm'], '.1f'):>8} "
            f"{_f(row['frequency_pct']['all'], '.1f'):>7}  "
            + "  ".join(f"{_f(row['frequency_pct'][r], '.0f'):>6}" for r in REGIONS)
        )
    a = ev["angles"]
    lines += [
        "",
        f"Joint angles (RMSE, degrees; {a['rows_compared']} worker-frames; all angles {_f(a['rmse_all_deg'], '.2f')})",
    ]
    for name, row in a["by_angle"].items():
        lines.append(
            f"  {name:<26} RMSE {_f(row['rmse_deg'], '6.2f')}  bias {_f(row['bias_deg'], '+6.2f')}  "
            f"n={row['n']}"
            + (f" missing={row['missing']}" if row["missing"] else "")
            + (
                f"  within 1 / 2 SD {_f(row['within_one_sd_pct'], '.0f')} / {_f(row['within_two_sd_pct'], '.0f')} %"
                f" (median SD {_f(row['median_sd_deg'], '.1f')})"
                if row.get("sd_rows")
                else ""
            )
        )
    s = ev["scores"]
    lines += ["", "RULA / REBA agreement with the scores of the true angles"]
    for c in ("rula_grand", "rula_action_level", "reba_score", "reba_risk_level"):
        r = s[c]
        lines.append(
            f"  {c:<18} exact {_f(r['exact_agreement_pct'], '5.1f', ' %')}, within one "
            f"{_f(r['within_one_pct'], '5.1f', ' %')}, kappa {_f(r['kappa'], '.3f')}, linear-weighted "
            f"{_f(r['kappa_linear'], '.3f')} (n={r['pairs']}"
            + (f"; {r['truth_on_band_edge']} with the true score on a band edge" if r["truth_on_band_edge"] else "")
            + ")"
        )
    lines.append(
        "  exact agreement that angle errors of this size leave (the truth plus this run's own angle errors "
        "moved in time): "
        + ", ".join(
            f"{c} {_f(s[c]['expected_exact_agreement_pct'], '.1f', ' %')}" for c in ("rula_grand", "reba_score")
        )
    )
    for c in ("rula_grand", "reba_score"):
        rel = s[c].get("reported_probability")
        if not rel:
            continue
        lines.append(
            f"  {c}: the reported probability against exact agreement: "
            + ", ".join(
                f"p {lo:.1f}-{hi:.1f}: {_f(e, '.0f', ' %')} (mean p {_f(m, '.2f')}, n={n})"
                for (lo, hi), n, m, e in zip(
                    rel["bins"], rel["frames"], rel["mean_probability"], rel["exact_agreement_pct"]
                )
                if n
            )
            + f"; gap {_f(rel['calibration_gap_pp'], '.1f')} points; confident frames "
            f"{_f(rel['confident']['exact_agreement_pct'], '.1f', ' %')} (n={rel['confident']['frames']}), "
            f"the others {_f(rel['others']['exact_agreement_pct'], '.1f', ' %')} (n={rel['others']['frames']})"
        )
    for c in ("rula_grand", "reba_score"):
        parts = s[c]["expected_exact_agreement_with_exact_part_pct"]
        if parts:
            lines.append(
                f"    {c} with one part's angles exact: "
                + ", ".join(f"{part} {_f(v, '.1f', ' %')}" for part, v in parts.items())
            )
    for c, sh in s["time_shares"].items():
        if not sh["by_worker"]:
            continue
        lines.append(
            f"  {c}: share of each worker's time per level (levels {sh['levels'][0]}-{sh['levels'][-1]}), "
            f"measured / true; largest difference {_f(sh['largest_difference_pp'], '.1f')} points"
        )
        for wid, r in sh["by_worker"].items():
            lines.append(
                f"    {wid:<6} "
                + "  ".join(f"{m:.0f}/{t:.0f}" for m, t in zip(r["measured_pct"], r["true_pct"]))
                + f" %  (n={r['frames']})"
            )
    b = ev["bar"]
    lines += [
        "",
        "Reference bar (calibration + geometry, not the pose network; "
        f"{_f(b['noise_px'], 'g')} px noise, {b['draws_per_bar']} draws per bar, seed {b['seed']})",
    ]
    lines += ["  " + t for t in b["table"].splitlines()]
    if ev.get("notes"):
        lines += ["", "Notes"]
        lines += [f"  - {n}" for n in ev["notes"]]
    return "\n".join(lines)
