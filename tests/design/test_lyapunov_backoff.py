"""Optimise, back off, certify for parameter-dependent Lyapunov designs
(``ParameterDependentSynthesis.minimise`` / ``maximise_decay``): the optimum on the boundary,
the backed-off design certified from the data with a real margin."""

import numpy as np
import pytest
from vehicle_observers.core.errors import CertificationError, ObserverArgumentError
from vehicle_observers.design import lyapunov as ly
from vehicle_observers.design.certify import certify_parameter_dependent
from vehicle_observers.design.constraints import Decay, InputToState
from vehicle_observers.design.lmi import MIN_RELATIVE_MARGIN
from vehicle_observers.design.lyapunov import ParameterDependentSynthesis
from vehicle_observers.design.system import PolytopicSystem

C3 = np.array([[0.0, 0.0, 1.0]])
#: a margin well above the certificate's round-off threshold (1e-9): chosen here as 1000x
#: it, so "certified with a real margin" cannot pass at round-off level
REAL_MARGIN = 1e3 * MIN_RELATIVE_MARGIN


def _embed(A0, a31=0.0):
    """3-state vertex: the 2x2 block ``A0`` is unobservable from ``y = x_3``."""
    A = np.zeros((3, 3))
    A[:2, :2] = A0
    A[2, 2], A[2, 0] = -1.0, a31
    return A


def _spirals(phi):
    """Two stable spirals (eigenvalues -0.1 +- 1.41j, unobservable) with no common quadratic
    Lyapunov function (tests/design/test_lyapunov.py)."""
    A = [_embed(np.array([[-0.1, 1.0], [-2.0, -0.1]])),
         _embed(np.array([[-0.1, 2.0], [-1.0, -0.1]]))]
    return PolytopicSystem(A, C3, E=np.eye(3), rate_bounds=[phi, phi])


def _iss(phi):
    A = [_embed(np.array([[-0.5, 1.0], [-2.0, -0.5]]), 1.0),
         _embed(np.array([[-0.5, 2.0], [-1.0, -0.5]]), 1.0)]
    return PolytopicSystem(A, C3, E=np.eye(3), rate_bounds=[phi, phi])


def test_minimise_c_backs_off_to_a_certified_margin():
    """min c of V' <= -0.2 V + c |w|^2 (relaxed coupling, slack M, phi = 0.5): the design at
    the optimum is on the boundary (relative margin below the real-margin threshold), the
    design re-solved at c (1 + 0.05) is "certified" from the data with a relative margin above
    it, and its c is the backed-off value. The optimum is a true lower bound: the same P, L,
    M certified at c 5 % below the optimum are "violated" (no P(h), L(h) does better than the
    optimum). Catches an optimum reported too high, a back-off not applied, the fixed c not
    reaching the certificate, or a design returned at round-off margin."""
    syn = ParameterDependentSynthesis(_iss(0.5), [InputToState(alpha=0.2, c=None)],
                                      eps=1e-9, P_upper=100.0)
    opt = syn.minimise(backoff=0.05)
    assert opt.quantity == "c" and opt.value == pytest.approx(1.05 * opt.optimum, rel=1e-15)
    assert opt.at_optimum.certificate.lmi.min_relative_margin < REAL_MARGIN
    assert opt.status == "certified" and opt.margin > REAL_MARGIN
    np.testing.assert_array_equal(opt.design.c, [opt.value])
    d = opt.design
    below = certify_parameter_dependent(syn, d.P, d.L, d.M, np.array([0.95 * opt.optimum]))
    assert below.status == "violated" and below.worst_name().startswith("iss[")
    with pytest.raises(ObserverArgumentError, match="c=None"):
        ParameterDependentSynthesis(_iss(0.5), [InputToState(alpha=0.2, c=1.0)]).minimise()


def test_maximise_decay_backs_off_below_the_unobservable_rate():
    """Largest alpha of V' <= -2 alpha V on the two spirals (phi = 0.05): their unobservable
    poles have Re = -0.1, so 0 < alpha* < 0.1 (theory); the design at alpha* (1 - 0.05) is
    "certified" with a real margin and its frozen error systems A_k - L_k C have every pole
    left of -alpha (eigenvalues computed here). Catches a bisection on the wrong constraint,
    an unbounded optimum (decay not entering the LMIs) or a back-off in the wrong
    direction."""
    syn = ParameterDependentSynthesis(_spirals(0.05), [Decay()])
    opt = syn.maximise_decay(hi=0.2, tol=1e-2, backoff=0.05)
    assert 0.0 < opt.optimum < 0.1
    assert opt.value == pytest.approx(0.95 * opt.optimum, rel=1e-15)
    assert opt.status == "certified" and opt.margin > REAL_MARGIN
    assert opt.design.synthesis.constraints[0].alpha == opt.value
    for Ak, Lk in zip(_spirals(0.05).A, opt.design.L[0]):
        assert np.linalg.eigvals(Ak - Lk @ C3).real.max() < -opt.value


def test_planted_wrong_rate_term_fails_the_backed_off_design(monkeypatch):
    """A builder whose rate term uses phi / 100 (a mistake in how the problem is posed): the
    optimum and the backed-off design come from that looser problem, and the data
    certificate, rebuilt from the system's rate bounds, rejects the backed-off design
    (CertificationError naming the LMI) instead of calling it certified."""
    rate = ly.rate_term
    monkeypatch.setattr(ly, "rate_term", lambda P, M, phi: rate(P, M, np.asarray(phi) / 100))
    with pytest.raises(CertificationError) as ei:
        ParameterDependentSynthesis(_spirals(0.3), [InputToState(alpha=0.0, c=None)],
                                    P_upper=100.0).minimise()
    assert ei.value.lmi.startswith("iss[")
