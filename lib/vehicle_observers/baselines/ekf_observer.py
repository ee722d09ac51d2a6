"""The filterpy extended Kalman filter of :mod:`.baselines.filterpy_generic` under the observer
contract of :mod:`vehicle_observers.core.protocol`.

The baselines of the bicycle (:mod:`.baselines.dmvt_ekf`), of the tyre forces
(:mod:`.baselines.sliding_mode_ekf`) and of the fault (:mod:`.baselines.uio_ekf`) are EKFs on
sampled data: :class:`EKFObserver` gives them the one ``step`` (readable numpy: predict over
``[t_{k-1}, t_k]`` with ``u_{k-1}`` held, then update with ``y_k``) and a ``run`` that calls
the filterpy loop :func:`.baselines.filterpy_generic.run_ekf` (update with ``y_k``, record,
predict: the same order, so ``z_k`` is the posterior at sample ``k``). The internal state is
``z = [x (n), P (n*n, row-major)]``; the design is the noise table :class:`NoiseDesign` (no
certificate).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, ClassVar

import numpy as np

from vehicle_observers.baselines.filterpy_generic import (
    FilterRun,
    numerical_jacobian,
    rk4_step,
    run_ekf,
)
from vehicle_observers.core.errors import ObserverArgumentError
from vehicle_observers.core.protocol import Trajectory
from vehicle_observers.observers.fixed_step import FixedStepObserver


@dataclass(frozen=True)
class NoiseDesign:
    """Noise table of a Kalman filter: ``Q`` (n, n) continuous process-noise intensity,
    ``R`` (p, p) measurement covariance, ``P0`` (n, n) initial covariance (a tuning rule, not
    an LMI: ``certificate`` is ``None``)."""

    certificate: ClassVar[None] = None

    Q: np.ndarray
    R: np.ndarray
    P0: np.ndarray


@dataclass(frozen=True, eq=False)
class EKFTrajectory(Trajectory):
    """Run of a Kalman filter: posterior means ``x`` (N, n) and the diagonal of their
    covariance ``P_diag`` (N, n)."""

    P_diag: np.ndarray | None = None


def filter_trajectory(t, run: FilterRun, names, cls=EKFTrajectory, **extra) -> EKFTrajectory:
    """A :class:`~.baselines.filterpy_generic.FilterRun` as a trajectory of class ``cls``."""
    return cls(t, run.x, tuple(names), seconds=run.seconds, estimator=run.name,
               info=dict(run.info), P_diag=run.P_diag, **extra)


class EKFObserver(FixedStepObserver):
    """filterpy ``ExtendedKalmanFilter`` on ``x' = f(x, u)``, ``y = h(x, u)`` at the sample
    period ``dt`` [s] (RK4 with ``u`` held, ``Q_k = Q dt``; see
    :mod:`.baselines.filterpy_generic`).

    ``f(x (n,), u (m,)) -> (n,)``, ``h(x, u) -> (p,)``; ``jac(x, u, dt) -> (x_next, F)`` and
    ``hjac(x, u) -> H`` override the central-difference Jacobians; ``Q``, ``R``, ``P0`` the
    noise table (:class:`NoiseDesign`); the names of the states, inputs and measurements.
    ``x0`` (n,) of :meth:`run`: the prior mean at sample 0 (required).
    """

    def __init__(self, f: Callable, h: Callable, dt: float, Q, R, P0, state_names,
                 input_names, output_names, jac: Callable | None = None,
                 hjac: Callable | None = None, name: str = "EKF (filterpy)"):
        super().__init__(dt)
        self.state_names, self.input_names = tuple(state_names), tuple(input_names)
        self.output_names = tuple(output_names)
        n, p = len(self.state_names), len(self.output_names)
        mats = {}
        for arg, M, k in (("Q", Q, n), ("R", R, p), ("P0", P0, n)):
            M = np.asarray(M, dtype=float)
            if M.shape != (k, k) or not np.all(np.isfinite(M)):
                raise ObserverArgumentError(f"{name}: {arg} must be ({k}, {k}) and finite, got "
                                            f"shape {M.shape}")
            mats[arg] = M
        self.design = NoiseDesign(**mats)
        self.f, self.h, self.jac, self.hjac, self.name = f, h, jac, hjac, name

    def _update(self, x, P, uk, yk):
        """Measurement update with ``y_k`` (filterpy's Joseph form)."""
        R = self.design.R
        H = self.hjac(x, uk) if self.hjac else numerical_jacobian(lambda s: self.h(s, uk), x)
        PHT = P @ H.T
        K = PHT @ np.linalg.inv(H @ PHT + R)
        x = x + K @ (yk - np.atleast_1d(self.h(x, uk)))
        I_KH = np.eye(len(x)) - K @ H
        return x, I_KH @ P @ I_KH.T + K @ R @ K.T

    def initial_state(self, t, u, y, x0=None) -> np.ndarray:
        if x0 is None:
            raise ObserverArgumentError(f"{self.name}: x0 (the prior mean, "
                                        f"{len(self.state_names)} values) is required")
        x, P = self._update(np.array(x0, dtype=float), self.design.P0.copy(), u[0], y[0])
        return np.concatenate([x, P.ravel()])

    def step(self, z, k, t, u, y) -> np.ndarray:
        """Extended Kalman filter: predict over ``[t_{k-1}, t_k]`` (one RK4 step of ``f``
        with ``u_{k-1}`` held and its Jacobian ``F``, ``P = F P F' + Q dt``), then update with
        ``y_k``: ``K = P H' (H P H' + R)^-1``, ``x += K (y_k - h(x))``,
        ``P = (I - K H) P (I - K H)' + K R K'``."""
        n, dt = len(self.state_names), self.dt
        x, P, uk = z[:n], z[n:].reshape(n, n), u[k - 1]
        if self.jac is not None:
            xn, F = self.jac(x, uk, dt)
        else:
            xn = rk4_step(self.f, x, uk, dt)
            F = numerical_jacobian(lambda s: rk4_step(self.f, s, uk, dt), x)
        x, P = self._update(xn, F @ P @ F.T + self.design.Q * dt, u[k], y[k])
        return np.concatenate([x, P.ravel()])

    def estimate(self, z) -> np.ndarray:
        return np.array(z[:len(self.state_names)])

    def run(self, t, u, y, x0=None) -> EKFTrajectory:
        """The filterpy loop (:func:`~.baselines.filterpy_generic.run_ekf`)."""
        t, u, y, x0 = self.check_data(t, u, y, x0)
        if x0 is None:
            self.initial_state(t, u, y, x0)          # raises: the prior is required
        d = self.design
        run = run_ekf(self.f, self.h, y, u, self.dt, x0, d.P0, d.Q, d.R, jac=self.jac,
                      hjac=self.hjac, name=self.name)
        return filter_trajectory(t, run, self.state_names)
