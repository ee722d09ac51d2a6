"""Experiments and figures of notebook 06 (relaxed UIO, El Youssfi 2020 reconstruction).

Each function runs one experiment of the notebook and returns plain dicts / arrays, or
builds one figure and returns the matplotlib Figure, so the notebook stays a few lines per
cell. Equations and reconstruction choices: :mod:`vehicle_observers.models.uncertain_lateral`
(model (1)-(15)), :mod:`vehicle_observers.observers.uio` (UIO (20)-(24), designs (a) [22] and
(b) Theorem 2), :mod:`.scenario` (signals, scenario, metrics), :mod:`vehicle_observers.baselines.uio_ekf`
(EKF/UKF with the fault as a random-walk state) and
:mod:`vehicle_observers_papers.elyoussfi_2020.constants` (constants).

Metrics are returned as ``{name: (value, unit, note)}`` in the order the notebook reports
them; :meth:`Report.record <vehicle_observers.results.reporting.Report.record>` writes
such a dict (and the claims); :func:`claims` gives the claims with
their :class:`~vehicle_observers.results.rules.Rule` (verdicts computed from the metrics).
Units: SI (m/s, rad/s, rad, s) unless a
name says otherwise; arrays are (N, ...) over samples.
"""

from __future__ import annotations

import dataclasses

import matplotlib.pyplot as plt
import matplotlib.ticker as mticker
import numpy as np
from vehicle_observers.baselines import uio_ekf as ub
from vehicle_observers.core.metrics import rmse
from vehicle_observers.models import uncertain_lateral as ul
from vehicle_observers.observers import uio
from vehicle_observers.results.plotting import PALETTE, TRUTH, color, time_series
from vehicle_observers.results.rules import Rule, fmt
from vehicle_observers.results.tables import Table, show_table

from vehicle_observers_papers.elyoussfi_2020 import constants as P
from vehicle_observers_papers.elyoussfi_2020 import scenario as sn

PAPER = "El Youssfi 2020 (relaxed UIO)"
#: state names / units of the augmented state X = [v_y, r, f]
STATES = (("vy", "m/s"), ("r", "rad/s"), ("f", "rad"))
#: plot styles of the estimate figures
STYLES = {"true": {"color": TRUTH}, "(b) Theorem 2": {"color": color("elyoussfi2020/theorem2")},
          "(a) [22]": {"color": color("elyoussfi2020/ref22"), "ls": "--"},
          "EKF": {"color": color("elyoussfi2020/ekf"), "ls": "-."},
          "EKF, tau rule": {"color": color("elyoussfi2020/ekf-tau"), "ls": ":"}}
#: correlation time [s] of the EKF's dt-independent noise rule (:func:`ub.noise_rule`,
#: ``q = s^2 tau``): the rate bounds are stated per second, so a drift at the bound is
#: assumed to persist for about 1 s. A stated choice, not fitted to the run.
TAU_NOISE = 1.0


# ------------------------------------------------------------ identification, designs ----
def fit_metrics(ty: ul.FuzzyTyres) -> dict:
    """Fuzzy cornering forces (2) identified by LM (Sec. 2.2): bell parameters ``a, c``
    [deg], ``b`` [-], rule stiffnesses ``C_f, C_r`` [N/rad] and the relative residuals."""
    return {
        "fit_a_deg": (np.degrees(ty.a), "deg", "bell width a"),
        "fit_b": (ty.b, "", "bell exponent b"),
        "fit_c_deg": (np.degrees(ty.c), "deg", "bell centre c"),
        "fit_C_f": (list(ty.C_f), "N/rad", "C_f1, C_f2"),
        "fit_C_r": (list(ty.C_r), "N/rad", "C_r1, C_r2"),
        "fit_rms_rel": (ty.rms_rel, "", "RMS force residual / peak force (both axles)"),
        "fit_max_rel": (ty.max_rel, "", "max force residual / peak force"),
    }


def phi_design(model: ul.UncertainLateralTS, delta_dot_max: float = P.delta_dot_max) -> dict:
    """Assumption 2 bound phi [1/s] from the stated input bounds (steering rate
    ``delta_dot_max`` [rad/s], fault rate ``model.scale_fdot``, speed ``model.vx``, tyre
    peak forces): :func:`uio.phi_bound`. Not taken from a run."""
    return uio.phi_bound(model, delta_dot_max, model.scale_fdot, P.tire_f.D, P.tire_r.D)


def phi_metrics(pb: dict) -> dict:
    """The parts of the phi derivation (:func:`phi_design`)."""
    return {"phi_dh_dalpha_max": (pb["dh_dalpha_max"], "1/rad", "max |dh_1/dalpha_f|"),
            "phi_ay_max": (pb["ay_max"], "m/s^2", "(1 + rho_m)(D_f + D_r)/m"),
            "phi_rdot_max": (pb["rdot_max"], "rad/s^2", "(1 + rho_I)(l_f D_f + l_r D_r)/I_z"),
            "phi_alpha_dot_max": (pb["alpha_dot_max"], "rad/s", "bound on |alpha_f'|"),
            "delta_dot_max": (pb["delta_dot_max"], "rad/s", "stated steering-rate bound"),
            "phi_design": (pb["phi"], "1/s", "Assumption 2 bound used by design (b)")}


def structure_metrics(model: ul.UncertainLateralTS, st: dict) -> dict:
    """Existence conditions of the UIO: ranks of ``Mbar`` and ``Cbar Mbar`` (Assumption 1),
    whether v_y is measured (a row of C picks it), the (23a) residual, and the unobservable
    modes of ``(T Abar_i, Cbar)`` [1/s] (detectability: all must be < 0)."""
    Cb, Mb = st["Cbar"], st["Mbar"]
    modes = unobservable_modes(st)
    return {"rank_M": (int(np.linalg.matrix_rank(Mb)), "", "rank Mbar"),
            "rank_CM": (int(np.linalg.matrix_rank(Cb @ Mb)), "", "rank Cbar Mbar"),
            "vy_measured": (bool(np.any(np.abs(model.C[:, 0]) > 0)), "",
                            "v_y measured (a row of C reads it)"),
            "T_Mbar_residual": (float(np.abs(st["T"] @ Mb).max()), "", "max |T Mbar| of (23a) (0 exactly)"),
            "unobservable_modes": (modes, "1/s", "unobservable modes of (T Abar_i, Cbar), per rule"),
            "max_unobservable_mode": (max(modes) if modes else None, "1/s",
                                      "detectable if < 0 (None: observable)")}


def unobservable_modes(st: dict, tol: float = 1e-8) -> list[float]:
    """Real parts [1/s] of the eigenvalues of ``T Abar_i`` that fail the PBH rank test with
    ``Cbar`` (unobservable modes), over all rules; SI time (``st`` in normalised states)."""
    out = []
    for TA in st["TA"]:
        for lam in np.linalg.eigvals(TA):
            pbh = np.vstack([lam * np.eye(3) - TA, st["Cbar"]])
            if np.linalg.svd(pbh, compute_uv=False)[-1] < tol * max(1.0, np.abs(pbh).max()):
                out.append(float(lam.real))
    return out


def designs(model: ul.UncertainLateralTS, st: dict, alpha: float, phi: float, mu=P.mu_grid,
            eps: float | None = None):
    """Designs (a) [22] (common quadratic) and (b) Theorem 2 (relaxed, ``mu`` line-searched
    over ``mu`` [s]) at decay rate ``alpha`` [1/s] and ``|h'| <= phi`` [1/s], poles in
    ``|lambda| < P.radius`` [1/s]; ``eps``: LMI strictness (default: the designs' own).
    Returns ``(gains_a, gains_b)``."""
    kw = {} if eps is None else {"eps": eps}
    ga = uio.design_quadratic(model, alpha, st, radius=P.radius, **kw)
    gb = uio.design_relaxed(model, alpha, phi, mu, st, radius=P.radius, **kw)
    return ga, gb


def design_summary(*gains: uio.UIOGains) -> str:
    """Solver summary and observer poles [1/s] of each design, as text."""
    return "\n".join(f"{g.solution.summary()} \npoles: {np.round(g.poles, 2).tolist()}"
                     for g in gains)


def design_metrics(ga: uio.UIOGains, gb: uio.UIOGains) -> dict:
    """Certified L2 gains gamma and their ratio, line-searched ``mu`` [s], certificate
    margins (time-scaled units) and status, slowest pole [1/s] and largest gain entry of (a),
    (b)."""
    out = {"gamma_a": (ga.gamma, "", f"design (a) [22], alpha = {ga.alpha:g} 1/s"),
           "gamma_b": (gb.gamma, "", f"design (b) Theorem 2, phi = {gb.phi:.3g} 1/s"),
           "gamma_ratio_b_over_a": (gb.gamma / ga.gamma, "", "at the design point"),
           "mu_b": (gb.mu, "s", "line-searched Finsler scalar")}
    for k, g in (("a", ga), ("b", gb)):
        out[f"margin_{k}"] = (g.min_margin, "", "min certified LMI margin (time-scaled units)")
        out[f"lmi_status_{k}"] = (g.solution.certificate.status, "",
                                  "LMI certificate: certified / inconclusive / violated")
        out[f"slowest_pole_{k}"] = (float(-g.poles.real.max()), "1/s",
                                    f"slowest observer pole of ({k}), -max Re lambda(N_i)")
        out[f"gain_norm_{k}"] = (float(np.abs(g.L).max()), "", "max |L_i| entry (normalised)")
    return out


def remark1(st: dict, ga: uio.UIOGains, phi: float, mu: float = 1e-7):
    """Remark 1 made constructive: the (a) solution as a point of Theorem 2's LMIs
    (:func:`uio.relaxed_from_quadratic`) at Finsler scalar ``mu`` [s], certified
    independently. Returns ``(certificate, metrics)``."""
    vals = uio.relaxed_from_quadratic(ga)
    cert = uio.relaxed_certificate(st, vals, ga.alpha, phi, mu, P.radius)
    return cert, {"remark1_certified": (bool(cert.ok), "",
                                        "(a) solution certified as a (b) point"),
                  "remark1_margin": (cert.min_margin, "",
                                     "min margin of that certificate (time-scaled units)")}


# ---------------------------------------------------------------------- simulation -------
def simulation(model: ul.UncertainLateralTS, gains: dict, t_end: float, seed: int,
               fault_kw: dict | None = None) -> dict:
    """Figs. 3-7 analogues: the faulty uncertain vehicle (:func:`.scenario.make_scenario`, fault at
    ``P.t_fault``, 1 kHz) with sensor noise (``sc``) and without (``sc0``, same seed), and
    the observers ``gains = {"a": UIOGains, "b": UIOGains}`` on both, scheduled on their
    own estimates (``ev[k]``, ``ev0[k]``), plus (b) fed the true memberships (``evt``,
    ``evt0``: comparison only, they contain the true slip angle and fault)."""
    kw = {"fault_kw": fault_kw or {"offset": P.fault_offset, "amp": P.fault_amp}}
    sc = sn.make_scenario(model, t_end, P.dt, P.t_fault, P.x0_true, seed=seed, **kw)
    sc0 = sn.make_scenario(model, t_end, P.dt, P.t_fault, P.x0_true, seed=seed, noise=False,
                            **kw)
    return {"t_end": t_end, "seed": seed, "sc": sc, "sc0": sc0, "X_openloop": open_loop(model, sc),
            "ev": {k: sn.evaluate(g, sc, model) for k, g in gains.items()},
            "ev0": {k: sn.evaluate(g, sc0, model) for k, g in gains.items()},
            "evt": sn.evaluate(gains["b"], sc, model, premise="true"),
            "evt0": sn.evaluate(gains["b"], sc0, model, premise="true")}


def open_loop(model: ul.UncertainLateralTS, sc: dict) -> np.ndarray:
    """The open-loop baseline of the v_y estimate: the nominal T-S model (1)-(9) (fuzzy forces,
    nominal ``1/I_z``, no fault) driven by the same measured steering ``sc["delta"]`` from the
    observers' initial estimate 0, *without* output injection. Returns (N, 2) ``[v_y, r]``
    [m/s, rad/s]. An estimate of v_y that is no better than this proves nothing about the
    observer (v_y is stable, so the model alone converges too)."""
    return ul.simulate_truth(model, np.zeros(2), sc["delta"], 0.0, 0.0, sc["dt"])


def convergence_time(t, err, t_stop: float, frac: float = 0.1) -> float:
    """Time [s] from which ``|err|`` stays below ``frac |err(0)|`` up to ``t_stop`` (nan if
    it never does). ``t``, ``err`` (N,)."""
    t, err = np.asarray(t, float), np.asarray(err, float)
    m = t < t_stop
    bad = np.flatnonzero(np.abs(err[m]) > frac * abs(err[0]))
    if len(bad) == 0:
        return 0.0
    return float("nan") if bad[-1] == m.sum() - 1 else float(t[m][bad[-1] + 1])


def delay_metrics(name: str, ev0: dict, sc0: dict, who: str) -> dict:
    """Noise-free fault delay [s] of one estimator as a finite metric: when the error never
    settles in the 10 % band, the delay is the post-fault run length (a lower bound) and
    ``<name>_settles`` is False."""
    d = ev0["fault_delay"]
    settles = bool(np.isfinite(d))
    length = float(sc0["t"][-1] - sc0["t_fault"])
    return {name: (d if settles else length, "s",
                   f"{who}, noise-free, 10 % band" + ("" if settles else
                                                      "; never settles: run length")),
            f"{name}_settles": (settles, "", f"{who}: the fault error settles in the band")}


def fault_step_samples(sc: dict):
    """(N,) mask of the samples whose central difference spans the fault onset: a fault
    offset is a step, so ``dh/dt`` there is a Dirac (the finite difference grows as 1/dt)
    and lies outside Assumption 2 and the stated fault-rate bound."""
    k = int(np.searchsorted(sc["t"], sc["t_fault"]))
    m = np.zeros(len(sc["t"]), dtype=bool)
    m[max(k - 1, 0):k + 1] = True
    return m


def simulation_metrics(sim: dict) -> dict:
    """Per design (estimated premises; after the fault, with / without noise): RMSE of
    ``v_y, r, f``, fault delay (noise-free, 10 % band), v_y convergence time (noise-free,
    to 10 % of the initial error), peak onset errors; the premise error and its effect
    (design (b) with true memberships); the RMS of the true v_y; largest front slip [deg]
    and ``max |dh/dt|`` [1/s] of the run (Assumption 2 check)."""
    sc, sc0, ev, ev0 = sim["sc"], sim["sc0"], sim["ev"], sim["ev0"]
    out = {}
    after = sc["t"] >= sc["t_fault"]
    for k in ev:
        for nm, u in STATES:
            out[f"rmse_{nm}_{k}"] = (ev[k][f"rmse_{nm}"], u, "after the fault, with noise")
            out[f"rmse_{nm}_{k}_noisefree"] = (ev0[k][f"rmse_{nm}"], u, "after the fault")
        out |= delay_metrics(f"fault_delay_{k}", ev0[k], sc0, f"UIO ({k})")
        out[f"vy_conv_time_{k}"] = (convergence_time(sc0["t"], ev0[k]["err"][:, 0],
                                                     sc0["t_fault"]), "s",
                                    "noise-free, |e_vy| < 10 % of |e_vy(0)| from then on")
        for j, (nm, _) in enumerate(STATES):
            out[f"peak_err_{nm}_onset_{k}"] = (
                ev0[k]["peak_err_onset"][j], "",
                "noise-free, max |error| within 0.5 s after the fault appears (SI)")
    out["rms_vy_true"] = (float(np.sqrt(np.mean(sc["X"][after, 0] ** 2))), "m/s",
                          "RMS of the true v_y after the fault")
    out["rmse_vy_openloop"] = (rmse(sim["X_openloop"][:, 0], sc["X"][:, 0], after), "m/s",
                               "open-loop model (same steering, no output injection), "
                               "after the fault")
    out["premise_err_max"] = (float(np.abs(ev["b"]["h_used"] - sc["h"]).max()), "",
                              "max |h(alpha_f_hat) - h(alpha_f)|, design (b), with noise")
    for nm, u in STATES[:1] + STATES[2:]:
        out[f"rmse_{nm}_b_truepremise"] = (sim["evt"][f"rmse_{nm}"], u,
                                           "(b) fed the true memberships, with noise")
        out[f"rmse_{nm}_b_truepremise_noisefree"] = (sim["evt0"][f"rmse_{nm}"], u,
                                                     "(b) fed the true memberships")
    out["max_abs_delta"] = (float(np.abs(sc["delta"]).max()), "rad", "steering input")
    out["max_slip_deg"] = (float(np.degrees(np.abs(sc["alpha_f"]).max())), "deg", "")
    step = fault_step_samples(sc)
    out["max_abs_hdot"] = (float(np.abs(sc["hdot"]).max()), "1/s",
                           "all samples: includes the finite difference across the fault step")
    out["max_abs_hdot_smooth"] = (float(np.abs(sc["hdot"][~step]).max()), "1/s",
                                  "Assumption 2 check, the two samples at the fault step left out")
    return out


def rmse_table(*evals: tuple[str, dict]) -> Table:
    """Rounded table of the RMSEs and fault delays of ``(name, evaluate dict)`` pairs."""
    keys = ("rmse_vy", "rmse_r", "rmse_f", "fault_delay")
    return show_table([{"estimator": k, **{m: e[m] for m in keys}} for k, e in evals])


# --------------------------------------------------------- C = I comparison variant ------
def full_variant(seed: int, t_end: float, quick: bool) -> dict:
    """The first version of this reproduction (``P.build_model(variant="full")``: C = I,
    v_y measured, uncertainty on 1/m), designs at ``alpha = P.alpha_full``,
    ``phi = P.phi_full`` and its feasibility map on alpha in {0, 15} x phi in {0, 10}.
    Returns the model, structure, gains, noisy-run evaluation of (b) and the map."""
    model = P.build_model(variant="full")
    st = uio.structure(model)
    ga, gb = designs(model, st, P.alpha_full, P.phi_full)
    sc = sn.make_scenario(model, t_end, P.dt, P.t_fault, P.x0_true, seed=seed)
    fm = uio.feasibility_map(model, [0.0, 15.0], [0.0, P.phi_full], P.mu_grid, st, P.radius,
                             gamma_level=0.55)
    fm["ratio"] = fm["gamma_b"] / fm["gamma_a"][:, None]
    return {"model": model, "st": st, "ga": ga, "gb": gb, "sc": sc, "fm": fm,
            "evb": sn.evaluate(gb, sc, model)}


def full_variant_metrics(fv: dict) -> dict:
    """v_y RMSE of (b) in the C = I variant against the v_y sensor noise, the certificate
    status of its designs, and its map (feasible at gamma <= 0.55, the level of its first
    version) restricted to phi >= 10."""
    out = {"full_rmse_vy_b": (fv["evb"]["rmse_vy"], "m/s", "C = I: v_y is measured"),
           "full_sigma_vy": (P.sigma_vy, "m/s", "v_y sensor noise"),
           "full_gamma_ratio": (fv["gb"].gamma / fv["ga"].gamma, "", "alpha = 2, phi = 10"),
           "full_lmi_status": ([fv[k].solution.certificate.status for k in ("ga", "gb")], "",
                               "LMI certificates of (a), (b) at alpha = 2, phi = 10")}
    return out | {f"full_{k}": v for k, v in feasibility_metrics(fv["fm"], P.phi_full).items()}


# ------------------------------------------------------------------ EKF baseline ---------
def ekf_baseline(model: ul.UncertainLateralTS, sim: dict, tau: float = TAU_NOISE) -> dict:
    """filterpy EKF with the fault as a random-walk state (:mod:`.baselines.uio_ekf`, Q/R by
    :func:`ub.noise_rule`, per-sample rule), scheduled on its own estimated premises, on the
    same noisy / noise-free runs (``evk``, ``evk0``), and the same EKF with the
    dt-independent rule of correlation time ``tau`` [s] (``evk_tau``, ``evk0_tau``)."""
    Qb, Rb, qinfo = ub.noise_rule(model, P.dt)
    Qt, _, _ = ub.noise_rule(model, P.dt, tau=tau)
    kw = {"h": "estimated", "kind": "ekf"}
    return {"qinfo": {**qinfo, "tau": tau},
            "evk": sn.evaluate_filter(model, sim["sc"], **kw),
            "evk0": sn.evaluate_filter(model, sim["sc0"], **kw),
            "evk_tau": sn.evaluate_filter(model, sim["sc"], Q=Qt, R=Rb, **kw),
            "evk0_tau": sn.evaluate_filter(model, sim["sc0"], Q=Qt, R=Rb, **kw)}


def settled_fault_rmse(ev: dict, sc: dict, after: float = 0.5) -> float:
    """RMS fault error [rad] from ``after`` s after the fault appears (onset excluded).
    ``ev["Xhat"]`` (N, 3), ``sc["t"], sc["f"]`` (N,); ValueError if the window is empty."""
    settled = sc["t"] >= sc["t_fault"] + after
    if not settled.any():
        raise ValueError(f"no sample {after} s after the fault (t_fault = {sc['t_fault']} s, "
                         f"run ends at {sc['t'][-1]} s): lengthen the run or lower 'after'")
    return rmse(ev["Xhat"][:, 2], sc["f"], settled)


def ekf_metrics(sim: dict, ekf: dict) -> dict:
    """EKF noise rule, RMSEs (noisy, noise-free) and fault delays of both EKF rules, and
    the fault error before the fault (noise-free: uncertainty taken for a fault) and after
    settling for (b) and the EKFs."""
    qi, sc0 = ekf["qinfo"], sim["sc0"]
    out = {"ekf_d_max": (qi["d_max"], "SI", "uncertainty size along M (rad/s^2 for 1/I_z)"),
           "ekf_fdot_max": (qi["fdot_max"], "rad/s", "fault-rate bound"),
           "ekf_tau": (qi["tau"], "s", "correlation time of the dt-independent rule")}
    rows = (("ekf", ekf["evk"], ekf["evk0"]), ("ekf_tau", ekf["evk_tau"], ekf["evk0_tau"]))
    for k, e, e0 in rows:
        for nm, u in STATES:
            out[f"rmse_{nm}_{k}"] = (e[f"rmse_{nm}"], u, "after the fault, with noise")
            out[f"rmse_{nm}_{k}_noisefree"] = (e0[f"rmse_{nm}"], u, "after the fault")
        out |= delay_metrics(f"fault_delay_{k}", e0, sc0, k)
    for k, e in (("b", sim["ev0"]["b"]), ("ekf", ekf["evk0"]), ("ekf_tau", ekf["evk0_tau"])):
        out[f"rmse_f_{k}_before_noisefree"] = (e["rmse_f_before"], "rad",
                                               "noise-free, 1 s to the fault (f = 0)")
        out[f"rmse_f_{k}_settled_noisefree"] = (settled_fault_rmse(e, sc0), "rad",
                                                "noise-free, from 0.5 s after the onset")
    return out


def fault_table(sim: dict, ekf: dict) -> Table:
    """Fault delay [s] (noise-free), fault RMSE [rad] after the fault (noise-free, with
    noise) and v_y RMSE [m/s] with noise per estimator and EKF noise rule."""
    tau = ekf["qinfo"]["tau"]
    rows = {"UIO (a)": (sim["ev0"]["a"], sim["ev"]["a"]),
            "UIO (b)": (sim["ev0"]["b"], sim["ev"]["b"]),
            "EKF q = s^2 dt": (ekf["evk0"], ekf["evk"]),
            f"EKF q = s^2 tau, tau = {tau:g} s": (ekf["evk0_tau"], ekf["evk_tau"])}
    return show_table([{"estimator": k, "delay [s]": e0["fault_delay"],
                        "rmse_f noise-free": e0["rmse_f"], "rmse_f": e["rmse_f"],
                        "rmse_vy": e["rmse_vy"]} for k, (e0, e) in rows.items()])


def cost_timings(sim: dict, gb: uio.UIOGains, model, evk: dict) -> dict:
    """Wall-clock cost per sample [us] of the compiled UIO (b) loop (best of 3, after a first
    run compiled it) and of filterpy's EKF: for :meth:`Report.timing`, never metrics."""
    sc = sim["sc"]
    obs = uio.UIObserver(gb, model, P.dt)
    sec = min(obs.run(sc["t"], sc["delta"], sc["y"]).seconds for _ in range(3))
    us_uio = 1e6 * sec / len(sc["t"])
    return {"us_per_step_uio": (us_uio, "us", "UIO (b), numba RK4 loop, best of 3"),
            "us_per_step_ekf": (evk["run"].us_per_step, "us", "filterpy EKF"),
            "cost_ratio_ekf_over_uio": (evk["run"].us_per_step / us_uio, "", "per sample")}


# --------------------------------------------------------------- feasibility map ---------
def feasibility(model: ul.UncertainLateralTS, st: dict, phi: float, quick: bool) -> dict:
    """Best certified gamma of (a) and (b) on the (alpha [1/s], phi [1/s]) grid
    (:func:`uio.feasibility_map`, feasible = a certified solution exists), plus ``ratio``
    = gamma_b / gamma_a. alpha up to 1.2 1/s (above the slowest unobservable v_y mode
    0.99 1/s); phi in {0, the derived bound ``phi``, 100}. Quick: alpha in {0.5, 1.2},
    phi in {0, phi}."""
    alphas = np.array([0.5, 1.2]) if quick else np.array([0.0, 0.5, 0.9, 0.95, 1.2])
    phis = np.array([0.0, phi]) if quick else np.array([0.0, phi, 100.0])
    fm = uio.feasibility_map(model, alphas, phis, P.mu_grid, st, P.radius, None)
    fm["ratio"] = fm["gamma_b"] / fm["gamma_a"][:, None]
    return fm


def feasibility_metrics(fm: dict, phi: float) -> dict:
    """Grid, gammas, containment feasible(a) <= feasible(b), counts, and on the cells with
    ``phi_grid >= phi`` (Assumption 2 honoured): cells where only (b) is feasible and the
    range of gamma_b / gamma_a."""
    ratio, ok = fm["ratio"], fm["phi"][None, :] >= phi - 1e-12
    only_b = fm["feasible_b"] & ~fm["feasible_a"]
    adm = ratio[np.broadcast_to(ok, ratio.shape) & np.isfinite(ratio)]
    return {
        "map_alpha": (fm["alpha"], "1/s", "decay rates of the map"),
        "map_phi": (fm["phi"], "1/s", "bounds phi of the map"),
        "map_gamma_a": (fm["gamma_a"], "", "best certified gamma of (a) per alpha"),
        "map_gamma_b": (fm["gamma_b"], "", "rows alpha, columns phi"),
        "map_containment": (bool(np.all(fm["feasible_b"] | ~fm["feasible_a"])), "",
                            "feasible(a) subset of feasible(b)"),
        "map_n_feasible_a": (int(fm["feasible_a"].sum()), "", "cells where (a) is feasible"),
        "map_n_feasible_b": (int(fm["feasible_b"].sum()), "", "cells where (b) is feasible"),
        "map_n_only_b": (int(only_b.sum()), "", "cells where only (b) is feasible"),
        "map_n_only_b_admissible": (int((only_b & ok).sum()), "",
                                    "cells with phi >= the derived bound where only (b) is "
                                    "feasible"),
        "map_max_ratio_admissible": (float(adm.max()) if adm.size else float("nan"), "",
                                     "largest gamma_b / gamma_a with phi >= the derived bound"),
        "map_min_ratio_admissible": (float(adm.min()) if adm.size else float("nan"), "",
                                     "smallest gamma_b / gamma_a with phi >= the derived bound"),
    }


# --------------------------------------------------------------------------- claims ------
#: |gamma_b / gamma_a - 1| below which the two designs reach the same certified optimum (the
#: solver's relative accuracy is about 1e-6; 1e-3 is far above it and far below a gain worth
#: the name)
GAMMA_SAME = 1e-3


def _faster_rule(value: str, paper: str, what: str, because: str | None) -> Rule:
    """Rule of a "(b) is faster than (a)" claim on the ratio ``value`` of a time (b) / (a):
    not comparable (``because``) when the reconstruction fixes the comparison, else
    reproduced at least 10 % shorter, partly any shorter."""
    if because is not None:
        return Rule.not_comparable(value, paper=paper, because=because)
    return Rule(value, reproduced="value <= 0.9", partly="value < 1", paper=paper,
                source=f"chosen here: 'faster' has no number; at least 10 % shorter {what}, "
                       "partly any (no reason for 10 % recorded)")


def claims(g: dict) -> list[dict]:
    """Claim keyword dicts for :meth:`Report.claim` from the report's stored metric values
    ``g`` (``rep.values()``); each verdict is computed by its :class:`Rule`."""
    return [
        dict(paper=PAPER, kind="paper", item="Fig. 3", figure="fig3_steering", metric="max |delta| [rad]",
             rule=Rule.no_number("max_abs_delta", paper="steering of the driver (values lost)"),
             note="signal chosen here: the paper's values were lost"),
        dict(paper=PAPER, kind="paper", item="Fig. 4 (v_y, not measured)", figure="fig4_vy",
             metric="rmse_vy (b) / RMS of the true v_y, with noise, estimated premises",
             rule=Rule("rmse_vy_b / rms_vy_true",
                       reproduced="value <= 0.1 and value < rmse_vy_openloop / rms_vy_true",
                       partly="value <= 0.5 and value < rmse_vy_openloop / rms_vy_true",
                       informative="rank_CM == rank_M and not vy_measured",
                       paper="v_y estimate converges to the true v_y",
                       source="chosen here: Fig. 4 prints no number; RMSE within 10 % of the "
                              "RMS of v_y, 50 % partly (no reason recorded), and below the "
                              "open-loop model's (same steering, no output injection: v_y is "
                              "stable, so the model alone also converges); informative if the "
                              "uncertainty is decoupled and v_y is not measured"),
             note=(f"open-loop model: rmse_vy {fmt(g['rmse_vy_openloop'])} m/s "
                   f"({fmt(g['rmse_vy_openloop'] / g['rms_vy_true'])} of the RMS of v_y); "
                   f"v_y converges at the open-loop lateral mode (unobservable, detectable): "
                   f"{fmt(g['vy_conv_time_b'])} s to 10 % of the initial error (noise-free); "
                   f"premise error max {fmt(g['premise_err_max'])} changes rmse_vy from "
                   f"{fmt(g['rmse_vy_b_truepremise'])} (true premises) to "
                   f"{fmt(g['rmse_vy_b'])} m/s")),
        dict(paper=PAPER, kind="paper", item="Figs. 4-5 (faster convergence)", figure="fig5_yaw_rate",
             metric="vy_conv_time (b) / (a), noise-free",
             rule=_faster_rule(
                 "vy_conv_time_b / vy_conv_time_a", "Theorem 2 converges faster than [22]",
                 "convergence time", None if g["max_unobservable_mode"] is None else
                 (f"v_y is unobservable through the decoupled outputs in this reconstruction "
                  f"(sensors and uncertainty direction chosen here): its error decays at the "
                  f"open-loop lateral mode {fmt(g['max_unobservable_mode'])} 1/s, an eigenvalue "
                  "of every N_i that no gain moves, so both designs converge in the same time "
                  "by construction")),
             note=(f"noise-free: v_y convergence {fmt(g['vy_conv_time_b'])} s (b), "
                   f"{fmt(g['vy_conv_time_a'])} s (a); r RMSE {fmt(g['rmse_r_b_noisefree'])} (b) "
                   f"vs {fmt(g['rmse_r_a_noisefree'])} rad/s (a)")),
        dict(paper=PAPER, kind="paper", item="Fig. 6 (fault estimation)", figure="fig6_fault",
             metric="fault delay (b) / (a), noise-free",
             rule=_faster_rule(
                 "fault_delay_b / fault_delay_a",
                 "fault estimate of Theorem 2 converges faster than [22]", "fault delay",
                 None if abs(g["gamma_ratio_b_over_a"] - 1) > GAMMA_SAME else
                 (f"in this reconstruction Theorem 2 reaches the same certified optimum as [22] "
                  f"(gamma_b / gamma_a = {g['gamma_ratio_b_over_a']:.4f}) at a decay rate "
                  "capped by the unobservable v_y mode for both, so the relaxation gains "
                  "nothing to be faster with; which of the equally good gains the solver "
                  "returns decides the delay, not Theorem 2")),
             note=(f"noise-free delays {fmt(g['fault_delay_b'])} s (b), "
                   f"{fmt(g['fault_delay_a'])} s (a); with noise fault RMSE "
                   f"{fmt(g['rmse_f_b'])} (b) vs {fmt(g['rmse_f_a'])} rad (a)")),
        dict(paper=PAPER, kind="paper", item="Fig. 7 / Assumption 2", figure="fig7_membership_derivatives",
             metric="max |dh/dt| of the run (fault step left out) / phi (from input bounds)",
             rule=Rule("max_abs_hdot_smooth / phi_design", reproduced="value <= 1",
                       informative="value >= 0.1",
                       paper="|dh_i/dt| below the bound phi",
                       source="paper: Assumption 2, |dh_i/dt| <= phi (ratio <= 1); chosen here: "
                              "informative if the run reaches a tenth of phi"),
             note=f"phi = {fmt(g['phi_design'])} 1/s derived from |delta'| <= "
                  f"{fmt(g['delta_dot_max'])} rad/s, |f'| <= {fmt(g['ekf_fdot_max'])} rad/s, "
                  f"v_x and the tyre peak forces; across the fault step the finite difference "
                  f"reaches {fmt(g['max_abs_hdot'])} 1/s (a Dirac sampled at 1 kHz, outside "
                  "the fault-rate bound)"),
        dict(paper=PAPER, kind="paper", item="Remark 1 / Sec. 6", figure="feasibility_map",
             metric="cells with phi >= bound where only (b) is feasible",
             rule=Rule("map_n_only_b_admissible", reproduced="value >= 1",
                       partly="map_containment and map_max_ratio_admissible <= 1 + 1e-4",
                       paper="relaxed conditions are less conservative than [22]",
                       source="paper: Remark 1, (b) contains (a) and is feasible where (a) is "
                              "not; chosen here: at least one such cell with phi at its bound, "
                              "partly if (b) is never worse (gamma ratio <= 1 + 1e-4; no reason for "
                              "1e-4 recorded)"),
             note=(f"gamma_b / gamma_a at the design point {fmt(g['gamma_ratio_b_over_a'], 4)}; "
                   f"on admissible cells {fmt(g['map_min_ratio_admissible'], 4)} to "
                   f"{fmt(g['map_max_ratio_admissible'], 4)}; cells where only (b) is feasible: "
                   f"{g['map_n_only_b']} in all, {g['map_n_only_b_admissible']} with "
                   "phi >= bound")),
        dict(paper=PAPER, kind="diagnostic", item="Remark 1, C = I comparison variant",
             figure="feasibility_map",
             metric="cells with phi >= 10 where only (b) reaches gamma <= 0.55",
             rule=Rule("full_map_n_only_b_admissible", reproduced="value >= 1",
                       partly="full_map_containment and full_map_max_ratio_admissible <= 1 + 1e-4",
                       paper="relaxed conditions are less conservative than [22]",
                       source="paper: Remark 1, (b) feasible where (a) is not; chosen here: at "
                              "least one such cell at phi = 10 and gamma <= 0.55, partly if (b) "
                              "is never worse (gamma ratio <= 1 + 1e-4; no reason for 1e-4 recorded)"),
             note=(f"only-(b) cells {g['full_map_n_only_b']} in all (phi = 0 violates "
                   f"Assumption 2), {g['full_map_n_only_b_admissible']} at phi = 10; "
                   f"gamma_b / gamma_a {fmt(g['full_map_min_ratio_admissible'], 4)} to "
                   f"{fmt(g['full_map_max_ratio_admissible'], 4)} there")),
        dict(paper=PAPER, kind="baseline", item="Sec. 1 / (23a) vs EKF baseline", figure="fault_uio_vs_ekf",
             metric="spurious fault before the fault, noise-free: [EKF q = s^2 dt, UIO (b)] "
                    "/ settled fault error of (b)",
             rule=Rule("[rmse_f_ekf_before_noisefree / rmse_f_b_settled_noisefree, "
                       "rmse_f_b_before_noisefree / rmse_f_b_settled_noisefree]",
                       reproduced="value[1] < 0.1 and fault_delay_b <= min(fault_delay_ekf, "
                                  "fault_delay_ekf_tau)",
                       partly="value[1] < 0.1",
                       paper="the UIO decouples the model uncertainty and estimates the "
                             "fault at least as fast as a filter",
                       source="chosen here: the paper has no filter; decoupled as a spurious "
                              "fault below 10 % of the settled error (no reason for 10 % "
                              "recorded), and a fault delay no longer than either EKF's"),
             note=(f"noise-free fault delays: UIO (b) {fmt(g['fault_delay_b'])} s, EKF "
                   f"q = s^2 dt {fmt(g['fault_delay_ekf'])} s"
                   f"{'' if g['fault_delay_ekf_settles'] else ' (never settles)'}, EKF q = s^2 tau "
                   f"{fmt(g['fault_delay_ekf_tau'])} s; fault RMSE with noise "
                   f"{fmt(g['rmse_f_b'])}, {fmt(g['rmse_f_ekf'])}, {fmt(g['rmse_f_ekf_tau'])}"
                   f" rad; v_y RMSE {fmt(g['rmse_vy_b'])}, {fmt(g['rmse_vy_ekf'])}, "
                   f"{fmt(g['rmse_vy_ekf_tau'])} m/s")),
    ]


# -------------------------------------------------------------------------- figures ------
def fig_fuzzy_fit(model: ul.UncertainLateralTS):
    """Sec. 2.2: Pacejka vs identified fuzzy forces (2) per axle [N] over the fit range
    ``|alpha| <= P.alpha_fit_max``, and the memberships ``h_1, h_2`` of the front slip."""
    ty = model.tyres
    al = np.linspace(-P.alpha_fit_max, P.alpha_fit_max, 401)
    d = np.degrees(al)
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    ax[0].plot(d, P.tire_f.force(al), "k", label="Pacejka front")
    ax[0].plot(d, ty.force_front(al), "C0--", label="fuzzy (2) front")
    ax[0].plot(d, P.tire_r.force(al), "0.5", label="Pacejka rear")
    ax[0].plot(d, ty.force_rear(al), "C1--", label="fuzzy (2) rear")
    ax[0].set(xlabel=r"slip angle $\alpha$ [deg]", ylabel="lateral force [N]", title="LM identification")
    ax[0].legend()
    ax[1].plot(d, ty.memberships(al))
    ax[1].set(xlabel=r"front slip angle $\alpha_f$ [deg]", ylabel=r"membership $h_i$ [-]",
              title=r"$h_1$ (bell), $h_2 = 1 - h_1$")
    return fig


def fig_steering(sc: dict):
    """Fig. 3 analogue: steering input ``delta`` and ``delta + f`` (actuator fault) [deg]."""
    fig, ax = plt.subplots(figsize=(9, 3))
    time_series(ax, sc["t"], {r"steering $\delta$": np.degrees(sc["delta"]),
                              r"$\delta + f$ (actuator)": np.degrees(sc["delta"] + sc["f"])},
                ylabel=r"$\delta$ [deg]", title="Fig. 3 analogue: steering input")
    ax.set_xlabel("t [s]")
    return fig


#: end [s] of the start transient left out of the error axes' scaling: v_y (ln(100) / 0.99 1/s:
#: the slowest v_y mode has decayed to 1 % of the initial error by then), and r, f (ln(100) /
#: 22 1/s, their slowest poles)
T_TRANSIENT = 5.0
T_TRANSIENT_FAST = 0.2
#: width [s] of the moving mean of the noisy fault errors in :func:`fig_fault_vs_ekf`
T_SMOOTH = 0.2


def _legend_right(ax):
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)


def _error_limits(ax, t, errs, t_from: float, pad: float = 1.3):
    """y-limits of an error panel: ``pad`` x the largest |error| of ``errs`` (list of (N,))
    from ``t_from`` on (after the start transient); the transient is marked when it goes off
    scale."""
    m = t >= t_from
    top = pad * max(float(np.abs(e[m]).max()) for e in errs)
    ax.set_ylim(-top, top)
    if max(float(np.abs(e[~m]).max(initial=0.0)) for e in errs) <= top:
        return                                    # nothing off scale: no mark
    ax.axvspan(t[0], t_from, color="0.92", zorder=0)
    ax.text(0.5 * t_from, 0.82 * top, "start transient\n(off scale)", ha="center", va="top",
            fontsize=7, color="0.35")


def _moving_mean(x, n: int):
    return np.convolve(x, np.ones(n) / n, mode="same")


def _estimate_panels(sim: dict, k: int, ylabel: str, title: str):
    """Four panels for state ``k`` of ``[v_y, r, f]``: truth and estimates of (a), (b) (noisy
    run; for v_y also the open-loop model), their errors (axis scaled after the start
    transient, :data:`T_TRANSIENT` for v_y, :data:`T_TRANSIENT_FAST` for r and f), the
    difference of the two designs' estimates (noisy and noise-free), and the noise-free errors
    zoomed on the fault onset."""
    sc, ev, ev0 = sim["sc"], sim["ev"], sim["ev0"]
    t = sc["t"]
    ref = sc["X"][:, k] if k < 2 else sc["f"]
    zoom = (t >= P.t_fault - 0.05) & (t <= P.t_fault + 0.4)
    runs = [("(b) Theorem 2", ev["b"], ev0["b"]), ("(a) [22]", ev["a"], ev0["a"])]
    unit = ylabel[ylabel.index("["):]
    sym = ylabel[:ylabel.index("[")].strip()
    fig, ax = plt.subplots(4, 1, figsize=(10, 10))
    series = {"true": ref, **{n: e["Xhat"][:, k] for n, e, _ in runs}}
    styles = dict(STYLES)
    if k == 0:
        series["open-loop model"] = sim["X_openloop"][:, 0]
        styles["open-loop model"] = {"color": "0.6", "ls": ":", "lw": 1.4}
    time_series(ax[0], t, series, ylabel=ylabel, styles=styles, title=title)
    _legend_right(ax[0])
    errs = {n: e["err"][:, k] for n, e, _ in runs}
    time_series(ax[1], t, errs, ylabel=f"error {unit}", styles=STYLES,
                title=f"estimation error of {sym} (with noise; axis scaled after the start "
                      "transient)")
    t_tr = T_TRANSIENT if k == 0 else T_TRANSIENT_FAST
    _error_limits(ax[1], t, list(errs.values()), t_tr)
    _legend_right(ax[1])
    diff = {"with noise": ev["b"]["Xhat"][:, k] - ev["a"]["Xhat"][:, k],
            "noise-free": ev0["b"]["Xhat"][:, k] - ev0["a"]["Xhat"][:, k]}
    time_series(ax[2], t, diff, ylabel=f"(b) $-$ (a) {unit}",
                styles={"with noise": {"color": "0.6", "lw": 0.7},
                        "noise-free": {"color": "k"}},
                title="difference of the two designs' estimates (b) $-$ (a) "
                      "(axis scaled after the start transient)")
    _error_limits(ax[2], t, list(diff.values()), t_tr)
    _legend_right(ax[2])
    time_series(ax[3], t[zoom], {n: e0["err"][zoom, k] for n, _, e0 in runs},
                ylabel=f"error {unit}", styles=STYLES,
                title="noise-free run, zoom on the fault onset")
    _legend_right(ax[3])
    return fig


def fig_estimate(sim: dict, k: int):
    """Figs. 4 (``k = 0``, v_y [m/s]), 5 (``k = 1``, r [rad/s]) and 6 (``k = 2``, fault f
    [rad]) analogues: estimates of (a) and (b) with noise, their errors, the difference of
    the two designs, and the noise-free errors zoomed on the fault onset."""
    lab = (r"$v_y$ [m/s]", r"$r$ [rad/s]", r"$f$ [rad]")[k]
    return _estimate_panels(sim, k, lab, f"Fig. {4 + k} analogue: estimate (with sensor noise)")


def fig_fault_vs_ekf(sim: dict, ekf: dict):
    """Fault estimate [rad] of the UIOs (a), (b) against the EKF with a random-walk fault
    (per-sample rule ``q = s^2 dt``, and ``q = s^2 tau``): the noisy run (EKFs drawn light,
    behind), the errors of the noisy run after a :data:`T_SMOOTH` s moving mean, and the
    noise-free errors zoomed on the fault onset."""
    sc, t = sim["sc"], sim["sc"]["t"]
    tau = ekf["qinfo"]["tau"]
    runs = [("EKF", ekf["evk"], ekf["evk0"]), ("EKF, tau rule", ekf["evk_tau"], ekf["evk0_tau"]),
            ("(a) [22]", sim["ev"]["a"], sim["ev0"]["a"]),
            ("(b) Theorem 2", sim["ev"]["b"], sim["ev0"]["b"])]
    light = {n: {**STYLES[n], "ls": "-", "lw": 0.6, "alpha": 0.35, "zorder": 1}
             for n in ("EKF", "EKF, tau rule")}
    fig, ax = plt.subplots(3, 1, figsize=(10, 8))
    time_series(ax[0], t, {n: e["Xhat"][:, 2] for n, e, _ in runs[:2]}, styles=light,
                ylabel=r"$f$ [rad]")
    time_series(ax[0], t, {"true": sc["f"], **{n: e["Xhat"][:, 2] for n, e, _ in runs[2:]}},
                styles={k: {**v, "zorder": 3} for k, v in STYLES.items()}, ylabel=r"$f$ [rad]",
                title=rf"fault estimate with sensor noise: UIOs against the EKF (random-walk "
                      rf"fault, $q = s^2 dt$ and $q = s^2\tau$, $\tau$ = {tau:g} s; drawn light)")
    _legend_right(ax[0])
    n = max(1, int(round(T_SMOOTH / sc["dt"])))
    sm = {nm: _moving_mean(e["err"][:, 2], n) for nm, e, _ in runs}
    time_series(ax[1], t, sm, ylabel="error [rad]", styles=STYLES,
                title=f"fault error, {T_SMOOTH:g} s moving mean (the noise averaged out; axis "
                      "scaled after the start transient)")
    _error_limits(ax[1], t, list(sm.values()), T_TRANSIENT_FAST + T_SMOOTH)
    _legend_right(ax[1])
    zoom = (t >= P.t_fault - 0.05) & (t <= P.t_fault + 0.4)
    time_series(ax[2], t[zoom], {nm: e0["err"][zoom, 2] for nm, _, e0 in runs},
                ylabel="error [rad]", styles=STYLES, title="noise-free run, zoom on the fault onset")
    _legend_right(ax[2])
    return fig


def fig_membership_derivatives(sc: dict, phi: float):
    """Fig. 7 analogue: ``dh_1/dt, dh_2/dt`` [1/s] against the Assumption 2 bound ``phi``
    (the samples across the fault step, :func:`fault_step_samples`, left out)."""
    hd = np.where(fault_step_samples(sc)[:, None], np.nan, sc["hdot"])
    fig, ax = plt.subplots(figsize=(9, 3))
    time_series(ax, sc["t"], {r"$\dot h_1$": hd[:, 0], r"$\dot h_2$": hd[:, 1]},
                ylabel=r"$\dot h_i$ [1/s]",
                title=r"Fig. 7 analogue: $\dot h_i$ vs the bound $\varphi$ "
                      "(the two samples across the fault step left out)")
    ax.axhline(phi, color="k", ls=":", label=r"$\pm\varphi$")
    ax.axhline(-phi, color="k", ls=":")
    ax.set_xlabel("t [s]")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig


def fig_feasibility_map(fm: dict, phi_bound: float | None = None,
                        alpha_limit: float | None = None):
    """Left: best certified gamma [-] (log axis) against the decay rate alpha [1/s] for (a)
    and each phi [1/s] of (b), with ``alpha_limit`` [1/s] (the slowest unobservable mode, no
    design can be faster) marked. Right: the (alpha, phi) grid, each cell with gamma_b /
    gamma_a and which designs are feasible (both / (b) only / none, grey); rows with
    ``phi < phi_bound`` (Assumption 2 violated) hatched."""
    alphas, phis, ratio = fm["alpha"], fm["phi"], fm["ratio"]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [1, 1.15]})
    for j, ph in enumerate(phis):
        ax[0].plot(alphas, fm["gamma_b"][:, j], "-", marker="os^v"[j % 4], ms=4 + 2.5 * j,
                   mfc="none", color=PALETTE[(0, 1, 4, 5)[j % 4]], label=rf"(b) $\varphi$ = {ph:.3g} 1/s")
    ax[0].plot(alphas, fm["gamma_a"], "k--", marker="x", ms=7, label="(a) [22]")
    if alpha_limit is not None:
        ax[0].axvline(alpha_limit, color="0.4", ls=":")
        ax[0].text(alpha_limit, 0.5, "slowest unobservable mode:\nno design beyond ",
                   transform=ax[0].get_xaxis_transform(), va="center", ha="right", fontsize=7,
                   color="0.3")
    ax[0].set_yscale("log")
    ax[0].yaxis.set_major_locator(mticker.LogLocator(subs=(1.0, 2.0, 5.0)))
    ax[0].yaxis.set_major_formatter(mticker.FormatStrFormatter("%g"))
    ax[0].yaxis.set_minor_formatter(mticker.NullFormatter())
    ax[0].set_xlim(alphas.min() - 0.05, alphas.max() + 0.05)
    ax[0].set(xlabel=r"decay rate $\alpha$ [1/s]", ylabel=r"certified $L_2$ gain $\gamma$ [-]",
              title=r"best certified $\gamma$ (no marker: infeasible)")
    ax[0].legend(fontsize=8, loc="upper left", bbox_to_anchor=(0.0, -0.18), ncol=2, frameon=False)
    cmap = plt.get_cmap("cividis").with_extremes(bad="0.8")   # grey: no certified solution
    im = ax[1].imshow(np.ma.masked_invalid(ratio.T), origin="lower", aspect="auto", cmap=cmap,
                      vmin=min(0.9, np.nanmin(ratio)) if np.isfinite(ratio).any() else 0.9,
                      vmax=1.0)
    for i in range(len(alphas)):
        for j in range(len(phis)):
            fa, fb = fm["feasible_a"][i, j], fm["feasible_b"][i, j]
            lab = "both" if fa and fb else "(b) only" if fb else "(a) only" if fa else "none"
            val = f"{ratio[i, j]:.4f}\n" if np.isfinite(ratio[i, j]) else ""
            ax[1].text(i, j, val + lab, ha="center", va="center", fontsize=9,
                       color="k" if np.isfinite(ratio[i, j]) and ratio[i, j] > 0.95 else "w"
                       if np.isfinite(ratio[i, j]) else "k")
            if phi_bound is not None and phis[j] < phi_bound * (1 - 1e-6):
                ax[1].add_patch(plt.Rectangle((i - 0.5, j - 0.5), 1, 1, fill=False, hatch="//",
                                              ec="0.5", lw=0))
    ax[1].set_xticks(range(len(alphas)), [f"{a:g}" for a in alphas])
    ylabels = [f"{p:.3g}" + ("\n(violates A2)" if phi_bound is not None
                             and p < phi_bound * (1 - 1e-6) else "\n(derived)"
                             if phi_bound is not None and abs(p - phi_bound) <= 1e-6 * phi_bound
                             else "") for p in phis]
    ax[1].set_yticks(range(len(phis)), ylabels)
    ax[1].set(xlabel=r"decay rate $\alpha$ [1/s]", ylabel=r"bound $\varphi$ on $|\dot h_i|$ [1/s]",
              title=r"$\gamma_b/\gamma_a$ [-] and feasible designs per cell")
    ax[1].grid(False)
    fig.colorbar(im, ax=ax[1], label=r"$\gamma_b/\gamma_a$ [-] (grey: none feasible)")
    return fig


# ------------------------------------------------------------------ teaching figures -----
def fig_fault_live(model: ul.UncertainLateralTS, gains: uio.UIOGains, offset: float,
                   noise: float, t_end: float = 11.0, seed: int = 0):
    """Live figure of the notebook: the fault estimate [rad] of design ``gains`` on a fresh
    run with a fault of size ``offset`` [rad] (plus the 0.005 rad sine) from ``P.t_fault`` and
    sensor noise ``noise`` x the nominal standard deviations, beside the raw residual
    ``y_gyro - y_wheel`` (= f + noise: the measurement the fault estimate filters). The gains
    stay those designed for the nominal noise. ``t_end`` [s]: a short run (one redraw < 1 s)."""
    m = dataclasses.replace(model, D_w=model.D_w * noise)
    sc = sn.make_scenario(m, t_end, P.dt, P.t_fault, P.x0_true, seed=seed,
                          fault_kw={"offset": offset, "amp": P.fault_amp})
    ev = sn.evaluate(gains, sc, m)
    t, res = sc["t"], sc["y"][:, 0] - sc["y"][:, 1]
    fig, ax = plt.subplots(figsize=(8.5, 3.4))
    ax.plot(t, res, color="0.75", lw=0.5, label=r"residual $y_{gyro} - y_{wheel}$")
    ax.plot(t, sc["f"], color=TRUTH, label="true fault $f$")
    ax.plot(t, ev["Xhat"][:, 2], color=color("elyoussfi2020/theorem2"), lw=1.4,
            label=r"UIO (b) estimate $\hat f$")
    lim = max(0.01, 1.5 * abs(offset) + 2 * P.fault_amp)
    ax.set(xlabel="t [s]", ylabel="fault [rad]", xlim=(P.t_fault - 2, t_end), ylim=(-lim, lim),
           title=f"fault {offset:+.3f} rad, noise x {noise:g}: fault RMSE after the onset "
                 f"{ev['rmse_f']:.2g} rad")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    return fig


def animate_convergence(sim: dict, model: ul.UncertainLateralTS, t_show: float = 3.0,
                        frames: int = 25):
    """Animation (:func:`teaching.animation`) of the v_y estimate of (b) converging in the
    noise-free run over the first ``t_show`` s: top, the true v_y, the estimate and the
    open-loop model; bottom, ``|e_vy|`` [m/s] on a log axis between the two open-loop decay
    envelopes ``|e_vy(0)| exp([A_i]_11 t)`` (no gain moves them: v_y is unobservable)."""
    from vehicle_observers.results import teaching

    sc0, ev0 = sim["sc0"], sim["ev0"]["b"]
    m = np.flatnonzero(sc0["t"] <= t_show)[::10]          # every 10th sample: small frames
    t, vy, vh = sc0["t"][m], sc0["X"][m, 0], ev0["Xhat"][m, 0]
    e = np.abs(ev0["err"][m, 0])
    fig, ax = plt.subplots(2, 1, figsize=(5.5, 3.8), sharex=True)
    ax[0].plot(t, vy, color=TRUTH, label="true $v_y$")
    ax[0].plot(t, sim["X_openloop"][m, 0], color="0.6", ls=":", label="open-loop model")
    (l_est,) = ax[0].plot([], [], color=color("elyoussfi2020/theorem2"), lw=1.6,
                          label=r"UIO (b) $\hat v_y$")
    ax[0].set(ylabel="$v_y$ [m/s]", title="UIO (b): the unmeasured $v_y$ converging")
    ax[0].legend(loc="lower right", fontsize=7)
    for A, ls in zip(model.A, ("--", "-.")):
        ax[1].plot(t, e[0] * np.exp(A[0, 0] * t), color="0.5", ls=ls, lw=0.8,
                   label=rf"$|e(0)|\,e^{{{A[0, 0]:.2f}t}}$")
    (l_err,) = ax[1].plot([], [], color=color("elyoussfi2020/theorem2"), lw=1.6,
                          label=r"$|v_y - \hat v_y|$")
    ax[1].set(yscale="log", ylim=(1e-5, 1.0), xlabel="t [s]", ylabel="|error| [m/s]")
    ax[1].legend(loc="lower left", fontsize=7)
    fig.tight_layout()
    idx = teaching.frame_indices(len(t), frames)

    def update(i):
        k = idx[i]
        l_est.set_data(t[:k], vh[:k])
        l_err.set_data(t[:k], np.maximum(e[:k], 1e-12))
        return l_est, l_err

    with plt.rc_context({"savefig.dpi": 60}):   # the frames' resolution (to_jshtml saves them)
        return teaching.animation(fig, update, len(idx))
