"""Interval-constrained EKF: truncated-Gaussian moments against scipy, compiled equal to
readable, and on matched data with true bounds the estimate stays inside with no larger
variance."""

import numpy as np
import pytest
from scipy.stats import truncnorm
from vehicle_observers.baselines import adaptive as AD
from vehicle_observers.baselines import fusion as FU
from vehicle_observers.core.protocol import run_readable
from vehicle_observers.models.vehicle import load_vehicle

VEH = load_vehicle("yacine2015")
T = np.arange(600) * 0.01
LOG = AD.simulate(VEH.params, T, np.full_like(T, 20.0),
                  0.02 * np.sin(2 * np.pi * 0.5 * T) + 0.01 * np.sin(2 * np.pi * 1.3 * T), seed=2)
TUN = AD.AdaptiveTuning(q_vy=1e-2, q_r=1e-3, R_r=4e-6, R_ay=2.5e-3, rel=0.1)
TERMS = AD.Terms(bias=True, consider=True)


@pytest.mark.parametrize("mu, s, lo, hi", [(0.0, 1.0, -0.5, 2.0), (1.0, 0.3, -1.0, 0.8),
                                           (-2.0, 0.5, -1.0, 1.0), (0.2, 2.0, -0.1, 0.1)])
def test_truncated_moments_match_scipy(mu, s, lo, hi):
    a, b = (lo - mu) / s, (hi - mu) / s
    m2, s2 = FU.truncate_moments(mu, s, lo, hi)
    assert m2 == pytest.approx(truncnorm.mean(a, b, loc=mu, scale=s), rel=1e-9, abs=1e-12)
    assert s2 == pytest.approx(truncnorm.std(a, b, loc=mu, scale=s), rel=1e-8)
    assert lo <= m2 <= hi and s2 <= s


def _uy(lo, hi):
    return (np.column_stack([LOG.vx, LOG.delta, lo, hi]),
            np.column_stack([LOG.yaw_rate, LOG.ay]))


def test_compiled_equals_readable():
    lo, hi = LOG.vy - 0.02, LOG.vy + 0.03
    obs = FU.IntervalFusedEKF(VEH.params, TERMS, TUN)
    u, y = _uy(lo, hi)
    n = 150
    a = obs.run(LOG.t[:n], u[:n], y[:n])
    b = run_readable(obs, LOG.t[:n], u[:n], y[:n])
    assert np.allclose(a.x, b.x, rtol=1e-9, atol=1e-11)


def test_true_bounds_keep_the_estimate_inside_and_shrink_variance():
    lo, hi = LOG.vy - 0.01, LOG.vy + 0.01
    arr = (LOG.t, LOG.vx, LOG.delta, LOG.yaw_rate, LOG.ay)
    free = AD.AdaptiveEKF(VEH.params, TERMS, TUN).filter(*arr)
    fused = FU.IntervalFusedEKF(VEH.params, TERMS, TUN).filter_fused(*arr, lo, hi)
    v = fused["X"][:, 0]
    assert np.all((v >= lo - 1e-12) & (v <= hi + 1e-12))
    assert np.all(fused["Pd"][:, 0] <= free["Pd"][:, 0] + 1e-15)
    e_free = np.sqrt(np.mean((free["X"][:, 0] - LOG.vy) ** 2))
    e_fused = np.sqrt(np.mean((v - LOG.vy) ** 2))
    assert e_fused < e_free


def test_missing_or_reversed_bounds_leave_the_filter_unconstrained():
    arr = (LOG.t, LOG.vx, LOG.delta, LOG.yaw_rate, LOG.ay)
    free = AD.AdaptiveEKF(VEH.params, TERMS, TUN).filter(*arr)
    nan = np.full(len(LOG), np.nan)
    for lo, hi in ((nan, nan), (np.ones(len(LOG)), -np.ones(len(LOG)))):
        f = FU.IntervalFusedEKF(VEH.params, TERMS, TUN).filter_fused(*arr, lo, hi)
        assert np.array_equal(f["X"], free["X"])
