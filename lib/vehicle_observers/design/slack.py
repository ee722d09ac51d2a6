"""Observer synthesis with an L2 gain, a Finsler slack variable and a parameter-dependent
(fuzzy) Lyapunov matrix; and its quadratic (non-relaxed) counterpart.

System: a :class:`~vehicle_observers.design.system.PolytopicSystem` (continuous time below;
discrete time at the end)
(vertices ``A_i, C_i, E_i, D_i``, performance output ``z = H e + Dz_i w``, membership rate
bounds ``|dh_k/dt| <= phi_k`` in ``rate_bounds``). Observer gain ``K_i`` per vertex
(``gains="pdc"``, blended with the plant's memberships; needs a common ``C`` and ``D`` so that
the error ``e' = sum_i h_i ((A_i - K_i C) e + (E_i - K_i D) w)`` is a single sum) or one
common ``K`` (``gains="common"``). For an unknown-input observer this system is the decoupled
one of :func:`vehicle_observers.design.uio.uio_system` and ``K_i`` the UIO's gains.

Lyapunov structures (``lyapunov``):

``"quadratic"``
    ``V = e^T P e``, one ``P``; ``W_i = P K_i``. The non-relaxed conditions (Darouach,
    Zasadzinski & Xu, IEEE TAC 39(3), 1994 with an L2 index; El Youssfi et al. 2020's
    reference [22]).
``"slack"``
    ``V = e^T (sum_k h_k P_k) e`` (fuzzy Lyapunov function), a common slack matrix ``G`` and a
    fixed scalar ``mu > 0`` [s]; ``W_i = G K_i``. Finsler's lemma (de Oliveira & Skelton,
    *Perspectives in Robust Control*, LNCIS 268, 2001) on ``e' = N_h e + B_h w`` with the
    multiplier ``[G; mu G; 0]`` separates ``P_h`` from ``N_h = A_h - K_h C`` (El Youssfi et al.
    2020 Theorem 2; Pipeleers, Demeulenaere, Swevers & Vandenberghe, Systems & Control Letters
    58, 2009). ``P_h' = sum_{k<q} h_k' (P_k - P_q)`` (the memberships sum to 1) is affine in
    ``h'``, so it is enough to check the ``2^(q-1)`` sign patterns ``s`` of
    ``Pdot_s = sum_{k<q} s_k phi_k (P_k - P_q)`` (exact for two vertices, where ``h_2' = -h_1'``;
    the box ``|h_k'| <= phi_k``, ``k < q`` over-bounds the rates for more).

Constraints (:mod:`vehicle_observers.design.constraints`), at vertex ``i``, sign pattern ``s``;
``X_i = P A_i - W_i C`` (quadratic) or ``G A_i - W_i C`` (slack), ``Y_i = P E_i - W_i D`` or
``G E_i - W_i D``, ``g = gamma^2``:

:class:`~vehicle_observers.design.constraints.L2Gain` ``(alpha, gamma)``, quadratic (``l2[i]``)::

    [[He(X_i) + 2 alpha P, Y_i, H^T], [*, -g I, Dz_i^T], [H, Dz_i, -I]] < 0

slack (``l2[i,s]``)::

    [[Pdot_s + 2 alpha P_i + He(X_i), P_i - G + mu X_i^T, Y_i,      H^T  ],
     [*,                              -mu (G + G^T),     mu Y_i,   0    ],
     [*,                              *,                 -g I,     Dz_i^T],
     [H,                              0,                 Dz_i,     -I   ]] < 0

:class:`~vehicle_observers.design.constraints.Decay` ``(alpha)``: the first block (two blocks
for the slack form) of the same matrices without ``w`` (:func:`.uio.slack_decay_lmi` plus
``Pdot_s``); homogeneous, so ``P - P_lower I > 0`` (each ``P_k``) fixes the scale.

:class:`~vehicle_observers.design.constraints.SpectralDisk` ``(radius)``: the Stein / extended
(de Oliveira 1999) LMIs of that class.

Every returned design is certified twice: by the builders' own re-evaluation
(:class:`~vehicle_observers.design.lmi.LMISolution`) and from the data by
:func:`vehicle_observers.design.certify.certify_slack_observer`, which rewrites every LMI in
numpy from the system's arrays, the gains ``K_i``, ``P`` (``P_k``), ``G`` and ``g`` alone and
adds the poles and the H-infinity norm (Hamiltonian bisection) of every frozen error system.

Fast continuous dynamics are best solved in a scaled time unit
(:meth:`~vehicle_observers.design.system.PolytopicSystem.time_scaled`).

Discrete time (``system.time == "discrete"``, sample period ``dt`` [s]): the error is
``e_{k+1} = N_h e_k + B_h w_k`` with ``N_i = A_i - K_i C``, ``B_i = E_i - K_i D``, and the
decay rate ``alpha`` [1/s] is the radius ``r = exp(-alpha dt)``: ``V_{k+1} - r^2 V_k +
|z_k|^2 - g |w_k|^2 < 0``. Same ``X_i, Y_i`` as above.

``"quadratic"``, Stein form (``decay[i]``) and discrete bounded-real lemma (``l2[i]``; Boyd
et al. 1994 Sec. 2.7.3 / de Souza & Xie 1992, with ``Dz_i`` and the decay radius)::

    [[-r^2 P, X_i^T], [X_i, -P]] < 0

    [[-r^2 P, 0,    X_i^T, H^T   ],
     [0,      -g I, Y_i^T, Dz_i^T],
     [X_i,    Y_i,  -P,    0     ],
     [H,      Dz_i, 0,     -I    ]] < 0

``"slack"``: ``V_k = e_k^T P(h_k) e_k`` with ``P(h) = sum_k h_k P_k``; the next step's
``P(h_{k+1})`` enters, so the LMIs are stated on every vertex pair ``(i, j)`` (vertex ``i``
now, ``j`` at the next step: no bound on how fast the memberships move, ``rate_bounds`` and
``mu`` are not used), with the extended (slack) form of de Oliveira, Bernussou & Geromel
(Systems & Control Letters 37, 1999, Thm 1), for time-varying memberships Daafouz &
Bernussou (Systems & Control Letters 43, 2001, Thm 3, "poly-quadratic stability") and for TS
observers Guerra & Vermeiren (Automatica 40(5), 2004) (``decay[i,j]``, ``l2[i,j]``)::

    [[-r^2 P_i, X_i^T], [X_i, P_j - G - G^T]] < 0

    [[-r^2 P_i, 0,    X_i^T,           H^T   ],
     [0,        -g I, Y_i^T,           Dz_i^T],
     [X_i,      Y_i,  P_j - G - G^T,   0     ],
     [H,        Dz_i, 0,               -I    ]] < 0

Since ``P_j - G - G^T >= -G P_j^-1 G^T`` (``(G - P_j) P_j^-1 (G - P_j)^T >= 0``), the
congruence with ``diag(I, I, G^-1, I)`` and a Schur complement give ``[N_i B_i]^T P_j [N_i
B_i] - diag(r^2 P_i, g I) + [H Dz_i]^T [H Dz_i] < 0`` for every ``(i, j)``, which is affine
in ``h_k`` (through ``i``) and in ``h_{k+1}`` (through ``j``): ``V`` decreases by ``r^2`` and
the L2 gain is below ``gamma`` for every membership sequence (arbitrary switching included).
With ``P_k = G = P`` the slack form is the quadratic one (it is never more conservative). The
gain ``K_h = G^-1 W_h`` is blended with the memberships of the current step.
:class:`SpectralDisk` ``(radius)`` bounds the poles of each frozen ``N_i`` by ``radius`` (a
dimensionless disk radius in discrete time; its LMIs are the ones above, frozen ``j = i``).
The data certificate adds the spectral radius of each ``N_i`` (``< r``, ``< 1``) and the
discrete H-infinity norm of every frozen ``(N_i, B_i, H, Dz_i)``.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from vehicle_observers.core.errors import CertificationError, InfeasibleDesign, ObserverArgumentError
from vehicle_observers.design.constraints import (
    SLACK_CONSTRAINTS,
    Decay,
    L2Gain,
    SpectralDisk,
)
from vehicle_observers.design.lmi import MAX_CONDITION, MIN_RELATIVE_MARGIN, LMIDesign, LMISolution, bmat
from vehicle_observers.design.system import PolytopicSystem

LYAPUNOV = ("quadratic", "slack")


def sign_patterns(q: int) -> list[tuple[int, ...]]:
    """The ``2^(q-1)`` sign patterns ``s`` of ``Pdot_s`` (``[()]`` for one vertex), in the
    order ``(+1, ...), ..., (-1, ...)``."""
    return list(itertools.product((1, -1), repeat=q - 1))


def _sign_name(s) -> str:
    return "".join("+" if v > 0 else "-" for v in s)


@dataclass
class SlackDesign:
    """A solved design of :class:`SlackSynthesis`.

    ``L`` (r, n, p) the observer gains of the synthesis' system (r = 1 common, q PDC; for a
    UIO the gains ``K_i`` of ``N_i = T A_i - K_i C``); ``P`` (n, n) quadratic or (q, n, n)
    the fuzzy Lyapunov matrices ``P_k``; ``G`` (n, n) the slack (``None`` quadratic);
    ``gamma`` the L2 gain (``None`` without :class:`L2Gain`); ``certificate`` the data
    certificate (:class:`~vehicle_observers.design.certify.ObserverCertificate`);
    ``solution`` the solver's :class:`~vehicle_observers.design.lmi.LMISolution` (values in
    the names of :meth:`SlackSynthesis.lmi_design`)."""

    synthesis: "SlackSynthesis"
    L: np.ndarray
    P: np.ndarray
    G: np.ndarray | None
    gamma: float | None
    certificate: object
    solution: LMISolution

    @property
    def status(self) -> str:
        return self.certificate.status


class SlackSynthesis:
    """L2 / decay / pole-disk observer design, quadratic or slack-relaxed (module docstring).

    Parameters
    ----------
    system : :class:`PolytopicSystem`, continuous time (``rate_bounds`` needed by the slack
        form with more than one vertex) or discrete time (no rate bounds, no ``mu``).
    constraints : :class:`L2Gain` (at most one), :class:`Decay`, :class:`SpectralDisk`.
    gains : ``"pdc"`` (one gain per vertex; common ``C`` and ``D``) or ``"common"``.
    lyapunov : ``"quadratic"`` or ``"slack"``.
    mu : the Finsler scalar ``mu > 0`` [time unit of the system] of the continuous-time slack
        form (``None`` in discrete time).
    P_lower : ``P - P_lower I > 0`` (every ``P_k``); ``"auto"``: none (``P > 0``) with an
        :class:`L2Gain` (not homogeneous), 1 otherwise.
    eps : strictness imposed on the solver (``LMIDesign.eps``).
    order : ``"vertex"`` (vertices outer, constraints inner) or ``"constraint"``.
    name : the design's name in every message.
    """

    def __init__(self, system: PolytopicSystem, constraints=(), gains: str = "pdc",
                 lyapunov: str = "quadratic", mu: float | None = None,
                 P_lower: float | None | str = "auto", eps: float = 1e-7,
                 order: str = "vertex", name: str = "slack observer design"):
        who = f"SlackSynthesis {name!r}"
        if not isinstance(system, PolytopicSystem):
            raise ObserverArgumentError(f"{who}: system must be a PolytopicSystem, got "
                                        f"{type(system).__name__}")
        cons = list(constraints) or [Decay(0.0)]
        for c in cons:
            if not isinstance(c, (Decay, *SLACK_CONSTRAINTS)):
                raise ObserverArgumentError(f"{who}: unknown constraint {c!r}; use L2Gain, "
                                            "Decay or SpectralDisk")
        if sum(isinstance(c, L2Gain) for c in cons) > 1:
            raise ObserverArgumentError(f"{who}: at most one L2Gain")
        if any(isinstance(c, L2Gain) for c in cons) and system.nw == 0:
            raise ObserverArgumentError(f"{who}: an L2Gain needs a disturbance matrix E")
        if gains not in ("pdc", "common"):
            raise ObserverArgumentError(f"{who}: gains must be 'pdc' or 'common', got {gains!r}")
        if gains == "pdc" and system.q > 1 and not (
                system.common_C and np.all(system.D == system.D[0])):
            raise ObserverArgumentError(f"{who}: PDC gains need a common C and D (a single sum "
                                        "over the vertices); vertex-dependent C_i or D_i would "
                                        "need a double-sum relaxation")
        if lyapunov not in LYAPUNOV:
            raise ObserverArgumentError(f"{who}: lyapunov must be one of {LYAPUNOV}, got "
                                        f"{lyapunov!r}")
        if lyapunov == "slack" and system.discrete:
            if mu is not None:
                raise ObserverArgumentError(f"{who}: the discrete-time slack form (de Oliveira "
                                            "et al. 1999) has no Finsler scalar; give mu=None")
        elif lyapunov == "slack":
            if mu is None or not (np.ndim(mu) == 0 and np.isfinite(mu) and mu > 0):
                raise ObserverArgumentError(f"{who}: the slack form needs a Finsler scalar "
                                            f"mu > 0, got {mu!r}")
            if system.q > 1 and system.rate_bounds is None:
                raise ObserverArgumentError(f"{who}: a fuzzy Lyapunov matrix needs the bounds "
                                            "|dh_k/dt| <= phi_k (PolytopicSystem.rate_bounds)")
            mu = float(mu)
        elif mu is not None:
            raise ObserverArgumentError(f"{who}: mu is the slack form's scalar; the quadratic "
                                        "form takes none")
        if order not in ("vertex", "constraint"):
            raise ObserverArgumentError(f"{who}: order must be 'vertex' or 'constraint'")
        if isinstance(P_lower, str):
            if P_lower != "auto":
                raise ObserverArgumentError(f"{who}: P_lower must be a number, None or 'auto'")
            P_lower = None if any(isinstance(c, L2Gain) for c in cons) else 1.0
        if P_lower is not None and not (np.isfinite(P_lower) and P_lower > 0):
            raise ObserverArgumentError(f"{who}: P_lower must be finite and > 0 (or None)")
        if not (np.isfinite(eps) and eps >= 0):
            raise ObserverArgumentError(f"{who}: eps must be finite and >= 0, got {eps!r}")
        self.system, self.constraints, self.gains, self.lyapunov = system, cons, gains, lyapunov
        self.mu, self.P_lower, self.eps, self.order, self.name = mu, P_lower, eps, order, name
        self.n_gains = system.q if gains == "pdc" else 1
        self.signs = sign_patterns(system.q) if lyapunov == "slack" else [()]
        if lyapunov == "slack" and system.discrete:
            self.signs = list(range(system.q))       # the next step's vertex j

    @property
    def slack(self) -> bool:
        return self.lyapunov == "slack"

    def gain_of(self, i: int) -> int:
        """Index of the gain acting at vertex ``i``."""
        return i if self.gains == "pdc" else 0

    def terms(self, c) -> list[tuple[str, int, tuple]]:
        """``(name, vertex, sign pattern)`` of every LMI of constraint ``c``."""
        q = self.system.q
        if self.slack and not isinstance(c, SpectralDisk) and q > 1:
            if self.system.discrete:                 # (vertex now, vertex at the next step)
                return [(f"{c.label}[{i + 1},{j + 1}]", i, j)
                        for i in range(q) for j in self.signs]
            return [(f"{c.label}[{i + 1},{_sign_name(s)}]", i, s)
                    for i in range(q) for s in self.signs]
        return [(f"{c.label}[{i + 1}]", i, ()) for i in range(q)]

    def positivity_names(self) -> list[str]:
        """Names of the positivity constraints of the Lyapunov matrices."""
        rel = "P>0" if self.P_lower is None else "P>P_lower I"
        if not self.slack:
            return [rel]
        return [rel.replace("P", f"P{k + 1}", 1) for k in range(self.system.q)]

    # ---- the LMIs (cvxpy or numpy, from a namespace of variables) ----------------------
    def _pdot(self, V, s):
        """``Pdot_s = sum_{k<q} s_k phi_k (P_k - P_q)``."""
        q, phi = self.system.q, self.system.rate_bounds
        out = None
        for k, sk in enumerate(s):
            term = sk * phi[k] * (V[f"P{k}"] - V[f"P{q - 1}"])
            out = term if out is None else out + term
        return out

    def matrix(self, c, V, i: int, s=()):
        """Matrix of constraint ``c`` at vertex ``i``, sign pattern ``s`` (must be < 0, or > 0
        for :class:`SpectralDisk`); in discrete time ``s`` is the next step's vertex ``j``
        (slack form) or ``()``."""
        sy = self.system
        if sy.discrete and not isinstance(c, SpectralDisk):
            return self._discrete_matrix(c, V, i, s)
        A, C, E, D, H, Dz = sy.A[i], sy.C[i], sy.E[i], sy.D[i], sy.H, sy.Dz[i]
        W = V[f"W{self.gain_of(i)}"]
        if self.slack:
            Pi, G = V[f"P{i}"], V.G
            X = G @ A - W @ C
        else:
            Pi = V.P
            X = Pi @ A - W @ C
        if isinstance(c, SpectralDisk):
            Xr = X if c.radius == 1.0 else X / c.radius
            if self.slack:
                return bmat([[Pi, Xr.T], [Xr, G + G.T - Pi]])
            return bmat([[Pi, Xr.T], [Xr, Pi]])
        lead = 2.0 * c.alpha * Pi
        if self.slack and s:
            lead = self._pdot(V, s) + lead
        first = lead + X + X.T
        n = sy.n
        if isinstance(c, Decay):
            if not self.slack:
                return first
            mu = self.mu
            return bmat([[first, Pi - G + mu * X.T], [Pi - G.T + mu * X, -mu * (G + G.T)]])
        # L2Gain
        g = V.g if c.gamma is None else c.gamma ** 2
        Y = (G if self.slack else Pi) @ E - W @ D
        nw, nz = E.shape[1], H.shape[0]
        if not self.slack:
            return bmat([[first, Y, H.T], [Y.T, -g * np.eye(nw), Dz.T],
                         [H, Dz, -np.eye(nz)]])
        mu, Z = self.mu, np.zeros((nz, n))
        return bmat([[first, Pi - G + mu * X.T, Y, H.T],
                     [Pi - G.T + mu * X, -mu * (G + G.T), mu * Y, Z.T],
                     [Y.T, mu * Y.T, -g * np.eye(nw), Dz.T],
                     [H, Z, Dz, -np.eye(nz)]])

    def _discrete_matrix(self, c, V, i: int, j=()):
        """The discrete-time Stein / bounded-real matrices of the module docstring (< 0)."""
        sy = self.system
        A, C, E, D, H, Dz = sy.A[i], sy.C[i], sy.E[i], sy.D[i], sy.H, sy.Dz[i]
        W = V[f"W{self.gain_of(i)}"]
        if self.slack:
            Pi, G = V[f"P{i}"], V.G
            Pj = V[f"P{i if j == () else j}"]
            M, nxt = G, Pj - G - G.T
        else:
            Pi = M = V.P
            nxt = -Pi
        X = M @ A - W @ C
        r2 = float(np.exp(-2.0 * c.alpha * sy.dt))
        if isinstance(c, Decay):
            return bmat([[-r2 * Pi, X.T], [X, nxt]])
        g = V.g if c.gamma is None else c.gamma ** 2
        Y = M @ E - W @ D
        n, nw, nz = sy.n, E.shape[1], H.shape[0]
        Z = np.zeros
        return bmat([[-r2 * Pi, Z((n, nw)), X.T, H.T],
                     [Z((nw, n)), -g * np.eye(nw), Y.T, Dz.T],
                     [X, Y, nxt, Z((n, nz))],
                     [H, Dz, Z((nz, n)), -np.eye(nz)]])

    def lmi_design(self) -> LMIDesign:
        """The :class:`LMIDesign`: variables ``P`` (quadratic) or ``P0..P{q-1}``, ``G``
        (slack), ``g`` (free L2 gain squared), ``W0..`` (``P K_i`` or ``G K_i``)."""
        sy, n, p = self.system, self.system.n, self.system.p
        d = LMIDesign(self.name, eps=self.eps)
        if self.slack:
            for k in range(sy.q):
                d.symmetric(f"P{k}", n)
            d.matrix("G", (n, n))
        else:
            d.symmetric("P", n)
        if self._free_gamma():
            d.scalar("g")
        for j in range(self.n_gains):
            d.matrix(f"W{j}", (n, p))
        I, pl = np.eye(n), self.P_lower
        names = self.positivity_names()
        keys = [f"P{k}" for k in range(sy.q)] if self.slack else ["P"]
        for nm, key in zip(names, keys):
            d.positive(nm, (lambda V, key=key: V[key]) if pl is None else
                       (lambda V, key=key: V[key] - pl * I))
        items = [(c, t) for t in range(sy.q) for c in self.constraints] \
            if self.order == "vertex" else [(c, t) for c in self.constraints for t in range(sy.q)]
        for c, i in items:
            for nm, i_, s in self.terms(c):
                if i_ != i:
                    continue
                add = d.positive if isinstance(c, SpectralDisk) else d.negative
                add(nm, lambda V, c=c, i=i, s=s: self.matrix(c, V, i, s))
        return d

    def _free_gamma(self) -> bool:
        return any(isinstance(c, L2Gain) and c.gamma is None for c in self.constraints)

    # ---- solve -----------------------------------------------------------------------
    def solve(self, objective: str | None = None,
              min_relative_margin: float = MIN_RELATIVE_MARGIN,
              max_condition: float = MAX_CONDITION, raise_on_violation: bool = True
              ) -> SlackDesign:
        """Solve (``objective="gamma"``: minimise ``g = gamma^2`` of a free :class:`L2Gain`;
        ``None``: feasibility) and certify from the data
        (:func:`~vehicle_observers.design.certify.certify_slack_observer`).

        Raises :class:`InfeasibleDesign` when the solver finds no point and
        :class:`CertificationError` naming the LMI when either certificate says "violated"
        (unless ``raise_on_violation=False``)."""
        from vehicle_observers.design.certify import certify_slack_observer

        if objective not in (None, "gamma"):
            raise ObserverArgumentError(f"{self.name}: objective must be None or 'gamma', got "
                                        f"{objective!r}")
        if objective == "gamma" and not self._free_gamma():
            raise ObserverArgumentError(f"{self.name}: objective 'gamma' needs "
                                        "L2Gain(gamma=None)")
        d = self.lmi_design()
        sol = d.solve(objective=None if objective is None else (lambda V: V.g),
                      raise_on_failure=raise_on_violation,
                      min_relative_margin=min_relative_margin, max_condition=max_condition)
        M = sol["G"] if self.slack else sol["P"]
        L = np.array([np.linalg.solve(M, sol[f"W{j}"]) for j in range(self.n_gains)])
        P = np.array([sol[f"P{k}"] for k in range(self.system.q)]) if self.slack else sol["P"]
        G = sol["G"] if self.slack else None
        gamma = None
        for c in self.constraints:
            if isinstance(c, L2Gain):
                gamma = float(np.sqrt(sol["g"])) if c.gamma is None else c.gamma
        cert = certify_slack_observer(self, P, L, G=G, gamma=gamma,
                                      min_relative_margin=min_relative_margin,
                                      max_condition=max_condition)
        des = SlackDesign(self, L, P, G, gamma, cert, sol)
        if raise_on_violation and cert.status == "violated":
            raise CertificationError(f"{self.name}: the data certificate rejects the solution: "
                                     f"{cert.reason()} (solver status {sol.status!r})",
                                     lmi=cert.worst_name(), status=sol.status)
        return des

    def minimise(self, backoff: float = 0.05, **kw):
        """Smallest ``gamma`` of the free :class:`L2Gain`, then the design re-solved with
        ``gamma`` fixed at ``optimum (1 + backoff)`` (a feasibility problem whose solution has a
        real margin, where the optimum sits on the boundary of the feasible set). Returns an
        :class:`~vehicle_observers.design.synthesis.OptimisedDesign` (``quantity="gamma"``,
        the optimum, the certified design and its margin). ``kw``: thresholds of
        :meth:`solve`."""
        import dataclasses

        from vehicle_observers.design.synthesis import OptimisedDesign, _backoff_ok

        _backoff_ok(f"{self.name}: minimise", backoff)
        free = [c for c in self.constraints if isinstance(c, L2Gain) and c.gamma is None]
        if len(free) != 1:
            raise ObserverArgumentError(f"{self.name}: minimise needs L2Gain(gamma=None)")
        opt = self.solve("gamma", raise_on_violation=False, **kw)
        value = opt.gamma * (1.0 + backoff)
        fixed = dataclasses.replace(free[0], gamma=value)
        syn = self.replace(constraints=[fixed if c is free[0] else c for c in self.constraints])
        return OptimisedDesign("gamma", opt.gamma, value, backoff, syn.solve(**kw), opt)

    def best_mu(self, mus, objective: str | None = "gamma", **kw) -> SlackDesign:
        """Line search of the slack form over the Finsler scalars ``mus``: the design with
        the smallest ``gamma`` (the first feasible one without an objective) among the values
        whose solution is found and not "violated". Raises :class:`InfeasibleDesign` naming
        every ``mu`` when none works."""
        if not self.slack or self.system.discrete:
            raise ObserverArgumentError(f"{self.name}: best_mu needs lyapunov='slack' in "
                                        "continuous time (the discrete-time form has no mu)")
        mus = np.atleast_1d(np.asarray(mus, dtype=float))
        if mus.size == 0 or not np.all(np.isfinite(mus) & (mus > 0)):
            raise ObserverArgumentError(f"{self.name}: need mu > 0 (Finsler scalar), got {mus}")
        best, errs = None, []
        for m_ in mus:
            syn = self.replace(mu=float(m_))
            try:
                des = syn.solve(objective, **kw)
            except InfeasibleDesign as exc:
                errs.append(f"mu={m_:g}: {exc}")
                continue
            if best is None or (objective is not None and
                                des.solution.objective < best.solution.objective):
                best = des
            if objective is None:
                break
        if best is None:
            raise InfeasibleDesign(f"{self.name}: infeasible for every mu; " + " | ".join(errs))
        return best

    def replace(self, **kw) -> "SlackSynthesis":
        """A copy with some arguments changed."""
        args = dict(system=self.system, constraints=self.constraints, gains=self.gains,
                    lyapunov=self.lyapunov, mu=self.mu, P_lower=self.P_lower, eps=self.eps,
                    order=self.order, name=self.name)
        args.update(kw)
        return SlackSynthesis(**args)
