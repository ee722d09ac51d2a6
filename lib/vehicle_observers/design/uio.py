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

The UIO error system carries the measurement noise twice (through ``L_i y`` and directly
in the estimate ``z + H y``): :func:`uio_system` forms both, and :func:`augment_faults` adds
actuator / sensor faults as states with a bounded derivative (fault estimation). The L2 /
decay / pole-disk designs of that system, quadratic or slack-relaxed with a fuzzy Lyapunov
matrix, are :class:`vehicle_observers.design.slack.SlackSynthesis`.

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


def augment_faults(system: PolytopicSystem, Fa, Fs=None, fault_rate=None,
                   name: str | None = None) -> PolytopicSystem:
    """Fault-estimation augmentation: actuator faults ``f`` (nf,) entering the state through
    ``Fa`` and the outputs through ``Fs`` become states with an unknown bounded derivative
    (the PI / descriptor augmentation of fault-estimating observers, e.g. El Youssfi et al.
    2020 (14)-(15); Gao & Ding, Automatica 43(5), 2007 for the descriptor form).

    With ``X = [x; f]`` and the disturbance ``w_a = [f' / fault_rate; w]`` (the fault rate in
    units of its bound ``fault_rate`` (nf,), default 1, then the system's own ``w``)::

        X' = [[A_i, Fa_i], [0, 0]] X + [B_i; 0] u + [[0, E_i], [diag(fault_rate), 0]] w_a
        y  = [C_i, Fs] X + [0, D_i] w_a,        z = blockdiag(H, I_nf) e_X + [[0, Dz_i], [0, 0]] w_a

    so an observer of the augmented system estimates the faults with the state, and its L2
    gain bounds the error from the fault rate and ``w``. ``Fa`` (n, nf) or (q, n, nf),
    ``Fs`` (p, nf) (default 0: actuator faults only). Unknown inputs to decouple
    (:func:`uio_system`) get a zero row appended: ``F_a = [F; 0]``."""
    s = system
    who = f"augment_faults {s.name!r}"
    Fa = np.asarray(Fa, dtype=float)
    Fa = np.broadcast_to(Fa, (s.q, *Fa.shape)) if Fa.ndim == 2 else Fa
    if Fa.ndim != 3 or Fa.shape[:2] != (s.q, s.n) or not np.all(np.isfinite(Fa)):
        raise ObserverArgumentError(f"{who}: Fa must be finite with shape ({s.n}, nf) or "
                                    f"({s.q}, {s.n}, nf), got {np.shape(Fa)}")
    nf = Fa.shape[2]
    Fs = np.zeros((s.p, nf)) if Fs is None else np.atleast_2d(np.asarray(Fs, dtype=float))
    if Fs.shape != (s.p, nf) or not np.all(np.isfinite(Fs)):
        raise ObserverArgumentError(f"{who}: Fs must be finite with shape ({s.p}, {nf}), got "
                                    f"{Fs.shape}")
    rate = np.ones(nf) if fault_rate is None else np.asarray(fault_rate, dtype=float).ravel()
    if rate.shape != (nf,) or not np.all(np.isfinite(rate) & (rate > 0)):
        raise ObserverArgumentError(f"{who}: fault_rate must be {nf} finite values > 0, got "
                                    f"{fault_rate!r}")
    q, n, p, nw, nz = s.q, s.n, s.p, s.nw, s.H.shape[0]
    A = np.zeros((q, n + nf, n + nf))
    A[:, :n, :n], A[:, :n, n:] = s.A, Fa
    B = np.concatenate([s.B, np.zeros((q, nf, s.B.shape[2]))], axis=1)
    C = np.concatenate([s.C, np.broadcast_to(Fs, (q, p, nf))], axis=2)
    E = np.zeros((q, n + nf, nf + nw))
    E[:, :n, nf:], E[:, n:, :nf] = s.E, np.diag(rate)
    D = np.concatenate([np.zeros((q, p, nf)), s.D], axis=2)
    H = np.zeros((nz + nf, n + nf))
    H[:nz, :n], H[nz:, n:] = s.H, np.eye(nf)
    Dz = np.zeros((q, nz + nf, nf + nw))
    Dz[:, :nz, nf:] = s.Dz
    return PolytopicSystem(A, C, B, E, D, H, s.time, s.dt, s.rate_bounds,
                           name or f"{s.name} (faults augmented)", Dz)
