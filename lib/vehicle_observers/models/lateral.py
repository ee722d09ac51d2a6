"""Yaw-drift lateral model with tyre relaxation and vision model (Yacine et al. 2015).

States and units (SI throughout):

- physical state of S1, eq. (8): ``[v_y (m/s), r = psi_dot (rad/s), F_f (N), F_r (N)]``
- transformed state, eq. (12): ``x = [v_y, r, (F_f+F_r)/m (m/s^2), (a_f F_f - a_r F_r)/I_z (rad/s^2)]``
- S2 (vision), eq. (9): ``[psi_L (rad), y_L (m)]`` at look-ahead ``l_s``
- inputs: road-wheel steering ``delta_f`` (rad), speed ``v_x`` (m/s), curvature ``rho`` (1/m)

Arrays: trajectories are (N, n) with one row per sample; inputs (N,).

Vectorised numpy right-hand sides are used for exactness checks; the ``simulate_*``
functions are numba-compiled fixed-step RK4 loops with zero-order-hold inputs (one call
handles a whole log; ``substeps`` RK4 steps per input sample keep ``v_x dt / r`` small
because the relaxation dynamics are stiff: ``v_x / r`` reaches 170 1/s for the paper's
``r = 0.1 m`` and ``v_x = 17 m/s``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.models.tires import (
    LinearTire,
    Pacejka,
    magic_formula,
    magic_formula_secant,
)
from vehicle_observers.models.ts import Premise, SectorTS

# ------------------------------------------------------------------ packed parameters -----
#: Index of each constant in :meth:`LateralParams.as_array`, the float vector every compiled
#: kernel of the lateral family reads (``P[M]`` is the mass, ``P[TF_B]`` the front tyre's B).
M, I_Z, A_F, A_R, R_F, R_R, L_S = range(7)
#: front-axle tyre ``(B, C, D, E)`` (``C = 0`` encodes a linear tyre of slope ``B`` [N/rad])
TF_B, TF_C, TF_D, TF_E = range(7, 11)
#: rear-axle tyre, same encoding
TR_B, TR_C, TR_D, TR_E = range(11, 15)
#: length of the packed vector
N_PARAMS = 15
#: order of the premises ``z = (f_r, f_f, v_x)`` of the TS model (24) (:func:`yacine_ts`,
#: :func:`ts_premises`): rear and front secant stiffness (16) [N/rad], speed [m/s]
Z_FR, Z_FF, Z_VX = range(3)


@dataclass(frozen=True)
class LateralParams:
    """Vehicle constants of the yaw-drift model (Yacine 2015 Table I symbols).

    m [kg], I_z [kg m^2], a_f / a_r [m] CG to front / rear axle, r_f / r_r [m] relaxation
    lengths, l_s [m] vision look-ahead, tire_f / tire_r per-axle Pacejka tyres.
    """

    m: float
    I_z: float
    a_f: float
    a_r: float
    tire_f: Pacejka
    tire_r: Pacejka
    r_f: float = 0.1
    r_r: float = 0.1
    l_s: float = 0.5
    name: str = field(default="vehicle", compare=False)
    #: speed gain ``k_s`` [s/m] of both axles' cornering stiffness, ``C(v_x) = C (1 + k_s
    #: v_x)`` (the tyre curves' ``B`` scaled, the peaks kept; 0: speed-independent). Read by
    #: the Kalman filters of :mod:`vehicle_observers.baselines.kalman`.
    stiffness_speed: float = 0.0

    def __post_init__(self):
        """Refuse constants no car has, naming them (a negative mass would otherwise reach
        the LMI solver and come back as "infeasible"): ``m``, ``I_z``, ``a_f``, ``a_r``
        finite and > 0; ``r_f``, ``r_r``, ``l_s`` finite and >= 0."""
        for k in ("m", "I_z", "a_f", "a_r", "r_f", "r_r", "l_s"):
            v = getattr(self, k)
            ok = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) \
                and np.isfinite(v) and (v > 0 if k in ("m", "I_z", "a_f", "a_r") else v >= 0)
            if not ok:
                raise ObserverArgumentError(
                    f"LateralParams.{k} must be a finite number "
                    f"{'> 0' if k in ('m', 'I_z', 'a_f', 'a_r') else '>= 0'} (SI units), "
                    f"got {v!r}")
        v = self.stiffness_speed
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
                or not np.isfinite(v) or abs(v) > 0.1:
            raise ObserverArgumentError(f"LateralParams.stiffness_speed must be a finite number "
                                        f"in [-0.1, 0.1] s/m, got {v!r}")

    def as_array(self) -> np.ndarray:
        """Packed float vector (:data:`N_PARAMS`,) for the numba kernels, laid out by the index
        constants :data:`M`, :data:`I_Z`, :data:`A_F`, :data:`A_R`, :data:`R_F`,
        :data:`R_R`, :data:`L_S`, :data:`TF_B` ... :data:`TF_E`, :data:`TR_B` ...
        :data:`TR_E` of this module."""
        P = np.empty(N_PARAMS)
        P[M], P[I_Z], P[A_F], P[A_R] = self.m, self.I_z, self.a_f, self.a_r
        P[R_F], P[R_R], P[L_S] = self.r_f, self.r_r, self.l_s
        P[TF_B], P[TF_C], P[TF_D], P[TF_E] = _tire_coeffs(self.tire_f)
        P[TR_B], P[TR_C], P[TR_D], P[TR_E] = _tire_coeffs(self.tire_r)
        return P


def _tire_coeffs(t) -> tuple[float, float, float, float]:
    """(B, C, D, E) for the kernels; a linear tyre is encoded as C = 0 with slope B."""
    if isinstance(t, LinearTire):
        return (t.C_alpha, 0.0, 0.0, 0.0)
    return (t.B, t.C, t.D, t.E)


# ------------------------------------------------------------------ numpy (vectorised) ----
def slip_angles(vy, r, delta, vx, p: LateralParams, exact: bool = True):
    """Front/rear slip angles [rad].

    exact=True: Yacine 2015 eq. (3), ``alpha_f = delta - beta - atan(a_f r cos(beta)/v_x)``,
    ``alpha_r = -beta + atan(a_r r cos(beta)/v_x)``, ``beta = atan(v_y/v_x)``.
    exact=False: the small-angle form (4), ``alpha_f = delta - (v_y + a_f r)/v_x``.
    """
    vy, r, delta, vx = (np.asarray(a, dtype=float) for a in (vy, r, delta, vx))
    if exact:
        beta = np.arctan2(vy, vx)
        af = delta - beta - np.arctan(p.a_f * r * np.cos(beta) / vx)
        ar = -beta + np.arctan(p.a_r * r * np.cos(beta) / vx)
    else:
        af = delta - vy / vx - p.a_f * r / vx
        ar = -vy / vx + p.a_r * r / vx
    return af, ar


def rhs_s1(X, delta, vx, p: LateralParams, exact: bool = True):
    """S1 with relaxation, eq. (8). X (N, 4) = [v_y, r, F_f, F_r] -> dX/dt (N, 4)."""
    X = np.atleast_2d(X)
    vy, r, Ff, Fr = X.T
    af, ar = slip_angles(vy, r, delta, vx, p, exact)
    FfS, FrS = p.tire_f.force(af), p.tire_r.force(ar)
    return np.column_stack([
        (Ff + Fr) / p.m - vx * r,
        (p.a_f * Ff - p.a_r * Fr) / p.I_z,
        vx / p.r_f * (FfS - Ff),
        vx / p.r_r * (FrS - Fr),
    ])


def rhs_no_relaxation(X, delta, vx, p: LateralParams, exact: bool = True):
    """Eq. (1) with steady Pacejka forces (2)-(3). X (N, 2) = [v_y, r]."""
    X = np.atleast_2d(X)
    vy, r = X.T
    af, ar = slip_angles(vy, r, delta, vx, p, exact)
    Ff, Fr = p.tire_f.force(af), p.tire_r.force(ar)
    return np.column_stack([(Ff + Fr) / p.m - vx * r, (p.a_f * Ff - p.a_r * Fr) / p.I_z])


def rhs_s2(S, vy, r, vx, rho, p: LateralParams):
    """Vision model S2, eq. (9). S (N, 2) = [psi_L, y_L]."""
    S = np.atleast_2d(S)
    psiL = S[:, 0]
    return np.column_stack([r - vx * rho, vy + vx * psiL + p.l_s * (r - vx * rho)])


def to_transformed(X, p: LateralParams):
    """Eq. (12): physical [v_y, r, F_f, F_r] (N, 4) -> transformed x (N, 4)."""
    X = np.atleast_2d(X)
    vy, r, Ff, Fr = X.T
    return np.column_stack([vy, r, (Ff + Fr) / p.m, (p.a_f * Ff - p.a_r * Fr) / p.I_z])


def forces_from_transformed(x3, x4, p: LateralParams):
    """Eq. (46): ``F_f = (m a_r x3 + I_z x4)/(a_f+a_r)``, ``F_r = (m a_f x3 - I_z x4)/(a_f+a_r)``."""
    L = p.a_f + p.a_r
    x3, x4 = np.asarray(x3), np.asarray(x4)
    return (p.m * p.a_r * x3 + p.I_z * x4) / L, (p.m * p.a_f * x3 - p.I_z * x4) / L


def _require_equal_relaxation(p: LateralParams):
    if p.r_f != p.r_r:
        raise ValueError(f"the transformed model (13) assumes r_f = r_r, got r_f={p.r_f}, "
                         f"r_r={p.r_r}")


def rhs_transformed(x, delta, vx, p: LateralParams):
    """Eq. (13), transformed coordinates, slip angles (4), Pacejka steady forces (7)."""
    _require_equal_relaxation(p)
    x = np.atleast_2d(x)
    x1, x2, x3, x4 = x.T
    r = p.r_f
    af, ar = slip_angles(x1, x2, delta, vx, p, exact=False)
    FfS, FrS = p.tire_f.force(af), p.tire_r.force(ar)
    return np.column_stack([
        -vx * x2 + x3,
        x4,
        -vx / r * x3 + vx / (p.m * r) * (FfS + FrS),
        -vx / r * x4 + vx / (p.I_z * r) * (p.a_f * FfS - p.a_r * FrS),
    ])


def ts_matrices(z, p: LateralParams):
    """``A(z), B(z)`` of eqs. (19)-(24) at premises ``z = (f_r, f_f, v_x)``.

    ``f_f = F_f^S/alpha_f`` and ``f_r = F_r^S/alpha_r`` are the secant stiffnesses (16)
    [N/rad]. Multi-affine in z (B has the product ``v_x f_f``), so the 8-vertex TS form is
    exact. A (4, 4), B (4, 1).
    """
    fr, ff, vx = z
    m, Iz, af, ar, r = p.m, p.I_z, p.a_f, p.a_r, p.r_f
    A = np.array([
        [0.0, -vx, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
        [-(ff + fr) / (m * r), -(af * ff - ar * fr) / (m * r), -vx / r, 0.0],
        [-(af * ff - ar * fr) / (Iz * r), -(af**2 * ff + ar**2 * fr) / (Iz * r), 0.0, -vx / r],
    ])
    B = np.array([[0.0], [0.0], [vx * ff / (m * r)], [af * vx * ff / (Iz * r)]])
    return A, B


def ts_premises(x, u, vx, p: LateralParams):
    """Premises ``(f_r(alpha_r), f_f(alpha_f), v_x)`` along (N, 4) states and (N, 1) steering."""
    x = np.atleast_2d(x)
    af, ar = slip_angles(x[:, 0], x[:, 1], np.ravel(u), vx, p, exact=False)
    vx = np.broadcast_to(np.asarray(vx, dtype=float), af.shape)
    return np.column_stack([p.tire_r.secant_stiffness(ar), p.tire_f.secant_stiffness(af), vx])


def yacine_ts(p: LateralParams, Mf: tuple[float, float], Mr: tuple[float, float],
              vx_bounds: tuple[float, float]) -> SectorTS:
    """The 8-submodel exact TS model (24) of the transformed system (13).

    ``Mf = (M_f2, M_f1)`` = (min, max) front secant stiffness [N/rad], likewise ``Mr``;
    ``vx_bounds = (v_x^min, v_x^max)`` [m/s]. Premise order ``(f_r, f_f, v_x)`` gives the
    paper's ordering (22) for the first four rules at ``v_x^max``.
    """
    _require_equal_relaxation(p)
    prem = [Premise("f_r (rear secant stiffness)", Mr[0], Mr[1], "N/rad"),
            Premise("f_f (front secant stiffness)", Mf[0], Mf[1], "N/rad"),
            Premise("v_x", vx_bounds[0], vx_bounds[1], "m/s")]
    return SectorTS(prem, lambda z: ts_matrices(z, p),
                    premise_fn=lambda x, u, vx: ts_premises(x, u, vx, p),
                    name=f"Yacine 2015 TS model ({p.name})")


# ------------------------------------------------------------------ numba kernels ---------
@njit(cache=True)
def s1_rhs(X, delta, vx, P, exact, relax, out):
    """Compiled right-hand side of S1 (8) (``relax=False``: model (1), forces steady) at the
    state ``X = [v_y, r, F_f, F_r]`` (the forces are read only with relaxation), steering
    ``delta`` [rad], speed ``vx`` [m/s], packed constants ``P`` (:meth:`LateralParams.as_array`);
    slip angles exact (3) or small-angle (4), Pacejka forces (7). Writes ``out`` (4,)."""
    m, Iz, af, ar, rf, rr = P[M], P[I_Z], P[A_F], P[A_R], P[R_F], P[R_R]
    vy, r = X[0], X[1]
    if exact:
        beta = np.arctan2(vy, vx)
        a_f = delta - beta - np.arctan(af * r * np.cos(beta) / vx)
        a_r = -beta + np.arctan(ar * r * np.cos(beta) / vx)
    else:
        a_f = delta - vy / vx - af * r / vx
        a_r = -vy / vx + ar * r / vx
    FfS = magic_formula(a_f, P[TF_B], P[TF_C], P[TF_D], P[TF_E])
    FrS = magic_formula(a_r, P[TR_B], P[TR_C], P[TR_D], P[TR_E])
    if relax:
        Ff, Fr = X[2], X[3]
        out[2] = vx / rf * (FfS - Ff)
        out[3] = vx / rr * (FrS - Fr)
    else:
        Ff, Fr = FfS, FrS
        out[2] = 0.0
        out[3] = 0.0
    out[0] = (Ff + Fr) / m - vx * r
    out[1] = (af * Ff - ar * Fr) / Iz


@njit(cache=True)
def _simulate_s1(X0, delta, vx, dt, substeps, P, exact, relax):
    N = delta.shape[0]
    X = np.empty((N, 4))
    x = X0.copy()
    h = dt / substeps
    k1 = np.empty(4)
    k2 = np.empty(4)
    k3 = np.empty(4)
    k4 = np.empty(4)
    tmp = np.empty(4)
    for k in range(N):
        X[k] = x
        for _ in range(substeps):
            s1_rhs(x, delta[k], vx[k], P, exact, relax, k1)
            for i in range(4):
                tmp[i] = x[i] + 0.5 * h * k1[i]
            s1_rhs(tmp, delta[k], vx[k], P, exact, relax, k2)
            for i in range(4):
                tmp[i] = x[i] + 0.5 * h * k2[i]
            s1_rhs(tmp, delta[k], vx[k], P, exact, relax, k3)
            for i in range(4):
                tmp[i] = x[i] + h * k3[i]
            s1_rhs(tmp, delta[k], vx[k], P, exact, relax, k4)
            for i in range(4):
                x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return X


def _check_inputs(delta, vx, dt, substeps):
    delta = np.ascontiguousarray(delta, dtype=float)
    vx = np.ascontiguousarray(np.broadcast_to(vx, delta.shape), dtype=float)
    if not (np.all(np.isfinite(delta)) and np.all(np.isfinite(vx))):
        raise ObserverArgumentError("steering and speed must be finite")
    if np.any(vx <= 0):
        k = int(np.argmax(vx <= 0))
        raise ObserverArgumentError(f"v_x must be > 0 (the model divides by it): v_x[{k}] = "
                                    f"{vx[k]}")
    if not (np.ndim(dt) == 0 and np.isfinite(dt) and dt > 0) or int(substeps) < 1:
        raise ObserverArgumentError(f"need a finite dt > 0 and substeps >= 1, got dt={dt}, "
                                    f"substeps={substeps}")
    return delta, vx


def simulate_s1(X0, delta, vx, dt, p: LateralParams, exact=True, relaxation=True,
                substeps=10):
    """Simulate S1 (8) (``relaxation=False``: model (1) with steady forces).

    X0 (4,) or (2,) initial ``[v_y, r(, F_f, F_r)]``; delta, vx (N,) sampled every ``dt`` s
    and held constant over each interval. Returns (N, 4) ``[v_y, r, F_f, F_r]`` at the
    sample instants (forces are the steady Pacejka forces when ``relaxation=False``).
    """
    delta, vx = _check_inputs(delta, vx, dt, substeps)
    x0 = np.zeros(4)
    x0[: len(X0)] = X0
    P = p.as_array()
    X = _simulate_s1(x0, delta, vx, float(dt), int(substeps), P, bool(exact), bool(relaxation))
    if not relaxation:
        af, ar = slip_angles(X[:, 0], X[:, 1], delta, vx, p, exact)
        X[:, 2], X[:, 3] = p.tire_f.force(af), p.tire_r.force(ar)
    return X


@njit(cache=True)
def ts_weights(z, zmin, zmax, h):
    """Memberships (22) of the multi-affine TS form at premises ``z`` (p,) inside
    ``[zmin, zmax]``: ``h_i = prod_j w_j^{bit}``, ``w_j = (z_j - zmin_j)/(zmax_j - zmin_j)``,
    vertex ``i``'s bit ``j`` (most significant first) 0 taking ``w_j`` (the upper bound),
    1 taking ``1 - w_j`` (:func:`vehicle_observers.models.ts.memberships` order). Writes
    ``h`` (2^p,)."""
    p = z.shape[0]
    nv = h.shape[0]
    for i in range(nv):
        w = 1.0
        for j in range(p):
            bit = (i >> (p - 1 - j)) & 1
            w0 = (z[j] - zmin[j]) / (zmax[j] - zmin[j])
            w *= w0 if bit == 0 else 1.0 - w0
        h[i] = w


@njit(cache=True)
def _ts_rhs(x, delta, vx, P, Av, Bv, zmin, zmax, h, z, out):
    af, ar = P[A_F], P[A_R]
    a_f = delta - x[0] / vx - af * x[1] / vx
    a_r = -x[0] / vx + ar * x[1] / vx
    z[Z_FR] = magic_formula_secant(a_r, P[TR_B], P[TR_C], P[TR_D], P[TR_E])
    z[Z_FF] = magic_formula_secant(a_f, P[TF_B], P[TF_C], P[TF_D], P[TF_E])
    z[Z_VX] = vx
    out_of_bounds = False
    for j in range(3):
        if z[j] < zmin[j] - 1e-9 * (zmax[j] - zmin[j]) or z[j] > zmax[j] + 1e-9 * (
                zmax[j] - zmin[j]):
            out_of_bounds = True
    ts_weights(z, zmin, zmax, h)
    n = x.shape[0]
    for i in range(n):
        out[i] = 0.0
    for v in range(h.shape[0]):
        for i in range(n):
            s = Bv[v, i, 0] * delta
            for j in range(n):
                s += Av[v, i, j] * x[j]
            out[i] += h[v] * s
    return out_of_bounds


@njit(cache=True)
def _simulate_ts(x0, delta, vx, dt, substeps, P, Av, Bv, zmin, zmax):
    N = delta.shape[0]
    n = x0.shape[0]
    X = np.empty((N, n))
    oob = np.zeros(N, dtype=np.bool_)
    x = x0.copy()
    hstep = dt / substeps
    h = np.empty(Av.shape[0])
    z = np.empty(3)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    for k in range(N):
        X[k] = x
        for _ in range(substeps):
            b1 = _ts_rhs(x, delta[k], vx[k], P, Av, Bv, zmin, zmax, h, z, k1)
            for i in range(n):
                tmp[i] = x[i] + 0.5 * hstep * k1[i]
            b2 = _ts_rhs(tmp, delta[k], vx[k], P, Av, Bv, zmin, zmax, h, z, k2)
            for i in range(n):
                tmp[i] = x[i] + 0.5 * hstep * k2[i]
            b3 = _ts_rhs(tmp, delta[k], vx[k], P, Av, Bv, zmin, zmax, h, z, k3)
            for i in range(n):
                tmp[i] = x[i] + hstep * k3[i]
            b4 = _ts_rhs(tmp, delta[k], vx[k], P, Av, Bv, zmin, zmax, h, z, k4)
            if b1 or b2 or b3 or b4:
                oob[k] = True
            for i in range(n):
                x[i] += hstep / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return X, oob


def simulate_ts(ts: SectorTS, x0, delta, vx, dt, p: LateralParams, substeps=10):
    """Simulate the TS form (24) itself: ``x' = sum h_i(z(x)) (A_i x + B_i delta)``.

    Returns ``(X, out_of_bounds)``: X (N, 4) in transformed coordinates (12) and a boolean
    (N,) flag of samples whose premises left the sector (where the TS form is not exact).
    """
    delta, vx = _check_inputs(delta, vx, dt, substeps)
    return _simulate_ts(np.asarray(x0, dtype=float), delta, vx, float(dt), int(substeps),
                        p.as_array(), ts.A, ts.B, ts.zmin, ts.zmax)
