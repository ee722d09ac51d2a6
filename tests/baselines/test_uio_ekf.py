"""EKF / UKF baseline of the relaxed UIO (Notebook 06): augmented nominal model, noise rule,
convergence on a model without error, UKF = EKF on the linear time-varying model, bad input."""

import dataclasses

import numpy as np
import pytest
from vehicle_observers.baselines import uio_ekf as ub
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import Observer, run_readable
from vehicle_observers_papers.elyoussfi_2020 import constants as P
from vehicle_observers_papers.elyoussfi_2020 import scenario as sn

T_FAULT, T_END = 1.5, 4.0


@pytest.fixture(scope="module")
def model():
    """The C = I comparison variant (v_y and r measured, 1/m error): the filter machinery is
    checked on it; the main model (v_y unmeasured) in ``test_noise_rule_main_model``."""
    return P.build_model(variant="full")


@pytest.fixture(scope="module")
def nominal_case(model):
    """Truth = the filter's own model (rho = 0: no uncertainty), noise 10x smaller than the
    design's, constant fault 0.01 rad from 1.5 s."""
    nom = dataclasses.replace(model, rho=0.0, D_w=0.1 * model.D_w)
    sc = sn.make_scenario(nom, T_END, P.dt, T_FAULT, P.x0_true, seed=3, fault_kw={"amp": 0.0})
    return nom, sc


def test_nominal_augmented_matrices(model):
    Ab, Bb, Cb = ub.nominal_augmented(model)
    assert Ab.shape == (2, 3, 3) and Bb.shape == (2, 3, 1) and Cb.shape == (2, 3)
    for i in range(2):
        np.testing.assert_array_equal(Ab[i, :2, :2], model.A[i])
        np.testing.assert_array_equal(Ab[i, :2, 2:], model.B[i])   # fault adds to delta
        np.testing.assert_array_equal(Ab[i, 2], 0.0)                # random-walk fault
    np.testing.assert_array_equal(Cb, [[1, 0, 0], [0, 1, 1]])       # y = x + F_s f


def test_noise_rule(model):
    Q, R, info = ub.noise_rule(model, P.dt)
    np.testing.assert_allclose(R, np.diag([P.sigma_vy**2, P.sigma_r**2]))
    assert Q[2, 2] == pytest.approx(P.scale_fdot**2 * P.dt)
    # 1/m error: rho * |force part of row 1 of A_i| . (0.5 m/s, 0.2 rad/s), largest rule
    Na, _ = model.uncertainty_matrices()
    d = max(abs(n[0, 0]) * 0.5 + abs(n[0, 1]) * 0.2 for n in Na)
    assert info["d_max"] == pytest.approx(d)
    assert Q[0, 0] == pytest.approx(d**2 * P.dt) and Q[1, 1] == 0.0   # M = [1, 0]^T
    assert info["tau"] is None
    with pytest.raises(ValueError, match="dt"):
        ub.noise_rule(model, 0.0)
    with pytest.raises(ValueError, match="tau"):
        ub.noise_rule(model, P.dt, tau=0.0)


def test_noise_rule_main_model():
    """Main model: C = I, rear cornering-force error d = rho F C_ri alpha_r [N] along
    M = [1/m, -l_r/I_z]^T: d_max = rho max_i C_ri (0.5 / v_x + l_r 0.2 / v_x) and the process
    noise is M M^T d_max^2 dt (both equations, correlated with the sign of -l_r). Catches an
    EKF noise rule built on the wrong uncertainty direction."""
    mm = P.build_model()
    Q, R, info = ub.noise_rule(mm, P.dt)
    d = P.rho * max(mm.tyres.C_r) * (0.5 + P.l_r * 0.2) / P.vx
    assert info["d_max"] == pytest.approx(d, rel=1e-12)
    M = np.array([1 / P.m, -P.l_r / P.I_z])
    np.testing.assert_allclose(Q[:2, :2], np.outer(M, M) * d**2 * P.dt, rtol=1e-12)
    assert Q[0, 1] < 0


def test_noise_rule_yaw_model():
    """The "yaw" variant: two yaw-rate sensors, 1/I_z error (M = [0, 1]^T): the process noise
    sits on the yaw equation, with d_max = rho |row 2 of A_i| . (0.5 m/s, 0.2 rad/s)."""
    mm = P.build_model(variant="yaw")
    Q, R, info = ub.noise_rule(mm, P.dt)
    np.testing.assert_allclose(R, np.diag([P.sigma_gyro**2, P.sigma_wheel**2]))
    d = max(P.rho * (abs(A[1, 0]) * 0.5 + abs(A[1, 1]) * 0.2) for A in mm.A)
    assert info["d_max"] == pytest.approx(d)
    assert Q[1, 1] == pytest.approx(d**2 * P.dt) and Q[0, 0] == 0.0
    Ab, _, Cb = ub.nominal_augmented(mm)
    np.testing.assert_array_equal(Cb, [[0, 1, 1], [0, 1, 0]])   # v_y not measured


def test_noise_rule_per_sample_vs_correlation_time(model):
    # per-sample rule: per-sample increment std = s dt, so Q_k = Q dt = (s dt)^2 and the
    # intensity scales with dt; correlation-time rule: Q = s^2 tau whatever dt is
    for dt in (1e-3, 1e-2):
        Q, _, info = ub.noise_rule(model, dt)
        assert np.sqrt(Q[2, 2] * dt) == pytest.approx(P.scale_fdot * dt)
        Qt, _, it = ub.noise_rule(model, dt, tau=0.5)
        assert Qt[2, 2] == pytest.approx(P.scale_fdot**2 * 0.5) and it["tau"] == 0.5
        assert Qt[0, 0] == pytest.approx(info["d_max"] ** 2 * 0.5) and Qt[1, 1] == 0.0
    # a random walk of intensity s^2 tau spreads s tau (the drift at the bound) in tau
    assert np.sqrt(Qt[2, 2] * 0.5) == pytest.approx(P.scale_fdot * 0.5)
    with pytest.raises(ValueError, match="fdot_max"):
        ub.noise_rule(model, P.dt, fdot_max=-1.0)


@pytest.mark.parametrize("premise", ["measured", None, "estimated"])
def test_ekf_converges_on_its_own_model(nominal_case, premise):
    nom, sc = nominal_case
    ev = sn.evaluate_filter(nom, sc, h=premise, kind="ekf")
    run = ev["run"]
    assert run.x.shape == (len(sc["t"]), 3) and run.P_diag.shape == (len(sc["t"]), 3)
    last = sc["t"] >= T_END - 1.0
    err = run.x[last, 2] - sc["f"][last]
    # no model error -> the filter is consistent: its normalised fault error has RMS ~ 1
    # (the error is correlated over the filter time constant ~ 40 ms, i.e. ~ 25 independent
    # samples in 1 s: 0.4 .. 1.6 is a wide chi-square band). The only mismatch is the truth's
    # 2-substep RK4 vs the filter's 1-step RK4 (O(dt^4)).
    z = err / np.sqrt(run.P_diag[last, 2])
    assert 0.4 < np.sqrt(np.mean(z**2)) < 1.6
    # and in absolute terms below 2 % of the 0.01 rad fault (sqrt(P_ff) ~ 9e-5 rad here)
    assert np.sqrt(np.mean(err**2)) < 2e-4
    assert ev["fault_delay"] < 0.2                       # settles within the 10 % band


def test_ukf_equals_ekf_on_linear_time_varying_model(nominal_case):
    nom, sc = nominal_case
    n = 400
    args = (nom, sc["delta"][:n], sc["y"][:n], P.dt, sc["h"][:n])
    ekf = ub.run_filter(*args, kind="ekf")
    ukf = ub.run_filter(*args, kind="ukf")
    # measured premises: the model is linear in X, the UKF's sigma-point moments are exact,
    # and both compute the Kalman filter of the same RK4 map (rounding only)
    np.testing.assert_allclose(ukf.x, ekf.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(ukf.P_diag, ekf.P_diag, rtol=1e-6, atol=1e-15)


def test_bad_input(model, nominal_case):
    _, sc = nominal_case
    d, y, h = sc["delta"], sc["y"], sc["h"]
    with pytest.raises(ValueError, match=r"y must be \(\d+, 2\)"):
        ub.run_filter(model, d, y[:, :1], P.dt, h)
    with pytest.raises(ValueError, match=r"y must be"):
        ub.run_filter(model, d, y[:-1], P.dt, h)
    with pytest.raises(ValueError, match=r"h must be \(\d+, 2\) memberships"):
        ub.run_filter(model, d, y, P.dt, h[:, :1])
    with pytest.raises(ValueError, match="sum to 1"):
        ub.run_filter(model, d, y, P.dt, 2 * h)
    with pytest.raises(ValueError, match=r"delta must be \(N,\)"):
        ub.run_filter(model, d[:, None], y, P.dt, h)
    with pytest.raises(ValueError, match="'estimated'"):
        ub.run_filter(model, d, y, P.dt, "guessed")
    with pytest.raises(ValueError, match="kind"):
        ub.run_filter(model, d, y, P.dt, h, kind="pf")
    with pytest.raises(ValueError, match=r"P0 must be \(3, 3\)"):
        ub.run_filter(model, d, y, P.dt, h, P0=np.eye(2))
    with pytest.raises(ValueError, match=r"Xh must be"):
        sn.estimate_metrics(np.zeros((len(d), 2)), sc)


def test_estimate_metrics_known_answer_and_empty_windows(nominal_case):
    _, sc = nominal_case
    ref = np.column_stack([sc["X"], sc["f"]])
    off = np.array([0.01, -0.002, 3e-4])
    m = sn.estimate_metrics(ref + off, sc)               # constant error -> RMSE = |offset|
    for k, nm in enumerate(("vy", "r", "f")):
        assert m[f"rmse_{nm}"] == pytest.approx(abs(off[k]), rel=1e-12)
        assert m[f"rmse_{nm}_before"] == pytest.approx(abs(off[k]), rel=1e-12)
    # fault at 1 s: the 'before' window [1 s, t_fault) is empty -> clear error, not NaN
    with pytest.raises(ValueError, match="t_fault must exceed 1 s"):
        sn.estimate_metrics(ref, {**sc, "t_fault": 1.0})
    with pytest.raises(ValueError, match="metric windows"):   # fault after the run
        sn.estimate_metrics(ref, {**sc, "t_fault": T_END + 1.0})


@pytest.mark.parametrize("premise", ["measured", "estimated", "nonlinear"])
def test_fault_ekf_run_readable_equals_run_and_is_causal(nominal_case, premise):
    """The fault EKF under the observer contract: the numpy predict/update step looped equals
    the filterpy loop (same Joseph-form formulas; the Jacobian is the exact RK4 map, or the
    same central differences of it: rounding only, 1e-9 relative over 300 steps, while a
    wrong predict/update order moves the fault estimate by O(dt)), and the estimate at k
    does not see the samples after k."""
    nom, sc = nominal_case
    n = 300
    t, y = sc["t"][:n], sc["y"][:n]
    u = (np.column_stack([sc["delta"], sc["h"]]) if premise == "measured" else sc["delta"][:, None])[:n]
    Q, R, _ = ub.noise_rule(nom, P.dt)
    ekf = ub.FaultEKF(nom, P.dt, Q, R, np.diag(nom.scale_x**2), premise)
    assert isinstance(ekf, Observer)
    x0 = np.array([0.1, 0.0, 0.0])
    tr, rd = ekf.run(t, u, y, x0), run_readable(ekf, t, u, y, x0)
    np.testing.assert_allclose(rd.x, tr.x, rtol=1e-9, atol=1e-12)
    if premise != "nonlinear":   # run_filter with the same premise is this run
        h = sc["h"][:n] if premise == "measured" else "estimated"
        np.testing.assert_array_equal(ub.run_filter(nom, sc["delta"][:n], y, P.dt, h, X0=x0).x,
                                      tr.x)
    k = 150
    y2 = y.copy()
    y2[k + 1:] += 0.05
    np.testing.assert_array_equal(ekf.run(t, u, y2, x0).x[:k + 1], tr.x[:k + 1])
    with pytest.raises(ObserverArgumentError, match="premise"):
        ub.FaultEKF(nom, P.dt, Q, R, np.eye(3), "true")
