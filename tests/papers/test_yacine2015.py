"""Printed constants of Yacine et al. (IEEE TCST 23(2), 2015) and the chosen (not printed)
Pacejka coefficients, checked against the paper's numbers and its sector bounds."""

import numpy as np
import pytest
from vehicle_observers_papers.yacine_2015 import constants as Y


def test_table_I_constants():
    assert (Y.m, Y.I_z, Y.a_f, Y.a_r) == (1500.0, 2454.0, 1.1, 1.44)
    assert Y.l_s == 0.5
    assert Y.r_relax == 0.1                       # r_f = r_r = 0.1 (Table I)
    p = Y.params
    assert (p.m, p.I_z, p.a_f, p.a_r, p.l_s, p.r_f, p.r_r) == (1500.0, 2454.0, 1.1, 1.44, 0.5,
                                                                0.1, 0.1)


def test_section_IV_constants():
    assert (Y.M_f1, Y.M_f2, Y.M_r1, Y.M_r2) == (4.2e4, 3.3e4, 4.9e4, 3.3e4)
    assert (Y.vx_min, Y.vx_max) == (0.2, 17.0)
    assert Y.alpha_decay == 0.001
    assert Y.Ts == 0.001
    assert Y.alpha_slip_max == pytest.approx(np.radians(8.0))   # "not exceeding 8 deg" (II-A)


@pytest.mark.parametrize("tire,M1,M2", [(Y.tire_f, 4.2e4, 3.3e4), (Y.tire_r, 4.9e4, 3.3e4)])
def test_chosen_pacejka_gives_exactly_the_sector_bounds(tire, M1, M2):
    """Secant stiffness f(alpha) = F/alpha (16): f(0) = B C D = M_1 and min over |alpha| <= 8
    deg = f(8 deg) = M_2 (f decreasing in |alpha|), so (17)'s bounds are exactly the paper's."""
    assert tire.cornering_stiffness == pytest.approx(M1, rel=1e-12)
    assert tire.secant_stiffness(0.0) == pytest.approx(M1, rel=1e-12)
    assert tire.secant_stiffness(np.radians(8.0)) == pytest.approx(M2, rel=1e-10)
    a = np.linspace(0, np.radians(8.0), 4001)
    f = tire.secant_stiffness(a)
    assert np.all(np.diff(f) < 0)                                   # monotone on [0, 8 deg]
    np.testing.assert_allclose(tire.secant_stiffness(-a), f)        # even
    fmin, fmax = tire.sector_bounds(np.radians(8.0))
    assert fmin == pytest.approx(M2, rel=1e-9) and fmax == pytest.approx(M1, rel=1e-12)
    # the peak is beyond 8 deg (force still rising at the sector edge): slope > 0 there
    da = 1e-6
    assert tire.force(np.radians(8.0) + da) > tire.force(np.radians(8.0))
    assert (tire.C, tire.E) == (1.3, 0.0)


def test_ts_model_vertices_match_eq_21():
    """Vertex matrices of (24) against the printed entries of (21) computed independently."""
    ts = Y.ts_model()
    m, Iz, af, ar, r = Y.m, Y.I_z, Y.a_f, Y.a_r, Y.r_relax
    assert ts.n_rules == 8
    for (Mr, Mf, vx), A, B in zip(ts.z_vertices, ts.A, ts.B, strict=True):
        A21 = np.array([
            [0, -vx, 1, 0],
            [0, 0, 0, 1],
            [-(Mf + Mr) / (m * r), -(af * Mf - ar * Mr) / (m * r), -vx / r, 0],
            [-(af * Mf - ar * Mr) / (Iz * r), -(af**2 * Mf + ar**2 * Mr) / (Iz * r), 0, -vx / r]])
        np.testing.assert_allclose(A, A21, rtol=1e-14)
        np.testing.assert_allclose(B[:, 0], [0, 0, vx * Mf / (m * r), af * vx * Mf / (Iz * r)],
                                   rtol=1e-14)


def test_shipped_vehicle_file_is_the_papers_car():
    """The library's default car (vehicle file ``yacine2015``) is exactly the paper module's."""
    from vehicle_observers.models.vehicle import load_vehicle
    from vehicle_observers_papers.yacine_2015 import constants as yacine2015

    assert load_vehicle("yacine2015").params == yacine2015.params
