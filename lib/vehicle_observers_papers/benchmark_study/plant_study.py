"""The independent-plant study: the observers on a plant that is not their model.

Rows on the CommonRoad multi-body plant (:mod:`vehicle_observers.data.plant`): the model is
*not* the observers' (camber, roll, load transfer, compliance, combined-slip PAC2002 tyres).
The vehicle file is the library's data sheet (:func:`plant.nominal_params`), with a +-10 %
stiffness box over 5..40 m/s. Targets (:func:`plant_targets`, :func:`plant_section`): best
project observer v_y RMSE <= 0.8 x the open-loop linear bicycle with the same vehicle file;
RTS <= EKF, with the smoother diagnosis (:func:`rts_diagnosis`) saying whether a miss is the
model's; the interval observer certified for every car, 100 % enclosure on matched-model runs,
width and enclosure under mismatch; Revs best causal v_y RMSE <= :data:`REVS_TARGET`.
"""

from __future__ import annotations

import numpy as np
from vehicle_observers import estimation as EST
from vehicle_observers.baselines.peers import open_loop_linear  # also this module's name for it
from vehicle_observers.core.metrics import rmse
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.estimation import kalman_runs as KR
from vehicle_observers.models.vehicle import load_vehicle

# the plant car's vehicle file, shared with the leaderboard (also this module's name for it)
from vehicle_observers_papers.leanza_2021.leaderboard import plant_vehicle

#: estimators run on the plant (besides the open-loop linear bicycle)
PLANT_OBSERVERS = ("ekf", "ukf", "rts", "interval-coordinates")
#: manoeuvres of the plant (:func:`vehicle_observers.data.plant.plant_log`)
PLANT_MANOEUVRES = ("satory", "sine_with_dwell", "slalom")
#: v_y RMSE target [m/s] of the best causal estimator on the Revs log
REVS_TARGET = 0.20


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
    from vehicle_observers.models import uncertain_bicycle as ub
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
        xi = ub.random_stiffness_trajectory(veh, n, dt, seed=seed, corr_time=0.5)
        X = ub.simulate_lpv(veh, [0.0, 0.0], u, vx, xi, dt)
        res = ic.run(cd, dt, vx, u, u, X[:, 1], [-1.0, -0.3], [1.0, 0.3])
        inside = np.all((res.x_lo <= X + 1e-9) & (X <= res.x_hi + 1e-9), axis=1)
        rows.append({"car": name, "certified": cd.certified, "kappa": cd.kappa,
                     "ifqir2017_alone": veh.max_metzler_uncertainty() >= veh.rel_unc,
                     "lmi_margin": cd.design.lmi_margin,
                     "metzler_margin": cd.design.min_metzler_margin,
                     "matched_enclosure": float(inside.mean()),
                     "matched_width_vy": float(res.width[t > 5, 0].mean())})
    return rows


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


def plant_section(seed: int = 0, quick: bool = False, revs_best=None, revs_rts=None,
                  revs_ekf=None, revs_diag=None) -> dict:
    """The independent-plant rows, every target and the interval certification rows
    (``make bench``). ``revs_best``: ``(name, v_y RMSE)`` of the best causal estimator on the
    Revs log; ``revs_rts`` / ``revs_ekf``: their v_y RMSE [m/s]; ``revs_diag``:
    :func:`rts_diagnosis` of the Revs log, shown beside its "RTS <= EKF" target. Returns
    ``{"rows", "targets", "interval"}``."""
    rows = independent_plant_rows(seed, quick)
    targets = plant_targets(rows)
    if revs_best is not None:
        targets.insert(0, {"dataset": "revs", "target": f"best causal v_y RMSE <= {REVS_TARGET}",
                           "value": revs_best[1], "limit": REVS_TARGET,
                           "met": revs_best[1] <= REVS_TARGET, "detail": revs_best[0]})
    if revs_rts is not None and revs_ekf is not None:
        targets.insert(1, rts_target("revs", revs_rts, revs_ekf, revs_diag))
    return {"rows": rows, "targets": targets, "interval": interval_certification_rows()}
