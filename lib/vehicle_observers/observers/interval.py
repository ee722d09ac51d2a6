"""Switched Takagi-Sugeno interval observer with uncertain cornering stiffness (Ifqir 2017).

Source: S. Ifqir, N. Ait-Oufroukh, D. Ichalal, S. Mammar, "Robust estimation of vehicle
lateral velocity and yaw rate using Switched T-S Fuzzy Interval Observer", GTAA 2017
(slides; equation numbers below are the slides').

Model
-----
LPV bicycle (3)-(4), state ``x = [v_y (m/s), r (rad/s)]``, input ``u = delta_f`` (rad,
road-wheel), output ``y = C x = r`` (yaw-rate gyro), ``C = [0, 1]``::

    A(rho, xi) = [[-(c_f+c_r)/(m v_x),           (c_r l_r - c_f l_f)/(m v_x) - v_x],
                  [(c_r l_r - c_f l_f)/(I_z v_x), -(c_r l_r^2 + c_f l_f^2)/(I_z v_x)]]
    B(xi)      = [c_f/m, c_f l_f/I_z]^T

with the measured scheduling vector ``rho = [1/v_x, v_x]`` and the unmeasured stiffness
``xi = [c_r, c_f]`` (N/rad) in a known box ``Xi`` (Assumption 3; +-10 % in the slides).

Switched TS form (5)-(7): the speed axis is cut into bands (switching law (22); the
slides use (0, 6], (6, 11], (11, 16.6] m/s). In band ``i`` the premises ``1/v_x`` and
``v_x`` are bounded by the band edges, and since ``A`` is affine in each premise, the
sector-nonlinearity TS form with 4 vertices ``A_i^j(xi) = A(rho_i^j, xi)`` is exact
(:mod:`vehicle_observers.models.ts` convention: premise order ``(1/v_x, v_x)``, bit 0 = upper
bound, so vertex ``j = 0..3`` is ``(1/v_min, v_max), (1/v_min, v_min), (1/v_max, v_max),
(1/v_max, v_min)``; the printed gains' pattern (``L^1, L^3`` more negative than ``L^2,
L^4`` in every mode) is consistent with ``v_x`` being the fast index). The polarity of
``1/v_x`` is not printed: ``SwitchedIntervalModel(..., inv_vx_upper_first=False)`` swaps it
(vertices 1-2 at ``1/v_max``); :mod:`vehicle_observers_papers.ifqir_2017.constants` uses that one (closer
to the printed gains). Vertex order only relabels the LMI unknowns; the observer kernel
always receives its arrays in the standard order (``vertex_perm``).

Element-wise bounds (Assumption 3): every entry of ``A(rho, xi)`` and ``B(xi)`` is affine
in ``xi`` for fixed ``rho``, so its exact range over the box is reached at a corner and is
computed from the signs of the coefficients (:func:`elementwise_bounds`), not by sampling.

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
``T_s`` (:func:`simulate_lpv`); for the continuous-time model it holds up to the Euler
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
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from vehicle_observers.core.errors import CertificationError, InfeasibleDesign
from vehicle_observers.design.lmi import LMIDesign, LMISolution, bmat
from vehicle_observers.models.ts import memberships, vertex_bits

N_STATE = 2
C_OUT = np.array([[0.0, 1.0]])


# ------------------------------------------------------------------ vehicle / LPV model ----
@dataclass(frozen=True)
class UncertainBicycle:
    """Linear bicycle (3) with a box of cornering stiffness (Assumption 3).

    m [kg], I_z [kg m^2], l_f / l_r [m] CG to front / rear axle, c_f0 / c_r0 nominal axle
    cornering stiffness [N/rad], ``rel_unc`` the relative half-width of the box
    (``c in [(1 - rel_unc) c_0, (1 + rel_unc) c_0]``; 0.10 in the slides).
    """

    m: float
    I_z: float
    l_f: float
    l_r: float
    c_f0: float
    c_r0: float
    rel_unc: float = 0.10
    name: str = field(default="vehicle", compare=False)

    def __post_init__(self):
        for k in ("m", "I_z", "l_f", "l_r", "c_f0", "c_r0"):
            v = getattr(self, k)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"UncertainBicycle.{k} must be finite and > 0, got {v}")
        if not (0.0 <= self.rel_unc < 1.0):
            raise ValueError(f"rel_unc must be in [0, 1), got {self.rel_unc}")

    @property
    def xi0(self) -> np.ndarray:
        """Nominal ``xi_0 = [c_r0, c_f0]`` (N/rad), the slides' ordering of (4)."""
        return np.array([self.c_r0, self.c_f0])

    @property
    def xi_box(self) -> np.ndarray:
        """(2, 2) array ``[[c_r^-, c_r^+], [c_f^-, c_f^+]]`` [N/rad]."""
        x0 = self.xi0
        return np.column_stack([x0 * (1 - self.rel_unc), x0 * (1 + self.rel_unc)])

    def max_metzler_uncertainty(self) -> float:
        """Largest ``rel_unc`` for which ``c_r l_r - c_f l_f > 0`` on the whole box.

        Entry (2, 1) of ``A - L C`` does not depend on ``L`` (``C = [0, 1]``); it is
        ``(c_r l_r - c_f l_f)/(I_z v_x)``, so the Metzler property needs an understeering
        vehicle on the whole box: ``(1-a) c_r0 l_r > (1+a) c_f0 l_f``.
        """
        a, b = self.c_r0 * self.l_r, self.c_f0 * self.l_f
        return max((a - b) / (a + b), 0.0)


def lpv_A(inv_vx, vx, xi, veh: UncertainBicycle) -> np.ndarray:
    """``A(rho, xi)`` of (3)-(4) with the two premises ``1/v_x`` [s/m] and ``v_x`` [m/s]
    treated independently (as in the TS form), ``xi = (c_r, c_f)``. Returns (2, 2)."""
    cr, cf = xi
    m, Iz, lf, lr = veh.m, veh.I_z, veh.l_f, veh.l_r
    return np.array([
        [-(cf + cr) / m * inv_vx, (cr * lr - cf * lf) / m * inv_vx - vx],
        [(cr * lr - cf * lf) / Iz * inv_vx, -(cr * lr**2 + cf * lf**2) / Iz * inv_vx],
    ])


def lpv_B(xi, veh: UncertainBicycle) -> np.ndarray:
    """``B(xi) = [c_f/m, c_f l_f/I_z]^T`` of (3), shape (2, 1)."""
    cf = xi[1]
    return np.array([[cf / veh.m], [cf * veh.l_f / veh.I_z]])


def elementwise_bounds(fn, box) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact element-wise ``(lower, nominal, upper)`` of ``fn(xi)`` over the box.

    ``fn`` must be affine in ``xi`` (checked at the box centre to 1e-9 relative); ``box``
    (p, 2) rows ``[lo, hi]``. Each entry ``a_0 + sum_p d_p xi_p`` ranges over
    ``a_0 + sum_p [min, max](d_p lo_p, d_p hi_p)``: attained at a corner (Assumption 3).
    """
    box = np.asarray(box, dtype=float)
    mid = box.mean(axis=1)
    half = (box[:, 1] - box[:, 0]) / 2
    f0 = np.asarray(fn(mid), dtype=float)
    lo = f0.copy()
    hi = f0.copy()
    for p in range(len(mid)):
        e = mid.copy()
        e[p] = mid[p] + half[p]
        d = np.asarray(fn(e), dtype=float) - f0       # = coefficient * half-width
        lo -= np.abs(d)
        hi += np.abs(d)
    # affinity check: value at a random-free corner must equal the linear prediction
    corner = box[:, 1]
    pred = f0.copy()
    for p in range(len(mid)):
        e = mid.copy()
        e[p] = box[p, 1]
        pred += np.asarray(fn(e), dtype=float) - f0
    scale = max(float(np.abs(f0).max()), 1e-300)
    if np.abs(np.asarray(fn(corner), dtype=float) - pred).max() > 1e-9 * scale:
        raise ValueError("elementwise_bounds: fn is not affine in xi; corner bounds not exact")
    return lo, f0, hi


# ------------------------------------------------------------------ switching / TS ---------
@dataclass(frozen=True)
class SpeedBands:
    """Switching law (22): mode ``i`` (0-based) is active when ``edges[i] < v_x <= edges[i+1]``
    (the first band also includes its lower edge). ``edges`` [m/s], strictly increasing,
    ``edges[0] > 0`` (the model divides by ``v_x``)."""

    edges: tuple

    def __post_init__(self):
        e = np.asarray(self.edges, dtype=float)
        if e.ndim != 1 or len(e) < 2:
            raise ValueError(f"SpeedBands: need at least two edges, got {self.edges}")
        if not np.all(np.isfinite(e)) or e[0] <= 0 or np.any(np.diff(e) <= 0):
            raise ValueError(f"SpeedBands: edges must be finite, > 0 and strictly increasing "
                             f"(m/s), got {self.edges}")

    @property
    def n_modes(self) -> int:
        return len(self.edges) - 1

    def mode(self, vx) -> np.ndarray:
        """sigma(t) (0-based) for speeds ``vx`` (any shape); raises outside the bands."""
        vx = np.asarray(vx, dtype=float)
        e = np.asarray(self.edges)
        bad = ~np.isfinite(vx) | (vx < e[0]) | (vx > e[-1])
        if bad.any():
            k = int(np.flatnonzero(bad.ravel())[0])
            raise ValueError(f"v_x = {vx.ravel()[k]:.6g} m/s at sample {k} is outside the speed "
                             f"bands [{e[0]:g}, {e[-1]:g}] m/s ({int(bad.sum())} samples); "
                             "widen SpeedBands or pass clip_speed=True")
        return np.clip(np.searchsorted(e, vx, side="left") - 1, 0, self.n_modes - 1)


class SwitchedIntervalModel:
    """Switched TS model (6) with the element-wise bounds of Assumption 3.

    Attributes (K modes, 4 vertices, n = 2)
    ---------------------------------------
    zmin, zmax : (K, 2) premise bounds of ``(1/v_x, v_x)`` per band
    A_lo, A_nom, A_hi : (K, 4, 2, 2) ``A_i^{j-}``, ``A_i^j(xi_0)``, ``A_i^{j+}``
    B_lo, B_nom, B_hi : (2, 1)
    """

    def __init__(self, veh: UncertainBicycle, bands: SpeedBands, inv_vx_upper_first: bool = True):
        self.veh = veh
        self.bands = bands
        self.inv_vx_upper_first = bool(inv_vx_upper_first)
        e = np.asarray(bands.edges, dtype=float)
        K = bands.n_modes
        self.zmin = np.column_stack([1.0 / e[1:], e[:-1]])
        self.zmax = np.column_stack([1.0 / e[:-1], e[1:]])
        bits = vertex_bits(2)
        if not self.inv_vx_upper_first:
            bits = bits ^ np.array([1, 0])         # 1/v_x lower bound at vertices 1-2
        #: model vertex j is vertex ``vertex_perm[j]`` of the standard order (bit 0 = upper)
        self.vertex_perm = np.array([0, 1, 2, 3]) if self.inv_vx_upper_first \
            else np.array([2, 3, 0, 1])
        self.z_vertices = np.where(bits[None, :, :] == 0, self.zmax[:, None, :],
                                   self.zmin[:, None, :])          # (K, 4, 2)
        box = veh.xi_box
        shape = (K, 4, N_STATE, N_STATE)
        self.A_lo, self.A_nom, self.A_hi = (np.empty(shape) for _ in range(3))
        for i in range(K):
            for j in range(4):
                s, v = self.z_vertices[i, j]
                lo, nom, hi = elementwise_bounds(lambda xi, s=s, v=v: lpv_A(s, v, xi, veh), box)
                self.A_lo[i, j], self.A_nom[i, j], self.A_hi[i, j] = lo, nom, hi
        self.B_lo, self.B_nom, self.B_hi = elementwise_bounds(lambda xi: lpv_B(xi, veh), box)
        self.C = C_OUT.copy()

    @property
    def n_modes(self) -> int:
        return self.bands.n_modes

    def memberships(self, vx):
        """``(sigma, h)``: active mode (N,) and its 4 weights (N, 4) (7) at speeds ``vx``."""
        vx = np.atleast_1d(np.asarray(vx, dtype=float))
        sig = self.bands.mode(vx)
        z = np.column_stack([1.0 / vx, vx])
        h = memberships(z, self.zmin[sig], self.zmax[sig])
        return sig, h[:, self.vertex_perm]

    def membership_rate_bounds(self, accel_max: float) -> np.ndarray:
        """``phi_i^k`` of (16) from ``|dv_x/dt| <= accel_max`` [m/s^2]; shape (K, 4).

        ``h^k = w_s w_v`` with ``w_s`` affine in ``1/v_x`` and ``w_v`` in ``v_x``, so
        ``|dh/dt| <= |dw_s/dt| + |dw_v/dt| <= a (v_max / v_min + 1) / (v_max - v_min)``.
        """
        if not (np.isfinite(accel_max) and accel_max >= 0):
            raise ValueError(f"accel_max must be finite and >= 0 m/s^2, got {accel_max}")
        vmin, vmax = self.zmin[:, 1], self.zmax[:, 1]
        phi = accel_max * (vmax / vmin + 1.0) / (vmax - vmin)
        return np.repeat(phi[:, None], 4, axis=1)

    def check_metzler_feasible(self):
        """Raise :class:`InfeasibleDesign` if an L-independent off-diagonal of ``A^{j-}`` is
        negative (with ``C = [0, 1]`` column 1 of ``A - L C`` cannot be changed by ``L``)."""
        for i in range(self.n_modes):
            for j in range(4):
                a21 = self.A_lo[i, j, 1, 0]
                if a21 < 0:
                    raise InfeasibleDesign(
                        f"Metzler condition (20) impossible in mode {i + 1}, vertex {j + 1}: "
                        f"entry (2,1) of A^- = {a21:.4g} < 0 and C = [0 1] leaves column 1 "
                        f"unchanged (needs c_r l_r > c_f l_f on the whole stiffness box; "
                        f"rel_unc = {self.veh.rel_unc:g} > "
                        f"{self.veh.max_metzler_uncertainty():.4g} allowed)",
                        lmi=f"Metzler[{i + 1},{j + 1}]", violation=-a21)

    def check_diagonal_shift(self, epsilon: float):
        """Raise :class:`InfeasibleDesign` if (20)'s diagonal part cannot hold: entry (1,1)
        of ``A^- - L C`` is ``A^-_11 = -(c_f+c_r)^+/(m v_x)`` whatever ``L`` (``C = [0 1]``)."""
        for i in range(self.n_modes):
            for j in range(4):
                a11 = self.A_lo[i, j, 0, 0]
                if a11 < -epsilon:
                    raise InfeasibleDesign(
                        f"(20) diagonal impossible in mode {i + 1}, vertex {j + 1}: entry (1,1) "
                        f"of A^- = {a11:.4g} < -epsilon = {-epsilon:g} and L cannot change it "
                        f"(C = [0 1]); raise epsilon above {-a11:.4g} 1/s or the lowest speed "
                        f"band edge ({self.bands.edges[0]:g} m/s)",
                        lmi=f"diag[{i + 1},{j + 1}] (20)", violation=-epsilon - a11)

    def check_detectable(self):
        """Assumption 1: (A^{j+}, C) observable for every mode/vertex (entry (2,1) != 0)."""
        for i in range(self.n_modes):
            for j in range(4):
                O = np.vstack([self.C, self.C @ self.A_hi[i, j]])
                if np.linalg.matrix_rank(O) < N_STATE:
                    raise InfeasibleDesign(f"Assumption 1 fails: (A^+, C) not observable in "
                                           f"mode {i + 1}, vertex {j + 1}")


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


def _diag_entries(X):
    n = X.shape[0]
    items = [X[a, a] for a in range(n)]
    if isinstance(X, np.ndarray):
        return np.array(items, dtype=float).reshape(1, -1)
    import cvxpy as cp
    return cp.reshape(cp.hstack(items), (1, n), order="C")


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


def _add_theorem2_iss(d: LMIDesign, model: SwitchedIntervalModel, phi: np.ndarray,
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


def min_epsilon_shift(model: SwitchedIntervalModel, L) -> np.ndarray:
    """Smallest ``epsilon`` of (20) that gains ``L`` (K, 4, 2[, 1]) satisfy, per mode (K,)
    [1/s]: the diagonal part of (20) is ``P (A^- - L C)_aa + epsilon P_aa >= 0`` (``P``
    diagonal positive), i.e. ``epsilon >= max_{j,a} -(A_i^{j-} - L_i^j C)_aa``."""
    L = np.asarray(L, dtype=float)
    L = L[..., None] if L.ndim == 3 else L
    if L.shape != (model.n_modes, 4, N_STATE, 1):
        raise ValueError(f"L must be ({model.n_modes}, 4, 2) or (..., 1), got {L.shape}")
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


def certify_solution(model: SwitchedIntervalModel, P_diag, L, eps_decay: float = 1.0,
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
    if P_diag.shape != (K, 4, N_STATE) or np.any(P_diag <= 0):
        raise ValueError(f"P_diag must be positive ({K}, 4, 2), got shape {P_diag.shape}")
    if L.shape != (K, 4, N_STATE):
        raise ValueError(f"L must be ({K}, 4, 2), got shape {L.shape}")
    scale = np.asarray(p_min, dtype=float) / P_diag.min(axis=(1, 2))
    Ps = P_diag * scale[:, None, None]
    d = LMIDesign(name, eps=lmi_eps)
    for i in range(K):
        for j in range(4):
            d.fixed(f"P{i}{j}", np.diag(Ps[i, j]))
            d.fixed(f"W{i}{j}", (Ps[i, j] * L[i, j])[:, None])
    phi = model.membership_rate_bounds(accel_max)
    gname = _add_theorem2_iss(d, model, phi, eps_decay, 0.0)   # (17) as printed: P > 0
    sol = d.solve(objective=lambda V: sum(V[gname(i)] for i in range(K)))
    return PrintedCertificate(np.array([float(sol[gname(i)]) for i in range(K)]),
                              metzler_margins(model, L[..., None]),
                              min_epsilon_shift(model, L), sol, scale)


def settling_time(t, w, w_ref, frac: float = 0.02) -> float:
    """Convergence time of an interval width from its initial box: the first time [s]
    (from ``t[0]``) after which ``|w - w_ref| <= frac * |w[0] - w_ref[0]|`` at every later
    sample, ``w_ref`` being the width of the same observer started from a point box (same
    inputs), so only the effect of the initial box is measured. ``inf`` if it never
    settles within the record. ``t``, ``w``, ``w_ref`` (N,)."""
    t, w, w_ref = (np.asarray(a, dtype=float) for a in (t, w, w_ref))
    if not (t.shape == w.shape == w_ref.shape) or t.ndim != 1 or len(t) < 2:
        raise ValueError(f"settling_time: t, w, w_ref must be 1-D of equal length, got "
                         f"{t.shape}, {w.shape}, {w_ref.shape}")
    if not 0 < frac < 1:
        raise ValueError(f"settling_time: frac must be in (0, 1), got {frac}")
    dev = np.abs(w - w_ref)
    out = dev > frac * dev[0]
    if not out.any():
        return 0.0
    k = int(np.flatnonzero(out)[-1])
    return float("inf") if k == len(t) - 1 else float(t[k + 1] - t[0])


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
    model.check_detectable()
    model.check_metzler_feasible()
    if epsilon_shift is not None:
        model.check_diagonal_shift(epsilon_shift)
    K, n = model.n_modes, N_STATE
    phi = model.membership_rate_bounds(accel_max) if phi is None else np.asarray(phi, float)
    if phi.shape != (K, 4) or np.any(phi < 0) or not np.all(np.isfinite(phi)):
        raise ValueError(f"phi must be a finite nonnegative ({K}, 4) array, got shape "
                         f"{phi.shape}")
    if eps_decay <= 0 or (epsilon_shift is not None and epsilon_shift <= 0):
        raise ValueError(f"need eps_decay > 0 and epsilon_shift > 0 (or None), got "
                         f"{eps_decay}, {epsilon_shift}")
    C = model.C
    d = LMIDesign(name, eps=lmi_eps)
    for i in range(K):
        for j in range(4):
            d.diagonal(f"P{i}{j}", n)
            d.matrix(f"W{i}{j}", (n, C.shape[0]))
    gname = _add_theorem2_iss(d, model, phi, eps_decay, p_min, per_mode_gamma)
    for i in range(K):
        for j in range(4):
            Am = model.A_lo[i, j]
            d.nonnegative(f"Metzler[{i + 1},{j + 1}] (20)",
                          lambda V, i=i, j=j, Am=Am: _offdiag(V[f"P{i}{j}"] @ Am
                                                              - V[f"W{i}{j}"] @ C))
            if epsilon_shift is not None:
                d.nonnegative(f"diag[{i + 1},{j + 1}] (20)",
                              lambda V, i=i, j=j, Am=Am: _diag_entries(
                                  V[f"P{i}{j}"] @ Am - V[f"W{i}{j}"] @ C
                                  + epsilon_shift * V[f"P{i}{j}"]))

    def strict(V):
        out = []
        for i in range(K):
            for j in range(4):
                X = V[f"P{i}{j}"] @ model.A_lo[i, j] - V[f"W{i}{j}"] @ C
                out.append(_offdiag(X) >= metzler_tol)
        return out

    d.extra(strict)
    t0 = time.perf_counter()
    sol = d.solve(objective=lambda V: sum(V[gname(i)] for i in range(K)))
    dt = time.perf_counter() - t0
    P = np.array([[np.diag(sol[f"P{i}{j}"]) for j in range(4)] for i in range(K)])
    L = np.array([[np.linalg.solve(sol[f"P{i}{j}"], sol[f"W{i}{j}"]) for j in range(4)]
                  for i in range(K)])
    mm = certify_metzler(model, L, name)
    gam = np.array([float(sol[gname(i)]) for i in range(K)])
    return IntervalDesign(model, L, P, float(gam.max()), eps_decay, epsilon_shift, phi,
                          sol, mm, dt, gam)


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
    ws = (s - zmin[i, 0]) / (zmax[i, 0] - zmin[i, 0])    # weight of the 1/v_x upper bound
    wv = (v - zmin[i, 1]) / (zmax[i, 1] - zmin[i, 1])
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


@njit(cache=True)
def _lpv_loop(x0, vx, u, xi, substeps, dt, m, Iz, lf, lr, rk4):
    N = vx.shape[0]
    X = np.empty((N, 2))
    x = x0.copy()
    hs = dt / substeps
    k1 = np.empty(2)
    k2 = np.empty(2)
    k3 = np.empty(2)
    k4 = np.empty(2)
    tmp = np.empty(2)
    for k in range(N):
        X[k] = x
        cr, cf, v = xi[k, 0], xi[k, 1], vx[k]
        a11 = -(cf + cr) / (m * v)
        a12 = (cr * lr - cf * lf) / (m * v) - v
        a21 = (cr * lr - cf * lf) / (Iz * v)
        a22 = -(cr * lr * lr + cf * lf * lf) / (Iz * v)
        b1 = cf / m * u[k]
        b2 = cf * lf / Iz * u[k]
        for _ in range(substeps):
            if not rk4:
                d0 = a11 * x[0] + a12 * x[1] + b1
                d1 = a21 * x[0] + a22 * x[1] + b2
                x[0] += hs * d0
                x[1] += hs * d1
            else:
                k1[0] = a11 * x[0] + a12 * x[1] + b1
                k1[1] = a21 * x[0] + a22 * x[1] + b2
                for q in range(2):
                    tmp[q] = x[q] + 0.5 * hs * k1[q]
                k2[0] = a11 * tmp[0] + a12 * tmp[1] + b1
                k2[1] = a21 * tmp[0] + a22 * tmp[1] + b2
                for q in range(2):
                    tmp[q] = x[q] + 0.5 * hs * k2[q]
                k3[0] = a11 * tmp[0] + a12 * tmp[1] + b1
                k3[1] = a21 * tmp[0] + a22 * tmp[1] + b2
                for q in range(2):
                    tmp[q] = x[q] + hs * k3[q]
                k4[0] = a11 * tmp[0] + a12 * tmp[1] + b1
                k4[1] = a21 * tmp[0] + a22 * tmp[1] + b2
                for q in range(2):
                    x[q] += hs / 6.0 * (k1[q] + 2 * k2[q] + 2 * k3[q] + k4[q])
    return X


# ------------------------------------------------------------------ Python front ends ------
def _vec(name, a, N=None):
    a = np.ascontiguousarray(a, dtype=float)
    if a.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array (N,), got shape {a.shape}")
    if N is not None and len(a) != N:
        raise ValueError(f"{name} has {len(a)} samples, expected {N} (same as vx)")
    if not np.all(np.isfinite(a)):
        k = int(np.argmax(~np.isfinite(a)))
        raise ValueError(f"{name}[{k}] = {a[k]} is not finite")
    return a


def simulate_lpv(veh: UncertainBicycle, x0, delta, vx, xi, dt: float, substeps: int = 1,
                 method: str = "euler") -> np.ndarray:
    """Simulate the LPV bicycle (3)-(4) with a stiffness trajectory ``xi`` (N, 2) = (c_r, c_f)
    [N/rad] (or (2,) constant), steering ``delta`` and speed ``vx`` (N,) held over each
    sample of ``dt`` s. ``method``: ``"euler"`` (same scheme as the observer: the enclosure
    guarantee is exact for it) or ``"rk4"``. Returns X (N, 2) = [v_y, r] at the samples."""
    vx = _vec("vx", vx)
    N = len(vx)
    delta = _vec("delta", delta, N)
    if np.any(vx <= 0):
        k = int(np.argmax(vx <= 0))
        raise ValueError(f"vx must be > 0 m/s (the model divides by it): vx[{k}] = {vx[k]}")
    xi = np.asarray(xi, dtype=float)
    xi = np.ascontiguousarray(np.broadcast_to(xi, (N, 2)) if xi.shape == (2,) else xi)
    if xi.shape != (N, 2):
        raise ValueError(f"xi must be (2,) or ({N}, 2) = (c_r, c_f), got {xi.shape}")
    if method not in ("euler", "rk4"):
        raise ValueError(f"method must be 'euler' or 'rk4', got {method!r}")
    if dt <= 0 or int(substeps) < 1:
        raise ValueError(f"need dt > 0 and substeps >= 1, got {dt}, {substeps}")
    return _lpv_loop(np.asarray(x0, dtype=float).copy(), vx, delta, xi, int(substeps),
                     float(dt), veh.m, veh.I_z, veh.l_f, veh.l_r, method == "rk4")


@dataclass
class IntervalResult:
    """Bounds (N, 2) on ``[v_y, r]`` at the samples, active mode (N,) (0-based), Euler
    substeps used and the number of speed samples clipped into the bands."""

    x_lo: np.ndarray
    x_hi: np.ndarray
    sigma: np.ndarray
    substeps: int
    n_clipped: int

    @property
    def width(self) -> np.ndarray:
        return self.x_hi - self.x_lo


def euler_substeps(design: IntervalDesign, dt: float) -> int:
    """Smallest Euler substep count with ``h max|diag(A^- - L C)| <= 1`` (the discrete-time
    positivity ``I + h M >= 0``). It is 1 when ``epsilon_shift <= 1/dt``, which is what the
    sampled guarantee needs: with one step per sample the output injection ``L y_k`` uses
    the measured ``y_k = C x_k`` exactly; with more substeps ``y`` is held between samples
    while ``C x`` moves, and the enclosure is then only approximate (O(h L |dr/dt|))."""
    return max(1, int(math.ceil(dt * design.max_diag_rate() - 1e-9)))


def run_interval_observer(design: IntervalDesign, dt: float, vx, u_lo, u_hi, y, x0_lo, x0_hi,
                          y_noise: float = 0.0, substeps: int | None = None,
                          clip_speed: bool = False) -> IntervalResult:
    """Run the switched interval observer (11) over a log sampled every ``dt`` s.

    vx [m/s], u_lo / u_hi bounds of the road-wheel steering [rad], y measured yaw rate
    [rad/s], all (N,); x0_lo / x0_hi (2,) initial box of ``[v_y, r]``; ``y_noise`` bound on
    ``|y - r|`` [rad/s]. ``substeps=None`` picks :func:`euler_substeps`; a given value must
    satisfy ``h max|diag| <= 1`` (discrete positivity) or a ValueError says so.
    ``clip_speed=True`` saturates speeds outside the bands (the guarantee is void there;
    counted in ``n_clipped``) instead of raising.
    """
    vx = _vec("vx", vx)
    N = len(vx)
    u_lo, u_hi, y = (_vec(nm, a, N) for nm, a in (("u_lo", u_lo), ("u_hi", u_hi), ("y", y)))
    if np.any(u_lo > u_hi):
        k = int(np.argmax(u_lo > u_hi))
        raise ValueError(f"u_lo[{k}] = {u_lo[k]} > u_hi[{k}] = {u_hi[k]}")
    x0_lo = np.asarray(x0_lo, dtype=float).reshape(-1)
    x0_hi = np.asarray(x0_hi, dtype=float).reshape(-1)
    if x0_lo.shape != (2,) or x0_hi.shape != (2,) or np.any(x0_lo > x0_hi):
        raise ValueError(f"initial box must be two (2,) vectors with x0_lo <= x0_hi, got "
                         f"{x0_lo}, {x0_hi}")
    if not (np.isfinite(y_noise) and y_noise >= 0):
        raise ValueError(f"y_noise must be >= 0 rad/s, got {y_noise}")
    edges = np.asarray(design.model.bands.edges, dtype=float)
    n_clip = int(np.sum((vx < edges[0]) | (vx > edges[-1])))
    if clip_speed:
        vx = np.clip(vx, edges[0], edges[-1])
    else:
        design.model.bands.mode(vx)  # raises with the sample and value
    rate = design.max_diag_rate()
    if substeps is None:
        substeps = euler_substeps(design, dt)
    if dt / substeps * rate > 1.0:
        raise ValueError(f"Euler step {dt / substeps:.3g} s too long: h max|diag(A^- - LC)| = "
                         f"{dt / substeps * rate:.3g} > 1 breaks the discrete positivity; use "
                         f"substeps >= {math.ceil(dt * rate)}")
    m = design.model
    perm = m.vertex_perm                 # the kernel weights vertices in the standard order
    Mp = np.ascontiguousarray((m.A_hi - design.L @ m.C)[:, perm])
    Mm = np.ascontiguousarray((m.A_lo - design.L @ m.C)[:, perm])
    Lg = np.ascontiguousarray(design.L[..., 0][:, perm])
    xl, xh, sig = _interval_loop(vx, u_lo, u_hi, y, float(y_noise), x0_lo, x0_hi, int(substeps),
                                 float(dt), edges, m.zmin, m.zmax, Mp, Mm, Lg,
                                 np.ascontiguousarray(m.B_lo[:, 0]),
                                 np.ascontiguousarray(m.B_hi[:, 0]))
    return IntervalResult(xl, xh, sig, int(substeps), n_clip)


def slides_rhs(design: IntervalDesign, i: int, h, x_hi, x_lo, y, u_lo, u_hi):
    """Right-hand sides of (11) exactly as printed (with ``A0`` the box-centre matrix and
    ``B^+ u^+``, ``B^- u^-``), for one mode ``i`` and weights ``h`` (4,). Used by the tests to
    check that the implemented form equals the slides' for ``u >= 0``."""
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


def implemented_rhs(design: IntervalDesign, i: int, h, x_hi, x_lo, y, u_lo, u_hi):
    """The right-hand sides that :func:`run_interval_observer` integrates (numpy version)."""
    m = design.model
    pos = lambda x: np.maximum(x, 0.0)
    neg = lambda x: np.maximum(-x, 0.0)
    Mp = np.tensordot(h, m.A_hi[i] - design.L[i] @ m.C, axes=1)
    Mm = np.tensordot(h, m.A_lo[i] - design.L[i] @ m.C, axes=1)
    Lh = np.tensordot(h, design.L[i][..., 0], axes=1)
    prods = np.stack([m.B_lo[:, 0] * u_lo, m.B_lo[:, 0] * u_hi, m.B_hi[:, 0] * u_lo,
                      m.B_hi[:, 0] * u_hi])
    fh = Mp @ pos(x_hi) - Mm @ neg(x_hi) + Lh * y + prods.max(axis=0)
    fl = Mm @ pos(x_lo) - Mp @ neg(x_lo) + Lh * y + prods.min(axis=0)
    return fh, fl


# ------------------------------------------------------------------ helpers ----------------
def random_stiffness_trajectory(veh: UncertainBicycle, n: int, dt: float, seed: int = 0,
                                corr_time: float = 1.0, corners: bool = False) -> np.ndarray:
    """A seeded stiffness trajectory (n, 2) = (c_r, c_f) inside the box: a band-limited
    random signal squashed by ``tanh`` (``corners=True``: a random corner held for a random
    time, i.e. jumps between vertices of the box)."""
    rng = np.random.default_rng(seed)
    box = veh.xi_box
    if corners:
        out = np.empty((n, 2))
        k = 0
        while k < n:
            length = max(1, int(rng.exponential(corr_time / dt)))
            out[k:k + length] = box[np.arange(2), rng.integers(0, 2, size=2)]
            k += length
        return out
    from scipy.signal import lfilter

    a = math.exp(-dt / corr_time)
    w = rng.standard_normal((n, 2)) * math.sqrt(1 - a * a)
    w[0] = rng.standard_normal(2)                     # stationary start
    z = lfilter([1.0], [1.0, -a], w, axis=0)          # z_k = a z_{k-1} + w_k
    s = np.tanh(1.5 * z)
    return box[:, 0] + (s + 1) / 2 * (box[:, 1] - box[:, 0])


def interval_metrics(res: IntervalResult, truth: np.ndarray, t: np.ndarray | None = None,
                     t_skip: float = 0.0, tol: float = 0.0, mask=None,
                     width_t_skip: float | None = None) -> dict:
    """Enclosure rate of ``truth`` (N, 2) (NaN columns are skipped) and mean / max widths of
    ``v_y`` [m/s] and ``r`` [rad/s], over samples with ``t >= t[0] + t_skip`` (and ``mask``
    (N,) bool if given). ``max_excursion_*``: largest distance outside the interval.
    ``width_t_skip`` (needs ``t``): widths only after this time, to leave out the decay of
    the initial box."""
    truth = np.asarray(truth, dtype=float)
    sel = np.ones(len(truth), bool) if t is None else (t >= t[0] + t_skip)
    if mask is not None:
        sel = sel & np.asarray(mask, dtype=bool)
    if not sel.any():
        raise ValueError("interval_metrics: no sample selected (check t_skip / mask)")
    wsel = sel
    if width_t_skip is not None:
        if t is None:
            raise ValueError("interval_metrics: width_t_skip needs t")
        wsel = sel & (t >= t[0] + width_t_skip)
    out = {}
    for c, nm in enumerate(("vy", "r")):
        w = res.width[wsel, c]
        out[f"width_mean_{nm}"] = float(w.mean())
        out[f"width_max_{nm}"] = float(w.max())
        x = truth[sel, c]
        if np.all(np.isnan(x)):
            continue
        inside = (res.x_lo[sel, c] - tol <= x) & (x <= res.x_hi[sel, c] + tol)
        out[f"enclosure_{nm}"] = float(inside.mean())
        above = np.maximum(x - res.x_hi[sel, c], 0) + np.maximum(res.x_lo[sel, c] - x, 0)
        out[f"max_excursion_{nm}"] = float(above.max())
    return out


def run_on_log(design: IntervalDesign, log, x0_lo, x0_hi, steer_noise: float = 0.0,
               y_noise: float = 0.0, use_truth: bool = False, clip_speed: bool = False):
    """Run the observer on a :class:`~vehicle_observers.data.logs.DriveLog`: measured ``vx``,
    steering ``delta +- steer_noise`` [rad] and yaw rate ``y`` with ``|y - r| <= y_noise``.
    ``use_truth=True`` takes the noise-free ``*_true`` channels of an emulated log instead."""
    if use_truth:
        for c in ("vx_true_mps", "delta_true_rad", "yaw_rate_true_radps"):
            if c not in log.extra:
                raise ValueError(f"{log.source or 'log'}: use_truth needs column {c!r}")
        vx, d, y = (log.extra[c] for c in ("vx_true_mps", "delta_true_rad",
                                           "yaw_rate_true_radps"))
    else:
        vx, d, y = log.vx, log.delta, log.yaw_rate
    return run_interval_observer(design, log.dt, vx, d - steer_noise, d + steer_noise, y,
                                 x0_lo, x0_hi, y_noise=y_noise, clip_speed=clip_speed)


def share_in_box(stiffness, lo: float, hi: float, mask=None) -> float:
    """Share of samples whose (secant) stiffness [N/rad] lies in ``[lo, hi]``."""
    s = np.asarray(stiffness, dtype=float)
    if mask is not None:
        s = s[np.asarray(mask, bool)]
    return float(np.mean((s >= lo) & (s <= hi)))


#: tableau-colorblind10 colours: switched / single-mode / third observer
PALETTE = ("#006BA4", "#FF800E", "#595959", "#5F9ED1", "#C85200")


def plot_inputs(t, vx, delta, sigma, bands: SpeedBands, title: str = ""):
    """Steering, speed with the band edges, and sigma(t) (the slides' input figures)."""
    import matplotlib.pyplot as plt

    from vehicle_observers.core.arrays import decimate

    fig, ax = plt.subplots(3, 1, sharex=True, figsize=(9.0, 6.0))
    tt, d, v, s = decimate(t, delta, vx, np.asarray(sigma) + 1, max_points=2000)
    ax[0].plot(tt, np.degrees(d), color=PALETTE[0])
    ax[0].set_ylabel(r"$\delta_f$ [deg]")
    ax[1].plot(tt, v, color=PALETTE[0])
    for e in bands.edges:
        ax[1].axhline(e, color="0.5", ls=":", lw=0.8)
    ax[1].set_ylabel("$v_x$ [m/s]")
    ax[2].step(tt, s, where="post", color=PALETTE[0])
    ax[2].set_ylabel(r"$\sigma(t)$ [mode]")
    ax[2].set_yticks(range(1, bands.n_modes + 1))
    ax[2].set_xlabel("$t$ [s]")
    if title:
        fig.suptitle(title)
    return fig


_STATES = (("v_y", "m/s"), ("r", "rad/s"))


def _band(ax, tt, lo, hi, k, label):
    col = PALETTE[k % len(PALETTE)]
    ax.fill_between(tt, lo, hi, color=col, alpha=0.35 if k == 0 else 0.18, lw=0,
                    label=label, zorder=2 - k)
    ax.plot(tt, lo, color=col, lw=0.7, ls="-" if k == 0 else "--", zorder=3)
    ax.plot(tt, hi, color=col, lw=0.7, ls="-" if k == 0 else "--", zorder=3)


def plot_intervals(t, results: dict, truth_vy, truth_r, title: str = "", tlim=None,
                   truth_label: str = "truth", error_panel: bool = False):
    """Interval estimates of v_y and r (``results = {label: IntervalResult}``) with the
    reference (the slides' two result figures, stacked). ``error_panel=True`` adds, per
    state, a panel with each observer's interval relative to the reference
    (``x^- - x`` and ``x^+ - x``: the reference is enclosed where the band contains 0)."""
    import matplotlib.pyplot as plt

    from vehicle_observers.core.arrays import decimate

    t = np.asarray(t)
    sel = np.ones(len(t), bool) if tlim is None else (t >= tlim[0]) & (t <= tlim[1])
    refs = (truth_vy, truth_r)
    nrow = 4 if error_panel else 2
    fig, ax = plt.subplots(nrow, 1, sharex=True, figsize=(9.0, 2.8 * nrow))
    for c, (nm, unit) in enumerate(_STATES):
        a = ax[2 * c] if error_panel else ax[c]
        for k, (lab, res) in enumerate(results.items()):
            tt, lo, hi = decimate(t[sel], res.x_lo[sel, c], res.x_hi[sel, c], max_points=2000)
            _band(a, tt, lo, hi, k, f"$[{nm}^-, {nm}^+]$ {lab}")
        ref = refs[c]
        if ref is not None:
            tt, rr = decimate(t[sel], np.asarray(ref)[sel], max_points=2000)
            a.plot(tt, rr, color="k", lw=0.9, label=truth_label, zorder=4)
        a.set_ylabel(f"${nm}$ [{unit}]")
        a.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
        if error_panel and ref is not None:
            e = ax[2 * c + 1]
            r = np.asarray(ref)[sel]
            for k, (lab, res) in enumerate(results.items()):
                tt, lo, hi = decimate(t[sel], res.x_lo[sel, c] - r, res.x_hi[sel, c] - r,
                                      max_points=2000)
                _band(e, tt, lo, hi, k, f"$[{nm}^- - {nm},\\ {nm}^+ - {nm}]$ {lab}")
            e.axhline(0.0, color="k", lw=0.9)
            e.set_ylabel(f"interval $-$ ${nm}$ [{unit}]")
            e.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
    ax[-1].set_xlabel("$t$ [s]")
    if title:
        fig.suptitle(title)
    return fig


def plot_widths(t, results: dict, title: str = "", t_settle: dict | None = None):
    """Interval widths of v_y and r (log scale) for several observers; ``t_settle``
    ``{label: (t_vy, t_r)}`` marks each observer's convergence time [s] (from ``t[0]``)."""
    import matplotlib.pyplot as plt

    from vehicle_observers.core.arrays import decimate

    fig, ax = plt.subplots(2, 1, sharex=True, figsize=(9.0, 4.8))
    for k, (lab, res) in enumerate(results.items()):
        col = PALETTE[k % len(PALETTE)]
        tt, w1, w2 = decimate(t, res.width[:, 0], res.width[:, 1], max_points=2000)
        ax[0].semilogy(tt, np.maximum(w1, 1e-12), color=col, label=lab)
        ax[1].semilogy(tt, np.maximum(w2, 1e-12), color=col, label=lab)
        for c in range(2):
            ts = (t_settle or {}).get(lab)
            if ts is not None and np.isfinite(ts[c]):
                ax[c].axvline(t[0] + ts[c], color=col, ls=":", lw=1.0)
    ax[0].set_ylabel("width $v_y^+ - v_y^-$ [m/s]")
    ax[1].set_ylabel("width $r^+ - r^-$ [rad/s]")
    ax[1].set_xlabel("$t$ [s]")
    ax[0].legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
    if title:
        fig.suptitle(title)
    return fig


def plot_gains(design: IntervalDesign, L_printed=None, P_printed=None, others: dict | None = None):
    """Designed |L| (and P_22/P_11) next to the slides' printed values, per mode.vertex;
    ``others`` ``{label: IntervalDesign}`` adds more designs (e.g. the other vertex polarity)."""
    import matplotlib.pyplot as plt

    K = design.L.shape[0]
    fig, ax = plt.subplots(1, 3, figsize=(10.5, 3.6))
    idx = np.arange(K * 4)
    labels = [f"{i + 1}.{j + 1}" for i in range(K) for j in range(4)]
    designs = {"designed": design, **(others or {})}
    marks = "osd^"
    for c, nm in enumerate(("$|L_1|$ ($v_y$ row) [m/s]", "$|L_2|$ ($r$ row) [1/s]")):
        for k, (lab, d) in enumerate(designs.items()):
            ax[c].plot(idx, np.abs(d.L[..., c, 0]).ravel(), marks[k % 4], mfc="none",
                       color=PALETTE[(0, 2, 4, 3)[k % 4]], label=lab)
        if L_printed is not None:
            lp = np.abs(np.asarray(L_printed)[..., c]).ravel()
            ax[c].plot(np.arange(len(lp)), lp, "x", color=PALETTE[1], label="printed")
        ax[c].set_yscale("log")
        ax[c].set_title(nm)
    if P_printed is not None:
        pp_ = np.asarray(P_printed)
        ax[2].plot(np.arange(pp_[..., 0].size), (pp_[..., 1] / pp_[..., 0]).ravel(), "x",
                   color=PALETTE[1], label="printed")
    ax[2].plot(idx, (design.P[..., 1] / design.P[..., 0]).ravel(), "o", mfc="none",
               color=PALETTE[0], label="designed")
    ax[2].set_yscale("log")
    ax[2].set_title("$P_{22} / P_{11}$ [-]")
    for a in ax:
        a.set_xticks(idx)
        a.set_xticklabels(labels, rotation=90, fontsize=7)
        a.set_xlabel("mode.vertex $i.j$")
    ax[0].legend(fontsize=7)
    return fig
