"""The two reference estimators of the campaign reports, registered like any estimator.

Both use the *linear* single-track (bicycle) model of the vehicle file: the tyres' slopes at
zero slip ``C_f, C_r`` [N/rad] (:attr:`vehicle_observers.models.vehicle.Vehicle.C_f`), state
``x = [v_y, r]`` (m/s, rad/s), inputs speed ``v_x`` and road-wheel angle ``delta``:

    A(v_x) = [[-(C_f + C_r)/(m v_x),         -(a_f C_f - a_r C_r)/(m v_x) - v_x],
              [-(a_f C_f - a_r C_r)/(I_z v_x), -(a_f^2 C_f + a_r^2 C_r)/(I_z v_x)]],
    B = [C_f/m, a_f C_f/I_z]^T

(Rajamani, *Vehicle Dynamics and Control*, eq. (2.31); Ifqir 2017 (3) at the nominal
stiffness). Discretisation between samples ``k-1`` and ``k`` (``h = t_k - t_{k-1}``, inputs
held at sample ``k-1``): ``n = max(1, ceil(h ||A||_inf))`` classical RK4 steps of the linear
ODE, i.e. ``x_k = Phi x_{k-1} + Gamma delta_{k-1}`` with ``M = I + hA + (hA)^2/2 + (hA)^3/6 +
(hA)^4/24`` per substep of length ``h/n`` (one RK4 step per sample, as the EKF, whenever it is
stable; more at low speed, where the poles grow like ``1/v_x``).

* ``open-loop-linear``: that model driven by the measured steering and speed from
  ``v_y = 0`` and the first measured yaw rate, no measurement feedback: the floor any
  observer must beat (the benchmark's reference, ``benchmark_study.open_loop_linear``).
* ``linear-kf``: the linear Kalman filter on the same model with the state ``b`` (offset of
  the lateral accelerometer, random walk), measuring ``y = [r, a_y]`` with
  ``a_y = (F_f + F_r)/m + b``, linear forces ``F_f = C_f alpha_f``, ``F_r = C_r alpha_r``:
  ``H = [[0, 1, 0], [-(C_f+C_r)/(m v_x), -(a_f C_f - a_r C_r)/(m v_x), 1]]``, feed-through
  ``C_f/m delta``. Noise as the EKF (:class:`~vehicle_observers.models.vehicle.KalmanTuning`
  of the vehicle file, else its defaults): ``Q = diag(q_vy, q_r, q_b) h``, ``R = diag(R_r,
  R_ay)``; initial ``x = [0, r_0, 0]``, ``P_0`` with the ``v_y`` variance capped at
  ``(0.05 v_x(0))^2`` (:func:`vehicle_observers.baselines.kalman._p0`); update with ``y_k``
  then predict (the EKF's order), Joseph-form covariance update.

Each is an :class:`~vehicle_observers.core.protocol.ObserverBase` with a readable numpy
``step`` and a compiled ``run`` (tested equal), registered with
:func:`~vehicle_observers.estimation.registry.register_observer`.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit

from vehicle_observers.core.protocol import ObserverBase
from vehicle_observers.estimation.registry import register_observer
from vehicle_observers.models.vehicle import KalmanTuning

#: cap of the initial sideslip standard deviation [rad] (that of the EKF)
BETA0_STD = 0.05


def bicycle_constants(vehicle) -> np.ndarray:
    """``[m, I_z, a_f, a_r, C_f, C_r]`` of a vehicle file (the linear model's constants)."""
    p = vehicle.params
    return np.array([p.m, p.I_z, p.a_f, p.a_r, vehicle.C_f, vehicle.C_r], dtype=float)


def linear_ab(c, vx):
    """``(A (2, 2), B (2,))`` of the module docstring at speed ``vx`` [m/s]."""
    m, Iz, af, ar, Cf, Cr = c
    return (np.array([[-(Cf + Cr) / (m * vx), -(af * Cf - ar * Cr) / (m * vx) - vx],
                      [-(af * Cf - ar * Cr) / (Iz * vx), -(af * af * Cf + ar * ar * Cr) / (Iz * vx)]]),
            np.array([Cf / m, af * Cf / Iz]))


def discretise(A, B, h):
    """``(Phi, Gamma)`` of ``n`` RK4 substeps (module docstring), numpy."""
    n = max(1, math.ceil(h * float(np.max(np.abs(A).sum(axis=1)))))
    hs = h / n
    I = np.eye(2)
    hA = hs * A
    hA2 = hA @ hA
    hA3 = hA2 @ hA
    M = I + hA + hA2 / 2.0 + hA3 / 6.0 + hA3 @ hA / 24.0
    g = hs * ((I + hA / 2.0 + hA2 / 6.0 + hA3 / 24.0) @ B)
    Phi, Gam = I.copy(), np.zeros(2)
    for _ in range(n):
        Gam = M @ Gam + g
        Phi = M @ Phi
    return Phi, Gam


@njit(cache=True)
def _discretise(c, vx, h):
    """Compiled :func:`discretise` of :func:`linear_ab` (scalars; same operation order)."""
    m, Iz, af, ar, Cf, Cr = c[0], c[1], c[2], c[3], c[4], c[5]
    a00 = -(Cf + Cr) / (m * vx)
    a01 = -(af * Cf - ar * Cr) / (m * vx) - vx
    a10 = -(af * Cf - ar * Cr) / (Iz * vx)
    a11 = -(af * af * Cf + ar * ar * Cr) / (Iz * vx)
    b0, b1 = Cf / m, af * Cf / Iz
    n = max(1, int(math.ceil(h * max(abs(a00) + abs(a01), abs(a10) + abs(a11)))))
    hs = h / n
    A = np.array([[hs * a00, hs * a01], [hs * a10, hs * a11]])
    A2 = _mm(A, A)
    A3 = _mm(A2, A)
    A4 = _mm(A3, A)
    M = np.empty((2, 2))
    T = np.empty((2, 2))
    for i in range(2):
        for j in range(2):
            d = 1.0 if i == j else 0.0
            M[i, j] = d + A[i, j] + A2[i, j] / 2.0 + A3[i, j] / 6.0 + A4[i, j] / 24.0
            T[i, j] = d + A[i, j] / 2.0 + A2[i, j] / 6.0 + A3[i, j] / 24.0
    g0 = hs * (T[0, 0] * b0 + T[0, 1] * b1)
    g1 = hs * (T[1, 0] * b0 + T[1, 1] * b1)
    Phi = np.eye(2)
    G0, G1 = 0.0, 0.0
    for _ in range(n):
        G0, G1 = M[0, 0] * G0 + M[0, 1] * G1 + g0, M[1, 0] * G0 + M[1, 1] * G1 + g1
        Phi = _mm(M, Phi)
    return Phi, G0, G1


@njit(cache=True)
def _mm(X, Y):
    """Small matrix product with the summation order of numpy's ``@`` on 2x2 / 3x3."""
    n, k, p = X.shape[0], X.shape[1], Y.shape[1]
    Z = np.zeros((n, p))
    for i in range(n):
        for j in range(p):
            s = 0.0
            for q in range(k):
                s += X[i, q] * Y[q, j]
            Z[i, j] = s
    return Z


@njit(cache=True)
def _mv(X, v):
    """Matrix-vector product with numpy's summation order (left to right)."""
    out = np.zeros(X.shape[0])
    for i in range(X.shape[0]):
        s = 0.0
        for q in range(X.shape[1]):
            s += X[i, q] * v[q]
        out[i] = s
    return out


# ------------------------------------------------------------------ open loop -------------
class OpenLoopBicycle(ObserverBase):
    """Open-loop linear bicycle (module docstring); ``z = [v_y, r]``. The yaw-rate channel
    is read at sample 0 only (initial ``r``)."""

    state_names = ("vy_mps", "yaw_rate_radps")
    input_names = ("vx_mps", "delta_roadwheel_rad")
    output_names = ("yaw_rate_radps",)

    def __init__(self, vehicle):
        self.design = None
        self.c = bicycle_constants(vehicle)

    def initial_state(self, t, u, y, x0=None):
        return np.array([0.0, float(y[0, 0])]) if x0 is None else np.asarray(x0, float).copy()

    def step(self, z, k, t, u, y):
        A, B = linear_ab(self.c, u[k - 1, 0])
        Phi, Gam = discretise(A, B, t[k] - t[k - 1])
        return Phi @ z + Gam * u[k - 1, 1]

    def estimate(self, z):
        return np.asarray(z, float)

    def run(self, t, u, y, x0=None):
        t, u, y, x0 = self.check_data(t, u, y, x0)
        z0 = self.initial_state(t, u, y, x0)
        t0 = time.perf_counter()
        X = _open_loop(t, u, z0, self.c)
        return self.trajectory(t, X, seconds=time.perf_counter() - t0)


@njit(cache=True)
def _open_loop(t, u, z0, c):
    N = t.shape[0]
    X = np.empty((N, 2))
    X[0, 0], X[0, 1] = z0[0], z0[1]
    for k in range(1, N):
        Phi, G0, G1 = _discretise(c, u[k - 1, 0], t[k] - t[k - 1])
        d = u[k - 1, 1]
        x0, x1 = X[k - 1, 0], X[k - 1, 1]
        X[k, 0] = Phi[0, 0] * x0 + Phi[0, 1] * x1 + G0 * d
        X[k, 1] = Phi[1, 0] * x0 + Phi[1, 1] * x1 + G1 * d
    return X


# ------------------------------------------------------------------ linear Kalman filter ---
class LinearKalman(ObserverBase):
    """Linear Kalman filter (module docstring); ``z = [v_y, r, b, vec(P) (9)]``."""

    state_names = ("vy_mps", "yaw_rate_radps", "ay_bias_mps2")
    input_names = ("vx_mps", "delta_roadwheel_rad")
    output_names = ("yaw_rate_radps", "ay_mps2")

    def __init__(self, vehicle, tuning: KalmanTuning | None = None):
        self.design = None
        self.c = bicycle_constants(vehicle)
        self.tuning = tuning or vehicle.kalman or KalmanTuning()
        self.theta = self.tuning.theta()

    def _h(self, vx):
        m, Iz, af, ar, Cf, Cr = self.c
        return (np.array([[0.0, 1.0, 0.0],
                          [-(Cf + Cr) / (m * vx), -(af * Cf - ar * Cr) / (m * vx), 1.0]]),
                np.array([0.0, Cf / m]))

    def _update(self, x, P, k, u, y):
        H, D = self._h(u[k, 0])
        R = np.diag(self.theta[3:5])
        e = y[k] - (H @ x + D * u[k, 1])
        S = H @ P @ H.T + R
        det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
        K = P @ H.T @ (np.array([[S[1, 1], -S[0, 1]], [-S[1, 0], S[0, 0]]]) / det)
        x = x + K @ e
        IKH = np.eye(3) - K @ H
        return x, IKH @ P @ IKH.T + K @ R @ K.T

    def initial_state(self, t, u, y, x0=None):
        x = np.array([0.0, float(y[0, 0]), 0.0]) if x0 is None else np.asarray(x0, float).copy()
        p0 = np.array(self.tuning.P0, dtype=float)
        p0[0] = min(p0[0], (BETA0_STD * float(u[0, 0])) ** 2)
        x, P = self._update(x, np.diag(p0), 0, u, y)
        return np.concatenate([x, P.ravel()])

    def step(self, z, k, t, u, y):
        x, P = z[:3], z[3:].reshape(3, 3)
        h = t[k] - t[k - 1]
        A, B = linear_ab(self.c, u[k - 1, 0])
        Phi2, Gam = discretise(A, B, h)
        F = np.eye(3)
        F[:2, :2] = Phi2
        x = F @ x + np.r_[Gam, 0.0] * u[k - 1, 1]
        P = F @ P @ F.T + np.diag(self.theta[:3]) * h
        x, P = self._update(x, P, k, u, y)
        return np.concatenate([x, P.ravel()])

    def estimate(self, z):
        return np.asarray(z[:3], float)

    def run(self, t, u, y, x0=None):
        t, u, y, x0 = self.check_data(t, u, y, x0)
        z0 = self.initial_state(t, u, y, x0)
        t0 = time.perf_counter()
        X = _lkf(t, u, y, z0, self.c, self.theta)
        return self.trajectory(t, X, seconds=time.perf_counter() - t0)


@njit(cache=True)
def _mm_into(X, Y, out):
    """``out = X @ Y`` (small matrices, summation left to right, no allocation)."""
    for i in range(X.shape[0]):
        for j in range(Y.shape[1]):
            s = 0.0
            for q in range(X.shape[1]):
                s += X[i, q] * Y[q, j]
            out[i, j] = s


@njit(cache=True)
def _mmt_into(X, Y, out):
    """``out = X @ Y.T`` (no allocation)."""
    for i in range(X.shape[0]):
        for j in range(Y.shape[0]):
            s = 0.0
            for q in range(X.shape[1]):
                s += X[i, q] * Y[j, q]
            out[i, j] = s


@njit(cache=True)
def _lkf(t, u, y, z0, c, theta):
    """Compiled :meth:`LinearKalman.step` loop (same operations; work arrays allocated once;
    the 2x2 innovation covariance inverted in closed form)."""
    N = t.shape[0]
    X = np.empty((N, 3))
    x = z0[:3].copy()
    P = np.ascontiguousarray(z0[3:]).reshape(3, 3).copy()
    X[0] = x
    m, af, ar, Cf, Cr = c[0], c[2], c[3], c[4], c[5]
    F = np.eye(3)
    H = np.zeros((2, 3))
    H[0, 1] = 1.0
    H[1, 2] = 1.0
    T3 = np.empty((3, 3))
    T32 = np.empty((3, 2))
    T23 = np.empty((2, 3))
    S = np.empty((2, 2))
    Si = np.empty((2, 2))
    K = np.empty((3, 2))
    KR = np.empty((3, 2))
    IKH = np.empty((3, 3))
    e = np.empty(2)
    xp = np.empty(3)
    for k in range(1, N):
        h = t[k] - t[k - 1]
        Phi, G0, G1 = _discretise(c, u[k - 1, 0], h)
        F[0, 0], F[0, 1], F[1, 0], F[1, 1] = Phi[0, 0], Phi[0, 1], Phi[1, 0], Phi[1, 1]
        d = u[k - 1, 1]
        for i in range(3):
            xp[i] = F[i, 0] * x[0] + F[i, 1] * x[1] + F[i, 2] * x[2]
        xp[0] += G0 * d
        xp[1] += G1 * d
        _mm_into(F, P, T3)
        _mmt_into(T3, F, P)
        for i in range(3):
            P[i, i] += theta[i] * h
        # ---- update with y_k
        vx, dk = u[k, 0], u[k, 1]
        H[1, 0] = -(Cf + Cr) / (m * vx)
        H[1, 1] = -(af * Cf - ar * Cr) / (m * vx)
        e[0] = y[k, 0] - ((H[0, 0] * xp[0] + H[0, 1] * xp[1] + H[0, 2] * xp[2]) + 0.0 * dk)
        e[1] = y[k, 1] - ((H[1, 0] * xp[0] + H[1, 1] * xp[1] + H[1, 2] * xp[2]) + Cf / m * dk)
        _mm_into(H, P, T23)
        _mmt_into(T23, H, S)
        S[0, 0] += theta[3]
        S[1, 1] += theta[4]
        det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
        Si[0, 0], Si[0, 1] = S[1, 1] / det, -S[0, 1] / det
        Si[1, 0], Si[1, 1] = -S[1, 0] / det, S[0, 0] / det
        _mmt_into(P, H, T32)
        _mm_into(T32, Si, K)
        for i in range(3):
            x[i] = xp[i] + (K[i, 0] * e[0] + K[i, 1] * e[1])
        _mm_into(K, H, IKH)
        for i in range(3):
            for j in range(3):
                IKH[i, j] = (1.0 if i == j else 0.0) - IKH[i, j]
        _mm_into(IKH, P, T3)
        _mmt_into(T3, IKH, P)
        for i in range(3):
            KR[i, 0], KR[i, 1] = K[i, 0] * theta[3], K[i, 1] * theta[4]
        for i in range(3):
            for j in range(3):
                P[i, j] += KR[i, 0] * K[j, 0] + KR[i, 1] * K[j, 1]
        X[k] = x
    return X


def _build_open_loop(vehicle, dt) -> OpenLoopBicycle:
    return OpenLoopBicycle(vehicle)


def _build_lkf(vehicle, dt) -> LinearKalman:
    return LinearKalman(vehicle)


register_observer("open-loop-linear", _build_open_loop,
                  "open-loop linear bicycle (zero-slip stiffness of the vehicle file) driven by the "
                  "measured steering and speed; no feedback (reference of the campaign reports)",
                  paper="baseline")
register_observer("linear-kf", _build_lkf,
                  "linear Kalman filter on the linear bicycle with an a_y offset state; measures "
                  "r and a_y; noise from the vehicle file's [kalman] table or the defaults",
                  paper="baseline")
