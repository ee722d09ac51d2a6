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

Vertex ordering of the Jacobian TS model (Ichalal 2011, below (34)): vertex ``v`` has entry
``l`` at its upper bound iff bit ``l`` of ``v`` is set (entry 0 = least significant). For
the bicycle (``xi1 = J[3,1]``, ``xi2 = J[3,2]``) this gives ``A1 = (lo, lo)``,
``A2 = (hi, lo)``, ``A3 = (lo, hi)``, ``A4 = (hi, hi)`` and ``h1 = F1^1 F2^1``,
``h2 = F1^0 F2^1``, ``h3 = F1^1 F2^0``, ``h4 = F1^0 F2^0`` as printed.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
from numba import njit

from vehicle_observers.core.errors import CertificationError, InfeasibleDesign
from vehicle_observers.design.lmi import LMIDesign, LMISolution, Region

# ---- Jacobian TS model (12)-(18) -----------------------------------------------------------


def numerical_jacobian(f: Callable, x, u, h: float = 1e-6) -> np.ndarray:
    """Central-difference Jacobian ``df/dx`` of ``f(x (N, n), u (N,...)) -> (N, n)``.

    Returns (N, n, n). Step ``h`` is scaled by ``max(1, |x_j|)``. Used to check analytic
    Jacobians (Ichalal 2011 eq. (31)).
    """
    x = np.atleast_2d(np.asarray(x, dtype=float))
    if not np.all(np.isfinite(x)):
        raise ValueError("numerical_jacobian: x contains non-finite values")
    N, n = x.shape
    J = np.empty((N, n, n))
    for j in range(n):
        hj = h * np.maximum(1.0, np.abs(x[:, j]))
        dx = np.zeros_like(x)
        dx[:, j] = hj
        fp = np.asarray(f(x + dx, u), dtype=float)
        fm = np.asarray(f(x - dx, u), dtype=float)
        J[:, :, j] = (fp - fm) / (2 * hj[:, None])
    return J


@dataclass
class JacobianTS:
    """Jacobian TS model (Ichalal 2011 eqs. (14)-(18), (34)).

    Attributes
    ----------
    A0 : (n, n) constant part (varying entries set to 0).
    entries : list of (row, col) of the varying entries (0-based).
    lo, hi : (k,) entry bounds ``a_kl``, ``b_kl`` of (14).
    names : k names for messages/plots.
    vertices : (2^k, n, n) vertex matrices ``A_i`` (ordering: see module docstring).
    """

    A0: np.ndarray
    entries: list
    lo: np.ndarray
    hi: np.ndarray
    names: list
    vertices: np.ndarray = field(init=False)

    def __post_init__(self):
        self.A0 = np.array(self.A0, dtype=float)
        self.lo = np.asarray(self.lo, dtype=float)
        self.hi = np.asarray(self.hi, dtype=float)
        n = self.A0.shape[0]
        if self.A0.shape != (n, n):
            raise ValueError(f"JacobianTS: A0 must be square, got shape {self.A0.shape}")
        k = len(self.entries)
        if self.lo.shape != (k,) or self.hi.shape != (k,):
            raise ValueError(f"JacobianTS: need {k} lower and upper bounds, got "
                             f"{self.lo.shape} and {self.hi.shape}")
        if len(self.names) != k:
            raise ValueError(f"JacobianTS: {len(self.names)} names for {k} varying entries")
        for l, ((r, c), a, b) in enumerate(zip(self.entries, self.lo, self.hi, strict=True)):
            if not (0 <= r < n and 0 <= c < n):
                raise ValueError(f"JacobianTS: entry {l} = ({r}, {c}) outside a {n}x{n} matrix")
            if not (np.isfinite(a) and np.isfinite(b) and b > a):
                raise ValueError(f"JacobianTS: entry {self.names[l]!r} ({r}, {c}) needs finite "
                                 f"bounds with upper > lower, got [{a}, {b}]")
            self.A0[r, c] = 0.0
        verts = np.repeat(self.A0[None], 2**k, axis=0)
        for v in range(2**k):
            for l, (r, c) in enumerate(self.entries):
                verts[v, r, c] = self.hi[l] if (v >> l) & 1 else self.lo[l]
        self.vertices = verts

    @property
    def q(self) -> int:
        return len(self.vertices)

    def values(self, J) -> np.ndarray:
        """Varying entries of Jacobians ``J`` (N, n, n) -> (N, k)."""
        J = np.asarray(J, dtype=float).reshape(-1, *self.A0.shape)
        return np.column_stack([J[:, r, c] for r, c in self.entries])

    def weights(self, J, clip: bool = False) -> np.ndarray:
        """Weights ``h_i`` (16)-(17) of Jacobians ``J`` (N, n, n) -> (N, 2^k).

        Raises ValueError naming the entry and sample if a value leaves its bounds (the
        TS form is exact only inside them) unless ``clip``.
        """
        xi = self.values(J)
        if clip:
            xi = np.clip(xi, self.lo, self.hi)
        else:
            bad = (xi < self.lo) | (xi > self.hi)
            if bad.any():
                n_, l = np.argwhere(bad)[0]
                raise ValueError(f"JacobianTS: entry {self.names[l]!r} = {xi[n_, l]:.6g} at "
                                 f"sample {n_} is outside [{self.lo[l]:.6g}, {self.hi[l]:.6g}]")
        w_hi = (xi - self.lo) / (self.hi - self.lo)          # F^0 in the paper
        h = np.ones((len(xi), self.q))
        for v in range(self.q):
            for l in range(len(self.entries)):
                h[:, v] *= w_hi[:, l] if (v >> l) & 1 else 1.0 - w_hi[:, l]
        return h


def jacobian_ts_from_bounds(A0, bounds: dict, names: Sequence[str] | None = None) -> JacobianTS:
    """Jacobian TS model from a constant part and ``{(row, col): (lo, hi)}`` entry bounds."""
    entries = list(bounds.keys())
    lo = [bounds[e][0] for e in entries]
    hi = [bounds[e][1] for e in entries]
    names = list(names) if names is not None else [f"J[{r},{c}]" for r, c in entries]
    return JacobianTS(np.asarray(A0, dtype=float), entries, lo, hi, names)


def jacobian_ts_from_samples(J, rtol: float = 1e-9, margin: float = 0.0,
                             names: Sequence[str] | None = None) -> JacobianTS:
    """Jacobian TS model from Jacobians sampled along trajectories, ``J`` (N, n, n).

    An entry is *varying* when its spread exceeds ``rtol * max(1, |J|_max)``; its bounds
    are the sampled min/max widened by ``margin`` times the spread on each side (Ichalal
    2011 eq. (14) with ``a_kl, b_kl`` taken from the simulation). Constant entries form A0.
    """
    J = np.asarray(J, dtype=float)
    if J.ndim != 3 or J.shape[1] != J.shape[2]:
        raise ValueError(f"jacobian_ts_from_samples: J must have shape (N, n, n), got {J.shape}")
    if not np.all(np.isfinite(J)):
        k = int(np.argwhere(~np.isfinite(J))[0][0])
        raise ValueError(f"jacobian_ts_from_samples: non-finite Jacobian at sample {k}")
    if margin < 0:
        raise ValueError(f"margin must be >= 0, got {margin}")
    jmin, jmax = J.min(axis=0), J.max(axis=0)
    spread = jmax - jmin
    tol = rtol * max(1.0, float(np.abs(J).max()))
    entries = [tuple(int(i) for i in rc) for rc in np.argwhere(spread > tol)]
    A0 = J[0].copy()
    lo = [jmin[r, c] - margin * spread[r, c] for r, c in entries]
    hi = [jmax[r, c] + margin * spread[r, c] for r, c in entries]
    if names is not None and len(names) != len(entries):
        raise ValueError(f"{len(names)} names given for {len(entries)} varying entries "
                         f"{entries}")
    names = list(names) if names is not None else [f"J[{r},{c}]" for r, c in entries]
    return JacobianTS(A0, entries, lo, hi, names)


def segment_jacobian_values(jac: Callable, X, Xhat, U, jts: JacobianTS,
                            n_points: int = 5) -> np.ndarray:
    """Varying Jacobian entries on the segments ``[xhat(t), x(t)]`` where the DMVT points
    ``xi^i`` of (11) lie: shape (N, n_points, k). ``jac(x (N, n), u (N,)) -> (N, n, n)``."""
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


def _regions(region) -> list[Region]:
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
    regs = _regions(region)
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
    """
    A = np.asarray(vertices, dtype=float)
    C = np.atleast_2d(np.asarray(C, dtype=float))
    if A.ndim != 3 or A.shape[1] != A.shape[2]:
        raise ValueError(f"vertices must have shape (q, n, n), got {A.shape}")
    q, n, _ = A.shape
    if C.shape[1] != n:
        raise ValueError(f"C must have {n} columns (one per state), got shape {C.shape}")
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(C))):
        raise ValueError("vertices and C must be finite")
    if int(r) != r or r < 1:
        raise ValueError(f"r (number of observer gains) must be a positive integer, got {r}")
    regs = _regions(region)
    p = C.shape[0]
    d = LMIDesign(name, eps=eps)
    d.symmetric("P", n)
    for j in range(r):
        d.matrix(f"K{j}", (n, p))
    d.positive("P - P_lower I > 0", lambda V: V.P - P_lower * np.eye(n))
    for i in range(q):
        for j in range(r):
            def pa(V, i=i, j=j):
                return V.P @ A[i] - V[f"K{j}"] @ C
            d.negative(f"(23)[{i + 1},{j + 1}]", lambda V, pa=pa: pa(V) + pa(V).T)
            for reg in regs:
                d.negative(f"region {reg.name}[{i + 1},{j + 1}]",
                           lambda V, pa=pa, reg=reg: reg.lmi(V.P, pa(V)))
    if K_bound is not None:
        import cvxpy as cp
        d.extra(lambda V: [cp.abs(V[f"K{j}"]) <= K_bound for j in range(r)])
    sol = d.solve()
    P = sol["P"]
    K = np.array([sol[f"K{j}"] for j in range(r)])
    L = np.array([np.linalg.solve(P, Kj) for Kj in K])
    poles = check_poles(A, L, C, regs, name=name)
    return DMVTDesign(P, K, L, poles, sol, regs)


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


# ---- observer (6) on the bicycle, numba co-simulation --------------------------------------


@njit(cache=True)
def observer_rhs(xh, u, y, P, Av, Bv, zmin, zmax, L, C, out):
    """Observer (6) of Ichalal 2011 (compiled): ``out = sum_i mu_i(z(xh)) (A_i xh + B_i u)
    + sum_j mu_j L_j (y - C xh)`` with the premises (31)-(33) computed from the *estimate*
    ``xh`` (4,) (unmeasurable premise variables). The model part uses the exact (possibly
    extrapolated) weights, so it equals ``f(xh, u)`` even outside the sector; the gain part
    the clipped, convex weights. ``P`` = (p, c, v, g, ...), ``Av`` (r, 4, 4), ``Bv`` (r, 4, 1),
    ``zmin, zmax`` (3,), ``L`` (r or 1, 4, ny), ``C`` (ny, 4), ``y`` (ny,), ``out`` (4,)."""
    p, c, v, g = P[0], P[1], P[2], P[3]
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


def observer_step(xh, u, y, ts, L, C) -> np.ndarray:
    """Observer (6) of Ichalal 2011, readable numpy version of :func:`observer_rhs`.

    ``xh`` (4,) estimate, ``u`` scalar input, ``y`` (ny,) measurement, ``ts`` the 8-rule
    sector TS model (:func:`vehicle_observers.models.bicycle.bicycle_ts`), ``L`` (r or 1, 4,
    ny), ``C`` (ny, 4). Returns ``dxhat/dt`` (4,)::

        zhat = z(xhat)                          premises from the estimate (unmeasurable)
        model = sum_i mu_i(zhat) (A_i xhat + B_i u)       (= f(xhat, u), exact weights)
        gain  = sum_j mu_j(clip(zhat)) L_j               (convex blend of the gains)
        dxhat/dt = model + gain (y - C xhat)
    """
    from vehicle_observers.models.ts import memberships

    xh = np.asarray(xh, dtype=float)
    z = ts.premise_fn(xh[None], np.array([[u]]))[0]
    mu = memberships(z, ts.zmin, ts.zmax)
    mu_clip = memberships(np.clip(z, ts.zmin, ts.zmax), ts.zmin, ts.zmax)
    A, B = ts.blend(mu)
    gain = np.tensordot(mu_clip, L, axes=1) if len(L) == len(mu) else L[0]
    return A @ xh + B[:, 0] * u + gain @ (np.asarray(y, dtype=float) - C @ xh)


@njit(cache=True)
def _bike_rhs(s, t, P, Av, Bv, zmin, zmax, L, C, out):
    """Plant (25)+(27) (states 0..3) and observer (6) (states 4..7, :func:`observer_rhs`
    with ``y = C x``)."""
    p, c, v, g, k1, k2 = P[0], P[1], P[2], P[3], P[4], P[5]
    u = -k1 * (s[2] - np.sin(t)) - k2 * (s[3] - np.cos(t))
    out[0] = s[1] * v
    out[1] = u
    out[2] = s[3]
    out[3] = (g * np.sin(s[2]) + (1 + p * s[1] * np.sin(s[2])) * np.cos(s[2]) * s[1] * v * v
              + c * np.cos(s[2]) * v * u) / p
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
    t = np.ascontiguousarray(t, dtype=float)
    if t.ndim != 1 or len(t) < 2 or np.any(np.diff(t) <= 0):
        raise ValueError("time grid t must be 1-D, with >= 2 strictly increasing samples")
    L = np.ascontiguousarray(L, dtype=float)
    C = np.ascontiguousarray(np.atleast_2d(C), dtype=float)
    if C.shape[1] != 4:
        raise ValueError(f"C must have 4 columns (bicycle states), got shape {C.shape}")
    if L.ndim != 3 or L.shape[1:] != (4, C.shape[0]) or L.shape[0] not in (1, ts.n_rules):
        raise ValueError(f"L must have shape (1 or {ts.n_rules}, 4, {C.shape[0]}), got "
                         f"{L.shape}")
    s0 = np.concatenate([np.asarray(x0, dtype=float), np.asarray(xhat0, dtype=float)])
    if s0.shape != (8,):
        raise ValueError("x0 and xhat0 must each have 4 entries")
    S, U = _bike_obs_sim(s0, t, bp.as_array(), np.ascontiguousarray(ts.A),
                         np.ascontiguousarray(ts.B), ts.zmin, ts.zmax, L, C)
    return S[:, :4], S[:, 4:], U


def error_metrics(t, X, Xhat, band: float = 0.02) -> dict:
    """Per-state error overshoot (relative to |e(0)|) and ``band`` settling time [s]
    (band relative to max |e|), using :mod:`vehicle_observers.core.metrics`."""
    from vehicle_observers.core.metrics import overshoot, settling_time

    E = np.asarray(X) - np.asarray(Xhat)
    return {"overshoot": np.array([overshoot(E[:, i]) for i in range(E.shape[1])]),
            "settling": np.array([settling_time(t, E[:, i], band=band)
                                  for i in range(E.shape[1])]),
            "max_abs": np.abs(E).max(axis=0)}


def min_feasible_radius(vertices, C, a: float, R_lo: float, R_hi: float, tol: float = 0.05,
                        r: int = 1, check_ends: bool = True, **kw) -> float:
    """Smallest disk radius ``R`` (to ``tol``) for which (23)+(35)+(36) with half-plane ``a``
    is feasible and certified, by bisection on ``[R_lo, R_hi]``.

    With ``check_ends`` the ends are tested first: returns ``nan`` if ``R_hi`` is infeasible
    and ``R_lo`` if ``R_lo`` is feasible. Without it the caller guarantees the bracket
    (``R_lo`` infeasible, ``R_hi`` feasible, e.g. from :func:`region_sweep`).
    """
    from vehicle_observers.design.lmi import disk, halfplane

    if not R_hi > R_lo:
        raise ValueError(f"need R_hi > R_lo, got [{R_lo}, {R_hi}]")

    def ok(R):
        try:
            design_dmvt_observer(vertices, C, r=r, region=[halfplane(a), disk(R)],
                                 name=f"bisection a={a:g} R={R:g}", **kw)
            return True
        except InfeasibleDesign:
            return False

    if check_ends:
        if not ok(R_hi):
            return float("nan")
        if ok(R_lo):
            return float(R_lo)
    lo, hi = float(R_lo), float(R_hi)
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return hi


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


def initial_error_study(bp, t, ts, designs: dict, C, n: int, scale, seed: int = 0,
                        x0=(0.0, 0.0, 0.0, 0.0)) -> dict:
    """Observer runs from ``n`` random initial errors ``e0 ~ U(-scale, scale)`` (per state,
    drawn from ``np.random.default_rng(seed)``), the same draws for every design.

    Returns ``{design name: {"overshoot": (n, 4), "settling": (n, 4)}}`` and ``"e0"`` (n, 4).
    """
    rng = np.random.default_rng(seed)
    scale = np.asarray(scale, dtype=float)
    E0 = rng.uniform(-1.0, 1.0, size=(n, 4)) * scale
    out: dict = {"e0": E0}
    for name, des in designs.items():
        ov, st = np.empty((n, 4)), np.empty((n, 4))
        for k, e0 in enumerate(E0):
            X, Xh, _ = simulate_bicycle_observer(bp, t, ts, des.L, C, x0=x0,
                                                 xhat0=np.asarray(x0) - e0)
            m = error_metrics(t, X, Xh)
            ov[k], st[k] = m["overshoot"], m["settling"]
        out[name] = {"overshoot": ov, "settling": st}
    return out


# ---- figures (used by notebook 04) ----------------------------------------------------------


def plot_poles(ax, designs: dict, region=None, colors=("C3", "C0", "C2", "C1"),
               legend: bool = True):
    """Closed-loop eigenvalues [1/s] of every vertex pair of each design and the region
    (35)-(36) drawn, equal aspect (a disk is a circle); legend below the axes."""
    for (name, des), col in zip(designs.items(), colors, strict=False):
        ev = des.poles.eigs.ravel()
        ax.plot(ev.real, ev.imag, "x" if "no" in name else "o", color=col, ms=5, mfc="none",
                label=f"{name}: max $|\\mathrm{{Im}}\\,\\lambda|$ {des.poles.max_imag:.1f} 1/s, "
                      f"min $\\zeta$ {des.poles.min_damping:.2f}")
    for reg in _regions(region):
        if reg.L.shape == (1, 1):       # half-plane Re z < -a
            a = reg.L[0, 0] / 2
            ax.axvline(-a, color="k", ls="--", lw=0.9, label=f"(35): Re $z = -{a:g}$")
        elif reg.L.shape == (2, 2) and reg.L[0, 0] != 0:   # disk
            R, q = -reg.L[0, 0], -reg.L[0, 1]
            th = np.linspace(0, 2 * np.pi, 300)
            ax.plot(q + R * np.cos(th), R * np.sin(th), "k:", lw=0.9, label=f"(36): $|z| = {R:g}$")
    ax.axvline(0, color="0.5", lw=0.6)
    ax.set_xlabel(r"Re $\lambda$ [1/s]")
    ax.set_ylabel(r"Im $\lambda$ [1/s]")
    ax.set_aspect("equal", adjustable="datalim")
    if legend:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=1, frameon=False)
    return ax


def plot_sweep(ax, sweep: dict, chosen=None):
    """Feasibility map of the region sweep: feasible cells light blue and annotated with
    max |Im lambda| [1/s], infeasible cells light orange."""
    from matplotlib.patches import Rectangle

    F = sweep["feasible"]
    a, R = sweep["a"], sweep["R"]
    from matplotlib.colors import ListedColormap

    # colour-blind safe (tableau-colorblind10): light orange infeasible, light blue feasible
    ax.imshow(F.T.astype(float), origin="lower", cmap=ListedColormap(["#FFBC79", "#A2C8EC"]),
              vmin=0, vmax=1, aspect="auto", extent=(-0.5, len(a) - 0.5, -0.5, len(R) - 0.5))
    for ia in range(len(a)):
        for iR in range(len(R)):
            txt = f"{sweep['max_imag'][ia, iR]:.1f}" if F[ia, iR] else "infeas."
            ax.text(ia, iR, txt, ha="center", va="center", fontsize=7)
    ax.set_xticks(range(len(a)), [f"{x:g}" for x in a])
    ax.set_yticks(range(len(R)), [f"{x:g}" for x in R])
    ax.set_xlabel("half-plane $a$ [1/s] (Re $z < -a$)")
    ax.set_ylabel("disk radius $R$ [1/s] ($|z| < R$)")
    ax.grid(False)
    if chosen is not None:
        ia = int(np.argmin(np.abs(a - chosen[0])))
        iR = int(np.argmin(np.abs(R - chosen[1])))
        ax.add_patch(Rectangle((ia - 0.5, iR - 0.5), 1, 1, fill=False, lw=2, ec="k"))
    return ax


STATE_LABELS = (r"$x_1 = \beta$ [rad]", r"$x_2 = \psi_\beta$ [1/m]", r"$x_3 = \alpha$ [rad]",
                r"$x_4 = \psi_\alpha$ [rad/s]")


def plot_estimates(axs, t, X, Xhat, label="estimate", color="C1", truth=True):
    """Four panels: state ``X[:, i]`` and its estimate ``Xhat[:, i]`` (decimated)."""
    from vehicle_observers.core.arrays import decimate

    td, Xd, Xhd = decimate(t, X, Xhat, max_points=1500)
    for i, ax in enumerate(np.ravel(axs)[:4]):
        if truth:
            ax.plot(td, Xd[:, i], "k", lw=1.2, label="state")
        ax.plot(td, Xhd[:, i], "--", color=color, label=label)
        ax.set_ylabel(STATE_LABELS[i])
    np.ravel(axs)[0].legend(loc="best")
    for ax in np.ravel(axs)[-2:]:
        ax.set_xlabel("t [s]")
    return axs


def printed_jacobian_entries(X, U, include_third: bool = False) -> np.ndarray:
    """Literal transcription of Ichalal 2011 eqs. (32)-(33) along states ``X`` (N, 4) and
    inputs ``U`` (N,), with ``z2 -> x2``, ``z3 -> x3`` (the printed ``z`` are the DMVT points):

        (32)  100 cos x3 x2 sin x3 + 100 cos x3 sin x3 (+ 1/3)
        (33)  16.35 cos x3 + 100 x2^2 cos^2 x3 - 8.33 u sin x3 - 100 x2^2 sin^2 x3 (+ 1/3)

    The trailing ``+ 1/3`` (garbled in the extraction) is added when ``include_third``.
    Returns (N, 2). Used only to explain the printed premise bounds: (33) lacks the term
    ``-(v^2/p) x2 sin x3`` of the exact derivative and (32) does not match ``(v^2/p) cos x3
    (1 + 2 p x2 sin x3)`` at all (it vanishes at x3 = 0 where the exact value is v^2/p).
    """
    X = np.atleast_2d(np.asarray(X, dtype=float))
    U = np.ravel(U)
    x2, x3 = X[:, 1], X[:, 2]
    extra = 1.0 / 3.0 if include_third else 0.0
    xi1 = 100 * np.cos(x3) * x2 * np.sin(x3) + 100 * np.cos(x3) * np.sin(x3) + extra
    xi2 = (16.35 * np.cos(x3) + 100 * x2**2 * np.cos(x3) ** 2 - 8.33 * U * np.sin(x3)
           - 100 * x2**2 * np.sin(x3) ** 2 + extra)
    return np.column_stack([xi1, xi2])


def plot_tracking(axs, t, X, U):
    """Fig. 3 analogue: x3 vs sin t, x4 vs cos t, and the input u of (27)."""
    from vehicle_observers.core.arrays import decimate

    td, x3, x4, u = decimate(t, X[:, 2], X[:, 3], U, max_points=1500)
    axs[0].plot(td, x3, label=r"$x_3 = \alpha$")
    axs[0].plot(td, np.sin(td), "k--", label=r"$x_{3d} = \sin t$")
    axs[1].plot(td, x4, label=r"$x_4$")
    axs[1].plot(td, np.cos(td), "k--", label=r"$x_{4d} = \cos t$")
    axs[2].plot(td, u, "C2")
    axs[0].set_ylabel("roll [rad]")
    axs[1].set_ylabel("roll rate [rad/s]")
    axs[2].set_ylabel("$u$ [normalised]")
    axs[2].set_xlabel("t [s]")
    for ax in axs[:2]:
        ax.legend(loc="upper right")
    return axs


def plot_jacobian_bounds(axs, t, xi, jts: JacobianTS, printed_bounds, xi_printed=None,
                         units=None):
    """Varying Jacobian entries ``xi`` (N, k) with the derived (``jts``) and printed bounds;
    ``xi_printed`` (N, k) optionally overlays the printed formulas (NaN columns skipped);
    ``units`` (k,) the axis-label unit of each entry (none when omitted: the entries of one
    Jacobian generally have different units)."""
    from vehicle_observers.core.arrays import decimate

    td, xd = decimate(t, xi, max_points=1500)
    pd = None if xi_printed is None else decimate(t, xi_printed, max_points=1500)[1]
    for l, ax in enumerate(np.ravel(axs)):
        ax.plot(td, xd[:, l], label=rf"$\xi_{l + 1}$ exact")
        if pd is not None and np.all(np.isfinite(pd[:, l])):
            ax.plot(td, pd[:, l], "C2", label="printed (33), literal")
        for k, v in enumerate((jts.lo[l], jts.hi[l])):
            ax.axhline(v, color="C0", ls=":", label="derived bounds" if k else None)
        for k, v in enumerate(printed_bounds[l]):
            ax.axhline(v, color="C3", ls="--", label="printed bounds" if k else None)
        ax.set_ylabel(rf"$\xi_{l + 1}$" + (f" [{units[l]}]" if units is not None else ""))
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    np.ravel(axs)[-1].set_xlabel("t [s]")
    return axs
