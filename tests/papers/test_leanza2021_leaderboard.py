"""Leaderboard targets are computed from the rows (planted values flip them), "best causal"
excludes baselines and smoothers, and the consistency columns follow their definition."""

import numpy as np
import pytest
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.data.logs import DriveLog
from vehicle_observers_papers.leanza_2021 import leaderboard as LB


def _row(ds, o, v, causal=True, **kw):
    return {"dataset": ds, "observer": o, "rmse_vy": v, "rmse_beta_deg": 10 * v,
            "causal": causal, **kw}


def _table(best=0.05):
    return [_row("plant_x", "open-loop-linear", 0.1), _row("plant_x", "linear-kf-ml", 0.07),
            _row("plant_x", "vy-zero", 0.3), _row("plant_x", "rts", 0.01, causal=False),
            _row("plant_x", "adaptive-ekf", best, coverage_2sigma=0.95, nees=1.1,
                 verdict="informative"),
            _row("revs", "mbds-fg", 0.24, causal=False), _row("revs", "vy-zero", 0.74),
            _row("revs", "adaptive-ekf", 0.19, coverage_2sigma=0.8, nees=3.0,
                 verdict="informative")]


def test_targets_are_computed_and_flip():
    tg = {(t["dataset"], t["target"]): t for t in LB.targets(_table(), us_per_step=2.0)}
    ol = tg[("plant_x", "best causal <= 0.8 x open loop")]
    assert ol["met"] and ol["value"] == pytest.approx(0.5)     # rts (offline) not counted
    assert tg[("plant_x", "best causal <= 0.85 x linear KF")]["met"]
    assert tg[("revs", "best causal v_y RMSE <= 0.2 m/s")]["met"]
    beta = tg[("revs", "best causal sideslip RMSE <= 0.7 x MBDS factor graph")]
    assert beta["value"] == pytest.approx(1.9 / 2.4) and not beta["met"]
    assert not tg[("revs", "adaptive-ekf 2-sigma coverage in [0.85, 0.99]")]["met"]  # 0.8
    assert tg[("plant_x", "adaptive-ekf 2-sigma coverage in [0.85, 0.99]")]["met"]
    assert tg[("all", "richest causal cost <= 3 us/step")]["met"]
    tg2 = {(t["dataset"], t["target"]): t for t in LB.targets(_table(best=0.09), 4.0)}
    assert not tg2[("plant_x", "best causal <= 0.8 x open loop")]["met"]
    assert not tg2[("all", "richest causal cost <= 3 us/step")]["met"]


def test_uninformative_flag_satisfies_the_vy_zero_target():
    t = _table(best=0.5)
    key = ("plant_x", "beats v_y = 0 or flagged uninformative")
    assert not {(x["dataset"], x["target"]): x for x in LB.targets(t)}[key]["met"]
    t[4]["verdict"] = "uninformative"
    assert {(x["dataset"], x["target"]): x for x in LB.targets(t)}[key]["met"]


def test_score_row_coverage_and_nees_of_a_consistent_std():
    rng = np.random.default_rng(0)
    n = 100_000
    t = np.arange(n) * 0.01
    ref = rng.standard_normal(n)
    s = np.full(n, 0.2)
    vy = ref + s * rng.standard_normal(n)
    log = DriveLog(t=t, vx=np.full(n, 20.0), delta=np.zeros(n), yaw_rate=np.zeros(n), vy=ref)
    tr = Trajectory.from_columns(t, {"vy_mps": vy, "vy_std_mps": s})
    r = LB.score_row(tr, log, np.ones(n, bool))
    assert r["coverage_2sigma"] == pytest.approx(0.9545, abs=0.003)
    assert r["nees"] == pytest.approx(1.0, abs=0.02)
    assert r["rmse_vy"] == pytest.approx(0.2, rel=0.01)


def test_claims_judge_the_targets_from_the_metrics():
    """Every target but the wall-clock one becomes a kind="target" claim whose rule, evaluated
    on the recorded (4-digit) metrics, gives "reproduced" exactly when targets() says met."""
    from vehicle_observers.results.reporting import Report

    for best in (0.05, 0.09, 0.5):
        table = _table(best)
        table.append(_row("revs", "open-loop-linear", 0.28))
        rep = Report("t", None, show=False)
        rep.record(metrics=LB.metrics(table))
        rep.record(claims=LB.claims(table))
        tg = {f"{t['dataset']}: {t['target']}": t["met"] for t in LB.targets(table)}
        got = {c.item: c.verdict for c in rep.claims}
        assert set(got) == set(tg)
        assert {k: v == "reproduced" for k, v in got.items()} == tg
        assert all(c.kind == "target" and c.rule_def["source"].startswith("chosen here:")
                   for c in rep.claims)
    flag = "beats v_y = 0 or flagged uninformative"
    assert {c.item: c.verdict for c in rep.claims}[f"plant_x: {flag}"] == "differs"
    assert not any("us_per_step" in k or "seconds" in k for k in LB.metrics(_table()))


def test_slow_names_exactly_the_pure_python_filterpy_references():
    """Catches SLOW naming the compiled UKF (``ukf``: its rows were left out of the
    leaderboard while ``ukf-filterpy`` ran) instead of filterpy's: SLOW must be the registered
    estimators that run filterpy, in both the leaderboard and the benchmark study."""
    from vehicle_observers.estimation import available
    from vehicle_observers_papers.benchmark_study import runs

    specs = available()
    filterpy = {n for n, s in specs.items() if "with filterpy" in s.description}
    assert filterpy == {"ekf-filterpy", "ukf-filterpy"}
    assert set(LB.SLOW) == filterpy and set(runs.SLOW) == filterpy
    assert "numba" in specs["ukf"].description


def test_ratio_targets_graded_on_every_dataset_but_revs():
    """Catches the claims grading the open-loop / linear-KF targets only on datasets named
    ``plant_*`` (car 2) while :func:`targets` computes them on the other cars' and the
    emulated runs too: claims and targets must list the same items for every dataset."""
    from vehicle_observers.results.reporting import Report

    table = _table()
    for ds in ("plant3_x", "emu_swd"):
        table += [{**r, "dataset": ds} for r in _table() if r["dataset"] == "plant_x"]
    rep = Report("t", None, show=False)
    rep.record(metrics=LB.metrics(table))
    rep.record(claims=LB.claims(table))
    items = {c.item for c in rep.claims}
    assert items == {f"{t['dataset']}: {t['target']}" for t in LB.targets(table)}
    for ds in ("plant3_x", "emu_swd"):
        assert f"{ds}: best causal <= 0.8 x open loop" in items
        assert f"{ds}: best causal <= 0.85 x linear KF" in items


def test_group_table_has_every_estimator_and_no_nan():
    """Catches an estimator silently missing from a group's table (not applicable, or it
    raised: the reason must be shown), and NaN cells for quantities an estimator does not
    report (coverage / NEES of an estimator without a std must read n/a); the verdict and
    the uninformative flag of every row reach the metrics."""
    rows = [_row("d1", "ekf", 0.1, coverage_2sigma=0.9, nees=1.2, verdict="informative"),
            _row("d1", "vy-zero", 0.3, verdict="uninformative")]
    t = LB.group_table(rows, ["ekf", "ts-yacine2015", "interval-ifqir2017", "vy-zero"],
                       skipped=[("d1", "ts-yacine2015", "needs column 'yL_m'")],
                       errors=["d1/interval-ifqir2017: InfeasibleDesign: Metzler (20)"])
    by = {r["observer"]: r for r in t}
    assert list(by) == ["ekf", "ts-yacine2015", "interval-ifqir2017", "vy-zero"]
    assert by["ekf"]["coverage_2sigma"] == 0.9 and by["ekf"]["nees"] == 1.2
    assert by["vy-zero"]["coverage_2sigma"] == LB.NA == by["vy-zero"]["nees"]
    assert by["ts-yacine2015"]["verdict"] == "not applicable: needs column 'yL_m'"
    assert by["interval-ifqir2017"]["verdict"].startswith("failed: InfeasibleDesign")
    assert all(not (isinstance(v, float) and np.isnan(v)) for r in t for v in r.values())
    m = LB.metrics(rows)
    assert m["lb.d1.vy-zero.uninformative"][0] == 1 and m["lb.d1.ekf.uninformative"][0] == 0


def test_every_keeps_the_rows_of_every_column():
    """Catches a decimation that drops a column (the emulated truth ``vx_true_mps`` used by
    the score mask, or the reference ``vy_mps``) or misaligns them."""
    n = 1000
    t = np.arange(n) * 0.001
    log = DriveLog(t=t, vx=10 + t, delta=0.01 * np.sin(t), yaw_rate=np.cos(t), vy=np.sin(3 * t),
                   extra={"vx_true_mps": 10 + 2 * t})
    d = LB.every(log, 10)
    assert len(d) == 100 and d.dt == pytest.approx(0.01)
    for c, v in log.columns().items():
        np.testing.assert_array_equal(d.columns()[c], v[::10])


def test_merge_groups_keeps_every_row_and_names_every_missing_estimator():
    """Catches a group's rows lost when the groups are merged for the metrics and claims, and
    an estimator without a row left unnamed (not applicable, or it raised)."""
    g1 = {"rows": [_row("a", "ekf", 0.1)], "skipped": [("a", "ts", "needs yL_m")], "errors": []}
    g2 = {"rows": [_row("b", "ekf", 0.2), _row("b", "ukf", 0.3)], "skipped": [],
          "errors": ["b/interval: InfeasibleDesign: x"]}
    rows, lines = LB.merge_groups({"g1": g1, "g2": g2})
    assert [(r["dataset"], r["observer"]) for r in rows] == [("a", "ekf"), ("b", "ekf"),
                                                             ("b", "ukf")]
    assert lines == ["a/ts: not applicable: needs yL_m", "b/interval: InfeasibleDesign: x"]


def test_filterpy_references_are_never_best_causal():
    """Catches a filterpy reference named "best causal" because its round-off puts it a hair
    below the compiled filter it checks (it is the same filter, not a candidate)."""
    t = _table() + [_row("plant_x", "ekf-filterpy", 0.01), _row("plant_x", "ukf-filterpy", 0.01)]
    m = LB.metrics(t)
    assert m["lb_plant_x_best_causal_rmse_vy"][2] == "adaptive-ekf"
