"""filterpy EKF / UKF baseline for the DMVT observer on the autonomous bicycle (Ichalal,
Arioui, Mammar, MED 2011; a baseline the paper does not have: the observer compared with
an EKF/UKF on the same data).

All estimators see the *same sampled data*: inputs ``u_k`` of the tracking law (27) computed
on the true state (N,) [normalised steering torque], measurements ``y_k = C x_k (+ noise)``
(N, 2) with ``C = [[1,0,0,0],[0,0,1,0]]`` (yaw x1 [rad], roll x3 [rad]), sample period ``dt``
[s]; both are held constant over a sample interval (zero-order hold).

* DMVT observer (6) with gains from the LMIs (23) (with or without the region (35)-(36)),
  ``xhat' = sum_j mu_j(zhat)(A_j xhat + B_j u) + sum_j mu_j^c(zhat) L_j (y - C xhat)``,
  RK4 per sample (numba; same weights as :func:`.observers.dmvt.simulate_bicycle_observer`, which
  instead re-evaluates ``u`` and ``y`` inside the RK4 stages of a plant/observer
  co-simulation: the two differ by O(dt)).
* EKF / UKF of :mod:`.baselines.filterpy_generic` on the model (25) ``x' = f(x, u)``, ``y = C x``.

Filter tuning rule (no tuning against the estimation error): ``R = sigma^2 I`` with
``sigma`` the stated sensor noise std [rad]; ``Q = diag(mean_k d_k^2) / dt`` (continuous
intensity) with ``d_k = x_{k+1} - RK4_zoh(x_k, u_k)`` the one-step discretisation residual of
the filter's own model along the simulated run (it comes from holding ``u`` over the
sample), floored at ``q_floor``; ``P0 = diag(scale^2)`` with ``scale`` the half-widths of the
initial-error box of notebook 04's robustness study.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from vehicle_observers.baselines.filterpy_generic import rk4_step, run_ekf, run_ukf
from vehicle_observers.core.timing import best_time
from vehicle_observers.observers.dmvt import observer_rhs

Array = np.ndarray


def bicycle_f(bp):
    """Scalar right-hand side of (25) ``f(x (4,), u (1,)) -> (4,)`` for the filters (fast
    pure-Python version of :func:`.models.bicycle.rhs`)."""
    p, c, v, g = bp.p, bp.c, bp.v, bp.g

    def f(x, u):
        u0 = float(u[0])
        s3, c3 = math.sin(x[2]), math.cos(x[2])
        f4 = (g * s3 + (1.0 + p * x[1] * s3) * c3 * x[1] * v * v + c * c3 * v * u0) / p
        return np.array([x[1] * v, u0, x[3], f4])

    return f


def discretisation_q(f, X, U, dt: float, floor: float = 1e-12) -> Array:
    """Continuous process-noise intensity ``Q = diag(mean_k d_k^2) / dt`` (4, 4) from the
    one-step residual ``d_k = X[k+1] - rk4_step(f, X[k], U[k], dt)`` of the ZOH-RK4 model
    along a simulated run ``X`` (N, 4), ``U`` (N,); diagonal floored at ``floor``."""
    U = np.asarray(U, dtype=float).reshape(len(X), -1)
    D = np.array([X[k + 1] - rk4_step(f, X[k], U[k], dt) for k in range(len(X) - 1)])
    return np.diag(np.maximum(np.mean(D**2, axis=0) / dt, floor))


@njit(cache=True)
def _obs_run(xh0, Y, U, dt, P, Av, Bv, zmin, zmax, L, C):
    N = Y.shape[0]
    Xh = np.empty((N, 4))
    s = xh0.copy()
    k1, k2, k3, k4, tmp = np.empty(4), np.empty(4), np.empty(4), np.empty(4), np.empty(4)
    for k in range(N):
        Xh[k] = s
        if k == N - 1:
            break
        observer_rhs(s, U[k], Y[k], P, Av, Bv, zmin, zmax, L, C, k1)
        for i in range(4):
            tmp[i] = s[i] + 0.5 * dt * k1[i]
        observer_rhs(tmp, U[k], Y[k], P, Av, Bv, zmin, zmax, L, C, k2)
        for i in range(4):
            tmp[i] = s[i] + 0.5 * dt * k2[i]
        observer_rhs(tmp, U[k], Y[k], P, Av, Bv, zmin, zmax, L, C, k3)
        for i in range(4):
            tmp[i] = s[i] + dt * k3[i]
        observer_rhs(tmp, U[k], Y[k], P, Av, Bv, zmin, zmax, L, C, k4)
        for i in range(4):
            s[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return Xh


def run_dmvt_on_data(bp, ts, L, C, Y, U, dt: float, xhat0, repeats: int = 3):
    """DMVT observer (6) (Ichalal 2011) driven by sampled data, RK4 with ``u_k``, ``y_k`` held.

    ``ts``: 8-rule TS model (:func:`.models.bicycle.bicycle_ts`), ``L`` (r, 4, 2), ``C`` (2, 4),
    ``Y`` (N, 2) [rad], ``U`` (N,), ``dt`` [s], ``xhat0`` (4,). Returns ``(Xhat (N, 4),
    seconds)``: the estimate at each sample and the best wall time of ``repeats`` identical
    runs (compiled code, first-call compilation excluded).
    """
    Y = np.ascontiguousarray(np.atleast_2d(Y), dtype=float)
    U = np.ascontiguousarray(np.ravel(U), dtype=float)
    if len(U) != len(Y):
        raise ValueError(f"U has {len(U)} samples but Y has {len(Y)}")
    L = np.ascontiguousarray(L, dtype=float)
    C = np.ascontiguousarray(C, dtype=float)
    xhat0 = np.ascontiguousarray(xhat0, dtype=float)
    ny, nr = Y.shape[1], ts.A.shape[0]
    _check_shape("xhat0", xhat0, [(4,)])
    _check_shape("C", C, [(ny, 4)], f"(ny, 4) with ny = {ny} columns of Y")
    _check_shape("L", L, [(nr, 4, ny), (1, 4, ny)],
                 f"(r, 4, ny) with r = {nr} rules or 1, ny = {ny}")
    args = (xhat0, Y, U, float(dt), bp.as_array(), np.ascontiguousarray(ts.A),
            np.ascontiguousarray(ts.B), ts.zmin, ts.zmax, L, C)
    # first call untimed (numba compilation / cache load)
    best, Xh = best_time(lambda: _obs_run(*args), max(repeats, 1), warmup=True)
    return Xh, best


def _check_shape(name: str, a: Array, allowed: list, expected: str | None = None) -> None:
    """ValueError naming ``name``, the expected and the actual shape unless ``a.shape`` is
    one of ``allowed``."""
    if a.shape not in allowed:
        raise ValueError(f"{name} must have shape {expected or allowed[0]}, got {a.shape}")


@dataclass
class EstimatorResult:
    """One estimator on one data set: estimate ``xhat`` (N, 4), per-state ``rmse`` (4,)
    over the window and ``rmse_late`` (4,) for ``t >= t_late`` (units of x1..x4: rad,
    rad/m, rad, rad/s), error ``overshoot`` (4,) and 2 % ``settling`` (4,) [s]
    (:func:`.observers.dmvt.error_metrics`), wall time ``us_per_step`` [us].

    Overshoot and settling use the error sequence that starts from the prior error
    ``x(0) - xhat0`` for every estimator: the filters' recorded ``x_0|0`` already contains
    the first measurement update, which would otherwise become the reference ``|e(0)|``."""

    name: str
    xhat: Array
    rmse: Array
    rmse_late: Array
    overshoot: Array
    settling: Array
    us_per_step: float
    info: dict = field(default_factory=dict)


def _result(name, t, X, Xh, xhat0, seconds, t_late, info=None) -> EstimatorResult:
    from vehicle_observers.observers.dmvt import error_metrics

    Xh = np.array(Xh, dtype=float)
    Xh0 = Xh.copy()
    Xh0[0] = xhat0  # error metrics start from the prior error for every estimator
    E = X - Xh
    late = t >= t_late
    if not late.any():
        raise ValueError(f"t_late = {t_late:g} s is past the end of the run (last sample "
                         f"t = {t[-1]:g} s): no sample for rmse_late")
    m = error_metrics(t, X, Xh0)
    return EstimatorResult(name, Xh, np.sqrt(np.mean(E**2, axis=0)),
                           np.sqrt(np.mean(E[late]**2, axis=0)), m["overshoot"], m["settling"],
                           1e6 * seconds / len(t), info or {})


def compare_estimators(bp, ts, gains: dict, C, t, X, U, Y, xhat0, Q, R, P0,
                       t_late: float = 2.0, ukf: bool = True) -> dict:
    """DMVT observers (one per entry of ``gains``: name -> L (r, 4, 2)), filterpy EKF and
    UKF on the same data: time grid ``t`` (N,) [s] (uniform), true states ``X`` (N, 4),
    inputs ``U`` (N,), measurements ``Y`` (N, 2), initial estimate ``xhat0`` (4,), filter
    matrices ``Q`` (4, 4) continuous intensity, ``R`` (2, 2) [rad^2], ``P0`` (4, 4).

    Returns ``{name: EstimatorResult}`` with keys of ``gains`` plus ``"ekf"`` and ``"ukf"``.
    """
    t = np.asarray(t, dtype=float)
    dt = float(t[1] - t[0])
    if not np.allclose(np.diff(t), dt, rtol=1e-9, atol=0.0):
        raise ValueError("time grid t must be uniform")
    X, Y = np.asarray(X, dtype=float), np.atleast_2d(np.asarray(Y, dtype=float))
    U = np.ravel(U)
    out = {}
    for name, L in gains.items():
        Xh, sec = run_dmvt_on_data(bp, ts, L, C, Y, U, dt, xhat0)
        out[name] = _result(name, t, X, Xh, xhat0, sec, t_late)
    f = bicycle_f(bp)
    Cm = np.asarray(C, dtype=float)

    def h(x, u):
        return Cm @ x

    def hjac(x, u):
        return Cm

    runs = [("ekf", run_ekf(f, h, Y, U[:, None], dt, xhat0, P0, Q, R, hjac=hjac,
                            jac=rk4_step_and_jacobian(bp)))]
    if ukf:
        runs.append(("ukf", run_ukf(f, h, Y, U[:, None], dt, xhat0, P0, Q, R)))
    for key, run in runs:
        out[key] = _result(run.name, t, X, run.x, xhat0, run.seconds, t_late, run.info)
    return out


def _jac_scalar(bp):
    """Analytic Jacobian (31) of (25) at one state, ``(x (4,), u float) -> (4, 4)``, the
    formula of :func:`.models.bicycle.jacobian` in scalar form."""
    p, c, v, g = bp.p, bp.c, bp.v, bp.g

    def J(x, u):
        s3, c3 = math.sin(x[2]), math.cos(x[2])
        out = np.zeros((4, 4))
        out[0, 1] = v
        out[2, 3] = 1.0
        out[3, 1] = (2 * p * x[1] * s3 + 1) * c3 * v * v / p
        out[3, 2] = (g / p * c3 + x[1] ** 2 * v * v * (c3 * c3 - s3 * s3)
                     - x[1] * v * v * s3 / p - c * v / p * u * s3)
        return out

    return J


def rk4_step_and_jacobian(bp):
    """``jac(x (4,), u (1,), dt) -> (x_next (4,), F (4, 4))`` for :func:`.run_ekf`: one RK4
    step of (25) with ``u`` held and its exact Jacobian by the chain rule through the four
    stages, ``F = I + dt/6 (J1 + 2 J2 + 2 J3 + J4)`` with ``J2 = Jf(x + dt/2 k1)(I + dt/2 J1)``
    etc. (``Jf``: analytic Jacobian (31) of Ichalal 2011)."""
    f, Jf = bicycle_f(bp), _jac_scalar(bp)
    eye = np.eye(4)

    def jac(x, u, dt):
        u0 = float(np.ravel(u)[0])
        k1 = f(x, u)
        J1 = Jf(x, u0)
        x2 = x + 0.5 * dt * k1
        k2 = f(x2, u)
        J2 = Jf(x2, u0) @ (eye + 0.5 * dt * J1)
        x3 = x + 0.5 * dt * k2
        k3 = f(x3, u)
        J3 = Jf(x3, u0) @ (eye + 0.5 * dt * J2)
        x4 = x + dt * k3
        k4 = f(x4, u)
        J4 = Jf(x4, u0) @ (eye + dt * J3)
        return (x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4),
                eye + dt / 6.0 * (J1 + 2.0 * J2 + 2.0 * J3 + J4))

    return jac
