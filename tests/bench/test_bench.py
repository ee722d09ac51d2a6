"""Benchmark plumbing: rows, ratios, files (fast observers only; the Kalman rows are covered by
tests/notebooks/test_notebook_07.py)."""

import json

import numpy as np
import pytest
from vehicle_observers.estimation import score
from vehicle_observers_papers.benchmark_study import runs, writers


@pytest.fixture(scope="module")
def res():
    return runs.run(quick=True, observers=["interval-ifqir2017", "ts-yacine2015"])


def test_rows_cover_applicable_observers(res):
    got = {(r["dataset"], r["observer"]) for r in res["rows"]}
    for d in ("satory_n1", "satory_n3", "swd"):
        assert {(d, "interval-ifqir2017"), (d, "ts-yacine2015")} <= got
    # the real log has no vision channels: the TS observer is not applicable there
    assert ("revs", "interval-ifqir2017") in got and ("revs", "ts-yacine2015") not in got
    assert not res["errors"]
    for r in res["rows"]:
        est = res["estimates"][(r["dataset"], r["observer"])]
        log, mask = res["logs"][r["dataset"]], res["masks"][r["dataset"]]
        assert r["rmse_vy"] == score(est, log, mask)["rmse_vy"]
        assert r["realtime_factor"] == pytest.approx(log.duration / est.seconds)


def test_outputs_and_metrics_file_list(res, tmp_path):
    paths = writers.write_outputs(res, tmp_path, topics=[{"topic": "x", "component": "y", "steps": 1,
                                                     "seconds": 1.0, "us_per_step": 1e6}])
    names = {p.name for p in paths}
    assert {"benchmark.csv", "benchmark.md", "metrics.json", "rmse_cost.png",
            "speed_topics.csv", "losses_revs.csv", "revs_vy.png"} <= names
    doc = json.loads((tmp_path / "metrics.json").read_text())
    assert set(doc["files"]) == {p.name for p in tmp_path.iterdir()}
    assert doc["quick"] is True
    md = (tmp_path / "benchmark.md").read_text()
    assert "| revs | interval-ifqir2017 |" in md
    # losses table: shares of each factor's bins sum to 1
    loss = runs.revs_losses(res["logs"]["revs"], {o: e for (d, o), e in res["estimates"].items()
                                                  if d == "revs"})
    for f in {r["factor"] for r in loss}:
        assert sum(r["share"] for r in loss if r["factor"] == f) == pytest.approx(1.0, abs=1e-3)
    assert np.isfinite([r["interval-ifqir2017"] for r in loss]).all()


def test_leaderboard_files(res, tmp_path):
    """make bench writes the leaderboard table (leaderboard.csv / .md, targets met / MISSED)
    beside the benchmark and keeps both in metrics.json's file list."""
    from vehicle_observers_papers.leanza_2021 import leaderboard as LB

    table = [{"dataset": "plant_x", "observer": o, "causal": True, "rmse_vy": v,
              "rmse_beta_deg": 10 * v} for o, v in (("open-loop-linear", 0.1), ("linear-kf-ml", 0.07),
                                                    ("vy-zero", 0.3), ("mbds-kf", 0.09))]
    tg = LB.targets(table)
    paths = writers.write_outputs(res, tmp_path, leaderboard=(table, tg, ["plant_x/x: n/a"]))
    assert {"leaderboard.csv", "leaderboard.md"} <= {p.name for p in paths}
    md = (tmp_path / "leaderboard.md").read_text()
    assert "| plant_x | mbds-kf | yes | 0.09 | 0.9 |" in md
    assert "| best causal <= 0.8 x open loop | 0.9 | 0.8 | MISSED |" in md
    assert "| best causal <= 0.85 x linear KF | 1.286 | 0.85 | MISSED |" in md
    doc = json.loads((tmp_path / "metrics.json").read_text())
    assert {"leaderboard.csv", "leaderboard.md"} <= set(doc["files"])
    assert (tmp_path / "leaderboard.csv").read_text().splitlines()[0].startswith("dataset,observer")
