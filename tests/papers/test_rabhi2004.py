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


def test_library_adaptation_law_is_the_printed_stabilising_one():
    """One step of the library's observer (10) with (20)-(22), on the sliding surfaces (the
    measured channels at their estimates, so the switching terms vanish and the adaptation is
    driven by the filtered equivalent injection x~4): the parameter update equals
    dt P Psi(X^)' x~4 with Psi written here from the force model (8) (R-A5), and along
    x~4' = -A x~4 + Psi theta~ (theta~ = theta - theta^) it cancels the cross term of
    V4' for V4 = x~4'x~4/2 + theta~'P^-1 theta~/2, whatever theta~: V4' + x~4' A x~4 = 0. The
    flipped gains (-P) double the cross term instead. Catches an adaptation law of the wrong
    sign, a transposed regressor or a regressor built from the wrong slips."""
    mdl = smo.ForceObserverModel.from_params(R.planar)
    dt = 5e-4
    rng = np.random.default_rng(11)
    y = np.array([[20.0, 0.3, 0.1, 20.0 / 0.3 + 1.0, 20.0 / 0.3 - 0.5]] * 2)   # vx vy r wf wr
    u = np.array([[0.05, 200.0, -100.0]] * 2)                                 # delta Tf Tr
    t = np.array([0.0, dt])
    x4 = np.array([800.0, -400.0, 1500.0, 1200.0])
    theta = np.array([5.0, 100.0, 5.0, -50.0, 3.0, 20.0, 3.0, 10.0])          # inside the box
    q = rng.normal(size=4) * 30.0                                             # x~4 on the surfaces
    vx, vy, r, wf, wr = y[0]
    delta = u[0, 0]
    slip = np.array([mdl.r_f * wf - vx, mdl.r_r * wr - vx, vx * delta - vy - mdl.l_f * r,
                     mdl.l_r * r - vy])
    C = np.array([mdl.C_kf, mdl.C_kr, mdl.C_af, mdl.C_ar])
    Psi = np.zeros((4, 8))
    for i in range(4):
        Psi[i, 2 * i], Psi[i, 2 * i + 1] = C[i] * slip[i] - vx * x4[i], vx
    for sign in (1.0, -1.0):
        gains = R.paper_gains.with_(P=tuple(sign * np.asarray(R.P_FULL)), theta_lo=(-1e9,) * 8,
                                    theta_hi=(1e9,) * 8)
        obs = smo.ForceObserver(mdl, gains, dt)
        z = np.concatenate([y[0, :3], y[0, 3:5], x4, theta, q])
        z1 = obs.step(z, 1, t, u, y)
        a = np.exp(-dt / gains.tau_f)
        e4f = a * q                                          # the switching terms are zero
        th_dot = (z1[9:17] - theta) / dt
        np.testing.assert_allclose(th_dot, sign * np.asarray(R.P_FULL) * (Psi.T @ e4f),
                                   rtol=1e-9)
        P = np.asarray(R.P_FULL)
        for _ in range(5):
            th_err = rng.normal(size=8)
            cross = e4f @ Psi @ th_err
            excess = cross - th_err @ (th_dot / P)          # V4' + x~4' A x~4
            if sign > 0:
                assert abs(excess) <= 1e-9 * abs(cross)     # V4' = -x~4' A x~4 <= 0
            else:
                assert excess == pytest.approx(2 * cross, rel=1e-9)
