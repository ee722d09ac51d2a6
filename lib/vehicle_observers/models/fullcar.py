"""Full-car vertical model (Rabhi et al., AVCS 2004, eqs. (23)-(29)).

``M q'' + C q' + K q = zeta``, ``q = [z_1, z_2, z_3, z_4, z, theta, phi]`` (7,):
four unsprung-mass displacements [m], body heave [m], pitch [rad], roll [rad], all
deviations from the static equilibrium (gravity cancels; the "G" of the paper's text does
not appear in (23)). Wheel order follows (26)-(27): 1 = rear left, 2 = rear right,
3 = front left, 4 = front right.

Road input through (25): ``zeta = [A11 U + B11 U'; 0_3]`` with ``A11 = diag(k_t)``,
``B11 = diag(c_t)`` (tyre stiffness and damping), ``U`` (4,) the road elevation under
each wheel.

Reconstructions (R-B1, R-B2; also in notebook 05)
-------------------------------------------------
R-B1  (24) says ``q in R^8`` but lists 7 coordinates (4 wheels + heave, pitch, roll);
      the model has 7 degrees of freedom; (25) writes ``zeta in R^{4x4}``: it is the
      4-vector entering the wheel equations (zero in the body equations).
R-B2  (29) has ``+zeta`` inside ``-M1^-1(...)``; from (23) the road force enters with a
      plus sign: ``x21' = -M1^-1(C11 x21 + C12 x22 + K11 x11 + K12 x12) + M1^-1 zeta``.

Body-corner displacement ``z_si = z + x_i theta + y_i phi`` (``x_i = +a`` front,
``-b`` rear; ``y_i = +w`` left, ``-w`` right; theta positive = nose up, phi positive =
left side up). Suspension corner force ``f_i = k_s,i (z_si - z_i) + c_s,i (z_si' - z_i')``
acts up on the wheel and down on the body.

Parameter values (the paper prints none): geometry ``a = 1.1 m, b = 1.44 m`` from the
Yacine 2015 car of the same group; half track ``w = 0.75 m`` so that the wheel tracks are
the two tracks of the OpenCRG Belgian-block sample (v = +-0.75 m); masses, inertias,
spring/damper and tyre rates are typical mid-size passenger-car values (ranges of
Gillespie, *Fundamentals of Vehicle Dynamics*, 1992, Ch. 5-6: body bounce 1-1.5 Hz,
wheel hop 10-12 Hz, suspension damping ratio 0.2-0.4), chosen here and checked by
``modal_summary``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from vehicle_observers.core.errors import ObserverArgumentError

WHEELS = ("rear left", "rear right", "front left", "front right")
#: first column of each block of :func:`outputs` (observer outputs ``[x11 (4), x12 (3), x22
#: (3)]``; paper outputs (29) ``[x12 (3), x22 (3), x31 (4)]``), read by the road observers
OUT_X11, OUT_X12, OUT_X22 = 0, 4, 7
PAPER_X12, PAPER_X22, PAPER_X31 = 0, 3, 6


@dataclass(frozen=True)
class FullCarParams:
    """Constants of the full-car model; per-corner arrays in wheel order (RL, RR, FL, FR)."""

    m_s: float = 1340.0                        # kg sprung mass
    I_theta: float = 2100.0                    # kg m^2 pitch inertia
    I_phi: float = 500.0                       # kg m^2 roll inertia
    a: float = 1.1                             # m CG -> front axle
    b: float = 1.44                            # m CG -> rear axle
    w: float = 0.75                            # m half track
    m_u: tuple = (38.0, 38.0, 42.0, 42.0)      # kg unsprung masses
    k_s: tuple = (25e3, 25e3, 30e3, 30e3)      # N/m suspension springs
    c_s: tuple = (2200.0, 2200.0, 2500.0, 2500.0)  # N s/m suspension dampers
    k_t: tuple = (2.0e5, 2.0e5, 2.0e5, 2.0e5)  # N/m tyre stiffness (A11)
    c_t: tuple = (150.0, 150.0, 150.0, 150.0)  # N s/m tyre damping (B11)

    def with_(self, **kw) -> "FullCarParams":
        return replace(self, **kw)

    def scaled(self, **rel) -> "FullCarParams":
        """Copy with relative errors, e.g. ``scaled(m_u=0.1, k_t=-0.05)``."""
        kw = {}
        for k, v in rel.items():
            cur = getattr(self, k)
            kw[k] = (tuple(float(c) * (1 + v) for c in cur) if isinstance(cur, tuple)
                     else cur * (1 + v))
        return replace(self, **kw)

    @property
    def S(self) -> np.ndarray:
        """Corner geometry (4, 3): ``z_s = S [z, theta, phi]``."""
        x = np.array([-self.b, -self.b, self.a, self.a])
        y = np.array([self.w, -self.w, self.w, -self.w])
        return np.column_stack([np.ones(4), x, y])

    def matrices(self):
        """``(M, C, K, A11, B11)``: M, C, K (7, 7) of (23)/(28), A11, B11 (4, 4) of (26)-(27)."""
        S = self.S
        Ks, Cs = np.diag(self.k_s), np.diag(self.c_s)
        Kt, Ct = np.diag(self.k_t), np.diag(self.c_t)
        M = np.diag([*self.m_u, self.m_s, self.I_theta, self.I_phi])
        K = np.block([[Ks + Kt, -Ks @ S], [-S.T @ Ks, S.T @ Ks @ S]])
        C = np.block([[Cs + Ct, -Cs @ S], [-S.T @ Cs, S.T @ Cs @ S]])
        return M, C, K, Kt, Ct

    def state_space(self):
        """``x' = A x + B_u U + B_d U'`` with ``x = [q; q']`` (14,); returns (A, B_u, B_d)."""
        M, C, K, A11, B11 = self.matrices()
        Mi = np.linalg.inv(M)
        A = np.block([[np.zeros((7, 7)), np.eye(7)], [-Mi @ K, -Mi @ C]])
        E = np.zeros((7, 4))
        E[:4] = np.eye(4)
        Bu = np.vstack([np.zeros((7, 4)), Mi @ E @ A11])
        Bd = np.vstack([np.zeros((7, 4)), Mi @ E @ B11])
        return A, Bu, Bd


def energy(x, p: FullCarParams) -> np.ndarray:
    """Mechanical energy ``q'M q'/2 + q'K q/2`` [J] of states x (..., 14)."""
    M, _, K, _, _ = p.matrices()
    x = np.asarray(x, dtype=float)
    q, v = x[..., :7], x[..., 7:]
    return 0.5 * np.einsum("...i,ij,...j", v, M, v) + 0.5 * np.einsum("...i,ij,...j", q, K, q)


def power(x, U, Ud, p: FullCarParams) -> np.ndarray:
    """``dE/dt = -q'C q' + q'_wheels . zeta`` [W] (damping loss + road power)."""
    _, C, _, A11, B11 = p.matrices()
    x = np.asarray(x, dtype=float)
    v = x[..., 7:]
    zeta = np.asarray(U) @ A11.T + np.asarray(Ud) @ B11.T
    return -np.einsum("...i,ij,...j", v, C, v) + np.sum(v[..., :4] * zeta, axis=-1)


def static_deflection(U0, p: FullCarParams) -> np.ndarray:
    """Equilibrium ``q`` (7,) for a constant road ``U0`` (4,): ``K q = [A11 U0; 0]``."""
    _, _, K, A11, _ = p.matrices()
    rhs = np.zeros(7)
    rhs[:4] = A11 @ np.asarray(U0, dtype=float)
    return np.linalg.solve(K, rhs)


def modal_summary(p: FullCarParams) -> dict:
    """Undamped natural frequencies [Hz] sorted (7,) and damping ratios of the damped modes."""
    M, C, K, _, _ = p.matrices()
    w2 = np.linalg.eigvals(np.linalg.solve(M, K))
    f = np.sort(np.sqrt(np.real(w2))) / (2 * np.pi)
    A, _, _ = p.state_space()
    lam = np.linalg.eigvals(A)
    lam = lam[np.imag(lam) > 0]
    zeta = -np.real(lam) / np.abs(lam)
    order = np.argsort(np.abs(lam))
    return {"f_undamped_hz": f, "f_damped_hz": np.abs(lam[order]) / (2 * np.pi),
            "damping_ratio": zeta[order]}


@njit(cache=True)
def _simulate_exact(x0, Phi, Gu, Gw, U, dt):
    """``x_{k+1} = Phi x_k + Gu U_k + Gw (U_{k+1} - U_k)/dt``: exact for U linear between
    samples (first-order hold)."""
    N = U.shape[0]
    n = x0.shape[0]
    m = U.shape[1]
    X = np.empty((N, n))
    x = x0.copy()
    xn = np.empty(n)
    for k in range(N):
        for i in range(n):
            X[k, i] = x[i]
        if k == N - 1:
            break
        for i in range(n):
            acc = 0.0
            for j in range(n):
                acc += Phi[i, j] * x[j]
            for j in range(m):
                acc += Gu[i, j] * U[k, j] + Gw[i, j] * (U[k + 1, j] - U[k, j]) / dt
            xn[i] = acc
        for i in range(n):
            x[i] = xn[i]
    return X


def discretise(p: FullCarParams, dt: float):
    """Exact discretisation of (23) for road inputs linear between samples:
    ``(Phi, Gu, Gw)`` from the exponential of ``[[A, B_u, B_d], [0, 0, I], [0, 0, 0]] dt``
    (state, road elevation, road slope)."""
    from scipy.linalg import expm

    A, Bu, Bd = p.state_space()
    n, m = A.shape[0], Bu.shape[1]
    Z = np.zeros((n + 2 * m, n + 2 * m))
    Z[:n, :n] = A
    Z[:n, n:n + m] = Bu
    Z[:n, n + m:] = Bd
    Z[n:n + m, n + m:] = np.eye(m)
    E = expm(Z * dt)
    return E[:n, :n].copy(), E[:n, n:n + m].copy(), E[:n, n + m:].copy()


def simulate(U, dt: float, p: FullCarParams, x0=None) -> np.ndarray:
    """Simulate (23) for road inputs ``U`` (N, 4) [m] sampled every ``dt`` s (linear in
    between; exact discretisation, see :func:`discretise`). Returns states (N, 14)
    ``[q, q']``; starts at rest (``x0`` = static equilibrium for ``U[0]``) unless ``x0``
    given."""
    U = np.ascontiguousarray(U, dtype=float)
    if U.ndim != 2 or U.shape[1] != 4 or len(U) < 1:
        raise ObserverArgumentError(f"fullcar.simulate: U must be (N, 4) road elevations (RL, "
                                    f"RR, FL, FR), got {U.shape}")
    if not np.all(np.isfinite(U)):
        k = int(np.argmax(~np.all(np.isfinite(U), axis=1)))
        raise ObserverArgumentError(f"fullcar.simulate: road input U row {k} is not finite: "
                                    f"{U[k]}")
    if not (np.isfinite(dt) and dt > 0):
        raise ObserverArgumentError(f"fullcar.simulate: dt must be > 0 s, got {dt}")
    if x0 is None:
        x0 = np.concatenate([static_deflection(U[0], p), np.zeros(7)])
    elif np.shape(x0) != (14,) or not np.all(np.isfinite(x0)):
        raise ObserverArgumentError(f"fullcar.simulate: x0 must be 14 finite values [q, q'], "
                                    f"got shape {np.shape(x0)}")
    Phi, Gu, Gw = discretise(p, float(dt))
    return _simulate_exact(np.asarray(x0, dtype=float), Phi, Gu, Gw, U, float(dt))


def outputs(X, U, Ud, p: FullCarParams, paper: bool = False) -> np.ndarray:
    """Measured outputs.

    ``paper=True``: the paper's (29) ``y = [x12, x22, x31]`` (3 + 3 + 4): body heave,
    pitch, roll, their rates, and the wheel accelerations.
    ``paper=False`` (used by the observer, reconstruction R-B3): ``y = [x11, x12, x22]``
    (4 + 3 + 3): wheel displacements (from suspension-deflection sensors ``d = S x12 - x11``
    and the body position), body positions and rates.
    """
    X = np.asarray(X, dtype=float)
    if paper:   # columns PAPER_X12, PAPER_X22, PAPER_X31
        A, Bu, Bd = p.state_space()
        xd = X @ A.T + np.asarray(U) @ Bu.T + np.asarray(Ud) @ Bd.T
        return np.concatenate([X[:, 4:7], X[:, 11:14], xd[:, 7:11]], axis=1)
    return np.concatenate([X[:, 0:4], X[:, 4:7], X[:, 11:14]], axis=1)   # OUT_X11, _X12, _X22


def warp_vector(p: FullCarParams) -> np.ndarray:
    """Wheel-displacement pattern ``v`` (4,) with ``S' K_s v = 0``: a static wheel offset
    that produces no body force (the "warp" mode), scaled to max |v| = 1.

    With the road ``U0 = (K_s + K_t) K_t^-1 v`` the state ``x11 = v``, everything else 0,
    is an equilibrium whose paper outputs (29) ``[x12, x22, x31]`` are all zero, exactly like
    the flat-road rest state: the paper's output set cannot tell a wheel displacement (and
    its road) from zero. This motivates reconstruction R-B3 (wheel displacements measured).
    """
    Nk = p.S.T @ np.diag(p.k_s)
    _, _, vt = np.linalg.svd(Nk)
    v = vt[-1]
    return v / np.max(np.abs(v))
