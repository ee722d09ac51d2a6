"""The observer contract: one result type, one argument order, one meaning of "step".

In the spirit of filterpy's shared filter interface (every filter has ``predict``,
``update``, ``batch_filter``) and python-control's estimator-as-system, every observer of
this library, and every observer a user writes, follows the same duck-typed protocol:

* a **design** (:class:`Design`) carries its LMI certificate
  (:class:`vehicle_observers.design.lmi.Certificate`) or ``None`` for gain-rule designs
  (sliding-mode gains, Kalman noise tables);
* an **observer** (:class:`Observer`) has a readable numpy :meth:`Observer.step` and a
  compiled :meth:`Observer.run` over sampled data, with one argument order
  ``(t, u, y, x0)``; :func:`run_readable` loops the step in plain Python, and the library's
  tests check it equal to the compiled ``run`` for every observer;
* every run returns one :class:`Trajectory` (time, estimate with schema names and units,
  optional lower/upper bounds, wall time, info).

The one meaning of ``step``: the observer is a discrete-time system on the sample grid. Its
internal state ``z`` (a 1-D float array: the estimate, plus whatever the observer carries,
e.g. the lower and upper bound of an interval observer or the covariance of a Kalman filter)
after sample ``k`` has been processed is ``z_k``; ``step(z_{k-1}, k, t, u, y)`` returns
``z_k`` and may read samples ``k - 1`` and ``k`` only (never a later one: observers are
causal). ``estimate(z)`` is the estimate ``x_k`` in ``state_names``; ``bounds(z)`` the
guaranteed interval or ``None``.

Shapes: ``t`` (N,) [s], strictly increasing; ``u`` (N, m) inputs in ``input_names``;
``y`` (N, p) measurements in ``output_names``; ``x0`` (n,) initial estimate or ``None`` (the
observer's documented default). Names follow the drive-log schema with units in the name
(``vy_mps``, ``yaw_rate_radps``, ``Ff_N``, ...; :mod:`vehicle_observers.data.logs`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError


def split_unit(name: str) -> tuple[str, str]:
    """``"vy_mps" -> ("vy", "mps")``: a schema name's quantity and its unit suffix (the text
    after the last underscore)."""
    base, _, unit = name.rpartition("_")
    return (base, unit) if base else (name, "")


def bound_name(name: str, side: str) -> str:
    """Column name of a bound: ``bound_name("vy_mps", "lo") == "vy_lo_mps"``."""
    base, unit = split_unit(name)
    return f"{base}_{side}_{unit}" if unit else f"{name}_{side}"


@dataclass(frozen=True, eq=False)
class Trajectory:
    """The one result type of every observer and estimator run.

    ``t`` (N,) [s]; ``x`` (N, n) estimate in SI units, column ``i`` named ``names[i]`` (log
    schema names with the unit in the name); ``lo``/``hi`` (N, n) guaranteed bounds of the
    interval observers (NaN in a column the observer does not bound) or ``None``;
    ``seconds``: wall time of the estimation loop (compiled kernels, compilation excluded);
    ``design_seconds``: LMI design or noise-tuning time (0 when none); ``causal``: False for
    smoothers; ``estimator``: the registry name or class name; ``info``: details of the run
    (design, tuning, certificate margin); ``flags``: name -> (N,) bool row flags (e.g.
    ``low_speed``, ``reinit`` of :mod:`vehicle_observers.estimation.segments`).
    """

    t: np.ndarray
    x: np.ndarray
    names: tuple[str, ...]
    lo: np.ndarray | None = None
    hi: np.ndarray | None = None
    seconds: float = float("nan")
    design_seconds: float = 0.0
    causal: bool = True
    estimator: str = ""
    info: dict = field(default_factory=dict)
    flags: dict = field(default_factory=dict)

    def __post_init__(self):
        t = np.asarray(self.t, float)
        x = np.asarray(self.x, float)
        if x.ndim == 1:
            x = x[:, None]
        names = tuple(self.names)
        if t.ndim != 1 or x.shape != (len(t), len(names)):
            raise ObserverArgumentError(
                f"Trajectory: t {t.shape} and x {x.shape} must be (N,) and (N, {len(names)}) "
                f"for names {names}")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "names", names)
        if (self.lo is None) != (self.hi is None):
            raise ObserverArgumentError("Trajectory: lo and hi come together")
        for side in ("lo", "hi"):
            b = getattr(self, side)
            if b is not None:
                b = np.asarray(b, float)
                if b.ndim == 1:
                    b = b[:, None]
                if b.shape != x.shape:
                    raise ObserverArgumentError(f"Trajectory: {side} {b.shape} != x {x.shape}")
                object.__setattr__(self, side, b)
        for k, v in self.flags.items():
            if np.shape(v) != t.shape:
                raise ObserverArgumentError(f"Trajectory: flag {k!r} {np.shape(v)} != t {t.shape}")

    # ----------------------------------------------------------------- access by name ----
    def __len__(self) -> int:
        return len(self.t)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"{self.estimator or 'trajectory'} has no {name!r}; it has "
                           f"{', '.join(self.names)}") from None

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def get(self, name: str, default=None):
        return self.columns.get(name, default)

    @property
    def columns(self) -> dict[str, np.ndarray]:
        """Name -> (N,) column: the estimate, then ``<quantity>_lo_<unit>`` /
        ``<quantity>_hi_<unit>`` for every bounded quantity (the output CSV's columns)."""
        out = {n: self.x[:, i] for i, n in enumerate(self.names)}
        if self.lo is not None:
            for i, n in enumerate(self.names):
                if np.isfinite(self.lo[:, i]).any() or np.isfinite(self.hi[:, i]).any():
                    out[bound_name(n, "lo")] = self.lo[:, i]
                    out[bound_name(n, "hi")] = self.hi[:, i]
        return out

    def table(self) -> dict[str, np.ndarray]:
        """``{"t_s": t, **columns, **flags}``: what the command line writes."""
        return {"t_s": self.t, **self.columns, **self.flags}

    @property
    def us_per_step(self) -> float:
        """Wall time per sample [us] of the estimation loop."""
        return 1e6 * self.seconds / max(len(self.t), 1)

    @property
    def interval(self) -> bool:
        return self.lo is not None

    @classmethod
    def from_columns(cls, t, columns: dict, *, seconds=float("nan"), design_seconds=0.0,
                     causal=True, estimator="", info=None) -> Trajectory:
        """Build from a name -> column dict in which bounds are named
        ``<quantity>_lo_<unit>`` / ``<quantity>_hi_<unit>`` (the inverse of
        :attr:`columns`); boolean columns become :attr:`flags`. Bound columns without an
        estimate column are an error."""
        flags = {n: np.asarray(v, bool) for n, v in columns.items()
                 if np.asarray(v).dtype == bool}
        columns = {n: v for n, v in columns.items() if n not in flags}
        names = [n for n in columns if not _is_bound(n, columns)]
        t = np.asarray(t, float)
        x = np.column_stack([np.asarray(columns[n], float) for n in names]) if names \
            else np.empty((len(t), 0))
        lo = hi = None
        bounded = [n for n in names if bound_name(n, "lo") in columns]
        if bounded:
            lo = np.full(x.shape, np.nan)
            hi = np.full(x.shape, np.nan)
            for n in bounded:
                i = names.index(n)
                lo[:, i] = columns[bound_name(n, "lo")]
                hi[:, i] = columns[bound_name(n, "hi")]
        used = set(names) | {bound_name(n, s) for n in bounded for s in ("lo", "hi")}
        orphans = sorted(set(columns) - used)
        if orphans:
            raise ObserverArgumentError(f"Trajectory.from_columns: bound columns {orphans} "
                                        "have no estimate column of the same quantity")
        return cls(t, x, tuple(names), lo, hi, float(seconds), float(design_seconds),
                   bool(causal), estimator, dict(info or {}), flags)


def _is_bound(name: str, columns: dict) -> bool:
    """``<quantity>_lo_<unit>`` / ``<quantity>_hi_<unit>`` (whether or not the estimate
    column exists: :meth:`Trajectory.from_columns` refuses an orphan bound)."""
    base, _ = split_unit(name)
    return base.endswith(("_lo", "_hi"))


@runtime_checkable
class Certificate(Protocol):
    """What an LMI certificate reports (:class:`vehicle_observers.design.lmi.Certificate`):
    the smallest eigenvalue margin of every constraint, rebuilt from the numeric solution
    independently of the solver."""

    min_margin: float


@runtime_checkable
class Design(Protocol):
    """A design: gains and whatever else the observer needs. ``certificate`` is the LMI
    certificate, or ``None`` for gain-rule designs."""

    certificate: Any


@runtime_checkable
class Observer(Protocol):
    """An observer on sampled data (see the module docstring for the one meaning of step)."""

    design: Any
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]

    def initial_state(self, t: np.ndarray, u: np.ndarray, y: np.ndarray,
                      x0: np.ndarray | None = None) -> np.ndarray:
        """Internal state ``z_0`` after sample 0."""

    def step(self, z: np.ndarray, k: int, t: np.ndarray, u: np.ndarray,
             y: np.ndarray) -> np.ndarray:
        """Readable numpy: ``z_k`` from ``z_{k-1}``, reading samples ``k - 1`` and ``k``."""

    def estimate(self, z: np.ndarray) -> np.ndarray:
        """The estimate (n,) in :attr:`state_names` held in ``z``."""

    def bounds(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Guaranteed ``(lo, hi)`` (n,) each, or ``None``."""

    def run(self, t: np.ndarray, u: np.ndarray, y: np.ndarray,
            x0: np.ndarray | None = None) -> Trajectory:
        """The compiled loop over the samples: the same numbers as :func:`run_readable`."""


class ObserverBase:
    """Shared plumbing for observers of this library: argument checks and the readable loop.

    Subclasses set ``design``, ``state_names``, ``input_names``, ``output_names`` and define
    ``initial_state``, ``step``, ``estimate`` (``bounds`` defaults to ``None``); ``run``
    defaults to the readable step looped in Python (:func:`run_readable`): a new observer
    works before it has a compiled loop, which then overrides ``run``.
    """

    design: Any = None
    state_names: tuple[str, ...] = ()
    input_names: tuple[str, ...] = ()
    output_names: tuple[str, ...] = ()

    def bounds(self, z):
        return None

    def run(self, t, u, y, x0=None) -> Trajectory:
        """The readable loop (:func:`run_readable`); override with a compiled one."""
        return run_readable(self, t, u, y, x0)

    def check_data(self, t, u, y, x0=None):
        """Validate and convert ``(t, u, y, x0)``; raise :class:`ObserverArgumentError`
        naming the argument. Returns contiguous float arrays (u, y 2-D)."""
        return check_data(t, u, y, x0, len(self.input_names), len(self.output_names),
                          len(self.state_names), type(self).__name__)

    def trajectory(self, t, X, lo=None, hi=None, seconds=float("nan"), **info) -> Trajectory:
        return Trajectory(t, X, self.state_names, lo, hi, seconds,
                          getattr(self, "design_seconds", 0.0), True, type(self).__name__,
                          info)


def check_data(t, u, y, x0, m: int, p: int, n: int, who: str = "observer"):
    """Argument checks shared by every ``run``: shapes, finiteness, increasing time, through
    the package's one input conversion (:mod:`vehicle_observers.core.inputs`: lists, pandas
    and polars accepted, ``datetime64`` time in seconds from the first sample)."""
    from vehicle_observers.core.inputs import as_array, as_time

    t = as_time(t, "t", who, min_len=2)
    out = [t]
    for arg, a, width in (("u", u, m), ("y", y, p)):
        a = as_array(a, arg, who, ndim=2, allow_nan=True)
        if a.shape != (len(t), width):
            raise ObserverArgumentError(f"{who}: {arg} must be (N, {width}) = ({len(t)}, "
                                        f"{width}), got {a.shape}")
        if not np.all(np.isfinite(a)):
            row, col = np.argwhere(~np.isfinite(a))[0]
            raise ObserverArgumentError(f"{who}: {arg} has a non-finite value at row {row}, "
                                        f"column {col}")
        out.append(a)
    if x0 is not None:
        x0 = as_array(x0, "x0", who, ndim=None, allow_nan=True).ravel()
        if x0.shape != (n,) or not np.all(np.isfinite(x0)):
            raise ObserverArgumentError(f"{who}: x0 must be {n} finite values, got {x0}")
    out.append(x0)
    return tuple(out)


def check_sample_period(t, dt: float, who: str = "observer", rtol: float = 1e-3):
    """For a fixed-step observer designed at one sample period ``dt`` [s]: raise
    :class:`ObserverArgumentError` naming ``t`` and the first bad step unless every step of
    ``t`` (N,) is within ``rtol`` (relative) of ``dt``."""
    d = np.diff(np.asarray(t, dtype=float))
    if len(d) and np.abs(d - dt).max() > rtol * dt:
        k = int(np.argmax(np.abs(d - dt)))
        raise ObserverArgumentError(f"{who}: t must be sampled every dt = {dt:.6g} s (fixed-step "
                                    f"observer); step {k} is {d[k]:.6g} s")


def run_readable(obs: Observer, t, u, y, x0=None) -> Trajectory:
    """The observer's readable numpy step looped in plain Python: the reference that every
    compiled :meth:`Observer.run` is tested equal to (slow; for tests and teaching)."""
    import time

    if hasattr(obs, "check_data"):
        t, u, y, x0 = obs.check_data(t, u, y, x0)
    t0 = time.perf_counter()
    z = np.asarray(obs.initial_state(t, u, y, x0), float)
    N, n = len(t), len(obs.state_names)
    X = np.empty((N, n))
    X[0] = obs.estimate(z)
    b = obs.bounds(z)
    lo = hi = None
    if b is not None:
        lo, hi = np.empty((N, n)), np.empty((N, n))
        lo[0], hi[0] = b
    for k in range(1, N):
        z = obs.step(z, k, t, u, y)
        X[k] = obs.estimate(z)
        if lo is not None:
            lo[k], hi[k] = obs.bounds(z)
    return Trajectory(t, X, tuple(obs.state_names), lo, hi, time.perf_counter() - t0,
                      0.0, True, type(obs).__name__ + " (readable)")
