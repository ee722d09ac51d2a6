"""Yacine 2015 chain: curvature (11), premise (26), Theorem 1 (33) certified, observer (31),
forces (46), bound (34)."""

import numpy as np
import pytest
from vehicle_observers.core.errors import InfeasibleDesign, LogFormatError, ObserverArgumentError
from vehicle_observers.core.protocol import Observer, Trajectory, run_readable
from vehicle_observers.data import scenarios
from vehicle_observers.models import lateral
from vehicle_observers.observers import ts_premise as to
from vehicle_observers_papers.yacine_2015 import constants as Y

P = Y.params


@pytest.fixture(scope="module")
def design():
    return to.design_theorem1(Y.ts_model())


@pytest.fixture(scope="module")
def quick_clean():
    return scenarios.emulated_satory(seed=0, quick=True, noise_scale=0.0)


def test_theorem1_is_certified_with_paper_bounds(design):
    ts = design.ts
    assert ts.n_rules == 8
    np.testing.assert_allclose(sorted(set(ts.z_vertices[:, 2])), [Y.vx_min, Y.vx_max])
    np.testing.assert_allclose(sorted(set(ts.z_vertices[:, 1])), [Y.M_f2, Y.M_f1])
    np.testing.assert_allclose(sorted(set(ts.z_vertices[:, 0])), [Y.M_r2, Y.M_r1])
    assert design.alpha == 1e-3
    assert design.solution.certificate.ok and design.certificate_original.ok
    assert design.certificate is design.certificate_original     # the protocol's certificate
    m = design.margins()
    assert m["xi_scaled_min_margin"] > 0 and m["xi_original_min_margin"] > 0
    assert m["P_min_eig"] > 0 and design.c > 0
    # independent recomputation of (33) at every vertex in original coordinates
    for i in range(8):
        Mi = design.P @ design.L[i]
        A = ts.A[i]
        X = A.T @ design.P + design.P @ A - Mi @ to.C_OUT - to.C_OUT.T @ Mi.T + 1e-3 * design.P
        Xi = np.block([[X, design.P @ to.GAMMA], [to.GAMMA.T @ design.P, -design.c * np.eye(2)]])
        assert np.linalg.eigvalsh(Xi)[-1] < 0


def test_blended_error_dynamics_decay_faster_than_alpha_over_2(design):
    """sum h_i Xi_i < 0 implies every frozen blend A(h) - L(h) C has spectral abscissa
    < -alpha/2 and (added disk region) modulus < R; checked on random convex weights."""
    rng = np.random.default_rng(1)
    for _ in range(200):
        h = rng.dirichlet(np.ones(8))
        Ah = np.tensordot(h, design.ts.A, axes=1)
        Lh = np.tensordot(h, design.L, axes=1)
        lam = np.linalg.eigvals(Ah - Lh @ to.C_OUT)
        assert lam.real.max() < -design.alpha / 2
        assert np.abs(lam).max() < design.disk_radius


def test_alpha_1_feasible_for_33_alone_infeasible_with_added_conditioning_bound():
    """alpha = 1: Theorem 1's (33) alone (only the normalisation P~ >= I) is feasible and
    certified; it is the repository's added bound P~ <= 1e3 I that makes it infeasible, and
    the error names the low-speed vertex (v_x = 0.2 m/s) and the violation."""
    ts = Y.ts_model()
    d = to.design_theorem1(ts, alpha=1.0, p_max=None, disk_radius=None)
    assert d.certificate_original.ok and d.margins()["xi_original_min_margin"] > 0
    assert d.added_constraints() == ["P~ >= I (normalisation; feasibility unchanged)"]
    assert d.alpha2 / d.alpha1 > 1e5          # what the conditioning bound forbids
    with pytest.raises(InfeasibleDesign) as ei:
        to.design_theorem1(ts, alpha=1.0, p_max=1e3, disk_radius=None)
    e = ei.value
    assert e.lmi == "Xi[8]"
    assert e.violation > 0.1
    assert "v_x=0.2" in str(e) and "Xi[8]" in str(e)


def test_certificate_rejects_wrong_gains(design):
    cert = to.certify_original(design.ts, design.P, -design.L, design.c, design.alpha)
    assert not cert.ok
    assert cert.worst().name.startswith("Xi[") and cert.worst().margin < 0


def test_curvature_and_vy_formulas_exact_with_exact_derivatives(quick_clean):
    """(11) and (26) are exact identities of S2 (9): with the true derivatives (from the
    truth's right-hand side) they return rho and v_y to round-off."""
    q = quick_clean
    vx, r, rho = q.extra["vx_true_mps"], q.extra["yaw_rate_true_radps"], q.rho
    psiL = q.extra["psiL_true_rad"]
    dpsi = r - vx * rho
    dy = q.vy + vx * psiL + P.l_s * dpsi
    np.testing.assert_allclose(to.curvature(r, vx, dpsi, vx_floor=1e-9), rho, atol=1e-12)
    np.testing.assert_allclose(to.vy_from_vision(vx, psiL, dy, dpsi, P.l_s), q.vy, atol=1e-12)


def test_premise_chain_noise_free(quick_clean):
    """HOSMD (n = 3) premise and curvature on the noise-free lap start, after T = 5 s, at
    speeds > 2 m/s: vy RMSE < 1e-3 m/s (|vy| up to 0.5), curvature RMSE < 1e-4 1/m (rho up
    to 0.0125). The residual comes from the curvature-rate jumps of the clothoids
    (psi_L^(4) unbounded there), where the differentiator re-converges."""
    q = quick_clean
    pe = to.estimate_premises(q)
    assert pe.s_e.shape == (len(q), 6)
    np.testing.assert_array_equal(pe.s_e[:, 0], q.vx)
    m = (q.t > 5) & (q.vx > 2)
    assert np.sqrt(np.mean((pe.vy - q.vy)[m] ** 2)) < 1e-3
    assert np.sqrt(np.mean((pe.rho - q.rho)[m] ** 2)) < 1e-4


def _protocol_data(q, vyp):
    return q.t, np.column_stack([q.delta, q.vx, vyp]), q.yaw_rate


def test_observer_protocol_readable_step_equals_compiled_run(design, quick_clean):
    """The contract: run_readable (the numpy step (31), :func:`observer_step`, looped in
    Python) equals the compiled run on 2 s of the lap with a wrong premise and x0, with 1 and
    3 RK4 substeps. Tolerance 1e-10 absolute on states of order 1-10 (observed ~2e-15): the
    readable step blends the vertex matrices with tensordot and evaluates the secant
    stiffness (16) with numpy, the kernel sums in loops with LLVM's libm, so each step differs
    by a few ulps, and the observer's error dynamics are contracting (certified decay), so
    these differences do not grow. The premises the run reports are those of the numpy
    formulas (clipped) to 1e-12, and the forces are (46) of its estimate."""
    q = quick_clean.segment(10.0, 12.0)
    vyp = q.vy + 0.01
    x0 = np.array([0.1, 0, 0.5, -0.5])
    t, u, y = _protocol_data(q, vyp)
    for sub in (1, 3):
        obs = to.TSPremiseObserver(design, q.dt, P, substeps=sub)
        assert isinstance(obs, Observer) and obs.bounds(x0) is None
        run = obs.run(t, u, y, x0)
        ref = run_readable(obs, t, u, y, x0)
        assert run.names == ref.names == to.STATE_NAMES
        np.testing.assert_allclose(run.x, ref.x, rtol=0, atol=1e-10)
    ts = design.ts
    z = np.clip(to.ts_premises(vyp, q.yaw_rate, q.delta, q.vx), ts.zmin, ts.zmax)
    np.testing.assert_allclose(run.z, z, rtol=1e-12)
    Ff, Fr = lateral.forces_from_transformed(run.x[:, 2], run.x[:, 3], P)
    np.testing.assert_allclose(run.Ff, Ff)
    np.testing.assert_allclose(run.Fr, Fr)
    # the log front end is the same observer at dt = log.dt
    np.testing.assert_array_equal(to.run_observer(q, design, vy_premise=vyp, x0=x0,
                                                  substeps=3).x, run.x)
    assert run.us_per_step > 0 and run.causal and isinstance(run, Trajectory)


def test_observer_is_causal(design, quick_clean):
    """Changing every sample after k (inputs, premise, gyro) leaves the estimates up to k
    unchanged, bit for bit: step k reads samples k - 1 and k only."""
    q = quick_clean.segment(10.0, 11.0)
    t, u, y = _protocol_data(q, q.vy)
    obs = to.TSPremiseObserver(design, q.dt, P)
    a = obs.run(t, u, y)
    k = 400
    u2, y2 = u.copy(), y.copy()
    rng = np.random.default_rng(0)
    u2[k + 1:, 0] += rng.normal(0, 0.02, len(t) - k - 1)
    u2[k + 1:, 2] += 0.3
    y2[k + 1:] += rng.normal(0, 0.05, len(t) - k - 1)
    b = obs.run(t, u2, y2)
    np.testing.assert_array_equal(a.x[:k + 1], b.x[:k + 1])
    assert np.abs(a.x[k + 2:] - b.x[k + 2:]).max() > 1e-4        # later samples do matter
    r = run_readable(obs, t[:k + 3], u2[:k + 3], y2[:k + 3])
    np.testing.assert_allclose(r.x[:k + 1], a.x[:k + 1], rtol=0, atol=1e-10)


def test_observer_arguments_are_checked(design, quick_clean):
    """dt, substeps, design, shapes of u / y / x0, a non-uniform t and v_x <= 0 raise
    ObserverArgumentError naming the argument."""
    q = quick_clean.segment(10.0, 10.1)
    t, u, y = _protocol_data(q, q.vy)
    for dt in (0.0, -1e-3, float("nan")):
        with pytest.raises(ObserverArgumentError, match="dt must be finite and > 0"):
            to.TSPremiseObserver(design, dt)
    with pytest.raises(ObserverArgumentError, match="substeps"):
        to.TSPremiseObserver(design, q.dt, substeps=0)
    with pytest.raises(ObserverArgumentError, match="design must be a Theorem1Design"):
        to.TSPremiseObserver(object(), q.dt)
    obs = to.TSPremiseObserver(design, q.dt)
    with pytest.raises(ObserverArgumentError, match=r"u must be \(N, 3\)"):
        obs.run(t, u[:, :2], y)
    with pytest.raises(ObserverArgumentError, match=r"y must be \(N, 1\)"):
        obs.run(t, u, np.column_stack([y, y]))
    with pytest.raises(ObserverArgumentError, match="x0 must be 4 finite values"):
        obs.run(t, u, y, np.zeros(3))
    with pytest.raises(ObserverArgumentError, match="sampled every dt"):
        obs.run(t * 1.5, u, y)
    u2 = u.copy()
    u2[7, 1] = 0.0
    with pytest.raises(ObserverArgumentError, match=r"vx_mps\) must be > 0.*row 7"):
        obs.run(t, u2, y)


def test_observer_step_is_the_convex_blend_of_vertex_observers(design):
    """At a vertex premise (h = e_i) one step equals RK4 of the vertex observer i alone, and
    with y = C x on a zero input the step of the exact state x = 0 stays 0."""
    ts = design.ts
    dt = 1e-3
    x = np.array([0.2, 0.05, 1.0, -0.5])
    for i in (0, 5, 7):
        Phi = ts.A[i] - design.L[i] @ to.C_OUT
        f = lambda xx, i=i, Phi=Phi: Phi @ xx + ts.B[i][:, 0] * 0.01 + design.L[i][:, 0] * 0.3
        k1 = f(x)
        k2 = f(x + dt / 2 * k1)
        k3 = f(x + dt / 2 * k2)
        k4 = f(x + dt * k3)
        want = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        np.testing.assert_allclose(to.observer_step(design, x, ts.z_vertices[i], 0.01, 0.3, dt),
                                   want, rtol=1e-12)
    assert np.all(to.observer_step(design, np.zeros(4), ts.z_vertices[3], 0.0, 0.0, dt) == 0)


def test_observer_on_emulated_lap_noise_free(design, quick_clean):
    """Truth = full nonlinear model (exact slip (3)); observer from xhat(0) = 0 with the
    HOSMD premise. After 5 s: vy RMSE < 1e-3 m/s, force RMSE < 10 N (peaks ~3-4 kN)."""
    q = quick_clean
    run = to.run_observer(q, design)
    m = q.t > 5
    assert np.sqrt(np.mean((run.vy - q.vy)[m] ** 2)) < 1e-3
    assert np.sqrt(np.mean((run.Ff - q.Ff)[m] ** 2)) < 10
    assert np.sqrt(np.mean((run.Fr - q.Fr)[m] ** 2)) < 10
    assert not run.clipped[:, :2].any()          # slip premises stayed inside the sector


def test_bad_inputs(design, quick_clean):
    q = quick_clean.segment(0, 1)
    q.yL = None
    with pytest.raises(LogFormatError, match="yL_m"):
        to.estimate_premises(q)
    q2 = quick_clean.segment(0, 1)
    q2.vx = q2.vx.copy()
    q2.vx[5] = 0.0
    with pytest.raises(ObserverArgumentError, match="vx_mps.*row 5"):
        to.run_observer(q2, design, vy_premise=np.zeros(len(q2)))


@pytest.mark.parametrize("alpha", [-1e-3, 0.0, float("nan"), float("inf")])
def test_design_refuses_a_decay_rate_that_is_not_positive(alpha):
    """alpha <= 0 or non-finite: (33) would certify no decay (alpha < 0 even a growing error),
    the "design" would not be an observer with the bound (34); refused before any solve."""
    with pytest.raises(ObserverArgumentError, match="alpha .decay rate of .33.. must be finite"):
        to.design_theorem1(Y.ts_model(), alpha=alpha)


def test_design_refuses_bad_options():
    with pytest.raises(ObserverArgumentError, match="disk_radius"):
        to.design_theorem1(Y.ts_model(), disk_radius=-1.0)
    with pytest.raises(ObserverArgumentError, match="scale"):
        to.design_theorem1(Y.ts_model(), scale=(1.0, 1.0, 0.0, 10.0))
