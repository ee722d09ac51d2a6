"""Studies of notebook 01: exactness of the TS forms and fit of the models to a real log.

- :func:`yacine_exactness`: the 8-rule TS model (24) of Yacine 2015 against the nonlinear
  transformed model (13) along a trajectory inside the sector (right-hand sides and
  simulated trajectories), and what happens outside it.
- :func:`emulated_fig1`: Yacine 2015 Fig. 1 on the paper's own car and sensors (an emulated
  Satory run, :func:`vehicle_observers.data.scenarios.emulated_satory`): no parameter fitted.
- :func:`revs_fig1`: Yacine 2015 Fig. 1 analogue on the Revs 250 LM log (another car).
- :func:`bicycle_exactness`: Ichalal 2011 Fig. 2 analogue (nonlinear bicycle vs its TS form).
- figures: :func:`tyre_sector_figure`, :func:`exactness_figure`, :func:`legends_outside`, and
  the teaching figures of the sector construction (:func:`sector_sweep_figure`,
  :func:`sector_range_figure`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import matplotlib.pyplot as plt
import numpy as np
from vehicle_observers.core.errors import ObserverArgumentError, PremiseOutOfBounds
from vehicle_observers.core.metrics import correlation, fit_percent, rmse
from vehicle_observers.core.signals import chirp, speed_ramp, time_grid
from vehicle_observers.data.identification import identify_friction
from vehicle_observers.data.logs import DriveLog, despike
from vehicle_observers.models import bicycle, lateral
from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.tires import LinearTire
from vehicle_observers.models.ts import SectorTS
from vehicle_observers.results.plotting import PALETTE, TRUTH
from vehicle_observers.results.tables import show_table


@dataclass
class Run:
    """A simulated run: time (N,), inputs (N,), states (N, n) by name."""

    t: np.ndarray
    inputs: dict
    states: dict


def excitation(duration: float, dt: float, steer_amp: float, vx_range=(3.0, 17.0)):
    """Steering chirp 0.05 -> 1.5 Hz with a speed ramp (deterministic)."""
    t = time_grid(duration, dt)
    return t, chirp(t, 0.05, 1.5, steer_amp), speed_ramp(t, *vx_range)


def yacine_exactness(p: LateralParams, ts: SectorTS, duration: float = 30.0, dt: float = 1e-3,
                     steer_amp: float = 0.16, vx_range=(3.0, 17.0)) -> dict:
    """Compare TS (24) and nonlinear (13) along the nonlinear model's trajectory.

    Returns max relative RHS difference, the convex-sum residual, the largest relative
    difference between the two *simulated* trajectories (TS form integrated by itself),
    the premise ranges, and the run.
    """
    t, delta, vx = excitation(duration, dt, steer_amp, vx_range)
    X = lateral.simulate_s1([0, 0, 0, 0], delta, vx, dt, p, exact=False, relaxation=True,
                            substeps=1)
    x = lateral.to_transformed(X, p)
    f_nl = lambda x_, u_, vx_: lateral.rhs_transformed(x_, np.ravel(u_), vx_, p)
    res = ts.exactness(x, delta, f_nl, vx)
    x_ts, oob = lateral.simulate_ts(ts, x[0], delta, vx, dt, p, substeps=1)
    scale = np.abs(x).max(axis=0)
    res["max_rel_traj_diff"] = float((np.abs(x_ts - x) / scale).max())
    res["n_out_of_bounds"] = int(oob.sum())
    af, ar = lateral.slip_angles(x[:, 0], x[:, 1], delta, vx, p, exact=False)
    res["max_abs_slip_deg"] = float(np.degrees(max(np.abs(af).max(), np.abs(ar).max())))
    res["run"] = Run(t, {"delta": delta, "vx": vx}, {"x_nl": x, "x_ts": x_ts})
    return res


def outside_sector(p: LateralParams, ts: SectorTS, duration: float = 30.0, dt: float = 1e-3,
                   steer_amp: float = 0.25, vx_range=(3.0, 17.0)) -> dict:
    """Drive past the sector (slip beyond its bound): the builder refuses with a message;
    with saturated memberships the TS form is no longer exact -- by how much."""
    t, delta, vx = excitation(duration, dt, steer_amp, vx_range)
    X = lateral.simulate_s1([0, 0, 0, 0], delta, vx, dt, p, exact=False, relaxation=True,
                            substeps=1)
    x = lateral.to_transformed(X, p)
    f_nl = lateral.rhs_transformed(x, delta, vx, p)
    z = ts.premise_fn(x, delta[:, None], vx)
    try:
        ts.check_bounds(z)
        message = None
    except PremiseOutOfBounds as exc:
        message = str(exc)
    out = (z < ts.zmin) | (z > ts.zmax)
    f_clip = ts.rhs(x, delta[:, None], vx, clip=True)
    scale = np.abs(f_nl).max(axis=0)
    af, ar = lateral.slip_angles(x[:, 0], x[:, 1], delta, vx, p, exact=False)
    return {"message": message, "share_out": float(out.any(axis=1).mean()),
            "max_rel_diff_clipped": float((np.abs(f_clip - f_nl) / scale).max()),
            "max_abs_slip_deg": float(np.degrees(max(np.abs(af).max(), np.abs(ar).max())))}


def sector_from_trajectory(p: LateralParams, alpha_max: float, vx, margin: float = 0.02):
    """TS bounds covering a trajectory: secant stiffness over ``|alpha| <= alpha_max`` and
    ``v_x`` range, each widened by ``margin`` (relative)."""
    ff = p.tire_f.sector_bounds(alpha_max)
    fr = p.tire_r.sector_bounds(alpha_max)
    widen = lambda lo, hi: (lo - margin * (hi - lo), hi + margin * (hi - lo))
    return widen(*ff), widen(*fr), widen(float(np.min(vx)), float(np.max(vx)))


def _fits(models: dict, log: DriveLog, mask=None) -> dict:
    """Yaw-rate RMSE [rad/s], correlation, fit [%] and v_y RMSE [m/s], correlation of each
    model ``{name: X (N, 2) = [v_y, r]}`` against the log, over the samples ``mask``."""
    fits = {}
    for name, X in models.items():
        fits[name] = {
            "yaw_rmse": rmse(X[:, 1], log.yaw_rate, mask),
            "yaw_corr": correlation(X[:, 1], log.yaw_rate, mask),
            "yaw_fit": fit_percent(X[:, 1], log.yaw_rate, mask),
            "vy_rmse": rmse(X[:, 0], log.vy, mask) if log.vy is not None else np.nan,
            "vy_corr": correlation(X[:, 0], log.vy, mask) if log.vy is not None else np.nan,
        }
    return fits


def revs_fig1(base: LateralParams, linear: LateralParams, log: DriveLog,
              spike_threshold: float = 0.05, fit_fraction: float = 0.5) -> dict:
    """Yacine 2015 Fig. 1 analogue on a real log, judged on samples the fit never saw.

    1. Steering despiked (isolated one-sample spikes > ``spike_threshold`` rad).
    2. Friction ``mu`` identified from the measured yaw rate only (identification.py), on the
       first ``fit_fraction`` of the log's duration (the *fit window*).
    3. Simulated open loop over the whole log from the measured steering and speed: nonlinear
       model without relaxation (1)-(3) (exact slip), TS model (24) with relaxation (its sector
       taken from the trajectory), and the linear bicycle for reference.
    Fit metrics against the measured yaw rate and the INS lateral velocity: ``fits`` over the
    whole log, ``fits_heldout`` over the samples after the fit window only (``t_split`` [s]).
    """
    if not 0.0 < fit_fraction < 1.0:
        raise ObserverArgumentError(f"revs_fig1: fit_fraction must be in (0, 1), got {fit_fraction!r}")
    delta, spikes = despike(log.delta, spike_threshold)
    t_split = float(log.t[0] + fit_fraction * (log.t[-1] - log.t[0]))
    fit_window = log.t <= t_split
    mu, p, _ = identify_friction(base, log.segment(log.t[0], t_split), delta[fit_window])
    X_nl = lateral.simulate_s1([0.0, log.yaw_rate[0]], delta, log.vx, log.dt, p, exact=True,
                               relaxation=False)
    X_rel = lateral.simulate_s1([0.0, log.yaw_rate[0], 0.0, 0.0], delta, log.vx, log.dt, p,
                                exact=False, relaxation=True)
    af, ar = lateral.slip_angles(X_rel[:, 0], X_rel[:, 1], delta, log.vx, p, exact=False)
    alpha_max = float(max(np.abs(af).max(), np.abs(ar).max()))
    Mf, Mr, vxb = sector_from_trajectory(p, alpha_max, log.vx)
    ts = lateral.yacine_ts(p, Mf=Mf, Mr=Mr, vx_bounds=vxb)
    x0 = lateral.to_transformed(X_rel[:1], p)[0]
    x_ts, oob = lateral.simulate_ts(ts, x0, delta, log.vx, log.dt, p)
    X_lin = lateral.simulate_s1([0.0, log.yaw_rate[0]], delta, log.vx, log.dt, linear,
                                exact=False, relaxation=False)
    models = {"nonlinear, no relaxation": X_nl[:, :2], "TS, relaxation": x_ts[:, :2],
              "linear bicycle": X_lin[:, :2]}
    x_rel_t = lateral.to_transformed(X_rel, p)
    return {"mu": mu, "params": p, "spikes": spikes, "alpha_max_deg": np.degrees(alpha_max),
            "ts": ts, "n_out_of_bounds": int(oob.sum()), "models": models,
            "fits": _fits(models, log), "fits_heldout": _fits(models, log, ~fit_window),
            "t_split": t_split,
            "ts_vs_nl_rel": float((np.abs(x_ts - x_rel_t) / np.abs(x_rel_t).max(axis=0)).max()),
            "delta": delta}


def emulated_fig1(p: LateralParams, ts: SectorTS, log: DriveLog, t_from: float = 1.0) -> dict:
    """Yacine 2015 Fig. 1 on the paper's configuration: open-loop models driven by the
    *measured* steering and speed of an emulated run of the paper's car (its parameters, its
    sensors at 1 kHz with their noise), compared with the measured yaw rate (gyro) and the
    true lateral velocity. Nothing is fitted: every parameter is the paper's (Table I, the
    sector bounds of Sec. IV) or the Pacejka tyres chosen so that the sector bounds hold.

    Models (all from ``[v_y, r] = 0`` at the start of the run, the car at rest):

    * ``"TS, relaxation"``: the TS form (24) with the printed sector ``ts`` integrated by
      itself (premises from its own state, RK4, 10 sub-steps per sample);
    * ``"nonlinear, no relaxation"``: model (1) with the exact slip (3) and Pacejka (7);
    * ``"linear bicycle"``: model (1) with linear tyres of the paper's zero-slip stiffnesses
      ``M_f1, M_r1`` (the upper sector bounds) and small-angle slip (4), the open-loop baseline.

    Parameters
    ----------
    p : the car of the models (the paper's: ``yacine_2015.constants.params``).
    ts : the TS model (24) with the paper's bounds (``constants.ts_model()``).
    log : emulated run (``scenarios.emulated_satory``) with measured ``delta`` [rad], ``vx``
        [m/s], ``yaw_rate`` [rad/s] and true ``vy`` [m/s], shape (N,).
    t_from : fits computed on ``t - t[0] > t_from`` [s] (the first second at 0.2 m/s is the
        car pulling away).

    Returns
    -------
    dict with ``models`` ``{name: (N, 2) [v_y, r]}``, ``fits`` (as :func:`revs_fig1`),
    ``n_out_of_bounds`` (samples where the TS premises left the printed sector: the TS form
    is then clipped, not exact) and ``alpha_max_deg`` (largest slip of the TS run [deg]).
    """
    x_ts, oob = lateral.simulate_ts(ts, np.zeros(4), log.delta, log.vx, log.dt, p)
    X_nl = lateral.simulate_s1([0.0, 0.0], log.delta, log.vx, log.dt, p, exact=True,
                               relaxation=False)
    lin = replace(p, tire_f=LinearTire(float(ts.zmax[1])), tire_r=LinearTire(float(ts.zmax[0])),
                  name=f"{p.name}, linear tyres")
    X_lin = lateral.simulate_s1([0.0, 0.0], log.delta, log.vx, log.dt, lin, exact=False,
                                relaxation=False)
    models = {"nonlinear, no relaxation": X_nl[:, :2], "TS, relaxation": x_ts[:, :2],
              "linear bicycle": X_lin[:, :2]}
    af, ar = lateral.slip_angles(x_ts[:, 0], x_ts[:, 1], log.delta, log.vx, p, exact=False)
    mask = log.t - log.t[0] > t_from
    return {"models": models, "fits": _fits(models, log, mask), "n_out_of_bounds": int(oob.sum()),
            "alpha_max_deg": float(np.degrees(max(np.abs(af).max(), np.abs(ar).max()))),
            "t_from": t_from}


def fig1_metrics(res: dict, prefix: str, where: str) -> dict:
    """The metrics of one :func:`emulated_fig1` result as ``{name: (value, unit, note)}``: the
    fits of every model (:func:`revs_fit_metrics` naming), the samples of the TS run outside
    the printed sector and its largest slip angle [deg]; ``where`` names the run in the notes."""
    out = revs_fit_metrics(res["fits"], prefix, where)
    out[f"{prefix}_ts_out_of_bounds"] = (res["n_out_of_bounds"], "",
                                         f"samples of the TS run outside the printed sector ({where})")
    out[f"{prefix}_alpha_max_deg"] = (res["alpha_max_deg"], "deg",
                                      f"largest slip angle of the TS run ({where})")
    return out

def fig1_figure(log: DriveLog, models: dict, title: str, t_window=None):
    """Fig. 1 layout: yaw rate (measured and models) and lateral velocity (truth and models)
    [rad/s, m/s], then each model's error against them; ``t_window`` ``(t0, t1)`` [s] zooms
    on a part of the run. ``models`` ``{name: (N, 2) [v_y, r]}``."""
    sel = np.ones(len(log.t), bool) if t_window is None else (log.t >= t_window[0]) & (log.t <= t_window[1])
    t = log.t[sel]
    styles = {"nonlinear, no relaxation": dict(ls="--", color=TRUTH, lw=1.0),
              "TS, relaxation": dict(color=PALETTE[0], lw=0.9),
              "linear bicycle": dict(color=PALETTE[1], lw=0.8)}
    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(10.5, 8.0),
                             gridspec_kw={"height_ratios": [2, 1, 2, 1]})
    for k, (ref, ref_lab, lab, unit) in enumerate(((log.yaw_rate, "measured (gyro)", "r", "rad/s"),
                                                    (log.vy, "truth", "v_y", "m/s"))):
        ax, ae = axes[2 * k + 1 - 1], axes[2 * k + 1]
        ax.plot(t, ref[sel], color="0.6", lw=2.0, label=ref_lab)
        for name, X in models.items():
            col = 1 - k                        # X = [v_y, r]: column 1 is r, column 0 is v_y
            ax.plot(t, X[sel, col], label=name, **styles.get(name, {}))
            ae.plot(t, X[sel, col] - ref[sel], **styles.get(name, {}))
        ax.set_ylabel(f"${lab}$ [{unit}]")
        ae.set_ylabel(f"model $-$ {ref_lab.split()[0]} [{unit}]")
        ae.axhline(0, color="0.6", lw=0.5)
        ax.legend(fontsize=7)
    axes[-1].set_xlabel("$t$ [s]")
    fig.suptitle(title)
    return legends_outside(fig)


#: metric-name key of each model of :func:`revs_fig1`
FIT_KEYS = {"nonlinear, no relaxation": "nl", "TS, relaxation": "ts", "linear bicycle": "lin"}
_FIT_UNITS = {"yaw_rmse": "rad/s", "vy_rmse": "m/s"}


_FIT_WORDS = {"yaw_rmse": "yaw-rate RMSE", "yaw_corr": "yaw-rate correlation",
              "yaw_fit": "yaw-rate fit [%]", "vy_rmse": "v_y RMSE", "vy_corr": "v_y correlation"}


def revs_fit_metrics(fits: dict, prefix: str = "revs", where: str = "whole log") -> dict:
    """Flatten ``fits`` of :func:`revs_fig1` into ``{"<prefix>_<model>_<fit>": (value, unit,
    description)}`` (model keys :data:`FIT_KEYS`; RMSE in rad/s or m/s, correlations and fit %
    unitless; the description names the model and ``where`` the fit is computed)."""
    return {f"{prefix}_{key}_{k}": (v, _FIT_UNITS.get(k, ""), f"{name}: {_FIT_WORDS[k]} ({where})")
            for name, key in FIT_KEYS.items() for k, v in fits[name].items()}


#: column headers of :func:`fit_rows` (fit key -> header with unit)
FIT_COLUMNS = {"yaw_rmse": "yaw-rate RMSE [rad/s]", "yaw_corr": "yaw-rate correlation",
               "yaw_fit": "yaw-rate fit [%]", "vy_rmse": "v_y RMSE [m/s]",
               "vy_corr": "v_y correlation"}


def fit_rows(fits: dict, title: str = ""):
    """One row per model of :func:`revs_fig1` (yaw-rate RMSE [rad/s], correlation and fit [%],
    v_y RMSE [m/s] and correlation; headers :data:`FIT_COLUMNS`), as a rounded table."""
    rows = [{"model": name, **{FIT_COLUMNS[k]: v for k, v in f.items()}} for name, f in fits.items()]
    return show_table(rows, ["model", *FIT_COLUMNS.values()], title=title)


def bicycle_exactness(bp: bicycle.BicycleParams, duration: float = 10.0, dt: float = 1e-3,
                      margin: float = 0.01) -> dict:
    """Ichalal 2011 Fig. 2 analogue: closed-loop nonlinear bicycle vs its 8-rule TS form.

    Premise bounds are the trajectory's ranges widened by ``margin`` (relative).
    """
    t = time_grid(duration, dt)
    X, u = bicycle.simulate(bp, t)
    z = bicycle.ts_premises(X, u, bp)
    lo, hi = z.min(axis=0), z.max(axis=0)
    span = np.maximum(hi - lo, 1e-6 * np.maximum(np.abs(hi), 1.0))
    bounds = list(zip(lo - margin * span, hi + margin * span))
    ts = bicycle.bicycle_ts(bp, bounds)
    X_ts, u_ts = bicycle.simulate(bp, t, ts=ts)
    res = ts.exactness(X, u, lambda x_, u_: bicycle.rhs(x_, np.ravel(u_), bp))
    res["max_rel_traj_diff"] = float((np.abs(X_ts - X) / np.abs(X).max(axis=0)).max())
    res["bounds"] = bounds
    res["run"] = Run(t, {"u": u, "u_ts": u_ts}, {"x_nl": X, "x_ts": X_ts})
    res["ts"] = ts
    return res


# ---------------------------------------------------------------------------- figures --------

def legends_outside(fig, width: float = 0.22):
    """Move every legend of ``fig`` to the right of its axes (off the data); the axes give up
    ``width`` of the figure's width. Returns ``fig``."""
    for ax in fig.axes:
        if ax.get_legend() is not None:
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    fig.tight_layout(rect=(0, 0, 1.0, 1.0))
    return fig


def tyre_sector_figure(tires: dict, alpha_max: float, bounds: dict | None = None):
    """Force and secant stiffness of tyres ``{name: Pacejka}`` over ``|alpha| <= 1.5 alpha_max``
    [rad], with the sector bounds ``{name: (M_min, M_max)}`` [N/rad] drawn as the lines
    ``M alpha`` (left) and as horizontal lines (right); the sector's slip range is shaded.
    Forces in kN, slip in degrees; legends to the right of the axes."""
    a = np.linspace(-1.5 * alpha_max, 1.5 * alpha_max, 601)
    deg = np.degrees(a)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10.5, 3.6))
    for j, (name, tyre) in enumerate(tires.items()):
        c = PALETTE[j % len(PALETTE)]
        ax1.plot(deg, tyre.force(a) / 1e3, color=c, label=f"{name}: $F^S(\\alpha)$ (7)")
        ax2.plot(deg, tyre.secant_stiffness(a) / 1e3, color=c, label=f"{name}: $f(\\alpha)$ (16)")
        if bounds and name in bounds:
            for M, ls in zip(bounds[name], ("--", ":")):
                which = "min" if ls == "--" else "max"
                ax1.plot(deg, M * a / 1e3, ls, color=c, lw=0.9,
                         label=f"{name}: $M_{{\\rm {which}}}\\,\\alpha$")
                ax2.axhline(M / 1e3, ls=ls, color=c, lw=0.9, label=f"{name}: $M_{{\\rm {which}}}$")
    for ax in (ax1, ax2):
        ax.axvspan(-np.degrees(alpha_max), np.degrees(alpha_max), color="0.92", zorder=0,
                   label=None)
        ax.set_xlabel(r"slip angle $\alpha$ [deg]")
    ax1.set_ylabel(r"lateral force $F^S$ [kN]")
    ax2.set_ylabel(r"secant stiffness $f = F^S/\alpha$ [kN/rad]")
    ax1.set_title(r"Pacejka (7) between the sector lines $M\,\alpha$")
    ax2.set_title(r"premise $f(\alpha)$ (16) and its bounds (shaded: $|\alpha| \leq \alpha_{\max}$)")
    ax1.legend(fontsize=7)
    ax2.legend(fontsize=7)
    return legends_outside(fig)


def exactness_figure(t, x_nl, x_ts, states: list[tuple[str, str]], title: str,
                     inputs: dict | None = None, nl_label: str = "nonlinear", ts_label: str = "TS"):
    """States of a nonlinear model and of its TS form integrated by itself (left column, the
    TS dashed over the nonlinear) and their difference TS - nonlinear in the state's unit
    (right column: the curves on the left coincide, so the difference is what can be read).
    ``states[i] = (name, unit)``: mathtext name without ``$`` (``"x_1 = v_y"``; the part before
    ``=`` names the difference) and unit of state ``i``; ``inputs`` ``{label with unit: (N,)
    signal}`` adds a top row (at most two). x_nl, x_ts (N, n)."""
    rows = len(states) + (1 if inputs else 0)
    fig, axes = plt.subplots(rows, 2, sharex=True, figsize=(11.0, 1.75 * rows + 0.7), squeeze=False)
    i0 = 0
    if inputs:
        for j, (lab, u) in enumerate(inputs.items()):
            axes[0, j].plot(t, u, color=TRUTH, lw=0.8)
            axes[0, j].set_ylabel(lab)
        i0 = 1
    for i, (name, unit) in enumerate(states):
        ax, axd = axes[i0 + i]
        ax.plot(t, x_nl[:, i], color=TRUTH, lw=1.6, label=nl_label)
        ax.plot(t, x_ts[:, i], "--", color=PALETTE[1], lw=1.0, label=ts_label)
        ax.set_ylabel(f"${name}$ [{unit}]")
        axd.plot(t, x_ts[:, i] - x_nl[:, i], color=PALETTE[0], lw=0.8)
        axd.set_ylabel(f"$\\Delta {name.split('=')[0].strip()}$ [{unit}]")
        axd.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
    axes[i0, 0].set_title("states (TS dashed over nonlinear)")
    axes[i0, 1].set_title(r"$\Delta$ = TS $-$ nonlinear (round-off level)")
    for ax in axes[-1]:
        ax.set_xlabel("$t$ [s]")
    fig.suptitle(title)
    h = fig.get_figheight()
    # the legend goes below the x labels, in a strip of its own (never over a panel)
    fig.legend(*axes[i0, 0].get_legend_handles_labels(), loc="lower center", ncol=2,
               bbox_to_anchor=(0.5, 0.0), frameon=False)
    fig.tight_layout(rect=(0, 0.35 / h, 1, 1.0 - 0.1 / h))
    return fig


# ------------------------------------------------------- teaching: the sector construction ----

def sector_weights(z, zmin: float, zmax: float):
    """The two weights of one premise ``z`` in ``[zmin, zmax]``: ``h1 = (zmax - z)/(zmax - zmin)``
    (weight of the lower bound), ``h2 = 1 - h1`` (weight of the upper bound), so that
    ``z = h1 zmin + h2 zmax`` exactly. Not clipped: outside the range one weight is negative."""
    z = np.asarray(z, dtype=float)
    h1 = (zmax - z) / (zmax - zmin)
    return h1, 1.0 - h1


def sector_sweep_figure(tyre, alpha_max: float, alpha_end: float, name: str = "front"):
    """The frame of the sector animation: left, the tyre force ``F^S(alpha)`` [kN] between its
    sector lines ``M_min alpha`` and ``M_max alpha`` (``M`` over ``|alpha| <= alpha_max``),
    a moving premise point; right, the two weights ``h1, h2`` as bars. Returns
    ``(fig, update)`` where ``update(alpha)`` [rad] moves the point (for
    :func:`vehicle_observers.results.teaching.animation`)."""
    Mmin, Mmax = tyre.sector_bounds(alpha_max)
    a = np.linspace(0.0, alpha_end, 300)
    deg = np.degrees(a)
    fig, (ax, axh) = plt.subplots(1, 2, figsize=(7.2, 2.9), gridspec_kw={"width_ratios": [2.2, 1]})
    ax.fill_between(deg, Mmin * a / 1e3, Mmax * a / 1e3, color=PALETTE[7], alpha=0.6, lw=0)
    ax.plot(deg, tyre.force(a) / 1e3, color=TRUTH, lw=1.4, label=f"$F^S$ ({name})")
    ax.plot(deg, Mmax * a / 1e3, "--", color=PALETTE[0], lw=1.0, label=r"$M_{\max}\alpha$")
    ax.plot(deg, Mmin * a / 1e3, "--", color=PALETTE[1], lw=1.0, label=r"$M_{\min}\alpha$")
    ax.axvline(np.degrees(alpha_max), color="0.5", lw=0.8, ls=":")
    (seg,) = ax.plot([], [], color=PALETTE[3], lw=3.0, alpha=0.7, solid_capstyle="butt")
    (pt,) = ax.plot([], [], "o", color=PALETTE[5], ms=6)
    ax.set_xlabel(r"slip angle $\alpha$ [deg]")
    ax.set_ylabel(r"$F^S$ [kN]")
    ax.legend(loc="upper left", fontsize=7)
    bars = axh.bar([0, 1], [0.5, 0.5], color=[PALETTE[1], PALETTE[0]], width=0.6)
    axh.set_xticks([0, 1], [r"$h_1$ (to $M_{\min}$)", r"$h_2$ (to $M_{\max}$)"])
    axh.set_ylim(-0.6, 1.6)
    axh.axhspan(0, 1, color="0.93", zorder=0)
    axh.set_ylabel("weight [-]")
    txt = ax.set_title("")

    def update(alpha):
        alpha = max(float(alpha), 1e-9)
        f = float(tyre.secant_stiffness(alpha))
        h1, h2 = sector_weights(f, Mmin, Mmax)
        d = np.degrees(alpha)
        seg.set_data([d, d], [Mmin * alpha / 1e3, Mmax * alpha / 1e3])
        pt.set_data([d], [tyre.force(alpha) / 1e3])
        inside = 0 <= h1 <= 1
        for b, h in zip(bars, (h1, h2)):
            b.set_height(h)
            b.set_alpha(1.0 if inside else 0.45)
        txt.set_text(f"$\\alpha$ = {d:.1f} deg: " + ("inside" if inside else "OUTSIDE the sector"))
        return seg, pt, *bars, txt

    update(alpha_end)       # the longest title, so the layout keeps room for it
    fig.tight_layout()
    return fig, update


def sector_range_figure(tyre, alpha_max: float, alpha_span: float):
    """For the widget: the sector taken over ``|alpha| <= alpha_max`` [rad]. Left, the force
    [kN] and its sector lines over ``[0, alpha_span]``; right, the relative error of the TS
    blend with *clipped* weights, ``|sum h_i M_i alpha - F^S(alpha)| / max |F^S|`` [%]: zero
    inside the range, growing outside. The title gives the sector's width."""
    Mmin, Mmax = tyre.sector_bounds(alpha_max)
    a = np.linspace(1e-6, alpha_span, 400)
    F = tyre.force(a)
    f = np.clip(tyre.secant_stiffness(a), Mmin, Mmax)
    h1, h2 = sector_weights(f, Mmin, Mmax)
    F_ts = (h1 * Mmin + h2 * Mmax) * a
    err = 100 * np.abs(F_ts - F) / np.abs(F).max()
    deg = np.degrees(a)
    fig, (ax, axe) = plt.subplots(1, 2, figsize=(9.0, 3.0))
    ax.fill_between(deg, Mmin * a / 1e3, Mmax * a / 1e3, color=PALETTE[7], alpha=0.6, lw=0)
    ax.plot(deg, F / 1e3, color=TRUTH, lw=1.4, label="$F^S$")
    ax.plot(deg, Mmax * a / 1e3, "--", color=PALETTE[0], label=r"$M_{\max}\alpha$")
    ax.plot(deg, Mmin * a / 1e3, "--", color=PALETTE[1], label=r"$M_{\min}\alpha$")
    for x in (ax, axe):
        x.axvspan(0, np.degrees(alpha_max), color="0.93", zorder=0)
        x.set_xlabel(r"slip angle $\alpha$ [deg]")
    ax.set_ylabel("$F^S$ [kN]")
    ax.legend(loc="upper left", fontsize=7)
    ax.set_title(f"sector [{Mmin / 1e3:.1f}, {Mmax / 1e3:.1f}] kN/rad "
                 f"(width {(Mmax - Mmin) / 1e3:.1f} kN/rad)")
    axe.plot(deg, err, color=PALETTE[5])
    axe.set_ylabel(r"clipped-TS error [% of max $|F^S|$]")
    axe.set_title("exact inside the shaded range only")
    fig.tight_layout()
    return fig
