"""Speed of the Rabhi 2004 sliding-mode observers and their truth models (60 s runs).

``python -m vehicle_observers_papers.rabhi_2004.speed`` prints the rows. ``run(quick)``
returns rows ``{"component", "steps", "seconds", "us_per_step", "dt"}``; the first call of
each kernel is excluded (numba compilation/caching).
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.baselines import sliding_mode_ekf as planar_baseline
from vehicle_observers.core.timing import best_time
from vehicle_observers.data import road
from vehicle_observers.models import fullcar, planar
from vehicle_observers.observers import sliding_mode as smo

from vehicle_observers_papers.rabhi_2004 import constants as R


def _time(fn, repeat=3):
    return best_time(fn, repeat, warmup=True)[0]


def run(quick: bool = False) -> list[dict]:
    T = 6.0 if quick else 60.0
    rows = []
    # Part A
    dt = R.dt_force
    man = planar.paper_manoeuvre(T, dt)
    X0 = planar.free_rolling_state(man.v0, R.planar)
    Xs = planar.simulate(X0, man.U, dt, R.planar)
    Y = planar.measurements(Xs)
    model = smo.ForceObserverModel.from_params(R.planar)
    n = len(man.t)
    sec = _time(lambda: planar.simulate(X0, man.U, dt, R.planar))
    rows.append({"component": "planar truth RK4 (12 states)", "steps": n, "seconds": sec,
                 "us_per_step": 1e6 * sec / n, "dt": dt})
    for mode in ("sign", "sat", "lpf"):
        g = R.force_gains.with_(mode=mode)
        obs = smo.ForceObserver(model, g, dt)
        sec = _time(lambda obs=obs: obs.run(man.t, man.U, Y))
        rows.append({"component": f"force SMO (10), {mode}", "steps": n, "seconds": sec,
                     "us_per_step": 1e6 * sec / n, "dt": dt})
    m = min(n, 2000 if quick else 10000)  # pure Python: a window of the same data
    sec, _ = best_time(lambda: planar_baseline.run_force_ekf(man.t[:m], Y[:m], man.U[:m], model,
                                                             R.sensor_noise), 1)
    rows.append({"component": "filterpy EKF on the same data (forces as random walks)",
                 "steps": m, "seconds": sec, "us_per_step": 1e6 * sec / m, "dt": dt})
    # Part B
    dt = R.dt_road
    t = np.arange(int(round(T / dt))) * dt
    p = R.fullcar
    rd = road.iso8608_road("C", R.speed_iso * T + 10, seed=0)
    U = rd.wheel_inputs(t, R.speed_iso, p.a + p.b)
    X = fullcar.simulate(U, dt, p)
    Yb = fullcar.outputs(X, None, None, p)
    n = len(t)
    sec = _time(lambda: fullcar.simulate(U, dt, p))
    rows.append({"component": "full-car truth, exact FOH (14 st.)", "steps": n, "seconds": sec,
                 "us_per_step": 1e6 * sec / n, "dt": dt})
    for mode in ("sign", "sat"):
        g = R.road_gains.with_(mode=mode)
        obs = smo.RoadObserver(p, g, dt)
        sec = _time(lambda obs=obs: obs.run(t, None, Yb))
        rows.append({"component": f"road UIO (30)-(38), {mode}", "steps": n, "seconds": sec,
                     "us_per_step": 1e6 * sec / n, "dt": dt})
    return rows


if __name__ == "__main__":
    for r in run():
        print(f"{r['component']:<34} {r['steps']:>8d} steps  {r['seconds']:7.3f} s  "
              f"{r['us_per_step']:6.2f} us/step  (dt = {r['dt']:g} s)")
