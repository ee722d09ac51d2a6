"""Discrete-time observer synthesis of the layer: the Stein / discrete bounded-real forms and
the parameter-dependent (poly-quadratic) slack form of design.slack (de Oliveira, Bernussou &
Geromel 1999; Daafouz & Bernussou 2001), their data certificate
(certify.certify_slack_observer), and the discrete-time positivity constraint
(constraints.Nonnegative) of ObserverSynthesis: independent cvxpy formulations, theory checks,
planted mistakes, bad input."""

import cvxpy as cp
import numpy as np
import pytest
from vehicle_observers.core.errors import (
    CertificationError,
    InfeasibleDesign,
    ObserverArgumentError,
)
from vehicle_observers.design import slack
from vehicle_observers.design.certify import certify_observer, certify_slack_observer, hinf_norm
from vehicle_observers.design.constraints import (
    BoundedReal,
    Decay,
    L2Gain,
    Metzler,
    Nonnegative,
    SpectralDisk,
)
from vehicle_observers.design.synthesis import ObserverSynthesis
from vehicle_observers.design.system import PolytopicSystem

DT = 0.1                                                      # sample period [s]
A2 = np.array([[[0.9, 0.3], [-0.2, 0.7]], [[1.1, 0.2], [0.1, 0.6]]])
C2 = np.array([[1.0, 0.0]])
E2 = np.array([[0.1, 0.0], [0.2, 0.0]])
D2 = np.array([[0.0, 0.05]])
H2 = np.array([[1.0, 0.0]])
DZ2 = np.array([[0.0, 0.2]])


def _l2_system():
    return PolytopicSystem(A2, C2, E=E2, D=D2, H=H2, Dz=DZ2, time="discrete", dt=DT,
                           name="discrete two-vertex")


def _embedded(F):
    """Three states, y = x1: the measured state is not driven by (x2, x3), so the error of
    (x2, x3) obeys F_i whatever the gain (up to the coupling from e1, which the gain can
    cancel): A_i = [[0.5, 0, 0], [1, F_i], [0, F_i]] block-wise, C = [1 0 0]."""
    A = np.zeros((len(F), 3, 3))
    for i, Fi in enumerate(F):
        A[i, 0, 0] = 0.5
        A[i, 1, 0] = 1.0
        A[i, 1:, 1:] = Fi
    return PolytopicSystem(A, np.array([[1.0, 0.0, 0.0]]), time="discrete", dt=DT,
                           name="embedded pair")


# F1, F2: each Schur, no common quadratic Lyapunov function (spectral-radius bound of one
# common P: 1.035 > 1), a poly-quadratic one (0.915 < 1); found here by a seeded search over
# 2 x 2 matrices with one decimal, properties checked below independently of the layer.
F_PQ = [np.array([[-0.2, -0.3], [0.8, 1.1]]), np.array([[0.8, -0.1], [0.8, 0.6]])]
# each Schur (eigenvalues 0.5), switching between them unstable: rho(F1 F2) = 1.082 > 1
F_SW = [np.array([[0.5, 0.8], [0.0, 0.5]]), np.array([[0.5, 0.0], [0.8, 0.5]])]


# ---- independent formulations (written here, not taken from the layer) ---------------------
def _cvxpy_l2(system, alpha, pd):
    """min g = gamma^2 of the discrete L2 design, blocks ordered (e_{k+1}, e_k, w, z) (the
    layer orders them (e_k, w, e_{k+1}, z)); pd: P_i per vertex, slack G, every pair (i, j);
    else one P with W_i = P K_i."""
    q, n, nw = system.q, system.n, system.nw
    nz = system.H.shape[0]
    r2 = np.exp(-2 * alpha * system.dt)
    P = [cp.Variable((n, n), symmetric=True) for _ in range(q if pd else 1)]
    G = cp.Variable((n, n)) if pd else P[0]
    W = [cp.Variable((n, system.p)) for _ in range(q)]
    g = cp.Variable(nonneg=True)
    cons = [Pk >> 1e-8 * np.eye(n) for Pk in P]
    for i in range(q):
        X = G @ system.A[i] - W[i] @ system.C[i]
        Y = G @ system.E[i] - W[i] @ system.D[i]
        Pi = P[i] if pd else P[0]
        for j in (range(q) if pd else [0]):
            nxt = (P[j] - G - G.T) if pd else -P[0]
            M = cp.bmat([[nxt, X, Y, np.zeros((n, nz))],
                         [X.T, -r2 * Pi, np.zeros((n, nw)), system.H.T],
                         [Y.T, np.zeros((nw, n)), -g * np.eye(nw), system.Dz[i].T],
                         [np.zeros((nz, n)), system.H, system.Dz[i], -np.eye(nz)]])
            cons.append((M + M.T) / 2 << -1e-8 * np.eye(2 * n + nw + nz))
    prob = cp.Problem(cp.Minimize(g), cons)
    prob.solve(solver="CLARABEL")
    assert prob.status == cp.OPTIMAL, prob.status
    return float(np.sqrt(g.value))


def _common_quadratic_refuted(F):
    """Theorem of alternatives for x+ = F_i x (any switching): if Q_i >= 0, sum tr Q_i = 1,
    S = sum_i (F_i Q_i F_i^T - Q_i) >= 0, then no P > 0 has F_i^T P F_i - P < 0 for all i
    (tr(P S) >= 0, yet it equals sum_i tr(Q_i (F_i^T P F_i - P)) < 0). Q_i by cvxpy
    (maximising lambda_min(S)); returns lambda_min(S) recomputed in numpy from the Q_i."""
    n = F[0].shape[0]
    Q = [cp.Variable((n, n), symmetric=True) for _ in F]
    t = cp.Variable()
    S = sum(Fi @ Qi @ Fi.T - Qi for Fi, Qi in zip(F, Q))
    prob = cp.Problem(cp.Maximize(t), [Qi >> 0 for Qi in Q] +
                      [sum(cp.trace(Qi) for Qi in Q) == 1, (S + S.T) / 2 >> t * np.eye(n)])
    prob.solve(solver="CLARABEL")
    Qv = [np.linalg.eigvalsh((Qi.value + Qi.value.T) / 2) for Qi in Q]
    assert min(v.min() for v in Qv) > -1e-9                       # Q_i >= 0 (to round-off)
    Sv = sum(Fi @ ((Qi.value + Qi.value.T) / 2) @ Fi.T - (Qi.value + Qi.value.T) / 2
             for Fi, Qi in zip(F, Q))
    return float(np.linalg.eigvalsh((Sv + Sv.T) / 2).min())


# ---- discrete-time slack synthesis ------------------------------------------------------
def test_discrete_l2_quadratic_and_poly_quadratic_match_independent_cvxpy():
    """Minimum gamma of the discrete L2 design with decay rate 0.5 1/s (radius exp(-0.05)),
    output feedthrough Dz, PDC gains: quadratic (Stein / discrete bounded-real lemma) and the
    slack form over every vertex pair (i, j), each equal to an independent cvxpy formulation
    with the blocks in another order (rel. 1e-5, the solver's accuracy); the slack optimum is
    no worse than the quadratic one (it contains it: P_k = G = P); the backed-off designs are
    certified from the data and every frozen error system's discrete H-infinity norm is below
    gamma. Catches a wrong block of either form (r^2 on the wrong block, P_i where P_j
    belongs, X instead of X^T), a slack form missing the cross pairs, and a certificate that
    measures the continuous-time norm of a discrete system (it would be inf or wrong)."""
    s = _l2_system()
    res = {}
    for lyap, pd in (("quadratic", False), ("slack", True)):
        syn = slack.SlackSynthesis(s, [L2Gain(0.5)], lyapunov=lyap, eps=1e-8)
        des = syn.solve("gamma", raise_on_violation=False)
        ref = _cvxpy_l2(s, 0.5, pd)
        assert des.gamma == pytest.approx(ref, rel=1e-5)
        opt = syn.minimise(backoff=0.05)
        assert opt.status == "certified" and opt.margin > 1e-9
        cert = opt.design.certificate
        for (i, _), v in cert.hinf.items():
            Ln = opt.design.L[i - 1]
            N, B = A2[i - 1] - Ln @ C2, E2 - Ln @ D2
            assert v == hinf_norm(N, B, H2, DZ2, discrete=True) <= opt.value  # pair (A_i, L_i)
            # independent of the bilinear map: the peak gain on a dense grid of the unit
            # circle is a lower bound of the norm and, for this smooth response, within 1e-3
            z = np.exp(1j * np.linspace(0.0, np.pi, 20001))
            T = H2 @ np.linalg.solve(z[:, None, None] * np.eye(2) - N, B) + DZ2
            grid = float(np.linalg.norm(T, 2, axis=(1, 2)).max())
            assert v * (1 - 1e-3) <= grid <= v * (1 + 1e-6)
        assert np.abs(cert.poles).max() < np.exp(-0.5 * DT)
        res[lyap] = des.gamma
    assert res["slack"] <= res["quadratic"] * (1 + 1e-5)     # to the solver accuracy above
    names = [c.name for c in opt.design.certificate.lmi.checks]
    assert names[2:] == ["l2[1,1]", "l2[1,2]", "l2[2,1]", "l2[2,2]"]


def test_discrete_quadratic_l2_equals_the_discrete_bounded_real_lemma():
    """With alpha = 0 and Dz = 0 the squared discrete L2 form of SlackSynthesis (Stein form,
    g = gamma^2) and the discrete bounded-real lemma of ObserverSynthesis (-gamma I blocks,
    common P, PDC gains) are congruent forms of one inequality: the same optimum gamma (rel.
    1e-4). Catches a discrete L2 block written for continuous time (He(X) where the Stein
    form belongs) on either side."""
    s = PolytopicSystem(A2, C2, E=E2, D=D2, H=H2, time="discrete", dt=DT)
    a = slack.SlackSynthesis(s, [L2Gain()]).solve("gamma", raise_on_violation=False)
    b = ObserverSynthesis(s, [BoundedReal()], gains="pdc").solve("gamma",
                                                                 raise_on_violation=False)
    assert a.gamma == pytest.approx(b.gamma, rel=1e-4)


def test_poly_quadratic_observer_where_no_common_quadratic_one_exists():
    """Theory (Daafouz & Bernussou 2001: poly-quadratic stability is necessary and sufficient
    for the extended LMIs over the pairs (i, j), and strictly weaker than quadratic
    stability). No published example with a printed number was found in the searched corpora,
    so the pair F_PQ is built here and its properties checked independently: (a) no common
    quadratic Lyapunov function for x+ = F_i x (a dual certificate Q_i, lambda_min(S) > 0,
    recomputed in numpy); (b) embedded in a 3-state observer problem where (x2, x3) do not
    reach y, the quadratic design is infeasible for any gains, while the slack form is
    feasible and certified; (c) its solution is checked directly on the definition,
    N_i^T P_j N_i - r^2 P_i < 0 for every (i, j) (numpy eigenvalues, not the extended LMI),
    and V = e^T P(h_k) e decreases on a seeded random membership sequence. Catches a slack
    form that is secretly quadratic (would be infeasible), one that forgets the next step's
    P_j (the direct check (c) would fail) and a quadratic form that is not (would be
    feasible)."""
    assert _common_quadratic_refuted(F_PQ) > 1e-4
    s = _embedded(F_PQ)
    with pytest.raises(InfeasibleDesign):
        slack.SlackSynthesis(s, [Decay(0.0)]).solve()
    des = slack.SlackSynthesis(s, [Decay(0.0)], lyapunov="slack").solve()
    assert des.status == "certified", des.certificate.reason()
    N = s.A - des.L @ s.C
    P = (des.P + np.swapaxes(des.P, 1, 2)) / 2
    worst = max(np.linalg.eigvalsh(N[i].T @ P[j] @ N[i] - P[i]).max()
                for i in range(2) for j in range(2))
    assert worst < 0
    rng = np.random.default_rng(7)
    h = rng.dirichlet([0.3, 0.3], size=200)
    e = np.array([1.0, -1.0, 2.0])
    V = []
    for k in range(len(h) - 1):
        Ph = np.einsum("k,kab->ab", h[k], P)
        V.append(e @ Ph @ e)
        e = np.einsum("k,kab->ab", h[k], N) @ e
    assert np.all(np.diff(V) < 0)


def test_planted_frozen_only_lmis_are_violated_by_the_data_certificate(monkeypatch):
    """A builder mistake in the layer: the slack LMIs posed on the frozen pairs (i, i) only
    (the next step's P_j replaced by P_i). On F_SW (each vertex Schur, switching unstable:
    rho(F1 F2) = 1.082) the solver finds a point and the builders certify themselves, the
    certificate rebuilt from the data over every pair (i, j) says 'violated' and names a
    cross pair."""
    assert np.abs(np.linalg.eigvals(F_SW[0] @ F_SW[1])).max() > 1
    real = slack.SlackSynthesis._discrete_matrix

    def frozen(self, c, V, i, j=()):
        return real(self, c, V, i, i)
    monkeypatch.setattr(slack.SlackSynthesis, "_discrete_matrix", frozen)
    syn = slack.SlackSynthesis(_embedded(F_SW), [Decay(0.0)], lyapunov="slack")
    with pytest.raises(CertificationError, match=r"decay\[(1,2|2,1)\]"):
        syn.solve()
    des = syn.solve(raise_on_violation=False)
    assert des.solution.certificate.ok
    assert des.status == "violated"


def test_planted_wrong_vertex_and_swapped_gains_are_violated():
    """Certificates of a valid discrete slack design with mistakes planted in the data:
    vertex 2's A replaced by vertex 1's in the system the design was solved on (a wrong
    vertex: the gains and P come from the wrong problem) and the two PDC gains swapped. Each
    is 'violated', naming the failing LMI."""
    s = PolytopicSystem(np.array([[[0.9, 0.3], [-0.2, 0.7]], [[1.6, 0.4], [0.3, 1.2]]]), C2,
                        E=E2, D=D2, time="discrete", dt=DT)
    syn = slack.SlackSynthesis(s, [L2Gain(0.5), SpectralDisk(0.9)], lyapunov="slack")
    des = syn.minimise().design
    assert des.status == "certified"
    swapped = certify_slack_observer(syn, des.P, des.L[::-1], G=des.G, gamma=des.gamma)
    assert swapped.status == "violated", swapped.reason()
    wrong = slack.SlackSynthesis(s.with_A(s.A[[0, 0]]), [L2Gain(0.5), SpectralDisk(0.9)],
                                 lyapunov="slack")
    wd = wrong.minimise().design
    planted = certify_slack_observer(syn, wd.P, wd.L, G=wd.G, gamma=wd.gamma)
    assert planted.status == "violated"
    assert "[2" in planted.worst_name()


def test_discrete_slack_bad_input_is_one_clear_error():
    """A Finsler scalar given to the discrete-time slack form (it has none) and best_mu on a
    discrete design: one ObserverArgumentError each, naming the cause."""
    s = _l2_system()
    with pytest.raises(ObserverArgumentError, match="no Finsler scalar"):
        slack.SlackSynthesis(s, [L2Gain()], lyapunov="slack", mu=0.1)
    with pytest.raises(ObserverArgumentError, match="best_mu"):
        slack.SlackSynthesis(s, [L2Gain()], lyapunov="slack").best_mu([0.1])


# ---- discrete-time positivity (interval observers) ----------------------------------------
def _cvxpy_nonnegative_design(A, C, rho):
    """Independent synthesis: diagonal d >= 1, K, every entry of diag(d) A - K C >= 0 and
    (diag(d) A - K C)^T diag(d)^-1 (.) < rho^2 diag(d) as [[rho^2 P, X^T], [X, P]] > 0."""
    n, p = A.shape[0], C.shape[0]
    d = cp.Variable(n)
    P = cp.diag(d)
    K = cp.Variable((n, p))
    X = P @ A - K @ C
    M = cp.bmat([[rho ** 2 * P, X.T], [X, P]])
    prob = cp.Problem(cp.Minimize(0), [d >= 1.0, X >= 0, (M + M.T) / 2 >> 1e-7 * np.eye(2 * n)])
    prob.solve(solver="CLARABEL")
    return prob.status == cp.OPTIMAL


def test_nonnegative_is_infeasible_on_efimov_2013():
    """Efimov, Perruquetti, Raissi & Zolghadri (ECC 2013) Sec. IV.A, A = [[0.3, -0.7], [0.6,
    -0.5]], C = [1 0]: "there is no observer gain L in R^2 making the matrix D = A - L C
    nonnegative" (L moves only the first column; the second, [-0.7, -0.5], stays negative).
    The layer (Nonnegative + Decay, P diagonal) says infeasible, as does an independent cvxpy
    formulation. The paper's own observation on its R = [[-0.5, 0], [1, 0]] (printed as the
    target of its change of coordinates) is Metzler but not nonnegative: the off-diagonal
    Metzler certificate of the layer accepts it on a discrete-time system (continuous-time
    cooperativity, not discrete-time positivity), the Nonnegative certificate rejects it by
    name. Catches a positivity constraint that leaves out the diagonal or a column."""
    A = np.array([[0.3, -0.7], [0.6, -0.5]])
    C = np.array([[1.0, 0.0]])
    s = PolytopicSystem(A, C, time="discrete", name="Efimov 2013 IV.A")
    with pytest.raises(InfeasibleDesign, match="nonneg"):
        ObserverSynthesis(s, [Decay(0.0), Nonnegative()], P="diagonal").solve()
    assert not _cvxpy_nonnegative_design(A, C, 0.999)
    rsys = PolytopicSystem(np.array([[-0.5, 0.0], [1.0, 0.0]]), np.zeros((1, 2)),
                           time="discrete", name="R")
    zero, P = np.zeros((1, 2, 1)), 2.0 * np.eye(2)
    met = certify_observer(ObserverSynthesis(rsys, [Metzler()], P="diagonal"), P, zero)
    assert met.lmi.ok
    neg = certify_observer(ObserverSynthesis(rsys, [Nonnegative()], P="diagonal"), P, zero)
    assert neg.status == "violated" and neg.lmi.worst().name == "nonneg[1]"


def test_nonnegative_design_on_wang_2018_example1():
    """Wang (2018, SCL) Example 1 with the printed T (tests/design/test_published.py): the
    pair (T A, C) admits a positive error system. The layer's design (Nonnegative + decay
    radius 0.2 per step, dt = 1, P diagonal) is certified and checked independently from the
    gain: every entry of T A - L C >= 0 and spectral radius < 0.2. Theory gives the fastest
    positive design: L changes only the first column, so T A - L C >= G0 = T A with its first
    column zeroed, entry-wise, and by Perron-Frobenius monotonicity its spectral radius is
    at least rho(G0) = (T A)[1, 1] = 0.01058, reached by that gain. The layer's bisection
    (maximise_decay, tolerance 1e-4 in alpha dt) finds 0.01058 to relative 3e-4, and an
    independent cvxpy formulation agrees (feasible 1 % above, infeasible 1 % below). A
    sign-flipped gain is 'violated' by name; a structural zero computed as -1e-16 is
    'inconclusive' (lmi.NONNEG_ROUNDOFF), not certified nor violated. Catches a positivity
    constraint or certificate that misses an entry, and one that calls round-off a
    certainty."""
    T = np.array([[-0.0238, 0.0], [-0.7294, 1.0]])
    At = T @ np.array([[0.3, -0.7], [0.6, -0.5]])
    C = np.array([[1.0, 0.0]])
    s = PolytopicSystem(At, C, time="discrete", name="Wang 2018 Ex. 1 (T A, C)")
    rho = 0.2
    syn = ObserverSynthesis(s, [Decay(-np.log(rho)), Nonnegative(margin=1e-6)], P="diagonal")
    des = syn.solve()
    assert des.certificate.status == "certified", des.certificate.reason()
    G = At - des.L[0] @ C
    assert G.min() >= 0 and np.abs(np.linalg.eigvals(G)).max() < rho
    rho0 = At[1, 1]
    assert rho0 == pytest.approx(0.01058, abs=1e-12)
    opt = ObserverSynthesis(s, [Decay(0.0), Nonnegative()], P="diagonal").maximise_decay(
        10.0, tol=1e-4, backoff=0.01)
    assert np.exp(-opt.optimum) == pytest.approx(rho0, rel=3e-4)
    assert opt.status == "certified"
    Go = At - opt.design.L[0] @ C
    assert Go.min() >= 0 and rho0 <= np.abs(np.linalg.eigvals(Go)).max() < np.exp(-opt.value)
    assert _cvxpy_nonnegative_design(At, C, 1.01 * rho0)
    assert not _cvxpy_nonnegative_design(At, C, 0.99 * rho0)
    bad = certify_observer(syn, des.P, -des.L)
    assert bad.status == "violated"
    assert not {c.name: c for c in bad.lmi.checks}["nonneg[1]"].ok
    # a gain whose A - L C has a structural zero computed with round-off
    Lz = np.array([[At[0, 0] + 1e-17], [At[1, 0]]])
    Gz = At - Lz @ C
    assert -1e-15 < Gz.min() < 0
    P = np.diag([2.0, 2.0])
    pos = ObserverSynthesis(s, [Nonnegative()], P="diagonal")
    cert = certify_observer(pos, P, Lz[None])
    assert cert.status == "inconclusive", cert.reason()
    assert {c.name: c for c in cert.lmi.checks}["nonneg[1]"].roundoff


def test_nonnegative_bad_input_is_one_clear_error():
    """Nonnegative with a symmetric P or on a continuous-time system, and a negative margin:
    one ObserverArgumentError each."""
    sd = PolytopicSystem(A2, C2, time="discrete")
    with pytest.raises(ObserverArgumentError, match="diagonal"):
        ObserverSynthesis(sd, [Nonnegative()])
    with pytest.raises(ObserverArgumentError, match="discrete-time"):
        ObserverSynthesis(PolytopicSystem(A2, C2), [Nonnegative()], P="diagonal")
    with pytest.raises(ObserverArgumentError, match="margin"):
        Nonnegative(margin=-1.0)
