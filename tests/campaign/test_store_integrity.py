"""A campaign folder cannot mix campaigns, and a spec is sized before anything runs.

Batch files planted in a finished campaign folder (another campaign's file under the same
name, a file without metadata, a file holding the rows of another batch, a torn file, a
file outside the plan) are refused by name on resume and recomputed (the rows equal a
clean run bit for bit), and left out of the report, which counts each task once and names
the missing ones. Specs too large to run, or with impossible manoeuvres, are refused in one
line before anything runs; a truth that fails gives the same rows on both engines; a task
that hangs is stopped by ``timeout_s`` and recorded."""

from __future__ import annotations

import json
import shutil
import subprocess
import time

import pyarrow.parquet as pq
import pytest
from campaignkit import PY, SLOW, TINY, plugin_env, same_bits, subprocess_env
from vehicle_observers.campaign import load_spec, read_results, run, store
from vehicle_observers.campaign import report as R
from vehicle_observers.campaign.spec import MAX_TASKS, SpecError, dump_toml

pytestmark = pytest.mark.xdist_group("campaign")


def _rewrite(path, table=None, meta=None, drop_meta=False):
    t = pq.read_table(path) if table is None else table
    kv = dict(t.schema.metadata or {})
    kv.pop(store.META_KEY, None)
    if not drop_meta:
        kv[store.META_KEY] = json.dumps(meta)
    pq.write_table(t.replace_schema_metadata(kv), path)


def _plant(kind, dst, spec):
    """Plant one bad file of class ``kind`` in campaign folder ``dst``; returns its name and
    the tasks it hides (those of the batch it replaces)."""
    f = store.batch_path(dst, "results", 5)
    bid, a, b = spec.batches()[5]
    meta = store.read_meta(f)
    if kind == "other-campaign":          # same name, same task range, another campaign
        other = load_spec({**TINY, "seed": 8})
        _rewrite(f, meta={**meta, "spec_sha256": other.sha256})
    elif kind == "no-metadata":           # an older writer, or a file copied from elsewhere
        _rewrite(f, drop_meta=True)
    elif kind == "rows-of-another-batch":  # a duplicate: batch 4's rows under batch 5's name
        shutil.copy(store.batch_path(dst, "results", 4), f)
    elif kind == "meta-lies-about-rows":  # right description, rows of another range
        _rewrite(f, table=pq.read_table(store.batch_path(dst, "results", 4)), meta=meta)
    elif kind == "torn":
        f.write_bytes(f.read_bytes()[:200])
    elif kind == "outside-the-plan":      # an extra file, no batch missing
        shutil.copy(store.batch_path(dst, "results", 4), store.batch_path(dst, "results", 999))
        return "batch-000999.parquet", []
    return f.name, list(range(a, b))


KINDS = ("other-campaign", "no-metadata", "rows-of-another-batch", "meta-lies-about-rows",
         "torn", "outside-the-plan")


@pytest.mark.parametrize("kind", KINDS)
def test_planted_batch_file_is_named_left_out_of_the_report_and_recomputed(
        tiny_serial, tmp_path, kind, caplog):
    """Catches: a foreign or duplicated batch file taken as done (a task counted twice,
    another one never run, rows of two campaigns summarised together)."""
    spec, out, ref, _ = tiny_serial
    dst = tmp_path / "c"
    shutil.copytree(out, dst)
    shutil.rmtree(dst / "report", ignore_errors=True)
    name, hidden = _plant(kind, dst, spec)
    # the report: each task once, the planted file named, the hidden tasks missing
    t = R.tables(dst)
    rej = [(f.name, why) for f, why in t["integrity"]["rejected"]]
    assert [n for n, _ in rej] == [name], rej
    got = R.store.read_results(dst, spec=spec)["task"].to_pylist()
    assert got == sorted(set(range(spec.n_tasks)) - set(hidden))
    assert t["rows"] == spec.n_tasks - len(hidden)
    lines = R.integrity_lines(t["integrity"])
    assert any(name in x for x in lines)
    if hidden:
        assert any(f"missing {len(hidden)} simulation(s)" in x
                   and f"{hidden[0]}..{hidden[-1]}" in x for x in lines), lines
    # the resume: named, moved aside (not deleted), recomputed; equal to the clean run
    s = run(TINY, dst, engine="serial", progress=False)
    assert s.run_now == len(hidden) and s.done_before == spec.n_tasks - len(hidden)
    assert any(name in r.getMessage() and "does not belong" in r.getMessage()
               for r in caplog.records)
    assert len(list((dst / "rejected").iterdir())) == 1
    assert same_bits(read_results(dst, spec=spec), ref) == []
    assert R.tables(dst)["integrity"] == {"rejected": [], "missing": [], "lmi_missing": []}


def test_every_batch_file_describes_itself(tiny_serial):
    """Catches: a batch file written without its spec hash, task range, schema version or
    provenance (nothing to verify it against)."""
    spec, out, _, _ = tiny_serial
    for bid, a, b in spec.batches():
        m = store.read_meta(store.batch_path(out, "results", bid))
        assert m["spec_sha256"] == spec.sha256 and (m["start"], m["stop"]) == (a, b)
        assert m["schema_version"] == store.SCHEMA_VERSION and m["kind"] == "results"
        assert m["provenance"]["package_version"]
        assert store.verify_batch(store.batch_path(out, "results", bid), spec, "results",
                                  bid, a, b) is None


def test_cli_report_warns_about_a_foreign_file(tiny_serial, tmp_path):
    """Catches: ``campaign report`` summarising a foreign file without a word."""
    spec, out, _, _ = tiny_serial
    dst = tmp_path / "c"
    shutil.copytree(out, dst)
    _plant("other-campaign", dst, spec)
    p = subprocess.run([PY, "-m", "vehicle_observers", "campaign", "report", str(dst)],
                       capture_output=True, text=True,
                       env={**subprocess_env(), "MPLBACKEND": "Agg"}, timeout=180)
    assert p.returncode == 0, p.stderr
    assert "ignored results/batch-000005.parquet: written by another campaign" in p.stderr
    assert "missing 3 simulation(s)" in p.stderr
    assert f"{spec.n_tasks - 3} of {spec.n_tasks} simulations" in p.stdout
    assert "batch-000005.parquet" in (dst / "report" / "summary.md").read_text()


@pytest.mark.parametrize("refs", [["linear-kf", "linear-kf"],
                                  ["open-loop-linear", "linear-kf", "open-loop-linear"]])
def test_a_reference_listed_twice_runs_once(refs):
    """Catches: the same simulation run (and counted in the report's medians) twice."""
    once = load_spec({**TINY, "references": list(dict.fromkeys(refs))})
    twice = load_spec({**TINY, "references": refs})
    assert twice.n_tasks == once.n_tasks and twice.pairs == once.pairs


# ------------------------------------------------------------------ sizing --------------
BIG = {
    "factorial of 1e12 variants": {"errors": {"design": "factorial",
                                              "mass": {"start": -0.5, "stop": 0.5, "num": 10 ** 6},
                                              "inertia": {"start": -0.5, "stop": 0.5,
                                                          "num": 10 ** 6}}},
    "1e7 sampled variants": {"errors": {"design": "sample", "samples": 10 ** 7,
                                        "mass": [-0.1, 0.1]}},
    "repetitions": {"repetitions": 10 ** 6},
    "noise grid x repetitions": {"repetitions": 1000,
                                 "sensors": {"noise_scale": {"start": 0.1, "stop": 2.0,
                                                             "num": 1000}}},
    "LMI map of 1e12 points": {"lmi_map": {"cars": ["bmw_320i"],
                                           "stiffness_rel": {"start": 0.01, "stop": 0.9,
                                                             "num": 10 ** 6},
                                           "kappa": {"start": -1.0, "stop": 1.0, "num": 10 ** 6}}},
    "batch files": {"repetitions": 5000, "batch_size": 1},
}


@pytest.mark.parametrize("case", list(BIG))
def test_oversized_plan_refused_at_once_naming_the_count(case):
    """Catches: a plan enumerated (variants, tasks, map points) before its size is known:
    minutes of work, then MemoryError."""
    t0 = time.perf_counter()
    with pytest.raises(SpecError) as e:
        load_spec({**TINY, **BIG[case]})
    assert time.perf_counter() - t0 < 5.0
    msg = str(e.value)
    assert "\n" not in msg and "limit" in msg, msg


def test_size_is_counted_not_enumerated():
    """Catches: a size that differs from the plan's enumeration (the count is an independent
    computation of the same number)."""
    for extra in ({}, {"errors": {"design": "factorial", "mass": [-0.1, 0.0, 0.1],
                                  "stiffness": [0.2, 0.3]}},
                  {"errors": {"design": "sample", "samples": 7, "mass": [-0.1, 0.1]}},
                  {"observer": {"stiffness_rel": [0.1, 0.2], "speed_range": [[5.0, 20.0],
                                                                              [6.0, 19.0]]}}):
        s = load_spec({**TINY, **extra})
        z = s.size()
        assert z["tasks"] == s.n_tasks == len(s.pairs) * len(s.variants) * 4
        assert z["lmi_points"] == len(s.lmi_points)
        assert z["batches"] == len(s.batches())
    assert MAX_TASKS >= 10 ** 5


@pytest.mark.parametrize("man, needle", [
    ({"name": "slalom", "duration": -6.0}, "duration"),
    ({"name": "slalom", "duration": 1e7}, "duration"),
    ({"name": "slalom", "vx": 0.0}, "vx"),
    ({"name": "slalom", "vx": -12.0}, "vx"),
    ({"name": "slalom", "ramp": 0.0}, "ramp"),
    ({"name": "sine_with_dwell", "frequency_hz": 0.0}, "frequency_hz"),
    ({"name": "sine_with_dwell", "amplitude": 3.0}, "amplitude"),
    ({"name": "sine_with_dwell", "t_after": 5000.0, "t_before": 0.0}, "t_after"),
    ({"name": "ramp_steer", "duration": 0.0}, "duration"),
    ({"name": "satory", "duration": 1e9}, "duration"),
])
def test_impossible_manoeuvre_refused_naming_the_argument(man, needle):
    """Catches: a manoeuvre the spec check passes and every task then fails on (or a truth
    that takes the machine's memory)."""
    with pytest.raises(SpecError) as e:
        load_spec({**TINY, "truth": {**TINY["truth"], "manoeuvres": [man]}})
    assert f"truth.manoeuvres.{man['name']}" in str(e.value) and needle in str(e.value)


@pytest.mark.parametrize("edit, key", [
    ({"sensors": {"std": {"ay": float("nan")}}}, "sensors.std.ay"),
    ({"sensors": {"noise_scale": [1.0, float("inf")]}}, "sensors.noise_scale[1]"),
    ({"errors": {"mass": [float("-inf")]}}, "errors.mass[0]"),
    ({"seed": float("nan")}, "seed"),
])
def test_non_finite_number_named_by_its_key(edit, key):
    """Catches: NaN / inf reported as "not JSON compliant" without the key."""
    with pytest.raises(SpecError) as e:
        load_spec({**TINY, **edit})
    assert f"key '{key}'" in str(e.value)


@pytest.mark.parametrize("entry", [{"name": ["ekf", "ukf"], "plants": ["lpv:bmw_320i"]},
                                   {"name": 3, "plants": ["lpv:bmw_320i"]},
                                   {"name": {"a": 1}, "plants": ["lpv:bmw_320i"]}])
def test_estimator_table_with_a_non_string_name_refused(entry):
    """Catches: an internal TypeError (unhashable list) instead of one line."""
    with pytest.raises(SpecError, match="one estimator name"):
        load_spec({**TINY, "estimators": ["ekf", entry]})


# ------------------------------------------------------------------ engines, timeouts ----
FAILING_TRUTH = {
    "name": "failing-truth", "seed": 1, "batch_size": 2, "plugins": ["campaign_plugin"],
    "estimators": ["ekf"], "references": ["open-loop-linear"],
    "truth": {"plants": ["lpv:bmw_320i"],
              "manoeuvres": [{"name": "slalom", "duration": 5.5},
                             {"name": "slalom", "duration": 4.0}]},
}


def test_engines_agree_when_a_truth_fails(tmp_path, monkeypatch):
    """Catches: the Dask engine ending with "Compute Failed" (exit 3) where the serial one
    records failed rows: the engines must give the same rows."""
    monkeypatch.setenv("PYTHONPATH", plugin_env(0)["PYTHONPATH"])
    s1 = run(FAILING_TRUTH, tmp_path / "serial", engine="serial", progress=False)
    s2 = run(FAILING_TRUTH, tmp_path / "dask", engine="dask", workers=1, progress=False)
    a, b = read_results(tmp_path / "serial"), read_results(tmp_path / "dask")
    assert same_bits(a, b) == []
    assert s1.failed == s2.failed == 2              # ekf and open loop on the 5.5 s slalom
    bad = a.filter(~a["ok"].to_numpy(zero_copy_only=False))
    assert set(bad["error_type"].to_pylist()) == {"RuntimeError"}
    assert all("planted by the tests" in e for e in bad["error"].to_pylist())


@pytest.mark.parametrize("engine", ["serial", "dask"])
def test_task_that_never_returns_is_stopped_and_recorded(tmp_path, monkeypatch, engine):
    """Catches: a plug-in whose run never returns hanging the whole campaign."""
    monkeypatch.setenv("PYTHONPATH", plugin_env(0)["PYTHONPATH"])
    monkeypatch.setenv("CAMPAIGN_TEST_HANG", "1")
    spec = {**SLOW, "name": "hangs", "repetitions": 1, "timeout_s": 0.5,
            "estimators": ["test-hangs", "test-slow"]}
    t0 = time.perf_counter()
    s = run(spec, tmp_path / engine, engine=engine, workers=1, progress=False) \
        if engine == "dask" else run(spec, tmp_path / engine, engine=engine, progress=False)
    assert time.perf_counter() - t0 < 90
    res = read_results(tmp_path / engine).to_pylist()
    hung = [r for r in res if r["estimator"] == "test-hangs"]
    assert hung and all(r["error_type"] == "TaskTimeout" and not r["ok"] for r in hung)
    assert "timeout_s = 0.5 s" in hung[0]["error"]
    assert all(r["ok"] for r in res if r["estimator"] == "test-slow")
    assert s.failures == {"test-hangs": len(hung)}


# ------------------------------------------------------------------ the command line ----
def _cli(args, env=None, timeout=180):
    return subprocess.run([PY, "-m", "vehicle_observers", "campaign", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout,
                          env=env or {**subprocess_env(), "MPLBACKEND": "Agg"})


def test_report_folder_that_is_a_file_is_one_line(tiny_serial, tmp_path):
    """Catches: an internal FileExistsError when DIR/report is a file."""
    _, out, _, _ = tiny_serial
    dst = tmp_path / "c"
    shutil.copytree(out, dst)
    shutil.rmtree(dst / "report", ignore_errors=True)
    (dst / "report").write_text("mine")
    p = _cli(["report", dst])
    assert p.returncode == 2 and p.stderr.count("\n") == 1
    assert "exists and is not a folder" in p.stderr
    assert (dst / "report").read_text() == "mine"


@pytest.mark.parametrize("edit, needle", [
    ({"estimators": [{"name": ["ekf", "ukf"], "plants": ["lpv:bmw_320i"]}]}, "one estimator"),
    ({"repetitions": 10 ** 6}, "limit"),
    ({"truth": {"plants": ["lpv:bmw_320i"], "manoeuvres": [{"name": "slalom", "vx": 0.0}]}},
     "vx"),
])
def test_bad_spec_is_one_line_exit_2(tmp_path, edit, needle):
    """Catches: internal errors (exit 3) or tracebacks for a wrong spec."""
    f = tmp_path / "s.toml"
    f.write_text(dump_toml({**TINY, **edit}))
    p = _cli([f, "--out", tmp_path / "o", "--engine", "serial"])
    assert p.returncode == 2, p.stderr
    assert p.stderr.count("\n") == 1 and needle in p.stderr


def test_out_that_cannot_be_written_is_one_line(tmp_path, monkeypatch):
    """Catches: an internal OSError for an unwritable --out (read-only file system)."""
    import errno
    import os

    def refuse(*a, **k):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))

    monkeypatch.setattr(store.Path, "mkdir", refuse)
    with pytest.raises(SpecError, match="read-only file system"):
        run(TINY, tmp_path / "ro", engine="serial", progress=False)


def test_disk_full_mid_campaign_keeps_the_batches_and_resumes_exactly(tiny_serial, tmp_path,
                                                                      monkeypatch):
    """Catches: an internal OSError on a full disk, and a resume that loses or repeats a
    task after it."""
    import errno

    from vehicle_observers.cli.main import main

    spec, _, ref, _ = tiny_serial
    real = store.write_batch
    n = {"k": 0}

    def full(*a, **k):
        n["k"] += 1
        if n["k"] > 4:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(*a, **k)

    monkeypatch.setattr(store, "write_batch", full)
    f = tmp_path / "s.toml"
    f.write_text(dump_toml(TINY))
    import contextlib
    import io

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["campaign", str(f), "--out", str(tmp_path / "o"), "--engine", "serial",
                     "--no-progress"])
    assert code == 2, err.getvalue()
    assert "the disk is full" in err.getvalue() and "4 of " in err.getvalue()
    assert "the same command resumes" in err.getvalue()
    monkeypatch.setattr(store, "write_batch", real)
    s = run(TINY, tmp_path / "o", engine="serial", progress=False)
    assert s.done_before == sum(b - a for k, a, b in spec.batches()[:4])
    assert same_bits(read_results(tmp_path / "o"), ref) == []


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_signal_says_what_was_kept_and_closes_the_cluster(tmp_path, sig):
    """Catches: "no output written" although batches were kept, and worker processes or
    semaphores leaked by a handler that exits without closing the cluster."""
    import os
    import signal

    import psutil
    from campaignkit import kill_tree, wait_for

    spec = tmp_path / "slow.toml"
    spec.write_text(dump_toml(SLOW))
    out = tmp_path / "out"
    p = subprocess.Popen([PY, "-m", "vehicle_observers", "campaign", str(spec), "--out", str(out),
                          "--workers", "1", "--no-progress"], env=plugin_env(0.15),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for(lambda: len(list((out / "results").glob("batch-*.parquet"))) >= 2
                 if (out / "results").exists() else False, 120, "two finished batches")
        kids = psutil.Process(p.pid).children(recursive=True)
        os.kill(p.pid, getattr(signal, sig))
        _, err = p.communicate(timeout=60)
        _, alive = psutil.wait_procs(kids, timeout=20)
        assert not alive, f"orphans: {[q.pid for q in alive]}"
    finally:
        kill_tree(p.pid)
    kept = len(list((out / "results").glob("batch-*.parquet")))
    assert p.returncode == 128 + getattr(signal, sig), err
    assert f"interrupted by {sig}; {kept} of 20 batch(es) kept" in err, err
    assert "leaked" not in err and "Traceback" not in err, err


def test_many_foreign_files_are_counted_not_listed(tiny_serial, tmp_path, caplog):
    """Catches: a folder of an older format flooding the terminal with one line per file
    (every file is still moved aside and recomputed)."""
    spec, out, ref, _ = tiny_serial
    dst = tmp_path / "c"
    shutil.copytree(out, dst)
    shutil.rmtree(dst / "report", ignore_errors=True)
    for bid, _, _ in spec.batches():
        _rewrite(store.batch_path(dst, "results", bid), drop_meta=True)
    lines = R.integrity_lines(R.integrity(dst, spec))
    assert len(lines) == store.MAX_NAMED + 2             # named, counted, missing tasks
    assert f"missing {spec.n_tasks} simulation(s)" in lines[-1]
    s = run(TINY, dst, engine="serial", progress=False)
    assert s.run_now == spec.n_tasks
    assert len([r for r in caplog.records if "does not belong" in r.getMessage()
                or "did not belong" in r.getMessage()]) == store.MAX_NAMED + 1
    assert len(list((dst / "rejected").iterdir())) == len(spec.batches())
    assert same_bits(read_results(dst, spec=spec), ref) == []
