"""Parameter-dependent Lyapunov functions with bounded membership rates (continuous time),
constraints on other vertex lists, and several modes designed in one problem.

Model
-----
A continuous-time polytopic / TS system (:class:`~vehicle_observers.design.system.
PolytopicSystem`) with memberships whose derivatives are bounded, ``|dh_k/dt| <= phi_k``
(``system.rate_bounds``, (q,) [1/s]), and the observer error
``e' = (A(h) - L(h) C(h)) e + (E(h) - L(h) D(h)) w``. The Lyapunov function is

    V(e, h) = e^T P(h) e,        P(h) = sum_k h_k P_k        (one P_k per vertex).

Because ``sum_k h_k = 1``, ``sum_k dh_k/dt = 0`` and, for every symmetric ``M``,

    dP/dt = sum_k (dh_k/dt) P_k = sum_k (dh_k/dt) (P_k + M) <= sum_k phi_k (P_k + M) =: R

whenever ``P_k + M >= 0`` (Mozelli, Palhares & Avellar, "A systematic approach to improve
multiple Lyapunov function stability and stabilization conditions for fuzzy systems",
Information Sciences 179(8), 2009: their slack matrix ``M``;
``slack=False`` sets ``M = 0``: Tanaka, Hori & Wang, "A multiple Lyapunov function approach
to stabilization of fuzzy control systems", IEEE TFS 11(4), 2003: ``R = sum_k phi_k P_k``
with ``P_k > 0``). With ``K_k = P_k L_k`` the LMIs at the pair ``(i, j)``
(Lyapunov matrix and gain ``i``, plant vertex ``j``; ``He(X) = X + X^T``) are

================== ===========================================================================
``Decay(alpha)``   ``G_ij = He(P_i A_j - K_i C_j) + 2 alpha P_i + R < 0``
                   (``V' <= -2 alpha V``)
``InputToState``   ``G_ij = [[He(P_i A_j - K_i C_j) + alpha P_i + R, P_i E_j - K_i D_j],
(alpha, c)         [*, -c I]] < 0`` (``V' <= -alpha V + c |w|^2``)
``Metzler``        ``P_k`` diagonal and every off-diagonal entry of ``P_k A_k - K_k C_k`` >=
                   ``margin`` (the certificate: off-diagonal of ``A_k - L_k C_k`` >= 0)
================== ===========================================================================

plus ``P_k - P_lower I > 0`` and, with the slack, ``P_k + M > 0``. Coupling of the vertices:

``"relaxed"`` (default)
    ``P(h) (A(h) - L(h) C(h)) = sum_i sum_j h_i h_j (P_i A_j - K_i C_j)`` for the gain
    ``L(h) = P(h)^-1 sum_k h_k K_k``: a double sum even with a common ``C``, relaxed as in
    :mod:`~vehicle_observers.design.synthesis` (Tuan et al. 2001: ``G_ii < 0``,
    ``2/(q-1) G_ii + G_ij + G_ji < 0``; or Tanaka et al. 1998). Every ``h(t)`` in the simplex
    with ``|dh_k/dt| <= phi_k`` then gets the decrease of the table. Labels ``label[i,j]``.
``"vertex"``
    ``G_kk < 0`` only, with the PDC gain ``L(h) = sum_k h_k L_k``: the conditions as Ifqir,
    Ait-Oufroukh, Ichalal & Mammar (GTAA 2017) state their Theorem 2 (19). They give the
    decrease at the vertices (frozen ``h = e_k``) but neglect the cross terms ``P_i L_j``
    (``i != j``) of the blended loop, so they prove nothing between the vertices; the
    certificate says so only by its name. Labels ``label[k]``.

Constraints on another vertex list: :class:`~vehicle_observers.design.constraints.OnVertices`
states a constraint on the vertices ``A~_k, C~_k`` of another system with the design's
``P_k, K_k`` (Ifqir's Metzler condition (20) on the lower bounds ``A^-_k`` while (19) is on
the upper bounds ``A^+_k``).

Several modes: ``modes`` is a list of systems (the modes of a switched system, each with its
own vertices and rate bounds); each mode has its own ``P_k, K_k, M`` and bound ``c``, and
:meth:`ParameterDependentSynthesis.solve` minimises ``sum_m c_m`` in one problem (Ifqir 2017
Theorem 2 with one ``gamma_i`` per mode; ``per_mode_c=False``: one shared ``c``). With several
modes the labels are ``label[m,k]`` / ``label[m:i,j]`` (1-based).

As ``phi -> inf`` the rate term forces ``P_k + M -> 0``, i.e. ``P_k = -M`` for every ``k``: the
slack form tends to the common-``P`` design (whose solutions it always contains: ``P_k = P``,
``M = -P`` makes ``R = 0``), while without the slack ``R >= phi q P_lower I`` grows without
bound and the LMIs become infeasible.

Discrete time is not posed here: with ``L(h) = P(h)^-1 K(h)`` the next step's ``P(h_{k+1})``
multiplies ``P(h_k)^-1``, which no change of variables makes affine. The slack variable of de
Oliveira, Bernussou & Geromel (1999) separates the two (gain ``G^-1 W(h)``, LMIs over every
pair ``(h_k, h_{k+1})`` of vertices; Daafouz & Bernussou 2001), which is the discrete-time
slack form of :class:`~vehicle_observers.design.slack.SlackSynthesis`; it needs no bound on
how fast the memberships move (a bound on ``|h_{k+1} - h_k|`` is not used there).

Optimise, back off, certify (as :class:`~vehicle_observers.design.synthesis.ObserverSynthesis`):
:meth:`ParameterDependentSynthesis.minimise` finds the smallest bounds ``c_m`` of an
``InputToState(c=None)`` (one optimisation), fixes them at ``c_m (1 + backoff)`` and
re-solves the feasibility problem; :meth:`ParameterDependentSynthesis.maximise_decay` finds
the largest ``alpha`` of the single :class:`Decay` / :class:`InputToState` by bisection
(``P_k > 0``, the coefficients of every relaxation positive: feasibility is monotone in
``alpha``) and re-solves at ``alpha (1 - backoff)``. The optimum sits on the boundary of the
feasible set (its certificate at round-off level, "inconclusive"); the backed-off design has
a real margin. Both return an :class:`~vehicle_observers.design.synthesis.OptimisedDesign`
(optimum, backed-off value, the certified design, its margin); the certificate thresholds
are per call.

Every returned design is certified from the data by
:func:`vehicle_observers.design.certify.certify_parameter_dependent` (each LMI rebuilt in
numpy from the vertex matrices, the rate bounds, ``P_k``, ``L_k`` and ``M``, not from the
builders below).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from vehicle_observers.core.errors import CertificationError, InfeasibleDesign, ObserverArgumentError
from vehicle_observers.design.constraints import Decay, InputToState, Metzler, OnVertices
from vehicle_observers.design.lmi import (
    MAX_CONDITION,
    MIN_RELATIVE_MARGIN,
    LMIDesign,
    LMISolution,
    bmat,
)
from vehicle_observers.design.synthesis import (
    RELAXATIONS,
    OptimisedDesign,
    _backoff_ok,
    _diag,
    _offdiag,
    bisect_decay,
    decay_target,
    pair_matrix,
    terms,
)
from vehicle_observers.design.system import PolytopicSystem

COUPLINGS = ("relaxed", "vertex")
#: default variable names (``m`` mode, ``k`` vertex, both 0-based)
NAMES = {"P": "P{m}{k}", "K": "K{m}{k}", "M": "M{m}", "c": "c{m}"}


def rate_term(P_k, M, phi):
    """``R = sum_k phi_k (P_k + M)`` (``M`` None: ``sum_k phi_k P_k``), cvxpy or numpy;
    ``None`` when every ``phi_k`` is 0."""
    R = None
    for Pk, f in zip(P_k, phi):
        if f == 0:
            continue
        t = f * (Pk if M is None else Pk + M)
        R = t if R is None else R + t
    return R


def with_rate(G, R, n: int):
    """``G`` with ``R`` (n, n) added to its leading ``n x n`` block (cvxpy)."""
    if R is None:
        return G
    m = G.shape[0]
    if m == n:
        return G + R
    return G + bmat([[R, np.zeros((n, m - n))], [np.zeros((m - n, n)), np.zeros((m - n, m - n))]])


@dataclass
class ParameterDependentDesign:
    """A solved design: per mode ``m``, ``P[m]`` (q, n, n), ``L[m]`` (q, n, p), ``M[m]``
    (n, n) or ``None``, ``c[m]`` the input-to-state bound (``None`` if none); ``certificate``
    (:class:`~vehicle_observers.design.certify.ObserverCertificate`) rebuilt from the data;
    ``solution`` the solver's :class:`~vehicle_observers.design.lmi.LMISolution`."""

    synthesis: "ParameterDependentSynthesis"
    P: list
    L: list
    M: list
    c: np.ndarray | None
    certificate: object
    solution: LMISolution

    @property
    def status(self) -> str:
        return self.certificate.status


class ParameterDependentSynthesis:
    """Observer LMIs with a vertex-dependent Lyapunov matrix and membership-rate bounds
    (module docstring for the LMIs).

    Parameters
    ----------
    modes : a continuous-time :class:`PolytopicSystem` with ``rate_bounds`` (``phi`` (q,)
        [1/s]), or a list of them (modes solved jointly; equal ``n``, ``p``).
    constraints : :class:`Decay`, :class:`InputToState`, :class:`Metzler`, or any of them
        wrapped in :class:`OnVertices`; at most one :class:`InputToState` (its ``c=None``
        gives one variable per mode, minimised by ``solve("c")``).
    P : ``"symmetric"`` or ``"diagonal"`` ``P_k`` (diagonal needed by :class:`Metzler`).
    slack : use the slack ``M`` of Mozelli et al. 2009 (else ``M = 0``, Tanaka et al. 2003).
    coupling : ``"relaxed"`` or ``"vertex"`` (module docstring).
    relaxation : ``"tuan"`` or ``"tanaka"`` (``coupling="relaxed"``).
    P_lower : normalisation ``P_k - P_lower I > 0`` (``None``: ``P_k > 0``).
    P_upper : ``P_upper I - P_k > 0`` (conditioning bound), ``None`` to omit.
    eps : strictness imposed on the solver (``LMIDesign.eps``).
    per_mode_c : one ``c_m`` per mode (minimise the sum) or one shared ``c``.
    extra : ``fn(V) -> list`` of further cvxpy constraints on the variables (solver side only,
        not certified: e.g. a stricter Metzler entry bound or gain bounds).
    names : variable-name formats overriding :data:`NAMES` (keys ``P``, ``K``, ``M``, ``c``;
        fields ``{m}``, ``{k}``); with ``per_mode_c=False`` the ``c`` name is formatted with
        ``m=""``.
    c_values : fixed bounds ``c_m`` (one per mode) of an ``InputToState(c=None)`` instead of
        variables (the backed-off design of :meth:`minimise`); ``None``: variables.
    name : the design's name in every message.
    """

    def __init__(self, modes, constraints=(), P: str = "symmetric", slack: bool = True,
                 coupling: str = "relaxed", relaxation: str = "tuan",
                 P_lower: float | None = 1.0, P_upper: float | None = None, eps: float = 1e-7,
                 per_mode_c: bool = True,
                 names: dict | None = None, extra=None, c_values=None,
                 name: str = "parameter-dependent design"):
        who = f"ParameterDependentSynthesis {name!r}"
        self._args = dict(modes=modes, constraints=constraints, P=P, slack=slack,
                          coupling=coupling, relaxation=relaxation, P_lower=P_lower,
                          P_upper=P_upper, eps=eps, per_mode_c=per_mode_c, names=names,
                          extra=extra, c_values=c_values, name=name)
        ms = list(modes) if isinstance(modes, (list, tuple)) else [modes]
        if not ms or not all(isinstance(s, PolytopicSystem) for s in ms):
            raise ObserverArgumentError(f"{who}: modes must be a PolytopicSystem or a list of "
                                        "them")
        n, p = ms[0].n, ms[0].p
        for m, s in enumerate(ms):
            if s.discrete:
                raise ObserverArgumentError(f"{who}: mode {m + 1} is discrete-time; the rate "
                                            "bound dP/dt <= R is a continuous-time condition "
                                            "(discrete time: design.slack.SlackSynthesis with "
                                            "lyapunov='slack', the poly-quadratic form)")
            if s.rate_bounds is None:
                raise ObserverArgumentError(f"{who}: mode {m + 1} has no rate_bounds "
                                            "(|dh_k/dt| <= phi_k, [1/s]; zeros for frozen "
                                            "memberships)")
            if (s.n, s.p) != (n, p):
                raise ObserverArgumentError(f"{who}: every mode needs the same n and p")
        cons = list(constraints) or [Decay(0.0)]
        for c in cons:
            inner = c.constraint if isinstance(c, OnVertices) else c
            if not isinstance(inner, (Decay, InputToState, Metzler)):
                raise ObserverArgumentError(f"{who}: unsupported constraint {c!r}; use Decay, "
                                            "InputToState, Metzler or OnVertices of them")
            if isinstance(c, OnVertices):
                if len(c.systems) not in (1, len(ms)):
                    raise ObserverArgumentError(f"{who}: OnVertices needs one system or one "
                                                f"per mode ({len(ms)})")
                for m, s in enumerate(ms):
                    o = c.systems[m if len(c.systems) > 1 else 0]
                    if (o.q, o.n, o.p) != (s.q, n, p):
                        raise ObserverArgumentError(
                            f"{who}: OnVertices system {o.name!r} has (q, n, p) = "
                            f"{(o.q, o.n, o.p)}, mode {m + 1} has {(s.q, n, p)}")
            for m in range(len(ms)):
                sv = self._vertex_system(c, ms, m)
                if isinstance(inner, InputToState) and sv.nw == 0:
                    raise ObserverArgumentError(f"{who}: an input-to-state constraint needs a "
                                                "disturbance matrix E")
        if sum(isinstance(c.constraint if isinstance(c, OnVertices) else c, InputToState)
               for c in cons) > 1:
            raise ObserverArgumentError(f"{who}: at most one InputToState")
        if P not in ("symmetric", "diagonal"):
            raise ObserverArgumentError(f"{who}: P must be 'symmetric' or 'diagonal', got {P!r}")
        if P != "diagonal" and any(isinstance(c.constraint if isinstance(c, OnVertices) else c,
                                              Metzler) for c in cons):
            raise ObserverArgumentError(f"{who}: a Metzler constraint needs P='diagonal'")
        if coupling not in COUPLINGS:
            raise ObserverArgumentError(f"{who}: coupling must be one of {COUPLINGS}, got "
                                        f"{coupling!r}")
        if relaxation not in RELAXATIONS:
            raise ObserverArgumentError(f"{who}: relaxation must be one of {RELAXATIONS}")
        for what, v in (("P_lower", P_lower), ("P_upper", P_upper)):
            if v is not None and not (np.isfinite(v) and v > 0):
                raise ObserverArgumentError(f"{who}: {what} must be finite and > 0 (or None)")
        if P_lower is not None and P_upper is not None and P_upper <= P_lower:
            raise ObserverArgumentError(f"{who}: P_upper must exceed P_lower")
        self.P_upper = P_upper
        nm = dict(NAMES)
        nm.update(names or {})
        self.modes, self.constraints, self.P_kind, self.slack = ms, cons, P, bool(slack)
        self.coupling, self.relaxation, self.P_lower, self.eps = coupling, relaxation, P_lower, eps
        self.per_mode_c, self.names, self.name = bool(per_mode_c), nm, name
        if extra is not None and not callable(extra):
            raise ObserverArgumentError(f"{who}: extra must be a function of the variables")
        self.extra = extra
        if c_values is not None:
            cv = np.asarray(c_values, dtype=float).ravel()
            iss = [self.inner(c) for c in cons if isinstance(self.inner(c), InputToState)]
            if not iss or iss[0].c is not None:
                raise ObserverArgumentError(f"{who}: c_values needs an InputToState(c=None)")
            if cv.shape != (len(ms),) or not np.all(np.isfinite(cv) & (cv > 0)):
                raise ObserverArgumentError(f"{who}: c_values must be {len(ms)} finite numbers "
                                            f"> 0 (one per mode), got {c_values!r}")
            c_values = cv
        self.c_values = c_values

    def replace(self, **kw) -> "ParameterDependentSynthesis":
        """A copy with some arguments changed (e.g. ``constraints=[...]``)."""
        return ParameterDependentSynthesis(**{**self._args, **kw})

    # ---- names and terms ------------------------------------------------------------------
    def var(self, what: str, m: int, k: int = 0) -> str:
        """Name of variable ``what`` (``"P"``, ``"K"``, ``"M"``, ``"c"``) of mode ``m``,
        vertex ``k`` (0-based)."""
        if what == "c" and not self.per_mode_c:
            return self.names["c"].format(m="", k="")
        return self.names[what].format(m=m, k=k)

    def suffix(self, m: int, tail: str) -> str:
        """``[tail]`` (one mode) or ``[m,tail]`` / ``[m:tail]`` (several)."""
        if len(self.modes) == 1:
            return f"[{tail}]"
        return f"[{m + 1}{',' if ',' not in tail else ':'}{tail}]"

    def mode_tag(self, m: int) -> str:
        """``""`` (one mode) or ``[m]`` (1-based): the tag of a per-mode variable."""
        return "" if len(self.modes) == 1 else f"[{m + 1}]"

    def terms(self, m: int):
        """``[(suffix, [(coef, i, j), ...])]`` of mode ``m``: ``sum coef G_ij < 0``."""
        s = self.modes[m]
        if self.coupling == "vertex":
            return [(self.suffix(m, f"{k + 1}"), [(1.0, k, k)]) for k in range(s.q)]
        return [(self.suffix(m, t[1:-1]), combo)
                for t, combo in terms(s, "pdc", s.q, self.relaxation, double_sum=True)]

    @staticmethod
    def _vertex_system(c, modes, m) -> PolytopicSystem:
        if isinstance(c, OnVertices):
            return c.systems[m if len(c.systems) > 1 else 0]
        return modes[m]

    def vertex_system(self, c, m: int) -> PolytopicSystem:
        """The vertex list constraint ``c`` is stated on in mode ``m``."""
        return self._vertex_system(c, self.modes, m)

    @staticmethod
    def inner(c):
        return c.constraint if isinstance(c, OnVertices) else c

    # ---- the LMIs -------------------------------------------------------------------------
    def lmi_design(self) -> LMIDesign:
        """The :class:`LMIDesign` (variables named by :meth:`var`)."""
        n, p = self.modes[0].n, self.modes[0].p
        d = LMIDesign(self.name, eps=self.eps)
        for m, s in enumerate(self.modes):
            for k in range(s.q):
                (d.diagonal if self.P_kind == "diagonal" else d.symmetric)(self.var("P", m, k), n)
                d.matrix(self.var("K", m, k), (n, p))
        if self.slack:
            for m in range(len(self.modes)):
                d.symmetric(self.var("M", m), n)
        iss = [self.inner(c) for c in self.constraints
               if isinstance(self.inner(c), InputToState)]
        if iss and iss[0].c is None and self.c_values is None:
            for cn in dict.fromkeys(self.var("c", m) for m in range(len(self.modes))):
                d.scalar(cn)
        I = np.eye(n)
        lmis = [c for c in self.constraints if not isinstance(self.inner(c), Metzler)]
        for m, s in enumerate(self.modes):
            Pn = [self.var("P", m, k) for k in range(s.q)]
            Kn = [self.var("K", m, k) for k in range(s.q)]
            Mn = self.var("M", m) if self.slack else None
            phi = s.rate_bounds

            def R(V, Pn=Pn, Mn=Mn, phi=phi):
                return rate_term([V[x] for x in Pn], None if Mn is None else V[Mn], phi)

            def build(V, c, combo, m=m, Pn=Pn, Kn=Kn, R=R):
                inner, sv = self.inner(c), self.vertex_system(c, m)
                free = isinstance(inner, InputToState) and inner.c is None
                cv = {"c": (V[self.var("c", m)] if self.c_values is None
                            else float(self.c_values[m])) if free else None}
                Rv = R(V)
                out = None
                for coef, i, j in combo:
                    G = with_rate(pair_matrix(inner, sv, V[Pn[i]], V[Kn[i]], j, cv), Rv, n)
                    G = G if coef == 1.0 else coef * G
                    out = G if out is None else out + G
                return out

            tm = self.terms(m)
            for k in range(s.q):
                sk = self.suffix(m, f"{k + 1}")
                if self.P_lower is not None:
                    d.positive(f"P{sk} - P_lower I > 0",
                               lambda V, x=Pn[k], pl=self.P_lower: V[x] - pl * I)
                else:
                    d.positive(f"P{sk} > 0", lambda V, x=Pn[k]: V[x])
                if self.P_upper is not None:
                    d.positive(f"P_upper I - P{sk} > 0",
                               lambda V, x=Pn[k], pu=self.P_upper: pu * I - V[x])
                if self.slack:
                    d.positive(f"P{sk} + M{self.mode_tag(m)} > 0",
                               lambda V, x=Pn[k], y=Mn: V[x] + V[y])
                if self.coupling == "vertex":
                    for c in lmis:
                        suf, combo = tm[k]
                        d.negative(f"{c.label}{suf}",
                                   lambda V, c=c, combo=combo, b=build: b(V, c, combo))
            if self.coupling == "relaxed":
                for c in lmis:
                    for suf, combo in tm:
                        d.negative(f"{c.label}{suf}",
                                   lambda V, c=c, combo=combo, b=build: b(V, c, combo))
        for c in self.constraints:
            inner = self.inner(c)
            if not isinstance(inner, Metzler):
                continue
            for m, s in enumerate(self.modes):
                sv = self.vertex_system(c, m)
                for k in range(s.q):
                    sk = self.suffix(m, f"{k + 1}")
                    P_, K_ = self.var("P", m, k), self.var("K", m, k)
                    d.nonnegative(f"{inner.label}{sk}",
                                  lambda V, P_=P_, K_=K_, A=sv.A[k], C=sv.C[k]:
                                  _offdiag(V[P_] @ A - V[K_] @ C), margin=inner.margin)
                    if inner.diag_shift is not None:
                        d.nonnegative(f"{inner.label} diag{sk}",
                                      lambda V, P_=P_, K_=K_, A=sv.A[k], C=sv.C[k],
                                      sh=inner.diag_shift:
                                      _diag(V[P_] @ A - V[K_] @ C + sh * V[P_]))
        if self.extra is not None:
            d.extra(self.extra)
        return d

    # ---- solve ----------------------------------------------------------------------------
    def solve(self, objective: str | None = None, min_relative_margin: float = MIN_RELATIVE_MARGIN,
              max_condition: float = MAX_CONDITION, raise_on_violation: bool = True
              ) -> ParameterDependentDesign:
        """Solve (``objective="c"``: minimise ``sum_m c_m``) and certify from the data
        (:func:`~vehicle_observers.design.certify.certify_parameter_dependent`).

        Raises :class:`InfeasibleDesign` when the solver finds no point and
        :class:`CertificationError` naming the LMI when the data certificate says "violated"
        (unless ``raise_on_violation=False``)."""
        from vehicle_observers.design.certify import certify_parameter_dependent

        if objective not in (None, "c"):
            raise ObserverArgumentError(f"{self.name}: objective must be None or 'c'")
        d = self.lmi_design()
        # sum over the modes (a shared c counts once per mode: the same minimiser)
        cnames = [self.var("c", m) for m in range(len(self.modes))]
        if objective == "c" and cnames[0] not in d._vars:
            raise ObserverArgumentError(f"{self.name}: objective 'c' needs InputToState(c=None)")
        obj = None if objective is None else (lambda V: sum(V[x] for x in cnames))
        sol = d.solve(objective=obj, raise_on_failure=raise_on_violation,
                      min_relative_margin=min_relative_margin, max_condition=max_condition)
        P, L, M = [], [], []
        for m, s in enumerate(self.modes):
            Pm = np.array([sol[self.var("P", m, k)] for k in range(s.q)])
            P.append(Pm)
            L.append(np.array([np.linalg.solve(Pm[k], sol[self.var("K", m, k)])
                               for k in range(s.q)]))
            M.append(sol[self.var("M", m)] if self.slack else None)
        iss = [self.inner(c) for c in self.constraints
               if isinstance(self.inner(c), InputToState)]
        cval = None
        if iss and self.c_values is not None:
            cval = self.c_values.copy()
        elif iss:
            cval = (np.array([float(sol[self.var("c", m)]) for m in range(len(self.modes))])
                    if iss[0].c is None else np.full(len(self.modes), iss[0].c))
        cert = certify_parameter_dependent(self, P, L, M, cval,
                                           min_relative_margin=min_relative_margin,
                                           max_condition=max_condition)
        des = ParameterDependentDesign(self, P, L, M, cval, cert, sol)
        if raise_on_violation and cert.status == "violated":
            raise CertificationError(f"{self.name}: the data certificate rejects the solution: "
                                     f"{cert.reason()} (solver status {sol.status!r})",
                                     lmi=cert.worst_name(), status=sol.status)
        return des

    # ---- optimise -> back off -> certify -------------------------------------------------
    def minimise(self, backoff: float = 0.05, **kw) -> OptimisedDesign:
        """Smallest input-to-state bounds ``c_m`` (``InputToState(c=None)``; ``sum_m c_m``
        minimised, :meth:`solve` ``"c"``), then the feasibility problem re-solved with every
        ``c_m`` fixed at ``c_m (1 + backoff)`` (``c_values``): its solution has a real margin.
        ``kw``: thresholds of :meth:`solve` (``min_relative_margin``, ``max_condition``).

        Returns an :class:`~vehicle_observers.design.synthesis.OptimisedDesign` with
        ``quantity = "c"``; ``optimum`` and ``value`` are floats with one mode or a shared
        ``c``, else arrays (modes,). Raises :class:`CertificationError` if the backed-off
        design is "violated"."""
        who = f"{self.name}: minimise"
        _backoff_ok(who, backoff)
        iss = [self.inner(c) for c in self.constraints if isinstance(self.inner(c), InputToState)]
        if not iss or iss[0].c is not None or self.c_values is not None:
            raise ObserverArgumentError(f"{who}: needs an InputToState(c=None) with free c")
        opt = self.solve("c", raise_on_violation=False, **kw)
        value = opt.c * (1.0 + backoff)
        design = self.replace(c_values=value).solve(**kw)
        one = len(self.modes) == 1 or not self.per_mode_c
        return OptimisedDesign("c", float(opt.c[0]) if one else opt.c.copy(),
                               float(value[0]) if one else value, backoff, design, opt)

    def maximise_decay(self, hi: float, lo: float = 0.0, tol: float = 1e-3,
                       backoff: float = 0.05, **kw) -> OptimisedDesign:
        """Largest decay rate ``alpha`` [1/s] of the single :class:`Decay` or
        :class:`InputToState` constraint (possibly in :class:`OnVertices`), by bisection on
        ``[lo, hi]`` to relative/absolute ``tol``
        (:func:`~vehicle_observers.design.synthesis.bisect_decay`: a step is feasible when the
        solver finds a point whose data certificate is not "violated"), then the design at
        ``alpha (1 - backoff)``, certified with a real margin. ``kw``: thresholds of
        :meth:`solve`. Each step poses its own problem (:meth:`solve`)."""
        who = f"{self.name}: maximise_decay"
        c0 = decay_target(who, self.constraints, lo, hi, backoff, self.inner)

        def at(a):
            inner = dataclasses.replace(self.inner(c0), alpha=a)
            new = dataclasses.replace(c0, constraint=inner) if isinstance(c0, OnVertices) \
                else inner
            return self.replace(constraints=[new if c is c0 else c for c in self.constraints])

        def feasible(a):
            try:
                return at(a).solve(raise_on_violation=False, **kw)
            except InfeasibleDesign:
                return None

        a_lo, best = bisect_decay(feasible, lo, hi, tol, who, self.inner(c0).label)
        value = a_lo * (1.0 - backoff)
        return OptimisedDesign("alpha", a_lo, value, backoff, at(value).solve(**kw), best)
