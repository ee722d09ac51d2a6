"""Interval observer for every car: Ifqir 2017's observer (11) in transformed coordinates.

Why a change of coordinates
---------------------------
With the yaw-rate gyro ``C = [0 1]``, entry (2,1) of ``A - L C`` is
``(c_r l_r - c_f l_f)/(I_z v_x)`` whatever the gain ``L``, so the error dynamics can be made
cooperative (Metzler) only for a car that understeers on the whole stiffness box
(``c_r l_r > c_f l_f``; ``UncertainBicycle.max_metzler_uncertainty`` in
:mod:`vehicle_observers.models.uncertain_bicycle`).
Neutral or oversteering cars, or a box that straddles neutral steer, are refused.

Raissi, Efimov, Zolghadri, "Interval state estimation for a class of nonlinear systems",
IEEE TAC 57(1), 2012 (Sec. III, time-invariant similarity ``z = T x``) and Mazenc & Bernard,
"Interval observers for linear time-invariant systems with disturbances", Automatica 47(1),
2011 (the cooperative form need not exist in the original coordinates): design the interval
observer for ``z = T x`` and map the bounds back with interval arithmetic. Here

    T = [[1, 0], [-kappa, 1]],  z = [v_y, r - kappa v_y],  T^-1 = [[1, 0], [kappa, 1]],

so ``A_z(rho, xi) = T A(rho, xi) T^-1``, ``B_z = T B``, ``C_z = C T^-1 = [kappa, 1]``
(:class:`~vehicle_observers.models.uncertain_bicycle.TransformedIntervalModel`). Entry
(2,1) of ``A_z - L C_z`` is ``A_z21 - kappa l_2``: for ``kappa != 0`` the gain reaches every
off-diagonal entry and the Metzler condition (20) is feasible for every car. ``A_z`` is still
affine in ``xi`` and in each premise ``(1/v_x, v_x)``, so the element-wise bounds of
Assumption 3 are exact at the box corners and the switched TS form (5)-(7) is unchanged; the
LMI design (16)-(21) of Ifqir 2017 Theorem 2 (:func:`~vehicle_observers.observers.interval.design_theorem2`)
and its independent certificate (eigenvalues of every LMI block, element-wise Metzler check
of every mode / vertex) apply verbatim with ``C_z``. ``kappa = 0`` is the original observer.

Back to ``x``: ``x = T^-1 z``; with ``T^-1 = S^+ - S^-`` (positive / negative parts),
``x^+ = S^+ z^+ - S^- z^-``, ``x^- = S^+ z^- - S^- z^+``, the tightest box image. The initial
``z`` box is the image of the ``x`` box under ``T`` the same way. The enclosure
``x^- <= x <= x^+`` therefore holds under exactly the conditions of the original observer
(Euler step with ``h max|diag| <= 1``, one step per sample, inputs and noise inside their
bounds).

Choice of ``kappa``: the candidates (rad/m) are tried and the certified design with the
smallest ISS gain ``gamma`` (sum over modes) is kept; a heuristic, reported with the design.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehicle_observers.core.errors import InfeasibleDesign, ObserverArgumentError
from vehicle_observers.design.lmi import Certificate
from vehicle_observers.models.uncertain_bicycle import (
    SpeedBands,
    TransformedIntervalModel,
    UncertainBicycle,
)
from vehicle_observers.observers import interval as iv

KAPPAS = (0.0, 0.05, 0.1, 0.2, 0.4, -0.05, -0.1, -0.2)


def box_image(S: np.ndarray, lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """Tightest box containing ``S x`` for ``lo <= x <= hi`` (element-wise), arrays (..., n)."""
    Sp, Sm = np.maximum(S, 0.0), np.maximum(-S, 0.0)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return lo @ Sp.T - hi @ Sm.T, hi @ Sp.T - lo @ Sm.T


@dataclass
class CoordinateIntervalDesign:
    """A certified Theorem 2 design in ``z = T x`` plus the transformation.

    ``design`` the :class:`~vehicle_observers.observers.interval.IntervalDesign` of ``z``
    (certificate in ``design.solution.certificate``, Metzler margins in
    ``design.metzler_margins``); ``tried`` ``{kappa: gamma or error message}``."""

    design: iv.IntervalDesign
    kappa: float
    tried: dict

    @property
    def certificate(self) -> Certificate | None:
        """The LMI certificate of Theorem 2 in ``z`` (:attr:`IntervalDesign.certificate`)."""
        return self.design.certificate

    @property
    def T(self):
        return self.design.model.T

    @property
    def Tinv(self):
        return self.design.model.Tinv

    @property
    def certified(self) -> bool:
        """Independent certificate: every LMI block checked by eigenvalues, the LMIs rebuilt
        from the vertex data by the synthesis layer (:attr:`IntervalDesign.data_certificate`)
        and every ``A_z^- - L C_z`` Metzler (re-checked here, not taken from the solver
        status)."""
        cert = self.design.solution.certificate
        data = self.design.data_certificate
        mm = iv.metzler_margins(self.design.model, self.design.L)
        return bool(cert.ok and (data is None or data.ok) and np.all(mm >= 0))


def design(veh: UncertainBicycle, bands: SpeedBands, dt: float,
           kappas=KAPPAS, accel_max: float = 12.0, eps_decay: float = 1.0) -> CoordinateIntervalDesign:
    """Certified design for any car: Theorem 2 (16)-(21) in ``z = T(kappa) x`` for each
    candidate ``kappa`` [rad/m]; keeps the smallest ``sum_i gamma_i``. ``epsilon`` of (20)
    is ``1/dt`` (one Euler step per sample, see :func:`~vehicle_observers.observers.interval.euler_substeps`).
    Raises :class:`InfeasibleDesign` listing every candidate's failure if none certifies."""
    if not (np.ndim(dt) == 0 and np.isfinite(dt) and dt > 0):
        raise ObserverArgumentError(f"design: dt must be finite and > 0 s, got {dt!r}")
    best, tried = None, {}
    for k in kappas:
        try:
            model = TransformedIntervalModel(veh, bands, k)
            d = iv.design_theorem2(model, eps_decay=eps_decay, epsilon_shift=1.0 / dt,
                                   accel_max=accel_max, p_min=1.0,
                                   name=f"Ifqir 2017 Theorem 2 in z = T x (kappa = {k:g})")
        except InfeasibleDesign as exc:
            tried[float(k)] = str(exc).splitlines()[0][:160]
            continue
        score = float(np.sum(d.gammas))
        tried[float(k)] = score
        if best is None or score < best[0]:
            best = (score, float(k), d)
    if best is None:
        raise InfeasibleDesign(f"{veh.name}: no certified interval observer for kappa in "
                               f"{list(kappas)}: " + "; ".join(f"{k:g}: {v}"
                                                               for k, v in tried.items()))
    return CoordinateIntervalDesign(best[2], best[1], tried)


def run(cd: CoordinateIntervalDesign, dt: float, vx, u_lo, u_hi, y, x0_lo, x0_hi,
        y_noise: float = 0.0, clip_speed: bool = False, t=None) -> iv.IntervalRun:
    """Run the observer in ``z`` and return bounds on ``x = [v_y, r]`` (N, 2).

    Arguments as :func:`~vehicle_observers.observers.interval.run_interval_observer`; the
    gyro ``y`` is still ``r`` (``= C_z z``), so ``y_noise`` bounds ``|y - r|`` [rad/s]."""
    x0_lo = np.asarray(x0_lo, float).reshape(-1)
    x0_hi = np.asarray(x0_hi, float).reshape(-1)
    if x0_lo.shape != (2,) or x0_hi.shape != (2,) or np.any(x0_lo > x0_hi):
        raise ObserverArgumentError(f"initial box must be two (2,) vectors with x0_lo <= x0_hi, "
                                    f"got {x0_lo}, {x0_hi}")
    z0_lo, z0_hi = box_image(cd.T, x0_lo, x0_hi)
    rz = iv.run_interval_observer(cd.design, dt, vx, u_lo, u_hi, y, z0_lo, z0_hi,
                                  y_noise=y_noise, clip_speed=clip_speed, t=t)
    x_lo, x_hi = box_image(cd.Tinv, rz.x_lo, rz.x_hi)
    return iv.IntervalRun(rz.t, 0.5 * (x_lo + x_hi), iv.STATE_NAMES, x_lo, x_hi, rz.seconds,
                          estimator="interval (11) in z = T x", sigma=rz.sigma,
                          substeps=rz.substeps, n_clipped=rz.n_clipped)


class CoordinateIntervalObserver(iv.IntervalObserver):
    """The interval observer (11) in ``z = T x`` (:class:`CoordinateIntervalDesign`) on the
    contract of :mod:`vehicle_observers.core.protocol`, with the arguments, inputs and
    outputs of :class:`~vehicle_observers.observers.interval.IntervalObserver`. The internal
    state is the box ``[z^-, z^+]`` (4,); :meth:`bounds` maps it back to ``x`` with the
    tightest box image under ``T^-1`` (module docstring), and the initial ``x`` box is mapped
    to ``z`` under ``T``."""

    def __init__(self, design: CoordinateIntervalDesign, dt: float, box0,
                 steer_noise: float = 0.0, y_noise: float = 0.0, clip_speed: bool = False):
        if not isinstance(design, CoordinateIntervalDesign):
            raise ObserverArgumentError(f"CoordinateIntervalObserver: design must be a "
                                        f"CoordinateIntervalDesign, got {type(design).__name__}")
        self._z_design = design.design
        super().__init__(design, dt, box0, steer_noise, y_noise, None, clip_speed)

    @property
    def _des(self) -> iv.IntervalDesign:
        return self._z_design

    def _to_z(self, lo, hi):
        return box_image(self.design.T, lo, hi)

    def _to_x(self, lo, hi):
        return box_image(self.design.Tinv, lo, hi)

