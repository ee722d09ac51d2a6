"""Yacine 2015 chain: curvature (11), premise (26), Theorem 1 (33) certified, observer (31),
forces (46), bound (34)."""

import numpy as np
import pytest
from vehicle_observers.core.errors import InfeasibleDesign, LogFormatError
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


@pytest.fixture(scope="module")
def ts_exact(quick_clean):
    """Noise-free truth of the model the TS form represents exactly ((13) with slip (4)),
    replayed from the curve entry (t = 12 s) so the differentiators start mid-transient."""
    log = scenarios.replay(quick_clean.segment(12.0, 40.0), exact_slip=False)
    log.t = log.t - log.t[0]
    return log


def test_theorem1_is_certified_with_paper_bounds(design):
    ts = design.ts
    assert ts.n_rules == 8
    np.testing.assert_allclose(sorted(set(ts.z_vertices[:, 2])), [Y.vx_min, Y.vx_max])
    np.testing.assert_allclose(sorted(set(ts.z_vertices[:, 1])), [Y.M_f2, Y.M_f1])
    np.testing.assert_allclose(sorted(set(ts.z_vertices[:, 0])), [Y.M_r2, Y.M_r1])
    assert design.alpha == 1e-3
    assert design.solution.certificate.ok and design.certificate_original.ok
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


def test_observer_matches_numpy_reference(design, quick_clean):
    """The numba loop against the readable numpy step :func:`observer_step` (31), first 2 s."""
    q = quick_clean.segment(10.0, 12.0)
    vyp = q.vy + 0.01
    x = np.array([0.1, 0, 0.5, -0.5])
    run = to.run_observer(q, design, vy_premise=vyp, x0=x)
    ts = design.ts
    z = np.clip(to.ts_premises(vyp, q.yaw_rate, q.delta, q.vx), ts.zmin, ts.zmax)
    np.testing.assert_allclose(run.z, z, rtol=1e-12)
    for k in range(len(q)):
        np.testing.assert_allclose(run.x[k], x, rtol=1e-9, atol=1e-9)
        x = to.observer_step(design, x, z[k], q.delta[k], q.yaw_rate[k], q.dt)
    Ff, Fr = lateral.forces_from_transformed(run.x[:, 2], run.x[:, 3], P)
    np.testing.assert_allclose(run.Ff, Ff)
    np.testing.assert_allclose(run.Fr, Fr)


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


def test_bound_34_holds_on_ts_exact_truth(design, ts_exact):
    """Theory check of Theorem 1: noise-free run whose truth is (13)+(4) (exactly the TS form
    inside the sector), observer started 2.9 away; the error norm stays below the bound at
    every sample (ISS form (40) with the measured delta(t) of (30), and the paper's two-branch
    form with T = the differentiator's convergence time)."""
    log = ts_exact
    pe = to.estimate_premises(log)
    x0 = np.array([0.5, 0.1, 2.0, -2.0])
    run = to.run_observer(log, design, pe, x0=x0)
    xt = lateral.to_transformed(np.column_stack([log.vy, log.yaw_rate, log.Ff, log.Fr]), P)
    zt = to.ts_premises(log.vy, log.yaw_rate, log.delta, log.vx)
    ts = design.ts
    assert np.all((zt >= ts.zmin) & (zt <= ts.zmax))        # truth inside the sector
    full, dl = to.premise_mismatch(ts, xt, log.delta, zt, run.z)
    assert np.abs(full[:, :2]).max() < 1e-12                # only Gamma-rows, as in (29)
    en = np.linalg.norm(xt - run.x, axis=1)
    dn = np.linalg.norm(dl, axis=1)
    T = to.convergence_time(log.t, pe.vy - log.vy, band=1e-3)
    b = to.bound_34(log.t, en[0], dn, T, design)
    assert np.all(en < b["iss"]) and np.all(en < b["paper"])
    assert en[0] > 2.5 and en[log.t > 5].max() < 1e-3        # and the error did converge


def test_bad_inputs(design, quick_clean):
    q = quick_clean.segment(0, 1)
    q.yL = None
    with pytest.raises(LogFormatError, match="yL_m"):
        to.estimate_premises(q)
    q2 = quick_clean.segment(0, 1)
    q2.vx = q2.vx.copy()
    q2.vx[5] = 0.0
    with pytest.raises(ValueError, match="vx_mps.*row 5"):
        to.run_observer(q2, design, vy_premise=np.zeros(len(q2)))


def test_convergence_time_modes():
    t = np.arange(0.0, 10.0, 0.01)
    err = np.where(t < 2.0, 1.0, 0.0)
    err[(t > 6.0) & (t < 6.5)] = 1.0            # a later excursion (re-convergence)
    assert to.convergence_time(t, err, 0.5, mode="first") == pytest.approx(2.0)
    assert to.convergence_time(t, err, 0.5, mode="last") == pytest.approx(6.5)
    assert np.isnan(to.convergence_time(t, np.ones_like(t), 0.5, mode="first"))
    with pytest.raises(ValueError, match="mode"):
        to.convergence_time(t, err, 0.5, mode="mid")
