"""Exercise checkers of notebook 04 (Ichalal, Arioui, Mammar, MED 2011: autonomous bicycle,
DMVT observer, LMI pole regions).

Each ``check_N(answer, ...)`` calls the student's function on several inputs (so a hard-coded
number fails), computes the expected answer **independently** of the notebook's solution (a
transcription of the model (25) written here, finite differences, eigenvalues) and shows one
line through :func:`vehicle_observers.results.teaching.check` (``show=False``: no display,
the :class:`~vehicle_observers.results.teaching.Outcome` is returned).

1. ``check_1(observability_rank)``: rank of the observability matrix of the bicycle (25)
   linearised at ``(x, u)`` for a sensor matrix ``C`` (Jacobian (31)).
2. ``check_2(xi_bounds)``: bounds (14) of the Jacobian entries ``xi1 = df4/dx2`` [m/s^2] and
   ``xi2 = df4/dx3`` [1/s^2] of (31)-(33) over a box of states (the DMVT points of (11) lie on
   segments inside the box).
3. ``check_3(design_for_settling, vertices, C)``: half-plane shift ``a`` of (35) for a 2 %
   settling time and a certified design whose closed-loop eigenvalues meet it.
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

    def answer():
        got = [observability_rank(np.array(x), u, C) for x, u, C in CASES_1]
        return None if _empty(got) else [int(g) for g in got]

    return check("04.1", answer, [expected_rank(*c) for c in CASES_1],
                 hint="A = bicycle.jacobian(x, u, params)[0] (shape (1, 4, 4) for one state); "
                      "stack C, CA, CA^2, CA^3 and take numpy.linalg.matrix_rank", rtol=0, atol=0, show=show)


#: boxes of exercise 2: ((x2 lo, x2 hi) [1/m], (x3 lo, x3 hi) [rad]); u = 0
CASES_2 = (((-0.2, 0.2), (-1.0, 1.0)), ((0.0, 0.1), (0.2, 0.6)), ((-0.1, 0.05), (-0.3, 0.8)))


def check_2(xi_bounds, show: bool = True):
    """Exercise 04.2: ``xi_bounds(x2_lim, x3_lim)`` -> ``[[xi1 lo, xi1 hi], [xi2 lo, xi2 hi]]``
    over the box (u = 0). Expected: finite-difference Jacobian of the model written here on a
    301 x 301 grid of the box (corners included); relative tolerance 2e-3 (grid resolution)."""
    def expected(x2_lim, x3_lim):
        g2, g3 = np.meshgrid(np.linspace(*x2_lim, 301), np.linspace(*x3_lim, 301))
        X = np.column_stack([np.zeros(g2.size), g2.ravel(), g3.ravel(), np.zeros(g2.size)])
        v = _jacobian_fd(X, 0.0)[:, 3, 1:3]
        return np.column_stack([v.min(0), v.max(0)])

    def answer():
        got = [xi_bounds(*c) for c in CASES_2]
        return None if _empty(got) else np.array(got, dtype=float)

    want = np.array([expected(*c) for c in CASES_2])
    return check("04.2", answer, want, rtol=2e-3, atol=1e-3,
                 hint="evaluate bicycle.jacobian on a fine grid of the box (x1 = x4 = 0, u = 0: "
                      "they do not enter J[3, 1:3]) with the corners included, then min and max "
                      "of J[:, 3, 1] and J[:, 3, 2]", show=show)


#: (T_s [s], R [1/s]) cases of exercise 3
CASES_3 = ((1.5, 10.0), (1.0, 12.0))


def check_3(design_for_settling, vertices, C, show: bool = True):
    """Exercise 04.3: ``design_for_settling(T_s, R)`` -> ``(a, L)``: ``a`` [1/s] the half-plane
    shift of (35) that makes every mode decay to 2 % within ``T_s`` (``exp(-a T_s) = 0.02``),
    ``L`` (4, 2) or (r, 4, 2) a gain designed with (23)+(35)+(36). Expected: ``a = ln(50)/T_s``
    and, from the eigenvalues of ``A_i - L_j C`` computed here for every vertex of
    ``vertices``, ``Re lambda < -a`` and ``|lambda| < R``."""
    vertices = np.asarray(vertices, dtype=float)

    def answer():
        out = {}
        for Ts, R in CASES_3:
            res = design_for_settling(Ts, R)
            if res is None or res is Ellipsis or _empty(res):
                return None
            a, L = res
            Ls = np.asarray(L, dtype=float).reshape(-1, 4, C.shape[0])
            ev = np.array([np.linalg.eigvals(A - Lj @ C) for A in vertices for Lj in Ls])
            out[f"T_s = {Ts:g} s"] = {"a": float(a),
                                      "poles meet T_s": bool(ev.real.max() < -np.log(50) / Ts),
                                      "poles inside |z| < R": bool(np.abs(ev).max() < R)}
        return out

    want = {f"T_s = {Ts:g} s": {"a": np.log(50) / Ts, "poles meet T_s": True,
                                "poles inside |z| < R": True} for Ts, R in CASES_3}
    return check("04.3", answer, want, rtol=1e-3,
                 hint="exp(-a T_s) = 0.02 gives a = ln(50) / T_s; then "
                      "dmvt.design_dmvt_observer(vertices, C, r=1, region=ds.region(a, R)) and "
                      "return (a, design.L)", show=show)
