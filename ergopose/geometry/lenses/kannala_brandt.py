"""Kannala-Brandt fisheye (the model of OpenCV's cv2.fisheye), extended past 90 degrees.

    theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)
    pixel   = (cx + fx theta_d x / r, cy + fy theta_d y / r),   r = sqrt(x^2 + y^2)

The parameters mean exactly what cv2.fisheye's K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] and
D = (k1, k2, k3, k4) mean (skew alpha = 0), and for rays in front of the camera the pixels are
the same. The difference: theta = atan2(r, z) here, so rays at and beyond 90 degrees off-axis
project too (cv2.fisheye divides by z first and cannot).

Domain: ``max_theta`` is the first angle in (0, pi] where theta_d stops increasing (where its
derivative 1 + 3 k1 theta^2 + 5 k2 theta^4 + 7 k3 theta^6 + 9 k4 theta^8 reaches zero), capped
at pi. Up to there every radius has exactly one angle; rays beyond project to NaN and pixels
whose normalised radius exceeds theta_d(max_theta) unproject to NaN.

Unprojection inverts theta_d(theta) = r_d in two stages, both vectorised: a starting value
from a table of the inverse (linear interpolation, nodes uniform in sqrt(1 - r_d / r_d_max)
so that the square-root cusp of the inverse at max_theta is resolved), then one Newton
step for every pixel. Its size d bounds the new residual |theta_d(theta) - r_d| by
max|theta_d''| d^2 / 2 (Taylor), which proves convergence to :data:`RESIDUAL_TOL` without
evaluating the polynomial again. The pixels without that proof (only next to max_theta, where
the derivative vanishes) continue alone, with their residual evaluated, for up to
:data:`MAX_EXTRA_STEPS` steps; a pixel still above the tolerance becomes NaN, never a wrong ray.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.errors import ConfigError
from ergopose.geometry.lenses._radial import RadialLens

#: At most this many further steps, only for the pixels still above RESIDUAL_TOL (near
#: max_theta Newton converges linearly, halving the angle error per step).
MAX_EXTRA_STEPS = 40
#: Largest accepted |theta_d(theta) - r_d| in normalised units (times f ~ 300 -> 3e-9 px).
RESIDUAL_TOL = 1e-11
#: Intervals of the inverse table (nodes uniform in sqrt(1 - r_d / r_d(max_theta))).
TABLE_SIZE = 8192


@dataclass(frozen=True)
class KannalaBrandt(RadialLens):
    """Kannala-Brandt / cv2.fisheye model: fx, fy, cx, cy in pixels, k1..k4 dimensionless."""

    fx: float
    fy: float
    cx: float
    cy: float
    k1: float = 0.0
    k2: float = 0.0
    k3: float = 0.0
    k4: float = 0.0

    kind: ClassVar[str] = "kannala_brandt"

    _max_theta: float = field(init=False, repr=False, compare=False)
    _rd_max: float = field(init=False, repr=False, compare=False)
    _table_theta: np.ndarray = field(init=False, repr=False, compare=False)
    _table_slope: np.ndarray = field(init=False, repr=False, compare=False)
    _step_tol2: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self._coerce_parameters()
        self._check_intrinsics()
        max_theta = _first_turning_point(self.k1, self.k2, self.k3, self.k4)
        rd_max = float(self._poly(np.array([max_theta]))[0])
        if not rd_max > 0:
            raise ConfigError(f"k1..k4 = {self.coefficients} give no valid field of view", field="lens.k1")
        object.__setattr__(self, "_max_theta", max_theta)
        object.__setattr__(self, "_rd_max", rd_max)
        # Inverse table: theta at TABLE_SIZE + 1 nodes uniform in w = sqrt(1 - r_d / r_d_max),
        # found by bisection on the increasing polynomial (once per lens). In w the inverse is
        # smooth even at max_theta, where theta(r_d) itself has a square-root cusp.
        w_nodes = np.linspace(0.0, 1.0, TABLE_SIZE + 1)
        rd_nodes = rd_max * (1.0 - w_nodes * w_nodes)
        lo = np.zeros_like(rd_nodes)
        hi = np.full_like(rd_nodes, max_theta)
        for _ in range(64):
            mid = 0.5 * (lo + hi)
            below = self._poly(mid) < rd_nodes
            lo = np.where(below, mid, lo)
            hi = np.where(below, hi, mid)
        theta_nodes = 0.5 * (lo + hi)
        theta_nodes[0], theta_nodes[-1] = max_theta, 0.0
        object.__setattr__(self, "_table_theta", theta_nodes)
        object.__setattr__(self, "_table_slope", np.append(np.diff(theta_nodes), 0.0))
        # After a Newton step of size d from theta, the new residual is f''(xi) d^2 / 2 for
        # some xi in between (Taylor): with M >= max |f''| on [0, max_theta], d^2 <= 2 tol / M
        # proves convergence without evaluating the polynomial again.
        grid = np.linspace(0.0, max_theta, 20001)
        curvature = np.abs(
            grid * (6 * self.k1 + grid**2 * (20 * self.k2 + grid**2 * (42 * self.k3 + grid**2 * 72 * self.k4)))
        )
        bound = 1.25 * float(curvature.max()) + 1e-300  # margin for the grid's sampling
        object.__setattr__(self, "_step_tol2", 2.0 * RESIDUAL_TOL / bound)

    # --- OpenCV interchange ---------------------------------------------------------------------

    @classmethod
    def from_opencv(cls, K: Any, D: Any) -> "KannalaBrandt":
        """From cv2.fisheye's camera matrix K (3x3, zero skew) and distortion D (4 values)."""
        K = np.asarray(K, dtype=np.float64)
        D = np.asarray(D, dtype=np.float64).ravel()
        if K.shape != (3, 3):
            raise ConfigError(f"expected a 3x3 camera matrix, got shape {K.shape}", field="K")
        if D.shape != (4,):
            raise ConfigError(f"expected 4 fisheye distortion coefficients k1..k4, got {D.size}", field="D")
        if not np.allclose(K[2], [0, 0, 1]) or K[1, 0] != 0:
            raise ConfigError(f"the last row must be (0, 0, 1) and K[1,0] zero, got {K.tolist()}", field="K")
        if abs(K[0, 1]) > 1e-9 * abs(K[0, 0]):
            raise ConfigError(f"skew K[0,1] = {K[0, 1]} is not supported (cv2.fisheye alpha must be 0)", field="K")
        return cls(K[0, 0], K[1, 1], K[0, 2], K[1, 2], *D)

    def to_opencv(self) -> tuple[np.ndarray, np.ndarray]:
        """(K 3x3, D shape (4, 1)) for cv2.fisheye functions."""
        K = np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])
        return K, np.array(self.coefficients).reshape(4, 1)

    @property
    def coefficients(self) -> tuple[float, float, float, float]:
        return (self.k1, self.k2, self.k3, self.k4)

    # --- the model ------------------------------------------------------------------------------

    @property
    def max_theta(self) -> float:
        return self._max_theta

    @property
    def rd_max(self) -> float:
        return self._rd_max

    def _poly(self, theta: np.ndarray) -> FloatArray:
        t2 = theta * theta
        out: FloatArray = t2 * self.k4
        out += self.k3
        out *= t2
        out += self.k2
        out *= t2
        out += self.k1
        out *= t2
        out += 1.0
        out *= theta
        return out

    def _rd_of_theta(self, theta: np.ndarray) -> np.ndarray:
        out = self._poly(theta)
        if self._max_theta < math.pi:
            out[theta > self._max_theta] = np.nan
        return out

    def _newton(self, theta: np.ndarray, rd: np.ndarray, steps: int) -> np.ndarray:
        """Up to ``steps`` Newton steps on theta_d(theta) = rd, in place; returns |residual| of
        the final theta. Stops early once every residual is within :data:`RESIDUAL_TOL` (each
        step computes its starting point's residual anyway)."""
        k1, k2, k3, k4 = self.coefficients
        d1, d2, d3, d4 = 3.0 * k1, 5.0 * k2, 7.0 * k3, 9.0 * k4
        t2 = np.empty_like(theta)
        f = np.empty_like(theta)
        df = np.empty_like(theta)
        for step in range(steps + 1):
            np.multiply(theta, theta, out=t2)
            np.multiply(t2, k4, out=f)
            f += k3
            f *= t2
            f += k2
            f *= t2
            f += k1
            f *= t2
            f += 1.0
            f *= theta
            f -= rd
            np.abs(f, out=df)
            # NaN radii (outside the image circle) are excluded from the stopping test.
            if step == steps or not (np.nanmax(df, initial=0.0) > RESIDUAL_TOL):
                return df
            np.multiply(t2, d4, out=df)
            df += d3
            df *= t2
            df += d2
            df *= t2
            df += d1
            df *= t2
            df += 1.0
            # df > 0 inside the domain; where it vanishes (at max_theta) the step is skipped.
            np.divide(f, df, out=f, where=df > 1e-300)
            f[df <= 1e-300] = 0.0
            theta -= f
            np.clip(theta, 0.0, self._max_theta, out=theta)
        raise AssertionError("unreachable")

    def _theta_of_rd(self, rd: np.ndarray) -> np.ndarray:
        # Start: linear interpolation in the inverse table over w = sqrt(1 - rd / rd_max).
        # Radii beyond rd_max (and NaN) use node 0 here and are blanked at the end.
        s = rd * (-1.0 / self._rd_max)
        s += 1.0
        np.fmax(s, 0.0, out=s)
        np.sqrt(s, out=s)
        s *= TABLE_SIZE
        index = s.astype(np.intp)
        s -= index
        theta = self._table_slope.take(index)
        theta *= s
        theta += self._table_theta.take(index)
        # One Newton step for every pixel; its size proves convergence (see _step_tol2).
        k1, k2, k3, k4 = self.coefficients
        t2 = theta * theta
        f = t2 * k4
        f += k3
        f *= t2
        f += k2
        f *= t2
        f += k1
        f *= t2
        f += 1.0
        f *= theta
        f -= rd
        df = t2 * (9.0 * k4)
        df += 7.0 * k3
        df *= t2
        df += 5.0 * k2
        df *= t2
        df += 3.0 * k1
        df *= t2
        df += 1.0
        f /= df  # the step; df > 0 inside the domain (inf/NaN where it vanishes: not converged)
        theta -= f
        np.multiply(f, f, out=df)
        bad = ~(df <= self._step_tol2)  # also NaN radii and steps that fail
        bad |= theta < 0.0
        bad |= theta > self._max_theta
        retry = bad & (rd <= self._rd_max)
        if retry.any():
            # The few stragglers (next to max_theta, where the derivative vanishes) continue
            # on their own, so one of them never slows down a whole block; their residual is
            # evaluated directly.
            where = np.flatnonzero(retry)
            sub_theta = np.clip(theta[where], 0.0, self._max_theta)
            sub_theta[~np.isfinite(sub_theta)] = self._max_theta
            sub_residual = self._newton(sub_theta, rd[where], MAX_EXTRA_STEPS)
            theta[where] = sub_theta
            bad[where] = ~(sub_residual <= RESIDUAL_TOL)
        # Unconverged, beyond the image of max_theta, or NaN input: no ray.
        theta[bad] = np.nan
        return theta


def _first_turning_point(k1: float, k2: float, k3: float, k4: float) -> float:
    """Smallest theta in (0, pi] where d theta_d / d theta = 0, or pi if there is none.

    With u = theta^2 the derivative is the quartic 1 + 3 k1 u + 5 k2 u^2 + 7 k3 u^3 + 9 k4 u^4.
    """
    coeffs = np.array([9.0 * k4, 7.0 * k3, 5.0 * k2, 3.0 * k1, 1.0])
    nonzero = np.flatnonzero(coeffs)
    coeffs = coeffs[nonzero[0] :]
    limit = math.pi
    if coeffs.size > 1:
        for root in np.roots(coeffs):
            if abs(root.imag) <= 1e-9 * max(1.0, abs(root)) and root.real > 0:
                limit = min(limit, math.sqrt(root.real))
    # Confirm on a fine grid (guards against a root np.roots misjudged as complex).
    theta = np.linspace(0.0, limit, 4097)
    u = theta * theta
    slope = (((9.0 * k4 * u + 7.0 * k3) * u + 5.0 * k2) * u + 3.0 * k1) * u + 1.0
    nonpositive = np.flatnonzero(slope <= 0)
    if nonpositive.size and nonpositive[0] < theta.size - 1:
        limit = float(theta[max(nonpositive[0] - 1, 1)])
    return float(limit)
