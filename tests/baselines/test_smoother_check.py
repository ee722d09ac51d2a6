"""RTS-loss diagnosis: the smoother beats the EKF on its own model, the whiteness test
flags a mismatched model, and no reference column is read."""

from dataclasses import replace

import numpy as np
import pytest
from vehicle_observers.baselines import kalman as K
from vehicle_observers.baselines import smoother_check as SC
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.tires import LinearTire, Pacejka

P = LateralParams(m=1500, I_z=2454, a_f=1.1, a_r=1.44,
                  tire_f=Pacejka(B=10.0, C=1.3, D=7000.0, E=0.0),
                  tire_r=Pacejka(B=12.0, C=1.3, D=8000.0, E=0.0))
TUN = K.KalmanTuning(q_vy=1e-2, q_r=1e-3, q_b=1e-3, R_r=4e-6, R_ay=2.5e-3)


def _inputs(n=3000, dt=0.01, seed=7):
    """Measured-input grid: seeded band-limited steering at 18 m/s (reference columns are
    placeholders: the diagnosis must not read them)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    d = 0.03 * np.sin(2 * np.pi * 0.4 * t) + 0.01 * np.sin(2 * np.pi * 1.1 * t + rng.uniform(0, 6))
    return DriveLog(t=t, vx=np.full(n, 18.0), delta=d, yaw_rate=np.zeros(n), ay=np.zeros(n),
                    vy=np.zeros(n))


def test_simulation_is_seeded_and_smoother_beats_filter_on_own_model():
    log = _inputs()
    a = SC.simulate_matched(log, P, TUN, seed=3)
    b = SC.simulate_matched(log, P, TUN, seed=3)
    assert np.array_equal(a.ay, b.ay) and np.array_equal(a.vy, b.vy)
    assert not np.array_equal(a.ay, SC.simulate_matched(log, P, TUN, seed=4).ay)
    mr = SC.matched_model_ratio(log, P, TUN, seeds=(0, 1, 2), max_samples=None)
    assert mr["ratio"] < 1.0
    assert all(r < 1.0 for r in mr["per_seed"])


def test_ljung_box_known_answer_and_power():
    rng = np.random.default_rng(0)
    x = rng.standard_normal(5000)
    lb = SC.ljung_box(x, lags=5)
    xc = x - x.mean()
    rho = [np.sum(xc[:-k] * xc[k:]) / np.sum(xc * xc) for k in range(1, 6)]
    n = len(x)
    Q = n * (n + 2) * sum(r**2 / (n - k) for k, r in zip(range(1, 6), rho))
    assert lb["Q"] == pytest.approx(Q, rel=1e-12)
    assert lb["white"]
    ar = np.empty(5000)
    ar[0] = 0.0
    for k in range(1, 5000):       # AR(1) with coefficient 0.3: coloured
        ar[k] = 0.3 * ar[k - 1] + x[k]
    assert not SC.ljung_box(ar, lags=5)["white"]
    with pytest.raises(ValueError):
        SC.ljung_box(x[:5], lags=5)


def test_whiteness_separates_own_model_from_mismatched_model():
    """Innovations are white on data of the filter's own model and coloured when the data
    come from a car with 40 % softer front tyres (same inputs, same noise draw)."""
    log = _inputs()
    own = SC.simulate_matched(log, P, TUN, seed=1)
    w = SC.innovation_whiteness(own, P, TUN)
    assert w["r"]["white"] and w["ay"]["white"]
    soft = replace(P, tire_f=Pacejka(B=10.0, C=1.3, D=0.6 * 7000.0, E=0.0))
    other = SC.simulate_matched(log, soft, TUN, seed=1)
    d = SC.rts_loss_diagnosis(other, P, TUN, seeds=(0,), max_samples=1500)
    assert d["model_mismatch"]
    assert d["smoother_correct"]


def test_diagnosis_never_reads_the_reference():
    log = _inputs(n=1500)
    sim = SC.simulate_matched(log, P, TUN, seed=2)
    a = SC.rts_loss_diagnosis(sim, P, TUN, seeds=(0,), max_samples=800)
    garbage = replace(sim, vy=np.full(len(sim), 123.0))
    b = SC.rts_loss_diagnosis(garbage, P, TUN, seeds=(0,), max_samples=800)
    assert a == b


def test_bias_coupling_slope_known_answer():
    t = np.arange(100) * 0.01
    X = np.zeros((100, 3))
    Y = np.zeros((100, 3))
    Y[:, 2] = np.sin(t)
    Y[:, 0] = 0.25 * np.sin(t)
    mk = lambda X_: K.KalmanRun(t, X_, K.STATE_NAMES, P=np.zeros((100, 3, 3)), Ff=t, Fr=t)  # noqa: E731
    bc = SC.bias_coupling(mk(X), mk(Y))
    assert bc["slope"] == pytest.approx(0.25) and bc["r2"] == pytest.approx(1.0)


def test_linear_tyres_supported():
    p = replace(P, tire_f=LinearTire(8e4), tire_r=LinearTire(9e4))
    sim = SC.simulate_matched(_inputs(n=400), p, TUN, seed=0)
    assert np.isfinite(sim.vy).all() and len(sim) == 400
