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
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product
from typing import Callable, Sequence

import numpy as np

from vehicle_observers.core.errors import PremiseOutOfBounds


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
