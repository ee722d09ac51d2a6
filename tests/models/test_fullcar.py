"""Full-car vertical model (Rabhi 2004 eqs. (23)-(29))."""

import numpy as np
import pytest
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.models import fullcar as fc

P = fc.FullCarParams()


def test_matrices_symmetric_positive_definite():
    M, C, K, A11, B11 = P.matrices()
    for X in (M, C, K):
        np.testing.assert_allclose(X, X.T, atol=1e-9)
        assert np.linalg.eigvalsh(X).min() > 0
    np.testing.assert_allclose(np.diag(A11), P.k_t)
    np.testing.assert_allclose(np.diag(B11), P.c_t)


def test_energy_rate_identity():
    """dE/dt = -q'Cq' + wheel velocities . zeta, identity of the equations."""
    rng = np.random.default_rng(1)
    A, Bu, Bd = P.state_space()
    M, C, K, _, _ = P.matrices()
    for _ in range(50):
        x = rng.normal(size=14) * 0.05
        U, Ud = rng.normal(size=4) * 0.01, rng.normal(size=4) * 0.1
        xd = A @ x + Bu @ U + Bd @ Ud
        dE = x[7:] @ M @ xd[7:] + x[:7] @ K @ xd[:7]
        assert dE == pytest.approx(fc.power(x, U, Ud, P), rel=1e-9, abs=1e-12)


def test_uniform_lift_equilibrium():
    h = 0.02
    q = fc.static_deflection(np.full(4, h), P)
    np.testing.assert_allclose(q, [h, h, h, h, h, 0, 0], atol=1e-12)
    U = np.full((2000, 4), h)
    X = fc.simulate(U, 1e-3, P)
    np.testing.assert_allclose(X[-1, :7], q, atol=1e-12)
    np.testing.assert_allclose(X[-1, 7:], 0, atol=1e-12)


def test_sign_conventions():
    """Front lift -> nose up (theta > 0); left lift -> left side up (phi > 0)."""
    q = fc.static_deflection([0, 0, 0.01, 0.01], P)
    assert q[5] > 0
    q = fc.static_deflection([0.01, 0, 0.01, 0], P)
    assert q[6] > 0


def test_free_decay_energy_balance():
    """No road input: the energy lost over 2 s equals the integrated damper dissipation
    (trapezoid on the exactly discretised samples, dt = 0.2 ms: agreement to 1e-4
    relative, the trapezoid error)."""
    dt = 2e-4
    x0 = np.zeros(14)
    x0[4] = 0.05
    x0[5] = 0.01
    U = np.zeros((10000, 4))
    X = fc.simulate(U, dt, P, x0=x0)
    E = fc.energy(X, P)
    assert np.all(np.diff(E) <= 1e-9)
    pw = fc.power(X, U, U, P)
    lost = E[0] - E[-1]
    diss = -np.trapezoid(pw, dx=dt)
    assert diss == pytest.approx(lost, rel=1e-4)


def test_modal_frequencies_typical():
    """Body modes 1-2 Hz and wheel hop 10-13 Hz: the ranges of Gillespie 1992 for a
    passenger car, the criterion used to choose the (unprinted) parameters."""
    ms = fc.modal_summary(P)
    f = ms["f_undamped_hz"]
    assert np.all((f[:3] > 1.0) & (f[:3] < 2.0))
    assert np.all((f[3:] > 10.0) & (f[3:] < 13.0))
    assert np.all((ms["damping_ratio"] > 0.2) & (ms["damping_ratio"] < 0.5))


def test_paper_outputs_cannot_see_warp_offset():
    """Reconstruction R-B3: with the paper's outputs (29) a static warp wheel offset (and
    the road that holds it) is indistinguishable from rest; with measured wheel
    displacements it is visible."""
    v = fc.warp_vector(P)
    _, _, K, A11, _ = P.matrices()
    U0 = np.linalg.solve(A11, K[:4, :4] @ v)  # road holding x11 = v with body at rest
    q = fc.static_deflection(U0, P)
    np.testing.assert_allclose(q[:4], v, atol=1e-12)
    np.testing.assert_allclose(q[4:], 0, atol=1e-12)
    x = np.concatenate([q, np.zeros(7)])[None, :]
    y_paper = fc.outputs(x, U0[None, :], np.zeros((1, 4)), P, paper=True)
    np.testing.assert_allclose(y_paper, 0, atol=1e-9)
    y_ours = fc.outputs(x, None, None, P)
    assert np.abs(y_ours[0, :4]).max() == pytest.approx(1.0)


def test_bad_road_input():
    with pytest.raises(ValueError, match=r"\(N, 4\)"):
        fc.simulate(np.zeros((10, 3)), 1e-3, P)
    U = np.zeros((10, 4))
    U[3, 2] = np.inf
    with pytest.raises(ValueError, match="row 3"):
        fc.simulate(U, 1e-3, P)
    with pytest.raises(ObserverArgumentError, match="dt"):
        fc.simulate(np.zeros((10, 4)), -1e-3, P)
    with pytest.raises(ObserverArgumentError, match="x0"):
        fc.simulate(np.zeros((10, 4)), 1e-3, P, x0=np.zeros(7))
