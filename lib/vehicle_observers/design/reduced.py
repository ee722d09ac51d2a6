"""Reduced-order (Luenberger) observer of a polytopic system: the measured block is taken
from the output, only the unmeasured block is estimated.

Luenberger (IEEE Trans. Mil. Electron. 8(2), 1964; IEEE TAC 11(2), 1966, Sec. IV). With a
common, full-row-rank output matrix ``C`` (p, n), the change of coordinates
``xbar = T x``, ``T = [C; N]`` (``N`` (n - p, n) an orthonormal basis of the orthogonal
complement of the rows of ``C``), gives ``C T^-1 = [I_p 0]``: ``xbar = (x1, x2)`` with
``x1 = y`` measured (p) and ``x2`` (n - p) unmeasured, and per vertex

    x1' = A11_i x1 + A12_i x2 + B1_i u + E1_i w,
    x2' = A21_i x1 + A22_i x2 + B2_i u + E2_i w.

The observer of ``z = x2 - L y`` (common gain ``L`` (n - p, p)),

    z' = sum_i h_i [(A22_i - L A12_i) z + ((A22_i - L A12_i) L + A21_i - L A11_i) y
                    + (B2_i - L B1_i) u],            x2hat = z + L y,

has the error ``e2 = x2 - x2hat`` with ``e2' = sum_i h_i [(A22_i - L A12_i) e2 +
(E2_i - L E1_i) w]`` (discrete time: ``x'`` read as ``x_{k+1}``, the same algebra). This is a
full-order error system with ``A -> A22_i``, ``C -> A12_i``, ``E -> E2_i``, ``D -> E1_i``:
:func:`reduced_system` returns it as a :class:`PolytopicSystem`, so every constraint of
:mod:`vehicle_observers.design.constraints` (decay, regions, H-infinity on ``H_r e2`` with
``H_r = H T^-1 [0; I]``, ...) applies to the unmeasured block unchanged, and the data
certificate rebuilds the LMIs from these arrays (computed from the plant's). The gain is
common: a scheduled ``L(h)`` would add ``-L(h)' y`` to ``z'``. The output must be exact
(``D = 0``): ``x1 = y`` is used as the state.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.design.system import PolytopicSystem


def measured_coordinates(C) -> np.ndarray:
    """``T = [C; N]`` (n, n) with ``C T^-1 = [I_p 0]`` (``N`` orthonormal, ``N C^T = 0``).

    ``C`` (p, n) of full row rank p < n."""
    C = np.atleast_2d(np.asarray(C, dtype=float))
    p, n = C.shape
    if not p < n:
        raise ObserverArgumentError(f"reduced-order observer: needs fewer outputs than states, "
                                    f"got C {p} x {n}")
    U, s, Vt = np.linalg.svd(C)
    if s[-1] <= 1e-10 * max(s[0], 1.0):
        raise ObserverArgumentError("reduced-order observer: C must have full row rank "
                                    f"(singular values {s})")
    return np.vstack([C, Vt[p:]])


@dataclass(frozen=True)
class ReducedCoordinates:
    """The plant in measured coordinates: ``T`` (n, n), ``p`` measured, the transformed
    system ``A~ = T A T^-1`` (q, n, n), ``B~ = T B``, ``E~ = T E``, ``H~ = H T^-1``."""

    T: np.ndarray
    p: int
    full: PolytopicSystem


def reduced_system(system: PolytopicSystem) -> tuple[PolytopicSystem, ReducedCoordinates]:
    """The error system of the unmeasured block (module docstring) and the coordinates.

    Returns ``(PolytopicSystem(A22_i, A12_i, E=E2_i, D=E1_i, H=H T^-1 [0; I]), coords)``;
    time, ``dt`` and rate bounds are the plant's."""
    who = f"reduced-order observer of {system.name!r}"
    if not system.common_C:
        raise ObserverArgumentError(f"{who}: needs one output matrix C common to all vertices")
    if np.any(system.D):
        raise ObserverArgumentError(f"{who}: needs an exact output (D = 0): the measured "
                                    "block is taken from y")
    T = measured_coordinates(system.C[0])
    tr = system.transformed(np.linalg.inv(T))
    p = system.p
    A, E = tr.A, tr.E
    red = PolytopicSystem(A[:, p:, p:], A[:, :p, p:], E=E[:, p:], D=E[:, :p],
                          H=tr.H[:, p:], time=system.time, dt=system.dt,
                          rate_bounds=system.rate_bounds, name=f"{system.name} (reduced order)")
    return red, ReducedCoordinates(T, p, tr)


def observer_matrices(coords: ReducedCoordinates, L) -> dict:
    """Matrices of the reduced-order observer ``z' = F_i z + G_i y + J_i u``,
    ``xhat = T^-1 [y; z + L y]``: ``F`` (q, n-p, n-p) ``= A22 - L A12``, ``G`` (q, n-p, p)
    ``= F L + A21 - L A11``, ``J`` (q, n-p, m) ``= B2 - L B1``, ``Xy`` (n, p) and ``Xz``
    (n, n-p) with ``xhat = Xy y + Xz z``."""
    tr, p = coords.full, coords.p
    L = np.asarray(L, dtype=float)
    A, B = tr.A, tr.B
    F = A[:, p:, p:] - L[None] @ A[:, :p, p:]
    G = F @ L[None] + A[:, p:, :p] - L[None] @ A[:, :p, :p]
    J = B[:, p:] - L[None] @ B[:, :p]
    Ti = np.linalg.inv(coords.T)
    n = coords.T.shape[0]
    Xy = Ti @ np.vstack([np.eye(p), L])
    Xz = Ti @ np.vstack([np.zeros((p, n - p)), np.eye(n - p)])
    return {"F": F, "G": G, "J": J, "Xy": Xy, "Xz": Xz}
