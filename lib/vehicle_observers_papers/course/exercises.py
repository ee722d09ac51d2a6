"""Checkers of notebook 00's exercises (:func:`vehicle_observers.results.teaching.check`).

Each checker computes the expected answer itself, by a route other than the worked solution,
and calls the student's function on more than one input, so a hard-coded number fails:

1. :func:`check_1` - the yaw-drift model with relaxation (Yacine 2015 eqs. (1), (4), (6)) written
   in the course notation. Expected: the paper's own transformed form (13) in the paper's
   symbols (:func:`vehicle_observers.models.lateral.rhs_transformed`, state
   ``x = [v_y, psi_dot, (F_f + F_r)/m, (a_f F_f - a_r F_r)/I_z]``, relaxation length ``r``),
   compared through the change of coordinates at random states of two cars.
2. :func:`check_2` - two registered estimators on the common manoeuvre: their ``v_y`` RMSE
   after the start transient and the better one. Expected: each estimator run by
   :meth:`EstimatorSpec.estimate` and scored by :func:`vehicle_observers.estimation.score`, for
   two pairs of estimators.
3. :func:`check_3` - which registered estimators fit a sensor set (and are causal, or give
   guaranteed bounds). Expected: each estimator's own check (:meth:`EstimatorSpec.check`) on a
   log that holds exactly those columns, for three sensor sets.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from vehicle_observers import estimation as EST
from vehicle_observers.core.errors import LogFormatError
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models import lateral
from vehicle_observers.models.vehicle import load_vehicle
from vehicle_observers.results.teaching import check

from vehicle_observers_papers.course import families

# ------------------------------------------------------------------ exercise 1 ---------------


@dataclass(frozen=True)
class CourseCar:
    """A car's constants in the course notation: mass ``m`` [kg], yaw inertia ``I_z``
    [kg m^2], CoG-axle distances ``l_f``, ``l_r`` [m], relaxation lengths ``sigma_f``,
    ``sigma_r`` [m], steady tyre forces ``F_f_ss(alpha_f)``, ``F_r_ss(alpha_r)`` [N] (Pacejka,
    slip angle in rad). ``params`` keeps the library's
    :class:`~vehicle_observers.models.lateral.LateralParams` (paper symbols ``a_f, a_r, r_f,
    r_r``)."""

    m: float
    I_z: float
    l_f: float
    l_r: float
    sigma_f: float
    sigma_r: float
    F_f_ss: Callable
    F_r_ss: Callable
    params: lateral.LateralParams


def course_car(vehicle: str = "yacine2015") -> CourseCar:
    """:class:`CourseCar` of a shipped vehicle file (``yacine2015``, ``revs250lm``)."""
    p = load_vehicle(vehicle).params
    return CourseCar(p.m, p.I_z, p.a_f, p.a_r, p.r_f, p.r_r, p.tire_f.force, p.tire_r.force, p)


def _states(seed: int, n: int = 6) -> np.ndarray:
    """``n`` random rows ``[v_y, r, F_f, F_r, delta, v_x]`` inside the model's range."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-1.0, 1.0, n), rng.uniform(-0.5, 0.5, n),
                            rng.uniform(-4e3, 4e3, n), rng.uniform(-4e3, 4e3, n),
                            rng.uniform(-0.05, 0.05, n), rng.uniform(5.0, 17.0, n)])


def _collect(fn, rows, car):
    out = []
    for vy, r, Ff, Fr, d, vx in rows:
        y = fn(vy, r, Ff, Fr, d, vx, car)
        if y is None or y is Ellipsis:
            return None
        out.append(np.asarray(y, dtype=float).reshape(4))
    return np.array(out)


def _paper_form(rows, p: lateral.LateralParams) -> np.ndarray:
    """Time derivative of the paper's state x of (12) by (13) at the course-notation states."""
    X = rows[:, :4]
    x = np.column_stack([X[:, 0], X[:, 1], (X[:, 2] + X[:, 3]) / p.m,
                         (p.a_f * X[:, 2] - p.a_r * X[:, 3]) / p.I_z])
    return np.array([lateral.rhs_transformed(x[k], rows[k, 4], rows[k, 5], p)[0]
                     for k in range(len(rows))])


def _to_paper(d: np.ndarray, p: lateral.LateralParams) -> np.ndarray:
    """Course-notation derivatives ``[v_y', r', F_f', F_r']`` -> ``x'`` of (12)."""
    return np.column_stack([d[:, 0], d[:, 1], (d[:, 2] + d[:, 3]) / p.m,
                            (p.a_f * d[:, 2] - p.a_r * d[:, 3]) / p.I_z])


def check_1(rhs_course):
    """Exercise 1: ``rhs_course(v_y, r, F_f, F_r, delta, v_x, car) -> (v_y', r', F_f', F_r')``
    (course notation, small-angle slips (4), relaxation (6)) against the paper's form (13),
    at six random states of each of two cars."""
    cars = [course_car("yacine2015"), course_car("revs250lm")]
    rows = [_states(1), _states(2)]

    def answer():
        got = [_collect(rhs_course, r, c) for r, c in zip(rows, cars)]
        if any(g is None for g in got):
            return None
        return np.vstack([_to_paper(g, c.params) for g, c in zip(got, cars)])

    want = np.vstack([_paper_form(r, c.params) for r, c in zip(rows, cars)])
    return check("00.1", answer, want, rtol=1e-6, atol=1e-9,
                 hint="the paper's r in (6) is the relaxation length (course sigma_f, sigma_r) and "
                      "its psi_dot is the yaw rate r; slips (4): alpha_f = delta - (v_y + l_f r)/v_x, "
                      "alpha_r = -(v_y - l_r r)/v_x")


# ------------------------------------------------------------------ exercise 2 ---------------

#: the pairs of registered estimators the student's function is run on
PAIRS = (("ekf", "open-loop-linear"), ("ts-yacine2015", "interval-ifqir2017"))


def expected_2(names, log: DriveLog, vehicle, tuning) -> dict:
    """``{"rmse": {name: v_y RMSE after the start transient [m/s]}, "best": name}`` through
    :meth:`EstimatorSpec.estimate` and :func:`vehicle_observers.estimation.score`."""
    veh = load_vehicle(vehicle) if isinstance(vehicle, str) else vehicle
    mask = families.score_mask(log)
    sc = {n: EST.score(EST.get(n).estimate(log, veh, tuning=tuning), log, mask)["rmse_vy"]
          for n in names}
    return {"rmse": sc, "best": min(sc, key=sc.get)}


def check_2(compare, log: DriveLog, vehicle, tuning):
    """Exercise 2: ``compare(names, log, vehicle, tuning) -> {"rmse": {name: m/s}, "best":
    name}`` on the common manoeuvre for each pair of :data:`PAIRS`."""
    def answer():
        got = {}
        for pair in PAIRS:
            g = compare(pair, log, vehicle, tuning)
            if g is None or g is Ellipsis:
                return None
            got[" vs ".join(pair)] = g
        return got

    want = {" vs ".join(p): expected_2(p, log, vehicle, tuning) for p in PAIRS}
    return check("00.2", answer, want, rtol=1e-6,
                 hint=f"score after the first {families.TRANSIENT_S:g} s only (t - t[0] >= "
                      f"{families.TRANSIENT_S:g}); the RMSE is sqrt(mean((v_y_hat - v_y)^2)); "
                      "run each estimator with the shared Kalman tuning")


# ------------------------------------------------------------------ exercise 3 ---------------

BASE = ("t_s", "vx_mps", "delta_roadwheel_rad", "yaw_rate_radps")
#: the sensor sets of the exercise: (columns, causal only, guaranteed bounds only)
CASES = {
    "gyro, steering, speed; online, guaranteed bounds": (BASE, True, True),
    "+ accelerometer; online": (BASE + ("ay_mps2",), True, False),
    "+ camera; online or offline": (BASE + ("yL_m", "psiL_rad"), False, False),
}

_ATTR = {"t_s": "t", "vx_mps": "vx", "delta_roadwheel_rad": "delta", "yaw_rate_radps": "yaw_rate",
         "ay_mps2": "ay", "yL_m": "yL", "psiL_rad": "psiL"}


def _log_with(columns) -> DriveLog:
    """A 20-row log holding exactly ``columns`` (of :data:`_ATTR`)."""
    n = 20
    full = {"t": np.arange(n) * 0.01, "vx": np.full(n, 10.0), "delta": np.zeros(n),
            "yaw_rate": np.zeros(n), "ay": np.zeros(n), "yL": np.zeros(n), "psiL": np.zeros(n)}
    return DriveLog(**{a: (v if any(_ATTR[c] == a for c in columns) else None)
                       for a, v in full.items()}, source="sensor set")


def expected_3(columns, causal_only: bool, interval_only: bool) -> str:
    """Names (sorted, comma-separated) of the registered estimators whose own check accepts a
    log with exactly ``columns``, causal if ``causal_only``, with bounds if ``interval_only``."""
    log = _log_with(columns)
    ok = []
    for n, spec in EST.available().items():
        try:
            spec.check(log)
        except LogFormatError:
            continue
        if (spec.causal or not causal_only) and (spec.interval or not interval_only):
            ok.append(n)
    return ", ".join(sorted(ok))


def check_3(usable):
    """Exercise 3: ``usable(columns, causal_only, interval_only) -> list of registry names``,
    for each sensor set of :data:`CASES`."""
    def answer():
        got = {}
        for label, (cols, c, i) in CASES.items():
            g = usable(set(cols), c, i)
            if g is None or g is Ellipsis:
                return None
            got[label] = ", ".join(sorted(g))
        return got

    want = {label: expected_3(*case) for label, case in CASES.items()}
    return check("00.3", answer, want,
                 hint="an estimator fits when every column of spec.needs is in the set; then "
                      "filter on spec.causal and spec.interval")
