"""Ifqir 2017 constants against the slides' printed numbers, and what the printed solution
tells about the reconstruction (vertex ordering, Metzler structure)."""

from __future__ import annotations

import numpy as np
import pytest
from vehicle_observers.models import uncertain_bicycle as ub
from vehicle_observers.observers import interval as iv
from vehicle_observers_papers.ifqir_2017 import constants as pp
from vehicle_observers_papers.ifqir_2017 import evaluation as ev
from vehicle_observers_papers.ifqir_2017 import printed_solution as ps
from vehicle_observers_papers.yacine_2015 import constants as yc

VEH = pp.vehicle


@pytest.fixture(scope="module")
def design():
    return pp.design()


def test_printed_values_transcribed():
    P, L = pp.P_printed, pp.L_printed
    assert P.shape == (3, 4, 2) and L.shape == (3, 4, 2)
    # spot checks against the slides (first, middle and last printed entries)
    assert P[0, 0].tolist() == [0.0080, 0.0205] and P[0, 2, 1] == 0.3545
    assert P[1, 3].tolist() == [0.2870, 0.5521] and P[2, 1, 1] == 0.3171
    assert L[0, 0].tolist() == pytest.approx([-0.0136e3, 4.3830e3])
    assert L[0, 1].tolist() == pytest.approx([-0.0078e3, 4.3813e3])
    assert L[1, 0].tolist() == [-11.1729, 153.0217] and L[2, 3].tolist() == [-14.0961, 316.8263]
    assert pp.bands_printed == (0.0, 6.0, 11.0, 16.6)
    assert pp.rel_unc == 0.10


def test_vehicle_is_yacine_car_with_box_from_its_tyre_bounds():
    v = pp.vehicle
    assert (v.m, v.I_z, v.l_f, v.l_r) == (1500.0, 2454.0, 1.1, 1.44)
    box = v.xi_box                      # rows (c_r, c_f)
    assert box[1, 1] == pytest.approx(yc.M_f1) and box[0, 1] == pytest.approx(yc.M_r1)
    assert box[1, 0] == pytest.approx(0.9 / 1.1 * yc.M_f1)
    # inner band edges as printed in (22)
    assert pp.bands.edges[1:3] == pp.bands_printed[1:3]


def test_printed_structure_diagonal_positive_P_and_gain_signs():
    assert np.all(pp.P_printed > 0)
    # Metzler entry (1,2) of A - L C is A12 - L1 with A12 ~ -v_x: needs L1 < 0; L2 > 0
    assert np.all(pp.L_printed[..., 0] < 0) and np.all(pp.L_printed[..., 1] > 0)


def test_printed_gains_are_metzler_for_this_vehicle_with_vx_as_fast_index():
    """The printed L1 of modes 2-3 satisfy L1^j <= A^-_12 at vertex j of our reconstruction
    (bands 6-11, 11-16.6 m/s, vertex order with v_x as the fast index); the other ordering
    violates it -- support for the documented ordering."""
    m = ub.SwitchedIntervalModel(pp.vehicle, ub.SpeedBands((3.0, 6.0, 11.0, 16.6)))
    A12 = m.A_lo[1:, :, 0, 1]
    L1 = pp.L_printed[1:, :, 0]
    assert np.all(L1 <= A12)
    assert not np.all(L1 <= A12[:, [0, 2, 1, 3]])
    # the printed L1 shifts by about -(v_max - v_min) between the v_max and v_min vertices,
    # as A12 = ... - v_x does: mode 2 (5 m/s): 4.94, 4.92; mode 3 (5.6 m/s): 5.46, 5.47
    d = L1[:, [1, 3]] - L1[:, [0, 2]]
    np.testing.assert_allclose(d, [[5.0, 5.0], [5.6, 5.6]], rtol=0.05)


def _A_lo_by_hand(z, veh):
    """Element-wise lower bound of A(rho, xi) (3)-(4) over the stiffness box at the premise
    vertex z = (1/v_x, v_x), written out entry by entry (each entry is affine in c_r, c_f):
    a11, a22 are smallest at the largest stiffnesses, a12, a21 at (c_r^-, c_f^+)."""
    s, v = z
    (crl, crh), (cfl, cfh) = veh.xi_box
    m, Iz, lf, lr = veh.m, veh.I_z, veh.l_f, veh.l_r
    return np.array([[-(cfh + crh) / m * s, (crl * lr - cfh * lf) / m * s - v],
                     [(crl * lr - cfh * lf) / Iz * s, -(crh * lr**2 + cfh * lf**2) / Iz * s]])


def test_designed_gains_certified_by_hand(design):
    """The Theorem 2 design re-certified without the solver or the model's own bounds:
    A^- by hand at every premise vertex; A^- - L C Metzler (Theorem 1); its diagonal above
    -epsilon (20) with the closed form epsilon_min = max -(A^- - L C)_aa; (17)-(19) rebuilt
    with numpy from P, W = P L, M_i, gamma_i and phi, and their eigenvalues on the right side
    of the imposed strictness margin 1e-2."""
    m, veh = design.model, design.model.veh
    A_lo = np.array([[_A_lo_by_hand(z, veh) for z in zz] for zz in m.z_vertices])
    np.testing.assert_allclose(m.A_lo, A_lo, rtol=1e-12, atol=1e-12)
    L = design.L[..., 0]                                   # (3, 4, 2)
    M = A_lo.copy()
    M[..., :, 1] -= L                                      # C = [0 1]: L C = [[0, L1], [0, L2]]
    assert M[..., 0, 1].min() >= 0 and M[..., 1, 0].min() >= 0          # Metzler
    np.testing.assert_allclose(design.metzler_margins, np.minimum(M[..., 0, 1], M[..., 1, 0]))
    eps_min = (-np.diagonal(M, axis1=2, axis2=3)).max(axis=(1, 2))
    np.testing.assert_allclose(ps.min_epsilon_shift(m, L), eps_min, rtol=1e-12)
    assert np.all(eps_min <= pp.epsilon_shift * (1 + 1e-6))
    # (17)-(19) from the numbers, per mode i and vertex j
    I2 = np.eye(2)
    C = np.array([[0.0, 1.0]])
    for i in range(3):
        Mi = design.solution[f"M{i}"]
        Pk = [np.diag(design.P[i, k]) for k in range(4)]
        for j in range(4):
            P, W = Pk[j], Pk[j] @ design.L[i, j]
            assert np.linalg.eigvalsh(P).min() >= 1.0 - 1e-6                      # (17), P >= I
            assert np.linalg.eigvalsh(Pk[j] + Mi).min() >= 0.99e-2                # (18)
            Ap = m.A_hi[i, j]
            Lam = Ap.T @ P + P @ Ap - C.T @ W.T - W @ C                            # (21)
            S = Lam + design.eps_decay * P + sum(design.phi[i, k] * (Pk[k] + Mi) for k in range(4))
            blk = np.block([[S, P], [P, -design.gammas[i] * I2]])
            assert np.linalg.eigvalsh((blk + blk.T) / 2).max() <= -0.99e-2        # (19)
            # the element-wise (20) in its P-scaled form, as the solver saw it
            X = P @ A_lo[i, j] - W @ C + pp.epsilon_shift * P
            assert X.min() >= -1e-6 * np.abs(X).max()


def test_half_of_the_designed_gains_sit_on_a_bound_of_20(design):
    """Known structure of the min sum gamma_i solution: at vertices 1-2 of every mode (the
    vertices with 1/v_x = 1/v_max) L1 is on the Metzler bound (A^- - L C)_12 = 0 (within the
    imposed 1e-3 / P) and L2 on the epsilon bound L2 = epsilon + A^-_22; at vertices 3-4 on
    neither. So there the gains' size is set by epsilon and the band edges: the shift of L1
    from vertex 1 (v_max) to vertex 2 (v_min) is A^-_12(2) - A^-_12(1) = v_max - v_min."""
    m = design.model
    M = m.A_lo - design.L @ m.C
    e = np.asarray(pp.bands.edges)
    assert np.all(M[:, :2, 0, 1] < 1e-2) and np.all(M[:, 2:, 0, 1] > 0.1)
    np.testing.assert_allclose(design.L[:, :2, 1, 0], pp.epsilon_shift + m.A_lo[:, :2, 1, 1],
                               rtol=1e-3)
    assert np.all(-M[:, 2:, 1, 1] < 0.9 * pp.epsilon_shift)
    np.testing.assert_allclose(design.L[:, 1, 0, 0] - design.L[:, 0, 0, 0], e[1:] - e[:-1],
                               atol=1e-2)


def test_vertex_polarity_of_inv_vx_is_the_one_closer_to_the_printed_gains():
    """The slides do not say which vertices carry the upper bound of ``1/v_x``. The chosen
    polarity (``pp.inv_vx_upper_first``) gives designed gains closer to the printed ones
    (mean |log10 L/L_printed| over the 3 modes) and the printed pattern of mode 1: the two
    largest L2 at vertices 1-2 (printed 4383, 4381 against 261, 272); the other polarity
    puts them at vertices 3-4."""
    chosen = pp.design()
    other = pp.design(inv_vx_upper_first=not pp.inv_vx_upper_first)
    lr = lambda d: float(np.abs(np.log10(np.abs(d.L[..., 0]) / np.abs(pp.L_printed))).mean())
    assert lr(chosen) < lr(other) - 0.1
    assert set(np.argsort(pp.L_printed[0, :, 1])[-2:]) == {0, 1}
    assert set(np.argsort(chosen.L[0, :, 1, 0])[-2:]) == {0, 1}
    assert set(np.argsort(other.L[0, :, 1, 0])[-2:]) == {2, 3}
    # chosen: vertices 1-2 carry the lower bound 1/v_max of every band, 3-4 the upper one
    m = pp.model()
    assert not pp.inv_vx_upper_first
    np.testing.assert_allclose(m.z_vertices[:, :2, 0], m.zmin[:, None, 0].repeat(2, 1))
    np.testing.assert_allclose(m.z_vertices[:, 2:, 0], m.zmax[:, None, 0].repeat(2, 1))
    # both polarities describe the same TS model: blended A equals A(rho) at any speed
    v = np.array([0.3, 4.0, 7.5, 12.0, 17.0])
    for mod in (m, pp.model(inv_vx_upper_first=True)):
        sig, h = mod.memberships(v)
        A = np.einsum("nj,njab->nab", h, mod.A_nom[sig])
        want = np.array([ub.lpv_A(1 / x, x, pp.vehicle.xi0, pp.vehicle) for x in v])
        np.testing.assert_allclose(A, want, rtol=1e-12, atol=1e-9)


# ------------------------------------------------------------------ observer (11) as printed --
def test_implemented_rhs_equals_slides_form(design):
    """The library's observer (11) (implemented_rhs: M^+ pos - M^- neg with the exact
    interval product of B u) equals the slides' printed right-hand sides for u >= 0."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        i = int(rng.integers(0, 3))
        hk = rng.dirichlet(np.ones(4))
        xh, xl = rng.normal(0, 1, 2), rng.normal(0, 1, 2)
        y, u = rng.normal(0, 0.3), abs(rng.normal(0, 0.05))
        fs = ps.slides_rhs(design, i, hk, xh, xl, y, u, u)
        fi = iv.implemented_rhs(design, i, hk, xh, xl, y, u, u)
        np.testing.assert_allclose(fi[0], fs[0], rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(fi[1], fs[1], rtol=1e-10, atol=1e-9)


def test_interval_metrics():
    xl = np.zeros((4, 2))
    xh = np.ones((4, 2))
    res = iv.IntervalRun(np.arange(4.0), (xl + xh) / 2, iv.STATE_NAMES, xl, xh, sigma=np.zeros(4, int))
    truth = np.array([[0.5, 0.5], [2.0, 0.5], [0.5, -1.0], [0.5, 0.5]])
    m = ev.interval_metrics(res, truth)
    assert m["enclosure_vy"] == 0.75 and m["enclosure_r"] == 0.75
    assert m["max_excursion_vy"] == 1.0 and m["width_mean_r"] == 1.0
    m2 = ev.interval_metrics(res, truth, mask=np.array([True, False, False, True]))
    assert m2["enclosure_vy"] == 1.0



# ------------------------------------------------------------------ printed-solution checks --
def test_min_epsilon_shift_known_answer():
    """With L = 0 the (20) shift is the largest |diagonal| of A^- over the box corners:
    entry (1,1) or (2,2) at the vertex with 1/v_x = 1/v_min and the largest stiffness."""
    m = pp.model()
    eps = ps.min_epsilon_shift(m, np.zeros((3, 4, 2)))
    e = np.asarray(pp.bands.edges)
    cr, cf = VEH.xi_box[0, 1], VEH.xi_box[1, 1]
    want = [max((cf + cr) / VEH.m, (cr * VEH.l_r**2 + cf * VEH.l_f**2) / VEH.I_z) / v
            for v in e[:-1]]
    np.testing.assert_allclose(eps, want, rtol=1e-12)
    # a gain L2 = g at every vertex adds g to the (2,2) entry
    L = np.zeros((3, 4, 2))
    L[..., 1] = 500.0
    d22 = (cr * VEH.l_r**2 + cf * VEH.l_f**2) / VEH.I_z / e[:-1] + 500.0
    np.testing.assert_allclose(ps.min_epsilon_shift(m, L), np.maximum(want, d22), rtol=1e-12)
    with pytest.raises(ValueError, match=r"L must be \(3, 4, 2\)"):
        ps.min_epsilon_shift(m, np.zeros((2, 4, 2)))


def test_certify_solution_of_a_design_reaches_its_gamma(design):
    """A design's own P, L (not rescaled: p_min = its own min P per mode) are feasible for
    the fixed-P problem with the same strictness margin (its M works) and optimal, so the
    certified gamma_i equals the design's; rescaled to min P = 1 they stay certified."""
    pm = design.P.min(axis=(1, 2))
    c = ps.certify_solution(design.model, design.P, design.L[..., 0], pp.eps_decay,
                            pp.accel_max, p_min=pm)
    assert c.solution.certificate.ok and c.lmi_margin >= 0.99e-2
    np.testing.assert_allclose(c.scale, 1.0)
    # same optimum: fixing P, W at the optimal values leaves gamma_i where the design put it
    # (to the interior-point solver's accuracy; observed differences ~1e-5 relative)
    np.testing.assert_allclose(c.gammas, design.gammas, rtol=1e-4)
    c = ps.certify_solution(design.model, design.P, design.L[..., 0], pp.eps_decay,
                            pp.accel_max)
    np.testing.assert_allclose(c.scale, 1.0 / pm)
    assert c.solution.certificate.ok
    np.testing.assert_allclose(c.metzler_margins, design.metzler_margins)
    assert np.all(c.min_epsilon <= pp.epsilon_shift * (1 + 1e-6))
    with pytest.raises(ValueError, match="P_diag must be positive"):
        ps.certify_solution(design.model, -design.P, design.L[..., 0])
    with pytest.raises(ValueError, match=r"L must be \(3, 4, 2\)"):
        ps.certify_solution(design.model, design.P, design.L)


def test_settling_time_known_answers():
    t = np.arange(0.0, 10.0, 0.001)
    w_ref = np.full_like(t, 0.3)
    w = w_ref + np.exp(-t / 0.5)                 # 2 % at t = 0.5 ln 50
    assert ev.settling_time(t, w, w_ref) == pytest.approx(0.5 * np.log(50), abs=2e-3)
    assert ev.settling_time(t, w, w_ref, frac=0.1) == pytest.approx(0.5 * np.log(10), abs=2e-3)
    # a late bump above the threshold moves the settling time behind it
    w2 = w.copy()
    w2[(t > 4.0) & (t < 4.5)] += 0.05
    assert ev.settling_time(t, w2, w_ref) == pytest.approx(4.5, abs=2e-3)
    # never settles within the record (constant or growing effect)
    assert ev.settling_time(t, w_ref + 1.0, w_ref) == float("inf")
    assert ev.settling_time(t, w_ref + 1 + t, w_ref) == float("inf")
    # gone after the first step / no initial-box effect at all
    w3 = w_ref.copy()
    w3[0] += 1.0
    assert ev.settling_time(t, w3, w_ref) == pytest.approx(0.001)
    assert ev.settling_time(t, w_ref, w_ref) == 0.0
    with pytest.raises(ValueError, match="equal length"):
        ev.settling_time(t, w[:-1], w_ref)
    with pytest.raises(ValueError, match=r"frac must be in \(0, 1\)"):
        ev.settling_time(t, w, w_ref, frac=1.5)
