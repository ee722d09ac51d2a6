"""Checkers of the exercises of lesson 05 (Rabhi, Imine, M'Sirdi, Delanne, AVCS 2004).

Each ``check_N`` computes the expected answer on its own route (the library's runs, an
independent Lyapunov derivative, the observer design's unobservable subspace), calls the
student's functions on more than one input (a hard-coded number fails) and shows one line with
:func:`vehicle_observers.results.teaching.check` (``correct`` / ``not yet`` with a hint that
says which output is wrong and by how much / ``not attempted`` while a stub is empty).

1. the wheel-speed switching gains of (10) that guarantee reaching the surface (16) within a
   deadline against the worst force error (a design from the reaching condition);
2. boundary-layer width against a chattering budget (sat mode of (10), noisy measurements);
3. the sign of the adaptation law (20)-(22) that cancels the cross term of ``V4'``;
4. unobservable directions of the wheel states with the outputs (29), with and without one
   suspension-deflection sensor (observability rank).
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.models import fullcar
from vehicle_observers.observers import sliding_mode as smo
from vehicle_observers.results import teaching

from vehicle_observers_papers.rabhi_2004 import constants as R
from vehicle_observers_papers.rabhi_2004 import experiments as EX

#: reaching deadlines of Exercise 1 [s]
DEADLINES = (0.02, 0.05)
#: boundary-layer multipliers of Exercise 2 and the chattering budget [N]
LAYER_SCALES = (0.3, 1.0, 3.0, 10.0, 30.0)
CHATTER_BUDGET = 25.0
#: sensor sets of Exercise 3: ``None`` = outputs (29) only, ``i`` = plus the deflection of wheel i
SENSOR_SETS = (None, 0, 3)


def _empty(values) -> bool:
    """True if one of ``values`` is ``None`` or ``...`` (a stub not filled in yet)."""
    return any(v is None or v is Ellipsis for v in values)


def lam3_required(Xs, t_r: float, p=R.planar) -> np.ndarray:
    """Smallest wheel-speed gains (2,) [rad/s^2] that guarantee reaching ``x~3 = 0`` within
    ``t_r`` [s] from ``|x~3(0)| = R.x3_err0``: ``|e|' <= -(lam - |d|)`` with the disturbance
    ``d = -(r_i/J_i) F~x_i`` of (16), and the force error bounded by the largest longitudinal
    force of the run ``Xs`` (the force estimate starts at zero)."""
    Fmax = np.abs(np.asarray(Xs)[:, 8:10]).max(axis=0)
    return np.asarray(R.x3_err0) / t_r + np.array([p.r_f / p.J_f, p.r_r / p.J_r]) * Fmax


def check_1(lam3_for, man, Xs):
    """Exercise 1. ``lam3_for(t_r)`` -> ``(lam_f, lam_r)`` [rad/s^2] at :data:`DEADLINES`
    against :func:`lam3_required`; the observer run with the student's gains
    (:func:`.experiments.part_a_run`) must also reach the front surface within ``t_r``."""
    want = {f"t_r = {tr:g} s": {"gains": lam3_required(Xs, tr), "reached in time": True}
            for tr in DEADLINES}
    got_ = {}

    def answer():
        out = {}
        for tr in DEADLINES:
            lam = lam3_for(tr)
            if _empty([lam]) or _empty(list(np.atleast_1d(lam))):
                return None
            lam = np.asarray(lam, dtype=float).reshape(2)
            run = EX.part_a_run(man, Xs, R.paper_gains.with_(lam3=tuple(lam)))
            got_[tr] = (lam, run["t_reach_omega_f"], run["t_reach_omega_r"])
            out[f"t_r = {tr:g} s"] = {"gains": lam, "reached in time": bool(
                max(run["t_reach_omega_f"], run["t_reach_omega_r"]) <= tr)}
        return out

    try:
        answer()
    except Exception:
        got_.clear()
    hint = "return the two gains (front, rear) in rad/s^2"
    for tr, (lam, _tf, _trr) in got_.items():
        need = lam3_required(Xs, tr)
        for w, name in enumerate(("front", "rear")):
            if not np.isclose(lam[w], need[w], rtol=1e-3):
                hint = (f"t_r = {tr:g} s, {name} wheel: your gain is {lam[w]:.4g} rad/s^2, "
                        f"{abs(lam[w] - need[w]):.3g} rad/s^2 {'below' if lam[w] < need[w] else 'above'} "
                        "the smallest gain that guarantees the deadline against the worst force "
                        "error (the force estimate starts at zero)")
                break
        else:
            continue
        break
    return teaching.check("05.1", answer, want, rtol=1e-3, hint=hint)


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

    hint = f"chattering in N (the worst of the four forces), best one of {LAYER_SCALES}"
    try:
        got = [chattering(1.0), chattering(10.0)]
        for sc, g_ in zip((1.0, 10.0), got, strict=True):
            if g_ is not None and g_ is not Ellipsis and not np.isclose(g_, chat[sc], rtol=1e-9):
                hint = (f"chattering at layer x{sc:g}: got {float(g_):.4g} N, expected "
                        f"{chat[sc]:.4g} N (noisy data, seed 0, both layers scaled, worst force)")
                break
        else:
            if best_scale is not None and best_scale is not Ellipsis and best_scale != best:
                hint = (f"best = {best_scale}: its chattering is "
                        f"{chat.get(best_scale, float('nan')):.4g} N; the budget is "
                        f"{CHATTER_BUDGET:g} N and the smallest layer within it is wanted")
    except Exception:
        pass
    return teaching.check("05.2", answer, want, rtol=1e-9, hint=hint)


#: cases of Exercise 3 (seeded): regressors Psi (4, 8), force errors x~4 (4,) [N],
#: parameter errors theta~ (8,), adaptation gains P (8,) > 0
def _adaptation_cases(n: int = 3, seed: int = 5):
    rng = np.random.default_rng(seed)
    return [(rng.normal(size=(4, 8)) * 100.0, rng.normal(size=4) * 50.0,
             rng.normal(size=8) * 0.1, rng.uniform(1.0, 10.0, size=8)) for _ in range(n)]


def lyapunov_excess(theta_hat_dot, Psi, e4, th_err, P) -> float:
    """``V4' + x~4' A x~4`` for ``V4 = x~4'x~4/2 + theta~' P^-1 theta~/2`` along
    ``x~4' = -A x~4 + Psi theta~`` (``theta~ = theta - theta^``, ``theta`` constant, so
    ``theta~' = -theta^'``) with the adaptation ``theta^' = theta_hat_dot(Psi, e4, P)``:
    ``e4' Psi theta~ - theta~' P^-1 theta^'``, zero when the law cancels the cross term."""
    th_dot = np.asarray(theta_hat_dot(Psi, e4, P), dtype=float).reshape(8)
    return float(e4 @ Psi @ th_err - th_err @ (th_dot / P))


def check_3(theta_hat_dot):
    """Exercise 3. ``theta_hat_dot(Psi, x4_err, P)`` -> ``theta^'`` (8,): the excess
    :func:`lyapunov_excess` must vanish (relative to ``|e4' Psi theta~|``) on seeded cases."""
    cases = _adaptation_cases()
    info = []

    def answer():
        info.clear()
        out = {}
        for k, (Psi, e4, th, P) in enumerate(cases, start=1):
            got = theta_hat_dot(Psi, e4, P)
            if got is None or got is Ellipsis:
                return None
            ex_ = lyapunov_excess(theta_hat_dot, Psi, e4, th, P)
            cross = float(e4 @ Psi @ th)
            info.append((k, ex_ / cross))
            out[f"case {k}"] = bool(abs(ex_) <= 1e-9 * abs(cross))
        return out

    want = {f"case {k}": True for k in range(1, len(cases) + 1)}
    try:
        answer()
    except Exception:
        info.clear()
    hint = "return theta^' as 8 numbers"
    for k, r in info:
        if abs(r) > 1e-9:
            what = ("the cross term is doubled, not cancelled: the sign of your law is flipped"
                    if abs(r - 2) < 1e-6 else "the cross term is not cancelled")
            hint = (f"case {k}: V4' + x~4' A x~4 = {r:.3g} times x~4' Psi theta~ (it must be 0 "
                    f"for every theta~): {what}")
            break
    return teaching.check("05.3", answer, want, hint=hint)


def check_4(n_unobservable, lost_wheel_pattern):
    """Exercise 4. ``n_unobservable(deflection_wheel)`` for the sensor sets of
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
        return {"n": [int(x) for x in n], "abs_cos": cos}

    hint = "(a) whole numbers of directions (0 to 8), (b) a pattern of 4 wheel heights"
    try:
        got = answer()
        if got is not None:
            names = ("outputs (29) only", "plus the deflection of wheel 0",
                     "plus the deflection of wheel 3")
            bad = [f"{nm}: got {g}, expected {w}" for nm, g, w in zip(names, got["n"], want["n"])
                   if g != w]
            if bad:
                hint = "(a) " + "; ".join(bad)
            elif got["abs_cos"] < 1 - 1e-6:
                hint = (f"(b) your pattern is at {np.degrees(np.arccos(min(got['abs_cos'], 1))):.1f} "
                        "deg from the lost one: it must load no spring force or moment on the body")
    except Exception:
        pass
    return teaching.check("05.4", answer, want, rtol=1e-6, hint=hint)
