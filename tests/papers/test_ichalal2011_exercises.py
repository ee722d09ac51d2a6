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
def xi_bounds(x2_lim, x3_lim):
    g2, g3 = np.meshgrid(np.linspace(*x2_lim, 201), np.linspace(*x3_lim, 201))
    X = np.column_stack([np.zeros(g2.size), g2.ravel(), g3.ravel(), np.zeros(g2.size)])
    J = b.jacobian(X, np.zeros(len(X)), BP)
    return [[J[:, 3, 1].min(), J[:, 3, 1].max()], [J[:, 3, 2].min(), J[:, 3, 2].max()]]


def test_check_2_accepts_the_solution_and_a_known_box():
    assert _run(ex.check_2, xi_bounds).status == CORRECT
    # x2 = 0: xi1 = (v^2/p) cos x3, xi2 = (g/p) cos x3; on x3 in [0.2, 0.6] both decrease
    box = xi_bounds((0.0, 0.0), (0.2, 0.6))
    np.testing.assert_allclose(box[0], BP.v**2 / BP.p * np.cos([0.6, 0.2]), rtol=1e-12)
    np.testing.assert_allclose(box[1], BP.g / BP.p * np.cos([0.6, 0.2]), rtol=1e-12)


def test_check_2_rejects_the_corners_only_and_the_empty_stub():
    def corners(x2_lim, x3_lim):
        X = np.array([[0, a, c, 0] for a in x2_lim for c in x3_lim], dtype=float)
        J = b.jacobian(X, np.zeros(4), BP)
        return [[J[:, 3, 1].min(), J[:, 3, 1].max()], [J[:, 3, 2].min(), J[:, 3, 2].max()]]

    # the box (-0.2..0.2) x (-1..1) has its maximum of xi2 inside (x3 = 0): corners miss it
    assert _run(ex.check_2, corners).status == WRONG
    assert _run(ex.check_2, lambda a, c: ...).status == EMPTY


# ------------------------------------------------------------------ exercise 3 -------------
@pytest.fixture(scope="module")
def vertices():
    t = np.arange(0.0, 8.0, 1e-3)
    X, U = b.simulate(BP, t)
    return jacobian_ts_from_samples(b.jacobian(X, U, BP), names=["xi1", "xi2"]).vertices


def test_check_3_accepts_the_solution_and_rejects_designs_that_miss_the_region(vertices):
    def solution(T_s, R):
        a = np.log(50.0) / T_s
        return a, dmvt.design_dmvt_observer(vertices, C, r=1, region=ds.region(a, R)).L

    assert _run(ex.check_3, solution, vertices, C).status == CORRECT
    # the 2 % settling rule by hand: a = ln(50) / T_s, 3.91 1/s for 1 s
    assert np.log(50.0) == pytest.approx(3.912, abs=1e-3)

    # right a, but a gain designed without the region: its fast poles leave the disk
    def no_region(T_s, R):
        return np.log(50.0) / T_s, dmvt.design_dmvt_observer(vertices, C, r=1).L

    assert _run(ex.check_3, no_region, vertices, C).status == WRONG

    # a 5 % settling rule (a = ln(20) / T_s) with its design: a wrong a
    def five_pct(T_s, R):
        a = np.log(20.0) / T_s
        return a, dmvt.design_dmvt_observer(vertices, C, r=1, region=ds.region(a, R)).L

    assert _run(ex.check_3, five_pct, vertices, C).status == WRONG
    assert _run(ex.check_3, lambda T_s, R: ..., vertices, C).status == EMPTY


def _run(checker, *args):
    """The outcome of a checker, not displayed."""
    return checker(*args, show=False)
