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

Implementations:

- :func:`ekf` numba EKF (the fast one used by the CLI and the benchmark),
- :func:`ekf_filterpy` the same filter with ``filterpy.kalman.ExtendedKalmanFilter`` (reference
  implementation and speed baseline; equal to :func:`ekf` to round-off, see the tests),
- :func:`ukf_filterpy` ``filterpy.kalman.UnscentedKalmanFilter`` (Merwe sigma points) with the
  covariance re-symmetrised and its eigenvalues floored after every step (filterpy's UKF can
  lose symmetry / positive definiteness, then ``cholesky`` fails),
- :func:`rts` the extended RTS smoother (offline, non-causal reference) on the EKF pass;
  with linear tyres the model is linear and it equals ``filterpy``'s ``rts_smoother``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
from numba import njit
from scipy.optimize import minimize

from vehicle_observers.data.identification import white_noise_std
from vehicle_observers.data.logs import DriveLog, despike
from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.vehicle import KalmanTuning

NX = 3
STATE_NAMES = ("vy", "r", "b_ay")


# ------------------------------------------------------------------ configuration --------
@dataclass
class KalmanResult:
    """Estimates along a log. X (N, 3) posterior ``[v_y, r, b_ay]``, P (N, 3, 3); Ff/Fr (N,)
    axle forces [N] from the tyre model at the estimated slip angles; nll the negative
    log-likelihood of the innovations (``nan`` for smoothers); seconds the wall time of the
    run (compiled code, excluding compilation)."""

    name: str
    t: np.ndarray
    X: np.ndarray
    P: np.ndarray
    Ff: np.ndarray
    Fr: np.ndarray
    nll: float = float("nan")
    seconds: float = float("nan")
    causal: bool = True
    info: dict = field(default_factory=dict)

    @property
    def vy(self):
        return self.X[:, 0]

    @property
    def r(self):
        return self.X[:, 1]

    @property
    def us_per_step(self) -> float:
        return 1e6 * self.seconds / max(len(self.t), 1)


# ------------------------------------------------------------------ model (numba) --------
@njit(cache=True)
def _tyre(alpha, B, C, D, E):
    """Force [N] and slope dF/dalpha [N/rad] of a Pacejka (C > 0) or linear (C = 0) tyre."""
    if C == 0.0:
        return B * alpha, B
    Ba = B * alpha
    phi = B * (1.0 - E) * alpha + E * np.arctan(Ba)
    ang = C * np.arctan(phi)
    F = D * np.sin(ang)
    dphi = B * (1.0 - E) + E * B / (1.0 + Ba * Ba)
    dF = D * np.cos(ang) * C / (1.0 + phi * phi) * dphi
    return F, dF


@njit(cache=True)
def _rhs(x, delta, vx, P, f, A):
    """f(x) and its Jacobian A (3x3) of the model above. P: LateralParams.as_array()."""
    m, Iz, af, ar = P[0], P[1], P[2], P[3]
    vy, r = x[0], x[1]
    a_f = delta - (vy + af * r) / vx
    a_r = -(vy - ar * r) / vx
    Ff, dFf = _tyre(a_f, P[7], P[8], P[9], P[10])
    Fr, dFr = _tyre(a_r, P[11], P[12], P[13], P[14])
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
    m, af, ar = P[0], P[2], P[3]
    vy, r = x[0], x[1]
    a_f = delta - (vy + af * r) / vx
    a_r = -(vy - ar * r) / vx
    Ff, dFf = _tyre(a_f, P[7], P[8], P[9], P[10])
    Fr, dFr = _tyre(a_r, P[11], P[12], P[13], P[14])
    y[0] = r
    H[0, 0] = 0.0
    H[0, 1] = 1.0
    H[0, 2] = 0.0
    if use_ay:
        y[1] = (Ff + Fr) / m + x[2]
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


@njit(cache=True)
def _ekf(t, vx, delta, yr, ay, use_ay, P, theta, x0, P0diag, store):
    """EKF pass. Returns Xf, Pf (posteriors), Xp, Pp (priors), Fs (transition Jacobians from
    k to k+1) and the innovation negative log-likelihood. ``store=False`` keeps only Xf/diag."""
    N = t.shape[0]
    n = 3
    Xf = np.empty((N, n))
    Pf = np.empty((N if store else 1, n, n))
    Pfd = np.empty((N, n))
    Xp = np.empty((N if store else 1, n))
    Pp = np.empty((N if store else 1, n, n))
    Fs = np.empty((N if store else 1, n, n))
    q = theta[:3].copy()
    if not use_ay:
        q[2] = 0.0
    Rr, Ray = theta[3], theta[4]
    x = x0.copy()
    Pk = np.zeros((n, n))
    for i in range(n):
        Pk[i, i] = P0diag[i]
    xn = np.empty(n)
    F = np.empty((n, n))
    T1 = np.empty((n, n))
    W = np.empty((6, n, n))
    V = np.empty((5, n))
    PHt = np.empty((n, 2))
    S = np.empty((2, 2))
    K = np.empty((n, 2))
    K1 = np.empty(n)
    IKH = np.empty((n, n))
    yh = np.empty(2)
    H = np.empty((2, n))
    nll = 0.0
    log2pi = np.log(2.0 * np.pi)
    for k in range(N):
        if store:
            Xp[k] = x
            Pp[k] = Pk
        # ---- update with y_k
        _meas(x, delta[k], vx[k], P, use_ay, yh, H)
        if use_ay:
            e0 = yr[k] - yh[0]
            e1 = ay[k] - yh[1]
            for i in range(n):
                for j in range(2):
                    s = 0.0
                    for l in range(n):
                        s += Pk[i, l] * H[j, l]
                    PHt[i, j] = s
            for i in range(2):
                for j in range(2):
                    s = 0.0
                    for l in range(n):
                        s += H[i, l] * PHt[l, j]
                    S[i, j] = s
            S[0, 0] += Rr
            S[1, 1] += Ray
            det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
            Si00 = S[1, 1] / det
            Si11 = S[0, 0] / det
            Si01 = -S[0, 1] / det
            nll += 0.5 * (np.log(det) + e0 * (Si00 * e0 + Si01 * e1)
                          + e1 * (Si01 * e0 + Si11 * e1) + 2.0 * log2pi)
            for i in range(n):
                K[i, 0] = PHt[i, 0] * Si00 + PHt[i, 1] * Si01
                K[i, 1] = PHt[i, 0] * Si01 + PHt[i, 1] * Si11
            for i in range(n):
                x[i] += K[i, 0] * e0 + K[i, 1] * e1
            # Joseph form keeps P symmetric positive definite
            for i in range(n):
                for j in range(n):
                    IKH[i, j] = (1.0 if i == j else 0.0) - K[i, 0] * H[0, j] - K[i, 1] * H[1, j]
            _mm3(IKH, Pk, T1)
            for i in range(n):
                for j in range(n):
                    s = 0.0
                    for l in range(n):
                        s += T1[i, l] * IKH[j, l]
                    Pk[i, j] = s + K[i, 0] * Rr * K[j, 0] + K[i, 1] * Ray * K[j, 1]
        else:
            e0 = yr[k] - yh[0]
            s = Pk[1, 1] + Rr
            nll += 0.5 * (np.log(s) + e0 * e0 / s + log2pi)
            for i in range(n):
                K1[i] = Pk[i, 1] / s
            for i in range(n):
                x[i] += K1[i] * e0
            for i in range(n):
                for j in range(n):
                    T1[i, j] = Pk[i, j] - K1[i] * Pk[1, j] - Pk[i, 1] * K1[j] + K1[i] * s * K1[j]
            for i in range(n):
                for j in range(n):
                    Pk[i, j] = T1[i, j]
        Xf[k] = x
        for i in range(n):
            Pfd[k, i] = Pk[i, i]
        if store:
            Pf[k] = Pk
        # ---- predict to k+1
        if k + 1 < N:
            h = t[k + 1] - t[k]
            _rk4_ws(x, delta[k], vx[k], h, P, xn, F, W, V)
            _mm3(F, Pk, T1)
            for i in range(n):
                for j in range(n):
                    s = 0.0
                    for l in range(n):
                        s += T1[i, l] * F[j, l]
                    Pk[i, j] = s
            for i in range(n):
                Pk[i, i] += q[i] * h
            for i in range(n):
                for j in range(i):
                    s2 = 0.5 * (Pk[i, j] + Pk[j, i])
                    Pk[i, j] = s2
                    Pk[j, i] = s2
            for i in range(n):
                x[i] = xn[i]
            if store:
                Fs[k + 1] = F
        elif store:
            Fs[0] = np.eye(n)
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
        return np.linalg.pinv(A)
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


def prepare(log: DriveLog, use_ay: bool | None = None, despike_steering: float | None = 0.1):
    """Arrays for the kernels. Steering spikes (single-sample jumps > ``despike_steering``
    rad from the 3-sample median, e.g. 0.48 rad at t = 671.67 s in the Revs log) are removed:
    a physical steering wheel cannot jump 0.1 rad road-wheel for one sample and come back."""
    if np.any(log.vx <= 0):
        k = int(np.argmax(log.vx <= 0))
        raise ValueError(f"column 'vx_mps' must be > 0 (the model divides by it): row {k} has "
                         f"{log.vx[k]:g}")
    has_ay = log.ay is not None
    use = has_ay if use_ay is None else bool(use_ay)
    if use and not has_ay:
        raise ValueError("use_ay=True but the log has no 'ay_mps2' column")
    delta = np.ascontiguousarray(log.delta, dtype=float)
    if despike_steering is not None:
        delta, _ = despike(delta, despike_steering)
    ay = np.ascontiguousarray(log.ay if use else np.zeros_like(log.t), dtype=float)
    x0 = np.array([0.0, float(log.yaw_rate[0]), 0.0])
    return _Inputs(np.ascontiguousarray(log.t, dtype=float), np.ascontiguousarray(log.vx, float),
                   delta, np.ascontiguousarray(log.yaw_rate, float), ay, use, x0)


#: initial sideslip standard deviation [rad] used to cap the initial v_y variance
BETA0_STD = 0.05


def _p0(P0, inp: _Inputs) -> np.ndarray:
    """Initial covariance diagonal: ``P0`` with the v_y variance capped at
    ``(BETA0_STD v_x(0))^2``, i.e. an initial sideslip of a few degrees. At walking speed a
    1 m/s v_y uncertainty means slip angles far past the tyre peak; sigma points there lock
    the UKF onto the saturated-tyre branch, where v_y is unobservable."""
    p = np.array(P0, dtype=float)
    p[0] = min(p[0], (BETA0_STD * float(inp.vx[0])) ** 2)
    return p


def _forces(X, inp: _Inputs, params: LateralParams):
    a_f = inp.delta - (X[:, 0] + params.a_f * X[:, 1]) / inp.vx
    a_r = -(X[:, 0] - params.a_r * X[:, 1]) / inp.vx
    return params.tire_f.force(a_f), params.tire_r.force(a_r)


def ekf(log: DriveLog, params: LateralParams, tuning: KalmanTuning | None = None,
        use_ay: bool | None = None, store: bool = False) -> KalmanResult:
    """Numba EKF on ``log`` (see module docstring). ``store=True`` keeps the priors and
    Jacobians (``info['Xp', 'Pp', 'Fs', 'Pf']``) for the smoother."""
    tuning = tuning or KalmanTuning()
    inp = prepare(log, use_ay)
    Parr = params.as_array()
    args = (inp.t, inp.vx, inp.delta, inp.yr, inp.ay, inp.use_ay, Parr, tuning.theta(), inp.x0,
            _p0(tuning.P0, inp), store)
    t0 = time.perf_counter()
    Xf, Pf, Pfd, Xp, Pp, Fs, nll = _ekf(*args)
    sec = time.perf_counter() - t0
    Ff, Fr = _forces(Xf, inp, params)
    P = Pf if store else np.einsum("ki,ij->kij", Pfd, np.eye(3))
    info = {"use_ay": inp.use_ay, "tuning": tuning}
    if store:
        info.update(Xp=Xp, Pp=Pp, Fs=Fs)
    return KalmanResult("EKF", inp.t, Xf, P, Ff, Fr, float(nll), sec, True, info)


def rts(log: DriveLog, params: LateralParams, tuning: KalmanTuning | None = None,
        use_ay: bool | None = None) -> KalmanResult:
    """Extended RTS smoother (offline, non-causal): EKF forward pass + RTS backward pass."""
    t0 = time.perf_counter()
    f = ekf(log, params, tuning, use_ay, store=True)
    Xs, Ps = _rts(f.X, f.P, f.info["Xp"], f.info["Pp"], f.info["Fs"])
    sec = time.perf_counter() - t0
    inp = prepare(log, use_ay)
    Ff, Fr = _forces(Xs, inp, params)
    return KalmanResult("RTS", inp.t, Xs, Ps, Ff, Fr, float("nan"), sec, False,
                        {"use_ay": inp.use_ay, "tuning": f.info["tuning"]})


def nll(log_or_inputs, params: LateralParams, tuning: KalmanTuning) -> float:
    """Innovation negative log-likelihood of the measured channels under ``tuning``."""
    inp = log_or_inputs if isinstance(log_or_inputs, _Inputs) else prepare(log_or_inputs)
    out = _ekf(inp.t, inp.vx, inp.delta, inp.yr, inp.ay, inp.use_ay, params.as_array(),
               tuning.theta(), inp.x0, _p0(tuning.P0, inp), False)
    return float(out[-1])


def thin(log: DriveLog, every: int) -> DriveLog:
    """Every ``every``-th sample of the measured channels (no reference columns)."""
    idx = np.arange(0, len(log), int(every))
    return DriveLog(t=log.t[idx], vx=log.vx[idx], delta=log.delta[idx],
                    yaw_rate=log.yaw_rate[idx], ay=None if log.ay is None else log.ay[idx],
                    source=f"{log.source} (every {every}th sample)" if every > 1 else log.source)


#: search box of the ML tuning, log10 of (q_vy, q_r, q_b, R_r, R_ay)
TUNE_BOUNDS = ((-8.0, 2.0), (-8.0, 1.0), (-6.0, 1.0), (-10.0, 0.0), (-6.0, 2.0))


#: measurement variances are bounded below by this share of the channel's white-noise
#: variance estimated from the data (second differences, robust): the estimate carries
#: 10-20 % error and some signal content, so half of it still keeps ML from collapsing
#: R to the search floor (R_r = 1e-10 on a 2e-3 rad/s gyro) while leaving it room.
NOISE_FLOOR_SHARE = 0.5


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
    inside :data:`TUNE_BOUNDS`, with Nelder-Mead (deterministic) from ``start`` and from
    ``start`` with ``q_b = 1e-5``; the better optimum is kept. Reads only
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
    # two starts: the given one and the same with a nearly constant a_y offset (the
    # likelihood has a second basin where b_ay soaks up the a_y noise)
    starts = [start, replace(start, q_b=1e-5)]
    if window_s is not None:
        log = log.segment(log.t[0], log.t[0] + float(window_s))
    every = max(1, int(np.floor(1.0 / (log.dt * max_rate_hz) + 1e-9)))
    log = thin(log, every)
    if noise_floor:
        # a third start at the data's own noise level: the likelihood is multimodal and a
        # start clipped onto the floor can fall into a poorer basin
        fl = {k: v / NOISE_FLOOR_SHARE for k, v in noise_floors(log).items()}
        starts.append(replace(start, **fl))
    inp = prepare(log, use_ay)
    Parr = params.as_array()
    P0 = _p0(start.P0, inp)
    free = [0, 1, 2, 3, 4] if inp.use_ay else [0, 1, 3]
    bounds = [tuple(b) for b in TUNE_BOUNDS]
    if noise_floor:
        for i, v in zip((3, 4), noise_floors(log).values()):
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
        v = _ekf(inp.t, inp.vx, inp.delta, inp.yr, inp.ay, inp.use_ay, Parr, th, inp.x0, P0,
                 False)[-1]
        return v if np.isfinite(v) else 1e300

    res = None
    lo, hi = [b[0] for b in bounds], [b[1] for b in bounds]
    for s in starts:
        z0 = np.clip(np.log10(s.theta()[free]), lo, hi)
        r = minimize(f, z0, method="Nelder-Mead", bounds=bounds,
                     options={"maxiter": maxiter, "xatol": 1e-2, "fatol": 0.05})
        if res is None or r.fun < res.fun:
            res = r
    th = th0.copy()
    th[free] = 10.0 ** res.x
    return KalmanTuning.from_theta(
        th, P0=start.P0,
        source=f"ML on measured channels of {log.source} ({len(inp.t)} samples, "
               f"{'r, a_y' if inp.use_ay else 'r'}; nll={res.fun:.6g}, {res.nit} iterations)")


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
    names = ["q_vy", "q_r", "q_b", "R_r", "R_ay"]
    free = [0, 1, 2, 3, 4] if inp.use_ay else [0, 1, 3]
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
    for i, k in ((3, "R_r"), (4, "R_ay")):
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

    def fx(x, dt):
        k = state["k"]
        xn = np.empty(3)
        F = np.empty((3, 3))
        _rk4(np.asarray(x, float), inp.delta[k], inp.vx[k], dt, Parr, xn, F)
        return xn

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
                 use_ay: bool | None = None, progress=None) -> KalmanResult:
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
    q = tuning.theta()[:3].copy()
    if not inp.use_ay:
        q[2] = 0.0
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
    return KalmanResult("EKF (filterpy)", inp.t, X, P, Ff, Fr, float("nan"), sec, True,
                        {"use_ay": inp.use_ay, "tuning": tuning})


def nearest_spd(P, floor: float = 1e-12):
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


def ukf_filterpy(log: DriveLog, params: LateralParams, tuning: KalmanTuning | None = None,
                 use_ay: bool | None = None, alpha: float = 0.1, beta: float = 2.0,
                 kappa: float = 0.0, progress=None) -> KalmanResult:
    """``filterpy`` UKF (Merwe scaled sigma points, ``alpha, beta, kappa``) on the same
    discretised model (sigma points through the RK4 step; ``progress(k, N)`` is called
    every 2000 steps). After each predict and update, P is re-symmetrised and its
    eigenvalues floored (:func:`nearest_spd`); ``info['spd_repairs']`` counts the repairs."""
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    tuning = tuning or KalmanTuning()
    inp = prepare(log, use_ay)
    state, fx, jac, hx, Hj = _filterpy_models(inp, params)
    dz = 2 if inp.use_ay else 1
    pts = MerweScaledSigmaPoints(3, alpha=alpha, beta=beta, kappa=kappa)
    dt0 = float(np.median(np.diff(inp.t))) if len(inp.t) > 1 else 0.01
    kf = UnscentedKalmanFilter(dim_x=3, dim_z=dz, dt=dt0, hx=hx, fx=fx, points=pts)
    kf.x = inp.x0.copy()
    kf.P = np.diag(_p0(tuning.P0, inp))
    kf.R = np.diag([tuning.R_r, tuning.R_ay][:dz])
    q = tuning.theta()[:3].copy()
    if not inp.use_ay:
        q[2] = 0.0
    N = len(inp.t)
    X = np.empty((N, 3))
    P = np.empty((N, 3, 3))
    z = np.column_stack([inp.yr, inp.ay])[:, :dz]
    repairs = 0
    t0 = time.perf_counter()
    # filterpy's UKF predicts from the stored sigma points of the last update, so the
    # sequence is predict(k-1 -> k) then update(k); the first sample is updated directly.
    kf.sigmas_f = pts.sigma_points(kf.x, kf.P)  # the prior at k = 0 is (x0, P0)
    for k in range(N):
        if progress is not None and k % 2000 == 0:
            progress(k, N)
        if k > 0:
            h = inp.t[k] - inp.t[k - 1]
            state["k"] = k - 1
            kf.Q = np.diag(q * h)
            kf.predict(dt=h)
            kf.P, fixed = nearest_spd(kf.P)
            repairs += fixed
        state["k"] = k
        if k == 0:
            kf.sigmas_f = pts.sigma_points(kf.x, kf.P)
        kf.update(z[k])
        kf.P, fixed = nearest_spd(kf.P)
        repairs += fixed
        X[k] = kf.x
        P[k] = kf.P
    sec = time.perf_counter() - t0
    Ff, Fr = _forces(X, inp, params)
    return KalmanResult("UKF (filterpy)", inp.t, X, P, Ff, Fr, float("nan"), sec, True,
                        {"use_ay": inp.use_ay, "tuning": tuning, "spd_repairs": repairs})


def with_tuning(res: KalmanResult, tuning: KalmanTuning) -> KalmanResult:
    return replace(res, info={**res.info, "tuning": tuning})
