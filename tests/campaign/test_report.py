"""The campaign report: its numbers recomputed from the rows by hand, and the command line."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest
from campaignkit import PY, subprocess_env
from vehicle_observers.campaign import report as R

pytestmark = pytest.mark.xdist_group("campaign")


@pytest.fixture(scope="module")
def rep(tiny_serial, tmp_path_factory):
    spec, out, res, _ = tiny_serial
    return R.tables(out), res.to_pylist()


def test_error_table_medians_and_paired_ratios(rep):
    t, rows = rep
    ok = [r for r in rows if r["ok"]]
    key = lambda r: tuple(r[c] for c in R.PAIR)
    ol = {key(r): r["rmse_vy"] for r in ok if r["estimator"] == "open-loop-linear"}
    for e in t["errors"]:
        v = 0.0 if e["parameter"] == "nominal" else e["error"]
        sel = [r for r in ok if r["estimator"] == e["estimator"] and r["err_stiffness"] == v]
        x = np.array([r["rmse_vy"] for r in sel])
        if not len(x):
            assert e["failed"] == e["n"] and np.isnan(e["median_rmse_vy"])
            continue
        assert e["median_rmse_vy"] == np.median(x)
        assert e["p90_rmse_vy"] == np.percentile(x, 90)
        assert e["ratio_open_loop"] == pytest.approx(np.median([r["rmse_vy"] / ol[key(r)]
                                                                for r in sel]))
    nominal = {e["estimator"]: e for e in t["errors"] if e["parameter"] == "nominal"}
    assert nominal["open-loop-linear"]["ratio_open_loop"] == 1.0
    assert nominal["linear-kf"]["ratio_linear_kf"] == 1.0
    assert {e["parameter"] for e in t["errors"]} == {"nominal", "stiffness"}


def test_conservatism_and_failures(rep):
    t, rows = rep
    c = {(r["car"], round(r["err_cf"], 9)): r for r in t["conservatism"]
         if r["estimator"] == "interval-ifqir2017"}
    assert sorted(c) == [("bmw_320i", 0.0), ("bmw_320i", 0.15), ("yacine2015", 0.0),
                         ("yacine2015", 0.15)]
    assert [c[k]["failed"] for k in sorted(c)] == [4, 4, 0, 0]
    assert all(c[k]["n"] == 4 for k in c)
    nominal = c[("yacine2015", 0.0)]
    assert nominal["in_box_share"] == 1.0 and c[("yacine2015", 0.15)]["in_box_share"] == 0.0
    assert nominal["guaranteed"] == 2 and nominal["guaranteed_enclosure_min"] == 1.0
    f = {r["estimator"]: r for r in t["failures"]}
    assert f["interval-ifqir2017"]["failed"] == 8 and f["interval-ifqir2017"]["n"] == 16
    assert f["ekf"]["failure_rate"] == 0.0
    assert "Metzler condition (20)" in f["interval-ifqir2017"]["most_frequent_error"]
    # the best estimator per region excludes the references
    assert all(b["best"] not in R.REFERENCES.values() for b in t["best"])
    s = t["lmi_summary"]
    assert len(s) == 1 and s[0]["points"] == 2 and s[0]["feasible"] == 1
    assert s[0]["max_feasible_rel"] == 0.05 < s[0]["metzler_bound"] < 0.3


def test_uncertainty_table_per_estimator_and_plant(rep):
    """Catches coverage / NEES averaged over runs instead of pooled over the scored samples
    (recomputed here from the rows, weighted by ``samples``), a table keyed by estimator only
    (one row per truth plant is wanted), and NaN cells for estimators that report no std or
    whose every run failed (they must read n/a). The EKF's std is its own covariance plus the
    calibration terms, so its coverage must lie in [0, 1] and its NEES be positive; nothing
    more is asserted about their values here (the benchmark grades them)."""
    t, rows = rep
    u = {(r["estimator"], r["plant"]): r for r in t["uncertainty"]}
    ests = {r["estimator"] for r in rows}
    plants = {f"{r['plant']}:{r['car']}" for r in rows}
    assert set(u) == {(e, p) for e in ests for p in plants}
    for (e, p), r in u.items():
        ok = [x for x in rows if x["ok"] and x["estimator"] == e
              and f"{x['plant']}:{x['car']}" == p]
        has_std = [x for x in ok if np.isfinite(x["coverage_vy"])]
        if not has_std:
            assert r["coverage_2sigma"] == R.NA and r["mean_nees"] == R.NA, r
            continue
        n = np.array([x["samples"] for x in has_std], float)
        cov = np.array([x["coverage_vy"] for x in has_std])
        nees = np.array([x["nees_vy"] for x in has_std])
        assert r["coverage_2sigma"] == pytest.approx(np.sum(cov * n) / n.sum(), rel=1e-12)
        assert r["mean_nees"] == pytest.approx(np.sum(nees * n) / n.sum(), rel=1e-12)
    assert all(isinstance(u[("ekf", p)]["coverage_2sigma"], float) for p in plants)
    assert all(u[("ekf", p)]["mean_nees"] > 0 for p in plants)
    assert u[("open-loop-linear", "lpv:yacine2015")]["coverage_2sigma"] == R.NA
    # the BMW's interval design is infeasible: every run failed, no RMSE either
    assert u[("interval-ifqir2017", "lpv:bmw_320i")]["median_rmse_vy"] == R.NA
    assert all(not (isinstance(v, float) and np.isnan(v)) for r in u.values()
               for v in r.values())


def test_cli_report(tiny_serial, tmp_path):
    import shutil

    _, out, _, _ = tiny_serial
    dst = tmp_path / "c"
    shutil.copytree(out, dst)
    p = subprocess.run([PY, "-m", "vehicle_observers", "campaign", "report", str(dst)],
                       capture_output=True, text=True, env={**subprocess_env(), "MPLBACKEND": "Agg"},
                       timeout=180)
    assert p.returncode == 0, p.stderr
    assert "interval-ifqir2017     failed 8/16" in p.stdout
    assert "ekf                    on lpv:yacine2015: median v_y RMSE " in p.stdout
    assert "2-sigma coverage n/a, mean NEES n/a" in p.stdout    # open-loop-linear
    summary = (dst / "report" / "summary.md").read_text()
    sec = summary.split("## Reported uncertainty of v_y per truth plant")[1].split("##")[0]
    assert "| ekf | lpv:yacine2015 |" in sec and "nan" not in sec.lower()
    for f in ("errors.csv", "conservatism.csv", "lmi_map.csv", "failures.csv", "summary.md",
              "uncertainty.csv", "warnings.csv",
              "error_effect.png", "conservatism.png", "feasibility.png", "failures.png"):
        assert (dst / "report" / f).stat().st_size > 0, f
    p = subprocess.run([PY, "-m", "vehicle_observers", "campaign", "report", str(tmp_path)],
                       capture_output=True, text=True, env=subprocess_env(), timeout=120)
    assert p.returncode == 2 and "not a campaign folder" in p.stderr
