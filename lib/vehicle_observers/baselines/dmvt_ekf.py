"""filterpy EKF / UKF baseline for the DMVT observer on the autonomous bicycle (Ichalal,
Arioui, Mammar, MED 2011; a baseline the paper does not have: the observer compared with
an EKF/UKF on the same data).

All estimators see the *same sampled data*: inputs ``u_k`` of the tracking law (27) computed
on the true state (N,) [normalised steering torque], measurements ``y_k = C x_k (+ noise)``
(N, 2) with ``C = [[1,0,0,0],[0,0,1,0]]`` (yaw x1 [rad], roll x3 [rad]), sample period ``dt``
[s]; both are held constant over a sample interval (zero-order hold).

* DMVT observer (6) on the same data: :class:`vehicle_observers.observers.dmvt.DMVTObserver`
  (RK4 per sample with ``u_k``, ``y_k`` held).
* EKF (:class:`BicycleEKF`, the observer contract) / UKF of :mod:`.baselines.filterpy_generic`
  on the model (25) ``x' = f(x, u)``, ``y = C x``.

Filter tuning rule (no tuning against the estimation error): ``R = sigma^2 I`` with
``sigma`` the stated sensor noise std [rad]; ``Q = diag(mean_k d_k^2) / dt`` (continuous
intensity) with ``d_k = x_{k+1} - RK4_zoh(x_k, u_k)`` the one-step discretisation residual of
the filter's own model along the simulated run (it comes from holding ``u`` over the
sample), floored at ``q_floor``; ``P0 = diag(scale^2)`` with ``scale`` the half-widths of the
initial-error box of notebook 04's robustness study.
"""

from __future__ import annotations

import math

import numpy as np

from vehicle_observers.baselines.ekf_observer import EKFObserver
from vehicle_observers.baselines.filterpy_generic import rk4_step
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.observers.dmvt import DMVTObserver
from vehicle_observers.observers.fixed_step import positive, row_names

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
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or len(X) < 2:
        raise ObserverArgumentError(f"discretisation_q: X must be (N, 4) with N >= 2, got "
                                    f"{X.shape}")
    positive("discretisation_q", "dt", dt)
    positive("discretisation_q", "floor", floor, allow_zero=True)
    U = np.asarray(U, dtype=float).reshape(len(X), -1)
    D = np.array([X[k + 1] - rk4_step(f, X[k], U[k], dt) for k in range(len(X) - 1)])
    return np.diag(np.maximum(np.mean(D**2, axis=0) / dt, floor))


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


class BicycleEKF(EKFObserver):
    """filterpy EKF on the bicycle (25) ``x' = f(x, u)``, ``y = C x`` at the sample period
    ``dt`` [s]: RK4 with ``u`` held and its exact Jacobian (:func:`rk4_step_and_jacobian`).
    ``Q`` (4, 4) continuous intensity (rule: :func:`discretisation_q`), ``R`` (ny, ny),
    ``P0`` (4, 4). Data and names as :class:`~vehicle_observers.observers.dmvt.DMVTObserver`:
    ``u`` (N, 1), ``y`` (N, ny); ``x0`` (4,) the prior mean."""

    def __init__(self, params, C, dt: float, Q, R, P0, name: str = "EKF (filterpy)"):
        C = np.atleast_2d(np.asarray(C, dtype=float))
        if C.ndim != 2 or C.shape[1] != 4:
            raise ObserverArgumentError(f"BicycleEKF: C must be (ny, 4), got {C.shape}")
        states = DMVTObserver.state_names
        super().__init__(bicycle_f(params), lambda x, u: C @ x, dt, Q, R, P0, states,
                         DMVTObserver.input_names, row_names(C, states),
                         jac=rk4_step_and_jacobian(params), hjac=lambda x, u: C, name=name)
        self.C = C
