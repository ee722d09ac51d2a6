"""Speed of the observer-synthesis layer (:mod:`vehicle_observers.design.synthesis`): solver
time against total time per design, and a feasibility map.

    python -m vehicle_observers.bench.lmi_layer [--points N] [--out build/timings/lmi_layer.json]

For each design: ``total`` (building the LMIs, cvxpy's canonicalisation, the solver, the data
certificate), ``solver`` (Clarabel's own time, ``LMISolution.solver_seconds``),
``problem_solve`` (cvxpy's ``Problem.solve``: canonicalisation + solver) and
``certify`` (the data certificate alone), reported as the ratio total / solver (goal <= 2).
The map solves ``Decay(alpha) + InRegion(disk(R))`` on a grid of ``N`` points (default 1000)
twice: one :class:`ObserverSynthesis` per point (each canonicalised by cvxpy), and built once
with cvxpy Parameters (:func:`~vehicle_observers.design.synthesis.decay_disk_map`), each point
certified from the data; it reports the ratio total / solver of each. Only ratios and
counts are meant to be read: wall-clock numbers depend on the machine and are written to
``build/timings`` (never committed).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from vehicle_observers.core.errors import InfeasibleDesign
from vehicle_observers.design.certify import certify_observer
from vehicle_observers.design.constraints import BoundedReal, Decay, InRegion
from vehicle_observers.design.lmi import disk
from vehicle_observers.design.synthesis import ObserverSynthesis, decay_disk_map
from vehicle_observers.design.system import PolytopicSystem


def msd_system() -> PolytopicSystem:
    """The README's mass-spring-damper, stiffness in [2, 5] (two vertices)."""
    A = [np.array([[0.0, 1.0], [-k, -0.5]]) for k in (2.0, 5.0)]
    return PolytopicSystem(A, [[1.0, 0.0]], E=[[0.0, 0.0], [1.0, 0.0]], D=[[0.0, 1.0]],
                           name="msd")


def random_system(q: int = 8, n: int = 4, seed: int = 0) -> PolytopicSystem:
    """``q`` seeded random vertices around a stable ``A_0`` (n states, 2 outputs)."""
    rng = np.random.default_rng(seed)
    A0 = rng.normal(size=(n, n)) - 2.0 * np.eye(n)
    A = A0 + 0.3 * rng.normal(size=(q, n, n))
    return PolytopicSystem(A, rng.normal(size=(2, n)), E=rng.normal(size=(n, 1)),
                           name=f"random q={q} n={n}")


def designs():
    """``(name, synthesis, objective)`` of the timed designs."""
    msd, rnd = msd_system(), random_system()
    return [
        ("msd decay+disk", ObserverSynthesis(msd, [Decay(1.0), InRegion(disk(20.0))]), None),
        ("msd min gamma", ObserverSynthesis(msd, [BoundedReal(), InRegion(disk(20.0))]), "gamma"),
        ("random 8x4 decay", ObserverSynthesis(rnd, [Decay(0.5)]), None),
        ("random 8x4 PDC decay", ObserverSynthesis(rnd, [Decay(0.5)], gains="pdc"), None),
        ("random 8x4 min gamma", ObserverSynthesis(rnd, [BoundedReal()]), "gamma"),
    ]


def time_design(syn, objective, repeat: int = 3) -> dict:
    best = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        des = syn.solve(objective=objective, raise_on_violation=False)
        total = time.perf_counter() - t0
        t1 = time.perf_counter()
        certify_observer(syn, des.P, des.L, gamma=des.gamma, c=des.c)
        cert = time.perf_counter() - t1
        row = {"total_s": total, "solver_s": des.solution.solver_seconds,
               "problem_solve_s": des.solution.solve_time, "certify_s": cert,
               "status": des.status}
        if best is None or total < best["total_s"]:
            best = row
    best["ratio"] = best["total_s"] / best["solver_s"]
    return best


def feasibility_map(points: int = 1000) -> dict:
    na = max(2, int(round(np.sqrt(points * 1.6))))
    nr = max(2, points // na)
    alphas, radii = np.linspace(0.2, 6.0, na), np.linspace(4.0, 30.0, nr)
    msd = msd_system()
    solver = 0.0
    feasible = 0
    t0 = time.perf_counter()
    for a in alphas:
        for R in radii:
            syn = ObserverSynthesis(msd, [Decay(float(a)), InRegion(disk(float(R)))])
            try:
                des = syn.solve(raise_on_violation=False)
            except InfeasibleDesign as exc:
                solver += float(getattr(exc, "solve_time", 0.0) or 0.0)
                continue
            solver += des.solution.solver_seconds
            feasible += des.status == "certified"
    total = time.perf_counter() - t0
    return {"points": int(na * nr), "certified": feasible, "total_s": total,
            "solver_s_feasible": solver, "ratio_feasible_solver": total / max(solver, 1e-12)}


def parametric_map(points: int = 1000) -> dict:
    """The same map through :func:`~vehicle_observers.design.synthesis.decay_disk_map`: the
    problem built once with cvxpy Parameters, every point certified from the data."""
    na = max(2, int(round(np.sqrt(points * 1.6))))
    nr = max(2, points // na)
    m = decay_disk_map(msd_system(), np.linspace(0.2, 6.0, na), np.linspace(4.0, 30.0, nr))
    st = m["status"]
    return {"points": int(st.size), "certified": int((st == "certified").sum()),
            "infeasible": int((st == "infeasible").sum()), "total_s": m["total_s"],
            "solver_s": m["solver_s"], "ratio_total_solver": m["total_s"] / m["solver_s"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m vehicle_observers.bench.lmi_layer")
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--out", default="build/timings/lmi_layer.json")
    args = ap.parse_args(argv)
    if args.points < 4:
        print("--points must be >= 4", file=sys.stderr)
        return 2
    rows = {}
    for _name, syn, obj in designs()[:1]:        # warm-up: imports and first canonicalisation
        time_design(syn, obj, repeat=1)
    for name, syn, obj in designs():
        rows[name] = time_design(syn, obj)
        r = rows[name]
        print(f"{name:<24} total/solver = {r['ratio']:5.2f}  cvxpy solve/solver = "
              f"{r['problem_solve_s'] / r['solver_s']:5.2f}  certify/total = "
              f"{r['certify_s'] / r['total_s']:.3f}  ({r['status']})")
    m = feasibility_map(args.points)
    print(f"map of {m['points']} points: {m['certified']} certified; total / solver time of "
          f"the feasible points = {m['ratio_feasible_solver']:.2f} (infeasible points add "
          "their canonicalisation and solver time to the total only)")
    pm = parametric_map(args.points)
    print(f"map of {pm['points']} points built once with Parameters: {pm['certified']} "
          f"certified, {pm['infeasible']} infeasible; total / solver time = "
          f"{pm['ratio_total_solver']:.2f} (goal <= 2)")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"designs": rows, "map": m, "parametric_map": pm},
                              indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
