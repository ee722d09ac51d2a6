"""Registry of observers: one entry per estimator, usable by the CLI and the benchmark.

Each :class:`ObserverSpec` says what the observer needs (log columns, vehicle-file keys),
whether it is causal and whether it gives intervals, and has ``run(log, vehicle, **opts)``
returning :class:`Estimates` (time plus columns with units in their names, the same names
as the log schema: ``vy_mps``, ``yaw_rate_radps``, ``Ff_N``, ``Fr_N``, ``beta_rad``;
interval observers add ``<name>_lo``/``<name>_hi`` pairs, e.g. ``vy_lo_mps``), plus the
row flags ``low_speed`` and ``reinit`` of :mod:`vehicle_observers.cli.segments` (each
observer runs on the stretches in motion between gaps; the other rows get the kinematic
low-speed model).

Adapters for observers written elsewhere in the package are registered only if their
module imports (see :func:`available`), so a missing module never breaks the CLI.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from vehicle_observers.baselines import kalman
from vehicle_observers.cli import segments
from vehicle_observers.core.errors import LogFormatError
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models.vehicle import KalmanTuning, Vehicle

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
#: fewest rows of moving data the ML noise tuning accepts
MIN_TUNE_ROWS = 50
#: the ML tuning runs on the window thinned to at most this rate [Hz] (:func:`kalman.tune`:
#: thinning keeps the per-sample measurement variance and q is per second)
TUNE_RATE_HZ = 100.0


def tuning_window(log: DriveLog, vehicle: Vehicle, window_s=TUNE_WINDOW_S,
                  max_gap=segments.MAX_GAP_S) -> DriveLog:
    """The first ``window_s`` seconds of the first stretch of moving rows
    (:func:`segments.stretches`) with at least :data:`MIN_TUNE_ROWS` rows. Raises
    LogFormatError when there is none or the window is too short."""
    if not (np.isfinite(window_s) and window_s > 0):
        raise LogFormatError(f"--tune-window must be > 0 s, got {window_s}")
    ok = segments.moving_rows(log, vehicle)
    runs, _ = segments.stretches(log.t, ok, max_gap, MIN_TUNE_ROWS)
    if not runs:
        raise LogFormatError(f"{log.source or 'log'}: no stretch of {MIN_TUNE_ROWS} rows in "
                             f"motion (v_x >= {segments.V_LOW:g} m/s, no gap > {max_gap:g} s) "
                             "for the ML noise tuning; add a [kalman] table to the vehicle file")
    a, b = runs[0]
    n = int(np.searchsorted(log.t[a:b], log.t[a] + window_s, side="right"))
    if n < MIN_TUNE_ROWS:
        raise LogFormatError(f"--tune-window {window_s:g} s holds {n} row(s) of the first "
                             f"stretch in motion (t = {log.t[a]:g} s); the ML noise tuning "
                             f"needs at least {MIN_TUNE_ROWS}")
    return segments.view(log, a, a + n)


def kalman_tuning(log: DriveLog, vehicle: Vehicle, tuning=None, window_s=TUNE_WINDOW_S,
                  progress=None, maxiter: int = 300, max_gap=segments.MAX_GAP_S,
                  rate_hz=TUNE_RATE_HZ, cache: bool = False):
    """The noise tuning used by the Kalman observers: ``tuning`` if given, else the vehicle
    file's ``[kalman]`` table, else ML (:func:`kalman.tune`) on :func:`tuning_window`
    thinned to at most ``rate_hz``. ``cache=True`` (the command line) reads / stores the ML
    result in :func:`cache_dir`. Returns ``(tuning, seconds)``."""
    if tuning is not None:
        return tuning, 0.0
    if vehicle.kalman is not None:
        return vehicle.kalman, 0.0
    t0 = time.perf_counter()
    win = tuning_window(log, vehicle, window_s, max_gap)
    key = _tuning_key(win, vehicle, maxiter, rate_hz) if cache else None
    tun = _cache_get(key) if cache else None
    if tun is None:
        tun = kalman.tune(win, vehicle.params, progress=progress, maxiter=maxiter,
                          max_rate_hz=rate_hz)
        if cache:
            _cache_put(key, tun)
    return tun, time.perf_counter() - t0


def cache_dir() -> Path:
    """Folder of the ML-tuning cache: ``$VEHICLE_OBSERVERS_CACHE`` or
    ``$XDG_CACHE_HOME/vehicle_observers`` (default ``~/.cache/vehicle_observers``)."""
    d = os.environ.get("VEHICLE_OBSERVERS_CACHE")
    if d:
        return Path(d)
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "vehicle_observers"


def _tuning_key(win: DriveLog, vehicle: Vehicle, maxiter, rate_hz) -> str:
    """SHA-256 of everything the ML tuning reads: the window's measured channels, the vehicle
    constants, the options and the source of :mod:`baselines.kalman` (a changed tuning
    never reuses an old entry)."""
    h = hashlib.sha256()      # time enters through its differences only (shift-invariant)
    for a in (win.t - win.t[0], win.vx, win.delta, win.yaw_rate, win.ay):
        h.update(b"-" if a is None else np.ascontiguousarray(a, float).tobytes())
    h.update(repr((vehicle.params.as_array().tolist(), maxiter, rate_hz)).encode())
    h.update(Path(kalman.__file__).read_bytes())
    return h.hexdigest()


def _cache_get(key):
    try:
        d = json.loads((cache_dir() / f"tuning-{key}.json").read_text())
        return KalmanTuning.from_theta(d["theta"], source=d["source"] + " (cached)",
                                       P0=tuple(d["P0"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _cache_put(key, tun: KalmanTuning):
    """Store a tuning (atomic rename; a read-only cache folder is silently skipped)."""
    f = cache_dir() / f"tuning-{key}.json"
    try:
        f.parent.mkdir(parents=True, exist_ok=True)
        tmp = f.with_name(f"{f.name}.partial-{os.getpid()}")
        tmp.write_text(json.dumps({"theta": tun.theta().tolist(), "P0": list(tun.P0),
                                   "source": tun.source}))
        os.replace(tmp, f)
    except OSError:
        pass


def ekf_columns(log: DriveLog, vehicle: Vehicle, tuning) -> tuple[dict, float]:
    """The numba EKF (:func:`kalman._ekf`, same call as :func:`kalman.ekf`) returning only
    the output columns: no (N, 3, 3) covariance array, so a 10^7-row log needs the input
    and output columns only. Returns (columns, seconds of the filter loop)."""
    inp = kalman.prepare(log)
    t0 = time.perf_counter()
    Xf, _, Pfd, *_ = kalman._ekf(inp.t, inp.vx, inp.delta, inp.yr, inp.ay, inp.use_ay,
                                 vehicle.params.as_array(), tuning.theta(), inp.x0,
                                 kalman._p0(tuning.P0, inp), False)
    sec = time.perf_counter() - t0
    std = np.sqrt(np.maximum(Pfd[:, 0], 0.0))
    del Pfd                                  # (N, 3): freed before the forces are computed
    Ff, Fr = kalman._forces(Xf, inp, vehicle.params)
    cols = {"vy_mps": Xf[:, 0], "yaw_rate_radps": Xf[:, 1],
            "beta_rad": np.arctan2(Xf[:, 0], log.vx), "Ff_N": Ff, "Fr_N": Fr,
            "vy_std_mps": std}
    if inp.use_ay:
        cols["ay_bias_mps2"] = Xf[:, 2]
    return cols, sec


def _kalman_columns(res: kalman.KalmanResult, log: DriveLog) -> dict:
    cols = {"vy_mps": res.vy, "yaw_rate_radps": res.r,
            "beta_rad": np.arctan2(res.vy, log.vx), "Ff_N": res.Ff, "Fr_N": res.Fr,
            "vy_std_mps": np.sqrt(np.maximum(res.P[:, 0, 0], 0.0))}
    if res.info.get("use_ay"):
        cols["ay_bias_mps2"] = res.X[:, 2]
    return cols


def _kalman_runner(fn, name, causal=True):
    def run(log: DriveLog, vehicle: Vehicle, tuning=None, window_s=TUNE_WINDOW_S,
            progress=None, max_gap=segments.MAX_GAP_S, cache=False, **_):
        tprog = None if progress is None else (lambda i, n: progress(i, n, "tuning"))
        tun, tsec = kalman_tuning(log, vehicle, tuning, window_s, tprog, max_gap=max_gap,
                                  cache=cache)
        slow = fn in (kalman.ekf_filterpy, kalman.ukf_filterpy)
        N = len(log)

        def one(sub, a):
            if fn is kalman.ekf:
                return ekf_columns(sub, vehicle, tun)
            kw = {}
            if progress is not None and slow:
                kw["progress"] = lambda i, n: progress(a + i, N)
            res = fn(sub, vehicle.params, tun, **kw)
            return _kalman_columns(res, sub), res.seconds

        one.columns = ("vy_mps", "yaw_rate_radps", "beta_rad", "Ff_N", "Fr_N", "vy_std_mps")
        cols, sec, n = segments.run_stretches(one, log, vehicle,
                                              segments.moving_rows(log, vehicle), max_gap,
                                              progress)
        return Estimates(name, log.t, cols, sec, tsec, causal,
                         {"tuning": tun, "stretches": n})
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

    vy (``vy_mps``) and sideslip (atan2(vy, vx), on rows with ``v_x >= V_LOW`` only) RMSE /
    max error; yaw rate against the
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
        mb = m & (log.vx >= segments.V_LOW)   # sideslip undefined at standstill
        if mb.any():
            out["rmse_beta"] = rmse(b_est, b_ref, mb)
            out["max_beta"] = max_abs(b_est, b_ref, mb)
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
