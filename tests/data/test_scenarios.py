"""Scenario generator (emulated Satory run of Yacine 2015, sine with dwell): geometry, speed
range, truth consistent with the paper's equations, sensors, seeding, errors."""

import numpy as np
import pytest
from vehicle_observers.data import scenarios
from vehicle_observers.models import lateral
from vehicle_observers_papers.yacine_2015 import constants as Y

P = Y.params


@pytest.fixture(scope="module")
def lap():
    return scenarios.emulated_satory(seed=0, noise_scale=0.0)


@pytest.fixture(scope="module")
def quick_noisy():
    return scenarios.emulated_satory(seed=3, quick=True)


def test_track_is_closed_3500m_and_turns_once():
    tr = scenarios.satory_track()
    assert tr.length == pytest.approx(3500.0, abs=1e-9)
    assert tr.heading_change() == pytest.approx(2 * np.pi, abs=1e-12)
    s, x, y, th = scenarios.track_xy(tr, ds=0.05)
    # midpoint-heading integration of a piecewise-linear curvature: error O(ds^2 rho') ~ 1e-8
    assert abs(x[-1]) < 1e-6 and abs(y[-1]) < 1e-6
    # not a degenerate loop: spans hundreds of metres both ways
    assert np.ptp(x) > 300 and np.ptp(y) > 300
    kinds = np.unique(np.round(np.abs(tr.rho_knots), 6))
    assert {0.0, round(1 / 80, 6), round(1 / 120, 6), round(1 / 100, 6), round(1 / 50, 6)} <= set(
        kinds)


def test_speed_profile_limits():
    tr = scenarios.satory_track()
    s, v = scenarios.speed_profile(tr)
    assert v[0] == pytest.approx(0.2) and v[-1] == pytest.approx(0.2)
    assert v.max() == pytest.approx(17.0)
    # lateral acceleration of the profile stays under the limit (5 m window makes it stricter)
    assert np.max(v**2 * np.abs(tr.rho(s))) <= scenarios.AY_MAX * (1 + 1e-9)
    # longitudinal acceleration limits: d(v^2)/ds = 2 a_x
    dv2 = np.diff(v**2) / np.diff(s)
    assert dv2.max() <= 2 * scenarios.AX_ACCEL * (1 + 1e-6)
    assert dv2.min() >= -2 * scenarios.AX_BRAKE * (1 + 1e-6)


def test_lap_covers_paper_speed_range_and_nonlinear_region(lap):
    assert 200 < lap.duration < 260
    assert lap.dt == pytest.approx(1e-3)
    assert lap.vx.min() <= 0.21 and lap.vx.max() >= 16.99
    # an intermediate-speed section (slow zone at 8 m/s) is driven for > 10 s
    vt = lap.extra["vx_true_mps"]
    assert np.sum((vt > 7.5) & (vt < 8.5)) * lap.dt > 10
    af, ar = lap.extra["alpha_f_true_rad"], lap.extra["alpha_r_true_rad"]
    # nonlinear region reached (front secant stiffness down >= 15 %), sector |alpha|<=8 deg kept
    assert Y.tire_f.secant_stiffness(af).min() < 0.85 * Y.M_f1
    assert Y.tire_r.secant_stiffness(ar).min() < 0.9 * Y.M_r1
    assert np.degrees(np.abs(af).max()) < 8.0 and np.degrees(np.abs(ar).max()) < 8.0
    # lane keeping works: stays well inside a 3.5 m lane
    assert np.abs(lap.extra["yL_true_m"]).max() < 0.5


def test_truth_satisfies_vision_model_9_and_26(lap):
    """Central differences of the noise-free truth against S2 (9) and the premise formula (26).

    Inputs are held over each 1 ms sample, so the central difference at sample k mixes the
    intervals k-1 and k: the residual is O(dt * d/dt(rhs)), bounded here by ~1e-3 of the
    signal scale.
    """
    t, vx, rho = lap.t, lap.extra["vx_true_mps"], lap.rho
    r, psiL, yL = lap.extra["yaw_rate_true_radps"], lap.extra["psiL_true_rad"], lap.extra[
        "yL_true_m"]
    k = slice(1, -1)
    dpsi = (psiL[2:] - psiL[:-2]) / (t[2:] - t[:-2])
    dy = (yL[2:] - yL[:-2]) / (t[2:] - t[:-2])
    res_psi = dpsi - (r[k] - vx[k] * rho[k])
    assert np.abs(res_psi).max() < 1e-3 * np.abs(r).max() + 2e-4
    vy26 = dy - vx[k] * psiL[k] - P.l_s * dpsi
    assert np.abs(vy26 - lap.vy[k]).max() < 3e-3      # |vy| up to 0.75 m/s
    # curvature formula (11) with exact derivatives recovers rho (where v_x is not tiny)
    fast = vx[k] > 2.0
    rho11 = (r[k] - dpsi) / vx[k]
    assert np.abs(rho11 - rho[k])[fast].max() < 1e-4


def test_truth_matches_lateral_simulate_s1_on_open_loop_manoeuvre():
    """Independent check of the truth kernel: the lead's ``lateral.simulate_s1`` (exact slip
    (3), Pacejka (7), relaxation (6), RK4) on the same held inputs gives the same states."""
    sw = scenarios.sine_with_dwell(seed=0, noise_scale=0.0)
    X = lateral.simulate_s1(np.zeros(4), sw.extra["delta_true_rad"], sw.extra["vx_true_mps"],
                            1e-3, P, exact=True, relaxation=True, substeps=2)
    np.testing.assert_allclose(X[:, 0], sw.vy, atol=1e-9)
    np.testing.assert_allclose(X[:, 1], sw.extra["yaw_rate_true_radps"], atol=1e-9)
    np.testing.assert_allclose(X[:, 2], sw.Ff, atol=1e-6)
    np.testing.assert_allclose(X[:, 3], sw.Fr, atol=1e-6)


def test_sine_with_dwell_reaches_nonlinear_region():
    sw = scenarios.sine_with_dwell(seed=0, noise_scale=0.0)
    af = sw.extra["alpha_f_true_rad"]
    assert np.degrees(np.abs(af).max()) > 6.5
    assert Y.tire_f.secant_stiffness(af).min() < 0.85 * Y.M_f1
    assert np.all(sw.rho == 0) and np.all(sw.vx == 17.0)
    # steering shape: +A peak, then held at -A for the dwell
    d = sw.delta
    A = d.max()
    assert d.min() == pytest.approx(-A)
    assert np.sum(np.isclose(d, -A)) == pytest.approx(500, abs=2)


def test_noise_levels_and_seeding(quick_noisy):
    q = quick_noisy
    assert 39.0 < q.duration < 41.0 and np.abs(q.rho).max() > 0.01   # contains a curve
    n = len(q)
    for col, true in [("yaw_rate", "yaw_rate_true_radps"), ("delta", "delta_true_rad"),
                      ("yL", "yL_true_m"), ("psiL", "psiL_true_rad"), ("ay", "ay_true_mps2")]:
        e = getattr(q, col) - q.extra[true]
        sd = scenarios.NOISE_STD[col]
        # sample std of n Gaussian draws: relative standard error 1/sqrt(2n) = 0.35 %
        assert np.std(e) == pytest.approx(sd, rel=5 / np.sqrt(2 * n)), col
        assert abs(np.mean(e)) < 5 * sd / np.sqrt(n), col
    again = scenarios.emulated_satory(seed=3, quick=True)
    np.testing.assert_array_equal(again.yaw_rate, q.yaw_rate)
    np.testing.assert_array_equal(again.vy, q.vy)
    other = scenarios.emulated_satory(seed=4, quick=True)
    assert not np.array_equal(other.yaw_rate, q.yaw_rate)
    half = scenarios.emulated_satory(seed=3, quick=True, noise_scale=0.5)
    assert np.std(half.yL - half.extra["yL_true_m"]) == pytest.approx(
        0.5 * scenarios.NOISE_STD["yL"], rel=0.02)


def test_noise_free_is_truth(lap):
    np.testing.assert_array_equal(lap.yaw_rate, lap.extra["yaw_rate_true_radps"])
    np.testing.assert_array_equal(lap.yL, lap.extra["yL_true_m"])
    np.testing.assert_array_equal(lap.vx, lap.extra["vx_true_mps"])


def test_vision_frame_rate_hold():
    q = scenarios.emulated_satory(seed=0, quick=True, vision_rate_hz=25.0)
    changes = np.count_nonzero(np.diff(q.yL))
    assert changes == pytest.approx(q.duration * 25, abs=2)
    # values at frame instants are the 1 kHz measurement of that instant
    assert np.abs(q.yL - q.extra["yL_true_m"]).max() < 0.05 + 6 * scenarios.NOISE_STD["yL"]


def test_bad_inputs_raise_clear_errors():
    with pytest.raises(ValueError, match="noise_scale"):
        scenarios.emulated_satory(quick=True, noise_scale=-1)
    with pytest.raises(ValueError, match="vision_rate_hz"):
        scenarios.emulated_satory(quick=True, vision_rate_hz=0)
    with pytest.raises(ValueError, match="vx"):
        scenarios.sine_with_dwell(vx=0.0)
