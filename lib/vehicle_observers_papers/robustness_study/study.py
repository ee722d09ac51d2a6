"""Notebook 08: a live campaign run two ways, and the fuller campaign with its key metrics.

* :data:`LIVE` - a small campaign (64 simulations, a 2-point LMI map) run serially and on an
  embedded Dask cluster of two worker processes: :func:`determinism` compares the rows bit
  for bit.
* :func:`fuller` - the notebook's campaign: the EKF, the RTS smoother, the two interval
  observers and the two references (open-loop linear bicycle, linear Kalman filter) on the
  BMW 320i's multi-body plant and LPV model and on the Yacine 2015 car's LPV model, a sine
  with dwell at 15 m/s, the vehicle file's stiffness (+-10 %, +-30 %), mass (+15 %) and
  inertia (+20 %) wrong, two speed ranges of the interval observers' box, bounded (uniform)
  sensor noise at the plant's standard deviations with the speed measured exactly, with and
  without a 0.005 rad/s gyro bias, three repetitions; and the LMI feasibility map of the
  interval design for both cars, without and with the change of coordinates
  (``kappa = 0.1 rad/m``). Quick mode: one repetition, two stiffness errors, one speed range,
  a coarse map.
* :func:`key_metrics` - the numbers the notebook records and judges (all computed from the
  campaign's rows by :mod:`vehicle_observers.campaign.report`).
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np

LIVE = {
    "name": "live", "seed": 7, "repetitions": 2, "batch_size": 3,
    "estimators": ["ekf", "interval-ifqir2017"],
    "truth": {"plants": ["lpv:yacine2015", "lpv:bmw_320i"],
              "manoeuvres": [{"name": "slalom", "duration": 6.0, "vx": 12.0}]},
    "observer": {"stiffness_rel": [0.1], "speed_range": [[5.0, 20.0]]},
    "errors": {"stiffness": [0.15]},
    "sensors": {"distribution": "uniform", "std": {"vx": 0.0},
                "bias": [{}, {"yaw_rate": 0.01}]},
    "lmi_map": {"cars": ["yacine2015"], "stiffness_rel": [0.05, 0.3],
                "speed_range": [[5.0, 20.0]], "kappa": [0.0], "batch_size": 1},
}

#: speed ranges of the interval observers' box in the fuller campaign [m/s]
SPEED_RANGES = ([5.0, 20.0], [5.0, 40.0])
#: LMI map: speed ranges and box half-widths
MAP_RANGES = ([2.0, 20.0], [5.0, 20.0], [5.0, 40.0], [10.0, 40.0])


def fuller(seed: int = 0, quick: bool = False) -> dict:
    """The notebook's campaign (module docstring)."""
    return {
        "name": "robustness", "seed": int(seed), "repetitions": 1 if quick else 3,
        "estimators": ["ekf", "rts",
                       {"name": "interval-coordinates",
                        "plants": ["multibody:bmw_320i", "lpv:bmw_320i"]},
                       {"name": "interval-ifqir2017",
                        "plants": ["lpv:yacine2015", "lpv:bmw_320i"]}],
        "truth": {"plants": ["multibody:bmw_320i", "lpv:bmw_320i", "lpv:yacine2015"],
                  "manoeuvres": [{"name": "sine_with_dwell", "vx": 15.0}]},
        "observer": {"stiffness_rel": [0.1],
                     "speed_range": [list(SPEED_RANGES[1])] if quick else [list(r) for r in
                                                                           SPEED_RANGES]},
        "errors": {"stiffness": [-0.2, 0.2] if quick else [-0.3, -0.1, 0.1, 0.3],
                   **({} if quick else {"mass": [0.15], "inertia": [0.2]})},
        "sensors": {"distribution": "uniform", "std": {"vx": 0.0},
                    "bias": [{}, {"yaw_rate": 0.005}]},
        "lmi_map": {"cars": ["bmw_320i", "yacine2015"],
                    "stiffness_rel": {"start": 0.01, "stop": 0.4, "num": 8 if quick else 40},
                    "speed_range": [list(r) for r in (MAP_RANGES[1:3] if quick else MAP_RANGES)],
                    "kappa": [0.0, 0.1], "batch_size": 40},
    }


def determinism(spec=LIVE, workers: int = 2, work=None) -> dict:
    """Run ``spec`` serially and on an embedded cluster of ``workers`` processes into two
    fresh folders; ``identical`` is 1 when every row of both (simulations and LMI map) is
    the same bit for bit. Returns the counts and the serial folder."""
    from vehicle_observers.campaign import read_lmi, read_results, run

    work = Path(work or tempfile.mkdtemp(prefix="08_live-"))
    s = run(spec, work / "serial", engine="serial", progress=False)
    d = run(spec, work / "dask", engine="dask", workers=workers, progress=False)
    same = all(_bits(f(work / "serial"), f(work / "dask")) for f in (read_results, read_lmi))
    return {"identical": int(same), "tasks": s.tasks, "failed": s.failed, "workers": d.workers,
            "lmi_points": s.lmi_points, "folder": work / "serial"}


def _bits(a, b) -> bool:
    if a.column_names != b.column_names or a.num_rows != b.num_rows:
        return False
    for n in a.column_names:
        x, y = a[n].to_numpy(zero_copy_only=False), b[n].to_numpy(zero_copy_only=False)
        ok = np.array_equal(x.view(np.uint64), y.view(np.uint64)) if x.dtype.kind == "f" \
            else list(x) == list(y)
        if not ok:
            return False
    return True


def run_fuller(seed: int = 0, quick: bool = False, workers: int | None = None, work=None):
    """Run :func:`fuller` (serial in quick mode, else an embedded cluster of ``workers``
    processes, default 2) into a fresh folder. Returns (summary, folder)."""
    from vehicle_observers.campaign import run

    work = Path(work or tempfile.mkdtemp(prefix="08_robustness-"))
    eng = "serial" if quick else "dask"
    s = run(fuller(seed, quick), work / "campaign", engine=eng,
            workers=None if quick else (workers or 2), progress=False)
    return s, work / "campaign"


def plant_errors(folder, plant: str) -> list[dict]:
    """:func:`vehicle_observers.campaign.report.error_table` on one plant's rows."""
    import polars as pl
    from vehicle_observers.campaign import report, store

    df = pl.from_arrow(store.read_results(folder)).filter(pl.col("plant") + ":" + pl.col("car")
                                                          == plant)
    return report.error_table(df, store.spec_of_folder(folder).doc["errors"]["design"])


def _best(rows: list[dict], parameter: str, error: float, refs=("open-loop-linear",
                                                                "linear-kf")) -> dict:
    r = [x for x in rows if x["parameter"] == parameter and x["error"] == error
         and x["estimator"] not in refs and np.isfinite(x["median_rmse_vy"])]
    return min(r, key=lambda x: x["median_rmse_vy"]) if r else {}


#: description and unit of the key metrics a reader sees in notebook 08's tables
NOTES = {
    "guaranteed_runs": ("-", "runs of both interval observers meeting Ifqir 2017's assumptions"),
    "guaranteed_enclosure_min": ("-", "min v_y enclosure rate over those runs (both observers)"),
    "guaranteed_runs_ifqir2017": ("-", "runs of interval-ifqir2017 meeting the assumptions"),
    "guaranteed_enclosure_min_ifqir2017": ("-", "min v_y enclosure rate over those runs "
                                                "(interval-ifqir2017)"),
    "multibody_enclosure_min": ("-", "min v_y enclosure rate, interval-coordinates on the "
                                     "multi-body BMW (outside the assumptions)"),
    "lmi_yacine_k0_max_feasible_rel": ("-", "largest feasible box half-width, Yacine car, "
                                            "kappa = 0, 5-20 m/s"),
    "lmi_yacine2015_metzler_bound": ("-", "analytic Metzler bound rho_M of the Yacine car"),
    "lmi_bmw_320i_metzler_bound": ("-", "analytic Metzler bound rho_M of the BMW 320i"),
    "lmi_rel_step": ("-", "grid step of the box half-width in the LMI map"),
    "multibody_nominal_best_ratio_open_loop": ("-", "multi-body BMW, exact file: best estimator's "
                                                    "median v_y RMSE / open loop's"),
    "lpv_nominal_best_ratio_open_loop": ("-", "LPV BMW, exact file: best estimator's median v_y "
                                              "RMSE / open loop's"),
}


def key_metrics(t: dict, folder) -> dict:
    """Flat metrics of the report tables ``t`` (:func:`vehicle_observers.campaign.report.tables`)
    of the fuller campaign in ``folder``."""
    out: dict = {"tasks": t["spec"].n_tasks, "rows": t["rows"],
                 "failed": sum(r["failed"] for r in t["failures"])}
    for r in t["failures"]:
        out[f"failure_rate.{r['estimator']}"] = r["failure_rate"]
    out["error_table"] = {f"{r['estimator']} {r['parameter']} {r['error']:+g}":
                          {k: r[k] for k in ("median_rmse_vy", "p90_rmse_vy", "ratio_open_loop",
                                             "ratio_linear_kf")} for r in t["errors"]}
    g = [r for r in t["conservatism"] if r["guaranteed"]]
    out["guaranteed_runs"] = int(sum(r["guaranteed"] for r in g))
    out["guaranteed_enclosure_min"] = min((r["guaranteed_enclosure_min"] for r in g),
                                          default=math.nan)
    # the paper's observer as printed (Ifqir 2017, no change of coordinates) on its own
    gi = [r for r in g if r["estimator"] == "interval-ifqir2017"]
    out["guaranteed_runs_ifqir2017"] = int(sum(r["guaranteed"] for r in gi))
    out["guaranteed_enclosure_min_ifqir2017"] = min((r["guaranteed_enclosure_min"] for r in gi),
                                                    default=math.nan)
    cons = {f"{r['estimator']} {r['plant']}:{r['car']} {r['box_vx_min']:g}-{r['box_vx_max']:g} "
            f"{r['err_cf']:+.2f}": {"enclosure_mean": r["enclosure_mean"],
                                    "enclosure_min": r["enclosure_min"],
                                    "width_mean": r["width_mean"], "in_box": r["in_box_share"]}
            for r in t["conservatism"]}
    out["conservatism"] = cons
    mb = [r for r in t["conservatism"] if r["plant"] == "multibody"]
    out["multibody_enclosure_min"] = min((r["enclosure_min"] for r in mb), default=math.nan)
    out["multibody_nominal_enclosure_min"] = min(
        (r["enclosure_min"] for r in mb if r["err_cf"] == 0.0), default=math.nan)
    out["width_ratio_wide_to_narrow_box"] = _width_ratio(t["conservatism"])
    out.update(_lmi_metrics(t["lmi_summary"], t["lmi_points"]))
    for plant in ("multibody:bmw_320i", "lpv:bmw_320i"):
        rows = plant_errors(folder, plant)
        tag = plant.split(":")[0]
        b = _best(rows, "nominal", 0.0)
        out[f"{tag}_nominal_best_ratio_open_loop"] = b.get("ratio_open_loop", math.nan)
        out[f"{tag}_nominal_best_ratio_linear_kf"] = b.get("ratio_linear_kf", math.nan)
        out[f"{tag}_best"] = {f"{r['parameter']} {r['error']:+g}": _best(rows, r["parameter"],
                                                                            r["error"]).get(
            "estimator", "") for r in rows}
    return out


def _width_ratio(cons: list[dict]) -> float:
    """Mean width with the wide speed box over that with the narrow one (interval observers,
    same truth, error and observer; NaN when only one box was run)."""
    by = {}
    for r in cons:
        by.setdefault((r["estimator"], r["plant"], r["car"], r["err_cf"]), {})[
            (r["box_vx_min"], r["box_vx_max"])] = r["width_mean"]
    ratios = [v[tuple(SPEED_RANGES[1])] / v[tuple(SPEED_RANGES[0])] for v in by.values()
              if tuple(SPEED_RANGES[0]) in v and tuple(SPEED_RANGES[1]) in v
              and np.isfinite(v[tuple(SPEED_RANGES[0])])]
    return float(np.median(ratios)) if ratios else math.nan


def _lmi_metrics(summary: list[dict], points: list[dict]) -> dict:
    out = {}
    for s in summary:
        tag = f"lmi.{s['car']}.k{s['kappa']:g}.{s['vx_min']:g}-{s['vx_max']:g}"
        out[f"{tag}.feasible"] = s["feasible"]
        out[f"{tag}.max_feasible_rel"] = s["max_feasible_rel"]
    for car in dict.fromkeys(p["car"] for p in points):
        for k in (0.0, 0.1):
            pts = [p for p in points if p["car"] == car and p["kappa"] == k]
            out[f"lmi_{car}_k{k:g}_feasible"] = sum(p["status"] == "feasible" for p in pts)
            out[f"lmi_{car}_k{k:g}_points"] = len(pts)
        out[f"lmi_{car}_metzler_bound"] = next(p["metzler_bound"] for p in points if p["car"] == car)
    out["lmi_inconclusive"] = sum(p["status"] == "inconclusive" for p in points)
    y = [p for p in points if p["car"] == "yacine2015" and p["kappa"] == 0.0
         and (p["vx_min"], p["vx_max"]) == (5.0, 20.0)]
    rels = sorted({p["stiffness_rel"] for p in y})
    feas = [p["stiffness_rel"] for p in y if p["status"] == "feasible"]
    out["lmi_yacine_k0_max_feasible_rel"] = max(feas) if feas else math.nan
    out["lmi_rel_step"] = float(rels[1] - rels[0]) if len(rels) > 1 else math.nan
    return out


def cli_exercise(spec: dict, work=None) -> dict:
    """The command line on ``spec`` twice into one folder (serial engine), then a
    spec with another seed into the same folder. Returns the simulations each run computed
    (parsed from its summary line) and the exit status of the third."""
    import os
    import subprocess
    import sys

    from vehicle_observers.campaign.spec import dump_toml

    work = Path(work or tempfile.mkdtemp(prefix="08_cli-"))
    (work / "live.toml").write_text(dump_toml(spec))
    (work / "other.toml").write_text(dump_toml({**spec, "seed": spec.get("seed", 0) + 1}))

    def cli(f):
        return subprocess.run([sys.executable, "-m", "vehicle_observers", "campaign", str(work / f),
                               "--out", str(work / "out"), "--engine", "serial", "--no-progress"],
                              capture_output=True, text=True, env=dict(os.environ))

    first, second, other = cli("live.toml"), cli("live.toml"), cli("other.toml")
    now = lambda p: int(p.stdout.split(" simulation(s) run now")[0].split()[-1])
    return {"first": now(first), "second": now(second), "other_spec_exit": other.returncode,
            "other_spec_error": other.stderr.strip()}
