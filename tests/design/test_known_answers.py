"""Problems whose answer is known in closed form, solved by the synthesis layer.

No printed numerical example from the LMI literature (Chilali & Gahinet 1996, Tanaka & Wang
2001, Darouach et al. 1994, Raissi/Efimov) could be confirmed from a readable source in the time
available, so these tests use answers derived from theory (each derivation in the docstring)
and computed independently of the layer (numpy/scipy only). Together with
``test_synthesis.py`` (max decay = unobservable mode, scalar H-infinity optimum
1/sqrt(1 + a^2)) they are the layer's known-answer tests."""

import numpy as np
import pytest
from vehicle_observers.core.errors import InfeasibleDesign
from vehicle_observers.design.constraints import Decay, InRegion
from vehicle_observers.design.lmi import unit_disk
from vehicle_observers.design.synthesis import ObserverSynthesis
from vehicle_observers.design.system import PolytopicSystem
from vehicle_observers.design.uio import uio_system


def test_discrete_contraction_limited_by_the_unobservable_mode():
    """Discrete time, x = (observable unstable mode 1.2, unobservable mode 0.5): no gain
    moves 0.5, every other pole can be placed anywhere, so |z| < rho is feasible iff
    rho > 0.5 (the Schur-stability LMI of the disk region is exact for one LTI system)."""
    A = np.array([[1.2, 0.0], [0.0, 0.5]])
    s = PolytopicSystem(A, [[1.0, 0.0]], time="discrete")
    des = ObserverSynthesis(s, [InRegion(unit_disk(0.55))]).solve()
    assert des.status == "certified"
    assert np.abs(np.linalg.eigvals(A - des.L[0] @ s.C[0])).max() < 0.55
    with pytest.raises(InfeasibleDesign):
        ObserverSynthesis(s, [InRegion(unit_disk(0.45))]).solve()


def test_uio_best_decay_is_the_invariant_zero():
    """Unknown-input observer: after decoupling (T F = 0) the modes of (C, T A) that no gain
    can move are the invariant zeros of (A, F, C) (Darouach, Zasadzinski & Xu 1994, Thm 1;
    Hou & Mueller 1992). By hand: with F = e2 and y = (x2, x3), x1' = -x1 + x2 does not enter
    the decoupled outputs, so s = -1 is the only invariant zero; it is checked independently
    as the rank drop of the Rosenbrock matrix [[A - s I, F], [C, 0]] (rank n + m = 4 except at
    s = -1). The layer's largest certified decay rate equals 1."""
    A = np.array([[-1.0, 1.0, 0.0], [0.0, -2.0, 1.0], [0.0, 0.0, -3.0]])
    F = np.array([[0.0], [1.0], [0.0]])
    C = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])

    def rosenbrock_rank(z):
        R = np.block([[A - z * np.eye(3), F], [C, np.zeros((2, 1))]])
        return np.linalg.matrix_rank(R)
    assert rosenbrock_rank(-1.0) == 3
    assert all(rosenbrock_rank(z) == 4 for z in (-3.0, -2.0, -0.5, 0.0, 1.0))
    s, _ = uio_system(PolytopicSystem(A, C), F)
    opt = ObserverSynthesis(s, [Decay(0.0)]).maximise_decay(hi=10.0, tol=1e-4)
    assert opt.optimum == pytest.approx(1.0, rel=2e-3)
    assert opt.status == "certified"
