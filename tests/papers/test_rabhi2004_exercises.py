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
def test_lam3_required_from_the_reaching_condition(truth):
    """The gains follow |e0| / t_r + (r/J) max |F_x| (written here from the model constants),
    and a sign() observer with them reaches both wheel-speed surfaces within t_r: catches a
    bound that forgets the disturbance or uses the wrong wheel's constants."""
    man, Xs = truth
    p = R.planar
    for tr in ex.DEADLINES:
        lam = ex.lam3_required(Xs, tr)
        want = [5.0 / tr + p.r_f / p.J_f * np.abs(Xs[:, 8]).max(),
                5.0 / tr + p.r_r / p.J_r * np.abs(Xs[:, 9]).max()]
        np.testing.assert_allclose(lam, want, rtol=1e-12)
        run = EX.part_a_run(man, Xs, R.paper_gains.with_(lam3=tuple(lam)))
        assert max(run["t_reach_omega_f"], run["t_reach_omega_r"]) <= tr


def test_check_1(truth):
    man, Xs = truth
    ex.check_1(lambda tr: ex.lam3_required(Xs, tr), man, Xs)
    assert _status("05.1") == teaching.CORRECT
    ex.check_1(lambda tr: np.asarray(R.x3_err0) / tr, man, Xs)   # forgets the disturbance
    assert _status("05.1") == teaching.WRONG
    ex.check_1(lambda tr: ..., man, Xs)
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


def test_check_4():
    assert [_n_unobservable(w) for w in ex.SENSOR_SETS] == [2, 0, 0]
    ex.check_4(_n_unobservable, _lost_pattern)
    assert _status("05.4") == teaching.CORRECT
    ex.check_4(lambda w: 0, _lost_pattern)            # forgets the warp
    assert _status("05.4") == teaching.WRONG
    ex.check_4(_n_unobservable, lambda: np.ones(4))   # heave is observable
    assert _status("05.4") == teaching.WRONG
    ex.check_4(lambda w: None, lambda: None)
    assert _status("05.4") == teaching.EMPTY


# ------------------------------------------------------------------ Exercise 3 ------------
def test_check_3_the_printed_law_cancels_the_cross_term():
    """theta^' = P Psi' x~4 (the law printed below (22)) is accepted; the flipped law and no
    adaptation are rejected, the flipped one with the doubled-cross-term hint."""
    ex.check_3(lambda Psi, e4, P: P * (Psi.T @ e4))
    assert _status("05.3") == teaching.CORRECT
    out = teaching.RESULTS
    ex.check_3(lambda Psi, e4, P: -P * (Psi.T @ e4))
    assert out["05.3"] == teaching.WRONG
    ex.check_3(lambda Psi, e4, P: np.zeros(8))
    assert _status("05.3") == teaching.WRONG
    ex.check_3(lambda Psi, e4, P: ...)
    assert _status("05.3") == teaching.EMPTY
