"""Generic Takagi-Sugeno (TS) models by sector nonlinearity (Tanaka & Wang 2001, ch. 2).

A nonlinear model is written ``x' = A(z) x + B(z) u`` where ``A, B`` are *multi-affine*
in the premise variables ``z = (z_1..z_p)`` (affine in each one separately) and each
``z_j`` is bounded, ``z_j^min <= z_j <= z_j^max``. With the two-sided weights

    w_j^0 = (z_j - z_j^min) / (z_j^max - z_j^min),   w_j^1 = 1 - w_j^0,

and vertex ``i`` given by bits ``(b_1..b_p)`` (``b_j = 0`` -> ``z_j^max``,
``b_j = 1`` -> ``z_j^min``; ``z_1`` is the most significant bit), the memberships
``h_i = prod_j w_j^{b_j}`` are a convex sum and ``sum_i h_i A(z_vertex_i) = A(z)``
*exactly* (bilinear interpolation is exact for multi-affine functions). This is the
ordering of Ichalal 2011 (mu_1 = F_1^0 F_2^0 F_3^0) and, with premises ordered
``(f_r, f_f, v_x)``, of Yacine 2015 eq. (22).

The exactness holds only inside the bounds: :meth:`SectorTS.memberships` raises
:class:`~vehicle_observers.core.errors.PremiseOutOfBounds` naming the premise, the sample and
the value when a premise leaves them (``clip=True`` saturates instead, which is what an
observer fed with noisy estimates needs; the TS model is then no longer exact there).

The second TS form here is the *Jacobian* TS model of the differential mean value theorem
(Ichalal, Arioui, Mammar, MED 2011, eqs. (12)-(18), (34)): :class:`JacobianTS`, built from
entry bounds (:func:`jacobian_ts_from_bounds`) or from sampled Jacobians
(:func:`jacobian_ts_from_samples`), the model of the DMVT observer's error dynamics
(:mod:`vehicle_observers.observers.dmvt`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import product
from typing import Callable, Sequence

import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError, PremiseOutOfBounds


@dataclass(frozen=True)
class Premise:
    """One premise variable with its sector bounds and a unit for messages."""

    name: str
    zmin: float
    zmax: float
    unit: str = ""

    def __post_init__(self):
        if not (np.isfinite(self.zmin) and np.isfinite(self.zmax) and self.zmax > self.zmin):
            raise ValueError(f"premise {self.name!r}: need finite bounds with zmax > zmin, "
                             f"got [{self.zmin}, {self.zmax}]")


def vertex_bits(p: int) -> np.ndarray:
    """(2^p, p) array of bits; row i is vertex i (0 -> zmax, 1 -> zmin), z_1 most significant."""
    return np.array(list(product((0, 1), repeat=p)), dtype=int)


def memberships(z, zmin, zmax) -> np.ndarray:
    """Membership functions ``h_i(z)`` for premises ``z`` of shape (..., p).

    Returns shape (..., 2^p); rows sum to one. No bound checking (see SectorTS).
    """
    z = np.asarray(z, dtype=float)
    zmin = np.asarray(zmin, dtype=float)
    zmax = np.asarray(zmax, dtype=float)
    w0 = (z - zmin) / (zmax - zmin)            # weight of the zmax vertex
    p = z.shape[-1]
    bits = vertex_bits(p)
    h = np.ones(z.shape[:-1] + (len(bits),))
    for j in range(p):
        wj = np.where(bits[:, j] == 0, w0[..., j, None], 1.0 - w0[..., j, None])
        h = h * wj
    return h


class SectorTS:
    """Exact TS model of ``x' = A(z) x + B(z) u`` on a box of premises.

    Parameters
    ----------
    premises : sequence of :class:`Premise`
    matrices : callable ``z -> (A, B)`` with ``z`` of shape (p,), multi-affine in ``z``.
    premise_fn : callable ``(x, u, *args) -> z`` evaluating the premises along a trajectory;
        ``x`` (N, n), ``u`` (N, m) -> (N, p). Optional; used by :meth:`rhs` and
        :meth:`exactness`.
    name : for messages.

    Attributes
    ----------
    A, B : vertex matrices, shapes (2^p, n, n) and (2^p, n, m).
    """

    def __init__(self, premises: Sequence[Premise], matrices: Callable, premise_fn=None,
                 name: str = "TS model", check_multiaffine: bool = True):
        self.premises = tuple(premises)
        self.name = name
        self.matrices = matrices
        self.premise_fn = premise_fn
        self.zmin = np.array([p.zmin for p in self.premises])
        self.zmax = np.array([p.zmax for p in self.premises])
        self.bits = vertex_bits(len(self.premises))
        self.z_vertices = np.where(self.bits == 0, self.zmax, self.zmin)
        AB = [matrices(zv) for zv in self.z_vertices]
        self.A = np.array([np.atleast_2d(a) for a, _ in AB], dtype=float)
        self.B = np.array([np.atleast_2d(b) for _, b in AB], dtype=float)
        if check_multiaffine:
            self._check_multiaffine()

    @property
    def n_rules(self) -> int:
        return len(self.A)

    def _check_multiaffine(self, n: int = 16, seed: int = 12345):
        """Convex interpolation must reproduce ``A(z), B(z)`` at random interior points."""
        rng = np.random.default_rng(seed)
        z = self.zmin + rng.random((n, len(self.premises))) * (self.zmax - self.zmin)
        h = memberships(z, self.zmin, self.zmax)
        for zk, hk in zip(z, h):
            A, B = self.matrices(zk)
            Ai = np.tensordot(hk, self.A, axes=1)
            Bi = np.tensordot(hk, self.B, axes=1)
            scale = max(np.abs(self.A).max(), np.abs(self.B).max(), 1e-300)
            err = max(np.abs(Ai - A).max(), np.abs(Bi - np.atleast_2d(B)).max()) / scale
            if err > 1e-10:
                raise ValueError(f"{self.name}: matrices(z) is not multi-affine in the premises "
                                 f"(interpolation error {err:.2e} at z = {zk}); a sector TS "
                                 "form would not be exact")

    def check_bounds(self, z, tol: float = 1e-12):
        """Raise :class:`PremiseOutOfBounds` at the first sample outside the sector bounds."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        span = self.zmax - self.zmin
        bad = (z < self.zmin - tol * span) | (z > self.zmax + tol * span) | ~np.isfinite(z)
        if bad.any():
            k, j = np.argwhere(bad)[0]
            p = self.premises[j]
            n_bad = int(bad[:, j].sum())
            raise PremiseOutOfBounds(
                f"{self.name}: premise {p.name!r} = {z[k, j]:.6g}{(' ' + p.unit) if p.unit else ''}"
                f" at sample {k} is outside its sector bounds [{p.zmin:.6g}, {p.zmax:.6g}] "
                f"({n_bad} of {len(z)} samples out); the TS model is exact only inside them",
                premise=p.name, index=int(k), value=float(z[k, j]), bounds=(p.zmin, p.zmax))

    def memberships(self, z, clip: bool = False) -> np.ndarray:
        """``h_i(z)`` for z of shape (p,) or (N, p); checks the bounds unless ``clip``."""
        z = np.asarray(z, dtype=float)
        if clip:
            z = np.clip(z, self.zmin, self.zmax)
        else:
            self.check_bounds(z)
        return memberships(z, self.zmin, self.zmax)

    def blend(self, h):
        """Blended matrices ``A_h = sum h_i A_i``, ``B_h`` for h of shape (2^p,) or (N, 2^p)."""
        return np.tensordot(h, self.A, axes=1), np.tensordot(h, self.B, axes=1)

    def rhs(self, x, u, *args, clip: bool = False):
        """TS right-hand side ``sum_i h_i(z) (A_i x + B_i u)`` along samples (N, n), (N, m)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        u = np.asarray(u, dtype=float).reshape(len(x), -1)
        z = self.premise_fn(x, u, *args)
        h = self.memberships(z, clip=clip)
        Ax = np.einsum("ikl,nl->nik", self.A, x)
        Bu = np.einsum("ikl,nl->nik", self.B, u)
        return np.einsum("ni,nik->nk", h, Ax + Bu)

    def exactness(self, x, u, f_nonlinear, *args) -> dict:
        """Compare the TS and nonlinear right-hand sides along a trajectory.

        ``f_nonlinear(x, u, *args)`` -> (N, n). Returns the maximum relative difference
        ``max_k |f_TS - f_NL|_inf / max(|f_NL|_inf, tiny)`` over samples, the maximum
        absolute difference per state, and the convex-sum residual ``max |sum h - 1|``.
        Raises :class:`PremiseOutOfBounds` if the trajectory leaves the sector.
        """
        x = np.atleast_2d(np.asarray(x, dtype=float))
        u = np.asarray(u, dtype=float).reshape(len(x), -1)
        z = self.premise_fn(x, u, *args)
        h = self.memberships(z)
        f_ts = self.rhs(x, u, *args)
        f_nl = np.asarray(f_nonlinear(x, u, *args), dtype=float)
        scale = np.maximum(np.abs(f_nl).max(axis=0), 1e-300)  # per-state scale over the run
        rel = np.abs(f_ts - f_nl) / scale
        return {
            "max_rel_diff": float(rel.max()),
            "max_abs_diff": np.abs(f_ts - f_nl).max(axis=0),
            "convex_sum_residual": float(np.abs(h.sum(axis=1) - 1.0).max()),
            "min_membership": float(h.min()),
            "premise_min": z.min(axis=0),
            "premise_max": z.max(axis=0),
        }


# ---- Jacobian TS model (Ichalal, Arioui, Mammar, MED 2011, eqs. (12)-(18), (34)) ----------
# The differential mean value theorem writes ``f(x) - f(xhat) = J(xi) (x - xhat)``; with entry
# bounds ``a_kl <= J_kl <= b_kl`` (14) the Jacobian is a convex sum of ``2^k`` vertices (18).
# Vertex ``v`` has varying entry ``l`` at its upper bound iff bit ``l`` of ``v`` is set (entry 0
# = least significant): for the bicycle (``xi1 = J[3,1]``, ``xi2 = J[3,2]``) ``A1 = (lo, lo)``,
# ``A2 = (hi, lo)``, ``A3 = (lo, hi)``, ``A4 = (hi, hi)`` as printed in (34).


def numerical_jacobian(f: Callable, x, u, h: float = 1e-6) -> np.ndarray:
    """Central-difference Jacobian ``df/dx`` of ``f(x (N, n), u (N,...)) -> (N, n)``.

    Returns (N, n, n). Step ``h`` is scaled by ``max(1, |x_j|)``. Used to check analytic
    Jacobians (Ichalal 2011 eq. (31)).
    """
    x = np.atleast_2d(np.asarray(x, dtype=float))
    if not np.all(np.isfinite(x)):
        raise ObserverArgumentError("numerical_jacobian: x contains non-finite values")
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
    vertices : (2^k, n, n) vertex matrices ``A_i`` (ordering: see the comment above).
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
            raise ObserverArgumentError(f"JacobianTS: A0 must be square, got shape "
                                        f"{self.A0.shape}")
        k = len(self.entries)
        if self.lo.shape != (k,) or self.hi.shape != (k,):
            raise ObserverArgumentError(f"JacobianTS: need {k} lower and upper bounds, got "
                                        f"{self.lo.shape} and {self.hi.shape}")
        if len(self.names) != k:
            raise ObserverArgumentError(f"JacobianTS: {len(self.names)} names for {k} varying "
                                        "entries")
        for l, ((r, c), a, b) in enumerate(zip(self.entries, self.lo, self.hi, strict=True)):
            if not (0 <= r < n and 0 <= c < n):
                raise ObserverArgumentError(f"JacobianTS: entry {l} = ({r}, {c}) outside a "
                                            f"{n}x{n} matrix")
            if not (np.isfinite(a) and np.isfinite(b) and b > a):
                raise ObserverArgumentError(f"JacobianTS: entry {self.names[l]!r} ({r}, {c}) "
                                            "needs finite bounds with upper > lower, got "
                                            f"[{a}, {b}]")
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

        Raises :class:`PremiseOutOfBounds` naming the entry and sample if a value leaves its
        bounds (the TS form is exact only inside them) unless ``clip``.
        """
        xi = self.values(J)
        if clip:
            xi = np.clip(xi, self.lo, self.hi)
        else:
            bad = (xi < self.lo) | (xi > self.hi)
            if bad.any():
                n_, l = np.argwhere(bad)[0]
                raise PremiseOutOfBounds(
                    f"JacobianTS: entry {self.names[l]!r} = {xi[n_, l]:.6g} at sample {n_} is "
                    f"outside [{self.lo[l]:.6g}, {self.hi[l]:.6g}]", premise=self.names[l],
                    index=int(n_), value=float(xi[n_, l]), bounds=(self.lo[l], self.hi[l]))
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
        raise ObserverArgumentError(f"jacobian_ts_from_samples: J must have shape (N, n, n), "
                                    f"got {J.shape}")
    if not np.all(np.isfinite(J)):
        k = int(np.argwhere(~np.isfinite(J))[0][0])
        raise ObserverArgumentError(f"jacobian_ts_from_samples: J is not finite at sample {k}")
    if margin < 0:
        raise ObserverArgumentError(f"jacobian_ts_from_samples: margin must be >= 0, got "
                                    f"{margin}")
    jmin, jmax = J.min(axis=0), J.max(axis=0)
    spread = jmax - jmin
    tol = rtol * max(1.0, float(np.abs(J).max()))
    entries = [tuple(int(i) for i in rc) for rc in np.argwhere(spread > tol)]
    A0 = J[0].copy()
    lo = [jmin[r, c] - margin * spread[r, c] for r, c in entries]
    hi = [jmax[r, c] + margin * spread[r, c] for r, c in entries]
    if names is not None and len(names) != len(entries):
        raise ObserverArgumentError(f"jacobian_ts_from_samples: {len(names)} names given for "
                                    f"{len(entries)} varying entries {entries}")
    names = list(names) if names is not None else [f"J[{r},{c}]" for r, c in entries]
    return JacobianTS(A0, entries, lo, hi, names)
