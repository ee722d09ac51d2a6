"""DMVT observer (Ichalal 2011, Sec. II/IV): Jacobian, Jacobian TS model, LMIs (23),
regions (35)-(36) on systems with a known answer, certification, observer, error paths."""

import numpy as np
import pytest
from vehicle_observers.core.errors import CertificationError, InfeasibleDesign, ObserverArgumentError
from vehicle_observers.core.protocol import Design, Observer, run_readable
from vehicle_observers.design.lmi import disk, halfplane, sector
from vehicle_observers.models import bicycle as b
from vehicle_observers.models.ts import jacobian_ts_from_samples, numerical_jacobian
from vehicle_observers.observers import dmvt
from vehicle_observers_papers.ichalal_2011 import constants as ic

BP = ic.params


# ---- Jacobian (31)-(33) -----------------------------------------------------------------
def test_shared_bicycle_jacobian_matches_finite_differences():
    """bicycle.jacobian (lead's derivation) vs central differences of bicycle.rhs (25)."""
    rng = np.random.default_rng(7)
    x = rng.uniform([-3, -0.3, -1.2, -1.5], [3, 0.3, 1.2, 1.5], size=(200, 4))
    u = rng.uniform(-10, 10, size=200)
    Jfd = numerical_jacobian(lambda x, u: b.rhs(x, u, BP), x, u)
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


# ---- helpers ---------------------------------------------------------------------------
def _bike_jts():
    t = np.arange(0, 10, 2e-3)
    X, U = b.simulate(BP, t)
    return jacobian_ts_from_samples(b.jacobian(X, U, BP), names=["xi1", "xi2"]), X, U


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
    for kw, name in (({"P_lower": -1.0}, "P_lower"), ({"eps": 0.0}, "eps"),
                     ({"K_bound": -5.0}, "K_bound"), ({"r": 1.5}, "r")):
        with pytest.raises(ObserverArgumentError, match=name):
            dmvt.design_dmvt_observer(A, np.ones((1, 2)), **kw)
    with pytest.raises(ObserverArgumentError, match="C must be finite"):
        dmvt.design_dmvt_observer(A, np.array([[np.nan, 1.0]]))


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


def test_readable_rhs_equals_compiled_and_model_part_is_f():
    """DMVTObserver.rhs (numpy, shown in notebook 04) = compiled observer_rhs, with 8
    distinct gains and with one gain, also for estimates outside the sector box; with
    y = C xhat the derivative is f(xhat, u) of (25) exactly (multi-affine weights)."""
    jts, X, U = _bike_jts()
    ts = _bike_ts(X, U)
    rng = np.random.default_rng(7)
    for L in (rng.normal(size=(8, 4, 2)), rng.normal(size=(1, 4, 2))):
        obs = dmvt.DMVTObserver(L, ts, BP, ic.C, 1e-3)
        for scale in (0.1, 2.0):                     # inside / outside the sector box
            xh, u, y = rng.normal(scale=scale, size=4), rng.normal(), rng.normal(size=2)
            out = np.empty(4)
            dmvt.observer_rhs(xh, u, y, BP.as_array(), ts.A, ts.B, ts.zmin, ts.zmax, L,
                              ic.C, out)
            np.testing.assert_allclose(obs.rhs(xh, u, y), out, rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(obs.rhs(xh, u, ic.C @ xh),
                                       b.rhs(xh[None], np.array([u]), BP)[0], rtol=1e-12,
                                       atol=1e-10)


def _sampled_data(T=2.0, dt=1e-3, seed=0):
    """Closed-loop bicycle run and noisy measurements of yaw and roll (sampled data)."""
    t = np.arange(0.0, T, dt)
    X, U = b.simulate(BP, t)
    Y = X @ ic.C.T + 0.01 * np.random.default_rng(seed).standard_normal((len(t), 2))
    return t, X, U[:, None], Y


def test_run_readable_equals_compiled_run():
    """The observer contract: looping the numpy step (RK4 of the numpy rhs) gives the compiled
    run. Both evaluate the same expressions in a different summation order (tensordot vs
    loops), ~1e-16 relative per stage; the error dynamics are exponentially stable, so the
    difference stays at rounding level: rtol 1e-9 over 2000 steps is ~1e4 ulps of margin."""
    jts, X, U = _bike_jts()
    ts = _bike_ts(X, U)
    t, _, u, y = _sampled_data()
    x0 = np.array([0.1, -0.1, 0.1, 0.5])
    L = np.random.default_rng(3).normal(size=(8, 4, 2))
    d = dmvt.design_dmvt_observer(jts.vertices, ic.C, region=[halfplane(2), disk(10)])
    for design in (d, L):
        obs = dmvt.DMVTObserver(design, ts, BP, ic.C, 1e-3)
        assert isinstance(obs, Observer) and isinstance(obs.design, Design)
        tr, rd = obs.run(t, u, y, x0), run_readable(obs, t, u, y, x0)
        np.testing.assert_allclose(rd.x, tr.x, rtol=1e-9, atol=1e-12)
        assert tr.names == obs.state_names and tr.seconds > 0
    assert obs.design.certificate is None and d.certificate.min_margin > 0
    assert obs.output_names == ("beta_rad", "alpha_rad")


def test_run_is_causal():
    """Changing the samples after k leaves the estimate at k unchanged (run and step)."""
    jts, X, U = _bike_jts()
    obs = dmvt.DMVTObserver(np.ones((1, 4, 2)), _bike_ts(X, U), BP, ic.C, 1e-3)
    t, _, u, y = _sampled_data(0.5)
    k = 200
    u2, y2 = u.copy(), y.copy()
    u2[k + 1:] += 3.0
    y2[k + 1:] -= 0.5
    a, c = obs.run(t, u, y), obs.run(t, u2, y2)
    np.testing.assert_array_equal(a.x[:k + 1], c.x[:k + 1])
    assert not np.allclose(a.x[k + 2:], c.x[k + 2:])
    z = obs.initial_state(t, u, y)
    for j in range(1, k + 1):
        z = obs.step(z, j, t, u2, y2)
    np.testing.assert_allclose(z, a.x[k], rtol=1e-9, atol=1e-12)


def test_sampled_data_dmvt_converges_to_cosimulation_at_first_order():
    """DMVTObserver holds u_k, y_k over the sample; the co-simulation evaluates them in the
    RK4 stages. ZOH is a first-order approximation: halving dt halves the difference."""
    jts, X, U = _bike_jts()
    ts = _bike_ts(X, U)
    L = dmvt.design_dmvt_observer(jts.vertices, ic.C, r=1).L
    xhat0 = np.array([0.1, -0.1, 0.1, 0.5])
    diffs = []
    for dt in (1e-3, 5e-4):
        t = np.arange(0.0, 1.0, dt)
        Xs, Xh, Us = dmvt.simulate_bicycle_observer(BP, t, ts, L, ic.C, xhat0=xhat0)
        tr = dmvt.DMVTObserver(L, ts, BP, ic.C, dt).run(t, Us, Xs @ ic.C.T, xhat0)
        assert tr.seconds > 0
        diffs.append(np.abs(tr.x - Xh).max())
    assert diffs[0] > 1e-4       # the two implementations do differ at dt = 1 ms
    assert 1.6 < diffs[0] / diffs[1] < 2.4


def test_observer_rejects_wrong_arguments():
    jts, X, U = _bike_jts()
    ts = _bike_ts(X, U)
    L = np.zeros((1, 4, 2))
    for args, msg in (((L[:, :, :1], ic.C), r"L must have shape \(r, 4, ny\) with r = 8 rules "
                                             r"or 1, ny = 2, got \(1, 4, 1\)"),
                      ((np.repeat(L, 3, axis=0), ic.C), r"L must .* got \(3, 4, 2\)"),
                      ((L, ic.C[:, :3]), r"C must have shape \(ny, 4\)")):
        with pytest.raises(ObserverArgumentError, match=msg):
            dmvt.DMVTObserver(args[0], ts, BP, args[1], 1e-3)
    for dt in (0.0, -1e-3, np.nan):
        with pytest.raises(ObserverArgumentError, match="dt"):
            dmvt.DMVTObserver(L, ts, BP, ic.C, dt)
    obs = dmvt.DMVTObserver(L, ts, BP, ic.C, 1e-3)
    t, _, u, y = _sampled_data(0.01)
    with pytest.raises(ObserverArgumentError, match="x0 must be 4"):
        obs.run(t, u, y, np.zeros(3))
    with pytest.raises(ObserverArgumentError, match=r"y must be \(N, 2\)"):
        obs.run(t, u, y[:, :1])
    with pytest.raises(ObserverArgumentError, match="dt = 0.001 s"):
        obs.run(2 * t, u, y)
    y[3, 1] = np.inf
    with pytest.raises(ObserverArgumentError, match="y has a non-finite value at row 3"):
        obs.run(t, u, y)


def test_observer_input_errors():
    jts, X, U = _bike_jts()
    ts = _bike_ts(X, U)
    t = np.arange(0, 1, 1e-2)
    with pytest.raises(ValueError, match="L must have shape"):
        dmvt.simulate_bicycle_observer(BP, t, ts, np.zeros((3, 4, 2)), ic.C)
    with pytest.raises(ValueError, match="strictly increasing"):
        dmvt.simulate_bicycle_observer(BP, t[::-1], ts, np.zeros((1, 4, 2)), ic.C)
    with pytest.raises(ObserverArgumentError, match=r"C must have shape \(ny, 4\)"):
        dmvt.simulate_bicycle_observer(BP, t, ts, np.zeros((1, 4, 2)), np.ones((2, 3)))
    with pytest.raises(ObserverArgumentError, match="xhat0"):
        dmvt.simulate_bicycle_observer(BP, t, ts, np.zeros((1, 4, 2)), ic.C, xhat0=(0, 0, 0))


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
    with pytest.raises(ObserverArgumentError, match="R_hi > R_lo"):
        dmvt.min_feasible_radius(A_KNOWN[None], C_KNOWN, 0.5, 3.0, 2.0)
    with pytest.raises(ObserverArgumentError, match="tol"):
        dmvt.min_feasible_radius(A_KNOWN[None], C_KNOWN, 0.5, 2.0, 3.0, tol=-0.1)
    # without end checks the bracket is trusted: same answer as with them
    R = dmvt.min_feasible_radius(A_KNOWN[None], C_KNOWN, 0.5, 2.0, 3.0, tol=0.02,
                                 check_ends=False)
    assert R == pytest.approx(np.sqrt(5), abs=0.03)
