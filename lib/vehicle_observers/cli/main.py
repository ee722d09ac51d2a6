"""Command line: estimate lateral states on your own log.

    python -m vehicle_observers [--plugin MODULE ...] observers
    python -m vehicle_observers estimate LOG.csv --vehicle VEHICLE.toml --observer NAME \\
        --out EST.csv [--tune-window 120] [--max-gap 0.5] [--accept-out-of-range]
        [--progress/--no-progress]
    python -m vehicle_observers tune LOG.csv --vehicle VEHICLE.toml [--tune-window 120]
    python -m vehicle_observers identify LOG.csv --out VEHICLE.toml --mass M --inertia IZ \\
        --a-f LF --a-r LR [--channels yaw_rate,ay] [--nonlinear auto|yes|no]

``tune`` prints the ML noise tuning of the Kalman observers as a ``[kalman]`` TOML table:
append it to the vehicle file to skip the tuning in later runs.

``LOG.csv`` follows the schema of :mod:`vehicle_observers.data.logs` (``t_s, vx_mps,
delta_roadwheel_rad, yaw_rate_radps`` and optionally ``ay_mps2``, reference ``vy_mps``, ...).
``--vehicle`` is a TOML file (:mod:`vehicle_observers.models.vehicle`) or a built-in name
(``yacine2015``, ``revs250lm``). The output CSV has ``t_s`` and one column per estimate with
its unit in the name, plus ``low_speed`` (1 where the kinematic low-speed model replaced the
observer: standstill, v_x < 2 m/s) and ``reinit`` (1 on the first row after a time gap longer
than ``--max-gap``; the observer restarts there), see :mod:`vehicle_observers.estimation.segments`.
The output is written to ``EST.csv.partial-<pid>`` next to it and renamed when complete (the
partial file is created first, so an unwritable folder fails at once; it is removed on
errors and SIGTERM, and by the next run if a SIGKILL left it). ``--out`` equal to the log is
refused. The log is checked for plausible units before computing
(:func:`vehicle_observers.data.logs.check_plausible`; ``--accept-out-of-range`` accepts a
log that really is out of range) and an output with NaN/inf, or ``|v_y|`` above 30 m/s, is an
error, not a result. When the log has reference columns the benchmark metrics are printed.
Errors: one line on stderr, exit status 2 (bad input), 3 (unexpected internal error), 143
(SIGTERM); never a traceback, never a warning line.

Estimators come from :mod:`vehicle_observers.estimation.registry`: the built-in ones, the
plug-ins installed under the entry-point group ``vehicle_observers.estimators``, the modules
named in ``$VEHICLE_OBSERVERS_PLUGINS`` and those given with ``--plugin MODULE`` (a module on
``sys.path``, or a ``.py`` file).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import signal
import sys
import warnings
from pathlib import Path

import numpy as np

EXIT_INPUT = 2
EXIT_INTERNAL = 3
#: stdout closed by its reader (as if ended by SIGPIPE)
EXIT_PIPE = 141


class CLIError(Exception):
    """A user-facing error (one line)."""


def _add_common(p):
    p.add_argument("log", help="drive log CSV (.csv or .csv.gz), schema of vehicle_observers.data.logs")
    p.add_argument("--vehicle", required=True,
                   help="vehicle TOML file, or a built-in name (yacine2015, revs250lm)")
    p.add_argument("--tune-window", type=float, default=120.0,
                   help="seconds of the log's first stretch in motion used for ML noise tuning "
                        "of the Kalman observers when the vehicle file has no [kalman] table "
                        "(default 120)")
    p.add_argument("--max-gap", type=float, default=0.5,
                   help="a time step longer than this [s] re-initialises the observer "
                        "(default 0.5)")
    p.add_argument("--accept-out-of-range", action="store_true",
                   help="accept a log whose values are outside the plausible ranges of a road "
                        "vehicle in SI units (otherwise refused naming the likely unit mistake)")


def _parser():
    p = argparse.ArgumentParser(prog="python -m vehicle_observers",
                                description="Vehicle lateral-state observers on drive logs.")
    p.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                   help="import MODULE (dotted name, or a .py file) before listing or running: "
                        "its estimators are registered (repeatable)")
    sub = p.add_subparsers(dest="cmd", required=True)
    sub.add_parser("observers", help="list the observers and what each needs")
    e = sub.add_parser("estimate", help="run one observer on a log and write the estimates")
    _add_common(e)
    e.add_argument("--observer", required=True, help="observer name (see 'observers')")
    e.add_argument("--out", required=True, help="output CSV path")
    tu = sub.add_parser("tune", help="ML noise tuning of the Kalman observers on a log; prints "
                                     "a [kalman] table for the vehicle file")
    _add_common(tu)
    _identify_parser(sub)
    _campaign_parser(sub)
    g = e.add_mutually_exclusive_group()
    g.add_argument("--progress", dest="progress", action="store_true", default=None,
                   help="show a progress bar (default: when stderr is a terminal)")
    g.add_argument("--no-progress", dest="progress", action="store_false")
    return p


def _plugins(args) -> list[str]:
    """``--plugin`` values as module names: a ``.py`` path puts its folder on ``sys.path``."""
    mods = []
    for m in getattr(args, "plugin", None) or []:
        if m.endswith(".py"):
            f = Path(m).resolve()
            if not f.is_file():
                raise CLIError(f"--plugin {m}: no such file")
            sys.path.insert(0, str(f.parent))
            m = f.stem
        mods.append(m)
    return mods


def _available(args):
    from vehicle_observers.core.errors import RegistryError
    from vehicle_observers.estimation import available

    try:
        return available(_plugins(args))
    except RegistryError as e:
        raise CLIError(str(e)) from None


def cmd_observers(out=None, args=None):
    out = out or sys.stdout
    from vehicle_observers.estimation.registry import BASE_COLUMNS

    print(f"every observer reads: {', '.join(BASE_COLUMNS)}", file=out)
    for name, s in _available(args).items():
        need = ", ".join(s.columns) or "-"
        opt = ", ".join(s.optional_columns) or "-"
        veh = ", ".join(k for k in s.vehicle_keys)
        flags = ("causal" if s.causal else "OFFLINE") + (", interval" if s.interval else "")
        print(f"{name:18s} {s.description}", file=out)
        print(f"{'':18s}   needs columns: {need}; uses if present: {opt}; vehicle keys: {veh}; "
              f"{flags}", file=out)
    return 0


def _fmt_metrics(m: dict) -> list[str]:
    units = {"vy": "m/s", "beta": "rad", "r": "rad/s", "Ff": "N", "Fr": "N"}
    lines = []
    for q, u in units.items():
        if f"rmse_{q}" in m:
            lines.append(f"  {q:5s} RMSE {m[f'rmse_{q}']:.4g} {u}, max error {m[f'max_{q}']:.4g} {u}")
    for q, u in (("vy", "m/s"), ("r", "rad/s")):
        if f"enclosure_{q}" in m:
            lines.append(f"  {q:5s} enclosure {100 * m[f'enclosure_{q}']:.2f} %, mean width "
                         f"{m[f'width_{q}']:.4g} {u}")
    return lines


#: output columns checked for plausibility: |value| above the bound is a diverged estimate
OUTPUT_BOUNDS = {"vy_mps": 30.0, "yaw_rate_radps": 5.0}


def _check_args(args):
    if not (np.isfinite(args.tune_window) and args.tune_window > 0):
        raise CLIError(f"--tune-window must be a number of seconds > 0, got {args.tune_window}")
    if not (np.isfinite(args.max_gap) and args.max_gap > 0):
        raise CLIError(f"--max-gap must be a number of seconds > 0, got {args.max_gap}")


def _load(args, vehicle, columns=None, progress=None):
    """The log, validated: schema, plausible units (unless --accept-out-of-range)."""
    from vehicle_observers.data.logs import check_plausible, load_log

    log = load_log(args.log, min_vx=None, columns=columns, progress=progress)
    check_plausible(log, vehicle.params.a_f + vehicle.params.a_r, args.accept_out_of_range)
    return log


def _check_output(name, table: dict, accept: bool):
    """An output with NaN/inf (or a diverged v_y / yaw rate) is an error, not a result."""
    for c, v in table.items():
        bad = ~np.isfinite(v)
        if bad.any():
            i = int(np.argmax(bad))
            raise CLIError(f"observer {name!r} produced {int(bad.sum())} NaN/inf value(s) in "
                           f"{c!r}, first at row {i}; nothing written")
    for c, lim in OUTPUT_BOUNDS.items():
        v = table.get(c)
        if v is not None and not accept and np.abs(v).max() > lim:
            i = int(np.argmax(np.abs(v) > lim))
            raise CLIError(f"observer {name!r} diverged: {c!r} = {v[i]:.4g} at row {i} "
                           f"(|value| > {lim:g} is implausible); nothing written")


def _same_file(a: Path, b: Path) -> bool:
    try:
        return b.exists() and os.path.samefile(a, b)
    except OSError:
        return a.resolve() == b.resolve()


def _out_path(args) -> Path:
    out_path = Path(args.out)
    if out_path.is_dir():
        raise CLIError(f"--out {args.out}: is a directory, expected a file path")
    if not out_path.parent.exists() and str(out_path.parent) not in ("", "."):
        raise CLIError(f"--out {args.out}: folder {out_path.parent} does not exist")
    if Path(args.log).exists() and _same_file(Path(args.log), out_path):
        raise CLIError(f"--out {args.out}: is the input log; choose another file")
    return out_path


class _Bar:
    """Progress bar on stderr with stages (loading 0-10 %, design/tuning 10-40 %, estimation
    40-85 %, writing 85-100 %)."""

    def __init__(self, show, desc):
        from tqdm import tqdm

        self.bar = tqdm(total=100, disable=not show, file=sys.stderr, desc=desc,
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| {postfix}")

    def stage(self, pct, what):
        self.bar.n = int(pct)
        self.bar.set_postfix_str(what, refresh=False)
        self.bar.refresh()

    def part(self, lo, hi, what):
        return lambda k, n: self.stage(lo + (hi - lo) * k / max(n, 1), f"{what} {k}/{n}")

    def observer(self, k, N, what="step"):
        if what == "tuning":
            self.stage(10 + 30 * k / max(N, 1), f"ML noise tuning, evaluation {k}")
        else:
            self.stage(40 + 45 * k / max(N, 1), f"row {k}/{N}")


def cmd_estimate(args, out=None):
    out = out or sys.stdout
    from vehicle_observers.data.logs import OPTIONAL, REQUIRED, AtomicOutput
    from vehicle_observers.estimation import score
    from vehicle_observers.models.vehicle import load_vehicle

    obs = _available(args)
    if args.observer not in obs:
        raise CLIError(f"unknown observer {args.observer!r}; available: {', '.join(obs)}")
    spec = obs[args.observer]
    _check_args(args)
    out_path = _out_path(args)
    show = sys.stderr.isatty() if args.progress is None else args.progress
    bar = _Bar(show, args.observer)
    try:
        vehicle = load_vehicle(args.vehicle)
        try:
            sink = AtomicOutput(out_path).__enter__()
        except OSError as exc:
            raise CLIError(f"--out {args.out}: cannot write there "
                           f"({exc.strerror or exc})") from None
        try:
            # every schema column is read and checked (an absurd value in any channel is
            # refused), plus the emulated logs' yaw-rate truth used for scoring
            cols = (*REQUIRED, *OPTIONAL, "yaw_rate_true_radps")
            log = _load(args, vehicle, cols, bar.part(0, 10, "loading, bytes"))
            bar.stage(10, "design / tuning")
            est = spec.estimate(log, vehicle, window_s=args.tune_window,
                                progress=bar.observer, max_gap=args.max_gap, cache=True)
            table = est.table()
            _check_output(spec.name, table, args.accept_out_of_range)
            bar.stage(85, "writing")
            sink.commit(table, bar.part(85, 100, "writing, rows"))
        except OSError as exc:
            raise CLIError(f"--out {args.out}: cannot write ({exc.strerror or exc})") from None
        finally:
            sink.__exit__(None, None, None)
        bar.stage(100, "done")
    finally:
        bar.bar.close()
    _report(args, spec, est, log, vehicle, out_path, score(est, log), out)
    return 0


def _report(args, spec, est, log, vehicle, out_path, m, out):
    n = len(est.t)
    low = int(np.sum(est.flags["low_speed"]))
    print(f"{spec.name} on {Path(args.log).name} ({n} samples, {log.duration:.1f} s) with "
          f"{vehicle.name}: {est.us_per_step:.3g} us/step (compiled kernels), real-time factor "
          f"{log.duration / max(est.seconds, 1e-12):.3g}x; design/tuning "
          f"{est.design_seconds:.2f} s", file=out)
    print(f"low-speed model on {low} row(s) (low_speed = 1); "
          f"{int(np.sum(est.flags['reinit']))} re-initialisation(s) after gaps > "
          f"{args.max_gap:g} s (reinit = 1)", file=out)
    if not est.causal:
        print("note: this estimator is OFFLINE (uses future samples)", file=out)
    print(f"wrote {out_path} (columns: {', '.join(est.table())})", file=out)
    if any(k.startswith("rmse_vy") or k.startswith("enclosure") or k.startswith("rmse_F")
           for k in m):
        print("metrics against the log's reference columns:", file=out)
        for line in _fmt_metrics(m):
            print(line, file=out)


def cmd_tune(args, out=None):
    out = out or sys.stdout
    from vehicle_observers.estimation.kalman_runs import kalman_tuning
    from vehicle_observers.models.vehicle import load_vehicle

    _check_args(args)
    vehicle = load_vehicle(args.vehicle)
    log = _load(args, vehicle, ("ay_mps2",))
    tun, _ = kalman_tuning(log, dataclasses.replace(vehicle, kalman=None),
                           window_s=args.tune_window, max_gap=args.max_gap, cache=True)
    print(f"# {tun.source}", file=out)
    print("[kalman]", file=out)
    for k in ("q_vy", "q_r", "q_b", "R_r", "R_ay"):
        print(f"{k} = {getattr(tun, k):.6g}", file=out)
    return 0


def _on_sigterm(signum, frame):
    """SIGTERM: remove the partial output, one line, exit 143 at once (no exception is
    raised: it could surface inside a pyarrow or numba call)."""
    from vehicle_observers.data.logs import ACTIVE_PARTIALS

    for p in list(ACTIVE_PARTIALS):
        try:
            p.unlink()
        except OSError:
            pass
    os.write(2, b"error: terminated by SIGTERM (no output written)\n")
    os._exit(143)


#: errors caused by the input (exit status 2)
def _input_errors():
    from vehicle_observers.core.errors import InfeasibleDesign, LogFormatError
    from vehicle_observers.models.vehicle import VehicleFileError

    return (LogFormatError, VehicleFileError, InfeasibleDesign, ValueError)


def _run(args):
    try:
        if args.cmd == "observers":
            return cmd_observers(args=args)
        if args.cmd == "tune":
            return cmd_tune(args)
        if args.cmd == "identify":
            return cmd_identify(args)
        if args.cmd == "campaign":
            return cmd_campaign(args)
        return cmd_estimate(args)
    except _input_errors() as exc:
        from vehicle_observers.core.errors import InfeasibleDesign

        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if isinstance(exc, InfeasibleDesign):
            lmi = f" (LMI {exc.lmi})" if getattr(exc, "lmi", None) else ""
            msg = f"observer {getattr(args, 'observer', 'tune')!r}: design infeasible{lmi}: {msg}"
        raise CLIError(msg) from None


def _identify_parser(sub):
    i = sub.add_parser("identify", help="cornering stiffness per axle (and friction past 0.5 g) "
                                        "from a log's measured channels; writes a vehicle TOML")
    i.add_argument("log")
    i.add_argument("--out", required=True, help="vehicle TOML to write")
    for flag, what in (("--mass", "m [kg]"), ("--inertia", "I_z [kg m^2]"),
                       ("--a-f", "CG to front axle [m]"), ("--a-r", "CG to rear axle [m]")):
        i.add_argument(flag, type=float, required=True, help=what)
    i.add_argument("--name", default=None, help="vehicle name (default: the log's file name)")
    i.add_argument("--channels", default="yaw_rate,ay",
                   help="measured channels to fit: yaw_rate and/or ay (default both)")
    i.add_argument("--nonlinear", choices=("auto", "yes", "no"), default="auto",
                   help="fit the friction peak mu: auto = only if max|a_y| >= 0.5 g")


def cmd_identify(args, out=None):
    """``identify``: :func:`vehicle_observers.data.identification.identify_stiffness` on the
    measured steering, speed, yaw rate and lateral acceleration (never the reference v_y);
    prints the estimates with 95 % intervals; writes ``--out`` only when every parameter is
    identifiable (else exit 2 naming the combination that is)."""
    out = out or sys.stdout
    import os
    import tempfile

    from vehicle_observers.core.errors import LogFormatError
    from vehicle_observers.data import identification as idf
    from vehicle_observers.data.logs import load_log
    from vehicle_observers.models.vehicle import VehicleFileError, load_vehicle

    chans = tuple(c.strip() for c in args.channels.split(",") if c.strip())
    try:
        log = load_log(args.log, min_vx=1.0)
        fit = idf.identify_stiffness(log, args.mass, args.inertia, args.a_f, args.a_r,
                                     channels=chans,
                                     nonlinear={"auto": "auto", "yes": True, "no": False}[
                                         args.nonlinear])
    except (LogFormatError, ValueError) as exc:
        raise CLIError(str(exc).splitlines()[0]) from None
    for n, v, lo, hi in zip(fit.names, fit.value, fit.ci_lo, fit.ci_hi):
        print(f"{n} = {v:.6g}  95% CI [{lo:.6g}, {hi:.6g}]", file=out)
    print("noise std (from the data): " + ", ".join(f"{c} {v:.3g}" for c, v in
                                                    fit.noise_std.items()), file=out)
    if not fit.identifiable:
        raise CLIError(fit.message)
    name = args.name or Path(args.log).name
    text = idf.vehicle_toml(fit, name, (float(log.vx.min()), float(log.vx.max())),
                            source=Path(args.log).name)
    dst = Path(args.out)
    fd, tmp = tempfile.mkstemp(dir=dst.parent if str(dst.parent) else ".", suffix=".toml")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        load_vehicle(tmp)                      # the other commands must accept it
        os.replace(tmp, dst)
    except VehicleFileError as exc:
        raise CLIError(f"identified values do not make a valid vehicle file: {exc}") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    print(f"{fit.message}\nwrote {dst}", file=out)
    return 0


def main(argv=None) -> int:
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse already printed a one-line usage error
        return EXIT_INPUT if exc.code else 0
    prev = signal.signal(signal.SIGTERM, _on_sigterm) if _main_thread() else None
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")   # one-line errors: no warning lines from libraries
            return _run(args)
    except CLIError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        print("error: interrupted (no output written)", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader of stdout went away (e.g. `| head -1`): leave quietly, as a process
        # ended by SIGPIPE would (128 + 13); the output file, if any, is already complete
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return EXIT_PIPE
    except Exception as exc:  # noqa: BLE001 - last resort: one line, never a traceback
        msg = str(exc).splitlines()[0] if str(exc) else ""
        print(f"error: internal error {type(exc).__name__}: {msg}", file=sys.stderr)
        return EXIT_INTERNAL
    finally:
        if prev is not None:
            signal.signal(signal.SIGTERM, prev)


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


def console(argv=None):
    """Process entry point (``python -m vehicle_observers``, the ``vehicle-observers`` script):
    :func:`main`, then flush and leave with ``os._exit``. Skipping the interpreter's teardown
    avoids a native abort ("terminate called without an active exception", exit -6) seen when
    the process ended while a thread of pyarrow's or numba's pool was still being torn down;
    everything the command writes is complete (renamed into place) before ``main`` returns."""
    code = main(argv)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(code)


def _campaign_parser(sub):
    c = sub.add_parser("campaign", help="robustness campaign: every estimator against cars, "
                                        "parameter errors and noise, on Dask; 'campaign report "
                                        "DIR' writes its tables and figures")
    c.add_argument("spec", metavar="SPEC.toml|report",
                   help="campaign spec (vehicle_observers.campaign.spec), or 'report'")
    c.add_argument("dir", nargs="?", metavar="DIR", help="with 'report': the campaign folder")
    c.add_argument("--out", help="results folder (one Parquet file per batch; a re-run resumes)")
    c.add_argument("--scheduler", metavar="ADDRESS",
                   help="a running Dask scheduler, e.g. tcp://127.0.0.1:8786 (default: an "
                        "embedded cluster of one single-threaded worker process per core)")
    c.add_argument("--workers", type=int, help="worker processes of the embedded cluster")
    c.add_argument("--engine", choices=("dask", "serial"), default="dask",
                   help="serial: every batch in this process (same results)")
    g = c.add_mutually_exclusive_group()
    g.add_argument("--progress", dest="progress", action="store_true", default=None,
                   help="progress bar on stderr (default: when stderr is a terminal)")
    g.add_argument("--no-progress", dest="progress", action="store_false")


def cmd_campaign(args, out=None):
    """``campaign SPEC.toml --out DIR``: :func:`vehicle_observers.campaign.run` (the spec is
    checked completely before anything runs); ``campaign report DIR``:
    :func:`vehicle_observers.campaign.report.write_report`."""
    out = out or sys.stdout
    from vehicle_observers import campaign

    if args.plugin:
        raise CLIError("campaign: name plug-in modules in the spec's 'plugins' key (they are "
                       "imported on every worker), not with --plugin")
    if args.spec == "report":
        if not args.dir:
            raise CLIError("campaign report: give the campaign folder (campaign report DIR)")
        from vehicle_observers.campaign.report import write_report

        t = write_report(args.dir)
        s = t["spec"]
        print(f"campaign {s.doc['name']} ({s.sha256[:12]}): {t['rows']} of {s.n_tasks} "
              f"simulations, {len(t['lmi_points'])} of {len(s.lmi_points)} LMI map points", file=out)
        for r in t["failures"]:
            print(f"  {r['estimator']:22s} failed {r['failed']}/{r['n']}", file=out)
        for r in t["best"]:
            print(f"  best at {r['parameter']} {r['error']:+g}: {r['best']} "
                  f"(median v_y RMSE {r['best_median_rmse_vy']:.4g} m/s)", file=out)
        print(f"wrote {len(t['files'])} files to {Path(t['files'][0]).parent}", file=out)
        return 0
    if args.dir:
        raise CLIError(f"campaign: unexpected argument {args.dir!r} (campaign SPEC.toml --out DIR)")
    if not args.out:
        raise CLIError("campaign: --out DIR is required (the results folder)")
    res = campaign.run(args.spec, args.out, scheduler=args.scheduler, engine=args.engine,
                       workers=args.workers, progress=args.progress)
    print(res.line(), file=out)
    return 0


if __name__ == "__main__":
    console()
