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
  :func:`load_plugins` (the command line's ``--plugin``, the bench's, a campaign's). A
  reference is a module name or the path of a ``.py`` file (:func:`load_plugin`, the one
  loader of every entry point). Loading the module registers its estimators; an entry point
  may also name a callable, which is called once.

Columns: an estimator may read any log column named ``<quantity>_<unit>``
(:func:`vehicle_observers.data.logs.is_log_column`, e.g. ``ax_mps2``), declared in
``columns`` or, for :func:`register_observer`, in the observer's ``input_names`` /
``output_names``.

Options: keyword parameters with defaults of ``build(vehicle, dt, **options)`` (or of the
observer class) and of an :func:`estimator` function are its declared options
(:attr:`EstimatorSpec.options`); :meth:`EstimatorSpec.parse_options` types ``KEY=VALUE`` text
from their defaults and refuses an unknown key.

Errors: an exception raised inside a plug-in's code (any estimator registered from outside
this package) is re-raised by :meth:`EstimatorSpec.estimate` as
:class:`~vehicle_observers.core.errors.PluginError` naming the estimator and the file:line
of the plug-in's innermost frame (never as bad input).
"""

from __future__ import annotations

import hashlib
import importlib
import inspect
import json
import os
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from vehicle_observers.core.errors import LogFormatError, PluginError, RegistryError
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
#: keyword arguments the command line, the bench and campaigns pass to every run (never
#: options of an estimator)
RUNTIME_KEYWORDS = ("progress", "max_gap", "window_s", "cache", "tuning")
#: module prefixes of the library's own estimators (anything else is a plug-in)
BUILTIN_PREFIXES = ("vehicle_observers.", "vehicle_observers_papers.")


@dataclass(frozen=True)
class EstimatorSpec:
    """One registered estimator (the ``LogEstimator`` of the observer contract).

    ``run(log, vehicle, **opts) -> Trajectory``; ``columns``: required log columns beyond
    :data:`BASE_COLUMNS`; ``optional_columns``: used when present; ``vehicle_keys``:
    vehicle-file keys read (``uncertainty.<key>`` entries are checked by :meth:`check`);
    ``causal``: False for smoothers; ``interval``: gives guaranteed bounds; ``paper``:
    where the method comes from; ``origin``: the module that registered it; ``options``:
    declared options, name -> default (the default's type types a ``KEY=VALUE`` text);
    ``columns_declared``: False when the columns read are known only once the observer is
    built (a ``build`` function without ``columns=``): the command line then reads every
    ``<quantity>_<unit>`` column of the log.
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
    options: dict = field(default_factory=dict)
    columns_declared: bool = True

    @property
    def plugin(self) -> bool:
        """Registered from outside this package (its errors are the plug-in's)."""
        return not self.origin.startswith(BUILTIN_PREFIXES)

    @property
    def source_file(self) -> str | None:
        """The file of the registering module (``None`` if it has none)."""
        return module_file(self.origin)

    def parse_options(self, items) -> dict:
        """``["KEY=VALUE", ...]`` (or a dict) -> typed options: :func:`parse_option` per
        key; an unknown key or a malformed value raises :class:`RegistryError` (one line
        naming the estimator, the key and the declared options)."""
        pairs = items.items() if isinstance(items, dict) else [_split_item(i) for i in items]
        out = {}
        for k, v in pairs:
            if k not in self.options:
                have = ", ".join(f"{n}={d!r}" for n, d in self.options.items()) or "none"
                raise RegistryError(f"estimator {self.name!r} has no option {k!r} (its "
                                    f"options: {have})")
            out[k] = parse_option(self.name, k, v, self.options[k])
        return out

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
        try:
            out = self.run(log, vehicle, **opts)
        except (KeyboardInterrupt, GeneratorExit):
            raise
        except BaseException as exc:   # noqa: BLE001 - SystemExit of a plug-in included
            err = plugin_error(self, exc)
            if err is None:
                raise
            raise err from exc
        if not isinstance(out, Trajectory) or len(out) != len(log):
            raise (PluginError if self.plugin else RegistryError)(
                                f"estimator {self.name!r} ({self.origin}) returned "
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
    Keyword arguments are those of :class:`EstimatorSpec` (``columns``, ``causal``, ...);
    the function's keyword parameters with defaults (other than
    :data:`RUNTIME_KEYWORDS`) are its options unless ``options`` is given."""
    def deco(fn):
        kw.setdefault("options", declared_options(fn, skip=2))
        register(EstimatorSpec(name, description or (fn.__doc__ or name).strip().splitlines()[0],
                               fn, origin=fn.__module__, **kw))
        return fn
    return deco


def register_observer(name: str, build: Callable, description: str = "", *,
                      warm_up: bool = True, columns=None, options=None, **kw) -> EstimatorSpec:
    """Register an observer following :class:`vehicle_observers.core.protocol.Observer`.

    ``build(vehicle, dt, **options) -> Observer`` builds it for a vehicle file, the log's
    median sample period ``dt`` [s] and the chosen options (an observer class with that
    constructor works as ``build``). The observer's ``input_names`` and ``output_names`` are
    read from the log's columns: any name ``<quantity>_<unit>``
    (:func:`vehicle_observers.data.logs.is_log_column`: the schema's ``vx_mps``,
    ``ay_mps2``, ..., or another column of the log such as ``ax_mps2``); it runs on every
    stretch in motion, restarted after a gap, with the kinematic low-speed model elsewhere,
    like the built-in observers.

    ``columns``: the log columns read beyond :data:`BASE_COLUMNS` (default: the class
    attributes of ``build`` when it is a class, or of its return annotation; otherwise they
    are known once built, :attr:`EstimatorSpec.columns_declared` False). ``options``: name
    -> default (default: ``build``'s keyword parameters with defaults after
    ``(vehicle, dt)``).
    """
    from vehicle_observers.data.logs import is_log_column

    declared = True
    if columns is None:
        names = _class_columns(build)
        declared = names is not None
        columns = tuple(c for c in (names or ()) if c not in BASE_COLUMNS)
    for c in columns:
        if not is_log_column(c):
            raise RegistryError(_not_a_column(name, c))
    if options is None:
        options = declared_options(build, skip=2)

    def run(log: DriveLog, vehicle: Vehicle, max_gap=segments.MAX_GAP_S, progress=None, **opts):
        t0 = time.perf_counter()
        obs = build(vehicle, log.dt, **{k: v for k, v in opts.items() if k in options})
        design_sec = time.perf_counter() - t0
        names = tuple(obs.input_names) + tuple(obs.output_names)
        for c in names:
            if not is_log_column(c):
                raise RegistryError(_not_a_column(name, c))
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

    run.build = build          # where its numbers come from (output_source)

    spec = EstimatorSpec(name, description or name, run, columns=tuple(columns),
                         origin=getattr(build, "__module__", ""), options=dict(options),
                         columns_declared=declared, **kw)
    return register(spec)


def _not_a_column(name, c) -> str:
    from vehicle_observers.data.logs import UNIT_RANGES

    return (f"observer {name!r} reads {c!r}, not a log column name: expected "
            f"<quantity>_<unit> with a unit of {', '.join(UNIT_RANGES)} (e.g. ax_mps2)")


def _class_columns(build) -> tuple | None:
    """``input_names + output_names`` of ``build`` when it is an observer class or annotates
    one as its return type; ``None`` when unknown before building."""
    cls = build if isinstance(build, type) else None
    if cls is None:
        try:
            import typing

            cls = typing.get_type_hints(build).get("return")
        except Exception:   # noqa: BLE001 - an unresolvable annotation: unknown
            cls = None
    if not isinstance(cls, type):
        return None
    names = tuple(getattr(cls, "input_names", ())) + tuple(getattr(cls, "output_names", ()))
    return names if names else None


def declared_options(fn, skip: int) -> dict:
    """Keyword parameters with defaults of ``fn`` after its first ``skip`` positional ones
    (an observer class: its constructor), other than :data:`RUNTIME_KEYWORDS`."""
    try:
        params = list(inspect.signature(fn).parameters.values())
    except (TypeError, ValueError):
        return {}
    out = {}
    for i, p in enumerate(params):
        if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) or (i < skip and p.kind != p.KEYWORD_ONLY):
            continue
        if p.default is not p.empty and p.name not in RUNTIME_KEYWORDS:
            out[p.name] = p.default
    return out


def _split_item(item: str) -> tuple[str, str]:
    k, eq, v = str(item).partition("=")
    if not eq or not k.strip():
        raise RegistryError(f"option {item!r}: expected KEY=VALUE")
    return k.strip(), v.strip()


_TRUE, _FALSE = ("1", "true", "yes", "on"), ("0", "false", "no", "off")


def parse_option(est: str, key: str, value, default):
    """``value`` (text from the command line, or a TOML value) as the type of ``default``:
    bool (true/false/yes/no/1/0), int, float, str, a tuple or list of numbers (``1,2`` or
    ``[1, 2]``); ``None`` default: JSON, else the text. Raises :class:`RegistryError`."""
    def bad(what):
        return RegistryError(f"estimator {est!r}: option {key}={value!r}: expected {what} "
                             f"(default {default!r})")

    if not isinstance(value, str):        # from a TOML file: already typed
        if isinstance(default, bool) and not isinstance(value, bool):
            raise bad("true or false")
        if isinstance(default, (int, float)) and not isinstance(default, bool):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise bad("a number")
            if isinstance(default, int) and int(value) != value:
                raise bad("an integer")
            return type(default)(value)
        if isinstance(default, (tuple, list)):
            if not isinstance(value, list) or not all(
                    isinstance(x, (int, float)) and not isinstance(x, bool) for x in value):
                raise bad("a list of numbers")
            return type(default)(float(x) for x in value)
        return value
    v = value.strip()
    if isinstance(default, bool):
        if v.lower() in _TRUE:
            return True
        if v.lower() in _FALSE:
            return False
        raise bad("true or false")
    if isinstance(default, int):
        try:
            return int(v)
        except ValueError:
            raise bad("an integer") from None
    if isinstance(default, float):
        try:
            x = float(v)
        except ValueError:
            raise bad("a number") from None
        if not np.isfinite(x):
            raise bad("a finite number")
        return x
    if isinstance(default, (tuple, list)):
        try:
            xs = [float(x) for x in v.strip("[]()").split(",") if x.strip()]
        except ValueError:
            raise bad("numbers separated by commas") from None
        return type(default)(xs)
    if isinstance(default, str):
        return v
    try:
        return json.loads(v)
    except ValueError:
        return v


# ------------------------------------------------------------------ plug-in code ----------
def module_file(module: str) -> str | None:
    """The source file of an imported module (``None`` when it has none)."""
    m = sys.modules.get(module)
    f = getattr(m, "__file__", None)
    return str(Path(f).resolve()) if f else None


def plugin_files() -> set[str]:
    """Source files of every plug-in module loaded (:func:`load_plugin`) and of every module
    that registered an estimator from outside this package."""
    out = set(_PLUGIN_FILES.values())
    for s in _REGISTRY.values():
        if s.plugin and s.source_file:
            out.add(s.source_file)
    return out


def _innermost(exc: BaseException, files: set[str]) -> str:
    """``"file:line (in func)"`` of the innermost traceback frame of ``exc`` in ``files``."""
    where = ""
    for fr in traceback.extract_tb(exc.__traceback__):
        try:
            f = str(Path(fr.filename).resolve())
        except (OSError, ValueError):
            continue
        if f in files:
            where = f"{fr.filename}:{fr.lineno} (in {fr.name})"
    return where


def plugin_error(spec: EstimatorSpec, exc: BaseException) -> PluginError | None:
    """The :class:`PluginError` for ``exc`` raised while running ``spec``, or ``None`` when
    it is not the plug-in's: a built-in estimator, or an input error (bad log or vehicle
    file) raised by the library's own checks outside the plug-in's frames."""
    if not spec.plugin:
        return None
    from vehicle_observers.models.vehicle import VehicleFileError

    files = plugin_files()
    if spec.source_file:
        files.add(spec.source_file)
    where = _innermost(exc, files)
    if isinstance(exc, (LogFormatError, VehicleFileError)) and not where:
        return None
    if not where:      # raised in library code the plug-in called: name both
        tb = traceback.extract_tb(exc.__traceback__)
        inner = f", raised in {tb[-1].filename}:{tb[-1].lineno} ({tb[-1].name})" if tb else ""
        at = f"{spec.source_file or 'module ' + spec.origin}{inner}"
    else:
        at = where
    msg = str(exc).splitlines()[0] if str(exc) else ""
    return PluginError(f"plug-in estimator {spec.name!r} raised {type(exc).__name__} at {at}"
                       + (f": {msg}" if msg else ""), spec.name, where)


def output_source(spec: EstimatorSpec) -> str:
    """``"path/to/file.py:LINE (in NAME)"`` of the plug-in code that computes the estimates
    of ``spec``: the ``step`` of an observer registered by :func:`register_observer` (else its
    ``build``), or the function registered by :func:`estimator`; ``""`` when it has no
    source file (a built-in or compiled callable)."""
    import inspect

    fn = getattr(spec.run, "build", spec.run)
    fn = getattr(fn, "step", fn) if inspect.isclass(fn) else fn
    fn = inspect.unwrap(fn)
    code = getattr(fn, "__code__", None)
    if code is None:
        return ""
    return f"{code.co_filename}:{code.co_firstlineno} (in {getattr(fn, '__qualname__', fn)})"


def source_sha256(module: str) -> str | None:
    """SHA-256 of the source file of ``module`` (``None`` when it has no file)."""
    f = module_file(module)
    if f is None:
        return None
    try:
        return hashlib.sha256(Path(f).read_bytes()).hexdigest()
    except OSError:
        return None


#: plug-in reference (module name or .py path as given) -> its source file
_PLUGIN_FILES: dict[str, str] = {}


def load_plugin(ref: str) -> str:
    """Import one plug-in: a module name on ``sys.path`` (``my_pkg.observers``) or the path
    of a ``.py`` file (its folder is put first on ``sys.path`` and it is imported under its
    stem, so that Dask workers and pickles find it by the same name). The one loader of the
    command line, the bench and campaigns. Returns the module name. A missing file is a
    :class:`RegistryError`; an exception raised while importing the module (including
    ``SystemExit``) a :class:`PluginError` naming it and its file:line."""
    ref = str(ref).strip()
    if ref.endswith(".py"):
        from vehicle_observers.data.logs import special_file

        kind = special_file(ref)
        if kind is not None:
            raise RegistryError(f"plug-in {ref}: is {kind}, expected a .py file")
        f = Path(ref).resolve()
        if not f.is_file():
            raise RegistryError(f"plug-in {ref}: no such file")
        if str(f.parent) not in sys.path:
            sys.path.insert(0, str(f.parent))
        mod = f.stem
        loaded = sys.modules.get(mod)
        if loaded is not None and module_file(mod) != str(f):
            raise RegistryError(f"plug-in {ref}: a module named {mod!r} is already imported "
                                f"from {module_file(mod)}; rename the file")
    else:
        mod = ref
    if ref in _PLUGINS_LOADED:
        return mod
    try:
        importlib.import_module(mod)
    except (KeyboardInterrupt, GeneratorExit):
        raise
    except ModuleNotFoundError as e:
        if e.name and (mod == e.name or mod.startswith(e.name + ".")):
            raise RegistryError(f"plug-in module {mod!r} not found (a module name on "
                                "sys.path, or the path of a .py file)") from None
        raise _import_error(ref, mod, e) from e
    except BaseException as e:   # noqa: BLE001 - SystemExit while importing included
        raise _import_error(ref, mod, e) from e
    f = module_file(mod)
    if f:
        _PLUGIN_FILES[ref] = f
    _PLUGINS_LOADED.add(ref)
    return mod


def _import_error(ref, mod, e) -> PluginError:
    f = module_file(mod) or (str(Path(ref).resolve()) if ref.endswith(".py") else None)
    files = {f} if f else set()
    where = _innermost(e, files) if files else ""
    if not where:      # the innermost frame of the traceback
        tb = traceback.extract_tb(e.__traceback__)
        where = f"{tb[-1].filename}:{tb[-1].lineno} (in {tb[-1].name})" if tb else ""
    msg = str(e).splitlines()[0] if str(e) else ""
    return PluginError(f"plug-in module {mod!r} failed to import: {type(e).__name__} at "
                       f"{where}" + (f": {msg}" if msg else ""), mod, where)


def load_plugins(modules=()) -> list[str]:
    """Import plug-ins (:func:`load_plugin`): ``modules``, ``$VEHICLE_OBSERVERS_PLUGINS``
    and the entry points of :data:`ENTRY_POINT_GROUP`. A plug-in that fails to import is an
    error naming it (never skipped silently). Returns the references loaded now."""
    from importlib.metadata import entry_points

    names = [m.strip() for m in os.environ.get(PLUGIN_ENV, "").split(",") if m.strip()]
    names += [str(m) for m in modules]
    loaded = []
    for m in names:
        if m in _PLUGINS_LOADED:
            continue
        load_plugin(m)
        loaded.append(m)
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        key = f"ep:{ep.name}={ep.value}"
        if key in _PLUGINS_LOADED:
            continue
        try:
            obj = ep.load()
        except Exception as e:   # noqa: BLE001
            raise PluginError(f"plug-in entry point {ep.name!r} ({ep.value}) failed to load: "
                              f"{type(e).__name__}: {e}", ep.name) from e
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

