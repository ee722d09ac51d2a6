import numpy as np
import pytest
from vehicle_observers.models.tires import LinearTire, Pacejka, relaxation_rhs
from vehicle_observers_papers.yacine_2015 import constants as Y


def magic_formula_reference(alpha, B, C, D, E):
    """Pacejka's book form D sin(C atan(B a - E (B a - atan(B a)))), written independently."""
    x = B * alpha
    return D * np.sin(C * np.arctan(x - E * (x - np.arctan(x))))


@pytest.mark.parametrize("E", [0.0, -0.5, 0.3])
def test_force_matches_book_form(E):
    t = Pacejka(B=8.0, C=1.4, D=5000.0, E=E)
    a = np.linspace(-0.4, 0.4, 801)
    np.testing.assert_allclose(t.force(a), magic_formula_reference(a, 8.0, 1.4, 5000.0, E),
                               rtol=1e-13, atol=1e-9)


@pytest.mark.parametrize("E", [0.0, -0.5, 0.3])
def test_secant_stiffness_times_alpha_is_force(E):
    t = Pacejka(B=8.0, C=1.4, D=5000.0, E=E)
    a = np.concatenate([np.linspace(-0.3, 0.3, 601), [1e-12, -1e-9, 1e-6, 3e-5]])
    np.testing.assert_allclose(t.secant_stiffness(a) * a, t.force(a), rtol=1e-12, atol=1e-12)
    # continuous through zero, equal to B C D there
    assert t.secant_stiffness(0.0) == pytest.approx(t.cornering_stiffness, rel=1e-15)
    assert t.secant_stiffness(1e-7) == pytest.approx(t.cornering_stiffness, rel=1e-12)


def test_from_sector_gives_exact_bounds():
    for M_max, M_min in [(Y.M_f1, Y.M_f2), (Y.M_r1, Y.M_r2)]:
        t = Pacejka.from_sector(M_max, M_min, Y.alpha_slip_max)
        lo, hi = t.sector_bounds(Y.alpha_slip_max)
        assert hi == pytest.approx(M_max, rel=1e-12)
        assert lo == pytest.approx(M_min, rel=1e-9)
        # the secant stiffness decreases monotonically with |alpha| on the sector
        a = np.linspace(0, Y.alpha_slip_max, 500)
        assert np.all(np.diff(t.secant_stiffness(a)) < 0)


def test_from_sector_rejects_bad_bounds():
    with pytest.raises(ValueError, match="M_min < M_max"):
        Pacejka.from_sector(3e4, 4e4, 0.1)


def test_linear_tire_and_relaxation():
    t = LinearTire(7e4)
    assert t.force(0.01) == pytest.approx(700.0)
    np.testing.assert_allclose(t.secant_stiffness(np.array([0.1, -0.2])), 7e4)
    # tau dF/dt + F = F_S with tau = r / vx: first-order lag towards F_S
    assert relaxation_rhs(0.0, 1000.0, 20.0, 0.5) == pytest.approx(1000.0 * 20.0 / 0.5)
    assert relaxation_rhs(1000.0, 1000.0, 20.0, 0.5) == 0.0


def test_compiled_kernels_equal_the_tire_methods():
    """The numba kernels used inside the simulation/observer loops equal the numpy methods."""
    from vehicle_observers.models.lateral import magic_formula_kernel, secant_kernel
    from vehicle_observers.models.tires import Pacejka

    tire = Pacejka(B=8.0, C=1.3, D=4000.0, E=-0.5)
    for a in (-0.2, -1e-6, 0.0, 3e-5, 0.05, 0.3):
        assert magic_formula_kernel(a, tire.B, tire.C, tire.D, tire.E) == pytest.approx(
            float(tire.force(a)), rel=1e-13, abs=1e-9)
        assert secant_kernel(a, tire.B, tire.C, tire.D, tire.E) == pytest.approx(
            float(tire.secant_stiffness(a)), rel=1e-13)
    assert secant_kernel(0.1, 5e4, 0.0, 0.0, 0.0) == 5e4  # C = 0 encodes a linear tyre
