import numpy as np
import pytest
from scipy.integrate import solve_ivp
from vehicle_observers.models import lateral
from vehicle_observers.models.lateral import LateralParams
from vehicle_observers.models.tires import LinearTire
from vehicle_observers_papers.leanza_2021 import constants as R
from vehicle_observers_papers.yacine_2015 import constants as Y

p = Y.params


def test_slip_angles_simplified_close_to_exact_for_small_angles():
    vy, r, d, vx = 0.05, 0.02, 0.01, 15.0
    e = np.array(lateral.slip_angles(vy, r, d, vx, p, exact=True))
    s = np.array(lateral.slip_angles(vy, r, d, vx, p, exact=False))
    assert np.abs(e - s).max() < 1e-5  # second-order small
    assert s[0] == pytest.approx(d - vy / vx - p.a_f * r / vx)


def test_transform_and_force_recovery_are_inverse():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(50, 4)) * [1, 0.3, 3000, 3000]
    x = lateral.to_transformed(X, p)
    Ff, Fr = lateral.forces_from_transformed(x[:, 2], x[:, 3], p)
    np.testing.assert_allclose(Ff, X[:, 2], rtol=1e-12)
    np.testing.assert_allclose(Fr, X[:, 3], rtol=1e-12)


def test_transformed_rhs_matches_s1_in_new_coordinates():
    rng = np.random.default_rng(1)
    X = rng.normal(size=(40, 4)) * [0.5, 0.2, 2000, 2000]
    d, vx = rng.uniform(-0.05, 0.05, 40), rng.uniform(3, 17, 40)
    f = lateral.rhs_s1(X, d, vx, p, exact=False)
    # chain rule: x' = T X' for the linear map (12)
    T = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1 / p.m, 1 / p.m],
                  [0, 0, p.a_f / p.I_z, -p.a_r / p.I_z]])
    np.testing.assert_allclose(lateral.rhs_transformed(lateral.to_transformed(X, p), d, vx, p),
                               f @ T.T, rtol=1e-10, atol=1e-9)


def test_numba_simulation_matches_scipy_solve_ivp():
    t = np.arange(0, 3.0, 0.001)
    d = 0.04 * np.sin(2 * np.pi * 0.7 * t)
    vx = np.full_like(t, 14.0)
    X = lateral.simulate_s1([0, 0, 0, 0], d, vx, 0.001, p, exact=True, relaxation=True,
                            substeps=2)
    f = lambda tt, x: lateral.rhs_s1(x[None], np.interp(tt, t, d, period=None), 14.0, p)[0]
    # piecewise-constant input: integrate each sample interval separately
    ref = [np.zeros(4)]
    x = np.zeros(4)
    for k in range(300):
        sol = solve_ivp(lambda tt, xx: lateral.rhs_s1(xx[None], d[k], 14.0, p)[0],
                        (t[k], t[k + 1]), x, rtol=1e-11, atol=1e-9)
        x = sol.y[:, -1]
        ref.append(x)
    ref = np.array(ref)
    np.testing.assert_allclose(X[:301], ref, rtol=1e-6, atol=1e-4)
    del f


def test_steady_state_matches_understeer_gradient():
    lin = LateralParams(m=R.m, I_z=R.I_z, a_f=R.l_f, a_r=R.l_r, tire_f=LinearTire(R.C_f),
                        tire_r=LinearTire(R.C_r))
    vx, d = 25.0, 0.01
    X = lateral.simulate_s1([0, 0], np.full(5000, d), np.full(5000, vx), 0.002, lin,
                            exact=False, relaxation=False, substeps=1)
    L = lin.a_f + lin.a_r
    K = lin.m * (lin.a_r * R.C_r - lin.a_f * R.C_f) / (L * R.C_f * R.C_r)
    assert X[-1, 1] == pytest.approx(vx * d / (L + K * vx**2), rel=1e-6)


def test_relaxation_converges_to_steady_forces():
    X = lateral.simulate_s1([0, 0, 0, 0], np.full(4000, 0.02), np.full(4000, 10.0), 0.001, p,
                            exact=True, relaxation=True, substeps=1)
    Xs = lateral.simulate_s1([0, 0], np.full(4000, 0.02), np.full(4000, 10.0), 0.001, p,
                             exact=True, relaxation=False, substeps=1)
    np.testing.assert_allclose(X[-1], Xs[-1], rtol=1e-3)


def test_packed_parameters_follow_the_named_indices():
    """as_array() puts each constant at its named index (the kernels read P[M], P[TF_B], ...);
    a linear tyre is encoded as (C_alpha, 0, 0, 0)."""
    P = p.as_array()
    assert P.shape == (lateral.N_PARAMS,)
    named = ((lateral.M, p.m), (lateral.I_Z, p.I_z), (lateral.A_F, p.a_f), (lateral.A_R, p.a_r),
             (lateral.R_F, p.r_f), (lateral.R_R, p.r_r), (lateral.L_S, p.l_s),
             (lateral.TF_B, p.tire_f.B), (lateral.TF_C, p.tire_f.C), (lateral.TF_D, p.tire_f.D),
             (lateral.TF_E, p.tire_f.E), (lateral.TR_B, p.tire_r.B), (lateral.TR_C, p.tire_r.C),
             (lateral.TR_D, p.tire_r.D), (lateral.TR_E, p.tire_r.E))
    for idx, v in named:
        assert P[idx] == v
    assert sorted(i for i, _ in named) == list(range(lateral.N_PARAMS))
    lin = LateralParams(m=1.0, I_z=1.0, a_f=1.0, a_r=1.0, tire_f=LinearTire(7e4),
                        tire_r=LinearTire(8e4))
    assert lin.as_array()[lateral.TR_B:lateral.TR_E + 1].tolist() == [8e4, 0.0, 0.0, 0.0]


def test_compiled_rhs_equals_numpy_rhs():
    """The compiled S1 right-hand side (simulate_s1 and the scenario truth) equals the
    vectorised numpy rhs_s1 / rhs_no_relaxation to round-off (1e-12 relative: the same
    formulas; numpy's and LLVM's libm may differ in the last bit of atan / sin)."""
    rng = np.random.default_rng(2)
    P = p.as_array()
    out = np.empty(4)
    for _ in range(50):
        X = rng.normal(size=4) * [0.5, 0.2, 2000, 2000]
        d, vx = rng.uniform(-0.05, 0.05), rng.uniform(3, 17)
        for exact in (True, False):
            lateral.s1_rhs(X, d, vx, P, exact, True, out)
            np.testing.assert_allclose(out, lateral.rhs_s1(X, d, vx, p, exact)[0], rtol=1e-12,
                                       atol=1e-9)
            lateral.s1_rhs(X, d, vx, P, exact, False, out)
            np.testing.assert_allclose(out[:2], lateral.rhs_no_relaxation(X[:2], d, vx, p,
                                                                          exact)[0],
                                       rtol=1e-12, atol=1e-9)


def test_bad_inputs():
    from vehicle_observers.core.errors import ObserverArgumentError

    for dt in (0.0, -1e-3, float("nan")):
        with pytest.raises(ObserverArgumentError, match="dt > 0"):
            lateral.simulate_s1([0, 0], np.zeros(4), np.ones(4), dt, p)
    with pytest.raises(ValueError, match=r"v_x must be > 0 .* v_x\[2\] = 0.0"):
        lateral.simulate_s1([0, 0], np.zeros(4), np.array([1.0, 1.0, 0.0, 1.0]), 0.01, p)
    with pytest.raises(ValueError, match="finite"):
        lateral.simulate_s1([0, 0], np.array([0.0, np.nan]), 10.0, 0.01, p)
    with pytest.raises(ValueError, match="r_f = r_r"):
        from dataclasses import replace
        lateral.rhs_transformed(np.zeros((1, 4)), 0.0, 10.0, replace(p, r_r=0.2))


def test_simulate_ts_equals_nonlinear_inside_sector():
    t = np.arange(0, 5.0, 0.001)
    d = 0.1 * np.sin(2 * np.pi * 0.5 * t)
    vx = np.linspace(5, 16, len(t))
    X = lateral.simulate_s1([0, 0, 0, 0], d, vx, 0.001, p, exact=False, relaxation=True,
                            substeps=1)
    x = lateral.to_transformed(X, p)
    x_ts, oob = lateral.simulate_ts(Y.ts_model(), x[0], d, vx, 0.001, p, substeps=1)
    assert not oob.any()
    assert (np.abs(x_ts - x) / np.abs(x).max(axis=0)).max() < 1e-10
    # outside the sector the TS simulation flags the samples
    _, oob2 = lateral.simulate_ts(Y.ts_model(), x[0], 4 * d, vx, 0.001, p, substeps=1)
    assert oob2.any()
