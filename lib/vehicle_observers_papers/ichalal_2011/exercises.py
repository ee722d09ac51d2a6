"""Exercise checkers of lesson 04 (Ichalal, Arioui, Mammar, MED 2011: autonomous bicycle,
DMVT observer, LMI pole regions).

Each ``check_N(answer, ...)`` calls the student's function on several inputs (so a hard-coded
number fails), computes the expected answer **independently** of the solutions notebook (a
transcription of the model (25) written here, finite differences, eigenvalues, root finding)
and shows one line through :func:`vehicle_observers.results.teaching.check`. Hints diagnose
(which case or output is wrong, by how much, in its unit); they never give the code.

1. ``check_1(observability_rank)``: rank of the observability matrix of the bicycle (25)
   linearised at ``(x, u)`` for a sensor matrix ``C`` (Jacobian (31)).
2. ``check_2(dmvt_point)``: the mean-value point of (11) on the segment ``[xhat, x]`` for the
   roll-acceleration row ``f4`` and whether its Jacobian entries lie inside the bounds (14).
3. ``check_3(design, vertices, C)``: a pole region (35)-(36) and a certified gain meeting a
   2 % settling time and a damping specification.
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.results.teaching import check

from vehicle_observers_papers.ichalal_2011 import constants as ic


def _f(x, u, bp=ic.params):
    """The bicycle (25) written out here (independent of :mod:`vehicle_observers.models.bicycle`):
    x1' = v x2, x2' = u, x3' = x4, x4' = (g sin x3 + (1 + p x2 sin x3) cos x3 x2 v^2
    + c cos x3 v u) / p."""
    x1, x2, x3, x4 = np.moveaxis(np.asarray(x, dtype=float), -1, 0)
    p, c, v, g = bp.p, bp.c, bp.v, bp.g
    u = np.broadcast_to(u, np.shape(x2))
    return np.stack([v * x2, u, x4, (g * np.sin(x3) + (1 + p * x2 * np.sin(x3)) * np.cos(x3)
                                     * x2 * v**2 + c * np.cos(x3) * v * u) / p], axis=-1)


def _jacobian_fd(x, u, h: float = 1e-6) -> np.ndarray:
    """Central finite differences of :func:`_f` in x: (4, 4) for x (4,), (N, 4, 4) for
    x (N, 4)."""
    x = np.asarray(x, dtype=float)
    cols = []
    for k in range(4):
        d = np.zeros(4)
        d[k] = h
        cols.append((_f(x + d, u) - _f(x - d, u)) / (2 * h))
    return np.stack(cols, axis=-1)


def _empty(values) -> bool:
    return any(v is None or v is Ellipsis for v in values)


#: (x, u, C) cases of exercise 1: both sensors, roll only, yaw only, roll only at x3 = pi/2
CASES_1 = (
    ((0.0, 0.0, 0.0, 0.0), 0.0, ic.C),
    ((0.0, 0.0, 0.0, 0.0), 0.0, np.array([[0.0, 0, 1, 0]])),
    ((0.0, 0.0, 0.0, 0.0), 0.0, np.array([[1.0, 0, 0, 0]])),
    ((0.3, 0.05, np.pi / 2, 0.2), 1.0, np.array([[0.0, 0, 1, 0]])),
    ((0.3, 0.05, np.pi / 2, 0.2), 1.0, ic.C),
)


def check_1(observability_rank, show: bool = True):
    """Exercise 04.1: ``observability_rank(x, u, C)`` -> rank of ``[C; CA; CA^2; CA^3]`` with
    ``A = df/dx (x, u)`` of (25). Expected: finite-difference Jacobian of the model written here,
    rank by singular values relative to the largest (tolerance 1e-8)."""
    def expected_rank(x, u, C):
        A = _jacobian_fd(x, u)
        O = np.vstack([C @ np.linalg.matrix_power(A, k) for k in range(4)])
        s = np.linalg.svd(O, compute_uv=False)
        return int(np.sum(s > 1e-8 * s[0]))

    want = [expected_rank(*c) for c in CASES_1]
    names = ("both sensors at x = 0", "roll only at x = 0", "yaw only at x = 0",
             "roll only at x3 = pi/2", "both sensors at x3 = pi/2")

    def answer():
        got = [observability_rank(np.array(x), u, C) for x, u, C in CASES_1]
        return None if _empty(got) else [int(g) for g in got]

    try:
        got = answer()
    except Exception:  # the checker reports the exception itself
        got = None
    hint = "the rank is an integer between 0 and 4 (number of observable directions)"
    if got is not None and len(got) == len(want):
        bad = [f"{n}: got {g}, expected {w}" for n, g, w in zip(names, got, want) if g != w]
        if bad:
            hint = ("wrong case(s): " + "; ".join(bad) + ". Check that A is the Jacobian at the "
                    "given (x, u) and that the stacked matrix has 4 blocks C A^k, k = 0..3")
    return check("04.1", answer, want, hint=hint, rtol=0, atol=0, show=show)


def _f4(x, u):
    return _f(x, u)[..., 3]


def _grad_f4(x, u, h: float = 1e-6) -> np.ndarray:
    return _jacobian_fd(x, u, h)[..., 3, :]


#: (x, xhat, u) cases of exercise 2: a small error while the bicycle leans against its
#: curvature (x2, x3 of opposite signs), an error at the start of a run (x = 0 side), and a
#: rolled estimate far from the state
CASES_2 = (((0.0, -0.1, 0.3, 0.0), (0.0, -0.09, 0.31, 0.1), 0.0),
           ((0.0004, 0.043, 0.002, 0.19), (0.099, -0.05, 0.081, 0.62), 9.2),
           ((0.0, 0.08, 0.4, 0.5), (0.0, -0.12, 1.2, -0.5), 0.0))
#: the trajectory bounds (14) of the lesson's run: xi1 [m/s^2], xi2 [1/s^2] (both rows)
XI_BOUNDS_2 = ((71.9, 167.1), (16.35, 33.4))


def check_2(dmvt_point, show: bool = True):
    """Exercise 04.2: ``dmvt_point(x, xhat, u)`` -> ``(s, inside)``: ``s`` in [0, 1] with
    ``f4(x) - f4(xhat) = grad f4(xi) . (x - xhat)`` at ``xi = xhat + s (x - xhat)`` (the
    mean value theorem of (11) for the row ``f4``), and ``inside`` whether ``xi1``, ``xi2`` of
    (32)-(33) at ``xi`` lie inside :data:`XI_BOUNDS_2`. Checked here: the mean-value equation
    at the student's ``s`` (residual below 1e-6 of ``|f4(x) - f4(xhat)|`` + 1e-9), with the
    model and a finite-difference gradient written here, and ``inside`` at that point."""
    rows = []

    def answer():
        rows.clear()
        out = {}
        for n, (x, xh, u) in enumerate(CASES_2, start=1):
            res = dmvt_point(np.array(x), np.array(xh), u)
            if res is None or res is Ellipsis or _empty(res):
                return None
            s_, inside = res
            x, xh = np.array(x), np.array(xh)
            xi = xh + float(s_) * (x - xh)
            df = _f4(x, u) - _f4(xh, u)
            resid = abs(df - _grad_f4(xi, u) @ (x - xh)) / (abs(df) + 1e-9)
            J = _jacobian_fd(xi, u)[3, 1:3]
            want_in = bool(np.all([(lo <= j <= hi) for j, (lo, hi) in zip(J, XI_BOUNDS_2)]))
            rows.append((float(s_), resid, J, want_in, bool(inside)))
            out[f"case {n}"] = {"s in [0, 1]": bool(0.0 <= float(s_) <= 1.0),
                                "mean-value equation holds": bool(resid < 1e-6),
                                "inside judged right": bool(inside) == want_in}
        return out

    want = {f"case {n}": {"s in [0, 1]": True, "mean-value equation holds": True,
                          "inside judged right": True} for n in range(1, len(CASES_2) + 1)}
    try:
        answer()
    except Exception:
        rows.clear()
    hint = "return (s, inside): s a number in [0, 1], inside a bool"
    for k, (s_, resid, J, want_in, got_in) in enumerate(rows):
        if not 0.0 <= s_ <= 1.0:
            hint = f"case {k + 1}: s = {s_:.3g} is off the segment [xhat, x] (s must be in [0, 1])"
            break
        if resid >= 1e-6:
            hint = (f"case {k + 1}: at s = {s_:.4g} the two sides of the mean-value equation "
                    f"differ by {100 * resid:.2g} % of f4(x) - f4(xhat); look for the s where "
                    "their difference changes sign")
            break
        if want_in != got_in:
            hint = (f"case {k + 1}: at your s, xi1 = {J[0]:.1f} m/s^2 and xi2 = {J[1]:.2f} "
                    f"1/s^2, so inside should be {want_in}")
            break
    return check("04.2", answer, want, hint=hint, show=show)


#: specification of exercise 3: 2 % settling time [s] of the slowest mode, smallest damping
SPEC_3 = (1.2, 0.45)


def check_3(design, vertices, C, show: bool = True):
    """Exercise 04.3: ``design()`` -> ``(lam, R, L)``: a region (35)-(36) (``Re z < -lam``,
    ``|z| < R`` [1/s]) and a gain ``L`` (4, 2) or (r, 4, 2) designed with it, such that every
    vertex pair ``A_i - L_j C`` has its eigenvalues settling to 2 % within ``SPEC_3[0]`` s
    (``Re < -ln(50)/T_s``) and damping at least ``SPEC_3[1]``. Checked here from the
    eigenvalues of every vertex pair (computed here), not from the student's lam and R."""
    vertices = np.asarray(vertices, dtype=float)
    Ts, zeta = SPEC_3
    info = {}

    def answer():
        res = design()
        if res is None or res is Ellipsis or _empty(res):
            return None
        lam, R, L = res
        Ls = np.asarray(L, dtype=float).reshape(-1, 4, C.shape[0])
        ev = np.array([np.linalg.eigvals(A - Lj @ C) for A in vertices for Lj in Ls]).ravel()
        info.update(slow=-ev.real.max(), damp=float(np.min(-ev.real / np.abs(ev))),
                    lam=float(lam), R=float(R))
        return {"settles within T_s": bool(-ev.real.max() > np.log(50) / Ts),
                "damping >= spec": bool(info["damp"] >= zeta),
                "region guarantees the spec": bool(lam >= np.log(50) / Ts and lam / R >= zeta)}

    want = {"settles within T_s": True, "damping >= spec": True,
            "region guarantees the spec": True}
    try:
        answer()
    except Exception:
        info.clear()
    hint = "return (lam, R, L) with L the gain of a design certified with your region"
    if info:
        if info["slow"] <= np.log(50) / Ts:
            hint = (f"the slowest eigenvalue has Re = {-info['slow']:.2f} 1/s: it settles to 2 % "
                    f"in {np.log(50) / info['slow']:.2f} s > {Ts:g} s")
        elif info["damp"] < zeta:
            hint = f"the smallest damping of the vertex pairs is {info['damp']:.2f} < {zeta:g}"
        elif not (info["lam"] >= np.log(50) / Ts and info["lam"] / info["R"] >= zeta):
            hint = (f"these poles meet the specification, but the region lam = {info['lam']:g}, "
                    f"R = {info['R']:g} 1/s does not guarantee it: which lam and lam / R does "
                    "the specification need?")
    return check("04.3", answer, want, hint=hint, show=show)
