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

from vehicle_observers.baselines.filterpy_generic import FilterRun, run_ekf, run_ukf
from vehicle_observers.models.planar import G_ACC
from vehicle_observers.observers.sliding_mode import ForceObserverModel, force_errors, omega_h

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

    def f(x, u):
        Om, H = omega_h(u[0], q)
        F = x[5:9]
        dx = np.zeros(N_X)
        dx[0:3] = Om @ F
        dx[0] += x[1] * x[2]
        dx[1] -= x[0] * x[2]
        dx[3:5] = u[1:3] / J - H @ F
        return dx

    def A(x, Om, H):
        a = np.zeros((N_X, N_X))
        a[0:3, 5:9] = Om
        a[0, 1], a[0, 2] = x[2], x[1]
        a[1, 0], a[1, 2] = -x[2], -x[0]
        a[3:5, 5:9] = -H
        return a

    def jac(x, u, dt):
        Om, H = omega_h(u[0], q)
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
    s = np.asarray(sensor_std, dtype=float)
    if s.shape != (5,) or np.any(s <= 0):
        raise ValueError(f"sensor_std must be 5 positive stds [vx, vy, r, w_f, w_r], got {s}")
    if t_rise <= 0:
        raise ValueError(f"t_rise must be > 0, got {t_rise}")
    Q = np.zeros((N_X, N_X))
    Q[5:, 5:] = np.diag(force_bounds(model, mu_max) ** 2 / t_rise)
    return Q, np.diag(s ** 2)


def block_mean(a, dec: int) -> np.ndarray:
    """Means of the ``len(a) // dec`` complete blocks of ``dec`` consecutive rows of ``a``
    (N, ...) -> (N // dec, ...); a trailing incomplete block is dropped. ``dec = 1``
    returns ``a`` itself (as an array)."""
    a = np.asarray(a, dtype=float)
    dec = int(dec)
    if dec < 1:
        raise ValueError(f"decimate must be >= 1, got {dec}")
    if dec == 1:
        return a
    nb = len(a) // dec
    return a[:nb * dec].reshape(nb, dec, *a.shape[1:]).mean(axis=1)


@dataclass
class ForceEKFResult:
    """EKF force estimates at the filter's samples: ``t`` (M,) block-centre times [s],
    ``x`` (M, 9) posterior means, ``F`` (M, 4) forces [N], ``F_std`` (M, 4) posterior stds
    [N], ``idx`` (M,) first measurement index of each block, ``z`` (M, 5) and ``u`` (M, 3) the
    block-averaged measurements and inputs the filter used, ``R`` (5, 5) its measurement
    covariance (``R / dec``), ``dec`` the block length, ``run`` the :class:`FilterRun`."""

    t: np.ndarray
    x: np.ndarray
    F: np.ndarray
    F_std: np.ndarray
    idx: np.ndarray
    z: np.ndarray
    u: np.ndarray
    R: np.ndarray
    dec: int
    run: FilterRun

    @property
    def us_per_step(self) -> float:
        return self.run.us_per_step


def run_force_ekf(t, Y, U, model: ForceObserverModel, sensor_std, *, decimate: int = 1,
                  x0=None, P0_std=None, t_rise: float = 0.5, mu_max: float = 1.0,
                  filter: str = "ekf") -> ForceEKFResult:
    """Random-walk-force EKF (or UKF, ``filter='ukf'``) on the SMO's measurements.

    t (N,) uniform [s], Y (N, 5) ``[v_x, v_y, r, w_f, w_r]``, U (N, 3) ``[delta, T_f, T_r]``
    (as :func:`.observers.sliding_mode.run_force_observer`); with ``decimate = dec > 1`` the filter
    runs on the
    block means of ``dec`` samples (measurements and inputs, :func:`block_mean`; inputs held
    over the step ``dec dt``) with ``R / dec``, time-stamped at the block centres. ``x0``
    (9,) defaults to the first (block-mean) measurement and zero forces; ``P0_std`` (9,)
    defaults to 1 m/s, 1 m/s, 0.1 rad/s, 5 rad/s, 5 rad/s and
    ``F_max`` on the forces. ``Q, R`` from :func:`noise_rule`.
    """
    t = np.asarray(t, dtype=float)
    Y = np.asarray(Y, dtype=float)
    U = np.asarray(U, dtype=float)
    if Y.ndim != 2 or Y.shape[1] != 5:
        raise ValueError(f"Y must be (N, 5) [vx, vy, r, omega_f, omega_r], got {Y.shape}")
    if U.shape != (len(Y), 3):
        raise ValueError(f"U must be (N, 3) [delta, T_f, T_r] with N={len(Y)}, got {U.shape}")
    if t.shape != (len(Y),) or len(t) < 2:
        raise ValueError(f"t must be (N,) with N={len(Y)} >= 2, got {t.shape}")
    dt = float(t[1] - t[0])
    if dt <= 0 or not np.allclose(np.diff(t), dt, rtol=1e-6, atol=1e-12):
        raise ValueError("t must be uniformly increasing (constant step)")
    if int(decimate) < 1:
        raise ValueError(f"decimate must be >= 1, got {decimate}")
    if filter not in ("ekf", "ukf"):
        raise ValueError(f"filter must be 'ekf' or 'ukf', got {filter!r}")
    dec = int(decimate)
    if len(t) < 2 * dec:
        raise ValueError(f"need at least 2 blocks of decimate = {dec} samples, got N = {len(t)}")
    f, h, jac, hjac = force_rw_model(model)
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
    if filter == "ekf":
        run = run_ekf(f, h, z, u, dtf, x0, P0, Q, R, jac=jac, hjac=hjac,
                      name="EKF random-walk forces (filterpy)")
    else:
        run = run_ukf(f, h, z, u, dtf, x0, P0, Q, R, name="UKF random-walk forces (filterpy)")
    return ForceEKFResult(tc, run.x, run.x[:, 5:9], np.sqrt(np.maximum(run.P_diag[:, 5:9], 0)),
                          idx, z, u, R, dec, run)


def part_a_ekf_run(man, Xs, p, sensor_std, *, errors=None, noise=None, seed: int = 0,
                   decimate: int = 1, t_skip: float = 1.0, x2_err0=None, x3_err0=None,
                   filter: str = "ekf", **kw) -> dict:
    """EKF counterpart of ``rabhi_2004.constants.part_a_run``: same truth ``Xs`` (N, 12), same
    measurements (:func:`.observers.sliding_mode.measurements_from_truth` with ``noise``, ``seed``), same
    observer-model ``errors``, same initial velocity/wheel-speed errors (default
    ``rabhi_2004.constants.x2_err0, x3_err0``), zero initial forces, same metrics after ``t_skip``
    (:func:`.observers.sliding_mode.force_errors`; with ``decimate > 1`` against the block means of the true
    forces, i.e. the truth at the block centres to O(dt^2)). ``p`` the truth
    :class:`.models.planar.PlanarParams`, ``sensor_std`` (5,) for ``R``. Returns a dict with ``res``
    (:class:`ForceEKFResult`), ``Y`` (N, 5) the measurements, ``rmse_*``, ``rmse_pct_*``,
    ``us_per_step``."""
    from vehicle_observers.observers.sliding_mode import measurements_from_truth

    if x2_err0 is None or x3_err0 is None:
        raise ValueError("part_a_ekf_run: give the initial errors x2_err0 (3,) and x3_err0 (2,) "
                         "(the paper's: rabhi_2004.constants.x2_err0, x3_err0)")
    model = ForceObserverModel.from_params(p, **(errors or {}))
    Y = measurements_from_truth(Xs, noise, seed)
    x0 = np.concatenate([Xs[0, 3:6] + np.asarray(x2_err0), Xs[0, 6:8] + np.asarray(x3_err0),
                         np.zeros(4)])
    res = run_force_ekf(man.t, Y, man.U, model, sensor_std, decimate=decimate, x0=x0,
                        filter=filter, **kw)
    F = Xs[:, 8:12]
    peak = np.max(np.abs(F), axis=0)
    out = {"res": res, "Y": Y, "us_per_step": res.us_per_step}
    out.update(force_errors(res.t, res.F, block_mean(F, res.dec), peak, t_skip, FORCE_NAMES))
    return out
