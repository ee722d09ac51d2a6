"""Ifqir 2017 (GTAA slides): the observer (11) AS PRINTED, i.e. with the slides' Theorem 2
gains ``L_i^j`` (:data:`.constants.L_printed`) on the printed switching law (22) (bands
0-6, 6-11, 11-16.6 m/s; the lower edge 0 replaced by 0.1 m/s because the model divides by
``v_x``), integrated by explicit Euler with as many substeps per sample as the printed
gains' diagonal shift ``epsilon`` of (20) needs (``h max|diag(A^- - L C)| <= 1``, e.g.
``epsilon = 4393 1/s`` at 1 kHz: 5 substeps).

* :func:`printed_design`: an :class:`~vehicle_observers.observers.interval.IntervalDesign`
  holding the printed gains (no LMI solved; its Metzler margins recomputed from the model);
* :func:`vertex_assignments`: the 24 ways of assigning the four printed gains of a mode to
  its four vertices, with the smallest off-diagonal entry of ``A^- - L C`` of each;
* :func:`a21_entry`: entry (2,1) of ``A^-`` (it does not depend on ``L``, ``C = [0 1]``);
* :func:`iss19_margins`: (19) with the printed ``P``, ``W = P L`` fixed, read as the
  standard ``phi (P + M)`` and literally as ``phi P + M``.

State ``x = [v_y (m/s), r (rad/s)]``.
"""

from __future__ import annotations

import itertools

import numpy as np
from vehicle_observers.models import uncertain_bicycle as ub
from vehicle_observers.observers import interval as iv

from vehicle_observers_papers.ifqir_2017 import constants as IF

#: switching law (22) as printed, first edge 0.1 m/s (the model divides by v_x) [m/s]
BANDS_PRINTED = ub.SpeedBands((0.1,) + tuple(IF.bands_printed[1:]))
#: identity assignment: printed gain j at model vertex j (see :func:`vertex_assignments`)
IDENTITY = (0, 1, 2, 3)


def printed_model(inv_vx_upper_first: bool = IF.inv_vx_upper_first,
                  veh: ub.UncertainBicycle | None = None) -> ub.SwitchedIntervalModel:
    """The switched interval model (5)-(7) on the printed bands :data:`BANDS_PRINTED`."""
    return ub.SwitchedIntervalModel(veh or IF.vehicle, BANDS_PRINTED, inv_vx_upper_first)


def printed_design(assignment=None, inv_vx_upper_first: bool = IF.inv_vx_upper_first,
                   veh: ub.UncertainBicycle | None = None) -> iv.IntervalDesign:
    """The printed observer: gains :data:`.constants.L_printed` (3, 4, 2) on
    :func:`printed_model`. ``assignment`` (3, 4) int: model vertex ``j`` of mode ``i`` gets
    printed gain ``assignment[i][j]`` (default: the identity in every mode). No LMI is
    solved (``solution=None``, ``gamma`` NaN); ``metzler_margins`` (3, 4) [1/s] are
    recomputed from ``A^- - L C``; ``epsilon_shift`` is the printed gains' own smallest
    (20) shift (max over modes) [1/s]."""
    m = printed_model(inv_vx_upper_first, veh)
    perm = np.array([IDENTITY] * 3 if assignment is None else assignment, dtype=int)
    L = np.stack([IF.L_printed[i, perm[i]] for i in range(3)])[..., None]   # (3, 4, 2, 1)
    Mm = m.A_lo - L @ m.C
    eps = float((-np.diagonal(Mm, axis1=2, axis2=3)).max())
    P = np.stack([IF.P_printed[i, perm[i]] for i in range(3)])
    return iv.IntervalDesign(model=m, L=L, P=P, gamma=float("nan"), eps_decay=IF.eps_decay,
                             epsilon_shift=eps, phi=np.zeros((3, 4)), solution=None,
                             metzler_margins=iv.metzler_margins(m, L), solve_time=0.0)


def vertex_assignments(model: ub.SwitchedIntervalModel | None = None) -> list[dict]:
    """All 24 assignments of the four printed gains of each mode to its four vertices.
    One row per (mode, permutation): ``mode`` (1-based), ``perm`` (printed gain index at
    model vertices 1..4, 1-based), ``min_offdiag`` [1/s] the smallest off-diagonal entry of
    ``A_i^{j-} - L C`` over the vertices (>= 0: Metzler, Theorem 1 holds), ``metzler``."""
    m = model or printed_model()
    rows = []
    for i in range(m.n_modes):
        for p in itertools.permutations(range(4)):
            M = m.A_lo[i] - IF.L_printed[i, list(p)][..., None] @ m.C
            off = float(min(M[:, 0, 1].min(), M[:, 1, 0].min()))
            rows.append({"mode": i + 1, "perm": tuple(k + 1 for k in p), "min_offdiag": off,
                         "metzler": off >= 0})
    return rows


def a21_entry(veh: ub.UncertainBicycle, v_max: float) -> float:
    """Entry (2,1) of ``A^-`` at speed ``v_max`` [1/s]: ``min_box (c_r l_r - c_f l_f) /
    (I_z v_x)`` at the corner ``(c_r^-, c_f^+)``. ``A - L C`` has the same entry for every
    ``L`` (``C = [0 1]`` only changes column 2), so it is a property of the model and of the
    top band edge, not of a gain."""
    box = veh.xi_box
    return float((box[0, 0] * veh.l_r - box[1, 1] * veh.l_f) / (veh.I_z * v_max))


def iss19_margins(model: ub.SwitchedIntervalModel | None = None, eps_decay: float = IF.eps_decay,
                  accel_max: float = IF.accel_max, literal: bool = False) -> np.ndarray:
    """Largest margin ``t`` (K,) of (18)-(19) with the printed ``P_i^j`` (each mode rescaled to
    ``min diag P = 1``) and ``W = P L_printed`` fixed, over ``M_i`` (symmetric) and
    ``gamma_i >= 0``: ``P_i^k + M_i >= t I`` and the (19) block ``<= -t I``, where the sum of
    (19) is ``sum_k phi_k (P_k + M)`` (standard form, ``literal=False``) or
    ``sum_k phi_k P_k + M`` (the slides' typography read literally). ``t > 0``: feasible;
    ``t < 0``: infeasible by ``|t|``. The solver's ``M`` is re-checked by eigenvalues
    (``numpy.linalg.eigvalsh``), and the returned margin is the certified one."""
    import cvxpy as cp

    m = model or printed_model()
    phi = m.membership_rate_bounds(accel_max)
    C, I2 = m.C, np.eye(2)
    out = np.empty(m.n_modes)
    for i in range(m.n_modes):
        s = 1.0 / IF.P_printed[i].min()
        P = [np.diag(IF.P_printed[i, j] * s) for j in range(4)]
        W = [P[j] @ IF.L_printed[i, j][:, None] for j in range(4)]
        M, g, t = cp.Variable((2, 2), symmetric=True), cp.Variable(4, nonneg=True), cp.Variable()

        def blocks(Mv, gv):
            out_ = []
            for j in range(4):
                Ap = m.A_hi[i, j]
                S = Ap.T @ P[j] + P[j] @ Ap - C.T @ W[j].T - W[j] @ C + eps_decay * P[j]
                if literal:
                    S = S + sum(phi[i, k] * P[k] for k in range(4)) + Mv
                else:
                    S = S + sum(phi[i, k] * (P[k] + Mv) for k in range(4))
                out_.append(cp.bmat([[S, P[j]], [P[j], -gv[j] * I2]]) if isinstance(Mv, cp.Expression)
                            else np.block([[S, P[j]], [P[j], -gv[j] * I2]]))
            return out_

        cons = [P[k] + M >> t * I2 for k in range(4)]
        cons += [(b + b.T) / 2 << -t * np.eye(4) for b in blocks(M, g)]
        cons += [t <= 1.0, g <= 1e6]
        cp.Problem(cp.Maximize(t), cons).solve(solver=cp.CLARABEL)
        Mv, gv = np.asarray(M.value), np.asarray(g.value)
        Mv = (Mv + Mv.T) / 2
        cert = min([np.linalg.eigvalsh(P[k] + Mv).min() for k in range(4)]
                   + [-np.linalg.eigvalsh((b + b.T) / 2).max() for b in blocks(Mv, gv)])
        out[i] = cert
    return out


def run_lpv(des: iv.IntervalDesign, log, seed: int = 0, box0=None, corr_time: float = 2.0):
    """The observer ``des`` on the LPV truth (3)-(4) of the emulated ``log``, integrated at the
    step the gains need: the log's steering and speed are held over ``k =``
    :func:`~vehicle_observers.observers.interval.euler_substeps` sub-samples of ``dt / k``
    (5 for the printed ``epsilon = 4393 1/s`` at 1 kHz), the truth is simulated by Euler at
    ``dt / k`` and the observer runs one Euler step per sub-sample on the yaw rate of that
    sub-sample (so the discrete positivity ``I + h (A^- - L C) >= 0`` holds and the gyro is
    not held between steps). The speed is clipped into ``des``'s bands (the printed bands end
    at 16.6 m/s; the truth is driven by the same clipped speed, so it stays the theorem's
    model). Seeded stiffness inside the box, correlation time ``corr_time`` [s]. Returns
    ``t``, ``dt`` (the fine step) [s], ``k``, ``vx``, ``delta``, ``xi``, ``X`` (N k, 2), ``res``."""
    e = np.asarray(des.model.bands.edges, dtype=float)
    k = iv.euler_substeps(des, log.dt)
    dt = log.dt / k
    vx = np.repeat(np.clip(log.extra["vx_true_mps"], e[0], e[-1]), k)
    d = np.repeat(log.extra["delta_true_rad"], k)
    t = log.t[0] + dt * np.arange(len(vx))
    xi = ub.random_stiffness_trajectory(des.model.veh, len(t), dt, seed=seed, corr_time=corr_time)
    X = ub.simulate_lpv(des.model.veh, [0.0, 0.0], d, vx, xi, dt)
    lo, hi = box0 if box0 is not None else (np.array([-0.5, -0.1]), np.array([0.5, 0.1]))
    res = iv.run_interval_observer(des, dt, vx, d, d, X[:, 1], lo, hi, substeps=1, t=t)
    return {"t": t, "dt": dt, "k": k, "vx": vx, "delta": d, "xi": xi, "X": X, "res": res}
