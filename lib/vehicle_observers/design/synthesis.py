"""Observer synthesis on a polytopic / TS system: gain structure + constraints -> LMIs ->
solve -> certificate rebuilt from the data.

Observer ``xhat' = A(h) xhat + B(h) u + L(h) (y - C(h) xhat)`` for the system of
:class:`~vehicle_observers.design.system.PolytopicSystem`. Gain structures (``gains``):

``"common"``
    one gain ``L`` for every vertex: the LMIs of every constraint at each vertex ``i``
    (named ``label[i]``).
``"pdc"``
    parallel distributed compensation, one gain ``L_i`` per vertex blended with the plant's
    memberships: ``e' = sum_i sum_j h_i h_j (A_i - L_j C_i) e``. With a common ``C`` the double
    sum is a single one and the LMIs are ``G_ii < 0`` (``label[i]``). With vertex-dependent
    ``C_i`` a relaxation of the double sum is needed (``relaxation``):
    ``"tanaka"`` (Tanaka, Ikeda & Wang, IEEE TFS 6(2), 1998, Thm 2 without the ``X`` slack):
    ``G_ii < 0``, ``G_ij + G_ji < 0`` (i < j); ``"tuan"`` (Tuan, Apkarian, Narikiyo & Yamamoto,
    IEEE TFS 9(2), 2001, Thm 2.2): ``G_ii < 0``, ``2/(q-1) G_ii + G_ij + G_ji < 0`` (i != j).
``"pairs"``
    ``n_gains`` gains scheduled by memberships unrelated to the plant's (e.g. estimated
    premises): every pair ``(i, j)``, ``label[i,j]`` (Ichalal 2011 (23)).
``"reduced"``
    reduced-order (Luenberger) observer: one common gain ``L`` (n - p, p) of the unmeasured
    block, the constraints posed on its error system ``A22_i - L A12_i`` in the coordinates
    where ``C = [I 0]`` (:mod:`vehicle_observers.design.reduced`); ``system`` is then that
    error system (``full_system`` the plant, ``coordinates`` the change of coordinates).

``G_ij`` is any constraint's matrix at the pair (:mod:`vehicle_observers.design.constraints`);
every constraint matrix is affine in the closed-loop data, so the relaxations apply to each.
The Lyapunov matrix ``P`` is common (``P="symmetric"``) or diagonal (``P="diagonal"``, needed
by :class:`~vehicle_observers.design.constraints.Metzler`).

The LMIs are posed with :class:`~vehicle_observers.design.lmi.LMIDesign` (builders generated
here from the vertex arrays), solved by Clarabel, and every returned design is then certified by
:func:`vehicle_observers.design.certify.certify_observer`, which rebuilds each LMI in numpy from
the system's arrays, the gains ``L_j`` and ``P`` only (not from these builders), adds the poles
of every frozen error system and, with a bounded-real constraint, each vertex's H-infinity norm
by Hamiltonian bisection.

Optimise, back off, certify (:meth:`ObserverSynthesis.maximise_decay`,
:meth:`ObserverSynthesis.minimise`): the optimum of a homogeneous LMI problem sits on the
boundary of the feasible set, where the certificate is at round-off level ("inconclusive").
The optimum is found first (bisection on ``alpha``, a generalised eigenvalue problem; or
``min gamma``), then the requirement is backed off by a stated fraction (``alpha (1 - b)``,
``gamma (1 + b)``) and the feasibility problem re-solved: the returned design has a real
margin, and the result carries the optimum, the certified design and the margin. The
bisection solves one problem compiled once with the decay requirement as a cvxpy Parameter
(:class:`CompiledBisection`); ``minimise`` is one optimisation and one feasibility solve, no
bisection.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from vehicle_observers.core.errors import CertificationError, InfeasibleDesign, ObserverArgumentError
from vehicle_observers.design.constraints import (
    CONSTRAINTS,
    BoundedReal,
    Decay,
    InputToState,
    InRegion,
    Metzler,
    Nonnegative,
)
from vehicle_observers.design.lmi import (
    MAX_CONDITION,
    MIN_RELATIVE_MARGIN,
    LMIDesign,
    LMISolution,
    Values,
    bmat,
    disk,
)
from vehicle_observers.design.system import PolytopicSystem

GAINS = ("common", "pdc", "pairs", "reduced")
RELAXATIONS = ("tanaka", "tuan")


def terms(system: PolytopicSystem, gains: str, n_gains: int, relaxation: str,
          double_sum: bool = False):
    """The LMIs of a gain structure: list of ``(suffix, [(coef, i, j), ...])``; each LMI is
    ``sum coef G_ij < 0`` (0-based ``i`` vertex, ``j`` gain). ``double_sum``: relax the PDC
    double sum even with a common ``C`` (a vertex-dependent Lyapunov matrix ``P_i`` makes
    ``P(h) A(h)`` a double sum, :mod:`vehicle_observers.design.lyapunov`)."""
    q = system.q
    if gains in ("common", "reduced"):
        return [(f"[{i + 1}]", [(1.0, i, 0)]) for i in range(q)]
    if gains == "pairs":
        return [(f"[{i + 1},{j + 1}]", [(1.0, i, j)]) for i in range(q) for j in range(n_gains)]
    if (system.common_C and not double_sum) or q == 1:
        return [(f"[{i + 1}]", [(1.0, i, i)]) for i in range(q)]
    out = [(f"[{i + 1},{i + 1}]", [(1.0, i, i)]) for i in range(q)]
    if relaxation == "tanaka":
        out += [(f"[{i + 1},{j + 1}]", [(1.0, i, j), (1.0, j, i)])
                for i in range(q) for j in range(i + 1, q)]
    else:
        out += [(f"[{i + 1},{j + 1}]", [(2.0 / (q - 1), i, i), (1.0, i, j), (1.0, j, i)])
                for i in range(q) for j in range(q) if i != j]
    return out


def decay_region(system: PolytopicSystem, c: Decay):
    """The discrete-time decay requirement as the disk ``|z| < exp(-alpha dt)``."""
    return disk(float(np.exp(-c.alpha * system.dt)))


# ---- cvxpy / numpy builders of one constraint at one pair ----------------------------------
def pair_matrix(c, system: PolytopicSystem, P, K, i: int, V, rate=None):
    """Matrix of constraint ``c`` at vertex ``i`` with gain variable ``K = P L_j`` (cvxpy).

    ``rate``: a cvxpy Parameter standing for the decay requirement of a :class:`Decay` or
    :class:`InputToState` ``c`` instead of its number (:class:`CompiledBisection`): ``alpha``
    [1/s] in continuous time and in ``InputToState``; for a discrete-time ``Decay`` the radius
    ``rho = exp(-alpha dt)`` of the disk ``[[-rho P, P A - K C], [*, -rho P]] < 0`` (the
    matrix of :func:`decay_region`, in which ``rho`` enters affinely)."""
    A, C, E, D, H = system.A[i], system.C[i], system.E[i], system.D[i], system.H
    PA = P @ A - K @ C
    if isinstance(c, Decay):
        if system.discrete:
            if rate is not None:
                return bmat([[-rate * P, PA], [PA.T, -rate * P]])
            return decay_region(system, c).lmi(P, PA)
        M = PA + PA.T
        if rate is not None:
            return M + 2.0 * rate * P
        return M + 2.0 * c.alpha * P if c.alpha else M
    if isinstance(c, InRegion):
        if rate is not None:
            return disk_lmi(c.region, P, PA, rate)
        return c.region.lmi(P, PA)
    PE = P @ E - K @ D if np.any(D) else P @ E
    if isinstance(c, BoundedReal):
        g = V["gamma"] if c.gamma is None else c.gamma
        nw, nz, n = E.shape[1], H.shape[0], A.shape[0]
        Iw, Iz = np.eye(nw), np.eye(nz)
        if system.discrete:
            return bmat([[-P, PA, PE, np.zeros((n, nz))],
                         [PA.T, -P, np.zeros((n, nw)), H.T],
                         [PE.T, np.zeros((nw, n)), -g * Iw, np.zeros((nw, nz))],
                         [np.zeros((nz, n)), H, np.zeros((nz, nw)), -g * Iz]])
        return bmat([[PA + PA.T, PE, H.T], [PE.T, -g * Iw, np.zeros((nw, nz))],
                     [H, np.zeros((nz, nw)), -g * Iz]])
    if isinstance(c, InputToState):
        cc = V["c"] if c.c is None else c.c
        X = A.T @ P + P @ A - K @ C - C.T @ K.T
        if rate is not None:
            X = X + rate * P
        elif c.alpha:
            X = X + c.alpha * P
        EP = E.T @ P if not np.any(D) else PE.T
        return bmat([[X, PE], [EP, -cc * np.eye(E.shape[1])]])
    raise TypeError(type(c))


def disk_center(region) -> float | None:
    """The center of a disk region (:func:`~vehicle_observers.design.lmi.disk`: ``L = [[-R, -c],
    [-c, -R]]``, ``M = [[0, 1], [0, 0]]``), ``None`` if ``region`` is not a disk."""
    L, M = region.L, region.M
    if L.shape != (2, 2) or not np.array_equal(M, [[0.0, 1.0], [0.0, 0.0]]) or \
            L[0, 0] != L[1, 1] or not L[0, 0] < 0:
        return None
    return float(-L[0, 1])


def disk_lmi(region, P, PA, R):
    """Chilali-Gahinet matrix of the disk ``region`` with its radius replaced by ``R`` (a cvxpy
    Parameter, :class:`CompiledBisection`): ``[[-R P, q P + P A], [q P + A^T P, -R P]]``
    (Ichalal 2011 eq. (36) with center ``-q``), the radius entering affinely."""
    from vehicle_observers.design.lmi import Region, kron

    L0 = region.L - region.L[0, 0] * np.eye(2)           # the center part, zero diagonal
    return Region(region.name, L0, region.M).lmi(P, PA) - R * kron(np.eye(2), P)


def _offdiag(X):
    """Off-diagonal entries of ``X`` as a row (cvxpy or numpy)."""
    n = X.shape[0]
    if isinstance(X, np.ndarray):
        return X[~np.eye(n, dtype=bool)][None]
    import cvxpy as cp
    return cp.reshape(cp.hstack([X[a, b] for a in range(n) for b in range(n) if a != b]),
                      (1, n * (n - 1)), order="C")


def _diag(X):
    """Diagonal entries of ``X`` as a row (cvxpy or numpy)."""
    n = X.shape[0]
    if isinstance(X, np.ndarray):
        return np.diag(X)[None]
    import cvxpy as cp
    return cp.reshape(cp.hstack([X[a, a] for a in range(n)]), (1, n), order="C")


# ---- result objects -------------------------------------------------------------------------
@dataclass
class ObserverDesign:
    """A solved observer design.

    ``P`` (n, n); ``L`` (r, n, p) gains (r = 1 common, q PDC, ``n_gains`` pairs); ``gamma``,
    ``c`` the values of the bounded-real / input-to-state bounds (``None`` if unused);
    ``certificate`` (:class:`~vehicle_observers.design.certify.ObserverCertificate`) rebuilt
    from the data; ``solution`` the solver's :class:`~vehicle_observers.design.lmi.LMISolution`
    (with the certificate of the builders)."""

    synthesis: "ObserverSynthesis"
    P: np.ndarray
    L: np.ndarray
    gamma: float | None
    c: float | None
    certificate: object
    solution: LMISolution

    @property
    def status(self) -> str:
        return self.certificate.status

    @property
    def K(self) -> np.ndarray:
        return np.array([self.P @ Lj for Lj in self.L])


@dataclass
class OptimisedDesign:
    """Optimise -> back off -> certify.

    ``optimum``: the best value found (largest ``alpha`` to ``tol`` by bisection, or smallest
    ``gamma`` / ``c``); ``at_optimum``: the design solved at the optimum (its certificate is
    usually "inconclusive": the optimum is on the boundary); ``backoff``: the fraction given up;
    ``value``: the backed-off requirement of ``design``, the certified design;
    ``margin``: its smallest relative LMI margin (from the data certificate)."""

    quantity: str
    optimum: float
    value: float
    backoff: float
    design: ObserverDesign
    at_optimum: ObserverDesign | None

    @property
    def margin(self) -> float:
        return self.design.certificate.lmi.min_relative_margin

    @property
    def status(self) -> str:
        return self.design.status


class ObserverSynthesis:
    """An observer LMI design on a :class:`PolytopicSystem` (module docstring).

    Parameters
    ----------
    system : the vertex data.
    constraints : sequence of :mod:`~vehicle_observers.design.constraints` objects (composed:
        every one must hold at every pair).
    gains : ``"common"``, ``"pdc"``, ``"pairs"`` or ``"reduced"``; ``n_gains`` the number of gains of
        ``"pairs"``.
    relaxation : ``"tuan"`` (default) or ``"tanaka"``, for PDC with vertex-dependent ``C_i``.
    P : ``"symmetric"`` or ``"diagonal"``.
    P_lower, P_upper : ``P - P_lower I > 0`` (normalisation of the homogeneous LMIs; ``"auto"``:
        1, or none (``P > 0``) with a bounded-real constraint, which is not homogeneous in
        ``P`` so that a normalisation would restrict it) and ``P_upper I - P > 0``
        (conditioning bound), ``None`` to omit.
    gain_bound : entry-wise ``|K_j| <= gain_bound`` (solver side only).
    eps : strictness imposed on the solver (``LMIDesign.eps``).
    order : ``"vertex"`` (pairs outer, constraints inner) or ``"constraint"``: the order the
        LMIs are posed in (the solution is the same up to the solver's round-off).
    gain_name, names : names of the gain variables (``K0``, ``K1``, ...) and of the
        normalisations in the certificates.
    name : the design's name in every message.
    """

    def __init__(self, system: PolytopicSystem, constraints=(), gains: str = "common",
                 n_gains: int | None = None, relaxation: str = "tuan", P: str = "symmetric",
                 P_lower: float | None | str = "auto", P_upper: float | None = None,
                 gain_bound: float | None = None, eps: float = 1e-7, order: str = "vertex",
                 gain_name: str = "K", lower_name: str | None = None,
                 upper_name: str | None = None, name: str = "observer design"):
        who = f"ObserverSynthesis {name!r}"
        if not isinstance(system, PolytopicSystem):
            raise ObserverArgumentError(f"{who}: system must be a PolytopicSystem, got "
                                        f"{type(system).__name__}")
        cons = list(constraints)
        for c in cons:
            if not isinstance(c, CONSTRAINTS):
                raise ObserverArgumentError(f"{who}: unknown constraint {c!r}; use one of "
                                            f"{', '.join(k.__name__ for k in CONSTRAINTS)}")
        if not cons:
            cons = [Decay(0.0)]
        if gains not in GAINS:
            raise ObserverArgumentError(f"{who}: gains must be one of {GAINS}, got {gains!r}")
        if relaxation not in RELAXATIONS:
            raise ObserverArgumentError(f"{who}: relaxation must be one of {RELAXATIONS}, got "
                                        f"{relaxation!r}")
        if P not in ("symmetric", "diagonal"):
            raise ObserverArgumentError(f"{who}: P must be 'symmetric' or 'diagonal', got {P!r}")
        if any(isinstance(c, Metzler) for c in cons) and P != "diagonal":
            raise ObserverArgumentError(f"{who}: a Metzler constraint needs P='diagonal' "
                                        "(then P A - K C Metzler <=> A - L C Metzler)")
        if any(isinstance(c, Nonnegative) for c in cons):
            if P != "diagonal":
                raise ObserverArgumentError(f"{who}: a Nonnegative constraint needs "
                                            "P='diagonal' (then P A - K C >= 0 <=> A - L C >= 0)")
            if not system.discrete:
                raise ObserverArgumentError(f"{who}: Nonnegative is the discrete-time positivity "
                                            "of A - L C; use Metzler in continuous time")
        if order not in ("vertex", "constraint"):
            raise ObserverArgumentError(f"{who}: order must be 'vertex' or 'constraint'")
        if gains == "pairs":
            if isinstance(n_gains, bool) or not isinstance(n_gains, (int, np.integer)) \
                    or n_gains < 1:
                raise ObserverArgumentError(f"{who}: gains='pairs' needs n_gains, a positive "
                                            f"integer, got {n_gains!r}")
        self.full_system, self.coordinates = system, None
        if gains == "reduced":
            from vehicle_observers.design.reduced import reduced_system

            system, self.coordinates = reduced_system(system)
        r = {"common": 1, "pdc": system.q, "pairs": n_gains, "reduced": 1}[gains]
        if isinstance(P_lower, str):
            if P_lower != "auto":
                raise ObserverArgumentError(f"{who}: P_lower must be a number, None or 'auto'")
            # the bounded-real LMI is not homogeneous in P (its -gamma I and H blocks fix the
            # scale): a normalisation P >= I would restrict it; every other LMI is homogeneous
            P_lower = None if any(isinstance(c, BoundedReal) for c in cons) else 1.0
        for what, v in (("P_lower", P_lower), ("P_upper", P_upper), ("gain_bound", gain_bound)):
            if v is not None and not (np.isfinite(v) and v > 0):
                raise ObserverArgumentError(f"{who}: {what} must be finite and > 0 (or None), "
                                            f"got {v!r}")
        if P_lower is not None and P_upper is not None and P_upper <= P_lower:
            raise ObserverArgumentError(f"{who}: P_upper must exceed P_lower")
        if sum(isinstance(c, BoundedReal) for c in cons) > 1 or \
                sum(isinstance(c, InputToState) for c in cons) > 1:
            raise ObserverArgumentError(f"{who}: at most one BoundedReal and one InputToState")
        if any(isinstance(c, (BoundedReal, InputToState)) for c in cons) and system.nw == 0:
            raise ObserverArgumentError(f"{who}: a bounded-real / input-to-state constraint "
                                        "needs a disturbance matrix E in the system")
        if any(isinstance(c, (BoundedReal, InputToState)) for c in cons) and \
                system.has_feedthrough:
            raise ObserverArgumentError(f"{who}: the system's performance output reads the "
                                        "disturbance (Dz != 0); use constraints.L2Gain with "
                                        "design.slack.SlackSynthesis")
        self.system, self.constraints, self.gains, self.n_gains = system, cons, gains, r
        self.relaxation, self.P_kind, self.P_lower, self.P_upper = relaxation, P, P_lower, P_upper
        self.gain_bound, self.eps, self.order, self.name = gain_bound, eps, order, name
        self.gain_name = gain_name
        self.lower_name = lower_name or "P - P_lower I > 0"
        self.upper_name = upper_name or "P_upper I - P > 0"
        self.terms = terms(system, gains, r, relaxation)

    def replace(self, **kw) -> "ObserverSynthesis":
        """A copy with some arguments changed (e.g. ``constraints=[...]``)."""
        args = dict(system=self.full_system, constraints=self.constraints, gains=self.gains,
                    n_gains=self.n_gains if self.gains == "pairs" else None,
                    relaxation=self.relaxation, P=self.P_kind, P_lower=self.P_lower,
                    P_upper=self.P_upper, gain_bound=self.gain_bound, eps=self.eps,
                    order=self.order, gain_name=self.gain_name, lower_name=self.lower_name,
                    upper_name=self.upper_name, name=self.name)
        args.update(kw)
        return ObserverSynthesis(**args)

    # ---- the LMIs -------------------------------------------------------------------------
    def lmi_design(self, rate=None, target=None) -> LMIDesign:
        """The :class:`LMIDesign` of this synthesis (variables ``P``, ``K0..``, ``gamma``,
        ``c``; constraints named ``label[i]`` / ``label[i,j]``). ``rate``: a cvxpy Parameter
        in place of the decay requirement of the (single) :class:`Decay` /
        :class:`InputToState` constraint, or, with ``target`` (one of the constraints, an
        :class:`InRegion` disk), in place of that disk's radius (:func:`pair_matrix`)."""
        s, n, p, eps = self.system, self.system.n, self.system.p, self.eps
        d = LMIDesign(self.name, eps=eps)
        (d.diagonal if self.P_kind == "diagonal" else d.symmetric)("P", n)
        gn = [f"{self.gain_name}{j}" for j in range(self.n_gains)]
        for g in gn:
            d.matrix(g, (n, p))
        if any(isinstance(c, InputToState) and c.c is None for c in self.constraints):
            d.scalar("c")
        if any(isinstance(c, BoundedReal) and c.gamma is None for c in self.constraints):
            d.scalar("gamma")
        I = np.eye(n)
        if self.P_lower is not None:
            pl = self.P_lower
            d.positive(self.lower_name, lambda V: V.P - pl * I)
        else:
            d.positive("P > 0", lambda V: V.P)
        if self.P_upper is not None:
            pu = self.P_upper
            d.positive(self.upper_name, lambda V: pu * I - V.P)
        lmis = [c for c in self.constraints if not isinstance(c, (Metzler, Nonnegative))]
        items = ([(c, t) for t in self.terms for c in lmis] if self.order == "vertex"
                 else [(c, t) for c in lmis for t in self.terms])
        for c, (suffix, combo) in items:
            def build(V, c=c, combo=combo):
                M = None
                for coef, i, j in combo:
                    hit = c is target if target is not None else isinstance(
                        c, (Decay, InputToState))
                    G = pair_matrix(c, s, V.P, V[gn[j]], i, V, rate=rate if hit else None)
                    G = G if coef == 1.0 else coef * G
                    M = G if M is None else M + G
                return M
            d.negative(f"{c.label}{suffix}", build)
        for c in self.constraints:
            if isinstance(c, Nonnegative):
                for i, j in self._pairs():
                    suffix = f"[{i + 1}]" if self.gains in ("common", "reduced") else \
                        f"[{i + 1},{j + 1}]"
                    d.nonnegative(f"{c.label}{suffix}",
                                  lambda V, i=i, j=j: V.P @ s.A[i] - V[gn[j]] @ s.C[i],
                                  margin=c.margin)
            if not isinstance(c, Metzler):
                continue
            for i, j in self._pairs():
                suffix = f"[{i + 1}]" if self.gains in ("common", "reduced") else \
                    f"[{i + 1},{j + 1}]"
                d.nonnegative(f"{c.label}{suffix}",
                              lambda V, i=i, j=j: _offdiag(V.P @ s.A[i] - V[gn[j]] @ s.C[i]),
                              margin=c.margin)
                if c.diag_shift is not None:
                    sh = c.diag_shift
                    d.nonnegative(f"{c.label} diag{suffix}",
                                  lambda V, i=i, j=j, sh=sh: _diag(
                                      V.P @ s.A[i] - V[gn[j]] @ s.C[i] + sh * V.P))
        if self.gain_bound is not None:
            import cvxpy as cp
            kb = self.gain_bound
            d.extra(lambda V: [cp.abs(V[g]) <= kb for g in gn])
        return d

    def _pairs(self):
        """Every frozen vertex pair ``(i, j)`` whose error system the LMIs constrain."""
        if self.gains in ("common", "reduced"):
            return [(i, 0) for i in range(self.system.q)]
        if self.gains == "pairs":
            return [(i, j) for i in range(self.system.q) for j in range(self.n_gains)]
        return [(i, i) for i in range(self.system.q)]

    # ---- solve ----------------------------------------------------------------------------
    def solve(self, objective: str | None = None, min_relative_margin: float = MIN_RELATIVE_MARGIN,
              max_condition: float = MAX_CONDITION, raise_on_violation: bool = True
              ) -> ObserverDesign:
        """Solve (``objective``: ``None`` feasibility, ``"gamma"`` or ``"c"`` minimised) and
        certify from the data (:func:`~vehicle_observers.design.certify.certify_observer`,
        thresholds per call).

        Raises :class:`InfeasibleDesign` naming the LMIs when the solver finds no point, and
        :class:`CertificationError` naming the LMI and the vertex when the data certificate
        says "violated" (unless ``raise_on_violation=False``)."""
        if objective not in (None, "gamma", "c"):
            raise ObserverArgumentError(f"{self.name}: objective must be None, 'gamma' or 'c', "
                                        f"got {objective!r}")
        d = self.lmi_design()
        if objective is not None and objective not in d._vars:
            raise ObserverArgumentError(f"{self.name}: objective {objective!r} is not a "
                                        "variable of this design (give BoundedReal(gamma=None) "
                                        "or InputToState(c=None))")
        obj = None if objective is None else (lambda V: V[objective])
        sol = d.solve(objective=obj, raise_on_failure=raise_on_violation,
                      min_relative_margin=min_relative_margin, max_condition=max_condition)
        return self._design(sol, min_relative_margin, max_condition, raise_on_violation)

    def _design(self, sol: LMISolution, min_relative_margin: float, max_condition: float,
                raise_on_violation: bool) -> ObserverDesign:
        """The :class:`ObserverDesign` of a solver's solution: gains ``L_j = P^-1 K_j`` and
        the data certificate."""
        from vehicle_observers.design.certify import certify_observer

        P = sol["P"]
        L = np.array([np.linalg.solve(P, sol[f"{self.gain_name}{j}"])
                      for j in range(self.n_gains)])
        gamma = self._value(sol, BoundedReal, "gamma")
        c = self._value(sol, InputToState, "c")
        cert = certify_observer(self, P, L, gamma=gamma, c=c,
                                min_relative_margin=min_relative_margin,
                                max_condition=max_condition)
        des = ObserverDesign(self, P, L, gamma, c, cert, sol)
        if raise_on_violation and cert.status == "violated":
            w = cert.reason()
            raise CertificationError(f"{self.name}: the data certificate rejects the solution: "
                                     f"{w} (solver status {sol.status!r})",
                                     lmi=cert.worst_name(), status=sol.status)
        return des

    def _value(self, sol, kind, var):
        for c in self.constraints:
            if isinstance(c, kind):
                v = getattr(c, var)
                return float(sol[var]) if v is None else float(v)
        return None

    # ---- optimise -> back off -> certify -------------------------------------------------
    def _with(self, old, new) -> "ObserverSynthesis":
        return self.replace(constraints=[new if c is old else c for c in self.constraints])

    def _feasible(self, syn, **kw):
        try:
            return syn.solve(**kw)
        except InfeasibleDesign:
            return None

    def maximise_decay(self, hi: float, lo: float = 0.0, tol: float = 1e-3,
                       backoff: float = 0.05, compiled: bool = True, **kw) -> OptimisedDesign:
        """Largest decay rate ``alpha`` of the (single) :class:`Decay` or
        :class:`InputToState` constraint, by bisection on ``[lo, hi]`` to relative/absolute
        ``tol`` (``He(P A - K C) + 2 alpha P < 0`` is a generalised eigenvalue problem:
        feasibility is monotone in ``alpha``), then the design at ``alpha (1 - backoff)``
        (certified with a real margin). ``kw``: thresholds of :meth:`solve`.

        A step is feasible when the solver finds a point whose data certificate is not
        "violated". ``compiled=True``: the steps solve one problem compiled once with the
        decay requirement as a cvxpy Parameter (:class:`CompiledBisection`: cvxpy's
        canonicalisation once for the whole bisection, then per step one matrix-vector
        product and a Clarabel solve on the substituted data); ``False``: each step poses and
        canonicalises its own problem (:meth:`solve`). Both solve the same conic problem at
        each step (data equal to round-off); the backed-off design is solved by
        :meth:`solve` either way, so it is the same array for the same optimum."""
        who = f"{self.name}: maximise_decay"
        c0 = decay_target(who, self.constraints, lo, hi, backoff)

        def at(a):
            return self._with(c0, dataclasses.replace(c0, alpha=a))

        if compiled:
            feasible = CompiledBisection(self).solve
        else:
            def feasible(a, **th):
                return self._feasible(at(a), raise_on_violation=False, **th)

        a_lo, best = bisect_decay(lambda a: feasible(a, **kw), lo, hi, tol, who, c0.label)
        value = a_lo * (1.0 - backoff)
        design = at(value).solve(**kw)
        return OptimisedDesign("alpha", a_lo, value, backoff, design, best)

    def minimise(self, backoff: float = 0.05, **kw) -> OptimisedDesign:
        """Smallest ``gamma`` (:class:`BoundedReal` with ``gamma=None``) or ``c``
        (:class:`InputToState` with ``c=None``), then the design re-solved with the bound
        fixed at ``optimum (1 + backoff)`` (a feasibility problem whose solution has a real
        margin)."""
        who = f"{self.name}: minimise"
        _backoff_ok(who, backoff)
        free = [c for c in self.constraints
                if (isinstance(c, BoundedReal) and c.gamma is None)
                or (isinstance(c, InputToState) and c.c is None)]
        if len(free) != 1:
            raise ObserverArgumentError(f"{who}: needs exactly one free gamma or c")
        c0 = free[0]
        var = "gamma" if isinstance(c0, BoundedReal) else "c"
        opt = self.solve(objective=var, raise_on_violation=False, **kw)
        optimum = opt.gamma if var == "gamma" else opt.c
        value = optimum * (1.0 + backoff)
        design = self._with(c0, dataclasses.replace(c0, **{var: value})).solve(**kw)
        return OptimisedDesign(var, optimum, value, backoff, design, opt)


def bisect_decay(feasible, lo: float, hi: float, tol: float, who: str, label: str):
    """Largest decay rate ``alpha`` in ``[lo, hi]`` (to relative/absolute ``tol``) at which
    ``feasible(alpha)`` returns a design whose data certificate is not "violated" (``None``:
    no point), feasibility being monotone in ``alpha``; ``hi`` is tried first. Returns
    ``(alpha, design at alpha)``; :class:`InfeasibleDesign` naming ``label`` if ``lo``
    fails."""
    def ok(d):
        return d is not None and d.status != "violated"

    best = feasible(lo)
    if not ok(best):
        raise InfeasibleDesign(f"{who}: infeasible already at alpha = {lo:g}", lmi=label)
    a_lo, a_hi = lo, hi
    top = feasible(hi)
    if ok(top):
        a_lo, best = hi, top
    while a_hi - a_lo > tol * max(1.0, a_lo) and a_lo < hi:
        mid = 0.5 * (a_lo + a_hi)
        des = feasible(mid)
        if ok(des):
            a_lo, best = mid, des
        else:
            a_hi = mid
    return a_lo, best


def _backoff_ok(who, b):
    if not (np.ndim(b) == 0 and np.isfinite(b) and 0 <= b < 1):
        raise ObserverArgumentError(f"{who}: backoff must be a fraction in [0, 1), got {b!r}")


def decay_target(who: str, constraints, lo: float, hi: float, backoff: float,
                 inner=lambda c: c):
    """The one :class:`Decay` / :class:`InputToState` of ``constraints`` (seen through
    ``inner``, e.g. an :class:`OnVertices` wrapper's constraint) that a decay bisection on
    ``[lo, hi]`` varies, after checking the bracket and the back-off fraction; one
    :class:`ObserverArgumentError` naming ``who`` otherwise."""
    tgt = [c for c in constraints if isinstance(inner(c), (Decay, InputToState))]
    if len(tgt) != 1:
        raise ObserverArgumentError(f"{who}: needs exactly one Decay or InputToState "
                                    "constraint to vary")
    if not (0 <= lo < hi and np.isfinite(hi)):
        raise ObserverArgumentError(f"{who}: need 0 <= lo < hi < inf, got [{lo}, {hi}]")
    _backoff_ok(who, backoff)
    return tgt[0]


def design_observer(system: PolytopicSystem, constraints=(), objective: str | None = None,
                    **kw) -> ObserverDesign:
    """One call: ``ObserverSynthesis(system, constraints, **kw).solve(objective)``."""
    solve_kw = {k: kw.pop(k) for k in ("min_relative_margin", "max_condition",
                                       "raise_on_violation") if k in kw}
    return ObserverSynthesis(system, constraints, **kw).solve(objective, **solve_kw)


def timed_solve(syn: ObserverSynthesis, **kw) -> tuple[ObserverDesign, float, float]:
    """``(design, solver seconds, total seconds)`` of one :meth:`ObserverSynthesis.solve`
    (the speed bench's ratio total / solver)."""
    t0 = time.perf_counter()
    des = syn.solve(**kw)
    return des, des.solution.solve_time, time.perf_counter() - t0



# ---- a problem compiled once, solved at many parameter values ----------------------------
class CompiledLMI:
    """A DPP cvxpy problem compiled once; each point only substitutes numbers.

    A DPP problem's conic data is affine in its parameters ``theta`` (every entry of every
    parameter; cvxpy's own parameter tensor): ``A(theta) = A_0 + sum_k theta_k (A_k - A_0)``,
    the same for ``b`` and ``c``, where ``A_0`` is the data at ``theta = 0`` and ``A_k`` at the
    ``k``-th unit vector. They are computed here once through cvxpy
    (``Problem.get_problem_data``, so cvxpy's own canonicalisation and cone formatting),
    stored on one union sparsity pattern, and each point costs one matrix-vector product.
    The solver object (Clarabel) is built once and then only receives new data
    (``DefaultSolver.update``: no re-allocation, no new symbolic factorisation; the
    interior-point iterations start afresh; ``reuse = False`` builds a new one per point).
    The decision variables are recovered from the solver's primal vector by the linear map
    cvxpy's reductions apply to it (found once by inverting the chain on unit vectors).

    Parameters
    ----------
    problem : a DPP ``cvxpy.Problem`` with a linear objective.
    params : sequence of ``cvxpy.Parameter`` s, in the order :meth:`solve` takes values.
    variables : dict name -> ``cvxpy.Variable`` whose values :meth:`solve` returns.
    """

    OK = ("Solved", "AlmostSolved")

    def __init__(self, problem, params, variables: dict):
        import clarabel
        import cvxpy as cp
        import scipy.sparse as sp
        from cvxpy.reductions.solution import Solution
        from cvxpy.reductions.solvers.conic_solvers.clarabel_conif import (
            dims_to_solver_cones,
        )

        if not problem.is_dpp():
            raise ObserverArgumentError("CompiledLMI: the problem is not DPP")
        self.params, self.variables = list(params), dict(variables)
        # probes: every parameter 0, then one entry at a time set to +1 (-1 if nonpositive)
        probes = [(None, 0, 0.0)] + [(m, k, -1.0 if p.is_nonpos() else 1.0)
                                     for m, p in enumerate(self.params) for k in range(p.size)]
        datas = []
        for m, k, v in probes:
            for mm, p in enumerate(self.params):
                x = np.zeros(p.size)
                if mm == m:
                    x[k] = v
                p.value = x.reshape(p.shape) if p.shape else float(x[0])
            data, chain, inv = problem.get_problem_data(solver="CLARABEL")
            datas.append(data)
        if "P" in datas[0] and datas[0]["P"].nnz:
            raise ObserverArgumentError("CompiledLMI: linear objectives only")
        As = [sp.csc_array(d["A"]) for d in datas]
        pattern = sp.csc_array(sum(abs(A) for A in As))
        pattern.sum_duplicates()
        pattern.sort_indices()
        r = pattern.indices                              # csc order: column by column
        c = np.repeat(np.arange(pattern.shape[1]), np.diff(pattern.indptr))
        vals = [np.asarray(A[r, c]).ravel() for A in As]
        self._A = sp.csc_array((vals[0].copy(), pattern.indices.copy(), pattern.indptr.copy()),
                               shape=pattern.shape)
        scale = np.array([v for _, _, v in probes[1:]])
        self._a0, self._b0, self._c0 = vals[0], datas[0]["b"], datas[0]["c"]
        self._Da = np.column_stack([v - vals[0] for v in vals[1:]]) / scale
        self._Db = np.column_stack([d["b"] - self._b0 for d in datas[1:]]) / scale
        self._Dc = np.column_stack([d["c"] - self._c0 for d in datas[1:]]) / scale
        self._P = sp.csc_array((len(self._c0), len(self._c0)))
        self._cones = dims_to_solver_cones(datas[0]["dims"])
        self._settings = clarabel.DefaultSettings()
        self._settings.verbose = False
        self._solver = None
        self._clarabel = clarabel
        #: re-use the solver object with new data (``False``: a new solver per point)
        self.reuse = True
        #: wall time [s] spent inside the solver's ``solve`` calls, summed (Clarabel's own
        #: ``solve_time`` counts a little more: its internal timer)
        self.solve_wall = 0.0
        # primal recovery: cvxpy's reductions map the solver's x linearly to the variables
        vid = inv[-1][chain.solver.VAR_ID]
        nx = len(self._c0)

        def recover(x):
            sol = Solution(cp.OPTIMAL, 0.0, {vid: x}, {}, {})
            for red, idata in reversed(list(zip(chain.reductions[:-1], inv[:-1]))):
                sol = red.invert(sol, idata)
            return {n: np.asarray(sol.primal_vars[v.id], float).reshape(v.shape, order="F")
                    for n, v in self.variables.items()}

        zero = recover(np.zeros(nx))
        cols = [recover(np.eye(nx)[k]) for k in range(nx)]
        self._off = {n: zero[n].ravel() for n in zero}
        self._map = {n: np.column_stack([cols[k][n].ravel() - self._off[n]
                                         for k in range(nx)]) for n in zero}
        self._shape = {n: zero[n].shape for n in zero}

    def theta(self, values) -> np.ndarray:
        """The flat parameter vector of ``values`` (one array or number per parameter)."""
        if len(values) != len(self.params):
            raise ObserverArgumentError(f"CompiledLMI: {len(self.params)} parameter values "
                                        f"expected, got {len(values)}")
        out = []
        for p, v in zip(self.params, values):
            v = np.asarray(v, dtype=float)
            if v.size != p.size:
                raise ObserverArgumentError(f"CompiledLMI: parameter {p.name()} has {p.size} "
                                            f"entries, got {v.size}")
            out.append(v.reshape(p.shape).ravel() if p.shape else v.ravel())
        return np.concatenate(out)

    def data(self, values):
        """``(A, b, c)`` of the conic problem at parameter values ``values``."""
        th = self.theta(values)
        self._A.data[:] = self._a0 + self._Da @ th       # same pattern: the values only
        return self._A, self._b0 + self._Db @ th, self._c0 + self._Dc @ th

    def solve(self, values):
        """Solve at parameter ``values`` (one array or number per parameter, in the order of
        ``params``).

        Returns ``(values, status, solver_seconds)``: ``values`` dict name -> array (``None``
        unless Clarabel's status is ``Solved`` or ``AlmostSolved``), Clarabel's status string
        and its own ``solve_time`` [s]."""
        A, b, c = self.data(values)
        if self.reuse and self._solver is not None and self._solver.is_data_update_allowed():
            self._solver.update(q=c, A=A, b=b)
        else:
            self._solver = self._clarabel.DefaultSolver(self._P, c, A, b, self._cones,
                                                        self._settings)
        t0 = time.perf_counter()
        res = self._solver.solve()
        self.solve_wall += time.perf_counter() - t0
        status = str(res.status)
        if status not in self.OK:
            return None, status, float(res.solve_time)
        x = np.asarray(res.x, float)
        vals = {n: (self._off[n] + self._map[n] @ x).reshape(self._shape[n])
                for n in self._map}
        return vals, status, float(res.solve_time)


class CompiledBisection:
    """The feasibility problem of an :class:`ObserverSynthesis` compiled once
    (:class:`CompiledLMI`) with the decay requirement of its single :class:`Decay` /
    :class:`InputToState` constraint as a cvxpy Parameter, for the bisection of
    :meth:`ObserverSynthesis.maximise_decay`.

    The Parameter is ``alpha`` [1/s] (continuous time: ``He(P A_i - K_j C_i) + 2 alpha P``;
    ``InputToState``: ``... + alpha P``) or, for a discrete-time ``Decay``, the disk radius
    ``rho = exp(-alpha dt)`` of ``[[-rho P, P A_i - K_j C_i], [*, -rho P]] < 0``: each enters
    the LMIs affinely, so the problem is DPP and the solver's data is affine in it. Every
    other constraint, the normalisations, the strictness ``eps`` and the gain bound are posed
    by :meth:`ObserverSynthesis.lmi_design` exactly as :meth:`ObserverSynthesis.solve` poses
    them. :meth:`solve` returns what :meth:`ObserverSynthesis.solve` returns at that ``alpha``
    (``raise_on_violation=False``): the builders' certificate and the data certificate
    (:func:`~vehicle_observers.design.certify.certify_observer`) of the solution, or ``None``
    where the solver finds no point.

    With ``target``, an :class:`InRegion` constraint of a disk (:func:`~vehicle_observers.
    design.lmi.disk`, any center), the Parameter is instead that disk's radius ``R``
    [1/s] (``[[-R P, q P + P A_i - K_j C_i], [*, -R P]] < 0``, :func:`disk_lmi`, affine in
    ``R``), every other constraint (a ``Decay`` included) posed with its number, and
    :meth:`solve` takes the radius (Ichalal 2011 (36), the radius bisection of
    :func:`vehicle_observers.observers.dmvt.min_feasible_radius`).

    Parameters
    ----------
    synthesis : the design; its one ``Decay`` / ``InputToState`` constraint is varied.
    reuse : ``False`` (default): a new Clarabel solver per step on the substituted data, so
        each step's iterates are those of :meth:`ObserverSynthesis.solve` on the same problem
        (the data agree to round-off; the point returned by a feasibility problem is one of
        many, and a solver updated in place keeps the equilibration of its first data, which
        moves that point by about 1 % of ``P``). ``True``: the solver updated in place
        (``CompiledLMI.reuse``).
    """

    #: Clarabel's statuses with a primal point, and cvxpy's name of each (cvxpy's
    #: ``CLARABEL.STATUS_MAP``: a point is returned and certified for these)
    STATUS = {"Solved": "optimal", "AlmostSolved": "optimal_inaccurate",
              "MaxIterations": "user_limit", "MaxTime": "user_limit"}

    def __init__(self, synthesis: ObserverSynthesis, reuse: bool = False, target=None):
        import cvxpy as cp

        if target is None:
            tgt = [c for c in synthesis.constraints if isinstance(c, (Decay, InputToState))]
            if len(tgt) != 1:
                raise ObserverArgumentError(f"{synthesis.name}: CompiledBisection needs exactly "
                                            "one Decay or InputToState constraint to vary")
            target = tgt[0]
        elif not any(c is target for c in synthesis.constraints) or not isinstance(
                target, InRegion) or disk_center(target.region) is None:
            raise ObserverArgumentError(f"{synthesis.name}: CompiledBisection target must be "
                                        "one of the synthesis' constraints, an InRegion of a disk")
        self.synthesis, self.target = synthesis, target
        #: the Parameter is a disk's radius (else a decay requirement)
        self.radius = isinstance(target, InRegion)
        self.discrete = isinstance(self.target, Decay) and synthesis.system.discrete
        self.rate = cp.Parameter(nonneg=True, name="R" if self.radius else
                                 "rho" if self.discrete else "alpha")
        d = synthesis.lmi_design(rate=self.rate, target=target if self.radius else None)
        self._exprs, self._raw = d._vars, d._raw
        prob = cp.Problem(cp.Minimize(0), d._cvx_constraints())
        self.compiled = CompiledLMI(prob, [self.rate],
                                    {k: r for k, r in d._raw.items() if r is not None})
        self.compiled.OK = tuple(self.STATUS)
        self.compiled.reuse = bool(reuse)

    def at(self, x: float) -> ObserverSynthesis:
        """The synthesis with the varied requirement at ``x`` (a decay rate, or the disk's
        radius; the disk keeps its center and a label of its own)."""
        if not self.radius:
            return self.synthesis._with(self.target, dataclasses.replace(self.target, alpha=x))
        t = self.target
        reg = disk(x, disk_center(t.region))
        label = None if t.label == f"region {t.region.name}" else t.label
        return self.synthesis._with(t, InRegion(reg, label=label))

    def value(self, alpha: float) -> float:
        """The Parameter's value at decay rate ``alpha``: ``alpha``, or ``exp(-alpha dt)``
        (discrete-time ``Decay``, as :func:`decay_region`); a radius as it is."""
        if self.discrete:
            return float(np.exp(-alpha * self.synthesis.system.dt))
        return float(alpha)

    def solve(self, alpha: float, min_relative_margin: float = MIN_RELATIVE_MARGIN,
              max_condition: float = MAX_CONDITION) -> ObserverDesign | None:
        """The design at decay rate ``alpha`` (or at the disk radius ``alpha`` with a disk
        ``target``; its synthesis the original one with that requirement), certified from the
        data; ``None`` if the solver finds no point. Its
        ``solution.solve_time`` is the wall time of the substitution, the solve and the
        recovery of the variables [s]; ``solution.solver_seconds`` Clarabel's own."""
        syn = self.at(alpha)
        t0 = time.perf_counter()
        vals, status, own = self.compiled.solve((self.value(alpha),))
        wall = time.perf_counter() - t0
        if vals is None:
            return None
        values = Values()
        for k, expr in self._exprs.items():
            raw = self._raw[k]
            if raw is None:
                values[k] = np.array(expr, dtype=float)
            elif raw is expr:
                values[k] = np.array(vals[k], dtype=float)
            else:                                # e.g. a diagonal P = diag(d)
                raw.value = vals[k]
                values[k] = np.array(expr.value, dtype=float)
        d = syn.lmi_design()
        cert = d.certify(values, min_relative_margin, max_condition)
        sol = LMISolution(d.name, values, cert, self.STATUS[status], wall, None, own)
        return syn._design(sol, min_relative_margin, max_condition, False)


def decay_disk_problem(system: PolytopicSystem, eps: float = 1e-7, P_lower: float = 1.0):
    """The DPP problem of :func:`decay_disk_map` with cvxpy Parameters ``alpha``, ``R``.

    Returns ``(problem, alpha, R, P, K)`` (the parameters and the variables ``P`` (n, n),
    ``K = P L`` (n, p))."""
    import cvxpy as cp

    if system.discrete:
        raise ObserverArgumentError("decay_disk_map: continuous-time systems only")
    n, p = system.n, system.p
    a_par, r_par = cp.Parameter(nonneg=True), cp.Parameter(nonneg=True)
    P = cp.Variable((n, n), symmetric=True)
    K = cp.Variable((n, p))
    I = np.eye(n)
    cons = [P - P_lower * I >> eps * I]
    for i in range(system.q):
        PA = P @ system.A[i] - K @ system.C[i]
        cons.append(PA + PA.T + 2 * a_par * P << -eps * I)
        D = cp.bmat([[-r_par * P, PA], [PA.T, -r_par * P]])
        cons.append((D + D.T) / 2 << -eps * np.eye(2 * n))
    return cp.Problem(cp.Minimize(0), cons), a_par, r_par, P, K


def decay_disk_map(system: PolytopicSystem, alphas, radii, eps: float = 1e-7,
                   P_lower: float = 1.0, **thresholds) -> dict:
    """Feasibility map of ``Decay(alpha) + InRegion(disk(R))`` (common gain, continuous time)
    on the grid ``alphas x radii``, the problem built and compiled **once** with cvxpy
    Parameters ``alpha``, ``R`` (:class:`CompiledLMI`: each point only substitutes numbers
    in the solver's data):

        P - P_lower I > eps I,   He(P A_i - K C_i) + 2 alpha P < -eps I,
        [[-R P, P A_i - K C_i], [(P A_i - K C_i)^T, -R P]] < -eps I     (i = 1..q).

    Every solved point is certified from the data by :func:`certify_observers` (the LMIs
    rebuilt in numpy from ``A_i, C_i``, ``L = P^-1 K``, ``P``; one batched eigenvalue call
    for all points, each certificate the one :func:`certify_observer` gives alone).

    Returns ``{"alpha", "R", "status" (na, nR) str ("infeasible" where the solver found no
    point), "solver_s" (Clarabel's own ``solve_time``, summed), "solver_wall_s" (wall time
    inside Clarabel's ``solve`` calls, summed), "build_s" (posing and compiling the
    problem), "solve_s" (substituting, solving, recovering P and K: solver included),
    "certify_s", "total_s"}`` [s]."""
    from vehicle_observers.design.certify import certify_observers

    t_start = time.perf_counter()
    prob, a_par, r_par, P, K = decay_disk_problem(system, eps, P_lower)
    compiled = CompiledLMI(prob, [a_par, r_par], {"P": P, "K": K})
    t_built = time.perf_counter()
    alphas, radii = np.asarray(alphas, float), np.asarray(radii, float)
    status = np.full((len(alphas), len(radii)), "infeasible", dtype=object)
    solver = 0.0
    items, where = [], []
    decays = [Decay(float(a)) for a in alphas]
    regions = [InRegion(disk(float(R))) for R in radii]
    for ia, a in enumerate(alphas):
        for ir, R in enumerate(radii):
            vals, _, st = compiled.solve((a, R))
            solver += st
            if vals is None:
                continue
            syn = ObserverSynthesis(system, [decays[ia], regions[ir]], P_lower=P_lower,
                                    eps=eps)
            Pv = vals["P"]
            items.append((syn, Pv, np.linalg.solve(Pv, vals["K"])[None], None, None))
            where.append((ia, ir))
    t_solved = time.perf_counter()
    for (ia, ir), cert in zip(where, certify_observers(items, **thresholds)):
        status[ia, ir] = cert.status
    t_end = time.perf_counter()
    return {"alpha": alphas, "R": radii, "status": status, "solver_s": solver,
            "solver_wall_s": compiled.solve_wall, "build_s": t_built - t_start, "solve_s": t_solved - t_built,
            "certify_s": t_end - t_solved, "total_s": t_end - t_start}
