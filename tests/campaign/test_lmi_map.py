"""The LMI feasibility map: one canonicalisation for many points, the same answers as
design_theorem2, the analytic Metzler bound, round-off margins inconclusive."""

from __future__ import annotations

import numpy as np
import pytest
from vehicle_observers.campaign import lmi_map as L
from vehicle_observers.core.errors import InfeasibleDesign
from vehicle_observers.observers import interval as iv

pytestmark = pytest.mark.xdist_group("campaign")
RATE, ACC = 100.0, 12.0


def test_problem_is_dpp_and_canonicalised_once():
    pr = L.problem()
    assert pr.problem.is_dpp()
    L.solve_point("yacine2015", 0.05, 5.0, 20.0, 0.0, RATE, ACC)
    prog = pr.problem._cache.param_prog
    for rel in (0.02, 0.08):
        L.solve_point("yacine2015", rel, 5.0, 20.0, 0.0, RATE, ACC)
    assert pr.problem._cache.param_prog is prog


def test_reused_solver_gives_the_same_bits_as_a_new_one():
    pr = L.problem()
    pts = [("bmw_320i", 0.08, 5.0, 40.0, 0.1), ("yacine2015", 0.3, 5.0, 20.0, 0.0),
           ("yacine2015", 0.12, 2.0, 20.0, 0.1), ("bmw_320i", 0.05, 2.0, 20.0, 0.1)]
    rows = {}
    for reuse in (True, False):
        pr.reuse = reuse
        try:
            rows[reuse] = [L.solve_point(*p, RATE, ACC)[0] for p in pts]
        finally:
            pr.reuse = True
    for a, b in zip(rows[True], rows[False]):
        assert a.keys() == b.keys()
        for k in a:
            assert a[k] == b[k] or (a[k] != a[k] and b[k] != b[k]), (k, a[k], b[k])


@pytest.mark.parametrize("car,rel,lo,hi,kappa", [
    ("yacine2015", 0.05, 5.0, 20.0, 0.0), ("revs250lm", 0.1, 15.0, 62.0, 0.0),
    ("bmw_320i", 0.1, 5.0, 40.0, 0.1), ("bmw_320i", 0.3, 5.0, 40.0, 0.1),
    ("bmw_320i", 0.1, 5.0, 40.0, 0.0)])
def test_same_answer_as_design_theorem2(car, rel, lo, hi, kappa):
    row, tm = L.solve_point(car, rel, lo, hi, kappa, RATE, ACC)
    model, _ = L.point_model(car, rel, lo, hi, kappa)
    try:
        d = iv.design_theorem2(model, eps_decay=1.0, epsilon_shift=RATE, accel_max=ACC, p_min=1.0)
    except InfeasibleDesign:
        assert row["status"] == "infeasible"
        return
    assert row["status"] == "feasible", row["reason"]
    assert row["gamma_sum"] == pytest.approx(float(np.sum(d.gammas)), rel=1e-6)
    # certified independently: the imposed strictness 1e-2 of (17)-(19), Metzler >= 0
    assert row["lmi_margin"] >= 0.99e-2 and row["metzler_margin"] > 0
    assert tm["solver"] > 0 and tm["wall"] >= tm["solver"]


def test_kappa_zero_boundary_is_the_analytic_metzler_bound():
    # c_r l_r > c_f l_f on the whole box <=> rel < (c_r0 l_r - c_f0 l_f)/(c_r0 l_r + c_f0 l_f)
    _, veh = L.point_model("yacine2015", 0.1, 5.0, 20.0, 0.0)
    b = veh.max_metzler_uncertainty()
    a, c = veh.c_r0 * veh.l_r, veh.c_f0 * veh.l_f
    assert b == pytest.approx((a - c) / (a + c))
    below, _ = L.solve_point("yacine2015", 0.98 * b, 5.0, 20.0, 0.0, RATE, ACC)
    above, _ = L.solve_point("yacine2015", 1.02 * b, 5.0, 20.0, 0.0, RATE, ACC)
    assert below["status"] == "feasible" and below["metzler_bound"] == pytest.approx(b)
    assert above["status"] == "infeasible" and above["reason"].startswith("structural: Metzler")
    # the change of coordinates certifies beyond it
    coord, _ = L.solve_point("yacine2015", 1.02 * b, 5.0, 20.0, 0.1, RATE, ACC)
    assert coord["status"] == "feasible"


@pytest.mark.parametrize("shift,why", [(-1e-13, "round-off level"), (-1e-3, "certificate fails")])
def test_margin_at_round_off_is_inconclusive(monkeypatch, shift, why):
    orig = L.ParametricTheorem2.solve

    def nudged(self, model, epsilon, phi):
        sol = orig(self, model, epsilon, phi)
        P, W = np.diag(sol["P"][0, 0]), sol["W"][0, 0]
        X = P @ model.A_lo[0, 0] - W @ model.C + epsilon * P
        scale = max(np.abs(P @ model.A_lo[0, 0]).max(), np.max(epsilon * P))
        # (20) diagonal entry (2,2): move W_2 so that it sits at shift x its scale
        sol["W"][0, 0][1, 0] += (X[1, 1] - shift * scale) / model.C[0, 1]
        return sol

    monkeypatch.setattr(L.ParametricTheorem2, "solve", nudged)
    row, _ = L.solve_point("yacine2015", 0.05, 5.0, 20.0, 0.0, RATE, ACC)
    assert row["status"] == "inconclusive" and why in row["reason"]
    assert row["diag_margin"] == pytest.approx(shift, rel=1e-3, abs=1e-15)
