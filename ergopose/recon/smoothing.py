"""Kalman filter and Rauch-Tung-Striebel smoother for every joint coordinate of every worker.

Model (per joint and world coordinate, independent): state x = (position, velocity) for
``constant_velocity`` or (position, velocity, acceleration) for ``constant_acceleration``,
frame interval dt = 1 / fps,

    x_k = F x_{k-1} + w,   w ~ N(0, Q)          z_k = x_k[0] + v,   v ~ N(0, r_k)

with F the constant-velocity (-acceleration) transition and Q filterpy's
``Q_discrete_white_noise(dim, dt, var)``: for constant velocity var = process_noise_m_s2^2 (a
white acceleration held over each frame); for constant acceleration var = (process_noise_m_s2
* process_noise_jerk_factor * dt)^2 (the change of acceleration per frame).

Measurement variance: per joint and coordinate, the diagonal of the triangulated point's
covariance from the geometry of its rays, the 2D noise model and the reprojection error
(:func:`ergopose.recon.triangulate.point_variance`; People3D.variance_world).

Filter, per coordinate series: the first measurement initialises x = (z, 0[, 0]) with P =
diag(r, INITIAL_VELOCITY_SIGMA^2[, INITIAL_ACCELERATION_SIGMA^2]); afterwards every frame is a
predict step followed by an update when there is a measurement (filterpy's KalmanFilter with
predict() / update(z, R=r), update(None) for a missing one). Outliers: a joint's measurement
whose Mahalanobis distance squared over its three coordinates, sum(y_c^2 / S_c) with innovation
y and innovation variance S = P_pred[0, 0] + r, exceeds ``outlier_gate_chi2`` is ignored; after
``max_gated_run`` ignored measurements in a row, the next measurement restarts the filter (the
motion was real). A gap of more than ``max_fill_gap_s`` between accepted measurements also
restarts it: the joint's track splits into independent segments.

Adaptive noise (``adaptive_noise``, constant velocity only): a bank of filters, one per pair of
``adaptive_process_noise_m_s2`` x ``adaptive_variance_scales``, runs beside the smoother on the
measurements it accepts and restarts where it restarts; each joint's innovation
log-likelihood per pair (summed over its coordinates, discounted with e-folding time
``adaptive_memory_s``) chooses the process noise and the factor on the measurement variance its
series use from the next frame on (``process_noise_m_s2`` and 1 until the joint has
``adaptive_min_s`` of measurements; a joint whose filter restarts forgets it all). The window
keeps each step's process noise, so the backward pass uses the model the forward pass used.
docs/reconstruction.md, section 4.

Smoother: the RTS backward pass (filterpy's ``rts_smoother``) within each segment,
``x_s[k] = x_f[k] + C_k (x_s[k+1] - F x_f[k])``, ``C_k = P_f[k] F^T (F P_f[k] F^T + Q)^-1``.
Output: the smoothed position where a measurement was accepted, and inside gaps of at most
``max_fill_gap_s`` between two accepted measurements (flagged gap_filled); NaN elsewhere (before
the first and after the last measurement of a segment, in longer gaps, at ignored outliers
that are not inside a short gap).

Vectorised: all series (workers x 33 joints x 3 coordinates) advance together, one Python step
per frame. For a whole shift in bounded memory, :class:`KalmanRTS` keeps the forward results
of a window of frames only; the backward pass for a block of frames starts a fixed lag after
the block's end (fixed-lag RTS). With block boundaries on a fixed frame grid the result does
not depend on how the shift is cut into chunks; docs/reconstruction.md measures how far it is
from the full-segment RTS (below a micrometre with the default 8 s lag).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from filterpy.common import Q_discrete_white_noise

from ergopose.arrays import BoolArray, FloatArray, IntArray
from ergopose.errors import InputError
from ergopose.recon.settings import ReconSettings

#: Standard deviation of the velocity (m/s) and acceleration (m/s^2) assumed at a series' first
#: measurement (a joint may be moving when first seen).
INITIAL_VELOCITY_SIGMA = 2.0
INITIAL_ACCELERATION_SIGMA = 10.0
#: "No accepted measurement yet" marker for frame indices.
_NEVER = np.iinfo(np.int64).min // 4
_FUTURE = np.iinfo(np.int64).max // 4


def motion_matrices(settings: ReconSettings, fps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(F, Q, P0 diagonal without the position entry) of the configured motion model at dt = 1/fps."""
    dt = 1.0 / fps
    if settings.motion_model == "constant_velocity":
        F = np.array([[1.0, dt], [0.0, 1.0]])
        Q = Q_discrete_white_noise(2, dt, settings.process_noise_m_s2**2)
        p0 = np.array([INITIAL_VELOCITY_SIGMA**2])
    else:
        F = np.array([[1.0, dt, 0.5 * dt * dt], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
        sd = settings.process_noise_m_s2 * settings.process_noise_jerk_factor * dt
        Q = Q_discrete_white_noise(3, dt, sd * sd)
        p0 = np.array([INITIAL_VELOCITY_SIGMA**2, INITIAL_ACCELERATION_SIGMA**2])
    return F, np.asarray(Q, dtype=np.float64), p0


@dataclass(frozen=True)
class Smoothed:
    """Smoother output for T frames and S series (series = worker x joint x coordinate).

    frame: (T,) int64 frame indices.
    value: (T, S) smoothed position (metres); NaN where not output (see module docstring).
    variance: (T, S) its smoothed variance (m^2); NaN where value is NaN.
    measured: (T, S) bool, an accepted measurement at this frame.
    gap_filled: (T, S) bool, no accepted measurement, value filled inside a short gap.
    gated: (T, S) bool, a measurement was ignored as an outlier.
    """

    frame: np.ndarray
    value: np.ndarray
    variance: np.ndarray
    measured: np.ndarray
    gap_filled: np.ndarray
    gated: np.ndarray


class KalmanRTS:
    """Kalman filter + fixed-lag RTS smoother over S series at once (see module docstring).

    ``series_per_joint`` consecutive series form one joint for the Mahalanobis gate (3: x, y, z).
    Feed frames with :meth:`forward` (consecutive frames, any number at a time) and take smoothed
    results with :meth:`smooth`. New series can be added at any time (:meth:`add_series`).
    """

    def __init__(
        self,
        n_series: int,
        fps: float,
        settings: ReconSettings | None = None,
        first_frame: int = 0,
        series_per_joint: int = 3,
    ) -> None:
        if n_series % series_per_joint:
            raise InputError(f"{n_series} series are not whole joints of {series_per_joint}", field="n_series")
        self.settings = settings or ReconSettings()
        self.fps = float(fps)
        self.F, self.Q, self._p0 = motion_matrices(self.settings, self.fps)
        self.n = self.F.shape[0]
        self.spj = series_per_joint
        self.max_gap = int(np.floor(self.settings.max_fill_gap_s * self.fps + 1e-9))
        self.gate = float(self.settings.outlier_gate_chi2)
        self.max_run = int(self.settings.max_gated_run)
        self.next_frame = int(first_frame)
        self.window_start = int(first_frame)
        self.S = 0
        # The adaptive noise (constant velocity only): a bank of G = |q| x |scale| filters per
        # series, each joint's log-likelihood per pair, and the pair each series uses.
        st = self.settings
        self.adaptive = bool(st.adaptive_noise) and self.n == 2
        self.q_bank = np.repeat(np.asarray(st.adaptive_process_noise_m_s2, float), len(st.adaptive_variance_scales))
        self.s_bank = np.tile(np.asarray(st.adaptive_variance_scales, float), len(st.adaptive_process_noise_m_s2))
        self.G = len(self.q_bank) if self.adaptive else 0
        self.decay = float(np.exp(-1.0 / (self.fps * st.adaptive_memory_s)))
        self.min_evidence = float(st.adaptive_min_s * self.fps)
        self.q_default = float(st.process_noise_m_s2)
        self._alloc_state(0)
        self._win: list[
            tuple[FloatArray, FloatArray, BoolArray, BoolArray, BoolArray, IntArray, FloatArray]
        ] = []  # per frame: (x_f, P_f, cont, acc, gated, prev_meas, process noise of the step into it)
        self.add_series(n_series)

    # --- state ------------------------------------------------------------------------------------

    def _alloc_state(self, s: int) -> None:
        n = self.n
        self.x = np.zeros((s, n))
        self.P = np.zeros((s, n, n))
        self.init = np.zeros(s, bool)
        self.last_meas = np.full(s, _NEVER, np.int64)
        self.run = np.zeros(s, np.int64)
        self.q = np.full(s, self.q_default)  # process noise each series uses (m/s^2)
        self.scale = np.ones(s)  # factor on each series' measurement variance
        G = self.G
        self.xb = np.zeros((s, G, 2))  # the bank: state, covariance (a, b, c), initialised
        self.Pb = np.zeros((s, G, 3))
        self.initb = np.zeros((s, G), bool)
        self.ll = np.zeros((s // self.spj, G))  # per joint and pair: discounted log-likelihood
        self.evidence = np.zeros(s // self.spj)  # discounted number of frames measured

    def _forget(self, joints: np.ndarray) -> None:
        """Joints whose filters restart (after a gap longer than max_fill_gap_s, or a run of gated
        measurements) forget what the adaptive noise learnt of them: their evidence and noise go
        back to the defaults, as for a new series. A smoother slot given to another worker has
        only such series, so reusing it gives the results a new slot would."""
        series = (joints[:, None] * self.spj + np.arange(self.spj)).ravel()
        self.q[series] = self.q_default
        self.scale[series] = 1.0
        self.initb[series] = False
        self.ll[joints] = 0.0
        self.evidence[joints] = 0.0

    def add_series(self, k: int) -> None:
        """Add k series (uninitialised; whole joints) at the end."""
        if k % self.spj:
            raise InputError(f"{k} series are not whole joints of {self.spj}", field="n_series")
        if k == 0:
            return
        n = self.n
        self.x = np.concatenate([self.x, np.zeros((k, n))])
        self.P = np.concatenate([self.P, np.zeros((k, n, n))])
        self.init = np.concatenate([self.init, np.zeros(k, bool)])
        self.last_meas = np.concatenate([self.last_meas, np.full(k, _NEVER, np.int64)])
        self.run = np.concatenate([self.run, np.zeros(k, np.int64)])
        self.q = np.concatenate([self.q, np.full(k, self.q_default)])
        self.scale = np.concatenate([self.scale, np.ones(k)])
        G = self.G
        self.xb = np.concatenate([self.xb, np.zeros((k, G, 2))])
        self.Pb = np.concatenate([self.Pb, np.zeros((k, G, 3))])
        self.initb = np.concatenate([self.initb, np.zeros((k, G), bool)])
        self.ll = np.concatenate([self.ll, np.zeros((k // self.spj, G))])
        self.evidence = np.concatenate([self.evidence, np.zeros(k // self.spj)])
        self._win = [
            (
                np.concatenate([xf, np.full((k, n), np.nan)]),
                np.concatenate([Pf, np.full((k, n, n), np.nan)]),
                np.concatenate([c, np.zeros(k, bool)]),
                np.concatenate([a, np.zeros(k, bool)]),
                np.concatenate([g, np.zeros(k, bool)]),
                np.concatenate([pm, np.full(k, _NEVER, np.int64)]),
                np.concatenate([qw, np.full(k, self.q_default)]),
            )
            for xf, Pf, c, a, g, pm, qw in self._win
        ]
        self.S += k

    # --- forward ----------------------------------------------------------------------------------

    def forward(self, z: np.ndarray, var: np.ndarray) -> None:
        """Filter T consecutive frames starting at ``next_frame``.

        z: (T, S) measured positions (NaN = none); var: (T, S) their variances (m^2).
        """
        z = np.asarray(z, dtype=np.float64)
        var = np.asarray(var, dtype=np.float64)
        if z.ndim != 2 or z.shape[1] != self.S or var.shape != z.shape:
            raise InputError(f"expected z and var of shape (T, {self.S}), got {z.shape} and {var.shape}", field="z")
        F, Q = self.F, self.Q
        FT = F.T
        n, spj = self.n, self.spj
        gate, max_gap, max_run = self.gate, self.max_gap, self.max_run
        p0 = self._p0
        cv = n == 2
        dt = F[0, 1]
        q00, q01, q11 = Q[0, 0], Q[0, 1], Q[1, 1]
        q_used = np.full(self.S, self.q_default)
        for t in range(z.shape[0]):
            k = self.next_frame
            zk, rk = z[t], var[t]
            has = np.isfinite(zk) & np.isfinite(rk) & (rk > 0)
            init = self.init
            if self.adaptive:
                restart = has & init & (((k - self.last_meas - 1) > max_gap) | (self.run >= max_run))
                if restart.any():
                    self._forget(np.unique(np.flatnonzero(restart) // spj))
                # This frame's step with each series' chosen pair (chosen on the frames before).
                q_used = self.q.copy()
                q00, q01, q11 = _cv_q(dt, q_used)
                rk = rk * self.scale
            # Predict the initialised series.
            if cv:  # the same arithmetic written out for 2 x 2 (several times faster)
                x = np.empty_like(self.x)
                x[:, 0] = self.x[:, 0] + dt * self.x[:, 1]
                x[:, 1] = self.x[:, 1]
                P = np.empty_like(self.P)
                ap, bp, cp = _cv_predict(self.P[:, 0, 0], self.P[:, 0, 1], self.P[:, 1, 1], dt, (q00, q01, q11))
                P[:, 0, 0] = ap
                P[:, 0, 1] = bp
                P[:, 1, 0] = bp
                P[:, 1, 1] = cp
            else:
                x = self.x @ FT
                P = F @ self.P @ FT + Q
            cont = init.copy()
            # Restart where the gap since the last accepted measurement is too long.
            gap_ok = (k - self.last_meas - 1) <= max_gap
            fresh = has & (~init | ~gap_ok | (self.run >= max_run))
            upd = has & ~fresh
            gated_now = np.zeros(self.S, bool)
            if upd.any():
                S_inn = P[:, 0, 0] + np.where(upd, rk, 1.0)
                y = np.where(upd, zk - x[:, 0], 0.0)
                if gate > 0:
                    d2 = (y * y / S_inn).reshape(-1, spj).sum(axis=1)
                    joint_has = upd.reshape(-1, spj).all(axis=1)
                    bad = np.repeat(joint_has & (d2 > gate), spj)
                    gated_now = upd & bad
                    upd = upd & ~bad
                if upd.any():
                    K = P[:, :, 0] / S_inn[:, None]  # (S, n)
                    K[~upd] = 0.0
                    x += K * y[:, None]
                    if cv:
                        a, b = P[:, 0, 0], P[:, 0, 1]
                        k0, k1 = K[:, 0], K[:, 1]
                        P[:, 1, 1] -= k1 * b
                        P[:, 0, 1] = b - k0 * b
                        P[:, 1, 0] = P[:, 0, 1]
                        P[:, 0, 0] = a - k0 * a
                    else:
                        P = P - K[:, :, None] * (S_inn[:, None, None] * K[:, None, :])
            if fresh.any():
                x[fresh] = 0.0
                x[fresh, 0] = zk[fresh]
                P[fresh] = 0.0
                P[fresh, 0, 0] = rk[fresh]
                for i in range(1, n):
                    P[fresh, i, i] = p0[i - 1]
                cont &= ~fresh
            acc = upd | fresh
            # Series that never had a measurement stay uninitialised (NaN state).
            newinit = init | fresh
            x[~newinit] = np.nan
            P[~newinit] = np.nan
            self.x, self.P, self.init = x, P, newinit
            self.last_meas = np.where(acc, k, np.where(fresh | newinit, self.last_meas, _NEVER))
            self.run = np.where(acc, 0, self.run + gated_now)
            self._win.append((x, P, cont, acc, gated_now, self.last_meas.copy(), q_used))
            if self.adaptive:
                self._bank_step(z[t], var[t], upd, fresh, dt)
            self.next_frame = k + 1

    def _bank_step(self, zk: np.ndarray, rk: np.ndarray, upd: np.ndarray, fresh: np.ndarray, dt: float) -> None:
        """Advance the bank of filters by one frame and choose each joint's pair for the next.

        Every bank filter of a series takes the measurements the smoother accepted (``upd``) and
        restarts where it restarted (``fresh``); a joint's log-likelihood per pair is the sum over
        its coordinates of -(log(2 pi S) + y^2 / S) / 2, innovation y, innovation variance S."""
        G, spj = self.G, self.spj
        x0 = self.xb[..., 0] + dt * self.xb[..., 1]
        x1 = self.xb[..., 1]
        ap, bp, cp = _cv_predict(self.Pb[..., 0], self.Pb[..., 1], self.Pb[..., 2], dt, _cv_q(dt, self.q_bank))
        r = rk[:, None] * self.s_bank[None, :]
        use = upd[:, None] & self.initb
        S_inn = np.where(use, ap + r, 1.0)
        y = np.where(use, zk[:, None] - x0, 0.0)
        ll = np.where(use, -0.5 * (np.log(2.0 * np.pi * S_inn) + y * y / S_inn), 0.0)
        k0, k1 = np.where(use, ap / S_inn, 0.0), np.where(use, bp / S_inn, 0.0)
        x0 = x0 + k0 * y
        x1 = x1 + k1 * y
        a_new = ap - k0 * ap
        b_new = bp - k0 * bp
        c_new = cp - k1 * bp
        start = fresh[:, None] | (upd[:, None] & ~self.initb)
        x0 = np.where(start, zk[:, None], x0)
        x1 = np.where(start, 0.0, x1)
        a_new = np.where(start, r, a_new)
        b_new = np.where(start, 0.0, b_new)
        c_new = np.where(start, INITIAL_VELOCITY_SIGMA**2, c_new)
        self.xb = np.stack([x0, x1], axis=-1)
        self.Pb = np.stack([a_new, b_new, c_new], axis=-1)
        self.initb = self.initb | start
        joint_ll = ll.reshape(-1, spj, G).sum(axis=1)
        measured = np.any(np.all(use.reshape(-1, spj, G), axis=1), axis=1)  # joints that gave evidence
        self.ll = self.ll * self.decay + joint_ll
        self.evidence = self.evidence * self.decay + measured
        best = np.argmax(self.ll, axis=1)
        # (the discounted count of n frames is (1 - decay^n) / (1 - decay): at most half its ceiling)
        ready = self.evidence >= min(self.min_evidence, 0.5 / (1.0 - self.decay))
        q = np.where(ready, self.q_bank[best], self.q_default)
        sc = np.where(ready, self.s_bank[best], 1.0)
        self.q = np.repeat(q, spj)
        self.scale = np.repeat(sc, spj)

    # --- backward ---------------------------------------------------------------------------------

    def smooth(self, stop: int | None = None) -> Smoothed:
        """Smoothed results for frames window_start <= f < stop (default: every filtered frame),
        using every frame filtered so far; those frames then leave the window."""
        end = self.next_frame
        stop = end if stop is None else int(stop)
        if not self.window_start <= stop <= end:
            raise InputError(f"can smooth up to frame {end}, asked for {stop}", field="stop")
        T = stop - self.window_start
        W = len(self._win)
        S, n = self.S, self.n
        F, Q = self.F, self.Q
        FT = F.T
        value = np.full((T, S), np.nan)
        variance = np.full((T, S), np.nan)
        measured = np.zeros((T, S), bool)
        filled = np.zeros((T, S), bool)
        gated = np.zeros((T, S), bool)
        if W == 0:
            return Smoothed(np.arange(self.window_start, stop), value, variance, measured, filled, gated)
        xs, Ps = self._win[-1][0], self._win[-1][1]
        next_meas = np.where(self._win[-1][3], end - 1, _FUTURE)
        max_gap = self.max_gap
        for w in range(W - 1, -1, -1):
            xf, Pf, cont, acc, g, prev, _ = self._win[w]
            k = self.window_start + w
            if w < W - 1:
                cont_next = self._win[w + 1][2]
                if n == 2:
                    q_next = _cv_q(F[0, 1], self._win[w + 1][6]) if self.adaptive else (Q[0, 0], Q[0, 1], Q[1, 1])
                    x_new, P_new = _rts_step_cv(xf, Pf, xs, Ps, F[0, 1], q_next)
                else:
                    Pp = F @ Pf @ FT + Q
                    C = Pf @ FT @ np.linalg.inv(Pp)
                    dx = xs - xf @ FT
                    x_new = xf + np.einsum("sij,sj->si", C, dx)
                    P_new = Pf + C @ (Ps - Pp) @ np.swapaxes(C, -1, -2)
                xs = np.where(cont_next[:, None], x_new, xf)
                Ps = np.where(cont_next[:, None, None], P_new, Pf)
                next_meas = np.where(cont_next, next_meas, _FUTURE)
                next_meas = np.where(acc, k, next_meas)
            if w < T:
                inner = ~acc & (prev > _NEVER) & (next_meas < _FUTURE) & (next_meas - prev - 1 <= max_gap)
                out = acc | inner
                value[w] = np.where(out, xs[:, 0], np.nan)
                variance[w] = np.where(out, Ps[:, 0, 0], np.nan)
                measured[w] = acc
                filled[w] = inner
                gated[w] = g
        self._win = self._win[T:]
        self.window_start = stop
        return Smoothed(np.arange(stop - T, stop), value, variance, measured, filled, gated)


def _cv_q(dt: float, q: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Q00, Q01, Q11) of the constant-velocity model's process noise for white acceleration of
    standard deviation q (m/s^2, an array or a number): filterpy's Q_discrete_white_noise(2, dt, q^2)."""
    v = np.asarray(q, dtype=np.float64) ** 2
    return 0.25 * dt**4 * v, 0.5 * dt**3 * v, dt**2 * v


def _cv_predict(
    a: np.ndarray, b: np.ndarray, c: np.ndarray, dt: float, Q: tuple[np.ndarray | float, ...]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The constant-velocity prediction F P F^T + Q of covariances P = [[a, b], [b, c]] (any
    shapes that broadcast with Q = (Q00, Q01, Q11)), written out: (P00, P01, P11)."""
    q00, q01, q11 = Q
    bp = b + dt * c + q01
    return a + dt * (b + bp - q01) + q00, bp, c + q11


def _rts_step_cv(
    xf: np.ndarray,
    Pf: np.ndarray,
    xs: np.ndarray,
    Ps: np.ndarray,
    dt: float,
    Q: tuple[np.ndarray | float, np.ndarray | float, np.ndarray | float],
) -> tuple[np.ndarray, np.ndarray]:
    """One RTS backward step for 2-state (constant velocity) series, written out per entry.

    Q: (Q00, Q01, Q11) of the step from this frame to the next (numbers, or one per series).
    Returns x_f + C (x_s - F x_f) and P_f + C (P_s - P_pred) C^T with C = P_f F^T P_pred^-1.
    """
    a, b, c = Pf[:, 0, 0], Pf[:, 0, 1], Pf[:, 1, 1]
    ap, bp, cp = _cv_predict(a, b, c, dt, Q)
    det = ap * cp - bp * bp
    # M = P_f F^T
    m00, m01 = a + dt * b, b
    m10, m11 = b + dt * c, c
    c00 = (m00 * cp - m01 * bp) / det
    c01 = (m01 * ap - m00 * bp) / det
    c10 = (m10 * cp - m11 * bp) / det
    c11 = (m11 * ap - m10 * bp) / det
    dx0 = xs[:, 0] - (xf[:, 0] + dt * xf[:, 1])
    dx1 = xs[:, 1] - xf[:, 1]
    x = np.empty_like(xf)
    x[:, 0] = xf[:, 0] + c00 * dx0 + c01 * dx1
    x[:, 1] = xf[:, 1] + c10 * dx0 + c11 * dx1
    d00 = Ps[:, 0, 0] - ap
    d01 = Ps[:, 0, 1] - bp
    d11 = Ps[:, 1, 1] - cp
    # C D C^T for symmetric D
    e00 = c00 * d00 + c01 * d01
    e01 = c00 * d01 + c01 * d11
    e10 = c10 * d00 + c11 * d01
    e11 = c10 * d01 + c11 * d11
    P = np.empty_like(Pf)
    P[:, 0, 0] = a + e00 * c00 + e01 * c01
    P[:, 0, 1] = b + e00 * c10 + e01 * c11
    P[:, 1, 0] = P[:, 0, 1]
    P[:, 1, 1] = c + e10 * c10 + e11 * c11
    return x, P


def smooth_series(
    z: np.ndarray, var: np.ndarray, fps: float, settings: ReconSettings | None = None, series_per_joint: int = 3
) -> Smoothed:
    """Filter and smooth whole series at once (full-segment RTS): z, var (T, S)."""
    z = np.asarray(z, dtype=np.float64)
    if z.ndim != 2:
        raise InputError(f"expected (T, S) series, got {z.shape}", field="z")
    with np.errstate(invalid="ignore"):
        k = KalmanRTS(z.shape[1], fps, settings, series_per_joint=series_per_joint)
        k.forward(z, var)
        return k.smooth()
