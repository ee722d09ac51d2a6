"""Wall-clock timing helper of the speed benchmarks (``make bench``); never used in tests."""

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
