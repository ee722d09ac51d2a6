"""The checkers of notebook 00's exercises accept a worked solution, reject a wrong answer (the
mistake the hint names) and report an empty stub as not attempted."""

from __future__ import annotations

import numpy as np
import pytest
from vehicle_observers import estimation as EST
from vehicle_observers.estimation import kalman_runs as KR
from vehicle_observers.models.vehicle import load_vehicle
from vehicle_observers.results.teaching import CORRECT, EMPTY, WRONG
from vehicle_observers_papers.course import exercises as ex
from vehicle_observers_papers.course import families


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

@pytest.fixture(scope="module")
def manoeuvre():
    log = families.common_manoeuvre(0)
    return log, KR.kalman_tuning(log, load_vehicle("yacine2015"))[0]


def compare(names, log, vehicle, tuning, transient=families.TRANSIENT_S):
    veh = load_vehicle(vehicle)
    keep = log.t - log.t[0] >= transient
    out = {}
    for n in names:
        est = EST.get(n).run(log, veh, tuning=tuning)
        out[n] = float(np.sqrt(np.mean((est.columns["vy_mps"][keep] - log.vy[keep]) ** 2)))
    return {"rmse": out, "best": min(out, key=out.get)}


def test_check_2_accepts_the_scored_pair_and_rejects_a_wrong_window(manoeuvre):
    log, tun = manoeuvre
    assert _check(ex.check_2, compare, log, "yacine2015", tun) == CORRECT
    assert _check(ex.check_2, lambda *a: compare(*a, transient=0.0), log, "yacine2015", tun) == WRONG
    assert _check(ex.check_2, lambda *a: None, log, "yacine2015", tun) == EMPTY


def test_check_2_expected_winner_is_the_lower_rmse(manoeuvre):
    log, tun = manoeuvre
    want = ex.expected_2(ex.PAIRS[0], log, "yacine2015", tun)
    assert want["best"] == min(want["rmse"], key=want["rmse"].get)
    # the EKF with its a_y and yaw-rate feedback beats the open-loop bicycle on its own model
    assert want["rmse"]["ekf"] < want["rmse"]["open-loop-linear"]


# ------------------------------------------------------------------ exercise 3 ---------------

def usable(columns, causal_only, interval_only):
    return sorted(n for n, s in EST.available().items() if set(s.needs) <= set(columns)
                  and (s.causal or not causal_only) and (s.interval or not interval_only))


def test_check_3_accepts_the_registry_filter_and_rejects_ignoring_causality():
    assert _check(ex.check_3, usable) == CORRECT
    assert _check(ex.check_3, lambda c, causal, i: usable(c, False, i)) == WRONG
    assert _check(ex.check_3, lambda *a: None) == EMPTY


def test_check_3_known_answer_for_the_minimal_sensor_set():
    """Gyro, steering and speed only, online, guaranteed bounds: the two interval observers."""
    assert ex.expected_3(ex.BASE, True, True) == "interval-coordinates, interval-ifqir2017"
    assert "ts-yacine2015" not in ex.expected_3(ex.BASE + ("ay_mps2",), False, False)
    assert "ts-yacine2015" in ex.expected_3(ex.BASE + ("yL_m", "psiL_rad"), False, False)
