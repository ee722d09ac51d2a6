"""The campaign's reference estimators: the readable step equals the compiled run, the open
loop equals the repository's RK4 simulator with linear tyres, the linear Kalman filter equals
filterpy's Kalman filter fed the same matrices; both are registered and run on logs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from vehicle_observers.campaign import truths as T
from vehicle_observers.core.protocol import run_readable
from vehicle_observers.estimation import available, score
from vehicle_observers.estimation import references as CE
from vehicle_observers.models.lateral import simulate_s1
from vehicle_observers.models.tires import LinearTire
from vehicle_observers.models.vehicle import KalmanTuning

pytestmark = pytest.mark.xdist_group("campaign")


def _data(n=400, dt=0.01, vx0=14.0, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    vx = vx0 + 3.0 * np.sin(0.3 * t)
    delta = 0.03 * np.sin(1.3 * t) + 2e-4 * rng.standard_normal(n)
    r = 0.1 * np.sin(1.3 * t - 0.2) + 0.002 * rng.standard_normal(n)
    ay = 1.2 * np.sin(1.3 * t - 0.3) + 0.05 * rng.standard_normal(n)
    return t, np.column_stack([vx, delta]), np.column_stack([r, ay])


def _vehicle():
    return T.observer_vehicle("bmw_320i", dict.fromkeys(("mass",), 0.0), 0.1, None,
                              KalmanTuning(q_vy=0.3, q_r=0.02, q_b=0.01, R_r=4e-6, R_ay=2.5e-3))


@pytest.mark.parametrize("cls", [CE.OpenLoopBicycle, CE.LinearKalman])
def test_readable_step_equals_compiled_run(cls):
    t, u, y = _data()
    obs = cls(_vehicle())
    a = obs.run(t, u, y[:, :len(obs.output_names)])
    b = run_readable(obs, t, u, y[:, :len(obs.output_names)])
    assert a.names == b.names
    np.testing.assert_allclose(a.x, b.x, rtol=1e-11, atol=1e-13)


def test_open_loop_equals_rk4_of_the_linear_tyre_model():
    # at constant speed and 100 Hz one RK4 step per sample is used (h ||A||_inf < 1): the
    # repository's RK4 simulator with linear tyres and small-angle slip, one substep
    t, u, y = _data()
    u[:, 0] = 16.0
    veh = _vehicle()
    p = veh.params
    lin = dataclasses.replace(p, tire_f=LinearTire(veh.C_f), tire_r=LinearTire(veh.C_r))
    X = simulate_s1([0.0, y[0, 0]], u[:, 1], u[:, 0], 0.01, lin, exact=False, relaxation=False,
                    substeps=1)
    A, _ = CE.linear_ab(CE.bicycle_constants(veh), 16.0)
    assert 0.01 * np.abs(A).sum(axis=1).max() < 1
    est = CE.OpenLoopBicycle(veh).run(t, u, y[:, :1])
    np.testing.assert_allclose(est.x, X[:, :2], rtol=1e-9, atol=1e-12)


def test_linear_kf_equals_filterpy():
    from filterpy.kalman import KalmanFilter

    t, u, y = _data(n=300)
    veh = _vehicle()
    obs = CE.LinearKalman(veh)
    est = obs.run(t, u, y)
    m, Iz, af, ar, Cf, Cr = CE.bicycle_constants(veh)
    tun = veh.kalman
    kf = KalmanFilter(dim_x=3, dim_z=2)
    kf.x = np.array([[0.0], [y[0, 0]], [0.0]])
    p0 = np.array(tun.P0, float)
    p0[0] = min(p0[0], (0.05 * u[0, 0]) ** 2)
    kf.P = np.diag(p0)
    kf.R = np.diag([tun.R_r, tun.R_ay])
    X = np.empty((len(t), 3))

    def update(k):
        vx = u[k, 0]
        kf.H = np.array([[0.0, 1.0, 0.0], [-(Cf + Cr) / (m * vx), -(af * Cf - ar * Cr) / (m * vx), 1.0]])
        kf.update((y[k] - np.array([0.0, Cf / m * u[k, 1]]))[:, None])
        X[k] = kf.x[:, 0]

    update(0)
    for k in range(1, len(t)):
        h = t[k] - t[k - 1]
        A, B = CE.linear_ab(CE.bicycle_constants(veh), u[k - 1, 0])
        Phi, Gam = CE.discretise(A, B, h)
        kf.F = np.eye(3)
        kf.F[:2, :2] = Phi
        kf.B = np.array([[Gam[0]], [Gam[1]], [0.0]])
        kf.Q = np.diag([tun.q_vy, tun.q_r, tun.q_b]) * h
        kf.predict(u=np.array([[u[k - 1, 1]]]))
        update(k)
    np.testing.assert_allclose(est.x, X, rtol=1e-8, atol=1e-10)


def test_registered_and_scored_on_a_campaign_log():
    reg = available()
    assert {"open-loop-linear", "linear-kf"} <= set(reg)
    tr = T.simulate_truth("lpv", "bmw_320i", ("slalom", (("duration", 6.0),)), 100.0)
    log = T.make_log(tr, 100.0, {"yaw_rate": 0.002, "delta": 2e-4, "vx": 0.0, "ay": 0.05,
                                 "yL": 0.0, "psiL": 0.0}, 1.0, {}, "gaussian",
                     np.random.default_rng(0))
    veh = T.observer_vehicle("bmw_320i", {}, 0.1, None, T.sensor_tuning(
        {"yaw_rate": 0.002, "ay": 0.05}, 1.0))
    m = log.t > 1.0
    ol = score(reg["open-loop-linear"].estimate(log, veh), log, m)["rmse_vy"]
    kf = score(reg["linear-kf"].estimate(log, veh), log, m)["rmse_vy"]
    # matched model (the LPV truth is this linear bicycle): both close to the truth, the
    # open loop limited only by RK4 vs Euler and the input noise
    assert ol < 0.01 and kf < 0.02
    # a wrong stiffness in the vehicle file costs the open loop an order of magnitude
    bad = T.observer_vehicle("bmw_320i", {"stiffness": -0.3}, 0.1, None, veh.kalman)
    assert bad.C_f == pytest.approx(0.7 * veh.C_f) and bad.C_r == pytest.approx(0.7 * veh.C_r)
    ol_b = score(reg["open-loop-linear"].estimate(log, bad), log, m)["rmse_vy"]
    assert ol_b > 10 * ol
