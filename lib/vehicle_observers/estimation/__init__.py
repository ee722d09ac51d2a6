"""Estimation on drive logs: the estimator registry (open to plug-ins), adapters, stretches."""

from vehicle_observers.core.protocol import Observer, ObserverBase, Trajectory, run_readable
from vehicle_observers.estimation import (
    adapters,  # noqa: F401  (registers the paper observers, after the Kalman family)
    auto,  # noqa: F401  (registers auto: chooses among the others at run time)
    kalman_runs,  # noqa: F401  (registers ekf, ekf-filterpy, ukf, rts)
    peer_runs,  # noqa: F401  (registers the peers, baselines, adaptive-ekf, fusion-interval)
    references,  # noqa: F401  (registers open-loop-linear, linear-kf)
)
from vehicle_observers.estimation.checks import ObserverCheck, check_observer
from vehicle_observers.estimation.registry import (
    EstimatorSpec,
    available,
    estimator,
    get,
    load_plugin,
    load_plugins,
    register,
    register_observer,
)
from vehicle_observers.estimation.scoring import score

__all__ = ["EstimatorSpec", "Observer", "ObserverBase", "ObserverCheck", "Trajectory",
           "available", "check_observer", "estimator", "get", "load_plugin", "load_plugins",
           "register", "register_observer", "run_readable", "score"]
