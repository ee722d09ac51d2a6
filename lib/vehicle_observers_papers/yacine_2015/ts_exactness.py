"""Studies of notebook 01: exactness of the TS forms and fit of the models to a real log.

- :func:`yacine_exactness`: the 8-rule TS model (24) of Yacine 2015 against the nonlinear
  transformed model (13) along a trajectory inside the sector (right-hand sides and
  simulated trajectories), and what happens outside it.
- :func:`revs_fig1`: Yacine 2015 Fig. 1 analogue on the Revs 250 LM log.
- :func:`bicycle_exactness`: Ichalal 2011 Fig. 2 analogue (nonlinear bicycle vs its TS form).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from vehicle_observers.core.errors import PremiseOutOfBounds
from vehicle_observers.core.metrics import correlation, fit_percent, rmse
from vehicle_observers.core.signals import chirp, speed_ramp, time_grid
from vehicle_observers.data.identification import identify_friction
from vehicle_observers.data.logs import DriveLog, despike
from vehicle_observers.models import bicycle, lateral
from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.ts import SectorTS
from vehicle_observers.results.tables import show_table


@dataclass
class Run:
    """A simulated run: time (N,), inputs (N,), states (N, n) by name."""

    t: np.ndarray
    inputs: dict
    states: dict


def excitation(duration: float, dt: float, steer_amp: float, vx_range=(3.0, 17.0)):
    """Steering chirp 0.05 -> 1.5 Hz with a speed ramp (deterministic)."""
    t = time_grid(duration, dt)
    return t, chirp(t, 0.05, 1.5, steer_amp), speed_ramp(t, *vx_range)


def yacine_exactness(p: LateralParams, ts: SectorTS, duration: float = 30.0, dt: float = 1e-3,
                     steer_amp: float = 0.16, vx_range=(3.0, 17.0)) -> dict:
    """Compare TS (24) and nonlinear (13) along the nonlinear model's trajectory.

    Returns max relative RHS difference, the convex-sum residual, the largest relative
    difference between the two *simulated* trajectories (TS form integrated by itself),
    the premise ranges, and the run.
    """
    t, delta, vx = excitation(duration, dt, steer_amp, vx_range)
    X = lateral.simulate_s1([0, 0, 0, 0], delta, vx, dt, p, exact=False, relaxation=True,
                            substeps=1)
    x = lateral.to_transformed(X, p)
    f_nl = lambda x_, u_, vx_: lateral.rhs_transformed(x_, np.ravel(u_), vx_, p)
    res = ts.exactness(x, delta, f_nl, vx)
    x_ts, oob = lateral.simulate_ts(ts, x[0], delta, vx, dt, p, substeps=1)
    scale = np.abs(x).max(axis=0)
    res["max_rel_traj_diff"] = float((np.abs(x_ts - x) / scale).max())
    res["n_out_of_bounds"] = int(oob.sum())
    af, ar = lateral.slip_angles(x[:, 0], x[:, 1], delta, vx, p, exact=False)
    res["max_abs_slip_deg"] = float(np.degrees(max(np.abs(af).max(), np.abs(ar).max())))
    res["run"] = Run(t, {"delta": delta, "vx": vx}, {"x_nl": x, "x_ts": x_ts})
    return res


def outside_sector(p: LateralParams, ts: SectorTS, duration: float = 30.0, dt: float = 1e-3,
                   steer_amp: float = 0.25, vx_range=(3.0, 17.0)) -> dict:
    """Drive past the sector (slip beyond its bound): the builder refuses with a message;
    with saturated memberships the TS form is no longer exact -- by how much."""
    t, delta, vx = excitation(duration, dt, steer_amp, vx_range)
    X = lateral.simulate_s1([0, 0, 0, 0], delta, vx, dt, p, exact=False, relaxation=True,
                            substeps=1)
    x = lateral.to_transformed(X, p)
    f_nl = lateral.rhs_transformed(x, delta, vx, p)
    z = ts.premise_fn(x, delta[:, None], vx)
    try:
        ts.check_bounds(z)
        message = None
    except PremiseOutOfBounds as exc:
        message = str(exc)
    out = (z < ts.zmin) | (z > ts.zmax)
    f_clip = ts.rhs(x, delta[:, None], vx, clip=True)
    scale = np.abs(f_nl).max(axis=0)
    af, ar = lateral.slip_angles(x[:, 0], x[:, 1], delta, vx, p, exact=False)
    return {"message": message, "share_out": float(out.any(axis=1).mean()),
            "max_rel_diff_clipped": float((np.abs(f_clip - f_nl) / scale).max()),
            "max_abs_slip_deg": float(np.degrees(max(np.abs(af).max(), np.abs(ar).max())))}


def sector_from_trajectory(p: LateralParams, alpha_max: float, vx, margin: float = 0.02):
    """TS bounds covering a trajectory: secant stiffness over ``|alpha| <= alpha_max`` and
    ``v_x`` range, each widened by ``margin`` (relative)."""
    ff = p.tire_f.sector_bounds(alpha_max)
    fr = p.tire_r.sector_bounds(alpha_max)
    widen = lambda lo, hi: (lo - margin * (hi - lo), hi + margin * (hi - lo))
    return widen(*ff), widen(*fr), widen(float(np.min(vx)), float(np.max(vx)))


def revs_fig1(base: LateralParams, linear: LateralParams, log: DriveLog,
              spike_threshold: float = 0.05) -> dict:
    """Yacine 2015 Fig. 1 analogue on a real log.

    1. Steering despiked (isolated one-sample spikes > ``spike_threshold`` rad).
    2. Friction ``mu`` identified from the measured yaw rate only (identification.py).
    3. Simulated open loop from the measured steering and speed: nonlinear model without
       relaxation (1)-(3) (exact slip), TS model (24) with relaxation (its sector taken
       from the trajectory), and the linear bicycle for reference.
    Fit metrics against the measured yaw rate and the INS lateral velocity.
    """
    delta, spikes = despike(log.delta, spike_threshold)
    mu, p, _ = identify_friction(base, log, delta)
    X_nl = lateral.simulate_s1([0.0, log.yaw_rate[0]], delta, log.vx, log.dt, p, exact=True,
                               relaxation=False)
    X_rel = lateral.simulate_s1([0.0, log.yaw_rate[0], 0.0, 0.0], delta, log.vx, log.dt, p,
                                exact=False, relaxation=True)
    af, ar = lateral.slip_angles(X_rel[:, 0], X_rel[:, 1], delta, log.vx, p, exact=False)
    alpha_max = float(max(np.abs(af).max(), np.abs(ar).max()))
    Mf, Mr, vxb = sector_from_trajectory(p, alpha_max, log.vx)
    ts = lateral.yacine_ts(p, Mf=Mf, Mr=Mr, vx_bounds=vxb)
    x0 = lateral.to_transformed(X_rel[:1], p)[0]
    x_ts, oob = lateral.simulate_ts(ts, x0, delta, log.vx, log.dt, p)
    X_lin = lateral.simulate_s1([0.0, log.yaw_rate[0]], delta, log.vx, log.dt, linear,
                                exact=False, relaxation=False)
    models = {"nonlinear, no relaxation": X_nl[:, :2], "TS, relaxation": x_ts[:, :2],
              "linear bicycle": X_lin[:, :2]}
    fits = {}
    for name, X in models.items():
        fits[name] = {
            "yaw_rmse": rmse(X[:, 1], log.yaw_rate), "yaw_corr": correlation(X[:, 1], log.yaw_rate),
            "yaw_fit": fit_percent(X[:, 1], log.yaw_rate),
            "vy_rmse": rmse(X[:, 0], log.vy) if log.vy is not None else np.nan,
            "vy_corr": correlation(X[:, 0], log.vy) if log.vy is not None else np.nan,
        }
    x_rel_t = lateral.to_transformed(X_rel, p)
    return {"mu": mu, "params": p, "spikes": spikes, "alpha_max_deg": np.degrees(alpha_max),
            "ts": ts, "n_out_of_bounds": int(oob.sum()), "fits": fits, "models": models,
            "ts_vs_nl_rel": float((np.abs(x_ts - x_rel_t) / np.abs(x_rel_t).max(axis=0)).max()),
            "delta": delta}


#: metric-name key of each model of :func:`revs_fig1`
FIT_KEYS = {"nonlinear, no relaxation": "nl", "TS, relaxation": "ts", "linear bicycle": "lin"}
_FIT_UNITS = {"yaw_rmse": "rad/s", "vy_rmse": "m/s"}


def revs_fit_metrics(fits: dict) -> dict:
    """Flatten the ``fits`` of :func:`revs_fig1` into ``{"revs_<model>_<fit>": (value, unit)}``
    (model keys :data:`FIT_KEYS`; RMSE in rad/s or m/s, correlations and fit % unitless)."""
    return {f"revs_{key}_{k}": (v, _FIT_UNITS.get(k, ""))
            for name, key in FIT_KEYS.items() for k, v in fits[name].items()}


def fit_rows(fits: dict):
    """One row per model of :func:`revs_fig1` (yaw-rate RMSE [rad/s], correlation and fit [%],
    v_y RMSE [m/s] and correlation), as a rounded table for the notebook."""
    return show_table([{"model": name, **f} for name, f in fits.items()],
                      ["model", "yaw_rmse", "yaw_corr", "yaw_fit", "vy_rmse", "vy_corr"])


def bicycle_exactness(bp: bicycle.BicycleParams, duration: float = 10.0, dt: float = 1e-3,
                      margin: float = 0.01) -> dict:
    """Ichalal 2011 Fig. 2 analogue: closed-loop nonlinear bicycle vs its 8-rule TS form.

    Premise bounds are the trajectory's ranges widened by ``margin`` (relative).
    """
    t = time_grid(duration, dt)
    X, u = bicycle.simulate(bp, t)
    z = bicycle.ts_premises(X, u, bp)
    lo, hi = z.min(axis=0), z.max(axis=0)
    span = np.maximum(hi - lo, 1e-6 * np.maximum(np.abs(hi), 1.0))
    bounds = list(zip(lo - margin * span, hi + margin * span))
    ts = bicycle.bicycle_ts(bp, bounds)
    X_ts, u_ts = bicycle.simulate(bp, t, ts=ts)
    res = ts.exactness(X, u, lambda x_, u_: bicycle.rhs(x_, np.ravel(u_), bp))
    res["max_rel_traj_diff"] = float((np.abs(X_ts - X) / np.abs(X).max(axis=0)).max())
    res["bounds"] = bounds
    res["run"] = Run(t, {"u": u, "u_ts": u_ts}, {"x_nl": X, "x_ts": X_ts})
    res["ts"] = ts
    return res
