"""Checkers of the exercises of notebook 01 (exact TS models by sector nonlinearity).

Each ``check_N(answer)`` computes the expected answer on its own (a closed form or a library
call the solution need not make), calls the student's function on more than one input (so a
hard-coded number fails) and shows one line through
:func:`vehicle_observers.results.teaching.check` (key ``"01.N"``): ``correct``, ``not yet``
with a hint, or ``not attempted`` while the stub still returns ``None`` (``...``).

1. Sector form of the gravity term ``(g/p) sin x3`` of the Ichalal 2011 bicycle (25):
   bounds of ``z1 = (g/p) sin(x3)/x3`` on ``|x3| <= x3_max`` and the two weights.
2. The matrices ``A(z), B(z)`` of the Yacine 2015 TS form (19)-(21), derived from (13) and
   the slip angles (4) with the premise factored out (``F_i^S = f_i alpha_i``).
3. Error of the TS blend with clipped weights outside the sector (Yacine 2015, (14)-(18)).
4. The ``2^p`` vertex matrices of the bicycle TS model (Ichalal 2011, Sec. III-A).
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.models.bicycle import BicycleParams
from vehicle_observers.results import teaching

from . import constants as Y

#: g [m/s^2] and CG height p [m] of the Ichalal 2011 bicycle (inferred, notebook 01 section 6)
G, P = 9.81, 0.6


def _empty(out) -> bool:
    return out is None or out is Ellipsis or (
        isinstance(out, (tuple, list)) and any(o is None or o is Ellipsis for o in out))


# --------------------------------------------------------------------------- exercise 1 ------

def expected_1(x3, x3_max: float, g: float = G, p: float = P) -> dict:
    """Closed form: ``z1 = (g/p) sin(x3)/x3`` is even and decreasing on ``[0, pi]``, so on
    ``|x3| <= x3_max`` (< pi) ``z_min = (g/p) sin(x3_max)/x3_max``, ``z_max = g/p`` (at 0);
    ``h1 = (z_max - z1)/(z_max - z_min)``, ``h2 = 1 - h1``; the blend ``(h1 z_min + h2 z_max)
    x3`` equals ``(g/p) sin x3``."""
    x3 = np.asarray(x3, dtype=float)
    zmin, zmax = g / p * np.sin(x3_max) / x3_max, g / p
    z = np.array([g / p * (np.sin(v) / v if v != 0 else 1.0) for v in x3])
    h1 = (zmax - z) / (zmax - zmin)
    return {"z_min": zmin, "z_max": zmax, "h1": h1, "h2": 1 - h1, "blend": g / p * np.sin(x3)}


#: roll-angle ranges [rad] the checker of exercise 1 tries
X3_MAX_1 = (0.3, 0.8)


def check_1(answer, show: bool = True):
    """``answer(x3, x3_max)`` -> ``(z_min, z_max, h1, h2)`` for a grid ``x3`` [rad] that holds
    0 and ``+-x3_max``; graded on the bounds, the weights and the blend ``(h1 z_min + h2 z_max)
    x3 = (g/p) sin x3`` for the ranges :data:`X3_MAX_1`."""
    want, grids = {}, {}
    for xm in X3_MAX_1:
        grids[xm] = np.linspace(-xm, xm, 41)
        for k, v in expected_1(grids[xm], xm).items():
            want[f"x3_max={xm}: {k}"] = v

    def run():
        got = {}
        for xm, x3 in grids.items():
            out = answer(x3, xm)
            if _empty(out):
                return None
            zmin, zmax, h1, h2 = out
            h1, h2 = np.asarray(h1, dtype=float), np.asarray(h2, dtype=float)
            got.update({f"x3_max={xm}: z_min": zmin, f"x3_max={xm}: z_max": zmax,
                        f"x3_max={xm}: h1": h1, f"x3_max={xm}: h2": h2,
                        f"x3_max={xm}: blend": (h1 * zmin + h2 * zmax) * x3})
        return got

    return teaching.check("01.1", run, want, rtol=1e-9, atol=1e-12, show=show,
                          hint="sin(x3)/x3 -> 1 at x3 = 0 (np.sinc(x3/np.pi) handles it); it is "
                               "largest at 0 and smallest at the ends; h1 weighs z_min")


# --------------------------------------------------------------------------- exercise 2 ------

#: premise points ``(f_r [N/rad], f_f [N/rad], v_x [m/s])`` the checker of exercise 2 tries
Z_2 = ((4.9e4, 4.2e4, 17.0), (3.3e4, 3.3e4, 0.2), (4.1e4, 3.7e4, 9.0))

#: what each row of (13) is, for the hints of exercise 2
_ROWS_2 = ("dx1/dt [m/s^2]", "dx2/dt [rad/s^2]", "dx3/dt [m/s^3]", "dx4/dt [rad/s^3]")


def expected_2(z, p=None) -> tuple[np.ndarray, np.ndarray]:
    """``A(z)`` (4, 4) and ``B(z)`` (4, 1) of (19)-(21), computed without the library's formula:
    the transformed model (13) with the steady forces frozen at ``F_i^S = f_i alpha_i`` (the
    premise factored out, (14)-(16)) and the small-angle slips (4) is linear in ``(x, delta_f)``;
    its columns are its values on the unit vectors."""
    p = Y.params if p is None else p
    fr, ff, vx = z
    sig = p.r_f

    def f13(x, d):
        a_f = d - x[0] / vx - p.a_f * x[1] / vx
        a_r = -x[0] / vx + p.a_r * x[1] / vx
        Ff, Fr = ff * a_f, fr * a_r
        return np.array([-vx * x[1] + x[2], x[3],
                         -vx / sig * x[2] + vx / (p.m * sig) * (Ff + Fr),
                         -vx / sig * x[3] + vx / (p.I_z * sig) * (p.a_f * Ff - p.a_r * Fr)])

    A = np.column_stack([f13(e, 0.0) for e in np.eye(4)])
    return A, f13(np.zeros(4), 1.0)[:, None]


def _diagnose_2(got_A, got_B, z) -> str:
    """Which entry of ``A(z)`` or ``B(z)`` is furthest off, by how much, and the usual cause."""
    A, B = expected_2(z)
    gA, gB = np.asarray(got_A, float), np.asarray(got_B, float).reshape(4, 1)
    worst = max([(abs(gA[i, j] - A[i, j]), f"A[{i},{j}]", gA[i, j], A[i, j], i)
                 for i in range(4) for j in range(4)]
                + [(abs(gB[i, 0] - B[i, 0]), f"B[{i},0]", gB[i, 0], B[i, 0], i) for i in range(4)])
    _, name, g, w, row = worst
    vx = z[2]
    why = ""
    if w != 0 and np.isclose(g, -w):
        why = (" (the sign: a slip angle (4) enters with -v_y/v_x, -l_f r/v_x at the front and +l_r r/v_x "
               "at the rear)")
    elif w != 0 and (np.isclose(g, w * vx) or np.isclose(g, w / vx)):
        why = (" (a factor v_x: the relaxation's v_x/sigma multiplies the slip's 1/v_x, they cancel in every "
               "term but delta_f's)")
    elif w == 0:
        why = " (this entry is zero in (13): the state does not enter that row)"
    return (f"at (f_r, f_f, v_x) = {z}: {name} (row {_ROWS_2[row]}) is {g:.6g}, expected {w:.6g}{why}")


def check_2(answer, show: bool = True):
    """``answer(fr, ff, vx)`` -> ``(A, B)`` with ``A`` (4, 4), ``B`` (4, 1): the matrices of the
    Yacine 2015 TS form at premises ``(f_r, f_f, v_x)``, derived from (13) and (4) for the
    paper's car (``Y.params``). Graded at the three points :data:`Z_2` against
    :func:`expected_2`; the hint names the entry furthest off, its row of (13), the error and
    the usual cause (a sign of a slip term, a factor ``v_x``)."""
    want, got_all = {}, {}
    for z in Z_2:
        A, B = expected_2(z)
        want[f"{z}: A"], want[f"{z}: B"] = A, B

    def run():
        for z in Z_2:
            out = answer(*z)
            if _empty(out):
                return None
            gA, gB = out
            got_all[z] = (np.asarray(gA, float), np.asarray(gB, float).reshape(-1, 1))
        return {k: got_all[z][i] for z in Z_2 for i, k in enumerate((f"{z}: A", f"{z}: B"))}

    hint = ("derive each row of (13) with F_i^S = f_i alpha_i and the slips (4); collect the "
            "coefficients of x1..x4 (A) and of delta_f (B)")
    probe = None
    try:
        probe = run()
    except Exception:   # the student's code: reported by teaching.check below
        probe = None
    if probe is not None:
        for z, (gA, gB) in got_all.items():
            if gA.shape != (4, 4) or gB.shape != (4, 1):
                hint = f"A must be (4, 4) and B (4, 1); got {gA.shape} and {gB.shape}"
                break
            A, B = expected_2(z)
            if not (np.allclose(gA, A, rtol=1e-9, atol=1e-9) and np.allclose(gB, B, rtol=1e-9, atol=1e-9)):
                hint = _diagnose_2(gA, gB, z)
                break
    return teaching.check("01.2", run, want, rtol=1e-9, atol=1e-9, show=show, hint=hint)


# --------------------------------------------------------------------------- exercise 3 ------

def expected_3(alpha_deg) -> np.ndarray:
    """Closed form: inside ``|alpha| <= 8 deg`` (the slip range of the sector) the blend is
    exact, error 0; outside it the clipped front weights give ``h1 = 1`` (``f`` below
    ``M_f2``), so the blend is ``M_f2 alpha`` and its relative error is
    ``(M_f2 alpha - F(alpha)) / F(alpha)``, ``F = D sin(C atan(B alpha))`` (E = 0)."""
    t = Y.tire_f
    a = np.radians(np.asarray(alpha_deg, dtype=float))
    F = t.D * np.sin(t.C * np.arctan(t.B * a))
    return np.where(np.abs(a) <= Y.alpha_slip_max, 0.0, (Y.M_f2 * a - F) / F)


#: slips [deg] the checker of exercise 3 tries (the first inside the sector: error 0)
ALPHA_3 = (6.0, 9.0, 10.0, 12.0)


def check_3(answer, show: bool = True):
    """``answer(alpha_deg)`` -> relative error ``(F_TS - F^S)/F^S`` of the front-tyre blend with
    clipped weights at one slip [deg]; graded at :data:`ALPHA_3`."""
    want = {f"{a:g} deg": float(expected_3(a)) for a in ALPHA_3}

    def run():
        got = {}
        for a in ALPHA_3:
            out = answer(a)
            if _empty([out]):
                return None
            got[f"{a:g} deg"] = out
        return got

    return teaching.check("01.3", run, want, rtol=1e-4, atol=1e-9, show=show,
                          hint="clip f(alpha) to [M_f2, M_f1] before computing the weights; the "
                               "blend is (h1 M_f2 + h2 M_f1) alpha, compared with tire_f.force(alpha)")


# --------------------------------------------------------------------------- exercise 4 ------

def expected_4(bounds, v: float):
    """Vertex matrices through the library's :func:`vehicle_observers.models.bicycle.bicycle_ts`
    (premises ``(z1, z2, z3)``; vertex ``i`` takes ``z_max`` of premise ``j`` when bit ``j`` of
    ``i``, most significant first, is 0): ``A`` (8, 4, 4), ``B`` (8, 4, 1)."""
    from vehicle_observers.models import bicycle

    ts = bicycle.bicycle_ts(BicycleParams(v=v), bounds)
    return ts.A, ts.B


#: (premise bounds, speed v [m/s]) the checker of exercise 4 tries
CASES_4 = (([(14.0, 16.35), (90.0, 170.0), (7.0, 8.33)], 10.0),
           ([(12.0, 16.35), (20.0, 60.0), (3.5, 4.2)], 5.0))


def check_4(answer, show: bool = True):
    """``answer(bounds, v)`` -> ``(A, B)``, the ``2^3`` vertex matrices of the bicycle TS model
    (``A`` (8, 4, 4), ``B`` (8, 4, 1)) in the order of ``itertools.product((max, min),
    repeat=3)``; graded against the library for the boxes of :data:`CASES_4`."""
    want = {}
    for n, (bounds, v) in enumerate(CASES_4):
        A, B = expected_4(bounds, v)
        want[f"case {n + 1}: A"], want[f"case {n + 1}: B"] = A, B

    def run():
        got = {}
        for n, (bounds, v) in enumerate(CASES_4):
            out = answer(bounds, v)
            if _empty(out):
                return None
            got[f"case {n + 1}: A"], got[f"case {n + 1}: B"] = out
        return got

    return teaching.check("01.4", run, want, rtol=1e-12, atol=1e-12, show=show,
                          hint="2^3 = 8 vertices; vertex i takes z_max of premise j when bit j of "
                               "i (most significant first) is 0: itertools.product((hi, lo), ...); "
                               "A(z) = [[0,v,0,0],[0,0,0,0],[0,0,0,1],[0,z2,z1,0]], B(z) = [0,1,0,z3]")
