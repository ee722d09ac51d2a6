"""Constants of Rabhi, Imine, M'Sirdi, Delanne, "Observers With Unknown Inputs to Estimate
Contact Forces and Road Profile", AVCS 2004 (hal-01967644).

The paper prints **no numerical values** (no vehicle constants, gains, step size or
error figures); what it prints is structure: dimensions of the state-space blocks of (9)
and (26)-(30), recorded here; ``tests/papers/test_rabhi2004.py`` checks our matrices against
independent computations (the planar right-hand side, the relaxation model (8), rigid heave
under a uniform road, the warp equilibrium with zero paper outputs).

Sign slip in the printed (18) and (22): with ``theta~ = theta - theta^``,
``Psi(X) theta - Psi(X^) theta^ = Psi(X^) theta~ + Delta Psi theta``, so
``x~4' = -A x~4 + Psi(X^) theta~`` (the paper prints ``- Psi theta~``) and
``theta^' = P Psi(X^)' x~4`` cancels the cross term of ``V4'``. The observer uses this
stabilising sign; the printed sign amounts to ``P -> -P`` and drives theta^ to its
projection bounds (notebook 05, Exercise 3). The numerical constants we use instead (vehicle,
tyres, suspension, gains, steps) are chosen in :mod:`..planar`, :mod:`..fullcar`,
:mod:`..smo` and listed with their sources there.
"""

from vehicle_observers.models.fullcar import FullCarParams
from vehicle_observers.models.planar import PlanarParams
from vehicle_observers.observers.sliding_mode import ForceObserverGains, RoadObserverGains

# --- printed structure, Part A (eq. (9)) ---
n_x1 = 3          # (x, y, psi)
n_x2 = 3          # (V_x, V_y, psi_dot)
n_x3 = 2          # (omega_f, omega_r)
n_x4 = 4          # (F_xf, F_xr, F_yf, F_yr)
omega_shape = (3, 4)   # Omega(u)
H_shape = (2, 4)       # H
n_theta = 8            # reconstructed (R-A5): (1/sigma_i, F0_i/sigma_i), i = 1..4

# --- printed structure, Part B (eqs. (24)-(30)) ---
n_dof = 7              # q = [z1, z2, z3, z4, z, theta, phi] (printed "R^8", R-B1)
n_wheels = 4
K11_shape = (4, 4)
K12_shape = (4, 3)
K21_shape = (3, 4)
K22_shape = (3, 3)
A11_shape = (4, 4)     # diag(k_r1, k_r2, k_f1, k_f2): rear wheels first (26)
B11_shape = (4, 4)
wheel_order = ("rear 1", "rear 2", "front 1", "front 2")

# --- our choices (not from the paper) ---
planar = PlanarParams()
fullcar = FullCarParams()
force_gains = ForceObserverGains(mode=1)
road_gains = RoadObserverGains()
dt_force = 5e-4        # s, Part A measurement/observer step (explicit Euler)
dt_road = 2e-4         # s, Part B step
speed_iso = 20.0       # m/s on the ISO roads
speed_belgian = 8.0    # m/s (about 30 km/h) on the Belgian block
contact_length = 0.1   # m, tyre-enveloping window on the Belgian block


# ----------------------------------------------------------------- scenario runners -----
# (used by notebook 05 and its tests; each returns truth, estimates and metrics)
import numpy as np  # noqa: E402
from vehicle_observers.core.metrics import rmse as _rmse  # noqa: E402
from vehicle_observers.data import road as _road  # noqa: E402
from vehicle_observers.models import fullcar as _fc  # noqa: E402
from vehicle_observers.models import planar as _pl  # noqa: E402
from vehicle_observers.observers import sliding_mode as _smo  # noqa: E402

FORCE_NAMES = ("Fxf", "Fxr", "Fyf", "Fyr")
X2_NAMES = ("vx", "vy", "r")
X3_NAMES = ("omega_f", "omega_r")
x2_err0 = np.array([1.0, 0.5, 0.1])   # initial observer errors (m/s, m/s, rad/s)
x3_err0 = np.array([5.0, 5.0])        # rad/s
sensor_noise = (0.02, 0.02, 0.002, 0.05, 0.05)  # std of [vx, vy, r, w_f, w_r] (noisy case)


def part_a_truth(T: float = 20.0, dt: float = dt_force, p: PlanarParams = planar):
    man = _pl.paper_manoeuvre(T, dt)
    Xs = _pl.simulate(_pl.free_rolling_state(man.v0, p), man.U, dt, p)
    return man, Xs


def part_a_truth_mu_step(T: float = 20.0, mu_after: float = 0.5, t_step: float | None = None,
                         dt: float = dt_force, p: PlanarParams = planar):
    """Part A truth with a road-friction step ``mu: p.mu -> mu_after`` at ``t_step`` s
    (default ``T/2``): the same manoeuvre, simulated in two pieces (the state is continuous
    across the step). Returns ``(man, Xs)`` like :func:`part_a_truth`."""
    man = _pl.paper_manoeuvre(T, dt)
    k = int(round((T / 2 if t_step is None else t_step) / dt))
    if not 0 < k < len(man.t) - 1:
        raise ValueError(f"t_step must lie inside (0, {T}) s, got {t_step}")
    X1 = _pl.simulate(_pl.free_rolling_state(man.v0, p), man.U[:k + 1], dt, p)
    X2 = _pl.simulate(X1[-1], man.U[k:], dt, p.with_(mu=mu_after))
    return man, np.vstack([X1[:-1], X2])


#: the printed adaptation (20)-(22) adapts all 8 entries of theta; the default
#: ``force_gains`` adapts only the F0/sigma entries
P_FULL = (5.0,) * 8


def part_a_run(man, Xs, gains=None, errors=None, noise=None, seed: int = 0,
               t_skip: float = 1.0, p: PlanarParams = planar) -> dict:
    """Run observer (10) on a truth run; metrics after ``t_skip`` s (reaching excluded)."""
    gains = force_gains if gains is None else gains
    model = _smo.ForceObserverModel.from_params(p, **(errors or {}))
    Y = _smo.measurements_from_truth(Xs, noise, seed)
    res = _smo.run_force_observer(man.t, Y, man.U, model, gains,
                                  x2_0=Xs[0, 3:6] + x2_err0, x3_0=Xs[0, 6:8] + x3_err0)
    t = man.t
    dt = t[1] - t[0]
    F = Xs[:, 8:12]
    m = t >= t_skip
    out = {"t": t, "Y": Y, "F": F, "res": res, "model": model}
    peak = np.max(np.abs(F), axis=0)
    out.update(_smo.force_errors(t, res.x4, F, peak, t_skip, FORCE_NAMES))
    for i, nm in enumerate(FORCE_NAMES):
        out[f"peak_{nm}"] = float(peak[i])
        out[f"chatter_{nm}"] = float(np.std(np.diff(res.x4[m, i])))
    # finite-time reaching of the sliding surfaces x~2 = 0, x~3 = 0
    lam = np.concatenate([gains.lam2, gains.lam3])
    phi = np.concatenate([gains.phi2, gains.phi3])
    err = np.column_stack([Xs[:, 3:6] - res.x2, Xs[:, 6:8] - res.x3])
    band = np.where(gains.mode == _smo.SAT, 2 * phi, 2 * lam * dt)
    if noise is not None:
        band = band + 3 * np.asarray(noise)
    lhs = _smo.omega_x4_bound(man.U[:, 0], F - res.x4, model)
    for j, nm in enumerate(X2_NAMES + X3_NAMES):
        tr = _smo.reaching_time(t, err[:, j], band[j])
        out[f"t_reach_{nm}"] = tr
        e0 = abs(err[0, j])
        k = max(int(np.searchsorted(t, tr if np.isfinite(tr) else t[-1])), 1)
        d = float(lhs[:k, j].max())
        out[f"t_bound_{nm}"] = e0 / (lam[j] - d) if lam[j] > d else float("inf")
        out[f"t_nominal_{nm}"] = e0 / lam[j]
        out[f"gain_margin_{nm}"] = float(np.min(lam[j] - lhs[m, j]))
    return out


def part_b_road(name: str, T: float, seed: int = 0):
    """``(road, speed, contact_length)`` for 'B', 'C', 'D' (ISO) or 'belgian'."""
    if name == "belgian":
        rd = _road.mirror_extend(_road.load_belgian_block(), speed_belgian * T + 10)
        return rd, speed_belgian, contact_length
    return _road.iso8608_road(name, speed_iso * T + 10, seed=seed), speed_iso, 0.0


_TRUTH_CACHE: dict = {}


def part_b_truth(name: str, T: float, seed: int = 0, dt: float = dt_road,
                 p: FullCarParams = fullcar):
    """Full-car truth on road ``name`` (cached per arguments, arrays read-only):
    ``(road, speed, t, U, X, Y)``."""
    key = (name, float(T), int(seed), float(dt), p)
    if key not in _TRUTH_CACHE:
        rd, V, cl = part_b_road(name, T, seed)
        t = np.arange(int(round(T / dt))) * dt
        U = rd.wheel_inputs(t, V, p.a + p.b, contact_length=cl)
        X = _fc.simulate(U, dt, p)
        Y = _fc.outputs(X, None, None, p)
        for a in (t, U, X, Y):
            a.setflags(write=False)
        if len(_TRUTH_CACHE) > 8:
            _TRUTH_CACHE.clear()
        _TRUTH_CACHE[key] = (rd, V, t, U, X, Y)
    return _TRUTH_CACHE[key]


def part_b_run(name: str, T: float = 20.0, gains=None, errors=None, seed: int = 0,
               t_skip: float = 1.0, dt: float = dt_road, z_err0: float = 5e-3,
               noise_z: float = 0.0, p: FullCarParams = fullcar) -> dict:
    """Simulate the full car on road ``name`` and run the UIO; metrics after ``t_skip``."""
    gains = road_gains if gains is None else gains
    rd, V, t, U, X, Y = part_b_truth(name, T, seed, dt, p)
    if noise_z > 0:
        Y = Y.copy()
        Y[:, :4] += np.random.default_rng(seed + 1).normal(scale=noise_z, size=(len(t), 4))
    obs_p = p.scaled(**(errors or {}))
    res = _smo.run_road_observer(t, Y, obs_p, gains, z0=Y[0, :4] + z_err0)
    m = t >= t_skip
    out = {"t": t, "U": U, "X": X, "Y": Y, "res": res, "road": rd, "speed": V}
    for i in range(4):
        rms = float(np.std(U[m, i]))
        e = _rmse(res.U[m, i], U[m, i])
        out[f"U_rmse_mm_{i + 1}"] = 1e3 * e
        out[f"U_rmse_pct_{i + 1}"] = 100 * e / rms
        out[f"U_rms_mm_{i + 1}"] = 1e3 * rms
        out[f"v_rmse_{i + 1}"] = _rmse(res.v[m, i], X[m, 7 + i])
        dtt = t[1] - t[0]
        band = 2 * gains.phi1 if gains.mode == _smo.SAT else 2 * gains.h11 * dtt
        out[f"t_reach_z{i + 1}"] = _smo.reaching_time(t, Y[:, i] - res.z[:, i], band)
    out["t_bound_z"] = z_err0 / gains.h11
    out["x22_rmse"] = [_rmse(res.x22[m, j], X[m, 11 + j]) for j in range(3)]
    out["U_rmse_mm_mean"] = float(np.mean([out[f"U_rmse_mm_{i + 1}"] for i in range(4)]))
    out["U_rmse_pct_mean"] = float(np.mean([out[f"U_rmse_pct_{i + 1}"] for i in range(4)]))
    return out


def part_b_paper_outputs(name: str, T: float, seed: int = 0, dt: float = dt_road,
                         p: FullCarParams = fullcar, deflection_wheel: int | None = None):
    """The paper's outputs (29) on road ``name``: ``(t, U, X, Yp, defl)`` with ``Yp`` (N, 10)
    ``[x12, x22, x31]`` (wheel accelerations from the model with the road slope of each
    sample interval, the truth's first-order hold) and ``defl`` (N,) the suspension
    deflection ``S_i x12 - x11_i`` of wheel ``deflection_wheel`` (``None`` without it).
    No column of ``Yp`` is a wheel displacement."""
    _, _, t, U, X, _ = part_b_truth(name, T, seed, dt, p)
    Ud = np.empty_like(U)
    Ud[:-1] = np.diff(U, axis=0) / dt
    Ud[-1] = Ud[-2]
    Yp = _fc.outputs(X, U, Ud, p, paper=True)
    defl = None
    if deflection_wheel is not None:
        defl = X[:, 4:7] @ p.S[deflection_wheel] - X[:, deflection_wheel]
    return t, U, X, Yp, defl


def part_b_paper_run(name: str, T: float = 20.0, deflection_wheel: int | None = None,
                     errors=None, seed: int = 0, t_skip: float = 1.0, dt: float = dt_road,
                     p: FullCarParams = fullcar) -> dict:
    """Observer on the paper's outputs (29) (``deflection_wheel`` adds one suspension-
    deflection sensor) on road ``name``; metrics after ``t_skip``: road RMSE per wheel raw
    and modulo the road patterns of the warp modes
    (:func:`.observers.sliding_mode.road_lost_subspace`, per sample), wheel-displacement
    RMSE [mm] raw and modulo the warp wheel patterns, the RMS road error removed by the
    modulo (``U_lost_rms_mm``), body-rate RMSE."""
    t, U, X, Yp, defl = part_b_paper_outputs(name, T, seed, dt, p, deflection_wheel)
    obs_p = p.scaled(**(errors or {}))
    design = _smo.paper_output_design(obs_p, deflection_wheel)
    res = _smo.run_paper_output_observer(t, Yp, obs_p, design, deflection=defl)
    m = t >= t_skip
    Qu = _smo.road_lost_subspace(obs_p, design)
    Qz = np.linalg.qr(design.V[0:4])[0] if design.V.shape[1] else np.zeros((4, 0))
    EU = (res.U - U)[m]
    EUm = _smo.modulo_subspace(EU, Qu)
    Ez = (res.z - X[:, 0:4])[m]
    Ezm = _smo.modulo_subspace(Ez, Qz)
    out = {"t": t, "U": U, "X": X, "Yp": Yp, "res": res, "design": design,
           "inputs": ("x12", "x22", "x31") + (() if deflection_wheel is None else ("deflection",))}
    for i in range(4):
        rms = float(np.std(U[m, i]))
        out[f"U_rms_mm_{i + 1}"] = 1e3 * rms
        out[f"U_rmse_pct_{i + 1}"] = 100 * float(np.sqrt(np.mean(EU[:, i] ** 2))) / rms
        out[f"U_mod_rmse_pct_{i + 1}"] = 100 * float(np.sqrt(np.mean(EUm[:, i] ** 2))) / rms
        out[f"z_rmse_mm_{i + 1}"] = 1e3 * float(np.sqrt(np.mean(Ez[:, i] ** 2)))
        out[f"z_mod_rmse_mm_{i + 1}"] = 1e3 * float(np.sqrt(np.mean(Ezm[:, i] ** 2)))
    for key in ("U_rmse_pct", "U_mod_rmse_pct", "z_rmse_mm", "z_mod_rmse_mm"):
        out[f"{key}_mean"] = float(np.mean([out[f"{key}_{i + 1}"] for i in range(4)]))
    out["z_rms_mm_mean"] = 1e3 * float(np.mean(np.std(X[m, 0:4], axis=0)))
    out["U_lost_rms_mm"] = 1e3 * float(np.sqrt(np.mean((EU - EUm) ** 2)))
    out["x22_rmse"] = [_rmse(res.x22[m, j], X[m, 11 + j]) for j in range(3)]
    out["n_unobservable"] = int(design.V.shape[1])
    out["margin"] = design.margin
    return out
