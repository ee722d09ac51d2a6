"""Speed benchmarks (``make bench``), one module per topic, each exposing ``run() -> list[dict]``.

Rows: ``{"component": str, "steps": int, "seconds": float, "us_per_step": float, ...}``.
Measured here, never in timed tests.
"""
