"""The vectorised Kalman filter + RTS smoother against filterpy, gating, gaps, fixed lag."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from ergopose.recon.settings import ReconSettings
from ergopose.recon.smoothing import (
    INITIAL_ACCELERATION_SIGMA,
    INITIAL_VELOCITY_SIGMA,
    KalmanRTS,
    motion_matrices,
    smooth_series,
)

FPS = 12.0


def _filterpy_reference(z: np.ndarray, var: np.ndarray, settings: ReconSettings):
    """filterpy's KalmanFilter (predict/update per frame, update(None) when missing) and
    rts_smoother on one series from its first measurement; returns (x_s, P_s) positions."""
    F, Q, _ = motion_matrices(settings, FPS)
    n = F.shape[0]
    idx = np.flatnonzero(np.isfinite(z))
    t0 = idx[0]
    kf = KalmanFilter(dim_x=n, dim_z=1)
    kf.F, kf.Q = F, Q
    kf.H = np.zeros((1, n))
    kf.H[0, 0] = 1.0
    kf.x = np.zeros((n, 1))
    kf.x[0, 0] = z[t0]
    p0 = [var[t0], INITIAL_VELOCITY_SIGMA**2, INITIAL_ACCELERATION_SIGMA**2][:n]
    kf.P = np.diag(p0)
    xs, Ps = [kf.x.copy()], [kf.P.copy()]
    for t in range(t0 + 1, len(z)):
        kf.predict()
        kf.update(None if np.isnan(z[t]) else z[t], R=var[t])
        xs.append(kf.x.copy())
        Ps.append(kf.P.copy())
    x_s, P_s, _, _ = kf.rts_smoother(np.array(xs), np.array(Ps))
    return t0, idx[-1], x_s[:, 0, 0], P_s[:, 0, 0]


@pytest.mark.parametrize("model", ["constant_velocity", "constant_acceleration"])
def test_equals_filterpy_kalman_and_rts(model, rng):
    # the fixed model (adaptive_noise chooses among such filters; tested below)
    settings = ReconSettings(motion_model=model, outlier_gate_chi2=0.0, max_fill_gap_s=100.0, adaptive_noise=False)
    T, S = 240, 12
    truth = np.cumsum(np.cumsum(rng.normal(0, 0.01, (T, S)), axis=0), axis=0)
    var = rng.uniform(1e-4, 9e-4, (T, S))
    z = truth + rng.normal(size=(T, S)) * np.sqrt(var)
    z[rng.random((T, S)) < 0.25] = np.nan
    z[:7, 2] = np.nan  # series starting late
    z[200:, 5] = np.nan  # and ending early
    res = smooth_series(z, var, FPS, settings)
    for s in range(S):
        t0, t1, ref_x, ref_P = _filterpy_reference(z[:, s], var[:, s], settings)
        assert np.allclose(res.value[t0 : t1 + 1, s], ref_x[: t1 - t0 + 1], rtol=0, atol=1e-10)
        assert np.allclose(res.variance[t0 : t1 + 1, s], ref_P[: t1 - t0 + 1], rtol=1e-9, atol=1e-14)
        # Before the first and after the last measurement nothing is output.
        assert np.all(np.isnan(res.value[:t0, s])) and np.all(np.isnan(res.value[t1 + 1 :, s]))
        assert np.array_equal(res.measured[:, s], np.isfinite(z[:, s]))


def test_gaps_filled_up_to_the_limit_only():
    settings = ReconSettings(max_fill_gap_s=0.5, outlier_gate_chi2=0.0)  # 6 frames at 12 fps
    T = 80
    t = np.arange(T) / FPS
    z = np.tile((0.5 * t)[:, None], (1, 3))
    var = np.full((T, 3), 1e-6)
    z[10:16] = np.nan  # 6 missing frames: filled
    z[30:37] = np.nan  # 7 missing frames: a gap, the series restarts after it
    res = smooth_series(z, var, FPS, settings)
    assert res.gap_filled[10:16].all() and np.isfinite(res.value[10:16]).all()
    assert np.allclose(res.value[10:16, 0], 0.5 * t[10:16], atol=1e-4)  # straight line bridged
    assert not res.gap_filled[30:37].any() and np.isnan(res.value[30:37]).all()
    assert np.isfinite(res.value[37:]).all()


def test_outliers_are_gated_and_long_runs_restart(rng):
    settings = ReconSettings(outlier_gate_chi2=16.27, max_gated_run=3)
    T = 120
    truth = np.tile(np.linspace(0, 1, T)[:, None], (1, 3))
    var = np.full((T, 3), 0.01**2)
    z = truth + rng.normal(0, 0.01, (T, 3))
    z[40] += 0.5  # one wild point (all three coordinates of the joint)
    z[70:] += 0.4  # a real jump: the person moved
    res = smooth_series(z, var, FPS, settings)
    assert res.gated[40].all() and not res.measured[40].any()
    assert abs(res.value[40, 0] - truth[40, 0]) < 0.03  # bridged by its neighbours, not pulled by 0.5 m
    ungated = smooth_series(z, var, FPS, settings.replace(outlier_gate_chi2=0.0))
    assert abs(ungated.value[40, 0] - truth[40, 0]) > 0.1
    # The jump: three frames ignored, then the filter restarts on the new level.
    assert res.gated[70:73].all() and res.measured[73].all()
    assert np.allclose(res.value[80:, 0], truth[80:, 0] + 0.4, atol=0.03)


@pytest.mark.slow
def test_fixed_lag_matches_full_smoother_and_chunking(rng):
    settings = ReconSettings()
    T, S = 900, 30
    truth = np.cumsum(np.cumsum(rng.normal(0, 0.005, (T, S)), axis=0), axis=0)
    var = rng.uniform(1e-4, 4e-4, (T, S))
    z = truth + rng.normal(size=(T, S)) * np.sqrt(var)
    z[rng.random((T, S)) < 0.1] = np.nan
    full = smooth_series(z, var, FPS, settings)
    lag = int(settings.smoother_lag_s * FPS)
    pieces = {}
    for cuts in ([0, 900], [0, 50, 51, 377, 900], [0, 300, 600, 900]):
        k = KalmanRTS(S, FPS, settings)
        out = []
        block = 128
        b0 = 0
        for a, b in zip(cuts[:-1], cuts[1:]):
            k.forward(z[a:b], var[a:b])
            while b0 + block + lag <= k.next_frame:
                out.append(k.smooth(b0 + block).value)
                b0 += block
        out.append(k.smooth().value)
        pieces[tuple(cuts)] = np.concatenate(out)
    first = pieces[(0, 900)]
    for v in pieces.values():
        assert np.array_equal(v, first, equal_nan=True)  # chunking changes nothing
    assert np.nanmax(np.abs(first - full.value)) < 1e-6  # fixed lag ~ full RTS
    assert np.array_equal(np.isnan(first), np.isnan(full.value))


def test_smoothing_reduces_error(rng):
    T, S = 600, 3
    t = np.arange(T) / FPS
    truth = np.stack([np.sin(t), np.cos(0.7 * t), 0.3 * np.sin(2 * t)], axis=1)
    var = np.full((T, S), 0.03**2)
    z = truth + rng.normal(0, 0.03, (T, S))
    res = smooth_series(z, var, FPS, ReconSettings())
    raw = np.sqrt(np.mean((z - truth) ** 2))
    sm = np.sqrt(np.mean((res.value - truth) ** 2))
    assert sm < 0.5 * raw


def _cv_track(rng, q_m_s2: float, T: int, S: int) -> np.ndarray:
    """Positions of S series moved by white acceleration of SD q held over each frame."""
    dt = 1.0 / FPS
    a = rng.normal(0.0, q_m_s2, (T, S))
    v = np.cumsum(a * dt, axis=0)
    return np.cumsum(v * dt - 0.5 * a * dt * dt, axis=0)


def _log_likelihood(z: np.ndarray, r: np.ndarray, q: float) -> float:
    """Innovation log-likelihood of one series under the constant-velocity filter, written out
    per frame in plain Python (the reference for the bank): starts at the first measurement with
    position variance r and velocity variance INITIAL_VELOCITY_SIGMA^2."""
    from ergopose.recon.smoothing import INITIAL_VELOCITY_SIGMA

    dt = 1.0 / FPS
    x = v = a = b = c = None
    total = 0.0
    for zk, rk in zip(z, r):
        if x is not None:  # predict
            x, v = x + dt * v, v
            a, b, c = (
                a + 2 * dt * b + dt * dt * c + dt**4 / 4 * q * q,
                b + dt * c + dt**3 / 2 * q * q,
                c + dt * dt * q * q,
            )
        if not np.isfinite(zk):
            continue
        if x is None:
            x, v, a, b, c = zk, 0.0, rk, 0.0, INITIAL_VELOCITY_SIGMA**2
            continue
        s_inn = a + rk
        y = zk - x
        total += -0.5 * (np.log(2 * np.pi * s_inn) + y * y / s_inn)
        k0, k1 = a / s_inn, b / s_inn
        x, v = x + k0 * y, v + k1 * y
        a, b, c = a - k0 * a, b - k0 * b, c - k1 * b
    return total


def test_adaptive_bank_likelihood_equals_a_plain_filter(rng):
    T = 300
    truth = _cv_track(rng, 4.0, T, 3)
    var = rng.uniform(0.5e-4, 2e-4, (T, 3))
    z = truth + rng.normal(size=(T, 3)) * np.sqrt(2.0 * var)
    z[rng.random(T) < 0.1] = np.nan  # whole joints missing
    settings = ReconSettings(outlier_gate_chi2=0.0, max_fill_gap_s=100.0, adaptive_memory_s=1e9)
    k = KalmanRTS(3, FPS, settings)
    k.forward(z, var)
    for g in range(k.G):
        ref = sum(_log_likelihood(z[:, s], var[:, s] * k.s_bank[g], k.q_bank[g]) for s in range(3))
        assert k.ll[0, g] == pytest.approx(ref, rel=1e-6)  # (a memory of 1e9 s still forgets 3e-8)


@pytest.mark.parametrize(("q_true", "scale_true"), [(4.0, 2.0), (1.0, 1.0), (8.0, 4.0), (16.0, 1.0)])
def test_adaptive_noise_finds_the_motion_and_the_variance(rng, q_true, scale_true):
    """Series whose true process noise and measurement variance (a multiple of the one reported)
    are known: the bank chooses them, and the adaptive smoother is closer to the truth than the
    fixed one (process_noise_m_s2 = 2, the variance as reported)."""
    T, S = 1200, 3
    truth = _cv_track(rng, q_true, T, S)
    var = np.full((T, S), 0.01**2)
    z = truth + rng.normal(size=(T, S)) * np.sqrt(scale_true * var)
    settings = ReconSettings(outlier_gate_chi2=0.0)
    k = KalmanRTS(S, FPS, settings)
    k.forward(z, var)
    assert k.q[0] == q_true and k.scale[0] == scale_true
    adaptive = k.smooth().value
    fixed = smooth_series(z, var, FPS, settings.replace(adaptive_noise=False)).value
    assert np.sqrt(np.mean((adaptive - truth) ** 2)) < np.sqrt(np.mean((fixed - truth) ** 2))


def test_adaptive_noise_waits_for_evidence_and_forgets_when_the_filter_restarts(rng):
    T = 240  # 20 s at 12 fps
    truth = _cv_track(rng, 16.0, T, 3)
    var = np.full((T, 3), 1e-4)
    z = truth + rng.normal(size=(T, 3)) * 0.01
    z[120:130] = np.nan  # a gap longer than max_fill_gap_s (6 frames): the filter restarts at 130
    k = KalmanRTS(3, FPS, ReconSettings(outlier_gate_chi2=0.0, adaptive_min_s=5.0, max_fill_gap_s=0.5))
    k.forward(z[:59], var[:59])  # less than 5 s of measurements: the defaults
    assert k.q[0] == 2.0 and k.scale[0] == 1.0
    k.forward(z[59:120], var[59:120])
    assert k.q[0] == 16.0
    k.forward(z[120:131], var[120:131])  # restarted: everything learnt is forgotten
    assert k.q[0] == 2.0 and k.scale[0] == 1.0 and k.evidence[0] == 0.0
    k.forward(z[131:], var[131:])
    assert k.q[0] == 16.0
    # the second segment alone, in a new filter, gives the same smoothed positions
    alone = KalmanRTS(3, FPS, ReconSettings(outlier_gate_chi2=0.0, adaptive_min_s=5.0, max_fill_gap_s=0.5))
    alone.forward(z[130:], var[130:])
    assert np.array_equal(k.smooth().value[130:], alone.smooth().value)
