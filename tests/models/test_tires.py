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


def test_compiled_formula_equals_the_numpy_twins():
    """The one compiled tyre formula (every kernel calls it) equals Pacejka.force and
    Pacejka.secant_stiffness (its numpy twins) to round-off, for E = 0 (the branch without
    the curvature term's arctan) and E != 0; C = 0 encodes a linear tyre of slope B."""
    from vehicle_observers.models.tires import (
        magic_formula,
        magic_formula_secant,
        magic_formula_slope,
    )

    for tire in (Pacejka(B=8.0, C=1.3, D=4000.0, E=-0.5), Pacejka(B=8.0, C=1.3, D=4000.0),
                 Y.params.tire_f):
        c = (tire.B, tire.C, tire.D, tire.E)
        for a in (-0.2, -1e-6, 0.0, 3e-5, 0.05, 0.3):
            F = float(tire.force(a))
            assert magic_formula(a, *c) == pytest.approx(F, rel=1e-13, abs=1e-9)
            assert magic_formula_slope(a, *c)[0] == pytest.approx(F, rel=1e-13, abs=1e-9)
            assert magic_formula_secant(a, *c) == pytest.approx(
                float(tire.secant_stiffness(a)), rel=1e-13)
    assert magic_formula_secant(0.1, 5e4, 0.0, 0.0, 0.0) == 5e4  # C = 0: a linear tyre
    assert magic_formula(0.1, 5e4, 0.0, 0.0, 0.0) == pytest.approx(5e3, rel=1e-15)


@pytest.mark.parametrize("E", [0.0, -0.5, 0.3])
def test_slope_is_the_derivative_of_the_force(E):
    """dF/dalpha of magic_formula_slope against a central difference of Pacejka.force (step
    1e-6 rad: truncation error ~ |F'''| 1e-12 / 6, round-off ~ 1e-16 |F| / 1e-6, both far
    below 1e-6 relative for these forces of ~5e3 N)."""
    from vehicle_observers.models.tires import magic_formula_slope

    t = Pacejka(B=8.0, C=1.4, D=5000.0, E=E)
    for a in (-0.3, -0.02, 0.0, 0.01, 0.2):
        fd = float(t.force(a + 1e-6) - t.force(a - 1e-6)) / 2e-6
        assert magic_formula_slope(a, t.B, t.C, t.D, t.E)[1] == pytest.approx(fd, rel=1e-6)
    assert magic_formula_slope(0.0, t.B, t.C, t.D, t.E)[1] == pytest.approx(
        t.cornering_stiffness, rel=1e-14)


@pytest.mark.parametrize("field", ["B", "C", "D"])
def test_negative_coefficient_is_refused_at_construction(field):
    """A negative B, C or D gives a negative cornering stiffness B C D (a sector of negative
    secant stiffnesses): refused when the tyre is built, naming the coefficient."""
    from vehicle_observers.core.errors import ObserverArgumentError

    kw = dict(B=8.0, C=1.3, D=4000.0)
    kw[field] = -kw[field]
    with pytest.raises(ObserverArgumentError, match=rf"Pacejka\.{field} must be a finite"):
        Pacejka(**kw)
    kw[field] = float("nan")
    with pytest.raises(ObserverArgumentError, match=rf"Pacejka\.{field}"):
        Pacejka(**kw)
    with pytest.raises(ObserverArgumentError, match="Pacejka.E must be finite"):
        Pacejka(B=8.0, C=1.3, D=4000.0, E=float("inf"))
    with pytest.raises(ObserverArgumentError, match="LinearTire.C_alpha"):
        LinearTire(-5e4)
