"""Exercise checkers of notebook 07: each accepts a worked solution, rejects a wrong answer and
says "not attempted" for an empty stub."""

from dataclasses import replace

import numpy as np
from vehicle_observers import estimation as EST
from vehicle_observers.baselines import kalman as K
from vehicle_observers.data.scenarios import emulated_satory, sine_with_dwell
from vehicle_observers.estimation.registry import unregister
from vehicle_observers.models.vehicle import load_vehicle
from vehicle_observers.results import teaching
from vehicle_observers_papers.benchmark_study import exercises as ex


def _status(key):
    return teaching.RESULTS[key]


def test_check_1_scalar_update_against_filterpy():
    def good(x, P, y, R):
        S = P[1, 1] + R
        k = P[:, 1] / S
        return x + k * (y - x[1]), P - S * np.outer(k, k)

    def naive(x, P, y, R):                # forgets R in the innovation variance
        k = P[:, 1] / P[1, 1]
        return x + k * (y - x[1]), P - P[1, 1] * np.outer(k, k)

    ex.check_1(good)
    assert _status("07.1") == teaching.CORRECT
    ex.check_1(naive)
    assert _status("07.1") == teaching.WRONG
    ex.check_1(lambda x, P, y, R: ...)
    assert _status("07.1") == teaching.EMPTY


def test_check_2_nees_tuning():
    from vehicle_observers.estimation import kalman_runs as KR

    car = load_vehicle("yacine2015")
    log = emulated_satory(seed=0, quick=True)
    mask = (log.vx > 1.0) & (log.t - log.t[0] > 1.0)
    tun, _ = KR.kalman_tuning(log, car)

    def nees(s):
        r = K.ekf(log, car.params, replace(tun, q_vy=tun.q_vy * s))
        e = r.vy - log.vy
        return float(np.mean(e[mask] ** 2 / r.P[mask, 0, 0]))

    # the ML tuning of r and a_y is over-confident about v_y here (NEES >> 1): a larger q_vy
    assert nees(1.0) > 2.0
    s_ok = next(s for s in (10.0, 30.0, 100.0, 300.0, 1000.0) if 0.5 <= nees(s) <= 2.0)
    ex.check_2(nees, s_ok, log, car.params, tun, mask)
    assert _status("07.2") == teaching.CORRECT
    ex.check_2(nees, 1.0, log, car.params, tun, mask)     # the over-confident ML tuning
    assert _status("07.2") == teaching.WRONG
    ex.check_2(lambda s: 2 * nees(s), s_ok, log, car.params, tun, mask)
    assert _status("07.2") == teaching.WRONG
    ex.check_2(nees, ..., log, car.params, tun, mask)
    assert _status("07.2") == teaching.EMPTY


def test_check_3_registered_estimator():
    revs = load_vehicle("revs250lm")
    yac = load_vehicle("yacine2015")
    logs = [(emulated_satory(seed=0, quick=True).segment(0.0, 5.0), yac),
            (sine_with_dwell(seed=1), yac), (sine_with_dwell(seed=2, vx=25.0), revs)]

    def run(log, vehicle, **_):
        p = vehicle.params
        L = p.a_f + p.a_r
        vy = log.yaw_rate * (p.a_r - p.m * p.a_f * log.vx ** 2 / (p.tire_r.cornering_stiffness * L))
        return EST.Trajectory.from_columns(log.t, {"vy_mps": vy})

    def kinematic(log, vehicle, **_):      # the low-speed kinematic v_y = l_r r: wrong at speed
        return EST.Trajectory.from_columns(log.t, {"vy_mps": vehicle.params.a_r * log.yaw_rate})

    try:
        EST.register(EST.EstimatorSpec("test-steady-state", "test", run), replace=True)
        EST.register(EST.EstimatorSpec("test-kinematic", "test", kinematic), replace=True)
        ex.check_3("test-steady-state", logs)
        assert _status("07.3") == teaching.CORRECT
        ex.check_3("test-kinematic", logs)
        assert _status("07.3") == teaching.WRONG
        ex.check_3(..., logs)
        assert _status("07.3") == teaching.EMPTY
    finally:
        unregister("test-steady-state")
        unregister("test-kinematic")
