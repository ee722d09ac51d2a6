"""Checkers of the exercises of notebook 05 (Rabhi, Imine, M'Sirdi, Delanne, AVCS 2004).

Each ``check_N`` computes the expected answer on its own route (an event-located ODE solution
with scipy, the library's runs, the observer design's unobservable subspace), calls the
student's functions on more than one input (a hard-coded number fails) and shows one line with
:func:`vehicle_observers.results.teaching.check` (``correct`` / ``not yet`` with a hint /
``not attempted`` while a stub still returns ``None``).

1. reaching time of a first-order sliding observer, eqs. (13), (16): closed form against a
   scipy solution, and the wheel-speed surface of observer (10) with a halved gain;
2. boundary-layer width against a chattering budget (sat mode of (10), noisy measurements);
3. unobservable directions of the wheel states with the outputs (29), with and without one
   suspension-deflection sensor (observability rank).
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.models import fullcar
from vehicle_observers.observers import sliding_mode as smo
from vehicle_observers.results import teaching

from vehicle_observers_papers.rabhi_2004 import constants as R
from vehicle_observers_papers.rabhi_2004 import experiments as EX

#: (e0, lambda, d) of the scalar sliding observers of Exercise 1: e' = -lambda sign(e) + d
REACH_CASES = ((1.0, 4.0, 0.0), (-5.0, 500.0, 0.0), (0.5, 4.0, 1.0), (-0.3, 3.0, 1.0))
#: halved wheel-speed gain of Exercise 1 [rad/s^2]
LAM3_HALF = 250.0
#: boundary-layer multipliers of Exercise 2 and the chattering budget [N]
LAYER_SCALES = (0.3, 1.0, 3.0, 10.0, 30.0)
CHATTER_BUDGET = 25.0
#: sensor sets of Exercise 3: ``None`` = outputs (29) only, ``i`` = plus the deflection of wheel i
SENSOR_SETS = (None, 0, 3)


def _empty(values) -> bool:
    """True if one of ``values`` is ``None`` or ``...`` (a stub not filled in yet)."""
    return any(v is None or v is Ellipsis for v in values)


def scalar_reaching_time(e0: float, lam: float, d: float = 0.0) -> float:
    """Reaching time [s] of ``e' = -lam sign(e) + d`` from ``e(0) = e0`` (``|d| < lam``),
    found by integrating the ODE with scipy until the event ``e = 0`` (no closed form used)."""
    from scipy.integrate import solve_ivp

    if not abs(d) < lam:
        raise ValueError(f"scalar_reaching_time: need |d| < lam, got d = {d}, lam = {lam}")
    s0 = np.sign(e0)

    def hit(t, e):
        return e[0]
    hit.terminal = True
    sol = solve_ivp(lambda t, e: [-lam * s0 + d], (0.0, 10 * abs(e0) / (lam - abs(d)) + 1.0),
                    [e0], events=hit, rtol=1e-10, atol=1e-12)
    return float(sol.t_events[0][0])


def check_1(reaching_time, measured_reaching, man, Xs):
    """Exercise 1. ``reaching_time(e0, lam, d)`` [s] on :data:`REACH_CASES` against
    :func:`scalar_reaching_time`; ``measured_reaching(lam3)`` [s], the reaching time of the
    front wheel-speed surface of the paper's observer (``R.paper_gains`` with both ``lam3``
    entries set) on the notebook's run ``man, Xs``, at 250 and 500 rad/s^2 against the runs
    of :func:`.experiments.part_a_run`."""
    want = {"formula": [scalar_reaching_time(*c) for c in REACH_CASES],
            "observer": [EX.part_a_run(man, Xs, R.paper_gains.with_(lam3=(l3, l3)))["t_reach_omega_f"]
                         for l3 in (LAM3_HALF, 500.0)]}

    def answer():
        f = [reaching_time(*c) for c in REACH_CASES]
        m = [measured_reaching(lam) for lam in (LAM3_HALF, 500.0)]
        return None if _empty(f + m) else {"formula": f, "observer": m}
    return teaching.check("05.1", answer, want, rtol=1e-6, atol=1e-9,
                          hint="while e has the sign of e0 the error moves at the constant rate "
                               "-lam sign(e0) + d; for the observer read 't_reach_omega_f' of "
                               "EX.part_a_run with R.paper_gains.with_(lam3=(lam3, lam3))")


def layer_chattering(man, Xs, scale: float, seed: int = 0) -> tuple[float, float]:
    """(max chattering [N], max force RMSE [% of peak]) of the sat observer with both boundary
    layers times ``scale`` on noisy measurements (``R.sensor_noise``, ``seed``)."""
    g = R.force_gains
    g = g.with_(mode="sat", phi2=tuple(np.array(g.phi2) * scale), phi3=tuple(np.array(g.phi3) * scale))
    o = EX.part_a_run(man, Xs, g, noise=R.sensor_noise, seed=seed)
    return (max(o[f"chatter_{n}"] for n in R.FORCE_NAMES),
            max(o[f"rmse_pct_{n}"] for n in R.FORCE_NAMES))


def check_2(chattering, best_scale, man, Xs):
    """Exercise 2. ``chattering(scale)`` [N] at two layer multipliers, and ``best_scale``, the
    smallest of :data:`LAYER_SCALES` whose chattering is within :data:`CHATTER_BUDGET`,
    against :func:`layer_chattering`."""
    chat = {sc: layer_chattering(man, Xs, sc)[0] for sc in LAYER_SCALES}
    best = min(sc for sc in LAYER_SCALES if chat[sc] <= CHATTER_BUDGET)
    want = {"chattering": [chat[1.0], chat[10.0]], "best": best}

    def answer():
        got = [chattering(1.0), chattering(10.0), best_scale]
        return None if _empty(got) else {"chattering": got[:2], "best": got[2]}
    return teaching.check("05.2", answer, want, rtol=1e-9,
                          hint="run EX.part_a_run with the sat gains, both layers phi2, phi3 times "
                               "the scale, noise=R.sensor_noise, seed=0; chattering is the max over "
                               "the forces of 'chatter_<force>'; then take the smallest scale within "
                               f"{CHATTER_BUDGET:g} N")


def check_3(n_unobservable, lost_wheel_pattern):
    """Exercise 3. ``n_unobservable(deflection_wheel)`` for the sensor sets of
    :data:`SENSOR_SETS` against the unobservable subspace of the observer design
    (:func:`vehicle_observers.observers.sliding_mode.paper_output_design`), and
    ``lost_wheel_pattern()`` (4,) against :func:`vehicle_observers.models.fullcar.warp_vector`
    (compared up to scale and sign: |cos| = 1)."""
    p = R.fullcar
    want = {"n": [smo.paper_output_design(p, w).V.shape[1] for w in SENSOR_SETS], "abs_cos": 1.0}
    w_ref = fullcar.warp_vector(p)

    def answer():
        n, v = [n_unobservable(w) for w in SENSOR_SETS], lost_wheel_pattern()
        if _empty(n + [v]):
            return None
        v = np.asarray(v, dtype=float)
        cos = abs(float(v @ w_ref)) / (np.linalg.norm(v) * np.linalg.norm(w_ref))
        return {"n": n, "abs_cos": cos}
    return teaching.check("05.3", answer, want, rtol=1e-6,
                          hint="with x31 measured, x11' = x21 and x21' = x31: build A = [[0, I], [0, 0]] "
                               "(8 x 8) and the known combination K21 x11 + C21 x21 of the body line "
                               "(29) (plus the deflection row), then 8 - rank of [C; C A]; the lost "
                               "pattern spans the null space of K21")
