"""evaluate_results against results with known answers: a perfect reconstruction (the ground truth
itself, written with the project's writers), swapped and switched identities, a known offset, and
hand-made changes to the angles and scores of the frames CSV."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pandas as pd
import pytest

from ergopose.errors import InputError
from ergopose.evaluation.compare import evaluate_results
from ergopose.evaluation.loading import ResultsLayout
from ergopose.evaluation.loading import scoring_settings
from ergopose.evaluation.scoring import angle_stats, ground_truth_posture, ground_truth_scores
from ergopose.session import load_session
from ergopose.recon.diagnostics import REGIONS
from ergopose.sim.ground_truth import load_ground_truth

from evaluation_helpers import ground_truth_tracks, write_results

# Left out of make test-fast (still in make test): every test here compares against a simulated 15 s session (small_session).
pytestmark = pytest.mark.slow

DRAWS = 40


def _evaluate(session, out):
    return evaluate_results(session, ResultsLayout.of_assess(out), bar_draws=DRAWS).to_dict()


@pytest.fixture(scope="module")
def gt(small_session):
    return load_ground_truth(small_session)


@pytest.fixture(scope="module")
def perfect(small_session, gt, tmp_path_factory):
    out = write_results(small_session, tmp_path_factory.mktemp("perfect") / "out", ground_truth_tracks(gt))
    return out, _evaluate(small_session, out)


def test_perfect_reconstruction_scores_zero_error(perfect, gt):
    _, ev = perfect
    F, P = gt.n_frames, len(gt.worker_ids)
    m = ev["matching"]
    assert m["mapping"] == {"worker_1": "w1", "worker_2": "w2"}
    assert m["identity_switches"] == 0 and m["identity_switches_sustained"] == 0
    assert m["unmatched_tracked_workers"] == []
    # Positions are stored as float32 in the tracks table: errors below 1e-6 m, 0.00 mm when rounded.
    for source in ("final", "raw"):
        e = ev["errors_3d"][source]
        assert e["mpjpe_mm"] == 0.0
        assert e["by_region"]["all"]["points"] == F * P * 33
        assert sum(e["by_region"][r]["points"] for r in REGIONS) == F * P * 33
        assert all(e["by_region"][r]["mean_mm"] in (0.0, None) for r in REGIONS)
        assert all(j["p95_mm"] == 0.0 for j in e["by_joint"].values())
    d = ev["detection"]
    assert d["detection_rate_pct"] == 100.0 and d["tracked_rows_triangulated_unmatched"] == 0
    assert d["all_worker_frames"]["rate_pct"] == 100.0
    assert d["followed_all_worker_frames"]["rate_pct"] == 100.0 and d["tracked_rows_with_a_position_unmatched"] == 0


def test_perfect_reconstruction_limbs_angles_and_scores(perfect):
    _, ev = perfect
    limbs = ev["limbs"]
    assert limbs["error"]["rmse_mm"] == 0.0 and limbs["frequency_pct"] == 100.0
    for name, row in limbs["by_limb"].items():
        # the measured spread is exactly the body model's own (the trunk sides follow the shoulders)
        assert row["cv_pct"]["all"] == pytest.approx(row["true_cv_pct"], abs=1e-3), name
    assert limbs["cv_mean_rigid_pct"] == 0.0
    assert "left_trunk_side" not in limbs["rigid_limbs"] and "left_forearm" in limbs["rigid_limbs"]

    angles = ev["angles"]
    assert angles["rows_compared"] == 360
    assert len(angles["by_angle"]) >= 16
    for name, row in angles["by_angle"].items():
        # angles re-derived from float32 positions, written with 2 decimals: within 0.01 degree
        assert row["n"] == 360 and row["missing"] == 0, name
        assert row["rmse_deg"] < 0.01, name

    scores = ev["scores"]
    for c in ("rula_grand", "rula_action_level", "reba_score", "reba_risk_level"):
        s = scores[c]
        assert s["pairs"] == 360 and s["missing_tracked"] == 0
        truth_categories = np.count_nonzero(np.sum(s["confusion_matrix"]["counts"], axis=0))
        assert truth_categories >= 2, c  # otherwise kappa is undefined and the test could not fail
        # Away from band edges a perfect reconstruction agrees exactly.
        assert s["off_edge"]["exact_agreement_pct"] == 100.0, c
        assert s["off_edge"]["kappa"] == 1.0 and s["off_edge"]["kappa_linear"] == 1.0, c
        # The simulator builds some postures exactly on a limit (walking arm swing of 20.000 deg):
        # there 1e-7 rad of float32 storage decides the band. Few frames, never more than one step.
        assert s["truth_on_band_edge"] <= 0.1 * s["pairs"], c
        assert s["within_one_pct"] == 100.0, c
        assert s["exact_agreement_pct"] >= 100.0 * (1 - s["truth_on_band_edge"] / s["pairs"]), c
    assert scores["rula_grand"]["kappa"] == 1.0 and scores["rula_action_level"]["exact_agreement_pct"] == 100.0
    # Errors of 0.005 degree at most (the CSV's 2 decimals), moved in time, leave the scores exact
    # but on band edges.
    for c in ("rula_grand", "reba_score"):
        s = scores[c]
        assert s["expected_exact_agreement_pct"] >= 100.0 * (1 - s["truth_on_band_edge"] / s["pairs"]), c


def test_reference_bar_table(perfect):
    _, ev = perfect
    bar = ev["bar"]
    assert [b["name"] for b in bar["bars"]] == ["bar_central", "bar_outer", "bar_edge"]
    assert [b["region"] for b in bar["bars"]] == ["central", "outer", "edge"]
    for b in bar["bars"]:
        assert b["noiseless_length_m"] == pytest.approx(1.5, abs=1e-6)  # calibration = truth
    assert bar["calibration_vs_truth_px"] == 0.0
    regions = {r["region"]: r for r in bar["regions"]}
    assert all(regions[r]["n"] == DRAWS for r in REGIONS)
    # Noise of 0.5 px: a longer lever in the outer rings, so the spread grows outward
    assert regions["central"]["std_m"] < regions["edge"]["std_m"]
    assert abs(regions["central"]["error_pct"]) < 1.0
    assert "central" in bar["table"] and "Region" in bar["table"]
    assert ev["lens_regions"]["used_limits_deg"] == [30.0, 60.0]


def test_order_of_tracked_identities_does_not_matter(small_session, gt, tmp_path):
    out = write_results(small_session, tmp_path / "out", ground_truth_tracks(gt, worker_order=[1, 0]))
    ev = _evaluate(small_session, out)
    assert ev["matching"]["mapping"] == {"worker_1": "w2", "worker_2": "w1"}
    assert ev["errors_3d"]["mpjpe_mm"] == 0.0
    assert ev["angles"]["rmse_all_deg"] < 0.01
    assert ev["scores"]["rula_grand"]["off_edge"]["kappa"] == 1.0


@pytest.mark.slow
def test_names_given_by_stature_are_checked_and_their_task_factors_used(small_session, gt, tmp_path):
    # naming by stature is off by default: switch it on in a copy of the session
    import shutil

    small_session = shutil.copytree(small_session, tmp_path / "session")
    settings = small_session / "settings.toml"
    settings.write_text(settings.read_text() + "\n[identification]\nby_stature = true\n")
    statures = {w["id"]: w["stature_m"] for w in gt.scene["workers"]}
    # worker_1 is w2 and worker_2 is w1; the stored stature estimates name them correctly ...
    tracks = ground_truth_tracks(gt, worker_order=[1, 0])
    out = write_results(
        small_session, tmp_path / "right", tracks, statures={"worker_1": statures["w2"], "worker_2": statures["w1"]}
    )
    assert sorted(p.name for p in (out / "csv").iterdir()) == ["w1_steps.csv", "w2_steps.csv"]
    ev = _evaluate(small_session, out)
    m = ev["matching"]
    assert m["reported_as"] == {"worker_1": "w2", "worker_2": "w1"}
    assert m["reported_workers"] == ["w1", "w2"]
    assert m["named_by_stature"]["correct_pct"] == 100.0 and m["named_by_stature"]["rows"] == 2 * gt.n_frames
    # the true scores use the named workers' loads, exactly as the pipeline did: full agreement
    assert ev["scores"]["rula_grand"]["off_edge"]["exact_agreement_pct"] == 100.0
    assert ev["scores"]["task_factor_note"] == ""
    # ... and swapped estimates name them wrongly: every named row is the other person
    out = write_results(
        small_session, tmp_path / "wrong", tracks, statures={"worker_1": statures["w1"], "worker_2": statures["w2"]}
    )
    ev = _evaluate(small_session, out)
    assert ev["matching"]["named_by_stature"]["correct_pct"] == 0.0
    assert ev["errors_3d"]["mpjpe_mm"] == 0.0  # the geometry is still exact


def test_detection_per_camera_region_counts_the_workers_under_one_camera(small_session, gt, perfect, tmp_path):
    from ergopose.geometry.regions import DEFAULT_LIMITS_DEG
    from ergopose.keypoints import JOINT_INDEX

    _, ev = perfect
    d = ev["detection"]
    both = d["visible_in_both_cameras"]["worker_frames"]
    for camera in ("cam_1", "cam_2"):
        per = d["by_camera_region"][camera]
        assert sum(per[r]["worker_frames"] for r in REGIONS) == both
        assert all(per[r]["rate_pct"] in (100.0, None) or per[r]["worker_frames"] == 0 for r in REGIONS)
    # Nothing triangulated while a worker's hips are within the central limit of cam_1.
    tf = ground_truth_tracks(gt)
    hips = [JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]
    theta_cam1 = np.degrees(gt.theta[:, 0][..., hips].astype(np.float64).mean(axis=-1))  # (F, P)
    central = theta_cam1[tf.frame, tf.worker - 1] < DEFAULT_LIMITS_DEG[0]
    assert central.any() and not central.all()
    raw = tf.raw_points_world.copy()
    raw[central] = np.nan
    out = write_results(small_session, tmp_path / "out", dataclasses.replace(tf, raw_points_world=raw))
    per = _evaluate(small_session, out)["detection"]["by_camera_region"]
    assert per["cam_1"]["central"]["worker_frames"] > 0 and per["cam_1"]["central"]["rate_pct"] == 0.0
    assert per["cam_1"]["outer"]["rate_pct"] == 100.0
    assert 0.0 < per["cam_2"]["outer"]["rate_pct"] < 100.0  # under cam_1 is cam_2's outer region


def test_identity_switch_is_counted_and_shows_in_the_errors(small_session, gt, tmp_path):
    tf = ground_truth_tracks(gt)
    half = gt.n_frames // 2
    swap = tf.frame >= half
    points = tf.points_world.copy()
    # after `half` the two tracked identities exchange people: worker 1 follows w2 and vice versa
    points[swap] = gt.joints_world[tf.frame[swap], 2 - tf.worker[swap]]
    angles = np.degrees(np.nanmax(gt.theta.astype(np.float64), axis=1))[
        tf.frame, np.where(swap, 2 - tf.worker, tf.worker - 1)
    ]
    switched = dataclasses.replace(tf, points_world=points, raw_points_world=points.copy(), lens_angle_deg=angles)
    out = write_results(small_session, tmp_path / "out", switched)
    ev = _evaluate(small_session, out)
    m = ev["matching"]
    assert m["identity_switches"] == 2  # each simulated worker changes id once
    assert m["identity_switches_sustained"] == 2  # and keeps the new one for half the session
    # the ids' majority partners: a tie of half and half each, so both rows sets of one half are "wrong"
    assert m["rows_matched"] == 2 * gt.n_frames
    assert m["rows_matched_to_another_worker_than_the_mapping"] == pytest.approx(gt.n_frames, abs=2)
    # each simulated worker's rows: half on one id, half on the other
    split = m["rows_by_id_per_ground_truth_worker"]
    assert sorted(split) == sorted(gt.worker_ids)
    for ids in split.values():
        assert sorted(ids) == ["worker_1", "worker_2"] and sum(ids.values()) == gt.n_frames
        assert abs(ids["worker_1"] - ids["worker_2"]) <= 2
    assert m["rows_on_the_workers_main_id_pct"] == pytest.approx(50.0, abs=0.2)
    assert ev["detection"]["detection_rate_pct"] == 100.0  # every person is still reconstructed
    # Frame by frame every row is matched to the right person: the geometry is exact ...
    assert ev["errors_3d"]["mpjpe_mm"] == 0.0
    for name, row in ev["angles"]["by_angle"].items():
        # shoulder elevation is measured against the track's median shoulder height, and the neck from
        # the trunk axis at that height, which a track made of two people shifts: the angles whose
        # values depend on the whole track
        # (measured: shoulder elevation 3.1 deg, neck flexion 1.0)
        bound = 5.0 if "shoulder_elevation" in name else 2.0 if name == "neck_flexion" else 0.01
        assert row["rmse_deg"] < bound, name
    # ... while a whole track attributed to one person is wrong for half the shift: metres
    true_distance = np.linalg.norm(gt.joints_world[half:, 0] - gt.joints_world[half:, 1], axis=-1).mean()
    by_id = ev["errors_3d"]["final"]["by_track_identity"]["all"]["mean_mm"]
    assert by_id == pytest.approx(1000 * true_distance / 2, rel=0.02)


def test_a_worker_split_over_two_ids_is_not_a_wrong_row(small_session, gt, tmp_path):
    """Worker 1's track ends half way and a new id (3) carries the same person on: one sustained
    switch and a worker on two ids, but no row in another worker's report."""
    tf = ground_truth_tracks(gt)
    half = gt.n_frames // 2
    worker = np.where((tf.worker == 1) & (tf.frame >= half), 3, tf.worker)
    out = write_results(small_session, tmp_path / "out", dataclasses.replace(tf, worker=worker))
    m = _evaluate(small_session, out)["matching"]
    assert m["identity_switches_sustained"] == 1
    assert m["rows_matched_to_another_worker_than_the_mapping"] == 0
    split = m["rows_by_id_per_ground_truth_worker"]
    first = gt.worker_ids[int(np.unique(tf.worker)[0]) - 1]
    assert split[first] == {"worker_3": gt.n_frames - half, "worker_1": half}
    assert m["rows_on_the_workers_main_id_pct"] == pytest.approx(
        100.0 * (2 * gt.n_frames - half) / (2 * gt.n_frames), abs=0.1
    )


def test_a_one_frame_flicker_is_a_switch_but_not_a_sustained_one(small_session, gt, tmp_path):
    tf = ground_truth_tracks(gt)
    flick = tf.frame == 90  # the two ids exchange people for one frame only
    points = tf.points_world.copy()
    points[flick] = gt.joints_world[90, 2 - tf.worker[flick]]
    out = write_results(
        small_session, tmp_path / "out", dataclasses.replace(tf, points_world=points, raw_points_world=points.copy())
    )
    m = _evaluate(small_session, out)["matching"]
    assert m["identity_switches"] == 4  # each person: to the other id and back
    assert m["identity_switches_sustained"] == 0 and m["sustained_min_frames"] == 12
    assert m["rows_matched_to_another_worker_than_the_mapping"] == 2
    # one frame of each worker on the other id
    assert m["rows_on_the_workers_main_id_pct"] == pytest.approx(100.0 * (2 * gt.n_frames - 2) / (2 * gt.n_frames))
    assert all(len(ids) == 2 and min(ids.values()) == 1 for ids in m["rows_by_id_per_ground_truth_worker"].values())


def test_known_offset_of_the_smoothed_positions(small_session, gt, tmp_path):
    tf = ground_truth_tracks(gt)
    shifted = dataclasses.replace(tf, points_world=tf.points_world + np.array([0.010, 0.0, 0.0]))
    out = write_results(small_session, tmp_path / "out", shifted)
    ev = _evaluate(small_session, out)
    assert ev["errors_3d"]["final"]["mpjpe_mm"] == pytest.approx(10.0, abs=0.01)
    assert ev["errors_3d"]["final"]["by_region"]["all"]["p95_mm"] == pytest.approx(10.0, abs=0.01)
    assert ev["errors_3d"]["raw"]["mpjpe_mm"] == 0.0
    assert ev["limbs"]["error"]["rmse_mm"] == 0.0  # a translation keeps every length
    assert ev["angles"]["rmse_all_deg"] < 0.01


def test_changes_to_the_frames_csv_are_measured(perfect, small_session, tmp_path):
    src, reference = perfect
    out = tmp_path / "out"
    shutil.copytree(src, out)
    path = out / "csv" / "worker_1_steps.csv"
    frames = pd.read_csv(path)
    n = len(frames)
    frames["trunk_flexion"] = frames["trunk_flexion"] + 3.0
    frames.loc[:9, "neck_flexion"] = np.nan
    grand = frames["rula_grand"].to_numpy().copy()
    changed = np.arange(0, n, 4)  # every 4th frame of worker_1 one grand score higher (capped at 7)
    grand[changed] = np.minimum(grand[changed] + 1, 7)
    really = int(np.sum(grand != frames["rula_grand"].to_numpy()))
    frames["rula_grand"] = grand
    frames.loc[:4, "reba_risk_level"] = np.nan
    frames.to_csv(path, index=False)
    ev = _evaluate(small_session, out)
    t = ev["angles"]["by_angle"]["trunk_flexion"]
    # worker_1 off by 3 degrees, worker_2 exact: RMSE = 3 / sqrt(2), bias 1.5
    assert t["rmse_deg"] == pytest.approx(3.0 / np.sqrt(2.0), abs=0.01)
    assert t["bias_deg"] == pytest.approx(1.5, abs=0.01)
    assert ev["angles"]["by_angle"]["neck_flexion"]["missing"] == 10
    g = ev["scores"]["rula_grand"]
    assert really > 10
    assert g["exact_agreement_pct"] == pytest.approx(100.0 * (2 * n - really) / (2 * n), abs=0.01)
    assert g["within_one_pct"] == 100.0
    assert g["kappa"] < g["kappa_linear"] < 1.0
    assert g["mean_difference"] == pytest.approx(really / (2 * n), abs=1e-3)
    r = ev["scores"]["reba_risk_level"]
    assert r["missing_tracked"] == 5 and r["pairs"] == reference["scores"]["reba_risk_level"]["pairs"] - 5


def test_missing_inputs_are_named(perfect, small_session, tmp_path):
    src, _ = perfect
    out = tmp_path / "out"
    shutil.copytree(src, out)
    (out / "csv" / "worker_2_steps.csv").unlink()
    with pytest.raises(InputError, match="worker_2_steps.csv"):
        _evaluate(small_session, out)
    with pytest.raises(InputError, match="tracks"):
        _evaluate(small_session, tmp_path / "nothing")
    plain = tmp_path / "plain"
    shutil.copytree(small_session, plain)
    shutil.rmtree(plain / "ground_truth")
    with pytest.raises(InputError, match="not a simulated session"):
        _evaluate(plain, src)


def test_angle_stats_say_how_well_the_reported_sds_cover_the_errors():
    d = np.array([1.0, -3.0, 0.5, 5.0, np.nan, 2.0])
    sd = np.array([2.0, 2.0, 1.0, 1.0, 1.0, 0.0])  # a missing difference, and a value from the settings (SD 0)
    r = angle_stats(d, sd)
    assert r["sd_rows"] == 4
    assert r["within_one_sd_pct"] == 50.0  # 1 <= 2 and 0.5 <= 1
    assert r["within_two_sd_pct"] == 75.0  # and 3 <= 4
    assert r["median_sd_deg"] == 1.5
    assert r["n"] == 5 and r["bias_deg"] == pytest.approx(1.1)
    assert "sd_rows" not in angle_stats(d)


def test_expected_agreement_is_that_of_the_truth_with_the_runs_angle_errors(perfect, small_session, gt, tmp_path):
    # worker_1's trunk flexion 25 degrees too high in every frame: the same error wherever it is moved
    # in time, so the expected agreement is that of the true posture with 25 degrees more trunk
    # flexion for that worker, scored here directly, and exact for the other.
    src, _ = perfect
    out = tmp_path / "out"
    shutil.copytree(src, out)
    path = out / "csv" / "worker_1_steps.csv"
    frames = pd.read_csv(path)
    frames["trunk_flexion"] = frames["trunk_flexion"] + 25.0
    frames.to_csv(path, index=False)
    ev = _evaluate(small_session, out)

    session = load_session(small_session, check_videos=False)
    p = gt.worker_ids.index("w1")
    posture = ground_truth_posture(gt, p)
    moved = posture.copy()
    moved["trunk_flexion"] = moved["trunk_flexion"] + np.radians(25.0)
    truth = ground_truth_scores(session, gt, p, "worker_1", scoring_settings(session), posture)
    bent = ground_truth_scores(session, gt, p, "worker_1", scoring_settings(session), moved)
    for c in ("rula_grand", "reba_score"):
        s = ev["scores"][c]
        same = int(np.sum(truth[c].to_numpy() == bent[c].to_numpy()))
        assert same < 0.9 * len(truth), c  # the error changes the score: the test can fail
        # worker_2 is exact but on band edges (at most truth_on_band_edge frames)
        expected = 100.0 * (same + s["pairs"] - len(truth)) / s["pairs"]
        assert s["expected_exact_agreement_pct"] == pytest.approx(
            expected, abs=100.0 * s["truth_on_band_edge"] / s["pairs"] + 0.01
        ), c
        # with the trunk exact nothing is left but band edges; with the knees exact, the trunk's cost stays
        parts = s["expected_exact_agreement_with_exact_part_pct"]
        assert parts["trunk"] >= 100.0 * (1 - s["truth_on_band_edge"] / s["pairs"]), c
        assert parts["knees"] == s["expected_exact_agreement_pct"], c
        # the scores in the CSV were left as they were: what was measured is still exact
        assert s["exact_agreement_pct"] > s["expected_exact_agreement_pct"], c


def test_followed_counts_final_positions_and_detection_the_triangulated_ones(small_session, gt, tmp_path):
    # worker_1 not triangulated in every third frame (its final position kept, as the body model
    # carries it), worker_2's final position 3 m up (near nobody) in every fifth frame.
    tf = ground_truth_tracks(gt)
    raw, final = tf.raw_points_world.copy(), tf.points_world.copy()
    untriangulated = (tf.worker == 1) & (tf.frame % 3 == 0)
    astray = (tf.worker == 2) & (tf.frame % 5 == 0)
    raw[untriangulated] = np.nan
    final[astray] += np.array([0.0, 0.0, 3.0])
    out = write_results(
        small_session, tmp_path / "out", dataclasses.replace(tf, raw_points_world=raw, points_world=final)
    )
    d = _evaluate(small_session, out)["detection"]
    n = gt.n_frames * len(gt.worker_ids)
    assert d["all_worker_frames"]["reconstructed"] == n - int(untriangulated.sum())
    assert d["followed_all_worker_frames"]["reconstructed"] == n - int(astray.sum())
    assert d["tracked_rows_with_a_position"] == n
    assert d["tracked_rows_with_a_position_unmatched"] == int(astray.sum())
    # 3 m above the worker is more than 1 m from everyone: each is a false person
    nn = d["rows_near_nobody"]
    assert nn["far_from_every_worker"] == nn["false_people"] == int(astray.sum()) > 0
    assert nn["second_row_on_a_followed_worker"] == nn["misplaced_rows_of_a_worker"] == 0
    assert d["false_people_pct"] == pytest.approx(100.0 * astray.sum() / n, abs=0.01)
    assert d["tracked_rows_triangulated_unmatched"] == 0
    both = d["visible_in_both_cameras"]["worker_frames"]
    assert d["followed_in_both_cameras"]["worker_frames"] == both > 0
    assert sum(r["worker_frames"] for r in d["followed_by_region"].values()) == both


def test_time_shares_per_worker_and_level(perfect, small_session, gt, tmp_path):
    src, reference = perfect
    sh = reference["scores"]["time_shares"]["rula_action_level"]
    assert set(sh["by_worker"]) == {"w1", "w2"}
    for r in sh["by_worker"].values():
        assert r["measured_pct"] == r["true_pct"] and r["largest_difference_pp"] == 0.0
        assert sum(r["true_pct"]) == pytest.approx(100.0, abs=0.05)
    # worker_1's RULA action level one higher (capped at 4) in every other frame: its shares move
    # by exactly what was changed, worker_2's stay.
    out = tmp_path / "out"
    shutil.copytree(src, out)
    path = out / "csv" / "worker_1_steps.csv"
    frames = pd.read_csv(path)
    level = frames["rula_action_level"].to_numpy().copy()
    before = [100.0 * np.mean(level == v) for v in (1, 2, 3, 4)]
    level[::2] = np.minimum(level[::2] + 1, 4)
    after = [100.0 * np.mean(level == v) for v in (1, 2, 3, 4)]
    assert max(abs(a - b) for a, b in zip(after, before)) > 5.0  # the change shows: the test can fail
    frames["rula_action_level"] = level
    frames.to_csv(path, index=False)
    sh = _evaluate(small_session, out)["scores"]["time_shares"]["rula_action_level"]
    w1 = sh["by_worker"]["w1"]
    assert w1["measured_pct"] == pytest.approx(after, abs=0.01)
    assert w1["true_pct"] == pytest.approx(before, abs=0.01)
    assert sh["by_worker"]["w2"]["largest_difference_pp"] == 0.0
    assert sh["largest_difference_pp"] == pytest.approx(max(abs(a - b) for a, b in zip(after, before)), abs=0.01)


def test_rows_near_nobody_are_told_apart_by_hand_counted_rows():
    """Two workers 3 m apart over 3 frames, and rows near nobody placed by hand: 0.7 m from worker
    A with no other row on A (misplaced), 0.6 m from A while another row follows A (a second row),
    1.5 m from A (far from everyone), 0.8 m above B while another row follows B (a second row)."""
    from ergopose.evaluation.matching import rows_near_nobody

    def body(x, y, z):
        return np.tile([x, y, z], (33, 1)).astype(float)

    truth = np.stack([np.stack([body(0, 0, 1), body(3, 0, 1)])] * 3)  # (3 frames, 2 workers, 33, 3)
    followed = np.array([[False, True], [True, True], [False, True]])
    rows = [
        (0, body(0.7, 0, 1), True),  # misplaced: A followed by nobody in frame 0
        (0, body(3, 0, 1), False),  # B's own row, matched
        (1, body(0, 0.6, 1), True),  # a second row: A is followed in frame 1
        (2, body(1.5, 0, 1), True),  # far: 1.5 m from A, 1.5 m from B
        (2, body(3, 0, 1.8), True),  # a second row on B
    ]
    frames = np.array([r[0] for r in rows])
    points = np.stack([r[1] for r in rows])
    near = np.array([r[2] for r in rows])
    out = rows_near_nobody(frames, points, truth, near, followed)
    assert out == {
        "rows": 4,
        "far_from_every_worker": 1,
        "second_row_on_a_followed_worker": 2,
        "misplaced_rows_of_a_worker": 1,
        "false_people": 3,
        "misplaced_distance_m": 1.0,
    }
    # No rows near nobody: nothing to tell apart.
    none = rows_near_nobody(frames, points, truth, np.zeros(len(rows), bool), followed)
    assert none["rows"] == none["false_people"] == 0
