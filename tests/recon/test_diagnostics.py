"""Limb-length diagnostics, lens regions and identity evaluation on hand-made tracks."""

from __future__ import annotations

import numpy as np

from ergopose.keypoints import JOINT_INDEX, LIMBS
from ergopose.recon import diagnostics as D
from ergopose.recon.pipeline import TrackFrames
from ergopose.recon.settings import ReconSettings

LS, LE = JOINT_INDEX["left_shoulder"], JOINT_INDEX["left_elbow"]


def _tracks(points, angle, worker=None):
    n = points.shape[0]
    worker = np.ones(n, np.int64) if worker is None else worker
    z = np.zeros((n, 33))
    return TrackFrames(
        worker=worker,
        frame=np.arange(n),
        time_s=np.arange(n) / 12.0,
        points_world=points,
        raw_points_world=points.copy(),
        confidence=z + 1,
        reprojection_error_px=z,
        views=np.full((n, 33), 2, np.int8),
        gap_filled=z.astype(bool),
        gated=z.astype(bool),
        smoothed=True,
        lens_angle_deg=angle,
    )


def test_lens_region_edges():
    r = D.lens_region([0.0, 29.999, 30.0, 59.9, 60.0, 89.0, np.nan], (30.0, 60.0))
    assert r.tolist() == [0, 0, 1, 1, 2, 2, -1]


def test_limb_statistics_known_answers():
    n = 10
    X = np.full((n, 33, 3), np.nan)
    X[:, LS] = [0.0, 0.0, 1.5]
    lengths = np.array([0.30, 0.31, 0.29, 0.30, 0.32, 0.28, 0.30, np.nan, np.nan, 0.30])
    X[:, LE] = X[:, LS] - np.c_[np.zeros(n), np.zeros(n), lengths]
    angle = np.full((n, 33), 20.0)
    angle[5:, LE] = 65.0  # the elbow is far out in the last five frames
    diag = D.limb_diagnostics(_tracks(X, angle), ReconSettings())
    assert len(diag) == 1 and diag[0].worker == "worker_1" and diag[0].frames == n
    s = diag[0].get("left_upper_arm")
    v = lengths[np.isfinite(lengths)]
    assert s.frames == 10 and s.reconstructed == 8 and np.isclose(s.frequency, 0.8)
    assert np.isclose(s.mean_m, v.mean()) and np.isclose(s.std_m, v.std()) and np.isclose(s.cv, v.std() / v.mean())
    assert np.allclose(s.percentiles_m, np.percentile(v, D.PERCENTILES), rtol=0, atol=D.LENGTH_BIN_M)
    c = diag[0].get("left_upper_arm", "central")
    e = diag[0].get("left_upper_arm", "edge")
    assert c.frames == 5 and c.reconstructed == 5 and np.isclose(c.mean_m, lengths[:5].mean())
    assert e.frames == 5 and e.reconstructed == 3 and np.isclose(e.frequency, 0.6)
    assert diag[0].get("left_upper_arm", "outer").frames == 0
    assert np.isnan(diag[0].get("left_upper_arm", "outer").frequency)
    never = diag[0].get("right_thigh")
    assert never.reconstructed == 0 and np.isnan(never.mean_m) and never.frequency == 0.0
    assert set(k[0] for k in diag[0].stats) == {n for n, _, _ in LIMBS}


def test_region_errors_known_answers():
    n = 4
    truth = np.zeros((n, 33, 3))
    X = truth.copy()
    X[:, :, 0] += 0.01
    X[2:, :, 0] += 0.02  # 3 cm off in the last two frames
    X[0, 0] = np.nan
    angle = np.full((n, 33), 10.0)
    angle[2:] = 70.0
    out = D.region_errors(_tracks(X, angle), {1: truth})
    assert out["central"].points == 65 and np.isclose(out["central"].mean_m, 0.01)
    assert out["edge"].points == 66 and np.isclose(out["edge"].mean_m, 0.03)
    assert out["outer"].points == 0 and np.isnan(out["outer"].mean_m)
    assert out["all"].points == 131


def test_identity_switch_count():
    """Two people on parallel lines; the tracker output swaps their ids half way: 2 switches."""
    n = 20
    truth = np.zeros((n, 2, 33, 3))
    truth[:, 0, :, 0] = np.linspace(0, 1, n)[:, None]
    truth[:, 1, :, 0] = np.linspace(0, 1, n)[:, None]
    truth[:, 1, :, 1] = 2.0
    pts = np.concatenate([truth[:, 0], truth[:, 1]])
    worker = np.r_[np.ones(n, np.int64), np.full(n, 2)]
    worker[10:20], worker[30:40] = 2, 1
    tf = _tracks(pts, np.zeros((2 * n, 33)), worker)
    tf = TrackFrames(**{**tf.__dict__, "frame": np.r_[np.arange(n), np.arange(n)]})
    assert D.identity_switches(tf, truth) == 2
    assert D.match_workers(tf, truth) in ({1: 0, 2: 1}, {1: 1, 2: 0})


def test_identity_switch_flicker_vs_sustained():
    n = 40
    truth = np.zeros((n, 2, 33, 3))
    truth[:, 1, :, 1] = 2.0
    pts = np.concatenate([truth[:, 0], truth[:, 1]])
    worker = np.r_[np.ones(n, np.int64), np.full(n, 2)]
    worker[[20, 20 + n]] = 2, 1  # one frame swapped: a flicker
    tf = _tracks(pts, np.zeros((2 * n, 33)), worker)
    tf = TrackFrames(**{**tf.__dict__, "frame": np.r_[np.arange(n), np.arange(n)]})
    assert D.identity_switches(tf, truth) == 4  # CLEAR-MOT: away and back, for both people
    assert D.identity_switches(tf, truth, min_frames=3) == 0


def test_statistics_in_chunks_equal_one_piece_and_percentiles_are_within_a_bin(rng):
    """A long shift fed in uneven chunks gives the diagnostics of one piece; percentiles stay within
    one 1 mm bin of numpy's, also for lengths beyond the histogram (a bad triangulation of 2.4 m)."""
    n = 5000
    X = np.full((n, 33, 3), np.nan)
    X[:, LS] = [0.0, 0.0, 1.5]
    lengths = rng.normal(0.30, 0.02, n)
    lengths[rng.random(n) < 0.1] = np.nan
    lengths[[7, 99]] = [2.4, 2.2]
    X[:, LE] = X[:, LS] - np.c_[np.zeros(n), np.zeros(n), lengths]
    angle = rng.uniform(0, 89, (n, 33))
    worker = np.where(np.arange(n) % 3 == 0, 2, 1).astype(np.int64)
    tracks = _tracks(X, angle, worker)
    whole = D.limb_diagnostics(tracks)
    acc = D.LimbStatsAccumulator()
    for a, b in [(0, 1), (1, 1000), (1000, 1001), (1001, 4321), (4321, n)]:
        sel = np.arange(a, b)
        acc.add(TrackFrames(**{k: (v[sel] if isinstance(v, np.ndarray) else v) for k, v in tracks.__dict__.items()}))
    pieces = acc.result()
    for d1, d2 in zip(whole, pieces):
        for key, s1 in d1.stats.items():
            s2 = d2.stats[key]
            assert (s1.frames, s1.reconstructed) == (s2.frames, s2.reconstructed)
            np.testing.assert_allclose(
                [s1.mean_m, s1.std_m, *s1.percentiles_m],
                [s2.mean_m, s2.std_m, *s2.percentiles_m],
                rtol=1e-9,
                atol=1e-12,
            )
    for d, w in zip(whole, (1, 2)):
        v = lengths[(worker == w) & np.isfinite(lengths)]
        s = d.get("left_upper_arm")
        assert s.reconstructed == v.size
        assert abs(s.mean_m - v.mean()) < 1e-12 and abs(s.std_m - v.std()) < 1e-12
        np.testing.assert_allclose(s.percentiles_m, np.percentile(v, D.PERCENTILES), rtol=0, atol=D.LENGTH_BIN_M)
        region = D.lens_region(np.fmax(angle[:, LS], angle[:, LE]))
        for k, name in enumerate(D.REGIONS):
            sel = (worker == w) & (region == k)
            vr = lengths[sel & np.isfinite(lengths)]
            sr = d.get("left_upper_arm", name)
            assert sr.frames == sel.sum() and sr.reconstructed == vr.size
            np.testing.assert_allclose(sr.percentiles_m, np.percentile(vr, D.PERCENTILES), rtol=0, atol=D.LENGTH_BIN_M)
    hist = np.zeros(D.LENGTH_BINS + 1, np.int64)
    hist[D.LENGTH_BINS] = 1  # one value in the overflow bin, the longest seen: 2.4 m
    assert np.isclose(D.histogram_percentiles(hist, (50,), overflow_max_m=2.4)[0], 2.2)  # placed mid-bin: 2.0-2.4
