"""Autonomous bicycle with tracking law (Ichalal, Arioui, Mammar, MED 2011, Sec. III).

State ``x = [beta (yaw, rad), psi_beta (1/m, see below), alpha (roll, rad), psi_alpha
(roll rate, rad/s)]``, eq. (25):

    x1' = x2 v
    x2' = u
    x3' = x4
    x4' = (1/p) (g sin x3 + (1 + p x2 sin x3) cos x3 x2 v^2 + c cos x3 v u)

with normalised steering torque ``u`` (eq. (24): ``x2 = psi_beta`` is the steering-related
yaw curvature, so ``x1' = v x2``), forward speed ``v`` (m/s), CG height ``p`` (m) and
horizontal CG offset ``c`` (m). Tracking law (27):
``u = -k1 (x3 - sin t) - k2 (x4 - cos t)``, k1 = k2 = 10.

Reconstruction note: the extraction puts ``(1/p)`` in front of the whole bracket and the
``c cos(x3) v u`` term on the next line; the factors in eq. (33) (8.33 = c v / p with
c = 0.5, v = 10, p = 0.6) confirm that ``c cos x3 v u`` is also divided by ``p``.

TS model by sector nonlinearity (Sec. III-A), premises
``z1 = (g/p) sin(x3)/x3``, ``z2 = (1/p)(1 + p x2 sin x3) cos(x3) v^2``, ``z3 = (c/p) cos(x3) v``:
``x4' = z1 x3 + z2 x2 + z3 u``, i.e. ``A(z) = [[0,v,0,0],[0,0,0,0],[0,0,0,1],[0,z2,z1,0]]``,
``B(z) = [0, 1, 0, z3]^T`` (8 submodels).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.models.ts import Premise, SectorTS

#: index of each constant in :meth:`BicycleParams.as_array` (the packed vector the compiled
#: kernels of this module and of :mod:`vehicle_observers.observers.dmvt` read)
BP_P, BP_C, BP_V, BP_G, BP_K1, BP_K2 = range(6)


@dataclass(frozen=True)
class BicycleParams:
    """p [m] CG height, c [m] CG horizontal offset, v [m/s] speed, g [m/s^2], k1, k2 gains."""

    p: float = 0.6
    c: float = 0.5
    v: float = 10.0
    g: float = 9.81
    k1: float = 10.0
    k2: float = 10.0

    def as_array(self):
        """``[p, c, v, g, k1, k2]``, indices :data:`BP_P` ... :data:`BP_K2`."""
        return np.array([self.p, self.c, self.v, self.g, self.k1, self.k2], dtype=float)


def tracking_reference(t):
    """x3d = sin t, x4d = cos t (Ichalal 2011, below (27))."""
    t = np.asarray(t, dtype=float)
    return np.sin(t), np.cos(t)


def control(x, t, bp: BicycleParams):
    """Tracking law (27); x (N, 4) or (4,), t (N,) or scalar."""
    x = np.asarray(x, dtype=float)
    x3d, x4d = tracking_reference(t)
    return -bp.k1 * (x[..., 2] - x3d) - bp.k2 * (x[..., 3] - x4d)


def rhs(x, u, bp: BicycleParams):
    """Open-loop right-hand side (25); x (N, 4), u (N,) -> (N, 4)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    u = np.ravel(u)
    x1, x2, x3, x4 = x.T
    p, c, v, g = bp.p, bp.c, bp.v, bp.g
    f4 = (g * np.sin(x3) + (1 + p * x2 * np.sin(x3)) * np.cos(x3) * x2 * v**2
          + c * np.cos(x3) * v * u) / p
    return np.column_stack([x2 * v, u, x4, f4])


def jacobian(x, u, bp: BicycleParams):
    """df/dx of (25) at (x, u) (u held fixed), shape (N, 4, 4). Ichalal 2011 eq. (31).

    df4/dx2 = (2 p x2 sin x3 + 1) cos(x3) v^2 / p
    df4/dx3 = (g/p) cos x3 + x2^2 v^2 (cos^2 x3 - sin^2 x3) - x2 v^2 sin(x3)/p - (c v/p) u sin x3
    """
    x = np.atleast_2d(np.asarray(x, dtype=float))
    u = np.ravel(u)
    _, x2, x3, _ = x.T
    p, c, v, g = bp.p, bp.c, bp.v, bp.g
    J = np.zeros((len(x), 4, 4))
    J[:, 0, 1] = v
    J[:, 2, 3] = 1.0
    J[:, 3, 1] = (2 * p * x2 * np.sin(x3) + 1) * np.cos(x3) * v**2 / p
    J[:, 3, 2] = (g / p * np.cos(x3) + x2**2 * v**2 * (np.cos(x3)**2 - np.sin(x3)**2)
                  - x2 * v**2 * np.sin(x3) / p - c * v / p * u * np.sin(x3))
    return J


def ts_premises(x, u, bp: BicycleParams):
    """(z1, z2, z3) of Sec. III-A along (N, 4) states; z1 = (g/p) sin(x3)/x3 (1 at 0)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    x2, x3 = x[:, 1], x[:, 2]
    p, c, v, g = bp.p, bp.c, bp.v, bp.g
    z1 = g / p * np.sinc(x3 / np.pi)
    z2 = (1 + p * x2 * np.sin(x3)) * np.cos(x3) * v**2 / p
    z3 = c / p * np.cos(x3) * v
    return np.column_stack([z1, z2, z3])


def ts_matrices(z, bp: BicycleParams):
    z1, z2, z3 = z
    A = np.array([[0.0, bp.v, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1.0], [0, z2, z1, 0]])
    B = np.array([[0.0], [1.0], [0.0], [z3]])
    return A, B


def bicycle_ts(bp: BicycleParams, bounds) -> SectorTS:
    """8-submodel TS model; ``bounds`` = [(z1min, z1max), (z2min, z2max), (z3min, z3max)]."""
    names = ["z1 = (g/p) sin(x3)/x3", "z2 = (1/p)(1 + p x2 sin x3) cos(x3) v^2",
             "z3 = (c/p) cos(x3) v"]
    # units from (25), where d(x4)/dt is in rad/s^2: z1 multiplies the roll x3 [rad] (1/s^2),
    # z2 the curvature x2 = d(x1)/dt / v [rad/m] (m/s^2); z3 = (c/p) cos(x3) v is in m/s
    prem = [Premise(nm, lo, hi, unit)
            for (nm, (lo, hi)), unit in zip(zip(names, bounds), ("1/s^2", "m/s^2", "m/s"))]
    return SectorTS(prem, lambda z: ts_matrices(z, bp),
                    premise_fn=lambda x, u: ts_premises(x, u, bp),
                    name="Ichalal 2011 bicycle TS model")


@njit(cache=True)
def plant_rhs(x, t, P, out):
    """Closed loop (25)+(27) (compiled): ``out`` (4,) = ``f(x, u)`` at time ``t`` [s] with
    the tracking law ``u = -k1 (x3 - sin t) - k2 (x4 - cos t)``; returns ``u``. ``P`` is
    :meth:`BicycleParams.as_array`. The one compiled definition of the plant, also used by
    the plant/observer co-simulation of :mod:`vehicle_observers.observers.dmvt`."""
    p, c, v, g = P[BP_P], P[BP_C], P[BP_V], P[BP_G]
    u = -P[BP_K1] * (x[2] - np.sin(t)) - P[BP_K2] * (x[3] - np.cos(t))
    out[0] = x[1] * v
    out[1] = u
    out[2] = x[3]
    out[3] = (g * np.sin(x[2]) + (1 + p * x[1] * np.sin(x[2])) * np.cos(x[2]) * x[1] * v * v
              + c * np.cos(x[2]) * v * u) / p
    return u


@njit(cache=True)
def _bike_f(x, t, P, ts_mode, Av, Bv, zmin, zmax, out):
    if not ts_mode:
        return plant_rhs(x, t, P, out)
    p, c, v, g = P[BP_P], P[BP_C], P[BP_V], P[BP_G]
    u = -P[BP_K1] * (x[2] - np.sin(t)) - P[BP_K2] * (x[3] - np.cos(t))
    z = np.empty(3)
    z[0] = g / p * (np.sin(x[2]) / x[2] if abs(x[2]) > 1e-8 else 1.0)
    z[1] = (1 + p * x[1] * np.sin(x[2])) * np.cos(x[2]) * v * v / p
    z[2] = c / p * np.cos(x[2]) * v
    for i in range(4):
        out[i] = 0.0
    for vtx in range(Av.shape[0]):
        w = 1.0
        for j in range(3):
            bit = (vtx >> (2 - j)) & 1
            w0 = (z[j] - zmin[j]) / (zmax[j] - zmin[j])
            w *= w0 if bit == 0 else 1.0 - w0
        for i in range(4):
            s = Bv[vtx, i, 0] * u
            for j in range(4):
                s += Av[vtx, i, j] * x[j]
            out[i] += w * s
    return u


@njit(cache=True)
def _bike_sim(x0, t, P, ts_mode, Av, Bv, zmin, zmax):
    N = t.shape[0]
    X = np.empty((N, 4))
    U = np.empty(N)
    x = x0.copy()
    k1 = np.empty(4)
    k2 = np.empty(4)
    k3 = np.empty(4)
    k4 = np.empty(4)
    tmp = np.empty(4)
    for k in range(N):
        X[k] = x
        U[k] = _bike_f(x, t[k], P, ts_mode, Av, Bv, zmin, zmax, k1)
        if k == N - 1:
            break
        h = t[k + 1] - t[k]
        for i in range(4):
            tmp[i] = x[i] + 0.5 * h * k1[i]
        _bike_f(tmp, t[k] + 0.5 * h, P, ts_mode, Av, Bv, zmin, zmax, k2)
        for i in range(4):
            tmp[i] = x[i] + 0.5 * h * k2[i]
        _bike_f(tmp, t[k] + 0.5 * h, P, ts_mode, Av, Bv, zmin, zmax, k3)
        for i in range(4):
            tmp[i] = x[i] + h * k3[i]
        _bike_f(tmp, t[k] + h, P, ts_mode, Av, Bv, zmin, zmax, k4)
        for i in range(4):
            x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return X, U


def simulate(bp: BicycleParams, t, x0=(0.0, 0.0, 0.0, 0.0), ts: SectorTS | None = None):
    """Closed-loop simulation (RK4 on the grid ``t``) of the nonlinear model (25)+(27),
    or of its TS form when ``ts`` is given (control law evaluated inside each stage).

    Returns (X (N, 4), u (N,)).
    """
    t = np.ascontiguousarray(t, dtype=float)
    if t.ndim != 1 or len(t) < 1 or not np.all(np.isfinite(t)):
        raise ObserverArgumentError(f"bicycle.simulate: t must be a finite (N,) time grid, "
                                    f"got shape {t.shape}")
    if np.any(np.diff(t) <= 0):
        raise ObserverArgumentError("bicycle.simulate: the time grid t must be strictly "
                                    "increasing (a time step dt <= 0)")
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (4,) or not np.all(np.isfinite(x0)):
        raise ObserverArgumentError(f"bicycle.simulate: x0 must be 4 finite values, got {x0}")
    if ts is None:
        Av = np.zeros((1, 4, 4))
        Bv = np.zeros((1, 4, 1))
        zmin = np.zeros(3)
        zmax = np.ones(3)
    else:
        Av, Bv, zmin, zmax = ts.A, ts.B, ts.zmin, ts.zmax
    return _bike_sim(x0, t, bp.as_array(), ts is not None, Av, Bv,
                     zmin, zmax)
