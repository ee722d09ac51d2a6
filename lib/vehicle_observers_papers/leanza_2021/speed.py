"""Speed of the Kalman baselines (Notebook 07): 350 s at 1 kHz.

The log is the Revs 250 LM run linearly interpolated to 1 kHz (first 350 s, 350,000 steps).
The numba EKF and RTS run on the whole of it; filterpy's EKF and UKF (pure Python) on the
first ``filterpy_steps`` steps, and their whole-run cost is extrapolated linearly (they have
no state-dependent cost). ``run(quick=False) -> list[dict]`` rows ``{"component", "steps",
"seconds", "us_per_step", "whole_run_s"}``; the numba kernels are compiled by a warm-up call.
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.baselines import kalman as K
from vehicle_observers.core.timing import best_time
from vehicle_observers.data.logs import DriveLog, despike, load_revs

from vehicle_observers_papers.leanza_2021 import constants as R

TUNING = K.KalmanTuning(q_vy=0.27, q_r=2e-3, q_b=0.4, R_r=1.6e-5, R_ay=1.3,
                        source="fixed for the speed benchmark")


def log_1khz(duration: float = 350.0) -> DriveLog:
    """The Revs log interpolated to 1 kHz over its first ``duration`` seconds."""
    src = load_revs()
    t = np.arange(src.t[0], src.t[0] + duration, 1e-3)
    d, _ = despike(src.delta, 0.1)
    f = lambda x: np.interp(t, src.t, x)
    return DriveLog(t=t, vx=f(src.vx), delta=f(d), yaw_rate=f(src.yaw_rate), ay=f(src.ay),
                    vy=f(src.vy), source=f"revs_250lm_2014 at 1 kHz ({duration:g} s)")


def run(quick: bool = False) -> list[dict]:
    dur = 35.0 if quick else 350.0
    log = log_1khz(dur)
    n = len(log)
    p = R.params
    K.ekf(log.segment(log.t[0], log.t[0] + 0.1), p, TUNING)    # compile
    K.rts(log.segment(log.t[0], log.t[0] + 0.1), p, TUNING)
    rows = []
    for name, fn in (("EKF (numba)", lambda: K.ekf(log, p, TUNING)),
                     ("RTS smoother (numba, EKF pass + backward pass)",
                      lambda: K.rts(log, p, TUNING))):
        sec, _ = best_time(fn, 3)
        rows.append({"component": name, "steps": n, "seconds": sec, "us_per_step": sec / n * 1e6,
                     "whole_run_s": sec})
    m = 2000 if quick else 20000
    seg = log.segment(log.t[0], log.t[m - 1])
    for name, fn in (("EKF (filterpy)", lambda: K.ekf_filterpy(seg, p, TUNING)),
                     ("UKF (filterpy, SPD repair)", lambda: K.ukf_filterpy(seg, p, TUNING))):
        sec, _ = best_time(fn, 1)
        rows.append({"component": name, "steps": m, "seconds": sec, "us_per_step": sec / m * 1e6,
                     "whole_run_s": sec / m * n})
    return rows


if __name__ == "__main__":
    for r in run():
        print(f"{r['component']:<48} {r['steps']:>8d} steps {r['seconds']*1e3:9.2f} ms "
              f"{r['us_per_step']:8.3f} us/step, whole run {r['whole_run_s']:.2f} s")
