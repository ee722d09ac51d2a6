"""Yaw misalignment of an inertial unit, estimated from the measured channels of a drive log.

An accelerometer mounted with a small yaw misalignment ``psi_m`` [rad] reads the body's
horizontal specific force in its own axes. Sign convention: ``psi_m > 0`` when the unit's
``x`` axis is turned to the **left** of the car's (a right-hand rotation about ``z`` up,
ISO 8855: x forward, y left, z up), so

    a_x,s = a_x cos(psi_m) + a_y sin(psi_m),     a_y,s = a_y cos(psi_m) - a_x sin(psi_m)

and the body's lateral specific force is recovered by the inverse rotation

    a_y = a_y,s cos(psi_m) + a_x,s sin(psi_m)                       (:func:`derotate_ay`).

If the same unit is also the reference (an INS), it reports the lateral velocity in its own
axes, ``v_y,s = v_y cos(psi_m) - v_x sin(psi_m) ~= v_y - v_x psi_m`` (:func:`sensor_frame`):
a constant sideslip offset ``-psi_m`` (0.36 deg on the Revs log's reference is 0.25 m/s at
40 m/s).

Estimate (:func:`yaw_misalignment`): on rows driven straight (small measured yaw rate and
steering, :data:`R_STRAIGHT`, :data:`DELTA_STRAIGHT`, speed above :data:`VX_MIN`) the body's
lateral specific force is ``v_y' + v_x r ~= v_x r``, so ``e = a_y,s - v_x r`` regresses on
``a_x,s`` with slope ``-tan(psi_m) ~= -psi_m`` (an intercept takes the sensor's a_y offset).
The estimate at row ``k`` is the running least-squares slope over the straight rows up to
``k`` (causal), shrunk towards the prior ``psi_m = 0`` by a ridge weight
:data:`PRIOR_WEIGHT`, and held at 0 until the centred sum of squares of ``a_x,s`` reaches
:data:`MIN_EXCITATION` (straight-line acceleration and braking). Only measured channels are
read (``t``, ``v_x``, ``delta``, ``r``, ``a_y``, ``ax_mps2``), never a reference column.
"""

from __future__ import annotations

import numpy as np

#: column of the longitudinal specific force [m/s^2] of the unit
AX_COLUMN = "ax_mps2"
#: a row is straight when ``|r| <`` this [rad/s] (chosen here: a straight road; the Revs
#: log has only a handful of such rows held for :data:`HOLD_S`, so there the estimate stays 0)
#: ...
R_STRAIGHT = 0.01
#: ... and ``|delta| <`` this [rad] (road wheel) ...
DELTA_STRAIGHT = 0.01
#: ... and ``v_x >`` this [m/s], all for at least :data:`HOLD_S` [s] up to the row (the
#: sideslip transient after a corner, ``v_y' != 0``, is over: without the hold it biased
#: the slope by -0.8 deg on the simulated log of the tests)
VX_MIN = 5.0
HOLD_S = 1.0
#: centred sum of squares of ``a_x,s`` over straight rows [(m/s^2)^2] before the estimate
#: leaves 0 (chosen here: 10 s at 100 Hz of +-1 m/s^2; with a_y noise 0.1-0.3 m/s^2 the
#: slope's std is then 0.1-0.3 deg, below the 0.36 deg offset to be found)
MIN_EXCITATION = 1000.0
#: ridge weight of the prior ``psi_m = 0`` [(m/s^2)^2] (chosen here: a tenth of
#: :data:`MIN_EXCITATION`, the estimate is shrunk by <= 9 % once it moves)
PRIOR_WEIGHT = 100.0


def yaw_misalignment(t, vx, delta, yaw_rate, ay, ax) -> np.ndarray:
    """Causal running estimate of ``psi_m`` (N,) [rad] (module docstring).

    Parameters
    ----------
    t : (N,) s (unused but for the shape check; rows are taken in order)
    vx : (N,) m/s
    delta : (N,) rad, road-wheel steering
    yaw_rate : (N,) rad/s
    ay, ax : (N,) m/s^2, the unit's lateral and longitudinal specific force
    """
    vx, delta, r, ay, ax = (np.asarray(v, dtype=float) for v in (vx, delta, yaw_rate, ay, ax))
    if not (len(vx) == len(delta) == len(r) == len(ay) == len(ax) == len(t)):
        raise ValueError("yaw_misalignment: the channels must have the length of t")
    ok = ((np.abs(r) < R_STRAIGHT) & (np.abs(delta) < DELTA_STRAIGHT) & (vx > VX_MIN)
          & np.isfinite(ax) & np.isfinite(ay))
    w = held(np.asarray(t, dtype=float), ok, HOLD_S).astype(float)
    x = np.where(w > 0, ax, 0.0)
    e = np.where(w > 0, ay - vx * r, 0.0)
    n = np.cumsum(w)
    sx, se = np.cumsum(x), np.cumsum(e)
    sxx, sxe = np.cumsum(x * x), np.cumsum(x * e)
    nn = np.maximum(n, 1.0)
    cxx = sxx - sx * sx / nn
    cxe = sxe - sx * se / nn
    psi = np.arctan(cxe / (cxx + PRIOR_WEIGHT))
    return np.where(cxx >= MIN_EXCITATION, -psi, 0.0)


def held(t, ok, hold_s) -> np.ndarray:
    """Rows (N,) bool where ``ok`` has been true on every row of the last ``hold_s``
    seconds up to and including the row (causal): ``t[k] - t[start of the run] >= hold_s``."""
    ok = np.asarray(ok, dtype=bool)
    idx = np.arange(len(ok))
    start = np.maximum.accumulate(np.where(ok, 0, idx + 1))     # first row of the current run
    start = np.minimum(start, len(ok) - 1)
    return ok & (t - t[start] >= hold_s)


def log_misalignment(log) -> np.ndarray | None:
    """:func:`yaw_misalignment` of a :class:`~vehicle_observers.data.logs.DriveLog` (N,)
    [rad]; ``None`` without an ``a_y`` channel or an :data:`AX_COLUMN` column."""
    extra = getattr(log, "extra", None) or {}
    if getattr(log, "ay", None) is None or AX_COLUMN not in extra:
        return None
    return yaw_misalignment(log.t, log.vx, log.delta, log.yaw_rate, log.ay, extra[AX_COLUMN])


def derotate_ay(ay_s, ax_s, psi) -> np.ndarray:
    """The body's lateral specific force ``a_y,s cos(psi) + a_x,s sin(psi)`` (N,) [m/s^2]."""
    return np.asarray(ay_s, float) * np.cos(psi) + np.asarray(ax_s, float) * np.sin(psi)


def sensor_frame(vy, vx, psi) -> np.ndarray:
    """Lateral velocity in the unit's axes ``v_y cos(psi) - v_x sin(psi)`` (N,) [m/s]."""
    return np.asarray(vy, float) * np.cos(psi) - np.asarray(vx, float) * np.sin(psi)
