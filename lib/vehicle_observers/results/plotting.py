"""Plot helpers shared by the notebooks (figures are saved through reporting.Report)."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from vehicle_observers.core.arrays import decimate


def time_series(ax, t, series: dict, ylabel: str = "", title: str = "", styles=None,
                max_points: int = 4000):
    """Plot named series ``{label: y}`` against ``t`` (thinned for small files)."""
    styles = styles or {}
    for label, y in series.items():
        if y is None:
            continue
        tt, yy = decimate(t, y, max_points=max_points)
        ax.plot(tt, yy, label=label, **styles.get(label, {}))
    ax.set_xlabel("t [s]")
    if ylabel:
        ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.legend(loc="best")
    return ax


def stacked(t, panels: list[tuple[str, dict]], title: str = "", styles=None, figsize=None,
            sharex: bool = True):
    """One row per panel ``(ylabel, {label: y})``; returns the figure."""
    fig, axes = plt.subplots(len(panels), 1, sharex=sharex,
                             figsize=figsize or (9.0, 2.2 * len(panels) + 0.6))
    axes = np.atleast_1d(axes)
    for ax, (ylabel, series) in zip(axes, panels):
        time_series(ax, t, series, ylabel=ylabel, styles=styles)
        if sharex and ax is not axes[-1]:
            ax.set_xlabel("")
    if title:
        fig.suptitle(title)
    return fig


def tyre_sector(tires: dict, alpha_max: float, bounds: dict | None = None):
    """Force and secant stiffness of tyres ``{name: tyre}`` over ``|alpha| <= 1.5 alpha_max``,
    with the sector bounds ``{name: (M_min, M_max)}`` drawn as lines ``M alpha``."""
    a = np.linspace(-1.5 * alpha_max, 1.5 * alpha_max, 601)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9.5, 3.6))
    for name, tyre in tires.items():
        (line,) = ax1.plot(np.degrees(a), tyre.force(a), label=f"{name}: Pacejka")
        ax2.plot(np.degrees(a), tyre.secant_stiffness(a), color=line.get_color(), label=name)
        if bounds and name in bounds:
            for M in bounds[name]:
                ax1.plot(np.degrees(a), M * a, ":", color=line.get_color(), lw=0.9)
                ax2.axhline(M, ls=":", color=line.get_color(), lw=0.9)
    for ax in (ax1, ax2):
        ax.axvspan(-np.degrees(alpha_max), np.degrees(alpha_max), color="0.9", zorder=0)
        ax.set_xlabel("slip angle alpha [deg]")
    ax1.set_ylabel("lateral force F^S [N]")
    ax2.set_ylabel("secant stiffness f = F^S / alpha [N/rad]")
    ax1.set_title("Pacejka (7) and sector lines M alpha")
    ax2.set_title("premise f(alpha), eq. (16), and its bounds")
    ax1.legend()
    ax2.legend()
    return fig
