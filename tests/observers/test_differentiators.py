"""Levant's arbitrary-order robust exact differentiator: the properties of Levant 2003.

Exponent tolerance: the tests fit log-log slopes of the maximal error (after the transient)
over a decade or more. The candidate exponents differ by 1 (sampling step, ``n-i+1``) and by
0.25 (noise, ``(n-i+1)/4`` for n = 3), so a tolerance of 0.1 still tells every derivative's
exponent from its neighbours (< half of 0.25) while allowing for the fact that one test
signal realises the worst case of the class ``|f^(4)| <= L`` only approximately.
"""

import numpy as np
import pytest
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import Observer, run_readable
from vehicle_observers.observers.differentiators import (
    LEVANT_LAMBDA,
    LevantDifferentiator,
    differentiate,
    levant_differentiator,
)

SLOPE_TOL = 0.1


def _poly(t):
    c = (1.0, 2.0, -0.5, 0.05)
    f = c[0] + c[1] * t + c[2] * t**2 + c[3] * t**3
    return [f, c[1] + 2 * c[2] * t + 3 * c[3] * t**2, 2 * c[2] + 6 * c[3] * t,
            np.full_like(t, 6 * c[3])]


def _band(t, Z, ders, t0, t1):
    m = (t >= t0) & (t < t1)
    return np.array([np.abs(Z[m, i] - ders[i][m]).max() for i in range(4)])


def test_standard_gains_are_levants():
    assert LEVANT_LAMBDA == (1.1, 1.5, 2.0, 3.0, 5.0, 8.0)


def test_finite_time_exact_on_cubic():
    """n = 3 on a cubic (f^(4) = 0 <= L): the error falls from O(1) to the sampling band
    nu_i L tau^(n-i+1) at a finite time T and then stays *flat* (no further decay, which an
    asymptotic observer would show); T does not depend on tau, the band scales with it."""
    out = {}
    for tau in (2e-3, 1e-3):
        t = np.arange(0.0, 12.0, tau)
        ders = _poly(t)
        Z = levant_differentiator(ders[0], tau, order=3, L=1.0)
        e1 = np.abs(Z[:, 1] - ders[1])
        early = _band(t, Z, ders, 0.0, 1.0)
        late1 = _band(t, Z, ders, 7.0, 8.0)
        late2 = _band(t, Z, ders, 11.0, 12.0)
        assert early[1] > 0.1                       # started far away (z_1(0) = 0, f'(0) = 2)
        # flat after convergence: the two late windows agree within a factor 1.5
        assert np.all(late2 < 1.5 * late1) and np.all(late1 < 1.5 * late2)
        # T: last time e_1 exceeds 10 x its final band
        T = t[np.flatnonzero(e1 > 10 * late2[1])[-1] + 1]
        out[tau] = (T, late2)
        # band ~ tau^(4-i): nu_i measured 3..12 for tau = 1e-3; assert an order-of-magnitude
        nu = late2 / (1.0 * tau ** (4 - np.arange(4)))
        assert np.all(nu < 50), nu
    (T1, b1), (T2, b2) = out[2e-3], out[1e-3]
    assert T1 < 8.0 and abs(T1 - T2) < 0.5        # finite time, independent of tau
    ratio = np.log2(b1 / b2)                        # halving tau divides band by 2^(4-i)
    np.testing.assert_allclose(ratio, 4 - np.arange(4), atol=0.35)


def test_started_exact_on_cubic_has_no_transient():
    """Started on the exact derivatives of a cubic, the error never leaves the sampling band
    (the Taylor-augmented update adds no truncation error; only the sign term chatters, by
    lam_0 L tau on z_3, because round-off makes the sign argument nonzero)."""
    tau = 1e-3
    t = np.arange(0.0, 5.0, tau)
    ders = _poly(t)
    z0 = np.array([d[0] for d in ders])
    Z = levant_differentiator(ders[0], tau, order=3, L=1.0, z_init=z0)
    err = np.array([np.abs(Z[:, i] - ders[i]).max() for i in range(4)])
    nu = err / tau ** (4 - np.arange(4))
    assert np.all(nu < 50), nu


def test_accuracy_scales_with_sampling_step():
    """|z_i - f^(i)| ~ tau^(n-i+1) (Levant 2003, Thm 6) for f = sin t, L = 1 >= |f^(4)|."""
    taus = np.array([0.002, 0.004, 0.008, 0.016, 0.032])
    errs = []
    for tau in taus:
        t = np.arange(0.0, 60.0, tau)
        Z = levant_differentiator(np.sin(t), tau, order=3, L=1.0)
        ders = [np.sin(t), np.cos(t), -np.sin(t), -np.cos(t)]
        errs.append(_band(t, Z, ders, 20.0, 60.0))
    errs = np.array(errs)
    for i in range(4):
        slope = np.polyfit(np.log(taus), np.log(errs[:, i]), 1)[0]
        assert slope == pytest.approx(4 - i, abs=SLOPE_TOL), (i, slope)


def test_accuracy_scales_with_noise_amplitude():
    """|z_i - f^(i)| ~ eps^((n-i+1)/(n+1)) with bounded noise |eta| <= eps (Levant 2003,
    Thm 5). tau = 1e-4 keeps the sampling term (L tau^(n-i+1)) well below the noise term."""
    rng = np.random.default_rng(0)
    eps = np.array([1e-9, 1e-8, 1e-7, 1e-6, 1e-5])
    tau = 1e-4
    t = np.arange(0.0, 30.0, tau)
    ders = [np.sin(t), np.cos(t), -np.sin(t), -np.cos(t)]
    errs = []
    for e in eps:
        Z = levant_differentiator(np.sin(t) + e * rng.uniform(-1, 1, len(t)), tau, 3, L=1.0)
        errs.append(_band(t, Z, ders, 10.0, 30.0))
    errs = np.array(errs)
    for i in range(4):
        slope = np.polyfit(np.log(eps), np.log(errs[:, i]), 1)[0]
        assert slope == pytest.approx((4 - i) / 4, abs=SLOPE_TOL), (i, slope)


def test_lower_order_and_time_vector_api():
    tau = 1e-3
    t = np.arange(0.0, 10.0, tau)
    Z = differentiate(t, t**2, order=2, L=1.0)      # quadratic: exact for n = 2
    assert Z.shape == (len(t), 3)
    m = t > 5
    assert np.abs(Z[m, 1] - 2 * t[m]).max() < 1e-5
    assert np.abs(Z[m, 2] - 2).max() < 5e-3         # band ~ lam_0 L tau


def test_bad_inputs():
    with pytest.raises(ValueError, match="uniformly sampled: step 2"):
        differentiate(np.array([0, 1, 2, 3.5, 4.5]), np.zeros(5))
    with pytest.raises(ValueError, match="non-finite sample at index 1"):
        levant_differentiator(np.array([0.0, np.nan, 1.0]), 0.1)
    with pytest.raises(ValueError, match="order must be 1..5"):
        levant_differentiator(np.zeros(5), 0.1, order=6)
    with pytest.raises(ValueError, match="L"):
        levant_differentiator(np.zeros(5), 0.1, L=0.0)
    with pytest.raises(ValueError, match="z_init must have shape"):
        levant_differentiator(np.zeros(5), 0.1, order=3, z_init=np.zeros(3))
    with pytest.raises(ObserverArgumentError, match="dt"):
        levant_differentiator(np.zeros(5), 0.0)
    with pytest.raises(ObserverArgumentError, match="gains"):
        levant_differentiator(np.zeros(5), 0.1, order=2, gains=(1.1, -1.5, 2.0))
    with pytest.raises(ObserverArgumentError, match="dt"):
        LevantDifferentiator(-1e-3)
    with pytest.raises(ObserverArgumentError, match="L"):
        LevantDifferentiator(1e-3, L=-2.0)
    with pytest.raises(ObserverArgumentError, match="t must be"):
        differentiate(np.array([0.0, 0.0, 1.0]), np.zeros(3))


@pytest.mark.parametrize("order", [1, 3, 5])
def test_run_readable_equals_compiled_run(order):
    """The observer contract: the numpy step (Levant 2003 (7), Taylor-augmented Euler of
    Livne & Levant 2014) looped equals the compiled run. Same operations in the same order
    except the Taylor terms' tau^l / l! (numba: running product of factorials, here
    math.factorial): rounding only. After convergence the sign term chatters, so an error
    of a few ulps in z_n could flip one sign; on this noisy signal the sign arguments are
    never at rounding level and 1e-9 relative over 3000 steps holds (a flip would cost
    lam_0 L tau^l ~ 1e-3 on z_n)."""
    tau = 1e-3
    t = np.arange(0.0, 3.0, tau)
    f = np.sin(t) + 1e-4 * np.random.default_rng(0).uniform(-1, 1, len(t))
    obs = LevantDifferentiator(tau, order=order, L=2.0)
    assert isinstance(obs, Observer) and obs.design.certificate is None
    tr, rd = obs.run(t, None, f), run_readable(obs, t, None, f)
    np.testing.assert_allclose(rd.x, tr.x, rtol=1e-9, atol=1e-9)
    # the array form is the same compiled loop
    np.testing.assert_array_equal(levant_differentiator(f, tau, order, 2.0), tr.x)
    assert tr.names == ("f", "df") + tuple(f"d{i}f" for i in range(2, order + 1))


def test_run_is_causal():
    """One-step causal: the estimate at k reads samples up to k - 1 only, so changing the
    samples from k on leaves rows 0..k unchanged."""
    tau = 1e-3
    t = np.arange(0.0, 1.0, tau)
    obs = LevantDifferentiator(tau)
    f = np.cos(t)
    k = 500
    f2 = f.copy()
    f2[k:] += 1.0
    a, b = obs.run(t, None, f), obs.run(t, None, f2)
    np.testing.assert_array_equal(a.x[:k + 1], b.x[:k + 1])
    assert not np.array_equal(a.x[k + 1], b.x[k + 1])
