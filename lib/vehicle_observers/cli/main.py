"""Command line: estimate lateral states on your own log.

    python -m vehicle_observers observers
    python -m vehicle_observers estimate LOG.csv --vehicle VEHICLE.toml --observer NAME \\
        --out EST.csv [--tune-window 120] [--progress/--no-progress]
    python -m vehicle_observers tune LOG.csv --vehicle VEHICLE.toml [--tune-window 120]
    python -m vehicle_observers identify LOG.csv --out VEHICLE.toml --mass M --inertia IZ \\
        --a-f LF --a-r LR [--channels yaw_rate,ay] [--nonlinear auto|yes|no]

``tune`` prints the ML noise tuning of the Kalman observers as a ``[kalman]`` TOML table:
append it to the vehicle file to skip the tuning in later runs.

``LOG.csv`` follows the schema of :mod:`vehicle_observers.data.logs` (``t_s, vx_mps,
delta_roadwheel_rad, yaw_rate_radps`` and optionally ``ay_mps2``, reference ``vy_mps``, ...).
``--vehicle`` is a TOML file (:mod:`vehicle_observers.models.vehicle`) or a built-in name
(``yacine2015``, ``revs250lm``). The output CSV has ``t_s`` and one column per estimate with
its unit in the name; it is written completely or not at all. When the log has reference
columns the benchmark metrics are printed. Errors: one line on stderr, exit status 2 (bad
input) or 3 (unexpected internal error); never a traceback.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

EXIT_INPUT = 2
EXIT_INTERNAL = 3


class CLIError(Exception):
    """A user-facing error (one line)."""


def _parser():
    p = argparse.ArgumentParser(prog="python -m vehicle_observers",
                                description="Vehicle lateral-state observers on drive logs.")
    sub = p.add_subparsers(dest="cmd", required=True)
    sub.add_parser("observers", help="list the observers and what each needs")
    e = sub.add_parser("estimate", help="run one observer on a log and write the estimates")
    e.add_argument("log", help="drive log CSV (.csv or .csv.gz), schema of vehicle_observers.data.logs")
    e.add_argument("--vehicle", required=True,
                   help="vehicle TOML file, or a built-in name (yacine2015, revs250lm)")
    e.add_argument("--observer", required=True, help="observer name (see 'observers')")
    e.add_argument("--out", required=True, help="output CSV path")
    e.add_argument("--tune-window", type=float, default=120.0,
                   help="seconds of the log used for ML noise tuning of the Kalman observers "
                        "when the vehicle file has no [kalman] table (default 120)")
    tu = sub.add_parser("tune", help="ML noise tuning of the Kalman observers on a log; prints "
                                     "a [kalman] table for the vehicle file")
    tu.add_argument("log")
    tu.add_argument("--vehicle", required=True)
    tu.add_argument("--tune-window", type=float, default=120.0)
    _identify_parser(sub)
    g = e.add_mutually_exclusive_group()
    g.add_argument("--progress", dest="progress", action="store_true", default=None,
                   help="show a progress bar (default: when stderr is a terminal)")
    g.add_argument("--no-progress", dest="progress", action="store_false")
    return p



def cmd_observers(out=None):
    out = out or sys.stdout
    from vehicle_observers.cli.registry import BASE_COLUMNS, available

    print(f"every observer reads: {', '.join(BASE_COLUMNS)}", file=out)
    for name, s in available().items():
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


def cmd_estimate(args, out=None):
    out = out or sys.stdout
    import numpy as np

    from vehicle_observers.cli.registry import available, score
    from vehicle_observers.core.errors import InfeasibleDesign, LogFormatError
    from vehicle_observers.data.logs import load_log, write_csv
    from vehicle_observers.models.vehicle import VehicleFileError, load_vehicle

    obs = available()
    if args.observer not in obs:
        raise CLIError(f"unknown observer {args.observer!r}; available: {', '.join(obs)}")
    spec = obs[args.observer]
    out_path = Path(args.out)
    if out_path.exists() and out_path.is_dir():
        raise CLIError(f"--out {args.out}: is a directory, expected a file path")
    if not out_path.parent.exists() and str(out_path.parent) not in ("", "."):
        raise CLIError(f"--out {args.out}: folder {out_path.parent} does not exist")
    if not np.isfinite(args.tune_window) or args.tune_window <= 0:
        raise CLIError(f"--tune-window must be > 0 s, got {args.tune_window}")
    show = sys.stderr.isatty() if args.progress is None else args.progress
    from tqdm import tqdm

    bar = tqdm(total=100, disable=not show, file=sys.stderr, desc=args.observer,
               bar_format="{desc}: {percentage:3.0f}%|{bar}| {postfix}")

    def stage(pct, what):
        bar.n = pct
        bar.set_postfix_str(what)
        bar.refresh()

    def progress(k, N, what="step"):
        if what == "tuning":
            stage(10 + int(40 * k / max(N, 1)), f"ML noise tuning, evaluation {k}")
        else:
            stage(50 + int(40 * k / max(N, 1)), f"step {k}/{N}")

    try:
        stage(0, "loading log")
        try:
            vehicle = load_vehicle(args.vehicle)
        except VehicleFileError as exc:
            raise CLIError(str(exc)) from None
        try:
            log = load_log(args.log)
            spec.check(log, vehicle)
        except (LogFormatError, VehicleFileError) as exc:
            raise CLIError(str(exc)) from None
        stage(10, "design / tuning")
        try:
            est = spec.run(log, vehicle, window_s=args.tune_window, progress=progress)
        except InfeasibleDesign as exc:
            lmi = f" (LMI {exc.lmi})" if getattr(exc, "lmi", None) else ""
            raise CLIError(f"observer {spec.name!r}: design infeasible for vehicle "
                           f"{vehicle.name!r}{lmi}: {str(exc).splitlines()[0]}") from None
        except (LogFormatError, VehicleFileError, ValueError) as exc:
            raise CLIError(f"observer {spec.name!r}: {str(exc).splitlines()[0]}") from None
        stage(90, "writing")
        try:
            write_csv(out_path, est.table())
        except OSError as exc:
            raise CLIError(f"--out {args.out}: cannot write ({exc.strerror or exc})") from None
        stage(100, "done")
    finally:
        bar.close()
    n = len(est.t)
    print(f"{spec.name} on {Path(args.log).name} ({n} samples, {log.duration:.1f} s) with "
          f"{vehicle.name}: {est.us_per_step:.3g} us/step, real-time factor "
          f"{log.duration / max(est.seconds, 1e-12):.3g}x; design/tuning {est.design_seconds:.2f} s",
          file=out)
    if not est.causal:
        print("note: this estimator is OFFLINE (uses future samples)", file=out)
    print(f"wrote {out_path} (columns: {', '.join(est.table())})", file=out)
    m = score(est, log)
    if any(k.startswith("rmse_vy") or k.startswith("enclosure") or k.startswith("rmse_F")
           for k in m):
        print("metrics against the log's reference columns:", file=out)
        for line in _fmt_metrics(m):
            print(line, file=out)
    return 0


def cmd_tune(args, out=None):
    out = out or sys.stdout
    from vehicle_observers.baselines.kalman import tune
    from vehicle_observers.core.errors import LogFormatError
    from vehicle_observers.data.logs import load_log
    from vehicle_observers.models.vehicle import VehicleFileError, load_vehicle

    if not args.tune_window > 0:
        raise CLIError(f"--tune-window must be > 0 s, got {args.tune_window}")
    try:
        vehicle = load_vehicle(args.vehicle)
        log = load_log(args.log)
    except (LogFormatError, VehicleFileError) as exc:
        raise CLIError(str(exc)) from None
    tun = tune(log, vehicle.params, window_s=args.tune_window)
    print(f"# {tun.source}", file=out)
    print("[kalman]", file=out)
    for k in ("q_vy", "q_r", "q_b", "R_r", "R_ay"):
        print(f"{k} = {getattr(tun, k):.6g}", file=out)
    return 0


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
    try:
        if args.cmd == "observers":
            return cmd_observers()
        if args.cmd == "tune":
            return cmd_tune(args)
        if args.cmd == "identify":
            return cmd_identify(args)
        return cmd_estimate(args)
    except CLIError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        print("error: interrupted (no output written)", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - last resort: one line, never a traceback
        msg = str(exc).splitlines()[0] if str(exc) else ""
        print(f"error: internal error {type(exc).__name__}: {msg}", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
