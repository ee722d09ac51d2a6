"""Generic filterpy EKF / UKF baseline for any continuous-time model (every observer is compared with it).

The lateral-dynamics baselines of :mod:`.baselines.kalman` are specialised (numba, exact RK4 Jacobian,
ML tuning). This module runs the *same textbook filters* on the models of the other papers
(autonomous bicycle, planar vehicle with wheel spin, fault-augmented lateral model), so every
observer of the repository is compared with an EKF/UKF on its own data.

Model (continuous time, ``f(x, u) -> dx/dt`` with ``x`` (n,), ``u`` (m,)), measurement
``y = h(x, u)`` (p,). Discretisation: one classical RK4 step per sample interval ``dt`` with
the input held at its sample-``k`` value (zero-order hold); the EKF transition matrix ``F_k``
is the Jacobian of that RK4 map (central differences with relative step ``1e-6`` unless the
caller passes ``jac``); ``H_k`` likewise. Process noise ``Q_k = Q dt`` (``Q``: continuous
intensity, (n, n)); measurement noise ``R`` (p, p). A measurement row with NaN skips the
update at that sample (multi-rate sensors).

Filter order per sample ``k``: update with ``y_k`` (posterior ``x_k|k`` is recorded), then
predict to ``k+1`` -- the convention of :func:`.baselines.kalman.ekf_filterpy`.

The UKF is ``filterpy.kalman.UnscentedKalmanFilter`` with Merwe scaled sigma points; its
covariance is re-symmetrised and eigen-floored after every predict and update
(:func:`.baselines.kalman.nearest_spd`), because filterpy's UKF can lose positive definiteness.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import Trajectory

Array = np.ndarray


@dataclass(frozen=True, eq=False)
class FilterRun(Trajectory):
    """A filterpy run: the :class:`~vehicle_observers.core.protocol.Trajectory` of the
    posterior means ``x`` (N, n) at ``t = k dt`` [s] (state names ``names`` given to the run,
    default ``x0 .. x{n-1}``), plus ``P_diag`` (N, n) the covariance diagonals; ``seconds``
    the wall time of the loop, ``info`` filter-specific details (e.g. ``spd_repairs``).
    ``name`` is ``estimator``."""

    P_diag: Array | None = None

    @property
    def name(self) -> str:
        return self.estimator


def _names(names, n) -> tuple[str, ...]:
    names = tuple(f"x{i}" for i in range(n)) if names is None else tuple(names)
    if len(names) != n:
        raise ObserverArgumentError(f"names must give the {n} states, got {names}")
    return names


def _result(name, dt, X, Pd, seconds, names, info=None) -> FilterRun:
    return FilterRun(dt * np.arange(len(X)), X, names, seconds=seconds, estimator=name,
                     info=dict(info or {}), P_diag=Pd)


def rk4_step(f: Callable, x: Array, u: Array, dt: float) -> Array:
    """One classical RK4 step of ``x' = f(x, u)`` with ``u`` held over ``dt``."""
    k1 = f(x, u)
    k2 = f(x + 0.5 * dt * k1, u)
    k3 = f(x + 0.5 * dt * k2, u)
    k4 = f(x + dt * k3, u)
    return x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def numerical_jacobian(fun: Callable, x: Array, rel: float = 1e-6) -> Array:
    """Central-difference Jacobian of ``fun`` (R^n -> R^p) at ``x``: (p, n)."""
    x = np.asarray(x, dtype=float)
    f0 = np.asarray(fun(x), dtype=float)
    J = np.empty((f0.size, x.size))
    for j in range(x.size):
        d = rel * max(1.0, abs(x[j]))
        xp, xm = x.copy(), x.copy()
        xp[j] += d
        xm[j] -= d
        J[:, j] = (np.asarray(fun(xp)) - np.asarray(fun(xm))) / (2.0 * d)
    return J


def _check(z, u, x0, P0, Q, R, dt):
    """Shapes and values of the run arguments (ObserverArgumentError naming the argument)."""
    if not (np.ndim(dt) == 0 and np.isfinite(dt) and dt > 0):
        raise ObserverArgumentError(f"dt (sample period) must be finite and > 0 s, got {dt!r}")
    z = np.asarray(z, dtype=float)
    if z.ndim == 1:  # one measurement channel: (N,) -> (N, 1)
        z = z[:, None]
    if z.ndim != 2:
        raise ObserverArgumentError(f"z must be (N, p) measurements (or (N,) for one channel), got {z.shape}")
    u = np.asarray(u, dtype=float)
    if u.ndim == 1:
        u = u[:, None]
    N = len(z)
    if len(u) != N:
        raise ObserverArgumentError(f"u has {len(u)} rows but z has {N} (one input row per measurement)")
    x0 = np.asarray(x0, dtype=float).ravel()
    if not np.all(np.isfinite(x0)):
        raise ObserverArgumentError(f"x0 must be finite, got {x0}")
    n, p = x0.size, z.shape[1]
    for name, M, k in (("P0", P0, n), ("Q", Q, n), ("R", R, p)):
        M = np.asarray(M, dtype=float)
        if M.shape != (k, k):
            raise ObserverArgumentError(f"{name} must be ({k}, {k}), got {M.shape}")
        scale = max(float(np.abs(M).max()), np.finfo(float).tiny)
        if np.abs(M - M.T).max() > 1e-12 * scale:
            raise ObserverArgumentError(f"{name} must be symmetric (max |{name} - {name}^T| = "
                                        f"{np.abs(M - M.T).max():.3g})")
        lam = float(np.linalg.eigvalsh(M).min())
        if lam < -1e-12 * scale:
            raise ObserverArgumentError(f"{name} must be positive semi-definite (smallest eigenvalue "
                                        f"{lam:.3g})")
    return z, u, x0, n, p


def run_ekf(f: Callable, h: Callable, z, u, dt: float, x0, P0, Q, R, *, jac: Callable | None = None,
            hjac: Callable | None = None, name: str = "EKF (filterpy)",
            names=None) -> FilterRun:
    """filterpy ``ExtendedKalmanFilter`` on ``x' = f(x, u)``, ``y = h(x, u)``.

    z (N, p) measurements (NaN row: no update), u (N, m) inputs, dt [s] sample period,
    x0 (n,), P0 (n, n), Q (n, n) continuous process-noise intensity, R (p, p).
    ``jac(x, u, dt) -> (x_next, F)`` and ``hjac(x, u) -> H`` override the numerical ones.
    ``names``: the state names of the returned :class:`FilterRun` (default ``x0 ..``).
    """
    from filterpy.kalman import ExtendedKalmanFilter

    z, u, x0, n, p = _check(z, u, x0, P0, Q, R, dt)
    names = _names(names, n)
    kf = ExtendedKalmanFilter(dim_x=n, dim_z=p)
    kf.x = x0.copy()
    kf.P = np.array(P0, dtype=float)
    kf.R = np.array(R, dtype=float)
    Qd = np.array(Q, dtype=float) * dt
    N = len(z)
    X = np.empty((N, n))
    Pd = np.empty((N, n))
    t0 = time.perf_counter()
    for k in range(N):
        uk = u[k]
        if np.all(np.isfinite(z[k])):
            Hf = (lambda x, uk=uk: hjac(x, uk)) if hjac else \
                (lambda x, uk=uk: numerical_jacobian(lambda s: h(s, uk), x))
            kf.update(z[k], Hf, lambda x, uk=uk: np.atleast_1d(h(x, uk)))
        X[k] = kf.x
        Pd[k] = np.diag(kf.P)
        if k + 1 < N:
            if jac is not None:
                xn, F = jac(kf.x, uk, dt)
            else:
                xn = rk4_step(f, kf.x, uk, dt)
                F = numerical_jacobian(lambda s: rk4_step(f, s, uk, dt), kf.x)
            kf.F = F
            kf.P = F @ kf.P @ F.T + Qd
            kf.x = xn
    return _result(name, dt, X, Pd, time.perf_counter() - t0, names)


def run_ukf(f: Callable, h: Callable, z, u, dt: float, x0, P0, Q, R, *, alpha: float = 0.1,
            beta: float = 2.0, kappa: float = 0.0, name: str = "UKF (filterpy)",
            names=None) -> FilterRun:
    """filterpy ``UnscentedKalmanFilter`` (Merwe points ``alpha, beta, kappa``) on the same
    RK4-discretised model; arguments as :func:`run_ekf`. ``info['spd_repairs']`` counts the
    covariance repairs (:func:`.baselines.kalman.nearest_spd`)."""
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    from vehicle_observers.baselines.kalman import nearest_spd

    z, u, x0, n, p = _check(z, u, x0, P0, Q, R, dt)
    names = _names(names, n)
    cur = {"u": u[0]}
    pts = MerweScaledSigmaPoints(n, alpha=alpha, beta=beta, kappa=kappa)
    kf = UnscentedKalmanFilter(dim_x=n, dim_z=p, dt=dt, points=pts,
                               fx=lambda x, dt_: rk4_step(f, x, cur["u"], dt_),
                               hx=lambda x: np.atleast_1d(h(x, cur["u"])))
    kf.x = x0.copy()
    kf.P = np.array(P0, dtype=float)
    kf.R = np.array(R, dtype=float)
    kf.Q = np.array(Q, dtype=float) * dt
    N = len(z)
    X = np.empty((N, n))
    Pd = np.empty((N, n))
    repairs = 0
    t0 = time.perf_counter()
    for k in range(N):
        cur["u"] = u[k]
        if np.all(np.isfinite(z[k])):
            if k > 0:
                kf.update(z[k])
            else:  # filterpy's update needs sigma points from a predict: make them at x0
                kf.sigmas_f = pts.sigma_points(kf.x, kf.P)
                kf.update(z[k])
            kf.P, rep = nearest_spd(kf.P)
            repairs += rep
        X[k] = kf.x
        Pd[k] = np.diag(kf.P)
        if k + 1 < N:
            kf.predict(dt)
            kf.P, rep = nearest_spd(kf.P)
            repairs += rep
    return _result(name, dt, X, Pd, time.perf_counter() - t0, names,
                   {"spd_repairs": int(repairs)})
