"""Plots of the benchmark (notebook 07 and ``make bench``); one colour per estimator
(:func:`vehicle_observers.results.plotting.color`)."""

from __future__ import annotations

import numpy as np
from vehicle_observers.core.arrays import decimate
from vehicle_observers.results.plotting import TRUTH, color, grouped_bars


def _row_value(rows, key):
    """``value(dataset, observer)`` of :func:`grouped_bars`: ``key`` of the matching row."""
    def value(d, o):
        r = next((r for r in rows if r["dataset"] == d and r["observer"] == o), None)
        return None if r is None else r.get(key, np.nan)
    return value


def _groups(rows):
    return (list(dict.fromkeys(r["dataset"] for r in rows)),
            list(dict.fromkeys(r["observer"] for r in rows)))


def fig_rmse(rows, target: float = 0.24):
    """$v_y$ RMSE per dataset and observer (log scale), the real-log target as a dotted line;
    legend beside the axes."""
    import matplotlib.pyplot as plt

    ds, obs = _groups(rows)
    fig, ax = plt.subplots(figsize=(10, 4.2))
    grouped_bars(ax, ds, obs, _row_value(rows, "rmse_vy"), log=True)
    ax.set_ylabel(r"$v_y$ RMSE [m/s]")
    ax.set_xlabel("dataset")
    ax.axhline(target, color=TRUTH, ls=":", lw=0.8, label=f"real-log target {target:g} m/s")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    return fig


def fig_rmse_cost(rows):
    """Accuracy and wall-clock cost per step side by side (``make bench`` only: the cost
    changes on every run, so this figure is not part of the committed notebook figures)."""
    import matplotlib.pyplot as plt

    ds, obs = _groups(rows)
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.2))
    grouped_bars(ax[0], ds, obs, _row_value(rows, "rmse_vy"), log=True)
    grouped_bars(ax[1], ds, obs, _row_value(rows, "us_per_step"), log=True)
    ax[0].set_ylabel(r"$v_y$ RMSE [m/s]")
    ax[1].set_ylabel(r"cost per step [$\mu$s]")
    ax[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    return fig


def fig_revs(log, ests, t_zoom=None):
    """$v_y$ estimates on the Revs log against the INS reference: the whole run and the
    zoom ``t_zoom`` [s] (default the first 40 s); interval observers as shaded boxes."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 1, figsize=(10, 6.4))
    names = [n for n in ("ekf", "ukf", "rts", "interval-ifqir2017") if n in ests]
    for a, (t0, t1) in zip(ax, ((log.t[0], log.t[-1]), t_zoom or (log.t[0], log.t[0] + 40))):
        m = (log.t >= t0) & (log.t <= t1)
        tt, ref = decimate(log.t[m], log.vy[m], max_points=3000)
        for k, n in enumerate(names):
            e = ests[n]
            if len(e.t) != len(log):
                mm = (e.t >= t0) & (e.t <= t1)
                if not mm.any():
                    continue
                te, v = decimate(e.t[mm], e.columns["vy_mps"][mm], max_points=3000)
            else:
                te, v = decimate(log.t[m], e.columns["vy_mps"][m], max_points=3000)
            if "vy_lo_mps" in e.columns:
                _, lo, hi = decimate(log.t[m], e.columns["vy_lo_mps"][m],
                                     e.columns["vy_hi_mps"][m], max_points=3000)
                a.fill_between(te, lo, hi, color=color(n, k), alpha=0.15, lw=0,
                               label=f"{n} [lo, hi]")
            else:
                a.plot(te, v, color=color(n, k), lw=0.8, label=n)
        a.plot(tt, ref, color=TRUTH, lw=0.9, label="INS reference")
        a.set_ylabel("v_y [m/s]")
    ax[0].legend(ncol=5, fontsize=7, loc="upper right")
    ax[1].set_xlabel("t [s]")
    ax[0].set_title("Revs 250 LM: lateral velocity estimates")
    return fig


def fig_losses(loss_rows):
    """$v_y$ RMSE per bin of each factor of :func:`.runs.revs_losses` (one panel per factor,
    tick labels: bin and share of the samples)."""
    import matplotlib.pyplot as plt

    factors = list(dict.fromkeys(r["factor"] for r in loss_rows))
    names = [k for k in loss_rows[0] if k not in ("factor", "bin", "share")]
    fig, ax = plt.subplots(1, len(factors), figsize=(13, 4.4), sharey=True)
    labels = {"|a_y| [m/s^2]": r"$|a_y|$ [m/s$^2$]", "v_x [m/s]": r"$v_x$ [m/s]",
              "|a_y - (dv_y/dt + v_x r)| [m/s^2]": r"$|a_y - (\dot v_y + v_x r)|$ [m/s$^2$]"}
    for a, f in zip(np.atleast_1d(ax), factors):
        rr = [r for r in loss_rows if r["factor"] == f]
        ticks = [f"{r['bin']}\n{100 * r['share']:.0f} %" for r in rr]
        grouped_bars(a, range(len(rr)), names, lambda i, n: rr[i].get(n, np.nan), labels=ticks)
        a.set_xticklabels(ticks, fontsize=7)
        a.set_xlabel(labels.get(f, f) + "\n(bin, share of samples)")
    np.atleast_1d(ax)[0].set_ylabel(r"$v_y$ RMSE [m/s]")
    np.atleast_1d(ax)[-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                                 borderaxespad=0)
    return fig


def fig_plant(rows: list[dict]):
    """Bar chart of v_y RMSE [m/s] per plant manoeuvre and estimator, with the target line
    0.8 x open loop drawn per manoeuvre (for notebook 07 / the closing note)."""
    import matplotlib.pyplot as plt

    ds, obs = _groups(rows)
    fig, ax = plt.subplots(figsize=(8, 3.8))
    w = grouped_bars(ax, ds, obs, _row_value(rows, "rmse_vy"),
                     labels=[d.replace("plant_", "") for d in ds])
    for i, d in enumerate(ds):
        ol = next(r["rmse_vy"] for r in rows if r["dataset"] == d
                  and r["observer"] == "open-loop-linear")
        ax.hlines(0.8 * ol, i - w / 2, i + 0.8 - w / 2, colors=TRUTH, linestyles=":", lw=1)
    ax.set_ylabel("$v_y$ RMSE [m/s]")
    ax.set_title("Independent multi-body plant (dotted: target 0.8 x open-loop linear)")
    ax.legend(fontsize=7, ncol=3, loc="upper left", bbox_to_anchor=(0, -0.12))
    fig.tight_layout()
    return fig


def fig_leaderboard(table: list[dict], open_loop: float = 0.8, linear_kf: float = 0.85):
    """Leaderboard (:mod:`vehicle_observers_papers.leanza_2021.leaderboard`): one panel per
    dataset, $v_y$ RMSE of every estimator relative to the open-loop linear bicycle on that
    dataset (log scale; hatched: not causal), with the plant targets ``open_loop`` (dotted)
    and ``linear_kf`` x the ``linear-kf-ml`` row (dashed)."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter

    ol = {r["dataset"]: r["rmse_vy"] for r in table if r["observer"] == "open-loop-linear"}
    ds, obs = _groups([r for r in table if r["dataset"] in ol])
    fig, axes = plt.subplots(1, len(ds), figsize=(2.6 * len(ds) + 2.2, 0.28 * len(obs) + 1.6),
                             sharey=True, squeeze=False)
    y = np.arange(len(obs))
    for a, d in zip(axes[0], ds):
        rr = {r["observer"]: r for r in table if r["dataset"] == d}
        for j, o in enumerate(obs):
            if o in rr:
                a.barh(j, rr[o]["rmse_vy"] / ol[d], color=color(o, j), height=0.75,
                       hatch=None if rr[o]["causal"] else "//", edgecolor="white", lw=0)
        a.axvline(1.0, color="0.6", lw=0.6)
        if d.startswith("plant_"):
            a.axvline(open_loop, color=TRUTH, ls=":", lw=1.2, label=f"{open_loop:g} x open loop")
            if "linear-kf-ml" in rr:
                a.axvline(linear_kf * rr["linear-kf-ml"]["rmse_vy"] / ol[d], color=TRUTH, ls="--",
                          lw=1.2, label=f"{linear_kf:g} x linear-kf-ml")
        a.set_xscale("log")
        a.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        a.xaxis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}" if v in (0.5, 2, 3) else ""))
        a.set_title(d.replace("plant_", "plant: "), fontsize=9)
        a.set_xlabel(r"$v_y$ RMSE / open loop's")
    axes[0][0].set_yticks(y)
    axes[0][0].set_yticklabels(obs, fontsize=8)
    axes[0][0].invert_yaxis()
    h = next((a for a in axes[0] if a.get_legend_handles_labels()[0]), None)
    if h is not None:
        h.legend(fontsize=7, loc="lower right")
    fig.suptitle("Leaderboard: v_y RMSE relative to the open-loop linear bicycle "
                 "(hatched: not causal; dotted / dashed: targets)", fontsize=10)
    return fig
