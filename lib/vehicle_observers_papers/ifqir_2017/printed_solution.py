"""Ifqir 2017: the slides' printed solution and printed observer form, checked against the
reconstruction of :mod:`vehicle_observers.observers.interval`.

* :func:`slides_rhs`: the right-hand sides of observer (11) exactly as printed (a test
  checks that the library's implemented form equals them for ``u >= 0``);
* :func:`certify_solution`: Theorem 2 checked for a given (the printed) ``P``, ``L``;
  :func:`min_epsilon_shift`: the smallest shift ``epsilon`` of (20) that gains satisfy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.design.lmi import LMIDesign, LMISolution
from vehicle_observers.models import uncertain_bicycle as ub
from vehicle_observers.observers import interval as iv


def min_epsilon_shift(model: ub.SwitchedIntervalModel, L) -> np.ndarray:
    """Smallest ``epsilon`` of (20) that gains ``L`` (K, 4, 2[, 1]) satisfy, per mode (K,)
    [1/s]: the diagonal part of (20) is ``P (A^- - L C)_aa + epsilon P_aa >= 0`` (``P``
    diagonal positive), i.e. ``epsilon >= max_{j,a} -(A_i^{j-} - L_i^j C)_aa``."""
    L = np.asarray(L, dtype=float)
    L = L[..., None] if L.ndim == 3 else L
    if L.shape != (model.n_modes, 4, ub.N_STATE, 1):
        raise ObserverArgumentError(f"L must be ({model.n_modes}, 4, 2) or (..., 1), got {L.shape}")
    D = np.diagonal(model.A_lo - L @ model.C, axis1=2, axis2=3)
    return (-D).max(axis=(1, 2))


@dataclass
class PrintedCertificate:
    """Theorem 2 checked for a given solution (``P`` diagonals (K, 4, 2), ``L`` (K, 4, 2))
    held fixed, each mode rescaled to ``min diag P_i^j = p_min`` (the LMIs are homogeneous).

    gammas (K,) : smallest ``gamma_i`` of (19) over ``M_i`` (certified, like any design);
    metzler_margins (K, 4) : smallest off-diagonal of ``A^- - L C`` (>= 0: Theorem 1 holds);
    min_epsilon (K,) [1/s] : smallest (20) shift the gains satisfy (:func:`min_epsilon_shift`);
    solution : the certified LMI solution (margins of (17)-(19)).
    """

    gammas: np.ndarray
    metzler_margins: np.ndarray
    min_epsilon: np.ndarray
    solution: LMISolution
    scale: np.ndarray

    @property
    def lmi_margin(self) -> float:
        return self.solution.certificate.min_margin


def certify_solution(model: ub.SwitchedIntervalModel, P_diag, L, eps_decay: float = 1.0,
                     accel_max: float = 3.0, p_min=1.0, lmi_eps: float = 1e-2,
                     name: str = "Theorem 2 with P, W = P L fixed") -> PrintedCertificate:
    """Certify a given (e.g. printed) Theorem 2 solution on ``model``: with ``P_i^j``
    (diagonals, (K, 4, 2)) and ``W_i^j = P_i^j L_i^j`` held fixed, solve (18)-(19) for
    ``M_i``, ``gamma_i`` (min sum gamma_i), certify (17)-(19) from the eigenvalues, and
    report the Metzler margins and the smallest ``epsilon`` of (20). Raises
    :class:`InfeasibleDesign` when (18)-(19) have no solution for these ``P``, ``L``.
    ``p_min`` (scalar or (K,)): the smallest diagonal of ``P_i^j`` after rescaling mode i."""
    P_diag = np.asarray(P_diag, dtype=float)
    L = np.asarray(L, dtype=float)
    K = model.n_modes
    if P_diag.shape != (K, 4, ub.N_STATE) or np.any(P_diag <= 0):
        raise ObserverArgumentError(f"P_diag must be positive ({K}, 4, 2), got shape {P_diag.shape}")
    if L.shape != (K, 4, ub.N_STATE):
        raise ObserverArgumentError(f"L must be ({K}, 4, 2), got shape {L.shape}")
    scale = np.asarray(p_min, dtype=float) / P_diag.min(axis=(1, 2))
    Ps = P_diag * scale[:, None, None]
    d = LMIDesign(name, eps=lmi_eps)
    for i in range(K):
        for j in range(4):
            d.fixed(f"P{i}{j}", np.diag(Ps[i, j]))
            d.fixed(f"W{i}{j}", (Ps[i, j] * L[i, j])[:, None])
    phi = model.membership_rate_bounds(accel_max)
    gname = iv.add_theorem2_iss(d, model, phi, eps_decay, 0.0)   # (17) as printed: P > 0
    sol = d.solve(objective=lambda V: sum(V[gname(i)] for i in range(K)))
    return PrintedCertificate(np.array([float(sol[gname(i)]) for i in range(K)]),
                              iv.metzler_margins(model, L[..., None]),
                              min_epsilon_shift(model, L), sol, scale)


def slides_rhs(design: iv.IntervalDesign, i: int, h, x_hi, x_lo, y, u_lo, u_hi):
    """Right-hand sides of (11) exactly as printed (with ``A0`` the box-centre matrix and
    ``B^+ u^+``, ``B^- u^-``), for one mode ``i`` and weights ``h`` (4,). Used by the tests to
    check that the implemented form (:func:`vehicle_observers.observers.interval.implemented_rhs`)
    equals the slides' for ``u >= 0``."""
    m = design.model
    fh = np.zeros(2)
    fl = np.zeros(2)
    for j in range(4):
        L = design.L[i, j]
        Ap, A0 = m.A_hi[i, j], m.A_nom[i, j]
        fh += h[j] * ((Ap - L @ m.C) @ x_hi + (L @ np.atleast_1d(y)).ravel()
                      + (Ap - A0) @ (np.abs(x_hi) - x_hi))
        fl += h[j] * ((Ap - L @ m.C) @ x_lo + (L @ np.atleast_1d(y)).ravel()
                      - (Ap - A0) @ (np.abs(x_lo) + x_lo))
    fh += m.B_hi[:, 0] * u_hi
    fl += m.B_lo[:, 0] * u_lo
    return fh, fl
