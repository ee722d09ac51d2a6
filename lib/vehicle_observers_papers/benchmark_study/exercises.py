"""Checkers of the exercises of notebook 07 (the Kalman baselines and the benchmark).

Each ``check_N(answer, ...)`` computes the expected answer on its own (filterpy, the library's
compiled EKF, a closed form), calls the student's function on more than one input, and shows
one line through :func:`vehicle_observers.results.teaching.check` (``correct``, ``not yet``
with a hint, or ``not attempted`` while the stub is empty). Keys ``"07.N"``.

1. the yaw-rate-only EKF update (scalar innovation, no matrix inverse), derived from the
   general update, against filterpy's ``ExtendedKalmanFilter.update`` on random states and
   covariances;
2. a process-noise scale that makes the EKF's ``v_y`` consistent (mean NEES in
   :data:`NEES_BAND`), with the student's NEES function checked at two scales;
3. a custom estimator plugged into the registry: ``v_y`` from the yaw rate in a steady turn,
   derived from the rear axle's balance (the steady-state linear bicycle), run through the
   registry on two logs.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from vehicle_observers.results.teaching import check

#: mean NEES of v_y accepted as consistent in Exercise 2 (chosen here: the errors of one run are
#: correlated in time, so the chi-square band of independent samples, about 1 +- 0.01 for
#: 40 000 samples, would be far too narrow; a factor 2 either way separates an over- from an
#: under-confident filter)
NEES_BAND = (0.5, 2.0)


def _empty(f) -> bool:
    return f is None or f is Ellipsis


def _call(f, *args):
    """``f(*args)``, ``None`` while ``f`` is a stub returning ``...``."""
    out = f(*args)
    return None if out is Ellipsis else out


# ------------------------------------------------------------------------- exercise 1 -------
def _filterpy_update(x, P, y, R):
    from filterpy.kalman import ExtendedKalmanFilter

    kf = ExtendedKalmanFilter(dim_x=3, dim_z=1)
    kf.x, kf.P, kf.R = np.array(x, float), np.array(P, float), np.array([[R]])
    H = np.array([[0.0, 1.0, 0.0]])
    kf.update(np.array([y]), lambda _x: H, lambda xx: np.array([xx[1]]))
    return kf.x.copy(), kf.P.copy()


def _cases(n: int = 3, seed: int = 7):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        A = rng.normal(size=(3, 3))
        P = A @ A.T + 0.1 * np.eye(3)
        out.append((rng.normal(size=3), P, float(rng.normal()), float(rng.uniform(0.01, 1.0))))
    return out


def check_1(scalar_update):
    """Exercise 1: ``scalar_update(x, P, y_r, R_r) -> (x_new, P_new)``, the EKF update with the
    yaw rate only (``H = [0, 1, 0]``), against filterpy on three random cases."""
    if _empty(scalar_update):
        return check("07.1", None, None, hint="")

    def answer():
        got = [_call(scalar_update, x, P, y, R) for x, P, y, R in _cases()]
        if any(g is None for g in got):
            return None
        return np.concatenate([np.concatenate([np.ravel(a), np.ravel(b)]) for a, b in got])

    want = np.concatenate([np.concatenate([a, b.ravel()])
                           for a, b in (_filterpy_update(*c) for c in _cases())])
    return check("07.1", answer, want, rtol=1e-9, atol=1e-12,
                 hint=["with H = [0, 1, 0], which entries of P does H P H^T pick? S is a number",
                       "P H^T is one column of P: the gain needs no matrix inverse",
                       "for the optimal gain, expand (I - KH) P (I - KH)^T + K R K^T: two terms "
                       "cancel"])


# ------------------------------------------------------------------------- exercise 2 -------
def mean_nees_vy(log, params, tuning, scale: float, mask) -> float:
    """Mean of ``(v_y_hat - v_y)^2 / P_vy`` over ``mask`` of the library's EKF on ``log`` with
    the process noise of ``v_y`` multiplied by ``scale``."""
    from vehicle_observers.baselines import kalman as K

    r = K.ekf(log, params, replace(tuning, q_vy=tuning.q_vy * float(scale)))
    e = r.vy - log.vy
    return float(np.mean(e[mask] ** 2 / r.P[mask, 0, 0]))


def check_2(mean_nees, scale, log, params, tuning, mask):
    """Exercise 2: ``mean_nees(s)`` (the student's NEES of v_y with ``q_vy`` scaled by ``s``)
    at ``s = 1`` and ``s = 10``, then the chosen ``scale``: its mean NEES must lie in
    :data:`NEES_BAND`."""
    if _empty(mean_nees) or _empty(scale):
        return check("07.2", None, None, hint="")
    want_f = [mean_nees_vy(log, params, tuning, s, mask) for s in (1.0, 10.0)]
    got_f = [_call(mean_nees, s) for s in (1.0, 10.0)]
    if any(g is None for g in got_f):
        return check("07.2", None, None, hint="")
    ok_f = np.allclose(got_f, want_f, rtol=1e-6)
    if not ok_f:
        return check("07.2", got_f, want_f, rtol=1e-6,
                     hint="NEES of one sample: (v_y_hat - v_y)^2 / P[0, 0]; average it over the "
                          "scored samples (mask) of the EKF run with q_vy * s")
    nees = mean_nees_vy(log, params, tuning, float(scale), mask)
    lo, hi = NEES_BAND
    return check("07.2", bool(lo <= nees <= hi), True,
                 hint=f"your scale gives a mean NEES of {nees:.3g}, outside [{lo}, {hi}]: "
                      "above 2 the filter is over-confident (raise q_vy), below 0.5 under-"
                      "confident; search s on a log scale")


# ------------------------------------------------------------------------- exercise 3 -------
def steady_state_vy(log, vehicle) -> np.ndarray:
    """``v_y = r (l_r - m l_f v_x^2 / (c_r L))`` of the steady-state linear bicycle (rear
    axle force ``c_r alpha_r`` carries ``m v_x r l_f / L``), from the measured yaw rate."""
    p = vehicle.params
    L = p.a_f + p.a_r
    return log.yaw_rate * (p.a_r - p.m * p.a_f * log.vx ** 2
                           / (p.tire_r.cornering_stiffness * L))


def check_3(name, logs):
    """Exercise 3: the estimator registered as ``name`` run through the registry on every
    ``(log, vehicle)`` of ``logs`` must return the steady-state bicycle's ``v_y``."""
    from vehicle_observers import estimation as EST

    if _empty(name):
        return check("07.3", None, None, hint="")

    def answer():
        spec = EST.get(name)
        return np.concatenate([spec.estimate(log, veh).columns["vy_mps"] for log, veh in logs])

    want = np.concatenate([steady_state_vy(log, veh) for log, veh in logs])
    return check("07.3", answer, want, rtol=1e-6, atol=1e-9,
                 hint=["in a steady turn the yaw moment balances: l_f F_f = l_r F_r, and the lateral "
                       "forces carry m v_x r",
                       "the rear slip alpha_r = F_r / C_r; the rear axle's kinematics give "
                       "alpha_r = (l_r r - v_y) / v_x",
                       "the registered run(log, vehicle, **_) must return "
                       "Trajectory.from_columns(log.t, {'vy_mps': ...})"])
