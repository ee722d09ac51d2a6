"""Sliding-mode observers of Rabhi, Imine, M'Sirdi, Delanne (AVCS 2004).

Part A: tyre-force observer with adaptive force model, eqs. (9)-(22)
Part B: sliding-mode unknown-input observer of the road profile, eqs. (30)-(38)

Both are discrete-time loops (explicit Euler at the measurement period ``dt``) compiled
with numba. The switching function is selectable (``mode``):

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

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from vehicle_observers.core.metrics import rmse
from vehicle_observers.models.planar import IR, IVX, IVY, IWF, IWR, PlanarParams

SIGN, SAT, LPF = 0, 1, 2
MODES = {"sign": SIGN, "sat": SAT, "lpf": LPF}


def _mode(mode) -> int:
    if isinstance(mode, str):
        if mode not in MODES:
            raise ValueError(f"mode must be one of {list(MODES)}, got {mode!r}")
        return MODES[mode]
    if int(mode) not in (0, 1, 2):
        raise ValueError(f"mode must be 0 (sign), 1 (sat) or 2 (lpf), got {mode}")
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


# ================================================================== Part A =================
@dataclass(frozen=True)
class ForceObserverModel:
    """Observer-side model constants (may differ from the truth to test robustness).

    Slip stiffnesses are the per-axle tangent slopes at zero slip used in (8):
    ``C_kf, C_kr`` [N] (longitudinal), ``C_af, C_ar`` [N/rad] (lateral).
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
                raise ValueError(f"unknown observer-model parameter {k!r}; expected one of "
                                 f"{sorted(base)}")
            base[k] = base[k] * (1.0 + float(v))
        return cls(**base)

    def as_array(self) -> np.ndarray:
        return np.array([self.m, self.J_z, self.l_f, self.l_r, self.r_f, self.r_r, self.J_f,
                         self.J_r, self.C_kf, self.C_kr, self.C_af, self.C_ar], dtype=float)

    def theta0(self) -> np.ndarray:
        """Nominal ``theta = (1/sigma, F0/sigma)`` per force with ``F0 = 0``, shape (8,)."""
        return np.array([1 / self.sigma_x, 0.0, 1 / self.sigma_x, 0.0,
                         1 / self.sigma_y, 0.0, 1 / self.sigma_y, 0.0])


@dataclass(frozen=True)
class ForceObserverGains:
    """Gains of observer (10). Defaults are the notebook's design (see ``design_note``).

    lam2 (3,) [m/s^2, m/s^2, rad/s^2] must exceed ``|Omega x~4|`` (13);
    lam3 (2,) [rad/s^2] must exceed ``|H x~4x|`` (16);
    k (4,) [1/s] the diagonal of ``K`` in ``A = K + v_x F`` (19);
    P (8,) adaptation gains; theta bounds (8,) for the projection;
    phi2 (3,), phi3 (2,) boundary-layer widths (mode SAT); tau_f [s] injection filter.
    """

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

    def with_(self, **kw) -> "ForceObserverGains":
        from dataclasses import replace

        if "mode" in kw:
            kw["mode"] = _mode(kw["mode"])
        return replace(self, **kw)


@njit(cache=True)
def _omega_h(delta, Q, Om, Hm):
    m, Jz, lf, lr, rf, rr, Jf, Jr = Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7]
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
    """Regressor Psi(X) (4, 8) of the relaxation model (8), reconstruction R-A5."""
    lf, lr, rf, rr = Q[2], Q[3], Q[4], Q[5]
    Ckf, Ckr, Caf, Car = Q[8], Q[9], Q[10], Q[11]
    for i in range(4):
        for j in range(8):
            Psi[i, j] = 0.0
    s0 = rf * wf - vx
    s1 = rr * wr - vx
    s2 = vx * delta - vy - lf * r
    s3 = lr * r - vy
    Psi[0, 0] = Ckf * s0 - vx * F[0]
    Psi[0, 1] = vx
    Psi[1, 2] = Ckr * s1 - vx * F[1]
    Psi[1, 3] = vx
    Psi[2, 4] = Caf * s2 - vx * F[2]
    Psi[2, 5] = vx
    Psi[3, 6] = Car * s3 - vx * F[3]
    Psi[3, 7] = vx


@njit(cache=True)
def _force_observer(Y, U, dt, Q, z0, lam2, lam3, kk, Pth, th_lo, th_hi, phi2, phi3, tau_f,
                    mode):
    N = Y.shape[0]
    x2 = z0[0:3].copy()
    x3 = z0[3:5].copy()
    x4 = z0[5:9].copy()
    th = z0[9:17].copy()
    e4f = np.zeros(4)
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
    Jf, Jr = Q[6], Q[7]
    a = np.exp(-dt / tau_f)
    for k in range(N):
        out_x2[k] = x2
        out_x3[k] = x3
        out_x4[k] = x4
        out_th[k] = th
        vx, vy, r, wf, wr = Y[k, 0], Y[k, 1], Y[k, 2], Y[k, 3], Y[k, 4]
        delta, Tf, Tr = U[k, 0], U[k, 1], U[k, 2]
        for i in range(3):
            s2[i] = _sw(Y[k, i] - x2[i], phi2[i], mode)
            v[i] = lam2[i] * s2[i]
        for i in range(2):
            s3[i] = _sw(Y[k, 3 + i] - x3[i], phi3[i], mode)
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
        x3[0] += dt * (Tf / Jf - Hm[0, 0] * x4[0] + v[3])
        x3[1] += dt * (Tr / Jr - Hm[1, 1] * x4[1] + v[4])
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


def _sw_np(e, phi, mode):
    """Switching function of :func:`_sw` on arrays."""
    return np.clip(e / phi, -1.0, 1.0) if mode == SAT else np.sign(e)


def force_observer_step(st: dict, y, u, model: ForceObserverModel, g: ForceObserverGains,
                        dt: float) -> dict:
    """One explicit-Euler step of observer (10) with the adaptation (20)-(22), the readable
    numpy version of the compiled loop ``_force_observer`` (tested equal).

    ``st``: ``x2`` (3,) ``[v_x, v_y, r]``, ``x3`` (2,) wheel speeds [rad/s], ``x4`` (4,)
    forces [N], ``th`` (8,) theta, ``e4f`` (4,) filtered equivalent injection; ``y`` (5,)
    measurements ``[v_x, v_y, r, w_f, w_r]``, ``u`` (3,) ``[delta, T_f, T_r]``. Returns the
    next state (new dict)."""
    mode = _mode(g.mode)
    Q = model.as_array()
    x2, x3, x4, th = st["x2"], st["x3"], st["x4"], st["th"]
    Om, Hm = omega_h(u[0], Q)
    # switching terms Lambda2 s(x~2), Lambda3 s(x~3) of (10)
    v = np.concatenate([np.asarray(g.lam2) * _sw_np(y[0:3] - x2, np.asarray(g.phi2), mode),
                        np.asarray(g.lam3) * _sw_np(y[3:5] - x3, np.asarray(g.phi3), mode)])
    W = np.vstack([Om, -Hm])
    e4 = np.linalg.solve(W.T @ W, W.T @ v)           # x~4 on the surfaces (R-A6, R-A7)
    a = np.exp(-dt / g.tau_f)
    e4f = a * st["e4f"] + (1 - a) * e4
    Psi = np.empty((4, 8))
    _psi(y[0], y[1], y[2], y[3], y[4], u[0], x4, Q, Psi)
    transport = np.array([y[1] * y[2], -y[0] * y[2], 0.0])   # v_y r, -v_x r (R-A3)
    inj = e4f if mode == LPF else e4
    th_new = np.clip(th + dt * np.asarray(g.P) * (Psi.T @ e4f), g.theta_lo, g.theta_hi)
    return {"x2": x2 + dt * (Om @ x4 + transport + v[0:3]),
            "x3": x3 + dt * (u[1:3] / Q[6:8] - np.diag(Hm[:, 0:2]) * x4[0:2] + v[3:5]),
            "x4": x4 + dt * (Psi @ th + np.asarray(g.k) * inj),
            "th": th_new, "e4f": e4f}


@dataclass
class ForceObserverResult:
    """Trajectories of observer (10): x2 (N,3), x3 (N,2), x4 (N,4) forces [N], theta (N,8),
    x4_err_eq (N,4) the filtered equivalent-injection estimate of ``x4 - x^4``, s (N,5)
    switching values."""

    t: np.ndarray
    x2: np.ndarray
    x3: np.ndarray
    x4: np.ndarray
    theta: np.ndarray
    x4_err_eq: np.ndarray
    s: np.ndarray


def run_force_observer(t, Y, U, model: ForceObserverModel, gains: ForceObserverGains,
                       x2_0=None, x3_0=None, x4_0=None, theta_0=None) -> ForceObserverResult:
    """Run observer (10) on measurements ``Y`` (N, 5) ``[v_x, v_y, r, w_f, w_r]`` and inputs
    ``U`` (N, 3) ``[delta, T_f, T_r]`` sampled at constant step ``t[1]-t[0]``.

    Initial estimates default to the first measurement (x2, x3), zero forces and the nominal
    ``theta`` (``model.theta0()``).
    """
    t = np.asarray(t, dtype=float)
    Y = np.ascontiguousarray(Y, dtype=float)
    U = np.ascontiguousarray(U, dtype=float)
    if Y.ndim != 2 or Y.shape[1] != 5:
        raise ValueError(f"Y must be (N, 5) [vx, vy, r, omega_f, omega_r], got {Y.shape}")
    if U.shape != (Y.shape[0], 3):
        raise ValueError(f"U must be (N, 3) [delta, T_f, T_r] with N={Y.shape[0]}, "
                         f"got {U.shape}")
    if t.shape != (Y.shape[0],):
        raise ValueError(f"t must be (N,) with N={Y.shape[0]}, got {t.shape}")
    dt = float(t[1] - t[0])
    if dt <= 0 or not np.allclose(np.diff(t), dt, rtol=1e-6, atol=1e-12):
        raise ValueError("t must be uniformly increasing (constant step)")
    bad = ~np.all(np.isfinite(Y), axis=1)
    if bad.any():
        raise ValueError(f"Y row {int(np.argmax(bad))} is not finite")
    if np.any(Y[:, 0] <= 0.5):
        k = int(np.argmax(Y[:, 0] <= 0.5))
        raise ValueError(f"v_x must stay > 0.5 m/s (relaxation model divides by it): "
                         f"Y[{k}, 0] = {Y[k, 0]}")
    z0 = np.empty(17)
    z0[0:3] = Y[0, 0:3] if x2_0 is None else x2_0
    z0[3:5] = Y[0, 3:5] if x3_0 is None else x3_0
    z0[5:9] = 0.0 if x4_0 is None else x4_0
    z0[9:17] = model.theta0() if theta_0 is None else theta_0
    g = gains
    arr = lambda v: np.asarray(v, dtype=float)
    x2, x3, x4, th, e4, s = _force_observer(
        Y, U, dt, model.as_array(), z0, arr(g.lam2), arr(g.lam3), arr(g.k), arr(g.P),
        arr(g.theta_lo), arr(g.theta_hi), arr(g.phi2), arr(g.phi3), float(g.tau_f),
        _mode(g.mode))
    return ForceObserverResult(t, x2, x3, x4, th, e4, s)


def measurements_from_truth(Xs, noise_std=None, seed: int = 0) -> np.ndarray:
    """Measured ``[v_x, v_y, r, w_f, w_r]`` (N, 5) from a planar trajectory (N, 12), with
    optional white noise ``noise_std`` (5,) drawn from ``default_rng(seed)``."""
    Y = np.asarray(Xs)[:, [IVX, IVY, IR, IWF, IWR]].copy()
    if noise_std is not None:
        rng = np.random.default_rng(seed)
        Y += rng.normal(size=Y.shape) * np.asarray(noise_std, dtype=float)
    return Y


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


def force_errors(t, F_est, F_true, peak, t_skip: float = 1.0,
                 names=("Fxf", "Fxr", "Fyf", "Fyr")) -> dict:
    """Force metrics shared by the SMO and the EKF baseline: for each force ``rmse_<nm>``
    [N] and ``rmse_pct_<nm>`` [% of ``peak``] over ``t >= t_skip``. t (M,), F_est,
    F_true (M, 4) [N], peak (4,) [N] (peak of the full truth run)."""
    t = np.asarray(t, dtype=float)
    m = t >= t_skip
    if not m.any():
        raise ValueError(f"no sample after t_skip = {t_skip} s")
    F_est, F_true = np.asarray(F_est, dtype=float), np.asarray(F_true, dtype=float)
    out = {}
    for i, nm in enumerate(names):
        e = rmse(F_est[m, i], F_true[m, i])
        out[f"rmse_{nm}"] = e
        out[f"rmse_pct_{nm}"] = 100 * e / float(peak[i])
    return out


def reaching_time(t, err, band) -> float:
    """First time after which ``|err| <= band`` for good (the sliding surface is reached
    and kept); ``nan`` if it never stays inside. ``err`` (N,), ``band`` scalar."""
    e = np.abs(np.asarray(err, dtype=float))
    outside = np.flatnonzero(e > band)
    if len(outside) == 0:
        return float(t[0])
    if outside[-1] == len(e) - 1:
        return float("nan")
    return float(t[outside[-1] + 1])


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


@dataclass(frozen=True)
class RoadObserverGains:
    """Gains of the road-profile UIO (R-B4/R-B5), per wheel (4,) or scalars.

    h11 [m/s] must exceed ``|x~21|`` (stage-1 reaching); h21 [m/s^2] must exceed the fast
    part of ``|M1^-1 zeta~|``; phi1 [m], phi2 [m/s] boundary layers (mode SAT); tau_f [s]
    equivalent-injection filter; tau_i [s] zeta^ integrator time constant.
    """

    h11: float = 2.0
    h21: float = 150.0
    phi1: float = 2e-4
    phi2: float = 0.02
    tau_f: float = 1e-3
    tau_i: float = 5e-3
    h22: float = 5.0
    phi22: float = 0.01
    mode: int = SAT

    def with_(self, **kw) -> "RoadObserverGains":
        from dataclasses import replace

        if "mode" in kw:
            kw["mode"] = _mode(kw["mode"])
        return replace(self, **kw)


@njit(cache=True)
def _road_observer(Y, dt, mu, c11, k11, C12, K12, kt, ct, h11, h21, phi1, phi2, tau_f,
                   tau_i, mode, M2, C21, C22, K21, K22, h22, phi22, z0):
    N = Y.shape[0]
    z = z0.copy()
    xb = Y[0, 7:10].copy()
    out_xb = np.empty((N, 3))
    v = np.zeros(4)
    veq = np.zeros(4)
    seq = np.zeros(4)
    zh = np.zeros(4)
    U = np.zeros(4)
    out_z = np.empty((N, 4))
    out_v = np.empty((N, 4))
    out_zeta = np.empty((N, 4))
    out_U = np.empty((N, 4))
    out_s1 = np.empty((N, 4))
    a = np.exp(-dt / tau_f)
    for k in range(N):
        x12 = Y[k, 4:7]
        x22 = Y[k, 7:10]
        g = C12 @ x22 + K12 @ x12
        # body-rate line of (30): x22^' = -M2^-1(C21 x21^ + C22 x22^ + K21 x11 + K22 x12)
        #                                 + H22 s(x~22)
        out_xb[k] = xb
        vw = v + veq
        db = -(C21 @ vw + C22 @ xb + K21 @ Y[k, 0:4] + K22 @ x12) / M2
        for j in range(3):
            xb[j] += dt * (db[j] + h22 * _sw(x22[j] - xb[j], phi22, mode))
        for i in range(4):
            s1 = _sw(Y[k, i] - z[i], phi1, mode)
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
            dv = (-(c11[i] * v[i] + k11[i] * Y[k, i] + g[i]) + zh[i]) / mu[i] + h21 * s2
            z[i] += dt * (v[i] + h11 * s1)
            v[i] += dt * dv
            zh[i] += dt * mu[i] * h21 * seq[i] / tau_i
    return out_z, out_v, out_zeta, out_U, out_s1, out_xb


@dataclass
class RoadObserverResult:
    """UIO trajectories, all (N, 4) in wheel order (RL, RR, FL, FR): wheel displacement
    ``z`` [m], wheel velocity ``v`` [m/s] (x21^ plus the equivalent injection), road force
    ``zeta`` [N] (36), road elevation ``U`` [m] (37), stage-1 switching values ``s1``;
    ``x22`` (N, 3) the body-rate estimate ``[z', theta', phi']`` of (30)."""

    t: np.ndarray
    z: np.ndarray
    v: np.ndarray
    zeta: np.ndarray
    U: np.ndarray
    s1: np.ndarray
    x22: np.ndarray


def _checked_outputs(t, Y, name: str, layout: str):
    """``(t, Y, dt)`` for a road observer: ``Y`` (N, 10) finite, ``t`` (N,) uniformly
    increasing; a ValueError naming the array, the row or the expected layout otherwise."""
    t = np.asarray(t, dtype=float)
    Y = np.ascontiguousarray(Y, dtype=float)
    if Y.ndim != 2 or Y.shape[1] != 10:
        raise ValueError(f"{name} must be (N, 10) {layout}, got {Y.shape}")
    if t.shape != (Y.shape[0],):
        raise ValueError(f"t must be (N,) with N={Y.shape[0]}, got {t.shape}")
    dt = float(t[1] - t[0])
    if dt <= 0 or not np.allclose(np.diff(t), dt, rtol=1e-6, atol=1e-12):
        raise ValueError("t must be uniformly increasing (constant step)")
    bad = ~np.all(np.isfinite(Y), axis=1)
    if bad.any():
        raise ValueError(f"{name} row {int(np.argmax(bad))} is not finite")
    return t, Y, dt


def run_road_observer(t, Y, p, gains: RoadObserverGains, z0=None) -> RoadObserverResult:
    """Run the road-profile UIO on outputs ``Y`` (N, 10) = ``fullcar.outputs(paper=False)``
    ``[x11 (4), x12 (3), x22 (3)]`` sampled at constant step, with observer-model constants
    ``p`` (:class:`~vehicle_observers.models.fullcar.FullCarParams`, may differ from the truth).
    ``z0`` (4,) initial wheel-displacement estimate (default: the first measurement); the
    wheel-velocity, road-force and body-rate estimates start at 0 / the first measurement."""
    t, Y, dt = _checked_outputs(t, Y, "Y", "[x11 (4), x12 (3), x22 (3)]")
    if _mode(gains.mode) == LPF:
        raise ValueError("mode 'lpf' applies to the force observer only: the road UIO always "
                         "low-pass filters its equivalent injections (tau_f); use 'sign' or "
                         "'sat'")
    M, C, K, A11, B11 = p.matrices()
    g = gains
    z0 = Y[0, 0:4] if z0 is None else np.asarray(z0, dtype=float)
    if z0.shape != (4,):
        raise ValueError(f"z0 must have shape (4,), got {z0.shape}")
    z, v, zeta, U, s1, xb = _road_observer(
        Y, dt, np.diag(M)[:4].copy(), np.diag(C)[:4].copy(), np.diag(K)[:4].copy(),
        np.ascontiguousarray(C[:4, 4:]), np.ascontiguousarray(K[:4, 4:]),
        np.diag(A11).copy(), np.diag(B11).copy(), float(g.h11), float(g.h21),
        float(g.phi1), float(g.phi2), float(g.tau_f), float(g.tau_i), _mode(g.mode),
        np.diag(M)[4:].copy(), np.ascontiguousarray(C[4:, :4]), np.ascontiguousarray(C[4:, 4:]),
        np.ascontiguousarray(K[4:, :4]), np.ascontiguousarray(K[4:, 4:]), float(g.h22),
        float(g.phi22), z0.copy())
    return RoadObserverResult(t, z, v, zeta, U, s1, xb)


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
    component stays constant); ``ValueError`` otherwise."""
    from scipy.linalg import null_space, solve_continuous_are

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
            raise ValueError(f"deflection_wheel must be 0..3 (RL, RR, FL, FR), got {deflection_wheel}")
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
        raise ValueError(f"paper-output observer: quotient error matrix not Hurwitz, "
                         f"max Re(eig) = {np.max(np.real(eq)):.3g} 1/s")
    if V.shape[1]:
        leak = np.max(np.abs(T.T @ (A - L @ C) @ V))
        if leak > 1e-6 * np.max(np.abs(A - L @ C)):
            raise ValueError(f"paper-output observer: the unobservable subspace is not invariant "
                             f"under A - LC (coupling {leak:.3g})")
    return PaperOutputDesign(A, B, C, L, V, eq, deflection_wheel)


def paper_output_step(xo, w, y, d: PaperOutputDesign, dt: float):
    """One explicit-Euler step of the observer, readable version of :func:`_lti_run`:
    ``xo + dt (A xo + B w + L (y - C xo) - V V' xo / tau_w)``. ``xo`` (11,), ``w = [x31, x12]`` (7,),
    ``y`` (p,) the measured outputs."""
    leak = d.V @ (d.V.T @ xo) / d.tau_w
    return xo + dt * (d.A @ xo + d.B @ w + d.L @ (y - d.C @ xo) - leak)


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


@dataclass
class PaperOutputResult:
    """Trajectories of the paper-output observer: ``z`` (N, 4) wheel displacements [m],
    ``v`` (N, 4) wheel velocities [m/s], ``x22`` (N, 3) body rates, ``zeta`` (N, 4) road
    force [N] (36), ``U`` (N, 4) road elevation [m] (37)."""

    t: np.ndarray
    z: np.ndarray
    v: np.ndarray
    x22: np.ndarray
    zeta: np.ndarray
    U: np.ndarray


def run_paper_output_observer(t, Yp, p, design: PaperOutputDesign, x0=None,
                              deflection=None) -> PaperOutputResult:
    """Run the observer of :func:`paper_output_design` on the paper's outputs
    ``Yp`` (N, 10) = ``fullcar.outputs(paper=True)`` ``[x12 (3), x22 (3), x31 (4)]`` and,
    if the design has a deflection sensor, ``deflection`` (N,) = ``S_i x12 - x11_i`` [m].
    ``p`` the observer-model constants. Explicit Euler at the sample step (the same step as
    :func:`paper_output_step`), ``x0`` (11,) the initial estimate (default zero wheel
    states, measured body rates). The road force is the wheel line of (24)-(29) solved
    for ``zeta``: ``zeta = M1 x31 + C11 x21 + C12 x22 + K11 x11 + K12 x12`` (36), and
    the road elevation follows from (37) integrated exactly over each step."""
    t, Yp, dt = _checked_outputs(t, Yp, "Yp", "[x12 (3), x22 (3), x31 (4)]")
    x12, x22, acc = Yp[:, 0:3], Yp[:, 3:6], Yp[:, 6:10]
    y = x22
    if design.deflection_wheel is not None:
        if deflection is None or np.shape(deflection) != (len(t),):
            raise ValueError(f"design has a deflection sensor on wheel {design.deflection_wheel}: "
                             f"deflection must be (N,) = ({len(t)},)")
        i = design.deflection_wheel
        y = np.column_stack([x22, p.S[i] @ x12.T - np.asarray(deflection, dtype=float)])
    d = design
    F = np.eye(11) + dt * (d.A - d.L @ d.C - d.V @ d.V.T / d.tau_w)
    G = dt * np.hstack([d.B, d.L])
    if x0 is None:
        x0 = np.concatenate([np.zeros(8), x22[0]])
    X = _lti_run(np.asarray(x0, dtype=float), F, G, np.ascontiguousarray(np.hstack([acc, x12, y])))
    M, Cm, K, A11, B11 = p.matrices()
    z, v = X[:, 0:4], X[:, 4:8]
    zeta = (acc * np.diag(M)[:4] + v @ Cm[:4, :4].T + x22 @ Cm[:4, 4:].T + z @ K[:4, :4].T
            + x12 @ K[:4, 4:].T)
    kt, ct = np.diag(A11), np.diag(B11)
    e = np.exp(-dt * kt / ct)
    U = _first_order_zoh(zeta / kt, e)
    return PaperOutputResult(t, z, v, X[:, 8:11], zeta, U)


@njit(cache=True)
def _first_order_zoh(u, e):
    """``U_{k+1} = e U_k + (1 - e) u_k`` per column, ``U_0 = 0``: (37) exact for ``zeta``
    held over each step. u (N, m), e (m,)."""
    N, m = u.shape
    U = np.zeros((N, m))
    for k in range(N - 1):
        U[k + 1] = e * U[k] + (1.0 - e) * u[k]
    return U


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
