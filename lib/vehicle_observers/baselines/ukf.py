"""Compiled unscented Kalman filter (numba) on the yaw-drift model of
:mod:`vehicle_observers.baselines.kalman`: the same filter as
:func:`~vehicle_observers.baselines.kalman.ukf_filterpy` (``filterpy``'s
``UnscentedKalmanFilter``), step for step, about 300 times faster.

Same as the reference, and equal to it to round-off (``tests/baselines/test_ukf.py``):

- sigma points of van der Merwe (filterpy's ``MerweScaledSigmaPoints(n=3, alpha, beta,
  kappa)``): ``lambda = alpha^2 (n + kappa) - n``, ``U`` the upper Cholesky factor of
  ``(n + lambda) P`` (``U^T U``, scipy's default), ``chi_0 = x``, ``chi_{1+i} = x + U[i]``,
  ``chi_{1+n+i} = x - U[i]``; weights ``W_m0 = lambda / (n + lambda)``,
  ``W_c0 = W_m0 + 1 - alpha^2 + beta``, ``W_mi = W_ci = 1 / (2 (n + lambda))``;
- predict from sample ``k-1`` to ``k``: the sigma points of the posterior through one RK4
  step of the model with the inputs of sample ``k-1`` held (``kalman._rk4``), unscented
  transform ``x = sum W_m chi``, ``P = sum W_c (chi - x)(chi - x)^T + diag(q) h``; then, as
  filterpy does, the sigma points are drawn again from that prior and ``P`` is repaired
  (:func:`nearest_spd`, symmetrised and its eigenvalues floored) after it;
- update with ``y_k = [r, a_y]`` (``[r]`` without a_y): the prior sigma points through the
  measurement model (``kalman._meas``), ``S = sum W_c (Y - y)(Y - y)^T + R``,
  ``P_xy = sum W_c (chi - x)(Y - y)^T``, ``K = P_xy S^-1``, ``x += K (y_k - y)``,
  ``P -= K S K^T``, then repaired again; the first sample is updated from ``(x_0, P_0)``.

The model and noise are those of the EKF (``kalman`` module docstring: state
``[v_y, r, b_ay]``, ``Q_k = diag(q) h_k``, ``P_0`` with the v_y variance capped at
``(BETA0_STD v_x(0))^2``).
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit

from vehicle_observers.baselines.kalman import (  # SPD_FLOOR: nearest_spd's eigenvalue floor
    BETA0_STD,
    SPD_FLOOR,
    KalmanRun,
    _meas,
    _rk4,
    _sym_eig_extremes,  # noqa: F401 - part of this module's interface (tests)
    kalman_run,
    prepare,
)
from vehicle_observers.baselines.kalman import nearest_spd_kernel as nearest_spd
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.vehicle import KalmanTuning

#: Merwe scaled sigma points of the reference filter (:func:`kalman.ukf_filterpy`)
ALPHA, BETA, KAPPA = 0.1, 2.0, 0.0


@njit(cache=True)
def _chol_upper(A, U):
    """Upper Cholesky factor ``U`` (``U^T U = A``) of a 3x3 matrix; False if ``A`` is not
    positive definite (the reference's scipy ``cholesky`` raises then)."""
    for i in range(3):
        for j in range(3):
            U[i, j] = 0.0
    for j in range(3):
        s = A[j, j]
        for k in range(j):
            s -= U[k, j] * U[k, j]
        if not s > 0.0:
            return False
        d = np.sqrt(s)
        U[j, j] = d
        for i in range(j + 1, 3):
            s = A[j, i]
            for k in range(j):
                s -= U[k, j] * U[k, i]
            U[j, i] = s / d
    return True


@njit(cache=True)
def _sigma_points(x, P, lam, sig, U, tmp):
    """Merwe sigma points (7, 3) of ``(x, P)`` into ``sig``; False if ``P`` is not positive
    definite."""
    for i in range(3):
        for j in range(3):
            tmp[i, j] = (lam + 3.0) * P[i, j]
    if not _chol_upper(tmp, U):
        return False
    for j in range(3):
        sig[0, j] = x[j]
    for k in range(3):
        for j in range(3):
            sig[k + 1, j] = x[j] + U[k, j]
            sig[3 + k + 1, j] = x[j] - U[k, j]
    return True


@njit(cache=True, nogil=True)
def _ukf(t, vx, delta, yr, ay, use_ay, Par, theta, x0, P0diag, alpha, beta, kappa, floor):
    """UKF pass (module docstring). Returns X (N, 3), P (N, 3, 3), the number of covariance
    repairs and the first row where a covariance was not positive definite (-1: none; the
    arrays are filled up to that row)."""
    N = t.shape[0]
    n = 3
    dz = 2 if use_ay else 1
    lam = alpha * alpha * (n + kappa) - n
    c = 0.5 / (n + lam)
    Wm = np.full(2 * n + 1, c)
    Wc = np.full(2 * n + 1, c)
    Wm[0] = lam / (n + lam)
    Wc[0] = lam / (n + lam) + (1.0 - alpha * alpha + beta)
    q = theta[:3].copy()
    if not use_ay:
        q[2] = 0.0
    R = np.zeros((dz, dz))
    R[0, 0] = theta[3]
    if use_ay:
        R[1, 1] = theta[4]
    X = np.empty((N, 3))
    Pout = np.empty((N, 3, 3))
    x = x0.copy()
    P = np.zeros((3, 3))
    for i in range(3):
        P[i, i] = P0diag[i]
    sig = np.empty((7, 3))
    sig_f = np.empty((7, 3))
    sig_h = np.empty((7, 2))
    U = np.empty((3, 3))
    tmp = np.empty((3, 3))
    xn = np.empty(3)
    F = np.empty((3, 3))
    yv = np.empty(2)
    H = np.empty((2, 3))
    z = np.empty(dz)
    zp = np.empty(dz)
    S = np.empty((dz, dz))
    Si = np.empty((dz, dz))
    Pxz = np.empty((3, dz))
    Kg = np.empty((3, dz))
    KS = np.empty((3, dz))
    repairs = 0
    for k in range(N):
        if k > 0:
            h = t[k] - t[k - 1]
            if not _sigma_points(x, P, lam, sig, U, tmp):
                return X, Pout, repairs, k
            for i in range(2 * n + 1):
                _rk4(sig[i], delta[k - 1], vx[k - 1], h, Par, xn, F)
                for j in range(3):
                    sig_f[i, j] = xn[j]
            for j in range(3):
                s = 0.0
                for i in range(2 * n + 1):
                    s += Wm[i] * sig_f[i, j]
                x[j] = s
            for a in range(3):
                for b in range(3):
                    s = 0.0
                    for i in range(2 * n + 1):
                        s += Wc[i] * (sig_f[i, a] - x[a]) * (sig_f[i, b] - x[b])
                    P[a, b] = s
            for a in range(3):
                P[a, a] += q[a] * h
            # filterpy draws the update's sigma points from the prior before the repair
            if not _sigma_points(x, P, lam, sig_f, U, tmp):
                return X, Pout, repairs, k
            P, fixed = nearest_spd(P, floor)
            repairs += fixed
        elif not _sigma_points(x, P, lam, sig_f, U, tmp):
            return X, Pout, repairs, 0
        # ---- update with y_k
        for i in range(2 * n + 1):
            _meas(sig_f[i], delta[k], vx[k], Par, use_ay, yv, H)
            for j in range(dz):
                sig_h[i, j] = yv[j]
        for j in range(dz):
            s = 0.0
            for i in range(2 * n + 1):
                s += Wm[i] * sig_h[i, j]
            zp[j] = s
        for a in range(dz):
            for b in range(dz):
                s = 0.0
                for i in range(2 * n + 1):
                    s += Wc[i] * (sig_h[i, a] - zp[a]) * (sig_h[i, b] - zp[b])
                S[a, b] = R[a, b] + s
        for a in range(3):
            for b in range(dz):
                s = 0.0
                for i in range(2 * n + 1):
                    s += Wc[i] * (sig_f[i, a] - x[a]) * (sig_h[i, b] - zp[b])
                Pxz[a, b] = s
        if dz == 2:                      # S^-1 of the 2x2 innovation covariance
            det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
            Si[0, 0], Si[0, 1] = S[1, 1] / det, -S[0, 1] / det
            Si[1, 0], Si[1, 1] = -S[1, 0] / det, S[0, 0] / det
        else:
            Si[0, 0] = 1.0 / S[0, 0]
        # K = Pxz S^-1; x += K (y - zp); P -= K S K^T
        for a in range(3):
            for b in range(dz):
                s = 0.0
                for j in range(dz):
                    s += Pxz[a, j] * Si[j, b]
                Kg[a, b] = s
        z[0] = yr[k] - zp[0]
        if use_ay:
            z[1] = ay[k] - zp[1]
        for a in range(3):
            s = 0.0
            for j in range(dz):
                s += Kg[a, j] * z[j]
            x[a] += s
        for a in range(3):
            for b in range(dz):
                s = 0.0
                for j in range(dz):
                    s += Kg[a, j] * S[j, b]
                KS[a, b] = s
        for a in range(3):
            for b in range(3):
                s = 0.0
                for j in range(dz):
                    s += KS[a, j] * Kg[b, j]
                P[a, b] -= s
        P, fixed = nearest_spd(P, floor)
        repairs += fixed
        for j in range(3):
            X[k, j] = x[j]
            for b in range(3):
                Pout[k, j, b] = P[j, b]
    return X, Pout, repairs, -1


def ukf(log: DriveLog, params: LateralParams, tuning: KalmanTuning | None = None,
        use_ay: bool | None = None, alpha: float = ALPHA, beta: float = BETA,
        kappa: float = KAPPA) -> KalmanRun:
    """The UKF of :func:`kalman.ukf_filterpy`, compiled (module docstring). Raises
    ValueError naming the row where a covariance stopped being positive definite (where
    the reference's ``cholesky`` raises)."""
    tuning = tuning or KalmanTuning()
    inp = prepare(log, use_ay)
    p0 = np.array(tuning.P0, dtype=float)
    p0[0] = min(p0[0], (BETA0_STD * float(inp.vx[0])) ** 2)
    t0 = time.perf_counter()
    X, P, repairs, bad = _ukf(inp.t, inp.vx, inp.delta, inp.yr, inp.ay, inp.use_ay,
                              params.as_array(), tuning.theta(), inp.x0, p0, float(alpha),
                              float(beta), float(kappa), SPD_FLOOR)
    sec = time.perf_counter() - t0
    if bad >= 0:
        raise ValueError(f"{log.source or 'log'}: UKF covariance not positive definite at row "
                         f"{bad} (t = {inp.t[bad]:.6g} s): the sigma points cannot be drawn")
    a_f = inp.delta - (X[:, 0] + params.a_f * X[:, 1]) / inp.vx
    a_r = -(X[:, 0] - params.a_r * X[:, 1]) / inp.vx
    return kalman_run("UKF (numba)", inp.t, X, P, params.tire_f.force(a_f),
                        params.tire_r.force(a_r), float("nan"), sec, True,
                        {"use_ay": inp.use_ay, "tuning": tuning, "spd_repairs": repairs})
