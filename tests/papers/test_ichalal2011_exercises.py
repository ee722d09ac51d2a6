"""Exercise checkers of notebook 04 (vehicle_observers_papers.ichalal_2011.exercises): each
accepts a worked solution, rejects a wrong answer (with its hint) and reports an empty stub as
not attempted."""

import numpy as np
import pytest
from vehicle_observers.models import bicycle as b
from vehicle_observers.models.ts import jacobian_ts_from_samples
from vehicle_observers.observers import dmvt
from vehicle_observers.results.teaching import CORRECT, EMPTY, WRONG
from vehicle_observers_papers.ichalal_2011 import bicycle_dmvt as ds
from vehicle_observers_papers.ichalal_2011 import constants as ic
from vehicle_observers_papers.ichalal_2011 import exercises as ex

BP, C = ic.params, ic.C


# ------------------------------------------------------------------ exercise 1 -------------
def observability_rank(x, u, C):
    A = b.jacobian(np.atleast_2d(x), np.atleast_1d(u), BP)[0]
    O = np.vstack([C @ np.linalg.matrix_power(A, k) for k in range(4)])
    return int(np.linalg.matrix_rank(O))


def test_check_1_accepts_the_solution_and_knows_the_ranks(monkeypatch):
    out = _run(ex.check_1, observability_rank)
    assert out.status == CORRECT
    # the ranks by hand at x = 0: yaw + roll observe everything; roll alone never sees x1
    # (it enters no other row); yaw alone sees x1 and x2 = x1'/v only; at x3 = pi/2,
    # cos x3 = 0 also removes df4/dx2 and roll alone keeps x3, x4 only
    assert [observability_rank(np.array(x), u, Cs) for x, u, Cs in ex.CASES_1] == [4, 3, 2, 2, 4]


def test_check_1_rejects_a_constant_and_the_full_rank():
    assert _run(ex.check_1, lambda x, u, C: 4).status == WRONG
    # the rank of C alone (forgetting the dynamics)
    assert _run(ex.check_1, lambda x, u, C: np.linalg.matrix_rank(C)).status == WRONG
    assert _run(ex.check_1, lambda x, u, C: None).status == EMPTY


# ------------------------------------------------------------------ exercise 2 -------------
def dmvt_point(x, xhat, u):
    from scipy.optimize import brentq

    e = x - xhat
    df = b.rhs(x, u, BP)[0, 3] - b.rhs(xhat, u, BP)[0, 3]

    def g(s):
        return b.jacobian(xhat + s * e, u, BP)[0, 3] @ e - df

    grid = np.linspace(0.0, 1.0, 201)
    vals = np.array([g(s) for s in grid])
    k = int(np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))[0])
    s = brentq(g, grid[k], grid[k + 1], xtol=1e-14)
    xi = b.jacobian(xhat + s * e, u, BP)[0, 3, 1:3]
    return s, bool(all(lo <= v <= hi for v, (lo, hi) in zip(xi, ex.XI_BOUNDS_2)))


def test_check_2_accepts_the_mean_value_point_and_knows_which_lie_inside():
    """The worked solution passes; its points satisfy the mean value equation of f4 checked
    here with the analytic Jacobian (31) (the checker uses finite differences of its own
    model), and only the first case lies inside the trajectory bounds."""
    out = _run(ex.check_2, dmvt_point)
    assert out.status == CORRECT
    got = [dmvt_point(np.array(x), np.array(xh), u) for x, xh, u in ex.CASES_2]
    assert [g[1] for g in got] == [True, False, False]
    for (x, xh, u), (s, _) in zip(ex.CASES_2, got, strict=True):
        x, xh = np.array(x), np.array(xh)
        xi = xh + s * (x - xh)
        grad = b.jacobian(xi, u, BP)[0, 3]
        assert grad @ (x - xh) == pytest.approx(b.rhs(x, u, BP)[0, 3] - b.rhs(xh, u, BP)[0, 3],
                                                rel=1e-8)


def test_check_2_rejects_the_midpoint_a_wrong_inside_and_the_empty_stub():
    """The midpoint s = 0.5 misses the mean value equation (f4 is not quadratic); the right s
    with 'inside' always True is wrong for the cases outside; the hint names the case."""
    out = _run(ex.check_2, lambda x, xh, u: (0.5, True))
    assert out.status == WRONG and "case" in out.message and "mean-value" in out.message
    out = _run(ex.check_2, lambda x, xh, u: (dmvt_point(x, xh, u)[0], True))
    assert out.status == WRONG and "case 2" in out.message and "inside should be False" in out.message
    assert _run(ex.check_2, lambda x, xh, u: (1.5, True)).status == WRONG
    assert _run(ex.check_2, lambda x, xh, u: ...).status == EMPTY


# ------------------------------------------------------------------ exercise 3 -------------
@pytest.fixture(scope="module")
def vertices():
    t = np.arange(0.0, 8.0, 1e-3)
    X, U = b.simulate(BP, t)
    return jacobian_ts_from_samples(b.jacobian(X, U, BP), names=["xi1", "xi2"]).vertices


def test_check_3_accepts_a_region_that_guarantees_the_specification(vertices):
    """lam = 4, R = 8 guarantees settling (lam >= ln 50 / 1.2 = 3.26) and damping
    (lam / R = 0.5 >= 0.45); the checker's eigenvalues of every vertex pair confirm it."""
    d = dmvt.design_dmvt_observer(vertices, C, r=1, region=ds.region(4.0, 8.0))
    assert _run(ex.check_3, lambda: (4.0, 8.0, d.L), vertices, C).status == CORRECT


def test_check_3_rejects_a_slow_or_underdamped_design_and_an_unguaranteed_region(vertices):
    """No region (damping about 0.3): the damping hint; a slow region (lam = 0.5): the
    settling hint in seconds; the good gain with a region that does not guarantee the
    specification: the region hint."""
    d0 = dmvt.design_dmvt_observer(vertices, C, r=1)
    out = _run(ex.check_3, lambda: (0.0, 100.0, d0.L), vertices, C)
    assert out.status == WRONG and ("damping" in out.message or "settles" in out.message)
    d = dmvt.design_dmvt_observer(vertices, C, r=1, region=ds.region(4.0, 8.0))
    out = _run(ex.check_3, lambda: (1.0, 8.0, d.L), vertices, C)
    assert out.status == WRONG and "does not guarantee" in out.message
    assert _run(ex.check_3, lambda: ..., vertices, C).status == EMPTY


def _run(checker, *args):
    """The outcome of a checker, not displayed."""
    return checker(*args, show=False)
