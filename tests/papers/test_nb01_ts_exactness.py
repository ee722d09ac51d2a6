"""Helpers of notebook 01 (exactness.py) that are not covered by the notebook test."""

import pytest
from vehicle_observers_papers.yacine_2015 import ts_exactness as exactness


def test_revs_fit_metrics_names_units_and_values():
    fit = {"yaw_rmse": 0.07, "yaw_corr": 0.98, "yaw_fit": 72.0, "vy_rmse": 0.35, "vy_corr": 0.9}
    fits = {name: {k: v + i for k, v in fit.items()} for i, name in enumerate(exactness.FIT_KEYS)}
    m = exactness.revs_fit_metrics(fits)
    assert len(m) == 15
    assert m["revs_nl_yaw_rmse"] == (0.07, "rad/s")
    assert m["revs_ts_vy_rmse"] == (pytest.approx(1.35), "m/s")
    assert m["revs_lin_yaw_fit"] == (74.0, "")
    t = exactness.fit_rows(fits)
    assert [r["model"] for r in t.rows] == list(exactness.FIT_KEYS)
    assert t.cells()[2][1] == "2.07"                 # linear bicycle yaw RMSE (0.07 + 2)
