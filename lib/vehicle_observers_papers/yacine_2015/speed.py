"""Speed of the Yacine 2015 chain: a 350 s run at 1 kHz (350,000 samples) of the third-order
Levant differentiator and of the TS observer (31) must each take at most 2 s; plus the
Theorem 1 LMI design and the truth simulation of the emulated lap.

    python -m vehicle_observers_papers.yacine_2015.speed [--quick]

Inputs are the emulated Satory lap (about 230 s) tiled to 350 s; timings are the best of
three runs after a warm-up call (numba compilation / cache load excluded).
"""

from __future__ import annotations

import sys
import time

import numpy as np
from vehicle_observers.core.timing import best_time
from vehicle_observers.data import scenarios
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.observers import ts_premise as to
from vehicle_observers.observers.differentiators import levant_differentiator

from vehicle_observers_papers.yacine_2015 import constants as yacine2015


def _best(fn, repeat=3):
    return best_time(fn, repeat)[0]


def _tile(log: DriveLog, T: float) -> DriveLog:
    n = int(round(T / log.dt))
    reps = int(np.ceil(n / len(log)))
    cols = {a: np.tile(getattr(log, a), reps)[:n] for a in
            ("vx", "delta", "yaw_rate", "yL", "psiL", "vy", "Ff", "Fr", "rho")}
    return DriveLog(t=np.arange(n) * log.dt, **cols, source=f"{log.source} tiled to {T:g} s")


def run(quick: bool = False) -> list[dict]:
    """Rows ``{"component", "steps", "seconds", "us_per_step", ...}``."""
    T = 35.0 if quick else 350.0
    rows = []
    t0 = time.perf_counter()
    lap = scenarios.emulated_satory(seed=0, quick=quick)
    dt_sim = time.perf_counter() - t0
    t0 = time.perf_counter()
    lap = scenarios.emulated_satory(seed=0, quick=quick)
    dt_sim = min(dt_sim, time.perf_counter() - t0)
    rows.append({"component": "emulated_satory truth (closed loop RK4 x2 + sensors)",
                 "steps": len(lap), "seconds": dt_sim, "us_per_step": dt_sim / len(lap) * 1e6})
    log = _tile(lap, T)
    n = len(log)
    levant_differentiator(log.yL[:10], log.dt, 3, 50.0)
    s = _best(lambda: levant_differentiator(log.yL, log.dt, 3, 50.0))
    rows.append({"component": "Levant differentiator n=3 (one signal)", "steps": n,
                 "seconds": s, "us_per_step": s / n * 1e6, "budget_seconds": 2.0 * n / 350000})
    s = _best(lambda: to.estimate_premises(log))
    rows.append({"component": "premise chain (2 differentiators, (11), (26), (28))",
                 "steps": n, "seconds": s, "us_per_step": s / n * 1e6})
    t0 = time.perf_counter()
    des = to.design_theorem1(yacine2015.ts_model())
    dt = time.perf_counter() - t0
    rows.append({"component": "Theorem 1 LMI (33) + disk, 8 vertices (solve + certify)",
                 "steps": 1, "seconds": dt, "us_per_step": dt * 1e6,
                 "solver_seconds": des.solution.solve_time})
    pe = to.estimate_premises(log)
    warm = log.segment(0, 0.01)                       # compile the kernel before timing it
    to.run_observer(warm, des, vy_premise=pe.vy[:len(warm.t)])
    s = _best(lambda: to.run_observer(log, des, pe))
    rows.append({"component": "TS observer (31), 8 rules, RK4, + forces (46)", "steps": n,
                 "seconds": s, "us_per_step": s / n * 1e6, "budget_seconds": 2.0 * n / 350000})
    return rows


if __name__ == "__main__":
    for row in run(quick="--quick" in sys.argv):
        print({k: (round(v, 4) if isinstance(v, float) else v) for k, v in row.items()})
