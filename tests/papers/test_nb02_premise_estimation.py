"""Helpers of notebook 02 (yacine_2015/premise_estimation.py) not covered by the notebook test."""

import numpy as np
import pytest
from vehicle_observers.data import scenarios
from vehicle_observers.observers import ts_premise as to
from vehicle_observers_papers.yacine_2015 import constants as Y
from vehicle_observers_papers.yacine_2015 import premise_estimation as ys


def test_mismatched_params_apply_the_stated_changes():
    p = ys.mismatched_params()
    mm = ys.MISMATCH
    for new, old in ((p.tire_f, Y.tire_f), (p.tire_r, Y.tire_r)):
        assert new.B == pytest.approx(old.B * (1 + mm["B"]))
        assert new.C == pytest.approx(old.C * (1 + mm["C"]))
        assert new.D == pytest.approx(old.D * (1 + mm["D"]))
        assert new.E == old.E
    assert p.m == pytest.approx(1650.0) and p.I_z == pytest.approx(2208.6)
    assert p.r_f == p.r_r == 0.15
    assert (p.a_f, p.a_r, p.l_s) == (Y.a_f, Y.a_r, Y.l_s)
    # the cornering stiffness B C D drops by (0.95 * 1.03 * 0.9) -> -11.9 %
    ratio = p.tire_f.cornering_stiffness / Y.tire_f.cornering_stiffness
    assert ratio == pytest.approx(0.95 * 1.03 * 0.9)


def test_columns_rounds_to_significant_digits():
    rows = [{"a": 0.123456789, "b": np.float64(12345.678), "c": np.bool_(True), "d": None},
            {"a": 1e-7 / 3, "b": 3, "c": False, "d": "Xi[8]"}]
    out = ys.columns(rows)
    assert out == {"a": [0.1235, 3.333e-08], "b": [12350.0, 3], "c": [True, False],
                   "d": [None, "Xi[8]"]}
    assert type(out["c"][0]) is bool


def test_lmi_study_rows_name_the_failing_constraint():
    """alpha = 1 with the conditioning bound only: infeasible, named LMI and violation;
    (33) alone: feasible, certificate margin, cond(P) above what the bound allows."""
    cfg = {k: ys.LMI_CONFIGS[k] for k in ("(33) alone", "(33) + P~ <= 1e3 I")}
    rows = ys.lmi_study((1.0,), cfg)
    alone, bounded = rows
    assert alone["feasible"] and alone["P_condition"] > 1e5 and alone["xi_min_relative"] > 0
    assert alone["pole_dt"] == pytest.approx(alone["max_pole_modulus"] * 1e-3)
    assert not bounded["feasible"] and bounded["lmi"] == "Xi[8]" and bounded["violation"] > 0


def test_theory_check_t_informative_matches_the_bound_itself():
    """t_informative is where the (45) branch equals ||e(0)||: evaluate the returned bound
    there (beyond the horizon it is extrapolated from its end value, same formula)."""
    clean = scenarios.emulated_satory(seed=0, quick=True, noise_scale=0.0, v_max=ys.V_MAX)
    d = to.design_theorem1(Y.ts_model(), alpha=0.5, **ys.DISK_ONLY)
    tc = ys.theory_check(clean, d, t1=40.0)
    t_inf = tc["t_informative"]
    assert tc["T"] < t_inf < tc["horizon"]
    k = np.searchsorted(tc["t"], t_inf)
    assert tc["bound_paper"][k - 1] >= tc["e0"] * (1 - 1e-6)
    assert tc["bound_paper"][k + 1] < tc["e0"]
    assert tc["alpha"] == 0.5 and tc["max_ratio"] <= 1


def test_scaled_mismatch_interpolates_between_the_paper_car_and_the_mismatch():
    assert ys.scaled_mismatch(1.0) == pytest.approx(ys.MISMATCH)
    zero = ys.scaled_mismatch(0.0)
    assert zero["r"] == Y.r_relax and all(v == 0 for k, v in zero.items() if k != "r")
    half = ys.scaled_mismatch(0.5)
    assert half["D"] == pytest.approx(-0.05) and half["r"] == pytest.approx(0.125)
    p = ys.mismatched_params(None, zero)
    assert (p.tire_f, p.tire_r, p.m, p.I_z, p.r_f) == (Y.tire_f, Y.tire_r, Y.m, Y.I_z, Y.r_relax)


def test_certificate_counts_never_count_inconclusive_as_feasible():
    rows = [{"alpha": 1e-3, "config": "(33) alone", "feasible": True, "status": "certified"},
            {"alpha": 1.0, "config": "(33) alone", "feasible": True, "status": "certified"},
            {"alpha": 5.0, "config": "(33) alone", "feasible": True, "status": "inconclusive"},
            {"alpha": 10.0, "config": "(33) alone", "feasible": False, "lmi": "Xi[2]"},
            {"alpha": 2.0, "config": "other", "feasible": True, "status": "certified"}]
    assert ys.certificate_counts(rows) == {"n": 4, "certified": 2, "inconclusive": 1, "infeasible": 1,
                                           "max_certified_alpha": 1.0}
