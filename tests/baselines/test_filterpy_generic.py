"""Generic filterpy EKF/UKF baseline: on a linear model both must equal an independent
hand-written Kalman filter whose transition matrix is the RK4 polynomial of A h."""

import numpy as np
import pytest
from vehicle_observers.baselines.filterpy_generic import numerical_jacobian, rk4_step, run_ekf, run_ukf
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import Trajectory

A = np.array([[-1.0, 2.0], [-3.0, -0.5]])
B = np.array([[0.0], [1.0]])
C = np.array([[1.0, 0.0]])
DT = 0.01


def _f(x, u):
    return A @ x + B @ u


def _h(x, u):
    return C @ x


def _data(n=400, seed=3):
    rng = np.random.default_rng(seed)
    u = np.sin(np.arange(n) * DT * 5.0)[:, None]
    x = np.array([0.3, -0.2])
    z = np.empty((n, 1))
    for k in range(n):
        z[k] = C @ x + 0.01 * rng.standard_normal()
        x = rk4_step(_f, x, u[k], DT) + 1e-3 * rng.standard_normal(2)
    return z, u


def _reference_kf(z, u, x0, P0, Q, R):
    """Plain linear KF, update-then-predict, Phi = sum_{j<=4} (A h)^j / j!."""
    Ah = A * DT
    Phi = np.eye(2) + Ah + Ah @ Ah / 2 + Ah @ Ah @ Ah / 6 + Ah @ Ah @ Ah @ Ah / 24
    x, P, out = x0.copy(), P0.copy(), []
    for k in range(len(z)):
        if np.all(np.isfinite(z[k])):
            S = C @ P @ C.T + R
            K = P @ C.T @ np.linalg.inv(S)
            x = x + K @ (z[k] - C @ x)
            P = (np.eye(2) - K @ C) @ P
        out.append(x.copy())
        x = rk4_step(_f, x, u[k], DT)
        P = Phi @ P @ Phi.T + Q * DT
    return np.array(out)


@pytest.mark.parametrize("runner", [run_ekf, run_ukf])
def test_linear_model_equals_reference_kf(runner):
    z, u = _data()
    z[50:60] = np.nan  # dropped samples: no update
    x0, P0, Q, R = np.zeros(2), np.eye(2), 1e-4 * np.eye(2), np.array([[1e-4]])
    ref = _reference_kf(z, u, x0, P0, Q, R)
    run = runner(_f, _h, z, u, DT, x0, P0, Q, R)
    # EKF: central differences of a linear map are exact to round-off; UKF: the unscented
    # transform is exact for linear maps, the SPD repair never triggers here
    assert np.max(np.abs(run.x - ref)) < 1e-9
    assert run.us_per_step > 0
    # one result type: a Trajectory at t = k dt with named states and the covariance diagonal
    assert isinstance(run, Trajectory) and run.names == ("x0", "x1")
    np.testing.assert_allclose(run.t, np.arange(len(z)) * DT)
    assert run.P_diag.shape == run.x.shape and run.name == run.estimator
    named = runner(_f, _h, z, u, DT, x0, P0, Q, R, names=("p_m", "v_mps"))
    np.testing.assert_array_equal(named["v_mps"], run.x[:, 1])
    if runner is run_ukf:
        assert run.info["spd_repairs"] == 0


def test_numerical_jacobian_known_answer():
    fun = lambda x: np.array([x[0] ** 2 * x[1], np.sin(x[1])])
    J = numerical_jacobian(fun, np.array([1.5, 0.7]))
    want = np.array([[2 * 1.5 * 0.7, 1.5**2], [0.0, np.cos(0.7)]])
    assert np.max(np.abs(J - want)) < 1e-8


def test_shape_errors_are_clear():
    z, u = _data(10)
    for dt in (0.0, -DT, float("nan")):
        with pytest.raises(ObserverArgumentError, match="dt .sample period. must be finite"):
            run_ekf(_f, _h, z, u, dt, np.zeros(2), np.eye(2), np.eye(2), np.eye(1))
    with pytest.raises(ObserverArgumentError, match="x0 must be finite"):
        run_ukf(_f, _h, z, u, DT, [0.0, np.nan], np.eye(2), np.eye(2), np.eye(1))
    with pytest.raises(ObserverArgumentError, match="names must give the 2 states"):
        run_ekf(_f, _h, z, u, DT, np.zeros(2), np.eye(2), np.eye(2), np.eye(1), names=("a",))
    with pytest.raises(ValueError, match="Q must be"):
        run_ekf(_f, _h, z, u, DT, np.zeros(2), np.eye(2), np.eye(3), np.eye(1))
    with pytest.raises(ValueError, match="u has 9 rows"):
        run_ekf(_f, _h, z, u[:9], DT, np.zeros(2), np.eye(2), np.eye(2), np.eye(1))
    with pytest.raises(ValueError, match="R must be positive semi-definite"):
        run_ekf(_f, _h, z, u, DT, np.zeros(2), np.eye(2), np.eye(2), -1e-12 * np.eye(1))
    with pytest.raises(ValueError, match="Q must be symmetric"):
        run_ekf(_f, _h, z, u, DT, np.zeros(2), np.eye(2), 1e-10 * np.array([[1, 1], [0, 1]]),
                np.eye(1))


def test_one_channel_and_roundoff_tolerances():
    """A 1-D z is one channel (not one sample); round-off below 1e-12 of the scale is accepted."""
    z, u = _data(50)
    Q = np.diag([1e-4, -1e-18])  # PSD up to round-off
    a = run_ekf(_f, _h, z[:, 0], u, DT, np.zeros(2), np.eye(2), Q, np.array([[1e-4]]))
    b = run_ekf(_f, _h, z, u, DT, np.zeros(2), np.eye(2), Q, np.array([[1e-4]]))
    assert a.x.shape == (50, 2) and np.array_equal(a.x, b.x)
