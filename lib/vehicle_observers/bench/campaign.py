"""Throughput of robustness campaigns (:mod:`vehicle_observers.campaign`); never a timed test.

    python -m vehicle_observers.bench.campaign [--quick] [--json build/benchmark/campaign.json]

Measured on the machine it runs on (wall clock, after a warm-up that loads the numba kernels;
each the best of :data:`REPEAT` runs, the 1-minute load average reported beside):

1. **Throughput** [simulations/s] of one campaign (:data:`WORKLOAD`: the EKF, the linear
   Kalman filter and the open-loop bicycle on two cars' LPV truths, 10 s slaloms at 100 Hz,
   stiffness and mass errors, two noise levels, two bias cases, repetitions) run

   * as a plain Python loop over the same tasks in this process (truths simulated once, no
     Dask, no Parquet): the reference;
   * by :func:`vehicle_observers.campaign.run` on a warm ``LocalCluster`` with 1 and with 2
     single-threaded worker processes (truth tasks, batches, transfers and the Parquet
     writes of this process included; cluster start-up excluded, reported apart).

   Dask overhead with one worker ``= t_dask1 / t_loop - 1`` (target <= :data:`TARGET_OVERHEAD`),
   also in CPU time (this process + the workers' processes against the loop's; meaningful
   when other work shares the cores: the 1-minute load average is reported);
   parallel efficiency with two workers ``= t_dask1 / (2 t_dask2)`` (target >=
   :data:`TARGET_EFFICIENCY` on 2 cores; this process's writes share the cores).
2. **LMI feasibility map** of :data:`LMI_POINTS` points (:mod:`vehicle_observers.campaign.lmi_map`)
   in one process: total time against the sum of the solver's own times (Clarabel's
   ``solve_time``; target total <= :data:`TARGET_LMI_RATIO` x), and the time of the same
   design through :func:`vehicle_observers.observers.interval.design_theorem2` (one
   canonicalisation per point) on a few points.
3. **Bit-identical results**: the rows of the serial engine, of 1 and 2 workers and of a
   separately started ``dask scheduler`` with two ``dask worker`` processes (127.0.0.1) are
   compared bit for bit.

From the per-simulation CPU time and the measured efficiency the cost of a 10^6-simulation
campaign on a 64-core node is extrapolated (printed; the README quotes a run).
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

TARGET_OVERHEAD = 0.10
#: each timing is the best of this many runs (the machine may be shared)
REPEAT = 2
TARGET_EFFICIENCY = 0.85
TARGET_LMI_RATIO = 3.0
LMI_POINTS = 1000

#: the measured campaign: 9600 simulations in batches of 256, the size the automatic rule
#: gives a campaign of 512,000 simulations (a Dask task costs about 10 ms of scheduling,
#: transfers and writing, against 0.25-0.3 s of simulations here)
WORKLOAD = {
    "name": "bench", "seed": 0, "repetitions": 100, "batch_size": 256,
    "estimators": ["ekf"], "references": ["open-loop-linear", "linear-kf"],
    "truth": {"plants": ["lpv:bmw_320i", "lpv:yacine2015"],
              "manoeuvres": [{"name": "slalom", "duration": 10.0}]},
    "errors": {"stiffness": [-0.2, 0.2], "mass": [0.1]},
    "sensors": {"noise_scale": [1.0, 3.0], "bias": [{}, {"yaw_rate": 0.005}]},
}


def lmi_spec(points: int = LMI_POINTS) -> dict:
    """A map of ``points`` points: BMW, ``kappa = 0.1``, box half-width x speed range."""
    n_rel = 50 if points >= 50 else points
    n_sp = max(points // n_rel, 1)
    lo = np.linspace(2.0, 12.0, n_sp)
    return {"name": "bench-lmi", "estimators": ["open-loop-linear"], "references": [],
            "truth": {"plants": ["lpv:bmw_320i"]}, "repetitions": 1,
            "lmi_map": {"cars": ["bmw_320i"], "stiffness_rel": {"start": 0.01, "stop": 0.4,
                                                                  "num": n_rel},
                        "speed_range": [[float(a), 40.0] for a in lo], "kappa": [0.1],
                        "batch_size": 50}}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _bits(a, b) -> bool:
    if a.column_names != b.column_names or a.num_rows != b.num_rows:
        return False
    for n in a.column_names:
        x, y = a[n].to_numpy(zero_copy_only=False), b[n].to_numpy(zero_copy_only=False)
        if x.dtype.kind == "f":
            if not np.array_equal(x.view(np.uint64), y.view(np.uint64)):
                return False
        elif list(x) != list(y):
            return False
    return True


def plain_loop(spec) -> tuple[float, float, dict]:
    """Every task of ``spec`` in this process: (wall [s], CPU [s], per-estimator mean
    wall per simulation [s])."""
    from vehicle_observers.campaign import tasks
    from vehicle_observers.estimation import registry

    avail = registry.available(spec.plugins)
    per: dict = {}
    c0, t0 = time.process_time(), time.perf_counter()
    truths = {}
    for _, a, b in spec.batches():
        for args in tasks.truths_of_batch(spec, a, b):
            k = tasks.S.truth_key(*args)
            if k not in truths:
                truths[k] = tasks.T.simulate_truth(*args)
    for i in range(spec.n_tasks):
        s = time.perf_counter()
        r = tasks.run_task(spec, i, 0, truths, avail)
        per.setdefault(r["estimator"], []).append(time.perf_counter() - s)
    return (time.perf_counter() - t0, time.process_time() - c0,
            {k: float(np.mean(v)) for k, v in per.items()})


def _dask_run(spec, out, address, client=None) -> tuple[float, float]:
    """(wall [s], CPU [s] of this process plus the workers') of the campaign via ``address``."""
    from vehicle_observers.campaign import run

    def cpu():
        import psutil

        pids = list(client.run(os.getpid).values()) if client is not None else []
        own = time.process_time()
        return own + sum(sum(psutil.Process(p).cpu_times()[:2]) for p in pids)

    c0, t0 = cpu(), time.perf_counter()
    run(spec, out, scheduler=address, progress=False)
    return time.perf_counter() - t0, cpu() - c0


def _warm_cluster(workers: int):
    from distributed import Client

    from vehicle_observers.campaign import engine

    t0 = time.perf_counter()
    cluster = engine.local_cluster(workers)
    client = Client(cluster, set_as_default=False)
    engine.prepare_client(client)
    client.run(lambda: None)
    return cluster, client, time.perf_counter() - t0


def throughput(quick: bool = False, work: Path | None = None) -> dict:
    from vehicle_observers.campaign import load_spec, read_results, run, tasks

    doc = dict(WORKLOAD, repetitions=4 if quick else WORKLOAD["repetitions"],
               batch_size=8 if quick else WORKLOAD["batch_size"])
    spec = load_spec(doc)
    tasks.warm_up()
    work = Path(work or tempfile.mkdtemp(prefix="bench-campaign-"))
    out = {"simulations": spec.n_tasks, "batches": len(spec.batches()),
           "batch_size": spec.batch_size}
    loop = [plain_loop(spec) for _ in range(REPEAT)]
    loop_s, loop_cpu, per = min(loop, key=lambda r: r[0])
    out.update(loop_s=loop_s, loop_cpu_s=loop_cpu, loop_sims_per_s=spec.n_tasks / loop_s,
               per_estimator_ms={k: 1e3 * v for k, v in per.items()})
    t0 = time.perf_counter()
    run(spec, work / "serial", engine="serial", progress=False)
    out["serial_engine_s"] = time.perf_counter() - t0
    for w in (1, 2):
        cluster, client, start = _warm_cluster(w)
        try:
            out[f"dask{w}_startup_s"] = start
            runs = [_dask_run(spec, work / f"dask{w}-{k}", cluster.scheduler_address, client)
                    for k in range(REPEAT)]
            out[f"dask{w}_s"], out[f"dask{w}_cpu_s"] = min(runs)
        finally:
            client.close()
            cluster.close()
        out[f"dask{w}_sims_per_s"] = spec.n_tasks / out[f"dask{w}_s"]
    out["overhead_1_worker"] = out["dask1_s"] / loop_s - 1.0
    out["cpu_overhead_1_worker"] = out["dask1_cpu_s"] / loop_cpu - 1.0
    out["load_average_1min"] = os.getloadavg()[0]
    out["efficiency_2_workers"] = out["dask1_s"] / (2.0 * out["dask2_s"])
    out["scheduler_s"] = _separate_scheduler(spec, work / "scheduler")
    ref = read_results(work / "serial")
    out["bit_identical"] = {k: _bits(read_results(work / k), ref)
                            for k in ("dask1-0", "dask2-0", "scheduler")}
    return out


def _separate_scheduler(spec, out) -> float:
    """The campaign through ``dask scheduler`` + two ``dask worker`` processes on 127.0.0.1
    (killed by pid at the end). Returns its wall time [s] (cluster start-up excluded)."""
    from distributed import Client

    from vehicle_observers.campaign.tasks import THREAD_ENV

    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, **THREAD_ENV}
    lib = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = os.pathsep.join([lib, env.get("PYTHONPATH", "")])
    dn = subprocess.DEVNULL
    procs = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1",
                               "--port", str(port), "--no-dashboard"], env=env, stdout=dn,
                              stderr=dn)]
    try:
        for i in range(2):
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "dask", "worker", addr, "--nthreads", "1", "--nworkers",
                 "1", "--host", "127.0.0.1", "--no-dashboard", "--name", f"w{i}"], env=env,
                stdout=dn, stderr=dn))
        with Client(addr, timeout=60) as c:
            c.wait_for_workers(2, timeout=120)
            from vehicle_observers.campaign import engine

            engine.prepare_client(c)
        return _dask_run(spec, out, addr)[0]
    finally:
        import psutil

        for p in procs:
            try:
                kids = psutil.Process(p.pid).children(recursive=True)
            except psutil.NoSuchProcess:
                kids = []
            for q in [p, *kids]:
                try:
                    q.kill()
                except psutil.NoSuchProcess:
                    pass
            p.wait(10)


def lmi_map_timing(points: int = LMI_POINTS, compare: int = 5) -> dict:
    """Section 2 of the module docstring."""
    from vehicle_observers.campaign import lmi_map, load_spec
    from vehicle_observers.observers import interval as iv

    spec = load_spec(lmi_spec(points))
    t_build = time.perf_counter()
    lmi_map.problem()
    t_build = time.perf_counter() - t_build
    tm: list = []
    statuses: dict = {}
    t0 = time.perf_counter()
    for bid, a, b in spec.lmi_batches():
        cols = lmi_map.run_lmi_batch(spec.raw, bid, a, b, tm)
        for s in cols["status"]:
            statuses[s] = statuses.get(s, 0) + 1
    total = time.perf_counter() - t0
    solver = float(np.nansum([t["solver"] for t in tm]))
    m = spec.doc["lmi_map"]
    t1 = time.perf_counter()
    for car, rel, lo, hi, kappa in spec.lmi_points[:: max(len(spec.lmi_points) // compare, 1)][:compare]:
        model, _ = lmi_map.point_model(car, rel, lo, hi, kappa)
        try:
            iv.design_theorem2(model, eps_decay=1.0, epsilon_shift=m["rate_hz"],
                               accel_max=m["accel_max"], p_min=1.0)
        except Exception:  # noqa: BLE001 - infeasible points cost the same canonicalisation
            pass
    per_design = (time.perf_counter() - t1) / compare
    return {"points": len(spec.lmi_points), "statuses": statuses, "build_s": t_build,
            "total_s": total, "solver_s": solver, "ratio_total_to_solver": total / solver,
            "per_point_ms": 1e3 * total / len(spec.lmi_points),
            "design_theorem2_per_point_ms": 1e3 * per_design}


def extrapolate(res: dict, sims: float = 1e6, cores: int = 64) -> dict:
    """Cost of ``sims`` simulations of the workload's kind on ``cores`` cores: CPU per
    simulation (the plain loop) / (cores x the measured 2-worker efficiency)."""
    per_sim = res["loop_cpu_s"] / res["simulations"]
    eff = min(res["efficiency_2_workers"], 1.0)
    return {"cpu_s_per_simulation": per_sim, "cores": cores, "simulations": sims,
            "wall_s": sims * per_sim / (cores * eff), "core_hours": sims * per_sim / 3600 / eff,
            "dask_tasks": -(-int(sims) // max(-(-int(sims) // 2000), 64))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="campaign throughput (make bench)")
    ap.add_argument("--quick", action="store_true", help="a small workload (smoke run)")
    ap.add_argument("--json", default="", help="also write the numbers here")
    args = ap.parse_args(argv)
    res = {"throughput": throughput(args.quick)}
    res["lmi_map"] = lmi_map_timing(100 if args.quick else LMI_POINTS)
    res["extrapolation"] = extrapolate(res["throughput"])
    tp, lm = res["throughput"], res["lmi_map"]
    res["targets"] = {
        "overhead_1_worker <= 10 %": tp["overhead_1_worker"] <= TARGET_OVERHEAD,
        "efficiency_2_workers >= 85 %": tp["efficiency_2_workers"] >= TARGET_EFFICIENCY,
        "lmi total <= 3 x solver": lm["ratio_total_to_solver"] <= TARGET_LMI_RATIO,
        "bit-identical": all(tp["bit_identical"].values())}
    print(json.dumps(res, indent=1, default=float))
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(res, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
