"""What a worker runs: batches of simulations, each scored; failures recorded, never fatal.

:func:`run_batch` rebuilds the :class:`~vehicle_observers.campaign.spec.Spec` from its
document (once per process), decodes its tasks, and for each: the noisy log
(:func:`~vehicle_observers.campaign.truths.make_log`, draws from the log's key), the
observer's vehicle file, the registry estimator's run, and the scores over ``t - t_0 >
settle_s`` (:func:`vehicle_observers.estimation.scoring.score`). A task that raises (an
infeasible LMI design, a filter that diverges: a non-finite estimate is an error) gives a row
with ``ok = False`` and its error message; the other tasks go on.

Rows hold no wall-clock time, so a task's row is the same wherever it ran (the engine's
determinism tests compare them bit for bit).

Warnings are not silenced: those raised while a task builds its log, runs its estimator and
scores it are recorded in its row (:func:`recorded_warnings`: ``warnings``, their number, and
``warning_kinds``, per category the count and the first message), every occurrence counted
(filter "always", so the count does not depend on which tasks ran before in the process).
The truth's simulation is shared by many tasks and done once per process, so its warnings
cannot be given to one task the same way on both engines: they are ignored (a truth that
fails is recorded as the error of every task that needs it).

For estimators that report a standard deviation of ``v_y`` (``vy_std_mps``) the row also
holds its 2-sigma coverage (``coverage_vy``) and mean NEES (``nees_vy``) over the scored
samples (:func:`vehicle_observers.core.metrics.coverage_2sigma`, :func:`~vehicle_observers.
core.metrics.mean_nees`); NaN for the others.

A truth that cannot be simulated is a failure of every task that needs it, with the same row
on both engines (:class:`TruthFailure` travels to the batches in place of the truth). With
the spec's ``timeout_s`` a task that runs longer is stopped and recorded as failed
(``error_type = "TaskTimeout"``; :func:`deadline`), and the campaign goes on; such a row
depends on the machine's speed, unlike every other.
"""

from __future__ import annotations

import contextlib
import json
import os
import warnings
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from vehicle_observers.campaign import spec as S
from vehicle_observers.campaign import truths as T

#: thread counts pinned to 1 in every worker process (set before the libraries start
#: their thread pools: BLAS/OpenMP, Rayon (Clarabel), numba)
THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              "VECLIB_MAXIMUM_THREADS": "1", "NUMEXPR_NUM_THREADS": "1",
              "RAYON_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
#: metric columns of a result row (NaN where an estimator or a log has no such quantity)
METRICS = ("rmse_vy", "max_vy", "rmse_beta", "max_beta", "rmse_r", "max_r", "rmse_Ff",
           "rmse_Fr", "enclosure_vy", "width_vy", "enclosure_r", "width_r", "coverage_vy",
           "nees_vy")
#: longest error message kept [characters]
MAX_MESSAGE = 300


def result_schema():
    """The pyarrow schema of the result rows (every batch file has exactly this one)."""
    import pyarrow as pa

    fields = [("task", pa.int64()), ("batch", pa.int64()), ("estimator", pa.string()),
              ("options", pa.string()),
              ("plant", pa.string()), ("car", pa.string()), ("manoeuvre", pa.string()),
              ("variant", pa.int64()),
              *((f"err_{k}", pa.float64()) for k in S.ERROR_KEYS),
              ("box_rel", pa.float64()), ("box_vx_min", pa.float64()),
              ("box_vx_max", pa.float64()), ("rate_hz", pa.float64()),
              ("noise_scale", pa.float64()), ("bias", pa.int64()),
              *((f"bias_{c}", pa.float64()) for c in S.CHANNELS),
              ("rep", pa.int64()), ("samples", pa.int64()),
              *((m, pa.float64()) for m in METRICS),
              ("truth_cf_min", pa.float64()), ("truth_cf_max", pa.float64()),
              ("truth_cr_min", pa.float64()), ("truth_cr_max", pa.float64()),
              ("in_box", pa.bool_()), ("guarantee", pa.bool_()),
              ("ok", pa.bool_()), ("error_type", pa.string()), ("error", pa.string()),
              ("warnings", pa.int64()), ("warning_kinds", pa.string())]
    return pa.schema(fields)


@lru_cache(maxsize=8)
def _spec(raw_json: str) -> S.Spec:
    return S.Spec(json.loads(raw_json), "spec")


def spec_of(raw: dict) -> S.Spec:
    """The :class:`Spec` of a document, built once per process."""
    return _spec(json.dumps(raw, sort_keys=True))


_TRUTHS: dict = {}


@dataclass(frozen=True)
class TruthFailure:
    """A truth that could not be simulated: the error of every task that needs it."""

    key: tuple
    error_type: str
    error: str


class TruthFailed(Exception):
    """Raised in a task whose truth failed; its row keeps the original error type."""

    def __init__(self, failure: TruthFailure):
        super().__init__(failure.error)
        self.type_name = failure.error_type


class TaskTimeout(Exception):
    """A task ran longer than the spec's ``timeout_s``."""


def _truth_or_failure(plant, car, man, rate):
    key = S.truth_key(plant, car, man, rate)
    try:
        return T.simulate_truth(plant, car, man, rate)
    except Exception as exc:  # noqa: BLE001 - recorded in the rows of its tasks
        msg = str(exc).splitlines()[0] if str(exc) else ""
        return TruthFailure(key, type(exc).__name__, msg[:MAX_MESSAGE])


def truth(plant, car, man, rate) -> T.Truth:
    """Truth of ``(plant, car, manoeuvre, rate)``, simulated once per process (a failure
    too: raises :class:`TruthFailed`)."""
    key = S.truth_key(plant, car, man, rate)
    if key not in _TRUTHS:
        _TRUTHS[key] = _truth_or_failure(plant, car, man, rate)
    tr = _TRUTHS[key]
    if isinstance(tr, TruthFailure):
        raise TruthFailed(tr)
    return tr


def truths_of_batch(spec: S.Spec, start: int, stop: int) -> list[tuple]:
    """Distinct ``(plant, car, manoeuvre, rate)`` the tasks ``start..stop-1`` need: one task
    decoded per block of tasks that share a manoeuvre (noise, bias and repetition do not
    change the truth), not every task."""
    out = {}
    inner = len(spec.noises) * len(spec.biases) * spec.repetitions
    i = start
    while i < stop:
        tk = spec.task(i)
        out.setdefault(tk.truth_key, (tk.plant, tk.car, tk.manoeuvre, tk.rate))
        i = (i // inner + 1) * inner
    return list(out.values())


def make_truth(args: tuple):
    """Dask task: the truth of ``args = (plant, car, manoeuvre, rate)``, or its
    :class:`TruthFailure` (never raises: the tasks that need it record the failure, as the
    serial engine does)."""
    return _truth_or_failure(*args)


@contextlib.contextmanager
def deadline(seconds):
    """Raise :class:`TaskTimeout` in this thread after ``seconds`` (``None``: no limit).
    In the main thread through ``SIGALRM`` (interrupts a sleep too); in another thread (a
    Dask worker's) through ``PyThreadState_SetAsyncExc``, raised at the next Python
    bytecode (a task blocked inside one C call is stopped when it returns)."""
    if not seconds:
        yield
        return
    import signal
    import threading

    if threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer"):
        def on_alarm(signum, frame):
            raise TaskTimeout()

        old = signal.signal(signal.SIGALRM, on_alarm)
        signal.setitimer(signal.ITIMER_REAL, float(seconds))
        try:
            yield
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            signal.signal(signal.SIGALRM, old)
        return
    import ctypes

    tid, lock, live = threading.get_ident(), threading.Lock(), [True]

    def fire():
        with lock:
            if live[0]:
                ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(tid),
                                                           ctypes.py_object(TaskTimeout))

    timer = threading.Timer(float(seconds), fire)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        with lock:
            live[0] = False
        timer.cancel()


def _in_box(tr: T.Truth, v: S.Variant, errors: dict) -> bool:
    """The truth's effective stiffness lies inside the observer's box on both axles, and
    the other constants of the vehicle file are exact."""
    if any(errors[k] != 0.0 for k in ("mass", "inertia", "a_f", "a_r")):
        return False
    ef = (1.0 + errors["stiffness"]) * (1.0 + errors["stiffness_front"])
    er = (1.0 + errors["stiffness"]) * (1.0 + errors["stiffness_rear"])
    s = tr.stiffness
    if not all(np.isfinite(list(s.values()))):
        return False
    return bool((1 - v.rel) * ef <= s["cf_min"] and s["cf_max"] <= (1 + v.rel) * ef
                and (1 - v.rel) * er <= s["cr_min"] and s["cr_max"] <= (1 + v.rel) * er)


def run_task(spec: S.Spec, i: int, batch_id: int, truths: dict | None = None,
             estimators: dict | None = None) -> dict:
    """One simulation: the row of task ``i`` (see :func:`result_schema`). ``truths``:
    truth key -> :class:`~vehicle_observers.campaign.truths.Truth` (else simulated here);
    ``estimators``: the registry (:func:`~vehicle_observers.estimation.registry.available`
    reads the plug-in entry points on every call: give it once per batch)."""
    tk = spec.task(i)
    v = spec.variants[tk.variant]
    errors = v.error_dict
    d = spec.doc
    bias = spec.biases[tk.bias]
    veh0 = T.car_vehicle(tk.car)
    lo, hi = v.speed if v.speed is not None else (veh0.uncertainty["vx_min"],
                                                  veh0.uncertainty["vx_max"])
    name, opts = spec.estimator_of(tk.estimator)
    row = {"task": tk.index, "batch": int(batch_id), "estimator": tk.estimator,
           "options": json.dumps(opts, sort_keys=True) if opts else "",
           "plant": tk.plant, "car": tk.car, "manoeuvre": S.manoeuvre_id(tk.manoeuvre),
           "variant": tk.variant, **{f"err_{k}": errors[k] for k in S.ERROR_KEYS},
           "box_rel": v.rel, "box_vx_min": float(lo), "box_vx_max": float(hi),
           "rate_hz": tk.rate, "noise_scale": tk.noise, "bias": tk.bias,
           **{f"bias_{c}": float(bias.get(c, 0.0)) for c in S.CHANNELS}, "rep": tk.rep,
           "samples": 0, **dict.fromkeys(METRICS, float("nan")),
           "truth_cf_min": float("nan"), "truth_cf_max": float("nan"),
           "truth_cr_min": float("nan"), "truth_cr_max": float("nan"),
           "in_box": None, "guarantee": None, "ok": False, "error_type": "", "error": "",
           "warnings": 0, "warning_kinds": ""}
    row0 = dict(row)
    try:
        with deadline(d.get("timeout_s")):
            _run_task_body(spec, tk, v, errors, bias, lo, hi, row, truths, estimators, name, opts)
    except Exception as exc:  # noqa: BLE001 - every failure of a task is recorded, not raised
        if isinstance(exc.__cause__, TaskTimeout):   # the stop landed in a plug-in's code,
            exc = exc.__cause__                      # which the registry wraps in PluginError
        msg = str(exc).splitlines()[0] if str(exc) else ""
        if isinstance(exc, TaskTimeout):
            msg = (f"estimator {tk.estimator!r}: task ran longer than timeout_s = "
                   f"{d['timeout_s']:g} s; stopped")
            row.update(row0)        # what ran before the stop depends on the machine's speed
        row["ok"] = False
        row["error_type"] = getattr(exc, "type_name", type(exc).__name__)
        row["error"] = msg[:MAX_MESSAGE]
    return row


def _run_task_body(spec, tk, v, errors, bias, lo, hi, row, truths, estimators, name, opts):
    key = S.truth_key(tk.plant, tk.car, tk.manoeuvre, tk.rate)
    tr = truths[key] if truths is not None and key in truths else \
        truth(tk.plant, tk.car, tk.manoeuvre, tk.rate)
    if isinstance(tr, TruthFailure):
        raise TruthFailed(tr)
    seen: dict = {}
    try:
        with recorded_warnings(seen):
            _estimate_and_score(spec, tk, v, errors, bias, lo, hi, row, tr, estimators, name,
                                opts)
    finally:
        row["warnings"], row["warning_kinds"] = warnings_summary(seen)


def _estimate_and_score(spec, tk, v, errors, bias, lo, hi, row, tr, estimators, name, opts):
    from vehicle_observers.core.metrics import coverage_2sigma, mean_nees
    from vehicle_observers.estimation import registry, scoring

    d = spec.doc
    rng = np.random.default_rng(S.seed_sequence(spec.seed, tk.log_key))
    sens = d["sensors"]
    log = T.make_log(tr, tk.rate, sens["std"], tk.noise, bias, sens["distribution"], rng)
    tun = T.sensor_tuning(sens["std"], tk.noise) if d["observer"]["kalman"] == "sensors" \
        else None
    veh = T.observer_vehicle(tk.car, errors, v.rel, v.speed, tun)
    row.update({f"truth_{k}": val for k, val in tr.stiffness.items()})
    inb = _in_box(tr, v, errors)
    row["in_box"] = inb
    row["guarantee"] = bool(
        inb and tk.plant == "lpv" and sens["distribution"] == "uniform"
        and not any(bias.values()) and (tk.noise == 0.0 or sens["std"]["vx"] == 0.0)
        and lo <= float(np.min(tr.vx)) and float(np.max(tr.vx)) <= hi)
    avail = estimators if estimators is not None else registry.available(spec.plugins)
    est = avail[name].estimate(log, veh, **opts)
    bad = [n for n, c in est.columns.items() if not np.all(np.isfinite(c))]
    if bad:
        k = int(np.argmax(~np.isfinite(est.columns[bad[0]])))
        raise FloatingPointError(f"diverged: {bad[0]} is not finite from t = "
                                 f"{log.t[k]:.3f} s")
    mask = log.t - log.t[0] > d["score"]["settle_s"]
    sc = scoring.score(est, log, mask)
    std = est.columns.get("vy_std_mps")
    if std is not None and log.vy is not None and "vy_mps" in est.columns:
        sc["coverage_vy"] = coverage_2sigma(est.columns["vy_mps"], std, log.vy, mask)
        sc["nees_vy"] = mean_nees(est.columns["vy_mps"], std, log.vy, mask)
    row.update({k: float(sc[k]) for k in METRICS if k in sc})
    row["samples"] = int(mask.sum())
    row["ok"] = True


@contextlib.contextmanager
def recorded_warnings(into: dict):
    """Record every warning raised inside the block into ``into``: ``{category name: [count,
    first message]}`` (filter "always": each occurrence counted, whatever the process saw
    before; numpy's floating-point errors raised as warnings, underflow excepted); nothing is
    printed."""
    with warnings.catch_warnings(), np.errstate(divide="warn", over="warn", invalid="warn",
                                                under="ignore"):
        warnings.simplefilter("always")

        def show(message, category, filename, lineno, file=None, line=None):
            text = str(message).splitlines()[0] if str(message) else ""
            c = into.setdefault(category.__name__, [0, text[:MAX_MESSAGE]])
            c[0] += 1

        warnings.showwarning = show
        yield into


def warnings_summary(seen: dict) -> tuple[int, str]:
    """``(total count, JSON {category: {"count", "first"}})`` of :func:`recorded_warnings`'
    record (``(0, "")`` when nothing was raised): the ``warnings`` and ``warning_kinds``
    columns of a row."""
    if not seen:
        return 0, ""
    kinds = {k: {"count": int(c), "first": m} for k, (c, m) in sorted(seen.items())}
    return int(sum(c for c, _ in seen.values())), json.dumps(kinds, sort_keys=True)


_AVAILABLE: dict = {}


def estimators_of(plugins, need=()) -> dict:
    """The registry after loading ``plugins``, read once per process (listing the plug-in
    entry points costs milliseconds per call) and again when a name in ``need`` is missing
    (registered since)."""
    from vehicle_observers.estimation import registry

    key = tuple(plugins)
    if key not in _AVAILABLE or any(n not in _AVAILABLE[key] for n in need):
        _AVAILABLE[key] = registry.available(plugins)
    return _AVAILABLE[key]


def run_batch(raw: dict, batch_id: int, start: int, stop: int, truths=None) -> dict:
    """Dask task: rows of tasks ``start..stop-1`` as columns (lists, :func:`result_schema`
    order). ``truths``: ``[Truth, ...]`` computed elsewhere (else simulated here)."""
    spec = spec_of(raw)
    tmap = None if truths is None else {t.key: t for t in truths}
    avail = estimators_of(spec.plugins, {spec.estimator_of(p[0])[0] for p in spec.pairs})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")    # the truths' (module docstring); a task records its own
        rows = [run_task(spec, i, batch_id, tmap, avail) for i in range(start, stop)]
    names = result_schema().names
    return {n: [r[n] for r in rows] for n in names}


# ------------------------------------------------------------------ worker set-up ---------
def pin_threads(env=None):
    """Set :data:`THREAD_ENV` in ``os.environ`` where unset (takes effect for the libraries
    that start their thread pools later in this process)."""
    env = os.environ if env is None else env
    for k, v in THREAD_ENV.items():
        env.setdefault(k, v)
    return env


_WARM: set = set()


def warm_up(plugins=()) -> list[str]:
    """Import the plug-ins and load every compiled kernel a campaign uses from numba's
    on-disk cache (compiling it once if absent) by running the estimators that need no LMI
    design on a short synthetic log: once per process. Returns the estimators warmed."""
    from vehicle_observers.estimation import registry

    key = tuple(plugins)
    if key in _WARM:
        return []
    registry.load_plugins(plugins)
    t = np.arange(60) * 0.01
    from vehicle_observers.data.logs import DriveLog

    log = DriveLog(t=t, vx=np.full(60, 15.0), delta=0.01 * np.sin(t), yaw_rate=0.05 * np.sin(t),
                   ay=0.5 * np.sin(t), vy=np.zeros(60), Ff=np.zeros(60), Fr=np.zeros(60),
                   extra={"yaw_rate_true_radps": 0.05 * np.sin(t)})
    veh = T.observer_vehicle("bmw_320i", dict.fromkeys(S.ERROR_KEYS, 0.0), 0.1, None,
                             T.sensor_tuning(S.DEFAULT_STD, 1.0))
    done = []
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        from vehicle_observers.estimation import scoring

        for name in ("ekf", "linear-kf", "open-loop-linear"):
            scoring.score(registry.get(name).estimate(log, veh), log)
            done.append(name)
        from vehicle_observers.models import uncertain_bicycle as ub

        ub.simulate_lpv(ub.UncertainBicycle(1500.0, 2500.0, 1.2, 1.4, 8e4, 9e4), [0.0, 0.0],
                        log.delta, log.vx, np.array([9e4, 8e4]), 0.01)
    _WARM.add(key)
    return done


class CampaignWorker:
    """Dask worker plug-in (``distributed.WorkerPlugin`` protocol): on each worker, pin the
    thread counts (for pools started later), import the plug-ins and warm the numba cache
    once (:func:`warm_up`)."""

    name = "vehicle-observers-campaign"
    idempotent = True

    def __init__(self, plugins=()):
        self.plugins = tuple(plugins)

    def setup(self, worker=None):
        pin_threads()
        warm_up(self.plugins)

    def teardown(self, worker=None):
        pass
