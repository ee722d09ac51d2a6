"""The constraints and objectives of an observer LMI design, as data.

Each class below names one requirement on the estimation error ``e = x - xhat`` of the
observer ``xhat' = A xhat + B u + L (y - C xhat)`` of a polytopic system
(:class:`~vehicle_observers.design.system.PolytopicSystem`). At a vertex pair ``(i, j)``
(plant vertex ``i``, gain ``L_j``) the error obeys ``e' = (A_i - L_j C_i) e + (E_i - L_j D_i) w``,
``z = H e``. With the Lyapunov matrix ``P`` and the change of variables ``K_j = P L_j`` every
requirement is an LMI in ``(P, K_j, gamma, c)``; ``He(X) = X + X^T``:

==================  ==============================================================================
:class:`Decay`      continuous: ``He(P A_i - K_j C_i) + 2 alpha P < 0`` (poles ``Re < -alpha``);
                    discrete: the disk ``|z| < exp(-alpha dt)`` of :class:`InRegion`
:class:`InRegion`   Chilali & Gahinet (1996) Thm 2.2: ``L (x) P + M (x) (P A_i - K_j C_i) +
                    M^T (x) (P A_i - K_j C_i)^T < 0``
:class:`BoundedReal` bounded-real lemma, ``||T_{w->z}||_inf < gamma`` (continuous)
                    ``[[He(P A_i - K_j C_i), P E_i - K_j D_i, H^T], [*, -gamma I, 0],
                    [H, 0, -gamma I]] < 0``; discrete ``[[-P, P A - K C, P E - K D, 0],
                    [*, -P, 0, H^T], [*, 0, -gamma I, 0], [0, H, 0, -gamma I]] < 0``
:class:`InputToState` ``[[A_i^T P + P A_i - K_j C_i - C_i^T K_j^T + alpha P, P E_i],
                    [E_i^T P, -c I]] < 0``: ``V' <= -alpha V + c |w|^2`` (Yacine 2015 (33))
:class:`Metzler`    ``P`` diagonal and every off-diagonal entry of ``P A_i - K_j C_i`` >= 0 (the
                    error system is cooperative: interval observers, Raissi et al. 2012);
                    optionally ``diag(P A_i - K_j C_i + shift P) >= 0``
:class:`Nonnegative` discrete time: ``P`` diagonal and every entry of ``P A_i - K_j C_i`` >= 0
                    (positive error system of a discrete-time interval observer)
==================  ==============================================================================

A value ``None`` for ``gamma`` / ``c`` makes it a decision variable (minimised by
:meth:`~vehicle_observers.design.synthesis.ObserverSynthesis.minimise`). ``label`` names the
LMI in certificates (``label[i]`` or ``label[i,j]``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.design.lmi import Region


def _num(who, name, v, lo=None, strict=False, allow_none=False):
    if v is None and allow_none:
        return None
    try:
        v = float(v)
    except (TypeError, ValueError):
        raise ObserverArgumentError(f"{who}: {name} must be a number, got {v!r}") from None
    if not np.isfinite(v) or (lo is not None and (v <= lo if strict else v < lo)):
        raise ObserverArgumentError(f"{who}: {name} must be finite and "
                                    f"{'>' if strict else '>='} {lo}, got {v!r}")
    return v


@dataclass(frozen=True)
class Decay:
    """Decay rate ``alpha`` [1/s] >= 0 of every frozen error system (module table)."""

    alpha: float = 0.0
    label: str = "decay"

    def __post_init__(self):
        object.__setattr__(self, "alpha", _num("Decay", "alpha", self.alpha, lo=0.0))


@dataclass(frozen=True)
class InRegion:
    """Poles of every frozen error system inside the LMI region ``region``."""

    region: Region
    label: str | None = None

    def __post_init__(self):
        if not isinstance(self.region, Region):
            raise ObserverArgumentError(f"InRegion: region must be a lmi.Region, got "
                                        f"{type(self.region).__name__}")
        if self.label is None:
            object.__setattr__(self, "label", f"region {self.region.name}")


@dataclass(frozen=True)
class BoundedReal:
    """``||T_{w -> H e}||_inf < gamma``; ``gamma=None``: a variable (minimised)."""

    gamma: float | None = None
    label: str = "hinf"

    def __post_init__(self):
        object.__setattr__(self, "gamma", _num("BoundedReal", "gamma", self.gamma, lo=0.0,
                                               strict=True, allow_none=True))


@dataclass(frozen=True)
class InputToState:
    """``V' <= -alpha V + c |w|^2`` (Yacine 2015 (33)); ``c=None``: a variable."""

    alpha: float = 0.0
    c: float | None = None
    label: str = "iss"

    def __post_init__(self):
        object.__setattr__(self, "alpha", _num("InputToState", "alpha", self.alpha, lo=0.0))
        object.__setattr__(self, "c", _num("InputToState", "c", self.c, lo=0.0, strict=True,
                                           allow_none=True))


@dataclass(frozen=True)
class Metzler:
    """Cooperative error system: off-diagonal of ``A_i - L_j C_i`` >= 0 (``P`` diagonal).

    ``margin``: the solver must reach off-diagonal entries of ``P A_i - K_j C_i`` >= margin
    (so its round-off cannot fail the certificate, which checks >= 0); ``diag_shift`` s:
    also ``diag(P A_i - K_j C_i + s P) >= 0`` (diagonal of ``A - L C`` >= -s, the explicit
    Euler step bound ``h s <= 1`` of a sampled interval observer). On a discrete-time
    system this is still the continuous-time cooperativity (the diagonal is free): the
    positivity of ``e_{k+1} = (A - L C) e_k`` is :class:`Nonnegative`."""

    margin: float = 0.0
    diag_shift: float | None = None
    label: str = "metzler"

    def __post_init__(self):
        object.__setattr__(self, "margin", _num("Metzler", "margin", self.margin, lo=0.0))
        object.__setattr__(self, "diag_shift", _num("Metzler", "diag_shift", self.diag_shift,
                                                    lo=0.0, strict=True, allow_none=True))


@dataclass(frozen=True)
class Nonnegative:
    """Positive discrete-time error system: every entry of ``A_i - L_j C_i`` >= 0 (``P``
    diagonal), the discrete-time counterpart of :class:`Metzler`.

    ``e_{k+1} = (A_i - L_j C_i) e_k`` keeps ``e_k >= 0`` for every ``e_0 >= 0`` iff the matrix
    is entry-wise nonnegative (Farina & Rinaldi, *Positive Linear Systems*, Wiley 2000, Thm 2);
    with it the errors of an interval observer ``x+ - x`` and ``x - x-`` stay nonnegative
    (Mazenc & Bernard, Int. J. Robust Nonlinear Control 24, 2014; Efimov, Perruquetti, Raissi
    & Zolghadri, ECC 2013, Corollary 1 with (7)-(8); Wang et al. 2018). The off-diagonal test of
    :class:`Metzler` is the continuous-time cooperativity: on a discrete-time system it lets a
    negative diagonal entry through. Posed as ``P A_i - K_j C_i >= margin`` entry-wise
    (``P`` diagonal positive, ``K_j = P L_j``: the sign pattern of ``A_i - L_j C_i``); stability
    comes from a :class:`Decay` / :class:`InRegion` constraint beside it (for a nonnegative
    matrix a diagonal ``P`` exists iff its spectral radius is < 1, Farina & Rinaldi Thm 15).
    The certificate checks the entries of ``A_i - L_j C_i`` from ``L`` (>= 0; a shortfall at
    round-off level, :data:`~vehicle_observers.design.lmi.NONNEG_ROUNDOFF`, is
    "inconclusive"). Discrete-time systems only."""

    margin: float = 0.0
    label: str = "nonneg"

    def __post_init__(self):
        object.__setattr__(self, "margin", _num("Nonnegative", "margin", self.margin, lo=0.0))


CONSTRAINTS = (Decay, InRegion, BoundedReal, InputToState, Metzler, Nonnegative)


@dataclass(frozen=True)
class OnVertices:
    """``constraint`` imposed on another vertex list than the design's own system.

    ``systems``: one :class:`~vehicle_observers.design.system.PolytopicSystem` (or one per
    mode of a multi-mode design) with as many vertices as the design's system: vertex ``k``
    of ``systems`` is constrained with the Lyapunov matrix and the gain of the design's vertex
    ``k``. Example: an interval observer whose error system must be cooperative on the
    element-wise lower bounds ``A^-_k`` while its decay / input-to-state condition is stated on
    the upper bounds ``A^+_k`` (Ifqir et al. 2017, Theorem 2 (19)-(20)). Used by
    :class:`~vehicle_observers.design.lyapunov.ParameterDependentSynthesis`; the label is the
    inner constraint's."""

    constraint: object
    systems: object

    def __post_init__(self):
        from vehicle_observers.design.system import PolytopicSystem

        if not isinstance(self.constraint, (Decay, InputToState, Metzler)):
            raise ObserverArgumentError("OnVertices: constraint must be a Decay, InputToState "
                                        f"or Metzler, got {type(self.constraint).__name__}")
        ss = self.systems if isinstance(self.systems, (list, tuple)) else (self.systems,)
        if not ss or not all(isinstance(x, PolytopicSystem) for x in ss):
            raise ObserverArgumentError("OnVertices: systems must be a PolytopicSystem or a "
                                        "list of them (one per mode)")
        object.__setattr__(self, "systems", tuple(ss))

    @property
    def label(self) -> str:
        return self.constraint.label


@dataclass(frozen=True)
class L2Gain:
    """L2 gain ``gamma`` from ``w`` to ``z = H e + Dz_i w`` with decay rate ``alpha`` [1/s],
    in the squared (Schur) form of the bounded-real lemma (Boyd, El Ghaoui, Feron &
    Balakrishnan, *Linear Matrix Inequalities in System and Control Theory*, SIAM 1994,
    Sec. 6.3.2), as in the unknown-input observer designs of Darouach et al. and El Youssfi et
    al. (2020) eq. (25) / Theorem 2. With ``g = gamma^2`` and ``V = e^T P e``:
    ``V' + 2 alpha V + |z|^2 - g |w|^2 < 0``, i.e. (quadratic ``P``, gain ``K_j``)::

        [[He(P A_i - W_j C_i) + 2 alpha P,  P E_i - W_j D_i,  H^T   ],
         [*,                                -g I_nw,          Dz_i^T],
         [H,                                Dz_i,             -I_nz ]] < 0,   W_j = P K_j

    (the slack form is in :mod:`vehicle_observers.design.slack`). It implies the decay rate
    ``alpha`` of ``e`` for ``w = 0`` and ``||z||_2 < gamma ||w||_2`` from ``e(0) = 0``.
    ``gamma=None``: ``g`` is a variable (minimised). Discrete time: ``V_{k+1} - r^2 V_k +
    |z_k|^2 - g |w_k|^2 < 0``, ``r = exp(-alpha dt)`` (:mod:`vehicle_observers.design.slack`).
    Used by
    :class:`~vehicle_observers.design.slack.SlackSynthesis`, not by ``ObserverSynthesis``."""

    alpha: float = 0.0
    gamma: float | None = None
    label: str = "l2"

    def __post_init__(self):
        object.__setattr__(self, "alpha", _num("L2Gain", "alpha", self.alpha, lo=0.0))
        object.__setattr__(self, "gamma", _num("L2Gain", "gamma", self.gamma, lo=0.0,
                                               strict=True, allow_none=True))


@dataclass(frozen=True)
class SpectralDisk:
    """Poles of every frozen error system ``A_i - K_i C_i`` in the disk ``|lambda| < radius``
    [1/s] (e.g. so that an explicit integration step ``dt`` sees ``|lambda| dt`` bounded), by
    the Stein inequality of ``(A_i - K_i C_i) / radius``: quadratic ``P``::

        [[P, (P A_i - W_i C_i)^T / radius], [(P A_i - W_i C_i) / radius, P]] > 0

    slack form (de Oliveira, Bernussou & Geromel, Systems & Control Letters 37, 1999, Thm 1)::

        [[P_i, (G A_i - W_i C_i)^T / radius], [(G A_i - W_i C_i) / radius, G + G^T - P_i]] > 0

    Used by :class:`~vehicle_observers.design.slack.SlackSynthesis`."""

    radius: float
    label: str = "disk"

    def __post_init__(self):
        object.__setattr__(self, "radius", _num("SpectralDisk", "radius", self.radius, lo=0.0,
                                                strict=True))


#: the constraints of :class:`~vehicle_observers.design.slack.SlackSynthesis`
SLACK_CONSTRAINTS = (L2Gain, SpectralDisk)
