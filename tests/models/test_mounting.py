"""Yaw misalignment of the inertial unit (:mod:`vehicle_observers.models.mounting`) and its
use by the EKF and the RTS smoother (options ``misalignment`` and ``frame``)."""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from vehicle_observers import estimation as EST
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.metrics import rmse
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models import mounting as MT
from vehicle_observers.models.vehicle import load_vehicle

VEH = load_vehicle("yacine2015")
#: planted misalignment [deg]
PSI_DEG = 0.5
#: tolerance on the recovered misalignment [deg] (chosen here: a fifth of the planted angle;
#: the slope's noise std on this log is ~0.03 deg, v_y' on the straight rows adds a bias)
PSI_TOL_DEG = 0.1


@lru_cache(maxsize=None)
def mounted_log(psi_deg: float, T: float = 60.0, seed: int = 0) -> DriveLog:
    """The single-track model with the vehicle file's tyres (``solve_ivp``, rtol 1e-8):
    speed 25 + 5 sin(2 pi t / 12 s) m/s (a_x up to 2.6 m/s^2), steering
    0.02 sin(2 pi t / 3 s) only while sin(2 pi t / 20 s) > 0 (straight-line acceleration and
    braking the other half). The unit is turned by ``psi_deg`` to the left (mounting
    module's sign): a_x, a_y rotated into its axes, with white noise 0.05 m/s^2 (seeded),
    yaw rate noise 0.002 rad/s; the reference ``vy`` is the unit's own (``v_y cos psi -
    v_x sin psi``), the body's in ``vy_body_mps``."""
    p = VEH.params
    t = np.arange(0.0, T, 0.01)
    vx = 25.0 + 5.0 * np.sin(2 * np.pi * t / 12)
    dvx = 5.0 * 2 * np.pi / 12 * np.cos(2 * np.pi * t / 12)
    delta = 0.02 * np.sin(2 * np.pi * t / 3) * (np.sin(2 * np.pi * t / 20) > 0)

    def forces(vy, r, v, d):
        return p.tire_f.force(d - (vy + p.a_f * r) / v), p.tire_r.force(-(vy - p.a_r * r) / v)

    def rhs(tt, x):
        v, d = np.interp(tt, t, vx), np.interp(tt, t, delta)
        Ff, Fr = forces(x[0], x[1], v, d)
        return [(Ff + Fr) / p.m - v * x[1], (p.a_f * Ff - p.a_r * Fr) / p.I_z]

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], t_eval=t, max_step=0.01, rtol=1e-8,
                    atol=1e-10)
    vy, r = sol.y
    ay = sum(forces(vy, r, vx, delta)) / p.m
    ax = dvx - vy * r
    s = np.radians(psi_deg)
    rng = np.random.default_rng(seed)
    ax_s = ax * np.cos(s) + ay * np.sin(s) + 0.05 * rng.standard_normal(len(t))
    ay_s = ay * np.cos(s) - ax * np.sin(s) + 0.05 * rng.standard_normal(len(t))
    return DriveLog(t=t, vx=vx, delta=delta, yaw_rate=r + 0.002 * rng.standard_normal(len(t)),
                    ay=ay_s, vy=vy * np.cos(s) - vx * np.sin(s),
                    extra={"ax_mps2": ax_s, "vy_body_mps": vy},
                    source=f"unit turned {psi_deg:g} deg")


def _vy(log, **opts):
    return EST.available()["ekf"].run(log, VEH, **opts).columns


def test_planted_misalignment_is_recovered_and_the_sensor_frame_error_drops():
    """Catches a wrong sign of the rotation or of the slope, a regression without intercept
    or on the wrong rows, and a sensor-frame output that does not subtract ``v_x psi_m``:
    the planted 0.5 deg is found within 0.1 deg (last row), and the EKF's v_y error against
    the unit's own reference, after the estimate has moved, is at most half of the plain
    EKF's (whose body-frame v_y misses the offset ``v_x psi_m`` ~= 0.22 m/s)."""
    log = mounted_log(PSI_DEG)
    psi = MT.log_misalignment(log)
    assert abs(np.degrees(psi[-1]) - PSI_DEG) < PSI_TOL_DEG
    on = _vy(log, misalignment=True, frame="sensor")
    np.testing.assert_array_equal(on["psi_mount_rad"], psi)
    moved = np.flatnonzero(psi != 0.0)[0]
    m = np.arange(len(log)) >= moved
    plain = rmse(_vy(log)["vy_mps"], log.vy, m)
    assert rmse(on["vy_mps"], log.vy, m) <= 0.5 * plain
    truth = log.extra["vy_body_mps"]
    body = _vy(log, misalignment=True)["vy_mps"]
    assert rmse(body, truth, m) <= 1.1 * rmse(_vy(log)["vy_mps"], truth, m)


def test_an_aligned_unit_stays_near_zero_and_changes_little():
    """Catches an estimate that moves without a misalignment (a_y's offset or v_y' read as
    a slope, no minimum excitation): with the unit aligned, the estimate stays within
    0.1 deg of 0 on every row; the EKF's body-frame v_y with the term is within 0.005 m/s
    of the plain EKF's on every row (a 0.1 deg rotation of a_x <= 2.6 m/s^2 shifts a_y by
    <= 0.0045 m/s^2, which the a_y offset state absorbs), and its sensor-frame v_y differs
    from the body-frame one by at most ``max v_x tan(0.1 deg)`` = 0.052 m/s."""
    log = mounted_log(0.0)
    psi = MT.log_misalignment(log)
    assert np.max(np.abs(np.degrees(psi))) < PSI_TOL_DEG
    a = _vy(log)["vy_mps"]
    b = _vy(log, misalignment=True)["vy_mps"]
    assert np.max(np.abs(a - b)) < 0.005
    c = _vy(log, misalignment=True, frame="sensor")["vy_mps"]
    assert np.max(np.abs(c - b)) <= np.max(log.vx) * np.tan(np.radians(PSI_TOL_DEG))


def test_the_reference_column_is_never_read():
    """Catches an estimate that peeks at the reference: replacing the reference ``vy`` (and
    the body-frame truth) by noise changes neither ``psi_m`` nor the estimate, to the bit."""
    log = mounted_log(PSI_DEG)
    rng = np.random.default_rng(1)
    bad = replace(log, vy=100.0 * rng.standard_normal(len(log)),
                  extra={"ax_mps2": log.extra["ax_mps2"],
                         "vy_body_mps": rng.standard_normal(len(log))})
    np.testing.assert_array_equal(MT.log_misalignment(bad), MT.log_misalignment(log))
    a = _vy(log, misalignment=True, frame="sensor")
    b = _vy(bad, misalignment=True, frame="sensor")
    np.testing.assert_array_equal(a["vy_mps"], b["vy_mps"])


def test_no_excitation_no_estimate_and_a_bad_frame_is_one_error():
    """Catches an estimate that moves on a log without straight-line acceleration (the
    prior must hold it at exactly 0) and a ``frame`` value silently taken as ``body``."""
    log = mounted_log(PSI_DEG)
    flat = replace(log, extra={"ax_mps2": np.zeros(len(log))})
    assert np.all(MT.log_misalignment(flat) == 0.0)
    with pytest.raises(ObserverArgumentError, match="frame"):
        _vy(log, misalignment=True, frame="car")
