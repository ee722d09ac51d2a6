"""EKF, UKF and RTS smoother baselines on the nonlinear yaw-drift model (Yacine 2015, eq. (1)).

Model (continuous time, SI units)
---------------------------------
State ``x = [v_y (m/s), r (rad/s), b_ay (m/s^2)]``; inputs ``u = (delta_f (rad), v_x (m/s))``:

    v_y' = (F_f + F_r)/m - v_x r + w_1         (Yacine 2015 eq. (1), first row)
    r'   = (a_f F_f - a_r F_r)/I_z + w_2        (eq. (1), second row)
    b'   = w_3                                  (random-walk bias of the a_y sensor)

with steady axle forces ``F_f = F_f^S(alpha_f)``, ``F_r = F_r^S(alpha_r)`` (Pacejka (2) or
linear tyres, :mod:`.models.tires`) at the small-angle slip angles of eq. (4):
``alpha_f = delta - (v_y + a_f r)/v_x``, ``alpha_r = -(v_y - a_r r)/v_x``. The tyre forces are
algebraic outputs of the estimated state (not extra states): with the relaxation length of
0.1 m the relaxation time ``r/v_x`` is below 6 ms at the logs' speeds, shorter than the 10 ms
sample period of the real log.

Measurements: ``y = [r, a_y]`` with ``a_y = (F_f + F_r)/m + b_ay`` (the CG lateral
acceleration ``v_y' + v_x r`` of the model plus a slowly varying offset that absorbs road bank,
body roll and mounting errors, which make the real ``a_y`` channel disagree with
``v_y' + v_x r``). Without an ``a_y`` channel only ``r`` is used and ``b_ay`` is unobservable
and inert (its noise is set to zero).

Discretisation: one classical RK4 step per sample interval ``h_k = t_{k+1} - t_k`` with the
inputs held (zero-order hold) at their sample-``k`` values. The EKF transition Jacobian ``F_k``
is the *exact* Jacobian of that RK4 map (sensitivities propagated through the four stages).
Process noise: ``w`` is white with diagonal intensity ``q = (q_vy, q_r, q_b)``,
discretised as ``Q_k = diag(q) h_k`` (first order in ``h``; the model's fastest pole,
``(C_f + C_r)/(m v_x)``, is ~12 1/s at 16 m/s, so ``|lambda| h <= 0.12`` at 100 Hz).

Noise tuning (:func:`tune`): maximum likelihood of the innovations of the *measured* channels
(yaw rate and, if present, a_y) over ``log(q_vy, q_r, q_b, R_r, R_ay)``, Nelder-Mead from a
sensor-spec start. The reference ``v_y`` is never read. The same call tunes any car's log.

Implementations (results: :class:`KalmanRun`, a
:class:`~vehicle_observers.core.protocol.Trajectory`):

- :class:`LateralEKF` / :class:`LateralUKF`: the EKF and the UKF as observers of
  :mod:`vehicle_observers.core.protocol` (readable numpy ``step``, ``run`` the numba kernel /
  filterpy), built from a :class:`KalmanDesign` (car, noise tuning; no LMI certificate);
- :func:`ekf` numba EKF on a drive log (the fast one used by the CLI and the benchmark),
- :func:`ekf_filterpy` the same filter with ``filterpy.kalman.ExtendedKalmanFilter`` (reference
  implementation and speed baseline; equal to :func:`ekf` to round-off, see the tests),
- :func:`ukf_filterpy` ``filterpy.kalman.UnscentedKalmanFilter`` (Merwe sigma points) with the
  covariance re-symmetrised and its eigenvalues floored after every step (filterpy's UKF can
  lose symmetry / positive definiteness, then ``cholesky`` fails),
- :func:`rts` the extended RTS smoother (offline, non-causal reference) on the EKF pass;
  with linear tyres the model is linear and it equals ``filterpy``'s ``rts_smoother``.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from types import SimpleNamespace

import numpy as np
from numba import njit

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import ObserverBase, Trajectory
from vehicle_observers.data.identification import white_noise_std
from vehicle_observers.data.logs import DriveLog, despike
from vehicle_observers.models.lateral import (
    A_F,
    A_R,
    I_Z,
    TF_B,
    TF_C,
    TF_D,
    TF_E,
    TR_B,
    TR_C,
    TR_D,
    TR_E,
    LateralParams,
    M,
)
from vehicle_observers.models.mounting import derotate_ay, log_misalignment
from vehicle_observers.models.road import bank_column, body_roll_ay, lateral_gravity
from vehicle_observers.models.tires import magic_formula_slope
from vehicle_observers.models.vehicle import Q_B, Q_R, Q_VY, R_AY, R_R, KalmanTuning

NX = 3
#: the filter state ``[v_y, r, b_ay]`` in drive-log schema names
STATE_NAMES = ("vy_mps", "yaw_rate_radps", "ay_bias_mps2")
#: index of each state in ``x`` (and row / column of ``P``)
X_VY, X_R, X_B = range(3)
#: floor of the speed-dependent stiffness factor ``1 + k_s v_x`` (a gain that would make a
#: tyre's stiffness vanish or change sign at some speed is kept at this share instead)
STIFFNESS_FACTOR_MIN = 0.2


# ------------------------------------------------------------------ result ---------------
@dataclass(frozen=True, eq=False)
class KalmanRun(Trajectory):
    """A Kalman run: the :class:`~vehicle_observers.core.protocol.Trajectory` of the posterior
    ``x`` (N, 3) ``[v_y, r, b_ay]`` (:data:`STATE_NAMES`), plus ``P`` (N, 3, 3) its covariance,
    ``Ff``/``Fr`` (N,) axle forces [N] from the tyre model at the estimated slip angles and
    ``nll`` the negative log-likelihood of the innovations (``nan`` for smoothers and the
    filterpy filters). ``seconds``: wall time of the loop (compiled code, compilation
    excluded); ``causal`` False for the RTS smoother. ``X``, ``vy``, ``r`` are views of ``x``;
    ``name`` is ``estimator``."""

    P: np.ndarray | None = None
    Ff: np.ndarray | None = None
    Fr: np.ndarray | None = None
    nll: float = float("nan")

    @property
    def name(self) -> str:
        return self.estimator

    @property
    def X(self) -> np.ndarray:
        return self.x

    @property
    def vy(self) -> np.ndarray:
        return self.x[:, X_VY]

    @property
    def r(self) -> np.ndarray:
        return self.x[:, X_R]


def kalman_run(name, t, X, P, Ff, Fr, nll, seconds, causal, info) -> KalmanRun:
    """The :class:`KalmanRun` of a filter or smoother: ``X`` (N, 3), ``P`` (N, 3, 3) or None,
    forces ``Ff``/``Fr`` (N,) [N], ``nll``, wall ``seconds``, ``causal``, ``info``."""
    return KalmanRun(t, X, STATE_NAMES, seconds=seconds, causal=causal, estimator=name,
                     info=info, P=P, Ff=Ff, Fr=Fr, nll=float(nll))


# ------------------------------------------------------------------ model (numba) --------
@njit(cache=True)
def _rhs(x, delta, vx, P, f, A):
    """f(x) and its Jacobian A (3x3) of the model above. P: LateralParams.as_array()."""
    m, Iz, af, ar = P[M], P[I_Z], P[A_F], P[A_R]
    vy, r = x[X_VY], x[X_R]
    a_f = delta - (vy + af * r) / vx                                   # slip (4)
    a_r = -(vy - ar * r) / vx
    Ff, dFf = magic_formula_slope(a_f, P[TF_B], P[TF_C], P[TF_D], P[TF_E])   # tyres (2)/(7)
    Fr, dFr = magic_formula_slope(a_r, P[TR_B], P[TR_C], P[TR_D], P[TR_E])
    f[0] = (Ff + Fr) / m - vx * r
    f[1] = (af * Ff - ar * Fr) / Iz
    f[2] = 0.0
    # d alpha_f / d(vy, r) = (-1/vx, -af/vx); d alpha_r / d(vy, r) = (-1/vx, ar/vx)
    dFf_vy, dFf_r = -dFf / vx, -dFf * af / vx
    dFr_vy, dFr_r = -dFr / vx, dFr * ar / vx
    A[0, 0] = (dFf_vy + dFr_vy) / m
    A[0, 1] = (dFf_r + dFr_r) / m - vx
    A[1, 0] = (af * dFf_vy - ar * dFr_vy) / Iz
    A[1, 1] = (af * dFf_r - ar * dFr_r) / Iz
    A[0, 2] = 0.0
    A[1, 2] = 0.0
    A[2, 0] = 0.0
    A[2, 1] = 0.0
    A[2, 2] = 0.0


@njit(cache=True)
def _meas(x, delta, vx, P, use_ay, y, H):
    """h(x) = [r, (F_f+F_r)/m + b] and its Jacobian H (2x3)."""
    m, af, ar = P[M], P[A_F], P[A_R]
    vy, r = x[X_VY], x[X_R]
    a_f = delta - (vy + af * r) / vx
    a_r = -(vy - ar * r) / vx
    Ff, dFf = magic_formula_slope(a_f, P[TF_B], P[TF_C], P[TF_D], P[TF_E])
    Fr, dFr = magic_formula_slope(a_r, P[TR_B], P[TR_C], P[TR_D], P[TR_E])
    y[0] = r
    H[0, 0] = 0.0
    H[0, 1] = 1.0
    H[0, 2] = 0.0
    if use_ay:
        y[1] = (Ff + Fr) / m + x[X_B]
        H[1, 0] = (-dFf / vx - dFr / vx) / m
        H[1, 1] = (-dFf * af / vx + dFr * ar / vx) / m
        H[1, 2] = 1.0
    else:
        y[1] = 0.0
        H[1, 0] = 0.0
        H[1, 1] = 0.0
        H[1, 2] = 0.0


@njit(cache=True)
def _mm3(A, B, out):
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(3):
                s += A[i, k] * B[k, j]
            out[i, j] = s


@njit(cache=True)
def _stage_jac(A, Jprev, c, out, tmp):
    """out = A (I + c Jprev)."""
    for i in range(3):
        for j in range(3):
            tmp[i, j] = c * Jprev[i, j] + (1.0 if i == j else 0.0)
    _mm3(A, tmp, out)


@njit(cache=True)
def _rk4(x, delta, vx, h, P, xn, F):
    """One RK4 step (ZOH inputs) -> xn, and its exact Jacobian F = d xn / d x."""
    _rk4_ws(x, delta, vx, h, P, xn, F, np.empty((6, 3, 3)), np.empty((5, 3)))


@njit(cache=True)
def _rk4_ws(x, delta, vx, h, P, xn, F, W, V):
    """:func:`_rk4` with caller-provided scratch W (6, 3, 3), V (5, 3) (no allocation)."""
    n = 3
    J1, J2, J3, J4, A, T = W[0], W[1], W[2], W[3], W[4], W[5]
    k1, k2, k3, k4, tmp = V[0], V[1], V[2], V[3], V[4]
    _rhs(x, delta, vx, P, k1, J1)
    for i in range(n):
        tmp[i] = x[i] + 0.5 * h * k1[i]
    _rhs(tmp, delta, vx, P, k2, A)
    _stage_jac(A, J1, 0.5 * h, J2, T)
    for i in range(n):
        tmp[i] = x[i] + 0.5 * h * k2[i]
    _rhs(tmp, delta, vx, P, k3, A)
    _stage_jac(A, J2, 0.5 * h, J3, T)
    for i in range(n):
        tmp[i] = x[i] + h * k3[i]
    _rhs(tmp, delta, vx, P, k4, A)
    _stage_jac(A, J3, h, J4, T)
    for i in range(n):
        xn[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    for i in range(n):
        for j in range(n):
            F[i, j] = (1.0 if i == j else 0.0) + h / 6.0 * (
                J1[i, j] + 2.0 * J2[i, j] + 2.0 * J3[i, j] + J4[i, j])


def rk4_step(x, delta, vx, h, params: LateralParams):
    """Public wrapper of the discretised model: (x_{k+1}, F_k) for one sample interval."""
    xn = np.empty(3)
    F = np.empty((3, 3))
    _rk4(np.asarray(x, dtype=float), float(delta), float(vx), float(h), params.as_array(), xn, F)
    return xn, F


def measure(x, delta, vx, params: LateralParams, use_ay=True):
    """Public wrapper of the measurement model: (y (2,), H (2, 3))."""
    y = np.empty(2)
    H = np.empty((2, 3))
    _meas(np.asarray(x, dtype=float), float(delta), float(vx), params.as_array(), bool(use_ay),
          y, H)
    return (y, H) if use_ay else (y[:1], H[:1])


@njit(cache=True, inline="always")
def _f2(vy, r, delta, vx, m, Iz, af, ar, Bf, Cf, Df, Ef, Br, Cr, Dr, Er):
    """(f_vy, f_r) of the model and its 2x2 Jacobian (a00, a01, a10, a11); b_ay is inert."""
    a_f = delta - (vy + af * r) / vx
    a_r = -(vy - ar * r) / vx
    Ff, dFf = magic_formula_slope(a_f, Bf, Cf, Df, Ef)
    Fr, dFr = magic_formula_slope(a_r, Br, Cr, Dr, Er)
    f0 = (Ff + Fr) / m - vx * r
    f1 = (af * Ff - ar * Fr) / Iz
    dFf_vy, dFf_r = -dFf / vx, -dFf * af / vx
    dFr_vy, dFr_r = -dFr / vx, dFr * ar / vx
    return (f0, f1, (dFf_vy + dFr_vy) / m, (dFf_r + dFr_r) / m - vx,
            (af * dFf_vy - ar * dFr_vy) / Iz, (af * dFf_r - ar * dFr_r) / Iz)


@njit(cache=True, nogil=True)
def _ekf(t, vx, delta, yr, ay, use_ay, P, theta, x0, P0diag, store):
    """EKF pass on a flat road with speed-independent tyres: :func:`_ekf_terms` without
    the model terms."""
    return _ekf_terms(t, vx, delta, yr, ay, use_ay, P, theta, x0, P0diag, store,
                      np.zeros(t.shape[0]), 0.0)


@njit(cache=True, nogil=True)
def _ekf_terms(t, vx, delta, yr, ay, use_ay, P, theta, x0, P0diag, store, gy, ks):
    """EKF pass. Returns Xf, Pf (posteriors), Xp, Pp (priors), Fs (transition Jacobians from
    k to k+1) and the innovation negative log-likelihood. ``store=False`` keeps only Xf/diag.

    Model terms: ``gy`` (N,) [m/s^2] the bank term ``-g sin(phi)`` of the lateral balance
    (:mod:`vehicle_observers.models.road`; held over the step like the inputs), ``ks`` [s/m]
    the speed gain of the cornering stiffness, ``C(v_x) = C (1 + ks v_x)`` on both axles
    (the tyre curves' ``B`` scaled, their peaks ``D`` kept; the factor is floored at
    :data:`STIFFNESS_FACTOR_MIN`).

    Written out in scalars: b_ay has no dynamics, so the RK4 map and its Jacobian act on
    (v_y, r) only and ``F = [[F2, 0], [0, 1]]``; ``H = [[0, 1, 0], [h10, h11, 1]]``."""
    N = t.shape[0]
    Xf = np.empty((N, 3))
    Pf = np.empty((N if store else 1, 3, 3))
    Pfd = np.empty((N, 3))
    Xp = np.empty((N if store else 1, 3))
    Pp = np.empty((N if store else 1, 3, 3))
    Fs = np.empty((N if store else 1, 3, 3))
    m, Iz, af, ar = P[M], P[I_Z], P[A_F], P[A_R]
    Bf0, Cf, Df, Ef = P[TF_B], P[TF_C], P[TF_D], P[TF_E]
    Br0, Cr, Dr, Er = P[TR_B], P[TR_C], P[TR_D], P[TR_E]
    q0, q1, q2 = theta[Q_VY], theta[Q_R], theta[Q_B]
    if not use_ay:
        q2 = 0.0
    Rr, Ray = theta[R_R], theta[R_AY]
    x0_, x1_, x2_ = x0[X_VY], x0[X_R], x0[X_B]
    p00, p11, p22 = P0diag[X_VY], P0diag[X_R], P0diag[X_B]
    p01 = p02 = p12 = 0.0
    nll = 0.0
    log2pi = np.log(2.0 * np.pi)
    for k in range(N):
        if store:
            Xp[k, 0], Xp[k, 1], Xp[k, 2] = x0_, x1_, x2_
            Pp[k, 0, 0], Pp[k, 0, 1], Pp[k, 0, 2] = p00, p01, p02
            Pp[k, 1, 0], Pp[k, 1, 1], Pp[k, 1, 2] = p01, p11, p12
            Pp[k, 2, 0], Pp[k, 2, 1], Pp[k, 2, 2] = p02, p12, p22
        dk, vk, gk = delta[k], vx[k], gy[k]
        sk = max(1.0 + ks * vk, STIFFNESS_FACTOR_MIN)
        Bf, Br = Bf0 * sk, Br0 * sk
        # ---- update with y_k
        e0 = yr[k] - x1_
        if use_ay:
            a_f = dk - (x0_ + af * x1_) / vk
            a_r = -(x0_ - ar * x1_) / vk
            Ff, dFf = magic_formula_slope(a_f, Bf, Cf, Df, Ef)
            Fr, dFr = magic_formula_slope(a_r, Br, Cr, Dr, Er)
            h0 = (-dFf / vk - dFr / vk) / m
            h1 = (-dFf * af / vk + dFr * ar / vk) / m
            e1 = ay[k] - ((Ff + Fr) / m + x2_)
            # P H^T: column 0 = P[:, 1], column 1 = h0 P[:, 0] + h1 P[:, 1] + P[:, 2]
            a0, a1, a2 = p01, p11, p12
            b0 = h0 * p00 + h1 * p01 + p02
            b1 = h0 * p01 + h1 * p11 + p12
            b2 = h0 * p02 + h1 * p12 + p22
            s00 = a1 + Rr
            s01 = b1
            s11 = h0 * b0 + h1 * b1 + b2 + Ray
            det = s00 * s11 - s01 * s01
            i00, i11, i01 = s11 / det, s00 / det, -s01 / det
            nll += 0.5 * (np.log(det) + e0 * (i00 * e0 + i01 * e1)
                          + e1 * (i01 * e0 + i11 * e1) + 2.0 * log2pi)
            k00, k01 = a0 * i00 + b0 * i01, a0 * i01 + b0 * i11
            k10, k11 = a1 * i00 + b1 * i01, a1 * i01 + b1 * i11
            k20, k21 = a2 * i00 + b2 * i01, a2 * i01 + b2 * i11
            x0_ += k00 * e0 + k01 * e1
            x1_ += k10 * e0 + k11 * e1
            x2_ += k20 * e0 + k21 * e1
            # Joseph form (I - K H) P (I - K H)^T + K R K^T keeps P symmetric positive definite
            m00, m01, m02 = 1.0 - k01 * h0, -k00 - k01 * h1, -k01
            m10, m11, m12 = -k11 * h0, 1.0 - k10 - k11 * h1, -k11
            m20, m21, m22 = -k21 * h0, -k20 - k21 * h1, 1.0 - k21
            t00 = m00 * p00 + m01 * p01 + m02 * p02
            t01 = m00 * p01 + m01 * p11 + m02 * p12
            t02 = m00 * p02 + m01 * p12 + m02 * p22
            t10 = m10 * p00 + m11 * p01 + m12 * p02
            t11 = m10 * p01 + m11 * p11 + m12 * p12
            t12 = m10 * p02 + m11 * p12 + m12 * p22
            t20 = m20 * p00 + m21 * p01 + m22 * p02
            t21 = m20 * p01 + m21 * p11 + m22 * p12
            t22 = m20 * p02 + m21 * p12 + m22 * p22
            p00 = t00 * m00 + t01 * m01 + t02 * m02 + k00 * Rr * k00 + k01 * Ray * k01
            p01 = t00 * m10 + t01 * m11 + t02 * m12 + k00 * Rr * k10 + k01 * Ray * k11
            p02 = t00 * m20 + t01 * m21 + t02 * m22 + k00 * Rr * k20 + k01 * Ray * k21
            p11 = t10 * m10 + t11 * m11 + t12 * m12 + k10 * Rr * k10 + k11 * Ray * k11
            p12 = t10 * m20 + t11 * m21 + t12 * m22 + k10 * Rr * k20 + k11 * Ray * k21
            p22 = t20 * m20 + t21 * m21 + t22 * m22 + k20 * Rr * k20 + k21 * Ray * k21
        else:
            s = p11 + Rr
            nll += 0.5 * (np.log(s) + e0 * e0 / s + log2pi)
            c0, c1, c2 = p01 / s, p11 / s, p12 / s
            x0_ += c0 * e0
            x1_ += c1 * e0
            x2_ += c2 * e0
            n00 = p00 - c0 * p01 - p01 * c0 + c0 * s * c0
            n01 = p01 - c0 * p11 - p01 * c1 + c0 * s * c1
            n02 = p02 - c0 * p12 - p01 * c2 + c0 * s * c2
            n11 = p11 - c1 * p11 - p11 * c1 + c1 * s * c1
            n12 = p12 - c1 * p12 - p11 * c2 + c1 * s * c2
            n22 = p22 - c2 * p12 - p12 * c2 + c2 * s * c2
            p00, p01, p02, p11, p12, p22 = n00, n01, n02, n11, n12, n22
        Xf[k, 0], Xf[k, 1], Xf[k, 2] = x0_, x1_, x2_
        Pfd[k, 0], Pfd[k, 1], Pfd[k, 2] = p00, p11, p22
        if store:
            Pf[k, 0, 0], Pf[k, 0, 1], Pf[k, 0, 2] = p00, p01, p02
            Pf[k, 1, 0], Pf[k, 1, 1], Pf[k, 1, 2] = p01, p11, p12
            Pf[k, 2, 0], Pf[k, 2, 1], Pf[k, 2, 2] = p02, p12, p22
        # ---- predict to k+1: RK4 with its exact Jacobian (stages J_i = A_i (I + c J_{i-1}))
        if k + 1 < N:
            h = t[k + 1] - t[k]
            hh = 0.5 * h
            f0a, f1a, j00, j01, j10, j11 = _f2(x0_, x1_, dk, vk, m, Iz, af, ar,
                                              Bf, Cf, Df, Ef, Br, Cr, Dr, Er)
            f0a += gk                                  # bank term (held)
            f0b, f1b, a00, a01, a10, a11 = _f2(x0_ + hh * f0a, x1_ + hh * f1a, dk, vk, m, Iz,
                                              af, ar, Bf, Cf, Df, Ef, Br, Cr, Dr, Er)
            f0b += gk                                  # bank term (held)
            u00, u01, u10, u11 = 1.0 + hh * j00, hh * j01, hh * j10, 1.0 + hh * j11
            g00, g01 = a00 * u00 + a01 * u10, a00 * u01 + a01 * u11
            g10, g11 = a10 * u00 + a11 * u10, a10 * u01 + a11 * u11
            s00, s01, s10, s11 = j00 + 2.0 * g00, j01 + 2.0 * g01, j10 + 2.0 * g10, j11 + 2.0 * g11
            f0c, f1c, a00, a01, a10, a11 = _f2(x0_ + hh * f0b, x1_ + hh * f1b, dk, vk, m, Iz,
                                              af, ar, Bf, Cf, Df, Ef, Br, Cr, Dr, Er)
            f0c += gk                                  # bank term (held)
            u00, u01, u10, u11 = 1.0 + hh * g00, hh * g01, hh * g10, 1.0 + hh * g11
            g00, g01 = a00 * u00 + a01 * u10, a00 * u01 + a01 * u11
            g10, g11 = a10 * u00 + a11 * u10, a10 * u01 + a11 * u11
            s00 += 2.0 * g00
            s01 += 2.0 * g01
            s10 += 2.0 * g10
            s11 += 2.0 * g11
            f0d, f1d, a00, a01, a10, a11 = _f2(x0_ + h * f0c, x1_ + h * f1c, dk, vk, m, Iz,
                                              af, ar, Bf, Cf, Df, Ef, Br, Cr, Dr, Er)
            f0d += gk                                  # bank term (held)
            u00, u01, u10, u11 = 1.0 + h * g00, h * g01, h * g10, 1.0 + h * g11
            s00 += a00 * u00 + a01 * u10
            s01 += a00 * u01 + a01 * u11
            s10 += a10 * u00 + a11 * u10
            s11 += a10 * u01 + a11 * u11
            x0_ += h / 6.0 * (f0a + 2.0 * f0b + 2.0 * f0c + f0d)
            x1_ += h / 6.0 * (f1a + 2.0 * f1b + 2.0 * f1c + f1d)
            F00, F01 = 1.0 + h / 6.0 * s00, h / 6.0 * s01
            F10, F11 = h / 6.0 * s10, 1.0 + h / 6.0 * s11
            # F P F^T + Q h with F = [[F2, 0], [0, 1]]
            t00, t01 = F00 * p00 + F01 * p01, F00 * p01 + F01 * p11
            t10, t11 = F10 * p00 + F11 * p01, F10 * p01 + F11 * p11
            n02 = F00 * p02 + F01 * p12
            n12 = F10 * p02 + F11 * p12
            p00 = t00 * F00 + t01 * F01 + q0 * h
            p01 = t00 * F10 + t01 * F11
            p11 = t10 * F10 + t11 * F11 + q1 * h
            p02, p12 = n02, n12
            p22 = p22 + q2 * h
            if store:
                Fs[k + 1, 0, 0], Fs[k + 1, 0, 1], Fs[k + 1, 0, 2] = F00, F01, 0.0
                Fs[k + 1, 1, 0], Fs[k + 1, 1, 1], Fs[k + 1, 1, 2] = F10, F11, 0.0
                Fs[k + 1, 2, 0], Fs[k + 1, 2, 1], Fs[k + 1, 2, 2] = 0.0, 0.0, 1.0
        elif store:
            Fs[0] = np.eye(3)
    return Xf, Pf, Pfd, Xp, Pp, Fs, nll


@njit(cache=True)
def _inv3(A):
    """Inverse of a symmetric positive semi-definite 3x3 matrix by cofactors; falls back to
    the pseudo-inverse when it is (numerically) singular (e.g. an inert b_ay with zero
    variance)."""
    c00 = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
    c01 = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
    c02 = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
    det = A[0, 0] * c00 + A[0, 1] * c01 + A[0, 2] * c02
    scale = A[0, 0] * A[1, 1] * A[2, 2]
    if not (abs(det) > 1e-12 * abs(scale)) or scale == 0.0:
        # C-contiguous like the cofactor branch, so the caller's ``@`` is typed on contiguous
        # arrays (numba's pinv returns another layout; mixed layouts are the slow path)
        return np.ascontiguousarray(np.linalg.pinv(A))
    out = np.empty((3, 3))
    out[0, 0] = c00 / det
    out[1, 0] = c01 / det
    out[2, 0] = c02 / det
    out[0, 1] = (A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]) / det
    out[1, 1] = (A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]) / det
    out[2, 1] = (A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]) / det
    out[0, 2] = (A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]) / det
    out[1, 2] = (A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]) / det
    out[2, 2] = (A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]) / det
    return out


@njit(cache=True)
def _rts(Xf, Pf, Xp, Pp, Fs):
    """Rauch-Tung-Striebel backward pass; Fs[k+1] maps k -> k+1, Xp/Pp[k+1] its prior."""
    N, n = Xf.shape
    Xs = Xf.copy()
    Ps = Pf.copy()
    for k in range(N - 2, -1, -1):
        G = Pf[k] @ np.ascontiguousarray(Fs[k + 1].T) @ _inv3(Pp[k + 1])
        Xs[k] = Xf[k] + G @ (Xs[k + 1] - Xp[k + 1])
        Ps[k] = Pf[k] + G @ (Ps[k + 1] - Pp[k + 1]) @ G.T
    return Xs, Ps


# ------------------------------------------------------------------ python API ----------
@dataclass
class _Inputs:
    t: np.ndarray
    vx: np.ndarray
    delta: np.ndarray
    yr: np.ndarray
    ay: np.ndarray
    use_ay: bool
    x0: np.ndarray
    gy: np.ndarray | None = None     # bank term -g sin(phi) [m/s^2] (None: flat road)
    psi: np.ndarray | None = None    # yaw misalignment of the unit [rad] (None: not applied)

    def terms(self, params: LateralParams) -> tuple:
        """The model-term arguments of :func:`_ekf_terms`: ``(gy, ks)``."""
        gy = np.zeros_like(self.t) if self.gy is None else self.gy
        return gy, float(params.stiffness_speed)


def prepare(log: DriveLog, use_ay: bool | None = None, despike_steering: float | None = 0.1,
            misalignment: bool = False):
    """Arrays for the kernels. ``misalignment=True`` with an a_y channel and an ``ax_mps2``
    column: a_y de-rotated by the causal estimate of the unit's yaw misalignment
    (:mod:`vehicle_observers.models.mounting`, kept in ``psi``; measured channels only).
    Steering spikes (single-sample jumps > ``despike_steering``
    rad from the 3-sample median, e.g. 0.48 rad at t = 671.67 s in the Revs log) are removed:
    a physical steering wheel cannot jump 0.1 rad road-wheel for one sample and come back
    (the 3-sample median reads the next sample: this cleaning is an offline step before the
    causal filter, which then reads only samples up to k). Raises
    :class:`~vehicle_observers.core.errors.ObserverArgumentError` naming the column and row
    of a non-finite value or of a speed <= 0."""
    has_ay = log.ay is not None
    use = has_ay if use_ay is None else bool(use_ay)
    if use and not has_ay:
        raise ObserverArgumentError("use_ay=True but the log has no 'ay_mps2' column")
    cols = {"t_s": log.t, "vx_mps": log.vx, "delta_roadwheel_rad": log.delta,
            "yaw_rate_radps": log.yaw_rate, **({"ay_mps2": log.ay} if use else {})}
    for c, a in cols.items():
        bad = ~np.isfinite(np.asarray(a, dtype=float))
        if bad.any():
            k = int(np.argmax(bad))
            raise ObserverArgumentError(
                f"{log.source or 'log'}: column {c!r} has {int(bad.sum())} non-finite value(s), "
                f"first at row {k} ({a[k]}); the Kalman filters need finite measurements")
    if np.any(log.vx <= 0):
        k = int(np.argmax(log.vx <= 0))
        raise ObserverArgumentError(f"column 'vx_mps' must be > 0 (the model divides by it): "
                                    f"row {k} has {log.vx[k]:g}")
    delta = np.ascontiguousarray(log.delta, dtype=float)
    if despike_steering is not None:
        delta, _ = despike(delta, despike_steering)
    ay = np.ascontiguousarray(log.ay if use else np.zeros_like(log.t), dtype=float)
    psi = log_misalignment(log) if (use and misalignment) else None
    if psi is not None:                    # the unit's yaw misalignment, a_x,s into a_y
        ay = np.ascontiguousarray(derotate_ay(ay, log.extra["ax_mps2"], psi))
    tilt = body_roll_ay(log) if use else None
    if tilt is not None:                   # a roll column: the body's tilt of the sensor
        ay = ay - tilt
    x0 = _x0(log.yaw_rate[0])
    gy = lateral_gravity(log)
    if gy is not None and not np.all(np.isfinite(gy)):
        k = int(np.argmax(~np.isfinite(gy)))
        raise ObserverArgumentError(f"{log.source or 'log'}: column {bank_column(log)!r} has a "
                                    f"non-finite value at row {k}; the bank term needs finite "
                                    "angles")
    return _Inputs(np.ascontiguousarray(log.t, dtype=float), np.ascontiguousarray(log.vx, float),
                   delta, np.ascontiguousarray(log.yaw_rate, float), ay, use, x0, gy, psi)


def _x0(yaw_rate0) -> np.ndarray:
    """Default initial estimate: ``v_y = 0``, the measured yaw rate, no a_y offset."""
    x0 = np.zeros(NX)
    x0[X_R] = float(yaw_rate0)
    return x0


#: initial sideslip standard deviation [rad] used to cap the initial v_y variance
BETA0_STD = 0.05


def _p0(P0, inp: _Inputs) -> np.ndarray:
    """Initial covariance diagonal: ``P0`` with the v_y variance capped at
    ``(BETA0_STD v_x(0))^2``, i.e. an initial sideslip of a few degrees. At walking speed a
    1 m/s v_y uncertainty means slip angles far past the tyre peak; sigma points there lock
    the UKF onto the saturated-tyre branch, where v_y is unobservable."""
    p = np.array(P0, dtype=float)
    p[X_VY] = min(p[X_VY], (BETA0_STD * float(inp.vx[0])) ** 2)
    return p


def stiffness_factor(vx, params: LateralParams) -> np.ndarray:
    """The speed factor ``max(1 + k_s v_x, STIFFNESS_FACTOR_MIN)`` of the cornering
    stiffness (``k_s = params.stiffness_speed`` [s/m]; 1 when it is 0)."""
    return np.maximum(1.0 + float(params.stiffness_speed) * np.asarray(vx, float),
                      STIFFNESS_FACTOR_MIN)


def _forces(X, inp: _Inputs, params: LateralParams):
    """Axle forces [N] of the tyre model at the slip angles (4) of the estimates X (N, 3)
    (with the speed factor of the stiffness: a tyre curve with ``B`` scaled by ``s`` is
    ``F(s alpha)``, for the magic formula and the linear tyre alike)."""
    s = stiffness_factor(inp.vx, params)
    a_f = inp.delta - (X[:, X_VY] + params.a_f * X[:, X_R]) / inp.vx
    a_r = -(X[:, X_VY] - params.a_r * X[:, X_R]) / inp.vx
    return params.tire_f.force(s * a_f), params.tire_r.force(s * a_r)


# ------------------------------------------------------------------ observers ------------
@dataclass(frozen=True)
class KalmanDesign:
    """What the Kalman filters of this module are built from: the car ``params``, the noise
    ``tuning`` (:class:`~vehicle_observers.models.vehicle.KalmanTuning`) and whether a_y is
    measured (``use_ay``; without it ``b_ay`` is inert). ``certificate`` is ``None``: a
    noise tuning, no LMI."""

    params: LateralParams
    tuning: KalmanTuning = field(default_factory=KalmanTuning)
    use_ay: bool = True
    certificate: None = None


class _KalmanObserver(ObserverBase):
    """Shared plumbing of :class:`LateralEKF` and :class:`LateralUKF`: names, inputs, the
    model in readable numpy (f, its Jacobian, h and its Jacobian)."""

    state_names = STATE_NAMES
    input_names = ("delta_roadwheel_rad", "vx_mps")

    def __init__(self, design: KalmanDesign):
        if not isinstance(design, KalmanDesign):
            raise ObserverArgumentError(f"{type(self).__name__}: design must be a KalmanDesign, "
                                        f"got {type(design).__name__}")
        self.design = design
        self.output_names = (("yaw_rate_radps", "ay_mps2") if design.use_ay
                             else ("yaw_rate_radps",))
        P = design.params.as_array()
        self._front = (P[TF_B], P[TF_C], P[TF_D], P[TF_E])
        self._rear = (P[TR_B], P[TR_C], P[TR_D], P[TR_E])
        th = design.tuning.theta()
        self._q = np.array([th[Q_VY], th[Q_R], th[Q_B] if design.use_ay else 0.0])
        self._R = np.diag([th[R_R], th[R_AY]][: len(self.output_names)])

    def _inputs(self, t, u, y, x0) -> _Inputs:
        t, u, y, x0 = self.check_data(t, u, y, x0)
        vx = np.ascontiguousarray(u[:, 1])
        if np.any(vx <= 0):
            k = int(np.argmax(vx <= 0))
            raise ObserverArgumentError(f"{type(self).__name__}: u column 1 (vx_mps) must be > 0 "
                                        f"(the model divides by it): row {k} has {vx[k]:g}")
        ay = np.ascontiguousarray(y[:, 1]) if self.design.use_ay else np.zeros_like(t)
        return _Inputs(t, vx, np.ascontiguousarray(u[:, 0]), np.ascontiguousarray(y[:, 0]), ay,
                       self.design.use_ay, _x0(y[0, 0]) if x0 is None else x0)

    # ---- the model of the module docstring, readable numpy --------------------------
    def _tyres(self, x, delta, vx):
        """Slip angles (4) and ``(F, dF/dalpha)`` of both axles (Pacejka (2)/(7))."""
        p = self.design.params
        a_f = delta - (x[X_VY] + p.a_f * x[X_R]) / vx
        a_r = -(x[X_VY] - p.a_r * x[X_R]) / vx
        return magic_formula_slope(a_f, *self._front), magic_formula_slope(a_r, *self._rear)

    def f(self, x, delta, vx):
        """``dx/dt`` of eq. (1) with the inert bias, and its Jacobian ``A`` (3, 3)."""
        p = self.design.params
        (Ff, dFf), (Fr, dFr) = self._tyres(x, delta, vx)
        # d alpha_f / d(v_y, r) = (-1, -a_f) / v_x;  d alpha_r / d(v_y, r) = (-1, a_r) / v_x
        dFf_dx = np.array([-dFf / vx, -dFf * p.a_f / vx, 0.0])
        dFr_dx = np.array([-dFr / vx, dFr * p.a_r / vx, 0.0])
        xdot = np.array([(Ff + Fr) / p.m - vx * x[X_R], (p.a_f * Ff - p.a_r * Fr) / p.I_z, 0.0])
        A = np.array([(dFf_dx + dFr_dx) / p.m - np.array([0.0, vx, 0.0]),
                      (p.a_f * dFf_dx - p.a_r * dFr_dx) / p.I_z,
                      np.zeros(3)])
        return xdot, A

    def rk4(self, x, delta, vx, h):
        """One RK4 step over ``h`` [s] with the inputs held, and its exact Jacobian ``F``:
        stage sensitivities ``J_1 = A(x)``, ``J_i = A(x_i) (I + c_i J_{i-1})``,
        ``F = I + h/6 (J_1 + 2 J_2 + 2 J_3 + J_4)`` (module docstring)."""
        I = np.eye(NX)
        k1, J1 = self.f(x, delta, vx)
        k2, A2 = self.f(x + 0.5 * h * k1, delta, vx)
        J2 = A2 @ (I + 0.5 * h * J1)
        k3, A3 = self.f(x + 0.5 * h * k2, delta, vx)
        J3 = A3 @ (I + 0.5 * h * J2)
        k4, A4 = self.f(x + h * k3, delta, vx)
        J4 = A4 @ (I + h * J3)
        return x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4), I + h / 6.0 * (
            J1 + 2.0 * J2 + 2.0 * J3 + J4)

    def h(self, x, delta, vx):
        """Measurement ``[r, (F_f + F_r)/m + b_ay]`` (or ``[r]``) and its Jacobian ``H``."""
        p = self.design.params
        (Ff, dFf), (Fr, dFr) = self._tyres(x, delta, vx)
        y = np.array([x[X_R], (Ff + Fr) / p.m + x[X_B]])
        H = np.array([[0.0, 1.0, 0.0],
                      [(-dFf / vx - dFr / vx) / p.m, (-dFf * p.a_f / vx + dFr * p.a_r / vx) / p.m,
                       1.0]])
        n = len(self.output_names)
        return y[:n], H[:n]

    def _prior(self, t, u, y, x0):
        """``(x0, P0)``: the documented default ``[0, y_0, 0]`` and the capped ``P0``."""
        x0 = _x0(y[0, 0]) if x0 is None else np.asarray(x0, dtype=float)
        P0 = np.diag(_p0(self.design.tuning.P0, SimpleNamespace(vx=u[:, 1])))
        return x0, P0

    def estimate(self, z):
        return z[:NX]

    @staticmethod
    def _pack(x, P):
        return np.concatenate([x, P.ravel()])

    @staticmethod
    def _unpack(z):
        return z[:NX], z[NX:].reshape(NX, NX)


class LateralEKF(_KalmanObserver):
    """Extended Kalman filter on the yaw-drift model of the module docstring, as an observer
    of :mod:`vehicle_observers.core.protocol`. Inputs ``u = [delta, v_x]`` (N, 2), outputs
    ``y = [r, a_y]`` (or ``[r]`` with ``use_ay=False``); internal state ``z = [x, vec(P)]``
    (12,). Sample ``k``: predict from ``k - 1`` (one RK4 step over ``t_k - t_{k-1}`` with the
    inputs of ``k - 1`` held, ``P <- F P F^T + diag(q) h``), then update with ``y_k`` (Joseph
    form). :meth:`run` is the numba kernel :func:`_ekf`."""

    def initial_state(self, t, u, y, x0=None):
        x, P = self._prior(t, u, y, x0)
        return self._pack(*self._update(x, P, y[0], u[0, 0], u[0, 1]))

    def _update(self, x, P, yk, delta, vx):
        """Kalman update with ``y_k``: ``K = P H^T S^-1``, ``x + K (y - h(x))``, Joseph form
        ``(I - K H) P (I - K H)^T + K R K^T``."""
        yhat, H = self.h(x, delta, vx)
        S = H @ P @ H.T + self._R
        K = P @ H.T @ np.linalg.inv(S)
        IKH = np.eye(NX) - K @ H
        return x + K @ (yk - yhat), IKH @ P @ IKH.T + K @ self._R @ K.T

    def step(self, z, k, t, u, y):
        """``z_k`` from ``z_{k-1}``: predict with the inputs of sample ``k - 1`` over
        ``h = t_k - t_{k-1}``, then update with ``y_k`` (inputs of sample ``k`` in ``h``)."""
        x, P = self._unpack(z)
        h = t[k] - t[k - 1]
        x, F = self.rk4(x, u[k - 1, 0], u[k - 1, 1], h)
        P = F @ P @ F.T + np.diag(self._q * h)
        return self._pack(*self._update(x, P, y[k], u[k, 0], u[k, 1]))

    def run(self, t, u, y, x0=None, store: bool = False) -> KalmanRun:
        """The numba EKF :func:`_ekf` over the samples (``store=True`` keeps the priors and
        Jacobians in ``info['Xp', 'Pp', 'Fs']`` for the smoother)."""
        return self._run_inputs(self._inputs(t, u, y, x0), store)

    def _run_inputs(self, inp: _Inputs, store: bool = False) -> KalmanRun:
        d = self.design
        args = (inp.t, inp.vx, inp.delta, inp.yr, inp.ay, inp.use_ay, d.params.as_array(),
                d.tuning.theta(), inp.x0, _p0(d.tuning.P0, inp), store, *inp.terms(d.params))
        t0 = time.perf_counter()
        Xf, Pf, Pfd, Xp, Pp, Fs, nll = _ekf_terms(*args)
        sec = time.perf_counter() - t0
        Ff, Fr = _forces(Xf, inp, d.params)
        P = Pf if store else np.einsum("ki,ij->kij", Pfd, np.eye(3))
        info = {"use_ay": inp.use_ay, "tuning": d.tuning}
        if store:
            info.update(Xp=Xp, Pp=Pp, Fs=Fs)
        return kalman_run("EKF", inp.t, Xf, P, Ff, Fr, nll, sec, True, info)


def ekf(log: DriveLog, params: LateralParams, tuning: KalmanTuning | None = None,
        use_ay: bool | None = None, store: bool = False,
        misalignment: bool = False) -> KalmanRun:
    """Numba EKF on ``log`` (see module docstring): :class:`LateralEKF` on the despiked
    inputs of :func:`prepare` (``misalignment``: a_y de-rotated by the unit's estimated yaw
    misalignment, then in ``info['psi_m']``). ``store=True`` keeps the priors and Jacobians
    (``info['Xp', 'Pp', 'Fs']``, ``P`` full) for the smoother."""
    tuning = tuning or KalmanTuning()
    inp = prepare(log, use_ay, misalignment=misalignment)
    out = LateralEKF(KalmanDesign(params, tuning, inp.use_ay))._run_inputs(inp, store)
    if inp.psi is not None:
        out.info["psi_m"] = inp.psi
    return out


def rts(log: DriveLog, params: LateralParams, tuning: KalmanTuning | None = None,
        use_ay: bool | None = None, misalignment: bool = False) -> KalmanRun:
    """Extended RTS smoother (offline, non-causal: ``causal=False``): EKF forward pass + RTS
    backward pass (Rauch, Tung & Striebel 1965); ``misalignment`` as in :func:`ekf`."""
    t0 = time.perf_counter()
    f = ekf(log, params, tuning, use_ay, store=True, misalignment=misalignment)
    Xs, Ps = _rts(f.X, f.P, f.info["Xp"], f.info["Pp"], f.info["Fs"])
    sec = time.perf_counter() - t0
    inp = prepare(log, use_ay, misalignment=misalignment)
    Ff, Fr = _forces(Xs, inp, params)
    info = {"use_ay": inp.use_ay, "tuning": f.info["tuning"]}
    if inp.psi is not None:
        info["psi_m"] = inp.psi
    return kalman_run("RTS", inp.t, Xs, Ps, Ff, Fr, float("nan"), sec, False, info)


def nll(log_or_inputs, params: LateralParams, tuning: KalmanTuning) -> float:
    """Innovation negative log-likelihood of the measured channels under ``tuning``."""
    inp = log_or_inputs if isinstance(log_or_inputs, _Inputs) else prepare(log_or_inputs)
    out = _ekf_terms(inp.t, inp.vx, inp.delta, inp.yr, inp.ay, inp.use_ay, params.as_array(),
                     tuning.theta(), inp.x0, _p0(tuning.P0, inp), False, *inp.terms(params))
    return float(out[-1])


def thin(log: DriveLog, every: int) -> DriveLog:
    """Every ``every``-th sample of the measured channels and of the bank column
    (:data:`vehicle_observers.models.road.BANK_COLUMNS`; no reference columns)."""
    idx = np.arange(0, len(log), int(every))
    c = bank_column(log)
    return DriveLog(t=log.t[idx], vx=log.vx[idx], delta=log.delta[idx],
                    yaw_rate=log.yaw_rate[idx], ay=None if log.ay is None else log.ay[idx],
                    extra={} if c is None else {c: log.extra[c][idx]},
                    source=f"{log.source} (every {every}th sample)" if every > 1 else log.source)


#: search box of the ML tuning, log10 of (q_vy, q_r, q_b, R_r, R_ay) (the order of
#: :meth:`KalmanTuning.theta`: :data:`Q_VY` ... :data:`R_AY`)
TUNE_BOUNDS = ((-8.0, 2.0), (-8.0, 1.0), (-6.0, 1.0), (-10.0, 0.0), (-6.0, 2.0))
#: names of the entries of :meth:`KalmanTuning.theta`, in its order
THETA_NAMES = ("q_vy", "q_r", "q_b", "R_r", "R_ay")


def _free(use_ay: bool) -> list[int]:
    """Tuned entries of theta: all five with a_y, else ``q_vy, q_r, R_r`` (b_ay is inert)."""
    return [Q_VY, Q_R, Q_B, R_R, R_AY] if use_ay else [Q_VY, Q_R, R_R]


#: measurement variances are bounded below by this share of the channel's white-noise
#: variance estimated from the data (second differences, robust): the estimate carries
#: 10-20 % error and some signal content, so half of it still keeps ML from collapsing
#: R to the search floor (R_r = 1e-10 on a 2e-3 rad/s gyro) while leaving it room.
NOISE_FLOOR_SHARE = 0.5


#: edge of the Nelder-Mead initial simplex of the ML tuning [decades]
SIMPLEX_STEP = 0.5


def noise_floors(log: DriveLog) -> dict:
    """Lower bounds ``{"R_r": ..., "R_ay": ...}`` [(rad/s)^2, (m/s^2)^2] of the measurement
    variances from the data: ``NOISE_FLOOR_SHARE * white_noise_std(channel)^2``
    (:func:`vehicle_observers.data.identification.white_noise_std`)."""
    out = {"R_r": NOISE_FLOOR_SHARE * white_noise_std(log.yaw_rate) ** 2}
    if log.ay is not None:
        out["R_ay"] = NOISE_FLOOR_SHARE * white_noise_std(log.ay) ** 2
    return out


def tune(log: DriveLog, params: LateralParams, start: KalmanTuning | None = None,
         use_ay: bool | None = None, window_s: float | None = None, max_rate_hz: float = 100.0,
         maxiter: int = 300, progress=None, noise_floor: bool = True) -> KalmanTuning:
    """Maximum-likelihood noise tuning on the measured channels only.

    Minimises the EKF innovation negative log-likelihood of the measured ``[r, a_y]``
    (or ``r`` alone) over ``log10`` of the five noise parameters (or three without a_y)
    inside :data:`TUNE_BOUNDS`, with Nelder-Mead (deterministic; initial simplex
    :data:`SIMPLEX_STEP` decades) from two starts, the better optimum kept: with
    ``noise_floor``, ``start`` with ``R`` at the data's own noise level and ``start`` itself;
    without, ``start`` and ``start`` with ``q_b = 1e-5``. The two run in parallel threads.
    (A third start, ``q_b = 1e-5`` beside the other two, never improved on them on the Revs
    log, the three plant manoeuvres or the emulated Satory log.) Reads only
    ``t, v_x, delta, r, a_y``: the reference ``v_y``/force columns are never used, so the
    same call applies to any car's log.

    ``window_s``: tune on the first ``window_s`` seconds only (``None``: the whole log).
    ``max_rate_hz``: faster logs are thinned to at most this rate before tuning (the
    objective costs one EKF pass per evaluation). Thinning a log by dropping samples leaves
    the per-sample variance of white sensor noise unchanged and ``q`` is per second, so the
    tuned values apply unchanged at the full rate. Tolerances: 0.01 in log10 of the
    parameters (2 %), 0.05 in NLL. ``progress(i, n)`` is called after each evaluation.

    ``noise_floor=True``: the lower search bounds of ``R_r`` and ``R_ay`` are raised to
    :func:`noise_floors` of the (thinned) tuning window, so the measurement noise cannot
    collapse below what the data itself shows (:func:`tuning_report` says which parameters
    end on a bound and which are poorly determined).
    """
    start = start or KalmanTuning()
    # without the floor: the given start and the same with a nearly constant a_y offset (the
    # likelihood has a second basin where b_ay soaks up the a_y noise)
    starts = [start, replace(start, q_b=1e-5)]
    if window_s is not None:
        log = log.segment(log.t[0], log.t[0] + float(window_s))
    every = max(1, int(np.floor(1.0 / (log.dt * max_rate_hz) + 1e-9)))
    log = thin(log, every)
    if noise_floor:
        # a start at the data's own noise level first: the likelihood is multimodal and a
        # start clipped onto the floor can fall into a poorer basin
        fl = {k: v / NOISE_FLOOR_SHARE for k, v in noise_floors(log).items()}
        starts = [replace(start, **fl), start]
    inp = prepare(log, use_ay)
    Parr = params.as_array()
    P0 = _p0(start.P0, inp)
    terms = inp.terms(params)
    free = _free(inp.use_ay)
    bounds = [tuple(b) for b in TUNE_BOUNDS]
    if noise_floor:
        for i, v in zip((R_R, R_AY), noise_floors(log).values()):
            bounds[i] = (min(max(bounds[i][0], float(np.log10(v))), bounds[i][1] - 0.5),
                         bounds[i][1])
    bounds = [bounds[i] for i in free]
    th0 = start.theta()

    count = [0]

    def f(z):
        count[0] += 1
        if progress is not None:
            progress(min(count[0], 2 * maxiter), 2 * maxiter)
        th = th0.copy()
        th[free] = 10.0 ** z
        v = _ekf_terms(inp.t, inp.vx, inp.delta, inp.yr, inp.ay, inp.use_ay, Parr, th, inp.x0,
                       P0, False, *terms)[-1]
        return v if np.isfinite(v) else 1e300

    lo, hi = np.array([b[0] for b in bounds]), np.array([b[1] for b in bounds])

    from scipy.optimize import minimize  # imported here: it costs 0.5 s of start-up

    def solve(s):
        # initial simplex SIMPLEX_STEP decades along each axis (towards the inside of the
        # box): scipy's default (5 % of each coordinate) is 0.24 decades for R_r but 0.005
        # for R_ay, and two of three starts then stop in poor optima on the Revs log
        z0 = np.clip(np.log10(s.theta()[free]), lo, hi)
        sim = [z0]
        for i in range(len(z0)):
            z = z0.copy()
            z[i] += SIMPLEX_STEP if z0[i] + SIMPLEX_STEP <= hi[i] else -SIMPLEX_STEP
            sim.append(z)
        return minimize(f, z0, method="Nelder-Mead", bounds=bounds,
                        options={"maxiter": maxiter, "xatol": 1e-2, "fatol": 0.05,
                                 "initial_simplex": np.array(sim)})

    # the starts are independent: one thread each (the kernel releases the GIL); the result
    # does not depend on the thread count (the first of equal optima in start order wins)
    with ThreadPoolExecutor(max_workers=max(1, min(len(starts), os.cpu_count() or 1))) as ex:
        found = list(ex.map(solve, starts))
    res = min(found, key=lambda r: r.fun)
    th = th0.copy()
    th[free] = 10.0 ** res.x
    return KalmanTuning.from_theta(
        th, P0=start.P0,
        source=f"ML on measured channels of {log.source} ({len(inp.t)} samples, "
               f"{'r, a_y' if inp.use_ay else 'r'}; nll={res.fun:.6g}, {res.nit} iterations)")


#: search interval of :func:`fit_stiffness_speed` [s/m] (+-0.02: the stiffness factor
#: changes by 40 % over 20 m/s at the ends)
STIFFNESS_SPEED_BOUNDS = (-0.02, 0.02)


def fit_stiffness_speed(log: DriveLog, params: LateralParams, tuning: KalmanTuning,
                        bounds=STIFFNESS_SPEED_BOUNDS, xatol: float = 1e-4) -> tuple[float, float]:
    """Maximum-likelihood speed gain ``k_s`` [s/m] of the cornering stiffness, ``C(v_x) = C
    (1 + k_s v_x)`` (:class:`~vehicle_observers.models.lateral.LateralParams`
    ``stiffness_speed``): the EKF innovation negative log-likelihood of the measured
    channels (:func:`nll`, noise ``tuning`` held) minimised over ``bounds`` by bounded Brent
    (``xatol`` [s/m]). Reads ``t, v_x, delta, r, a_y`` (and a bank column) only: never the
    reference. Returns ``(k_s, nll(k_s) - nll(0))`` (negative: the data prefer ``k_s``)."""
    from scipy.optimize import minimize_scalar

    inp = prepare(log)

    def f(k):
        v = nll(inp, replace(params, stiffness_speed=float(k)), tuning)
        return v if np.isfinite(v) else 1e300

    res = minimize_scalar(f, bounds=tuple(bounds), method="bounded",
                          options={"xatol": float(xatol)})
    return float(res.x), float(res.fun - f(0.0))


def tuning_report(log: DriveLog, params: LateralParams, tuning: KalmanTuning,
                  window_s: float | None = None, max_rate_hz: float = 100.0,
                  step: float = 0.05, poorly: float = 0.5) -> dict:
    """Identifiability of a noise tuning: the NLL Hessian in ``log10`` of the free
    parameters by central differences (``step`` decades), ``std_log10 = sqrt(diag(H^-1))``,
    the parameters on a search bound (:data:`TUNE_BOUNDS` or the data floor of
    :func:`noise_floors`) and those with ``std_log10 > poorly`` (more than a factor
    ``10**poorly`` undetermined) or in a direction of a non-positive Hessian eigenvalue.
    Returns ``{"names", "value", "std_log10", "at_bound", "not_identifiable", "floors",
    "eig"}``."""
    if window_s is not None:
        log = log.segment(log.t[0], log.t[0] + float(window_s))
    every = max(1, int(np.floor(1.0 / (log.dt * max_rate_hz) + 1e-9)))
    log = thin(log, every)
    inp = prepare(log)
    names = list(THETA_NAMES)
    free = _free(inp.use_ay)
    th0 = tuning.theta()
    z0 = np.log10(th0[free])
    Parr, P0 = params.as_array(), _p0(tuning.P0, inp)

    def f(z):
        th = th0.copy()
        th[free] = 10.0 ** z
        return float(_ekf(inp.t, inp.vx, inp.delta, inp.yr, inp.ay, inp.use_ay, Parr, th,
                          inp.x0, P0, False)[-1])

    n = len(free)
    E = np.eye(n) * step
    f0 = f(z0)
    H = np.empty((n, n))
    for i in range(n):
        H[i, i] = (f(z0 + E[i]) - 2 * f0 + f(z0 - E[i])) / step**2
    for i, j in ((a, b) for a in range(n) for b in range(a + 1, n)):
        H[i, j] = H[j, i] = (f(z0 + E[i] + E[j]) - f(z0 + E[i] - E[j]) - f(z0 - E[i] + E[j])
                             + f(z0 - E[i] - E[j])) / (4 * step**2)
    w, V = np.linalg.eigh(H)
    floors = noise_floors(log)
    lo = [b[0] for b in TUNE_BOUNDS]
    hi = [b[1] for b in TUNE_BOUNDS]
    for i, k in ((R_R, "R_r"), (R_AY, "R_ay")):
        if k in floors:
            lo[i] = max(lo[i], float(np.log10(floors[k])))
    at_bound = [names[i] for i, z in zip(free, z0) if z - lo[i] < 0.05 or hi[i] - z < 0.05]
    if np.all(w > 0):
        sd = np.sqrt(np.diag(np.linalg.inv(H)))
        weak = [names[i] for i, s_ in zip(free, sd) if s_ > poorly]
    else:
        sd = np.full(n, np.inf)
        weak = sorted({names[free[k]] for k in np.flatnonzero(np.abs(V[:, w <= 0]).max(axis=1)
                                                               > 0.3)})
    return {"names": [names[i] for i in free], "value": th0[free], "std_log10": sd,
            "at_bound": at_bound, "not_identifiable": weak, "floors": floors, "eig": w}


# ------------------------------------------------------------------ filterpy ------------
def _filterpy_models(inp: _Inputs, params: LateralParams):
    Parr = params.as_array()
    state = {"k": 0}
    # scratch of the UKF's per-sigma-point calls (filterpy copies fx's result into its
    # sigma array at once, so one buffer serves every call)
    F_, W_, V_, xn_ = np.empty((3, 3)), np.empty((6, 3, 3)), np.empty((5, 3)), np.empty(3)

    def fx(x, dt):
        k = state["k"]
        _rk4_ws(x, inp.delta[k], inp.vx[k], dt, Parr, xn_, F_, W_, V_)
        return xn_

    def jac(x, dt):
        k = state["k"]
        xn = np.empty(3)
        F = np.empty((3, 3))
        _rk4(np.asarray(x, float), inp.delta[k], inp.vx[k], dt, Parr, xn, F)
        return xn, F

    def hx(x):
        k = state["k"]
        y = np.empty(2)
        H = np.empty((2, 3))
        _meas(np.asarray(x, float), inp.delta[k], inp.vx[k], Parr, inp.use_ay, y, H)
        return y if inp.use_ay else y[:1]

    def Hj(x):
        k = state["k"]
        y = np.empty(2)
        H = np.empty((2, 3))
        _meas(np.asarray(x, float), inp.delta[k], inp.vx[k], Parr, inp.use_ay, y, H)
        return H if inp.use_ay else H[:1]

    return state, fx, jac, hx, Hj


def ekf_filterpy(log: DriveLog, params: LateralParams, tuning: KalmanTuning | None = None,
                 use_ay: bool | None = None, progress=None) -> KalmanRun:
    """The same EKF with ``filterpy.kalman.ExtendedKalmanFilter`` (update, then a predict
    whose mean is the RK4 step and whose ``F`` is its Jacobian). Pure Python per step."""
    from filterpy.kalman import ExtendedKalmanFilter

    tuning = tuning or KalmanTuning()
    inp = prepare(log, use_ay)
    state, fx, jac, hx, Hj = _filterpy_models(inp, params)
    dz = 2 if inp.use_ay else 1
    kf = ExtendedKalmanFilter(dim_x=3, dim_z=dz)
    kf.x = inp.x0.copy()
    kf.P = np.diag(_p0(tuning.P0, inp))
    kf.R = np.diag([tuning.R_r, tuning.R_ay][:dz])
    q = LateralEKF(KalmanDesign(params, tuning, inp.use_ay))._q
    N = len(inp.t)
    X = np.empty((N, 3))
    P = np.empty((N, 3, 3))
    z = np.column_stack([inp.yr, inp.ay])[:, :dz]
    t0 = time.perf_counter()
    for k in range(N):
        if progress is not None and k % 2000 == 0:
            progress(k, N)
        state["k"] = k
        kf.update(z[k], Hj, hx)
        X[k] = kf.x
        P[k] = kf.P
        if k + 1 < N:
            h = inp.t[k + 1] - inp.t[k]
            xn, F = jac(kf.x, h)
            kf.F = F
            kf.Q = np.diag(q * h)
            kf.P = F @ kf.P @ F.T + kf.Q
            kf.x = xn
    sec = time.perf_counter() - t0
    Ff, Fr = _forces(X, inp, params)
    return kalman_run("EKF (filterpy)", inp.t, X, P, Ff, Fr, float("nan"), sec, True,
                {"use_ay": inp.use_ay, "tuning": tuning})


#: eigenvalue floor of :func:`nearest_spd`, relative to the largest eigenvalue
SPD_FLOOR = 1e-12


def nearest_spd(P, floor: float = SPD_FLOOR):
    """Symmetrise ``P`` and floor its eigenvalues at ``floor`` x its largest one so that
    ``cholesky`` succeeds. Returns ``(P_new, repaired)`` (``repaired``: an eigenvalue was
    raised)."""
    S = 0.5 * (P + P.T)
    w, V = np.linalg.eigh(S)
    lo = floor * max(float(w.max()), 1e-300)
    if w.min() >= lo:
        return S, False
    w = np.maximum(w, lo)
    S = (V * w) @ V.T
    return 0.5 * (S + S.T), True


@njit(cache=True)
def _sym_eig_extremes(A):
    """Smallest and largest eigenvalue of a symmetric 3x3 matrix in closed form
    (trigonometric solution of the characteristic cubic; absolute error ~1e-16 ||A||)."""
    p1 = A[0, 1] * A[0, 1] + A[0, 2] * A[0, 2] + A[1, 2] * A[1, 2]
    q = (A[0, 0] + A[1, 1] + A[2, 2]) / 3.0
    if p1 == 0.0:
        return min(A[0, 0], A[1, 1], A[2, 2]), max(A[0, 0], A[1, 1], A[2, 2])
    b00, b11, b22 = A[0, 0] - q, A[1, 1] - q, A[2, 2] - q
    p = np.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * p1) / 6.0)
    det = (b00 * (b11 * b22 - A[1, 2] * A[1, 2]) - A[0, 1] * (A[0, 1] * b22 - A[1, 2] * A[0, 2])
           + A[0, 2] * (A[0, 1] * A[1, 2] - b11 * A[0, 2]))
    r = min(max(det / (2.0 * p * p * p), -1.0), 1.0)
    phi = np.arccos(r) / 3.0
    return q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0), q + 2.0 * p * np.cos(phi)


@njit(cache=True)
def nearest_spd_kernel(P, floor):
    """Kernel of :func:`vehicle_observers.baselines.kalman.nearest_spd`: ``(P + P^T) / 2``
    with its eigenvalues floored at ``floor`` x the largest. Returns ``(P_new, repaired)``.
    The eigenvalues are taken in closed form; near the floor (within x100, where that form's
    round-off could flip the decision) and for a repair LAPACK's ``eigh`` is used, as in the
    reference."""
    S = 0.5 * (P + P.T)
    wmin, wmax = _sym_eig_extremes(S)
    if wmin >= 100.0 * floor * max(wmax, 1e-300):
        return S, False
    w, V = np.linalg.eigh(S)
    lo = floor * max(w.max(), 1e-300)
    if w.min() >= lo:
        return S, False
    for i in range(w.shape[0]):
        w[i] = max(w[i], lo)
    S = (V * w) @ V.T
    return 0.5 * (S + S.T), True


class LateralUKF(_KalmanObserver):
    """Unscented Kalman filter on the yaw-drift model (Julier & Uhlmann; Merwe scaled sigma
    points ``alpha, beta, kappa``, Van der Merwe 2004) with the same RK4-discretised model,
    noise and order as :class:`LateralEKF`; after each predict and update ``P`` is
    re-symmetrised and its eigenvalues floored (:func:`nearest_spd`). :meth:`run` is
    ``filterpy.kalman.UnscentedKalmanFilter`` (Python per step); :meth:`step` the same
    filter in plain numpy. Internal state ``z = [x, vec(P)]`` (12,)."""

    def __init__(self, design: KalmanDesign, alpha: float = 0.1, beta: float = 2.0,
                 kappa: float = 0.0):
        super().__init__(design)
        for name, v in (("alpha", alpha), ("beta", beta), ("kappa", kappa)):
            if not np.isfinite(v):
                raise ObserverArgumentError(f"LateralUKF: {name} must be finite, got {v}")
        if not alpha > 0:
            raise ObserverArgumentError(f"LateralUKF: alpha must be > 0, got {alpha}")
        self.alpha, self.beta, self.kappa = float(alpha), float(beta), float(kappa)
        n = NX
        lam = alpha**2 * (n + kappa) - n
        self._lam = lam
        self._Wm = np.full(2 * n + 1, 0.5 / (n + lam))
        self._Wc = self._Wm.copy()
        self._Wm[0] = lam / (n + lam)
        self._Wc[0] = lam / (n + lam) + (1.0 - alpha**2 + beta)

    # ---- the unscented transform, readable numpy ------------------------------------
    def sigma_points(self, x, P):
        """``2n + 1`` Merwe points: ``x``, ``x +- U_i`` with ``U^T U = (n + lambda) P``."""
        U = np.linalg.cholesky((NX + self._lam) * P).T
        return np.vstack([x, x + U, x - U])

    def _ut(self, sigmas, noise):
        """Weighted mean and covariance of the points, plus the noise covariance."""
        mean = self._Wm @ sigmas
        d = sigmas - mean
        return mean, d.T @ np.diag(self._Wc) @ d + noise

    def _update(self, x, P, sigmas, yk, delta, vx):
        """Measurement update with the state points ``sigmas`` (filterpy's order)."""
        Y = np.array([self.h(s, delta, vx)[0] for s in sigmas])
        yp, S = self._ut(Y, self._R)
        Pxy = (sigmas - x).T @ np.diag(self._Wc) @ (Y - yp)
        K = Pxy @ np.linalg.inv(S)
        return x + K @ (yk - yp), nearest_spd(P - K @ S @ K.T)[0]

    def initial_state(self, t, u, y, x0=None):
        x, P = self._prior(t, u, y, x0)
        return self._pack(*self._update(x, P, self.sigma_points(x, P), y[0], u[0, 0], u[0, 1]))

    def step(self, z, k, t, u, y):
        """Predict the points of ``z_{k-1}`` through the RK4 step (inputs of ``k - 1``,
        ``h = t_k - t_{k-1}``, ``Q = diag(q) h``), redraw points at the prior (as filterpy
        does), repair ``P``, then update with ``y_k``."""
        x, P = self._unpack(z)
        h = t[k] - t[k - 1]
        Xf = np.array([self.rk4(s, u[k - 1, 0], u[k - 1, 1], h)[0]
                       for s in self.sigma_points(x, P)])
        x, P = self._ut(Xf, np.diag(self._q * h))
        sigmas = self.sigma_points(x, P)
        P = nearest_spd(P)[0]
        return self._pack(*self._update(x, P, sigmas, y[k], u[k, 0], u[k, 1]))

    def run(self, t, u, y, x0=None, progress=None) -> KalmanRun:
        """``filterpy``'s UKF over the samples (``progress(k, N)`` every 2000 steps);
        ``info['spd_repairs']`` counts the covariance repairs."""
        return self._run_inputs(self._inputs(t, u, y, x0), progress)

    def _run_inputs(self, inp: _Inputs, progress=None) -> KalmanRun:
        from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter


        d = self.design
        state, fx, jac, hx, Hj = _filterpy_models(inp, d.params)
        dz = len(self.output_names)
        pts = MerweScaledSigmaPoints(NX, alpha=self.alpha, beta=self.beta, kappa=self.kappa)
        dt0 = float(np.median(np.diff(inp.t))) if len(inp.t) > 1 else 0.01
        kf = UnscentedKalmanFilter(dim_x=NX, dim_z=dz, dt=dt0, hx=hx, fx=fx, points=pts)
        kf.x = inp.x0.copy()
        kf.P = np.diag(_p0(d.tuning.P0, inp))
        kf.R = self._R
        q = self._q
        N = len(inp.t)
        X = np.empty((N, NX))
        P = np.empty((N, NX, NX))
        z = np.column_stack([inp.yr, inp.ay])[:, :dz]
        repairs = 0
        t0 = time.perf_counter()
        # filterpy's UKF predicts from the stored sigma points of the last update, so the
        # sequence is predict(k-1 -> k) then update(k); the first sample is updated directly.
        kf.sigmas_f = pts.sigma_points(kf.x, kf.P)  # the prior at k = 0 is (x0, P0)
        h_q = None
        # P is repaired between filterpy's steps by the compiled kernel (the same decision
        # and result as nearest_spd; the Python one was a fifth of the loop's time)
        for k in range(N):
            if progress is not None and k % 2000 == 0:
                progress(k, N)
            if k > 0:
                h = inp.t[k] - inp.t[k - 1]
                state["k"] = k - 1
                if h != h_q:                        # Q = diag(q) h, rebuilt when h changes
                    kf.Q, h_q = np.diag(q * h), h
                kf.predict(dt=h)
                kf.P, fixed = nearest_spd_kernel(kf.P, SPD_FLOOR)
                repairs += fixed
            state["k"] = k
            if k == 0:
                kf.sigmas_f = pts.sigma_points(kf.x, kf.P)
            kf.update(z[k])
            kf.P, fixed = nearest_spd_kernel(kf.P, SPD_FLOOR)
            repairs += fixed
            X[k] = kf.x
            P[k] = kf.P
        sec = time.perf_counter() - t0
        Ff, Fr = _forces(X, inp, d.params)
        return kalman_run("UKF (filterpy)", inp.t, X, P, Ff, Fr, float("nan"), sec, True,
                    {"use_ay": inp.use_ay, "tuning": d.tuning, "spd_repairs": repairs})


def ukf_filterpy(log: DriveLog, params: LateralParams, tuning: KalmanTuning | None = None,
                 use_ay: bool | None = None, alpha: float = 0.1, beta: float = 2.0,
                 kappa: float = 0.0, progress=None) -> KalmanRun:
    """``filterpy`` UKF (:class:`LateralUKF`, Merwe scaled sigma points ``alpha, beta,
    kappa``) on the despiked inputs of :func:`prepare` (sigma points through the RK4 step;
    ``progress(k, N)`` is called every 2000 steps). After each predict and update, P is
    re-symmetrised and its eigenvalues floored (:func:`nearest_spd`);
    ``info['spd_repairs']`` counts the repairs."""
    tuning = tuning or KalmanTuning()
    inp = prepare(log, use_ay)
    obs = LateralUKF(KalmanDesign(params, tuning, inp.use_ay), alpha, beta, kappa)
    return obs._run_inputs(inp, progress)


def with_tuning(res: KalmanRun, tuning: KalmanTuning) -> KalmanRun:
    return replace(res, info={**res.info, "tuning": tuning})
