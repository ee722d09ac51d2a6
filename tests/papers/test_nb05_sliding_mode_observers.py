"""rabhi_study (notebook 05 experiments and figures) on short horizons: 3 s manoeuvre, 1.5 s
roads. Each experiment is checked against an independent computation or a known answer;
each figure function for its number of axes. The full-length numbers are checked by
tests/test_notebook_05.py."""

import matplotlib.pyplot as plt  # the Agg backend is set by conftest.py
import numpy as np
import pytest
from vehicle_observers.models import fullcar
from vehicle_observers.papers import nb05_sliding_mode_observers as rs
from vehicle_observers.papers import rabhi2004 as R

T_A = 3.0   # s; metrics are taken after t_skip = 1 s
T_B = 1.5
FORCES = R.FORCE_NAMES


def _rmse_after(t, est, ref, t_skip=1.0):
    m = np.asarray(t) >= t_skip
    return float(np.sqrt(np.mean((np.asarray(est)[m] - np.asarray(ref)[m]) ** 2)))


@pytest.fixture(scope="module")
def truth():
    return R.part_a_truth(T_A)


@pytest.fixture(scope="module")
def A(truth):
    return rs.force_modes(*truth)


@pytest.fixture(scope="module")
def ek(truth, A):
    return rs.ekf_study(*truth, A["sat"], seed=0)


@pytest.fixture(scope="module")
def rob(truth):
    cases = [c for c in rs.ROBUST_CASES_A if c[1] in ("nominal", "wheel_radius", "m")]
    return rs.robustness_study(*truth, cases=cases)


@pytest.fixture(scope="module")
def Bres():
    return rs.road_runs(T_B, seed=0)


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


# ------------------------------------------------------------------ Part A ---------------
def test_force_modes_rmse_matches_independent_computation(truth, A):
    man, Xs = truth
    assert list(A) == ["sign", "sat", "lpf"]
    for mode, o in A.items():
        for i, nm in enumerate(FORCES):
            ref = _rmse_after(man.t, o["res"].x4[:, i], Xs[:, 8 + i])
            assert o[f"rmse_{nm}"] == pytest.approx(ref, rel=1e-12), (mode, nm)
            assert o[f"peak_{nm}"] == pytest.approx(np.abs(Xs[:, 8 + i]).max())
    # sign switches the force injection at full amplitude every step: more chattering than sat
    for nm in FORCES:
        assert A["sign"][f"chatter_{nm}"] > 5 * A["sat"][f"chatter_{nm}"]


def test_force_metrics_known_answers(A):
    d = rs.force_metrics(A)
    assert len(d) == 4 * 5 + 3 * 3 * 4 + 4
    assert all(len(v) == 3 for v in d.values())
    # |e(0)| / lambda with the printed initial errors: v_x 1 m/s / 4 m/s^2, wheels 5 / 500
    assert d["A_t_nominal_vx"][0] == pytest.approx(R.x2_err0[0] / R.force_gains.lam2[0])
    assert d["A_t_nominal_omega_f"][0] == pytest.approx(0.01)
    assert d["A_t_reach_sign_r"][0] == A["sign"]["t_reach_r"]
    assert d["A_lpf_rmse_pct_Fyr"] == (A["lpf"]["rmse_pct_Fyr"], "% of peak", "")
    assert list(d)[-1] == "A_peak_Fyr"


def test_tradeoff_study_rows_and_seed(truth, A):
    rows = rs.tradeoff_study(*truth, seed=0, scales=(1, 100))
    assert [(r["meas"], r["key"]) for r in rows] == [
        (m, k) for m in ("clean", "noisy") for k in ("sign", "lpf", "sat_phi_1", "sat_phi_100")]
    # scale 1 is the nominal sat observer, built through another path
    sat1 = rows[2]
    assert sat1["rmse"] == pytest.approx([A["sat"][f"rmse_{n}"] for n in FORCES], rel=1e-12)
    assert sat1["rmse_mean"] == pytest.approx(np.mean(sat1["rmse"]))
    # a 100x wider layer is a low-gain linear observer: lag, larger error on clean data
    assert rows[3]["rmse_mean"] > 2 * sat1["rmse_mean"]
    # the noise is drawn from the seed: clean rows do not depend on it, noisy rows do
    other = rs.tradeoff_study(*truth, seed=1, scales=(1,))
    assert other[2]["rmse_mean"] == sat1["rmse_mean"]
    assert other[5]["rmse_mean"] != rows[6]["rmse_mean"]
    m = rs.tradeoff_metrics(rows)
    assert m["A_tradeoff_noisy_sat_phi_100_chatter_mean"] == (rows[7]["chatter_mean"], "N",
                                                              "mean step-to-step std")
    assert len(rs.tradeoff_table(rows).splitlines()) == 1 + len(rows)


def test_robustness_study(A, rob):
    nominal, mass, radius = rob
    assert nominal["adaptive"] == pytest.approx([A["sat"][f"rmse_pct_{n}"] for n in FORCES], rel=1e-12)
    # a 2 % radius error: the slip velocity r w - v_x is of the order of the error; the
    # adaptation of F0/sigma absorbs it, the P = 0 observer does not
    assert max(radius["noadapt"]) > 5 * max(radius["adaptive"])
    # mass error: lateral forces recovered from m a_y carry the 10 % scale error
    assert max(mass["adaptive"]) > max(nominal["adaptive"])
    m = rs.robustness_metrics(rob)
    assert m["A_robust_wheel_radius_noadapt_rmse_pct_max"] == (
        max(radius["noadapt"]), "% of peak", "wheel radius +2 %, P = 0")
    assert len(m) == 2 * len(rob)


def test_ekf_study_and_metrics(truth, A, ek):
    man, Xs = truth
    assert ek["S"]["clean"] is A["sat"]
    E = ek["E"]["clean"]
    res = E["res"]
    dec = rs.EKF_DEC
    nb = len(man.t) // dec
    assert len(res.t) == nb and res.dec == dec
    # the EKF sees every SMO measurement: the same noisy array, averaged over blocks of dec
    Yn = ek["S"]["noisy"]["Y"]
    assert np.array_equal(ek["E"]["noisy"]["Y"], Yn) and np.array_equal(ek["E2"]["noisy"]["Y"], Yn)
    assert np.allclose(ek["E"]["noisy"]["res"].z, Yn[:nb * dec].reshape(nb, dec, 5).mean(axis=1),
                       rtol=1e-14, atol=1e-12)
    assert np.diag(res.R) == pytest.approx(np.array(R.sensor_noise) ** 2 / dec, rel=1e-12)
    F_blk = Xs[:nb * dec, 8:12].reshape(nb, dec, 4).mean(axis=1)
    for i, nm in enumerate(FORCES):
        ref = _rmse_after(res.t, res.F[:, i], F_blk[:, i])
        assert E[f"rmse_{nm}"] == pytest.approx(ref, rel=1e-12)
    # rule 2: Q_F = (F_max / t_rise)^2 T_s = F_max^2 / t_rise * (T_s / t_rise), T_s = 10 x 0.5 ms,
    # t_rise = 0.5 s: 1/100 of rule 1 (known answer), and a different filter
    assert ek["q_ratio"] == pytest.approx(dec * R.dt_force / 0.5, rel=1e-12)
    assert ek["q_ratio"] == pytest.approx(0.01, rel=1e-9)
    assert ek["E2"]["clean"]["rmse_Fyf"] != E["rmse_Fyf"]
    # the EKF converges and tracks: a diverged filter is far above 100 % of peak, the zero
    # estimate scores RMSE = RMS of the force; measured 1.7-5.7 % of peak and 0.05-0.13 RMS
    assert max(E[f"rmse_pct_{n}"] for n in FORCES) < 10.0
    m = man.t >= 1.0
    for i, nm in enumerate(FORCES):
        assert E[f"rmse_{nm}"] < 0.25 * np.sqrt(np.mean(Xs[m, 8 + i] ** 2)), nm
    us = rs.smo_us_per_step(man, A["sat"], repeat=1)
    assert 0 < us < 1e4
    m = rs.ekf_metrics(ek, us)
    # per second of driving = per step x steps per second, the rates read off the time grids
    steps_ekf, steps_smo = 1 / (res.t[1] - res.t[0]), 1 / (man.t[1] - man.t[0])
    assert m["A_ekf_smo_cost_ratio_per_second"][0] == pytest.approx(
        E["us_per_step"] * steps_ekf / (us * steps_smo), rel=1e-9)
    assert m["A_ekf_us_per_step"][2].endswith("200 Hz") and "2 kHz" in m["A_smo_us_per_step"][2]
    assert m["A_ekf_rule2_q_ratio"][0] == ek["q_ratio"]
    assert m["A_smo_sat_noisy_phi10_rmse_pct_max"][0] == max(
        ek["S"]["noisy_phi10"][f"rmse_pct_{n}"] for n in FORCES)
    assert len(m) == 2 * (4 * 4 + 2) + 1 + 5
    assert "(2 kHz), EKF" in rs.ekf_table(ek, us) and "(200 Hz)" in rs.ekf_table(ek, us)
    c = rs.ekf_claim(ek)
    ratio = max(E[f"rmse_pct_{n}"] for n in FORCES) / max(A["sat"][f"rmse_pct_{n}"] for n in FORCES)
    assert c["value"] == pytest.approx(ratio)
    assert c["figure"] == "figA_ekf_forces"
    # the note follows the numbers: every force is named on the side of its smaller RMSE
    for case in ("clean", "noisy"):
        part = c["note"].split(f"{case}: ")[1].split(";")[0]
        smo_side, ekf_side = part.split("EKF better or equal on")
        for n in FORCES:
            smo_wins = ek["S"][case][f"rmse_{n}"] < ek["E"][case][f"rmse_{n}"]
            assert (n in smo_side.split("(")[0]) == smo_wins and (n in ekf_side.split("(")[0]) != smo_wins


def test_ekf_rates_follow_dec(truth, A):
    """A different block length changes the rates, the rule-2 ratio and the notes with it."""
    man, Xs = truth
    ek5 = rs.ekf_study(man, Xs, A["sat"], seed=0, dec=5)
    assert ek5["q_ratio"] == pytest.approx(5 * R.dt_force / 0.5, rel=1e-12)
    m = rs.ekf_metrics(ek5, 1.0)
    assert m["A_ekf_smo_cost_ratio_per_second"][0] == pytest.approx(
        ek5["E"]["clean"]["us_per_step"] / 5, rel=1e-9)
    assert m["A_ekf_us_per_step"][2].endswith("400 Hz")
    assert "400 Hz on block means of 5 samples (R / 5)" in rs.ekf_claim(ek5)["note"]
    assert "us (400 Hz)" in rs.ekf_table(ek5, 1.0)


def test_ekf_robustness_reuses_nominal_for_tyre_parameters(truth, ek, rob):
    cases = [c for c in rs.ROBUST_CASES_A if c[1] in ("nominal", "slip", "m")]
    rows = rs.ekf_robustness(*truth, ek, seed=0, cases=cases)
    nominal = max(ek["E"]["clean"][f"rmse_pct_{n}"] for n in FORCES)
    assert [r["metric"] for r in rows] == ["A_ekf_robust_nominal_rmse_pct_max",
                                           "A_ekf_robust_m_p10_pct_rmse_pct_max",
                                           "A_ekf_robust_slip_stiffness_m20_pct_rmse_pct_max"]
    assert rows[0]["value"] == rows[2]["value"] == nominal
    assert rows[1]["value"] != nominal    # the mass is in the EKF model
    m = rs.row_metrics(rows)
    assert m["A_ekf_robust_m_p10_pct_rmse_pct_max"] == (rows[1]["value"], "% of peak",
                                                        "m +10 %, EKF rule 1")
    assert len(rs.ekf_robustness_table(rows, rob).splitlines()) == 3


# ------------------------------------------------------------------ Part B ---------------
def test_road_psd_check_and_model_metrics():
    psd = rs.road_psd_check(seed=0, length=500.0)
    assert psd["ratio"] == pytest.approx(1.0, abs=0.1)   # generated track follows its class
    m = rs.model_metrics(psd)
    f = fullcar.modal_summary(R.fullcar)["f_undamped_hz"]
    assert [m[f"B_f_mode_{i}"][0] for i in range(7)] == list(f)
    # the four highest modes are the wheel-hop modes, near sqrt((k_s + k_t) / m_u) / 2 pi
    p = R.fullcar
    hop = np.sort(np.sqrt((np.array(p.k_s) + np.array(p.k_t)) / np.array(p.m_u)) / (2 * np.pi))
    assert f[3:] == pytest.approx(hop, rel=0.05)
    assert m["B_iso_psd_ratio_C"][0] == psd["ratio"]


def test_road_runs_and_metrics(Bres):
    assert set(Bres) == {(r, m) for r in rs.ROADS for m in ("sign", "sat")}
    o = Bres[("D", "sat")]
    for i in range(4):
        ref = _rmse_after(o["t"], o["res"].U[:, i], o["U"][:, i])
        assert o[f"U_rmse_mm_{i + 1}"] == pytest.approx(1e3 * ref, rel=1e-12)
    d = rs.road_metrics(Bres)
    assert d["B_t_bound_z"] == (5e-3 / R.road_gains.h11, "s", "|e(0)|/H11")
    assert d["B_D_sat_U_rmse_pct_4"] == (o["U_rmse_pct_4"], "% of profile RMS", fullcar.WHEELS[3])
    assert len(d) == 6 * (3 * 4 + 2) + 3 + 1
    assert len(rs.road_table(Bres).splitlines()) == 6


def test_road_sweep_and_robustness(Bres):
    rows = rs.road_sweep(T_B, seed=0, scales=(1, 100), noises=(1e-4,))
    assert [r["metric"] for r in rows] == [
        "B_D_sat_phi1_U_rmse_pct_mean", "B_D_sat_phi100_U_rmse_pct_mean",
        "B_D_sign_noise100um_U_rmse_pct_mean", "B_D_sat_noise100um_U_rmse_pct_mean",
        "B_D_sat_phi2x10_noise100um_U_rmse_pct_mean"]
    assert rows[0]["value"] == pytest.approx(Bres[("D", "sat")]["U_rmse_pct_mean"], rel=1e-12)
    assert rows[1]["value"] > rows[0]["value"]          # wider layer: lag
    assert rows[3]["value"] > rows[0]["value"]          # noise costs accuracy
    assert rows[4]["value"] < rows[3]["value"]          # wider stage-2 layer filters it
    robB = rs.road_robustness(T_B, seed=0, cases=rs.ROBUST_CASES_B[:2])
    assert robB[0]["value"] == rows[0]["value"]
    assert robB[1]["value"] != robB[0]["value"]
    m = rs.row_metrics(rows + robB)
    assert m["B_robust_m_u_U_rmse_pct_mean"] == (robB[1]["value"], "% of profile RMS", "m_u +10 %")
    assert m["B_D_sat_phi1_U_rmse_pct_mean"][1:] == ("%", "")
    assert len(rs.sweep_table(rows + robB).splitlines()) == 7


def test_paper_claims(A, Bres):
    claims = rs.paper_claims(A["sat"], Bres, robust_slip=0.5)
    assert [c["item"] for c in claims] == ["Figs. 4-5", "Fig. 6", "Sec. V robustness", "Fig. 8",
                                           "Fig. 9", "Fig. 10", "Fig. 7"]
    assert claims[1]["value"] == max(A["sat"][f"rmse_pct_{n}"] for n in FORCES)
    assert claims[2]["value"] == 0.5
    assert claims[5]["value"] == Bres[("belgian", "sat")]["U_rmse_pct_mean"]
    assert all(c["paper"] == "Rabhi 2004" for c in claims)


# ------------------------------------------------------------------ figures --------------
def test_part_a_figures(truth, A, ek, rob):
    man, Xs = truth
    a = A["sat"]
    rows = rs.tradeoff_study(man, Xs, seed=0, scales=(1,))
    for fig, n in [(rs.fig_velocities(man, Xs, a), 4), (rs.fig_wheel_speeds(man, Xs, a), 3),
                   (rs.fig_forces(man, Xs, a), 4), (rs.fig_chattering(man, Xs, A, rows), 2),
                   (rs.fig_robustness(rob), 1), (rs.fig_ekf_forces(man, Xs, ek), 8)]:
        assert isinstance(fig, plt.Figure)
        assert len(fig.axes) == n


def test_part_b_figures(Bres):
    psd = rs.road_psd_check(seed=0, length=300.0)
    for fig, n in [(rs.fig_road_psd(psd), 1), (rs.fig_wheels(Bres), 4),
                   (rs.fig_body_rates(Bres), 3), (rs.fig_road_profile(Bres), 6),
                   (rs.fig_road_profile(Bres, roads=("D",)), 2)]:
        assert isinstance(fig, plt.Figure)
        assert len(fig.axes) == n
