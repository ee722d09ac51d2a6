"""The observer-synthesis layer: vertex data -> LMIs -> optimise/back off -> certificate
rebuilt from the data. Known answers, an independent cvxpy formulation, the H-infinity norm
against python-control, planted mistakes, bad input."""

import control
import cvxpy as cp
import numpy as np
import pytest
from vehicle_observers.core.errors import CertificationError, ObserverArgumentError
from vehicle_observers.design import synthesis
from vehicle_observers.design.certify import certify_observer, hinf_norm
from vehicle_observers.design.constraints import BoundedReal, Decay, InRegion, Metzler
from vehicle_observers.design.lmi import LMIDesign, disk, ellipse, sector, strip, unit_disk
from vehicle_observers.design.synthesis import ObserverSynthesis
from vehicle_observers.design.system import PolytopicSystem
from vehicle_observers.design.uio import decoupling, slack_decay_lmi, uio_system

C1 = np.array([[1.0, 0.0]])
A_V = [np.array([[0.0, 1.0], [-2.0, -1.0]]), np.array([[0.0, 1.0], [-5.0, -0.5]])]


def test_planted_closure_capture_is_violated_by_the_data_certificate():
    """The classic loop mistake (every builder captures the last vertex) yields a solution
    the builder certificate calls 'certified'; the certificate rebuilt from the vertex data
    must call it 'violated' and name vertex 1."""
    A0 = np.array([[0.0, 1.0], [3.0, 0.0]])          # unstable vertex, observable from x1
    A1 = -np.eye(2)
    system = PolytopicSystem([A0, A1], C1)
    d = LMIDesign("closure bug")
    d.symmetric("P", 2)
    d.matrix("K0", (2, 1))
    d.positive("P - P_lower I > 0", lambda V: V.P - np.eye(2))
    for i, A in enumerate([A0, A1]):
        d.negative(f"decay[{i + 1}]", lambda V: (V.P @ A - V.K0 @ C1) + (V.P @ A - V.K0 @ C1).T)
    d.extra(lambda V: [V.K0 == 0])                    # a gain that only suits vertex 2
    sol = d.solve()
    assert sol.certificate.status == "certified"      # the closures certify themselves
    syn = ObserverSynthesis(system, [Decay(0.0)])
    L = np.linalg.solve(sol["P"], sol["K0"])[None]
    cert = certify_observer(syn, sol["P"], L)
    assert cert.status == "violated"
    assert cert.lmi.worst().name == "decay[1]" and cert.lmi.worst().margin < 0


def test_planted_wrong_vertex_in_the_layer_is_caught(monkeypatch):
    """If the layer's own builder used the wrong vertex, the data certificate (which does not
    call the builders) rejects the solution with an error naming the LMI."""
    A0 = np.array([[0.0, 1.0], [3.0, 0.0]])
    system = PolytopicSystem([A0, -np.eye(2)], C1)
    real = synthesis.pair_matrix

    def wrong(c, s, P, K, i, V, **kw):
        return real(c, s, P, K, s.q - 1, V, **kw)     # always the last vertex
    monkeypatch.setattr(synthesis, "pair_matrix", wrong)
    syn = ObserverSynthesis(system, [Decay(0.0)], gain_bound=1e-6)
    with pytest.raises(CertificationError, match="decay\\[1\\]"):
        syn.solve()


def test_max_decay_equals_the_unobservable_mode_and_backoff_certifies():
    """Known answer: the unobservable pair -1 +- 2j cannot be moved, the observable mode can:
    the largest certified decay rate is 1. The backed-off design is certified with a margin
    well above round-off; the result carries optimum, value and margin."""
    A = np.array([[0.5, 0, 0], [0, -1.0, 2.0], [0, -2.0, -1.0]])
    s = PolytopicSystem(A, np.array([[1.0, 0, 0]]))
    opt = ObserverSynthesis(s, [Decay(0.0)]).maximise_decay(hi=3.0, tol=1e-3, backoff=0.05)
    assert opt.optimum == pytest.approx(1.0, abs=2e-3)
    assert opt.value == pytest.approx(0.95 * opt.optimum)
    assert opt.status == "certified" and opt.margin > 1e-6
    assert opt.design.certificate.max_pole_real < -0.95 * opt.optimum + 1e-9


def test_min_gamma_scalar_analytic_and_against_independent_cvxpy():
    """Scalar plant x' = a x + w1, y = x + w2, z = e: ||T|| = sqrt(1 + L^2)/(L - a), minimal
    at L = -1/a with gamma* = 1/sqrt(1 + a^2) (a = -1: 0.70711). The layer's min gamma and an
    independent cvxpy formulation (written here) agree with it."""
    a = -1.0
    s = PolytopicSystem([[a]], [[1.0]], E=[[1.0, 0.0]], D=[[0.0, 1.0]])
    opt = ObserverSynthesis(s, [BoundedReal()]).minimise(backoff=0.02)
    assert opt.optimum == pytest.approx(1 / np.sqrt(2), rel=1e-5)
    assert opt.design.status == "certified"
    assert opt.design.L[0, 0, 0] > 0
    # independent formulation (no layer code): P > 0, Y = P L
    P, Y, g = cp.Variable((1, 1)), cp.Variable((1, 1)), cp.Variable()
    X = P * a - Y
    M = cp.bmat([[X + X.T, P, -Y, np.eye(1)], [P, -g * np.eye(1), np.zeros((1, 1)), np.zeros((1, 1))],
                 [-Y.T, np.zeros((1, 1)), -g * np.eye(1), np.zeros((1, 1))],
                 [np.eye(1), np.zeros((1, 1)), np.zeros((1, 1)), -g * np.eye(1)]])
    cp.Problem(cp.Minimize(g), [P >> 1e-9, (M + M.T) / 2 << 0]).solve(solver="CLARABEL")
    assert opt.optimum == pytest.approx(g.value, rel=1e-5)


def test_polytopic_min_gamma_matches_independent_cvxpy_two_vertices():
    """Two vertices, common gain: the layer's gamma* equals a hand-written cvxpy problem."""
    E = np.array([[0.0, 0.0], [1.0, 0.0]])
    D = np.array([[0.0, 1.0]])
    s = PolytopicSystem(A_V, C1, E=E, D=D)
    opt = ObserverSynthesis(s, [BoundedReal()]).minimise()
    P = cp.Variable((2, 2), symmetric=True)
    Y = cp.Variable((2, 1))
    g = cp.Variable()
    cons = [P >> 1e-9 * np.eye(2)]
    for A in A_V:
        X = P @ A - Y @ C1
        B = P @ E - Y @ D
        M = cp.bmat([[X + X.T, B, np.eye(2)], [B.T, -g * np.eye(2), np.zeros((2, 2))],
                     [np.eye(2), np.zeros((2, 2)), -g * np.eye(2)]])
        cons.append((M + M.T) / 2 << 0)
    cp.Problem(cp.Minimize(g), cons).solve(solver="CLARABEL")
    assert opt.optimum == pytest.approx(g.value, rel=1e-4)
    # the frozen vertex norms of the certified design are below its gamma (Hamiltonian)
    c = opt.design.certificate
    assert c.hinf and all(v <= opt.value for v in c.hinf.values())


@pytest.mark.parametrize("discrete", [False, True])
def test_hamiltonian_hinf_matches_python_control(discrete):
    """The certificate's H-infinity norm (own Hamiltonian bisection) against python-control's
    (a different implementation) on seeded random stable systems."""
    rng = np.random.default_rng(3)
    for _ in range(5):
        A = rng.normal(size=(3, 3))
        if discrete:
            A = 0.9 * A / max(abs(np.linalg.eigvals(A)))
        else:
            A = A - (max(np.linalg.eigvals(A).real) + 0.3) * np.eye(3)
        B, C = rng.normal(size=(3, 2)), rng.normal(size=(2, 3))
        ref = control.norm(control.ss(A, B, C, np.zeros((2, 2)), 1 if discrete else 0), p="inf")
        assert hinf_norm(A, B, C, discrete=discrete) == pytest.approx(ref, rel=1e-5)


@pytest.mark.parametrize("region, inside, outside", [
    (strip(-3.0, -1.0), [-2 + 5j], [-0.5, -3.5]),
    (strip(half_width=2.0), [-1 + 1.5j, 3.0], [-1 + 2.5j]),
    (ellipse(2.0, 1.0, center=-3.0), [-3 + 0.9j, -4.9], [-3 + 1.1j, -0.9]),
    (unit_disk(0.5), [0.3 + 0.3j], [0.4 + 0.4j]),
])
def test_region_presets_contain_what_their_definition_says(region, inside, outside):
    """Point-wise membership of each preset equals its geometric definition."""
    assert region.contains(inside).all()
    assert not region.contains(outside).any()


def test_region_design_puts_every_vertex_pole_in_the_regions():
    """Decay + sector + disk on two vertices: the certified design's poles (recomputed)
    satisfy each region; an impossible region (the unobservable pole outside) is infeasible."""
    s = PolytopicSystem(A_V, C1)
    des = ObserverSynthesis(s, [Decay(1.0), InRegion(sector(np.radians(60))),
                                InRegion(disk(30.0))]).solve()
    ev = np.concatenate([np.linalg.eigvals(A - des.L[0] @ C1) for A in A_V])
    assert des.status == "certified"
    assert np.all(ev.real < -1) and np.all(abs(ev) < 30)
    assert np.all(np.abs(ev.imag) < -ev.real * np.tan(np.radians(60)))


def test_thresholds_are_per_call():
    """The same solution is 'certified' with the default thresholds and 'inconclusive' when the
    caller demands a relative margin it does not have."""
    s = PolytopicSystem(A_V, C1)
    des = ObserverSynthesis(s, [Decay(0.5)]).solve()
    m = des.certificate.lmi.min_relative_margin
    assert des.status == "certified"
    strict = ObserverSynthesis(s, [Decay(0.5)]).solve(min_relative_margin=10 * m)
    assert strict.status == "inconclusive"


def test_pdc_relaxations_hold_for_blended_systems():
    """PDC with vertex-dependent C_i (Tuan 2001 and Tanaka 1998 relaxations): for random
    memberships h the blended error matrix sum h_i h_j (A_i - L_j C_i) satisfies the Lyapunov
    inequality with the designed P (what the relaxation must guarantee)."""
    Cs = [np.array([[1.0, 0.0]]), np.array([[1.0, 0.3]])]
    s = PolytopicSystem(A_V, Cs)
    rng = np.random.default_rng(0)
    for relax in ("tuan", "tanaka"):
        des = ObserverSynthesis(s, [Decay(0.2)], gains="pdc", relaxation=relax).solve()
        assert des.status == "certified"
        for h in rng.dirichlet([0.5, 0.5], 200):
            Acl = sum(h[i] * h[j] * (A_V[i] - des.L[j] @ Cs[i]) for i in range(2)
                      for j in range(2))
            X = des.P @ Acl
            assert np.linalg.eigvalsh(X + X.T + 0.4 * des.P).max() < 0


def test_metzler_design_gives_a_cooperative_error():
    """Interval-observer structure: diagonal P and A_i - L C Metzler at every vertex."""
    # C = [1 0] moves column 1 only: (1,2) must already be >= 0, (2,1) < 0 needs l2 <= -2
    A = [np.array([[-2.0, 1.0], [-1.0, -3.0]]), np.array([[-2.5, 0.5], [-2.0, -3.0]])]
    s = PolytopicSystem(A, C1)
    des = ObserverSynthesis(s, [Decay(0.1), Metzler(margin=1e-3)], P="diagonal").solve()
    for Ai in A:
        M = Ai - des.L[0] @ C1
        assert M[0, 1] >= 0 and M[1, 0] >= 0
    assert des.L[0, 1, 0] <= -2.0
    assert np.count_nonzero(des.P - np.diag(np.diag(des.P))) == 0


def test_discrete_time_design_is_schur_and_contracts():
    """Discrete time: Decay(alpha) is |z| < exp(-alpha dt); the poles obey it."""
    A = np.array([[1.0, 0.1], [0.0, 1.0]])
    s = PolytopicSystem(A, C1, time="discrete", dt=0.1)
    des = ObserverSynthesis(s, [Decay(2.0)]).solve()
    assert np.abs(np.linalg.eigvals(A - des.L[0] @ C1)).max() < np.exp(-0.2)


def test_uio_decoupling_and_rank_condition():
    """H C F = F, T F = 0; the rank condition rank(CF) = rank(F) is checked with a clear
    error; the decoupled design rejects the unknown input exactly (error independent of d)."""
    A = np.array([[-1.0, 1.0, 0.0], [0.0, -2.0, 1.0], [0.0, 0.0, -3.0]])
    F = np.array([[0.0], [1.0], [0.0]])
    C = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    dec = decoupling(F, C)
    np.testing.assert_allclose(dec.H @ C @ F, F, atol=1e-12)
    assert dec.residual < 1e-12
    with pytest.raises(ObserverArgumentError, match="rank"):
        decoupling(F, np.array([[1.0, 0.0, 0.0]]))
    s, dec = uio_system(PolytopicSystem(A, C), F)
    des = ObserverSynthesis(s, [Decay(0.5)]).solve()
    N, L, _ = dec.gains(A, np.zeros((3, 0)), des.L[0], C)
    assert np.linalg.eigvals(N).real.max() < -0.5
    # error dynamics e' = N e + (T F) d: T F = 0 so d does not enter
    np.testing.assert_allclose(dec.T @ F, 0.0, atol=1e-12)
    np.testing.assert_allclose(N, dec.T @ A - des.L[0] @ C)


def test_slack_lmi_implies_the_quadratic_one():
    """Finsler form: with G = P, W = P K, and mu small, the slack LMI holds whenever the
    quadratic one does; and any (P, G, W) meeting it gives He(P (A - K C)) + 2 a P < 0."""
    s = PolytopicSystem(A_V[0], C1)
    des = ObserverSynthesis(s, [Decay(0.5)]).solve()
    P, K = des.P, des.L[0]
    M = slack_decay_lmi(P, P, P @ K, A_V[0], C1, 0.5, 1e-4)
    assert np.linalg.eigvalsh((M + M.T) / 2).max() < 0
    Acl = A_V[0] - K @ C1
    T = np.hstack([np.eye(2), Acl.T])
    Q = T @ M @ T.T
    np.testing.assert_allclose(Q, P @ Acl + Acl.T @ P + P, atol=1e-9)


def test_bad_input_is_one_clear_error():
    """Shapes, NaN, unknown constraint, Metzler without diagonal P: each a clear error."""
    with pytest.raises(ObserverArgumentError, match="vertex 2 has NaN"):
        PolytopicSystem([np.eye(2), np.full((2, 2), np.nan)], C1)
    with pytest.raises(ObserverArgumentError, match="columns"):
        PolytopicSystem(np.eye(2), np.ones((1, 3)))
    with pytest.raises(ObserverArgumentError, match="unknown constraint"):
        ObserverSynthesis(PolytopicSystem(np.eye(2), C1), ["decay"])
    with pytest.raises(ObserverArgumentError, match="diagonal"):
        ObserverSynthesis(PolytopicSystem(np.eye(2), C1), [Metzler()])
    with pytest.raises(ObserverArgumentError, match="not stable"):
        PolytopicSystem(np.diag([1.0, -1.0]), [[0.0, 1.0]]).check_detectable()


def test_parametric_map_matches_one_design_per_point():
    """The map built once with cvxpy Parameters gives, point for point, the status of a
    separately posed ObserverSynthesis (catches a wrong parametric formulation)."""
    s = PolytopicSystem(A_V, C1)
    alphas, radii = np.array([0.5, 3.0, 8.0]), np.array([3.0, 12.0])
    m = synthesis.decay_disk_map(s, alphas, radii)
    for ia, a in enumerate(alphas):
        for ir, R in enumerate(radii):
            try:
                st = ObserverSynthesis(s, [Decay(a), InRegion(disk(R))]).solve(
                    raise_on_violation=False).status
            except Exception:
                st = "infeasible"
            assert (m["status"][ia, ir] == "certified") == (st == "certified"), (a, R)
    assert (m["status"] == "certified").any() and (m["status"] == "infeasible").any()


def test_paper_designs_data_certificate_agrees_with_builder_certificate():
    """Yacine 2015 Theorem 1 (33) and Ichalal 2011 (23)+(35)-(36) as layer calls: every LMI's
    margin rebuilt in numpy from the data equals the margin of the builder re-evaluated at
    the solution (two implementations of the same matrices)."""
    from vehicle_observers.design.lmi import halfplane
    from vehicle_observers.observers.ts_premise import theorem1_synthesis
    from vehicle_observers_papers.yacine_2015 import constants as yc

    A = np.array([[0.5, 0, 0], [0, -1.0, 2.0], [0, -2.0, -1.0]])
    dmvt = ObserverSynthesis(PolytopicSystem([A, A + 0.1 * np.eye(3)], [[1.0, 0, 0]]),
                             [Decay(0.0, label="(23)"), InRegion(halfplane(0.5)),
                              InRegion(disk(5.0))], gains="pairs", n_gains=2)
    for syn, obj in ((theorem1_synthesis(yc.ts_model()), "c"), (dmvt, None)):
        des = syn.solve(objective=obj)
        built = {c.name: c for c in des.solution.certificate.checks}
        data = {c.name: c for c in des.certificate.lmi.checks}
        common = [k for k in built if k in data]
        assert len(common) >= len(built) - 1
        for k in common:
            assert data[k].margin == pytest.approx(built[k].margin, rel=1e-5, abs=1e-9), k
