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


#: readable names of the benchmark's datasets (tick labels)
DATASET_LABELS = {"satory_n1": "Satory lap\nnoise x1", "satory_n3": "Satory lap\nnoise x3",
                  "swd": "sine with dwell\n(17 m/s, 7 deg slip)", "revs": "Revs 250 LM\n(real log)"}


def _same_bars(rows, obs):
    """``{kept: [dropped, ...]}``: observers whose v_y RMSE equals a previous one's on every
    dataset (e.g. ``interval-coordinates`` = ``interval-ifqir2017`` when its design keeps
    ``kappa = 0``): one bar is drawn for them, labelled with both names."""
    val = {o: {r["dataset"]: r.get("rmse_vy") for r in rows if r["observer"] == o} for o in obs}
    same: dict[str, list[str]] = {}
    dropped = set()
    for j, o in enumerate(obs):
        if o in dropped:
            continue
        for p in obs[j + 1:]:
            if p not in dropped and val[p] and val[p].keys() == val[o].keys() and all(
                    np.isclose(val[p][d], val[o][d], rtol=1e-9, atol=0) for d in val[o]):
                same.setdefault(o, []).append(p)
                dropped.add(p)
    return same, dropped


def fig_rmse(rows, target: float = 0.24, target_dataset: str = "revs"):
    """$v_y$ RMSE per dataset and observer: the emulated runs (log scale) and the real log
    ``target_dataset`` (linear scale, the accuracy target ``target`` [m/s] drawn there only).
    Rows scored on a shorter window than the others of their dataset (the pure-Python filterpy
    rows, ``samples`` column) are hatched and their legend entry says so; observers with the
    same RMSE on every dataset share one bar."""
    import matplotlib.pyplot as plt

    ds, obs = _groups(rows)
    same, dropped = _same_bars(rows, obs)
    obs = [o for o in obs if o not in dropped]
    full = {d: max(r["samples"] for r in rows if r["dataset"] == d) for d in ds}
    windowed = {(r["dataset"], r["observer"]) for r in rows if r["samples"] < full[r["dataset"]]}
    win_n = sorted({r["samples"] for r in rows if (r["dataset"], r["observer"]) in windowed})
    emu = [d for d in ds if d != target_dataset]
    real = [d for d in ds if d == target_dataset]
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), gridspec_kw={
        "width_ratios": [max(len(emu), 1), max(len(real), 1) + 0.4, 1.5]})
    w = 0.8 / max(len(obs), 1)
    value = _row_value(rows, "rmse_vy")
    for ax, group, log in ((axes[0], emu, True), (axes[1], real, False)):
        for j, o in enumerate(obs):
            for i, d in enumerate(group):
                v = value(d, o)
                if v is None or not np.isfinite(v):
                    continue
                hatched = (d, o) in windowed
                ax.bar(i + j * w, v, w, color=color(o, j), hatch="///" if hatched else None,
                       edgecolor="white" if hatched else None, lw=0)
        ax.set_xticks(np.arange(len(group)) + 0.4 - w / 2)
        ax.set_xticklabels([DATASET_LABELS.get(d, d) for d in group])
        if log:
            ax.set_yscale("log")
        ax.set_ylabel(r"$v_y$ RMSE [m/s]")
    axes[0].set_title("emulated runs (truth known; log scale)")
    axes[1].set_title("real log (INS reference)")
    if real:
        axes[1].hlines(target, -0.5 * w, 0.8 - 0.5 * w, colors=TRUTH, linestyles=":", lw=1.2,
                       label=f"Revs target {target:g} m/s (best causal)")
        axes[1].set_xlim(-0.5, 1.1)
    handles = []
    from matplotlib.patches import Patch

    for j, o in enumerate(obs):
        label = " = ".join([o, *same.get(o, [])])
        if any(oo == o for _, oo in windowed):
            label += f" (first {', '.join(f'{n:g}' for n in win_n)} samples)"
        hatched = any(oo == o for _, oo in windowed)
        handles.append(Patch(facecolor=color(o, j), hatch="///" if hatched else None,
                             edgecolor="white" if hatched else color(o, j), label=label))
    h, lab = axes[1].get_legend_handles_labels()
    axes[2].axis("off")                      # the legend's own column, off the data
    axes[2].legend(handles=handles + h, fontsize=7, loc="upper left", borderaxespad=0,
                   title="hatched: scored on a window only", title_fontsize=7)
    fig.tight_layout()
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
    r"""$v_y$ estimates on the Revs log against the INS reference: the whole run (the zoom
    window shaded), the zoom ``t_zoom`` [s] (default the first 40 s) and the error
    $\hat v_y - v_y^{INS}$ in the zoom; interval observers as shaded boxes. Legend above the
    axes (off the data)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(3, 1, figsize=(10, 7.8), gridspec_kw={"height_ratios": [1.0, 1.1, 0.8]})
    names = [n for n in ("ekf", "ukf", "rts", "interval-ifqir2017") if n in ests]
    zoom = t_zoom or (log.t[0], log.t[0] + 40)
    for a, (t0, t1) in zip(ax[:2], ((log.t[0], log.t[-1]), zoom)):
        m = (log.t >= t0) & (log.t <= t1)
        tt, ref = decimate(log.t[m], log.vy[m], max_points=3000)
        for k, n in enumerate(names):
            e = ests[n]
            if len(e.t) != len(log):
                mm = (e.t >= t0) & (e.t <= t1)
                if not mm.any():
                    continue
                te, v = decimate(e.t[mm], e.columns["vy_mps"][mm], max_points=3000)
                label = f"{n} (first {len(e.t)} samples)"
            else:
                te, v = decimate(log.t[m], e.columns["vy_mps"][m], max_points=3000)
                label = n
            if "vy_lo_mps" in e.columns:
                _, lo, hi = decimate(log.t[m], e.columns["vy_lo_mps"][m],
                                     e.columns["vy_hi_mps"][m], max_points=3000)
                a.fill_between(te, lo, hi, color=color(n, k), alpha=0.2, lw=0,
                               label=f"{n} $[\\underline{{v}}_y, \\overline{{v}}_y]$")
            else:
                a.plot(te, v, color=color(n, k), lw=0.9, label=label)
        a.plot(tt, ref, color=TRUTH, lw=0.9, label="INS reference")
        a.set_ylabel(r"$v_y$ [m/s]")
        a.set_xlabel("t [s]")
    ax[0].axvspan(*zoom, color="0.6", alpha=0.25, lw=0, zorder=0)
    ax[0].set_title("Revs 250 LM: lateral velocity, whole run (grey: zoom below)", fontsize=9)
    ax[1].set_title(f"zoom {zoom[0]:g}-{zoom[1]:g} s", fontsize=9)
    m = (log.t >= zoom[0]) & (log.t <= zoom[1])
    for k, n in enumerate(names):
        e = ests[n]
        if len(e.t) != len(log) or "vy_lo_mps" in e.columns:
            continue
        te, err = decimate(log.t[m], e.columns["vy_mps"][m] - log.vy[m], max_points=3000)
        ax[2].plot(te, err, color=color(n, k), lw=0.9)
    ax[2].axhline(0.0, color=TRUTH, lw=0.6)
    ax[2].set_ylabel(r"$\hat v_y - v_y^{INS}$ [m/s]")
    ax[2].set_xlabel("t [s]")
    ax[2].set_title("error of the point estimates in the zoom", fontsize=9)
    ax[0].legend(ncol=5, fontsize=7, loc="lower left", bbox_to_anchor=(0.0, 1.12), borderaxespad=0)
    fig.tight_layout()
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


def fig_plant(rows: list[dict], margin: float = 0.8):
    """$v_y$ RMSE [m/s] per estimator on each plant manoeuvre, one panel (and y scale) per
    manoeuvre: the open-loop linear bicycle is the hollow black reference bar, the target
    ``margin`` x its RMSE the dotted line; each bar carries its value (3 significant digits,
    more on a bar that would print the same as another bar of its panel)."""
    import matplotlib.pyplot as plt

    ds, obs = _groups(rows)
    fig, axes = plt.subplots(1, len(ds), figsize=(3.3 * len(ds) + 0.6, 3.9), squeeze=False)
    for a, d in zip(axes[0], ds):
        rr = {r["observer"]: r["rmse_vy"] for r in rows if r["dataset"] == d}
        names = [o for o in obs if o in rr]
        vals = [rr[o] for o in names]
        for j, o in enumerate(names):
            digits = 3                       # more only where two bars would print the same
            while digits < 7 and any(f"{rr[o]:.{digits}g}" == f"{v:.{digits}g}"
                                     for p, v in rr.items() if p != o and v != rr[o]):
                digits += 1
            ref = o == "open-loop-linear"
            a.bar(j, rr[o], 0.75, color="white" if ref else color(o, j), edgecolor=TRUTH if ref else
                  "none", lw=1.2 if ref else 0)
            a.annotate(f"{rr[o]:.{digits}g}", (j, rr[o]), xytext=(0, 2), textcoords="offset points",
                       ha="center", va="bottom", fontsize=7)
        if "open-loop-linear" in rr:
            a.axhline(margin * rr["open-loop-linear"], color=TRUTH, ls=":", lw=1.2)
        a.set_xticks(range(len(names)))
        a.set_xticklabels(names, rotation=35, ha="right", fontsize=7)
        a.set_ylim(0, 1.18 * max(vals))
        a.set_title(d.replace("plant_", "").replace("_", " "), fontsize=9)
    axes[0][0].set_ylabel(r"$v_y$ RMSE [m/s]")
    fig.suptitle(f"Independent multi-body plant, one scale per manoeuvre (hollow: open-loop linear "
                 f"bicycle; dotted: target {margin:g} x its RMSE)", fontsize=9)
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
    ncol = min(len(ds), 5)
    nrow = -(-len(ds) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(2.6 * ncol + 2.2,
                                                  nrow * (0.28 * len(obs) + 1.2) + 0.4),
                             sharey=True, squeeze=False)
    for a in axes.flat[len(ds):]:
        a.set_visible(False)
    y = np.arange(len(obs))
    for a, d in zip(axes.flat, ds):
        rr = {r["observer"]: r for r in table if r["dataset"] == d}
        for j, o in enumerate(obs):
            if o in rr:
                a.barh(j, rr[o]["rmse_vy"] / ol[d], color=color(o, j), height=0.75,
                       hatch=None if rr[o]["causal"] else "//", edgecolor="white", lw=0)
        a.axvline(1.0, color="0.6", lw=0.6)
        if not d.startswith("revs"):
            a.axvline(open_loop, color=TRUTH, ls=":", lw=1.2, label=f"{open_loop:g} x open loop")
            if "linear-kf-ml" in rr:
                a.axvline(linear_kf * rr["linear-kf-ml"]["rmse_vy"] / ol[d], color=TRUTH, ls="--",
                          lw=1.2, label=f"{linear_kf:g} x linear-kf-ml")
        a.set_xscale("log")
        a.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        a.xaxis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}" if v in (0.5, 2, 3) else ""))
        a.set_title(d.replace("plant_", "plant: "), fontsize=9)
        a.set_xlabel(r"$v_y$ RMSE / open loop's [-]")
    for row in axes:
        row[0].set_yticks(y)
        row[0].set_yticklabels(obs, fontsize=8)
    axes[0][0].invert_yaxis()
    from matplotlib.patches import Patch

    # the key in the first panel with target lines (no suptitle: tight_layout, which the
    # report's savefig applies, lets a suptitle overlap the first row of a tall figure)
    h = next((a for a in axes.flat if a.get_legend_handles_labels()[0]), axes.flat[0])
    hs, ls = h.get_legend_handles_labels()
    hs.append(Patch(facecolor="0.85", hatch="//", edgecolor="white", label="not causal"))
    h.legend(handles=hs, fontsize=7, loc="lower right",
             title="v_y RMSE / open loop's", title_fontsize=7)
    return fig
