"""Notebook 05 (Rabhi 2004 sliding-mode observers), quick mode: 6 s manoeuvre, 3 s roads.

Tolerances are requirements stated in the notebook (force error below 1 % of the peak
force, road error below 3 % of the profile RMS on ISO roads) or theory (reaching time
|e(0)|/lambda, ISO class PSD); the quick-mode values measured when the notebook was written
are given in the comments.
"""

import pytest
from lesson_outputs import differences, outputs

pytestmark = [pytest.mark.notebook, pytest.mark.xdist_group("nb05")]

NB = "05_sliding_mode_observers_report"
FORCES = ("Fxf", "Fxr", "Fyf", "Fyr")
SURF = ("vx", "vy", "r", "omega_f", "omega_r")


@pytest.fixture(scope="module")
def m(run_notebook):
    return run_notebook(NB)


def test_finite_time_reaching(m):
    """Every sliding surface is reached in finite time. v_x, v_y: the disturbance
    |Omega x~4| is small against lambda, so t = |e0|/lambda within 10 % (measured 1.01x,
    1.00x); r and the wheel speeds reach earlier (the force injection helps), never later."""
    for nm in ("vx", "vy"):
        assert m[f"A_t_reach_{nm}"] == pytest.approx(m[f"A_t_nominal_{nm}"], rel=0.10)
    for nm in SURF:
        assert 0 < m[f"A_t_reach_{nm}"] <= 1.1 * m[f"A_t_nominal_{nm}"]
        assert 0 < m[f"A_t_reach_sign_{nm}"] <= 1.1 * m[f"A_t_nominal_{nm}"]
        assert 0 < m[f"A_paper_t_reach_{nm}"] <= 1.1 * m[f"A_t_nominal_{nm}"]
        assert m[f"A_gain_margin_{nm}"] > 0  # (13)/(16) hold after reaching


def test_force_accuracy_and_chattering(m):
    for f in FORCES:
        assert m[f"A_sat_rmse_pct_{f}"] < 1.0      # measured 0.15-0.42 %
        assert m[f"A_lpf_rmse_pct_{f}"] < 1.0      # 0.41-0.51 %
        assert m[f"A_sign_rmse_pct_{f}"] < 5.0     # 1.6-3.2 %
        # sign switches the force injection at full amplitude every step
        assert m[f"A_sign_chatter_{f}"] > 10 * m[f"A_sat_chatter_{f}"]  # 19-55x
        assert m[f"A_sat_rmse_{f}"] < m[f"A_sign_rmse_{f}"]


def test_boundary_layer_tradeoff(m):
    """Too wide a layer costs accuracy (clean), too thin amplifies noise (noisy)."""
    assert m["A_tradeoff_clean_sat_phi_100_rmse_mean"] > 5 * m["A_tradeoff_clean_sat_phi_1_rmse_mean"]
    assert m["A_tradeoff_noisy_sat_phi_10_rmse_mean"] < m["A_tradeoff_noisy_sat_phi_1_rmse_mean"]
    assert m["A_tradeoff_noisy_sat_phi_10_rmse_mean"] < m["A_tradeoff_noisy_sign_rmse_mean"]


def test_robustness_rows_are_the_runs_they_name(m):
    """Known answers across routes: the nominal row of each robustness study is the run of
    the same configuration computed elsewhere in the notebook, bit for bit; tyre-parameter
    errors leave the random-walk EKF unchanged (it has no tyre model); adaptation absorbs the
    radius error (the F0/sigma intercepts carry it) while P = 0 cannot. The mass error's
    size is checked against the error dynamics (18)-(19) in
    tests/papers/test_nb05_sliding_mode_observers.py."""
    assert m["A_paper_robust_nominal_rmse_pct_max"] == m["A_paper_rmse_pct_max"]
    assert m["A_robust_nominal_rmse_pct_max"] == m["A_sat_rmse_pct_max"]
    assert m["A_robust_nominal_noadapt_rmse_pct_max"] == m["A_adapt_sat_none_rmse_pct_max"]
    for k in ("slip_stiffness_m20_pct", "relaxation_length_p50_pct"):
        assert m[f"A_ekf_robust_{k}_rmse_pct_max"] == m["A_ekf_robust_nominal_rmse_pct_max"]
    assert m["A_ekf_robust_nominal_rmse_pct_max"] == m["A_ekf_clean_rmse_pct_max"]
    assert m["A_robust_wheel_radius_rmse_pct_max"] < m["A_robust_wheel_radius_noadapt_rmse_pct_max"]
    assert m["A_robust_slip_rmse_pct_max"] < m["A_robust_slip_noadapt_rmse_pct_max"]


def test_ekf_baseline(m):
    """Random-walk-force EKF (filterpy, 200 Hz on block means of 10 samples, R / 10) on the same
    run and measurements as the SMO. Quick-mode values measured when written in the comments
    (full mode in the notebook)."""
    # the EKF converges (1.9 % of peak clean; noisy 21 %: the compressed quick manoeuvre has
    # small lateral peaks and rule 1's Q_F lets the noise through; a diverged filter is > 100 %)
    assert m["A_ekf_clean_rmse_pct_max"] < 5.0
    assert m["A_ekf_noisy_rmse_pct_max"] < 40.0
    # the paper's sign() observer chatters: on clean data the EKF beats it (1.9 vs 3.3 %, quick)
    assert m["A_ekf_clean_rmse_pct_max"] < m["A_smo_paper_clean_rmse_pct_max"]
    # the SMO (tyre model) wins on the lateral forces: 44 / 28 N EKF vs 7.7 / 3.6 N SMO clean
    for f in ("Fyf", "Fyr"):
        assert m[f"A_smo_sat_clean_rmse_{f}"] < 0.5 * m[f"A_ekf_clean_rmse_{f}"]
    # with noise the SMO (nominal layer) is better on every force (30/21/116/90 vs 43/32/425/330 N)
    for f in FORCES:
        assert m[f"A_smo_sat_noisy_rmse_{f}"] < m[f"A_ekf_noisy_rmse_{f}"]
    # the random-walk intensity trades lag against noise: rule 2's Q_F is T_s / t_rise =
    # 5 ms / 0.5 s = 1/100 of rule 1's; it lags on clean data (148 vs 44 N on F_yf) and is less
    # noisy (172 vs 425 N)
    assert m["A_ekf_rule2_q_ratio"] == pytest.approx(0.01, rel=1e-9)
    assert m["A_ekf_rule2_clean_rmse_Fyf"] > m["A_ekf_clean_rmse_Fyf"]
    assert m["A_ekf_rule2_noisy_rmse_Fyf"] < m["A_ekf_noisy_rmse_Fyf"]
    # a mass error maps into the inferred lateral forces for the EKF as well (3.5 vs 1.9 %)
    assert m["A_ekf_robust_m_p10_pct_rmse_pct_max"] > m["A_ekf_robust_nominal_rmse_pct_max"]
    # wall-clock numbers are timings (build/timings/), never metrics
    assert not any("us_per_step" in k or "cost_ratio" in k for k in m)


def test_sign_headline_full_theta_and_friction_step(m):
    """The paper's configuration (sign(), printed law) computed on two routes gives the same
    numbers; sign() chatters at tens of N; the friction step mu 1 -> 0.5 costs the
    non-adaptive observer about three times the adaptive one's error (30.6 vs 9.5 %)."""
    assert m["A_adapt_sign_full_rmse_pct_max"] == m["A_paper_rmse_pct_max"]
    assert m["A_adapt_sign_full_chatter_max"] == m["A_paper_chatter_max"]
    assert m["A_adapt_sign_partial_rmse_pct_max"] == m["A_sign_rmse_pct_max"]
    assert m["A_paper_chatter_max"] > 20.0
    assert m["A_mu_sign_partial_rmse_pct_max"] < 0.5 * m["A_mu_sign_none_rmse_pct_max"]
    assert m["A_mu_sat_partial_rmse_pct_max"] < 0.5 * m["A_mu_sat_none_rmse_pct_max"]


def test_paper_outputs_road_and_wheels(m):
    """Observer on the paper's outputs (29): two lost directions; road modulo the warp
    patterns 0.7-1.7 % of RMS (quick), raw 7-15 %; one deflection sensor restores them
    (1.5-2.2 % raw)."""
    for road in ("D", "belgian"):
        assert m[f"B_paper_{road}_n_unobservable"] == 2 and m[f"B_defl_{road}_n_unobservable"] == 0
        assert m[f"B_paper_{road}_U_mod_rmse_pct_mean"] < 3.0
        assert m[f"B_paper_{road}_U_rmse_pct_mean"] > 2 * m[f"B_paper_{road}_U_mod_rmse_pct_mean"]
        assert m[f"B_defl_{road}_U_rmse_pct_mean"] < 4.0
        assert m[f"B_defl_{road}_z_rmse_mm_mean"] < m[f"B_paper_{road}_z_rmse_mm_mean"]
    assert m["B_paper_x22_measured"] == 1.0


def test_layer_tradeoff_warp_and_printed_sign(m):
    """A 10x wider layer: clean data, more error (lag) and the same step-to-step change (3.04 N
    both, quick run); noisy data, less error and less chattering (64 -> 32 N, 25 -> 6.8 N).
    The warp state has zero paper outputs and two directions are lost. The flipped adaptation
    law does far worse than the printed (stabilising) one."""
    assert m["A_tradeoff_clean_sat_phi_10_rmse_mean"] > m["A_tradeoff_clean_sat_phi_1_rmse_mean"]
    assert m["A_tradeoff_clean_sat_phi_10_chatter_mean"] == pytest.approx(
        m["A_tradeoff_clean_sat_phi_1_chatter_mean"], rel=0.05)
    assert m["A_tradeoff_noisy_sat_phi_10_rmse_mean"] < 0.7 * m["A_tradeoff_noisy_sat_phi_1_rmse_mean"]
    assert m["A_tradeoff_noisy_sat_phi_10_chatter_mean"] < 0.5 * m["A_tradeoff_noisy_sat_phi_1_chatter_mean"]
    assert m["B_warp_max_output"] < 1e-9 and m["B_warp_max_x11"] == 1.0
    assert m["B_warp_n_unobservable"] == 2
    assert m["A_signflip_flipped_rmse_pct_max"] > 3 * m["A_signflip_stabilising_rmse_pct_max"]


def test_model_and_road_generator(m):
    f = [m[f"B_f_mode_{i}"] for i in range(7)]
    assert all(1.0 < x < 2.0 for x in f[:3]) and all(10.0 < x < 13.0 for x in f[3:])
    assert m["B_iso_psd_ratio_C"] == pytest.approx(1.0, abs=0.1)  # 0.977


@pytest.mark.parametrize("road,limit", [("B", 3.0), ("D", 3.0), ("belgian", 4.0)])
def test_road_profile_accuracy(m, road, limit):
    """sat: measured 1.7-2.3 % (ISO), 2.2-2.6 % (Belgian block, sharper texture); sign
    chatters: at least 5x worse on average."""
    sat = [m[f"B_{road}_sat_U_rmse_pct_{i}"] for i in range(1, 5)]
    sgn = [m[f"B_{road}_sign_U_rmse_pct_{i}"] for i in range(1, 5)]
    assert max(sat) < limit
    assert sum(sgn) > 5 * sum(sat)
    for i in range(1, 5):
        assert m[f"B_{road}_sat_U_rmse_mm_{i}"] < 1.0  # mm; 0.10-0.61 mm
        assert 0 < m[f"B_{road}_sat_t_reach_z{i}"] <= m["B_t_bound_z"] + 2e-4


def test_road_robustness_and_noise(m):
    for k in ("m_u", "k_t", "c_s", "k_s", "m_s"):
        assert m[f"B_robust_{k}_U_rmse_pct_mean"] < 6.0   # 1.9-4.7 %
    assert m["B_D_sat_phi100_U_rmse_pct_mean"] > m["B_D_sat_phi10_U_rmse_pct_mean"] \
        > m["B_D_sat_phi1_U_rmse_pct_mean"]
    assert m["B_D_sat_phi2x10_noise10um_U_rmse_pct_mean"] < 0.5 * m[
        "B_D_sat_noise10um_U_rmse_pct_mean"]


def test_claims_and_figures(m):
    """The paper rows are graded on the paper's configuration: Part A on sign() with the
    printed law, Part B on the raw errors with the outputs (29); the variants are diagnostic
    rows, the EKF comparisons baseline rows; Fig. 9 (measured body rates) is not comparable."""
    doc = m["_doc"]
    claims = {c["item"]: c for c in doc["claims"]}
    paper = {k for k, c in claims.items() if c["kind"] == "paper"}
    # Fig. 7 is a photograph of the profilometer: no claim, no row
    assert paper == {"Figs. 4-5", "Fig. 6", "Sec. V robustness", "Sec. V road condition",
                     "Fig. 8", "Fig. 9", "Fig. 10"}
    assert {k for k, c in claims.items() if c["kind"] == "baseline"} == {
        "EKF baseline, Part A forces", "EKF baseline vs boundary-layer SMO (variant)"}
    for c in doc["claims"]:
        assert c["rule"] != "(hand-written verdict)", c["item"]
        assert c["kind"] == "paper" or "(variant)" in c["item"] or c["kind"] == "baseline", c["item"]
    assert claims["Fig. 6"]["value"] == m["A_paper_rmse_pct_max"]
    assert claims["Sec. V road condition"]["value"] == m["A_mu_sign_full_rmse_pct_max"]
    assert claims["Fig. 10"]["value"] == m["B_paper_belgian_U_rmse_pct_mean"]
    assert claims["Fig. 9"]["verdict"] == "not comparable"
    for c in doc["claims"]:
        if c["figure"]:
            assert (m["_dir"] / f"{c['figure']}.png").exists()
    for f in doc["files"]:
        assert (m["_dir"] / f).exists()


def test_lesson_builds_both_observers_and_leaves_the_exercises_open(run_notebook):
    """The lesson's numpy force SMO and road SMO agree with the compiled loops (printed
    differences: the force observer to 1e-6 N against forces of kN, the road to 1e-6 mm), and
    its four exercise stubs say 'not attempted' (no solution runs in the lesson). Catches a
    lesson observer that drifts from the library's equations and a solution left in a lesson."""
    text, status = outputs(run_notebook("05_sliding_mode_observers")["_executed"])
    diffs = differences(text)
    assert len(diffs) == 2 and diffs[0] < 1e-6 and diffs[1] < 1e-6
    assert status == ["not attempted"] * 4


def test_solutions_are_correct(run_notebook):
    """Every worked solution passes its checker."""
    _, status = outputs(run_notebook("05_sliding_mode_observers_solutions")["_executed"])
    assert status == ["correct"] * 4
