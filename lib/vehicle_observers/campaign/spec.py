"""Campaign specification (TOML): what is run, checked completely before anything runs.

A campaign runs every listed estimator of the registry
(:mod:`vehicle_observers.estimation.registry`, plug-ins included) on simulated drives whose
truth is known, with the *observer's* vehicle file perturbed, and scores each run
(:func:`vehicle_observers.estimation.scoring.score`). Format (every key optional except
``estimators`` and ``[truth]``; SI units)::

    name = "robustness"
    seed = 0                  # campaign seed: every random draw derives from it (see below)
    repetitions = 2           # seeded repetitions of every noisy log
    estimators = ["ekf", {name = "interval-coordinates", plants = ["lpv:bmw_320i"]},
                  {name = "my-observer", options = {gain = [10.0, 20.0]}}]
                              # registry names, or "all"; a table: on those plants only
                              # (plants), with those options (options: a list of values
                              # is a sweep axis: one estimator "name[gain=10.0]" per value)
    references = ["open-loop-linear", "linear-kf"] # always run too (ratios of the report)
    plugins = []              # modules or .py files registering more estimators (imported
                              # on the workers; the command line's --plugin adds to them)
    batch_size = "auto"       # simulations per Dask task (auto: 64, fewer below 4096
                              # simulations, more above 128000: at most 2000 tasks)
    timeout_s = 60.0          # a simulation running longer is stopped and recorded as
                              # failed (error_type "TaskTimeout"); default: no limit

    [truth]
    plants = ["multibody:bmw_320i", "lpv:bmw_320i", "yaw-drift:yacine2015"]
    manoeuvres = ["sine_with_dwell", {name = "slalom", duration = 10.0}]

    [observer]                # the observer's vehicle file around the car's nominal constants
    stiffness_rel = [0.1]     # [uncertainty] half-width of the stiffness box (axis)
    speed_range = "car"       # or [[5.0, 40.0], ...]: [uncertainty] vx_min, vx_max (axis)
    kalman = "sensors"        # [kalman] R from the sensor noise below (q: defaults); or "file"

    [errors]                  # relative errors of the observer's vehicle file
    design = "one-at-a-time"  # nominal + each value alone; "factorial"; "sample"
    samples = 20              # design = "sample": draws, each key uniform in [min, max]
    mass = [-0.1, 0.1]        # also inertia, a_f, a_r, stiffness (both axles),
                              # stiffness_front, stiffness_rear, friction

    [sensors]
    noise_scale = [1.0]       # multiplies std (axis)
    distribution = "gaussian" # or "uniform" (bounded, same standard deviation)
    std = {yaw_rate = 0.002, delta = 2e-4, vx = 0.02, ay = 0.05, yL = 0.005, psiL = 5e-4}
    bias = [{}, {yaw_rate = 0.005}]   # constant offsets per channel (axis)
    rates_hz = [100.0]        # sample rates; must divide the plant's native rate (axis)

    [score]
    settle_s = 1.0            # scored samples: t - t_0 > settle_s

    [lmi_map]                 # optional: feasibility of the interval design (Theorem 2)
    cars = ["bmw_320i"]
    stiffness_rel = {start = 0.02, stop = 0.4, num = 20}   # or a list
    speed_range = [[5.0, 40.0], [10.0, 30.0]]
    kappa = [0.0]             # z = T(kappa) x (interval_coordinates); 0: Ifqir 2017 as printed
    rate_hz = 100.0           # epsilon of (20) = rate
    accel_max = 12.0

Truths (``plant:car``): ``multibody`` = the CommonRoad multi-body plant
(:mod:`vehicle_observers.data.plant`, cars ``ford_escort``, ``bmw_320i``, ``vw_vanagon``,
100 Hz); ``yaw-drift`` = the repository's nonlinear model with relaxation and vision
(Yacine 2015 S1 + S2, :func:`vehicle_observers.data.scenarios.replay`, 1 kHz); ``lpv`` = the
Ifqir 2017 LPV linear bicycle at its nominal stiffness, Euler at the sample rate (the model
the interval observers' guarantee is proved for). Cars of the last two: the CommonRoad cars
(data-sheet constants) or a shipped vehicle file (``yacine2015``, ``revs250lm``).
Manoeuvres: :data:`vehicle_observers.data.plant.MANOEUVRES` with their keyword arguments.

Random draws: the noise of a log comes from ``numpy.random.SeedSequence([seed, *h])`` with
``h`` the SHA-256 of the log's part of the task key (plant, manoeuvre, noise scale, bias,
rate, repetition): every estimator and every parameter error sees the same noisy log
(common random numbers), and no draw depends on where or in which order a task ran. The
sampled parameter errors of draw ``j`` come from the key ``("errors", j)`` the same way.

Errors in the file (unknown key or estimator, negative noise, NaN or inf anywhere, empty
grid, a manoeuvre argument outside :data:`MANOEUVRE_BOUNDS`, ...) raise :class:`SpecError`
with one line naming the key.

Size: the plan is counted from the document without enumerating it (:meth:`Spec.size`) and a
spec above :data:`MAX_TASKS` simulations, :data:`MAX_BATCH_FILES` batch files,
:data:`MAX_LMI_POINTS` LMI map points or :data:`MAX_TRUTH_SAMPLES` samples in one truth is
refused before anything runs, naming the count and the limit.
"""

from __future__ import annotations

import hashlib
import inspect
import itertools
import json
import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import tomllib

from vehicle_observers.campaign.plants import COMMONROAD_CARS, cars_of, get_plant, plants
from vehicle_observers.core.errors import ObserverArgumentError, RegistryError

#: version of the plan and of the result columns (a folder of another version is refused)
FORMAT = 1
#: the truth plants: :mod:`vehicle_observers.campaign.plants` (registered, open to plug-ins)
ERROR_KEYS = ("mass", "inertia", "a_f", "a_r", "stiffness", "stiffness_front",
              "stiffness_rear", "friction")
DESIGNS = ("one-at-a-time", "factorial", "sample")
#: sensor noise standard deviations at noise_scale 1 (SI units; those of the plant logs)
DEFAULT_STD = {"yaw_rate": 0.002, "delta": 2e-4, "vx": 0.02, "ay": 0.05, "yL": 0.005,
               "psiL": 5e-4}
CHANNELS = tuple(DEFAULT_STD)
DISTRIBUTIONS = ("gaussian", "uniform")
DEFAULT_REFERENCES = ("open-loop-linear", "linear-kf")
#: default speed range of the observer box for the CommonRoad cars [m/s]
COMMONROAD_SPEED_RANGE = (5.0, 40.0)
#: simulations per Dask task (``batch_size = "auto"``): at most this many tasks for any
#: campaign size ...
MAX_BATCHES = 2000
#: ... at least this many simulations per task (a filter run costs about 1-10 ms, a Dask task
#: a few ms of scheduling, transfer and Parquet writing) ...
MIN_BATCH = 64
#: ... unless the campaign would then have fewer tasks than this (parallelism)
MIN_BATCHES = 64

#: largest campaign [simulations]: the report holds every row in memory, about
#: :data:`ROW_BYTES` each (1e6 rows: about 0.6 GB; README: 1e6 simulations of the bench's
#: estimators are 0.3-0.4 core-hours); a larger study is several campaigns
MAX_TASKS = 10 ** 6
#: largest number of batch files (one Parquet file and one Dask task each)
MAX_BATCH_FILES = 10 ** 5
#: largest LMI feasibility map [points] (each a cvxpy solve of 10-100 ms)
MAX_LMI_POINTS = 10 ** 5
#: largest truth [samples] (about 12 float64 arrays of this length per truth in memory)
MAX_TRUTH_SAMPLES = 10 ** 7
#: memory of one result row in the report [bytes] (measured: 430 on the tiny campaign of the
#: tests, pyarrow and polars alike; rounded up for longer error messages)
ROW_BYTES = 600
#: manoeuvre arguments: (lowest, highest, lowest excluded) in SI units (rad, m/s, s, Hz); a
#: manoeuvre's whole length is at most MAX_MANOEUVRE_S
MANOEUVRE_BOUNDS = {"vx": (2.0, 80.0, False), "amplitude": (-0.6, 0.6, False),
                    "delta_max": (-0.6, 0.6, False), "frequency_hz": (0.0, 10.0, True),
                    "duration": (0.0, 3600.0, True), "ramp": (0.0, 3600.0, True),
                    "dwell": (0.0, 600.0, False), "t_before": (0.0, 600.0, False),
                    "t_after": (0.0, 600.0, False), "t_start": (0.0, 3600.0, False)}
MAX_MANOEUVRE_S = 3600.0

TOP_KEYS = ("name", "seed", "repetitions", "estimators", "references", "plugins", "batch_size",
            "timeout_s", "truth", "observer", "errors", "sensors", "score", "lmi_map")
TABLE_KEYS = {
    "truth": ("plants", "manoeuvres"),
    "observer": ("stiffness_rel", "speed_range", "kalman"),
    "errors": ("design", "samples", *ERROR_KEYS),
    "sensors": ("noise_scale", "distribution", "std", "bias", "rates_hz"),
    "score": ("settle_s",),
    "lmi_map": ("cars", "stiffness_rel", "speed_range", "kappa", "rate_hz", "accel_max",
                "batch_size"),
}


class SpecError(ObserverArgumentError):
    """A campaign specification is wrong; the one-line message names the key."""


# ------------------------------------------------------------------ hashing / seeds -------
def canonical(obj) -> str:
    """Canonical JSON text of ``obj`` (sorted keys, shortest round-trip floats)."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def stable_hash(obj) -> str:
    """SHA-256 (hex) of :func:`canonical` ``obj``: the same on every machine and run (unlike
    Python's ``hash``, salted per process)."""
    return hashlib.sha256(canonical(obj).encode()).hexdigest()


def seed_sequence(seed: int, key) -> np.random.SeedSequence:
    """``SeedSequence([seed, w0, w1, w2, w3])`` with ``w`` the first 128 bits of
    :func:`stable_hash` ``(key)``: the draws of ``key`` whatever ran before or beside it."""
    h = stable_hash(key)
    return np.random.SeedSequence([int(seed), *(int(h[i:i + 8], 16) for i in range(0, 32, 8))])


# ------------------------------------------------------------------ small validators ------
def _err(where: str, key: str, what: str):
    raise SpecError(f"{where}: key '{key}' {what}")


def _number(where, key, v, lo=-math.inf, hi=math.inf, lo_open=False, integer=False):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        _err(where, key, f"must be a finite number, got {v!r}")
    if integer and int(v) != v:
        _err(where, key, f"must be an integer, got {v!r}")
    if v < lo or (lo_open and v == lo) or v > hi:
        rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
        _err(where, key, f"must be in {rng}, got {v!r}")
    return int(v) if integer else float(v)


def _list(where, key, v, allow_scalar=True):
    if isinstance(v, list):
        if not v:
            _err(where, key, "is an empty list (an empty grid runs nothing)")
        return v
    if allow_scalar:
        return [v]
    _err(where, key, f"must be a list, got {v!r}")


def _unknown(where, table: dict, allowed, prefix=""):
    for k in table:
        if k not in allowed:
            raise SpecError(f"{where}: unknown key '{prefix}{k}' (expected one of "
                            f"{', '.join(allowed)})")


def _table(where, doc, key) -> dict:
    t = doc.get(key, {})
    if not isinstance(t, dict):
        _err(where, key, "must be a table")
    _unknown(where, t, TABLE_KEYS[key], f"{key}.")
    return t


def _range_list(where, key, v):
    """``[[lo, hi], ...]`` speed ranges [m/s] (one range may be given flat)."""
    v = _list(where, key, v, allow_scalar=False)
    if len(v) == 2 and all(isinstance(x, (int, float)) for x in v):
        v = [v]
    out = []
    for r in v:
        if not (isinstance(r, list) and len(r) == 2):
            _err(where, key, f"must hold [vx_min, vx_max] pairs, got {r!r}")
        lo = _number(where, key, r[0], 0.0, 150.0, lo_open=True)
        hi = _number(where, key, r[1], 0.0, 150.0, lo_open=True)
        if not lo < hi:
            _err(where, key, f"needs vx_min < vx_max, got {r!r}")
        out.append((lo, hi))
    return tuple(out)


def _grid(where, key, v, lo, hi, lo_open=False):
    """A list of numbers, or ``{start, stop, num}`` (linear)."""
    if isinstance(v, dict):
        _unknown(where, v, ("start", "stop", "num"), f"{key}.")
        for k in ("start", "stop", "num"):
            if k not in v:
                _err(where, f"{key}.{k}", "is missing")
        a = _number(where, f"{key}.start", v["start"], lo, hi, lo_open)
        b = _number(where, f"{key}.stop", v["stop"], lo, hi, lo_open)
        n = _number(where, f"{key}.num", v["num"], 1, 10 ** 6, integer=True)
        return tuple(float(x) for x in np.linspace(a, b, n))
    return tuple(_number(where, key, x, lo, hi, lo_open) for x in _list(where, key, v))


# ------------------------------------------------------------------ the specification ------
@dataclass(frozen=True)
class Variant:
    """One observer vehicle file: relative ``errors`` (key -> value, :data:`ERROR_KEYS`),
    stiffness box half-width ``rel`` and speed range ``speed`` ((vx_min, vx_max) or ``None``
    for the car's own)."""

    errors: tuple
    rel: float
    speed: tuple | None

    @property
    def error_dict(self) -> dict:
        return dict(self.errors)


@dataclass(frozen=True)
class Task:
    """One simulation: estimator ``estimator`` on the log of ``(plant, car, manoeuvre, noise,
    bias, rate, rep)`` with the observer vehicle file ``variant``."""

    index: int
    estimator: str
    plant: str
    car: str
    manoeuvre: tuple        # (name, ((key, value), ...))
    variant: int
    rate: float
    noise: float
    bias: int
    rep: int

    @property
    def log_key(self) -> tuple:
        """The part of the key the noisy log depends on (:func:`seed_sequence`)."""
        return ("log", self.plant, self.car, manoeuvre_id(self.manoeuvre), self.noise,
                self.bias, self.rate, self.rep)

    @property
    def truth_key(self) -> tuple:
        return truth_key(self.plant, self.car, self.manoeuvre, self.rate)


def truth_key(plant, car, manoeuvre, rate) -> tuple:
    """Key of a noise-free truth: the ``lpv`` plant is simulated at the sample rate, the
    others at their native rate (decimated afterwards)."""
    at_rate = get_plant(plant).native_rate is None
    return (plant, car, manoeuvre_id(manoeuvre), float(rate) if at_rate else None)


def manoeuvre_id(man) -> str:
    """``"slalom(duration=10.0)"``: the manoeuvre with its keyword arguments."""
    name, kw = man
    return name + ("(" + ",".join(f"{k}={v!r}" for k, v in kw) + ")" if kw else "")


class Spec:
    """A validated campaign specification (module docstring); build with :func:`load_spec`.

    :attr:`doc` is the normalised specification (defaults filled in, JSON-able): its
    :attr:`sha256` identifies the campaign (two files that differ only in layout, comments
    or spelled-out defaults are the same campaign); :attr:`raw` is the document as given.
    The plan enumerates tasks in mixed radix over (estimator x truth) pairs, variants,
    rates, manoeuvres, noise scales, biases, repetitions (slowest first), so consecutive
    tasks share the observer design; batches are runs of consecutive task indices.
    """

    def __init__(self, doc: dict, source: str = "spec"):
        self.source = source
        bad = _non_finite(doc)
        if bad:
            raise SpecError(f"{source}: key '{bad}' must be a finite number, got "
                            f"{_lookup(doc, bad)!r}")
        #: the document as given (JSON-able): what the workers rebuild the spec from
        try:
            self.raw = json.loads(json.dumps(doc, allow_nan=False)) if isinstance(doc, dict) \
                else doc
        except (TypeError, ValueError) as exc:
            raise SpecError(f"{source}: values must be strings, finite numbers, lists and "
                            f"tables ({exc})") from None
        self.doc = _normalise(doc, source)
        check_size(self.doc, source)

    @cached_property
    def sha256(self) -> str:
        return stable_hash({"format": FORMAT, "spec": self.doc})

    # ---- axes ----------------------------------------------------------------------------
    @property
    def seed(self) -> int:
        return self.doc["seed"]

    @property
    def plugins(self) -> tuple:
        return tuple(self.doc["plugins"])

    def estimator_of(self, label: str) -> tuple[str, dict]:
        """``(registry name, options)`` of an estimator column (:func:`option_label`)."""
        e = self.doc.get("_options", {}).get(label)
        return (label, {}) if e is None else (e[0], dict(e[1]))

    @cached_property
    def pairs(self) -> tuple:
        """(estimator, plant, car) combinations that run (``"all"`` skips an estimator whose
        log columns a plant does not give; a named one is an error there)."""
        return tuple(tuple(p) for p in self.doc["_pairs"])

    @cached_property
    def variants(self) -> tuple:
        d = self.doc
        errs = _error_points(d["errors"], d["seed"])
        sp = [None] if d["observer"]["speed_range"] == "car" else \
            [tuple(r) for r in d["observer"]["speed_range"]]
        return tuple(Variant(tuple(sorted(e.items())), rel, s)
                     for e in errs for rel in d["observer"]["stiffness_rel"] for s in sp)

    @cached_property
    def manoeuvres(self) -> tuple:
        return tuple((m["name"], tuple(sorted(m["kwargs"].items())))
                     for m in self.doc["truth"]["manoeuvres"])

    @property
    def rates(self) -> tuple:
        return tuple(self.doc["sensors"]["rates_hz"])

    @property
    def noises(self) -> tuple:
        return tuple(self.doc["sensors"]["noise_scale"])

    @property
    def biases(self) -> tuple:
        return tuple(self.doc["sensors"]["bias"])

    @property
    def repetitions(self) -> int:
        return self.doc["repetitions"]

    @cached_property
    def n_variants(self) -> int:
        """Number of vehicle-file variants, counted from the document (not enumerated)."""
        return count_variants(self.doc)

    @cached_property
    def radix(self) -> tuple:
        return (len(self.pairs), self.n_variants, len(self.rates), len(self.manoeuvres),
                len(self.noises), len(self.biases), self.repetitions)

    @cached_property
    def n_tasks(self) -> int:
        return math.prod(self.radix)

    def size(self) -> dict:
        """The plan's size, counted without enumerating it: ``tasks``, ``batches``,
        ``rows`` (= tasks), ``memory_bytes`` (rows in the report), ``lmi_points``,
        ``truth_samples`` (the longest truth)."""
        return plan_size(self.doc)

    def task(self, i: int) -> Task:
        """Task ``i`` of the plan (``0 <= i < n_tasks``)."""
        if not 0 <= i < self.n_tasks:
            raise IndexError(f"task {i} outside 0..{self.n_tasks - 1}")
        idx = []
        r = int(i)
        for n in reversed(self.radix):
            idx.append(r % n)
            r //= n
        p, v, ra, m, s, b, rep = reversed(idx)
        est, plant, car = self.pairs[p]
        return Task(int(i), est, plant, car, self.manoeuvres[m], v, self.rates[ra],
                    self.noises[s], b, rep)

    @cached_property
    def batch_size(self) -> int:
        return batch_size_of(self.doc["batch_size"], self.n_tasks)

    def batches(self) -> list[tuple[int, int, int]]:
        """``[(batch id, first task, end task), ...]``."""
        b = self.batch_size
        return [(k, a, min(a + b, self.n_tasks)) for k, a in enumerate(range(0, self.n_tasks, b))]

    # ---- LMI feasibility map --------------------------------------------------------------
    @cached_property
    def lmi_points(self) -> tuple:
        """``((car, stiffness_rel, vx_min, vx_max, kappa), ...)`` of ``[lmi_map]``."""
        m = self.doc.get("lmi_map")
        if not m:
            return ()
        return tuple((c, rel, lo, hi, k) for c in m["cars"] for rel in m["stiffness_rel"]
                     for lo, hi in m["speed_range"] for k in m["kappa"])

    def lmi_batches(self) -> list[tuple[int, int, int]]:
        m = self.doc.get("lmi_map")
        if not m:
            return []
        b, n = m["batch_size"], len(self.lmi_points)
        return [(k, a, min(a + b, n)) for k, a in enumerate(range(0, n, b))]

    def summary(self) -> str:
        return (f"{self.doc['name']}: {self.n_tasks} simulations ({len(self.pairs)} estimator x "
                f"truth pairs, {self.n_variants} vehicle-file variants, {len(self.rates)} "
                f"rate(s), {len(self.manoeuvres)} manoeuvre(s), {len(self.noises)} noise "
                f"level(s), {len(self.biases)} bias case(s), {self.repetitions} repetition(s)) "
                f"in {len(self.batches())} batches of {self.batch_size}"
                + (f"; LMI map of {len(self.lmi_points)} points" if self.lmi_points else ""))


def batch_size_of(b, n: int) -> int:
    """Simulations per batch: ``b``, or for ``"auto"`` (:data:`MAX_BATCHES`, ...)."""
    if b != "auto":
        return int(b)
    return max(-(-n // MAX_BATCHES), min(MIN_BATCH, -(-n // MIN_BATCHES)), 1)


def count_variants(doc: dict) -> int:
    """Vehicle-file variants of a normalised document (:func:`_error_points` x stiffness
    boxes x speed ranges), counted."""
    er = doc["errors"]
    vals = er["values"]
    if er["design"] == "one-at-a-time":
        n = 1 + sum(1 for k in ERROR_KEYS for v in vals.get(k, []) if v != 0.0)
    elif er["design"] == "factorial":
        n = math.prod(len(v) for v in vals.values())
    else:
        n = er["samples"]
    sr = doc["observer"]["speed_range"]
    return n * len(doc["observer"]["stiffness_rel"]) * (1 if sr == "car" else len(sr))


def manoeuvre_seconds(name: str, kw: dict) -> float:
    """Length of a manoeuvre [s] from its arguments (defaults of its function)."""
    from vehicle_observers.data import plant

    params = inspect.signature(plant.MANOEUVRES[name]).parameters
    a = {k: p.default for k, p in params.items()}
    a.update(kw)
    if name == "sine_with_dwell":
        return a["t_before"] + 1.0 / a["frequency_hz"] + a["dwell"] + a["t_after"]
    return float(a["duration"])


def plan_size(doc: dict) -> dict:
    """Size of the plan of a normalised document (:meth:`Spec.size`)."""
    n = (len(doc["_pairs"]) * count_variants(doc) * len(doc["sensors"]["rates_hz"])
         * len(doc["truth"]["manoeuvres"]) * len(doc["sensors"]["noise_scale"])
         * len(doc["sensors"]["bias"]) * doc["repetitions"])
    lm = doc.get("lmi_map")
    lmi = (len(lm["cars"]) * len(lm["stiffness_rel"]) * len(lm["speed_range"])
           * len(lm["kappa"])) if lm else 0
    longest = max(manoeuvre_seconds(m["name"], m["kwargs"]) for m in doc["truth"]["manoeuvres"])
    rate = max([get_plant(p.split(":")[0]).native_rate or 0.0 for p in doc["truth"]["plants"]]
               + list(doc["sensors"]["rates_hz"]))
    bs = batch_size_of(doc["batch_size"], n)
    return {"tasks": n, "batches": -(-n // bs) if n else 0, "rows": n,
            "memory_bytes": n * ROW_BYTES, "lmi_points": lmi,
            "lmi_batches": -(-lmi // lm["batch_size"]) if lm else 0,
            "truth_samples": int(longest * rate) + 1}


def check_size(doc: dict, where: str = "spec"):
    """Refuse a plan above the limits (module docstring), naming the count."""
    z = plan_size(doc)
    if z["tasks"] > MAX_TASKS:
        raise SpecError(f"{where}: the plan has {z['tasks']:.4g} simulations (about "
                        f"{z['memory_bytes'] / 1e9:.3g} GB of rows), above the limit of "
                        f"{MAX_TASKS:.0e}: fewer grid values, samples or repetitions, or "
                        "several campaigns")
    if z["batches"] > MAX_BATCH_FILES:
        raise SpecError(f"{where}: key 'batch_size' gives {z['batches']} batch files, above the "
                        f"limit of {MAX_BATCH_FILES:.0e}: a larger batch_size (or \"auto\")")
    if z["lmi_points"] > MAX_LMI_POINTS or z["lmi_batches"] > MAX_BATCH_FILES:
        raise SpecError(f"{where}: key 'lmi_map' gives {z['lmi_points']:.4g} points in "
                        f"{z['lmi_batches']} batches, above the limit of {MAX_LMI_POINTS:.0e} "
                        f"points / {MAX_BATCH_FILES:.0e} batches")
    if z["truth_samples"] > MAX_TRUTH_SAMPLES:
        raise SpecError(f"{where}: key 'truth.manoeuvres' with 'sensors.rates_hz' gives a truth "
                        f"of {z['truth_samples']:.4g} samples, above the limit of "
                        f"{MAX_TRUTH_SAMPLES:.0e}")
    return z


def _lookup(doc, path: str):
    import re

    cur = doc
    for part in re.findall(r"[^.\[\]]+|\[\d+\]", path):
        try:
            cur = cur[int(part[1:-1])] if part.startswith("[") else cur[part]
        except (KeyError, IndexError, TypeError, ValueError):
            return None
    return cur


def _non_finite(obj, path="") -> str | None:
    """Dotted key of the first NaN / inf number in ``obj`` (``None`` if none)."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return path or "value"
    if isinstance(obj, dict):
        for k, v in obj.items():
            r = _non_finite(v, f"{path}.{k}" if path else str(k))
            if r:
                return r
    if isinstance(obj, list | tuple):
        for i, v in enumerate(obj):
            r = _non_finite(v, f"{path}[{i}]")
            if r:
                return r
    return None


def dump_toml(doc: dict) -> str:
    """TOML text of a spec document (scalars and lists at the top, then one table per
    sub-table; tables inside lists and tables are written inline): ``load_spec`` of it is
    the same campaign (same :attr:`Spec.sha256`)."""
    def val(v):
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {val(x)}" for k, x in v.items()) + "}"
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, float):
            return repr(v) if math.isfinite(v) else _err("spec", "value", f"{v} is not finite")
        return json.dumps(v)

    lines = [f"{k} = {val(v)}" for k, v in doc.items() if not isinstance(v, dict)]
    for k, v in doc.items():
        if isinstance(v, dict):
            lines += ["", f"[{k}]"] + [f"{kk} = {val(vv)}" for kk, vv in v.items()]
    return "\n".join(lines) + "\n"


def load_spec(spec) -> Spec:
    """A :class:`Spec` from a TOML file path, a TOML text, a dict, or a :class:`Spec`."""
    if isinstance(spec, Spec):
        return spec
    if isinstance(spec, dict):
        return Spec(spec, "spec")
    s = str(spec)
    p = Path(s)
    if "\n" not in s and "=" not in s:
        if not p.is_file():
            raise SpecError(f"{p}: no such campaign spec file")
        try:
            doc = tomllib.loads(p.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError) as exc:
            raise SpecError(f"{p.name}: cannot read ({exc})") from None
        except tomllib.TOMLDecodeError as exc:
            raise SpecError(f"{p.name}: not valid TOML ({exc})") from None
        return Spec(doc, p.name)
    try:
        doc = tomllib.loads(s)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"spec: not valid TOML ({exc})") from None
    return Spec(doc, "spec")


# ------------------------------------------------------------------ normalisation --------
def _normalise(doc: dict, where: str) -> dict:
    """Validate ``doc`` and return the normalised document (see :class:`Spec`)."""
    from vehicle_observers.data import plant
    from vehicle_observers.estimation import references as _est  # noqa: F401  (references)
    from vehicle_observers.estimation import registry
    from vehicle_observers.models.vehicle import builtin_vehicles

    if not isinstance(doc, dict):
        raise SpecError(f"{where}: a campaign spec is a TOML table, got {type(doc).__name__}")
    _unknown(where, doc, TOP_KEYS)
    out: dict = {}
    name = doc.get("name", "campaign")
    if not isinstance(name, str) or not name:
        _err(where, "name", f"must be a non-empty string, got {name!r}")
    out["name"] = name
    out["seed"] = _number(where, "seed", doc.get("seed", 0), 0, 2 ** 63 - 1, integer=True)
    out["repetitions"] = _number(where, "repetitions", doc.get("repetitions", 1), 1, 10 ** 6,
                                 integer=True)
    plugins = doc.get("plugins", [])
    if not isinstance(plugins, list) or not all(isinstance(p, str) and p for p in plugins):
        _err(where, "plugins", f"must be a list of module names or .py paths, got {plugins!r}")
    out["plugins"] = list(plugins)
    try:
        avail = registry.available(plugins)
    except RegistryError as exc:
        raise SpecError(f"{where}: key 'plugins': {exc}") from None
    if "timeout_s" in doc:          # only when given: the hash of other specs is unchanged
        out["timeout_s"] = _number(where, "timeout_s", doc["timeout_s"], 0.0, 86400.0,
                                   lo_open=True)
    bs = doc.get("batch_size", "auto")
    out["batch_size"] = bs if bs == "auto" else _number(where, "batch_size", bs, 1, 10 ** 7,
                                                       integer=True)

    # estimators
    if "estimators" not in doc:
        raise SpecError(f"{where}: missing key 'estimators' (registry names or \"all\"; "
                        f"available: {', '.join(avail)})")
    est = doc["estimators"]
    every = est == "all"
    only: dict = {}        # estimator -> the plants it runs on ({name, plants} entries)
    labels: dict = {}      # label -> [registry name, options] (options entries)
    names = []
    for e in (list(avail) if every else _list(where, "estimators", est)):
        if isinstance(e, dict):
            _unknown(where, e, ("name", "plants", "options"), "estimators.")
            if "name" not in e or not ({"plants", "options"} & set(e)):
                _err(where, "estimators", f"a table entry needs name and plants or options, "
                                          f"got {e!r}")
            if not isinstance(e["name"], str):
                _err(where, "estimators", f"a table entry's name is one estimator name (a "
                                          f"string), got {e['name']!r}: one entry per estimator")
            if e["name"] not in avail:
                raise SpecError(f"{where}: key 'estimators': unknown estimator "
                                f"{e['name']!r}; available: {', '.join(avail)}")
            sweep = _option_sweep(where, avail[e["name"]], e.get("options", {}))
            for opts in sweep:
                lab = option_label(e["name"], opts)
                if "plants" in e:
                    only[lab] = _list(where, f"estimators.{e['name']}.plants", e["plants"])
                if opts:
                    labels[lab] = [e["name"], opts]
                names.append(lab)
            continue
        names.append(e)
    refs = doc.get("references", list(DEFAULT_REFERENCES))
    refs = [] if refs == [] else _list(where, "references", refs)
    if all(isinstance(r, str) for r in refs):
        refs = list(dict.fromkeys(refs))        # a reference listed twice runs once
    for n in list(names) + list(refs):
        if n in labels:
            continue
        if not isinstance(n, str) or n not in avail:
            raise SpecError(f"{where}: key 'estimators': unknown estimator {n!r}; available: "
                            f"{', '.join(avail)}")
    if len(set(names)) != len(names):
        _err(where, "estimators", f"lists an estimator twice: {names}")
    names = names + [r for r in refs if r not in names]
    out["estimators"] = "all" if every else list(est if isinstance(est, list) else [est])
    out["references"] = list(refs)
    out["_options"] = labels

    # truths
    tr = _table(where, doc, "truth")
    if "plants" not in tr:
        raise SpecError(f"{where}: missing key 'truth.plants' (e.g. [\"multibody:bmw_320i\"])")
    truths = []
    files = builtin_vehicles()
    for t in _list(where, "truth.plants", tr["plants"]):
        if not isinstance(t, str) or ":" not in t:
            _err(where, "truth.plants", f"entries are \"plant:car\", got {t!r}")
        pl, car = t.split(":", 1)
        known = plants()
        if pl not in known:
            _err(where, "truth.plants", f"unknown plant {pl!r} in {t!r} (expected "
                                        f"{', '.join(known)})")
        cars = cars_of(known[pl])
        if car not in cars:
            _err(where, "truth.plants", f"unknown car {car!r} for plant {pl!r} (expected "
                                        f"{', '.join(cars)})")
        if (pl, car) in truths:
            _err(where, "truth.plants", f"lists {t!r} twice")
        truths.append((pl, car))
    out["truth"] = {"plants": [f"{p}:{c}" for p, c in truths]}
    mans = []
    for m in _list(where, "truth.manoeuvres", tr.get("manoeuvres", ["sine_with_dwell"])):
        if isinstance(m, str):
            m = {"name": m}
        if not isinstance(m, dict) or not isinstance(m.get("name"), str):
            _err(where, "truth.manoeuvres", f"entries are names or {{name = ..., ...}}, got {m!r}")
        nm = m["name"]
        if nm not in plant.MANOEUVRES:
            _err(where, "truth.manoeuvres", f"unknown manoeuvre {nm!r} (expected "
                                            f"{', '.join(plant.MANOEUVRES)})")
        params = inspect.signature(plant.MANOEUVRES[nm]).parameters
        kw = {}
        for k, v in m.items():
            if k == "name":
                continue
            if k not in params:
                _err(where, f"truth.manoeuvres.{nm}", f"has unknown argument {k!r} (expected "
                                                      f"{', '.join(params)})")
            lo, hi, lo_open = MANOEUVRE_BOUNDS.get(k, (-math.inf, math.inf, False))
            kw[k] = _number(where, f"truth.manoeuvres.{nm}.{k}", v, lo, hi, lo_open)
        length = manoeuvre_seconds(nm, kw)
        if not 0.0 < length <= MAX_MANOEUVRE_S:
            _err(where, f"truth.manoeuvres.{nm}", f"lasts {length:g} s; at most "
                                                  f"{MAX_MANOEUVRE_S:g} s")
        mans.append({"name": nm, "kwargs": kw})
    ids = [manoeuvre_id((m["name"], tuple(sorted(m["kwargs"].items())))) for m in mans]
    if len(set(ids)) != len(ids):
        _err(where, "truth.manoeuvres", f"lists a manoeuvre twice: {ids}")
    out["truth"]["manoeuvres"] = mans

    # observer box
    ob = _table(where, doc, "observer")
    sr = ob.get("speed_range", "car")
    out["observer"] = {
        "stiffness_rel": list(_grid(where, "observer.stiffness_rel",
                                    ob.get("stiffness_rel", [0.1]), 0.0, 0.95)),
        "speed_range": "car" if sr == "car" else [list(r) for r in
                                                  _range_list(where, "observer.speed_range", sr)],
        "kalman": ob.get("kalman", "sensors")}
    if out["observer"]["kalman"] not in ("sensors", "file"):
        _err(where, "observer.kalman", f"must be \"sensors\" or \"file\", got "
                                       f"{out['observer']['kalman']!r}")

    # parameter errors
    er = _table(where, doc, "errors")
    design = er.get("design", "one-at-a-time")
    if design not in DESIGNS:
        _err(where, "errors.design", f"must be one of {', '.join(DESIGNS)}, got {design!r}")
    vals = {k: list(_grid(where, f"errors.{k}", er[k], -0.9, 10.0)) for k in ERROR_KEYS if k in er}
    samples = er.get("samples", 0)
    if design == "sample":
        samples = _number(where, "errors.samples", samples, 1, 10 ** 7, integer=True)
        for k, v in vals.items():
            if len(v) != 2 or not v[0] <= v[1]:
                _err(where, f"errors.{k}", f"must be [min, max] for design = \"sample\", got {v}")
    elif "samples" in er:
        _err(where, "errors.samples", f"is only read with design = \"sample\" (design is "
                                      f"{design!r})")
    out["errors"] = {"design": design, "samples": int(samples), "values": vals}

    # sensors
    se = _table(where, doc, "sensors")
    std = dict(DEFAULT_STD)
    user_std = se.get("std", {})
    if not isinstance(user_std, dict):
        _err(where, "sensors.std", "must be a table of channel = standard deviation")
    _unknown(where, user_std, CHANNELS, "sensors.std.")
    for k, v in user_std.items():
        std[k] = _number(where, f"sensors.std.{k}", v, 0.0, 1e3)
    dist = se.get("distribution", "gaussian")
    if dist not in DISTRIBUTIONS:
        _err(where, "sensors.distribution", f"must be one of {', '.join(DISTRIBUTIONS)}, got "
                                            f"{dist!r}")
    biases = []
    for b in _list(where, "sensors.bias", se.get("bias", [{}])):
        if not isinstance(b, dict):
            _err(where, "sensors.bias", f"entries are tables of channel = offset, got {b!r}")
        _unknown(where, b, CHANNELS, "sensors.bias.")
        biases.append({k: _number(where, f"sensors.bias.{k}", v, -1e3, 1e3)
                       for k, v in sorted(b.items())})
    if len({canonical(b) for b in biases}) != len(biases):
        _err(where, "sensors.bias", "lists a bias case twice")
    rates = _grid(where, "sensors.rates_hz", se.get("rates_hz", [100.0]), 0.0, 1e4, lo_open=True)
    for pl, _car in truths:
        nat = get_plant(pl).native_rate
        for r in rates:
            q = nat / r if nat else 1.0
            if nat and (abs(q - round(q)) > 1e-9 or round(q) < 1):
                _err(where, "sensors.rates_hz", f"{r:g} Hz does not divide the {nat:g} Hz native "
                                                f"rate of plant {pl!r}")
    out["sensors"] = {"noise_scale": list(_grid(where, "sensors.noise_scale",
                                                se.get("noise_scale", [1.0]), 0.0, 1e3)),
                      "distribution": dist, "std": std, "bias": biases,
                      "rates_hz": list(rates)}
    for key in ("noise_scale", "rates_hz"):
        if len(set(out["sensors"][key])) != len(out["sensors"][key]):
            _err(where, f"sensors.{key}", f"lists a value twice: {out['sensors'][key]}")

    sc = _table(where, doc, "score")
    out["score"] = {"settle_s": _number(where, "score.settle_s", sc.get("settle_s", 1.0), 0.0,
                                        1e4)}

    # LMI map
    if "lmi_map" in doc:
        lm = _table(where, doc, "lmi_map")
        cars = _list(where, "lmi_map.cars", lm.get("cars", sorted({c for _, c in truths})))
        for c in cars:
            if c not in tuple(COMMONROAD_CARS) + tuple(files):
                _err(where, "lmi_map.cars", f"unknown car {c!r}")
        out["lmi_map"] = {
            "cars": list(cars),
            "stiffness_rel": list(_grid(where, "lmi_map.stiffness_rel",
                                        lm.get("stiffness_rel", [0.1]), 0.0, 0.95)),
            "speed_range": [list(r) for r in _range_list(
                where, "lmi_map.speed_range", lm.get("speed_range", [list(COMMONROAD_SPEED_RANGE)]))],
            "kappa": list(_grid(where, "lmi_map.kappa", lm.get("kappa", [0.0]), -10.0, 10.0)),
            "rate_hz": _number(where, "lmi_map.rate_hz", lm.get("rate_hz", 100.0), 0.0, 1e5,
                               lo_open=True),
            "accel_max": _number(where, "lmi_map.accel_max", lm.get("accel_max", 12.0), 0.0, 1e3),
            "batch_size": _number(where, "lmi_map.batch_size", lm.get("batch_size", 25), 1, 10 ** 6,
                                  integer=True)}

    # estimator x truth pairs
    pairs = []
    for n, pls in only.items():
        for t in pls:
            if t not in out["truth"]["plants"]:
                _err(where, f"estimators.{n}.plants", f"names {t!r}, not one of truth.plants")
    for n in names:
        s = avail[labels[n][0]] if n in labels else avail[n]
        for pl, car in truths:
            if n in only and f"{pl}:{car}" not in only[n]:
                continue
            missing = [c for c in s.columns if c not in get_plant(pl).columns]
            if missing:
                if every and n not in refs:
                    continue
                raise SpecError(f"{where}: key 'estimators': estimator {n!r} needs log "
                                f"column(s) {', '.join(missing)} that plant {pl!r} does not give")
            pairs.append((n, pl, car))
    if not pairs:
        _err(where, "estimators", "leaves nothing to run on these plants")
    out["_pairs"] = [list(p) for p in pairs]
    return out


def option_label(name: str, opts: dict) -> str:
    """``"name[gain=10.0,mode='a']"``: the estimator column of a run with options (the
    registry name alone without)."""
    if not opts:
        return name
    return f"{name}[" + ",".join(f"{k}={v!r}" for k, v in sorted(opts.items())) + "]"


def _option_sweep(where, spec, options) -> list[dict]:
    """The option sets of an ``estimators`` entry: ``options = {k = v}`` one set; a list of
    values for a key whose default is not a list sweeps it (every combination, in order)."""
    if not isinstance(options, dict):
        _err(where, f"estimators.{spec.name}.options", f"must be a table, got {options!r}")
    keys, axes = [], []
    for k, v in options.items():
        default = spec.options.get(k)
        nested = isinstance(v, list) and v and isinstance(v[0], list)
        sweep = isinstance(v, list) and (nested or not isinstance(default, (list, tuple)))
        vals = _list(where, f"estimators.{spec.name}.options.{k}", v) if sweep else [v]
        keys.append(k)
        axes.append(vals)
    out = []
    for combo in itertools.product(*axes):
        try:
            out.append(spec.parse_options(dict(zip(keys, combo))))
        except RegistryError as exc:
            raise SpecError(f"{where}: key 'estimators.{spec.name}.options': {exc}") from None
    return out


def _error_points(er: dict, seed: int) -> list[dict]:
    """The relative-error points of the observer's vehicle file (every key of
    :data:`ERROR_KEYS`, 0 where not varied)."""
    vals = er["values"]
    zero = dict.fromkeys(ERROR_KEYS, 0.0)
    if er["design"] == "one-at-a-time":
        pts = [dict(zero)]
        for k in ERROR_KEYS:
            for v in vals.get(k, []):
                if v != 0.0:
                    pts.append({**zero, k: v})
        return pts
    if er["design"] == "factorial":
        keys = [k for k in ERROR_KEYS if k in vals]
        return [{**zero, **dict(zip(keys, combo))}
                for combo in itertools.product(*(vals[k] for k in keys))]
    pts = []
    for j in range(er["samples"]):
        rng = np.random.default_rng(seed_sequence(seed, ("errors", j)))
        u = rng.random(len(ERROR_KEYS))                 # fixed draw order: ERROR_KEYS
        pts.append({k: (float(vals[k][0] + (vals[k][1] - vals[k][0]) * u[i]) if k in vals else 0.0)
                    for i, k in enumerate(ERROR_KEYS)})
    return pts
