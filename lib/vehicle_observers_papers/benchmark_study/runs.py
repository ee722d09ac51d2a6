"""The benchmark runs: datasets, every registered observer on each, scores and ratios.

:func:`run` runs every registry entry (:func:`vehicle_observers.estimation.available`) that
applies to each dataset of :func:`datasets` and scores it; :func:`key_metrics` and
:func:`timing_metrics` flatten the rows for notebook 07 (accuracy, committed) and ``make
bench`` (wall clock, never committed); :func:`revs_losses` and :func:`amplitude_ratio` say
where the estimators lose on the real log. The protocol: :mod:`vehicle_observers_papers.benchmark_study`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from vehicle_observers import estimation as EST
from vehicle_observers.core.metrics import rmse
from vehicle_observers.data.logs import DriveLog, load_revs
from vehicle_observers.estimation import kalman_runs as KR
from vehicle_observers.models.vehicle import load_vehicle

#: columns of ``benchmark.csv``
COLUMNS = ["dataset", "observer", "causal", "samples", "rmse_vy", "max_vy", "rmse_beta",
           "max_beta", "rmse_r", "max_r", "rmse_Ff", "max_Ff", "rmse_Fr", "max_Fr",
           "enclosure_vy", "width_vy", "enclosure_r", "width_r", "us_per_step",
           "realtime_factor", "design_s", "ratio_vy_vs_ekf", "ratio_vy_vs_rts",
           "speedup_vs_filterpy_ekf"]
#: pure-Python estimators, run on a window of ``filterpy_steps`` samples only
SLOW = ("ekf-filterpy", "ukf-filterpy")
#: estimators that use the Kalman noise tuning
KALMAN = ("ekf", "ekf-filterpy", "ukf", "rts")

#: references on the Revs log, registry name -> label: the two estimators published with the log
#: (MBDS/sideslip-angle-vehicle-estimation, Leanza et al. 2021, re-implemented in
#: :mod:`vehicle_observers.baselines.peers`) and the two baselines; scored by
#: :func:`revs_references` (PROVENANCE.md prints 0.28 m/s for the open-loop linear bicycle)
REVS_REFERENCE_ESTIMATORS = {"vy-zero": "vy = 0",
                             "mbds-kf": "their KF (linear bicycle, r + a_y)",
                             "open-loop-linear": "open-loop linear bicycle",
                             "mbds-fg": "their offline factor graph (batch)"}


def revs_references() -> list[dict]:
    """The rows of :data:`REVS_REFERENCE_ESTIMATORS` on the whole Revs log, scored by the
    leaderboard (:func:`vehicle_observers_papers.leanza_2021.leaderboard.score_row`): ``{"estimator"
    (label), "observer" (registry name), "causal", "rmse_vy" [m/s], "rmse_beta_deg"}``."""
    from vehicle_observers_papers.leanza_2021 import leaderboard as LB

    table, errors = LB.rows(LB.datasets(manoeuvres=()), observers=tuple(REVS_REFERENCE_ESTIMATORS))
    if errors:
        raise RuntimeError("Revs references: " + "; ".join(errors))
    by = {r["observer"]: r for r in table}
    return [{"estimator": label, "observer": o, "causal": by[o]["causal"],
             "rmse_vy": by[o]["rmse_vy"], "rmse_beta_deg": by[o]["rmse_beta_deg"]}
            for o, label in REVS_REFERENCE_ESTIMATORS.items()]


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
    from vehicle_observers.models.vehicle import KalmanTuning

    log = sine_with_dwell(seed=0, t_after=0.5)
    veh = vehicles["yacine2015"]
    for name, spec in observers.items():
        if name in SLOW:
            continue
        try:
            spec.check(log, veh)
            spec.run(log.segment(0.0, 0.3), veh, tuning=KalmanTuning())
        except Exception:  # noqa: BLE001 - warm-up only; the real run reports errors
            pass


#: the estimators of notebook 07's committed study (the paper observers against the Kalman
#: baselines); every other registered estimator, plug-ins included, is timed by
#: :mod:`vehicle_observers.bench.estimators` and scored by the Revs/plant leaderboard of
#: :mod:`vehicle_observers_papers.leanza_2021.leaderboard`; ``run(observers=...)`` takes any.
STUDY_ESTIMATORS = ("ekf", "ekf-filterpy", "ukf", "rts", "ts-yacine2015", "interval-ifqir2017",
                    "interval-coordinates")


def run(seed: int = 0, quick: bool = False, filterpy_steps: int | None = None,
        observers=None, progress=None, tune_maxiter: int = 300) -> dict:
    """Run the benchmark (``tune_maxiter``: Nelder-Mead iterations per start of the ML
    tuning; do not lower it: a stopped-early search can leave large ``q_vy, q_b`` with which
    the EKF drifts onto the saturated-tyre branch, e.g. 13.5 m/s RMSE on the quick n3 run
    with 120 iterations against 0.0015 with 300). Returns ``{"rows": [...], "estimates":
    {(dataset, obs): Trajectory}, "logs": {...}, "masks": {...}, "tunings": {...},
    "errors": [...], "quick", "seed"}``."""
    filterpy_steps = filterpy_steps or (3000 if quick else 60000)
    obs = EST.available()
    wanted = STUDY_ESTIMATORS if observers is None else tuple(observers)
    obs = {k: v for k, v in obs.items() if k in wanted}
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
                est = replace(est, design_seconds=tsec)      # the ML tuning is their design
            ests[(dname, oname)] = est
            m = EST.score(est, lg, mk)
            row = {"dataset": dname, "observer": oname, "causal": est.causal,
                   "samples": len(lg), **m, "us_per_step": est.us_per_step,
                   "realtime_factor": lg.duration / max(est.seconds, 1e-12),
                   "design_s": est.design_seconds}
            rows.append(row)
    ratios(rows)
    return {"rows": rows, "estimates": ests, "logs": {k: v[0] for k, v in data.items()},
            "masks": {k: v[2] for k, v in data.items()}, "tunings": tunings, "errors": errors,
            "quick": bool(quick), "seed": int(seed)}


def ratios(rows: list[dict]) -> None:
    """Add, in place, ``ratio_vy_vs_ekf`` / ``ratio_vy_vs_rts`` (v_y RMSE over that of the
    EKF / RTS smoother on the same dataset; NaN when the windows differ, the filterpy rows)
    and ``speedup_vs_filterpy_ekf`` (filterpy EKF us per step / the row's)."""
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
