"""Experiments and figures of notebook 02 (Yacine 2015, Figs. 2-3, Theorem 1).

Each function runs one experiment of the notebook on a :class:`~vehicle_observers.data.logs.DriveLog`
and returns plain dicts / figures, so the notebook stays a few lines per cell. Equations:
see :mod:`vehicle_observers.observers.ts_premise`.
"""

from __future__ import annotations

from dataclasses import replace
from itertools import product

import matplotlib.pyplot as plt
import numpy as np
from vehicle_observers.core.arrays import decimate
from vehicle_observers.core.errors import InfeasibleDesign
from vehicle_observers.core.metrics import max_abs, rmse
from vehicle_observers.data import scenarios
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models import lateral
from vehicle_observers.observers import ts_premise as to
from vehicle_observers.observers.differentiators import levant_differentiator
from vehicle_observers.results import plotting as PLOT
from vehicle_observers.results.rules import round_sig

from vehicle_observers_papers.yacine_2015 import constants as yacine2015
from vehicle_observers_papers.yacine_2015 import theorem1 as T1

#: samples before this time [s] are excluded from "after convergence" metrics
T_SETTLE = 5.0
#: speeds below this [m/s] are excluded from the curvature metrics ((11) divides by v_x)
VX_RHO_MIN = 2.0
#: top speed of the emulated lap [m/s]: below the sector's v_x^max = 17 m/s by 25 noise
#: standard deviations of the measured v_x, so the measured speed stays inside the sector
V_MAX = 16.5
#: deliberately wrong initial estimate of the theory check (transformed state (12))
X0_WRONG = (0.5, 0.1, 2.0, -2.0)


def estimation_metrics(log: DriveLog, run: to.TSRun, t_settle: float = T_SETTLE,
                       vx_rho_min: float = VX_RHO_MIN) -> dict:
    """RMSE / max error of vy (observer and premise (26)), Ff, Fr after ``t_settle``, and the
    curvature (11) RMSE / max where ``v_x > vx_rho_min``; clipping fractions of the premises."""
    m = log.t - log.t[0] > t_settle
    pe = run.premises
    out = {}
    for name, est, ref in (("vy", run.vy, log.vy), ("Ff", run.Ff, log.Ff), ("Fr", run.Fr, log.Fr),
                           ("vy_premise", None if pe is None else pe.vy, log.vy)):
        if est is None:
            continue
        out[f"rmse_{name}"] = rmse(est, ref, m)
        out[f"max_{name}"] = max_abs(est, ref, m)
    if pe is not None:
        mr = m & (log.vx > vx_rho_min)
        out["rmse_rho"] = rmse(pe.rho, log.rho, mr)
        out["max_rho"] = max_abs(pe.rho, log.rho, mr)
    out["clipped_slip_fraction"] = float(run.clipped[:, :2].any(axis=1).mean())
    out["clipped_vx_fraction"] = float(run.clipped[:, 2].mean())
    return out


def rezero(log: DriveLog, t0: float, t1: float) -> DriveLog:
    """``log.segment(t0, t1)`` with time restarted at 0 (filters restart from their defaults)."""
    seg = log.segment(t0, t1)
    seg.t = seg.t - seg.t[0]
    return seg


def differentiator_convergence(log: DriveLog, pe: to.PremiseEstimate, params=None,
                               band_vy: float = 1e-3) -> dict:
    """Convergence times of the vision differentiators on a noise-free log.

    ``T_first``: end of the initial transient of the premise ``v_ye`` (26) (first time its
    error stays below ``band_vy`` for 1 s); ``T_last``: after the last excursion above the
    band (re-convergences at the clothoid junctions included); also the same for the
    ``dpsi_L`` estimate (band ``band_vy / 10`` rad/s).
    """
    p = params or to._params(None)
    vx, r = log.extra["vx_true_mps"], log.extra["yaw_rate_true_radps"]
    dpsi = r - vx * log.rho
    dy = log.vy + vx * log.extra["psiL_true_rad"] + p.l_s * dpsi
    out = {}
    for name, err, band in (("vy", pe.vy - log.vy, band_vy),
                            ("dpsiL", pe.dpsiL - dpsi, band_vy / 10),
                            ("dyL", pe.dyL - dy, band_vy)):
        out[f"T_first_{name}"] = T1.convergence_time(log.t, err, band, mode="first")
        out[f"T_last_{name}"] = T1.convergence_time(log.t, err, band, mode="last")
    return out


def hosmd_scaling(order: int = 3, L: float = 1.0, seed: int = 0, duration: float = 30.0) -> dict:
    """Log-log slopes of the HOSMD accuracy on ``f = sin t`` (|f^(n+1)| <= 1 <= L).

    Sampling step: tau in 0.002..0.032 s (noise-free); noise: uniform in [-eps, eps],
    eps in 1e-9..1e-5 at tau = 1e-4 s over ``duration`` s (errors after 10 s). Returns the
    error tables and fitted exponents with the theoretical ones ``n-i+1`` and ``(n-i+1)/(n+1)`` (Levant 2003).
    """
    n = order
    taus = np.array([0.002, 0.004, 0.008, 0.016, 0.032])
    e_tau = []
    for tau in taus:
        t = np.arange(0.0, 60.0, tau)
        Z = levant_differentiator(np.sin(t), tau, n, L)
        m = t > 20
        e_tau.append([np.abs(Z[m, i] - np.sin(t[m] + i * np.pi / 2)).max() for i in range(n + 1)])
    e_tau = np.array(e_tau)
    rng = np.random.default_rng(seed)
    eps = np.array([1e-9, 1e-8, 1e-7, 1e-6, 1e-5])
    tau = 1e-4
    t = np.arange(0.0, duration, tau)
    e_eps = []
    for e in eps:
        Z = levant_differentiator(np.sin(t) + e * rng.uniform(-1, 1, len(t)), tau, n, L)
        m = t > 10
        e_eps.append([np.abs(Z[m, i] - np.sin(t[m] + i * np.pi / 2)).max() for i in range(n + 1)])
    e_eps = np.array(e_eps)
    s_tau = [float(np.polyfit(np.log(taus), np.log(e_tau[:, i]), 1)[0]) for i in range(n + 1)]
    s_eps = [float(np.polyfit(np.log(eps), np.log(e_eps[:, i]), 1)[0]) for i in range(n + 1)]
    return {"taus": taus, "err_tau": e_tau, "slope_tau": s_tau,
            "theory_tau": [n - i + 1 for i in range(n + 1)],
            "eps": eps, "err_eps": e_eps, "slope_eps": s_eps,
            "theory_eps": [(n - i + 1) / (n + 1) for i in range(n + 1)]}


def theory_check(base: DriveLog, design: to.Theorem1Design, t0: float = 12.0, t1: float = 40.0,
                 x0=X0_WRONG, band_vy: float = 1e-3, params=None) -> dict:
    """Bound (34) against the error norm on a noise-free TS-exact run (Theorem 1 check).

    ``base`` (noise-free emulated log) gives steering, speed and curvature on ``[t0, t1]``;
    the truth is re-simulated with (13) and the slip angles (4) (:func:`scenarios.replay`),
    which the TS form (24) represents exactly inside the sector. The observer starts at
    ``x0`` (a deliberately wrong estimate, to exercise the decay term). ``T`` = last exit of
    the premise error from ``band_vy`` (the differentiators' convergence time in (34)).

    ``max_ratio_open_loop``: the same largest ratio for the open-loop model (all ``L_i = 0``,
    the gyro unused) against the bound of ``design``: below 1 means the bound holds even without
    the observer's correction on this run, i.e. it proves little about the gains.

    ``t_informative`` [s]: the time after which the bound (45) falls below ``||e(0)||``
    (before it, (34) says less than "the error does not grow"): ``(2/alpha) ln(B0/||e0||)``
    with ``B0 = sqrt(a2/a1 ||e0||^2 + c/(alpha a1) max_[0,T] ||delta||^2 e^(alpha T))``, the
    factor of ``e^(-alpha t/2)`` in (45); it may lie beyond the simulated horizon.
    """
    p = params or to._params(None)
    log = scenarios.replay(base.segment(t0, t1), exact_slip=False)
    log.t = log.t - log.t[0]
    pe = to.estimate_premises(log)
    run = to.run_observer(log, design, pe, x0=np.asarray(x0, dtype=float))
    xt = lateral.to_transformed(np.column_stack([log.vy, log.yaw_rate, log.Ff, log.Fr]), p)
    zt = to.ts_premises(log.vy, log.yaw_rate, log.delta, log.vx)
    ts = design.ts
    inside = bool(np.all((zt >= ts.zmin) & (zt <= ts.zmax)))
    _, dl = T1.premise_mismatch(ts, xt, log.delta, zt, run.z)
    en = np.linalg.norm(xt - run.x, axis=1)
    dn = np.linalg.norm(dl, axis=1)
    T = T1.convergence_time(log.t, pe.vy - log.vy, band=band_vy)
    b = T1.bound_34(log.t, en[0], dn, T, design)
    # the same bound against the open-loop model (L_i = 0, the gyro unused): if this error also
    # stays below the bound, the bound cannot tell a designed gain from none on this run
    ol = to.run_observer(log, replace(design, L=np.zeros_like(design.L)), pe,
                         x0=np.asarray(x0, dtype=float))
    _, dl_ol = T1.premise_mismatch(ts, xt, log.delta, zt, ol.z)
    en_ol = np.linalg.norm(xt - ol.x, axis=1)
    b_ol = T1.bound_34(log.t, en_ol[0], np.linalg.norm(dl_ol, axis=1), T, design)
    a, a1, a2 = design.alpha, design.alpha1, design.alpha2
    B0 = np.sqrt(a2 / a1 * en[0] ** 2 + design.c / (a * a1) * b["delta_max_T"] ** 2 * np.exp(a * T))
    return {"alpha": a, "t": log.t, "err": xt - run.x, "err_norm": en, "delta_norm": dn,
            "bound_iss": b["iss"],
            "bound_paper": b["paper"], "T": T, "truth_inside_sector": inside,
            "max_ratio": float(np.max(en / b["paper"])),
            "max_ratio_iss": float(np.max(en / b["iss"])),
            "max_ratio_open_loop": float(np.max(en_ol / b_ol["paper"])),
            "min_margin": float(np.min(b["paper"] - en)),
            "min_margin_iss": float(np.min(b["iss"] - en)),
            "delta_max_T": b["delta_max_T"], "e0": float(en[0]),
            "err_after_5s": float(en[log.t > 5].max()),
            "bound_end": float(b["paper"][-1]), "horizon": float(log.t[-1]),
            "t_informative": float(max(T, 2.0 / a * np.log(B0 / en[0])))}


def noise_study(levels=(0.0, 1.0, 3.0), seed: int = 0, quick: bool = False,
                design: to.Theorem1Design | None = None, vision_rate_hz=None,
                v_max: float = V_MAX, L_y: float = to.L_YL, L_psi: float = to.L_PSIL) -> list[dict]:
    """Estimation metrics for several ``noise_scale`` values (same seed, same truth)."""
    design = design or to.design_theorem1(yacine2015.ts_model())
    rows = []
    for lv in levels:
        log = scenarios.emulated_satory(seed=seed, quick=quick, noise_scale=lv,
                                        vision_rate_hz=vision_rate_hz, v_max=v_max)
        pe = to.estimate_premises(log, L_y=L_y, L_psi=L_psi)
        run = to.run_observer(log, design, pe)
        rows.append({"noise_scale": lv, "vision_rate_hz": vision_rate_hz,
                     **estimation_metrics(log, run)})
    return rows


#: configurations of the LMI problem: Theorem 1 (33) alone, then each constraint the
#: repository adds (``design_theorem1`` keywords). ``P~ >= I`` is always there (normalisation
#: of the homogeneous (33), feasibility unchanged).
LMI_CONFIGS = {"(33) alone": {"p_max": None, "disk_radius": None},
               "(33) + P~ <= 1e3 I": {"p_max": 1e3, "disk_radius": None},
               "(33) + disk |lambda| < 600": {"p_max": None, "disk_radius": 600.0},
               "(33) + both (default)": {"p_max": 1e3, "disk_radius": 600.0}}
#: the configuration used when alpha is larger than the default design allows: (33) with the
#: disk region only (poles implementable at 1 kHz), no conditioning bound
DISK_ONLY = LMI_CONFIGS["(33) + disk |lambda| < 600"]


def lmi_study(alphas=(1e-3, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0), configs=None, ts=None) -> list[dict]:
    """Feasibility of Theorem 1 against alpha, for (33) alone and with each added constraint.

    One row per (alpha, configuration): ``feasible``; if feasible ``c``, ``P_condition``
    (of P in original coordinates), ``xi_min_relative`` (worst relative eigenvalue margin of
    (33) rebuilt in original coordinates: below ~1e-10 the certificate is at round-off
    level), ``status`` of that certificate (``Certificate.status``: "inconclusive" below a
    relative margin of 1e-9 or above cond(P) = 1e8), ``max_pole_modulus`` of the vertex
    observers and ``pole_dt`` = that times ``Ts`` (RK4 at ``Ts`` is stable on the real axis for
    ``|lambda| Ts < 2.78``); if infeasible the LMI named by the diagnosis and its violation.
    """
    configs = LMI_CONFIGS if configs is None else configs
    ts = ts or yacine2015.ts_model()
    rows = []
    for a, (name, kw) in product(alphas, configs.items()):
        row = {"alpha": a, "config": name}
        try:
            d = to.design_theorem1(ts, alpha=a, **kw)
        except InfeasibleDesign as exc:
            rows.append({**row, "feasible": False, "lmi": exc.lmi, "violation": exc.violation})
            continue
        mg = d.margins()
        rows.append({**row, "feasible": True, "c": d.c, "P_condition": mg["P_condition"],
                     "xi_min_relative": mg["xi_original_min_relative"],
                     "status": d.certificate_original.status,
                     "max_pole_modulus": mg["max_pole_modulus"],
                     "pole_dt": mg["max_pole_modulus"] * yacine2015.Ts})
    return rows


def certificate_counts(rows: list[dict], config: str = "(33) alone") -> dict:
    """How many rows of :func:`lmi_study` for ``config`` are ``certified``, ``inconclusive``
    (signs right but relative margin < 1e-9 or cond(P) > 1e8: never counted as feasible) and
    ``infeasible`` (no solution, or a violated certificate), and the largest certified alpha."""
    rs = [r for r in rows if r["config"] == config]
    cert = [r["alpha"] for r in rs if r.get("status") == "certified"]
    return {"n": len(rs), "certified": len(cert),
            "inconclusive": sum(r.get("status") == "inconclusive" for r in rs),
            "infeasible": sum(r.get("status") not in ("certified", "inconclusive") for r in rs),
            "max_certified_alpha": max(cert) if cert else float("nan")}


def alpha_study(log: DriveLog, alphas=(1e-3, 0.1, 0.5, 1.0), x0=X0_WRONG,
                band: float = 1e-3, config=None) -> list[dict]:
    """The observer for several decay parameters ``alpha`` (design ``config``, default
    :data:`DISK_ONLY`) on ``log`` started at ``x0``: time for ``|vy error|`` to enter ``band``
    [m/s] and stay there >= 1 s, the certificate ``status`` (as in :func:`lmi_study`) and the
    metrics. Infeasible alphas give a row with the error's LMI and violation."""
    config = DISK_ONLY if config is None else config
    rows = []
    for a in alphas:
        try:
            d = to.design_theorem1(yacine2015.ts_model(), alpha=a, **config)
        except InfeasibleDesign as exc:
            rows.append({"alpha": a, "feasible": False, "lmi": exc.lmi,
                         "violation": exc.violation})
            continue
        run = to.run_observer(log, d, x0=np.asarray(x0, dtype=float))
        rows.append({"alpha": a, "feasible": True, "c": d.c,
                     "status": d.certificate_original.status,
                     "T_settle_vy": T1.convergence_time(log.t, run.vy - log.vy, band,
                                                        mode="first"),
                     **estimation_metrics(log, run)})
    return rows


def bound_study(base: DriveLog, alphas=(1e-3, 1.0, 2.0), t1: float = 40.0,
                config=None) -> list[dict]:
    """Bound (34) for several ``alpha`` (design ``config``, default :data:`DISK_ONLY`) on the
    TS-exact noise-free replay ``[12 s, t1]`` of ``base`` (:func:`theory_check`): the largest
    ratio ``||e|| / bound``, the bound at the end of the horizon, ``t_informative`` and the
    certificate ``status`` of the design (as in :func:`lmi_study`); the full
    :func:`theory_check` result under ``"check"`` (for :func:`fig_bound`)."""
    config = DISK_ONLY if config is None else config
    rows = []
    for a in alphas:
        d = to.design_theorem1(yacine2015.ts_model(), alpha=a, **config)
        tc = theory_check(base, d, t1=t1)
        rows.append({"alpha": a, "c": d.c, "P_condition": d.alpha2 / d.alpha1,
                     "status": d.certificate_original.status,
                     **{k: tc[k] for k in ("T", "horizon", "max_ratio", "max_ratio_iss", "e0",
                                           "bound_end", "err_after_5s", "t_informative",
                                           "truth_inside_sector")}, "check": tc})
    return rows


#: model mismatch of the truth against the observer's model (relative changes of the
#: Pacejka B, C, D of both tyres, of m and I_z; absolute relaxation length r [m])
MISMATCH = {"B": -0.05, "C": 0.03, "D": -0.10, "m": 0.10, "I_z": -0.10, "r": 0.15}


def mismatched_params(p=None, mismatch=None):
    """The paper's car with the tyre and inertia errors of ``mismatch`` (default
    :data:`MISMATCH`): ``B, C, D`` multiplied by ``1 + change`` on both axles, ``m, I_z``
    likewise, relaxation lengths ``r_f = r_r = mismatch["r"]`` [m]."""
    p = p or to._params(None)
    mm = MISMATCH if mismatch is None else mismatch
    tyre = lambda t: replace(t, B=t.B * (1 + mm["B"]), C=t.C * (1 + mm["C"]), D=t.D * (1 + mm["D"]))
    return replace(p, tire_f=tyre(p.tire_f), tire_r=tyre(p.tire_r), m=p.m * (1 + mm["m"]),
                   I_z=p.I_z * (1 + mm["I_z"]), r_f=mm["r"], r_r=mm["r"],
                   name=f"{p.name}, mismatched")


def scaled_mismatch(fraction: float, mismatch=None) -> dict:
    """``fraction`` of :data:`MISMATCH` (0: the paper's car, 1: the full mismatch): the relative
    changes multiplied by ``fraction``, the relaxation length moved from the paper's ``r`` by
    ``fraction`` of the way to the mismatched one."""
    mm = MISMATCH if mismatch is None else mismatch
    out = {k: fraction * v for k, v in mm.items() if k != "r"}
    out["r"] = yacine2015.r_relax + fraction * (mm["r"] - yacine2015.r_relax)
    return out


def mismatch_study(design: to.Theorem1Design, seed: int = 0, quick: bool = False,
                   noise_scale: float = 1.0, v_max: float = V_MAX, mismatch=None,
                   fractions=(0.0, 1.0)) -> list[dict]:
    """The same emulated lap, same seed, driven by cars that are ``fraction`` of the way from
    the observer's model (0, ``truth`` "matched") to the mismatched car (1, "mismatched";
    :func:`mismatched_params`, :func:`scaled_mismatch`): estimation metrics side by side (the
    observer and the premise chain keep the paper's car); each row also carries ``fraction``,
    its ``log`` and ``run`` (for :func:`fig_estimates`)."""
    rows = []
    for f in fractions:
        name = {0.0: "matched", 1.0: "mismatched"}.get(float(f), f"{f:g} x mismatch")
        truth = None if f == 0 else mismatched_params(None, scaled_mismatch(f, mismatch))
        log = scenarios.emulated_satory(seed=seed, quick=quick, noise_scale=noise_scale,
                                        params=truth, v_max=v_max)
        run = to.run_observer(log, design)
        rows.append({"truth": name, "fraction": float(f), **estimation_metrics(log, run),
                     "log": log, "run": run})
    return rows


# ------------------------------------------------------------------ figures ----------------
#: the colour-blind-safe style of every figure (:mod:`vehicle_observers.results.plotting`)
STYLE = PLOT.STYLE


def fig_scenario(track, log: DriveLog, vx_sector=(yacine2015.vx_min, yacine2015.vx_max)):
    """Track map, curvature and speed along the run (with the TS sector's v_x bound), slips."""
    s, x, y, _ = scenarios.track_xy(track, ds=1.0)
    sl = log.extra["s_m"]
    xs, ys_ = np.interp(sl % track.length, s, x), np.interp(sl % track.length, s, y)
    t = log.t
    panels = [(r"$\rho$ [1/m]", log.rho), (r"$v_x$ [m/s]", log.vx),
              (r"slip $\alpha$ [deg]",
               np.degrees(np.column_stack([log.extra["alpha_f_true_rad"],
                                           log.extra["alpha_r_true_rad"]])))]
    with plt.style.context(STYLE):
        fig, axes = plt.subplots(3, 2, figsize=(10, 6.5), gridspec_kw={"width_ratios": [1, 1.6]})
        gs = axes[0, 0].get_gridspec()
        for a in axes[:, 0]:
            a.remove()
        axm = fig.add_subplot(gs[:, 0])
        axm.plot(x, y, "k-", lw=1)
        axm.plot(xs[::50], ys_[::50], "C1", lw=2.5, label="driven in this run")
        axm.plot(x[0], y[0], "o", c="C2", label="start / finish")
        axm.set_aspect("equal")
        axm.set_title(track.name)
        axm.set_xlabel("$x$ [m]")
        axm.set_ylabel("$y$ [m]")
        axm.legend(loc="upper left", bbox_to_anchor=(0, -0.2))
        for ax, (lab, yv) in zip(axes[:, 1], panels, strict=True):
            tt, yy = decimate(t, yv)
            ax.plot(tt, yy)
            ax.set_ylabel(lab)
            ax.set_xlabel("$t$ [s]")
        axes[1, 1].axhline(vx_sector[1], ls=":", c="k", lw=0.8)
        axes[1, 1].legend(["measured $v_x$", r"sector $v_x^{max}$"], loc="lower center")
        axes[2, 1].axhline(8, ls=":", c="k", lw=0.8)
        axes[2, 1].axhline(-8, ls=":", c="k", lw=0.8)
        axes[2, 1].legend(["front", "rear", r"sector $\pm 8°$"], loc="lower left", ncol=3)
        axes[2, 1].set_xlabel("$t$ [s]")
    return fig


def fig_estimates(log: DriveLog, run: to.TSRun, mismatched=None, t_settle: float = T_SETTLE):
    """Fig. 2 analogue: v_y (truth, premise (26), observer), F_f, F_r (truth, observer), each
    followed by its error panel; the v_y errors of the observer and of the premise get a panel
    each, and every error panel its own scale (fitted on ``t > t_settle``, after the start
    transient), so that neither error hides the other. ``mismatched``: ``(log, run)`` of the same
    lap driven by a car that is not the observer's model, drawn as a second column; the signal
    rows share their scale across the columns."""
    cols = [("truth = the observer's model", log, run)]
    if mismatched is not None:
        cols.append(("mismatched car (tyres, mass, inertia, relaxation)", *mismatched))
    nc = len(cols)
    obs = dict(c="k", lw=0.7)
    with plt.style.context(STYLE):
        fig, axes = plt.subplots(7, nc, sharex=True, figsize=(6.2 * nc + 1, 11.5),
                                 gridspec_kw={"height_ratios": [2, 1, 1, 2, 1, 2, 1]}, squeeze=False)
        for j, (title, lg, rn) in enumerate(cols):
            late = lg.t - lg.t[0] > t_settle
            tt, yt, ye, yp = decimate(lg.t, lg.vy, rn.vy, rn.premises.vy)
            ax = axes[0, j]
            ax.plot(tt, yt, c="0.6", lw=2.2, label="truth")
            ax.plot(tt, yp, c="C1", lw=0.6, label="premise (26), HOSMD")
            ax.plot(tt, ye, c="k", ls="--", lw=0.9, label="TS observer (31), forces (46)")
            panels = [(1, ye - yt, rn.vy - lg.vy, obs, r"$\hat v_y - v_y$ [m/s]"),
                      (2, yp - yt, rn.premises.vy - lg.vy, dict(c="C1", lw=0.6), r"$v_{y,e} - v_y$ [m/s]")]
            for k, (name, truth, est) in enumerate((("F_f", lg.Ff, rn.Ff), ("F_r", lg.Fr, rn.Fr))):
                r0 = 3 + 2 * k
                _, ft, fe = decimate(lg.t, truth, est)
                axes[r0, j].plot(tt, ft, c="0.6", lw=2.2)
                axes[r0, j].plot(tt, fe, c="k", ls="--", lw=0.9)
                axes[r0, j].set_ylabel(f"${name}$ [N]")
                panels.append((r0 + 1, fe - ft, est - truth, obs, f"$\\hat {name} - {name}$ [N]"))
            for row, err_dec, err, st, lab in panels:
                ae = axes[row, j]
                ae.plot(tt, err_dec, **st)
                ae.axhline(0, c="0.6", lw=0.5)
                lim = float(np.abs(err)[late].max())
                ae.set_ylim(-1.15 * lim, 1.15 * lim)
                ae.set_ylabel(lab)
            axes[0, j].set_ylabel(r"$v_y$ [m/s]")
            axes[0, j].set_title(title, fontsize=10)
            axes[-1, j].set_xlabel("$t$ [s]")
        for row in (0, 3, 5):           # the signals share their scale across the columns
            lo = min(a.get_ylim()[0] for a in axes[row])
            hi = max(a.get_ylim()[1] for a in axes[row])
            for a in axes[row]:
                a.set_ylim(lo, hi)
        fig.align_ylabels(axes[:, 0])
        h, lab = axes[0, 0].get_legend_handles_labels()
        axes[-1, 0].legend(h, lab, loc="upper left", bbox_to_anchor=(0.0, -0.6), ncol=3,
                           fontsize=8, frameon=False)
        fig.suptitle("Lateral dynamics estimation (Yacine 2015 Fig. 2 analogue, emulated run); "
                     f"each error panel scaled on $t > {t_settle:g}$ s")
    return fig


def fig_curvature(log: DriveLog, pe: to.PremiseEstimate, vx_min: float = VX_RHO_MIN):
    """Fig. 3 analogue: road curvature estimated by (11) vs truth (masked below vx_min)."""
    t = log.t
    est = np.where(log.vx > vx_min, pe.rho, np.nan)
    with plt.style.context(STYLE):
        fig, axes = plt.subplots(2, 1, sharex=True, figsize=(10, 5.5),
                                 gridspec_kw={"height_ratios": [2, 1]})
        tt, r, e = decimate(t, log.rho, est)
        axes[0].plot(tt, r, c="0.6", lw=2.2, label="truth")
        axes[0].plot(tt, e, "k--", lw=0.8, label="estimate (11), HOSMD $n = 3$")
        axes[0].set_ylabel(r"$\rho$ [1/m]")
        axes[0].legend(loc="upper right")
        tt, ee = decimate(t, est - log.rho)
        axes[1].plot(tt, ee, "k", lw=0.6)
        axes[1].set_ylabel(r"$\hat\rho - \rho$ [1/m]")
        axes[1].set_xlabel("$t$ [s]")
        fig.suptitle("Road curvature (Yacine 2015 Fig. 3 analogue); "
                     rf"$v_x \leq {vx_min:g}$ m/s masked")
    return fig


#: the states of the transformed model (12) with their units, for the per-state panels
STATE_LABELS = ((r"e_1 = v_y - \hat v_y", "m/s"), (r"e_2 = r - \hat r", "rad/s"),
                (r"e_3", "m/s$^2$"), (r"e_4", "rad/s$^2$"))


def fig_bound(checks: list[dict]):
    """Bound (34)/(45) and the ISS form (40) against the error, log scale; one column per
    :func:`theory_check` result (``checks`` items carry the design's ``alpha``). Top row: the
    Euclidean norm of Theorem 1 (the transformed state (12) mixes m/s, rad/s, m/s^2 and
    rad/s^2: the norm has no single unit); the rows below: each state's error ``|e_i|`` in its
    own unit, with the same bound (``|e_i| <= ||e||``, so the bound also holds per state)."""
    with plt.style.context(STYLE):
        fig, axes = plt.subplots(5, len(checks), figsize=(5.2 * len(checks) + 1.5, 11), sharex=True,
                                 sharey="row", squeeze=False)
        for j, tc in enumerate(checks):
            t = tc["t"]
            col = axes[:, j]
            for key, lab, st in (("bound_paper", "bound (34)/(45)", dict(c="C1", lw=1.6)),
                                 ("bound_iss", "ISS bound (40)", dict(c="C4", ls=":", lw=1.6)),
                                 ("err_norm", r"$\|e(t)\|$ simulated", dict(c="k")),
                                 ("delta_norm", r"$\|\delta_z(t)\|$ (30)", dict(c="C0", lw=0.6))):
                tt, yy = decimate(t, np.maximum(tc[key], 1e-12))
                col[0].semilogy(tt, yy, label=lab, **st)
            for i in range(4):
                tt, ei, bp = decimate(t, np.maximum(np.abs(tc["err"][:, i]), 1e-12), tc["bound_paper"])
                col[i + 1].semilogy(tt, bp, c="C1", lw=1.6)
                col[i + 1].semilogy(tt, ei, c="k", lw=0.8)
            for ax in col:
                ax.axvline(tc["T"], c="0.5", ls="--", lw=0.8)
            col[-1].set_xlabel("$t$ [s]")
            for ax in col:
                ax.set_ylim(bottom=1e-9)
            col[0].set_title(f"decay rate $\\lambda$ = {tc['alpha']:g} 1/s (Theorem 1's $\\alpha$)")
        axes[0, 0].set_ylabel(r"$\|e\|$ (12) [mixed units]")
        for i, (name, unit) in enumerate(STATE_LABELS):
            axes[i + 1, 0].set_ylabel(f"$|{name}|$ [{unit}]")
        axes[0, -1].legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
        fig.suptitle("Theorem 1: error vs bound (34), TS-exact noise-free run ($T$: dashed); "
                     "rows 2-5: each state's error in its unit")
    return fig


def fig_hosmd(sc: dict):
    """Log-log accuracy of the HOSMD vs sampling step and noise amplitude."""
    from matplotlib.ticker import FixedLocator, NullLocator

    with plt.style.context(STYLE):
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.8))
        for i in range(sc["err_tau"].shape[1]):
            a1.loglog(sc["taus"], sc["err_tau"][:, i], "o-",
                      label=f"$i$={i}: slope {sc['slope_tau'][i]:.2f} (theory {sc['theory_tau'][i]})")
            a2.loglog(sc["eps"], sc["err_eps"][:, i], "o-",
                      label=f"$i$={i}: slope {sc['slope_eps'][i]:.2f} "
                            f"(theory {sc['theory_eps'][i]:.2f})")
        a1.xaxis.set_major_locator(FixedLocator(sc["taus"]))
        a1.xaxis.set_minor_locator(NullLocator())
        a1.set_xticklabels([f"{v:g}" for v in sc["taus"]])
        a1.set_xlabel(r"sampling step $\tau$ [s]")
        a2.set_xlabel(r"noise amplitude $\varepsilon$ [same unit as $f$]")
        for a in (a1, a2):
            a.set_ylabel(r"$\max_t |z_i - f^{(i)}|$")
            a.legend(loc="lower right", fontsize=7)
        fig.suptitle("Levant differentiator $n = 3$ on $f = \\sin t$: accuracy exponents")
    return fig


def fig_hosmd_live(log10_L: float = 0.0, log10_noise: float = -5.0, seed: int = 0,
                   tau: float = 1e-3, horizon: float = 12.0):
    """The live figure of notebook 02: Levant n = 3 with bound ``L = 10**log10_L`` on
    ``f = sin t`` plus uniform noise of amplitude ``10**log10_noise``: ``z_1`` against
    ``f' = cos t`` and ``|z_1 - cos t|`` (log scale)."""
    t = np.arange(0.0, horizon, tau)
    f = np.sin(t) + 10**log10_noise * np.random.default_rng(seed).uniform(-1, 1, len(t))
    Z = levant_differentiator(f, tau, 3, 10**log10_L)
    with plt.style.context(STYLE):
        fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 4.2))
        a.plot(t, np.cos(t), c="0.6", lw=2.2, label=r"$f'(t) = \cos t$")
        a.plot(t, Z[:, 1], "k--", lw=0.9, label="HOSMD $z_1$")
        a.set_ylim(-2, 2)
        a.set_ylabel(r"$f'$ [1/s]")
        a.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8)
        b.semilogy(t, np.abs(Z[:, 1] - np.cos(t)) + 1e-12, c="k", lw=0.6)
        b.set_ylim(1e-8, 10)
        b.set_ylabel(r"$|z_1 - f'|$ [1/s]")
        b.set_xlabel("$t$ [s]")
        a.set_title(f"$L$ = {10**log10_L:.3g}, noise $\\varepsilon$ = {10**log10_noise:.1e}",
                    fontsize=10)
        fig.tight_layout()
    return fig


def convergence_animation(tc: dict, t_end: float = 2.5, frames: int = 30):
    """Figure and frame update of the animation of notebook 02: the error norm of a
    :func:`theory_check` result revealed up to ``t_end`` [s] beside its bound (34).
    Returns ``(fig, update, n_frames)`` for :func:`vehicle_observers.results.teaching.animation`."""
    from vehicle_observers.results.teaching import frame_indices

    k_end = int(np.searchsorted(tc["t"], t_end))
    tt, en, bd = tc["t"][:k_end], tc["err_norm"][:k_end], tc["bound_paper"][:k_end]
    idx = frame_indices(len(tt), frames)
    with plt.style.context(STYLE):
        fig, ax = plt.subplots(figsize=(6, 3))
        ax.set_xlim(0, tt[-1])
        ax.set_ylim(1e-4, 3 * bd.max())
        ax.set_yscale("log")
        (l_e,) = ax.plot([], [], c="k", label=r"$\|e(t)\|$ simulated")
        (l_b,) = ax.plot([], [], c="C1", lw=1.6, label=f"bound (34), $\\alpha$ = {tc['alpha']:g}")
        ax.set_xlabel("$t$ [s]")
        ax.set_ylabel("norm (state (12), mixed units)")
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8)
        fig.tight_layout()

    def update(i):
        l_e.set_data(tt[: idx[i]], en[: idx[i]])
        l_b.set_data(tt[: idx[i]], bd[: idx[i]])

    return fig, update, len(idx)


#: readable column headings (with units) of the notebook's tables, by row key
LABELS = {"alpha": "alpha [1/s]", "config": "LMI problem", "feasible": "solver found a solution",
          "c": "ISS gain c", "P_condition": "cond(P)", "xi_min_relative": "relative margin of (33)",
          "status": "certificate", "pole_dt": "|pole| x Ts", "lmi": "violated LMI",
          "violation": "violation (largest eigenvalue)", "truth": "truth",
          "rmse_vy": "RMSE v_y observer [m/s]", "rmse_vy_premise": "RMSE v_y premise (26) [m/s]",
          "ratio_vy": "observer / premise", "rmse_Ff": "RMSE F_f [N]", "rmse_Fr": "RMSE F_r [N]",
          "rmse_rho": "RMSE rho [1/m]", "max_rho": "max |rho error| [1/m]",
          "clipped_slip_fraction": "slip premises clipped (fraction)",
          "clipped_vx_fraction": "v_x premise clipped (fraction)", "noise_scale": "noise std x",
          "vision_rate_hz": "camera [Hz] (None: 1 kHz)", "T": "T [s]", "horizon": "horizon [s]",
          "max_ratio": "max ||e|| / (34)", "max_ratio_iss": "max ||e|| / ISS (40)",
          "bound_end": "(34) at the end", "err_after_5s": "max ||e|| after 5 s",
          "t_informative": "(45) < ||e(0)|| after [s]", "T_settle_vy": "v_y within 1e-3 m/s after [s]"}


def table(rows: list[dict], keys, title: str = ""):
    """``show_table`` of ``rows`` restricted to ``keys``, headed by :data:`LABELS`."""
    from vehicle_observers.results.tables import show_table

    lab = [LABELS.get(k, k) for k in keys]
    return show_table([{lb: r.get(k) for k, lb in zip(keys, lab, strict=True)} for r in rows], lab,
                      title=title)


def columns(rows: list[dict], keys=None, digits: int = 4) -> dict:
    """Rows -> ``{key: [values]}`` (for metrics.json), numbers at ``digits`` significant digits."""
    keys = keys or list(dict.fromkeys(k for r in rows for k in r))
    return {k: [round_sig(_plain(r.get(k)), digits) for r in rows] for k in keys}


def _plain(v):
    if isinstance(v, (np.bool_, bool)):
        return bool(v)
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    return v
