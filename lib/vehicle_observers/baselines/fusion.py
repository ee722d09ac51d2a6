"""Interval-constrained Kalman filter: the adaptive EKF kept inside an interval observer's bounds.

At every sample, after the Kalman update of :mod:`.adaptive`, the Gaussian posterior
``N(x, P)`` is truncated to the interval observer's enclosure ``lo_k <= v_y <= hi_k`` (the
``vy_lo_mps`` / ``vy_hi_mps`` columns of the registered ``interval-coordinates`` estimator,
:mod:`vehicle_observers.observers.interval_coordinates`): density-function truncation (Simon &
Simon, "Constrained Kalman filtering via density function truncation for turbofan engine
health estimation", Int. J. Syst. Sci. 41(2), 2010, Sec. 3). With ``mu = x_0``,
``s = sqrt(P_00)``, ``a = (lo - mu)/s``, ``b = (hi - mu)/s``, ``Z = Phi(b) - Phi(a)``:

    mu' = mu + s (phi(a) - phi(b)) / Z
    s'^2 = s^2 [1 + (a phi(a) - b phi(b)) / Z - ((phi(a) - phi(b)) / Z)^2]

and the other states follow through their covariance with ``v_y`` (the Gaussian conditional
on the scalar constraint): ``x' = x + P[:, 0] (mu' - mu) / P_00``,
``P' = P - P[:, 0] P[0, :] (1 - s'^2 / s^2) / P_00``. The truncated posterior is the prior of
the next step (the bounds enter the filter, not only its output). A bound pair that is
``NaN`` or reversed leaves the step unconstrained. ``margin`` [m/s] widens the bounds on both
sides (0: the enclosure as given).

When the enclosure holds (the interval observer's assumptions hold), the truncated estimate
is never outside it and its variance never larger; when the enclosure is violated
(mismatched stiffness box) the filter is pulled towards the wrong interval: the leaderboard
reports both.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit

from vehicle_observers.baselines import adaptive as AD
from vehicle_observers.core.protocol import Trajectory


@njit(cache=True)
def _phi(x):
    return math.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi)


@njit(cache=True)
def _Phi(x):
    return 0.5 * (1.0 + math.erf(x / math.sqrt(2.0)))


@njit(cache=True)
def truncate_moments(mu, s, lo, hi):
    """Mean and std of ``N(mu, s^2)`` truncated to ``[lo, hi]`` (module docstring); far
    outside (``Z`` below 1e-12) the estimate is put on the nearer bound with zero spread."""
    a, b = (lo - mu) / s, (hi - mu) / s
    Z = _Phi(b) - _Phi(a)
    if Z < 1e-12:
        return (lo, 0.0) if mu < lo else (hi, 0.0)
    pa, pb = _phi(a), _phi(b)
    d = (pa - pb) / Z
    v = 1.0 + (a * pa - b * pb) / Z - d * d
    return mu + s * d, s * math.sqrt(max(v, 0.0))


@njit(cache=True)
def _truncate(x, Pm, lo, hi):
    """Apply the truncation to ``x`` (6,), ``Pm`` (6, 6) in place."""
    if not (lo <= hi) or Pm[0, 0] <= 0.0:
        return
    s = math.sqrt(Pm[0, 0])
    mu2, s2 = truncate_moments(x[0], s, lo, hi)
    c = (mu2 - x[0]) / Pm[0, 0]
    f = (1.0 - (s2 * s2) / Pm[0, 0]) / Pm[0, 0]
    col = np.empty(6)
    for i in range(6):
        col[i] = Pm[i, 0]
    for i in range(6):
        x[i] += col[i] * c
    for i in range(6):
        for j in range(6):
            Pm[i, j] -= col[i] * col[j] * f


@njit(cache=True)
def _run_fused(t, vx, delta, yr, ay, use_ay, P, th, x0, P0, lo, hi):
    """:func:`.adaptive._run` with :func:`_truncate` after every update. Returns X, Pd."""
    N = t.shape[0]
    X = np.empty((N, 6))
    Pd = np.empty((N, 6))
    W = np.empty((4, 6, 6))
    V = np.empty((5, 6))
    out = np.empty(4)
    x = x0.copy()
    Pm = np.zeros((6, 6))
    for i in range(6):
        Pm[i, i] = P0[i]
    for k in range(N):
        if k > 0:
            AD._predict(x, Pm, delta[k - 1], vx[k - 1], ay[k - 1], t[k] - t[k - 1], P, th,
                        W, V)
        AD._update(x, Pm, delta[k], vx[k], yr[k], ay[k], use_ay, P, th, W, V, out)
        _truncate(x, Pm, lo[k], hi[k])
        for i in range(6):
            X[k, i] = x[i]
            Pd[k, i] = Pm[i, i]
    return X, Pd


def truncate_np(x, Pm, lo, hi):
    """Readable numpy twin of :func:`_truncate` (returns new arrays)."""
    from scipy.stats import norm

    x, Pm = np.array(x, float), np.array(Pm, float)
    if not (lo <= hi) or Pm[0, 0] <= 0:
        return x, Pm
    s = np.sqrt(Pm[0, 0])
    a, b = (lo - x[0]) / s, (hi - x[0]) / s
    Z = norm.cdf(b) - norm.cdf(a)
    if Z < 1e-12:
        mu2, s2 = (lo, 0.0) if x[0] < lo else (hi, 0.0)
    else:
        d = (norm.pdf(a) - norm.pdf(b)) / Z
        mu2 = x[0] + s * d
        s2 = s * np.sqrt(max(1 + (a * norm.pdf(a) - b * norm.pdf(b)) / Z - d * d, 0.0))
    col = Pm[:, 0].copy()
    return x + col * (mu2 - x[0]) / Pm[0, 0], \
        Pm - np.outer(col, col) * (1 - s2**2 / Pm[0, 0]) / Pm[0, 0]


class IntervalFusedEKF(AD.AdaptiveEKF):
    """:class:`.adaptive.AdaptiveEKF` truncated to ``[lo, hi]`` of ``v_y`` at every sample.
    Inputs ``[v_x, delta, vy_lo, vy_hi]`` (the interval observer's bounds are inputs: the
    observer that produces them is causal), outputs ``[r, a_y]``."""

    input_names = ("vx_mps", "delta_roadwheel_rad", "vy_lo_mps", "vy_hi_mps")

    def __init__(self, *a, margin: float = 0.0, **kw):
        super().__init__(*a, **kw)
        self.margin = float(margin)

    def initial_state(self, t, u, y, x0=None):
        z = super().initial_state(t, u, y, x0)
        x, Pm = truncate_np(z[:6], z[6:].reshape(6, 6), u[0, 2] - self.margin,
                            u[0, 3] + self.margin)
        return np.r_[x, Pm.ravel()]

    def step(self, z, k, t, u, y):
        z = super().step(z, k, t, u, y)
        x, Pm = truncate_np(z[:6], z[6:].reshape(6, 6), u[k, 2] - self.margin,
                            u[k, 3] + self.margin)
        return np.r_[x, Pm.ravel()]

    def run(self, t, u, y, x0=None) -> Trajectory:
        t, u, y, x0 = self.check_data(t, u, y, x0)
        res = self.filter_fused(t, u[:, 0], u[:, 1], y[:, 0], y[:, 1], u[:, 2], u[:, 3], x0)
        return Trajectory(t, res["X"], self.state_names, seconds=res["seconds"],
                          estimator="fusion-interval", info={"std": np.sqrt(res["Pd"])})

    def filter_fused(self, t, vx, delta, yr, ay, lo, hi, x0=None) -> dict:
        x0 = np.array([0.0, yr[0], 0.0, 0.0, 1.0, 1.0]) if x0 is None else np.asarray(x0, float)
        P0 = AD.initial_covariance(self.terms, vx[0], self.tuning.rel)
        ay = np.zeros_like(yr) if ay is None else ay
        args = [np.ascontiguousarray(a, float) for a in (t, vx, delta, yr, ay)]
        lo = np.ascontiguousarray(lo, float) - self.margin
        hi = np.ascontiguousarray(hi, float) + self.margin
        t0 = time.perf_counter()
        X, Pd = _run_fused(*args, self.use_ay, self.P, self.th, x0, P0, lo, hi)
        return {"X": X, "Pd": Pd, "seconds": time.perf_counter() - t0}
