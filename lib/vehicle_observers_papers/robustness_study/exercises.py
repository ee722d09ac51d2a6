"""Checkers of the exercises of notebook 08 (Monte Carlo robustness campaigns).

Each ``check_N(answer, ...)`` computes the expected answer on its own (scipy, the library,
another route), calls the student's function on more than one input, and shows one line
through :func:`vehicle_observers.results.teaching.check`. Keys ``"08.N"``.

1. a Monte Carlo confidence interval of a mean RMSE (Student t) and the number of runs a claim
   needs, against ``scipy.stats.t`` on two samples;
2. a *paired* comparison of two estimators run on the same logs (the mean difference of
   their RMSEs, its 95 % Student-t half-width, and whether the first is better), against
   ``scipy.stats.ttest_rel``'s confidence interval, on samples where an unpaired comparison
   could not tell;
3. the stiffness box an interval observer needs when the vehicle file's stiffness is off by up
   to ``E`` (derived: the truth ``c = c_file / (1 + e)`` must lie in ``[(1 - rho) c_file,
   (1 + rho) c_file]`` for every ``|e| <= E``) and, inverted, the largest file error a box
   ``rho`` covers; against a brute-force search over ``e``.
"""

from __future__ import annotations

import math

import numpy as np
from vehicle_observers.results.teaching import check


def _empty(f) -> bool:
    return f is None or f is Ellipsis


# ------------------------------------------------------------------------- exercise 1 -------
def t_interval(samples, level: float = 0.95) -> tuple[float, float, float]:
    """``(mean, lo, hi)``: Student-t confidence interval of the mean of ``samples``."""
    from scipy import stats

    x = np.asarray(samples, float)
    n = len(x)
    lo, hi = stats.t.interval(level, n - 1, loc=x.mean(), scale=x.std(ddof=1) / math.sqrt(n))
    return float(x.mean()), float(lo), float(hi)


def runs_for_half_width(samples, half_width: float, level: float = 0.95) -> int:
    """Smallest ``n >= 2`` with ``t_{n-1} s / sqrt(n) <= half_width``, ``s`` the sample standard
    deviation of the pilot ``samples`` (searched one ``n`` at a time)."""
    from scipy import stats

    s = float(np.std(np.asarray(samples, float), ddof=1))
    n = 2
    while stats.t.ppf(0.5 + level / 2, n - 1) * s / math.sqrt(n) > half_width:
        n += 1
    return n


#: second sample of the checker (so a number copied from the notebook fails)
_OTHER = np.array([0.051, 0.047, 0.060, 0.055, 0.049, 0.058, 0.052, 0.062, 0.050, 0.054])


def check_1(ci, n_runs, samples, half_width):
    """Exercise 1: ``ci(samples) -> (mean, lo, hi)`` (95 %) and ``n_runs(samples, half_width)
    -> int`` on the notebook's Monte Carlo RMSEs and on a second sample."""
    if _empty(ci) or _empty(n_runs):
        return check("08.1", None, None, hint="")
    sets = [(np.asarray(samples, float), float(half_width)), (_OTHER, 0.002)]

    def answer():
        out = []
        for x, w in sets:
            c = ci(x)
            if c is Ellipsis or c is None:
                return None
            out += [*c, n_runs(x, w)]
        return out

    want = []
    for x, w in sets:
        want += [*t_interval(x), runs_for_half_width(x, w)]
    return check("08.1", answer, want, rtol=1e-6,
                 hint="half-width t_{n-1, 0.975} s / sqrt(n) with s = std(ddof=1) "
                      "(scipy.stats.t.ppf); for n_runs keep s from the pilot and raise n until "
                      "the half-width is small enough")


# ------------------------------------------------------------------------- exercise 2 -------

def paired_samples(seed: int = 11, n: int = 25, gap: float = 0.002):
    """Two RMSE samples [m/s] of two estimators on the same ``n`` logs: the logs' difficulty
    varies a lot (a common factor), estimator ``a`` is better by ``gap`` on every log up to a
    small noise; an unpaired interval cannot tell them apart, a paired one can."""
    rng = np.random.default_rng(seed)
    base = rng.gamma(3.0, 0.02, n)                     # how hard each log is
    b = base + rng.normal(0.0, 0.0005, n)
    a = base - gap + rng.normal(0.0, 0.0005, n)
    return a, b


def paired_expected(a, b, level: float = 0.95) -> tuple[float, float, bool]:
    """``(mean of a - b, half-width of its interval, a better)`` from
    ``scipy.stats.ttest_rel(a, b).confidence_interval``."""
    from scipy import stats

    res = stats.ttest_rel(a, b)
    lo, hi = res.confidence_interval(level)
    return float((lo + hi) / 2), float((hi - lo) / 2), bool(hi < 0)


def check_2(paired):
    """Exercise 2: ``paired(a, b) -> (mean difference, half-width, a_is_better)`` on two pairs
    of samples (one where ``a`` is better, one where it is not)."""
    if _empty(paired):
        return check("08.2", None, None, hint="")
    sets = [paired_samples(11), paired_samples(12, gap=0.0)]

    def answer():
        out = {}
        for k, (a, b) in enumerate(sets):
            g = paired(a, b)
            if g is None or g is Ellipsis:
                return None
            m, h, better = g
            out[f"set {k + 1}"] = {"mean difference": float(m), "half-width": float(h),
                                   "a better": bool(better)}
        return out

    want = {}
    for k, (a, b) in enumerate(sets):
        m, h, better = paired_expected(a, b)
        want[f"set {k + 1}"] = {"mean difference": m, "half-width": h, "a better": better}
    return check("08.2", answer, want, rtol=1e-6, unit="m/s",
                 hint=["the same logs: what varies from log to log cancels in a - b",
                       "work on d = a - b: its mean and a Student-t interval with n - 1 degrees "
                       "of freedom",
                       "a is better when the whole interval of the mean difference is below 0"])


# ------------------------------------------------------------------------- exercise 3 -------
#: file errors E of exercise 3 (fractions) and boxes rho
ERRORS_3 = (0.05, 0.1, 0.3)
BOXES_3 = (0.1, 0.25)


def box_brute_force(E: float, n: int = 20001) -> float:
    """Smallest ``rho`` with ``1/(1 + e)`` in ``[1 - rho, 1 + rho]`` for every ``e`` on a grid of
    ``[-E, E]`` (endpoints included)."""
    e = np.linspace(-E, E, n)
    return float(np.max(np.abs(1.0 / (1.0 + e) - 1.0)))


def max_error_brute_force(rho: float) -> float:
    """Largest ``E`` with :func:`box_brute_force` ``(E) <= rho`` (bisection)."""
    lo, hi = 0.0, 0.999
    for _ in range(80):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if box_brute_force(mid, 2001) <= rho else (lo, mid)
    return lo


def check_3(box_for_file_error, max_file_error):
    """Exercise 3: ``box_for_file_error(E) -> rho`` and ``max_file_error(rho) -> E`` against a
    brute-force search."""
    if _empty(box_for_file_error) or _empty(max_file_error):
        return check("08.3", None, None, hint="")

    def answer():
        out = {}
        for E in ERRORS_3:
            out[f"box for E = {E:g}"] = box_for_file_error(E)
        for r in BOXES_3:
            out[f"largest E for rho = {r:g}"] = max_file_error(r)
        if any(v is None or v is Ellipsis for v in out.values()):
            return None
        return out

    want = {f"box for E = {E:g}": box_brute_force(E) for E in ERRORS_3}
    want |= {f"largest E for rho = {r:g}": max_error_brute_force(r) for r in BOXES_3}
    return check("08.3", answer, want, rtol=1e-6,
                 hint=["the observer's box is centred on the file's value c_file; the truth is "
                       "c_file / (1 + e)",
                       "which sign of e puts the truth furthest from c_file, and by how much?",
                       "the box is not symmetric in e: a file 30 % too high and one 30 % too low "
                       "need different rho"])
