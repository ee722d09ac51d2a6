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
"""

from __future__ import annotations

import numpy as np
from numba import njit

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


def levant_differentiator(f, dt: float, order: int = 3, L: float = 1.0, z_init=None,
                          gains=None) -> np.ndarray:
    """Derivatives ``f, f', ..., f^{(order)}`` of a uniformly sampled signal.

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
        raise ValueError(f"f must be a 1-D array with >= 2 samples, got shape {f.shape}")
    if not np.all(np.isfinite(f)):
        k = int(np.argmax(~np.isfinite(f)))
        raise ValueError(f"f has a non-finite sample at index {k} ({f[k]})")
    n = int(order)
    if not 1 <= n <= 5:
        raise ValueError(f"order must be 1..5 (Levant's standard gains), got {order}")
    if not (dt > 0 and np.isfinite(dt)):
        raise ValueError(f"dt must be > 0, got {dt}")
    if not (L > 0 and np.isfinite(L)):
        raise ValueError(f"L (bound on |f^(n+1)|) must be > 0, got {L}")
    lam = np.asarray(LEVANT_LAMBDA if gains is None else gains, dtype=float)
    if len(lam) < n + 1 or np.any(lam[: n + 1] <= 0):
        raise ValueError(f"need {n + 1} positive gains lambda_0..lambda_{n}, got {lam}")
    if z_init is None:
        z0 = np.zeros(n + 1)
        z0[0] = f[0]
    else:
        z0 = np.asarray(z_init, dtype=float).copy()
        if z0.shape != (n + 1,):
            raise ValueError(f"z_init must have shape ({n + 1},), got {z0.shape}")
    return _hosmd(f, float(dt), float(L), lam, z0)


def differentiate(t, f, order: int = 3, L: float = 1.0, **kw) -> np.ndarray:
    """:func:`levant_differentiator` on a time vector; checks that sampling is uniform.

    ``t`` (N,) [s] must be uniformly spaced (relative spread of steps below 1e-6), as the
    discrete scheme assumes. Returns (N, order+1).
    """
    t = np.asarray(t, dtype=float)
    d = np.diff(t)
    if len(d) == 0 or np.any(d <= 0):
        raise ValueError("t must be strictly increasing with >= 2 samples")
    dt = float(np.median(d))
    if np.max(np.abs(d - dt)) > 1e-6 * dt + 1e-12:
        k = int(np.argmax(np.abs(d - dt)))
        raise ValueError(f"t must be uniformly sampled: step {k} is {d[k]:.9g} s, the median "
                         f"step is {dt:.9g} s")
    return levant_differentiator(f, dt, order=order, L=L, **kw)
