"""EKF / UKF / RTS baselines: implementation cross-checks, SPD covariance, tuning, accuracy."""

from dataclasses import replace

import numpy as np
import pytest
from vehicle_observers.baselines import kalman as K
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.metrics import rmse
from vehicle_observers.core.protocol import Observer, Trajectory, run_readable
from vehicle_observers.data.logs import DriveLog, load_revs
from vehicle_observers.data.scenarios import NOISE_STD, emulated_satory
from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.tires import LinearTire
from vehicle_observers_papers.leanza_2021 import constants as R
from vehicle_observers_papers.yacine_2015 import constants as Y

TUN = K.KalmanTuning(q_vy=0.27, q_r=2e-3, q_b=0.4, R_r=1.6e-5, R_ay=1.3)


@pytest.fixture(scope="module")
def revs():
    return load_revs()


@pytest.fixture(scope="module")
def satory():
    return emulated_satory(seed=0, quick=True)


def test_rk4_jacobian_matches_finite_differences():
    x = np.array([0.4, 0.3, 0.1])
    for p, delta, vx in ((Y.params, 0.08, 12.0), (R.params, 0.05, 30.0)):
        xn, F = K.rk4_step(x, delta, vx, 0.01, p)
        Fd = np.empty((3, 3))
        for j in range(3):
            e = np.zeros(3)
            e[j] = 1e-6
            Fd[:, j] = (K.rk4_step(x + e, delta, vx, 0.01, p)[0]
                        - K.rk4_step(x - e, delta, vx, 0.01, p)[0]) / 2e-6
        assert np.abs(F - Fd).max() < 1e-7
        # one RK4 step agrees with the model's own right-hand side to O(h^2)
        f = np.zeros(3)
        A = np.zeros((3, 3))
        K._rhs(x, delta, vx, p.as_array(), f, A)
        assert np.allclose((xn - x) / 0.01, f, rtol=0.05, atol=0.05)


def test_measurement_model_is_lateral_acceleration():
    x = np.array([0.3, 0.2, 0.05])
    p = R.params
    y, H = K.measure(x, 0.04, 25.0, p)
    af = 0.04 - (0.3 + p.a_f * 0.2) / 25.0
    ar = -(0.3 - p.a_r * 0.2) / 25.0
    assert y[0] == 0.2
    assert y[1] == pytest.approx((p.tire_f.force(af) + p.tire_r.force(ar)) / p.m + 0.05,
                                 rel=1e-12)
    Hd = np.array([(K.measure(x + e, 0.04, 25.0, p)[0] - K.measure(x - e, 0.04, 25.0, p)[0])
                   / 2e-6 for e in np.eye(3) * 1e-6]).T
    assert np.abs(H - Hd).max() < 1e-6


@pytest.mark.parametrize("use_ay", [True, False])
def test_numba_ekf_equals_filterpy_ekf(revs, use_ay):
    seg = revs.segment(300.0, 310.0)
    a = K.ekf(seg, R.params, TUN, use_ay=use_ay)
    b = K.ekf_filterpy(seg, R.params, TUN, use_ay=use_ay)
    assert np.abs(a.X - b.X).max() < 1e-9
    assert np.abs(a.P[:, 0, 0] - b.P[:, 0, 0]).max() < 1e-12


def test_rts_equals_filterpy_smoother_on_linear_model():
    """With linear tyres and no steering the model is linear: our extended RTS must equal
    filterpy's KalmanFilter.rts_smoother fed with the same filter pass."""
    from filterpy.kalman import KalmanFilter

    p = LateralParams(m=1500, I_z=2454, a_f=1.1, a_r=1.44, tire_f=LinearTire(4e4),
                      tire_r=LinearTire(4.5e4))
    rng = np.random.default_rng(3)
    N = 400
    t = np.arange(N) * 0.01
    vx = np.full(N, 15.0)
    # free response from vy = 0.5 m/s, r = 0.2 rad/s plus measurement noise
    x = np.array([0.5, 0.2, 0.0])
    X = np.empty((N, 3))
    for k in range(N):
        X[k] = x
        x = K.rk4_step(x, 0.0, 15.0, 0.01, p)[0]
    ay_true = np.array([K.measure(X[k], 0.0, 15.0, p)[0][1] for k in range(N)])
    log = DriveLog(t=t, vx=vx, delta=np.zeros(N), yaw_rate=X[:, 1] + 0.003 * rng.standard_normal(N),
                   ay=ay_true + 0.1 * rng.standard_normal(N), vy=X[:, 0])
    tun = K.KalmanTuning(q_vy=0.01, q_r=1e-3, q_b=1e-3, R_r=9e-6, R_ay=0.01)
    f = K.ekf(log, p, tun, store=True)
    s = K.rts(log, p, tun)
    Fs = f.info["Fs"].copy()
    Fs[0] = Fs[1]  # filterpy indexes F[k] as k -> k+1 and never uses F[N-1]
    Fp = np.concatenate([Fs[1:], Fs[-1:]])
    Qs = np.array([np.diag([0.01, 1e-3, 1e-3]) * 0.01] * N)
    xs, Ps, _, _ = KalmanFilter(dim_x=3, dim_z=2).rts_smoother(f.X, f.P, Fs=Fp, Qs=Qs)
    assert np.abs(s.X - xs).max() < 1e-10
    assert np.abs(s.P - Ps).max() < 1e-12
    # and the smoother beats the filter on the true-model data
    assert rmse(s.vy, X[:, 0]) < rmse(f.vy, X[:, 0])


def test_ukf_covariance_stays_spd_and_tracks(revs):
    seg = revs.segment(400.0, 415.0)
    u = K.ukf_filterpy(seg, R.params, TUN)
    Ps = u.P
    assert np.abs(Ps - np.transpose(Ps, (0, 2, 1))).max() == 0.0
    assert np.linalg.eigvalsh(Ps).min() > 0
    e = K.ekf(seg, R.params, TUN)
    # same model and noise: UKF and EKF estimates agree to a few cm/s on this segment
    assert rmse(u.vy, e.vy) < 0.05
    assert rmse(u.vy, seg.vy) < 0.4


def test_nearest_spd_repairs_indefinite_matrix():
    P = np.array([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1e-3]])  # eigenvalue -1
    Q, fixed = K.nearest_spd(P)
    assert fixed
    np.linalg.cholesky(Q)
    assert np.allclose(Q, Q.T)
    Q2, fixed2 = K.nearest_spd(np.eye(3))
    assert not fixed2 and np.array_equal(Q2, np.eye(3))


def test_tuning_ignores_reference_columns(satory):
    seg = satory.segment(10.0, 18.0)
    a = K.tune(seg, Y.params, maxiter=60)
    garbage = replace(seg, vy=np.full(len(seg), 123.0), Ff=None, Fr=None)
    b = K.tune(garbage, Y.params, maxiter=60)
    assert a.theta().tolist() == b.theta().tolist()


@pytest.mark.slow
def test_ml_tuning_recovers_gyro_noise_and_filter_is_accurate(satory):
    """On the emulated run (truth = the same model family plus relaxation), the ML estimate
    of the gyro variance is within 15 % of the simulated 0.002^2 (rad/s)^2, and the tuned
    EKF's vy error is far below the vy signal."""
    tun = K.tune(satory, Y.params, window_s=25.0)
    assert tun.R_r == pytest.approx(NOISE_STD["yaw_rate"] ** 2, rel=0.15)
    res = K.ekf(satory, Y.params, tun)
    m = satory.t > 1.0
    e = rmse(res.vy, satory.vy, m)
    assert e < 0.01 < 0.1 * np.sqrt(np.mean(satory.vy[m] ** 2)) + 0.01
    assert rmse(res.Ff, satory.Ff, m) < 0.02 * np.abs(satory.Ff).max()


@pytest.mark.slow
def test_real_log_target_with_first_120s_tuning(revs):
    """Headline: ML tuning on the measured channels of the first 120 s only, then the causal
    EKF over the whole run beats the issue's 0.24 m/s target (vy = 0 gives 0.743)."""
    tun = K.tune(revs, R.params, window_s=120.0)
    res = K.ekf(revs, R.params, tun)
    e = rmse(res.vy, revs.vy)
    assert e <= 0.24
    assert rmse(np.zeros(len(revs)), revs.vy) == pytest.approx(0.743, abs=0.001)


def test_inv3_matches_numpy_and_handles_singular():
    rng = np.random.default_rng(0)
    for _ in range(20):
        M = rng.standard_normal((3, 3))
        A = M @ M.T + 0.01 * np.eye(3)
        assert np.allclose(K._inv3(A), np.linalg.inv(A), rtol=1e-9, atol=1e-9)
    S = np.diag([1.0, 2.0, 0.0])  # inert bias state with zero variance
    assert np.allclose(K._inv3(S), np.linalg.pinv(S))


# ------------------------------------------------------------------ noise floor ------------
def test_noise_floors_known_answer():
    rng = np.random.default_rng(1)
    t = np.arange(0, 60, 0.01)
    r = 0.2 * np.sin(2 * np.pi * 0.3 * t) + 0.002 * rng.standard_normal(len(t))
    ay = 3.0 * np.sin(2 * np.pi * 0.3 * t) + 0.05 * rng.standard_normal(len(t))
    log = DriveLog(t=t, vx=np.full(len(t), 20.0), delta=0.01 * np.sin(t), yaw_rate=r, ay=ay)
    fl = K.noise_floors(log)
    assert fl["R_r"] == pytest.approx(K.NOISE_FLOOR_SHARE * 0.002**2, rel=0.1)
    assert fl["R_ay"] == pytest.approx(K.NOISE_FLOOR_SHARE * 0.05**2, rel=0.1)


def test_tuning_recovers_sensor_noise_and_respects_the_data_floor(satory):
    """On this 8 s window the ML tuning, with or without the data floor, puts R_r and R_ay
    within a factor 2 of the simulated sensor variances (with scipy's default simplex, 0.005
    decades wide for R_ay, it stopped on the search floor R_r = 1e-10); with the floor the
    result never lies below it."""
    seg = satory.segment(10.0, 18.0)
    fl = K.noise_floors(K.thin(seg, 10))
    for floor in (False, True):
        tun = K.tune(seg, Y.params, maxiter=60, noise_floor=floor)
        for got, sd in ((tun.R_r, NOISE_STD["yaw_rate"]), (tun.R_ay, NOISE_STD["ay"])):
            assert 0.5 * sd**2 <= got <= 2 * sd**2
        if floor:
            assert tun.R_r >= fl["R_r"] * (1 - 1e-12) and tun.R_ay >= fl["R_ay"] * (1 - 1e-12)


def test_tuning_report_flags_bounds_and_identifiability(satory):
    seg = satory.segment(10.0, 18.0)
    tun = K.tune(seg, Y.params, maxiter=60, noise_floor=False)
    floor_rr = 10 ** K.TUNE_BOUNDS[3][0]
    collapsed = replace(tun, R_r=floor_rr)           # a collapsed gyro noise, on the bound
    rep = K.tuning_report(seg, Y.params, collapsed)
    assert rep["names"] == ["q_vy", "q_r", "q_b", "R_r", "R_ay"]
    # R_r sits below the data floor, on the search bound
    assert "R_r" in rep["at_bound"]
    assert rep["floors"]["R_r"] == pytest.approx(K.noise_floors(K.thin(seg, 10))["R_r"])
    assert "R_r" not in K.tuning_report(seg, Y.params, tun)["at_bound"]


# ------------------------------------------------------------------ observer contract ------
def _protocol(seg, use_ay=True):
    inp = K.prepare(seg)
    u = np.column_stack([inp.delta, inp.vx])
    y = np.column_stack([inp.yr, inp.ay])[:, :2 if use_ay else 1]
    return inp.t, u, y


@pytest.mark.parametrize("use_ay", [True, False])
def test_ekf_protocol_readable_step_equals_compiled_run(revs, use_ay):
    """The contract: run_readable (numpy predict with the RK4 map and its stage-Jacobian,
    Joseph-form update) equals the numba kernel on 5 s of the Revs log. Tolerance 1e-10
    absolute on v_y, r, b_ay of order 0.01-1 (observed ~1e-14): the kernel writes the
    products in scalars, the readable step as matrix products, so each step differs by a few
    ulps; the filter's error dynamics are contracting, they do not grow. The design has no
    LMI certificate (a noise tuning)."""
    seg = revs.segment(300.0, 305.0)
    t, u, y = _protocol(seg, use_ay)
    obs = K.LateralEKF(K.KalmanDesign(R.params, TUN, use_ay))
    assert obs.design.certificate is None and isinstance(obs, Observer)
    run = obs.run(t, u, y)
    ref = run_readable(obs, t, u, y)
    assert run.names == ref.names == K.STATE_NAMES
    np.testing.assert_allclose(run.x, ref.x, rtol=0, atol=1e-10)
    # the log front end is this observer on the despiked inputs
    e = K.ekf(seg, R.params, TUN, use_ay=use_ay)
    np.testing.assert_array_equal(e.x, run.x)
    assert isinstance(e, Trajectory) and e.X is e.x and e.us_per_step > 0


def test_ukf_protocol_readable_step_equals_filterpy_run(revs):
    """The numpy UKF step (Merwe points, unscented transform, points redrawn at the prior as
    filterpy does, SPD repair) equals filterpy's UKF to 1e-10 (observed ~2e-14; numpy's
    cholesky of the lower factor against scipy's upper one, and matrix products in another
    order, differ by ulps per step)."""
    seg = revs.segment(400.0, 402.0)
    t, u, y = _protocol(seg)
    obs = K.LateralUKF(K.KalmanDesign(R.params, TUN, True))
    assert isinstance(obs, Observer)
    run = obs.run(t, u, y)
    ref = run_readable(obs, t, u, y)
    np.testing.assert_allclose(run.x, ref.x, rtol=0, atol=1e-10)
    np.testing.assert_array_equal(K.ukf_filterpy(seg, R.params, TUN).x, run.x)


@pytest.mark.parametrize("cls", [K.LateralEKF, K.LateralUKF])
def test_kalman_observers_are_causal(revs, cls):
    """Changing every sample after k leaves the posterior up to k unchanged, bit for bit."""
    seg = revs.segment(300.0, 302.0)
    t, u, y = _protocol(seg)
    obs = cls(K.KalmanDesign(R.params, TUN, True))
    a = obs.run(t, u, y)
    k = 120
    u2, y2 = u.copy(), y.copy()
    u2[k + 1:, 0] += 0.01
    y2[k + 1:] += 0.05
    b = obs.run(t, u2, y2)
    np.testing.assert_array_equal(a.x[:k + 1], b.x[:k + 1])
    assert np.abs(a.x[k + 2:] - b.x[k + 2:]).max() > 1e-4


def test_rts_is_an_offline_trajectory(revs):
    s = K.rts(revs.segment(300.0, 302.0), R.params, TUN)
    assert isinstance(s, Trajectory) and not s.causal and s.name == "RTS"


def test_theta_layout_follows_the_named_indices():
    th = TUN.theta()
    assert (th[K.Q_VY], th[K.Q_R], th[K.Q_B], th[K.R_R], th[K.R_AY]) == (
        TUN.q_vy, TUN.q_r, TUN.q_b, TUN.R_r, TUN.R_ay)
    assert K.KalmanTuning.from_theta(th, P0=TUN.P0) == TUN
    assert list(K.THETA_NAMES) == ["q_vy", "q_r", "q_b", "R_r", "R_ay"]


@pytest.mark.parametrize("col,attr", [("yaw_rate_radps", "yaw_rate"), ("ay_mps2", "ay"),
                                      ("delta_roadwheel_rad", "delta"), ("vx_mps", "vx")])
def test_log_with_nan_rows_is_refused_naming_row_and_column(revs, col, attr):
    """A NaN row used to give NaN estimates from that row on (500 of them on this segment):
    the EKF (and every Kalman function) refuses the log, naming the column and the row."""
    seg = revs.segment(300.0, 305.0)
    bad = replace(seg, **{attr: getattr(seg, attr).copy()})
    getattr(bad, attr)[37] = np.nan
    for fn in (K.ekf, K.rts, K.ekf_filterpy):
        with pytest.raises(ObserverArgumentError, match=rf"column '{col}' has 1 non-finite .*row 37"):
            fn(bad, R.params, TUN)


def test_observer_arguments_are_checked(revs):
    seg = revs.segment(300.0, 300.2)
    t, u, y = _protocol(seg)
    obs = K.LateralEKF(K.KalmanDesign(R.params, TUN, True))
    with pytest.raises(ObserverArgumentError, match=r"y must be \(N, 2\)"):
        obs.run(t, u, y[:, :1])
    with pytest.raises(ObserverArgumentError, match=r"u must be \(N, 2\)"):
        obs.run(t, u[:, :1], y)
    with pytest.raises(ObserverArgumentError, match="x0 must be 3 finite values"):
        obs.run(t, u, y, np.zeros(2))
    with pytest.raises(ObserverArgumentError, match="strictly increasing"):
        obs.run(t[::-1], u, y)
    u2 = u.copy()
    u2[3, 1] = -1.0
    with pytest.raises(ObserverArgumentError, match=r"vx_mps\) must be > 0.*row 3"):
        obs.run(t, u2, y)
    with pytest.raises(ObserverArgumentError, match="design must be a KalmanDesign"):
        K.LateralEKF(TUN)
    with pytest.raises(ObserverArgumentError, match="alpha must be > 0"):
        K.LateralUKF(K.KalmanDesign(R.params, TUN), alpha=0.0)
