"""A problem compiled once (``CompiledLMI``) and the batched data certificate
(``certify_observers``): the same numbers as cvxpy's own ``Problem.solve`` and as the
certificate of each design alone."""

import cvxpy as cp
import numpy as np
import pytest
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.design.certify import certify_observer, certify_observers
from vehicle_observers.design.constraints import BoundedReal, Decay, InRegion
from vehicle_observers.design.lmi import disk, halfplane
from vehicle_observers.design.synthesis import (
    CompiledLMI,
    ObserverSynthesis,
    decay_disk_problem,
)
from vehicle_observers.design.system import PolytopicSystem

C1 = np.array([[1.0, 0.0]])
A_V = [np.array([[0.0, 1.0], [-2.0, -1.0]]), np.array([[0.0, 1.0], [-5.0, -0.5]])]


def test_compiled_problem_matches_cvxpy_solve_point_by_point():
    """The solver data rebuilt as an affine function of the parameters, the solver updated
    in place and the variables recovered by a precomputed linear map give, at every point,
    the P and K of cvxpy's own Problem.solve, and the same feasible/infeasible verdicts
    (catches a wrong affine decomposition, a wrong sparsity pattern or a wrong recovery)."""
    prob, a, r, P, K = decay_disk_problem(PolytopicSystem(A_V, C1))
    comp = CompiledLMI(prob, [a, r], {"P": P, "K": K})
    seen = set()
    for al, R in [(0.5, 12.0), (3.0, 3.0), (2.0, 20.0), (8.0, 12.0), (1.0, 30.0), (0.5, 12.0)]:
        vals, status, t = comp.solve((al, R))
        a.value, r.value = al, R
        prob.solve(solver="CLARABEL")
        ok = prob.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE)
        assert (vals is not None) == ok, (al, R, status, prob.status)
        assert t > 0
        seen.add(ok)
        if ok:
            # the same interior-point iterations from the same data: equal to round-off
            np.testing.assert_allclose(vals["P"], P.value, rtol=1e-6, atol=1e-8)
            np.testing.assert_allclose(vals["K"], K.value, rtol=1e-6, atol=1e-8)
            assert np.allclose(vals["P"], vals["P"].T)
    assert seen == {True, False}


def test_compiled_problem_refuses_non_dpp_and_wrong_values():
    """A problem that is not DPP (a product of two parameters times a variable) is refused,
    and so are parameter values of the wrong number or size, each in one line."""
    x = cp.Variable()
    p, q = cp.Parameter(), cp.Parameter()
    with pytest.raises(ObserverArgumentError, match="not DPP"):
        CompiledLMI(cp.Problem(cp.Minimize(0), [p * q * x >= 1]), [p, q], {"x": x})
    v = cp.Parameter(2)
    y = cp.Variable(2)
    comp = CompiledLMI(cp.Problem(cp.Minimize(cp.sum(y)), [y >= v]), [v], {"y": y})
    with pytest.raises(ObserverArgumentError, match="entries"):
        comp.solve([np.ones(3)])
    with pytest.raises(ObserverArgumentError, match="expected"):
        comp.solve([np.ones(2), 1.0])


def test_array_and_signed_parameters_match_cvxpy():
    """Matrix parameters (entries probed one by one, in cvxpy's order), a nonpositive
    parameter (probed at -1) and a parameter multiplying a variable: the compiled solution
    equals cvxpy's own at random values (catches a transposed parameter or a sign error)."""
    rng = np.random.default_rng(1)
    Ap = cp.Parameter((2, 3))
    s = cp.Parameter(nonpos=True)
    X = cp.Variable((3, 3), symmetric=True)
    y = cp.Variable(2)
    prob = cp.Problem(cp.Minimize(cp.trace(X) + cp.sum(y)),
                      [X >> np.eye(3) + s * X, y >= Ap @ np.ones(3), y >= -5])
    comp = CompiledLMI(prob, [Ap, s], {"X": X, "y": y})
    for _ in range(3):
        a, sv = rng.normal(size=(2, 3)), -abs(rng.normal())
        vals, status, _ = comp.solve([a, sv])
        Ap.value, s.value = a, sv
        prob.solve(solver="CLARABEL")
        np.testing.assert_allclose(vals["y"], y.value, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(vals["X"], X.value, rtol=1e-6, atol=1e-7)


def test_batched_certificate_equals_each_certificate_alone():
    """certify_observers over designs of different constraints, sizes and structures
    returns, check for check, the margins certify_observer gives each design alone
    (catches a mix-up of the stacked matrices between designs or a wrong batched
    eigenvalue reduction)."""
    rng = np.random.default_rng(3)
    sys2 = PolytopicSystem(A_V, C1, E=[[0.0], [1.0]])
    A3 = [rng.normal(size=(3, 3)) - 3 * np.eye(3) for _ in range(3)]
    sys3 = PolytopicSystem(A3, rng.normal(size=(2, 3)))
    items = []
    for syn, obj in ((ObserverSynthesis(sys2, [Decay(0.5), InRegion(disk(12.0))]), None),
                     (ObserverSynthesis(sys2, [BoundedReal(), InRegion(halfplane(0.2))]),
                      "gamma"),
                     (ObserverSynthesis(sys3, [Decay(0.3)], gains="pdc"), None),
                     (ObserverSynthesis(sys3, [Decay(0.3), InRegion(disk(30.0))]), None)):
        des = syn.solve(objective=obj, raise_on_violation=False)
        items.append((syn, des.P, des.L, des.gamma, des.c))
    # a violated one too: the gain of another design
    items.append((items[3][0], items[3][1], np.zeros_like(items[3][2]), None, None))
    batch = certify_observers(items)
    for it, cb in zip(items, batch):
        ca = certify_observer(*it)
        assert [c.name for c in cb.lmi.checks] == [c.name for c in ca.lmi.checks]
        for x, y in zip(cb.lmi.checks, ca.lmi.checks):
            assert (x.kind, x.margin, x.relative, x.asymmetry, x.size) == \
                (y.kind, y.margin, y.relative, y.asymmetry, y.size)
        np.testing.assert_array_equal(cb.poles, ca.poles)
        assert cb.pole_failures == ca.pole_failures and cb.hinf == ca.hinf
        assert cb.status == ca.status
    # independent check of the stacked eigenvalues for one LMI of the first design
    syn, P, L = items[0][:3]
    X = P @ (A_V[1] - L[0] @ C1)
    assert batch[0].lmi.as_dict()["decay[2]"]["margin"] == pytest.approx(
        -np.linalg.eigvalsh(X + X.T + 2 * 0.5 * P).max(), rel=1e-9)
    assert batch[-1].status == "violated"
