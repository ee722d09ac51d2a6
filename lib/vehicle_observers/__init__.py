"""vehicle_observers: reproductions of vehicle state observers from five papers.

Modules by concept:

- :mod:`.tires`      Pacejka magic formula, linear tyre, first-order relaxation.
- :mod:`.lateral`    Yaw-drift model with relaxation and vision model (Yacine 2015).
- :mod:`.bicycle`    Autonomous bicycle with tracking law (Ichalal 2011).
- :mod:`.ts`         Generic Takagi-Sugeno builder by sector nonlinearity.
- :mod:`.lmi`        LMI synthesis with cvxpy + Clarabel and independent certification.
- :mod:`.logs`       Drive-log CSV schema and validated loader.
- :mod:`.simulate`   Fixed-step integrators (numba) with zero-order-hold inputs.
- :mod:`.metrics`    Error metrics.
- :mod:`.reporting`  Figure/metrics helper used by every notebook.
- :mod:`.pipeline`   Papermill regeneration of every notebook and REPRODUCTION.md.
- :mod:`.papers`     Paper-specific constants, one module per paper.
"""

from .errors import (
    CertificationError,
    InfeasibleDesign,
    LogFormatError,
    PremiseOutOfBounds,
)

__all__ = ["CertificationError", "InfeasibleDesign", "LogFormatError", "PremiseOutOfBounds"]
__version__ = "0.1.0"
