"""Sliding-mode observers of Rabhi 2004: force observer (9)-(22), road UIO (30)-(38)."""

import numpy as np
import pytest
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.metrics import rmse
from vehicle_observers.core.protocol import Design, Observer, run_readable
from vehicle_observers.models import fullcar as fc
from vehicle_observers.models import planar as pl
from vehicle_observers.observers import sliding_mode as smo
from vehicle_observers_papers.rabhi_2004.experiments import reaching_time

P = pl.PlanarParams()
DT = 5e-4


def straight_run(T=3.0, Tf=0.0):
    N = int(T / DT)
    U = np.column_stack([np.zeros(N), np.full(N, Tf), np.zeros(N)])
    t = np.arange(N) * DT
    Xs = pl.simulate(pl.free_rolling_state(15.0, P), U, DT, P)
    return t, U, Xs


def force_run(t, Y, U, model, gains, x2_0=None, x3_0=None):
    """ForceObserver at DT on (t, U, Y), initial velocities / wheel speeds ``x2_0``, ``x3_0``
    (default the first measurement), zero forces."""
    x0 = None if x2_0 is None else np.concatenate([x2_0, x3_0, np.zeros(4)])
    return smo.ForceObserver(model, gains, DT).run(t, U, Y, x0)


@pytest.mark.parametrize("j,e0", [(0, 1.0), (1, 0.5), (2, 0.1), (3, 5.0), (4, 5.0)])
def test_reaching_time_known_answer(j, e0):
    """Free rolling (true forces 0), no force injection (k = 0, P = 0): the error obeys
    e' = -lambda sign(e) exactly, so the surface is reached at |e0|/lambda (to one step)
    and kept (chattering band lambda dt)."""
    t, U, Xs = straight_run(1.0)
    Y = pl.measurements(Xs)
    g = smo.ForceObserverGains(k=(0.0,) * 4, P=(0.0,) * 8, mode=smo.SIGN)
    err0 = np.zeros(5)
    err0[j] = e0
    r = force_run(t, Y, U, smo.ForceObserverModel.from_params(P), g,
                  x2_0=Y[0, :3] + err0[:3], x3_0=Y[0, 3:] + err0[3:])
    est = np.column_stack([r.x2, r.x3])
    lam = np.concatenate([g.lam2, g.lam3])[j]
    tr = reaching_time(t, Y[:, j] - est[:, j], lam * DT * 1.0001)
    assert tr == pytest.approx(e0 / lam, abs=1.01 * DT)
    assert np.abs(Y[t > tr, j] - est[t > tr, j]).max() <= lam * DT * 1.0001


def test_force_convergence_constant_torque():
    """Known answer: constant front torque, the true F_xf tends to
    (T - J_f v'/r_f)/r_f (see test_planar); the observer (sat, adaptive) reaches it to
    0.5 % after 2 s, and the equivalent injection reproduces the force error."""
    t, U, Xs = straight_run(3.0, Tf=500.0)
    Y = pl.measurements(Xs)
    r = force_run(t, Y, U, smo.ForceObserverModel.from_params(P),
                  smo.ForceObserverGains(mode=smo.SAT))
    acc = 500.0 / P.r_f / (P.m + P.J_f / P.r_f**2 + P.J_r / P.r_r**2)
    Fxf = (500.0 - P.J_f * acc / P.r_f) / P.r_f
    late = t > 2.0
    assert np.abs(r.x4[late, 0] - Fxf).max() < 0.005 * Fxf
    assert np.abs(r.x4[late, 2:]).max() < 1.0  # no lateral force invented
    mid = (t > 0.3) & (t < 1.0)
    e_true = Xs[mid, 8] - r.x4[mid, 0]
    assert rmse(r.x4_err_eq[mid, 0], e_true) < 0.2 * np.sqrt(np.mean(e_true**2)) + 2.0


def manoeuvre_runs(errors=None, **gkw):
    man = pl.paper_manoeuvre(10.0, DT)
    Xs = pl.simulate(pl.free_rolling_state(man.v0, P), man.U, DT, P)
    Y = pl.measurements(Xs)
    model = smo.ForceObserverModel.from_params(P, **(errors or {}))
    r = force_run(man.t, Y, man.U, model, smo.ForceObserverGains(**gkw))
    m = man.t > 1.0
    e = [rmse(r.x4[m, i], Xs[m, 8 + i]) for i in range(4)]
    ch = [np.std(np.diff(r.x4[m, i])) for i in range(4)]
    return np.array(e), np.array(ch)


def test_boundary_layer_removes_chattering():
    """sign: the force injection switches at full amplitude each step (std of the step
    change ~ K |W^+ Lambda| dt ~ 80 N); sat: continuous (< 10 N). Both track the forces."""
    e_sign, ch_sign = manoeuvre_runs(mode=smo.SIGN)
    e_sat, ch_sat = manoeuvre_runs(mode=smo.SAT)
    assert np.all(ch_sign > 40.0) and np.all(ch_sat < 10.0)
    assert np.all(e_sat < e_sign)
    assert np.all(e_sign < 150.0)


def test_adaptation_absorbs_slip_stiffness_error():
    """-20 % slip stiffness in the observer model: adapting F0/sigma (P = 5) divides the
    force RMSE by more than 2 compared with P = 0 (measured ~5x)."""
    err = dict(C_kf=-0.2, C_kr=-0.2, C_af=-0.2, C_ar=-0.2)
    e_ad, _ = manoeuvre_runs(errors=err, mode=smo.SAT)
    e_no, _ = manoeuvre_runs(errors=err, mode=smo.SAT, P=(0.0,) * 8)
    assert e_ad.max() < 0.5 * e_no.max()


def test_gain_condition_lhs_matches_kernel():
    model = smo.ForceObserverModel.from_params(P)
    rng = np.random.default_rng(0)
    d = rng.uniform(-0.2, 0.2, 20)
    e = rng.normal(size=(20, 4)) * 1000
    out = smo.omega_x4_bound(d, e, model)
    Om, Hm = np.empty((3, 4)), np.empty((2, 4))
    for k in range(20):
        smo._omega_h(d[k], model.as_array(), Om, Hm)
        np.testing.assert_allclose(out[k, :3], np.abs(Om @ e[k]), rtol=1e-12)
        np.testing.assert_allclose(out[k, 3:], np.abs(Hm @ e[k]), rtol=1e-12)


def test_force_observer_bad_inputs():
    t, U, Xs = straight_run(0.1)
    Y = pl.measurements(Xs)
    model = smo.ForceObserverModel.from_params(P)
    obs = smo.ForceObserver(model, smo.ForceObserverGains(), DT)
    with pytest.raises(ObserverArgumentError, match=r"y must be \(N, 5\)"):
        obs.run(t, U, Y[:, :4])
    Y2 = Y.copy()
    Y2[10, 0] = 0.1
    with pytest.raises(ObserverArgumentError, match=r"y\[10, 0\]"):
        obs.run(t, U, Y2)
    with pytest.raises(ObserverArgumentError, match="dt = 0.0005 s"):
        obs.run(2 * t, U, Y)
    with pytest.raises(ObserverArgumentError, match="x0 must be 9"):
        obs.run(t, U, Y, np.zeros(5))
    with pytest.raises(ObserverArgumentError, match="mode"):
        smo.ForceObserverGains().with_(mode="twisting")
    with pytest.raises(ObserverArgumentError, match="unknown observer-model parameter"):
        smo.ForceObserverModel.from_params(P, mass=0.1)
    with pytest.raises(ObserverArgumentError, match="J_z"):
        smo.ForceObserverModel.from_params(P, J_z=-1.5)
    with pytest.raises(ObserverArgumentError, match="dt"):
        smo.ForceObserver(model, smo.ForceObserverGains(), 0.0)
    with pytest.raises(ObserverArgumentError, match="theta0"):
        smo.ForceObserver(model, smo.ForceObserverGains(), DT, theta0=np.zeros(3))


@pytest.mark.parametrize("kw, name", [
    (dict(lam2=(4.0, -1.0, 3.0)), "lam2"), (dict(lam3=(500.0, 0.0)), "lam3"),
    (dict(k=(40.0, 40.0, -1.0, 40.0)), "k"), (dict(phi2=(0.02, 0.0, 0.01)), "phi2"),
    (dict(phi3=(-2.0, 2.0)), "phi3"), (dict(tau_f=0.0), "tau_f"), (dict(P=(5.0,) * 7), "P"),
    (dict(theta_lo=(30.0,) * 8), "theta_lo < theta_hi"), (dict(lam2=(np.nan, 4, 3)), "lam2"),
])
def test_force_gains_validation(kw, name):
    with pytest.raises(ObserverArgumentError, match=name):
        smo.ForceObserverGains(**kw)


@pytest.mark.parametrize("kw, name", [
    (dict(h11=-1.0), "h11"), (dict(phi1=0.0), "phi1"), (dict(phi2=-0.1), "phi2"),
    (dict(tau_f=0.0), "tau_f"), (dict(tau_i=-1e-3), "tau_i"), (dict(phi22=np.inf), "phi22"),
])
def test_road_gains_validation(kw, name):
    with pytest.raises(ObserverArgumentError, match=name):
        smo.RoadObserverGains(**kw)


# ---------------------------------------------------------------- road UIO ------------
FP = fc.FullCarParams()


def road_run(U, dt=2e-4, gains=None, p_obs=None, z_err0=0.0):
    t = np.arange(len(U)) * dt
    X = fc.simulate(U, dt, FP)
    Y = fc.outputs(X, None, None, FP)
    x0 = np.concatenate([Y[0, :4] + z_err0, np.zeros(4), Y[0, 7:10]])
    r = smo.RoadObserver(p_obs or FP, gains or smo.RoadObserverGains(), dt).run(t, None, Y, x0)
    return t, X, r


def test_road_step_known_answer():
    """Known answer: a 10 mm smoothed step under the front-left wheel only. After the
    transient the road estimate of that wheel is 10 mm (0.5 %) and the others 0 (0.1 mm);
    zeta -> k_t U."""
    dt = 2e-4
    t = np.arange(int(1.5 / dt)) * dt
    U = np.zeros((len(t), 4))
    U[:, 2] = 0.01 * np.clip((t - 0.2) / 0.02, 0, 1)
    _, X, r = road_run(U, dt)
    late = t > 1.2
    assert np.abs(r.U[late, 2] - 0.01).max() < 5e-5
    assert np.abs(r.U[late][:, [0, 1, 3]]).max() < 1e-4
    assert np.abs(r.zeta[late, 2] - FP.k_t[2] * 0.01).max() < 0.005 * FP.k_t[2] * 0.01


def test_road_reaching_time():
    """Stage-1 surface x~11 = 0 from a 5 mm initial error, H11 = 2 m/s, car at rest.
    With stage 2 off (H21 = 0) the error obeys e' = -H11 sign(e): reached at exactly
    5e-3/2 = 2.5 ms (to one step). With stage 2 on, v^ is pushed the same way by the
    filtered injection, so the surface is reached earlier, never later."""
    dt = 2e-4
    U = np.zeros((2000, 4))
    g0 = smo.RoadObserverGains(mode=smo.SIGN, h21=0.0)
    t, X, r = road_run(U, dt, g0, z_err0=5e-3)
    g = smo.RoadObserverGains(mode=smo.SIGN)
    _, _, r2 = road_run(U, dt, g, z_err0=5e-3)
    for i in range(4):
        tr = reaching_time(t, X[:, i] - r.z[:, i], g.h11 * dt * 1.0001)
        assert tr == pytest.approx(5e-3 / g.h11, abs=1.01 * dt)
        tr2 = reaching_time(t, X[:, i] - r2.z[:, i], 2 * g.h11 * dt)
        assert 0 < tr2 <= 5e-3 / g.h11 + dt


def test_road_sinusoid_accuracy_and_sign_chattering():
    """2 Hz, 10 mm sinusoid on every wheel (different phases): sat mode RMSE < 2 % of the
    amplitude after 0.5 s; sign mode chatters (limit cycle through the injection filter)
    with an error at least 5x larger."""
    dt = 2e-4
    t = np.arange(int(2.0 / dt)) * dt
    U = 0.01 * np.sin(2 * np.pi * 2.0 * t[:, None] + np.array([0, 1, 2, 3]))
    _, _, r_sat = road_run(U, dt, smo.RoadObserverGains(mode=smo.SAT))
    _, _, r_sgn = road_run(U, dt, smo.RoadObserverGains(mode=smo.SIGN))
    m = t > 0.5
    e_sat = [rmse(r_sat.U[m, i], U[m, i]) for i in range(4)]
    e_sgn = [rmse(r_sgn.U[m, i], U[m, i]) for i in range(4)]
    assert max(e_sat) < 0.02 * 0.01
    assert min(e_sgn) > 5 * max(e_sat)


def test_road_observer_bad_inputs():
    t = np.arange(100) * 2e-4
    obs = smo.RoadObserver(FP, smo.RoadObserverGains(), 2e-4)
    with pytest.raises(ObserverArgumentError, match=r"y must be \(N, 10\)"):
        obs.run(t, None, np.zeros((100, 9)))
    with pytest.raises(ObserverArgumentError, match="lpf"):
        smo.RoadObserver(FP, smo.RoadObserverGains().with_(mode="lpf"), 2e-4)
    with pytest.raises(ObserverArgumentError, match="dt"):
        smo.RoadObserver(FP, smo.RoadObserverGains(), -2e-4)
    with pytest.raises(ObserverArgumentError, match="x0 must be 11"):
        obs.run(t, None, np.zeros((100, 10)), np.zeros(4))


@pytest.mark.parametrize("mode", ["sign", "sat", "lpf"])
def test_run_readable_equals_compiled_force_observer(mode):
    """The observer contract for (10) + (20)-(22): the numpy step (shown in notebook 05)
    looped equals the compiled run, all 8 theta entries adapted, from wrong initial states;
    theta and the filtered equivalent injection of the internal state equal the run's
    extras. The two differ in the order of the 5x4 least-squares products only (numpy
    BLAS vs numba loops): ~1e-16 relative per step; the sign terms never sit at a
    rounding-level error here, so the trajectories agree to 1e-10 relative over 400 steps
    (a sign flip would move a force by lambda dt-scaled amounts, ~1e-3 relative)."""
    t, U, Xs = straight_run(0.2, Tf=200.0)
    U[:, 0] = 0.02 * np.sin(2 * np.pi * t)
    Xs = pl.simulate(pl.free_rolling_state(15.0, P), U, DT, P)
    Y = pl.measurements(Xs)
    model = smo.ForceObserverModel.from_params(P)
    g = smo.ForceObserverGains(P=(5.0,) * 8, mode=smo.MODES[mode])
    obs = smo.ForceObserver(model, g, DT)
    assert isinstance(obs, Observer) and isinstance(obs.design, Design)
    assert obs.design.certificate is None
    x0 = np.concatenate([Y[0, :3] + [1.0, 0.5, 0.1], Y[0, 3:] + 5.0, np.zeros(4)])
    r, rd = obs.run(t, U, Y, x0), run_readable(obs, t, U, Y, x0)
    np.testing.assert_allclose(rd.x, r.x, rtol=1e-10, atol=1e-8)
    z = obs.initial_state(t, U, Y, x0)
    for k in range(1, len(t)):
        z = obs.step(z, k, t, U, Y)
        np.testing.assert_allclose(z[smo.Z_TH:smo.Z_E4F], r.theta[k], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(z[smo.Z_E4F:], r.x4_err_eq[k - 1], rtol=1e-9, atol=1e-8)
    # paper-named properties are views of the estimate columns
    assert np.shares_memory(r.x4, r.x) and r.x4.shape == (len(t), 4)
    np.testing.assert_array_equal(r.x2[:, 0], r["vx_mps"])
    np.testing.assert_array_equal(r.x3[:, 1], r["omega_r_radps"])


def test_force_observer_is_causal():
    """Changing the samples after k leaves the estimate (and theta) at k unchanged."""
    t, U, Xs = straight_run(0.2, Tf=200.0)
    Y = pl.measurements(Xs)
    obs = smo.ForceObserver(smo.ForceObserverModel.from_params(P), smo.ForceObserverGains(), DT)
    k = 150
    Y2, U2 = Y.copy(), U.copy()
    Y2[k + 1:, :2] += 0.3
    U2[k + 1:, 1] += 300.0
    a, b = obs.run(t, U, Y), obs.run(t, U2, Y2)
    np.testing.assert_array_equal(a.x[:k + 1], b.x[:k + 1])
    np.testing.assert_array_equal(a.theta[:k + 1], b.theta[:k + 1])
    assert not np.array_equal(a.x[k + 2:], b.x[k + 2:])


@pytest.mark.parametrize("mode", ["sign", "sat"])
def test_run_readable_equals_compiled_road_observer(mode):
    """The observer contract for the road UIO: the numpy step looped equals the compiled
    run (estimate: wheel displacements, road, body rates), from a 5 mm initial error on an
    ISO class C road. Different product order of the 4x3 / 3x4 couplings only (rounding);
    sat mode is smooth, and in sign mode the switching arguments stay far above rounding
    (the stage-1 error chatters at h11 dt = 0.4 mm): 1e-9 relative over 1500 steps."""
    from vehicle_observers.data import road

    dt = 2e-4
    t = np.arange(1500) * dt
    U = road.iso8608_road("C", 20.0, seed=2).wheel_inputs(t, 10.0, FP.a + FP.b)
    X = fc.simulate(U, dt, FP)
    Y = fc.outputs(X, None, None, FP)
    obs = smo.RoadObserver(FP.scaled(m_u=0.1), smo.RoadObserverGains(mode=mode), dt)
    x0 = np.concatenate([Y[0, :4] + 5e-3, np.zeros(4), Y[0, 7:10]])
    r, rd = obs.run(t, None, Y, x0), run_readable(obs, t, None, Y, x0)
    np.testing.assert_allclose(rd.x, r.x, rtol=1e-9, atol=1e-12)
    assert r.U.shape == r.v.shape == r.zeta.shape == (len(t), 4) and r.x22.shape == (len(t), 3)
    # causal: samples after k do not reach the estimate at k
    k = 700
    Y2 = Y.copy()
    Y2[k + 1:] += 1e-3
    np.testing.assert_array_equal(obs.run(t, None, Y2, x0).x[:k + 1], r.x[:k + 1])


def test_paper_output_design_loses_exactly_the_warp():
    """Paper outputs (29): the unobservable subspace is 2-D, the static warp x11 = w
    (K21 w = 0) and its drift; its x11 part contains fullcar.warp_vector; the quotient is
    Hurwitz. One deflection sensor on any wheel makes the pair observable."""
    p = fc.FullCarParams()
    d = smo.paper_output_design(p)
    assert d.V.shape == (11, 2) and d.margin > 0
    w = fc.warp_vector(p)
    e = np.zeros(11)
    e[0:4] = w / np.linalg.norm(w)
    assert np.linalg.norm(d.V @ (d.V.T @ e) - e) < 1e-8          # w lies in span V
    assert np.allclose(d.C @ d.V, 0, atol=1e-12)
    # the body rows of A see nothing of V: A V stays in V (invariant subspace)
    AV = d.A @ d.V
    assert np.linalg.norm(AV - d.V @ (d.V.T @ AV)) < 1e-8 * np.linalg.norm(d.A)
    for i in range(4):
        di = smo.paper_output_design(p, deflection_wheel=i)
        assert di.V.shape == (11, 0) and di.margin > 0
    with pytest.raises(ObserverArgumentError, match="deflection_wheel"):
        smo.paper_output_design(p, deflection_wheel=4)
    for kw in (dict(q=0.0), dict(r=-1e-6), dict(tol=np.nan)):
        with pytest.raises(ObserverArgumentError, match=next(iter(kw))):
            smo.paper_output_design(p, **kw)


def test_run_readable_equals_compiled_paper_output_observer():
    """The observer contract for the observer on the paper's outputs: the numpy step
    (explicit Euler of A, B, L, V; (36)-(37)) looped equals the compiled run (F = I + dt (A
    - LC - VV'/tau_w), G = dt [B, L]: the same map, products grouped differently, rounding
    only: 1e-10 relative over 200 steps). A missing deflection column is a shape error."""
    p = fc.FullCarParams()
    d = smo.paper_output_design(p, deflection_wheel=3)
    rng = np.random.default_rng(0)
    N = 200
    t = np.arange(N) * 2e-4
    y = np.column_stack([rng.normal(size=(N, 10)) * 1e-2, rng.normal(size=N) * 1e-3])
    obs = smo.PaperOutputObserver(p, d, 2e-4)
    assert obs.output_names[-1] == "defl_fr_m" and obs.design.certificate is None
    r, rd = obs.run(t, None, y), run_readable(obs, t, None, y)
    np.testing.assert_allclose(rd.x, r.x, rtol=1e-10, atol=1e-14)
    k = 100
    y2 = y.copy()
    y2[k + 1:] += 1.0
    np.testing.assert_array_equal(obs.run(t, None, y2).x[:k + 1], r.x[:k + 1])
    with pytest.raises(ObserverArgumentError, match=r"y must be \(N, 11\)"):
        obs.run(t, None, y[:, :10])
    with pytest.raises(ObserverArgumentError, match="design must be a PaperOutputDesign"):
        smo.PaperOutputObserver(p, smo.RoadObserverGains(), 2e-4)


def test_paper_output_observer_road_known_answer():
    """Static road U0 with the car at its equilibrium, observer started at the truth: the
    accelerations are zero, the body at rest, and (36)-(37) return U0 after the tyre time
    constant c_t/k_t (modulo nothing: one deflection sensor)."""
    p = fc.FullCarParams()
    U0 = np.array([0.01, -0.02, 0.015, 0.005])
    q = fc.static_deflection(U0, p)
    N = 400
    t = np.arange(N) * 2e-4
    Yp = np.tile(np.concatenate([q[4:7], np.zeros(3), np.zeros(4)]), (N, 1))
    d = smo.paper_output_design(p, deflection_wheel=0)
    defl = np.full(N, p.S[0] @ q[4:7] - q[0])
    x0 = np.concatenate([q[0:4], np.zeros(11)])
    r = smo.PaperOutputObserver(p, d, 2e-4).run(t, None, np.column_stack([Yp, defl]), x0)
    np.testing.assert_allclose(r.z[-1], q[0:4], atol=1e-12)
    np.testing.assert_allclose(r.U[-1], U0, rtol=1e-9, atol=1e-12)


def test_modulo_subspace_and_road_lost_subspace():
    E = np.array([[1.0, 2.0, 3.0, 4.0], [0.0, 1.0, 0.0, 0.0]])
    Q = np.array([[1.0], [0.0], [0.0], [0.0]])
    np.testing.assert_allclose(smo.modulo_subspace(E, Q), [[0, 2, 3, 4], [0, 1, 0, 0]])
    p = fc.FullCarParams()
    Qu = smo.road_lost_subspace(p, smo.paper_output_design(p))
    uw = (np.array(p.k_s) + np.array(p.k_t)) / np.array(p.k_t) * fc.warp_vector(p)
    uw /= np.linalg.norm(uw)
    assert Qu.shape == (4, 2)
    assert np.linalg.norm(uw - Qu @ (Qu.T @ uw)) < 1e-9      # the static warp road is lost
    assert smo.road_lost_subspace(p, smo.paper_output_design(p, 3)).shape == (4, 0)
