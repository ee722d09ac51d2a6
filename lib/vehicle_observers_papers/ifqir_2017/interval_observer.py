"""Experiments and figures of notebook 03 (Ifqir 2017, switched TS interval observer).

Each function runs one experiment of the notebook and returns a plain dict (arrays, the
:class:`~vehicle_observers.observers.interval.IntervalResult` objects and a ``"metrics"`` entry
``{name: (value, unit, note)}`` in the order the notebook records them with
``rep.metric(name, *v)``), and each ``fig_*`` function returns a matplotlib Figure, so the
notebook stays a few lines per cell. Equations, the reconstruction of observer (11) and of
Theorem 2: see :mod:`vehicle_observers.observers.interval`; printed constants:
:mod:`vehicle_observers_papers.ifqir_2017.constants`.

State ``x = [v_y (m/s), r (rad/s)]``; every ``(N, 2)`` array below has these two columns.
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.data.logs import DriveLog, despike, load_revs
from vehicle_observers.data.scenarios import NOISE_STD, emulated_satory
from vehicle_observers.models import uncertain_bicycle as ub
from vehicle_observers.observers import interval as iv

from vehicle_observers_papers.ifqir_2017 import constants as IF
from vehicle_observers_papers.ifqir_2017 import evaluation as ev
from vehicle_observers_papers.ifqir_2017 import printed_observer as po
from vehicle_observers_papers.ifqir_2017 import printed_solution as ps

#: initial box ``(x0_lo, x0_hi)`` of ``[v_y, r]`` [m/s, rad/s] on the emulated run
BOX0 = (np.array([-0.5, -0.1]), np.array([0.5, 0.1]))
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
#: convergence time: the initial-box effect on a width falls below this share of its start
SETTLE_FRAC = 0.02
#: record length [s] after each start of the convergence test
CONV_HORIZON = 5.0
#: top speed [m/s] of the emulated run for the printed observer: 0.2 m/s below the printed
#: top band edge 16.6 m/s (22), so the measured speed (noise std 0.05 m/s) stays in the bands
V_MAX_PRINTED = 16.4


def metrics_line(label: str, m: dict) -> str:
    """One readable line of :func:`evaluation.interval_metrics` output ``m``: enclosure,
    mean / max width and largest excursion of ``v_y`` [m/s] and ``r`` [rad/s]."""
    parts = [f"{label:9s}"]
    if "enclosure_vy" in m:
        parts.append(f"enclosure v_y {m['enclosure_vy']:.4f}, r {m['enclosure_r']:.4f};")
    parts.append(f"mean width v_y {m['width_mean_vy']:.4f} m/s, r {m['width_mean_r']:.2e} rad/s; "
                 f"max width v_y {m['width_max_vy']:.3f} m/s, r {m['width_max_r']:.2e} rad/s")
    if "max_excursion_vy" in m:
        parts.append(f"; largest excursion v_y {m['max_excursion_vy']:.2e} m/s, r "
                     f"{m['max_excursion_r']:.2e} rad/s")
    return " ".join(parts)


def _ratio(a: dict, b: dict, key: str) -> float:
    """``a[key] / b[key]`` (switched / single-mode width)."""
    return a[key] / b[key]


# ------------------------------------------------------------------ section 1 --------------
def box_summary(veh: ub.UncertainBicycle | None = None, model: ub.SwitchedIntervalModel | None = None
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
def observer_step_check(des: iv.IntervalDesign, dt: float = IF.Ts, seed: int = 0,
                        n: int = 50) -> float:
    """Largest difference between one step of the compiled observer
    (:func:`interval.run_interval_observer`) and the readable numpy right-hand side
    :func:`interval.implemented_rhs` (one explicit Euler step ``x + dt f``), over ``n``
    seeded random speeds (inside the bands), boxes, inputs and yaw rates. Rounding only
    (~1e-15 relative) when both implement the same observer (11)."""
    rng = np.random.default_rng(seed)
    e = np.asarray(des.model.bands.edges, dtype=float)
    worst = 0.0
    for _ in range(n):
        v = rng.uniform(e[0], e[-1])
        c, w = rng.normal(0, 0.3, 2), rng.uniform(0, 0.5, 2)
        u = np.sort(rng.normal(0, 0.02, 2))
        y = rng.normal(0, 0.2)
        res = iv.run_interval_observer(des, dt, [v, v], u[:1].repeat(2), u[1:].repeat(2),
                                       [y, y], c - w, c + w)
        sig, h = des.model.memberships(v)
        fh, fl = iv.implemented_rhs(des, int(sig[0]), h[0], c + w, c - w, y, u[0], u[1])
        worst = max(worst, float(np.abs(res.x_hi[1] - (c + w + dt * fh)).max()),
                    float(np.abs(res.x_lo[1] - (c - w + dt * fl)).max()))
    return worst


def design_study(seed: int = 0, quick: bool = False, veh: ub.UncertainBicycle | None = None,
                 bands: ub.SpeedBands | None = None) -> dict:
    """Theorem 2 (17)-(21) for the switched bands (22) (``bands``, default
    :data:`.constants.bands`) and for one band over the same range (non-switched), both
    certified, for the vehicle ``veh`` (default :data:`.constants.vehicle`); the
    a-posteriori blended check of (19) (:func:`interval.blended_iss_margin`, 300 random
    weights per mode in quick mode, else 3000, drawn from ``seed``) and the
    average dwell time (:func:`interval.dwell_time_bound`). Returns ``des``, ``des1``
    (:class:`~vehicle_observers.observers.interval.IntervalDesign`), ``blended`` (max eigenvalue,
    < 0 is good), ``dwell`` (dict), ``text`` and ``metrics`` (gamma per mode (K,), margins
    [1/s], dwell time [s]) and ``timings`` (solver wall clock [s], for ``rep.timing``)."""
    bands = bands or IF.bands
    single = ub.SpeedBands((bands.edges[0], bands.edges[-1]))
    des, des1 = IF.design(bands, veh), IF.design(single, veh)
    bl = iv.blended_iss_margin(des, n=300 if quick else 3000, seed=seed)
    dw = iv.dwell_time_bound(des)
    lines = [des.solution.summary().splitlines()[0]]
    for nm, d in (("switched", des), ("single", des1)):
        lines.append(f"{nm:9s} gamma_i = {np.round(d.gammas, 4)}, LMI margin {d.lmi_margin:.2e} "
                     f"(relative {d.lmi_relative_margin:.1e}), min Metzler margin "
                     f"{d.min_metzler_margin:.2e} 1/s, "
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
        "lmi_status": (des.solution.certificate.status, "",
                       "LMI certificate: certified / inconclusive / violated"),
        "metzler_margin_min": (des.min_metzler_margin, "1/s", ""),
        "metzler_margins": (des.metzler_margins, "1/s", ""),
        "dwell_time_bound": (dw["dwell_time_s"], "s", ""),
    }
    timings = {"solve_time": (des.solve_time, "s", "Theorem 2, 3 modes"),
               "solve_time_single": (des1.solve_time, "s", "Theorem 2, one band")}
    return {"des": des, "des1": des1, "blended": bl, "dwell": dw, "text": "\n".join(lines),
            "metrics": metrics, "timings": timings}


def log_ratio(L, L_printed) -> np.ndarray:
    """``|log10(|L| / |L_printed|)|`` element-wise, shape (K, 4, 2): 0 is equal magnitude,
    1 is a factor of ten. ``L`` (K, 4, 2[, 1])."""
    L = np.asarray(L, dtype=float)
    L = L[..., 0] if L.ndim == 4 else L
    return np.abs(np.log10(np.abs(L) / np.abs(np.asarray(L_printed))))


def gain_comparison(des: iv.IntervalDesign, L_printed=None, P_printed=None) -> dict:
    """Designed ``L_i^j``, ``P_i^j`` next to the slides' printed solution (defaults:
    :data:`.constants.L_printed` (3, 4, 2), ``P_printed`` (3, 4, 2)), all three modes.

    ``L = [L1, L2]`` with ``L1`` [m/s] (v_y row) and ``L2`` [1/s] (r row).
    ``shift_designed`` / ``shift_printed`` (2, 2): shift of ``L1`` [m/s] from the ``v_max``
    to the ``v_min`` vertex (vertices 1->2 and 3->4) in modes 2-3;
    ``sign_agreement``: share of the 24 entries whose sign equals the printed one,
    ``sign_mismatch``: ``(mode, vertex, row, designed value)`` (1-based) of the others;
    ``log_ratio`` (K, 4, 2) :func:`log_ratio`, its mean over all modes and over modes 2-3;
    ``ratio_range`` [min, max] of ``|L| designed / printed`` over all modes.
    """
    Lp = IF.L_printed if L_printed is None else np.asarray(L_printed)
    Pp = IF.P_printed if P_printed is None else np.asarray(P_printed)
    L = des.L[..., 0]
    shift_des = L[1:, [1, 3], 0] - L[1:, [0, 2], 0]
    shift_pr = Lp[1:, [1, 3], 0] - Lp[1:, [0, 2], 0]
    same = np.sign(L) == np.sign(Lp)
    mismatch = [(int(i) + 1, int(j) + 1, int(c) + 1, round(float(L[i, j, c]), 4))
                for i, j, c in np.argwhere(~same)]
    lr = log_ratio(L, Lp)
    ratio = np.abs(L) / np.abs(Lp)
    act = active_constraints(des)
    free = ~np.stack([act["at_metzler"], act["at_cap"]], axis=-1)     # (K, 4, 2) per entry
    rows = [{"mode.vertex": f"{i + 1}.{j + 1}", "L1 designed [m/s]": L[i, j, 0],
             "L1 printed [m/s]": Lp[i, j, 0], "L2 designed [1/s]": L[i, j, 1],
             "L2 printed [1/s]": Lp[i, j, 1], "P22/P11 designed": des.P[i, j, 1] / des.P[i, j, 0],
             "P22/P11 printed": Pp[i, j, 1] / Pp[i, j, 0]}
            for i in range(L.shape[0]) for j in range(L.shape[1])]
    text = "\n".join([
        f"L1 shift v_max -> v_min vertex, modes 2-3: designed {np.round(shift_des, 3).tolist()}  "
        f"printed {np.round(shift_pr, 3).tolist()} m/s",
        f"signs equal to the printed ones: {same.sum()} of {same.size}; different at (mode, "
        f"vertex, row, value): {mismatch}"])
    metrics = {"L_designed": (L, "", "[L1 m/s, L2 1/s] per mode, vertex"),
               "P_designed": (des.P, "", ""),
               "L1_shift_designed": (shift_des, "m/s", ""),
               "L1_shift_printed": (shift_pr, "m/s", ""),
               "L_sign_agreement": (float(same.mean()), "", "share of the 24 printed signs"),
               "L_log_ratio_mean": (float(lr.mean()), "", "mean |log10(L/L_printed)|, 3 modes"),
               "L_log_ratio_mean_modes23": (float(lr[1:].mean()), "", "modes 2-3"),
               "L2_at_epsilon_cap_share": (float(act["at_cap"].mean()), "",
                                           "share of the 12 designed L2 on the (20) diagonal "
                                           "bound -(A^- - LC)_22 = epsilon"),
               "L1_at_metzler_limit_share": (float(act["at_metzler"].mean()), "",
                                             "share of the 12 designed L1 on the Metzler bound "
                                             "(A^- - LC)_12 = 0"),
               "L_log_ratio_free": (float(lr[free].mean()), "",
                                    f"mean |log10(L/L_printed)| over the {int(free.sum())} "
                                    "entries on no active (20) bound")}
    text += (f"\nL2 on the epsilon bound (mode, vertex): "
             f"{[(int(i) + 1, int(j) + 1) for i, j in np.argwhere(act['at_cap'])]}; "
             f"L1 on the Metzler bound: "
             f"{[(int(i) + 1, int(j) + 1) for i, j in np.argwhere(act['at_metzler'])]}")
    return {"des": des, "L_printed": Lp, "P_printed": Pp, "shift_designed": shift_des,
            "shift_printed": shift_pr, "sign_agreement": float(same.mean()),
            "sign_mismatch": mismatch, "log_ratio": lr,
            "ratio_range": [float(ratio.min()), float(ratio.max())], "text": text, "rows": rows,
            "metrics": metrics}


def active_constraints(des: iv.IntervalDesign, cap_rtol: float = 1e-3,
                       metzler_tol: float = 1e-2) -> dict:
    """Which entries of the designed gains sit on a bound of (20) rather than where the
    objective (min sum gamma_i) puts them: ``at_cap`` (K, 4) bool, ``L2`` on the diagonal bound
    ``-(A^- - L C)_22 >= (1 - cap_rtol) epsilon`` (the ``epsilon`` of the design, [1/s]);
    ``at_metzler`` (K, 4) bool, ``L1`` on the Metzler bound ``(A^- - L C)_12 <= metzler_tol``
    [1/s]. ``M`` (K, 4, 2, 2): ``A^- - L C``."""
    M = des.model.A_lo - des.L @ des.model.C
    eps = np.inf if des.epsilon_shift is None else des.epsilon_shift
    return {"at_cap": -M[..., 1, 1] >= (1 - cap_rtol) * eps,
            "at_metzler": M[..., 0, 1] <= metzler_tol, "M": M}


def printed_solution_study(inv_vx_upper_first: bool = IF.inv_vx_upper_first) -> dict:
    """Theorem 2 checked for the slides' printed ``P``, ``L`` on the reconstructed vehicle
    (:func:`interval.certify_solution`: ``P``, ``W = P L`` fixed, each mode rescaled to
    ``P >= I``, min sum ``gamma_i`` over ``M_i``, every LMI certified), for both vertex
    polarities of ``1/v_x``; the chosen one (``inv_vx_upper_first``) first. Returns
    ``cert`` / ``cert_other`` (:class:`interval.PrintedCertificate`), ``min_epsilon`` (the
    smallest (20) shift of the printed gains, max over modes [1/s]), ``text``, ``metrics``."""
    out, lines, metrics = {}, [], {}
    for key, pol in (("cert", inv_vx_upper_first), ("cert_other", not inv_vx_upper_first)):
        c = ps.certify_solution(po.printed_model(pol), IF.P_printed, IF.L_printed,
                                IF.eps_decay, IF.accel_max, IF.p_min)
        out[key] = c
        sfx = "" if key == "cert" else "_other_polarity"
        metrics.update({
            f"printed_gamma_per_mode{sfx}": (c.gammas, "", "(19) with printed P, W = P L"),
            f"printed_lmi_margin{sfx}": (c.lmi_margin, "", "min eigenvalue margin (17)-(19)"),
            f"printed_lmi_relative_margin{sfx}": (c.solution.certificate.min_relative_margin, "",
                                                  "min relative eigenvalue margin (17)-(19)"),
            f"printed_lmi_status{sfx}": (c.solution.certificate.status, "",
                                         "LMI certificate: certified / inconclusive / violated"),
            f"printed_metzler_margin_min{sfx}": (c.metzler_margins.min(), "1/s", ""),
            f"printed_min_epsilon{sfx}": (c.min_epsilon, "1/s", "per mode")})
        lines.append(f"1/v_x upper bound at vertices 1-2: {pol}: gamma_i {np.round(c.gammas, 4)},"
                     f" LMI margin {c.lmi_margin:.2e}, min Metzler entry "
                     f"{c.metzler_margins.min():.3g} 1/s, smallest epsilon of (20) per mode "
                     f"{np.round(c.min_epsilon, 1)} 1/s")
    metrics["epsilon_shift"] = (IF.epsilon_shift, "1/s", "(20) shift of the designs")
    pm = po.printed_model(inv_vx_upper_first)
    M = pm.A_lo - IF.L_printed[..., None] @ pm.C
    metrics["printed_metzler12_min"] = (float(M[..., 0, 1].min()), "1/s",
                                        "smallest entry (1,2) of A^- - L C, printed L and bands "
                                        "(the Metzler entry that depends on L)")
    metrics["a21_at_16_6"] = (po.a21_entry(IF.vehicle, IF.bands_printed[-1]), "1/s",
                              "entry (2,1) of A^- (= of A^- - L C for every L) at 16.6 m/s")
    metrics["a21_at_17_5"] = (po.a21_entry(IF.vehicle, IF.bands.edges[-1]), "1/s",
                              "same at 17.5 m/s (the re-design's top band)")
    std, lit = po.iss19_margins(pm), po.iss19_margins(pm, literal=True)
    metrics["iss19_margin_standard"] = (std, "", "per mode: largest eigenvalue margin of (18)-"
                                        "(19) read phi (P + M), printed P (min diag 1), W = P L")
    metrics["iss19_margin_literal"] = (lit, "", "per mode: same, (19) read phi P + M")
    asg = po.vertex_assignments(pm)
    metrics["metzler_assignments"] = ([sum(r["metzler"] for r in asg if r["mode"] == i + 1)
                                       for i in range(3)], "",
                                      "of the 24 assignments of the printed gains to the "
                                      "vertices, per mode")
    metrics["identity_assignment_metzler"] = (
        int(all(r["metzler"] for r in asg if r["perm"] == (1, 2, 3, 4))), "",
        "1 if printed gain j at vertex j is Metzler in every mode")
    lines.append(f"(18)-(19) margin per mode with the printed P, W: read phi (P + M) "
                 f"{np.round(std, 3)}, read phi P + M {np.round(lit, 3)}")
    lines.append(f"Metzler assignments of the printed gains (of 24) per mode: "
                 f"{metrics['metzler_assignments'][0]}; entry (2,1) of A^- "
                 f"{metrics['a21_at_16_6'][0]:.4f} 1/s at 16.6 m/s, "
                 f"{metrics['a21_at_17_5'][0]:.4f} at 17.5 m/s (independent of L)")
    out["assignments"] = asg
    out.update(min_epsilon=float(out["cert"].min_epsilon.max()), text="\n".join(lines),
               metrics=metrics)
    return out


def polarity_study(printed: dict) -> dict:
    """Theorem 2 designs compared with the printed gains under both vertex polarities of
    ``1/v_x`` (chosen: :data:`.constants.inv_vx_upper_first`), each with the
    repository's ``epsilon`` (:data:`.constants.epsilon_shift`) and with the printed
    gains' own smallest (20) shift under that polarity (``printed`` =
    :func:`printed_solution_study` output, rounded up to the next 1/s), and the slides'
    single-gamma objective (one gamma shared by all modes) beside the per-mode sum, all three
    modes compared. Returns ``designs`` ``{(polarity, epsilon): design}``, ``single_gamma``
    (design, chosen polarity, repository epsilon), ``rows`` (one per design: polarity,
    epsilon, mean / max |log10 L/L_printed|, sign agreement, gamma_i), ``text``, ``metrics``."""
    designs, rows = {}, []
    pols = (IF.inv_vx_upper_first, not IF.inv_vx_upper_first)
    for pol, cert in zip(pols, (printed["cert"], printed["cert_other"])):
        for eps in (IF.epsilon_shift, float(np.ceil(cert.min_epsilon.max()))):
            d = IF.design(inv_vx_upper_first=pol, epsilon_shift=eps)
            designs[(pol, eps)] = d
            rows.append(_design_row(d, pol, eps, "sum of gamma_i"))
    sg = IF.design(per_mode_gamma=False)
    rows.append(_design_row(sg, IF.inv_vx_upper_first, IF.epsilon_shift, "one shared gamma"))
    lr = [r["mean |log10 L/L_pr|"] for r in rows]
    metrics = {"epsilon_printed": ([r["epsilon [1/s]"] for r in rows[1:4:2]], "1/s",
                                   "smallest (20) shift of the printed gains: chosen, other "
                                   "polarity"),
               "log_ratio_chosen": (lr[0], "", "chosen polarity, epsilon_shift"),
               "log_ratio_chosen_eps_printed": (lr[1], "", "chosen polarity, epsilon_printed"),
               "log_ratio_other": (lr[2], "", "other polarity, epsilon_shift"),
               "log_ratio_other_eps_printed": (lr[3], "", "other polarity, epsilon_printed"),
               "log_ratio_single_gamma": (lr[4], "", "one shared gamma, chosen polarity"),
               "gamma_single_objective": (sg.gamma, "", "one gamma shared by the 3 modes"),
               "gamma_per_mode_objective_max": (rows[0]["gamma_3"], "", "")}
    base = designs[(pols[0], IF.epsilon_shift)]
    text = (f"one shared gamma (slides' objective): gamma = {sg.gamma:.4f}; sum of gamma_i: "
            f"gamma_i = {np.round(base.gammas, 4)}")
    return {"designs": designs, "single_gamma": sg, "rows": rows, "text": text,
            "metrics": metrics}


def _design_row(d: iv.IntervalDesign, pol: bool, eps: float, objective: str) -> dict:
    lr = log_ratio(d.L, IF.L_printed)
    return {"1/v_x upper at vertices 1-2": pol, "epsilon [1/s]": eps, "objective": objective,
            "mean |log10 L/L_pr|": float(lr.mean()), "max |log10 L/L_pr|": float(lr.max()),
            "signs as printed": float(np.mean(np.sign(d.L[..., 0]) == np.sign(IF.L_printed))),
            "gamma_1": float(d.gammas[0]), "gamma_2": float(d.gammas[1]),
            "gamma_3": float(d.gammas[2])}


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
    xi = ub.random_stiffness_trajectory(des.model.veh, len(t), dt, seed=seed,
                                        corr_time=CORR_TIME)
    X = ub.simulate_lpv(des.model.veh, [0.0, 0.0], d, vx, xi, dt)
    res = iv.run_interval_observer(des, dt, vx, d, d, X[:, 1], *box0)
    res1 = iv.run_interval_observer(des1, dt, vx, d, d, X[:, 1], *box0)
    m = ev.interval_metrics(res, X, t, width_t_skip=WIDTH_T_SKIP)
    m1 = ev.interval_metrics(res1, X, t, width_t_skip=WIDTH_T_SKIP)
    acc = np.abs(np.diff(vx)).max() / dt
    metrics = {f"lpv_{k}": (v, "", "") for k, v in m.items()}
    for k in ("width_mean_vy", "width_mean_r"):
        metrics[f"lpv_single_{k}"] = (m1[k], "", "")
    for c in ("vy", "r"):
        metrics[f"lpv_width_ratio_{c}"] = (_ratio(m, m1, f"width_mean_{c}"), "",
                                           "switched / single")
    metrics["euler_substeps"] = (res.substeps, "", "")
    text = (f"max |dv_x/dt| of the run: {acc:.3f} m/s^2 (phi assumes {IF.accel_max:g})\n"
            f"{metrics_line('switched', m)}\n{metrics_line('single', m1)}")
    return {"t": t, "dt": dt, "vx": vx, "delta": d, "xi": xi, "X": X, "res": res, "res1": res1,
            "m": m,
            "m1": m1, "enclosure": min(m["enclosure_vy"], m["enclosure_r"]), "max_accel": acc,
            "bands": des.model.bands, "text": text, "metrics": metrics}


def convergence_starts(t, vx, bands: ub.SpeedBands, horizon: float = CONV_HORIZON) -> list:
    """Start samples for the convergence test: per mode, the first sample whose speed is
    closest to the band's mid speed [m/s] among those followed by ``horizon`` s of record
    (one int per mode; ``-1`` when the run never reaches the band)."""
    e = np.asarray(bands.edges, dtype=float)
    n_h = int(round(horizon / (t[1] - t[0])))
    v = np.asarray(vx[: max(len(vx) - n_h, 0)])
    sig = bands.mode(np.clip(v, e[0], e[-1]))
    mids = (e[:-1] + e[1:]) / 2
    dist = [np.where(sig == i, np.abs(v - mids[i]), np.inf) for i in range(len(mids))]
    return [int(np.argmin(dd)) if np.isfinite(dd).any() else -1 for dd in dist]


def convergence_study(lpv: dict, des: iv.IntervalDesign, des1: iv.IntervalDesign,
                      box0=BOX0, frac: float = SETTLE_FRAC, horizon: float = CONV_HORIZON
                      ) -> dict:
    """Convergence time of the widths from the initial box ("the convergence time is short",
    conclusion of the slides), switched (``des``) vs single-mode (``des1``), on the LPV run
    of :func:`lpv_experiment` (``lpv``). The observers are started in each mode
    (:func:`convergence_starts`) from the box ``x(t0) + box0`` and, on the same inputs, from
    the point box ``[x(t0), x(t0)]``; the convergence time of a width is
    :func:`interval.settling_time` of the first run against the second (``frac`` of the
    initial difference) over ``horizon`` s. Returns ``starts`` (sample per mode), ``times``
    ``{label: (K, 2) array}`` [s] (rows: mode, columns: v_y, r; NaN when the mode is not
    reached), ``text``, ``metrics``."""
    t, vx, d, X, dt = lpv["t"], lpv["vx"], lpv["delta"], lpv["X"], lpv["dt"]
    starts = convergence_starts(t, vx, des.model.bands, horizon)
    n_h = int(round(horizon / dt))
    times, curves = {}, {}
    for lab, de in (("switched", des), ("single mode", des1)):
        out = [_settle(de, t, vx, d, X, dt, k, n_h, box0, frac) for k in starts]
        times[lab] = np.array([o[0] for o in out])
        curves[lab] = [o[1] for o in out]
    out = [_settle_open_loop(des.model.veh, lpv["xi"], t, vx, d, X, dt, k, n_h, box0, frac)
           for k in starts]
    times["open loop"] = np.array([o[0] for o in out])
    curves["open loop"] = [o[1] for o in out]
    ts, t1, t0 = times["switched"], times["single mode"], times["open loop"]
    metrics = {"conv_time": (ts, "s", f"per mode [v_y, r]; {100 * frac:g} % of the initial-"
                                      "box effect"),
               "conv_time_max": (float(np.nanmax(ts)), "s", "switched, over modes and states"),
               "conv_time_single": (t1, "s", "same starts"),
               "conv_time_single_max": (float(np.nanmax(t1)), "s", ""),
               "conv_time_open_loop": (t0, "s", "open-loop model (L = 0) from the box corner, "
                                                "per mode [v_y, r]"),
               "conv_time_open_loop_max": (float(np.nanmax(t0)), "s",
                                           "open-loop model (L = 0), over modes and states"),
               "conv_start_speed": ([float(vx[k]) if k >= 0 else float("nan") for k in starts],
                                    "m/s", "")}
    text = "\n".join(f"{lab:12s}: width settling times [s] per mode (rows) for [v_y, r]:\n"
                     f"{np.round(tt, 4)}" for lab, tt in times.items())
    return {"starts": starts, "times": times, "curves": curves, "frac": frac,
            "speeds": metrics["conv_start_speed"][0], "text": text, "metrics": metrics}


def _settle_open_loop(veh, xi, t, vx, d, X, dt, k, n_h, box0, frac):
    """Open-loop baseline of :func:`convergence_study` (no output injection, ``L = 0``): the
    LPV model (3)-(4) with the truth's stiffness ``xi`` simulated from the box corner
    ``x(t0) + box0[1]`` and from ``x(t0)``; settling times [v_y, r] of their difference
    (:func:`evaluation.settling_time`, ``frac`` of its initial value) and the curves ``(t - t0,
    relative difference (n, 2))``; ``None`` curves if the mode is not reached."""
    if k < 0:
        return [float("nan"), float("nan")], None
    sl = slice(k, k + n_h)
    run = lambda x0: ub.simulate_lpv(veh, x0, d[sl], vx[sl], xi[sl], dt)
    xa, xb = run(X[k] + box0[1]), run(X[k])
    dev = np.abs(xa - xb)
    return ([ev.settling_time(t[sl], xa[:, c], xb[:, c], frac) for c in range(2)],
            (t[sl] - t[k], dev / dev[0]))


def _settle(de, t, vx, d, X, dt, k, n_h, box0, frac):
    """Settling times [v_y, r] of one restart at sample ``k`` and the curves ``(t - t0,
    relative initial-box effect (n, 2))`` (``None`` if the mode is not reached)."""
    if k < 0:
        return [float("nan"), float("nan")], None
    sl = slice(k, k + n_h)
    x0 = X[k]
    run = lambda lo, hi: iv.run_interval_observer(de, dt, vx[sl], d[sl], d[sl], X[sl, 1], lo, hi)
    res, ref = run(x0 + box0[0], x0 + box0[1]), run(x0, x0)
    dev = np.abs(res.width - ref.width)
    return ([ev.settling_time(t[sl], res.width[:, c], ref.width[:, c], frac) for c in range(2)],
            (t[sl] - t[k], dev / dev[0]))


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
    return {"front": ev.share_in_box(cf_eff, *xi_box[1], mask=big),
            "rear": ev.share_in_box(cr_eff, *xi_box[0], mask=big),
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
    res, res1 = ev.run_on_log(des, log, *box0, **kw), ev.run_on_log(des1, log, *box0, **kw)
    truth = np.column_stack([log.vy, log.extra["yaw_rate_true_radps"]])
    m = ev.interval_metrics(res, truth, log.t, width_t_skip=WIDTH_T_SKIP)
    m1 = ev.interval_metrics(res1, truth, log.t, width_t_skip=WIDTH_T_SKIP)
    st = effective_stiffness_share(log, des.model.veh.xi_box)
    metrics = {f"nl_{k}": (v, "", "") for k, v in m.items()}
    metrics["nl_single_width_mean_vy"] = (m1["width_mean_vy"], "", "")
    metrics["nl_width_ratio_vy"] = (_ratio(m, m1, "width_mean_vy"), "", "switched / single")
    metrics["nl_stiffness_in_box_front"] = (st["front"], "", "share of samples with |alpha| > "
                                            f"{MIN_SLIP_DEG} deg")
    metrics["nl_stiffness_in_box_rear"] = (st["rear"], "", "")
    metrics["nl_n_clipped"] = (res.n_clipped, "", "")
    text = (f"{metrics_line('switched', m)}\n{metrics_line('single', m1)}\n"
            f"speed samples clipped: {res.n_clipped}\n"
            f"samples with |alpha| > {MIN_SLIP_DEG} deg: {st['share_big_slip']:.3f}; effective "
            f"stiffness F/alpha inside the box: front {st['front']:.3f}, rear {st['rear']:.3f}")
    return {"t": log.t, "truth": truth, "res": res, "res1": res1, "m": m, "m1": m1,
            "stiffness": st, "text": text, "metrics": metrics}


# ------------------------------------------------------------------ section 6 --------------
def enclosure_by_band(res: iv.IntervalRun, ref: np.ndarray, t: np.ndarray, ay: np.ndarray,
                      bands=AY_BANDS, t_skip: float = REVS_T_SKIP) -> list[dict]:
    """Enclosure of ``ref`` (N, 2) by ``res`` split by ``|a_y|`` bands [m/s^2] (``lo <= |a_y|
    < hi``), over samples after ``t_skip`` [s]. One row per band: ``lo``, ``hi``, ``share``
    (of all samples), ``enclosure_vy``, ``enclosure_r``."""
    ay = np.abs(np.asarray(ay, dtype=float))
    rows = []
    for lo, hi in bands:
        mk = (ay >= lo) & (ay < hi)
        mm = ev.interval_metrics(res, ref, t, t_skip=t_skip, mask=mk)
        rows.append({"lo": lo, "hi": hi, "share": float(mk.mean()),
                     "enclosure_vy": mm["enclosure_vy"], "enclosure_r": mm["enclosure_r"]})
    return rows


def revs_experiment(quick: bool = False, span: float | None = None) -> dict:
    """Section 6: the Revs Ferrari 250 LM log (100 Hz; first :data:`REVS_QUICK_SPAN` s in quick
    mode, or the first ``span`` s if given), steering despiked, designs
    :func:`.constants.revs_design` (switched, ``revs_bands``) and single-band, bounds
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
    res = ev.run_on_log(rdes, log, *REVS_BOX0, **kw)
    res1 = ev.run_on_log(rdes1, log, *REVS_BOX0, **kw)
    ref = np.column_stack([log.vy, log.yaw_rate])
    m = ev.interval_metrics(res, ref, log.t, t_skip=REVS_T_SKIP, width_t_skip=WIDTH_T_SKIP)
    m1 = ev.interval_metrics(res1, ref, log.t, t_skip=REVS_T_SKIP, width_t_skip=WIDTH_T_SKIP)
    by_ay = enclosure_by_band(res, ref, log.t, log.extra["ay_filt_mps2"])
    metrics = {f"revs_{k}": (v, "", "") for k, v in m.items()}
    metrics["revs_gamma"] = (rdes.gamma, "", "")
    for c in ("vy", "r"):
        metrics[f"revs_width_ratio_{c}"] = (_ratio(m, m1, f"width_mean_{c}"), "",
                                            "switched / single")
    lines = [f"gamma_i {np.round(rdes.gammas, 4)} single {round(rdes1.gamma, 4)} LMI margin "
             f"{rdes.lmi_margin:.1e} Metzler margin {rdes.min_metzler_margin:.1e} substeps "
             f"{res.substeps}", metrics_line("switched", m), metrics_line("single", m1)]
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


# ------------------------------------------------------------------ printed observer -------
def n_outside(res: iv.IntervalRun, truth) -> int:
    """Number of samples where ``truth`` (N, 2) leaves ``[x^-, x^+]`` in either state (an
    enclosure rate rounded to 4 digits can read 1 with a few samples outside)."""
    truth = np.asarray(truth, dtype=float)
    return int(np.sum(np.any((truth < res.x_lo) | (truth > res.x_hi), axis=1)))


def printed_run_study(seed: int = 0, quick: bool = False, n_sigma: float = N_SIGMA,
                      box0=BOX0) -> dict:
    """The paper's trajectory claims on the observer AS PRINTED
    (:func:`.printed_observer.printed_design`: printed ``L`` on the printed bands up to
    16.6 m/s, identity vertex assignment, Euler at the step the printed ``epsilon`` needs):
    on the emulated Satory run with its top speed at :data:`V_MAX_PRINTED` (``seed``,
    ``quick`` as :func:`~vehicle_observers.data.scenarios.emulated_satory`; returned as
    ``log``): the LPV-truth run (:func:`.printed_observer.run_lpv`), the convergence study
    (:func:`convergence_study`) and the nonlinear run on the measured signals
    (:func:`nonlinear_experiment`, speeds above 16.6 m/s clipped and counted). The
    single-mode comparison observer is this repository's Theorem 2 design over the same
    range (0.1-16.6 m/s; the slides print no single-mode gains). Returns ``des``, ``des1``,
    ``lpv``, ``cv``, ``nl``, ``m``/``m1`` (LPV metrics), ``text`` and ``metrics``
    (all named ``printed_*``)."""
    log = emulated_satory(seed=seed, quick=quick, v_max=V_MAX_PRINTED)
    des = po.printed_design()
    des1 = IF.design(ub.SpeedBands((po.BANDS_PRINTED.edges[0], po.BANDS_PRINTED.edges[-1])))
    lpv = po.run_lpv(des, log, seed=seed, box0=box0, corr_time=CORR_TIME)
    res1 = iv.run_interval_observer(des1, lpv["dt"], lpv["vx"], lpv["delta"], lpv["delta"],
                                    lpv["X"][:, 1], *box0, t=lpv["t"])
    m = ev.interval_metrics(lpv["res"], lpv["X"], lpv["t"], width_t_skip=WIDTH_T_SKIP)
    m1 = ev.interval_metrics(res1, lpv["X"], lpv["t"], width_t_skip=WIDTH_T_SKIP)
    lpv.update(res1=res1, m=m, m1=m1, bands=des.model.bands)
    cv = convergence_study(lpv, des, des1, box0)
    nl = nonlinear_experiment(log, des, des1, n_sigma=n_sigma, box0=box0)
    metrics = {"printed_substeps": (lpv["k"], "", "Euler steps per 1 ms sample "
                                    "(h max|diag(A^- - L C)| <= 1)"),
               "printed_epsilon": (des.epsilon_shift, "1/s", "smallest (20) shift of the "
                                   "printed gains (mode 1)"),
               "printed_lpv_enclosure_vy": (m["enclosure_vy"], "", "LPV truth"),
               "printed_lpv_enclosure_r": (m["enclosure_r"], "", "LPV truth"),
               "printed_lpv_width_mean_vy": (m["width_mean_vy"], "m/s", ""),
               "printed_lpv_width_mean_r": (m["width_mean_r"], "rad/s", ""),
               "printed_lpv_width_ratio_vy": (_ratio(m, m1, "width_mean_vy"), "",
                                              "printed switched / designed single"),
               "printed_conv_time": (cv["times"]["switched"], "s", "per mode [v_y, r]"),
               "printed_conv_time_max": (float(np.nanmax(cv["times"]["switched"])), "s", ""),
               "printed_conv_time_open_loop_max": (float(np.nanmax(cv["times"]["open loop"])),
                                                   "s", "open-loop model (L = 0)"),
               "printed_nl_enclosure_vy": (nl["m"]["enclosure_vy"], "", "nonlinear truth, "
                                           "measured signals"),
               "printed_nl_enclosure_r": (nl["m"]["enclosure_r"], "", ""),
               "printed_nl_max_excursion_r": (nl["m"]["max_excursion_r"], "rad/s", ""),
               "printed_nl_width_ratio_vy": (_ratio(nl["m"], nl["m1"], "width_mean_vy"), "",
                                             "printed switched / designed single"),
               "printed_lpv_n_outside": (n_outside(lpv["res"], lpv["X"]), "",
                                         "samples with v_y or r outside the interval"),
               "printed_nl_n_outside": (n_outside(nl["res"], nl["truth"]), "",
                                        "samples with v_y or r outside the interval"),
               "printed_nl_n_clipped": (nl["res"].n_clipped, "",
                                        "measured speed samples above 16.6 m/s (clipped)")}
    text = "\n".join([
        f"printed observer: epsilon {des.epsilon_shift:.0f} 1/s -> {lpv['k']} Euler steps per "
        f"1 ms sample; min Metzler entry {des.min_metzler_margin:.4f} 1/s",
        metrics_line("LPV print", m), metrics_line("LPV single", m1),
        f"convergence times [s] per mode [v_y, r]: {np.round(cv['times']['switched'], 3).tolist()}"
        f" (open loop max {metrics['printed_conv_time_open_loop_max'][0]:.3f} s)",
        metrics_line("NL print", nl["m"]), metrics_line("NL single", nl["m1"]),
        f"speed samples clipped to 16.6 m/s: {nl['res'].n_clipped}"])
    return {"log": log, "des": des, "des1": des1, "lpv": lpv, "cv": cv, "nl": nl, "m": m,
            "m1": m1, "text": text, "metrics": metrics}


def fig_assignments(rows: list[dict], modes=(2, 3)):
    """Smallest off-diagonal entry of ``A^- - L C`` [1/s] for the 24 assignments of the
    printed gains to the vertices (:func:`.printed_observer.vertex_assignments` rows) of
    ``modes``, on a symlog axis with the zero line; the Metzler ones (>= 0) filled, the
    identity (the one simulated) labelled. 1 axes."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10.0, 3.8))
    for k, mode in enumerate(modes):
        rr = [r for r in rows if r["mode"] == mode]
        x = np.arange(len(rr)) + 0.2 * (k - 0.5)
        v = np.array([r["min_offdiag"] for r in rr])
        ok = np.array([r["metzler"] for r in rr])
        col = ev.PALETTE[k]
        ax.plot(x[ok], v[ok], "o", color=col, label=f"mode {mode}: Metzler ({ok.sum()} of 24)")
        ax.plot(x[~ok], v[~ok], "o", mfc="none", color=col, label=f"mode {mode}: not Metzler")
        ax.set_xticks(np.arange(len(rr)))
        ax.set_xticklabels(["".join(map(str, r["perm"])) for r in rr], rotation=90, fontsize=7)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_yscale("symlog", linthresh=1.0)
    ax.set_xlabel("printed gain at model vertices 1-4 (1234 = as printed, simulated) [-]")
    ax.set_ylabel("min off-diagonal of $A^- - LC$ [1/s]")
    ax.set_title("Vertex assignments of the printed gains, modes 2-3")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------ figures ----------------
def fig_gains(gc: dict, po: dict | None = None):
    """Theorem 2 solution: designed ``|L|`` and ``P_22/P_11`` per mode.vertex next to the
    printed ones (:func:`gain_comparison` output); with ``po`` (:func:`polarity_study`) also
    the design with the other ``1/v_x`` polarity; 3 axes."""
    others = None
    if po is not None:
        others = {"other $1/v_x$ polarity": po["designs"][(not IF.inv_vx_upper_first,
                                                         IF.epsilon_shift)]}
    return ev.plot_gains(gc["des"], gc["L_printed"], gc["P_printed"], others)


def fig_convergence(cv: dict):
    """Effect of the initial box after a restart in each mode, relative to its initial value
    (log scale): on the widths of the switched and single-mode observers, and on the state of
    the open-loop model (``L = 0``), with the settling level (:func:`convergence_study`
    output); 2 axes (v_y, r)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(11.0, 3.8), sharey=True)
    styles = {"switched": ("-", 1.3), "single mode": ("--", 1.0), "open loop": (":", 1.3)}
    for lab, curves in cv["curves"].items():
        for i, cur in enumerate(curves):
            if cur is None:
                continue
            ls, lw = styles[lab]
            for c in range(2):
                ax[c].semilogy(cur[0], np.maximum(cur[1][:, c], 1e-6), ls, lw=lw,
                               color=ev.PALETTE[i % len(ev.PALETTE)],
                               label=f"{lab}, mode {i + 1} ($v_x$ = {cv['speeds'][i]:.1f} m/s)")
    for c, nm in enumerate(("$v_y$", "$r$")):
        ax[c].axhline(cv["frac"], color="0.4", lw=0.8, ls="-.",
                      label=f"settling level {100 * cv['frac']:g} %" if c == 1 else None)
        ax[c].set_ylim(1e-5, 2.0)
        ax[c].set_xlabel("$t - t_0$ [s]")
        ax[c].set_title(f"{nm}: effect of the initial box")
    ax[0].set_ylabel("relative effect of the initial box [-]")
    ax[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    return fig


def fig_inputs_emulated(lpv: dict):
    """Steering [deg], speed with the band edges (22) [m/s] and sigma(t) of the emulated run
    (:func:`lpv_experiment` output); 3 axes."""
    return ev.plot_inputs(lpv["t"], lpv["vx"], lpv["delta"], lpv["res"].sigma, lpv["bands"],
                          "Emulated Satory run: inputs and switching signal (22)")


def fig_intervals_lpv(lpv: dict, title: str = "printed observer"):
    """The slides' two interval figures (v_y, r) on the LPV truth (Theorem 1 situation),
    each with its margins ``x^+ - x``, ``x - x^-`` on a symlog axis with the zero line below
    it (a violation is a negative margin); 4 axes."""
    return ev.plot_margins(lpv["t"], lpv["res"], lpv["X"],
                           f"Interval observer ({title}) on the LPV truth (stiffness varying "
                           r"inside the $\pm$10 % box)", truth_label="LPV truth")


def fig_intervals_nonlinear(nl: dict):
    """Switched and single-mode intervals on the measured signals, nonlinear truth
    (:func:`nonlinear_experiment` output), each state with a panel of the interval relative
    to the truth; 4 axes."""
    return ev.plot_intervals(nl["t"], {"switched": nl["res"], "single mode": nl["res1"]},
                             nl["truth"][:, 0], nl["truth"][:, 1],
                             "Measured signals, nonlinear truth (Pacejka + relaxation)",
                             truth_label="nonlinear truth", error_panel=True)


def fig_widths(nl: dict):
    """Interval widths of v_y [m/s] and r [rad/s] (log scale), switched vs single mode, on
    the measured signals; 2 axes."""
    return ev.plot_widths(nl["t"], {"switched (3 modes)": nl["res"], "single mode": nl["res1"]},
                          "Interval widths, measured signals")


def fig_inputs_revs(revs: dict):
    """Steering, speed with the Revs bands and sigma(t) on the real log; 3 axes."""
    log = revs["log"]
    return ev.plot_inputs(log.t, log.vx, log.delta, revs["res"].sigma, revs["rdes"].model.bands,
                          "Revs 250 LM: inputs and switching signal")


def fig_intervals_revs(revs: dict, zoom: bool = False):
    """Intervals vs the measured v_y (INS) and yaw rate on the Revs log; ``zoom=True``: the
    60 s starting at ``revs["t_zoom"]``; 2 axes."""
    log = revs["log"]
    if zoom:
        t0 = revs["t_zoom"]
        return ev.plot_intervals(log.t, {"switched": revs["res"]}, log.vy, log.yaw_rate,
                                 "Revs 250 LM, 60 s zoom", tlim=(t0, t0 + 60.0),
                                 truth_label="measured")
    return ev.plot_intervals(log.t, {"switched": revs["res"]}, log.vy, log.yaw_rate,
                             "Revs 250 LM: interval observer vs measured v_y (INS) and yaw rate",
                             truth_label="measured")


# ------------------------------------------------------------------ teaching ---------------
#: time span [s] of the live box figure (short, so one redraw stays near one second)
BOX_SPAN = (8.0, 24.0)


def box_band_run(log: DriveLog, bands: ub.SpeedBands, rel_unc: float, seed: int = 0,
                 span: tuple[float, float] = BOX_SPAN) -> dict:
    """The switched observer for a stiffness box of half-width ``rel_unc`` (fraction of
    ``c_0``, Assumption 3) on the LPV truth, over ``span`` [s] of the emulated ``log``: the
    Theorem 2 design for that box (:func:`.constants.design`), a seeded stiffness trajectory
    inside the same box and the observer from the point box at the truth. Returns ``t``,
    ``X`` (N, 2) truth, ``res``, ``m`` (:func:`evaluation.interval_metrics`, widths after 1 s)
    and ``a_max`` (the Metzler limit of the box); ``res`` is ``None`` and ``error`` the reason
    when no certified design exists (e.g. ``rel_unc > a_max``: Theorem 1 has no gain)."""
    import dataclasses

    from vehicle_observers.core.errors import InfeasibleDesign

    veh = dataclasses.replace(IF.vehicle, rel_unc=rel_unc)
    seg = log.segment(*span)
    t, dt = seg.t, seg.dt
    vx, d = seg.extra["vx_true_mps"], seg.extra["delta_true_rad"]
    xi = ub.random_stiffness_trajectory(veh, len(t), dt, seed=seed, corr_time=CORR_TIME)
    X = ub.simulate_lpv(veh, [0.0, 0.0], d, vx, xi, dt)
    out = {"t": t, "X": X, "res": None, "m": None, "a_max": veh.max_metzler_uncertainty(),
           "error": ""}
    try:
        des = IF.design(bands, veh)
    except InfeasibleDesign as exc:
        out["error"] = str(exc).splitlines()[0]
        return out
    out["res"] = iv.run_interval_observer(des, dt, vx, d, d, X[:, 1], X[0], X[0])
    out["m"] = ev.interval_metrics(out["res"], X, t, width_t_skip=1.0)
    return out


def fig_box_band(log: DriveLog, bands: ub.SpeedBands, rel_unc: float, seed: int = 0,
                 span: tuple[float, float] = BOX_SPAN):
    """Live figure of the stiffness box (:func:`box_band_run`): the ``v_y`` interval against
    the LPV truth and, below, the yaw-rate margins ``r^+ - r``, ``r - r^-`` on a log axis,
    with the enclosure and mean widths in the title; fixed axes so a move of the slider
    shows the change. 2 axes."""
    import matplotlib.pyplot as plt

    b = box_band_run(log, bands, rel_unc, seed, span)
    t, X = b["t"], b["X"]
    fig, ax = plt.subplots(2, 1, sharex=True, figsize=(8.0, 4.6),
                           gridspec_kw={"height_ratios": [1.4, 1.0]})
    ax[0].plot(t, X[:, 0], color="k", lw=0.9, label="LPV truth $v_y$", zorder=4)
    ax[0].set_ylim(X[:, 0].min() - 0.6, X[:, 0].max() + 0.6)
    ax[1].set_ylim(1e-7, 1e-1)
    ax[1].set_yscale("log")
    if b["res"] is None:
        ax[0].text(0.5, 0.5, f"box $\\pm${100 * rel_unc:.0f} %: no certified Theorem 2 design\n"
                   f"(Metzler limit $a_{{max}}$ = {b['a_max']:.3f}, Exercise 1)",
                   transform=ax[0].transAxes, ha="center", va="center", color=ev.PALETTE[4])
        ax[0].set_title(f"stiffness box $\\pm${100 * rel_unc:.0f} % of $c_0$")
    else:
        res, m = b["res"], b["m"]
        ev._band(ax[0], t, res.x_lo[:, 0], res.x_hi[:, 0], 0, "$[v_y^-, v_y^+]$")
        ax[1].plot(t, np.maximum(res.x_hi[:, 1] - X[:, 1], 1e-9), color=ev.PALETTE[0], lw=0.8,
                   label="$r^+ - r$")
        ax[1].plot(t, np.maximum(X[:, 1] - res.x_lo[:, 1], 1e-9), color=ev.PALETTE[1], lw=0.8,
                   ls="--", label="$r - r^-$")
        ax[0].set_title(f"stiffness box $\\pm${100 * rel_unc:.0f} % of $c_0$: enclosure "
                        f"{min(m['enclosure_vy'], m['enclosure_r']):.3f}, mean width $v_y$ "
                        f"{m['width_mean_vy']:.3f} m/s, $r$ {m['width_mean_r']:.1e} rad/s",
                        fontsize=9)
    ax[0].set_ylabel("$v_y$ [m/s]")
    ax[1].set_ylabel("margin of $r$ [rad/s]")
    ax[1].set_xlabel("$t$ [s]")
    for a in ax:
        if a.get_legend_handles_labels()[0]:
            a.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
    fig.tight_layout()
    return fig


def animate_convergence(lpv: dict, des: iv.IntervalDesign, start: int, horizon: float = 2.5,
                        frames: int = 30, box0=BOX0):
    """Animation (:func:`vehicle_observers.results.teaching.animation`) of the switched
    observer restarted at sample ``start`` of the LPV run (``lpv``) from the box
    ``x(t0) + box0``: the ``v_y`` and ``r`` intervals revealed over ``horizon`` s, shrinking
    onto the truth. Returns the HTML player."""
    import matplotlib.pyplot as plt
    from vehicle_observers.results import teaching

    n = int(round(horizon / lpv["dt"]))
    sl = slice(start, start + n)
    t, X = lpv["t"][sl] - lpv["t"][start], lpv["X"][sl]
    res = iv.run_interval_observer(des, lpv["dt"], lpv["vx"][sl], lpv["delta"][sl],
                                   lpv["delta"][sl], X[:, 1], X[0] + box0[0], X[0] + box0[1])
    fig, ax = plt.subplots(1, 2, figsize=(7.5, 2.8))
    idx = teaching.frame_indices(len(t), frames)
    polys = [None, None]
    for c, (nm, unit) in enumerate((("v_y", "m/s"), ("r", "rad/s"))):
        ax[c].plot(t, X[:, c], color="k", lw=1.0, label="truth")
        ax[c].set_xlim(0, t[-1])
        ax[c].set_ylim(X[0, c] + 1.2 * box0[0][c], X[0, c] + 1.2 * box0[1][c])
        ax[c].set_xlabel("$t - t_0$ [s]")
        ax[c].set_ylabel(f"${nm}$ [{unit}]")
    ax[0].legend(loc="upper right", fontsize=7)
    title = fig.suptitle("")

    def update(i):
        k = idx[i]
        for c in range(2):
            if polys[c] is not None:
                polys[c].remove()
            polys[c] = ax[c].fill_between(t[:k], res.x_lo[:k, c], res.x_hi[:k, c],
                                          color=ev.PALETTE[0], alpha=0.4, lw=0)
        title.set_text(f"$t - t_0$ = {t[k - 1]:.2f} s: width $v_y$ {res.width[k - 1, 0]:.3f} "
                       f"m/s, $r$ {res.width[k - 1, 1]:.1e} rad/s")
        return polys

    fig.tight_layout()
    return teaching.animation(fig, update, len(idx))
