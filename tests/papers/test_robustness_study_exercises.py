"""Exercise checkers of notebook 08: each accepts a worked solution, rejects a wrong answer and
says "not attempted" for an empty stub."""

import hashlib
import json

import numpy as np
import pytest
from scipy import stats
from vehicle_observers.results import teaching
from vehicle_observers_papers.robustness_study import exercises as ex


def test_t_interval_and_runs_against_closed_forms():
    x = np.array([1.0, 2.0, 3.0, 4.0])
    mean, lo, hi = ex.t_interval(x)
    # mean 2.5, s = sqrt(5/3), t_{3, 0.975} = 3.182446
    half = 3.182446305284263 * np.sqrt(5 / 3) / 2
    assert (mean, lo, hi) == pytest.approx((2.5, 2.5 - half, 2.5 + half), rel=1e-9)
    n = ex.runs_for_half_width(x, 0.5)
    s = np.sqrt(5 / 3)
    assert stats.t.ppf(0.975, n - 1) * s / np.sqrt(n) <= 0.5 < stats.t.ppf(0.975, n - 2) * s / np.sqrt(n - 1)


def test_check_1_confidence_interval():
    rng = np.random.default_rng(3)
    samples = rng.gamma(4.0, 0.01, size=30)

    def ci(x):
        x = np.asarray(x)
        h = stats.t.ppf(0.975, len(x) - 1) * x.std(ddof=1) / np.sqrt(len(x))
        return x.mean(), x.mean() - h, x.mean() + h

    def n_runs(x, w):
        s, k = np.std(x, ddof=1), 2
        while stats.t.ppf(0.975, k - 1) * s / np.sqrt(k) > w:
            k += 1
        return k

    def ci_normal(x):                      # z quantile and ddof=0: too narrow for small n
        x = np.asarray(x)
        h = 1.96 * x.std() / np.sqrt(len(x))
        return x.mean(), x.mean() - h, x.mean() + h

    ex.check_1(ci, n_runs, samples, 0.002)
    assert teaching.RESULTS["08.1"] == teaching.CORRECT
    ex.check_1(ci_normal, n_runs, samples, 0.002)
    assert teaching.RESULTS["08.1"] == teaching.WRONG
    ex.check_1(lambda x: ..., n_runs, samples, 0.002)
    assert teaching.RESULTS["08.1"] == teaching.EMPTY


def test_check_2_task_seed():
    def task_seed(seed, key):
        h = hashlib.sha256(json.dumps(key, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
        return np.random.SeedSequence([int(seed), *(int(h[i:i + 8], 16) for i in range(0, 32, 8))])

    def salted(seed, key):                 # Python's hash: differs between processes
        return np.random.SeedSequence([int(seed), abs(hash(str(key))) % 2 ** 32])

    ex.check_2(task_seed)
    assert teaching.RESULTS["08.2"] == teaching.CORRECT
    ex.check_2(salted)
    assert teaching.RESULTS["08.2"] == teaching.WRONG
    ex.check_2(lambda s, k: ...)
    assert teaching.RESULTS["08.2"] == teaching.EMPTY


def test_check_3_metzler_bound():
    from vehicle_observers.campaign.truths import car_vehicle

    def bound(car):
        v = car_vehicle(car)
        a, b = v.C_r * v.params.a_r, v.C_f * v.params.a_f
        return max((a - b) / (a + b), 0.0)

    def unclipped_swapped(car):            # front and rear swapped
        v = car_vehicle(car)
        a, b = v.C_r * v.params.a_r, v.C_f * v.params.a_f
        return (b - a) / (a + b)

    # the Yacine car understeers (bound > 0)
    assert bound("yacine2015") > 0.1
    ex.check_3(bound)
    assert teaching.RESULTS["08.3"] == teaching.CORRECT
    ex.check_3(unclipped_swapped)
    assert teaching.RESULTS["08.3"] == teaching.WRONG
    ex.check_3(lambda c: ...)
    assert teaching.RESULTS["08.3"] == teaching.EMPTY
