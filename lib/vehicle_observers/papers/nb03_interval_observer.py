"""Experiments and figures of notebook 03 (Ifqir 2017, switched TS interval observer).

Each function runs one experiment of the notebook and returns a plain dict (arrays, the
:class:`~vehicle_observers.observers.interval.IntervalResult` objects and a ``"metrics"`` entry
``{name: (value, unit, note)}`` in the order the notebook records them with
``rep.metric(name, *v)``), and each ``fig_*`` function returns a matplotlib Figure, so the
notebook stays a few lines per cell. Equations, the reconstruction of observer (11) and of
Theorem 2: see :mod:`vehicle_observers.observers.interval`; printed constants:
:mod:`vehicle_observers.papers.ifqir2017`.

State ``x = [v_y (m/s), r (rad/s)]``; every ``(N, 2)`` array below has these two columns.
"""

from __future__ import annotations

import numpy as np

from vehicle_observers.data.logs import DriveLog, despike, load_revs
from vehicle_observers.data.scenarios import NOISE_STD
from vehicle_observers.observers import interval as iv
from vehicle_observers.papers import ifqir2017 as IF

#: initial box ``(x0_lo, x0_hi)`` of ``[v_y, r]`` [m/s, rad/s] on the emulated run
BOX0 = ([-0.5, -0.1], [0.5, 0.1])
#: initial box on the Revs log (higher speeds, larger initial uncertainty)
REVS_BOX0 = ([-2.0, -0.6], [2.0, 0.6])
#: widths are averaged after this time [s] (the initial box has decayed)
WIDTH_T_SKIP = 5.0
#: stiffness correlation time of the random LPV truth [s]
CORR_TIME = 2.0
#: measurement bounds of the emulated run, in standard deviations of the sensor noise
N_SIGMA = 3.0
#: slip angles below this [deg] are left out of the effective-stiffness share (F/alpha)
MIN_SLIP_DEG = 0.5
#: |a_y| bands [m/s^2] of the real-log enclosure table
AY_BANDS = ((0, 3), (3, 6), (6, 99))
#: Revs log: steering despike threshold [rad], quick-mode span [s], enclosure skip [s]
REVS_DESPIKE = 0.05
REVS_QUICK_SPAN = 150.0
REVS_T_SKIP = 2.0


def _ratio(a: dict, b: dict, key: str) -> float:
    """``a[key] / b[key]`` (switched / single-mode width)."""
    return a[key] / b[key]


# ------------------------------------------------------------------ section 1 --------------
def box_summary(veh: iv.UncertainBicycle | None = None, model: iv.SwitchedIntervalModel | None = None
                ) -> dict:
    """Assumption 3 bounds of section 1: stiffness box ``[[c_r^-, c_r^+], [c_f^-, c_f^+]]``
    [N/rad], the largest relative uncertainty keeping entry (2,1) of ``A - LC`` >= 0, and a
    text with ``A^{-}, A^{+}`` of mode 3, vertex 1 and ``B^{-}, B^{+}`` of (5)-(7)."""
    veh = veh or IF.vehicle
    model = model or IF.model()
    box, mu = veh.xi_box, veh.max_metzler_uncertainty()
    text = "\n".join([
        f"{veh.name}\nstiffness box [N/rad]: c_r {box[0]}  c_f {box[1]}",
        f"largest relative uncertainty keeping (2,1) >= 0: {round(mu, 4)}",
        f"mode 3, vertex 1 (1/v_x = 1/11, v_x = 17.5): A^- =\n{model.A_lo[2, 0]}\n"
        f"A^+ =\n{model.A_hi[2, 0]}",
        f"B^- = {model.B_lo.ravel()}  B^+ = {model.B_hi.ravel()}"])
    return {"text": text, "metrics": {"stiffness_box_cr": (box[0], "N/rad", ""),
                                      "stiffness_box_cf": (box[1], "N/rad", ""),
                                      "max_rel_unc_metzler": (mu, "", "")}}


# ------------------------------------------------------------------ section 2 --------------
def design_study(seed: int = 0, quick: bool = False) -> dict:
    """Theorem 2 (17)-(21) for the switched bands (22) and for one band (non-switched), both
    certified; the a-posteriori blended check of (19) (:func:`interval.blended_iss_margin`,
    300 random weights per mode in quick mode, else 3000, drawn from ``seed``) and the
    average dwell time (:func:`interval.dwell_time_bound`). Returns ``des``, ``des1``
    (:class:`~vehicle_observers.observers.interval.IntervalDesign`), ``blended`` (max eigenvalue,
    < 0 is good), ``dwell`` (dict), ``text`` and ``metrics`` (gamma per mode (K,), margins
    [1/s], solve times [s], dwell time [s])."""
    des, des1 = IF.design(), IF.design(IF.bands_single)
    bl = iv.blended_iss_margin(des, n=300 if quick else 3000, seed=seed)
    dw = iv.dwell_time_bound(des)
    lines = [des.solution.summary().splitlines()[0]]
    for nm, d in (("switched", des), ("single", des1)):
        lines.append(f"{nm:9s} gamma_i = {np.round(d.gammas, 4)}, LMI margin {d.lmi_margin:.2e} "
                     f"(relative {d.lmi_relative_margin:.1e}), min Metzler margin "
                     f"{d.min_metzler_margin:.2e} 1/s, solve {d.solve_time:.2f} s, "
                     f"ISS gain {d.iss_gain:.3f}")
    lines.append(f"(19) with blended P(h), L(h) at random frozen h (cross terms included): "
                 f"max eigenvalue {bl:.3e}")
    lines.append(f"switching: mu = {round(dw['mu'], 3)} -> average dwell time for the switched "
                 f"ISS argument: {round(dw['dwell_time_s'], 3)} s")
    metrics = {
        "blended_iss_max_eig": (bl, "", "< 0: (15) holds at frozen blended weights"),
        "gamma": (des.gamma, "", "max over modes of gamma_i"),
        "gamma_per_mode": (des.gammas, "", ""),
        "gamma_single_mode": (des1.gamma, "", ""),
        "lmi_margin": (des.lmi_margin, "", "min eigenvalue margin of (17)-(19), absolute"),
        "lmi_relative_margin": (des.lmi_relative_margin, "", ""),
        "metzler_margin_min": (des.min_metzler_margin, "1/s", ""),
        "metzler_margins": (des.metzler_margins, "1/s", ""),
        "solve_time": (des.solve_time, "s", ""),
        "solve_time_single": (des1.solve_time, "s", ""),
        "dwell_time_bound": (dw["dwell_time_s"], "s", ""),
    }
    return {"des": des, "des1": des1, "blended": bl, "dwell": dw, "text": "\n".join(lines),
            "metrics": metrics}


def gain_comparison(des: iv.IntervalDesign, L_printed=None, P_printed=None) -> dict:
    """Designed ``L_i^j``, ``P_i^j`` next to the slides' printed solution (defaults:
    :data:`papers.ifqir2017.L_printed` (3, 4, 2), ``P_printed`` (3, 4, 2)).

    ``L = [L1, L2]`` with ``L1`` [m/s] (v_y row) and ``L2`` [1/s] (r row).
    ``shift_designed`` / ``shift_printed`` (2, 2): shift of ``L1`` [m/s] from the ``v_max``
    to the ``v_min`` vertex (vertices 1->2 and 3->4) in modes 2-3;
    ``ratio_range`` [min, max] of ``|L| designed / printed`` over modes 2-3; ``sign_ok``:
    ``L1 < 0`` and ``L2 > 0`` at every vertex of modes 2-3 (the printed signs).
    """
    Lp = IF.L_printed if L_printed is None else np.asarray(L_printed)
    Pp = IF.P_printed if P_printed is None else np.asarray(P_printed)
    shift_des = des.L[1:, [1, 3], 0, 0] - des.L[1:, [0, 2], 0, 0]
    shift_pr = Lp[1:, [1, 3], 0] - Lp[1:, [0, 2], 0]
    sign_ok = bool(np.all(des.L[1:, :, 0, 0] < 0) and np.all(des.L[1:, :, 1, 0] > 0))
    ratio = [float(np.min(np.abs(des.L[1:, ..., 0]) / np.abs(Lp[1:]))),
             float(np.max(np.abs(des.L[1:, ..., 0]) / np.abs(Lp[1:])))]
    text = "\n".join([
        f"designed L_i^j (rows: mode; [L1, L2] per vertex):\n{des.L[..., 0]}",
        f"printed  L_i^j:\n{Lp}", f"designed diag P_i^j:\n{des.P}", f"printed  diag P_i^j:\n{Pp}",
        f"L1 shift v_max -> v_min vertex, modes 2-3: designed {shift_des.ravel()}  printed "
        f"{shift_pr.ravel()}"])
    metrics = {"L_designed": (des.L[..., 0], "", ""), "P_designed": (des.P, "", ""),
               "L1_shift_designed": (shift_des, "", ""), "L1_shift_printed": (shift_pr, "", "")}
    return {"des": des, "L_printed": Lp, "P_printed": Pp, "shift_designed": shift_des,
            "shift_printed": shift_pr, "sign_ok": sign_ok, "ratio_range": ratio, "text": text,
            "metrics": metrics}


# ------------------------------------------------------------------ section 3 --------------
def lpv_experiment(log: DriveLog, des: iv.IntervalDesign, des1: iv.IntervalDesign,
                   seed: int = 0, box0=BOX0) -> dict:
    """Section 3: the theorem's situation. Truth = the LPV model (3)-(4) driven by the true
    steering and speed of the emulated ``log`` (``extra`` columns ``vx_true_mps``,
    ``delta_true_rad``), with a seeded random stiffness trajectory inside the box
    (:func:`interval.random_stiffness_trajectory`, correlation time :data:`CORR_TIME`),
    discretised like the observer (Euler at ``log.dt``). The switched (``des``) and
    single-mode (``des1``) observers see the exact steering and the true yaw rate.

    Returns ``t`` (N,) [s], ``vx`` [m/s], ``delta`` [rad], ``xi`` (N, 2) ``[c_r, c_f]``
    [N/rad], ``X`` (N, 2) truth, ``res``/``res1`` results, ``m``/``m1``
    (:func:`interval.interval_metrics`, widths after :data:`WIDTH_T_SKIP`), ``enclosure``
    (min over v_y and r; 1.0 is the theorem), ``max_accel`` [m/s^2] (max ``|dv_x/dt|``
    of the run, to compare with the ``phi`` assumption), ``bands``, ``text``, ``metrics``.
    """
    t, dt = log.t, log.dt
    vx, d = log.extra["vx_true_mps"], log.extra["delta_true_rad"]
    xi = iv.random_stiffness_trajectory(des.model.veh, len(t), dt, seed=seed,
                                        corr_time=CORR_TIME)
    X = iv.simulate_lpv(des.model.veh, [0.0, 0.0], d, vx, xi, dt)
    res = iv.run_interval_observer(des, dt, vx, d, d, X[:, 1], *box0)
    res1 = iv.run_interval_observer(des1, dt, vx, d, d, X[:, 1], *box0)
    m = iv.interval_metrics(res, X, t, width_t_skip=WIDTH_T_SKIP)
    m1 = iv.interval_metrics(res1, X, t, width_t_skip=WIDTH_T_SKIP)
    acc = np.abs(np.diff(vx)).max() / dt
    metrics = {f"lpv_{k}": (v, "", "") for k, v in m.items()}
    for k in ("width_mean_vy", "width_mean_r"):
        metrics[f"lpv_single_{k}"] = (m1[k], "", "")
    for c in ("vy", "r"):
        metrics[f"lpv_width_ratio_{c}"] = (_ratio(m, m1, f"width_mean_{c}"), "",
                                           "switched / single")
    metrics["euler_substeps"] = (res.substeps, "", "")
    text = (f"max |dv_x/dt| of the run: {acc} m/s^2 (phi assumes {IF.accel_max})"
            f"\nswitched: {m}\nsingle:   {m1}")
    return {"t": t, "vx": vx, "delta": d, "xi": xi, "X": X, "res": res, "res1": res1, "m": m,
            "m1": m1, "enclosure": min(m["enclosure_vy"], m["enclosure_r"]), "max_accel": acc,
            "bands": des.model.bands, "text": text, "metrics": metrics}


# ------------------------------------------------------------------ section 4 --------------
def effective_stiffness_share(log: DriveLog, xi_box, min_slip_deg: float = MIN_SLIP_DEG) -> dict:
    """Share of samples whose effective (secant) axle stiffness ``F / alpha`` [N/rad] lies in
    the box ``xi_box`` ((2, 2) ``[[c_r^-, c_r^+], [c_f^-, c_f^+]]``), over the samples where
    both true slip angles (``extra`` ``alpha_f_true_rad``, ``alpha_r_true_rad``) exceed
    ``min_slip_deg`` in magnitude. Returns ``front``, ``rear`` (NaN when no sample qualifies)
    and ``share_big_slip`` (share of samples used)."""
    af, ar = log.extra["alpha_f_true_rad"], log.extra["alpha_r_true_rad"]
    big = (np.abs(af) > np.radians(min_slip_deg)) & (np.abs(ar) > np.radians(min_slip_deg))
    if not big.any():                  # e.g. a short straight segment: nothing to measure
        return {"front": float("nan"), "rear": float("nan"), "share_big_slip": 0.0}
    cf_eff, cr_eff = log.Ff / np.where(big, af, 1), log.Fr / np.where(big, ar, 1)
    return {"front": iv.share_in_box(cf_eff, *xi_box[1], mask=big),
            "rear": iv.share_in_box(cr_eff, *xi_box[0], mask=big),
            "share_big_slip": float(big.mean())}


def nonlinear_experiment(log: DriveLog, des: iv.IntervalDesign, des1: iv.IntervalDesign,
                         n_sigma: float = N_SIGMA, box0=BOX0) -> dict:
    """Section 4: the observers on the *measured* channels of the emulated ``log`` (steering
    bound ``n_sigma`` x its noise std [rad], gyro bound ``|y - r| <= n_sigma`` x its std
    [rad/s], speed clipped into the bands), truth = the nonlinear model (``log.vy``,
    ``extra["yaw_rate_true_radps"]``). Returns ``t``, ``truth`` (N, 2), ``res``/``res1``,
    ``m``/``m1`` (:func:`interval.interval_metrics`), ``stiffness``
    (:func:`effective_stiffness_share`), ``text`` and ``metrics``."""
    kw = dict(steer_noise=n_sigma * NOISE_STD["delta"], y_noise=n_sigma * NOISE_STD["yaw_rate"],
              clip_speed=True)
    res, res1 = iv.run_on_log(des, log, *box0, **kw), iv.run_on_log(des1, log, *box0, **kw)
    truth = np.column_stack([log.vy, log.extra["yaw_rate_true_radps"]])
    m = iv.interval_metrics(res, truth, log.t, width_t_skip=WIDTH_T_SKIP)
    m1 = iv.interval_metrics(res1, truth, log.t, width_t_skip=WIDTH_T_SKIP)
    st = effective_stiffness_share(log, des.model.veh.xi_box)
    metrics = {f"nl_{k}": (v, "", "") for k, v in m.items()}
    metrics["nl_single_width_mean_vy"] = (m1["width_mean_vy"], "", "")
    metrics["nl_width_ratio_vy"] = (_ratio(m, m1, "width_mean_vy"), "", "switched / single")
    metrics["nl_stiffness_in_box_front"] = (st["front"], "", "share of samples with |alpha| > "
                                            f"{MIN_SLIP_DEG} deg")
    metrics["nl_stiffness_in_box_rear"] = (st["rear"], "", "")
    metrics["nl_n_clipped"] = (res.n_clipped, "", "")
    text = (f"switched: {m}\nsingle:   {m1}\nspeed samples clipped: {res.n_clipped}\n"
            f"samples with |alpha| > {MIN_SLIP_DEG} deg: {st['share_big_slip']:.3f}; effective "
            f"stiffness F/alpha inside the box: front {st['front']:.3f}, rear {st['rear']:.3f}")
    return {"t": log.t, "truth": truth, "res": res, "res1": res1, "m": m, "m1": m1,
            "stiffness": st, "text": text, "metrics": metrics}


# ------------------------------------------------------------------ section 6 --------------
def enclosure_by_band(res: iv.IntervalResult, ref: np.ndarray, t: np.ndarray, ay: np.ndarray,
                      bands=AY_BANDS, t_skip: float = REVS_T_SKIP) -> list[dict]:
    """Enclosure of ``ref`` (N, 2) by ``res`` split by ``|a_y|`` bands [m/s^2] (``lo <= |a_y|
    < hi``), over samples after ``t_skip`` [s]. One row per band: ``lo``, ``hi``, ``share``
    (of all samples), ``enclosure_vy``, ``enclosure_r``."""
    ay = np.abs(np.asarray(ay, dtype=float))
    rows = []
    for lo, hi in bands:
        mk = (ay >= lo) & (ay < hi)
        mm = iv.interval_metrics(res, ref, t, t_skip=t_skip, mask=mk)
        rows.append({"lo": lo, "hi": hi, "share": float(mk.mean()),
                     "enclosure_vy": mm["enclosure_vy"], "enclosure_r": mm["enclosure_r"]})
    return rows


def revs_experiment(quick: bool = False, span: float | None = None) -> dict:
    """Section 6: the Revs Ferrari 250 LM log (100 Hz; first :data:`REVS_QUICK_SPAN` s in quick
    mode, or the first ``span`` s if given), steering despiked, designs
    :func:`papers.ifqir2017.revs_design` (switched, ``revs_bands``) and single-band, bounds
    ``revs_steer_noise`` [rad] and ``revs_y_noise`` [rad/s], initial box :data:`REVS_BOX0`.
    Reference = the INS ``v_y`` and the gyro. Returns ``log``, ``rdes``, ``rdes1``,
    ``ref`` (N, 2), ``res``/``res1``, ``m``/``m1`` (enclosure after :data:`REVS_T_SKIP` s,
    widths after :data:`WIDTH_T_SKIP` s), ``by_ay`` (:func:`enclosure_by_band` on the filtered
    ``|a_y|``), ``t_zoom`` (start [s] of the 60 s zoom), ``text`` and ``metrics``."""
    log = load_revs()
    if span is None and quick:
        span = REVS_QUICK_SPAN
    if span is not None:
        log = log.segment(log.t[0], log.t[0] + span)
    log.delta = despike(log.delta, REVS_DESPIKE)[0]
    rdes, rdes1 = IF.revs_design(), IF.revs_design(IF.revs_bands_single)
    kw = dict(steer_noise=IF.revs_steer_noise, y_noise=IF.revs_y_noise)
    res = iv.run_on_log(rdes, log, *REVS_BOX0, **kw)
    res1 = iv.run_on_log(rdes1, log, *REVS_BOX0, **kw)
    ref = np.column_stack([log.vy, log.yaw_rate])
    m = iv.interval_metrics(res, ref, log.t, t_skip=REVS_T_SKIP, width_t_skip=WIDTH_T_SKIP)
    m1 = iv.interval_metrics(res1, ref, log.t, t_skip=REVS_T_SKIP, width_t_skip=WIDTH_T_SKIP)
    by_ay = enclosure_by_band(res, ref, log.t, log.extra["ay_filt_mps2"])
    metrics = {f"revs_{k}": (v, "", "") for k, v in m.items()}
    metrics["revs_gamma"] = (rdes.gamma, "", "")
    for c in ("vy", "r"):
        metrics[f"revs_width_ratio_{c}"] = (_ratio(m, m1, f"width_mean_{c}"), "",
                                            "switched / single")
    lines = [f"gamma_i {np.round(rdes.gammas, 4)} single {round(rdes1.gamma, 4)} LMI margin "
             f"{rdes.lmi_margin:.1e} Metzler margin {rdes.min_metzler_margin:.1e} substeps "
             f"{res.substeps}", f"switched: {m}", f"single:   {m1}"]
    for r in by_ay:
        sfx = f"ay_{r['lo']}_{r['hi']}"
        metrics[f"revs_enclosure_vy_{sfx}"] = (r["enclosure_vy"], "", "")
        metrics[f"revs_enclosure_r_{sfx}"] = (r["enclosure_r"], "", "")
        metrics[f"revs_share_{sfx}"] = (r["share"], "", "")
        lines.append(f"|a_y| in [{r['lo']}, {r['hi']}) m/s^2: {r['share']:.2f} of samples, "
                     f"enclosure v_y {r['enclosure_vy']:.3f}, r {r['enclosure_r']:.3f}")
    return {"log": log, "rdes": rdes, "rdes1": rdes1, "ref": ref, "res": res, "res1": res1,
            "m": m, "m1": m1, "by_ay": by_ay, "t_zoom": log.t[0] + (20.0 if quick else 200.0),
            "text": "\n".join(lines), "metrics": metrics}


def summary(lpv: dict, nl: dict, revs: dict) -> str:
    """Section 7: enclosure and mean widths of the three runs, one line each."""
    out = []
    for nm, m in (("emulated LPV truth:", lpv["m"]), ("emulated nonlinear:", nl["m"]),
                  ("Revs real log:     ", revs["m"])):
        out.append(f"{nm} enclosure {m['enclosure_vy']:.3f} / {m['enclosure_r']:.3f}, "
                   f"mean width v_y {m['width_mean_vy']:.4f} m/s, r {m['width_mean_r']:.2e} rad/s")
    return "\n".join(out)


# ------------------------------------------------------------------ figures ----------------
def fig_gains(gc: dict):
    """Theorem 2 solution: designed ``|L|`` and ``P_22/P_11`` per mode.vertex next to the
    printed ones (:func:`gain_comparison` output); 3 axes."""
    return iv.plot_gains(gc["des"], gc["L_printed"], gc["P_printed"])


def fig_inputs_emulated(lpv: dict):
    """Steering [deg], speed with the band edges (22) [m/s] and sigma(t) of the emulated run
    (:func:`lpv_experiment` output); 3 axes."""
    return iv.plot_inputs(lpv["t"], lpv["vx"], lpv["delta"], lpv["res"].sigma, lpv["bands"],
                          "Emulated Satory run: inputs and switching signal (22)")


def fig_intervals_lpv(lpv: dict):
    """The slides' two interval figures (v_y, r) on the LPV truth (Theorem 1 situation);
    2 axes."""
    return iv.plot_intervals(lpv["t"], {"switched": lpv["res"]}, lpv["X"][:, 0], lpv["X"][:, 1],
                             "Interval observer on the LPV truth (stiffness varying inside the "
                             "+-10 % box)", truth_label="LPV truth")


def fig_intervals_nonlinear(nl: dict):
    """Switched and single-mode intervals on the measured signals, nonlinear truth
    (:func:`nonlinear_experiment` output); 2 axes."""
    return iv.plot_intervals(nl["t"], {"switched": nl["res"], "single mode": nl["res1"]},
                             nl["truth"][:, 0], nl["truth"][:, 1],
                             "Measured signals, nonlinear truth (Pacejka + relaxation)",
                             truth_label="nonlinear truth")


def fig_widths(nl: dict):
    """Interval widths of v_y [m/s] and r [rad/s] (log scale), switched vs single mode, on
    the measured signals; 2 axes."""
    return iv.plot_widths(nl["t"], {"switched (3 modes)": nl["res"], "single mode": nl["res1"]},
                          "Interval widths, measured signals")


def fig_inputs_revs(revs: dict):
    """Steering, speed with the Revs bands and sigma(t) on the real log; 3 axes."""
    log = revs["log"]
    return iv.plot_inputs(log.t, log.vx, log.delta, revs["res"].sigma, revs["rdes"].model.bands,
                          "Revs 250 LM: inputs and switching signal")


def fig_intervals_revs(revs: dict, zoom: bool = False):
    """Intervals vs the measured v_y (INS) and yaw rate on the Revs log; ``zoom=True``: the
    60 s starting at ``revs["t_zoom"]``; 2 axes."""
    log = revs["log"]
    if zoom:
        t0 = revs["t_zoom"]
        return iv.plot_intervals(log.t, {"switched": revs["res"]}, log.vy, log.yaw_rate,
                                 "Revs 250 LM, 60 s zoom", tlim=(t0, t0 + 60.0),
                                 truth_label="measured")
    return iv.plot_intervals(log.t, {"switched": revs["res"]}, log.vy, log.yaw_rate,
                             "Revs 250 LM: interval observer vs measured v_y (INS) and yaw rate",
                             truth_label="measured")
