"""Property: on seeded random stable, observable vertex sets, every design the layer calls
"certified" (common gain, PDC with the Tuan and Tanaka relaxations, gains scheduled by other
memberships, reduced order, discrete time; decay, disk region, H-infinity) passes an
independent numpy check written here, in other forms than the layer's: the Schur
complements of the region and discrete-time LMIs, the Lyapunov inequality of the blended
system at random memberships instead of the relaxation's vertex sums, the H-infinity norm on
a frequency grid."""

import dataclasses

import numpy as np
import pytest
from vehicle_observers.core.errors import InfeasibleDesign
from vehicle_observers.design.certify import certify_observer
from vehicle_observers.design.constraints import BoundedReal, Decay, InRegion
from vehicle_observers.design.lmi import disk
from vehicle_observers.design.synthesis import ObserverSynthesis
from vehicle_observers.design.system import PolytopicSystem

SEEDS = range(4)


def _vertices(rng, n, p, q=2, common_C=True, discrete=False):
    """q vertices around a stable A0 (continuous: Hurwitz; discrete: spectral radius 0.9),
    C common or per vertex; redrawn until every vertex is observable (PBH)."""
    while True:
        A0 = rng.normal(size=(n, n))
        if discrete:
            A0 = 0.9 * A0 / np.abs(np.linalg.eigvals(A0)).max()
        else:
            A0 = A0 - (np.linalg.eigvals(A0).real.max() + 0.5) * np.eye(n)
        A = A0 + 0.15 * rng.normal(size=(q, n, n))
        C = rng.normal(size=(p, n)) if common_C else rng.normal(size=(q, p, n))
        E = rng.normal(size=(n, 1))
        s = PolytopicSystem(A, C, E=E, time="discrete" if discrete else "continuous",
                            dt=0.05)
        obs = all(np.linalg.matrix_rank(np.vstack([s.C[i] @ np.linalg.matrix_power(s.A[i], k)
                                                   for k in range(n)])) == n
                  for i in range(q))
        stable = all((np.abs(np.linalg.eigvals(a)).max() < 1) if discrete
                     else (np.linalg.eigvals(a).real.max() < 0) for a in s.A)
        if obs and stable:
            return s


def _simplex(rng, q, k=25):
    """The q vertices and k random points of the simplex of memberships."""
    return np.vstack([np.eye(q), rng.dirichlet(np.ones(q), size=k)])


def _hinf_grid(Acl, B, H):
    """Lower bound of ||H (sI - Acl)^-1 B||_inf on a frequency grid."""
    n = Acl.shape[0]
    return max(np.linalg.norm(H @ np.linalg.solve(1j * w * np.eye(n) - Acl, B), 2)
               for w in np.concatenate([[0.0], np.logspace(-3, 3, 300)]))


def _check(des, rng):
    """Independent check of a certified design: P > 0 and, for every membership sample of
    the plant (and of the gains' own memberships for "pairs"), each requirement in a form
    other than the layer's LMI."""
    syn, P, Ls = des.synthesis, des.P, des.L
    s = syn.system
    assert np.linalg.eigvalsh((P + P.T) / 2).min() > 0
    H = _simplex(rng, s.q)
    G = _simplex(rng, len(Ls)) if syn.gains == "pairs" else None
    for k, h in enumerate(H):
        A = np.tensordot(h, s.A, axes=1)
        C = np.tensordot(h, s.C, axes=1)
        E = np.tensordot(h, s.E, axes=1)
        g = h if syn.gains == "pdc" else (G[k % len(G)] if G is not None else np.ones(1))
        L = np.tensordot(g, Ls, axes=1)
        Acl = A - L @ C
        for c in syn.constraints:
            if isinstance(c, Decay) and s.discrete:
                rho = np.exp(-c.alpha * s.dt)
                # Schur complement of [[-rho P, P Acl], [Acl^T P, -rho P]] < 0
                assert np.linalg.eigvalsh(Acl.T @ P @ Acl - rho ** 2 * P).max() < 0, h
                assert np.abs(np.linalg.eigvals(Acl)).max() < rho
            elif isinstance(c, Decay):
                X = P @ Acl
                assert np.linalg.eigvalsh(X + X.T + 2 * c.alpha * P).max() < 0, h
                assert np.linalg.eigvals(Acl).real.max() < -c.alpha
            elif isinstance(c, InRegion):
                # disk |s| < R  <=>  Acl^T P Acl - R^2 P < 0 (Schur complement)
                R = -c.region.L[0, 0]
                assert np.linalg.eigvalsh(Acl.T @ P @ Acl - R ** 2 * P).max() < 0, h
                assert np.abs(np.linalg.eigvals(Acl)).max() < R
            elif isinstance(c, BoundedReal):
                if syn.gains == "common" or len(Ls) == 1:
                    assert _hinf_grid(Acl, E, s.H) < c.gamma


def _designs(seed):
    rng = np.random.default_rng(seed)
    cont = _vertices(rng, 3, 1)
    varC = _vertices(rng, 3, 1, q=3, common_C=False)
    red = _vertices(rng, 3, 2)
    disc = _vertices(rng, 3, 1, discrete=True)
    return rng, [
        ObserverSynthesis(cont, [Decay(0.3), InRegion(disk(15.0))]),
        ObserverSynthesis(cont, [BoundedReal(3.0)]),
        ObserverSynthesis(varC, [Decay(0.2)], gains="pdc", relaxation="tuan"),
        ObserverSynthesis(varC, [Decay(0.2)], gains="pdc", relaxation="tanaka"),
        ObserverSynthesis(cont, [Decay(0.2)], gains="pairs", n_gains=2),
        ObserverSynthesis(red, [Decay(0.3), InRegion(disk(20.0))], gains="reduced"),
        ObserverSynthesis(disc, [Decay(1.0)]),
    ]


@pytest.mark.parametrize("seed", SEEDS)
def test_every_certified_design_passes_the_independent_check(seed):
    """Every "certified" design of seven structures on random vertex sets passes the
    independent check, and most of them are certified (catches a certificate that calls a
    design certified although a blended system violates a requirement, e.g. a wrong
    relaxation sum, a region posed on the wrong matrix, a wrong reduced-order block, or a
    property that holds vacuously because nothing is certified)."""
    rng, syns = _designs(seed)
    certified = caught = 0
    for syn in syns:
        try:
            des = syn.solve(raise_on_violation=False)
        except InfeasibleDesign:
            continue
        if des.status == "certified":
            certified += 1
            _check(des, rng)
        # planted: the gains negated. Whenever the independent check fails, the layer's
        # certificate of (P, -L) must not say "certified"
        bad = dataclasses.replace(des, L=-des.L)
        try:
            _check(bad, rng)
        except AssertionError:
            caught += 1
            cert = certify_observer(syn, des.P, -des.L, gamma=des.gamma, c=des.c)
            assert cert.status == "violated", (syn.name, cert.reason())
    assert certified >= 5, certified
    assert caught >= 3, caught
