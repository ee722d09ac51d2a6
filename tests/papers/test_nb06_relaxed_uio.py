"""Experiments and figures of notebook 06 (``uio_study``) on short horizons: each experiment
against a known answer or an independent computation, each figure's axes."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.figure import Figure
from vehicle_observers.observers import uio
from vehicle_observers.papers import elyoussfi2020 as P
from vehicle_observers.papers import nb06_relaxed_uio as us
from vehicle_observers.results.reporting import Report

T_SHORT = P.t_fault + 1.0   # s: 1 s after the fault (notebook: 12 s quick, 20 s full)
SEED = 3


@pytest.fixture(scope="module")
def case():
    """Identified model, (23a) structure, designs (a)/(b) and the short noisy/noise-free runs."""
    model = P.build_model()
    st = uio.structure(model)
    ga, gb = us.designs(model, st)
    return {"model": model, "st": st, "gains": (ga, gb),
            "sim": us.simulation(model, {"a": ga, "b": gb}, T_SHORT, SEED)}


@pytest.fixture(scope="module")
def ekf(case):
    return us.ekf_baseline(case["model"], case["sim"], case["gains"][1])


def _values(metrics):
    return {k: v[0] for k, v in metrics.items()}


def test_fit_metrics_units_on_known_tyres():
    ty = uio.FuzzyTyres(a=np.radians(4.0), b=1.5, c=np.radians(-0.5), C_f=(4e4, 2e4),
                        C_r=(5e4, 1e4), rms_rel=1e-3, max_rel=2e-3)
    m = us.fit_metrics(ty)
    assert m["fit_a_deg"][:2] == (pytest.approx(4.0), "deg")
    assert m["fit_c_deg"][0] == pytest.approx(-0.5)
    assert m["fit_C_f"][0] == [4e4, 2e4] and m["fit_C_r"][0] == [5e4, 1e4]
    assert m["fit_rms_rel"][0] == 1e-3 and m["fit_max_rel"][0] == 2e-3


def test_designs_and_their_metrics(case):
    model, st, gains = case["model"], case["st"], case["gains"]
    ga, gb = gains
    assert (ga.design, gb.design) == ("a", "b") and gb.mu in P.mu_grid
    m = _values(us.design_metrics(st, ga, gb))
    assert m["T_Mbar_residual"] < 1e-12                      # (23a) holds exactly
    assert m["gamma_b"] <= m["gamma_a"] * (1 + 1e-4)         # relaxed no worse
    # independent: slowest pole from the eigenvalues of N_i, largest gain entry of L_i
    for k, g in (("a", ga), ("b", gb)):
        slow = min(-np.linalg.eigvals(n).real.max() for n in g.N)
        assert m[f"slowest_pole_{k}"] == pytest.approx(slow, rel=1e-9)
        assert m[f"slowest_pole_{k}"] > P.alpha_design       # decay rate respected
        assert m[f"gain_norm_{k}"] == max(np.abs(li).max() for li in g.L)
    # a strictness of 1e-3 costs gain: gamma grows, and the certified margin with it
    ga_r, gb_r = us.designs(model, st, mu=(gb.mu,), eps=1e-3)
    r = _values(us.strictness_metrics(ga_r, gb_r))
    assert list(r) == ["gamma_a_eps1e-3", "margin_a_eps1e-3", "gamma_b_eps1e-3",
                       "margin_b_eps1e-3"]
    assert r["gamma_a_eps1e-3"] > ga.gamma and r["gamma_b_eps1e-3"] > gb.gamma
    assert r["margin_a_eps1e-3"] > 1e-4 > ga.min_margin
    text = us.design_summary(ga, gb)
    assert text.count("poles:") == 2


def test_remark1_quadratic_solution_is_a_relaxed_point(case):
    cert, m = us.remark1(case["st"], case["gains"][0])
    assert m["remark1_certified"][0] is True and cert.ok
    assert m["remark1_margin"][0] == cert.min_margin > 0


def test_simulation_metrics_against_independent_computation(case):
    sim = case["sim"]
    sc, sc0 = sim["sc"], sim["sc0"]
    assert len(sc["t"]) == int(round(T_SHORT / P.dt)) + 1
    np.testing.assert_array_equal(sc["X"], sc0["X"])        # same truth, noise only in y
    m = _values(us.simulation_metrics(sim))
    after = sc["t"] >= P.t_fault
    # v_y lies in the decoupled direction: the estimate is the measured v_y, so its RMSE after
    # the fault is the RMS of the measurement noise on v_y (noise-free: ~0, 3e-7 m/s)
    noise_vy = float(np.sqrt(np.mean((sc["y"][after, 0] - sc["X"][after, 0]) ** 2)))
    for k in "ab":
        assert m[f"rmse_vy_{k}"] == pytest.approx(noise_vy, rel=1e-4)
        assert m[f"rmse_vy_{k}_noisefree"] < 1e-3 * P.sigma_vy
        e0 = sim["ev0"][k]["Xhat"][:, 1] - sc0["X"][:, 1]
        assert m[f"initial_err_r_rms_{k}"] == pytest.approx(
            np.sqrt(np.mean(e0[sc0["t"] < 1.0] ** 2)), rel=1e-12)
        assert 0 <= m[f"fault_delay_{k}"] < 0.1
    assert m["max_slip_deg"] == pytest.approx(np.degrees(np.abs(sc["alpha_f"]).max()))
    assert m["max_abs_hdot"] < m["phi_design"] == P.phi_design
    assert len(m) == 2 * 12 + 3
    tab = us.rmse_table(*sim["ev"].items())
    assert set(tab) == {"a", "b"} and tab["a"]["rmse_vy"] == round(m["rmse_vy_a"], 6)


def test_ekf_baseline_metrics(case, ekf):
    sim = case["sim"]
    m = _values(us.ekf_metrics(sim, ekf))
    qi = ekf["qinfo"]
    assert m["ekf_fdot_max"] == P.scale_fdot and m["ekf_d_max"] == qi["d_max"] > 0
    assert m["ekf_tau"] == us.TAU_NOISE
    sc0 = sim["sc0"]
    # settled RMSE (properties): bounded by the largest settled error and by the RMSE over the
    # whole post-fault window, which also holds the onset transient
    mask = sc0["t"] >= P.t_fault + 0.5
    for k, e in (("ekf", ekf["evk0"]), ("ekf_tau", ekf["evk0_tau"])):
        assert 0 < m[f"rmse_f_{k}_settled_noisefree"] <= np.abs(e["err"][mask, 2]).max()
        assert m[f"rmse_f_{k}_settled_noisefree"] < m[f"rmse_f_{k}_noisefree"]
    # the dt-independent rule has a ~1000x larger fault intensity at 1 kHz (tau / dt): it
    # follows the step faster than the per-sample rule, and passes more sensor noise
    assert m["fault_delay_ekf_tau"] < m["fault_delay_ekf"]
    # (noise share of its fault RMSE: noisy / noise-free, much larger than the per-sample one)
    ratio = {k: m[f"rmse_f_{k}"] / m[f"rmse_f_{k}_noisefree"] for k in ("ekf", "ekf_tau")}
    assert ratio["ekf_tau"] > 5 > 2 * ratio["ekf"]
    # the truth without uncertainty really is a different run, and (23a) makes the UIO's
    # fault error before the fault independent of F(t), unlike the EKF's
    assert ekf["sc0_nom"]["X"][:, 0] != pytest.approx(sc0["X"][:, 0])
    assert m["rmse_f_b_before_noisefree"] == pytest.approx(m["rmse_f_b_before_nounc"], rel=0.05)
    assert m["rmse_f_ekf_before_noisefree"] > 10 * m["rmse_f_ekf_before_nounc"]
    assert m["rmse_vy_ekf"] < 0.7 * P.sigma_vy


def test_settled_fault_rmse_known_answer():
    t = np.arange(0, 3.0 + 5e-4, 1e-3)
    f = np.where(t >= 1.0, 0.01, 0.0)
    Xh = np.zeros((len(t), 3))
    Xh[:, 2] = f + np.where(t < 1.5, 0.05, 3e-4)          # onset error excluded, then 3e-4
    ev, sc = {"Xhat": Xh}, {"t": t, "f": f, "t_fault": 1.0}
    assert us.settled_fault_rmse(ev, sc) == pytest.approx(3e-4, rel=1e-12)
    assert us.settled_fault_rmse(ev, sc, after=0.2) > 3e-4  # the onset error counts now
    with pytest.raises(ValueError, match="no sample 2.5 s after the fault"):
        us.settled_fault_rmse(ev, sc, after=2.5)


def test_fault_table(case, ekf):
    tab = us.fault_table(case["sim"], ekf)
    assert list(tab) == ["UIO (a)", "UIO (b)", "EKF q = s^2 dt", "EKF q = s^2 tau, tau = 1 s"]
    assert tab["EKF q = s^2 dt"]["delay"] == round(ekf["evk0"]["fault_delay"], 6)
    assert tab["UIO (b)"]["rmse_f"] == round(case["sim"]["ev"]["b"]["rmse_f"], 6)


def test_cost_comparison_quick_window(case, ekf):
    m = _values(us.cost_comparison(case["model"], case["sim"], case["gains"][1], ekf["evk"],
                                   quick=True))
    assert m["ukf_window_s"] == pytest.approx(us.UKF_QUICK_S)
    assert np.max(m["ukf_ekf_max_diff"]) < 1e-8            # linear model: UKF = EKF = KF
    assert m["ukf_spd_repairs"] == 0
    assert m["cost_ratio_ekf_over_uio"] == pytest.approx(m["us_per_step_ekf"] /
                                                         m["us_per_step_uio"])


def test_feasibility_quick_grid(case):
    fm = us.feasibility(case["model"], case["st"], quick=True)
    np.testing.assert_array_equal(fm["alpha"], [0.0, 15.0])
    np.testing.assert_array_equal(fm["phi"], [0.0, 10.0])
    np.testing.assert_allclose(fm["ratio"], fm["gamma_b"] / fm["gamma_a"][:, None])
    m = _values(us.feasibility_metrics(fm))
    assert m["map_containment"] is True
    assert m["map_n_feasible_a"] == int(np.sum(fm["gamma_a"] <= P.gamma_level)) * 2


def test_feasibility_metrics_known_map():
    fm = {"alpha": np.array([0.0, 1.0]), "phi": np.array([0.0, 10.0]),
          "gamma_a": np.array([0.5, np.nan]), "gamma_b": np.array([[0.45, 0.5], [0.6, np.nan]]),
          "feasible_a": np.array([[True, True], [False, False]]),
          "feasible_b": np.array([[True, True], [False, False]])}
    fm["ratio"] = fm["gamma_b"] / fm["gamma_a"][:, None]
    m = _values(us.feasibility_metrics(fm))
    assert m["map_containment"] is True
    assert (m["map_n_feasible_a"], m["map_n_feasible_b"]) == (2, 2)
    assert (m["map_min_ratio_b_over_a"], m["map_max_ratio_b_over_a"]) == (0.9, 1.0)
    fm["feasible_b"][0, 1] = False                        # (a) feasible where (b) is not
    assert us.feasibility_metrics(fm)["map_containment"][0] is False


def _claim_metrics(**over):
    v = dict(rmse_r_a=2e-3, rmse_r_b=1e-3, peak_err_r_onset_a=1e-2, peak_err_r_onset_b=1e-2,
             rmse_f_a=4e-4, rmse_f_b=2e-4, fault_delay_a=0.02, fault_delay_b=0.025,
             rmse_f_a_noisefree=1e-4, rmse_f_b_noisefree=1.2e-4, max_abs_hdot=6.0,
             map_min_ratio_b_over_a=0.92, map_max_ratio_b_over_a=1.0, map_containment=True,
             rmse_f_ekf_before_noisefree=1e-3, rmse_f_ekf_before_nounc=1e-5,
             rmse_f_b_before_noisefree=1e-5, rmse_f_b_before_nounc=1e-5, fault_delay_ekf=0.07,
             rmse_f_ekf_settled_noisefree=3e-4, rmse_f_b_settled_noisefree=1e-4,
             rmse_f_ekf=3e-4, rmse_vy_ekf=0.01, rmse_vy_b=0.02, cost_ratio_ekf_over_uio=200.0,
             ekf_tau=1.0, fault_delay_ekf_tau=0.05, rmse_f_ekf_tau=1e-3, rmse_vy_ekf_tau=0.012,
             rmse_f_ekf_tau_settled_noisefree=1e-5, rmse_f_ekf_tau_before_noisefree=2e-6)
    v.update(over)
    return {k: {"value": x, "unit": "", "note": ""} for k, x in v.items()}


def test_claims_verdicts_follow_the_metrics(tmp_path):
    cl = us.claims(_claim_metrics())
    assert [c[2] for c in cl] == ["fig3_steering", "fig5_yaw_rate", "fig6_fault",
                                  "fig7_membership_derivatives", "feasibility_map",
                                  "fault_uio_vs_ekf"]
    assert [c[6] for c in cl] == ["not comparable", "partly", "partly", "reproduced",
                                  "reproduced", "reproduced"]
    assert cl[1][4] == pytest.approx(0.5) and cl[5][4] == pytest.approx([100.0, 1.0])
    bad = us.claims(_claim_metrics(rmse_r_b=3e-3, max_abs_hdot=11.0, map_containment=False,
                                   rmse_f_ekf_before_nounc=1e-3))
    assert [c[6] for c in bad][1:] == ["differs", "partly", "differs", "differs", "differs"]
    # the notes name the winners the numbers give
    notes = cl[5][7]
    assert "fastest: UIO (a)" in notes and "lowest: EKF q = s^2 dt (the UIO" in notes
    assert "Fault RMSE with noise (rad): " in notes and "-> lowest: UIO (b). Spurious" in notes
    assert "noise-free, (b) is slower" in cl[2][7]
    # an EKF (either rule) faster than UIO (b) makes the comparison only partly reproduced
    fast = us.claims(_claim_metrics(fault_delay_ekf_tau=0.002))
    assert fast[5][6] == "partly" and "fastest: EKF q = s^2 tau (tau = 1 s)" in fast[5][7]
    assert us.claims(_claim_metrics(fault_delay_ekf=0.02))[5][6] == "partly"
    tie = us.claims(_claim_metrics(fault_delay_a=0.025, fault_delay_ekf_tau=np.nan))
    assert tie[5][6] == "reproduced" and "fastest: tie: UIO (b) = UIO (a)" in tie[5][7]
    assert "noise-free, (b) is as fast" in tie[2][7]
    rep = Report("06_test", tmp_path)
    us.record(rep, {"x": (1.5, "m/s", "note")}, claims=cl)
    assert rep.metrics["x"] == {"value": 1.5, "unit": "m/s", "note": "note"}
    assert len(rep.claims) == 6 and rep.claims[5].figure == "fault_uio_vs_ekf"


def _n_axes(fig):
    assert isinstance(fig, Figure)
    n = len(fig.axes)
    plt.close(fig)
    return n


def test_figures_axes(case, ekf):
    model, sim = case["model"], case["sim"]
    assert _n_axes(us.fig_fuzzy_fit(model)) == 2
    assert _n_axes(us.fig_steering(sim["sc"])) == 1
    for k in range(3):
        assert _n_axes(us.fig_estimate(sim, k)) == 3
    fig = us.fig_fault_vs_ekf(sim, ekf)
    assert len(fig.axes[0].get_lines()) == 5                # truth, (b), (a), 2 EKFs
    assert _n_axes(fig) == 3
    assert _n_axes(us.fig_membership_derivatives(sim["sc"])) == 1
    fm = {"alpha": np.array([0.0, 15.0]), "phi": np.array([0.0, 10.0]),
          "gamma_a": np.array([0.4, 0.6]), "gamma_b": np.array([[0.38, 0.4], [0.5, 0.6]]),
          "feasible_a": np.array([[True, True], [False, False]]),
          "feasible_b": np.array([[True, True], [True, False]])}
    fm["ratio"] = fm["gamma_b"] / fm["gamma_a"][:, None]
    assert _n_axes(us.fig_feasibility_map(fm)) == 3          # two panels + colorbar
