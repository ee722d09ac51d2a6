"""Printed constants of Ichalal, Arioui, Mammar (MED 2011) checked against the paper's other
printed numbers, against derivations from the model (25) and against an independent
integration (scipy) of the closed loop."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from vehicle_observers.models import bicycle as b
from vehicle_observers.models.ts import jacobian_ts_from_bounds, jacobian_ts_from_samples
from vehicle_observers_papers.ichalal_2011 import constants as ic


def _printed_h(xi1, xi2):
    """h1..h4 exactly as printed below (34): F~ with the printed denominators 82.91, 11.05."""
    F10, F11 = (xi1 - 84.92) / 82.91, (167.83 - xi1) / 82.91
    F20, F21 = (xi2 - 8.9) / 11.05, (19.95 - xi2) / 11.05
    return np.array([F11 * F21, F10 * F21, F11 * F20, F10 * F20])


def test_printed_weight_denominators_are_the_spans_of_the_printed_bounds():
    # two separately printed sets of numbers: the bounds (34) and the F~ denominators
    (a1, b1), (a2, b2) = ic.xi1_bounds_printed, ic.xi2_bounds_printed
    assert b1 - a1 == pytest.approx(82.91, abs=1e-9)
    assert b2 - a2 == pytest.approx(11.05, abs=1e-9)


def test_printed_weights_pick_the_printed_vertices_in_order():
    """h_k of the printed F~ is 1 at the (xi1, xi2) of the printed A_k and 0 at the others,
    and the library's vertex ordering gives the same weights as the printed h."""
    A = np.array(ic.printed_jacobian_vertices())
    for k, Ak in enumerate(A):
        np.testing.assert_allclose(_printed_h(Ak[3, 1], Ak[3, 2]), np.eye(4)[k], atol=1e-12)
    jts = jacobian_ts_from_bounds(A[0], {(3, 1): ic.xi1_bounds_printed,
                                              (3, 2): ic.xi2_bounds_printed})
    np.testing.assert_allclose(jts.vertices, A, atol=0)
    rng = np.random.default_rng(3)
    xi = np.column_stack([rng.uniform(*ic.xi1_bounds_printed, 50),
                          rng.uniform(*ic.xi2_bounds_printed, 50)])
    J = np.repeat(A[:1], 50, axis=0)
    J[:, 3, 1], J[:, 3, 2] = xi[:, 0], xi[:, 1]
    np.testing.assert_allclose(jts.weights(J), _printed_h(xi[:, 0], xi[:, 1]).T, atol=1e-12)


def test_printed_vertices_have_the_structure_of_the_exact_jacobian():
    """Nonzero pattern of (31)/(34) = pattern of df/dx of (25); the (3,4) entry is 1 in both;
    the (1,2) entry is v = 10 in the exact Jacobian, 30 in print."""
    rng = np.random.default_rng(0)
    X = rng.uniform(-0.5, 0.5, (20, 4))
    J = b.jacobian(X, rng.uniform(-5, 5, 20), ic.params)
    pattern = np.any(J != 0, axis=0)
    for Ak in ic.printed_jacobian_vertices():
        np.testing.assert_array_equal(Ak != 0, pattern)
        assert Ak[2, 3] == J[0, 2, 3] == 1.0
        assert Ak[0, 1] == 30.0 and J[0, 0, 1] == ic.params.v == 10.0


def test_output_matrix_measures_x1_x3_and_tracking_law_27():
    x = np.array([0.3, -0.2, 0.1, 0.7])
    np.testing.assert_array_equal(ic.C @ x, x[[0, 2]])          # (28): x1, x3 measured
    t = 0.4
    assert b.control(x, t, ic.params) == pytest.approx(-10 * (0.1 - np.sin(t))
                                                       - 10 * (0.7 - np.cos(t)), abs=1e-14)


def test_inferred_parameters_reproduce_printed_factors():
    bp = ic.params
    assert bp.g / bp.p == pytest.approx(16.35, abs=1e-12)     # (33)
    assert bp.v**2 == pytest.approx(100.0)                     # (32)-(33)
    assert bp.c * bp.v / bp.p == pytest.approx(8.33, abs=0.005)  # (33), printed rounded


def _closed_loop_scipy(bp, t):
    """(25)+(27) integrated by scipy (DOP853, tight tolerances), independent of the RK4."""
    def f(tt, x):
        u = b.control(x, tt, bp)
        return b.rhs(x[None], np.array([u]), bp)[0]
    sol = solve_ivp(f, (t[0], t[-1]), np.zeros(4), method="DOP853", t_eval=t, rtol=1e-10,
                    atol=1e-12)
    return sol.y.T, b.control(sol.y.T, t, bp)


def test_derived_bounds_and_literal_33_range_do_not_give_the_printed_ones():
    """Bounds along x(0) = 0, 0..20 s, with the RK4 of the library and with scipy: the two
    integrations agree (to 1e-6, far below the gaps), and the literal (33) misses both
    printed ends of xi2 by more than 1.5 (printed to two decimals)."""
    bp = ic.params
    t = np.arange(0, 20, 1e-3)
    X, U = b.simulate(bp, t)
    Xs, Us = _closed_loop_scipy(bp, t)
    np.testing.assert_allclose(X, Xs, atol=1e-7)
    jts = jacobian_ts_from_samples(b.jacobian(X, U, bp), names=["xi1", "xi2"])
    (lo1, lo2), (hi1, hi2) = jts.lo, jts.hi
    # xi2 starts at g/p (x = 0); xi1 upper end v^2/p (x3 = 0) plus the transient term
    assert lo2 == pytest.approx(bp.g / bp.p, abs=1e-12)
    assert bp.v**2 / bp.p <= hi1 <= ic.xi1_bounds_printed[1]
    assert lo1 < ic.xi1_bounds_printed[0] - 10 and hi2 > ic.xi2_bounds_printed[1] + 10
    pr, prs = (ic.printed_jacobian_entries(x, u)[:, 1] for x, u in ((X, U), (Xs, Us)))
    assert abs(pr.min() - prs.min()) < 1e-6 and abs(pr.max() - prs.max()) < 1e-6
    assert ic.xi2_bounds_printed[0] - pr.min() > 1.5
    assert ic.xi2_bounds_printed[1] - pr.max() > 1.5
    # at t = 0 (x = 0, u = k2 cos 0 = 10) the literal (33) is 16.35: known answer
    assert pr[0] == pytest.approx(16.35, abs=1e-12)
