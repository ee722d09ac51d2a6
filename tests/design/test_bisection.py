"""The bisection of ``ObserverSynthesis.maximise_decay`` through one compiled problem
(``CompiledBisection``: the decay requirement a cvxpy Parameter) against the same bisection
posing and canonicalising a problem at every step (``compiled=False``)."""

import cvxpy as cp
import numpy as np
import pytest
from vehicle_observers.core.errors import InfeasibleDesign
from vehicle_observers.design.constraints import (
    BoundedReal,
    Decay,
    InputToState,
    InRegion,
    Metzler,
)
from vehicle_observers.design.lmi import disk, sector
from vehicle_observers.design.synthesis import CompiledBisection, ObserverSynthesis
from vehicle_observers.design.system import PolytopicSystem

C1 = np.array([[1.0, 0.0]])
A_V = [np.array([[0.0, 1.0], [-2.0, -1.0]]), np.array([[0.0, 1.0], [-5.0, -0.5]])]


def _random_vertices(q, n, seed):
    rng = np.random.default_rng(seed)
    A0 = rng.normal(size=(n, n)) - 1.5 * np.eye(n)
    return [A0 + 0.3 * rng.normal(size=(n, n)) for _ in range(q)], rng


def _cases():
    """``(name, synthesis, hi)``: continuous time with two pole regions, PDC with
    vertex-dependent ``C_i`` under both relaxations, discrete time (the disk radius
    ``exp(-alpha dt)`` as the Parameter), input-to-state with a free ``c`` and a disk, a decay
    rate under a fixed H-infinity level (``P > 0`` unnormalised), a diagonal ``P`` with a
    Metzler constraint and a gain bound."""
    A3, rng = _random_vertices(3, 3, 4)
    C3 = [rng.normal(size=(1, 3)) for _ in range(3)]
    pdc = PolytopicSystem(A3, C3)
    Ad = [np.array([[0.9, 0.2], [-0.1, 0.8]]), np.array([[0.7, 0.3], [0.0, 0.95]])]
    dsys = PolytopicSystem(Ad, C1, time="discrete", dt=0.1)
    iss = PolytopicSystem(A_V, C1, E=[[0.0], [1.0]])
    Am = [np.array([[-2.0, 1.0], [0.5, -3.0]]), np.array([[-2.5, 0.4], [1.0, -1.0]])]
    return [
        ("common decay + disk + sector",
         ObserverSynthesis(PolytopicSystem(A_V, C1),
                           [Decay(), InRegion(disk(12.0)), InRegion(sector(1.2))]), 20.0),
        ("pdc tanaka", ObserverSynthesis(pdc, [Decay()], gains="pdc", relaxation="tanaka"),
         20.0),
        ("pdc tuan", ObserverSynthesis(pdc, [Decay()], gains="pdc", relaxation="tuan"), 20.0),
        ("discrete decay", ObserverSynthesis(dsys, [Decay()]), 40.0),
        ("iss free c", ObserverSynthesis(iss, [InputToState(c=None), InRegion(disk(12.0))]),
         30.0),
        ("decay at a fixed hinf level",
         ObserverSynthesis(iss, [Decay(), BoundedReal(gamma=0.5), InRegion(disk(12.0))]),
         30.0),
        ("metzler diagonal P", ObserverSynthesis(PolytopicSystem(Am, C1),
                                                 [Decay(), Metzler(margin=1e-6)],
                                                 P="diagonal", gain_bound=50.0), 10.0),
    ]


CASES = _cases()


@pytest.mark.parametrize("name,syn,hi", CASES, ids=[c[0] for c in CASES])
def test_compiled_bisection_gives_the_old_optimum_and_design(name, syn, hi):
    """The compiled bisection takes the same feasible/infeasible decision at every step as
    the bisection that poses each problem anew, so it ends at the same optimum (the same
    dyadic point; at worst one step apart, within the bisection tolerance) and, at the same
    optimum, returns the very same backed-off design (the same arrays) and the same
    statuses (catches a Parameter entering the LMIs with a wrong coefficient or sign, the
    discrete-time radius taken as alpha, a lost normalisation, gain bound or Metzler
    constraint in the compiled problem, or variables recovered in the wrong order)."""
    tol = 1e-3
    old = syn.maximise_decay(hi=hi, tol=tol, compiled=False)
    new = syn.maximise_decay(hi=hi, tol=tol, compiled=True)
    assert 0.0 < old.optimum < hi                     # a bisection that really ran
    assert abs(new.optimum - old.optimum) <= tol * max(1.0, old.optimum)
    assert new.status == old.status == "certified"
    assert new.at_optimum.status == old.at_optimum.status
    if new.optimum == old.optimum:
        assert new.value == old.value
        np.testing.assert_array_equal(new.design.P, old.design.P)
        np.testing.assert_array_equal(new.design.L, old.design.L)
        assert new.margin == old.margin


@pytest.mark.parametrize("idx", [0, 3])
def test_each_compiled_step_is_the_solve_at_that_alpha(idx):
    """At decay rates inside and beyond the optimum, one compiled step returns what
    ``ObserverSynthesis.solve`` returns at that alpha: ``None`` exactly where the solver
    finds no point (InfeasibleDesign), else the same data-certificate status, the builders'
    certificate with the same names and, inside the feasible set, the same P and L to
    round-off: the same conic data (to 1e-15) and a fresh solver give the same iterates,
    while the point of a feasibility problem is one of many, so a different problem gives a
    different point (catches a step posed or certified at the wrong alpha, or an infeasible
    verdict missed). Near the optimum the problem is ill-conditioned and round-off in the
    data moves the point: there only the decisions are compared (previous test)."""
    name, syn, hi = CASES[idx]
    opt = syn.maximise_decay(hi=hi, tol=1e-3, compiled=False).optimum
    comp = CompiledBisection(syn)
    seen = set()
    for a in (0.0, 0.5 * opt, 1.2 * opt, 3.0 * opt):
        at = syn._with(syn.constraints[0], Decay(a))
        try:
            ref = at.solve(raise_on_violation=False)
        except InfeasibleDesign:
            ref = None
        got = comp.solve(a)
        assert (got is None) == (ref is None), a
        seen.add(ref is None)
        if ref is None:
            continue
        assert got.status == ref.status
        assert got.synthesis.constraints[0].alpha == a
        assert got.solution.certificate.as_dict().keys() == ref.solution.certificate.as_dict().keys()
        scale = np.abs(ref.P).max()
        np.testing.assert_allclose(got.P, ref.P, rtol=1e-8, atol=1e-10 * scale)
        np.testing.assert_allclose(got.L, ref.L, rtol=1e-6, atol=1e-8 * np.abs(ref.L).max())
    assert seen == {True, False}


def test_discrete_compiled_bisection_finds_the_unobservable_mode():
    """Discrete time, an unobservable mode at z = 0.5 with dt = 0.1 s: no gain moves it, so
    the largest decay rate is -ln(0.5) / dt = 6.93 1/s (the Parameter is the disk radius
    exp(-alpha dt); catches the radius and alpha confused, or the exponent's sign)."""
    A = [np.array([[0.5, 0.0], [0.0, 0.2]]), np.array([[0.5, 0.0], [0.0, 0.3]])]
    s = PolytopicSystem(A, [[0.0, 1.0]], time="discrete", dt=0.1)
    opt = ObserverSynthesis(s, [Decay()]).maximise_decay(hi=20.0, tol=1e-4)
    assert opt.optimum == pytest.approx(-np.log(0.5) / 0.1, rel=2e-4)
    assert opt.status == "certified"
    assert np.abs(opt.design.certificate.poles).max() < np.exp(-opt.value * 0.1) + 1e-9


def test_compiled_bisection_canonicalises_once(monkeypatch):
    """The whole compiled bisection asks cvxpy for the conic data twice (the compilation's
    two probes of the one Parameter) plus once for the backed-off design, however many steps
    it takes; the old path asks once per step (catches a bisection that silently
    re-poses its problem at every step)."""
    calls = []
    real = cp.Problem.get_problem_data

    def counted(self, *a, **k):
        calls.append(1)
        return real(self, *a, **k)
    monkeypatch.setattr(cp.Problem, "get_problem_data", counted)
    name, syn, hi = CASES[0]
    new = syn.maximise_decay(hi=hi, tol=1e-4, compiled=True)
    n_new = len(calls)
    calls.clear()
    syn.maximise_decay(hi=hi, tol=1e-4, compiled=False)
    steps = len(calls) - 1                           # every step, then the backed-off design
    assert steps >= 10 and np.log2(hi / 1e-4) - 2 <= steps
    assert n_new == 3
    assert new.status == "certified"
