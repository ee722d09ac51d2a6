"""Command line: observer registry, adapters to drive logs, and the entry point."""

from vehicle_observers.cli import (
    adapters,  # noqa: F401  (registers the paper observers)
    registry,  # noqa: F401  (first: the Kalman family)
)
