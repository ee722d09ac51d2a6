"""Sliding-mode observers of Rabhi, Imine, M'Sirdi, Delanne (AVCS 2004).

Part A: tyre-force observer with adaptive force model, eqs. (9)-(22)
Part B: sliding-mode unknown-input observer of the road profile, eqs. (30)-(38)

Both are discrete-time loops (explicit Euler at the measurement period ``dt``) compiled
with numba, and follow the observer contract of :mod:`vehicle_observers.core.protocol`
(:class:`ForceObserver`, :class:`RoadObserver`, and :class:`PaperOutputObserver` for the
road on the paper's outputs (29)): a readable numpy ``step`` and a compiled ``run`` giving
the same numbers, runs returning a :class:`~vehicle_observers.core.protocol.Trajectory`
subclass whose paper-named properties (``x2``, ``x4``, ``theta``, ``U``, ``zeta``, ...) are
views of its columns. The gains are rules (no LMI): their ``certificate`` is ``None``.
The switching function is selectable (``mode``):

* ``SIGN`` (0): the paper's ``sign`` (chattering of amplitude ``lambda dt`` in the
  observed states, full-amplitude switching in the injected terms);
* ``SAT`` (1): boundary layer, ``sat(e / phi)`` (continuous; inside the layer the observer
  is a high-gain linear one, the sliding is no longer exact: accuracy cost);
* ``LPF`` (2): ``sign`` in the sliding loops but only the *low-pass filtered* equivalent
  injection (time constant ``tau_f``) is passed on to the estimated unknowns (forces,
  road input): no chattering in the estimates, a lag ``tau_f`` instead.

Switching-function values ``s`` are clipped to [-1, 1] in every mode.

Part A reconstructions (written here and in notebook 05)
--------------------------------------------------------
R-A3  State form (9): ``x2 = (v_x, v_y, r)`` (the extraction's ``psi`` is the yaw *rate*),
      ``x3 = (omega_f, omega_r)``, ``x4 = (F_xf, F_xr, F_yf, F_yr)``. The body-frame
      transport terms ``f0(x2) = (v_y r, -v_x r, 0)`` (dropped in (9)) are known because
      ``x2`` is measured and are added to the observer.
R-A4  ``Omega(u)`` row 1 has ``+sin(d)/m`` for ``F_yf``; from (4) it is ``-sin(d)/m``.
      ``G`` is printed 3x3 with a zero row: here ``G = diag(1/J_f, 1/J_r)``, ``u = (T_f,
      T_r)``. ``H`` prints ``r_f/J_f`` twice: the rear entry is ``r_r/J_r``.
R-A5  ``Psi(X)`` (printed twice, garbled): each force obeys the relaxation model (8)
      ``F' = (1/sigma)(C s - v_x F) + (F0/sigma) v_x`` with slip velocity ``s``
      (``r_f w_f - v_x``, ``r_r w_r - v_x``, ``v_x d - v_y - l_f r``, ``l_r r - v_y``), so
      ``Psi`` is block diagonal with rows ``[C s - v_x F, v_x]`` and
      ``theta = (1/sigma_i, F0_i/sigma_i)``, 8 parameters. This is consistent with the
      printed ``Delta Psi = -x21 x~4`` and ``F = diag(theta_1, theta_2, theta_5, theta_6)``
      (the ``1/sigma`` entries). The same ``v_x`` is used in braking and traction (7a).
R-A6  Injections ``Lambda4, Lambda5``: chosen as
      ``[Lambda4 Lambda2^-1, Lambda5 Lambda3^-1] = K W^+``, ``W = [Omega(d); -H]`` (5x4, full
      column rank), so that (19) becomes ``A = K + v_x F`` with ``K = diag(k) > 0``, i.e. the
      paper's condition ``A > 0`` holds by construction.
R-A7  The Lyapunov weight called ``G`` in (20)-(22) (a name clash with the wheel input
      matrix) is the identity; ``P`` in (20) is written ``P^-1`` in (21): we use
      ``V4 = x~4'x~4/2 + theta~' P^-1 theta~/2`` and the adaptation law
      ``theta^' = P Psi(X^)' x~4_eq`` where ``x~4_eq = W^+ [Lambda2 s2; Lambda3 s3]``
      filtered, which equals ``x~4`` on the sliding surfaces (14), (16).
      ``theta^`` is projected on a box (bounded adaptation).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
from numba import njit

from vehicle_observers.core.errors import CertificationError, ObserverArgumentError
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.models.fullcar import (
    OUT_X11,
    OUT_X12,
    OUT_X22,
    PAPER_X12,
    PAPER_X22,
    PAPER_X31,
    FullCarParams,
)
from vehicle_observers.models.planar import IU_DELTA, IU_TF, IU_TR, PlanarParams
from vehicle_observers.observers.fixed_step import FixedStepObserver, positive, positive_array

SIGN, SAT, LPF = 0, 1, 2
MODES = {"sign": SIGN, "sat": SAT, "lpf": LPF}


def _mode(mode) -> int:
    if isinstance(mode, str):
        if mode not in MODES:
            raise ObserverArgumentError(f"mode must be one of {list(MODES)}, got {mode!r}")
        return MODES[mode]
    if int(mode) not in (0, 1, 2):
        raise ObserverArgumentError(f"mode must be 0 (sign), 1 (sat) or 2 (lpf), got {mode}")
    return int(mode)


@njit(cache=True)
def _sw(e, phi, mode):
    """Switching function: sign (mode 0 and 2) or saturation sat(e/phi) (mode 1)."""
    if mode == 1:
        v = e / phi
        if v > 1.0:
            return 1.0
        if v < -1.0:
            return -1.0
        return v
    if e > 0.0:
        return 1.0
    if e < 0.0:
        return -1.0
    return 0.0


def _sw_np(e, phi, mode):
    """Switching function of :func:`_sw` on arrays."""
    return np.clip(e / phi, -1.0, 1.0) if mode == SAT else np.sign(e)


# ================================================================== Part A =================
#: index of each constant in :meth:`ForceObserverModel.as_array` (read by the kernels)
FM_M, FM_JZ, FM_LF, FM_LR, FM_RF, FM_RR, FM_JF, FM_JR, FM_CKF, FM_CKR, FM_CAF, FM_CAR = range(12)
#: columns of the measurements ``y = [v_x, v_y, r, omega_f, omega_r]`` (the order of
#: :func:`vehicle_observers.models.planar.measurements`)
Y_VX, Y_VY, Y_R, Y_WF, Y_WR = range(5)
#: entries of the force vector ``x4 = [F_xf, F_xr, F_yf, F_yr]``
F_XF, F_XR, F_YF, F_YR = range(4)
#: internal state of :class:`ForceObserver`: ``[x2 (3), x3 (2), x4 (4), theta (8), x~4_eq
#: filtered (4)]``, blocks starting at these indices
Z_X2, Z_X3, Z_X4, Z_TH, Z_E4F, Z_END = 0, 3, 5, 9, 17, 21


@dataclass(frozen=True)
class ForceObserverModel:
    """Observer-side model constants (may differ from the truth to test robustness).

    m [kg], J_z [kg m^2], l_f, l_r [m], wheel radii r_f, r_r [m], axle spin inertias J_f, J_r
    [kg m^2]; slip stiffnesses, the per-axle tangent slopes at zero slip used in (8):
    ``C_kf, C_kr`` [N] (longitudinal), ``C_af, C_ar`` [N/rad] (lateral); relaxation lengths
    sigma_x, sigma_y [m]. Every constant must be finite and > 0.
    """

    m: float
    J_z: float
    l_f: float
    l_r: float
    r_f: float
    r_r: float
    J_f: float
    J_r: float
    C_kf: float
    C_kr: float
    C_af: float
    C_ar: float
    sigma_x: float
    sigma_y: float

    def __post_init__(self):
        for name, v in vars(self).items():
            positive("ForceObserverModel", name, v)

    @classmethod
    def from_params(cls, p: PlanarParams, **errors) -> "ForceObserverModel":
        """Nominal observer model from the truth constants; ``errors`` are relative errors,
        e.g. ``m=0.1`` for a 10 % heavier observer model. Keys: any field name."""
        base = dict(m=p.m, J_z=p.J_z, l_f=p.l_f, l_r=p.l_r, r_f=p.r_f, r_r=p.r_r,
                    J_f=p.J_f, J_r=p.J_r, C_kf=p.C_kappa_f, C_kr=p.C_kappa_r,
                    C_af=p.C_alpha_f, C_ar=p.C_alpha_r, sigma_x=p.sigma_x,
                    sigma_y=p.sigma_y)
        for k, v in errors.items():
            if k not in base:
                raise ObserverArgumentError(f"unknown observer-model parameter {k!r}; expected "
                                            f"one of {sorted(base)}")
            base[k] = base[k] * (1.0 + float(v))
        return cls(**base)

    def as_array(self) -> np.ndarray:
        """The constants packed for the kernels, indices :data:`FM_M` ... :data:`FM_CAR`."""
        return np.array([self.m, self.J_z, self.l_f, self.l_r, self.r_f, self.r_r, self.J_f,
                         self.J_r, self.C_kf, self.C_kr, self.C_af, self.C_ar], dtype=float)

    def theta0(self) -> np.ndarray:
        """Nominal ``theta = (1/sigma, F0/sigma)`` per force with ``F0 = 0``, shape (8,)."""
        return np.array([1 / self.sigma_x, 0.0, 1 / self.sigma_x, 0.0,
                         1 / self.sigma_y, 0.0, 1 / self.sigma_y, 0.0])


@dataclass(frozen=True)
class ForceObserverGains:
    """Gains of observer (10): the design of :class:`ForceObserver` (a gain rule, no LMI:
    ``certificate`` is ``None``). Defaults are the notebook's design (see ``design_note``).

    lam2 (3,) [m/s^2, m/s^2, rad/s^2] > 0 must exceed ``|Omega x~4|`` (13);
    lam3 (2,) [rad/s^2] > 0 must exceed ``|H x~4x|`` (16);
    k (4,) [1/s] >= 0 the diagonal of ``K`` in ``A = K + v_x F`` (19);
    P (8,) adaptation gains (positive: the printed law; ``-P`` flips it); theta bounds
    (8,) for the projection, ``theta_lo < theta_hi``;
    phi2 (3,), phi3 (2,) > 0 boundary-layer widths (mode SAT); tau_f [s] > 0 injection filter.
    """

    certificate: ClassVar[None] = None

    lam2: tuple = (4.0, 4.0, 3.0)
    lam3: tuple = (500.0, 500.0)
    k: tuple = (40.0, 40.0, 40.0, 40.0)
    P: tuple = (0.0, 5.0, 0.0, 5.0, 0.0, 5.0, 0.0, 5.0)
    theta_lo: tuple = (1.0, -2e5, 1.0, -2e5, 0.5, -2e5, 0.5, -2e5)
    theta_hi: tuple = (20.0, 2e5, 20.0, 2e5, 10.0, 2e5, 10.0, 2e5)
    phi2: tuple = (0.02, 0.02, 0.01)
    phi3: tuple = (2.0, 2.0)
    tau_f: float = 0.01
    mode: int = SIGN
    design_note: str = field(default=(
        "lam2 > max|Omega x~4| for force errors up to 4 kN (4 kN/1500 kg = 2.7 m/s^2, "
        "l_f 4 kN / J_z = 1.8 rad/s^2); lam3 > r/J x 3 kN = 450 rad/s^2; k = 40 1/s "
        "(force-estimate bandwidth 6 Hz, above the manoeuvre content); P adapts only the "
        "F0/sigma terms (the 1/sigma terms stay nominal: their regressor is not "
        "persistently exciting in the manoeuvre); P = 5 gives an adaptation loop of "
        "natural frequency v_x sqrt(P) ~ 45 rad/s at 20 m/s, below K + v_x/sigma; P = 20 "
        "makes the lateral loops unstable at 1 kHz-2 kHz sampling (measured)."), compare=False)

    def __post_init__(self):
        who = "ForceObserverGains"
        object.__setattr__(self, "mode", _mode(self.mode))
        for name, n, zero in (("lam2", 3, False), ("lam3", 2, False), ("k", 4, True),
                              ("phi2", 3, False), ("phi3", 2, False)):
            positive_array(who, name, getattr(self, name), (n,), allow_zero=zero)
        positive(who, "tau_f", self.tau_f)
        for name in ("P", "theta_lo", "theta_hi"):
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != (8,) or not np.all(np.isfinite(a)):
                raise ObserverArgumentError(f"{who}: {name} must be 8 finite values, got "
                                            f"{getattr(self, name)}")
        if not np.all(np.asarray(self.theta_lo) < np.asarray(self.theta_hi)):
            raise ObserverArgumentError(f"{who}: need theta_lo < theta_hi entry by entry, got "
                                        f"{self.theta_lo} and {self.theta_hi}")

    def with_(self, **kw) -> "ForceObserverGains":
        return replace(self, **kw)


@njit(cache=True)
def _omega_h(delta, Q, Om, Hm):
    """``Omega(delta)`` (3, 4) and ``H`` (2, 4) of (9) (R-A4) into ``Om``, ``Hm``."""
    m, Jz, lf, lr = Q[FM_M], Q[FM_JZ], Q[FM_LF], Q[FM_LR]
    rf, rr, Jf, Jr = Q[FM_RF], Q[FM_RR], Q[FM_JF], Q[FM_JR]
    c, s = np.cos(delta), np.sin(delta)
    Om[0, 0] = c / m
    Om[0, 1] = 1.0 / m
    Om[0, 2] = -s / m
    Om[0, 3] = 0.0
    Om[1, 0] = s / m
    Om[1, 1] = 0.0
    Om[1, 2] = c / m
    Om[1, 3] = 1.0 / m
    Om[2, 0] = lf * s / Jz
    Om[2, 1] = 0.0
    Om[2, 2] = lf * c / Jz
    Om[2, 3] = -lr / Jz
    for i in range(2):
        for j in range(4):
            Hm[i, j] = 0.0
    Hm[0, 0] = rf / Jf
    Hm[1, 1] = rr / Jr


@njit(cache=True)
def _psi(vx, vy, r, wf, wr, delta, F, Q, Psi):
    """Regressor Psi(X) (4, 8) of the relaxation model (8), reconstruction R-A5: row ``i``
    (force ``i``) holds ``[C s_i - v_x F_i, v_x]`` in columns ``2i, 2i + 1``."""
    lf, lr, rf, rr = Q[FM_LF], Q[FM_LR], Q[FM_RF], Q[FM_RR]
    Ckf, Ckr, Caf, Car = Q[FM_CKF], Q[FM_CKR], Q[FM_CAF], Q[FM_CAR]
    for i in range(4):
        for j in range(8):
            Psi[i, j] = 0.0
    s0 = rf * wf - vx
    s1 = rr * wr - vx
    s2 = vx * delta - vy - lf * r
    s3 = lr * r - vy
    Psi[F_XF, 2 * F_XF] = Ckf * s0 - vx * F[F_XF]
    Psi[F_XF, 2 * F_XF + 1] = vx
    Psi[F_XR, 2 * F_XR] = Ckr * s1 - vx * F[F_XR]
    Psi[F_XR, 2 * F_XR + 1] = vx
    Psi[F_YF, 2 * F_YF] = Caf * s2 - vx * F[F_YF]
    Psi[F_YF, 2 * F_YF + 1] = vx
    Psi[F_YR, 2 * F_YR] = Car * s3 - vx * F[F_YR]
    Psi[F_YR, 2 * F_YR + 1] = vx


@njit(cache=True)
def _force_observer(Y, U, dt, Q, z0, lam2, lam3, kk, Pth, th_lo, th_hi, phi2, phi3, tau_f,
                    mode):
    """Observer (10) with the adaptation (20)-(22): explicit Euler at ``dt`` over the samples.
    ``z0`` (21,) the internal state of :class:`ForceObserver` at sample 0; row ``k`` of the
    estimates is the state before sample ``k`` is used, of ``e4`` after, of ``s`` at it."""
    N = Y.shape[0]
    x2 = z0[Z_X2:Z_X3].copy()
    x3 = z0[Z_X3:Z_X4].copy()
    x4 = z0[Z_X4:Z_TH].copy()
    th = z0[Z_TH:Z_E4F].copy()
    e4f = z0[Z_E4F:Z_END].copy()
    out_x2 = np.empty((N, 3))
    out_x3 = np.empty((N, 2))
    out_x4 = np.empty((N, 4))
    out_th = np.empty((N, 8))
    out_e4 = np.empty((N, 4))
    out_s = np.empty((N, 5))
    Om = np.empty((3, 4))
    Hm = np.empty((2, 4))
    W = np.empty((5, 4))
    Psi = np.empty((4, 8))
    v = np.empty(5)
    s2 = np.empty(3)
    s3 = np.empty(2)
    Jf, Jr = Q[FM_JF], Q[FM_JR]
    a = np.exp(-dt / tau_f)
    for k in range(N):
        out_x2[k] = x2
        out_x3[k] = x3
        out_x4[k] = x4
        out_th[k] = th
        vx, vy, r, wf, wr = Y[k, Y_VX], Y[k, Y_VY], Y[k, Y_R], Y[k, Y_WF], Y[k, Y_WR]
        delta, Tf, Tr = U[k, IU_DELTA], U[k, IU_TF], U[k, IU_TR]
        for i in range(3):
            s2[i] = _sw(Y[k, Y_VX + i] - x2[i], phi2[i], mode)
            v[i] = lam2[i] * s2[i]
        for i in range(2):
            s3[i] = _sw(Y[k, Y_WF + i] - x3[i], phi3[i], mode)
            v[3 + i] = lam3[i] * s3[i]
        out_s[k, 0:3] = s2
        out_s[k, 3:5] = s3
        _omega_h(delta, Q, Om, Hm)
        for j in range(4):
            for i in range(3):
                W[i, j] = Om[i, j]
            for i in range(2):
                W[3 + i, j] = -Hm[i, j]
        # x~4 from the injections: least squares W x~4 = v (R-A6/R-A7)
        e4raw = np.linalg.solve(W.T @ W, W.T @ v)
        for i in range(4):
            e4f[i] = a * e4f[i] + (1.0 - a) * e4raw[i]
        out_e4[k] = e4f
        _psi(vx, vy, r, wf, wr, delta, x4, Q, Psi)
        f4 = Psi @ th
        dx2 = Om @ x4
        dx2[0] += vy * r
        dx2[1] += -vx * r
        # explicit Euler update
        for i in range(3):
            x2[i] += dt * (dx2[i] + v[i])
        x3[0] += dt * (Tf / Jf - Hm[0, 0] * x4[F_XF] + v[3])
        x3[1] += dt * (Tr / Jr - Hm[1, 1] * x4[F_XR] + v[4])
        inj = e4f if mode == 2 else e4raw
        dth = Pth * (Psi.T @ e4f)
        for i in range(4):
            x4[i] += dt * (f4[i] + kk[i] * inj[i])
        for i in range(8):
            th[i] += dt * dth[i]
            if th[i] < th_lo[i]:
                th[i] = th_lo[i]
            elif th[i] > th_hi[i]:
                th[i] = th_hi[i]
    return out_x2, out_x3, out_x4, out_th, out_e4, out_s


@dataclass(frozen=True, eq=False)
class ForceTrajectory(Trajectory):
    """Run of :class:`ForceObserver`: the estimate ``x`` (N, 9) ``[x2, x3, x4]`` and, per
    sample, ``theta`` (N, 8) the adapted parameters, ``x4_err_eq`` (N, 4) the filtered
    equivalent-injection estimate of ``x4 - x^4`` [N] (using sample ``k``), ``s`` (N, 5)
    the switching values at sample ``k``. ``x2`` (N, 3) ``[v_x, v_y, r]``, ``x3`` (N, 2)
    wheel speeds [rad/s] and ``x4`` (N, 4) forces ``[F_xf, F_xr, F_yf, F_yr]`` [N] are views
    of ``x`` (the paper's names)."""

    theta: np.ndarray | None = None
    x4_err_eq: np.ndarray | None = None
    s: np.ndarray | None = None

    @property
    def x2(self) -> np.ndarray:
        return self.x[:, Z_X2:Z_X3]

    @property
    def x3(self) -> np.ndarray:
        return self.x[:, Z_X3:Z_X4]

    @property
    def x4(self) -> np.ndarray:
        return self.x[:, Z_X4:Z_TH]


class ForceObserver(FixedStepObserver):
    """Tyre-force sliding-mode observer (10) with the adaptive force model (20)-(22) of
    Rabhi, Imine, M'Sirdi, Delanne (AVCS 2004), explicit Euler at the sample period ``dt``.

    ``model``: :class:`ForceObserverModel` (observer-side constants); ``gains``
    (:attr:`design`): :class:`ForceObserverGains`; ``theta0`` (8,) initial ``theta``
    (default ``model.theta0()``). Data: ``u`` (N, 3) ``[delta, T_f, T_r]`` [rad, N m, N m],
    ``y`` (N, 5) ``[v_x, v_y, r, omega_f, omega_r]`` with ``v_x > 0.5 m/s`` (the relaxation
    model divides by it). ``x0`` (9,) the initial estimate ``[x2, x3, x4]``; default the
    first measurement and zero forces. Internal state ``z`` (21,): blocks :data:`Z_X2`
    ... :data:`Z_E4F` (estimate, ``theta``, filtered equivalent injection).
    """

    state_names = ("vx_mps", "vy_mps", "yaw_rate_radps", "omega_f_radps", "omega_r_radps",
                   "Fxf_N", "Fxr_N", "Fyf_N", "Fyr_N")
    input_names = ("delta_roadwheel_rad", "Tf_Nm", "Tr_Nm")
    output_names = ("vx_mps", "vy_mps", "yaw_rate_radps", "omega_f_radps", "omega_r_radps")

    def __init__(self, model: ForceObserverModel, gains: ForceObserverGains, dt: float,
                 theta0=None):
        super().__init__(dt)
        if not isinstance(model, ForceObserverModel):
            raise ObserverArgumentError(f"ForceObserver: model must be a ForceObserverModel, "
                                        f"got {type(model).__name__}")
        if not isinstance(gains, ForceObserverGains):
            raise ObserverArgumentError(f"ForceObserver: gains must be ForceObserverGains, got "
                                        f"{type(gains).__name__}")
        self.model, self.design = model, gains
        th = model.theta0() if theta0 is None else np.asarray(theta0, dtype=float)
        if th.shape != (8,) or not np.all(np.isfinite(th)):
            raise ObserverArgumentError(f"ForceObserver: theta0 must be 8 finite values, got "
                                        f"{theta0}")
        self.theta0 = th
        self._Q = model.as_array()
        g = gains
        self._g = {k: np.asarray(getattr(g, k), dtype=float)
                   for k in ("lam2", "lam3", "k", "P", "theta_lo", "theta_hi", "phi2", "phi3")}

    def check_data(self, t, u, y, x0=None):
        t, u, y, x0 = super().check_data(t, u, y, x0)
        if np.any(y[:, Y_VX] <= 0.5):
            k = int(np.argmax(y[:, Y_VX] <= 0.5))
            raise ObserverArgumentError(f"ForceObserver: v_x must stay > 0.5 m/s (the "
                                        f"relaxation model divides by it): y[{k}, 0] = "
                                        f"{y[k, Y_VX]}")
        return t, u, y, x0

    def initial_state(self, t, u, y, x0=None) -> np.ndarray:
        z = np.zeros(Z_END)
        if x0 is None:
            z[Z_X2:Z_X4] = y[0, Y_VX:Y_WR + 1]
        else:
            z[Z_X2:Z_TH] = x0
        z[Z_TH:Z_E4F] = self.theta0
        return z

    def step(self, z, k, t, u, y) -> np.ndarray:
        """Observer (10) with the adaptation (20)-(22) (Rabhi 2004; reconstructions R-A3 to
        R-A7): one explicit-Euler step over ``[t_{k-1}, t_k]`` with sample ``k - 1``::

            v      = [Lambda2 s(y_x2 - x2^); Lambda3 s(y_x3 - x3^)]   switching terms of (10)
            e4     = W^+ v,  W = [Omega(delta); -H]                   x~4 on the surfaces
            e4f    = a e4f + (1 - a) e4,  a = exp(-dt / tau_f)         filtered (R-A7)
            x2^+   = x2^ + dt (Omega x4^ + [v_y r, -v_x r, 0] + v_2)  (10), R-A3
            x3^+   = x3^ + dt (T / J - H x4^ + v_3)
            x4^+   = x4^ + dt (Psi(X^) theta^ + K inj)     inj = e4f (lpf) or e4   (19)
            theta^+ = proj(theta^ + dt P Psi(X^)' e4f)                           (20)-(22)
        """
        g, m, dt, mode = self._g, self.model, self.dt, self.design.mode
        yk, (delta, Tf, Tr) = y[k - 1], u[k - 1]
        vx, vy, r, wf, wr = yk
        x2, x3, x4 = z[Z_X2:Z_X3], z[Z_X3:Z_X4], z[Z_X4:Z_TH]
        th, e4f = z[Z_TH:Z_E4F], z[Z_E4F:Z_END]
        c, s = np.cos(delta), np.sin(delta)
        Om = np.array([[c / m.m, 1.0 / m.m, -s / m.m, 0.0],
                       [s / m.m, 0.0, c / m.m, 1.0 / m.m],
                       [m.l_f * s / m.J_z, 0.0, m.l_f * c / m.J_z, -m.l_r / m.J_z]])
        H = np.array([[m.r_f / m.J_f, 0.0, 0.0, 0.0], [0.0, m.r_r / m.J_r, 0.0, 0.0]])
        v = np.concatenate([g["lam2"] * _sw_np(yk[0:3] - x2, g["phi2"], mode),
                            g["lam3"] * _sw_np(yk[3:5] - x3, g["phi3"], mode)])
        W = np.vstack([Om, -H])
        e4 = np.linalg.solve(W.T @ W, W.T @ v)
        a = np.exp(-dt / self.design.tau_f)
        e4f = a * e4f + (1 - a) * e4
        slip = np.array([m.r_f * wf - vx, m.r_r * wr - vx, vx * delta - vy - m.l_f * r,
                         m.l_r * r - vy])          # slip velocities of (8), R-A5
        stiff = np.array([m.C_kf, m.C_kr, m.C_af, m.C_ar])
        Psi = np.zeros((4, 8))
        i = np.arange(4)
        Psi[i, 2 * i] = stiff * slip - vx * x4    # row i: [C s_i - v_x F_i, v_x] (R-A5)
        Psi[i, 2 * i + 1] = vx
        inj = e4f if mode == LPF else e4
        return np.concatenate([
            x2 + dt * (Om @ x4 + np.array([vy * r, -vx * r, 0.0]) + v[0:3]),
            x3 + dt * (np.array([Tf, Tr]) / np.array([m.J_f, m.J_r]) - np.diag(H[:, 0:2]) * x4[0:2]
                       + v[3:5]),
            x4 + dt * (Psi @ th + g["k"] * inj),
            np.clip(th + dt * g["P"] * (Psi.T @ e4f), g["theta_lo"], g["theta_hi"]),
            e4f])

    def estimate(self, z) -> np.ndarray:
        return z[Z_X2:Z_TH].copy()

    def run(self, t, u, y, x0=None) -> ForceTrajectory:
        """The compiled loop (``_force_observer``): the estimate of :meth:`step` looped, plus
        ``theta``, the filtered equivalent injection and the switching values per sample."""
        t, u, y, x0 = self.check_data(t, u, y, x0)
        z0 = self.initial_state(t, u, y, x0)
        g = self._g
        sec, (x2, x3, x4, th, e4, s) = self.timed(
            _force_observer, y, u, self.dt, self._Q, z0, g["lam2"], g["lam3"], g["k"], g["P"],
            g["theta_lo"], g["theta_hi"], g["phi2"], g["phi3"], float(self.design.tau_f),
            int(self.design.mode))
        return ForceTrajectory(t, np.hstack([x2, x3, x4]), self.state_names, seconds=sec,
                               estimator=type(self).__name__, theta=th, x4_err_eq=e4, s=s)


def omega_h(delta: float, model: ForceObserverModel):
    """``Omega(delta)`` (3, 4) and ``H`` (2, 4) of (9) (R-A4) for one steering angle [rad],
    from the compiled kernel ``_omega_h`` the observer itself uses (single definition, also
    used by :mod:`.baselines.sliding_mode_ekf`). ``model`` a :class:`ForceObserverModel` or its
    :meth:`~ForceObserverModel.as_array`."""
    q = model.as_array() if isinstance(model, ForceObserverModel) else np.asarray(model, dtype=float)
    Om, Hm = np.empty((3, 4)), np.empty((2, 4))
    _omega_h(float(delta), q, Om, Hm)
    return Om, Hm


@njit(cache=True)
def _omega_x4_bound(d, e, Q, out):
    Om = np.empty((3, 4))
    Hm = np.empty((2, 4))
    for k in range(len(d)):
        _omega_h(d[k], Q, Om, Hm)
        for i in range(3):
            out[k, i] = abs(Om[i, 0] * e[k, 0] + Om[i, 1] * e[k, 1] + Om[i, 2] * e[k, 2]
                            + Om[i, 3] * e[k, 3])
        for i in range(2):
            out[k, 3 + i] = abs(Hm[i, 0] * e[k, 0] + Hm[i, 1] * e[k, 1] + Hm[i, 2] * e[k, 2]
                                + Hm[i, 3] * e[k, 3])


def omega_x4_bound(delta, x4_err, model: ForceObserverModel) -> np.ndarray:
    """``|Omega(d) x~4|`` (N, 3) and ``|H x~4x|`` (N, 2) stacked as (N, 5): the left sides
    of the gain conditions (13) and (16) along a trajectory (compiled loop over the same
    ``_omega_h`` kernel the observer uses)."""
    d = np.ascontiguousarray(np.atleast_1d(np.asarray(delta, dtype=float)))
    e = np.ascontiguousarray(np.asarray(x4_err, dtype=float).reshape(len(d), 4))
    out = np.empty((len(d), 5))
    _omega_x4_bound(d, e, model.as_array(), out)
    return out


# ================================================================== Part B =================
# Reconstructions (also in notebook 05):
# R-B3  Outputs. (29) lists y = [x12, x22, x31] (body positions, rates, wheel accelerations);
#       with these the wheel displacements are not observable with unknown road input (see
#       fullcar.warp_vector: a static "warp" wheel offset with its road gives outputs
#       identical to rest). The paper's Fig. 8 compares *measured* wheel displacements, so
#       we measure x11 (suspension-deflection sensors + body position) with x12, x22.
# R-B4  Observer (30) is printed with mismatched dimensions (x11' = x12 + H11 sign(x~22)).
#       Reconstructed as the step-by-step (triangular) sliding-mode observer per wheel:
#         x11^' = x21^ + H11 s(x11 - x11^)                       (stage 1, surface x~11 = 0)
#         v_eq  = LPF[H11 s(.)]  (= x~21 on the surface, equivalent injection)
#         x21^' = -M1^-1(C11 x21^ + C12 x22 + K11 x11 + K12 x12) + M1^-1 zeta^ + H21 s(v_eq)
#       (stage 2, the role of sign(x~31) in (30)); x12, x22 are measured (their observer
#       lines in (30) are trivial and omitted).
# R-B5  zeta^ in (30) is left undefined in the paper: here an integral of the equivalent
#       injection, zeta^' = M1 H21 LPF[s] / tau_i (so that H21 only has to dominate the fast
#       part of the road force), and (36): zeta = zeta^ + M1 H21 LPF[s].
# R-B6  (38) is the step response of (37) for constant zeta; we integrate (37) itself,
#       B11 U' + A11 U = zeta, exactly for zeta held over a step (ZOH).
#: wheel labels (order RL, RR, FL, FR of :mod:`vehicle_observers.models.fullcar`)
_WHEEL = ("rl", "rr", "fl", "fr")
#: measurement names of the full car: wheel displacements x11, body positions x12, body
#: rates x22, wheel accelerations x31
X11_NAMES = tuple(f"zw_{w}_m" for w in _WHEEL)
X12_NAMES = ("z_m", "theta_rad", "phi_rad")
X22_NAMES = ("dz_mps", "dtheta_radps", "dphi_radps")
X31_NAMES = tuple(f"azw_{w}_mps2" for w in _WHEEL)
ROAD_NAMES = tuple(f"road_{w}_m" for w in _WHEEL)
#: internal state of :class:`RoadObserver`: ``[x11^ (4), x21^ (4), v_eq (4), LPF[s] (4),
#: zeta^ (4), U (4), x22^ (3)]``, blocks starting at these indices
R_Z, R_V, R_VEQ, R_SEQ, R_ZH, R_U, R_XB, R_END = 0, 4, 8, 12, 16, 20, 24, 27


@dataclass(frozen=True)
class RoadObserverGains:
    """Gains of the road-profile UIO (R-B4/R-B5), scalars shared by the four wheels: the
    design of :class:`RoadObserver` (a gain rule: ``certificate`` is ``None``).

    h11 [m/s] must exceed ``|x~21|`` (stage-1 reaching); h21 [m/s^2] must exceed the fast
    part of ``|M1^-1 zeta~|``; phi1 [m], phi2 [m/s] boundary layers (mode SAT); tau_f [s]
    equivalent-injection filter; tau_i [s] zeta^ integrator time constant; h22 [1/s] >= 0,
    phi22 [rad/s] body-rate injection and its boundary layer. Gains >= 0, widths and time
    constants > 0.
    """

    certificate: ClassVar[None] = None

    h11: float = 2.0
    h21: float = 150.0
    phi1: float = 2e-4
    phi2: float = 0.02
    tau_f: float = 1e-3
    tau_i: float = 5e-3
    h22: float = 5.0
    phi22: float = 0.01
    mode: int = SAT

    def __post_init__(self):
        who = "RoadObserverGains"
        object.__setattr__(self, "mode", _mode(self.mode))
        for name in ("h11", "h21", "h22"):
            positive(who, name, getattr(self, name), allow_zero=True)
        for name in ("phi1", "phi2", "phi22", "tau_f", "tau_i"):
            positive(who, name, getattr(self, name))

    def with_(self, **kw) -> "RoadObserverGains":
        return replace(self, **kw)


@njit(cache=True)
def _road_observer(Y, dt, mu, c11, k11, C12, K12, kt, ct, h11, h21, phi1, phi2, tau_f,
                   tau_i, mode, M2, C21, C22, K21, K22, h22, phi22, s0):
    """The road UIO (R-B4 to R-B6) over the samples; ``s0`` (27,) the internal state of
    :class:`RoadObserver` at sample 0 (blocks :data:`R_Z` ...). Row ``k`` of ``z``, ``U``,
    ``xb`` is the state before sample ``k`` is used; ``v``, ``zeta``, ``s1`` use it."""
    N = Y.shape[0]
    z = s0[R_Z:R_V].copy()
    v = s0[R_V:R_VEQ].copy()
    veq = s0[R_VEQ:R_SEQ].copy()
    seq = s0[R_SEQ:R_ZH].copy()
    zh = s0[R_ZH:R_U].copy()
    U = s0[R_U:R_XB].copy()
    xb = s0[R_XB:R_END].copy()
    out_xb = np.empty((N, 3))
    out_z = np.empty((N, 4))
    out_v = np.empty((N, 4))
    out_zeta = np.empty((N, 4))
    out_U = np.empty((N, 4))
    out_s1 = np.empty((N, 4))
    a = np.exp(-dt / tau_f)
    for k in range(N):
        x12 = Y[k, OUT_X12:OUT_X12 + 3]
        x22 = Y[k, OUT_X22:OUT_X22 + 3]
        g = C12 @ x22 + K12 @ x12
        # body-rate line of (30): x22^' = -M2^-1(C21 x21^ + C22 x22^ + K21 x11 + K22 x12)
        #                                 + H22 s(x~22)
        out_xb[k] = xb
        vw = v + veq
        db = -(C21 @ vw + C22 @ xb + K21 @ Y[k, OUT_X11:OUT_X11 + 4] + K22 @ x12) / M2
        for j in range(3):
            xb[j] += dt * (db[j] + h22 * _sw(x22[j] - xb[j], phi22, mode))
        for i in range(4):
            s1 = _sw(Y[k, OUT_X11 + i] - z[i], phi1, mode)
            out_s1[k, i] = s1
            veq[i] = a * veq[i] + (1.0 - a) * h11 * s1
            s2 = _sw(veq[i], phi2, mode)
            seq[i] = a * seq[i] + (1.0 - a) * s2
            zeta = zh[i] + mu[i] * h21 * seq[i]                        # (36)
            out_z[k, i] = z[i]
            out_v[k, i] = v[i] + veq[i]
            out_zeta[k, i] = zeta
            # (37): ct U' + kt U = zeta, exact for zeta held over the step
            e = np.exp(-dt * kt[i] / ct[i])
            out_U[k, i] = U[i]
            U[i] = e * U[i] + (1.0 - e) * zeta / kt[i]
            dv = (-(c11[i] * v[i] + k11[i] * Y[k, OUT_X11 + i] + g[i]) + zh[i]) / mu[i] \
                + h21 * s2
            z[i] += dt * (v[i] + h11 * s1)
            v[i] += dt * dv
            zh[i] += dt * mu[i] * h21 * seq[i] / tau_i
    return out_z, out_v, out_zeta, out_U, out_s1, out_xb


@dataclass(frozen=True, eq=False)
class RoadTrajectory(Trajectory):
    """Run of :class:`RoadObserver`: the estimate ``x`` (N, 11) ``[x11^ (4), U (4), x22^
    (3)]`` and, per sample (using sample ``k``), ``v`` (N, 4) the wheel velocity [m/s]
    (``x21^`` plus the equivalent injection), ``zeta`` (N, 4) the road force [N] (36),
    ``s1`` (N, 4) the stage-1 switching values. Views of ``x`` (paper names, wheel order
    RL, RR, FL, FR): ``z`` (N, 4) wheel displacements [m], ``U`` (N, 4) road elevation [m]
    (37), ``x22`` (N, 3) body rates ``[z', theta', phi']``."""

    v: np.ndarray | None = None
    zeta: np.ndarray | None = None
    s1: np.ndarray | None = None

    @property
    def z(self) -> np.ndarray:
        return self.x[:, 0:4]

    @property
    def U(self) -> np.ndarray:
        return self.x[:, 4:8]

    @property
    def x22(self) -> np.ndarray:
        return self.x[:, 8:11]


class RoadObserver(FixedStepObserver):
    """Road-profile sliding-mode unknown-input observer (30)-(38) of Rabhi 2004 Part B
    (reconstructions R-B3 to R-B6), explicit Euler at the sample period ``dt``.

    ``params``: :class:`~vehicle_observers.models.fullcar.FullCarParams`, the observer-model
    constants (may differ from the truth); ``gains`` (:attr:`design`):
    :class:`RoadObserverGains` (modes ``sign`` and ``sat``; the injections are always
    low-pass filtered). Data: no input (``u=None``); ``y`` (N, 10) =
    :func:`vehicle_observers.models.fullcar.outputs` ``[x11 (4), x12 (3), x22 (3)]``.
    ``x0`` (11,) the initial estimate ``[x11^, U, x22^]``; default the first measured wheel
    displacements and body rates, a flat road. Wheel velocity, equivalent injections and
    road force start at 0. Internal state ``z`` (27,): blocks :data:`R_Z` ... :data:`R_XB`.
    """

    state_names = X11_NAMES + ROAD_NAMES + X22_NAMES
    input_names = ()
    output_names = X11_NAMES + X12_NAMES + X22_NAMES

    def __init__(self, params: FullCarParams, gains: RoadObserverGains, dt: float):
        super().__init__(dt)
        if not isinstance(gains, RoadObserverGains):
            raise ObserverArgumentError(f"RoadObserver: gains must be RoadObserverGains, got "
                                        f"{type(gains).__name__}")
        if gains.mode == LPF:
            raise ObserverArgumentError(
                "RoadObserver: mode 'lpf' applies to the force observer only: the road UIO "
                "always low-pass filters its equivalent injections (tau_f); use 'sign' or 'sat'")
        self.params, self.design = params, gains
        M, C, K, A11, B11 = params.matrices()
        c = np.ascontiguousarray
        self._m = {"mu": np.diag(M)[:4].copy(), "c11": np.diag(C)[:4].copy(),
                   "k11": np.diag(K)[:4].copy(), "C12": c(C[:4, 4:]), "K12": c(K[:4, 4:]),
                   "kt": np.diag(A11).copy(), "ct": np.diag(B11).copy(),
                   "M2": np.diag(M)[4:].copy(), "C21": c(C[4:, :4]), "C22": c(C[4:, 4:]),
                   "K21": c(K[4:, :4]), "K22": c(K[4:, 4:])}

    def initial_state(self, t, u, y, x0=None) -> np.ndarray:
        z = np.zeros(R_END)
        if x0 is None:
            z[R_Z:R_V] = y[0, OUT_X11:OUT_X11 + 4]
            z[R_XB:R_END] = y[0, OUT_X22:OUT_X22 + 3]
        else:
            z[R_Z:R_V], z[R_U:R_XB], z[R_XB:R_END] = x0[0:4], x0[4:8], x0[8:11]
        return z

    def step(self, z, k, t, u, y) -> np.ndarray:
        """Road UIO of Rabhi 2004 (30), (36)-(37) as reconstructed (R-B4 to R-B6): one
        explicit-Euler step over ``[t_{k-1}, t_k]`` with sample ``k - 1``, per wheel::

            s1     = s(x11 - x11^)                     stage 1, surface x~11 = 0
            v_eq+  = a v_eq + (1 - a) H11 s1           equivalent injection (= x~21), a = exp(-dt/tau_f)
            s2     = s(v_eq+),  S+ = a S + (1 - a) s2  stage 2 and its filtered value
            zeta   = zeta^ + M1 H21 S+                 road force (36)
            U+     = e U + (1 - e) zeta / k_t          (37) exact for zeta held, e = exp(-dt k_t/c_t)
            x11^+  = x11^ + dt (x21^ + H11 s1)
            x21^+  = x21^ + dt ((zeta^ - c11 x21^ - k11 x11 - C12 x22 - K12 x12) / M1 + H21 s2)
            zeta^+ = zeta^ + dt M1 H21 S+ / tau_i      (R-B5)
            x22^+  = x22^ + dt (-M2^-1 (C21 (x21^ + v_eq) + C22 x22^ + K21 x11 + K22 x12)
                                + H22 s(x22 - x22^))   body-rate line of (30)
        """
        g, m, dt, mode = self.design, self._m, self.dt, self.design.mode
        yk = y[k - 1]
        x11, x12, x22 = yk[OUT_X11:OUT_X11 + 4], yk[OUT_X12:OUT_X12 + 3], yk[OUT_X22:OUT_X22 + 3]
        zw, v, veq, seq = z[R_Z:R_V], z[R_V:R_VEQ], z[R_VEQ:R_SEQ], z[R_SEQ:R_ZH]
        zh, U, xb = z[R_ZH:R_U], z[R_U:R_XB], z[R_XB:R_END]
        a = np.exp(-dt / g.tau_f)
        db = -(m["C21"] @ (v + veq) + m["C22"] @ xb + m["K21"] @ x11 + m["K22"] @ x12) / m["M2"]
        xb_new = xb + dt * (db + g.h22 * _sw_np(x22 - xb, g.phi22, mode))
        s1 = _sw_np(x11 - zw, g.phi1, mode)
        veq_new = a * veq + (1.0 - a) * g.h11 * s1
        s2 = _sw_np(veq_new, g.phi2, mode)
        seq_new = a * seq + (1.0 - a) * s2
        zeta = zh + m["mu"] * g.h21 * seq_new
        e = np.exp(-dt * m["kt"] / m["ct"])
        body = m["C12"] @ x22 + m["K12"] @ x12
        dv = (-(m["c11"] * v + m["k11"] * x11 + body) + zh) / m["mu"] + g.h21 * s2
        return np.concatenate([zw + dt * (v + g.h11 * s1), v + dt * dv, veq_new, seq_new,
                               zh + dt * m["mu"] * g.h21 * seq_new / g.tau_i,
                               e * U + (1.0 - e) * zeta / m["kt"], xb_new])

    def estimate(self, z) -> np.ndarray:
        return np.concatenate([z[R_Z:R_V], z[R_U:R_XB], z[R_XB:R_END]])

    def run(self, t, u, y, x0=None) -> RoadTrajectory:
        """The compiled loop (``_road_observer``): the estimate of :meth:`step` looped, plus
        the wheel velocity, road force and switching values per sample."""
        t, u, y, x0 = self.check_data(t, u, y, x0)
        s0 = self.initial_state(t, u, y, x0)
        g, m = self.design, self._m
        sec, (z, v, zeta, U, s1, xb) = self.timed(
            _road_observer, y, self.dt, m["mu"], m["c11"], m["k11"], m["C12"], m["K12"],
            m["kt"], m["ct"], float(g.h11), float(g.h21), float(g.phi1), float(g.phi2),
            float(g.tau_f), float(g.tau_i), int(g.mode), m["M2"], m["C21"], m["C22"],
            m["K21"], m["K22"], float(g.h22), float(g.phi22), s0)
        return RoadTrajectory(t, np.hstack([z, U, xb]), self.state_names, seconds=sec,
                              estimator=type(self).__name__, v=v, zeta=zeta, s1=s1)


# ============================================================ Part B, the paper's outputs ===
# With the paper's outputs (29) y = [x12, x22, x31] the measured wheel accelerations x31
# remove the road from the wheel kinematics (x11' = x21, x21' = x31), so the road is an
# unknown input recovered afterwards from the wheel equation (36)-(37). The body line of (30)
# couples the wheel states to the measured body rates:
#     x22' = -M2^-1 (C21 x21 + C22 x22 + K21 x11 + K22 x12).
# One direction is lost: the static warp offset x11 = w with K21 w = 0 (fullcar.warp_vector)
# changes none of the outputs. The observer below is designed on the observable quotient
# (the state space modulo the unobservable subspace) and leaves the warp component of its
# error where it starts; an added suspension-deflection sensor on one wheel removes it.


@dataclass(frozen=True)
class PaperOutputDesign:
    """Linear injection observer for the wheel states on the paper's outputs (29).

    State ``xo = [x11 (4), x21 (4), x22 (3)]`` (11,); inputs ``w = [x31 (4), x12 (3)]``;
    outputs ``x22`` (3,) plus, with ``deflection_wheel = i``, the wheel displacement
    ``x11_i = S_i x12 - d_i`` from a suspension-deflection sensor ``d_i``.
    ``A`` (11, 11), ``B`` (11, 7), ``C`` (p, 11), gain ``L`` (11, p), ``V`` (11, k) an
    orthonormal basis of the unobservable subspace (k = 2 on the paper's outputs: the static
    warp offset ``x11 = w`` and the warp drift ``x11 = a + t w, x21 = w`` with
    ``K21 a = -C21 w``; k = 0 with the added sensor), ``eig_quotient`` the eigenvalues of the
    error dynamics on the quotient [1/s] (all with negative real part: checked at design).
    ``tau_w`` [s]: the estimate's component along ``V`` (which no output corrects) is pulled
    to zero with this time constant (a zero-mean warp prior); this leaves the error modulo
    ``V`` unchanged, because ``V`` is invariant under ``A - LC``."""

    certificate: ClassVar[None] = None

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    L: np.ndarray
    V: np.ndarray
    eig_quotient: np.ndarray
    deflection_wheel: int | None
    tau_w: float = 1.0

    @property
    def margin(self) -> float:
        """Stability margin ``-max Re(eig)`` [1/s] of the quotient error dynamics."""
        return float(-np.max(np.real(self.eig_quotient)))


def paper_output_design(p, deflection_wheel: int | None = None, q: float = 1.0,
                        r: float = 1e-6, tol: float = 1e-9) -> PaperOutputDesign:
    """Design the observer of :class:`PaperOutputDesign` for the full car ``p``
    (:class:`~vehicle_observers.models.fullcar.FullCarParams`) on the paper's outputs (29).

    Gain: Kalman-Bucy (dual Riccati) on the observable quotient ``(T'AT, CT)`` with process
    intensity ``q I`` and output intensity ``r I``, lifted as ``L = T L_q`` (``T`` the
    orthonormal complement of the unobservable subspace ``V``, found from the SVD of the
    observability matrix with relative tolerance ``tol``). Certified after the solve: the
    quotient error matrix ``T'(A - LC)T`` must be Hurwitz and ``(A - LC) V = 0`` (the warp
    component stays constant); ``CertificationError`` otherwise. ``q``, ``r``, ``tol`` > 0
    (:class:`~vehicle_observers.core.errors.ObserverArgumentError` otherwise)."""
    from scipy.linalg import null_space, solve_continuous_are

    for name, v in (("q", q), ("r", r), ("tol", tol)):
        positive("paper_output_design", name, v)
    M, Cm, K, _, _ = p.matrices()
    M2 = np.diag(M)[4:]
    A = np.zeros((11, 11))
    A[0:4, 4:8] = np.eye(4)
    A[8:11, 0:4] = -K[4:, :4] / M2[:, None]
    A[8:11, 4:8] = -Cm[4:, :4] / M2[:, None]
    A[8:11, 8:11] = -Cm[4:, 4:] / M2[:, None]
    B = np.zeros((11, 7))
    B[4:8, 0:4] = np.eye(4)
    B[8:11, 4:7] = -K[4:, 4:] / M2[:, None]
    rows = [np.hstack([np.zeros((3, 8)), np.eye(3)])]
    if deflection_wheel is not None:
        if deflection_wheel not in range(4):
            raise ObserverArgumentError(f"paper_output_design: deflection_wheel must be 0..3 "
                                        f"(RL, RR, FL, FR) or None, got {deflection_wheel}")
        e = np.zeros((1, 11))
        e[0, deflection_wheel] = 1.0
        rows.append(e)
    C = np.vstack(rows)
    a = np.max(np.abs(A))  # scaled powers: the observability matrix stays well conditioned
    O = np.vstack([C @ np.linalg.matrix_power(A / a, k) for k in range(11)])
    V = null_space(O, rcond=tol)
    T = null_space(V.T) if V.shape[1] else np.eye(11)
    Aq, Cq = T.T @ A @ T, C @ T
    Pq = solve_continuous_are(Aq.T, Cq.T, q * np.eye(Aq.shape[0]), r * np.eye(C.shape[0]))
    L = T @ (Pq @ Cq.T / r)
    eq = np.linalg.eigvals(T.T @ (A - L @ C) @ T)
    if np.max(np.real(eq)) >= 0:
        raise CertificationError(f"paper-output observer: quotient error matrix not Hurwitz, "
                                 f"max Re(eig) = {np.max(np.real(eq)):.3g} 1/s")
    if V.shape[1]:
        leak = np.max(np.abs(T.T @ (A - L @ C) @ V))
        if leak > 1e-6 * np.max(np.abs(A - L @ C)):
            raise CertificationError(f"paper-output observer: the unobservable subspace is not "
                                     f"invariant under A - LC (coupling {leak:.3g})")
    return PaperOutputDesign(A, B, C, L, V, eq, deflection_wheel)


@njit(cache=True)
def _lti_run(x0, F, G, Wk):
    """``x_{k+1} = F x_k + G w_k`` over the rows of ``Wk`` (N, m); returns (N, n)."""
    N = Wk.shape[0]
    n = x0.shape[0]
    X = np.empty((N, n))
    x = x0.copy()
    for k in range(N):
        X[k] = x
        x = F @ x + G @ Wk[k]
    return X


@njit(cache=True)
def _first_order_zoh(u, e, U0):
    """``U_{k+1} = e U_k + (1 - e) u_k`` per column from ``U_0 = U0``: (37) exact for
    ``zeta`` held over each step. u (N, m), e (m,), U0 (m,)."""
    N, m = u.shape
    U = np.zeros((N, m))
    U[0] = U0
    for k in range(N - 1):
        U[k + 1] = e * U[k] + (1.0 - e) * u[k]
    return U


#: internal state of :class:`PaperOutputObserver`: ``[x11^ (4), x21^ (4), x22^ (3), U (4)]``
P_X11, P_X21, P_X22, P_U, P_END = 0, 4, 8, 11, 15


@dataclass(frozen=True, eq=False)
class PaperOutputTrajectory(Trajectory):
    """Run of :class:`PaperOutputObserver`: the estimate ``x`` (N, 15) ``[x11^ (4), x21^
    (4), x22^ (3), U (4)]`` and ``zeta`` (N, 4) the road force [N] (36) at sample ``k``.
    Views of ``x``: ``z`` wheel displacements [m], ``v`` wheel velocities [m/s], ``x22`` body
    rates, ``U`` road elevation [m] (37)."""

    zeta: np.ndarray | None = None

    @property
    def z(self) -> np.ndarray:
        return self.x[:, P_X11:P_X21]

    @property
    def v(self) -> np.ndarray:
        return self.x[:, P_X21:P_X22]

    @property
    def x22(self) -> np.ndarray:
        return self.x[:, P_X22:P_U]

    @property
    def U(self) -> np.ndarray:
        return self.x[:, P_U:P_END]


class PaperOutputObserver(FixedStepObserver):
    """Road observer on the paper's outputs (29) (Rabhi 2004 Part B): the linear injection
    observer of :func:`paper_output_design` (explicit Euler at ``dt``), then the road force
    (36) from the wheel line and the road elevation (37) integrated exactly over each step.

    ``params``: :class:`~vehicle_observers.models.fullcar.FullCarParams` (observer model);
    ``design``: :class:`PaperOutputDesign`. Data: no input (``u=None``); ``y`` (N, 10) =
    ``fullcar.outputs(paper=True)`` ``[x12 (3), x22 (3), x31 (4)]``, plus a column
    ``S_i x12 - x11_i`` [m] (suspension deflection of wheel ``i``) when the design has a
    deflection sensor. ``x0`` (15,) the initial estimate ``[x11^, x21^, x22^, U]``; default
    zero wheel states, the measured body rates and a flat road.
    """

    state_names = (X11_NAMES + tuple(f"vzw_{w}_mps" for w in _WHEEL) + X22_NAMES
                   + ROAD_NAMES)
    input_names = ()

    def __init__(self, params: FullCarParams, design: "PaperOutputDesign", dt: float):
        super().__init__(dt)
        if not isinstance(design, PaperOutputDesign):
            raise ObserverArgumentError(f"PaperOutputObserver: design must be a "
                                        f"PaperOutputDesign, got {type(design).__name__}")
        self.params, self.design = params, design
        i = design.deflection_wheel
        self.output_names = X12_NAMES + X22_NAMES + X31_NAMES + (
            () if i is None else (f"defl_{_WHEEL[i]}_m",))
        d = design
        M, Cm, K, A11, B11 = params.matrices()
        self._M1, self._C1, self._K1 = np.diag(M)[:4], Cm[:4], K[:4]
        self._kt, self._e = np.diag(A11), np.exp(-self.dt * np.diag(A11) / np.diag(B11))
        self._S = params.S
        self._F = np.eye(11) + self.dt * (d.A - d.L @ d.C - d.V @ d.V.T / d.tau_w)
        self._G = self.dt * np.hstack([d.B, d.L])

    def _split(self, y):
        """``(x12, x22, x31, observer outputs yo)`` of the samples ``y`` (N, p)."""
        x12 = y[:, PAPER_X12:PAPER_X12 + 3]
        x22 = y[:, PAPER_X22:PAPER_X22 + 3]
        acc = y[:, PAPER_X31:PAPER_X31 + 4]
        yo = x22
        i = self.design.deflection_wheel
        if i is not None:
            yo = np.column_stack([x22, self._S[i] @ x12.T - y[:, PAPER_X31 + 4]])
        return x12, x22, acc, yo

    def _zeta(self, xo, y):
        """Road force (36) ``zeta = M1 x31 + C11 x21 + C12 x22 + K11 x11 + K12 x12`` (N, 4)."""
        x12, x22, acc, _ = self._split(y)
        C1, K1 = self._C1, self._K1
        return (acc * self._M1 + xo[:, 4:8] @ C1[:, :4].T + x22 @ C1[:, 4:].T
                + xo[:, 0:4] @ K1[:, :4].T + x12 @ K1[:, 4:].T)

    def initial_state(self, t, u, y, x0=None) -> np.ndarray:
        z = np.zeros(P_END)
        if x0 is None:
            z[P_X22:P_U] = y[0, PAPER_X22:PAPER_X22 + 3]
        else:
            z[:] = x0
        return z

    def step(self, z, k, t, u, y) -> np.ndarray:
        """Observer on the paper's outputs (29) (Rabhi 2004 Part B, the wheel and body lines
        of (24)-(29)), one explicit-Euler step over ``[t_{k-1}, t_k]`` with sample ``k - 1``:
        ``xo+ = xo + dt (A xo + B w + L (yo - C xo) - V V' xo / tau_w)`` with ``w = [x31,
        x12]`` and ``yo`` the measured body rates (and wheel displacement), then the road
        elevation (37) ``U+ = e U + (1 - e) zeta / k_t`` with the road force (36) of sample
        ``k - 1``."""
        d = self.design
        x12, _, acc, yo = (a[0] for a in self._split(y[k - 1:k]))
        xo = z[P_X11:P_U]
        zeta = self._zeta(xo[None], y[k - 1:k])[0]
        xo_new = xo + self.dt * (d.A @ xo + d.B @ np.concatenate([acc, x12])
                                 + d.L @ (yo - d.C @ xo) - d.V @ (d.V.T @ xo) / d.tau_w)
        return np.concatenate([xo_new, self._e * z[P_U:P_END] + (1.0 - self._e) * zeta
                               / self._kt])

    def estimate(self, z) -> np.ndarray:
        return np.array(z, dtype=float)

    def run(self, t, u, y, x0=None) -> PaperOutputTrajectory:
        """Compiled: the observer (``_lti_run``), then (36) and (37) (``_first_order_zoh``)."""
        t, u, y, x0 = self.check_data(t, u, y, x0)
        z0 = self.initial_state(t, u, y, x0)
        x12, _, acc, yo = self._split(y)
        W = np.ascontiguousarray(np.hstack([acc, x12, yo]))
        sec, X = self.timed(_lti_run, z0[P_X11:P_U].copy(), self._F, self._G, W)
        zeta = self._zeta(X, y)
        sec2, U = self.timed(_first_order_zoh, zeta / self._kt, self._e, z0[P_U:P_END].copy())
        return PaperOutputTrajectory(t, np.hstack([X, U]), self.state_names, seconds=sec + sec2,
                                     estimator=type(self).__name__, zeta=zeta)


def road_lost_subspace(p, design: PaperOutputDesign) -> np.ndarray:
    """Orthonormal basis (4, k) of the road patterns that carry the unobservable wheel
    states ``V`` of ``design``: a state error ``e`` in ``V`` gives the road-force error
    ``K11 e_x11 + C11 e_x21`` (36) and, through (37), the road error ``K_t^-1`` times it
    (for a constant force). With the static warp alone this is
    ``U_w = K_t^-1 (K_s + K_t) w``."""
    from scipy.linalg import orth

    M, Cm, K, A11, _ = p.matrices()
    if design.V.shape[1] == 0:
        return np.zeros((4, 0))
    Z = np.linalg.solve(A11, K[:4, :4] @ design.V[0:4] + Cm[:4, :4] @ design.V[4:8])
    return orth(Z)


def modulo_subspace(E, Q) -> np.ndarray:
    """``E`` (N, m) with its component in the span of the orthonormal columns of ``Q``
    (m, k) removed per row: the error modulo the lost directions."""
    E = np.asarray(E, dtype=float)
    Q = np.asarray(Q, dtype=float).reshape(E.shape[1], -1)
    return E - (E @ Q) @ Q.T
