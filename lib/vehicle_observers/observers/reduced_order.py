"""The reduced-order (Luenberger) observer of a ``gains="reduced"`` design of
:mod:`vehicle_observers.design.synthesis`, on sampled data.

With the observer matrices of :func:`vehicle_observers.design.reduced.observer_matrices`
(Luenberger 1966, Sec. IV, in the coordinates where ``C = [I 0]``),

    z' = sum_i h_i (F_i z + G_i y + J_i u),       xhat = Xy y + Xz z,

``z`` (n - p,) is integrated by classical RK4 over each sample interval with ``u`` and
``h`` held (zero-order hold) and ``y`` interpolated linearly between ``y_{k-1}`` and ``y_k``
(first-order hold: the gain ``G_i`` acts on ``y`` directly, so a held ``y`` would leave an
error of order ``|G| |y'| dt``); in discrete time it is the recursion. The estimate at
sample ``k`` uses ``y_k`` itself (the measured block is the measurement), so the readable
state is ``(z_k, y_k)``. The observer contract of :mod:`vehicle_observers.core.protocol`
(readable ``step``; ``run`` loops it).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.design.reduced import observer_matrices
from vehicle_observers.observers.polytopic import PolytopicObserver


class ReducedOrderObserver(PolytopicObserver):
    """Observer of an :class:`~vehicle_observers.design.synthesis.ObserverDesign` whose
    synthesis has ``gains="reduced"``.

    ``dt`` [s] sample period; ``schedule(u_k, y_k) -> h`` (q,) memberships (default equal
    weights). Names ``x1..xn`` (the plant's state), ``u1..um``, ``y1..yp``.
    ``initial_state(..., x0)``: ``x0`` (n,) the guess of the whole state, of which only the
    unmeasured block is used (default 0)."""

    def __init__(self, design, dt: float, schedule: Callable | None = None):
        syn = design.synthesis
        if getattr(syn, "gains", None) != "reduced":
            raise ObserverArgumentError("ReducedOrderObserver: the design must have "
                                        "gains='reduced'")
        super().__init__(design, dt, schedule)
        s = syn.full_system
        self.system, self.coords = s, syn.coordinates
        self.Lr = np.asarray(design.L[0], dtype=float)
        self.M = observer_matrices(self.coords, self.Lr)
        self.nz = s.n - s.p
        self.state_names = tuple(f"x{i + 1}" for i in range(s.n))
        self.input_names = tuple(f"u{i + 1}" for i in range(s.B.shape[2]))
        self.output_names = tuple(f"y{i + 1}" for i in range(s.p))

    def zdot(self, z, u, y, h) -> np.ndarray:
        """``sum h_i (F_i z + G_i y + J_i u)``."""
        F, G, J = (np.tensordot(h, self.M[k], axes=1) for k in ("F", "G", "J"))
        return F @ z + G @ y + J @ u

    def initial_state(self, t, u, y, x0=None) -> np.ndarray:
        s = self.system
        x0 = np.zeros(s.n) if x0 is None else np.asarray(x0, dtype=float)
        if x0.shape != (s.n,):
            raise ObserverArgumentError(f"ReducedOrderObserver: x0 must have {s.n} entries, "
                                        f"got shape {x0.shape}")
        y0 = np.asarray(y[0], dtype=float)
        x2 = (self.coords.T @ x0)[s.p:]
        return np.concatenate([x2 - self.Lr @ y0, y0])

    def step(self, w, k, t, u, y) -> np.ndarray:
        """One sample: ``z`` by RK4 with ``u_{k-1}``, ``h_{k-1}`` held and ``y`` linear from
        ``y_{k-1}`` to ``y_k`` (the recursion with ``y_{k-1}`` in discrete time), then ``y_k``
        stored for the estimate."""
        uk, yk = u[k - 1], y[k - 1]
        h = self.memberships(uk, yk)
        z = w[:self.nz]
        if self.system.discrete:
            zn = self.zdot(z, uk, yk, h)
        else:
            dt, y1 = self.dt, np.asarray(y[k], dtype=float)
            ym = 0.5 * (yk + y1)
            k1 = self.zdot(z, uk, yk, h)
            k2 = self.zdot(z + 0.5 * dt * k1, uk, ym, h)
            k3 = self.zdot(z + 0.5 * dt * k2, uk, ym, h)
            k4 = self.zdot(z + dt * k3, uk, y1, h)
            zn = z + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return np.concatenate([zn, np.asarray(y[k], dtype=float)])

    def estimate(self, w) -> np.ndarray:
        return self.M["Xy"] @ w[self.nz:] + self.M["Xz"] @ w[:self.nz]
