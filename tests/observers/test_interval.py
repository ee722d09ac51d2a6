"""Switched TS interval observer (Ifqir 2017): bounds, TS exactness, LMI design and its
certification, and the enclosure guarantee as property tests over random stiffness
trajectories, inputs, speeds and initial boxes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from vehicle_observers.core.errors import CertificationError, InfeasibleDesign, ObserverArgumentError
from vehicle_observers.core.protocol import Observer, Trajectory, run_readable
from vehicle_observers.models import uncertain_bicycle as ub
from vehicle_observers.observers import interval as iv
from vehicle_observers_papers.ifqir_2017 import constants as pp

VEH = pp.vehicle
DT = 0.001


@pytest.fixture(scope="module")
def design():
    return pp.design()


@pytest.fixture(scope="module")
def design_single():
    return pp.design(pp.bands_single)


# ------------------------------------------------------------------ model & bounds ---------
def test_lpv_matrices_match_eq3():
    cr, cf, vx = 4.1e4, 3.9e4, 12.0
    m, Iz, lf, lr = VEH.m, VEH.I_z, VEH.l_f, VEH.l_r
    A = ub.lpv_A(1 / vx, vx, (cr, cf), VEH)
    assert A[0, 0] == pytest.approx(-(cf + cr) / (m * vx))
    assert A[0, 1] == pytest.approx((cr * lr - cf * lf) / (m * vx) - vx)
    assert A[1, 0] == pytest.approx((cr * lr - cf * lf) / (Iz * vx))
    assert A[1, 1] == pytest.approx(-(cr * lr**2 + cf * lf**2) / (Iz * vx))
    B = ub.lpv_B((cr, cf), VEH)
    np.testing.assert_allclose(B.ravel(), [cf / m, cf * lf / Iz])


def test_elementwise_bounds_exact_at_corners_and_contain_random_members():
    rng = np.random.default_rng(0)
    box = VEH.xi_box
    corners = [(a, b) for a in box[0] for b in box[1]]
    for s, v in [(1 / 0.1, 6.0), (1 / 11.0, 17.5), (1 / 6.0, 6.0)]:
        fn = lambda xi: ub.lpv_A(s, v, xi, VEH)
        lo, nom, hi = ub.elementwise_bounds(fn, box)
        Ac = np.array([fn(c) for c in corners])
        # exact: the bounds are attained at corners (not sampled, not loose)
        np.testing.assert_allclose(Ac.min(axis=0), lo, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(Ac.max(axis=0), hi, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(nom, fn(VEH.xi0), rtol=1e-12)
        xi = box[:, 0] + rng.random((2000, 2)) * (box[:, 1] - box[:, 0])
        A = np.array([fn(x) for x in xi])
        assert np.all(A >= lo - 1e-12 * np.abs(lo)) and np.all(A <= hi + 1e-12 * np.abs(hi))
        # the box is symmetric about xi_0: the nominal matrix is the midpoint (used by (11))
        np.testing.assert_allclose(nom, (lo + hi) / 2, rtol=1e-12, atol=1e-12)


def test_elementwise_bounds_rejects_non_affine():
    with pytest.raises(ValueError, match="not affine"):
        ub.elementwise_bounds(lambda xi: np.array([[xi[0] * xi[1]]]), VEH.xi_box)


def test_switched_ts_form_is_exact_in_every_band():
    model = pp.model()
    rng = np.random.default_rng(1)
    box = VEH.xi_box
    vx = rng.uniform(0.1, 17.5, 300)
    sig, h = model.memberships(vx)
    assert np.allclose(h.sum(axis=1), 1) and h.min() >= -1e-12
    for v, i, hk in zip(vx, sig, h):
        xi = box[:, 0] + rng.random(2) * (box[:, 1] - box[:, 0])
        Aj = np.array([ub.lpv_A(s, w, xi, VEH) for s, w in model.z_vertices[i]])
        np.testing.assert_allclose(np.tensordot(hk, Aj, axes=1), ub.lpv_A(1 / v, v, xi, VEH),
                                   rtol=1e-10, atol=1e-10)


def test_speed_bands_switching_law():
    b = ub.SpeedBands((0.1, 6.0, 11.0, 17.5))
    np.testing.assert_array_equal(b.mode([0.1, 5.9, 6.0, 6.0001, 11.0, 11.2, 17.5]),
                                  [0, 0, 0, 1, 1, 2, 2])
    with pytest.raises(ValueError, match=r"18 m/s at sample 1 is outside"):
        b.mode([5.0, 18.0])
    with pytest.raises(ValueError, match="strictly increasing"):
        ub.SpeedBands((0.0, 6.0))
    with pytest.raises(ValueError, match="strictly increasing"):
        ub.SpeedBands((1.0, 6.0, 6.0))


def test_membership_rate_bound_holds_along_speed_trajectories():
    model = pp.model()
    rng = np.random.default_rng(2)
    a_max = 3.0
    phi = model.membership_rate_bounds(a_max)
    t = np.arange(0, 60, DT)
    acc = a_max * np.tanh(3 * np.sin(2 * np.pi * t / 7 + rng.random()))
    vx = np.clip(0.15 + np.cumsum(acc) * DT, 0.15, 17.4)
    sig, h = model.memberships(vx)
    same = sig[1:] == sig[:-1]
    dh = np.abs(np.diff(h, axis=0)[same]) / DT
    assert np.all(dh <= phi[sig[1:][same]] * (1 + 1e-6))
    # the bound is not vacuous: some derivative reaches > 20 % of it
    assert np.max(dh / phi[sig[1:][same]]) > 0.2


# ------------------------------------------------------------------ LMI design --------------
def test_design_is_certified(design):
    model = design.model
    assert design.solution.certificate.ok
    assert design.lmi_margin > 0 and design.gamma > 0
    # L = P^-1 W from the solution
    for i in range(model.n_modes):
        for j in range(4):
            P = design.solution[f"P{i}{j}"]
            assert np.count_nonzero(P - np.diag(np.diag(P))) == 0      # diagonal P
            np.testing.assert_allclose(design.L[i, j], np.linalg.solve(P, design.solution[
                f"W{i}{j}"]), rtol=1e-12)
    # independent Metzler check recomputed from the corners of the stiffness box
    box = VEH.xi_box
    for i in range(model.n_modes):
        for j in range(4):
            s, v = model.z_vertices[i, j]
            for cr in box[0]:
                for cf in box[1]:
                    M = ub.lpv_A(s, v, (cr, cf), VEH) - design.L[i, j] @ model.C
                    assert M[0, 1] >= 0 and M[1, 0] >= 0
                    assert np.all(np.diag(M) >= -pp.epsilon_shift * (1 + 1e-6))  # (20) diag
    assert design.min_metzler_margin > 0
    # frozen-h closed loops A^+ - L C are Hurwitz (the width dynamics (13))
    for i in range(model.n_modes):
        for hk in np.random.default_rng(3).dirichlet(np.ones(4), 50):
            M = np.tensordot(hk, model.A_hi[i] - design.L[i] @ model.C, axes=1)
            assert np.linalg.eigvals(M).real.max() < 0


def test_design_gamma_minimised_per_mode(design, design_single):
    # per-mode gamma: the worst mode (highest speed) has the largest gamma, and a single
    # mode over the same speed range cannot do better than the worst switched mode
    assert design.gammas[0] < design.gammas[1] < design.gammas[2]
    assert design_single.gamma >= design.gamma * (1 - 1e-3)
    # ISS bound: V' <= -eps V + gamma |d|^2 checked on random (e, d) at a vertex
    rng = np.random.default_rng(4)
    m, i = design.model, 2
    for j in range(4):
        P = np.diag(design.P[i, j])
        Acl = m.A_hi[i, j] - design.L[i, j] @ m.C
        for _ in range(200):
            e, dd = rng.standard_normal(2), rng.standard_normal(2)
            lhs = e @ (Acl.T @ P + P @ Acl + design.eps_decay * P) @ e + 2 * e @ P @ dd
            assert lhs <= design.gammas[i] * dd @ dd + 1e-9


def test_blended_iss_margin(design, design_single):
    # the neglected cross terms P^k L^j do not break (19) at frozen blended weights
    for d in (design, design_single):
        w = iv.blended_iss_margin(d, n=500, seed=1)
        assert w < 0
        # at the vertices it is the certified (19) itself: margin >= the imposed lmi_eps
        assert w <= -0.9e-2


def test_infeasible_when_box_allows_oversteer():
    a_max = VEH.max_metzler_uncertainty()
    lr_term = VEH.c_r0 * VEH.l_r * (1 - a_max)
    assert lr_term == pytest.approx(VEH.c_f0 * VEH.l_f * (1 + a_max), rel=1e-12)
    wide = ub.UncertainBicycle(VEH.m, VEH.I_z, VEH.l_f, VEH.l_r, VEH.c_f0, VEH.c_r0,
                               rel_unc=a_max + 0.02)
    with pytest.raises(InfeasibleDesign, match=r"entry \(2,1\) of A\^- .* < 0") as ei:
        iv.design_theorem2(ub.SwitchedIntervalModel(wide, pp.bands))
    assert ei.value.lmi.startswith("Metzler")


def test_diagonal_shift_precheck_names_the_entry():
    # at 0.1 m/s, A^-_11 = -(c_f + c_r)^+ / (m 0.1) = -606.7 1/s cannot be shifted by L
    a11 = -(VEH.xi_box[:, 1].sum()) / (VEH.m * 0.1)
    with pytest.raises(InfeasibleDesign, match=r"entry \(1,1\) of A\^- = -606.7 < -epsilon = -300"):
        pp.design(epsilon_shift=300.0)
    assert a11 == pytest.approx(-606.666, rel=1e-4)
    pp.design(epsilon_shift=300.0, bands_=ub.SpeedBands((1.0, 6.0, 11.0, 17.5)))  # feasible


def test_infeasible_lmi_raises():
    # a decay rate far beyond what the uncontrollable v_y pole allows at 17.5 m/s
    with pytest.raises(InfeasibleDesign, match="infeasible"):
        pp.design(eps_decay=50.0)


def test_certify_metzler_names_the_violation(design):
    L = design.L.copy()
    L[1, 2, 0, 0] = +5.0          # positive L1 makes entry (1,2) negative
    with pytest.raises(CertificationError, match=r"mode 2, vertex 3: entry \(1,2\)"):
        iv.certify_metzler(design.model, L)


def test_dwell_time_bound(design):
    out = iv.dwell_time_bound(design)
    P = design.P
    mu = max(float(np.max(P[b, k] / P[a, j])) for a, b in ((0, 1), (1, 0), (1, 2), (2, 1))
             for j in range(4) for k in range(4))
    assert out["mu"] == pytest.approx(mu) and out["mu"] >= 1
    assert out["dwell_time_s"] == pytest.approx(np.log(mu) / design.eps_decay)


# ------------------------------------------------------------------ observer ---------------
def _drive(n, seed=0, v0=2.0, v1=16.0):
    """Speeds crossing every band, steering and a yaw rate of the LPV model (N,) at DT."""
    t = np.arange(n) * DT
    vx = v0 + (v1 - v0) * t / t[-1]
    u = 0.04 * np.sin(2 * np.pi * 0.7 * t)
    xi = ub.random_stiffness_trajectory(VEH, n, DT, seed=seed, corr_time=0.3)
    X = ub.simulate_lpv(VEH, [0.1, -0.02], u, vx, xi, DT)
    return t, vx, u, X


def test_observer_protocol_readable_step_equals_compiled_run(design):
    """The contract: run_readable (the numpy Euler step of implemented_rhs (11), mode and
    weights (7) from model.memberships) equals the compiled run, with steering and gyro noise
    bounds, speeds crossing the bands and clipped outside them. Tolerance 1e-10 absolute on
    bounds of order 0.1-1 (observed ~1e-15): the readable step blends the vertex matrices
    with tensordot and the memberships with numpy, the kernel in loops, so each step differs
    by a few ulps; the width dynamics are stable (A^+ - L C Hurwitz), so they do not grow."""
    t, vx, u, X = _drive(3000)
    vx = vx.copy()
    vx[100:120] = 20.0                                   # above the bands: clipped
    uu = np.column_stack([vx, u])
    obs = iv.IntervalObserver(design, DT, ([-0.5, -0.1], [0.5, 0.1]), steer_noise=1e-3,
                              y_noise=2e-3, clip_speed=True)
    assert isinstance(obs, Observer) and obs.design.certificate.ok
    run = obs.run(t, uu, X[:, 1])
    ref = run_readable(obs, t, uu, X[:, 1])
    np.testing.assert_allclose(run.lo, ref.lo, rtol=0, atol=1e-10)
    np.testing.assert_allclose(run.hi, ref.hi, rtol=0, atol=1e-10)
    np.testing.assert_allclose(run.x, ref.x, rtol=0, atol=1e-10)
    assert isinstance(run, Trajectory) and run.names == iv.STATE_NAMES
    assert run.x_lo is run.lo and run.n_clipped == 20 and run.substeps == 1
    np.testing.assert_array_equal(run.width, run.hi - run.lo)
    # default x0 = [0, y_0]: the box is centred on the measured yaw rate
    np.testing.assert_array_equal(run.lo[0], [-0.5, X[0, 1] - 0.1])
    # the function front end gives the same numbers (with u^+- = delta +- steer_noise)
    f = iv.run_interval_observer(design, DT, np.clip(vx, 0.1, 17.5), u - 1e-3, u + 1e-3,
                                 X[:, 1], run.lo[0], run.hi[0], y_noise=2e-3)
    np.testing.assert_array_equal(f.lo, run.lo)
    np.testing.assert_array_equal(f.hi, run.hi)


def test_observer_is_causal(design):
    """Changing every sample after k leaves the bounds up to k unchanged, bit for bit."""
    t, vx, u, X = _drive(2000)
    obs = iv.IntervalObserver(design, DT, ([-0.5, -0.1], [0.5, 0.1]), steer_noise=1e-3)
    uu = np.column_stack([vx, u])
    a = obs.run(t, uu, X[:, 1])
    k = 900
    u2, y2 = uu.copy(), X[:, 1].copy()
    u2[k + 1:, 1] += 0.02
    u2[k + 1:, 0] = 12.0
    y2[k + 1:] -= 0.05
    b = obs.run(t, u2, y2)
    np.testing.assert_array_equal(a.lo[:k + 1], b.lo[:k + 1])
    np.testing.assert_array_equal(a.hi[:k + 1], b.hi[:k + 1])
    assert np.abs(a.hi[k + 2:] - b.hi[k + 2:]).max() > 1e-4


def test_implemented_rhs_with_gyro_noise_widens_by_L_vbar(design):
    """The noise term of (11): with |y - r| <= v_bar each bound moves by |L_h| v_bar."""
    m = design.model
    sig, h = m.memberships([8.3])
    xl, xh = np.array([-0.3, -0.02]), np.array([0.2, 0.05])
    f0 = iv.implemented_rhs(design, int(sig[0]), h[0], xh, xl, 0.01, 0.01, 0.02)
    f1 = iv.implemented_rhs(design, int(sig[0]), h[0], xh, xl, 0.01, 0.01, 0.02, y_noise=0.003)
    Lh = np.abs(np.tensordot(h[0], design.L[int(sig[0])][..., 0], axes=1))
    np.testing.assert_allclose(f1[0] - f0[0], Lh * 0.003, rtol=1e-12)
    np.testing.assert_allclose(f0[1] - f1[1], Lh * 0.003, rtol=1e-12)


def test_width_converges_to_zero_without_uncertainty():
    exact = ub.UncertainBicycle(VEH.m, VEH.I_z, VEH.l_f, VEH.l_r, VEH.c_f0, VEH.c_r0, 0.0)
    d = pp.design(veh=exact)
    t = np.arange(0, 20, DT)
    vx = 3 + 12 * (1 - np.cos(2 * np.pi * t / 20)) / 2
    u = 0.03 * np.sin(2 * np.pi * 0.3 * t)
    X = ub.simulate_lpv(exact, [0.1, 0.0], u, vx, exact.xi0, DT)
    res = iv.run_interval_observer(d, DT, vx, u, u, X[:, 1], [-1, -0.5], [1, 0.5])
    assert np.all(res.x_lo <= X + 1e-12) and np.all(X <= res.x_hi + 1e-12)
    assert res.width[-1].max() < 1e-6 * res.width[0].max()


@pytest.mark.parametrize("dt", [0.0, -1e-3, float("nan"), float("inf")])
def test_sample_period_must_be_positive(design, dt):
    """dt <= 0 used to integrate backwards in time (widths of 6e18 m/s): refused, named."""
    v = np.full(10, 8.0)
    with pytest.raises(ObserverArgumentError, match="dt .sample period. must be finite and > 0"):
        iv.run_interval_observer(design, dt, v, v * 0, v * 0, v * 0, [0, 0], [1, 1])
    with pytest.raises(ObserverArgumentError, match="dt .sample period. must be finite"):
        iv.IntervalObserver(design, dt, ([0, 0], [1, 1]))
    with pytest.raises(ObserverArgumentError, match="dt .sample period. must be finite"):
        iv.euler_substeps(design, dt)


@pytest.mark.parametrize("eps", [-1.0, 0.0, float("nan"), float("inf")])
def test_decay_rate_must_be_positive(eps):
    """A negative decay rate of (19) certified a growing width: refused before any solve."""
    with pytest.raises(ObserverArgumentError, match="eps_decay .decay rate of .19.. must be"):
        pp.design(eps_decay=eps)


def test_observer_arguments_are_checked(design):
    t, vx, u, X = _drive(50)
    uu = np.column_stack([vx, u])
    with pytest.raises(ObserverArgumentError, match="design must be an IntervalDesign"):
        iv.IntervalObserver(design.model, DT, ([0, 0], [1, 1]))
    with pytest.raises(ObserverArgumentError, match="box0 must be two finite"):
        iv.IntervalObserver(design, DT, ([1, 0], [0, 1]))
    with pytest.raises(ObserverArgumentError, match="y_noise must be finite and >= 0"):
        iv.IntervalObserver(design, DT, ([0, 0], [1, 1]), y_noise=-1.0)
    obs = iv.IntervalObserver(design, DT, ([0, 0], [1, 1]))
    with pytest.raises(ObserverArgumentError, match=r"u must be \(N, 2\)"):
        obs.run(t, vx, X[:, 1])
    with pytest.raises(ObserverArgumentError, match=r"y must be \(N, 1\)"):
        obs.run(t, uu, X)
    with pytest.raises(ObserverArgumentError, match="x0 must be 2 finite values"):
        obs.run(t, uu, X[:, 1], [0.0, np.nan])
    with pytest.raises(ObserverArgumentError, match="sampled every dt"):
        obs.run(t * 2, uu, X[:, 1])


def test_bad_inputs_raise_clear_errors(design):
    v = np.full(10, 8.0)
    with pytest.raises(ValueError, match="u_lo has 9 samples, expected 10"):
        iv.run_interval_observer(design, DT, v, v[:9], v, v, [0, 0], [1, 1])
    with pytest.raises(ValueError, match=r"u_lo\[0\] = 1.0 > u_hi\[0\] = 0.0"):
        iv.run_interval_observer(design, DT, v, np.ones(10), np.zeros(10), v, [0, 0], [1, 1])
    with pytest.raises(ValueError, match="x0_lo <= x0_hi"):
        iv.run_interval_observer(design, DT, v, v, v, v, [1, 0], [0, 1])
    vv = v.copy()
    vv[3] = 30.0
    with pytest.raises(ValueError, match="30 m/s at sample 3 is outside"):
        iv.run_interval_observer(design, DT, vv, v, v, v, [0, 0], [1, 1])
    res = iv.run_interval_observer(design, DT, vv, v * 0, v * 0, v * 0, [0, 0], [1, 1],
                                   clip_speed=True)
    assert res.n_clipped == 1
    with pytest.raises(ValueError, match="breaks the discrete positivity"):
        iv.run_interval_observer(design, 0.01, v, v * 0, v * 0, v * 0, [0, 0], [1, 1],
                                 substeps=1)
    bad = v.copy()
    bad[2] = np.nan
    with pytest.raises(ValueError, match=r"y\[2\] = nan is not finite"):
        iv.run_interval_observer(design, DT, v, v, v, bad, [0, 0], [1, 1])


def test_random_stiffness_trajectory_in_box_and_seeded():
    box = VEH.xi_box
    for corners in (False, True):
        a = ub.random_stiffness_trajectory(VEH, 5000, DT, seed=7, corners=corners)
        b = ub.random_stiffness_trajectory(VEH, 5000, DT, seed=7, corners=corners)
        np.testing.assert_array_equal(a, b)
        assert np.all(a >= box[:, 0]) and np.all(a <= box[:, 1])
    c = ub.random_stiffness_trajectory(VEH, 5000, DT, seed=7, corners=True)
    assert set(np.unique(c[:, 0])) <= set(box[0])


# ------------------------------------------------------------------ the guarantee ----------
def _scenario(data, n):
    """Speed, steering and stiffness trajectories drawn by hypothesis."""
    t = np.arange(n) * DT
    v0 = data.draw(st.floats(0.2, 17.0), label="v0")
    v1 = data.draw(st.floats(0.2, 17.0), label="v1")
    vx = v0 + (v1 - v0) * np.clip(t / max(t[-1], DT), 0, 1)        # crosses bands
    amp = data.draw(st.floats(0.0, 0.08), label="steer amplitude")
    f = data.draw(st.floats(0.05, 3.0), label="steer frequency")
    ph = data.draw(st.floats(0, 6.3), label="phase")
    step = data.draw(st.booleans(), label="steering steps")
    u = amp * (np.sign(np.sin(2 * np.pi * f * t + ph)) if step else np.sin(2 * np.pi * f * t
                                                                           + ph))
    kind = data.draw(st.sampled_from(["constant", "random", "corners", "fast corners"]),
                     label="stiffness")
    seed = data.draw(st.integers(0, 2**31 - 1), label="seed")
    box = VEH.xi_box
    if kind == "constant":
        fr = data.draw(st.tuples(st.floats(0, 1), st.floats(0, 1)), label="xi fraction")
        xi = box[:, 0] + np.array(fr) * (box[:, 1] - box[:, 0])
    elif kind == "random":
        xi = ub.random_stiffness_trajectory(VEH, n, DT, seed=seed, corr_time=0.3)
    else:
        tc = 0.2 if kind == "corners" else 0.003
        xi = ub.random_stiffness_trajectory(VEH, n, DT, seed=seed, corr_time=tc, corners=True)
    return vx, u, xi


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_enclosure_guarantee_property(design, data):
    """x^- <= x <= x^+ at every sample for the LPV model (Euler, T_s = 1 ms) with any
    stiffness trajectory in the box, bounded inputs and any x0 in the initial box.

    Tolerance: floating-point rounding only (1e-9 (1 + |x|)): the truth and the bounds
    are computed by different operation orders, and hypothesis finds cases where they
    coincide exactly (zero-width initial box, stiffness at a corner)."""
    n = 2500
    vx, u, xi = _scenario(data, n)
    c = np.array([data.draw(st.floats(-1.0, 1.0)), data.draw(st.floats(-0.5, 0.5))])
    hw = np.array([data.draw(st.floats(0.0, 1.0)), data.draw(st.floats(0.0, 0.5))])
    fr = np.array([data.draw(st.floats(0, 1)), data.draw(st.floats(0, 1))])
    x0 = c - hw + 2 * hw * fr
    un = data.draw(st.floats(0.0, 0.01), label="steering uncertainty")
    # the measured steering is u + noise with |noise| <= un; the truth sees u
    noise = un * np.sin(np.arange(n) * 0.37)
    um = u + noise
    X = ub.simulate_lpv(VEH, x0, u, vx, xi, DT)
    res = iv.run_interval_observer(design, DT, vx, um - un, um + un, X[:, 1], c - hw, c + hw)
    tol = 1e-9 * (1 + np.abs(X))
    assert np.all(res.x_lo <= X + tol), "lower bound above the state"
    assert np.all(X <= res.x_hi + tol), "upper bound below the state"


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_enclosure_with_bounded_yaw_rate_noise(design_single, data):
    """Same guarantee for the single-mode observer with a noisy gyro |y - r| <= v_bar."""
    n = 2500
    vx, u, xi = _scenario(data, n)
    vbar = data.draw(st.floats(0.0, 0.01), label="gyro noise bound")
    seed = data.draw(st.integers(0, 2**31 - 1))
    X = ub.simulate_lpv(VEH, [0.2, -0.05], u, vx, xi, DT)
    y = X[:, 1] + vbar * np.random.default_rng(seed).uniform(-1, 1, n)
    res = iv.run_interval_observer(design_single, DT, vx, u, u, y, [0, -0.1], [0.5, 0.1],
                                   y_noise=vbar)
    tol = 1e-9 * (1 + np.abs(X))
    assert np.all(res.x_lo <= X + tol) and np.all(X <= res.x_hi + tol)


def test_non_metzler_gain_breaks_enclosure():
    """Negative control: the same run with L1 > A12 (entry (1,2) of A - L C negative) loses
    the enclosure, so the property tests above can fail. Exact stiffness (no slack from the
    uncertainty) and a state on the lower face of the initial box make it immediate."""
    exact = ub.UncertainBicycle(VEH.m, VEH.I_z, VEH.l_f, VEH.l_r, VEH.c_f0, VEH.c_r0, 0.0)
    good = pp.design(veh=exact)
    t = np.arange(0, 2, DT)
    vx = np.full_like(t, 12.0)
    u = 0.04 * np.sin(2 * np.pi * 0.5 * t)
    X = ub.simulate_lpv(exact, [0.0, 0.0], u, vx, exact.xi0, DT)
    box = ([0.0, -0.1], [1.0, 0.1])
    res = iv.run_interval_observer(good, DT, vx, u, u, X[:, 1], *box)
    assert np.all(res.x_lo <= X + 1e-12) and np.all(X <= res.x_hi + 1e-12)
    bad = iv.IntervalDesign(good.model, good.L.copy(), good.P, good.gamma, good.eps_decay,
                            good.epsilon_shift, good.phi, None, good.metzler_margins, 0.0)
    bad.L[..., 0, 0] = 40.0
    with pytest.raises(CertificationError, match="not Metzler"):
        iv.certify_metzler(bad.model, bad.L)
    res = iv.run_interval_observer(bad, DT, vx, u, u, X[:, 1], *box)
    assert np.any(res.x_lo[:, 0] > X[:, 0] + 1e-6)


def test_continuous_truth_also_enclosed(design):
    """Against the continuous-time LPV model (RK4, 10 substeps) the Euler observer is not a
    theorem; on this 30 s run with time-varying stiffness it still encloses every sample."""
    t = np.arange(0, 30, DT)
    vx = 1 + 15 * (1 - np.cos(2 * np.pi * t / 30)) / 2
    u = 0.05 * np.sin(2 * np.pi * 0.4 * t) * np.sin(2 * np.pi * 0.05 * t)
    xi = ub.random_stiffness_trajectory(VEH, len(t), DT, seed=11, corr_time=0.5)
    X = ub.simulate_lpv(VEH, [0.0, 0.0], u, vx, xi, DT, substeps=10, method="rk4")
    res = iv.run_interval_observer(design, DT, vx, u, u, X[:, 1], [-0.2, -0.1], [0.2, 0.1])
    assert np.all(res.x_lo <= X) and np.all(X <= res.x_hi)
