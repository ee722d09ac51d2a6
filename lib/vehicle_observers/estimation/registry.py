"""The estimator registry: every estimator the command line, the benchmark and campaigns know.

An :class:`EstimatorSpec` says what an estimator needs (log columns, vehicle-file keys),
whether it is causal and whether it gives intervals, and has ``run(log, vehicle, **opts)``
returning a :class:`~vehicle_observers.core.protocol.Trajectory` (names with units, the same
names as the log schema: ``vy_mps``, ``yaw_rate_radps``, ``Ff_N``, ``Fr_N``, ``beta_rad``;
interval observers carry ``lo``/``hi``), with the row flags ``low_speed`` and ``reinit`` of
:mod:`vehicle_observers.estimation.segments`.

Three ways in, none of which edits this repository:

* :func:`estimator` - a decorator on a function ``run(log, vehicle, **opts) -> Trajectory``;
* :func:`register_observer` - an observer following the protocol of
  :mod:`vehicle_observers.core.protocol` (``build(vehicle, dt) -> Observer``), run on the
  log's stretches in motion with the same low-speed and gap handling as the built-in ones;
* plug-ins loaded by :func:`available`: every entry point of the group
  ``vehicle_observers.estimators`` (a user's ``pyproject.toml``:
  ``[project.entry-points."vehicle_observers.estimators"] my = "my_pkg.observers"``) and
  every module named in ``$VEHICLE_OBSERVERS_PLUGINS`` (comma-separated) or passed to
  :func:`load_plugins` (the command line's ``--plugin``). Loading the module registers its
  estimators; an entry point may also name a callable, which is called once.
"""

from __future__ import annotations

import importlib
import os
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from vehicle_observers.core.errors import RegistryError
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.estimation import segments
from vehicle_observers.models.vehicle import Vehicle

#: columns every estimator reads (the log schema's required ones)
BASE_COLUMNS = ("t_s", "vx_mps", "delta_roadwheel_rad", "yaw_rate_radps")
#: vehicle-file keys of the single-track model every built-in estimator reads
VEHICLE_KEYS = ("m", "I_z", "a_f", "a_r", "tire_front", "tire_rear")
#: entry-point group of plug-in estimators
ENTRY_POINT_GROUP = "vehicle_observers.estimators"
#: environment variable naming plug-in modules (comma-separated)
PLUGIN_ENV = "VEHICLE_OBSERVERS_PLUGINS"


@dataclass(frozen=True)
class EstimatorSpec:
    """One registered estimator (the ``LogEstimator`` of the observer contract).

    ``run(log, vehicle, **opts) -> Trajectory``; ``columns``: required log columns beyond
    :data:`BASE_COLUMNS`; ``optional_columns``: used when present; ``vehicle_keys``:
    vehicle-file keys read (``uncertainty.<key>`` entries are checked by :meth:`check`);
    ``causal``: False for smoothers; ``interval``: gives guaranteed bounds; ``paper``:
    where the method comes from; ``origin``: the module that registered it.
    """

    name: str
    description: str
    run: Callable[..., Trajectory]
    columns: tuple = ()
    optional_columns: tuple = ()
    vehicle_keys: tuple = VEHICLE_KEYS
    causal: bool = True
    interval: bool = False
    paper: str = ""
    origin: str = ""

    @property
    def needs(self) -> tuple[str, ...]:
        return BASE_COLUMNS + tuple(self.columns)

    def check(self, log: DriveLog, vehicle: Vehicle | None = None):
        """Raise (LogFormatError / VehicleFileError) naming what is missing."""
        log.require(*BASE_COLUMNS, *self.columns, purpose=f"observer {self.name!r}")
        for k in self.vehicle_keys:
            if k.startswith("uncertainty.") and vehicle is not None:
                vehicle.need_uncertainty(k.split(".", 1)[1], purpose=f"observer {self.name!r}")

    def estimate(self, log: DriveLog, vehicle: Vehicle, **opts) -> Trajectory:
        """:meth:`check`, then ``run``; the result must be a :class:`Trajectory` of the
        log's length (a plug-in returning anything else is named in the error). ``log``: a
        :class:`DriveLog` (checked again: strictly increasing time, finite channels) or a
        pandas / polars DataFrame of schema columns
        (:func:`vehicle_observers.data.logs.as_log`)."""
        from vehicle_observers.data.logs import as_log

        log = as_log(log, f"observer {self.name!r}: log")
        self.check(log, vehicle)
        out = self.run(log, vehicle, **opts)
        if not isinstance(out, Trajectory) or len(out) != len(log):
            raise RegistryError(f"estimator {self.name!r} ({self.origin}) returned "
                                f"{type(out).__name__} of length "
                                f"{len(out) if hasattr(out, '__len__') else '?'}; expected a "
                                f"Trajectory of {len(log)} rows")
        return out


_REGISTRY: dict[str, EstimatorSpec] = {}
_PLUGINS_LOADED: set[str] = set()


def register(spec: EstimatorSpec, replace: bool = False) -> EstimatorSpec:
    """Add ``spec``; a second estimator of the same name from another module is an error
    unless ``replace`` (re-importing the same module re-registers silently)."""
    if not spec.name or any(c.isspace() for c in spec.name):
        raise RegistryError(f"estimator name {spec.name!r}: a non-empty word without spaces")
    old = _REGISTRY.get(spec.name)
    if old is not None and not replace and old.origin != spec.origin:
        raise RegistryError(f"estimator {spec.name!r} is registered twice ({old.origin} and "
                            f"{spec.origin}); pass replace=True to override")
    _REGISTRY[spec.name] = spec
    return spec


def estimator(name: str, description: str = "", **kw):
    """Decorator: register ``run(log, vehicle, **opts) -> Trajectory`` under ``name``.
    Keyword arguments are those of :class:`EstimatorSpec` (``columns``, ``causal``, ...)."""
    def deco(fn):
        register(EstimatorSpec(name, description or (fn.__doc__ or name).strip().splitlines()[0],
                               fn, origin=fn.__module__, **kw))
        return fn
    return deco


def register_observer(name: str, build: Callable, description: str = "", *,
                      warm_up: bool = True, **kw) -> EstimatorSpec:
    """Register an observer following :class:`vehicle_observers.core.protocol.Observer`.

    ``build(vehicle, dt) -> Observer`` builds it for a vehicle file and the log's median
    sample period ``dt`` [s]. The observer's ``input_names`` and ``output_names`` are read
    from the log's columns (schema names, e.g. ``vx_mps``, ``delta_roadwheel_rad``,
    ``yaw_rate_radps``, ``ay_mps2``); it runs on every stretch in motion, restarted after a
    gap, with the kinematic low-speed model elsewhere, like the built-in observers.
    """
    from vehicle_observers.data.logs import OPTIONAL, REQUIRED

    known = set(REQUIRED) | set(OPTIONAL)

    def run(log: DriveLog, vehicle: Vehicle, max_gap=segments.MAX_GAP_S, progress=None, **_):
        t0 = time.perf_counter()
        obs = build(vehicle, log.dt)
        design_sec = time.perf_counter() - t0
        names = tuple(obs.input_names) + tuple(obs.output_names)
        bad = [c for c in names if c not in known]
        if bad:
            raise RegistryError(f"observer {name!r} reads {bad}, not drive-log columns "
                                f"({', '.join(sorted(known))})")
        log.require(*names, purpose=f"observer {name!r}")
        info = {"design": obs.design}

        def one(sub, a):
            cols = sub.columns()
            u = np.column_stack([cols[c] for c in obs.input_names])
            y = np.column_stack([cols[c] for c in obs.output_names])
            tr = obs.run(sub.t, u, y)
            return tr.columns, tr.seconds

        one.columns = tuple(obs.state_names)
        cols, sec, n = segments.run_stretches(one, log, vehicle, segments.moving_rows(log),
                                              max_gap, progress, warm_up=warm_up)
        info["stretches"] = n
        return Trajectory.from_columns(log.t, cols, seconds=sec, design_seconds=design_sec,
                                       causal=True, estimator=name, info=info)

    spec = EstimatorSpec(name, description or name, run, origin=getattr(build, "__module__", ""),
                         **kw)
    return register(spec)


def load_plugins(modules=()) -> list[str]:
    """Import plug-in modules: ``modules``, ``$VEHICLE_OBSERVERS_PLUGINS`` and the entry
    points of :data:`ENTRY_POINT_GROUP`. A plug-in that fails to import is an error naming
    it (never skipped silently). Returns the names loaded now."""
    from importlib.metadata import entry_points

    names = [m.strip() for m in os.environ.get(PLUGIN_ENV, "").split(",") if m.strip()]
    names += list(modules)
    loaded = []
    for m in names:
        if m in _PLUGINS_LOADED:
            continue
        try:
            importlib.import_module(m)
        except Exception as e:   # noqa: BLE001 - any import failure is reported the same way
            raise RegistryError(f"plug-in module {m!r} failed to import: "
                                f"{type(e).__name__}: {e}") from e
        _PLUGINS_LOADED.add(m)
        loaded.append(m)
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        key = f"ep:{ep.name}={ep.value}"
        if key in _PLUGINS_LOADED:
            continue
        try:
            obj = ep.load()
        except Exception as e:   # noqa: BLE001
            raise RegistryError(f"plug-in entry point {ep.name!r} ({ep.value}) failed to load: "
                                f"{type(e).__name__}: {e}") from e
        if callable(obj) and not isinstance(obj, type):
            obj()
        _PLUGINS_LOADED.add(key)
        loaded.append(ep.value)
    return loaded


def available(plugins=()) -> dict[str, EstimatorSpec]:
    """Registered estimators in registration order, after loading the plug-ins
    (:func:`load_plugins`)."""
    load_plugins(plugins)
    return dict(_REGISTRY)


def get(name: str) -> EstimatorSpec:
    obs = available()
    if name not in obs:
        raise RegistryError(f"unknown observer {name!r}; available: {', '.join(obs)}")
    return obs[name]


def unregister(name: str):
    """Remove ``name`` (tests and interactive sessions)."""
    _REGISTRY.pop(name, None)

