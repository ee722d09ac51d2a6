"""Planar vehicle with wheel spin and relaxation forces (Rabhi 2004 eqs. (3)-(8), truth)."""

import numpy as np
import pytest
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.models import planar as pl

P = pl.PlanarParams()


def random_states(n, seed=0):
    rng = np.random.default_rng(seed)
    X = np.zeros((n, 12))
    X[:, 2] = rng.uniform(-1, 1, n)
    X[:, 3] = rng.uniform(5, 30, n)
    X[:, 4] = rng.uniform(-1, 1, n)
    X[:, 5] = rng.uniform(-0.5, 0.5, n)
    X[:, 6] = X[:, 3] / P.r_f * rng.uniform(0.9, 1.1, n)
    X[:, 7] = X[:, 3] / P.r_r * rng.uniform(0.9, 1.1, n)
    X[:, 8:12] = rng.uniform(-4000, 4000, (n, 4))
    U = np.column_stack([rng.uniform(-0.1, 0.1, n), rng.uniform(-800, 800, n),
                         rng.uniform(-800, 800, n)])
    return X, U


def test_energy_rate_equals_power_of_external_actions():
    """dT/dt along rhs = torque power - tyre slip power (Coriolis terms do no work):
    an identity of the equations, so it holds to round-off."""
    X, U = random_states(200)
    for x, u in zip(X, U, strict=True):
        dx = pl.rhs(x, u, P)
        dT = (P.m * (x[3] * dx[3] + x[4] * dx[4]) + P.J_z * x[5] * dx[5]
              + P.J_f * x[6] * dx[6] + P.J_r * x[7] * dx[7])
        pw = pl.power_balance(x, u, P)
        assert dT == pytest.approx(pw, rel=1e-9, abs=1e-6)


def test_free_rolling_is_equilibrium():
    X = pl.free_rolling_state(17.0, P)
    dx = pl.rhs(X, [0.0, 0.0, 0.0], P)
    assert dx[0] == pytest.approx(17.0)
    np.testing.assert_allclose(dx[1:], 0.0, atol=1e-12)


def test_combined_slip_properties():
    X = pl.free_rolling_state(20.0, P)
    # lateral slip via steering: odd in alpha; the steered wheel's contact speed is
    # v cos(delta), so kappa_f = 1/cos(delta) - 1 exactly (rear: 0)
    f_pos = pl.steady_forces(X, 0.02, P)
    f_neg = pl.steady_forces(X, -0.02, P)
    assert f_pos[1, 0] == pytest.approx(1 / np.cos(0.02) - 1, rel=1e-9)
    assert f_pos[1, 1] == pytest.approx(0.0, abs=1e-12)
    assert f_pos[0, 2] == pytest.approx(-f_neg[0, 2], rel=1e-12)
    # small slip: F = C_alpha alpha (slope at zero)
    a = f_pos[1, 2]
    assert f_pos[0, 2] == pytest.approx(P.C_alpha_f * a, rel=0.03)
    # combined: adding longitudinal slip lowers the lateral force (G_yk < 1)
    Xk = X.copy()
    Xk[pl.IWF] *= 1.05
    f_comb = pl.steady_forces(Xk, 0.02, P)
    assert 0 < f_comb[0, 2] < f_pos[0, 2]
    assert f_comb[0, 0] > 0  # traction
    # saturation: |F| <= mu F_z
    Xb = X.copy()
    Xb[pl.IWF] *= 1.5
    fb = pl.steady_forces(Xb, 0.3, P)
    assert abs(fb[0, 0]) <= P.mu * P.Fz_f + 1e-9
    assert abs(fb[0, 2]) <= P.mu * P.Fz_f + 1e-9


def test_constant_torque_known_answer():
    """Straight line, constant front torque: after the wheel/relaxation transients
    v' = T/r / (m + J_f/r_f^2 + J_r/r_r^2) and F_xf = (T - J_f v'/r_f)/r_f exactly
    (rigid rolling relation omega' = v'/r in the quasi-steady state)."""
    dt, T = 5e-4, 4.0
    Tf = 500.0
    N = int(T / dt)
    U = np.column_stack([np.zeros(N), np.full(N, Tf), np.zeros(N)])
    Xs = pl.simulate(pl.free_rolling_state(15.0, P), U, dt, P)
    acc = Tf / P.r_f / (P.m + P.J_f / P.r_f**2 + P.J_r / P.r_r**2)
    Fxf = (Tf - P.J_f * acc / P.r_f) / P.r_f
    Fxr = -P.J_r * acc / P.r_r**2
    k = int(3.0 / dt)
    vdot = (Xs[k + 1, 3] - Xs[k - 1, 3]) / (2 * dt)
    assert vdot == pytest.approx(acc, rel=1e-3)
    assert Xs[k, 8] == pytest.approx(Fxf, rel=1e-3)
    assert Xs[k, 9] == pytest.approx(Fxr, rel=1e-2)


def test_steady_cornering_matches_linear_bicycle():
    """Small constant steering at 20 m/s: yaw rate = v delta / (L + K v^2),
    K = m (l_r/C_f - l_f/C_r) / L (linear bicycle, Rajamani 2012 eq. (3.15) with per-axle
    stiffnesses). Tolerance 2 %: the truth has small-angle-exact kinematics, a tiny drag
    from F_yf sin(delta) slows the car (~0.1 %), and the magic formula is 1-2 % below its
    tangent at this slip."""
    dt, T = 5e-4, 4.0
    N = int(T / dt)
    delta = np.radians(0.5)
    U = np.column_stack([np.full(N, delta), np.zeros(N), np.zeros(N)])
    Xs = pl.simulate(pl.free_rolling_state(20.0, P), U, dt, P)
    v = Xs[-1, 3]
    K = P.m * (P.l_r / P.C_alpha_f - P.l_f / P.C_alpha_r) / P.L
    r_lin = v * delta / (P.L + K * v**2)
    assert Xs[-1, 5] == pytest.approx(r_lin, rel=0.02)


def test_manoeuvre_excites_all_forces():
    man = pl.paper_manoeuvre(20.0, 1e-3)
    Xs = pl.simulate(pl.free_rolling_state(man.v0, P), man.U, 1e-3, P)
    peaks = np.abs(Xs[:, 8:12]).max(axis=0)
    assert np.all(peaks > 1000.0)
    assert Xs[:, 3].min() > 5.0


def test_steady_forces_are_the_textbook_magic_formula():
    """The kernels call models.tires.magic_formula, ``B (1 - E) k + E atan(B k)``; the
    textbook form of the module docstring is ``B k - E (B k - atan(B k))``: the same number
    up to rounding (1e-12 relative), with the cosine weights of combined slip."""
    X, U = random_states(50, seed=3)
    for x, u in zip(X, U, strict=True):
        F, S = pl.steady_forces(x, u[0], P)
        for i, Fz in enumerate((P.Fz_f, P.Fz_r)):
            kappa, alpha = S[i], S[2 + i]
            D = P.mu * Fz

            def mf(s, B, C, E):
                return D * np.sin(C * np.arctan(B * s - E * (B * s - np.arctan(B * s))))
            Fx = mf(kappa, P.B_x, P.C_x, P.E_x) * np.cos(P.C_xa * np.arctan(P.B_xa * alpha))
            Fy = mf(alpha, P.B_y, P.C_y, P.E_y) * np.cos(P.C_yk * np.arctan(P.B_yk * kappa))
            assert F[i] == pytest.approx(Fx, rel=1e-12, abs=1e-9)
            assert F[2 + i] == pytest.approx(Fy, rel=1e-12, abs=1e-9)


def test_measurements_pick_the_measured_states():
    X, _ = random_states(20)
    np.testing.assert_array_equal(pl.measurements(X), X[:, [3, 4, 5, 6, 7]])
    noisy = pl.measurements(X, (0.1, 0.0, 0.0, 0.0, 0.0), seed=1)
    assert np.array_equal(noisy[:, 1:], X[:, 4:8]) and not np.array_equal(noisy[:, 0], X[:, 3])
    with pytest.raises(ObserverArgumentError, match="noise_std"):
        pl.measurements(X, (-0.1, 0, 0, 0, 0))
    with pytest.raises(ObserverArgumentError, match="Xs"):
        pl.measurements(X[:, :5])


def test_bad_inputs():
    with pytest.raises(ObserverArgumentError, match="U must have shape"):
        pl.simulate(np.zeros(12), np.zeros((10, 2)), 1e-3, P)
    U = np.zeros((10, 3))
    U[4, 1] = np.nan
    with pytest.raises(ObserverArgumentError, match="row 4"):
        pl.simulate(np.zeros(12), U, 1e-3, P)
    with pytest.raises(ObserverArgumentError, match="dt"):
        pl.simulate(np.zeros(12), np.zeros((10, 3)), 0.0, P)
    with pytest.raises(ObserverArgumentError, match="substeps"):
        pl.simulate(np.zeros(12), np.zeros((10, 3)), 1e-3, P, substeps=0)
    with pytest.raises(ObserverArgumentError, match="X0"):
        pl.simulate(np.zeros(11), np.zeros((10, 3)), 1e-3, P)
