"""Registry of observers: one entry per estimator, usable by the CLI and the benchmark.

Each :class:`ObserverSpec` says what the observer needs (log columns, vehicle-file keys),
whether it is causal and whether it gives intervals, and has ``run(log, vehicle, **opts)``
returning :class:`Estimates` (time plus columns with units in their names, the same names
as the log schema: ``vy_mps``, ``yaw_rate_radps``, ``Ff_N``, ``Fr_N``, ``beta_rad``;
interval observers add ``<name>_lo``/``<name>_hi`` pairs, e.g. ``vy_lo_mps``).

Adapters for observers written elsewhere in the package are registered only if their
module imports (see :func:`available`), so a missing module never breaks the CLI.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from vehicle_observers.baselines import kalman
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models.vehicle import Vehicle

#: columns every observer reads (the log schema's required ones)
BASE_COLUMNS = ("t_s", "vx_mps", "delta_roadwheel_rad", "yaw_rate_radps")
#: default ML tuning window [s] when the vehicle file has no [kalman] table
TUNE_WINDOW_S = 120.0


@dataclass
class Estimates:
    """Output of one observer run. ``columns``: name (with unit) -> (N,) array;
    ``seconds``: wall time of the estimation loop; ``design_seconds``: LMI design / tuning
    time (0 if none); ``causal``; ``info``: observer-specific details."""

    observer: str
    t: np.ndarray
    columns: dict
    seconds: float
    design_seconds: float = 0.0
    causal: bool = True
    info: dict = field(default_factory=dict)

    def get(self, name):
        return self.columns.get(name)

    @property
    def us_per_step(self) -> float:
        return 1e6 * self.seconds / max(len(self.t), 1)

    def table(self) -> dict:
        return {"t_s": self.t, **self.columns}


@dataclass(frozen=True)
class ObserverSpec:
    name: str
    description: str
    run: Callable[..., Estimates]
    columns: tuple = ()              # required log columns beyond BASE_COLUMNS
    optional_columns: tuple = ()     # used when present
    vehicle_keys: tuple = ("m", "I_z", "a_f", "a_r", "tire_front", "tire_rear")
    causal: bool = True
    interval: bool = False
    paper: str = ""

    def check(self, log: DriveLog, vehicle: Vehicle | None = None):
        """Raise (LogFormatError / VehicleFileError) naming what is missing."""
        log.require(*BASE_COLUMNS, *self.columns, purpose=f"observer {self.name!r}")
        for k in self.vehicle_keys:
            if k.startswith("uncertainty.") and vehicle is not None:
                vehicle.need_uncertainty(k.split(".", 1)[1], purpose=f"observer {self.name!r}")


_REGISTRY: dict[str, ObserverSpec] = {}


def register(spec: ObserverSpec):
    _REGISTRY[spec.name] = spec
    return spec


def get(name: str) -> ObserverSpec:
    obs = available()
    if name not in obs:
        raise KeyError(f"unknown observer {name!r}; available: {', '.join(obs)}")
    return obs[name]


def available() -> dict[str, ObserverSpec]:
    """Registered observers in registration order (the package ``cli`` imports the adapters)."""
    return dict(_REGISTRY)


# ------------------------------------------------------------------ Kalman family -------
def kalman_tuning(log: DriveLog, vehicle: Vehicle, tuning=None, window_s=TUNE_WINDOW_S,
                  progress=None, maxiter: int = 300):
    """The noise tuning used by the Kalman observers: ``tuning`` if given, else the vehicle
    file's ``[kalman]`` table, else ML on the measured channels of the log's first
    ``window_s`` seconds (:func:`kalman.tune`). Returns ``(tuning, seconds)``."""
    if tuning is not None:
        return tuning, 0.0
    if vehicle.kalman is not None:
        return vehicle.kalman, 0.0
    t0 = time.perf_counter()
    tun = kalman.tune(log, vehicle.params, window_s=window_s, progress=progress,
                      maxiter=maxiter)
    return tun, time.perf_counter() - t0


def _kalman_columns(res: kalman.KalmanResult, log: DriveLog) -> dict:
    cols = {"vy_mps": res.vy, "yaw_rate_radps": res.r,
            "beta_rad": np.arctan2(res.vy, log.vx), "Ff_N": res.Ff, "Fr_N": res.Fr,
            "vy_std_mps": np.sqrt(np.maximum(res.P[:, 0, 0], 0.0))}
    if res.info.get("use_ay"):
        cols["ay_bias_mps2"] = res.X[:, 2]
    return cols


def _kalman_runner(fn, name, causal=True):
    def run(log: DriveLog, vehicle: Vehicle, tuning=None, window_s=TUNE_WINDOW_S,
            progress=None, **_):
        tprog = None if progress is None else (lambda i, n: progress(i, n, "tuning"))
        tun, tsec = kalman_tuning(log, vehicle, tuning, window_s, tprog)
        slow = fn in (kalman.ekf_filterpy, kalman.ukf_filterpy)
        kw = {"progress": progress} if progress is not None and slow else {}
        res = fn(log, vehicle.params, tun, **kw)
        return Estimates(name, res.t, _kalman_columns(res, log), res.seconds, tsec, causal,
                         {"tuning": tun, **{k: v for k, v in res.info.items()
                                            if k not in ("Xp", "Pp", "Fs")}})
    return run


_KF_DOC = ("nonlinear yaw-drift model (Yacine 2015 eq. (1), Pacejka tyres), measures yaw rate "
           "and a_y if present; noise by ML on the first 120 s of measured channels unless the "
           "vehicle file has [kalman]")
register(ObserverSpec("ekf", "EKF, numba (" + _KF_DOC + ")", _kalman_runner(kalman.ekf, "ekf"),
                      optional_columns=("ay_mps2",), paper="baseline"))
register(ObserverSpec("ekf-filterpy", "the same EKF with filterpy (slow reference)",
                      _kalman_runner(kalman.ekf_filterpy, "ekf-filterpy"),
                      optional_columns=("ay_mps2",), paper="baseline"))
register(ObserverSpec("ukf", "UKF, filterpy Merwe sigma points, P kept SPD (same model/noise)",
                      _kalman_runner(kalman.ukf_filterpy, "ukf"),
                      optional_columns=("ay_mps2",), paper="baseline"))
register(ObserverSpec("rts", "extended RTS smoother (OFFLINE, non-causal reference) on the EKF",
                      _kalman_runner(kalman.rts, "rts", causal=False),
                      optional_columns=("ay_mps2",), causal=False, paper="baseline"))


# ------------------------------------------------------------------ scoring --------------
def score(est: Estimates, log: DriveLog, mask=None) -> dict:
    """Benchmark metrics of ``est`` against the reference columns the log has.

    vy (``vy_mps``) and sideslip (atan2(vy, vx)) RMSE / max error; yaw rate against the
    log's yaw-rate truth (``yaw_rate_true_radps`` in emulated logs) or the measured
    channel; axle forces when the log has ``Ff_N``/``Fr_N``; for interval observers the
    enclosure rate and mean width of vy and yaw rate. ``mask`` (N,) bool restricts the
    samples. Keys: ``rmse_vy``, ``max_vy``, ``rmse_beta``, ``max_beta``, ``rmse_r``,
    ``max_r``, ``rmse_Ff``, ``rmse_Fr``, ``max_Ff``, ``max_Fr``, ``enclosure_vy``,
    ``width_vy``, ``enclosure_r``, ``width_r``; absent where not computable.
    """
    from vehicle_observers.core.metrics import enclosure_rate, max_abs, rmse

    m = np.ones(len(log), bool) if mask is None else np.asarray(mask, bool)
    out = {}
    c = est.columns
    if log.vy is not None and "vy_mps" in c:
        out["rmse_vy"] = rmse(c["vy_mps"], log.vy, m)
        out["max_vy"] = max_abs(c["vy_mps"], log.vy, m)
        b_ref = np.arctan2(log.vy, log.vx)
        b_est = c.get("beta_rad", np.arctan2(c["vy_mps"], log.vx))
        out["rmse_beta"] = rmse(b_est, b_ref, m)
        out["max_beta"] = max_abs(b_est, b_ref, m)
    r_ref = log.extra.get("yaw_rate_true_radps", log.yaw_rate)
    if "yaw_rate_radps" in c:
        out["rmse_r"] = rmse(c["yaw_rate_radps"], r_ref, m)
        out["max_r"] = max_abs(c["yaw_rate_radps"], r_ref, m)
    for ax in ("Ff", "Fr"):
        ref = getattr(log, ax)
        if ref is not None and f"{ax}_N" in c:
            out[f"rmse_{ax}"] = rmse(c[f"{ax}_N"], ref, m)
            out[f"max_{ax}"] = max_abs(c[f"{ax}_N"], ref, m)
    for key, ref, nm in (("vy", log.vy, "vy_{}_mps"), ("r", r_ref, "yaw_rate_{}_radps")):
        lo, hi = c.get(nm.format("lo")), c.get(nm.format("hi"))
        if lo is not None and hi is not None and ref is not None:
            out[f"enclosure_{key}"] = enclosure_rate(lo[m], ref[m], hi[m])
            out[f"width_{key}"] = float(np.mean((hi - lo)[m]))
    return out
