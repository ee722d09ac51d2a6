"""Exercise checkers of notebook 03 (Ifqir 2017, switched TS interval observer).

Each ``check_k(f)`` calls the student's function ``f`` on several inputs (so a hard-coded
number fails), computes the expected answer independently of the notebook's solution cell
(the library, or a closed form written here) and shows one line through
:func:`vehicle_observers.results.teaching.check` (``correct`` / ``not yet`` with a hint /
``not attempted`` while the stub still returns ``None``). ``show=False`` returns the
:class:`~vehicle_observers.results.teaching.Outcome` instead (used by the tests).

1. :func:`check_1`: the largest relative stiffness uncertainty ``a`` keeping entry (2,1) of
   ``A^- - L C`` nonnegative (the Metzler limit of Theorem 1), as a function of the vehicle.
2. :func:`check_2`: the smallest shift ``epsilon`` of (20) that given gains ``L`` satisfy,
   per mode [1/s].
3. :func:`check_3`: a gain ``L`` for one vertex putting ``A^- - L C`` on the Metzler bound
   ``(A^- - L C)_12 = 0`` with the yaw-rate diagonal at ``-lam``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from vehicle_observers.models import uncertain_bicycle as ub
from vehicle_observers.results import teaching

from vehicle_observers_papers.ifqir_2017 import constants as IF
from vehicle_observers_papers.ifqir_2017 import printed_solution as ps


def _vehicles() -> list[ub.UncertainBicycle]:
    """The Satory car, the Revs car, and two variants (a stiffer rear axle; an oversteering
    car, whose answer is 0: no box keeps (2,1) >= 0)."""
    v = IF.vehicle
    return [v, IF.revs_vehicle(), dataclasses.replace(v, c_r0=1.5 * v.c_r0),
            dataclasses.replace(v, c_r0=0.6 * v.c_r0)]


def _calls(f, cases):
    """``f`` called on every case, or ``None`` when ``f`` is still a stub (returns ``None``)."""
    def run():
        out = [f(*c) for c in cases]
        return None if any(o is None or o is Ellipsis for o in out) else out
    return run


def check_1(metzler_limit, show: bool = True):
    """Exercise 03.1: ``metzler_limit(veh) -> a`` [-], the largest relative uncertainty
    ``rel_unc`` of the stiffness box ``c in [(1 - a) c_0, (1 + a) c_0]`` for which
    ``c_r l_r - c_f l_f >= 0`` on the whole box (0 if none). Expected: the library's
    :meth:`UncertainBicycle.max_metzler_uncertainty`, on four vehicles."""
    vehs = _vehicles()
    want = [v.max_metzler_uncertainty() for v in vehs]
    return teaching.check("03.1", _calls(metzler_limit, [(v,) for v in vehs]), want,
                          hint="the worst corner has the smallest rear and the largest front "
                               "stiffness: solve (1 - a) c_r0 l_r = (1 + a) c_f0 l_f for a, and "
                               "return 0 for a car with c_r0 l_r <= c_f0 l_f",
                          rtol=1e-6, show=show)


def _gain_cases():
    """(model, L) pairs: the printed gains under both vertex polarities, and seeded random
    gains (L1 < 0, L2 > 0 up to 6000 1/s) on the chosen polarity."""
    rng = np.random.default_rng(3)
    L_rand = np.stack([-rng.uniform(0, 200, (3, 4)), rng.uniform(0, 6000, (3, 4))], axis=-1)
    return [(IF.model(inv_vx_upper_first=False), IF.L_printed),
            (IF.model(inv_vx_upper_first=True), IF.L_printed),
            (IF.model(), L_rand)]


def check_2(smallest_epsilon, show: bool = True):
    """Exercise 03.2: ``smallest_epsilon(model, L) -> (K,)`` [1/s], the smallest ``epsilon``
    for which the diagonal part of (20) holds for the gains ``L`` (K, 4, 2) on ``model``
    (:class:`~vehicle_observers.models.uncertain_bicycle.SwitchedIntervalModel`), per mode.
    Expected: :func:`.printed_solution.min_epsilon_shift`, on three (model, L) pairs."""
    cases = _gain_cases()
    want = [ps.min_epsilon_shift(m, L) for m, L in cases]
    return teaching.check("03.2", _calls(smallest_epsilon, cases), want,
                          hint="with P diagonal and positive, the diagonal of (20) reads "
                               "(A^- - L C)_aa + epsilon >= 0; take the largest -(A^- - L C)_aa "
                               "over the four vertices and both states of each mode",
                          rtol=1e-9, show=show)


def check_3(vertex_gain, show: bool = True):
    """Exercise 03.3: ``vertex_gain(A_lo, lam) -> L`` (2,) (``[L1 m/s, L2 1/s]``) for one
    vertex matrix ``A_lo = A_i^{j-}`` (2, 2) with ``C = [0 1]``: ``(A^- - L C)_12 = 0``
    (on the Metzler bound) and ``(A^- - L C)_22 = -lam``, so that ``A^- - L C`` is Metzler
    (entry (2,1) > 0 on the box) and Hurwitz with eigenvalues ``A_11`` and ``-lam``.
    Expected: ``L = [A_12, A_22 + lam]`` (closed form), on the 12 vertices of the Satory
    model and two ``lam``; the Metzler and Hurwitz properties are checked too."""
    A = IF.model().A_lo.reshape(-1, 2, 2)
    cases = [(A[k], lam) for lam in (20.0, 150.0) for k in range(len(A))]
    want = [np.array([a[0, 1], a[1, 1] + lam]) for a, lam in cases]
    C = np.array([[0.0, 1.0]])

    def run():
        got = _calls(vertex_gain, cases)()
        if got is None:
            return None
        got = [np.asarray(g, dtype=float).reshape(2) for g in got]
        for (a, _lam), g in zip(cases, got):
            M = a - g[:, None] @ C
            if M[0, 1] < -1e-9 or M[1, 0] < 0:
                raise ValueError(f"A^- - L C is not Metzler: off-diagonals {M[0, 1]:.4g}, "
                                 f"{M[1, 0]:.4g}")
            if np.linalg.eigvals(M).real.max() >= 0:
                raise ValueError("A^- - L C is not Hurwitz")
        return got

    return teaching.check("03.3", run, want,
                          hint="with C = [0 1], L C changes only column 2: (A^- - L C)_12 = "
                               "A_12 - L1 and (A^- - L C)_22 = A_22 - L2",
                          rtol=1e-9, atol=1e-9, show=show)
