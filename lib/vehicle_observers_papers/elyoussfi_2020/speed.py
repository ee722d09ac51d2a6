"""Speed of the relaxed-UIO simulation loops (Notebook 06): 60 s at 1 kHz per observer.

``run(quick=False) -> list[dict]`` rows ``{"component", "steps", "seconds", "us_per_step"}``.
The designs are solved once (not timed); the numba kernels are compiled by a warm-up call.
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.baselines import uio_ekf as uio_baseline
from vehicle_observers.core.timing import best_time
from vehicle_observers.models import uncertain_lateral as ul
from vehicle_observers.observers import uio

from vehicle_observers_papers.elyoussfi_2020 import constants as P
from vehicle_observers_papers.elyoussfi_2020 import scenario as sn


def _best_of(fn, repeat=3):
    return best_time(fn, repeat)[0]


def run(quick: bool = False) -> list[dict]:
    model = P.build_model()
    st = uio.structure(model)
    ga = uio.design_quadratic(model, P.alpha_design, st, radius=P.radius)
    phi = uio.phi_bound(model, P.delta_dot_max, P.scale_fdot, P.tire_f.D, P.tire_r.D)["phi"]
    gb = uio.design_relaxed(model, P.alpha_design, phi, P.mu_grid, st, radius=P.radius)
    t_end = 10.0 if quick else 60.0
    sc = sn.make_scenario(model, 1.0, P.dt, 0.5, P.x0_true, seed=0)  # warm-up / compile
    obs = {g.design: uio.UIObserver(g, model, P.dt) for g in (ga, gb)}
    for o in obs.values():
        o.run(sc["t"], sc["delta"], sc["y"])
    n = int(round(t_end / P.dt)) + 1
    t = np.arange(n) * P.dt
    delta = sn.steering_signal(t)
    f = sn.fault_signal(t, 0.4 * t_end)
    F = sn.uncertainty_signal(t, 0)
    rows = []
    sec = _best_of(lambda: ul.simulate_truth(model, P.x0_true, delta, f, F, P.dt), 3)
    rows.append({"component": "uio truth model RK4 (2 substeps)", "steps": n, "seconds": sec,
                 "us_per_step": sec / n * 1e6})
    X = ul.simulate_truth(model, P.x0_true, delta, f, F, P.dt)
    y = X @ model.C.T + f[:, None] * model.F_s[:, 0][None, :]
    for name, g in (("uio (a) quadratic [22]", ga), ("uio (b) relaxed Thm 2", gb)):
        sec = _best_of(lambda g=g: obs[g.design].run(t, delta, y), 5)
        rows.append({"component": f"{name} observer RK4", "steps": n, "seconds": sec,
                     "us_per_step": sec / n * 1e6})
    m = 2000 if quick else 10000  # pure Python: a window, cost per step is state-independent
    sec, _ = best_time(lambda: uio_baseline.run_filter(model, delta[:m], y[:m], P.dt,
                                                       h="estimated"), 1)
    rows.append({"component": "filterpy EKF on the same data (fault random walk)", "steps": m,
                 "seconds": sec, "us_per_step": sec / m * 1e6})
    return rows


if __name__ == "__main__":
    for r in run():
        print(f"{r['component']:<40} {r['steps']:>8d} steps {r['seconds']*1e3:9.2f} ms "
              f"{r['us_per_step']:8.3f} us/step")
