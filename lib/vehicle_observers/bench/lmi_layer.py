"""Speed of the observer-synthesis layer (:mod:`vehicle_observers.design.synthesis`): solver
time against total time per design, and a feasibility map.

    python -m vehicle_observers.bench.lmi_layer [--points N] [--repeat R]
        [--out build/timings/lmi_layer.json]

For each single design: ``total`` (building the LMIs, cvxpy's canonicalisation, the solver, the data
certificate), ``solver`` (Clarabel's own time, ``LMISolution.solver_seconds``),
``problem_solve`` (cvxpy's ``Problem.solve``: canonicalisation + solver) and
``certify`` (the data certificate alone), reported as the ratio total / solver.
For each bisection (:meth:`~vehicle_observers.design.synthesis.ObserverSynthesis.maximise_decay`,
optimum, back-off and certificates): total / solver before (``compiled=False``: a problem
posed and canonicalised by cvxpy at every step) and after (``compiled=True``: one problem
compiled once with the decay rate as a Parameter), the solver's time being the wall time
inside every Clarabel ``solve`` call of the bisection, infeasible steps and the backed-off
solve included, and the two optima compared.
The disk-radius bisections of notebook 04 (Ichalal 2011, LMIs (23) + (35)-(36) on the
bicycle's Jacobian TS vertices, one bisection per half-plane ``a`` of the notebook's region
sweep, in the bracket the sweep's grid gives, to 0.1 1/s;
:func:`~vehicle_observers.observers.dmvt.min_feasible_radius`): total / solver and total
time before (``compiled=False``) and after (``compiled=True``: the radius a Parameter of one
compiled problem per bisection), the radii compared (``--dmvt-rows`` half-plane values of
the grid, default all; 0 skips them).
The map solves ``Decay(alpha) + InRegion(disk(R))`` on a grid of ``N`` points (default 1000)
three times: one :class:`ObserverSynthesis` per point (each canonicalised by cvxpy); built
once with cvxpy Parameters and solved by ``Problem.solve`` per point, each point certified
alone (the reference); and compiled once
(:func:`~vehicle_observers.design.synthesis.decay_disk_map`: the solver's data affine in the
parameters, the Clarabel solver updated in place, every point certified from the data in one
batched call). It reports, for each, the ratio total / solver, the time per point, the
split of the compiled map's time (build once, substitute + solve + recover, certify) and the
speed-up of the compiled map over the reference, measured in the same process. The solver's
time of the reference is Clarabel's own ``solve_time`` summed over the points (a new solver
per point: its median over the points is within about 10 % of the wall time of the call); that of the
compiled map is the wall time inside Clarabel's ``solve`` calls (the goal <= 2 is read on
it), because with a solver updated in place Clarabel's reported ``solve_time`` exceeds the
wall time of its own call (by 20 % up to several times in the runs measured): it is printed beside
it, not used. Only ratios and
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
from vehicle_observers.design.synthesis import (
    ObserverSynthesis,
    decay_disk_map,
    decay_disk_problem,
)
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


class _ClarabelClock:
    """While active, every Clarabel solver (built by cvxpy's ``Problem.solve`` or by
    :class:`~vehicle_observers.design.synthesis.CompiledLMI`) is wrapped so that the calls
    of its ``solve``, the wall time inside them and Clarabel's own ``solve_time`` are summed:
    the solver's time of a whole optimisation, infeasible steps included."""

    def __enter__(self):
        import clarabel

        self.calls, self.wall_s, self.own_s = 0, 0.0, 0.0
        self._mod, self._real = clarabel, clarabel.DefaultSolver
        clock = self

        class Timed:
            def __init__(self, *a, **k):
                self._s = clock._real(*a, **k)

            def solve(self):
                t0 = time.perf_counter()
                res = self._s.solve()
                clock.wall_s += time.perf_counter() - t0
                clock.own_s += float(res.solve_time)
                clock.calls += 1
                return res

            def __getattr__(self, name):
                return getattr(self._s, name)

        clarabel.DefaultSolver = Timed
        return self

    def __exit__(self, *exc):
        self._mod.DefaultSolver = self._real
        return False


def bisection_designs():
    """``(name, synthesis, hi)`` of the timed :meth:`ObserverSynthesis.maximise_decay`
    calls (bisection to ``tol = 1e-3`` on ``[0, hi]``)."""
    msd, rnd = msd_system(), random_system()
    Ad = [np.array([[0.9, 0.2], [-0.1, 0.8]]), np.array([[0.7, 0.3], [0.0, 0.95]])]
    dsys = PolytopicSystem(Ad, [[1.0, 0.0]], time="discrete", dt=0.1, name="discrete 2x2")
    return [
        ("msd max decay + disk", ObserverSynthesis(msd, [Decay(), InRegion(disk(20.0))]), 40.0),
        ("random 8x4 max decay + disk",
         ObserverSynthesis(rnd, [Decay(), InRegion(disk(20.0))]), 40.0),
        ("random 8x4 PDC max decay + disk",
         ObserverSynthesis(rnd, [Decay(), InRegion(disk(20.0))], gains="pdc"), 40.0),
        ("discrete max decay", ObserverSynthesis(dsys, [Decay()]), 40.0),
    ]


def time_bisection(syn, hi: float, compiled: bool, repeat: int = 3) -> dict:
    """Best of ``repeat`` calls of ``syn.maximise_decay(hi, compiled=compiled)``: total
    time, the solver's time summed over every step and the backed-off solve (wall time inside
    Clarabel's ``solve`` and Clarabel's own ``solve_time``), the number of solver calls, the
    optimum and status."""
    best = None
    for _ in range(repeat):
        with _ClarabelClock() as clock:
            t0 = time.perf_counter()
            opt = syn.maximise_decay(hi=hi, tol=1e-3, compiled=compiled)
            total = time.perf_counter() - t0
        row = {"total_s": total, "solver_wall_s": clock.wall_s, "solver_s": clock.own_s,
               "solver_calls": clock.calls, "optimum": opt.optimum, "status": opt.status}
        if best is None or total < best["total_s"]:
            best = row
    best["ratio"] = best["total_s"] / best["solver_wall_s"]
    return best


#: notebook 04's full-mode region sweep: half-plane ``a`` and disk radius ``R`` grids [1/s],
#: and the tolerance of its radius bisections [1/s]
NB04_A = (0.0, 2.0, 4.0, 6.0, 8.0)
NB04_R = (4.0, 6.0, 8.0, 10.0, 15.0, 20.0)
NB04_TOL = 0.1


def nb04_problem():
    """Notebook 04's LMI data: the Jacobian TS vertices (34) of the bicycle (25) with law (27)
    from ``x(0) = 0`` over 20 s at 1 ms (``BicycleParams()`` holds Ichalal 2011's constants,
    Appendix A), (q, 4, 4), and the output matrix (28) (2, 4)."""
    from vehicle_observers.models import bicycle as b
    from vehicle_observers.models.ts import jacobian_ts_from_samples

    bp = b.BicycleParams()
    t = np.arange(0.0, 20.0, 1e-3)
    X, U = b.simulate(bp, t)
    jts = jacobian_ts_from_samples(b.jacobian(X, U, bp), names=["xi1", "xi2"])
    return jts.vertices, np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])


def time_disk_bisections(rows: int = len(NB04_A), repeat: int = 3) -> dict:
    """Notebook 04's radius bisections (one per bracket of its region sweep on the first
    ``rows`` half-plane values; the sweep itself is not timed), best of ``repeat`` runs per
    path: ``before`` (``compiled=False``) and ``after`` (``compiled=True``), each with total
    and solver time (wall inside Clarabel's ``solve``), solver calls and the radii."""
    from vehicle_observers.observers import dmvt

    V, C = nb04_problem()
    brackets = dmvt.sweep_brackets(dmvt.region_sweep(V, C, NB04_A[:rows], NB04_R))
    out = {"brackets": [list(b) for b in brackets]}
    for key, compiled in (("before", False), ("after", True)):
        best = None
        for _ in range(repeat):
            with _ClarabelClock() as clock:
                t0 = time.perf_counter()
                radii = [dmvt.min_feasible_radius(V, C, a, lo, hi, tol=NB04_TOL,
                                                  check_ends=False, compiled=compiled)
                         for a, lo, hi in brackets]
                total = time.perf_counter() - t0
            row = {"total_s": total, "solver_wall_s": clock.wall_s, "solver_s": clock.own_s,
                   "solver_calls": clock.calls, "radii": radii}
            if best is None or total < best["total_s"]:
                best = row
        best["ratio"] = best["total_s"] / best["solver_wall_s"]
        out[key] = best
    return out


def feasibility_map(points: int = 1000) -> dict:
    alphas, radii = _grid(points)
    na, nr = alphas.size, radii.size
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


def _grid(points: int):
    na = max(2, int(round(np.sqrt(points * 1.6))))
    nr = max(2, points // na)
    return np.linspace(0.2, 6.0, na), np.linspace(4.0, 30.0, nr)


def parametric_map_reference(points: int = 1000) -> dict:
    """Reference: the map's problem built once with cvxpy Parameters
    (:func:`~vehicle_observers.design.synthesis.decay_disk_problem`) and solved by
    ``Problem.solve`` at each point (cvxpy substitutes the parameters into its stored
    tensor, re-formats the cones, builds a new Clarabel solver and recovers primal and dual
    values), each point certified alone by :func:`certify_observer`."""
    import cvxpy as cp

    alphas, radii = _grid(points)
    msd = msd_system()
    t0 = time.perf_counter()
    prob, a_par, r_par, P, K = decay_disk_problem(msd)
    solver, certified, infeasible = 0.0, 0, 0
    for a in alphas:
        for R in radii:
            a_par.value, r_par.value = float(a), float(R)
            try:
                prob.solve(solver="CLARABEL")
            except cp.error.SolverError:
                infeasible += 1
                continue
            solver += float(prob.solver_stats.solve_time or 0.0)
            if P.value is None or prob.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
                infeasible += 1
                continue
            syn = ObserverSynthesis(msd, [Decay(float(a)), InRegion(disk(float(R)))])
            L = np.linalg.solve(P.value, K.value)[None]
            certified += certify_observer(syn, P.value, L).status == "certified"
    total = time.perf_counter() - t0
    return {"points": int(alphas.size * radii.size), "certified": certified,
            "infeasible": infeasible, "total_s": total, "solver_s": solver,
            "ratio_total_solver": total / solver}


def parametric_map(points: int = 1000) -> dict:
    """The same map through :func:`~vehicle_observers.design.synthesis.decay_disk_map`: the
    problem compiled once (:class:`~vehicle_observers.design.synthesis.CompiledLMI`), each
    point substituting numbers into the solver's data, all points certified from the data
    in one batched call; with the split of the total into building, solving (solver
    included) and certifying."""
    alphas, radii = _grid(points)
    m = decay_disk_map(msd_system(), alphas, radii)
    st = m["status"]
    return {"points": int(st.size), "certified": int((st == "certified").sum()),
            "infeasible": int((st == "infeasible").sum()), "total_s": m["total_s"],
            "solver_s": m["solver_s"], "solver_wall_s": m["solver_wall_s"],
            "build_s": m["build_s"], "solve_s": m["solve_s"],
            "certify_s": m["certify_s"], "ratio_total_solver": m["total_s"] / m["solver_s"],
            "ratio_total_solver_wall": m["total_s"] / m["solver_wall_s"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m vehicle_observers.bench.lmi_layer")
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--out", default="build/timings/lmi_layer.json")
    ap.add_argument("--repeat", type=int, default=3,
                    help="timed runs of each design and bisection (the fastest is kept)")
    ap.add_argument("--dmvt-rows", type=int, default=len(NB04_A),
                    help="half-plane values of notebook 04's sweep whose radius bisections "
                         f"are timed (0..{len(NB04_A)}; 0: none)")
    args = ap.parse_args(argv)
    if not 0 <= args.dmvt_rows <= len(NB04_A):
        print(f"--dmvt-rows must be in 0..{len(NB04_A)}", file=sys.stderr)
        return 2
    if args.points < 4:
        print("--points must be >= 4", file=sys.stderr)
        return 2
    if args.repeat < 1:
        print("--repeat must be >= 1", file=sys.stderr)
        return 2
    rows = {}
    for _name, syn, obj in designs()[:1]:        # warm-up: imports and first canonicalisation
        time_design(syn, obj, repeat=1)
    for name, syn, obj in designs():
        rows[name] = time_design(syn, obj, args.repeat)
        r = rows[name]
        print(f"{name:<24} total/solver = {r['ratio']:5.2f}  cvxpy solve/solver = "
              f"{r['problem_solve_s'] / r['solver_s']:5.2f}  certify/total = "
              f"{r['certify_s'] / r['total_s']:.3f}  ({r['status']})")
    bis = {}
    for name, syn, hi in bisection_designs():
        before = time_bisection(syn, hi, False, args.repeat)
        after = time_bisection(syn, hi, True, args.repeat)
        bis[name] = {"before": before, "after": after}
        same = "same optimum" if before["optimum"] == after["optimum"] else \
            f"optimum {before['optimum']:.6g} -> {after['optimum']:.6g}"
        print(f"{name:<32} maximise_decay total/solver: posed per step {before['ratio']:5.2f}"
              f" -> compiled once {after['ratio']:5.2f} ({before['solver_calls']} solver "
              f"calls; {same}, {after['status']}; before / after total time = "
              f"{before['total_s'] / after['total_s']:.2f})")
    dm = time_disk_bisections(args.dmvt_rows, args.repeat) if args.dmvt_rows else None
    if dm is not None:
        b4, a4 = dm["before"], dm["after"]
        same = "same radii" if b4["radii"] == a4["radii"] else \
            f"radii {b4['radii']} -> {a4['radii']}"
        print(f"04 disk bisections ({len(dm['brackets'])}, {b4['solver_calls']} solver calls):"
              f" total/solver posed per step {b4['ratio']:5.2f} -> compiled once "
              f"{a4['ratio']:5.2f}; before / after total time = "
              f"{b4['total_s'] / a4['total_s']:.2f}, solver time = "
              f"{b4['solver_wall_s'] / a4['solver_wall_s']:.2f} ({same})")
    m = feasibility_map(args.points)
    print(f"map of {m['points']} points: {m['certified']} certified; total / solver time of "
          f"the feasible points = {m['ratio_feasible_solver']:.2f} (infeasible points add "
          "their canonicalisation and solver time to the total only)")
    ref = parametric_map_reference(args.points)
    pm = parametric_map(args.points)
    n = pm["points"]
    print(f"map of {ref['points']} points, Parameters + Problem.solve per point (reference): "
          f"{ref['certified']} certified, {ref['infeasible']} infeasible; total / solver "
          f"time = {ref['ratio_total_solver']:.2f}; {1e3 * ref['total_s'] / n:.2f} ms per "
          "point")
    print(f"map of {n} points, compiled once (decay_disk_map): {pm['certified']} certified, "
          f"{pm['infeasible']} infeasible; total / solver time (wall inside Clarabel's solve "
          f"calls) = {pm['ratio_total_solver_wall']:.2f} (goal <= 2; "
          f"{pm['ratio_total_solver']:.2f} against Clarabel's reported solve_time); "
          f"{1e3 * pm['total_s'] / n:.2f} ms per point, of which solver (wall) "
          f"{1e3 * pm['solver_wall_s'] / n:.2f}, substitute + solve + "
          f"recover {1e3 * pm['solve_s'] / n:.2f}, certify {1e3 * pm['certify_s'] / n:.2f}, "
          f"build once {1e3 * pm['build_s']:.0f} ms in all; reference / compiled total time "
          f"= {ref['total_s'] / pm['total_s']:.2f}")
    if (ref["certified"], ref["infeasible"]) != (pm["certified"], pm["infeasible"]):
        print("the two maps disagree on the counts", file=sys.stderr)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"designs": rows, "maximise_decay": bis, "disk_bisection_04": dm,
                               "map": m,
                               "parametric_map_reference": ref, "parametric_map": pm},
                              indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
