import numpy as np
import pytest
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.models import bicycle
from vehicle_observers_papers.ichalal_2011 import constants as I

bp = I.params


def test_jacobian_matches_central_differences():
    rng = np.random.default_rng(0)
    x = np.column_stack([rng.normal(size=20), rng.uniform(-0.3, 0.3, 20),
                         rng.uniform(-1.2, 1.2, 20), rng.normal(size=20)])
    u = rng.normal(size=20)
    J = bicycle.jacobian(x, u, bp)
    h = 1e-6
    for j in range(4):
        dx = np.zeros(4)
        dx[j] = h
        num = (bicycle.rhs(x + dx, u, bp) - bicycle.rhs(x - dx, u, bp)) / (2 * h)
        np.testing.assert_allclose(J[:, :, j], num, rtol=1e-6, atol=1e-5)


def test_paper_factors_in_jacobian():
    # (32)-(33): g/p = 16.35, v^2 = 100, c v / p = 8.33; df4/dx2 at x = 0 is v^2/p
    J = bicycle.jacobian(np.zeros((1, 4)), np.zeros(1), bp)[0]
    assert J[3, 1] == pytest.approx(bp.v**2 / bp.p)
    assert J[3, 2] == pytest.approx(16.35, abs=0.01)
    assert J[0, 1] == pytest.approx(bp.v)


def test_closed_loop_tracks_reference():
    t = np.arange(0, 10.0, 1e-3)
    X, u = bicycle.simulate(bp, t)
    x3d, x4d = bicycle.tracking_reference(t)
    late = t > 3
    assert np.abs(X[late, 2] - x3d[late]).max() < 0.05
    assert np.all(np.isfinite(X))
    np.testing.assert_allclose(u, bicycle.control(X, t, bp), rtol=1e-12, atol=1e-12)


def test_time_grid_must_increase():
    with pytest.raises(ObserverArgumentError, match="strictly increasing"):
        bicycle.simulate(bp, np.array([0.0, 0.1, 0.1]))
    with pytest.raises(ObserverArgumentError, match="x0"):
        bicycle.simulate(bp, np.array([0.0, 0.1]), x0=(0.0, np.nan, 0.0, 0.0))


def test_plant_rhs_is_the_vectorised_model():
    """The compiled closed loop (25)+(27) (shared with the observer co-simulation) equals
    rhs (25) with the tracking law (27): the same expressions, to rounding."""
    rng = np.random.default_rng(2)
    P = bp.as_array()
    for _ in range(20):
        x, t = rng.normal(size=4), rng.uniform(0, 10)
        out = np.empty(4)
        u = bicycle.plant_rhs(x, t, P, out)
        assert u == pytest.approx(bicycle.control(x, t, bp), rel=1e-14, abs=1e-14)
        np.testing.assert_allclose(out, bicycle.rhs(x[None], np.array([u]), bp)[0],
                                   rtol=1e-13, atol=1e-13)
