"""LMI synthesis with cvxpy + Clarabel, and an independent certificate for every solution.

Every design in this repository is written as *builders*: plain Python functions of a
namespace of decision variables that return the matrix of one LMI. The same builder is
called twice:

1. with cvxpy variables, to pose the problem to the solver;
2. with the numeric values of the solution (numpy arrays), to recompute each constraint
   matrix from scratch and take its eigenvalues with LAPACK.

Step 2 does not look at the solver's status or its own residuals: a solution is accepted
only when every constraint matrix has the required sign with a positive margin. When it
fails, :class:`~vehicle_observers.core.errors.CertificationError` names the LMI and the amount.

LMI regions (Chilali & Gahinet, IEEE TAC 41(3), 1996), used by Ichalal 2011 eqs. (35)-(36):
``D = {z : L + M z + M^T conj(z) < 0}`` and ``A`` is D-stable iff there is ``P > 0`` with
``L (x) P + M (x) (P A) + M^T (x) (A^T P) < 0``. With an observer, ``P A`` is replaced by
``P A - K C`` (``K = P L``) so the constraint stays linear.
"""

from __future__ import annotations

import sys
import time
import warnings
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from vehicle_observers.core.errors import (
    CertificationError,
    InfeasibleDesign,
    ObserverArgumentError,
)

Builder = Callable[["Values"], object]


class _LazyCvxpy:
    """``cvxpy`` imported on first use (about 1-2 s: scipy.stats and the solvers): running a
    design read from a cache, or reading certificates, never needs it."""

    def __getattr__(self, name):
        import cvxpy

        globals()["cp"] = cvxpy
        return getattr(cvxpy, name)


cp = _LazyCvxpy()


def _is_expr(x) -> bool:
    # a cvxpy expression exists only once cvxpy is imported
    return "cvxpy" in sys.modules and isinstance(x, sys.modules["cvxpy"].Expression)


class LMIDataError(InfeasibleDesign):
    """The data of an LMI (a constant inside a constraint) is NaN or infinite: the design is
    refused before the solver sees it. ``lmi`` names the constraint."""


def _check_finite(design: str, name: str, M):
    """Raise :class:`LMIDataError` if constraint ``name`` holds a NaN/inf constant."""
    consts = [c.value for c in M.constants()] if _is_expr(M) else [M]
    for c in consts:
        a = np.asarray(c, dtype=float)
        if not np.all(np.isfinite(a)):
            bad = "NaN" if np.isnan(a).any() else "inf"
            raise LMIDataError(f"{design}: constraint {name!r} has {bad} in its data (expected "
                               f"finite matrices; check the model constants)", lmi=name,
                               status="bad_data")


def _shape(M) -> tuple:
    return tuple(M.shape) if _is_expr(M) else np.shape(np.asarray(M, dtype=float))


def _check_shape(design: str, name: str, M, kind: str):
    """Raise :class:`ObserverArgumentError` naming the constraint unless its matrix is 2-D
    (a scalar counts as 1 x 1) and, for a definite constraint, square and not empty."""
    sh = _shape(M)
    if len(sh) > 2 or (len(sh) == 2 and 0 in sh):
        raise ObserverArgumentError(f"{design}: constraint {name!r} is an array of shape {sh}; "
                                    "expected a non-empty matrix")
    if kind in ("neg", "pos") and len(sh) == 2 and sh[0] != sh[1]:
        raise ObserverArgumentError(f"{design}: constraint {name!r} is a {sh[0]} x {sh[1]} "
                                    "matrix; a definite (LMI) constraint must be square "
                                    "(check the shapes of its variables and constants)")


def _positive_int(design: str, what: str, n) -> int:
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ObserverArgumentError(f"{design}: {what} must be a positive integer, got {n!r}")
    return int(n)


def bmat(blocks):
    """Block matrix from a nested list; cvxpy if any block is a cvxpy expression else numpy."""
    if any(_is_expr(b) for row in blocks for b in row):
        return cp.bmat(blocks)
    return np.block([[np.asarray(b, dtype=float) for b in row] for row in blocks])


def kron(a, b):
    """Kronecker product ``a (x) b`` with constant ``a`` (cvxpy or numpy ``b``)."""
    if _is_expr(b):
        return cp.kron(np.asarray(a, dtype=float), b)
    return np.kron(a, b)


def transpose(x):
    return x.T


def symmetric_part(x):
    return (x + x.T) / 2


class _MissingVariable(AttributeError, KeyError):
    """A builder read a variable the design does not define."""


class Values(dict):
    """Decision variables by name, also readable as attributes (``V.P`` or ``V["P"]``)."""

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise _MissingVariable(name) from None

    def __missing__(self, name):
        raise _MissingVariable(name)


@dataclass
class ConstraintCheck:
    """Independent check of one constraint.

    ``margin`` > 0 means satisfied: for ``"neg"`` it is ``-lambda_max``, for ``"pos"``
    ``lambda_min``, for ``"nonneg"`` the smallest entry (element-wise constraints).
    ``relative`` divides the margin by the largest absolute eigenvalue / entry.
    """

    name: str
    kind: str
    margin: float
    relative: float
    asymmetry: float
    size: int

    @property
    def ok(self) -> bool:
        """The required sign holds, or (element-wise checks) an entry misses it only at
        round-off level (:attr:`roundoff`; the certificate is then ``"inconclusive"``)."""
        if self.kind in ("neg", "pos"):
            return self.margin > 0
        return self.margin >= 0 or self.roundoff

    @property
    def roundoff(self) -> bool:
        """An element-wise (``"nonneg"``) check whose smallest entry is negative by less than
        :data:`NONNEG_ROUNDOFF` of the matrix's largest entry: its sign is not known (e.g. a
        structural zero of ``S^-1 D S`` computed as -1.3e-15)."""
        return (self.kind == "nonneg" and self.margin < 0
                and self.relative >= -NONNEG_ROUNDOFF)


#: Smallest relative margin (margin / largest absolute eigenvalue of the same matrix) that a
#: certificate accepts as conclusive. The interior-point solver (Clarabel) stops at relative
#: residuals and gaps of about 1e-8: a constraint met by less than 1e-9 of its own scale holds
#: only to the accuracy of the solver's iterate (moving the decision variables by that accuracy
#: can flip the sign), even though LAPACK resolves the eigenvalue itself to ~1e-16.
MIN_RELATIVE_MARGIN = 1e-9
#: Largest condition number lambda_max / lambda_min of a positive-definite decision matrix (the
#: ``"pos"`` constraints, e.g. the Lyapunov matrix ``P > 0``) that a certificate accepts as
#: conclusive. Gains ``L = P^-1 W`` and bounds with ``lambda_max / lambda_min`` lose
#: log10(cond) of the 16 digits of double precision; above 1e8 fewer than 8 remain, below the
#: solver's own accuracy, so the certified matrix is not the one the gains were computed from.
MAX_CONDITION = 1e8
#: Largest relative shortfall ``-min(M) / max|M|`` of an element-wise (``"nonneg"``) check that
#: is read as round-off, not as a violation: entries formed by a few products and sums of
#: double-precision matrices (``A - L C``, ``S^-1 D S``) carry relative errors of
#: ``n eps ||.||`` (about 1e-15 for the sizes here, more after an ill-conditioned ``S``); 1e-12
#: (about 5000 eps) leaves room for that and is far below any deliberate margin. Such a
#: certificate is ``"inconclusive"``: the sign of that entry is not known.
NONNEG_ROUNDOFF = 1e-12
#: the values of :attr:`Certificate.status`
STATUSES = ("certified", "inconclusive", "violated")


@dataclass
class Certificate:
    """Independent eigenvalue checks of every constraint of one LMI solution.

    :attr:`ok`: every constraint has the required sign. :attr:`status` also asks whether the
    signs mean something numerically: ``"violated"`` (a constraint fails), ``"inconclusive"``
    (all signs right, but the smallest relative margin is below ``min_relative`` (default
    :data:`MIN_RELATIVE_MARGIN`) or a positive-definite constraint matrix has a condition
    number above ``max_cond`` (default :data:`MAX_CONDITION`), or an element-wise check misses
    its sign only at round-off level, :data:`NONNEG_ROUNDOFF`), else ``"certified"``. The two
    thresholds are per certificate: :meth:`LMIDesign.solve` and
    :func:`vehicle_observers.design.certify.certify_observer` take them per call.
    """

    checks: list[ConstraintCheck] = field(default_factory=list)
    #: smallest conclusive relative margin of this certificate (default
    #: :data:`MIN_RELATIVE_MARGIN`)
    min_relative: float = MIN_RELATIVE_MARGIN
    #: largest conclusive condition number of a ``"pos"`` matrix (default :data:`MAX_CONDITION`)
    max_cond: float = MAX_CONDITION

    @property
    def ok(self) -> bool:
        return all(c.ok for c in self.checks)

    @property
    def max_condition(self) -> float:
        """Largest condition number ``lambda_max / lambda_min`` over the positive-definite
        (``"pos"``) constraints, ``1 / relative`` of each (``inf`` if one is not positive
        definite, 1 if there is none)."""
        conds = [1.0 / c.relative if c.relative > 0 else np.inf
                 for c in self.checks if c.kind == "pos"]
        return float(max(conds)) if conds else 1.0

    @property
    def status(self) -> str:
        """``"certified"``, ``"inconclusive"`` or ``"violated"`` (see the class docstring)."""
        if not self.ok:
            return "violated"
        rel = self.min_relative_margin
        if (not np.isnan(rel) and rel < self.min_relative) or self.max_condition > self.max_cond \
                or any(c.roundoff for c in self.checks):
            return "inconclusive"
        return "certified"

    @property
    def min_margin(self) -> float:
        lm = [c.margin for c in self.checks if c.kind in ("neg", "pos")]
        return float(min(lm)) if lm else float("nan")

    @property
    def min_relative_margin(self) -> float:
        lm = [c.relative for c in self.checks if c.kind in ("neg", "pos")]
        return float(min(lm)) if lm else float("nan")

    def worst(self) -> ConstraintCheck:
        return min(self.checks, key=lambda c: (c.ok, c.relative))

    def table(self) -> str:
        lines = [f"{'constraint':<24} {'kind':<7} {'margin':>12} {'relative':>10} {'ok':>4}"]
        for c in self.checks:
            lines.append(f"{c.name:<24} {c.kind:<7} {c.margin:12.4e} {c.relative:10.2e} "
                         f"{'yes' if c.ok else 'NO':>4}")
        return "\n".join(lines)

    def as_dict(self) -> dict:
        return {c.name: {"kind": c.kind, "margin": c.margin, "relative": c.relative}
                for c in self.checks}


def _threshold(what: str, v) -> float:
    """A certificate threshold: a finite number > 0."""
    try:
        v = float(v)
    except (TypeError, ValueError):
        raise ObserverArgumentError(f"certificate threshold {what} must be a number, got "
                                    f"{v!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise ObserverArgumentError(f"certificate threshold {what} must be finite and > 0, got "
                                    f"{v!r}")
    return v


def check_matrix(name: str, M, kind: str) -> ConstraintCheck:
    """Eigenvalue (or entry-wise) check of one numeric constraint matrix.

    kind: ``"neg"`` (M < 0), ``"pos"`` (M > 0) or ``"nonneg"`` (every entry >= 0).
    """
    if kind not in ("neg", "pos", "nonneg"):
        raise ObserverArgumentError(f"check_matrix: kind must be 'neg', 'pos' or 'nonneg', got "
                                    f"{kind!r}")
    M = np.atleast_2d(np.asarray(M, dtype=float))
    _check_shape("check_matrix", name, M, kind)
    if not np.all(np.isfinite(M)):
        return ConstraintCheck(name, kind, -np.inf, -np.inf, np.nan, M.shape[0])
    if kind == "nonneg":
        scale = max(float(np.max(np.abs(M))), 1e-300)
        m = float(M.min())
        return ConstraintCheck(name, kind, m, m / scale, 0.0, M.size)
    with np.errstate(over="ignore", invalid="ignore"):
        S = M / 2 + M.T / 2                 # no overflow for entries near the float limit
        asym = float(np.max(np.abs(M / 2 - M.T / 2))) * 2 / max(float(np.max(np.abs(M))),
                                                                1e-300)
    try:
        ev = np.linalg.eigvalsh(S)
    except np.linalg.LinAlgError:           # LAPACK did not converge: not certified
        return ConstraintCheck(name, kind, -np.inf, -np.inf, asym, M.shape[0])
    scale = max(float(np.max(np.abs(ev))), 1e-300)
    margin = float(-ev[-1]) if kind == "neg" else float(ev[0])
    return ConstraintCheck(name, kind, margin, margin / scale, asym, M.shape[0])


@dataclass
class LMISolution:
    """Numeric solution of a certified design."""

    name: str
    values: Values
    certificate: Certificate
    status: str
    solve_time: float
    objective: float | None
    #: the solver's own time (Clarabel's ``solve_time``, cvxpy's canonicalisation excluded)
    #: [s]; ``solve_time`` is the wall time of ``Problem.solve`` (canonicalisation included)
    solver_seconds: float = float("nan")

    def __getitem__(self, key):
        return self.values[key]

    @property
    def solver_inaccurate(self) -> bool:
        """The solver reported ``optimal_inaccurate`` (cvxpy's "Solution may be inaccurate"):
        only the certificate (:attr:`certificate`, its ``status``) says whether the returned
        point satisfies the LMIs, and by how much."""
        return str(self.status).endswith("inaccurate")

    def summary(self) -> str:
        obj = "" if self.objective is None else f", objective {self.objective:.6g}"
        return (f"{self.name}: {self.status}{obj}, solve {self.solve_time*1e3:.0f} ms, "
                f"min margin {self.certificate.min_margin:.3e} "
                f"(relative {self.certificate.min_relative_margin:.2e})\n"
                + self.certificate.table())


class LMIDesign:
    """An LMI feasibility / optimisation problem built from reusable builders.

    Example (Lyapunov, ``A`` Hurwitz)::

        d = LMIDesign("lyap")
        d.symmetric("P", n)
        d.positive("P>0", lambda V: V.P)
        d.negative("AtP+PA<0", lambda V: A.T @ V.P + V.P @ A)
        sol = d.solve()          # certified, or raises InfeasibleDesign / CertificationError

    ``eps`` is the strictness margin imposed on the solver (``M << -eps I``); the
    certificate then demands strictly negative eigenvalues of the recomputed matrices.
    """

    def __init__(self, name: str, eps: float = 1e-7):
        if not (isinstance(eps, (int, float, np.floating)) and np.isfinite(eps) and eps >= 0):
            raise ObserverArgumentError(f"LMIDesign {name!r}: eps must be a finite number >= 0, "
                                        f"got {eps!r}")
        self.name = name
        self.eps = eps
        self._vars: dict[str, cp.Expression] = {}
        self._raw: dict[str, cp.Variable] = {}
        self._cons: list[tuple[str, str, Builder]] = []
        self._extra: list[Callable] = []
        self._margins: dict[str, float] = {}

    # ---- variables -------------------------------------------------------------------
    def _add(self, name, expr, raw):
        if name in self._vars:
            raise ValueError(f"variable {name!r} defined twice in design {self.name!r}")
        self._vars[name] = expr
        self._raw[name] = raw
        return expr

    def symmetric(self, name: str, n: int):
        """A symmetric ``n x n`` matrix variable (``n`` a positive integer)."""
        n = _positive_int(self.name, f"symmetric variable {name!r}: n", n)
        v = cp.Variable((n, n), symmetric=True, name=name)
        return self._add(name, v, v)

    def diagonal(self, name: str, n: int):
        """A diagonal ``n x n`` matrix variable (e.g. Ifqir 2017's diagonal P)."""
        n = _positive_int(self.name, f"diagonal variable {name!r}: n", n)
        d = cp.Variable(n, name=name)
        return self._add(name, cp.diag(d), d)

    def matrix(self, name: str, shape: tuple[int, int]):
        """A general ``shape = (rows, columns)`` matrix variable (e.g. a gain ``K``)."""
        if not (isinstance(shape, (tuple, list)) and len(shape) == 2):
            raise ObserverArgumentError(f"{self.name}: matrix variable {name!r}: shape must be "
                                        f"(rows, columns), got {shape!r}")
        shape = tuple(_positive_int(self.name, f"matrix variable {name!r}: shape entry", k)
                      for k in shape)
        v = cp.Variable(shape, name=name)
        return self._add(name, v, v)

    def scalar(self, name: str, nonneg: bool = True):
        v = cp.Variable(nonneg=nonneg, name=name)
        return self._add(name, v, v)

    def fixed(self, name: str, value):
        """A constant that builders read like a variable (kept in the solution)."""
        try:
            v = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ObserverArgumentError(f"{self.name}: constant {name!r} must be numeric, got "
                                        f"{type(value).__name__}") from None
        if name in self._vars:
            raise ObserverArgumentError(f"variable {name!r} defined twice in design "
                                        f"{self.name!r}")
        if v.ndim > 2 or v.size == 0:
            raise ObserverArgumentError(f"{self.name}: constant {name!r} has shape {v.shape}; "
                                        "expected a scalar, vector or non-empty matrix")
        self._vars[name] = v
        self._raw[name] = None
        return v

    # ---- constraints -------------------------------------------------------------------
    def _constraint(self, name, kind, builder):
        if not callable(builder):
            raise ObserverArgumentError(f"{self.name}: constraint {name!r}: builder must be a "
                                        f"function of the variables, got "
                                        f"{type(builder).__name__}")
        self._cons.append((name, kind, builder))

    def negative(self, name: str, builder: Builder):
        """Require ``builder(V) < 0`` (negative definite; a square matrix)."""
        self._constraint(name, "neg", builder)

    def positive(self, name: str, builder: Builder):
        """Require ``builder(V) > 0`` (positive definite; a square matrix)."""
        self._constraint(name, "pos", builder)

    def nonnegative(self, name: str, builder: Builder, margin: float = 0.0):
        """Require every entry of ``builder(V)`` to be >= 0 (e.g. a Metzler off-diagonal).

        ``margin`` > 0 asks the solver for entries >= margin, so its round-off (~1e-12)
        cannot fail the certificate, which still checks >= 0 on the recomputed matrix.
        """
        if not (np.isfinite(margin) and margin >= 0):
            raise ObserverArgumentError(f"{self.name}: constraint {name!r}: margin must be a "
                                        f"finite number >= 0, got {margin!r}")
        self._constraint(name, "nonneg", builder)
        self._margins[name] = float(margin)

    def extra(self, fn: Callable):
        """Additional cvxpy constraints ``fn(V) -> list`` (e.g. gain bounds), not certified."""
        self._extra.append(fn)

    @property
    def constraint_names(self) -> list[str]:
        return [c[0] for c in self._cons]

    # ---- solve & certify ------------------------------------------------------------------
    def _cvx_constraints(self):
        V = Values(self._vars)
        out = []
        for name, kind, b in self._cons:
            M = self._build(name, kind, b, V)
            _check_finite(self.name, name, M)
            if kind == "nonneg":
                out.append(M >= self._margins.get(name, 0.0))
                continue
            if not _is_expr(M):
                continue  # constant matrix: checked in the certificate only
            S = symmetric_part(M)
            I = np.eye(S.shape[0])
            out.append(S << -self.eps * I if kind == "neg" else S >> self.eps * I)
        for fn in self._extra:
            out.extend(fn(V))
        return out

    def _build(self, name, kind, b, V):
        """``b(V)`` with its shape checked; a builder that fails on mismatched shapes (numpy's
        or cvxpy's broadcast error) is reported naming the constraint."""
        try:
            M = b(V)
        except (ValueError, IndexError) as exc:
            if isinstance(exc, ObserverArgumentError):
                raise
            raise ObserverArgumentError(f"{self.name}: constraint {name!r} cannot be built: "
                                        f"{str(exc).splitlines()[0] if str(exc) else exc!r} "
                                        "(check the shapes of its variables and constants)"
                                        ) from None
        except _MissingVariable as exc:
            raise ObserverArgumentError(f"{self.name}: constraint {name!r} reads variable "
                                        f"{exc.args[0]!r}, which is not defined") from None
        _check_shape(self.name, name, M, kind)
        return M

    def certify(self, values: dict, min_relative_margin: float = MIN_RELATIVE_MARGIN,
                max_condition: float = MAX_CONDITION) -> Certificate:
        """Recompute every constraint from numeric ``values`` and check its eigenvalues
        (``min_relative_margin``, ``max_condition``: the thresholds of
        :attr:`Certificate.status`)."""
        V = Values(values)
        return Certificate([check_matrix(name, self._build(name, kind, b, V), kind)
                            for name, kind, b in self._cons],
                           _threshold("min_relative_margin", min_relative_margin),
                           _threshold("max_condition", max_condition))

    def solve(self, objective: Callable | None = None, solver: str = "CLARABEL",
              raise_on_failure: bool = True, min_relative_margin: float = MIN_RELATIVE_MARGIN,
              max_condition: float = MAX_CONDITION, **solver_kw) -> LMISolution:
        """Solve (minimise ``objective(V)`` if given), then certify independently
        (thresholds ``min_relative_margin``, ``max_condition`` of the certificate's status,
        defaults :data:`MIN_RELATIVE_MARGIN`, :data:`MAX_CONDITION`).

        Raises :class:`InfeasibleDesign` if the solver finds no solution and
        :class:`CertificationError` if its solution fails the eigenvalue certificate
        (message: which constraint and by how much).
        """
        cons = self._cvx_constraints()
        obj = cp.Minimize(objective(Values(self._vars))) if objective else cp.Minimize(0)
        prob = cp.Problem(obj, cons)
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                # cvxpy warns "Solution may be inaccurate" for the status optimal_inaccurate;
                # the status is kept in LMISolution.status (``solver_inaccurate``) and the
                # independent certificate decides, so the warning is not repeated to the user
                warnings.filterwarnings("ignore", message="Solution may be inaccurate",
                                        category=UserWarning)
                prob.solve(solver=solver, **solver_kw)
        except cp.error.SolverError as exc:
            raise InfeasibleDesign(f"{self.name}: solver {solver} failed ({exc})",
                                   status="solver_error") from exc
        dt = time.perf_counter() - t0
        status = prob.status
        if status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE, cp.UNBOUNDED,
                      cp.UNBOUNDED_INACCURATE) or any(
                self._raw[k] is not None and self._raw[k].value is None for k in self._raw):
            raise InfeasibleDesign(
                f"{self.name}: the LMIs are infeasible (solver status {status!r}); "
                f"constraints: {', '.join(self.constraint_names)}", status=status)
        values = Values()
        for k, raw in self._raw.items():
            expr = self._vars[k]
            values[k] = np.array(expr if raw is None else expr.value, dtype=float)
        cert = self.certify(values, min_relative_margin, max_condition)
        stats = getattr(prob, "solver_stats", None)
        own = getattr(stats, "solve_time", None) if stats is not None else None
        sol = LMISolution(self.name, values, cert, status, dt,
                          None if objective is None else float(prob.value),
                          float(own) if own is not None else float("nan"))
        if raise_on_failure and not cert.ok:
            w = cert.worst()
            what = {"neg": "largest eigenvalue", "pos": "smallest eigenvalue",
                    "nonneg": "smallest entry"}[w.kind]
            need = {"neg": "< 0", "pos": "> 0", "nonneg": ">= 0"}[w.kind]
            val = -w.margin if w.kind == "neg" else w.margin
            raise CertificationError(
                f"{self.name}: constraint {w.name!r} fails the independent check: {what} = "
                f"{val:.3e} (needs {need}; solver status {status!r})",
                lmi=w.name, violation=-w.margin, status=status)
        return sol


# ---- LMI regions (Chilali & Gahinet 1996) -----------------------------------------------
@dataclass(frozen=True)
class Region:
    """LMI region ``{z : L + M z + M^T conj(z) < 0}`` with a readable name."""

    name: str
    L: np.ndarray
    M: np.ndarray

    def __post_init__(self):
        L = np.atleast_2d(np.asarray(self.L, dtype=float))
        M = np.atleast_2d(np.asarray(self.M, dtype=float))
        for arg, X in (("L", L), ("M", M)):
            if X.ndim != 2 or X.shape[0] != X.shape[1] or not np.all(np.isfinite(X)):
                raise ObserverArgumentError(f"Region {self.name!r}: {arg} must be a finite "
                                            f"square matrix, got shape {X.shape}")
        if L.shape != M.shape:
            raise ObserverArgumentError(f"Region {self.name!r}: L {L.shape} and M {M.shape} "
                                        "must have the same shape")
        if not np.allclose(L, L.T):
            raise ObserverArgumentError(f"Region {self.name!r}: L must be symmetric")
        object.__setattr__(self, "L", L)
        object.__setattr__(self, "M", M)

    def lmi(self, P, PA):
        """Characteristic matrix ``L (x) P + M (x) PA + M^T (x) PA^T`` (must be < 0)."""
        return kron(self.L, P) + kron(self.M, PA) + kron(self.M.T, transpose(PA))

    def contains(self, z) -> np.ndarray:
        """Point-wise membership test of complex numbers ``z`` (strict)."""
        z = np.atleast_1d(np.asarray(z, dtype=complex))
        if not np.all(np.isfinite(z)):
            raise ObserverArgumentError(f"Region {self.name!r}.contains: z must be finite, got "
                                        f"{z[~np.isfinite(z)][0]}")
        # every point's matrix in one stack, one batched LAPACK call (same routine per point)
        zz = z.ravel()[:, None, None]
        F = self.L[None] + self.M[None] * zz + self.M.T[None] * np.conj(zz)
        H = (F + np.conj(np.swapaxes(F, 1, 2))) / 2
        return (np.linalg.eigvalsh(H)[:, -1] < 0).reshape(z.shape)


def _finite(fn: str, arg: str, v, positive=False) -> float:
    try:
        v = float(v)
    except (TypeError, ValueError):
        raise ObserverArgumentError(f"{fn}: {arg} must be a number, got {v!r}") from None
    if not np.isfinite(v) or (positive and v <= 0):
        raise ObserverArgumentError(f"{fn}: {arg} must be a finite number"
                                    f"{' > 0' if positive else ''}, got {v!r}")
    return v


def halfplane(a: float) -> Region:
    """``Re(z) < -a``: ``2 a P + P A + A^T P < 0`` (Ichalal 2011 eq. (35))."""
    a = _finite("halfplane", "a", a)
    return Region(f"Re(z) < -{a:g}", np.array([[2.0 * a]]), np.array([[1.0]]))


def disk(R: float, center: float = 0.0) -> Region:
    """``|z - center| < R`` (Ichalal 2011 eq. (36) with center 0):
    ``[[-R P, q P + P A], [q P + A^T P, -R P]] < 0``."""
    R = _finite("disk", "R (radius)", R, positive=True)
    center = _finite("disk", "center", center)
    q = -center
    return Region(f"|z{'' if center == 0 else f' - {center:g}'}| < {R:g}",
                  np.array([[-R, q], [q, -R]], dtype=float),
                  np.array([[0.0, 1.0], [0.0, 0.0]]))


def sector(theta: float) -> Region:
    """Conic sector ``|Im z| < -Re(z) tan(theta)``, i.e. damping ratio > cos(theta);
    ``0 < theta < pi/2`` [rad]."""
    theta = _finite("sector", "theta", theta)
    if not 0 < theta < np.pi / 2:
        raise ObserverArgumentError(f"sector: theta must be in (0, pi/2) rad, got {theta!r}")
    s, c = np.sin(theta), np.cos(theta)
    return Region(f"sector {np.degrees(theta):.1f} deg",
                  np.zeros((2, 2)), np.array([[s, c], [-c, s]]))


def strip(lo: float | None = None, hi: float | None = None, half_width: float | None = None
          ) -> Region:
    """Vertical strip ``lo < Re(z) < hi`` (Chilali & Gahinet 1996, ``L = diag(2 lo, -2 hi)``,
    ``M = diag(-1, 1)``) or, with ``half_width = w``, the horizontal strip ``|Im z| < w``
    (``L = -2 w I_2``, ``M = [[0, 1], [-1, 0]]``: oscillation frequency below ``w`` rad/s)."""
    if half_width is not None:
        if lo is not None or hi is not None:
            raise ObserverArgumentError("strip: give either lo/hi (vertical) or half_width "
                                        "(horizontal), not both")
        w = _finite("strip", "half_width", half_width, positive=True)
        return Region(f"|Im z| < {w:g}", -2.0 * w * np.eye(2), np.array([[0.0, 1.0],
                                                                          [-1.0, 0.0]]))
    if lo is None or hi is None:
        raise ObserverArgumentError("strip: a vertical strip needs both lo and hi")
    lo, hi = _finite("strip", "lo", lo), _finite("strip", "hi", hi)
    if not lo < hi:
        raise ObserverArgumentError(f"strip: need lo < hi, got {lo!r}, {hi!r}")
    return Region(f"{lo:g} < Re(z) < {hi:g}", np.diag([2.0 * lo, -2.0 * hi]),
                  np.diag([-1.0, 1.0]))


def ellipse(a: float, b: float, center: float = 0.0) -> Region:
    """Ellipse ``((Re z - center)/a)^2 + (Im z / b)^2 < 1`` (axes ``a`` along the real axis,
    ``b`` along the imaginary one). Chilali & Gahinet (1996) form ``f(z) = [[-1, g], [conj(g),
    -1]] < 0`` with ``g = Re(z - c)/a + i Im(z)/b`` (so ``f < 0`` iff ``|g| < 1``):
    ``L = [[-1, -c/a], [-c/a, -1]]``, ``M = [[0, (1/a + 1/b)/2], [(1/a - 1/b)/2, 0]]``."""
    a = _finite("ellipse", "a", a, positive=True)
    b = _finite("ellipse", "b", b, positive=True)
    c = _finite("ellipse", "center", center)
    L = np.array([[-1.0, -c / a], [-c / a, -1.0]])
    M = np.array([[0.0, (1 / a + 1 / b) / 2], [(1 / a - 1 / b) / 2, 0.0]])
    return Region(f"ellipse a={a:g} b={b:g} c={c:g}", L, M)


def unit_disk(rho: float = 1.0) -> Region:
    """Discrete time: poles strictly inside the disk ``|z| < rho`` (``rho <= 1``; ``rho = 1``
    is Schur stability, ``rho < 1`` a contraction rate per sample)."""
    rho = _finite("unit_disk", "rho", rho, positive=True)
    if rho > 1:
        raise ObserverArgumentError(f"unit_disk: rho must be <= 1 (inside the unit circle), got "
                                    f"{rho!r}")
    r = disk(rho)
    return Region(f"|z| < {rho:g} (discrete)", r.L, r.M)


def discrete_disk(R: float, center: float = 0.0) -> Region:
    """Discrete time: the disk ``|z - center| < R`` inside the unit circle
    (``|center| + R <= 1``), e.g. to bound the damping and the speed of a sampled observer."""
    R = _finite("discrete_disk", "R", R, positive=True)
    center = _finite("discrete_disk", "center", center)
    if abs(center) + R > 1:
        raise ObserverArgumentError(f"discrete_disk: |center| + R = {abs(center) + R:g} > 1: the "
                                    "disk leaves the unit circle")
    r = disk(R, center)
    return Region(f"|z - {center:g}| < {R:g} (discrete)", r.L, r.M)
