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


def rear_sector(alpha_max_deg):
    f = Y.tire_r.secant_stiffness(np.radians(np.linspace(-alpha_max_deg, alpha_max_deg, 2001)))
    return f.min(), f.max()


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


SOLUTIONS = {1: sector_form, 2: rear_sector, 3: clipped_error, 4: bicycle_vertices}
WRONG = {
    1: lambda x3, xm: (lambda r: (r[0], r[1], r[3], r[2]))(sector_form(x3, xm)),   # weights swapped
    2: lambda a: rear_sector(np.radians(a)),                                     # degrees twice
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


def test_hard_coded_answer_fails():
    """A constant answer right for one input is wrong for the others the checker tries."""
    lo8, hi8 = ex.expected_2(8.0)
    assert (lo8, hi8) == pytest.approx((3.3e4, 4.9e4), rel=1e-6)  # the paper's rear sector
    assert ex.check_2(lambda a: (lo8, hi8), show=False).status == teaching.WRONG


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
