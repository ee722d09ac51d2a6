"""Rabhi 2004 prints structure, not numbers: known-answer checks of the matrices of (9) and
(23)-(29) against independent computations, and of the scenario runners."""

import numpy as np
import pytest
from vehicle_observers.models import fullcar as fc
from vehicle_observers.models import planar as pl
from vehicle_observers.observers import sliding_mode as smo
from vehicle_observers_papers.rabhi_2004 import constants as R


def test_omega_h_reproduce_the_planar_model():
    """Omega(delta) x4 + transport terms and G u - H x4 of (9) equal the accelerations of
    the planar model (3)-(4) (an independent right-hand side) for arbitrary forces."""
    model = smo.ForceObserverModel.from_params(R.planar)
    X = pl.free_rolling_state(15.0, R.planar)
    X[4], X[5] = 0.3, 0.1
    X[8:12] = [800.0, -300.0, 1500.0, 900.0]
    for delta in (0.0, 0.05, -0.1):
        u = np.array([delta, 120.0, -40.0])
        f = pl.rhs(X, u, R.planar)
        Om, Hm = smo.omega_h(delta, model)
        vx, vy, r = X[3], X[4], X[5]
        np.testing.assert_allclose(Om @ X[8:12] + [vy * r, -vx * r, 0.0], f[3:6], rtol=1e-12)
        Gu = u[1:3] / np.array([R.planar.J_f, R.planar.J_r])
        np.testing.assert_allclose(Gu - Hm @ X[8:12], f[6:8], rtol=1e-12)
    W = np.vstack(smo.omega_h(0.05, model)[0:1] + (-smo.omega_h(0.05, model)[1],))
    assert np.linalg.matrix_rank(W) == R.n_x4   # x~4 recoverable from the injections (R-A6)


def test_psi_theta_is_the_relaxation_model():
    """Psi(X) theta with theta = (1/sigma, F0/sigma) equals (8): (C s - v_x F)/sigma +
    F0 v_x / sigma per force, with the slip velocities of R-A5 written out here."""
    model = smo.ForceObserverModel.from_params(R.planar)
    vx, vy, r, wf, wr, d = 20.0, 0.4, 0.2, 67.0, 66.5, 0.03
    F = np.array([100.0, -50.0, 30.0, 10.0])
    F0 = np.array([5.0, -7.0, 11.0, 2.0])
    sig = np.array([model.sigma_x, model.sigma_x, model.sigma_y, model.sigma_y])
    th = np.ravel(np.column_stack([1 / sig, F0 / sig]))
    Psi = np.empty((4, 8))
    smo._psi(vx, vy, r, wf, wr, d, F, model.as_array(), Psi)
    s = np.array([model.r_f * wf - vx, model.r_r * wr - vx, vx * d - vy - model.l_f * r,
                  model.l_r * r - vy])
    C = np.array([model.C_kf, model.C_kr, model.C_af, model.C_ar])
    np.testing.assert_allclose(Psi @ th, (C * s - vx * F) / sig + F0 * vx / sig, rtol=1e-12)


def test_fullcar_uniform_road_lifts_the_car_rigidly():
    """A uniform road offset U0 on all four wheels: the static equilibrium is a rigid heave
    (every wheel and the body up by U0, no pitch or roll), an independent known answer."""
    q = fc.static_deflection(np.full(4, 0.02), R.fullcar)
    np.testing.assert_allclose(q, [0.02] * 5 + [0.0, 0.0], atol=1e-14)
    M, C, K, A11, B11 = R.fullcar.matrices()
    for X in (M, C, K):
        np.testing.assert_allclose(X, X.T, rtol=0, atol=1e-12 * np.abs(X).max())
        assert np.all(np.linalg.eigvalsh(X) > 0)
    # wheel order of (26): rear wheels first (negative longitudinal arm)
    assert np.all(R.fullcar.S[:2, 1] < 0) and np.all(R.fullcar.S[2:, 1] > 0)


def test_warp_road_gives_zero_paper_outputs():
    """The warp state x11 = w on the road U_w = K_t^-1 (K_s + K_t) w is an equilibrium with
    all paper outputs (29) zero: x12 = 0, x22 = 0, x31 = 0 (the rank loss at s = 0)."""
    p = R.fullcar
    w = fc.warp_vector(p)
    np.testing.assert_allclose(w, [-1.0, 1.0, 25 / 30, -25 / 30], rtol=1e-12)
    x = np.zeros((1, 14))
    x[0, :4] = w
    U = ((np.array(p.k_s) + np.array(p.k_t)) / np.array(p.k_t) * w)[None, :]
    A, Bu, Bd = p.state_space()
    np.testing.assert_allclose(x @ A.T + U @ Bu.T, 0, atol=1e-9)   # an equilibrium
    y = fc.outputs(x, U, np.zeros((1, 4)), p, paper=True)
    np.testing.assert_allclose(y, 0, atol=1e-9)


def test_mu_step_halves_the_slip_stiffness():
    """The friction step changes the truth's slip stiffness C = B C mu F_z in proportion
    to mu, the observer's model (from mu = 1) stays: its stiffness is now twice too large."""
    assert R.planar.with_(mu=0.5).C_alpha_f == pytest.approx(0.5 * R.planar.C_alpha_f)
    assert R.planar.with_(mu=0.5).C_kappa_r == pytest.approx(0.5 * R.planar.C_kappa_r)
