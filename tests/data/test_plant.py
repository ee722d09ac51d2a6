"""Independent truth plant (CommonRoad multi-body model): schema, seeded noise, and physics
checked against the linear bicycle with the library's own data-sheet constants."""

from __future__ import annotations

import numpy as np
import pytest
from vehicle_observers.data import plant
from vehicle_observers.data.logs import REQUIRED, load_log

P = plant.nominal_params()


@pytest.fixture(scope="module")
def sine():
    return plant.plant_log("sine_with_dwell", seed=3)


@pytest.fixture(scope="module")
def ramp():
    return plant.plant_log("ramp_steer", seed=0)


def test_nominal_params_are_the_library_data_sheet():
    p = plant.plant_parameters(2)
    Fzf, Fzr = plant.static_axle_loads(p)
    assert Fzf + Fzr == pytest.approx(p.m * 9.81, rel=1e-6)   # m_s + m_uf + m_ur = m
    assert P.m == p.m and P.a_f == p.a and P.a_r == p.b and P.I_z == p.I_z
    assert P.tire_f.cornering_stiffness == pytest.approx(21.92 * Fzf, rel=1e-12)
    assert P.tire_r.D == pytest.approx(1.0489 * Fzr, rel=1e-12)


def test_log_in_schema_round_trip(sine, tmp_path):
    assert sine.dt == pytest.approx(0.01)
    for c in REQUIRED + ("ay_mps2", "vy_mps", "Ff_N", "Fr_N"):
        assert sine.has(c), c
    path = tmp_path / "plant.csv"
    sine.to_csv(path)
    back = load_log(path)
    np.testing.assert_allclose(back.vy, sine.vy, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(back.extra["yaw_rate_true_radps"],
                               sine.extra["yaw_rate_true_radps"], rtol=1e-8, atol=1e-12)


def test_seeded_noise_with_stated_std(sine):
    again = plant.simulate(plant.sine_with_dwell_manoeuvre(), seed=3)
    np.testing.assert_array_equal(again.yaw_rate, sine.yaw_rate)
    other = plant.simulate(plant.sine_with_dwell_manoeuvre(), seed=4)
    np.testing.assert_array_equal(other.vy, sine.vy)            # same truth
    assert not np.array_equal(other.yaw_rate, sine.yaw_rate)    # other noise
    n = len(sine)
    for ch, attr, truth in (("yaw_rate", "yaw_rate", "yaw_rate_true_radps"),
                            ("ay", "ay", "ay_sensor_true_mps2"), ("vx", "vx", "vx_true_mps")):
        e = getattr(sine, attr) - sine.extra[truth]
        # sample std of n Gaussian draws: relative error ~ 1/sqrt(2n) = 2.6 %; 4 sigma band
        assert np.std(e) == pytest.approx(plant.NOISE_STD[ch], rel=4 / np.sqrt(2 * n))


def test_reaches_nonlinear_range_and_follows_driver(sine):
    assert np.abs(sine.ay).max() > 0.6 * 9.81
    assert np.abs(sine.extra["vx_true_mps"] - 20.0).max() < 0.5     # speed controller
    # the steering servo follows the reference within the library's 0.4 rad/s rate limit
    lag = np.abs(sine.extra["delta_true_rad"] - sine.extra["delta_ref_rad"]).max()
    assert lag < 0.4 * 0.05 + 0.005


def test_quasi_steady_yaw_gain_matches_bicycle_with_data_sheet(ramp):
    """Independent physics check: at 20 m/s and <= 0.2 g the multi-body yaw-rate gain is
    the linear bicycle's v / (L + K_us v^2) with the data-sheet stiffness, within 5 %
    (camber, roll steer and compliance make the rest)."""
    L = P.a_f + P.a_r
    Kus = P.m / L * (P.a_r / P.tire_f.cornering_stiffness - P.a_f / P.tire_r.cornering_stiffness)
    v = 20.0
    late = ramp.t > 10
    gain = ramp.extra["yaw_rate_true_radps"][late] / ramp.extra["delta_true_rad"][late]
    assert np.median(gain) == pytest.approx(v / (L + Kus * v**2), rel=0.05)


def test_body_accelerometer_reads_more_than_the_level_acceleration_in_turns(sine):
    """The body rolls outward in turns, so a sprung-mass accelerometer reads the level
    acceleration plus about g |phi|. The sign of the library's roll angle is checked here,
    not assumed: the sensor's magnitude is larger on at least 95 % of the samples with
    |a_y| > 1 m/s^2 (the rest are where a_y changes sign and the roll lags it), and its
    least-squares gain on a_y is 1 + g k_phi for a roll gradient of 6-12 deg per g; a
    "level" sensor reads a_y itself."""
    ay, sens = sine.extra["ay_true_mps2"], sine.extra["ay_sensor_true_mps2"]
    turn = np.abs(ay) > 1.0
    assert turn.sum() > 100
    assert np.mean(np.abs(sens[turn]) > np.abs(ay[turn])) >= 0.95
    gain = float(ay @ sens / (ay @ ay))
    assert 1 + np.radians(6) < gain < 1 + np.radians(12)
    level = plant.simulate(plant.sine_with_dwell_manoeuvre(), seed=3, accelerometer="level")
    np.testing.assert_allclose(level.ay - sine.ay, ay - sens, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="accelerometer must be one of"):
        plant.simulate(plant.sine_with_dwell_manoeuvre(), accelerometer="tilted")


def test_bad_manoeuvre_rejected():
    with pytest.raises(ValueError, match="unknown manoeuvre"):
        plant.plant_log("donut")
    m = plant.slalom_manoeuvre(duration=1.0)
    slow = plant.Manoeuvre("slow", m.t, m.delta_ref, np.full_like(m.t, 0.5))
    with pytest.raises(ValueError, match="v_x > 1 m/s"):
        plant.simulate(slow)


def test_a_diverging_plant_is_one_error_without_package_warnings():
    """Car 3 on the Satory lap leaves the multi-body model's valid range (a wheel speed
    reaches 0 in the package's slip ratio, t = 53.22 s): one FloatingPointError naming the
    time, and none of the package's scalar RuntimeWarnings on the way (which would otherwise
    reach a notebook's stderr before the error). Catches a divergence that leaks NaN into a
    log or floods stderr."""
    import warnings

    from vehicle_observers.data import plant

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(FloatingPointError, match=r"diverged at t = 53\.22 s \(satory\)"):
            plant.plant_log("satory", seed=0, quick=False, vehicle_id=3)
