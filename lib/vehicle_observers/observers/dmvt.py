"""DMVT observer for TS systems with unmeasurable premise variables (Ichalal, Arioui, Mammar,
MED 2011, Sec. II and IV).

The system ``x' = f(x, u) = A_mu(x) x + B_mu(x) u`` (eq. (3)/(5)) is observed by (6)

    xhat' = A_muhat xhat + B_muhat u + L_muhat (y - C xhat),   muhat = mu(z(xhat)),

and the error ``e = x - xhat`` obeys (7) ``e' = f(x, u) - f(xhat, u) - L_muhat C e``. The
differential mean value theorem (11)-(12) writes ``f(x) - f(xhat) = J(xi) e`` row by row
(each row ``i`` at its own point ``xi^i`` of the segment ``[xhat, x]``); with entry bounds
``a_kl <= J_kl <= b_kl`` (14) and the sector weights (15)-(17), the Jacobian is a convex
sum of ``q = 2^k`` vertices (``k`` = number of varying entries), eq. (18):

    e' = sum_i sum_j h_i(xi) mu_j(zhat) (A_i - L_j C) e.

A common quadratic Lyapunov function (19)-(22) and ``K_j = P L_j`` give the LMIs (23)

    A_i^T P + P A_i - C^T K_j^T - K_j C < 0,   i = 1..q, j = 1..r,

and the optional Chilali-Gahinet region constraints (35) (half-plane ``Re z < -a``) and
(36) (disk ``|z| < R``), built with :mod:`vehicle_observers.design.lmi` (``Region.lmi(P, P A_i -
K_j C)``), composable with any other region (e.g. a sector).

Every design is certified twice: (1) :class:`~vehicle_observers.design.lmi.LMIDesign` recomputes
each LMI from the numeric ``P, K_j`` and checks its eigenvalues; (2) the eigenvalues of
every vertex pair ``A_i - L_j C`` are computed and checked against the region (or against
``Re < 0`` without a region). A failure raises
:class:`~vehicle_observers.core.errors.CertificationError` naming the pair and the eigenvalue.

Remark (checked in the tests): with a common ``P`` the LMIs of different ``j`` do not
interact, so the feasible set of every ``K_j`` is the same; ``r > 1`` gains (the paper's
``L_1..L_8``) add nothing to feasibility. They are kept for fidelity with (29).

The Jacobian TS model (12)-(18), (34) (entry bounds, vertices and their ordering, weights
``h1 = F1^1 F2^1``, ``h2 = F1^0 F2^1``, ``h3 = F1^1 F2^0``, ``h4 = F1^0 F2^0`` as printed) is
:class:`vehicle_observers.models.ts.JacobianTS`; the bicycle (25), its Jacobian (31) and its
8-rule sector TS model are in :mod:`vehicle_observers.models.bicycle`.

Observer (6) on sampled data: :class:`DMVTObserver` (the observer contract of
:mod:`vehicle_observers.core.protocol`): RK4 over each sample interval with ``u_k``, ``y_k``
held (zero-order hold), the compiled ``run`` and the readable numpy ``step`` giving the same
numbers. :func:`simulate_bicycle_observer` instead co-simulates the plant and the observer
(``u`` and ``y = C x`` re-evaluated in every RK4 stage): the two differ by O(dt).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from numba import njit

from vehicle_observers.core.errors import CertificationError, InfeasibleDesign, ObserverArgumentError
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.design.constraints import Decay, InRegion
from vehicle_observers.design.lmi import LMISolution, Region
from vehicle_observers.design.synthesis import ObserverSynthesis
from vehicle_observers.design.system import PolytopicSystem
from vehicle_observers.models.bicycle import BP_C, BP_G, BP_P, BP_V, BicycleParams, plant_rhs
from vehicle_observers.models.ts import JacobianTS, SectorTS, memberships
from vehicle_observers.observers.fixed_step import FixedStepObserver, positive, row_names


def segment_jacobian_values(jac: Callable, X, Xhat, U, jts: JacobianTS,
                            n_points: int = 5) -> np.ndarray:
    """Varying Jacobian entries on the segments ``[xhat(t), x(t)]`` where the DMVT points
    ``xi^i`` of (11) lie: shape (N, n_points, k). ``jac(x (N, n), u (N,)) -> (N, n, n)``;
    ``jts`` the Jacobian TS model (:class:`~vehicle_observers.models.ts.JacobianTS`)."""
    X, Xhat = np.asarray(X, dtype=float), np.asarray(Xhat, dtype=float)
    out = np.empty((len(X), n_points, len(jts.entries)))
    for m, s in enumerate(np.linspace(0.0, 1.0, n_points)):
        out[:, m] = jts.values(jac(Xhat + s * (X - Xhat), U))
    return out


# ---- LMI design (23), (35)-(36) ------------------------------------------------------------


@dataclass
class PoleSummary:
    """Closed-loop eigenvalues ``lambda(A_i - L_j C)`` of every vertex pair, (q, r, n)."""

    eigs: np.ndarray

    @property
    def max_real(self) -> float:
        return float(self.eigs.real.max())

    @property
    def max_imag(self) -> float:
        return float(np.abs(self.eigs.imag).max())

    @property
    def max_modulus(self) -> float:
        return float(np.abs(self.eigs).max())

    @property
    def min_damping(self) -> float:
        """Smallest damping ratio ``-Re(l)/|l|`` over every eigenvalue of every pair."""
        e = self.eigs.ravel()
        return float(np.min(-e.real / np.maximum(np.abs(e), 1e-300)))

    def as_dict(self) -> dict:
        return {"max_real": self.max_real, "max_imag": self.max_imag,
                "max_modulus": self.max_modulus, "min_damping": self.min_damping}


def as_regions(region) -> list[Region]:
    """``region`` (None, a :class:`~vehicle_observers.design.lmi.Region` or a sequence of
    them) as a list of regions."""
    if region is None:
        return []
    if isinstance(region, Region):
        return [region]
    regs = list(region)
    for r in regs:
        if not isinstance(r, Region):
            raise TypeError(f"region must be a lmi.Region or a sequence of them, got {type(r)}")
    return regs


def pole_summary(vertices, L, C) -> PoleSummary:
    vertices, L, C = (np.asarray(a, dtype=float) for a in (vertices, L, C))
    eig = np.array([[np.linalg.eigvals(A - Lj @ C) for Lj in L] for A in vertices])
    return PoleSummary(eig)


def check_poles(vertices, L, C, region=None, name: str = "DMVT observer") -> PoleSummary:
    """Eigenvalues of every pair ``A_i - L_j C`` inside the region (``Re < 0`` without one).

    Raises :class:`CertificationError` naming the pair (1-based like the paper) and the
    offending eigenvalue.
    """
    ps = pole_summary(vertices, L, C)
    regs = as_regions(region)
    for i in range(ps.eigs.shape[0]):
        for j in range(ps.eigs.shape[1]):
            ev = ps.eigs[i, j]
            if np.any(ev.real >= 0):
                k = int(np.argmax(ev.real))
                raise CertificationError(
                    f"{name}: pair (i={i + 1}, j={j + 1}): eigenvalue {ev[k]:.4g} of "
                    f"A_i - L_j C is not in the open left half-plane", lmi=f"eig[{i + 1},{j + 1}]",
                    violation=float(ev[k].real))
            for reg in regs:
                inside = reg.contains(ev)
                if not inside.all():
                    k = int(np.argmin(inside))
                    raise CertificationError(
                        f"{name}: pair (i={i + 1}, j={j + 1}): eigenvalue {ev[k]:.4g} of "
                        f"A_i - L_j C lies outside the region {reg.name!r}",
                        lmi=f"eig[{i + 1},{j + 1}] in {reg.name}", violation=None)
    return ps


@dataclass
class DMVTDesign:
    """Certified DMVT observer design.

    P (n, n), K (r, n, p), L (r, n, p) with ``L_j = P^{-1} K_j``; ``poles`` are the
    eigenvalues of every vertex pair; ``solution`` holds the LMI certificate.
    """

    P: np.ndarray
    K: np.ndarray
    L: np.ndarray
    poles: PoleSummary
    solution: LMISolution
    regions: list
    #: the certificate rebuilt from the vertex data, the gains and P
    #: (:class:`vehicle_observers.design.certify.ObserverCertificate`)
    data_certificate: object = None

    @property
    def certificate(self):
        """The LMI certificate (:class:`vehicle_observers.design.lmi.Certificate`)."""
        return self.solution.certificate

    @property
    def min_margin(self) -> float:
        return self.solution.certificate.min_margin

    @property
    def min_relative_margin(self) -> float:
        return self.solution.certificate.min_relative_margin

    def margins(self) -> dict:
        """Smallest absolute / relative LMI margin per constraint family ((23), P, regions)."""
        fam: dict[str, list] = {}
        for c in self.solution.certificate.checks:
            key = c.name.split("[")[0]
            fam.setdefault(key, []).append(c)
        return {k: {"margin": min(c.margin for c in v), "relative": min(c.relative for c in v)}
                for k, v in fam.items()}


def design_dmvt_observer(vertices, C, r: int = 1, region=None, P_lower: float = 1.0,
                         K_bound: float | None = None, eps: float = 1e-7,
                         name: str = "DMVT observer (23)") -> DMVTDesign:
    """Solve the LMIs (23) (and the region LMIs (35)-(36) when ``region`` is given).

    Parameters
    ----------
    vertices : (q, n, n) Jacobian TS vertices ``A_i`` (Ichalal 2011 eq. (34)).
    C : (p, n) output matrix (28).
    r : number of observer gains ``L_j`` (the observer's TS rules; 8 for the bicycle).
    region : None, a :class:`~vehicle_observers.design.lmi.Region` or a sequence of them
        (intersection), e.g. ``[halfplane(a), disk(R)]`` for (35)-(36).
    P_lower : ``P >= P_lower I`` fixes the scale of the homogeneous LMIs (conditioning).
    K_bound : optional entry-wise bound ``|K_j| <= K_bound`` (keeps gains finite).
    eps : strictness imposed on the solver.

    Returns a :class:`DMVTDesign`; raises :class:`InfeasibleDesign` naming the LMIs when the
    solver finds none, :class:`CertificationError` when the solution fails either check.

    A call of the synthesis layer (:class:`~vehicle_observers.design.synthesis.ObserverSynthesis`):
    the vertices as a :class:`~vehicle_observers.design.system.PolytopicSystem`, ``r`` gains
    against every vertex (``gains="pairs"``), :class:`~vehicle_observers.design.constraints.Decay`
    with ``alpha = 0`` (the LMIs (23)) and one
    :class:`~vehicle_observers.design.constraints.InRegion` per region; the data certificate
    (``DMVTDesign.data_certificate``) rebuilds every LMI from ``A_i``, ``C``, ``L_j``, ``P``.
    """
    syn, A, C, regs = dmvt_synthesis(vertices, C, r, region, P_lower, K_bound, eps, name)
    des = syn.solve()
    sol, P, L = des.solution, des.P, des.L
    K = np.array([sol[f"K{j}"] for j in range(int(r))])
    poles = check_poles(A, L, C, regs, name=name)
    return DMVTDesign(P, K, L, poles, sol, regs, des.certificate)


def dmvt_synthesis(vertices, C, r: int = 1, region=None, P_lower: float = 1.0,
                   K_bound: float | None = None, eps: float = 1e-7,
                   name: str = "DMVT observer (23)"):
    """The :class:`~vehicle_observers.design.synthesis.ObserverSynthesis` of LMIs (23) (+ the
    regions (35)-(36)) that :func:`design_dmvt_observer` solves (arguments as there, checked
    here). Returns ``(synthesis, A (q, n, n), C (p, n), regions)``."""
    who = "design_dmvt_observer"
    A = np.asarray(vertices, dtype=float)
    C = np.atleast_2d(np.asarray(C, dtype=float))
    if A.ndim != 3 or A.shape[1] != A.shape[2]:
        raise ObserverArgumentError(f"{who}: vertices must have shape (q, n, n), got {A.shape}")
    q, n, _ = A.shape
    if C.ndim != 2 or C.shape[1] != n:
        raise ObserverArgumentError(f"{who}: C must have {n} columns (one per state), got "
                                    f"shape {C.shape}")
    if not np.all(np.isfinite(A)):
        raise ObserverArgumentError(f"{who}: vertices must be finite")
    if not np.all(np.isfinite(C)):
        raise ObserverArgumentError(f"{who}: C must be finite")
    if isinstance(r, bool) or int(r) != r or r < 1:
        raise ObserverArgumentError(f"{who}: r (number of observer gains) must be a positive "
                                    f"integer, got {r}")
    positive(who, "P_lower", P_lower)
    positive(who, "eps", eps)
    if K_bound is not None:
        positive(who, "K_bound", K_bound)
    regs = as_regions(region)
    syn = ObserverSynthesis(PolytopicSystem(A, C, name=name),
                            [Decay(0.0, label="(23)"), *(InRegion(reg) for reg in regs)],
                            gains="pairs", n_gains=int(r), P_lower=P_lower, gain_bound=K_bound,
                            eps=eps, order="vertex", name=name)
    return syn, A, C, regs


def region_sweep(vertices, C, a_values, R_values, r: int = 1, **kw) -> dict:
    """Feasibility of (23)+(35)+(36) on a grid of half-plane ``a`` and disk radius ``R``.

    Returns ``{"a": (na,), "R": (nR,), "feasible": (na, nR) bool, "margin": (na, nR)
    relative LMI margin (nan if infeasible), "max_imag", "min_damping" (na, nR)}``.
    Certification failures count as infeasible (reason kept in ``"reason"``).
    """
    from vehicle_observers.design.lmi import disk, halfplane

    a_values, R_values = np.asarray(a_values, float), np.asarray(R_values, float)
    shape = (len(a_values), len(R_values))
    feas = np.zeros(shape, dtype=bool)
    margin, mi, md = (np.full(shape, np.nan) for _ in range(3))
    reason = np.full(shape, "", dtype=object)
    for ia, a in enumerate(a_values):
        for iR, R in enumerate(R_values):
            try:
                des = design_dmvt_observer(vertices, C, r=r, region=[halfplane(a), disk(R)],
                                           name=f"sweep a={a:g} R={R:g}", **kw)
            except InfeasibleDesign as exc:
                reason[ia, iR] = type(exc).__name__
                continue
            feas[ia, iR] = True
            margin[ia, iR] = des.min_relative_margin
            mi[ia, iR] = des.poles.max_imag
            md[ia, iR] = des.poles.min_damping
    return {"a": a_values, "R": R_values, "feasible": feas, "margin": margin,
            "max_imag": mi, "min_damping": md, "reason": reason}


def min_feasible_radius(vertices, C, a: float, R_lo: float, R_hi: float, tol: float = 0.05,
                        r: int = 1, check_ends: bool = True, compiled: bool = True,
                        return_design: bool = False, **kw):
    """Smallest disk radius ``R`` (to ``tol``) for which (23)+(35)+(36) with half-plane ``a``
    is feasible and certified, by bisection on ``[R_lo, R_hi]`` [1/s].

    With ``check_ends`` the ends are tested first: returns ``nan`` if ``R_hi`` is infeasible
    and ``R_lo`` if ``R_lo`` is feasible. Without it the caller guarantees the bracket
    (``R_lo`` infeasible, ``R_hi`` feasible, e.g. from :func:`region_sweep`).

    A radius is feasible when :func:`design_dmvt_observer` would return a design there: the
    solver finds a point, the builders' certificate and the data certificate do not say
    "violated" and every pole of ``A_i - L_j C`` lies in the regions (:func:`check_poles`).
    ``compiled=True``: every step solves one problem compiled once with the radius as a cvxpy
    Parameter (:class:`~vehicle_observers.design.synthesis.CompiledBisection` with the disk as
    its target: cvxpy's canonicalisation once, then per step the substituted data and a fresh
    Clarabel solve, so each step's conic data equal those of :func:`design_dmvt_observer` to
    round-off); ``False``: each step poses and canonicalises its own problem
    (:func:`design_dmvt_observer`). ``kw``: ``P_lower``, ``K_bound``, ``eps`` of
    :func:`design_dmvt_observer`.

    Returns ``R`` [1/s], or with ``return_design`` ``(R, design)``: the
    :class:`DMVTDesign` of :func:`design_dmvt_observer` at that ``R`` (``None`` with ``nan``),
    the same arrays whichever path found ``R``.
    """
    from vehicle_observers.design.lmi import disk, halfplane
    from vehicle_observers.design.synthesis import CompiledBisection

    who = "min_feasible_radius"
    positive(who, "R_lo", R_lo, allow_zero=True)
    positive(who, "tol", tol)
    if not R_hi > R_lo:
        raise ObserverArgumentError(f"{who}: need R_hi > R_lo, got [{R_lo}, {R_hi}]")

    def design_at(R):
        return design_dmvt_observer(vertices, C, r=r, region=[halfplane(a), disk(R)],
                                    name=f"bisection a={a:g} R={R:g}", **kw)

    if compiled:
        syn, A, Cm, regs = dmvt_synthesis(vertices, C, r, [halfplane(a), disk(R_hi)],
                                          name=f"bisection a={a:g}", **kw)
        comp = CompiledBisection(syn, target=syn.constraints[-1])

        def ok(R):
            des = comp.solve(R)
            if des is None or des.status == "violated" or not des.solution.certificate.ok:
                return False
            try:
                check_poles(A, des.L, Cm, [halfplane(a), disk(R)])
            except CertificationError:
                return False
            return True
    else:
        def ok(R):
            try:
                design_at(R)
                return True
            except InfeasibleDesign:
                return False

    def result(R):
        if not return_design:
            return R
        return R, (None if np.isnan(R) else design_at(R))

    if check_ends:
        if not ok(R_hi):
            return result(float("nan"))
        if ok(R_lo):
            return result(float(R_lo))
    lo, hi = float(R_lo), float(R_hi)
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return result(hi)


def sweep_brackets(sweep: dict) -> list:
    """Per half-plane ``a`` of a :func:`region_sweep`: ``(a, R_infeasible, R_feasible)`` with
    the largest infeasible and the smallest feasible grid radius (rows whose feasible set is
    not an upper interval of the R grid, or has no feasible/infeasible cell, are skipped)."""
    out = []
    for ia, a in enumerate(sweep["a"]):
        F = sweep["feasible"][ia]
        if F.all() or not F.any():
            continue
        k = int(np.argmax(F))
        if not F[k:].all():
            continue
        out.append((float(a), float(sweep["R"][k - 1]), float(sweep["R"][k])))
    return out


# ---- observer (6): compiled right-hand side ------------------------------------------------


@njit(cache=True)
def observer_rhs(xh, u, y, P, Av, Bv, zmin, zmax, L, C, out):
    """Observer (6) of Ichalal 2011 (compiled): ``out = sum_i mu_i(z(xh)) (A_i xh + B_i u)
    + sum_j mu_j L_j (y - C xh)`` with the premises (31)-(33) computed from the *estimate*
    ``xh`` (4,) (unmeasurable premise variables). The model part uses the exact (possibly
    extrapolated) weights, so it equals ``f(xh, u)`` even outside the sector; the gain part
    the clipped, convex weights. ``P`` = :meth:`~vehicle_observers.models.bicycle.BicycleParams.as_array`,
    ``Av`` (r, 4, 4), ``Bv`` (r, 4, 1), ``zmin, zmax`` (3,), ``L`` (r or 1, 4, ny), ``C`` (ny, 4),
    ``y`` (ny,), ``out`` (4,)."""
    p, c, v, g = P[BP_P], P[BP_C], P[BP_V], P[BP_G]
    x2h, x3h = xh[1], xh[2]
    z = np.empty(3)
    z[0] = g / p * (np.sin(x3h) / x3h if abs(x3h) > 1e-8 else 1.0)
    z[1] = (1 + p * x2h * np.sin(x3h)) * np.cos(x3h) * v * v / p
    z[2] = c / p * np.cos(x3h) * v
    nr, nz, ny = Av.shape[0], zmin.shape[0], C.shape[0]
    innov = np.empty(ny)
    for k in range(ny):
        acc = y[k]
        for i in range(4):
            acc -= C[k, i] * xh[i]
        innov[k] = acc
    for i in range(4):
        out[i] = 0.0
    for vtx in range(nr):
        w = 1.0   # exact (possibly extrapolated) weight: model part equals f(xhat, u)
        wc = 1.0  # clipped weight: convex blend of the gains
        for j in range(nz):
            bit = (vtx >> (nz - 1 - j)) & 1
            w0 = (z[j] - zmin[j]) / (zmax[j] - zmin[j])
            w0c = min(max(w0, 0.0), 1.0)
            w *= w0 if bit == 0 else 1.0 - w0
            wc *= w0c if bit == 0 else 1.0 - w0c
        jl = vtx if L.shape[0] == nr else 0
        for i in range(4):
            acc = Bv[vtx, i, 0] * u
            for j in range(4):
                acc += Av[vtx, i, j] * xh[j]
            gain = 0.0
            for k in range(ny):
                gain += L[jl, i, k] * innov[k]
            out[i] += w * acc + wc * gain



def _check_gains(who: str, C, L, n_rules: int):
    """``(C (ny, 4), L (r, 4, ny))`` as contiguous arrays with ``r`` = 1 or ``n_rules``;
    :class:`ObserverArgumentError` naming the argument otherwise."""
    C = np.ascontiguousarray(np.atleast_2d(C), dtype=float)
    L = np.ascontiguousarray(L, dtype=float)
    if C.ndim != 2 or C.shape[1] != 4 or not np.all(np.isfinite(C)):
        raise ObserverArgumentError(f"{who}: C must have shape (ny, 4) (one column per bicycle "
                                    f"state), finite, got {C.shape}")
    ny = C.shape[0]
    if L.ndim != 3 or L.shape[1:] != (4, ny) or L.shape[0] not in (1, n_rules):
        raise ObserverArgumentError(f"{who}: L must have shape (r, 4, ny) with r = {n_rules} "
                                    f"rules or 1, ny = {ny}, got {L.shape}")
    if not np.all(np.isfinite(L)):
        raise ObserverArgumentError(f"{who}: L must be finite")
    return C, L


# ---- observer (6) on sampled data: the observer contract -----------------------------------
@njit(cache=True)
def _dmvt_run(xh0, Y, U, dt, P, Av, Bv, zmin, zmax, L, C):
    """Observer (6) on sampled data: RK4 of :func:`observer_rhs` over each interval with
    ``U[k]``, ``Y[k]`` held; row ``k`` of the result is the estimate at ``t_k``."""
    N = Y.shape[0]
    Xh = np.empty((N, 4))
    s = xh0.copy()
    k1, k2, k3, k4, tmp = np.empty(4), np.empty(4), np.empty(4), np.empty(4), np.empty(4)
    for k in range(N):
        Xh[k] = s
        if k == N - 1:
            break
        observer_rhs(s, U[k], Y[k], P, Av, Bv, zmin, zmax, L, C, k1)
        for i in range(4):
            tmp[i] = s[i] + 0.5 * dt * k1[i]
        observer_rhs(tmp, U[k], Y[k], P, Av, Bv, zmin, zmax, L, C, k2)
        for i in range(4):
            tmp[i] = s[i] + 0.5 * dt * k2[i]
        observer_rhs(tmp, U[k], Y[k], P, Av, Bv, zmin, zmax, L, C, k3)
        for i in range(4):
            tmp[i] = s[i] + dt * k3[i]
        observer_rhs(tmp, U[k], Y[k], P, Av, Bv, zmin, zmax, L, C, k4)
        for i in range(4):
            s[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return Xh


@dataclass(frozen=True)
class DMVTGains:
    """Gains ``L`` (r, 4, ny) of observer (6) given without their LMI design (``certificate``
    None), e.g. to run a gain of another design study."""

    L: np.ndarray
    certificate: None = None


class DMVTObserver(FixedStepObserver):
    """Observer (6) of Ichalal, Arioui, Mammar (MED 2011) for the bicycle (25) on sampled data.

    ``design``: a :class:`DMVTDesign` of LMIs (23) (+ (35)-(36)) or the gains ``L`` (r, 4,
    ny), r = 1 or ``ts.n_rules``; ``ts``: the 8-rule sector TS model of the bicycle
    (:func:`vehicle_observers.models.bicycle.bicycle_ts`), whose premises the observer
    evaluates at its own estimate (unmeasurable premises, Sec. IV); ``params``:
    :class:`~vehicle_observers.models.bicycle.BicycleParams`; ``C`` (ny, 4) output matrix (28);
    ``dt`` [s] sample period.

    Data: ``u`` (N, 1) the input of (27) (normalised steering torque, known to the observer),
    ``y`` (N, ny) = ``C x`` (+ noise). Each interval is one RK4 step of (6) with ``u_{k-1}``,
    ``y_{k-1}`` held (zero-order hold). ``x0`` (4,) initial estimate, default 0.
    """

    state_names = ("beta_rad", "psi_beta_1pm", "alpha_rad", "psi_alpha_radps")
    input_names = ("u_norm",)

    def __init__(self, design, ts: SectorTS, params: BicycleParams, C, dt: float):
        super().__init__(dt)
        L = design.L if isinstance(design, DMVTDesign) else design
        self.C, self.L = _check_gains(type(self).__name__, C, L, ts.n_rules)
        self.design = design if isinstance(design, DMVTDesign) else DMVTGains(self.L)
        self.ts, self.params = ts, params
        self.output_names = row_names(self.C, self.state_names)
        self._P = params.as_array()
        self._Av, self._Bv = np.ascontiguousarray(ts.A), np.ascontiguousarray(ts.B)

    def rhs(self, xh, u: float, y) -> np.ndarray:
        """``dxhat/dt`` of (6), readable numpy (the compiled twin is :func:`observer_rhs`)::

            zhat  = z(xhat)                                   premises from the estimate
            model = sum_i mu_i(zhat) (A_i xhat + B_i u)       (= f(xhat, u), exact weights)
            gain  = sum_j mu_j(clip(zhat)) L_j                (convex blend of the gains)
            dxhat/dt = model + gain (y - C xhat)

        ``xh`` (4,), ``u`` scalar, ``y`` (ny,)."""
        ts = self.ts
        z = ts.premise_fn(np.asarray(xh, dtype=float)[None], np.array([[u]]))[0]
        mu = memberships(z, ts.zmin, ts.zmax)
        mu_clip = memberships(np.clip(z, ts.zmin, ts.zmax), ts.zmin, ts.zmax)
        A, B = ts.blend(mu)
        gain = np.tensordot(mu_clip, self.L, axes=1) if len(self.L) == len(mu) else self.L[0]
        return A @ xh + B[:, 0] * u + gain @ (np.asarray(y, dtype=float) - self.C @ xh)

    def initial_state(self, t, u, y, x0=None) -> np.ndarray:
        return np.zeros(4) if x0 is None else np.array(x0, dtype=float)

    def step(self, z, k, t, u, y) -> np.ndarray:
        """Observer (6) (Ichalal 2011) over ``[t_{k-1}, t_k]``: one classical RK4 step of
        :meth:`rhs` with ``u_{k-1}``, ``y_{k-1}`` held; ``z`` is the estimate (4,)."""
        h, uk, yk = self.dt, float(u[k - 1, 0]), y[k - 1]
        k1 = self.rhs(z, uk, yk)
        k2 = self.rhs(z + 0.5 * h * k1, uk, yk)
        k3 = self.rhs(z + 0.5 * h * k2, uk, yk)
        k4 = self.rhs(z + h * k3, uk, yk)
        return z + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    def estimate(self, z) -> np.ndarray:
        return np.asarray(z, dtype=float)

    def run(self, t, u, y, x0=None) -> Trajectory:
        """The compiled loop (``_dmvt_run``): the numbers of :meth:`step` looped."""
        t, u, y, x0 = self.check_data(t, u, y, x0)
        xh0 = self.initial_state(t, u, y, x0)
        sec, Xh = self.timed(_dmvt_run, xh0, y, np.ascontiguousarray(u[:, 0]), self.dt,
                             self._P, self._Av, self._Bv, self.ts.zmin, self.ts.zmax, self.L,
                             self.C)
        return self.trajectory(t, Xh, seconds=sec)


# ---- plant and observer co-simulation (Figs. 4-5) ---------------------------------------
@njit(cache=True)
def _bike_rhs(s, t, P, Av, Bv, zmin, zmax, L, C, out):
    """Plant (25)+(27) (states 0..3, the compiled
    :func:`vehicle_observers.models.bicycle.plant_rhs`) and observer (6) (states 4..7,
    :func:`observer_rhs` with ``y = C x``)."""
    u = plant_rhs(s, t, P, out)
    ny = C.shape[0]
    y = np.empty(ny)
    for k in range(ny):
        acc = 0.0
        for i in range(4):
            acc += C[k, i] * s[i]
        y[k] = acc
    observer_rhs(s[4:], u, y, P, Av, Bv, zmin, zmax, L, C, out[4:])
    return u


@njit(cache=True)
def _bike_obs_sim(s0, t, P, Av, Bv, zmin, zmax, L, C):
    N = t.shape[0]
    S = np.empty((N, 8))
    U = np.empty(N)
    s = s0.copy()
    k1 = np.empty(8)
    k2 = np.empty(8)
    k3 = np.empty(8)
    k4 = np.empty(8)
    tmp = np.empty(8)
    for k in range(N):
        S[k] = s
        U[k] = _bike_rhs(s, t[k], P, Av, Bv, zmin, zmax, L, C, k1)
        if k == N - 1:
            break
        h = t[k + 1] - t[k]
        for i in range(8):
            tmp[i] = s[i] + 0.5 * h * k1[i]
        _bike_rhs(tmp, t[k] + 0.5 * h, P, Av, Bv, zmin, zmax, L, C, k2)
        for i in range(8):
            tmp[i] = s[i] + 0.5 * h * k2[i]
        _bike_rhs(tmp, t[k] + 0.5 * h, P, Av, Bv, zmin, zmax, L, C, k3)
        for i in range(8):
            tmp[i] = s[i] + h * k3[i]
        _bike_rhs(tmp, t[k] + h, P, Av, Bv, zmin, zmax, L, C, k4)
        for i in range(8):
            s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return S, U


def simulate_bicycle_observer(bp, t, ts, L, C, x0=(0.0, 0.0, 0.0, 0.0),
                              xhat0=(0.0, 0.0, 0.0, 0.0)):
    """Bicycle (25) with tracking law (27) and the TS observer (6), RK4 on the grid ``t``.

    The observer weights ``mu_j(zhat)`` use the premises ``z(xhat)`` of the 8-rule TS model
    ``ts`` (:func:`vehicle_observers.models.bicycle.bicycle_ts`) computed from the *estimated*
    state (Ichalal 2011, Sec. IV). Implementation choice (documented in notebook 04): the
    model part ``sum_j mu_j(zhat)(A_j xhat + B_j u)`` uses the unclipped multi-affine
    weights, so it equals ``f(xhat, u)`` exactly even if ``zhat`` leaves the sector box
    during a transient; the gain part ``sum_j mu_j L_j`` uses weights of ``zhat`` clipped
    to the box so it stays a convex combination of the designed gains. The input ``u`` is
    the tracking law on the true state (known to the observer).

    Parameters: ``L`` (r, 4, 2) with r = 1 or r = ts.n_rules; ``C`` (2, 4).
    Returns (X (N, 4), Xhat (N, 4), u (N,)).
    """
    who = "simulate_bicycle_observer"
    t = np.ascontiguousarray(t, dtype=float)
    if t.ndim != 1 or len(t) < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ObserverArgumentError(f"{who}: the time grid t must be 1-D and finite, with >= 2 "
                                    "strictly increasing samples (a time step dt <= 0)")
    C, L = _check_gains(who, C, L, ts.n_rules)
    for name, v in (("x0", x0), ("xhat0", xhat0)):
        if np.shape(v) != (4,) or not np.all(np.isfinite(v)):
            raise ObserverArgumentError(f"{who}: {name} must be 4 finite values, got {v}")
    s0 = np.concatenate([np.asarray(x0, dtype=float), np.asarray(xhat0, dtype=float)])
    S, U = _bike_obs_sim(s0, t, bp.as_array(), np.ascontiguousarray(ts.A),
                         np.ascontiguousarray(ts.B), ts.zmin, ts.zmax, L, C)
    return S[:, :4], S[:, 4:], U
