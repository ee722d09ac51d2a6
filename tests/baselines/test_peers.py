"""The MBDS peers (Leanza et al. 2021): their KF step checked by hand, the compiled loops equal
to the readable ones, the factor graph equal to GTSAM's, the fixed-lag look-ahead, and the
Revs numbers of their published code's behaviour."""

import numpy as np
import pytest
from vehicle_observers.baselines import peers as PE
from vehicle_observers.core.metrics import rmse
from vehicle_observers.data.logs import load_revs


@pytest.fixture(scope="module")
def revs():
    return load_revs()


def test_kf_step_by_hand():
    """One step of BetaStanfordLinear.m / LinearKF.m written out in scalars from the .m file
    (independent of :func:`peers.kf_matrices`)."""
    m, Jz, lf, lr, Cf, Cr = 982.0, 982.0 / 12 * (1.7**2 + 4.09**2), 1.33, 1.07, 0.7e5, 1.2e5
    dt, up, u, dp, d = 0.01, 30.0, 31.0, 0.02, 0.021
    X = np.array([0.01, 0.1])
    P = np.diag([1e-3, 1e-4])
    Y = np.array([2.0, 0.11])
    s_ay, s_r, s_d = 1.0, 0.005, 2.0
    a11 = 1 - dt * (Cf + Cr) / (m * up)
    a12 = -dt * (1 + (lf * Cf - lr * Cr) / (m * up**2))
    a21 = -dt * (lf * Cf - lr * Cr) / Jz
    a22 = 1 - dt * (lf**2 * Cf + lr**2 * Cr) / (Jz * up)
    b1, b2 = dt * Cf / (m * up), dt * lf * Cf / Jz
    xp = np.array([a11 * X[0] + a12 * X[1] + b1 * dp, a21 * X[0] + a22 * X[1] + b2 * dp])
    A = np.array([[a11, a12], [a21, a22]])
    Pp = A @ P @ A.T + s_d**2 * np.array([[b1 * b1, b1 * b2], [b1 * b2, b2 * b2]])
    c11, c12 = -(Cf + Cr) / m, -(lf * Cf - lr * Cr) / (m * u)
    C = np.array([[c11, c12], [0.0, 1.0]])
    S = C @ Pp @ C.T + np.diag([s_ay**2, s_r**2])
    K = Pp @ C.T @ np.linalg.inv(S)
    innov = Y - np.array([c11 * xp[0] + c12 * xp[1] + Cf / m * d, xp[1]])
    x_hand = xp + K @ innov
    P_hand = (np.eye(2) - K @ C) @ Pp
    Am, Bm, Cm, Dm = PE.kf_matrices(PE.MBDS_CAR, dt, up, u)
    x, Pn = PE.linear_kf_step(Am, Bm, Cm, Dm, dp, d, Y, X, P, np.outer(Bm, Bm) * s_d**2,
                              np.diag([s_ay**2, s_r**2]))
    assert np.allclose(x, x_hand, rtol=1e-12, atol=1e-15)
    assert np.allclose(Pn, P_hand, rtol=1e-9, atol=1e-18)
    # the numbers themselves: the predicted sideslip a11 beta + a12 r + b1 delta
    assert xp[0] == pytest.approx(0.01 * (1 - 0.01 * 1.9e5 / (982 * 30))
                                  - 0.01 * (1 + (0.931e5 - 1.284e5) / (982 * 900)) * 0.1
                                  + 0.01 * 0.7e5 / (982 * 30) * 0.02, rel=1e-12)


def test_compiled_kf_equals_readable(revs):
    s = revs.segment(300.0, 302.0)
    sg = PE.mbds_kf_sigmas(revs)
    obs = PE.MBDSLinearKF(PE.MBDS_CAR, sg["s_ay"], sg["s_r"], sg["s_d"])
    u = np.column_stack([s.vx, s.delta])
    y = np.column_stack([s.ay, s.yaw_rate])
    a = obs.run(s.t, u, y).x
    b = PE.readable_with_speed(obs, s.t, u, y)
    assert np.allclose(a, b, rtol=1e-9, atol=1e-10)
    assert np.all(a[0] == 0.0)                      # their States(:, 1) = 0


def test_highpass_meets_its_spec():
    from scipy.signal import freqz

    b = PE.highpass_fir()
    w, h = freqz(b, worN=8192, fs=2.0)            # frequency in units of Nyquist
    a = 20 * np.log10(np.abs(h))
    assert a[w <= 0.15].max() <= -60.0 + 1e-9
    assert a[w >= 0.25].max() - a[w >= 0.25].min() <= 1.0
    assert len(b) % 2 == 1 and np.allclose(b, b[::-1])      # type I linear phase
    assert PE.remez_order(0.15, 0.25, 60, 1) <= len(b) - 1


def test_factor_graph_equals_gtsam(revs):
    pytest.importorskip("gtsam")
    s = revs.segment(420.0, 421.5)
    args = (s.t, s.vx, s.delta, s.ay, s.yaw_rate)
    assert np.allclose(PE.mbds_fg_gtsam(*args), PE.mbds_fg_batch(*args), rtol=1e-8, atol=1e-12)
    assert np.allclose(PE.mbds_fg_gtsam(*args, window=5), PE.mbds_fg_fixed_lag(*args, window=5),
                       rtol=1e-8, atol=1e-12)


def test_fixed_lag_reads_four_samples_ahead(revs):
    """Window W = 5: the estimate at sample i is that of the window starting at i (factors of
    samples i .. i+4): a change at i+4 moves it, a change at i+5 does not."""
    s = revs.segment(500.0, 500.5)
    ay = s.ay.copy()
    base = PE.mbds_fg_fixed_lag(s.t, s.vx, s.delta, ay, s.yaw_rate)
    i = 10
    for j, moved in ((i + 4, True), (i + 5, False)):
        a2 = ay.copy()
        a2[j] += 5.0
        x = PE.mbds_fg_fixed_lag(s.t, s.vx, s.delta, a2, s.yaw_rate)
        assert (abs(x[i, 0] - base[i, 0]) > 1e-6) == moved
    assert np.all(base[: i] == PE.mbds_fg_fixed_lag(s.t, s.vx, s.delta, ay, s.yaw_rate)[: i])


def test_revs_numbers_of_their_code(revs):
    """The Revs log through their code path: v_y RMSE 0.350 m/s (KF) and 0.242 m/s (batch
    factor graph) over the whole log (the references of notebook 07,
    ``benchmark_study.runs.revs_references``, go through the registry); sideslip RMSE in their metric
    (degrees over every sample), and both beat v_y = 0 (1.69 deg)."""
    bt = np.arctan2(revs.vy, revs.vx)
    kf = PE.mbds_kf(revs)
    fg = PE.mbds_fg(revs)
    assert rmse(kf["vy_mps"], revs.vy) == pytest.approx(0.350, abs=1e-3)
    assert rmse(fg["vy_mps"], revs.vy) == pytest.approx(0.242, abs=1e-3)
    b_kf, b_fg = PE.beta_rmse_deg(kf["beta_rad"], bt), PE.beta_rmse_deg(fg["beta_rad"], bt)
    b0 = PE.beta_rmse_deg(np.zeros_like(bt), bt)
    assert b_fg < b_kf < b0 and b0 == pytest.approx(1.692, abs=1e-3)
    assert not fg.causal and kf.causal


def test_bad_arguments_are_named():
    from vehicle_observers.core.errors import ObserverArgumentError

    with pytest.raises(ObserverArgumentError, match="s_r"):
        PE.MBDSLinearKF(PE.MBDS_CAR, 1.0, 0.0, 1.0)
    with pytest.raises(ObserverArgumentError, match="window"):
        PE.mbds_fg_fixed_lag(np.arange(10.0), np.ones(10), np.zeros(10), np.zeros(10),
                             np.zeros(10), window=0)
