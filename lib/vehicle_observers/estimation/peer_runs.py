"""Registrations of the peers, the baselines and the adaptive / fused estimators.

* ``mbds-kf`` - the linear single-track KF published with the Revs log
  (:func:`vehicle_observers.baselines.peers.mbds_kf`), on the vehicle file's zero-slip
  stiffnesses (on ``revs250lm`` exactly their constants), their noise rule; its ``v_y`` std
  calibrated (:func:`vehicle_observers.estimation.calibration.calibrate`);
* ``mbds-fg`` (offline batch) and ``mbds-fg-lag5`` (fixed lag of 5 samples: 4-sample
  look-ahead, not causal) - their factor graph;
* ``linear-kf-ml`` - a plain linear Kalman filter on the vehicle file (linear tyres of the
  zero-slip slopes, no added term, stiffness box considered, ML noise on measured channels);
* ``open-loop-linear`` (registered by :mod:`vehicle_observers.estimation.references`) - the linear
  single-track model driven by steering and speed;
  ``vy-zero`` - ``v_y = 0``;
* ``adaptive-ekf`` - :mod:`vehicle_observers.baselines.adaptive` with the terms and tuning
  chosen by :func:`vehicle_observers.estimation.selection.select`, a ``vy_std_mps`` column
  (the filter's std with the stiffness box as consider states, inflated by the innovation
  consistency of :func:`~vehicle_observers.estimation.selection.vy_std`, then calibrated by
  :func:`vehicle_observers.estimation.calibration.calibrate`) and the identifiability verdict
  in ``info["verdict"]`` (one line in ``info["verdict_line"]``);
* ``fusion-interval`` - the same filter truncated to the ``interval-coordinates`` bounds
  (:mod:`vehicle_observers.baselines.fusion`).

Every selection is cached per log (measured channels and vehicle constants hashed) within
the process, so ``adaptive-ekf`` and ``fusion-interval`` on the same log select once.
"""

from __future__ import annotations

import hashlib
import importlib
import time
from dataclasses import replace

import numpy as np

from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.estimation import calibration, segments
from vehicle_observers.estimation.registry import estimator
from vehicle_observers.models.road import BANK_COLUMNS, lateral_gravity
from vehicle_observers.models.tires import LinearTire


class _OnUse:
    """A module imported on first use: listing the estimators (every command's start-up)
    does not pay for the filters' numba modules and the selection's imports."""

    def __init__(self, name: str):
        self._name, self._mod = name, None

    def __getattr__(self, attr):
        if self._mod is None:
            self._mod = importlib.import_module(self._name)
        return getattr(self._mod, attr)


AD = _OnUse("vehicle_observers.baselines.adaptive")
FU = _OnUse("vehicle_observers.baselines.fusion")
PE = _OnUse("vehicle_observers.baselines.peers")
SE = _OnUse("vehicle_observers.estimation.selection")

_SELECTIONS: dict[str, SE.Selection] = {}


def _key(log: DriveLog, vehicle, tag: str) -> str:
    h = hashlib.sha256(tag.encode())
    for a in (log.t - log.t[0], log.vx, log.delta, log.yaw_rate, log.ay, lateral_gravity(log)):
        h.update(b"-" if a is None else np.ascontiguousarray(a, float).tobytes())
    h.update(repr((vehicle.params.as_array().tolist(), sorted(vehicle.uncertainty.items())))
             .encode())
    return h.hexdigest()


def linear_vehicle(vehicle):
    """The vehicle file with linear tyres of its zero-slip slopes."""
    p = vehicle.params
    return replace(vehicle, params=replace(p, tire_f=LinearTire(p.tire_f.cornering_stiffness),
                                           tire_r=LinearTire(p.tire_r.cornering_stiffness)))


def selection_for(log: DriveLog, vehicle, linear: bool = False, candidates=None,
                  maxiter: int = 250, cache: bool = False) -> tuple[SE.Selection, float]:
    """The (cached) :func:`selection.select` of ``log``; ``linear``: no term, linear tyres
    (the ``linear-kf-ml`` tuning). ``cache=True`` (the command line) also keeps it on disk
    as JSON in :func:`vehicle_observers.estimation.kalman_runs.cache_dir`, keyed by the
    measured channels, the vehicle constants and box, the options and the source of the
    whole package (:func:`vehicle_observers.core.source.package_sha256`: an edited rule or
    filter never reuses an old entry). Returns (selection,
    seconds spent now)."""
    cands = () if linear else tuple(AD.TERM_NAMES if candidates is None else candidates)
    key = _key(log, vehicle, f"{linear}{cands}{maxiter}")
    if key in _SELECTIONS:
        return _SELECTIONS[key], 0.0
    t0 = time.perf_counter()
    sel = _disk_selection(key) if cache else None
    if sel is None:
        veh = linear_vehicle(vehicle) if linear else vehicle
        sel = SE.select(log, veh, candidates=cands, maxiter=maxiter)
        if cache:
            _store_selection(key, sel)
    _SELECTIONS[key] = sel
    return sel, time.perf_counter() - t0


def _selection_file(key: str):
    from vehicle_observers.core.source import package_sha256
    from vehicle_observers.estimation.kalman_runs import cache_dir

    h = hashlib.sha256(key.encode())
    h.update(package_sha256().encode())     # the whole library: the selection reaches far
    return cache_dir() / f"selection-{h.hexdigest()}.json"


def _disk_selection(key: str):
    """The selection stored by :func:`_store_selection`, or ``None`` (missing, unreadable or
    of another format)."""
    import json
    from dataclasses import fields

    try:
        d = json.loads(_selection_file(key).read_text())
        terms = AD.Terms(**d["terms"])
        names = {f.name for f in fields(AD.AdaptiveTuning)}
        tun = AD.AdaptiveTuning(**{k: v for k, v in d["tuning"].items() if k in names})
        return SE.Selection(terms, tun, d["rows"], float(d["nis_ratio"]), bool(d["use_ay"]),
                            int(d["samples"]), float(d["iact"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _store_selection(key: str, sel) -> None:
    """Write ``sel`` as JSON (atomic rename; an unwritable cache folder is skipped)."""
    import json
    import os
    from dataclasses import asdict

    f = _selection_file(key)
    rows = [{k: (bool(v) if isinstance(v, (bool, np.bool_)) else
                 float(v) if isinstance(v, (float, np.floating)) else v) for k, v in r.items()}
            for r in sel.rows]
    d = {"terms": asdict(sel.terms), "tuning": asdict(sel.tuning), "rows": rows,
         "nis_ratio": sel.nis_ratio, "use_ay": sel.use_ay, "samples": sel.samples,
         "iact": sel.iact}
    try:
        f.parent.mkdir(parents=True, exist_ok=True)
        tmp = f.with_name(f".{f.name}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps(d))
        os.replace(tmp, f)
    except OSError:
        pass


def _columns(X, std, log, vehicle) -> dict:
    p = vehicle.params
    cols = {"vy_mps": X[:, 0], "yaw_rate_radps": X[:, 1],
            "beta_rad": np.arctan2(X[:, 0], log.vx), "vy_std_mps": std,
            "ay_bias_mps2": X[:, 2], "bank_mps2": X[:, 3], "kf": X[:, 4], "kr": X[:, 5]}
    a_f = log.delta - (X[:, 0] + p.a_f * X[:, 1]) / log.vx
    a_r = -(X[:, 0] - p.a_r * X[:, 1]) / log.vx
    cols["Ff_N"] = X[:, 4] * p.tire_f.force(a_f)
    cols["Fr_N"] = X[:, 5] * p.tire_r.force(a_r)
    return cols


def _run_adaptive(log: DriveLog, vehicle, name: str, linear: bool = False, fused=None,
                  progress=None, max_gap=segments.MAX_GAP_S, margin: float = 0.0,
                  candidates=None, maxiter: int = 250, cache: bool = False):
    sel, ssec = selection_for(log, vehicle, linear, candidates, maxiter, cache)
    veh = linear_vehicle(vehicle) if linear else vehicle
    use_ay = sel.use_ay

    def one(sub, a):
        t, vx, d, r, ay = SE._arrays(sub)
        if fused is None:
            obs = AD.AdaptiveEKF(veh.params, sel.terms, sel.tuning, use_ay)
            res = obs.filter(t, vx, d, r, ay, gy=None if linear else lateral_gravity(sub))
        else:
            obs = FU.IntervalFusedEKF(veh.params, sel.terms, sel.tuning, use_ay, margin=margin)
            res = obs.filter_fused(t, vx, d, r, ay, fused[0][a:a + len(sub)],
                                   fused[1][a:a + len(sub)])
        std = SE.vy_std(res["Pd"][:, 0], vx, sel.inflation, beta_floor=0.0)
        return _columns(res["X"], std, sub, veh), res["seconds"]

    one.columns = ("vy_mps", "yaw_rate_radps", "beta_rad", "vy_std_mps", "ay_bias_mps2",
                   "bank_mps2", "kf", "kr", "Ff_N", "Fr_N")
    ok = segments.moving_rows(log, vehicle)
    cols, sec, n = segments.run_stretches(one, log, vehicle, ok, max_gap, progress)
    info = {"selection": sel, "terms": str(sel.terms), "tuning": sel.tuning,
            "stretches": n, "inflation": sel.inflation}
    tr = Trajectory.from_columns(log.t, cols, seconds=sec, design_seconds=ssec, causal=True,
                                 estimator=name, info=info)
    # the stiffness box is in the filter's covariance already (Schmidt consider states)
    # when the stiffness is considered or estimated with both factors free; estimated along
    # the understeer direction only, the direction steady cornering leaves unidentified (the
    # v_y shift at fitted r and a_y) is the calibration's consider term
    considered = sel.terms.consider or (sel.terms.stiffness and not sel.terms.understeer_only)
    return calibration.calibrate(tr, log, vehicle, consider=not considered)


@estimator("adaptive-ekf", "EKF with the model terms (roll gradient, a_y bias, bank, stiffness "
           "adaptation, kinematic blend) chosen per log by BIC of the measured-channel "
           "innovations; road bank from a bank/roll column if present; v_y std and an "
           "identifiability verdict",
           optional_columns=("ay_mps2", *BANK_COLUMNS), paper="this library")
def run_adaptive(log: DriveLog, vehicle, progress=None, max_gap=segments.MAX_GAP_S,
                 candidates=None, maxiter: int = 250, cache: bool = False, **_):
    """``candidates``: the terms the selection may add (default: every term,
    ``adaptive.TERM_NAMES``); ``maxiter``: Nelder-Mead iterations
    per tuning."""
    return _run_adaptive(log, vehicle, "adaptive-ekf", progress=progress, max_gap=max_gap,
                         candidates=candidates, maxiter=maxiter, cache=cache)


@estimator("linear-kf-ml", "plain linear Kalman filter on the vehicle file (linear tyres of the "
           "zero-slip slopes, measures r and a_y), ML noise on measured channels",
           optional_columns=("ay_mps2",), paper="baseline")
def run_linear_kf(log: DriveLog, vehicle, progress=None, max_gap=segments.MAX_GAP_S,
                  cache: bool = False, **_):
    return _run_adaptive(log, vehicle, "linear-kf-ml", linear=True, progress=progress,
                         max_gap=max_gap, cache=cache)


@estimator("fusion-interval", "adaptive EKF truncated to the interval-coordinates bounds of "
           "v_y at every sample (truncated Gaussian)", optional_columns=("ay_mps2",),
           vehicle_keys=("m", "I_z", "a_f", "a_r", "tire_front", "tire_rear",
                         "uncertainty.stiffness_rel", "uncertainty.vx_min",
                         "uncertainty.vx_max"), paper="this library")
def run_fusion(log: DriveLog, vehicle, progress=None, max_gap=segments.MAX_GAP_S,
               margin: float = 0.0, interval: Trajectory | None = None, cache: bool = False,
               **_):
    from vehicle_observers.estimation.registry import get

    iv = interval if interval is not None else get("interval-coordinates").run(log, vehicle,
                                                                              cache=cache)
    c = iv.columns
    tr = _run_adaptive(log, vehicle, "fusion-interval", fused=(c["vy_lo_mps"], c["vy_hi_mps"]),
                       progress=progress, max_gap=max_gap, margin=margin, cache=cache)
    tr.info["interval_seconds"] = iv.seconds
    return tr


@estimator("mbds-kf", "linear single-track KF of MBDS/sideslip-angle-vehicle-estimation "
           "(Leanza et al. 2021), their noise rule", columns=("ay_mps2",), paper="leanza2021")
def run_mbds_kf(log: DriveLog, vehicle, max_gap=segments.MAX_GAP_S, progress=None, **_):
    """Their KF on every stretch in motion, the kinematic low-speed model elsewhere (the
    same standstill and gap handling as every built-in filter: their model divides by
    ``v_x``), their noise rule from the whole log's channels."""
    car = PE.SingleTrack.from_vehicle(vehicle)
    sg = PE.mbds_kf_sigmas(log)

    def one(sub, a):
        tr = PE.mbds_kf(sub, car, sg)
        return {k: tr.columns[k] for k in one.columns}, tr.seconds

    one.columns = ("vy_mps", "yaw_rate_radps", "beta_rad", "vy_std_mps")
    cols, sec, n = segments.run_stretches(one, log, vehicle, segments.moving_rows(log, vehicle),
                                          max_gap, progress)
    tr = Trajectory.from_columns(log.t, cols, seconds=sec, estimator="mbds-kf",
                                 info={"sigmas": sg, "car": car, "stretches": n})
    return calibration.calibrate(tr, log, vehicle)


@estimator("mbds-fg", "factor graph of Leanza et al. 2021 (GTSAM model; batch, OFFLINE)",
           columns=("ay_mps2",), causal=False, paper="leanza2021")
def run_mbds_fg(log: DriveLog, vehicle, **_):
    return PE.mbds_fg(log, PE.SingleTrack.from_vehicle(vehicle), window=0)


@estimator("mbds-fg-lag5", "factor graph of Leanza et al. 2021, fixed-lag window of 5 samples "
           "(4-sample look-ahead: not causal)", columns=("ay_mps2",), causal=False,
           paper="leanza2021")
def run_mbds_fg_lag(log: DriveLog, vehicle, **_):
    return PE.mbds_fg(log, PE.SingleTrack.from_vehicle(vehicle), window=PE.MBDS_FIXED_LAG)


@estimator("vy-zero", "v_y = 0 (the do-nothing baseline)", paper="baseline")
def run_vy_zero(log: DriveLog, vehicle, **_):
    z = np.zeros(len(log))
    return Trajectory.from_columns(log.t, {"vy_mps": z, "beta_rad": z}, seconds=0.0,
                                   estimator="vy-zero")
