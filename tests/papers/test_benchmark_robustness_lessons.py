"""Library parts of the lessons of notebooks 07 and 08 against independent computations."""

import numpy as np
import pytest
from scipy import stats
from vehicle_observers.baselines import kalman as K
from vehicle_observers.models.vehicle import load_vehicle
from vehicle_observers_papers.benchmark_study import lesson as L7
from vehicle_observers_papers.robustness_study import lesson as L8


def test_filterpy_update_is_the_joseph_update_of_the_library_ekf():
    p = load_vehicle("revs250lm").params
    tun = K.KalmanTuning()
    obs = K.LateralEKF(K.KalmanDesign(p, tun))
    rng = np.random.default_rng(1)
    A = rng.normal(size=(3, 3))
    P = A @ A.T * 0.01 + 1e-3 * np.eye(3)
    x, y = np.array([0.3, 0.1, 0.05]), np.array([0.12, 2.0])
    R = np.diag([tun.R_r, tun.R_ay])
    got = L7.filterpy_update(x, P, y, 0.02, 30.0, p, R)
    want = obs._update(x, P, y, 0.02, 30.0)
    assert np.allclose(got[0], want[0], rtol=1e-10, atol=1e-14)
    assert np.allclose(got[1], want[1], rtol=1e-10, atol=1e-14)


def test_running_interval_against_scipy():
    x = np.array([0.03, 0.05, 0.04, 0.07, 0.02])
    n, mean, half = L8.running_interval(x)
    assert list(n) == [2, 3, 4, 5]
    for k, m, h in zip(n, mean, half):
        lo, hi = stats.t.interval(0.95, k - 1, loc=x[:k].mean(), scale=stats.sem(x[:k]))
        assert m == pytest.approx(x[:k].mean()) and h == pytest.approx((hi - lo) / 2)


def test_worked_monte_carlo_is_seeded_and_grows_with_the_stiffness_error():
    e1, r1 = L8.worked_monte_carlo(3, 6)
    e2, r2 = L8.worked_monte_carlo(3, 6)
    assert np.array_equal(e1, e2) and np.array_equal(r1, r2)
    assert np.all(np.abs(e1) <= 0.2)
    # a wrong rear stiffness biases v_y: the RMSE grows with |error| (rank correlation)
    assert stats.spearmanr(np.abs(e1), r1).statistic > 0.8


def test_readable_tables_rename_and_keep_order():
    rows, cols = L7.readable([{"observer": "ekf", "rmse_vy": 0.2, "x": 1}], ["observer", "rmse_vy"])
    assert cols == ["observer", "v_y RMSE [m/s]"] and rows == [{"observer": "ekf", "v_y RMSE [m/s]": 0.2}]


def test_numpy_ekf_is_the_compiled_filter_and_its_update_is_filterpys():
    """Catches a readable twin that drifted from the kernel: the numpy EKF (predict with the RK4
    step, Joseph update) equals ``K.ekf`` on 5 s of the real log, and one Joseph update equals
    filterpy's ``ExtendedKalmanFilter.update`` from the same prior."""
    import numpy as np
    from vehicle_observers.baselines import kalman as K
    from vehicle_observers.data.logs import load_revs
    from vehicle_observers_papers.benchmark_study import lesson as BL
    from vehicle_observers_papers.leanza_2021 import constants as rv

    log = load_revs()
    log = log.segment(log.t[0], log.t[0] + 5.0)
    tun = K.KalmanTuning()
    X, P = BL.numpy_ekf(log, rv.params, tun)
    np.testing.assert_allclose(X, K.ekf(log, rv.params, tun).X, rtol=0, atol=1e-10)
    R = np.diag([tun.R_r, tun.R_ay])
    inp = K.prepare(log)
    y = np.array([inp.yr[50], inp.ay[50]])
    mine = BL.joseph_update(X[49], P, y, inp.delta[50], inp.vx[50], rv.params, R)
    theirs = BL.filterpy_update(X[49], P, y, inp.delta[50], inp.vx[50], rv.params, R)
    np.testing.assert_allclose(mine[0], theirs[0], atol=1e-12)
    np.testing.assert_allclose(mine[1], theirs[1], atol=1e-12)
