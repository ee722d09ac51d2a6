"""Experiments and figures of notebook 02 (Yacine 2015, Figs. 2-3, Theorem 1).

Each function runs one experiment of the notebook on a :class:`~vehicle_observers.data.logs.DriveLog`
and returns plain dicts / figures, so the notebook stays a few lines per cell. Equations:
see :mod:`vehicle_observers.observers.ts_premise`.
"""

from __future__ import annotations

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
from vehicle_observers.papers import yacine2015

#: samples before this time [s] are excluded from "after convergence" metrics
T_SETTLE = 5.0
#: speeds below this [m/s] are excluded from the curvature metrics ((11) divides by v_x)
VX_RHO_MIN = 2.0


def estimation_metrics(log: DriveLog, run: to.ObserverRun, t_settle: float = T_SETTLE,
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
        out[f"T_first_{name}"] = to.convergence_time(log.t, err, band, mode="first")
        out[f"T_last_{name}"] = to.convergence_time(log.t, err, band, mode="last")
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


def theory_check(base: DriveLog, design: to.ObserverDesign, t0: float = 12.0, t1: float = 40.0,
                 x0=(0.5, 0.1, 2.0, -2.0), band_vy: float = 1e-3, params=None) -> dict:
    """Bound (34) against the error norm on a noise-free TS-exact run (Theorem 1 check).

    ``base`` (noise-free emulated log) gives steering, speed and curvature on ``[t0, t1]``;
    the truth is re-simulated with (13) and the slip angles (4) (:func:`scenarios.replay`),
    which the TS form (24) represents exactly inside the sector. The observer starts at
    ``x0`` (a deliberately wrong estimate, to exercise the decay term). ``T`` = last exit of
    the premise error from ``band_vy`` (the differentiators' convergence time in (34)).
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
    _, dl = to.premise_mismatch(ts, xt, log.delta, zt, run.z)
    en = np.linalg.norm(xt - run.x, axis=1)
    dn = np.linalg.norm(dl, axis=1)
    T = to.convergence_time(log.t, pe.vy - log.vy, band=band_vy)
    b = to.bound_34(log.t, en[0], dn, T, design)
    return {"t": log.t, "err_norm": en, "delta_norm": dn, "bound_iss": b["iss"],
            "bound_paper": b["paper"], "T": T, "truth_inside_sector": inside,
            "max_ratio": float(np.max(en / b["paper"])),
            "min_margin": float(np.min(b["paper"] - en)),
            "min_margin_iss": float(np.min(b["iss"] - en)),
            "delta_max_T": b["delta_max_T"], "e0": float(en[0]),
            "err_after_5s": float(en[log.t > 5].max())}


def noise_study(levels=(0.0, 1.0, 3.0), seed: int = 0, quick: bool = False,
                design: to.ObserverDesign | None = None, vision_rate_hz=None) -> list[dict]:
    """Estimation metrics for several ``noise_scale`` values (same seed, same truth)."""
    design = design or to.design_theorem1(yacine2015.ts_model())
    rows = []
    for lv in levels:
        log = scenarios.emulated_satory(seed=seed, quick=quick, noise_scale=lv,
                                        vision_rate_hz=vision_rate_hz)
        run = to.run_observer(log, design)
        rows.append({"noise_scale": lv, "vision_rate_hz": vision_rate_hz,
                     **estimation_metrics(log, run)})
    return rows


def alpha_study(log: DriveLog, alphas=(1e-3, 0.1, 0.5, 1.0), x0=(0.5, 0.1, 2.0, -2.0),
                band: float = 1e-3) -> list[dict]:
    """Theorem 1 for several decay parameters ``alpha``: feasibility, ``c``, P conditioning,
    and the observer on ``log`` started at ``x0``: time for ``|vy error|`` to enter ``band``
    [m/s] and stay there >= 1 s, and the metrics. Infeasible alphas give a row with the
    error message."""
    rows = []
    for a in alphas:
        try:
            d = to.design_theorem1(yacine2015.ts_model(), alpha=a)
        except InfeasibleDesign as exc:
            rows.append({"alpha": a, "feasible": False, "error": str(exc).split("Diagnosis: ")[-1],
                         "lmi": exc.lmi, "violation": exc.violation})
            continue
        run = to.run_observer(log, d, x0=np.asarray(x0, dtype=float))
        mg = d.margins()
        rows.append({"alpha": a, "feasible": True, "c": d.c, "P_condition": mg["P_condition"],
                     "min_margin": mg["xi_original_min_margin"],
                     "max_pole_real": mg["max_pole_real"],
                     "T_settle_vy": to.convergence_time(log.t, run.vy - log.vy, band,
                                                        mode="first"),
                     **estimation_metrics(log, run)})
    return rows


# ------------------------------------------------------------------ figures ----------------
def fig_scenario(track, log: DriveLog):
    """Track map, curvature and speed along the run, slip angles."""
    s, x, y, _ = scenarios.track_xy(track, ds=1.0)
    sl = log.extra["s_m"]
    xs, ys = np.interp(sl % track.length, s, x), np.interp(sl % track.length, s, y)
    t = log.t
    panels = [("rho [1/m]", log.rho), ("v_x [m/s]", log.vx),
              ("slip [deg]", np.degrees(np.column_stack([log.extra["alpha_f_true_rad"],
                                                         log.extra["alpha_r_true_rad"]])))]
    fig, axes = plt.subplots(3, 2, figsize=(10, 6.5), gridspec_kw={"width_ratios": [1, 1.6]})
    gs = axes[0, 0].get_gridspec()
    for a in axes[:, 0]:
        a.remove()
    axm = fig.add_subplot(gs[:, 0])
    axm.plot(x, y, "k-", lw=1)
    axm.plot(xs[::50], ys[::50], "C1", lw=2.5, label="driven in this run")
    axm.plot(x[0], y[0], "go", label="start / finish")
    axm.set_aspect("equal")
    axm.set_title(track.name)
    axm.set_xlabel("x [m]")
    axm.set_ylabel("y [m]")
    axm.legend(loc="best")
    for ax, (lab, yv) in zip(axes[:, 1], panels, strict=True):
        tt, yy = decimate(t, yv)
        ax.plot(tt, yy)
        ax.set_ylabel(lab)
    axes[2, 1].axhline(8, ls=":", c="k", lw=0.8)
    axes[2, 1].axhline(-8, ls=":", c="k", lw=0.8)
    axes[2, 1].legend(["front", "rear", "sector +-8 deg"], loc="best")
    axes[2, 1].set_xlabel("t [s]")
    return fig


def fig_estimates(log: DriveLog, run: to.ObserverRun):
    """Fig. 2 analogue: v_y (truth, premise (26), observer), F_f, F_r (truth, observer)."""
    t = log.t
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(10, 7))
    series = [("v_y [m/s]", [("truth", log.vy, dict(c="0.6", lw=2.2)),
                             ("premise (26), HOSMD", run.premises.vy, dict(c="C1", lw=0.6)),
                             ("TS observer (31)", run.vy, dict(c="k", ls="--"))]),
              ("F_f [N]", [("truth", log.Ff, dict(c="0.6", lw=2.2)),
                           ("TS observer (31)+(46)", run.Ff, dict(c="k", ls="--"))]),
              ("F_r [N]", [("truth", log.Fr, dict(c="0.6", lw=2.2)),
                           ("TS observer (31)+(46)", run.Fr, dict(c="k", ls="--"))])]
    for ax, (lab, ss) in zip(axes, series, strict=True):
        for name, y, st in ss:
            tt, yy = decimate(t, y)
            ax.plot(tt, yy, label=name, **st)
        ax.set_ylabel(lab)
        ax.legend(loc="best")
    axes[-1].set_xlabel("t [s]")
    fig.suptitle("Lateral dynamics estimation (Yacine 2015 Fig. 2 analogue, emulated run)")
    return fig


def fig_curvature(log: DriveLog, pe: to.PremiseEstimate, vx_min: float = VX_RHO_MIN):
    """Fig. 3 analogue: road curvature estimated by (11) vs truth (masked below vx_min)."""
    t = log.t
    est = np.where(log.vx > vx_min, pe.rho, np.nan)
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(10, 5.5),
                             gridspec_kw={"height_ratios": [2, 1]})
    tt, r, e = decimate(t, log.rho, est)
    axes[0].plot(tt, r, c="0.6", lw=2.2, label="truth")
    axes[0].plot(tt, e, "k--", lw=0.8, label="estimate (11), HOSMD n = 3")
    axes[0].set_ylabel("rho [1/m]")
    axes[0].legend(loc="best")
    tt, ee = decimate(t, est - log.rho)
    axes[1].plot(tt, ee, "k", lw=0.6)
    axes[1].set_ylabel("error [1/m]")
    axes[1].set_xlabel("t [s]")
    fig.suptitle(f"Road curvature (Yacine 2015 Fig. 3 analogue); v_x <= {vx_min} m/s masked")
    return fig


def fig_bound(tc: dict):
    """Bound (34) and the ISS form (40) vs the error norm, log scale."""
    fig, ax = plt.subplots(figsize=(9, 4))
    t = tc["t"]
    for key, lab, st in (("bound_paper", "bound (34)/(45)", dict(c="C3")),
                         ("bound_iss", "ISS bound (40)", dict(c="C1", ls=":")),
                         ("err_norm", "||e(t)|| simulated", dict(c="k")),
                         ("delta_norm", "||delta(t)|| (30)", dict(c="C0", lw=0.6))):
        tt, yy = decimate(t, np.maximum(tc[key], 1e-12))
        ax.semilogy(tt, yy, label=lab, **st)
    ax.axvline(tc["T"], c="0.5", ls="--", lw=0.8, label=f"T = {tc['T']:.2f} s")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("norm (transformed units)")
    ax.legend(loc="best")
    ax.set_title("Theorem 1: error norm vs bound, TS-exact noise-free run")
    return fig


def fig_hosmd(sc: dict):
    """Log-log accuracy of the HOSMD vs sampling step and noise amplitude."""
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.8))
    for i in range(sc["err_tau"].shape[1]):
        a1.loglog(sc["taus"], sc["err_tau"][:, i], "o-",
                  label=f"i={i}: slope {sc['slope_tau'][i]:.2f} (theory {sc['theory_tau'][i]})")
        a2.loglog(sc["eps"], sc["err_eps"][:, i], "o-",
                  label=f"i={i}: slope {sc['slope_eps'][i]:.2f} (theory {sc['theory_eps'][i]:.2f})")
    a1.set_xlabel("sampling step tau [s]")
    a2.set_xlabel("noise amplitude eps")
    for a in (a1, a2):
        a.set_ylabel("max |z_i - f^(i)|")
        a.legend(loc="best", fontsize=7)
    fig.suptitle("Levant differentiator n = 3 on sin t: accuracy exponents")
    return fig


def table(rows: list[dict], columns=None) -> str:
    """Plain-text table of dict rows (4 significant digits), for notebook printing."""
    columns = columns or list(dict.fromkeys(k for r in rows for k in r))

    def fmt(v):
        if isinstance(v, (float, np.floating)):
            return f"{v:.4g}"
        return str(v)

    cells = [[fmt(r.get(c, "")) for c in columns] for r in rows]
    w = [max(len(c), *(len(row[j]) for row in cells)) for j, c in enumerate(columns)]
    lines = ["  ".join(c.rjust(w[j]) for j, c in enumerate(columns))]
    lines += ["  ".join(v.rjust(w[j]) for j, v in enumerate(row)) for row in cells]
    return "\n".join(lines)


def columns(rows: list[dict], keys=None) -> dict:
    """Rows -> ``{key: [values]}`` (for metrics.json)."""
    keys = keys or list(dict.fromkeys(k for r in rows for k in r))
    return {k: [r.get(k) for r in rows] for k in keys}
