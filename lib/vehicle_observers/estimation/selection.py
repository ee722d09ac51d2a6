"""One selection rule for every car: which model terms, which noise, and whether to trust it.

Everything here reads the **measured** channels only (``t, v_x, delta, r, a_y``) and the
vehicle file; the reference ``v_y`` is never read, so the same call applies unchanged to
every dataset.

Tuning (:func:`fit_terms`): for a set of terms of :mod:`vehicle_observers.baselines.adaptive`,
maximum likelihood of the filter's innovations of the measured channels over ``log10`` of
its noise intensities (``q_vy, q_r, R_r, R_ay`` always; ``q_b``, ``q_d``, ``q_k`` with the
bias, bank and stiffness terms), the accelerometer gain ``g_ay`` (roll term) and the blend
weight ``w_max`` (blend term); Nelder-Mead in a box, the measurement variances floored at
half the channels' white-noise variance (:func:`~vehicle_observers.data.identification.
white_noise_std`), on the tuning window (:func:`~vehicle_observers.estimation.kalman_runs.
tuning_window`: the first 120 s in motion) thinned to 100 Hz.

Selection (:func:`select`): greedy forward selection over :data:`~vehicle_observers.baselines.
adaptive.TERM_NAMES` by the Bayesian information criterion of the innovations,
``BIC = 2 NLL + p ln N`` (``p`` free parameters, ``N`` samples): a term is added when it
lowers the BIC by more than :data:`MIN_BIC_GAIN` and does not make the innovations less
white (Ljung-Box ``Q`` of the normalised innovations, Mehra 1970, summed over the channels,
may grow by at most :data:`MAX_Q_GROWTH`). The table of every candidate is kept.

A candidate whose estimate leaves the model's range (:func:`plausible`) is never added.

Uncertainty (:func:`vy_std`): the filter's ``v_y`` variance (with the vehicle file's
stiffness box as Schmidt "consider" states) scaled by the innovation consistency of the
tuning window (``mean NIS / m`` when above 1: covariance matching) times the integrated
autocorrelation time of the normalised innovations by batch means over :data:`BATCH_S`
(:attr:`Selection.inflation`), plus a sideslip floor ``(v_x tan BETA_FLOOR)^2`` for what no
lateral model here holds (wheel alignment, ply steer, tyre conicity: a constant sideslip
offset the measured channels cannot see).

Verdict (:func:`verdict`): ``uninformative`` when the estimate does not stand out of its own
uncertainty (RMS of ``v_y`` estimate below :data:`MIN_SIGNAL_TO_STD` times the RMS of its
std, or its 2-sigma band containing ``v_y = 0`` on more than
:data:`~vehicle_observers.estimation.calibration.ZERO_COVERED` of the rows: the estimate
cannot be told from ``v_y = 0``), or when the log has no a_y channel and the yaw rate alone
does not identify the axle stiffnesses
(:func:`~vehicle_observers.data.identification.identify_stiffness`); ``informative``
otherwise. One line, also in ``Trajectory.info["verdict"]``; an uninformative line says that
``v_y = 0`` is expected to do as well. The std judged is the calibrated one
(:mod:`vehicle_observers.estimation.calibration`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from vehicle_observers.baselines import adaptive as AD
from vehicle_observers.baselines.smoother_check import ljung_box
from vehicle_observers.data.identification import white_noise_std
from vehicle_observers.data.logs import DriveLog
from vehicle_observers.estimation.calibration import (
    BETA_FLOOR,  # noqa: F401  (constant-sideslip floor [rad], 0.1 deg; used by vy_std)
    MIN_SIGNAL_TO_STD,  # noqa: F401  (informative when RMS(v_y) >= this x RMS(std))
)
from vehicle_observers.models.road import body_roll_ay, lateral_gravity

#: BIC decrease a term must bring to be added
MIN_BIC_GAIN = 10.0
#: relative growth of the summed Ljung-Box Q a term may cause and still be added
MAX_Q_GROWTH = 0.10
#: batch length [s] of the innovation autocorrelation time (:func:`batch_means_iact`)
BATCH_S = 0.5
#: thinning rate of the tuning window [Hz]
TUNE_RATE_HZ = 100.0
#: box of the ML search: log10 of the intensities, linear g_ay and w_max
BOUNDS = {"q_vy": (-8.0, 1.0), "q_r": (-8.0, 0.0), "q_b": (-8.0, 0.0), "q_d": (-8.0, 0.0),
          "q_k": (-8.0, -1.0), "R_r": (-10.0, 0.0), "R_ay": (-6.0, 2.0),
          "ay_gain": (0.7, 1.5), "w_max": (0.0, 1.0)}
LINEAR = ("ay_gain", "w_max")


@dataclass
class Selection:
    """Result of :func:`select`: the chosen ``terms`` and ``tuning``, the candidates table
    (``rows``: terms, nll, bic, q_white, accepted), the innovation consistency ``nis_ratio``
    (mean NIS / channels on the window), ``use_ay`` and the window size."""

    terms: AD.Terms
    tuning: AD.AdaptiveTuning
    rows: list = field(default_factory=list)
    nis_ratio: float = 1.0
    use_ay: bool = True
    samples: int = 0
    iact: float = 1.0

    @property
    def inflation(self) -> float:
        """Variance factor of the reported v_y std: ``max(1, NIS ratio) x`` the integrated
        autocorrelation time of the normalised innovations (coloured innovations: the
        model error persists over ``iact`` samples, and the filter's covariance, computed as
        if it were white, is too small by about that factor)."""
        return max(1.0, self.nis_ratio) * max(1.0, self.iact)

    def summary(self) -> str:
        return (f"terms {self.terms} chosen by BIC of the measured-channel innovations on "
                f"{self.samples} samples; g_ay {self.tuning.ay_gain:.3f}; NIS ratio "
                f"{self.nis_ratio:.2f}")


def _free(terms: AD.Terms, use_ay: bool) -> list[str]:
    out = ["q_vy", "q_r", "R_r"] + (["R_ay"] if use_ay else [])
    out += [n for n, t in (("q_b", terms.bias), ("q_d", terms.bank), ("q_k", terms.stiffness),
                           ("ay_gain", terms.roll), ("w_max", terms.blend)) if t]
    return out


def thin(log: DriveLog, rate_hz: float = TUNE_RATE_HZ) -> DriveLog:
    """Every n-th sample so that the rate is at most ``rate_hz`` (measured channels and the
    bank column only: :func:`vehicle_observers.baselines.kalman.thin`)."""
    from vehicle_observers.baselines.kalman import thin as thin_every

    every = max(1, int(np.floor(1.0 / (log.dt * rate_hz) + 1e-9)))
    return replace(thin_every(log, every), source=log.source)


def _arrays(log: DriveLog):
    from vehicle_observers.data.logs import despike

    d, _ = despike(np.asarray(log.delta, float), 0.1)
    ay = np.zeros(len(log)) if log.ay is None else log.ay
    tilt = body_roll_ay(log)              # a roll column: the body's tilt of the sensor
    return log.t, log.vx, d, log.yaw_rate, ay if tilt is None else ay - tilt


def fit_terms(win: DriveLog, params, terms: AD.Terms, rel: float, use_ay: bool,
              start: AD.AdaptiveTuning | None = None, maxiter: int = 250):
    """ML tuning of ``terms`` on ``win`` (module docstring). Returns ``(tuning, nll,
    p_free, result of the pass)``."""
    from scipy.optimize import minimize

    start = start or AD.AdaptiveTuning(rel=rel)
    floors = {"R_r": 0.5 * white_noise_std(win.yaw_rate) ** 2}
    if use_ay:
        floors["R_ay"] = 0.5 * white_noise_std(win.ay) ** 2
    start = replace(start, rel=rel, **{k: max(getattr(start, k), 2 * v) for k, v in floors.items()})
    names = _free(terms, use_ay)
    lo, hi = [], []
    for n in names:
        a, b = BOUNDS[n]
        if n in floors:
            a = min(max(a, math.log10(max(floors[n], 1e-300))), b - 0.5)
        lo.append(a)
        hi.append(b)
    z0 = np.array([getattr(start, n) if n in LINEAR else math.log10(getattr(start, n))
                   for n in names])
    z0 = np.clip(z0, lo, hi)
    arr = _arrays(win)
    gy = lateral_gravity(win)

    def tun(z):
        kw = {n: (float(v) if n in LINEAR else float(10.0 ** v)) for n, v in zip(names, z)}
        return replace(start, **kw)

    def f(z):
        obs = AD.AdaptiveEKF(params, terms, tun(z), use_ay)
        v = obs.filter(*arr, gy=gy)["nll"]
        return v if np.isfinite(v) else 1e300

    sim = [z0]
    for i in range(len(z0)):
        z = z0.copy()
        st = 0.1 if names[i] in LINEAR else 0.5
        z[i] += st if z0[i] + st <= hi[i] else -st
        sim.append(z)
    res = minimize(f, z0, method="Nelder-Mead", bounds=list(zip(lo, hi)),
                   options={"maxiter": maxiter, "xatol": 1e-2, "fatol": 0.05,
                            "initial_simplex": np.array(sim)})
    best = tun(res.x)
    best = replace(best, source=f"ML on measured channels ({len(win)} samples, terms {terms}; "
                                f"nll={res.fun:.6g})")
    out = AD.AdaptiveEKF(params, terms, best, use_ay).filter(*arr, gy=gy)
    return best, float(res.fun), len(names), out


def _q_white(out, use_ay: bool, skip: int = 50) -> float:
    nu = out["nu"][skip:]
    q = ljung_box(nu[:, 0])["Q"]
    if use_ay:
        q += ljung_box(nu[:, 1])["Q"]
    return float(q)


def select(log: DriveLog, vehicle, use_ay: bool | None = None, window: DriveLog | None = None,
           candidates=AD.TERM_NAMES, maxiter: int = 250) -> Selection:
    """Greedy forward selection of the terms (module docstring) on the tuning window of
    ``log`` (or ``window``). Terms the vehicle file's ``[terms]`` table sets are fixed (on
    or off) and not tried. The candidates are compared without consider states (the
    likelihood of a model is not to be penalised for the uncertainty it declares); the
    chosen terms are then re-tuned with the vehicle file's stiffness box (``uncertainty.
    stiffness_rel``, 0 when absent) as consider states unless the stiffness is estimated,
    and that filter is the one reported (last row of the table)."""
    from vehicle_observers.estimation.kalman_runs import tuning_window

    use_ay = (log.ay is not None) if use_ay is None else bool(use_ay)
    win = thin(window if window is not None else tuning_window(log, vehicle))
    rel = float(vehicle.uncertainty.get("stiffness_rel", 0.0))
    params = vehicle.params
    fixed = getattr(vehicle, "terms", {}) or {}
    cur = AD.Terms(**{k: True for k, v in fixed.items() if v})
    candidates = [c for c in candidates if c not in fixed]
    tun, nll, p, out = fit_terms(win, params, cur, rel, use_ay, maxiter=maxiter)
    N = len(win)
    bic = 2 * nll + p * math.log(N)
    qw = _q_white(out, use_ay)
    rows = [{"terms": str(cur), "nll": nll, "bic": bic, "q_white": qw, "accepted": True,
             "plausible": plausible(out, win, vehicle)}]
    cands = [c for c in candidates if use_ay or c in ("bank", "stiffness")]
    while cands:
        trial = []
        for c in cands:
            t_ = cur.with_(**{c: True})
            tu, nl, pp, o = fit_terms(win, params, t_, rel, use_ay, start=tun, maxiter=maxiter)
            b = 2 * nl + pp * math.log(N)
            q = _q_white(o, use_ay)
            ok = (bic - b > MIN_BIC_GAIN) and q <= qw * (1 + MAX_Q_GROWTH) \
                and plausible(o, win, vehicle)
            row = {"terms": str(t_), "nll": nl, "bic": b, "q_white": q, "accepted": False,
                   "plausible": plausible(o, win, vehicle), "ok": ok}
            rows.append(row)
            trial.append((b, c, tu, q, o, row))
        good = [x for x in trial if x[5]["ok"]]
        if not good:
            break
        b, c, tu, q, o, row = min(good, key=lambda x: x[0])
        row["accepted"] = True
        cur, tun, bic, qw, out = cur.with_(**{c: True}), tu, b, q, o
        cands.remove(c)
    for r in rows:
        r.pop("ok", None)
    if rel > 0 and not cur.stiffness:
        # the chosen terms with the stiffness box as consider states: the reported filter
        cur = cur.with_(consider=True)
        tun, nll, p, out = fit_terms(win, params, cur, rel, use_ay, start=tun, maxiter=maxiter)
        rows.append({"terms": str(cur), "nll": nll, "bic": 2 * nll + p * math.log(N),
                     "q_white": _q_white(out, use_ay), "accepted": True,
                     "plausible": plausible(out, win, vehicle)})
    nis = out["nis"][50:]
    nis_ratio = float(np.mean(nis) / (2 if use_ay else 1)) if len(nis) else 1.0
    nu = out["nu"][50:]
    tau = max(batch_means_iact(nu[:, j], BATCH_S / float(np.median(np.diff(win.t))))
              for j in range(2 if use_ay else 1))
    return Selection(cur, tun, rows, nis_ratio, use_ay, N, tau)


def batch_means_iact(x, batch: float) -> float:
    """Integrated autocorrelation time of ``x`` by batch means: ``B var(batch means) /
    var(x)`` with batches of ``B = round(batch)`` samples (Flegal & Jones, Ann. Stat. 38(2),
    2010): 1 for a white sequence, larger when the sequence is coloured at periods up to
    ``B`` samples."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    B = max(1, int(round(batch)))
    n = len(x) // B
    if n < 10:
        return 1.0
    x = x[: n * B] - x[: n * B].mean()
    v = float(np.var(x))
    return float(B * np.var(x.reshape(n, B).mean(axis=1)) / v) if v > 0 else 1.0


def plausible(out, win: DriveLog, vehicle) -> bool:
    """The filter stays where its model holds on the window: ``|atan2(v_y, v_x)|`` never
    above the vehicle file's ``uncertainty.slip_max_deg`` (default 8 deg). A filter that
    leaves it has locked onto the saturated-tyre branch (measured channels fitted, v_y
    meaningless)."""
    lim = math.radians(vehicle.uncertainty.get("slip_max_deg", 8.0))
    return bool(np.all(np.abs(np.arctan2(out["X"][:, 0], win.vx)) <= lim))


def vy_std(Pd_vy, vx, inflation: float, beta_floor: float = BETA_FLOOR) -> np.ndarray:
    """Reported ``v_y`` std [m/s] (module docstring): ``sqrt(inflation P_vy +
    (v_x tan beta_floor)^2)`` (``inflation``: :attr:`Selection.inflation`)."""
    return np.sqrt(max(1.0, inflation) * np.maximum(Pd_vy, 0.0)
                   + (np.abs(vx) * math.tan(beta_floor)) ** 2)


def verdict(vy, std, log: DriveLog, vehicle, use_ay: bool, mask=None) -> dict:
    """Identifiability verdict from measured channels and the estimate's own uncertainty
    (module docstring; computed by :func:`vehicle_observers.estimation.calibration.
    identifiability`). Returns ``{"verdict", "line", "signal_to_std", "zero_covered",
    "stiffness"}``."""
    from vehicle_observers.estimation.calibration import identifiability

    return identifiability(vy, std, log, vehicle, use_ay, mask)
