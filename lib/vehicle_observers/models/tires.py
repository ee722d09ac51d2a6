"""Tyre models: Pacejka magic formula, its secant stiffness, linear tyre, relaxation.

References
----------
Yacine et al. 2015 (IEEE TCST 23(2)), eqs. (2), (6), (7), (15)-(16).
Pacejka, *Tire and Vehicle Dynamics*, 2005 (the standard magic formula).

Reconstruction note: the extracted eq. (2) reads ``D sin(C atan(B(1-E) a + atan(B a)))``;
the factor ``E`` in front of the inner ``atan`` was lost. Eq. (16) of the same paper
(``S2 = B(1-E) a + E atan(S1)``) and Pacejka's book both give the standard form used here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vehicle_observers.core.errors import ObserverArgumentError


# ------------------------------------------------------------------ the one tyre formula --
@njit(cache=True)
def magic_formula(alpha, B, C, D, E):
    """Pacejka magic formula ``D sin(C atan(B(1-E) alpha + E atan(B alpha)))`` [N] at slip
    ``alpha`` [rad] (Yacine 2015 eq. (7); Pacejka 2005 eq. (4.49)); ``C == 0`` encodes a
    linear tyre of slope ``B`` [N/rad]. Scalar in, scalar out; compiled, so every kernel of
    the library calls this one definition (:meth:`Pacejka.force` is its numpy twin)."""
    if C == 0.0:  # linear tyre, slope B
        return B * alpha
    Ba = B * alpha
    if E == 0.0:  # the same number without the curvature term's arctan
        return D * np.sin(C * np.arctan(Ba))
    return D * np.sin(C * np.arctan(B * (1.0 - E) * alpha + E * np.arctan(Ba)))


@njit(cache=True)
def magic_formula_slope(alpha, B, C, D, E):
    """``(F, dF/dalpha)`` [N], [N/rad] of :func:`magic_formula` (for Jacobians)."""
    if C == 0.0:
        return B * alpha, B
    Ba = B * alpha
    if E == 0.0:
        phi = Ba
        dphi = B
    else:
        phi = B * (1.0 - E) * alpha + E * np.arctan(Ba)
        dphi = B * (1.0 - E) + E * B / (1.0 + Ba * Ba)
    ang = C * np.arctan(phi)
    return D * np.sin(ang), D * np.cos(ang) * C / (1.0 + phi * phi) * dphi


@njit(cache=True)
def _atanc_scalar(x):
    """atan(x)/x, 1 at 0 (series below 1e-4): compiled twin of :func:`_atanc`."""
    if abs(x) < 1e-4:
        return 1.0 - x * x / 3.0 + x**4 / 5.0
    return np.arctan(x) / x


@njit(cache=True)
def _sinc_scalar(x):
    """sin(x)/x, 1 at 0 (series below 1e-4): compiled twin of :func:`_sinc`."""
    if abs(x) < 1e-4:
        return 1.0 - x * x / 6.0 + x**4 / 120.0
    return np.sin(x) / x


@njit(cache=True)
def magic_formula_secant(alpha, B, C, D, E):
    """Secant stiffness ``F(alpha)/alpha`` [N/rad] of :func:`magic_formula`, finite at
    ``alpha = 0`` (where it is ``B C D``): Yacine 2015 eq. (16) in its product form with the
    series of ``atan(x)/x`` and ``sin(x)/x``, the TS premise of (14)-(17). ``C == 0``: the
    linear tyre's slope ``B``. Compiled twin of :meth:`Pacejka.secant_stiffness`."""
    if C == 0.0:
        return B
    S1 = B * alpha
    S2 = B * (1.0 - E) * alpha + E * np.arctan(S1)
    S3 = C * np.arctan(S2)
    common = _sinc_scalar(S3) * _atanc_scalar(S2)
    return B * C * D * (1.0 - E) * common + B * C * D * E * common * _atanc_scalar(S1)


def _sinc(x):
    """sin(x)/x, 1 at 0 (numpy's sinc is sin(pi x)/(pi x))."""
    return np.sinc(np.asarray(x, dtype=float) / np.pi)


def _atanc(x):
    """atan(x)/x, with its series near 0 so the result is exact to round-off."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < 1e-4
    xs = np.where(small, 1.0, x)
    return np.where(small, 1.0 - x * x / 3.0 + x**4 / 5.0, np.arctan(xs) / xs)


def _finite_nonnegative(v) -> bool:
    try:
        return math.isfinite(v) and v >= 0
    except TypeError:
        return False


@dataclass(frozen=True)
class Pacejka:
    """Magic-formula lateral tyre ``F = D sin(C atan(B(1-E) a + E atan(B a)))``.

    Parameters are per axle (both tyres of the axle lumped), as in Yacine 2015 eq. (7).
    ``B`` [1/rad], ``C`` [-], ``D`` [N] peak force, ``E`` [-] curvature.
    """

    B: float
    C: float
    D: float
    E: float = 0.0

    def __post_init__(self):
        # a negative B, C or D makes a negative cornering stiffness B C D and a sector of
        # negative secant stiffnesses: every TS / LPV bound built on it is meaningless
        for k in ("B", "C", "D"):
            v = getattr(self, k)
            if not _finite_nonnegative(v):
                raise ObserverArgumentError(f"Pacejka.{k} must be a finite number >= 0, got {v!r}")
        if not (np.ndim(self.E) == 0 and np.isfinite(self.E)):
            raise ObserverArgumentError(f"Pacejka.E must be finite, got {self.E!r}")

    @property
    def cornering_stiffness(self) -> float:
        """Slope at zero slip, ``B C D`` [N/rad]."""
        return self.B * self.C * self.D

    def force(self, alpha):
        """Steady-state lateral force [N] at slip angle ``alpha`` [rad] (any shape): the numpy
        twin of the compiled :func:`magic_formula` (a test checks them equal)."""
        a = np.asarray(alpha, dtype=float)
        B, C, D, E = self.B, self.C, self.D, self.E
        return D * np.sin(C * np.arctan(B * (1.0 - E) * a + E * np.arctan(B * a)))

    def secant_stiffness(self, alpha):
        """``f(alpha) = F(alpha)/alpha`` [N/rad], Yacine 2015 eq. (16), exact at 0.

        Evaluated in the paper's product form so it is smooth through ``alpha = 0``
        (where it equals ``B C D``); numpy twin of :func:`magic_formula_secant`.
        """
        a = np.asarray(alpha, dtype=float)
        B, C, D, E = self.B, self.C, self.D, self.E
        S1 = B * a
        S2 = B * (1.0 - E) * a + E * np.arctan(S1)
        S3 = C * np.arctan(S2)
        common = _sinc(S3) * _atanc(S2)
        return B * C * D * (1.0 - E) * common + B * C * D * E * common * _atanc(S1)

    def sector_bounds(self, alpha_max: float, n: int = 20001) -> tuple[float, float]:
        """(f_min, f_max) of the secant stiffness over ``|alpha| <= alpha_max`` (dense grid)."""
        a = np.linspace(-alpha_max, alpha_max, n)
        f = self.secant_stiffness(a)
        return float(f.min()), float(f.max())

    @classmethod
    def from_sector(cls, M_max: float, M_min: float, alpha_max: float, C: float = 1.3,
                    E: float = 0.0) -> "Pacejka":
        """Coefficients whose secant stiffness spans exactly ``[M_min, M_max]`` on ``|a|<=a_max``.

        ``B C D = M_max`` (slope at zero slip) and ``F(a_max)/a_max = M_min``; ``C`` and
        ``E`` are fixed by the caller, ``B`` is found by a bracketing root search and ``D``
        follows. This is how the Yacine 2015 coefficients (not printed) are chosen.
        """
        if not 0 < M_min < M_max:
            raise ValueError(f"need 0 < M_min < M_max, got M_min={M_min}, M_max={M_max}")
        ratio = M_min / M_max

        def gap(B):
            t = cls(B=B, C=C, D=M_max / (B * C), E=E)
            return t.secant_stiffness(alpha_max) / M_max - ratio

        from scipy.optimize import brentq

        B = brentq(gap, 1e-3, 10.0 / alpha_max, xtol=1e-14, rtol=1e-14)
        return cls(B=B, C=C, D=M_max / (B * C), E=E)


@dataclass(frozen=True)
class LinearTire:
    """Linear tyre ``F = C_alpha * alpha`` [N], ``C_alpha`` in N/rad."""

    C_alpha: float

    def __post_init__(self):
        v = self.C_alpha
        if not _finite_nonnegative(v):
            raise ObserverArgumentError(f"LinearTire.C_alpha must be a finite number >= 0 N/rad, "
                                        f"got {v!r}")

    @property
    def cornering_stiffness(self) -> float:
        return self.C_alpha

    def force(self, alpha):
        return self.C_alpha * np.asarray(alpha, dtype=float)

    def secant_stiffness(self, alpha):
        return np.full_like(np.asarray(alpha, dtype=float), self.C_alpha)


def relaxation_rhs(F, F_steady, vx, relaxation_length):
    """First-order tyre relaxation, Yacine 2015 eqs. (6)/(8): ``dF/dt = vx/r (F_S - F)``.

    ``tau = r / vx`` [s] with relaxation length ``r`` [m] and speed ``vx`` [m/s].
    """
    return np.asarray(vx) / relaxation_length * (np.asarray(F_steady) - np.asarray(F))
