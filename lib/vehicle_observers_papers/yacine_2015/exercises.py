"""Exercise checkers of notebook 02 (Yacine et al., IEEE TCST 23(2), 2015).

Each ``check_N(answer)`` computes the expected answer **independently** of the notebook's
solution cell (a library call or a second route), calls the student's function on more than
one input (so a hard-coded number fails) and shows one line through
:func:`vehicle_observers.results.teaching.check` (``correct`` / ``not yet`` with a hint /
``not attempted`` while the stub still returns ``...``).

1. one step of Levant's differentiator (HOSMD, n = 3) against the compiled library loop;
2. the lateral forces from the transformed state (12) (the paper's (46)), derived by solving
   the two lines of (12);
3. a decay-rate LMI (the core of (33), one vertex, no premise error) solved with cvxpy and
   certified by eigenvalues;
4. the time after which the bound (45) falls below ``||e(0)||``, closed form against the
   bound evaluated by :func:`..theorem1.bound_34`.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from vehicle_observers.design.lmi import Certificate, check_matrix
from vehicle_observers.observers.differentiators import LEVANT_LAMBDA, levant_differentiator
from vehicle_observers.results.teaching import check

from vehicle_observers_papers.yacine_2015 import constants as Y
from vehicle_observers_papers.yacine_2015 import theorem1 as T1

_EMPTY = (None, Ellipsis)


def _signals():
    """Two test signals of the differentiator exercise: (name, samples, step, L)."""
    t = np.arange(0.0, 3.0, 1e-3)
    return [("sin t", np.sin(t), 1e-3, 1.0),
            ("a noisy chirp", np.sin(2 * t + 0.3 * t**2)
             + 1e-4 * np.random.default_rng(2).uniform(-1, 1, len(t)), 1e-3, 200.0)]


def _euler_levant(f, tau, L, taylor: bool):
    """The recursive differentiator n = 3 on samples ``f`` with plain (``taylor=False``) or
    Taylor-augmented explicit Euler: the checker's reference for diagnosing an answer."""
    lam, n = LEVANT_LAMBDA, 3
    z = np.array([f[0], 0.0, 0.0, 0.0])
    Z = np.empty((len(f), 4))
    for k in range(len(f)):
        Z[k] = z
        v, prev = np.empty(4), f[k]
        for i in range(n):
            e, q = z[i] - prev, n - i
            v[i] = -lam[q] * L ** (1 / (q + 1)) * abs(e) ** (q / (q + 1)) * np.sign(e) + z[i + 1]
            prev = v[i]
        v[n] = -lam[0] * L * np.sign(z[n] - prev)
        znew = z + tau * v
        if taylor:
            znew[0] += tau**2 / 2 * z[2] + tau**3 / 6 * z[3]
            znew[1] += tau**2 / 2 * z[3]
        z = znew
    return Z


def _diagnose_1(got: dict) -> str:
    """Which derivative estimate first leaves the library's loop, when, by how much, and whether
    the answer is plain explicit Euler (Taylor terms missing)."""
    for name, f, tau, L in _signals():
        want = levant_differentiator(f, tau, 3, L)
        G = got[name]
        bad = np.abs(G - want) > 1e-9 * (1 + np.abs(want))
        if not bad.any():
            continue
        k, i = np.argwhere(bad)[0]
        msg = (f"on {name}: z_{i} (estimate of f^({i})) first differs at sample {k} (t = {k * tau:.3f} s): "
               f"{G[k, i]:.6g} instead of {want[k, i]:.6g}")
        if np.allclose(G, _euler_levant(f, tau, L, taylor=False), rtol=1e-9, atol=1e-9):
            msg += ("; your step is plain explicit Euler. What must z_0(k+1) be when f is a cubic and "
                    "z holds its exact derivatives? Expand f(t + tau) in tau")
        elif k <= 1:
            msg += ("; already the first step: check the correction terms v_i (their order and which "
                    "error each uses)")
        return msg
    return "the answer has the wrong shape"


def check_1(levant_step, show: bool = True):
    """Exercise 02.1: ``levant_step(z, f_k, tau, L)`` -> ``z`` at the next sample, for ``n = 3``
    (Levant 2003 recursive form, gains :data:`LEVANT_LAMBDA`, Taylor-augmented explicit Euler
    of Livne & Levant 2014). Run over two signals from ``z = (f_0, 0, 0, 0)`` and compared with
    :func:`levant_differentiator` (the library's compiled loop) at every sample. The hint names
    the first derivative estimate that leaves the library's, at which sample and by how much, and
    says whether the answer is plain explicit Euler (the Taylor terms left out)."""
    def answer():
        out = {}
        for name, f, tau, L in _signals():
            z = np.array([f[0], 0.0, 0.0, 0.0])
            Z = np.empty((len(f), 4))
            for k in range(len(f)):
                Z[k] = z
                z = levant_step(z.copy(), float(f[k]), tau, L)
                if z is None or z is Ellipsis:
                    return None
                z = np.asarray(z, dtype=float).reshape(4)
            out[name] = Z
        return out

    expected = {name: levant_differentiator(f, tau, 3, L) for name, f, tau, L in _signals()}
    hint = "compare your z_i with the library's at the first samples"
    try:
        got = answer()
    except Exception:   # the student's code: reported by check below
        got = None
    if got is not None:
        hint = _diagnose_1(got)
        answer_value = got
    else:
        answer_value = answer
    return check("02.1", answer_value, expected, rtol=1e-9, atol=1e-9, show=show, hint=hint)


#: transformed states ``(x3 [m/s^2], x4 [rad/s^2])`` the checker of exercise 2 tries: a left
#: turn (both forces positive), a pure yaw moment (x3 = 0) and a braking-like mix
X34_2 = ((2.0, 0.5), (0.0, 1.0), (-3.0, 2.0))


def expected_2(x3, x4, p=None) -> tuple[float, float]:
    """``(F_f, F_r)`` [N] solving the two lines of (12), ``x3 = (F_f + F_r)/m`` and
    ``x4 = (l_f F_f - l_r F_r)/I_z``, as a linear system (``numpy.linalg.solve``), not the closed
    form (46) the library uses."""
    p = Y.params if p is None else p
    M = np.array([[1 / p.m, 1 / p.m], [p.a_f / p.I_z, -p.a_r / p.I_z]])
    return tuple(float(v) for v in np.linalg.solve(M, [x3, x4]))


def check_2(forces, show: bool = True):
    """Exercise 02.2: ``forces(x3, x4)`` -> ``(F_f, F_r)`` [N]: the lateral forces of the paper's
    car recovered from the transformed state (12) (the observer estimates ``x3, x4``, the paper
    plots forces: its (46)). Three states :data:`X34_2`; the hint names the force that is off,
    by how many newtons, and the usual cause (the two forces swapped, a sign of the yaw-moment
    term)."""
    want = {f"(x3, x4) = {x}": np.array(expected_2(*x)) for x in X34_2}
    got = {}

    def answer():
        for x in X34_2:
            out = forces(*x)
            if out is None or out is Ellipsis or any(o is None or o is Ellipsis for o in out):
                return None
            got[f"(x3, x4) = {x}"] = np.asarray(out, dtype=float).ravel()
        return dict(got)

    hint = ("write the two lines of (12) as a 2 x 2 linear system in (F_f, F_r) and solve it "
            "(by hand: add l_r times the first to the second)")
    try:
        probe = answer()
    except Exception:   # the student's code: reported by check below
        probe = None
    if probe:
        for k, w in want.items():
            g = probe[k]
            if g.shape != (2,):
                hint = f"return two numbers (F_f, F_r) in N, got {g.size}"
                break
            if not np.allclose(g, w, rtol=1e-9, atol=1e-6):
                i = int(np.argmax(np.abs(g - w)))
                name = ("F_f", "F_r")[i]
                hint = f"at {k}: {name} is {g[i]:.1f} N, expected {w[i]:.1f} N (off by {g[i] - w[i]:+.1f} N)"
                if np.allclose(g[::-1], w, rtol=1e-9, atol=1e-6):
                    hint += "; the two forces are swapped"
                elif np.allclose(g.sum(), w.sum(), rtol=1e-9, atol=1e-6):
                    hint += ("; their sum m x3 is right, so the yaw-moment line l_f F_f - l_r F_r = I_z x4 "
                             "is not")
                break
    return check("02.2", answer, want, rtol=1e-9, atol=1e-6, show=show, hint=hint)


#: the systems of exercise 3: (name, A, C, alpha)
SYSTEMS_3 = (
    ("lightly damped oscillator", np.array([[0.0, 1.0], [-4.0, -0.2]]), np.array([[1.0, 0.0]]), 1.0),
    ("unstable chain", np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.5, -1.0, 0.3]]),
     np.array([[1.0, 0.0, 0.0]]), 2.0),
)


def certify_decay(A, C, alpha, P, L) -> dict:
    """Eigenvalue certificate of ``A^T P + P A - P L C - C^T L^T P + alpha P < 0``, ``P > 0``
    (:class:`~vehicle_observers.design.lmi.Certificate`: "certified", "inconclusive" or
    "violated") and whether the spectral abscissa of ``A - L C`` is below ``-alpha/2``."""
    A, C, P, L = (np.asarray(v, dtype=float) for v in (A, C, P, L))
    Phi = A - L.reshape(A.shape[0], C.shape[0]) @ C
    cert = Certificate([check_matrix("P", P, "pos"),
                        check_matrix("Xi", Phi.T @ P + P @ Phi + alpha * P, "neg")])
    return {"status": cert.status, "decays": bool(np.linalg.eigvals(Phi).real.max() < -alpha / 2)}


def check_3(decay_gain, show: bool = True):
    """Exercise 02.3: ``decay_gain(A, C, alpha)`` -> ``(P, L)`` with ``P > 0`` and
    ``(A - L C)^T P + P (A - L C) + alpha P < 0`` (the vertex LMI of (33) without the premise
    error, ``M = P L``), solved with cvxpy. Graded on the two :data:`SYSTEMS_3` by an
    independent eigenvalue certificate (:func:`certify_decay`): expected "certified" (not only
    the right signs: relative margin >= 1e-9, cond(P) <= 1e8) and a decay faster than alpha/2."""
    def answer():
        out = {}
        for name, A, C, alpha in SYSTEMS_3:
            got = decay_gain(A.copy(), C.copy(), alpha)
            if got is None or got is Ellipsis or any(g is None or g is Ellipsis for g in got):
                return None
            out[name] = certify_decay(A, C, alpha, *got)
        return out

    expected = {name: {"status": "certified", "decays": True} for name, *_ in SYSTEMS_3}
    return check("02.3", answer, expected, show=show,
                 hint="variables P (symmetric) and M = P L; constraint A^T P + P A - M C - C^T M^T "
                      "+ alpha P << -eps I and P >> I; then L = solve(P, M); an 'inconclusive' status "
                      "means margins below the solver's accuracy: add a margin eps or bound P")


#: the cases of exercise 4: (alpha, c, alpha1, alpha2, ||e0||, max_[0,T] ||delta||, T)
#: (the notebook's paper-alpha-like case, one where the delta term matters, one ending at T)
CASES_4 = ((0.5, 0.04, 1.0, 4.0e5, 2.9, 0.01, 25.0),
           (0.5, 0.5, 1.0, 10.0, 1.0, 0.5, 3.0),
           (1.0, 0.5, 1.0, 10.0, 1.0, 0.5, 8.0))


def _t_informative_numeric(alpha, c, a1, a2, e0, dmax, T, dt=1e-3):
    """First time the bound (34)/(45) (:func:`..theorem1.bound_34`, with ``||delta|| = dmax``
    on ``[0, T]`` and 0 after) is below ``||e0||`` after ``T``: a second route, by search."""
    design = SimpleNamespace(alpha=alpha, c=c, alpha1=a1, alpha2=a2)
    horizon = 2.0 * T + 10.0 / alpha
    while True:                     # lengthen the horizon until the bound crosses ||e0||
        t = np.arange(0.0, horizon, dt)
        b = T1.bound_34(t, e0, np.where(t <= T, dmax, 0.0), T, design)["paper"]
        k = np.flatnonzero((t >= T) & (b < e0))
        if len(k):
            return float(t[k[0]])
        horizon *= 2


def check_4(t_informative, show: bool = True):
    """Exercise 02.4: ``t_informative(alpha, c, a1, a2, e0, dmax, T)`` [s], the time after
    which (45) is below ``||e(0)||`` (not before ``T``), against a search on the bound itself
    (:func:`..theorem1.bound_34`) for three cases."""
    def answer():
        out = []
        for case in CASES_4:
            v = t_informative(*case)
            if v is None or v is Ellipsis:
                return None
            out.append(float(v))
        return out

    expected = [_t_informative_numeric(*case) for case in CASES_4]
    return check("02.4", answer, expected, rtol=0, atol=2e-3, show=show,
                 hint="after T, (45) is B0 e^{-alpha t/2} with B0^2 = a2/a1 e0^2 + c/(alpha a1) dmax^2 "
                      "e^{alpha T}; solve B0 e^{-alpha t/2} = e0 for t, and take max(T, that)")


__all__ = ["check_1", "check_2", "check_3", "check_4", "certify_decay", "SYSTEMS_3", "CASES_4",
           "LEVANT_LAMBDA"]
