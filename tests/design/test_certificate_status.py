"""Certificate.status: a sign-feasible certificate counts only when its margins are above the
solver's accuracy (relative margin >= MIN_RELATIVE_MARGIN, cond(P) <= MAX_CONDITION)."""

import numpy as np
import pytest
from vehicle_observers.design.lmi import (
    MAX_CONDITION,
    MIN_RELATIVE_MARGIN,
    Certificate,
    LMIDesign,
    check_matrix,
)


def _rotated(eigs, seed=0):
    """A symmetric matrix with eigenvalues ``eigs`` in a random orthonormal basis."""
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(len(eigs), len(eigs))))
    return q @ np.diag(eigs) @ q.T


@pytest.mark.parametrize("rel, status", [(1e-12, "inconclusive"), (1e-10, "inconclusive"),
                                         (1e-3, "certified"), (1e-8, "certified")])
def test_relative_margin_decides_between_certified_and_inconclusive(rel, status):
    """M < 0 with eigenvalues -1 and -rel: relative margin rel (known)."""
    c = Certificate([check_matrix("M<0", _rotated([-1.0, -rel, -0.5]), "neg")])
    assert c.ok
    assert c.min_relative_margin == pytest.approx(rel, rel=1e-3)
    assert c.status == status


def test_a_positive_eigenvalue_is_violated_whatever_its_size():
    c = Certificate([check_matrix("M<0", _rotated([-1.0, 1e-14]), "neg"),
                     check_matrix("P>0", np.eye(2), "pos")])
    assert not c.ok and c.status == "violated"


def test_ill_conditioned_lyapunov_matrix_is_inconclusive():
    """cond(P) = 5e8: its relative margin 2e-9 passes the margin test, the condition test
    does not."""
    P = _rotated([5e8, 3.0, 1.0])
    c = Certificate([check_matrix("P>0", P, "pos"),
                     check_matrix("AtP+PA<0", -np.eye(3), "neg")])
    assert c.max_condition == pytest.approx(5e8, rel=1e-6)
    assert c.min_relative_margin >= MIN_RELATIVE_MARGIN
    assert c.status == "inconclusive"
    c = Certificate([check_matrix("P>0", _rotated([1e7, 1.0]), "pos")])
    assert c.max_condition < MAX_CONDITION and c.status == "certified"


def test_element_wise_and_scalar_checks_do_not_make_it_inconclusive():
    c = Certificate([check_matrix("W>=0", np.array([[0.0, 1e-14], [3.0, 1.0]]), "nonneg"),
                     check_matrix("c>0", np.array([[2.5]]), "pos")])
    assert c.ok and c.max_condition == 1.0 and c.status == "certified"
    assert Certificate([]).status == "certified"


@pytest.mark.parametrize("entry, status", [(-1.3e-15, "inconclusive"), (-5e-13, "inconclusive"),
                                           (-1e-11, "violated"), (-1e-3, "violated"),
                                           (0.0, "certified")])
def test_round_off_below_zero_in_an_element_wise_check_is_inconclusive(entry, status):
    """A structural zero computed as -1.3e-15 (e.g. an entry of S^-1 D S) has an unknown sign:
    inconclusive, not violated; a shortfall above NONNEG_ROUNDOFF (1e-12 of the largest entry,
    here 3) is a violation. Catches an entry-wise check without a round-off band, and one
    whose band is so wide it hides real violations."""
    M = np.array([[0.5, entry * 3.0], [3.0, 1.0]])
    c = Certificate([check_matrix("R>=0", M, "nonneg"), check_matrix("P>0", np.eye(2), "pos")])
    assert c.status == status
    assert (status != "violated") == c.ok


def test_status_of_a_solved_lyapunov_design():
    """A well-posed Lyapunov LMI solved by the solver is certified."""
    A = np.array([[-1.0, 2.0], [0.0, -3.0]])
    d = LMIDesign("lyap")
    d.symmetric("P", 2)
    d.positive("P>0", lambda V: V.P - np.eye(2))
    d.negative("AtP+PA<0", lambda V: A.T @ V.P + V.P @ A + np.eye(2))
    sol = d.solve()
    assert sol.certificate.status == "certified"
