"""The checkers of the start page's exercises accept a worked solution, reject a wrong answer (the
mistake the hint names) and report an empty stub as not attempted."""

from __future__ import annotations

import numpy as np
import pytest
from vehicle_observers.models.vehicle import load_vehicle
from vehicle_observers.results.teaching import CORRECT, EMPTY, WRONG
from vehicle_observers_papers.course import exercises as ex


def _check(fn, *args):
    """Run a checker without IPython display and return the outcome's status."""
    from vehicle_observers.results import teaching

    key = {ex.check_1: "00.1", ex.check_2: "00.2", ex.check_3: "00.3"}[fn]
    teaching.RESULTS.pop(key, None)
    fn(*args)
    return teaching.RESULTS[key]


# ------------------------------------------------------------------ exercise 1 ---------------

def rhs_course(v_y, r, F_f, F_r, delta, v_x, car, swap=False):
    alpha_f = delta - (v_y + car.l_f * r) / v_x
    alpha_r = -(v_y - car.l_r * r) / v_x
    sf, sr = car.sigma_f, car.sigma_r
    if swap:                        # the collision: the paper's r (relaxation) read as yaw rate
        sf = sr = r if abs(r) > 1e-9 else 1e-9
    return ((F_f + F_r) / car.m - v_x * r, (car.l_f * F_f - car.l_r * F_r) / car.I_z,
            v_x / sf * (car.F_f_ss(alpha_f) - F_f), v_x / sr * (car.F_r_ss(alpha_r) - F_r))


def test_check_1_accepts_the_course_form_and_rejects_the_symbol_collision():
    assert _check(ex.check_1, rhs_course) == CORRECT
    assert _check(ex.check_1, lambda *a: rhs_course(*a, swap=True)) == WRONG
    assert _check(ex.check_1, lambda *a: None) == EMPTY


def test_check_1_expected_is_the_paper_form_13_not_the_course_form():
    """The expected values come from (13) in the paper's coordinates; mapped back they equal the
    course-form derivatives of the library's S1 (8) with small-angle slips."""
    from vehicle_observers.models import lateral

    car = ex.course_car("revs250lm")
    rows = ex._states(7)
    direct = np.array([lateral.rhs_s1(r[:4], r[4], r[5], car.params, exact=False)[0] for r in rows])
    np.testing.assert_allclose(ex._paper_form(rows, car.params), ex._to_paper(direct, car.params),
                               rtol=1e-10, atol=1e-9)


# ------------------------------------------------------------------ exercise 2 ---------------

def observable(veh, v_x):
    p = veh.params
    rear, front = veh.C_r * p.a_r, veh.C_f * p.a_f
    return bool(abs(rear - front) > 1e-9 * (rear + front))


def test_check_2_accepts_the_derivation_and_rejects_always_observable():
    """Catches a checker that cannot tell the derivation (a21 != 0) from "always True": the
    neutral-steer car must come out unobservable."""
    assert _check(ex.check_2, observable) == CORRECT
    assert _check(ex.check_2, lambda veh, vx: True) == WRONG
    assert _check(ex.check_2, lambda veh, vx: ...) == EMPTY


def test_check_2_expected_from_the_observability_matrix_with_a_neutral_steer_car():
    """Catches a wrong neutral-steer construction: C_r l_r = C_f l_f to round-off, the shipped
    cars far from it, and the other dynamics unchanged (same C_f, mass, inertia)."""
    cars = ex.cars_2()
    n, y = cars["neutral steer"], cars["yacine2015"]
    assert n.C_r * n.params.a_r == pytest.approx(n.C_f * n.params.a_f, rel=1e-12)
    assert (n.C_f, n.params.m, n.params.I_z) == (y.C_f, y.params.m, y.params.I_z)
    assert {k: ex.expected_2(v, 10.0) for k, v in cars.items()} == {
        "yacine2015": True, "revs250lm": True, "neutral steer": False}


# ------------------------------------------------------------------ exercise 3 ---------------

def steady_vy(veh, v_x):
    p = veh.params
    L = p.a_f + p.a_r
    K = p.m / L * (p.a_r / veh.C_f - p.a_f / veh.C_r)       # understeer gradient
    return v_x * (p.a_r - p.m * p.a_f * v_x ** 2 / (veh.C_r * L)) / (L + K * v_x ** 2)


def test_check_3_accepts_the_textbook_steady_state_and_rejects_the_kinematic_one():
    """The textbook closed form (understeer gradient K) against python-control's DC gain: a
    second derivation agrees; the kinematic v_y = l_r v_x / L (no tyre slip) fails at speed."""
    assert _check(ex.check_3, steady_vy) == CORRECT
    kinematic = lambda veh, vx: vx * veh.params.a_r / (veh.params.a_r + veh.params.a_f)  # noqa: E731
    assert _check(ex.check_3, kinematic) == WRONG
    assert _check(ex.check_3, lambda veh, vx: None) == EMPTY


def test_check_3_sign_change_at_the_speed_of_the_formula():
    """Catches a wrong A or B: v_y,ss changes sign at v_x = sqrt(C_r l_r L / (m l_f))."""
    veh = load_vehicle("yacine2015")
    p = veh.params
    v0 = np.sqrt(veh.C_r * p.a_r * (p.a_f + p.a_r) / (p.m * p.a_f))
    assert ex.expected_3(veh, 0.99 * v0) > 0 > ex.expected_3(veh, 1.01 * v0)
