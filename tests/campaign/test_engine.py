"""The engine: serial == embedded Dask cluster bit for bit; failing tasks recorded, not fatal;
a campaign killed (SIGKILL) mid-run resumes with nothing lost or duplicated."""

from __future__ import annotations

import os
import signal
import subprocess

import numpy as np
import pyarrow.compute as pc
import pytest
from campaignkit import PY, SLOW, TINY, kill_tree, plugin_env, same_bits, wait_for
from vehicle_observers.campaign import read_lmi, read_results, run
from vehicle_observers.campaign.spec import dump_toml
from vehicle_observers.campaign.store import batch_path

pytestmark = pytest.mark.xdist_group("campaign")


def test_serial_equals_local_cluster_of_two_workers(tiny_serial, tmp_path):
    spec, _, ref, ref_lmi = tiny_serial
    s = run(TINY, tmp_path / "dask", engine="dask", workers=2, progress=False)
    assert s.workers == 2 and s.run_now == spec.n_tasks == 64 and s.lmi_run_now == 2
    assert same_bits(read_results(tmp_path / "dask"), ref) == []
    assert same_bits(read_lmi(tmp_path / "dask"), ref_lmi) == []


def test_embedded_cluster_is_silent_when_the_dashboard_port_is_taken():
    """Catches the scheduler's HTTP server on the default port 8787: when another cluster (or
    any program) holds it, distributed writes a UserWarning to stderr, which shows in a
    notebook's output as a red warning."""
    import socket
    import warnings

    from vehicle_observers.campaign.engine import local_cluster

    with socket.socket() as held:
        held.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            held.bind(("0.0.0.0", 8787))
        except OSError:
            pass                          # already held by another process: the same case
        held.listen()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            cluster = local_cluster(1)
            try:
                port = cluster.scheduler.http_server.port
            finally:
                cluster.close()
    assert port != 8787
    assert not [w for w in caught if "already in use" in str(w.message)]


def test_failing_tasks_are_recorded_not_fatal(tiny_serial):
    spec, out, res, _ = tiny_serial
    assert res.num_rows == spec.n_tasks
    bad = res.filter(pc.invert(res["ok"])).to_pylist()
    # interval-ifqir2017 cannot be designed for the oversteering BMW box: every such task
    assert {(r["estimator"], r["car"]) for r in bad} == {("interval-ifqir2017", "bmw_320i")}
    assert len(bad) == 8
    assert all(r["error_type"] == "InfeasibleDesign" and "Metzler condition (20)" in r["error"]
               and np.isnan(r["rmse_vy"]) for r in bad)
    good = res.filter(res["ok"])
    assert all(np.isfinite(good["rmse_vy"].to_numpy()))


def test_interval_enclosure_where_the_guarantee_applies(tiny_serial):
    # Ifqir 2017: LPV truth inside the stiffness box, bounded noise, no bias, exact speed in
    # the bands -> the interval encloses v_y at every scored sample
    _, _, res, _ = tiny_serial
    g = res.filter(pc.and_(res["guarantee"], pc.equal(res["estimator"], "interval-ifqir2017")))
    g = g.filter(g["ok"])
    assert g.num_rows == 2 and all(e == 1.0 for e in g["enclosure_vy"].to_pylist())
    assert set(g["err_stiffness"].to_pylist()) == {0.0} and set(g["bias"].to_pylist()) == {0}


def test_resume_runs_only_missing_batches(tiny_serial, tmp_path):
    spec, out, ref, _ = tiny_serial
    import shutil

    dst = tmp_path / "copy"
    shutil.copytree(out, dst)
    gone = [3, 7, 21]
    for b in gone:
        batch_path(dst, "results", b).unlink()
    (dst / "results" / "batch-000004.parquet.partial-999999999").write_text("torn")
    s = run(TINY, dst, engine="serial", progress=False)
    assert s.run_now == sum(b - a for k, a, b in spec.batches() if k in gone) == 7
    assert s.done_before == 57 and s.lmi_run_now == 0
    assert not list((dst / "results").glob("*.partial-*"))
    assert same_bits(read_results(dst), ref) == []


def test_sigkill_mid_campaign_then_resume(tmp_path, monkeypatch):
    import psutil

    spec = tmp_path / "slow.toml"
    spec.write_text(dump_toml(SLOW))
    out = tmp_path / "out"
    p = subprocess.Popen([PY, "-m", "vehicle_observers", "campaign", str(spec), "--out", str(out),
                          "--workers", "1", "--no-progress"], env=plugin_env(0.15),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        wait_for(lambda: len(list((out / "results").glob("batch-*.parquet"))) >= 3
                 if (out / "results").exists() else False, 120, "three finished batches")
        kids = psutil.Process(p.pid).children(recursive=True)
        os.kill(p.pid, signal.SIGKILL)
        p.wait(10)
        # the embedded cluster's worker processes leave with their parent
        _, alive = psutil.wait_procs(kids, timeout=20)
        assert not alive, f"orphans: {[q.pid for q in alive]}"
    finally:
        kill_tree(p.pid)
        p.communicate()
    done = sorted(out.glob("results/batch-*.parquet"))
    assert 3 <= len(done) < 20, "the campaign was not killed mid-run"
    # resume here (the plug-in must be importable: this folder is on sys.path in the tests)
    monkeypatch.setenv("CAMPAIGN_TEST_SLEEP", "0")
    s = run(SLOW, out, engine="serial", progress=False)
    assert s.done_before == 2 * len(done) and s.run_now == 40 - s.done_before
    res = read_results(out)
    assert res["task"].to_pylist() == list(range(40))         # nothing lost or duplicated
    assert not list(out.glob("results/*.partial-*"))
    ref = tmp_path / "ref"
    run(SLOW, ref, engine="serial", progress=False)
    assert same_bits(res, read_results(ref)) == []
    # the diverging plug-in: recorded, counted, never stopped the campaign
    assert s.failed == 10 and s.failures == {"test-diverges": 10}
    bad = res.filter(pc.invert(res["ok"]))
    assert set(bad["error_type"].to_pylist()) == {"FloatingPointError"}
    assert all(e.startswith("diverged: vy_mps is not finite from t = 1.0")
               for e in bad["error"].to_pylist())
