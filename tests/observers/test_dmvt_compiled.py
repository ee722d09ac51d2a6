"""The disk-radius bisection of the DMVT observer design (Ichalal 2011, LMIs (23) with the
regions (35)-(36)) on one compiled problem (``min_feasible_radius(compiled=True)``, the
radius a cvxpy Parameter of ``CompiledBisection``) against the bisection that poses and
canonicalises a problem at every step (``compiled=False``)."""

import numpy as np
import pytest
from vehicle_observers.core.errors import InfeasibleDesign, ObserverArgumentError
from vehicle_observers.design import synthesis
from vehicle_observers.design.lmi import disk, halfplane
from vehicle_observers.design.synthesis import CompiledBisection
from vehicle_observers.models import bicycle as b
from vehicle_observers.models.ts import jacobian_ts_from_samples
from vehicle_observers.observers import dmvt
from vehicle_observers_papers.ichalal_2011 import constants as ic

# observable state at 0.5 and an unobservable pair -1 +- 2j that no gain moves: the disk
# |z| < R is feasible iff R > sqrt(5) (with Re z < -a, a < 1)
A_KNOWN = np.array([[0.5, 0, 0], [0, -1.0, 2.0], [0, -2.0, -1.0]])
C_KNOWN = np.array([[1.0, 0, 0]])


def _nb04_vertices():
    """The Jacobian TS vertices (34) of notebook 04: the bicycle (25) with law (27) from
    x(0) = 0 over 20 s at dt = 1 ms (``bicycle_dmvt.model_study``), bounds of xi1, xi2 along
    the run (``bicycle_dmvt.jacobian_study``)."""
    t = np.arange(0.0, 20.0, 1e-3)
    X, U = b.simulate(ic.params, t)
    return jacobian_ts_from_samples(b.jacobian(X, U, ic.params), names=["xi1", "xi2"]).vertices


def _random_vertices():
    rng = np.random.default_rng(7)
    A0 = rng.normal(size=(3, 3)) - 2.0 * np.eye(3)
    return np.array([A0 + 0.4 * rng.normal(size=(3, 3)) for _ in range(3)]), \
        rng.normal(size=(1, 3))


def _cases():
    Ar, Cr = _random_vertices()
    return [
        # name, vertices, C, a, R_lo, R_hi, tol, r, check_ends
        ("known sqrt5", A_KNOWN[None], C_KNOWN, 0.5, 1.0, 4.0, 0.05, 1, True),
        ("random, 3 vertices, 2 gains", Ar, Cr, 0.5, 2.0, 4.0, 0.2, 2, False),
        ("notebook 04, a = 0", _nb04_vertices(), ic.C, 0.0, 4.0, 6.0, 0.1, 1, False),
    ]


CASES = _cases()


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_compiled_radius_bisection_equals_the_old_path(case):
    """Each compiled step solves the very conic problem of ``design_dmvt_observer`` at that
    radius, so the whole bisection takes the same decisions: the same optimum radius (the
    same float) and the same design at it (the same arrays P, K, L and status), on the known
    answer sqrt(5), a random 3-vertex system with two gains and notebook 04's bicycle
    (catches the radius entering the compiled LMIs with a wrong coefficient, a lost
    half-plane, normalisation or gain, a decision that ignores the pole check or the
    builders' certificate)."""
    name, A, C, a, lo, hi, tol, r, ends = case
    R_old, d_old = dmvt.min_feasible_radius(A, C, a, lo, hi, tol=tol, r=r, check_ends=ends,
                                            compiled=False, return_design=True)
    R_new, d_new = dmvt.min_feasible_radius(A, C, a, lo, hi, tol=tol, r=r, check_ends=ends,
                                            compiled=True, return_design=True)
    assert lo < R_old < hi                             # a bisection that really ran
    assert R_new == R_old
    for k in ("P", "K", "L"):
        np.testing.assert_array_equal(getattr(d_new, k), getattr(d_old, k))
    assert d_new.data_certificate.status == d_old.data_certificate.status != "violated"
    assert d_new.poles.max_modulus < R_new
    if name == "known sqrt5":
        assert abs(R_new - np.sqrt(5)) <= tol


def test_each_compiled_radius_step_is_the_design_at_that_radius():
    """At radii on both sides of the optimum, one compiled step returns ``None`` exactly where
    ``design_dmvt_observer`` raises InfeasibleDesign and otherwise the same P and L, bit for
    bit (the same conic data from the affine map, a fresh Clarabel solver), and a disk with a
    center is varied keeping its center: for ``|z + 1| < R`` the pair -1 +- 2j needs R > 2
    (catches a step posed at the wrong radius or the center dropped)."""
    Ar, Cr = _random_vertices()
    syn, A, C, regs = dmvt.dmvt_synthesis(Ar, Cr, 2, [halfplane(0.5), disk(30.0)])
    comp = CompiledBisection(syn, target=syn.constraints[-1])
    seen = set()
    for R in (2.0, 4.0):
        try:
            ref = dmvt.design_dmvt_observer(Ar, Cr, r=2, region=[halfplane(0.5), disk(R)])
        except InfeasibleDesign:
            ref = None
        got = comp.solve(R)
        seen.add(ref is None)
        assert (got is None or got.status == "violated") == (ref is None), R
        if ref is not None:
            np.testing.assert_array_equal(got.P, ref.P)
            np.testing.assert_array_equal(got.L, ref.L)
    assert seen == {True, False}
    sk = synthesis.ObserverSynthesis(synthesis.PolytopicSystem(A_KNOWN[None], C_KNOWN),
                                     [synthesis.InRegion(disk(3.0, center=-1.0))])
    ck = CompiledBisection(sk, target=sk.constraints[0])
    ok = [ck.solve(R) for R in (1.9, 2.1)]
    assert ok[0] is None or ok[0].status == "violated"
    assert ok[1].status != "violated"
    assert ok[1].synthesis.constraints[0].region.contains(-1.0 + 2.05j)


def test_planted_wrong_radius_in_the_compiled_problem_is_caught(monkeypatch):
    """A compiled disk LMI posed at 0.9 R (a wrong coefficient of the Parameter) moves the
    compiled optimum away from the old path's and from sqrt(5) (a too-strict problem is still
    certified, so only the comparison catches it); a target that is not one of the
    synthesis' disk constraints is refused in one line."""
    good = synthesis.disk_lmi
    monkeypatch.setattr(synthesis, "disk_lmi", lambda reg, P, PA, R: good(reg, P, PA, 0.9 * R))
    R_bad = dmvt.min_feasible_radius(A_KNOWN[None], C_KNOWN, 0.5, 1.0, 4.0, tol=0.02)
    monkeypatch.setattr(synthesis, "disk_lmi", good)
    R_old = dmvt.min_feasible_radius(A_KNOWN[None], C_KNOWN, 0.5, 1.0, 4.0, tol=0.02,
                                     compiled=False)
    assert R_bad != R_old and R_bad > np.sqrt(5) / 0.9 - 0.02
    syn = dmvt.dmvt_synthesis(A_KNOWN[None], C_KNOWN, 1, [halfplane(0.5), disk(3.0)])[0]
    with pytest.raises(ObserverArgumentError, match="disk"):
        CompiledBisection(syn, target=syn.constraints[1])      # the half-plane
