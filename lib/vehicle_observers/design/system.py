"""Polytopic / Takagi-Sugeno systems given as data: the vertex matrices of an observer design.

A polytopic (LPV, or TS with the convex memberships ``h_i >= 0``, ``sum h_i = 1``) system

    x' = sum_i h_i (A_i x + B_i u + E_i w),      y = sum_i h_i (C_i x + D_i w)

(``x'`` the derivative in continuous time, ``x_{k+1}`` in discrete time) is described by its
``q`` vertices: ``A`` (q, n, n), ``B`` (q, n, m), ``C`` (q, p, n), disturbance ``E``
(q, n, nw), measurement feedthrough of the disturbance ``D`` (q, p, nw); a matrix common to all
vertices may be given once (2-D). ``H`` (nz, n) selects the estimation error whose gain from
``w`` is bounded (default ``I_n``: the whole error), ``Dz`` (q, nz, nw) its direct feedthrough
``z = H e + Dz w`` (default 0; an unknown-input observer's estimate ``z + H_uio y`` reads the
measurement noise directly). ``rate_bounds`` (q,) bound
``|dh_i/dt|`` (used by a parameter-dependent Lyapunov matrix).

Everything an LMI design or its certificate needs is read from this object, never from user
code: :mod:`vehicle_observers.design.synthesis` builds the LMIs from these arrays and
:mod:`vehicle_observers.design.certify` rebuilds them in numpy from the same arrays and the
returned gains.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError

TIMES = ("continuous", "discrete")


def _stack(who: str, name: str, X, q: int | None, rows: int | None, cols: int | None):
    """``X`` as a (q, rows, cols) float array; 2-D input is repeated for every vertex."""
    try:
        X = np.asarray(X, dtype=float)
    except (TypeError, ValueError):
        raise ObserverArgumentError(f"{who}: {name} must be numeric arrays") from None
    if X.ndim == 2:
        X = X[None] if q is None else np.broadcast_to(X, (q, *X.shape)).copy()
    if X.ndim != 3:
        raise ObserverArgumentError(f"{who}: {name} must have shape (q, rows, columns) or "
                                    f"(rows, columns), got {X.shape}")
    if q is not None and X.shape[0] not in (q,):
        raise ObserverArgumentError(f"{who}: {name} has {X.shape[0]} vertices, A has {q}")
    if rows is not None and X.shape[1] != rows:
        raise ObserverArgumentError(f"{who}: {name} must have {rows} rows, got shape {X.shape}")
    if cols is not None and X.shape[2] != cols:
        raise ObserverArgumentError(f"{who}: {name} must have {cols} columns, got shape "
                                    f"{X.shape}")
    if not np.all(np.isfinite(X)):
        k = int(np.argwhere(~np.isfinite(X))[0][0])
        raise ObserverArgumentError(f"{who}: {name} of vertex {k + 1} has NaN or inf entries")
    return X


@dataclass(frozen=True)
class PolytopicSystem:
    """Vertex data of a polytopic / TS system (module docstring for the model).

    Parameters
    ----------
    A : (q, n, n) or (n, n) state matrices ``A_i``.
    C : (q, p, n) or (p, n) output matrices ``C_i``.
    B : (q, n, m) or (n, m) input matrices (default: no input, m = 0).
    E : (q, n, nw) or (n, nw) disturbance matrices (default: no disturbance, nw = 0).
    D : (q, p, nw) or (p, nw) disturbance-to-output matrices (default 0).
    H : (nz, n) performance output of the error ``z = H e`` (default ``I_n``).
    time : ``"continuous"`` or ``"discrete"``.
    dt : sample period [s] of a discrete-time system (decay rates in 1/s use it), default 1.
    rate_bounds : (q,) bounds ``|dh_i/dt| <= phi_i`` [1/s] of the memberships, or ``None``.
    name : used in every error message.
    Dz : (q, nz, nw) or (nz, nw) feedthrough of the disturbance to the performance output
        ``z = H e + Dz w`` (default 0).
    """

    A: np.ndarray
    C: np.ndarray
    B: np.ndarray | None = None
    E: np.ndarray | None = None
    D: np.ndarray | None = None
    H: np.ndarray | None = None
    time: str = "continuous"
    dt: float = 1.0
    rate_bounds: np.ndarray | None = None
    name: str = "system"
    Dz: np.ndarray | None = None
    meta: dict = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self):
        who = f"PolytopicSystem {self.name!r}"
        A = _stack(who, "A", self.A, None, None, None)
        q, n, n2 = A.shape
        if n != n2 or n == 0:
            raise ObserverArgumentError(f"{who}: A must be square (n x n), got {A.shape[1:]}")
        C = _stack(who, "C", self.C, q, None, n)
        p = C.shape[1]
        if p == 0:
            raise ObserverArgumentError(f"{who}: C has no rows (no measurement)")
        B = np.zeros((q, n, 0)) if self.B is None else _stack(who, "B", self.B, q, n, None)
        E = np.zeros((q, n, 0)) if self.E is None else _stack(who, "E", self.E, q, n, None)
        nw = E.shape[2]
        D = np.zeros((q, p, nw)) if self.D is None else _stack(who, "D", self.D, q, p, nw)
        H = np.eye(n) if self.H is None else _stack(who, "H", self.H, None, None, n)[0]
        Dz = np.zeros((q, H.shape[0], nw)) if self.Dz is None else \
            _stack(who, "Dz", self.Dz, q, H.shape[0], nw)
        if self.time not in TIMES:
            raise ObserverArgumentError(f"{who}: time must be one of {TIMES}, got {self.time!r}")
        dt = float(self.dt)
        if not (np.isfinite(dt) and dt > 0):
            raise ObserverArgumentError(f"{who}: dt must be finite and > 0 [s], got {self.dt!r}")
        rb = self.rate_bounds
        if rb is not None:
            rb = np.asarray(rb, dtype=float)
            if rb.shape != (q,) or not np.all(np.isfinite(rb)) or np.any(rb < 0):
                raise ObserverArgumentError(f"{who}: rate_bounds must be {q} finite values >= 0 "
                                            f"(one per vertex), got {self.rate_bounds!r}")
        for k, v in (("A", A), ("B", B), ("C", C), ("D", D), ("E", E), ("H", H), ("dt", dt),
                     ("rate_bounds", rb), ("Dz", Dz)):
            object.__setattr__(self, k, v)

    # ---- sizes ------------------------------------------------------------------------
    @property
    def q(self) -> int:
        """Number of vertices."""
        return self.A.shape[0]

    @property
    def n(self) -> int:
        return self.A.shape[1]

    @property
    def p(self) -> int:
        return self.C.shape[1]

    @property
    def nw(self) -> int:
        return self.E.shape[2]

    @property
    def common_C(self) -> bool:
        """``C_i`` equal at every vertex (a PDC observer then needs no double sum)."""
        return bool(np.all(self.C == self.C[0]))

    @property
    def discrete(self) -> bool:
        return self.time == "discrete"

    # ---- structure --------------------------------------------------------------------
    def unobservable_modes(self, tol: float = 1e-9) -> list[tuple[int, complex]]:
        """``(vertex, eigenvalue)`` of every mode of ``(A_i, C_i)`` that fails the PBH rank
        test ``rank [A_i - lambda I; C_i] = n`` and is not stable (``Re >= 0`` in continuous
        time, ``|lambda| >= 1`` in discrete time): a design is impossible when one exists."""
        bad = []
        for i in range(self.q):
            for lam in np.linalg.eigvals(self.A[i]):
                stable = abs(lam) < 1 if self.discrete else lam.real < 0
                if stable:
                    continue
                M = np.vstack([self.A[i] - lam * np.eye(self.n), self.C[i]])
                s = np.linalg.svd(M, compute_uv=False)
                if s[-1] <= tol * max(s[0], 1.0):
                    bad.append((i, complex(lam)))
        return bad

    def check_detectable(self):
        """Raise :class:`ObserverArgumentError` naming the vertex and the mode when a vertex
        ``(A_i, C_i)`` is not detectable."""
        bad = self.unobservable_modes()
        if bad:
            i, lam = bad[0]
            raise ObserverArgumentError(f"{self.name}: vertex {i + 1}: the mode {lam:.4g} of A "
                                        "is unobservable from C and not stable (PBH test): no "
                                        "observer gain can stabilise the error")

    def transformed(self, S) -> "PolytopicSystem":
        """The same system in the state ``x~ = S^-1 x``: ``A~ = S^-1 A S``, ``B~ = S^-1 B``,
        ``C~ = C S``, ``E~ = S^-1 E``, ``H~ = H S`` (a congruence of every observer LMI with
        ``S``: gains map back by ``L = S L~``, ``P = S^-T P~ S^-1``)."""
        S = np.atleast_2d(np.asarray(S, dtype=float))
        if S.shape != (self.n, self.n) or not np.all(np.isfinite(S)):
            raise ObserverArgumentError(f"{self.name}: transformation must be a finite "
                                        f"{self.n} x {self.n} matrix, got {S.shape}")
        Si = np.linalg.inv(S)
        return PolytopicSystem(Si @ self.A @ S, self.C @ S, Si @ self.B, Si @ self.E, self.D,
                               self.H @ S, self.time, self.dt, self.rate_bounds,
                               f"{self.name} (transformed)", self.Dz)

    def with_A(self, A, name: str | None = None) -> "PolytopicSystem":
        """A copy with other state matrices (e.g. ``T A_i`` of an unknown-input observer)."""
        return PolytopicSystem(A, self.C, self.B, self.E, self.D, self.H, self.time, self.dt,
                               self.rate_bounds, name or self.name, self.Dz)

    def error_system(self, i: int, L, j: int | None = None):
        """``(A_cl, B_cl, C_cl, D_cl)`` of the estimation error at vertex pair ``(i, j)``:
        ``e' = (A_i - L C_i) e + (E_i - L D_i) w``, ``z = H e + Dz_i w`` (``L`` (n, p))."""
        L = np.asarray(L, dtype=float)
        return (self.A[i] - L @ self.C[i], self.E[i] - L @ self.D[i], self.H, self.Dz[i].copy())

    @property
    def has_feedthrough(self) -> bool:
        """``Dz`` is not zero (the performance output reads the disturbance directly)."""
        return bool(np.any(self.Dz))

    def time_scaled(self, tau: float) -> "PolytopicSystem":
        """The same continuous-time system in the time unit ``tau`` [s]: ``A, B, E`` times
        ``tau`` (``C, D, H, Dz`` unchanged, rate bounds times ``tau``). An observer gain ``K~``
        designed on it is ``K = K~ / tau`` in seconds; decay rates scale by ``tau``, a pole
        radius by ``tau``, the L2 gain is unchanged. Used to bring fast dynamics to O(1) before
        an LMI solver sees them (conditioning)."""
        tau = float(tau)
        if self.discrete or not (np.isfinite(tau) and tau > 0):
            raise ObserverArgumentError(f"{self.name}: time_scaled needs a continuous-time system "
                                        f"and a finite tau > 0 [s], got {self.time}, {tau!r}")
        rb = None if self.rate_bounds is None else self.rate_bounds * tau
        return PolytopicSystem(self.A * tau, self.C, self.B * tau, self.E * tau, self.D, self.H,
                               self.time, self.dt, rb, self.name, self.Dz)
