"""Identification of tyre parameters from measured channels only.

The friction coefficient of a log's Pacejka tyres is identified by matching the *measured
yaw rate* (an ordinary sensor channel), never the reference lateral velocity, so the
reference stays an independent check and the same procedure applies to any car's log:

    mu* = argmin_mu  RMS( r_model(mu; delta, v_x) - r_measured ),   mu in [mu_lo, mu_hi]

with ``r_model`` the open-loop simulation of the yaw-drift model (1)-(3) of Yacine 2015
driven by the measured steering and speed. The slope at zero slip (``B C D``) is kept at
the given cornering stiffness, so ``mu`` only moves the saturation (``D = mu F_z``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from vehicle_observers.data.logs import DriveLog
from vehicle_observers.models.lateral import LateralParams, simulate_s1
from vehicle_observers.models.tires import LinearTire, Pacejka


def pacejka_axle(C_alpha: float, Fz: float, mu: float, C: float = 1.3, E: float = 0.0):
    """Per-axle Pacejka tyre with slope ``C_alpha`` [N/rad] at zero slip and peak ``mu Fz`` [N]."""
    D = mu * Fz
    return Pacejka(B=C_alpha / (C * D), C=C, D=D, E=E)


def with_friction(p: LateralParams, mu: float, Fz_f: float, Fz_r: float, C: float = 1.3):
    """Copy of ``p`` whose tyres keep their zero-slip slope and have peak ``mu F_z``."""
    return replace(p, tire_f=pacejka_axle(p.tire_f.cornering_stiffness, Fz_f, mu, C),
                   tire_r=pacejka_axle(p.tire_r.cornering_stiffness, Fz_r, mu, C))


def static_axle_loads(p: LateralParams, g: float = 9.81) -> tuple[float, float]:
    L = p.a_f + p.a_r
    return p.m * g * p.a_r / L, p.m * g * p.a_f / L


def yaw_rate_rms(p: LateralParams, log: DriveLog, delta=None, substeps: int = 10) -> float:
    """RMS yaw-rate error [rad/s] of the open-loop model (1)-(3); inf if it diverges."""
    delta = log.delta if delta is None else delta
    X = simulate_s1([0.0, log.yaw_rate[0]], delta, log.vx, log.dt, p, exact=True,
                    relaxation=False, substeps=substeps)
    e = X[:, 1] - log.yaw_rate
    val = float(np.sqrt(np.mean(e**2)))
    return val if np.isfinite(val) and np.abs(X[:, 0]).max() < 50 else np.inf


def identify_friction(p: LateralParams, log: DriveLog, delta=None, bounds=(1.0, 3.0),
                      substeps: int = 10) -> tuple[float, LateralParams, float]:
    """Identify ``mu`` from the measured yaw rate (bounded Brent search).

    Returns ``(mu, params_with_mu, yaw_rate_rms)``. The search is a bounded scalar
    minimisation; a diverging simulation (spin) scores ``inf`` -- a large finite penalty is
    used instead so the bracket search stays well defined.
    """
    Fz_f, Fz_r = static_axle_loads(p)

    def cost(mu):
        c = yaw_rate_rms(with_friction(p, mu, Fz_f, Fz_r), log, delta, substeps)
        return c if np.isfinite(c) else 1e3

    from scipy.optimize import minimize_scalar

    res = minimize_scalar(cost, bounds=bounds, method="bounded", options={"xatol": 1e-3})
    mu = float(res.x)
    return mu, with_friction(p, mu, Fz_f, Fz_r), float(res.fun)


# ------------------------------------------------------------------ any car, from a log ----
# Cornering stiffness per axle (and the friction peak when the log reaches the nonlinear
# range) from the measured channels only: steering, speed, yaw rate, lateral acceleration.
# Output-error fit of the single-track model (1) with steady tyre forces (no relaxation):
#
#   v_y' = (F_f + F_r)/m - v_x r,   r' = (l_f F_f - l_r F_r)/I_z,   a_y = (F_f + F_r)/m,
#   F_f = C_f alpha_f (linear) or Pacejka(B C D = C_f, D = mu F_zf, C = 1.3, E = 0), same rear,
#
# simulated open loop from the measured steering and speed (v_y(0) = 0, r(0) measured; the
# first ``t_skip`` seconds are left out of the residual). Residuals are scaled by each
# channel's white-noise std estimated from the data (:func:`white_noise_std`). Parameters are
# fitted in logarithms; the covariance is ``s^2 tau (J^T J)^-1`` with ``s^2`` the residual
# variance per degree of freedom and ``tau`` the integrated autocorrelation time of the
# residuals (model mismatch makes them coloured; white-residual intervals would be too
# narrow). 95 % intervals are ``exp(theta +- 1.96 sigma)``.

Z95 = 1.959963984540054
DEFAULT_MAX_REL_CI = 0.25   # a parameter is "identified" if its 95 % CI half-width < 25 %
MAX_CORR = 0.995            # |correlation| above this: only a combination is determined
NONLINEAR_AY = 0.5 * 9.81   # m/s^2: mu is fitted only if max|a_y| reaches 0.5 g
#: default start of the stiffness fit: C = START_COEFF * static axle load [1/rad] per axle (a
#: neutral-steer car, stable at every speed; a fixed start such as 8e4 N/rad on both axles is
#: an oversteering car for a rearward CG and its open-loop run spins above ~40 m/s)
START_COEFF = 16.0
#: a fit whose open-loop model leaves more than this share of a channel's variance unexplained
#: (RMS residual / channel std) does not follow the log: it is refused, whatever its intervals
MAX_UNEXPLAINED = 0.7


def white_noise_std(x) -> float:
    """Std of the white part of a channel from its second differences:
    ``1.4826 MAD(x_{k+1} - 2 x_k + x_{k-1}) / sqrt(6)`` (robust; a signal's own curvature
    enters as ``x'' dt^2`` only, negligible at the log rates used here)."""
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or len(x) < 5:
        raise ValueError(f"white_noise_std needs a 1-D channel of >= 5 samples, got shape "
                         f"{x.shape}")
    d2 = x[2:] - 2 * x[1:-1] + x[:-2]
    return float(1.482602218505602 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def _iact(e: np.ndarray, max_lag: int = 200) -> float:
    """Integrated autocorrelation time ``1 + 2 sum rho_k`` (sum stopped at the first
    ``rho_k < 0.05``), of a residual channel."""
    e = e - e.mean()
    v = float(e @ e)
    if v <= 0:
        return 1.0
    tau = 1.0
    for k in range(1, min(max_lag, len(e) // 4)):
        rho = float(e[k:] @ e[:-k]) / v
        if rho < 0.05:
            break
        tau += 2 * rho
    return tau


@dataclass
class StiffnessFit:
    """Result of :func:`identify_stiffness`.

    ``names`` of the fitted parameters (``C_f``, ``C_r`` [N/rad], ``mu`` [-]); ``value``,
    ``ci_lo``, ``ci_hi`` 95 % intervals; ``rel_ci`` half-widths relative to the value;
    ``corr`` correlation matrix (log parameters); ``singular_values`` of the scaled Jacobian;
    ``identifiable`` True when every parameter's ``rel_ci`` is below the threshold;
    ``combination`` (when not): the best-determined combination ``prod p_i^{w_i}`` of the
    tyre parameters (accelerometer gain marginalised out; its weight 0) as
    ``(weights, value, rel_ci)``; ``channels`` used; ``noise_std`` per channel;
    ``rms_residual`` per channel (same units as the channel); ``nonlinear`` whether ``mu``
    was identified; ``message`` a one-paragraph plain statement; ``ay_gain`` the fitted
    accelerometer gain (1.0 when not fitted; also in ``names`` then)."""

    names: tuple
    value: np.ndarray
    ci_lo: np.ndarray
    ci_hi: np.ndarray
    rel_ci: np.ndarray
    corr: np.ndarray
    singular_values: np.ndarray
    identifiable: bool
    combination: tuple | None
    channels: tuple
    noise_std: dict
    rms_residual: dict
    nonlinear: bool
    message: str
    params: LateralParams | None = None
    ay_gain: float = 1.0

    def get(self, name: str) -> float:
        return float(self.value[self.names.index(name)])


#: search interval of the accelerometer gain g_ay of :func:`identify_stiffness`
AY_GAIN_BOUNDS = (0.7, 1.5)


def _model_params(base: LateralParams, th: np.ndarray, nonlinear: bool,
                  Fz: tuple[float, float]) -> LateralParams:
    Cf, Cr = float(np.exp(th[0])), float(np.exp(th[1]))
    if nonlinear:
        mu = float(np.exp(th[2]))
        return replace(base, tire_f=pacejka_axle(Cf, Fz[0], mu), tire_r=pacejka_axle(Cr, Fz[1], mu))
    return replace(base, tire_f=LinearTire(Cf), tire_r=LinearTire(Cr))


def open_loop_outputs(p: LateralParams, log: DriveLog, substeps: int = 4):
    """Yaw rate [rad/s] and lateral acceleration ``(F_f + F_r)/m`` [m/s^2], each (N,), of the
    single-track model (1) with steady tyre forces, simulated open loop from the log's
    measured steering and speed (``v_y(0) = 0``, ``r(0)`` measured; fixed step ``log.dt``)."""
    X = simulate_s1([0.0, float(log.yaw_rate[0])], log.delta, log.vx, log.dt, p, exact=False,
                    relaxation=False, substeps=substeps)
    return X[:, 1], (X[:, 2] + X[:, 3]) / p.m


_outputs = open_loop_outputs


def unexplained_share(model, measured) -> float:
    """RMS of ``model - measured`` over the standard deviation of ``measured``: 0 for a
    perfect model, about 1 for one that explains nothing (inf for a zero-variance channel or a
    non-finite model). Compared with :data:`MAX_UNEXPLAINED` by :func:`identify_stiffness`
    and by :mod:`vehicle_observers.estimation.consistency`."""
    model, measured = np.asarray(model, float), np.asarray(measured, float)
    sd = float(np.std(measured))
    rms = float(np.sqrt(np.mean((model - measured) ** 2)))
    return rms / sd if sd > 0 and np.isfinite(rms) else float("inf")


def identify_stiffness(log: DriveLog, m: float, I_z: float, a_f: float, a_r: float,
                       channels=("yaw_rate", "ay"), nonlinear: str | bool = "auto",
                       t_skip: float = 1.0, max_rel_ci: float = DEFAULT_MAX_REL_CI,
                       max_corr: float = MAX_CORR,
                       start=None, substeps: int = 4,
                       ay_gain: bool = True) -> StiffnessFit:
    """Identify ``C_f, C_r`` [N/rad] (and ``mu`` when the log reaches the nonlinear range)
    from ``channels`` (``"yaw_rate"`` and/or ``"ay"``; never the reference ``v_y``).

    ``m`` [kg], ``I_z`` [kg m^2], ``a_f``, ``a_r`` [m] are given (not identified).
    ``start``: ``(C_f, C_r, mu)`` of the search (``None``: :data:`START_COEFF` times the static
    axle loads, ``mu = 1``). A fit whose open-loop model does not follow the log (RMS
    residual above :data:`MAX_UNEXPLAINED` times the channel's standard deviation, e.g. a
    run that spins) or whose Jacobian is singular is reported not identifiable, never as a
    result.
    ``nonlinear``: ``"auto"`` fits ``mu`` only if the log reaches the nonlinear range of any
    dry-road tyre, ``max|a_y| >= 0.5 g`` (below it a fitted ``mu`` only absorbs model
    mismatch: on the plant's 0.4 g slalom it came out 0.86 for a 1.05 tyre), and keeps it
    only if its interval is below ``max_rel_ci``; ``True`` always fits it; ``False`` fits
    linear tyres.
    ``ay_gain`` (with the ``"ay"`` channel): also fit the accelerometer's gain ``g_ay``,
    ``a_y,meas = g_ay (F_f + F_r)/m``. An accelerometer fixed to the body reads the specific
    force along the rolled lateral axis, ``a_y cos(phi) + g sin(phi_out)``, and the body rolls
    outward in proportion to ``a_y`` (roll gradient ``k_phi`` [rad per m/s^2]), so
    ``g_ay ~ 1 + g k_phi`` (1.16 for a car rolling 9 deg per g); fitting the stiffness with
    ``g_ay = 1`` on such a sensor puts the roll into the tyres (C_f +11 % on the plant's sine
    with dwell). The yaw-rate channel fixes the stiffness, a_y then fixes ``g_ay``.
    Identifiable means every 95 % interval below ``max_rel_ci`` *and* every pairwise
    |correlation| below ``max_corr``: near-collinear parameters (quasi-steady cornering, where
    only the understeer gradient is seen) are biased by small model mismatch far beyond their
    statistical interval (on the plant's ramp steer: C_f 38 % low with a "+-10 %" interval).
    The fit never raises for poor data: it reports ``identifiable = False``, the
    best-determined combination and a message; callers must refuse to use the values then.
    """
    from scipy.optimize import least_squares

    for c in channels:
        if c not in ("yaw_rate", "ay"):
            raise ValueError(f"channel {c!r} not usable for identification (expected "
                             "'yaw_rate' and/or 'ay'; the reference v_y is never used)")
    if "ay" in channels:
        log.require("ay_mps2", purpose="identification from lateral acceleration")
    if not channels:
        raise ValueError("identification needs at least one of 'yaw_rate', 'ay'")
    for k, v in (("m", m), ("I_z", I_z), ("a_f", a_f), ("a_r", a_r)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{k} must be a finite number > 0, got {v}")
    base = LateralParams(m=m, I_z=I_z, a_f=a_f, a_r=a_r, tire_f=LinearTire(1.0),
                         tire_r=LinearTire(1.0), name="identified")
    Fz = static_axle_loads(base)
    if start is None:
        start = (START_COEFF * Fz[0], START_COEFF * Fz[1], 1.0)
    meas = {"yaw_rate": log.yaw_rate, "ay": log.ay}
    sd = {c: max(white_noise_std(meas[c]), 1e-6) for c in channels}
    sel = log.t >= log.t[0] + t_skip

    def resid(th, nl):
        try:
            r, ay = _outputs(_model_params(base, th, nl, Fz), log, substeps)
        except (ValueError, FloatingPointError):
            return np.full(int(sel.sum()) * len(channels), 1e3)
        out = {"yaw_rate": r, "ay": ay * (np.exp(th[-1]) if gain else 1.0)}
        e = np.concatenate([(out[c][sel] - meas[c][sel]) / sd[c] for c in channels])
        return np.where(np.isfinite(e), np.clip(e, -1e4, 1e4), 1e4)

    gain = bool(ay_gain) and "ay" in channels

    def fit(nl):
        k = 3 if nl else 2
        th0 = np.log(np.r_[np.asarray(start[:k], dtype=float), [1.0] if gain else []])
        lb = np.log(np.r_[[5e3, 5e3, 0.2][:k], [AY_GAIN_BOUNDS[0]] if gain else []])
        ub = np.log(np.r_[[2e6, 2e6, 3.0][:k], [AY_GAIN_BOUNDS[1]] if gain else []])
        res = least_squares(lambda th: resid(th, nl), th0, bounds=(lb, ub), x_scale=1.0,
                            diff_step=1e-4, max_nfev=200)
        e = res.fun
        J = res.jac
        n, p = len(e), len(th0)
        s2 = float(e @ e) / max(n - p, 1)
        blocks = np.split(e, len(channels))
        tau = max(_iact(b) for b in blocks)
        JtJ = J.T @ J
        cov = s2 * tau * np.linalg.pinv(JtJ)
        return res.x, cov, J * np.sqrt(1.0 / (s2 * tau)), res

    ay_peak = float(np.abs(log.ay if log.ay is not None else log.vx * log.yaw_rate).max())
    nl = bool(nonlinear) if nonlinear != "auto" else ay_peak >= NONLINEAR_AY
    th, cov, Js, _ = fit(nl)
    sig = np.sqrt(np.maximum(np.diag(cov), 0))
    nonlin_kept = nl
    if nonlinear == "auto" and nl and Z95 * sig[2] > max_rel_ci:
        nonlin_kept = False
        th, cov, Js, _ = fit(False)
        sig = np.sqrt(np.maximum(np.diag(cov), 0))
    names = ("C_f", "C_r", "mu")[: len(th) - gain] + (("ay_gain",) if gain else ())
    g_ay = float(np.exp(th[-1])) if gain else 1.0
    val = np.exp(th)
    sig = np.minimum(sig, 300.0 / Z95)      # an interval of e^300 is infinite for every purpose
    rel = np.exp(Z95 * sig) - 1.0
    d = np.where(sig > 0, sig, 1.0)
    corr = cov / np.outer(d, d)
    U, S, Vt = np.linalg.svd(Js, full_matrices=False)
    off = np.abs(corr[~np.eye(len(th), dtype=bool)])
    ident = bool(np.all(rel < max_rel_ci) and np.all(off < max_corr))
    comb = None
    p = _model_params(base, th, nonlin_kept, Fz)
    r_mod, ay_mod = _outputs(p, log, substeps)
    ay_mod = g_ay * ay_mod
    mod = {"yaw_rate": r_mod, "ay": ay_mod}
    rms = {c: float(np.sqrt(np.mean((mod[c] - meas[c])[sel] ** 2))) for c in channels}
    spread = {c: float(np.std(meas[c][sel])) for c in channels}
    poor = [c for c in channels
            if not (unexplained_share(mod[c][sel], meas[c][sel]) <= MAX_UNEXPLAINED)]
    singular = not (S.size and S.min() > 1e-9 * S.max())
    if poor or singular:
        ident = False
        why = ("the open-loop model does not follow the log: RMS residual "
               + ", ".join(f"{c} {rms[c]:.3g} (channel std {spread[c]:.3g})" for c in poor)
               + f" above {MAX_UNEXPLAINED:g} x the channel std" if poor else
               "the fit's Jacobian is singular (the channels do not move with the parameters)")
        msg = (f"NOT identified from {'+'.join(channels)}: {why}; the search ended at "
               + ", ".join(f"{n} = {v:.4g}" for n, v in zip(names, val))
               + ". Try a log segment without spins and standstill, other --channels, or a "
               "vehicle file from a data sheet; no vehicle file is written from this fit.")
        return StiffnessFit(names, val, np.exp(th - Z95 * sig), np.exp(th + Z95 * sig), rel,
                            corr, S, False, None, tuple(channels), sd, rms, nonlin_kept, msg,
                            None, g_ay)
    if not ident:
        # best-determined combination of the tyre parameters (the accelerometer gain
        # marginalised out): the least-variance direction of their covariance block,
        # weights scaled to max |w| = 1 with the last one positive
        k = len(th) - gain
        ev, V = np.linalg.eigh(cov[:k, :k])
        w = V[:, 0] / np.abs(V[:, 0]).max()
        w = w if w[-1] >= 0 else -w
        cval = float(np.exp(w @ th[:k]))
        csig = float(np.sqrt(max(float(w @ cov[:k, :k] @ w), 0.0)))
        w = np.r_[w, np.zeros(len(th) - k)]
        comb = (w, cval, float(np.exp(Z95 * csig) - 1.0))
        txt = " * ".join(f"{n}^{wi:+.2f}" for n, wi in zip(names, w) if abs(wi) >= 0.005)
        msg = (f"NOT identifiable from {'+'.join(channels)}: 95 % intervals "
               + ", ".join(f"{n} +-{100 * r:.0f} %" for n, r in zip(names, rel))
               + f" (threshold {100 * max_rel_ci:.0f} %), correlation C_f-C_r "
               f"{corr[0, 1]:+.4f} (threshold {max_corr:g}); only the combination {txt} = {cval:.4g} "
               f"(+-{100 * comb[2]:.1f} %) is determined. Needs a transient manoeuvre (steering "
               "steps, slalom)" + ("" if "ay" in channels else " or the lateral acceleration")
               + "; no vehicle file is written from this fit.")
    else:
        msg = ("identified from " + "+".join(channels) + ": "
               + ", ".join(f"{n} = {v:.4g} [{lo:.4g}, {hi:.4g}]"
                           for n, v, lo, hi in zip(names, val, val / (1 + rel),
                                                   val * (1 + rel))))
        if not nonlin_kept:
            msg += (f"; mu not identified (max|a_y| = {ay_peak:.3g} m/s^2"
                    + (" < 0.5 g: linear range" if ay_peak < NONLINEAR_AY else
                       ", but mu's interval exceeds the threshold") + "): linear tyres")
    return StiffnessFit(names, val, np.exp(th - Z95 * sig), np.exp(th + Z95 * sig), rel, corr,
                        S, ident, comb, tuple(channels), sd, rms, nonlin_kept, msg,
                        p if ident else None, g_ay)


def vehicle_toml(fit: StiffnessFit, name: str, vx_range: tuple[float, float],
                 source: str = "") -> str:
    """Vehicle-file text (format of :mod:`vehicle_observers.models.vehicle`) from an
    identified fit. ``[uncertainty] stiffness_rel`` is the larger 95 % interval half-width
    of ``C_f, C_r`` (at least 0.05); ``vx_min``/``vx_max`` the log's speed range.
    Raises ValueError when the fit is not identifiable (refuses to write guesses)."""
    if not fit.identifiable or fit.params is None:
        raise ValueError(f"refusing to write a vehicle file: {fit.message}")
    p = fit.params
    rel = max(float(fit.rel_ci[0]), float(fit.rel_ci[1]), 0.05)
    if rel >= 1:
        raise ValueError(f"stiffness interval +-{100 * rel:.0f} % too wide for a vehicle file")
    lines = [f"# Identified by 'python -m vehicle_observers identify' from {source or 'a log'}",
             f"# {fit.message}",
             f"name = {name!r}".replace("'", '"'),
             f"m = {p.m!r}", f"I_z = {p.I_z!r}", f"a_f = {p.a_f!r}", f"a_r = {p.a_r!r}", ""]
    for sect, t in (("tire_front", p.tire_f), ("tire_rear", p.tire_r)):
        lines.append(f"[{sect}]")
        if isinstance(t, LinearTire):
            lines += ['model = "linear"', f"cornering_stiffness = {t.C_alpha!r}"]
        else:
            lines += ['model = "pacejka"', f"B = {t.B!r}", f"C = {t.C!r}", f"D = {t.D!r}",
                      f"E = {t.E!r}"]
        lines.append("")
    lines += ["[uncertainty]", f"stiffness_rel = {rel:.4f}",
              f"vx_min = {max(vx_range[0], 0.1):.4g}", f"vx_max = {vx_range[1]:.4g}",
              "slip_max_deg = 8.0", ""]
    return "\n".join(lines)
