"""Linear bicycle with a box of cornering stiffness and its switched TS form (Ifqir 2017).

Source: S. Ifqir, N. Ait-Oufroukh, D. Ichalal, S. Mammar, "Robust estimation of vehicle
lateral velocity and yaw rate using Switched T-S Fuzzy Interval Observer", GTAA 2017
(slides; equation numbers below are the slides'). The interval observer (11) and its LMI
design (Theorem 2) built on this model are in :mod:`vehicle_observers.observers.interval`;
the same model in the coordinates ``z = T x`` (:class:`TransformedIntervalModel`) is used by
:mod:`vehicle_observers.observers.interval_coordinates`.

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

Simulation: :func:`simulate_lpv` (Euler, the observer's own scheme, or RK4) with a stiffness
trajectory inside the box (:func:`random_stiffness_trajectory`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from vehicle_observers.core.errors import InfeasibleDesign, ObserverArgumentError
from vehicle_observers.models.ts import memberships, vertex_bits

N_STATE = 2
#: the yaw-rate gyro ``y = C x = r``
C_OUT = np.array([[0.0, 1.0]])
#: columns of the premise bounds ``zmin``, ``zmax`` (K, 2): ``1/v_x`` [s/m], ``v_x`` [m/s]
Z_INV_VX, Z_VX = range(2)


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
                raise ObserverArgumentError(f"UncertainBicycle.{k} must be finite and > 0, got {v}")
        if not (0.0 <= self.rel_unc < 1.0):
            raise ObserverArgumentError(f"rel_unc must be in [0, 1), got {self.rel_unc}")

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
        raise ObserverArgumentError("elementwise_bounds: fn is not affine in xi; corner bounds not exact")
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
            raise ObserverArgumentError(f"SpeedBands: need at least two edges, got {self.edges}")
        if not np.all(np.isfinite(e)) or e[0] <= 0 or np.any(np.diff(e) <= 0):
            raise ObserverArgumentError(f"SpeedBands: edges must be finite, > 0 and strictly increasing "
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
            raise ObserverArgumentError(f"v_x = {vx.ravel()[k]:.6g} m/s at sample {k} is outside the speed "
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
        # columns Z_INV_VX, Z_VX
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
            raise ObserverArgumentError(f"accel_max must be finite and >= 0 m/s^2, got {accel_max}")
        vmin, vmax = self.zmin[:, Z_VX], self.zmax[:, Z_VX]
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


def check_series(name, a, N=None):
    """``a`` as a contiguous float (N,) array; ObserverArgumentError naming ``name`` if it is
    not 1-D, has another length than ``N`` or holds a non-finite value."""
    a = np.ascontiguousarray(a, dtype=float)
    if a.ndim != 1:
        raise ObserverArgumentError(f"{name} must be a 1-D array (N,), got shape {a.shape}")
    if N is not None and len(a) != N:
        raise ObserverArgumentError(f"{name} has {len(a)} samples, expected {N} (same as vx)")
    if not np.all(np.isfinite(a)):
        k = int(np.argmax(~np.isfinite(a)))
        raise ObserverArgumentError(f"{name}[{k}] = {a[k]} is not finite")
    return a


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


def simulate_lpv(veh: UncertainBicycle, x0, delta, vx, xi, dt: float, substeps: int = 1,
                 method: str = "euler") -> np.ndarray:
    """Simulate the LPV bicycle (3)-(4) with a stiffness trajectory ``xi`` (N, 2) = (c_r, c_f)
    [N/rad] (or (2,) constant), steering ``delta`` and speed ``vx`` (N,) held over each
    sample of ``dt`` s. ``method``: ``"euler"`` (same scheme as the observer: the enclosure
    guarantee is exact for it) or ``"rk4"``. Returns X (N, 2) = [v_y, r] at the samples."""
    vx = check_series("vx", vx)
    N = len(vx)
    delta = check_series("delta", delta, N)
    if np.any(vx <= 0):
        k = int(np.argmax(vx <= 0))
        raise ObserverArgumentError(f"vx must be > 0 m/s (the model divides by it): vx[{k}] = {vx[k]}")
    xi = np.asarray(xi, dtype=float)
    xi = np.ascontiguousarray(np.broadcast_to(xi, (N, 2)) if xi.shape == (2,) else xi)
    if xi.shape != (N, 2):
        raise ObserverArgumentError(f"xi must be (2,) or ({N}, 2) = (c_r, c_f), got {xi.shape}")
    if method not in ("euler", "rk4"):
        raise ObserverArgumentError(f"method must be 'euler' or 'rk4', got {method!r}")
    if dt <= 0 or int(substeps) < 1:
        raise ObserverArgumentError(f"need dt > 0 and substeps >= 1, got {dt}, {substeps}")
    return _lpv_loop(np.asarray(x0, dtype=float).copy(), vx, delta, xi, int(substeps),
                     float(dt), veh.m, veh.I_z, veh.l_f, veh.l_r, method == "rk4")


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


# ------------------------------------------------------------------ coordinates z = T x ----
def transform(kappa: float) -> tuple[np.ndarray, np.ndarray]:
    """``(T, T^-1)`` of the similarity ``z = T x`` (module docstring), each (2, 2)."""
    k = float(kappa)
    return np.array([[1.0, 0.0], [-k, 1.0]]), np.array([[1.0, 0.0], [k, 1.0]])


class TransformedIntervalModel(SwitchedIntervalModel):
    """:class:`SwitchedIntervalModel` of ``z = T x`` (Raissi, Efimov, Zolghadri 2012):
    ``A_lo/A_nom/A_hi`` (K, 4, 2, 2) of ``T A T^-1``, ``B_*`` (2, 1) of ``T B``, ``C = C_z``."""

    def __init__(self, veh: UncertainBicycle, bands: SpeedBands, kappa: float):
        super().__init__(veh, bands)
        self.kappa = float(kappa)
        self.T, self.Tinv = transform(kappa)
        box = veh.xi_box
        for i in range(bands.n_modes):
            for j in range(4):
                s, v = self.z_vertices[i, j]
                fn = (lambda xi, s=s, v=v: self.T @ lpv_A(s, v, xi, veh) @ self.Tinv)
                self.A_lo[i, j], self.A_nom[i, j], self.A_hi[i, j] = elementwise_bounds(fn,
                                                                                           box)
        self.B_lo, self.B_nom, self.B_hi = elementwise_bounds(
            lambda xi: self.T @ lpv_B(xi, veh), box)
        self.C = C_OUT @ self.Tinv

    def check_metzler_feasible(self):
        """Raise :class:`InfeasibleDesign` if an off-diagonal entry in a column that ``L C``
        cannot reach (``C[0, b] = 0``) is negative somewhere on the box."""
        K, J, n, _ = self.A_lo.shape
        for b in range(n):
            if self.C[0, b] != 0.0:
                continue
            for i in range(K):
                for j in range(J):
                    for a in range(n):
                        if a != b and self.A_lo[i, j, a, b] < 0:
                            raise InfeasibleDesign(
                                f"Metzler condition (20) impossible with kappa = {self.kappa:g}"
                                f" in mode {i + 1}, vertex {j + 1}: entry ({a + 1},{b + 1}) of "
                                f"A_z^- = {self.A_lo[i, j, a, b]:.4g} < 0 and C_z[{b + 1}] = 0",
                                lmi=f"Metzler[{i + 1},{j + 1}]",
                                violation=-self.A_lo[i, j, a, b])

    def check_diagonal_shift(self, epsilon: float):
        """(20)'s diagonal part: only columns with ``C[0, a] = 0`` are out of the gain's
        reach; for ``kappa != 0`` none is and the LMI decides."""
        if self.C[0, 0] == 0.0:
            super().check_diagonal_shift(epsilon)
