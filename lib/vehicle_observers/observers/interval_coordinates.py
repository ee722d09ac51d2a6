"""Interval observer for every car: Ifqir 2017's observer (11) in transformed coordinates.

Why a change of coordinates
---------------------------
With the yaw-rate gyro ``C = [0 1]``, entry (2,1) of ``A - L C`` is
``(c_r l_r - c_f l_f)/(I_z v_x)`` whatever the gain ``L``, so the error dynamics can be made
cooperative (Metzler) only for a car that understeers on the whole stiffness box
(``c_r l_r > c_f l_f``; ``UncertainBicycle.max_metzler_uncertainty`` in
:mod:`vehicle_observers.observers.interval`).
Neutral or oversteering cars, or a box that straddles neutral steer, are refused.

Raissi, Efimov, Zolghadri, "Interval state estimation for a class of nonlinear systems",
IEEE TAC 57(1), 2012 (Sec. III, time-invariant similarity ``z = T x``) and Mazenc & Bernard,
"Interval observers for linear time-invariant systems with disturbances", Automatica 47(1),
2011 (the cooperative form need not exist in the original coordinates): design the interval
observer for ``z = T x`` and map the bounds back with interval arithmetic. Here

    T = [[1, 0], [-kappa, 1]],  z = [v_y, r - kappa v_y],  T^-1 = [[1, 0], [kappa, 1]],

so ``A_z(rho, xi) = T A(rho, xi) T^-1``, ``B_z = T B``, ``C_z = C T^-1 = [kappa, 1]``. Entry
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

from vehicle_observers.core.errors import InfeasibleDesign
from vehicle_observers.observers import interval as iv

KAPPAS = (0.0, 0.05, 0.1, 0.2, 0.4, -0.05, -0.1, -0.2)


def transform(kappa: float) -> tuple[np.ndarray, np.ndarray]:
    """``(T, T^-1)`` of the similarity ``z = T x`` (module docstring), each (2, 2)."""
    k = float(kappa)
    return np.array([[1.0, 0.0], [-k, 1.0]]), np.array([[1.0, 0.0], [k, 1.0]])


def box_image(S: np.ndarray, lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """Tightest box containing ``S x`` for ``lo <= x <= hi`` (element-wise), arrays (..., n)."""
    Sp, Sm = np.maximum(S, 0.0), np.maximum(-S, 0.0)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return lo @ Sp.T - hi @ Sm.T, hi @ Sp.T - lo @ Sm.T


class TransformedIntervalModel(iv.SwitchedIntervalModel):
    """:class:`~vehicle_observers.observers.interval.SwitchedIntervalModel` of ``z = T x``:
    ``A_lo/A_nom/A_hi`` (K, 4, 2, 2) of ``T A T^-1``, ``B_*`` (2, 1) of ``T B``, ``C = C_z``."""

    def __init__(self, veh: iv.UncertainBicycle, bands: iv.SpeedBands, kappa: float):
        super().__init__(veh, bands)
        self.kappa = float(kappa)
        self.T, self.Tinv = transform(kappa)
        box = veh.xi_box
        for i in range(bands.n_modes):
            for j in range(4):
                s, v = self.z_vertices[i, j]
                fn = (lambda xi, s=s, v=v: self.T @ iv.lpv_A(s, v, xi, veh) @ self.Tinv)
                self.A_lo[i, j], self.A_nom[i, j], self.A_hi[i, j] = iv.elementwise_bounds(fn,
                                                                                           box)
        self.B_lo, self.B_nom, self.B_hi = iv.elementwise_bounds(
            lambda xi: self.T @ iv.lpv_B(xi, veh), box)
        self.C = iv.C_OUT @ self.Tinv

    def check_metzler_feasible(self):
        """Raise :class:`InfeasibleDesign` if an off-diagonal entry in a column that ``L C``
        cannot reach (``C[0, b] = 0``) is negative somewhere on the box."""
        K, J, n, _ = self.A_lo.shape
        for b in range(n):
            if self.C[0, b] != 0.0:
                continue
            for i in range(K):
                for j in range(J):
                    for a in range(n):
                        if a != b and self.A_lo[i, j, a, b] < 0:
                            raise InfeasibleDesign(
                                f"Metzler condition (20) impossible with kappa = {self.kappa:g}"
                                f" in mode {i + 1}, vertex {j + 1}: entry ({a + 1},{b + 1}) of "
                                f"A_z^- = {self.A_lo[i, j, a, b]:.4g} < 0 and C_z[{b + 1}] = 0",
                                lmi=f"Metzler[{i + 1},{j + 1}]",
                                violation=-self.A_lo[i, j, a, b])

    def check_diagonal_shift(self, epsilon: float):
        """(20)'s diagonal part: only columns with ``C[0, a] = 0`` are out of the gain's
        reach; for ``kappa != 0`` none is and the LMI decides."""
        if self.C[0, 0] == 0.0:
            super().check_diagonal_shift(epsilon)


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
    def T(self):
        return self.design.model.T

    @property
    def Tinv(self):
        return self.design.model.Tinv

    @property
    def certified(self) -> bool:
        """Independent certificate: every LMI block checked by eigenvalues and every
        ``A_z^- - L C_z`` Metzler (re-checked here, not taken from the solver status)."""
        cert = self.design.solution.certificate
        mm = iv.metzler_margins(self.design.model, self.design.L)
        return bool(cert.ok and np.all(mm >= 0))


def design(veh: iv.UncertainBicycle, bands: iv.SpeedBands, dt: float,
           kappas=KAPPAS, accel_max: float = 12.0, eps_decay: float = 1.0) -> CoordinateIntervalDesign:
    """Certified design for any car: Theorem 2 (16)-(21) in ``z = T(kappa) x`` for each
    candidate ``kappa`` [rad/m]; keeps the smallest ``sum_i gamma_i``. ``epsilon`` of (20)
    is ``1/dt`` (one Euler step per sample, see :func:`~vehicle_observers.observers.interval.euler_substeps`).
    Raises :class:`InfeasibleDesign` listing every candidate's failure if none certifies."""
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be > 0 s, got {dt}")
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
        y_noise: float = 0.0, clip_speed: bool = False) -> iv.IntervalResult:
    """Run the observer in ``z`` and return bounds on ``x = [v_y, r]`` (N, 2).

    Arguments as :func:`~vehicle_observers.observers.interval.run_interval_observer`; the
    gyro ``y`` is still ``r`` (``= C_z z``), so ``y_noise`` bounds ``|y - r|`` [rad/s]."""
    x0_lo = np.asarray(x0_lo, float).reshape(-1)
    x0_hi = np.asarray(x0_hi, float).reshape(-1)
    if x0_lo.shape != (2,) or x0_hi.shape != (2,) or np.any(x0_lo > x0_hi):
        raise ValueError(f"initial box must be two (2,) vectors with x0_lo <= x0_hi, got "
                         f"{x0_lo}, {x0_hi}")
    z0_lo, z0_hi = box_image(cd.T, x0_lo, x0_hi)
    rz = iv.run_interval_observer(cd.design, dt, vx, u_lo, u_hi, y, z0_lo, z0_hi,
                                  y_noise=y_noise, clip_speed=clip_speed)
    x_lo, x_hi = box_image(cd.Tinv, rz.x_lo, rz.x_hi)
    return iv.IntervalResult(x_lo, x_hi, rz.sigma, rz.substeps, rz.n_clipped)


def step_readable(cd: CoordinateIntervalDesign, i: int, h, z_hi, z_lo, y, u_lo, u_hi):
    """Readable numpy right-hand side of the observer in ``z`` (mode ``i``, weights ``h``):
    the same formula as :func:`~vehicle_observers.observers.interval.implemented_rhs` (the
    tests compare it with one compiled Euler step)."""
    return iv.implemented_rhs(cd.design, i, h, z_hi, z_lo, y, u_lo, u_hi)
