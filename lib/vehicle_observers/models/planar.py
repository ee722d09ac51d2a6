"""Planar vehicle with wheel spin and relaxation tyre forces (Rabhi et al., AVCS 2004, Part A).

Truth model used to test the tyre-force sliding-mode observer of :mod:`.observers.sliding_mode`.

State ``X`` (12,), SI units::

    [X_pos (m), Y_pos (m), psi (rad), v_x (m/s), v_y (m/s), r = psi_dot (rad/s),
     omega_f (rad/s), omega_r (rad/s), F_xf, F_xr, F_yf, F_yr (N)]

Inputs per sample ``u = [delta_f (rad), T_f (N m), T_r (N m)]`` (zero-order hold).
Front/rear quantities are per axle (the two wheels of an axle lumped, "bicycle" model of
Rabhi 2004 Sec. II-A); ``J_f, J_r`` are the axle spin inertias.

Equations
---------
* Body, Rabhi 2004 eq. (4) **reconstructed** (R-A1): the extraction reads
  ``m V_x' = F_xf (cos d - F_yf sin d + F_xr)`` (misplaced bracket) and drops the
  body-frame transport terms. We use the standard body-frame form
  ``m (v_x' - v_y r) = F_xf cos d - F_yf sin d + F_xr``,
  ``m (v_y' + v_x r) = F_xf sin d + F_yf cos d + F_yr``,
  ``J_z r' = l_f (F_xf sin d + F_yf cos d) - l_r F_yr``.
* Wheels, eq. (3): ``J_i omega_i' = T_i - r_i F_xi``.
* Tyre forces: first-order relaxation (eqs. (5)-(8) in their exact nonlinear form)
  ``sigma_x F_x' = |v_cx| (F_x^ss - F_x)``, ``sigma_y F_y' = |v_cx| (F_y^ss - F_y)`` where
  ``v_cx`` is the contact-point longitudinal speed in the wheel frame and the steady
  forces come from a **combined-slip** magic formula (Pacejka, *Tire and Vehicle
  Dynamics* 2005, Sec. 4.3.2, cosine weighting functions without shifts)::

      F_x^ss = D_x sin(C_x atan(B_x kappa - E_x (B_x kappa - atan(B_x kappa)))) * G_xa(alpha)
      F_y^ss = D_y sin(C_y atan(B_y alpha - E_y (B_y alpha - atan(B_y alpha)))) * G_yk(kappa)
      G_xa = cos(C_xa atan(B_xa alpha)),   G_yk = cos(C_yk atan(B_yk kappa))

  with ``D = mu F_z`` and static axle loads. Slip (R-A2, sign convention): traction
  positive, ``kappa = (r omega - v_cx) / max(|v_cx|, v_eps)``,
  ``alpha = -atan(v_cy / |v_cx|)`` (the paper's (7) writes ``C_x (V_x - r omega)``,
  i.e. braking positive; we keep one convention, traction and left forces positive).

The observer of :mod:`.observers.sliding_mode` uses the *linearised* relaxation model (8) with nominal slip
stiffnesses, so truth and observer model differ (nonlinear, combined slip, loads).
Not modelled (paper assumptions 1-4): roll, pitch, load transfer, aerodynamic forces.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.models.tires import magic_formula

G_ACC = 9.81

# state indices
IX, IY, IPSI, IVX, IVY, IR, IWF, IWR, IFXF, IFXR, IFYF, IFYR = range(12)
#: input indices of ``u = [delta_f, T_f, T_r]``
IU_DELTA, IU_TF, IU_TR = range(3)
STATE_NAMES = ("X", "Y", "psi", "vx", "vy", "r", "omega_f", "omega_r",
               "Fxf", "Fxr", "Fyf", "Fyr")
#: the measured states ``[v_x, v_y, r, omega_f, omega_r]`` of :func:`measurements`, in order
MEASURED = (IVX, IVY, IR, IWF, IWR)
#: index of each constant in :meth:`PlanarParams.as_array` (read by the compiled kernels)
(PP_M, PP_JZ, PP_LF, PP_LR, PP_RF, PP_RR, PP_JF, PP_JR, PP_SX, PP_SY, PP_MU, PP_BX, PP_CX,
 PP_EX, PP_BY, PP_CY, PP_EY, PP_BXA, PP_CXA, PP_BYK, PP_CYK, PP_VEPS, PP_FZF, PP_FZR) = range(24)


@dataclass(frozen=True)
class PlanarParams:
    """Vehicle and tyre constants of the planar model.

    Geometry and mass (m, J_z, l_f, l_r) are the Yacine 2015 car (same research group;
    Rabhi 2004 prints no values). Wheel radius, axle spin inertia, relaxation lengths and
    magic-formula coefficients are typical passenger-car values (Pacejka 2005, Ch. 4, 7),
    chosen, not taken from the paper. Per-axle slip stiffness ``C_kappa = B_x C_x D_x`` [N]
    and cornering stiffness ``C_alpha = B_y C_y D_y`` [N/rad] are properties.
    """

    m: float = 1500.0        # kg
    J_z: float = 2454.0      # kg m^2
    l_f: float = 1.1         # m
    l_r: float = 1.44        # m
    r_f: float = 0.3         # m, wheel radius
    r_r: float = 0.3         # m
    J_f: float = 2.4         # kg m^2, front axle (2 wheels + driveline share)
    J_r: float = 2.0         # kg m^2
    sigma_x: float = 0.25    # m, longitudinal relaxation length
    sigma_y: float = 0.5     # m, lateral relaxation length
    mu: float = 1.0          # road friction
    B_x: float = 12.0
    C_x: float = 1.65
    E_x: float = 0.0
    B_y: float = 9.0
    C_y: float = 1.3
    E_y: float = -0.5
    B_xa: float = 10.0       # combined-slip weighting (Pacejka r_Bx1, r_Cx1)
    C_xa: float = 1.0
    B_yk: float = 8.0        # (r_By1, r_Cy1)
    C_yk: float = 1.0
    v_eps: float = 1.0       # m/s, slip denominator floor

    @property
    def L(self) -> float:
        return self.l_f + self.l_r

    @property
    def Fz_f(self) -> float:
        """Static front axle load [N]."""
        return self.m * G_ACC * self.l_r / self.L

    @property
    def Fz_r(self) -> float:
        return self.m * G_ACC * self.l_f / self.L

    @property
    def C_kappa_f(self) -> float:
        """Front longitudinal slip stiffness ``dF_x/dkappa`` at 0 [N]."""
        return self.B_x * self.C_x * self.mu * self.Fz_f

    @property
    def C_kappa_r(self) -> float:
        return self.B_x * self.C_x * self.mu * self.Fz_r

    @property
    def C_alpha_f(self) -> float:
        """Front cornering stiffness ``dF_y/dalpha`` at 0 [N/rad]."""
        return self.B_y * self.C_y * self.mu * self.Fz_f

    @property
    def C_alpha_r(self) -> float:
        return self.B_y * self.C_y * self.mu * self.Fz_r

    def with_(self, **kw) -> "PlanarParams":
        return replace(self, **kw)

    def as_array(self) -> np.ndarray:
        """The constants packed for the kernels, indices :data:`PP_M` ... :data:`PP_FZR`
        (the static axle loads last)."""
        return np.array([self.m, self.J_z, self.l_f, self.l_r, self.r_f, self.r_r, self.J_f,
                         self.J_r, self.sigma_x, self.sigma_y, self.mu, self.B_x, self.C_x,
                         self.E_x, self.B_y, self.C_y, self.E_y, self.B_xa, self.C_xa,
                         self.B_yk, self.C_yk, self.v_eps, self.Fz_f, self.Fz_r], dtype=float)


# ------------------------------------------------------------------ numba kernels ---------
@njit(cache=True)
def _contact(X, delta, P):
    """Wheel-frame contact velocities (v_cx, v_cy) of the front and rear axle."""
    vx, vy, r = X[IVX], X[IVY], X[IR]
    lf, lr = P[PP_LF], P[PP_LR]
    c, s = np.cos(delta), np.sin(delta)
    vyf = vy + lf * r
    vcx_f = vx * c + vyf * s
    vcy_f = -vx * s + vyf * c
    vcx_r = vx
    vcy_r = vy - lr * r
    return vcx_f, vcy_f, vcx_r, vcy_r


@njit(cache=True)
def _combined(vcx, vcy, omega, radius, Fz, P):
    """Steady combined-slip forces (F_x, F_y) [N] and slips (kappa, alpha): the magic
    formula of :func:`vehicle_observers.models.tires.magic_formula` (``B k - E (B k -
    atan(B k))`` written ``B (1 - E) k + E atan(B k)``) times the cosine weights."""
    veps = P[PP_VEPS]
    den = max(abs(vcx), veps)
    kappa = (radius * omega - vcx) / den
    alpha = -np.arctan(vcy / den)
    D = P[PP_MU] * Fz
    Fx0 = magic_formula(kappa, P[PP_BX], P[PP_CX], D, P[PP_EX])
    Fy0 = magic_formula(alpha, P[PP_BY], P[PP_CY], D, P[PP_EY])
    Gxa = np.cos(P[PP_CXA] * np.arctan(P[PP_BXA] * alpha))
    Gyk = np.cos(P[PP_CYK] * np.arctan(P[PP_BYK] * kappa))
    return Fx0 * Gxa, Fy0 * Gyk, kappa, alpha


@njit(cache=True)
def _rhs(X, u, P, out):
    m, Jz, lf, lr = P[PP_M], P[PP_JZ], P[PP_LF], P[PP_LR]
    rf, rr, Jf, Jr, sx, sy = P[PP_RF], P[PP_RR], P[PP_JF], P[PP_JR], P[PP_SX], P[PP_SY]
    delta, Tf, Tr = u[IU_DELTA], u[IU_TF], u[IU_TR]
    psi, vx, vy, r = X[IPSI], X[IVX], X[IVY], X[IR]
    Fxf, Fxr, Fyf, Fyr = X[IFXF], X[IFXR], X[IFYF], X[IFYR]
    c, s = np.cos(delta), np.sin(delta)
    out[IX] = vx * np.cos(psi) - vy * np.sin(psi)
    out[IY] = vx * np.sin(psi) + vy * np.cos(psi)
    out[IPSI] = r
    out[IVX] = vy * r + (Fxf * c - Fyf * s + Fxr) / m
    out[IVY] = -vx * r + (Fxf * s + Fyf * c + Fyr) / m
    out[IR] = (lf * (Fxf * s + Fyf * c) - lr * Fyr) / Jz
    out[IWF] = (Tf - rf * Fxf) / Jf
    out[IWR] = (Tr - rr * Fxr) / Jr
    vcx_f, vcy_f, vcx_r, vcy_r = _contact(X, delta, P)
    Fxs_f, Fys_f, _, _ = _combined(vcx_f, vcy_f, X[IWF], rf, P[PP_FZF], P)
    Fxs_r, Fys_r, _, _ = _combined(vcx_r, vcy_r, X[IWR], rr, P[PP_FZR], P)
    out[IFXF] = abs(vcx_f) / sx * (Fxs_f - Fxf)
    out[IFXR] = abs(vcx_r) / sx * (Fxs_r - Fxr)
    out[IFYF] = abs(vcx_f) / sy * (Fys_f - Fyf)
    out[IFYR] = abs(vcx_r) / sy * (Fys_r - Fyr)


@njit(cache=True)
def _simulate(X0, U, dt, P, substeps):
    N = U.shape[0]
    n = X0.shape[0]
    Xs = np.empty((N, n))
    x = X0.copy()
    h = dt / substeps
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    for k in range(N):
        Xs[k] = x
        u = U[k]
        for _ in range(substeps):
            _rhs(x, u, P, k1)
            for i in range(n):
                tmp[i] = x[i] + 0.5 * h * k1[i]
            _rhs(tmp, u, P, k2)
            for i in range(n):
                tmp[i] = x[i] + 0.5 * h * k2[i]
            _rhs(tmp, u, P, k3)
            for i in range(n):
                tmp[i] = x[i] + h * k3[i]
            _rhs(tmp, u, P, k4)
            for i in range(n):
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return Xs


# ------------------------------------------------------------------ python API ------------
def rhs(X, u, p: PlanarParams) -> np.ndarray:
    """Time derivative of the state (12,) for input ``u = [delta, T_f, T_r]`` (3,)."""
    out = np.empty(12)
    _rhs(np.asarray(X, dtype=float), np.asarray(u, dtype=float), p.as_array(), out)
    return out


def steady_forces(X, delta, p: PlanarParams) -> np.ndarray:
    """Steady combined-slip forces ``[F_xf^ss, F_xr^ss, F_yf^ss, F_yr^ss]`` [N] and slips
    ``[kappa_f, kappa_r, alpha_f, alpha_r]``, shape (2, 4)."""
    P = p.as_array()
    X = np.asarray(X, dtype=float)
    vcx_f, vcy_f, vcx_r, vcy_r = _contact(X, float(delta), P)
    fxf, fyf, kf, af = _combined(vcx_f, vcy_f, X[IWF], p.r_f, p.Fz_f, P)
    fxr, fyr, kr, ar = _combined(vcx_r, vcy_r, X[IWR], p.r_r, p.Fz_r, P)
    return np.array([[fxf, fxr, fyf, fyr], [kf, kr, af, ar]])


def kinetic_energy(X, p: PlanarParams) -> float:
    """``T = m (v_x^2 + v_y^2)/2 + J_z r^2/2 + J_f omega_f^2/2 + J_r omega_r^2/2`` [J]."""
    X = np.asarray(X, dtype=float)
    return float(0.5 * p.m * (X[IVX] ** 2 + X[IVY] ** 2) + 0.5 * p.J_z * X[IR] ** 2
                 + 0.5 * p.J_f * X[IWF] ** 2 + 0.5 * p.J_r * X[IWR] ** 2)


def power_balance(X, u, p: PlanarParams) -> float:
    """Power of the external actions [W]: drive torques minus tyre slip power,
    ``T_f w_f + T_r w_r - sum_i F_xi (r_i w_i - v_cxi) + sum_i F_yi v_cyi``.
    Must equal ``dT/dt`` along :func:`rhs` (energy check used in the tests)."""
    X = np.asarray(X, dtype=float)
    P = p.as_array()
    delta, Tf, Tr = u
    vcx_f, vcy_f, vcx_r, vcy_r = _contact(X, float(delta), P)
    return float(Tf * X[IWF] + Tr * X[IWR]
                 - X[IFXF] * (p.r_f * X[IWF] - vcx_f) - X[IFXR] * (p.r_r * X[IWR] - vcx_r)
                 + X[IFYF] * vcy_f + X[IFYR] * vcy_r)


def free_rolling_state(vx: float, p: PlanarParams) -> np.ndarray:
    """Straight-line free rolling at speed ``vx``: zero slip, zero forces (an equilibrium of
    every state except the position X)."""
    X = np.zeros(12)
    X[IVX] = vx
    X[IWF] = vx / p.r_f
    X[IWR] = vx / p.r_r
    return X


def simulate(X0, U, dt: float, p: PlanarParams, substeps: int = 1) -> np.ndarray:
    """RK4 simulation with zero-order-hold inputs.

    X0 (12,), U (N, 3) ``[delta, T_f, T_r]`` per sample, ``dt`` [s]. Returns (N, 12): the
    state at the sample instants ``t_k = k dt`` (before applying ``U[k]``).
    """
    U = np.ascontiguousarray(U, dtype=float)
    if U.ndim != 2 or U.shape[1] != 3:
        raise ObserverArgumentError(f"planar.simulate: U must have shape (N, 3) [delta, T_f, "
                                    f"T_r], got {U.shape}")
    if not np.all(np.isfinite(U)):
        k = int(np.argmax(~np.all(np.isfinite(U), axis=1)))
        raise ObserverArgumentError(f"planar.simulate: U row {k} is not finite: {U[k]}")
    X0 = np.asarray(X0, dtype=float)
    if X0.shape != (12,) or not np.all(np.isfinite(X0)):
        raise ObserverArgumentError(f"planar.simulate: X0 must be 12 finite values, got shape "
                                    f"{X0.shape}")
    if not (np.isfinite(dt) and dt > 0):
        raise ObserverArgumentError(f"planar.simulate: dt must be > 0 s, got {dt}")
    if int(substeps) != substeps or substeps < 1:
        raise ObserverArgumentError(f"planar.simulate: substeps must be an integer >= 1, got "
                                    f"{substeps}")
    return _simulate(X0.copy(), U, float(dt), p.as_array(), int(substeps))


def measurements(Xs, noise_std=None, seed: int = 0) -> np.ndarray:
    """Sensors of Rabhi 2004 Part A: measured ``[v_x, v_y, r, omega_f, omega_r]`` (N, 5) [m/s,
    m/s, rad/s, rad/s, rad/s] (states :data:`MEASURED`) of a trajectory ``Xs`` (N, 12), with
    optional white noise of standard deviations ``noise_std`` (5,) drawn from
    ``default_rng(seed)``."""
    Xs = np.asarray(Xs, dtype=float)
    if Xs.ndim != 2 or Xs.shape[1] != 12:
        raise ObserverArgumentError(f"planar.measurements: Xs must be (N, 12) states, got "
                                    f"{Xs.shape}")
    Y = Xs[:, list(MEASURED)].copy()
    if noise_std is not None:
        std = np.asarray(noise_std, dtype=float)
        if std.shape != (5,) or np.any(std < 0) or not np.all(np.isfinite(std)):
            raise ObserverArgumentError(f"planar.measurements: noise_std must be 5 finite "
                                        f"standard deviations >= 0, got {noise_std}")
        rng = np.random.default_rng(seed)
        Y += rng.normal(size=Y.shape) * std
    return Y


@dataclass(frozen=True)
class Manoeuvre:
    """Inputs of the Part A run (Fig. 4 analogue) sampled every ``dt``."""

    t: np.ndarray
    U: np.ndarray  # (N, 3) [delta, T_f, T_r]
    v0: float


def paper_manoeuvre(T: float = 20.0, dt: float = 5e-4, v0: float = 15.0) -> Manoeuvre:
    """Steering + traction + braking run like Rabhi 2004 Fig. 4 (the steering input is
    shown there, not its values; this one is chosen to excite every force):

    * traction torque on the front axle 0 -> 600 N m from 1 s to 6 s (ramped),
    * sinusoidal steering 2.5 deg amplitude, 0.4 Hz, from 3 s to 13 s (smooth window),
    * braking -900 N m front / -450 N m rear from 14 s to 17 s (ramped).

    For ``T < 20`` the schedule is compressed proportionally; for ``T > 20`` the 20 s
    pattern repeats (the speed drops by about 3 m/s per cycle).
    """
    N = int(round(T / dt))
    tt = np.arange(N) * dt
    sc = min(T / 20.0, 1.0)
    t = tt % 20.0 if T > 20 else tt

    def ramp(t0, t1, tr):
        a = np.clip((t - t0 * sc) / (tr * sc), 0, 1)
        b = np.clip((t1 * sc - t) / (tr * sc), 0, 1)
        return np.minimum(a, b)

    w = ramp(3.0, 13.0, 1.0)
    delta = np.radians(2.5) * w * np.sin(2 * np.pi * 0.4 / sc * (t - 3.0 * sc))
    Tf = 600.0 * ramp(1.0, 6.0, 0.5) - 900.0 * ramp(14.0, 17.0, 0.5)
    Tr = -450.0 * ramp(14.0, 17.0, 0.5)
    return Manoeuvre(t=tt, U=np.column_stack([delta, Tf, Tr]), v0=v0)
