"""Unknown-input observers: the decoupling matrices and the LMIs (quadratic and slack-relaxed).

Unknown-input observer (Darouach, Zasadzinski & Xu, IEEE TAC 39(3), 1994; Chen & Patton,
*Robust Model-Based Fault Diagnosis*, 1999, Sec. 3.2) of ``x' = A x + B u + F d``,
``y = C x`` with ``d`` unknown::

    z' = N z + G u + L y,      xhat = z + H y

With ``T = I - H C`` the error ``e = x - xhat`` obeys ``e' = N e`` for every ``d`` iff

    T F = 0  (i.e. H C F = F),   N = T A - K C,   L = K + N H,   G = T B.

``H C F = F`` is solvable iff ``rank(C F) = rank(F)`` (:func:`decoupling` checks it and
takes the minimum-norm solution ``H = F (C F)^+``); ``N`` can then be made stable iff
``(C, T A)`` is detectable (equivalently, the invariant zeros of ``(A, F, C)`` are stable):
:func:`uio_system` returns the polytopic system ``(T A_i, C)`` on which any constraint of
:mod:`vehicle_observers.design.synthesis` designs ``K`` (``N_i = T A_i - K_i C``).

The slack-variable (Finsler / de Oliveira) form of the decay LMI, used by relaxed
(fuzzy-Lyapunov) UIO designs such as El Youssfi et al. (2020) Theorem 2, is
:func:`slack_decay_lmi`; the quadratic form is :func:`quadratic_decay_lmi`. Both are
backend-agnostic builders (cvxpy or numpy arrays).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.design.lmi import bmat
from vehicle_observers.design.system import PolytopicSystem


@dataclass(frozen=True)
class Decoupling:
    """``H`` (n, p), ``T = I - H C`` (n, n) with ``T F = 0``; ``residual = ||T F||``."""

    H: np.ndarray
    T: np.ndarray
    residual: float

    def gains(self, A, B, K, C):
        """``N = T A - K C``, ``L = K + N H``, ``G = T B`` of the observer for gain ``K``."""
        N = self.T @ A - K @ C
        return N, K + N @ self.H, self.T @ B


def decoupling(F, C, tol: float = 1e-9) -> Decoupling:
    """Decoupling matrices of an unknown-input observer (module docstring).

    ``F`` (n, nd) unknown-input matrix, ``C`` (p, n). Raises :class:`ObserverArgumentError`
    naming the rank condition when ``rank(C F) != rank(F)`` (no ``H`` with ``H C F = F``)."""
    F = np.atleast_2d(np.asarray(F, dtype=float))
    C = np.atleast_2d(np.asarray(C, dtype=float))
    if F.shape[0] != C.shape[1] or not (np.all(np.isfinite(F)) and np.all(np.isfinite(C))):
        raise ObserverArgumentError(f"decoupling: F must be finite with {C.shape[1]} rows (one "
                                    f"per state), got {F.shape}; C {C.shape}")
    rF = np.linalg.matrix_rank(F, tol=tol * max(1.0, np.abs(F).max()))
    CF = C @ F
    rCF = np.linalg.matrix_rank(CF, tol=tol * max(1.0, np.abs(CF).max()))
    if rCF != rF:
        raise ObserverArgumentError(f"decoupling: rank(C F) = {rCF} != rank(F) = {rF}: the "
                                    "unknown input cannot be decoupled (H C F = F has no "
                                    "solution; Darouach 1994 condition)")
    H = F @ np.linalg.pinv(CF)
    T = np.eye(F.shape[0]) - H @ C
    return Decoupling(H, T, float(np.abs(T @ F).max()) if F.size else 0.0)


def uio_system(system: PolytopicSystem, F) -> tuple[PolytopicSystem, Decoupling]:
    """``(system with A_i -> T A_i and E_i -> T E_i, decoupling)``: designing the observer gain
    ``K`` of this system with any constraint designs ``N_i = T A_i - K C`` of the UIO.
    Needs a common ``C``; raises :class:`ObserverArgumentError` when the decoupled pair
    ``(C, T A_i)`` is not detectable at some vertex."""
    if not system.common_C:
        raise ObserverArgumentError(f"uio_system: {system.name}: the UIO needs a common C")
    dec = decoupling(F, system.C[0])
    T = dec.T
    s = PolytopicSystem(T @ system.A, system.C, system.B, T @ system.E, system.D, system.H,
                        system.time, system.dt, system.rate_bounds,
                        f"{system.name} (unknown input decoupled)")
    s.check_detectable()
    return s, dec


def quadratic_decay_lmi(P, W, A, C, alpha: float):
    """``He(P A - W C) + 2 alpha P`` (must be < 0; ``K = P^-1 W``): quadratic Lyapunov
    function ``e^T P e`` decreasing at rate ``2 alpha``."""
    X = P @ A - W @ C
    return X + X.T + 2.0 * alpha * P


def slack_decay_lmi(P, G, W, A, C, alpha: float, mu: float):
    """Finsler / slack form of the decay LMI (must be < 0; gain ``K = G^-1 W``)::

        [[2 alpha P + He(G A - W C),   P - G + mu (G A - W C)^T],
         [*,                          -mu (G + G^T)              ]]

    Finsler's lemma with the multiplier ``-[G; mu G]`` on ``e' = (A - K C) e``: it implies
    ``He(P (A - K C)) + 2 alpha P < 0`` (congruence with ``[I, (A - K C)^T]``), and with
    ``G = P``, ``W = P K`` it holds for ``mu`` small enough whenever the quadratic LMI does
    (the Schur complement adds ``mu/2 (A - K C)^T P (A - K C)``). ``P`` may then depend on the
    premises (``P_i``) without a common ``G``-free product: the relaxation of El Youssfi et
    al. (2020) Theorem 2."""
    X = G @ A - W @ C
    return bmat([[2.0 * alpha * P + X + X.T, P - G + mu * X.T],
                 [P - G.T + mu * X, -mu * (G + G.T)]])
