"""A campaign on a separately started cluster: `dask scheduler` and two `dask worker`
processes on 127.0.0.1; one worker is killed mid-run; the rows equal the serial run bit for
bit."""

from __future__ import annotations

import subprocess
import threading

import pytest
from campaignkit import PY, SLOW, free_port, kill_tree, plugin_env, same_bits, wait_for
from vehicle_observers.campaign import read_results, run

pytestmark = pytest.mark.xdist_group("campaign")


def _start(args, env, log):
    return subprocess.Popen([PY, "-m", "dask", *args], env=env, stdout=log, stderr=log)


def test_scheduler_address_with_a_worker_killed_mid_run(tmp_path, monkeypatch):
    from distributed import Client

    port = free_port()
    addr = f"tcp://127.0.0.1:{port}"
    env = plugin_env(0.15)
    log = open(tmp_path / "cluster.log", "w")
    procs = [_start(["scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                    env, log)]
    try:
        for name in ("wA", "wB"):
            procs.append(_start(["worker", addr, "--nthreads", "1", "--nworkers", "1", "--host",
                                 "127.0.0.1", "--no-dashboard", "--name", name], env, log))
        with Client(addr, timeout=60) as c:
            c.wait_for_workers(2, timeout=120)
        out = tmp_path / "out"
        killed = {}

        def kill_one():
            try:
                wait_for(lambda: len(list(out.glob("results/batch-*.parquet"))) >= 2, 120,
                         "two finished batches")
            except TimeoutError:
                return
            killed["done"] = len(list(out.glob("results/batch-*.parquet")))
            kill_tree(procs[1].pid)

        th = threading.Thread(target=kill_one, daemon=True)
        th.start()
        s = run(SLOW, out, scheduler=addr, progress=False)
        th.join(10)
        assert killed and killed["done"] < 20, "no worker was killed mid-run"
        assert procs[1].poll() is not None
        assert s.workers == 2 and s.run_now == 40 and s.failed == 10
        monkeypatch.setenv("CAMPAIGN_TEST_SLEEP", "0")
        run(SLOW, tmp_path / "ref", engine="serial", progress=False)
        assert same_bits(read_results(out), read_results(tmp_path / "ref")) == []
    finally:
        for p in procs:
            kill_tree(p.pid)
            p.wait(10)
        log.close()
