"""Exercise checkers of notebook 02 (yacine_2015/exercises.py): each accepts a worked solution,
rejects a plausible wrong answer (with a hint) and reports an empty stub as not attempted."""

import math

import numpy as np
import pytest
from vehicle_observers.observers.differentiators import LEVANT_LAMBDA
from vehicle_observers.results.teaching import CORRECT, EMPTY, WRONG
from vehicle_observers_papers.yacine_2015 import exercises as ex


def levant_step(z, f_k, tau, L):
    n = len(z) - 1
    v = np.empty(n + 1)
    prev = f_k
    for i in range(n):
        e = z[i] - prev
        p = n - i
        v[i] = -LEVANT_LAMBDA[p] * L ** (1 / (p + 1)) * abs(e) ** (p / (p + 1)) * np.sign(e) + z[i + 1]
        prev = v[i]
    v[n] = -LEVANT_LAMBDA[0] * L * np.sign(z[n] - prev)
    return np.array([z[i] + tau * v[i] + sum(tau**l / math.factorial(l) * z[i + l]
                                             for l in range(2, n - i + 1)) for i in range(n + 1)])


def plain_euler_step(z, f_k, tau, L):
    """The same correction terms without the Taylor terms: close, but not the library's scheme."""
    full = levant_step(z, f_k, tau, L)
    return full - np.array([sum(tau**l / math.factorial(l) * z[i + l] for l in range(2, 4 - i))
                            for i in range(4)])


def forces(x3, x4, p=ex.Y.params):
    L = p.a_f + p.a_r
    return (p.m * p.a_r * x3 + p.I_z * x4) / L, (p.m * p.a_f * x3 - p.I_z * x4) / L


def decay_gain(A, C, alpha, eps=1e-3):
    import cvxpy as cp

    n, m = A.shape[0], C.shape[0]
    P, M = cp.Variable((n, n), symmetric=True), cp.Variable((n, m))
    X = A.T @ P + P @ A - M @ C - C.T @ M.T + alpha * P
    cp.Problem(cp.Minimize(cp.trace(P)), [P >> np.eye(n), (X + X.T) / 2 << -eps * np.eye(n)]).solve()
    return P.value, np.linalg.solve(P.value, M.value)


def t_informative(alpha, c, a1, a2, e0, dmax, T):
    B0 = np.sqrt(a2 / a1 * e0**2 + c / (alpha * a1) * dmax**2 * np.exp(alpha * T))
    return max(T, 2 / alpha * np.log(B0 / e0))


@pytest.mark.parametrize("k,right,wrong", [
    (1, levant_step, plain_euler_step),
    (2, forces, lambda x3, x4: forces(x3, x4)[::-1]),                   # the two forces swapped
    (3, decay_gain, lambda A, C, alpha: (np.eye(len(A)), np.zeros((len(A), 1)))),   # no gain
    (4, t_informative, lambda alpha, c, a1, a2, e0, dmax, T: 2 / alpha * np.log(np.sqrt(a2 / a1))),
])
def test_checker_accepts_the_solution_and_rejects_a_wrong_answer(k, right, wrong):
    chk = getattr(ex, f"check_{k}")
    assert chk(right, show=False).status == CORRECT
    out = chk(wrong, show=False)
    assert out.status == WRONG and "Hint" in out.message
    assert chk(lambda *a: ..., show=False).status == EMPTY


def test_decay_certificate_refuses_a_closed_loop_at_the_decay_limit():
    """The certificate of exercise 3 is Certificate.status: the solution is certified; the same
    P, L on a system shifted so that A - L C decays at alpha/2 (to 1e-12) are not."""
    A, C, alpha = ex.SYSTEMS_3[0][1], ex.SYSTEMS_3[0][2], ex.SYSTEMS_3[0][3]
    P, L = decay_gain(A, C, alpha)
    assert ex.certify_decay(A, C, alpha, P, L) == {"status": "certified", "decays": True}
    Phi = A - L @ C
    shift = np.linalg.eigvals(Phi).real.max() + alpha / 2 - 1e-12
    A2 = A - shift * np.eye(2)
    assert ex.certify_decay(A2, C, alpha, P, L)["status"] != "certified"


def test_forces_hint_says_which_force_and_by_how_many_newtons():
    """Exercise 02.2's hint diagnoses in newtons: a yaw-moment sign error keeps F_f + F_r = m x3
    and the hint says so (catches a hint that only reports a relative error)."""
    out = ex.check_2(lambda x3, x4: forces(x3, -x4), show=False)
    assert out.status == WRONG and " N" in out.message and "yaw-moment" in out.message
    Ff, Fr = ex.expected_2(2.0, 0.5)
    assert Ff + Fr == pytest.approx(1500 * 2.0) and 1.1 * Ff - 1.44 * Fr == pytest.approx(2454 * 0.5)


def test_levant_hint_recognises_plain_euler():
    """A step without the Taylor terms is diagnosed as plain explicit Euler, with the derivative
    estimate and the sample where it leaves the library's loop (catches a hint that gives the
    code instead of a diagnosis, or none)."""
    out = ex.check_1(plain_euler_step, show=False)
    assert out.status == WRONG and "plain explicit Euler" in out.message and "sample" in out.message
    assert "tau**" not in out.message and "z_i +=" not in out.message
