"""Plot helpers of the notebooks and the benchmark, with the one colour palette of the project.

Every figure uses the colour-blind-safe Tableau colour-blind 10 palette (matplotlib style
``tableau-colorblind10``, :data:`PALETTE`); :func:`apply_style` (run on import, so by every
notebook through :mod:`vehicle_observers.results.reporting`) makes it the colour cycle, with a
light grid and small fonts. An estimator or observer has the same colour in every figure:
:data:`COLORS` is its one definition (:func:`color` looks a name up, with a cycling fallback
for names it does not list); the truth or reference is black (:data:`TRUTH`).

Figures are saved through :meth:`vehicle_observers.results.reporting.Report.savefig`.
"""

from __future__ import annotations

import re

import matplotlib
import matplotlib.pyplot as plt
import numpy as np

from vehicle_observers.core.arrays import decimate

#: the matplotlib style of the palette
STYLE = "tableau-colorblind10"
#: Tableau colour-blind 10: blue, orange, light grey, dark grey, light blue, dark orange,
#: mid grey, pale blue, pale orange, pale grey
PALETTE: tuple[str, ...] = tuple(plt.style.library[STYLE]["axes.prop_cycle"].by_key()["color"])
#: colour of the truth / reference in every figure
TRUTH = "k"

#: one colour per estimator or observer (the registry names of
#: :func:`vehicle_observers.estimation.available` for the benchmark; ``<paper>/<role>`` for
#: the variants a reproduction compares)
COLORS: dict[str, str] = {
    # registered estimators (benchmark, notebook 07)
    "ekf": PALETTE[1], "ekf-filterpy": PALETTE[0], "ukf": PALETTE[2], "rts": PALETTE[3],
    "ts-yacine2015": PALETTE[4], "interval-ifqir2017": PALETTE[5],
    "interval-coordinates": PALETTE[8], "open-loop-linear": TRUTH,
    # Ichalal 2011 (notebook 04): DMVT observer without / with the pole region (35)-(36),
    # filterpy EKF and UKF on the bicycle model (25)
    "ichalal2011/noreg": PALETTE[5], "ichalal2011/reg": PALETTE[0], "ichalal2011/ekf": TRUTH,
    "ichalal2011/ukf": PALETTE[6],
    # El Youssfi 2020 (notebook 06): UIO designs (b) Theorem 2 and (a) [22]; EKFs with the
    # fault as a random-walk state
    "elyoussfi2020/theorem2": PALETTE[3], "elyoussfi2020/ref22": PALETTE[0],
    "elyoussfi2020/ekf": PALETTE[2], "elyoussfi2020/ekf-tau": PALETTE[1],
}
#: first palette entry of the fallback colours of :func:`color`
FALLBACK = 6


def color(name: str, j: int = 0) -> str:
    """Colour of estimator ``name`` (:data:`COLORS`); a name it does not list gets
    ``PALETTE[6 + j % 4]`` (``j``: its position in the figure)."""
    c = COLORS.get(name)
    return c if c is not None else PALETTE[FALLBACK + j % (len(PALETTE) - FALLBACK)]


#: rcParams of every figure (besides the style): light grid, small fonts, deterministic files
RC = {"figure.dpi": 100, "savefig.dpi": 110, "figure.figsize": (9.0, 5.0), "axes.grid": True,
      "grid.alpha": 0.3, "font.size": 9, "legend.fontsize": 8, "axes.titlesize": 10,
      "lines.linewidth": 1.1, "svg.hashsalt": "vehicle-observers", "path.simplify": True}


def apply_style():
    """Make :data:`PALETTE` the colour cycle of every figure and set :data:`RC`; labels use
    mathtext (``$v_y$``) and carry units."""
    matplotlib.rcParams.update({"axes.prop_cycle": plt.style.library[STYLE]["axes.prop_cycle"],
                                "patch.facecolor": PALETTE[0], **RC})


apply_style()


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


def grouped_bars(ax, groups, series, value, log: bool = False, labels=None) -> float:
    """One group of bars per entry of ``groups`` (x axis), one bar per entry of ``series`` in
    each, coloured by :func:`color`. ``value(group, series)`` is the bar's height, ``None`` or
    NaN for no bar; ``log``: logarithmic y axis; ``labels``: tick labels (default the groups).
    Returns the bar width (the groups span 0.8 of a unit)."""
    w = 0.8 / max(len(series), 1)
    for j, s in enumerate(series):
        xs, ys = [], []
        for i, g in enumerate(groups):
            v = value(g, s)
            if v is not None and np.isfinite(v):
                xs.append(i + j * w)
                ys.append(v)
        ax.bar(xs, ys, w, label=s, color=color(s, j))
    ax.set_xticks(np.arange(len(groups)) + 0.4 - w / 2)
    ax.set_xticklabels(list(groups) if labels is None else labels)
    if log:
        ax.set_yscale("log")
    return w


#: a unit in an axis label: ``[m/s]``, ``[-]`` for a pure number, or ``[%]``
_UNIT = re.compile(r"\[[^\]]+\]")


def _has_data(ax) -> bool:
    return bool(ax.lines or ax.patches or ax.collections or ax.images)


def _categorical(axis) -> bool:
    """Tick labels that are words (bar charts by estimator, dataset names): no unit needed."""
    labels = [t.get_text() for t in axis.get_ticklabels() if t.get_text()]
    return bool(labels) and not all(re.fullmatch(r"[\s\d.,\u2212+\-−e$^{}\\mathrm×]*", t) for t in labels)


def _labelled_neighbour(fig, ax, which: str) -> bool:
    """A panel of the same grid row to the left (``which="y"``) or of the same grid column
    below (``"x"``) carries the label: a zoom or a repeated panel of the same quantity."""
    spec = ax.get_subplotspec() if hasattr(ax, "get_subplotspec") else None
    if spec is None:
        return False
    for other in fig.axes:
        o = other.get_subplotspec() if other is not ax and hasattr(other, "get_subplotspec") else None
        if o is None or o.get_gridspec() is not spec.get_gridspec():
            continue
        if which == "y" and o.rowspan == spec.rowspan and o.colspan.start < spec.colspan.start \
                and other.yaxis.get_label_text():
            return True
        if which == "x" and o.colspan == spec.colspan and o.rowspan.start > spec.rowspan.start \
                and other.xaxis.get_label_text():
            return True
    return False


def label_problems(fig) -> list[str]:
    """Axis labels a reader needs, one line per problem (empty when fine): every visible panel
    with data has an x and a y label with a unit in brackets (``[-]`` for a pure number),
    unless the axis is categorical (word tick labels), shows no tick labels, or shares its axis
    with a labelled panel or repeats the quantity of one (a panel to its left in the same grid
    row, or below it in the same grid column, carries the label)."""
    problems = []
    for i, ax in enumerate(fig.axes):
        if not ax.get_visible() or not ax.axison or not _has_data(ax):
            continue
        where = f"panel {i}" + (f" ({ax.get_title()[:40]!r})" if ax.get_title() else "")
        for which in "xy":
            axis = ax.xaxis if which == "x" else ax.yaxis
            label = axis.get_label_text()
            if _categorical(axis) or not any(t.get_visible() and t.get_text()
                                             for t in axis.get_ticklabels()):
                continue
            if not label:
                shared = (ax.get_shared_x_axes() if which == "x" else ax.get_shared_y_axes())
                if any((s.xaxis if which == "x" else s.yaxis).get_label_text()
                       for s in shared.get_siblings(ax) if s is not ax) or \
                        _labelled_neighbour(fig, ax, which):
                    continue
                problems.append(f"{where}: no {which} label")
            elif not _UNIT.search(label):
                problems.append(f"{where}: {which} label {label!r} has no unit in brackets")
    return problems


# ------------------------------------------------------------------ figure data ----------

def _hex(c) -> str:
    """A matplotlib colour as ``#rrggbbaa`` (``"none"`` for a transparent or absent one)."""
    from matplotlib.colors import to_hex

    try:
        arr = np.asarray(c, dtype=float)
        if arr.ndim == 2:
            arr = arr[0] if len(arr) else None
        if arr is None or arr.size == 0:
            return "none"
        return to_hex(arr, keep_alpha=True)
    except (TypeError, ValueError):
        try:
            return to_hex(c, keep_alpha=True)
        except (TypeError, ValueError):
            return "none"


def _summary(v) -> dict:
    """``{"n", "min", "max", "mean"}`` of the finite values of ``v`` (4 significant digits);
    ``{"n": 0}`` without finite values."""
    a = np.asarray(v, dtype=float).ravel()
    a = a[np.isfinite(a)]
    if a.size == 0:
        return {"n": 0}
    r = lambda x: float(f"{float(x):.4g}")  # noqa: E731
    return {"n": int(a.size), "min": r(a.min()), "max": r(a.max()), "mean": r(a.mean())}


def _as_float(v):
    try:
        return np.asarray(v, dtype=float)
    except (TypeError, ValueError):   # dates or categories: their positions are what is drawn
        return np.arange(len(v), dtype=float)


def figure_data(fig) -> dict:
    """What a figure shows, as plain data that a regeneration check can compare
    (:func:`vehicle_observers.results.check.compare_figure_data`): per axes its title, labels,
    scales and limits; per line its label, colour, style, marker and a summary (count, min, max,
    mean) of its x and y data; per patch group (bars, areas) its colours and hatches and a
    summary of the rectangles; per collection (scatter, fill_between, pcolormesh) its colours
    and a summary of its offsets or array; per image its shape, colour map and a summary; the
    texts and legend entries. A different colour, a missing series or moved data show up as a
    difference; the rendering (fonts, anti-aliasing) does not."""
    from matplotlib.patches import Rectangle

    out = {"suptitle": fig._suptitle.get_text() if fig._suptitle else "", "axes": []}
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        a = {"title": " | ".join(t for t in (ax.get_title("left"), ax.get_title(),
                                              ax.get_title("right")) if t),
             "xlabel": ax.get_xlabel(), "ylabel": ax.get_ylabel(),
             "xscale": ax.get_xscale(), "yscale": ax.get_yscale(),
             "xlim": [float(f"{x:.4g}") for x in ax.get_xlim()],
             "ylim": [float(f"{x:.4g}") for x in ax.get_ylim()],
             "axis_on": bool(ax.axison)}
        a["lines"] = [{"label": ln.get_label() if not ln.get_label().startswith("_") else "",
                       "color": _hex(ln.get_color()), "linestyle": str(ln.get_linestyle()),
                       "marker": str(ln.get_marker()), "x": _summary(_as_float(ln.get_xdata())),
                       "y": _summary(_as_float(ln.get_ydata()))}
                      for ln in ax.get_lines() if ln.get_visible()]
        rects = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_visible()]
        others = [p for p in ax.patches if not isinstance(p, Rectangle) and p.get_visible()]
        a["bars"] = {"n": len(rects),
                     "facecolors": sorted({_hex(p.get_facecolor()) for p in rects}),
                     "hatches": sorted({str(p.get_hatch() or "") for p in rects}),
                     "x": _summary([p.get_x() + p.get_width() / 2 for p in rects]),
                     "height": _summary([p.get_height() for p in rects]),
                     "width": _summary([p.get_width() for p in rects])} if rects else {}
        a["patches"] = [{"type": type(p).__name__, "facecolor": _hex(p.get_facecolor()),
                         "hatch": str(p.get_hatch() or "")} for p in others]
        cols = []
        for c in ax.collections:
            if not c.get_visible():
                continue
            label = c.get_label()
            d = {"type": type(c).__name__, "label": "" if label.startswith("_") else label,
                 "facecolors": sorted({_hex(x) for x in np.atleast_2d(c.get_facecolor())})[:10],
                 "edgecolors": sorted({_hex(x) for x in np.atleast_2d(c.get_edgecolor())})[:10]}
            arr = c.get_array()
            if arr is not None:
                d["array"] = _summary(np.ma.filled(np.ma.asarray(arr, dtype=float), np.nan))
                d["cmap"] = c.get_cmap().name
            off = c.get_offsets()
            if off is not None and len(off) > 1:
                off = np.asarray(off, dtype=float)
                d["x"], d["y"] = _summary(off[:, 0]), _summary(off[:, 1])
            paths = c.get_paths() if hasattr(c, "get_paths") else []
            verts = [p.vertices for p in paths if len(p.vertices)]
            if verts and (off is None or len(off) <= 1):
                v = np.concatenate(verts)
                d["x"], d["y"] = _summary(v[:, 0]), _summary(v[:, 1])
            cols.append(d)
        a["collections"] = cols
        a["images"] = [{"shape": list(np.shape(im.get_array())), "cmap": im.get_cmap().name,
                        "clim": [float(f"{x:.4g}") for x in im.get_clim()],
                        "values": _summary(np.ma.filled(np.ma.asarray(im.get_array(), dtype=float),
                                                        np.nan))}
                       for im in ax.get_images()]
        a["texts"] = [t.get_text() for t in ax.texts if t.get_visible() and t.get_text()]
        leg = ax.get_legend()
        a["legend"] = [t.get_text() for t in leg.get_texts()] if leg else []
        out["axes"].append(a)
    legs = [lg for lg in fig.legends]
    out["figure_legend"] = [t.get_text() for lg in legs for t in lg.get_texts()]
    return out
