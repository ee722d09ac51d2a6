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

    python -m vehicle_observers.bench.estimators [--quick] [--plugin MODULE|FILE.py ...]
        [--only NAME ...] [--log LOG.csv --vehicle VEHICLE]

``--plugin`` loads a plug-in like the command line (a module name or a ``.py`` file:
:func:`vehicle_observers.estimation.registry.load_plugin`); ``--only NAME`` (repeatable, or
comma-separated) times only those estimators (``ekf-filterpy`` is added as the reference of
the speed-up column); ``--log`` / ``--vehicle`` time them on another log (e.g. the shipped
Revs log, which has ``ax_mps2``) instead of the generated one.
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


def run(quick: bool = False, plugins=(), names=None, log=None, vehicle=None) -> list[dict]:
    """Rows ``{"component", "steps", "seconds", "us_per_step", "speedup_vs_filterpy_ekf",
    "causal", "interval", "origin"[, "error"]}``, one per registered estimator in
    registration order (plug-in modules ``plugins`` loaded first; ``names``: only these;
    ``log``, ``vehicle``: another drive log than :func:`bench_log` and its vehicle file)."""
    specs = available(plugins)
    if names is not None:
        specs = {k: v for k, v in specs.items() if k in names}
    log = bench_log(quick) if log is None else log
    vehicle = load_vehicle(VEHICLE) if vehicle is None else vehicle
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


def parse_args(argv, prog="python -m vehicle_observers.bench.estimators"):
    """The bench's options (module docstring)."""
    import argparse

    ap = argparse.ArgumentParser(prog=prog)
    ap.add_argument("--quick", action="store_true", help="a shorter generated log")
    ap.add_argument("--plugin", action="append", default=[], metavar="MODULE|FILE.py")
    ap.add_argument("--only", action="append", default=[], metavar="NAME",
                    help="time only these estimators (repeatable or comma-separated)")
    ap.add_argument("--log", help="time on this drive log instead of the generated one")
    ap.add_argument("--vehicle", help="the vehicle file (or built-in name) of --log")
    return ap.parse_args(argv)


def selection(args) -> tuple[list[str] | None, object, object]:
    """``(names or None, log or None, vehicle or None)`` of parsed options; raises
    ``SystemExit(2)`` with one line on an unknown name or a log without a vehicle."""
    from vehicle_observers.core.errors import RegistryError

    try:
        specs = available(args.plugin)
    except RegistryError as exc:
        sys.exit(f"error: {exc}")
    only = [n.strip() for o in args.only for n in o.split(",") if n.strip()] or None
    if only:
        bad = [n for n in only if n not in specs]
        if bad:
            sys.exit(f"error: --only: unknown estimator(s) {', '.join(bad)}; available: "
                     f"{', '.join(specs)}")
        only = list(dict.fromkeys([*only, REFERENCE]))
    log = vehicle = None
    if args.log:
        if not args.vehicle:
            sys.exit("error: --log needs --vehicle (the log's vehicle file)")
        from vehicle_observers.data.logs import load_log

        log, vehicle = load_log(args.log, min_vx=None), load_vehicle(args.vehicle)
    return only, log, vehicle


def main(argv=None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else list(argv))
    only, log, vehicle = selection(args)
    rows = run(quick=args.quick, plugins=args.plugin, names=only, log=log, vehicle=vehicle)
    print(table(rows, f"{'the chosen' if only else 'every registered'} estimator(s) on "
                      f"{log.source if log is not None else f'the {VEHICLE} sine with dwell'} "
                      f"({rows[0]['steps'] if rows else 0} steps)"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
