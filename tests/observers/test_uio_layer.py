"""El Youssfi 2020 designs (a) [22] and (b) Theorem 2 as calls of the synthesis layer: equal
to the conditions written out here in plain cvxpy (the formulation the reproduction used
before it called the layer), certified from the data, exposing the decoupling."""

import cvxpy as cp
import numpy as np
import pytest
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.design.certify import certify_slack_observer
from vehicle_observers.design.uio import uio_system
from vehicle_observers.observers import uio
from vehicle_observers_papers.elyoussfi_2020 import constants as P
from vehicle_observers_papers.elyoussfi_2020 import relaxed_uio as us


@pytest.fixture(scope="module")
def case():
    model = P.build_model()
    st = uio.structure(model)
    return model, st, us.phi_design(model)["phi"]


def _plain_cvxpy(st, alpha, phi, mu, radius, eps, relaxed):
    """(a) or (b) at one ``mu`` written directly in cvxpy from (23)-(25), in the time unit
    1/radius, with the error input ``B_i = [T Gam, -L_i D_w]``, ``L_i = K_i (I - Cbar H) +
    T Abar_i H`` multiplied by ``P`` (or ``G``), the output ``e = eps - H D_w w`` and the pole
    disk (Stein / de Oliveira). Returns ``(gamma, K (SI))``."""
    tau = 1.0 / radius
    TA, TG = st["TA"] * tau, st["TG"] * tau
    Cb, H, Dw = st["Cbar"], st["H"], st["Dw"]
    p = Cb.shape[0]
    IcH = np.eye(p) - Cb @ H
    De = np.hstack([np.zeros((3, 1)), -H @ Dw])
    a, ph, m = alpha * tau, phi * tau, mu / tau
    I3, Z3 = np.eye(3), np.zeros((3, 3))

    def sym(M):
        return (M + M.T) / 2

    if not relaxed:
        Pv = cp.Variable((3, 3), symmetric=True)
        g = cp.Variable(nonneg=True)
        W = [cp.Variable((3, p)) for _ in range(2)]
        cons = [sym(Pv) >> eps * I3]
        for i in range(2):
            PN = Pv @ TA[i] - W[i] @ Cb
            PB = cp.bmat([[Pv @ TG, -(W[i] @ IcH + Pv @ (TA[i] @ H)) @ Dw]])
            M = cp.bmat([[2 * a * Pv + PN + PN.T, PB, I3], [PB.T, -g * np.eye(1 + p), De.T],
                         [I3, De, -I3]])
            cons.append(sym(M) << -eps * np.eye(M.shape[0]))
            cons.append(sym(cp.bmat([[Pv, PN.T], [PN, Pv]])) >> eps * np.eye(6))
        cp.Problem(cp.Minimize(g), cons).solve(solver="CLARABEL")
        return float(np.sqrt(g.value)), np.array([np.linalg.solve(Pv.value, w.value)
                                                  for w in W]) / tau
    Ps = [cp.Variable((3, 3), symmetric=True) for _ in range(2)]
    G = cp.Variable((3, 3))
    g = cp.Variable(nonneg=True)
    W = [cp.Variable((3, p)) for _ in range(2)]
    cons = [sym(Pi) >> eps * I3 for Pi in Ps]
    for i in range(2):
        for s in (1, -1):
            GN = G @ TA[i] - W[i] @ Cb
            GB = cp.bmat([[G @ TG, -(W[i] @ IcH + G @ (TA[i] @ H)) @ Dw]])
            M = cp.bmat([[s * ph * (Ps[0] - Ps[1]) + 2 * a * Ps[i] + GN + GN.T,
                          Ps[i] - G + m * GN.T, GB, I3],
                         [Ps[i] - G.T + m * GN, -m * (G + G.T), m * GB, Z3],
                         [GB.T, m * GB.T, -g * np.eye(1 + p), De.T],
                         [I3, Z3, De, -I3]])
            cons.append(sym(M) << -eps * np.eye(M.shape[0]))
    for i in range(2):
        GN = G @ TA[i] - W[i] @ Cb
        cons.append(sym(cp.bmat([[Ps[i], GN.T], [GN, G + G.T - Ps[i]]])) >> eps * np.eye(6))
    cp.Problem(cp.Minimize(g), cons).solve(solver="CLARABEL")
    return float(np.sqrt(g.value)), np.array([np.linalg.solve(G.value, w.value)
                                              for w in W]) * radius


def test_port_equals_the_conditions_written_in_plain_cvxpy(case):
    """Designs (a) and (b) through the layer (SlackSynthesis on the decoupled error system
    of design.uio.uio_system) give the gamma and the gains K_i of (23)-(25) written directly
    in cvxpy: gamma to 1e-9 relative, the gains of (b) to 1e-6 (the optimum of (a) is
    flat in K: its gains move by ~1e-3 under round-off-level changes of the data, so only
    its poles and gamma are compared). Catches a wrong error input (the feedthrough of
    H y, the T Abar H D_w term), a wrong time scaling or a wrong sign pattern."""
    model, st, phi = case
    ga = uio.design_quadratic(model, P.alpha_design, st, radius=P.radius, eps=P.lmi_eps)
    gb = uio.design_relaxed(model, P.alpha_design, phi, (1e-2,), st, radius=P.radius,
                            eps=P.lmi_eps)
    gam_a, _ = _plain_cvxpy(st, P.alpha_design, phi, 1e-2, P.radius, P.lmi_eps, False)
    gam_b, Kb = _plain_cvxpy(st, P.alpha_design, phi, 1e-2, P.radius, P.lmi_eps, True)
    assert ga.gamma == pytest.approx(gam_a, rel=1e-9)
    assert gb.gamma == pytest.approx(gam_b, rel=1e-9)
    np.testing.assert_allclose(gb.K, Kb, rtol=1e-6, atol=1e-6 * np.abs(Kb).max())
    assert gb.gamma < ga.gamma                           # Theorem 2 relaxes [22] here


def test_result_exposes_decoupling_gains_and_data_certificate(case):
    """UIOGains carries T (T Mbar = 0, T = I - H Cbar), N_i = T Abar_i - K_i Cbar,
    L_i = K_i + N_i H, and the layer's data certificate: certified, every rule's
    H-infinity norm of the decoupled error system below gamma, the same LMI names as the
    builders' certificate. Catches a result whose N, L, K do not belong together."""
    model, st, phi = case
    for g in (uio.design_quadratic(model, P.alpha_design, st, radius=P.radius, eps=P.lmi_eps),
              uio.design_relaxed(model, P.alpha_design, phi, P.mu_grid, st, radius=P.radius,
                                 eps=P.lmi_eps)):
        np.testing.assert_allclose(g.T @ st["Mbar"], 0.0, atol=1e-12)
        np.testing.assert_allclose(g.T, np.eye(3) - g.H @ st["Cbar"], atol=1e-15)
        for i in range(2):
            np.testing.assert_allclose(g.N[i], st["TA"][i] - g.K[i] @ st["Cbar"], atol=1e-9)
            np.testing.assert_allclose(g.L[i], g.K[i] + g.N[i] @ g.H, atol=1e-9)
        c = g.data_certificate
        assert c.status == "certified" and g.certificate.status == "certified"
        assert max(c.hinf.values()) <= g.gamma
        assert sorted(x.name for x in c.lmi.checks if "conditioning" not in x.name) == \
            sorted(x.name for x in g.certificate.checks)
        # the data certificate reads the gains: with the rules' gains swapped it fails
        lay = g.layer
        wrong = certify_slack_observer(lay.synthesis, lay.P, lay.L[::-1], G=lay.G,
                                       gamma=lay.gamma)
        assert wrong.status == "violated"


def test_rank_condition_failing_gives_one_clear_error(case):
    """An uncertainty direction the sensors do not see (Cbar Mbar = 0): the layer's
    decoupling refuses it in one line naming the rank condition."""
    model, st, _ = case
    Mb = np.array([[0.0], [0.0], [1.0]])
    Mb = Mb - np.linalg.pinv(st["Cbar"]) @ (st["Cbar"] @ Mb)       # in ker Cbar
    with pytest.raises(ObserverArgumentError) as exc:
        uio_system(uio.uio_plant(st), Mb)
    assert "rank(C F) = 0 != rank(F) = 1" in str(exc.value) and "\n" not in str(exc.value)


def test_layer_fault_augmentation_equals_the_papers_augmented_model(case):
    """design.uio.augment_faults (generic: actuator fault through Fa, sensor fault through
    Fs, fault rate as a disturbance in units of its bound) on the physical two-state model,
    normalised with X = S X_s and y = R y_s, gives El Youssfi's (14)-(15) as the model builds
    them (Abar, Bbar, Cbar, Gam, D_w). Catches a fault entering the wrong block or the
    fault-rate bound applied twice."""
    from vehicle_observers.design.system import PolytopicSystem
    from vehicle_observers.design.uio import augment_faults

    model, st, _ = case
    p = model.C.shape[0]
    phys = PolytopicSystem(model.A, model.C, B=model.B, E=np.zeros((2, p)), D=model.D_w)
    aug = augment_faults(phys, model.B, model.F_s, fault_rate=[model.scale_fdot])
    S, Ri = np.diag(model.scale_x), np.linalg.inv(model.output_scale())
    norm = aug.transformed(S)
    Ab, Bb, Cb, _, Gam, Dw = model.augmented()
    np.testing.assert_allclose(norm.A, Ab, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(norm.B, Bb, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(Ri @ norm.C[0], Cb, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(norm.E[0], np.hstack([Gam, np.zeros((3, p))]), atol=1e-15)
    np.testing.assert_allclose(Ri @ norm.D[0], np.hstack([np.zeros((p, 1)), Dw]), atol=1e-15)
    with pytest.raises(ObserverArgumentError, match="fault_rate"):
        augment_faults(phys, model.B, model.F_s, fault_rate=[0.0])
