"""Exercise checkers of notebook 03: each accepts a worked solution, rejects a wrong answer
and reports a stub as not attempted."""

from __future__ import annotations

import numpy as np
from vehicle_observers.results import teaching
from vehicle_observers_papers.ifqir_2017 import exercises as ex


def metzler_limit(veh):
    a, b = veh.c_r0 * veh.l_r, veh.c_f0 * veh.l_f
    return max((a - b) / (a + b), 0.0)


def smallest_epsilon(model, L):
    L = np.asarray(L, dtype=float)
    D = np.diagonal(model.A_lo, axis1=2, axis2=3).copy()
    D[..., 1] -= L[..., 1]                    # C = [0 1]: L C only touches column 2
    return (-D).max(axis=(1, 2))


def vertex_gain(A, lam):
    return np.array([A[0, 1], A[1, 1] + lam])


def test_checkers_accept_the_solutions():
    assert ex.check_1(metzler_limit, show=False).status == teaching.CORRECT
    assert ex.check_2(smallest_epsilon, show=False).status == teaching.CORRECT
    assert ex.check_3(vertex_gain, show=False).status == teaching.CORRECT


def test_checkers_reject_wrong_answers():
    # 1: no clipping at 0 (the oversteering variant), and a hard-coded Satory value
    wrong = lambda v: (v.c_r0 * v.l_r - v.c_f0 * v.l_f) / (v.c_r0 * v.l_r + v.c_f0 * v.l_f)
    assert ex.check_1(wrong, show=False).status == teaching.WRONG
    assert ex.check_1(lambda v: 0.2086, show=False).status == teaching.WRONG
    # 2: forgetting the gain, or only the first vertex
    assert ex.check_2(lambda m, L: -np.diagonal(m.A_lo, axis1=2, axis2=3).min(axis=(1, 2)),
                      show=False).status == teaching.WRONG
    assert ex.check_2(lambda m, L: smallest_epsilon(m, L) * 0 + (-(m.A_lo[:, 0, 1, 1] - L[:, 0, 1])),
                      show=False).status == teaching.WRONG
    # 3: L1 one unit too large leaves (1,2) negative (not Metzler): reported as not yet
    out = ex.check_3(lambda A, lam: np.array([A[0, 1] + 1.0, A[1, 1] + lam]), show=False)
    assert out.status == teaching.WRONG and "not Metzler" in out.message
    # a Metzler, Hurwitz gain that is not on the bound is still not the asked one
    out = ex.check_3(lambda A, lam: np.array([A[0, 1] - 1.0, A[1, 1] + lam]), show=False)
    assert out.status == teaching.WRONG


def test_stubs_are_not_attempted():
    def stub(*args):
        ...  # your code here
    for check in (ex.check_1, ex.check_2, ex.check_3):
        assert check(stub, show=False).status == teaching.EMPTY
