"""Speed of every registered estimator on one generated log (part of ``make bench``).

Every estimator of :func:`vehicle_observers.estimation.available` (the built-in ones and the
plug-ins) runs on the same emulated log: a sine with dwell at 17 m/s, 1 kHz, seed
:data:`SEED` (:func:`vehicle_observers.data.scenarios.sine_with_dwell`: 6,929 samples; quick:
0.5 s after the manoeuvre instead of 4 s), with the shipped vehicle file ``yacine2015`` and
the Kalman filters' sensor-spec noise defaults (:class:`~vehicle_observers.models.vehicle.
KalmanTuning`; no maximum-likelihood tuning: speed only, accuracy is the reproductions'
benchmark). Each estimator first runs once on the first :data:`WARM_UP_S` s (numba
compilation, LMI designs cached per vehicle; not timed), then :data:`REPEAT` times on the
whole log (once when a run takes more than :data:`LONG_S` s); the best run counts. Columns:

* ``us_per_step`` [us]: wall time of the estimation loop per sample as the estimator reports
  it (:attr:`~vehicle_observers.core.protocol.Trajectory.us_per_step`: compiled loop, design
  excluded), or of the whole call when it reports none;
* ``seconds`` [s]: wall clock of the whole call (checks, stretches, design-cache look-ups);
* ``speedup_vs_filterpy_ekf``: ``us_per_step`` of filterpy's EKF (``ekf-filterpy``: the same
  model and noise as ``ekf``, in pure Python; measured in the same process on the same log)
  over the estimator's (above 1: faster than filterpy; NaN when either is not measured);
* ``causal``, ``interval``, ``origin`` of the registry entry; ``error``: why an estimator did
  not run (a column the log lacks, an exception), with NaN times.

    python -m vehicle_observers.bench.estimators [--quick] [--plugin MODULE ...]
"""

from __future__ import annotations

import inspect
import math
import sys
import time

from vehicle_observers.data.scenarios import sine_with_dwell
from vehicle_observers.estimation import available
from vehicle_observers.models.vehicle import KalmanTuning, load_vehicle

#: seed of the generated log
SEED = 0
#: shipped vehicle file of the log and of every estimator
VEHICLE = "yacine2015"
#: untimed first run on the log's first WARM_UP_S seconds [s]
WARM_UP_S = 0.5
#: timed runs per estimator (the best counts) ...
REPEAT = 3
#: ... unless one run takes longer than LONG_S [s]
LONG_S = 1.0
#: the reference of the speed-up column
REFERENCE = "ekf-filterpy"


def bench_log(quick: bool = False):
    """The generated log of the benchmark (:func:`sine_with_dwell`, seed :data:`SEED`)."""
    return sine_with_dwell(seed=SEED, t_after=0.5 if quick else 4.0)


def _accepts(fn, name: str) -> bool:
    """Does ``fn`` take the keyword ``name`` (by name or through ``**kwargs``)?"""
    try:
        params = inspect.signature(fn).parameters.values()
    except (TypeError, ValueError):
        return True
    return any(p.name == name or p.kind is p.VAR_KEYWORD for p in params)


def time_estimator(spec, log, vehicle, tuning=None) -> dict:
    """One row for the registry entry ``spec`` on ``log``: warm-up, then the best of
    :data:`REPEAT` runs (``us_per_step``, ``seconds``; ``error`` when it does not run). The
    warm-up runs on the first :data:`WARM_UP_S` s; an estimator that cannot run on so short
    a log (e.g. one that tunes its noise on the log itself) is warmed up on the whole log."""
    row = {"component": spec.name, "steps": len(log), "seconds": float("nan"),
           "us_per_step": float("nan"), "causal": spec.causal, "interval": spec.interval,
           "origin": spec.origin}
    kw = {"tuning": tuning} if tuning is not None and _accepts(spec.run, "tuning") else {}
    try:
        spec.check(log, vehicle)
        try:
            spec.estimate(log.segment(log.t[0], log.t[0] + WARM_UP_S), vehicle, **kw)
        except Exception:  # noqa: BLE001 - too short for this estimator: warm up on the log
            spec.estimate(log, vehicle, **kw)
        best_us, best_wall = float("inf"), float("inf")
        for _ in range(REPEAT):
            t0 = time.perf_counter()
            tr = spec.estimate(log, vehicle, **kw)
            wall = time.perf_counter() - t0
            us = tr.us_per_step if math.isfinite(tr.seconds) else 1e6 * wall / len(log)
            best_us, best_wall = min(best_us, us), min(best_wall, wall)
            if wall > LONG_S:
                break
    except Exception as exc:  # noqa: BLE001 - reported in the row, the others still run
        row["error"] = f"{type(exc).__name__}: {exc}"
        return row
    row.update(seconds=best_wall, us_per_step=best_us)
    return row


def run(quick: bool = False, plugins=(), names=None, log=None) -> list[dict]:
    """Rows ``{"component", "steps", "seconds", "us_per_step", "speedup_vs_filterpy_ekf",
    "causal", "interval", "origin"[, "error"]}``, one per registered estimator in
    registration order (plug-in modules ``plugins`` loaded first; ``names``: only these;
    ``log``: another drive log than :func:`bench_log`)."""
    specs = available(plugins)
    if names is not None:
        specs = {k: v for k, v in specs.items() if k in names}
    log = bench_log(quick) if log is None else log
    vehicle = load_vehicle(VEHICLE)
    tuning = KalmanTuning(source="sensor-spec defaults (speed benchmark)")
    rows = [time_estimator(spec, log, vehicle, tuning) for spec in specs.values()]
    ref = next((r["us_per_step"] for r in rows if r["component"] == REFERENCE), float("nan"))
    for r in rows:
        us = r["us_per_step"]
        r["speedup_vs_filterpy_ekf"] = ref / us if us > 0 else float("nan")
    return rows


#: columns of the printed table
COLUMNS = ["component", "steps", "us_per_step", "speedup_vs_filterpy_ekf", "seconds", "causal",
           "interval", "error"]


def table(rows, title: str = ""):
    """The rows as a rounded :class:`~vehicle_observers.results.tables.Table` (the columns
    of :data:`COLUMNS` some row has)."""
    from vehicle_observers.results.tables import show_table

    cols = [c for c in COLUMNS if any(c in r for r in rows)]
    return show_table(rows, cols, digits=3, title=title)


def plugin_args(argv) -> list[str]:
    """The modules named by ``--plugin MODULE`` in ``argv``."""
    return [argv[i + 1] for i, a in enumerate(argv[:-1]) if a == "--plugin"]


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    rows = run(quick="--quick" in argv, plugins=plugin_args(argv))
    print(table(rows, f"every registered estimator on the {VEHICLE} sine with dwell "
                      f"({rows[0]['steps'] if rows else 0} steps)"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
