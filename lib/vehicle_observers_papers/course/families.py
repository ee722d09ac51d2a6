"""The observer families of the course side by side, run on one common manoeuvre and the real log.

:data:`FAMILIES` describes each family (what it estimates, what it needs, its guarantee, its
knobs, the notebooks that teach it) and names the registered estimators
(:func:`vehicle_observers.estimation.available`) that represent it on a drive log. The families
that do not estimate a car's lateral velocity from a drive log (the DMVT observer of a bicycle,
the sliding-mode observers of tyre forces and road, the fault-estimating UIO) say why in
``no_vy``; their cost per step comes from their own observer classes (:func:`family_costs`).

Data (:func:`common_manoeuvre`, :func:`real_log`):

* the common manoeuvre: a sine with dwell at 17 m/s (:func:`vehicle_observers.data.scenarios.
  sine_with_dwell`, seeded, 1 kHz, truth and sensors of the Yacine 2015 emulation, camera
  included) with :data:`LEAD_S` s of straight driving before the steering starts, so that the
  score window after the :data:`TRANSIENT_S` s start transient holds the whole manoeuvre;
  vehicle file ``yacine2015``;
* the real log: the Revs Program Ferrari 250 LM track run (``data/revs_250lm_2014``, 100 Hz,
  INS reference of ``v_y``), vehicle file ``revs250lm``; quick mode scores its first
  :data:`QUICK_WINDOW_S` s, full mode the whole run.

The Kalman filters get the maximum-likelihood noise tuning the command line uses
(:func:`vehicle_observers.estimation.kalman_runs.kalman_tuning`, first 120 s of the log's first
stretch in motion): computed once per log and passed to each of them, so ``ekf``, ``ukf`` and
``rts`` share it, and on the real log the quick window gets the tuning of the whole log (the
estimate over the window is then the whole-log estimate cut to the window: the filters are
causal).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from vehicle_observers import estimation as EST
from vehicle_observers.core.metrics import rmse
from vehicle_observers.data.logs import DriveLog, load_revs
from vehicle_observers.data.scenarios import sine_with_dwell
from vehicle_observers.estimation import kalman_runs as KR
from vehicle_observers.models.vehicle import load_vehicle

#: straight driving before the sine with dwell starts [s]
LEAD_S = 3.0
#: start transient left out of every score [s]
TRANSIENT_S = 2.0
#: the first seconds of the real log scored in quick mode [s]
QUICK_WINDOW_S = 120.0
#: references without measurement feedback (hatched in :func:`fig_rmse`)
REFERENCES = ("open-loop-linear", "vy-zero")
#: registered estimators of the comparison, in the order of the figure
ESTIMATORS = ("ts-yacine2015", "interval-ifqir2017", "ekf", "ukf", "rts", "open-loop-linear")


#: the observers without a registry entry whose cost per step is measured (:func:`family_costs`)
DMVT = "DMVT observer (6), Ichalal 2011 bicycle"
SMO = "force sliding-mode observer (10), boundary layer"
HOSMD = "Levant differentiator, order 3"
UIO = "relaxed UIO, Theorem 2"


@dataclass(frozen=True)
class Family:
    """One observer family: ``name``; ``notebooks`` that teach it; ``estimates``; ``needs``
    (sensors and model); ``guarantee``; ``knobs`` (course notation); ``estimators``: registry
    names run on the drive logs; ``no_vy``: why the family has no ``v_y`` score (empty when
    it has one); ``components``: the observers of a family without a registry entry whose cost
    per step :func:`family_costs` measures."""

    name: str
    notebooks: str
    estimates: str
    needs: str
    guarantee: str
    knobs: str
    estimators: tuple[str, ...] = ()
    no_vy: str = ""
    components: tuple[str, ...] = ()


FAMILIES: tuple[Family, ...] = (
    Family("TS/LMI observer (Yacine 2015)", "01, 02",
           r"$v_y$, $r$, $F_f$, $F_r$, road curvature $\kappa$",
           r"gyro $r$, steering $\delta$, speed $v_x$, camera $y_L$, $\psi_L$; yaw-drift model, "
           "Pacejka tyres with relaxation, exact 8-rule TS form",
           r"Theorem 1: exponential error bound (34) with decay rate $\lambda$, once the premise "
           "differentiators have converged (ISS in the premise error)",
           r"decay rate $\lambda$, pole disk, differentiator constant $L$", ("ts-yacine2015",)),
    Family("interval observer (Ifqir 2017)", "03, 08",
           r"guaranteed bounds $\underline v_y \le v_y \le \overline v_y$, "
           r"$\underline r \le r \le \overline r$",
           r"gyro $r$, steering $\delta$, speed $v_x$; LPV bicycle, cornering stiffness in a box "
           r"$\pm\Delta_c$, speed bands",
           "enclosure at every time while the truth stays in the box and the noise within its "
           "bound (Theorem 1); ISS width (Theorem 2)",
           r"box half-width $\Delta_c$, speed bands, Metzler shift $\epsilon_M$, gain $\gamma$",
           ("interval-ifqir2017",)),
    Family("DMVT observer (Ichalal 2011)", "04",
           "the states of an autonomous bicycle (roll angle, roll rate, heading states)",
           "two angle sensors of the bicycle; TS model with unmeasured premises, Jacobian bounds",
           "exponential convergence where the DMVT bounds of the Jacobian hold (LMIs (23)); "
           "poles in the region (35)-(36)",
           r"pole region $a$, $R$; number of Jacobian vertices",
           no_vy="a bicycle's roll dynamics, not a car's lateral velocity",
           components=(DMVT,)),
    Family("sliding-mode observer and differentiator (Rabhi 2004, Levant)", "02, 05",
           r"tyre forces $F_x$, $F_y$ per axle, road profile under each wheel; derivatives of a "
           "signal",
           r"$v_x$, $v_y$, $r$, wheel speeds and torques (forces); suspension sensors (road); a "
           r"bound $L$ on the $(n+1)$-th derivative (differentiator)",
           "finite-time reaching of the sliding surfaces, asymptotic force convergence; exact "
           "derivatives in finite time without noise (differentiator)",
           r"switching gains $\lambda_i$, boundary layer $\phi$, adaptation gain; Lipschitz "
           r"constant $L$",
           no_vy=r"reads $v_y$ as a measurement (Rabhi 2004 (9)) and estimates forces and road",
           components=(SMO, HOSMD)),
    Family("unknown-input observer (El Youssfi 2020)", "06",
           r"$v_y$, $r$ and an actuator + sensor fault $f$",
           r"gyro $r$ and a second yaw-rate source (wheel speeds), steering $\delta$, one "
           "constant speed; uncertain TS lateral model with fuzzy tyres",
           r"the error is decoupled from the model uncertainty; $\mathcal L_2$ gain $\gamma$ from "
           r"fault rate and noise, decay rate $\lambda$ (relaxed LMIs)",
           r"decay rate $\lambda$, bound $\varphi$ on the membership rates, slack $\mu$, pole disk",
           no_vy="needs two yaw-rate sources at one constant speed: not registered for drive logs",
           components=(UIO,)),
    Family("EKF / UKF / RTS smoother (baselines)", "07, 08",
           r"$v_y$, $r$, $a_y$ offset $b_{a_y}$, with a standard deviation",
           r"gyro $r$, steering $\delta$, speed $v_x$, lateral acceleration $a_y$ if logged; "
           "yaw-drift model without relaxation, Pacejka tyres",
           "none in general (optimal for a linear Gaussian model); the RTS smoother is offline",
           r"noise $Q$, $R$ (maximum likelihood of the innovations), initial covariance $P_0$",
           ("ekf", "ukf", "rts")),
    Family("open-loop bicycle (reference)", "07, 08",
           r"$v_y$, $r$ from the steering alone",
           r"steering $\delta$, speed $v_x$; linear bicycle of the vehicle file",
           "none: no measurement feedback; the score an observer must beat",
           "-", ("open-loop-linear",)),
)


def common_manoeuvre(seed: int = 0) -> DriveLog:
    """The common manoeuvre: a seeded sine with dwell at 17 m/s, :data:`LEAD_S` s of straight
    driving first (1 kHz, truth and camera of the Yacine 2015 emulation)."""
    return sine_with_dwell(seed=seed, t_before=LEAD_S)


def real_log(quick: bool = False) -> DriveLog:
    """The Revs log, whole (full mode) or its first :data:`QUICK_WINDOW_S` s (quick)."""
    log = load_revs()
    return log.segment(log.t[0], log.t[0] + QUICK_WINDOW_S) if quick else log


def score_mask(log: DriveLog, transient_s: float = TRANSIENT_S) -> np.ndarray:
    """Samples scored: after the first ``transient_s`` seconds of ``log``."""
    return log.t - log.t[0] >= transient_s


def run(names, log: DriveLog, vehicle, tuning=None) -> dict:
    """Run the registered estimators ``names`` on ``log`` with ``vehicle`` (a shipped name or a
    :class:`~vehicle_observers.models.vehicle.Vehicle`); the Kalman noise ``tuning`` is shared
    (``None``: the vehicle file's, else maximum likelihood on ``log`` once). Estimators that do
    not apply (a column the log lacks) are left out. Returns ``{name: Trajectory}``."""
    veh = load_vehicle(vehicle) if isinstance(vehicle, str) else vehicle
    out = {}
    for n in names:
        spec = EST.get(n)
        try:
            spec.check(log, veh)
        except Exception:  # noqa: BLE001 - not applicable to this log (named in the table)
            continue
        if tuning is None and n in KR_NAMES:
            tuning = KR.kalman_tuning(log, veh)[0]
        out[n] = spec.run(log, veh, tuning=tuning)
    return out


#: estimators that read the Kalman noise tuning
KR_NAMES = ("ekf", "ekf-filterpy", "ukf", "ukf-filterpy", "rts")


def vy_rmse(estimates: dict, log: DriveLog, mask=None) -> dict:
    """``{name: v_y RMSE [m/s]}`` of ``estimates`` against the log's ``v_y`` reference on
    ``mask`` (default every sample)."""
    m = np.ones(len(log), bool) if mask is None else mask
    return {n: rmse(e.columns["vy_mps"], log.vy, m) for n, e in estimates.items()}


def study(seed: int = 0, quick: bool = False, names=ESTIMATORS,
          transient_s: float = TRANSIENT_S) -> dict:
    """The comparison of notebook 00: every estimator of ``names`` on the common manoeuvre
    and on the real log. Returns ``{"logs": {"swd", "revs"}, "estimates": {dataset: {name:
    Trajectory}}, "rmse": {dataset: {name: m/s}}, "tunings": {dataset: KalmanTuning}}``;
    ``swd`` is scored after ``transient_s`` s, ``revs`` on every sample of the window."""
    swd = common_manoeuvre(seed)
    revs_all = load_revs()
    tun = {"swd": KR.kalman_tuning(swd, load_vehicle("yacine2015"))[0],
           "revs": KR.kalman_tuning(revs_all, load_vehicle("revs250lm"))[0]}
    revs = real_log(quick)
    logs = {"swd": swd, "revs": revs}
    ests = {"swd": run(names, swd, "yacine2015", tun["swd"]),
            "revs": run(names, revs, "revs250lm", tun["revs"])}
    scores = {"swd": vy_rmse(ests["swd"], swd, score_mask(swd, transient_s)),
              "revs": vy_rmse(ests["revs"], revs)}
    return {"logs": logs, "estimates": ests, "rmse": scores, "tunings": tun,
            "transient_s": float(transient_s)}


def rescored(res: dict, transient_s: float) -> dict:
    """``res`` with the common manoeuvre scored after ``transient_s`` instead (the estimates are
    not re-run; the real log's scores are kept), for the live figure of notebook 00."""
    swd = res["logs"]["swd"]
    rm = dict(res["rmse"], swd=vy_rmse(res["estimates"]["swd"], swd, score_mask(swd, transient_s)))
    return dict(res, rmse=rm, transient_s=float(transient_s))


def metrics(res: dict) -> dict:
    """``{name: (value, unit, note)}`` for :meth:`Report.record`: the ``v_y`` RMSE of every
    estimator on each dataset (``<dataset>.<estimator>.rmse_vy``) and the scored durations."""
    label = {"swd": f"sine with dwell after {res['transient_s']:g} s", "revs": "Revs log window"}
    out = {}
    for d, sc in res["rmse"].items():
        for n, v in sc.items():
            out[f"{d}.{n}.rmse_vy"] = (v, "m/s", f"v_y RMSE of {n}, {label[d]}")
    out["revs.window_s"] = (res["logs"]["revs"].duration, "s", "scored duration of the Revs log")
    out["swd.duration_s"] = (res["logs"]["swd"].duration, "s", "duration of the common manoeuvre")
    return out


def rmse_names(res: dict) -> list[str]:
    """Names of the ``v_y`` RMSE metrics of :func:`metrics`, manoeuvre first."""
    return [f"{d}.{n}.rmse_vy" for d in ("swd", "revs") for n in res["rmse"][d]]


def table(res: dict, costs: dict | None = None) -> list[dict]:
    """One row per estimator or timed observer of each family: the family's description once,
    the cost per step [us] (from ``costs``: :func:`registry_costs` and :func:`family_costs`) and
    the ``v_y`` RMSE on both datasets (a family without a ``v_y`` score gets the reason)."""
    costs = costs or {}
    rows = []
    for f in FAMILIES:
        base = {"family": f.name, "notebooks": f.notebooks, "estimates": f.estimates,
                "needs": f.needs, "guarantee": f.guarantee, "knobs": f.knobs}
        for n in f.estimators or f.components:
            if f.estimators:
                sw = res["rmse"]["swd"].get(n, "not run")
                rv = res["rmse"]["revs"].get(n, "not run (needs a camera)"
                                             if "yL_m" in EST.get(n).needs else "not run")
            else:                                 # the reason once per family
                sw, rv = (f.no_vy, "-") if base["family"] else ("", "")
            rows.append({**base, "registry name / observer": n,
                         "cost [us/step]": costs.get(n, np.nan),
                         "RMSE v_y manoeuvre [m/s]": sw, "RMSE v_y Revs [m/s]": rv})
            base = {k: "" for k in base}          # the description once per family
    return rows


def registry_costs(res: dict, repeat: int = 3) -> dict:
    """``{estimator: us per step}`` on the common manoeuvre: each estimator of the study run
    ``repeat`` more times with the study's tuning, the best of its own loop timings
    (:attr:`Trajectory.us_per_step`, design excluded; the study's first run paid the numba
    cache load). Wall clock: never a committed metric."""
    log, tun = res["logs"]["swd"], res["tunings"]["swd"]
    veh = load_vehicle("yacine2015")
    out = {}
    for n, first in res["estimates"]["swd"].items():
        spec = EST.get(n)
        out[n] = min([first.us_per_step] + [spec.run(log, veh, tuning=tun).us_per_step
                                            for _ in range(repeat)])
    return out


def family_costs(log: DriveLog) -> dict:
    """``{observer: us per step}`` of the families without a registered estimator (their
    ``components``), each run on data of its own paper's setting (best of 3 runs after a
    warm-up; wall clock, never a committed metric): :data:`DMVT` on 1 s of the Ichalal 2011
    bicycle, :data:`SMO` on 2 s of the Rabhi 2004 manoeuvre, :data:`UIO` on 2 s of the El
    Youssfi 2020 scenario, and :data:`HOSMD` on the yaw rate of ``log``."""
    from vehicle_observers.core.timing import best_time
    from vehicle_observers.observers.differentiators import differentiate

    out = {}
    for name, fn in ((DMVT, _dmvt_run), (SMO, _smo_run), (UIO, _uio_run)):
        run_once, steps = fn()
        out[name] = best_time(run_once, 3, warmup=True)[0] / steps * 1e6
    sec = best_time(lambda: differentiate(log.t, log.yaw_rate, order=3, L=1.0), 3, warmup=True)[0]
    out[HOSMD] = sec / len(log) * 1e6
    return out


def _dmvt_run():
    from vehicle_observers.models import bicycle as b
    from vehicle_observers.models.ts import jacobian_ts_from_samples
    from vehicle_observers.observers import dmvt

    from vehicle_observers_papers.ichalal_2011 import constants as ic

    t = np.arange(0.0, 1.0, 1e-3)
    X, U = b.simulate(ic.params, t)
    z = b.ts_premises(X, U, ic.params)
    lo, hi = z.min(0), z.max(0)
    ts = b.bicycle_ts(ic.params, list(zip(lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo),
                                          strict=True)))
    des = dmvt.design_dmvt_observer(jacobian_ts_from_samples(b.jacobian(X, U, ic.params)).vertices,
                                    ic.C, r=1)
    obs = dmvt.DMVTObserver(np.repeat(des.L, ts.n_rules, axis=0), ts, ic.params, ic.C, 1e-3)
    Y, x0 = X @ ic.C.T, np.array([0.1, -0.1, 0.1, 0.5])
    return (lambda: obs.run(t, U[:, None], Y, x0)), len(t)


def _smo_run():
    from vehicle_observers.models import planar
    from vehicle_observers.observers import sliding_mode as smo

    from vehicle_observers_papers.rabhi_2004 import constants as R

    dt = R.dt_force
    man = planar.paper_manoeuvre(2.0, dt)
    X0 = planar.free_rolling_state(man.v0, R.planar)
    Y = planar.measurements(planar.simulate(X0, man.U, dt, R.planar))
    obs = smo.ForceObserver(smo.ForceObserverModel.from_params(R.planar),
                            R.force_gains.with_(mode="sat"), dt)
    return (lambda: obs.run(man.t, man.U, Y)), len(man.t)


def _uio_run():
    from vehicle_observers.observers import uio

    from vehicle_observers_papers.elyoussfi_2020 import constants as P
    from vehicle_observers_papers.elyoussfi_2020 import scenario as sn

    model = P.build_model()
    st = uio.structure(model)
    phi = uio.phi_bound(model, P.delta_dot_max, P.scale_fdot, P.tire_f.D, P.tire_r.D)["phi"]
    g = uio.design_relaxed(model, P.alpha_design, phi, P.mu_grid, st, radius=P.radius)
    sc = sn.make_scenario(model, 2.0, P.dt, 0.5, P.x0_true, seed=0)
    obs = uio.UIObserver(g, model, P.dt)
    return (lambda: obs.run(sc["t"], sc["delta"], sc["y"])), len(sc["t"])


def fig_rmse(res: dict):
    """Bar figure of the ``v_y`` RMSE of every estimator: the common manoeuvre (after the start
    transient) and the real log, one panel each, one colour per estimator
    (:func:`vehicle_observers.results.plotting.color`; the references without feedback,
    :data:`REFERENCES`, hatched), the legend beside the panels."""
    import matplotlib.pyplot as plt

    names = [n for n in ESTIMATORS if any(n in res["rmse"][d] for d in res["rmse"])]
    titles = {"swd": f"common manoeuvre: sine with dwell, 17 m/s\n(after {res['transient_s']:g} s, "
                     "truth of the emulation)",
              "revs": f"real log: Revs Ferrari 250 LM\n({res['logs']['revs'].duration:.0f} s, "
                      "INS reference)"}
    fig, (*axes, lax) = plt.subplots(1, 3, figsize=(10.5, 3.8),
                                     gridspec_kw={"width_ratios": (1.0, 1.0, 0.5)})
    handles = {}
    for ax, d in zip(axes, ("swd", "revs")):
        sc = res["rmse"][d]
        for j, n in enumerate(names):
            if n not in sc:
                ax.text(j, 0.02, "not run: no camera" if "yL_m" in EST.get(n).needs else "not run",
                        ha="center", va="bottom", fontsize=7, color="0.4", rotation=90,
                        transform=ax.get_xaxis_transform())
                continue
            handles[n] = ax.bar(j, sc[n], 0.7, color=colour(n), label=n,
                                hatch="//" if n in REFERENCES else None, edgecolor="0.3", lw=0.5)
            ax.text(j, sc[n], f"{sc[n]:.3g}", ha="center", va="bottom", fontsize=7)
        ax.set_xlim(-0.6, len(names) - 0.4)
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels([f"({j + 1})" for j in range(len(names))])
        ax.set_ylabel(r"$v_y$ RMSE [m/s]")
        ax.set_title(titles[d])
        ax.margins(y=0.15)
    lax.axis("off")                       # the legend's own panel: never over the bars
    lax.legend([handles[n] for n in names if n in handles],
               [f"({j + 1}) {n}" + (" (no feedback)" if n in REFERENCES else "")
                for j, n in enumerate(names) if n in handles],
               loc="center left", frameon=False, title="estimator")
    return fig


#: estimators left out of the time-series figure: on the common manoeuvre their curves lie on
#: the EKF's (their RMSE is in the bar figure)
HIDDEN = ("ukf", "rts")


def colour(name: str) -> str:
    """The estimator's colour (:func:`vehicle_observers.results.plotting.color`); a name without
    an entry of its own gets the fallback of its place in :data:`ESTIMATORS`, the same in every
    figure of this module."""
    from vehicle_observers.results import plotting

    return plotting.color(name, ESTIMATORS.index(name) if name in ESTIMATORS else 0)


def _series(res: dict, names=None):
    log = res["logs"]["swd"]
    names = [n for n in res["estimates"]["swd"] if n not in HIDDEN] if names is None else names
    ests = {n: res["estimates"]["swd"][n] for n in names if n in res["estimates"]["swd"]}
    return log, log.t - log.t[0], ests


def fig_vy_manoeuvre(res: dict):
    """The common manoeuvre in time: the true ``v_y`` with the study's estimates but
    :data:`HIDDEN` (the
    interval observer's guaranteed band shaded) and, below, each estimate's error, with the start
    transient (not scored) greyed."""
    import matplotlib.pyplot as plt
    from vehicle_observers.results import plotting

    log, t, ests = _series(res)
    fig, (ax, axe) = plt.subplots(2, 1, sharex=True, figsize=(9.0, 5.6),
                                  gridspec_kw={"height_ratios": (1.4, 1.0)})
    band = ests.get("interval-ifqir2017")
    if band is not None:
        ax.fill_between(t, band.columns["vy_lo_mps"], band.columns["vy_hi_mps"], alpha=0.25,
                        color=colour("interval-ifqir2017"), lw=0,
                        label="interval-ifqir2017: guaranteed band")
    ax.plot(t, log.vy, color=plotting.TRUTH, lw=1.6, label=r"truth $v_y$")
    for n, e in ests.items():
        style = {"ls": "--"} if n in REFERENCES else {"ls": ":"} if n == "interval-ifqir2017" else {}
        ax.plot(t, e.columns["vy_mps"], color=colour(n), **style,
                label=n + (": middle of the band" if n == "interval-ifqir2017" else ""))
        axe.plot(t, e.columns["vy_mps"] - log.vy, color=colour(n), **style)
    for a in (ax, axe):
        a.axvspan(0, res["transient_s"], color="0.9", zorder=0)
    lo, hi = np.percentile(log.vy, [0.5, 99.5])
    ax.set_ylim(lo - 0.5 * (hi - lo), hi + 0.5 * (hi - lo))     # the band starts at +-2 m/s
    ax.set_ylabel(r"$v_y$ [m/s]")
    ax.set_title("common manoeuvre: sine with dwell at 17 m/s (grey: start transient, not scored)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    axe.set_ylabel(r"$\hat v_y - v_y$ [m/s]")
    axe.set_xlabel("t [s]")
    keep = t >= res["transient_s"]
    err = max(np.max(np.abs(e.columns["vy_mps"][keep] - log.vy[keep])) for e in ests.values())
    axe.set_ylim(-1.1 * err, 1.1 * err)               # scaled after the start transient
    return fig


def animate_manoeuvre(res: dict, frames: int = 24):
    """An HTML player (:func:`vehicle_observers.results.teaching.animation`) revealing the
    manoeuvre over time: the truth, the EKF and the interval observer's band closing in."""
    import matplotlib.pyplot as plt
    from vehicle_observers.results import plotting
    from vehicle_observers.results.teaching import animation, frame_indices

    log, t, ests = _series(res, ("ekf", "interval-ifqir2017"))
    fig, ax = plt.subplots(figsize=(5.5, 2.6))
    ax.set_xlim(t[0], t[-1])
    lo, hi = np.percentile(log.vy, [0.5, 99.5])
    ax.set_ylim(lo - 0.5 * (hi - lo), hi + 0.5 * (hi - lo))
    ax.set_xlabel("t [s]")
    ax.set_ylabel(r"$v_y$ [m/s]")
    (truth,) = ax.plot([], [], color=plotting.TRUTH, lw=1.5, label="truth")
    (ekf,) = ax.plot([], [], color=colour("ekf"), label="ekf")
    band = ests["interval-ifqir2017"].columns
    holder = [ax.fill_between([], [], [], lw=0, alpha=0.3, color=colour("interval-ifqir2017"),
                              label="interval band")]
    ax.legend(loc="lower left", fontsize=7)
    fig.tight_layout()
    idx = frame_indices(len(t), frames)

    def update(i):
        k = idx[i]
        truth.set_data(t[:k], log.vy[:k])
        ekf.set_data(t[:k], ests["ekf"].columns["vy_mps"][:k])
        holder[0].remove()
        holder[0] = ax.fill_between(t[:k], band["vy_lo_mps"][:k], band["vy_hi_mps"][:k], lw=0,
                                    alpha=0.3, color=colour("interval-ifqir2017"))
        ax.set_title(f"t = {t[k - 1]:.1f} s: the interval band (shaded) and the EKF on the truth",
                     fontsize=8)
        return truth, ekf

    return animation(fig, update, len(idx))
