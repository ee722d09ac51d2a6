"""Checkers of notebook 05's exercises: each accepts a worked solution, rejects a wrong answer
with a hint and reports an empty stub as not attempted (short 3 s manoeuvre)."""

import numpy as np
import pytest
from vehicle_observers.results import teaching
from vehicle_observers_papers.rabhi_2004 import constants as R
from vehicle_observers_papers.rabhi_2004 import exercises as ex
from vehicle_observers_papers.rabhi_2004 import experiments as EX


@pytest.fixture(scope="module")
def truth():
    return EX.part_a_truth(3.0)


def _status(key):
    return teaching.RESULTS[key]


# ------------------------------------------------------------------ Exercise 1 ------------
def _reaching(e0, lam, d=0.0):
    return abs(e0) / (lam - d * np.sign(e0))


def test_scalar_reaching_time_is_the_closed_form():
    """The scipy event solution of e' = -lam sign(e) + d is |e0| / (lam - d sign(e0))."""
    for c in ex.REACH_CASES:
        assert ex.scalar_reaching_time(*c) == pytest.approx(_reaching(*c), rel=1e-9)
    with pytest.raises(ValueError, match="lam"):
        ex.scalar_reaching_time(1.0, 1.0, 2.0)


def test_check_1(truth):
    man, Xs = truth

    def measured(lam3):
        return EX.part_a_run(man, Xs, R.paper_gains.with_(lam3=(lam3, lam3)))["t_reach_omega_f"]

    ex.check_1(_reaching, measured, man, Xs)
    assert _status("05.1") == teaching.CORRECT
    ex.check_1(lambda e0, lam, d=0.0: abs(e0) / lam, measured, man, Xs)   # ignores d
    assert _status("05.1") == teaching.WRONG
    ex.check_1(_reaching, lambda lam3: 5.0 / lam3, man, Xs)   # the bound, not the run
    assert _status("05.1") == teaching.WRONG
    ex.check_1(lambda e0, lam, d=0.0: None, lambda lam3: None, man, Xs)
    assert _status("05.1") == teaching.EMPTY


# ------------------------------------------------------------------ Exercise 2 ------------
def test_check_2(truth):
    man, Xs = truth

    def chattering(scale):
        return ex.layer_chattering(man, Xs, scale)[0]

    best = min(s for s in ex.LAYER_SCALES if chattering(s) <= ex.CHATTER_BUDGET)
    # a wider layer lowers the chattering on noisy data, down to the true force's own change
    assert chattering(10.0) < chattering(1.0)
    ex.check_2(chattering, best, man, Xs)
    assert _status("05.2") == teaching.CORRECT
    ex.check_2(chattering, max(ex.LAYER_SCALES), man, Xs)   # within budget but not the smallest
    assert _status("05.2") == teaching.WRONG
    ex.check_2(lambda s: None, ..., man, Xs)
    assert _status("05.2") == teaching.EMPTY


# ------------------------------------------------------------------ Exercise 3 ------------
def _n_unobservable(w):
    """8 - rank of the observability matrix of (x11, x21) with x31 measured."""
    M, C, K, _, _ = R.fullcar.matrices()
    A = np.block([[np.zeros((4, 4)), np.eye(4)], [np.zeros((4, 8))]])
    Cm = np.hstack([K[4:7, 0:4], C[4:7, 0:4]])
    if w is not None:
        Cm = np.vstack([Cm, np.hstack([np.eye(4)[w], np.zeros(4)])])
    return 8 - np.linalg.matrix_rank(np.vstack([Cm, Cm @ A]))


def _lost_pattern():
    M, C, K, _, _ = R.fullcar.matrices()
    return np.linalg.svd(K[4:7, 0:4])[2][-1]


def test_check_3():
    assert [_n_unobservable(w) for w in ex.SENSOR_SETS] == [2, 0, 0]
    ex.check_3(_n_unobservable, _lost_pattern)
    assert _status("05.3") == teaching.CORRECT
    ex.check_3(lambda w: 0, _lost_pattern)            # forgets the warp
    assert _status("05.3") == teaching.WRONG
    ex.check_3(_n_unobservable, lambda: np.ones(4))   # heave is observable
    assert _status("05.3") == teaching.WRONG
    ex.check_3(lambda w: None, lambda: None)
    assert _status("05.3") == teaching.EMPTY
