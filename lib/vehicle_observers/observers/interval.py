"""Switched Takagi-Sugeno interval observer with uncertain cornering stiffness (Ifqir 2017).

Source: S. Ifqir, N. Ait-Oufroukh, D. Ichalal, S. Mammar, "Robust estimation of vehicle
lateral velocity and yaw rate using Switched T-S Fuzzy Interval Observer", GTAA 2017
(slides; equation numbers below are the slides').

Model
-----
The LPV bicycle (3)-(4) with the stiffness box of Assumption 3, its switched TS form (5)-(7)
and the element-wise bounds ``A^{j-}, A^{j+}, B^-, B^+`` are in
:mod:`vehicle_observers.models.uncertain_bicycle` (:class:`SwitchedIntervalModel`); state
``x = [v_y (m/s), r (rad/s)]``, input ``delta_f`` (rad), output ``y = C x = r``,
``C = [0, 1]``.

Interval observer (11), reconstructed
-------------------------------------
The slides print, with ``A0 = A(rho, xi_0)`` the nominal (box-centre) matrix::

    x+' = sum_j h_j [ (A^{j+} - L^j C) x+ + L^j y + B^+ u^+ + (A^{j+} - A^j_0)(|x+| - x+) ]
    x-' = sum_j h_j [ (A^{j+} - L^j C) x- + L^j y + B^- u^- - (A^{j+} - A^j_0)(|x-| + x-) ]

Because the box is symmetric about ``xi_0`` and ``A`` is affine in ``xi``,
``A^{j+} - A^j_0 = (A^{j+} - A^{j-})/2``, and with ``M^{j+-} = A^{j+-} - L^j C`` these
right-hand sides equal ``M^+ pos(x+) - M^- neg(x+)`` and ``M^- pos(x-) - M^+ neg(x-)``
(``pos = max(x, 0)``, ``neg = max(-x, 0)``): the element-wise tightest bounds of
``M x`` over the matrix box when ``M`` is Metzler. That is the form implemented here (a
unit test checks the identity). Two generalisations are ours and are written down:

- ``B^+ u^+`` is an upper bound of ``B u`` only if ``u >= 0``; the exact interval product
  ``max/min`` over the four corners ``{B^-, B^+} x {u^-, u^+}`` is used instead.
- A bounded yaw-rate noise ``|y_meas - r| <= v_bar`` enters as ``+- |L_h| v_bar``
  (``v_bar = 0`` gives the slides' observer).

Guarantee: if every ``A^{j-} - L^j C`` is Metzler, the errors ``x+ - x`` and ``x - x-``
obey positive systems (Lemma 1), so ``x- <= x <= x+`` for every stiffness trajectory in
the box. The observer is integrated by explicit Euler with ``substeps`` per sample; the
discrete-time guarantee then needs ``I + h (A^{j-} - L^j C) >= 0`` (``h`` = Euler step),
i.e. ``h max|diag| <= 1``, which :func:`run_interval_observer` enforces, and one step per
sample, because ``y_k = C x_k`` is only known at the samples (with substeps the held ``y``
lags the moving ``C x``). The design's ``epsilon <= 1/T_s`` in (20) gives both. The
guarantee is then exact (up to rounding) for the Euler-discretised LPV model sampled at
``T_s`` (:func:`~vehicle_observers.models.uncertain_bicycle.simulate_lpv`); for the
continuous-time model it holds up to the Euler
discretisation error (a test checks a 30 s RK4 truth).

LMI design, Theorem 2 (16)-(21)
-------------------------------
Diagonal ``P_i^j``, ``W_i^j`` (n x p), symmetric ``M_i``, minimise ``gamma``::

    (17) P_i^j > 0                      (here P_i^j >= p_min I, see below)
    (18) P_i^k + M_i > 0
    (19) [[Lambda_i^j + eps P_i^j + sum_k phi_i^k (P_i^k + M_i),  P_i^j],
          [P_i^j,                                              -gamma I]] < 0
    (20) P_i^j A_i^{j-} - W_i^j C + epsilon P_i^j >= 0   (element-wise)
    (21) Lambda_i^j = A^{j+T} P + P A^{j+} - C^T W^T - W C,     L_i^j = (P_i^j)^-1 W_i^j

Reconstruction notes. (i) (19)-(21) are homogeneous of degree one in ``(P, W, M, gamma)``,
so "min gamma" alone drives everything to zero; we normalise ``P_i^j >= p_min I`` (with
``p_min = 1``, ``V >= |e|^2`` and ``sqrt(gamma/eps)`` is the ISS gain of the width). The
slides' printed P (0.008...0.55) therefore differ by a scale; ``L`` is scale-free and is
the comparable quantity. (ii) In (20), ``epsilon`` only shifts the diagonal: the
off-diagonal part is the Metzler condition; the diagonal part bounds ``diag(A^- - L C)``
from below by ``-epsilon`` and thereby the gains (and the Euler step). (iii) ``phi_i^k``
bounds ``|dh_i^k/dt|`` (16); with ``|dv_x/dt| <= a_max`` we use (:func:`membership_rate_bounds`)
``phi = a_max (v_max/v_min + 1)/(v_max - v_min)``. (iv) (19) neglects the cross terms
``P^k L^j`` of the blended closed loop and the jumps of ``V`` at mode switches (no
dwell-time condition in the slides); :func:`dwell_time_bound` reports the average dwell
time ``ln(mu)/eps`` that would make the switched ISS argument rigorous, and
:func:`blended_iss_margin` checks the blended inequality a posteriori; the Metzler
guarantee does not depend on either. (v) One ``gamma_i`` per mode, minimising
``sum_i gamma_i`` (one shared gamma only optimises the worst mode). (vi) A strictness margin
``lmi_eps`` (1e-2) is imposed on (17)-(19); otherwise min gamma sits on the boundary and the
certified eigenvalue margins are ~1e-7.

The LMIs are posed and certified by the synthesis layer (:func:`theorem2_synthesis`, a call
of :class:`vehicle_observers.design.lyapunov.ParameterDependentSynthesis`: vertex-dependent
``P_i^j`` with the slack ``M_i`` and the rate bounds ``phi``, (19) on the ``A^+`` vertices,
(20) on the ``A^-`` vertices, ``sum_i gamma_i`` over the modes); the layer re-certifies every
LMI from the vertex matrices, ``phi``, ``P``, ``L`` and ``M``
(:attr:`IntervalDesign.data_certificate`).

Observer class: :class:`IntervalObserver` (the contract of
:mod:`vehicle_observers.core.protocol`: readable Euler step of :func:`implemented_rhs`,
compiled loop :func:`_interval_loop`). The check of the slides' printed solution, the
paper's experiments, metrics and figures are in :mod:`vehicle_observers_papers.ifqir_2017`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from numba import njit

from vehicle_observers.core.errors import CertificationError, ObserverArgumentError
from vehicle_observers.core.protocol import ObserverBase, Trajectory, check_sample_period
from vehicle_observers.design.lmi import Certificate, LMIDesign, LMISolution, bmat
from vehicle_observers.models.uncertain_bicycle import (
    N_STATE,
    Z_INV_VX,
    Z_VX,
    SwitchedIntervalModel,
    check_series,
)

#: the state ``[v_y, r]`` in drive-log schema names
STATE_NAMES = ("vy_mps", "yaw_rate_radps")
#: largest relative spread of the sample period the fixed-step observer accepts
DT_RTOL = 1e-3


# ------------------------------------------------------------------ Theorem 2 LMI ----------
@dataclass
class IntervalDesign:
    """A certified Theorem 2 design. L (K, 4, 2, 1), P (K, 4, 2) (diagonals)."""

    model: SwitchedIntervalModel
    L: np.ndarray
    P: np.ndarray
    gamma: float
    eps_decay: float
    epsilon_shift: float | None
    phi: np.ndarray
    solution: LMISolution | None
    metzler_margins: np.ndarray      # (K, 4) min off-diagonal of A^{j-} - L^j C
    solve_time: float
    gammas: np.ndarray | None = None   # (K,) per-mode gamma_i
    #: certificate rebuilt from the data by the LMI layer
    #: (:func:`vehicle_observers.design.certify.certify_parameter_dependent`)
    data_certificate: object = None

    @property
    def certificate(self) -> Certificate | None:
        """The LMI certificate of (17)-(20) (eigenvalues / entries of the numeric solution,
        independent of the solver), ``None`` for a design without a solution. The Metzler
        guarantee is re-checked separately (:attr:`metzler_margins`), and every LMI is
        rebuilt from the vertex data in :attr:`data_certificate`."""
        return self.solution.certificate if self.solution else None

    @property
    def lmi_margin(self) -> float:
        return self.solution.certificate.min_margin if self.solution else float("nan")

    @property
    def lmi_relative_margin(self) -> float:
        return self.solution.certificate.min_relative_margin if self.solution else float("nan")

    @property
    def min_metzler_margin(self) -> float:
        return float(self.metzler_margins.min())

    @property
    def iss_gain(self) -> float:
        """``sqrt(gamma / (eps p_min))``: bound of |e| per unit of |delta| (ultimate)."""
        pmin = float(self.P.min())
        return float(np.sqrt(self.gamma / (self.eps_decay * pmin)))

    def max_diag_rate(self) -> float:
        """``max |diag(A^{j-} - L^j C)|`` [1/s]: fixes the Euler step of the observer."""
        Mm = self.model.A_lo - self.L @ self.model.C
        return float(np.max(-np.diagonal(Mm, axis1=2, axis2=3)))


def _offdiag(X):
    n = X.shape[0]
    items = [X[a, b] for a in range(n) for b in range(n) if a != b]
    if isinstance(X, np.ndarray):
        return np.array(items, dtype=float).reshape(1, -1)
    import cvxpy as cp
    return cp.reshape(cp.hstack(items), (1, len(items)), order="C")


def metzler_margins(model: SwitchedIntervalModel, L: np.ndarray) -> np.ndarray:
    """Smallest off-diagonal entry of ``A_i^{j-} - L_i^j C`` for every mode/vertex, (K, 4)."""
    M = model.A_lo - np.asarray(L) @ model.C
    n = M.shape[-1]
    off = ~np.eye(n, dtype=bool)
    return M[..., off].min(axis=-1)


def certify_metzler(model: SwitchedIntervalModel, L: np.ndarray, name: str = "design"):
    """Raise :class:`CertificationError` naming the mode/vertex/entry if some
    ``A_i^{j-} - L_i^j C`` is not Metzler (the enclosure guarantee of Theorem 1)."""
    M = model.A_lo - np.asarray(L) @ model.C
    K, J, n, _ = M.shape
    for i in range(K):
        for j in range(J):
            for a in range(n):
                for b in range(n):
                    if a != b and not M[i, j, a, b] >= 0:
                        raise CertificationError(
                            f"{name}: A^- - L C is not Metzler in mode {i + 1}, vertex {j + 1}: "
                            f"entry ({a + 1},{b + 1}) = {M[i, j, a, b]:.4g} < 0",
                            lmi=f"Metzler[{i + 1},{j + 1}]", violation=-M[i, j, a, b])
    return metzler_margins(model, L)


def add_theorem2_iss(d: LMIDesign, model: SwitchedIntervalModel, phi: np.ndarray,
                      eps_decay: float, p_min: float, per_mode_gamma: bool = True):
    """Add ``M_i``, ``gamma`` and the LMIs (17)-(19) of Theorem 2 to ``d``, whose variables
    (or fixed values) ``P{i}{j}`` (diagonal) and ``W{i}{j}`` must already exist. Returns
    the gamma-name function (mode index -> variable name)."""
    K, n, C = model.n_modes, N_STATE, model.C
    for i in range(K):
        d.symmetric(f"M{i}", n)
    gname = (lambda i: f"gamma{i}") if per_mode_gamma else (lambda i: "gamma")
    for g in dict.fromkeys(gname(i) for i in range(K)):
        d.scalar(g)
    I = np.eye(n)
    for i in range(K):
        for j in range(4):
            Ap = model.A_hi[i, j]
            d.positive(f"P[{i + 1},{j + 1}]>=pI", lambda V, i=i, j=j: V[f"P{i}{j}"] - p_min * I)
            d.positive(f"P[{i + 1},{j + 1}]+M[{i + 1}]>0",
                       lambda V, i=i, j=j: V[f"P{i}{j}"] + V[f"M{i}"])

            def iss(V, i=i, j=j, Ap=Ap):
                P, W = V[f"P{i}{j}"], V[f"W{i}{j}"]
                Lam = Ap.T @ P + P @ Ap - C.T @ W.T - W @ C
                S = Lam + eps_decay * P
                for k in range(4):
                    S = S + phi[i, k] * (V[f"P{i}{k}"] + V[f"M{i}"])
                return bmat([[S, P], [P, -V[gname(i)] * I]])

            d.negative(f"ISS[{i + 1},{j + 1}] (19)", iss)
    return gname


def theorem2_synthesis(model: SwitchedIntervalModel, phi: np.ndarray, eps_decay: float,
                       epsilon_shift: float | None, p_min: float, metzler_tol: float,
                       lmi_eps: float, per_mode_gamma: bool = True,
                       name: str = "Ifqir 2017 Theorem 2"):
    """Theorem 2 (17)-(21) as a call of the LMI layer
    (:class:`~vehicle_observers.design.lyapunov.ParameterDependentSynthesis`): one polytopic
    system per mode ``i`` with the upper-bound vertices ``A_i^{j+}``, ``E = I`` (the ``P_i^j``
    block of (19)) and the membership-rate bounds ``phi_i`` (K, 4); diagonal ``P_i^j``,
    ``W_i^j`` (the layer's ``K``), slack ``M_i`` ((18)), the vertex coupling of (19) (no cross
    terms, note (iv)), :class:`InputToState` ``(eps_decay, gamma_i)`` for (19) and the
    Metzler condition (20) with the diagonal shift ``epsilon`` on the lower-bound vertices
    ``A_i^{j-}`` (:class:`OnVertices`). Variable names ``P{i}{j}``, ``W{i}{j}``, ``M{i}``,
    ``gamma{i}`` (``gamma`` when shared)."""
    from vehicle_observers.design.constraints import InputToState, Metzler, OnVertices
    from vehicle_observers.design.lyapunov import ParameterDependentSynthesis
    from vehicle_observers.design.system import PolytopicSystem

    K, C, I = model.n_modes, model.C, np.eye(N_STATE)
    upper = [PolytopicSystem(model.A_hi[i], C, E=I, rate_bounds=phi[i],
                             name=f"{name} mode {i + 1} (A+)") for i in range(K)]
    lower = [PolytopicSystem(model.A_lo[i], C, rate_bounds=phi[i],
                             name=f"{name} mode {i + 1} (A-)") for i in range(K)]
    cons = [InputToState(alpha=eps_decay, c=None, label="ISS (19)"),
            OnVertices(Metzler(margin=0.0, diag_shift=epsilon_shift,
                               label="Metzler (20)"), lower)]

    def strict(V):
        # the solver keeps the off-diagonal of P A^- - W C >= metzler_tol, so its round-off
        # cannot fail the certificate's >= 0
        return [_offdiag(V[f"P{i}{j}"] @ model.A_lo[i, j] - V[f"W{i}{j}"] @ C) >= metzler_tol
                for i in range(K) for j in range(4)]

    return ParameterDependentSynthesis(
        upper, cons, P="diagonal", slack=True, coupling="vertex", P_lower=p_min, eps=lmi_eps,
        per_mode_c=per_mode_gamma, name=name, extra=strict,
        names={"P": "P{m}{k}", "K": "W{m}{k}", "M": "M{m}", "c": "gamma{m}"})


def design_theorem2(model: SwitchedIntervalModel, eps_decay: float = 1.0,
                    epsilon_shift: float | None = 1000.0, accel_max: float = 3.0,
                    phi: np.ndarray | None = None, p_min: float = 1.0,
                    metzler_tol: float = 1e-3, lmi_eps: float = 1e-2,
                    per_mode_gamma: bool = True, name: str = "Ifqir 2017 Theorem 2") \
        -> IntervalDesign:
    """Solve Theorem 2 (17)-(21) (min gamma) and certify it.

    Parameters
    ----------
    eps_decay : ``varepsilon`` of (19) [1/s] (ISS decay rate of ``V``).
    epsilon_shift : ``epsilon`` of (20) [1/s]; ``None`` imposes only the off-diagonal
        (Metzler) part. Bounds ``diag(A^- - L C) >= -epsilon``.
    accel_max : bound on ``|dv_x/dt|`` [m/s^2] giving ``phi`` (ignored if ``phi`` given).
    phi : (K, 4) membership-derivative bounds of (16).
    p_min : normalisation ``P >= p_min I`` (see module docstring, note (i)).
    metzler_tol : the solver must give off-diagonals of ``P A^- - W C`` >= this (the
        certificate then only needs >= 0).
    lmi_eps : strictness margin imposed on the solver for (17)-(19) (``LMIDesign.eps``);
        min gamma otherwise sits on the boundary and the certified margins are ~1e-7.
    per_mode_gamma : one ``gamma_i`` per mode and minimise ``sum_i gamma_i`` (reported
        ``gamma = max_i gamma_i``). With a single shared gamma only the worst mode is
        optimised and the others are left anywhere in the feasible set; for K = 1 both
        are the slides' problem.

    Returns a certified :class:`IntervalDesign`; raises :class:`InfeasibleDesign` /
    :class:`CertificationError` (naming the LMI) otherwise.
    """
    if not (np.ndim(eps_decay) == 0 and np.isfinite(eps_decay) and eps_decay > 0):
        raise ObserverArgumentError(f"design_theorem2: eps_decay (decay rate of (19)) must be "
                                    f"finite and > 0 [1/s], got {eps_decay!r}")
    if epsilon_shift is not None and not (np.isfinite(epsilon_shift) and epsilon_shift > 0):
        raise ObserverArgumentError(f"design_theorem2: epsilon_shift of (20) must be finite and "
                                    f"> 0 [1/s] (or None), got {epsilon_shift!r}")
    model.check_detectable()
    model.check_metzler_feasible()
    if epsilon_shift is not None:
        model.check_diagonal_shift(epsilon_shift)
    K = model.n_modes
    phi = model.membership_rate_bounds(accel_max) if phi is None else np.asarray(phi, float)
    if phi.shape != (K, 4) or np.any(phi < 0) or not np.all(np.isfinite(phi)):
        raise ObserverArgumentError(f"phi must be a finite nonnegative ({K}, 4) array, got shape "
                         f"{phi.shape}")

    t0 = time.perf_counter()
    syn = theorem2_synthesis(model, phi, eps_decay, epsilon_shift, p_min, metzler_tol, lmi_eps,
                             per_mode_gamma, name)
    res = syn.solve("c")
    dt = time.perf_counter() - t0
    sol = res.solution
    P = np.array([[np.diag(res.P[i][j]) for j in range(4)] for i in range(K)])
    L = np.array(res.L)
    mm = certify_metzler(model, L, name)
    gam = np.asarray(res.c, dtype=float)
    return IntervalDesign(model, L, P, float(gam.max()), eps_decay, epsilon_shift, phi,
                          sol, mm, dt, gam, res.certificate)


def blended_iss_margin(design: IntervalDesign, n: int = 2000, seed: int = 0) -> float:
    """Independent a-posteriori check of what (19) neglects: with the *blended* ``P(h) =
    sum h_k P^k`` and ``A(h) - L(h) C`` (``L(h) = sum h_j L^j``, the observer's actual gain),
    the largest eigenvalue of ``[[A_cl^T P + P A_cl + eps P + sum_k phi_k (P^k + M), P],
    [P, -gamma_i I]]`` over the vertices and ``n`` random weights per mode (Dirichlet,
    seeded). Negative means the ISS inequality (15) holds at those frozen ``h``; the cross
    terms ``P^k L^j`` (k != j) are included here."""
    m = design.model
    rng = np.random.default_rng(seed)
    gam = design.gammas if design.gammas is not None else np.full(m.n_modes, design.gamma)
    worst = -np.inf
    I = np.eye(N_STATE)
    for i in range(m.n_modes):
        Mi = design.solution[f"M{i}"]
        Pk = [np.diag(design.P[i, k]) for k in range(4)]
        phis = sum(design.phi[i, k] * (Pk[k] + Mi) for k in range(4))
        for h in np.vstack([np.eye(4), rng.dirichlet(np.full(4, 0.5), n)]):
            Ph = sum(h[k] * Pk[k] for k in range(4))
            Acl = np.tensordot(h, m.A_hi[i], axes=1) - np.tensordot(h, design.L[i], axes=1) @ m.C
            X = Acl.T @ Ph + Ph @ Acl + design.eps_decay * Ph + phis
            blk = np.block([[X, Ph], [Ph, -gam[i] * I]])
            worst = max(worst, float(np.linalg.eigvalsh((blk + blk.T) / 2).max()))
    return worst


def dwell_time_bound(design: IntervalDesign) -> dict:
    """Switching between adjacent bands: ``mu = max lambda_max(P_b P_a^-1)`` over the
    vertices of two adjacent modes and the average dwell time ``ln(mu)/eps`` above which the
    mode-dependent Lyapunov function (14) still decays across switches (Hespanha & Morse
    1999). Not part of the slides' Theorem 2; reported as a check."""
    P = design.P
    mu = 1.0
    for i in range(P.shape[0] - 1):
        for a, b in ((i, i + 1), (i + 1, i)):
            for j in range(4):
                for k in range(4):
                    mu = max(mu, float(np.max(P[b, k] / P[a, j])))
    return {"mu": mu, "dwell_time_s": math.log(mu) / design.eps_decay}


# ------------------------------------------------------------------ numba kernels ----------
@njit(cache=True)
def _mode_weights(v, edges, zmin, zmax, h):
    K = edges.shape[0] - 1
    i = 0
    while i < K - 1 and v > edges[i + 1]:
        i += 1
    s = 1.0 / v
    ws = (s - zmin[i, Z_INV_VX]) / (zmax[i, Z_INV_VX] - zmin[i, Z_INV_VX])   # 1/v_x upper bound
    wv = (v - zmin[i, Z_VX]) / (zmax[i, Z_VX] - zmin[i, Z_VX])
    h[0] = ws * wv
    h[1] = ws * (1.0 - wv)
    h[2] = (1.0 - ws) * wv
    h[3] = (1.0 - ws) * (1.0 - wv)
    return i


@njit(cache=True)
def _interval_loop(vx, u_lo, u_hi, y, y_noise, x0_lo, x0_hi, substeps, dt, edges, zmin, zmax,
                   Mp, Mm, Lg, B_lo, B_hi):
    N = vx.shape[0]
    n = x0_lo.shape[0]
    X_lo = np.empty((N, n))
    X_hi = np.empty((N, n))
    sig = np.empty(N, dtype=np.int64)
    xl = x0_lo.copy()
    xh = x0_hi.copy()
    h = np.empty(4)
    Mph = np.empty((n, n))
    Mmh = np.empty((n, n))
    Lh = np.empty(n)
    fl = np.empty(n)
    fh = np.empty(n)
    hs = dt / substeps
    for k in range(N):
        X_lo[k] = xl
        X_hi[k] = xh
        i = _mode_weights(vx[k], edges, zmin, zmax, h)
        sig[k] = i
        for a in range(n):
            Lh[a] = 0.0
            for b in range(n):
                Mph[a, b] = 0.0
                Mmh[a, b] = 0.0
        for j in range(4):
            for a in range(n):
                Lh[a] += h[j] * Lg[i, j, a]
                for b in range(n):
                    Mph[a, b] += h[j] * Mp[i, j, a, b]
                    Mmh[a, b] += h[j] * Mm[i, j, a, b]
        ul, uh = u_lo[k], u_hi[k]
        for _ in range(substeps):
            for a in range(n):
                # exact interval product of B [B_lo, B_hi] and u [ul, uh]
                p1 = B_lo[a] * ul
                p2 = B_lo[a] * uh
                p3 = B_hi[a] * ul
                p4 = B_hi[a] * uh
                bu_hi = max(max(p1, p2), max(p3, p4))
                bu_lo = min(min(p1, p2), min(p3, p4))
                ly = Lh[a] * y[k]
                ln = abs(Lh[a]) * y_noise
                sh = ly + ln + bu_hi
                sl = ly - ln + bu_lo
                for b in range(n):
                    if xh[b] >= 0.0:
                        sh += Mph[a, b] * xh[b]
                    else:
                        sh += Mmh[a, b] * xh[b]
                    if xl[b] >= 0.0:
                        sl += Mmh[a, b] * xl[b]
                    else:
                        sl += Mph[a, b] * xl[b]
                fh[a] = sh
                fl[a] = sl
            for a in range(n):
                xh[a] += hs * fh[a]
                xl[a] += hs * fl[a]
    return X_lo, X_hi, sig


def euler_substeps(design: IntervalDesign, dt: float) -> int:
    """Smallest Euler substep count with ``h max|diag(A^- - L C)| <= 1`` (the discrete-time
    positivity ``I + h M >= 0``). It is 1 when ``epsilon_shift <= 1/dt``, which is what the
    sampled guarantee needs: with one step per sample the output injection ``L y_k`` uses
    the measured ``y_k = C x_k`` exactly; with more substeps ``y`` is held between samples
    while ``C x`` moves, and the enclosure is then only approximate (O(h L |dr/dt|))."""
    _check_dt(dt, "euler_substeps")
    return max(1, int(math.ceil(dt * design.max_diag_rate() - 1e-9)))


def _check_dt(dt, who):
    if not (np.ndim(dt) == 0 and np.isfinite(dt) and dt > 0):
        raise ObserverArgumentError(f"{who}: dt (sample period) must be finite and > 0 s, got "
                                    f"{dt!r}")


def run_interval_observer(design: IntervalDesign, dt: float, vx, u_lo, u_hi, y, x0_lo, x0_hi,
                          y_noise: float = 0.0, substeps: int | None = None,
                          clip_speed: bool = False, t=None) -> IntervalRun:
    """Run the switched interval observer (11) over a log sampled every ``dt`` s.

    vx [m/s], u_lo / u_hi bounds of the road-wheel steering [rad], y measured yaw rate
    [rad/s], all (N,); x0_lo / x0_hi (2,) initial box of ``[v_y, r]``; ``y_noise`` bound on
    ``|y - r|`` [rad/s]. ``substeps=None`` picks :func:`euler_substeps`; a given value must
    satisfy ``h max|diag| <= 1`` (discrete positivity) or a ValueError says so.
    ``clip_speed=True`` saturates speeds outside the bands (the guarantee is void there;
    counted in ``n_clipped``) instead of raising. ``t`` (N,) [s]: the sample times of the
    result (default ``dt * arange(N)``). Returns an :class:`IntervalRun`. Bad arguments raise
    :class:`~vehicle_observers.core.errors.ObserverArgumentError` naming them.
    """
    _check_dt(dt, "run_interval_observer")
    vx = check_series("vx", vx)
    N = len(vx)
    u_lo, u_hi, y = (check_series(nm, a, N) for nm, a in (("u_lo", u_lo), ("u_hi", u_hi),
                                                          ("y", y)))
    if np.any(u_lo > u_hi):
        k = int(np.argmax(u_lo > u_hi))
        raise ObserverArgumentError(f"u_lo[{k}] = {u_lo[k]} > u_hi[{k}] = {u_hi[k]}")
    x0_lo = np.asarray(x0_lo, dtype=float).reshape(-1)
    x0_hi = np.asarray(x0_hi, dtype=float).reshape(-1)
    if x0_lo.shape != (2,) or x0_hi.shape != (2,) or np.any(x0_lo > x0_hi) \
            or not np.all(np.isfinite(x0_lo) & np.isfinite(x0_hi)):
        raise ObserverArgumentError(f"initial box must be two finite (2,) vectors with x0_lo "
                                    f"<= x0_hi, got {x0_lo}, {x0_hi}")
    if not (np.isfinite(y_noise) and y_noise >= 0):
        raise ObserverArgumentError(f"y_noise must be >= 0 rad/s, got {y_noise}")
    edges = np.asarray(design.model.bands.edges, dtype=float)
    n_clip = int(np.sum((vx < edges[0]) | (vx > edges[-1])))
    if clip_speed:
        vx = np.clip(vx, edges[0], edges[-1])
    else:
        design.model.bands.mode(vx)  # raises with the sample and value
    rate = design.max_diag_rate()
    if substeps is None:
        substeps = euler_substeps(design, dt)
    if int(substeps) != substeps or substeps < 1:
        raise ObserverArgumentError(f"substeps must be an integer >= 1, got {substeps!r}")
    if dt / substeps * rate > 1.0:
        raise ObserverArgumentError(f"Euler step {dt / substeps:.3g} s too long: h max|diag(A^- - LC)| = "
                         f"{dt / substeps * rate:.3g} > 1 breaks the discrete positivity; use "
                         f"substeps >= {math.ceil(dt * rate)}")
    m = design.model
    perm = m.vertex_perm                 # the kernel weights vertices in the standard order
    Mp = np.ascontiguousarray((m.A_hi - design.L @ m.C)[:, perm])
    Mm = np.ascontiguousarray((m.A_lo - design.L @ m.C)[:, perm])
    Lg = np.ascontiguousarray(design.L[..., 0][:, perm])
    t0 = time.perf_counter()
    xl, xh, sig = _interval_loop(vx, u_lo, u_hi, y, float(y_noise), x0_lo, x0_hi, int(substeps),
                                 float(dt), edges, m.zmin, m.zmax, Mp, Mm, Lg,
                                 np.ascontiguousarray(m.B_lo[:, 0]),
                                 np.ascontiguousarray(m.B_hi[:, 0]))
    sec = time.perf_counter() - t0
    t = dt * np.arange(N) if t is None else t
    return IntervalRun(t, 0.5 * (xl + xh), STATE_NAMES, xl, xh, sec, estimator="interval (11)",
                       sigma=sig, substeps=int(substeps), n_clipped=n_clip)


def implemented_rhs(design: IntervalDesign, i: int, h, x_hi, x_lo, y, u_lo, u_hi,
                    y_noise: float = 0.0):
    """The right-hand sides ``(f+, f-)`` of observer (11) that :func:`run_interval_observer`
    integrates (readable numpy; module docstring): in mode ``i`` with weights ``h`` (4,),
    ``f+ = M^+ pos(x+) - M^- neg(x+) + L_h y + |L_h| v_bar + max(B u)``,
    ``f- = M^- pos(x-) - M^+ neg(x-) + L_h y - |L_h| v_bar + min(B u)``, ``M^{+-} =
    sum_j h_j (A^{j+-} - L^j C)``, ``L_h = sum_j h_j L^j``, ``B u`` over the four corners of
    ``[B^-, B^+] x [u^-, u^+]``, ``v_bar = y_noise`` the gyro noise bound."""
    m = design.model
    pos = lambda x: np.maximum(x, 0.0)
    neg = lambda x: np.maximum(-x, 0.0)
    Mp = np.tensordot(h, m.A_hi[i] - design.L[i] @ m.C, axes=1)
    Mm = np.tensordot(h, m.A_lo[i] - design.L[i] @ m.C, axes=1)
    Lh = np.tensordot(h, design.L[i][..., 0], axes=1)
    prods = np.stack([m.B_lo[:, 0] * u_lo, m.B_lo[:, 0] * u_hi, m.B_hi[:, 0] * u_lo,
                      m.B_hi[:, 0] * u_hi])
    fh = Mp @ pos(x_hi) - Mm @ neg(x_hi) + Lh * y + np.abs(Lh) * y_noise + prods.max(axis=0)
    fl = Mm @ pos(x_lo) - Mp @ neg(x_lo) + Lh * y - np.abs(Lh) * y_noise + prods.min(axis=0)
    return fh, fl


@dataclass(frozen=True, eq=False)
class IntervalRun(Trajectory):
    """A run of the interval observer: the :class:`~vehicle_observers.core.protocol.Trajectory`
    with ``lo``/``hi`` (N, 2) the guaranteed bounds on ``[v_y, r]`` and ``x`` their midpoint,
    plus ``sigma`` (N,) the active mode (0-based), the Euler ``substeps`` per sample and
    ``n_clipped`` the number of speed samples clipped into the bands. ``x_lo``, ``x_hi`` and
    ``width`` are views of (or computed from) ``lo``/``hi``."""

    sigma: np.ndarray | None = None
    substeps: int = 1
    n_clipped: int = 0

    @property
    def x_lo(self) -> np.ndarray:
        return self.lo

    @property
    def x_hi(self) -> np.ndarray:
        return self.hi

    @property
    def width(self) -> np.ndarray:
        return self.hi - self.lo


class IntervalObserver(ObserverBase):
    """Ifqir 2017 switched interval observer (11) on the contract of
    :mod:`vehicle_observers.core.protocol`.

    ``design``: a certified :class:`IntervalDesign` (Theorem 2); ``dt`` [s] the fixed sample
    period (``run`` checks ``t`` against it, relative :data:`DT_RTOL`); ``box0 = (lo, hi)``
    (2,) each: the initial box is ``[x0 + lo, x0 + hi]`` around the initial estimate ``x0``
    (default ``[0, y_0]``: ``v_y = 0`` and the measured yaw rate); ``steer_noise`` [rad]:
    bound on the steering measurement error (``u^{+-} = delta +- steer_noise``);
    ``y_noise`` [rad/s]: bound on ``|y - r|``; ``substeps``: Euler steps per sample
    (``None``: :func:`euler_substeps`); ``clip_speed``: saturate speeds outside the bands
    (the guarantee is void there) instead of raising.

    Inputs ``u = [v_x, delta]`` (N, 2), output ``y = [r]`` (N, 1); internal state ``z =
    [x^-, x^+]`` (4,), estimate the midpoint, :meth:`bounds` the box. Sample ``k`` is
    ``substeps`` Euler steps of :func:`implemented_rhs` with the inputs of sample ``k - 1``.
    """

    state_names = STATE_NAMES
    input_names = ("vx_mps", "delta_roadwheel_rad")
    output_names = ("yaw_rate_radps",)

    def __init__(self, design: IntervalDesign, dt: float, box0, steer_noise: float = 0.0,
                 y_noise: float = 0.0, substeps: int | None = None, clip_speed: bool = False):
        who = type(self).__name__
        self.design = design
        if not isinstance(self._des, IntervalDesign):
            raise ObserverArgumentError(f"{who}: design must be an IntervalDesign, got "
                                        f"{type(self._des).__name__}")
        _check_dt(dt, who)
        lo, hi = (np.asarray(b, dtype=float).reshape(-1) for b in box0)
        if lo.shape != (2,) or hi.shape != (2,) or np.any(lo > hi) \
                or not np.all(np.isfinite(lo) & np.isfinite(hi)):
            raise ObserverArgumentError(f"{who}: box0 must be two finite (2,) offsets with lo <= "
                                        f"hi, got {lo}, {hi}")
        for name, v in (("steer_noise", steer_noise), ("y_noise", y_noise)):
            if not (np.isfinite(v) and v >= 0):
                raise ObserverArgumentError(f"{who}: {name} must be finite and >= 0, got {v!r}")
        self.dt = float(dt)
        self.box0 = (lo, hi)
        self.steer_noise, self.y_noise = float(steer_noise), float(y_noise)
        self.clip_speed = bool(clip_speed)
        self.substeps = euler_substeps(self._des, dt) if substeps is None else substeps
        if int(self.substeps) != self.substeps or self.substeps < 1:
            raise ObserverArgumentError(f"{who}: substeps must be an integer >= 1, got "
                                        f"{substeps!r}")
        self.substeps = int(self.substeps)

    @property
    def _des(self) -> IntervalDesign:
        """The design in the observer's own coordinates."""
        return self.design

    # ---- coordinates: identity here (see interval_coordinates) --------------------
    def _to_z(self, lo, hi):
        return lo, hi

    def _to_x(self, lo, hi):
        return lo, hi

    def check_data(self, t, u, y, x0=None):
        t, u, y, x0 = super().check_data(t, u, y, x0)
        check_sample_period(t, self.dt, type(self).__name__, DT_RTOL)
        return t, u, y, x0

    def _box(self, y, x0):
        x0 = np.array([0.0, y[0, 0]]) if x0 is None else np.asarray(x0, dtype=float)
        return x0 + self.box0[0], x0 + self.box0[1]

    def initial_state(self, t, u, y, x0=None):
        return np.concatenate(self._to_z(*self._box(y, x0)))

    def step(self, z, k, t, u, y):
        """Explicit Euler of (11) (:func:`implemented_rhs`) over ``[t_{k-1}, t_k]`` in
        ``substeps`` steps of ``dt / substeps``, with the mode, weights (7), steering bounds
        and gyro of sample ``k - 1`` held."""
        m = self._des.model
        e = m.bands.edges
        v = u[k - 1, 0]
        if self.clip_speed:
            v = min(max(v, e[0]), e[-1])
        sig, h = m.memberships(v)
        d = u[k - 1, 1]
        zl, zh = z[:N_STATE], z[N_STATE:]
        hs = self.dt / self.substeps
        for _ in range(self.substeps):
            fh, fl = implemented_rhs(self._des, int(sig[0]), h[0], zh, zl, y[k - 1, 0],
                                     d - self.steer_noise, d + self.steer_noise, self.y_noise)
            zl, zh = zl + hs * fl, zh + hs * fh
        return np.concatenate([zl, zh])

    def bounds(self, z):
        return self._to_x(z[:N_STATE], z[N_STATE:])

    def estimate(self, z):
        lo, hi = self.bounds(z)
        return 0.5 * (lo + hi)

    def run(self, t, u, y, x0=None) -> IntervalRun:
        """The compiled loop (:func:`run_interval_observer`) over the samples."""
        t, u, y, x0 = self.check_data(t, u, y, x0)
        d = u[:, 1]
        zl, zh = self._to_z(*self._box(y, x0))
        r = run_interval_observer(self._des, self.dt, u[:, 0], d - self.steer_noise,
                                  d + self.steer_noise, y[:, 0], zl, zh, self.y_noise,
                                  self.substeps, self.clip_speed, t=t)
        lo, hi = self._to_x(r.lo, r.hi)
        return IntervalRun(t, 0.5 * (lo + hi), STATE_NAMES, lo, hi, r.seconds,
                           estimator=type(self).__name__, sigma=r.sigma, substeps=r.substeps,
                           n_clipped=r.n_clipped)
