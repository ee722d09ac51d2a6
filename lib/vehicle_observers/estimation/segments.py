"""Real logs for every observer: standstill / low speed, time gaps, irregular sampling.

Every observer of the registry estimates on a *stretch*: consecutive rows that are

- in motion: ``v_x >= V_LOW`` (2 m/s) and, for the Kalman family, ``h_k |lambda|max <= 2.5``
  with ``h_k = t_{k+1} - t_k`` [s] and ``|lambda|max`` the largest pole magnitude of the linear
  bicycle model at ``v_x`` (:func:`pole_rate`; the poles grow like ``1/v_x`` at low speed and
  one RK4 step per sample is stable only while ``h |lambda| < 2.78``; at 10 Hz on the Revs
  car the model is used from about 7 m/s);
- not separated by a time gap longer than ``max_gap`` (default :data:`MAX_GAP_S`).

The observer is started afresh on each stretch (its own initialisation: ``v_y = 0``, the
measured yaw rate) and re-converges there. Rows outside any stretch (standstill, low speed,
stretches shorter than :data:`MIN_RUN` rows) get the **kinematic low-speed model** (no tyre
slip at low speed; Rajamani, *Vehicle Dynamics and Control*, eq. (2.29)):

    beta = arctan(a_r tan(delta) / (a_f + a_r)),   v_y = v_x tan(beta),   r = r_meas,

axle forces from the steady turn ``F_f = m v_x r a_r / L``, ``F_r = m v_x r a_f / L``; the
``v_y`` standard deviation there is ``|v_x| tan(BETA_KIN_STD)`` and interval observers get
``v_y`` within ``+- (|v_x| tan(slip_max) + 0.01 m/s)`` of the kinematic value (``uncertainty.slip_max_deg``,
default 8 deg: an assumed bound, not the paper's guarantee). These rows have ``low_speed = 1``
in the output; the first row after a gap has ``reinit = 1``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from vehicle_observers.data.logs import _ATTR, DriveLog

#: speed below which the kinematic low-speed model is used [m/s]
V_LOW = 2.0
#: a time step longer than this re-initialises the observer [s]
MAX_GAP_S = 0.5
#: shortest stretch an observer is started on [rows]
MIN_RUN = 3
#: sideslip standard deviation of the kinematic model [rad]
BETA_KIN_STD = 0.02
#: floor of the kinematic v_y half-width [m/s] (the bound is not zero at standstill)
KIN_VY_FLOOR = 0.01
#: RK4 stability bound used for ``h |lambda|`` (the exact real-axis bound is 2.785)
RK4_BOUND = 2.5


def pole_rate(vehicle, vx) -> np.ndarray:
    """Largest pole magnitude [1/s] of the linear bicycle model (cornering stiffnesses at zero
    slip) at speeds ``vx`` (N,) [m/s], from the trace and determinant of its 2x2 matrix
    (one compiled pass: a 10^7-row log needs no temporaries)."""
    p = vehicle.params
    return _pole_rate(np.ascontiguousarray(vx, dtype=float), float(p.m), float(p.I_z),
                      float(p.a_f), float(p.a_r), float(vehicle.C_f), float(vehicle.C_r))


@njit(cache=True)
def _pole_rate(vx, m, Iz, af, ar, Cf, Cr):
    out = np.empty(vx.shape[0])
    for k in range(vx.shape[0]):
        v = max(abs(vx[k]), 1e-6)
        a11 = -(Cf + Cr) / (m * v)
        a12 = -(af * Cf - ar * Cr) / (m * v) - v
        a21 = -(af * Cf - ar * Cr) / (Iz * v)
        a22 = -(af * af * Cf + ar * ar * Cr) / (Iz * v)
        half = 0.5 * (a11 + a22)
        det = a11 * a22 - a12 * a21
        disc = half * half - det
        # real poles half +- sqrt(disc): the larger magnitude is |half| + sqrt(disc); a
        # complex pair has magnitude sqrt(det)
        out[k] = abs(half) + np.sqrt(disc) if disc >= 0 else np.sqrt(max(det, 0.0))
    return out


def moving_rows(log: DriveLog, vehicle=None, v_low: float = V_LOW) -> np.ndarray:
    """(N,) bool: rows where the observer model is used (see the module docstring);
    ``vehicle`` given: also the RK4 stability condition ``h_k |lambda|max <= 2.5``."""
    ok = log.vx >= v_low
    if vehicle is not None and len(log) > 1:
        h = np.empty(len(log))
        h[:-1] = np.diff(log.t)
        h[-1] = h[-2]
        ok &= h * pole_rate(vehicle, log.vx) <= RK4_BOUND
    return ok


def stretches(t, ok, max_gap: float = MAX_GAP_S, min_run: int = MIN_RUN):
    """Stretches ``[(a, b), ...]`` (rows ``a..b-1``) of consecutive ``ok`` rows with no time
    step above ``max_gap``, at least ``min_run`` rows long; and the (N,) bool ``reinit``
    (True on the first row after a gap)."""
    t = np.asarray(t, float)
    ok = np.asarray(ok, bool)
    reinit = np.zeros(len(t), bool)
    reinit[1:] = np.diff(t) > max_gap
    brk = np.flatnonzero(reinit | np.r_[True, ok[1:] != ok[:-1]])
    ends = np.r_[brk[1:], len(t)]
    out = [(int(a), int(b)) for a, b in zip(brk, ends) if ok[a] and b - a >= min_run]
    return out, reinit


def view(log: DriveLog, a: int, b: int) -> DriveLog:
    """Rows ``a..b-1`` of every channel, ``extra`` columns included, as views (no copy):
    an observer may read any column of the log (e.g. ``ax_mps2``)."""
    kw = {at: (None if getattr(log, at) is None else getattr(log, at)[a:b])
          for at in _ATTR.values()}
    return DriveLog(**kw, extra={c: v[a:b] for c, v in log.extra.items()},
                    source=f"{log.source}[rows {a}..{b - 1}]")


def kinematic(log: DriveLog, vehicle, rows) -> dict:
    """Kinematic low-speed estimates on ``rows`` (index array): ``vy_mps``, ``beta_rad``,
    ``yaw_rate_radps``, ``Ff_N``, ``Fr_N``, ``vy_std_mps``, ``vy_lo_mps``, ``vy_hi_mps``
    (module docstring)."""
    p = vehicle.params
    L = p.a_f + p.a_r
    vx, r = log.vx[rows], log.yaw_rate[rows]
    beta = np.arctan(p.a_r * np.tan(log.delta[rows]) / L)
    vy = vx * np.tan(beta)
    slip = np.radians(vehicle.uncertainty.get("slip_max_deg", 8.0))
    half = np.abs(vx) * np.tan(slip) + KIN_VY_FLOOR
    return {"vy_mps": vy, "beta_rad": beta, "yaw_rate_radps": r,
            "Ff_N": p.m * vx * r * p.a_r / L, "Fr_N": p.m * vx * r * p.a_f / L,
            "vy_std_mps": np.abs(vx) * np.tan(BETA_KIN_STD),
            "vy_lo_mps": vy - half, "vy_hi_mps": vy + half}


def run_stretches(run, log: DriveLog, vehicle, ok, max_gap=MAX_GAP_S, progress=None,
                  warm_up: bool = True):
    """Run ``run(sub_log, first_row) -> (columns dict, seconds)`` on every stretch and fill
    the other rows with :func:`kinematic`; yaw-rate bounds ``yaw_rate_lo/hi_radps`` there are
    the measured value +- ``run.r_noise`` (0 if unset). A first call on :data:`MIN_RUN` rows
    loads (or compiles) the numba kernels so the returned seconds exclude compilation
    (``warm_up=False`` skips it).
    Returns (columns with ``low_speed``/``reinit``, seconds summed over the stretches,
    number of stretches)."""
    N = len(log)
    runs, reinit = stretches(log.t, ok, max_gap)
    cols: dict[str, np.ndarray] = {}
    low = np.ones(N, bool)
    sec = 0.0
    done = 0
    if runs and warm_up:
        run(view(log, runs[0][0], runs[0][0] + MIN_RUN), runs[0][0])   # warm-up, discarded
    for a, b in runs:
        c, s = run(view(log, a, b), a)
        sec += s
        for k, v in c.items():
            if (a, b) == (0, N):
                cols[k] = v         # one stretch over the whole log: no copy (large logs)
                continue
            if k not in cols:
                cols[k] = np.zeros(N)
            cols[k][a:b] = v
        low[a:b] = False
        done += b - a
        if progress is not None:
            progress(done, N)
    rows = np.flatnonzero(low)
    if not cols:   # no stretch at all: the columns the observer would give
        cols = {k: np.zeros(N) for k in getattr(run, "columns", ("vy_mps",))}
    kin = kinematic(log, vehicle, rows)
    rn = getattr(run, "r_noise", 0.0)
    for k, v in cols.items():
        if k in kin:
            v[rows] = kin[k]
        elif k == "yaw_rate_lo_radps":
            v[rows] = log.yaw_rate[rows] - rn
        elif k == "yaw_rate_hi_radps":
            v[rows] = log.yaw_rate[rows] + rn
        # other columns (e.g. ay_bias_mps2) stay 0 on low-speed rows
    cols["low_speed"] = low
    cols["reinit"] = reinit
    return cols, sec, len(runs)
