"""vehicle_observers: reproductions of vehicle state observers from five papers.

Subpackages by concept, imports pointing one way (``tests/test_architecture.py``)::

    core <- models <- design, data <- observers, results <- baselines <- papers <- cli <- bench

- :mod:`.core`       errors, error metrics, signals, array and timing helpers.
- :mod:`.models`     tyres, Takagi-Sugeno forms, lateral / bicycle / planar / full-car models, vehicle files.
- :mod:`.design`     LMI synthesis with an independent certificate, pole regions.
- :mod:`.data`       drive logs, scenario generators, road profiles, identification.
- :mod:`.observers`  one module per observer kind, each citing its paper; differentiators.
- :mod:`.baselines`  EKF/UKF/RTS baselines (filterpy), one per observer's own data.
- :mod:`.results`    figures, metrics.json and claims; the papermill pipeline.
- :mod:`.papers`     the reproductions: printed constants and each notebook's experiments.
- :mod:`.cli`        ``python -m vehicle_observers``.
- :mod:`.bench`      ``make bench``.
"""

from vehicle_observers.core.errors import (
    CertificationError,
    InfeasibleDesign,
    LogFormatError,
    PremiseOutOfBounds,
)

__all__ = ["CertificationError", "InfeasibleDesign", "LogFormatError", "PremiseOutOfBounds"]
__version__ = "0.1.0"
