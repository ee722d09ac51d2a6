import numpy as np
import pytest
from vehicle_observers.estimation import segments
from vehicle_observers.models.vehicle import load_vehicle


@pytest.mark.parametrize("car", ["yacine2015", "revs250lm"])
def test_pole_rate_equals_eigenvalues_of_the_linear_bicycle(car):
    """Largest pole magnitude from the closed form against numpy's eigenvalues of the 2x2
    linear bicycle matrix, from walking pace (real poles) to 80 m/s (complex pair)."""
    v = load_vehicle(car)
    p, Cf, Cr = v.params, v.C_f, v.C_r
    vx = np.geomspace(0.3, 80.0, 60)
    got = segments.pole_rate(v, vx)
    ref, complex_pair = [], []
    for u in vx:
        A = np.array([[-(Cf + Cr) / (p.m * u), -(p.a_f * Cf - p.a_r * Cr) / (p.m * u) - u],
                      [-(p.a_f * Cf - p.a_r * Cr) / (p.I_z * u),
                       -(p.a_f ** 2 * Cf + p.a_r ** 2 * Cr) / (p.I_z * u)]])
        lam = np.linalg.eigvals(A)
        ref.append(np.abs(lam).max())
        complex_pair.append(bool(np.iscomplex(lam).any()))
    np.testing.assert_allclose(got, ref, rtol=1e-10)
    assert any(complex_pair) and not all(complex_pair)     # both branches are exercised
