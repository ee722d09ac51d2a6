"""Experiments of Rabhi, Imine, M'Sirdi, Delanne (AVCS 2004) behind notebook 05: the truth
runs of the planar car (Part A) and of the full car on a road (Part B), the observers of
:mod:`vehicle_observers.observers.sliding_mode` and the EKF of
:mod:`vehicle_observers.baselines.sliding_mode_ekf` on them, and the paper's metrics
(force RMSE, reaching times, road RMSE). Each runner returns truth, estimates and metrics
in a dict; the constants (printed structure and our choices) are in :mod:`.constants`.
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.baselines import sliding_mode_ekf as sme
from vehicle_observers.core.metrics import rmse as _rmse
from vehicle_observers.data import road as _road
from vehicle_observers.models import fullcar as _fc
from vehicle_observers.models import planar as _pl
from vehicle_observers.models.fullcar import FullCarParams
from vehicle_observers.models.planar import PlanarParams
from vehicle_observers.observers import sliding_mode as _smo

from vehicle_observers_papers.rabhi_2004.constants import (
    FORCE_NAMES,
    X2_NAMES,
    X3_NAMES,
    contact_length,
    dt_force,
    dt_road,
    force_gains,
    fullcar,
    planar,
    road_gains,
    speed_belgian,
    speed_iso,
    x2_err0,
    x3_err0,
)


# ------------------------------------------------------------------ metrics --------------
def force_errors(t, F_est, F_true, peak, t_skip: float = 1.0, names=FORCE_NAMES) -> dict:
    """Force metrics shared by the SMO and the EKF baseline: for each force ``rmse_<nm>``
    [N] and ``rmse_pct_<nm>`` [% of ``peak``] over ``t >= t_skip``. t (M,), F_est,
    F_true (M, 4) [N], peak (4,) [N] (peak of the full truth run)."""
    t = np.asarray(t, dtype=float)
    m = t >= t_skip
    if not m.any():
        raise ValueError(f"no sample after t_skip = {t_skip} s")
    F_est, F_true = np.asarray(F_est, dtype=float), np.asarray(F_true, dtype=float)
    out = {}
    for i, nm in enumerate(names):
        e = _rmse(F_est[m, i], F_true[m, i])
        out[f"rmse_{nm}"] = e
        out[f"rmse_pct_{nm}"] = 100 * e / float(peak[i])
    return out


def reaching_time(t, err, band) -> float:
    """First time after which ``|err| <= band`` for good (the sliding surface is reached
    and kept); ``nan`` if it never stays inside. ``err`` (N,), ``band`` scalar."""
    e = np.abs(np.asarray(err, dtype=float))
    outside = np.flatnonzero(e > band)
    if len(outside) == 0:
        return float(t[0])
    if outside[-1] == len(e) - 1:
        return float("nan")
    return float(t[outside[-1] + 1])


# ------------------------------------------------------------------ Part A ---------------
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


def initial_estimate(Xs) -> np.ndarray:
    """Initial estimate ``[x2, x3, x4]`` (9,) of the Part A runs: the true velocities and
    wheel speeds plus the errors ``x2_err0``, ``x3_err0`` of :mod:`.constants`, zero forces."""
    return np.concatenate([Xs[0, 3:6] + x2_err0, Xs[0, 6:8] + x3_err0, np.zeros(4)])


def part_a_run(man, Xs, gains=None, errors=None, noise=None, seed: int = 0,
               t_skip: float = 1.0, p: PlanarParams = planar) -> dict:
    """Run observer (10) on a truth run; metrics after ``t_skip`` s (reaching excluded)."""
    gains = force_gains if gains is None else gains
    model = _smo.ForceObserverModel.from_params(p, **(errors or {}))
    Y = _pl.measurements(Xs, noise, seed)
    t = man.t
    dt = t[1] - t[0]
    res = _smo.ForceObserver(model, gains, dt).run(t, man.U, Y, initial_estimate(Xs))
    F = Xs[:, 8:12]
    m = t >= t_skip
    out = {"t": t, "Y": Y, "F": F, "res": res, "model": model, "gains": gains}
    peak = np.max(np.abs(F), axis=0)
    out.update(force_errors(t, res.x4, F, peak, t_skip, FORCE_NAMES))
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
        tr = reaching_time(t, err[:, j], band[j])
        out[f"t_reach_{nm}"] = tr
        e0 = abs(err[0, j])
        k = max(int(np.searchsorted(t, tr if np.isfinite(tr) else t[-1])), 1)
        d = float(lhs[:k, j].max())
        out[f"t_bound_{nm}"] = e0 / (lam[j] - d) if lam[j] > d else float("inf")
        out[f"t_nominal_{nm}"] = e0 / lam[j]
        out[f"gain_margin_{nm}"] = float(np.min(lam[j] - lhs[m, j]))
    return out


def part_a_ekf_run(man, Xs, p, sensor_std, *, errors=None, noise=None, seed: int = 0,
                   decimate: int = 1, t_skip: float = 1.0, x2_err0=None, x3_err0=None,
                   filter: str = "ekf", **kw) -> dict:
    """EKF counterpart of :func:`part_a_run`: same truth ``Xs`` (N, 12), same measurements
    (:func:`vehicle_observers.models.planar.measurements` with ``noise``, ``seed``), same
    observer-model ``errors``, the initial velocity/wheel-speed errors ``x2_err0`` (3,),
    ``x3_err0`` (2,) (the paper runs': :data:`.constants.x2_err0`, ``x3_err0``), zero initial
    forces, same metrics after ``t_skip`` (:func:`force_errors`; with ``decimate > 1``
    against the block means of the true forces, i.e. the truth at the block centres to
    O(dt^2)). ``p`` the truth :class:`~vehicle_observers.models.planar.PlanarParams`,
    ``sensor_std`` (5,) for ``R``. Returns a dict with ``res``
    (:class:`~vehicle_observers.baselines.sliding_mode_ekf.ForceEKFTrajectory`), ``Y`` (N, 5)
    the measurements, ``rmse_*``, ``rmse_pct_*`` (the cost per step is ``res.us_per_step``)."""
    if x2_err0 is None or x3_err0 is None:
        raise ValueError("part_a_ekf_run: give the initial errors x2_err0 (3,) and x3_err0 (2,) "
                         "(the paper runs': constants.x2_err0, x3_err0)")
    model = _smo.ForceObserverModel.from_params(p, **(errors or {}))
    Y = _pl.measurements(Xs, noise, seed)
    x0 = np.concatenate([Xs[0, 3:6] + np.asarray(x2_err0), Xs[0, 6:8] + np.asarray(x3_err0),
                         np.zeros(4)])
    res = sme.run_force_ekf(man.t, Y, man.U, model, sensor_std, decimate=decimate, x0=x0,
                            filter=filter, **kw)
    F = Xs[:, 8:12]
    peak = np.max(np.abs(F), axis=0)
    out = {"res": res, "Y": Y}
    out.update(force_errors(res.t, res.F, sme.block_mean(F, res.dec), peak, t_skip,
                            FORCE_NAMES))
    return out


# ------------------------------------------------------------------ Part B ---------------
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
    """Simulate the full car on road ``name`` and run the road UIO
    (:class:`~vehicle_observers.observers.sliding_mode.RoadObserver`, initial wheel
    displacements off by ``z_err0`` [m], flat road, measured body rates); metrics after
    ``t_skip``."""
    gains = road_gains if gains is None else gains
    rd, V, t, U, X, Y = part_b_truth(name, T, seed, dt, p)
    if noise_z > 0:
        Y = Y.copy()
        Y[:, :4] += np.random.default_rng(seed + 1).normal(scale=noise_z, size=(len(t), 4))
    obs_p = p.scaled(**(errors or {}))
    x0 = np.concatenate([Y[0, :4] + z_err0, np.zeros(4), Y[0, 7:10]])
    res = _smo.RoadObserver(obs_p, gains, t[1] - t[0]).run(t, None, Y, x0)
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
        out[f"t_reach_z{i + 1}"] = reaching_time(t, Y[:, i] - res.z[:, i], band)
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
    (:func:`vehicle_observers.observers.sliding_mode.road_lost_subspace`, per sample),
    wheel-displacement RMSE [mm] raw and modulo the warp wheel patterns, the RMS road error
    removed by the modulo (``U_lost_rms_mm``), body-rate RMSE."""
    t, U, X, Yp, defl = part_b_paper_outputs(name, T, seed, dt, p, deflection_wheel)
    obs_p = p.scaled(**(errors or {}))
    design = _smo.paper_output_design(obs_p, deflection_wheel)
    y = Yp if defl is None else np.column_stack([Yp, defl])
    res = _smo.PaperOutputObserver(obs_p, design, t[1] - t[0]).run(t, None, y)
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
