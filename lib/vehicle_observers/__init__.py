"""vehicle_observers: reproductions of vehicle state observers from five papers.

Subpackages by concept, imports pointing one way (``tests/test_architecture.py``)::

    core <- models <- design, data <- observers, results <- baselines <- estimation
         <- campaign <- cli <- bench

The paper reproductions live beside the library, in :mod:`vehicle_observers_papers`.

- :mod:`.core`       errors, error metrics, signals, array and timing helpers.
- :mod:`.models`     tyres, Takagi-Sugeno forms, lateral / bicycle / planar / full-car models, vehicle files.
- :mod:`.design`     LMI synthesis with an independent certificate, pole regions.
- :mod:`.data`       drive logs, scenario generators, road profiles, identification.
- :mod:`.observers`  one module per observer kind, each citing its paper; differentiators.
- :mod:`.baselines`  EKF/UKF/RTS baselines (filterpy), one per observer's own data.
- :mod:`.estimation` estimators on drive logs: the registry (open to plug-ins), provenance.
- :mod:`.campaign`   robustness campaigns (spec, truths, tasks, store, engines, report).
- :mod:`.results`    figures, metrics.json and claims; the papermill pipeline.
- :mod:`.cli`        ``python -m vehicle_observers``.
- :mod:`.bench`      ``make bench``.
"""

from vehicle_observers.core.errors import (
    CertificationError,
    InfeasibleDesign,
    LogFormatError,
    PremiseOutOfBounds,
)
from vehicle_observers.core.source import configure_jit_cache

# numba's compiled kernels are cached in a folder named after the SHA-256 of the package
# source (vehicle_observers.core.source): a kernel calling another module's kernel is never
# run from a cache compiled against that module's old code
configure_jit_cache()

__all__ = ["CertificationError", "InfeasibleDesign", "LogFormatError", "PremiseOutOfBounds"]
__version__ = "0.1.0"
