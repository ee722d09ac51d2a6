"""Yacine 2015 estimation chain: curvature (11), premise estimate (26)-(28), LMI Theorem 1
(33) and its certificate, TS observer (31) and force recovery (46).

Reference: Z. Yacine, D. Ichalal, N. Ait-Oufroukh, S. Mammar, S. Djennoune, "Takagi-Sugeno
observers: experimental application for vehicle lateral dynamics estimation", IEEE TCST
23(2):754-761, 2015 (text: ``shared/papers/000_9b02bf71cd4b2069.txt``).

Chain (units SI, arrays (N,) unless stated):

1. ``y_L, psi_L`` (vision) -> third-order Levant differentiators -> ``dy_L, dpsi_L``
   (:mod:`vehicle_observers.observers.differentiators`).
2. Road curvature (11): ``rho_hat = (psi_dot - dpsi_L) / v_x`` [1/m].
3. Premise estimate (26): ``v_ye = dy_L - v_x psi_L - l_s dpsi_L`` [m/s]; premise vector
   (28) ``s_e = (v_x, psi_dot, psi_L, dy_Le, dpsi_Le, delta_f)`` (N, 6).
4. TS premises of (24) from ``s_e``: slip angles (4) with ``v_ye`` and the measured yaw rate,
   secant stiffnesses ``f_f(alpha_f), f_r(alpha_r)`` (16) and ``v_x``; memberships
   ``h_i(s_e)`` (the product form (22) extended with ``v_x``), premises *clipped* to the
   sector (an estimate or a true state outside it cannot be represented; the fraction of
   clipped samples is returned).
5. Observer (31): ``xhat' = sum_i h_i(s_e) (A_i xhat + B_i delta + L_i (psi_dot - C xhat))``,
   ``C = (0 1 0 0)``, ``xhat(0) = 0`` (paper), integrated by RK4 with the inputs held over
   each sample (numba loop).
6. Forces (46): ``F_f = (m a_r x3 + I_z x4)/(a_f + a_r)``, ``F_r = (m a_f x3 - I_z x4)/(a_f + a_r)``.

LMI Theorem 1 (33), solved with cvxpy + Clarabel through :class:`~vehicle_observers.design.lmi.LMIDesign`:
for the 8 vertices,
``[[A_i^T P + P A_i - M_i C - C^T M_i^T + alpha P, P Gamma], [Gamma^T P, -c I_2]] < 0``,
``P > 0``, ``c > 0``, ``L_i = P^{-1} M_i``, ``Gamma = [0 0 1 0; 0 0 0 1]^T``.

Conditioning (what is done and why): the entries of ``A_i`` range from 1 to ~600 and the
states have different units (m/s, rad/s, m/s^2, rad/s^2). The LMIs are solved for the scaled
state ``x~ = S^-1 x`` with ``S = diag(1, 1, 10, 10)`` (the order of magnitude of each state
on the emulated lap), which is a congruence of (33) with ``diag(S, I_2)``: feasibility and
``c`` are unchanged, ``P = S^-1 P~ S^-1``, ``L_i = S L~_i``. The homogeneity of (33) in
``(P, M_i, c)`` is removed by ``P~ >= I`` (feasibility unchanged). Two constraints are
*added to the paper's conditions* by default: ``P~ <= p_max I`` (1e3) bounds the eigenvalue
spread of ``P~`` (it enters the bound (34) through ``alpha_2/alpha_1``; it is what makes the
design infeasible from alpha = 1 on, while (33) alone stays certified up to alpha = 1 and
sign-feasible but only inconclusive (``Certificate.status``) from alpha = 2 to 10), and a
disk LMI region ``|lambda| < R`` (R = 600 1/s; Chilali-Gahinet, same
``P``) on every vertex ``A_i - L_i C`` keeps the observer poles implementable at the paper's
1 kHz (RK4 needs ``|lambda| dt`` well below 2.8). The objective minimises ``c`` (it scales
the transient term of (34)). The solution is certified twice: the builders re-evaluated with
the numeric ``P~, M~_i, c`` (LMIDesign), and (33) rebuilt independently in the original
coordinates from ``A_i``, ``P`` and ``L_i`` (:func:`certify_original`).

Observer class: :class:`TSPremiseObserver` (the contract of
:mod:`vehicle_observers.core.protocol`; readable step :func:`observer_step`, compiled loop
:func:`_observer`); :func:`run_observer` runs it on a drive log with the vision chain. The
error bound (34) and the premise mismatch (30) of the paper's Theorem 1 are checked in
:mod:`vehicle_observers_papers.yacine_2015.theorem1`.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
from numba import njit

from vehicle_observers.core.errors import CertificationError, InfeasibleDesign, ObserverArgumentError
from vehicle_observers.core.protocol import ObserverBase, Trajectory, check_sample_period
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.design.constraints import InputToState, InRegion
from vehicle_observers.design.lmi import Certificate, LMISolution, bmat, check_matrix, disk
from vehicle_observers.design.synthesis import ObserverSynthesis
from vehicle_observers.design.system import PolytopicSystem
from vehicle_observers.models.lateral import (
    A_F,
    A_R,
    TF_B,
    TF_C,
    TF_D,
    TF_E,
    TR_B,
    TR_C,
    TR_D,
    TR_E,
    Z_FF,
    Z_FR,
    Z_VX,
    LateralParams,
    forces_from_transformed,
    ts_weights,
)
from vehicle_observers.models.tires import magic_formula_secant
from vehicle_observers.models.ts import SectorTS, memberships
from vehicle_observers.models.vehicle import load_vehicle
from vehicle_observers.observers.differentiators import levant_differentiator

C_OUT = np.array([[0.0, 1.0, 0.0, 0.0]])                           # y = psi_dot
GAMMA = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])  # eq. (29)

#: default state scaling for the LMI (m/s, rad/s, m/s^2, rad/s^2)
STATE_SCALE = (1.0, 1.0, 10.0, 10.0)
#: default Levant bounds |f^(4)| for the vision signals (chosen on the noise-free lap)
L_YL = 50.0     # m/s^4
L_PSIL = 5.0    # rad/s^4
#: speed floor [m/s] in the curvature formula (11) (the formula is singular at v_x = 0)
VX_FLOOR = 0.5
#: largest relative spread of the sample period the fixed-step observer accepts
DT_RTOL = 1e-3
#: the transformed state (12) in schema names: ``v_y`` [m/s], ``r`` [rad/s],
#: ``x3 = (F_f + F_r)/m`` [m/s^2], ``x4 = (a_f F_f - a_r F_r)/I_z`` [rad/s^2]
STATE_NAMES = ("vy_mps", "yaw_rate_radps", "x3_mps2", "x4_radps2")


def _params(params):
    """``params`` or, by default, the paper's car: the shipped vehicle file ``yacine2015``
    (equal to ``vehicle_observers_papers.yacine_2015.constants.params``; a test checks it)."""
    if params is not None:
        return params
    return load_vehicle("yacine2015").params


# ================================================================ premise estimation ======
@dataclass
class PremiseEstimate:
    """Outputs of the vision chain, arrays (N,). ``s_e`` is (N, 6) in the order of (28)."""

    dyL: np.ndarray
    dpsiL: np.ndarray
    vy: np.ndarray
    rho: np.ndarray
    s_e: np.ndarray
    Zy: np.ndarray = field(repr=False)
    Zpsi: np.ndarray = field(repr=False)


def curvature(yaw_rate, vx, dpsiL, vx_floor: float = VX_FLOOR):
    """Road curvature, Yacine 2015 eq. (11): ``(psi_dot - dpsi_L) / max(v_x, vx_floor)`` [1/m].

    The formula divides by ``v_x``; below ``vx_floor`` the speed is floored (the estimate
    there is meaningless and should be masked by the caller).
    """
    vx = np.asarray(vx, dtype=float)
    return (np.asarray(yaw_rate, dtype=float) - np.asarray(dpsiL, dtype=float)) / np.maximum(
        vx, vx_floor)


def vy_from_vision(vx, psiL, dyL, dpsiL, l_s: float):
    """Lateral velocity from the vision model, eq. (26): ``dy_L - v_x psi_L - l_s dpsi_L``."""
    return (np.asarray(dyL, dtype=float) - np.asarray(vx, dtype=float) * np.asarray(psiL)
            - l_s * np.asarray(dpsiL, dtype=float))


def estimate_premises(log: DriveLog, L_y: float = L_YL, L_psi: float = L_PSIL, order: int = 3,
                      params: LateralParams | None = None,
                      vx_floor: float = VX_FLOOR) -> PremiseEstimate:
    """Differentiate the vision outputs (HOSMD, order 3 as in the paper), then (11), (26), (28).

    ``L_y`` [m/s^4], ``L_psi`` [rad/s^4]: Levant's bounds on ``|y_L^(4)|, |psi_L^(4)|``.
    """
    p = _params(params)
    log.require("yL_m", "psiL_rad", purpose="premise estimation (26)")
    dt = log.dt
    d = np.diff(log.t)
    if np.max(np.abs(d - dt)) > 1e-6 * dt:
        k = int(np.argmax(np.abs(d - dt)))
        raise ValueError(f"{log.source}: the discrete differentiator needs uniform sampling; "
                         f"step {k} is {d[k]:.6g} s, median {dt:.6g} s")
    Zy = levant_differentiator(log.yL, dt, order=order, L=L_y)
    Zp = levant_differentiator(log.psiL, dt, order=order, L=L_psi)
    dyL, dpsiL = Zy[:, 1], Zp[:, 1]
    vy = vy_from_vision(log.vx, log.psiL, dyL, dpsiL, p.l_s)
    rho = curvature(log.yaw_rate, log.vx, dpsiL, vx_floor)
    s_e = np.column_stack([log.vx, log.yaw_rate, log.psiL, dyL, dpsiL, log.delta])
    return PremiseEstimate(dyL, dpsiL, vy, rho, s_e, Zy, Zp)


def ts_premises(vy, yaw_rate, delta, vx, params: LateralParams | None = None):
    """TS premises ``z = (f_r(alpha_r), f_f(alpha_f), v_x)`` (N, 3) from slip angles (4)."""
    p = _params(params)
    vx = np.asarray(vx, dtype=float)
    af = np.asarray(delta) - np.asarray(vy) / vx - p.a_f * np.asarray(yaw_rate) / vx
    ar = -np.asarray(vy) / vx + p.a_r * np.asarray(yaw_rate) / vx
    return np.column_stack([p.tire_r.secant_stiffness(ar), p.tire_f.secant_stiffness(af), vx])


# ================================================================ LMI Theorem 1 ===========
@dataclass
class Theorem1Design:
    """Certified solution of Theorem 1 (33) in original coordinates (Yacine 2015).

    Theorem 1's own result: the solution of the synthesis layer's call
    (:func:`theorem1_synthesis`) mapped back from the scaled state, with ``c``, ``alpha``, the
    scaling and the certificate of (33) in original coordinates. A general design of the
    layer is :class:`vehicle_observers.design.synthesis.ObserverDesign`.

    P (4, 4); L (8, 4, 1) gains ``L_i = P^-1 M_i``; c, alpha scalars; ``alpha1, alpha2`` =
    extreme eigenvalues of P; ``certificate`` of the scaled LMIs (LMIDesign) and
    ``certificate_original`` of (33) rebuilt in original coordinates.
    """

    P: np.ndarray
    L: np.ndarray
    c: float
    alpha: float
    ts: SectorTS
    scale: np.ndarray
    solution: LMISolution
    certificate_original: Certificate
    disk_radius: float | None
    solve_time: float
    p_max: float | None = 1e3

    @property
    def certificate(self) -> Certificate:
        """The LMI certificate of the observer: (33) rebuilt in original coordinates from
        ``A_i``, ``P``, ``L_i`` and checked by eigenvalues (independent of the solver; the
        scaled problem's own certificate, added constraints included, is
        ``solution.certificate``)."""
        return self.certificate_original

    def added_constraints(self) -> list[str]:
        """The constraints solved *in addition to* (33) and ``P > 0`` (scaled coordinates
        ``P~ = S P S``): the normalisation ``P~ >= I`` (removes the homogeneity of (33), does
        not change feasibility), the conditioning bound ``P~ <= p_max I`` and the disk region
        ``|lambda(A_i - L_i C)| < R`` when they were used."""
        out = ["P~ >= I (normalisation; feasibility unchanged)"]
        if self.p_max is not None:
            out.append(f"P~ <= {self.p_max:g} I (conditioning bound)")
        if self.disk_radius is not None:
            out.append(f"|lambda(A_i - L_i C)| < {self.disk_radius:g} 1/s (disk region)")
        return out

    @property
    def alpha1(self) -> float:
        return float(np.linalg.eigvalsh(self.P)[0])

    @property
    def alpha2(self) -> float:
        return float(np.linalg.eigvalsh(self.P)[-1])

    def margins(self) -> dict:
        """Worst absolute/relative margins of (33) (scaled and original) and of P > 0."""
        cs, co = self.solution.certificate, self.certificate_original
        xi_s = [c for c in cs.checks if c.name.startswith("Xi")]
        xi_o = [c for c in co.checks if c.name.startswith("Xi")]
        return {"xi_scaled_min_margin": min(c.margin for c in xi_s),
                "xi_scaled_min_relative": min(c.relative for c in xi_s),
                "xi_original_min_margin": min(c.margin for c in xi_o),
                "xi_original_min_relative": min(c.relative for c in xi_o),
                "P_min_eig": self.alpha1, "P_max_eig": self.alpha2,
                "P_condition": self.alpha2 / self.alpha1,
                "max_pole_modulus": float(max(np.abs(np.linalg.eigvals(
                    self.ts.A[i] - self.L[i] @ C_OUT)).max() for i in range(len(self.L)))),
                "max_pole_real": float(max(np.linalg.eigvals(
                    self.ts.A[i] - self.L[i] @ C_OUT).real.max() for i in range(len(self.L))))}


def _xi(A, P, M, c, alpha, C=C_OUT, G=GAMMA):
    """The matrix of (33) (cvxpy or numpy)."""
    X = A.T @ P + P @ A - M @ C - C.T @ M.T + alpha * P
    return bmat([[X, P @ G], [G.T @ P, -c * np.eye(G.shape[1])]])


def certify_original(ts: SectorTS, P, L, c, alpha) -> Certificate:
    """Rebuild (33) in original coordinates from ``A_i``, ``P``, ``M_i = P L_i`` and check it."""
    checks = [check_matrix("P>0", P, "pos"), check_matrix("c>0", np.array([[c]]), "pos")]
    for i in range(ts.n_rules):
        checks.append(check_matrix(f"Xi[{i + 1}]", _xi(ts.A[i], P, P @ L[i], c, alpha), "neg"))
    return Certificate(checks)


def design_theorem1(ts: SectorTS, alpha: float = 1e-3,
                    scale=STATE_SCALE, disk_radius: float | None = 600.0,
                    p_max: float | None = 1e3, eps: float = 1e-2) -> Theorem1Design:
    """Solve Theorem 1 (33) for the 8-rule TS model (24) ``ts`` (the paper's bounds:
    ``vehicle_observers_papers.yacine_2015.constants.ts_model()``).

    Constraints solved, in scaled coordinates (module docstring): (33) for the 8 vertices,
    ``P~ >= I`` (normalisation of the homogeneous (33); feasibility unchanged) and, **added
    to the paper** unless set to ``None``: ``P~ <= p_max I`` (conditioning bound) and the
    disk region ``|lambda(A_i - L_i C)| < disk_radius`` [1/s]. Both added constraints
    restrict (33): an infeasibility with them is not an infeasibility of Theorem 1 (for the
    paper's bounds (33) alone is certified up to alpha = 1, sign-feasible but inconclusive
    from alpha = 2 to 10; ``p_max`` is what fails first as alpha grows). Objective ``min c``.
    Raises :class:`InfeasibleDesign` naming the worst vertex and the best achievable largest
    eigenvalue of (33) (found by :func:`diagnose_infeasible`) when there is no solution,
    :class:`CertificationError` if a returned solution fails either certificate, and
    :class:`~vehicle_observers.core.errors.ObserverArgumentError` for a decay rate ``alpha``
    that is not finite and > 0 (with ``alpha <= 0`` (33) certifies no decay: the "design"
    would not be an observer with the bound (34)), a radius, bound or scale <= 0.
    """
    _check_design_args(alpha, scale, disk_radius, p_max)
    nr = ts.n_rules
    S = np.diag(np.asarray(scale, dtype=float))
    Si = np.linalg.inv(S)
    syn = theorem1_synthesis(ts, alpha, scale, disk_radius, p_max, eps)
    t0 = time.perf_counter()
    try:
        sol = syn.solve(objective="c").solution
    except CertificationError:
        raise
    except InfeasibleDesign as exc:
        diag = diagnose_infeasible(ts, alpha, scale, disk_radius, p_max)
        if diag["worst"] is None:
            raise InfeasibleDesign(f"{exc}. Diagnosis: the relaxed problem could not be solved "
                                   f"either (badly scaled or non-finite model data)",
                                   status=exc.status) from exc
        k = int(diag["worst"].split("[")[1].rstrip("]")) - 1
        zv = ", ".join(f"{pr.name.split(' ')[0]}={v:g}" for pr, v in zip(ts.premises,
                                                                         ts.z_vertices[k]))
        raise InfeasibleDesign(
            f"{exc}. Diagnosis: the best common P gives largest eigenvalue "
            f"{diag['t']:+.3e} for {diag['worst']} (vertex {zv}; needs < 0)", lmi=diag["worst"],
            violation=diag["t"], status=exc.status) from exc
    solve_time = time.perf_counter() - t0
    Pt = sol["P"]
    P = Si @ Pt @ Si
    L = np.array([S @ np.linalg.solve(Pt, sol[f"M{i}"]) for i in range(nr)])
    c = float(sol["c"])
    cert_o = certify_original(ts, P, L, c, alpha)
    if not cert_o.ok:
        w = cert_o.worst()
        raise CertificationError(f"Theorem 1: {w.name} fails in original coordinates "
                                 f"(margin {w.margin:.3e})", lmi=w.name, violation=-w.margin)
    return Theorem1Design(P, L, c, alpha, ts, np.diag(S), sol, cert_o, disk_radius,
                          solve_time, p_max)


def theorem1_synthesis(ts: SectorTS, alpha: float = 1e-3, scale=STATE_SCALE,
                       disk_radius: float | None = 600.0, p_max: float | None = 1e3,
                       eps: float = 1e-2) -> ObserverSynthesis:
    """Theorem 1 (33) of Yacine 2015 as a call of the synthesis layer, in the scaled state
    ``x~ = S^-1 x`` (``S = diag(scale)``): the 8 vertices ``A~_i = S^-1 A_i S``, ``C~ = C S``,
    disturbance ``Gamma~ = S^-1 Gamma`` as a
    :class:`~vehicle_observers.design.system.PolytopicSystem`; one gain ``M_i`` per vertex
    (``gains="pdc"``: the observer (31) uses the plant's memberships and ``C`` is common, so the
    LMIs are ``G_ii < 0``); :class:`~vehicle_observers.design.constraints.InputToState` with
    ``alpha`` and a free ``c`` (the matrix of (33), ``Xi[i]``); the disk region
    (``disk[i]``); ``P~ >= I`` and ``P~ <= p_max I``. Objective ``min c``."""
    S = np.diag(np.asarray(scale, dtype=float))
    system = PolytopicSystem(ts.A, C_OUT, E=GAMMA, name="Yacine 2015 (24)").transformed(S)
    cons = [InputToState(alpha, None, label="Xi")]
    if disk_radius is not None:
        cons.append(InRegion(disk(disk_radius), label="disk"))
    return ObserverSynthesis(system, cons, gains="pdc", P_lower=1.0 - eps,
                             P_upper=None if p_max is None else p_max + eps, eps=eps,
                             order="constraint", gain_name="M", lower_name="P>=I",
                             upper_name="P<=pmax I",
                             name=f"Yacine 2015 Theorem 1 (alpha={alpha:g})")


def _check_design_args(alpha, scale, disk_radius, p_max):
    if not (np.ndim(alpha) == 0 and np.isfinite(alpha) and alpha > 0):
        raise ObserverArgumentError(f"design_theorem1: alpha (decay rate of (33)) must be finite "
                                    f"and > 0 [1/s], got {alpha!r}")
    sc = np.asarray(scale, dtype=float)
    if sc.shape != (4,) or not np.all(np.isfinite(sc) & (sc > 0)):
        raise ObserverArgumentError(f"design_theorem1: scale must be 4 finite values > 0, got "
                                    f"{scale!r}")
    for name, v in (("disk_radius", disk_radius), ("p_max", p_max)):
        if v is not None and not (np.isfinite(v) and v > 0):
            raise ObserverArgumentError(f"design_theorem1: {name} must be finite and > 0 (or "
                                        f"None), got {v!r}")


def diagnose_infeasible(ts: SectorTS, alpha: float, scale=STATE_SCALE,
                        disk_radius: float | None = 600.0, p_max: float | None = 1e3) -> dict:
    """Relaxed problem ``min t`` s.t. every LMI of the design ``<= t I`` (same P, M_i, c).

    Returns ``{"t": t*, "worst": name}``: ``t* >= 0`` means infeasible; ``worst`` is the LMI
    (vertex) whose largest eigenvalue attains ``t*`` at the relaxed optimum. When the relaxed
    problem cannot be solved (solver failure, non-finite data or values) it returns
    ``worst=None`` and ``t = nan`` instead of raising.
    """
    nr = ts.n_rules
    unknown = {"t": float("nan"), "worst": None, "largest_eig": float("nan")}
    if not all(np.all(np.isfinite(ts.A[i])) for i in range(nr)):
        return unknown                        # NaN/inf model: nothing to diagnose
    S = np.diag(np.asarray(scale, dtype=float))
    Si = np.linalg.inv(S)
    As = [Si @ ts.A[i] @ S for i in range(nr)]
    Cs, Gs = C_OUT @ S, Si @ GAMMA
    P = cp.Variable((4, 4), symmetric=True)
    M = [cp.Variable((4, 1)) for _ in range(nr)]
    c = cp.Variable(nonneg=True)
    t = cp.Variable()
    cons = [P >> np.eye(4), c <= 1e6]
    if p_max is not None:
        cons.append(P << p_max * np.eye(4))
    mats = {}
    for i in range(nr):
        X = _xi(As[i], P, M[i], c, alpha, Cs, Gs)
        mats[f"Xi[{i + 1}]"] = (X, i, "xi")
        cons.append((X + X.T) / 2 << t * np.eye(6))
        if disk_radius is not None:
            D = disk(disk_radius).lmi(P, P @ As[i] - M[i] @ Cs)
            mats[f"disk[{i + 1}]"] = (D, i, "disk")
            cons.append((D + D.T) / 2 << t * np.eye(8))
    if not all(np.all(np.isfinite(a)) for a in (*As, Cs, Gs)):
        return unknown
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)   # "solution may be inaccurate": a
            cp.Problem(cp.Minimize(t), cons).solve(solver="CLARABEL")   # diagnosis only
    except (cp.error.SolverError, ValueError, ArithmeticError):
        return unknown                        # the relaxed problem itself fails numerically
    worst, wval = None, -np.inf
    for name, (X, _, _) in mats.items():
        if X.value is None or not np.all(np.isfinite(X.value)):
            return unknown
        v = np.linalg.eigvalsh((X.value + X.value.T) / 2)[-1]
        if v > wval:
            worst, wval = name, v
    if t.value is None:
        return unknown
    return {"t": float(t.value), "worst": worst, "largest_eig": float(wval)}


# ================================================================ observer (31) ===========
@njit(cache=True)
def _obs_rhs(x, Ab, Bb, Lb, u, y, out):
    n = x.shape[0]
    innov = y - x[1]
    for i in range(n):
        s = Bb[i] * u + Lb[i] * innov
        for j in range(n):
            s += Ab[i, j] * x[j]
        out[i] = s


@njit(cache=True)
def _observer(y, u, vx, vyp, dt, P, Av, Bv, Lv, zmin, zmax, x0, substeps):
    """Compiled loop of the TS observer (31): the estimate at sample ``k`` is stored, then the
    premises (slip (4) with ``v_ye``, secant stiffnesses (16), ``v_x``) of sample ``k`` are
    clipped to the sector, the memberships frozen, and ``substeps`` RK4 steps of
    ``dt / substeps`` with the inputs of sample ``k`` held give the estimate at ``k + 1``."""
    N = y.shape[0]
    nv = Av.shape[0]
    n = x0.shape[0]
    X = np.empty((N, n))
    Z = np.empty((N, 3))
    clipped = np.zeros((N, 3), dtype=np.bool_)
    x = x0.copy()
    h = np.empty(nv)
    z = np.empty(3)
    Ab = np.empty((n, n))
    Bb = np.empty(n)
    Lb = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    af, ar = P[A_F], P[A_R]
    hs = dt / substeps
    for k in range(N):
        X[k] = x
        v = vx[k]
        r = y[k]
        a_f = u[k] - vyp[k] / v - af * r / v                       # slip (4) with v_ye
        a_r = -vyp[k] / v + ar * r / v
        z[Z_FR] = magic_formula_secant(a_r, P[TR_B], P[TR_C], P[TR_D], P[TR_E])
        z[Z_FF] = magic_formula_secant(a_f, P[TF_B], P[TF_C], P[TF_D], P[TF_E])
        z[Z_VX] = v
        for j in range(3):
            if z[j] < zmin[j]:
                z[j] = zmin[j]
                clipped[k, j] = True
            elif z[j] > zmax[j]:
                z[j] = zmax[j]
                clipped[k, j] = True
            Z[k, j] = z[j]
        ts_weights(z, zmin, zmax, h)                 # memberships (22), ts.memberships order
        for a in range(n):
            Bb[a] = 0.0
            Lb[a] = 0.0
            for b in range(n):
                Ab[a, b] = 0.0
        for i in range(nv):
            for a in range(n):
                Bb[a] += h[i] * Bv[i, a, 0]
                Lb[a] += h[i] * Lv[i, a, 0]
                for b in range(n):
                    Ab[a, b] += h[i] * Av[i, a, b]
        for _ in range(substeps):
            _obs_rhs(x, Ab, Bb, Lb, u[k], r, k1)
            for i in range(n):
                tmp[i] = x[i] + 0.5 * hs * k1[i]
            _obs_rhs(tmp, Ab, Bb, Lb, u[k], r, k2)
            for i in range(n):
                tmp[i] = x[i] + 0.5 * hs * k2[i]
            _obs_rhs(tmp, Ab, Bb, Lb, u[k], r, k3)
            for i in range(n):
                tmp[i] = x[i] + hs * k3[i]
            _obs_rhs(tmp, Ab, Bb, Lb, u[k], r, k4)
            for i in range(n):
                x[i] += hs / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return X, Z, clipped


def observer_step(design: Theorem1Design, x, z, u: float, y: float, dt: float):
    """One RK4 step of the TS observer (31), Yacine 2015:
    ``xhat' = sum_i h_i(s_e) (A_i xhat + B_i u + L_i (y - C xhat))``, ``C xhat = xhat_2``.

    ``x`` (4,) estimate (transformed state (12)); ``z`` (3,) premises ``(f_r, f_f, v_x)``
    already clipped to the sector; ``u`` steering [rad], ``y`` measured yaw rate [rad/s],
    both held over ``dt`` [s]. Returns the estimate after the step.
    """
    ts = design.ts
    h = memberships(np.atleast_2d(z), ts.zmin, ts.zmax)[0]     # h_i(s_e), sum = 1
    A = np.tensordot(h, ts.A, axes=1)                           # sum_i h_i A_i
    B = np.tensordot(h, ts.B, axes=1)[:, 0]
    L = np.tensordot(h, design.L, axes=1)[:, 0]

    def f(xx):
        return A @ xx + B * u + L * (y - xx[1])                 # C xhat = xhat_2

    k1 = f(x)
    k2 = f(x + dt / 2 * k1)
    k3 = f(x + dt / 2 * k2)
    k4 = f(x + dt * k3)
    return x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


@dataclass(frozen=True, eq=False)
class TSRun(Trajectory):
    """A run of the TS observer (31): the :class:`~vehicle_observers.core.protocol.Trajectory`
    of the transformed state (12) ``x`` (N, 4) (:data:`STATE_NAMES`), plus ``Ff``, ``Fr``
    (N,) axle forces [N] by (46), ``z`` (N, 3) premises ``(f_r, f_f, v_x)`` after clipping
    to the sector, ``clipped`` (N, 3) bool (which premise was clipped at which sample) and
    ``premises`` the vision chain's :class:`PremiseEstimate` (or ``None``). ``vy`` is a view
    of ``x``."""

    Ff: np.ndarray | None = None
    Fr: np.ndarray | None = None
    z: np.ndarray | None = None
    clipped: np.ndarray | None = None
    premises: PremiseEstimate | None = None

    @property
    def vy(self) -> np.ndarray:
        return self.x[:, 0]


class TSPremiseObserver(ObserverBase):
    """Yacine 2015 TS observer (31) with estimated premises, on the contract of
    :mod:`vehicle_observers.core.protocol`.

    ``design``: the certified :class:`Theorem1Design` (Theorem 1); ``params``: the car of
    the premises (default the paper's); ``dt`` [s]: the fixed sample period the observer
    integrates with (``run`` checks ``t`` against it, relative :data:`DT_RTOL`);
    ``substeps``: RK4 steps per sample. Inputs ``u = [delta, v_x, v_ye]`` (N, 3): road-wheel
    steering [rad], speed [m/s] (> 0) and the premise lateral velocity (26) [m/s] of the
    vision chain (:func:`estimate_premises`); output ``y = [r]`` (N, 1) the gyro; state
    ``x = z`` the transformed state (12) (:data:`STATE_NAMES`), ``x0`` default 0 (paper).
    Sample ``k`` integrates over ``[t_{k-1}, t_k]`` with the inputs of sample ``k - 1``
    held (premises clipped to the sector, memberships frozen).
    """

    state_names = STATE_NAMES
    input_names = ("delta_roadwheel_rad", "vx_mps", "vy_premise_mps")
    output_names = ("yaw_rate_radps",)

    def __init__(self, design: Theorem1Design, dt: float, params: LateralParams | None = None,
                 substeps: int = 1):
        if not isinstance(design, Theorem1Design):
            raise ObserverArgumentError(f"TSPremiseObserver: design must be a Theorem1Design, "
                                        f"got {type(design).__name__}")
        if not (np.ndim(dt) == 0 and np.isfinite(dt) and dt > 0):
            raise ObserverArgumentError(f"TSPremiseObserver: dt must be finite and > 0 s, got "
                                        f"{dt!r}")
        if int(substeps) != substeps or substeps < 1:
            raise ObserverArgumentError(f"TSPremiseObserver: substeps must be an integer >= 1, "
                                        f"got {substeps!r}")
        self.design = design
        self.params = _params(params)
        self.dt = float(dt)
        self.substeps = int(substeps)

    def check_data(self, t, u, y, x0=None):
        t, u, y, x0 = super().check_data(t, u, y, x0)
        check_sample_period(t, self.dt, "TSPremiseObserver", DT_RTOL)
        if np.any(u[:, 1] <= 0):
            k = int(np.argmax(u[:, 1] <= 0))
            raise ObserverArgumentError(f"TSPremiseObserver: u column 1 (vx_mps) must be > 0 "
                                        f"(slip (4) divides by it): row {k} has {u[k, 1]}")
        return t, u, y, x0

    def initial_state(self, t, u, y, x0=None):
        return np.zeros(4) if x0 is None else np.array(x0, dtype=float)

    def premises(self, k, u, y):
        """Premises ``(f_r, f_f, v_x)`` of sample ``k`` (slip (4) with ``v_ye``, secant
        stiffnesses (16)), clipped to the sector of the TS model (24)."""
        ts = self.design.ts
        z = ts_premises(u[k, 2], y[k, 0], u[k, 0], u[k, 1], self.params)[0]
        return np.clip(z, ts.zmin, ts.zmax)

    def step(self, z, k, t, u, y):
        """``substeps`` :func:`observer_step` (31) over ``[t_{k-1}, t_k]`` with the inputs and
        the clipped premises of sample ``k - 1`` held."""
        zc = self.premises(k - 1, u, y)
        for _ in range(self.substeps):
            z = observer_step(self.design, z, zc, u[k - 1, 0], y[k - 1, 0],
                              self.dt / self.substeps)
        return z

    def estimate(self, z):
        return z

    def run(self, t, u, y, x0=None, premises: PremiseEstimate | None = None) -> TSRun:
        """The compiled loop :func:`_observer`; forces by (46). ``premises`` (the vision
        chain that produced ``u[:, 2]``) is only attached to the result."""
        t, u, y, x0 = self.check_data(t, u, y, x0)
        x0 = self.initial_state(t, u, y, x0)
        ts = self.design.ts
        t0 = time.perf_counter()
        X, Z, clipped = _observer(np.ascontiguousarray(y[:, 0]), np.ascontiguousarray(u[:, 0]),
                                  np.ascontiguousarray(u[:, 1]), np.ascontiguousarray(u[:, 2]),
                                  self.dt, self.params.as_array(), ts.A, ts.B,
                                  np.ascontiguousarray(self.design.L), ts.zmin, ts.zmax, x0,
                                  self.substeps)
        sec = time.perf_counter() - t0
        Ff, Fr = forces_from_transformed(X[:, 2], X[:, 3], self.params)
        return TSRun(t, X, STATE_NAMES, seconds=sec, estimator=type(self).__name__,
                     Ff=Ff, Fr=Fr, z=Z, clipped=clipped, premises=premises)


def run_observer(log: DriveLog, design: Theorem1Design, premises: PremiseEstimate | None = None,
                 vy_premise=None, x0=None, params: LateralParams | None = None,
                 substeps: int = 1) -> TSRun:
    """TS observer (31) (:class:`TSPremiseObserver` at ``dt = log.dt``) on a log; premise
    ``v_y`` from (26) (:func:`estimate_premises`) unless ``vy_premise`` is given.

    ``x0`` (4,) initial estimate (default 0, as in the paper). The inputs (yaw rate,
    steering, speed, premise) are held over each sample; RK4 with ``substeps`` steps.
    """
    p = _params(params)
    if premises is None and vy_premise is None:
        premises = estimate_premises(log, params=p)
    vyp = np.asarray(premises.vy if vy_premise is None else vy_premise, dtype=float)
    if np.any(log.vx <= 0):
        k = int(np.argmax(log.vx <= 0))
        raise ObserverArgumentError(f"{log.source}: column 'vx_mps' must be > 0 (slip (4) "
                                    f"divides by it); row {k} has {log.vx[k]}")
    obs = TSPremiseObserver(design, log.dt, p, substeps)
    return obs.run(log.t, np.column_stack([log.delta, log.vx, vyp]), log.yaw_rate, x0,
                   premises=premises)


def __getattr__(name):
    """``ObserverDesign``, the former name of :class:`Theorem1Design` (the layer's general
    design is :class:`vehicle_observers.design.synthesis.ObserverDesign`)."""
    if name == "ObserverDesign":
        import warnings

        warnings.warn("ts_premise.ObserverDesign is now Theorem1Design", DeprecationWarning,
                      stacklevel=2)
        return Theorem1Design
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
