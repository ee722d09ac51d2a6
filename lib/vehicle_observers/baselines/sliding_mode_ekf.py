"""EKF baseline for the tyre forces of Rabhi et al. (AVCS 2004), Part A.

The classical "force as random walk" extended Kalman filter of the vehicle-dynamics
literature, built on the **same simplified planar model** the sliding-mode observer of
:mod:`.observers.sliding_mode` uses (eq. (9) with reconstructions R-A1, R-A3, R-A4) and the **same measured
outputs** ``y = [v_x, v_y, r, omega_f, omega_r]``; only the force model differs: the SMO
uses the relaxation model (8) with adaptive ``theta``, the EKF models each force as a random
walk (no tyre model at all). Filtering is done by the generic
:func:`.baselines.filterpy_generic.run_ekf` (filterpy ``ExtendedKalmanFilter``, RK4 discretisation,
zero-order-hold input); this module supplies the exact Jacobian of the RK4 map.

Augmented state ``x`` (9,)::

    [v_x (m/s), v_y (m/s), r (rad/s), omega_f (rad/s), omega_r (rad/s),
     F_xf, F_xr, F_yf, F_yr (N)]

Model (continuous time, input ``u = [delta (rad), T_f (N m), T_r (N m)]``)::

    [v_x, v_y, r]'   = Omega(delta) F + [v_y r, -v_x r, 0]        (9), R-A3/R-A4
    [omega_f, omega_r]' = [T_f / J_f, T_r / J_r] - H F             (3)
    F'               = w,   E[w w'] = Q_F delta(t)                 (random walk)

Measurement ``y = x[:5] + v``, ``E[v v'] = R``.

Decimation (``decimate = dec > 1``): the filter runs at ``1 / (dec dt)`` on the **block
averages** of ``dec`` consecutive measurements (all the SMO's samples, none discarded), each
time-stamped at its block centre, with ``R / dec`` (white sensor noise, averaged); the inputs
are block-averaged over the same blocks and held (zero-order hold) over the filter step.

Noise rule (stated, not tuned against the truth):

* ``R = diag(sensor_std^2)`` (the sensor noise of the noisy case, also used on clean data,
  where it is the sensor specification);
* ``Q_F = diag(F_max^2 / t_rise)`` [N^2/s]: over the rise time ``t_rise`` the random walk
  spreads by one peak force ``F_max = mu_max F_z`` (static axle load of the observer model,
  ``mu_max = 1``), i.e. a force-rate bound ``F_max / t_rise``;
* zero process noise on the velocities (the model is exact given the forces, the forces
  carry all the uncertainty).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehicle_observers.baselines.ekf_observer import EKFObserver, EKFTrajectory, filter_trajectory
from vehicle_observers.baselines.filterpy_generic import run_ukf
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.models.planar import G_ACC, IU_DELTA, IU_TF, IU_TR
from vehicle_observers.observers.fixed_step import positive, positive_array
from vehicle_observers.observers.sliding_mode import (
    Z_TH,
    Z_X2,
    Z_X3,
    Z_X4,
    ForceObserver,
    ForceObserverModel,
    omega_h,
)

FORCE_NAMES = ("Fxf", "Fxr", "Fyf", "Fyr")
N_X = 9


def force_rw_model(model: ForceObserverModel):
    """Augmented random-walk-force model of the SMO's planar model.

    Returns ``(f, h, jac, hjac)`` for :func:`.baselines.filterpy_generic.run_ekf`:
    ``f(x, u) -> x'`` (9,), ``h(x, u) -> y`` (5,), ``jac(x, u, dt) -> (x_next, F)`` the RK4
    step and its exact Jacobian (9, 9) (tangent-linear RK4), ``hjac(x, u) -> [I5 0]`` (5, 9).
    """
    J = np.array([model.J_f, model.J_r])
    q = model.as_array()
    H5 = np.hstack([np.eye(5), np.zeros((5, 4))])

    # state blocks [x2 = (v_x, v_y, r), x3 = (omega_f, omega_r), x4 = forces]: the first
    # blocks of the force observer's state (Z_X2, Z_X3, Z_X4, ending at Z_TH)
    def f(x, u):
        Om, H = omega_h(u[IU_DELTA], q)
        F = x[Z_X4:Z_TH]
        dx = np.zeros(N_X)
        dx[Z_X2:Z_X3] = Om @ F
        dx[0] += x[1] * x[2]        # transport terms v_y r, -v_x r (R-A3)
        dx[1] -= x[0] * x[2]
        dx[Z_X3:Z_X4] = u[IU_TF:IU_TR + 1] / J - H @ F
        return dx

    def A(x, Om, H):
        a = np.zeros((N_X, N_X))
        a[Z_X2:Z_X3, Z_X4:Z_TH] = Om
        a[0, 1], a[0, 2] = x[2], x[1]
        a[1, 0], a[1, 2] = -x[2], -x[0]
        a[Z_X3:Z_X4, Z_X4:Z_TH] = -H
        return a

    def jac(x, u, dt):
        Om, H = omega_h(u[IU_DELTA], q)
        eye = np.eye(N_X)
        k1 = f(x, u)
        d1 = A(x, Om, H)
        x2 = x + 0.5 * dt * k1
        k2 = f(x2, u)
        d2 = A(x2, Om, H) @ (eye + 0.5 * dt * d1)
        x3 = x + 0.5 * dt * k2
        k3 = f(x3, u)
        d3 = A(x3, Om, H) @ (eye + 0.5 * dt * d2)
        x4 = x + dt * k3
        k4 = f(x4, u)
        d4 = A(x4, Om, H) @ (eye + dt * d3)
        xn = x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        return xn, eye + dt / 6.0 * (d1 + 2 * d2 + 2 * d3 + d4)

    def h(x, u):
        return x[0:5].copy()

    def hjac(x, u):
        return H5

    return f, h, jac, hjac


def force_bounds(model: ForceObserverModel, mu_max: float = 1.0) -> np.ndarray:
    """Physical force bounds ``mu_max F_z`` [N] per force (F_xf, F_xr, F_yf, F_yr), static
    axle loads of the observer model, shape (4,)."""
    L = model.l_f + model.l_r
    fz_f = model.m * G_ACC * model.l_r / L
    fz_r = model.m * G_ACC * model.l_f / L
    return mu_max * np.array([fz_f, fz_r, fz_f, fz_r])


def noise_rule(model: ForceObserverModel, sensor_std, t_rise: float = 0.5, mu_max: float = 1.0):
    """``(Q, R)`` by the rule of the module docstring: ``Q`` (9, 9) continuous intensity
    (zeros on the velocities, ``F_max^2 / t_rise`` on the forces), ``R = diag(sensor_std^2)``
    (5, 5). ``t_rise`` [s] > 0, ``sensor_std`` (5,) > 0."""
    if np.shape(sensor_std) != (5,):
        raise ObserverArgumentError(f"noise_rule: sensor_std must be 5 positive stds [vx, vy, "
                                    f"r, w_f, w_r], got {sensor_std}")
    s = positive_array("noise_rule", "sensor_std", sensor_std, (5,))
    positive("noise_rule", "t_rise", t_rise)
    positive("noise_rule", "mu_max", mu_max)
    Q = np.zeros((N_X, N_X))
    Q[5:, 5:] = np.diag(force_bounds(model, mu_max) ** 2 / t_rise)
    return Q, np.diag(s ** 2)


def block_mean(a, dec: int) -> np.ndarray:
    """Means of the ``len(a) // dec`` complete blocks of ``dec`` consecutive rows of ``a``
    (N, ...) -> (N // dec, ...); a trailing incomplete block is dropped. ``dec = 1``
    returns ``a`` itself (as an array)."""
    a = np.asarray(a, dtype=float)
    if int(dec) != dec or dec < 1:
        raise ObserverArgumentError(f"block_mean: decimate must be an integer >= 1, got {dec}")
    dec = int(dec)
    if dec == 1:
        return a
    nb = len(a) // dec
    return a[:nb * dec].reshape(nb, dec, *a.shape[1:]).mean(axis=1)


@dataclass(frozen=True, eq=False)
class ForceEKFTrajectory(EKFTrajectory):
    """Run of :func:`run_force_ekf` at the filter's samples: ``t`` (M,) block-centre times
    [s], ``x`` (M, 9) posterior means, ``P_diag`` (M, 9) their variances; ``idx`` (M,) the
    first measurement index of each block, ``z`` (M, 5) and ``u`` (M, 3) the block-averaged
    measurements and inputs the filter used, ``R`` (5, 5) its measurement covariance
    (``R / dec``), ``dec`` the block length. ``F`` (M, 4) the forces [N] (a view of ``x``)
    and ``F_std`` (M, 4) their posterior standard deviations [N]."""

    idx: np.ndarray | None = None
    z: np.ndarray | None = None
    u: np.ndarray | None = None
    R: np.ndarray | None = None
    dec: int = 1

    @property
    def F(self) -> np.ndarray:
        return self.x[:, 5:9]

    @property
    def F_std(self) -> np.ndarray:
        return np.sqrt(np.maximum(self.P_diag[:, 5:9], 0))


class ForceEKF(EKFObserver):
    """Random-walk-force EKF (the model of :func:`force_rw_model`) at the sample period ``dt``
    [s], the observer contract: data as :class:`~vehicle_observers.observers.sliding_mode.ForceObserver`
    (``u`` (N, 3) ``[delta, T_f, T_r]``, ``y`` (N, 5) ``[v_x, v_y, r, w_f, w_r]``), state
    ``[v_x, v_y, r, omega_f, omega_r, F_xf, F_xr, F_yf, F_yr]``; ``Q`` (9, 9), ``R`` (5, 5)
    (rule: :func:`noise_rule`), ``P0`` (9, 9); ``x0`` (9,) the prior mean."""

    def __init__(self, model: ForceObserverModel, dt: float, Q, R, P0,
                 name: str = "EKF random-walk forces (filterpy)"):
        f, h, jac, hjac = force_rw_model(model)
        super().__init__(f, h, dt, Q, R, P0, ForceObserver.state_names,
                         ForceObserver.input_names, ForceObserver.output_names, jac=jac,
                         hjac=hjac, name=name)
        self.model = model


def run_force_ekf(t, Y, U, model: ForceObserverModel, sensor_std, *, decimate: int = 1,
                  x0=None, P0_std=None, t_rise: float = 0.5, mu_max: float = 1.0,
                  filter: str = "ekf") -> ForceEKFTrajectory:
    """Random-walk-force EKF (:class:`ForceEKF`, or the UKF with ``filter='ukf'``) on the
    SMO's measurements.

    t (N,) uniform [s], Y (N, 5) ``[v_x, v_y, r, w_f, w_r]``, U (N, 3) ``[delta, T_f, T_r]``
    (as :class:`.observers.sliding_mode.ForceObserver`); with ``decimate = dec > 1`` the
    filter runs on the block means of ``dec`` samples (measurements and inputs,
    :func:`block_mean`; inputs held over the step ``dec dt``) with ``R / dec``,
    time-stamped at the block centres. ``x0`` (9,) defaults to the first (block-mean)
    measurement and zero forces; ``P0_std`` (9,) defaults to 1 m/s, 1 m/s, 0.1 rad/s, 5
    rad/s, 5 rad/s and ``F_max`` on the forces. ``Q, R`` from :func:`noise_rule`.
    """
    t = np.asarray(t, dtype=float)
    Y = np.asarray(Y, dtype=float)
    U = np.asarray(U, dtype=float)
    if Y.ndim != 2 or Y.shape[1] != 5:
        raise ObserverArgumentError(f"run_force_ekf: Y must be (N, 5) [vx, vy, r, omega_f, "
                                    f"omega_r], got {Y.shape}")
    if U.shape != (len(Y), 3):
        raise ObserverArgumentError(f"run_force_ekf: U must be (N, 3) [delta, T_f, T_r] with "
                                    f"N={len(Y)}, got {U.shape}")
    if t.shape != (len(Y),) or len(t) < 2:
        raise ObserverArgumentError(f"run_force_ekf: t must be (N,) with N={len(Y)} >= 2, got "
                                    f"{t.shape}")
    dt = float(t[1] - t[0])
    if dt <= 0 or not np.allclose(np.diff(t), dt, rtol=1e-6, atol=1e-12):
        raise ObserverArgumentError("run_force_ekf: t must be uniformly increasing (constant "
                                    "step dt > 0)")
    if int(decimate) != decimate or decimate < 1:
        raise ObserverArgumentError(f"run_force_ekf: decimate must be an integer >= 1, got "
                                    f"{decimate}")
    if filter not in ("ekf", "ukf"):
        raise ObserverArgumentError(f"run_force_ekf: filter must be 'ekf' or 'ukf', got "
                                    f"{filter!r}")
    dec = int(decimate)
    if len(t) < 2 * dec:
        raise ObserverArgumentError(f"run_force_ekf: need at least 2 blocks of decimate = {dec} "
                                    f"samples, got N = {len(t)}")
    Q, R = noise_rule(model, sensor_std, t_rise, mu_max)
    R = R / dec                       # white noise: the mean of dec samples has R / dec
    z, u = block_mean(Y, dec), block_mean(U, dec)
    idx = np.arange(len(z)) * dec
    tc = block_mean(t, dec)           # block centres
    if x0 is None:
        x0 = np.concatenate([z[0], np.zeros(4)])
    if P0_std is None:
        P0_std = np.concatenate([[1.0, 1.0, 0.1, 5.0, 5.0], force_bounds(model, mu_max)])
    P0 = np.diag(np.asarray(P0_std, dtype=float) ** 2)
    dtf = dt * dec
    extra = {"idx": idx, "z": z, "u": u, "R": R, "dec": dec}
    if filter == "ekf":
        ekf = ForceEKF(model, dtf, Q, R, P0)
        run = ekf.run(tc, u, z, x0)
        return ForceEKFTrajectory(run.t, run.x, run.names, seconds=run.seconds,
                                  estimator=run.estimator, info=run.info, P_diag=run.P_diag,
                                  **extra)
    f, h, _, _ = force_rw_model(model)
    run = run_ukf(f, h, z, u, dtf, x0, P0, Q, R, name="UKF random-walk forces (filterpy)")
    return filter_trajectory(tc, run, ForceObserver.state_names, ForceEKFTrajectory, **extra)
