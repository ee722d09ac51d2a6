"""Checkers of the start page's exercises (:func:`vehicle_observers.results.teaching.check`).

Each checker computes the expected answer itself, by a route other than the worked solution
(``notebooks/solutions/00_start_here_solutions.ipynb``), and calls the student's function on
more than one input, so a hard-coded number fails:

1. :func:`check_1` - the yaw-drift model with relaxation (Yacine 2015 eqs. (1), (4), (6)) written
   in the course notation. Expected: the paper's own transformed form (13) in the paper's
   symbols (:func:`vehicle_observers.models.lateral.rhs_transformed`, state
   ``x = [v_y, psi_dot, (F_f + F_r)/m, (a_f F_f - a_r F_r)/I_z]``, relaxation length ``r``),
   compared through the change of coordinates at random states of two cars.
2. :func:`check_2` - is ``v_y`` observable from the yaw rate alone through the linear bicycle?
   A derivation (the observability matrix of a 2-state system with ``C = [0 1]``) and a design
   decision (which car needs another sensor). Expected: the rank of python-control's
   observability matrix, for the shipped cars and a neutral-steer one.
3. :func:`check_3` - the steady-state ``v_y`` of the linear bicycle for a held steering angle,
   derived by hand (the 2x2 equilibrium). Expected: python-control's DC gain of the same
   bicycle, at several speeds and two cars.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from vehicle_observers.models import lateral
from vehicle_observers.models.vehicle import load_vehicle
from vehicle_observers.results.teaching import check

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
                 hint=["two of the paper's letters mean something else here: look up psi_dot and "
                       "r_i in the notation table",
                       "the slips (4) use a_f, a_r: the course's l_f, l_r; check the sign of the "
                       "yaw-rate term at each axle",
                       "the relaxation (6) divides by the relaxation length, not by the yaw rate"])


# ------------------------------------------------------------------ exercises 2, 3 -----------

def linear_bicycle(veh, v_x: float) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` of the linear single-track model, state ``[v_y, r]``, input the road-wheel
    angle ``delta`` [rad], at speed ``v_x`` [m/s], with the vehicle file's axle cornering
    stiffnesses ``C_f``, ``C_r`` [N/rad] (course notation; Ifqir 2017 (3) with ``xi`` nominal)."""
    p = veh.params
    cf, cr, lf, lr, m, iz = veh.C_f, veh.C_r, p.a_f, p.a_r, p.m, p.I_z
    A = np.array([[-(cf + cr) / (m * v_x), (cr * lr - cf * lf) / (m * v_x) - v_x],
                  [(cr * lr - cf * lf) / (iz * v_x), -(cr * lr ** 2 + cf * lf ** 2) / (iz * v_x)]])
    B = np.array([[cf / m], [cf * lf / iz]])
    return A, B


def neutral_steer(vehicle: str = "yacine2015"):
    """A shipped car made neutral-steer (rear stiffness set so that ``C_r l_r = C_f l_f``), a
    case the exercises use to tell a derivation from a guess."""
    import dataclasses

    veh = load_vehicle(vehicle)
    p = veh.params
    k = (veh.C_f * p.a_f) / (veh.C_r * p.a_r)
    tr = dataclasses.replace(p.tire_r, D=p.tire_r.D * k)   # cornering stiffness B C D scaled by k
    return dataclasses.replace(veh, params=dataclasses.replace(p, tire_r=tr), name=veh.name + " (neutral)")


def cars_2():
    """The cars of exercise 2: the two shipped vehicle files and a neutral-steer one."""
    return {"yacine2015": load_vehicle("yacine2015"), "revs250lm": load_vehicle("revs250lm"),
            "neutral steer": neutral_steer()}


def expected_2(veh, v_x: float) -> bool:
    """Observability of ``[v_y, r]`` from ``y = r``: rank of ``control.obsv(A, C) == 2``."""
    import control

    A, _ = linear_bicycle(veh, v_x)
    O = control.obsv(A, np.array([[0.0, 1.0]]))
    return bool(np.linalg.matrix_rank(O, tol=1e-9 * np.abs(O).max()) == 2)


def check_2(observable):
    """Exercise 2: ``observable(veh, v_x) -> bool``: can ``v_y`` be reconstructed from the yaw
    rate alone through the linear bicycle at speed ``v_x``? Three cars at 10 m/s."""
    cars = cars_2()

    def answer():
        got = {}
        for name, veh in cars.items():
            g = observable(veh, 10.0)
            if g is None or g is Ellipsis:
                return None
            got[name] = g
        return got

    want = {name: expected_2(veh, 10.0) for name, veh in cars.items()}
    return check("00.2", answer, want,
                 hint=["write the 2x2 observability matrix O = [C; C A] with C = [0 1]: which "
                       "entry of A appears in its first column?",
                       "O is singular exactly when that entry is zero: when is "
                       "C_r l_r - C_f l_f zero?",
                       "compare C_r l_r with C_f l_f for each car (veh.C_r, veh.params.a_r, ...); "
                       "a tolerance relative to their size, not '== 0'"])


#: speeds [m/s] of exercise 3
SPEEDS_3 = (8.0, 17.0, 30.0)


def expected_3(veh, v_x: float) -> float:
    """Steady-state ``v_y`` [m/s] per radian of road-wheel angle: the DC gain of the linear
    bicycle from ``delta`` to ``v_y`` (python-control)."""
    import control

    A, B = linear_bicycle(veh, v_x)
    return float(np.squeeze(control.dcgain(control.ss(A, B, np.array([[1.0, 0.0]]), 0.0))))


def check_3(steady_vy):
    """Exercise 3: ``steady_vy(veh, v_x) -> v_y / delta`` [m/s per rad] of the linear bicycle in
    steady cornering, at three speeds for two cars."""
    cars = {"yacine2015": load_vehicle("yacine2015"), "revs250lm": load_vehicle("revs250lm")}

    def answer():
        got = {}
        for name, veh in cars.items():
            for vx in SPEEDS_3:
                g = steady_vy(veh, vx)
                if g is None or g is Ellipsis:
                    return None
                got[f"{name} at {vx:g} m/s"] = g
        return got

    want = {f"{name} at {vx:g} m/s": expected_3(veh, vx) for name, veh in cars.items()
            for vx in SPEEDS_3}
    return check("00.3", answer, want, rtol=1e-6, unit="m/s per rad",
                 hint=["in steady cornering dv_y/dt = dr/dt = 0: solve A x + B delta = 0 for x",
                       "a 2x2 system: Cramer's rule or np.linalg.solve; v_y is the first entry",
                       "check the sign at high speed: for an understeering car v_y / delta turns "
                       "negative above a speed you can compute from the same formula"])
