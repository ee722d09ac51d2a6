"""Identification of tyre parameters from measured channels only.

The friction coefficient of a log's Pacejka tyres is identified by matching the *measured
yaw rate* (an ordinary sensor channel), never the reference lateral velocity, so the
reference stays an independent check and the same procedure applies to any car's log:

    mu* = argmin_mu  RMS( r_model(mu; delta, v_x) - r_measured ),   mu in [mu_lo, mu_hi]

with ``r_model`` the open-loop simulation of the yaw-drift model (1)-(3) of Yacine 2015
driven by the measured steering and speed. The slope at zero slip (``B C D``) is kept at
the given cornering stiffness, so ``mu`` only moves the saturation (``D = mu F_z``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import minimize_scalar

from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models.lateral import LateralParams, simulate_s1
from vehicle_observers.models.tires import Pacejka


def pacejka_axle(C_alpha: float, Fz: float, mu: float, C: float = 1.3, E: float = 0.0):
    """Per-axle Pacejka tyre with slope ``C_alpha`` [N/rad] at zero slip and peak ``mu Fz`` [N]."""
    D = mu * Fz
    return Pacejka(B=C_alpha / (C * D), C=C, D=D, E=E)


def with_friction(p: LateralParams, mu: float, Fz_f: float, Fz_r: float, C: float = 1.3):
    """Copy of ``p`` whose tyres keep their zero-slip slope and have peak ``mu F_z``."""
    return replace(p, tire_f=pacejka_axle(p.tire_f.cornering_stiffness, Fz_f, mu, C),
                   tire_r=pacejka_axle(p.tire_r.cornering_stiffness, Fz_r, mu, C))


def static_axle_loads(p: LateralParams, g: float = 9.81) -> tuple[float, float]:
    L = p.a_f + p.a_r
    return p.m * g * p.a_r / L, p.m * g * p.a_f / L


def yaw_rate_rms(p: LateralParams, log: DriveLog, delta=None, substeps: int = 10) -> float:
    """RMS yaw-rate error [rad/s] of the open-loop model (1)-(3); inf if it diverges."""
    delta = log.delta if delta is None else delta
    X = simulate_s1([0.0, log.yaw_rate[0]], delta, log.vx, log.dt, p, exact=True,
                    relaxation=False, substeps=substeps)
    e = X[:, 1] - log.yaw_rate
    val = float(np.sqrt(np.mean(e**2)))
    return val if np.isfinite(val) and np.abs(X[:, 0]).max() < 50 else np.inf


def identify_friction(p: LateralParams, log: DriveLog, delta=None, bounds=(1.0, 3.0),
                      substeps: int = 10) -> tuple[float, LateralParams, float]:
    """Identify ``mu`` from the measured yaw rate (bounded Brent search).

    Returns ``(mu, params_with_mu, yaw_rate_rms)``. The search is a bounded scalar
    minimisation; a diverging simulation (spin) scores ``inf`` -- a large finite penalty is
    used instead so the bracket search stays well defined.
    """
    Fz_f, Fz_r = static_axle_loads(p)

    def cost(mu):
        c = yaw_rate_rms(with_friction(p, mu, Fz_f, Fz_r), log, delta, substeps)
        return c if np.isfinite(c) else 1e3

    res = minimize_scalar(cost, bounds=bounds, method="bounded", options={"xatol": 1e-3})
    mu = float(res.x)
    return mu, with_friction(p, mu, Fz_f, Fz_r), float(res.fun)
