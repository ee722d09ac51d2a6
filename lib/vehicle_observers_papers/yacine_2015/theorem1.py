"""Theorem 1 of Yacine 2015 checked on simulated data: the premise mismatch (30), the error
bound (34) and the differentiators' convergence time ``T`` it needs.

The library keeps the observer, its LMI design and certificate
(:mod:`vehicle_observers.observers.ts_premise`); this module holds what only the paper's
theory check uses (notebook 02, :func:`..premise_estimation.theory_check`).

Bound (34). The printed second branch of (34) is garbled ("sqrt(a2/a1)||e0|| + c/(a a1)
max||delta||^2 e^{aT} e^{-a t/2}" mixes a norm and a squared norm); it is reconstructed from
the proof, (40)-(45):
``||e(t)|| <= sqrt(a2/a1 ||e0||^2 e^{-a t} + c/(a a1) max_{[0,t]} ||delta||^2)`` (t <= T) and
``||e(t)|| <= sqrt(a2/a1 ||e0||^2 + c/(a a1) max_{[0,T]} ||delta||^2 e^{a T}) e^{-a t/2}``
(t >= T, where ``delta = 0``), ``a1, a2`` the extreme eigenvalues of ``P``. The first
(ISS) form holds for all t with the running max; :func:`bound_34` returns both.
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.models.ts import SectorTS, memberships
from vehicle_observers.observers.ts_premise import Theorem1Design


def premise_mismatch(ts: SectorTS, x_true, u, z_true, z_est):
    """``delta(t)`` of (30): ``sum_i (h_i(z) - h_i(z_e)) (A_i x + B_i u)`` -> (N, 4).

    Rows 1-2 vanish identically (they depend on ``v_x`` only, which both premise sets share);
    ``Gamma delta`` uses rows 3-4, returned as the (N, 2) second output.
    """
    h = memberships(np.clip(z_true, ts.zmin, ts.zmax), ts.zmin, ts.zmax)
    he = memberships(np.clip(z_est, ts.zmin, ts.zmax), ts.zmin, ts.zmax)
    x_true = np.atleast_2d(x_true)
    u = np.asarray(u, dtype=float).reshape(len(x_true), 1)
    f = np.einsum("ikl,nl->nik", ts.A, x_true) + np.einsum("ikl,nl->nik", ts.B, u)
    full = np.einsum("ni,nik->nk", h - he, f)
    return full, full[:, 2:]


def bound_34(t, e0_norm: float, delta_norm, T: float, design: Theorem1Design) -> dict:
    """Right-hand sides of (34) as reconstructed from (40)-(45) (module docstring).

    ``delta_norm`` (N,) = ``||delta(t_k)||``. Returns ``iss`` (all t, running max of delta),
    ``paper`` ((34): first branch on [0, T], (45) after T with max over [0, T]) (N,).
    """
    t = np.asarray(t, dtype=float) - float(np.asarray(t)[0])
    a, c, a1, a2 = design.alpha, design.c, design.alpha1, design.alpha2
    dn = np.asarray(delta_norm, dtype=float)
    run = np.maximum.accumulate(dn**2)
    iss = np.sqrt(a2 / a1 * e0_norm**2 * np.exp(-a * t) + c / (a * a1) * run)
    dT = float(run[np.searchsorted(t, T, side="right") - 1]) if T > 0 else 0.0
    after = np.sqrt(a2 / a1 * e0_norm**2 + c / (a * a1) * dT * np.exp(a * T)) * np.exp(
        -a * t / 2)
    paper = np.where(t <= T, iss, after)
    return {"iss": iss, "paper": paper, "delta_max_T": float(np.sqrt(dT))}


def convergence_time(t, err, band: float, mode: str = "last", hold: float = 1.0) -> float:
    """Differentiator convergence time ``T`` from an error signal (N,) [s from ``t[0]``].

    ``mode="last"``: the instant after the last sample with ``|err| > band`` (so
    ``|err| <= band`` on ``[T, end]``; this is the ``T`` of (34)). ``mode="first"``: the first
    instant after which ``|err| <= band`` holds for at least ``hold`` s (the initial
    transient only; later re-convergences, e.g. at clothoid junctions where ``psi_L^(4)`` is
    unbounded, are not counted). Returns ``nan`` if never converged.
    """
    t = np.asarray(t, dtype=float)
    t = t - t[0]
    bad = np.abs(np.asarray(err, dtype=float)) > band
    if mode == "last":
        idx = np.flatnonzero(bad)
        if len(idx) == 0:
            return 0.0
        return float(t[idx[-1] + 1]) if idx[-1] + 1 < len(t) else float("nan")
    if mode != "first":
        raise ValueError(f"mode must be 'last' or 'first', got {mode!r}")
    n_hold = max(1, int(round(hold / np.median(np.diff(t)))))
    good = ~bad
    run = 0
    for k in range(len(good)):
        run = run + 1 if good[k] else 0
        if run >= n_hold:
            return float(t[k - n_hold + 1])
    return float("nan")
