"""Tables and figures of a campaign folder.

    python -m vehicle_observers campaign report DIR

writes ``DIR/report/`` (CSV tables, ``summary.md``, PNG figures) from the rows of
:mod:`vehicle_observers.campaign.store`:

* :func:`error_table` - ``v_y`` RMSE of every estimator against each parameter error of the
  observer's vehicle file: median and 90th percentile over the logs (plants, manoeuvres,
  noise, biases, rates, repetitions), and the median of the *paired* ratios to the
  open-loop linear bicycle and to the linear Kalman filter run on the same log with the same
  vehicle file (:mod:`vehicle_observers.estimation.references`). One-at-a-time designs slice
  the rows where only that parameter is wrong; factorial designs average over the others;
  sampled designs bin the error into :data:`BINS` equal-width bins.
* :func:`conservatism_table` - interval observers: enclosure rate (mean, min) and mean width
  of ``v_y`` against the stiffness error of the vehicle file and the speed range of its box
  (the conservatism map), with the share of runs whose truth lies inside the stiffness box
  and the minimum enclosure where Ifqir 2017's guarantee applies (``guarantee``: matched LPV
  truth inside the box, bounded noise, no bias, exact speed inside the bands).
* :func:`lmi_table` - the feasibility map of the interval design (:mod:`.lmi_map`) and, per
  car, coordinate change and speed range, the largest feasible box half-width beside the
  analytic Metzler bound of the untransformed observer
  (``UncertainBicycle.max_metzler_uncertainty``).
* :func:`uncertainty_table` - per estimator and truth plant (``plant:car``): the median
  ``v_y`` RMSE beside the 2-sigma coverage of the reported ``vy_std_mps`` and the mean NEES,
  both pooled over every scored sample of the successful runs (``n/a`` for an estimator that
  reports no standard deviation).
* :func:`failure_table` - failure rate per estimator and its most frequent error.
* :func:`warning_table` - warnings raised while the tasks ran (recorded per task by
  :func:`vehicle_observers.campaign.tasks.recorded_warnings`, never silenced): per estimator
  and category, the tasks that raised it, the number of occurrences and the first message.
* :func:`best_table` - the estimator with the smallest median ``v_y`` RMSE per plant and
  parameter error (the best per region).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from vehicle_observers.campaign import store
from vehicle_observers.campaign.spec import ERROR_KEYS

BINS = 5
REFERENCES = {"open_loop": "open-loop-linear", "linear_kf": "linear-kf"}
#: columns identifying one noisy log and one vehicle file (the pairing of the ratios)
PAIR = ("plant", "car", "manoeuvre", "variant", "rate_hz", "noise_scale", "bias", "rep")


def _frame(out, spec=None):
    import polars as pl

    return pl.from_arrow(store.read_results(out, spec=spec))


def _slices(df, design: str):
    """``[(parameter, error value, rows), ...]`` (module docstring)."""
    import polars as pl

    errs = [k for k in ERROR_KEYS if df[f"err_{k}"].n_unique() > 1]
    zero = pl.all_horizontal([pl.col(f"err_{k}") == 0.0 for k in ERROR_KEYS]) if ERROR_KEYS \
        else pl.lit(True)
    out = [("nominal", 0.0, df.filter(zero))] if design != "sample" else []
    for k in errs:
        c = f"err_{k}"
        if design == "sample":
            lo, hi = float(df[c].min()), float(df[c].max())
            edges = np.linspace(lo, hi, BINS + 1)
            for b in range(BINS):
                sel = (pl.col(c) >= edges[b]) & ((pl.col(c) < edges[b + 1]) if b < BINS - 1
                                                  else (pl.col(c) <= edges[b + 1]))
                out.append((k, float(0.5 * (edges[b] + edges[b + 1])), df.filter(sel)))
            continue
        others = pl.all_horizontal([pl.col(f"err_{j}") == 0.0 for j in ERROR_KEYS if j != k])
        for v in sorted(df[c].unique().to_list()):
            if v == 0.0:
                continue
            sel = pl.col(c) == v
            out.append((k, float(v), df.filter(sel & others) if design == "one-at-a-time"
                        else df.filter(sel)))
    return [(k, v, d) for k, v, d in out if len(d)]


def _ratios(rows, refs):
    """Paired ratios of ``rmse_vy`` of ``rows`` to the reference rows of the same log and
    vehicle file (``refs``: key -> rmse)."""
    keys = list(zip(*(rows[c].to_list() for c in PAIR)))
    r = [a / refs[k] if k in refs and refs[k] > 0 else math.nan
         for a, k in zip(rows["rmse_vy"].to_list(), keys)]
    r = np.array([x for x in r if np.isfinite(x)])
    return float(np.median(r)) if len(r) else math.nan


def _stats(x) -> tuple[float, float]:
    x = np.asarray([v for v in x if v is not None and np.isfinite(v)], float)
    if not len(x):
        return math.nan, math.nan
    return float(np.median(x)), float(np.percentile(x, 90))


def error_table(df, design: str) -> list[dict]:
    """Rows ``estimator, parameter, error, n, failed, median_rmse_vy, p90_rmse_vy,
    ratio_open_loop, ratio_linear_kf`` (module docstring)."""
    import polars as pl

    ok = df.filter(pl.col("ok"))
    refs = {}
    for name, est in REFERENCES.items():
        r = ok.filter(pl.col("estimator") == est)
        refs[name] = dict(zip(zip(*(r[c].to_list() for c in PAIR)), r["rmse_vy"].to_list()))
    out = []
    for k, v, d in _slices(df, design):
        for est in dict.fromkeys(df["estimator"].to_list()):
            e = d.filter(pl.col("estimator") == est)
            if not len(e):
                continue
            good = e.filter(pl.col("ok"))
            med, p90 = _stats(good["rmse_vy"].to_list())
            out.append({"estimator": est, "parameter": k, "error": v, "n": len(e),
                        "failed": len(e) - len(good), "median_rmse_vy": med, "p90_rmse_vy": p90,
                        "ratio_open_loop": _ratios(good, refs["open_loop"]),
                        "ratio_linear_kf": _ratios(good, refs["linear_kf"])})
    return out


def conservatism_table(df) -> list[dict]:
    """Interval observers: one row per (estimator, plant, car, box speed range, box
    half-width, front / rear stiffness error), other errors zero (module docstring)."""
    import polars as pl

    iv = df.filter(pl.col("enclosure_vy").is_not_nan() | ~pl.col("ok"))
    iv = iv.filter(pl.col("estimator").is_in(
        df.filter(pl.col("enclosure_vy").is_not_nan())["estimator"].unique().to_list()))
    others = pl.all_horizontal([pl.col(f"err_{k}") == 0.0 for k in ("mass", "inertia", "a_f",
                                                                       "a_r", "friction")])
    iv = iv.filter(others).with_columns(
        ((1 + pl.col("err_stiffness")) * (1 + pl.col("err_stiffness_front")) - 1).alias("err_cf"),
        ((1 + pl.col("err_stiffness")) * (1 + pl.col("err_stiffness_rear")) - 1).alias("err_cr"))
    keys = ["estimator", "plant", "car", "box_vx_min", "box_vx_max", "box_rel", "err_cf", "err_cr"]
    out = []
    for g in iv.partition_by(keys, maintain_order=True):
        good = g.filter(pl.col("ok"))
        enc = np.array(good["enclosure_vy"].to_list(), float)
        gua = good.filter(pl.col("guarantee"))
        r = {k: g[k][0] for k in keys}
        r.update(n=len(g), failed=len(g) - len(good),
                 enclosure_mean=float(enc.mean()) if len(enc) else math.nan,
                 enclosure_min=float(enc.min()) if len(enc) else math.nan,
                 width_mean=float(np.mean(good["width_vy"].to_list())) if len(good) else math.nan,
                 in_box_share=float(np.mean(good["in_box"].to_list())) if len(good) else math.nan,
                 guaranteed=len(gua),
                 guaranteed_enclosure_min=float(gua["enclosure_vy"].min()) if len(gua) else math.nan)
        out.append(r)
    return out


def lmi_table(out, spec=None) -> tuple[list[dict], list[dict]]:
    """(every map point, summary per (car, kappa, speed range): points, feasible,
    infeasible, inconclusive, largest feasible ``stiffness_rel``, the analytic Metzler
    bound). ``spec``: the verified batch files only."""
    t = store.read_lmi(out, spec)
    rows = t.to_pylist()
    summ = {}
    for r in rows:
        k = (r["car"], r["kappa"], r["vx_min"], r["vx_max"])
        s = summ.setdefault(k, {"car": k[0], "kappa": k[1], "vx_min": k[2], "vx_max": k[3],
                                "points": 0, "feasible": 0, "infeasible": 0, "inconclusive": 0,
                                "max_feasible_rel": math.nan, "metzler_bound": r["metzler_bound"]})
        s["points"] += 1
        s[r["status"]] += 1
        if r["status"] == "feasible":
            s["max_feasible_rel"] = r["stiffness_rel"] if not np.isfinite(s["max_feasible_rel"]) \
                else max(s["max_feasible_rel"], r["stiffness_rel"])
    return rows, list(summ.values())


#: the cell of a quantity an estimator does not report (never NaN in a table)
NA = "n/a"


def uncertainty_table(df) -> list[dict]:
    """Rows ``estimator, plant, n, failed, median_rmse_vy, coverage_2sigma, mean_nees`` per
    estimator and truth plant (``plant:car``). Coverage and NEES are pooled over the scored
    samples of the successful runs: a run's share weighted by its number of samples, which
    is the share over all of them (:func:`vehicle_observers.core.metrics.coverage_2sigma`,
    :func:`~vehicle_observers.core.metrics.mean_nees`); :data:`NA` where the estimator gives no
    ``vy_std_mps`` (or no run succeeded)."""
    import polars as pl

    d = df.with_columns((pl.col("plant") + ":" + pl.col("car")).alias("_truth"))
    out = []
    for (est, tr), g in ((k, g) for k, g in d.group_by(["estimator", "_truth"],
                                                         maintain_order=True)):
        good = g.filter(pl.col("ok"))
        med, _ = _stats(good["rmse_vy"].to_list())
        row = {"estimator": est, "plant": tr, "n": len(g), "failed": len(g) - len(good),
               "median_rmse_vy": med if np.isfinite(med) else NA}
        for col, name in (("coverage_vy", "coverage_2sigma"), ("nees_vy", "mean_nees")):
            v = np.array(good[col].to_list(), float) if len(good) else np.array([])
            w = np.array(good["samples"].to_list(), float) if len(good) else np.array([])
            keep = np.isfinite(v) & (w > 0)
            row[name] = float(np.sum(v[keep] * w[keep]) / np.sum(w[keep])) if keep.any() else NA
        out.append(row)
    return out


def warning_table(df) -> list[dict]:
    """Rows ``estimator, category, tasks, count, first_message``: the warnings the tasks of
    each estimator raised (columns ``warnings`` / ``warning_kinds`` of the rows), the first
    message of the first task (in task order) that raised that category."""
    import json

    import polars as pl

    out: dict = {}
    w = df.filter(pl.col("warnings") > 0).sort("task")
    for est, kinds in zip(w["estimator"].to_list(), w["warning_kinds"].to_list()):
        for cat, v in json.loads(kinds).items():
            r = out.setdefault((est, cat), {"estimator": est, "category": cat, "tasks": 0,
                                            "count": 0, "first_message": v["first"][:120]})
            r["tasks"] += 1
            r["count"] += int(v["count"])
    return list(out.values())


def failure_table(df) -> list[dict]:
    import polars as pl

    out = []
    for est in dict.fromkeys(df["estimator"].to_list()):
        e = df.filter(pl.col("estimator") == est)
        bad = e.filter(~pl.col("ok"))
        top, cnt = "", 0
        if len(bad):
            vc = bad.group_by("error").len().sort(["len", "error"], descending=[True, False])
            top, cnt = vc["error"][0], int(vc["len"][0])
        out.append({"estimator": est, "n": len(e), "failed": len(bad),
                    "failure_rate": len(bad) / len(e) if len(e) else math.nan,
                    "most_frequent_error": top[:120], "its_count": cnt})
    return out


def best_table(errors: list[dict], exclude=()) -> list[dict]:
    """Per (parameter, error): the estimator with the smallest median ``v_y`` RMSE (ties:
    the first in the table), with the runner-up and their ratio."""
    groups: dict = {}
    for r in errors:
        if r["estimator"] in exclude or not np.isfinite(r["median_rmse_vy"]):
            continue
        groups.setdefault((r["parameter"], r["error"]), []).append(r)
    out = []
    for (p, e), rs in groups.items():
        rs = sorted(rs, key=lambda r: r["median_rmse_vy"])
        second = rs[1] if len(rs) > 1 else None
        out.append({"parameter": p, "error": e, "best": rs[0]["estimator"],
                    "best_median_rmse_vy": rs[0]["median_rmse_vy"],
                    "runner_up": second["estimator"] if second else "",
                    "runner_up_over_best": second["median_rmse_vy"] / rs[0]["median_rmse_vy"]
                    if second else math.nan})
    return out


# ------------------------------------------------------------------ figures ---------------
def fig_error_effect(errors: list[dict]):
    """Median (solid) and 90th percentile (dashed) ``v_y`` RMSE against each parameter error,
    one colour per estimator."""
    import matplotlib.pyplot as plt

    params = [p for p in dict.fromkeys(r["parameter"] for r in errors) if p != "nominal"]
    nominal = {r["estimator"]: r for r in errors if r["parameter"] == "nominal"}
    n = max(len(params), 1)
    cols = min(n, 4)
    fig, axes = plt.subplots(-(-n // cols), cols, figsize=(max(3.2 * cols, 6.5),
                                                           2.8 * -(-n // cols) + 0.4),
                             squeeze=False, sharey=True)
    ests = list(dict.fromkeys(r["estimator"] for r in errors))
    colours = {e: f"C{i % 10}" for i, e in enumerate(ests)}
    for ax, p in zip(axes.flat, params):
        for e in ests:
            rs = sorted([r for r in errors if r["parameter"] == p and r["estimator"] == e]
                        + ([{**nominal[e], "error": 0.0}] if e in nominal else []),
                        key=lambda r: r["error"])
            if not rs:
                continue
            x = [100 * r["error"] for r in rs]
            ax.plot(x, [r["median_rmse_vy"] for r in rs], "o-", color=colours[e], label=e, ms=3)
            ax.plot(x, [r["p90_rmse_vy"] for r in rs], "--", color=colours[e], lw=0.8)
        ax.set_xlabel(f"error of {p} [%]")
        ax.set_yscale("log")
    for ax in axes.flat[len(params):]:
        ax.set_visible(False)
    axes[0, 0].set_ylabel(r"$v_y$ RMSE [m/s]")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(r"$v_y$ RMSE vs vehicle-file errors: median (solid), 90th percentile (dashed)",
                 fontsize=9)
    return fig


def fig_conservatism(cons: list[dict]):
    """Conservatism map: enclosure rate (top) and mean width (bottom) of ``v_y`` per interval
    observer over the stiffness error (columns) and the box's speed range (rows). Cells with
    runs inside Ifqir 2017's assumptions (``guaranteed > 0``: matched LPV truth inside the
    box, bounded noise, no bias, exact speed in the bands) are framed in black."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    ests = list(dict.fromkeys((r["estimator"], f"{r['plant']}:{r['car']}") for r in cons
                              if np.isfinite(r["enclosure_mean"])))     # a panel per pair that ran
    fig, axes = plt.subplots(2, max(len(ests), 1), figsize=(4.2 * max(len(ests), 1), 5.6),
                             squeeze=False)
    for c, (e, pl_) in enumerate(ests):
        rs = [r for r in cons if r["estimator"] == e and f"{r['plant']}:{r['car']}" == pl_]
        xs = sorted({r["err_cf"] for r in rs})
        ys = sorted({(r["box_vx_min"], r["box_vx_max"], r["box_rel"]) for r in rs})
        for row, (key, title, cmap) in enumerate((("enclosure_mean", "enclosure", "RdYlGn"),
                                                  ("width_mean", "mean width [m/s]", "viridis"))):
            Z = np.full((len(ys), len(xs)), np.nan)
            inside = np.zeros(Z.shape, bool)
            for r in rs:
                ij = (ys.index((r["box_vx_min"], r["box_vx_max"], r["box_rel"])),
                      xs.index(r["err_cf"]))
                Z[ij] = r[key]
                inside[ij] |= r.get("guaranteed", 0) > 0
            ax = axes[row, c]
            for i, j in np.argwhere(inside):
                ax.add_patch(Rectangle((j - 0.48, i - 0.48), 0.96, 0.96, fill=False, ec="k",
                                       lw=1.6, zorder=5))
            im = ax.imshow(Z, aspect="auto", cmap=cmap, origin="lower",
                           vmin=(0.0 if key == "enclosure_mean" else None),
                           vmax=(1.0 if key == "enclosure_mean" else None))
            ax.set_xticks(range(len(xs)), [f"{100 * x:+.0f}" for x in xs], fontsize=7)
            ax.set_yticks(range(len(ys)), [f"{a:g}-{b:g} m/s, +-{100 * rr:.0f}%" for a, b, rr in ys],
                          fontsize=7)
            for (i, j), z in np.ndenumerate(Z):
                if np.isfinite(z):
                    ax.text(j, i, f"{z:.2f}", ha="center", va="center", fontsize=7,
                            bbox={"fc": "white", "alpha": 0.6, "lw": 0, "pad": 1})
            ax.set_title(f"{e} on {pl_}: {title}" + ("\n(framed: runs inside the paper's "
                                                     "assumptions)" if inside.any() else ""),
                         fontsize=8)
            ax.set_xlabel("stiffness error of the vehicle file [%]")
            fig.colorbar(im, ax=ax, shrink=0.8).set_label(
                "enclosure rate [-]" if key == "enclosure_mean" else "mean $v_y$ width [m/s]")
    return fig


def fig_feasibility(points: list[dict]):
    """LMI feasibility map: status over box half-width (x) and speed range (y), one panel per
    (car, kappa); the dotted line is the analytic Metzler bound of the untransformed
    observer."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    panels = list(dict.fromkeys((r["car"], r["kappa"]) for r in points))
    fig, axes = plt.subplots(1, max(len(panels), 1), figsize=(4.2 * max(len(panels), 1), 3.4),
                             squeeze=False)
    code = {"infeasible": 0, "inconclusive": 1, "feasible": 2}
    cmap = ListedColormap(["#c8553d", "#f2d0a4", "#588b8b"])
    for ax, (car, kappa) in zip(axes.flat, panels):
        rs = [r for r in points if r["car"] == car and r["kappa"] == kappa]
        xs = sorted({r["stiffness_rel"] for r in rs})
        ys = sorted({(r["vx_min"], r["vx_max"]) for r in rs})
        Z = np.full((len(ys), len(xs)), np.nan)
        for r in rs:
            Z[ys.index((r["vx_min"], r["vx_max"])), xs.index(r["stiffness_rel"])] = code[r["status"]]
        ext = [100 * xs[0], 100 * xs[-1], -0.5, len(ys) - 0.5] if len(xs) > 1 else None
        ax.imshow(Z, aspect="auto", cmap=cmap, vmin=0, vmax=2, origin="lower",
                  extent=ext, interpolation="nearest")
        ax.set_yticks(range(len(ys)), [f"{a:g}-{b:g} m/s" for a, b in ys], fontsize=7)
        if kappa == 0.0 and len(xs) > 1:
            ax.axvline(100 * rs[0]["metzler_bound"], color="k", ls=":", lw=1.2,
                       label="Metzler bound (analytic)")
            ax.legend(fontsize=7, loc="upper right")
        ax.set_xlabel("stiffness box half-width [%]")
        ax.set_title(f"{car}, kappa = {kappa:g} rad/m", fontsize=8)
    fig.suptitle("Theorem 2 LMIs: green feasible (certified), red infeasible, sand inconclusive "
                 "(margin at round-off)", fontsize=9)
    return fig


def fig_failures(fails: list[dict]):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 2.8))
    names = [r["estimator"] for r in fails]
    ax.barh(names, [100 * r["failure_rate"] for r in fails], color="C3")
    for i, r in enumerate(fails):
        ax.text(100 * r["failure_rate"], i, f" {r['failed']}/{r['n']}", va="center", fontsize=7)
    ax.set_xlabel("failed runs [%] (infeasible design, diverged filter, ...)")
    ax.set_xlim(0, 105)
    return fig


# ------------------------------------------------------------------ the whole report -------
def integrity(out, spec) -> dict:
    """Which batch files of ``out`` belong to ``spec`` (:func:`store.check_batches`):
    ``rejected`` ``[(file, reason), ...]`` (left out of every table), ``missing`` and
    ``lmi_missing`` (ranges of tasks / points in no verified file)."""
    good, bad = store.check_batches(out, spec, "results")
    lgood, lbad = store.check_batches(out, spec, "lmi")
    return {"rejected": bad + lbad, "missing": store.missing(spec, "results", good),
            "lmi_missing": store.missing(spec, "lmi", lgood)}


def integrity_lines(t: dict) -> list[str]:
    """Lines of the report naming the files left out and the tasks missing."""
    rej = t["rejected"]
    lines = [f"ignored {f.parent.name}/{f.name}: {why}" for f, why in rej[:store.MAX_NAMED]]
    if len(rej) > store.MAX_NAMED:
        lines.append(f"ignored {len(rej) - store.MAX_NAMED} more batch file(s) that do not "
                     "belong to this campaign")
    for key, what in (("missing", "simulation"), ("lmi_missing", "LMI map point")):
        n = sum(b - a for a, b in t[key])
        if n:
            lines.append(f"missing {n} {what}(s) (not run yet, or in an ignored file): "
                         f"{store.ranges_text(t[key])}")
    return lines


def tables(out) -> dict:
    """Every table of the report of campaign folder ``out`` (lists of dicts), from the
    batch files that belong to its spec only (each task counted once); ``integrity``
    names the files left out and the tasks missing."""
    spec = store.spec_of_folder(out)
    check = integrity(out, spec)
    df = _frame(out, spec)
    res = {"spec": spec, "rows": len(df), "integrity": check}
    if len(df):
        errs = error_table(df, spec.doc["errors"]["design"])
        res.update(errors=errs, conservatism=conservatism_table(df), failures=failure_table(df),
                   best=best_table(errs, exclude=tuple(REFERENCES.values())),
                   uncertainty=uncertainty_table(df), warnings=warning_table(df))
    else:
        res.update(errors=[], conservatism=[], failures=[], best=[], uncertainty=[], warnings=[])
    res["lmi_points"], res["lmi_summary"] = lmi_table(out, spec)
    return res


#: header of an empty table's CSV (a campaign whose tasks raised no warning)
HEADERS = {"warnings": ("estimator", "category", "tasks", "count", "first_message")}


def _csv(path: Path, rows: list[dict], header=()):
    import csv

    with open(path, "w", newline="") as fh:
        if not rows and not header:
            return
        w = csv.DictWriter(fh, fieldnames=list(rows[0]) if rows else list(header))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def _md(rows: list[dict], digits: int = 4) -> list[str]:
    if not rows:
        return ["(none)"]
    cols = list(rows[0])
    fmt = lambda v: f"{v:.{digits}g}" if isinstance(v, float) else str(v)
    return (["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
            + ["| " + " | ".join(fmt(r[c]).replace("|", "/") for c in cols) + " |" for r in rows])


def write_report(out, dest=None) -> dict:
    """Write the report of campaign folder ``out`` into ``dest`` (default ``out/report``):
    ``errors.csv``, ``conservatism.csv``, ``lmi_map.csv``, ``lmi_summary.csv``,
    ``failures.csv``, ``best.csv``, ``uncertainty.csv``, ``warnings.csv``, ``summary.md``
    and the figures (PNG). Returns the tables
    and ``files``."""
    from vehicle_observers.campaign.spec import SpecError

    out = Path(out)
    store.manifest(out)
    dest = Path(dest) if dest else out / "report"
    if dest.exists() and not dest.is_dir():
        raise SpecError(f"{dest}: exists and is not a folder (the report is written there); "
                        "move it away")
    t = tables(out)
    try:
        dest.mkdir(parents=True, exist_ok=True)
        return _write(dest, t)
    except OSError as exc:
        raise SpecError(f"{dest}: cannot write the report ({store.write_reason(exc)})") from None


def _write(dest: Path, t: dict) -> dict:
    import matplotlib.pyplot as plt

    names = {"errors": "errors", "conservatism": "conservatism", "lmi_points": "lmi_map",
             "lmi_summary": "lmi_summary", "failures": "failures", "best": "best",
             "uncertainty": "uncertainty", "warnings": "warnings"}
    files = []
    for k, fn in names.items():
        _csv(dest / f"{fn}.csv", t[k], HEADERS.get(k, ()))
        files.append(dest / f"{fn}.csv")
    figs = {"error_effect": (fig_error_effect, "errors"),
            "conservatism": (fig_conservatism, "conservatism"),
            "feasibility": (fig_feasibility, "lmi_points"), "failures": (fig_failures, "failures")}
    for name, (fn, key) in figs.items():
        if t[key]:
            fig = fn(t[key])
            fig.tight_layout()
            fig.savefig(dest / f"{name}.png", dpi=110, metadata={"Software": None})
            plt.close(fig)
            files.append(dest / f"{name}.png")
    spec = t["spec"]
    warn = integrity_lines(t["integrity"])
    lines = [f"# Campaign {spec.doc['name']} (spec {spec.sha256[:12]})", "",
             f"{t['rows']} of {spec.n_tasks} simulations done; "
             f"{len(t['lmi_points'])} of {len(spec.lmi_points)} LMI map points.", "",
             *([*(f"- {w}" for w in warn), ""] if warn else []),
             "## v_y RMSE [m/s] against the vehicle file's errors", "", *_md(t["errors"]), "",
             "## Best estimator per region", "", *_md(t["best"]), "",
             "## Reported uncertainty of v_y per truth plant", "",
             "2-sigma coverage: share of scored samples with |v_y error| <= 2 vy_std_mps "
             "(0.954 for a consistent Gaussian std); mean NEES: mean of (v_y error / "
             f"vy_std_mps)^2 (1 when consistent); {NA}: the estimator reports no std.", "",
             *_md(t["uncertainty"]), "",
             "## Interval observers: conservatism map", "", *_md(t["conservatism"]), "",
             "## LMI feasibility of the interval design", "", *_md(t["lmi_summary"]), "",
             "## Failures", "", *_md(t["failures"]), "",
             "## Warnings raised by the tasks", "", *_md(t["warnings"]), ""]
    (dest / "summary.md").write_text("\n".join(lines) + "\n")
    files.append(dest / "summary.md")
    t["files"] = files
    return t
