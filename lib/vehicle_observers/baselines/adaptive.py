"""An EKF on the single-track model with optional model terms, each switched by a flag.

State ``x = [v_y (m/s), r (rad/s), b (m/s^2), d (m/s^2), k_f, k_r]``; inputs
``delta`` [rad], ``v_x`` [m/s] (and the measured ``a_y`` of the previous sample for the
kinematic blend); measurements ``y = [r, a_y]`` (or ``r`` alone).

Model (continuous time, SI units; ``F_f0``, ``F_r0`` the vehicle file's tyres at the
small-angle slip angles ``alpha_f = delta - (v_y + a_f r)/v_x``, ``alpha_r = -(v_y - a_r
r)/v_x``, Yacine 2015 eqs. (1), (4)):

    F_f = k_f F_f0(alpha_f),   F_r = k_r F_r0(alpha_r)
    v_y' = (1 - w) (F_f + F_r)/m + w (a_y,meas - b)/g_ay - v_x r + d + w_1
    r'   = (a_f F_f - a_r F_r)/I_z + w_2
    b' = w_3,  d' = w_4,  k_f' = w_5,  k_r' = w_6          (random walks)
    r_meas  = r + v_1
    a_y,meas = g_ay (F_f + F_r)/m + b + v_2

The terms (:class:`Terms`; each off leaves the plain EKF of the nonlinear single-track model):

* ``roll`` - accelerometer on the rolling body: a sensor fixed to the sprung mass reads
  ``a_y cos(phi) - g sin(phi)`` with the roll angle ``phi = -k_phi a_y`` (roll gradient
  ``k_phi`` [rad per m/s^2]), i.e. ``g_ay ~ 1 + g k_phi`` (:mod:`vehicle_observers.data.plant`
  docstring). ``g_ay`` is identified from the measured channels (innovation likelihood,
  :mod:`vehicle_observers.estimation.selection`); off: ``g_ay = 1``.
* ``bias`` - a random-walk offset ``b`` of the a_y channel (mounting, sensor offset).
* ``bank`` - road bank as an estimated disturbance ``d = g sin(theta_bank)`` in the lateral
  balance: the accelerometer reads the tyre forces only (specific force), so a bank moves
  ``v_y`` and ``r`` but not ``a_y``; ``b`` and ``d`` are told apart by the yaw dynamics.
* ``stiffness`` - axle cornering-stiffness factors ``k_f``, ``k_r`` (the whole tyre curve
  scaled), random walks bounded by the vehicle file's box ``1 +- uncertainty.stiffness_rel``
  (the mean is projected onto the box after every update): joint EKF. **Understeer direction
  only** (``Terms.understeer_only``, the default): in steady cornering yaw rate and ``a_y``
  fix only the understeer gradient ``K_us = m/L (a_r/C_f - a_f/C_r)`` (``L = a_f + a_r``;
  ``r/delta = v_x/(L + K_us v_x^2)``, ``a_y = v_x r``), so the factors drift along the level
  set of ``K_us`` there. The adaptation is restricted to ``k = 1 + s u`` with ``u`` the unit
  gradient of ``K_us`` in ``(k_f, k_r)`` at ``(1, 1)``, ``u ~ (-a_r/C_f, a_f/C_r)``: the
  gain rows of ``(k_f, k_r)`` and their process noise ``q_k u u^T`` are projected on ``u``,
  the mean is kept on that line inside the box; the orthogonal direction keeps its initial
  variance as a Schmidt consider state (never updated, carried into the v_y variance; the
  registered ``adaptive-ekf`` adds the calibration's stiffness-box consider term for it,
  :mod:`vehicle_observers.estimation.calibration`).
  In **consider** mode
  (``Terms.consider = True``, a Schmidt-Kalman filter) they are not estimated but their box
  variance ``rel^2/3`` (uniform) stays in the covariance, so the reported ``v_y`` variance
  carries the stiffness uncertainty of the vehicle file.
* ``blend`` - kinematic/dynamic blending: the weight ``w = w_max r^2/(r^2 + r_0^2)`` moves
  the lateral balance from the tyre model (dynamic, ``w = 0`` at low yaw rate, where the
  integrated accelerometer is ill-conditioned against its own offset) towards the
  integrated accelerometer (kinematic, ``v_y' = a_y - v_x r``) in strong cornering, where
  the tyre curve is least known. The measured ``a_y`` of sample ``k-1`` is held over the
  step (causal).

Discretisation: one RK4 step of the mean per sample interval ``h`` (inputs held at sample
``k-1``); transition Jacobian ``F = I + h A + h^2 A^2/2`` (``A`` the continuous Jacobian at
the posterior of ``k-1``: second order in ``h |lambda| <= 0.12`` at 100 Hz); ``Q = diag(q) h``.
The update uses the Joseph form (valid for the consider filter's zeroed gain rows).

Kernels: :func:`_run` (numba, ``cache=True``) and the readable numpy :class:`AdaptiveEKF`
step (:func:`model_np`, :func:`measure_np`), tested equal.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, fields

import numpy as np
from numba import njit

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import ObserverBase, Trajectory
from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.tires import magic_formula, magic_formula_slope

NX = 6
STATE_NAMES = ("vy_mps", "yaw_rate_radps", "ay_bias_mps2", "bank_mps2", "kf", "kr")
#: the optional terms, in the order the selection tries them
TERM_NAMES = ("roll", "bias", "bank", "stiffness", "blend")
#: initial sideslip std [rad] capping the initial v_y variance at ``(BETA0_STD v_x(0))^2``
BETA0_STD = 0.05
#: initial std of the bank disturbance [m/s^2] (``g sin 3 deg``)
BANK0_STD = 0.5
#: initial std of the a_y offset [m/s^2]
BIAS0_STD = 1.0
#: kinematic blend: yaw rate [rad/s] at which half of ``w_max`` is reached
BLEND_R0 = 0.1


@dataclass(frozen=True)
class Terms:
    """Which optional model terms are on (module docstring). ``consider``: the stiffness
    factors are Schmidt "consider" states (covariance kept, never updated) when
    ``stiffness`` is off; with ``stiffness`` on they are estimated."""

    roll: bool = False
    bias: bool = False
    bank: bool = False
    stiffness: bool = False
    blend: bool = False
    consider: bool = False
    understeer_only: bool = True

    def on(self) -> tuple[str, ...]:
        return tuple(n for n in TERM_NAMES if getattr(self, n))

    def with_(self, **kw) -> Terms:
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        d.update(kw)
        return Terms(**d)

    def __str__(self):
        s = "+".join(self.on()) or "none"
        return s + (" (stiffness considered)" if self.consider and not self.stiffness else "")


@dataclass(frozen=True)
class AdaptiveTuning:
    """Noise and term parameters. ``q_*``: white-noise intensities of ``v_y'`` [(m/s^2)^2 s],
    ``r'`` [(rad/s^2)^2 s], ``b'`` [(m/s^3)^2 s], ``d'`` [(m/s^3)^2 s], ``k'`` [1/s];
    ``R_r`` [(rad/s)^2], ``R_ay`` [(m/s^2)^2]; ``ay_gain`` ``g_ay``; ``w_max`` the kinematic
    blend weight; ``rel`` the stiffness box half-width (``k`` in ``[1 - rel, 1 + rel]``)."""

    q_vy: float = 1e-3
    q_r: float = 1e-3
    q_b: float = 1e-4
    q_d: float = 1e-4
    q_k: float = 1e-4
    R_r: float = 1e-5
    R_ay: float = 1e-2
    ay_gain: float = 1.0
    w_max: float = 0.5
    rel: float = 0.1
    source: str = field(default="defaults", compare=False)

    def theta(self, terms: Terms) -> np.ndarray:
        """Kernel parameter vector (terms that are off get zero noise / neutral values)."""
        return np.array([self.q_vy, self.q_r, self.q_b if terms.bias else 0.0,
                         self.q_d if terms.bank else 0.0, self.q_k if terms.stiffness else 0.0,
                         self.R_r, self.R_ay, self.ay_gain if terms.roll else 1.0,
                         self.w_max if terms.blend else 0.0, BLEND_R0, 1.0 - self.rel,
                         1.0 + self.rel, 1.0 if terms.stiffness else 0.0, 0.0, 0.0],
                        dtype=float)


def understeer_direction(params: LateralParams) -> np.ndarray:
    """Unit gradient ``u`` (2,) of the understeer gradient ``K_us = m/L (a_r/(k_f C_f) -
    a_f/(k_r C_r))`` in the stiffness factors ``(k_f, k_r)`` at ``(1, 1)`` (``C`` the
    zero-slip cornering stiffnesses of the vehicle file; module docstring): the one
    direction of the factors that steady cornering identifies."""
    g = np.array([-params.a_r / params.tire_f.cornering_stiffness,
                  params.a_f / params.tire_r.cornering_stiffness])
    return g / np.linalg.norm(g)


def initial_covariance(terms: Terms, vx0: float, rel: float) -> np.ndarray:
    """Diagonal of ``P_0``: ``v_y`` ``(BETA0_STD v_x(0))^2``, ``r`` 0.01, the terms that are
    on their initial variances (bias :data:`BIAS0_STD`, bank :data:`BANK0_STD`, stiffness
    ``(rel/2)^2`` estimated or ``rel^2/3`` considered), the others 0 (inert)."""
    k0 = (rel / 2) ** 2 if terms.stiffness else (rel**2 / 3 if terms.consider else 0.0)
    return np.array([(BETA0_STD * max(float(vx0), 1.0)) ** 2, 0.01,
                     BIAS0_STD**2 if terms.bias else 0.0, BANK0_STD**2 if terms.bank else 0.0,
                     k0, k0])


# ------------------------------------------------------------------ compiled model ---------
@njit(cache=True)
def _model(x, delta, vx, ayin, P, th, f, A, gyin=0.0):
    """Continuous right-hand side ``f`` (6,) and Jacobian ``A`` (6, 6) (module docstring);
    ``gyin`` [m/s^2] the measured bank term ``-g sin(phi)`` (:mod:`vehicle_observers.models.road`)."""
    m, Iz, af, ar = P[0], P[1], P[2], P[3]
    vy, r, b, d, kf, kr = x[0], x[1], x[2], x[3], x[4], x[5]
    g, wmax, r0 = th[7], th[8], th[9]
    a_f = delta - (vy + af * r) / vx
    a_r = -(vy - ar * r) / vx
    Ff0, dFf0 = magic_formula_slope(a_f, P[7], P[8], P[9], P[10])
    Fr0, dFr0 = magic_formula_slope(a_r, P[11], P[12], P[13], P[14])
    Ff, Fr = kf * Ff0, kr * Fr0
    dyn = (Ff + Fr) / m
    w = 0.0
    dw = 0.0
    if wmax > 0.0:
        den = r * r + r0 * r0
        w = wmax * r * r / den
        dw = wmax * 2.0 * r * r0 * r0 / (den * den)
    kin = (ayin - b) / g
    for i in range(6):
        f[i] = 0.0
        for j in range(6):
            A[i, j] = 0.0
    f[0] = (1.0 - w) * dyn + w * kin - vx * r + d + gyin
    f[1] = (af * Ff - ar * Fr) / Iz
    fv, fr = -kf * dFf0 / vx, -kf * dFf0 * af / vx
    rv, rr = -kr * dFr0 / vx, kr * dFr0 * ar / vx
    A[0, 0] = (1.0 - w) * (fv + rv) / m
    A[0, 1] = (1.0 - w) * (fr + rr) / m + (kin - dyn) * dw - vx
    A[0, 2] = -w / g
    A[0, 3] = 1.0
    A[0, 4] = (1.0 - w) * Ff0 / m
    A[0, 5] = (1.0 - w) * Fr0 / m
    A[1, 0] = (af * fv - ar * rv) / Iz
    A[1, 1] = (af * fr - ar * rr) / Iz
    A[1, 4] = af * Ff0 / Iz
    A[1, 5] = -ar * Fr0 / Iz


@njit(cache=True)
def _model_f(x, delta, vx, ayin, P, th, f, gyin=0.0):
    """:func:`_model` without the Jacobian (the RK4 stages 2-4)."""
    m, Iz, af, ar = P[0], P[1], P[2], P[3]
    vy, r, b, d, kf, kr = x[0], x[1], x[2], x[3], x[4], x[5]
    g, wmax, r0 = th[7], th[8], th[9]
    Ff = kf * magic_formula(delta - (vy + af * r) / vx, P[7], P[8], P[9], P[10])
    Fr = kr * magic_formula(-(vy - ar * r) / vx, P[11], P[12], P[13], P[14])
    w = wmax * r * r / (r * r + r0 * r0) if wmax > 0.0 else 0.0
    f[0] = (1.0 - w) * (Ff + Fr) / m + w * (ayin - b) / g - vx * r + d + gyin
    f[1] = (af * Ff - ar * Fr) / Iz
    for i in range(2, 6):
        f[i] = 0.0


@njit(cache=True)
def _measure(x, delta, vx, P, th, yh, H):
    """``h(x) = [r, g_ay (F_f + F_r)/m + b]`` and its Jacobian ``H`` (2, 6)."""
    m, af, ar = P[0], P[2], P[3]
    vy, r, b, kf, kr = x[0], x[1], x[2], x[4], x[5]
    g = th[7]
    a_f = delta - (vy + af * r) / vx
    a_r = -(vy - ar * r) / vx
    Ff0, dFf0 = magic_formula_slope(a_f, P[7], P[8], P[9], P[10])
    Fr0, dFr0 = magic_formula_slope(a_r, P[11], P[12], P[13], P[14])
    for j in range(6):
        H[0, j] = 0.0
        H[1, j] = 0.0
    yh[0] = r
    H[0, 1] = 1.0
    yh[1] = g * (kf * Ff0 + kr * Fr0) / m + b
    H[1, 0] = g * (-kf * dFf0 / vx - kr * dFr0 / vx) / m
    H[1, 1] = g * (-kf * dFf0 * af / vx + kr * dFr0 * ar / vx) / m
    H[1, 2] = 1.0
    H[1, 4] = g * Ff0 / m
    H[1, 5] = g * Fr0 / m


@njit(cache=True)
def _predict(x, Pm, delta, vx, ayin, h, P, th, W, V, gyin=0.0):
    """Mean: RK4 (inputs held); covariance: ``F Pm F^T + diag(q) h``, ``F = I + hA +
    h^2 A^2 / 2``. Scratch ``W`` (4, 6, 6), ``V`` (5, 6)."""
    A, F, T = W[0], W[1], W[2]
    k1, k2, k3, k4, tmp = V[0], V[1], V[2], V[3], V[4]
    _model(x, delta, vx, ayin, P, th, k1, A, gyin)
    # only rows 0, 1 of A are non-zero: F = I + h A + h^2 A^2/2 differs from I in rows 0, 1
    for i in range(6):
        for j in range(6):
            F[i, j] = 1.0 if i == j else 0.0
    for i in range(2):
        for j in range(6):
            F[i, j] += h * A[i, j] + 0.5 * h * h * (A[i, 0] * A[0, j] + A[i, 1] * A[1, j])
    for i in range(6):
        tmp[i] = x[i] + 0.5 * h * k1[i]
    _model_f(tmp, delta, vx, ayin, P, th, k2, gyin)
    for i in range(6):
        tmp[i] = x[i] + 0.5 * h * k2[i]
    _model_f(tmp, delta, vx, ayin, P, th, k3, gyin)
    for i in range(6):
        tmp[i] = x[i] + h * k3[i]
    _model_f(tmp, delta, vx, ayin, P, th, k4, gyin)
    for i in range(6):
        x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    # T = F Pm (rows 2..5 are those of Pm); Pm = T F^T (columns 2..5 those of T) + Q h
    for i in range(2):
        for j in range(6):
            s = 0.0
            for l in range(6):
                s += F[i, l] * Pm[l, j]
            T[i, j] = s
    for i in range(2, 6):
        for j in range(6):
            T[i, j] = Pm[i, j]
    for i in range(6):
        for j in range(2):
            s = 0.0
            for l in range(6):
                s += T[i, l] * F[j, l]
            A[i, j] = s                       # A is free now: column j of T F^T
    for i in range(6):
        for j in range(6):
            v = A[i, j] if j < 2 else (A[j, i] if i < 2 else T[i, j])
            Pm[i, j] = v
    for i in range(4):
        Pm[i, i] += th[i] * h
    u0, u1 = th[13], th[14]
    if u0 != 0.0 or u1 != 0.0:               # stiffness along the understeer direction only
        Pm[4, 4] += th[4] * h * u0 * u0
        Pm[4, 5] += th[4] * h * u0 * u1
        Pm[5, 4] += th[4] * h * u0 * u1
        Pm[5, 5] += th[4] * h * u1 * u1
    else:
        Pm[4, 4] += th[4] * h
        Pm[5, 5] += th[4] * h


@njit(cache=True)
def _update(x, Pm, delta, vx, yr, ay, use_ay, P, th, W, V, out):
    """Joseph-form update (expanded) with ``[r, a_y]`` (or ``r``); the stiffness rows of the gain are
    zeroed in consider mode (``th[12] == 0``) and the stiffness mean is projected onto the
    box. ``out`` (4,): NLL contribution, normalised innovations of r and a_y, NIS."""
    H = W[0, :2, :]
    K = W[1, :, :2]
    PH = W[2, :, :2]
    yh = V[0, :2]
    e = V[1, :2]
    _measure(x, delta, vx, P, th, yh, H)
    n = 2 if use_ay else 1
    e[0] = yr - yh[0]
    e[1] = ay - yh[1]
    for i in range(6):
        for a in range(n):
            s = 0.0
            for l in range(6):
                s += Pm[i, l] * H[a, l]
            PH[i, a] = s
    s00 = PH[1, 0] + th[5]                  # H[0] = e_1
    s01 = 0.0
    s11 = 0.0
    if n == 2:
        s01 = PH[1, 1]
        s11 = th[6]
        for l in range(6):
            s11 += H[1, l] * PH[l, 1]
        det = s00 * s11 - s01 * s01
        i00, i01, i11 = s11 / det, -s01 / det, s00 / det
        nis = e[0] * (i00 * e[0] + i01 * e[1]) + e[1] * (i01 * e[0] + i11 * e[1])
        out[0] = 0.5 * (np.log(det) + nis + 2.0 * np.log(2.0 * np.pi))
        out[1] = e[0] / np.sqrt(s00)
        out[2] = e[1] / np.sqrt(s11)
        out[3] = nis
        for i in range(6):
            K[i, 0] = PH[i, 0] * i00 + PH[i, 1] * i01
            K[i, 1] = PH[i, 0] * i01 + PH[i, 1] * i11
    else:
        nis = e[0] * e[0] / s00
        out[0] = 0.5 * (np.log(s00) + nis + np.log(2.0 * np.pi))
        out[1] = e[0] / np.sqrt(s00)
        out[2] = np.nan
        out[3] = nis
        for i in range(6):
            K[i, 0] = PH[i, 0] / s00
    if th[12] == 0.0:                       # stiffness not estimated: consider / inert
        for a in range(n):
            K[4, a] = 0.0
            K[5, a] = 0.0
    elif th[13] != 0.0 or th[14] != 0.0:    # gain rows projected on u (Schmidt elsewhere)
        for a in range(n):
            sa = th[13] * K[4, a] + th[14] * K[5, a]
            K[4, a] = th[13] * sa
            K[5, a] = th[14] * sa
    for i in range(6):
        for a in range(n):
            x[i] += K[i, a] * e[a]
    # Joseph form expanded (valid for any gain): P - K (PH)^T - PH K^T + K S K^T
    for i in range(6):
        if n == 2:
            u0 = K[i, 0] * s00 + K[i, 1] * s01
            u1 = K[i, 0] * s01 + K[i, 1] * s11
        else:
            u0 = K[i, 0] * s00
            u1 = 0.0
        for j in range(i, 6):
            v = Pm[i, j] - K[i, 0] * PH[j, 0] - PH[i, 0] * K[j, 0] + u0 * K[j, 0]
            if n == 2:
                v += -K[i, 1] * PH[j, 1] - PH[i, 1] * K[j, 1] + u1 * K[j, 1]
            Pm[i, j] = v
            Pm[j, i] = v
    if th[12] != 0.0:
        if th[13] != 0.0 or th[14] != 0.0:
            _clip_on_line(x, th)
        else:
            for i in range(4, 6):
                x[i] = min(max(x[i], th[10]), th[11])


@njit(cache=True)
def _clip_on_line(x, th):
    """The factors ``1 + s u`` kept in the box ``[th[10], th[11]]^2`` by clipping ``s``
    (the mean stays on the understeer line)."""
    s = th[13] * (x[4] - 1.0) + th[14] * (x[5] - 1.0)
    lo, hi = -1e300, 1e300
    for i in range(2):
        ui = th[13 + i]
        if ui > 0.0:
            lo, hi = max(lo, (th[10] - 1.0) / ui), min(hi, (th[11] - 1.0) / ui)
        elif ui < 0.0:
            lo, hi = max(lo, (th[11] - 1.0) / ui), min(hi, (th[10] - 1.0) / ui)
    s = min(max(s, lo), hi)
    x[4] = 1.0 + s * th[13]
    x[5] = 1.0 + s * th[14]


@njit(cache=True)
def _run(t, vx, delta, yr, ay, use_ay, P, th, x0, P0):
    """:func:`_run_terms` on a flat road."""
    return _run_terms(t, vx, delta, yr, ay, use_ay, P, th, x0, P0, np.zeros(t.shape[0]))


@njit(cache=True)
def _run_terms(t, vx, delta, yr, ay, use_ay, P, th, x0, P0, gy):
    """The filter over a log (``gy`` (N,) the measured bank term, held over each step).
    Returns X (N, 6) posterior means, Pd (N, 6) posterior variances, the innovation NLL,
    nu (N, 2) normalised innovations, nis (N,)."""
    N = t.shape[0]
    X = np.empty((N, 6))
    Pd = np.empty((N, 6))
    nu = np.empty((N, 2))
    nis = np.empty(N)
    W = np.empty((4, 6, 6))
    V = np.empty((5, 6))
    out = np.empty(4)
    x = x0.copy()
    Pm = np.zeros((6, 6))
    for i in range(6):
        Pm[i, i] = P0[i]
    nll = 0.0
    for k in range(N):
        if k > 0:
            _predict(x, Pm, delta[k - 1], vx[k - 1], ay[k - 1], t[k] - t[k - 1], P, th, W, V,
                     gy[k - 1])
        _update(x, Pm, delta[k], vx[k], yr[k], ay[k], use_ay, P, th, W, V, out)
        nll += out[0]
        nu[k, 0], nu[k, 1], nis[k] = out[1], out[2], out[3]
        for i in range(6):
            X[k, i] = x[i]
            Pd[k, i] = Pm[i, i]
    return X, Pd, nll, nu, nis


@njit(cache=True)
def _step(z, k, t, vx, delta, yr, ay, use_ay, P, th):
    """One compiled protocol step on ``z = [x (6), P (36)]`` (the readable step's twin)."""
    x = z[:6].copy()
    Pm = z[6:].reshape(6, 6).copy()
    W = np.empty((4, 6, 6))
    V = np.empty((5, 6))
    out = np.empty(4)
    _predict(x, Pm, delta[k - 1], vx[k - 1], ay[k - 1], t[k] - t[k - 1], P, th, W, V)
    _update(x, Pm, delta[k], vx[k], yr[k], ay[k], use_ay, P, th, W, V, out)
    zn = np.empty(42)
    zn[:6] = x
    zn[6:] = Pm.ravel()
    return zn


# ------------------------------------------------------------------ readable numpy ---------
def model_np(x, delta, vx, ayin, p: LateralParams, th, gyin: float = 0.0):
    """Readable twin of :func:`_model`: ``(f (6,), A (6, 6))``."""
    vy, r, b, d, kf, kr = x
    g, wmax, r0 = th[7], th[8], th[9]
    af, ar, m, Iz = p.a_f, p.a_r, p.m, p.I_z
    a_f = delta - (vy + af * r) / vx
    a_r = -(vy - ar * r) / vx
    (Ff0, dFf0), (Fr0, dFr0) = _tyre_np(p.tire_f, a_f), _tyre_np(p.tire_r, a_r)
    Ff, Fr = kf * Ff0, kr * Fr0
    dyn = (Ff + Fr) / m
    den = r * r + r0 * r0
    w, dw = (wmax * r * r / den, wmax * 2 * r * r0 * r0 / den**2) if wmax > 0 else (0.0, 0.0)
    kin = (ayin - b) / g
    f = np.array([(1 - w) * dyn + w * kin - vx * r + d + gyin, (af * Ff - ar * Fr) / Iz,
                  0, 0, 0, 0])
    dF = np.array([[-kf * dFf0 / vx, -kf * dFf0 * af / vx, 0, 0, Ff0, 0],    # dF_f/dx
                   [-kr * dFr0 / vx, kr * dFr0 * ar / vx, 0, 0, 0, Fr0]])    # dF_r/dx
    A = np.zeros((6, 6))
    A[0] = (1 - w) * (dF[0] + dF[1]) / m + np.array([0, (kin - dyn) * dw - vx, -w / g, 1, 0, 0])
    A[1] = (af * dF[0] - ar * dF[1]) / Iz
    return f, A


def measure_np(x, delta, vx, p: LateralParams, th):
    """Readable twin of :func:`_measure`: ``(y (2,), H (2, 6))``."""
    vy, r, b, d, kf, kr = x
    g = th[7]
    a_f = delta - (vy + p.a_f * r) / vx
    a_r = -(vy - p.a_r * r) / vx
    (Ff0, dFf0), (Fr0, dFr0) = _tyre_np(p.tire_f, a_f), _tyre_np(p.tire_r, a_r)
    H = np.zeros((2, 6))
    H[0, 1] = 1.0
    H[1] = g / p.m * np.array([-(kf * dFf0 + kr * dFr0) / vx,
                               (-kf * dFf0 * p.a_f + kr * dFr0 * p.a_r) / vx, 0, 0, Ff0, Fr0])
    H[1, 2] = 1.0
    return np.array([r, g * (kf * Ff0 + kr * Fr0) / p.m + b]), H


def _line_box(u, lo, hi):
    """Range of ``s`` with ``1 + s u`` in ``[lo, hi]^2`` (readable twin of
    :func:`_clip_on_line`)."""
    a = [((lo - 1) / ui, (hi - 1) / ui) if ui > 0 else ((hi - 1) / ui, (lo - 1) / ui)
         for ui in u if ui != 0]
    return max(v[0] for v in a), min(v[1] for v in a)


def _tyre_np(tire, alpha):
    from vehicle_observers.models.lateral import _tire_coeffs

    return magic_formula_slope(float(alpha), *_tire_coeffs(tire))


class AdaptiveEKF(ObserverBase):
    """The filter as an :class:`~vehicle_observers.core.protocol.Observer`: inputs
    ``[v_x, delta]``, outputs ``[r, a_y]`` (``a_y`` ignored when ``use_ay`` is False),
    estimate :data:`STATE_NAMES`, internal state ``z = [x (6), P (36)]``."""

    state_names = STATE_NAMES
    input_names = ("vx_mps", "delta_roadwheel_rad")
    output_names = ("yaw_rate_radps", "ay_mps2")

    def __init__(self, params: LateralParams, terms: Terms = Terms(),
                 tuning: AdaptiveTuning = AdaptiveTuning(), use_ay: bool = True):
        if (terms.roll or terms.bias or terms.blend) and not use_ay:
            raise ObserverArgumentError(f"AdaptiveEKF: terms {terms} need the a_y channel "
                                        "(use_ay=False)")
        if not 0.0 <= tuning.rel < 1.0:
            raise ObserverArgumentError(f"AdaptiveEKF: tuning.rel must be in [0, 1), got "
                                        f"{tuning.rel}")
        self.params, self.terms, self.tuning, self.use_ay = params, terms, tuning, bool(use_ay)
        self.th = tuning.theta(terms)
        if terms.stiffness and terms.understeer_only:
            self.th[13:15] = understeer_direction(params)
        self.P = params.as_array()
        self.design = {"terms": terms, "tuning": tuning}

    # --- protocol -------------------------------------------------------------------
    def initial_state(self, t, u, y, x0=None):
        x = np.array([0.0, y[0, 0], 0.0, 0.0, 1.0, 1.0]) if x0 is None \
            else np.asarray(x0, float).copy()
        Pm = np.diag(initial_covariance(self.terms, u[0, 0], self.tuning.rel))
        x, Pm, _ = self._update_np(x, Pm, u[0], y[0])
        return np.r_[x, Pm.ravel()]

    def _update_np(self, x, Pm, uk, yk):
        th = self.th
        yh, H = measure_np(x, uk[1], uk[0], self.params, th)
        n = 2 if self.use_ay else 1
        H, e, R = H[:n], (yk - yh)[:n], np.diag([th[5], th[6]][:n])
        S = H @ Pm @ H.T + R
        K = Pm @ H.T @ np.linalg.inv(S)
        u = th[13:15]
        if th[12] == 0.0:
            K[4:] = 0.0
        elif u.any():
            K[4:] = np.outer(u, u) @ K[4:]
        x = x + K @ e
        M = np.eye(6) - K @ H
        Pm = M @ Pm @ M.T + K @ R @ K.T
        if th[12] != 0.0 and u.any():
            x[4:] = 1.0 + u * np.clip(u @ (x[4:] - 1.0), *_line_box(u, th[10], th[11]))
        elif th[12] != 0.0:
            x[4:] = np.clip(x[4:], th[10], th[11])
        nll = 0.5 * (np.log(np.linalg.det(S)) + e @ np.linalg.solve(S, e) + n * np.log(2 * np.pi))
        return x, 0.5 * (Pm + Pm.T), nll

    def step(self, z, k, t, u, y):
        th = self.th
        x, Pm = z[:6].copy(), z[6:].reshape(6, 6)
        h = t[k] - t[k - 1]
        ayin = y[k - 1, 1]
        args = (u[k - 1, 1], u[k - 1, 0], ayin, self.params, th)
        f1, A = model_np(x, *args)
        f2, _ = model_np(x + 0.5 * h * f1, *args)
        f3, _ = model_np(x + 0.5 * h * f2, *args)
        f4, _ = model_np(x + h * f3, *args)
        x = x + h / 6 * (f1 + 2 * f2 + 2 * f3 + f4)
        F = np.eye(6) + h * A + 0.5 * h * h * A @ A
        Q = np.diag(np.r_[th[:5], th[4]])
        if th[13:15].any():
            Q[4:, 4:] = th[4] * np.outer(th[13:15], th[13:15])
        Pm = F @ Pm @ F.T + Q * h
        x, Pm, _ = self._update_np(x, Pm, u[k], y[k])
        return np.r_[x, Pm.ravel()]

    def estimate(self, z):
        return z[:6].copy()

    def run(self, t, u, y, x0=None) -> Trajectory:
        t, u, y, x0 = self.check_data(t, u, y, x0)
        res = self.filter(t, u[:, 0], u[:, 1], y[:, 0], y[:, 1], x0)
        return Trajectory(t, res["X"], self.state_names, seconds=res["seconds"],
                          estimator="adaptive-ekf", info={"nll": res["nll"],
                                                          "std": np.sqrt(res["Pd"])})

    def filter(self, t, vx, delta, yr, ay, x0=None, gy=None) -> dict:
        """Compiled pass; ``{"X", "Pd", "nll", "nu", "nis", "seconds"}``. ``gy`` (N,)
        [m/s^2]: the measured bank term ``-g sin(phi)`` (:func:`vehicle_observers.models.road.
        lateral_gravity`; ``None``: a flat road)."""
        x0 = np.array([0.0, yr[0], 0.0, 0.0, 1.0, 1.0]) if x0 is None else np.asarray(x0, float)
        P0 = initial_covariance(self.terms, vx[0], self.tuning.rel)
        ay = np.zeros_like(yr) if ay is None else ay
        args = [np.ascontiguousarray(a, float) for a in (t, vx, delta, yr, ay)]
        t0 = time.perf_counter()
        gy = np.zeros(len(args[0])) if gy is None else np.ascontiguousarray(gy, float)
        X, Pd, nll, nu, nis = _run_terms(*args, self.use_ay, self.P, self.th, x0, P0, gy)
        return {"X": X, "Pd": Pd, "nll": float(nll), "nu": nu, "nis": nis,
                "seconds": time.perf_counter() - t0}

    def compiled_step(self, z, k, t, u, y):
        """The numba step on ``z`` (tests: equal to :meth:`step`)."""
        return _step(np.ascontiguousarray(z, float), int(k), *[np.ascontiguousarray(a, float)
                     for a in (t, u[:, 0], u[:, 1], y[:, 0], y[:, 1])], self.use_ay, self.P,
                     self.th)


def simulate(params: LateralParams, t, vx, delta, kf: float = 1.0, kr: float = 1.0,
             ay_gain: float = 1.0, bias: float = 0.0, bank: float = 0.0,
             noise=(0.002, 0.05), seed: int = 0):
    """Data generated by the model of this module with the terms given (constant ``bias``
    [m/s^2], ``bank`` disturbance ``d`` [m/s^2], stiffness factors ``kf``, ``kr``,
    accelerometer gain ``ay_gain``; no blend, no process noise), RK4 per sample with the
    inputs held. ``noise``: white measurement noise std of ``(r, a_y)``, drawn with
    ``numpy.random.default_rng(seed)`` (r then a_y, per sample). Returns a
    :class:`~vehicle_observers.data.logs.DriveLog` whose ``vy`` is the simulated truth."""
    from vehicle_observers.data.logs import DriveLog

    t, vx, delta = (np.asarray(a, float) for a in (t, vx, delta))
    th = AdaptiveTuning(ay_gain=ay_gain).theta(Terms(roll=True))
    x = np.array([0.0, 0.0, bias, bank, kf, kr])
    rng = np.random.default_rng(seed)
    N = len(t)
    X = np.empty((N, 6))
    Y = np.empty((N, 2))
    for k in range(N):
        X[k] = x
        y, _ = measure_np(x, delta[k], vx[k], params, th)
        Y[k] = y + rng.standard_normal(2) * np.asarray(noise, float)
        if k + 1 < N:
            h = t[k + 1] - t[k]
            args = (delta[k], vx[k], 0.0, params, th)
            f1, _ = model_np(x, *args)
            f2, _ = model_np(x + 0.5 * h * f1, *args)
            f3, _ = model_np(x + 0.5 * h * f2, *args)
            f4, _ = model_np(x + h * f3, *args)
            x = x + h / 6 * (f1 + 2 * f2 + 2 * f3 + f4)
    return DriveLog(t=t.copy(), vx=vx.copy(), delta=delta.copy(), yaw_rate=Y[:, 0], ay=Y[:, 1],
                    vy=X[:, 0], source=f"adaptive-model simulation (kf={kf:g}, kr={kr:g}, "
                    f"g_ay={ay_gain:g}, bias={bias:g}, bank={bank:g}, seed={seed})")
