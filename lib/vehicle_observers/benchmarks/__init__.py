"""Speed benchmarks (``make bench``), one module per topic, each exposing ``run() -> list[dict]``.

Rows: ``{"component": str, "steps": int, "seconds": float, "us_per_step": float, ...}``.
Measured here, never in timed tests.
"""

import time


def best_time(fn, repeat: int = 3, warmup: bool = False):
    """Best wall time [s] of ``repeat`` calls of ``fn()`` and the last call's result:
    ``(seconds, result)``. ``warmup``: one untimed call first (numba compilation / cache
    load). The minimum is the least load-disturbed measurement of a deterministic loop."""
    if warmup:
        fn()
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out
