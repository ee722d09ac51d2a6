"""One benchmark for every registered observer (``make bench`` = ``python -m
vehicle_observers_papers.benchmark_study.suite``; Notebook 07 shows the same tables and plots).

Datasets (:func:`datasets`)
    ``satory_n1`` / ``satory_n3``: the emulated Satory run (:func:`scenarios.emulated_satory`)
    at sensor-noise scale 1 and 3; ``swd``: sine with dwell at 17 m/s reaching ~7 deg front
    slip (nonlinear tyre region, :func:`scenarios.sine_with_dwell`); ``revs``: the real Revs
    250 LM log (INS ``v_y`` as reference). Emulated runs use the ``yacine2015`` vehicle file,
    the real log ``revs250lm``.

Observers: every registry entry whose required columns the dataset has. The filterpy EKF and
UKF (pure Python, ~0.1-1 ms per step) run on ``filterpy_steps`` samples only, starting at the
first scored sample; their rows say so (``samples`` column), their accuracy is over that
window and they get no ratio against the whole-run EKF/RTS.

Kalman noise tuning: ML on the measured channels of each log's first 120 s
(:func:`kalman_runs.kalman_tuning`); the 7 s sine-with-dwell is too short for ML and reuses the
tuning of the Satory run with the same noise level (same car and sensors).

Metrics (:func:`scoring.score`): RMSE / max error of ``v_y``, sideslip, yaw rate (against the
noise-free yaw rate in emulated logs, the measured one on the real log), axle forces where
the log has them; interval enclosure and mean width. Emulated runs are scored where
``v_x > 1 m/s`` and ``t > 1 s`` (the run starts from 0.2 m/s where every model is singular);
the real log on every sample. Cost per step = wall time of the estimation loop (compiled,
after a warm-up) / samples; real-time factor = log duration / wall time; design time = LMI
solve (or ML tuning for the Kalman filters). Ratios: ``rmse_vy`` / that of ``ekf`` and of
``rts`` on the same dataset; speed-up = filterpy EKF cost per step / the observer's.

Outputs in ``figures/benchmark/``: ``benchmark.csv``, ``benchmark.md``, ``speed_topics.csv``
(the per-topic benchmarks of ``vehicle_observers/bench/<topic>.py``), ``losses_revs.csv``
(where each estimator loses on the real log) and PNG plots.
"""

from __future__ import annotations

import argparse
import csv
import importlib
import sys
import time
from pathlib import Path

import numpy as np
from vehicle_observers import estimation as EST
from vehicle_observers.core.metrics import rmse
from vehicle_observers.data.logs import DriveLog, load_revs, repo_root
from vehicle_observers.estimation import kalman_runs as KR
from vehicle_observers.models.vehicle import load_vehicle

COLUMNS = ["dataset", "observer", "causal", "samples", "rmse_vy", "max_vy", "rmse_beta",
           "max_beta", "rmse_r", "max_r", "rmse_Ff", "max_Ff", "rmse_Fr", "max_Fr",
           "enclosure_vy", "width_vy", "enclosure_r", "width_r", "us_per_step",
           "realtime_factor", "design_s", "ratio_vy_vs_ekf", "ratio_vy_vs_rts",
           "speedup_vs_filterpy_ekf"]
SLOW = ("ekf-filterpy", "ukf")
KALMAN = ("ekf", "ekf-filterpy", "ukf", "rts")
#: one colour per observer in every plot
COLORS = {"ekf": "C1", "ekf-filterpy": "C0", "ukf": "C2", "rts": "C3", "ts-yacine2015": "C4",
          "interval-ifqir2017": "C5"}


def _color(name, j=0):
    return COLORS.get(name, f"C{6 + j % 4}")


#: references on the Revs log (the publishing repository's results, see data/revs_250lm_2014/
#: PROVENANCE.md): v_y RMSE [m/s] over the whole run
REVS_REFERENCES = {"vy = 0": 0.743, "their KF (linear bicycle, r + a_y)": 0.350,
                   "open-loop linear bicycle": 0.282, "offline factor graph": 0.242}


def datasets(seed: int = 0, quick: bool = False) -> dict[str, tuple[DriveLog, str, np.ndarray]]:
    """``{name: (log, vehicle file, score mask)}``. Quick: the first 40 s of the Satory run
    (the Revs log is always used whole: the numba estimators need ~0.1 s for it)."""
    from vehicle_observers.data.scenarios import emulated_satory, sine_with_dwell

    out = {}
    for ns in (1.0, 3.0):
        log = emulated_satory(seed=seed, quick=quick, noise_scale=ns)
        out[f"satory_n{ns:g}"] = (log, "yacine2015", _emu_mask(log))
    swd = sine_with_dwell(seed=seed)
    out["swd"] = (swd, "yacine2015", _emu_mask(swd))
    revs = load_revs()
    out["revs"] = (revs, "revs250lm", np.ones(len(revs), bool))
    return out


def _emu_mask(log):
    vx = log.extra.get("vx_true_mps", log.vx)
    return (vx > 1.0) & (log.t - log.t[0] > 1.0)


def _warm_up(observers, vehicles):
    """Compile every numba kernel once on a short emulated log (not timed)."""
    from vehicle_observers.data.scenarios import sine_with_dwell

    log = sine_with_dwell(seed=0, t_after=0.5)
    veh = vehicles["yacine2015"]
    from vehicle_observers.models.vehicle import KalmanTuning

    for name, spec in observers.items():
        if name in SLOW:
            continue
        try:
            spec.check(log, veh)
            spec.run(log.segment(0.0, 0.3), veh, tuning=KalmanTuning())
        except Exception:  # noqa: BLE001 - warm-up only; the real run reports errors
            pass


def run(seed: int = 0, quick: bool = False, filterpy_steps: int | None = None,
        observers=None, progress=None, tune_maxiter: int = 300) -> dict:
    """Run the benchmark (``tune_maxiter``: Nelder-Mead iterations per start of the ML
    tuning; do not lower it: a stopped-early search can leave large ``q_vy, q_b`` with which
    the EKF drifts onto the saturated-tyre branch, e.g. 13.5 m/s RMSE on the quick n3 run
    with 120 iterations against 0.0015 with 300). Returns ``{"rows": [...], "estimates":
    {(dataset, obs): Estimates}, "logs": {...}, "tunings": {...}, "errors": [...]}``."""
    filterpy_steps = filterpy_steps or (3000 if quick else 60000)
    obs = EST.available()
    if observers is not None:
        obs = {k: v for k, v in obs.items() if k in observers}
    vehicles = {n: load_vehicle(n) for n in ("yacine2015", "revs250lm")}
    _warm_up(obs, vehicles)
    data = datasets(seed, quick)
    rows, ests, tunings, errors = [], {}, {}, []
    for dname, (log, vname, mask) in data.items():
        veh = vehicles[vname]
        if not any(o in KALMAN for o in obs):
            tun, tsec = None, 0.0
        elif dname == "swd":
            tun, tsec = tunings["satory_n1"]
        else:
            tun, tsec = KR.kalman_tuning(log, veh, maxiter=tune_maxiter)
        if tun is not None:
            tunings[dname] = (tun, tsec)
        for oname, spec in obs.items():
            if progress:
                progress(f"{dname}: {oname}")
            try:
                spec.check(log, veh)
            except Exception:  # noqa: BLE001 - not applicable to this dataset
                continue
            lg, mk = log, mask
            if oname in SLOW and len(log) > filterpy_steps:
                # window of filterpy_steps samples starting where the scoring mask starts
                i0 = int(np.argmax(mask))
                i1 = min(i0 + filterpy_steps, len(log))
                lg = log.segment(log.t[i0], log.t[i1 - 1])
                mk = mask[i0:i1]
            try:
                est = spec.run(lg, veh, tuning=tun)
            except Exception as exc:  # noqa: BLE001 - reported in the table
                errors.append(f"{dname}/{oname}: {type(exc).__name__}: {exc}")
                continue
            if est.estimator.startswith(("ekf", "ukf", "rts")):
                est.design_seconds = tsec
            ests[(dname, oname)] = est
            m = EST.score(est, lg, mk)
            row = {"dataset": dname, "observer": oname, "causal": est.causal,
                   "samples": len(lg), **m, "us_per_step": est.us_per_step,
                   "realtime_factor": lg.duration / max(est.seconds, 1e-12),
                   "design_s": est.design_seconds}
            rows.append(row)
    _ratios(rows)
    return {"rows": rows, "estimates": ests, "logs": {k: v[0] for k, v in data.items()},
            "masks": {k: v[2] for k, v in data.items()}, "tunings": tunings, "errors": errors,
            "quick": bool(quick), "seed": int(seed)}


def _ratios(rows):
    by = {(r["dataset"], r["observer"]): r for r in rows}
    for r in rows:
        for ref, key in (("ekf", "ratio_vy_vs_ekf"), ("rts", "ratio_vy_vs_rts")):
            b = by.get((r["dataset"], ref))
            if b is not None and "rmse_vy" in r and b.get("samples") == r["samples"]:
                r[key] = r["rmse_vy"] / b["rmse_vy"]
            elif b is not None and "rmse_vy" in r:
                r[key] = float("nan")  # different window (filterpy rows): see samples
        fp = by.get((r["dataset"], "ekf-filterpy"))
        if fp is not None:
            r["speedup_vs_filterpy_ekf"] = fp["us_per_step"] / r["us_per_step"]


# ------------------------------------------------------------------ losses on the real log
def revs_losses(log: DriveLog, ests: dict, names=("ekf", "ukf", "rts", "interval-ifqir2017")):
    """Where each estimator loses on the real log: v_y RMSE by |a_y| bin (slip saturation),
    by speed bin, and by the disagreement of the a_y channel with ``dv_y/dt + v_x r`` computed
    from the INS reference (``d_ay``). Rows ``{"factor", "bin", "share", <observer>: rmse}``."""
    ay = np.abs(log.extra.get("ay_filt_mps2", log.ay))
    vy_dot = np.gradient(log.vy, log.t)
    d_ay = np.abs(log.ay - (vy_dot + log.vx * log.yaw_rate))
    factors = {"|a_y| [m/s^2]": (ay, [0, 4, 8, 10, 20]),
               "v_x [m/s]": (log.vx, [0, 25, 35, 45, 70]),
               "|a_y - (dv_y/dt + v_x r)| [m/s^2]": (d_ay, [0, 0.5, 1.0, 2.0, 100])}
    rows = []
    for fname, (x, edges) in factors.items():
        for lo, hi in zip(edges[:-1], edges[1:]):
            m = (x >= lo) & (x < hi)
            if m.sum() < 10:
                continue
            row = {"factor": fname, "bin": f"[{lo:g}, {hi:g})", "share": float(m.mean())}
            for n in names:
                e = ests.get(n)
                if e is not None and len(e.t) == len(log):
                    row[n] = rmse(e.columns["vy_mps"], log.vy, m)
            rows.append(row)
    return rows


def amplitude_ratio(est, ref) -> float:
    """Least-squares gain ``g`` of ``ref ~ g est`` (< 1: the estimate overshoots the
    reference's amplitude)."""
    est, ref = np.asarray(est, float), np.asarray(ref, float)
    return float(np.dot(est, ref) / np.dot(est, est))


# ------------------------------------------------------------------ topic speed benchmarks
#: the per-paper speed benchmarks: topic -> module with ``run(quick) -> rows``
SPEED_TOPICS = {"cli": "vehicle_observers.bench.cli",
                "dmvt": "vehicle_observers_papers.ichalal_2011.speed",
                "interval": "vehicle_observers_papers.ifqir_2017.speed",
                "kalman": "vehicle_observers_papers.leanza_2021.speed",
                "sliding_mode": "vehicle_observers_papers.rabhi_2004.speed",
                "uio": "vehicle_observers_papers.elyoussfi_2020.speed",
                "yacine": "vehicle_observers_papers.yacine_2015.speed"}


def topic_benchmarks(quick: bool = False, skip=()) -> list[dict]:
    """Run every ``run(quick)`` of :data:`SPEED_TOPICS` (the command line's end-to-end speed
    and each paper's observers) and tag rows by topic."""
    rows = []
    for mod, path in sorted(SPEED_TOPICS.items()):
        if mod in skip:
            continue
        try:
            m = importlib.import_module(path)
            for r in m.run(quick=quick):
                rows.append({"topic": mod, **r})
        except Exception as exc:  # noqa: BLE001 - one failing topic must not hide the rest
            rows.append({"topic": mod, "component": f"FAILED: {type(exc).__name__}: {exc}",
                         "steps": 0, "seconds": float("nan"), "us_per_step": float("nan")})
    return rows


# ------------------------------------------------------------------ tables / files ------
def _fmt(v, col=""):
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "OFFLINE"
    if isinstance(v, (int, np.integer)):
        return str(v)
    if isinstance(v, float):
        if col.startswith("enclosure"):
            return f"{100 * v:.1f} %"
        return f"{v:.4g}"
    return str(v)


def markdown_table(rows, cols) -> str:
    cols = [c for c in cols if any(c in r for r in rows)]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        lines.append("| " + " | ".join(_fmt(r.get(c), c) for c in cols) + " |")
    return "\n".join(lines)


def write_csv_rows(path: Path, rows, cols=None):
    cols = cols or list(dict.fromkeys(k for r in rows for k in r))
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({c: ("" if r.get(c) is None else r.get(c)) for c in cols})


def summary_columns():
    return ["dataset", "observer", "causal", "samples", "rmse_vy", "max_vy", "rmse_beta",
            "rmse_r", "rmse_Ff", "rmse_Fr", "enclosure_vy", "width_vy", "enclosure_r",
            "width_r", "us_per_step", "realtime_factor", "design_s", "ratio_vy_vs_ekf",
            "ratio_vy_vs_rts", "speedup_vs_filterpy_ekf"]


# ------------------------------------------------------------------ plots ---------------
def _bars(ax, rows, key, ds, obs):
    w = 0.8 / len(obs)
    for j, o in enumerate(obs):
        xs, ys = [], []
        for i, d in enumerate(ds):
            r = next((r for r in rows if r["dataset"] == d and r["observer"] == o), None)
            if r is not None and np.isfinite(r.get(key, np.nan)):
                xs.append(i + j * w)
                ys.append(r[key])
        ax.bar(xs, ys, w, label=o, color=_color(o, j))
    ax.set_xticks(np.arange(len(ds)) + 0.4 - w / 2)
    ax.set_xticklabels(ds)
    ax.set_yscale("log")


def fig_rmse(rows, target: float = 0.24):
    """$v_y$ RMSE per dataset and observer (log scale), the real-log target as a dotted line;
    legend beside the axes."""
    import matplotlib.pyplot as plt

    ds = list(dict.fromkeys(r["dataset"] for r in rows))
    obs = list(dict.fromkeys(r["observer"] for r in rows))
    fig, ax = plt.subplots(figsize=(10, 4.2))
    _bars(ax, rows, "rmse_vy", ds, obs)
    ax.set_ylabel(r"$v_y$ RMSE [m/s]")
    ax.set_xlabel("dataset")
    ax.axhline(target, color="k", ls=":", lw=0.8, label=f"real-log target {target:g} m/s")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    return fig


def fig_rmse_cost(rows):
    """Accuracy and wall-clock cost per step side by side (``make bench`` only: the cost
    changes on every run, so this figure is not part of the committed notebook figures)."""
    import matplotlib.pyplot as plt

    ds = list(dict.fromkeys(r["dataset"] for r in rows))
    obs = list(dict.fromkeys(r["observer"] for r in rows))
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.2))
    _bars(ax[0], rows, "rmse_vy", ds, obs)
    _bars(ax[1], rows, "us_per_step", ds, obs)
    ax[0].set_ylabel(r"$v_y$ RMSE [m/s]")
    ax[1].set_ylabel(r"cost per step [$\mu$s]")
    ax[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    return fig


def fig_revs(log, ests, t_zoom=None):
    import matplotlib.pyplot as plt
    from vehicle_observers.core.arrays import decimate

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
                a.fill_between(te, lo, hi, color=_color(n, k), alpha=0.15, lw=0,
                               label=f"{n} [lo, hi]")
            else:
                a.plot(te, v, color=_color(n, k), lw=0.8, label=n)
        a.plot(tt, ref, color="k", lw=0.9, label="INS reference")
        a.set_ylabel("v_y [m/s]")
    ax[0].legend(ncol=5, fontsize=7, loc="upper right")
    ax[1].set_xlabel("t [s]")
    ax[0].set_title("Revs 250 LM: lateral velocity estimates")
    return fig


def fig_losses(loss_rows):
    import matplotlib.pyplot as plt

    factors = list(dict.fromkeys(r["factor"] for r in loss_rows))
    names = [k for k in loss_rows[0] if k not in ("factor", "bin", "share")]
    fig, ax = plt.subplots(1, len(factors), figsize=(13, 4.4), sharey=True)
    labels = {"|a_y| [m/s^2]": r"$|a_y|$ [m/s$^2$]", "v_x [m/s]": r"$v_x$ [m/s]",
              "|a_y - (dv_y/dt + v_x r)| [m/s^2]": r"$|a_y - (\dot v_y + v_x r)|$ [m/s$^2$]"}
    for a, f in zip(np.atleast_1d(ax), factors):
        rr = [r for r in loss_rows if r["factor"] == f]
        x = np.arange(len(rr))
        w = 0.8 / max(len(names), 1)
        for j, n in enumerate(names):
            a.bar(x + j * w, [r.get(n, np.nan) for r in rr], w, label=n, color=_color(n, j))
        a.set_xticks(x + 0.4 - w / 2)
        a.set_xticklabels([f"{r['bin']}\n{100 * r['share']:.0f} %" for r in rr], fontsize=7)
        a.set_xlabel(labels.get(f, f) + "\n(bin, share of samples)")
    np.atleast_1d(ax)[0].set_ylabel(r"$v_y$ RMSE [m/s]")
    np.atleast_1d(ax)[-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                                 borderaxespad=0)
    return fig


def write_outputs(res: dict, out_dir: Path, topics=None) -> list[Path]:
    """CSV + Markdown tables and plots into ``out_dir``; returns the written paths."""
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    rows = res["rows"]
    paths = []
    p = out_dir / "benchmark.csv"
    write_csv_rows(p, rows, COLUMNS)
    paths.append(p)
    md = ["# Observer benchmark", "",
          "Generated by `python -m vehicle_observers_papers.benchmark_study` (`make bench`); "
          "see the module docstring for the protocol.", "",
          markdown_table(rows, summary_columns()), ""]
    if "revs" in res["logs"]:
        md += ["Real-log references (v_y RMSE over the whole run, PROVENANCE.md): " + ", ".join(
            f"{k} {v}" for k, v in REVS_REFERENCES.items()) + " m/s.", ""]
        loss = revs_losses(res["logs"]["revs"], {o: e for (d, o), e in res["estimates"].items()
                                                   if d == "revs"})
        write_csv_rows(out_dir / "losses_revs.csv", loss)
        paths.append(out_dir / "losses_revs.csv")
        md += ["## Where the estimators lose on the real log (v_y RMSE by bin)", "",
               markdown_table(loss, list(loss[0])), ""]
        fig = fig_losses(loss)
        fig.savefig(out_dir / "losses_revs.png", dpi=110, metadata={"Software": None},
                    bbox_inches="tight")
        plt.close(fig)
        paths.append(out_dir / "losses_revs.png")
        fig = fig_revs(res["logs"]["revs"], {o: e for (d, o), e in res["estimates"].items()
                                             if d == "revs"})
        fig.savefig(out_dir / "revs_vy.png", dpi=110, metadata={"Software": None})
        plt.close(fig)
        paths.append(out_dir / "revs_vy.png")
    md += ["## Kalman noise tuning (ML on measured channels)", ""]
    for d, (tun, sec) in res["tunings"].items():
        md.append(f"- {d}: q_vy={tun.q_vy:.3g}, q_r={tun.q_r:.3g}, q_b={tun.q_b:.3g}, "
                  f"R_r={tun.R_r:.3g}, R_ay={tun.R_ay:.3g} ({tun.source}; {sec:.1f} s)")
    md.append("")
    if topics:
        write_csv_rows(out_dir / "speed_topics.csv", topics)
        paths.append(out_dir / "speed_topics.csv")
        md += ["## Per-topic speed benchmarks (`vehicle_observers/bench/<topic>.py`)", "",
               markdown_table(topics, ["topic", "component", "steps", "seconds",
                                       "us_per_step"]), ""]
    if res["errors"]:
        md += ["## Errors", ""] + [f"- {e}" for e in res["errors"]] + [""]
    (out_dir / "benchmark.md").write_text("\n".join(md))
    paths.append(out_dir / "benchmark.md")
    fig = fig_rmse_cost(rows)
    fig.savefig(out_dir / "rmse_cost.png", dpi=110, metadata={"Software": None}, bbox_inches="tight")
    plt.close(fig)
    paths.append(out_dir / "rmse_cost.png")
    # metrics.json in the notebooks' format (tests/test_repository.py checks the file list)
    import json

    from vehicle_observers.results.reporting import _jsonable

    names = sorted({p.name for p in paths} | {"metrics.json"})
    doc = {"notebook": "benchmark", "quick": bool(res.get("quick", False)),
           "seed": int(res.get("seed", 0)),
           "metrics": {k: {"value": _jsonable(v), "unit": "", "note": ""}
                       for k, v in {**key_metrics(res), **timing_metrics(res)}.items()},
           "claims": [], "files": names}
    (out_dir / "metrics.json").write_text(json.dumps(_jsonable(doc), indent=1) + "\n")
    paths.append(out_dir / "metrics.json")
    for f in out_dir.iterdir():  # leftovers of an earlier run with other options
        if f.is_file() and f.name not in names and f.suffix in (".csv", ".md", ".png", ".json"):
            f.unlink()
    return paths


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m vehicle_observers_papers.benchmark_study.suite")
    ap.add_argument("--quick", action="store_true", help="short runs (CI)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=str(repo_root() / "build" / "benchmark"),
                    help="output folder (default build/benchmark, ignored by git: wall-clock "
                    "results change on every run)")
    ap.add_argument("--no-topics", action="store_true",
                    help="skip the per-topic speed benchmarks")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    res = run(seed=args.seed, quick=args.quick,
              progress=lambda s: print(f"  running {s}", file=sys.stderr, flush=True))
    topics = None if args.no_topics else topic_benchmarks(args.quick)
    paths = write_outputs(res, Path(args.out), topics)
    print(markdown_table(res["rows"], summary_columns()))
    if topics:
        print()
        print(markdown_table(topics, ["topic", "component", "steps", "seconds", "us_per_step"]))
    for e in res["errors"]:
        print("error:", e)
    km = key_metrics(res)
    rv = {o: km.get(f"revs.{o}.rmse_vy") for o in ("ekf", "rts")}
    best = (km["revs.best_causal"], km["revs.best_causal_rmse_vy"]) \
        if "revs.best_causal" in km else None
    revs_diag = None
    if "revs" in res["logs"] and "revs" in res["tunings"]:
        revs_diag = rts_diagnosis(res["logs"]["revs"], load_vehicle("revs250lm").params,
                                  res["tunings"]["revs"][0], seed=args.seed)
    print_plant_section(args.seed, args.quick, best, rv["rts"], rv["ekf"], revs_diag=revs_diag)
    print(f"\nwrote {', '.join(str(p) for p in paths)} in {time.perf_counter() - t0:.1f} s")
    return 0



#: wall-clock columns: reported by ``make bench`` and ``Report.timing``, never committed as
#: notebook metrics (they change on every run)
TIMING_COLUMNS = ("us_per_step", "realtime_factor", "design_s", "speedup_vs_filterpy_ekf")


def key_metrics(res: dict) -> dict:
    """Flat accuracy metrics for the notebook / tests: ``<dataset>.<observer>.<metric>`` for
    the accuracy and ratio columns, plus ``revs.best_causal`` (name) /
    ``revs.best_causal_rmse_vy`` over the causal observers run on the whole real log. The
    wall-clock columns are in :func:`timing_metrics`."""
    out = {}
    keep = ("rmse_vy", "max_vy", "rmse_beta", "rmse_r", "rmse_Ff", "rmse_Fr", "enclosure_vy",
            "width_vy", "enclosure_r", "width_r", "ratio_vy_vs_ekf", "ratio_vy_vs_rts", "samples")
    for r in res["rows"]:
        for k in keep:
            v = r.get(k)
            if v is not None and not (isinstance(v, float) and not np.isfinite(v)):
                out[f"{r['dataset']}.{r['observer']}.{k}"] = v
    n_revs = len(res["logs"]["revs"]) if "revs" in res["logs"] else 0
    causal = [r for r in res["rows"] if r["dataset"] == "revs" and r["causal"]
              and r["samples"] == n_revs and "rmse_vy" in r]
    if causal:
        best = min(causal, key=lambda r: r["rmse_vy"])
        out["revs.best_causal"] = best["observer"]
        out["revs.best_causal_rmse_vy"] = best["rmse_vy"]
    return out


def timing_metrics(res: dict) -> dict:
    """Wall-clock values ``<dataset>.<observer>.<column>`` and ``min_speedup_vs_filterpy_ekf``
    over the compiled causal observers (all datasets; the offline RTS smoother excluded)."""
    out = {}
    for r in res["rows"]:
        for k in TIMING_COLUMNS:
            v = r.get(k)
            if v is not None and np.isfinite(v):
                out[f"{r['dataset']}.{r['observer']}.{k}"] = v
    sp = [r["speedup_vs_filterpy_ekf"] for r in res["rows"]
          if r["observer"] not in SLOW and r["causal"] and "speedup_vs_filterpy_ekf" in r]
    if sp:
        out["min_speedup_vs_filterpy_ekf"] = float(min(sp))
    return out


if __name__ == "__main__":
    sys.exit(main())


# ------------------------------------------------------------------ independent plant -----
# Rows on the CommonRoad multi-body plant (:mod:`vehicle_observers.data.plant`): the model is
# *not* the observers' (camber, roll, load transfer, compliance, combined-slip PAC2002
# tyres). The vehicle file is the library's data sheet (:func:`plant.nominal_params`), with
# a +-10 % stiffness box over 5..40 m/s. Targets (printed): best project observer v_y RMSE
# <= 0.8 x the open-loop linear bicycle with the same vehicle file; RTS <= EKF; the interval
# observer certified for every car, 100 % enclosure on matched-model runs, width and
# enclosure under mismatch; Revs best causal v_y RMSE <= 0.20 m/s.

PLANT_OBSERVERS = ("ekf", "ukf", "rts", "interval-coordinates")
PLANT_MANOEUVRES = ("satory", "sine_with_dwell", "slalom")
REVS_TARGET = 0.20


def plant_vehicle(rel: float = 0.10, vx_min: float = 5.0, vx_max: float = 40.0):
    """The plant car's vehicle file as a :class:`~vehicle_observers.models.vehicle.Vehicle`
    (data-sheet constants, no fitting)."""
    from vehicle_observers.data import plant
    from vehicle_observers.models.vehicle import Vehicle

    p = plant.nominal_params()
    return Vehicle(name=p.name, params=p, uncertainty={"stiffness_rel": rel, "vx_min": vx_min,
                                                       "vx_max": vx_max, "slip_max_deg": 8.0})


def open_loop_linear(log: DriveLog, params) -> np.ndarray:
    """v_y [m/s] of the open-loop linear bicycle (zero-slip slopes of ``params``' tyres,
    steady forces) driven by the measured steering and speed, from ``v_y = 0``."""
    from dataclasses import replace as _replace

    from vehicle_observers.models.lateral import simulate_s1
    from vehicle_observers.models.tires import LinearTire

    lin = _replace(params, tire_f=LinearTire(params.tire_f.cornering_stiffness),
                   tire_r=LinearTire(params.tire_r.cornering_stiffness))
    X = simulate_s1([0.0, float(log.yaw_rate[0])], log.delta, log.vx, log.dt, lin,
                    exact=False, relaxation=False, substeps=4)
    return X[:, 0]


def plant_stiffness_box(log: DriveLog, params, min_slip_deg: float = 0.5) -> dict:
    """The stiffness box the plant actually needs: the plant's equivalent axle forces over
    the bicycle slip angles of its truth, ``c = F / alpha`` where ``|alpha| >= min_slip_deg``,
    relative to the vehicle file's zero-slip slope. Returns min / max ratios per axle."""
    ex = log.extra
    vx, r, d = ex["vx_true_mps"], ex["yaw_rate_true_radps"], ex["delta_true_rad"]
    af = d - (log.vy + params.a_f * r) / vx
    ar = -(log.vy - params.a_r * r) / vx
    out = {}
    for ax, F, a, c0 in (("f", log.Ff, af, params.tire_f.cornering_stiffness),
                         ("r", log.Fr, ar, params.tire_r.cornering_stiffness)):
        k = np.abs(a) >= np.radians(min_slip_deg)
        q = F[k] / a[k] / c0 if k.any() else np.array([np.nan])
        out[f"c{ax}_ratio_min"], out[f"c{ax}_ratio_max"] = float(q.min()), float(q.max())
    return out


def independent_plant_rows(seed: int = 0, quick: bool = False, manoeuvres=PLANT_MANOEUVRES,
                           observers=PLANT_OBSERVERS) -> list[dict]:
    """One row per (manoeuvre, estimator) on the plant, plus ``open-loop-linear``; each row
    has the :func:`~vehicle_observers.estimation.scoring.score` metrics over ``t > 1 s``."""
    from vehicle_observers.data import plant

    veh = plant_vehicle()
    obs = EST.available()
    rows = []
    for name in manoeuvres:
        log = plant.plant_log(name, seed=seed, quick=quick)
        mask = log.t - log.t[0] > 1.0
        tun, _ = KR.kalman_tuning(log, veh)
        ol = open_loop_linear(log, veh.params)
        rows.append({"dataset": f"plant_{name}", "observer": "open-loop-linear",
                     "causal": True, "rmse_vy": rmse(ol, log.vy, mask)})
        for o in observers:
            est = obs[o].run(log, veh, tuning=tun)
            rows.append({"dataset": f"plant_{name}", "observer": o, "causal": est.causal,
                         **EST.score(est, log, mask)})
            if o == "rts":
                rows[-1].update(rts_diagnosis(log, veh.params, tun, mask))
        rows[-len(observers) - 1].update(plant_stiffness_box(log, veh.params))
    return rows


#: columns of :func:`rts_diagnosis` added to the ``rts`` rows
RTS_DIAG_COLUMNS = ("matched_rts_over_ekf", "innov_p_r", "innov_p_ay", "q_b", "dvy_db_r2",
                    "smoother_correct", "model_mismatch")


def rts_diagnosis(log: DriveLog, params, tuning, mask=None, seed: int = 0) -> dict:
    """Why the RTS smoother may lose to the EKF on ``log`` (measured channels only, see
    :mod:`vehicle_observers.baselines.smoother_check`): the RTS/EKF v_y RMSE ratio on data
    simulated by the observer's own model with the same tuning (seeds ``seed..seed+2``), the
    Ljung-Box p-values of the EKF's normalised yaw-rate and a_y innovations, the tuned bias
    intensity ``q_b`` [(m/s^2)^2/s], the R^2 of the smoother's v_y change on its b_ay change,
    and the computed ``smoother_correct`` / ``model_mismatch``."""
    from vehicle_observers.baselines import smoother_check as SC

    d = SC.rts_loss_diagnosis(log, params, tuning, seeds=(seed, seed + 1, seed + 2),
                              mask=mask)
    return {"matched_rts_over_ekf": d["matched_ratio"], "innov_p_r": d["r_p"],
            "innov_p_ay": d["ay_p"], "q_b": d["q_b"], "dvy_db_r2": d["dvy_db_r2"],
            "smoother_correct": d["smoother_correct"], "model_mismatch": d["model_mismatch"]}


def diagnosis_metrics(prefix: str, diag: dict) -> dict:
    """Flat metrics of :func:`rts_diagnosis` for notebook 07: ``<prefix>_rts_matched_ratio``
    (RTS / EKF v_y RMSE on data drawn from the filter's own model), ``<prefix>_innov_p_r`` and
    ``<prefix>_innov_p_ay`` (Ljung-Box p-values of the normalised innovations; the a_y one
    only when the log has a_y)."""
    out = {f"{prefix}_rts_matched_ratio": float(diag["matched_rts_over_ekf"]),
           f"{prefix}_innov_p_r": float(diag["innov_p_r"])}
    if np.isfinite(diag["innov_p_ay"]):
        out[f"{prefix}_innov_p_ay"] = float(diag["innov_p_ay"])
    return out


def rts_target(dataset: str, rts: float, ekf: float, diag: dict | None = None) -> dict:
    """The target "RTS <= EKF" (v_y RMSE [m/s]) with, when ``diag`` (:func:`rts_diagnosis`)
    is given, ``explained``: the target is missed, the smoother beats the filter on its own
    model (``smoother_correct``) and the log's innovations show the model mismatch
    (``model_mismatch``). All fields computed."""
    v = rts / ekf
    out = {"dataset": dataset, "target": "RTS <= EKF", "value": v, "limit": 1.0,
           "met": v <= 1.0, "detail": f"rts {rts:.4f} vs ekf {ekf:.4f} m/s"}
    if diag:
        out["explained"] = bool(not out["met"] and diag["smoother_correct"]
                                and diag["model_mismatch"])
        out["detail"] += (f"; own-model rts/ekf {diag['matched_rts_over_ekf']:.3f}; "
                          f"innovation whiteness p(r) {diag['innov_p_r']:.2g}, "
                          f"p(a_y) {diag['innov_p_ay']:.2g}; q_b {diag['q_b']:.3g}; "
                          f"R^2(dv_y ~ db_ay) {diag['dvy_db_r2']:.2f}")
    return out


def plant_targets(rows: list[dict]) -> list[dict]:
    """Per manoeuvre: best project observer's v_y RMSE vs 0.8 x open loop, RTS vs EKF,
    interval enclosure / width under mismatch. ``met`` is computed, never typed."""
    out = []
    for ds in dict.fromkeys(r["dataset"] for r in rows):
        rr = {r["observer"]: r for r in rows if r["dataset"] == ds}
        ol = rr["open-loop-linear"]["rmse_vy"]
        causal = {o: r["rmse_vy"] for o, r in rr.items()
                  if o != "open-loop-linear" and "rmse_vy" in r}
        best = min(causal, key=causal.get)
        out.append({"dataset": ds, "target": "best observer <= 0.8 x open loop",
                    "value": causal[best] / ol, "limit": 0.8, "met": causal[best] / ol <= 0.8,
                    "detail": f"{best} {causal[best]:.4f} vs open loop {ol:.4f} m/s"})
        if "rts" in rr and "ekf" in rr:
            diag = rr["rts"] if "matched_rts_over_ekf" in rr["rts"] else None
            out.append(rts_target(ds, rr["rts"]["rmse_vy"], rr["ekf"]["rmse_vy"], diag))
        iv_ = rr.get("interval-coordinates", {})
        if "enclosure_vy" in iv_:
            box = rr["open-loop-linear"]
            out.append({"dataset": ds, "target": "interval enclosure of v_y (mismatch)",
                        "value": iv_["enclosure_vy"], "limit": 1.0,
                        "met": iv_["enclosure_vy"] >= 1.0,
                        "detail": f"mean width {iv_['width_vy']:.3f} m/s; plant needs "
                                  f"c_f/c_f0 in [{box['cf_ratio_min']:.2f}, "
                                  f"{box['cf_ratio_max']:.2f}], c_r/c_r0 in "
                                  f"[{box['cr_ratio_min']:.2f}, {box['cr_ratio_max']:.2f}] "
                                  "(box +-10 %)"})
    return out


#: log period of each car's data [s] (the design's epsilon = 1/dt): the Yacine car's 1 kHz
#: emulated logs, the Revs log and the plant at 100 Hz
CAR_DT = {"yacine2015": 0.001, "revs250lm": 0.01, "plant": 0.01}


def interval_certification_rows(seed: int = 0, duration: float = 30.0) -> list[dict]:
    """Every shipped car and the plant car: certified coordinate-change design (kappa,
    LMI margin, Metzler margin) and the enclosure rate on a matched-model run (the LPV
    bicycle, Euler at the car's log period, seeded random stiffness in the box, speeds
    sweeping the bands)."""
    from vehicle_observers.estimation import adapters
    from vehicle_observers.observers import interval as iv
    from vehicle_observers.observers import interval_coordinates as ic

    cars = {n_: load_vehicle(n_) for n_ in ("yacine2015", "revs250lm")}
    cars["plant"] = plant_vehicle()
    rows = []
    for name, v in cars.items():
        dt = CAR_DT[name]
        n = int(round(duration / dt))
        cd, _ = adapters.coordinate_interval_design(v, dt)
        veh = cd.design.model.veh
        e = cd.design.model.bands.edges
        t = np.arange(n) * dt
        vx = e[0] + (e[-1] - e[0]) * (0.5 - 0.5 * np.cos(2 * np.pi * t / t[-1]))
        u = 0.03 * np.sin(2 * np.pi * 0.4 * t)
        xi = iv.random_stiffness_trajectory(veh, n, dt, seed=seed, corr_time=0.5)
        X = iv.simulate_lpv(veh, [0.0, 0.0], u, vx, xi, dt)
        res = ic.run(cd, dt, vx, u, u, X[:, 1], [-1.0, -0.3], [1.0, 0.3])
        inside = np.all((res.x_lo <= X + 1e-9) & (X <= res.x_hi + 1e-9), axis=1)
        rows.append({"car": name, "certified": cd.certified, "kappa": cd.kappa,
                     "ifqir2017_alone": veh.max_metzler_uncertainty() >= veh.rel_unc,
                     "lmi_margin": cd.design.lmi_margin,
                     "metzler_margin": cd.design.min_metzler_margin,
                     "matched_enclosure": float(inside.mean()),
                     "matched_width_vy": float(res.width[t > 5, 0].mean())})
    return rows


def print_plant_section(seed: int = 0, quick: bool = False, revs_best=None, revs_rts=None,
                        revs_ekf=None, file=None, revs_diag=None) -> dict:
    """Print the independent-plant tables and every target (``make bench``). ``revs_diag``:
    :func:`rts_diagnosis` of the Revs log, shown beside its "RTS <= EKF" target. Returns
    ``{"rows", "targets", "interval"}`` for a notebook or the closing note."""
    file = file or sys.stdout
    rows = independent_plant_rows(seed, quick)
    targets = plant_targets(rows)
    if revs_best is not None:
        targets.insert(0, {"dataset": "revs", "target": f"best causal v_y RMSE <= {REVS_TARGET}",
                           "value": revs_best[1], "limit": REVS_TARGET,
                           "met": revs_best[1] <= REVS_TARGET, "detail": revs_best[0]})
    if revs_rts is not None and revs_ekf is not None:
        targets.insert(1, rts_target("revs", revs_rts, revs_ekf, revs_diag))
    ivr = interval_certification_rows()
    cols = ["dataset", "observer", "rmse_vy", "max_vy", "rmse_r", "enclosure_vy", "width_vy",
            "cf_ratio_min", "cf_ratio_max", "cr_ratio_min", "cr_ratio_max"]
    print("\n## Independent plant (CommonRoad multi-body, model mismatched)\n", file=file)
    print(markdown_table(rows, cols), file=file)
    print("\n## Interval observer for every car (z = T x, certified)\n", file=file)
    print(markdown_table([{k: (("yes" if v else "no") if isinstance(v, bool) else v)
                           for k, v in r.items()} for r in ivr], list(ivr[0])), file=file)
    print("\n## Targets\n", file=file)
    shown = [{**t, "met": "met" if t["met"] else
              ("MISSED (explained: model mismatch)" if t.get("explained") else "MISSED")}
             for t in targets]
    print(markdown_table(shown, ["dataset", "target", "value", "limit", "met", "detail"]),
          file=file)
    return {"rows": rows, "targets": targets, "interval": ivr}


def plant_metrics(rows: list[dict], cert_rows: list[dict]) -> dict:
    """Flat metrics of the independent-plant section for notebook 07 (identifier names, so
    that rules can use them): per manoeuvre ``plant_<m>_<observer>_rmse_vy`` [m/s] (and the
    interval observer's ``_enclosure_vy`` / ``_width_vy``), ``plant_<m>_best_over_open_loop``
    (best project observer / open-loop linear bicycle), ``plant_<m>_rts_over_ekf`` and the
    smoother diagnosis (:func:`diagnosis_metrics`) when the ``rts`` rows carry it; over the
    cars of :func:`interval_certification_rows`: ``interval_cars``, ``interval_certified_cars``,
    ``interval_min_matched_enclosure``."""
    out = {}
    for ds in dict.fromkeys(r["dataset"] for r in rows):
        rr = {r["observer"]: r for r in rows if r["dataset"] == ds}
        key = ds.replace("plant_", "")
        for o, r in rr.items():
            name = f"plant_{key}_{o.replace('-', '_')}"
            for k in ("rmse_vy", "enclosure_vy", "width_vy"):
                if k in r and np.isfinite(r[k]):
                    out[f"{name}_{k}"] = float(r[k])
        ol = rr["open-loop-linear"]["rmse_vy"]
        best = min(r["rmse_vy"] for o, r in rr.items() if o != "open-loop-linear" and "rmse_vy" in r)
        out[f"plant_{key}_best_over_open_loop"] = best / ol
        if "rts" in rr and "ekf" in rr:
            out[f"plant_{key}_rts_over_ekf"] = rr["rts"]["rmse_vy"] / rr["ekf"]["rmse_vy"]
        if "matched_rts_over_ekf" in rr.get("rts", {}):
            out.update(diagnosis_metrics(f"plant_{key}", rr["rts"]))
    out["interval_cars"] = len(cert_rows)
    out["interval_certified_cars"] = int(sum(bool(r["certified"]) for r in cert_rows))
    out["interval_min_matched_enclosure"] = float(min(r["matched_enclosure"] for r in cert_rows))
    return out


def fig_plant(rows: list[dict]):
    """Bar chart of v_y RMSE [m/s] per plant manoeuvre and estimator, with the target line
    0.8 x open loop drawn per manoeuvre (for notebook 07 / the closing note)."""
    import matplotlib.pyplot as plt

    ds = list(dict.fromkeys(r["dataset"] for r in rows))
    obs = list(dict.fromkeys(r["observer"] for r in rows))
    w = 0.8 / len(obs)
    fig, ax = plt.subplots(figsize=(8, 3.8))
    for j, o in enumerate(obs):
        pts = [(i + j * w, r["rmse_vy"]) for i, d in enumerate(ds) for r in rows
               if r["dataset"] == d and r["observer"] == o and "rmse_vy" in r]
        ax.bar([p[0] for p in pts], [p[1] for p in pts], w, label=o, color=_color(o, j))
    for i, d in enumerate(ds):
        ol = next(r["rmse_vy"] for r in rows if r["dataset"] == d
                  and r["observer"] == "open-loop-linear")
        ax.hlines(0.8 * ol, i - w / 2, i + 0.8 - w / 2, colors="k", linestyles=":", lw=1)
    ax.set_xticks(np.arange(len(ds)) + 0.4 - w / 2)
    ax.set_xticklabels([d.replace("plant_", "") for d in ds])
    ax.set_ylabel("$v_y$ RMSE [m/s]")
    ax.set_title("Independent multi-body plant (dotted: target 0.8 x open-loop linear)")
    ax.legend(fontsize=7, ncol=3, loc="upper left", bbox_to_anchor=(0, -0.12))
    fig.tight_layout()
    return fig
