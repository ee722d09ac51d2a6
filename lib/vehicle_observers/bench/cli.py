"""Speed of ``python -m vehicle_observers estimate`` end to end (part of ``make bench``).

Two targets, each measured as a fresh process (wall clock including interpreter start-up,
imports, loading the numba kernels from their cache, reading, tuning, filtering, writing):

1. ``estimate`` on the shipped Revs log (55,001 rows at 100 Hz) with ``--observer ekf`` and
   the built-in ``revs250lm`` vehicle (no ``[kalman]`` table: the ML noise tuning runs on the
   first 120 s at the log's rate and is cached per window data and vehicle,
   :func:`kalman_runs.kalman_tuning`): at most :data:`TARGET_REVS_S` s, measured with an empty
   tuning cache and with the tuning cached. The ``v_y`` RMSE (against the log's INS ``v_y``)
   with that tuning is reported beside the RMSE with the window thinned to 25 Hz (the
   other way to make the tuning cheaper, which loses accuracy).
2. A 10^7-row log (the Revs channels repeated with a continuous time axis) with ``ekf``:
   at most :data:`TARGET_BIG_S` s and :data:`TARGET_BIG_MB` MB peak resident memory
   (``ru_maxrss`` of the child process, :func:`resource.getrusage`). Wall clock depends on the
load of the machine; the user + system CPU time of the process is reported beside it.

3. Every command on the Revs log (``observers``, ``tune``, ``identify``, ``estimate`` with
   each registered estimator that runs on it; the filterpy references ``ekf-filterpy`` and
   ``ukf-filterpy`` are excluded: they exist to check the compiled filters, at about 0.5 ms
   per step), each as a fresh process: **cold** with empty caches of this package (ML
   tuning, LMI designs, identification; numba's compiled kernels cached, as after any first
   run) and **warm** (the same command again): at most :data:`TARGET_WARM_S` s warm and
   :data:`TARGET_COLD_S` s cold (:func:`command_times`).

    python -m vehicle_observers.bench.cli [--quick] [--commands-only]

``--quick`` (CI) uses 10^5 rows for the second case; the target columns then say so.
``--commands-only`` measures the third case only. Never run inside timed tests.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

TARGET_REVS_S = 3.0
#: every command on the Revs log, warm / with empty caches [s]
TARGET_WARM_S = 3.0
TARGET_COLD_S = 10.0
TARGET_BIG_S = 30.0
TARGET_BIG_MB = 2000.0
BIG_ROWS = 10 ** 7


def _run_cli(*argv, cache=None, ok=(0,)) -> dict:
    """One fresh CLI process: ``wall`` [s], ``cpu`` (user + system) [s], ``peak_mb`` (peak
    resident memory, NaN when not above that of an earlier child), ``stdout``. ``cache``:
    the ML-tuning cache folder of the run."""
    env = dict(os.environ)
    if cache is not None:
        env["VEHICLE_OBSERVERS_CACHE"] = str(cache)
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "vehicle_observers", *map(str, argv)],
                       capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode not in ok:
        raise RuntimeError(f"CLI exited {p.returncode}: {p.stderr.strip()}")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    # ru_maxrss of the children is a maximum over all of them: only a new maximum is this run's
    peak = r1.ru_maxrss / 1024.0 if r1.ru_maxrss > r0.ru_maxrss else float("nan")
    return {"wall": wall, "cpu": cpu, "peak_mb": peak, "stdout": p.stdout}


def big_log(path: Path, rows: int):
    """Write a ``rows``-row log: the Revs channels (t, v_x, delta, r, a_y) repeated, time
    continuous at 100 Hz."""
    from vehicle_observers.data.logs import load_revs, write_csv

    revs = load_revs()
    reps = -(-rows // len(revs))
    cols = {"t_s": np.arange(rows) * 0.01}
    for c, a in (("vx_mps", revs.vx), ("delta_roadwheel_rad", revs.delta),
                 ("yaw_rate_radps", revs.yaw_rate), ("ay_mps2", revs.ay)):
        cols[c] = np.tile(a, reps)[:rows]
    write_csv(path, cols)


#: thinned tuning rate compared with the full-rate one [Hz]
THINNED_HZ = 25.0


def tuning_accuracy() -> dict:
    """``v_y`` RMSE of the EKF on the whole Revs log with the ML tuning used by the command
    line (the log's full 100 Hz, :data:`kalman_runs.TUNE_RATE_HZ`) and with the tuning window
    thinned to :data:`THINNED_HZ`, and the tuning times (wall clock)."""
    from vehicle_observers.core.metrics import rmse
    from vehicle_observers.data.logs import load_revs
    from vehicle_observers.estimation import kalman_runs as RG
    from vehicle_observers.models.vehicle import load_vehicle

    log, veh = load_revs(), load_vehicle("revs250lm")
    out = {}
    for tag, hz in (("full_rate", RG.TUNE_RATE_HZ), ("thinned", THINNED_HZ)):
        tun, sec = RG.kalman_tuning(log, veh, rate_hz=hz)          # no cache: measured
        cols, _ = RG.ekf_columns(log, veh, tun)
        out[f"rmse_vy_{tag}"] = rmse(cols["vy_mps"], log.vy)
        out[f"tuning_s_{tag}"] = sec
    return out


def run(quick: bool = False) -> list[dict]:
    """Rows ``{"component", "steps", "seconds", "us_per_step", ...}`` (``seconds`` = wall
    clock of the process; ``cpu_seconds`` = its user + system time)."""
    from vehicle_observers.data.logs import revs_log_path

    rows = []
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        args = ("estimate", revs_log_path(), "--vehicle", "revs250lm", "--observer", "ekf",
                "--out", d / "est.csv", "--no-progress")
        # numba and import caches warm (the kernels compile once after an install or an
        # edit): one full run with its own tuning cache, not measured
        _run_cli(*args, cache=d / "warm-up")
        for tag, cache in (("empty tuning cache", d / "cold"), ("tuning cached", d / "warm")):
            if tag == "tuning cached":
                _run_cli(*args, cache=cache)                     # fills the cache
            r = _run_cli(*args, cache=cache)
            rows.append({"component": f"estimate --observer ekf, Revs log, {tag}",
                         "steps": 55001, "seconds": r["wall"], "cpu_seconds": r["cpu"],
                         "us_per_step": r["wall"] / 55001 * 1e6,
                         "target_seconds": TARGET_REVS_S,
                         "meets_target": bool(r["wall"] <= TARGET_REVS_S),
                         "cli_line": r["stdout"].splitlines()[0]})
        rows[-1].update(tuning_accuracy())
        n = 10 ** 5 if quick else BIG_ROWS
        big = d / "big.csv"
        big_log(big, n)
        size_mb = os.path.getsize(big) / 2 ** 20
        r = _run_cli("estimate", big, "--vehicle", "revs250lm", "--observer", "ekf",
                     "--out", d / "big_est.csv", "--no-progress", cache=d / "warm")
        os.unlink(big)
        full = n == BIG_ROWS
        rows.append({"component": f"estimate --observer ekf, {n:.0e} rows ({size_mb:.0f} MB "
                                  "CSV)", "steps": n, "seconds": r["wall"],
                     "cpu_seconds": r["cpu"], "us_per_step": r["wall"] / n * 1e6,
                     "peak_mb": r["peak_mb"],
                     "target_seconds": TARGET_BIG_S if full else float("nan"),
                     "target_mb": TARGET_BIG_MB if full else float("nan"),
                     "meets_target": bool(full and r["wall"] <= TARGET_BIG_S
                                          and r["peak_mb"] <= TARGET_BIG_MB),
                     "cli_line": r["stdout"].splitlines()[0]})
    return rows


#: estimators not timed by :func:`command_times` (the filterpy references)
REFERENCES = ("ekf-filterpy", "ukf-filterpy")


def revs_commands(folder: Path) -> list[tuple]:
    """``(label, argv, accepted exit codes)`` of every command on the Revs log."""
    from vehicle_observers.data.logs import load_revs, revs_log_path
    from vehicle_observers.estimation import available
    from vehicle_observers.models.vehicle import load_vehicle

    log, veh = revs_log_path(), load_vehicle("revs250lm")
    p = veh.params
    revs = load_revs(None)
    cmds = [("observers", ("observers",), (0,)),
            ("tune", ("tune", log, "--vehicle", "revs250lm"), (0,)),
            # the open-loop model does not follow the Revs car well enough: exit 2 (refused,
            # after the whole fit), which is the command's answer on this log
            ("identify", ("identify", log, "--out", folder / "car.toml", "--mass", p.m,
                          "--inertia", p.I_z, "--a-f", p.a_f, "--a-r", p.a_r), (0, 2))]
    for name, spec in available().items():
        if name in REFERENCES or not all(revs.has(c) for c in spec.columns):
            continue
        cmds.append((f"estimate --observer {name}",
                     ("estimate", log, "--vehicle", "revs250lm", "--observer", name, "--out",
                      folder / f"est-{name}.csv", "--no-progress"), (0,)))
    return cmds


def command_times() -> list[dict]:
    """Cold and warm wall time of every command on the Revs log (module docstring, case 3).
    Each command runs once first with a throw-away cache (numba kernels compiled or loaded
    into their on-disk cache), then cold with an empty cache folder, then warm with that
    folder."""
    rows = []
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        for i, (label, argv, ok) in enumerate(revs_commands(d)):
            _run_cli(*argv, cache=d / f"throw-away-{i}", ok=ok)
            cold = _run_cli(*argv, cache=d / f"cache-{i}", ok=ok)
            warm = _run_cli(*argv, cache=d / f"cache-{i}", ok=ok)
            rows.append({"command": label, "cold_s": cold["wall"], "warm_s": warm["wall"],
                         "target_cold_s": TARGET_COLD_S, "target_warm_s": TARGET_WARM_S,
                         "meets_target": bool(cold["wall"] <= TARGET_COLD_S
                                              and warm["wall"] <= TARGET_WARM_S)})
    return rows


def print_command_times(rows):
    print(f"{'command on the Revs log (55,001 rows)':42s} {'cold':>7s} {'target':>7s} "
          f"{'warm':>7s} {'target':>7s}")
    for r in rows:
        print(f"{r['command']:42s} {r['cold_s']:6.2f}s {r['target_cold_s']:6.1f}s "
              f"{r['warm_s']:6.2f}s {r['target_warm_s']:6.1f}s  "
              f"{'ok' if r['meets_target'] else 'MISSED'}")


if __name__ == "__main__":
    if "--commands-only" not in sys.argv:
        for row in run(quick="--quick" in sys.argv):
            print({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()})
    print_command_times(command_times())
