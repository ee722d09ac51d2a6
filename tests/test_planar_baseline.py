"""Random-walk-force EKF baseline for Rabhi 2004 Part A (planar_baseline)."""

import numpy as np
import pytest
from vehicle_observers import planar as pl
from vehicle_observers import planar_baseline as pb
from vehicle_observers import smo
from vehicle_observers.filterpy_baseline import numerical_jacobian, rk4_step
from vehicle_observers.metrics import rmse

P = pl.PlanarParams()
MODEL = smo.ForceObserverModel.from_params(P)
DT = 5e-3
STD = np.array([0.002, 0.002, 2e-4, 0.005, 0.005])  # small sensor noise
T_RISE = 50.0  # s: Q_F = F_max^2 / 50 s, a random walk of ~1.7 kN over 2 s


def own_model_run(N=400, seed=3):
    """Truth = the EKF's own model: RK4 step of f, forces a random walk drawn with the
    filter's own Q (Q dt per step), measurements x[:5] + N(0, R). No mismatch at all."""
    f, h, jac, hjac = pb.force_rw_model(MODEL)
    Q, R = pb.noise_rule(MODEL, STD, T_RISE)
    rng = np.random.default_rng(seed)
    t = np.arange(N) * DT
    U = np.column_stack([0.03 * np.sin(2 * np.pi * 0.5 * t), np.full(N, 200.0), np.zeros(N)])
    X = np.empty((N, 9))
    x = np.concatenate([[15.0, 0.0, 0.0], [50.0, 50.0], np.zeros(4)])
    for k in range(N):
        X[k] = x
        x = rk4_step(f, x, U[k], DT)
        x[5:] += rng.normal(size=4) * np.sqrt(np.diag(Q)[5:] * DT)
    Y = X[:, :5] + rng.normal(size=(N, 5)) * STD
    return t, U, X, Y


def test_rk4_jacobian_is_exact():
    f, h, jac, hjac = pb.force_rw_model(MODEL)
    x = np.array([15.0, 0.3, 0.1, 50.0, 51.0, 300.0, -20.0, 1000.0, 800.0])
    u = np.array([0.03, 100.0, -50.0])
    xn, F = jac(x, u, DT)
    assert np.allclose(xn, rk4_step(f, x, u, DT), rtol=0, atol=1e-12)
    Fn = numerical_jacobian(lambda s: rk4_step(f, s, u, DT), x)
    assert np.abs(F - Fn).max() < 1e-7  # central differences agree to ~1e-9
    assert np.allclose(hjac(x, u), numerical_jacobian(lambda s: h(s, u), x))


def test_noise_rule():
    Q, R = pb.noise_rule(MODEL, STD, 0.5)
    assert Q.shape == (9, 9) and R.shape == (5, 5)
    assert np.all(Q[:5] == 0) and np.allclose(np.diag(R), STD**2)
    Fz_f = P.m * pl.G_ACC * P.l_r / P.L
    assert Q[5, 5] == pytest.approx(Fz_f**2 / 0.5)
    with pytest.raises(ValueError, match="sensor_std"):
        pb.noise_rule(MODEL, STD[:4])
    with pytest.raises(ValueError, match="t_rise"):
        pb.noise_rule(MODEL, STD, 0.0)


def test_own_model_forces_consistent():
    """No mismatch: the EKF is (nearly, the transport terms are bilinear) the optimal filter,
    so after a 0.5 s burn-in the force errors are consistent with its covariance (mean
    normalised squared error near 1; accepted 0.3-3 for a 1.5 s correlated sample; a wrong
    Jacobian sign or Q scaling fails it) and small against the force excursions."""
    t, U, X, Y = own_model_run()
    r = pb.run_force_ekf(t, Y, U, MODEL, STD, t_rise=T_RISE, x0=X[0], filter="ekf")
    assert r.F.shape == (len(t), 4) and r.F_std.shape == (len(t), 4) and r.x.shape == (len(t), 9)
    m = t >= 0.5
    e = r.F[m] - X[m, 5:]
    nees = np.mean((e / r.F_std[m]) ** 2, axis=0)
    assert np.all((nees > 0.3) & (nees < 3.0)), nees
    for i in range(4):
        excursion = np.ptp(X[:, 5 + i])
        assert rmse(r.F[m, i], X[m, 5 + i]) < 0.1 * excursion
    assert r.us_per_step > 0


def test_ukf_matches_ekf_on_own_model():
    t, U, X, Y = own_model_run(N=200)
    e = pb.run_force_ekf(t, Y, U, MODEL, STD, t_rise=T_RISE, x0=X[0])
    u = pb.run_force_ekf(t, Y, U, MODEL, STD, t_rise=T_RISE, x0=X[0], filter="ukf")
    m = t >= 0.5
    for i in range(4):
        assert rmse(u.F[m, i], X[m, 5 + i]) < 1.5 * rmse(e.F[m, i], X[m, 5 + i]) + 1.0


def test_part_a_run_same_data_and_metrics():
    """The EKF runner sees exactly the SMO's measurements and reports the SMO's metric."""
    man = pl.paper_manoeuvre(2.0, 5e-4)
    Xs = pl.simulate(pl.free_rolling_state(man.v0, P), man.U, 5e-4, P)
    noise = (0.02, 0.02, 0.002, 0.05, 0.05)
    o = pb.part_a_ekf_run(man, Xs, P, noise, noise=noise, seed=7, decimate=10, t_skip=1.0)
    r = o["res"]
    assert np.array_equal(r.idx, np.arange(0, len(man.t), 10))
    assert np.array_equal(r.t, man.t[::10])
    peak = np.max(np.abs(Xs[:, 8:12]), axis=0)
    m = r.t >= 1.0
    for i, nm in enumerate(pb.FORCE_NAMES):
        e = rmse(r.F[m, i], Xs[r.idx][m, 8 + i])
        assert o[f"rmse_{nm}"] == pytest.approx(e)
        assert o[f"rmse_pct_{nm}"] == pytest.approx(100 * e / peak[i])
    # initial state: truth + the SMO's initial errors, zero forces
    Y = smo.measurements_from_truth(Xs, noise, 7)
    assert np.isfinite(r.x).all() and Y.shape == (len(man.t), 5)


def test_input_errors():
    t, U, X, Y = own_model_run(N=20)
    with pytest.raises(ValueError, match="Y must be"):
        pb.run_force_ekf(t, Y[:, :4], U, MODEL, STD)
    with pytest.raises(ValueError, match="U must be"):
        pb.run_force_ekf(t, Y, U[:, :2], MODEL, STD)
    with pytest.raises(ValueError, match="decimate"):
        pb.run_force_ekf(t, Y, U, MODEL, STD, decimate=0)
    with pytest.raises(ValueError, match="filter"):
        pb.run_force_ekf(t, Y, U, MODEL, STD, filter="pf")
    with pytest.raises(ValueError, match="uniformly"):
        pb.run_force_ekf(t[::-1], Y, U, MODEL, STD)
    with pytest.raises(ValueError, match="t_skip"):
        pb.force_errors(t, Y[:, :4], Y[:, :4], np.ones(4), t_skip=10.0)
