"""Exercise checkers of notebook 08: each accepts a worked solution, rejects a wrong answer and
says "not attempted" for an empty stub."""


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


def test_check_2_paired_comparison_against_ttest_rel_and_rejects_the_unpaired_one():
    """Catches a checker that cannot tell a paired interval from an unpaired one (the point of
    the exercise): on the first pair only the paired interval excludes zero."""
    def paired(a, b):
        d = np.asarray(a) - np.asarray(b)
        h = stats.t.ppf(0.975, len(d) - 1) * d.std(ddof=1) / np.sqrt(len(d))
        return d.mean(), h, bool(d.mean() + h < 0)

    def unpaired(a, b):
        a, b = np.asarray(a), np.asarray(b)
        h = stats.t.ppf(0.975, 2 * len(a) - 2) * np.sqrt((a.var(ddof=1) + b.var(ddof=1)) / len(a))
        return a.mean() - b.mean(), h, bool(a.mean() - b.mean() + h < 0)

    ex.check_2(paired)
    assert teaching.RESULTS["08.2"] == teaching.CORRECT
    ex.check_2(unpaired)
    assert teaching.RESULTS["08.2"] == teaching.WRONG
    ex.check_2(lambda a, b: ...)
    assert teaching.RESULTS["08.2"] == teaching.EMPTY
    a, b = ex.paired_samples(11)
    assert paired(a, b)[2] and not unpaired(a, b)[2]
    assert not ex.paired_expected(*ex.paired_samples(12, gap=0.0))[2]


def test_check_3_box_for_a_wrong_file_against_the_closed_form():
    """Catches the symmetric guess rho = E (a file 30 % low needs a 43 % box) and a wrong
    inverse; the brute force agrees with E/(1-E) and rho/(1+rho)."""
    assert ex.box_brute_force(0.3) == pytest.approx(0.3 / 0.7, rel=1e-12)
    assert ex.max_error_brute_force(0.25) == pytest.approx(0.2, rel=1e-6)
    ex.check_3(lambda E: E / (1 - E), lambda r: r / (1 + r))
    assert teaching.RESULTS["08.3"] == teaching.CORRECT
    ex.check_3(lambda E: E, lambda r: r)
    assert teaching.RESULTS["08.3"] == teaching.WRONG
    ex.check_3(lambda E: ..., lambda r: r)
    assert teaching.RESULTS["08.3"] == teaching.EMPTY
