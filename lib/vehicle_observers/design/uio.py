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
        """``N = T A - K C``, ``L = K + N H``, ``G = T B`` of the observer for gain ``K``
        (Darouach et al. 1994 eqs. (7)-(9); El Youssfi et al. 2020 (23b)-(23c))."""
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


def uio_system(system: PolytopicSystem, F, dec: Decoupling | None = None,
               time_unit: float | None = None) -> tuple[PolytopicSystem, Decoupling]:
    """``(error system, decoupling)``: the system on which the UIO gains ``K_i`` are designed
    with any constraint of the layer (:mod:`~vehicle_observers.design.synthesis`,
    :mod:`~vehicle_observers.design.slack`).

    For ``x' = A_i x + B_i u + F d + E_i w``, ``y = C x + D_i w`` and the observer ``z' = N_i z
    + G_i u + L_i y``, ``xhat = z + H y`` with (module docstring) ``N_i = T A_i - K_i C``,
    ``L_i = K_i + N_i H``, ``G_i = T B_i``, ``eps = T x - z`` and ``e = x - xhat = eps - H D_i w``
    obey::

        eps' = (T A_i - K_i C) eps + (E~_i - K_i D~_i) w,   z_perf = H_p e = H_p eps + Dz~_i w

        E~_i = T E_i - T A_i H D_i,   D~_i = (I - C H) D_i,   Dz~_i = Dz_i - H_p H D_i

    (``H_p`` the performance output of ``system``). The returned system holds ``T A_i, C,
    T B_i, E~_i, D~_i, H_p, Dz~_i``; its observer gain is ``K_i``. Needs a common ``C``;
    ``dec``: a decoupling already computed (e.g. with another solution of ``H C F = F``),
    else :func:`decoupling` of ``F``. ``time_unit`` ``tau`` [s]: the error system in that time
    unit (``T A_i``, ``T B_i``, ``T E_i`` times ``tau`` before ``E~_i`` is formed, rate bounds
    times ``tau``; gains designed on it are ``K_i = K~_i / tau``; cf.
    :meth:`~vehicle_observers.design.system.PolytopicSystem.time_scaled`). Raises
    :class:`ObserverArgumentError` naming the rank condition when ``F`` cannot be decoupled,
    or the vertex and the mode when ``(C, T A_i)`` is not detectable."""
    if not system.common_C:
        raise ObserverArgumentError(f"uio_system: {system.name}: the UIO needs a common C")
    C = system.C[0]
    if dec is None:
        dec = decoupling(F, C)
    T, H = dec.T, dec.H
    TA, TB, TE, rb = T @ system.A, T @ system.B, T @ system.E, system.rate_bounds
    if time_unit is not None:
        tau = float(time_unit)
        if system.discrete or not (np.isfinite(tau) and tau > 0):
            raise ObserverArgumentError(f"uio_system: {system.name}: time_unit needs a "
                                        f"continuous-time system and a finite tau > 0 [s], got "
                                        f"{time_unit!r}")
        TA, TB, TE = TA * tau, TB * tau, TE * tau
        rb = None if rb is None else rb * tau
    D = system.D
    E = TE - TA @ H @ D if np.any(D) else TE
    Dt = (np.eye(C.shape[0]) - C @ H) @ D
    Dz = system.Dz - system.H @ H @ D
    s = PolytopicSystem(TA, system.C, TB, E, Dt, system.H, system.time, system.dt, rb,
                        f"{system.name} (unknown input decoupled)", Dz)
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
