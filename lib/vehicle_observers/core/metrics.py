"""Error metrics shared by every notebook and the benchmark. Arrays (N,) unless stated."""

from __future__ import annotations

import numpy as np


def _errors(est, ref, mask, what):
    e = np.asarray(est, dtype=float) - np.asarray(ref, dtype=float)
    if mask is not None:
        e = e[mask]
    if e.size == 0:
        raise ValueError(f"{what}: the selection is empty (mask selects no sample of "
                         f"{np.size(est)}); widen the window or check the mask")
    return e


def rmse(est, ref, mask=None) -> float:
    """Root-mean-square of ``est - ref`` over ``mask`` (ValueError if it selects nothing)."""
    e = _errors(est, ref, mask, "rmse")
    return float(np.sqrt(np.mean(e**2)))


def max_abs(est, ref, mask=None) -> float:
    """Largest ``|est - ref|`` over ``mask`` (ValueError if it selects nothing)."""
    return float(np.abs(_errors(est, ref, mask, "max_abs")).max())


def nrmse(est, ref, mask=None) -> float:
    """RMSE divided by the RMS of the reference."""
    ref = np.asarray(ref, dtype=float)
    r = ref if mask is None else ref[mask]
    return rmse(est, ref, mask) / float(np.sqrt(np.mean(r**2)))


def fit_percent(est, ref, mask=None) -> float:
    """NRMSE fit ``100 (1 - |e| / |ref - mean(ref)|)`` (MATLAB ``compare`` convention)."""
    est, ref = np.asarray(est, dtype=float), np.asarray(ref, dtype=float)
    if mask is not None:
        est, ref = est[mask], ref[mask]
    return float(100 * (1 - np.linalg.norm(est - ref) / np.linalg.norm(ref - ref.mean())))


def correlation(est, ref, mask=None) -> float:
    est, ref = np.asarray(est, dtype=float), np.asarray(ref, dtype=float)
    if mask is not None:
        est, ref = est[mask], ref[mask]
    return float(np.corrcoef(est, ref)[0, 1])


def settling_time(t, err, band: float = 0.02, reference: float | None = None) -> float:
    """First time after which ``|err|`` stays within ``band * reference`` (default: 2 % of
    ``max |err|``). Returns ``nan`` if it never settles, ``t[0]`` if always inside."""
    t, e = np.asarray(t, dtype=float), np.abs(np.asarray(err, dtype=float))
    ref = float(e.max()) if reference is None else reference
    outside = np.flatnonzero(e > band * ref)
    if len(outside) == 0:
        return float(t[0])
    if outside[-1] == len(e) - 1:
        return float("nan")
    return float(t[outside[-1] + 1])


def overshoot(err) -> float:
    """Largest excursion of the error on the opposite side of its initial sign, relative to
    ``|err(0)|`` (0 for a monotone decay)."""
    e = np.asarray(err, dtype=float)
    if e[0] == 0:
        return 0.0
    opp = -np.sign(e[0]) * e
    return float(max(opp.max(), 0.0) / abs(e[0]))


def enclosure_rate(lower, x, upper, tol: float = 0.0) -> float:
    """Share of samples with ``lower - tol <= x <= upper + tol``."""
    lower, x, upper = (np.asarray(a, dtype=float) for a in (lower, x, upper))
    return float(np.mean((lower - tol <= x) & (x <= upper + tol)))


def coverage_2sigma(est, std, ref, mask=None) -> float:
    """Share of the samples with ``|est - ref| <= 2 std``: the 2-sigma coverage of a reported
    standard deviation ``std`` (same unit as ``est``), 0.954 for a consistent Gaussian one
    (ValueError if ``mask`` selects nothing)."""
    e = _errors(est, ref, mask, "coverage_2sigma")
    s = np.asarray(std, dtype=float)
    s = s[mask] if mask is not None else s
    return float(np.mean(np.abs(e) <= 2.0 * s))


def mean_nees(est, std, ref, mask=None, floor: float = 1e-12) -> float:
    """Mean normalised estimation error squared of one state, ``mean(((est - ref) / std)^2)``
    (Bar-Shalom, Li & Kirubarajan 2001, sec. 5.4.2): 1 for a consistent ``std``, above 1 when
    it is too small. ``std`` is floored at ``floor`` (same unit as ``est``)."""
    e = _errors(est, ref, mask, "mean_nees")
    s = np.asarray(std, dtype=float)
    s = s[mask] if mask is not None else s
    return float(np.mean((e / np.maximum(s, floor)) ** 2))
