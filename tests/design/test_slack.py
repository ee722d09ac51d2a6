"""The slack / fuzzy-Lyapunov synthesis of the layer (design.slack), its data certificate
(certify.certify_slack_observer) and the unknown-input error system with measurement
feedthrough (design.uio.uio_system): theory, an independent cvxpy formulation, planted
mistakes, bad input."""

import cvxpy as cp
import numpy as np
import pytest
from vehicle_observers.core.errors import CertificationError, ObserverArgumentError
from vehicle_observers.design import slack
from vehicle_observers.design.certify import certify_slack_observer, hinf_norm
from vehicle_observers.design.constraints import BoundedReal, Decay, L2Gain, SpectralDisk
from vehicle_observers.design.synthesis import ObserverSynthesis
from vehicle_observers.design.system import PolytopicSystem
from vehicle_observers.design.uio import uio_system

C1 = np.array([[1.0, 0.0]])
A_V = np.array([[[0.0, 1.0], [-2.0, -1.0]], [[0.0, 1.0], [-5.0, -0.5]]])
E_V = np.array([[0.0, 0.0], [1.0, 0.0]])
D_V = np.array([[0.0, 0.1]])


def _system(phi=2.0):
    return PolytopicSystem(A_V, C1, E=E_V, D=D_V, rate_bounds=[phi, phi], name="two-vertex")


def test_slack_min_gamma_matches_an_independent_cvxpy_formulation():
    """El Youssfi 2020 Theorem 2 (two vertices, h_2' = -h_1', signs +-phi) written here
    directly in cvxpy: the layer's minimum gamma agrees to the solver's accuracy, and its
    design backed off by 5 % is certified from the data with every vertex's H-infinity norm
    below its gamma. Catches a wrong block in the layer (checked by planting each: the
    P_h' term left out, a wrong Finsler scalar in the L2 blocks, the slack disk posed in
    the quadratic form)."""
    phi, mu, alpha, R = 2.0, 0.05, 0.2, 20.0
    s = _system(phi)
    syn = slack.SlackSynthesis(s, [L2Gain(alpha), SpectralDisk(R)], lyapunov="slack", mu=mu,
                               eps=1e-8, order="constraint")
    des = syn.solve("gamma", raise_on_violation=False)
    n, nw = 2, 2
    P = [cp.Variable((n, n), symmetric=True) for _ in range(2)]
    G = cp.Variable((n, n))
    W = [cp.Variable((n, 1)) for _ in range(2)]
    g = cp.Variable(nonneg=True)
    cons = [P[0] >> 1e-8 * np.eye(n), P[1] >> 1e-8 * np.eye(n)]
    for i in range(2):
        GN = G @ A_V[i] - W[i] @ C1
        GB = G @ E_V - W[i] @ D_V
        for sgn in (1.0, -1.0):
            M = cp.bmat([
                [sgn * phi * (P[0] - P[1]) + 2 * alpha * P[i] + GN + GN.T,
                 P[i] - G + mu * GN.T, GB, np.eye(n)],
                [P[i] - G.T + mu * GN, -mu * (G + G.T), mu * GB, np.zeros((n, n))],
                [GB.T, mu * GB.T, -g * np.eye(nw), np.zeros((nw, n))],
                [np.eye(n), np.zeros((n, n)), np.zeros((n, nw)), -np.eye(n)]])
            cons.append((M + M.T) / 2 << -1e-8 * np.eye(3 * n + nw))
    for i in range(2):
        X = (G @ A_V[i] - W[i] @ C1) / R
        Dk = cp.bmat([[P[i], X.T], [X, G + G.T - P[i]]])
        cons.append((Dk + Dk.T) / 2 >> 1e-8 * np.eye(2 * n))
    prob = cp.Problem(cp.Minimize(g), cons)
    prob.solve(solver="CLARABEL")
    assert prob.status == cp.OPTIMAL
    assert des.gamma == pytest.approx(np.sqrt(g.value), rel=1e-5)
    opt = syn.minimise(backoff=0.05)
    assert opt.optimum == des.gamma and opt.status == "certified" and opt.margin > 1e-9
    assert max(opt.design.certificate.hinf.values()) <= opt.value
    assert [c.name for c in opt.design.certificate.lmi.checks][2:] == [
        "l2[1,+]", "l2[1,-]", "l2[2,+]", "l2[2,-]", "disk[1]", "disk[2]"]


def test_slack_with_small_mu_contains_the_quadratic_design():
    """Remark 1 of El Youssfi 2020: with P_i = G = P the slack LMI is the quadratic one plus
    mu/2 [N B]^T P [N B], so for mu small the relaxed optimum is no worse than the quadratic
    one, with two vertices (rate bound 0.5) and with one. Catches a slack form more
    conservative than the quadratic one (Remark 1 broken); it does not pin the slack blocks
    themselves (a sign-flipped P_i - G block passes here; the independent cvxpy formulation
    pins them)."""
    cons = [L2Gain(0.2), SpectralDisk(20.0)]
    kw = {"raise_on_violation": False}
    s = _system(phi=0.5)
    quad = slack.SlackSynthesis(s, cons, lyapunov="quadratic").solve("gamma", **kw)
    # the strictness eps is imposed on -mu (G + G^T) too: kept well below mu
    rel = slack.SlackSynthesis(s, cons, lyapunov="slack", mu=1e-6, eps=1e-11).solve("gamma",
                                                                                   **kw)
    assert rel.gamma <= quad.gamma * (1 + 1e-5)
    one = PolytopicSystem(A_V[:1], C1, E=E_V, D=D_V)
    q1 = slack.SlackSynthesis(one, cons).solve("gamma", **kw)
    r1 = slack.SlackSynthesis(one, cons, lyapunov="slack", mu=1e-6, eps=1e-11).solve("gamma",
                                                                                     **kw)
    assert r1.gamma <= q1.gamma * (1 + 1e-5)


def test_quadratic_l2_equals_bounded_real_lemma_without_feedthrough():
    """With alpha = 0 and Dz = 0 the squared L2 form (g = gamma^2, -I block) and the layer's
    bounded-real lemma (-gamma I blocks) have the same optimum gamma (Boyd et al. 1994,
    Sec. 6.3.2: congruent forms of one inequality)."""
    s = _system()
    a = slack.SlackSynthesis(s, [L2Gain()], gains="common").solve("gamma",
                                                                   raise_on_violation=False)
    b = ObserverSynthesis(s, [BoundedReal()], gains="common").solve("gamma",
                                                                    raise_on_violation=False)
    assert a.gamma == pytest.approx(b.gamma, rel=1e-4)


def test_spectral_disk_and_decay_hold_on_the_poles():
    """Decay(alpha) + SpectralDisk(R), quadratic and slack: every frozen error pole has
    Re < -alpha and |lambda| < R (from the gains, not the LMIs)."""
    for lyap, mu in (("quadratic", None), ("slack", 0.01)):
        des = slack.SlackSynthesis(_system(), [Decay(1.0), SpectralDisk(8.0)], lyapunov=lyap,
                                   mu=mu).solve()
        for i in range(2):
            ev = np.linalg.eigvals(A_V[i] - des.L[i] @ C1)
            assert ev.real.max() < -1.0 and np.abs(ev).max() < 8.0
        assert des.status == "certified"


def test_planted_wrong_vertex_is_violated_by_the_data_certificate(monkeypatch):
    """A builder mistake in the layer (every vertex's LMI posed with vertex 1's A): the
    solver and the builders' own re-evaluation agree, the certificate rebuilt from the vertex
    data calls it 'violated' and names the LMI of vertex 2."""
    A2 = np.array([[[0.0, 1.0], [-2.0, -1.0]], [[1.0, 1.0], [0.0, 3.0]]])   # vertex 2 unstable
    s = PolytopicSystem(A2, C1, E=E_V, D=D_V, rate_bounds=[1.0, 1.0])
    real = slack.SlackSynthesis.matrix

    def wrong(self, c, V, i, s=()):
        sy = self.system
        self.system = PolytopicSystem(sy.A[[0, 0]], sy.C, E=sy.E, D=sy.D, Dz=sy.Dz,
                                      rate_bounds=sy.rate_bounds)
        try:
            return real(self, c, V, i, s)
        finally:
            self.system = sy
    monkeypatch.setattr(slack.SlackSynthesis, "matrix", wrong)
    syn = slack.SlackSynthesis(s, [L2Gain(0.0, gamma=50.0)], lyapunov="slack", mu=0.01)
    with pytest.raises(CertificationError, match=r"l2\[2"):
        syn.solve()
    des = syn.solve(raise_on_violation=False)
    assert des.solution.certificate.ok                 # the builders certify themselves
    assert des.status == "violated"


def test_planted_swapped_gains_are_violated():
    """Gains of the two vertices swapped after the solve: the data certificate (which
    recomputes W_i = G L_i from the gains) says 'violated'."""
    A2 = np.array([[[0.0, 1.0], [-2.0, -1.0]], [[1.0, 1.0], [0.0, 3.0]]])
    s = PolytopicSystem(A2, C1, E=E_V, D=D_V, rate_bounds=[1.0, 1.0])
    syn = slack.SlackSynthesis(s, [L2Gain(0.5), SpectralDisk(20.0)], lyapunov="slack",
                               mu=0.01)
    des = syn.minimise().design
    assert des.status == "certified"
    bad = certify_slack_observer(syn, des.P, des.L[::-1], G=des.G, gamma=des.gamma)
    assert bad.status == "violated"


def test_uio_error_system_with_feedthrough_matches_the_observer_built_by_hand():
    """The UIO error system of uio_system (E~ = T E - T A H D, D~ = (I - C H) D,
    Dz~ = -H D) against the plant and the observer z' = N z + G u + L y, xhat = z + H y
    assembled by hand: the transfer from w to e = x - xhat agrees at several frequencies, and
    the unknown input d does not reach e. Catches the feedthrough of the estimate (H y reads
    the noise) left out, as the layer did before."""
    A = np.array([[-1.0, 1.0, 0.0], [0.0, -2.0, 1.0], [0.5, 0.0, -3.0]])
    F = np.array([[0.0], [1.0], [0.0]])
    C = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    E = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    D = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    s, dec = uio_system(PolytopicSystem(A, C, E=E, D=D), F)
    K = np.array([[1.0, 0.5], [0.2, 1.0], [0.0, 2.0]])
    N, L, _ = dec.gains(A, np.zeros((3, 0)), K, C)
    # closed loop of (x, z): x' = A x + F d + E w, z' = N z + L (C x + D w)
    Acl = np.block([[A, np.zeros((3, 3))], [L @ C, N]])
    Bw = np.vstack([E, L @ D])
    Bd = np.vstack([F, np.zeros((3, 1))])
    Ce = np.hstack([np.eye(3) - dec.H @ C, -np.eye(3)])      # e = x - z - H (C x + D w)
    De = -dec.H @ D
    Ae, Be, Cz, Dz = s.error_system(0, K)
    for w in (0.0, 0.7, 3.0):
        Z = 1j * w * np.eye(6) - Acl
        direct = Ce @ np.linalg.solve(Z, Bw) + De
        layer = Cz @ np.linalg.solve(1j * w * np.eye(3) - Ae, Be) + Dz
        np.testing.assert_allclose(layer, direct, atol=1e-12)
        np.testing.assert_allclose(Ce @ np.linalg.solve(Z, Bd), 0.0, atol=1e-12)
    assert hinf_norm(Ae, Be, Cz, Dz) > 0


def test_rank_condition_failing_is_one_clear_error():
    """rank(C F) < rank(F): one ObserverArgumentError, one line, naming the rank condition
    (no traceback from deep inside the solver)."""
    A = np.array([[-1.0, 1.0], [0.0, -2.0]])
    with pytest.raises(ObserverArgumentError) as exc:
        uio_system(PolytopicSystem(A, np.array([[1.0, 0.0]])), np.array([[0.0], [1.0]]))
    msg = str(exc.value)
    assert "rank(C F) = 0 != rank(F) = 1" in msg and "\n" not in msg


def test_bad_input_is_one_clear_error():
    s = _system()
    with pytest.raises(ObserverArgumentError, match="mu > 0"):
        slack.SlackSynthesis(s, [L2Gain()], lyapunov="slack")
    with pytest.raises(ObserverArgumentError, match="rate_bounds"):
        slack.SlackSynthesis(PolytopicSystem(A_V, C1, E=E_V), [L2Gain()], lyapunov="slack",
                             mu=0.1)
    with pytest.raises(ObserverArgumentError, match="common C and D"):
        slack.SlackSynthesis(PolytopicSystem(A_V, [C1, 2 * C1], E=E_V), [L2Gain()])
    with pytest.raises(ObserverArgumentError, match="unknown constraint"):
        slack.SlackSynthesis(s, [BoundedReal()])
    with pytest.raises(ObserverArgumentError, match="Dz"):
        ObserverSynthesis(PolytopicSystem(A_V, C1, E=E_V, Dz=np.ones((2, 2))), [BoundedReal()])
    with pytest.raises(ObserverArgumentError, match="gamma"):
        slack.SlackSynthesis(s, [Decay(0.1)]).solve("gamma")
    assert slack.sign_patterns(3) == [(1, 1), (1, -1), (-1, 1), (-1, -1)]


def test_three_vertices_use_every_sign_pattern_of_the_rate_box():
    """Three vertices: P_h' = sum_{k<3} h_k' (P_k - P_3) over the box |h_k'| <= phi_k gives
    2^2 sign patterns per vertex, 12 decay LMIs named decay[i,++] ... decay[i,--], rebuilt
    by the data certificate with the same names; the design is certified and every frozen
    vertex decays at alpha. Catches a wrong enumeration of the patterns (a missing one
    leaves a corner of the rate box unchecked)."""
    A3 = np.array([[[0.0, 1.0], [-2.0, -1.0]], [[0.0, 1.0], [-5.0, -0.5]],
                   [[0.5, 1.0], [-3.0, 0.0]]])
    s = PolytopicSystem(A3, C1, rate_bounds=[1.0, 2.0, 3.0])
    syn = slack.SlackSynthesis(s, [Decay(0.5), SpectralDisk(30.0)], lyapunov="slack", mu=0.02)
    des = syn.solve()
    names = [c.name for c in des.certificate.lmi.checks if c.name.startswith("decay")]
    assert names == [f"decay[{i}," + sg + "]" for i in (1, 2, 3)
                     for sg in ("++", "+-", "-+", "--")]
    assert sorted(names) == sorted(c for c in syn.lmi_design().constraint_names
                                   if c.startswith("decay"))
    assert des.status == "certified"
    for i in range(3):
        assert np.linalg.eigvals(A3[i] - des.L[i] @ C1).real.max() < -0.5


def test_time_scaled_system_keeps_the_l2_gain():
    """PolytopicSystem.time_scaled(tau): A, B, E times tau leave the L2 gain unchanged (the
    time axis is stretched, the signals' energies scale alike), so the minimum gamma of the
    scaled and unscaled problems agree, and the scaled gain maps back by K = K~ / tau with the
    frozen error poles divided by tau. Catches E left unscaled (gamma would change by
    sqrt(tau)) and a gain mapped back the wrong way."""
    s = _system()
    tau = 0.05
    kw = {"raise_on_violation": False}
    a = slack.SlackSynthesis(s, [L2Gain()], gains="common").solve("gamma", **kw)
    st = s.time_scaled(tau)
    b = slack.SlackSynthesis(st, [L2Gain()], gains="common").solve("gamma", **kw)
    assert b.gamma == pytest.approx(a.gamma, rel=1e-4)
    K = b.L[0] / tau
    for i in range(2):
        np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A_V[i] - K @ C1)),
                                   np.sort_complex(np.linalg.eigvals(st.A[i] - b.L[0] @ C1))
                                   / tau, rtol=1e-9)
        assert hinf_norm(A_V[i] - K @ C1, E_V - K @ D_V, s.H) <= a.gamma * (1 + 1e-3)
