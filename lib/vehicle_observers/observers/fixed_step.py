"""Shared plumbing of the observers discretised at a fixed sample period.

The DMVT observer on sampled data (:mod:`.dmvt`), the sliding-mode observers
(:mod:`.sliding_mode`), the UIO (:mod:`.uio`) and Levant's differentiator
(:mod:`.differentiators`) are discrete-time systems designed for one sample period ``dt``
[s] (explicit Euler, RK4 with zero-order hold, or the Taylor-augmented Euler scheme): their
:meth:`~vehicle_observers.core.protocol.Observer.step` uses that ``dt`` and their compiled
``run`` accepts only a time grid with that step. :class:`FixedStepObserver` holds ``dt``,
checks the grid, lets observers without inputs take ``u=None`` and times the compiled
kernel (the first use in a process compiles it or loads it from numba's cache; that is done
before the timed call, so :attr:`~vehicle_observers.core.protocol.Trajectory.seconds` is the
loop alone).
"""

from __future__ import annotations

import time

import numba
import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import ObserverBase

#: largest relative deviation of a sampling interval from ``dt`` that a run accepts
DT_RTOL = 1e-6


def positive(who: str, name: str, value, allow_zero: bool = False) -> float:
    """``float(value)`` if finite and > 0 (>= 0 with ``allow_zero``), else
    :class:`ObserverArgumentError` naming ``name``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ObserverArgumentError(f"{who}: {name} must be a number, got {value!r}") from None
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise ObserverArgumentError(f"{who}: {name} must be {'>= 0' if allow_zero else '> 0'}"
                                    f" and finite, got {value}")
    return v


def positive_array(who: str, name: str, value, shape, allow_zero: bool = False) -> np.ndarray:
    """``value`` as a float array broadcast to ``shape``, every entry finite and > 0 (>= 0
    with ``allow_zero``), else :class:`ObserverArgumentError` naming ``name``."""
    try:
        a = np.broadcast_to(np.asarray(value, dtype=float), shape)
    except ValueError:
        raise ObserverArgumentError(f"{who}: {name} must have shape {shape} (or be a scalar), "
                                    f"got {np.shape(value)}") from None
    bad = ~np.isfinite(a) | (a < 0) | ((a == 0) & (not allow_zero))
    if bad.any():
        raise ObserverArgumentError(f"{who}: every entry of {name} must be "
                                    f"{'>= 0' if allow_zero else '> 0'} and finite, got "
                                    f"{np.asarray(value).tolist()}")
    return np.array(a)


def row_names(C, state_names) -> tuple[str, ...]:
    """Names of the measurements ``y = C x``: a row that reads one state alone (and the only
    row reading it) takes that state's name, any other row ``y<i>`` (1-based)."""
    C = np.atleast_2d(np.asarray(C, dtype=float))
    picks = [np.flatnonzero(row) for row in C]
    single = [int(p[0]) if len(p) == 1 and row[p[0]] == 1.0 else None
              for p, row in zip(picks, C, strict=True)]
    return tuple(state_names[j] if j is not None and single.count(j) == 1 else f"y{i + 1}"
                 for i, j in enumerate(single))


class FixedStepObserver(ObserverBase):
    """An observer discretised at the sample period ``dt`` [s] (see the module docstring).

    Subclasses set the names, define ``initial_state``, ``step``, ``estimate`` and ``run``
    and call :meth:`check_data` (grid with step ``dt``) and :meth:`timed` (compiled kernel).
    """

    def __init__(self, dt: float):
        self.dt = positive(type(self).__name__, "dt (sample period)", dt)

    def check_data(self, t, u, y, x0=None):
        """:func:`~vehicle_observers.core.protocol.check_data` plus: ``u=None`` for an observer
        without inputs, and every sampling interval equal to :attr:`dt` (relative
        :data:`DT_RTOL`); :class:`ObserverArgumentError` naming the argument otherwise."""
        if u is None:
            u = np.empty((np.size(t), 0))
        t, u, y, x0 = super().check_data(t, u, y, x0)
        d = np.diff(t)
        k = int(np.argmax(np.abs(d - self.dt)))
        if abs(d[k] - self.dt) > DT_RTOL * self.dt:
            raise ObserverArgumentError(
                f"{type(self).__name__}: t must be sampled every dt = {self.dt:.9g} s (the "
                f"observer's sample period); interval {k} is {d[k]:.9g} s")
        return t, u, y, x0

    @staticmethod
    def timed(kernel, *args):
        """``(seconds, kernel(*args))``: wall time of one call of the compiled ``kernel``; a
        kernel not yet compiled in this process is first compiled (or loaded from numba's
        on-disk cache) for the argument types, without running it, outside the timing."""
        if not getattr(kernel, "signatures", True):
            kernel.compile(tuple(numba.typeof(a) for a in args))
        t0 = time.perf_counter()
        out = kernel(*args)
        return time.perf_counter() - t0, out
