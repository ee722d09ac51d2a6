"""Road bank in the lateral balance, read from a bank or roll column of a drive log.

On a road banked by ``phi`` the weight has a component along the car's lateral axis, but an
accelerometer reads the specific force (contact forces only): the lateral balance of the
single-track model (Yacine 2015 eq. (1), first row) gains the gravity term while the
measured ``a_y`` does not,

    v_y' = (F_f + F_r)/m - v_x r - g sin(phi),       a_y,meas = (F_f + F_r)/m

(the bank term of Tseng 2001, "Dynamic estimation of road bank angle", Vehicle System
Dynamics 36). Sign convention: ``phi > 0``
when the **right side is down**, i.e. a right-hand rotation about the forward ``x`` axis in
ISO 8855 (x forward, y left, z up) and in the NED frame of an INS (x forward, y right, z
down) alike; on such a road the weight pulls the car to its right (``-y``), hence the minus
sign. (The multi-body plant of :mod:`vehicle_observers.data.plant` counts its body roll
``roll_rad`` the other way, positive left side down.)

Columns (the open ``<quantity>_<unit>`` schema of :mod:`vehicle_observers.data.logs`):
:data:`BANK_COLUMNS`, the first present is used; ``deg`` is converted to rad. ``bank_*`` is
the road's bank and is used as it is. ``roll_*`` is the roll angle of the sensor frame
against gravity (an INS roll): the bank plus the body's own roll on its suspension. The
body's roll is no force on the car and must not enter the balance (taken as bank, it makes
the EKF 2-3x worse on the flat-road plant logs), but it tilts an accelerometer fixed to the
body, which then reads ``g sin(phi_body)`` more than the tyre forces (specific force along
the tilted axis, :mod:`vehicle_observers.data.plant`). The body's roll follows the lateral
specific force, ``phi_body = k_phi a`` (roll gradient ``k_phi`` [rad per m/s^2]; ``a`` the
measured ``a_y``, or ``v_x r`` without an a_y channel), so

    phi = roll - k_phi a,       a_y,meas - g sin(phi_body)  is what the filters read as a_y

with ``k_phi`` fitted by least squares on the differences of ``roll`` and ``a`` over
:data:`ROLL_FIT_LAG_S` (the road's bank hardly changes in 0.5 s, the body's roll follows the
load transfer within it), corrected for the white noise of ``a`` (errors in variables) and
kept in ``[0, ROLL_GRADIENT_MAX]`` (:func:`roll_gradient`; measured channels only, the
reference is never read). On the multi-body plant's four manoeuvres it finds 0.013-0.015
rad per m/s^2 against 0.013-0.015 from the noise-free channels.
"""

from __future__ import annotations

import math

import numpy as np

#: gravity [m/s^2]
G = 9.81
#: columns read as the bank angle, in order of preference (``bank`` is the road's own)
BANK_COLUMNS = ("bank_rad", "bank_deg", "roll_rad", "roll_deg")
#: factor to rad of each angle unit of :data:`BANK_COLUMNS`
TO_RAD = {"rad": 1.0, "deg": math.pi / 180.0}
#: lag [s] of the differences the roll gradient is fitted on (:func:`roll_gradient`)
ROLL_FIT_LAG_S = 0.5
#: the noise-corrected variance of the differences of ``a`` must be at least this share of
#: their raw variance, else ``a`` holds no roll signal and ``k_phi = 0``
ROLL_SIGNAL_SHARE = 0.05
#: largest roll gradient accepted [rad per m/s^2] (0.03: 17 deg per g, far beyond a road car's
#: 3-9 deg per g)
ROLL_GRADIENT_MAX = 0.03


def bank_column(log) -> str | None:
    """The column of ``log`` (a :class:`~vehicle_observers.data.logs.DriveLog`) read as the
    bank angle: the first of :data:`BANK_COLUMNS` in ``log.extra``, else ``None``."""
    extra = getattr(log, "extra", None) or {}
    return next((c for c in BANK_COLUMNS if c in extra), None)


def roll_gradient(t, roll, a) -> float:
    """Roll gradient ``k_phi`` [rad per m/s^2]: least squares of ``roll(t + L) - roll(t)`` on
    ``a(t + L) - a(t)`` (``L`` = :data:`ROLL_FIT_LAG_S` in samples of the median interval),
    the white-noise share of the regressor removed from the normal equation (noise variance
    of ``a`` from its second differences, ``E[(a_{k+1} - 2 a_k + a_{k-1})^2] = 6 sigma^2``),
    clipped to ``[0, ROLL_GRADIENT_MAX]``; 0 when the log is shorter than two lags or the
    differences of ``a`` are noise (:data:`ROLL_SIGNAL_SHARE`). ``t``, ``roll`` [rad], ``a``
    [m/s^2]: (N,)."""
    t, roll, a = (np.asarray(v, dtype=float) for v in (t, roll, a))
    if len(t) < 3:
        return 0.0
    n = max(1, int(round(ROLL_FIT_LAG_S / float(np.median(np.diff(t))))))
    if len(t) <= 2 * n:
        return 0.0
    dr, da = roll[n:] - roll[:-n], a[n:] - a[:-n]
    raw = float(da @ da)
    den = raw - len(da) * 2.0 * float(np.mean(np.diff(a, 2) ** 2)) / 6.0
    if not (raw > 0.0 and den > ROLL_SIGNAL_SHARE * raw):
        return 0.0
    return float(np.clip(float(dr @ da) / den, 0.0, ROLL_GRADIENT_MAX))


def bank_angle(log) -> np.ndarray | None:
    """Bank angle ``phi`` (N,) [rad] (module docstring's sign) from :func:`bank_column`,
    ``None`` when the log has none; a roll column less the body's roll ``k_phi a``
    (module docstring)."""
    c = bank_column(log)
    if c is None:
        return None
    phi = np.asarray(log.extra[c], dtype=float) * TO_RAD[c.rsplit("_", 1)[1]]
    if c.startswith("roll_"):
        a = log.ay if getattr(log, "ay", None) is not None else log.vx * log.yaw_rate
        a = np.asarray(a, dtype=float)
        phi = phi - roll_gradient(log.t, phi, a) * a
    return phi


def body_roll_ay(log) -> np.ndarray | None:
    """``g sin(phi_body)`` (N,) [m/s^2], what the body's roll adds to an accelerometer on
    the body, to be subtracted from the measured ``a_y`` (module docstring); ``None`` without
    a roll column or an a_y channel."""
    c = bank_column(log)
    if c is None or not c.startswith("roll_") or getattr(log, "ay", None) is None:
        return None
    roll = np.asarray(log.extra[c], dtype=float) * TO_RAD[c.rsplit("_", 1)[1]]
    a = np.asarray(log.ay, dtype=float)
    return G * np.sin(roll_gradient(log.t, roll, a) * a)


def lateral_gravity(log) -> np.ndarray | None:
    """The term ``-g sin(phi)`` (N,) [m/s^2] of the lateral balance, ``None`` without a bank
    column (a flat road: the term is zero)."""
    phi = bank_angle(log)
    return None if phi is None else np.ascontiguousarray(-G * np.sin(phi))
