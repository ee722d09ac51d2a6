"""Plot helpers of notebook 04 (Ichalal, Arioui, Mammar, MED 2011): states and estimates of
the bicycle (25), the tracking of (27), the Jacobian entries with their bounds (32)-(34), the
closed-loop eigenvalues with the region (35)-(36) and the region feasibility map. The figure
functions of :mod:`.bicycle_dmvt` compose them."""

from __future__ import annotations

import numpy as np
from vehicle_observers.core.arrays import decimate
from vehicle_observers.models.ts import JacobianTS
from vehicle_observers.observers.dmvt import as_regions


def plot_poles(ax, designs: dict, region=None, colors=("C3", "C0", "C2", "C1"),
               legend: bool = True):
    """Closed-loop eigenvalues [1/s] of every vertex pair of each design and the region
    (35)-(36) drawn, equal aspect (a disk is a circle); legend below the axes."""
    for (name, des), col in zip(designs.items(), colors, strict=False):
        ev = des.poles.eigs.ravel()
        ax.plot(ev.real, ev.imag, "x" if "no" in name else "o", color=col, ms=5, mfc="none",
                label=f"{name}: max $|\\mathrm{{Im}}\\,\\lambda|$ {des.poles.max_imag:.1f} 1/s, "
                      f"min $\\zeta$ {des.poles.min_damping:.2f}")
    for reg in as_regions(region):
        if reg.L.shape == (1, 1):       # half-plane Re z < -a
            a = reg.L[0, 0] / 2
            ax.axvline(-a, color="k", ls="--", lw=0.9, label=f"(35): Re $z = -{a:g}$")
        elif reg.L.shape == (2, 2) and reg.L[0, 0] != 0:   # disk
            R, q = -reg.L[0, 0], -reg.L[0, 1]
            th = np.linspace(0, 2 * np.pi, 300)
            ax.plot(q + R * np.cos(th), R * np.sin(th), "k:", lw=0.9, label=f"(36): $|z| = {R:g}$")
    ax.axvline(0, color="0.5", lw=0.6)
    ax.set_xlabel(r"Re $\lambda$ [1/s]")
    ax.set_ylabel(r"Im $\lambda$ [1/s]")
    ax.set_aspect("equal", adjustable="datalim")
    if legend:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=1, frameon=False)
    return ax


def plot_sweep(ax, sweep: dict, chosen=None):
    """Feasibility map of the region sweep: feasible cells light blue and annotated with
    max |Im lambda| [1/s], infeasible cells light orange."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Rectangle

    F = sweep["feasible"]
    a, R = sweep["a"], sweep["R"]

    # colour-blind safe (tableau-colorblind10): light orange infeasible, light blue feasible
    ax.imshow(F.T.astype(float), origin="lower", cmap=ListedColormap(["#FFBC79", "#A2C8EC"]),
              vmin=0, vmax=1, aspect="auto", extent=(-0.5, len(a) - 0.5, -0.5, len(R) - 0.5))
    for ia in range(len(a)):
        for iR in range(len(R)):
            txt = f"{sweep['max_imag'][ia, iR]:.1f}" if F[ia, iR] else "infeas."
            ax.text(ia, iR, txt, ha="center", va="center", fontsize=7)
    ax.set_xticks(range(len(a)), [f"{x:g}" for x in a])
    ax.set_yticks(range(len(R)), [f"{x:g}" for x in R])
    ax.set_xlabel("half-plane $a$ [1/s] (Re $z < -a$)")
    ax.set_ylabel("disk radius $R$ [1/s] ($|z| < R$)")
    ax.grid(False)
    if chosen is not None:
        ia = int(np.argmin(np.abs(a - chosen[0])))
        iR = int(np.argmin(np.abs(R - chosen[1])))
        ax.add_patch(Rectangle((ia - 0.5, iR - 0.5), 1, 1, fill=False, lw=2, ec="k"))
    return ax


STATE_LABELS = (r"$x_1 = \beta$ [rad]", r"$x_2 = \psi_\beta$ [1/m]", r"$x_3 = \alpha$ [rad]",
                r"$x_4 = \psi_\alpha$ [rad/s]")


def plot_estimates(axs, t, X, Xhat, label="estimate", color="C1", truth=True):
    """Four panels: state ``X[:, i]`` and its estimate ``Xhat[:, i]`` (decimated)."""
    td, Xd, Xhd = decimate(t, X, Xhat, max_points=1500)
    for i, ax in enumerate(np.ravel(axs)[:4]):
        if truth:
            ax.plot(td, Xd[:, i], "k", lw=1.2, label="state")
        ax.plot(td, Xhd[:, i], "--", color=color, label=label)
        ax.set_ylabel(STATE_LABELS[i])
    np.ravel(axs)[0].legend(loc="best")
    for ax in np.ravel(axs)[-2:]:
        ax.set_xlabel("t [s]")
    return axs


def plot_tracking(axs, t, X, U):
    """Fig. 3 analogue: x3 vs sin t, x4 vs cos t, and the input u of (27)."""
    td, x3, x4, u = decimate(t, X[:, 2], X[:, 3], U, max_points=1500)
    axs[0].plot(td, x3, label=r"$x_3 = \alpha$")
    axs[0].plot(td, np.sin(td), "k--", label=r"$x_{3d} = \sin t$")
    axs[1].plot(td, x4, label=r"$x_4$")
    axs[1].plot(td, np.cos(td), "k--", label=r"$x_{4d} = \cos t$")
    axs[2].plot(td, u, "C2")
    axs[0].set_ylabel("roll [rad]")
    axs[1].set_ylabel("roll rate [rad/s]")
    axs[2].set_ylabel("$u$ [normalised]")
    axs[2].set_xlabel("t [s]")
    for ax in axs[:2]:
        ax.legend(loc="upper right")
    return axs


def plot_jacobian_bounds(axs, t, xi, jts: JacobianTS, printed_bounds, xi_printed=None,
                         units=None):
    """Varying Jacobian entries ``xi`` (N, k) with the derived (``jts``) and printed bounds;
    ``xi_printed`` (N, k) optionally overlays the printed formulas (NaN columns skipped);
    ``units`` (k,) the axis-label unit of each entry (none when omitted: the entries of one
    Jacobian generally have different units)."""
    td, xd = decimate(t, xi, max_points=1500)
    pd = None if xi_printed is None else decimate(t, xi_printed, max_points=1500)[1]
    for l, ax in enumerate(np.ravel(axs)):
        ax.plot(td, xd[:, l], label=rf"$\xi_{l + 1}$ exact")
        if pd is not None and np.all(np.isfinite(pd[:, l])):
            ax.plot(td, pd[:, l], "C2", label="printed (33), literal")
        for k, v in enumerate((jts.lo[l], jts.hi[l])):
            ax.axhline(v, color="C0", ls=":", label="derived bounds" if k else None)
        for k, v in enumerate(printed_bounds[l]):
            ax.axhline(v, color="C3", ls="--", label="printed bounds" if k else None)
        ax.set_ylabel(rf"$\xi_{l + 1}$" + (f" [{units[l]}]" if units is not None else ""))
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    np.ravel(axs)[-1].set_xlabel("t [s]")
    return axs
