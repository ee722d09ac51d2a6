"""Parameter-dependent Lyapunov functions with membership-rate bounds
(:mod:`vehicle_observers.design.lyapunov`), checked against theory, an independent cvxpy
formulation, a simulation, planted mistakes and the Ifqir 2017 Theorem 2 formulation."""

import numpy as np
import pytest
from vehicle_observers.core.errors import (
    CertificationError,
    InfeasibleDesign,
    ObserverArgumentError,
)
from vehicle_observers.design import lyapunov as ly
from vehicle_observers.design.constraints import Decay, InputToState, Metzler, OnVertices
from vehicle_observers.design.lyapunov import ParameterDependentSynthesis
from vehicle_observers.design.synthesis import ObserverSynthesis, _diag
from vehicle_observers.design.system import PolytopicSystem

#: two Hurwitz matrices (eigenvalues -0.1 +- 1.41j) whose convex combinations are all
#: Hurwitz (off-diagonal product (1 + t)(t - 2) < 0, real part -0.1) but which have no common
#: quadratic Lyapunov function: switching between the two stable spirals at the right
#: moments makes the state grow (the textbook example of switched-system instability);
#: checked below by a simulation
SPIRALS = (np.array([[-0.1, 1.0], [-2.0, -0.1]]), np.array([[-0.1, 2.0], [-1.0, -0.1]]))
C3 = np.array([[0.0, 0.0, 1.0]])


def _embed(A0, a31=0.0):
    """3-state vertex: the 2x2 block ``A0`` is not seen by ``y = x_3`` (no gain reaches the
    error of ``x_1, x_2``), ``x_3' = a31 x_1 - x_3``."""
    A = np.zeros((3, 3))
    A[:2, :2] = A0
    A[2, 2] = -1.0
    A[2, 0] = a31
    return A


def spirals_system(phi):
    return PolytopicSystem(np.array([_embed(a) for a in SPIRALS]), C3, E=np.eye(3),
                           rate_bounds=[phi, phi], name="two spirals")


def _switched_growth():
    """|x(20 s)| / |x(0)| of x' = A_sigma x with sigma(x) the vertex of largest d|x|^2/dt."""
    x, dt = np.array([1.0, 0.0]), 1e-3
    for _ in range(20000):
        j = int(np.argmax([x @ (a + a.T) @ x for a in SPIRALS]))
        x = x + dt * SPIRALS[j] @ x
    return float(np.linalg.norm(x))


def test_pd_lyapunov_certifies_where_common_p_cannot():
    """The error of x_1, x_2 obeys A0(h) whatever the gain. Every frozen A0(h) is Hurwitz,
    but no common P exists (a switching law makes |x| grow, simulated here), so the common-P
    design must be infeasible; with slowly varying memberships (|dh/dt| <= 0.05 1/s) the
    vertex-dependent P(h) with the slack M must be certified, and for fast memberships
    (phi = 10 1/s) it must fail (as phi -> inf the slack form becomes the common-P problem).
    Without the slack (M = 0, Tanaka 2003) the admissible rate is smaller. Catches a rate term
    with the wrong sign or missing (feasible at any phi), or a builder that lost the
    vertex-dependence of P (infeasible at small phi)."""
    assert _switched_growth() > 10.0                    # no common quadratic Lyapunov function
    with pytest.raises(InfeasibleDesign):
        ObserverSynthesis(spirals_system(0.0), [Decay(0.0)], gains="pdc").solve()
    des = ParameterDependentSynthesis(spirals_system(0.05), [Decay(0.0)]).solve()
    assert des.status == "certified" and des.certificate.lmi.min_relative_margin > 1e-6
    assert np.abs(des.P[0][0] - des.P[0][1]).max() > 0.1     # a genuinely varying P(h)
    with pytest.raises(InfeasibleDesign):
        ParameterDependentSynthesis(spirals_system(10.0), [Decay(0.0)]).solve()
    # slack M (Mozelli 2009) is less conservative than M = 0 (Tanaka 2003)
    ParameterDependentSynthesis(spirals_system(0.2), [Decay(0.0)]).solve()
    with pytest.raises(InfeasibleDesign):
        ParameterDependentSynthesis(spirals_system(0.2), [Decay(0.0)], slack=False).solve()


def test_certified_v_decreases_along_an_admissible_trajectory():
    """Meaning of the certificate, checked by simulation: with h_1(t) = 0.5 + 0.5 sin(w t),
    |dh/dt| = 0.5 w = phi, the gain L(h) = P(h)^-1 K(h) and V = e^T P(h) e, V must decrease
    at every step of an RK4 simulation (Decay(0): V' < 0). Catches certificates whose rate
    term does not bound dP/dt or whose gain is blended the wrong way."""
    phi = 0.05
    des = ParameterDependentSynthesis(spirals_system(phi), [Decay(0.0)]).solve()
    Pk, Kk = des.P[0], des.P[0] @ des.L[0]
    A = spirals_system(phi).A
    w = 2 * phi

    def h(t):
        a = 0.5 + 0.5 * np.sin(w * t)
        return np.array([a, 1 - a])

    def f(t, e):
        hh = h(t)
        P, K = np.tensordot(hh, Pk, 1), np.tensordot(hh, Kk, 1)
        return (np.tensordot(hh, A, 1) - np.linalg.solve(P, K) @ C3) @ e

    e, t, dt = np.array([1.0, -0.5, 0.3]), 0.0, 0.01
    V = [e @ np.tensordot(h(t), Pk, 1) @ e]
    for _ in range(6000):
        k1 = f(t, e)
        k2 = f(t + dt / 2, e + dt / 2 * k1)
        k3 = f(t + dt / 2, e + dt / 2 * k2)
        k4 = f(t + dt, e + dt * k3)
        e, t = e + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4), t + dt
        V.append(e @ np.tensordot(h(t), Pk, 1) @ e)
    assert np.all(np.diff(V) < 0)
    assert V[-1] < 1e-3 * V[0]


def _iss_system(phi):
    # a variant whose two blocks do have a common P (damping 0.5), with an ISS bound
    A = np.array([_embed(np.array([[-0.5, 1.0], [-2.0, -0.5]]), 1.0),
                  _embed(np.array([[-0.5, 2.0], [-1.0, -0.5]]), 1.0)])
    return PolytopicSystem(A, C3, E=np.eye(3), rate_bounds=[phi, phi], name="ISS pair")


ISS = InputToState(alpha=0.2, c=None)


def test_rate_bound_growth_tends_to_the_common_p_answer():
    """Theory: the slack form contains every common-P solution (P_k = P, M = -P gives R = 0),
    its feasible set shrinks as phi grows (R grows with phi because P_k + M >= 0), and as
    phi -> inf it forces P_k + M -> 0, i.e. a common P. So min c(phi) is nondecreasing, never
    above the common-P min c, and reaches it for large phi. Tolerance: 1e-5 relative (the
    solver's gap 1e-8 plus the strictness eps = 1e-9 times phi q = 2e3). Catches a rate term
    that ignores phi, the slack, or the common-P limit."""
    kw = dict(eps=1e-9, P_upper=100.0)
    common = ObserverSynthesis(_iss_system(0.0), [ISS], gains="pdc", **kw).solve(
        "c", raise_on_violation=False).c
    cs = [ParameterDependentSynthesis(_iss_system(phi), [ISS], **kw).solve(
        "c", raise_on_violation=False).c[0] for phi in (0.0, 1.0, 1e3)]
    assert cs[0] < 0.8 * common                          # vertex-dependent P helps at phi = 0
    assert cs[0] <= cs[1] * (1 + 1e-5) and cs[1] <= cs[2] * (1 + 1e-5)
    assert cs[1] <= common * (1 + 1e-5)
    assert cs[2] == pytest.approx(common, rel=1e-5)


def test_independent_cvxpy_formulation_agrees():
    """One PD problem (relaxed coupling, q = 2, Tuan: G_11, G_22, 2 G_ii + G_12 + G_21 < 0 with
    slack M, min c) written here directly in cvxpy: the same optimum to 1e-6 relative.
    Catches a wrong index (P_i with A_j), a missing slack or rate term in the layer."""
    import cvxpy as cp

    phi, alpha, eps = 0.5, 0.2, 1e-9
    s = _iss_system(phi)
    n = 3
    P = [cp.Variable((n, n), symmetric=True) for _ in range(2)]
    K = [cp.Variable((n, 1)) for _ in range(2)]
    M = cp.Variable((n, n), symmetric=True)
    c = cp.Variable(nonneg=True)
    I = np.eye(n)
    R = phi * (P[0] + M) + phi * (P[1] + M)

    def G(i, j):
        X = P[i] @ s.A[j] - K[i] @ C3
        return cp.bmat([[X + X.T + alpha * P[i] + R, P[i]], [P[i], -c * I]])

    cons = [Pi - I >> eps * I for Pi in P] + [100 * I - Pi >> eps * I for Pi in P]
    cons += [Pi + M >> eps * I for Pi in P]
    for S in (G(0, 0), G(1, 1), 2 * G(0, 0) + G(0, 1) + G(1, 0),
              2 * G(1, 1) + G(1, 0) + G(0, 1)):
        cons.append((S + S.T) / 2 << -eps * np.eye(2 * n))
    cp.Problem(cp.Minimize(c), cons).solve(solver="CLARABEL")
    des = ParameterDependentSynthesis(s, [ISS], eps=eps, P_upper=100.0).solve(
        "c", raise_on_violation=False)
    assert des.c[0] == pytest.approx(float(c.value), rel=1e-6)


def test_planted_wrong_vertex_and_wrong_rate_are_violated(monkeypatch):
    """The certificate rebuilds every LMI from the vertex matrices and rate bounds, not from
    the builders: (a) a builder that states every LMI at the last vertex (the captured loop
    variable) and (b) a builder whose rate term uses phi / 100 both let the solver find a
    point that the data certificate must call "violated", naming the LMI. Catches a
    certificate that reuses the builders."""
    good = ly.pair_matrix

    def last_vertex(c, system, P, K, i, V):
        return good(c, system, P, K, system.q - 1, V)

    monkeypatch.setattr(ly, "pair_matrix", last_vertex)
    with pytest.raises(CertificationError) as ei:
        ParameterDependentSynthesis(spirals_system(0.05), [Decay(0.0)]).solve()
    assert ei.value.lmi.startswith("decay[")
    monkeypatch.setattr(ly, "pair_matrix", good)

    rate = ly.rate_term
    monkeypatch.setattr(ly, "rate_term", lambda P, M, phi: rate(P, M, np.asarray(phi) / 100))
    des = ParameterDependentSynthesis(spirals_system(0.3), [Decay(0.0)]).solve(
        raise_on_violation=False)
    assert des.status == "violated" and des.certificate.worst_name().startswith("decay[")
    # the same solution is certified against the rate bound it was solved for
    from vehicle_observers.design.certify import certify_parameter_dependent
    syn03 = ParameterDependentSynthesis(spirals_system(0.003), [Decay(0.0)])
    assert certify_parameter_dependent(syn03, des.P, des.L, des.M).status != "violated"


def test_metzler_on_another_vertex_list():
    """OnVertices: the Metzler condition stated on a second vertex list (element-wise lower
    bounds A^-, while the ISS condition is on A^+, as in Ifqir 2017 (19)-(20)) is met by the
    gains on that list (checked here from L), and the certificate reads the list it is given:
    the same gains against a list whose (1,2) entries are lowered by the design's smallest
    Metzler entry + 0.1 must be "violated", naming the Metzler LMI. Catches a constraint
    silently stated on the design's own vertices or a certificate that ignores the list."""
    from vehicle_observers.design.certify import certify_parameter_dependent

    A_hi = np.array([[[-2.0, 1.0], [0.5, -3.0]], [[-2.5, 1.2], [0.6, -3.0]]])
    A_lo = A_hi - np.array([[0.0, 1.5], [0.3, 0.0]])       # A^-: (1,2) entries negative
    C = np.array([[0.0, 1.0]])                             # the gain reaches entry (1,2)
    hi = PolytopicSystem(A_hi, C, E=np.eye(2), rate_bounds=[0.1, 0.1])
    lo = PolytopicSystem(A_lo, C, rate_bounds=[0.1, 0.1])
    syn = ParameterDependentSynthesis(hi, [InputToState(0.5, c=None),
                                           OnVertices(Metzler(margin=1e-3), lo)],
                                      P="diagonal", coupling="vertex", eps=1e-3)
    des = syn.solve("c")            # eps: min c off the boundary, so "certified" is reachable
    M12 = (A_lo - des.L[0] @ C)[:, 0, 1]
    assert des.status == "certified" and M12.min() >= 0 and (A_lo[:, 0, 1] < 0).all()
    bad = A_lo.copy()
    bad[:, 0, 1] -= M12.min() + 0.1
    wrong = ParameterDependentSynthesis(hi, [InputToState(0.5, c=None), OnVertices(
        Metzler(), PolytopicSystem(bad, C, rate_bounds=[0.1, 0.1]))], P="diagonal",
        coupling="vertex")
    cert = certify_parameter_dependent(wrong, des.P, des.L, des.M, des.c)
    assert cert.status == "violated" and cert.worst_name().startswith("metzler[")
    assert cert.lmi.worst().margin == pytest.approx(-0.1, abs=1e-9)
    with pytest.raises(ObserverArgumentError):
        ParameterDependentSynthesis(hi, [Metzler()])      # needs a diagonal P


def test_ifqir_theorem2_through_the_layer_equals_the_paper_formulation():
    """Ifqir 2017 Theorem 2 (17)-(20) posed directly as in the paper's LMIs
    (``interval.add_theorem2_iss`` and element-wise (20), as the design was written before it
    called the layer) and through the layer give the same P, L, M and gamma: bitwise here
    (the same cvxpy problem); asserted to 1e-9 relative, the solver's reproducibility.
    Catches a port that changed the LMIs, the vertex lists or the objective."""
    from vehicle_observers.design.lmi import LMIDesign
    from vehicle_observers.models import uncertain_bicycle as ub
    from vehicle_observers.observers import interval as iv
    from vehicle_observers_papers.ifqir_2017 import constants as IF

    model = IF.model(IF.bands_single)
    phi = model.membership_rate_bounds(IF.accel_max)
    C = model.C
    d = LMIDesign("paper formulation", eps=1e-2)
    for j in range(4):
        d.diagonal(f"P0{j}", 2)
        d.matrix(f"W0{j}", (2, 1))
    g = iv.add_theorem2_iss(d, model, phi, IF.eps_decay, IF.p_min)
    for j in range(4):
        Am = model.A_lo[0, j]
        d.nonnegative(f"M{j}", lambda V, j=j, Am=Am: iv._offdiag(V[f"P0{j}"] @ Am
                                                                 - V[f"W0{j}"] @ C))
        d.nonnegative(f"D{j}", lambda V, j=j, Am=Am: _diag(
            V[f"P0{j}"] @ Am - V[f"W0{j}"] @ C + IF.epsilon_shift * V[f"P0{j}"]))
    d.extra(lambda V: [iv._offdiag(V[f"P0{j}"] @ model.A_lo[0, j] - V[f"W0{j}"] @ C) >= 1e-3
                       for j in range(4)])
    sol = d.solve(objective=lambda V: V[g(0)])
    des = IF.design(IF.bands_single)
    assert isinstance(model, ub.SwitchedIntervalModel)
    for j in range(4):
        np.testing.assert_allclose(np.diag(sol[f"P0{j}"]), des.P[0, j], rtol=1e-9)
        np.testing.assert_allclose(np.linalg.solve(sol[f"P0{j}"], sol[f"W0{j}"]), des.L[0, j],
                                   rtol=1e-9)
    np.testing.assert_allclose(sol["M0"], des.solution["M0"], rtol=1e-9, atol=1e-12)
    assert des.gamma == pytest.approx(float(sol["gamma0"]), rel=1e-9)
    assert des.data_certificate.status == "certified"
