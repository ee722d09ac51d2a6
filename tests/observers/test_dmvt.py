"""DMVT observer (Ichalal 2011, Sec. II/IV): Jacobian, Jacobian TS model, LMIs (23),
regions (35)-(36) on systems with a known answer, certification, observer, error paths."""

import numpy as np
import pytest
from vehicle_observers.core.errors import CertificationError, InfeasibleDesign
from vehicle_observers.design.lmi import disk, halfplane, sector
from vehicle_observers.models import bicycle as b
from vehicle_observers.observers import dmvt
from vehicle_observers_papers.ichalal_2011 import constants as ic

BP = ic.params


# ---- Jacobian (31)-(33) -----------------------------------------------------------------
def test_numerical_jacobian_of_linear_map_is_exact():
    A = np.array([[1.0, 2.0], [-3.0, 0.5]])
    x = np.random.default_rng(1).normal(size=(4, 2))
    J = dmvt.numerical_jacobian(lambda x, u: x @ A.T, x, None)
    np.testing.assert_allclose(J, np.broadcast_to(A, (4, 2, 2)), rtol=0, atol=1e-9)


def test_shared_bicycle_jacobian_matches_finite_differences():
    """bicycle.jacobian (lead's derivation) vs central differences of bicycle.rhs (25)."""
    rng = np.random.default_rng(7)
    x = rng.uniform([-3, -0.3, -1.2, -1.5], [3, 0.3, 1.2, 1.5], size=(200, 4))
    u = rng.uniform(-10, 10, size=200)
    Jfd = dmvt.numerical_jacobian(lambda x, u: b.rhs(x, u, BP), x, u)
    Ja = b.jacobian(x, u, BP)
    # central-difference truncation error ~ h^2 |f'''| ~ 1e-12 * 200 -> far below 1e-6
    np.testing.assert_allclose(Ja, Jfd, rtol=1e-7, atol=1e-6)
    # structure of (31): row 1 = [0, v, 0, 0] (the paper prints 30), row 3 = [0, 0, 0, 1]
    np.testing.assert_array_equal(Ja[:, 0], np.broadcast_to([0, BP.v, 0, 0], (200, 4)))
    np.testing.assert_array_equal(Ja[:, 2], np.broadcast_to([0, 0, 0, 1.0], (200, 4)))


def test_bicycle_jacobian_hand_values_at_upright():
    """At x2 = x3 = 0: xi1 = v^2/p, xi2 = g/p (the 16.35 of (33))."""
    J = b.jacobian(np.zeros((1, 4)), np.array([3.0]), BP)[0]
    assert J[3, 1] == pytest.approx(BP.v**2 / BP.p, rel=1e-12)
    assert J[3, 2] == pytest.approx(BP.g / BP.p, rel=1e-12)
    assert BP.g / BP.p == pytest.approx(16.35, abs=1e-12)


# ---- Jacobian TS model (14)-(18), (34) --------------------------------------------------
def _bike_jts():
    t = np.arange(0, 10, 2e-3)
    X, U = b.simulate(BP, t)
    return dmvt.jacobian_ts_from_samples(b.jacobian(X, U, BP), names=["xi1", "xi2"]), X, U


def test_jacobian_ts_detects_varying_entries_and_interpolates_exactly():
    jts, X, U = _bike_jts()
    assert jts.entries == [(3, 1), (3, 2)]
    assert jts.q == 4
    J = b.jacobian(X, U, BP)
    h = jts.weights(J)
    np.testing.assert_allclose(h.sum(axis=1), 1.0, atol=1e-12)
    assert h.min() >= -1e-12
    np.testing.assert_allclose(np.einsum("ni,ijk->njk", h, jts.vertices), J, atol=1e-9)


def test_jacobian_ts_vertex_ordering_matches_printed_34():
    jts = dmvt.jacobian_ts_from_bounds(
        np.array([[0, 30.0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1], [0, 0, 0, 0]]),
        {(3, 1): ic.xi1_bounds_printed, (3, 2): ic.xi2_bounds_printed})
    np.testing.assert_array_equal(jts.vertices, np.array(ic.printed_jacobian_vertices()))
    # h1 = F1^1 F2^1: weight 1 on A1 when xi1, xi2 sit at their lower bounds
    J = jts.vertices[0][None]
    np.testing.assert_allclose(jts.weights(J), [[1, 0, 0, 0]], atol=1e-12)


def test_jacobian_ts_errors_name_the_entry():
    jts, _, _ = _bike_jts()
    J = jts.vertices[3].copy()
    J[3, 2] += 1.0
    with pytest.raises(ValueError, match="xi2"):
        jts.weights(J[None])
    np.testing.assert_allclose(jts.weights(J[None], clip=True), [[0, 0, 0, 1]], atol=1e-12)
    with pytest.raises(ValueError, match="upper > lower"):
        dmvt.jacobian_ts_from_bounds(np.zeros((2, 2)), {(0, 1): (2.0, 1.0)})
    with pytest.raises(ValueError, match="outside a 2x2"):
        dmvt.jacobian_ts_from_bounds(np.zeros((2, 2)), {(2, 1): (0.0, 1.0)})
    with pytest.raises(ValueError, match="shape"):
        dmvt.jacobian_ts_from_samples(np.zeros((3, 2, 3)))
    bad = np.zeros((3, 2, 2))
    bad[1, 0, 0] = np.nan
    with pytest.raises(ValueError, match="sample 1"):
        dmvt.jacobian_ts_from_samples(bad)


# ---- region LMIs on systems with a known answer -------------------------------------------
# x = (observable state, unobservable complex pair -1 +- 2j): the pair cannot be moved by
# any gain, so the D-stability LMIs are feasible iff -1 +- 2j lies in the region:
#   half-plane Re z < -a  <=> a < 1;  disk |z| < R  <=> R > sqrt(5);
#   sector (damping > cos th) <=> cos th < 1/sqrt(5)  (th > 63.43 deg).
A_KNOWN = np.array([[0.5, 0, 0], [0, -1.0, 2.0], [0, -2.0, -1.0]])
C_KNOWN = np.array([[1.0, 0, 0]])


@pytest.mark.parametrize("region, feasible", [
    (halfplane(0.9), True), (halfplane(1.1), False),
    (disk(2.35), True), (disk(2.15), False),
    (sector(np.radians(66)), True), (sector(np.radians(61)), False),
    ([halfplane(0.8), disk(2.4)], True), ([halfplane(0.8), disk(2.1)], False),
])
def test_region_lmis_known_answer(region, feasible):
    if feasible:
        des = dmvt.design_dmvt_observer(A_KNOWN[None], C_KNOWN, region=region)
        assert des.min_margin > 0
        # the fixed pair is there, the observable pole was moved into the region
        ev = des.poles.eigs[0, 0]
        assert np.min(np.abs(ev - (-1 + 2j))) < 1e-9
        regs = region if isinstance(region, list) else [region]
        for reg in regs:
            assert reg.contains(ev).all()
    else:
        with pytest.raises(InfeasibleDesign):
            dmvt.design_dmvt_observer(A_KNOWN[None], C_KNOWN, region=region)


def test_region_matrices_are_the_papers_35_36():
    rng = np.random.default_rng(3)
    M = rng.normal(size=(3, 3))
    P = M @ M.T + np.eye(3)
    PA = rng.normal(size=(3, 3))
    a, R = 1.7, 9.0
    np.testing.assert_allclose(halfplane(a).lmi(P, PA), PA + PA.T + 2 * a * P)
    np.testing.assert_allclose(disk(R).lmi(P, PA), np.block([[-R * P, PA], [PA.T, -R * P]]))


def test_min_feasible_radius_matches_sqrt5():
    Rmin = dmvt.min_feasible_radius(A_KNOWN[None], C_KNOWN, a=0.5, R_lo=1.0, R_hi=4.0,
                                    tol=0.02)
    assert Rmin == pytest.approx(np.sqrt(5), abs=0.03)


def test_region_sweep_boundary_known_answer():
    sw = dmvt.region_sweep(A_KNOWN[None], C_KNOWN, [0.5, 1.2], [2.0, 3.0])
    np.testing.assert_array_equal(sw["feasible"], [[False, True], [False, False]])
    assert np.isnan(sw["margin"][0, 0]) and sw["margin"][0, 1] > 0


# ---- certification --------------------------------------------------------------------
def test_bicycle_designs_are_certified_and_region_reduces_oscillation():
    jts, _, _ = _bike_jts()
    d0 = dmvt.design_dmvt_observer(jts.vertices, ic.C, r=2)
    d1 = dmvt.design_dmvt_observer(jts.vertices, ic.C, r=2, region=[halfplane(2), disk(10)])
    for d in (d0, d1):
        assert d.solution.certificate.ok and d.min_margin > 0
        # independent: every vertex pair Hurwitz; L = P^-1 K
        assert d.poles.max_real < 0
        np.testing.assert_allclose(np.einsum("ij,rjk->rik", d.P, d.L), d.K, atol=1e-8)
    assert d1.poles.max_real < -2 and d1.poles.max_modulus < 10
    assert d1.poles.max_imag < d0.poles.max_imag
    assert d1.poles.min_damping > d0.poles.min_damping
    # LMIs of different j are decoupled and identical: every K_j is feasible for all j
    assert set(d1.margins()) == {"P - P_lower I > 0", "(23)", "region Re(z) < -2",
                                 "region |z| < 10"}


def test_check_poles_rejects_and_names_the_pair():
    A = np.array([[[0.0, 1.0], [2.0, 0.0]], [[0.0, 1.0], [-1.0, 0.0]]])
    C = np.array([[1.0, 0.0]])
    L_ok = np.array([[[6.0], [12.0]]])           # poles of A_i - L C: -3 +- ...
    ps = dmvt.check_poles(A, L_ok, C)
    assert ps.max_real < 0
    with pytest.raises(CertificationError, match=r"pair \(i=1, j=1\)"):
        dmvt.check_poles(A, np.zeros((1, 2, 1)), C)   # A_1 is unstable with L = 0
    with pytest.raises(CertificationError, match="outside the region"):
        dmvt.check_poles(A, L_ok, C, region=halfplane(10.0))


def test_infeasible_design_unobservable_unstable_mode():
    A = np.array([[[-1.0, 0.0], [0.0, 0.3]]])   # state 2 unstable and not measured
    with pytest.raises(InfeasibleDesign, match="infeasible"):
        dmvt.design_dmvt_observer(A, np.array([[1.0, 0.0]]))


def test_design_input_errors():
    A = np.zeros((1, 2, 2))
    with pytest.raises(ValueError, match="columns"):
        dmvt.design_dmvt_observer(A, np.ones((1, 3)))
    with pytest.raises(ValueError, match=r"\(q, n, n\)"):
        dmvt.design_dmvt_observer(np.zeros((2, 2)), np.ones((1, 2)))
    with pytest.raises(ValueError, match="positive integer"):
        dmvt.design_dmvt_observer(A, np.ones((1, 2)), r=0)
    with pytest.raises(TypeError, match="Region"):
        dmvt.design_dmvt_observer(A, np.ones((1, 2)), region=[1.0])


# ---- observer (6) ---------------------------------------------------------------------
def _bike_ts(X, U):
    z = b.ts_premises(X, U, BP)
    lo, hi = z.min(0), z.max(0)
    sp = hi - lo
    return b.bicycle_ts(BP, list(zip(lo - 0.05 * sp, hi + 0.05 * sp, strict=True)))


def test_observer_plant_part_equals_shared_simulator_and_error_decays():
    jts, X, U = _bike_jts()
    ts = _bike_ts(X, U)
    d = dmvt.design_dmvt_observer(jts.vertices, ic.C, region=[halfplane(2), disk(10)])
    t = np.arange(0, 8, 1e-3)
    Xs, Xh, Us = dmvt.simulate_bicycle_observer(BP, t, ts, d.L, ic.C,
                                                xhat0=(0.1, -0.1, 0.1, 0.5))
    Xref, Uref = b.simulate(BP, t)
    np.testing.assert_allclose(Xs, Xref, atol=1e-12)
    np.testing.assert_allclose(Us, Uref, atol=1e-12)
    e = np.abs(Xs - Xh)
    # guaranteed decay rate a = 2 1/s (Re < -2) -> after 8 s the error is far below 1e-3
    assert e[-1].max() < 1e-3 * e[0].max()
    # the same estimate with 8 (identical-feasible-set) gains and with exact initial state
    Xs2, Xh2, _ = dmvt.simulate_bicycle_observer(BP, t, ts, np.repeat(d.L, 8, axis=0), ic.C,
                                                 xhat0=(0.0, 0.0, 0.0, 0.0))
    np.testing.assert_allclose(Xh2, Xs2, atol=1e-12)


def test_readable_observer_step_equals_compiled_and_model_part_is_f():
    """dmvt.observer_step (numpy, shown in notebook 04) = compiled observer_rhs, with 8
    distinct gains and with one gain, also for estimates outside the sector box; with
    y = C xhat the derivative is f(xhat, u) of (25) exactly (multi-affine weights)."""
    jts, X, U = _bike_jts()
    ts = _bike_ts(X, U)
    rng = np.random.default_rng(7)
    for L in (rng.normal(size=(8, 4, 2)), rng.normal(size=(1, 4, 2))):
        for scale in (0.1, 2.0):                     # inside / outside the sector box
            xh, u, y = rng.normal(scale=scale, size=4), rng.normal(), rng.normal(size=2)
            out = np.empty(4)
            dmvt.observer_rhs(xh, u, y, BP.as_array(), ts.A, ts.B, ts.zmin, ts.zmax, L,
                              ic.C, out)
            np.testing.assert_allclose(dmvt.observer_step(xh, u, y, ts, L, ic.C), out,
                                       rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(dmvt.observer_step(xh, u, ic.C @ xh, ts, L, ic.C),
                                       b.rhs(xh[None], np.array([u]), BP)[0], rtol=1e-12,
                                       atol=1e-10)


def test_observer_input_errors():
    jts, X, U = _bike_jts()
    ts = _bike_ts(X, U)
    t = np.arange(0, 1, 1e-2)
    with pytest.raises(ValueError, match="L must have shape"):
        dmvt.simulate_bicycle_observer(BP, t, ts, np.zeros((3, 4, 2)), ic.C)
    with pytest.raises(ValueError, match="strictly increasing"):
        dmvt.simulate_bicycle_observer(BP, t[::-1], ts, np.zeros((1, 4, 2)), ic.C)
    with pytest.raises(ValueError, match="4 columns"):
        dmvt.simulate_bicycle_observer(BP, t, ts, np.zeros((1, 4, 2)), np.ones((2, 3)))


def test_error_metrics_on_known_signals():
    t = np.linspace(0, 10, 10001)
    X = np.column_stack([np.exp(-t), -np.exp(-t) * np.cos(3 * t)] + [np.zeros_like(t)] * 2)
    m = dmvt.error_metrics(t, X, np.zeros_like(X))
    assert m["overshoot"][0] == 0.0
    assert m["settling"][0] == pytest.approx(np.log(50), abs=2e-3)   # exp(-t) = 0.02
    # -exp(-t) cos 3t: opposite-sign peak where tan 3t = -1/3, value exp(-t*) 3/sqrt(10)
    ts = (np.pi - np.arctan(1 / 3)) / 3
    assert m["overshoot"][1] == pytest.approx(np.exp(-ts) * 3 / np.sqrt(10), rel=1e-5)


def test_number_of_gains_does_not_change_feasibility_on_the_bicycle():
    """Remark in dmvt: with common P the LMIs of different j are decoupled and identical,
    so r = 1 and r = 2 gains are feasible for exactly the same regions (checked across the
    boundary R_min(a=2) ~ 6.1 found by the notebook's bisection)."""
    jts, _, _ = _bike_jts()
    for R, feasible in ((5.5, False), (7.0, True)):
        for r in (1, 2):
            region = [halfplane(2.0), disk(R)]
            if feasible:
                d = dmvt.design_dmvt_observer(jts.vertices, ic.C, r=r, region=region)
                assert d.poles.max_modulus < R and d.poles.max_real < -2.0
            else:
                with pytest.raises(InfeasibleDesign):
                    dmvt.design_dmvt_observer(jts.vertices, ic.C, r=r, region=region)


def test_sweep_brackets_and_bisection_bracket_errors():
    sw = {"a": np.array([0.0, 1.0, 2.0, 3.0]), "R": np.array([4.0, 6.0, 10.0]),
          "feasible": np.array([[0, 1, 1], [0, 0, 1], [0, 0, 0], [1, 0, 1]], dtype=bool)}
    # a = 2 (never feasible) and a = 3 (not an upper interval) are skipped
    assert dmvt.sweep_brackets(sw) == [(0.0, 4.0, 6.0), (1.0, 6.0, 10.0)]
    with pytest.raises(ValueError, match="R_hi > R_lo"):
        dmvt.min_feasible_radius(A_KNOWN[None], C_KNOWN, 0.5, 3.0, 2.0)
    # without end checks the bracket is trusted: same answer as with them
    R = dmvt.min_feasible_radius(A_KNOWN[None], C_KNOWN, 0.5, 2.0, 3.0, tol=0.02,
                                 check_ends=False)
    assert R == pytest.approx(np.sqrt(5), abs=0.03)
