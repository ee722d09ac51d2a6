"""Command line: ``python -m vehicle_observers`` (observers, estimate, tune, identify)."""
