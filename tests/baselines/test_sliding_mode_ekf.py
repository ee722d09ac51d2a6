"""Random-walk-force EKF baseline for Rabhi 2004 Part A (planar_baseline)."""

import numpy as np
import pytest
from vehicle_observers.baselines import sliding_mode_ekf as pb
from vehicle_observers.baselines.filterpy_generic import numerical_jacobian, rk4_step
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.metrics import rmse
from vehicle_observers.core.protocol import Observer, run_readable
from vehicle_observers.models import planar as pl
from vehicle_observers.observers import sliding_mode as smo
from vehicle_observers_papers.rabhi_2004 import experiments as EX

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


def _post_fit_ratio(r, Y, std, m):
    """Per channel mean of ``(y - x_post)^2 / (R - P_post)``: the post-fit residual of a
    consistent (linear) Kalman filter has covariance ``R - H P_post H'``, so each ratio is
    near 1; an R that is too large (small) makes it small (large)."""
    res = Y[m] - r.x[m, :5]
    return np.mean(res**2 / (np.asarray(std) ** 2 - r.P_diag[m, :5]), axis=0)


def test_own_model_forces_consistent():
    """No mismatch: the EKF is (nearly, the transport terms are bilinear) the optimal filter,
    so after a 0.5 s burn-in the force errors are consistent with its covariance (mean
    normalised squared error near 1, measured 0.88-0.99; accepted 0.3-3 for a 1.5 s correlated
    sample; a wrong Jacobian sign or a 10x Q error fails it) and small against the force
    excursions. The NEES alone does not see a wrong R (100x R: 0.64-0.88), so the post-fit
    residuals are checked against R - P_post per channel (measured 0.96-1.04, accepted
    0.7-1.4; 100x R gives 0.01-0.43, R / 100 gives 5-96, both asserted to fail)."""
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
    ratio = _post_fit_ratio(r, Y, STD, m)
    assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio
    for scale in (10.0, 0.1):       # std x10 = R x100, std / 10 = R / 100
        rw = pb.run_force_ekf(t, Y, U, MODEL, STD * scale, t_rise=T_RISE, x0=X[0])
        bad = _post_fit_ratio(rw, Y, STD * scale, m)
        assert not np.all((bad > 0.7) & (bad < 1.4)), (scale, bad)


def test_block_mean_and_decimated_noise():
    """Decimation keeps every sample: the filter sees block means (R / dec), at the centres."""
    a = np.arange(23.0).reshape(-1, 1) * np.array([1.0, -2.0])
    b = pb.block_mean(a, 5)
    assert b.shape == (4, 2)
    for k in range(4):
        assert b[k] == pytest.approx(a[5 * k:5 * k + 5].mean(axis=0), rel=1e-15)
    assert np.array_equal(pb.block_mean(a, 1), a)
    t, U, X, Y = own_model_run(N=100)
    r = pb.run_force_ekf(t, Y, U, MODEL, STD, t_rise=T_RISE, x0=X[0], decimate=4)
    assert np.array_equal(r.z, pb.block_mean(Y, 4)) and np.array_equal(r.u, pb.block_mean(U, 4))
    assert np.allclose(np.diag(r.R), STD**2 / 4, rtol=1e-15)
    assert r.t == pytest.approx(t[::4] + 1.5 * DT, abs=1e-15)
    assert np.array_equal(r.idx, np.arange(0, 100, 4)) and r.dec == 4


def test_ukf_matches_ekf_on_own_model():
    t, U, X, Y = own_model_run(N=200)
    e = pb.run_force_ekf(t, Y, U, MODEL, STD, t_rise=T_RISE, x0=X[0])
    u = pb.run_force_ekf(t, Y, U, MODEL, STD, t_rise=T_RISE, x0=X[0], filter="ukf")
    m = t >= 0.5
    for i in range(4):
        assert rmse(u.F[m, i], X[m, 5 + i]) < 1.5 * rmse(e.F[m, i], X[m, 5 + i]) + 1.0


def test_part_a_run_same_data_and_metrics(monkeypatch):
    """The EKF runner sees exactly the SMO's measurements (same array, not just the same
    shape: a different seed fails), averaged over blocks of 10, and reports the SMO's metric
    against the block means of the true forces."""
    from vehicle_observers_papers.rabhi_2004 import constants as R

    man = pl.paper_manoeuvre(2.0, 5e-4)
    Xs = pl.simulate(pl.free_rolling_state(man.v0, P), man.U, 5e-4, P)
    noise = (0.02, 0.02, 0.002, 0.05, 0.05)
    o = EX.part_a_ekf_run(man, Xs, P, noise, noise=noise, seed=7, decimate=10, t_skip=1.0,
                          x2_err0=R.x2_err0, x3_err0=R.x3_err0)
    r = o["res"]
    Y_smo = EX.part_a_run(man, Xs, noise=noise, seed=7, p=P)["Y"]
    assert np.array_equal(o["Y"], Y_smo)
    assert np.array_equal(r.z, pb.block_mean(Y_smo, 10))
    assert not np.array_equal(r.z, pb.block_mean(pl.measurements(Xs, noise, 8), 10))
    assert np.array_equal(r.u, pb.block_mean(man.U, 10))
    nb = len(man.t) // 10
    assert np.array_equal(r.idx, np.arange(nb) * 10)
    assert r.t == pytest.approx(man.t[:nb * 10:10] + 4.5 * 5e-4, abs=1e-12)
    assert np.diag(r.R) == pytest.approx(np.array(noise) ** 2 / 10, rel=1e-12)
    peak = np.max(np.abs(Xs[:, 8:12]), axis=0)
    m = r.t >= 1.0
    for i, nm in enumerate(pb.FORCE_NAMES):
        F_ref = np.array([Xs[10 * k:10 * k + 10, 8 + i].mean() for k in range(nb)])
        e = rmse(r.F[m, i], F_ref[m])
        assert o[f"rmse_{nm}"] == pytest.approx(e, rel=1e-12)
        assert o[f"rmse_pct_{nm}"] == pytest.approx(100 * e / peak[i], rel=1e-12)
    # initial state: truth + the SMO's initial errors (the paper module's constants), zero forces
    seen = {}
    real = pb.run_force_ekf
    monkeypatch.setattr(pb, "run_force_ekf", lambda *a, **kw: seen.update(kw) or real(*a, **kw))
    EX.part_a_ekf_run(man, Xs, P, noise, decimate=10, x2_err0=R.x2_err0, x3_err0=R.x3_err0)
    x0 = np.concatenate([Xs[0, 3:6] + R.x2_err0, Xs[0, 6:8] + R.x3_err0, np.zeros(4)])
    assert np.array_equal(seen["x0"], x0) and np.isfinite(r.x).all()


def test_omega_h_is_the_observer_kernel():
    """The EKF model uses the SMO's own Omega(delta), H (one definition, smo._omega_h)."""
    f, h, jac, hjac = pb.force_rw_model(MODEL)
    x = np.array([15.0, 0.3, 0.1, 50.0, 51.0, 300.0, -20.0, 1000.0, 800.0])
    u = np.array([0.07, 100.0, -50.0])
    Om, Hm = np.empty((3, 4)), np.empty((2, 4))
    smo._omega_h(u[0], MODEL.as_array(), Om, Hm)
    dx = f(x, u)
    assert np.allclose(dx[:3] - [x[1] * x[2], -x[0] * x[2], 0.0], Om @ x[5:], rtol=1e-13)
    assert np.allclose(dx[3:5], u[1:] / [MODEL.J_f, MODEL.J_r] - Hm @ x[5:], rtol=1e-13)


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
        EX.force_errors(t, Y[:, :4], Y[:, :4], np.ones(4), t_skip=10.0)
    with pytest.raises(ObserverArgumentError, match="sensor_std"):
        pb.run_force_ekf(t, Y, U, MODEL, -STD)
    with pytest.raises(ObserverArgumentError, match="t_rise"):
        pb.run_force_ekf(t, Y, U, MODEL, STD, t_rise=-1.0)


def test_force_ekf_run_readable_equals_run_and_is_causal():
    """The random-walk-force EKF under the observer contract: the numpy predict/update step
    looped equals the filterpy loop (the same Joseph-form formulas and exact RK4 Jacobian in
    another product order: rounding only, 1e-9 relative over 200 steps, while a wrong
    predict/update order moves the forces by O(dt) ~ 1e-2 relative), and samples after k
    do not change the estimate at k."""
    t, U, X, Y = own_model_run(N=200)
    Q, R = pb.noise_rule(MODEL, STD, T_RISE)
    ekf = pb.ForceEKF(MODEL, DT, Q, R, np.diag(np.r_[np.ones(5), 1e6 * np.ones(4)]))
    assert isinstance(ekf, Observer)
    tr, rd = ekf.run(t, U, Y, X[0]), run_readable(ekf, t, U, Y, X[0])
    np.testing.assert_allclose(rd.x, tr.x, rtol=1e-9, atol=1e-9)
    k = 90
    Y2 = Y.copy()
    Y2[k + 1:] += 1.0
    np.testing.assert_array_equal(ekf.run(t, U, Y2, X[0]).x[:k + 1], tr.x[:k + 1])
