"""Speed of the DMVT observer (Ichalal 2011): numba co-simulation of bicycle + observer (6)
and the LMI designs (23) / (23)+(35)+(36).

    python -m vehicle_observers_papers.ichalal_2011.speed [--quick]
"""

from __future__ import annotations

import sys
import time

import numpy as np
from vehicle_observers.baselines import dmvt_ekf as bb
from vehicle_observers.core.timing import best_time
from vehicle_observers.design.lmi import disk, halfplane
from vehicle_observers.models import bicycle as b
from vehicle_observers.models.ts import jacobian_ts_from_samples
from vehicle_observers.observers import dmvt

from vehicle_observers_papers.ichalal_2011 import constants as ic


def _setup(T: float):
    bp = ic.params
    t = np.arange(0.0, T, 1e-3)
    X, U = b.simulate(bp, t)
    z = b.ts_premises(X, U, bp)
    lo, hi = z.min(0), z.max(0)
    ts = b.bicycle_ts(bp, list(zip(lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo), strict=True)))
    jts = jacobian_ts_from_samples(b.jacobian(X, U, bp))
    return bp, t, ts, jts


def run(quick: bool = False) -> list[dict]:
    """Rows ``{"component", "steps", "seconds", "us_per_step", ...}``."""
    T = 10.0 if quick else 100.0
    bp, t, ts, jts = _setup(20.0)
    rows = []
    for name, region, r in (("LMI (23), r=8", None, 8),
                            ("LMI (23)+(35)+(36) a=2 R=10, r=8", [halfplane(2), disk(10)], 8),
                            ("LMI (23)+(35)+(36) a=2 R=10, r=1", [halfplane(2), disk(10)], 1)):
        t0 = time.perf_counter()
        des = dmvt.design_dmvt_observer(jts.vertices, ic.C, r=r, region=region)
        dt = time.perf_counter() - t0
        rows.append({"component": f"dmvt design {name} (solve + certify)", "steps": 1,
                     "seconds": dt, "us_per_step": dt * 1e6,
                     "solver_seconds": des.solution.solve_time,
                     "n_lmis": len(des.solution.certificate.checks)})
    tt = np.arange(0.0, T, 1e-3)
    L = np.repeat(des.L, ts.n_rules, axis=0)
    best, _ = best_time(lambda: dmvt.simulate_bicycle_observer(      # warmup: compile / cache
        bp, tt, ts, L, ic.C, xhat0=(0.1, -0.1, 0.1, 0.5)), 3, warmup=True)
    rows.append({"component": "dmvt bicycle + observer (6) RK4 co-simulation, 8 rules",
                 "steps": len(tt), "seconds": best, "us_per_step": best / len(tt) * 1e6})
    # the same observer on sampled data, and the filterpy EKF baseline on the same data
    m = 1000 if quick else 5000
    X, U = b.simulate(bp, tt[:m])
    Y = X @ ic.C.T
    x0 = np.array([0.1, -0.1, 0.1, 0.5])
    obs = dmvt.DMVTObserver(L, ts, bp, ic.C, 1e-3)
    sec = min(obs.run(tt[:m], U[:, None], Y, x0).seconds for _ in range(3))
    rows.append({"component": "dmvt observer (6) on sampled data (DMVTObserver.run)",
                 "steps": m, "seconds": sec, "us_per_step": sec / m * 1e6})
    ekf = bb.BicycleEKF(bp, ic.C, 1e-3, 1e-6 * np.eye(4), 1e-4 * np.eye(2), np.eye(4))
    sec = ekf.run(tt[:m], U[:, None], Y, x0).seconds
    rows.append({"component": "filterpy EKF on the same data (exact RK4 Jacobian)",
                 "steps": m, "seconds": sec, "us_per_step": sec / m * 1e6})
    return rows


if __name__ == "__main__":
    for row in run(quick="--quick" in sys.argv):
        print({k: (round(v, 4) if isinstance(v, float) else v) for k, v in row.items()})
