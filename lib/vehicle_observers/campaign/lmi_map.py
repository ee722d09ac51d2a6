"""Feasibility map of the interval design (Ifqir 2017 Theorem 2) over stiffness box and speed range.

:func:`vehicle_observers.observers.interval.design_theorem2` poses its LMIs with numeric
constants, so every design is canonicalised anew by cvxpy. Here the *same* LMIs (17)-(21),
with the same options as the registry's interval observers
(:func:`vehicle_observers.estimation.adapters.interval_design`: three speed bands of equal
``v_max / v_min`` ratio, ``eps_decay = 1``, ``p_min = 1``, ``lmi_eps = 1e-2``, Metzler
margin ``1e-3``, ``epsilon`` of (20) = the sample rate, ``phi`` from ``|dv_x/dt| <=
accel_max``, one ``gamma_i`` per mode, minimise ``sum_i gamma_i``) are written once with
cvxpy ``Parameter`` s for every number that changes across the map (the element-wise bounds
``A_i^{j-}``, ``A_i^{j+}``, ``phi``, ``C`` (``C_z = C T^-1`` of the change of coordinates
``z = T(kappa) x``, :mod:`vehicle_observers.observers.interval_coordinates`) and
``epsilon``): the problem is DPP, so it is compiled once per process
(:class:`~vehicle_observers.design.synthesis.CompiledLMI`: the solver's data affine in the
parameters, found through cvxpy) and each map point only substitutes numbers. The problem
is built inside the process that solves (a Dask worker), never shipped.

Each point is decided in this order:

1. the structural checks of the design (Assumption 1, the Metzler entries out of the gain's
   reach, the diagonal shift; ``check_detectable`` / ``check_metzler_feasible`` /
   ``check_diagonal_shift`` of the model): exact, no solver -> ``infeasible``;
2. the solver: infeasible -> ``infeasible``;
3. the solution is certified independently (:func:`vehicle_observers.design.lmi.check_matrix`
   on every LMI recomputed from the numbers, the Metzler margins of ``A^- - L C`` with
   ``L = P^-1 W``, the diagonal part of (20)): every margin clear of round-off ->
   ``feasible``; a margin within :data:`ROUNDOFF` (relative) of zero, or a solution that
   fails the certificate -> ``inconclusive`` (never counted as feasible).
"""

from __future__ import annotations

import time

import numpy as np

from vehicle_observers.core.errors import InfeasibleDesign
from vehicle_observers.design.synthesis import CompiledLMI

N_MODES = 3
EPS_DECAY = 1.0
P_MIN = 1.0
LMI_EPS = 1e-2
METZLER_TOL = 1e-3
#: a certified margin within this relative distance of zero is round-off: inconclusive
ROUNDOFF = 1e-9
STATUSES = ("feasible", "infeasible", "inconclusive")


def schema():
    import pyarrow as pa

    return pa.schema([("point", pa.int64()), ("batch", pa.int64()), ("car", pa.string()),
                      ("stiffness_rel", pa.float64()), ("vx_min", pa.float64()),
                      ("vx_max", pa.float64()), ("kappa", pa.float64()),
                      ("rate_hz", pa.float64()), ("status", pa.string()),
                      ("reason", pa.string()), ("solver_status", pa.string()),
                      ("gamma_sum", pa.float64()), ("gamma_max", pa.float64()),
                      ("lmi_margin", pa.float64()), ("lmi_relative_margin", pa.float64()),
                      ("metzler_margin", pa.float64()), ("diag_margin", pa.float64()),
                      ("metzler_bound", pa.float64())])


def _sym(X):
    """Symmetric part, as :class:`vehicle_observers.design.lmi.LMIDesign` poses every LMI."""
    return (X + X.T) / 2


class ParametricTheorem2:
    """Theorem 2 (17)-(21) for ``N_MODES`` modes with cvxpy Parameters (module docstring).

    ``solve(model, epsilon)`` -> dict of the solution and its status; ``certify(model,
    epsilon, sol)`` -> the independent margins."""

    def __init__(self, K: int = N_MODES):
        import cvxpy as cp

        self.K = K
        n = 2
        # every A_i^{j-} (A_i^{j+}) side by side in one parameter: one value to set per point
        self.Alo_all = cp.Parameter((n, n * 4 * K), name="A_lo")
        self.Ahi_all = cp.Parameter((n, n * 4 * K), name="A_hi")
        blk = lambda A, i, j: A[:, n * (4 * i + j): n * (4 * i + j + 1)]
        self.Alo = [[blk(self.Alo_all, i, j) for j in range(4)] for i in range(K)]
        self.Ahi = [[blk(self.Ahi_all, i, j) for j in range(4)] for i in range(K)]
        self.phi = cp.Parameter((K, 4), nonneg=True, name="phi")
        self.C = cp.Parameter((1, n), name="C")
        self.eps = cp.Parameter(nonneg=True, name="epsilon")
        self.d = [[cp.Variable(n, name=f"P{i}{j}") for j in range(4)] for i in range(K)]
        self.W = [[cp.Variable((n, 1), name=f"W{i}{j}") for j in range(4)] for i in range(K)]
        self.M = [cp.Variable((n, n), symmetric=True, name=f"M{i}") for i in range(K)]
        self.g = [cp.Variable(nonneg=True, name=f"gamma{i}") for i in range(K)]
        I = np.eye(n)
        cons = []
        for i in range(K):
            P = [cp.diag(self.d[i][j]) for j in range(4)]
            for j in range(4):
                cons.append(self.d[i][j] >= P_MIN + LMI_EPS)    # (17): P diagonal, so linear
                cons.append(_sym(P[j] + self.M[i]) >> LMI_EPS * I)                     # (18)
                Wc = self.W[i][j] @ self.C
                S = (self.Ahi[i][j].T @ P[j] + P[j] @ self.Ahi[i][j] - Wc.T - Wc
                     + EPS_DECAY * P[j])
                for k in range(4):
                    S = S + self.phi[i, k] * (P[k] + self.M[i])
                B = cp.bmat([[S, P[j]], [P[j], -self.g[i] * I]])
                cons.append(_sym(B) << -LMI_EPS * np.eye(2 * n))                       # (19)
                X = P[j] @ self.Alo[i][j] - Wc                                          # (20)
                cons.append(cp.hstack([X[0, 1], X[1, 0]]) >= METZLER_TOL)
                cons.append(cp.hstack([X[0, 0], X[1, 1]]) + self.eps
                            * cp.hstack([self.d[i][j][0], self.d[i][j][1]]) >= 0)
        self.problem = cp.Problem(cp.Minimize(sum(self.g)), cons)
        if not self.problem.is_dpp():   # pragma: no cover - a structural property, tested
            raise RuntimeError("Theorem 2 problem is not DPP")
        #: the problem compiled once (the solver's data affine in the parameters, the
        #: Clarabel solver re-used with new data: no re-allocation, no new symbolic
        #: factorisation; the interior-point iterations start afresh, so the solution is
        #: bit-identical to a new solver's; ``reuse = False`` builds a new one)
        self.compiled = CompiledLMI(
            self.problem, [self.Alo_all, self.Ahi_all, self.phi, self.C, self.eps],
            {**{f"d{i}{j}": self.d[i][j] for i in range(K) for j in range(4)},
             **{f"W{i}{j}": self.W[i][j] for i in range(K) for j in range(4)},
             **{f"M{i}": self.M[i] for i in range(K)},
             **{f"g{i}": self.g[i] for i in range(K)}})

    @property
    def reuse(self) -> bool:
        return self.compiled.reuse

    @reuse.setter
    def reuse(self, v: bool):
        self.compiled.reuse = bool(v)

    def solve(self, model, epsilon: float, phi) -> dict:
        """Substitute the point's numbers into the compiled problem and solve (Clarabel).
        Only the primal solution is recovered (the certificate does not use the duals).
        ``status`` is cvxpy's name of Clarabel's status."""
        from cvxpy.reductions.solvers.conic_solvers.clarabel_conif import CLARABEL

        side = lambda A: np.concatenate([A[i, j] for i in range(self.K) for j in range(4)], axis=1)
        t0 = time.perf_counter()
        vals, status, solver_time = self.compiled.solve(
            [side(model.A_lo), side(model.A_hi), np.asarray(phi, float),
             np.asarray(model.C, float), float(epsilon)])
        out = {"status": CLARABEL.STATUS_MAP.get(status, "solver_error"),
               "wall": time.perf_counter() - t0, "solver_time": solver_time}
        if vals is not None:
            K = self.K
            out["P"] = np.array([[vals[f"d{i}{j}"] for j in range(4)] for i in range(K)])
            out["W"] = np.array([[vals[f"W{i}{j}"] for j in range(4)] for i in range(K)])
            out["M"] = np.array([vals[f"M{i}"] for i in range(K)])
            out["gamma"] = np.array([float(vals[f"g{i}"].ravel()[0]) for i in range(K)])
        return out


def certify(model, epsilon: float, phi, sol: dict) -> dict:
    """Independent margins of a solution (module docstring, step 3): ``lmi_margin`` (min
    eigenvalue margin of (17)-(19), :func:`~vehicle_observers.design.lmi.check_matrix` on each
    family's LMIs recomputed from the numbers and stacked block-diagonally: the eigenvalues of
    a block-diagonal matrix are those of its blocks), ``lmi_relative_margin`` (each family's
    margin over its largest eigenvalue magnitude, the smallest of the three),
    ``metzler_margin`` (min off-diagonal of ``A^- - L C``) and its relative value,
    ``diag_margin`` (min of (20)'s diagonal, relative to its entries)."""
    from scipy.linalg import block_diag

    from vehicle_observers.design.lmi import check_matrix
    from vehicle_observers.observers.interval import metzler_margins

    K = model.n_modes
    I = np.eye(2)
    C = model.C
    fam = {"(17)": [], "(18)": [], "(19)": []}
    diag_rel = np.inf
    for i in range(K):
        Ps = [np.diag(sol["P"][i, j]) for j in range(4)]
        for j in range(4):
            P, W, M = Ps[j], sol["W"][i, j], sol["M"][i]
            fam["(17)"].append(P - P_MIN * I)
            fam["(18)"].append(P + M)
            Ap = model.A_hi[i, j]
            S = Ap.T @ P + P @ Ap - C.T @ W.T - W @ C + EPS_DECAY * P
            for k in range(4):
                S = S + phi[i, k] * (Ps[k] + M)
            fam["(19)"].append(np.block([[S, P], [P, -sol["gamma"][i] * I]]))
            X = P @ model.A_lo[i, j] - W @ C + epsilon * P
            dg = np.diag(X)
            scale = max(float(np.max(np.abs(P @ model.A_lo[i, j]))), float(np.max(epsilon * P)))
            diag_rel = min(diag_rel, float(dg.min()) / scale)
    checks = [check_matrix(n, block_diag(*ms), "neg" if n == "(19)" else "pos")
              for n, ms in fam.items()]
    L = np.array([[np.linalg.solve(np.diag(sol["P"][i, j]), sol["W"][i, j]) for j in range(4)]
                  for i in range(K)])
    mm = metzler_margins(model, L)
    scale_m = float(np.max(np.abs(model.A_lo - L @ C)))
    return {"lmi_margin": min(c.margin for c in checks),
            "lmi_relative_margin": min(c.relative for c in checks),
            "metzler_margin": float(mm.min()), "metzler_relative": float(mm.min()) / scale_m,
            "diag_margin": diag_rel}


_PROBLEMS: dict = {}


def problem(K: int = N_MODES) -> ParametricTheorem2:
    """The parametrised problem of this process (built and canonicalised once)."""
    if K not in _PROBLEMS:
        _PROBLEMS[K] = ParametricTheorem2(K)
    return _PROBLEMS[K]


def point_model(car: str, rel: float, vx_min: float, vx_max: float, kappa: float):
    """The switched interval model of a map point (bands as the registry's adapters)."""
    from vehicle_observers.campaign.truths import car_vehicle
    from vehicle_observers.models import uncertain_bicycle as ub
    from vehicle_observers.models.uncertain_bicycle import TransformedIntervalModel

    v = car_vehicle(car)
    p = v.params
    veh = ub.UncertainBicycle(m=p.m, I_z=p.I_z, l_f=p.a_f, l_r=p.a_r, c_f0=v.C_f, c_r0=v.C_r,
                              rel_unc=rel, name=v.name)
    bands = ub.SpeedBands(tuple(np.geomspace(vx_min, vx_max, N_MODES + 1)))
    return TransformedIntervalModel(veh, bands, kappa), veh


def solve_point(car, rel, vx_min, vx_max, kappa, rate_hz, accel_max) -> tuple[dict, dict]:
    """Decide one map point. Returns (row fields, timing ``{"wall", "solver"}`` [s])."""
    model, veh = point_model(car, rel, vx_min, vx_max, kappa)
    eps = float(rate_hz)
    row = {"status": "", "reason": "", "solver_status": "", "gamma_sum": float("nan"),
           "gamma_max": float("nan"), "lmi_margin": float("nan"),
           "lmi_relative_margin": float("nan"), "metzler_margin": float("nan"),
           "diag_margin": float("nan"), "metzler_bound": float(veh.max_metzler_uncertainty())}
    t0 = time.perf_counter()
    try:
        model.check_detectable()
        model.check_metzler_feasible()
        model.check_diagonal_shift(eps)
    except InfeasibleDesign as exc:
        row.update(status="infeasible", reason="structural: " + str(exc).splitlines()[0][:200])
        return row, {"wall": time.perf_counter() - t0, "solver": 0.0}
    phi = model.membership_rate_bounds(accel_max)
    sol = problem(model.n_modes).solve(model, eps, phi)
    row["solver_status"] = sol["status"]
    timing = {"wall": time.perf_counter() - t0, "solver": sol["solver_time"]}
    if "P" not in sol:
        row.update(status="infeasible" if "infeasible" in sol["status"] else "inconclusive",
                   reason=f"solver: {sol.get('message', sol['status'])}")
        timing["wall"] = time.perf_counter() - t0
        return row, timing
    c = certify(model, eps, phi, sol)
    row.update(gamma_sum=float(sol["gamma"].sum()), gamma_max=float(sol["gamma"].max()),
               lmi_margin=c["lmi_margin"], lmi_relative_margin=c["lmi_relative_margin"],
               metzler_margin=c["metzler_margin"], diag_margin=c["diag_margin"])
    rel_margins = (c["lmi_relative_margin"], c["metzler_relative"], c["diag_margin"])
    if min(rel_margins) > ROUNDOFF:
        row.update(status="feasible", reason="certified")
    elif min(rel_margins) >= -ROUNDOFF:
        row.update(status="inconclusive", reason=f"margin at round-off level "
                                                 f"({min(rel_margins):.2e} relative)")
    else:
        row.update(status="inconclusive", reason=f"solver {sol['status']} but the certificate "
                                                 f"fails ({min(rel_margins):.2e} relative)")
    timing["wall"] = time.perf_counter() - t0
    return row, timing


def run_lmi_batch(raw: dict, batch_id: int, start: int, stop: int, timings: list | None = None):
    """Dask task: rows of map points ``start..stop-1`` as columns (:func:`schema` order).
    ``timings`` (a list) receives ``{"wall", "solver"}`` per point (benchmarks)."""
    from vehicle_observers.campaign.tasks import spec_of

    spec = spec_of(raw)
    m = spec.doc["lmi_map"]
    rows = []
    for i in range(start, stop):
        car, rel, lo, hi, kappa = spec.lmi_points[i]
        r, tm = solve_point(car, rel, lo, hi, kappa, m["rate_hz"], m["accel_max"])
        rows.append({"point": i, "batch": int(batch_id), "car": car, "stiffness_rel": rel,
                     "vx_min": lo, "vx_max": hi, "kappa": kappa, "rate_hz": m["rate_hz"], **r})
        if timings is not None:
            timings.append(tm)
    return {n: [r[n] for r in rows] for n in schema().names}
