"""Command line: estimate lateral states on your own log.

    python -m vehicle_observers [--plugin MODULE|FILE.py ...] [--debug] observers
    python -m vehicle_observers estimate LOG.csv --vehicle VEHICLE.toml --observer NAME \\
        --out EST.csv [--set KEY=VALUE ...] [--tune-window 120] [--max-gap 0.5]
        [--accept-out-of-range] [--accept-mismatch] [--timeout SECONDS] [--progress/--no-progress]
    python -m vehicle_observers tune LOG.csv --vehicle VEHICLE.toml [--tune-window 120]
    python -m vehicle_observers identify LOG.csv --out VEHICLE.toml --mass M --inertia IZ \\
        --a-f LF --a-r LR [--channels yaw_rate,ay] [--nonlinear auto|yes|no] [--window 120]

``tune`` prints the ML noise tuning of the Kalman observers as a ``[kalman]`` TOML table:
append it to the vehicle file to skip the tuning in later runs (a log without ``ay_mps2``
is refused: the a_y noise and bias drift cannot be identified from it).

``LOG.csv`` follows the schema of :mod:`vehicle_observers.data.logs` (``t_s, vx_mps,
delta_roadwheel_rad, yaw_rate_radps`` and optionally ``ay_mps2``, reference ``vy_mps``, ...,
and any ``<quantity>_<unit>`` column an estimator declares, e.g. ``ax_mps2``: read and
checked against its unit's range only when the chosen estimator reads it);
it must be a regular file (a FIFO or device is refused: it could block forever).
``--vehicle`` is a TOML file (:mod:`vehicle_observers.models.vehicle`) or a built-in name
(``yacine2015``, ``revs250lm``). The output CSV has ``t_s`` and one column per estimate with
its unit in the name, plus ``low_speed`` (1 where the kinematic low-speed model replaced the
observer: standstill, v_x < 2 m/s) and ``reinit`` (1 on the first row after a time gap longer
than ``--max-gap``; the observer restarts there), see :mod:`vehicle_observers.estimation.segments`.

Outputs (``estimate --out``, ``identify --out``) are checked before any computing
(:func:`vehicle_observers.data.logs.check_output`): an output that is an input of the same
command (log, vehicle file, plug-in; whatever the spelling: symlink, hard link, relative
path), a folder or special file, in a missing folder, or whose suffix is not written
(``.csv`` / ``.csv.gz`` for estimates, gzip-compressed for ``.gz``; ``.toml`` for vehicle
files) is refused. The output is written to a hidden partial file next to it and renamed
when complete (:class:`~vehicle_observers.data.logs.AtomicOutput`: created first, so an
unwritable folder fails at once; removed on errors and on SIGTERM, SIGINT and SIGHUP, and by
a later run if a SIGKILL left it; a user's file is never removed). The log is checked for
plausible units before computing (:func:`vehicle_observers.data.logs.check_plausible`,
including a change of unit inside the log; ``--accept-out-of-range`` accepts a log that
really is out of range), the options against the log (``--max-gap`` at least
:data:`MIN_GAP_PERIODS` sample periods), and the vehicle file against the log
(:mod:`vehicle_observers.estimation.consistency`: refused when it cannot be this car unless
``--accept-mismatch``, one warning line when doubtful). An output with NaN/inf, or ``|v_y|``
above 30 m/s, is an error, not a result. When the log has reference columns the benchmark
metrics are printed.
``--set KEY=VALUE`` (repeatable) passes an option of the estimator, typed from its declared
default (``observers`` lists them); an unknown key or a malformed value is one line, exit 2.
Beside the output, ``EST.csv.provenance.json`` records what made it
(:func:`vehicle_observers.campaign.provenance.code_provenance`: package version, the hash of
the estimator's module source and of each plug-in's, the options).

Errors: one line on stderr, exit status 2 (bad input, including bad options), 3
(a plug-in's code raised: the message names the plug-in and its file:line; or an unexpected
internal error), 128 + signal number (SIGHUP 129, SIGINT 130, SIGTERM 143); no traceback
unless ``--debug``. Warnings: at most one line on stderr, after a successful run; with
``--debug`` every warning is shown (numerical warnings of numpy included) and an error
prints its traceback. A reference column, read by no estimator, out of range or
changing scale gets a warning of its own: only the columns the estimator reads can refuse a log.

Estimators come from :mod:`vehicle_observers.estimation.registry`: the built-in ones, the
plug-ins installed under the entry-point group ``vehicle_observers.estimators``, the modules
named in ``$VEHICLE_OBSERVERS_PLUGINS`` and those given with ``--plugin MODULE`` (a module on
``sys.path``, or a ``.py`` file).
"""

from __future__ import annotations

import argparse
import dataclasses
import errno
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
#: signals that end a run like SIGTERM: partial output removed, one line, exit 128 + signum
SIGNALS = ("SIGTERM", "SIGINT", "SIGHUP")
#: ``--max-gap`` must cover at least this many median sample periods of the log (a shorter
#: one restarts the observer on every row)
MIN_GAP_PERIODS = 3.0
#: suffixes of the files each command writes (the format follows the suffix)
ESTIMATE_SUFFIXES = (".csv", ".csv.gz")
VEHICLE_SUFFIXES = (".toml",)


class CLIError(Exception):
    """A user-facing error (one line)."""


class _UsageError(Exception):
    """A command-line usage error from argparse (one line)."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (the stock parser prints the usage block, up to 8
    lines, before the message)."""

    def error(self, message):
        raise _UsageError(f"{self.prog}: {message} (see --help)")


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
                        f"(default 0.5; at least {MIN_GAP_PERIODS:g} sample periods of the log)")
    p.add_argument("--accept-out-of-range", action="store_true",
                   help="accept a log whose values are outside the plausible ranges of a road "
                        "vehicle in SI units (otherwise refused naming the likely unit mistake)")
    p.add_argument("--accept-mismatch", action="store_true",
                   help="go on when the vehicle file cannot be the log's car (tyres, axle "
                        "distances or speed box contradict the log; otherwise refused)")


def _parser():
    p = _Parser(prog="python -m vehicle_observers",
                description="Vehicle lateral-state observers on drive logs.")
    p.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                   help="import MODULE (dotted name, or a .py file) before listing or running: "
                        "its estimators are registered (repeatable; campaigns load it on "
                        "every worker)")
    p.add_argument("--debug", action="store_true",
                   help="for observer writers: show every warning (numpy's included) and the "
                        "traceback of an error")
    sub = p.add_subparsers(dest="cmd", required=True)
    _add_plugin_options(sub.add_parser("observers", help="list the observers and what each "
                                                         "needs"))
    e = sub.add_parser("estimate", help="run one observer on a log and write the estimates")
    _add_common(e)
    _add_plugin_options(e)
    e.add_argument("--observer", required=True, help="observer name (see 'observers')")
    e.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="options",
                   help="an option of the observer, typed from its declared default "
                        "(repeatable; 'observers' lists them)")
    e.add_argument("--out", required=True,
                   help="output CSV path (.csv, or .csv.gz written gzip-compressed)")
    e.add_argument("--timeout", type=float, default=None, metavar="SECONDS",
                   help="stop when the run takes longer (a plug-in that never returns): one "
                        "line, exit status 2, nothing written (default: no limit)")
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


def _add_plugin_options(p):
    """``--plugin`` and ``--debug`` after a command too (``estimate ... --plugin f.py``)."""
    p.add_argument("--plugin", action="append", default=[], dest="sub_plugin",
                   metavar="MODULE", help="as before the command: import MODULE or FILE.py")
    p.add_argument("--debug", action="store_true", dest="sub_debug",
                   help="as before the command: warnings and tracebacks shown")


def _plugins(args) -> list[str]:
    """``--plugin`` values, before and after the command (module names or ``.py`` paths:
    :func:`registry.load_plugin`)."""
    return list(getattr(args, "plugin", None) or []) + list(getattr(args, "sub_plugin", None)
                                                             or [])


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
        need = ", ".join(s.columns) or ("-" if s.columns_declared else
                                        "declared by the observer once built")
        opt = ", ".join(s.optional_columns) or "-"
        veh = ", ".join(k for k in s.vehicle_keys)
        flags = ("causal" if s.causal else "OFFLINE") + (", interval" if s.interval else "")
        print(f"{name:18s} {s.description}", file=out)
        print(f"{'':18s}   needs columns: {need}; uses if present: {opt}; vehicle keys: {veh}; "
              f"{flags}", file=out)
        if s.options:
            print(f"{'':18s}   options (--set): "
                  + ", ".join(f"{k}={v!r}" for k, v in s.options.items()), file=out)
        if s.plugin:
            print(f"{'':18s}   plug-in: {s.origin} ({s.source_file or 'no file'})", file=out)
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


def _check_options_against_log(args, log):
    """Options that would defeat the estimator on this log are refused (one line)."""
    if len(log) < 2:
        return
    dt = float(np.median(np.diff(log.t)))
    if args.max_gap < MIN_GAP_PERIODS * dt:
        raise CLIError(f"--max-gap {args.max_gap:g} s is shorter than {MIN_GAP_PERIODS:g} sample "
                       f"periods of the log (median step {dt:.4g} s): the observer would restart "
                       f"on every row; use at least {MIN_GAP_PERIODS * dt:.3g} s (default 0.5)")


def _load(args, vehicle, columns=None, progress=None, spec=None):
    """The log, validated: schema, plausible units (unless --accept-out-of-range). With an
    estimator ``spec``, only the columns it reads are checked (:func:`_reads`); the others
    (references) are checked by :func:`_reference_warning`."""
    from vehicle_observers.data.logs import check_plausible, load_log

    log = load_log(args.log, min_vx=None, columns=columns, progress=progress)
    if spec is not None:
        check_plausible(log, accept=True)        # absurd values in any column: refused always
    check_plausible(log if spec is None else _reads(log, spec),
                    vehicle.params.a_f + vehicle.params.a_r, args.accept_out_of_range)
    return log


def _reads(log, spec):
    """The log restricted to the columns ``spec`` reads (required and optional, schema and
    ``<quantity>_<unit>`` columns alike)."""
    from vehicle_observers.data.logs import _ATTR, DriveLog

    reads = set(spec.needs) | set(spec.optional_columns)
    kw = {a: getattr(log, a) for c, a in _ATTR.items() if c in reads}
    return DriveLog(**kw, extra={c: v for c, v in log.extra.items() if c in reads},
                    source=log.source)


def _reference_warning(log, spec) -> str | None:
    """One warning line when a column ``spec`` does not read (a reference, scored only)
    changes scale or leaves its plausible range: the metrics against it are then doubtful,
    the estimate is not."""
    from vehicle_observers.data.logs import _ATTR, PLAUSIBLE, scale_change

    reads = set(spec.needs) | set(spec.optional_columns)
    refs = [c for c, a in _ATTR.items() if c not in reads and getattr(log, a) is not None]
    if not refs:
        return None
    msg = scale_change(log, columns=refs)
    if msg is None:
        for c in refs:
            lo, hi, why = PLAUSIBLE.get(c, (-np.inf, np.inf, ""))
            v = getattr(log, _ATTR[c])
            out = (v < lo) | (v > hi)
            if out.any():
                i = int(np.argmax(out))
                msg = (f"column {c!r} = {v[i]:.4g} at row {i} is outside [{lo:g}, {hi:g}]: "
                       f"{why}")
                break
    if msg is None:
        return None
    return (f"warning: reference column, read by no estimator here, only scored: {msg} "
            "(the metrics against it may be wrong; the estimate is not affected)")


def _check_vehicle(args, log, vehicle, spec=None) -> str | None:
    """:func:`consistency.check_vehicle_log`: raises CLIError when the vehicle file cannot be
    the log's car (unless --accept-mismatch); returns the warning line when doubtful."""
    from vehicle_observers.estimation.consistency import check_vehicle_log

    box = spec is not None and {"uncertainty.vx_min", "uncertainty.vx_max"} <= set(
        spec.vehicle_keys)
    res = check_vehicle_log(log, vehicle, box=box, max_gap=args.max_gap)
    if res.problems and not args.accept_mismatch:
        raise CLIError(f"{res.message()} (--accept-mismatch to go on)")
    if res.problems or res.doubts:
        return f"warning: {res.message()}"
    return None


def _check_output(spec, table: dict, accept: bool):
    """An output with NaN/inf (or a diverged v_y / yaw rate) is an error, not a result. NaN
    from a plug-in is the plug-in's error (:class:`PluginError`, exit 3, naming the file:line
    of the code that computes its estimates, :func:`registry.output_source`); from a
    built-in estimator, the input's (exit 2)."""
    from vehicle_observers.core.errors import PluginError
    from vehicle_observers.estimation.registry import output_source

    name = spec.name
    for c, v in table.items():
        bad = ~np.isfinite(v)
        if bad.any():
            i = int(np.argmax(bad))
            what = (f"{name!r} produced {int(bad.sum())} NaN/inf value(s) in {c!r}, first "
                    f"at row {i}")
            if spec.plugin:
                at = output_source(spec) or spec.source_file or f"module {spec.origin}"
                raise PluginError(f"plug-in estimator {what}; its estimates are computed at "
                                  f"{at}", name, at)
            raise CLIError(f"observer {what}; nothing written")
    for c, lim in OUTPUT_BOUNDS.items():
        v = table.get(c)
        if v is not None and not accept and np.abs(v).max() > lim:
            i = int(np.argmax(np.abs(v) > lim))
            raise CLIError(f"observer {name!r} diverged: {c!r} = {v[i]:.4g} at row {i} "
                           f"(|value| > {lim:g} is implausible); nothing written")


def _vehicle_path(spec: str) -> str | None:
    """The file a ``--vehicle`` value reads (a path, or the built-in file of that name)."""
    from vehicle_observers.models.vehicle import builtin_vehicles

    if Path(spec).exists():
        return spec
    b = builtin_vehicles().get(str(spec))
    return None if b is None else str(b)


def _inputs(args) -> dict:
    """Every input file of the command, described for the refusal of an output onto it."""
    out = {"the input log": args.log}
    if getattr(args, "vehicle", None):
        out["the vehicle file"] = _vehicle_path(args.vehicle)
    for m in _plugins(args):
        if m.endswith(".py"):
            out[f"the plug-in {m}"] = m
    return out


def _out_path(args, suffixes=ESTIMATE_SUFFIXES) -> Path:
    from vehicle_observers.data.logs import check_output

    return check_output(args.out, _inputs(args), suffixes, "--out")


class _Sink:
    """The output of a command: :class:`AtomicOutput` with one-line errors (an unwritable
    folder at once; a full disk or any write error when committing: nothing is left)."""

    def __init__(self, path: Path, option="--out"):
        from vehicle_observers.data.logs import AtomicOutput

        self.path, self.option = path, option
        self.out = AtomicOutput(path)

    def __enter__(self):
        try:
            self.out.__enter__()
        except OSError as exc:
            raise CLIError(f"{self.option} {self.path}: cannot write there "
                           f"({exc.strerror or exc})") from None
        return self

    def commit(self, fn, *a, **kw):
        try:
            return fn(*a, **kw)
        except OSError as exc:
            text = str(exc)
            full = (exc.errno in (errno.ENOSPC, errno.EDQUOT) or "os error 28" in text
                    or "No space left" in text or "quota exceeded" in text.lower())
            why = "the disk is full" if full else exc.strerror or text
            raise CLIError(f"{self.option} {self.path}: cannot write ({why}); nothing "
                           "written") from None

    def __exit__(self, *exc):
        self.out.__exit__(*exc)
        return False


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


def _warn(line):
    if line:
        print(line, file=sys.stderr)


def _options(spec, args) -> dict:
    """``--set KEY=VALUE`` as typed options of ``spec`` (one line on an unknown key)."""
    from vehicle_observers.core.errors import RegistryError

    try:
        return spec.parse_options(getattr(args, "options", None) or [])
    except RegistryError as exc:
        raise CLIError(f"--set: {exc}") from None


def _undeclared_columns(spec, path) -> tuple:
    """Every ``<quantity>_<unit>`` column of the log's header when ``spec`` knows its
    columns only once built (:attr:`EstimatorSpec.columns_declared`); else none."""
    from vehicle_observers.data.logs import is_log_column, log_header

    if spec.columns_declared:
        return ()
    try:
        return tuple(c for c in log_header(path) if is_log_column(c))
    except Exception:   # noqa: BLE001 - the loader reports an unreadable log itself
        return ()


class _Sidecar:
    """``<out>.provenance.json`` beside an estimate: what made it
    (:func:`vehicle_observers.campaign.provenance.code_provenance`). Built before the
    estimate is committed (an older one is removed then: it would describe other results)
    and written atomically just after it."""

    def __init__(self, out_path: Path, spec, options, args):
        import json

        from vehicle_observers.campaign.provenance import code_provenance

        prov = code_provenance({spec.name: spec}, {spec.name: options}, _plugins(args))
        prov["command"] = {"log": str(args.log), "vehicle": str(args.vehicle),
                           "observer": spec.name, "max_gap": args.max_gap,
                           "tune_window": args.tune_window}
        self.path = self.path_of(out_path)
        self.text = json.dumps(prov, indent=1, sort_keys=True, default=repr)
        try:
            self.path.unlink(missing_ok=True)
        except OSError:
            pass

    @staticmethod
    def path_of(out_path) -> Path:
        out_path = Path(out_path)
        return out_path.with_name(out_path.name + ".provenance.json")

    def commit(self):
        from vehicle_observers.data.logs import AtomicOutput

        with AtomicOutput(self.path, compress=False) as out:
            out.commit_text(self.text + "\n")


def cmd_estimate(args, out=None):
    out = out or sys.stdout
    from vehicle_observers.data.logs import OPTIONAL, REQUIRED
    from vehicle_observers.estimation import score
    from vehicle_observers.models.vehicle import load_vehicle

    obs = _available(args)
    if args.observer not in obs:
        raise CLIError(f"unknown observer {args.observer!r}; available: {', '.join(obs)}")
    spec = obs[args.observer]
    _check_args(args)
    options = _options(spec, args)
    out_path = _out_path(args)
    show = sys.stderr.isatty() if args.progress is None else args.progress
    bar = _Bar(show, args.observer)
    try:
        vehicle = load_vehicle(args.vehicle)
        with _Sink(out_path) as sink:
            # every schema column is read and checked (an absurd value in any channel is
            # refused), plus the emulated logs' yaw-rate truth used for scoring
            cols = (*REQUIRED, *OPTIONAL, "yaw_rate_true_radps", *spec.columns,
                    *spec.optional_columns, *_undeclared_columns(spec, args.log))
            log = _load(args, vehicle, cols, bar.part(0, 10, "loading, bytes"), spec)
            _check_options_against_log(args, log)
            spec.check(log, vehicle)
            warning = _check_vehicle(args, log, vehicle, spec)
            ref_warning = _reference_warning(log, spec)
            bar.stage(10, "design / tuning")
            est = spec.estimate(log, vehicle, window_s=args.tune_window,
                                progress=bar.observer, max_gap=args.max_gap, cache=True,
                                **options)
            table = est.table()
            _check_output(spec, table, args.accept_out_of_range)
            est.info["verdict_info"] = _verdict(est, log, vehicle)
            bar.stage(85, "writing")
            side = _Sidecar(out_path, spec, options, args)
            sink.commit(sink.out.commit, table, bar.part(85, 100, "writing, rows"))
            _write_verdict(out_path, est.info["verdict_info"])
            sink.commit(side.commit)
        bar.stage(100, "done")
    finally:
        bar.bar.close()
    _warn(warning)
    _warn(ref_warning)
    _report(args, spec, est, log, vehicle, out_path, score(est, log), out)
    return 0


def _verdict(est, log, vehicle) -> dict:
    """The identifiability verdict of the estimate with the uncertainty method
    (:func:`vehicle_observers.estimation.calibration.verdict_of`), JSON-ready."""
    from vehicle_observers.estimation.calibration import verdict_of

    v = verdict_of(est, log, vehicle)
    out = {k: (float(x) if isinstance(x, (float, np.floating)) else x) for k, x in v.items()}
    out["estimator"] = est.estimator
    out["uncertainty"] = est.info.get("uncertainty", "the estimator's own")
    return out


def _verdict_path(out_path: Path) -> Path:
    """The verdict's metadata file next to the estimates: ``<out>.verdict.json``."""
    return out_path.with_name(out_path.name + ".verdict.json")


def _write_verdict(out_path: Path, v: dict):
    """Write the verdict metadata (JSON) next to the output, atomically."""
    import json

    with _Sink(_verdict_path(out_path)) as sink:
        sink.commit(sink.out.commit_text, json.dumps(v, indent=1) + "\n")


def _report(args, spec, est, log, vehicle, out_path, m, out):
    n = len(est.t)
    loop = ("the plug-in's run loop, as it timed it" if spec.plugin
            else "compiled kernels, compilation excluded")
    print(f"{spec.name} on {Path(args.log).name} ({n} samples, {log.duration:.1f} s) with "
          f"{vehicle.name}: {est.us_per_step:.3g} us/step ({loop}), real-time factor "
          f"{log.duration / max(est.seconds, 1e-12):.3g}x; design/tuning "
          f"{est.design_seconds:.2f} s", file=out)
    if "low_speed" in est.flags and "reinit" in est.flags:
        print(f"low-speed model on {int(np.sum(est.flags['low_speed']))} row(s) (low_speed = "
              f"1); {int(np.sum(est.flags['reinit']))} re-initialisation(s) after gaps > "
              f"{args.max_gap:g} s (reinit = 1)", file=out)
    else:
        print("no row flags (low_speed, reinit): this estimator runs on the whole log as it "
              "is", file=out)
    if not est.causal:
        print("note: this estimator is OFFLINE (uses future samples)", file=out)
    print(f"wrote {out_path} (columns: {', '.join(est.table())}) and its provenance "
          f"{_Sidecar.path_of(out_path).name}", file=out)
    if any(k.startswith("rmse_vy") or k.startswith("enclosure") or k.startswith("rmse_F")
           for k in m):
        print("metrics against the log's reference columns:", file=out)
        for line in _fmt_metrics(m):
            print(line, file=out)
    if est.info.get("auto_line"):
        print(est.info["auto_line"], file=out)
    v = est.info.get("verdict_info")
    if v:
        print(f"identifiability verdict: {v['verdict_line']}", file=out)
        print(f"wrote {_verdict_path(out_path)} (verdict, reason, uncertainty method)", file=out)


#: what the ML tuning reads from the a_y channel (named when a log has none)
_AY_PARAMS = "R_ay (the a_y noise) and q_b (the drift of the a_y bias)"


def cmd_tune(args, out=None):
    out = out or sys.stdout
    from vehicle_observers.estimation.kalman_runs import kalman_tuning
    from vehicle_observers.models.vehicle import load_vehicle

    _check_args(args)
    vehicle = load_vehicle(args.vehicle)
    log = _load(args, vehicle, ("ay_mps2",))
    _check_options_against_log(args, log)
    if log.ay is None:
        raise CLIError(f"{Path(args.log).name}: no 'ay_mps2' column: tune cannot identify "
                       f"{_AY_PARAMS} from the yaw rate alone, and a [kalman] table with "
                       "defaults for them would look fitted; nothing printed (estimate tunes "
                       "q_vy, q_r, R_r on such a log at run time)")
    warning = _check_vehicle(args, log, vehicle)
    tun, _ = kalman_tuning(log, dataclasses.replace(vehicle, kalman=None),
                           window_s=args.tune_window, max_gap=args.max_gap, cache=True)
    _warn(warning)
    print(f"# {tun.source}", file=out)
    print("[kalman]", file=out)
    for k in ("q_vy", "q_r", "q_b", "R_r", "R_ay"):
        print(f"{k} = {getattr(tun, k):.6g}", file=out)
    return 0


def _on_signal(signum, frame):
    """SIGTERM, SIGINT, SIGHUP: remove the partial output, one line, exit 128 + signum at
    once (no exception is raised: it could surface inside a pyarrow or numba call)."""
    from vehicle_observers.data.logs import discard_active_partials

    discard_active_partials()
    name = signal.Signals(signum).name
    what = "interrupted" if signum == signal.SIGINT else "terminated"
    os.write(2, f"error: {what} by {name} (no output written)\n".encode())
    os._exit(128 + signum)


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
        with _Deadline(getattr(args, "timeout", None), f"observer {args.observer!r}"):
            return cmd_estimate(args)
    except _input_errors() as exc:
        from vehicle_observers.core.errors import InfeasibleDesign

        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if isinstance(exc, InfeasibleDesign):
            lmi = f" (LMI {exc.lmi})" if getattr(exc, "lmi", None) else ""
            msg = f"observer {getattr(args, 'observer', 'tune')!r}: design infeasible{lmi}: {msg}"
        raise CLIError(msg) from None


class _Deadline:
    """``estimate --timeout``: a watchdog thread that, when the run outlasts it, removes the
    partial output, writes one line and ends the process with exit status 2 (the main thread
    may be stuck in a plug-in that never returns: no exception could reach it; a loop inside
    one C call that holds the GIL for ever is beyond any thread's reach)."""

    def __init__(self, seconds, what: str):
        if seconds is not None and not (np.isfinite(seconds) and seconds > 0):
            raise CLIError(f"--timeout must be a number of seconds > 0, got {seconds:g}")
        self.seconds, self.what, self.timer = seconds, what, None

    def _fire(self):
        from vehicle_observers.data.logs import discard_active_partials

        discard_active_partials()
        os.write(2, f"error: {self.what} ran longer than --timeout {self.seconds:g} s; stopped, "
                    "nothing written\n".encode())
        os._exit(EXIT_INPUT)

    def __enter__(self):
        if self.seconds is not None:
            import threading

            self.timer = threading.Timer(self.seconds, self._fire)
            self.timer.daemon = True
            self.timer.start()
        return self

    def __exit__(self, *exc):
        if self.timer is not None:
            self.timer.cancel()
        return False


def _identify_parser(sub):
    i = sub.add_parser("identify", help="cornering stiffness per axle (and friction past 0.5 g) "
                                        "from a log's measured channels; writes a vehicle TOML")
    i.add_argument("log")
    i.add_argument("--out", required=True, help="vehicle TOML to write (.toml)")
    for flag, what in (("--mass", "m [kg]"), ("--inertia", "I_z [kg m^2]"),
                       ("--a-f", "CG to front axle [m]"), ("--a-r", "CG to rear axle [m]")):
        i.add_argument(flag, type=float, required=True, help=what)
    i.add_argument("--name", default=None, help="vehicle name (default: the log's file name)")
    i.add_argument("--channels", default="yaw_rate,ay",
                   help="measured channels to fit: yaw_rate and/or ay (default both)")
    i.add_argument("--nonlinear", choices=("auto", "yes", "no"), default="auto",
                   help="fit the friction peak mu: auto = only if max|a_y| >= 0.5 g")
    i.add_argument("--window", type=float, default=IDENTIFY_WINDOW_S,
                   help="seconds of the log's first stretch in motion (v_x > 1 m/s, no gap) the "
                        f"model is fitted on (default {IDENTIFY_WINDOW_S:g})")
    i.add_argument("--accept-out-of-range", action="store_true",
                   help="accept a log whose values are outside the plausible ranges of a road "
                        "vehicle in SI units (otherwise refused naming the likely unit mistake)")


#: default ``identify --window`` [s]: the open-loop fit follows a real car for minutes, not
#: for a whole session (on the Revs log: 20 % of the yaw rate unexplained over the first
#: 120 s, more than its spread over the 550 s), and 120 s at 100 Hz fit in about a second
IDENTIFY_WINDOW_S = 120.0
#: speed above which ``identify`` fits (the model divides by v_x) [m/s]
IDENTIFY_MIN_VX = 1.0


def _identify_window(args, log):
    """The first ``--window`` seconds of the log's first stretch with ``v_x > 1 m/s`` and no
    time gap above 0.5 s (at least 50 rows)."""
    from vehicle_observers.estimation import segments

    if not (np.isfinite(args.window) and args.window > 0):
        raise CLIError(f"--window must be a number of seconds > 0, got {args.window}")
    runs, _ = segments.stretches(log.t, log.vx > IDENTIFY_MIN_VX, segments.MAX_GAP_S, 50)
    if not runs:
        raise CLIError(f"{Path(args.log).name}: no stretch of 50 rows with v_x > "
                       f"{IDENTIFY_MIN_VX:g} m/s and no time gap > {segments.MAX_GAP_S:g} s to "
                       "fit the model on")
    a, b = runs[0]
    n = int(np.searchsorted(log.t[a:b], log.t[a] + args.window, side="right"))
    if n < 50:
        raise CLIError(f"--window {args.window:g} s holds {n} row(s) of the first stretch in "
                       f"motion (t = {log.t[a]:g} s); the fit needs at least 50")
    return segments.view(log, a, a + n)


def _identify_cached(log, geometry, channels, nonlinear):
    """:func:`identify_stiffness` through an on-disk cache (like the Kalman tuning's, in
    :func:`vehicle_observers.data.logs.cache_dir`): key = the window's measured channels,
    the geometry and options, and the source of the package
    (:func:`vehicle_observers.core.source.package_sha256`)."""
    import hashlib

    from vehicle_observers.core import cache as _cache
    from vehicle_observers.core.source import package_sha256
    from vehicle_observers.data import identification as idf
    from vehicle_observers.data.logs import cache_dir
    from vehicle_observers.models import lateral, tires

    h = hashlib.sha256()
    for a in (log.t - log.t[0], log.vx, log.delta, log.yaw_rate, log.ay):
        h.update(b"-" if a is None else np.ascontiguousarray(a, float).tobytes())
    h.update(repr((tuple(float(g) for g in geometry), tuple(channels), nonlinear)).encode())
    for m in (idf, lateral, tires):
        h.update(Path(m.__file__).read_bytes())
    h.update(package_sha256().encode())     # any module the identification reaches
    f = cache_dir() / f"identify-{h.hexdigest()}.npz"
    fit = _cache.load(f, "identify", _check_fit)
    if fit is None:
        fit = idf.identify_stiffness(log, *geometry, channels=channels, nonlinear=nonlinear)
        _cache.save(f, fit, "identify", _check_fit)
    return fit


def _check_fit(fit):
    """A cached fit: a :class:`StiffnessFit` of finite numbers with positive values
    (stiffness, friction) and ordered 95 % intervals."""
    from vehicle_observers.core.cache import InvalidEntry, check_finite
    from vehicle_observers.data.identification import StiffnessFit

    if not isinstance(fit, StiffnessFit):
        raise InvalidEntry(f"holds a {type(fit).__name__}, not a StiffnessFit")
    v, lo, hi = (np.asarray(x, float) for x in (fit.value, fit.ci_lo, fit.ci_hi))
    check_finite(v, "value")
    if v.shape != (len(fit.names),) or np.any(v <= 0):
        raise InvalidEntry(f"fitted values {v.tolist()} are not one positive number per "
                           f"parameter {list(fit.names)}")
    if not np.all((lo <= v) & (v <= hi)):
        raise InvalidEntry("a 95 % interval does not contain its value")


#: the vehicle-file keys the geometry options of ``identify`` become
_GEOMETRY = (("--mass", "mass", "m"), ("--inertia", "inertia", "I_z"), ("--a-f", "a_f", "a_f"),
             ("--a-r", "a_r", "a_r"))


def cmd_identify(args, out=None):
    """``identify``: :func:`vehicle_observers.data.identification.identify_stiffness` on the
    measured steering, speed, yaw rate and lateral acceleration (never the reference v_y);
    prints the estimates with 95 % intervals; writes ``--out`` only when every parameter is
    identifiable (else exit 2 naming the combination that is). The fit uses the first
    ``--window`` seconds of the first stretch in motion. The log is checked like
    ``estimate``'s (schema, plausible units against the wheelbase ``a_f + a_r``, a change of
    unit inside it) and ``--out`` like ``estimate``'s (never an input, a ``.toml`` name)."""
    out = out or sys.stdout
    from vehicle_observers.data import identification as idf
    from vehicle_observers.data.logs import check_plausible, load_log
    from vehicle_observers.models.vehicle import RANGES, VehicleFileError, load_vehicle

    for flag, attr, key in _GEOMETRY:
        v = getattr(args, attr)
        lo, hi = RANGES[key]
        if not (np.isfinite(v) and lo <= v <= hi):
            raise CLIError(f"{flag} {v:g} is outside the plausible range [{lo:g}, {hi:g}] of a "
                           f"road vehicle's {key} (SI units)")
    chans = tuple(c.strip() for c in args.channels.split(",") if c.strip())
    out_path = _out_path(args, VEHICLE_SUFFIXES)
    with _Sink(out_path) as sink:
        full = load_log(args.log, min_vx=None)
        check_plausible(full, args.a_f + args.a_r, args.accept_out_of_range)
        log = _identify_window(args, full)
        print(f"fitted on t = {log.t[0]:.6g}..{log.t[-1]:.6g} s ({len(log)} rows: the first "
              f"{args.window:g} s in motion)", file=out)
        fit = _identify_cached(log, (args.mass, args.inertia, args.a_f, args.a_r), chans,
                               {"auto": "auto", "yes": True, "no": False}[args.nonlinear])
        for n, v, lo, hi in zip(fit.names, fit.value, fit.ci_lo, fit.ci_hi):
            print(f"{n} = {v:.6g}  95% CI [{lo:.6g}, {hi:.6g}]", file=out)
        print("noise std (from the data): " + ", ".join(f"{c} {v:.3g}" for c, v in
                                                        fit.noise_std.items()), file=out)
        if not fit.identifiable:
            raise CLIError(fit.message)
        name = args.name or Path(args.log).name
        text = idf.vehicle_toml(fit, name, (float(log.vx.min()), float(log.vx.max())),
                                source=Path(args.log).name)

        def accepted(tmp):            # the other commands must accept it
            try:
                load_vehicle(tmp)
            except VehicleFileError as exc:
                msg = str(exc).replace(Path(tmp).name, out_path.name)
                raise CLIError(f"identified values do not make a valid vehicle file: "
                               f"{msg}") from None

        sink.commit(sink.out.commit_text, text, check=accepted)
    print(f"{fit.message}\nwrote {out_path}", file=out)
    return 0


def main(argv=None) -> int:
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except _UsageError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except SystemExit as exc:  # --help
        return EXIT_INPUT if exc.code else 0
    prev = {}
    if _main_thread():
        for name in SIGNALS:
            sig = getattr(signal, name, None)
            if sig is not None:
                prev[sig] = signal.signal(sig, _on_signal)
    debug = bool(getattr(args, "debug", False) or getattr(args, "sub_debug", False))
    try:
        if debug:
            with warnings.catch_warnings():
                warnings.simplefilter("default")
                return _run(args)
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")   # recorded: only a plug-in's are reported
            try:
                return _run(args)
            finally:
                _plugin_warnings(seen)
    except CLIError as exc:
        print(f"error: {exc}", file=sys.stderr)
        if debug and exc.__cause__ is not None:
            import traceback

            traceback.print_exception(exc.__cause__, file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        from vehicle_observers.data.logs import discard_active_partials

        discard_active_partials()
        print("error: interrupted by SIGINT (no output written)", file=sys.stderr)
        return 128 + signal.SIGINT
    except BrokenPipeError:
        # the reader of stdout went away (e.g. `| head -1`): leave quietly, as a process
        # ended by SIGPIPE would (128 + 13); the output file, if any, is already complete
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return EXIT_PIPE
    except Exception as exc:  # noqa: BLE001 - last resort: one line (traceback with --debug)
        from vehicle_observers.core.errors import PluginError

        if debug:
            import traceback

            traceback.print_exception(exc, file=sys.stderr)
        msg = str(exc).splitlines()[0] if str(exc) else ""
        hint = "" if debug else " (--debug shows the traceback)"
        if isinstance(exc, PluginError):
            print(f"error: {msg}; no output written{hint}", file=sys.stderr)
        else:
            print(f"error: internal error {type(exc).__name__}: {msg}{hint}", file=sys.stderr)
        return EXIT_INTERNAL
    finally:
        for sig, handler in prev.items():
            signal.signal(sig, handler)


def _plugin_warnings(seen):
    """One line on stderr for the warnings raised in plug-in code (their count, the first
    with its file:line); the libraries' warnings stay quiet without ``--debug``."""
    from vehicle_observers.estimation.registry import plugin_files

    files = plugin_files()
    mine = [w for w in seen if str(Path(w.filename).resolve()) in files]
    if mine:
        w = mine[0]
        print(f"warning: plug-in code raised {len(mine)} warning(s), first at {w.filename}:"
              f"{w.lineno}: {w.category.__name__}: {str(w.message).splitlines()[0]} "
              "(--debug shows all)", file=sys.stderr)


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
    c.add_argument("--recompute", action="store_true",
                   help="when the code changed since the folder's results were computed "
                        "(package version, an estimator's or plug-in's source, options): "
                        "recompute the batches it affects (otherwise refused)")
    _add_plugin_options(c)
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

    if args.spec == "report":
        if not args.dir:
            raise CLIError("campaign report: give the campaign folder (campaign report DIR)")
        from vehicle_observers.campaign.report import integrity_lines, write_report

        t = write_report(args.dir)
        s = t["spec"]
        print(f"campaign {s.doc['name']} ({s.sha256[:12]}): {t['rows']} of {s.n_tasks} "
              f"simulations, {len(t['lmi_points'])} of {len(s.lmi_points)} LMI map points", file=out)
        for line in integrity_lines(t["integrity"]):
            print(f"warning: {line}", file=sys.stderr)
        for r in t["failures"]:
            print(f"  {r['estimator']:22s} failed {r['failed']}/{r['n']}", file=out)
        for r in t["best"]:
            print(f"  best at {r['parameter']} {r['error']:+g}: {r['best']} "
                  f"(median v_y RMSE {r['best_median_rmse_vy']:.4g} m/s)", file=out)
        fmt = lambda v, f: v if isinstance(v, str) else format(v, f)  # noqa: E731
        for r in t["uncertainty"]:
            print(f"  {r['estimator']:22s} on {r['plant']}: median v_y RMSE "
                  f"{fmt(r['median_rmse_vy'], '.4g')} m/s, 2-sigma coverage "
                  f"{fmt(r['coverage_2sigma'], '.3f')}, mean NEES {fmt(r['mean_nees'], '.3g')}",
                  file=out)
        for r in t["warnings"]:
            print(f"  {r['estimator']:22s} raised {r['count']} {r['category']}(s) in "
                  f"{r['tasks']} task(s), first: {r['first_message']}", file=out)
        print(f"wrote {len(t['files'])} files to {Path(t['files'][0]).parent}", file=out)
        return 0
    if args.dir:
        raise CLIError(f"campaign: unexpected argument {args.dir!r} (campaign SPEC.toml --out DIR)")
    if not args.out:
        raise CLIError("campaign: --out DIR is required (the results folder)")
    from vehicle_observers.campaign.engine import CampaignStopped

    try:
        res = campaign.run(args.spec, args.out, scheduler=args.scheduler, engine=args.engine,
                           workers=args.workers, progress=args.progress, plugins=_plugins(args),
                           recompute=args.recompute)
    except CampaignStopped as exc:
        if exc.signum is None:
            raise CLIError(str(exc)) from None
        print(f"error: {exc}", file=sys.stderr)
        return 128 + exc.signum
    print(res.line(), file=out)
    return 0


if __name__ == "__main__":
    console()
