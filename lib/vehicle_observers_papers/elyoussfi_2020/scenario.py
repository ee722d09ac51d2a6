"""Scenario and metrics of notebook 06 (relaxed UIO, El Youssfi 2020 reconstruction): the
steering, fault and uncertainty signals of Sec. 5 (Figs. 3-7 analogues), the simulated faulty
vehicle and its sensors, the UIO and the EKF run on it, and the paper's error metrics (RMSE
after the fault, fault-estimation delay, peak onset errors). SI units; arrays (N, ...).
"""

from __future__ import annotations

import numpy as np
from vehicle_observers.baselines import uio_ekf as ub
from vehicle_observers.core.metrics import rmse
from vehicle_observers.models.uncertain_lateral import (
    UncertainLateralTS,
    simulate_truth,
    slip_front,
)
from vehicle_observers.observers import uio
from vehicle_observers.observers.uio import UIOGains


# ----------------------------------------------------------------------- metrics ---------
def fault_delay(t, f_hat, f, t_fault: float, band: float = 0.1, window: int = 1) -> float:
    """Fault-estimation delay [s]: time after ``t_fault`` from which ``|f_hat - f|`` stays
    within ``band * max|f|`` until the end (``nan`` if it never settles).

    ``window`` > 1 first averages the error over that many samples (centred moving mean),
    so that isolated sensor-noise spikes do not count as loss of tracking.
    """
    t, fh, f = (np.asarray(a, dtype=float) for a in (t, f_hat, f))
    if int(window) < 1:
        raise ValueError(f"window must be >= 1 sample, got {window}")
    m = t >= t_fault
    ref = band * float(np.max(np.abs(f[m])))
    err = fh[m] - f[m]
    if window > 1:
        err = np.convolve(err, np.ones(int(window)) / int(window), mode="same")
    bad = np.flatnonzero(np.abs(err) > ref)
    if len(bad) == 0:
        return 0.0
    if bad[-1] == m.sum() - 1:
        return float("nan")
    return float(t[m][bad[-1] + 1] - t_fault)


# ----------------------------------------------------------------------- scenario --------
def steering_signal(t):
    """Fig. 3 analogue (reconstruction): a sine of 0.05 rad at 0.25 Hz plus 0.02 rad at
    0.6 Hz with a 1 s smooth start [rad]."""
    t = np.asarray(t, dtype=float)
    env = np.clip(t, 0.0, 1.0) ** 2 * (3 - 2 * np.clip(t, 0.0, 1.0))
    return env * (0.05 * np.sin(2 * np.pi * 0.25 * t) + 0.02 * np.sin(2 * np.pi * 0.6 * t))


def fault_signal(t, t_fault: float, offset: float = 0.01, amp: float = 0.005,
                 freq: float = 0.5):
    """Time-varying fault (reconstruction of Sec. 5's "variant fault") [rad]: zero before
    ``t_fault``, then ``offset + amp sin(2 pi freq (t - t_fault))``."""
    t = np.asarray(t, dtype=float)
    return np.where(t >= t_fault, offset + amp * np.sin(2 * np.pi * freq * (t - t_fault)), 0.0)


def uncertainty_signal(t, seed: int = 0):
    """``F(t)`` of (10), ``|F| <= 1``: two sines with random phases from ``seed``."""
    rng = np.random.default_rng(seed)
    ph = rng.uniform(0, 2 * np.pi, 2)
    t = np.asarray(t, dtype=float)
    return 0.6 * np.sin(2 * np.pi * 0.7 * t + ph[0]) + 0.4 * np.sin(2 * np.pi * 1.3 * t + ph[1])


def make_scenario(model: UncertainLateralTS, t_end: float, dt: float, t_fault: float, x0,
                  seed: int = 0, noise: bool = True, pacejka=None, fault_kw=None) -> dict:
    """Simulate the faulty uncertain vehicle and its sensors (Sec. 5).

    Returns t (N,), delta (N,), f (N,), F (N,), X (N, 2) true ``[v_y, r]``, y (N, 2)
    measured (``C x + F_s f`` + noise ``D_w w`` with ``w ~ N(0, I)`` from ``seed``), h
    (N, 2) memberships of the true front slip angle (truth: for Assumption 2 checks and
    comparisons, never an observer input), hdot (N, 2) [1/s] by central differences,
    alpha_f (N,) [rad].
    """
    t = np.arange(int(round(t_end / dt)) + 1) * dt
    delta = steering_signal(t)
    f = fault_signal(t, t_fault, **(fault_kw or {}))
    F = uncertainty_signal(t, seed)
    X = simulate_truth(model, x0, delta, f, F, dt, pacejka=pacejka)
    y = X @ model.C.T + f[:, None] * model.F_s[:, 0][None, :]
    if noise:
        rng = np.random.default_rng(seed + 1)
        y = y + rng.standard_normal(y.shape) @ model.D_w.T
    af = slip_front(model, X, delta, f)
    h = model.tyres.memberships(af)
    hdot = np.gradient(h, dt, axis=0)
    return {"t": t, "delta": delta, "f": f, "F": F, "X": X, "y": y, "h": h, "hdot": hdot,
            "alpha_f": af, "dt": dt, "t_fault": t_fault}


def evaluate(gains: UIOGains, sc: dict, model: UncertainLateralTS, premise: str = "estimated",
             X0_hat=None) -> dict:
    """Run the UIO on a scenario and compute the paper's error metrics.

    ``premise="estimated"``: memberships of the observer's own slip-angle estimate
    (:class:`uio.UIObserver`; reads only ``sc["delta"], sc["y"], sc["dt"]``);
    ``"true"``: the scenario's true memberships ``sc["h"]`` (comparison only: they contain
    the true slip angle and fault). Returns the observer's ``run`` (a
    :class:`~vehicle_observers.observers.uio.UIOTrajectory`), Xhat (N, 3), h_used (N, 2) and
    rmse_vy, rmse_r,
    rmse_f after the fault appears (SI units), rmse before it, the fault-estimation delay
    (10 % band; also on the 20 ms moving mean of the error) and the peak |error| per state
    in the 0.5 s after the fault appears.
    """
    delta, y, dt = sc["delta"], sc["y"], sc["dt"]
    t = np.arange(len(delta)) * dt
    if premise == "estimated":
        run = uio.UIObserver(gains, model, dt).run(t, delta, y, X0_hat)
    elif premise == "true":
        u = np.column_stack([delta, sc["h"]])
        run = uio.UIObserver(gains, model, dt, premise="measured").run(t, u, y, X0_hat)
    else:
        raise ValueError(f"premise must be 'estimated' or 'true', got {premise!r}")
    return estimate_metrics(run.x, sc) | {"h_used": run.h, "run": run}


def estimate_metrics(Xh, sc: dict) -> dict:
    """Metrics of :func:`evaluate` for any estimate ``Xh`` (N, 3) = ``[v_y, r, f]`` (SI) of a
    scenario ``sc`` of :func:`make_scenario` (also used for the EKF/UKF baseline,
    :mod:`vehicle_observers.baselines.uio_ekf`)."""
    Xh = np.asarray(Xh, dtype=float)
    if Xh.shape != (len(sc["t"]), 3):
        raise ValueError(f"Xh must be ({len(sc['t'])}, 3) = [v_y, r, f], got {Xh.shape}")
    t, tf = sc["t"], sc["t_fault"]
    after = t >= tf
    before = (t < tf) & (t >= 1.0)
    if not before.any() or not after.any():
        raise ValueError(
            f"metric windows need samples in [1 s, t_fault) and in [t_fault, t_end]: got "
            f"t_fault = {tf} s on t in [{t[0]}, {t[-1]}] s (the 'before' window skips the "
            f"first second of convergence, so t_fault must exceed 1 s)")
    ref = np.column_stack([sc["X"], sc["f"]])
    err = Xh - ref
    out = {"Xhat": Xh, "err": err}
    for k, nm in enumerate(("vy", "r", "f")):
        out[f"rmse_{nm}"] = rmse(Xh[:, k], ref[:, k], after)
        out[f"rmse_{nm}_before"] = rmse(Xh[:, k], ref[:, k], before)
    out["fault_delay"] = fault_delay(t, Xh[:, 2], sc["f"], tf)
    out["fault_delay_smoothed"] = fault_delay(t, Xh[:, 2], sc["f"], tf,
                                              window=max(1, int(round(0.02 / sc["dt"]))))
    onset = (t >= tf) & (t <= tf + 0.5)
    out["peak_err_onset"] = np.abs(err[onset]).max(axis=0)
    return out


def evaluate_filter(model: UncertainLateralTS, sc: dict, h="measured", kind: str = "ekf",
                    **kw) -> dict:
    """Run :func:`~vehicle_observers.baselines.uio_ekf.run_filter` on a scenario of
    :func:`make_scenario` and compute the same metrics as :func:`evaluate` (``rmse_vy``,
    ``rmse_r``, ``rmse_f`` after the fault, ``fault_delay``...) plus ``run`` (the
    :class:`~vehicle_observers.baselines.ekf_observer.EKFTrajectory`, with ``us_per_step``).

    ``h='measured'``: the scenario's true memberships (comparison only: they contain the
    true slip angle and fault); ``None`` or ``'estimated'``: premises from the filter's own
    estimate. Other keywords go to ``run_filter``.
    """
    hh = sc["h"] if isinstance(h, str) and h == "measured" else h
    run = ub.run_filter(model, sc["delta"], sc["y"], sc["dt"], hh, kind, **kw)
    out = estimate_metrics(run.x, sc)
    out["run"] = run
    return out
