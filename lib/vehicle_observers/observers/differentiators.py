"""Levant's arbitrary-order robust exact differentiator (HOSMD), in discrete time.

Yacine et al. 2015 (IEEE TCST 23(2)) take the time derivatives of the vision outputs
``y_L, psi_L`` (Sec. III-A, eq. (11), and III-B, eq. (26)) with "a third-order sliding mode
differentiator [16]", i.e. A. Levant, "Higher-order sliding modes, differentiation and
output-feedback control", Int. J. Control 76(9-10), 2003, eq. (7) / recursive form:

    z_0' = v_0,  v_0 = -lam_n L^{1/(n+1)} |z_0 - f|^{n/(n+1)} sign(z_0 - f) + z_1
    z_i' = v_i,  v_i = -lam_{n-i} L^{1/(n-i+1)} |z_i - v_{i-1}|^{(n-i)/(n-i+1)}
                                                     sign(z_i - v_{i-1}) + z_{i+1}
    z_n' = -lam_0 L sign(z_n - v_{n-1})

with ``|f^{(n+1)}| <= L`` and Levant's standard gains (Levant 2003, valid for n <= 5)
``lam_0..lam_5 = 1.1, 1.5, 2, 3, 5, 8`` (:data:`LEVANT_LAMBDA`). After a finite time
``z_i = f^{(i)}`` exactly (continuous time, noise-free). With bounded noise ``|eta| <= eps``
and sampling step ``tau`` the accuracy is (Levant 2003, Theorems 5-6)

    |z_i - f^{(i)}| <= mu_i L^{i/(n+1)} eps^{(n-i+1)/(n+1)}   and   <= nu_i L tau^{n-i+1}.

Discretisation (the reason for the choice): the input is sampled at constant ``tau`` and
the differentiator integrated by the *Taylor-augmented explicit Euler* scheme of
Livne & Levant, "Proper discretization of homogeneous differentiators", Automatica 50(8),
2014 (also Barbot, Levant, Livne, Lunz, "Discrete differentiators based on sliding modes",
Automatica 112, 2020):

    z_i(k+1) = z_i(k) + tau v_i(k) + sum_{l=2}^{n-i} tau^l / l! z_{i+l}(k),   i = 0..n,

``v_i(k)`` evaluated with the current sample ``f(k)``. Why: (a) it is explicit and one
pass over the samples (a numba loop, no implicit solve); (b) it keeps the discrete system
homogeneous, hence the accuracy asymptotics ``tau^{n-i+1}`` and ``eps^{(n-i+1)/(n+1)}``
above; (c) its update is the exact Taylor expansion on polynomials of degree ``n``: when
``z_i = f^{(i)}(t_k)`` every correction term but the last vanishes, so after convergence the
only error left is the chattering of the sign term (``lam_0 L tau`` on ``z_n``, giving the
band ``nu_i L tau^{n-i+1}``; measured ``nu_i`` = 2..10 for ``n = 3``, see the tests). Plain
Euler (``z_i += tau v_i``) drops the ``tau^l z_{i+l} / l!`` terms, a truncation error per
step that the nonlinear correction has to absorb.

:class:`LevantDifferentiator` follows the observer contract of
:mod:`vehicle_observers.core.protocol` (readable ``step``, compiled ``run`` returning a
:class:`~vehicle_observers.core.protocol.Trajectory`); :func:`levant_differentiator` is the
array form of the same compiled loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial
from typing import ClassVar

import numpy as np
from numba import njit

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.observers.fixed_step import FixedStepObserver, positive

#: Levant 2003 standard gains lambda_0 .. lambda_5 (lambda_0 multiplies L sign(.) in the
#: last equation, lambda_n the first), sufficient for orders n <= 5.
LEVANT_LAMBDA = (1.1, 1.5, 2.0, 3.0, 5.0, 8.0)


@njit(cache=True)
def _hosmd(f, tau, L, lam, z_init):
    n = z_init.shape[0] - 1
    N = f.shape[0]
    out = np.empty((N, n + 1))
    z = z_init.copy()
    v = np.empty(n + 1)
    fact = np.empty(n + 2)
    fact[0] = 1.0
    for l in range(1, n + 2):
        fact[l] = fact[l - 1] * l
    taup = np.empty(n + 2)
    for l in range(n + 2):
        taup[l] = tau**l / fact[l]
    for k in range(N):
        for i in range(n + 1):
            out[k, i] = z[i]
        # recursive correction terms v_i (Levant 2003)
        prev = f[k]
        for i in range(n):
            e = z[i] - prev
            p = n - i                       # exponent numerator: (n-i)/(n-i+1)
            g = lam[n - i] * L ** (1.0 / (p + 1))
            a = abs(e)
            s = 1.0 if e > 0 else (-1.0 if e < 0 else 0.0)
            v[i] = -g * a ** (p / (p + 1.0)) * s + z[i + 1]
            prev = v[i]
        e = z[n] - prev
        s = 1.0 if e > 0 else (-1.0 if e < 0 else 0.0)
        v[n] = -lam[0] * L * s
        # Taylor-augmented Euler (Livne & Levant 2014)
        for i in range(n + 1):
            acc = z[i] + tau * v[i]
            for l in range(2, n - i + 1):
                acc += taup[l] * z[i + l]
            z[i] = acc
    return out


def _check_levant(order, L, gains) -> tuple[int, float, np.ndarray]:
    """``(n, L, lambda_0..lambda_n)`` checked: ``order`` 1..5, ``L`` > 0, positive gains."""
    if isinstance(order, bool) or int(order) != order or not 1 <= int(order) <= 5:
        raise ObserverArgumentError(f"order must be 1..5 (Levant's standard gains), got {order}")
    n = int(order)
    L = positive("Levant differentiator", "L (bound on |f^(n+1)|)", L)
    lam = np.asarray(LEVANT_LAMBDA if gains is None else gains, dtype=float)
    if lam.ndim != 1 or len(lam) < n + 1 or np.any(lam[: n + 1] <= 0) \
            or not np.all(np.isfinite(lam[: n + 1])):
        raise ObserverArgumentError(f"gains: need {n + 1} positive gains lambda_0..lambda_{n}, "
                                    f"got {lam}")
    return n, L, lam


@dataclass(frozen=True)
class LevantGains:
    """Design of :class:`LevantDifferentiator`: order ``n``, bound ``L`` and the gains
    ``lambda_0..lambda_n`` (a gain rule: ``certificate`` is ``None``)."""

    certificate: ClassVar[None] = None

    order: int
    L: float
    gains: np.ndarray


class LevantDifferentiator(FixedStepObserver):
    """Levant's robust exact differentiator of order ``n`` (Levant 2003, eq. (7), recursive
    form) with the Taylor-augmented explicit Euler discretisation of Livne & Levant 2014, at
    the sample period ``dt`` [s] (see the module docstring).

    ``order`` = n (1..5), ``L`` the bound on ``|f^{(n+1)}|`` [unit / s^{n+1}], ``gains``
    ``lambda_0..lambda_n`` (default :data:`LEVANT_LAMBDA`). Data: no input (``u=None``);
    ``y`` (N, 1) the samples of ``f``. The estimate ``[f, f', ..., f^{(n)}]`` at sample ``k``
    uses samples ``0..k-1`` (one-step causal). ``x0`` (n+1,) the initial state, default
    ``[f_0, 0, ..., 0]``.
    """

    input_names = ()
    output_names = ("f",)

    def __init__(self, dt: float, order: int = 3, L: float = 1.0, gains=None):
        super().__init__(dt)
        self.order, self.L, self.gains = _check_levant(order, L, gains)
        self.state_names = ("f", "df") + tuple(f"d{i}f" for i in range(2, self.order + 1))
        self.design = LevantGains(self.order, self.L, self.gains)

    def initial_state(self, t, u, y, x0=None) -> np.ndarray:
        if x0 is not None:
            return np.array(x0, dtype=float)
        z = np.zeros(self.order + 1)
        z[0] = y[0, 0]
        return z

    def step(self, z, k, t, u, y) -> np.ndarray:
        """Levant 2003 (7) with ``v_i(k)`` of sample ``k - 1``, integrated by the
        Taylor-augmented Euler scheme of Livne & Levant 2014::

            v_i  = -lam_{n-i} L^{1/(n-i+1)} |z_i - v_{i-1}|^{(n-i)/(n-i+1)} sign(.) + z_{i+1}
                   (v_{-1} = f),   v_n = -lam_0 L sign(z_n - v_{n-1})
            z_i+ = z_i + tau v_i + sum_{l=2}^{n-i} tau^l / l! z_{i+l}
        """
        n, L, lam, tau = self.order, self.L, self.gains, self.dt
        v = np.empty(n + 1)
        prev = y[k - 1, 0]
        for i in range(n):
            p = n - i
            e = z[i] - prev
            v[i] = -lam[p] * L ** (1.0 / (p + 1)) * abs(e) ** (p / (p + 1.0)) * np.sign(e) \
                + z[i + 1]
            prev = v[i]
        v[n] = -lam[0] * L * np.sign(z[n] - prev)
        out = np.empty(n + 1)
        for i in range(n + 1):
            out[i] = z[i] + tau * v[i]
            for m in range(2, n - i + 1):
                out[i] += tau**m / factorial(m) * z[i + m]
        return out

    def estimate(self, z) -> np.ndarray:
        return np.asarray(z, dtype=float)

    def run(self, t, u, y, x0=None) -> Trajectory:
        """The compiled loop (``_hosmd``): the numbers of :meth:`step` looped."""
        t, u, y, x0 = self.check_data(t, u, y, x0)
        z0 = self.initial_state(t, u, y, x0)
        sec, Z = self.timed(_hosmd, np.ascontiguousarray(y[:, 0]), self.dt, self.L,
                            self.gains, z0)
        return self.trajectory(t, Z, seconds=sec)


def levant_differentiator(f, dt: float, order: int = 3, L: float = 1.0, z_init=None,
                          gains=None) -> np.ndarray:
    """Derivatives ``f, f', ..., f^{(order)}`` of a uniformly sampled signal: the array form
    of :class:`LevantDifferentiator` (the same compiled loop, without a time vector).

    Parameters
    ----------
    f : (N,) samples, step ``dt`` [s].
    order : ``n``, the highest derivative estimated (Yacine 2015 uses ``n = 3``).
    L : Lipschitz constant of ``f^{(n)}``, i.e. a bound on ``|f^{(n+1)}|`` [unit / s^{n+1}].
    z_init : (n+1,) initial state; default ``[f[0], 0, ..., 0]``.
    gains : ``lambda_0..lambda_n``; default Levant's :data:`LEVANT_LAMBDA`.

    Returns
    -------
    Z : (N, n+1); ``Z[k, i]`` is the estimate of ``f^{(i)}(t_k)`` using samples up to ``k-1``
    (the state *before* the update with sample ``k``; one-step causal).
    """
    f = np.ascontiguousarray(f, dtype=float)
    if f.ndim != 1 or len(f) < 2:
        raise ObserverArgumentError(f"f must be a 1-D array with >= 2 samples, got shape "
                                    f"{f.shape}")
    if not np.all(np.isfinite(f)):
        k = int(np.argmax(~np.isfinite(f)))
        raise ObserverArgumentError(f"f has a non-finite sample at index {k} ({f[k]})")
    dt = positive("levant_differentiator", "dt", dt)
    n, L, lam = _check_levant(order, L, gains)
    if z_init is None:
        z0 = np.zeros(n + 1)
        z0[0] = f[0]
    else:
        z0 = np.asarray(z_init, dtype=float).copy()
        if z0.shape != (n + 1,) or not np.all(np.isfinite(z0)):
            raise ObserverArgumentError(f"z_init must have shape ({n + 1},), finite, got "
                                        f"{z0.shape}")
    return _hosmd(f, dt, L, lam, z0)


def differentiate(t, f, order: int = 3, L: float = 1.0, **kw) -> np.ndarray:
    """:func:`levant_differentiator` on a time vector; checks that sampling is uniform.

    ``t`` (N,) [s] must be uniformly spaced (relative spread of steps below 1e-6), as the
    discrete scheme assumes. Returns (N, order+1).
    """
    t = np.asarray(t, dtype=float)
    d = np.diff(t)
    if t.ndim != 1 or len(d) == 0 or np.any(d <= 0) or not np.all(np.isfinite(t)):
        raise ObserverArgumentError("t must be finite and strictly increasing with >= 2 samples "
                                    "(a time step dt <= 0)")
    dt = float(np.median(d))
    if np.max(np.abs(d - dt)) > 1e-6 * dt + 1e-12:
        k = int(np.argmax(np.abs(d - dt)))
        raise ObserverArgumentError(f"t must be uniformly sampled: step {k} is {d[k]:.9g} s, "
                                    f"the median step is {dt:.9g} s")
    return levant_differentiator(f, dt, order=order, L=L, **kw)
