"""Experiments and figures of notebook 03 (``interval_study``) on short horizons: each
experiment against a known answer or an independent computation, each figure's axes."""

from __future__ import annotations

import math
from types import SimpleNamespace

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.figure import Figure
from vehicle_observers.data.scenarios import NOISE_STD, emulated_satory
from vehicle_observers.models import uncertain_bicycle as ub
from vehicle_observers.observers import interval as iv
from vehicle_observers_papers.ifqir_2017 import constants as IF
from vehicle_observers_papers.ifqir_2017 import interval_observer as ist
from vehicle_observers_papers.ifqir_2017 import printed_observer as pob

T_SHORT = 10.0   # s of the emulated run used here (the notebook: 40 s quick, full lap)


@pytest.fixture(scope="module")
def ds():
    return ist.design_study(seed=0, quick=True)


@pytest.fixture(scope="module")
def log():
    return emulated_satory(seed=0, quick=True).segment(0.0, T_SHORT)


@pytest.fixture(scope="module")
def lpv(log, ds):
    return ist.lpv_experiment(log, ds["des"], ds["des1"], seed=0)


@pytest.fixture(scope="module")
def nl(log, ds):
    return ist.nonlinear_experiment(log, ds["des"], ds["des1"])


@pytest.fixture(scope="module")
def revs():
    return ist.revs_experiment(quick=True, span=30.0)


def _values(d):
    return {k: v[0] for k, v in d["metrics"].items()}


@pytest.fixture(scope="module")
def conv(lpv, ds):
    return ist.convergence_study(lpv, ds["des"], ds["des1"])


def test_metrics_are_value_unit_note_triples(ds, lpv, nl, revs, conv):
    for d in (ist.box_summary(), ds, ist.gain_comparison(ds["des"]), lpv, nl, revs, conv):
        for k, v in d["metrics"].items():
            assert len(v) == 3 and isinstance(v[1], str) and isinstance(v[2], str), k


def test_box_summary_against_nominal_stiffness():
    b = _values(ist.box_summary())
    np.testing.assert_allclose(b["stiffness_box_cr"], [0.9 * IF.c_r0, 1.1 * IF.c_r0])
    np.testing.assert_allclose(b["stiffness_box_cf"], [0.9 * IF.c_f0, 1.1 * IF.c_f0])
    a, c = IF.c_r0 * IF.l_r, IF.c_f0 * IF.l_f
    assert b["max_rel_unc_metzler"] == pytest.approx((a - c) / (a + c))
    # at that relative uncertainty entry (2,1) of A^- is zero (the Metzler limit)
    u = b["max_rel_unc_metzler"]
    assert (1 - u) * a - (1 + u) * c == pytest.approx(0.0, abs=1e-6 * a)


def _iss_block_max_eig(des, i, j):
    """Largest eigenvalue of the (19) block of mode i, vertex j, rebuilt with numpy from the
    design's P, W = P L, M_i, gamma_i and phi."""
    m, C = des.model, np.array([[0.0, 1.0]])
    Mi = des.solution[f"M{i}"]
    Pk = [np.diag(des.P[i, k]) for k in range(4)]
    P, W, Ap = Pk[j], Pk[j] @ des.L[i, j], m.A_hi[i, j]
    S = Ap.T @ P + P @ Ap - C.T @ W.T - W @ C + des.eps_decay * P \
        + sum(des.phi[i, k] * (Pk[k] + Mi) for k in range(4))
    blk = np.block([[S, P], [P, -des.gammas[i] * np.eye(2)]])
    return float(np.linalg.eigvalsh((blk + blk.T) / 2).max())


def test_design_study_against_independent_computations(ds):
    """The design study's numbers recomputed outside the solver: (19) rebuilt with numpy at
    every vertex is active at the optimum (min sum gamma_i: in each mode the largest
    eigenvalue sits on the imposed strictness margin -1e-2, so no gamma_i could be lowered);
    the blended check contains the vertices, so it is at least their maximum and negative;
    the Metzler margins are the off-diagonals of A^- - L C; the dwell time ln(mu)/eps with mu
    the largest ratio of diagonal P entries over adjacent modes."""
    v, des = _values(ds), ds["des"]
    np.testing.assert_array_equal(v["gamma_per_mode"], des.gammas)
    assert v["gamma"] == des.gammas.max() and v["gamma_single_mode"] == ds["des1"].gamma
    worst = np.array([[_iss_block_max_eig(des, i, j) for j in range(4)] for i in range(3)])
    np.testing.assert_allclose(worst.max(axis=1), -1e-2, rtol=1e-3)
    assert v["blended_iss_max_eig"] >= worst.max() - 1e-9 and v["blended_iss_max_eig"] < 0
    M = des.model.A_lo - des.L @ des.model.C
    np.testing.assert_allclose(v["metzler_margins"], np.minimum(M[..., 0, 1], M[..., 1, 0]))
    assert v["metzler_margin_min"] == np.min(v["metzler_margins"]) >= 0
    assert v["lmi_status"] == "certified" and v["lmi_relative_margin"] > 1e-9
    P = des.P
    mu = max(float(np.max(P[b][:, None, :] / P[a][None, :, :]))
             for i in range(P.shape[0] - 1) for a, b in ((i, i + 1), (i + 1, i)))
    assert v["dwell_time_bound"] == pytest.approx(math.log(mu) / IF.eps_decay)
    # wall clock is a timing, never a metric
    assert set(ds["timings"]) == {"solve_time", "solve_time_single"}
    assert not any("time" in k and "dwell" not in k for k in ds["metrics"])


@pytest.mark.parametrize("pol", [True, False])
def test_observer_step_numpy_equals_compiled(pol):
    des = IF.design(inv_vx_upper_first=pol)
    assert ist.observer_step_check(des, seed=1) < 1e-12
    # the check is sensitive: gains of the other polarity's vertex order break it
    wrong = iv.IntervalDesign(**{**des.__dict__, "L": des.L[:, [2, 3, 0, 1]]})
    assert ist.observer_step_check(wrong, seed=1) > 1e-6


def test_convergence_starts_known_answer():
    t = np.arange(0.0, 20.0, 0.5)
    vx = np.linspace(0.5, 17.0, len(t))
    starts = ist.convergence_starts(t, vx, IF.bands, horizon=2.0)
    mids = [(0.1 + 6) / 2, (6 + 11) / 2, (11 + 17.5) / 2]
    assert starts == [int(np.argmin(np.abs(vx - m))) for m in mids]
    # with a 6 s horizon the mode-3 mid speed is too late: the last usable sample is taken
    starts = ist.convergence_starts(t, vx, IF.bands, horizon=6.0)
    assert starts[2] == len(t) - 12 - 1 and vx[starts[2]] > 11.0
    assert ist.convergence_starts(t, np.full(len(t), 3.0), IF.bands, 2.0)[1:] == [-1, -1]


def test_convergence_study(conv, lpv, ds):
    """v_y: L cannot act on the v_y row (C = [0 1]), so the initial-box effect on the v_y
    width decays at the open-loop rate |A_11| ~ (c_f + c_r)/(m v_x) in both observers:
    equal times, ~ ln(1/frac) / |A_11(v_x(t0))|; r is much faster (output injection)."""
    ts, t1 = conv["times"]["switched"], conv["times"]["single mode"]
    # the 10 s segment reaches modes 1-2 (up to ~9 m/s), not mode 3: NaN there
    assert ts.shape == (3, 2) and np.all(np.isfinite(ts[:2])) and np.all(np.isnan(ts[2]))
    assert conv["starts"][2] == -1
    ts, t1 = ts[:2], t1[:2]
    np.testing.assert_allclose(ts[:, 0], t1[:, 0], rtol=0.05)
    veh = ds["des"].model.veh
    a11 = (veh.c_f0 + veh.c_r0) / (veh.m * np.asarray(conv["speeds"][:2]))
    np.testing.assert_allclose(ts[:, 0], np.log(1 / ist.SETTLE_FRAC) / a11, rtol=0.35)
    assert np.all(ts[:, 1] < 0.1 * ts[:, 0])
    v = _values(conv)
    assert v["conv_time_max"] == ts.max()
    # independent recomputation of one settling time from the stored curve
    tt, dev = conv["curves"]["switched"][1]
    k = np.flatnonzero(dev[:, 0] > ist.SETTLE_FRAC)[-1]
    assert ts[1, 0] == pytest.approx(tt[k + 1])


def test_gain_comparison_known_answer():
    # a "design" whose gains are the printed ones: ratio exactly 1, same shifts, printed signs
    fake = SimpleNamespace(L=IF.L_printed[..., None].copy(), P=IF.P_printed.copy(),
                           model=IF.model(), epsilon_shift=4394.0)
    gc = ist.gain_comparison(fake)
    # with epsilon = the printed gains' own 4394 1/s (4393.4 needed at mode 1, vertex 1), the
    # printed mode-1 L2 at vertices 1-2 sit on the epsilon bound (4383 + 10.4, 4381.3 + 10.4
    # 1/s >= 0.999 x 4394), no printed L1 on the Metzler bound (its smallest entry is 0.27 1/s)
    act = ist.active_constraints(fake)
    want = np.zeros((3, 4), bool)
    want[0, :2] = True
    np.testing.assert_array_equal(act["at_cap"], want)
    assert not act["at_metzler"].any()
    v = _values(gc)
    assert v["L2_at_epsilon_cap_share"] == 2 / 12 and v["L1_at_metzler_limit_share"] == 0.0
    assert v["L_log_ratio_free"] == 0.0
    assert gc["ratio_range"] == [1.0, 1.0]
    np.testing.assert_array_equal(gc["shift_designed"], gc["shift_printed"])
    np.testing.assert_allclose(gc["shift_printed"], [[-6.2345 + 11.1729, -7.7325 + 12.6483],
                                                     [-13.6983 + 19.1574, -14.0961 + 19.5678]])
    assert gc["sign_agreement"] == 1.0 and gc["sign_mismatch"] == []
    assert _values(gc)["L_log_ratio_mean"] == 0.0
    fake.L[2, 1, 1, 0] = -1.0                           # one L2 < 0 in mode 3
    gc = ist.gain_comparison(fake)
    assert gc["sign_agreement"] == 23 / 24 and gc["sign_mismatch"] == [(3, 2, 2, -1.0)]
    fake.L = 10.0 * IF.L_printed[..., None]             # mode 1 included in the range
    gc = ist.gain_comparison(fake)
    assert gc["ratio_range"] == pytest.approx([10.0, 10.0])
    assert _values(gc)["L_log_ratio_mean"] == pytest.approx(1.0)


def test_designed_sign_differences_are_allowed_by_metzler(ds):
    """The design differs from the printed signs only where the Metzler entry (1,2),
    ``A^-_12 - L1 >= 0``, allows a positive L1: mode 1, vertex 2 (1/v_max = 1/6 s/m,
    v_min = 0.1 m/s), where ``A^-_12 = (c_r l_r - c_f l_f)^- / (6 m) - 0.1 > 0``; min gamma
    pushes L1 onto that bound."""
    des = ds["des"]
    gc = ist.gain_comparison(des)
    A12 = des.model.A_lo[..., 0, 1]
    assert np.all(des.L[..., 0, 0] <= A12)
    assert [m[:3] for m in gc["sign_mismatch"]] == [(1, 2, 1)]
    veh = des.model.veh
    a12 = ((1 - veh.rel_unc) * veh.c_r0 * veh.l_r - (1 + veh.rel_unc) * veh.c_f0 * veh.l_f) \
        / (veh.m * 6.0) - 0.1
    assert A12[0, 1] == pytest.approx(a12)
    L1 = des.L[0, 1, 0, 0]
    assert gc["sign_mismatch"][0][3] == round(L1, 4) and 0 < L1 <= a12 and a12 - L1 < 0.01 * a12
    assert gc["sign_agreement"] == 23 / 24
    np.testing.assert_allclose(gc["log_ratio"], np.abs(np.log10(np.abs(des.L[..., 0])
                                                                / np.abs(IF.L_printed))))


@pytest.fixture(scope="module")
def printed():
    return ist.printed_solution_study()


def test_printed_solution_minimal_epsilon_known_answer(printed):
    """The printed mode-1 ``L2 = 4383`` sits at vertices 1-2; the diagonal (2,2) of
    ``A^- - L C`` there is ``-(c_r^+ l_r^2 + c_f^+ l_f^2) / (I_z v) - 4383`` with ``v = 6``
    (chosen polarity, 1/v_max) or ``v = 0.1`` m/s (other polarity, 1/v_min)."""
    v = IF.vehicle
    k = (1 + v.rel_unc) * (v.c_r0 * v.l_r**2 + v.c_f0 * v.l_f**2) / v.I_z
    assert printed["cert"].min_epsilon[0] == pytest.approx(k / 6.0 + 4383.0)
    assert printed["cert_other"].min_epsilon[0] == pytest.approx(k / 0.1 + 4383.0)
    assert printed["min_epsilon"] == pytest.approx(k / 6.0 + 4383.0)
    assert printed["min_epsilon"] > IF.epsilon_shift          # (20) excludes the printed L
    for c in (printed["cert"], printed["cert_other"]):
        assert c.metzler_margins.min() > 0                      # Metzler part of (20) holds
        assert c.lmi_margin >= 0.99e-2                          # (17)-(19) certified
        np.testing.assert_allclose(c.scale * IF.P_printed.min(axis=(1, 2)), 1.0)


def test_printed_solution_is_feasible_for_the_design_with_its_epsilon(printed):
    """With epsilon >= the printed gains' own shift, the rescaled printed P, W are a feasible
    point of our Theorem 2 problem, so the optimal sum of gamma_i cannot exceed theirs."""
    eps = float(np.ceil(printed["min_epsilon"]))
    des = IF.design(pob.BANDS_PRINTED, epsilon_shift=eps)      # the certificate's bands
    assert des.gammas.sum() <= printed["cert"].gammas.sum() * (1 + 1e-3)


def test_polarity_study_single_gamma_and_table(printed):
    po = ist.polarity_study(printed)
    rows = po["rows"]
    assert [(r["1/v_x upper at vertices 1-2"], r["epsilon [1/s]"]) for r in rows[:4]] == [
        (False, 1000.0), (False, float(np.ceil(printed["cert"].min_epsilon.max()))),
        (True, 1000.0), (True, float(np.ceil(printed["cert_other"].min_epsilon.max())))]
    # one shared gamma minimises the worst mode: not above the per-mode design's worst gamma
    sg = po["single_gamma"]
    assert sg.gammas.tolist() == [sg.gamma] * 3
    assert sg.gamma <= rows[0]["gamma_3"] * (1 + 1e-3)
    v = _values(po)
    assert v["log_ratio_chosen"] == rows[0]["mean |log10 L/L_pr|"]
    assert v["log_ratio_chosen"] < v["log_ratio_other"]        # the polarity choice


def test_lpv_experiment_truth_and_guarantee(lpv, log, ds):
    veh = ds["des"].model.veh
    box = veh.xi_box
    assert np.all((lpv["xi"] >= box[:, 0]) & (lpv["xi"] <= box[:, 1]))
    # truth: explicit Euler of (3)-(4) at dt, recomputed with lpv_A / lpv_B at a few samples
    X, dt = lpv["X"], log.dt
    for k in (0, 1234, len(X) - 2):
        v, xi = lpv["vx"][k], lpv["xi"][k]
        dx = ub.lpv_A(1 / v, v, xi, veh) @ X[k] + ub.lpv_B(xi, veh)[:, 0] * lpv["delta"][k]
        np.testing.assert_allclose(X[k + 1], X[k] + dt * dx, rtol=1e-9, atol=1e-12)
    v = _values(lpv)
    assert v["lpv_enclosure_vy"] == 1.0 and v["lpv_enclosure_r"] == 1.0 and lpv["enclosure"] == 1.0
    # the width ratio against an independent mean over t >= 5 s
    w = log.t >= log.t[0] + ist.WIDTH_T_SKIP
    ratio = lpv["res"].width[w, 0].mean() / lpv["res1"].width[w, 0].mean()
    assert v["lpv_width_ratio_vy"] == pytest.approx(ratio, rel=1e-12)
    assert v["euler_substeps"] == 1
    assert lpv["max_accel"] <= IF.accel_max + 1e-6


def test_effective_stiffness_share_known_answer():
    box = np.array([[9.0, 11.0], [4.0, 6.0]])            # rear [9, 11], front [4, 6] N/rad
    a = np.radians([1.0, 1.0, 1.0, 0.1, -2.0])           # sample 3: slip too small, left out
    log = SimpleNamespace(extra={"alpha_f_true_rad": a, "alpha_r_true_rad": a},
                          Ff=a * np.array([5.0, 7.0, 5.0, 5.0, 5.0]),   # front in: 0, 2, 4
                          Fr=a * np.array([10.0, 10.0, 8.0, 1.0, 12.0]))  # rear in: 0, 1
    s = ist.effective_stiffness_share(log, box)
    assert s["front"] == 0.75 and s["rear"] == 0.5 and s["share_big_slip"] == 0.8
    log.extra = {"alpha_f_true_rad": 0.1 * a, "alpha_r_true_rad": 0.1 * a}   # all < 0.5 deg
    s = ist.effective_stiffness_share(log, box)
    assert np.isnan(s["front"]) and np.isnan(s["rear"]) and s["share_big_slip"] == 0.0


def test_nonlinear_experiment(nl, log, ds):
    v = _values(nl)
    lo, hi = nl["res"].x_lo, nl["res"].x_hi
    for c, nm in enumerate(("vy", "r")):
        x = nl["truth"][:, c]
        assert v[f"nl_enclosure_{nm}"] == np.mean((lo[:, c] <= x) & (x <= hi[:, c]))
    assert v["nl_n_clipped"] == int(np.sum((log.vx < 0.1) | (log.vx > 17.5)))
    # the gyro bound is 3 sigma: without it the r interval collapses onto the gyro
    tight = ist.nonlinear_experiment(log, ds["des"], ds["des1"], n_sigma=0.0)
    assert tight["m"]["width_mean_r"] < 0.1 * nl["m"]["width_mean_r"]
    assert nl["m"]["width_mean_r"] == pytest.approx(2 * 3 * NOISE_STD["yaw_rate"], rel=0.2)


def test_enclosure_by_band_known_answer():
    t = np.arange(6.0)
    res = iv.IntervalRun(t, np.full((6, 2), 0.5), iv.STATE_NAMES, np.zeros((6, 2)),
                         np.ones((6, 2)), sigma=np.zeros(6, int))
    ref = np.array([[0.5, 0.5], [2.0, 0.5], [0.5, 0.5], [0.5, -1.0], [0.5, 0.5], [3.0, 0.5]])
    ay = np.array([1.0, -2.0, 4.0, 5.0, 7.0, -8.0])
    rows = ist.enclosure_by_band(res, ref, t, ay, t_skip=0.0)
    assert [r["share"] for r in rows] == pytest.approx([2 / 6, 2 / 6, 2 / 6])
    assert [r["enclosure_vy"] for r in rows] == [0.5, 1.0, 0.5]
    assert [r["enclosure_r"] for r in rows] == [1.0, 0.5, 1.0]
    # t_skip drops the first samples from the enclosure, not from the share
    rows = ist.enclosure_by_band(res, ref, t, ay, bands=((0, 6),), t_skip=1.5)
    assert rows == [{"lo": 0, "hi": 6, "share": 4 / 6, "enclosure_vy": 1.0, "enclosure_r": 0.5}]


def test_revs_experiment(revs):
    log = revs["log"]
    assert log.t[-1] - log.t[0] <= 30.0 + 1e-9
    v = _values(revs)
    ay = np.abs(log.extra["ay_filt_mps2"])
    for lo, hi in ist.AY_BANDS:
        assert v[f"revs_share_ay_{lo}_{hi}"] == np.mean((ay >= lo) & (ay < hi))
    assert sum(r["share"] for r in revs["by_ay"]) == pytest.approx(1.0)
    assert v["revs_gamma"] == pytest.approx(max(revs["rdes"].gammas))
    w = log.t >= log.t[0] + ist.WIDTH_T_SKIP
    assert v["revs_width_mean_vy"] == pytest.approx(revs["res"].width[w, 0].mean(), rel=1e-12)
    assert revs["t_zoom"] == log.t[0] + 20.0
    assert [k for k in v if k.startswith("revs_enclosure_vy_ay")] == [
        "revs_enclosure_vy_ay_0_3", "revs_enclosure_vy_ay_3_6", "revs_enclosure_vy_ay_6_99"]


def test_summary(lpv, nl, revs):
    s = ist.summary(lpv, nl, revs).splitlines()
    assert len(s) == 3 and s[0].startswith("emulated LPV truth: enclosure 1.000 / 1.000")
    assert f"{revs['m']['width_mean_vy']:.4f} m/s" in s[2]


@pytest.mark.parametrize("name, n_axes", [
    ("gains", 3), ("inputs_emulated", 3), ("intervals_lpv", 4), ("intervals_nonlinear", 4),
    ("widths", 2), ("inputs_revs", 3), ("intervals_revs", 2), ("intervals_revs_zoom", 2),
    ("convergence", 2), ("box_band", 2), ("assignments", 1)])
def test_figures(name, n_axes, ds, lpv, nl, revs, conv):
    make = {"gains": lambda: ist.fig_gains(ist.gain_comparison(ds["des"])),
            "convergence": lambda: ist.fig_convergence(conv),
            "inputs_emulated": lambda: ist.fig_inputs_emulated(lpv),
            "intervals_lpv": lambda: ist.fig_intervals_lpv(lpv),
            "intervals_nonlinear": lambda: ist.fig_intervals_nonlinear(nl),
            "widths": lambda: ist.fig_widths(nl),
            "inputs_revs": lambda: ist.fig_inputs_revs(revs),
            "intervals_revs": lambda: ist.fig_intervals_revs(revs),
            "intervals_revs_zoom": lambda: ist.fig_intervals_revs(revs, zoom=True),
            "assignments": lambda: ist.fig_assignments(pob.vertex_assignments()),
            "box_band": lambda: ist.fig_box_band(emulated_satory(seed=0, quick=True), IF.bands,
                                                 0.1, span=(12.0, 16.0))}[name]
    fig = make()
    try:
        assert isinstance(fig, Figure)
        assert len(fig.axes) == n_axes
    finally:
        plt.close(fig)


def test_box_band_run_widens_with_the_box_and_refuses_past_the_metzler_limit():
    """The live figure's run: enclosure 1 at any box inside the Metzler limit (the theorem's
    situation), a wider v_y band for a wider box, and no design past a_max (entry (2,1) of
    A^- negative at the corner (c_r^-, c_f^+))."""
    log = emulated_satory(seed=0, quick=True)
    span = (12.0, 18.0)                                 # the corner of the quick run
    runs = {a: ist.box_band_run(log, IF.bands, a, span=span) for a in (0.05, 0.15)}
    for b in runs.values():
        assert b["m"]["enclosure_vy"] == 1.0 and b["m"]["enclosure_r"] == 1.0
        assert b["t"][0] >= span[0] and b["t"][-1] <= span[1] + 1e-9
    assert runs[0.15]["m"]["width_mean_vy"] > 2 * runs[0.05]["m"]["width_mean_vy"]
    a, c = IF.c_r0 * IF.l_r, IF.c_f0 * IF.l_f
    past = ist.box_band_run(log, IF.bands, (a - c) / (a + c) + 0.01, span=span)
    assert past["res"] is None and past["error"]
    assert past["a_max"] == pytest.approx((a - c) / (a + c))


def test_convergence_open_loop_baseline_known_answer(ds):
    """Open loop at constant speed (10 m/s, mode 2 only) and stiffness: the model error is
    e_k = (I + dt A)^k e0 (Euler), so each state's settling time follows from the matrix
    power, computed here independently; modes 1 and 3 are not reached (NaN)."""
    veh, dt, n = IF.vehicle, 1e-3, 6000
    t = np.arange(n) * dt
    lpv = {"t": t, "dt": dt, "vx": np.full(n, 10.0), "delta": np.zeros(n),
           "xi": np.tile(veh.xi0, (n, 1)), "X": np.zeros((n, 2))}
    cv = ist.convergence_study(lpv, ds["des"], ds["des1"])
    assert cv["starts"] == [-1, 0, -1]
    A = ub.lpv_A(0.1, 10.0, veh.xi0, veh)
    k_h = int(round(ist.CONV_HORIZON / dt))
    e = np.array([np.linalg.matrix_power(np.eye(2) + dt * A, k) @ ist.BOX0[1] for k in range(k_h)])
    want = [t[np.flatnonzero(np.abs(e[:, c]) > ist.SETTLE_FRAC * abs(e[0, c]))[-1] + 1]
            for c in range(2)]
    t0 = cv["times"]["open loop"]
    np.testing.assert_allclose(t0[1], want, atol=1.5 * dt)
    assert np.isnan(t0[[0, 2]]).all()
    tt, rel = cv["curves"]["open loop"][1]
    np.testing.assert_allclose(rel, np.abs(e) / np.abs(e[0]), rtol=1e-9, atol=1e-12)


def test_convergence_study_has_the_open_loop_rows(conv):
    v = _values(conv)
    ts, t0 = np.asarray(v["conv_time"]), np.asarray(v["conv_time_open_loop"])
    assert t0.shape == ts.shape and np.isnan(t0[2]).all()        # mode 3 not reached in 10 s
    assert np.all(ts[:2, 1] < 0.1 * t0[:2, 1])                   # output injection on r
    assert v["conv_time_open_loop_max"] == np.nanmax(t0)


def test_animate_convergence_player(lpv, ds):
    """The animation is an offline HTML player with one frame per requested index (first and
    last sample of the horizon included)."""
    from IPython.display import HTML

    h = ist.animate_convergence(lpv, ds["des"], start=100, horizon=0.5, frames=3)
    assert isinstance(h, HTML)
    assert h.data.count("data:image/png;base64") == 3
    assert "font-awesome" not in h.data


def test_figures_can_show_their_claim(ds, lpv):
    """gains_vs_printed plots signed gains (the printed L1 < 0 below the zero line, so a sign
    disagreement is visible) and the margin panels of intervals_emulated_lpv are on a symlog
    axis with the zero line and the signed margins (a violation would plot below 0). Catches
    |L| on a log axis and margins clipped to a positive floor on a log axis."""
    fig = ist.fig_gains(ist.gain_comparison(ds["des"]))
    try:
        ax = fig.axes[0]
        printed = next(ln for ln in ax.get_lines() if ln.get_label() == "printed")
        np.testing.assert_allclose(printed.get_ydata(), IF.L_printed[..., 0].ravel())
        assert ax.get_yscale() == "symlog"
    finally:
        plt.close(fig)
    res = lpv["res"]
    shifted = SimpleNamespace(x_lo=res.x_lo + 1e-3, x_hi=res.x_hi + 1e-3)   # truth below x^-
    fig = ist.fig_intervals_lpv({**lpv, "res": shifted})
    try:
        b = fig.axes[1]                         # v_y margins
        assert b.get_yscale() == "symlog"
        assert any(np.all(np.asarray(ln.get_ydata(), float) == 0) for ln in b.get_lines())
        lower = next(ln for ln in b.get_lines() if "lower" in ln.get_label())
        assert np.min(lower.get_ydata()) < 0     # the planted violation is drawn below 0
    finally:
        plt.close(fig)
