"""Ifqir 2017: the observer AS PRINTED (printed L on the printed bands), checked against the
printed numbers, hand-written model entries and a truth integrated independently by scipy."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from vehicle_observers.observers import interval as iv
from vehicle_observers_papers.ifqir_2017 import constants as IF
from vehicle_observers_papers.ifqir_2017 import printed_observer as po

VEH = IF.vehicle


def _A_lo(s, v):
    """Entry-by-entry lower bound of A(rho, xi) (3)-(4) over the box at 1/v_x = s, v_x = v,
    written from the model equations (not from the library's vertex arrays)."""
    (crl, crh), (cfl, cfh) = VEH.xi_box
    m, Iz, lf, lr = VEH.m, VEH.I_z, VEH.l_f, VEH.l_r
    return np.array([[-(cfh + crh) / m * s, (crl * lr - cfh * lf) / m * s - v],
                     [(crl * lr - cfh * lf) / Iz * s, -(crh * lr**2 + cfh * lf**2) / Iz * s]])


def _vertices(i):
    """Premise vertices (1/v_x, v_x) of printed band i in the chosen order: v_x the fast
    index, 1/v_x at its lower bound 1/v_max at vertices 1-2 (IF.inv_vx_upper_first False)."""
    lo, hi = po.BANDS_PRINTED.edges[i], po.BANDS_PRINTED.edges[i + 1]
    s1, s2 = (1 / hi, 1 / lo) if not IF.inv_vx_upper_first else (1 / lo, 1 / hi)
    return [(s1, hi), (s1, lo), (s2, hi), (s2, lo)]


def test_printed_gains_metzler_entry_by_entry():
    """Every off-diagonal entry of A^- - L C with the printed L at its printed vertex is >= 0,
    with A^- written by hand. Catches a flipped sign of L1 (entry (1,2) = A^-_12 - L1 turns
    negative in modes 2-3), a wrong vertex order or polarity, and bands that are not the
    printed ones (the printed design uses the library's arrays; they must agree)."""
    des = po.printed_design()
    C = np.array([[0.0, 1.0]])
    for i in range(3):
        for j, (s, v) in enumerate(_vertices(i)):
            M = _A_lo(s, v) - IF.L_printed[i, j][:, None] @ C
            assert M[0, 1] >= 0 and M[1, 0] >= 0, (i, j, M)
            np.testing.assert_allclose(des.model.A_lo[i, j], _A_lo(s, v), rtol=1e-12)
            flipped = _A_lo(s, v) - (IF.L_printed[i, j] * [-1, 1])[:, None] @ C
            if i > 0:
                assert flipped[0, 1] < 0
    np.testing.assert_allclose(des.L[..., 0], IF.L_printed)
    assert des.min_metzler_margin >= 0


def test_vertex_assignments_four_of_24_in_modes_2_3():
    """Of the 24 ways to assign the printed gains of a mode to its vertices, count those with
    A^- - L C Metzler, by hand: 24 in mode 1 (its A^-_12 is large), exactly 4 in modes 2 and
    3, the identity among them. Catches a library count that disagrees with the hand matrices
    (e.g. permuting the vertices instead of the gains)."""
    rows = po.vertex_assignments()
    C = np.array([[0.0, 1.0]])
    for i in range(3):
        V = _vertices(i)
        ok = []
        for p in itertools.permutations(range(4)):
            Ms = [_A_lo(*V[j]) - IF.L_printed[i, p[j]][:, None] @ C for j in range(4)]
            ok.append(min(min(M[0, 1], M[1, 0]) for M in Ms) >= 0)
        lib = [r["metzler"] for r in rows if r["mode"] == i + 1]
        assert lib == ok
        assert sum(ok) == (24, 4, 4)[i]
        assert ok[0]                              # identity (1, 2, 3, 4)


def test_a21_entry_is_a_model_property():
    """Entry (2,1) of A^- - L C is (c_r^- l_r - c_f^+ l_f) / (I_z v_max) for every L: 0.2685
    1/s at 17.5 m/s, 0.2831 1/s at 16.6 m/s. Catches a report of this entry as a property of
    the gains, and a wrong corner of the stiffness box."""
    assert po.a21_entry(VEH, 17.5) == pytest.approx(0.2685, abs=5e-5)
    assert po.a21_entry(VEH, 16.6) == pytest.approx(0.2831, abs=5e-5)
    m = po.printed_model()
    rng = np.random.default_rng(0)
    L = rng.normal(0, 1000, (3, 4, 2, 1))
    assert (m.A_lo - L @ m.C)[..., 1, 0].min() == pytest.approx(po.a21_entry(VEH, 16.6))


def test_printed_epsilon_and_substeps():
    """The (20) shift the printed gains need, max over the mode-1 vertices of L2 +
    (c_r^+ l_r^2 + c_f^+ l_f^2) / (I_z) * (1/v_x), computed by hand: 4393.35 1/s (the printed
    L2 = 4383 at vertices 1-2), hence 5 Euler steps per 1 ms sample. Catches a wrong polarity
    of 1/v_x (5004 1/s) and a substep count that breaks discrete positivity."""
    des = po.printed_design()
    (_, crh), (_, cfh) = VEH.xi_box
    d22 = lambda s: -(crh * VEH.l_r**2 + cfh * VEH.l_f**2) / VEH.I_z * s
    by_hand = max(-(d22(s) - IF.L_printed[0, j, 1]) for j, (s, _) in enumerate(_vertices(0)))
    assert des.epsilon_shift == pytest.approx(by_hand, rel=1e-12)
    assert des.epsilon_shift == pytest.approx(4393.35, abs=0.01)
    assert iv.euler_substeps(des, IF.Ts) == 5


def test_iss19_standard_reading_feasible_literal_not():
    """(18)-(19) with the printed P, W = P L: the standard reading phi (P + M) is feasible in
    every mode (certified margin > 0), the literal reading phi P + M is infeasible in mode 1.
    Catches the two readings swapped in the LMI code."""
    std = po.iss19_margins()
    lit = po.iss19_margins(literal=True)
    assert np.all(std > 0)
    assert lit[0] < 0 and np.all(lit[1:] > 0)


def test_printed_observer_encloses_an_independent_truth():
    """The printed observer (Euler at the step its epsilon needs) encloses a truth integrated
    by scipy's RK45 (rtol 1e-10) of the LPV bicycle written here, at a fixed stiffness inside
    the box, through all three printed bands (speed 3 -> 15 m/s); the yaw rate measured at
    the observer's steps; the final v_y width is below 0.1 m/s, and with L2 sign-flipped it is
    not (the width diverges). Catches a wrong observer form (11) or a model that is not the
    paper's (3)-(4) (the truth leaves the interval), and a flipped sign of L2. (A flipped L1
    need not show on one trajectory: Metzler is sufficient, not necessary; the entry-by-entry
    test catches it.)"""
    crc, cfc = VEH.xi_box.mean(axis=1) * [1.04, 0.97]    # a point inside the box
    m, Iz, lf, lr = VEH.m, VEH.I_z, VEH.l_f, VEH.l_r
    T, h = 12.0, IF.Ts / 5
    vx = lambda t: 3.0 + 12.0 * t / T
    delta = lambda t: 0.03 * np.sin(2 * np.pi * 0.4 * t)

    def f(t, x):
        v = vx(t)
        A = np.array([[-(cfc + crc) / (m * v), (crc * lr - cfc * lf) / (m * v) - v],
                      [(crc * lr - cfc * lf) / (Iz * v), -(crc * lr**2 + cfc * lf**2) / (Iz * v)]])
        return A @ x + np.array([cfc / m, cfc * lf / Iz]) * delta(t)

    t = np.arange(0.0, T, h)
    sol = solve_ivp(f, (0.0, t[-1]), [0.05, 0.0], t_eval=t, rtol=1e-10, atol=1e-12)
    X = sol.y.T
    # inputs held over each step at their left value, as the observer sees them
    V, D = vx(t), delta(t)
    box = ([-0.2, -0.05], [0.3, 0.05])
    des = po.printed_design()
    res = iv.run_interval_observer(des, h, V, D, D, X[:, 1], *box, substeps=1)
    assert np.all(res.x_lo <= X) and np.all(X <= res.x_hi)
    assert res.width[-1, 0] < 0.1                          # and it is informative
    bad = po.printed_design()
    bad.L[..., 1, 0] *= -1                                 # L2 with the wrong sign
    with np.errstate(over="ignore", invalid="ignore"):     # the diverging run overflows
        res_bad = iv.run_interval_observer(bad, h, V, D, D, X[:, 1], *box, substeps=1)
        assert not res_bad.width[-1, 0] < 0.1              # (NaN or huge: not informative)
