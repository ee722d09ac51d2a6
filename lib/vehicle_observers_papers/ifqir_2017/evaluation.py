"""Ifqir 2017 evaluation: the observer on a drive log, enclosure / width metrics, the
convergence time of the widths and the slides' figures (notebook 03).

Arrays ``(N, 2)`` have the columns ``[v_y (m/s), r (rad/s)]``; results are the
:class:`~vehicle_observers.observers.interval.IntervalRun` of the library's observer.
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.models import uncertain_bicycle as ub
from vehicle_observers.observers import interval as iv


def settling_time(t, w, w_ref, frac: float = 0.02) -> float:
    """Convergence time of an interval width from its initial box: the first time [s]
    (from ``t[0]``) after which ``|w - w_ref| <= frac * |w[0] - w_ref[0]|`` at every later
    sample, ``w_ref`` being the width of the same observer started from a point box (same
    inputs), so only the effect of the initial box is measured. ``inf`` if it never
    settles within the record. ``t``, ``w``, ``w_ref`` (N,)."""
    t, w, w_ref = (np.asarray(a, dtype=float) for a in (t, w, w_ref))
    if not (t.shape == w.shape == w_ref.shape) or t.ndim != 1 or len(t) < 2:
        raise ObserverArgumentError(f"settling_time: t, w, w_ref must be 1-D of equal length, got "
                                    f"{t.shape}, {w.shape}, {w_ref.shape}")
    if not 0 < frac < 1:
        raise ObserverArgumentError(f"settling_time: frac must be in (0, 1), got {frac}")
    dev = np.abs(w - w_ref)
    out = dev > frac * dev[0]
    if not out.any():
        return 0.0
    k = int(np.flatnonzero(out)[-1])
    return float("inf") if k == len(t) - 1 else float(t[k + 1] - t[0])


def interval_metrics(res: iv.IntervalRun, truth: np.ndarray, t: np.ndarray | None = None,
                     t_skip: float = 0.0, tol: float = 0.0, mask=None,
                     width_t_skip: float | None = None) -> dict:
    """Enclosure rate of ``truth`` (N, 2) (NaN columns are skipped) and mean / max widths of
    ``v_y`` [m/s] and ``r`` [rad/s], over samples with ``t >= t[0] + t_skip`` (and ``mask``
    (N,) bool if given). ``max_excursion_*``: largest distance outside the interval.
    ``width_t_skip`` (needs ``t``): widths only after this time, to leave out the decay of
    the initial box."""
    truth = np.asarray(truth, dtype=float)
    sel = np.ones(len(truth), bool) if t is None else (t >= t[0] + t_skip)
    if mask is not None:
        sel = sel & np.asarray(mask, dtype=bool)
    if not sel.any():
        raise ObserverArgumentError("interval_metrics: no sample selected (check t_skip / mask)")
    wsel = sel
    if width_t_skip is not None:
        if t is None:
            raise ObserverArgumentError("interval_metrics: width_t_skip needs t")
        wsel = sel & (t >= t[0] + width_t_skip)
    out = {}
    for c, nm in enumerate(("vy", "r")):
        w = res.width[wsel, c]
        out[f"width_mean_{nm}"] = float(w.mean())
        out[f"width_max_{nm}"] = float(w.max())
        x = truth[sel, c]
        if np.all(np.isnan(x)):
            continue
        inside = (res.x_lo[sel, c] - tol <= x) & (x <= res.x_hi[sel, c] + tol)
        out[f"enclosure_{nm}"] = float(inside.mean())
        above = np.maximum(x - res.x_hi[sel, c], 0) + np.maximum(res.x_lo[sel, c] - x, 0)
        out[f"max_excursion_{nm}"] = float(above.max())
    return out


def run_on_log(design: iv.IntervalDesign, log, x0_lo, x0_hi, steer_noise: float = 0.0,
               y_noise: float = 0.0, use_truth: bool = False, clip_speed: bool = False):
    """Run the observer on a :class:`~vehicle_observers.data.logs.DriveLog`: measured ``vx``,
    steering ``delta +- steer_noise`` [rad] and yaw rate ``y`` with ``|y - r| <= y_noise``.
    ``use_truth=True`` takes the noise-free ``*_true`` channels of an emulated log instead."""
    if use_truth:
        for c in ("vx_true_mps", "delta_true_rad", "yaw_rate_true_radps"):
            if c not in log.extra:
                raise ObserverArgumentError(f"{log.source or 'log'}: use_truth needs column {c!r}")
        vx, d, y = (log.extra[c] for c in ("vx_true_mps", "delta_true_rad",
                                           "yaw_rate_true_radps"))
    else:
        vx, d, y = log.vx, log.delta, log.yaw_rate
    return iv.run_interval_observer(design, log.dt, vx, d - steer_noise, d + steer_noise, y,
                                 x0_lo, x0_hi, y_noise=y_noise, clip_speed=clip_speed)


def share_in_box(stiffness, lo: float, hi: float, mask=None) -> float:
    """Share of samples whose (secant) stiffness [N/rad] lies in ``[lo, hi]``."""
    s = np.asarray(stiffness, dtype=float)
    if mask is not None:
        s = s[np.asarray(mask, bool)]
    return float(np.mean((s >= lo) & (s <= hi)))


#: tableau-colorblind10 colours: switched / single-mode / third observer
PALETTE = ("#006BA4", "#FF800E", "#595959", "#5F9ED1", "#C85200")


def plot_inputs(t, vx, delta, sigma, bands: ub.SpeedBands, title: str = ""):
    """Steering, speed with the band edges, and sigma(t) (the slides' input figures)."""
    import matplotlib.pyplot as plt
    from vehicle_observers.core.arrays import decimate

    fig, ax = plt.subplots(3, 1, sharex=True, figsize=(9.0, 6.0))
    tt, d, v, s = decimate(t, delta, vx, np.asarray(sigma) + 1, max_points=2000)
    ax[0].plot(tt, np.degrees(d), color=PALETTE[0])
    ax[0].set_ylabel(r"$\delta_f$ [deg]")
    ax[0].lines[0].set_label(r"steering $\delta_f$")
    ax[1].plot(tt, v, color=PALETTE[0], label="speed $v_x$")
    for k, e in enumerate(bands.edges):
        ax[1].axhline(e, color="0.5", ls=":", lw=0.8, label="band edges (22)" if k == 0 else None)
    ax[1].set_ylabel("$v_x$ [m/s]")
    ax[2].step(tt, s, where="post", color=PALETTE[0], label=r"mode $\sigma(t)$")
    ax[2].set_ylabel(r"$\sigma(t)$ [-] (mode index)")
    ax[2].set_yticks(range(1, bands.n_modes + 1))
    ax[2].set_xlabel("$t$ [s]")
    for a in ax:
        a.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
    if title:
        fig.suptitle(title)
    return fig


_STATES = (("v_y", "m/s"), ("r", "rad/s"))


def _band(ax, tt, lo, hi, k, label):
    """The first observer (``k = 0``) as a filled band; the others as their two edges only
    (dashed, no fill), so two overlapping bands never blend into a third colour."""
    col = PALETTE[k % len(PALETTE)]
    if k == 0:
        ax.fill_between(tt, lo, hi, color=col, alpha=0.35, lw=0, label=label, zorder=2)
        ax.plot(tt, lo, color=col, lw=0.7, zorder=3)
        ax.plot(tt, hi, color=col, lw=0.7, zorder=3)
        return
    ax.plot(tt, lo, color=col, lw=0.9, ls="--", zorder=3 + k, label=label + " (edges)")
    ax.plot(tt, hi, color=col, lw=0.9, ls="--", zorder=3 + k)


def plot_intervals(t, results: dict, truth_vy, truth_r, title: str = "", tlim=None,
                   truth_label: str = "truth", error_panel: bool = False,
                   t_transient: float = 1.0):
    """Interval estimates of v_y and r (``results = {label: IntervalRun}``) with the
    reference (the slides' two result figures, stacked). ``error_panel=True`` adds, per
    state, a panel with each observer's interval relative to the reference
    (``x^- - x`` and ``x^+ - x``: the reference is enclosed where the band contains 0), its
    vertical scale set by the samples after ``t_transient`` s (the initial box leaves the
    axis)."""
    import matplotlib.pyplot as plt
    from vehicle_observers.core.arrays import decimate

    t = np.asarray(t)
    sel = np.ones(len(t), bool) if tlim is None else (t >= tlim[0]) & (t <= tlim[1])
    refs = (truth_vy, truth_r)
    nrow = 4 if error_panel else 2
    fig, ax = plt.subplots(nrow, 1, sharex=True, figsize=(9.0, 2.8 * nrow))
    for c, (nm, unit) in enumerate(_STATES):
        a = ax[2 * c] if error_panel else ax[c]
        for k, (lab, res) in enumerate(results.items()):
            tt, lo, hi = decimate(t[sel], res.x_lo[sel, c], res.x_hi[sel, c], max_points=2000)
            _band(a, tt, lo, hi, k, f"$[{nm}^-, {nm}^+]$ {lab}")
        ref = refs[c]
        if ref is not None:
            tt, rr = decimate(t[sel], np.asarray(ref)[sel], max_points=2000)
            a.plot(tt, rr, color="k", lw=0.9, label=truth_label, zorder=4)
        a.set_ylabel(f"${nm}$ [{unit}]")
        a.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
        if error_panel and ref is not None:
            e = ax[2 * c + 1]
            r = np.asarray(ref)[sel]
            for k, (lab, res) in enumerate(results.items()):
                tt, lo, hi = decimate(t[sel], res.x_lo[sel, c] - r, res.x_hi[sel, c] - r,
                                      max_points=2000)
                _band(e, tt, lo, hi, k, f"$[{nm}^- - {nm},\\ {nm}^+ - {nm}]$ {lab}")
            e.axhline(0.0, color="k", lw=0.9)
            e.set_ylabel(f"interval $-$ ${nm}$ [{unit}]")
            # scaled after the start transient (the initial box would flatten the rest)
            late = t[sel] >= t[sel][0] + t_transient
            if late.any():
                big = max(float(np.abs(res.x_lo[sel, c][late] - r[late]).max())
                          for res in results.values())
                big = max(big, max(float(np.abs(res.x_hi[sel, c][late] - r[late]).max())
                                   for res in results.values()))
                e.set_ylim(-1.15 * big, 1.15 * big)
            e.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
    ax[-1].set_xlabel("$t$ [s]")
    if title:
        fig.suptitle(title)
    return fig


def plot_margins(t, res: iv.IntervalRun, truth, title: str = "", truth_label: str = "truth",
                 floor: float = 1e-9):
    """Interval against the truth ``(N, 2)``, one pair of panels per state: the band with the
    truth, and below it the two margins ``x^+ - x`` and ``x - x^-`` [state unit] on a symlog
    axis with the zero line (both >= 0 where the truth is enclosed; a violation shows as a
    negative margin below the line; linear within the 1st percentile of ``|margin|``, at least
    ``floor``). A narrow interval (the yaw rate's) is invisible at the scale of the state; its
    margins are not. 4 axes."""
    import matplotlib.pyplot as plt
    from vehicle_observers.core.arrays import decimate

    truth = np.asarray(truth, dtype=float)
    fig, ax = plt.subplots(4, 1, sharex=True, figsize=(9.0, 9.0),
                           gridspec_kw={"height_ratios": [1.0, 0.8, 1.0, 0.8]})
    for c, (nm, unit) in enumerate(_STATES):
        a, b = ax[2 * c], ax[2 * c + 1]
        tt, lo, hi, x = decimate(t, res.x_lo[:, c], res.x_hi[:, c], truth[:, c], max_points=3000)
        _band(a, tt, lo, hi, 0, f"$[{nm}^-, {nm}^+]$")
        a.plot(tt, x, color="k", lw=0.9, label=truth_label, zorder=4)
        a.set_ylabel(f"${nm}$ [{unit}]")
        a.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
        up, dn = res.x_hi[:, c] - truth[:, c], truth[:, c] - res.x_lo[:, c]
        lin = max(floor, float(np.percentile(np.abs(np.concatenate([up, dn])), 1)))
        tt, up, dn = decimate(t, up, dn, max_points=3000)
        b.plot(tt, up, color=PALETTE[0], lw=0.8, label=f"upper margin ${nm}^+ - {nm}$")
        b.plot(tt, dn, color=PALETTE[1], lw=0.8, ls="--", label=f"lower margin ${nm} - {nm}^-$")
        b.axhline(0.0, color="k", lw=0.8, label="0 (below: truth outside)")
        b.set_yscale("symlog", linthresh=lin)
        b.set_ylabel(f"margin [{unit}]")
        b.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
    ax[-1].set_xlabel("$t$ [s]")
    if title:
        fig.suptitle(title)
    return fig


def plot_widths(t, results: dict, title: str = "", t_settle: dict | None = None):
    """Interval widths of v_y and r (log scale) for several observers; ``t_settle``
    ``{label: (t_vy, t_r)}`` marks each observer's convergence time [s] (from ``t[0]``)."""
    import matplotlib.pyplot as plt
    from vehicle_observers.core.arrays import decimate

    fig, ax = plt.subplots(2, 1, sharex=True, figsize=(9.0, 4.8))
    for k, (lab, res) in enumerate(results.items()):
        col = PALETTE[k % len(PALETTE)]
        tt, w1, w2 = decimate(t, res.width[:, 0], res.width[:, 1], max_points=2000)
        ax[0].semilogy(tt, np.maximum(w1, 1e-12), color=col, label=lab)
        ax[1].semilogy(tt, np.maximum(w2, 1e-12), color=col, label=lab)
        for c in range(2):
            ts = (t_settle or {}).get(lab)
            if ts is not None and np.isfinite(ts[c]):
                ax[c].axvline(t[0] + ts[c], color=col, ls=":", lw=1.0)
    ax[0].set_ylabel("width $v_y^+ - v_y^-$ [m/s]")
    ax[1].set_ylabel("width $r^+ - r^-$ [rad/s]")
    ax[1].set_xlabel("$t$ [s]")
    ax[0].legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
    if title:
        fig.suptitle(title)
    return fig


def plot_gains(design: iv.IntervalDesign, L_printed=None, P_printed=None, others: dict | None = None):
    """Designed ``L`` with its sign (and ``P_22/P_11``) next to the slides' printed values, per
    mode.vertex, on a symlog axis with the zero line, so a sign disagreement shows as a point
    on the other side of the line; ``others`` ``{label: IntervalDesign}`` adds more designs
    (e.g. the other vertex polarity). 3 axes."""
    import matplotlib.pyplot as plt

    K = design.L.shape[0]
    fig, ax = plt.subplots(1, 3, figsize=(10.5, 3.6))
    idx = np.arange(K * 4)
    labels = [f"{i + 1}.{j + 1}" for i in range(K) for j in range(4)]
    designs = {"designed": design, **(others or {})}
    marks = "osd^"
    for c, nm in enumerate(("$L_1$ ($v_y$ row) [m/s]", "$L_2$ ($r$ row) [1/s]")):
        for k, (lab, d) in enumerate(designs.items()):
            ax[c].plot(idx, d.L[..., c, 0].ravel(), marks[k % 4], mfc="none",
                       color=PALETTE[(0, 2, 4, 3)[k % 4]], label=lab)
        if L_printed is not None:
            lp = np.asarray(L_printed)[..., c].ravel()
            ax[c].plot(np.arange(len(lp)), lp, "x", color=PALETTE[1], label="printed")
        ax[c].axhline(0.0, color="k", lw=0.6)
        ax[c].set_yscale("symlog", linthresh=1.0)
        ax[c].set_title(nm)
    if P_printed is not None:
        pp_ = np.asarray(P_printed)
        ax[2].plot(np.arange(pp_[..., 0].size), (pp_[..., 1] / pp_[..., 0]).ravel(), "x",
                   color=PALETTE[1], label="printed")
    ax[2].plot(idx, (design.P[..., 1] / design.P[..., 0]).ravel(), "o", mfc="none",
               color=PALETTE[0], label="designed")
    ax[2].set_yscale("log")
    ax[2].set_title("$P_{22} / P_{11}$ [-]")
    for a in ax:
        a.set_xticks(idx)
        a.set_xticklabels(labels, rotation=90, fontsize=7)
        a.set_xlabel("mode.vertex $i.j$ [-]")
    ax[0].legend(fontsize=7)
    return fig
