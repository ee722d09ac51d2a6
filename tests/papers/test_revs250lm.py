"""The real log's vehicle constants vs its PROVENANCE.md, and the linear-bicycle sanity check
printed there (open loop: yaw rate RMSE 0.10 rad/s, v_y RMSE 0.28 m/s, correlations 0.98/0.96)."""

import pytest
from vehicle_observers.core.metrics import correlation, rmse
from vehicle_observers.data import logs
from vehicle_observers.models import lateral
from vehicle_observers_papers.leanza_2021 import constants as R


def test_constants_as_published():
    assert (R.m, R.l_f, R.l_r, R.track) == (982.0, 1.33, 1.07, 1.35)
    assert R.I_z == pytest.approx(1605, abs=1)
    assert (R.C_f, R.C_r) == (0.7e5, 1.2e5)
    assert R.tire_f.cornering_stiffness == pytest.approx(R.C_f)
    assert R.tire_r.cornering_stiffness == pytest.approx(R.C_r)


def test_provenance_linear_bicycle_sanity_check():
    log = logs.load_revs()
    X = lateral.simulate_s1([log.vy[0], log.yaw_rate[0]], log.delta, log.vx, log.dt,
                            R.linear_params, exact=False, relaxation=False)
    assert rmse(X[:, 1], log.yaw_rate) == pytest.approx(0.10, abs=0.005)
    assert rmse(X[:, 0], log.vy) == pytest.approx(0.28, abs=0.005)
    assert correlation(X[:, 1], log.yaw_rate) == pytest.approx(0.98, abs=0.005)
    assert correlation(X[:, 0], log.vy) == pytest.approx(0.96, abs=0.005)
