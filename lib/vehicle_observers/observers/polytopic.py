"""The observer of a design of :mod:`vehicle_observers.design.synthesis`, on sampled data.

For a polytopic / TS system with memberships ``h(k)`` (q,) known at every sample (measured
scheduling variables), the observer

    xhat' = sum_i h_i (A_i xhat + B_i u) + L(h) (y - sum_i h_i C_i xhat)

with ``L(h) = L`` (common gain), ``sum_i h_i L_i`` (PDC) is integrated by classical RK4 over
each sample interval with ``u``, ``y`` and ``h`` held (zero-order hold); in discrete time it is
the recursion ``xhat_k = A(h) xhat_{k-1} + B(h) u_{k-1} + L(h) (y_{k-1} - C(h) xhat_{k-1})``.
The observer contract of :mod:`vehicle_observers.core.protocol` (readable ``step``; ``run``
loops it). ``schedule(u_k (m,), y_k (p,)) -> h (q,)`` gives the memberships.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import run_readable
from vehicle_observers.observers.fixed_step import FixedStepObserver


class PolytopicObserver(FixedStepObserver):
    """Observer of an :class:`~vehicle_observers.design.synthesis.ObserverDesign`.

    ``design``: the certified design (its system, gains ``L`` (r, n, p)); ``dt`` [s] sample
    period (the system's own for a discrete-time design); ``schedule``: memberships from the
    data (default: the single vertex, or equal weights). Gains structured ``"pairs"`` are
    blended with the same memberships. Names ``x1..xn``, ``u1..um``, ``y1..yp``.
    """

    def __init__(self, design, dt: float, schedule: Callable | None = None):
        super().__init__(dt)
        s = design.synthesis.system
        if s.discrete and abs(dt - s.dt) > 1e-12 * s.dt:
            raise ObserverArgumentError(f"PolytopicObserver: a discrete-time design runs at its "
                                        f"own dt = {s.dt:g} s, got {dt:g}")
        self.design, self.system, self.L = design, s, np.asarray(design.L, dtype=float)
        self.schedule = schedule
        self.state_names = tuple(f"x{i + 1}" for i in range(s.n))
        self.input_names = tuple(f"u{i + 1}" for i in range(s.B.shape[2]))
        self.output_names = tuple(f"y{i + 1}" for i in range(s.p))

    def memberships(self, u, y) -> np.ndarray:
        q = self.system.q
        if self.schedule is None:
            return np.full(q, 1.0 / q)
        h = np.asarray(self.schedule(u, y), dtype=float)
        if h.shape != (q,) or not np.all(np.isfinite(h)):
            raise ObserverArgumentError(f"PolytopicObserver: schedule must return {q} finite "
                                        f"memberships, got {h!r}")
        return h

    def rhs(self, xh, u, y, h) -> np.ndarray:
        """``sum h_i (A_i xh + B_i u) + L(h) (y - C(h) xh)`` (``xh`` (n,), ``u`` (m,))."""
        s = self.system
        A, B, C = (np.tensordot(h, M, axes=1) for M in (s.A, s.B, s.C))
        L = self.L[0] if len(self.L) == 1 else np.tensordot(h[:len(self.L)], self.L, axes=1)
        return A @ xh + B @ u + L @ (y - C @ xh)

    def initial_state(self, t, u, y, x0=None) -> np.ndarray:
        return np.zeros(self.system.n) if x0 is None else np.array(x0, dtype=float)

    def step(self, z, k, t, u, y) -> np.ndarray:
        """One sample: RK4 of :meth:`rhs` with ``u_{k-1}``, ``y_{k-1}``, ``h_{k-1}`` held (the
        recursion itself in discrete time)."""
        uk, yk = u[k - 1], y[k - 1]
        h = self.memberships(uk, yk)
        if self.system.discrete:
            return self.rhs(z, uk, yk, h)
        dt = self.dt
        k1 = self.rhs(z, uk, yk, h)
        k2 = self.rhs(z + 0.5 * dt * k1, uk, yk, h)
        k3 = self.rhs(z + 0.5 * dt * k2, uk, yk, h)
        k4 = self.rhs(z + dt * k3, uk, yk, h)
        return z + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    def estimate(self, z) -> np.ndarray:
        return np.asarray(z, dtype=float)

    def run(self, t, u, y, x0=None):
        """The readable step looped (:func:`~vehicle_observers.core.protocol.run_readable`)."""
        if u is None:
            u = np.empty((np.size(t), 0))
        return run_readable(self, t, u, y, x0)
