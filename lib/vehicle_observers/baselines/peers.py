"""The two estimators published with the Revs 250 LM log, re-implemented, and plain baselines.

Source: the MIT-licensed repository MBDS/sideslip-angle-vehicle-estimation (commit 0446c76,
A. Leanza, G. Reina, J.-L. Blanco-Claraco, "A Factor-Graph-Based Approach to Vehicle
Sideslip Angle Estimation", Sensors 21(16):5409, 2021). Both use the **linear single-track
model in sideslip form**, state ``[beta (rad), r (rad/s)]``, speed ``u = v_x`` [m/s],
road-wheel steering ``delta`` [rad], forward-Euler discretisation with the sample period
``dt`` [s]:

    beta_{k+1} = beta_k + dt (-(C_f+C_r)/(m u) beta_k - ((C_f l_f - C_r l_r)/(m u^2) + 1) r_k
                              + C_f delta_k/(m u))
    r_{k+1}    = r_k + dt (-(C_f l_f - C_r l_r)/J_z beta_k - (C_f l_f^2 + C_r l_r^2)/(J_z u) r_k
                           + C_f l_f delta_k/J_z)
    a_y        = -(C_f+C_r)/m beta - (C_f l_f - C_r l_r)/(m u) r + C_f delta/m

1. :func:`mbds_kf` - ``estimators/matlab_kf/BetaStanfordLinear.m`` with ``LinearKF.m``:
   a linear Kalman filter measuring ``[a_y, r]``; ``A_d(u_{k-1})``, ``B_d = dt [C_f/(m u);
   C_f l_f/J_z]``, process noise ``Q_d = B_d s_d^2 B_d^T`` (steering noise), ``C_d(u_k)``,
   ``D_d = [C_f/m; 0]``, ``R = diag(s_ay^2, s_r^2)``, ``X_0 = 0``, ``P_0 = diag(1e4, 1e4)``;
   the first sample is not filtered (``States(:, 1) = 0``). Their noise sigmas are computed
   from the log itself (:func:`mbds_kf_sigmas`): the standard deviation of each channel
   after a high-pass equiripple FIR (MATLAB ``fdesign.highpass('Fst,Fp,Ast,Ap', 0.15, 0.25,
   60, 1)``, normalised frequencies, minimum order), and ``s_d`` that of the steering
   **times 1000** (as written in their file).
2. :func:`mbds_fg_batch` / :func:`mbds_fg_fixed_lag` - ``estimators/cpp_factor_graph/
   main.cpp`` (GTSAM): one variable pair per sample; factors ``FactorBeta`` (sigma 4e-3),
   ``FactorRate`` (9e-3) between consecutive samples (the model above), a yaw-rate prior
   per sample (1e-2), ``FactorLateralAcceleration`` per sample (7.0), priors ``beta_0 =
   r_0 = 0`` (sigma 100); one Gauss-Newton iteration from all-zero values (the factors are
   linear, so this is the exact least-squares solution). Fixed lag ``W`` (their
   ``--fixed-lag-window``): for every ``i`` with ``i + W < N``, the factors whose first
   sample is in ``i .. i+W-1``, plus priors ``beta_i = r_i = 0`` with sigma 1 (their
   ``estimated`` map is the untouched initial values), solved alone; a sample keeps the
   value of the last window that contains it, i.e. of the window it starts for every
   ``i <= N-1-W``: the estimate at ``i`` reads samples ``i .. i+W-1`` (a 4-sample look-ahead
   for ``W = 5``; **not causal**). :func:`mbds_fg_gtsam` builds the same graphs with GTSAM's
   Python ``CustomFactor`` and ``GaussNewtonOptimizer`` (``maxIterations = 1``); the tests
   check it equal to the sparse / compiled solvers.

Their metric: sideslip RMSE in degrees over every sample of the log (``beta_true`` the INS
sideslip), :func:`beta_rmse_deg`.

Baselines on the user's vehicle file: :func:`open_loop_linear` (the linear single-track model
with the vehicle file's zero-slip cornering stiffnesses, driven by the measured steering and
speed from ``v_y = 0``) and ``v_y = 0``; the plain linear Kalman filter ``linear-kf`` is the
adaptive filter of :mod:`.adaptive` with linear tyres and no added term.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import ObserverBase, Trajectory

# ------------------------------------------------------------------ constants ------------


@dataclass(frozen=True)
class SingleTrack:
    """Constants of the linear single-track model: ``m`` [kg], ``J_z`` [kg m^2], ``l_f``,
    ``l_r`` [m], ``C_f``, ``C_r`` [N/rad] (axle cornering stiffness)."""

    m: float
    J_z: float
    l_f: float
    l_r: float
    C_f: float
    C_r: float

    def as_array(self) -> np.ndarray:
        return np.array([self.m, self.J_z, self.l_f, self.l_r, self.C_f, self.C_r], float)

    @classmethod
    def from_vehicle(cls, vehicle) -> SingleTrack:
        """From a vehicle file: the zero-slip slopes of its tyres (Pacejka ``B C D``)."""
        p = vehicle.params
        return cls(float(p.m), float(p.I_z), float(p.a_f), float(p.a_r),
                   float(p.tire_f.cornering_stiffness), float(p.tire_r.cornering_stiffness))


#: the car of the publishing repository (``CarParameters`` of main.cpp, BetaStanfordLinear.m)
MBDS_CAR = SingleTrack(m=982.0, J_z=982.0 / 12.0 * (1.7**2 + 4.09**2), l_f=1.33, l_r=1.07,
                       C_f=0.7e5, C_r=1.2e5)
#: factor-graph noise sigmas (main.cpp defaults = the example invocation in its header)
MBDS_FG_SIGMAS = {"beta": 4e-3, "rate": 9e-3, "obs_rate": 1e-2, "ay": 7.0, "prior": 1e2,
                  "window_prior": 1.0}
#: their fixed-lag window length [samples] (the 5-sample window of the paper)
MBDS_FIXED_LAG = 5
#: KF initial covariance ``P = diag([10^4 10^4])``
MBDS_KF_P0 = (1e4, 1e4)
#: high-pass FIR spec of BetaStanfordLinear.m: Fst, Fp (x Nyquist), Ast, Ap [dB]
MBDS_HIGHPASS = (0.15, 0.25, 60.0, 1.0)
#: their steering-noise factor: ``s_d = std(Noise_delta)*1000``
MBDS_STEER_FACTOR = 1000.0


# ------------------------------------------------------------------ noise sigmas ----------
def remez_order(f_stop: float, f_pass: float, a_stop_db: float, a_pass_db: float) -> int:
    """Minimum order of an equiripple FIR (Herrmann, Rabiner & Chan 1973, as MATLAB's
    ``firpmord``): band edges in units of the Nyquist frequency, ripple from the dB specs,
    rounded up to an even order (a high-pass FIR needs an odd length)."""
    dp = (10 ** (a_pass_db / 20) - 1) / (10 ** (a_pass_db / 20) + 1)
    ds = 10 ** (-a_stop_db / 20)
    lp, ls = math.log10(dp), math.log10(ds)
    a1, a2, a3, a4, a5, a6 = 5.309e-3, 7.114e-2, -4.761e-1, -2.66e-3, -5.941e-1, -4.278e-1
    dinf = ls * (a1 * lp * lp + a2 * lp + a3) + (a4 * lp * lp + a5 * lp + a6)
    f = 11.01217 + 0.51244 * (lp - ls)
    df = abs(f_pass - f_stop) / 2.0        # cycles per sample
    n = int(math.ceil(dinf / df - f * df))
    return n + (n % 2)


def highpass_fir(spec=MBDS_HIGHPASS) -> np.ndarray:
    """Taps of the minimum-order equiripple high-pass FIR meeting :data:`MBDS_HIGHPASS`
    (``scipy.signal.remez``, band weights from the ripple ratio as in ``firpm``): from the
    :func:`remez_order` estimate, the order is raised by 2 until the stopband attenuation and
    the passband ripple are met on a 8192-point grid (as MATLAB's minimum-order
    ``design(d, 'equiripple')`` does; Herrmann's estimate 40 gives 59.7 dB, 42 meets 60)."""
    from scipy.signal import freqz, remez

    fst, fp, ast, ap = spec
    dp = (10 ** (ap / 20) - 1) / (10 ** (ap / 20) + 1)
    ds = 10 ** (-ast / 20)
    n = remez_order(fst, fp, ast, ap)
    while True:
        b = remez(n + 1, [0.0, fst / 2, fp / 2, 0.5], [0.0, 1.0], weight=[dp / ds, 1.0], fs=1.0)
        w, h = freqz(b, worN=8192, fs=1.0)
        a = np.abs(h)
        if a[w <= fst / 2].max() <= ds and np.all(np.abs(a[w >= fp / 2] - 1) <= dp) or n > 400:
            return b
        n += 2


def highpass_std(x, taps=None) -> float:
    """``std(filter(Hd, x))`` of MATLAB: the causal FIR output's sample std (``N - 1``)."""
    from scipy.signal import lfilter

    taps = highpass_fir() if taps is None else taps
    return float(np.std(lfilter(taps, [1.0], np.asarray(x, float)), ddof=1))


def mbds_kf_sigmas(log) -> dict:
    """Their KF noise sigmas from the log: ``s_ay`` [m/s^2], ``s_r`` [rad/s], ``s_d`` [rad]
    (the high-pass std of the steering times :data:`MBDS_STEER_FACTOR`)."""
    log.require("ay_mps2", purpose="the MBDS Kalman filter (it measures a_y)")
    taps = highpass_fir()
    return {"s_ay": highpass_std(log.ay, taps), "s_r": highpass_std(log.yaw_rate, taps),
            "s_d": highpass_std(log.delta, taps) * MBDS_STEER_FACTOR}


# ------------------------------------------------------------------ the MBDS linear KF -----
def kf_matrices(car: SingleTrack, dt: float, u_prev: float, u: float):
    """``(A_d, B_d, C_d, D_d)`` of BetaStanfordLinear.m for one step (``A_d, B_d`` at the
    previous speed ``u_prev``, ``C_d`` at the current ``u``)."""
    m, Jz, lf, lr, Cf, Cr = car.as_array()
    A = np.array([[1 - dt * (Cf + Cr) / (m * u_prev), -dt * (1 + (lf * Cf - lr * Cr) / (m * u_prev**2))],
                  [-dt * (lf * Cf - lr * Cr) / Jz, 1 - dt * (lf**2 * Cf + lr**2 * Cr) / (Jz * u_prev)]])
    B = dt * np.array([Cf / (m * u_prev), lf * Cf / Jz])
    C = np.array([[-(Cf + Cr) / m, -(lf * Cf - lr * Cr) / (m * u)], [0.0, 1.0]])
    D = np.array([Cf / m, 0.0])
    return A, B, C, D


def linear_kf_step(A, B, C, D, u_prev, u, Y, X, P, Qd, Rd):
    """``LinearKF.m`` line by line: predict ``A X + B u_prev``, ``A P A^T + Q``; correct with
    ``S = C P C^T + R``, ``K = P C^T S^-1``, ``X + K (Y - C X - D u)``, ``(I - K C) P``."""
    Xp = A @ X + B * u_prev
    Pp = A @ P @ A.T + Qd
    S = C @ Pp @ C.T + Rd
    K = Pp @ C.T @ np.linalg.inv(S)
    Xn = Xp + K @ (Y - C @ Xp - D * u)
    return Xn, (np.eye(len(X)) - K @ C) @ Pp


@njit(cache=True)
def _mbds_kf(t, vx, delta, ay, yr, car, s_ay, s_r, s_d, p0):
    """Compiled :func:`linear_kf_step` loop (scalars; ``dt`` per sample from ``t``).
    Returns X (N, 2) ``[beta, r]`` and Pd (N, 2) the posterior variances."""
    N = t.shape[0]
    m, Jz, lf, lr, Cf, Cr = car[0], car[1], car[2], car[3], car[4], car[5]
    X = np.zeros((N, 2))
    Pd = np.zeros((N, 2))
    x0, x1 = 0.0, 0.0
    p00, p01, p11 = p0[0], 0.0, p0[1]
    Pd[0, 0], Pd[0, 1] = p00, p11
    q = s_d * s_d
    Ra, Rr = s_ay * s_ay, s_r * s_r
    for i in range(1, N):
        dt = t[i] - t[i - 1]
        up, u = vx[i - 1], vx[i]
        a00 = 1.0 - dt * (Cf + Cr) / (m * up)
        a01 = -dt * (1.0 + (lf * Cf - lr * Cr) / (m * up * up))
        a10 = -dt * (lf * Cf - lr * Cr) / Jz
        a11 = 1.0 - dt * (lf * lf * Cf + lr * lr * Cr) / (Jz * up)
        b0, b1 = dt * Cf / (m * up), dt * lf * Cf / Jz
        xp0 = a00 * x0 + a01 * x1 + b0 * delta[i - 1]
        xp1 = a10 * x0 + a11 * x1 + b1 * delta[i - 1]
        t00, t01 = a00 * p00 + a01 * p01, a00 * p01 + a01 * p11
        t10, t11 = a10 * p00 + a11 * p01, a10 * p01 + a11 * p11
        pp00 = t00 * a00 + t01 * a01 + b0 * q * b0
        pp01 = t00 * a10 + t01 * a11 + b0 * q * b1
        pp11 = t10 * a10 + t11 * a11 + b1 * q * b1
        c00, c01 = -(Cf + Cr) / m, -(lf * Cf - lr * Cr) / (m * u)
        # S = C P C^T + R with C = [[c00, c01], [0, 1]]
        g0 = c00 * pp00 + c01 * pp01          # (C P)[0, :]
        g1 = c00 * pp01 + c01 * pp11
        s00 = g0 * c00 + g1 * c01 + Ra
        s01 = g1                              # (C P C^T)[0, 1] = (C P)[0, 1]
        s11 = pp11 + Rr
        det = s00 * s11 - s01 * s01
        i00, i01, i11 = s11 / det, -s01 / det, s00 / det
        # P C^T = [[g0, pp01], [g1, pp11]]
        k00, k01 = g0 * i00 + pp01 * i01, g0 * i01 + pp01 * i11
        k10, k11 = g1 * i00 + pp11 * i01, g1 * i01 + pp11 * i11
        e0 = ay[i] - (c00 * xp0 + c01 * xp1) - Cf / m * delta[i]
        e1 = yr[i] - xp1
        x0 = xp0 + k00 * e0 + k01 * e1
        x1 = xp1 + k10 * e0 + k11 * e1
        # (I - K C) P
        m00, m01 = 1.0 - k00 * c00, -k00 * c01 - k01
        m10, m11 = -k10 * c00, 1.0 - k10 * c01 - k11
        n00 = m00 * pp00 + m01 * pp01
        n01 = m00 * pp01 + m01 * pp11
        n11 = m10 * pp01 + m11 * pp11
        p00, p01, p11 = n00, n01, n11
        X[i, 0], X[i, 1] = x0, x1
        Pd[i, 0], Pd[i, 1] = p00, p11
    return X, Pd


class MBDSLinearKF(ObserverBase):
    """The MBDS linear Kalman filter as an :class:`~vehicle_observers.core.protocol.Observer`.

    Inputs ``u = [v_x, delta]``, outputs ``y = [a_y, r]``, estimate ``[v_y, r, beta]``
    (``v_y = v_x tan(beta)``); internal state ``z = [beta, r, P00, P01, P11]``. Sample 0 is
    not filtered (their ``States(:, 1) = 0``)."""

    state_names = ("vy_mps", "yaw_rate_radps", "beta_rad")
    input_names = ("vx_mps", "delta_roadwheel_rad")
    output_names = ("ay_mps2", "yaw_rate_radps")

    def __init__(self, car: SingleTrack, s_ay: float, s_r: float, s_d: float,
                 p0=MBDS_KF_P0):
        for k, v in (("s_ay", s_ay), ("s_r", s_r), ("s_d", s_d)):
            if not (np.isfinite(v) and v > 0):
                raise ObserverArgumentError(f"MBDSLinearKF: {k} must be > 0, got {v}")
        self.car, self.s_ay, self.s_r, self.s_d, self.p0 = car, s_ay, s_r, s_d, tuple(p0)
        self.design = {"car": car, "s_ay": s_ay, "s_r": s_r, "s_d": s_d, "P0": self.p0}

    def initial_state(self, t, u, y, x0=None):
        return np.array([0.0, 0.0, self.p0[0], 0.0, self.p0[1]])

    def step(self, z, k, t, u, y):
        A, B, C, D = kf_matrices(self.car, t[k] - t[k - 1], u[k - 1, 0], u[k, 0])
        P = np.array([[z[2], z[3]], [z[3], z[4]]])
        R = np.diag([self.s_ay**2, self.s_r**2])
        Qd = np.outer(B, B) * self.s_d**2
        X, P = linear_kf_step(A, B, C, D, u[k - 1, 1], u[k, 1], y[k], z[:2], P, Qd, R)
        return np.array([X[0], X[1], P[0, 0], 0.5 * (P[0, 1] + P[1, 0]), P[1, 1]])

    def estimate(self, z):
        return np.array([np.nan, z[1], z[0]])      # v_y needs v_x: see run / estimate_at

    def run(self, t, u, y, x0=None) -> Trajectory:
        t, u, y, _ = self.check_data(t, u, y, None)
        t0 = time.perf_counter()
        X, Pd = _mbds_kf(t, u[:, 0], u[:, 1], y[:, 0], y[:, 1], self.car.as_array(),
                         self.s_ay, self.s_r, self.s_d, np.asarray(self.p0, float))
        sec = time.perf_counter() - t0
        vy = u[:, 0] * np.tan(X[:, 0])
        return Trajectory(t, np.column_stack([vy, X[:, 1], X[:, 0]]), self.state_names,
                          seconds=sec, estimator="mbds-kf",
                          info={"beta_std_rad": np.sqrt(np.maximum(Pd[:, 0], 0.0))})


def readable_with_speed(obs: MBDSLinearKF, t, u, y) -> np.ndarray:
    """The readable step looped in Python, returning ``[v_y, r, beta]`` (N, 3) with
    ``v_y = v_x tan(beta)`` (the test reference of :meth:`MBDSLinearKF.run`)."""
    z = obs.initial_state(t, u, y)
    out = np.empty((len(t), 3))
    out[0] = (0.0, 0.0, 0.0)
    for k in range(1, len(t)):
        z = obs.step(z, k, t, u, y)
        out[k] = (u[k, 0] * np.tan(z[0]), z[1], z[0])
    return out


def mbds_kf(log, car: SingleTrack = MBDS_CAR, sigmas: dict | None = None) -> Trajectory:
    """Their KF on a log (``sigmas``: :func:`mbds_kf_sigmas` of the log when ``None``).
    Columns ``vy_mps``, ``yaw_rate_radps``, ``beta_rad``, ``vy_std_mps`` (``v_x`` times the
    sideslip std, first order)."""
    sg = mbds_kf_sigmas(log) if sigmas is None else sigmas
    obs = MBDSLinearKF(car, sg["s_ay"], sg["s_r"], sg["s_d"])
    u = np.column_stack([log.vx, log.delta])
    y = np.column_stack([log.ay, log.yaw_rate])
    tr = obs.run(log.t, u, y)
    cols = {**tr.columns, "vy_std_mps": np.abs(log.vx) * tr.info["beta_std_rad"]}
    return Trajectory.from_columns(log.t, cols, seconds=tr.seconds, estimator="mbds-kf",
                                   info={"sigmas": sg, "car": car})


# ------------------------------------------------------------------ the MBDS factor graph --
def _fg_rows(car: SingleTrack, dt: float, u, delta):
    """Coefficients of the linear factors at samples ``k`` (arrays (N,)): FactorBeta
    ``e = beta_{k+1} + cb_b beta_k + cb_r r_k - cb_0``, FactorRate ``e = r_{k+1} + cr_r r_k
    + cr_b beta_k - cr_0``, FactorLateralAcceleration ``e = a_y + ca_b beta_k + ca_r r_k
    - ca_0``."""
    m, Jz, lf, lr, Cf, Cr = car.as_array()
    cb_b = -(1.0 - dt * (Cf + Cr) / (m * u))
    cb_r = dt * ((Cf * lf - Cr * lr) / (m * u * u) + 1.0)
    cb_0 = dt * Cf * delta / (m * u)
    cr_r = -1.0 + dt * (Cf * lf**2 + Cr * lr**2) / (Jz * u)
    cr_b = np.full_like(u, dt * (Cf * lf - Cr * lr) / Jz)
    cr_0 = dt * Cf * lf * delta / Jz
    ca_b = np.full_like(u, (Cf + Cr) / m)
    ca_r = (Cf * lf - Cr * lr) / (m * u)
    ca_0 = Cf * delta / m
    return cb_b, cb_r, cb_0, cr_r, cr_b, cr_0, ca_b, ca_r, ca_0


def mbds_fg_batch(t, vx, delta, ay, yr, car: SingleTrack = MBDS_CAR, sigmas=None,
                  dt: float | None = None) -> np.ndarray:
    """The batch factor graph solved exactly (sparse normal equations, SuperLU). ``dt``:
    their constant sample period (default: the median of ``diff(t)``). Returns (N, 2)
    ``[beta, r]``."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.linalg import spsolve

    sg = {**MBDS_FG_SIGMAS, **(sigmas or {})}
    vx, delta = np.asarray(vx, float), np.asarray(delta, float)
    N = len(vx)
    dt = float(np.median(np.diff(t))) if dt is None else float(dt)
    cb_b, cb_r, cb_0, cr_r, cr_b, cr_0, ca_b, ca_r, ca_0 = _fg_rows(car, dt, vx, delta)
    ib, ir = 2 * np.arange(N), 2 * np.arange(N) + 1
    rows, cols, vals, rhs = [], [], [], []
    nrow = 0

    def add(cidx, cval, b, sigma):
        nonlocal nrow
        n = len(b)
        r = nrow + np.arange(n)
        for c, v in zip(cidx, cval):
            rows.append(r)
            cols.append(c)
            vals.append(np.broadcast_to(v / sigma, (n,)))
        rhs.append(np.asarray(b, float) / sigma)
        nrow += n

    k = np.arange(N - 1)
    add([ib[:1]], [1.0], [0.0], sg["prior"])
    add([ir[:1]], [1.0], [0.0], sg["prior"])
    add([ib[k + 1], ib[k], ir[k]], [1.0, cb_b[k], cb_r[k]], cb_0[k], sg["beta"])
    add([ir[k + 1], ir[k], ib[k]], [1.0, cr_r[k], cr_b[k]], cr_0[k], sg["rate"])
    add([ir], [1.0], yr, sg["obs_rate"])
    add([ib, ir], [ca_b, ca_r], ca_0 - np.asarray(ay, float), sg["ay"])
    A = csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                   shape=(nrow, 2 * N))
    b = np.concatenate(rhs)
    z = spsolve((A.T @ A).tocsc(), A.T @ b)
    return np.column_stack([z[0::2], z[1::2]])


@njit(cache=True)
def _fg_window(i, W, N, cb_b, cb_r, cb_0, cr_r, cr_b, cr_0, ca_b, ca_r, ca_0, ay, yr,
               s_b, s_r, s_o, s_a, s_p, s_w, M, v):
    """Normal equations of window ``i`` (variables ``beta_{i..i+W}`` at ``0..W`` and
    ``r_{i..i+W}`` at ``W+1..2W+1``) into ``M``, ``v``; returns the solution."""
    n = 2 * (W + 1)
    for a in range(n):
        v[a] = 0.0
        for b in range(n):
            M[a, b] = 0.0
    # window priors beta_i = r_i = 0 (sigma s_w), and the sigma-100 priors of sample 0
    w = 1.0 / (s_w * s_w)
    M[0, 0] += w
    M[W + 1, W + 1] += w
    if i == 0:
        w = 1.0 / (s_p * s_p)
        M[0, 0] += w
        M[W + 1, W + 1] += w
    for off in range(W):
        j = i + off
        bj, rj = off, W + 1 + off
        if j < N - 1:
            w = 1.0 / (s_b * s_b)          # beta_{j+1} + cb_b beta_j + cb_r r_j = cb_0
            idx = (bj + 1, bj, rj)
            co = (1.0, cb_b[j], cb_r[j])
            for a in range(3):
                v[idx[a]] += w * co[a] * cb_0[j]
                for b in range(3):
                    M[idx[a], idx[b]] += w * co[a] * co[b]
            w = 1.0 / (s_r * s_r)          # r_{j+1} + cr_r r_j + cr_b beta_j = cr_0
            idx = (rj + 1, rj, bj)
            co = (1.0, cr_r[j], cr_b[j])
            for a in range(3):
                v[idx[a]] += w * co[a] * cr_0[j]
                for b in range(3):
                    M[idx[a], idx[b]] += w * co[a] * co[b]
        w = 1.0 / (s_o * s_o)              # r_j = yaw-rate observation
        M[rj, rj] += w
        v[rj] += w * yr[j]
        w = 1.0 / (s_a * s_a)              # ca_b beta_j + ca_r r_j = ca_0 - a_y
        c = ca_0[j] - ay[j]
        M[bj, bj] += w * ca_b[j] * ca_b[j]
        M[bj, rj] += w * ca_b[j] * ca_r[j]
        M[rj, bj] += w * ca_b[j] * ca_r[j]
        M[rj, rj] += w * ca_r[j] * ca_r[j]
        v[bj] += w * ca_b[j] * c
        v[rj] += w * ca_r[j] * c
    return np.linalg.solve(M, v)


@njit(cache=True)
def _fg_fixed_lag(W, cb_b, cb_r, cb_0, cr_r, cr_b, cr_0, ca_b, ca_r, ca_0, ay, yr,
                  s_b, s_r, s_o, s_a, s_p, s_w):
    N = ay.shape[0]
    out = np.zeros((N, 2))
    n = 2 * (W + 1)
    M = np.empty((n, n))
    v = np.empty(n)
    for i in range(0, N - W):
        z = _fg_window(i, W, N, cb_b, cb_r, cb_0, cr_r, cr_b, cr_0, ca_b, ca_r, ca_0, ay,
                       yr, s_b, s_r, s_o, s_a, s_p, s_w, M, v)
        for a in range(W + 1):
            out[i + a, 0] = z[a]
            out[i + a, 1] = z[W + 1 + a]
    return out


def mbds_fg_fixed_lag(t, vx, delta, ay, yr, car: SingleTrack = MBDS_CAR, window: int =
                      MBDS_FIXED_LAG, sigmas=None, dt: float | None = None) -> np.ndarray:
    """Their fixed-lag loop (module docstring), compiled: one ``2(W+1)`` normal-equation
    solve per window. Returns (N, 2) ``[beta, r]``."""
    if int(window) < 1:
        raise ObserverArgumentError(f"mbds_fg_fixed_lag: window must be >= 1, got {window}")
    sg = {**MBDS_FG_SIGMAS, **(sigmas or {})}
    vx, delta = np.ascontiguousarray(vx, float), np.ascontiguousarray(delta, float)
    if len(vx) <= int(window):
        raise ObserverArgumentError(f"mbds_fg_fixed_lag: needs more than window = {window} "
                                    f"samples, got {len(vx)}")
    dt = float(np.median(np.diff(t))) if dt is None else float(dt)
    co = _fg_rows(car, dt, vx, delta)
    return _fg_fixed_lag(int(window), *[np.ascontiguousarray(c, float) for c in co],
                         np.ascontiguousarray(ay, float), np.ascontiguousarray(yr, float),
                         sg["beta"], sg["rate"], sg["obs_rate"], sg["ay"], sg["prior"],
                         sg["window_prior"])


def mbds_fg_gtsam(t, vx, delta, ay, yr, car: SingleTrack = MBDS_CAR, window: int = 0,
                  sigmas=None, dt: float | None = None) -> np.ndarray:
    """main.cpp's graphs with GTSAM (``CustomFactor`` for FactorBeta, FactorRate and
    FactorLateralAcceleration, ``PriorFactorDouble`` for the priors and the yaw-rate
    observation; ``GaussNewtonOptimizer`` with ``maxIterations = 1``); ``window = 0`` batch,
    ``>= 1`` their fixed-lag loop. Python callbacks per factor: slow (tests, short logs)."""
    import gtsam

    sg = {**MBDS_FG_SIGMAS, **(sigmas or {})}
    vx, delta = np.asarray(vx, float), np.asarray(delta, float)
    N = len(vx)
    dt = float(np.median(np.diff(t))) if dt is None else float(dt)
    cb_b, cb_r, cb_0, cr_r, cr_b, cr_0, ca_b, ca_r, ca_0 = _fg_rows(car, dt, vx, delta)
    B = lambda k: gtsam.symbol("b", k)          # noqa: E731
    R = lambda k: gtsam.symbol("r", k)          # noqa: E731
    iso = gtsam.noiseModel.Isotropic.Sigma

    def lin3(c1, c2, c3, c0):
        def err(this, values, H):
            k = this.keys()
            x = [values.atDouble(kk) for kk in k]
            if H is not None:
                H[0], H[1], H[2] = np.array([[c1]]), np.array([[c2]]), np.array([[c3]])
            return np.array([c1 * x[0] + c2 * x[1] + c3 * x[2] - c0])
        return err

    def lin2(c1, c2, c0):
        def err(this, values, H):
            k = this.keys()
            x = [values.atDouble(kk) for kk in k]
            if H is not None:
                H[0], H[1] = np.array([[c1]]), np.array([[c2]])
            return np.array([c1 * x[0] + c2 * x[1] - c0])
        return err

    by_time: dict[int, list] = {k: [] for k in range(N)}
    by_time[0] += [gtsam.PriorFactorDouble(B(0), 0.0, iso(1, sg["prior"])),
                   gtsam.PriorFactorDouble(R(0), 0.0, iso(1, sg["prior"]))]
    for k in range(N):
        if k < N - 1:
            by_time[k].append(gtsam.CustomFactor(iso(1, sg["beta"]), [B(k + 1), B(k), R(k)],
                                                 lin3(1.0, cb_b[k], cb_r[k], cb_0[k])))
            by_time[k].append(gtsam.CustomFactor(iso(1, sg["rate"]), [R(k + 1), R(k), B(k)],
                                                 lin3(1.0, cr_r[k], cr_b[k], cr_0[k])))
        by_time[k].append(gtsam.PriorFactorDouble(R(k), float(yr[k]), iso(1, sg["obs_rate"])))
        by_time[k].append(gtsam.CustomFactor(iso(1, sg["ay"]), [B(k), R(k)],
                                             lin2(ca_b[k], ca_r[k], ca_0[k] - ay[k])))
    params = gtsam.GaussNewtonParams()
    params.setMaxIterations(1)
    out = np.zeros((N, 2))
    if window <= 0:
        g = gtsam.NonlinearFactorGraph()
        v = gtsam.Values()
        for k in range(N):
            for f in by_time[k]:
                g.add(f)
            v.insert(B(k), 0.0)
            v.insert(R(k), 0.0)
        est = gtsam.GaussNewtonOptimizer(g, v, params).optimize()
        for k in range(N):
            out[k] = est.atDouble(B(k)), est.atDouble(R(k))
        return out
    W = int(window)
    for i in range(0, N - W):
        g = gtsam.NonlinearFactorGraph()
        for off in range(W):
            for f in by_time[i + off]:
                g.add(f)
        v = gtsam.Values()
        for k in range(i, i + W + 1):
            v.insert(B(k), float(out[k, 0]))
            v.insert(R(k), float(out[k, 1]))
        g.add(gtsam.PriorFactorDouble(B(i), 0.0, iso(1, sg["window_prior"])))
        g.add(gtsam.PriorFactorDouble(R(i), 0.0, iso(1, sg["window_prior"])))
        est = gtsam.GaussNewtonOptimizer(g, v, params).optimize()
        for k in range(i, i + W + 1):
            out[k] = est.atDouble(B(k)), est.atDouble(R(k))
    return out


def mbds_fg(log, car: SingleTrack = MBDS_CAR, window: int = 0, sigmas=None) -> Trajectory:
    """Their factor graph on a log: batch (``window = 0``, offline) or fixed-lag. Columns
    ``vy_mps`` (``v_x tan(beta)``), ``yaw_rate_radps``, ``beta_rad``. Not causal either way
    (the fixed-lag estimate at ``k`` reads samples up to ``k + window - 1``)."""
    log.require("ay_mps2", purpose="the MBDS factor graph (FactorLateralAcceleration)")
    t0 = time.perf_counter()
    if window <= 0:
        X = mbds_fg_batch(log.t, log.vx, log.delta, log.ay, log.yaw_rate, car, sigmas)
    else:
        X = mbds_fg_fixed_lag(log.t, log.vx, log.delta, log.ay, log.yaw_rate, car, window,
                              sigmas)
    sec = time.perf_counter() - t0
    cols = {"vy_mps": log.vx * np.tan(X[:, 0]), "yaw_rate_radps": X[:, 1], "beta_rad": X[:, 0]}
    name = "mbds-fg" if window <= 0 else f"mbds-fg-lag{window}"
    return Trajectory.from_columns(log.t, cols, seconds=sec, causal=False, estimator=name,
                                   info={"window": int(window), "car": car,
                                         "look_ahead_samples": max(int(window) - 1, 0)
                                         if window > 0 else None})


# ------------------------------------------------------------------ baselines ------------
def open_loop_linear(log, params) -> np.ndarray:
    """v_y [m/s] of the open-loop linear single-track model (the zero-slip slopes of
    ``params``' tyres, steady axle forces) driven by the measured steering and speed from
    ``v_y = 0`` (RK4, 4 sub-steps per sample)."""
    from vehicle_observers.models.lateral import simulate_s1
    from vehicle_observers.models.tires import LinearTire

    lin = replace(params, tire_f=LinearTire(params.tire_f.cornering_stiffness),
                  tire_r=LinearTire(params.tire_r.cornering_stiffness))
    X = simulate_s1([0.0, float(log.yaw_rate[0])], log.delta, log.vx, log.dt, lin,
                    exact=False, relaxation=False, substeps=4)
    return X[:, 0]


def beta_rmse_deg(beta_est, beta_true) -> float:
    """Their metric: ``sqrt(mean((beta - beta_true)^2))`` in degrees over every sample."""
    e = np.asarray(beta_est, float) - np.asarray(beta_true, float)
    return float(np.degrees(np.sqrt(np.mean(e * e))))
