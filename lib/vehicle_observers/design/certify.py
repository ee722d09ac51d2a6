"""Certificate of an observer design rebuilt from the data: vertex matrices, gains, ``P``.

:func:`certify_observer` never calls the builders that posed the problem to the solver
(:mod:`vehicle_observers.design.synthesis`): it rewrites each LMI of
:mod:`vehicle_observers.design.constraints` here, in numpy, from the system's arrays
``A_i, C_i, E_i, D_i, H``, the gains ``L_j`` and ``P`` (``K_j = P L_j`` recomputed), stacks
the matrices of every vertex pair and takes their eigenvalues in one vectorised LAPACK call.
A mistake in how the problem was posed (a wrong vertex, a captured loop variable, a wrong
sign) therefore shows up as "violated" here even when the solver and the builders agree.

Three further checks from the same data, each necessary for the LMIs to mean what they say:

* the poles of every frozen error system ``A_i - L_j C_i`` (inside each region, ``Re <
  -alpha`` for a decay rate, ``|z| < 1`` in discrete time);
* with a bounded-real constraint, the H-infinity norm of every frozen error system
  ``(A_i - L_j C_i, E_i - L_j D_i, H, 0)`` computed by Hamiltonian bisection
  (Boyd, Balakrishnan & Kabamba, MCSS 2(3), 1989; discrete time through the bilinear map
  ``z = (1 + s)/(1 - s)``, which preserves the norm) must not exceed ``gamma``;
* with a Metzler constraint, the off-diagonal entries of ``A_i - L_j C_i`` (from ``L``, not
  from ``P``) must be >= 0; with a (discrete-time) Nonnegative constraint, all its entries.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.design.constraints import (
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
    Certificate,
    ConstraintCheck,
    check_matrix,
)


def _he(X):
    return X + np.swapaxes(X, -1, -2)


def _kron_stack(Lr, Mr, P, PA):
    """``L (x) P + M (x) PA + M^T (x) PA^T`` for a stack ``PA`` (N, n, n)."""
    N, n = PA.shape[0], P.shape[0]
    m = Lr.shape[0] * n                 # np.kron(Lr, P), without np.kron's Python overhead
    out = np.einsum("ab,ij->aibj", Lr, P).reshape(m, m)[None] + np.einsum(
        "ab,kij->kaibj", Mr, PA).reshape(
        N, Mr.shape[0] * PA.shape[1], -1)
    return out + np.einsum("ba,kji->kaibj", Mr, PA).reshape(N, Mr.shape[0] * PA.shape[1], -1)


def _stack_matrices(c, system, P, K, pairs, gamma, cval):
    """Matrices (N, m, m) of constraint ``c`` at the vertex pairs ``pairs`` [(i, j)]."""
    i_ = np.array([p[0] for p in pairs])
    j_ = np.array([p[1] for p in pairs])
    A, C, E, D, H = system.A[i_], system.C[i_], system.E[i_], system.D[i_], system.H
    Kp = K[j_]
    PA = P[None] @ A - Kp @ C                           # (N, n, n)
    N, n = PA.shape[:2]
    if isinstance(c, Decay):
        if system.discrete:
            rho = float(np.exp(-c.alpha * system.dt))
            Lr, Mr = np.array([[-rho, 0.0], [0.0, -rho]]), np.array([[0.0, 1.0], [0.0, 0.0]])
            return _kron_stack(Lr, Mr, P, PA)
        return _he(PA) + 2.0 * c.alpha * P[None]
    if isinstance(c, InRegion):
        return _kron_stack(c.region.L, c.region.M, P, PA)
    PE = P[None] @ E - Kp @ D
    nw, nz = E.shape[2], H.shape[0]
    if isinstance(c, BoundedReal):
        g = gamma
        Z = np.zeros
        Hs = np.broadcast_to(H, (N, nz, n))
        if system.discrete:
            top = np.concatenate([-np.broadcast_to(P, (N, n, n)), PA, PE, Z((N, n, nz))], 2)
            r2 = np.concatenate([np.swapaxes(PA, 1, 2), -np.broadcast_to(P, (N, n, n)),
                                 Z((N, n, nw)), np.swapaxes(Hs, 1, 2)], 2)
            r3 = np.concatenate([np.swapaxes(PE, 1, 2), Z((N, nw, n)),
                                 -g * np.broadcast_to(np.eye(nw), (N, nw, nw)), Z((N, nw, nz))], 2)
            r4 = np.concatenate([Z((N, nz, n)), Hs, Z((N, nz, nw)),
                                 -g * np.broadcast_to(np.eye(nz), (N, nz, nz))], 2)
            return np.concatenate([top, r2, r3, r4], 1)
        top = np.concatenate([_he(PA), PE, np.swapaxes(Hs, 1, 2)], 2)
        r2 = np.concatenate([np.swapaxes(PE, 1, 2), -g * np.broadcast_to(np.eye(nw), (N, nw, nw)),
                             Z((N, nw, nz))], 2)
        r3 = np.concatenate([Hs, Z((N, nz, nw)), -g * np.broadcast_to(np.eye(nz), (N, nz, nz))], 2)
        return np.concatenate([top, r2, r3], 1)
    if isinstance(c, InputToState):
        X = _he(PA) + c.alpha * P[None]
        top = np.concatenate([X, PE], 2)
        bot = np.concatenate([np.swapaxes(PE, 1, 2),
                              -cval * np.broadcast_to(np.eye(nw), (N, nw, nw))], 2)
        return np.concatenate([top, bot], 1)
    raise TypeError(type(c))


# ---- H-infinity norm by Hamiltonian bisection ---------------------------------------------
def _hinf_continuous(A, B, C, D, rtol=1e-8):
    """``||C (sI - A)^-1 B + D||_inf`` of a Hurwitz ``A`` (Boyd-Balakrishnan bisection):
    ``gamma`` exceeds the norm iff the Hamiltonian of ``gamma`` has no imaginary eigenvalue."""
    n = A.shape[0]
    if B.shape[1] == 0 or C.shape[0] == 0:
        return float(np.linalg.norm(D, 2)) if D.size else 0.0
    sD = float(np.linalg.norm(D, 2)) if D.size else 0.0
    G0 = C @ np.linalg.solve(-A, B) + D
    lo = max(sD, float(np.linalg.norm(G0, 2)))
    w = np.abs(np.linalg.eigvals(A))
    for wk in w[w > 0]:                       # a few frequency samples raise the lower bound
        Gw = C @ np.linalg.solve(1j * wk * np.eye(n) - A, B) + D
        lo = max(lo, float(np.linalg.norm(Gw, 2)))
    hi = max(2.0 * lo, 1e-300)

    def has_axis_eig(g):
        R = g * g * np.eye(D.shape[1]) - D.T @ D
        Ri = np.linalg.inv(R)
        Ah = A + B @ Ri @ D.T @ C
        Hm = np.block([[Ah, B @ Ri @ B.T],
                       [-C.T @ (np.eye(C.shape[0]) + D @ Ri @ D.T) @ C, -Ah.T]])
        ev = np.linalg.eigvals(Hm)
        return bool(np.any(np.abs(ev.real) < 1e-9 * max(1.0, float(np.abs(ev).max()))))

    while has_axis_eig(hi):
        lo, hi = hi, 2.0 * hi
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        if has_axis_eig(mid):
            lo = mid
        else:
            hi = mid
    return hi


def hinf_norm(A, B, C, D=None, discrete: bool = False, rtol: float = 1e-8) -> float:
    """H-infinity norm of a stable ``(A, B, C, D)`` (``inf`` if ``A`` is not stable), by
    Hamiltonian bisection to relative ``rtol``; discrete time via the bilinear map
    ``A_c = (A + I)^-1 (A - I)``, ``B_c = sqrt(2) (A + I)^-1 B``, ``C_c = sqrt(2) C (A + I)^-1``,
    ``D_c = D - C (A + I)^-1 B`` (same norm)."""
    A, B, C = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (A, B, C))
    D = np.zeros((C.shape[0], B.shape[1])) if D is None else np.atleast_2d(np.asarray(D, float))
    ev = np.linalg.eigvals(A)
    if (np.abs(ev).max() >= 1) if discrete else (ev.real.max() >= 0):
        return float("inf")
    if discrete:
        n = A.shape[0]
        Fi = np.linalg.inv(A + np.eye(n))
        A, B, C, D = Fi @ (A - np.eye(n)), np.sqrt(2) * Fi @ B, np.sqrt(2) * C @ Fi, D - C @ Fi @ B
    return _hinf_continuous(A, B, C, D, rtol)


# ---- the certificate ----------------------------------------------------------------------
@dataclass
class ObserverCertificate:
    """Data certificate of one observer design.

    ``lmi``: :class:`~vehicle_observers.design.lmi.Certificate` of every LMI rebuilt in numpy
    (names ``label[i]`` / ``label[i,j]`` as posed); ``poles`` (q, r, n) complex eigenvalues of
    every frozen error system ``A_i - L_j C_i`` (NaN where the structure does not constrain the
    pair); ``pole_failures`` what lies outside its region; ``hinf`` ``{pair: norm}`` of every
    frozen error system (bounded-real designs); ``gamma`` the bound they must respect.
    """

    lmi: Certificate
    poles: np.ndarray
    pole_failures: list = field(default_factory=list)
    hinf: dict = field(default_factory=dict)
    gamma: float | None = None
    hinf_rtol: float = 1e-6

    @property
    def hinf_failures(self) -> list:
        if self.gamma is None:
            return []
        return [f"||T_zw|| of pair {k} = {v:.6g} > gamma = {self.gamma:.6g}"
                for k, v in self.hinf.items() if not v <= self.gamma * (1 + self.hinf_rtol)]

    @property
    def status(self) -> str:
        """``"violated"`` if an LMI, a pole or a vertex norm fails, else the LMI
        certificate's status (``"certified"`` or ``"inconclusive"``)."""
        if not self.lmi.ok or self.pole_failures or self.hinf_failures:
            return "violated"
        return self.lmi.status

    @property
    def ok(self) -> bool:
        return self.status != "violated"

    def worst_name(self) -> str:
        if not self.lmi.ok:
            return self.lmi.worst().name
        if self.pole_failures:
            return self.pole_failures[0].split(":")[0]
        return "hinf"

    def reason(self) -> str:
        """One line: the worst failing LMI (name, eigenvalue), pole or norm."""
        if not self.lmi.ok:
            w = self.lmi.worst()
            what = {"neg": "largest eigenvalue", "pos": "smallest eigenvalue",
                    "nonneg": "smallest entry"}[w.kind]
            val = -w.margin if w.kind == "neg" else w.margin
            return f"LMI {w.name!r}: {what} = {val:.4g}"
        if self.pole_failures:
            return self.pole_failures[0]
        if self.hinf_failures:
            return self.hinf_failures[0]
        return f"{self.status} (min relative margin {self.lmi.min_relative_margin:.3e})"

    @property
    def max_pole_real(self) -> float:
        return float(np.nanmax(self.poles.real))


def check_matrices(names, Ms, kind: str) -> list[ConstraintCheck]:
    """:func:`~vehicle_observers.design.lmi.check_matrix` of a stack ``Ms`` (N, m, m) of
    ``"neg"`` / ``"pos"`` matrices in one batched LAPACK call (``numpy.linalg.eigvalsh`` on
    the stack runs the same routine on each matrix, so every check is the one
    ``check_matrix`` returns for it alone). A stack LAPACK cannot diagonalise, or one with a
    non-finite entry, falls back to ``check_matrix`` matrix by matrix."""
    Ms = np.asarray(Ms, dtype=float)
    if kind not in ("neg", "pos") or Ms.ndim != 3 or Ms.shape[1] != Ms.shape[2] \
            or not np.all(np.isfinite(Ms)):
        return [check_matrix(nm, M, kind) for nm, M in zip(names, Ms)]
    Mt = np.swapaxes(Ms, 1, 2)
    with np.errstate(over="ignore", invalid="ignore"):
        S = Ms / 2 + Mt / 2
        asym = np.abs(Ms / 2 - Mt / 2).max(axis=(1, 2)) * 2 / np.maximum(
            np.abs(Ms).max(axis=(1, 2)), 1e-300)
    try:
        ev = np.linalg.eigvalsh(S)
    except np.linalg.LinAlgError:
        return [check_matrix(nm, M, kind) for nm, M in zip(names, Ms)]
    scale = np.maximum(np.abs(ev).max(axis=1), 1e-300)
    margin = -ev[:, -1] if kind == "neg" else ev[:, 0]
    rel = margin / scale
    m = Ms.shape[1]
    return [ConstraintCheck(nm, kind, float(a), float(r), float(s), m)
            for nm, a, r, s in zip(names, margin, rel, asym)]


class _Batch:
    """Matrices to check and to diagonalise, collected over designs and evaluated together:
    one :func:`check_matrices` call per (kind, size) and one ``eigvals`` per size."""

    def __init__(self):
        self.mats: dict = {}
        self.eig: dict = {}
        self.done: dict = {}

    def check(self, name, M, kind):
        M = np.asarray(M, dtype=float)
        if kind not in ("neg", "pos") or M.ndim != 2 or M.shape[0] != M.shape[1]:
            return check_matrix(name, M, kind)             # evaluated now (rare shapes)
        key = (kind, M.shape[0])
        lst = self.mats.setdefault(key, [])
        lst.append((name, M))
        return ("chk", key, len(lst) - 1)

    def eigvals(self, M):
        key = M.shape[0]
        lst = self.eig.setdefault(key, [])
        lst.append(M)
        return ("eig", key, len(lst) - 1)

    def run(self):
        for key, lst in self.mats.items():
            self.done[("chk", key)] = check_matrices([n for n, _ in lst],
                                                     np.array([M for _, M in lst]), key[0])
        for key, lst in self.eig.items():
            self.done[("eig", key)] = np.linalg.eigvals(np.array(lst))

    def get(self, h):
        if isinstance(h, tuple) and len(h) == 3 and h[0] in ("chk", "eig"):
            return self.done[(h[0], h[1])][h[2]]
        return h


def certify_observer(synthesis, P, L, gamma: float | None = None, c: float | None = None,
                     min_relative_margin: float = MIN_RELATIVE_MARGIN,
                     max_condition: float = MAX_CONDITION) -> ObserverCertificate:
    """Certify gains ``L`` (r, n, p) and Lyapunov matrix ``P`` (n, n) for the design
    ``synthesis`` (an :class:`~vehicle_observers.design.synthesis.ObserverSynthesis`: its
    system's arrays, gain structure and constraints), from the data alone (module docstring).

    ``gamma`` / ``c``: the values of a bounded-real / input-to-state bound (needed when the
    constraint left them free). ``min_relative_margin``, ``max_condition``: the thresholds of
    "inconclusive" (defaults :data:`~vehicle_observers.design.lmi.MIN_RELATIVE_MARGIN`,
    :data:`~vehicle_observers.design.lmi.MAX_CONDITION`)."""
    return certify_observers([(synthesis, P, L, gamma, c)], min_relative_margin,
                             max_condition)[0]


def certify_observers(items, min_relative_margin: float = MIN_RELATIVE_MARGIN,
                      max_condition: float = MAX_CONDITION) -> list[ObserverCertificate]:
    """:func:`certify_observer` of many designs at once: ``items`` a sequence of
    ``(synthesis, P, L, gamma, c)``. Every constraint matrix of every design is rebuilt as in
    :func:`certify_observer`, then the matrices of one size are checked in one batched
    ``eigvalsh`` and the error-system poles of one size found in one batched ``eigvals``
    (the same LAPACK routine per matrix: each certificate is the one
    :func:`certify_observer` gives the design alone). Used by feasibility maps, where one
    call certifies every solved point."""
    batch = _Batch()
    pending = [_prepare(*it, batch) for it in items]
    batch.run()
    return [_finish(pd, batch, min_relative_margin, max_condition) for pd in pending]


def _prepare(synthesis, P, L, gamma, c, batch):
    """The checks of one design, registered in ``batch`` (evaluated by :func:`_finish`)."""
    s = synthesis.system
    P = np.asarray(P, dtype=float)
    L = np.asarray(L, dtype=float)
    if P.shape != (s.n, s.n) or L.shape != (synthesis.n_gains, s.n, s.p):
        raise ObserverArgumentError(f"certify_observer: P must be {s.n} x {s.n} and L "
                                    f"({synthesis.n_gains}, {s.n}, {s.p}); got {P.shape}, "
                                    f"{L.shape}")
    K = P[None] @ L
    checks: list = []
    I = np.eye(s.n)
    if synthesis.P_lower is not None:
        checks.append(batch.check(synthesis.lower_name, P - synthesis.P_lower * I, "pos"))
    else:
        checks.append(batch.check("P > 0", P, "pos"))
    if synthesis.P_upper is not None:
        checks.append(batch.check(synthesis.upper_name, synthesis.P_upper * I - P, "pos"))
    if synthesis.P_lower is not None:           # P itself: its conditioning decides too
        checks.append(batch.check("P > 0 (conditioning)", P, "pos"))
    Ps = (P + P.T) / 2
    all_pairs = sorted({(i, j) for _, combo in synthesis.terms for _, i, j in combo})
    index = {p: k for k, p in enumerate(all_pairs)}
    for con in synthesis.constraints:
        if isinstance(con, (Metzler, Nonnegative)):
            continue
        g = gamma if not isinstance(con, BoundedReal) or con.gamma is None else con.gamma
        cv = c if not isinstance(con, InputToState) or con.c is None else con.c
        if isinstance(con, BoundedReal) and g is None:
            raise ObserverArgumentError("certify_observer: the bounded-real constraint needs "
                                        "gamma")
        if isinstance(con, InputToState) and cv is None:
            raise ObserverArgumentError("certify_observer: the input-to-state constraint needs c")
        G = _stack_matrices(con, s, Ps, K, all_pairs, g, cv)
        for suffix, combo in synthesis.terms:
            M = sum(coef * G[index[(i, j)]] for coef, i, j in combo)
            checks.append(batch.check(f"{con.label}{suffix}", M, "neg"))
        if isinstance(con, BoundedReal):
            gamma = g
    pairs = synthesis._pairs()
    Acl = {(i, j): s.A[i] - L[j] @ s.C[i] for i, j in pairs}
    eig = {pr: batch.eigvals(Acl[pr]) for pr in pairs}
    return synthesis, L, Acl, eig, checks, gamma


def _pair_suffix(synthesis, i, j) -> str:
    """``[i]`` (one gain) or ``[i,j]``: the suffix the synthesis names pair ``(i, j)`` with."""
    return f"[{i + 1}]" if synthesis.gains in ("common", "reduced") else f"[{i + 1},{j + 1}]"


def _finish(pending, batch, min_relative_margin, max_condition) -> ObserverCertificate:
    """The certificate of one design from its evaluated checks and poles."""
    synthesis, L, Acl, eig, checks, gamma = pending
    s = synthesis.system
    checks = [batch.get(h) for h in checks]
    # poles of every constrained frozen pair
    pairs = synthesis._pairs()
    poles = np.full((s.q, synthesis.n_gains, s.n), np.nan + 0j)
    fails = []
    for i, j in pairs:
        poles[i, j] = batch.get(eig[(i, j)])
    for con in synthesis.constraints:
        if isinstance(con, InRegion):           # every pair's poles in one batched test
            inside_all = con.region.contains(np.array([poles[i, j] for i, j in pairs]))
        for k, (i, j) in enumerate(pairs):
            ev = poles[i, j]
            tag = f"pair ({i + 1},{j + 1})"
            if isinstance(con, Decay):
                bad = (np.abs(ev) >= np.exp(-con.alpha * s.dt)) if s.discrete else \
                    (ev.real >= -con.alpha)
                if bad.any():
                    fails.append(f"{con.label}{tag}: pole {ev[np.argmax(bad)]:.4g} of A_i - L_j C_i "
                                 f"violates the decay rate {con.alpha:g}")
            elif isinstance(con, InRegion):
                inside = inside_all[k]
                if not inside.all():
                    fails.append(f"{con.label}{tag}: pole {ev[np.argmin(inside)]:.4g} of "
                                 f"A_i - L_j C_i lies outside {con.region.name!r}")
            elif isinstance(con, Nonnegative):
                M = Acl[(i, j)]
                m = float(M.min())
                checks.append(ConstraintCheck(f"{con.label}{_pair_suffix(synthesis, i, j)}",
                                              "nonneg", m, m / max(float(np.abs(M).max()),
                                                                   1e-300), 0.0, M.size))
            elif isinstance(con, Metzler):
                M = Acl[(i, j)]
                off = M[~np.eye(s.n, dtype=bool)]
                m = float(off.min()) if off.size else 0.0
                checks.append(ConstraintCheck(f"{con.label}[{i + 1},{j + 1}]", "nonneg", m,
                                              m / max(float(np.abs(M).max()), 1e-300), 0.0,
                                              off.size))
                if con.diag_shift is not None:
                    dm = float((np.diag(M) + con.diag_shift).min())
                    checks.append(ConstraintCheck(f"{con.label} diag[{i + 1},{j + 1}]",
                                                  "nonneg", dm, dm / max(con.diag_shift, 1e-300),
                                                  0.0, s.n))
    stable = (np.abs(poles[~np.isnan(poles.real)]) < 1) if s.discrete else \
        (poles[~np.isnan(poles.real)].real < 0)
    if not stable.all():
        fails.append("stability: a frozen error system A_i - L_j C_i is not stable")
    hinf = {}
    if gamma is not None and any(isinstance(x, BoundedReal) for x in synthesis.constraints):
        for i, j in pairs:
            Ac, Bc, Cc, Dc = s.error_system(i, L[j])
            hinf[(i + 1, j + 1)] = hinf_norm(Ac, Bc, Cc, Dc, discrete=s.discrete)
    cert = Certificate(checks, min_relative_margin, max_condition)
    return ObserverCertificate(cert, poles, fails, hinf,
                               gamma if any(isinstance(x, BoundedReal)
                                            for x in synthesis.constraints) else None)


# ---- parameter-dependent Lyapunov designs -------------------------------------------------
def _pd_matrix(con, sv, Pi, Ki, j, R, cval):
    """Numpy matrix ``G_ij`` of :mod:`vehicle_observers.design.lyapunov` (Decay or
    InputToState) at Lyapunov matrix / gain ``(P_i, K_i)`` and vertex ``j`` of ``sv``, with
    the rate term ``R`` (n, n)."""
    A, C, E, D = sv.A[j], sv.C[j], sv.E[j], sv.D[j]
    PA = Pi @ A - Ki @ C
    X = PA + PA.T + R
    if isinstance(con, Decay):
        return X + 2.0 * con.alpha * Pi
    X = X + con.alpha * Pi
    PE = Pi @ E - Ki @ D
    return np.block([[X, PE], [PE.T, -cval * np.eye(E.shape[1])]])


def certify_parameter_dependent(synthesis, P, L, M, c=None,
                                min_relative_margin: float = MIN_RELATIVE_MARGIN,
                                max_condition: float = MAX_CONDITION) -> ObserverCertificate:
    """Certify a :class:`~vehicle_observers.design.lyapunov.ParameterDependentSynthesis`
    solution from the data alone: per mode ``m``, ``P[m]`` (q, n, n), ``L[m]`` (q, n, p),
    ``M[m]`` (n, n) or ``None``, ``c`` (modes,) the input-to-state bounds.

    Rebuilt here in numpy (``K_k = P_k L_k``): ``P_k - P_lower I > 0`` and ``P_k`` itself
    (conditioning), ``P_k + M > 0``, the rate term ``R = sum_k phi_k (P_k + M)`` from the
    system's ``rate_bounds``, every LMI ``sum coef G_ij < 0`` of the coupling (on the vertex
    list each constraint is stated on), the Metzler entries of ``A_k - L_k C_k`` (from ``L``),
    and the poles of every frozen vertex error system ``A_k - L_k C_k`` of an LMI's vertex
    list (stable; ``Re < -alpha`` under a :class:`Decay`). Names as posed (``label[m,k]``
    ...); a failing one is named by :meth:`ObserverCertificate.reason`."""
    syn = synthesis
    checks: list[ConstraintCheck] = []
    fails = []
    n_modes = len(syn.modes)
    if len(P) != n_modes or len(L) != n_modes or len(M) != n_modes:
        raise ObserverArgumentError(f"certify_parameter_dependent: P, L, M need one entry per "
                                    f"mode ({n_modes})")
    poles = []
    for m, s in enumerate(syn.modes):
        Pm = np.asarray(P[m], dtype=float)
        Lm = np.asarray(L[m], dtype=float)
        if Pm.shape != (s.q, s.n, s.n) or Lm.shape != (s.q, s.n, s.p):
            raise ObserverArgumentError(f"certify_parameter_dependent: mode {m + 1}: P must be "
                                        f"({s.q}, {s.n}, {s.n}) and L ({s.q}, {s.n}, {s.p}); "
                                        f"got {Pm.shape}, {Lm.shape}")
        Pm = (Pm + np.swapaxes(Pm, 1, 2)) / 2
        Km = Pm @ Lm
        Mm = None if M[m] is None else (np.asarray(M[m], float) + np.asarray(M[m], float).T) / 2
        if syn.slack and Mm is None:
            raise ObserverArgumentError("certify_parameter_dependent: the slack design needs M")
        I = np.eye(s.n)
        for k in range(s.q):
            sk = syn.suffix(m, f"{k + 1}")
            if syn.P_lower is not None:
                checks.append(check_matrix(f"P{sk} - P_lower I > 0", Pm[k] - syn.P_lower * I,
                                           "pos"))
            checks.append(check_matrix(f"P{sk} > 0 (conditioning)", Pm[k], "pos"))
            if syn.P_upper is not None:
                checks.append(check_matrix(f"P_upper I - P{sk} > 0", syn.P_upper * I - Pm[k],
                                           "pos"))
            if Mm is not None:
                checks.append(check_matrix(f"P{sk} + M{syn.mode_tag(m)} > 0", Pm[k] + Mm, "pos"))
        # dP/dt <= R, rebuilt here from the system's rate bounds (not the builders' code)
        phi = np.asarray(s.rate_bounds, dtype=float)
        R = np.einsum("k,kab->ab", phi, Pm + (0.0 if Mm is None else Mm[None]))
        for con in syn.constraints:
            inner, sv = syn.inner(con), syn.vertex_system(con, m)
            if isinstance(inner, Metzler):
                for k in range(s.q):
                    sk = syn.suffix(m, f"{k + 1}")
                    Acl = sv.A[k] - Lm[k] @ sv.C[k]
                    off = Acl[~np.eye(s.n, dtype=bool)]
                    mn = float(off.min()) if off.size else 0.0
                    checks.append(ConstraintCheck(f"{inner.label}{sk}", "nonneg", mn,
                                                  mn / max(float(np.abs(Acl).max()), 1e-300),
                                                  0.0, off.size))
                    if inner.diag_shift is not None:
                        dm = float((np.diag(Acl) + inner.diag_shift).min())
                        checks.append(ConstraintCheck(f"{inner.label} diag{sk}", "nonneg", dm,
                                                      dm / inner.diag_shift, 0.0, s.n))
                continue
            cv = None
            if isinstance(inner, InputToState):
                cv = inner.c if inner.c is not None else (None if c is None else float(c[m]))
                if cv is None:
                    raise ObserverArgumentError("certify_parameter_dependent: the input-to-state "
                                                "constraint needs c")
            G = {}
            for suffix, combo in syn.terms(m):
                for _, i, j in combo:
                    if (i, j) not in G:
                        G[(i, j)] = _pd_matrix(inner, sv, Pm[i], Km[i], j, R, cv)
                checks.append(check_matrix(f"{inner.label}{suffix}",
                                           sum(coef * G[(i, j)] for coef, i, j in combo), "neg"))
            for k in range(s.q):
                ev = np.linalg.eigvals(sv.A[k] - Lm[k] @ sv.C[k])
                poles.append(ev)
                lim = -inner.alpha if isinstance(inner, Decay) else 0.0
                if np.any(ev.real >= lim):
                    fails.append(f"{inner.label}{syn.suffix(m, str(k + 1))}: pole "
                                 f"{ev[np.argmax(ev.real)]:.4g} of A_k - L_k C_k has Re >= "
                                 f"{lim:g}")
    cert = Certificate(checks, min_relative_margin, max_condition)
    return ObserverCertificate(cert, np.array(poles) if poles else np.zeros((0, 0)), fails)


# ---- slack / fuzzy-Lyapunov designs (vehicle_observers.design.slack) ------------------------
def _slack_discrete_checks(con, s, Pv, G, X, Y, g2, slack) -> list[ConstraintCheck]:
    """Discrete-time LMIs of :mod:`vehicle_observers.design.slack` rebuilt in numpy (< 0):
    ``[[-r^2 P_i, X_i^T], [X_i, Q_ij]]`` (Decay) or the bounded-real matrix with rows
    ``(e_k, w_k, e_{k+1}, z_k)`` (L2Gain), ``r = exp(-alpha dt)``, ``Q_ij = P_j - G - G^T``
    over every pair ``(i, j)`` (slack, de Oliveira et al. 1999 / Daafouz & Bernussou 2001) or
    ``-P`` (quadratic, frozen ``[i]``). ``Pv`` (q, n, n), ``X = M N_i``, ``Y = M B_i`` (q, ...)
    with ``M = G`` or ``P``; names ``label[i,j]`` / ``label[i]`` as posed."""
    from vehicle_observers.design.constraints import L2Gain

    q, n = Pv.shape[0], Pv.shape[1]
    r2 = float(np.exp(-2.0 * con.alpha * s.dt))
    pairs = [(i, j) for i in range(q) for j in range(q)] if (slack and q > 1) else \
        [(i, i) for i in range(q)]
    names, mats = [], []
    nz, nw = s.H.shape[0], s.nw
    for i, j in pairs:
        Q = Pv[j] - G - G.T if slack else -Pv[i]
        if isinstance(con, L2Gain):
            mat = np.block([[-r2 * Pv[i], np.zeros((n, nw)), X[i].T, s.H.T],
                            [np.zeros((nw, n)), -g2 * np.eye(nw), Y[i].T, s.Dz[i].T],
                            [X[i], Y[i], Q, np.zeros((n, nz))],
                            [s.H, s.Dz[i], np.zeros((nz, n)), -np.eye(nz)]])
        else:
            mat = np.block([[-r2 * Pv[i], X[i].T], [X[i], Q]])
        names.append(f"{con.label}[{i + 1},{j + 1}]" if (slack and q > 1) else
                     f"{con.label}[{i + 1}]")
        mats.append(mat)
    return check_matrices(names, np.array(mats), "neg")



def certify_slack_observer(synthesis, P, L, G=None, gamma: float | None = None,
                           min_relative_margin: float = MIN_RELATIVE_MARGIN,
                           max_condition: float = MAX_CONDITION) -> ObserverCertificate:
    """Certify a :class:`~vehicle_observers.design.slack.SlackSynthesis` design from the data:
    the system's arrays ``A_i, C_i, E_i, D_i, H, Dz_i``, rate bounds ``phi_k``, the gains
    ``L`` (r, n, p), ``P`` ((n, n) quadratic, (q, n, n) the fuzzy ``P_k``), the slack ``G``
    (n, n) and the L2 bound ``gamma``. ``W_i = P L_i`` (or ``G L_i``) is recomputed here and
    every LMI of :mod:`vehicle_observers.design.slack` rewritten in numpy (stacked over the
    vertices, one batched eigenvalue call per constraint family), with the same names.

    Checks from the same data, each necessary for the LMIs to mean what they say: the poles of
    every frozen error system ``A_i - L_i C_i`` (``Re < -alpha`` of each decay / L2 constraint,
    in discrete time the spectral radius ``< exp(-alpha dt)`` and ``< 1``; ``|lambda| <
    radius`` of each disk) and, with an L2 gain, the H-infinity norm of every frozen
    ``(A_i - L_i C_i, E_i - L_i D_i, H, Dz_i)`` by Hamiltonian bisection (discrete time through
    the bilinear map, :func:`hinf_norm`; at most ``gamma``). Discrete-time LMIs (Stein and
    bounded-real, the slack form over every vertex pair ``(i, j)``):
    :func:`_slack_discrete_checks`."""
    from vehicle_observers.design.constraints import L2Gain, SpectralDisk

    s = synthesis.system
    q, n = s.q, s.n
    slack = synthesis.lyapunov == "slack"
    P = np.asarray(P, dtype=float)
    L = np.asarray(L, dtype=float)
    want_P = (q, n, n) if slack else (n, n)
    if P.shape != want_P or L.shape != (synthesis.n_gains, n, s.p) or \
            (slack and np.shape(G) != (n, n)):
        raise ObserverArgumentError(f"certify_slack_observer: P must be {want_P}, L "
                                    f"({synthesis.n_gains}, {n}, {s.p}) and G ({n}, {n}) in the "
                                    f"slack form; got {P.shape}, {L.shape}, {np.shape(G)}")
    jv = np.array([i if synthesis.gains == "pdc" else 0 for i in range(q)])
    Lv = L[jv]                                               # gain acting at each vertex
    Pv = (P + np.swapaxes(P, -1, -2)) / 2 if slack else np.broadcast_to((P + P.T) / 2, (q, n, n))
    M = np.asarray(G, dtype=float) if slack else None        # the multiplier of W = M L
    checks: list[ConstraintCheck] = []
    lower = synthesis.P_lower
    for name, Pk in zip(synthesis.positivity_names(), Pv if slack else Pv[:1]):
        checks.append(check_matrix(name, Pk - (lower or 0.0) * np.eye(n), "pos"))
        if lower is not None:
            checks.append(check_matrix(f"{name.split('>')[0]}>0 (conditioning)", Pk, "pos"))
    Ncl = s.A - Lv @ s.C                                     # (q, n, n) frozen error systems
    Bcl = s.E - Lv @ s.D
    if slack:
        X = M[None] @ Ncl                                    # G A_i - W_i C_i = G N_i
        Y = M[None] @ Bcl
    else:
        X = Pv @ Ncl
        Y = Pv @ Bcl
    phi = s.rate_bounds
    poles = np.linalg.eigvals(Ncl)[:, None, :]              # (q, 1, n)
    fails = []
    hinf = {}
    g2 = None if gamma is None else float(gamma) ** 2
    for con in synthesis.constraints:
        if isinstance(con, SpectralDisk):
            R = con.radius
            for i in range(q):
                top = np.hstack([Pv[i], X[i].T / R])
                bot = np.hstack([X[i] / R, (M + M.T - Pv[i]) if slack else Pv[i]])
                checks.append(check_matrix(f"{con.label}[{i + 1}]", np.vstack([top, bot]),
                                           "pos"))
                bad = np.abs(poles[i, 0]) >= R
                if bad.any():
                    fails.append(f"{con.label}[{i + 1}]: pole {poles[i, 0][np.argmax(bad)]:.4g} "
                                 f"of A_i - L_i C_i outside |lambda| < {R:g}")
            continue
        for i in range(q):
            bad = (np.abs(poles[i, 0]) >= np.exp(-con.alpha * s.dt)) if s.discrete else \
                (poles[i, 0].real >= -con.alpha)
            if bad.any():
                fails.append(f"{con.label}[{i + 1}]: pole {poles[i, 0][np.argmax(bad)]:.4g} of "
                             f"A_i - L_i C_i violates the decay rate {con.alpha:g}")
        if isinstance(con, L2Gain):
            if g2 is None:
                raise ObserverArgumentError("certify_slack_observer: the L2 constraint needs "
                                            "gamma")
            for i in range(q):
                hinf[(i + 1, int(jv[i]) + 1)] = hinf_norm(Ncl[i], Bcl[i], s.H, s.Dz[i],
                                                          discrete=s.discrete)
        if s.discrete:
            checks.extend(_slack_discrete_checks(con, s, Pv, M, X, Y, g2, slack))
            continue
        signs = synthesis.signs if (slack and q > 1) else [()]
        for i in range(q):
            for sg in signs:
                Pdot = sum((sk * phi[k] * (Pv[k] - Pv[q - 1]) for k, sk in enumerate(sg)),
                           np.zeros((n, n)))
                lead = Pdot + 2.0 * con.alpha * Pv[i] + X[i] + X[i].T
                tag = f"[{i + 1},{''.join('+' if v > 0 else '-' for v in sg)}]" if sg \
                    else f"[{i + 1}]"
                if isinstance(con, L2Gain):
                    nw, nz = s.nw, s.H.shape[0]
                    if slack:
                        mu = synthesis.mu
                        mat = np.block([
                            [lead, Pv[i] - M + mu * X[i].T, Y[i], s.H.T],
                            [Pv[i] - M.T + mu * X[i], -mu * (M + M.T), mu * Y[i],
                             np.zeros((n, nz))],
                            [Y[i].T, mu * Y[i].T, -g2 * np.eye(nw), s.Dz[i].T],
                            [s.H, np.zeros((nz, n)), s.Dz[i], -np.eye(nz)]])
                    else:
                        mat = np.block([[lead, Y[i], s.H.T],
                                        [Y[i].T, -g2 * np.eye(nw), s.Dz[i].T],
                                        [s.H, s.Dz[i], -np.eye(nz)]])
                elif slack:
                    mu = synthesis.mu
                    mat = np.block([[lead, Pv[i] - M + mu * X[i].T],
                                    [Pv[i] - M.T + mu * X[i], -mu * (M + M.T)]])
                else:
                    mat = lead
                checks.append(check_matrix(f"{con.label}{tag}", mat, "neg"))
    if not ((np.abs(poles) < 1) if s.discrete else (poles.real < 0)).all():
        fails.append("stability: a frozen error system A_i - L_i C_i is not stable")
    cert = Certificate(checks, min_relative_margin, max_condition)
    has_l2 = any(isinstance(c, L2Gain) for c in synthesis.constraints)
    return ObserverCertificate(cert, poles, fails, hinf, float(gamma) if has_l2 else None)
