"""Checkers of the exercises of notebook 08 (Monte Carlo robustness campaigns).

Each ``check_N(answer, ...)`` computes the expected answer on its own (scipy, the library,
another route), calls the student's function on more than one input, and shows one line
through :func:`vehicle_observers.results.teaching.check`. Keys ``"08.N"``.

1. a Monte Carlo confidence interval of a mean RMSE (Student t) and the number of runs a claim
   needs, against ``scipy.stats.t`` on two samples;
2. the seed of a campaign task (``SeedSequence`` keyed by the SHA-256 of the task's key),
   against :func:`vehicle_observers.campaign.spec.seed_sequence` on two keys;
3. the Metzler bound of Theorem 2 without a change of coordinates for two cars, against the
   library's :meth:`UncertainBicycle.max_metzler_uncertainty` of the LMI map's model.
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


# ------------------------------------------------------------------------- exercise 3 -------
def check_3(metzler_bound_of, cars=("yacine2015", "bmw_320i")):
    """Exercise 3: ``metzler_bound_of(car) -> float`` for each car of ``cars``, against the
    LMI map's model of that car."""
    from vehicle_observers.campaign import lmi_map

    if _empty(metzler_bound_of):
        return check("08.3", None, None, hint="")
    want = [lmi_map.point_model(c, 0.1, 5.0, 20.0, 0.0)[1].max_metzler_uncertainty() for c in cars]
    return check("08.3", lambda: [metzler_bound_of(c) for c in cars], want, rtol=1e-9, atol=1e-12,
                 hint="rho_M = (c_r0 l_r - c_f0 l_f) / (c_r0 l_r + c_f0 l_f), 0 when negative "
                      "(an oversteering car); l_f, l_r are a_f, a_r of the vehicle's params and "
                      "c_f0, c_r0 its C_f, C_r")


# ------------------------------------------------------------------------- exercise 2 -------
_KEYS = (("log", "lpv:yacine2015", "slalom", 1.0, 0), ("errors", 3))


def check_2(task_seed, seed: int = 7):
    """Exercise 2: ``task_seed(seed, key) -> numpy.random.SeedSequence`` equal (same first four
    words of state) to the campaign's for two keys."""
    from vehicle_observers.campaign.spec import seed_sequence

    if _empty(task_seed):
        return check("08.2", None, None, hint="")

    def answer():
        out = [task_seed(seed, list(k)) for k in _KEYS]
        if any(o is Ellipsis or o is None for o in out):
            return None
        return [int(w) for o in out for w in o.generate_state(4)]

    want = [int(w) for k in _KEYS for w in seed_sequence(seed, list(k)).generate_state(4)]
    return check("08.2", answer, want, rtol=0, atol=0,
                 hint="hash json.dumps(key, sort_keys=True, separators=(',', ':')) with SHA-256, "
                      "take the first 32 hex digits as four 8-digit words, "
                      "SeedSequence([seed, w0, w1, w2, w3])")
