"""Truths, noisy logs and the observer's vehicle files of a campaign."""

from __future__ import annotations

import numpy as np
import pytest
from vehicle_observers.campaign import truths as T
from vehicle_observers.campaign.spec import DEFAULT_STD, ERROR_KEYS, Variant
from vehicle_observers.campaign.tasks import _in_box
from vehicle_observers.data import plant
from vehicle_observers.models.uncertain_bicycle import UncertainBicycle, simulate_lpv

pytestmark = pytest.mark.xdist_group("campaign")
SLALOM = ("slalom", (("duration", 4.0),))


def test_vehicle_file_errors():
    v0 = T.car_vehicle("bmw_320i")
    assert v0.params == plant.nominal_params(2)
    e = {"mass": 0.1, "inertia": -0.2, "a_f": 0.05, "a_r": -0.05, "stiffness": 0.1,
         "stiffness_front": -0.1, "stiffness_rear": 0.2, "friction": -0.3}
    v = T.observer_vehicle("bmw_320i", e, 0.25, (10.0, 30.0))
    p, p0 = v.params, v0.params
    assert (p.m, p.I_z, p.a_f, p.a_r) == pytest.approx((1.1 * p0.m, 0.8 * p0.I_z, 1.05 * p0.a_f,
                                                        0.95 * p0.a_r))
    assert v.C_f == pytest.approx(1.1 * 0.9 * v0.C_f, rel=1e-12)
    assert v.C_r == pytest.approx(1.1 * 1.2 * v0.C_r, rel=1e-12)
    # friction scales the peak and keeps the slope
    assert p.tire_f.D == pytest.approx(0.7 * p0.tire_f.D) and p.tire_f.C == p0.tire_f.C
    assert v.uncertainty["stiffness_rel"] == 0.25
    assert (v.uncertainty["vx_min"], v.uncertainty["vx_max"]) == (10.0, 30.0)
    # a shipped vehicle file keeps its own speed range when none is given
    y = T.observer_vehicle("yacine2015", {}, 0.1, None)
    assert (y.uncertainty["vx_min"], y.uncertainty["vx_max"]) == (0.2, 17.0)


def test_lpv_truth_is_the_euler_lpv_model():
    tr = T.simulate_truth("lpv", "bmw_320i", SLALOM, 50.0)
    v = T.car_vehicle("bmw_320i")
    p = v.params
    m = plant.slalom_manoeuvre(duration=4.0)
    t = np.arange(0.0, 4.0 - 1e-9, 0.02)
    assert np.allclose(tr.t, t, rtol=0, atol=1e-12) and tr.rate == 50.0
    X = simulate_lpv(UncertainBicycle(p.m, p.I_z, p.a_f, p.a_r, v.C_f, v.C_r, 0.0), [0.0, 0.0],
                     np.interp(t, m.t, m.delta_ref), np.interp(t, m.t, m.v_ref),
                     np.array([v.C_r, v.C_f]), 0.02)
    np.testing.assert_array_equal(tr.vy, X[:, 0])
    np.testing.assert_allclose(tr.ay, (tr.Ff + tr.Fr) / p.m)
    # effective stiffness of a linear truth: exactly the nominal slope
    assert tr.stiffness["cf_min"] == pytest.approx(1.0, abs=1e-12)
    assert tr.stiffness["cr_max"] == pytest.approx(1.0, abs=1e-12)


def test_noisy_log_draws_decimation_and_bias():
    tr = T.simulate_truth("yaw-drift", "yacine2015", SLALOM)
    assert tr.rate == 1000.0 and "yL" in tr.extra
    std = dict(DEFAULT_STD)
    log = T.make_log(tr, 100.0, std, 2.0, {"yaw_rate": 0.01}, "uniform",
                     np.random.default_rng(3))
    assert len(log) == 400 and np.allclose(np.diff(log.t), 0.01)
    np.testing.assert_array_equal(log.vy, tr.vy[::10])
    n = log.yaw_rate - tr.r[::10] - 0.01
    assert np.abs(n).max() <= np.sqrt(3) * 2 * std["yaw_rate"] * (1 + 1e-12)
    assert np.std(n) == pytest.approx(2 * std["yaw_rate"], rel=0.15)
    # the draws do not depend on the plant: the same generator state gives the same noise on
    # a truth without vision channels
    tl = T.simulate_truth("lpv", "yacine2015", SLALOM, 100.0)
    log2 = T.make_log(tl, 100.0, std, 2.0, {"yaw_rate": 0.01}, "uniform",
                      np.random.default_rng(3))
    np.testing.assert_allclose(log2.yaw_rate - tl.r, log.yaw_rate - tr.r[::10], rtol=0, atol=1e-15)
    assert log2.yL is None and log.yL is not None


def test_in_box():
    tr = T.simulate_truth("lpv", "bmw_320i", SLALOM, 100.0)
    zero = dict.fromkeys(ERROR_KEYS, 0.0)
    # truth stiffness 1 (relative to the car), observer nominal 1 + e, box +-rel
    assert _in_box(tr, Variant((), 0.1, None), zero)
    assert _in_box(tr, Variant((), 0.1, None), {**zero, "stiffness": 0.09})
    assert not _in_box(tr, Variant((), 0.1, None), {**zero, "stiffness": 0.12})
    assert _in_box(tr, Variant((), 0.1, None), {**zero, "stiffness": -0.09})
    assert not _in_box(tr, Variant((), 0.1, None), {**zero, "stiffness_rear": -0.1})
    assert not _in_box(tr, Variant((), 0.1, None), {**zero, "mass": 0.01})
