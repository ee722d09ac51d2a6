"""The speed table of every registered estimator (vehicle_observers.bench.estimators): its
structure, plug-ins included; no timing value is asserted (wall clock)."""

from __future__ import annotations

import sys
import textwrap

import numpy as np
import pytest
from vehicle_observers import estimation as EST
from vehicle_observers.bench import estimators as BE
from vehicle_observers.core.protocol import Trajectory


@pytest.fixture(scope="module")
def short_log():
    """The benchmark's own log, cut to 1.5 s (the structure does not depend on its length)."""
    log = BE.bench_log(quick=True)
    return log.segment(log.t[0], log.t[0] + 1.5)


@pytest.fixture
def zero_estimator():
    """A plug-in registered by the test: v_y = 0 everywhere (decorator way in)."""
    @EST.estimator("test-zero-vy", "v_y = 0 (test plug-in)")
    def _run(log, vehicle, **opts):
        return Trajectory(log.t, np.zeros((len(log), 1)), ("vy_mps",), seconds=0.0,
                          estimator="test-zero-vy")
    yield "test-zero-vy"
    EST.registry.unregister("test-zero-vy")


def test_one_row_per_registered_estimator_plugin_included(short_log, zero_estimator):
    rows = BE.run(log=short_log)
    assert [r["component"] for r in rows] == list(EST.available())
    by = {r["component"]: r for r in rows}
    assert zero_estimator in by and by[zero_estimator]["origin"] == __name__
    builtin = ("ekf", "ekf-filterpy", "ukf", "rts", "ts-yacine2015", "interval-ifqir2017",
               "interval-coordinates")
    assert set(builtin) <= set(by)
    for r in rows:
        assert set(BE.COLUMNS) - {"error"} <= set(r), r
        assert r["steps"] == len(short_log)
        assert "error" not in r, r
        assert r["us_per_step"] > 0 or r["component"] in (zero_estimator, "vy-zero")  # no work
        assert r["seconds"] > 0
    # the ratio is filterpy's EKF cost per step over the row's, from the same run
    ref = by["ekf-filterpy"]["us_per_step"]
    assert by["ekf-filterpy"]["speedup_vs_filterpy_ekf"] == 1.0
    for r in rows:
        if r["us_per_step"] > 0:
            assert r["speedup_vs_filterpy_ekf"] == pytest.approx(ref / r["us_per_step"])
    assert by["rts"]["causal"] is False and by["interval-ifqir2017"]["interval"] is True
    # an estimator reporting no loop time (seconds = 0 here) still gets its row, no ratio
    assert by[zero_estimator]["us_per_step"] == 0.0
    assert np.isnan(by[zero_estimator]["speedup_vs_filterpy_ekf"])


def test_a_plugin_module_is_loaded_and_benchmarked(short_log, tmp_path, monkeypatch, capsys):
    (tmp_path / "bench_plugin_mod.py").write_text(textwrap.dedent('''
        import numpy as np
        from vehicle_observers.core.protocol import Trajectory
        from vehicle_observers.estimation import estimator

        @estimator("test-plugin-module", "mean yaw rate (test plug-in module)")
        def run(log, vehicle):                       # no **opts: the tuning is not passed
            return Trajectory(log.t, np.full((len(log), 1), log.yaw_rate.mean()),
                              ("yaw_rate_radps",), estimator="test-plugin-module")
    '''))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(BE, "bench_log", lambda quick=False: short_log)
    try:
        rows = BE.run(plugins=["bench_plugin_mod"], names=["ekf-filterpy", "test-plugin-module"])
        r = {x["component"]: x for x in rows}["test-plugin-module"]
        assert "error" not in r and r["steps"] == len(short_log)
        # seconds NaN in its Trajectory: the whole call's wall time per step is reported
        assert r["us_per_step"] == pytest.approx(1e6 * r["seconds"] / len(short_log))
        BE.main(["--quick", "--plugin", "bench_plugin_mod"])
        out = capsys.readouterr().out
        assert "test-plugin-module" in out and "speedup_vs_filterpy_ekf" in out
    finally:
        EST.registry.unregister("test-plugin-module")
        sys.modules.pop("bench_plugin_mod", None)


def test_an_estimator_that_does_not_apply_gets_an_error_row(short_log):
    @EST.estimator("test-needs-gps", "needs a column the log lacks", columns=("gps_speed_mps",))
    def _run(log, vehicle, **opts):
        raise AssertionError("never called: the column check fails first")
    try:
        rows = BE.run(log=short_log, names=["ekf-filterpy", "test-needs-gps"])
    finally:
        EST.registry.unregister("test-needs-gps")
    r = rows[-1]
    assert r["component"] == "test-needs-gps" and "gps_speed_mps" in r["error"]
    assert np.isnan(r["us_per_step"]) and np.isnan(r["speedup_vs_filterpy_ekf"])


def test_the_reproductions_benchmark_includes_the_rows(short_log, monkeypatch):
    from vehicle_observers_papers.benchmark_study import speed

    assert speed.SPEED_TOPICS["estimators"] == "vehicle_observers.bench.estimators"
    monkeypatch.setattr(BE, "bench_log", lambda quick=False: short_log)
    monkeypatch.setattr(BE, "available", lambda plugins=(): {
        k: v for k, v in EST.available(plugins).items() if k in ("ekf", "ekf-filterpy")})
    rows = speed.topic_benchmarks(quick=True, skip=set(speed.SPEED_TOPICS) - {"estimators"})
    assert [(r["topic"], r["component"]) for r in rows] == [("estimators", "ekf"),
                                                            ("estimators", "ekf-filterpy")]
