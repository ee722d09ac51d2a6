"""Model terms of the EKF family on logs with and without them, the truth integrated here
(scipy, independent of the filters' RK4 kernels): road bank from a bank or roll column
(:mod:`vehicle_observers.models.road`) and the speed-dependent cornering stiffness
(:func:`vehicle_observers.baselines.kalman.fit_stiffness_speed`)."""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from vehicle_observers import estimation as EST
from vehicle_observers.core.errors import LogFormatError
from vehicle_observers.core.metrics import rmse
from vehicle_observers.data.logs import DriveLog, check_plausible
from vehicle_observers.models import road
from vehicle_observers.models.vehicle import load_vehicle

VEH = load_vehicle("yacine2015")


@lru_cache(maxsize=None)
def banked_log(bank_deg: float, T: float = 40.0, seed: int = 0, ks: float = 0.0,
               ramp: bool = False) -> DriveLog:
    """The single-track model with the vehicle file's tyres on a road banked by ``bank_deg *
    (0.6 + 0.4 sin(2 pi t / 11 s))`` (right side down), integrated by ``solve_ivp`` (rtol
    1e-8); the accelerometer reads the tyre forces only (specific force); r and a_y with
    white noise 0.002 rad/s and 0.05 m/s^2 (seeded); bank in a ``bank_deg`` column. The
    tyres' stiffness is scaled by ``1 + ks v_x`` (slip scaled, peaks kept); ``ramp``: speed
    from 10 to 35 m/s (else 20 +- 2 m/s)."""
    p = VEH.params
    t = np.arange(0.0, T, 0.01)
    vx = 10.0 + 25.0 * t / T if ramp else 20.0 + 2.0 * np.sin(2 * np.pi * t / 30)
    delta = 0.02 * np.sin(2 * np.pi * t / 7) + 0.01 * np.sin(2 * np.pi * t / 2.3)
    phi = np.radians(bank_deg) * (0.6 + 0.4 * np.sin(2 * np.pi * t / 11))

    def forces(vy, r, v, d):
        s = 1.0 + ks * v
        return (p.tire_f.force(s * (d - (vy + p.a_f * r) / v)),
                p.tire_r.force(s * -(vy - p.a_r * r) / v))

    def rhs(tt, x):
        v, d, ph = (np.interp(tt, t, a) for a in (vx, delta, phi))
        Ff, Fr = forces(x[0], x[1], v, d)
        return [(Ff + Fr) / p.m - v * x[1] - 9.81 * np.sin(ph), (p.a_f * Ff - p.a_r * Fr) / p.I_z]

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], t_eval=t, max_step=0.01, rtol=1e-8,
                    atol=1e-10)
    vy, r = sol.y
    F = sum(forces(vy, r, vx, delta))
    rng = np.random.default_rng(seed)
    return DriveLog(t=t, vx=vx, delta=delta, yaw_rate=r + 0.002 * rng.standard_normal(len(t)),
                    ay=F / p.m + 0.05 * rng.standard_normal(len(t)), vy=vy,
                    extra={"bank_deg": np.degrees(phi)}, source=f"banked {bank_deg:g} deg")


def _score(name, log):
    est = EST.available()[name].run(log, VEH)
    return rmse(est.columns["vy_mps"], log.vy, log.t > 5.0)


def test_bank_angle_units_sign_and_preference():
    """Catches a degree column read as radians, a sign flip of the gravity term (a road with
    its right side down pulls the car to its right, -y) and a roll column preferred over the
    road's own bank column."""
    n = 3
    base = dict(t=np.arange(n) * 0.01, vx=np.full(n, 10.0), delta=np.zeros(n),
                yaw_rate=np.zeros(n))
    log = DriveLog(**base, extra={"roll_deg": np.full(n, 30.0), "bank_rad": np.full(n, 0.1)})
    assert road.bank_column(log) == "bank_rad"
    np.testing.assert_allclose(road.lateral_gravity(log), -9.81 * np.sin(0.1))
    log = DriveLog(**base, extra={"roll_deg": np.full(n, 30.0)})
    np.testing.assert_allclose(road.bank_angle(log), np.pi / 6)
    np.testing.assert_allclose(road.lateral_gravity(log), -9.81 * 0.5)
    assert road.lateral_gravity(DriveLog(**base)) is None


@pytest.mark.parametrize("use_ay", [True, False])
def test_bank_term_removes_the_bias_of_a_banked_road(use_ay):
    """Catches a bank column that does not reach the EKF's lateral balance (or enters it
    with the wrong sign or unit, or is dropped by the ML tuning's thinning): on a road banked
    by 6-14 deg the EKF with the column must do as well as on the same manoeuvre on a flat
    road (1.5x its RMSE: same model, only the noise draws of the tuning differ), and without
    the column it is at least 5x worse (a bias that only the column explains)."""
    bank, flat = banked_log(10.0), banked_log(0.0)
    if not use_ay:
        bank, flat = replace(bank, ay=None), replace(flat, ay=None)
    with_col, without = _score("ekf", bank), _score("ekf", replace(bank, extra={}))
    on_flat = _score("ekf", flat)
    assert with_col <= 1.5 * on_flat, (with_col, on_flat)
    assert without >= 5.0 * with_col, (without, with_col)


def test_bank_term_in_the_adaptive_ekf_kernel():
    """Catches the adaptive EKF's kernel ignoring the bank term or adding it with another
    sign than the EKF: with the term (no optional state, fixed noise) the banked road is
    estimated within 1.5x of the flat road, without it at least 5x worse."""
    from vehicle_observers.baselines import adaptive as AD

    tun = AD.AdaptiveTuning(q_vy=1e-4, q_r=1e-4, R_r=0.002**2, R_ay=0.05**2)
    obs = AD.AdaptiveEKF(VEH.params, AD.Terms(), tun, use_ay=True)

    def score(log, gy):
        X = obs.filter(log.t, log.vx, log.delta, log.yaw_rate, log.ay, gy=gy)["X"]
        return rmse(X[:, 0], log.vy, log.t > 5.0)

    bank, flat = banked_log(10.0), banked_log(0.0)
    with_term = score(bank, road.lateral_gravity(bank))
    assert with_term <= 1.5 * score(flat, None)
    assert score(bank, None) >= 5.0 * with_term


def test_a_roll_column_is_bank_plus_body_roll():
    """Catches a roll column taken as bank with the body's own roll left in (no force on the
    car) or the body's tilt of the accelerometer left in a_y: the roll of a sensor on a body
    rolling 0.012 rad per m/s^2 of a_y on the banked road is split back into bank, and the
    EKF then does at least 2x better than without the column (0.0073 against 0.0177 m/s;
    0.0012 with the bank column itself: the fitted gradient's error, 0.2 % of a_y taken as
    bank and as tilt). The roll gradient is found within 20 %: this road's bank changes by up
    to 1.1 deg in the 0.5 s lag and the specific force answers it, which biases the fit (on
    the flat plant logs it is within 5 % of the noise-free fit,
    :mod:`vehicle_observers.models.road`)."""
    bank = banked_log(10.0)
    phi = np.radians(bank.extra["bank_deg"])
    body = 0.012 * bank.ay                 # the body's roll; it tilts the accelerometer too
    roll, ay = phi + body, bank.ay + 9.81 * np.sin(body)
    k = road.roll_gradient(bank.t, roll, ay)
    assert abs(k - 0.012) <= 0.2 * 0.012, k
    with_roll = _score("ekf", replace(bank, ay=ay, extra={"roll_deg": np.degrees(roll)}))
    assert 2.0 * with_roll <= _score("ekf", replace(bank, ay=ay, extra={})), with_roll


def test_a_roll_column_on_a_flat_road_costs_little():
    """Catches the body roll of a flat road counted as bank: on the multi-body plant's sine
    with dwell (its roll angle as an INS roll column, ISO sign; its accelerometer on the
    rolling body), the EKF with the column stays within 10 % of the EKF without it (taken as
    bank, the body roll made it 2.9x worse: 0.0445 -> 0.131 m/s)."""
    from vehicle_observers.data import plant
    from vehicle_observers_papers.leanza_2021.leaderboard import plant_vehicle

    log = plant.plant_log("sine_with_dwell", seed=0)
    veh, m = plant_vehicle(), log.t - log.t[0] > 1.0
    none = EST.available()["ekf"].run(replace(log, extra={}), veh).columns["vy_mps"]
    roll = replace(log, extra={"roll_rad": -log.extra["roll_true_rad"]})
    with_roll = EST.available()["ekf"].run(roll, veh).columns["vy_mps"]
    assert rmse(with_roll, log.vy, m) <= 1.10 * rmse(none, log.vy, m)


def test_a_flat_road_column_changes_nothing():
    """Catches a bank term that acts without a bank (an offset, a unit factor applied to
    zero, a different code path): a zero bank column gives the estimate of the log without
    the column, to the last bit."""
    flat = banked_log(0.0)
    a = EST.available()["ekf"].run(flat, VEH).columns["vy_mps"]
    b = EST.available()["ekf"].run(replace(flat, extra={}), VEH).columns["vy_mps"]
    np.testing.assert_array_equal(a, b)


def test_the_bank_column_is_checked_as_a_column_the_estimator_reads():
    """Catches a bank column outside the estimator's read columns: the command line's input
    checks (plausible range of its unit) must cover it, and an angle of 400 'deg' is
    refused naming the column."""
    from vehicle_observers.cli.main import _reads

    for name in ("ekf", "rts", "adaptive-ekf"):
        assert set(road.BANK_COLUMNS) <= set(EST.available()[name].optional_columns)
    log = replace(banked_log(0.0), extra={"roll_deg": np.full(4000, 400.0)})
    with pytest.raises(LogFormatError, match="roll_deg"):
        check_plausible(_reads(log, EST.available()["ekf"]))


@pytest.mark.parametrize("ks", [-0.008, 0.0])
def test_speed_dependent_stiffness_identified_from_measured_channels(ks):
    """Catches a speed gain that is not in the EKF's tyres (its likelihood flat), enters with
    the wrong sign or reads the reference: on a 10 -> 35 m/s ramp whose tyres stiffen by
    ``1 + ks v_x`` (``ks = -0.008`` s/m: 8 % softer at 10 m/s, 28 % at 35 m/s) the
    maximum-likelihood gain of the measured channels (the reference v_y replaced by garbage)
    is found within 0.001 s/m and the EKF with it is at least 2x better than with the
    vehicle file's constant stiffness; on the same ramp with constant tyres the gain found
    is within 0.001 s/m of 0 and the EKF with it within 0.001 m/s of the EKF without (both
    near 0.003 m/s here; 0.001 m/s is 5 % of the plant logs' best RMSE, a bound chosen here)."""
    from vehicle_observers.baselines import kalman as K
    from vehicle_observers.models.vehicle import KalmanTuning

    log = banked_log(0.0, ks=ks, ramp=True)
    blind = replace(log, vy=np.full(len(log), 123.0), extra={})
    # the sensors' noise, small process noise (a fixed tuning: the ML tuning is not the
    # subject here and would take a minute)
    tun = KalmanTuning(q_vy=1e-4, q_r=1e-4, q_b=1e-6, R_r=0.002**2, R_ay=0.05**2)
    k, dnll = K.fit_stiffness_speed(blind, VEH.params, tun)
    assert abs(k - ks) <= 0.001, (k, dnll)
    m = log.t > 5.0
    fitted = K.ekf(log, replace(VEH.params, stiffness_speed=k), tun).vy
    const = K.ekf(log, VEH.params, tun).vy
    if ks != 0.0:
        assert 2.0 * rmse(fitted, log.vy, m) <= rmse(const, log.vy, m)
    else:
        assert rmse(fitted, log.vy, m) <= rmse(const, log.vy, m) + 0.001


def test_stiffness_speed_read_from_the_vehicle_file(tmp_path):
    """Catches the vehicle file's ``stiffness_speed`` not reaching the filters' parameters, or
    an implausible value accepted."""
    from vehicle_observers.models.vehicle import VehicleFileError

    text = open(VEH.path).read()
    f = tmp_path / "car.toml"
    f.write_text("stiffness_speed = -0.004\n" + text)
    assert load_vehicle(f).params.stiffness_speed == -0.004
    f.write_text("stiffness_speed = 0.5\n" + text)
    with pytest.raises(VehicleFileError, match="stiffness_speed"):
        load_vehicle(f)
