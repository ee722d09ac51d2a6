"""Registry adapters for the observers of the other modules (imported by the package ``estimation``).

Each adapter builds the observer's design from a :class:`~vehicle_observers.models.vehicle.Vehicle`
(mass, inertia, axle distances, tyres, ``[uncertainty]`` box) with a rule that applies to
any vehicle file, runs it on a :class:`~vehicle_observers.data.logs.DriveLog` and returns
:class:`~vehicle_observers.core.protocol.Trajectory`. The observers themselves are not changed.

- ``ts-yacine2015``: Yacine 2015 TS observer (31) with Theorem 1 (33) (:mod:`.observers.ts_premise`).
  Needs the vision channels ``yL_m, psiL_rad`` (the premise ``v_y`` comes from them, (26)).
  TS sectors: secant-stiffness range of the vehicle's tyres over
  ``|alpha| <= uncertainty.slip_max_deg``; speed premise ``[vx_min, vx_max]``.
- ``interval-ifqir2017``: switched TS interval observer (11), Theorem 2 (:mod:`.observers.interval`).
  Nominal stiffness = the tyres' slope at zero slip, box ``+- uncertainty.stiffness_rel``;
  three speed bands with equal ``v_max/v_min`` ratio over ``[vx_min, vx_max]``; the (20)
  shift ``epsilon = 1/dt`` (one Euler step per sample keeps discrete positivity);
  ``|dv_x/dt| <= 12 m/s^2`` (1.2 g, a bound for any road car); measurement bounds
  ``|y - r| <= 4 sigma_r`` and ``|delta_meas - delta| <= 4 sigma_delta`` with the sigmas
  the standard deviation of the first difference / sqrt(2) of each channel (white-noise
  part), floored at 1e-4; initial box ``v_y in [-2, 2] m/s``, ``r`` +-0.6 rad/s around the
  first measurement.

Not registered: the relaxed UIO of :mod:`.observers.uio` (El Youssfi 2020): its model needs two
yaw-rate sources (gyro and wheel-speed yaw rate) at one constant speed and estimates an
actuator/sensor fault, a different problem from estimating ``v_y`` on a variable-speed log.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from vehicle_observers.core.errors import InfeasibleDesign, LogFormatError
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.core.source import package_sha256
from vehicle_observers.estimation import (
    kalman_runs,  # noqa: F401  (the Kalman family first)
    segments,
)
from vehicle_observers.estimation.registry import VEHICLE_KEYS, EstimatorSpec, register
from vehicle_observers.models.vehicle import VehicleFileError


def _noise_std(x):
    """Std of the white part of a channel: std(diff(x)) / sqrt(2)."""
    return float(np.std(np.diff(np.asarray(x, float))) / np.sqrt(2.0))


# ------------------------------------------------------------------ design cache --------
# A certified LMI design takes 0.5-8 s (cvxpy + Clarabel); the command line keeps it on disk
# like the Kalman tuning (:func:`kalman_runs.cache_dir`), keyed by everything the design
# reads (the vehicle constants and tyres, the [uncertainty] box, the sample period, the
# design's options) and the source of the modules that compute it and the solver versions,
# so an edited design or solver never reuses an old entry.


def _design_key(kind: str, vehicle, dt, *modules) -> str:
    import hashlib
    from importlib.metadata import PackageNotFoundError, version

    h = hashlib.sha256()
    h.update(repr((kind, vehicle.params.as_array().tolist(),
                   type(vehicle.params.tire_f).__name__, type(vehicle.params.tire_r).__name__,
                   sorted(vehicle.uncertainty.items()), None if dt is None else round(dt, 9),
                   ACCEL_MAX)).encode())
    for pkg in ("cvxpy", "clarabel", "numpy"):
        try:
            h.update(f"{pkg}={version(pkg)}".encode())
        except PackageNotFoundError:
            h.update(pkg.encode())
    for m in (__file__, *modules):
        h.update(Path(m).read_bytes())
    h.update(package_sha256().encode())     # any module the design reaches
    return h.hexdigest()


def _disk_design(kind, key_args, build, cache: bool):
    """``build() -> design`` through the on-disk cache when ``cache`` (an ``.npz`` data entry
    in :func:`kalman_runs.cache_dir`, :mod:`vehicle_observers.core.cache`: no pickle, so a
    planted file cannot run code; written atomically; an unreadable, stale or invalid entry
    (a non-finite number, a ``P`` not positive definite) is rebuilt with a line naming it,
    an unwritable folder skipped; a design holding functions, e.g. the TS model's premises,
    is not kept). Returns (design, seconds spent now)."""
    from vehicle_observers.core import cache as _cache

    t0 = time.perf_counter()
    if not cache:
        return build(), time.perf_counter() - t0
    f = kalman_runs.cache_dir() / f"design-{kind}-{_design_key(kind, *key_args)}.npz"
    des = _cache.load(f, f"design-{kind}", _cache.check_finite)
    if des is not None:
        return des, time.perf_counter() - t0
    des = build()
    _cache.save(f, des, f"design-{kind}", _cache.check_finite)
    return des, time.perf_counter() - t0


# ------------------------------------------------------------------ Yacine 2015 TS -------
# The observer modules import cvxpy (~1 s): they are imported when an observer runs, not
# when the registry is listed, so ``estimate --observer ekf`` does not pay for them.


def ts_design(vehicle, cache: bool = False):
    """Theorem 1 design for ``vehicle`` (cached per vehicle in the process; ``cache=True``
    also on disk, :func:`_disk_design`). Returns (design, seconds of the LMI solve or of
    reading the disk cache; the first solve's time is returned for designs cached in the
    process)."""
    from vehicle_observers.design import lmi as _lmi
    from vehicle_observers.models import lateral as _lat
    from vehicle_observers.observers import ts_premise as _to

    key = (vehicle.params, tuple(sorted(vehicle.uncertainty.items())))
    if key in _TS_CACHE:
        return _TS_CACHE[key]
    vmin, vmax, amax = vehicle.need_uncertainty("vx_min", "vx_max", "slip_max_deg",
                                                purpose="observer 'ts-yacine2015'")
    p = vehicle.params
    a = np.radians(amax)

    def build():
        ts = _lat.yacine_ts(p, Mf=p.tire_f.sector_bounds(a), Mr=p.tire_r.sector_bounds(a),
                            vx_bounds=(vmin, vmax))
        return _to.design_theorem1(ts, alpha=1e-3)

    des, sec = _disk_design("ts", (vehicle, None, _to.__file__, _lmi.__file__, _lat.__file__),
                            build, cache)
    _TS_CACHE[key] = (des, sec)
    return des, sec


_TS_CACHE: dict = {}


def _run_ts(log, vehicle, max_gap=segments.MAX_GAP_S, progress=None, cache=False, **_):
    from vehicle_observers.models.tires import Pacejka

    for axle, tyre in (("tire_front", vehicle.params.tire_f), ("tire_rear", vehicle.params.tire_r)):
        if not isinstance(tyre, Pacejka):
            raise VehicleFileError(f"{Path(vehicle.path).name or vehicle.name}: "
                                   f"'{axle}.model' = \"linear\" gives one stiffness, no TS "
                                   "sectors; observer 'ts-yacine2015' needs Pacejka tyres")
    from vehicle_observers.observers import ts_premise as _to

    des, sec = ts_design(vehicle, cache)
    info = {"clipped": 0}

    def one(sub, a):
        _regular(sub, "ts-yacine2015")
        t0 = time.perf_counter()
        run = _to.run_observer(sub, des, params=vehicle.params)
        wall = time.perf_counter() - t0
        info["clipped"] += int(run.clipped.any(axis=1).sum())
        return ({"vy_mps": run.vy, "yaw_rate_radps": run.x[:, 1],
                 "beta_rad": np.arctan2(run.vy, sub.vx), "Ff_N": run.Ff, "Fr_N": run.Fr}, wall)

    one.columns = ("vy_mps", "yaw_rate_radps", "beta_rad", "Ff_N", "Fr_N")
    cols, wall, n = segments.run_stretches(one, log, vehicle, segments.moving_rows(log),
                                           max_gap, progress)
    return Trajectory.from_columns(log.t, cols, seconds=wall, design_seconds=sec,
                                   estimator="ts-yacine2015",
                                   info={"clipped_share": info["clipped"] / len(log),
                                         "stretches": n,
                                         "lmi_margin": des.margins()["xi_original_min_margin"],
                                         "note": "wall time includes the vision-chain "
                                                 "differentiators"})


#: largest relative spread of the sampling interval the fixed-step observers accept
DT_RTOL = 1e-3


def _regular(log, name):
    """Raise LogFormatError unless ``log`` is sampled at one period (within DT_RTOL)."""
    d = np.diff(log.t)
    if len(d) and (d.max() - d.min()) > DT_RTOL * np.median(d):
        k = int(np.argmax(np.abs(d - np.median(d))))
        raise LogFormatError(f"{log.source}: column 't_s' is irregular (step {d[k]:.6g} s at "
                             f"row {k + 1} vs median {np.median(d):.6g} s); observer {name!r} "
                             f"needs a fixed sampling period (resample the log, or use 'ekf' / "
                             f"'interval-ifqir2017', which use the real timestamps)")


register(EstimatorSpec(
    "ts-yacine2015",
    "Yacine 2015 TS observer (31), Theorem 1 LMI (33), premise v_y from vision (26)",
    _run_ts, columns=("yL_m", "psiL_rad"),
    vehicle_keys=VEHICLE_KEYS + ("l_s", "uncertainty.vx_min", "uncertainty.vx_max",
                                 "uncertainty.slip_max_deg"),
    paper="Yacine 2015", origin=__name__))


# ------------------------------------------------------------------ Ifqir 2017 interval --

ACCEL_MAX = 12.0  # m/s^2
_IV_CACHE: dict = {}


def _design_or_refusal(kind, key_args, build, cache):
    """:func:`_disk_design`, or the :class:`InfeasibleDesign` it raised (kept in the process
    cache like a design: a car the LMIs refuse is refused again without re-solving, e.g.
    ``fusion-interval`` after ``interval-coordinates`` on the same log)."""
    try:
        return _disk_design(kind, key_args, build, cache)
    except InfeasibleDesign as exc:
        return exc


def _cached(entry):
    """A process-cache entry: the (design, seconds) pair, or a new :class:`InfeasibleDesign`
    with the stored refusal's message (a fresh exception, no growing traceback)."""
    if isinstance(entry, InfeasibleDesign):
        raise type(entry)(str(entry), lmi=entry.lmi, violation=entry.violation,
                          status=entry.status)
    return entry


def _layer_files() -> tuple:
    """Source files of the LMI synthesis layer that poses and certifies Theorem 2
    (:func:`vehicle_observers.observers.interval.theorem2_synthesis`): part of the cache key."""
    from vehicle_observers.design import certify, constraints, lyapunov, synthesis, system

    return tuple(m.__file__ for m in (lyapunov, synthesis, certify, constraints, system))


def interval_design(vehicle, dt: float, cache: bool = False):
    """Theorem 2 design for ``vehicle`` at sample period ``dt`` (``cache=True``: also on
    disk, :func:`_disk_design`). Returns (design, seconds)."""
    from vehicle_observers.design import lmi as _lmi
    from vehicle_observers.models import uncertain_bicycle as _ub
    from vehicle_observers.observers import interval as _iv

    key = (vehicle.params, tuple(sorted(vehicle.uncertainty.items())), round(dt, 9))
    if key in _IV_CACHE:
        return _cached(_IV_CACHE[key])
    rel, vmin, vmax = vehicle.need_uncertainty("stiffness_rel", "vx_min", "vx_max",
                                               purpose="observer 'interval-ifqir2017'")
    p = vehicle.params

    def build():
        veh = _ub.UncertainBicycle(m=p.m, I_z=p.I_z, l_f=p.a_f, l_r=p.a_r, c_f0=vehicle.C_f,
                                   c_r0=vehicle.C_r, rel_unc=rel, name=vehicle.name)
        bands = _ub.SpeedBands(tuple(np.geomspace(vmin, vmax, 4)))
        model = _ub.SwitchedIntervalModel(veh, bands)
        return _iv.design_theorem2(model, eps_decay=1.0, epsilon_shift=1.0 / dt,
                                   accel_max=ACCEL_MAX, p_min=1.0)

    _IV_CACHE[key] = _design_or_refusal(
        "ifqir2017", (vehicle, dt, _iv.__file__, _ub.__file__, _lmi.__file__, *_layer_files()),
        build, cache)
    return _cached(_IV_CACHE[key])


def dt_runs(t, rtol=DT_RTOL):
    """Runs of sample steps with one period: ``[(a, b, dt), ...]`` covering samples ``a..b``
    (inclusive; consecutive runs share a sample), ``dt`` the mean step of the run. Steps
    within ``rtol`` (relative) of each other share a run (quantised on a log grid)."""
    d = np.diff(np.asarray(t, float))
    if not len(d):
        return [(0, 0, 0.0)]
    q = np.round(np.log(d) / np.log1p(rtol)).astype(np.int64)
    brk = np.flatnonzero(np.r_[True, q[1:] != q[:-1]])
    ends = np.r_[brk[1:], len(d)]
    return [(int(a), int(b), float(d[a:b].mean())) for a, b in zip(brk, ends)]


def interval_real_dt(des, t, vx, u_lo, u_hi, y, x0_lo, x0_hi, y_noise, run=None):
    """Ifqir 2017 observer (11) over a log with its real timestamps ``t`` (N,) [s]: one call of
    ``run`` (default :func:`interval.run_interval_observer`; the coordinate-change observer
    passes :func:`interval_coordinates.run`) per run of equal steps (:func:`dt_runs`), each
    started from the box the previous one reached. Returns (x_lo, x_hi) (N, 2)."""
    if run is None:
        from vehicle_observers.observers.interval import run_interval_observer as run

    N = len(t)
    xl, xh = np.empty((N, 2)), np.empty((N, 2))
    lo, hi = np.asarray(x0_lo, float), np.asarray(x0_hi, float)
    for a, b, dt in dt_runs(t):
        sl = slice(a, b + 1)
        res = run(des, dt if dt > 0 else 1.0, vx[sl], u_lo[sl], u_hi[sl], y[sl], lo, hi,
                  y_noise=y_noise, clip_speed=True)
        xl[sl], xh[sl] = res.x_lo, res.x_hi
        lo, hi = res.x_lo[-1], res.x_hi[-1]
    return xl, xh


INTERVAL_COLUMNS = ("vy_mps", "yaw_rate_radps", "beta_rad", "vy_lo_mps", "vy_hi_mps",
                    "yaw_rate_lo_radps", "yaw_rate_hi_radps")


def _interval_stretches(des, log, vehicle, max_gap, progress, run=None):
    """Run an interval observer over the moving stretches of ``log`` (real timestamps, low
    speed and gaps handled by :mod:`.estimation.segments`). Returns (columns, wall [s], stretches,
    y_noise, steer_noise)."""
    y_noise = 4.0 * max(_noise_std(log.yaw_rate), 1e-4)
    d_noise = 4.0 * max(_noise_std(log.delta), 1e-4)

    def one(sub, a):
        r0 = float(sub.yaw_rate[0])
        t0 = time.perf_counter()
        lo, hi = interval_real_dt(des, sub.t, sub.vx, sub.delta - d_noise, sub.delta + d_noise,
                                  sub.yaw_rate, [-2.0, r0 - 0.6], [2.0, r0 + 0.6], y_noise, run)
        wall = time.perf_counter() - t0
        mid = 0.5 * (lo + hi)
        return (dict(zip(INTERVAL_COLUMNS, (mid[:, 0], mid[:, 1], np.arctan2(mid[:, 0], sub.vx),
                                            lo[:, 0], hi[:, 0], lo[:, 1], hi[:, 1]))), wall)

    one.columns = INTERVAL_COLUMNS
    one.r_noise = y_noise
    cols, wall, n = segments.run_stretches(one, log, vehicle, segments.moving_rows(log),
                                           max_gap, progress)
    return cols, wall, n, y_noise, d_noise


def _run_interval(log, vehicle, max_gap=segments.MAX_GAP_S, progress=None, cache=False, **_):
    des, sec = interval_design(vehicle, log.dt, cache)
    cols, wall, n, y_noise, d_noise = _interval_stretches(des, log, vehicle, max_gap, progress)
    edges = des.model.bands.edges
    moving = ~cols["low_speed"]
    return Trajectory.from_columns(log.t, cols, seconds=wall, design_seconds=sec,
                                   estimator="interval-ifqir2017",
                                   info={"y_noise": y_noise, "steer_noise": d_noise, "stretches": n,
                                         "n_clipped": int(np.sum(moving & ((log.vx < edges[0])
                                                                 | (log.vx > edges[-1])))),
                                         "gamma": des.gamma, "lmi_margin": des.lmi_margin,
                                         "metzler_margin": des.min_metzler_margin})


register(EstimatorSpec(
    "interval-ifqir2017",
    "Ifqir 2017 switched TS interval observer (11), Theorem 2 LMI; bounds on vy and r "
    "(point estimate = interval midpoint)",
    _run_interval,
    vehicle_keys=VEHICLE_KEYS + ("uncertainty.stiffness_rel", "uncertainty.vx_min",
                                 "uncertainty.vx_max"),
    interval=True, paper="Ifqir 2017", origin=__name__))


# ------------------------------------------------------------------ interval, any car -----
# ``interval-coordinates``: the same observer (11) in z = T(kappa) x
# (:mod:`.observers.interval_coordinates`, Raissi, Efimov, Zolghadri 2012), which certifies
# for neutral-steer and oversteering cars that ``interval-ifqir2017`` refuses. Same bands,
# epsilon = 1/dt, acceleration bound, measurement bounds, initial box, real timestamps and
# low-speed / gap handling as ``interval-ifqir2017``; kappa picked among the candidates by the
# smallest certified gamma.


def coordinate_interval_design(vehicle, dt: float, cache: bool = False):
    """Certified design in ``z = T x`` for ``vehicle`` at ``dt`` (``cache=True``: also on
    disk, :func:`_disk_design`). Returns (design, seconds)."""
    from vehicle_observers.design import lmi as _lmi
    from vehicle_observers.models import uncertain_bicycle as _ub
    from vehicle_observers.observers import interval as _iv
    from vehicle_observers.observers import interval_coordinates as _ic

    key = ("coordinates", vehicle.params, tuple(sorted(vehicle.uncertainty.items())),
           round(dt, 9))
    if key in _IV_CACHE:
        return _cached(_IV_CACHE[key])
    rel, vmin, vmax = vehicle.need_uncertainty("stiffness_rel", "vx_min", "vx_max",
                                               purpose="observer 'interval-coordinates'")
    p = vehicle.params

    def build():
        veh = _ub.UncertainBicycle(m=p.m, I_z=p.I_z, l_f=p.a_f, l_r=p.a_r, c_f0=vehicle.C_f,
                                   c_r0=vehicle.C_r, rel_unc=rel, name=vehicle.name)
        bands = _ub.SpeedBands(tuple(np.geomspace(vmin, vmax, 4)))
        return _ic.design(veh, bands, dt, accel_max=ACCEL_MAX)

    _IV_CACHE[key] = _design_or_refusal("coordinates",
                                        (vehicle, dt, _ic.__file__, _iv.__file__, _ub.__file__,
                                         _lmi.__file__, *_layer_files()), build, cache)
    return _cached(_IV_CACHE[key])


def _run_interval_coordinates(log, vehicle, max_gap=segments.MAX_GAP_S, progress=None,
                              cache=False, **_):
    from vehicle_observers.observers import interval_coordinates as _ic

    cd, sec = coordinate_interval_design(vehicle, log.dt, cache)
    cols, wall, n, y_noise, d_noise = _interval_stretches(cd, log, vehicle, max_gap, progress,
                                                          run=_ic.run)
    d = cd.design
    return Trajectory.from_columns(log.t, cols, seconds=wall, design_seconds=sec,
                                   estimator="interval-coordinates",
                                   info={"y_noise": y_noise, "steer_noise": d_noise, "stretches": n,
                                         "kappa": cd.kappa, "gamma": d.gamma,
                                         "lmi_margin": d.lmi_margin,
                                         "metzler_margin": d.min_metzler_margin,
                                         "certified": cd.certified})


register(EstimatorSpec(
    "interval-coordinates",
    "Ifqir 2017 interval observer (11) in z = T x (Raissi 2012 change of coordinates): "
    "certified for any car, incl. neutral / oversteer boxes refused by interval-ifqir2017",
    _run_interval_coordinates,
    vehicle_keys=VEHICLE_KEYS + ("uncertainty.stiffness_rel", "uncertainty.vx_min",
                                 "uncertainty.vx_max"),
    interval=True, paper="Ifqir 2017; Raissi, Efimov, Zolghadri 2012",
    origin=__name__))
