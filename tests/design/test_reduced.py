"""Reduced-order (Luenberger) observer as a gain structure of the synthesis layer: the error
poles against theory (A22 - L A12, computed independently here), a known answer, the
protocol ``run`` converging, bad input."""

import numpy as np
import pytest
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.design.constraints import BoundedReal, Decay, InRegion
from vehicle_observers.design.lmi import disk
from vehicle_observers.design.synthesis import ObserverSynthesis
from vehicle_observers.design.system import PolytopicSystem
from vehicle_observers.observers.reduced_order import ReducedOrderObserver


def _plant(seed=4):
    """Two seeded vertices, 3 states, 2 outputs whose C is not of the form [I 0]."""
    rng = np.random.default_rng(seed)
    A0 = rng.normal(size=(3, 3)) - 1.0 * np.eye(3)
    A = [A0, A0 + 0.4 * rng.normal(size=(3, 3))]
    C = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, -1.0]])
    B = np.column_stack([rng.normal(size=3), np.zeros(3)])   # u2: the measured scheduling
    return PolytopicSystem(A, C, B=B, E=rng.normal(size=(3, 1)), name="random 3x2")


def test_double_integrator_known_answer():
    """x1' = x2, x2' = u, y = x1: the reduced error is e2' = -L e2 (A22 = 0, A12 = 1), so with
    the poles in the disk |s| < 5 the largest decay rate is 5 (Luenberger 1966), and the
    certified gain is the pole itself (catches a wrong block of the coordinates)."""
    s = PolytopicSystem([[0.0, 1.0], [0.0, 0.0]], [[1.0, 0.0]], B=[[0.0], [1.0]])
    syn = ObserverSynthesis(s, [Decay(0.0), InRegion(disk(5.0))], gains="reduced")
    opt = syn.maximise_decay(hi=10.0, tol=1e-4)
    assert opt.optimum == pytest.approx(5.0, rel=2e-3)
    assert opt.status == "certified"
    L = opt.design.L[0]
    assert L.shape == (1, 1)
    # pole -L (T = [C; N] = I here up to the sign of N)
    pole = opt.design.certificate.poles[0, 0]
    assert pole[0].real == pytest.approx(-abs(L[0, 0]), rel=1e-9)
    assert opt.value < abs(L[0, 0]) < 5.0


def test_reduced_poles_are_those_of_a22_minus_l_a12_independently():
    """For a random plant with C not of the form [I 0], a decay / region / H-infinity design
    of the reduced gain: the error matrix of the unmeasured block, computed here from the
    plant's A_i, C, the coordinates T and L alone (W = [-L I] T, V with C V = 0, W V = I,
    F_i = W A_i V; W A_i = F_i W + G_i C holds, the Luenberger condition), has the
    certificate's poles and meets the requirements (catches a wrong partition or a gain
    mapped in the wrong coordinates)."""
    s = _plant()
    for cons in ([Decay(0.8)], [Decay(0.3), InRegion(disk(8.0))], [BoundedReal(2.0)]):
        des = ObserverSynthesis(s, cons, gains="reduced").solve()
        assert des.status == "certified"
        T, L = des.synthesis.coordinates.T, des.L[0]
        n, p = 3, 2
        Ti = np.linalg.inv(T)
        np.testing.assert_allclose(s.C[0] @ Ti, np.hstack([np.eye(p), np.zeros((p, 1))]),
                                   atol=1e-12)
        W = np.hstack([-L, np.eye(n - p)]) @ T
        V = Ti[:, p:]
        U = Ti @ np.vstack([np.eye(p), L])
        assert np.allclose(s.C[0] @ V, 0) and np.allclose(W @ V, np.eye(n - p))
        for i in range(2):
            F = W @ s.A[i] @ V
            G = W @ s.A[i] @ U
            np.testing.assert_allclose(W @ s.A[i], F @ W + G @ s.C[0], atol=1e-10)
            ev = np.sort_complex(np.linalg.eigvals(F))
            np.testing.assert_allclose(ev, np.sort_complex(des.certificate.poles[i, 0]),
                                       atol=1e-9)
            for c in cons:
                if isinstance(c, Decay):
                    assert ev.real.max() < -c.alpha
                if isinstance(c, InRegion):
                    assert np.abs(ev).max() < 8.0
        if isinstance(cons[0], BoundedReal):
            # z = e2 here: |(sI - F)^-1 (W E)|_inf < gamma, checked on a frequency grid
            for i in range(2):
                F, Ew = W @ s.A[i] @ V, W @ s.E[i]
                g = max(np.linalg.norm(np.linalg.solve(1j * w * np.eye(1) - F, Ew), 2)
                        for w in np.logspace(-3, 3, 400))
                assert g < 2.0


def test_run_converges_on_a_scheduled_plant():
    """The protocol ``run`` of the reduced-order observer on a plant moving between its two
    vertices (memberships measured): the estimate converges to the true state from a wrong
    initial guess at the certified decay rate (catches a wrong observer matrix G or J, or the
    estimate assembled in the wrong coordinates)."""
    s = _plant()
    des = ObserverSynthesis(s, [Decay(1.0)], gains="reduced").solve()
    dt = 4e-3
    t = np.arange(0.0, 4.0 + dt / 2, dt)
    h1 = 0.5 + 0.5 * np.sin(0.7 * t)
    h = np.column_stack([1 - h1, h1])
    u = np.column_stack([np.sin(2 * t), h1])
    x = np.zeros((len(t), 3))
    x[0] = [1.0, -0.5, 2.0]
    for k in range(1, len(t)):           # RK4 with held input, as the observer
        Ak = h[k - 1, 0] * s.A[0] + h[k - 1, 1] * s.A[1]
        f = lambda z: Ak @ z + s.B[0] @ u[k - 1]
        k1 = f(x[k - 1])
        k2 = f(x[k - 1] + dt / 2 * k1)
        k3 = f(x[k - 1] + dt / 2 * k2)
        k4 = f(x[k - 1] + dt * k3)
        x[k] = x[k - 1] + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    y = x @ s.C[0].T
    obs = ReducedOrderObserver(des, dt, schedule=lambda uk, yk: np.array([1 - uk[1], uk[1]]))
    with pytest.raises(ObserverArgumentError, match="schedule"):
        ReducedOrderObserver(des, dt, schedule=lambda uk, yk: np.ones(3)).run(t[:3], u[:3],
                                                                              y[:3])
    traj = obs.run(t, u, y)
    err = np.linalg.norm(traj.x - x, axis=1)
    assert err[0] > 0.2
    # the measured combination is exact at every sample
    np.testing.assert_allclose(traj.x @ s.C[0].T, y, atol=1e-9)
    # decay rate 1: V = e^T P e decays at 2 alpha, so |e(t)| <= e^-t cond(P)^1/2 |e(0)|
    # (the plant is simulated with the observer's holds: only RK4's O(dt^4) differs)
    cond = np.linalg.cond(des.P)
    for tk in (1.0, 2.0, 4.0):
        k = int(round(tk / dt))
        assert err[k] < np.exp(-tk) * np.sqrt(cond) * err[0], tk


def test_reduced_order_bad_input_is_one_clear_line():
    """A vertex-dependent C, a noisy output (D != 0), as many outputs as states, and a
    full-order design given to the reduced-order observer are each refused in one line."""
    A = [np.eye(2) * -1.0, np.eye(2) * -2.0]
    with pytest.raises(ObserverArgumentError, match="common to all vertices"):
        ObserverSynthesis(PolytopicSystem(A, [[[1.0, 0]], [[0, 1.0]]]), gains="reduced")
    with pytest.raises(ObserverArgumentError, match="D = 0"):
        ObserverSynthesis(PolytopicSystem(A, [[1.0, 0]], E=[[1.0], [0]], D=[[1.0]]),
                          gains="reduced")
    with pytest.raises(ObserverArgumentError, match="fewer outputs"):
        ObserverSynthesis(PolytopicSystem(A, np.eye(2)), gains="reduced")
    full = ObserverSynthesis(PolytopicSystem(A, [[1.0, 0]]), [Decay(0.1)]).solve()
    with pytest.raises(ObserverArgumentError, match="gains='reduced'"):
        ReducedOrderObserver(full, 1e-3)


def test_discrete_time_error_follows_a22_minus_l_a12_exactly():
    """In discrete time the reduced-order error obeys e2_{k+1} = (A22(h_k) - L A12(h_k)) e2_k
    exactly: the run's error, mapped by W = [-L I] T, equals the recursion of F_i = W A_i V
    computed here (catches an off-by-one sample in the observer or a wrong G_i, J_i)."""
    rng = np.random.default_rng(7)
    A0 = 0.5 * rng.normal(size=(3, 3))
    A = [A0, A0 + 0.2 * rng.normal(size=(3, 3))]
    C = np.array([[1.0, 0.0, 1.0], [0.0, 2.0, 1.0]])
    B = np.column_stack([rng.normal(size=3), np.zeros(3)])
    s = PolytopicSystem(A, C, B=B, time="discrete", dt=0.1)
    des = ObserverSynthesis(s, [Decay(1.0)], gains="reduced").solve()
    assert des.status == "certified"
    T, L = des.synthesis.coordinates.T, des.L[0]
    W = np.hstack([-L, np.eye(1)]) @ T
    V = np.linalg.inv(T)[:, 2:]
    N = 60
    t = np.arange(N) * 0.1
    h1 = 0.5 + 0.5 * np.cos(0.9 * t)
    u = np.column_stack([np.sin(t), h1])
    x = np.zeros((N, 3))
    x[0] = [0.3, -1.0, 0.5]
    for k in range(1, N):
        x[k] = ((1 - h1[k - 1]) * s.A[0] + h1[k - 1] * s.A[1]) @ x[k - 1] + B @ u[k - 1]
    y = x @ C.T
    obs = ReducedOrderObserver(des, 0.1, schedule=lambda uk, yk: np.array([1 - uk[1], uk[1]]))
    xh = obs.run(t, u, y).x
    e2 = (x - xh) @ W.T
    assert abs(e2[0, 0]) > 0.1
    rec = e2[0].copy()
    for k in range(1, N):
        F = W @ ((1 - h1[k - 1]) * s.A[0] + h1[k - 1] * s.A[1]) @ V
        rec = F @ rec
        np.testing.assert_allclose(e2[k], rec, rtol=1e-8, atol=1e-12)
    assert abs(e2[-1, 0]) < np.exp(-1.0 * 0.1 * (N - 1)) * np.sqrt(np.linalg.cond(des.P)) \
        * abs(e2[0, 0])
