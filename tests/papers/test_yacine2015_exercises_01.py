"""Checkers of notebook 01's exercises: each accepts a worked solution, rejects a wrong answer
with ``not yet`` and reports a stub (returning ``None``) as ``not attempted``."""

from itertools import product

import numpy as np
import pytest
from vehicle_observers.results import teaching
from vehicle_observers_papers.yacine_2015 import constants as Y
from vehicle_observers_papers.yacine_2015 import exercises_01 as ex


def sector_form(x3, x3_max, g=9.81, p=0.6):
    z = g / p * np.sinc(x3 / np.pi)
    z_min, z_max = g / p * np.sin(x3_max) / x3_max, g / p
    h1 = (z_max - z) / (z_max - z_min)
    return z_min, z_max, h1, 1 - h1


def ts_matrices(fr, ff, vx, p=Y.params):
    """(19)-(21) written out from (13) with F_i^S = f_i alpha_i and the slips (4)."""
    m, Iz, lf, lr, s = p.m, p.I_z, p.a_f, p.a_r, p.r_f
    A = np.array([[0, -vx, 1, 0], [0, 0, 0, 1],
                  [-(ff + fr) / (m * s), -(lf * ff - lr * fr) / (m * s), -vx / s, 0],
                  [-(lf * ff - lr * fr) / (Iz * s), -(lf**2 * ff + lr**2 * fr) / (Iz * s), 0, -vx / s]])
    return A, np.array([[0], [0], [vx * ff / (m * s)], [lf * vx * ff / (Iz * s)]])


def ts_matrices_vx_kept(fr, ff, vx):
    """The classic slip: the 1/v_x of the slip angle kept beside the relaxation's v_x."""
    A, B = ts_matrices(fr, ff, vx)
    A[2:, :2] *= vx
    return A, B


def clipped_error(alpha_deg):
    a = np.radians(alpha_deg)
    f = np.clip(Y.tire_f.secant_stiffness(a), Y.M_f2, Y.M_f1)
    h1 = (Y.M_f1 - f) / (Y.M_f1 - Y.M_f2)
    return float(((h1 * Y.M_f2 + (1 - h1) * Y.M_f1) * a - Y.tire_f.force(a)) / Y.tire_f.force(a))


def bicycle_vertices(bounds, v):
    A, B = [], []
    for z1, z2, z3 in product(*[(hi, lo) for lo, hi in bounds]):
        A.append([[0, v, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1], [0, z2, z1, 0]])
        B.append([[0], [1], [0], [z3]])
    return np.array(A, float), np.array(B, float)


SOLUTIONS = {1: sector_form, 2: ts_matrices, 3: clipped_error, 4: bicycle_vertices}
WRONG = {
    1: lambda x3, xm: (lambda r: (r[0], r[1], r[3], r[2]))(sector_form(x3, xm)),   # weights swapped
    2: ts_matrices_vx_kept,                                                      # v_x not cancelled
    3: lambda a: 0.0,                                                             # "always exact"
    4: lambda b, v: (bicycle_vertices(b, v)[0][::-1], bicycle_vertices(b, v)[1]),  # order reversed
}


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_checker_accepts_solution_rejects_wrong_reports_stub(n):
    check = getattr(ex, f"check_{n}")
    assert check(SOLUTIONS[n], show=False).status == teaching.CORRECT
    assert check(WRONG[n], show=False).status == teaching.WRONG
    assert check(lambda *a: None, show=False).status == teaching.EMPTY
    assert teaching.RESULTS[f"01.{n}"] == teaching.EMPTY


def test_hard_coded_answer_fails_and_the_hint_names_the_entry():
    """A constant answer right for one premise point is wrong for the others the checker tries;
    a wrong entry is named with its row of (13) and the usual cause (catches a checker whose
    hint gives no diagnosis)."""
    A0, B0 = ts_matrices(*ex.Z_2[0])
    assert ex.check_2(lambda *z: (A0, B0), show=False).status == teaching.WRONG
    out = ex.check_2(ts_matrices_vx_kept, show=False)
    assert "A[3,1] (row dx4/dt" in out.message and "factor v_x" in out.message


def test_expected_matrices_against_the_printed_entries_of_21():
    """expected_2 (built from (13) on unit vectors) against entries of (21) computed by hand for
    the paper's car at (f_r, f_f, v_x) = (4.9e4, 4.2e4, 17): catches a wrong premise factor or
    sign in the checker itself. -(f_f + f_r)/(m sigma) = -91000/150 = -606.67 1/s^2,
    v_x f_f/(m sigma) = 17 * 42000/150 = 4760 m/s^3/rad."""
    A, B = ex.expected_2((4.9e4, 4.2e4, 17.0))
    assert A[2, 0] == pytest.approx(-91000 / 150, rel=1e-12)
    assert A[0, 1] == -17.0 and A[2, 2] == pytest.approx(-170.0) and A[1, 3] == 1.0
    assert B[2, 0] == pytest.approx(17 * 42000 / 150, rel=1e-12)
    assert A[3, 1] == pytest.approx(-(1.1**2 * 42000 + 1.44**2 * 49000) / (2454 * 0.1), rel=1e-12)


def test_expected_answers_closed_forms():
    # exercise 1: the blend is the gravity term exactly, also at x3 = 0
    x3 = np.linspace(-0.8, 0.8, 41)
    e = ex.expected_1(x3, 0.8)
    assert np.allclose((e["h1"] * e["z_min"] + e["h2"] * e["z_max"]) * x3, 9.81 / 0.6 * np.sin(x3))
    # exercise 3: zero inside the sector, positive and growing outside
    errs = ex.expected_3(np.array(ex.ALPHA_3))
    assert errs[0] == 0 and 0 < errs[1] < errs[2] < errs[3]
    # exercise 4: 2^3 vertices, and the product weights blend them back to A(z)
    bounds, v = ex.CASES_4[0]
    A, B = ex.expected_4(bounds, v)
    assert A.shape == (8, 4, 4) and B.shape == (8, 4, 1)
    assert A[0][3, 2] == bounds[0][1] and A[-1][3, 1] == bounds[1][0] and B[0][3, 0] == bounds[2][1]
