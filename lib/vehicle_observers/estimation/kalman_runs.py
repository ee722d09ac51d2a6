"""The Kalman family on drive logs: EKF (numba and filterpy), UKF (numba,
:mod:`vehicle_observers.baselines.ukf`, and filterpy) and the RTS smoother of
:mod:`vehicle_observers.baselines.kalman`, with their noise tuning (the vehicle file's
``[kalman]`` table, or maximum likelihood of the measured channels' innovations, cached).
Their ``vy_std_mps`` is calibrated (:func:`vehicle_observers.estimation.calibration.
calibrate`: the filter's own std is kept as ``vy_std_filter_mps``) and they carry the
identifiability verdict in ``info["verdict"]``.
"""

from __future__ import annotations

import hashlib
import math
import time
from pathlib import Path

import numpy as np

from vehicle_observers.baselines import kalman
from vehicle_observers.baselines.ukf import ukf as ukf_numba
from vehicle_observers.core.errors import LogFormatError, ObserverArgumentError
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.core.source import package_sha256
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.estimation import calibration, segments
from vehicle_observers.estimation.registry import EstimatorSpec, register
from vehicle_observers.models.mounting import AX_COLUMN, sensor_frame
from vehicle_observers.models.road import BANK_COLUMNS, lateral_gravity
from vehicle_observers.models.vehicle import KalmanTuning, Vehicle

#: default ML tuning window [s] when the vehicle file has no [kalman] table
TUNE_WINDOW_S = 120.0

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
    """Folder of the ML-tuning and design caches: ``$VEHICLE_OBSERVERS_CACHE`` or
    ``$XDG_CACHE_HOME/vehicle_observers`` (default ``~/.cache/vehicle_observers``;
    :func:`vehicle_observers.data.logs.cache_dir`)."""
    from vehicle_observers.data.logs import cache_dir as _cache_dir

    return _cache_dir()


def _tuning_key(win: DriveLog, vehicle: Vehicle, maxiter, rate_hz) -> str:
    """SHA-256 of everything the ML tuning reads: the window's measured channels, the vehicle
    constants, the options and the source of the package
    (:func:`vehicle_observers.core.source.package_sha256`: a changed tuning never reuses an
    old entry)."""
    h = hashlib.sha256()      # time enters through its differences only (shift-invariant)
    for a in (win.t - win.t[0], win.vx, win.delta, win.yaw_rate, win.ay,
              lateral_gravity(win)):
        h.update(b"-" if a is None else np.ascontiguousarray(a, float).tobytes())
    h.update(repr((vehicle.params.as_array().tolist(), vehicle.params.stiffness_speed, maxiter,
                   rate_hz)).encode())
    h.update(Path(kalman.__file__).read_bytes())
    h.update(package_sha256().encode())     # any module the tuning reaches
    return h.hexdigest()


def _check_tuning(d: dict):
    """A cached tuning: five finite noise variances (``q_b`` >= 0, the others > 0) and three
    finite positive initial variances; else :class:`~vehicle_observers.core.cache.InvalidEntry`."""
    from vehicle_observers.core.cache import InvalidEntry

    th, P0 = d.get("theta"), d.get("P0")
    if not (isinstance(th, list) and len(th) == 5 and isinstance(P0, list) and len(P0) == 3
            and isinstance(d.get("source"), str)):
        raise InvalidEntry("not a tuning entry of this version")
    tun = KalmanTuning.from_theta(th, P0=P0)
    for k in ("q_vy", "q_r", "q_b", "R_r", "R_ay"):
        v = getattr(tun, k)
        if not (math.isfinite(v) and (v >= 0.0 if k == "q_b" else v > 0.0)):
            raise InvalidEntry(f"variance {k} = {v!r} is not "
                               f"{'>= 0' if k == 'q_b' else '> 0'} and finite")
    if not all(math.isfinite(float(v)) and float(v) > 0.0 for v in P0):
        raise InvalidEntry(f"initial variances P0 = {P0} are not > 0 and finite")


def _cache_get(key):
    from vehicle_observers.core import cache as _cache

    d = _cache.load_json(cache_dir() / f"tuning-{key}.json", "kalman-tuning", _check_tuning)
    if d is None:
        return None
    return KalmanTuning.from_theta(d["theta"], source=d["source"] + " (cached)",
                                   P0=tuple(d["P0"]))


def _cache_put(key, tun: KalmanTuning):
    """Store a tuning (atomic rename; a read-only cache folder is silently skipped; a tuning
    that would not pass :func:`_check_tuning` is not kept)."""
    from vehicle_observers.core import cache as _cache

    d = {"theta": tun.theta().tolist(), "P0": list(tun.P0), "source": tun.source}
    try:
        _check_tuning(d)
    except ValueError:
        return
    _cache.save_json(cache_dir() / f"tuning-{key}.json", d, "kalman-tuning")


def ekf_columns(log: DriveLog, vehicle: Vehicle, tuning, misalignment: bool = False,
                frame: str = "body") -> tuple[dict, float]:
    """The numba EKF (:func:`kalman._ekf`, same call as :func:`kalman.ekf`) returning only
    the output columns: no (N, 3, 3) covariance array, so a 10^7-row log needs the input
    and output columns only. ``misalignment``, ``frame``: :func:`_frame`. Returns (columns,
    seconds of the filter loop)."""
    inp = kalman.prepare(log, misalignment=misalignment)
    t0 = time.perf_counter()
    Xf, _, Pfd, *_ = kalman._ekf_terms(inp.t, inp.vx, inp.delta, inp.yr, inp.ay, inp.use_ay,
                                       vehicle.params.as_array(), tuning.theta(), inp.x0,
                                       kalman._p0(tuning.P0, inp), False,
                                       *inp.terms(vehicle.params))
    sec = time.perf_counter() - t0
    std = np.sqrt(np.maximum(Pfd[:, 0], 0.0))
    del Pfd                                  # (N, 3): freed before the forces are computed
    Ff, Fr = kalman._forces(Xf, inp, vehicle.params)
    cols = {"vy_mps": Xf[:, 0], "yaw_rate_radps": Xf[:, 1],
            "beta_rad": np.arctan2(Xf[:, 0], log.vx), "Ff_N": Ff, "Fr_N": Fr,
            "vy_std_mps": std}
    if inp.use_ay:
        cols["ay_bias_mps2"] = Xf[:, 2]
    return _frame(cols, log, inp.psi, frame), sec


#: values of the ``frame`` option of the EKF and the RTS smoother
FRAMES = ("body", "sensor")


def _frame(cols: dict, log: DriveLog, psi, frame: str) -> dict:
    """``frame="sensor"``: ``vy_mps`` and ``beta_rad`` in the axes of the inertial unit
    (:func:`vehicle_observers.models.mounting.sensor_frame`, ``v_y - v_x psi_m``), the frame
    an INS reference reports in; ``"body"``: the car's axes. ``psi`` (N,) [rad] the
    estimated yaw misalignment (``None``: not applied, both frames coincide); the estimated
    ``psi_m`` is added as ``psi_mount_rad``."""
    if frame not in FRAMES:
        raise ObserverArgumentError(f"frame={frame!r}: expected one of {', '.join(FRAMES)}")
    if psi is None:
        return cols
    cols["psi_mount_rad"] = np.asarray(psi, dtype=float)
    if frame == "sensor":
        cols["vy_mps"] = sensor_frame(cols["vy_mps"], log.vx, psi)
        cols["beta_rad"] = np.arctan2(cols["vy_mps"], log.vx)
    return cols


def _kalman_columns(res: kalman.KalmanRun, log: DriveLog) -> dict:
    cols = {"vy_mps": res.vy, "yaw_rate_radps": res.r,
            "beta_rad": np.arctan2(res.vy, log.vx), "Ff_N": res.Ff, "Fr_N": res.Fr,
            "vy_std_mps": np.sqrt(np.maximum(res.P[:, 0, 0], 0.0))}
    if res.info.get("use_ay"):
        cols["ay_bias_mps2"] = res.X[:, 2]
    return cols


def _kalman_runner(fn, name, causal=True):
    def run(log: DriveLog, vehicle: Vehicle, tuning=None, window_s=TUNE_WINDOW_S,
            progress=None, max_gap=segments.MAX_GAP_S, cache=False,
            misalignment=MISALIGNMENT_DEFAULT, frame=FRAME_DEFAULT, **_):
        tprog = None if progress is None else (lambda i, n: progress(i, n, "tuning"))
        tun, tsec = kalman_tuning(log, vehicle, tuning, window_s, tprog, max_gap=max_gap,
                                  cache=cache)
        slow = fn in (kalman.ekf_filterpy, kalman.ukf_filterpy)
        N = len(log)

        def one(sub, a):
            if fn is kalman.ekf:
                return ekf_columns(sub, vehicle, tun, misalignment, frame)
            kw = {}
            if progress is not None and slow:
                kw["progress"] = lambda i, n: progress(a + i, N)
            if fn is kalman.rts:
                kw["misalignment"] = misalignment
            res = fn(sub, vehicle.params, tun, **kw)
            return _frame(_kalman_columns(res, sub), sub, res.info.get("psi_m"), frame), \
                res.seconds

        one.columns = ("vy_mps", "yaw_rate_radps", "beta_rad", "Ff_N", "Fr_N", "vy_std_mps")
        cols, sec, n = segments.run_stretches(one, log, vehicle,
                                              segments.moving_rows(log, vehicle), max_gap,
                                              progress)
        tr = Trajectory.from_columns(log.t, cols, seconds=sec, design_seconds=tsec,
                                     causal=causal, estimator=name,
                                     info={"tuning": tun, "stretches": n})
        return calibration.calibrate(tr, log, vehicle)
    return run


#: default of the ``misalignment`` option of the EKF and the RTS smoother (a_y de-rotated by
#: the unit's estimated yaw misalignment when the log has ``ax_mps2``)
MISALIGNMENT_DEFAULT = False
#: default of their ``frame`` option (:func:`_frame`)
FRAME_DEFAULT = "body"
#: the options of the EKF and the RTS smoother
_MOUNT_OPTIONS = {"misalignment": MISALIGNMENT_DEFAULT, "frame": FRAME_DEFAULT}

_KF_DOC = ("nonlinear yaw-drift model (Yacine 2015 eq. (1), Pacejka tyres; road bank from a "
           "bank/roll column if present), measures yaw rate and a_y if present; noise by ML "
           "on the first 120 s of measured channels unless the vehicle file has [kalman]")
register(EstimatorSpec("ekf", "EKF, numba (" + _KF_DOC + ")", _kalman_runner(kalman.ekf, "ekf"),
                      optional_columns=("ay_mps2", *BANK_COLUMNS, AX_COLUMN), paper="baseline",
                      origin=__name__, options=dict(_MOUNT_OPTIONS)))
register(EstimatorSpec("ekf-filterpy", "the same EKF with filterpy (slow reference)",
                      _kalman_runner(kalman.ekf_filterpy, "ekf-filterpy"),
                      optional_columns=("ay_mps2",), paper="baseline", origin=__name__))
register(EstimatorSpec("ukf", "UKF, numba (Merwe sigma points, P kept SPD; the same filter "
                      "as ukf-filterpy to round-off, same model/noise as the EKF)",
                      _kalman_runner(ukf_numba, "ukf"),
                      optional_columns=("ay_mps2",), paper="baseline", origin=__name__))
register(EstimatorSpec("ukf-filterpy", "the same UKF with filterpy (slow reference)",
                      _kalman_runner(kalman.ukf_filterpy, "ukf-filterpy"),
                      optional_columns=("ay_mps2",), paper="baseline", origin=__name__))
register(EstimatorSpec("rts", "extended RTS smoother (OFFLINE, non-causal reference) on the EKF",
                      _kalman_runner(kalman.rts, "rts", causal=False),
                      optional_columns=("ay_mps2", *BANK_COLUMNS, AX_COLUMN), causal=False,
                      paper="baseline", origin=__name__, options=dict(_MOUNT_OPTIONS)))
